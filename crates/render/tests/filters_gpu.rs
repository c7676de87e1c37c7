//! The motion blur filters' WGSL passes (`methods/post_process/tiles.wgsl`, each filter's `gather.wgsl`) against their CPU twins
//! (`render::methods::post_process`), pass by pass and on the final image, on small G-buffers (64 x 36 and
//! sizes that are not multiples of the tile), plus the hard cases whose answer is exact:
//! no motion, non-finite colours, bad sizes. Without a GPU adapter each test says SKIPPED
//! (and fails under `BLURLAB_REQUIRE_GPU=1`).

use rand::{RngExt, SeedableRng};
use render::methods::guertin::{GuertinParams, guertin_cpu};
use render::methods::mcguire::{McGuireParams, mcguire_cpu};
use render::methods::post_process::common::PassParams;
use render::methods::post_process::host::{GUERTIN_WGSL, MCGUIRE_WGSL, TILES_WGSL, assemble};
use render::methods::post_process::{FilterError, GBuffer, GpuFilters, tiles};

/// One 8-bit step: the tolerance per channel between the GPU and its twin (linear values
/// of inputs in [0, 1]). Measured on Mesa 22.3.6's llvmpipe (wgpu's GL backend; this machine
/// has no Vulkan driver): 0 for every gather and every final image, including 640 x 360;
/// 1.2e-7 in `tile_variance`, the only pass before the gather that is not bit-identical. It
/// took the sample parameter from `s + 1` in integers to get there: with `s + j + 1` in
/// floats, which Mesa reassociates, one sample in 8 million moved by a pixel (0.012).
const TOLERANCE: f32 = 1.0 / 255.0;

fn filters(test: &str) -> Option<GpuFilters> {
    let ctx = gpu::test_context(test)?;
    Some(GpuFilters::new(ctx).expect("the filters' WGSL compiles"))
}

/// Random colours in [0, 1], depths in [1, 20], velocities up to `speed` px per exposure,
/// with a near square moving fast across the middle (real occlusion edges).
fn gbuffer(w: u32, h: u32, speed: f32, seed: u64) -> GBuffer {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut g = GBuffer { width: w, height: h, color: vec![], depth: vec![], velocity: vec![] };
    for y in 0..h {
        for x in 0..w {
            let inside = x > w / 3 && x < w / 2 + 4 && y > h / 4 && y < 3 * h / 4;
            g.color.push([rng.random::<f32>(), rng.random::<f32>(), rng.random::<f32>()]);
            let z = if inside { 2.0 } else { 5.0 + 15.0 * rng.random::<f32>() };
            g.depth.push(z);
            let v = if inside {
                [2.5 * speed, -0.5 * speed]
            } else {
                [(rng.random::<f32>() * 2.0 - 1.0) * speed, (rng.random::<f32>() * 2.0 - 1.0) * speed]
            };
            g.velocity.push(v);
        }
    }
    g
}

fn max_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f32, usize) {
    let mut worst = (0.0f32, 0);
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        for c in 0..3 {
            let d = (p[c] - q[c]).abs();
            // A NaN difference (NaN on one side only) counts as infinite.
            let d = if d.is_nan() { f32::INFINITY } else { d };
            if d > worst.0 {
                worst = (d, i);
            }
        }
    }
    worst
}

fn max_difference2(a: &[[f32; 2]], b: &[[f32; 2]]) -> f32 {
    a.iter().zip(b).flat_map(|(p, q)| [(p[0] - q[0]).abs(), (p[1] - q[1]).abs()]).fold(0.0, f32::max)
}

#[test]
fn every_filter_shader_assembles_and_validates() {
    for (file, source) in [("tiles.wgsl", TILES_WGSL), ("mcguire.wgsl", MCGUIRE_WGSL), ("guertin.wgsl", GUERTIN_WGSL)] {
        let wgsl = assemble(file, source).unwrap();
        gpu::validate_wgsl(file, &wgsl).unwrap();
    }
}

