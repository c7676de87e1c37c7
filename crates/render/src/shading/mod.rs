//! The shading layer the tracer and the analytic rasterizer share: cameras and their rays
//! (`camera`), ray-scene intersection (`intersect`), materials and their textures
//! (`material`), the path integrator from a hit (`integrator`) and the padded Owen-scrambled
//! Sobol sampler (`sampler`), in f64 for the CPU references; and in `gpu` their f32 forms:
//! what the kernels read (`params`), the u32 sampler (`sampler32`) and the f32 twin of the
//! shared WGSL (`tracer_twin`, a Rust function per function of `shaders/tracer.wgsl`, which
//! `shaders/analytic.wgsl` includes).

pub mod camera;
pub mod gpu;
pub mod integrator;
pub mod intersect;
pub mod material;
pub mod sampler;
