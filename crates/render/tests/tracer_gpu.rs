//! The GPU tracer (`methods/tracer/trace_batch.wgsl` with the shading layer's `radiance.wgsl`) against its f32 CPU twin (`methods::tracer::trace_batch` with `shading::gpu::radiance`) and
//! against the f64 CPU tracer, on small images of the study's own scenes (the design file,
//! shrunk to 64 x 36), plus the physics tests of `tracer_physics.rs` that have a closed
//! form (white furnace, motion coverage) and the f32 hard cases. Without a GPU adapter each
//! test says SKIPPED (and fails under `BLURLAB_REQUIRE_GPU=1`).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use common::agreement::{H, W, assert_noise_apart, checker, design, hard_cases, study_scene};
use common::{
    assert_coverage_matches, assert_white_furnace, coverage_scene, furnace_scene, scene, study_camera, uniform,
};
use glam::DVec3;
use render::env::EnvironmentMap;
use render::io::LinearImage;
use render::methods::tracer::GpuTracer;
use render::methods::tracer::trace_batch;
use render::shading::gpu::params::{EnvTables, Specialisation, material_kind};
use study::ids::View;
use study::scene::{FrameScene, Shutter};

fn tracer(test: &str) -> Option<GpuTracer> {
    let ctx = gpu::test_context(test)?;
    Some(GpuTracer::new(ctx).expect("the tracer kernel compiles"))
}

fn max_abs_difference(a: &LinearImage, b: &LinearImage) -> (f32, usize) {
    let mut worst = (0.0f32, 0);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let d = (p[c] - q[c]).abs() / (1.0 + q[c].abs());
            if d > worst.0 {
                worst = (d, i);
            }
        }
    }
    worst
}

#[test]
fn the_kernel_agrees_with_its_cpu_twin_per_pixel() {
    let Some(gpu) = tracer("the_kernel_agrees_with_its_cpu_twin_per_pixel") else { return };
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let mut worst_all = 0.0f32;
    for material in 1..=3 {
        for shutter in [1, 5] {
            // Samples through the pixel centres (the tracer's `pixel_jitter = false`) on the
            // checker, mono, too.
            let cases: &[(View, bool)] = if material == 2 {
                &[(View::Mono, true), (View::Stereo, true), (View::Mono, false)]
            } else {
                &[(View::Mono, true), (View::Stereo, true)]
            };
            for &(view, jitter) in cases {
                let mut s = study_scene(&design, material, shutter, view, 8);
                s.pixel_jitter = jitter;
                let spec = Specialisation::of(&s);
                assert_eq!(spec.pixel_jitter, jitter);
                assert_eq!(spec.time_sampling, shutter == 5);
                let out = gpu.render_frame(&s, &genv).unwrap();
                let (twin, twin_bad) = trace_batch::render_frame(&s, genv.tables(), &spec).unwrap();
                assert_eq!(out.eyes.len(), twin.len());
                assert_eq!(out.nonfinite_samples, twin_bad);
                assert_eq!(out.camera_samples, u64::from(W * H * 8) * twin.len() as u64);
                for (g, t) in out.eyes.iter().zip(&twin) {
                    // Tolerance: 1e-4 relative per channel. The same operations in the same
                    // order differ only where the device rounds a division or square root
                    // otherwise (Vulkan allows 2.5 ulp and 3 ulp); lavapipe agrees far closer.
                    let (worst, at) = max_abs_difference(g, t);
                    worst_all = worst_all.max(worst);
                    assert!(
                        worst < 1e-4,
                        "M{material} T{shutter} {view:?}: pixel {at} GPU {:?} twin {:?}",
                        g.pixels[at],
                        t.pixels[at]
                    );
                    let mean: f32 = g.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>();
                    assert!(mean > 0.0, "an image with light in it");
                }
            }
        }
    }
    eprintln!("largest relative difference GPU - twin: {worst_all:e}");
}

fn assert_agrees_with_f64(gpu: &GpuTracer, s: &FrameScene, what: &str) {
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let g = gpu.render_frame(s, &genv).unwrap();
    assert_eq!(g.nonfinite_samples, 0, "{what}: NaN or infinite samples on the GPU");
    assert_noise_apart(&g.eyes, &render::methods::tracer::render_frame(s, &env).unwrap().eyes, what);
}

