//! Thurstone Case V scaling of paired comparisons by maximum a posteriori estimation, with
//! bootstrap confidence intervals over judges.
//!
//! Model: `P(i preferred over j) = Phi((s_i - s_j) / sigma)` with
//! `sigma = 1 / Phi^{-1}(0.75) ~ 1.4826`, so that a difference of 1 unit is preferred in 75 %
//! of trials (the just-objectionable-difference unit pwcmp reports). The log-likelihood
//! `sum_{i,j} a_ij ln Phi((s_i - s_j) / sigma)` is concave; a weak Gaussian prior
//! `s_i ~ N(0, prior_sd^2)` (default 3 units) makes it strictly concave, so the estimate is
//! unique and finite for incomplete designs, disconnected comparison graphs and unanimous
//! pairs (a stimulus that always wins), where plain maximum likelihood diverges. At the
//! optimum the scores sum to zero (the prior's gradient balances the likelihood's, whose
//! components sum to zero), so scores are relative to their mean.
//!
//! The optimiser is Newton's method with a Cholesky solve and backtracking line search.
//! Bootstrap: judges are resampled with replacement (a seeded PCG64 generator), every
//! resample is refitted from the full-data estimate, and percentile intervals are reported.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::paired::PreferenceMatrix;
use crate::srange::{normal_pdf, normal_sf};

/// `sigma` of the Case V model in JOD units: `1 / Phi^{-1}(0.75)`.
pub const JOD_SIGMA: f64 = 1.482_602_218_505_602;

/// The most bootstrap resamples (`analyze --bootstrap` refuses more).
pub const MAX_RESAMPLES: usize = 100_000;

/// Options of the scaling.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScaleOptions {
    /// Standard deviation of the Gaussian prior on each score, in JOD units.
    pub prior_sd: f64,
    /// Bootstrap resamples (0 for none; at most [`MAX_RESAMPLES`], more are clamped).
    pub resamples: usize,
    /// Seed of the bootstrap's PCG64 generator.
    pub seed: u64,
    /// Confidence level of the intervals, e.g. 0.95.
    pub confidence: f64,
}

impl Default for ScaleOptions {
    fn default() -> Self {
        Self { prior_sd: 3.0, resamples: 1000, seed: 1, confidence: 0.95 }
    }
}

/// Scores on the Case V scale with their bootstrap intervals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scale {
    /// MAP scores in JOD units, mean zero.
    pub scores: Vec<f64>,
    /// Lower ends of the percentile intervals (empty without bootstrap).
    pub lower: Vec<f64>,
    /// Upper ends of the percentile intervals (empty without bootstrap).
    pub upper: Vec<f64>,
    /// The options used (seed included, so the intervals can be reproduced).
    pub options: ScaleOptions,
    /// Newton iterations of the full-data fit.
    pub iterations: usize,
}

/// `ln Phi(x)`, finite for very negative `x`.
fn log_cdf(x: f64) -> f64 {
    if x > -30.0 { normal_sf(-x).ln() } else { -0.5 * x * x - (-x).ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() }
}

/// The inverse Mills ratio `phi(x) / Phi(x)`.
fn mills(x: f64) -> f64 {
    if x > -30.0 { normal_pdf(x) / normal_sf(-x) } else { -x - 1.0 / x }
}

fn objective(m: &PreferenceMatrix, s: &[f64], lambda: f64) -> f64 {
    let t = s.len();
    let mut value = -0.5 * lambda * s.iter().map(|x| x * x).sum::<f64>();
    for i in 0..t {
        for j in 0..t {
            let a = m.counts[i][j];
            if a > 0 {
                value += f64::from(a) * log_cdf((s[i] - s[j]) / JOD_SIGMA);
            }
        }
    }
    value
}

