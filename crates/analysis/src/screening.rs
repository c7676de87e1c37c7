//! Observer screening: how unlikely each participant's answers are under the scale fitted
//! without them, after pwcmp's outlier analysis (Perez-Ortiz and Mantiuk 2017, section 9;
//! `pw_outlier_analysis.m`).
//!
//! **Statistic.** For participant `p`, the Thurstone Case V scale `s^(-p)` is fitted (MAP,
//! [`crate::scaling::fit_case_v`]) to every trial of the *other* participants, and `p`'s own
//! answers are scored by their mean log-10 likelihood per trial,
//! `L_p = (1/n_p) sum_{trials} log10 Phi((s_winner - s_loser) / sigma)` with the JOD
//! `sigma = 1.4826`. pwcmp sums binomial log-likelihoods over pairs; the mean over trials is
//! used here because with active or random pair selection participants judge different
//! numbers of trials, and a sum would rank them by their budget. An honest observer's `L_p`
//! is near the model's expected value; an observer answering at random scores at most
//! `log10 0.5 = -0.301` per trial in expectation (less the more the scale spreads), and one
//! who reverses the scale far less.
//!
//! **Threshold.** pwcmp's distance: with `Q1` and `IQR` the first quartile and the
//! interquartile range of the `L_p` over participants (quartiles by linear interpolation),
//! `D_p = (Q1 - L_p) / IQR` when `L_p < Q1`, else 0. pwcmp suggests a distance above 1 "could
//! indicate" an outlier; since flagged participants may be excluded, blurlab flags at
//! `D_p > 1.5`, Tukey's lower fence `Q1 - 1.5 IQR`: for normally distributed `L_p` of honest
//! observers it flags 0.35 % of them, against 2.2 % at pwcmp's 1, while an observer answering
//! at random or reversing the scale lies many IQRs below `Q1` once participants make a few
//! hundred trials over a scale spanning a few JOD. Screening needs at
//! least 4 participants (fewer give no quartiles worth the name); with fewer nobody is flagged.

use serde::Serialize;

use crate::paired::PreferenceMatrix;
use crate::scaling::{JOD_SIGMA, fit_case_v, percentile};
use crate::srange::normal_sf;

/// The distance below the first quartile, in IQRs, above which a participant is flagged.
pub const OUTLIER_DISTANCE: f64 = 1.5;

/// The fewest participants screening flags anyone among.
pub const MIN_PARTICIPANTS: usize = 4;

/// One participant's screening.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ObserverScore {
    /// Participant code.
    pub participant: String,
    /// Trials they made.
    pub trials: u32,
    /// Mean log-10 likelihood per trial under the scale fitted without them.
    pub log10_likelihood: f64,
    /// `(Q1 - L) / IQR` when below `Q1`, else 0.
    pub distance: f64,
    /// `distance > OUTLIER_DISTANCE`.
    pub flagged: bool,
}

/// The screening of every participant of one experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Screening {
    /// The statistic and the threshold, in words (for the report).
    pub statistic: String,
    /// First quartile of the `L_p`.
    pub q1: f64,
    /// Interquartile range of the `L_p`.
    pub iqr: f64,
    /// `Q1 - OUTLIER_DISTANCE * IQR`: participants below are flagged.
    pub threshold: f64,
    /// Per participant, in the order given.
    pub observers: Vec<ObserverScore>,
    /// Codes of the flagged participants.
    pub flagged: Vec<String>,
}

fn log10_cdf(x: f64) -> f64 {
    // ln Phi(x) / ln 10, finite for very negative x.
    let ln =
        if x > -30.0 { normal_sf(-x).ln() } else { -0.5 * x * x - (-x).ln() - 0.5 * (2.0 * std::f64::consts::PI).ln() };
    ln / std::f64::consts::LN_10
}

