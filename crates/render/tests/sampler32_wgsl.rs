//! `shading/gpu/sampler32.wgsl` against its CPU twin `render::shading::gpu::sampler32`: a compute
//! shader derives the pixel seeds and computes the 1D and 2D sample values of a few thousand
//! (eye, pixel, sample index, dimension) cases, with sample indices at the start of the
//! stream, around 2^16, 2^20 and 2^31 and at u32::MAX, and dimensions 0..=20 and beyond;
//! every seed and value must equal the CPU's bit for bit, as integers and as f32.

use render::shading::gpu::assembler::assembler;
use render::shading::gpu::sampler32;

const KERNEL: &str = "//! include sampler32
// Per case: eye seed, pixel, sample index, dimension.
@group(0) @binding(0) var<storage, read> cases: array<vec4<u32>>;
// Per case: pixel seed, 1D bits, 2D bits (x, y), and the f32 bits of the 1D and 2D values.
@group(0) @binding(1) var<storage, read_write> output: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let c = id.x;
    if c >= arrayLength(&cases) {
        return;
    }
    let k = cases[c];
    let seed = sampler32_pixel_seed(k.x, k.y);
    let v2 = sampler32_2d_bits(seed, k.z, k.w);
    let u2 = sampler32_2d(seed, k.z, k.w);
    let o = 7u * c;
    output[o] = seed;
    output[o + 1u] = sampler32_1d_bits(seed, k.z, k.w);
    output[o + 2u] = v2.x;
    output[o + 3u] = v2.y;
    output[o + 4u] = bitcast<u32>(sampler32_1d(seed, k.z, k.w));
    output[o + 5u] = bitcast<u32>(u2.x);
    output[o + 6u] = bitcast<u32>(u2.y);
}
";

/// The CPU's outputs for one case, in the kernel's order.
fn expected([eye, pixel, index, dim]: [u32; 4]) -> [u32; 7] {
    let seed = sampler32::pixel_seed(eye, pixel);
    let one = sampler32::sample_1d_bits(seed, index, dim);
    let [x, y] = sampler32::sample_2d_bits(seed, index, dim);
    let unit = |v| sampler32::to_unit(v).to_bits();
    [seed, one, x, y, unit(one), unit(x), unit(y)]
}

fn cases() -> Vec<[u32; 4]> {
    let eyes = [sampler32::eye_seed32(2024), sampler32::eye_seed32(u64::MAX)];
    let pixels = [0, 641, 640 * 360 - 1, u32::MAX];
    let indices: Vec<u32> = (0..40)
        .chain(65_530..65_542)
        .chain((1 << 20) - 6..(1 << 20) + 6)
        .chain([1 << 31, u32::MAX - 1, u32::MAX])
        .collect();
    let dims: Vec<u32> = (0..=20).chain([31, 32, 1000, u32::MAX]).collect();
    let mut out = Vec::new();
    for (e, &eye) in eyes.iter().enumerate() {
        // Every index and dimension for two pixels of one eye, the others at fewer indices.
        for (p, &pixel) in pixels.iter().enumerate() {
            let step = if (e, p) == (0, 0) || (e, p) == (0, 2) { 1 } else { 4 };
            for &index in indices.iter().step_by(step) {
                out.extend(dims.iter().map(|&d| [eye, pixel, index, d]));
            }
        }
    }
    out
}

#[test]
fn sampler32_wgsl_equals_the_cpu_bit_for_bit() {
    let Some(ctx) = gpu::test_context("sampler32_wgsl_equals_the_cpu_bit_for_bit") else { return };
    let wgsl = assembler().assemble("sampler32_twin.wgsl", KERNEL).unwrap();
    let cases = cases();
    let workgroups = (cases.len() as u32).div_ceil(64);
    let got: Vec<u32> =
        ctx.run_kernel("sampler32_twin.wgsl", &wgsl, "main", &cases, 7 * cases.len(), workgroups).unwrap();

    const NAMES: [&str; 7] = ["pixel seed", "1D bits", "2D x bits", "2D y bits", "1D f32", "2D x f32", "2D y f32"];
    for (c, case) in cases.iter().enumerate() {
        let cpu = expected(*case);
        let gpu = &got[7 * c..7 * c + 7];
        for k in 0..7 {
            assert_eq!(
                gpu[k], cpu[k],
                "[eye, pixel, index, dim] = {case:?}: {} GPU {:#010x}, CPU {:#010x}",
                NAMES[k], gpu[k], cpu[k]
            );
        }
    }
    eprintln!("{}: {} cases, {} values bit-equal to the CPU's", ctx.info, cases.len(), 7 * cases.len());
}
