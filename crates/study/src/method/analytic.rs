//! Gribel et al. 2010's analytic motion blur rasterizer: its settings (interval budget,
//! tessellation, lighting samples, supersampling) with defaults, ranges and cost; its cost
//! knobs are the interval budget and the supersampling.

use std::ops::RangeInclusive;

use super::{CurveInput, FrameWork, KeyError, MethodSettings, MethodTable, SweepSetting, check_count};
use crate::design::Preset;

/// The per-pixel interval budget when a design does not set `intervals`.
pub const DEFAULT_INTERVALS: u32 = 8;
/// The interval budgets a design may set.
pub const INTERVALS_RANGE: RangeInclusive<u32> = 4..=64;
/// Sample points per pixel along each axis a design may set.
pub const SUPERSAMPLING_RANGE: RangeInclusive<u32> = 1..=8;
/// The sphere's tessellation (segments around its equator) a design may set.
pub const TESSELLATION_RANGE: RangeInclusive<u32> = 3..=4096;
/// The tessellation when a design does not set `tessellation`.
pub const DEFAULT_TESSELLATION: u32 = 64;
/// Interval budgets the cost sweep measures: the paper's Figure 15 rates (4, 6, 8, 10) and up to 64.
pub const SWEEP_INTERVALS: [u32; 7] = [4, 6, 8, 10, 16, 32, 64];
/// Sample points per pixel along each axis the cost sweep measures, at the default budget
/// and the lighting samples divided among the points (the shading work per pixel stays that
/// of one point).
pub const SWEEP_SUPERSAMPLING: [u32; 2] = [2, 4];

/// Triangles of the analytic rasterizer's sphere at `tessellation` segments: `rings =
/// max(segments / 2, 2)` rings, a fan at each pole and two triangles per quad between.
pub fn sphere_triangle_count(tessellation: u32) -> u64 {
    let n = u64::from(tessellation);
    2 * n * ((n / 2).max(2) - 1)
}

/// `[method] kind = "analytic"`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnalyticSettings {
    /// The per-pixel interval budget of the compression.
    pub intervals: Option<u32>,
    /// The sphere's tessellation, segments around its equator.
    pub tessellation: Option<u32>,
    /// Lighting samples of each interval's one shading evaluation (default: the A level's
    /// samples per pixel).
    pub lighting_samples: Option<u32>,
    /// Sample points per pixel along each axis, `n x n` at the cells' centres, box-filtered
    /// (1, the default, is the paper's one point at the pixel's centre).
    pub supersampling: Option<u32>,
}

defaults!(AnalyticSettings {
    /// The interval budget.
    intervals: u32 = DEFAULT_INTERVALS,
    /// The tessellation.
    tessellation: u32 = DEFAULT_TESSELLATION,
    /// Sample points per pixel along each axis.
    supersampling: u32 = 1,
});

impl MethodSettings for AnalyticSettings {
    const KEYS: &'static [&'static str] = &["intervals", "tessellation", "lighting_samples", "supersampling"];
    const CURVE_INPUT: CurveInput = CurveInput::Each;

    fn from_table(t: &MethodTable) -> Self {
        AnalyticSettings {
            intervals: t.intervals,
            tessellation: t.tessellation,
            lighting_samples: t.lighting_samples,
            supersampling: t.supersampling,
        }
    }

    fn write_table(&self, t: &mut MethodTable) {
        (t.intervals, t.tessellation) = (self.intervals, self.tessellation);
        (t.lighting_samples, t.supersampling) = (self.lighting_samples, self.supersampling);
    }

    fn check(&self) -> Result<(), KeyError> {
        check_count("tessellation", self.tessellation, TESSELLATION_RANGE)?;
        check_count("lighting_samples", self.lighting_samples, 1..=1 << 16)?;
        check_count("supersampling", self.supersampling, SUPERSAMPLING_RANGE)?;
        check_count("intervals", self.intervals, INTERVALS_RANGE)
    }

    /// Lighting samples at each of the n x n sample points.
    fn samples_cost(&self, spp: u32) -> u64 {
        let points = u64::from(self.supersampling().max(1)).pow(2);
        u64::from(self.lighting_samples.unwrap_or(spp.max(1)).max(1)) * points
    }

    fn frame_work(&self, spp: u32) -> FrameWork {
        let n = u64::from(self.supersampling());
        let l = self.lighting_samples.unwrap_or(spp).max(1);
        let set = |key: &'static str, written: bool| written.then_some(key);
        let paths_key = set("lighting_samples", self.lighting_samples.is_some())
            .or(set("supersampling", self.supersampling.is_some()));
        let triangles = sphere_triangle_count(self.tessellation());
        let pairs_key =
            set("tessellation", self.tessellation.is_some()).or(set("supersampling", self.supersampling.is_some()));
        FrameWork {
            light_paths: n * n * u64::from(l),
            light_paths_key: paths_key,
            light_paths_how: format!("{} sample points x {l} lighting samples", n * n),
            triangle_pairs: Some((
                triangles * n * n,
                pairs_key,
                format!("{triangles} triangles x {} sample points per pixel", n * n),
            )),
        }
    }

    /// The interval budgets at the preset's top samples as lighting samples, then the
    /// supersampling at the same lighting samples per pixel in all.
    fn sweep(preset: &Preset, _: u32) -> Vec<SweepSetting> {
        let top_level = preset.samples_per_pixel.iter().copied().max().unwrap_or(1);
        let intervals = SWEEP_INTERVALS.iter().map(move |&intervals| SweepSetting {
            spec: super::MethodSpec::Analytic(AnalyticSettings {
                intervals: Some(intervals),
                lighting_samples: Some(top_level),
                ..AnalyticSettings::default()
            }),
            knob: "intervals",
            value: intervals,
            input_spp: top_level,
            antialias: None,
        });
        let supersampling = SWEEP_SUPERSAMPLING.iter().map(move |&n| SweepSetting {
            spec: super::MethodSpec::Analytic(AnalyticSettings {
                supersampling: Some(n),
                lighting_samples: Some((top_level / (n * n)).max(1)),
                ..AnalyticSettings::default()
            }),
            knob: "supersampling",
            value: n,
            input_spp: top_level,
            antialias: None,
        });
        intervals.chain(supersampling).collect()
    }

    fn work_units(knob: &str, value: u32, _: u32) -> u64 {
        if knob == "supersampling" { u64::from(DEFAULT_INTERVALS) * u64::from(value).pow(2) } else { u64::from(value) }
    }

    fn curve_label(knob: &str, _: u32) -> String {
        if knob == "supersampling" {
            format!("analytic (n x n points per pixel, {DEFAULT_INTERVALS} intervals)")
        } else {
            "analytic (intervals)".to_owned()
        }
    }
}
