//! Forecast votes: the expected outcome of a paired-comparison test from an image-computable
//! observer's per-sequence qualities, grouped exactly as `analyze` groups people's votes, and
//! how well the forecast agrees with a published table.
//!
//! - ColorVideoVDP's qualities are in JOD, and by the unit's definition a difference of 1 JOD
//!   means that 75 % of people prefer the better sequence. With Thurstone's case V that fixes
//!   the choice probability without a fitted slope: `P(i over j) = Phi(z75 (Q_i - Q_j))`,
//!   `z75 = Phi^-1(0.75)` ([`preference_from_jod`]).
//! - FLIP distances have no such scale; the FLIP observer's probability is that of its
//!   simulated decision (`runner::flip_observer`): each distance plus Gaussian noise of
//!   `sigma`, the smaller wins ([`preference_from_distances`]).
//! - Judged as a pair ([`preference_from_pair`]): the better of the two (by its quality
//!   against the shared reference) is the other's reference, and the worse one's quality
//!   against it, `Q_pair`, measures the difference directly: `10 - Q_pair` JOD, so
//!   `P(better over worse) = Phi(z75 (10 - Q_pair))`. A shared reference that both sequences
//!   are far from compresses their difference; the pair does not.
//! - With `m` judges each judging every pair once, stimulus `i` expects
//!   `m sum_j P(i over j)` votes; David's groups are computed on these expected counts with
//!   the same critical range as for counted votes ([`ExpectedVotes::groups`]).
//! - Agreement with a published table: Spearman's and Kendall's (tau-b) rank correlations of
//!   the vote totals, and the adjusted Rand index of the groups. David's groups may overlap;
//!   for the index each stimulus's class is the set of groups it belongs to (stimuli in
//!   exactly the same groups are one class), which is a partition of the stimuli
//!   ([`membership_classes`]).

use serde::Serialize;

use crate::grouping::{CriticalRange, critical_range, significance_groups};
use crate::srange::normal_cdf;

pub use study::stats::{Z75, jod_preference as preference_from_jod};

/// Probability that the FLIP observer prefers the sequence at distance `a` from its
/// reference over the one at `b`, with decision noise `sigma` on each distance (`sigma` 0:
/// the smaller distance always wins, a tie is a coin toss).
pub fn preference_from_distances(a: f64, b: f64, sigma: f64) -> f64 {
    if sigma > 0.0 {
        normal_cdf((b - a) / (sigma * std::f64::consts::SQRT_2))
    } else if a < b {
        1.0
    } else if a > b {
        0.0
    } else {
        0.5
    }
}

/// Probability that sequence `i` (quality `q_i` against the shared reference) is preferred
/// over `j` (`q_j`) when the worse of the two, judged with the better as its reference, has
/// quality `q_pair` (JOD): `Phi(z75 (10 - q_pair))` for the better one, the complement for the
/// worse one, a coin toss when the shared qualities tie (then neither is the better).
pub fn preference_from_pair(q_i: f64, q_j: f64, q_pair: f64) -> f64 {
    let better = preference_from_jod(10.0, q_pair.min(10.0));
    match q_i.total_cmp(&q_j) {
        std::cmp::Ordering::Greater => better,
        std::cmp::Ordering::Less => 1.0 - better,
        std::cmp::Ordering::Equal => 0.5,
    }
}

/// A forecast of a complete paired-comparison test.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExpectedVotes {
    /// Stimulus labels.
    pub labels: Vec<String>,
    /// `probability[i][j]`: `P(i preferred over j)`; the diagonal is 0.
    pub probability: Vec<Vec<f64>>,
    /// Judgements of each pair.
    pub judges: u32,
    /// Expected votes of each stimulus: `judges * sum_j probability[i][j]`.
    pub votes: Vec<f64>,
}

impl ExpectedVotes {
    /// The forecast for `labels` with pairwise preference `prefer(i, j)` and `judges`
    /// judgements per pair.
    pub fn new(labels: Vec<String>, judges: u32, prefer: impl Fn(usize, usize) -> f64) -> ExpectedVotes {
        let t = labels.len();
        let probability: Vec<Vec<f64>> =
            (0..t).map(|i| (0..t).map(|j| if i == j { 0.0 } else { prefer(i, j) }).collect()).collect();
        let votes = probability.iter().map(|row| f64::from(judges) * row.iter().sum::<f64>()).collect();
        ExpectedVotes { labels, probability, judges, votes }
    }

