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
use glam::{DVec3, Vec3};

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

/// One body for both widths: the f64 reference and the GPU kernels' f32 twin
/// (`shading::gpu::radiance`, mirrored by `radiance.wgsl`) run these same operations.
macro_rules! intersect_impl {
    ($t:ty, $v:ty, $sphere:ident, $blocks:ident, $floor:ident) => {
        /// Nearest root with `t > 0` of the sphere's quadratic for the ray from `o` along
        /// the unit direction `d`, or `None`.
        #[inline]
        pub fn $sphere(o: $v, d: $v, centre: $v, radius: $t) -> Option<$t> {
            let f = o - centre;
            let b = -f.dot(d);
            let v = f + d * b;
            let disc = radius * radius - v.dot(v);
            if disc < 0.0 || disc.is_nan() {
                return None;
            }
            let c = f.dot(f) - radius * radius;
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

        /// Whether the ray meets the sphere at some `t > 0`, without computing where: the
        /// roots' product is `c = |f|^2 - r^2` and their sum `2 b`, so one is positive when
        /// `c < 0` (the origin is inside) or, otherwise, when `b > 0`. Same discriminant as
        #[doc = concat!("[`", stringify!($sphere), "`], no square root or division.")]
        #[inline]
        pub fn $blocks(o: $v, d: $v, centre: $v, radius: $t) -> bool {
            let f = o - centre;
            let b = -f.dot(d);
            let v = f + d * b;
            let disc = radius * radius - v.dot(v);
            if disc.is_nan() || disc < 0.0 {
                return false;
            }
            let c = f.dot(f) - radius * radius;
            c < 0.0 || b > 0.0
        }

        /// Distance to the floor plane at `height`, or `None` for rays parallel to it or
        /// pointing away (and beyond the largest finite distance).
        #[inline]
        pub fn $floor(o: $v, d: $v, height: $t) -> Option<$t> {
            if d.y == 0.0 {
                return None;
            }
            let t = (height - o.y) / d.y;
            (t > 0.0 && t < <$t>::MAX).then_some(t)
        }
    };
}

intersect_impl!(f64, DVec3, sphere_root, sphere_ahead, floor_root);
intersect_impl!(f32, Vec3, sphere_root_f32, sphere_ahead_f32, floor_root_f32);

/// Nearest root of the ray-sphere quadratic with `t > 0`, or `None`.
#[inline]
pub fn intersect_sphere(ray: &Ray, centre: DVec3, radius: f64) -> Option<f64> {
    sphere_root(ray.origin, ray.dir, centre, radius)
}

/// Whether the ray meets the sphere at some `t > 0` ([`sphere_ahead`]).
#[inline]
pub fn sphere_blocks(ray: &Ray, centre: DVec3, radius: f64) -> bool {
    sphere_ahead(ray.origin, ray.dir, centre, radius)
}

/// Distance to the floor plane, or `None` for rays parallel to it or pointing away.
#[inline]
pub fn intersect_floor(ray: &Ray, height: f64) -> Option<f64> {
    floor_root(ray.origin, ray.dir, height)
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
    fn both_widths_find_the_same_roots() {
        for i in 0..1000 {
            let t = f64::from(i);
            let o = DVec3::new(3.0 * (t * 0.37).sin(), 0.5 + (t * 0.11).cos(), -4.0 + (t * 0.07).sin());
            let d =
                (DVec3::new(0.1, 0.4, 0.0) - o + DVec3::new((t * 0.3).sin(), 0.0, (t * 0.2).cos()) * 0.2).normalize();
            let (c, r) = (DVec3::new(0.0, 0.4, 0.0), 0.4);
            let wide = sphere_root(o, d, c, r);
            let narrow = sphere_root_f32(o.as_vec3(), d.as_vec3(), c.as_vec3(), r as f32);
            match (wide, narrow) {
                (Some(a), Some(b)) => assert!((a - f64::from(b)).abs() < 1e-5 * a.max(1.0), "{a} {b}"),
                (None, None) => {}
                // Grazing rays may round to the other side of the tangent.
                (a, b) => {
                    assert!(sphere_ahead(o, d, c, r * 1.0001) && !sphere_ahead(o, d, c, r * 0.9999), "{a:?} {b:?}")
                }
            }
            assert_eq!(sphere_ahead(o, d, c, r), wide.is_some());
            let floor = (floor_root(o, d, 0.0), floor_root_f32(o.as_vec3(), d.as_vec3(), 0.0));
            assert_eq!(floor.0.is_some(), floor.1.is_some());
        }
    }

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
