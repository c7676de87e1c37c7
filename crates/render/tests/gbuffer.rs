//! The G-buffer's velocities at extreme motion (issue 31, defect 5): a point whose motion
//! over the exposure carries it past the camera's near plane keeps the screen motion of its
//! segment clipped at that plane, instead of standing still, and velocities stay finite
//! however far a point travels.

mod common;

use common::{flat, scene, study_camera, study_frame, uniform};
use glam::{DVec2, DVec3};
use render::methods::post_process::SKY_DEPTH;
use render::methods::post_process::gbuffer::{FloorMotion, MAX_VELOCITY, MOTION_NEAR, pixel_geometry, screen_motion};

#[test]
fn a_point_moving_past_the_near_plane_keeps_its_clipped_motion() {
    let cam = study_camera(160, 90);
    // A point right of the image centre, 3 m in front, moving straight at the camera (and a
    // little up): the near end of its segment crosses the near plane at half exposure `e_c`.
    let p = cam.position + cam.forward * 3.0 + cam.right * 0.2;
    let velocity = -cam.forward * 2.0 + cam.up * 0.1;
    let depth = |q: DVec3| (q - cam.position).dot(cam.forward);
    let approach = -velocity.dot(cam.forward);
    let e_c = (depth(p) - MOTION_NEAR) / approach;
    // Just before the crossing the segment is projected as it is; just after, clipped at the
    // plane: the two agree, the motion does not drop to zero at the crossing.
    let before = screen_motion(&cam, p, velocity, e_c * (1.0 - 1e-12));
    let after = screen_motion(&cam, p, velocity, e_c * (1.0 + 1e-12));
    assert!(before.x > 1000.0, "{before}");
    assert!((after - before).length() < 1e-6 * before.length(), "{before} then {after}");
    // Far beyond the crossing only the receding end moves on: the near end stays clipped.
    for k in [1.5, 10.0, 1e6] {
        let got = screen_motion(&cam, p, velocity, e_c * k);
        // The receding end is p - velocity e; the velocity is (near end) - (receding end).
        let far_end_moved = cam.project(p - velocity * (e_c * k)).unwrap() - cam.project(p - velocity * e_c).unwrap();
        let want = before - far_end_moved;
        assert!(got.is_finite() && (got - want).length() < 1e-6 * want.length(), "x{k}: {got} vs {want}");
    }
    // Receding instead: the mirror image of the segment, the same vector.
    let mirrored = screen_motion(&cam, p, -velocity, e_c * 10.0);
    assert!((mirrored + screen_motion(&cam, p, velocity, e_c * 10.0)).length() < 1e-6 * mirrored.length());
}

#[test]
fn motions_overflowing_f64_keep_their_screen_direction_and_stay_finite() {
    let cam = study_camera(160, 90);
    let p = cam.position + cam.forward * 3.0;
    // Along the image plane, towards the camera and away from it; at speeds whose
    // displacement overflows f64 (1e30 m/s for 1e300 s) and at ordinary ones.
    for dir in [cam.right, cam.up + cam.right * 0.5, -cam.forward + cam.right, cam.forward + cam.up] {
        let ordinary = screen_motion(&cam, p, dir, 0.01);
        for (speed, half_exposure) in [(1e30, 1e300), (1e300, 1e300), (1.0, 1e200)] {
            let v = screen_motion(&cam, p, dir * speed, half_exposure);
            assert!(v.is_finite() && v.length() <= MAX_VELOCITY * (1.0 + 1e-12), "{dir} {speed}: {v}");
            assert!(v.length() > 1e3, "{dir} {speed}: {v}");
            let cos = v.dot(ordinary) / (v.length() * ordinary.length());
            assert!(cos > 0.5, "{dir} {speed}: {v} against {ordinary}");
        }
    }
    // No motion, or no exposure: none on screen.
    assert_eq!(screen_motion(&cam, p, DVec3::ZERO, 1e300), DVec2::ZERO);
    assert_eq!(screen_motion(&cam, p, cam.right * 1e30, 0.0), DVec2::ZERO);
}

