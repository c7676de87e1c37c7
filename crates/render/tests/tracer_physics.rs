//! Physics tests of the CPU tracer: white furnace, a known lighting integral, motion blur
//! geometry and coverage, rolling, stereo noise independence, convergence, determinism
//! and hard cases. Scenes are built directly from `study::scene` types. Tolerances come
//! from Monte Carlo standard errors estimated from the renders themselves.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use common::*;
use glam::{DVec2, DVec3};
use render::env::{EnvironmentMap, default_map};
use render::io::LinearImage;
use render::measure::tracer::freeze_at;
use render::methods::tracer::{FrameSetup, render_frame};
use render::numeric::solve_quadratic;
use study::ids::{StimulusId, View};
use study::scene::{Camera, Environment, EyeView, Floor, FrameScene, Integrator, Material, Shutter};
use study::seed::Eye;
use study::stats::correlation;

fn render(scene: &FrameScene) -> Vec<LinearImage> {
    let env = EnvironmentMap::from_lighting(&scene.lighting).unwrap();
    let out = render_frame(scene, &env).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    out.eyes
}

fn mean_and_se(values: &[f64]) -> (f64, f64) {
    let s = study::stats::Summary::of(values);
    (s.mean, s.standard_error())
}

fn channel(img: &LinearImage, c: usize) -> Vec<f64> {
    img.pixels.iter().map(|p| f64::from(p[c])).collect()
}

#[test]
fn white_furnace_converges_to_the_environment_radiance() {
    // Every surface, seen from anywhere, has the environment's radiance.
    let s = furnace_scene();
    let img = &render(&s)[0];
    let sphere_pixels: Vec<f64> = (0..img.pixels.len())
        .filter(|i| {
            let (x, y) = (i % 48, i / 48);
            let cam = &s.views[0].camera;
            let d = cam.ray_direction(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            let f = cam.position - s.sphere.start;
            let b = f.dot(d);
            b * b - (f.length_squared() - 0.01) > 0.0
        })
        .map(|i| f64::from(img.pixels[i][0]))
        .collect();
    assert!(sphere_pixels.len() > 100, "sphere covers {} pixels", sphere_pixels.len());
    for values in [channel(img, 0), sphere_pixels] {
        let (mean, se) = mean_and_se(&values);
        assert!(se > 0.0 && se < 0.01, "se {se}");
        assert!((mean - L).abs() < 3.0 * se + 1e-6, "mean {mean} vs {L}, se {se}");
    }
}

#[test]
fn furnace_with_a_bounce_limit_follows_the_geometric_series() {
    // With albedo rho, a floor that sees only the sky reflects rho L after one bounce; with
    // the floor seen through the sphere's reflection nothing else enters. The camera looks
    // down at the floor and the sphere is far away behind it.
    for (rho, bounces) in [(0.5, 1u32), (0.7, 3)] {
        let mut s = scene(
            Camera::look_at(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, -0.3), 0.05, 0.036, 32, 18),
            flat(rho),
            uniform(L),
            16,
        );
        s.sphere.start = DVec3::new(0.0, 0.1, 1.0e4);
        s.floor.albedo = [rho; 3];
        s.integrator = Integrator { max_bounces: bounces, russian_roulette_from: 2 };
        let img = &render(&s)[0];
        let (mean, se) = mean_and_se(&channel(img, 1));
        assert!((mean - rho * L).abs() < 3.0 * se + 1e-9, "rho {rho}: {mean} +- {se}");
    }
    // Zero bounces: surfaces are black; only the environment seen directly remains.
    let mut s = scene(study_camera(32, 18), flat(1.0), uniform(L), 4);
    s.floor.albedo = [1.0; 3];
    s.integrator = Integrator { max_bounces: 0, russian_roulette_from: 3 };
    let img = &render(&s)[0];
    // Box pixel filter, 4 samples: each pixel is L times the share of its camera rays that
    // escape to the sky, a multiple of L / 4, grey, and 0 where every ray meets a surface.
    for (i, p) in img.pixels.iter().enumerate() {
        let k = f64::from(p[0]) / (L / 4.0);
        assert!((k - k.round()).abs() < 1e-5 && (0.0..=4.0).contains(&k.round()), "pixel {i}: {p:?} is not k L / 4");
        assert!(p[1] == p[0] && p[2] == p[0], "pixel {i}: {p:?} is not grey");
    }
    assert_eq!(img.get(16, 17)[0], 0.0, "floor pixel without bounces");
    assert!((f64::from(img.get(16, 0)[0]) - L).abs() < 1e-6, "sky pixel {:?}", img.get(16, 0));
}

