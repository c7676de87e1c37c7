//! One packet: up to [`LANES`] camera samples traced together, each lane a (pixel, sample
//! index) pair of one row: the consecutive samples of one pixel, or, below [`LANES`]
//! samples per pixel, every sample of several neighbouring pixels.
//!
//! The algorithm is the f32 twin's ([`crate::shading::gpu::radiance`]), the same operations
//! in the same order per lane, so a lane's radiance is bit for bit the twin's radiance of
//! that sample. What is structured (the sampler's hashing, camera rays, the sphere's and
//! the floor's roots, shadow rays, cosine sampling, MIS weights, throughput and Russian
//! roulette) runs on all lanes at once under a mask of the lanes still tracing; what looks
//! up tables with data-dependent loops (the environment's texel search and CDF inversion,
//! the textures) calls the twin's own function lane by lane for the lanes that need it.
//!
//! The samples of one pixel share their seeds: the three hashes that seed each dimension
//! are computed once per pixel ([`PixelSeeds`]) instead of once per value, and each lane
//! reads its pixel's ([`LaneSeeds`]).

use glam::Vec3;

use super::env;
use super::lanes::{F, LANES, M, U, V3};
use crate::shading::gpu::params::{FrameParams, Specialisation, material_kind};
use crate::shading::gpu::radiance::{
    DIFFUSE_SPREAD, FLOOR, FRAC_1_PI, HIT_POINT_ERROR, Hit, NONE, PI, SPHERE, SphereAt, TAU, surface_albedo, xyz,
};
use crate::shading::gpu::sampler32::{DimSeeds, dim_seeds};
use crate::shading::sampler::dim;

/// The bytes of a packet's loop state: direction, hit (t, point, normal, surface), radiance,
/// throughput, the sphere, the albedo, the light sample (direction, density, jacobian,
/// texel), the next direction and the per-lane scalars (pdfs, footprint, mask, index).
pub(crate) fn state_bytes() -> usize {
    use std::mem::size_of;
    size_of::<V3>() * 10 + size_of::<F>() * 12 + size_of::<U>() * 3 + size_of::<M>() * 4
}

/// The scrambling seeds of every dimension a pixel's samples draw.
pub(crate) struct PixelSeeds {
    dims: Vec<DimSeeds>,
}

impl PixelSeeds {
    /// Room for the dimensions of paths of `max_bounces` scattering events.
    pub(crate) fn new(max_bounces: u32) -> Self {
        let n = dim::BOUNCE_BASE + dim::PER_BOUNCE * max_bounces;
        PixelSeeds { dims: vec![DimSeeds { shuffle: 0, first: 0, second: 0 }; n as usize] }
    }

    /// Seeds for the pixel whose seed is `pixel_seed`.
    #[inline(always)]
    pub(crate) fn set_pixel(&mut self, pixel_seed: u32) {
        for (d, s) in self.dims.iter_mut().enumerate() {
            *s = dim_seeds(pixel_seed, d as u32);
        }
    }
}

/// Each lane's seeds of every dimension: (shuffle, first, second) per dimension.
pub(crate) struct LaneSeeds {
    dims: Vec<[U; 3]>,
}

impl LaneSeeds {
    /// Room for the dimensions of paths of `max_bounces` scattering events.
    pub(crate) fn new(max_bounces: u32) -> Self {
        let n = dim::BOUNCE_BASE + dim::PER_BOUNCE * max_bounces;
        LaneSeeds { dims: vec![[U::splat(0); 3]; n as usize] }
    }

    /// Every lane a sample of the pixel of `seeds`.
    #[inline(always)]
    pub(crate) fn set_all(&mut self, seeds: &PixelSeeds) {
        for (o, s) in self.dims.iter_mut().zip(&seeds.dims) {
            *o = [U::splat(s.shuffle), U::splat(s.first), U::splat(s.second)];
        }
    }

