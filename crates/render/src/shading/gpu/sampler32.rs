//! The u32-only sampler of the GPU tracer: the padded, Owen-scrambled 2D Sobol sampler of
//! [`crate::shading::sampler`] with every operation on u32, because WGSL has no 64-bit
//! integers. `sampler32.wgsl` beside it is its twin and computes the same integer sample
//! values bit for bit (`tests/sampler32_wgsl.rs`).
//!
//! The structure is the CPU sampler's: the same [`dim`] layout; 2D values are the first two
//! Sobol dimensions (van der Corput and the generator of the primitive polynomial x + 1),
//! each coordinate Owen-scrambled by the Laine-Karras style hash of Burley 2020 with its own
//! seed; every dimension but [`dim::PIXEL`] draws from its own Owen shuffle of the sample
//! index, so dimensions are padded rather than correlated, and the first 2^k samples of a
//! dimension are still a (0, k, 2)-net. Only the seeding differs, being 32-bit:
//!
//! - [`eye_seed32`], once per eye on the CPU: `h = splitmix64(eye_seed)`, reduced to
//!   `(h >> 32) ^ (h & 0xffff_ffff)`. The splitmix step first makes every bit of the u64
//!   seed reach every bit of the result (a plain `hi ^ lo` would give `0` and
//!   `1 << 32 | 1` the same seed).
//! - [`pixel_seed`]: `hash32(eye ^ hash32(pixel))` with `pixel = y * width + x`. Both steps
//!   are bijections, so the pixels of one eye never share a seed. Pixels of two different
//!   eyes do, at random pairs of positions, as 32-bit seeds must (about n^2 / 2^32 pairs of
//!   an n-pixel image).
//! - [`dim_seeds`]: `h = hash32(pixel_seed ^ hash32(dim ^ 0x5bd1_e995))` is the index
//!   shuffle's seed, `hash32(h ^ 0x68e3_1da4)` and `hash32(h ^ 0xb529_7a4d)` those of the two
//!   coordinates.
//!
//! `hash32` is the "lowbias32" integer hash found by Chris Wellons' hash prospector (two
//! multiply-xorshift rounds, bijective). Sample values are 32-bit fixed-point fractions;
//! [`to_unit`] keeps their top 24 bits, `(v >> 8) as f32 * 2^-24`, so the f32 value is
//! exact and below 1. Values are pure functions of (pixel seed, sample index, dimension):
//! they do not depend on evaluation order, and skipping a dimension changes no other.

use study::seed::splitmix64;

use crate::shading::sampler::{dim, laine_karras};

/// The 32-bit seed of an eye: its u64 frame seed through splitmix64, high half xor low half.
pub fn eye_seed32(eye_seed: u64) -> u32 {
    let h = splitmix64(eye_seed);
    (h >> 32) as u32 ^ h as u32
}

/// The "lowbias32" integer hash: a bijection of u32 with low avalanche bias.
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The seed of pixel number `pixel` (`y * width + x`) of the eye whose [`eye_seed32`] is
/// `eye_seed`.
#[inline]
pub fn pixel_seed(eye_seed: u32, pixel: u32) -> u32 {
    hash32(eye_seed ^ hash32(pixel))
}

/// The scrambling seeds of one dimension of one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DimSeeds {
    /// Owen shuffle of the sample index (unused by [`dim::PIXEL`]).
    pub shuffle: u32,
    /// Scramble of the first coordinate (and of a 1D value).
    pub first: u32,
    /// Scramble of the second coordinate.
    pub second: u32,
}

/// The seeds of dimension `dim` of the pixel whose seed is `pixel_seed`.
#[inline]
pub fn dim_seeds(pixel_seed: u32, dim: u32) -> DimSeeds {
    let h = hash32(pixel_seed ^ hash32(dim ^ 0x5bd1_e995));
    DimSeeds { shuffle: h, first: hash32(h ^ 0x68e3_1da4), second: hash32(h ^ 0xb529_7a4d) }
}

