//! The WGSL assembler that knows the render crate's shader includes: the shading layer's
//! `sampler32.wgsl` and `radiance.wgsl`, which the methods' kernels include with
//! `//! include NAME`.

use ::gpu::WgslAssembler;

use crate::shading::sampler::dim;

/// The render crate's WGSL include files: `(name, text)`, included with `//! include NAME`.
pub const INCLUDES: &[(&str, &str)] = &[
    // The u32 Owen-scrambled Sobol sampler, the WGSL twin of `sampler32`.
    ("sampler32", include_str!("sampler32.wgsl")),
    // The f32 shading layer (geometry, environment, materials, integrator), the WGSL twin
    // of `radiance`.
    ("radiance", include_str!("radiance.wgsl")),
];

/// A WGSL assembler with the gpu crate's shared includes, the render crate's [`INCLUDES`]
/// and the sampling dimensions of [`dim`] declared as `DIM_PIXEL`, `DIM_TIME`,
/// `DIM_BOUNCE_BASE`, `DIM_PER_BOUNCE`, `DIM_LIGHT`, `DIM_BSDF` and `DIM_ROULETTE`
/// (`sampler32.wgsl` needs `DIM_PIXEL`, `radiance.wgsl` the rest), so the shaders and the CPU share one layout.
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