#[test]
fn each_bounce_multiplies_by_the_albedo_and_the_limit_cuts_the_series() {
    // Without Russian roulette the paths (directions, light samples, occlusion) do not
    // depend on the albedo rho shared by the sphere and the floor, so each pixel's
    // estimate is exactly L (c0 + c1 rho + ... + cB rho^B), where ck collects the paths
    // that scatter k times. Rendered at B + 2 equally spaced rho, the (B+1)-th finite
    // difference must vanish (no path scatters more than B times) while the B-th, B! h^B cB,
    // must not (the camera looks at the sphere's contact with the floor, where light
    // bounces between the two).
    let camera = Camera::look_at(DVec3::new(0.35, 0.22, 0.55), DVec3::new(0.0, 0.06, 0.0), 0.05, 0.036, 24, 16);
    let h = 0.2;
    for bounces in [1u32, 2, 3] {
        let images: Vec<LinearImage> = (0..bounces + 2)
            .map(|k| {
                let rho = 0.2 + h * f64::from(k);
                let mut s = scene(camera.clone(), flat(rho), uniform(L), 4);
                s.floor.albedo = [rho; 3];
                s.integrator = Integrator { max_bounces: bounces, russian_roulette_from: 100 };
                render(&s).remove(0)
            })
            .collect();
        let difference = |order: usize, px: usize| -> f64 {
            // Forward difference of `order` over the first order + 1 images.
            let mut binomial = 1.0;
            let mut sum = 0.0;
            for (j, image) in images.iter().enumerate().take(order + 1) {
                let sign = if (order - j).is_multiple_of(2) { 1.0 } else { -1.0 };
                sum += sign * binomial * f64::from(image.pixels[px][1]);
                binomial = binomial * (order - j) as f64 / (j + 1) as f64;
            }
            sum
        };
        let b = bounces as usize;
        let pixels = images[0].pixels.len();
        let beyond = (0..pixels).map(|px| difference(b + 1, px).abs()).fold(0.0, f64::max);
        let top = (0..pixels).map(|px| difference(b, px).abs()).fold(0.0, f64::max);
        // f32 pixels: the differences carry rounding of about 2^(B+1) x 6e-8 x L.
        assert!(beyond < 2e-5 * L, "B = {bounces}: the difference of order {} is {beyond}", b + 1);
        assert!(top > 1e-3 * L, "B = {bounces}: the difference of order {bounces} is only {top}");
    }
}

/// Irradiance of an upward normal under `map` by fine quadrature of the same piecewise
/// constant map the renderer sees.
fn irradiance_up(env: &EnvironmentMap) -> DVec3 {
    let n = 800;
    let mut sum = DVec3::ZERO;
    for i in 0..n / 2 {
        let theta = std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
        for j in 0..2 * n {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / (2 * n) as f64;
            let d = DVec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
            sum += env.radiance(d) * theta.cos() * theta.sin();
        }
    }
    sum * (std::f64::consts::PI / n as f64) * (2.0 * std::f64::consts::PI / (2 * n) as f64)
}