#[test]
fn each_pass_agrees_with_its_cpu_twin() {
    let Some(f) = filters("each_pass_agrees_with_its_cpu_twin") else { return };
    let mut worst_tiles = 0.0f32;
    let mut worst_image = 0.0f32;
    // Sizes that are and are not multiples of the tile; the last case has velocities far
    // beyond any tile (1e30 px, clamped) and depths of zero and ties.
    for (w, h, tile, seed) in [(64u32, 36u32, 16u32, 1u64), (67, 37, 40, 2), (53, 29, 12, 3), (64, 36, 20, 4)] {
        let mut g = gbuffer(w, h, 14.0, seed);
        if seed == 4 {
            for (i, (v, z)) in g.velocity.iter_mut().zip(&mut g.depth).enumerate() {
                *v = [v[0] * 1e29, v[1] * -1e29];
                *z = [0.0, 3.0, 3.0, *z][i % 4];
            }
        }
        for guertin in [false, true] {
            for variance in [0u32, 1] {
                if variance == 1 && !guertin {
                    continue;
                }
                let mut p = if guertin {
                    GuertinParams { tile, seed: seed as u32, ..GuertinParams::default() }.pass_params(&g)
                } else {
                    McGuireParams { tile, seed: seed as u32, ..McGuireParams::default() }.pass_params(&g)
                };
                p.variance = variance;
                let (image, gpu_tiles) = f.run_passes(&g, &p, guertin).unwrap();
                let cpu_tiles = tiles::run(&p, &g.velocity, guertin);
                let what = format!("{w}x{h} tile {tile} guertin {guertin} variance {variance}");
                // The passes before the gather: the same operations, agreeing to rounding.
                for (name, a, b) in [
                    ("encode_velocity", &gpu_tiles.velocity, &cpu_tiles.velocity),
                    ("tile_max_x", &gpu_tiles.rows, &cpu_tiles.rows),
                    ("tile_max_y", &gpu_tiles.tile_max, &cpu_tiles.tile_max),
                    ("neighbor_max", &gpu_tiles.neighbor_max, &cpu_tiles.neighbor_max),
                ] {
                    let d = max_difference2(a, b);
                    worst_tiles = worst_tiles.max(d);
                    assert!(d <= 1e-5, "{what}: {name} differs by {d}");
                }
                let dv =
                    gpu_tiles.variance.iter().zip(&cpu_tiles.variance).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
                worst_tiles = worst_tiles.max(dv);
                assert!(dv <= 1e-5, "{what}: tile_variance differs by {dv}");
                // The gather, from the twin's own intermediates.
                let mut twin = vec![[0.0f32; 3]; p.pixels()];
                if guertin {
                    render::methods::guertin::gather::guertin_gather(
                        &p,
                        &g.color,
                        &g.depth,
                        &cpu_tiles.velocity,
                        &cpu_tiles.neighbor_max,
                        &cpu_tiles.variance,
                        &mut twin,
                    );
                } else {
                    render::methods::mcguire::gather::mcguire_gather(
                        &p,
                        &g.color,
                        &g.depth,
                        &cpu_tiles.velocity,
                        &cpu_tiles.neighbor_max,
                        &mut twin,
                    );
                }
                let (d, at) = max_difference(&image.color, &twin);
                worst_image = worst_image.max(d);
                assert!(
                    d <= TOLERANCE,
                    "{what}: gather differs by {d} at pixel ({}, {}): GPU {:?}, twin {:?}",
                    at as u32 % w,
                    at as u32 / w,
                    image.color[at],
                    twin[at]
                );
            }
        }
    }
    eprintln!("largest GPU - twin difference: passes before the gather {worst_tiles:e}, gathers {worst_image:e}");
}

