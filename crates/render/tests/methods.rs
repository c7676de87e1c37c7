//! The rendering methods beside the tracer, on the CPU: the G-buffer's analytic depth and
//! velocity, the accumulation buffer against the closed-form time-averaged coverage, and the
//! post-process filters over the G-buffer of a moving sphere against the same closed form.
//! Frames without motion during an open shutter must be the tracer's bytes.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use common::{L, coverage_scene, exact_coverage, flat, scene, study_camera, uniform};
use glam::{DVec2, DVec3};
use render::Renderer;
use render::env::EnvironmentMap;
use render::io::LinearImage;
use render::methods::post_process::SKY_DEPTH;
use render::methods::post_process::gbuffer::{
    FloorMotion, SHADOW_FORM_FACTOR, gbuffers, pixel_geometry, shadow_form_factor,
};
use study::Method;
use study::method::MethodSpec;
use study::scene::{FrameScene, Shutter};

fn render_with(spec: &MethodSpec, s: &FrameScene) -> render::RenderedFrame {
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    Renderer::cpu(&env).render(spec, s).unwrap()
}

/// The study's camera on a sphere rolling at 2 m/s through the image centre, shutter open a
/// whole 30 fps frame centred on t = 0.
fn rolling_scene(width: u32, height: u32) -> FrameScene {
    let mut s = scene(study_camera(width, height), flat(0.6), uniform(L), 1);
    s.sphere.velocity = DVec3::new(2.0, 0.0, 0.0);
    s.sphere.start = DVec3::new(0.0, 0.1, 0.0);
    s.shutter = Shutter { open: -1.0 / 60.0, close: 1.0 / 60.0 };
    s
}

#[test]
fn gbuffer_velocity_is_the_projected_displacement_of_the_visible_material_point() {
    let s = rolling_scene(160, 90);
    let cam = &s.views[0].camera;
    let exposure = s.shutter.close - s.shutter.open;
    let (t, sphere) = (s.shutter.centre(), &s.sphere);
    let v_centre = (cam.project(sphere.centre_at(t) + sphere.velocity * (exposure / 2.0)).unwrap()
        - cam.project(sphere.centre_at(t) - sphere.velocity * (exposure / 2.0)).unwrap())
    .x;
    let (mut on_sphere, mut fastest) = (0, 0.0f64);
    for y in 0..90 {
        for x in 0..160 {
            let g = pixel_geometry(&s, cam, (x, y), t, exposure, FloorMotion::Surface);
            let dir = cam.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            // The point the depth names, on the ray; pixels whose point is on the sphere.
            let p = cam.position + dir * (f64::from(g.depth) / dir.dot(cam.forward));
            if ((p - sphere.centre_at(t)).length() - sphere.radius).abs() > 1e-4 {
                continue;
            }
            on_sphere += 1;
            // The material point under the pixel, followed along its true (rolling) path over
            // a short time: its projected velocity times the exposure.
            let local = sphere.world_to_object(p, t);
            let at = |time: f64| sphere.centre_at(time) + sphere.orientation_at(time) * (local * sphere.radius);
            let h = 1e-5;
            let v = (cam.project(at(t + h)).unwrap() - cam.project(at(t - h)).unwrap()) * (exposure / (2.0 * h));
            let got = DVec2::new(f64::from(g.velocity[0]), f64::from(g.velocity[1]));
            assert!((got - v).length() < 0.02 * v.length().max(1.0), "pixel ({x}, {y}): {got} vs {v}");
            fastest = fastest.max(got.x / v_centre);
        }
    }
    // A disc of radius 0.1 m at 3 m is about 7.4 pixels across at 160 pixels.
    assert!(on_sphere > 30, "only {on_sphere} sphere pixels");
    // Near the top the surface moves at almost twice the speed of the centre.
    assert!(fastest > 1.7 && fastest < 2.0, "fastest {fastest} x the centre's");
}

