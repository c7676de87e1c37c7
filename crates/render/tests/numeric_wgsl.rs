//! `numeric.wgsl` (crates/gpu/shaders) against its CPU twin `render::numeric`: a compute
//! shader evaluates each helper on random and hand-picked inputs and the results must match
//! the Rust f32 functions: bit for bit where the operations are exact (next floats), within
//! rounding where `normalize`, `sqrt` and division may differ (offsets, the quadratic). Vulkan does not promise a fused `fma`; the difference of products is
//! compared exactly where the adapter fuses (measured below) and the test says which.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use rand::{RngExt, SeedableRng};
use render::numeric::{
    difference_of_products_f32, next_float_down_f32, next_float_up_f32, offset_ray_origin_f32, solve_quadratic_f32,
};

/// Per input record: 12 floats in, 12 floats out (see KERNEL).
const KERNEL: &str = "//! include numeric
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if 12u * i >= arrayLength(&input) {
        return;
    }
    let o = 12u * i;
    let a = input[o];
    let b = input[o + 1u];
    let c = input[o + 2u];
    let d = input[o + 3u];
    output[o] = difference_of_products(a, b, c, d);
    let roots = solve_quadratic(a, b, c);
    output[o + 1u] = roots.x;
    output[o + 2u] = roots.y;
    output[o + 3u] = roots.z;
    output[o + 4u] = next_float_up(a);
    output[o + 5u] = next_float_down(b);
    let p = vec3<f32>(input[o + 4u], input[o + 5u], input[o + 6u]);
    let n = normalize(vec3<f32>(input[o + 7u], input[o + 8u], input[o + 9u]));
    let w = vec3<f32>(input[o + 10u], input[o + 11u], -input[o + 7u]);
    let origin = offset_ray_origin(p, abs(p) * 1e-6, n, w);
    output[o + 6u] = origin.x;
    output[o + 7u] = origin.y;
    output[o + 8u] = origin.z;
    output[o + 9u] = next_float_up(c);
    output[o + 10u] = next_float_down(d);
    output[o + 11u] = next_float_up(-0.0 * a);
}
";

/// The CPU twin of one record of KERNEL.
fn twin(r: &[f32]) -> [f32; 12] {
    let (a, b, c, d) = (r[0], r[1], r[2], r[3]);
    let roots = solve_quadratic_f32(a, b, c).map_or([0.0, 0.0, 0.0], |(r0, r1)| [r0, r1, 1.0]);
    let p = [r[4], r[5], r[6]];
    let n = glam::Vec3::new(r[7], r[8], r[9]).normalize().to_array();
    let w = [r[10], r[11], -r[7]];
    let origin = offset_ray_origin_f32(p, p.map(|v| v.abs() * 1e-6), n, w);
    [
        difference_of_products_f32(a, b, c, d),
        roots[0],
        roots[1],
        roots[2],
        next_float_up_f32(a),
        next_float_down_f32(b),
        origin[0],
        origin[1],
        origin[2],
        next_float_up_f32(c),
        next_float_down_f32(d),
        next_float_up_f32(-0.0 * a),
    ]
}

fn records() -> Vec<[f32; 12]> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(2026);
    let mut out: Vec<[f32; 12]> = (0..2000)
        .map(|_| {
            let mut r = [0.0f32; 12];
            for v in &mut r {
                // Magnitudes over twelve decades, both signs.
                *v = (rng.random::<f32>() * 2.0 - 1.0) * 10f32.powf(rng.random::<f32>() * 12.0 - 6.0);
            }
            r
        })
        .collect();
    // Cancellation: b^2 close to 4ac, a tiny root next to a large one, and zeros.
    out.push([1.0, -2.0, 1.0, 1.0 + f32::EPSILON, 1.0, 2.0, 3.0, 0.0, 1.0, 0.0, 1.0, 0.5]);
    out.push([1.0, -1e4, 1.0, 1e-8, -3.0, 0.5, 8.0, 0.3, 0.9, 0.1, -0.2, 0.7]);
    out.push([0.0, 2.0, -4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0]);
    out.push([0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
    out
}

fn run(ctx: &gpu::GpuContext, records: &[[f32; 12]]) -> Vec<f32> {
    let wgsl = gpu::WgslAssembler::new().assemble("numeric_twin.wgsl", KERNEL).unwrap();
    let input: Vec<f32> = records.iter().flatten().copied().collect();
    ctx.run_kernel("numeric_twin.wgsl", &wgsl, "main", &input, input.len(), (records.len() as u32).div_ceil(64))
        .unwrap()
}

fn ulps(a: f32, b: f32) -> u32 {
    if a == b {
        return 0;
    }
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 { i32::MIN - i } else { i }
    };
    key(a).abs_diff(key(b))
}