/// Mean log-10 likelihood per trial of `answers` under `scores`.
pub fn mean_log10_likelihood(answers: &PreferenceMatrix, scores: &[f64]) -> f64 {
    let mut sum = 0.0;
    let mut n = 0u64;
    for (i, row) in answers.counts.iter().enumerate() {
        for (j, &a) in row.iter().enumerate() {
            if a > 0 {
                sum += f64::from(a) * log10_cdf((scores[i] - scores[j]) / JOD_SIGMA);
                n += u64::from(a);
            }
        }
    }
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

/// Screens `participants` (code and all their trials as one matrix) with the MAP prior
/// `prior_sd` (JOD), as the module docs say.
pub fn screen_observers(participants: &[(String, PreferenceMatrix)], prior_sd: f64) -> Screening {
    let t = participants.first().map_or(0, |(_, m)| m.t());
    let mut total = PreferenceMatrix::new(t);
    participants.iter().for_each(|(_, m)| total.add_matrix(m));
    let (full, _) = fit_case_v(&total, prior_sd, None);
    let mut scores: Vec<ObserverScore> = participants
        .iter()
        .map(|(code, m)| {
            let mut others = total.clone();
            for (row, own) in others.counts.iter_mut().zip(&m.counts) {
                for (c, o) in row.iter_mut().zip(own) {
                    *c -= o;
                }
            }
            let (scale, _) = fit_case_v(&others, prior_sd, Some(&full));
            ObserverScore {
                participant: code.clone(),
                trials: m.total(),
                log10_likelihood: mean_log10_likelihood(m, &scale),
                distance: 0.0,
                flagged: false,
            }
        })
        .collect();
    let mut sorted: Vec<f64> = scores.iter().map(|o| o.log10_likelihood).filter(|l| l.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let (q1, q3) = (percentile(&sorted, 0.25), percentile(&sorted, 0.75));
    let iqr = q3 - q1;
    let threshold = q1 - OUTLIER_DISTANCE * iqr;
    let enough = sorted.len() >= MIN_PARTICIPANTS;
    for o in &mut scores {
        let l = o.log10_likelihood;
        if enough && l < q1 {
            o.distance = if iqr > 0.0 { (q1 - l) / iqr } else { f64::INFINITY };
            o.flagged = o.distance > OUTLIER_DISTANCE;
        }
    }
    let flagged = scores.iter().filter(|o| o.flagged).map(|o| o.participant.clone()).collect();
    let statistic = format!(
        "L = mean log10 likelihood per trial of a participant's answers under the Thurstone scale fitted to the other participants (leave one out, as pwcmp's pw_outlier_analysis); flagged when more than {OUTLIER_DISTANCE} IQR below the first quartile of L (L < Q1 - {OUTLIER_DISTANCE} IQR = {threshold:.4}; Q1 = {q1:.4}, IQR = {iqr:.4}){}",
        if enough {
            String::new()
        } else {
            format!("; {} participants, fewer than {MIN_PARTICIPANTS}: nobody is flagged", sorted.len())
        }
    );
    Screening { statistic, q1, iqr, threshold, observers: scores, flagged }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_and_reversed_answers_score_lower_than_consistent_ones() {
        let scores = [0.0, 1.0, 2.0];
        let consistent = PreferenceMatrix::from_wins(3, [(2, 1), (1, 0), (2, 0)]);
        let reversed = PreferenceMatrix::from_wins(3, [(1, 2), (0, 1), (0, 2)]);
        let a = mean_log10_likelihood(&consistent, &scores);
        let b = mean_log10_likelihood(&reversed, &scores);
        assert!(a > 0.5f64.log10() && b < 0.5f64.log10(), "{a} {b}");
        // Equal scores: every answer is a coin flip.
        assert!((mean_log10_likelihood(&consistent, &[0.0; 3]) - 0.5f64.log10()).abs() < 1e-12);
    }

    #[test]
    fn fewer_than_four_participants_flag_nobody() {
        let p = |w: &[(usize, usize)]| PreferenceMatrix::from_wins(3, w.iter().copied());
        let list = vec![
            ("A".to_owned(), p(&[(2, 1), (1, 0), (2, 0)])),
            ("B".to_owned(), p(&[(2, 1), (1, 0), (2, 0)])),
            ("C".to_owned(), p(&[(1, 2), (0, 1), (0, 2)])),
        ];
        let s = screen_observers(&list, 3.0);
        assert!(s.flagged.is_empty() && s.statistic.contains("nobody is flagged"));
        assert!(s.observers[2].log10_likelihood < s.observers[0].log10_likelihood);
    }
}
