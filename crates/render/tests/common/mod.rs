//! Scenes shared by the CPU and GPU tracer tests.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]
#![allow(dead_code)]

use glam::{DQuat, DVec3};
use study::ids::{StimulusId, View};
use study::scene::{
    Camera, Environment, Exposure, EyeView, Floor, FrameScene, Integrator, Lighting, Material, RollingSphere, Shutter,
    ToneMap,
};
use study::seed::Eye;

pub mod agreement;

/// Radiance of the uniform environments.
pub const L: f64 = 0.8;

pub fn scene(camera: Camera, material: Material, environment: Environment, spp: u32) -> FrameScene {
    FrameScene {
        stimulus: StimulusId { material: 1, speed: 1, shutter: 1, samples: 1, method: None, view: View::Mono },
        frame: 0,
        frame_time: 0.0,
        shutter: Shutter { open: 0.0, close: 0.0 },
        views: vec![EyeView { eye: Eye::Centre, camera, seed: 12345 }],
        sphere: RollingSphere {
            radius: 0.1,
            start: DVec3::new(0.0, 0.1, 0.0),
            velocity: DVec3::ZERO,
            start_orientation: DQuat::from_rotation_y(0.3),
            floor_normal: DVec3::Y,
            wrap_length: None,
        },
        material,
        floor: Floor { height: 0.0, albedo: [0.5; 3] },
        lighting: Lighting { environment, intensity: 1.0, rotation_y: 0.0 },
        samples_per_pixel: spp,
        pixel_jitter: true,
        antialias: None,
        integrator: Integrator { max_bounces: 4, russian_roulette_from: 3 },
        exposure: Exposure { stops: 0.0, tone_map: ToneMap::Reinhard },
        medium: None,
    }
}

pub fn study_camera(width: u32, height: u32) -> Camera {
    Camera::look_at(DVec3::new(0.0, 0.5, 3.0), DVec3::new(0.0, 0.1, 0.0), 0.05, 0.036, width, height)
}

pub fn uniform(l: f64) -> Environment {
    Environment::Uniform { radiance: [l; 3] }
}

pub fn flat(albedo: f64) -> Material {
    Material::Flat { albedo: [albedo; 3] }
}

/// A horizontal camera at the sphere's height, looking along -z at a narrow strip; the
/// sphere is black, the sky uniform and the floor a perfect white reflector far below,
/// so a pixel's value is L times the fraction of (area x shutter time) not covered.
pub fn coverage_scene(speed: f64, shutter_fraction: f64, spp: u32) -> FrameScene {
    let camera = Camera::look_at(DVec3::new(0.0, 0.1, 3.0), DVec3::new(0.0, 0.1, 0.0), 0.05, 0.036, 320, 4);
    let mut s = scene(camera, flat(0.0), uniform(L), spp);
    s.sphere.velocity = DVec3::new(speed, 0.0, 0.0);
    s.sphere.start = DVec3::new(0.0, 0.1, 0.0);
    s.floor = Floor { height: -1.0e4, albedo: [1.0; 3] };
    let duration = shutter_fraction / 30.0;
    s.frame_time = 0.0;
    s.shutter = Shutter { open: -0.5 * duration, close: 0.5 * duration };
    s
}

/// The exact coverage of pixel `(x, y)` by the moving sphere over area and shutter time:
/// the analytic rasterizer's closed form for the untessellated sphere
/// (`render::methods::analytic::sphere`), on a 24 x 24 lattice of points in the pixel.
pub fn exact_coverage(s: &FrameScene, x: u32, y: u32) -> f64 {
    render::methods::analytic::sphere::pixel_coverage(s, 0, x, y, 24)
}

/// The built-in default environment at a small size.
pub fn default_env() -> Environment {
    Environment::Default { width: 256 }
}

/// The white furnace: albedo 1 everywhere, a uniform environment, no effective bounce
/// limit, the camera framing the sphere and its contact region; every pixel's expected
/// value is L.
pub fn furnace_scene() -> FrameScene {
    let mut s = scene(study_camera(48, 27), flat(1.0), uniform(L), 32);
    s.floor.albedo = [1.0; 3];
    s.integrator = Integrator { max_bounces: 10_000, russian_roulette_from: 3 };
    s.views[0].camera = Camera::look_at(DVec3::new(0.0, 0.25, 0.8), DVec3::new(0.0, 0.08, 0.0), 0.05, 0.036, 48, 27);
    s
}

/// Checks a render of [`furnace_scene`]: the mean of its first channel over every pixel is
/// `L` within 3 standard errors (plus 1e-5), the standard error positive (the frame is a
/// Monte Carlo estimate, not a constant) and under 0.01.
pub fn assert_white_furnace(img: &render::io::LinearImage) {
    let values: Vec<f64> = img.pixels.iter().map(|p| f64::from(p[0])).collect();
    let summary = study::stats::Summary::of(&values);
    let se = summary.standard_error();
    assert!(se > 0.0 && se < 0.01, "se {se}");
    assert!((summary.mean - L).abs() < 3.0 * se + 1e-5, "mean {} vs {L}, se {se}", summary.mean);
}

/// Checks row 1 of a render of `coverage_scene(.., spp)` against [`exact_coverage`]
/// pixel by pixel: within 3 binomial standard errors of a coverage estimate from `spp`
/// stratified samples (at most `sqrt(c (1 - c) / spp)`) plus 0.01, and with at least 16
/// partially covered pixels.
pub fn assert_coverage_matches(s: &FrameScene, img: &render::io::LinearImage, spp: u32) {
    let mut compared = 0;
    for x in 0..img.width {
        let expected = exact_coverage(s, x, 1);
        let measured = 1.0 - f64::from(img.get(x, 1)[0]) / L;
        let se = (expected * (1.0 - expected) / f64::from(spp)).sqrt();
        assert!((measured - expected).abs() < 3.0 * se + 0.01, "x {x}: measured {measured}, analytic {expected}");
        if expected > 0.05 && expected < 0.95 {
            compared += 1;
        }
    }
    assert!(compared >= 16, "only {compared} partially covered pixels");
}

/// The design's benchmark frame (M3-S3-T5, `render::measure::tracer::benchmark_frame`) at
/// `width` x `height` and `spp`, its field of view narrowed `zoom` times.
pub fn study_frame(width: u32, height: u32, spp: u32, zoom: f64) -> FrameScene {
    let design = study::design::Design::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
    )
    .unwrap();
    let mut s = render::measure::tracer::benchmark_frame(&design, spp, false).unwrap();
    for view in &mut s.views {
        (view.camera.width, view.camera.height) = (width, height);
        view.camera.sensor_width /= zoom;
    }
    s
}
