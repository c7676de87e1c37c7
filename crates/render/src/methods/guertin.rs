//! Guertin et al. 2014's filtering approach as a method: the CPU reference
//! (`crate::filters::guertin`) or its WGSL passes (`crate::filters::gpu`) over the tracer's
//! G-buffer at the shutter's centre ([`super::post_process`]).

use study::method::GuertinSettings;

use super::post_process::Filter;
use crate::filters::{FilterError, FilteredImage, GBuffer, GpuFilters, GuertinParams};
use crate::gbuffer::FloorMotion;

/// Guertin et al.'s filter.
pub struct Guertin;

impl Filter for Guertin {
    type Settings = GuertinSettings;
    type Params = GuertinParams;

    fn params(settings: &GuertinSettings, seed: u32) -> GuertinParams {
        GuertinParams::from_settings(settings, seed)
    }

    fn floor_motion(settings: &GuertinSettings) -> FloorMotion {
        if settings.shadow_motion() { FloorMotion::Shadow } else { FloorMotion::Surface }
    }

    fn gpu(gpu: &GpuFilters, g: &GBuffer, params: &GuertinParams) -> Result<FilteredImage, FilterError> {
        gpu.guertin(g, params)
    }

    fn cpu(g: &GBuffer, params: &GuertinParams) -> Result<Vec<[f32; 3]>, FilterError> {
        crate::filters::guertin::try_guertin_cpu(g, params)
    }
}
