//! Expected information gain of showing a pair, and the choice of the next pair (or batch).
//!
//! The gain of pair `(i, j)` is the expected Kullback-Leibler divergence from the current
//! posterior to the posterior after its answer, weighted by the predictive probability of
//! each answer (ASAP's criterion): `p_ij KL(i wins) + (1 - p_ij) KL(j wins)`, the KL summed
//! over every stimulus whose marginal the answer moves.
//!
//! The posterior after a hypothetical answer is ASAP's warm-started update: the converged
//! messages stay, the new comparison sends its message (an online update of `i` and `j`),
//! then the comparisons that share a stimulus with it are refreshed once, moving their other
//! stimuli, and the new comparison once more. At a converged posterior the other messages
//! would not change in the paper's second message-passing iteration, so this computes it
//! without touching them: the cost of a pair is proportional to how many comparisons `i` and
//! `j` took part in, not to all comparisons.
//!
//! **Selective evaluation** (the paper's): the gain of `(i, j)`, `j < i`, is computed only
//! with probability `q_ij / max_k q_ik` (`k < i`), where `q_ij = min(p_ij, 1 - p_ij)` is the
//! probability of the less likely answer. Pairs whose outcome is all but certain are rarely
//! evaluated, and each stimulus keeps its most uncertain pair. Pairs not evaluated cannot be
//! chosen. The draws come from the caller's seeded generator.
//!
//! **Choice.** One pair at a time (a participant is waiting): the pair of largest gain, ties
//! broken uniformly at random. For many stimuli and comparisons the warm-started gain of every
//! kept pair is too slow for a waiting participant (about 120 ms for 225 stimuli after 4,500
//! answers on one core), so [`Search::Refine`] ranks the kept pairs by their online gain and
//! computes the warm-started gain of the best [`REFINED_PAIRS`] only. A batch (the paper's batch mode): the spanning tree of the
//! evaluated pairs with the smallest total `1 / gain` (Kruskal), so every stimulus is in the
//! batch once its component allows, ordered from the largest gain down.

use rand::Rng;

use crate::posterior::{Comparison, Natural, Posterior, factor_messages};

/// Whether to evaluate every pair or only those the paper's selective evaluation keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluation {
    /// Every pair (for comparison in the benchmark).
    Every,
    /// The paper's selective evaluation.
    Selective,
}

/// The gain of one evaluated pair (`i > j`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairGain {
    /// The later stimulus.
    pub i: usize,
    /// The earlier stimulus.
    pub j: usize,
    /// Expected information gain in nats.
    pub gain: f64,
}

/// Scratch marginals over a posterior: the ones an update moved, in front of the base.
struct Overlay<'a> {
    base: &'a Posterior,
    stamp: Vec<u32>,
    slot: Vec<u32>,
    changed: Vec<(usize, Natural)>,
    generation: u32,
}

impl<'a> Overlay<'a> {
    fn new(base: &'a Posterior) -> Self {
        Overlay {
            base,
            stamp: vec![0; base.len()],
            slot: vec![0; base.len()],
            changed: Vec::with_capacity(64),
            generation: 0,
        }
    }
    fn reset(&mut self) {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.fill(0);
            self.generation = 1;
        }
        self.changed.clear();
    }
    fn get(&self, i: usize) -> Natural {
        if self.stamp[i] == self.generation { self.changed[self.slot[i] as usize].1 } else { self.base.marginal(i) }
    }
    fn set(&mut self, i: usize, value: Natural) {
        if self.stamp[i] == self.generation {
            self.changed[self.slot[i] as usize].1 = value;
        } else {
            self.stamp[i] = self.generation;
            self.slot[i] = self.changed.len() as u32;
            self.changed.push((i, value));
        }
    }
    /// KL(new || base) summed over the moved marginals.
    fn divergence(&self) -> f64 {
        self.changed
            .iter()
            .map(|&(i, new)| {
                let old = self.base.marginal(i);
                let (v1, v0) = (new.variance(), old.variance());
                let d = new.mean() - old.mean();
                0.5 * ((v0 / v1).ln() + v1 / v0 + d * d / v0 - 1.0)
            })
            .sum()
    }
}

