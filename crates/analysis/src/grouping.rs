//! Significance grouping by David's method of paired comparisons (David 1988; thesis 5.6.3).
//!
//! With `m` judges each judging all pairs of `t` stimuli once, two stimuli whose scores
//! differ by at least `ceil(R_c)` differ significantly at level `alpha`, where
//! `R_c = (W_{t,alpha} sqrt(m t) + 1/2) / 2` and `W_{t,alpha}` is the upper `alpha` quantile
//! of the range of `t` independent standard normals ([`crate::srange`]).
//!
//! Groups are the maximal sets of stimuli whose scores lie within a window narrower than
//! `ceil(R_c)`: for every stimulus `i`, the set `{j : s_i - ceil(R_c) < s_j <= s_i}`; sets
//! contained in another are dropped. Stimuli with tied scores are always in the same groups
//! (a tie never splits at a boundary), and groups may overlap.

use serde::Serialize;

use crate::srange::{SrangeError, srange_quantile};

/// The critical range of David's test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CriticalRange {
    /// Number of stimuli.
    pub t: usize,
    /// Number of judges (judgments per pair).
    pub judges: u32,
    /// Significance level.
    pub alpha: f64,
    /// `W_{t,alpha}`.
    pub w: f64,
    /// `R_c = (W sqrt(m t) + 1/2) / 2`.
    pub rc: f64,
    /// `ceil(R_c)`: scores differing by this much or more differ significantly.
    pub ceil_rc: u64,
}

/// Computes `W_{t,alpha}`, `R_c` and `ceil(R_c)` for `t` stimuli and `m` judges.
pub fn critical_range(t: usize, judges: u32, alpha: f64) -> Result<CriticalRange, SrangeError> {
    if judges == 0 {
        return Err(SrangeError::NoJudges);
    }
    let w = srange_quantile(t, alpha)?;
    let rc = (w * (f64::from(judges) * t as f64).sqrt() + 0.5) / 2.0;
    // Guard against a value a hair above an integer from rounding: R_c is irrational in general.
    let ceil_rc = (rc - 1e-9).ceil().max(0.0) as u64;
    Ok(CriticalRange { t, judges, alpha, w, rc, ceil_rc })
}

/// The maximal overlapping groups of stimuli whose scores differ by less than `threshold`.
/// Each group lists stimulus indices by decreasing score (ties by index); groups are ordered
/// by their top score, highest first.
pub fn significance_groups(scores: &[f64], threshold: f64) -> Vec<Vec<usize>> {
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| scores[b].total_cmp(&scores[a]).then(a.cmp(&b)));
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for &top in &order {
        let high = scores[top];
        let group: Vec<usize> =
            order.iter().copied().filter(|&j| scores[j] <= high && high - scores[j] < threshold).collect();
        let contained = groups.iter().any(|g| group.iter().all(|x| g.contains(x)));
        if !contained {
            groups.retain(|g| !g.iter().all(|x| group.contains(x)));
            groups.push(group);
        }
    }
    groups
}

/// The groups (by index into `groups`) that contain each stimulus.
pub fn memberships(t: usize, groups: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); t];
    for (g, members) in groups.iter().enumerate() {
        for &i in members {
            out[i].push(g);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_example_of_the_thesis() {
        let c = critical_range(5, 20, 0.01).unwrap();
        assert!((c.w - 4.6028).abs() < 1e-3, "{c:?}");
        assert_eq!(c.ceil_rc, 24);
        // A1 8, A2 34, A3 48, A4 51, A5 59
        let groups = significance_groups(&[8.0, 34.0, 48.0, 51.0, 59.0], c.ceil_rc as f64);
        assert_eq!(groups, vec![vec![4, 3, 2], vec![3, 2, 1], vec![0]]);
    }

    #[test]
    fn ties_at_a_group_boundary_stay_together_and_the_boundary_is_exclusive() {
        // 10 - 6 = 4 is not below 4, so 6 and its tie partner leave the first group together.
        let groups = significance_groups(&[10.0, 6.0, 6.0, 7.0], 4.0);
        assert_eq!(groups, vec![vec![0, 3], vec![3, 1, 2]]);
        // All tied: one group.
        assert_eq!(significance_groups(&[3.0; 4], 1.0), vec![vec![0, 1, 2, 3]]);
        // Threshold 0 makes every stimulus its own group (ties still together).
        assert_eq!(significance_groups(&[1.0, 2.0, 2.0], 0.5), vec![vec![1, 2], vec![0]]);
    }

    #[test]
    fn a_never_chosen_stimulus_is_grouped_normally() {
        let c = critical_range(3, 10, 0.05).unwrap();
        let groups = significance_groups(&[20.0, 10.0, 0.0], c.ceil_rc as f64);
        assert_eq!(groups.last().unwrap().last(), Some(&2));
        assert_eq!(memberships(3, &groups).iter().filter(|m| m.is_empty()).count(), 0);
    }

    #[test]
    fn alpha_near_zero_and_one() {
        let tiny = critical_range(5, 20, 1e-9).unwrap();
        let large = critical_range(5, 20, 0.999).unwrap();
        assert!(tiny.ceil_rc > 40 && large.ceil_rc < 10, "{tiny:?} {large:?}");
        let scores = [8.0, 34.0, 48.0, 51.0, 59.0];
        assert!(significance_groups(&scores, tiny.ceil_rc as f64).len() <= 2);
        assert!(significance_groups(&scores, large.ceil_rc as f64).len() >= 4);
    }
}
