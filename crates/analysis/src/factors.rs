//! Per-factor preference in a broad 2AFC comparison (thesis test #1, figure 5.4): for each
//! factor and each pair of its levels, the trials whose two stimuli differ in that factor
//! at exactly those levels, the share choosing each level, its standard error
//! `sqrt(p (1 - p) / n)`, and the chi-square goodness-of-fit test against no preference
//! (`chi2 = (k - (n - k))^2 / n`, 1 degree of freedom).

use serde::Serialize;
use study::{Factor, StimulusId};

use crate::paired::chi_square_sf;

/// Preference between two levels of one factor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelPreference {
    /// The factor.
    pub factor: Factor,
    /// The first level's label, e.g. `M2`.
    pub level_a: String,
    /// The second level's label, e.g. `M3`.
    pub level_b: String,
    /// Trials comparing the two levels.
    pub n: u32,
    /// Trials choosing the first level.
    pub chose_a: u32,
    /// Share choosing the first level.
    pub p_a: f64,
    /// Share choosing the second level.
    pub p_b: f64,
    /// Standard error of the shares.
    pub se: f64,
    /// Chi-square statistic against 50 : 50.
    pub chi_square: f64,
    /// Its p-value (1 degree of freedom).
    pub p_value: f64,
}

/// The preference of `chose_a` out of `n` with its standard error and chi-square test.
pub fn level_preference(factor: Factor, level_a: u8, level_b: u8, n: u32, chose_a: u32) -> LevelPreference {
    let nf = f64::from(n);
    let (p_a, se, chi_square) = if n == 0 {
        (f64::NAN, f64::NAN, 0.0)
    } else {
        let p = f64::from(chose_a) / nf;
        let diff = 2.0 * f64::from(chose_a) - nf;
        (p, (p * (1.0 - p) / nf).sqrt(), diff * diff / nf)
    };
    LevelPreference {
        factor,
        level_a: factor.label(level_a),
        level_b: factor.label(level_b),
        n,
        chose_a,
        p_a,
        p_b: 1.0 - p_a,
        se,
        chi_square,
        p_value: if n == 0 { f64::NAN } else { chi_square_sf(chi_square, 1.0) },
    }
}

/// Preferences for every factor and level pair over `trials` of `(first, second, choice)`.
pub fn factor_preferences(
    trials: &[(&StimulusId, &StimulusId, &StimulusId)],
    factors: &[Factor],
) -> Vec<LevelPreference> {
    let mut out = Vec::new();
    for &factor in factors {
        let mut levels: Vec<u8> = Vec::new();
        for &(a, b, _) in trials {
            for l in [a.level(factor), b.level(factor)] {
                if !levels.contains(&l) {
                    levels.push(l);
                }
            }
        }
        levels.sort_unstable();
        for (i, &la) in levels.iter().enumerate() {
            for &lb in &levels[i + 1..] {
                let (mut n, mut k) = (0, 0);
                for &(a, b, choice) in trials {
                    let pair = (a.level(factor), b.level(factor));
                    if pair == (la, lb) || pair == (lb, la) {
                        n += 1;
                        if choice.level(factor) == la {
                            k += 1;
                        }
                    }
                }
                if n > 0 {
                    out.push(level_preference(factor, la, lb, n, k));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_standard_error_and_chi_square_by_hand() {
        let p = level_preference(Factor::Material, 2, 3, 100, 33);
        assert!((p.p_a - 0.33).abs() < 1e-12 && (p.p_b - 0.67).abs() < 1e-12);
        assert!((p.se - (0.33f64 * 0.67 / 100.0).sqrt()).abs() < 1e-12);
        // (33 - 67)^2 / 100 = 11.56; P(chi2_1 > 11.56) = 6.74e-4.
        assert!((p.chi_square - 11.56).abs() < 1e-9);
        assert!((p.p_value - 6.74e-4).abs() < 1e-5, "{}", p.p_value);
        let even = level_preference(Factor::Speed, 2, 3, 10, 5);
        assert_eq!(even.chi_square, 0.0);
        assert_eq!(even.p_value, 1.0);
    }

    #[test]
    fn counts_only_trials_that_differ_in_the_factor() {
        let id = |s: &str| s.parse::<StimulusId>().unwrap();
        let (a, b, c) = (id("M2-S2-T3-A5"), id("M3-S2-T3-A5"), id("M3-S3-T3-A5"));
        let trials = [(a, b, b), (b, c, b), (a, c, a)];
        let prefs = factor_preferences(
            &trials.iter().map(|(x, y, z)| (x, y, z)).collect::<Vec<_>>(),
            &[Factor::Material, Factor::Speed],
        );
        let material = &prefs[0];
        assert_eq!((material.n, material.chose_a), (2, 1));
        let speed = &prefs[1];
        assert_eq!((speed.n, speed.chose_a), (2, 2));
    }
}
