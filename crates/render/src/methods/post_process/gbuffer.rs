//! The G-buffer the post-process filters read: one eye's radiance at one instant (the
//! shutter's centre) from the tracer, and per pixel the view depth and the screen-space
//! velocity of what the pixel's centre sees, computed analytically from the rolling motion.
//!
//! Velocities are pixels per exposure: where the visible material point moves between the
//! shutter's opening and closing if it kept its velocity at the centre instant, projected by
//! the eye's own camera (so the stereo eyes each get theirs). On the sphere that is the rolling
//! velocity of the surface point (translation plus spin: twice the speed on top, rest at the
//! contact). A motion that carries the point past the camera's near plane within the exposure
//! is clipped there ([`screen_motion`]), not dropped. The floor does not move: its velocity is
//! zero, as a game engine's velocity buffer holds it, so a moving shadow stays unblurred (a
//! known limit of post-process blur). [`FloorMotion::Shadow`] (the filters' `shadow_motion`
//! setting) instead gives floor points where the sphere covers at least
//! [`SHADOW_FORM_FACTOR`] of the cosine-weighted sky the sphere's translation, so the filters
//! smear the contact shadow as the tracer's time integral does, but also the floor's own
//! texture and noise around it (a smooth disc sliding with the sphere).

use glam::{DVec2, DVec3};
use study::scene::{Camera, FrameScene};

use crate::io::LinearImage;
use crate::methods::post_process::{GBuffer, SKY_DEPTH};
use crate::numeric::solve_quadratic;

/// The share of a floor point's cosine-weighted sky that the sphere must hide for the point to
/// move with the sphere's shadow. A sphere of radius r whose centre is at distance d from the
/// point, seen at angle theta from the floor normal, covers the point-to-sphere form factor
/// cos(theta) r^2 / d^2; 1 % reaches about 4.5 radii from the contact point.
pub const SHADOW_FORM_FACTOR: f64 = 0.01;

/// The velocity the G-buffer gives the floor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FloorMotion {
    /// Its surface motion: none (the floor is static).
    #[default]
    Surface,
    /// The sphere's translation where the sphere's shadow falls ([`SHADOW_FORM_FACTOR`]).
    Shadow,
}

/// What a pixel's centre sees at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelGeometry {
    /// View depth, metres ([`SKY_DEPTH`] for the sky).
    pub depth: f32,
    /// Screen-space displacement over the exposure, pixels (x right, y down).
    pub velocity: [f32; 2],
}

