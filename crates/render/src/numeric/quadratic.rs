//! Real roots of `a x^2 + b x + c = 0` without catastrophic cancellation: the discriminant
//! by a difference of products (exact to about one rounding even when `b^2` and `4 a c`
//! nearly cancel), then `q = -(b + sign(b) sqrt(disc)) / 2` and the roots `q / a` and
//! `c / q`, so the smaller root is never the difference of two nearly equal numbers.

use super::eft::{difference_of_products, difference_of_products_f32};

/// One body for both widths, so the f32 twin cannot drift from the f64 solver.
macro_rules! solve_quadratic_impl {
    ($(#[$doc:meta])* $name:ident, $t:ty, $dop:ident) => {
        $(#[$doc])*
        pub fn $name(a: $t, b: $t, c: $t) -> Option<($t, $t)> {
            if a == 0.0 {
                if b == 0.0 {
                    return None;
                }
                let x = -c / b;
                return Some((x, x));
            }
            let disc = $dop(b, b, 4.0 * a, c);
            if disc < 0.0 || disc.is_nan() {
                return None;
            }
            let q = -0.5 * (b + disc.sqrt().copysign(b));
            if q == 0.0 {
                // b = 0 and c = 0: the double root 0.
                return Some((0.0, 0.0));
            }
            let (r0, r1) = (q / a, c / q);
            Some(if r0 <= r1 { (r0, r1) } else { (r1, r0) })
        }
    };
}

solve_quadratic_impl!(
    /// The real roots of `a x^2 + b x + c`, smaller first (equal for a double root); `None`
    /// without real roots. A zero `a` leaves the linear equation (its root twice); `a = b = 0`
    /// has no isolated root.
    solve_quadratic,
    f64,
    difference_of_products
);
solve_quadratic_impl!(
    /// [`solve_quadratic`] in f32 (the GPU kernels' twin; same steps as `numeric.wgsl`).
    solve_quadratic_f32,
    f32,
    difference_of_products_f32
);

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::numeric::eft::{two_product, two_sum};

    /// A double-double number `hi + lo` (about 106 bits): the f64 reference's reference.
    #[derive(Clone, Copy, Debug)]
    struct Dd(f64, f64);

    impl Dd {
        fn from(x: f64) -> Dd {
            Dd(x, 0.0)
        }
        fn add(self, o: Dd) -> Dd {
            let (s, e) = two_sum(self.0, o.0);
            let (s, e2) = two_sum(s, e + self.1 + o.1);
            Dd(s, e2)
        }
        fn neg(self) -> Dd {
            Dd(-self.0, -self.1)
        }
        fn mul(self, o: Dd) -> Dd {
            let (p, e) = two_product(self.0, o.0);
            let (s, e2) = two_sum(p, e + self.0 * o.1 + self.1 * o.0);
            Dd(s, e2)
        }
        fn div(self, o: Dd) -> Dd {
            let q = self.0 / o.0;
            // One Newton correction: r = self - q o, q += r / o.
            let r = self.add(o.mul(Dd::from(q)).neg());
            let (s, e) = two_sum(q, r.0 / o.0);
            Dd(s, e)
        }
        fn sqrt(self) -> Dd {
            if self.0 <= 0.0 {
                return Dd(0.0, 0.0);
            }
            let s = self.0.sqrt();
            let r = self.add(Dd::from(s).mul(Dd::from(s)).neg());
            let (h, l) = two_sum(s, r.0 / (2.0 * s));
            Dd(h, l)
        }
        fn value(self) -> f64 {
            self.0 + self.1
        }
    }

    /// The roots in double-double arithmetic, rounded to f64.
    fn reference(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
        let (a, b, c) = (Dd::from(a), Dd::from(b), Dd::from(c));
        let disc = b.mul(b).add(Dd::from(4.0).mul(a).mul(c).neg());
        if disc.value() < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let q = if b.0 >= 0.0 { b.add(sq).mul(Dd::from(-0.5)) } else { b.add(sq.neg()).mul(Dd::from(-0.5)) };
        let (r0, r1) = (q.div(a).value(), c.div(q).value());
        Some(if r0 <= r1 { (r0, r1) } else { (r1, r0) })
    }

    fn relative(got: f64, want: f64) -> f64 {
        (got - want).abs() / want.abs().max(f64::MIN_POSITIVE)
    }

    /// The textbook formula the helpers replace.
    fn naive(a: f64, b: f64, c: f64) -> (f64, f64) {
        let d = (b * b - 4.0 * a * c).sqrt();
        ((-b - d) / (2.0 * a), (-b + d) / (2.0 * a))
    }

    #[test]
    fn tiny_root_next_to_a_large_one() {
        // x^2 - 1e9 x + 1: roots 1e9 and 1e-9. The naive small root is the difference of two
        // numbers near 1e9 and keeps no correct digit.
        let (a, b, c) = (1.0, -1e9, 1.0);
        let (small, large) = solve_quadratic(a, b, c).unwrap();
        assert!(relative(small, 1e-9) < 1e-15, "{small}");
        assert!(relative(large, 1e9) < 1e-15, "{large}");
        assert!(relative(naive(a, b, c).0, 1e-9) > 1e-3);
        let (small, large) = solve_quadratic_f32(1.0, -1e4, 1.0).unwrap();
        assert!((f64::from(small) - 1e-4).abs() / 1e-4 < 1e-6, "{small}");
        assert!((f64::from(large) - 1e4).abs() / 1e4 < 1e-6, "{large}");
    }

    #[test]
    fn near_double_roots_and_degenerate_cases() {
        // (x - 1)(x - (1 + 2^-26)): b^2 - 4ac = 2^-52, lost by the naive discriminant.
        let e = 2f64.powi(-26);
        let (a, b, c) = (1.0, -(2.0 + e), 1.0 + e);
        let (r0, r1) = solve_quadratic(a, b, c).unwrap();
        assert_eq!((r0, r1), (1.0, 1.0 + e));
        assert_eq!(solve_quadratic(1.0, 0.0, 1.0), None);
        assert_eq!(solve_quadratic(1.0, 0.0, 0.0), Some((0.0, 0.0)));
        assert_eq!(solve_quadratic(0.0, 2.0, -4.0), Some((2.0, 2.0)));
        assert_eq!(solve_quadratic(0.0, 0.0, 1.0), None);
        assert_eq!(solve_quadratic(f64::NAN, 1.0, 1.0), None);
        assert_eq!(solve_quadratic_f32(1.0, 0.0, -4.0), Some((-2.0, 2.0)));
        assert_eq!(solve_quadratic_f32(0.0, 0.0, 1.0), None);
    }

    /// How far a backward-stable solver may put root `w` of `a x^2 + b x + c` (other root
    /// at distance `sep`): relative coefficient perturbations of `k eps` move a simple root
    /// by `k eps (|a| w^2 + |b w| + |c|) / |p'(w)|` with `|p'(w)| = |a| sep`.
    fn tolerance(k: f64, eps: f64, (a, b, c): (f64, f64, f64), w: f64, sep: f64) -> f64 {
        let conditioning = (a.abs() * w * w + (b * w).abs() + c.abs()) / (a.abs() * sep.max(f64::MIN_POSITIVE));
        k * eps * (w.abs() + conditioning)
    }

    proptest! {
        #[test]
        fn f64_roots_match_the_double_double_reference(
            r0 in -1e6f64..1e6, r1 in -1e6f64..1e6, scale in 1e-3f64..1e3
        ) {
            // Coefficients of scale (x - r0)(x - r1), rounded to f64: the reference solves the
            // rounded polynomial, so the comparison has no representation error.
            let (a, b, c) = (scale, -scale * (r0 + r1), scale * r0 * r1);
            if let Some((w0, w1)) = reference(a, b, c) {
                let (g0, g1) = solve_quadratic(a, b, c).expect("real roots");
                let sep = w1 - w0;
                prop_assert!((g0 - w0).abs() <= tolerance(4.0, f64::EPSILON, (a, b, c), w0, sep), "{g0} vs {w0}");
                prop_assert!((g1 - w1).abs() <= tolerance(4.0, f64::EPSILON, (a, b, c), w1, sep), "{g1} vs {w1}");
            }
        }

        #[test]
        fn f32_roots_match_the_f64_solution(r0 in -1e3f32..1e3, r1 in -1e3f32..1e3, scale in 1e-2f32..1e2) {
            let (a, b, c) = (scale, -scale * (r0 + r1), scale * r0 * r1);
            let coefficients = (f64::from(a), f64::from(b), f64::from(c));
            // The double-double solution of the same (f32-rounded) coefficients.
            if let Some((w0, w1)) = reference(coefficients.0, coefficients.1, coefficients.2) {
                let (g0, g1) = solve_quadratic_f32(a, b, c).expect("real roots");
                let (eps, sep) = (f64::from(f32::EPSILON), w1 - w0);
                prop_assert!((f64::from(g0) - w0).abs() <= tolerance(4.0, eps, coefficients, w0, sep), "{g0} vs {w0}");
                prop_assert!((f64::from(g1) - w1).abs() <= tolerance(4.0, eps, coefficients, w1, sep), "{g1} vs {w1}");
            }
        }

        #[test]
        fn the_small_root_keeps_its_relative_accuracy(large in 1e3f64..1e12, small in 1e-12f64..1e-3) {
            // (x - large)(x - small): the cancellation case of the textbook formula.
            let (a, b, c) = (1.0, -(large + small), large * small);
            let (w0, _) = reference(a, b, c).unwrap();
            let (g0, _) = solve_quadratic(a, b, c).unwrap();
            prop_assert!(relative(g0, w0) <= 4.0 * f64::EPSILON, "{g0} vs {w0}");
        }
    }
}
