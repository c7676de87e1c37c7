//! The shading layer's f32 forms, which the GPU kernels compute, each WGSL file beside its
//! CPU twin of the same name: the parameters the kernels read ([`params`]: frame
//! parameters, environment tables, pipeline specialisations), the u32 sampler
//! (`sampler32.wgsl` and [`sampler32`], bit for bit), the shading layer itself
//! (`radiance.wgsl` and [`radiance`]: geometry, environment, materials, the integrator),
//! which the tracer's and the analytic rasterizer's kernels include, and the WGSL
//! [`assembler`] that resolves those includes.

pub mod assembler;
pub mod params;
pub mod radiance;
pub mod sampler32;
