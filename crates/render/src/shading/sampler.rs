//! The sample generator: padded, Owen-scrambled 2D Sobol points (hash-based nested uniform
//! scrambling in the manner of Burley 2020, "Practical Hash-based Owen Scrambling").
//!
//! Each pixel owns a seed (the eye's seed mixed with the pixel index), so the values a
//! pixel draws do not depend on which thread or tile renders it. Each sampling dimension
//! (pixel position, time, the light and BSDF choices of every bounce, ...) gets its own
//! scramble, and every one but the pixel position its own shuffle of the sample index:
//! dimensions are padded, not correlated, and the points of one dimension over the
//! pixel's samples stay well stratified (a (0, 2)-sequence in 2D). The pixel position
//! keeps the samples' own order, the reference the other dimensions are shuffled against
//! (one shuffle fewer per camera sample). Skipping a dimension (no time sampling in a
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
pub(crate) fn laine_karras(mut x: u32, seed: u32) -> u32 {
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
#[cfg(test)]
fn sobol0(i: u32) -> u32 {
    i.reverse_bits()
}

/// Direction numbers of the second Sobol dimension (primitive polynomial x + 1: each
/// direction number is the previous one xor itself shifted right by one).
const SOBOL1_DIRECTIONS: [u32; 32] = {
    let mut v = [0u32; 32];
    let mut d = 1u32 << 31;
    let mut k = 0;
    while k < 32 {
        v[k] = d;
        d ^= d >> 1;
        k += 1;
    }
    v
};

/// The second dimension is linear over GF(2) in the bits of the index, so it splits into
/// four byte-indexed tables: one look-up per byte instead of a loop over 32 bits (the
/// index is Owen-shuffled, so all 32 bits are in use).
const SOBOL1_BYTE_TABLES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut b = 0;
        while b < 256 {
            let mut r = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if b & (1 << bit) != 0 {
                    r ^= SOBOL1_DIRECTIONS[byte * 8 + bit];
                }
                bit += 1;
            }
            t[byte][b] = r;
            b += 1;
        }
        byte += 1;
    }
    t
};

/// The same tables bit-reversed: the scrambling works on reversed values, and reversing
/// a table entry once here saves reversing every sample.
const SOBOL1_REVERSED_TABLES: [[u32; 256]; 4] = {
    let mut t = SOBOL1_BYTE_TABLES;
    let mut byte = 0;
    while byte < 4 {
        let mut b = 0;
        while b < 256 {
            t[byte][b] = t[byte][b].reverse_bits();
            b += 1;
        }
        byte += 1;
    }
    t
};