    /// David's critical range and groups (labels, most preferred first) of the expected
    /// counts at level `alpha`.
    pub fn groups(&self, alpha: f64) -> Result<(CriticalRange, Vec<Vec<String>>), crate::srange::SrangeError> {
        let critical = critical_range(self.labels.len(), self.judges, alpha)?;
        let groups = significance_groups(&self.votes, critical.ceil_rc as f64)
            .into_iter()
            .map(|g| g.into_iter().map(|i| self.labels[i].clone()).collect())
            .collect();
        Ok((critical, groups))
    }
}

/// Each label's class: the indices of the groups that hold it, as a partition of `labels`
/// (class ids from 0 in order of first appearance). A label in no group is a class alone.
pub fn membership_classes(labels: &[String], groups: &[Vec<String>]) -> Vec<usize> {
    let signatures: Vec<Vec<usize>> = labels
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let mut s: Vec<usize> = groups.iter().enumerate().filter(|(_, g)| g.contains(l)).map(|(i, _)| i).collect();
            if s.is_empty() {
                s.push(usize::MAX - k);
            }
            s
        })
        .collect();
    let mut seen: Vec<&Vec<usize>> = Vec::new();
    signatures
        .iter()
        .map(|s| {
            seen.iter().position(|x| *x == s).unwrap_or_else(|| {
                seen.push(s);
                seen.len() - 1
            })
        })
        .collect()
}

/// The adjusted Rand index of two partitions of the same items (Hubert and Arabie 1985): 1
/// for identical partitions, about 0 for independent ones. When both partitions are trivial
/// in the same way (all items together, or all apart) the index is 1 if they are identical.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> f64 {
    assert_eq!(a.len(), b.len(), "partitions of different item counts");
    let pairs = |n: usize| (n * n.saturating_sub(1)) as f64 / 2.0;
    let ka = a.iter().max().map_or(0, |m| m + 1);
    let kb = b.iter().max().map_or(0, |m| m + 1);
    let mut table = vec![vec![0usize; kb]; ka];
    for (&x, &y) in a.iter().zip(b) {
        table[x][y] += 1;
    }
    let index: f64 = table.iter().flatten().map(|&n| pairs(n)).sum();
    let sum_a: f64 = table.iter().map(|row| pairs(row.iter().sum())).sum();
    let sum_b: f64 = (0..kb).map(|j| pairs(table.iter().map(|row| row[j]).sum())).sum();
    let expected = sum_a * sum_b / pairs(a.len());
    let max = 0.5 * (sum_a + sum_b);
    if (max - expected).abs() < 1e-12 {
        return if index == max { 1.0 } else { 0.0 };
    }
    (index - expected) / (max - expected)
}

/// How a forecast agrees with published votes and groups.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Agreement {
    /// Spearman's rank correlation of the vote totals.
    pub spearman: f64,
    /// Kendall's tau-b of the vote totals.
    pub kendall: f64,
    /// Adjusted Rand index of the groups' membership classes.
    pub adjusted_rand: f64,
    /// Whether the groups are the same sets of members.
    pub same_groups: bool,
}

