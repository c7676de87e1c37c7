//! Piecewise-constant 1D distributions in 16-bit fixed point: the marginal (one
//! distribution over the rows) and the conditionals (one per row) of the environment's
//! light-sampling distribution.
//!
//! The conditionals hold most of the distribution's memory and are read at random, so
//! their size decides whether a light sample hits the core's L2 cache: 16-bit cumulative
//! tables with each distribution's guide table beside it take about a third of f32 tables
//! with separate guides, and the two look-ups of a sample fall in one contiguous block.
//! Integer comparisons also make the inversion exact: no rounding puts `u` a hair outside
//! the interval its guide entry names.
//!
//! Quantising the cumulative weights changes each probability by at most `1 / 65535`; the
//! density the sampler reports is always computed from the stored tables, so the estimator
//! stays unbiased. A cell whose share is below that resolution may get probability zero:
//! it is then reached only by BSDF sampling, whose multiple importance weight is 1 where
//! the light density is 0.

/// A distribution's cumulative weight in fixed point runs from 0 to `ONE`.
const ONE: u32 = u16::MAX as u32;

/// Distributions over `width` cells each, stored one after another ("rows").
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Cdf16 {
    /// Cells per distribution.
    width: usize,
    /// Guide entries per row (a power of two) and `16 - log2` of it: guide entry `k`
    /// covers fixed-point positions `[k << guide_shift, (k + 1) << guide_shift)`.
    guide_len: usize,
    guide_shift: u32,
    /// Table entries per row: `guide_len` guide entries, then `width + 1` cumulative ones.
    stride: usize,
    /// Per row: the guide (entry `k`: the last cell whose cumulative start is at most the
    /// start of `k`'s range), then the cumulative starts `c_0 = 0, c_1, ..., c_width = ONE`.
    table: Vec<u16>,
}

impl Cdf16 {
    /// Distributions over `width` cells from non-negative cell weights, `width` per
    /// distribution, one distribution after another. One without weight becomes uniform.
    pub(super) fn new(weights: &[f64], width: usize) -> Self {
        assert!(width > 0 && width < ONE as usize && weights.len().is_multiple_of(width));
        let guide_len = (width / 8).clamp(1, 1 << 16).next_power_of_two();
        let guide_shift = 16 - guide_len.trailing_zeros();
        let stride = guide_len + width + 1;
        let mut table = Vec::with_capacity(stride * weights.len() / width);
        let mut cdf = vec![0u16; width + 1];
        for row in weights.chunks_exact(width) {
            let sum: f64 = row.iter().sum();
            let mut running = 0.0;
            for (x, w) in row.iter().enumerate() {
                running += w;
                // Rounding a non-decreasing sequence keeps it non-decreasing.
                let share = if sum > 0.0 { running / sum } else { (x + 1) as f64 / width as f64 };
                cdf[x + 1] = (share.min(1.0) * f64::from(ONE)).round() as u16;
            }
            cdf[width] = ONE as u16;
            let mut x = 0;
            for k in 0..guide_len {
                let start = (k as u32) << guide_shift;
                while x + 1 < width && u32::from(cdf[x + 1]) <= start {
                    x += 1;
                }
                table.push(x as u16);
            }
            table.extend_from_slice(&cdf);
        }
        Cdf16 { width, guide_len, guide_shift, stride, table }
    }

    /// Cells per distribution.
    pub(crate) fn width(&self) -> usize {
        self.width
    }

    /// Guide entries per distribution, and `16 - log2` of that.
    pub(crate) fn guide(&self) -> (usize, u32) {
        (self.guide_len, self.guide_shift)
    }

    /// Table entries per distribution (guide, then `width + 1` cumulative entries).
    pub(crate) fn stride(&self) -> usize {
        self.stride
    }

    /// Every distribution's guide and cumulative table, one after another.
    pub(crate) fn table(&self) -> &[u16] {
        &self.table
    }

    fn cdf(&self, y: usize) -> &[u16] {
        &self.table[y * self.stride + self.guide_len..(y + 1) * self.stride]
    }

    /// The probability of cell `x` in distribution `y`.
    #[inline]
    pub(super) fn probability(&self, y: usize, x: usize) -> f64 {
        let cdf = self.cdf(y);
        f64::from(cdf[x + 1] - cdf[x]) * (1.0 / f64::from(ONE))
    }

