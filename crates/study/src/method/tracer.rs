//! The distribution ray tracer's settings: beyond the A level's samples per pixel, only
//! whether camera samples are jittered within the pixel (`pixel_jitter`, default true); its
//! cost knob is the samples per pixel themselves.

use super::{CurveInput, KeyError, MethodSettings, MethodTable, SweepSetting, sweep_levels};
use crate::design::Preset;

/// The tracer's settings.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TracerSettings {
    /// `pixel_jitter`: camera samples at random positions in the pixel (the box filter) or,
    /// when false, all through the pixel's centre (aliased edges, as a rasterizer's).
    pub pixel_jitter: Option<bool>,
}

impl TracerSettings {
    /// Whether camera samples are jittered within the pixel (default true).
    pub fn pixel_jitter(&self) -> bool {
        self.pixel_jitter.unwrap_or(true)
    }
}

impl MethodSettings for TracerSettings {
    const KEYS: &'static [&'static str] = &["pixel_jitter"];
    const CURVE_INPUT: CurveInput = CurveInput::Ignored;

    fn from_table(t: &MethodTable) -> Self {
        TracerSettings { pixel_jitter: t.pixel_jitter }
    }

    fn write_table(&self, t: &mut MethodTable) {
        t.pixel_jitter = self.pixel_jitter;
    }

    fn check(&self) -> Result<(), KeyError> {
        Ok(())
    }

    fn samples_cost(&self, spp: u32) -> u64 {
        u64::from(spp.max(1))
    }

    /// Powers of two up to `max_spp` and the preset's levels.
    fn sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
        let mut spp: Vec<u32> = std::iter::successors(Some(1u32), |s| s.checked_mul(2))
            .take_while(|&s| s <= max_spp)
            .chain(sweep_levels(preset, max_spp))
            .collect();
        spp.sort_unstable();
        spp.dedup();
        spp.into_iter()
            .map(|s| SweepSetting {
                spec: super::MethodSpec::Tracer(TracerSettings::default()),
                knob: "spp",
                value: s,
                input_spp: s,
                antialias: None,
            })
            .collect()
    }

    fn curve_label(knob: &str, _: u32) -> String {
        match knob {
            super::antialias::SWEEP_KNOB_SEARCH_DISTANCE => {
                "tracer at pixel centres + MLAA (search distance)".to_owned()
            }
            super::antialias::SWEEP_KNOB_THRESHOLD => "tracer at pixel centres + MLAA (threshold)".to_owned(),
            _ => "tracer (spp)".to_owned(),
        }
    }

    fn work_units(knob: &str, value: u32, input_spp: u32) -> u64 {
        // MLAA's knobs: the samples traced, whatever the filter's setting.
        if knob == "spp" { u64::from(value) } else { u64::from(input_spp) }
    }
}
