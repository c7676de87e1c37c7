//! The exact visibility of the study's sphere itself, not its tessellation: the ray through a
//! sample point meets the sphere while the distance from the ray's line to the centre,
//! which moves in a straight line over the shutter, is below the radius. That distance
//! squared is a quadratic in time, so the covered span is one interval whose ends are the
//! roots of `a t^2 + b t + c` from the cancellation-free solver.
//!
//! It is the closed form the rasterizer's tessellated sphere approximates
//! ([`crate::measure::analytic_accuracy::tessellation_error`] measures the gap) and the reference against which
//! the tests judge the time-sampled methods' coverage (tracer, accumulation buffer, filters).

use glam::{DVec2, DVec3};
use study::scene::FrameScene;

use crate::numeric::solve_quadratic;

/// A sphere whose centre moves from `centre` at shutter open by `travel` by shutter close.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MovingSphere {
    /// Centre at shutter open (world).
    pub centre: DVec3,
    /// Displacement of the centre over the shutter (world).
    pub travel: DVec3,
    /// Radius.
    pub radius: f64,
}

impl MovingSphere {
    /// The sphere of `scene` over its shutter (a zero-length shutter: not moving).
    pub fn of(scene: &FrameScene) -> Self {
        let travel =
            if scene.needs_time_sampling() { scene.sphere.velocity * scene.shutter.duration() } else { DVec3::ZERO };
        MovingSphere { centre: scene.sphere.centre_at(scene.shutter.open), travel, radius: scene.sphere.radius }
    }

    /// The span of normalised shutter time, within `[0, 1]`, in which the ray from `origin`
    /// along the unit direction `dir` meets the sphere; `None` when it never does (a grazing
    /// touch is a span of zero length). The origin must lie outside the sphere throughout.
    pub fn covered_span(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        // The centre relative to the ray's line: p(t) = pw + pv t, both perpendicular to dir.
        let w0 = self.centre - origin;
        let pw = w0 - dir * w0.dot(dir);
        let pv = self.travel - dir * self.travel.dot(dir);
        let (a, b, c) = (pv.dot(pv), 2.0 * pw.dot(pv), pw.dot(pw) - self.radius * self.radius);
        let (t0, t1) = if a == 0.0 {
            // Still relative to the line (or not moving): covered throughout or never.
            if c <= 0.0 { (0.0, 1.0) } else { return None }
        } else {
            let (r0, r1) = solve_quadratic(a, b, c)?;
            (r0.max(0.0), r1.min(1.0))
        };
        if t0 > t1 {
            return None;
        }
        // Both crossings lie on one side of the origin, which is outside the sphere: the
        // sphere is in front when its centre is at the span's middle.
        let mid = 0.5 * (t0 + t1);
        ((self.centre + self.travel * mid - origin).dot(dir) > 0.0).then_some((t0, t1))
    }

    /// The fraction of the shutter in which the ray covers the sphere.
    pub fn coverage(&self, origin: DVec3, dir: DVec3) -> f64 {
        self.covered_span(origin, dir).map_or(0.0, |(t0, t1)| t1 - t0)
    }
}

/// The exact fraction of the shutter in which view `view` of `scene` sees the sphere at the
/// continuous pixel position `pixel` (x right, y down).
pub fn sample_coverage(scene: &FrameScene, view: usize, pixel: DVec2) -> f64 {
    let camera = &scene.views[view].camera;
    MovingSphere::of(scene).coverage(camera.position, camera.ray_direction(pixel))
}

/// The sphere's coverage of pixel `(x, y)` over area and shutter time: the mean of
/// [`sample_coverage`] over a `grid` x `grid` lattice of points at the pixel's cell centres
/// (the box pixel filter of the tracer, integrated by the midpoint rule in area and exactly in
/// time).
pub fn pixel_coverage(scene: &FrameScene, view: usize, x: u32, y: u32, grid: u32) -> f64 {
    let camera = &scene.views[view].camera;
    let sphere = MovingSphere::of(scene);
    let k = grid.max(1);
    let mut total = 0.0;
    for i in 0..k {
        for j in 0..k {
            let p = DVec2::new(
                f64::from(x) + (f64::from(i) + 0.5) / f64::from(k),
                f64::from(y) + (f64::from(j) + 0.5) / f64::from(k),
            );
            total += sphere.coverage(camera.position, camera.ray_direction(p));
        }
    }
    total / f64::from(k * k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(travel: DVec3) -> MovingSphere {
        MovingSphere { centre: DVec3::new(0.0, 0.0, 5.0), travel, radius: 1.0 }
    }

    #[test]
    fn a_sphere_crossing_the_ray_covers_it_for_its_diameter_over_its_speed() {
        // Moving 4 along x through the ray at the origin along +z: the centre is within 1 of
        // the line for x in [-1, 1], from t = 0.25 to 0.75 when it starts at x = -2.
        let s = MovingSphere { centre: DVec3::new(-2.0, 0.0, 5.0), ..sphere(DVec3::new(4.0, 0.0, 0.0)) };
        let (t0, t1) = s.covered_span(DVec3::ZERO, DVec3::Z).unwrap();
        assert!((t0 - 0.25).abs() < 1e-15 && (t1 - 0.75).abs() < 1e-15, "{t0} {t1}");
        // At half the radius off the line the chord is sqrt(3): covered for sqrt(3) / 4.
        let c = s.coverage(DVec3::new(0.0, 0.5, 0.0), DVec3::Z);
        assert!((c - 3f64.sqrt() / 4.0).abs() < 1e-15, "{c}");
    }

    #[test]
    fn still_grazing_clipped_and_behind() {
        let still = sphere(DVec3::ZERO);
        assert_eq!(still.covered_span(DVec3::ZERO, DVec3::Z), Some((0.0, 1.0)));
        assert_eq!(still.coverage(DVec3::new(1.5, 0.0, 0.0), DVec3::Z), 0.0);
        // Moving along the ray: the distance to the line does not change.
        assert_eq!(sphere(DVec3::new(0.0, 0.0, 3.0)).coverage(DVec3::ZERO, DVec3::Z), 1.0);
        // Tangent at one instant: a span of zero length.
        let s = MovingSphere { centre: DVec3::new(-1.0, 1.0, 5.0), ..sphere(DVec3::new(2.0, 0.0, 0.0)) };
        let (t0, t1) = s.covered_span(DVec3::ZERO, DVec3::Z).unwrap();
        assert!((t0 - 0.5).abs() < 1e-7 && (t1 - t0).abs() < 1e-7, "{t0} {t1}");
        // Entering before open and leaving after close: clipped to the shutter.
        let s = MovingSphere { centre: DVec3::new(-0.5, 0.0, 5.0), ..sphere(DVec3::new(1.0, 0.0, 0.0)) };
        assert_eq!(s.covered_span(DVec3::ZERO, DVec3::Z), Some((0.0, 1.0)));
        // Behind the eye: never seen.
        assert_eq!(sphere(DVec3::ZERO).coverage(DVec3::ZERO, -DVec3::Z), 0.0);
    }
}
