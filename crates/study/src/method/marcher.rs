//! The participating-media ray marcher of the thesis's Part I (chapter 2) as a method: the
//! sphere, the floor and the sky come from the tracer at the A level's samples, and the
//! medium of the design's `[medium]` is marched along each pixel's centre ray up to the
//! first surface and composited over them. Its settings: the lighting model of the thesis's
//! figure 2.3, the step in voxels, the lights of the environment's constellation, the two
//! accelerations (which change the work, never the image) and the sub-frames the medium is
//! averaged over while the shutter is open. Its cost knobs are the lighting model, the
//! lights (of the two models that have lights) and the step.

use serde::{Deserialize, Serialize};

use super::{CurveInput, FrameWork, KeyError, MethodSettings, MethodTable, SweepSetting, check_count, check_real};
use crate::design::Preset;

/// The lighting models of the thesis's figure 2.3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MarchLighting {
    /// Density as opacity over a constant grey (no lights).
    AlphaCompositing,
    /// Single scattering of every light at full strength (no shadows).
    Primary,
    /// Single scattering with a shadow ray to each light (self-shadowing, and the smoke's
    /// shadow on the surfaces).
    #[default]
    PrimaryAndShadow,
}

impl MarchLighting {
    /// Every model, simplest first.
    pub const ALL: [MarchLighting; 3] =
        [MarchLighting::AlphaCompositing, MarchLighting::Primary, MarchLighting::PrimaryAndShadow];

    /// The name a design writes.
    pub fn name(self) -> &'static str {
        match self {
            MarchLighting::AlphaCompositing => "alpha-compositing",
            MarchLighting::Primary => "primary",
            MarchLighting::PrimaryAndShadow => "primary-and-shadow",
        }
    }
}

/// Most lights of a constellation.
pub const MAX_LIGHTS: u32 = 256;
/// Steps (in voxels) a design may write: from a twentieth of a voxel to 16 voxels.
pub const STEP_RANGE: (f64, f64) = (0.05, 16.0);
/// Lights the cost sweep measures.
pub const SWEEP_LIGHTS: [u32; 6] = [1, 2, 4, 8, 16, 32];
/// The step knob of the cost sweep: slices per 4 voxels (a step of 4 / value voxels).
pub const SWEEP_SLICES_PER_4_VOXELS: [u32; 5] = [1, 2, 4, 8, 16];
/// The cost sweep's knob for the step.
pub const SWEEP_KNOB_STEP: &str = "slices_per_4_voxels";
/// The cost sweep's knob for the lighting model: value `i + 1` is [`MarchLighting::ALL`]`[i]`.
pub const SWEEP_KNOB_LIGHTING: &str = "lighting";
/// The cost sweep's knob for the lights of the model without shadow rays (knob `lights`
/// turns them in the full model).
pub const SWEEP_KNOB_PRIMARY_LIGHTS: &str = "primary_lights";

/// `[method] kind = "marcher"`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MarcherSettings {
    /// The lighting model.
    pub lighting: Option<MarchLighting>,
    /// Step along primary and shadow rays, in voxels (the shortest voxel edge).
    pub step: Option<f64>,
    /// Lights the environment is split into (median cut).
    pub lights: Option<u32>,
    /// March only pixels whose ray meets a non-empty voxel (the thesis's validity mask).
    pub validity_mask: Option<bool>,
    /// Skip empty space with the distance map.
    pub distance_map: Option<bool>,
    /// Instants the medium is marched at while the shutter is open (an accumulation buffer
    /// of the medium over the tracer's motion-blurred surfaces).
    pub sub_frames: Option<u32>,
}

defaults!(MarcherSettings {
    /// The lighting model, the thesis's full one (primary and shadow rays) by default.
    lighting: MarchLighting = MarchLighting::PrimaryAndShadow,
    /// The step, one voxel by default (the thesis: below half a voxel avoids aliasing, up
    /// to five voxels can do for smooth data).
    step: f64 = 1.0,
    /// Lights, 16 by default (the thesis used up to 20).
    lights: u32 = 16,
    /// The validity mask, on by default.
    validity_mask: bool = true,
    /// The distance map, on by default.
    distance_map: bool = true,
    /// Sub-frames, 4 by default.
    sub_frames: u32 = 4,
});

