//! How well any forecast can agree with a table of vote totals: the ceiling that the table's
//! own sampling noise sets.
//!
//! A forecast is judged by the rank correlation of its expected votes with a table's totals.
//! Even a forecast that knew people's preferences exactly would not reach 1: the totals are
//! counts of `m` judgements per pair, and stimuli whose true totals differ by less than their
//! binomial noise come out in either order. This module estimates that ceiling by parametric
//! bootstrap:
//! 1. [`fit_qualities`]: Thurstone case V qualities in JOD (`P(i over j) = Phi(z75 (q_i -
//!    q_j))`, the forecasts' own choice model) whose expected votes equal the table's totals,
//!    the only statistics a published table gives. The expected votes `m sum_j P(i over j)`
//!    are, up to a constant vector, the gradient of a convex function of `q` (a sum over pairs
//!    of an antiderivative of `Phi`), strictly convex but along `q + c`, so the solution is
//!    unique up to that constant (fixed by `sum q = 0`); Newton's method finds it.
//! 2. Replicate tables drawn from those qualities: each pair's `m` judgements binomial, from a
//!    recorded seed.
//! 3. The perfect forecast, the fitted model's expected votes, ranks the stimuli exactly as
//!    the table does; its Spearman and Kendall correlations with each replicate are what a
//!    forecast that knows the truth would meet when the test is run.
//!
//! The fitted qualities carry the table's noise as well as its signal, so their spread is
//! larger than the truth's (as a measured range overstates a true one) and this ceiling is
//! optimistic. A second estimate shrinks them by the noise that the replicates' own fits
//! measure ([`TableCeiling`]); the truth's ceiling is expected between the two.
//!
//! Where the `k` best stimuli won every judgement against the rest (one that won every
//! judgement, or a stimulus that lost every one), the gap between the two groups is infinite.
//! The fit holds every quality within `±`[`QUALITY_CAP`] JOD, so the gap ends near the
//! bound, where judgements across it are all but certain (at 7 JOD, 1 in a million goes the
//! other way), and the split is reported ([`certain_splits`]).

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::votes::VoteTable;
use study::stats::{Z75, jod_preference, kendall_tau_b, spearman};

/// The most replicate tables per estimate: each is kept (for other forecasts against the same
/// replicates), so a million tables of nine stimuli take about 150 MB for the two estimates.
pub const MAX_REPLICATIONS: usize = 1_000_000;

/// The bound on a fitted quality's magnitude, in JOD, while the fit runs.
pub const QUALITY_CAP: f64 = 10.0;

/// Why a ceiling cannot be estimated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CeilingError {
    /// The table cannot be a complete paired-comparison test with these judges.
    #[error("{table}: {message}")]
    Table {
        /// The table (its file).
        table: String,
        /// What is wrong.
        message: String,
    },
    /// A setting out of range.
    #[error("{0}")]
    Setting(String),
}

