//! The posterior ASAP selects pairs from: one Gaussian per stimulus score, fitted to the
//! comparisons so far by expectation propagation (approximate message passing on the
//! TrueSkill factor graph, as Mikhailiuk et al. 2020 do).
//!
//! Model, in the paper's units: scores `s_i ~ N(0, PRIOR_VARIANCE)` a priori; a comparison
//! that `w` won over `l` observes `s_w - s_l + e > 0` with `e ~ N(0, DIFFERENCE_VARIANCE)`,
//! so `P(w beats l) = Phi(s_w - s_l)`: Thurstone Case V with a unit standard deviation of
//! the difference. One model unit is [`JOD_PER_UNIT`] just-objectionable differences (a
//! difference of 1 JOD is preferred 75 % of the time: `Phi(0.6745) = 0.75`).
//!
//! Every comparison is a factor holding one message to each of its two stimuli; a
//! stimulus's posterior is its prior times the messages of its comparisons (natural
//! parameters add). The fit sweeps the comparisons in their order, replacing each factor's
//! messages by moment matching of the truncated difference against the cavity (the posterior
//! without that factor), until no marginal moves by more than [`TOLERANCE`]. It always starts
//! from empty messages, so the posterior is a function of the comparison list alone: a
//! posterior rebuilt from the response logs equals the one kept while they were written.

use statrs::function::erf::erfc;

/// Prior variance of each score (model units), as in the paper's code.
pub const PRIOR_VARIANCE: f64 = 0.5;
/// Variance of the observation noise on a score difference (model units).
pub const DIFFERENCE_VARIANCE: f64 = 1.0;
/// JOD per model unit: `1 / Phi^{-1}(0.75)`.
pub const JOD_PER_UNIT: f64 = 1.482_602_218_505_602;
/// Convergence: the largest change of any marginal's mean or standard deviation in a sweep.
pub const TOLERANCE: f64 = 1e-10;
/// The most sweeps of a fit (reached only if the tolerance is not).
pub const MAX_SWEEPS: usize = 500;

/// One answer: `winner` was preferred over `loser` (indices into the stimulus list).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Comparison {
    /// The preferred stimulus.
    pub winner: usize,
    /// The other one.
    pub loser: usize,
}

/// A Gaussian in natural parameters: precision and precision times mean.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Natural {
    /// Precision (inverse variance).
    pub precision: f64,
    /// Precision times mean.
    pub tau: f64,
}

impl Natural {
    pub(crate) fn mean(self) -> f64 {
        self.tau / self.precision
    }
    pub(crate) fn variance(self) -> f64 {
        1.0 / self.precision
    }
    pub(crate) fn plus(self, other: Natural) -> Natural {
        Natural { precision: self.precision + other.precision, tau: self.tau + other.tau }
    }
    pub(crate) fn minus(self, other: Natural) -> Natural {
        Natural { precision: self.precision - other.precision, tau: self.tau - other.tau }
    }
}