impl MethodSettings for MarcherSettings {
    const KEYS: &'static [&'static str] =
        &["lighting", "step", "lights", "validity_mask", "distance_map", "sub_frames"];
    const CURVE_INPUT: CurveInput = CurveInput::Each;

    fn from_table(t: &MethodTable) -> Self {
        MarcherSettings {
            lighting: t.lighting,
            step: t.step,
            lights: t.lights,
            validity_mask: t.validity_mask,
            distance_map: t.distance_map,
            sub_frames: t.sub_frames,
        }
    }

    fn write_table(&self, t: &mut MethodTable) {
        (t.lighting, t.step, t.lights, t.validity_mask, t.distance_map, t.sub_frames) =
            (self.lighting, self.step, self.lights, self.validity_mask, self.distance_map, self.sub_frames);
    }

    fn check(&self) -> Result<(), KeyError> {
        check_real("step", self.step, STEP_RANGE.0, STEP_RANGE.1)?;
        check_count("lights", self.lights, 1..=MAX_LIGHTS)?;
        check_count("sub_frames", self.sub_frames, 1..=256)
    }

    /// The tracer's samples for the surfaces, plus about one traced sample's work per
    /// sub-frame for the march (a march of a few hundred lookups per light).
    fn samples_cost(&self, spp: u32) -> u64 {
        u64::from(spp.max(1)) + u64::from(self.sub_frames())
    }

    fn frame_work(&self, spp: u32) -> FrameWork {
        FrameWork::samples(spp)
    }

    /// The three lighting models at the defaults, the lights of the primary-rays model, the
    /// lights of the full model, then its step; the surfaces at the preset's highest
    /// sampling level up to `max_spp`. The last (the finest step) is the most expensive.
    fn sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
        let input_spp = super::sweep_levels(preset, max_spp).last().copied().unwrap_or(max_spp.max(1));
        let setting = |knob: &'static str, value: u32, settings: MarcherSettings| SweepSetting {
            spec: super::MethodSpec::Marcher(settings),
            knob,
            value,
            input_spp,
            antialias: None,
        };
        let models = (1..).zip(MarchLighting::ALL).map(|(value, lighting)| {
            setting(SWEEP_KNOB_LIGHTING, value, MarcherSettings { lighting: Some(lighting), ..Default::default() })
        });
        let primary_lights = SWEEP_LIGHTS.iter().map(|&n| {
            let settings =
                MarcherSettings { lighting: Some(MarchLighting::Primary), lights: Some(n), ..Default::default() };
            setting(SWEEP_KNOB_PRIMARY_LIGHTS, n, settings)
        });
        let lights = SWEEP_LIGHTS
            .iter()
            .map(|&n| setting("lights", n, MarcherSettings { lights: Some(n), ..Default::default() }));
        let steps = SWEEP_SLICES_PER_4_VOXELS.iter().map(|&v| {
            setting(SWEEP_KNOB_STEP, v, MarcherSettings { step: Some(4.0 / f64::from(v)), ..Default::default() })
        });
        models.chain(primary_lights).chain(lights).chain(steps).collect()
    }

    /// Rays marched per pixel (the primary ray, and a shadow ray per light in the full
    /// model) times the slices per 4 voxels: the march's work, not the surfaces'.
    fn work_units(knob: &str, value: u32, _input_spp: u32) -> u64 {
        let defaults = MarcherSettings::default();
        let slices = (4.0 / defaults.step()).round() as u64;
        let full = 1 + u64::from(defaults.lights());
        match knob {
            SWEEP_KNOB_LIGHTING if value == 3 => full * slices,
            SWEEP_KNOB_LIGHTING | SWEEP_KNOB_PRIMARY_LIGHTS => slices,
            SWEEP_KNOB_STEP => full * u64::from(value),
            _ => (1 + u64::from(value)) * slices,
        }
    }

    fn curve_label(knob: &str, input_spp: u32) -> String {
        match knob {
            SWEEP_KNOB_LIGHTING => {
                format!("marcher (lighting: 1 alpha, 2 primary, 3 primary + shadow; {input_spp} spp surfaces)")
            }
            SWEEP_KNOB_PRIMARY_LIGHTS => format!("marcher (lights, primary rays only, {input_spp} spp surfaces)"),
            "lights" => format!("marcher (lights, {input_spp} spp surfaces)"),
            _ => format!("marcher (slices per 4 voxels, {input_spp} spp surfaces)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::MethodSpec;

    #[test]
    fn keys_round_trip_and_ranges_are_checked() {
        let written = "kind = \"marcher\"\nlighting = \"primary\"\nstep = 0.5\nlights = 8\nvalidity_mask = false\ndistance_map = false\nsub_frames = 2";
        let table: MethodTable = toml::from_str(written).unwrap();
        let spec = MethodSpec::from_table(&table).unwrap();
        let MethodSpec::Marcher(s) = &spec else { panic!("{spec:?}") };
        assert_eq!(s.lighting(), MarchLighting::Primary);
        assert_eq!(
            (s.step(), s.lights(), s.validity_mask(), s.distance_map(), s.sub_frames()),
            (0.5, 8, false, false, 2)
        );
        assert_eq!(spec.to_table(), table);
        for (bad, key) in [
            ("step = 0.0", "step"),
            ("lights = 0", "lights"),
            ("lights = 257", "lights"),
            ("sub_frames = 0", "sub_frames"),
        ] {
            let table: MethodTable = toml::from_str(&format!("kind = \"marcher\"\n{bad}")).unwrap();
            assert_eq!(MethodSpec::from_table(&table).unwrap_err().key, key, "{bad}");
        }
        assert!(toml::from_str::<MethodTable>("kind = \"marcher\"\nlighting = \"shadows\"").is_err());
        let table: MethodTable = toml::from_str("kind = \"tracer\"\nlights = 4").unwrap();
        assert_eq!(MethodSpec::from_table(&table).unwrap_err().message, "applies to marcher only, not to `tracer`");
    }

    #[test]
    fn the_sweep_turns_the_lights_then_the_step() {
        let preset = Preset {
            name: "test".into(),
            width: 8,
            height: 4,
            frames: 1,
            first_frame: 0,
            samples_per_pixel: vec![4, 16, 64],
        };
        let sweep = MarcherSettings::sweep(&preset, 32);
        assert!(sweep.iter().all(|s| s.input_spp == 16));
        let lights: Vec<u32> = sweep.iter().filter(|s| s.knob == "lights").map(|s| s.value).collect();
        assert_eq!(lights, SWEEP_LIGHTS);
        let steps: Vec<f64> = sweep
            .iter()
            .filter_map(|s| match &s.spec {
                MethodSpec::Marcher(m) if s.knob == SWEEP_KNOB_STEP => Some(m.step()),
                _ => None,
            })
            .collect();
        assert_eq!(steps, [4.0, 2.0, 1.0, 0.5, 0.25]);
        let models: Vec<(u32, MarchLighting)> = sweep
            .iter()
            .filter_map(|s| match &s.spec {
                MethodSpec::Marcher(m) if s.knob == SWEEP_KNOB_LIGHTING => Some((s.value, m.lighting())),
                _ => None,
            })
            .collect();
        assert_eq!(
            models,
            [(1, MarchLighting::AlphaCompositing), (2, MarchLighting::Primary), (3, MarchLighting::PrimaryAndShadow)]
        );
        let primary: Vec<(u32, u32, MarchLighting)> = sweep
            .iter()
            .filter_map(|s| match &s.spec {
                MethodSpec::Marcher(m) if s.knob == SWEEP_KNOB_PRIMARY_LIGHTS => {
                    Some((s.value, m.lights(), m.lighting()))
                }
                _ => None,
            })
            .collect();
        assert_eq!(primary, SWEEP_LIGHTS.map(|n| (n, n, MarchLighting::Primary)));
        let work = |knob, value| MarcherSettings::work_units(knob, value, 16);
        assert_eq!([work(SWEEP_KNOB_LIGHTING, 1), work(SWEEP_KNOB_LIGHTING, 3), work("lights", 4)], [4, 68, 20]);
        assert_eq!([work(SWEEP_KNOB_PRIMARY_LIGHTS, 32), work(SWEEP_KNOB_STEP, 16)], [4, 272]);
        // The finest step comes last: the cost sweep checks its reference against it first.
        assert_eq!((sweep.last().map(|s| s.knob), sweep.last().map(|s| s.value)), (Some(SWEEP_KNOB_STEP), Some(16)));
    }
}
