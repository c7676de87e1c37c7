//! Small statistics shared by every crate: compensated (Neumaier) summation, and the mean
//! and spread of a sample. Benchmarks, frame-pacing reports, Monte Carlo tests and the cost
//! report all summarise with these, so a standard deviation means the same everywhere.

/// A running sum with Neumaier's compensation (Kahan-Babuska): the error of adding `n`
/// values is about one rounding of the result instead of growing with `n`, also when a
/// term is larger than the running sum.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompensatedSum {
    sum: f64,
    compensation: f64,
}

impl CompensatedSum {
    /// An empty sum.
    pub const fn new() -> Self {
        CompensatedSum { sum: 0.0, compensation: 0.0 }
    }

    /// Adds `x`.
    #[inline]
    pub fn add(&mut self, x: f64) {
        let t = self.sum + x;
        // The low-order bits lost in `t`, from whichever operand was smaller.
        self.compensation += if self.sum.abs() >= x.abs() { (self.sum - t) + x } else { (x - t) + self.sum };
        self.sum = t;
    }

    /// The sum so far.
    #[inline]
    pub fn value(&self) -> f64 {
        self.sum + self.compensation
    }
}

impl FromIterator<f64> for CompensatedSum {
    fn from_iter<I: IntoIterator<Item = f64>>(iter: I) -> Self {
        let mut s = CompensatedSum::new();
        iter.into_iter().for_each(|x| s.add(x));
        s
    }
}

/// The compensated sum of `values`.
pub fn sum(values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().collect::<CompensatedSum>().value()
}

/// Count, mean, spread and extremes of a sample, computed in two compensated passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Summary {
    /// Number of values.
    pub n: usize,
    /// Arithmetic mean (0 for an empty sample).
    pub mean: f64,
    /// Sum of squared deviations from the mean.
    pub squared_deviations: f64,
    /// Smallest value (+inf for an empty sample).
    pub min: f64,
    /// Largest value (-inf for an empty sample).
    pub max: f64,
}

impl Summary {
    /// Summarises `values`.
    pub fn of(values: &[f64]) -> Summary {
        let n = values.len();
        let mean = if n == 0 { 0.0 } else { sum(values.iter().copied()) / n as f64 };
        let squared_deviations = sum(values.iter().map(|x| (x - mean) * (x - mean)));
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Summary { n, mean, squared_deviations, min, max }
    }

    /// Standard deviation of the values themselves (divides by n; 0 below two values).
    pub fn population_sd(&self) -> f64 {
        if self.n < 2 { 0.0 } else { (self.squared_deviations / self.n as f64).sqrt() }
    }

    /// Unbiased sample standard deviation (divides by n - 1; 0 below two values).
    pub fn sample_sd(&self) -> f64 {
        if self.n < 2 { 0.0 } else { (self.squared_deviations / (self.n - 1) as f64).sqrt() }
    }

    /// Standard error of the mean, `sample_sd / sqrt(n)` (0 below two values).
    pub fn standard_error(&self) -> f64 {
        if self.n < 2 { 0.0 } else { self.sample_sd() / (self.n as f64).sqrt() }
    }
}

/// The median of `values` (the mean of the middle two for an even count; NaN when empty).
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// The Pearson correlation of two equally long samples (NaN when either is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "correlation of samples of different lengths");
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// Ranks from 1, tied values given their mean rank (mid-ranks).
pub fn ranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut out = vec![0.0; x.len()];
    let mut k = 0;
    while k < order.len() {
        let mut e = k;
        while e + 1 < order.len() && x[order[e + 1]] == x[order[k]] {
            e += 1;
        }
        let rank = (k + e) as f64 / 2.0 + 1.0;
        for &o in &order[k..=e] {
            out[o] = rank;
        }
        k = e + 1;
    }
    out
}

/// Spearman's rank correlation: the [`correlation`] of the mid-[`ranks`] (NaN when either
/// sample is constant).
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    correlation(&ranks(a), &ranks(b))
}

/// The standard normal distribution function `Phi(x)`.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * statrs::function::erf::erfc(-x / std::f64::consts::SQRT_2)
}

/// `Phi^-1(0.75)`: the probit of one JOD (just-objectionable difference).
pub const Z75: f64 = 0.674_489_750_196_081_7;

/// The probability that people prefer a sequence of quality `a` JOD over one of `b` JOD: by
/// the unit's definition 1 JOD is 75 % preference, so with Thurstone's case V
/// `P = Phi(z75 (a - b))`, no slope to fit.
pub fn jod_preference(a: f64, b: f64) -> f64 {
    normal_cdf(Z75 * (a - b))
}

