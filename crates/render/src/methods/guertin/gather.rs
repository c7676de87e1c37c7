//! Guertin et al. 2014's gather, the twin of `gather.wgsl` beside it (the paper's
//! appendix A with its text's sections 4.1-4.5 and 5).
//!
//! The pseudocode leaves out or gets wrong some details; each is resolved as the text
//! describes, and the code says so where it happens:
//!
//! 1. Depth comparison sign: see [`super::common::z_compare`].
//! 2. The centre direction: the pseudocode's `rnmix(w_p, norm(v_c), (|v_c| - 0.5) / gamma)`
//!    is kept (the perpendicular for still pixels, the pixel's direction from speed
//!    `0.5 + gamma` on, as the text says); the paper's equation 1 has its ends swapped, and
//!    the blend factor is clamped to [0, 1], which neither states.
//! 3. Where the second half of the samples goes: the pseudocode puts them at `t v_c`, which
//!    for a still pixel is the pixel itself (the "wasted" samples the text replaces by the
//!    perpendicular) and is inconsistent with the distance `T = t |v_max|` the weights use.
//!    Both sample sets lie along unit directions (w_n = norm(v_max), and the centre direction
//!    w_c) out to `|v_max|`, so every sample is |T| from the pixel before rounding (the
//!    weights then use the distance after rounding, 7).
//! 4. The velocity-aware factors use unit directions and absolute values,
//!    `wA = |w_c . d|`, `wB = |norm(v_s) . d|`: the pseudocode dots with the unscaled `d`
//!    (a length, not a direction cosine) and with signs, but a blur spans `+-v`, so a
//!    velocity and its negation smear alike, and a negative weight (opposite velocities
//!    meeting) would leave holes or divide by zero.
//! 5. Speeds are at least half a pixel wherever they divide (`|v_c|` in the centre weight
//!    `N / (kappa |v_c|)`, which is infinite for a still pixel otherwise, and the cones),
//!    as the pseudocode's comment says for `v_s`.
//! 6. The tile offset's random number is independent of the sample jitter (see
//!    [`super::common::tile_offset_random`]), and its fall-off is stated in
//!    [`stochastic_tile`].
//! 7. The weights use the distance to the pixel actually sampled (the rounded, edge-clamped
//!    position, as McGuire et al. 2012 do), not the unrounded `|T|`: with `|T|` a sample
//!    rounded to the next pixel at `|T|` in [0.5, 0.525) would get the cylinder weight of the
//!    pixel itself, leaking a moving background into a still one-pixel feature (the
//!    flagpole the paper's section 4.3 is about), and a sample clamped at the image's edge
//!    would be weighted for a distance it does not have.
//! 8. The jitter `j eta phi / N` exceeds one sample spacing for N < eta phi (about 26): kept
//!    as the paper states; samples then pushed past |t| = 1 lie beyond every blur radius and
//!    get (near) zero weight.
//!
//! As the text says (section 4.3), the sample nearest the pixel is not skipped (McGuire et
//! al. skip it), and the centre weight is `N / (kappa |v_c|)`. With
//! [`GuertinParams::tile_variance`] the samples are split by equation 2's variance (of the
//! NeighborMax directions, bilinearly interpolated as section 5 says), `upsilon N` along
//! the centre direction, evenly interleaved ([`along_centre`]); otherwise half and half (the
//! paper's setting for its results). The paper's second output, a luminance checkerboard to
//! steer a following FXAA pass (section 4.5), is not produced: there is no FXAA pass here.

use crate::methods::post_process::common::{
    Gathered, HALF_PIXEL, OVERFLOW_SCALE, PassParams, cone, cylinder, dot2, halton_jitter, index, is_bad, is_bad3,
    length2, offset_pixel, scale2, tile_index, tile_offset_random, z_compare,
};
use rayon::prelude::*;

use super::GuertinParams;
use crate::methods::post_process::{FilterError, GBuffer, check_gbuffer, tiles};

/// The tile whose NeighborMax pixel (x, y) reads (`soffset` of the paper, section 4.2): its
/// own, or with probability `max(0, 1/2 - tau d / r)` the neighbour across the nearer tile
/// border at distance d (pixel centre to border, in pixels), never a diagonal one. The
/// probability is 1/2 at the border itself, so the two tiles' velocities blend evenly there,
/// and with the paper's tau = 1 it falls linearly to 0 at the tile's centre. `u` in [0, 1)
/// decides. A neighbour outside the image is not taken.
pub fn stochastic_tile(p: &PassParams, x: u32, y: u32, u: f32) -> [u32; 2] {
    let tx = x / p.tile;
    let ty = y / p.tile;
    let r = p.tile as f32;
    let lx = (x - tx * p.tile) as f32 + 0.5;
    let ly = (y - ty * p.tile) as f32 + 0.5;
    let dx = lx.min(r - lx);
    let dy = ly.min(r - ly);
    let sx: i32 = if lx < r - lx { -1 } else { 1 };
    let sy: i32 = if ly < r - ly { -1 } else { 1 };
    let (d, step) = if dx <= dy { (dx, [sx, 0]) } else { (dy, [0, sy]) };
    let prob = (0.5 - p.tau * d * p.inv_tile).clamp(0.0, 0.5);
    if u >= prob {
        return [tx, ty];
    }
    let nx = tx as i32 + step[0];
    let ny = ty as i32 + step[1];
    if nx < 0 || ny < 0 || nx >= p.tiles_x as i32 || ny >= p.tiles_y as i32 {
        return [tx, ty];
    }
    [nx as u32, ny as u32]
}