/// `phi(t) / Phi(t)`, accurate for any `t` (a continued fraction of Mills' ratio in the far
/// left tail, where both would underflow).
pub(crate) fn truncation_psi(t: f64) -> f64 {
    if t > -20.0 {
        let pdf = (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let cdf = 0.5 * erfc(-t / std::f64::consts::SQRT_2);
        pdf / cdf
    } else {
        // 1 / R(x) with R(x) = 1 / (x + 1 / (x + 2 / (x + 3 / (x + ...)))), x = -t.
        let x = -t;
        let mut f = x;
        for k in (1..=40).rev() {
            f = x + f64::from(k) / f;
        }
        f
    }
}

/// `Phi(x)`.
pub fn normal_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// The messages a comparison sends to its winner and loser, given their cavities.
/// A comparison whose outcome was certain under the cavities carries no information: its
/// messages are empty rather than the limit of a vanishing precision.
pub fn factor_messages(winner: Natural, loser: Natural) -> [Natural; 2] {
    let (vw, vl) = (winner.variance(), loser.variance());
    let v = DIFFERENCE_VARIANCE + vw + vl;
    let m = winner.mean() - loser.mean();
    let sd = v.sqrt();
    let t = m / sd;
    let psi = truncation_psi(t);
    let one_minus_lambda = (1.0 - psi * (psi + t)).max(1e-12);
    // Moments of the difference given that the winner won, then the message they imply.
    let post_precision = 1.0 / (v * one_minus_lambda);
    let post_mean = m + sd * psi;
    let msg_precision = post_precision - 1.0 / v;
    if msg_precision.is_nan() || msg_precision <= 1e-12 / v || !msg_precision.is_finite() {
        return [Natural::default(); 2];
    }
    let msg_mean = (post_mean * post_precision - m / v) / msg_precision;
    // s_w = d - e + s_l and s_l = s_w - d + e: the message's variance adds the noise and the
    // other side's cavity.
    let to_winner_var = 1.0 / msg_precision + DIFFERENCE_VARIANCE + vl;
    let to_loser_var = 1.0 / msg_precision + DIFFERENCE_VARIANCE + vw;
    let w_mean = msg_mean + loser.mean();
    let l_mean = winner.mean() - msg_mean;
    [
        Natural { precision: 1.0 / to_winner_var, tau: w_mean / to_winner_var },
        Natural { precision: 1.0 / to_loser_var, tau: l_mean / to_loser_var },
    ]
}

/// The fitted posterior of `n` stimulus scores.
#[derive(Clone, Debug)]
pub struct Posterior {
    comparisons: Vec<Comparison>,
    messages: Vec<[Natural; 2]>,
    marginals: Vec<Natural>,
    /// For each stimulus, the comparisons it took part in.
    adjacency: Vec<Vec<u32>>,
    sweeps: usize,
}

/// A comparison names a stimulus outside the list, or a stimulus against itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BadComparison {
    /// Its position in the list.
    pub index: usize,
    /// The comparison.
    pub comparison: Comparison,
    /// The number of stimuli.
    pub stimuli: usize,
}

impl std::fmt::Display for BadComparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "comparison {} ({} over {}) is not a pair of two of the {} stimuli",
            self.index, self.comparison.winner, self.comparison.loser, self.stimuli
        )
    }
}

impl std::error::Error for BadComparison {}

impl Posterior {
    /// The prior of `n` stimuli (no comparisons).
    pub fn prior(n: usize) -> Posterior {
        Posterior {
            comparisons: Vec::new(),
            messages: Vec::new(),
            marginals: vec![Natural { precision: 1.0 / PRIOR_VARIANCE, tau: 0.0 }; n],
            adjacency: vec![Vec::new(); n],
            sweeps: 0,
        }
    }

    /// Fits the posterior of `n` stimuli to `comparisons`, in their order.
    pub fn fit(n: usize, comparisons: &[Comparison]) -> Result<Posterior, BadComparison> {
        let mut p = Posterior::prior(n);
        for (index, &c) in comparisons.iter().enumerate() {
            if c.winner >= n || c.loser >= n || c.winner == c.loser {
                return Err(BadComparison { index, comparison: c, stimuli: n });
            }
            let g = p.comparisons.len() as u32;
            p.comparisons.push(c);
            p.messages.push([Natural::default(); 2]);
            p.adjacency[c.winner].push(g);
            p.adjacency[c.loser].push(g);
        }
        p.converge(true);
        Ok(p)
    }

    /// [`Posterior::fit`] without the extrapolation (for tests: the same fixed point, slowly).
    #[cfg(test)]
    pub(crate) fn fit_plain(n: usize, comparisons: &[Comparison]) -> Posterior {
        let mut p = Posterior::prior(n);
        for &c in comparisons {
            let g = p.comparisons.len() as u32;
            p.comparisons.push(c);
            p.messages.push([Natural::default(); 2]);
            p.adjacency[c.winner].push(g);
            p.adjacency[c.loser].push(g);
        }
        p.converge(false);
        p
    }

