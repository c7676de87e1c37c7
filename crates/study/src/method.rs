//! The rendering method of a stimulus set: which algorithm turns a frame's scene into
//! pixels, and its settings. Design files name it (`[method] kind = "tracer"`, the default)
//! or make it a factor (`[[factors.method]]`, one table per level), manifests record it, and
//! `render::Renderer` dispatches on it. Settings left out take the method's defaults, which
//! the renderer documents (the filters' come from their papers).

use std::fmt;
use std::ops::RangeInclusive;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// The accumulation buffer's instants when a design does not set `instants`.
pub const DEFAULT_INSTANTS: u32 = 8;
/// The analytic rasterizer's `tessellation` (segments around the sphere's equator): the
/// design accepts and the renderer renders exactly this range.
pub const TESSELLATION_RANGE: RangeInclusive<u32> = 3..=4096;
/// The analytic rasterizer's tessellation when a design does not set `tessellation`.
pub const DEFAULT_TESSELLATION: u32 = 64;

/// Triangles of the analytic rasterizer's sphere at `tessellation` segments: `rings =
/// max(segments / 2, 2)` rings, a fan at each pole and two triangles per quad between.
pub fn sphere_triangle_count(tessellation: u32) -> u64 {
    let n = u64::from(tessellation);
    2 * n * ((n / 2).max(2) - 1)
}

/// A rendering method. The tracer is the reference every other method is compared with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The distribution (Monte Carlo) ray tracer: pixel area and shutter time sampled.
    #[default]
    Tracer,
    /// Accumulation buffer: instantaneous renders at several times in the shutter, averaged.
    Accum,
    /// McGuire et al. 2012 post-process motion blur (reconstruction filter).
    Mcguire,
    /// Guertin et al. 2014 post-process motion blur (filtering approach).
    Guertin,
    /// Gribel et al. 2010 analytic motion blur rasterizer (visibility over the shutter).
    Analytic,
}

impl Method {
    /// Every method, in the order reports list them.
    pub const ALL: [Method; 5] = [Method::Tracer, Method::Accum, Method::Mcguire, Method::Guertin, Method::Analytic];

    /// The name used in design files, manifests and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Tracer => "tracer",
            Method::Accum => "accum",
            Method::Mcguire => "mcguire",
            Method::Guertin => "guertin",
            Method::Analytic => "analytic",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            format!("unknown rendering method `{s}`; expected one of {}", names.join(", "))
        })
    }
}

/// `[method]` of a design file (the set's rendering method) or one `[[factors.method]]`
/// level: the method and the settings that apply to it (others are refused by the design).
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MethodSpec {
    /// Human name of a method level (reports); defaults to the level's tag.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The method (default `tracer`).
    #[serde(default)]
    pub kind: Method,
    /// Accumulation buffer: instants K averaged over the open shutter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instants: Option<u32>,
    /// Accumulation buffer: jittered instants (one random time in each of the K equal
    /// sub-intervals) instead of their centres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jitter: Option<bool>,
    /// Accumulation buffer: samples per pixel of each instant; by default the A level's
    /// samples are shared among the instants (rounded up).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_per_instant: Option<u32>,
    /// Filters: taps N gathered per pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taps: Option<u32>,
    /// Filters: tile size in pixels, the largest blur radius (McGuire's k, Guertin's r).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<u32>,
    /// McGuire: the soft depth comparison's extent, metres (Guertin's depth comparison is
    /// relative and has none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub soft_z_extent: Option<f64>,
    /// Guertin: tau, the velocity (pixels) below which the centre velocity is used alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau: Option<f64>,
    /// Guertin: kappa, the centre weight's scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kappa: Option<f64>,
    /// Guertin: eta, the tile variance threshold of the sampling split.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta: Option<f64>,
    /// Guertin: gamma, the exponent of the direction weights.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gamma: Option<f64>,
    /// Guertin: phi, the jitter scale (the jitter is phi / N).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi: Option<f64>,
    /// Guertin: split the samples between the dominant and the centre velocity by the
    /// tile's velocity variance (section 4.2; off in the paper's results but one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile_variance: Option<bool>,
    /// Analytic rasterizer: the per-pixel interval budget of the compression (4-64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intervals: Option<u32>,
    /// Analytic rasterizer: the sphere's tessellation, segments around its equator (the
    /// rings from pole to pole are half as many).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tessellation: Option<u32>,
    /// Analytic rasterizer: lighting samples of each interval's one shading evaluation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting_samples: Option<u32>,
    /// Analytic rasterizer: sample points per pixel along each axis, `n x n` at the centres
    /// of the pixel's cells, each with its own interval list, box-filtered (1-8; 1, the
    /// default, is the paper's one sample point at the pixel's centre).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supersampling: Option<u32>,
}

