//! A method table as a design file writes it (`[method]` or one `[[factors.method]]` level):
//! the method, a name and every method's keys in one flat table, which
//! [`super::MethodSpec::from_table`] turns into one method's typed settings.

use serde::{Deserialize, Serialize};

use super::Method;

/// `[method]` of a design file or one `[[factors.method]]` level, as written.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MethodTable {
    /// Human name of a method level (reports); defaults to the level's tag.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The method (default `tracer`).
    #[serde(default)]
    pub kind: Method,
    /// Tracer: whether camera samples are jittered within the pixel (false: all through its
    /// centre, aliased).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pixel_jitter: Option<bool>,
    /// Any method: antialiasing of the display frame (`none` or `mlaa`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub antialias: Option<super::antialias::AntialiasKind>,
    /// Any method with `antialias = "mlaa"`: the step that makes an edge (of display
    /// luminance, or of inverse view depth in 1/m with `mlaa_edges = "depth"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mlaa_threshold: Option<f64>,
    /// Any method with `antialias = "mlaa"`: what edges are found in (`luminance` or `depth`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mlaa_edges: Option<crate::scene::MlaaEdges>,
    /// Any method with `antialias = "mlaa"`: the search distance in pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mlaa_search_distance: Option<u32>,
    /// Accumulation buffer: instants K averaged over the open shutter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instants: Option<u32>,
    /// Accumulation buffer: jittered instants instead of the sub-intervals' centres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jitter: Option<bool>,
    /// Accumulation buffer: samples per pixel of each instant.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_per_instant: Option<u32>,
    /// Filters: taps N gathered per pixel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub taps: Option<u32>,
    /// Filters: tile size in pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<u32>,
    /// McGuire: the soft depth comparison's extent, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub soft_z_extent: Option<f64>,
    /// Guertin: tau.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau: Option<f64>,
    /// Guertin: kappa.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kappa: Option<f64>,
    /// Guertin: eta.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta: Option<f64>,
    /// Guertin: gamma.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gamma: Option<f64>,
    /// Guertin: phi.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi: Option<f64>,
    /// Filters: the floor in the sphere's shadow moves with the sphere in the G-buffer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shadow_motion: Option<bool>,
    /// Guertin: the tile-variance sampling split.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile_variance: Option<bool>,
    /// Analytic rasterizer: the per-pixel interval budget.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intervals: Option<u32>,
    /// Analytic rasterizer: the sphere's tessellation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tessellation: Option<u32>,
    /// Analytic rasterizer: lighting samples of each interval's shading.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting_samples: Option<u32>,
    /// Analytic rasterizer: sample points per pixel along each axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supersampling: Option<u32>,
    /// Marcher: the lighting model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting: Option<super::marcher::MarchLighting>,
    /// Marcher: the step in voxels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
    /// Marcher: lights of the environment's constellation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lights: Option<u32>,
    /// Marcher: the validity mask.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validity_mask: Option<bool>,
    /// Marcher: the distance map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_map: Option<bool>,
    /// Marcher: instants the medium is marched at over the open shutter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sub_frames: Option<u32>,
}

impl MethodTable {
    /// Every settings key of the table, in file order of the struct.
    pub const KEYS: &'static [&'static str] = &[
        "pixel_jitter",
        "antialias",
        "mlaa_threshold",
        "mlaa_edges",
        "mlaa_search_distance",
        "instants",
        "jitter",
        "samples_per_instant",
        "taps",
        "tile",
        "soft_z_extent",
        "shadow_motion",
        "tau",
        "kappa",
        "eta",
        "gamma",
        "phi",
        "tile_variance",
        "intervals",
        "tessellation",
        "lighting_samples",
        "supersampling",
        "lighting",
        "step",
        "lights",
        "validity_mask",
        "distance_map",
        "sub_frames",
    ];

    /// The settings keys written in this table.
    pub fn written_keys(&self) -> Vec<&'static str> {
        let written = [
            self.pixel_jitter.is_some(),
            self.antialias.is_some(),
            self.mlaa_threshold.is_some(),
            self.mlaa_edges.is_some(),
            self.mlaa_search_distance.is_some(),
            self.instants.is_some(),
            self.jitter.is_some(),
            self.samples_per_instant.is_some(),
            self.taps.is_some(),
            self.tile.is_some(),
            self.soft_z_extent.is_some(),
            self.shadow_motion.is_some(),
            self.tau.is_some(),
            self.kappa.is_some(),
            self.eta.is_some(),
            self.gamma.is_some(),
            self.phi.is_some(),
            self.tile_variance.is_some(),
            self.intervals.is_some(),
            self.tessellation.is_some(),
            self.lighting_samples.is_some(),
            self.supersampling.is_some(),
            self.lighting.is_some(),
            self.step.is_some(),
            self.lights.is_some(),
            self.validity_mask.is_some(),
            self.distance_map.is_some(),
            self.sub_frames.is_some(),
        ];
        Self::KEYS.iter().zip(written).filter(|(_, w)| *w).map(|(k, _)| *k).collect()
    }
}