    fn converge(&mut self, accelerate: bool) {
        self.sweeps = 0;
        // The slowest mode of the sweeps is a common shift of every score, which only the
        // weak prior pins: it decays geometrically, by the ratio of prior to total precision
        // per sweep. Once four sweeps show the same ratio (within 2 %), the shift is
        // extrapolated to its limit (Aitken) by moving every message; the fixed point is
        // unchanged, and the sweeps that follow must still meet the tolerance. Where the
        // slow mode is not a pure shift the extrapolation can overshoot: if the sweep after
        // it changes the marginals more than the sweep before it did, the state before the
        // extrapolation is restored and later extrapolations go half as far (none after three
        // such restores).
        let mut centres: Vec<f64> = Vec::new();
        let mut saved: Option<(Vec<[Natural; 2]>, Vec<Natural>, f64)> = None;
        let mut step = if accelerate { 1.0 } else { 0.0 };
        while self.sweeps < MAX_SWEEPS {
            self.sweeps += 1;
            let mut change = 0.0f64;
            for g in 0..self.comparisons.len() {
                change = change.max(self.update_factor(g));
            }
            if let Some((messages, marginals, before)) = saved.take()
                && (change.is_nan() || change > before)
            {
                self.messages = messages;
                self.marginals = marginals;
                step *= 0.5;
                centres.clear();
                continue;
            }
            if change < TOLERANCE {
                break;
            }
            centres.push(self.marginals.iter().map(|m| m.mean()).sum::<f64>() / self.len() as f64);
            if let [.., a, b, c, d] = centres[..] {
                let (r1, r2) = ((c - b) / (b - a), (d - c) / (c - b));
                if step > 0.1 && r2 > 0.5 && r2 < 1.0 && (r1 - r2).abs() < 0.02 * r2 && (d - c).abs() > TOLERANCE {
                    saved = Some((self.messages.clone(), self.marginals.clone(), change));
                    self.shift(step * (d - c) * r2 / (1.0 - r2));
                    centres.clear();
                }
            }
        }
    }

    /// Moves every message's mean by `delta` (marginals follow).
    fn shift(&mut self, delta: f64) {
        for m in self.messages.iter_mut().flatten() {
            m.tau += delta * m.precision;
        }
        for (i, marginal) in self.marginals.iter_mut().enumerate() {
            let mut sum = Natural { precision: 1.0 / PRIOR_VARIANCE, tau: 0.0 };
            for &g in &self.adjacency[i] {
                let (c, msg) = (self.comparisons[g as usize], self.messages[g as usize]);
                sum = sum.plus(if c.winner == i { msg[0] } else { msg[1] });
            }
            *marginal = sum;
        }
    }

    /// Replaces factor `g`'s messages; returns the largest change of a mean or sd it caused.
    fn update_factor(&mut self, g: usize) -> f64 {
        let Comparison { winner, loser } = self.comparisons[g];
        let old = self.messages[g];
        let cw = self.marginals[winner].minus(old[0]);
        let cl = self.marginals[loser].minus(old[1]);
        let new = factor_messages(cw, cl);
        let (bw, bl) = (self.marginals[winner], self.marginals[loser]);
        self.marginals[winner] = cw.plus(new[0]);
        self.marginals[loser] = cl.plus(new[1]);
        self.messages[g] = new;
        let moved =
            |a: Natural, b: Natural| (a.mean() - b.mean()).abs().max((a.variance().sqrt() - b.variance().sqrt()).abs());
        moved(bw, self.marginals[winner]).max(moved(bl, self.marginals[loser]))
    }

    /// Number of stimuli.
    pub fn len(&self) -> usize {
        self.marginals.len()
    }

    /// Whether there are no stimuli.
    pub fn is_empty(&self) -> bool {
        self.marginals.is_empty()
    }

    /// The comparisons fitted, in order.
    pub fn comparisons(&self) -> &[Comparison] {
        &self.comparisons
    }

    /// Posterior means (model units).
    pub fn means(&self) -> Vec<f64> {
        self.marginals.iter().map(|m| m.mean()).collect()
    }

    /// Posterior variances (model units squared).
    pub fn variances(&self) -> Vec<f64> {
        self.marginals.iter().map(|m| m.variance()).collect()
    }

    /// Sweeps the last fit took.
    pub fn sweeps(&self) -> usize {
        self.sweeps
    }

    /// `P(i beats j)` under the posterior predictive.
    pub fn win_probability(&self, i: usize, j: usize) -> f64 {
        let (a, b) = (self.marginals[i], self.marginals[j]);
        normal_cdf((a.mean() - b.mean()) / (DIFFERENCE_VARIANCE + a.variance() + b.variance()).sqrt())
    }

    pub(crate) fn marginal(&self, i: usize) -> Natural {
        self.marginals[i]
    }

    pub(crate) fn adjacent(&self, i: usize) -> &[u32] {
        &self.adjacency[i]
    }