impl MethodSpec {
    /// The method's defaults.
    pub fn of(kind: Method) -> MethodSpec {
        MethodSpec { kind, ..MethodSpec::default() }
    }

    /// The settings written, as `(key, applies to)`: which methods take each key.
    pub fn settings(&self) -> Vec<(&'static str, &'static [Method])> {
        const ACCUM: &[Method] = &[Method::Accum];
        const FILTERS: &[Method] = &[Method::Mcguire, Method::Guertin];
        const GUERTIN: &[Method] = &[Method::Guertin];
        const MCGUIRE: &[Method] = &[Method::Mcguire];
        const ANALYTIC: &[Method] = &[Method::Analytic];
        let written = [
            ("instants", self.instants.is_some(), ACCUM),
            ("jitter", self.jitter.is_some(), ACCUM),
            ("samples_per_instant", self.samples_per_instant.is_some(), ACCUM),
            ("taps", self.taps.is_some(), FILTERS),
            ("tile", self.tile.is_some(), FILTERS),
            ("soft_z_extent", self.soft_z_extent.is_some(), MCGUIRE),
            ("tau", self.tau.is_some(), GUERTIN),
            ("kappa", self.kappa.is_some(), GUERTIN),
            ("eta", self.eta.is_some(), GUERTIN),
            ("gamma", self.gamma.is_some(), GUERTIN),
            ("phi", self.phi.is_some(), GUERTIN),
            ("tile_variance", self.tile_variance.is_some(), GUERTIN),
            ("intervals", self.intervals.is_some(), ANALYTIC),
            ("tessellation", self.tessellation.is_some(), ANALYTIC),
            ("lighting_samples", self.lighting_samples.is_some(), ANALYTIC),
            ("supersampling", self.supersampling.is_some(), ANALYTIC),
        ];
        written.into_iter().filter(|(_, set, _)| *set).map(|(k, _, m)| (k, m)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_text_and_serde() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{}\"", m.name()));
            assert_eq!(serde_json::from_str::<Method>(&format!("\"{m}\"")).unwrap(), m);
        }
        let e = "raster".parse::<Method>().unwrap_err();
        assert_eq!(e, "unknown rendering method `raster`; expected one of tracer, accum, mcguire, guertin, analytic");
        assert_eq!(Method::default(), Method::Tracer);
        let spec: MethodSpec = toml::from_str("kind = \"guertin\"").unwrap();
        assert_eq!(spec.kind, Method::Guertin);
        assert!(toml::from_str::<MethodSpec>("kind = \"x\"").is_err());
        assert!(toml::from_str::<MethodSpec>("sort = \"tracer\"").is_err());
        let spec: MethodSpec = toml::from_str("kind = \"accum\"\ninstants = 8\ntau = 1.0").unwrap();
        let keys: Vec<_> = spec.settings().into_iter().map(|(k, m)| (k, m.to_vec())).collect();
        assert_eq!(keys, vec![("instants", vec![Method::Accum]), ("tau", vec![Method::Guertin])]);
    }
}
