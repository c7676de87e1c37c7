//! Numerical helpers of the tracer's inner loop: trigonometry of angles given in turns
//! (fractions of a full circle, as samplers produce them) and a floor without a library
//! call.

use std::f64::consts::TAU;

/// `floor x` for `|x| < 2^52` without a library call (the baseline x86-64 target has no
/// rounding instruction, so `f64::floor` calls libm in the inner loop).
#[inline]
pub fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x { t - 1.0 } else { t }
}

// Polynomials in x^2 for sin(x) / x and cos(x) on |x| <= pi / 4, fitted on Chebyshev
// nodes (errors 3e-18 and 5e-17: below half an ulp, with two terms fewer than the Taylor
// series needs).
const S1: f64 = -0.16666666666666616;
const S2: f64 = 0.008333333333320366;
const S3: f64 = -0.00019841269828653024;
const S4: f64 = 2.7557313377251883e-06;
const S5: f64 = -2.5050717096836155e-08;
const S6: f64 = 1.5894743283863398e-10;
const C1: f64 = -0.4999999999999925;
const C2: f64 = 0.041666666666472375;
const C3: f64 = -0.0013888888869983285;
const C4: f64 = 2.4801578540009602e-05;
const C5: f64 = -2.7555234093295837e-07;
const C6: f64 = 2.063046564331699e-09;

/// `(sin 2 pi t, cos 2 pi t)` for `|t| < 2^50`, to within a few units in the last place.
///
/// The angle is reduced in turns, where the reduction is exact (`t - q / 4` with `q` the
/// nearest quarter turn), so the polynomials only see `|x| <= pi / 4`.
#[inline]
pub fn sin_cos_turns(t: f64) -> (f64, f64) {
    let q = floor(t * 4.0 + 0.5);
    let x = (t - q * 0.25) * TAU;
    let y = x * x;
    let s = x + x * y * (S1 + y * (S2 + y * (S3 + y * (S4 + y * (S5 + y * S6)))));
    let c = 1.0 + y * (C1 + y * (C2 + y * (C3 + y * (C4 + y * (C5 + y * C6)))));
    match (q as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `(sin x, cos x)` for `|x| <= pi / 128` (about 0.0245), to within 1e-17: the series to
/// `x^7` and `x^8` suffice there.
#[inline]
pub fn sin_cos_small(x: f64) -> (f64, f64) {
    let y = x * x;
    let s = x + x * y * (-1.0 / 6.0 + y * (1.0 / 120.0 + y * (-1.0 / 5040.0)));
    let c = 1.0 + y * (-0.5 + y * (1.0 / 24.0 + y * (-1.0 / 720.0 + y * (1.0 / 40320.0))));
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values() -> impl Iterator<Item = f64> {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        (0..200_000).map(move |_| {
            x = study::seed::splitmix64(x);
            (x >> 11) as f64 / (1u64 << 53) as f64
        })
    }

    #[test]
    fn sin_cos_turns_matches_std() {
        let special = [0.0, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0 - f64::EPSILON, 1e-300, -0.3, 7.25, 0.999_999];
        for t in values().chain(special) {
            let (s, c) = sin_cos_turns(t);
            let (es, ec) = (TAU * t).sin_cos();
            // The reference itself rounds 2 pi t; allow for that and a few ulps.
            let tol = 4.0 * f64::EPSILON * (1.0 + (TAU * t).abs());
            assert!((s - es).abs() <= tol && (c - ec).abs() <= tol, "t {t}: {s} {c} vs {es} {ec}");
        }
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
    }

    #[test]
    fn sin_cos_small_matches_std() {
        let limit = std::f64::consts::PI / 128.0;
        for u in values() {
            let x = (2.0 * u - 1.0) * limit;
            let (s, c) = sin_cos_small(x);
            assert!((s - x.sin()).abs() <= 2e-17 + f64::EPSILON * x.abs(), "{x}");
            assert!((c - x.cos()).abs() <= f64::EPSILON, "{x}");
        }
    }

    #[test]
    fn floor_matches_std() {
        for u in values() {
            for x in [u, -u, u * 1e6 - 5e5, -1e15 * u, u * 3.0 - 1.5] {
                assert_eq!(floor(x), x.floor(), "{x}");
            }
        }
        for x in [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 2.0f64.powi(51) + 0.5, -(2.0f64.powi(51)) - 0.5] {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
    }
}