/// The KL divergence the answer "`winner` beats `loser`" would cause.
/// With `second_iteration` false, only the new comparison's message (the online update).
fn divergence_after(overlay: &mut Overlay<'_>, winner: usize, loser: usize, second_iteration: bool) -> f64 {
    overlay.reset();
    let post = overlay.base;
    let new = factor_messages(post.marginal(winner), post.marginal(loser));
    overlay.set(winner, post.marginal(winner).plus(new[0]));
    overlay.set(loser, post.marginal(loser).plus(new[1]));
    if !second_iteration {
        return overlay.divergence();
    }
    let refresh = |g: u32, overlay: &mut Overlay<'_>| {
        let (Comparison { winner: a, loser: b }, old) = post.factor(g as usize);
        let (ca, cb) = (overlay.get(a).minus(old[0]), overlay.get(b).minus(old[1]));
        let m = factor_messages(ca, cb);
        overlay.set(a, ca.plus(m[0]));
        overlay.set(b, cb.plus(m[1]));
    };
    for &g in post.adjacent(winner) {
        refresh(g, overlay);
    }
    for &g in post.adjacent(loser) {
        let (c, _) = post.factor(g as usize);
        if c.winner != winner && c.loser != winner {
            refresh(g, overlay);
        }
    }
    let (cw, cl) = (overlay.get(winner).minus(new[0]), overlay.get(loser).minus(new[1]));
    let again = factor_messages(cw, cl);
    overlay.set(winner, cw.plus(again[0]));
    overlay.set(loser, cl.plus(again[1]));
    overlay.divergence()
}

/// The expected information gain of showing `(i, j)` (with the warm-started update).
pub fn pair_gain(post: &Posterior, i: usize, j: usize) -> f64 {
    let mut overlay = Overlay::new(post);
    gain_with(&mut overlay, i, j, true)
}

fn gain_with(overlay: &mut Overlay<'_>, i: usize, j: usize, second_iteration: bool) -> f64 {
    let p = overlay.base.win_probability(i, j);
    p * divergence_after(overlay, i, j, second_iteration)
        + (1.0 - p) * divergence_after(overlay, j, i, second_iteration)
}

/// The gains of the pairs `evaluation` keeps, in order `(1, 0), (2, 0), (2, 1), ...`.
pub fn gains(post: &Posterior, evaluation: Evaluation, rng: &mut impl Rng) -> Vec<PairGain> {
    gains_by(post, evaluation, true, rng)
}

fn gains_by(post: &Posterior, evaluation: Evaluation, second_iteration: bool, rng: &mut impl Rng) -> Vec<PairGain> {
    let n = post.len();
    let means = post.means();
    let variances = post.variances();
    let mut overlay = Overlay::new(post);
    let mut out = Vec::with_capacity(n * n.saturating_sub(1) / 2);
    let mut row = Vec::with_capacity(n);
    for i in 1..n {
        row.clear();
        for j in 0..i {
            let p = crate::posterior::normal_cdf(
                (means[i] - means[j]) / (crate::posterior::DIFFERENCE_VARIANCE + variances[i] + variances[j]).sqrt(),
            );
            row.push(p.min(1.0 - p));
        }
        let max = row.iter().copied().fold(0.0f64, f64::max);
        for (j, &q) in row.iter().enumerate() {
            let keep = match evaluation {
                Evaluation::Every => true,
                Evaluation::Selective => {
                    let u: f64 = crate::unit_f64(rng);
                    max > 0.0 && q / max >= u
                }
            };
            if keep {
                out.push(PairGain { i, j, gain: gain_with(&mut overlay, i, j, second_iteration) });
            }
        }
    }
    out
}

/// How the next single pair is found among the evaluated pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Search {
    /// The warm-started gain of every evaluated pair (the paper's ASAP).
    Full,
    /// The online gain (the new comparison's message alone, as ASAP-approx computes it) of
    /// every evaluated pair, then the warm-started gain of the `n` best of them; the choice
    /// is the best of those. Its agreement with [`Search::Full`] is measured in
    /// `blurlab bench selection`.
    Refine(usize),
}

/// The pairs a participant waits for are chosen with [`Search::Refine`] over this many.
pub const REFINED_PAIRS: usize = 64;

/// The next pair to show: the largest gain among the evaluated pairs, ties broken at random.
/// `None` with fewer than two stimuli.
pub fn best_pair(
    post: &Posterior,
    evaluation: Evaluation,
    search: Search,
    rng: &mut impl Rng,
) -> Option<(usize, usize)> {
    best_pair_avoiding(post, evaluation, search, &[], rng)
}

