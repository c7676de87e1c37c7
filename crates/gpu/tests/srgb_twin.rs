//! `shaders/srgb.wgsl` against its CPU twin `study::color` (f32): a compute shader evaluates
//! `srgb_encode`, `srgb_decode` and their vec3 forms on a few thousand inputs over [0, 1]
//! (a uniform grid, every 8-bit code / 255, the knees and their f32 neighbours) and every
//! result must be within `TOLERANCE` of the CPU's, take the same branch at the knees, and
//! the vec3 forms must equal the scalar ones bit for bit.
//!
//! Measured on lavapipe (llvmpipe 15.0.6, Mesa 22.3.6, Vulkan): 4,365 inputs, 2,974 of the
//! 8,730 scalar results bit-equal to the CPU's, largest differences 2.4e-7 (encode, at 0.855)
//! and 3.0e-7 (decode, at 0.969), 2 to 3 f32 ULP below 1; the test prints them on each run.

use gpu::WgslAssembler;
use study::color::{srgb_decode, srgb_encode};

/// Largest absolute difference allowed between the GPU's and the CPU's curve. WGSL's `pow`
/// (exp2 of log2) may be several ULP off on hardware; 2e-6 is about 0.0005 of an 8-bit code
/// step, so codes computed on either side agree.
const TOLERANCE: f32 = 2e-6;

const KERNEL: &str = "//! include srgb
@group(0) @binding(0) var<storage, read> input: array<f32>;
// Per input: encode, decode, encode3 (x, y, z), decode3 (x, y, z).
@group(0) @binding(1) var<storage, read_write> output: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&input) {
        return;
    }
    let x = input[i];
    let e3 = srgb_encode3(vec3<f32>(x));
    let d3 = srgb_decode3(vec3<f32>(x));
    let o = 8u * i;
    output[o] = srgb_encode(x);
    output[o + 1u] = srgb_decode(x);
    output[o + 2u] = e3.x;
    output[o + 3u] = e3.y;
    output[o + 4u] = e3.z;
    output[o + 5u] = d3.x;
    output[o + 6u] = d3.y;
    output[o + 7u] = d3.z;
}
";

fn neighbours(x: f32) -> [f32; 3] {
    [f32::from_bits(x.to_bits() - 1), x, f32::from_bits(x.to_bits() + 1)]
}

fn inputs() -> Vec<f32> {
    let mut x: Vec<f32> = (0..=4096).map(|i| i as f32 / 4096.0).collect();
    x.extend((0..=255).map(|c| c as f32 / 255.0));
    x.extend(neighbours(0.003_130_8));
    x.extend(neighbours(0.04045));
    // Tiny values (the toe's scale) and values near 1.
    x.extend([1e-7, 1e-5, 1e-4, 1e-3, 0.999_999, f32::from_bits(1.0f32.to_bits() - 1)]);
    x
}

#[test]
fn srgb_wgsl_agrees_with_the_cpu_curve() {
    let Some(ctx) = gpu::test_context("srgb_wgsl_agrees_with_the_cpu_curve") else { return };
    let wgsl = WgslAssembler::new().assemble("srgb_twin.wgsl", KERNEL).unwrap();
    let x = inputs();
    let got: Vec<f32> =
        ctx.run_kernel("srgb_twin.wgsl", &wgsl, "main", &x, 8 * x.len(), (x.len() as u32).div_ceil(64)).unwrap();

    let (mut worst_encode, mut worst_decode, mut exact) = ((0.0f32, 0.0f32), (0.0f32, 0.0f32), 0usize);
    for (i, &v) in x.iter().enumerate() {
        let g = &got[8 * i..8 * i + 8];
        let (e, d) = (srgb_encode::<f32>(v), srgb_decode::<f32>(v));
        for (name, gpu, cpu, worst) in [("encode", g[0], e, &mut worst_encode), ("decode", g[1], d, &mut worst_decode)]
        {
            let diff = (gpu - cpu).abs();
            assert!(diff <= TOLERANCE, "srgb_{name}({v:?}): GPU {gpu:?}, CPU {cpu:?} ({diff:e} apart)");
            if diff > worst.0 {
                *worst = (diff, v);
            }
            exact += usize::from(gpu.to_bits() == cpu.to_bits());
        }
        // The vec3 forms are the scalar ones per component.
        for c in 0..3 {
            assert_eq!(g[2 + c].to_bits(), g[0].to_bits(), "srgb_encode3({v:?}).{c}");
            assert_eq!(g[5 + c].to_bits(), g[1].to_bits(), "srgb_decode3({v:?}).{c}");
        }
    }
    // At and next to the knees the GPU takes the CPU's branch: the toe there is exact
    // (one multiplication or division), so it must agree to the bit.
    for (j, &v) in x.iter().enumerate() {
        if v <= 0.003_130_8 {
            assert_eq!(got[8 * j].to_bits(), (v * 12.92).to_bits(), "toe of srgb_encode({v:?})");
        }
    }
    eprintln!(
        "{}: {} inputs, {exact} of {} results bit-equal; largest differences: encode {:e} at {:?}, decode {:e} at {:?} (tolerance {TOLERANCE:e})",
        ctx.info,
        x.len(),
        2 * x.len(),
        worst_encode.0,
        worst_encode.1,
        worst_decode.0,
        worst_decode.1
    );
}
