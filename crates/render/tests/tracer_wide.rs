//! The wide CPU tracer (`methods::tracer::wide`): the f32 twin's bytes on every instruction
//! set and thread count, the GPU tracer's prefixes, and the f64 reference within Monte
//! Carlo error on the study's scenes and the f32 hard cases (the paired 8 x 8-block z-tests
//! of `tracer_gpu.rs`), with the closed-form physics tests of `tracer_physics.rs`. No GPU
//! needed: these run everywhere.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use common::agreement::{H, W, assert_noise_apart, checker, design, hard_cases, study_scene};
use common::{
    assert_coverage_matches, assert_white_furnace, coverage_scene, furnace_scene, scene, study_camera, uniform,
};
use glam::DVec3;
use render::env::EnvironmentMap;
use render::methods::tracer::trace_batch;
use render::methods::tracer::wide::{self, Isa};
use render::shading::gpu::params::{EnvTables, Specialisation};
use study::ids::View;
use study::scene::{FrameScene, Shutter};

fn wide_on(isa: Isa, s: &FrameScene, tables: &EnvTables) -> render::methods::tracer::FrameOutput {
    wide::render_frame_nested(s, tables, &[], isa).unwrap().pop().unwrap()
}

#[test]
fn every_instruction_set_renders_the_twins_bytes() {
    // The same operations in the same order on every path, no fused multiply-add anywhere:
    // the f32 twin's frame exactly. 20 samples: a full packet of 16 and a partial one; 1, 3
    // and 5: packets of 16, 5 and 3 pixels, the row's last one partial for 3 and 5 (64
    // pixels across).
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let tables = EnvTables::new(&env);
    let isas = Isa::available();
    eprintln!("instruction sets here: {isas:?}");
    assert_eq!(isas.last(), Some(&Isa::Baseline));
    for material in 1..=3 {
        for shutter in [1, 5] {
            for view in [View::Mono, View::Stereo] {
                for spp in [20, 1, 3, 5] {
                    let mut s = study_scene(&design, material, shutter, view, spp);
                    s.pixel_jitter = !(material == 2 && view == View::Mono);
                    let (twin, twin_bad) = trace_batch::render_frame(&s, &tables, &Specialisation::of(&s)).unwrap();
                    let what = format!("M{material} T{shutter} {view:?} {spp} spp");
                    for &isa in &isas {
                        let out = wide_on(isa, &s, &tables);
                        assert_eq!(out.nonfinite_samples, twin_bad, "{what} on {isa}");
                        assert_eq!(out.camera_samples, u64::from(W * H * spp) * twin.len() as u64);
                        assert!(out.eyes == twin, "{what} on {isa}: not the twin's bytes");
                    }
                }
            }
        }
    }
}

#[test]
fn the_thread_count_does_not_change_a_byte() {
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let tables = EnvTables::new(&env);
    let s = study_scene(&design, 3, 5, View::Stereo, 16);
    let on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| wide::render_frame(&s, &tables).unwrap().eyes)
    };
    let one = on(1);
    assert!(one == on(2) && one == on(3));
}

#[test]
fn nested_prefixes_are_the_gpu_tracers_read_outs() {
    // Prefix k is the running sum of the first k samples (each divided by the full count)
    // scaled by spp / k, which is how the GPU tracer reads its prefixes out; it equals
    // rendering k samples alone up to the rounding of that division.
    let design = design();
    let env = EnvironmentMap::from_lighting(&design.lighting).unwrap();
    let tables = EnvTables::new(&env);
    // 40 samples: packets of one pixel; 6: packets of two pixels.
    for (spp, checkpoints, expected) in
        [(40, &[12, 4, 4, 0, 99, 33][..], &[4, 12, 33, 40][..]), (6, &[2, 5, 6, 7][..], &[2, 5, 6][..])]
    {
        let top = study_scene(&design, 3, 5, View::Stereo, spp);
        let levels = wide::render_frame_nested(&top, &tables, checkpoints, Isa::widest()).unwrap();
        let counts: Vec<u64> = levels.iter().map(|l| l.camera_samples / u64::from(2 * W * H)).collect();
        assert_eq!(counts, expected, "duplicates, zero and counts above the stream's are dropped");
        assert!(levels.last().unwrap().eyes == wide::render_frame(&top, &tables).unwrap().eyes);
        assert_prefixes_render_alone(&top, &tables, &levels[..levels.len() - 1]);
    }
}

