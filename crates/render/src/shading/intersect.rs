//! Ray intersection with the scene's two surfaces: the sphere (at its position for the
//! sample's time) and the floor plane.
//!
//! The sphere uses the cancellation-free quadratic: the discriminant is computed as
//! `r^2 - |f - (f.d) d|^2` (the squared distance of the line from the centre, which does
//! not lose precision when the origin is far away) and the two roots as `q` and `c / q`
//! with `q = b' + sign(b') sqrt(disc)`, so neither root subtracts nearly equal numbers.
//! Hit points on the sphere are re-projected onto it, and secondary rays start from the
//! hit point offset along the normal by a bound on its floating-point error. A ray that
//! leaves a convex surface on its outer side never meets that surface again, so the
//! tracer skips that surface rather than relying on an epsilon.

use crate::numeric::offset_along_normal;
use glam::DVec3;

/// A ray with a unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

/// Which surface a ray hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// The rolling sphere.
    Sphere,
    /// The floor plane.
    Floor,
}

/// The nearest hit of a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f64,
    /// Point on the surface.
    pub point: DVec3,
    /// Outward unit normal of the surface (the sphere's outside, the floor's +y side).
    pub normal: DVec3,
    /// The surface.
    pub surface: Surface,
}

/// Scene geometry at one instant.
#[derive(Clone, Copy, Debug)]
pub struct Geometry {
    /// Sphere centre.
    pub centre: DVec3,
    /// Sphere radius.
    pub radius: f64,
    /// Height of the floor plane (y).
    pub floor_height: f64,
}

