//! The CPU twin of `radiance.wgsl`, the f32 shading layer the tracer's kernel
//! (`methods/tracer/trace_batch.wgsl`) and the analytic kernel include, in f32: every WGSL
//! function has a Rust function of the same name and the same operations in the same order,
//! so GPU and twin agree to rounding, except the 64-bit emulation (`mul64`, `splitmix64`,
//! `lattice_gradient` and their helpers), where the twin uses u64 itself, and `copysign`,
//! which is `f32::copysign` (`tests/tracer_gpu.rs` holds them to it per pixel). Where the
//! f64 reference runs the same algorithm, the twin does not restate it but calls the one
//! body both widths are generated from: the sphere's and the floor's roots
//! ([`crate::shading::intersect`]) and the filtered gradient noise with its lattice hash
//! ([`crate::shading::material`]).
//!
//! The integrator is the CPU tracer's ([`crate::shading::integrator`]): the same bounce
//! structure, MIS, Russian roulette, cone footprints and sampling dimensions, with the u32
//! sampler of [`super::sampler32`]. What differs is only what f32 and WGSL force:
//!
//! - Trigonometry is by polynomial (`sin_cos_turns`, `atan`), not by the platform's
//!   functions, whose precision WGSL leaves to the implementation.
//! - Ray origins are offset along the normal by `16 eps32 (|p|max + 1)`, the f64 tracer's
//!   bound with the f32 unit round-off.
//! - Samples are added to the pixel already divided by the sample count, so a sum of huge
//!   values cannot overflow where their mean does not. The f32 sum of `n` non-negative
//!   terms has a relative error of at most `(n - 1) eps32 / 2` (3.0e-5 at 512 samples),
//!   far below an 8-bit output step and the Monte Carlo noise.
//! - A sample is finite when none of its channels has an all-ones exponent (WGSL has no
//!   `isNan`, and comparisons with NaN may be optimised away).
//! - The noise texture's 64-bit lattice hash is [`crate::shading::material`]'s, which the
//!   WGSL computes with pairs of u32.

use glam::Vec3;

use super::params::{FrameParams, Specialisation, material_kind};
use super::sampler32::{sample_1d_bits, sample_2d_bits, to_unit};
use crate::shading::intersect::{floor_root_f32, sphere_ahead_f32, sphere_root_f32};
use crate::shading::material::{NOISE_GAIN, filtered_noise_f32};
use crate::shading::sampler::dim;

pub(crate) const PI: f32 = std::f32::consts::PI;
pub(crate) const TAU: f32 = std::f32::consts::TAU;
pub(crate) const FRAC_1_PI: f32 = std::f32::consts::FRAC_1_PI;
/// Spread of the cone a sample stands for after a diffuse bounce (the CPU tracer's).
pub(crate) const DIFFUSE_SPREAD: f32 = 0.25;
/// Relative error bound of a hit point: 16 f32 unit round-offs.
pub(crate) const HIT_POINT_ERROR: f32 = 16.0 * f32::EPSILON;
/// 1 / 65535, the weight of one step of a 16-bit cumulative table.
const CDF_STEP: f32 = 1.0 / 65535.0;

pub(crate) fn xyz(v: [f32; 4]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

pub(crate) fn cross3(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x)
}