/// Solves `A x = b` for a symmetric positive definite `A` (row-major, `t x t`) by Cholesky.
fn cholesky_solve(a: &mut [f64], b: &mut [f64], t: usize) -> bool {
    for j in 0..t {
        let mut d = a[j * t + j];
        for k in 0..j {
            d -= a[j * t + k] * a[j * t + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j * t + j] = d;
        for i in j + 1..t {
            let mut v = a[i * t + j];
            for k in 0..j {
                v -= a[i * t + k] * a[j * t + k];
            }
            a[i * t + j] = v / d;
        }
    }
    for i in 0..t {
        let mut v = b[i];
        for k in 0..i {
            v -= a[i * t + k] * b[k];
        }
        b[i] = v / a[i * t + i];
    }
    for i in (0..t).rev() {
        let mut v = b[i];
        for k in i + 1..t {
            v -= a[k * t + i] * b[k];
        }
        b[i] = v / a[i * t + i];
    }
    true
}

/// Fits the Case V scores by MAP from `start` (zeros if `None`); returns scores and the
/// number of Newton iterations.
pub fn fit_case_v(m: &PreferenceMatrix, prior_sd: f64, start: Option<&[f64]>) -> (Vec<f64>, usize) {
    let t = m.t();
    let lambda = 1.0 / (prior_sd * prior_sd);
    let mut s: Vec<f64> = start.map_or_else(|| vec![0.0; t], <[f64]>::to_vec);
    let mut current = objective(m, &s, lambda);
    let mut hessian = vec![0.0; t * t];
    let mut step = vec![0.0; t];
    for iteration in 1..=100 {
        // Gradient and negated Hessian.
        hessian.iter_mut().for_each(|h| *h = 0.0);
        for i in 0..t {
            step[i] = -lambda * s[i];
            hessian[i * t + i] = lambda;
        }
        for i in 0..t {
            for j in 0..t {
                let a = m.counts[i][j];
                if a == 0 {
                    continue;
                }
                let a = f64::from(a);
                let x = (s[i] - s[j]) / JOD_SIGMA;
                let h = mills(x);
                let g = a * h / JOD_SIGMA;
                step[i] += g;
                step[j] -= g;
                let curvature = a * h * (x + h) / (JOD_SIGMA * JOD_SIGMA);
                hessian[i * t + i] += curvature;
                hessian[j * t + j] += curvature;
                hessian[i * t + j] -= curvature;
                hessian[j * t + i] -= curvature;
            }
        }
        let gradient_norm = step.iter().fold(0.0_f64, |acc, g| acc.max(g.abs()));
        if gradient_norm < 1e-10 {
            return (s, iteration - 1);
        }
        if !cholesky_solve(&mut hessian, &mut step, t) {
            break;
        }
        // Backtracking line search on the concave objective.
        let mut factor = 1.0;
        loop {
            let trial: Vec<f64> = s.iter().zip(&step).map(|(x, d)| x + factor * d).collect();
            let value = objective(m, &trial, lambda);
            if value >= current - 1e-12 * current.abs() || factor < 1e-8 {
                s = trial;
                current = value;
                break;
            }
            factor *= 0.5;
        }
        if step.iter().fold(0.0_f64, |acc, d| acc.max((factor * d).abs())) < 1e-12 {
            return (s, iteration);
        }
    }
    (s, 100)
}

/// The bootstrap fits: `options.resamples` (clamped to [`MAX_RESAMPLES`]) resamples of
/// `judges` drawn with replacement from a PCG64 generator seeded with `options.seed`, each
/// refitted from `start`. Returns one score vector per resample (empty without judges).
pub fn bootstrap_fits(judges: &[PreferenceMatrix], start: &[f64], options: ScaleOptions) -> Vec<Vec<f64>> {
    let resamples = options.resamples.min(MAX_RESAMPLES);
    let Some(first) = judges.first() else { return Vec::new() };
    let t = first.t();
    let mut rng = Pcg64::seed_from_u64(options.seed);
    let mut fits = Vec::with_capacity(resamples);
    let mut resampled = PreferenceMatrix::new(t);
    for _ in 0..resamples {
        resampled.counts.iter_mut().flatten().for_each(|c| *c = 0);
        for _ in 0..judges.len() {
            resampled.add_matrix(&judges[rng.random_range(0..judges.len())]);
        }
        fits.push(fit_case_v(&resampled, options.prior_sd, Some(start)).0);
    }
    fits
}

/// Scales the stimuli of the summed matrix, with bootstrap intervals from `judges` (one
/// matrix per judge, resampled with replacement; their sum should be `total`).
pub fn scale_with_bootstrap(total: &PreferenceMatrix, judges: &[PreferenceMatrix], options: ScaleOptions) -> Scale {
    scale_with_bootstrap_fits(total, judges, options).0
}

/// [`scale_with_bootstrap`] that also returns the bootstrap fits ([`bootstrap_fits`]).
pub fn scale_with_bootstrap_fits(
    total: &PreferenceMatrix,
    judges: &[PreferenceMatrix],
    options: ScaleOptions,
) -> (Scale, Vec<Vec<f64>>) {
    let t = total.t();
    let (scores, iterations) = fit_case_v(total, options.prior_sd, None);
    let (mut lower, mut upper) = (Vec::new(), Vec::new());
    let options = ScaleOptions { resamples: options.resamples.min(MAX_RESAMPLES), ..options };
    let fits = if options.resamples > 0 { bootstrap_fits(judges, &scores, options) } else { Vec::new() };
    if !fits.is_empty() {
        let tail = (1.0 - options.confidence) / 2.0;
        for i in 0..t {
            let mut column: Vec<f64> = fits.iter().map(|f| f[i]).collect();
            column.sort_by(f64::total_cmp);
            lower.push(percentile(&column, tail));
            upper.push(percentile(&column, 1.0 - tail));
        }
    }
    (Scale { scores, lower, upper, options, iterations }, fits)
}

/// Linear-interpolated percentile of sorted values (`q` in [0, 1]).
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let below = position.floor() as usize;
    let above = (below + 1).min(sorted.len() - 1);
    let frac = position - below as f64;
    sorted[below] * (1.0 - frac) + sorted[above] * frac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_known_differences_from_large_counts() {
        // True scores 0, 1, 2 JOD; counts are n * P(i > j) rounded.
        let truth = [0.0, 1.0, 2.0];
        let n = 100_000.0;
        let mut m = PreferenceMatrix::new(3);
        for i in 0..3 {
            for j in 0..3 {
                if i != j {
                    let p = 1.0 - normal_sf((truth[i] - truth[j]) / JOD_SIGMA);
                    m.counts[i][j] = (n * p).round() as u32;
                }
            }
        }
        let (s, _) = fit_case_v(&m, 1e3, None);
        assert!((s[1] - s[0] - 1.0).abs() < 0.01 && (s[2] - s[1] - 1.0).abs() < 0.01, "{s:?}");
        assert!(s.iter().sum::<f64>().abs() < 1e-6);
        // One JOD is 75 %.
        assert!((1.0 - normal_sf(1.0 / JOD_SIGMA) - 0.75).abs() < 1e-12);
    }

    #[test]
    fn a_stimulus_that_always_wins_and_an_incomplete_design_stay_finite() {
        // Stimulus 0 wins every comparison; stimulus 3 is compared only with 2.
        let mut m = PreferenceMatrix::new(4);
        for _ in 0..30 {
            m.add(0, 1);
            m.add(0, 2);
            m.add(1, 2);
            m.add(2, 3);
        }
        m.add(2, 1);
        let judges = vec![m.clone()];
        let scale = scale_with_bootstrap(&m, &judges, ScaleOptions { resamples: 50, ..Default::default() });
        assert!(scale.scores.iter().all(|s| s.is_finite()));
        assert!(
            scale.scores[0] > scale.scores[1] && scale.scores[1] > scale.scores[2] && scale.scores[2] > scale.scores[3]
        );
        assert!(scale.iterations < 50);
        // Disconnected components are also fine.
        let m = PreferenceMatrix::from_wins(4, [(0, 1), (0, 1), (3, 2)]);
        let (s, _) = fit_case_v(&m, 3.0, None);
        assert!(s.iter().all(|x| x.is_finite()) && s[0] > s[1] && s[3] > s[2]);
    }

    #[test]
    fn bootstrap_is_reproducible_and_brackets_the_estimate() {
        let mut judges = Vec::new();
        for k in 0..12u32 {
            let mut j = PreferenceMatrix::new(3);
            j.add(0, 1);
            if k % 3 == 0 {
                j.add(2, 1)
            } else {
                j.add(1, 2)
            }
            if k % 4 == 0 {
                j.add(2, 0)
            } else {
                j.add(0, 2)
            }
            judges.push(j);
        }
        let mut total = PreferenceMatrix::new(3);
        judges.iter().for_each(|j| total.add_matrix(j));
        let options = ScaleOptions { resamples: 200, seed: 7, ..Default::default() };
        let a = scale_with_bootstrap(&total, &judges, options);
        let b = scale_with_bootstrap(&total, &judges, options);
        assert_eq!(a, b);
        for i in 0..3 {
            assert!(a.lower[i] <= a.scores[i] + 1e-9 && a.scores[i] <= a.upper[i] + 1e-9, "{a:?}");
        }
    }
}
