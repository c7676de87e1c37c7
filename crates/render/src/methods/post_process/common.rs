//! The twin of `common.wgsl`: the parameters every pass reads
//! ([`PassParams`], the uniform buffer) and the functions the passes share, each named as its
//! WGSL function and written with the same f32 operations in the same order (no fused
//! multiply-adds, no built-ins whose precision WGSL leaves open: `length`, `normalize`,
//! `smoothstep` and `mix` are spelt out).

/// What every pass reads: the WGSL struct `Params` (uniform, 24 words).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PassParams {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tiles across: ceil(width / tile).
    pub tiles_x: u32,
    /// Tiles down: ceil(height / tile).
    pub tiles_y: u32,
    /// Tile size in pixels (k, r), also the largest blur radius.
    pub tile: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// Jitter seed.
    pub seed: u32,
    /// 1: split samples by the tile variance (Guertin); 0: half and half.
    pub variance: u32,
    /// McGuire: soft depth extent in metres.
    pub soft_z_extent: f32,
    /// Guertin: tau.
    pub tau: f32,
    /// Guertin: kappa.
    pub kappa: f32,
    /// Guertin: eta.
    pub eta: f32,
    /// Guertin: gamma.
    pub gamma: f32,
    /// Guertin: phi.
    pub phi: f32,
    /// 1 / (samples + 1), computed once on the host. Every quotient by a parameter is a
    /// product with its reciprocal from here, on both sides: a shader compiler may replace a
    /// division by a loop-invariant value by a product with its reciprocal, which rounds
    /// differently, and a last-bit difference in a sample's position can move it to the next
    /// pixel.
    pub inv_samples_plus_one: f32,
    /// 1 / tile.
    pub inv_tile: f32,
    /// McGuire: 1 / soft_z_extent.
    pub inv_soft_z_extent: f32,
    /// Guertin: 1 / gamma.
    pub inv_gamma: f32,
    /// Guertin: the jitter's scale eta phi / N.
    pub jitter_scale: f32,
    /// Unused (a 16-byte multiple).
    pub pad0: u32,
    /// Unused.
    pub pad1: u32,
    /// Unused.
    pub pad2: u32,
}

impl PassParams {
    /// Parameters with the sizes set and every filter setting zero (no tiles for a zero
    /// tile size, which the filters refuse).
    pub fn new(width: u32, height: u32, tile: u32, samples: u32, seed: u32) -> PassParams {
        PassParams {
            width,
            height,
            tiles_x: if tile == 0 { 0 } else { width.div_ceil(tile) },
            tiles_y: if tile == 0 { 0 } else { height.div_ceil(tile) },
            tile,
            samples,
            seed,
            variance: 0,
            soft_z_extent: 0.0,
            tau: 0.0,
            kappa: 0.0,
            eta: 0.0,
            gamma: 0.0,
            phi: 0.0,
            inv_samples_plus_one: 1.0 / (samples as f32 + 1.0),
            inv_tile: if tile == 0 { 0.0 } else { 1.0 / tile as f32 },
            inv_soft_z_extent: 0.0,
            inv_gamma: 0.0,
            jitter_scale: 0.0,
            pad0: 0,
            pad1: 0,
            pad2: 0,
        }
    }

    /// Pixels in the image.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Tiles in the image.
    pub fn tiles(&self) -> usize {
        self.tiles_x as usize * self.tiles_y as usize
    }
}

/// Encoded velocities are `v / (|v| + VELOCITY_EPSILON)` times the clamped length (Guertin
/// et al. 2014, section 5).
pub const VELOCITY_EPSILON: f32 = 1.0e-5;
/// The smallest blur radius of a moving pixel, and the speed below which a pixel counts as
/// still (half a pixel, both papers).
pub const HALF_PIXEL: f32 = 0.5;

/// The colour scale of a gather's second try, 2^-64: a gather whose weighted mean came out
/// non-finite from finite inputs overflowed its sum (colours near `f32::MAX` times weights
/// that add up to more than 1), and is gathered again with every colour times this, the
/// mean multiplied back by [`OVERFLOW_UNSCALE`]. Powers of two scale exactly, so the second
/// try is the first one's arithmetic with the exponents shifted: the right mean, not a clamp.
/// 2^-64 leaves room for any weight total up to 2^64 (the largest, Guertin's centre weight
/// at the design's smallest kappa with 1024 samples, is about 2^21); colours below about
/// 2^-62, which the shift takes into the subnormals, are at most 2^-100 of the overflowing
/// ones. Ordinary pixels never take the second try, so their bits are unchanged.
pub const OVERFLOW_SCALE: f32 = f32::from_bits(0x1f80_0000);
/// 2^64, the inverse of [`OVERFLOW_SCALE`].
pub const OVERFLOW_UNSCALE: f32 = f32::from_bits(0x5f80_0000);

