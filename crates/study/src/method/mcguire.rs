//! McGuire et al. 2012's reconstruction filter: its settings with the paper's defaults
//! (S = 15 taps, tile k = 20), ranges and cost; its cost knob is the taps at each A level.

use super::{
    CurveInput, FILTER_COUNT_RANGE, KeyError, MethodSettings, MethodTable, SweepSetting, check_count, check_real,
};
use crate::design::Preset;

/// Taps the cost sweep measures the post-process filters at.
pub const SWEEP_TAPS: [u32; 4] = [3, 7, 15, 35];

/// Camera samples per pixel a post-process filter costs: the traced centre instant at `spp`
/// plus about one traced sample's work per 8 taps gathered.
pub(crate) fn filter_samples_cost(spp: u32, taps: u32) -> u64 {
    u64::from(spp.max(1)) + u64::from(taps).div_ceil(8)
}

/// A filter's cost sweep: [`SWEEP_TAPS`] at each of the preset's A levels.
pub(crate) fn filter_sweep(
    preset: &Preset,
    max_spp: u32,
    spec: impl Fn(u32) -> super::MethodSpec,
) -> Vec<SweepSetting> {
    super::sweep_levels(preset, max_spp)
        .into_iter()
        .flat_map(|level| SWEEP_TAPS.iter().map(move |&taps| (level, taps)))
        .map(|(level, taps)| SweepSetting {
            spec: spec(taps),
            knob: "taps",
            value: taps,
            input_spp: level,
            antialias: None,
        })
        .collect()
}

/// `[method] kind = "mcguire"`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct McGuireSettings {
    /// Taps (the paper's S) gathered per pixel along the dominant velocity.
    pub taps: Option<u32>,
    /// Tile size k in pixels, the largest blur radius.
    pub tile: Option<u32>,
    /// The soft depth comparison's extent, metres.
    pub soft_z_extent: Option<f64>,
    /// The floor in the sphere's shadow moves with the sphere in the G-buffer (off: the
    /// floor is static, as a velocity buffer holds it).
    pub shadow_motion: Option<bool>,
}

defaults!(McGuireSettings {
    /// Taps, the paper's 15 by default.
    taps: u32 = 15,
    /// Tile size, the paper's suggested 20 pixels by default.
    tile: u32 = 20,
    /// Soft depth extent, 0.1 m by default (metre-scale scenes; the paper leaves it to the
    /// scene).
    soft_z_extent: f64 = 0.1,
    /// The shadow's motion on the floor, off by default.
    shadow_motion: bool = false,
});

impl MethodSettings for McGuireSettings {
    const KEYS: &'static [&'static str] = &["taps", "tile", "soft_z_extent", "shadow_motion"];
    const CURVE_INPUT: CurveInput = CurveInput::Highest;

    fn from_table(t: &MethodTable) -> Self {
        McGuireSettings { taps: t.taps, tile: t.tile, soft_z_extent: t.soft_z_extent, shadow_motion: t.shadow_motion }
    }

    fn write_table(&self, t: &mut MethodTable) {
        (t.taps, t.tile, t.soft_z_extent, t.shadow_motion) =
            (self.taps, self.tile, self.soft_z_extent, self.shadow_motion);
    }

    fn check(&self) -> Result<(), KeyError> {
        check_count("taps", self.taps, FILTER_COUNT_RANGE)?;
        check_count("tile", self.tile, FILTER_COUNT_RANGE)?;
        check_real("soft_z_extent", self.soft_z_extent, 1e-6, 1e3)
    }

    fn samples_cost(&self, spp: u32) -> u64 {
        filter_samples_cost(spp, self.taps())
    }

    fn sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
        filter_sweep(preset, max_spp, |taps| {
            super::MethodSpec::Mcguire(McGuireSettings { taps: Some(taps), ..McGuireSettings::default() })
        })
    }

    fn curve_label(_: &str, input_spp: u32) -> String {
        format!("mcguire (taps, {input_spp} spp in)")
    }
}