#[inline]
fn byte_table_lookup(t: &[[u32; 256]; 4], i: u32) -> u32 {
    t[0][(i & 0xff) as usize]
        ^ t[1][((i >> 8) & 0xff) as usize]
        ^ t[2][((i >> 16) & 0xff) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// Second Sobol dimension, 32-bit fraction.
#[cfg(test)]
fn sobol1(i: u32) -> u32 {
    byte_table_lookup(&SOBOL1_BYTE_TABLES, i)
}

/// The second Sobol dimension, bit-reversed.
#[inline]
pub(crate) fn sobol1_reversed(i: u32) -> u32 {
    byte_table_lookup(&SOBOL1_REVERSED_TABLES, i)
}

/// The second Sobol dimension by its definition, bit by bit (the tables' reference).
#[cfg(test)]
fn sobol1_bitwise(mut i: u32) -> u32 {
    let mut r = 0;
    let mut k = 0;
    while i != 0 {
        if i & 1 != 0 {
            r ^= SOBOL1_DIRECTIONS[k];
        }
        i >>= 1;
        k += 1;
    }
    r
}

#[inline]
fn to_unit(x: u32) -> f64 {
    f64::from(x) * (1.0 / 4_294_967_296.0)
}

/// Dimensions whose scrambling seeds a [`PixelSampler`] keeps precomputed (enough for
/// `2 + 3 x 10` bounces); higher dimensions derive theirs on every call.
const CACHED_DIMS: usize = 32;

/// The scrambling seeds of one dimension of one pixel: index shuffle, first and second
/// coordinate.
#[derive(Clone, Copy, Debug, Default)]
struct DimSeeds {
    shuffle: u32,
    first: u32,
    second: u32,
}

/// The samples of one pixel.
#[derive(Clone, Debug)]
pub struct PixelSampler {
    seed: u64,
    /// The current sample's index, and bit-reversed.
    index: u32,
    reversed_index: u32,
    /// Seeds of the first `cached` dimensions: they do not change between the pixel's
    /// samples, so they are derived once per pixel rather than once per value.
    seeds: [DimSeeds; CACHED_DIMS],
    cached: u32,
}

impl PixelSampler {
    /// The sampler of the pixel `(x, y)` of an image `width` wide, for an eye's seed;
    /// `dims` is how many dimensions a sample uses (their seeds are derived up front).
    pub fn new(eye_seed: u64, x: u32, y: u32, width: u32, dims: u32) -> Self {
        let pixel = u64::from(y) * u64::from(width) + u64::from(x);
        let seed = splitmix64(eye_seed ^ splitmix64(pixel));
        let cached = dims.min(CACHED_DIMS as u32);
        let mut seeds = [DimSeeds::default(); CACHED_DIMS];
        for (d, s) in seeds.iter_mut().enumerate().take(cached as usize) {
            *s = derive_seeds(seed, d as u32);
        }
        PixelSampler { seed, index: 0, reversed_index: 0, seeds, cached }
    }

    /// Moves to sample `index` of this pixel.
    #[inline]
    pub fn start_sample(&mut self, index: u32) {
        self.index = index;
        self.reversed_index = index.reverse_bits();
    }

    #[inline]
    fn seeds(&self, dim: u32) -> DimSeeds {
        if dim < self.cached { self.seeds[dim as usize] } else { derive_seeds(self.seed, dim) }
    }

    /// The shuffled sample index of a dimension, `owen_scramble(index, shuffle)`; the
    /// pixel position's is the index itself.
    #[inline]
    fn shuffled_index(&self, dim: u32, s: &DimSeeds) -> u32 {
        if dim == dim::PIXEL {
            return self.index;
        }
        laine_karras(self.reversed_index, s.shuffle).reverse_bits()
    }

    // `owen_scramble(v, seed)` is `reverse(laine_karras(reverse(v), seed))`; the first Sobol
    // dimension is `reverse(i)`, so its scrambled value is `reverse(laine_karras(i, seed))`,
    // and the second uses the reversed tables: three bit reversals per 2D value, not seven.

    /// A 1D value in [0, 1) of dimension `dim` for the current sample.
    #[inline]
    pub fn get_1d(&self, dim: u32) -> f64 {
        let s = self.seeds(dim);
        let i = self.shuffled_index(dim, &s);
        to_unit(laine_karras(i, s.first).reverse_bits())
    }

    /// A 2D value in [0, 1)^2 of dimension `dim` for the current sample.
    #[inline]
    pub fn get_2d(&self, dim: u32) -> [f64; 2] {
        let s = self.seeds(dim);
        let i = self.shuffled_index(dim, &s);
        [
            to_unit(laine_karras(i, s.first).reverse_bits()),
            to_unit(laine_karras(sobol1_reversed(i), s.second).reverse_bits()),
        ]
    }
}

/// The seeds of dimension `dim` of the pixel whose seed is `pixel_seed`.
#[inline]
fn derive_seeds(pixel_seed: u64, dim: u32) -> DimSeeds {
    let h = splitmix64(pixel_seed ^ (u64::from(dim) << 32 | 0x5bd1));
    DimSeeds { shuffle: h as u32, first: (h >> 32) as u32, second: splitmix64(h) as u32 }
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
    fn each_dimension_of_a_pixels_samples_is_a_net() {
        // The first 2^m samples of any 2D dimension of a pixel, shuffled or not, put one
        // point in every cell of every 2^a x 2^b grid with a + b = m.
        for (pixel, m) in [(0u32, 4u32), (7, 6), (123, 3)] {
            let mut sampler = PixelSampler::new(2024, pixel, 1, 640, 8);
            for dim in [dim::PIXEL, dim::BOUNCE_BASE + dim::LIGHT, dim::BOUNCE_BASE + dim::BSDF, 40] {
                let pts: Vec<[f64; 2]> = (0..1u32 << m)
                    .map(|i| {
                        sampler.start_sample(i);
                        sampler.get_2d(dim)
                    })
                    .collect();
                for a in 0..=m {
                    let b = m - a;
                    let mut seen = vec![false; 1 << m];
                    for p in &pts {
                        let cell =
                            (((p[0] * f64::from(1u32 << a)) as usize) << b) | (p[1] * f64::from(1u32 << b)) as usize;
                        assert!(!seen[cell], "pixel {pixel} dim {dim} grid 2^{a} x 2^{b}: two points in one cell");
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn sobol1_tables_match_the_bitwise_definition() {
        let mut x = 0x2545_f491_u64;
        for i in (0..4096u32).chain([u32::MAX, 1 << 31, 0x8000_0001]) {
            assert_eq!(sobol1(i), sobol1_bitwise(i), "{i}");
            x = splitmix64(x);
            assert_eq!(sobol1(x as u32), sobol1_bitwise(x as u32));
        }
    }

    #[test]
    fn values_equal_the_owen_scrambled_sobol_definition() {
        let mut sampler = PixelSampler::new(77, 1, 2, 3, 8);
        for index in 0..64 {
            sampler.start_sample(index);
            for dim in 0..10 {
                let s = derive_seeds(sampler.seed, dim);
                let i = if dim == dim::PIXEL { index } else { owen_scramble(index, s.shuffle) };
                let expected =
                    [to_unit(owen_scramble(sobol0(i), s.first)), to_unit(owen_scramble(sobol1_bitwise(i), s.second))];
                assert_eq!(sampler.get_2d(dim), expected);
                assert_eq!(sampler.get_1d(dim), expected[0]);
            }
        }
    }

    #[test]
    fn cached_seeds_equal_derived_ones() {
        let mut cached = PixelSampler::new(9, 5, 7, 640, 14);
        let mut uncached = PixelSampler::new(9, 5, 7, 640, 0);
        for i in 0..8 {
            cached.start_sample(i);
            uncached.start_sample(i);
            for d in 0..20 {
                assert_eq!(cached.get_2d(d), uncached.get_2d(d));
                assert_eq!(cached.get_1d(d), uncached.get_1d(d));
            }
        }
    }

    #[test]
    fn pixel_dimensions_are_uniform_and_independent_of_each_other() {
        let mut s = PixelSampler::new(42, 3, 4, 10, 6);
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
