//! The CPU twin of `analytic_pixel.wgsl`, in f32: [`analytic_pixel`] is the kernel's entry
//! point for one pixel, and every WGSL function has a Rust function of the same name with
//! the same operations in the same order (the tracer's integrator is its own twin,
//! `crate::shading::gpu::radiance::radiance_from`). The interval list is a `Vec` instead of a
//! slice of the storage buffer; its length never exceeds the budget plus one, as there.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3};

use super::prepare::{ANALYTIC_STREAM, GpuInterval, GpuTriangle, PixelStats, Prepared, RasterParams};
use crate::io::LinearImage;
use crate::methods::analytic::interval::ORACLE_H;
use crate::numeric::solve_quadratic_f32;
use crate::shading::gpu::params::{FrameParams, Specialisation, material_kind};
use crate::shading::gpu::radiance::{
    FLOOR, Hit, SPHERE, SphereAt, cross3, dot3, env_texel, intersect_sphere, is_finite3, normalize3, radiance_from,
    sin_cos_turns, texel_of, xyz,
};
use crate::shading::gpu::sampler32::pixel_seed;

/// Disjoint visibility spans of one triangle at most.
pub const MAX_SPANS: usize = 8;

/// What the kernel reads besides the prepared view: the environment words and its
/// specialisation (`TIME_SAMPLING`, `MATERIAL`, `SHADE`).
#[derive(Clone, Copy, Debug)]
pub struct Kernel<'a> {
    /// The view.
    pub prepared: &'a Prepared,
    /// The environment tables' words.
    pub env: &'a [u32],
    /// The tracer's specialisation.
    pub spec: Specialisation,
    /// Radiance (true) or coverage (false: the sphere's in red, the floor's in green).
    pub shade: bool,
}

fn edge_coeff(tri: &GpuTriangle, k: usize, j: usize) -> Vec3 {
    xyz(tri.edges[k][j])
}

fn dot_s(c: Vec3, s: Vec2) -> f32 {
    c.x * s.x + c.y * s.y + c.z
}

/// `(alpha, beta, gamma)` of edge `k` at `s`.
fn edge_equation(tri: &GpuTriangle, k: usize, s: Vec2) -> Vec3 {
    Vec3::new(dot_s(edge_coeff(tri, k, 2), s), dot_s(edge_coeff(tri, k, 1), s), dot_s(edge_coeff(tri, k, 0), s))
}

fn eval_q(q: Vec3, t: f32) -> f32 {
    (q.x * t + q.y) * t + q.z
}

fn vertex_at(tri: &GpuTriangle, i: usize, t: f32) -> Vec3 {
    xyz(tri.base[i]) + xyz(tri.motion[i]) * t
}

fn det_at(tri: &GpuTriangle, t: f32) -> f32 {
    dot3(vertex_at(tri, 0, t), cross3(vertex_at(tri, 1, t), vertex_at(tri, 2, t)))
}

/// The exact (f32) view depth at `s` and `t`.
pub fn depth_at_time(tri: &GpuTriangle, s: Vec2, t: f32) -> f32 {
    let sum =
        eval_q(edge_equation(tri, 0, s), t) + eval_q(edge_equation(tri, 1, s), t) + eval_q(edge_equation(tri, 2, s), t);
    det_at(tri, t) / sum
}

fn is_finite1(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) != 0x7f80_0000
}

fn edge_inside(tri: &GpuTriangle, k: usize, s: Vec2, t: f32, sign: f32) -> bool {
    let v = eval_q(edge_equation(tri, k, s), t) * sign;
    if v != 0.0 {
        return v > 0.0;
    }
    let n = (edge_coeff(tri, k, 0) + edge_coeff(tri, k, 1) * t + edge_coeff(tri, k, 2) * (t * t)) * sign;
    n.x > 0.0 || (n.x == 0.0 && n.y > 0.0)
}

fn inside(tri: &GpuTriangle, s: Vec2, t: f32, sign: f32) -> bool {
    det_at(tri, t) * sign > 0.0
        && edge_inside(tri, 0, s, t, sign)
        && edge_inside(tri, 1, s, t, sign)
        && edge_inside(tri, 2, s, t, sign)
}