/// A gather's running sums: the WGSL struct `Gathered`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gathered {
    /// Sum of weight times (scaled) colour.
    pub sum: [f32; 3],
    /// Sum of the weights.
    pub weight: f32,
    /// Per channel, the smallest unscaled colour gathered.
    pub lo: [f32; 3],
    /// Per channel, the largest unscaled colour gathered.
    pub hi: [f32; 3],
}

impl Gathered {
    /// The sums with the pixel's own colour `c` (unscaled) at weight `w`, scaled by `scale`.
    pub fn start(c: [f32; 3], w: f32, scale: f32) -> Gathered {
        Gathered { sum: [c[0] * scale * w, c[1] * scale * w, c[2] * scale * w], weight: w, lo: c, hi: c }
    }

    /// Adds colour `c` (unscaled) at weight `w`, scaled by `scale`.
    pub fn add(&mut self, c: [f32; 3], w: f32, scale: f32) {
        self.weight += w;
        self.sum = [self.sum[0] + c[0] * scale * w, self.sum[1] + c[1] * scale * w, self.sum[2] + c[2] * scale * w];
        self.lo = [self.lo[0].min(c[0]), self.lo[1].min(c[1]), self.lo[2].min(c[2])];
        self.hi = [self.hi[0].max(c[0]), self.hi[1].max(c[1]), self.hi[2].max(c[2])];
    }

    /// The weighted mean of a gather at scale 1.
    pub fn mean(&self) -> [f32; 3] {
        [self.sum[0] / self.weight, self.sum[1] / self.weight, self.sum[2] / self.weight]
    }

    /// The weighted mean of a gather at [`OVERFLOW_SCALE`], multiplied back. A mean of
    /// colours within a few units in the last place of `f32::MAX` can round past it; a
    /// weighted mean with non-negative weights lies between the smallest and the largest
    /// colour gathered, so it is held there (a correction of rounding only).
    pub fn rescaled_mean(&self) -> [f32; 3] {
        let m = self.mean();
        [
            (m[0] * OVERFLOW_UNSCALE).clamp(self.lo[0], self.hi[0]),
            (m[1] * OVERFLOW_UNSCALE).clamp(self.lo[1], self.hi[1]),
            (m[2] * OVERFLOW_UNSCALE).clamp(self.lo[2], self.hi[2]),
        ]
    }
}

/// `x` is NaN or infinite: an all-ones exponent (WGSL has no `isNan`, and comparisons with
/// NaN may be optimised away).
pub fn is_bad(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) == 0x7f80_0000
}

/// Any channel of `c` is NaN or infinite.
pub fn is_bad3(c: [f32; 3]) -> bool {
    is_bad(c[0]) || is_bad(c[1]) || is_bad(c[2])
}

/// `a . b`.
pub fn dot2(a: [f32; 2], b: [f32; 2]) -> f32 {
    a[0] * b[0] + a[1] * b[1]
}

/// `|v|`.
pub fn length2(v: [f32; 2]) -> f32 {
    dot2(v, v).sqrt()
}

/// `v * s`.
pub fn scale2(v: [f32; 2], s: f32) -> [f32; 2] {
    [v[0] * s, v[1] * s]
}

