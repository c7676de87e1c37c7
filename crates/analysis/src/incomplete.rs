//! Incomplete designs: experiments in which participants judge only some pairs (active
//! sampling such as ASAP, or random pairs with a trial budget per participant).
//!
//! **The rule.** Kendall's coefficients (circular triads, zeta, agreement `u` and their
//! chi-square tests) and David's vote-count grouping assume every judge judged every pair
//! once. A *complete judge* is a pass over the pairs (a replicate, see [`crate::experiment`])
//! that judged every pair exactly once. The design is **incomplete** when fewer than 2
//! passes are complete, or when the complete passes hold fewer than half of the counted
//! trials (most of the data would be left out of those statistics). Otherwise it is
//! complete and analysed as before, incomplete passes left out of Kendall's statistics.
//!
//! **What replaces them.** The Thurstone Case V scale ([`crate::scaling`]) over every trial,
//! with bootstrap intervals over *participants* (each resample draws participants with
//! replacement and pools all their trials, since a participant's trials are not
//! independent), and significance groups from the scale:
//!
//! - For every pair, `d_ij = s_i - s_j` and its bootstrap standard deviation `SD(d_ij)`
//!   over the same participant resamples (from the resamples' covariance, so the
//!   correlation of the two scores is kept).
//! - `i` and `j` differ significantly when `|d_ij| / SD(d_ij) >= W_{t,alpha} / sqrt(2)`,
//!   where `W_{t,alpha}` is the upper `alpha` quantile of the range of `t` standard normals
//!   ([`crate::srange`]). This is Tukey's honestly-significant-difference form of the range
//!   test behind David's method, so the family-wise level over all pairs is `alpha` as in the
//!   complete design. A z-test on the bootstrap SD was chosen over a percentile test of the
//!   resampled differences because the SD is stable with a few hundred resamples, while a
//!   percentile test at `alpha = 0.01` (and far smaller after the family-wise correction)
//!   would need tens of thousands of resamples to resolve its tails.
//! - Groups are the maximal runs of the stimuli in scale order (highest first) within which
//!   no pair differs significantly, as [`crate::grouping::significance_groups`] builds
//!   homogeneous subsets from sorted scores; runs contained in another are dropped, so groups
//!   may overlap.

use serde::Serialize;

use crate::paired::PreferenceMatrix;
use crate::scaling::{Scale, ScaleOptions, scale_with_bootstrap_fits};
use crate::srange::srange_quantile;

/// Whether Kendall's statistics and David's grouping apply.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Design {
    /// Enough complete passes: the thesis's statistics are reported.
    Complete,
    /// Too few complete passes: the scale and its groups are reported instead.
    Incomplete {
        /// Why, in words (for the report).
        reason: String,
    },
}

impl Design {
    /// Whether the design is incomplete.
    pub fn is_incomplete(&self) -> bool {
        matches!(self, Design::Incomplete { .. })
    }
}

/// Applies the rule of the module docs: `complete` passes of `passes` judged every pair
/// once, holding `complete_trials` of `all_trials` counted trials.
pub fn classify_design(complete: u32, passes: usize, complete_trials: u64, all_trials: u64) -> Design {
    if complete < 2 {
        Design::Incomplete {
            reason: format!(
                "{complete} of {passes} passes over the pairs judged every pair; Kendall's coefficients and David's grouping need at least 2 complete judges"
            ),
        }
    } else if 2 * complete_trials < all_trials {
        Design::Incomplete {
            reason: format!(
                "the {complete} complete passes (of {passes}) hold {complete_trials} of {all_trials} trials, fewer than half; Kendall's coefficients and David's grouping would leave most of the data out"
            ),
        }
    } else {
        Design::Complete
    }
}