fn inside_any(tri: &GpuTriangle, s: Vec2, t: f32) -> bool {
    inside(tri, s, t, 1.0) || (tri.flags[1] != 0 && inside(tri, s, t, -1.0))
}

/// Visibility spans of one triangle at one sample point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spans {
    /// `(start, end)`, ascending.
    pub t: [(f32, f32); MAX_SPANS],
    /// How many.
    pub n: usize,
}

fn push_span(v: &mut Spans, a: f32, b: f32) {
    let n = v.n;
    if n > 0 && v.t[n - 1].1 == a {
        v.t[n - 1].1 = b;
    } else if n < MAX_SPANS {
        v.t[n] = (a, b);
        v.n = n + 1;
    }
}

/// Appends the roots of `q` in (0, 1), ascending, a double root once.
fn add_roots(q: Vec3, cuts: &mut [f32; 16], n: &mut usize) {
    let Some((r0, r1)) = solve_quadratic_f32(q.x, q.y, q.z) else { return };
    let first = r0 > 0.0 && r0 < 1.0;
    if first {
        cuts[*n] = r0;
        *n += 1;
    }
    if r1 > 0.0 && r1 < 1.0 && !(first && r1 == r0) {
        cuts[*n] = r1;
        *n += 1;
    }
}

/// Whether `q` is below zero on all of [0, 1] by more than its evaluation's rounding (a
/// margin of 1e-5 of its coefficients' size).
fn negative_throughout(q: Vec3) -> bool {
    let margin = 1e-5 * (q.x.abs() + q.y.abs() + q.z.abs());
    let mut max = q.z.max(q.x + q.y + q.z);
    if q.x < 0.0 {
        let t = -q.y / (2.0 * q.x);
        if t > 0.0 && t < 1.0 {
            max = max.max(eval_q(q, t));
        }
    }
    max < -margin
}