#[test]
fn every_material_agrees_with_the_f64_tracer_within_monte_carlo_error() {
    let Some(gpu) = tracer("every_material_agrees_with_the_f64_tracer_within_monte_carlo_error") else { return };
    let design = design();
    for material in 1..=3 {
        for shutter in [1, 5] {
            let s = study_scene(&design, material, shutter, View::Mono, 32);
            assert_agrees_with_f64(&gpu, &s, &format!("M{material}-S3-T{shutter}"));
        }
    }
}

#[test]
fn specialisations_change_the_cost_not_the_image() {
    // A still frame rendered by the time-sampling kernel, and a flat sphere by the noise
    // kernel (whose blend of two equal albedos is that albedo), give the same bytes: sample
    // values do not depend on which dimensions are drawn.
    let Some(gpu) = tracer("specialisations_change_the_cost_not_the_image") else { return };
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let still = study_scene(&design, 1, 1, View::Stereo, 4);
    let cheapest = Specialisation::of(&still);
    assert_eq!(cheapest, Specialisation { time_sampling: false, material: material_kind::FLAT, pixel_jitter: true });
    let base = gpu.render_frame(&still, &genv).unwrap();
    for spec in [
        Specialisation { time_sampling: true, material: material_kind::FLAT, pixel_jitter: true },
        Specialisation { time_sampling: true, material: material_kind::NOISE, pixel_jitter: true },
        Specialisation { time_sampling: false, material: material_kind::NOISE, pixel_jitter: true },
    ] {
        let other = gpu.render_frame_with(&still, &genv, spec).unwrap();
        assert_eq!(other.eyes, base.eyes, "{spec:?}");
    }
    // And a zero-length shutter with time sampling forced on (the hard case of a shutter
    // interval of no width) is the still frame too.
    let mut moving = study_scene(&design, 3, 1, View::Mono, 4);
    moving.shutter = Shutter { open: moving.shutter.open, close: moving.shutter.open };
    let a = gpu.render_frame(&moving, &genv).unwrap();
    let b = gpu
        .render_frame_with(
            &moving,
            &genv,
            Specialisation { time_sampling: true, material: material_kind::NOISE, pixel_jitter: true },
        )
        .unwrap();
    assert_eq!(a.eyes, b.eyes);
    assert_eq!(b.nonfinite_samples, 0);
}

#[test]
fn white_furnace_on_the_gpu() {
    let Some(gpu) = tracer("white_furnace_on_the_gpu") else { return };
    let s = furnace_scene();
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let out = gpu.render_frame(&s, &genv).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    assert_white_furnace(&out.eyes[0]);
}

#[test]
fn motion_coverage_on_the_gpu_matches_the_analytic_fraction() {
    let Some(gpu) = tracer("motion_coverage_on_the_gpu_matches_the_analytic_fraction") else { return };
    let s = coverage_scene(2.238, 1.0, 128);
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    assert_coverage_matches(&s, &gpu.render_frame(&s, &genv).unwrap().eyes[0], 128);
}

#[test]
fn f32_hard_cases_stay_finite_and_agree_with_the_f64_tracer() {
    let Some(gpu) = tracer("f32_hard_cases_stay_finite_and_agree_with_the_f64_tracer") else { return };
    for (s, what) in hard_cases() {
        assert_agrees_with_f64(&gpu, &s, what);
    }

    // A zero-length shutter on a moving sphere with time sampling forced on.
    let mut s = scene(study_camera(W, H), checker(), uniform(0.8), 16);
    s.sphere.velocity = DVec3::new(2.238, 0.0, 0.0);
    s.shutter = Shutter { open: 0.02, close: 0.02 };
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let forced = Specialisation { time_sampling: true, material: material_kind::CHECKER, pixel_jitter: true };
    let out = gpu.render_frame_with(&s, &genv, forced).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    assert_eq!(out.eyes, gpu.render_frame(&s, &genv).unwrap().eyes);
    let (twin, _) = trace_batch::render_frame(&s, &EnvTables::new(&env), &forced).unwrap();
    assert!(max_abs_difference(&out.eyes[0], &twin[0]).0 < 1e-4);
}

