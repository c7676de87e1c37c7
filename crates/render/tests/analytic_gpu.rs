//! The analytic rasterizer's GPU kernel (`methods/analytic/analytic_pixel.wgsl`) against its f32 CPU twin
//! (`render::methods::analytic::analytic_pixel`), and the twin against the f64 rasterizer
//! (`render::methods::analytic`): coverage without shading noise pixel by pixel, shaded frames, and
//! the interval counts. Small study frames (64 x 36, and zoomed in 4x so the sphere's
//! triangles are about a pixel and it moves 9 px). Without a GPU adapter the GPU tests say
//! SKIPPED (and fail under `BLURLAB_REQUIRE_GPU=1`).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use glam::{DVec2, Vec3};
use render::env::EnvironmentMap;
use render::methods::analytic::AnalyticParams;
use render::methods::analytic::GpuAnalytic;
use render::methods::analytic::analytic_pixel::{Kernel, render_view};
use render::methods::analytic::frame::{RasterStats, bin, rasterize_sample};
use render::methods::analytic::geometry::{CameraFrame, SurfaceKind, scene_triangles};
use render::methods::analytic::host::raster_stats;
use render::methods::analytic::interval::SEARCH_RANGE_OPAQUE;
use render::methods::analytic::prepare::Prepared;
use render::methods::analytic::resolve::resolve_opaque;
use render::methods::tracer::GpuTracer;
use render::shading::gpu::params::{EnvTables, Specialisation};
use study::scene::FrameScene;

fn study_scene(width: u32, height: u32, spp: u32, zoom: f64) -> FrameScene {
    common::study_frame(width, height, spp, zoom)
}

const PARAMS: AnalyticParams =
    AnalyticParams { intervals: 8, tessellation: 64, lighting_samples: Some(2), supersampling: 1 };

/// Per pixel, the f64 rasterizer's coverage of the sphere and of the floor (what the
/// coverage kernel writes in red and green).
fn f64_coverage(s: &FrameScene, params: &AnalyticParams) -> Vec<[f64; 2]> {
    let cam = &s.views[0].camera;
    let camera = CameraFrame::new(cam);
    let binned = bin(&scene_triangles(s, &camera, params.tessellation), &camera, cam.width, cam.height);
    let mut out = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let sp = camera.sample(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            let here = binned.iter().filter(|b| b.covers(x, y));
            let mut stats = RasterStats::default();
            let list =
                rasterize_sample(here, sp, params.intervals as usize, SEARCH_RANGE_OPAQUE, &mut stats, |b, _, _| {
                    (if b.triangle.surface == SurfaceKind::Sphere { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] }, 0)
                });
            let (c, _) = resolve_opaque(&list, [0.0; 3]);
            out.push([c[0], c[1]]);
        }
    }
    out
}

fn twin(
    s: &FrameScene,
    tables: &EnvTables,
    params: &AnalyticParams,
    shade: bool,
) -> render::methods::analytic::analytic_pixel::View {
    let prepared = Prepared::new(s, &s.views[0], tables, params).unwrap();
    let k = Kernel { prepared: &prepared, env: &tables.words, spec: Specialisation::of(s), shade };
    render_view(&k)
}

#[test]
fn the_f32_twin_covers_like_the_f64_rasterizer() {
    for zoom in [1.0, 4.0] {
        let s = study_scene(64, 36, 1, zoom);
        let tables = EnvTables::new(&EnvironmentMap::from_lighting(&s.lighting).unwrap());
        let reference = f64_coverage(&s, &PARAMS);
        let view = twin(&s, &tables, &PARAMS, false);
        let (mut worst, mut off, mut moving) = (0.0f64, 0, 0);
        for (r, p) in reference.iter().zip(&view.image.pixels) {
            let d = (r[0] - f64::from(p[0])).abs().max((r[1] - f64::from(p[1])).abs());
            worst = worst.max(d);
            off += usize::from(d > 1e-4);
            moving += usize::from(r[0] > 1e-3 && r[0] < 0.999);
        }
        eprintln!(
            "zoom {zoom}: f32 twin vs f64 coverage: worst {worst:.2e}, {off} of {} pixels over 1e-4",
            reference.len()
        );
        assert!(moving > 10, "the sphere's motion blur must be in view ({moving} partly covered pixels)");
        // f32 moves interval ends by a few ulps of shutter time; a flipped compression choice
        // may move a pixel further, but not many and not by much.
        assert!(off * 100 <= reference.len(), "{off} pixels differ by more than 1e-4");
        assert!(worst < 0.05, "worst pixel {worst}");
    }
}

