//! McGuire et al. 2012's reconstruction filter as a method: the CPU reference
//! (`crate::filters::mcguire`) or its WGSL pass (`crate::filters::gpu`) over the tracer's
//! G-buffer at the shutter's centre ([`super::post_process`]).

use study::method::McGuireSettings;

use super::post_process::Filter;
use crate::filters::{FilterError, FilteredImage, GBuffer, GpuFilters, McGuireParams};
use crate::gbuffer::FloorMotion;

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
        crate::filters::mcguire::try_mcguire_cpu(g, params)
    }
}
