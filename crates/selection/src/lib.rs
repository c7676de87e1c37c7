//! Active pair selection for paired-comparison experiments too large to show every pair.
//!
//! - [`posterior`]: ASAP's posterior over the stimulus scores (Thurstone Case V on the
//!   TrueSkill factor graph, fitted by expectation propagation).
//! - [`gain`]: the expected information gain of a pair, the paper's selective evaluation,
//!   and the choice of the next pair or of a spanning-tree batch.
//! - [`random_pair`]: the baseline, a uniformly random pair.
//!
//! Mikhailiuk, Wilmot, Perez-Ortiz, Yue and Mantiuk, "Active sampling for pairwise
//! comparisons via approximate message passing and information gain maximization", ICPR
//! 2020, implemented from the paper. Every random choice draws from the caller's seeded
//! generator, so a selection is reproducible from its seed and the comparisons before it.

pub mod gain;
pub mod posterior;

pub use gain::{
    Evaluation, PairGain, REFINED_PAIRS, Search, best_pair, best_pair_avoiding, gains, pair_gain, spanning_batch,
};
pub use posterior::{Comparison, JOD_PER_UNIT, Posterior};

use rand::Rng;

/// A uniform draw in `[0, 1)` with 53 random bits (public so that simulations of a selection
/// draw as it does).
pub fn unit_f64(rng: &mut impl Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform index below `n` (`n > 0`), by rejection so that every index is equally likely.
pub fn index_below(rng: &mut impl Rng, n: usize) -> usize {
    let n = n as u64;
    let zone = u64::MAX - u64::MAX % n;
    loop {
        let x = rng.next_u64();
        if x < zone {
            return (x % n) as usize;
        }
    }
}

/// A uniformly random unordered pair `(i, j)`, `i > j`, of `n >= 2` stimuli.
pub fn random_pair(n: usize, rng: &mut impl Rng) -> (usize, usize) {
    let k = index_below(rng, n * (n - 1) / 2);
    // Row i holds the pairs (i, 0..i): k = i (i - 1) / 2 + j.
    let mut i = ((1.0 + (1.0 + 8.0 * k as f64).sqrt()) / 2.0).floor() as usize;
    while i * (i - 1) / 2 > k {
        i -= 1;
    }
    while (i + 1) * i / 2 <= k {
        i += 1;
    }
    (i, k - i * (i - 1) / 2)
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_pcg::Pcg64;

    #[test]
    fn random_pairs_cover_every_pair_evenly() {
        let n = 7;
        let mut counts = vec![0u32; n * n];
        let mut rng = Pcg64::seed_from_u64(5);
        for _ in 0..21_000 {
            let (i, j) = super::random_pair(n, &mut rng);
            assert!(i > j && i < n);
            counts[i * n + j] += 1;
        }
        let seen: Vec<u32> = counts.into_iter().filter(|&c| c > 0).collect();
        assert_eq!(seen.len(), 21);
        assert!(seen.iter().all(|&c| (850..1150).contains(&c)), "{seen:?}");
    }
}