#[test]
fn the_f32_twin_shades_like_the_f64_rasterizer_up_to_noise() {
    let s = study_scene(64, 36, 64, 4.0);
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let tables = EnvTables::new(&env);
    let params = AnalyticParams { lighting_samples: Some(64), ..PARAMS };
    let view = twin(&s, &tables, &params, true);
    let f64_frame = render::methods::analytic::render_frame(&s, &env, &params).unwrap();
    let mean = |img: &render::io::LinearImage| {
        img.pixels.iter().map(|p| f64::from(p[0] + p[1] + p[2])).sum::<f64>() / img.pixels.len() as f64
    };
    let (a, b) = (mean(&view.image), mean(&f64_frame.eyes[0]));
    eprintln!("mean radiance: twin {a:.5}, f64 rasterizer {b:.5}");
    assert!((a - b).abs() < 0.02 * b, "{a} vs {b}");
    let stats = raster_stats(&view.stats);
    assert_eq!(stats.pixels, f64_frame.stats.pixels);
    let rel = (stats.intervals as f64 - f64_frame.stats.intervals as f64).abs() / f64_frame.stats.intervals as f64;
    assert!(rel < 0.01, "intervals offered: twin {} vs f64 {}", stats.intervals, f64_frame.stats.intervals);
}

fn gpu_and_env(test: &str, s: &FrameScene) -> Option<(GpuAnalytic, render::methods::tracer::GpuEnvironment)> {
    let ctx = gpu::test_context(test)?;
    let tracer = GpuTracer::new(ctx.clone()).expect("the tracer kernel compiles");
    let env = tracer.environment(&EnvironmentMap::from_lighting(&s.lighting).unwrap()).unwrap();
    Some((GpuAnalytic::new(ctx).expect("the analytic kernel compiles"), env))
}

/// (largest difference, pixels differing by more than `tol`) over all channels.
fn compare(a: &[[f32; 3]], b: &[[f32; 3]], tol: f32) -> (f32, usize) {
    let mut worst = 0.0f32;
    let mut off = 0;
    for (p, q) in a.iter().zip(b) {
        let d = (0..3).map(|c| (p[c] - q[c]).abs() / q[c].abs().max(1.0)).fold(0.0, f32::max);
        worst = worst.max(d);
        off += usize::from(d > tol);
    }
    (worst, off)
}

#[test]
fn the_gpu_kernel_covers_like_its_twin() {
    for zoom in [1.0, 4.0] {
        let s = study_scene(64, 36, 1, zoom);
        let Some((gpu, env)) = gpu_and_env("the_gpu_kernel_covers_like_its_twin", &s) else { return };
        let prepared = Prepared::new(&s, &s.views[0], env.tables(), &PARAMS).unwrap();
        let g = gpu.render_view(&prepared, &env, Specialisation::of(&s), false).unwrap();
        let t = twin(&s, env.tables(), &PARAMS, false);
        let (worst, off) = compare(&g.image.pixels, &t.image.pixels, 1e-4);
        eprintln!(
            "zoom {zoom}: GPU vs twin coverage: worst {worst:.2e}, {off} pixels over 1e-4 ({})",
            gpu.info().short()
        );
        assert!(off * 100 <= t.image.pixels.len(), "{off} pixels differ");
        let same_counts = g.stats.iter().zip(&t.stats).filter(|(a, b)| a.offered == b.offered).count();
        assert!(same_counts * 100 >= 99 * t.stats.len(), "offered counts agree at {same_counts} pixels");
    }
}

