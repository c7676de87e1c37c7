//! Paired-comparison statistics after Kendall and Babington Smith (1940) and David (1988):
//! the preference matrix and scores, circular triads and the coefficient of consistency
//! zeta of one judge, and the coefficient of agreement u of several judges.
//!
//! Notation: `t` stimuli, `m` judges (each judging every pair once), `a_ij` the number of
//! judgments preferring `i` over `j`, `a_i = sum_j a_ij` the score of `i`.

use serde::Serialize;
use statrs::distribution::{Binomial, ChiSquared, ContinuousCDF, DiscreteCDF};

/// Why a statistic cannot be computed from the given data.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PairedError {
    /// A judge's matrix is not a complete tournament (every pair judged exactly once).
    #[error("pair ({0}, {1}) was judged {2} times by this judge, expected exactly once")]
    NotATournament(usize, usize, u32),
    /// The design is not balanced (every pair judged the same number of times).
    #[error("pair ({0}, {1}) was judged {2} times, expected {3} like the first pair")]
    Unbalanced(usize, usize, u32, u32),
    /// Too few stimuli or judges.
    #[error("{0}")]
    TooSmall(String),
}

/// Counts `a_ij` of judgments preferring stimulus `i` over stimulus `j`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PreferenceMatrix {
    /// `counts[i][j]` = times `i` was preferred over `j` (the diagonal is zero).
    pub counts: Vec<Vec<u32>>,
}

impl PreferenceMatrix {
    /// An empty matrix for `t` stimuli.
    pub fn new(t: usize) -> Self {
        Self { counts: vec![vec![0; t]; t] }
    }

    /// Builds a matrix from `(winner, loser)` pairs.
    pub fn from_wins(t: usize, wins: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut m = Self::new(t);
        for (w, l) in wins {
            m.add(w, l);
        }
        m
    }

    /// Records one judgment preferring `winner` over `loser`.
    pub fn add(&mut self, winner: usize, loser: usize) {
        assert_ne!(winner, loser, "a stimulus cannot be compared with itself");
        self.counts[winner][loser] += 1;
    }

    /// Adds another matrix of the same size.
    pub fn add_matrix(&mut self, other: &PreferenceMatrix) {
        for (row, other_row) in self.counts.iter_mut().zip(&other.counts) {
            for (a, b) in row.iter_mut().zip(other_row) {
                *a += b;
            }
        }
    }

    /// Number of stimuli `t`.
    pub fn t(&self) -> usize {
        self.counts.len()
    }

    /// Times the pair `(i, j)` was judged: `a_ij + a_ji`.
    pub fn judged(&self, i: usize, j: usize) -> u32 {
        self.counts[i][j] + self.counts[j][i]
    }

    /// Scores `a_i = sum_j a_ij`: how often each stimulus was preferred over any other.
    pub fn scores(&self) -> Vec<u32> {
        self.counts.iter().map(|row| row.iter().sum()).collect()
    }

    /// Total number of judgments.
    pub fn total(&self) -> u32 {
        self.scores().iter().sum()
    }

    /// The number of judgments per pair if every pair was judged equally often.
    pub fn balanced_judges(&self) -> Result<u32, PairedError> {
        let t = self.t();
        if t < 2 {
            return Err(PairedError::TooSmall(format!("{t} stimuli, expected at least 2")));
        }
        let m = self.judged(0, 1);
        for i in 0..t {
            for j in i + 1..t {
                let n = self.judged(i, j);
                if n != m {
                    return Err(PairedError::Unbalanced(i, j, n, m));
                }
            }
        }
        Ok(m)
    }
}

/// The largest possible number of circular triads among `t` stimuli: `(t^3 - t) / 24` for
/// odd `t` and `(t^3 - 4t) / 24` for even `t`.
pub fn max_circular_triads(t: usize) -> u64 {
    let t = t as u64;
    if t % 2 == 1 { (t * t * t - t) / 24 } else { (t * t * t - 4 * t) / 24 }
}