    /// Lanes `lanes` samples of the pixel of `seeds`.
    #[inline(always)]
    pub(crate) fn set_lanes(&mut self, lanes: std::ops::Range<usize>, seeds: &PixelSeeds) {
        for (o, s) in self.dims.iter_mut().zip(&seeds.dims) {
            for i in lanes.clone() {
                (o[0].0[i], o[1].0[i], o[2].0[i]) = (s.shuffle, s.first, s.second);
            }
        }
    }

    /// The seeds of dimension `d` (every dimension a path of at most `max_bounces` draws).
    #[inline(always)]
    fn get(&self, d: u32) -> &[U; 3] {
        &self.dims[d as usize]
    }
}

/// `laine_karras` per lane (`crate::shading::sampler`).
#[inline(always)]
fn laine_karras(x: U, seed: U) -> U {
    let mut x = x.wrapping_add(seed);
    x = x.xor(x.wrapping_mul(U::splat(0x6c50_b47c)));
    x = x.xor(x.wrapping_mul(U::splat(0xb82f_1e52)));
    x = x.xor(x.wrapping_mul(U::splat(0xc7af_e638)));
    x.xor(x.wrapping_mul(U::splat(0x8d22_f6e6)))
}

/// `sobol1_reversed` per lane (`crate::shading::gpu::sampler32`).
#[inline(always)]
fn sobol1_reversed(i: U) -> U {
    let mut x = i;
    x = x.xor(x.shr(1).and(U::splat(0x5555_5555)));
    x = x.xor(x.shr(2).and(U::splat(0x3333_3333)));
    x = x.xor(x.shr(4).and(U::splat(0x0f0f_0f0f)));
    x = x.xor(x.shr(8).and(U::splat(0x00ff_00ff)));
    x.xor(x.shr(16).and(U::splat(0x0000_ffff)))
}

#[inline(always)]
fn shuffled_index(index: U, d: u32, s: &[U; 3]) -> U {
    if d == dim::PIXEL { index } else { laine_karras(index.reverse_bits(), s[0]).reverse_bits() }
}

/// `to_unit` per lane: the top 24 bits as an exact f32 in [0, 1).
#[inline(always)]
fn to_unit(v: U) -> F {
    v.shr(8).to_f32() * F::splat(1.0 / 16_777_216.0)
}

#[inline(always)]
fn sample_1d(seeds: &LaneSeeds, index: U, d: u32) -> F {
    let s = seeds.get(d);
    to_unit(laine_karras(shuffled_index(index, d, s), s[1]).reverse_bits())
}

#[inline(always)]
fn sample_2d(seeds: &LaneSeeds, index: U, d: u32) -> [F; 2] {
    let s = seeds.get(d);
    let i = shuffled_index(index, d, s);
    [to_unit(laine_karras(i, s[1]).reverse_bits()), to_unit(laine_karras(sobol1_reversed(i), s[2]).reverse_bits())]
}

/// `sin_cos_turns` per lane.
#[inline(always)]
pub(crate) fn sin_cos_turns(t: F) -> (F, F) {
    let q = (t * F::splat(4.0) + F::splat(0.5)).floor();
    let x = (t - q * F::splat(0.25)) * F::splat(TAU);
    let y = x * x;
    let c = F::splat;
    let s = x + x * y * (c(-1.0 / 6.0) + y * (c(1.0 / 120.0) + y * (c(-1.0 / 5040.0) + y * c(1.0 / 362_880.0))));
    let co = c(1.0)
        + y * (c(-0.5)
            + y * (c(1.0 / 24.0) + y * (c(-1.0 / 720.0) + y * (c(1.0 / 40_320.0) + y * c(-1.0 / 3_628_800.0)))));
    let quadrant = q.integral_to_i32_bits().and(U::splat(3));
    let (q1, q2, q3) = (quadrant.eq(U::splat(1)), quadrant.eq(U::splat(2)), quadrant.eq(U::splat(3)));
    let sn = q1.select(co, q2.select(-s, q3.select(-co, s)));
    let cs = q1.select(-s, q2.select(-co, q3.select(s, co)));
    (sn, cs)
}

/// The sphere of each lane's sample time.
#[derive(Clone, Copy)]
struct Spheres {
    centre: V3,
    radius: F,
    spin_sin: F,
    spin_cos: F,
}