#[test]
fn the_public_filters_agree_with_the_cpu_filters_and_are_timed() {
    let Some(f) = filters("the_public_filters_agree_with_the_cpu_filters_and_are_timed") else { return };
    let timestamps = f.info().features.contains(gpu::wgpu::Features::TIMESTAMP_QUERY);
    let mut worst = 0.0f32;
    // 64 x 36 with the papers' tiles (k = 20, r = 40: neither divides the size), a size
    // made of whole 12-pixel tiles (with the tile variance on for Guertin's filter),
    // and the study's eye size with r = 32 (360 rows are 11.25 tiles).
    for (w, h, tile) in [(64u32, 36u32, None), (72, 36, Some(12u32)), (640, 360, Some(32))] {
        let g = gbuffer(w, h, 30.0, u64::from(w));
        let mut m = McGuireParams::default();
        let mut q = GuertinParams { tile_variance: w == 72, ..GuertinParams::default() };
        if let Some(t) = tile {
            m.tile = t;
            q.tile = t;
        }
        for (name, image, cpu) in [
            ("mcguire", f.mcguire(&g, &m).unwrap(), mcguire_cpu(&g, &m)),
            ("guertin", f.guertin(&g, &q).unwrap(), guertin_cpu(&g, &q)),
        ] {
            let (d, at) = max_difference(&image.color, &cpu);
            worst = worst.max(d);
            assert!(d <= TOLERANCE, "{name} {w}x{h}: differs by {d} at {at}");
            assert_eq!(image.gpu_seconds.is_some(), timestamps, "{name}: {:?}", image.timing_source);
            assert!(image.seconds > 0.0 && image.seconds.is_finite(), "{name}: {:?}", image.timing_source);
            eprintln!("{name} {w}x{h}: {:.2} ms ({:?})", image.seconds * 1e3, image.timing_source);
        }
    }
    eprintln!("largest GPU - CPU filter difference {worst:e} (tolerance {TOLERANCE:e})");
}

#[test]
fn without_motion_the_gpu_returns_the_input_bit_for_bit() {
    let Some(f) = filters("without_motion_the_gpu_returns_the_input_bit_for_bit") else { return };
    let mut g = gbuffer(64, 36, 0.0, 4);
    g.velocity.fill([0.0, 0.0]);
    let m = f.mcguire(&g, &McGuireParams::default()).unwrap();
    let q = f.guertin(&g, &GuertinParams::default()).unwrap();
    for (name, out) in [("mcguire", m.color), ("guertin", q.color)] {
        for (i, (o, c)) in out.iter().zip(&g.color).enumerate() {
            assert_eq!(o.map(f32::to_bits), c.map(f32::to_bits), "{name} pixel {i}");
        }
    }
}

#[test]
fn non_finite_colours_and_depths_stay_in_their_pixel_on_the_gpu() {
    let Some(f) = filters("non_finite_colours_and_depths_stay_in_their_pixel_on_the_gpu") else { return };
    let mut g = gbuffer(64, 36, 20.0, 5);
    let bad = [(30usize, 17usize, f32::NAN), (5, 3, f32::INFINITY), (63, 35, f32::NEG_INFINITY)];
    for &(x, y, v) in &bad {
        g.color[y * 64 + x][0] = v;
    }
    let bad_depth = [(40usize, 10usize, f32::NAN), (7, 20, f32::INFINITY)];
    for &(x, y, z) in &bad_depth {
        g.depth[y * 64 + x] = z;
    }
    let m = McGuireParams { tile: 12, ..McGuireParams::default() };
    let q = GuertinParams { tile: 12, ..GuertinParams::default() };
    for (name, gpu, cpu) in [
        ("mcguire", f.mcguire(&g, &m).unwrap().color, mcguire_cpu(&g, &m)),
        ("guertin", f.guertin(&g, &q).unwrap().color, guertin_cpu(&g, &q)),
    ] {
        for (i, (a, b)) in gpu.iter().zip(&cpu).enumerate() {
            if let Some(&(_, _, v)) = bad.iter().find(|(x, y, _)| y * 64 + x == i) {
                assert!(a[0].to_bits() == v.to_bits() || (v.is_nan() && a[0].is_nan()), "{name} {i}: {a:?}");
                continue;
            }
            if bad_depth.iter().any(|(x, y, _)| y * 64 + x == i) {
                assert_eq!(a.map(f32::to_bits), g.color[i].map(f32::to_bits), "{name} {i}: passed through");
                continue;
            }
            assert!(a.iter().all(|c| c.is_finite()), "{name} pixel {i}: {a:?}");
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= TOLERANCE, "{name} pixel {i}: {a:?} vs {b:?}");
            }
        }
    }
}