/// Kendall's rank correlation tau-b: concordant minus discordant pairs over the geometric
/// mean of the pairs untied in each sample (NaN when either sample is constant).
pub fn kendall_tau_b(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "Kendall's tau of samples of different lengths");
    let (mut concordant, mut discordant, mut untied_a, mut untied_b) = (0i64, 0i64, 0i64, 0i64);
    for i in 0..a.len() {
        for j in i + 1..a.len() {
            let (da, db) = ((a[i] - a[j]).signum(), (b[i] - b[j]).signum());
            let (ta, tb) = (a[i] != a[j], b[i] != b[j]);
            untied_a += i64::from(ta);
            untied_b += i64::from(tb);
            if ta && tb {
                if da == db {
                    concordant += 1;
                } else {
                    discordant += 1;
                }
            }
        }
    }
    (concordant - discordant) as f64 / ((untied_a as f64) * (untied_b as f64)).sqrt()
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn kendall_tau_b_counts_ties_as_scipy_does() {
        // scipy.stats.kendalltau([1, 2, 3, 4, 5], [5, 6, 7, 8, 7]) = 0.737864787372622 (tau-b).
        let t = kendall_tau_b(&[1.0, 2.0, 3.0, 4.0, 5.0], &[5.0, 6.0, 7.0, 8.0, 7.0]);
        assert!((t - 0.737_864_787_372_622).abs() < 1e-12, "{t}");
        assert!((kendall_tau_b(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        assert!(kendall_tau_b(&[1.0, 1.0], &[1.0, 2.0]).is_nan());
    }

    #[test]
    fn spearman_uses_mid_ranks() {
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), [3.5, 1.0, 3.5, 2.0]);
        assert!((spearman(&[1.0, 2.0, 3.0], &[10.0, 20.0, 40.0]) - 1.0).abs() < 1e-12);
        // Ranks (1.5, 1.5, 3) against (1, 2, 3).
        assert!((spearman(&[0.0, 0.0, 1.0], &[1.0, 2.0, 3.0]) - 0.866_025_403_784_438_6).abs() < 1e-12);
        assert!(spearman(&[1.0, 1.0], &[1.0, 2.0]).is_nan());
    }

    #[test]
    fn correlation_of_lines_and_of_a_symmetric_pair() {
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((correlation(&a, &[3.0, 5.0, 7.0, 9.0]) - 1.0).abs() < 1e-15);
        assert!((correlation(&a, &[-1.0, -2.0, -3.0, -4.0]) + 1.0).abs() < 1e-15);
        assert_eq!(correlation(&[-1.0, 0.0, 1.0], &[1.0, 0.0, 1.0]), 0.0);
    }

    /// The exact sum, correctly rounded, of values that are multiples of 2^-40 below 2^80
    /// in magnitude: in fixed point with 2^-40 resolution each is an integer, summed exactly
    /// in i128.
    fn exact_sum(values: &[f64]) -> f64 {
        let scale = 2f64.powi(40);
        let total: i128 = values.iter().map(|&v| (v * scale) as i128).sum();
        total as f64 / scale
    }

    #[test]
    fn cancellation_that_naive_summation_gets_wrong() {
        let values = [1.0, 1e16, 1.0, -1e16];
        assert_eq!(values.iter().sum::<f64>(), 0.0);
        assert_eq!(sum(values), 2.0);
        let many = std::iter::once(1e10).chain(std::iter::repeat_n(1e-6, 1_000_000));
        assert!((sum(many) - (1e10 + 1.0)).abs() < 1e-6);
    }

    #[test]
    fn summary_of_a_known_sample() {
        let s = Summary::of(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!((s.n, s.mean, s.min, s.max), (8, 5.0, 2.0, 9.0));
        assert_eq!(s.population_sd(), 2.0);
        assert!((s.sample_sd() - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert!((s.standard_error() - (32.0f64 / 7.0).sqrt() / 8f64.sqrt()).abs() < 1e-15);
        let empty = Summary::of(&[]);
        assert_eq!((empty.n, empty.mean, empty.population_sd()), (0, 0.0, 0.0));
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    proptest! {
        #[test]
        fn compensated_sum_is_within_neumaiers_bound(
            parts in prop::collection::vec((-(1i64 << 40)..(1i64 << 40), 0i32..=40), 1..200)
        ) {
            // m * 2^-k: magnitudes from 2^-40 to 2^40, heavy cancellation between signs.
            let values: Vec<f64> = parts.iter().map(|&(m, k)| m as f64 * 2f64.powi(-k)).collect();
            let exact = exact_sum(&values);
            let got = sum(values.iter().copied());
            // |error| <= 2 eps |exact| + O(n eps^2) sum |x|.
            let abs: f64 = values.iter().map(|v| v.abs()).sum();
            let bound = 2.0 * f64::EPSILON * exact.abs() + 4.0 * f64::EPSILON * f64::EPSILON * abs * values.len() as f64;
            prop_assert!((got - exact).abs() <= bound, "got {got}, exact {exact}");
        }
    }
}
