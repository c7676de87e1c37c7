//! The distribution ray tracer's settings: none beyond the A level's samples per pixel; its
//! cost knob is the samples per pixel themselves.

use super::{CurveInput, KeyError, MethodSettings, MethodTable, SweepSetting, sweep_levels};
use crate::design::Preset;

/// The tracer takes no settings of its own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TracerSettings;

impl MethodSettings for TracerSettings {
    const KEYS: &'static [&'static str] = &[];
    const CURVE_INPUT: CurveInput = CurveInput::Ignored;

    fn from_table(_: &MethodTable) -> Self {
        TracerSettings
    }

    fn write_table(&self, _: &mut MethodTable) {}

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
                spec: super::MethodSpec::Tracer(TracerSettings),
                knob: "spp",
                value: s,
                input_spp: s,
            })
            .collect()
    }

    fn curve_label(_: &str, _: u32) -> String {
        "tracer (spp)".to_owned()
    }
}