#[test]
fn the_gpu_kernel_shades_like_its_twin() {
    // A coarser sphere (16 segments) keeps each pixel's shading loops under llvmpipe's limit
    // of 65535 loop iterations per invocation group (the path integrator loops over bounces,
    // the environment's tables and the sampler's bits for every kept interval).
    let params = AnalyticParams { tessellation: 16, ..PARAMS };
    let s = study_scene(64, 36, 2, 4.0);
    let Some((gpu, env)) = gpu_and_env("the_gpu_kernel_shades_like_its_twin", &s) else { return };
    let prepared = Prepared::new(&s, &s.views[0], env.tables(), &params).unwrap();
    let g = gpu.render_view(&prepared, &env, Specialisation::of(&s), true).unwrap();
    let t = twin(&s, env.tables(), &params, true);
    let (worst, off) = compare(&g.image.pixels, &t.image.pixels, 1e-3);
    eprintln!("GPU vs twin radiance: worst {worst:.2e}, {off} pixels over 1e-3");
    assert!(off * 100 <= t.image.pixels.len(), "{off} pixels differ");
    let lit = g.image.pixels.iter().map(|p| Vec3::from_array(*p).length()).sum::<f32>();
    assert!(lit > 0.0 && lit.is_finite());
    // Through the frame API: the same image.
    let frame = gpu.render_frame(&s, &env, &params).unwrap();
    assert_eq!(frame.eyes[0].pixels, g.image.pixels);
    assert_eq!(frame.stats, raster_stats(&g.stats));
}

#[test]
fn a_supersampled_gpu_frame_is_the_twins_larger_frame_averaged_in_blocks() {
    let params = AnalyticParams { tessellation: 16, supersampling: 2, ..PARAMS };
    let s = study_scene(32, 18, 2, 2.0);
    let Some((gpu, env)) = gpu_and_env("a_supersampled_gpu_frame_is_the_twins_larger_frame_averaged_in_blocks", &s)
    else {
        return;
    };
    let frame = gpu.render_frame(&s, &env, &params).unwrap();
    let large = render::methods::analytic::supersample::scaled(&s, 2);
    assert_eq!((large.views[0].camera.width, large.views[0].camera.height), (64, 36));
    let t = twin(&large, env.tables(), &params, true);
    let expected = render::methods::analytic::supersample::downsample(&t.image, 2);
    assert_eq!((frame.eyes[0].width, frame.eyes[0].height), (32, 18));
    let (worst, off) = compare(&frame.eyes[0].pixels, &expected.pixels, 1e-3);
    eprintln!("supersampled GPU frame vs the twin's: worst {worst:.2e}, {off} pixels over 1e-3");
    assert!(off * 100 <= expected.pixels.len(), "{off} pixels differ");
    assert_eq!(frame.stats.pixels, 64 * 36, "one interval list per sample point");
}

/// Issue 31, defect 1: on the shipped design at the quick preset's own sample counts, a pixel
/// of the moving sphere needs more loop iterations than llvmpipe runs in one invocation group
/// (65535), which ended the kernel's loops early and painted 8x8 tiles over the sphere. The
/// kernel now works in resumable steps; the frame must equal its twin everywhere.
#[test]
fn the_shipped_design_at_its_quick_sample_counts_renders_like_the_twin() {
    let design = study::design::Design::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
    )
    .unwrap();
    let preset = design.preset("quick").unwrap();
    let id: study::ids::StimulusId = "M3-S3-T5-A5".parse().unwrap();
    let s = design.frame_scene_with(&preset, &id, 3).unwrap();
    let params = AnalyticParams::default();
    let Some((gpu, env)) = gpu_and_env("the_shipped_design_at_its_quick_sample_counts_renders_like_the_twin", &s)
    else {
        return;
    };
    let frame = gpu.render_frame(&s, &env, &params).unwrap();
    let t = twin(&s, env.tables(), &params, true);
    let (worst, off) = compare(&frame.eyes[0].pixels, &t.image.pixels, 1e-3);
    eprintln!(
        "shipped M3-S3-T5-A5 at {}x{}, {} spp: GPU vs twin worst {worst:.2e}, {off} pixels over 1e-3",
        t.image.width, t.image.height, s.samples_per_pixel
    );
    // One cut-off work group is a tile of 64 wrong pixels; f32 rounding flips a compression
    // choice or an interval's end at a handful.
    assert!(off * 1000 <= t.image.pixels.len(), "{off} pixels differ");
    let g = raster_stats(&t.stats);
    assert!(frame.stats.shaded.abs_diff(g.shaded) * 1000 <= g.shaded, "shaded {} vs {}", frame.stats.shaded, g.shaded);
    assert!(
        frame.stats.intervals.abs_diff(g.intervals) * 1000 <= g.intervals,
        "{} vs {}",
        frame.stats.intervals,
        g.intervals
    );
}