#[test]
fn gbuffer_floor_is_static_and_moves_in_the_shadow_region_only_when_asked() {
    let s = rolling_scene(160, 90);
    let cam = &s.views[0].camera;
    let t = s.shutter.centre();
    let exposure = s.shutter.close - s.shutter.open;
    let centre = s.sphere.centre_at(t);
    let v_shadow = {
        let p = DVec3::new(centre.x, 0.0, centre.z + 0.15);
        cam.project(p + s.sphere.velocity * exposure / 2.0).unwrap()
            - cam.project(p - s.sphere.velocity * exposure / 2.0).unwrap()
    };
    let (mut moving, mut still, mut sky) = (0, 0, 0);
    for y in 0..90 {
        for x in 0..160 {
            let g = pixel_geometry(&s, cam, (x, y), t, exposure, FloorMotion::Shadow);
            let surface = pixel_geometry(&s, cam, (x, y), t, exposure, FloorMotion::Surface);
            let dir = cam.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            if dir.y >= 0.0 {
                sky += 1;
                assert_eq!((g.depth, g.velocity), (SKY_DEPTH, [0.0, 0.0]));
                continue;
            }
            let floor_t = -cam.position.y / dir.y;
            let p = cam.position + dir * floor_t;
            let floor_depth = floor_t * dir.dot(cam.forward);
            if (f64::from(g.depth) - floor_depth).abs() > 1e-5 * floor_depth {
                continue; // the sphere hides this floor point
            }
            // By default the floor holds its own (zero) motion everywhere, in the shadow too.
            assert_eq!((surface.depth, surface.velocity), (g.depth, [0.0, 0.0]), "({x}, {y})");
            let f = shadow_form_factor(p, DVec3::Y, centre, s.sphere.radius);
            if f >= SHADOW_FORM_FACTOR {
                moving += 1;
                assert!(
                    (f64::from(g.velocity[0]) - v_shadow.x).abs() < 0.15 * v_shadow.x.abs(),
                    "({x}, {y}): {:?}",
                    g.velocity
                );
            } else {
                still += 1;
                assert_eq!(g.velocity, [0.0, 0.0], "({x}, {y})");
            }
        }
    }
    assert!(moving > 20 && still > 1000 && sky > 100, "{moving} {still} {sky}");
    // The form factor of a point right under the sphere is 1, and falls as (r/d)^3 along the floor.
    let r = s.sphere.radius;
    assert!((shadow_form_factor(DVec3::new(0.0, 0.0, 0.0), DVec3::Y, DVec3::new(0.0, r, 0.0), r) - 1.0).abs() < 1e-12);
    let d = 3.0 * r;
    let x = (d * d - r * r).sqrt();
    let f = shadow_form_factor(DVec3::new(x, 0.0, 0.0), DVec3::Y, DVec3::new(0.0, r, 0.0), r);
    assert!((f - (r / d).powi(3)).abs() < 1e-12, "{f}");
}

#[test]
fn without_motion_in_the_shutter_every_velocity_is_zero() {
    let mut s = rolling_scene(48, 27);
    s.shutter = Shutter { open: 0.01, close: 0.01 };
    let eyes = vec![LinearImage::new(48, 27)];
    assert!(gbuffers(&s, eyes.clone(), FloorMotion::Surface)[0].velocity.iter().all(|v| *v == [0.0, 0.0]));
    let mut s = rolling_scene(48, 27);
    s.sphere.velocity = DVec3::ZERO;
    assert!(gbuffers(&s, eyes, FloorMotion::Surface)[0].velocity.iter().all(|v| *v == [0.0, 0.0]));
}

#[test]
fn accumulation_buffer_converges_to_the_time_averaged_coverage() {
    let spp = 2;
    let instants = 64;
    let s = {
        let mut s = coverage_scene(2.238, 1.0, spp * instants);
        s.samples_per_pixel = spp * instants;
        s
    };
    for jitter in [false, true] {
        let spec = MethodSpec::Accum(study::method::AccumSettings {
            instants: Some(instants),
            jitter: Some(jitter),
            ..Default::default()
        });
        let frame = render_with(&spec, &s);
        assert_eq!(frame.camera_samples, u64::from(spp * instants) * 320 * 4);
        let img = &frame.image;
        let mut partial = 0;
        for x in 0..img.width {
            let expected = exact_coverage(&s, x, 1);
            let measured = 1.0 - f64::from(img.get(x, 1)[0]) / L;
            // Monte Carlo over the pixel area at spp x K samples, plus the midpoint rule's
            // bound for an interval indicator sampled at K instants: 1/K.
            let se = (expected * (1.0 - expected) / f64::from(spp * instants)).sqrt();
            let bound = 3.0 * se + 0.01 + 1.0 / f64::from(instants);
            assert!((measured - expected).abs() < bound, "jitter {jitter} x {x}: {measured} vs {expected}");
            partial += usize::from(expected > 0.05 && expected < 0.95);
        }
        assert!(partial >= 16, "{partial}");
    }
}

