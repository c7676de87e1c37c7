//! The environment's look-ups on all lanes: the twin's `texel_of`, `cell_density`,
//! `cdf_sample` and `env_sample` ([`crate::shading::gpu::radiance`]) with their table reads
//! as per-lane gathers and their searches as loops that run while any lane still moves.
//! A lane's result is the twin's, operation for operation.

use super::lanes::{F, M, U, V3};
use crate::shading::gpu::params::FrameParams;
use crate::shading::gpu::radiance::PI;

const CDF_STEP: f32 = 1.0 / 65535.0;

#[inline(always)]
fn env_f32(env: &[u32], index: U) -> F {
    let w = U::gather(env, index);
    let mut out = F::splat(0.0);
    for (o, w) in out.0.iter_mut().zip(w.0) {
        *o = f32::from_bits(w);
    }
    out
}

#[inline(always)]
fn env_u16(env: &[u32], offset: u32, i: U) -> U {
    U::gather(env, U::splat(offset).wrapping_add(i.shr(1))).shr_each(i.and(U::splat(1)).shl(4)).and(U::splat(0xffff))
}

/// The texels of `index` (RGB).
#[inline(always)]
pub(crate) fn env_texel(env: &[u32], index: U) -> V3 {
    let i3 = index.wrapping_mul(U::splat(3));
    V3 {
        x: env_f32(env, i3),
        y: env_f32(env, i3.wrapping_add(U::splat(1))),
        z: env_f32(env, i3.wrapping_add(U::splat(2))),
    }
}

#[inline(always)]
fn pseudo_angle(a: F, b: F) -> F {
    let zero = F::splat(0.0);
    let sum = a.abs() + b.abs();
    let r = a / sum;
    let upper = a.ge(zero).select(r, F::splat(4.0) + r);
    let v = b.ge(zero).select(upper, F::splat(2.0) - r);
    sum.eq(zero).select(zero, v)
}

#[inline(always)]
fn col_after(p: &FrameParams, env: &[u32], m: V3, j: U) -> M {
    let at = U::splat(p.off_col_edge).wrapping_add(j.shl(1));
    let s = env_f32(env, at);
    let c = env_f32(env, at.wrapping_add(U::splat(1)));
    (m.x * c + m.z * s).ge(F::splat(0.0))
}

/// The texel each lane's direction falls in: (index, cell x, cell y, sin theta).
#[inline(always)]
pub(crate) fn texel_of(p: &FrameParams, env: &[u32], d: V3, lanes: M) -> (U, U, U, F) {
    let (rc, rs) = (F::splat(p.env_rot_cos), F::splat(p.env_rot_sin));
    let m = V3 { x: rc * d.x - rs * d.z, y: d.y, z: rs * d.x + rc * d.z };
    let inv_len = F::splat(1.0) / m.dot(m).sqrt();
    let cos_theta = (m.y * inv_len).clamp(-1.0, 1.0);
    let sin_theta = (m.x * m.x + m.z * m.z).sqrt() * inv_len;
    let (w, h) = (p.env_width, p.env_height);
    let bins = 16 * h;
    let k = ((F::splat(1.0) - cos_theta) * F::splat(0.5 * bins as f32)).to_u32_below_2_31().min(U::splat(bins - 1));
    let mut y = U::gather(env, U::splat(p.off_row_bins).wrapping_add(k));
    let one = U::splat(1);
    let mut moving = lanes;
    while moving.any() {
        let next = y.wrapping_add(one);
        moving =
            moving & next.lt(U::splat(h)) & cos_theta.le(env_f32(env, U::splat(p.off_row_edge_cos).wrapping_add(next)));
        y = moving.select_u(next, y);
    }
    moving = lanes;
    while moving.any() {
        moving = moving & y.gt(U::splat(0)) & cos_theta.gt(env_f32(env, U::splat(p.off_row_edge_cos).wrapping_add(y)));
        y = moving.select_u(y.wrapping_sub(one), y);
    }
    let bins = 4 * w;
    let k = (pseudo_angle(m.x, -m.z) * F::splat(0.25 * bins as f32)).to_u32_below_2_31().min(U::splat(bins - 1));
    let mut x = U::gather(env, U::splat(p.off_col_bins).wrapping_add(k));
    let mut searching = lanes;
    for _ in 0..4 {
        if !searching.any() {
            break;
        }
        let back = searching & !col_after(p, env, m, x);
        let forward = searching & !back & col_after(p, env, m, x.wrapping_add(one));
        let prev = x.eq(U::splat(0)).select_u(U::splat(w - 1), x.wrapping_sub(one));
        let next = x.wrapping_add(one).eq(U::splat(w)).select_u(U::splat(0), x.wrapping_add(one));
        x = back.select_u(prev, forward.select_u(next, x));
        searching = back | forward;
    }
    let shift = p.env_cell_shift;
    (y.wrapping_mul(U::splat(w)).wrapping_add(x), x.shr(shift), y.shr(shift), sin_theta)
}