fn assert_prefixes_render_alone(top: &FrameScene, tables: &EnvTables, levels: &[render::methods::tracer::FrameOutput]) {
    for level in levels {
        let mut alone = top.clone();
        alone.samples_per_pixel = (level.camera_samples / u64::from(2 * W * H)) as u32;
        let frame = wide::render_frame(&alone, tables).unwrap();
        assert_eq!(level.nonfinite_samples, frame.nonfinite_samples);
        for (a, b) in level.eyes.iter().zip(&frame.eyes) {
            for (p, q) in a.pixels.iter().zip(&b.pixels) {
                for c in 0..3 {
                    assert!((p[c] - q[c]).abs() <= 1e-6 * (1.0 + q[c].abs()), "{p:?} vs {q:?}");
                }
            }
        }
    }
}

fn assert_agrees_with_f64(s: &FrameScene, what: &str) {
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let w = wide::render_frame(s, &EnvTables::new(&env)).unwrap();
    assert_eq!(w.nonfinite_samples, 0, "{what}: NaN or infinite samples");
    assert_noise_apart(&w.eyes, &render::methods::tracer::render_frame(s, &env).unwrap().eyes, what);
}

#[test]
fn every_material_agrees_with_the_f64_tracer_still_and_blurred_mono_and_stereo() {
    let design = design();
    for material in 1..=3 {
        for shutter in [1, 5] {
            let view = if material == 2 { View::Stereo } else { View::Mono };
            let s = study_scene(&design, material, shutter, view, 32);
            assert_agrees_with_f64(&s, &format!("M{material}-S3-T{shutter} {view:?}"));
        }
    }
    let s = study_scene(&design, 3, 5, View::Stereo, 32);
    assert_agrees_with_f64(&s, "M3-S3-T5 stereo");
}

#[test]
fn f32_hard_cases_stay_finite_and_agree_with_the_f64_tracer() {
    for (s, what) in hard_cases() {
        assert_agrees_with_f64(&s, what);
    }

    // A zero-length shutter on a moving sphere: the still frame, bytes and all.
    let mut s = scene(study_camera(W, H), checker(), uniform(0.8), 16);
    s.sphere.velocity = DVec3::new(2.238, 0.0, 0.0);
    s.shutter = Shutter { open: 0.02, close: 0.02 };
    let env = EnvTables::new(&EnvironmentMap::from_lighting(&s.lighting).unwrap());
    let zero_length = wide::render_frame(&s, &env).unwrap();
    assert_eq!(zero_length.nonfinite_samples, 0);
    let mut still = s.clone();
    still.sphere.velocity = DVec3::ZERO;
    still.sphere.start = s.sphere.centre_at(0.02);
    still.sphere.start_orientation = s.sphere.orientation_at(0.02);
    let still = wide::render_frame(&still, &env).unwrap();
    for (a, b) in zero_length.eyes[0].pixels.iter().zip(&still.eyes[0].pixels) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-5 * (1.0 + b[c]), "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn white_furnace() {
    let s = furnace_scene();
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let out = wide::render_frame(&s, &EnvTables::new(&env)).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    assert_white_furnace(&out.eyes[0]);
}

#[test]
fn motion_coverage_matches_the_analytic_fraction() {
    let s = coverage_scene(2.238, 1.0, 128);
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    assert_coverage_matches(&s, &wide::render_frame(&s, &EnvTables::new(&env)).unwrap().eyes[0], 128);
}

#[test]
fn overflowing_samples_are_counted_and_discarded_as_the_twin_does() {
    // A furnace lit at 3e38: a path that picks up the sky twice overflows f32. Those samples
    // are discarded and counted on every path, as the twin does.
    let mut s = furnace_scene();
    s.lighting.environment = uniform(3.0e38);
    s.samples_per_pixel = 8;
    let tables = EnvTables::new(&EnvironmentMap::from_lighting(&s.lighting).unwrap());
    let (twin, twin_bad) = trace_batch::render_frame(&s, &tables, &Specialisation::of(&s)).unwrap();
    for isa in Isa::available() {
        let out = wide_on(isa, &s, &tables);
        assert!(out.nonfinite_samples > 0, "no sample overflowed");
        assert!(out.nonfinite_samples < out.camera_samples / 2);
        assert_eq!(out.nonfinite_samples, twin_bad);
        assert!(out.eyes == twin);
        assert!(out.eyes[0].pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }
}