/// Circular triads of one judge (a complete tournament: every pair judged exactly once) by
/// Kendall's formula `d = t(t-1)(2t-1)/12 - (1/2) sum_i a_i^2`.
pub fn circular_triads(judge: &PreferenceMatrix) -> Result<u64, PairedError> {
    let t = judge.t();
    for i in 0..t {
        for j in i + 1..t {
            let n = judge.judged(i, j);
            if n != 1 {
                return Err(PairedError::NotATournament(i, j, n));
            }
        }
    }
    let t64 = t as u64;
    let sum_sq: u64 = judge.scores().iter().map(|&a| u64::from(a) * u64::from(a)).sum();
    // 2d = t(t-1)(2t-1)/6 - sum a_i^2, an exact integer identity for tournaments.
    let twice = (t64 * t64.saturating_sub(1) * (2 * t64).saturating_sub(1)) / 6 - sum_sq;
    Ok(twice / 2)
}

/// Circular triads by enumerating every triple (the definition; used to verify the formula):
/// a triple `{i, j, k}` is circular when each of its members beats exactly one other.
pub fn circular_triads_brute_force(judge: &PreferenceMatrix) -> u64 {
    let t = judge.t();
    let beats = |a: usize, b: usize| judge.counts[a][b] > judge.counts[b][a];
    let mut d = 0;
    for i in 0..t {
        for j in i + 1..t {
            for k in j + 1..t {
                if (beats(i, j) && beats(j, k) && beats(k, i)) || (beats(j, i) && beats(k, j) && beats(i, k)) {
                    d += 1;
                }
            }
        }
    }
    d
}

/// Kendall's coefficient of consistency `zeta = 1 - d / d_max`: `1 - 24 d / (t^3 - t)` for
/// odd `t`, `1 - 24 d / (t^3 - 4t)` for even `t`. Undefined (None) for `t < 3`, where no
/// triad exists.
pub fn consistency_zeta(d: u64, t: usize) -> Option<f64> {
    let max = max_circular_triads(t);
    (max > 0).then(|| 1.0 - d as f64 / max as f64)
}

/// Kendall's chi-square approximation for the number of circular triads of a judge who
/// chooses at random, usable for `t >= 5`:
/// `chi2 = 8/(t-4) [C(t,3)/4 - d + 1/2] + nu`, `nu = t(t-1)(t-2)/(t-4)^2` degrees of freedom.
/// A small p-value means fewer triads than chance: the judge is significantly consistent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TriadTest {
    /// The statistic.
    pub chi_square: f64,
    /// Degrees of freedom `nu` (not an integer in general).
    pub df: f64,
    /// Upper-tail probability of the statistic.
    pub p_value: f64,
}

/// The chi-square test of `d` for `t >= 5` (None for smaller `t`).
pub fn triads_chi_square(d: u64, t: usize) -> Option<TriadTest> {
    if t < 5 {
        return None;
    }
    let tf = t as f64;
    let c3 = tf * (tf - 1.0) * (tf - 2.0) / 6.0;
    let df = tf * (tf - 1.0) * (tf - 2.0) / ((tf - 4.0) * (tf - 4.0));
    let chi_square = 8.0 / (tf - 4.0) * (c3 / 4.0 - d as f64 + 0.5) + df;
    Some(TriadTest { chi_square, df, p_value: chi_square_sf(chi_square, df) })
}

/// Upper tail of the chi-square distribution with `df` degrees of freedom.
pub fn chi_square_sf(x: f64, df: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    ChiSquared::new(df).map(|c| c.sf(x)).unwrap_or(f64::NAN)
}

/// Kendall's coefficient of agreement for `m` judges who each judged every pair once.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Agreement {
    /// Number of judges `m`.
    pub judges: u32,
    /// `Sigma = sum_{i != j} C(a_ij, 2)`: pairs of judges agreeing, summed over pairs.
    pub sigma: u64,
    /// `u = 2 Sigma / (C(m,2) C(t,2)) - 1`.
    pub u: f64,
    /// Lowest possible `u` for this `m`: `-1/(m-1)` for even `m`, `-1/m` for odd `m`.
    pub u_min: f64,
    /// Chi-square statistic `4/(m-2) [Sigma - C(t,2) C(m,2) (m-3) / (2 (m-2))]` (m >= 3);
    /// for `m = 2`, `Sigma` itself (binomial test).
    pub chi_square: f64,
    /// Degrees of freedom `C(t,2) m (m-1) / (m-2)^2` (m >= 3); for `m = 2`, `C(t,2)`.
    pub df: f64,
    /// Probability of at least this much agreement among judges choosing at random.
    pub p_value: f64,
}

fn choose2(n: u64) -> u64 {
    n * n.saturating_sub(1) / 2
}