impl Spheres {
    #[inline(always)]
    fn at(p: &FrameParams, spec: &Specialisation, u: F) -> Spheres {
        let mut s = Spheres {
            centre: V3::splat(xyz(p.centre_open)),
            radius: F::splat(p.centre_open[3]),
            spin_sin: F::splat(0.0),
            spin_cos: F::splat(1.0),
        };
        if spec.time_sampling {
            s.centre = s.centre + V3::splat(xyz(p.travel)).scale(u);
            let wrapped = u.ge(F::splat(p.travel[3]));
            s.centre = wrapped.select3(s.centre + V3::splat(xyz(p.wrap_jump)), s.centre);
            if spec.material != material_kind::FLAT {
                let (sn, cs) = sin_cos_turns(F::splat(-p.spin[3]) * u / F::splat(TAU));
                s.spin_sin = sn;
                s.spin_cos = cs;
            }
        }
        s
    }

    fn lane(&self, i: usize) -> SphereAt {
        SphereAt {
            centre: self.centre.lane(i),
            radius: self.radius.0[i],
            spin_sc: (self.spin_sin.0[i], self.spin_cos.0[i]),
        }
    }
}

/// Each lane's nearest hit.
#[derive(Clone, Copy)]
struct Hits {
    t: F,
    point: V3,
    normal: V3,
    surface: U,
}

impl Hits {
    fn lane(&self, i: usize) -> Hit {
        Hit { t: self.t.0[i], point: self.point.lane(i), normal: self.normal.lane(i), surface: self.surface.0[i] }
    }
}

/// `sphere_root_f32(..).unwrap_or(-1.0)` per lane (`crate::shading::intersect`).
#[inline(always)]
fn intersect_sphere(o: V3, d: V3, s: &Spheres) -> F {
    let f = o - s.centre;
    let b = -f.dot(d);
    let v = f + d.scale(b);
    let r2 = s.radius * s.radius;
    let disc = r2 - v.dot(v);
    let miss = disc.lt(F::splat(0.0)) | disc.is_nan();
    let c = f.dot(f) - r2;
    let q = b + disc.sqrt().copysign(b);
    let miss = miss | q.eq(F::splat(0.0));
    let a = c / q;
    let swap = a.lt(q);
    let (t0, t1) = (swap.select(a, q), swap.select(q, a));
    let none = F::splat(-1.0);
    let t = t0.gt(F::splat(0.0)).select(t0, t1.gt(F::splat(0.0)).select(t1, none));
    miss.select(none, t)
}

/// `sphere_ahead_f32` per lane.
#[inline(always)]
fn sphere_blocks(o: V3, d: V3, s: &Spheres) -> M {
    let f = o - s.centre;
    let b = -f.dot(d);
    let v = f + d.scale(b);
    let r2 = s.radius * s.radius;
    let disc = r2 - v.dot(v);
    let miss = disc.is_nan() | disc.lt(F::splat(0.0));
    let c = f.dot(f) - r2;
    !miss & (c.lt(F::splat(0.0)) | b.gt(F::splat(0.0)))
}

/// `floor_root_f32(..).unwrap_or(-1.0)` per lane.
#[inline(always)]
fn intersect_floor(o: V3, d: V3, height: f32) -> F {
    let t = (F::splat(height) - o.y) / d.y;
    let hit = !d.y.eq(F::splat(0.0)) & t.gt(F::splat(0.0)) & t.lt(F::splat(f32::MAX));
    hit.select(t, F::splat(-1.0))
}