/// The tile variance at pixel (x, y), bilinearly interpolated between tile centres (section
/// 5: nearest look-ups left tile borders visible), clamped at the image's edge tiles.
pub fn variance_at(p: &PassParams, variance: &[f32], x: u32, y: u32) -> f32 {
    let u = ((x as f32 + 0.5) * p.inv_tile - 0.5).clamp(0.0, (p.tiles_x - 1) as f32);
    let v = ((y as f32 + 0.5) * p.inv_tile - 0.5).clamp(0.0, (p.tiles_y - 1) as f32);
    let x0 = u.floor();
    let y0 = v.floor();
    let fx = u - x0;
    let fy = v - y0;
    let x0 = x0 as u32;
    let y0 = y0 as u32;
    let x1 = (x0 + 1).min(p.tiles_x - 1);
    let y1 = (y0 + 1).min(p.tiles_y - 1);
    let a = variance[tile_index(p, x0, y0)];
    let b = variance[tile_index(p, x1, y0)];
    let c = variance[tile_index(p, x0, y1)];
    let d = variance[tile_index(p, x1, y1)];
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    top + (bottom - top) * fy
}

/// Whether sample `i` goes along the centre direction when a fraction `share` of the samples
/// does: evenly interleaved (a Bresenham split), which for `share` = 1/2 is the
/// pseudocode's "odd samples".
pub fn along_centre(i: u32, share: f32) -> bool {
    ((i + 1) as f32 * share).floor() > (i as f32 * share).floor()
}

/// `normalize(a + (b - a) t)`.
fn mix_normalize(a: [f32; 2], b: [f32; 2], t: f32) -> [f32; 2] {
    let m = [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
    scale2(m, 1.0 / length2(m))
}

/// The gather of pixel (x, y): `color`, `depth` are the G-buffer's, `velocity` the encoded
/// one, `neighbor_max` the culled NeighborMax and `variance` the tile variance (read only
/// when `p.variance` is 1).
#[allow(clippy::too_many_arguments)]
pub fn guertin_gather_one(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    neighbor_max: &[[f32; 2]],
    variance: &[f32],
    x: u32,
    y: u32,
) -> [f32; 3] {
    let i = index(p, x, y);
    let cp = color[i];
    if is_bad3(cp) || is_bad(depth[i]) {
        return cp;
    }
    let j = halton_jitter(x, y, p.width, p.seed);
    let [tx, ty] = stochastic_tile(p, x, y, tile_offset_random(x, y, p.seed));
    let vmax = neighbor_max[tile_index(p, tx, ty)];
    let rmax = length2(vmax);
    if rmax <= HALF_PIXEL {
        return cp;
    }
    let wn = scale2(vmax, 1.0 / rmax);
    let vc = velocity[i];
    let lc = length2(vc);
    let mut wp = [-wn[1], wn[0]];
    if dot2(wp, vc) < 0.0 {
        wp = [-wp[0], -wp[1]];
    }
    // Fixes 2 and 5: norm(v_c) with the length at least 1/2, the blend clamped.
    let rc = lc.max(HALF_PIXEL);
    let nc = scale2(vc, 1.0 / rc);
    let wc = mix_normalize(wp, nc, ((lc - HALF_PIXEL) * p.inv_gamma).clamp(0.0, 1.0));
    let share = if p.variance != 0 { variance_at(p, variance, x, y) } else { 0.5 };
    let dirs = GuertinDirections { wn, wc, rmax, rc, share, jj: j * p.jitter_scale };
    let weigh = |scale: f32| guertin_weigh(p, color, depth, velocity, &dirs, x, y, scale);
    let mean = weigh(1.0).mean();
    if !is_bad3(mean) {
        return mean;
    }
    // Colours near `f32::MAX` overflowed the sums: see `OVERFLOW_SCALE`.
    weigh(OVERFLOW_SCALE).rescaled_mean()
}

/// What a pixel's gather needs from its NeighborMax and its own velocity: the WGSL struct
/// `Directions`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuertinDirections {
    /// The dominant direction, norm(v_max).
    pub wn: [f32; 2],
    /// The centre direction.
    pub wc: [f32; 2],
    /// |v_max|.
    pub rmax: f32,
    /// The pixel's speed, at least half a pixel.
    pub rc: f32,
    /// The share of the samples along the centre direction.
    pub share: f32,
    /// The pixel's jitter times eta phi / N.
    pub jj: f32,
}