/// The significance groups of an incomplete design and how they were found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScaleGrouping {
    /// The test, in words (for the report).
    pub test: String,
    /// Family-wise significance level.
    pub alpha: f64,
    /// `W_{t,alpha}`.
    pub w: f64,
    /// The critical value of `|d_ij| / SD(d_ij)`: `W / sqrt(2)`.
    pub critical_z: f64,
    /// Bootstrap resamples over participants behind the SDs.
    pub resamples: usize,
    /// Participants resampled.
    pub participants: usize,
    /// Groups: stimulus indices by decreasing scale value, highest group first.
    pub groups: Vec<Vec<usize>>,
    /// Pairs that differ significantly (`i < j`).
    pub significant_pairs: usize,
}

/// Why the scale could not be grouped.
#[derive(Debug, thiserror::Error)]
pub enum GroupingError {
    /// Too few resamples or participants for a standard deviation.
    #[error("{0}")]
    TooFew(String),
    /// The quantile W could not be computed.
    #[error(transparent)]
    Srange(#[from] crate::srange::SrangeError),
}

/// Bootstrap standard deviations of `s_i - s_j` (row-major `t x t`, zero diagonal) from
/// resampled score vectors.
pub fn difference_sd(fits: &[Vec<f64>], t: usize) -> Vec<f64> {
    let n = fits.len();
    let mut sd = vec![0.0; t * t];
    if n < 2 {
        return sd;
    }
    let mean: Vec<f64> = (0..t).map(|i| fits.iter().map(|f| f[i]).sum::<f64>() / n as f64).collect();
    // Covariance of the scores; var(d_ij) = c_ii + c_jj - 2 c_ij.
    let mut cov = vec![0.0; t * t];
    let mut centred = vec![0.0; t];
    for f in fits {
        for i in 0..t {
            centred[i] = f[i] - mean[i];
        }
        for i in 0..t {
            let ci = centred[i];
            let row = &mut cov[i * t..(i + 1) * t];
            for (c, x) in row.iter_mut().zip(&centred).skip(i) {
                *c += ci * x;
            }
        }
    }
    let scale = 1.0 / (n - 1) as f64;
    for i in 0..t {
        for j in i + 1..t {
            let v = (cov[i * t + i] + cov[j * t + j] - 2.0 * cov[i * t + j]) * scale;
            let s = v.max(0.0).sqrt();
            sd[i * t + j] = s;
            sd[j * t + i] = s;
        }
    }
    sd
}

/// Whether `i` and `j` differ significantly: `|s_i - s_j| >= critical * SD(d_ij)`. A pair
/// whose difference has no spread differs when the scores differ.
fn differ(scores: &[f64], sd: &[f64], t: usize, critical: f64, i: usize, j: usize) -> bool {
    let d = (scores[i] - scores[j]).abs();
    let s = sd[i * t + j];
    if s > 0.0 { d / s >= critical } else { d > 0.0 }
}

/// The maximal runs of the stimuli sorted by `scores` (highest first, ties by index) within
/// which no pair differs significantly (`|d_ij| >= critical * SD(d_ij)`, `sd` row-major
/// `t x t`). Each group lists indices by decreasing score; groups are ordered by their top
/// score, highest first.
pub fn scale_groups(scores: &[f64], sd: &[f64], critical: f64) -> Vec<Vec<usize>> {
    let t = scores.len();
    let mut order: Vec<usize> = (0..t).collect();
    order.sort_by(|&a, &b| scores[b].total_cmp(&scores[a]).then(a.cmp(&b)));
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for start in 0..t {
        let mut end = start;
        'extend: while end + 1 < t {
            let next = order[end + 1];
            for &k in &order[start..=end] {
                if differ(scores, sd, t, critical, k, next) {
                    break 'extend;
                }
            }
            end += 1;
        }
        // A run that starts later and ends no later is contained in an earlier one.
        if runs.last().is_none_or(|&(_, e)| end > e) {
            runs.push((start, end));
        }
    }
    runs.into_iter().map(|(s, e)| order[s..=e].to_vec()).collect()
}