#[inline(always)]
fn intersect(o: V3, d: V3, skip: U, s: &Spheres, floor_height: f32) -> Hits {
    let none = F::splat(-1.0);
    let zero = F::splat(0.0);
    let ts = skip.eq(U::splat(SPHERE)).select(none, intersect_sphere(o, d, s));
    let tf = skip.eq(U::splat(FLOOR)).select(none, intersect_floor(o, d, floor_height));
    let on_sphere = ts.gt(zero) & (tf.le(zero) | ts.le(tf));
    let on_floor = !on_sphere & tf.gt(zero);
    let n = (o + d.scale(ts) - s.centre).normalize();
    let sphere_point = s.centre + n.scale(s.radius);
    let mut floor_point = o + d.scale(tf);
    floor_point.y = F::splat(floor_height);
    let floor_normal = V3::splat(Vec3::Y);
    let zero3 = V3::splat(Vec3::ZERO);
    Hits {
        t: on_sphere.select(ts, on_floor.select(tf, none)),
        point: on_sphere.select3(sphere_point, on_floor.select3(floor_point, zero3)),
        normal: on_sphere.select3(n, on_floor.select3(floor_normal, zero3)),
        surface: on_sphere.select_u(U::splat(SPHERE), on_floor.select_u(U::splat(FLOOR), U::splat(NONE))),
    }
}

#[inline(always)]
fn occluded(o: V3, d: V3, skip: U, s: &Spheres, floor_height: f32) -> M {
    let by_floor = !skip.eq(U::splat(FLOOR)) & intersect_floor(o, d, floor_height).gt(F::splat(0.0));
    by_floor | (!skip.eq(U::splat(SPHERE)) & sphere_blocks(o, d, s))
}

#[inline(always)]
fn offset_origin(p: V3, n: V3) -> V3 {
    let err = F::splat(HIT_POINT_ERROR) * (p.x.abs().max(p.y.abs()).max(p.z.abs()) + F::splat(1.0));
    p + n.scale(err)
}

#[inline(always)]
fn cosine_sample(n: V3, u: [F; 2]) -> (V3, F) {
    let one = F::splat(1.0);
    let r = u[0].sqrt();
    let (sn, cs) = sin_cos_turns(u[1]);
    let z = (one - u[0]).max(F::splat(0.0)).sqrt();
    let sign = one.copysign(n.z);
    let a = F::splat(-1.0) / (sign + n.z);
    let b = n.x * n.y * a;
    let t = V3 { x: one + sign * n.x * n.x * a, y: sign * b, z: -sign * n.x };
    let bt = V3 { x: b, y: sign + n.y * n.y * a, z: -n.y };
    (t.scale(r * cs) + bt.scale(r * sn) + n.scale(z), z * F::splat(FRAC_1_PI))
}

/// The radiance of each lane's sample: sample `index` of pixel `(x, y)` (the lane's `x`,
/// the row's `y`), seeded by `seeds`; lanes outside `lanes` are not traced and hold zero.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_packet(
    p: &FrameParams,
    spec: &Specialisation,
    env: &[u32],
    seeds: &LaneSeeds,
    x: F,
    y: u32,
    index: U,
    lanes: M,
) -> V3 {
    let u = if spec.pixel_jitter { sample_2d(seeds, index, dim::PIXEL) } else { [F::splat(0.5), F::splat(0.5)] };
    let (corner, sx, sy) = (V3::splat(xyz(p.cam_corner)), V3::splat(xyz(p.cam_step_x)), V3::splat(xyz(p.cam_step_y)));
    let dir = (corner + sx.scale(x + u[0]) + sy.scale(F::splat(y as f32) + u[1])).normalize();
    let t = if spec.time_sampling { sample_1d(seeds, index, dim::TIME) } else { F::splat(0.0) };
    let spheres = Spheres::at(p, spec, t);
    let floor_h = p.wrap_jump[3];
    let first_hit = intersect(V3::splat(xyz(p.cam_origin)), dir, U::splat(NONE), &spheres, floor_h);
    radiance(p, spec, env, seeds, index, &spheres, dir, first_hit, lanes)
}