pub(crate) fn dot3(a: Vec3, b: Vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

pub(crate) fn normalize3(v: Vec3) -> Vec3 {
    v / dot3(v, v).sqrt()
}

/// `(sin 2 pi t, cos 2 pi t)`: reduction to the nearest quarter turn, then Taylor
/// polynomials to x^9 and x^10 on |x| <= pi / 4 (errors below 2e-9).
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    let q = (t * 4.0 + 0.5).floor();
    let x = (t - q * 0.25) * TAU;
    let y = x * x;
    let s = x + x * y * (-1.0 / 6.0 + y * (1.0 / 120.0 + y * (-1.0 / 5040.0 + y * (1.0 / 362_880.0))));
    let c = 1.0 + y * (-0.5 + y * (1.0 / 24.0 + y * (-1.0 / 720.0 + y * (1.0 / 40_320.0 + y * (-1.0 / 3_628_800.0)))));
    match (q as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `atan x` for x in [0, 1]: reduced by `atan x = pi / 4 + atan((x - 1) / (x + 1))` above
/// tan(pi / 8) to |z| <= 0.4143, then the odd Taylor series to z^15 (error below 2e-8).
fn atan_unit(x: f32) -> f32 {
    let reduce = x > 0.414_213_57;
    let z = if reduce { (x - 1.0) / (x + 1.0) } else { x };
    let y = z * z;
    let p = 1.0
        + y * (-1.0 / 3.0
            + y * (1.0 / 5.0
                + y * (-1.0 / 7.0 + y * (1.0 / 9.0 + y * (-1.0 / 11.0 + y * (1.0 / 13.0 + y * (-1.0 / 15.0)))))));
    let r = z * p;
    if reduce { 0.25 * PI + r } else { r }
}

/// `atan2_poly(y, x)` in [-pi, pi] from [`atan_unit`].
pub fn atan2_poly(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let hi = ax.max(ay);
    if hi == 0.0 {
        return 0.0;
    }
    let mut r = atan_unit(ax.min(ay) / hi);
    if ay > ax {
        r = 0.5 * PI - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// The sphere at one sample's time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SphereAt {
    pub(crate) centre: Vec3,
    pub(crate) radius: f32,
    /// Spin since the opening: (sin, cos) of minus the angle, about `FrameParams::spin`.
    pub(crate) spin_sc: (f32, f32),
}

/// Hit surfaces (as in WGSL: 0 none, 1 sphere, 2 floor).
pub(crate) const NONE: u32 = 0;
pub(crate) const SPHERE: u32 = 1;
pub(crate) const FLOOR: u32 = 2;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub(crate) t: f32,
    pub(crate) point: Vec3,
    pub(crate) normal: Vec3,
    pub(crate) surface: u32,
}

// The sphere's and the floor's roots are the f64 reference's own body in f32
// (`crate::shading::intersect`); WGSL has no Option, so no root is -1.
pub(crate) fn intersect_sphere(o: Vec3, d: Vec3, centre: Vec3, radius: f32) -> f32 {
    sphere_root_f32(o, d, centre, radius).unwrap_or(-1.0)
}

fn sphere_blocks(o: Vec3, d: Vec3, centre: Vec3, radius: f32) -> bool {
    sphere_ahead_f32(o, d, centre, radius)
}

fn intersect_floor(o: Vec3, d: Vec3, height: f32) -> f32 {
    floor_root_f32(o, d, height).unwrap_or(-1.0)
}

fn intersect(o: Vec3, d: Vec3, skip: u32, s: &SphereAt, floor_height: f32) -> Hit {
    let ts = if skip == SPHERE { -1.0 } else { intersect_sphere(o, d, s.centre, s.radius) };
    let tf = if skip == FLOOR { -1.0 } else { intersect_floor(o, d, floor_height) };
    if ts > 0.0 && (tf <= 0.0 || ts <= tf) {
        let p = o + d * ts;
        let n = normalize3(p - s.centre);
        return Hit { t: ts, point: s.centre + n * s.radius, normal: n, surface: SPHERE };
    }
    if tf > 0.0 {
        let mut p = o + d * tf;
        p.y = floor_height;
        return Hit { t: tf, point: p, normal: Vec3::Y, surface: FLOOR };
    }
    Hit { t: -1.0, point: Vec3::ZERO, normal: Vec3::ZERO, surface: NONE }
}

fn occluded(o: Vec3, d: Vec3, skip: u32, s: &SphereAt, floor_height: f32) -> bool {
    (skip != FLOOR && intersect_floor(o, d, floor_height) > 0.0)
        || (skip != SPHERE && sphere_blocks(o, d, s.centre, s.radius))
}

fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let err = HIT_POINT_ERROR * (p.x.abs().max(p.y.abs()).max(p.z.abs()) + 1.0);
    p + n * err
}

fn is_bad(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) == 0x7f80_0000
}