#[test]
fn mis_estimate_of_floor_irradiance_under_the_default_map() {
    // A floor lit only by the sky: radiance rho / pi * E, E the cosine-weighted integral of
    // the map over the upper hemisphere. One bounce: light sampling plus BSDF sampling
    // combined by MIS must reproduce the integral.
    let rho = 0.5;
    let mut s = scene(
        Camera::look_at(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, -0.3), 0.05, 0.036, 32, 18),
        flat(rho),
        Environment::Default { width: 256 },
        16,
    );
    s.sphere.start = DVec3::new(0.0, 0.1, 1.0e4);
    s.floor.albedo = [rho; 3];
    s.integrator = Integrator { max_bounces: 1, russian_roulette_from: 3 };
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let expected = irradiance_up(&env) * (rho / std::f64::consts::PI);
    let img = &render(&s)[0];
    for c in 0..3 {
        let (mean, se) = mean_and_se(&channel(img, c));
        assert!(
            (mean - expected[c]).abs() < 3.0 * se + 1e-4 * expected[c],
            "channel {c}: {mean} +- {se} vs {}",
            expected[c]
        );
    }
}

#[test]
fn time_averaged_coverage_matches_the_analytic_fraction_of_the_shutter() {
    let s = coverage_scene(2.238, 1.0, 128);
    assert_coverage_matches(&s, &render(&s)[0], 128);
}

/// Columns of row 1 whose coverage exceeds 2 %.
fn streak_extent(img: &LinearImage) -> usize {
    (0..img.width).filter(|&x| 1.0 - f64::from(img.get(x, 1)[0]) / L > 0.02).count()
}

#[test]
fn streak_grows_with_shutter_and_speed_as_geometry_predicts() {
    let px_per_m = {
        let s = coverage_scene(1.0, 0.0, 1);
        let cam = &s.views[0].camera;
        cam.project(DVec3::new(1.0, 0.1, 0.0)).unwrap().x - cam.project(DVec3::new(0.0, 0.1, 0.0)).unwrap().x
    };
    let mut previous = 0;
    for (speed, fraction) in [(2.238, 0.0), (2.238, 0.25), (2.238, 0.5), (2.238, 1.0), (4.0, 1.0)] {
        let s = coverage_scene(speed, fraction, 64);
        let img = &render(&s)[0];
        let extent = streak_extent(img) as f64;
        // The chord of row 1 (within a pixel of the centre line) is about the diameter;
        // the streak adds the distance travelled while the shutter is open.
        let predicted = (0.2 + speed * fraction / 30.0) * px_per_m;
        assert!((extent - predicted).abs() <= 2.0, "speed {speed} T {fraction}: extent {extent} vs {predicted}");
        assert!(extent as usize > previous || fraction == 0.0, "extent must grow");
        previous = extent as usize;
    }
}

#[test]
fn closed_shutter_is_sharp_and_equals_the_static_scene_byte_for_byte() {
    let mut moving = scene(
        study_camera(64, 36),
        Material::Checker { albedo_a: [0.8; 3], albedo_b: [0.1; 3], squares_around: 16, squares_pole_to_pole: 8 },
        Environment::Default { width: 128 },
        8,
    );
    moving.sphere.velocity = DVec3::new(2.238, 0.0, 0.0);
    moving.sphere.start = DVec3::new(-0.3, 0.1, 0.0);
    moving.shutter = Shutter { open: 0.1, close: 0.1 };
    let mut frozen = moving.clone();
    freeze_at(&mut frozen, 0.1);
    assert!(!FrameSetup::new(&moving).time_sampling && FrameSetup::new(&moving).textured);
    assert_ne!(moving.sphere, frozen.sphere);
    let a = render(&moving);
    let b = render(&frozen);
    assert!(a[0] == b[0], "T1 frame differs from the static scene");
    let png = |img: &LinearImage| render::io::encode_png_srgb(img, &moving.exposure);
    assert_eq!(png(&a[0]), png(&b[0]));
    // With an open shutter the same frame is different (the control).
    let mut open = moving.clone();
    open.shutter = Shutter { open: 0.1 - 1.0 / 60.0, close: 0.1 + 1.0 / 60.0 };
    assert!(FrameSetup::new(&open).time_sampling);
    assert!(render(&open)[0] != a[0]);
    // Flat material: no texture is evaluated.
    let mut f = moving.clone();
    f.material = flat(0.5);
    assert!(!FrameSetup::new(&f).textured);

    // And sharp: with the coverage scene at T1, partially covered pixels only occur at
    // the two silhouette edges (at most two per edge).
    let img = &render(&coverage_scene(2.238, 0.0, 64))[0];
    let partial = (0..320).filter(|&x| {
        let c = 1.0 - f64::from(img.get(x, 1)[0]) / L;
        c > 0.02 && c < 0.98
    });
    assert!(partial.count() <= 4);
}