/// Scales every trial (`total`) with bootstrap intervals over `participants` (one matrix per
/// participant) and groups the scale as the module docs say.
pub fn scale_and_group(
    total: &PreferenceMatrix,
    participants: &[PreferenceMatrix],
    options: ScaleOptions,
    alpha: f64,
) -> (Scale, Result<ScaleGrouping, GroupingError>) {
    let (scale, fits) = scale_with_bootstrap_fits(total, participants, options);
    let t = total.t();
    let grouping = (|| {
        if participants.len() < 2 || fits.len() < 2 {
            return Err(GroupingError::TooFew(format!(
                "{} participants and {} bootstrap resamples; the grouping needs at least 2 of each",
                participants.len(),
                fits.len()
            )));
        }
        let w = srange_quantile(t, alpha)?;
        let critical_z = w / std::f64::consts::SQRT_2;
        let sd = difference_sd(&fits, t);
        let groups = scale_groups(&scale.scores, &sd, critical_z);
        let significant_pairs =
            (0..t).map(|i| (i + 1..t).filter(|&j| differ(&scale.scores, &sd, t, critical_z, i, j)).count()).sum();
        Ok(ScaleGrouping {
            test: format!(
                "two stimuli differ when |s_i - s_j| / SD(s_i - s_j) >= W_{{t,alpha}} / sqrt(2) = {critical_z:.3} (W = {w:.4}, t = {t}, alpha = {alpha}), SD over {} bootstrap resamples of the {} participants; groups are the maximal runs in scale order with no significant pair",
                fits.len(),
                participants.len()
            ),
            alpha,
            w,
            critical_z,
            resamples: fits.len(),
            participants: participants.len(),
            groups,
            significant_pairs,
        })
    })();
    (scale, grouping)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_needs_two_complete_passes_holding_half_the_trials() {
        assert!(classify_design(0, 20, 0, 6000).is_incomplete());
        assert!(classify_design(1, 3, 100, 120).is_incomplete());
        assert!(classify_design(2, 20, 200, 2000).is_incomplete());
        assert_eq!(classify_design(2, 3, 200, 300), Design::Complete);
        assert_eq!(classify_design(7, 7, 70, 70), Design::Complete);
    }

    #[test]
    fn runs_stop_at_the_first_significant_pair_and_contained_runs_are_dropped() {
        // Scores 3, 2, 1, 0 with SD 1 for every difference: critical 1.5 separates pairs
        // two or more apart.
        let scores = [0.0, 1.0, 2.0, 3.0];
        let mut sd = vec![1.0; 16];
        (0..4).for_each(|i| sd[i * 4 + i] = 0.0);
        assert_eq!(scale_groups(&scores, &sd, 1.5), vec![vec![3, 2], vec![2, 1], vec![1, 0]]);
        assert_eq!(scale_groups(&scores, &sd, 3.5), vec![vec![3, 2, 1, 0]]);
        assert_eq!(scale_groups(&scores, &sd, 0.5), vec![vec![3], vec![2], vec![1], vec![0]]);
        // A noisy pair (large SD) does not split; a precise one does.
        sd[3 * 4] = 10.0;
        sd[3] = 10.0;
        assert_eq!(scale_groups(&scores, &sd, 2.5), vec![vec![3, 2, 1, 0]]);
    }

    #[test]
    fn difference_sd_keeps_the_correlation_of_the_scores() {
        // Scores 0 and 1 move together: their difference has no spread; 2 moves alone.
        let fits: Vec<Vec<f64>> = (0..100).map(|k| vec![f64::from(k), f64::from(k), f64::from(k % 2)]).collect();
        let sd = difference_sd(&fits, 3);
        assert!(sd[1].abs() < 1e-12 && sd[3].abs() < 1e-12);
        assert!(sd[2] > 20.0 && (sd[2] - sd[6]).abs() < 1e-12);
    }
}