/// Thurstone case V qualities (JOD, mean 0) whose expected votes, with `judges` judgements
/// of every pair, equal `votes` (where the table has [`certain_splits`], as nearly as
/// qualities within `±`[`QUALITY_CAP`] can). `Err` (a message) when the totals are not
/// those of a complete test: they must be whole, within `0..=judges (t - 1)` and sum to
/// `judges t (t - 1) / 2`.
pub fn fit_qualities(votes: &[f64], judges: u32) -> Result<Vec<f64>, String> {
    let t = votes.len();
    if t < 2 {
        return Err(format!("{t} stimuli: a paired-comparison test needs at least 2"));
    }
    if judges == 0 {
        return Err("0 judges: every pair must be judged at least once".into());
    }
    let m = f64::from(judges);
    let most = m * (t - 1) as f64;
    for (i, &v) in votes.iter().enumerate() {
        if !(v.is_finite() && v.fract() == 0.0 && (0.0..=most).contains(&v)) {
            return Err(format!("stimulus {}: {v} votes, expected a whole number in 0..={most}", i + 1));
        }
    }
    let total: f64 = votes.iter().sum();
    let judgements = m * (t * (t - 1) / 2) as f64;
    if total != judgements {
        return Err(format!(
            "the votes total {total}, but {judges} judgements of each of the {} pairs of {t} stimuli total {judgements}",
            t * (t - 1) / 2
        ));
    }
    let expected = |q: &[f64]| -> Vec<f64> {
        (0..t).map(|i| m * (0..t).filter(|&j| j != i).map(|j| jod_preference(q[i], q[j])).sum::<f64>()).collect()
    };
    let residual =
        |q: &[f64]| -> f64 { expected(q).iter().zip(votes).map(|(e, v)| (v - e).powi(2)).sum::<f64>().sqrt() };
    let clamp = |q: &mut [f64]| q.iter_mut().for_each(|x| *x = x.clamp(-QUALITY_CAP, QUALITY_CAP));
    let mut q = vec![0.0; t];
    let mut r = residual(&q);
    for _ in 0..200 {
        if r < 1e-10 * m {
            break;
        }
        // Newton on the subspace sum q = 0: the Jacobian is a weighted graph Laplacian, made
        // invertible by adding the all-ones matrix (the step then sums to 0, as the
        // residual does). Levenberg damping and backtracking keep it safe near the cap.
        let e = expected(&q);
        let rhs: Vec<f64> = votes.iter().zip(&e).map(|(v, e)| v - e).collect();
        let mut jacobian = vec![vec![1.0; t]; t];
        for i in 0..t {
            for j in 0..t {
                if i != j {
                    let d = Z75 * (q[i] - q[j]);
                    let w = m * Z75 * (-0.5 * d * d).exp() / (2.0 * std::f64::consts::PI).sqrt();
                    jacobian[i][j] -= w;
                    jacobian[i][i] += w;
                }
            }
        }
        let mut improved = false;
        let mut damping = 0.0;
        for _ in 0..60 {
            let mut a = jacobian.clone();
            for (i, row) in a.iter_mut().enumerate() {
                row[i] += damping;
            }
            let Some(step) = solve(a, rhs.clone()) else {
                damping = if damping == 0.0 { 1e-6 * m } else { damping * 10.0 };
                continue;
            };
            let mut next: Vec<f64> = q.iter().zip(&step).map(|(a, b)| a + b).collect();
            clamp(&mut next);
            let rn = residual(&next);
            if rn < r {
                (q, r, improved) = (next, rn, true);
                break;
            }
            damping = if damping == 0.0 { 1e-6 * m } else { damping * 10.0 };
        }
        if !improved {
            break;
        }
    }
    // Without a certain split the fit must reproduce the totals; with one, only as far as
    // finite qualities can.
    if r > 1e-6 * m && certain_splits(votes, judges).is_empty() {
        return Err(format!("the Thurstone fit did not converge (residual {r:.3e} votes)"));
    }
    let mean = q.iter().sum::<f64>() / t as f64;
    Ok(q.iter().map(|x| x - mean).collect())
}

/// Each `k` (`1..t`) for which the `k` stimuli with the most votes won every judgement
/// against the other `t - k`: no finite qualities explain such a table, as the gap between
/// the two groups is infinite. A group that won every judgement against the rest holds the
/// `k` highest totals (each member has at least `m (t - k)`, each other stimulus at most
/// `m (t - k - 1)`), and they sum to the most `k` stimuli can win, `m (k (k - 1) / 2 + k (t -
/// k))`; that sum is reached by no other `k` stimuli.
pub fn certain_splits(votes: &[f64], judges: u32) -> Vec<usize> {
    let t = votes.len();
    let m = f64::from(judges);
    let mut sorted = votes.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    (1..t).filter(|&k| sorted[..k].iter().sum::<f64>() == m * (k * (k - 1) / 2 + k * (t - k)) as f64).collect()
}