/// The agreement of forecast votes and groups with published ones, over the same labels.
pub fn agreement(
    labels: &[String],
    predicted_votes: &[f64],
    predicted_groups: &[Vec<String>],
    published_votes: &[f64],
    published_groups: &[Vec<String>],
) -> Agreement {
    Agreement {
        spearman: study::stats::spearman(predicted_votes, published_votes),
        kendall: study::stats::kendall_tau_b(predicted_votes, published_votes),
        adjusted_rand: adjusted_rand_index(
            &membership_classes(labels, predicted_groups),
            &membership_classes(labels, published_groups),
        ),
        same_groups: crate::votes::groups_as_sets(predicted_groups) == crate::votes::groups_as_sets(published_groups),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn one_jod_is_three_quarters_of_people() {
        assert!((preference_from_jod(8.0, 7.0) - 0.75).abs() < 1e-9);
        assert!((preference_from_jod(7.0, 8.0) - 0.25).abs() < 1e-9);
        assert!((preference_from_jod(9.0, 9.0) - 0.5).abs() < 1e-15);
        assert!((preference_from_distances(0.01, 0.02, 0.0) - 1.0).abs() < 1e-15);
        // Two noisy distances: the difference has sd sigma sqrt 2.
        let p = preference_from_distances(0.0, 0.005 * std::f64::consts::SQRT_2, 0.005);
        assert!((p - normal_cdf(1.0)).abs() < 1e-12);
    }

    #[test]
    fn a_pair_judged_against_itself_takes_its_direction_from_the_shared_reference() {
        // The shared reference sees 0.02 JOD between them; judged as a pair they are 1 JOD
        // apart, so three people in four prefer the better one.
        assert!((preference_from_pair(9.05, 9.03, 9.0) - 0.75).abs() < 1e-9);
        assert!((preference_from_pair(9.03, 9.05, 9.0) - 0.25).abs() < 1e-9);
        // The magnitude is the pair's alone, however close the shared qualities are.
        let p = preference_from_pair(9.000_001, 9.0, 7.0);
        assert!((p - normal_cdf(3.0 * Z75)).abs() < 1e-12, "{p}");
        // Identical sequences, a tie of the shared qualities, or a pair quality at the
        // metric's top (or above it by rounding): no preference beyond a coin toss.
        assert_eq!(preference_from_pair(9.0, 9.0, 8.0), 0.5);
        assert!((preference_from_pair(9.5, 9.0, 10.0) - 0.5).abs() < 1e-15);
        assert!((preference_from_pair(9.5, 9.0, 10.000_1) - 0.5).abs() < 1e-15);
        for (a, b, q) in [(9.1, 9.2, 8.5), (7.0, 9.9, 6.0)] {
            assert!((preference_from_pair(a, b, q) + preference_from_pair(b, a, q) - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn expected_votes_total_the_judgements_and_group_as_counted_votes_do() {
        let q = [9.5, 9.0, 7.0, 3.0];
        let f = ExpectedVotes::new(labels(&["A", "B", "C", "D"]), 20, |i, j| preference_from_jod(q[i], q[j]));
        let total: f64 = f.votes.iter().sum();
        assert!((total - 20.0 * 6.0).abs() < 1e-9, "{total}");
        for i in 0..4 {
            for j in 0..4 {
                if i != j {
                    assert!((f.probability[i][j] + f.probability[j][i] - 1.0).abs() < 1e-12);
                }
            }
        }
        // Integer-valued expectations group like a published table of the same numbers.
        let (critical, groups) = f.groups(0.01).unwrap();
        let direct = significance_groups(&f.votes, critical.ceil_rc as f64);
        assert_eq!(groups.len(), direct.len());
        assert_eq!(groups[0][0], "A");
        assert_eq!(groups.last().unwrap(), &vec!["D".to_string()]);
    }

    #[test]
    fn adjusted_rand_index_matches_sklearn() {
        // sklearn.metrics.adjusted_rand_score([0, 0, 1, 1], [0, 0, 1, 2]) = 0.5714285714285715
        assert!((adjusted_rand_index(&[0, 0, 1, 1], &[0, 0, 1, 2]) - 0.571_428_571_428_571_5).abs() < 1e-12);
        // ... ([0, 0, 1, 2], [0, 0, 1, 1]) is symmetric; ([0, 0, 1, 1], [0, 1, 0, 1]) = -0.5
        assert!((adjusted_rand_index(&[0, 0, 1, 1], &[0, 1, 0, 1]) + 0.5).abs() < 1e-12);
        assert_eq!(adjusted_rand_index(&[0, 0, 0], &[0, 0, 0]), 1.0);
        assert_eq!(adjusted_rand_index(&[0, 1, 2], &[0, 1, 2]), 1.0);
    }

    #[test]
    fn overlapping_groups_become_membership_classes() {
        // The thesis's mono sampling groups: {A5 A4 A3} {A4 A3 A2} {A1}.
        let l = labels(&["A1", "A2", "A3", "A4", "A5"]);
        let g = vec![labels(&["A5", "A4", "A3"]), labels(&["A4", "A3", "A2"]), labels(&["A1"])];
        assert_eq!(membership_classes(&l, &g), [0, 1, 2, 2, 3]);
        let a = agreement(&l, &[8.0, 34.0, 48.0, 51.0, 59.0], &g, &[8.0, 34.0, 48.0, 51.0, 59.0], &g);
        assert_eq!((a.spearman, a.adjusted_rand, a.same_groups), (1.0, 1.0, true));
        assert!((a.kendall - 1.0).abs() < 1e-12);
        let one = vec![labels(&["A1", "A2", "A3", "A4", "A5"])];
        let b = agreement(&l, &[1.0, 2.0, 3.0, 4.0, 5.0], &one, &[8.0, 34.0, 48.0, 51.0, 59.0], &g);
        assert!(b.adjusted_rand <= 0.0 && !b.same_groups, "{b:?}");
    }
}