pub(crate) fn is_finite3(v: Vec3) -> bool {
    !(is_bad(v.x) || is_bad(v.y) || is_bad(v.z))
}

// ---- Environment: texel look-up and importance sampling (see `crate::env`). ----

fn env_f32(env: &[u32], i: u32) -> f32 {
    f32::from_bits(env[i as usize])
}

fn env_u16(env: &[u32], offset: u32, i: u32) -> u32 {
    (env[(offset + (i >> 1)) as usize] >> ((i & 1) * 16)) & 0xffff
}

pub(crate) fn env_texel(env: &[u32], index: u32) -> Vec3 {
    Vec3::new(env_f32(env, 3 * index), env_f32(env, 3 * index + 1), env_f32(env, 3 * index + 2))
}

fn pseudo_angle(a: f32, b: f32) -> f32 {
    let sum = a.abs() + b.abs();
    if sum == 0.0 {
        return 0.0;
    }
    let r = a / sum;
    if b >= 0.0 { if a >= 0.0 { r } else { 4.0 + r } } else { 2.0 - r }
}

/// Whether the map direction `m` lies after column edge `j` (`sin(phi - phi_j) >= 0`).
fn col_after(p: &FrameParams, env: &[u32], m: Vec3, j: u32) -> bool {
    let s = env_f32(env, p.off_col_edge + 2 * j);
    let c = env_f32(env, p.off_col_edge + 2 * j + 1);
    m.x * c + m.z * s >= 0.0
}

/// The texel a finite non-zero world direction falls in: (index, cell x, cell y, sin theta).
pub(crate) fn texel_of(p: &FrameParams, env: &[u32], d: Vec3) -> (u32, u32, u32, f32) {
    let (rc, rs) = (p.env_rot_cos, p.env_rot_sin);
    let m = Vec3::new(rc * d.x - rs * d.z, d.y, rs * d.x + rc * d.z);
    let inv_len = 1.0 / dot3(m, m).sqrt();
    let cos_theta = (m.y * inv_len).clamp(-1.0, 1.0);
    let sin_theta = (m.x * m.x + m.z * m.z).sqrt() * inv_len;
    let (w, h) = (p.env_width, p.env_height);
    let bins = 16 * h;
    let k = (((1.0 - cos_theta) * (0.5 * bins as f32)) as u32).min(bins - 1);
    let mut y = env[(p.off_row_bins + k) as usize];
    while y + 1 < h && cos_theta <= env_f32(env, p.off_row_edge_cos + y + 1) {
        y += 1;
    }
    while y > 0 && cos_theta > env_f32(env, p.off_row_edge_cos + y) {
        y -= 1;
    }
    let bins = 4 * w;
    let k = ((pseudo_angle(m.x, -m.z) * (0.25 * bins as f32)) as u32).min(bins - 1);
    let mut x = env[(p.off_col_bins + k) as usize];
    for _ in 0..4 {
        if !col_after(p, env, m, x) {
            x = if x == 0 { w - 1 } else { x - 1 };
        } else if col_after(p, env, m, x + 1) {
            x = if x + 1 == w { 0 } else { x + 1 };
        } else {
            break;
        }
    }
    let shift = p.env_cell_shift;
    (y * w + x, x >> shift, y >> shift, sin_theta)
}