/// The visibility function of `tri` at `s` (edge.rs's `visibility` in f32).
pub fn visibility(tri: &GpuTriangle, s: Vec2) -> Spans {
    let mut vis = Spans::default();
    if tri.flags[1] == 0
        && (negative_throughout(edge_equation(tri, 0, s))
            || negative_throughout(edge_equation(tri, 1, s))
            || negative_throughout(edge_equation(tri, 2, s)))
    {
        return vis;
    }
    if tri.flags[2] != 0 {
        if inside_any(tri, s, 0.5) {
            push_span(&mut vis, 0.0, 1.0);
        }
        return vis;
    }
    let mut cuts = [0.0f32; 16];
    let mut n = 1;
    for k in 0..3 {
        add_roots(edge_equation(tri, k, s), &mut cuts, &mut n);
    }
    cuts[n] = 1.0;
    n += 1;
    for i in 1..n {
        let v = cuts[i];
        let mut j = i;
        while j > 0 && cuts[j - 1] > v {
            cuts[j] = cuts[j - 1];
            j -= 1;
        }
        cuts[j] = v;
    }
    let mut all = [0.0f32; 16];
    let mut m = 0;
    for w in 0..n {
        if w > 0 {
            let (a, b) = (cuts[w - 1], cuts[w]);
            let (da, db) = (det_at(tri, a), det_at(tri, b));
            if b > a && da * db < 0.0 && m < 15 {
                let (mut lo, mut hi) = (a, b);
                for _ in 0..64 {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    if (det_at(tri, mid) < 0.0) == (da < 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                all[m] = hi;
                m += 1;
            }
        }
        if m < 16 {
            all[m] = cuts[w];
            m += 1;
        }
    }
    for w in 1..m {
        let (a, b) = (all[w - 1], all[w]);
        if b <= a {
            continue;
        }
        if inside_any(tri, s, 0.5 * (a + b)) {
            push_span(&mut vis, a, b);
        }
    }
    vis
}

/// Depth at `ts` and the secant slope over `[ts, te]`.
pub fn linear_depth(tri: &GpuTriangle, s: Vec2, ts: f32, te: f32) -> (f32, f32) {
    let mid = depth_at_time(tri, s, 0.5 * (ts + te));
    let mut z0 = depth_at_time(tri, s, ts);
    let mut z1 = depth_at_time(tri, s, te);
    if !is_finite1(z0) {
        z0 = mid;
    }
    if !is_finite1(z1) {
        z1 = mid;
    }
    if te > ts { (z0, (z1 - z0) / (te - ts)) } else { (z0, 0.0) }
}

fn iv_depth(iv: &GpuInterval, t: f32) -> f32 {
    iv.z + iv.k * (t - iv.ts)
}

fn iv_clipped(iv: &GpuInterval, ts: f32, te: f32) -> GpuInterval {
    GpuInterval { z: iv_depth(iv, ts), ts, te, ..*iv }
}

fn nearer(front: &GpuInterval, back: &GpuInterval, t0: f32, t1: f32) -> bool {
    iv_depth(front, t0) < iv_depth(back, t0) && iv_depth(front, t1) < iv_depth(back, t1)
}

/// Eq. 19 in f32.
pub fn oracle(a: &GpuInterval, b: &GpuInterval) -> f32 {
    let h = ORACLE_H.map(|v| v as f32);
    let z_end = a.z + a.k * (a.te - a.ts);
    let dc = (a.r - b.r).abs() + (a.g - b.g).abs() + (a.b - b.b).abs();
    h[0] * (b.ts - a.te).max(0.0)
        + h[1] * (z_end - b.z).abs()
        + h[2] * (a.k - b.k).abs()
        + h[3] * ((a.te - a.ts) + (b.te - b.ts))
        + h[4] * dc
}

/// Eq. 20 in f32.
pub fn merge(a: &GpuInterval, b: &GpuInterval) -> GpuInterval {
    let total = (a.te - a.ts) + (b.te - b.ts);
    let w = if total > 0.0 { (b.te - b.ts) / total } else { 0.5 };
    let u = 1.0 - w;
    GpuInterval {
        ts: a.ts,
        te: a.te.max(b.te),
        z: u * a.z + w * (b.z - b.k * (b.ts - a.ts)),
        k: u * a.k + w * b.k,
        r: u * a.r + w * b.r,
        g: u * a.g + w * b.g,
        b: u * a.b + w * b.b,
        pad: 0.0,
    }
}

/// The opaque `LESS_EQUAL` rules: the clipped interval, or an empty one when it is hidden;
/// removes the entries it hides.
pub fn insert_opaque_clip(list: &mut Vec<GpuInterval>, new_iv: GpuInterval) -> GpuInterval {
    let mut iv = new_iv;
    for e in list.iter() {
        if iv.te <= iv.ts {
            break;
        }
        if e.ts <= iv.ts && e.te >= iv.te && nearer(e, &iv, iv.ts, iv.te) {
            iv.te = iv.ts;
            return iv;
        }
        if e.ts <= iv.ts && e.te > iv.ts && e.te < iv.te && nearer(e, &iv, iv.ts, e.te) {
            iv = iv_clipped(&iv, e.te, iv.te);
        } else if e.ts > iv.ts && e.ts < iv.te && e.te >= iv.te && nearer(e, &iv, e.ts, iv.te) {
            iv = iv_clipped(&iv, iv.ts, e.ts);
        }
    }
    if iv.te <= iv.ts {
        return iv;
    }
    list.retain(|e| {
        let hidden = iv.ts <= e.ts
            && iv.te >= e.te
            && iv_depth(&iv, e.ts) <= iv_depth(e, e.ts)
            && iv_depth(&iv, e.te) <= iv_depth(e, e.te);
        !hidden
    });
    iv
}

/// Inserts `iv` after the entries with the same or an earlier start.
pub fn insert_sorted(list: &mut Vec<GpuInterval>, iv: GpuInterval) {
    let mut at = list.len();
    while at > 0 && list[at - 1].ts > iv.ts {
        at -= 1;
    }
    list.insert(at, iv);
}

/// Merges the lowest-oracle pair until `list` holds at most `budget` entries.
pub fn compress(list: &mut Vec<GpuInterval>, budget: u32, range: u32) -> u32 {
    let mut merges = 0;
    while list.len() > budget as usize {
        let n = list.len();
        let (mut best, mut bi, mut bj) = (f32::MAX, 0, 1);
        for i in 0..n {
            for j in i + 1..(i + 1 + range as usize).min(n) {
                let o = oracle(&list[i], &list[j]);
                if o < best {
                    best = o;
                    bi = i;
                    bj = j;
                }
            }
        }
        list[bi] = merge(&list[bi], &list[bj]);
        list.remove(bj);
        merges += 1;
    }
    merges
}

/// Each entry's share of the shutter where it is the nearest: `(radiance, coverage)`.
pub fn resolve(list: &[GpuInterval]) -> ([f32; 3], f32) {
    let mut sum = Vec3::ZERO;
    let mut covered = 0.0f32;
    let mut hidden: Vec<(f32, f32)> = Vec::with_capacity(list.len());
    for (i, a) in list.iter().enumerate() {
        if a.te <= a.ts {
            continue;
        }
        hidden.clear();
        for (j, b) in list.iter().enumerate() {
            if j == i {
                continue;
            }
            let (lo, hi) = (a.ts.max(b.ts), a.te.min(b.te));
            if !(hi > lo) {
                continue;
            }
            let d0 = iv_depth(b, lo) - iv_depth(a, lo);
            let d1 = iv_depth(b, hi) - iv_depth(a, hi);
            let h0 = d0 < 0.0 || (d0 == 0.0 && j > i);
            let h1 = d1 < 0.0 || (d1 == 0.0 && j > i);
            let span = if h0 && h1 {
                (lo, hi)
            } else if h0 || h1 {
                let x = (lo + (hi - lo) * (d0 / (d0 - d1))).clamp(lo, hi);
                if h0 { (lo, x) } else { (x, hi) }
            } else {
                continue;
            };
            let mut at = hidden.len();
            while at > 0 && hidden[at - 1].0 > span.0 {
                at -= 1;
            }
            hidden.insert(at, span);
        }
        let mut gone = 0.0f32;
        let mut cur = (0.0f32, 0.0f32);
        let mut open = false;
        for &sp in &hidden {
            if open && sp.0 <= cur.1 {
                cur.1 = cur.1.max(sp.1);
            } else {
                if open {
                    gone += cur.1 - cur.0;
                }
                cur = sp;
                open = true;
            }
        }
        if open {
            gone += cur.1 - cur.0;
        }
        let seen = ((a.te - a.ts) - gone).max(0.0);
        sum += seen * Vec3::new(a.r, a.g, a.b);
        covered += seen;
    }
    (sum.to_array(), covered)
}

fn sphere_straight(p: &FrameParams, spec: &Specialisation, u: f32) -> SphereAt {
    let mut s = SphereAt { centre: xyz(p.centre_open), radius: p.centre_open[3], spin_sc: (0.0, 1.0) };
    if spec.time_sampling {
        s.centre += xyz(p.travel) * u;
        if spec.material != material_kind::FLAT {
            s.spin_sc = sin_cos_turns(-p.spin[3] * u / std::f32::consts::TAU);
        }
    }
    s
}

fn camera_ray(ap: &RasterParams, s: Vec2) -> Vec3 {
    xyz(ap.forward) + xyz(ap.right) * s.x + xyz(ap.up) * s.y
}

/// Where an interval is shaded (`ShadePoint` in WGSL): the sphere at the interval's midpoint,
/// the hit on the interval's surface, the camera ray's direction.
struct ShadePoint {
    sphere: SphereAt,
    hit: Hit,
    dir: Vec3,
}

fn shade_point(k: &Kernel<'_>, tri: &GpuTriangle, iv: &GpuInterval, s: Vec2) -> ShadePoint {
    let (p, ap) = (&k.prepared.frame, &k.prepared.raster);
    let t = 0.5 * (iv.ts + iv.te);
    let mut depth = depth_at_time(tri, s, t);
    if !(is_finite1(depth) && depth > 0.0) {
        depth = iv_depth(iv, t);
    }
    let origin = xyz(p.cam_origin);
    let point_on_ray = origin + camera_ray(ap, s) * depth;
    let sphere = sphere_straight(p, &k.spec, t);
    let dir = normalize3(camera_ray(ap, s));
    let hit = if tri.flags[0] == SPHERE {
        // The ray's front hit on the true sphere, else the radial projection (as `shade`).
        let along = intersect_sphere(origin, dir, sphere.centre, sphere.radius);
        let mut point = point_on_ray;
        if along > 0.0 {
            point = origin + dir * along;
        }
        let mut n = point - sphere.centre;
        let len2 = dot3(n, n);
        n = if len2 > 0.0 && is_finite1(len2) { n / len2.sqrt() } else { Vec3::Y };
        if !(along > 0.0) {
            point = sphere.centre + n * sphere.radius;
        }
        let dp = point - origin;
        Hit { t: dot3(dp, dp).sqrt(), point, normal: n, surface: SPHERE }
    } else {
        let mut point = point_on_ray;
        point.y = p.wrap_jump[3];
        let dp = point - origin;
        Hit { t: dot3(dp, dp).sqrt(), point, normal: Vec3::Y, surface: FLOOR }
    };
    ShadePoint { sphere, hit, dir }
}

/// A sphere point facing away from the ray: shaded from the sphere's inside, where no light
/// arrives and no path escapes, so zero at once (`from_inside` in WGSL; the f64 rasterizer's
/// `shade` does the same).
fn from_inside(sp: &ShadePoint) -> bool {
    sp.hit.surface == SPHERE && dot3(sp.hit.normal, sp.dir) > 0.0
}

/// The colour the coverage specialisation gives a surface (`coverage_colour` in WGSL).
fn coverage_colour(tri: &GpuTriangle) -> Vec3 {
    if tri.flags[0] == SPHERE { Vec3::X } else { Vec3::Y }
}

/// The interval's colour and the lighting samples dropped: the kernel's shading step, all of
/// the interval's lighting samples in one (the kernel may take them over several passes, in
/// the same order).
fn shade(k: &Kernel<'_>, tri: &GpuTriangle, iv: &GpuInterval, s: Vec2, seed: u32, index: u32, sub: u32) -> (Vec3, u32) {
    if !k.shade {
        return (coverage_colour(tri), 0);
    }
    let (p, ap) = (&k.prepared.frame, &k.prepared.raster);
    let sp = shade_point(k, tri, iv, s);
    if from_inside(&sp) {
        return (Vec3::ZERO, 0);
    }
    let mut sum = Vec3::ZERO;
    let mut scaled = false;
    let mut bad = 0;
    let first = (index * ap.supersampling * ap.supersampling + sub) * ap.lighting;
    for j in 0..ap.lighting {
        let l = radiance_from(p, &k.spec, k.env, &sp.sphere, seed, first + j, sp.dir, sp.hit);
        if is_finite3(l) {
            if !scaled && needs_scaling(sum, l) {
                scaled = true;
                sum *= SUM_SCALE;
            }
            sum = add_lighting(sum, l, scaled);
        } else {
            bad += 1;
        }
    }
    (lighting_mean(ap, sum, scaled), bad)
}

/// 2^-64 and 2^64 (`SUM_SCALE`, `SUM_UNSCALE` in WGSL): a running sum of finite lighting
/// samples that could overflow f32 (a sky near its maximum) continues scaled, exactly, once
/// a sample or the sum exceeds [`SCALE_FROM`] (2^100).
const SUM_SCALE: f32 = 1.0 / 18_446_744_073_709_551_616.0;
const SUM_UNSCALE: f32 = 18_446_744_073_709_551_616.0;
const SCALE_FROM: f32 = 1.267_650_6e30;

fn needs_scaling(sum: Vec3, l: Vec3) -> bool {
    sum.abs().max(l.abs()).max_element() > SCALE_FROM
}

fn add_lighting(sum: Vec3, l: Vec3, scaled: bool) -> Vec3 {
    if scaled { sum + l * SUM_SCALE } else { sum + l }
}

fn lighting_mean(ap: &RasterParams, sum: Vec3, scaled: bool) -> Vec3 {
    let mean = sum / ap.lighting as f32;
    if scaled { (mean * SUM_UNSCALE).min(Vec3::splat(f32::MAX)) } else { mean }
}

/// The kernel's body for pixel `(x, y)`: linear radiance (or coverage), the fraction of the
/// shutter covered, the counts and the final list.
pub fn analytic_pixel(k: &Kernel<'_>, x: u32, y: u32) -> ([f32; 4], PixelStats, Vec<GpuInterval>) {
    let (prep, ap) = (k.prepared, &k.prepared.raster);
    let p = &prep.frame;
    let cs = ap.sample_corner_step;
    let s = Vec2::new(cs[0], cs[1]) + Vec2::new(cs[2], cs[3]) * Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
    let n = ap.supersampling;
    let seed = pixel_seed(p.eye_seed ^ ANALYTIC_STREAM, (y / n) * (ap.width / n) + x / n);
    let sub = (y % n) * n + x % n;
    let mut list: Vec<GpuInterval> = Vec::with_capacity(ap.budget as usize + 1);
    let mut stats = PixelStats::default();
    let tile = ((y / super::prepare::TILE) * ap.tiles_x + x / super::prepare::TILE) as usize;
    for &index in &prep.bins[prep.bins[tile] as usize..prep.bins[tile + 1] as usize] {
        let tri = &prep.triangles[index as usize];
        let [x0, x1, y0, y1] = tri.bounds;
        if x < x0 || x >= x1 || y < y0 || y >= y1 {
            continue;
        }
        let vis = visibility(tri, s);
        for &(ts, te) in &vis.t[..vis.n] {
            stats.offered += 1;
            let (z, kz) = linear_depth(tri, s, ts, te);
            let mut iv = insert_opaque_clip(&mut list, GpuInterval { ts, te, z, k: kz, ..GpuInterval::default() });
            if iv.te <= iv.ts {
                continue;
            }
            let (c, bad) = shade(k, tri, &iv, s, seed, stats.kept, sub);
            (iv.r, iv.g, iv.b) = (c.x, c.y, c.z);
            insert_sorted(&mut list, iv);
            stats.kept += 1;
            stats.nonfinite += bad;
            stats.merges += compress(&mut list, ap.budget, ap.range);
        }
    }
    let (sum, covered) = resolve(&list);
    let background =
        if k.shade { env_texel(k.env, texel_of(p, k.env, normalize3(camera_ray(ap, s))).0) } else { Vec3::ZERO };
    let rest = (1.0 - covered).max(0.0);
    let c = Vec3::from_array(sum) + background * rest;
    ([c.x, c.y, c.z, covered], stats, list)
}

/// The twin's result for one view.
#[derive(Clone, Debug)]
pub struct View {
    /// Linear radiance (or coverage colours when not shading).
    pub image: LinearImage,
    /// The fraction of the shutter covered, per pixel.
    pub coverage: Vec<f32>,
    /// Counts per pixel.
    pub stats: Vec<PixelStats>,
}

/// The twin over a whole view; rows run in parallel.
pub fn render_view(k: &Kernel<'_>) -> View {
    use rayon::prelude::*;
    let ap = &k.prepared.raster;
    let (w, h) = (ap.width, ap.height);
    let rows: Vec<Vec<([f32; 4], PixelStats)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let (c, st, _) = analytic_pixel(k, x, y);
                    (c, st)
                })
                .collect()
        })
        .collect();
    let mut image = LinearImage::new(w, h);
    let mut coverage = Vec::with_capacity((w * h) as usize);
    let mut stats = Vec::with_capacity((w * h) as usize);
    for (dst, (c, st)) in image.pixels.iter_mut().zip(rows.into_iter().flatten()) {
        *dst = [c[0], c[1], c[2]];
        coverage.push(c[3]);
        stats.push(st);
    }
    View { image, coverage, stats }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};

    use super::*;
    use crate::methods::analytic::interval::Interval;
    use crate::methods::analytic::resolve::resolve_opaque;

    fn to_f32(iv: &Interval) -> GpuInterval {
        let [r, g, b] = iv.color.map(|c| c as f32);
        GpuInterval { ts: iv.ts as f32, te: iv.te as f32, z: iv.z as f32, k: iv.k as f32, r, g, b, pad: 0.0 }
    }

    /// The per-entry resolve in f32 against the f64 sweep over random overlapping lists
    /// (crossing depths, shared ends, ties of identical entries).
    #[test]
    fn the_per_entry_resolve_integrates_like_the_sweep() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let (mut worst, mut loose) = (0.0f64, 0);
        for case in 0..2000 {
            let n = 1 + case % 9;
            let mut list64 = Vec::new();
            for _ in 0..n {
                let a: f64 = rng.random();
                let b: f64 = if rng.random::<f64>() < 0.2 { 1.0 } else { rng.random() };
                let (ts, te) = (a.min(b), a.max(b));
                let z: f64 = 1.0 + 4.0 * rng.random::<f64>();
                let k: f64 = (rng.random::<f64>() - 0.5) * 8.0;
                let color = [rng.random(), rng.random(), rng.random()];
                list64.push(Interval { ts, te, z, k, color, alpha: 1.0 });
            }
            if case % 5 == 0 && n > 1 {
                list64[n - 1] = list64[0];
                list64[n - 1].color = [1.0, 0.0, 0.0];
            }
            list64.sort_by(|a, b| a.ts.total_cmp(&b.ts));
            // Exactly representable in f32, so both see the same list.
            for iv in &mut list64 {
                iv.ts = f64::from(iv.ts as f32);
                iv.te = f64::from(iv.te as f32);
                iv.z = f64::from(iv.z as f32);
                iv.k = f64::from(iv.k as f32);
                iv.color = iv.color.map(|c| f64::from(c as f32));
            }
            let list32: Vec<GpuInterval> = list64.iter().map(to_f32).collect();
            let (sum64, cov64) = resolve_opaque(&list64, [0.0; 3]);
            let (sum32, cov32) = resolve(&list32);
            let d =
                (0..3).map(|c| (sum64[c] - f64::from(sum32[c])).abs()).fold((cov64 - f64::from(cov32)).abs(), f64::max);
            worst = worst.max(d);
            loose += usize::from(d > 1e-5);
            // Where two depth lines nearly coincide, f32 places their crossing less exactly
            // (the colours swap there, so the error is bounded by their difference).
            assert!(d < 1e-3, "case {case}: sweep {sum64:?} {cov64} vs per entry {sum32:?} {cov32}");
        }
        eprintln!("worst difference {worst:.2e}; {loose} of 2000 lists over 1e-5");
        assert!(loose <= 20, "{loose} lists over 1e-5");
    }

    /// Compression in f32 picks the pairs the f64 compression picks, merged the same way.
    #[test]
    fn compression_matches_the_f64_lists() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        for case in 0..500 {
            let mut list64 = Vec::new();
            for i in 0..12 {
                let ts = f64::from(i as f32 / 12.0 + rng.random::<f32>() * 0.05);
                let te = f64::from(ts as f32 + rng.random::<f32>() * 0.2);
                let z = f64::from(1.0 + rng.random::<f32>());
                let k = f64::from(rng.random::<f32>() - 0.5);
                let color = [0, 1, 2].map(|_| f64::from(rng.random::<f32>()));
                list64.push(Interval { ts, te, z, k, color, alpha: 1.0 });
            }
            let mut list32: Vec<GpuInterval> = list64.iter().map(to_f32).collect();
            let merges64 = crate::methods::analytic::interval::compress(&mut list64, 8, 3);
            let merges32 = compress(&mut list32, 8, 3);
            assert_eq!(merges64 as u32, merges32, "case {case}");
            for (a, b) in list64.iter().zip(&list32) {
                assert!((a.ts - f64::from(b.ts)).abs() < 1e-6 && (a.te - f64::from(b.te)).abs() < 1e-6, "case {case}");
                assert!((a.z - f64::from(b.z)).abs() < 1e-5, "case {case}");
            }
        }
    }
}