/// [`best_pair`] among the pairs other than `avoid` (pairs `(i, j)` with `i > j`, e.g. those
/// on other participants' screens, which the posterior does not know about yet).
pub fn best_pair_avoiding(
    post: &Posterior,
    evaluation: Evaluation,
    search: Search,
    avoid: &[(usize, usize)],
    rng: &mut impl Rng,
) -> Option<(usize, usize)> {
    let allowed = |g: &PairGain| !avoid.contains(&(g.i, g.j));
    let all = match search {
        Search::Full => gains(post, evaluation, rng).into_iter().filter(allowed).collect(),
        Search::Refine(n) => {
            let mut online = gains_by(post, evaluation, false, rng);
            online.retain(allowed);
            online.sort_by(|a, b| b.gain.total_cmp(&a.gain).then((a.i, a.j).cmp(&(b.i, b.j))));
            online.truncate(n.max(1));
            let mut overlay = Overlay::new(post);
            for g in &mut online {
                g.gain = gain_with(&mut overlay, g.i, g.j, true);
            }
            online.sort_by_key(|g| (g.i, g.j));
            online
        }
    };
    let best = all.iter().map(|g| g.gain).fold(f64::NEG_INFINITY, f64::max);
    let ties: Vec<&PairGain> = all.iter().filter(|g| g.gain == best).collect();
    if ties.is_empty() {
        return None;
    }
    let k = crate::index_below(rng, ties.len());
    Some((ties[k].i, ties[k].j))
}