/// Solves `a x = b` by Gaussian elimination with partial pivoting; `None` when `a` is
/// singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-300 || !a[p][c].is_finite() {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        let (above, below) = a.split_at_mut(c + 1);
        let pivot = &above[c];
        for (offset, row) in below.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            row[c..].iter_mut().zip(&pivot[c..]).for_each(|(x, p)| *x -= f * p);
            b[c + 1 + offset] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// A distribution's summary: mean and the 5 %, 50 % and 95 % quantiles (nearest rank).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    /// Mean.
    pub mean: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// Median.
    pub median: f64,
    /// 95 % quantile.
    pub q95: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Spread {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let at = |p: f64| sorted[((sorted.len() - 1) as f64 * p).round() as usize];
        Spread { mean: values.iter().sum::<f64>() / values.len() as f64, q05: at(0.05), median: at(0.5), q95: at(0.95) }
    }
}

/// A perfect forecast against replicate tables drawn from one set of true qualities.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The qualities taken as true (JOD, mean 0), in the table's order.
    pub truth: Vec<f64>,
    /// Spearman's correlation of the perfect forecast with the replicates.
    pub spearman: Spread,
    /// Kendall's tau-b of the perfect forecast with the replicates.
    pub kendall: Spread,
    /// The share of replicates on which the perfect forecast's Spearman reaches the floor.
    pub reaches_floor: f64,
    /// Replicates whose totals all tie (no order: counted as Spearman 0).
    pub constant_replicates: usize,
    /// Spearman per replicate (for the joint goal over several tables).
    #[serde(skip)]
    pub spearman_samples: Vec<f64>,
    /// The replicate tables' totals (for other forecasts against the same replicates).
    #[serde(skip)]
    pub replicates: Vec<Vec<f64>>,
}

/// The ceiling of one table, estimated twice: from the fitted qualities (optimistic: their
/// spread includes the table's noise) and from the same qualities shrunk towards their mean
/// until their spread is the fitted one less that noise (method of moments: the replicate
/// tables' own fits show how far noise alone moves a fit, `N = E sum (q*_i - q_i)^2`, and the
/// truth's spread is estimated as the fit's `V = sum q_i^2` less `N`: a factor
/// `sqrt(max(0, 1 - N / V))`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TableCeiling {
    /// The table's file, as given.
    pub table: String,
    /// Stimulus labels, in the table's order.
    pub labels: Vec<String>,
    /// The table's totals.
    pub votes: Vec<f64>,
    /// Judgements of each pair in the table.
    pub judges: u32,
    /// Judgements of each pair in the replicate tables: the table's own, or those of a test
    /// being planned.
    pub replicate_judges: u32,
    /// Each `k` for which the `k` best stimuli won every judgement against the rest
    /// ([`certain_splits`]).
    pub certain_splits: Vec<usize>,
    /// Replicate tables drawn for each estimate.
    pub replications: usize,
    /// The seed of the replicates' generator (derived from the run's seed and the table's
    /// totals).
    pub seed: u64,
    /// From the fitted qualities.
    pub fitted: Estimate,
    /// The factor the shrunk estimate scales the fitted qualities by.
    pub shrink: f64,
    /// Replicates left out of the noise measure `N` because their fit has a certain split
    /// (no finite qualities).
    pub unfittable_replicates: usize,
    /// From the shrunk qualities.
    pub shrunk: Estimate,
}

/// Draws a replicate table: each pair's `judges` judgements, won by `i` over `j` with
/// `p[i][j]`.
fn replicate(p: &[Vec<f64>], judges: u32, rng: &mut Pcg64) -> Vec<f64> {
    let t = p.len();
    let mut out = vec![0.0; t];
    for i in 0..t {
        for j in i + 1..t {
            let wins = (0..judges).filter(|_| rng.random::<f64>() < p[i][j]).count() as f64;
            out[i] += wins;
            out[j] += f64::from(judges) - wins;
        }
    }
    out
}

