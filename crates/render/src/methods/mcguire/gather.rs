//! McGuire et al. 2012's gather, the twin of `gather.wgsl` beside it: each pixel
//! takes N jittered samples along its tile neighbourhood's dominant (NeighborMax) velocity
//! and weights them by the three cases of the paper: a sample in front blurring over the
//! pixel (its cone), the pixel's own blur revealing what is behind it (the pixel's cone),
//! and both moving (the product of cylinders, twice).

use crate::methods::post_process::common::{
    Gathered, HALF_PIXEL, OVERFLOW_SCALE, PassParams, cone, cylinder, dot2, hash_jitter, index, is_bad, is_bad3,
    length2, offset_pixel, soft_depth_compare, tile_index,
};
use rayon::prelude::*;

use super::McGuireParams;
use crate::methods::post_process::{FilterError, GBuffer, check_gbuffer, tiles};

/// The gather of pixel (x, y): `color`, `depth` are the G-buffer's, `velocity` the encoded
/// one and `neighbor_max` the plain NeighborMax. A pixel whose weighted mean overflows
/// (colours near `f32::MAX`) is gathered again at [`OVERFLOW_SCALE`] (see there).
pub fn mcguire_gather_one(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    neighbor_max: &[[f32; 2]],
    x: u32,
    y: u32,
) -> [f32; 3] {
    let i = index(p, x, y);
    let cx = color[i];
    if is_bad3(cx) || is_bad(depth[i]) {
        return cx;
    }
    let vn = neighbor_max[tile_index(p, x / p.tile, y / p.tile)];
    if length2(vn) <= HALF_PIXEL {
        return cx;
    }
    let weigh = |scale: f32| mcguire_weigh(p, color, depth, velocity, vn, x, y, scale);
    let mean = weigh(1.0).mean();
    if !is_bad3(mean) {
        return mean;
    }
    weigh(OVERFLOW_SCALE).rescaled_mean()
}

/// The weighted sums of pixel (x, y)'s gather along `vn` (its tile's NeighborMax), every
/// colour times `scale`: the WGSL function `mcguire_weigh`.
#[allow(clippy::too_many_arguments)]
pub fn mcguire_weigh(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    vn: [f32; 2],
    x: u32,
    y: u32,
    scale: f32,
) -> Gathered {
    let i = index(p, x, y);
    let zx = depth[i];
    let rx = length2(velocity[i]).max(HALF_PIXEL);
    let mut g = Gathered::start(color[i], 1.0 / rx, scale);
    let j = hash_jitter(x, y, p.seed);
    let n = p.samples;
    // The paper skips the sample nearest t = 0: the pixel itself, already in `g`.
    let centre = (n - 1) / 2;
    for s in 0..n {
        if s == centre && n > 1 {
            continue;
        }
        // `s + 1` in integers, then one float addition: a compiler may reassociate
        // `s + j + 1` (Mesa's does), and at 16 + j one last-bit step moves a sample by
        // 2e-6 px, enough to cross to the next pixel now and then.
        let t = -1.0 + 2.0 * (((s + 1) as f32 + j) * p.inv_samples_plus_one);
        let [sx, sy] = offset_pixel(p, x, y, [vn[0] * t, vn[1] * t]);
        let k = index(p, sx, sy);
        let cy = color[k];
        if is_bad3(cy) || is_bad(depth[k]) {
            continue;
        }
        let d = [sx as f32 - x as f32, sy as f32 - y as f32];
        let dist = dot2(d, d).sqrt();
        let zy = depth[k];
        let ry = length2(velocity[k]).max(HALF_PIXEL);
        let f = soft_depth_compare(zx, zy, p.inv_soft_z_extent);
        let b = soft_depth_compare(zy, zx, p.inv_soft_z_extent);
        let a = f * cone(dist, ry) + b * cone(dist, rx) + cylinder(dist, ry) * cylinder(dist, rx) * 2.0;
        g.add(cy, a, scale);
    }
    g
}

/// Pass `mcguire_gather` over the whole image (rows in parallel; each pixel's result does
/// not depend on the order).
pub fn mcguire_gather(
    p: &PassParams,
    color: &[[f32; 3]],
    depth: &[f32],
    velocity: &[[f32; 2]],
    neighbor_max: &[[f32; 2]],
    out: &mut [[f32; 3]],
) {
    out.par_chunks_mut(p.width as usize).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            *o = mcguire_gather_one(p, color, depth, velocity, neighbor_max, x as u32, y as u32);
        }
    });
}

/// McGuire et al. 2012 on the CPU: every pass's twin in order. Panics on a bad G-buffer or
/// settings; [`try_mcguire_cpu`] returns the error instead.
pub fn mcguire_cpu(g: &GBuffer, params: &McGuireParams) -> Vec<[f32; 3]> {
    try_mcguire_cpu(g, params).unwrap_or_else(|e| panic!("mcguire_cpu: {e}"))
}

/// McGuire et al. 2012 on the CPU, refusing a bad G-buffer or settings.
pub fn try_mcguire_cpu(g: &GBuffer, params: &McGuireParams) -> Result<Vec<[f32; 3]>, FilterError> {
    check_gbuffer(g)?;
    params.check()?;
    let p = params.pass_params(g);
    let t = tiles::run(&p, &g.velocity, false);
    let mut out = vec![[0.0; 3]; p.pixels()];
    mcguire_gather(&p, &g.color, &g.depth, &t.velocity, &t.neighbor_max, &mut out);
    Ok(out)
}
