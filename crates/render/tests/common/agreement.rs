//! What the f32 tracers' tests (GPU kernel, wide CPU tracer) share: the study's scenes
//! shrunk to 64 x 36, the paired block z-test against the f64 tracer, and the f32 hard
//! cases.

use glam::DVec3;
use render::io::LinearImage;
use study::design::Design;
use study::ids::{StimulusId, View};
use study::scene::{FrameScene, Material, Shutter};

use super::{flat, scene, study_camera};

/// Image size of these tests.
pub const W: u32 = 64;
/// Image size of these tests.
pub const H: u32 = 36;

/// The study's design.
pub fn design() -> Design {
    Design::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml")).unwrap()
}

/// Stimulus `M{m}-S3-T{t}` of the study at the benchmark frame (the sphere near the image
/// centre), at `spp` samples per pixel, every eye shrunk to 64 x 36 pixels.
pub fn study_scene(design: &Design, material: u8, shutter: u8, view: View, spp: u32) -> FrameScene {
    let frame = render::measure::tracer::benchmark_frame(design, 1, false).unwrap().frame;
    let id = StimulusId { material, speed: 3, shutter, samples: 1, method: None, view };
    let mut s = design.frame_scene(&id, frame).unwrap();
    s.samples_per_pixel = spp;
    for v in &mut s.views {
        (v.camera.width, v.camera.height) = (W, H);
    }
    s
}

/// Per 8 x 8 block and channel, the paired difference of two independent renders of the
/// same scene: its mean over the block divided by its standard error (from the block's own
/// differences). Both estimators unbiased, each z is about standard normal.
pub fn block_z_scores(a: &LinearImage, b: &LinearImage) -> Vec<f64> {
    let mut out = Vec::new();
    for by in 0..a.height / 8 {
        for bx in 0..a.width / 8 {
            for c in 0..3 {
                let d: Vec<f64> = (0..64)
                    .map(|k| {
                        let (x, y) = (bx * 8 + k % 8, by * 8 + k / 8);
                        f64::from(a.get(x, y)[c]) - f64::from(b.get(x, y)[c])
                    })
                    .collect();
                let s = study::stats::Summary::of(&d);
                let se = s.standard_error();
                out.push(if se > 0.0 {
                    s.mean / se
                } else if s.mean == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                });
            }
        }
    }
    out
}

/// Asserts that an f32 tracer's eyes differ from the f64 tracer's by noise alone.
pub fn assert_noise_apart(f32_eyes: &[LinearImage], f64_eyes: &[LinearImage], what: &str) {
    assert_eq!(f32_eyes.len(), f64_eyes.len(), "{what}");
    for (ge, ce) in f32_eyes.iter().zip(f64_eyes) {
        assert!(ge.pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{what}");
        let z = block_z_scores(ge, ce);
        // 4.5 sd: over all blocks of all tests here (about 2,000 z-scores) a false alarm has
        // probability about 1e-2; a bias of a few per cent fails many blocks at once.
        let worst = z.iter().fold(0.0f64, |m, z| m.max(z.abs()));
        let rms = (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt();
        eprintln!("{what}: {} blocks, largest |z| {worst:.2}, RMS z {rms:.2}", z.len());
        assert!(worst < 4.5, "{what}: a block differs by {worst:.2} standard errors");
        assert!(rms < 1.6, "{what}: RMS z {rms:.2}: the difference is not noise");
    }
}

/// The checker of the hard cases.
pub fn checker() -> Material {
    Material::Checker { albedo_a: [0.8; 3], albedo_b: [0.1; 3], squares_around: 16, squares_pole_to_pole: 8 }
}

/// The f32 hard cases judged against the f64 tracer, each with its name.
pub fn hard_cases() -> Vec<(FrameScene, &'static str)> {
    let lit = super::default_env();
    // The sphere far from the origin (the wrapped path puts it metres away; here 40 m),
    // moving, with the camera following at the study's distance.
    let far = DVec3::new(40.0, 0.0, -25.0);
    let mut distant = scene(study_camera(W, H), checker(), lit.clone(), 32);
    distant.sphere.start += far;
    distant.sphere.velocity = DVec3::new(2.238, 0.0, 0.0);
    distant.shutter = Shutter { open: 0.0, close: 1.0 / 30.0 };
    distant.views[0].camera = study::scene::Camera::look_at(
        DVec3::new(0.0, 0.5, 3.0) + far,
        DVec3::new(0.0, 0.1, 0.0) + far,
        0.05,
        0.036,
        W,
        H,
    );
    // Grazing rays: the camera 1 mm above the floor, looking along it at the sphere's
    // silhouette and contact point.
    let mut grazing = scene(study_camera(W, H), checker(), lit.clone(), 32);
    grazing.views[0].camera =
        study::scene::Camera::look_at(DVec3::new(0.0, 0.001, 1.0), DVec3::new(0.0, 0.001, 0.0), 0.05, 0.036, W, H);
    // Self-intersection: a close-up of the contact region, where every secondary ray starts
    // on a surface and most shadow rays pass within a hair of the other one. Acne would
    // darken it against the f64 tracer.
    let mut contact = scene(study_camera(W, H), flat(0.7), lit, 32);
    contact.views[0].camera =
        study::scene::Camera::look_at(DVec3::new(0.0, 0.05, 0.4), DVec3::new(0.0, 0.01, 0.0), 0.05, 0.036, W, H);
    vec![
        (distant, "sphere 47 m from the origin"),
        (grazing, "grazing the floor and the silhouette"),
        (contact, "contact point close-up"),
    ]
}