/// The weighted sums of pixel (x, y)'s gather, every colour times `scale`: the WGSL
/// function `guertin_weigh`.
#[allow(clippy::too_many_arguments)]
pub fn guertin_weigh(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    dirs: &GuertinDirections,
    x: u32,
    y: u32,
    scale: f32,
) -> Gathered {
    let GuertinDirections { wn, wc, rmax, rc, share, jj } = *dirs;
    let i = index(p, x, y);
    let zp = depth[i];
    let nf = p.samples as f32;
    let mut g = Gathered::start(color[i], nf / (p.kappa * rc), scale);
    for s in 0..p.samples {
        // `s + 1` in integers, then one float addition: a compiler may reassociate
        // `s + jj + 1` (Mesa's does), and at 16 + jj one last-bit step moves a sample by
        // 2e-6 px, enough to cross to the next pixel now and then.
        let t = -1.0 + 2.0 * (((s + 1) as f32 + jj) * p.inv_samples_plus_one);
        // Fix 3: unit directions out to |v_max|.
        let d = if along_centre(s, share) { wc } else { wn };
        let tt = t * rmax;
        let [sx, sy] = offset_pixel(p, x, y, scale2(d, tt));
        let k = index(p, sx, sy);
        let cs = color[k];
        if is_bad3(cs) || is_bad(depth[k]) {
            continue;
        }
        let vs = velocity[k];
        let rs = length2(vs).max(HALF_PIXEL);
        let zs = depth[k];
        let f = z_compare(zp, zs);
        let b = z_compare(zs, zp);
        // Fix 4: direction cosines, unsigned.
        let wa = dot2(wc, d).abs();
        let wb = dot2(scale2(vs, 1.0 / rs), d).abs();
        // Fix 7: the distance to the pixel sampled.
        let o = [sx as f32 - x as f32, sy as f32 - y as f32];
        let dist = dot2(o, o).sqrt();
        let mut w = f * cone(dist, rs) * wb;
        w += b * cone(dist, rc) * wa;
        w += cylinder(dist, rs.min(rc)) * wa.max(wb) * 2.0;
        g.add(cs, w, scale);
    }
    g
}

/// Pass `guertin_gather` over the whole image (rows in parallel; each pixel's result does
/// not depend on the order).
pub fn guertin_gather(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    neighbor_max: &[[f32; 2]],
    variance: &[f32],
    out: &mut [[f32; 3]],
) {
    out.par_chunks_mut(p.width as usize).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            *o = guertin_gather_one(p, color, depth, velocity, neighbor_max, variance, x as u32, y as u32);
        }
    });
}

/// Guertin et al. 2014 on the CPU: every pass's twin in order. Panics on a bad G-buffer or
/// settings; [`try_guertin_cpu`] returns the error instead.
pub fn guertin_cpu(g: &GBuffer, params: &GuertinParams) -> Vec<[f32; 3]> {
    try_guertin_cpu(g, params).unwrap_or_else(|e| panic!("guertin_cpu: {e}"))
}

/// Guertin et al. 2014 on the CPU, refusing a bad G-buffer or settings.
pub fn try_guertin_cpu(g: &GBuffer, params: &GuertinParams) -> Result<Vec<[f32; 3]>, FilterError> {
    check_gbuffer(g)?;
    params.check()?;
    let p = params.pass_params(g);
    let t = tiles::run(&p, &g.velocity, true);
    let mut out = vec![[0.0; 3]; p.pixels()];
    guertin_gather(&p, &g.color, &g.depth, &t.velocity, &t.neighbor_max, &t.variance, &mut out);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_split_interleaves_the_share_evenly() {
        let along = |share: f32| (0..35).filter(|&i| along_centre(i, share)).collect::<Vec<u32>>();
        // Half and half: the pseudocode's odd samples.
        assert_eq!(along(0.5), (0..35).filter(|i| i % 2 == 1).collect::<Vec<u32>>());
        assert!(along(0.0).is_empty());
        assert_eq!(along(1.0).len(), 35);
        // A quarter: every fourth sample, 8 of 35.
        assert_eq!(along(0.25), vec![3, 7, 11, 15, 19, 23, 27, 31]);
    }

    #[test]
    fn the_variance_is_interpolated_between_tile_centres() {
        let p = PassParams::new(40, 20, 20, 1, 0);
        let variance = [0.0, 1.0];
        // Tile centres at x = 10 and 30 (pixel x's centre is x + 1/2); clamped beyond them.
        assert_eq!(variance_at(&p, &variance, 9, 0), 0.0);
        assert_eq!(variance_at(&p, &variance, 0, 0), 0.0);
        assert_eq!(variance_at(&p, &variance, 30, 0), 1.0);
        assert_eq!(variance_at(&p, &variance, 39, 19), 1.0);
        assert!((variance_at(&p, &variance, 19, 7) - 0.475).abs() < 1e-6);
        assert!((variance_at(&p, &variance, 20, 7) - 0.525).abs() < 1e-6);
    }
}