fn preferences(q: &[f64]) -> Vec<Vec<f64>> {
    q.iter().map(|&a| q.iter().map(|&b| jod_preference(a, b)).collect()).collect()
}

/// `replications` replicate tables drawn from `truth` with `judges` judgements per pair.
fn replicates(truth: &[f64], judges: u32, replications: usize, rng: &mut Pcg64) -> Vec<Vec<f64>> {
    let p = preferences(truth);
    (0..replications).map(|_| replicate(&p, judges, rng)).collect()
}

/// Whether every stimulus has the same total (no order to correlate).
fn all_tied(v: &[f64]) -> bool {
    v.iter().all(|&x| x == v[0])
}

/// Spearman's correlation of `forecast` with each replicate, a replicate that ties every
/// stimulus counted as 0.
fn spearman_with(forecast: &[f64], replicates: &[Vec<f64>]) -> Vec<f64> {
    replicates.iter().map(|r| if all_tied(r) { 0.0 } else { spearman(forecast, r) }).collect()
}

/// The share of `rho` at or above `floor`.
fn share_reaching(rho: &[f64], floor: f64) -> f64 {
    rho.iter().filter(|&&r| r >= floor).count() as f64 / rho.len() as f64
}

/// The perfect forecast (the table's own order, `votes`) against `replications` tables drawn
/// from `truth`.
fn estimate(votes: &[f64], truth: Vec<f64>, judges: u32, replications: usize, floor: f64, rng: &mut Pcg64) -> Estimate {
    let replicates = replicates(&truth, judges, replications, rng);
    let rho = spearman_with(votes, &replicates);
    let tau: Vec<f64> = replicates.iter().map(|r| if all_tied(r) { 0.0 } else { kendall_tau_b(votes, r) }).collect();
    Estimate {
        truth,
        spearman: Spread::of(&rho),
        kendall: Spread::of(&tau),
        reaches_floor: share_reaching(&rho, floor),
        constant_replicates: replicates.iter().filter(|r| all_tied(r)).count(),
        spearman_samples: rho,
        replicates,
    }
}

/// A forecast's agreement with the replicate tables of an estimate: the distribution of its
/// Spearman correlation (a replicate that ties every stimulus counts as 0) and the share
/// reaching `floor`; what the forecast would meet if the test were run again. `None` for a
/// forecast that ties every stimulus (no order to correlate).
pub fn forecast_again(estimate: &Estimate, forecast: &[f64], floor: f64) -> Option<(Spread, f64)> {
    if all_tied(forecast) {
        return None;
    }
    let rho = spearman_with(forecast, &estimate.replicates);
    Some((Spread::of(&rho), share_reaching(&rho, floor)))
}