/// Kendall's coefficient of agreement `u` with its lower bound, chi-square statistic,
/// degrees of freedom and p-value, from the summed matrix of `m` judges (a balanced design:
/// every pair judged `m >= 2` times).
pub fn agreement(matrix: &PreferenceMatrix) -> Result<Agreement, PairedError> {
    let m = matrix.balanced_judges()?;
    if m < 2 {
        return Err(PairedError::TooSmall(format!("{m} judgment per pair, agreement needs at least 2 judges")));
    }
    let t = matrix.t() as u64;
    let m64 = u64::from(m);
    let sigma: u64 = matrix.counts.iter().flatten().map(|&a| choose2(u64::from(a))).sum();
    let pairs = choose2(t) as f64;
    let judge_pairs = choose2(m64) as f64;
    let u = 2.0 * sigma as f64 / (judge_pairs * pairs) - 1.0;
    let u_min = if m % 2 == 0 { -1.0 / (f64::from(m) - 1.0) } else { -1.0 / f64::from(m) };
    let (chi_square, df, p_value) = if m == 2 {
        // Sigma counts the pairs on which both judges agree: Binomial(C(t,2), 1/2).
        let binomial = Binomial::new(0.5, choose2(t)).expect("valid binomial");
        let p = if sigma == 0 { 1.0 } else { binomial.sf(sigma - 1) };
        (sigma as f64, pairs, p)
    } else {
        let mf = f64::from(m);
        let chi = 4.0 / (mf - 2.0) * (sigma as f64 - pairs * judge_pairs * (mf - 3.0) / (2.0 * (mf - 2.0)));
        let df = pairs * mf * (mf - 1.0) / ((mf - 2.0) * (mf - 2.0));
        (chi, df, chi_square_sf(chi, df))
    };
    Ok(Agreement { judges: m, sigma, u, u_min, chi_square, df, p_value })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A random tournament on t stimuli from a bit pattern.
    fn tournament(t: usize, bits: &[bool]) -> PreferenceMatrix {
        let mut m = PreferenceMatrix::new(t);
        let mut k = 0;
        for i in 0..t {
            for j in i + 1..t {
                if bits[k % bits.len()] {
                    m.add(i, j)
                } else {
                    m.add(j, i)
                }
                k += 1;
            }
        }
        m
    }

    proptest! {
        #[test]
        fn formula_equals_brute_force(t in 2usize..12, bits in proptest::collection::vec(any::<bool>(), 66)) {
            let m = tournament(t, &bits);
            prop_assert_eq!(circular_triads(&m).unwrap(), circular_triads_brute_force(&m));
        }
    }

    #[test]
    fn maximal_triads_for_odd_and_even_t_give_zeta_zero() {
        // Odd t: the regular tournament i beats i+1..i+(t-1)/2 (mod t) has every score equal.
        for t in [3usize, 5, 7, 9] {
            let mut m = PreferenceMatrix::new(t);
            for i in 0..t {
                for k in 1..=(t - 1) / 2 {
                    m.add(i, (i + k) % t);
                }
            }
            let d = circular_triads(&m).unwrap();
            assert_eq!(d, max_circular_triads(t));
            assert_eq!(d, circular_triads_brute_force(&m));
            assert_eq!(consistency_zeta(d, t), Some(0.0));
        }
        // Even t: scores t/2 and t/2 - 1, half each, reach (t^3 - 4t)/24.
        for t in [4usize, 6, 8] {
            let mut m = PreferenceMatrix::new(t);
            for i in 0..t {
                for k in 1..t / 2 {
                    m.add(i, (i + k) % t);
                }
                if i < t / 2 {
                    m.add(i, i + t / 2);
                }
            }
            let d = circular_triads(&m).unwrap();
            assert_eq!(d, max_circular_triads(t), "t {t}");
            assert_eq!(consistency_zeta(d, t), Some(0.0));
        }
        // A transitive judge has none.
        let m = PreferenceMatrix::from_wins(6, (0..6).flat_map(|i| (i + 1..6).map(move |j| (i, j))));
        assert_eq!(circular_triads(&m).unwrap(), 0);
        assert_eq!(consistency_zeta(0, 6), Some(1.0));
        // t = 2 has no triads and no zeta.
        let m = PreferenceMatrix::from_wins(2, [(1, 0)]);
        assert_eq!(circular_triads(&m).unwrap(), 0);
        assert_eq!(consistency_zeta(0, 2), None);
        assert!(triads_chi_square(0, 4).is_none());
    }

    #[test]
    fn triad_test_separates_consistent_from_random_judges() {
        let consistent = triads_chi_square(0, 9).unwrap();
        assert!(consistent.p_value < 0.001, "{consistent:?}");
        let worst = triads_chi_square(max_circular_triads(9), 9).unwrap();
        assert!(worst.p_value > 0.99, "{worst:?}");
        // nu = t(t-1)(t-2)/(t-4)^2 = 9*8*7/25 for t = 9.
        assert!((consistent.df - 20.16).abs() < 1e-12);
    }

    #[test]
    fn incomplete_judge_is_rejected() {
        let m = PreferenceMatrix::from_wins(3, [(0, 1), (1, 2)]);
        assert_eq!(circular_triads(&m), Err(PairedError::NotATournament(0, 2, 0)));
    }

    fn judges_matrix(t: usize, judges: &[PreferenceMatrix]) -> PreferenceMatrix {
        let mut total = PreferenceMatrix::new(t);
        for j in judges {
            total.add_matrix(j);
        }
        total
    }

    #[test]
    fn unanimous_judges_give_u_one() {
        for m in [2usize, 3, 4, 7] {
            let t = 5;
            let judge = PreferenceMatrix::from_wins(t, (0..t).flat_map(|i| (i + 1..t).map(move |j| (i, j))));
            let a = agreement(&judges_matrix(t, &vec![judge; m])).unwrap();
            assert!((a.u - 1.0).abs() < 1e-12, "m {m}: {a:?}");
            assert!(a.p_value < 0.05, "m {m}: {a:?}");
        }
    }

    #[test]
    fn maximal_disagreement_reaches_the_lower_bound() {
        // Even m: every pair split m/2 : m/2 gives u = -1/(m-1).
        // Odd m: every pair split (m+1)/2 : (m-1)/2 gives u = -1/m.
        for (m, t) in [(2u32, 2usize), (4, 3), (6, 4), (3, 5), (5, 2), (21, 9)] {
            let mut matrix = PreferenceMatrix::new(t);
            for i in 0..t {
                for j in i + 1..t {
                    matrix.counts[i][j] = m.div_ceil(2);
                    matrix.counts[j][i] = m / 2;
                }
            }
            let a = agreement(&matrix).unwrap();
            assert!((a.u - a.u_min).abs() < 1e-12, "m {m} t {t}: {a:?}");
            let expected = if m % 2 == 0 { -1.0 / f64::from(m - 1) } else { -1.0 / f64::from(m) };
            assert!((a.u_min - expected).abs() < 1e-15);
            assert!(a.p_value > 0.5, "m {m} t {t}: {a:?}");
        }
    }

    #[test]
    fn agreement_chi_square_matches_kendall_formula_by_hand() {
        // t = 3, m = 4: a_01 = 4, a_02 = 3, a_12 = 2 (others by complement).
        let mut matrix = PreferenceMatrix::new(3);
        for (i, j, a) in [(0, 1, 4), (0, 2, 3), (1, 2, 2)] {
            matrix.counts[i][j] = a;
            matrix.counts[j][i] = 4 - a;
        }
        let a = agreement(&matrix).unwrap();
        // Sigma = C(4,2) + C(3,2) + C(1,2) + C(2,2) + C(2,2) = 6 + 3 + 0 + 1 + 1 = 11.
        assert_eq!(a.sigma, 11);
        assert!((a.u - (2.0 * 11.0 / (6.0 * 3.0) - 1.0)).abs() < 1e-12);
        // chi2 = 4/(m-2) (Sigma - C(t,2) C(m,2) (m-3)/(2(m-2))) = 2 (11 - 3*6*1/4) = 13.
        assert!((a.chi_square - 13.0).abs() < 1e-12);
        assert!((a.df - 3.0 * 4.0 * 3.0 / 4.0).abs() < 1e-12);
    }

    #[test]
    fn unbalanced_design_is_reported() {
        let matrix = PreferenceMatrix::from_wins(3, [(0, 1), (1, 0), (0, 2)]);
        assert!(matches!(agreement(&matrix), Err(PairedError::Unbalanced(0, 2, 1, 2))));
    }
}
