//! The sample generator: padded, Owen-scrambled 2D Sobol points (hash-based nested uniform
//! scrambling in the manner of Burley 2020, "Practical Hash-based Owen Scrambling").
//!
//! Each pixel owns a seed (the eye's seed mixed with the pixel index), so the values a
//! pixel draws do not depend on which thread or tile renders it. Each sampling dimension
//! (pixel position, time, the light and BSDF choices of every bounce, ...) gets its own
//! scramble and its own shuffle of the sample index: dimensions are padded, not
//! correlated, and the points of one dimension over the pixel's samples stay well
//! stratified (a (0, 2)-sequence in 2D). Skipping a dimension (no time sampling in a
//! static frame) does not change the values of the others.

use study::seed::splitmix64;

/// Sampling dimensions of a camera sample; bounce `b` uses `BOUNCE_BASE + b * PER_BOUNCE`
/// onwards.
pub mod dim {
    /// Position inside the pixel (2D).
    pub const PIXEL: u32 = 0;
    /// Time inside the shutter interval (1D).
    pub const TIME: u32 = 1;
    /// First dimension of the bounce-dependent block.
    pub const BOUNCE_BASE: u32 = 2;
    /// Dimensions used by one bounce: light sample (2D), BSDF sample (2D), roulette (1D).
    pub const PER_BOUNCE: u32 = 3;
    /// Offsets inside a bounce's block.
    pub const LIGHT: u32 = 0;
    /// BSDF direction.
    pub const BSDF: u32 = 1;
    /// Russian roulette.
    pub const ROULETTE: u32 = 2;
}

/// Laine-Karras style hash permutation: an Owen scramble of the bit-reversed value.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of a 32-bit fixed-point fraction.
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// First Sobol dimension (van der Corput in base 2), 32-bit fraction.
#[inline]
fn sobol0(i: u32) -> u32 {
    i.reverse_bits()
}

/// Second Sobol dimension (primitive polynomial x + 1: each direction number is the
/// previous one xor itself shifted right by one).
#[inline]
fn sobol1(mut i: u32) -> u32 {
    let mut v = 1u32 << 31;
    let mut r = 0;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

#[inline]
fn to_unit(x: u32) -> f64 {
    f64::from(x) * (1.0 / 4_294_967_296.0)
}

/// The samples of one pixel.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    seed: u64,
    index: u32,
}

impl PixelSampler {
    /// The sampler of the pixel `(x, y)` of an image `width` wide, for an eye's seed.
    pub fn new(eye_seed: u64, x: u32, y: u32, width: u32) -> Self {
        let pixel = u64::from(y) * u64::from(width) + u64::from(x);
        PixelSampler { seed: splitmix64(eye_seed ^ splitmix64(pixel)), index: 0 }
    }

    /// Moves to sample `index` of this pixel.
    #[inline]
    pub fn start_sample(&mut self, index: u32) {
        self.index = index;
    }

    #[inline]
    fn dim_hash(&self, dim: u32) -> u64 {
        splitmix64(self.seed ^ (u64::from(dim) << 32 | 0x5bd1))
    }

    /// A 1D value in [0, 1) of dimension `dim` for the current sample.
    #[inline]
    pub fn get_1d(&self, dim: u32) -> f64 {
        let h = self.dim_hash(dim);
        let i = owen_scramble(self.index, h as u32);
        to_unit(owen_scramble(sobol0(i), (h >> 32) as u32))
    }

    /// A 2D value in [0, 1)^2 of dimension `dim` for the current sample.
    #[inline]
    pub fn get_2d(&self, dim: u32) -> [f64; 2] {
        let h = self.dim_hash(dim);
        let h2 = splitmix64(h);
        let i = owen_scramble(self.index, h as u32);
        [to_unit(owen_scramble(sobol0(i), (h >> 32) as u32)), to_unit(owen_scramble(sobol1(i), h2 as u32))]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_2d_is_stratified_in_every_elementary_interval() {
        // The first 16 points of (sobol0, sobol1) hit each cell of every 2^a x 2^b grid
        // with a + b = 4 exactly once; Owen scrambling keeps that.
        for seed in [0u32, 12345, 0xdead_beef] {
            let pts: Vec<(u32, u32)> =
                (0..16).map(|i| (owen_scramble(sobol0(i), seed), owen_scramble(sobol1(i), seed ^ 77))).collect();
            for a in 0..=4 {
                let b = 4 - a;
                let mut seen = [false; 16];
                for &(x, y) in &pts {
                    let cell = (((u64::from(x) >> (32 - a)) << b) | (u64::from(y) >> (32 - b))) as usize;
                    assert!(!seen[cell], "seed {seed} a {a}: duplicate cell");
                    seen[cell] = true;
                }
            }
        }
    }

    #[test]
    fn pixel_dimensions_are_uniform_and_independent_of_each_other() {
        let mut s = PixelSampler::new(42, 3, 4, 10);
        let n = 4096;
        let (mut mean_a, mut mean_b, mut cov) = (0.0, 0.0, 0.0);
        for i in 0..n {
            s.start_sample(i);
            let a = s.get_1d(5);
            let b = s.get_2d(6)[0];
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            mean_a += a;
            mean_b += b;
            cov += (a - 0.5) * (b - 0.5);
        }
        let n = f64::from(n);
        assert!((mean_a / n - 0.5).abs() < 1e-3 && (mean_b / n - 0.5).abs() < 1e-3);
        // Independent uniforms: covariance sd is 1/12/sqrt(n) ~ 1.3e-3.
        assert!((cov / n).abs() < 6e-3, "cov {}", cov / n);
    }
}