#[test]
fn accumulation_buffer_with_few_instants_strobes() {
    // Two instants half a shutter apart, 0.33 m: two sharp copies of the 0.2 m sphere, and
    // uncovered pixels between them where the tracer has a continuous streak.
    let mut s = coverage_scene(20.0, 1.0, 32);
    s.samples_per_pixel = 32;
    let spec = MethodSpec::Accum(study::method::AccumSettings { instants: Some(2), ..Default::default() });
    let img = render_with(&spec, &s).image;
    let coverage: Vec<f64> = (0..img.width).map(|x| 1.0 - f64::from(img.get(x, 1)[0]) / L).collect();
    let analytic: Vec<f64> = (0..img.width).map(|x| exact_coverage(&s, x, 1)).collect();
    let gaps = (0..coverage.len()).filter(|&x| analytic[x] > 0.2 && coverage[x] < 0.02).count();
    assert!(gaps >= 5, "{gaps} gap pixels: {coverage:?}");
    // Elsewhere inside the streak a copy covers a pixel at one instant of two: 1/2.
    assert!(coverage.iter().filter(|&&c| (c - 0.5).abs() < 0.02).count() >= 10);
}

#[test]
fn methods_render_the_tracer_bytes_when_nothing_moves_in_the_shutter() {
    let mut s = rolling_scene(48, 27);
    s.samples_per_pixel = 4;
    s.shutter = Shutter { open: 0.0, close: 0.0 };
    let tracer = render_with(&MethodSpec::of(Method::Tracer), &s);
    for kind in [Method::Accum, Method::Mcguire, Method::Guertin] {
        let frame = render_with(&MethodSpec::of(kind), &s);
        assert_eq!(frame.image, tracer.image, "{kind}");
        assert_eq!(frame.camera_samples, tracer.camera_samples, "{kind}");
    }
    // The analytic rasterizer shades the same surfaces with its own samples: not the tracer's
    // bytes, but without motion no pixel needs more than two intervals (the sphere hides the
    // floor), so the budget changes nothing, and it is close to the tracer.
    let few = render_with(
        &MethodSpec::Analytic(study::method::AnalyticSettings { intervals: Some(4), ..Default::default() }),
        &s,
    );
    let many = render_with(
        &MethodSpec::Analytic(study::method::AnalyticSettings { intervals: Some(64), ..Default::default() }),
        &s,
    );
    assert_eq!(few.image, many.image);
    let mean = |img: &render::io::LinearImage| {
        img.pixels.iter().map(|p| f64::from(p[1])).sum::<f64>() / img.pixels.len() as f64
    };
    assert!(
        (mean(&few.image) - mean(&tracer.image)).abs() < 0.05 * mean(&tracer.image),
        "{} {}",
        mean(&few.image),
        mean(&tracer.image)
    );
}

#[test]
fn nested_levels_are_the_tracers_alone() {
    let mut s = rolling_scene(16, 9);
    s.samples_per_pixel = 8;
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let renderer = Renderer::cpu(&env);
    let e = renderer.submit(&MethodSpec::of(Method::Accum), &s, &[2, 8]).err().unwrap().to_string();
    assert!(e.contains("`accum` cannot render nested sample levels"), "{e}");
    assert!(renderer.submit(&MethodSpec::of(Method::Accum), &s, &[8]).is_ok());
}

/// Row 1 coverage of a render of a [`coverage_scene`].
fn row_coverage(img: &LinearImage) -> Vec<f64> {
    (0..img.width).map(|x| 1.0 - f64::from(img.get(x, 1)[0]) / L).collect()
}