/// A batch of pairs: the minimum spanning forest of the evaluated pairs under `1 / gain`,
/// largest gain first.
pub fn spanning_batch(post: &Posterior, evaluation: Evaluation, rng: &mut impl Rng) -> Vec<(usize, usize)> {
    let mut all = gains(post, evaluation, rng);
    // Kruskal on 1 / gain ascending = gain descending; stable for equal gains.
    all.sort_by(|a, b| b.gain.total_cmp(&a.gain));
    let mut parent: Vec<usize> = (0..post.len()).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let mut out = Vec::new();
    for g in all {
        if g.gain.is_nan() || g.gain <= 0.0 {
            continue;
        }
        let (a, b) = (root(&mut parent, g.i), root(&mut parent, g.j));
        if a != b {
            parent[a] = b;
            out.push((g.i, g.j));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_pcg::Pcg64;

    use super::*;

    /// The same update computed the slow way: append the comparison, then one full sweep of
    /// every factor after the new one's first message (the paper's second iteration), at a
    /// posterior converged before.
    fn divergence_by_full_refit(post: &Posterior, winner: usize, loser: usize) -> f64 {
        let mut list = post.comparisons().to_vec();
        list.push(Comparison { winner, loser });
        let after = Posterior::fit(post.len(), &list).unwrap();
        let (m0, v0, m1, v1) = (post.means(), post.variances(), after.means(), after.variances());
        (0..post.len())
            .map(|i| 0.5 * ((v0[i] / v1[i]).ln() + v1[i] / v0[i] + (m1[i] - m0[i]).powi(2) / v0[i] - 1.0))
            .sum()
    }

    fn some_posterior() -> Posterior {
        let list: Vec<Comparison> = [(0, 1), (1, 2), (0, 2), (3, 1), (2, 4), (0, 4), (3, 4), (1, 0)]
            .iter()
            .map(|&(winner, loser)| Comparison { winner, loser })
            .collect();
        Posterior::fit(6, &list).unwrap()
    }

    #[test]
    fn the_warm_update_is_close_to_a_full_refit() {
        let post = some_posterior();
        for (w, l) in [(0, 3), (4, 1), (5, 0), (2, 3)] {
            let mut overlay = Overlay::new(&post);
            let fast = divergence_after(&mut overlay, w, l, true);
            let exact = divergence_by_full_refit(&post, w, l);
            assert!((fast - exact).abs() < 0.05 * exact, "{w} over {l}: {fast} vs {exact}");
        }
    }

    #[test]
    fn an_unseen_stimulus_against_a_known_one_teaches_more_than_a_settled_pair() {
        // Many answers settle 0 vs 1; stimulus 2 is new.
        let list: Vec<Comparison> = (0..60).map(|k| Comparison { winner: k % 2, loser: 1 - k % 2 }).collect();
        let post = Posterior::fit(3, &list).unwrap();
        assert!(pair_gain(&post, 2, 0) > 5.0 * pair_gain(&post, 1, 0));
        let mut rng = Pcg64::seed_from_u64(1);
        let (i, j) = best_pair(&post, Evaluation::Every, Search::Full, &mut rng).unwrap();
        assert_eq!(i, 2, "{i} {j}");
    }

    #[test]
    fn selective_evaluation_keeps_uncertain_pairs_and_drops_settled_ones() {
        // Stimuli spread far apart: neighbours are uncertain, distant pairs settled.
        let n = 12;
        let mut list = Vec::new();
        for i in 0..n {
            for j in 0..i {
                for _ in 0..(if i - j == 1 { 3 } else { 6 }) {
                    list.push(Comparison { winner: i, loser: j });
                }
            }
        }
        let post = Posterior::fit(n, &list).unwrap();
        let mut rng = Pcg64::seed_from_u64(2);
        let kept = gains(&post, Evaluation::Selective, &mut rng);
        let every = gains(&post, Evaluation::Every, &mut rng);
        assert_eq!(every.len(), n * (n - 1) / 2);
        assert!(kept.len() < every.len() / 2, "{} of {}", kept.len(), every.len());
        for i in 1..n {
            assert!(kept.iter().any(|g| g.i == i && g.j == i - 1), "the neighbour pair of {i} was dropped");
        }
    }

    #[test]
    fn a_batch_spans_every_stimulus_once() {
        let post = Posterior::prior(9);
        let mut rng = Pcg64::seed_from_u64(3);
        let batch = spanning_batch(&post, Evaluation::Selective, &mut rng);
        assert_eq!(batch.len(), 8);
        let mut parent: Vec<usize> = (0..9).collect();
        for &(a, b) in &batch {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            assert_ne!(ra, rb, "the batch has a cycle");
            parent[ra] = rb;
        }
        fn find(p: &mut [usize], mut x: usize) -> usize {
            while p[x] != x {
                x = p[x];
            }
            x
        }
    }

    /// ASAP's batches over 45 stimuli with answers from a Thurstone observer: every fit
    /// along the way converges, to the fixed point the sweeps reach without extrapolation.
    /// (An extrapolation that was not checked once blew a fit up here, to scores of 200.)
    #[test]
    fn fits_along_an_asap_run_converge_to_the_unaccelerated_fixed_point() {
        let n = 45;
        let mut rng = Pcg64::seed_from_u64(110);
        let uniform = |rng: &mut Pcg64| crate::unit_f64(rng);
        let truth: Vec<f64> = (0..n)
            .map(|_| {
                let (a, b) = (uniform(&mut rng).max(1e-12), uniform(&mut rng));
                (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
            })
            .collect();
        let mut list = Vec::new();
        let mut queue: Vec<(usize, usize)> = Vec::new();
        while list.len() < 2300 {
            if queue.is_empty() {
                let post = Posterior::fit(n, &list).unwrap();
                assert!(post.sweeps() < crate::posterior::MAX_SWEEPS, "no convergence at {}", list.len());
                if list.len() % 4 == 0 {
                    let plain = Posterior::fit_plain(n, &list);
                    for (a, b) in post.means().iter().zip(plain.means()) {
                        assert!((a - b).abs() < 1e-7, "{} comparisons: {a} vs {b}", list.len());
                    }
                }
                queue = spanning_batch(&post, Evaluation::Selective, &mut rng);
                queue.reverse();
            }
            let (i, j) = queue.pop().unwrap();
            let p = crate::posterior::normal_cdf(truth[i] - truth[j]);
            list.push(if uniform(&mut rng) < p {
                Comparison { winner: i, loser: j }
            } else {
                Comparison { winner: j, loser: i }
            });
        }
    }

    #[test]
    fn an_avoided_pair_is_not_chosen() {
        let post = Posterior::prior(3);
        for seed in 0..20 {
            let mut rng = Pcg64::seed_from_u64(seed);
            let pair = best_pair_avoiding(&post, Evaluation::Every, Search::Refine(2), &[(1, 0), (2, 0)], &mut rng);
            assert_eq!(pair, Some((2, 1)));
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_choice() {
        let post = some_posterior();
        for search in [Search::Full, Search::Refine(3)] {
            let a = best_pair(&post, Evaluation::Selective, search, &mut Pcg64::seed_from_u64(9));
            let b = best_pair(&post, Evaluation::Selective, search, &mut Pcg64::seed_from_u64(9));
            assert_eq!(a, b);
        }
    }
}