/// The perfect forecast of `table` (with `judges` judgements per pair) against
/// `replications` replicate tables for each estimate, with generator seed `mix(seed,
/// totals)`; `floor` is the Spearman a forecast must reach on the table. The replicates have
/// `replicate_judges` judgements per pair: `judges` to run the test again as it was, another
/// number for a test being planned (the truth is still fitted with `judges`, and the fit
/// noise measured at `judges`).
pub fn table_ceiling(
    table: &VoteTable,
    judges: u32,
    replicate_judges: u32,
    replications: usize,
    seed: u64,
    floor: f64,
) -> Result<TableCeiling, CeilingError> {
    let name = table.path.display().to_string();
    let bad = |message: String| CeilingError::Table { table: name.clone(), message };
    if !(2..=MAX_REPLICATIONS).contains(&replications) {
        return Err(CeilingError::Setting(format!(
            "{replications} replications: expected 2 to {MAX_REPLICATIONS} (each estimate keeps its replicate tables)"
        )));
    }
    let votes: Vec<f64> = table.votes.iter().map(|&v| f64::from(v)).collect();
    if votes.iter().all(|&v| v == votes[0]) {
        return Err(bad("every stimulus has the same votes: there is no order to forecast".into()));
    }
    let quality = fit_qualities(&votes, judges).map_err(bad)?;
    let seed = study::seed::mix(seed, &table.votes.iter().map(|&v| u64::from(v)).collect::<Vec<_>>());
    let mut rng = Pcg64::seed_from_u64(seed);
    if replicate_judges == 0 {
        return Err(CeilingError::Setting("0 judges in the replicate tables: at least 1 is needed".into()));
    }
    // The fit noise is the table's (its judges): the test run again as it was measures it on
    // its own replicates, a planned one on replicates drawn at the table's judges first.
    let (fitted, own_noise_tables) = if replicate_judges == judges {
        (estimate(&votes, quality.clone(), judges, replications, floor, &mut rng), None)
    } else {
        let tables = replicates(&quality, judges, replications, &mut rng);
        (estimate(&votes, quality.clone(), replicate_judges, replications, floor, &mut rng), Some(tables))
    };
    let (mut noise, mut fitted_replicates, mut unfittable) = (0.0, 0usize, 0usize);
    for r in own_noise_tables.as_ref().unwrap_or(&fitted.replicates) {
        match fit_qualities(r, judges) {
            Ok(q) if certain_splits(r, judges).is_empty() => {
                noise += q.iter().zip(&quality).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
                fitted_replicates += 1;
            }
            _ => unfittable += 1,
        }
    }
    let spread: f64 = quality.iter().map(|q| q * q).sum();
    let shrink = if fitted_replicates == 0 || spread == 0.0 {
        0.0
    } else {
        (1.0 - noise / fitted_replicates as f64 / spread).max(0.0).sqrt()
    };
    let shrunk_truth = quality.iter().map(|q| q * shrink).collect();
    let shrunk = estimate(&votes, shrunk_truth, replicate_judges, replications, floor, &mut rng);
    Ok(TableCeiling {
        table: name,
        labels: table.labels.clone(),
        certain_splits: certain_splits(&votes, judges),
        votes,
        judges,
        replicate_judges,
        replications,
        seed,
        fitted,
        shrink,
        unfittable_replicates: unfittable,
        shrunk,
    })
}

/// The chance that a perfect forecast meets a goal over several tables at once: a mean
/// Spearman of at least `mean_goal` and none below `floor`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GoalChance {
    /// The goal's mean.
    pub mean_goal: f64,
    /// The goal's floor.
    pub floor: f64,
    /// The perfect forecast's mean Spearman over the tables (its distribution).
    pub mean_spearman: Spread,
    /// The share of replicate studies whose mean reaches `mean_goal`.
    pub reaches_mean: f64,
    /// The share whose every table reaches `floor`.
    pub reaches_floor_everywhere: f64,
    /// The share meeting both.
    pub meets_goal: f64,
}