#[test]
fn nested_prefixes_are_the_lower_sample_counts_of_the_same_stream() {
    let Some(gpu) = tracer("nested_prefixes_are_the_lower_sample_counts_of_the_same_stream") else { return };
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let top = study_scene(&design, 3, 5, View::Stereo, 16);
    let nested = gpu.submit_nested(&top, &genv, &[12, 4, 4, 0, 99]).unwrap().finish().unwrap();
    let levels: Vec<u32> = nested.prefixes.iter().map(|p| p.samples_per_pixel).collect();
    assert_eq!(levels, [4, 12], "duplicates, zero and counts above the stream's are dropped");
    assert_eq!(nested.eyes, gpu.render_frame(&top, &genv).unwrap().eyes, "the full stream is the plain frame");
    let mut previous = 0.0;
    for prefix in &nested.prefixes {
        let mut alone = top.clone();
        alone.samples_per_pixel = prefix.samples_per_pixel;
        let frame = gpu.render_frame(&alone, &genv).unwrap();
        assert_eq!(prefix.camera_samples, frame.camera_samples);
        assert_eq!(prefix.nonfinite_samples, frame.nonfinite_samples);
        for (a, b) in prefix.eyes.iter().zip(&frame.eyes) {
            // The same samples; only the division by the count is rounded differently.
            let (worst, at) = max_abs_difference(a, b);
            assert!(
                worst < 1e-6,
                "{} spp: pixel {at}: {:?} vs {:?}",
                prefix.samples_per_pixel,
                a.pixels[at],
                b.pixels[at]
            );
        }
        if let Some(t) = prefix.gpu_seconds {
            assert!(t >= previous && t <= nested.gpu_seconds.unwrap());
            previous = t;
        }
    }
}

#[test]
fn overflowing_samples_are_counted_and_discarded_as_the_twin_does() {
    // A furnace lit at 3e38, near the f32 limit: the f64 tracer's sums stay finite, but in
    // f32 a path that picks up the sky twice overflows. Those samples are discarded and
    // counted, the image stays finite, and GPU and twin agree on the count.
    let Some(gpu) = tracer("overflowing_samples_are_counted_and_discarded_as_the_twin_does") else { return };
    let mut s = furnace_scene();
    s.lighting.environment = uniform(3.0e38);
    s.samples_per_pixel = 8;
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let out = gpu.render_frame(&s, &genv).unwrap();
    let (twin, twin_bad) = trace_batch::render_frame(&s, genv.tables(), &Specialisation::of(&s)).unwrap();
    assert!(out.nonfinite_samples > 0, "no sample overflowed");
    assert!(out.nonfinite_samples < out.camera_samples / 2, "{} of {}", out.nonfinite_samples, out.camera_samples);
    assert_eq!(out.nonfinite_samples, twin_bad);
    assert!(out.eyes[0].pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(max_abs_difference(&out.eyes[0], &twin[0]).0 < 1e-4);
}

#[test]
fn a_frame_split_into_many_dispatches_is_the_frame_of_one() {
    // Each dispatch carries the pixels' f32 sums on in the accumulator, so splitting the
    // samples into batches changes nothing, also across nested checkpoints.
    let Some(gpu) = tracer("a_frame_split_into_many_dispatches_is_the_frame_of_one") else { return };
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let genv = gpu.environment(&env).unwrap();
    let s = study_scene(&design, 2, 5, View::Stereo, 11);
    let whole = gpu.submit_nested(&s, &genv, &[4]).unwrap().finish().unwrap();
    let split = gpu.with_samples_per_dispatch(u64::from(3 * W * H));
    let genv = split.environment(&env).unwrap();
    let parts = split.submit_nested(&s, &genv, &[4]).unwrap().finish().unwrap();
    // 11 samples in batches of 3, split at 4: 3 + 1 + 3 + 3 + 1 per eye.
    assert_eq!((whole.dispatches, parts.dispatches), (4, 10));
    assert_eq!(parts.eyes, whole.eyes);
    assert_eq!(parts.prefixes[0].eyes, whole.prefixes[0].eyes);
    assert_eq!(parts.nonfinite_samples, whole.nonfinite_samples);
}