#[test]
fn at_extreme_speed_every_moving_pixel_of_the_study_frame_keeps_a_velocity() {
    // The design's benchmark frame with its exposure stretched as 78648.9 deg/s would stretch
    // the displacement (the sphere stays where it is at the shutter's centre): where the
    // stretched segment of a pixel's point reaches behind the camera, the velocity was zero.
    let s = study_frame(160, 90, 1, 1.0);
    let cam = &s.views[0].camera;
    let t = s.shutter.centre();
    let exposure = s.shutter.close - s.shutter.open;
    let stretch = 78648.9 / 15.0;
    let (mut moving, mut past_the_camera) = (0, 0);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ordinary = pixel_geometry(&s, cam, (x, y), t, exposure, FloorMotion::Surface);
            if ordinary.velocity == [0.0, 0.0] {
                continue;
            }
            moving += 1;
            let fast = pixel_geometry(&s, cam, (x, y), t, exposure * stretch, FloorMotion::Surface);
            assert_ne!(fast.velocity, [0.0, 0.0], "({x}, {y})");
            assert!(fast.velocity.iter().all(|v| v.is_finite()), "({x}, {y}): {:?}", fast.velocity);
            assert!(fast.depth < SKY_DEPTH);
            // The point the pixel sees and its displaced ends: was one behind the camera?
            let dir = cam.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
            let p = cam.position + dir * (f64::from(fast.depth) / dir.dot(cam.forward));
            let sphere = (p - s.sphere.centre_at(t)).length() < s.sphere.radius * 1.001;
            let w = if sphere { s.sphere.surface_velocity(p, t) } else { s.sphere.velocity };
            let h = w * (0.5 * exposure * stretch);
            if cam.project(p + h).is_none() || cam.project(p - h).is_none() {
                past_the_camera += 1;
            }
        }
    }
    assert!(moving > 100, "only {moving} moving pixels");
    assert!(past_the_camera > 10, "only {past_the_camera} pixels whose motion passes the camera");
}

#[test]
fn the_filters_blur_a_sphere_whose_motion_passes_the_camera() {
    // A sphere rushing at the camera across one exposure: every sphere pixel's segment
    // passes the near plane, and both filters must smear the sphere.
    let (w, h) = (160u32, 90u32);
    let mut s = scene(study_camera(w, h), flat(0.6), uniform(0.8), 1);
    s.sphere.velocity = DVec3::new(0.0, 0.0, 500.0);
    s.shutter = study::scene::Shutter { open: -1.0 / 60.0, close: 1.0 / 60.0 };
    let cam = s.views[0].camera.clone();
    let t = s.shutter.centre();
    let eye = render::io::LinearImage {
        width: w,
        height: h,
        pixels: (0..w * h).map(|i| [(i % 7) as f32 / 7.0, (i % 5) as f32 / 5.0, (i % 3) as f32 / 3.0]).collect(),
    };
    let g = render::methods::post_process::gbuffer::gbuffers(&s, vec![eye], FloorMotion::Surface).remove(0);
    let on_sphere = |i: usize| {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let dir = cam.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
        let p = cam.position + dir * (f64::from(g.depth[i]) / dir.dot(cam.forward));
        (p - s.sphere.centre_at(t)).length() < s.sphere.radius * 1.001
    };
    let sphere: Vec<usize> = (0..g.depth.len()).filter(|&i| on_sphere(i)).collect();
    let still = sphere.iter().filter(|&&i| g.velocity[i] == [0.0, 0.0]).count();
    assert!(sphere.len() > 20 && still == 0, "{still} of {} sphere pixels without velocity", sphere.len());
    let m = render::methods::mcguire::mcguire_cpu(&g, &render::methods::mcguire::McGuireParams::default());
    let q = render::methods::guertin::guertin_cpu(&g, &render::methods::guertin::GuertinParams::default());
    for (name, out) in [("mcguire", m), ("guertin", q)] {
        let changed = sphere.iter().filter(|&&i| out[i] != g.color[i]).count();
        assert!(changed * 10 > sphere.len() * 9, "{name}: {changed} of {} sphere pixels blurred", sphere.len());
    }
}