    /// Inverts distribution `y` at `u` in [0, 1): the cell, the position inside it in
    /// [0, 1), and the cell's probability (never zero).
    #[inline]
    pub(super) fn sample(&self, y: usize, u: f64) -> (usize, f64, f64) {
        let row = &self.table[y * self.stride..(y + 1) * self.stride];
        let (guide, cdf) = row.split_at(self.guide_len);
        let t = u * f64::from(ONE);
        // The cell is the last x with c_x <= t, that is with c_x <= floor(t) (the c_x are
        // integers); c_width = ONE > t ends the search.
        let ti = (t as u32).min(ONE - 1);
        let k = (ti >> self.guide_shift) as usize;
        let lo = usize::from(guide[k]);
        let hi = if k + 1 < self.guide_len { usize::from(guide[k + 1]) } else { self.width - 1 };
        let x = lo + cdf[lo + 1..=hi].partition_point(|&c| u32::from(c) <= ti);
        let (start, width) = (f64::from(cdf[x]), f64::from(cdf[x + 1] - cdf[x]));
        let f = ((t - start) / width).clamp(0.0, 1.0 - f64::EPSILON);
        (x, f, width * (1.0 / f64::from(ONE)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of several kinds: peaked with zero cells, uniform, empty, one live cell.
    fn rows(width: usize) -> Vec<f64> {
        let mut w = Vec::new();
        for x in 0..width {
            w.push(if x % 7 == 0 { 0.0 } else { 1.0 + (x % 5) as f64 } + if x == width / 2 { 1.0e5 } else { 0.0 });
        }
        w.extend((0..width).map(|_| 3.0));
        w.extend((0..width).map(|_| 0.0));
        w.extend((0..width).map(|x| if x == width - 1 { 2.0 } else { 0.0 }));
        w.extend((0..width).map(|x| if x == 0 { 1e-300 } else { 1e300 }));
        w
    }

    #[test]
    fn inversion_equals_a_linear_search_of_the_fixed_point_table() {
        for width in [1usize, 3, 8, 300, 512] {
            let weights = rows(width);
            let d = Cdf16::new(&weights, width);
            let mut rng = 11_u64;
            for y in 0..weights.len() / width {
                let cdf = d.cdf(y);
                for k in 0..20_000 {
                    rng = study::seed::splitmix64(rng);
                    let u = match k {
                        0 => 0.0,
                        1 => 1.0 - f64::EPSILON,
                        k if k < 600 => (f64::from(cdf[k % width]) / f64::from(ONE)).min(1.0 - f64::EPSILON),
                        _ => (rng >> 11) as f64 / (1u64 << 53) as f64,
                    };
                    let (x, f, p) = d.sample(y, u);
                    let t = u * f64::from(ONE);
                    let expected = (0..width).rev().find(|&x| f64::from(cdf[x]) <= t).unwrap();
                    assert_eq!(x, expected, "width {width} row {y} u {u}");
                    assert!(p > 0.0 && p == d.probability(y, x) && (0.0..1.0).contains(&f));
                }
            }
        }
    }

    #[test]
    fn probabilities_sum_to_one_and_follow_the_weights_to_the_table_resolution() {
        let width = 300;
        let weights = rows(width);
        let d = Cdf16::new(&weights, width);
        for (y, row) in weights.chunks_exact(width).enumerate() {
            let sum: f64 = row.iter().sum();
            let total: f64 = (0..width).map(|x| d.probability(y, x)).sum();
            assert!((total - 1.0).abs() < 1e-12, "row {y}: {total}");
            for (x, &w) in row.iter().enumerate() {
                let exact = if sum > 0.0 { w / sum } else { 1.0 / width as f64 };
                // Each cumulative entry is rounded once: two half-steps of error at most.
                assert!((d.probability(y, x) - exact).abs() <= 1.0 / f64::from(ONE) + 1e-15, "row {y} cell {x}");
                if w == 0.0 && sum > 0.0 {
                    assert_eq!(d.probability(y, x), 0.0, "a zero cell must never be drawn");
                }
            }
        }
    }
}