/// The depth and velocity seen through the centre of pixel (`x`, `y`) of `camera` at `time`,
/// for an exposure of `exposure` seconds, the floor moving as `floor` says.
pub fn pixel_geometry(
    scene: &FrameScene,
    camera: &Camera,
    (x, y): (u32, u32),
    time: f64,
    exposure: f64,
    floor: FloorMotion,
) -> PixelGeometry {
    let sky = PixelGeometry { depth: SKY_DEPTH, velocity: [0.0, 0.0] };
    let dir = camera.ray_direction(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
    let origin = camera.position;
    let sphere = &scene.sphere;
    let centre = sphere.centre_at(time);
    let oc = origin - centre;
    // |o + t d - c|^2 = r^2 with |d| = 1: t^2 + 2 (d.oc) t + |oc|^2 - r^2 = 0.
    let sphere_t = solve_quadratic(1.0, 2.0 * dir.dot(oc), oc.length_squared() - sphere.radius * sphere.radius)
        .and_then(|(t0, t1)| [t0, t1].into_iter().find(|&t| t > 0.0));
    let normal = sphere.floor_normal;
    let floor_t = {
        let denom = dir.dot(normal);
        let t = (scene.floor.height - origin.dot(normal)) / denom;
        (denom < 0.0 && t.is_finite() && t > 0.0).then_some(t)
    };
    let (t, on_sphere) = match (sphere_t, floor_t) {
        (Some(s), Some(f)) if f < s => (f, false),
        (Some(s), _) => (s, true),
        (None, Some(f)) => (f, false),
        (None, None) => return sky,
    };
    let p = origin + dir * t;
    let world_velocity = if on_sphere {
        sphere.surface_velocity(p, time)
    } else if floor == FloorMotion::Shadow && shadow_form_factor(p, normal, centre, sphere.radius) >= SHADOW_FORM_FACTOR
    {
        sphere.velocity
    } else {
        DVec3::ZERO
    };
    let velocity = screen_motion(camera, p, world_velocity, 0.5 * exposure);
    PixelGeometry { depth: (t * dir.dot(camera.forward)) as f32, velocity: [velocity.x as f32, velocity.y as f32] }
}

/// The near plane motion segments are clipped to (metres of view depth), or half the depth
/// of the point that moves where that is nearer.
pub const MOTION_NEAR: f64 = 1e-3;
/// The longest velocity a G-buffer holds, pixels per exposure: longer ones keep their
/// direction (the filters clamp every velocity to their tile size, at most 1024 pixels, and
/// f32 holds this one).
pub const MAX_VELOCITY: f64 = 1e30;
/// How far a motion segment reaches at most, in distances from the camera to the point:
/// farther, its end projects within 1e-12 of the line's vanishing point, or beyond 1e9
/// image widths where it runs parallel to the image plane.
const MAX_REACH: f64 = 1e12;

/// The screen-space displacement (pixels, x right, y down) of a point `p` in front of
/// `camera` moving at `world_velocity` for `half_exposure` seconds either side of now: the
/// projection of the segment from `p - h` to `p + h` (`h` the velocity times
/// `half_exposure`).
///
/// An end that would cross the near plane ([`MOTION_NEAR`]) is clipped where the segment from
/// `p` towards it crosses the plane, and the velocity is the screen vector of the clipped
/// segment: a point passing the camera sweeps the screen towards that side (the filters
/// clamp the vector to their largest blur), it does not stand still. Segments longer than
/// [`MAX_REACH`] viewing distances (or overflowing f64) are shortened to it, and the result
/// to [`MAX_VELOCITY`], both keeping their direction. Segments within all three bounds, every
/// ordinary frame's, are projected as they are.
pub fn screen_motion(camera: &Camera, p: DVec3, world_velocity: DVec3, half_exposure: f64) -> DVec2 {
    let to_p = p - camera.position;
    let (z_p, reach_limit) = (to_p.dot(camera.forward), MAX_REACH * to_p.length());
    let near = MOTION_NEAR.min(0.5 * z_p);
    let depth = |q: DVec3| (q - camera.position).dot(camera.forward);
    let h = world_velocity * half_exposure;
    let plain = h.is_finite() && h.length() <= reach_limit && depth(p - h) >= near && depth(p + h) >= near;
    let v = if plain {
        match (camera.project(p - h), camera.project(p + h)) {
            (Some(a), Some(b)) => b - a,
            _ => DVec2::ZERO,
        }
    } else {
        // Direction and length apart, so that neither overflows.
        let m = world_velocity.abs().max_element();
        if !(m > 0.0 && m.is_finite() && half_exposure > 0.0 && z_p > 0.0) {
            return DVec2::ZERO;
        }
        let scaled = world_velocity / m;
        let u = scaled.normalize();
        let reach = (m * scaled.length() * half_exposure).min(reach_limit);
        let rate = u.dot(camera.forward);
        // The end on side `sign`, clipped where its depth reaches the near plane.
        let end = |sign: f64| {
            let towards = sign * rate;
            let s = if z_p + reach * towards < near { (z_p - near) / -towards } else { reach };
            camera.project(p + u * (sign * s))
        };
        match (end(-1.0), end(1.0)) {
            (Some(a), Some(b)) => b - a,
            _ => DVec2::ZERO,
        }
    };
    let length = v.length();
    if length > MAX_VELOCITY { v * (MAX_VELOCITY / length) } else { v }
}

/// The form factor from a floor point `p` (normal `n`) to a sphere of radius `r` at `c`:
/// the share of the point's cosine-weighted hemisphere the sphere hides.
pub fn shadow_form_factor(p: DVec3, n: DVec3, c: DVec3, r: f64) -> f64 {
    let to_centre = c - p;
    let d2 = to_centre.length_squared();
    if d2 <= r * r {
        return 1.0;
    }
    let cos = to_centre.dot(n) / d2.sqrt();
    (cos * r * r / d2).clamp(0.0, 1.0)
}

/// The G-buffer of each eye of `scene` at its shutter's centre, with the radiance `eyes`
/// rendered at that instant (one image per eye, in the scene's order), the floor moving as
/// `floor` says.
pub fn gbuffers(scene: &FrameScene, eyes: Vec<LinearImage>, floor: FloorMotion) -> Vec<GBuffer> {
    let time = scene.shutter.centre();
    let exposure = if scene.needs_time_sampling() { scene.shutter.duration() } else { 0.0 };
    scene
        .views
        .iter()
        .zip(eyes)
        .map(|(view, image)| {
            let camera = &view.camera;
            let (width, height) = (camera.width, camera.height);
            let geometry: Vec<PixelGeometry> = (0..height)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .map(|(x, y)| pixel_geometry(scene, camera, (x, y), time, exposure, floor))
                .collect();
            GBuffer {
                width,
                height,
                color: image.pixels,
                depth: geometry.iter().map(|g| g.depth).collect(),
                velocity: geometry.iter().map(|g| g.velocity).collect(),
            }
        })
        .collect()
}
