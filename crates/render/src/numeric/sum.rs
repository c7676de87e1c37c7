//! Compensated summation for accumulations of many samples. The f64 sum is the shared one
//! ([`study::stats::CompensatedSum`], Neumaier's); the f32 sum is the GPU accumulation's
//! twin: a pixel of a 1024-sample frame accumulated over many dispatches in f32 keeps about
//! one rounding of error instead of `n` of them.
//!
//! The CPU tracer keeps its plain f64 sum per pixel: at most a few thousand samples summed in
//! f64 carry a relative error near 1e-13, far below the f32 the pixel is stored as, so
//! compensation there would change no image (and the images must not change).

pub use study::stats::CompensatedSum;

use super::eft::two_sum_f32;

/// A compensated f32 sum (same steps as `compensated_add` in `numeric.wgsl`): the sum is
/// kept as an unevaluated pair `sum + compensation` with `|compensation| <= ulp(sum) / 2`.
/// Each addition is Knuth's TwoSum of the running sum and the new term, its error added to
/// the compensation, and the pair renormalised by another TwoSum. Unlike Neumaier's running
/// compensation (an ordinary f32 sum of the lost parts, which itself loses about `n u` of
/// its size once the terms fall below half an ulp of the sum), the pair's error stays about
/// `u^2` per addition, so a pixel accumulated over many dispatches stays within one rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompensatedSumF32 {
    /// The running sum, rounded.
    pub sum: f32,
    /// What `sum` lacks of the exact running total (to about `u^2` of it).
    pub compensation: f32,
}

impl CompensatedSumF32 {
    /// Adds `x`.
    #[inline]
    pub fn add(&mut self, x: f32) {
        let (s, e) = two_sum_f32(self.sum, x);
        // Renormalised by a second TwoSum (not the fast one: after cancellation `|c|` may
        // exceed `|s|`).
        (self.sum, self.compensation) = two_sum_f32(s, self.compensation + e);
    }

    /// The sum so far, rounded to f32.
    #[inline]
    pub fn value(&self) -> f32 {
        self.sum + self.compensation
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn a_million_small_samples_after_a_large_one() {
        // 1e-4 is below half an ulp of 1e4 in f32 (2^-11): the naive sum never moves.
        let mut s = CompensatedSumF32::default();
        let mut naive = 0.0f32;
        s.add(1e4);
        naive += 1e4;
        for _ in 0..1_000_000 {
            s.add(1e-4);
            naive += 1e-4;
        }
        let want = 1e4 + 1e6 * f64::from(1e-4f32);
        let got = f64::from(s.value());
        assert!((got - want).abs() <= 3.0 * f64::from(f32::EPSILON) * want, "{got} vs {want}");
        assert_eq!(naive, 1e4, "the naive f32 sum loses every sample");
    }

    proptest! {
        #[test]
        fn f32_sum_is_within_a_few_roundings_of_the_f64_sum(values in prop::collection::vec(0.0f32..10.0, 1..5000)) {
            // Radiance samples are non-negative: the bound is relative to the sum.
            let mut s = CompensatedSumF32::default();
            values.iter().for_each(|&v| s.add(v));
            let exact: f64 = values.iter().map(|&v| f64::from(v)).collect::<CompensatedSum>().value();
            let got = f64::from(s.value());
            prop_assert!((got - exact).abs() <= 2.0 * f64::from(f32::EPSILON) * exact + 1e-30, "{got} vs {exact}");
        }
    }
}