pub(crate) fn cell_density(p: &FrameParams, env: &[u32], x: u32, y: u32) -> f32 {
    if p.env_samplable == 0 {
        return 0.0;
    }
    let m = p.off_marginal;
    let row_cdf = p.marginal_guide_len;
    let p_row = (env_u16(env, m, row_cdf + y + 1) - env_u16(env, m, row_cdf + y)) as f32 * CDF_STEP;
    let base = y * p.rows_stride + p.rows_guide_len;
    let p_col = (env_u16(env, p.off_rows, base + x + 1) - env_u16(env, p.off_rows, base + x)) as f32 * CDF_STEP;
    p_row * p_col * (p.env_dist_width * p.env_dist_height) as f32
}

/// Inverts distribution `row` (of `width` cells) of a 16-bit table at `u`: (cell, position
/// in the cell, probability).
fn cdf_sample(
    env: &[u32],
    offset: u32,
    row: u32,
    (guide_len, guide_shift, stride): (u32, u32, u32),
    width: u32,
    u: f32,
) -> (u32, f32, f32) {
    let base = row * stride;
    let t = u * 65535.0;
    let ti = (t as u32).min(65534);
    let k = ti >> guide_shift;
    let mut x = env_u16(env, offset, base + k);
    let hi = if k + 1 < guide_len { env_u16(env, offset, base + k + 1) } else { width - 1 };
    let cdf = base + guide_len;
    while x < hi && env_u16(env, offset, cdf + x + 1) <= ti {
        x += 1;
    }
    let start = env_u16(env, offset, cdf + x) as f32;
    let cell = (env_u16(env, offset, cdf + x + 1) - env_u16(env, offset, cdf + x)) as f32;
    let f = ((t - start) / cell).clamp(0.0, 1.0 - f32::EPSILON);
    (x, f, cell * CDF_STEP)
}

/// A light sample: (world direction, density over map coordinates, jacobian, texel), or
/// density 0 for none.
pub(crate) fn env_sample(p: &FrameParams, env: &[u32], u: [f32; 2]) -> (Vec3, f32, f32, u32) {
    let none = (Vec3::ZERO, 0.0, 0.0, 0);
    if p.env_samplable == 0 {
        return none;
    }
    let (wd, hd) = (p.env_dist_width, p.env_dist_height);
    let marginal = (p.marginal_guide_len, p.marginal_guide_shift, p.marginal_stride);
    let rows = (p.rows_guide_len, p.rows_guide_shift, p.rows_stride);
    let (y, fy, p_y) = cdf_sample(env, p.off_marginal, 0, marginal, hd, u[0]);
    let (x, fx, p_x) = cdf_sample(env, p.off_rows, y, rows, wd, u[1]);
    let density = p_y * p_x * (wd * hd) as f32;
    if density <= 0.0 {
        return none;
    }
    let (sin_theta, cos_theta) = sin_cos_turns(0.5 * (y as f32 + fy) / hd as f32);
    let (sin_phi, cos_phi) = sin_cos_turns((x as f32 + fx) / wd as f32);
    if sin_theta <= 0.0 {
        return none;
    }
    let f = 1u32 << p.env_cell_shift;
    let px = (((x as f32 + fx) * f as f32) as u32).clamp(x * f, x * f + f - 1);
    let py = (((y as f32 + fy) * f as f32) as u32).clamp(y * f, y * f + f - 1);
    let m = Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta);
    let (rc, rs) = (p.env_rot_cos, p.env_rot_sin);
    let world = Vec3::new(rc * m.x + rs * m.z, m.y, -rs * m.x + rc * m.z);
    (world, density, 2.0 * PI * PI * sin_theta, py * p.env_width + px)
}

// ---- Materials. ----

// The noise and its filtering are the f64 reference's own body in f32
// (`crate::shading::material`).
fn filtered_noise(q: Vec3, p: &FrameParams, footprint: f32) -> f32 {
    filtered_noise_f32(q, p.albedo_a[3], p.octaves, p.noise_seed, footprint)
}

