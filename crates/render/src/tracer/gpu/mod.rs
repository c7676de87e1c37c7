//! The GPU tracer's CPU-side pieces. For now the sampler: [`sampler32`], the u32-only
//! version of [`super::sampler`] that the GPU kernel will compute bit for bit.

pub mod sampler32;