/// Issue 31, defect 3, on the GPU: the kernel refuses a sphere that travels more than its
/// path's wrap length in one exposure with the CPU rasterizer's error
/// (`tests/analytic.rs`), before any parameter is prepared.
#[test]
fn the_gpu_refuses_a_sphere_that_wraps_over_within_the_shutter_as_the_cpu_does() {
    let mut s = study_scene(32, 18, 1, 1.0);
    let Some((gpu, env)) =
        gpu_and_env("the_gpu_refuses_a_sphere_that_wraps_over_within_the_shutter_as_the_cpu_does", &s)
    else {
        return;
    };
    let wrap = s.sphere.wrap_length.expect("the study's path wraps");
    let duration = s.shutter.close - s.shutter.open;
    s.sphere.velocity *= 1.5 * wrap / (s.sphere.velocity.length() * duration);
    let e = gpu.render_frame(&s, &env, &AnalyticParams::default()).unwrap_err();
    let cpu = render::methods::analytic::check_motion(&s).unwrap_err();
    assert_eq!(e.to_string(), cpu.to_string());
}

/// The brightest legal sky (`study::scene::MAX_RADIANCE`, about 3.2e32): its lighting
/// samples exceed 2^100, so the kernel and its twin sum them scaled by 2^-64 (the guard that
/// keeps a sky near f32's maximum from overflowing the sum: under a 1e38 sky, accepted before
/// the design's limit, the kernel wrote f32::MAX floors). The scaled sums must give the f64
/// rasterizer's floor within the noise, and the kernel its twin's bits.
#[test]
fn a_sky_near_the_f32_maximum_shades_finite_and_like_the_f64_rasterizer() {
    let mut s = study_scene(16, 9, 4, 1.0);
    let r = study::scene::MAX_RADIANCE;
    s.lighting.environment = study::scene::Environment::Uniform { radiance: [r, r, r] };
    let params = AnalyticParams { tessellation: 16, lighting_samples: Some(16), ..PARAMS };
    let env_map = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let tables = EnvTables::new(&env_map);
    let t = twin(&s, &tables, &params, true);
    let f64_frame = render::methods::analytic::render_frame(&s, &env_map, &params).unwrap();
    let mean = |p: &[[f32; 3]]| p.iter().map(|c| f64::from(c[0])).sum::<f64>() / p.len() as f64;
    let (a, b) = (mean(&t.image.pixels), mean(&f64_frame.eyes[0].pixels));
    assert!(t.image.pixels.iter().flatten().all(|c| c.is_finite()));
    assert!((a - b).abs() < 0.05 * b, "twin {a:e} vs f64 {b:e}");
    let Some((gpu, env)) = gpu_and_env("a_sky_near_the_f32_maximum_shades_finite_and_like_the_f64_rasterizer", &s)
    else {
        return;
    };
    let prepared = Prepared::new(&s, &s.views[0], env.tables(), &params).unwrap();
    let g = gpu.render_view(&prepared, &env, Specialisation::of(&s), true).unwrap();
    let (worst, off) = compare(&g.image.pixels, &t.image.pixels, 1e-3);
    assert!(off == 0, "{off} pixels differ from the twin, worst {worst:e}");
}