#[test]
fn filters_reproduce_the_time_averaged_coverage_of_a_moving_sphere() {
    // A black sphere crossing a uniform sky at 2.238 m/s (S3), shutter open the whole frame:
    // an 11-pixel streak on a 30-pixel disc. Each filter, from the G-buffer at the shutter's
    // centre alone, must spread the disc over the streak the closed form gives.
    let s = coverage_scene(2.238, 1.0, 16);
    let analytic: Vec<f64> = (0..320).map(|x| exact_coverage(&s, x, 1)).collect();
    let sharp = row_coverage(
        &render_with(&MethodSpec::of(Method::Tracer), &{
            let mut c = s.clone();
            c.shutter = Shutter { open: 0.0, close: 0.0 };
            c
        })
        .image,
    );
    // RMS over the streak: the pixels the exposure partly covers or the instant misplaces.
    let streak: Vec<usize> = (0..320)
        .filter(|&x| (analytic[x] > 0.0 && analytic[x] < 1.0) || (sharp[x] - analytic[x]).abs() > 1e-3)
        .collect();
    let rms =
        |c: &[f64]| (streak.iter().map(|&x| (c[x] - analytic[x]).powi(2)).sum::<f64>() / streak.len() as f64).sqrt();
    let sharp_rms = rms(&sharp);
    assert!(streak.len() >= 20 && sharp_rms > 0.2, "{} streak pixels, unblurred error {sharp_rms}", streak.len());
    // The background side of each edge (sky pixels the sphere passes over): what a gather can
    // reconstruct exactly, and where Guertin et al.'s normalised centre weight corrects McGuire
    // et al.'s overweighted foreground.
    let background: Vec<usize> = streak.iter().copied().filter(|&x| sharp[x].abs() < 1e-3).collect();
    let mut background_rms = Vec::new();
    for kind in [Method::Mcguire, Method::Guertin] {
        let c = row_coverage(&render_with(&MethodSpec::of(kind), &s).image);
        let error = rms(&c);
        assert!(error < 0.75 * sharp_rms, "{kind}: error {error} against the unblurred {sharp_rms}");
        let extent = |v: &[f64]| v.iter().filter(|&&x| x > 0.02).count() as f64;
        assert!(
            (extent(&c) - extent(&analytic)).abs() <= 3.0,
            "{kind}: extent {} vs {}",
            extent(&c),
            extent(&analytic)
        );
        let worst = background.iter().map(|&x| (c[x] - analytic[x]).abs()).fold(0.0, f64::max);
        background_rms.push((kind, worst));
    }
    assert!(background.len() >= 8, "{background:?}");
    let (mcguire, guertin) = (background_rms[0].1, background_rms[1].1);
    assert!(guertin < 0.1 && guertin < 0.6 * mcguire, "worst background error: McGuire {mcguire}, Guertin {guertin}");
}

#[test]
fn a_stereo_frame_is_filtered_eye_by_eye_with_each_eyes_own_velocities() {
    let mut s = rolling_scene(64, 36);
    s.samples_per_pixel = 2;
    let mut left = s.clone();
    let rig =
        |eye| study::scene::eye_camera(&s.views[0].camera, eye, 0.065, 3.0, study::scene::StereoConvergence::OffAxis);
    s.views = vec![
        study::scene::EyeView { eye: study::Eye::Left, camera: rig(study::Eye::Left), seed: 1 },
        study::scene::EyeView { eye: study::Eye::Right, camera: rig(study::Eye::Right), seed: 2 },
    ];
    left.views = vec![s.views[0].clone()];
    let mut right = s.clone();
    right.views = vec![s.views[1].clone()];
    let left_g = gbuffers(&left, vec![LinearImage::new(64, 36)], FloorMotion::Surface).remove(0);
    let right_g = gbuffers(&right, vec![LinearImage::new(64, 36)], FloorMotion::Surface).remove(0);
    assert_ne!(left_g.velocity, right_g.velocity, "each eye projects the motion with its own camera");
    for kind in [Method::Mcguire, Method::Guertin] {
        let stereo = render_with(&MethodSpec::of(kind), &s).image;
        for (half, eye) in [(0, &left), (64, &right)] {
            let alone = render_with(&MethodSpec::of(kind), eye).image;
            for y in 0..36 {
                for x in 0..64 {
                    assert_eq!(stereo.get(half + x, y), alone.get(x, y), "{kind} eye at {half}: ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn the_filters_leave_the_static_floor_unblurred_unless_the_shadow_motion_is_asked_for() {
    // Issue 24: the shadow region's velocity made the filters smear the floor's noise in a
    // disc sliding with the sphere. By default the floor is static in the G-buffer: fewer
    // pixels change from the traced centre instant, and none of them far below the sphere.
    let mut s = rolling_scene(96, 54);
    s.samples_per_pixel = 4;
    let centre = s.at_instant(s.shutter.centre());
    let traced = render_with(&MethodSpec::of(Method::Tracer), &centre).image;
    for kind in [Method::Mcguire, Method::Guertin] {
        let changed = |spec: &MethodSpec| {
            let img = render_with(spec, &s).image;
            img.pixels.iter().zip(&traced.pixels).filter(|(a, b)| a != b).count()
        };
        let surface = changed(&MethodSpec::of(kind));
        let shadow = match kind {
            Method::Mcguire => {
                MethodSpec::Mcguire(study::method::McGuireSettings { shadow_motion: Some(true), ..Default::default() })
            }
            _ => {
                MethodSpec::Guertin(study::method::GuertinSettings { shadow_motion: Some(true), ..Default::default() })
            }
        };
        let with_shadow = changed(&shadow);
        assert!(surface > 0, "{kind}: the moving sphere is blurred");
        assert!(
            surface < with_shadow,
            "{kind}: {surface} pixels changed with a static floor, {with_shadow} with the shadow moving"
        );
    }
}