/// Hermite step from 0 at `e0` to 1 at `e1` (WGSL's `smoothstep`, spelt out).
pub fn smooth_step(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Weight of a sample at distance `dist` from a pixel blurred over radius `radius`: falls
/// linearly from 1 at 0 to 0 at `radius` (McGuire et al. 2012's cone).
pub fn cone(dist: f32, radius: f32) -> f32 {
    (1.0 - dist / radius).clamp(0.0, 1.0)
}

/// 1 within `radius` of the pixel, 0 beyond, with a smooth 10% transition (McGuire et al.
/// 2012's cylinder).
pub fn cylinder(dist: f32, radius: f32) -> f32 {
    1.0 - smooth_step(0.95 * radius, 1.05 * radius, dist)
}

/// McGuire et al. 2012's soft depth comparison for positive depths: 1 where `zb` is in front
/// of or level with `za`, falling to 0 where `zb` is `extent` (`1 / inv_extent`) or more
/// behind it.
///
/// The paper writes `clamp(1 - (za - zb) / extent)` for its negative (OpenGL camera-space)
/// z; with the positive depths of [`super::GBuffer`] the difference changes sign, so that
/// `soft_depth_compare(Z[X], Z[Y])` is still "Y is in front of X".
pub fn soft_depth_compare(za: f32, zb: f32, inv_extent: f32) -> f32 {
    (1.0 - (zb - za) * inv_extent).clamp(0.0, 1.0)
}

/// The smallest depth the relative comparison divides by (a micrometre): depth zero is a
/// valid input (a point on the eye) but not a valid divisor.
pub const Z_MIN: f32 = 1.0e-6;

/// Guertin et al. 2014's relative depth comparison for positive depths: 1 where `zb` is in
/// front of or level with `za`, falling to 0 where `zb` is twice as far (the transition
/// interval is the nearer depth, so the test does not depend on the scene's scale).
///
/// The paper's formula, `clamp(1 - (za - zb) / min(za, zb))` with `f = zCompare(Z[p], Z[S])`,
/// gives 0 for a foreground sample S in front of the background pixel p, the opposite of
/// its text (f is the weight of "objects moving over p"); the difference is taken the other
/// way round here, as for [`soft_depth_compare`]. Equal depths, zero included, give 1 without
/// dividing; the divisor is at least [`Z_MIN`].
pub fn z_compare(za: f32, zb: f32) -> f32 {
    let d = zb - za;
    if d <= 0.0 {
        return 1.0;
    }
    (1.0 - d / za.min(zb).max(Z_MIN)).clamp(0.0, 1.0)
}

/// PCG's output permutation as a hash (Jarzynski and Olano 2020, "Hash functions for GPU
/// rendering"): u32 only, so the WGSL computes the same bits.
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The top 24 bits of `h` as a number in [0, 1), exactly.
pub fn to_unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A hash of pixel (x, y) and `seed`.
pub fn pixel_hash(x: u32, y: u32, seed: u32) -> u32 {
    pcg_hash(x.wrapping_add(pcg_hash(y.wrapping_add(pcg_hash(seed)))))
}

/// McGuire et al. 2012's per-pixel jitter, in [-1/2, 1/2): a hash of the pixel and the seed.
pub fn hash_jitter(x: u32, y: u32, seed: u32) -> f32 {
    to_unit(pixel_hash(x, y, seed)) - 0.5
}

/// Guertin et al. 2014's per-pixel Halton jitter in [-1, 1): the base-2 Halton (van der
/// Corput) point of the pixel's row-major index, the sequence shifted by a hash of the seed,
/// so pixels along a row get evenly spread jitters.
pub fn halton_jitter(x: u32, y: u32, width: u32, seed: u32) -> f32 {
    let n = y.wrapping_mul(width).wrapping_add(x).wrapping_add(pcg_hash(seed));
    2.0 * to_unit(n.reverse_bits()) - 1.0
}

/// The random number in [0, 1) that decides Guertin's stochastic tile offset: a hash
/// independent of [`halton_jitter`] (the pseudocode reuses the sample jitter j, which would
/// tie the tile chosen to the direction the samples are shifted in).
pub fn tile_offset_random(x: u32, y: u32, seed: u32) -> f32 {
    to_unit(pixel_hash(x, y, seed ^ 0x9e37_79b9))
}

/// The index of pixel (x, y).
pub fn index(p: &PassParams, x: u32, y: u32) -> usize {
    y as usize * p.width as usize + x as usize
}

/// The index of tile (tx, ty).
pub fn tile_index(p: &PassParams, tx: u32, ty: u32) -> usize {
    ty as usize * p.tiles_x as usize + tx as usize
}

/// Pixel (x, y) moved by the rounded offset `o` (round half up, `floor(o + 0.5)`, the same
/// on both sides; WGSL's `round` rounds half to even, Rust's half away from zero) and
/// clamped into the image, as a clamp-to-edge texture read would.
pub fn offset_pixel(p: &PassParams, x: u32, y: u32, o: [f32; 2]) -> [u32; 2] {
    let sx = (x as f32 + (o[0] + 0.5).floor()).clamp(0.0, (p.width - 1) as f32);
    let sy = (y as f32 + (o[1] + 0.5).floor()).clamp(0.0, (p.height - 1) as f32);
    [sx as u32, sy as u32]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_comparisons_say_in_front_for_nearer_or_equal_samples() {
        assert_eq!(soft_depth_compare(10.0, 5.0, 10.0), 1.0);
        assert_eq!(soft_depth_compare(5.0, 10.0, 10.0), 0.0);
        assert!((soft_depth_compare(5.0, 5.05, 10.0) - 0.5).abs() < 1e-5);
        assert_eq!(z_compare(10.0, 5.0), 1.0);
        assert_eq!(z_compare(5.0, 10.0), 0.0);
        assert_eq!(z_compare(10.0, 15.0), 0.5);
        // Scale-free: 1000 and 1500 as 10 and 15.
        assert_eq!(z_compare(1000.0, 1500.0), 0.5);
        // Equal depths, zero included, and a zero depth against a positive one.
        for z in [0.0, 1.0, SKY_DEPTH_TEST] {
            assert_eq!(z_compare(z, z), 1.0);
        }
        assert_eq!(z_compare(0.0, 1.0), 0.0);
        assert_eq!(z_compare(1.0, 0.0), 1.0);
    }

    const SKY_DEPTH_TEST: f32 = super::super::SKY_DEPTH;

    #[test]
    fn jitters_stay_in_their_ranges_and_differ_between_pixels() {
        let mut seen = std::collections::HashSet::new();
        for y in 0..16 {
            for x in 0..16 {
                let j = halton_jitter(x, y, 16, 3);
                assert!((-1.0..1.0).contains(&j));
                seen.insert(j.to_bits());
                let h = hash_jitter(x, y, 3);
                assert!((-0.5..0.5).contains(&h));
            }
        }
        // 256 consecutive indices of the van der Corput sequence are 256 distinct points.
        assert_eq!(seen.len(), 256);
    }
}