/// The light-sampling density of each lane's cell.
#[inline(always)]
pub(crate) fn cell_density(p: &FrameParams, env: &[u32], x: U, y: U) -> F {
    if p.env_samplable == 0 {
        return F::splat(0.0);
    }
    let m = p.off_marginal;
    let row_cdf = U::splat(p.marginal_guide_len).wrapping_add(y);
    let p_row = env_u16(env, m, row_cdf.wrapping_add(U::splat(1))).wrapping_sub(env_u16(env, m, row_cdf)).to_f32()
        * F::splat(CDF_STEP);
    let base = y.wrapping_mul(U::splat(p.rows_stride)).wrapping_add(U::splat(p.rows_guide_len)).wrapping_add(x);
    let p_col =
        env_u16(env, p.off_rows, base.wrapping_add(U::splat(1))).wrapping_sub(env_u16(env, p.off_rows, base)).to_f32()
            * F::splat(CDF_STEP);
    p_row * p_col * F::splat((p.env_dist_width * p.env_dist_height) as f32)
}

/// Inverts distribution `row` of a 16-bit table at `u`, per lane: (cell, position in the
/// cell, probability).
#[inline(always)]
fn cdf_sample(
    env: &[u32],
    offset: u32,
    row: U,
    (guide_len, guide_shift, stride): (u32, u32, u32),
    width: u32,
    u: F,
    lanes: M,
) -> (U, F, F) {
    let one = U::splat(1);
    let base = row.wrapping_mul(U::splat(stride));
    let t = u * F::splat(65535.0);
    let ti = t.to_u32_below_2_31().min(U::splat(65534));
    let k = ti.shr(guide_shift);
    let mut x = env_u16(env, offset, base.wrapping_add(k));
    let k1 = k.wrapping_add(one);
    let mut hi = k1.lt(U::splat(guide_len)).select_u(env_u16(env, offset, base.wrapping_add(k1)), U::splat(width - 1));
    let cdf = base.wrapping_add(U::splat(guide_len));
    // The twin walks forward from the guide's cell to the first `x < hi` whose cell ends
    // past `ti` (or to `hi`). The cumulative table never decreases, so "ends past `ti`" is
    // false then true along the walk, and bisecting `[x, hi]` finds the same cell. A walk
    // costs the longest of the lanes' spans, a bisection its logarithm: in a dark part of
    // the map one guide entry spans dozens of cells.
    let mut moving = lanes & x.lt(hi);
    while moving.any() {
        let mid = x.wrapping_add(hi).shr(1);
        let before = env_u16(env, offset, cdf.wrapping_add(mid).wrapping_add(one)).le(ti);
        x = (moving & before).select_u(mid.wrapping_add(one), x);
        hi = (moving & !before).select_u(mid, hi);
        moving = moving & x.lt(hi);
    }
    let lo = env_u16(env, offset, cdf.wrapping_add(x));
    let start = lo.to_f32();
    let cell = env_u16(env, offset, cdf.wrapping_add(x).wrapping_add(one)).wrapping_sub(lo).to_f32();
    let f = ((t - start) / cell).clamp(0.0, 1.0 - f32::EPSILON);
    (x, f, cell * F::splat(CDF_STEP))
}

/// A light sample per lane: (world direction, density over map coordinates, jacobian,
/// texel); density 0 where there is none.
#[inline(always)]
pub(crate) fn env_sample(p: &FrameParams, env: &[u32], u: [F; 2], lanes: M) -> (V3, F, F, U) {
    let zero = F::splat(0.0);
    if p.env_samplable == 0 {
        return (V3 { x: zero, y: zero, z: zero }, zero, zero, U::splat(0));
    }
    let (wd, hd) = (p.env_dist_width, p.env_dist_height);
    let marginal = (p.marginal_guide_len, p.marginal_guide_shift, p.marginal_stride);
    let rows = (p.rows_guide_len, p.rows_guide_shift, p.rows_stride);
    let (y, fy, p_y) = cdf_sample(env, p.off_marginal, U::splat(0), marginal, hd, u[0], lanes);
    let (x, fx, p_x) = cdf_sample(env, p.off_rows, y, rows, wd, u[1], lanes);
    let density = p_y * p_x * F::splat((wd * hd) as f32);
    let (sin_theta, cos_theta) = super::packet::sin_cos_turns(F::splat(0.5) * (y.to_f32() + fy) / F::splat(hd as f32));
    let (sin_phi, cos_phi) = super::packet::sin_cos_turns((x.to_f32() + fx) / F::splat(wd as f32));
    let valid = density.gt(zero) & sin_theta.gt(zero);
    let f = 1u32 << p.env_cell_shift;
    let (px, py) = (cell_texel(x, fx, f), cell_texel(y, fy, f));
    let m = V3 { x: sin_phi * sin_theta, y: cos_theta, z: -cos_phi * sin_theta };
    let (rc, rs) = (F::splat(p.env_rot_cos), F::splat(p.env_rot_sin));
    let world = V3 { x: rc * m.x + rs * m.z, y: m.y, z: -rs * m.x + rc * m.z };
    let texel = py.wrapping_mul(U::splat(p.env_width)).wrapping_add(px);
    (world, valid.select(density, zero), F::splat(2.0 * PI * PI) * sin_theta, texel)
}

