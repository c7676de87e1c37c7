//! The methods on a GPU `Renderer` (lavapipe in CI): the post-process filters run on the
//! GPU over the GPU tracer's G-buffer and must equal their CPU twins applied to that same
//! G-buffer (within 1/255); the accumulation buffer is the mean of the GPU tracer's instants;
//! both record GPU time.

mod common;

use common::{L, flat, scene, study_camera, uniform};
use glam::DVec3;
use render::env::EnvironmentMap;
use render::io::LinearImage;
use render::method::filter_seed;
use render::methods::guertin::GuertinParams;
use render::methods::mcguire::McGuireParams;
use render::methods::post_process::gbuffer::{FloorMotion, gbuffers};
use render::{DeviceChoice, Renderer};
use study::Method;
use study::method::MethodSpec;
use study::scene::{FrameScene, Shutter};

fn moving_scene() -> FrameScene {
    let mut s = scene(study_camera(64, 36), flat(0.6), uniform(L), 4);
    s.sphere.velocity = DVec3::new(2.0, 0.0, 0.0);
    s.shutter = Shutter { open: -1.0 / 60.0, close: 1.0 / 60.0 };
    s
}

fn gpu_renderer<'e>(test: &str, env: &'e EnvironmentMap) -> Option<Renderer<'e>> {
    match Renderer::open(DeviceChoice::Gpu, env) {
        Ok(r) => Some(r),
        Err(e) => {
            gpu::skip_or_fail(test, &e);
            None
        }
    }
}

fn split(image: &LinearImage) -> Vec<LinearImage> {
    vec![image.clone()]
}

#[test]
fn gpu_filters_over_the_gpu_gbuffer_equal_their_cpu_twins() {
    let s = moving_scene();
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let Some(renderer) = gpu_renderer("gpu_filters_over_the_gpu_gbuffer_equal_their_cpu_twins", &env) else {
        return;
    };
    let centre = s.at_instant(s.shutter.centre());
    let traced = renderer.render(&MethodSpec::of(Method::Tracer), &centre).unwrap();
    let g = gbuffers(&s, split(&traced.image), FloorMotion::Surface).remove(0);
    assert!(g.velocity.iter().any(|v| v[0] > 1.0), "the sphere moves in the G-buffer");
    let seed = filter_seed(s.views[0].seed);
    for kind in [Method::Mcguire, Method::Guertin] {
        let spec = MethodSpec::of(kind);
        let frame = renderer.render(&spec, &s).unwrap();
        let twin = match &spec {
            MethodSpec::Mcguire(m) => render::methods::mcguire::mcguire_cpu(&g, &McGuireParams::from_settings(m, seed)),
            MethodSpec::Guertin(m) => render::methods::guertin::guertin_cpu(&g, &GuertinParams::from_settings(m, seed)),
            other => panic!("not a filter: {other:?}"),
        };
        let worst = frame
            .image
            .pixels
            .iter()
            .zip(&twin)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0.0f32, f32::max);
        assert!(worst <= 1.0 / 255.0, "{kind}: GPU frame and CPU twin differ by {worst}");
        assert!(frame.image != traced.image, "{kind} blurs the moving sphere");
        assert!(frame.gpu_seconds.is_some_and(|t| t > 0.0), "{kind}: GPU time recorded");
    }
}

#[test]
fn gpu_accumulation_buffer_is_the_mean_of_the_gpu_instants() {
    let s = moving_scene();
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let Some(renderer) = gpu_renderer("gpu_accumulation_buffer_is_the_mean_of_the_gpu_instants", &env) else {
        return;
    };
    let settings = study::method::AccumSettings { instants: Some(4), ..Default::default() };
    let frame = renderer.render(&MethodSpec::Accum(settings.clone()), &s).unwrap();
    let instants: Vec<Vec<LinearImage>> = render::methods::accum::instants::instant_scenes(&s, &settings)
        .iter()
        .map(|i| split(&renderer.render(&MethodSpec::of(Method::Tracer), i).unwrap().image))
        .collect();
    assert_eq!(instants.len(), 4);
    assert_eq!(frame.image, render::methods::accum::instants::average(&instants).remove(0));
    assert_eq!(frame.camera_samples, 4 * 64 * 36);
}

#[test]
fn the_analytic_method_on_a_gpu_renderer_runs_its_kernel() {
    let s = moving_scene();
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let Some(renderer) = gpu_renderer("the_analytic_method_on_a_gpu_renderer_runs_its_kernel", &env) else {
        return;
    };
    let settings = study::method::AnalyticSettings {
        intervals: Some(8),
        tessellation: Some(16),
        lighting_samples: Some(2),
        ..Default::default()
    };
    let frame = renderer.render(&MethodSpec::Analytic(settings.clone()), &s).unwrap();
    let params = render::methods::analytic::AnalyticParams::from_settings(&settings).unwrap();
    // The kernel's own output (its f32 twin is held to it in tests/analytic_gpu.rs), not the
    // f64 CPU rasterizer's, whose shading samples differ.
    let ctx = gpu::test_context("the_analytic_method_on_a_gpu_renderer_runs_its_kernel").unwrap();
    let tracer = render::methods::tracer::GpuTracer::new(ctx.clone()).unwrap();
    let genv = tracer.environment(&env).unwrap();
    let kernel = render::methods::analytic::GpuAnalytic::new(ctx).unwrap();
    let direct = kernel.render_frame(&s, &genv, &params).unwrap();
    assert_eq!(frame.image.pixels, direct.eyes[0].pixels);
    let cpu = render::methods::analytic::render_frame(&s, &env, &params).unwrap();
    assert_ne!(frame.image.pixels, cpu.eyes[0].pixels, "the GPU renderer must not fall back to the CPU rasterizer");
    assert_eq!(frame.camera_samples, direct.lighting_samples);
}