#[test]
fn rendering_is_deterministic_and_independent_of_thread_count() {
    let mut s = scene(
        study_camera(40, 24),
        Material::Noise {
            albedo_a: [0.8, 0.7, 0.6],
            albedo_b: [0.1, 0.1, 0.4],
            base_frequency: 4.0,
            octaves: 4,
            seed: 7,
        },
        Environment::Default { width: 64 },
        4,
    );
    s.sphere.velocity = DVec3::new(1.5, 0.0, 0.0);
    s.shutter = Shutter { open: 0.0, close: 1.0 / 30.0 };
    let a = render(&s);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = pool.install(|| render(&s));
    assert!(a == b);
    let mut other = s.clone();
    other.views[0].seed += 1;
    assert!(render(&other) != a);
}

/// Pixel of the image nearest world point `p`.
fn sample_bilinear(img: &LinearImage, p: DVec2) -> Option<f64> {
    let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
    if x < 0 || y < 0 || x >= i64::from(img.width) || y >= i64::from(img.height) {
        return None;
    }
    Some(f64::from(img.get(x as u32, y as u32)[0]))
}

#[test]
fn a_texture_feature_moves_as_rolling_predicts() {
    // Two instants of a rolling checker sphere under even light (uniform sky, the floor a
    // far white reflector): the image is the albedo. Each sphere pixel of the second
    // image, traced back along the rolling motion (rotation about the contact line plus
    // translation), must find the same albedo in the first image; sliding (translation
    // alone) must not.
    let camera = Camera::look_at(DVec3::new(0.0, 0.1, 3.0), DVec3::new(0.0, 0.1, 0.0), 0.2, 0.036, 160, 90);
    let mut s = scene(
        camera,
        Material::Checker { albedo_a: [0.9; 3], albedo_b: [0.1; 3], squares_around: 16, squares_pole_to_pole: 8 },
        uniform(1.0),
        16,
    );
    s.floor = Floor { height: -1.0e4, albedo: [1.0; 3] };
    s.sphere.velocity = DVec3::new(0.6, 0.0, 0.0);
    s.sphere.start = DVec3::new(-0.02, 0.1, 0.0);
    let (t1, t2) = (0.0, 0.04);
    let at = |t: f64| {
        let mut f = s.clone();
        f.shutter = Shutter { open: t, close: t };
        render(&f).remove(0)
    };
    let (img1, img2) = (at(t1), at(t2));
    let cam = &s.views[0].camera;
    let sph = &s.sphere;
    let (mut err_roll, mut err_slide, mut n) = (0.0, 0.0, 0);
    for y in 0..90 {
        for x in 0..160 {
            let d = cam.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            let f = cam.position - sph.centre_at(t2);
            let Some((near, far)) = solve_quadratic(1.0, 2.0 * f.dot(d), f.length_squared() - sph.radius * sph.radius)
            else {
                continue;
            };
            if near >= far {
                continue;
            }
            let q2 = cam.position + d * near;
            // Keep away from the silhouette, where pixels mix sphere and sky.
            if (q2 - sph.centre_at(t2)).normalize().dot(-d) < 0.5 {
                continue;
            }
            let local = sph.world_to_object(q2, t2);
            let q1_roll = sph.centre_at(t1) + sph.orientation_at(t1) * (local * sph.radius);
            let q1_slide = q2 - (sph.centre_at(t2) - sph.centre_at(t1));
            let value2 = f64::from(img2.get(x, y)[0]);
            if let (Some(a), Some(b)) = (
                sample_bilinear(&img1, cam.project(q1_roll).unwrap()),
                sample_bilinear(&img1, cam.project(q1_slide).unwrap()),
            ) {
                err_roll += (a - value2).abs();
                err_slide += (b - value2).abs();
                n += 1;
            }
        }
    }
    let (err_roll, err_slide) = (err_roll / f64::from(n), err_slide / f64::from(n));
    assert!(n > 500, "{n} pixels");
    assert!(err_roll < 0.06 && err_roll < 0.3 * err_slide, "rolling error {err_roll}, sliding error {err_slide}");
}

