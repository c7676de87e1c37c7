//! The shading layer the tracer and the analytic rasterizer share: cameras and their rays
//! (`camera`), ray-scene intersection (`intersect`), materials and their textures
//! (`material`), the path integrator from a hit (`integrator`) and the padded Owen-scrambled
//! Sobol sampler (`sampler`), in f64 for the CPU references; and in `gpu` their f32 forms:
//! what the kernels read (`params`), the u32 sampler (`sampler32`) and the shading layer
//! both kernels include (`radiance.wgsl`, with its twin `radiance`, a Rust function per WGSL
//! function).

pub mod camera;
pub mod gpu;
pub mod integrator;
pub mod intersect;
pub mod material;
pub mod sampler;
