//! The shading layer's f32 forms, which the GPU kernels compute: the parameters they read
//! ([`params`]: frame parameters, environment tables, pipeline specialisations), the u32
//! sampler ([`sampler32`], bit for bit `shaders/sampler32.wgsl`) and the f32 twin of
//! `shaders/tracer.wgsl` ([`tracer_twin`]), whose integrator the analytic kernel's twin
//! shades with as its kernel includes the tracer's.

pub mod params;
pub mod sampler32;
pub mod tracer_twin;