/// The noise-textured sphere seen from 1.2 m under a small default map: a textured,
/// softly lit close-up for the noise statistics.
fn noise_close_up(width: u32, height: u32, spp: u32) -> FrameScene {
    let material = Material::Noise {
        albedo_a: [0.8, 0.7, 0.6],
        albedo_b: [0.1, 0.1, 0.4],
        base_frequency: 4.0,
        octaves: 4,
        seed: 7,
    };
    let camera = Camera::look_at(DVec3::new(0.0, 0.3, 1.2), DVec3::new(0.0, 0.1, 0.0), 0.05, 0.036, width, height);
    scene(camera, material, Environment::Default { width: 128 }, spp)
}

#[test]
fn the_two_eyes_have_independent_noise() {
    // Both eyes look through the same camera (so they see the same expected image) with
    // the seeds a stereo frame gives them; their residuals against a high-sample
    // reference must be uncorrelated.
    let id = StimulusId { material: 3, speed: 2, shutter: 3, samples: 1, method: None, view: View::Stereo };
    let mut s = noise_close_up(64, 36, 4);
    let cam = s.views[0].camera.clone();
    let seed = |eye| study::seed::frame_seed(2011, &id, eye, 3);
    s.views = vec![
        EyeView { eye: Eye::Left, camera: cam.clone(), seed: seed(Eye::Left) },
        EyeView { eye: Eye::Right, camera: cam.clone(), seed: seed(Eye::Right) },
    ];
    let eyes = render(&s);
    let mut reference = s.clone();
    reference.samples_per_pixel = 256;
    reference.views.truncate(1);
    reference.views[0].seed = 99;
    let r = render(&reference).remove(0);
    let residual = |img: &LinearImage| -> Vec<f64> {
        img.pixels.iter().zip(&r.pixels).map(|(a, b)| f64::from(a[1]) - f64::from(b[1])).collect()
    };
    let (rl, rr) = (residual(&eyes[0]), residual(&eyes[1]));
    let rho = correlation(&rl, &rr);
    // Under independence rho ~ N(0, 1/n).
    let limit = 4.0 / (rl.len() as f64).sqrt();
    assert!(rho.abs() < limit, "residual correlation {rho} (limit {limit})");
    // Control: an eye rendered with the same seed is perfectly correlated.
    let mut same = s.clone();
    same.views[1].seed = same.views[0].seed;
    let twins = render(&same);
    assert!(correlation(&residual(&twins[0]), &residual(&twins[1])) > 0.999);
}

#[test]
fn rms_error_falls_as_one_over_sqrt_spp() {
    let mut s = noise_close_up(48, 27, 1);
    s.sphere.velocity = DVec3::new(1.5, 0.0, 0.0);
    s.shutter = Shutter { open: 0.0, close: 1.0 / 30.0 };
    let mut reference = s.clone();
    reference.samples_per_pixel = 4096;
    reference.views[0].seed = 777;
    let r = render(&reference).remove(0);
    let counts = [4u32, 16, 64];
    let errors: Vec<f64> = counts
        .iter()
        .map(|&spp| {
            let mut f = s.clone();
            f.samples_per_pixel = spp;
            render(&f)[0].rms_difference(&r)
        })
        .collect();
    // Least-squares slope of log(rms) against log(spp): -1/2 for independent Monte Carlo
    // samples. The Owen-scrambled Sobol sampler stratifies the low dimensions (pixel
    // position, time, first bounce), which makes the error fall faster (about -0.75 here:
    // the rate of scrambled nets on integrands with edges); slower than -0.42 would mean
    // correlated or biased samples, faster than -1 a broken reference.
    let xs: Vec<f64> = counts.iter().map(|&c| f64::from(c).ln()).collect();
    let ys: Vec<f64> = errors.iter().map(|e| e.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / 3.0, ys.iter().sum::<f64>() / 3.0);
    let slope = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
        / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    assert!((-1.0..=-0.42).contains(&slope), "slope {slope}, errors {errors:?}");
}