    pub(crate) fn factor(&self, g: usize) -> (Comparison, [Natural; 2]) {
        (self.comparisons[g], self.messages[g])
    }

    /// Bytes of memory the posterior holds (for the benchmark's statement).
    pub fn memory_bytes(&self) -> usize {
        self.comparisons.capacity() * std::mem::size_of::<Comparison>()
            + self.messages.capacity() * std::mem::size_of::<[Natural; 2]>()
            + self.marginals.capacity() * std::mem::size_of::<Natural>()
            + self.adjacency.iter().map(|a| a.capacity() * 4 + std::mem::size_of::<Vec<u32>>()).sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psi_is_continuous_across_the_tail_switch_and_matches_its_asymptote() {
        let (a, b) = (truncation_psi(-20.0 + 1e-9), truncation_psi(-20.0 - 1e-9));
        assert!((a - b).abs() < 1e-6 * a, "{a} {b}");
        // psi(t) ~ -t for t -> -inf; 0.398942 at t = 0 (phi(0) / 0.5).
        assert!((truncation_psi(-1e4) - 1e4).abs() < 1e-3);
        assert!((truncation_psi(0.0) - 0.797_884_560_802_865_4).abs() < 1e-12);
        assert!(truncation_psi(40.0) >= 0.0 && truncation_psi(40.0) < 1e-300);
    }

    #[test]
    fn one_comparison_matches_the_closed_form_moments() {
        // With one comparison EP is exact moment matching: the winner's posterior mean is
        // v_w / sqrt(v) * psi(0) with v = 1 + 2 * PRIOR_VARIANCE.
        let p = Posterior::fit(3, &[Comparison { winner: 0, loser: 1 }]).unwrap();
        let v = DIFFERENCE_VARIANCE + 2.0 * PRIOR_VARIANCE;
        let psi0 = truncation_psi(0.0);
        let mean = PRIOR_VARIANCE / v.sqrt() * psi0;
        let lambda = psi0 * psi0;
        let var = PRIOR_VARIANCE - PRIOR_VARIANCE * PRIOR_VARIANCE / v * lambda;
        let (m, s) = (p.means(), p.variances());
        assert!((m[0] - mean).abs() < 1e-12 && (m[1] + mean).abs() < 1e-12, "{m:?}");
        assert!((s[0] - var).abs() < 1e-12 && (s[1] - var).abs() < 1e-12, "{s:?}");
        assert_eq!((m[2], s[2]), (0.0, PRIOR_VARIANCE));
    }

    #[test]
    fn many_answers_recover_the_true_order_and_shrink_the_variance() {
        // Deterministic answers in proportion to the true win probabilities.
        let truth = [0.0, 0.5, 1.0, 2.0];
        let mut list = Vec::new();
        for i in 0..4 {
            for j in i + 1..4 {
                let p = normal_cdf(truth[j] - truth[i]);
                let wins = (p * 200.0).round() as usize;
                list.extend((0..wins).map(|_| Comparison { winner: j, loser: i }));
                list.extend((0..200 - wins).map(|_| Comparison { winner: i, loser: j }));
            }
        }
        let p = Posterior::fit(4, &list).unwrap();
        let m = p.means();
        let offset = m[0] - truth[0];
        for i in 0..4 {
            assert!((m[i] - offset - truth[i]).abs() < 0.1, "{m:?}");
        }
        assert!(p.variances().iter().all(|&v| v < 0.01));
        assert!(p.sweeps() < MAX_SWEEPS);
    }

    #[test]
    fn bad_comparisons_are_refused_with_their_position() {
        let e =
            Posterior::fit(3, &[Comparison { winner: 0, loser: 1 }, Comparison { winner: 2, loser: 2 }]).unwrap_err();
        assert_eq!(e.index, 1);
        assert!(Posterior::fit(3, &[Comparison { winner: 3, loser: 1 }]).is_err());
    }

    #[test]
    fn a_unanimous_stimulus_stays_finite() {
        let list: Vec<Comparison> = (0..500).map(|k| Comparison { winner: 0, loser: 1 + k % 2 }).collect();
        let p = Posterior::fit(3, &list).unwrap();
        assert!(p.means().iter().chain(&p.variances()).all(|x| x.is_finite()));
        assert!(p.means()[0] > 1.0);
    }
}
