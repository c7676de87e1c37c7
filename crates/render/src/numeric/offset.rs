//! Ray-origin offsets: a ray leaving a surface starts on the surface's side of every point
//! its computed hit point could really be, so it cannot hit the surface it leaves
//! (self-intersection, "acne"). The f64 form is the CPU tracer's (offset along the normal by
//! a bound on the point's error relative to its magnitude); the f32 form is pbrt-v4's
//! `OffsetRayOrigin` with a per-component error bound and rounding away from the surface.

use glam::DVec3;

/// Relative error bound of a hit point in the f64 tracer: a small multiple of the unit
/// round-off covering the few operations that produce it.
pub const HIT_POINT_ERROR: f64 = 16.0 * f64::EPSILON;

/// `point` moved along the unit `normal` by its error bound, `HIT_POINT_ERROR (|p|_max + 1)`
/// (the `+ 1` covers points near the origin, whose error is absolute).
#[inline]
pub fn offset_along_normal(point: DVec3, normal: DVec3) -> DVec3 {
    let err = HIT_POINT_ERROR * (point.abs().max_element() + 1.0);
    point + normal * err
}

/// The next f32 above `v` (infinity stays, -0 becomes the smallest positive).
#[inline]
pub fn next_float_up_f32(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The next f32 below `v`.
#[inline]
pub fn next_float_down_f32(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v > 0.0 { bits - 1 } else { bits + 1 })
}

/// Origin for a ray leaving point `p` (with absolute error at most `p_error` per component)
/// of a surface with normal `n` in direction `w`: `p` moved along `n` (or `-n` when `w` goes
/// below the surface) by the error box's extent along `n`, each component then rounded one
/// more float away from `p` so the move survives rounding.
pub fn offset_ray_origin_f32(p: [f32; 3], p_error: [f32; 3], n: [f32; 3], w: [f32; 3]) -> [f32; 3] {
    let d = n[0].abs() * p_error[0] + n[1].abs() * p_error[1] + n[2].abs() * p_error[2];
    let towards = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
    let sign = if towards < 0.0 { -1.0 } else { 1.0 };
    std::array::from_fn(|i| {
        let offset = sign * d * n[i];
        let po = p[i] + offset;
        if offset > 0.0 {
            next_float_up_f32(po)
        } else if offset < 0.0 {
            next_float_down_f32(po)
        } else {
            po
        }
    })
}

/// `gamma(n) = n eps / (1 - n eps)` in f32 with `eps` the unit round-off (half an ulp):
/// the bound on the relative error of `n` rounded operations.
pub fn gamma_f32(n: u32) -> f32 {
    let e = 0.5 * f32::EPSILON * n as f32;
    e / (1.0 - e)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn next_floats_step_one_ulp() {
        assert_eq!(next_float_up_f32(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down_f32(1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_float_up_f32(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down_f32(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up_f32(-1.0), -1.0 + f32::EPSILON / 2.0);
        assert_eq!(next_float_up_f32(f32::INFINITY), f32::INFINITY);
        assert_eq!(next_float_down_f32(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(next_float_up_f32(f32::MAX), f32::INFINITY);
    }

    #[test]
    fn the_f64_offset_is_the_documented_bound() {
        let p = DVec3::new(3.0, -1.0, 0.5);
        let moved = offset_along_normal(p, DVec3::Y);
        assert_eq!(moved - p, DVec3::new(0.0, HIT_POINT_ERROR * 4.0, 0.0));
    }

    /// The hit of a ray on a sphere in f32 (re-projected onto the sphere, as the GPU kernel
    /// does), its error bound, the normal.
    fn f32_sphere_hit(centre: DVec3, radius: f64, from: DVec3, dir: DVec3) -> Option<([f32; 3], [f32; 3], [f32; 3])> {
        let c = centre.as_vec3();
        let (o, d, r) = (from.as_vec3(), dir.as_vec3().normalize(), radius as f32);
        let f = o - c;
        let b = -f.dot(d);
        let v = f + b * d;
        let disc = r * r - v.length_squared();
        if disc <= 0.0 {
            return None;
        }
        let cc = f.length_squared() - r * r;
        let q = b + disc.sqrt().copysign(b);
        let t = (cc / q).min(q);
        if t <= 0.0 {
            return None;
        }
        let n = (o + d * t - c).normalize();
        let p = c + n * r;
        // Re-projection leaves errors from c + n r: a few roundings of |c| + r, plus the
        // normal's error times r.
        let err = p.abs() * gamma_f32(5) + glam::Vec3::splat(r * gamma_f32(8));
        Some((p.to_array(), err.to_array(), n.to_array()))
    }

    proptest! {
        #[test]
        fn the_f32_origin_leaves_the_surface_on_the_ray_side(
            cx in -8.0f64..8.0, cz in -8.0f64..8.0, radius in 0.05f64..1.0,
            theta in 0.0f64..std::f64::consts::PI, phi in 0.0f64..std::f64::consts::TAU,
            out_theta in 0.0f64..std::f64::consts::FRAC_PI_2, out_phi in 0.0f64..std::f64::consts::TAU,
            inward in any::<bool>()
        ) {
            // A ray from a camera near the origin aimed at a point of a sphere up to 8 m away.
            let centre = DVec3::new(cx, radius, cz);
            let target = centre + radius * DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            let from = DVec3::new(0.1, 0.3, 0.2);
            let Some((p, err, n)) = f32_sphere_hit(centre, radius, from, target - from) else { return Ok(()) };
            // An outgoing direction in the hemisphere of n (or of -n for a refracted ray).
            let n64 = DVec3::from_array(n.map(f64::from));
            let (t, b) = n64.any_orthonormal_pair();
            let side = if inward { -1.0 } else { 1.0 };
            let w64 = (t * out_theta.sin() * out_phi.cos() + b * out_theta.sin() * out_phi.sin() + side * n64 * out_theta.cos().max(1e-3)).normalize();
            let w = w64.as_vec3().to_array();
            let o = offset_ray_origin_f32(p, err, n, w);
            // In exact (f64) terms the new origin is outside the true sphere for an outgoing
            // ray and inside for an inward one, whatever the hit point's real error was.
            let distance = (DVec3::from_array(o.map(f64::from)) - centre).length() - radius;
            if inward {
                prop_assert!(distance < 0.0, "origin {distance} outside for an inward ray");
            } else {
                prop_assert!(distance > 0.0, "origin {distance} inside for an outgoing ray");
            }
            // And it moved no further than a few error bounds.
            let bound = 4.0 * f64::from(err.iter().copied().fold(0.0f32, f32::max));
            prop_assert!(distance.abs() <= bound + 1e-12, "moved {distance}, bound {bound}");
        }
    }
}