/// The albedo of the sphere at `local` (its own frame, unit sphere).
fn texture(p: &FrameParams, spec: &Specialisation, local: Vec3, footprint: f32) -> Vec3 {
    let (a, b) = (xyz(p.albedo_a), xyz(p.albedo_b));
    if spec.material == material_kind::CHECKER {
        let lon = atan2_poly(local.z, local.x);
        let y = local.y.clamp(-1.0, 1.0);
        let lat = atan2_poly(y, (1.0 - y * y).max(0.0).sqrt());
        let u = (lon / TAU + 0.5) * p.albedo_a[3];
        let v = (lat / PI + 0.5) * p.albedo_b[3];
        return if ((u.floor() as i32).wrapping_add(v.floor() as i32) & 1) == 0 { a } else { b };
    }
    let n = filtered_noise(local, p, footprint);
    let s = (0.5 + NOISE_GAIN as f32 * n).clamp(0.0, 1.0);
    a + (b - a) * s
}

/// World-to-object rotation of a vector at the sample's time: the spin since the opening
/// undone (Rodrigues), then the opening's rotation.
fn to_object(p: &FrameParams, spec: &Specialisation, s: &SphereAt, v: Vec3) -> Vec3 {
    let mut r = v;
    if spec.time_sampling {
        let k = xyz(p.spin);
        let (sn, cs) = s.spin_sc;
        r = v * cs + cross3(k, v) * sn + k * (dot3(k, v) * (1.0 - cs));
    }
    Vec3::new(dot3(xyz(p.w2o_row0), r), dot3(xyz(p.w2o_row1), r), dot3(xyz(p.w2o_row2), r))
}

pub(crate) fn surface_albedo(
    p: &FrameParams,
    spec: &Specialisation,
    s: &SphereAt,
    hit: &Hit,
    footprint: f32,
    dir: Vec3,
) -> Vec3 {
    if hit.surface == FLOOR {
        return xyz(p.floor_albedo);
    }
    if spec.material == material_kind::FLAT {
        return xyz(p.albedo_a);
    }
    let local = to_object(p, spec, s, (hit.point - s.centre) / s.radius);
    let cos = dot3(hit.normal, dir).abs().max(0.05);
    texture(p, spec, local, footprint / (s.radius * cos.sqrt()))
}

fn cosine_sample(n: Vec3, u: [f32; 2]) -> (Vec3, f32) {
    let r = u[0].sqrt();
    let (sn, cs) = sin_cos_turns(u[1]);
    let z = (1.0 - u[0]).max(0.0).sqrt();
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t * (r * cs) + bt * (r * sn) + n * z, z * FRAC_1_PI)
}

pub(crate) fn sample_2d(seed: u32, index: u32, d: u32) -> [f32; 2] {
    sample_2d_bits(seed, index, d).map(to_unit)
}

/// Radiance along a camera ray (the integrator of `crate::shading::integrator`, in f32).
pub(crate) fn radiance(
    p: &FrameParams,
    spec: &Specialisation,
    env: &[u32],
    s: &SphereAt,
    seed: u32,
    index: u32,
    camera_dir: Vec3,
) -> Vec3 {
    let first = intersect(xyz(p.cam_origin), camera_dir, NONE, s, p.wrap_jump[3]);
    radiance_from(p, spec, env, s, seed, index, camera_dir, first)
}