/// Nearest root of the ray-sphere quadratic with `t > 0`, or `None`.
#[inline]
pub fn intersect_sphere(ray: &Ray, centre: DVec3, radius: f64) -> Option<f64> {
    let f = ray.origin - centre;
    let b = -f.dot(ray.dir);
    let v = f + b * ray.dir;
    let disc = radius * radius - v.length_squared();
    if disc < 0.0 || disc.is_nan() {
        return None;
    }
    let c = f.length_squared() - radius * radius;
    let q = b + disc.sqrt().copysign(b);
    if q == 0.0 {
        // Origin at the centre's plane with a tangent ray: both roots 0.
        return None;
    }
    let (t0, t1) = {
        let (a, b) = (c / q, q);
        if a < b { (a, b) } else { (b, a) }
    };
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

/// Whether the ray meets the sphere at some `t > 0`, without computing where: the roots'
/// product is `c = |f|^2 - r^2` and their sum `2 b`, so one is positive when `c < 0`
/// (the origin is inside) or, otherwise, when `b > 0`. Same discriminant as
/// [`intersect_sphere`], no square root or division.
#[inline]
pub fn sphere_blocks(ray: &Ray, centre: DVec3, radius: f64) -> bool {
    let f = ray.origin - centre;
    let b = -f.dot(ray.dir);
    let v = f + b * ray.dir;
    let disc = radius * radius - v.length_squared();
    if disc.is_nan() || disc < 0.0 {
        return false;
    }
    let c = f.length_squared() - radius * radius;
    c < 0.0 || b > 0.0
}

/// Distance to the floor plane, or `None` for rays parallel to it or pointing away.
#[inline]
pub fn intersect_floor(ray: &Ray, height: f64) -> Option<f64> {
    if ray.dir.y == 0.0 {
        return None;
    }
    let t = (height - ray.origin.y) / ray.dir.y;
    (t > 0.0 && t.is_finite()).then_some(t)
}

impl Geometry {
    /// Nearest hit; `skip` leaves out the surface a secondary ray leaves from its outer
    /// side (convex surfaces cannot be hit again).
    #[inline]
    pub fn intersect(&self, ray: &Ray, skip: Option<Surface>) -> Option<Hit> {
        let ts = if skip == Some(Surface::Sphere) { None } else { intersect_sphere(ray, self.centre, self.radius) };
        let tf = if skip == Some(Surface::Floor) { None } else { intersect_floor(ray, self.floor_height) };
        match (ts, tf) {
            (Some(ts), Some(tf)) if ts <= tf => Some(self.sphere_hit(ray, ts)),
            (Some(ts), None) => Some(self.sphere_hit(ray, ts)),
            (_, Some(tf)) => Some(self.floor_hit(ray, tf)),
            (None, None) => None,
        }
    }

    /// Whether anything blocks the ray (shadow rays towards the environment).
    #[inline]
    pub fn occluded(&self, ray: &Ray, skip: Option<Surface>) -> bool {
        (skip != Some(Surface::Floor) && intersect_floor(ray, self.floor_height).is_some())
            || (skip != Some(Surface::Sphere) && sphere_blocks(ray, self.centre, self.radius))
    }

    fn sphere_hit(&self, ray: &Ray, t: f64) -> Hit {
        let p = ray.origin + ray.dir * t;
        let n = (p - self.centre).normalize();
        // Re-project onto the sphere: removes the error accumulated along the ray.
        Hit { t, point: self.centre + n * self.radius, normal: n, surface: Surface::Sphere }
    }

    fn floor_hit(&self, ray: &Ray, t: f64) -> Hit {
        let mut p = ray.origin + ray.dir * t;
        p.y = self.floor_height;
        Hit { t, point: p, normal: DVec3::Y, surface: Surface::Floor }
    }
}

/// A ray leaving `hit` in direction `dir` (on the normal's side), its origin offset along
/// the normal by the hit point's error bound so it cannot start below the surface.
#[inline]
pub fn spawn_ray(hit: &Hit, dir: DVec3) -> Ray {
    Ray { origin: offset_along_normal(hit.point, hit.normal), dir }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn far_origin_hits_precisely() {
        // A naive (b^2 - 4ac) discriminant loses all digits here.
        let ray = Ray { origin: DVec3::new(0.0, 0.0, 1.0e7), dir: DVec3::new(0.0, 0.0, -1.0) };
        let t = intersect_sphere(&ray, DVec3::ZERO, 0.1).unwrap();
        assert!((t - (1.0e7 - 0.1)).abs() < 1e-8);
        let off = Ray { origin: DVec3::new(0.0999, 0.0, 1.0e7), ..ray };
        assert!(intersect_sphere(&off, DVec3::ZERO, 0.1).is_some());
        let miss = Ray { origin: DVec3::new(0.1001, 0.0, 1.0e7), ..ray };
        assert!(intersect_sphere(&miss, DVec3::ZERO, 0.1).is_none());
    }

    #[test]
    fn inside_and_behind() {
        let ray = Ray { origin: DVec3::ZERO, dir: DVec3::X };
        assert!((intersect_sphere(&ray, DVec3::ZERO, 2.0).unwrap() - 2.0).abs() < 1e-15);
        let behind = Ray { origin: DVec3::new(5.0, 0.0, 0.0), dir: DVec3::X };
        assert!(intersect_sphere(&behind, DVec3::ZERO, 1.0).is_none());
        let parallel = Ray { origin: DVec3::new(0.0, 1.0, 0.0), dir: DVec3::X };
        assert!(intersect_floor(&parallel, 0.0).is_none());
    }

    proptest! {
        #[test]
        fn blocking_test_agrees_with_the_intersection(
            ox in -2.0f64..2.0, oy in -2.0f64..2.0, oz in -2.0f64..2.0,
            dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0, r in 0.01f64..1.5,
        ) {
            let dir = DVec3::new(dx, dy, dz);
            prop_assume!(dir.length() > 1e-3);
            let ray = Ray { origin: DVec3::new(ox, oy, oz), dir: dir.normalize() };
            let centre = DVec3::new(0.1, 0.2, -0.3);
            prop_assert_eq!(sphere_blocks(&ray, centre, r), intersect_sphere(&ray, centre, r).is_some());
        }

        #[test]
        fn grazing_rays_give_finite_hits_on_the_surface(
            z in -1.0e3f64..-0.5, y in -1.0f64..1.0, eps in -1e-9f64..1e-9, dx in -1e-3f64..1e-3,
        ) {
            let r = 0.1;
            let centre = DVec3::new(0.0, 0.1, 0.0);
            // Aim at the silhouette: offset by r (+- eps) from the centre.
            let origin = DVec3::new(0.0, 0.1 + y, z);
            let target = centre + DVec3::new(r + eps, 0.0, 0.0);
            let dir = (target - origin + DVec3::new(0.0, 0.0, dx)).normalize();
            let ray = Ray { origin, dir };
            let geom = Geometry { centre, radius: r, floor_height: 0.0 };
            if let Some(hit) = geom.intersect(&ray, None) {
                prop_assert!(hit.t.is_finite() && hit.point.is_finite() && hit.normal.is_finite());
                if hit.surface == Surface::Sphere {
                    prop_assert!(((hit.point - centre).length() - r).abs() < 1e-12);
                }
                let out = spawn_ray(&hit, hit.normal);
                prop_assert!(out.origin.is_finite());
                // The spawned origin is on the outer side.
                if hit.surface == Surface::Sphere {
                    prop_assert!((out.origin - centre).length() >= r);
                } else {
                    prop_assert!(out.origin.y >= 0.0);
                }
            }
        }

        #[test]
        fn rays_near_the_contact_point_stay_finite(dx in -1e-6f64..1e-6, dy in 0.0f64..1e-6, a in 0.0f64..std::f64::consts::TAU) {
            let geom = Geometry { centre: DVec3::new(0.0, 0.1, 0.0), radius: 0.1, floor_height: 0.0 };
            let origin = DVec3::new(dx, dy + 1e-12, 0.0);
            let dir = DVec3::new(a.cos(), 0.3, a.sin()).normalize();
            let ray = Ray { origin, dir };
            if let Some(hit) = geom.intersect(&ray, Some(Surface::Floor)) {
                prop_assert!(hit.t.is_finite() && hit.point.is_finite());
            }
            // Parallel to the floor: never the floor.
            let flat = Ray { origin: DVec3::new(dx, 0.0, 1.0), dir: DVec3::new(a.cos(), 0.0, a.sin()) };
            if let Some(hit) = geom.intersect(&flat, None) {
                prop_assert_eq!(hit.surface, Surface::Sphere);
            }
        }
    }
}
