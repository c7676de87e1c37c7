//! The GPU distribution ray tracer: the kernel `shaders/tracer.wgsl` and everything around
//! it.
//!
//! - `crate::shading::gpu`: what the kernel reads (frame parameters, environment tables,
//!   batches, its specialisation by pipeline override constants), the u32 sampler and the
//!   kernel's f32 twin, shared with the analytic kernel.
//! - [`tracer_host`]: the host side, [`GpuTracer`].
//! - [`assembler`]: the WGSL assembler that knows the render crate's shader includes.

pub mod tracer_host;

pub use crate::shading::gpu::params::Specialisation;
pub use tracer_host::{GpuEnvironment, GpuFrame, GpuPrefix, GpuTracer, GpuTracerError, PendingFrame};

use ::gpu::WgslAssembler;

use crate::shading::sampler::dim;

/// The render crate's WGSL include files: `(name, text)`, included with `//! include NAME`.
pub const INCLUDES: &[(&str, &str)] = &[
    // The u32 Owen-scrambled Sobol sampler, the WGSL twin of `sampler32`.
    ("sampler32", include_str!("../../../shaders/sampler32.wgsl")),
];

/// A WGSL assembler with the gpu crate's shared includes, the render crate's [`INCLUDES`]
/// and the sampling dimensions of [`dim`] declared as `DIM_PIXEL`, `DIM_TIME`,
/// `DIM_BOUNCE_BASE`, `DIM_PER_BOUNCE`, `DIM_LIGHT`, `DIM_BSDF` and `DIM_ROULETTE`
/// (`sampler32.wgsl` needs `DIM_PIXEL`), so the shaders and the CPU share one layout.
pub fn assembler() -> WgslAssembler {
    let mut a = INCLUDES.iter().fold(WgslAssembler::new(), |a, &(name, text)| a.with_include(name, text));
    a.constant_u32("DIM_PIXEL", dim::PIXEL)
        .constant_u32("DIM_TIME", dim::TIME)
        .constant_u32("DIM_BOUNCE_BASE", dim::BOUNCE_BASE)
        .constant_u32("DIM_PER_BOUNCE", dim::PER_BOUNCE)
        .constant_u32("DIM_LIGHT", dim::LIGHT)
        .constant_u32("DIM_BSDF", dim::BSDF)
        .constant_u32("DIM_ROULETTE", dim::ROULETTE);
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_render_include_assembles_and_validates() {
        for (name, _) in INCLUDES {
            let wgsl = assembler().assemble("main.wgsl", &format!("//! include {name}\n")).unwrap();
            assert!(wgsl.contains("const DIM_PIXEL: u32 = 0u;"), "{wgsl}");
            ::gpu::validate_wgsl(&format!("{name}.wgsl"), &wgsl).unwrap();
        }
    }
}