/// [`GoalChance`] over the estimates of several tables (their replicates are independent,
/// so replicate `k` of each makes up replicate study `k`). `None` without estimates.
pub fn goal_chance(estimates: &[&Estimate], mean_goal: f64, floor: f64) -> Option<GoalChance> {
    let n = estimates.iter().map(|e| e.spearman_samples.len()).min()?;
    let (mut means, mut mean_ok, mut floor_ok, mut both) = (Vec::with_capacity(n), 0usize, 0usize, 0usize);
    for k in 0..n {
        let mean = estimates.iter().map(|e| e.spearman_samples[k]).sum::<f64>() / estimates.len() as f64;
        let (a, b) = (mean >= mean_goal, estimates.iter().all(|e| e.spearman_samples[k] >= floor));
        means.push(mean);
        mean_ok += usize::from(a);
        floor_ok += usize::from(b);
        both += usize::from(a && b);
    }
    let share = |c: usize| c as f64 / n as f64;
    (n > 0).then(|| GoalChance {
        mean_goal,
        floor,
        mean_spearman: Spread::of(&means),
        reaches_mean: share(mean_ok),
        reaches_floor_everywhere: share(floor_ok),
        meets_goal: share(both),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(votes: &[u32]) -> VoteTable {
        VoteTable {
            path: "t.csv".into(),
            header: Vec::new(),
            labels: (0..votes.len()).map(|i| format!("S{i}")).collect(),
            votes: votes.to_vec(),
        }
    }

    #[test]
    fn the_fit_reproduces_the_totals_and_recovers_the_qualities_that_made_them() {
        // Expected votes of known qualities, fitted back: the same qualities.
        let truth = [1.2, 0.4, -0.1, -1.5];
        let m = 1000;
        let expected: Vec<f64> = (0..4)
            .map(|i| f64::from(m) * (0..4).filter(|&j| j != i).map(|j| jod_preference(truth[i], truth[j])).sum::<f64>())
            .collect();
        // The fit needs whole totals; 1000 judges make the rounding small.
        let mut rounded: Vec<f64> = expected.iter().map(|v| v.round()).collect();
        rounded[0] += expected.iter().sum::<f64>().round() - rounded.iter().sum::<f64>();
        let q = fit_qualities(&rounded, m).unwrap();
        let mean = truth.iter().sum::<f64>() / 4.0;
        for (a, b) in q.iter().zip(&truth) {
            assert!((a - (b - mean)).abs() < 0.01, "{q:?} against {truth:?}");
        }
        // Two stimuli, 20 judges, 15 to 5: three in four prefer the first, which is 1 JOD.
        let q = fit_qualities(&[15.0, 5.0], 20).unwrap();
        assert!((q[0] - q[1] - 1.0).abs() < 1e-9, "{q:?}");
        // A tie: equal qualities.
        let q = fit_qualities(&[10.0, 10.0, 10.0], 10).unwrap();
        assert!(q.iter().all(|x| x.abs() < 1e-12), "{q:?}");
    }

    #[test]
    fn a_group_that_won_every_judgement_against_the_rest_is_a_certain_split() {
        let q = fit_qualities(&[20.0, 7.0, 3.0], 10).unwrap();
        assert_eq!(certain_splits(&[20.0, 7.0, 3.0], 10), [1]);
        assert!(q[0] > q[1] + 7.0 && q[1] > q[2], "{q:?}");
        // The other two still split their own pair 7 to 3 (each also lost 10 to the first).
        assert!((jod_preference(q[1], q[2]) - 0.7).abs() < 1e-5, "{q:?}");
        // One that lost every judgement, and a pair that won every judgement against the rest.
        let q = fit_qualities(&[16.0, 14.0, 0.0], 10).unwrap();
        assert_eq!(certain_splits(&[16.0, 14.0, 0.0], 10), [2]);
        assert!(q[2] < q[1] - 7.0 && (jod_preference(q[0], q[1]) - 0.6).abs() < 1e-5, "{q:?}");
        let votes = [25.0, 25.0, 7.0, 3.0];
        let q = fit_qualities(&votes, 10).unwrap();
        assert_eq!(certain_splits(&votes, 10), [2]);
        assert!((q[0] - q[1]).abs() < 1e-9 && (jod_preference(q[2], q[3]) - 0.7).abs() < 1e-5, "{q:?}");
        // A table without one, and a complete order: every split certain.
        assert!(certain_splits(&[15.0, 10.0, 5.0], 10).is_empty());
        assert_eq!(certain_splits(&[20.0, 10.0, 0.0], 10), [1, 2]);
    }

    #[test]
    fn totals_that_no_complete_test_can_give_are_refused() {
        assert!(fit_qualities(&[10.0, 9.0], 20).unwrap_err().contains("total 19"));
        assert!(fit_qualities(&[25.0, -5.0], 20).unwrap_err().contains("stimulus 1: 25 votes"));
        assert!(fit_qualities(&[10.5, 9.5], 20).unwrap_err().contains("whole number"));
        assert!(fit_qualities(&[10.0], 20).unwrap_err().contains("at least 2"));
        assert!(fit_qualities(&[0.0, 0.0], 0).unwrap_err().contains("0 judges"));
        let e = table_ceiling(&table(&[10, 10]), 10, 10, 100, 1, 0.5).unwrap_err();
        assert!(e.to_string().contains("t.csv: every stimulus has the same votes"), "{e}");
        let e = table_ceiling(&table(&[15, 5]), 20, 20, 1, 1, 0.5).unwrap_err();
        assert!(e.to_string().starts_with("1 replications: expected 2 to 1000000"), "{e}");
        let e = table_ceiling(&table(&[15, 5]), 20, 20, MAX_REPLICATIONS + 1, 1, 0.5).unwrap_err();
        assert!(e.to_string().contains("1000001 replications"), "{e}");
    }

    #[test]
    fn the_ceiling_falls_with_noise_and_is_reproducible() {
        // Well separated totals with many judges: a perfect forecast nearly always ranks the
        // replicate as the table; close totals with few judges: far from it.
        let clear = table_ceiling(&table(&[280, 190, 100, 30]), 100, 100, 2000, 7, 0.5).unwrap();
        assert!(clear.fitted.spearman.mean > 0.99 && clear.fitted.reaches_floor == 1.0, "{:?}", clear.fitted);
        assert!(clear.shrink > 0.98 && clear.shrunk.spearman.mean > 0.99, "{}", clear.shrink);
        let close = table_ceiling(&table(&[8, 8, 7, 7]), 5, 5, 2000, 7, 0.5).unwrap();
        assert!(close.fitted.spearman.mean < 0.6 && close.fitted.reaches_floor < 0.7, "{:?}", close.fitted);
        assert!(close.fitted.spearman.q05 < 0.0 && close.fitted.spearman.q95 <= 1.0);
        // Its spread is mostly noise: the shrunk estimate is lower still.
        assert!(close.shrink < 0.5 && close.shrunk.spearman.mean < close.fitted.spearman.mean, "{}", close.shrink);
        // Two stimuli 1 JOD apart, 20 judges: the order flips when the better one wins at
        // most 10 of 20 at p = 0.75 (binomial: 0.01386), tying at 10 (0.00992, Spearman 0).
        let two = table_ceiling(&table(&[15, 5]), 20, 20, 100_000, 3, 0.5).unwrap();
        // (Tolerances: 6 and 5 binomial standard errors.)
        let flipped = two.fitted.spearman_samples.iter().filter(|&&r| r < 0.0).count() as f64 / 100_000.0;
        assert!((flipped - (0.013_864 - 0.009_922)).abs() < 0.0012, "{flipped}");
        assert!((two.fitted.constant_replicates as f64 / 100_000.0 - 0.009_922).abs() < 0.0016);
        // The same seed, the same replicates; another seed, others.
        let again = table_ceiling(&table(&[8, 8, 7, 7]), 5, 5, 2000, 7, 0.5).unwrap();
        assert_eq!(again, close);
        let other = table_ceiling(&table(&[8, 8, 7, 7]), 5, 5, 2000, 8, 0.5).unwrap();
        assert_ne!(other.fitted.spearman_samples, close.fitted.spearman_samples);
    }

    #[test]
    fn the_shrunk_spread_is_nearer_the_truth_than_the_fitted_one() {
        // Tables drawn from known qualities with few judges: on average the fit overstates
        // the qualities' spread, and shrinking by the replicates' measured noise corrects it.
        let truth = [0.4, 0.1, 0.0, -0.5];
        let spread = |q: &[f64]| {
            let mean = q.iter().sum::<f64>() / q.len() as f64;
            q.iter().map(|x| (x - mean).powi(2)).sum::<f64>()
        };
        let p = preferences(&truth);
        let mut rng = Pcg64::seed_from_u64(11);
        let (mut fitted, mut shrunk, mut n) = (0.0, 0.0, 0.0);
        for _ in 0..300 {
            let votes = replicate(&p, 10, &mut rng);
            if !certain_splits(&votes, 10).is_empty() {
                continue;
            }
            let c = table_ceiling(&table(&votes.iter().map(|&v| v as u32).collect::<Vec<_>>()), 10, 10, 300, 5, 0.5);
            let Ok(c) = c else { continue };
            fitted += spread(&c.fitted.truth);
            shrunk += spread(&c.shrunk.truth);
            n += 1.0;
        }
        let (fitted, shrunk, true_spread) = (fitted / n, shrunk / n, spread(&truth));
        assert!(n > 250.0, "{n}");
        assert!(fitted > 1.3 * true_spread, "fitted {fitted} true {true_spread}");
        assert!(
            (shrunk - true_spread).abs() < 0.5 * (fitted - true_spread),
            "shrunk {shrunk} fitted {fitted} true {true_spread}"
        );
    }

    #[test]
    fn a_forecast_run_again_and_a_planned_test_with_more_judges() {
        let votes = [10, 8, 7, 5];
        let c = table_ceiling(&table(&votes), 5, 5, 3000, 7, 0.5).unwrap();
        // The perfect forecast against the same replicates is the ceiling itself; the reverse
        // order its mirror image; a forecast that ties everything has no order.
        let perfect: Vec<f64> = votes.iter().map(|&v| f64::from(v)).collect();
        let (again, reaches) = forecast_again(&c.fitted, &perfect, 0.5).unwrap();
        assert_eq!((again, reaches), (c.fitted.spearman, c.fitted.reaches_floor));
        let reversed: Vec<f64> = perfect.iter().map(|v| -v).collect();
        let (mirror, _) = forecast_again(&c.fitted, &reversed, 0.5).unwrap();
        assert!((mirror.mean + again.mean).abs() < 1e-12, "{mirror:?} {again:?}");
        assert!(forecast_again(&c.fitted, &[1.0; 4], 0.5).is_none());
        // Twenty times the judges: the same truth, far less noise, so a higher ceiling; the
        // fit noise (the shrink) is still the table's.
        let planned = table_ceiling(&table(&votes), 5, 100, 3000, 7, 0.5).unwrap();
        assert_eq!((planned.replicate_judges, planned.fitted.truth.clone()), (100, c.fitted.truth.clone()));
        assert_eq!(planned.shrink, c.shrink);
        assert!(planned.fitted.spearman.mean > c.fitted.spearman.mean + 0.2, "{:?}", planned.fitted.spearman);
        assert_eq!(planned.fitted.replicates[0].iter().sum::<f64>(), 100.0 * 6.0);
        let e = table_ceiling(&table(&votes), 5, 0, 10, 7, 0.5).unwrap_err();
        assert!(e.to_string().contains("0 judges in the replicate tables"), "{e}");
    }

    #[test]
    fn the_goal_over_several_tables_counts_whole_replicate_studies() {
        let mut a = table_ceiling(&table(&[15, 5]), 20, 20, 4, 1, 0.5).unwrap().fitted;
        let mut b = a.clone();
        a.spearman_samples = vec![1.0, 1.0, 0.4, 0.9];
        b.spearman_samples = vec![0.7, 0.5, 1.0, 0.2];
        let g = goal_chance(&[&a, &b], 0.8, 0.5).unwrap();
        // Means 0.85, 0.75, 0.70, 0.55; floors met in studies 1, 2.
        assert_eq!((g.reaches_mean, g.reaches_floor_everywhere, g.meets_goal), (0.25, 0.5, 0.25));
        assert!(goal_chance(&[], 0.8, 0.5).is_none());
    }
}