#[test]
fn colours_near_the_f32_maximum_stay_finite_on_the_gpu_and_equal_the_twins() {
    // Issue 31, defect 2: a 1e38 sky made the gathers' sums overflow to +Inf. Colours in
    // [0, 2^126] (2^126 = 8.5e37), and a square moving over a sky of 3e38.
    let Some(f) = filters("colours_near_the_f32_maximum_stay_finite_on_the_gpu_and_equal_the_twins") else { return };
    let up = 2f32.powi(126);
    let mut scaled = gbuffer(64, 36, 20.0, 9);
    for c in &mut scaled.color {
        *c = c.map(|v| v * up);
    }
    let mut sky = gbuffer(64, 36, 20.0, 10);
    for (i, (c, (z, v))) in sky.color.iter_mut().zip(sky.depth.iter_mut().zip(&mut sky.velocity)).enumerate() {
        let (x, y) = (i % 64, i / 64);
        if !((20..34).contains(&x) && (10..26).contains(&y)) {
            (*c, *z, *v) = ([3e38, 3e38, 1e38], render::methods::post_process::SKY_DEPTH, [0.0, 0.0]);
        }
    }
    let m = McGuireParams { tile: 12, ..McGuireParams::default() };
    let q = GuertinParams { tile: 12, ..GuertinParams::default() };
    for (what, g, scale) in [("colours x 2^126", &scaled, up), ("3e38 sky", &sky, 3e38)] {
        for (name, gpu, cpu) in [
            ("mcguire", f.mcguire(g, &m).unwrap().color, mcguire_cpu(g, &m)),
            ("guertin", f.guertin(g, &q).unwrap().color, guertin_cpu(g, &q)),
        ] {
            assert!(cpu.iter().flatten().all(|c| c.is_finite()), "{name} {what}: the twin");
            for (i, (a, b)) in gpu.iter().zip(&cpu).enumerate() {
                assert!(a.iter().all(|c| c.is_finite()), "{name} {what} pixel {i}: {a:?}");
                for c in 0..3 {
                    assert!((a[c] - b[c]).abs() <= TOLERANCE * scale, "{name} {what} pixel {i}: {a:?} vs {b:?}");
                }
            }
        }
    }
}

#[test]
fn bad_sizes_are_errors_on_the_gpu_too() {
    let Some(f) = filters("bad_sizes_are_errors_on_the_gpu_too") else { return };
    let g = gbuffer(8, 4, 3.0, 6);
    let e = f.mcguire(&GBuffer { height: 0, ..g.clone() }, &McGuireParams::default()).unwrap_err();
    assert!(matches!(e, FilterError::EmptyImage { width: 8, height: 0 }), "{e}");
    let mut short = g.clone();
    short.color.pop();
    let e = f.guertin(&short, &GuertinParams::default()).unwrap_err();
    assert!(matches!(e, FilterError::BufferLength { buffer: "color", expected: 32, got: 31 }), "{e}");
    let e = f.run_passes(&g, &PassParams::new(8, 4, 0, 3, 0), true).unwrap_err();
    assert!(matches!(e, FilterError::BadParam { .. }), "{e}");
}