/// The twin's `radiance_from` over the lanes of `active`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn radiance(
    p: &FrameParams,
    spec: &Specialisation,
    env: &[u32],
    seeds: &LaneSeeds,
    index: U,
    s: &Spheres,
    camera_dir: V3,
    first: Hits,
    mut active: M,
) -> V3 {
    let zero = F::splat(0.0);
    let floor_h = p.wrap_jump[3];
    let mut d = camera_dir;
    let mut hit = first;
    let mut l = V3::splat(Vec3::ZERO);
    let mut beta = V3::splat(Vec3::ONE);
    let mut prev_bsdf_pdf = zero;
    let mut cone_width = zero;
    let mut spread = p.cam_origin[3];
    let mut bounce = 0u32;
    loop {
        // Lanes that leave for the environment: its radiance there, weighted against light
        // sampling after a bounce.
        let escaped = active & hit.surface.eq(U::splat(NONE));
        if escaped.any() {
            let (texel, cx, cy, sin_theta) = env::texel_of(p, env, d, escaped);
            let le = env::env_texel(env, texel);
            let contribution = if bounce == 0 {
                beta.mul(le)
            } else {
                let density = sin_theta.gt(zero).select(env::cell_density(p, env, cx, cy), zero);
                let jacobian = F::splat(2.0 * PI * PI) * sin_theta;
                let pj = prev_bsdf_pdf * jacobian;
                let w = density.gt(zero).select(pj * pj / (pj * pj + density * density), F::splat(1.0));
                beta.mul(le).scale(w)
            };
            l = escaped.select3(l + contribution, l);
            active = active & !escaped;
        }
        if bounce == p.max_bounces || !active.any() {
            break;
        }
        let base = dim::BOUNCE_BASE + bounce * dim::PER_BOUNCE;
        let u_light = sample_2d(seeds, index, base + dim::LIGHT);
        let u_bsdf = sample_2d(seeds, index, base + dim::BSDF);
        let flip = hit.normal.dot(d).gt(zero);
        hit.normal = flip.select3(-hit.normal, hit.normal);
        let leave_skip = (flip & hit.surface.eq(U::splat(SPHERE))).select_u(U::splat(NONE), hit.surface);
        let footprint = cone_width + hit.t * F::splat(spread);

        // Albedo: constant for the floor and a flat sphere, the twin's texture otherwise.
        let floor = hit.surface.eq(U::splat(FLOOR));
        let sphere_albedo = V3::splat(xyz(p.albedo_a));
        let mut albedo = floor.select3(V3::splat(xyz(p.floor_albedo)), sphere_albedo);
        if spec.material != material_kind::FLAT {
            let textured = active & !floor;
            for i in 0..LANES {
                if textured.lane(i) {
                    let a = surface_albedo(p, spec, &s.lane(i), &hit.lane(i), footprint.0[i], d.lane(i));
                    albedo.set_lane(i, a);
                }
            }
        }

        // Light sampling: one direction from the map, with a shadow ray.
        let (ld, density, jacobian, texel) = env::env_sample(p, env, u_light, active);
        let cos = hit.normal.dot(ld);
        let candidate = active & density.gt(zero) & cos.gt(zero);
        if candidate.any() {
            let so = offset_origin(hit.point, hit.normal);
            let lit = candidate & !occluded(so, ld, leave_skip, s, floor_h);
            let b = cos * F::splat(FRAC_1_PI);
            let bj = b * jacobian;
            let weight = b * density * jacobian / (density * density + bj * bj);
            let le = env::env_texel(env, texel);
            l = lit.select3(l + beta.mul(albedo).mul(le).scale(weight), l);
        }

        let (wi, pdf) = cosine_sample(hit.normal, u_bsdf);
        active = active & !(pdf.is_nan() | pdf.le(zero));
        beta = active.select3(beta.mul(albedo), beta);
        bounce += 1;
        if bounce >= p.russian_roulette_from {
            let survive = beta.x.max(beta.y).max(beta.z).clamp(0.05, 1.0);
            let at_risk = active & survive.lt(F::splat(1.0));
            if at_risk.any() {
                let killed = at_risk & sample_1d(seeds, index, base + dim::ROULETTE).ge(survive);
                active = active & !killed;
                beta = (at_risk & !killed).select3(beta.div(survive), beta);
            }
        }
        active = active & !(beta.x.eq(zero) & beta.y.eq(zero) & beta.z.eq(zero));
        if !active.any() {
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