/// The second Sobol dimension of `i`, bit-reversed, without tables or a loop over the bits.
/// Its generator matrix is Pascal's triangle mod 2: bit `m` of the reversed value is the xor
/// of the index bits `k` whose binomial C(k, m) is odd, which by Lucas' theorem are those
/// with `k ⊇ m` (every bit of `m` set in `k`). That "superset xor" of the 32 bits takes five
/// shift-and-xor steps, each folding in the bits one power of two above. Equal to the CPU
/// sampler's table look-up for every index (tested).
#[inline]
pub fn sobol1_reversed(i: u32) -> u32 {
    let mut x = i;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

/// The index dimension `dim` draws its point from for sample `index`: the index itself for
/// the pixel position, otherwise its Owen shuffle.
#[inline]
fn shuffled_index(index: u32, dim: u32, shuffle: u32) -> u32 {
    if dim == dim::PIXEL { index } else { laine_karras(index.reverse_bits(), shuffle).reverse_bits() }
}

// As in the CPU sampler: `owen_scramble(v, s) = reverse(laine_karras(reverse(v), s))` and the
// first Sobol dimension is `reverse(i)`, so its scrambled value is `reverse(laine_karras(i, s))`.

/// The 1D value of dimension `dim` for sample `index` of a pixel, as a 32-bit fraction.
#[inline]
pub fn sample_1d_bits(pixel_seed: u32, index: u32, dim: u32) -> u32 {
    let s = dim_seeds(pixel_seed, dim);
    laine_karras(shuffled_index(index, dim, s.shuffle), s.first).reverse_bits()
}

/// The 2D value of dimension `dim` for sample `index` of a pixel, as 32-bit fractions; the
/// first coordinate is [`sample_1d_bits`].
#[inline]
pub fn sample_2d_bits(pixel_seed: u32, index: u32, dim: u32) -> [u32; 2] {
    let s = dim_seeds(pixel_seed, dim);
    let i = shuffled_index(index, dim, s.shuffle);
    [laine_karras(i, s.first).reverse_bits(), laine_karras(sobol1_reversed(i), s.second).reverse_bits()]
}

/// A 32-bit fraction as an f32 in [0, 1): its top 24 bits, exactly.
#[inline]
pub fn to_unit(v: u32) -> f32 {
    (v >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The samples of one pixel, as the GPU kernel draws them: seeds are derived on every call
/// (as on the GPU, where registers are dearer than three hashes).
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler32 {
    seed: u32,
    index: u32,
}

impl PixelSampler32 {
    /// The sampler of pixel `(x, y)` of an image `width` wide, for an eye's [`eye_seed32`].
    pub fn new(eye_seed: u32, x: u32, y: u32, width: u32) -> Self {
        PixelSampler32 { seed: pixel_seed(eye_seed, y * width + x), index: 0 }
    }

    /// This pixel's seed.
    pub fn seed(&self) -> u32 {
        self.seed
    }

    /// Moves to sample `index` of this pixel.
    #[inline]
    pub fn start_sample(&mut self, index: u32) {
        self.index = index;
    }

    /// A 1D value in [0, 1) of dimension `dim` for the current sample.
    #[inline]
    pub fn get_1d(&self, dim: u32) -> f32 {
        to_unit(sample_1d_bits(self.seed, self.index, dim))
    }

    /// A 2D value in [0, 1)^2 of dimension `dim` for the current sample.
    #[inline]
    pub fn get_2d(&self, dim: u32) -> [f32; 2] {
        sample_2d_bits(self.seed, self.index, dim).map(to_unit)
    }
}

#[cfg(test)]
mod tests {
    use study::stats::correlation;

    use super::*;

    /// A few pixels of two eyes, corner and interior, of a 640-wide image.
    fn pixels() -> Vec<PixelSampler32> {
        let mut out = Vec::new();
        for eye in [eye_seed32(2024), eye_seed32(study::seed::splitmix64(7))] {
            for (x, y) in [(0, 0), (1, 0), (0, 1), (319, 179), (639, 359)] {
                out.push(PixelSampler32::new(eye, x, y, 640));
            }
        }
        out
    }

    /// Dimensions the tracer uses (ten bounces) and a few beyond.
    fn dims() -> impl Iterator<Item = u32> {
        (0..dim::BOUNCE_BASE + 10 * dim::PER_BOUNCE).chain([100, 1000, u32::MAX])
    }

    #[test]
    fn every_2d_dimension_of_a_pixels_first_samples_is_a_net() {
        // The first 2^k samples (and any aligned block of 2^k: the shuffle maps one onto
        // another) put exactly one point in each of the 2^k cells of every 2^a x 2^b grid
        // with a + b = k, read from the f32 values.
        for mut s in pixels() {
            for d in dims() {
                for k in 2..=8u32 {
                    for block in [0u32, 5] {
                        let start = block << k;
                        let pts: Vec<[f32; 2]> = (start..start + (1 << k))
                            .map(|i| {
                                s.start_sample(i);
                                s.get_2d(d)
                            })
                            .collect();
                        for a in 0..=k {
                            let b = k - a;
                            let mut seen = vec![false; 1 << k];
                            for p in &pts {
                                let cell = (((p[0] * (1u32 << a) as f32) as usize) << b)
                                    | (p[1] * (1u32 << b) as f32) as usize;
                                assert!(
                                    !seen[cell],
                                    "pixel seed {:#x} dim {d} samples {start}..+2^{k}: two points in one cell of 2^{a} x 2^{b}",
                                    s.seed()
                                );
                                seen[cell] = true;
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn every_1d_dimension_is_stratified() {
        for mut s in pixels() {
            for d in dims() {
                for k in 2..=10u32 {
                    let mut seen = vec![false; 1 << k];
                    for i in 0..1u32 << k {
                        s.start_sample(i);
                        let cell = (s.get_1d(d) * (1u32 << k) as f32) as usize;
                        assert!(!seen[cell], "pixel seed {:#x} dim {d}: two of 2^{k} samples in one stratum", s.seed());
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn dimensions_and_pixels_are_decorrelated() {
        const N: u32 = 4096;
        // For independent uniforms the correlation over N samples has sd 1/sqrt(N) = 0.016.
        // The hash-based shuffles spread it about 1.3 times wider (RMS, measured; the CPU
        // sampler's do the same): the largest of the 2,640 pairs of dimensions here is 5.1
        // sd. Each pair must stay within 6 sd, and the RMS over all within 1.5.
        let sd = 1.0 / f64::from(N).sqrt();
        let limit = 6.0 * sd;
        let series = |s: &PixelSampler32, d: u32, coord: usize| -> Vec<f64> {
            let mut s = *s;
            (0..N)
                .map(|i| {
                    s.start_sample(i);
                    f64::from(s.get_2d(d)[coord])
                })
                .collect()
        };
        let pixels = pixels();
        let (mut worst, mut sum_sq, mut pairs) = (0.0f64, 0.0, 0usize);
        for (p, s) in pixels.iter().enumerate() {
            let columns: Vec<(u32, usize, Vec<f64>)> =
                (0..12).flat_map(|d| [0, 1].map(|c| (d, c, series(s, d, c)))).collect();
            // Coordinates of different dimensions of one pixel.
            for (i, (da, ca, a)) in columns.iter().enumerate() {
                for (db, cb, b) in &columns[i + 1..] {
                    if da == db {
                        continue;
                    }
                    let r = correlation(a, b);
                    worst = worst.max(r.abs());
                    sum_sq += r * r;
                    pairs += 1;
                    assert!(r.abs() < limit, "pixel {p}: dims {da}.{ca} and {db}.{cb} correlate {r:.4}");
                }
            }
            // The same shuffled dimension of two pixels (the pixel position keeps the sample
            // order in every pixel, so only its values, not its order, are per pixel).
            for (q, t) in pixels.iter().enumerate().skip(p + 1) {
                for d in [dim::TIME, dim::BOUNCE_BASE, 7, 40] {
                    let r = correlation(&series(s, d, 0), &series(t, d, 0));
                    assert!(r.abs() < limit, "dim {d}: pixels {p} and {q} correlate {r:.4}");
                }
                let same = (0..N)
                    .filter(|&i| {
                        let (mut a, mut b) = (*s, *t);
                        a.start_sample(i);
                        b.start_sample(i);
                        a.get_2d(dim::PIXEL) == b.get_2d(dim::PIXEL)
                    })
                    .count();
                assert!(same < 4, "pixels {p} and {q} share {same} of {N} pixel positions");
            }
        }
        let rms = (sum_sq / pairs as f64).sqrt();
        eprintln!("{pairs} pairs of dimensions: RMS correlation {:.2} sd, largest {:.2} sd", rms / sd, worst / sd);
        assert!(rms < 1.5 * sd && worst > 0.0, "RMS correlation {:.2} sd", rms / sd);
    }

    #[test]
    fn values_do_not_depend_on_evaluation_order() {
        let pixels = pixels();
        let indices: Vec<u32> = (0..64).chain([65_535, 65_536, 1 << 20, u32::MAX]).collect();
        let dims: Vec<u32> = dims().collect();
        let key = |p: usize, i: usize, d: usize| (p * indices.len() + i) * dims.len() + d;
        let mut forward = vec![[0u32; 3]; pixels.len() * indices.len() * dims.len()];
        for (p, s) in pixels.iter().enumerate() {
            for (i, &index) in indices.iter().enumerate() {
                for (d, &dm) in dims.iter().enumerate() {
                    let [x, y] = sample_2d_bits(s.seed(), index, dm);
                    forward[key(p, i, d)] = [x, y, sample_1d_bits(s.seed(), index, dm)];
                }
            }
        }
        // One stateful sampler per pixel, visited in a scrambled order of (pixel, index, dim).
        let mut samplers = pixels.clone();
        let mut order: Vec<usize> = (0..forward.len()).collect();
        order.sort_by_key(|&k| hash32(k as u32 ^ 0x1234_5678));
        for k in order {
            let (p, rest) = (k / (indices.len() * dims.len()), k % (indices.len() * dims.len()));
            let (i, d) = (rest / dims.len(), rest % dims.len());
            let s = &mut samplers[p];
            s.start_sample(indices[i]);
            let [x, y] = s.get_2d(dims[d]);
            let expected = forward[key(p, i, d)];
            assert_eq!([x, y, s.get_1d(dims[d])], [to_unit(expected[0]), to_unit(expected[1]), to_unit(expected[2])]);
            assert_eq!(expected[0], expected[2], "a 1D value is the 2D value's first coordinate");
        }
    }

    #[test]
    fn the_loop_free_second_dimension_equals_the_cpu_samplers_tables() {
        let mut x = 7u32;
        let mut indices: Vec<u32> = (0..1 << 16).chain([u32::MAX, 1 << 31, (1 << 31) - 1]).collect();
        for _ in 0..100_000 {
            x = hash32(x);
            indices.push(x);
        }
        for i in indices {
            assert_eq!(sobol1_reversed(i), crate::shading::sampler::sobol1_reversed(i), "index {i:#x}");
        }
    }

    #[test]
    fn unit_values_are_the_exact_top_24_bits() {
        assert_eq!(to_unit(0), 0.0);
        assert_eq!(to_unit(u32::MAX), 1.0 - f32::EPSILON / 2.0);
        let mut x = 1u32;
        for _ in 0..10_000 {
            x = hash32(x);
            let u = to_unit(x);
            assert!((0.0..1.0).contains(&u));
            assert_eq!(f64::from(u), f64::from(x >> 8) / 16_777_216.0);
            assert_eq!((u * 16_777_216.0) as u32, x >> 8);
        }
    }

    #[test]
    fn seeds_are_32_bit_reductions_that_keep_pixels_apart() {
        let h = splitmix64(0x0123_4567_89ab_cdef);
        assert_eq!(eye_seed32(0x0123_4567_89ab_cdef), (h >> 32) as u32 ^ h as u32);
        // Seeds whose halves xor alike still differ.
        assert_ne!(eye_seed32(0), eye_seed32(1 << 32 | 1));
        // Every pixel of a 1920 x 1080 eye has its own seed.
        let eye = eye_seed32(99);
        let mut seeds: Vec<u32> = (0..1920 * 1080).map(|p| pixel_seed(eye, p)).collect();
        seeds.sort_unstable();
        seeds.dedup();
        assert_eq!(seeds.len(), 1920 * 1080);
        // The hash is a bijection that mixes: one flipped input bit flips about half the output.
        let flips: u32 = (0..32).map(|b| (hash32(12345) ^ hash32(12345 ^ (1 << b))).count_ones()).sum();
        assert!((12 * 32..20 * 32).contains(&flips), "{flips}");
    }
}