/// Radiance along a camera ray whose first hit is `first` (the analytic rasterizer's GPU
/// twin gives its own; [`radiance`] intersects the scene).
#[allow(clippy::too_many_arguments)]
pub(crate) fn radiance_from(
    p: &FrameParams,
    spec: &Specialisation,
    env: &[u32],
    s: &SphereAt,
    seed: u32,
    index: u32,
    camera_dir: Vec3,
    first: Hit,
) -> Vec3 {
    let floor_h = p.wrap_jump[3];
    let mut d = camera_dir;
    let mut hit = first;
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut prev_bsdf_pdf = 0.0f32;
    let mut cone_width = 0.0f32;
    let mut spread = p.cam_origin[3];
    let mut bounce = 0u32;
    loop {
        if hit.surface == NONE {
            let (texel, cx, cy, sin_theta) = texel_of(p, env, d);
            let le = env_texel(env, texel);
            if bounce == 0 {
                l += beta * le;
            } else {
                let density = if sin_theta > 0.0 { cell_density(p, env, cx, cy) } else { 0.0 };
                let jacobian = 2.0 * PI * PI * sin_theta;
                let mut w = 1.0;
                if density > 0.0 {
                    let pj = prev_bsdf_pdf * jacobian;
                    w = pj * pj / (pj * pj + density * density);
                }
                l += beta * le * w;
            }
            break;
        }
        if bounce == p.max_bounces {
            break;
        }
        let base = dim::BOUNCE_BASE + bounce * dim::PER_BOUNCE;
        let u_light = sample_2d(seed, index, base + dim::LIGHT);
        let u_bsdf = sample_2d(seed, index, base + dim::BSDF);
        let mut leave_skip = hit.surface;
        if dot3(hit.normal, d) > 0.0 {
            hit.normal = -hit.normal;
            if hit.surface == SPHERE {
                leave_skip = NONE;
            }
        }
        let footprint = cone_width + hit.t * spread;
        let albedo = surface_albedo(p, spec, s, &hit, footprint, d);
        let (ld, density, jacobian, texel) = env_sample(p, env, u_light);
        if density > 0.0 {
            let cos = dot3(hit.normal, ld);
            if cos > 0.0 {
                let so = offset_origin(hit.point, hit.normal);
                if !occluded(so, ld, leave_skip, s, floor_h) {
                    let b = cos * FRAC_1_PI;
                    let bj = b * jacobian;
                    let weight = b * density * jacobian / (density * density + bj * bj);
                    l += beta * albedo * env_texel(env, texel) * weight;
                }
            }
        }
        let (wi, pdf) = cosine_sample(hit.normal, u_bsdf);
        if pdf.is_nan() || pdf <= 0.0 {
            break;
        }
        beta *= albedo;
        bounce += 1;
        if bounce >= p.russian_roulette_from {
            let survive = beta.x.max(beta.y).max(beta.z).clamp(0.05, 1.0);
            if survive < 1.0 {
                if to_unit(sample_1d_bits(seed, index, base + dim::ROULETTE)) >= survive {
                    break;
                }
                beta /= survive;
            }
        }
        if beta.x == 0.0 && beta.y == 0.0 && beta.z == 0.0 {
            break;
        }
        let o = offset_origin(hit.point, hit.normal);
        d = wi;
        prev_bsdf_pdf = pdf;
        cone_width = footprint;
        spread = spread.max(DIFFUSE_SPREAD);
        hit = intersect(o, d, leave_skip, s, floor_h);
    }
    l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_trigonometry_is_accurate_to_f32() {
        for i in -2000..=2000 {
            let t = i as f32 / 1000.0 + 0.000_37;
            let (s, c) = sin_cos_turns(t);
            let (es, ec) = (std::f64::consts::TAU * f64::from(t)).sin_cos();
            assert!((f64::from(s) - es).abs() < 4e-7 && (f64::from(c) - ec).abs() < 4e-7, "{t}");
            for j in [-3.0f32, -0.5, 0.0, 0.25, 1.0, 7.0] {
                let (y, x) = (t, j * 0.37 + 0.01);
                let a = atan2_poly(y, x);
                let e = f64::from(y).atan2(f64::from(x));
                assert!((f64::from(a) - e).abs() < 5e-7, "atan2_poly({y}, {x}) = {a}, expected {e}");
            }
        }
        assert_eq!(atan2_poly(0.0, 0.0), 0.0);
        assert!((atan2_poly(1.0, 0.0) - 0.5 * PI).abs() < 1e-7 && (atan2_poly(0.0, -1.0) - PI).abs() < 1e-7);
    }
}
