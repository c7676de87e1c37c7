//! McGuire et al. 2012's reconstruction filter as a method: its parameters
//! ([`McGuireParams`]), its gather pass (`gather.wgsl` and its CPU twin [`gather`], also
//! the CPU fallback) after the passes both filters share, over the tracer's G-buffer at the
//! shutter's centre ([`super::post_process`], whose host runs it on a GPU).

pub mod gather;

pub use gather::{mcguire_cpu, try_mcguire_cpu};
use study::method::McGuireSettings;

use super::post_process::filter::{check_count, check_real};
use super::post_process::gbuffer::FloorMotion;
use super::post_process::{Filter, FilterError, FilteredImage, GBuffer, GpuFilters, MAX_SAMPLES, MAX_TILE, common};

/// Settings of McGuire et al. 2012.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct McGuireParams {
    /// Samples per pixel along the dominant velocity (the paper's S; 15).
    pub samples: u32,
    /// Tile size k in pixels, which is also the largest blur radius (half displacement) a
    /// pixel can have: velocities are clamped to it (20, the paper's suggestion).
    pub tile: u32,
    /// Depth interval in metres over which the soft depth comparison goes from "in front" to
    /// "behind" (SOFT_Z_EXTENT; scene-dependent in the paper; 0.1 m suits metre-scale scenes).
    pub soft_z_extent: f32,
    /// Seed of the per-pixel jitter.
    pub seed: u32,
}

impl Default for McGuireParams {
    fn default() -> Self {
        McGuireParams::from_settings(&McGuireSettings::default(), 0)
    }
}

impl McGuireParams {
    /// The settings a design wrote (the paper's defaults where unset, from the study model's
    /// [`McGuireSettings`]) with the per-pixel jitter `seed`.
    pub fn from_settings(s: &McGuireSettings, seed: u32) -> Self {
        McGuireParams { samples: s.taps(), tile: s.tile(), soft_z_extent: s.soft_z_extent() as f32, seed }
    }
}

/// McGuire et al.'s filter.
pub struct McGuire;

impl Filter for McGuire {
    type Settings = McGuireSettings;
    type Params = McGuireParams;

    fn params(settings: &McGuireSettings, seed: u32) -> McGuireParams {
        McGuireParams::from_settings(settings, seed)
    }

    fn floor_motion(settings: &McGuireSettings) -> FloorMotion {
        if settings.shadow_motion() { FloorMotion::Shadow } else { FloorMotion::Surface }
    }

    fn gpu(gpu: &GpuFilters, g: &GBuffer, params: &McGuireParams) -> Result<FilteredImage, FilterError> {
        gpu.mcguire(g, params)
    }

    fn cpu(g: &GBuffer, params: &McGuireParams) -> Result<Vec<[f32; 3]>, FilterError> {
        try_mcguire_cpu(g, params)
    }
}

impl McGuireParams {
    /// Checks the settings' ranges.
    pub fn check(&self) -> Result<(), FilterError> {
        check_count("samples", self.samples, MAX_SAMPLES)?;
        check_count("tile", self.tile, MAX_TILE)?;
        check_real("soft_z_extent", self.soft_z_extent, true)
    }

    /// What every pass of this filter reads for `g`.
    pub fn pass_params(&self, g: &GBuffer) -> common::PassParams {
        let mut p = common::PassParams::new(g.width, g.height, self.tile, self.samples, self.seed);
        p.soft_z_extent = self.soft_z_extent;
        p.inv_soft_z_extent = 1.0 / self.soft_z_extent;
        p
    }
}