#[test]
fn hard_cases_stay_finite() {
    // Environment with black rows and huge values.
    let mut map = default_map(64);
    for x in 0..64 {
        map.set(x, 3, [0.0; 3]);
        map.set(x, 20, [0.0; 3]);
    }
    map.set(5, 10, [3.0e37; 3]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hard.exr");
    std::fs::write(&path, render::io::encode_exr(&map).unwrap()).unwrap();
    // A camera at floor level (rays parallel to the floor), the sphere touching the floor
    // in view (the contact point), moving, with its shutter bounds evaluated.
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 0.0, 0.0), 0.05, 0.036, 48, 27);
    let mut s = scene(
        camera,
        Material::Checker { albedo_a: [0.8; 3], albedo_b: [0.1; 3], squares_around: 16, squares_pole_to_pole: 8 },
        Environment::File { path },
        8,
    );
    s.sphere.velocity = DVec3::new(1.0, 0.0, 0.0);
    s.shutter = Shutter { open: 0.0, close: 1.0 / 30.0 };
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let out = render_frame(&s, &env).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    assert!(out.eyes[0].pixels.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
    assert_eq!(out.camera_samples, 48 * 27 * 8);
    // The shutter's bounds: a frame at each bound alone.
    for t in [s.shutter.open, s.shutter.close, s.shutter.time_at(0.0), s.shutter.time_at(1.0)] {
        let mut f = s.clone();
        f.shutter = Shutter { open: t, close: t };
        let out = render_frame(&f, &env).unwrap();
        assert_eq!(out.nonfinite_samples, 0);
        assert!(out.eyes[0].pixels.iter().all(|p| p.iter().all(|c| c.is_finite())));
    }
}

#[test]
fn nested_levels_are_each_sample_count_rendered_alone() {
    let mut s = noise_close_up(24, 16, 12);
    s.sphere.velocity = DVec3::new(1.5, 0.0, 0.0);
    s.shutter = Shutter { open: 0.0, close: 1.0 / 30.0 };
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let levels = render::methods::tracer::render_frame_nested(&s, &env, &[5, 1, 5, 40, 0]).unwrap();
    let counts: Vec<u64> = levels.iter().map(|l| l.camera_samples).collect();
    assert_eq!(counts, [24 * 16, 24 * 16 * 5, 24 * 16 * 12]);
    for (level, spp) in levels.iter().zip([1, 5, 12]) {
        let mut alone = s.clone();
        alone.samples_per_pixel = spp;
        assert_eq!(level.eyes, render_frame(&alone, &env).unwrap().eyes, "{spp} spp");
    }
}

#[test]
fn centred_samples_alias_the_silhouette_and_jittered_ones_do_not() {
    // A black sphere in front of a lit floor and sky: with every sample through the pixel's
    // centre, a pixel is exactly black if and only if its centre ray meets the sphere; with
    // jittered samples the silhouette's pixels mix the two.
    let mut s = scene(study_camera(64, 40), flat(0.0), uniform(L), 4);
    s.pixel_jitter = false;
    let centred = render(&s).remove(0);
    let cam = &s.views[0].camera;
    let rays = render::shading::camera::CameraRays::new(cam);
    let centre = s.sphere.start;
    let mut hits = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ray = rays.ray(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            let hit = render::shading::intersect::intersect_sphere(&ray, centre, s.sphere.radius).is_some();
            hits += u32::from(hit);
            let black = centred.get(x, y) == [0.0; 3];
            assert_eq!(black, hit, "pixel ({x}, {y}): {:?}", centred.get(x, y));
        }
    }
    assert!(hits > 20, "the sphere covers {hits} pixel centres");
    s.pixel_jitter = true;
    let jittered = render(&s).remove(0);
    let partial = (0..cam.height)
        .flat_map(|y| (0..cam.width).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let (c, j) = (centred.get(x, y)[0], jittered.get(x, y)[0]);
            (c == 0.0) != (j == 0.0)
        })
        .count();
    assert!(partial > 0, "jittered samples leave the silhouette exactly as centred ones");
}