/// The texel of position `c + fc` of a distribution cell `f` texels wide:
/// `(((c + fc) f) as u32).clamp(c f, c f + f - 1)`.
#[inline(always)]
fn cell_texel(c: U, fc: F, f: u32) -> U {
    let lo = c.wrapping_mul(U::splat(f));
    let v = ((c.to_f32() + fc) * F::splat(f as f32)).to_u32_below_2_31();
    let v = lo.gt(v).select_u(lo, v);
    v.min(lo.wrapping_add(U::splat(f - 1)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::EnvironmentMap;
    use crate::io::LinearImage;
    use crate::shading::gpu::params::EnvTables;
    use crate::shading::gpu::radiance;

    /// A map whose light distribution has every shape the inversion meets: a sun of a few
    /// texels holding nearly all the weight (so one guide entry spans dozens of dim cells),
    /// a black band (runs of equal cumulative entries), a dim gradient and a bright row.
    fn hard_map() -> EnvironmentMap {
        let (w, h) = (512u32, 256u32);
        let mut pixels = vec![[0.0f32; 3]; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let v = if (40..44).contains(&y) && (300..303).contains(&x) {
                    5.0e4
                } else if (100..160).contains(&y) || (200..260).contains(&x) {
                    0.0
                } else if y == 20 {
                    30.0
                } else {
                    0.01 + 0.002 * (x % 37) as f32
                };
                pixels[(y * w + x) as usize] = [v, v * 0.8, v * 0.6];
            }
        }
        EnvironmentMap::from_image(&LinearImage { width: w, height: h, pixels }, 1.0, 0.3, "hard map").unwrap()
    }

    #[test]
    fn bisected_light_samples_are_the_twins_walked_ones() {
        let design = study::design::Design::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
        )
        .unwrap();
        let scene = design.frame_scene(&"M3-S3-T5-A1".parse().unwrap(), 10).unwrap();
        let tables = EnvTables::new(&hard_map());
        let p = FrameParams::new(&scene, &scene.views[0], &tables).unwrap();
        let words = &tables.words;
        // Edges of the unit square, then a low-discrepancy sweep of it.
        let mut us: Vec<[f32; 2]> = vec![[0.0, 0.0], [1.0 - f32::EPSILON, 1.0 - f32::EPSILON], [0.5, 0.0]];
        for i in 0..20_000u32 {
            us.push([(i as f32 + 0.5) / 20_000.0, (i.wrapping_mul(2_654_435_769) >> 8) as f32 / 16_777_216.0]);
        }
        let mut longest_walk = 0;
        for chunk in us.chunks(16) {
            let mut u = [F::splat(0.0), F::splat(0.0)];
            for (i, v) in chunk.iter().enumerate() {
                u[0].0[i] = v[0];
                u[1].0[i] = v[1];
            }
            let (dir, density, jacobian, texel) = env_sample(&p, words, u, M::first(chunk.len() as u32));
            for (i, v) in chunk.iter().enumerate() {
                let (d, dens, jac, tex) = radiance::env_sample(&p, words, *v);
                assert_eq!(
                    (
                        dir.lane(i).to_array().map(f32::to_bits),
                        density.0[i].to_bits(),
                        jacobian.0[i].to_bits(),
                        texel.0[i]
                    ),
                    (d.to_array().map(f32::to_bits), dens.to_bits(), jac.to_bits(), tex),
                    "u = {v:?}"
                );
            }
        }
        // The map must give the walk long spans, or the test would not test the bisection.
        let rows = (p.rows_guide_len, p.rows_guide_shift, p.rows_stride);
        for y in 0..p.env_dist_height {
            for k in 0..rows.0.saturating_sub(1) {
                let base = y * rows.2;
                let g = |i: u32| (words[(p.off_rows + (base + i) / 2) as usize] >> (16 * ((base + i) & 1))) & 0xffff;
                longest_walk = longest_walk.max(g(k + 1) - g(k));
            }
        }
        assert!(longest_walk >= 32, "the longest guide span is only {longest_walk} cells");
    }
}