#[test]
fn numeric_wgsl_agrees_with_the_cpu_twin() {
    let Some(ctx) = gpu::test_context("numeric_wgsl_agrees_with_the_cpu_twin") else { return };
    let records = records();
    let got = run(&ctx, &records);
    // Whether the adapter fuses fma: (1 + e)(1 + e) - 1 keeps e^2 only when fused.
    let fused_probe = {
        let r = [1.0 + f32::EPSILON, 1.0 + f32::EPSILON, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0];
        run(&ctx, &[r])[0] == f32::EPSILON * f32::EPSILON
    };
    let (mut worst_roots, mut compared) = (0, 0);
    for (k, r) in records.iter().enumerate() {
        let g = &got[12 * k..12 * k + 12];
        let w = twin(r);
        let what = |i: usize| format!("record {k} {r:?} output {i}: GPU {:?}, CPU {:?}", g[i], w[i]);
        // Exact operations: next floats and the offset origin (normalize may differ by an ulp
        // in the normal, so the origin is compared within the offset's own rounding below).
        for i in [4, 5, 9, 10, 11] {
            assert!(g[i].to_bits() == w[i].to_bits() || (g[i] == 0.0 && w[i] == 0.0), "{}", what(i));
        }
        for i in [6, 7, 8] {
            // The origin moves by at most |n| . p_error (1e-6 |p|) plus one float; a normal an
            // ulp off changes that by a relative 1e-7 of it.
            let tolerance = 2e-6 * r[4..7].iter().fold(0.0f32, |m, v| m.max(v.abs())) + 2.0 * f32::EPSILON * w[i].abs();
            assert!((g[i] - w[i]).abs() <= tolerance, "{}", what(i));
        }
        // Roots: found by both or neither; values within a few ulps (sqrt and division are
        // correctly rounded on the CPU, within 1-3 ulps in WGSL). Without a fused fma the
        // discriminant is the naive one, off by up to an ulp of b^2: compared only where it is
        // at least a hundredth of b^2, so the roots move by at most about 50 ulps.
        let (a, b, c) = (f64::from(r[0]), f64::from(r[1]), f64::from(r[2]));
        let well_conditioned = b * b - 4.0 * a * c > 1e-2 * b * b;
        let root_ulps = if fused_probe { 8 } else { 64 };
        if fused_probe {
            assert!(ulps(g[0], w[0]) <= 1, "{}", what(0));
        }
        if fused_probe || well_conditioned {
            assert_eq!(g[3], w[3], "{}", what(3));
            for i in [1, 2] {
                worst_roots = worst_roots.max(ulps(g[i], w[i]));
                assert!(ulps(g[i], w[i]) <= root_ulps, "{}", what(i));
            }
            compared += 1;
        }
    }
    use std::io::Write as _;
    let _ = writeln!(
        std::io::stderr(),
        "numeric.wgsl on {}: fma fused: {fused_probe}; {} records, roots compared in {compared}, largest root difference {worst_roots} ulps",
        ctx.info.short(),
        records.len()
    );
    assert!(compared > records.len() / 4, "only {compared} records had their roots compared");
}
