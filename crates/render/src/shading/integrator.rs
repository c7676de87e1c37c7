//! The path-tracing integrator: Lambertian surfaces under an environment map.
//!
//! At every surface vertex the environment is sampled twice: by importance sampling the
//! map (a shadow ray) and by the cosine-weighted BSDF direction that also continues the
//! path; the two are combined by the power heuristic. Bounce `k` is the `k`-th
//! scattering at a surface: with `max_bounces = B` a path scatters at most B times, so
//! its longest chain has B + 1 segments (Mitsuba's `max_depth = B + 1`). Russian
//! roulette may stop a path before it scatters for the `russian_roulette_from`-th time,
//! with survival probability equal to the largest channel of the throughput (at most 1,
//! at least 5 %).
//!
//! In a scene with a participating medium ([`PathMedium`]) every segment of the path is
//! delta tracked through it: a real collision scatters (isotropic phase, weighted by the
//! albedo), the environment is sampled there with a shadow ray whose transmittance comes
//! from ratio tracking, and up to `max_scatterings` collisions continue in a direction drawn
//! from the phase function (a path that leaves a collision for the sky adds nothing: the
//! sample at the collision counted that light). Surfaces' shadow rays also carry the
//! medium's transmittance, so the smoke shadows the floor. Without a medium none of this
//! runs and the path is what it always was.

use std::f64::consts::FRAC_1_PI;

use glam::{DQuat, DVec3};

use media::scatter::{ISOTROPIC, uniform_sphere};
use media::tracking::Medium;

use super::intersect::{Geometry, Hit, Ray, Surface, spawn_ray};
use super::material::Shader;
use super::sampler::{PixelSampler, dim};
use crate::env::EnvironmentMap;
use crate::numeric::trig::sin_cos_turns;
use crate::volume::WorldMedium;

/// Spread (radians) of the cone a sample stands for after a diffuse bounce, for texture
/// filtering of indirect hits: diffuse light averages over a wide area.
const DIFFUSE_SPREAD: f64 = 0.25;

/// The sphere at the instant of one camera sample.
#[derive(Clone, Copy, Debug)]
pub struct SphereState {
    /// Intersectable geometry.
    pub geometry: Geometry,
    /// World-to-object rotation (inverse of the orientation), used only by textures.
    pub world_to_object: DQuat,
}

/// Everything the integrator needs that does not change within a frame.
pub struct PathTracer<'a> {
    /// Environment.
    pub env: &'a EnvironmentMap,
    /// Sphere material.
    pub shader: Shader,
    /// Floor albedo.
    pub floor_albedo: DVec3,
    /// Maximum scattering events.
    pub max_bounces: u32,
    /// Scattering event from which Russian roulette applies.
    pub russian_roulette_from: u32,
}

/// The medium one camera sample's path travels through, with the random numbers its
/// tracking draws (their count varies from path to path, so they come from their own seeded
/// stream rather than the sampler's fixed dimensions).
pub struct PathMedium<'m, R: FnMut() -> f64> {
    /// The medium at the sample's time.
    pub medium: WorldMedium<'m>,
    /// Collisions that scatter along one path (1: single scattering).
    pub max_scatterings: u32,
    /// Uniform numbers in [0, 1).
    pub uniform: R,
}

/// Orthonormal basis around a unit normal (Duff et al. 2017, branchless).
#[inline]
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Cosine-weighted direction about `n` and its density `cos / pi`.
#[inline]
pub fn cosine_sample(n: DVec3, u: [f64; 2]) -> (DVec3, f64) {
    let r = u[0].sqrt();
    let (s, c) = sin_cos_turns(u[1]);
    let z = (1.0 - u[0]).max(0.0).sqrt();
    let (t, b) = basis(n);
    // Unit length up to rounding: r^2 + z^2 = 1 over an orthonormal basis.
    let d = t * (r * c) + b * (r * s) + n * z;
    (d, z * FRAC_1_PI)
}

impl PathTracer<'_> {
    fn albedo(&self, hit: &Hit, sphere: &SphereState, footprint: f64, ray: &Ray) -> DVec3 {
        match hit.surface {
            Surface::Floor => self.floor_albedo,
            Surface::Sphere => match &self.shader {
                Shader::Flat(c) => *c,
                shader => {
                    let g = &sphere.geometry;
                    let local = sphere.world_to_object * ((hit.point - g.centre) / g.radius);
                    // The footprint stretches by 1/cos towards the silhouette; the
                    // geometric mean of the two axes keeps the filter isotropic.
                    let cos = hit.normal.dot(ray.dir).abs().max(0.05);
                    shader.albedo(local, footprint / (g.radius * cos.sqrt()))
                }
            },
        }
    }

    /// Radiance along a camera ray; `pixel_angle` is the angle a pixel subtends.
    pub fn radiance(&self, camera_ray: Ray, sphere: &SphereState, sampler: &PixelSampler, pixel_angle: f64) -> DVec3 {
        let first = sphere.geometry.intersect(&camera_ray, None);
        self.radiance_from_hit(camera_ray, first, sphere, sampler, pixel_angle)
    }

    /// Radiance along a camera ray through a participating medium.
    pub fn radiance_in_medium<R: FnMut() -> f64>(
        &self,
        camera_ray: Ray,
        sphere: &SphereState,
        sampler: &PixelSampler,
        pixel_angle: f64,
        medium: &mut PathMedium<'_, R>,
    ) -> DVec3 {
        self.trace(camera_ray, None, sphere, sampler, pixel_angle, Some(medium))
    }

    /// Radiance along a camera ray whose first hit is already known (`None`: it leaves for
    /// the environment): the analytic rasterizer shades the surface point it found with the
    /// tracer's lighting from there on.
    pub fn radiance_from_hit(
        &self,
        camera_ray: Ray,
        first: Option<Hit>,
        sphere: &SphereState,
        sampler: &PixelSampler,
        pixel_angle: f64,
    ) -> DVec3 {
        self.trace::<fn() -> f64>(camera_ray, Some(first), sphere, sampler, pixel_angle, None)
    }

    /// The path: `first` is the camera ray's hit when already known.
    fn trace<R: FnMut() -> f64>(
        &self,
        camera_ray: Ray,
        mut first: Option<Option<Hit>>,
        sphere: &SphereState,
        sampler: &PixelSampler,
        pixel_angle: f64,
        mut medium: Option<&mut PathMedium<'_, R>>,
    ) -> DVec3 {
        let geom = &sphere.geometry;
        let mut ray = camera_ray;
        let mut l = DVec3::ZERO;
        let mut beta = DVec3::ONE;
        let mut skip: Option<Surface> = None;
        let mut prev_bsdf_pdf = 0.0;
        let mut cone_width = 0.0;
        let mut spread = pixel_angle;
        let mut bounce = 0u32;
        let mut scatterings = 0u32;
        // whether the ray leaves a collision in the medium (its sky was sampled there)
        let mut from_medium = false;
        loop {
            let found = match first.take() {
                Some(given) => given,
                None => geom.intersect(&ray, skip),
            };
            if let Some(pm) = medium.as_deref_mut() {
                let t_max = found.as_ref().map_or(f64::INFINITY, |h| h.t);
                if let Some(t) = pm.medium.sample_collision(ray.origin, ray.dir, t_max, &mut pm.uniform) {
                    scatterings += 1;
                    beta *= pm.medium.albedo();
                    if scatterings > pm.max_scatterings || beta == DVec3::ZERO {
                        break;
                    }
                    let x = ray.origin + t * ray.dir;
                    let u = [(pm.uniform)(), (pm.uniform)()];
                    if let Some(s) = self.env.sample(u) {
                        let shadow = Ray { origin: x, dir: s.direction };
                        if s.density > 0.0 && !geom.occluded(&shadow, None) {
                            let tr = pm.medium.transmittance(x, s.direction, f64::INFINITY, &mut pm.uniform);
                            l += beta * self.env.sample_radiance(&s) * (ISOTROPIC / s.pdf() * tr);
                        }
                    }
                    if scatterings == pm.max_scatterings {
                        break;
                    }
                    ray = Ray { origin: x, dir: uniform_sphere([(pm.uniform)(), (pm.uniform)()]) };
                    skip = None;
                    cone_width += t * spread;
                    spread = spread.max(DIFFUSE_SPREAD);
                    from_medium = true;
                    continue;
                }
            }
            let Some(mut hit) = found else {
                if from_medium {
                    break;
                }
                if bounce == 0 {
                    l += beta * self.env.radiance(ray.dir);
                } else {
                    // Power heuristic against the map's density D / J, with one division.
                    let (le, density, jacobian) = self.env.radiance_and_density(ray.dir);
                    let w = if density > 0.0 {
                        let pj = prev_bsdf_pdf * jacobian;
                        pj * pj / (pj * pj + density * density)
                    } else {
                        1.0
                    };
                    l += beta * le * w;
                }
                break;
            };
            from_medium = false;
            if bounce == self.max_bounces {
                break;
            }
            // Both of this vertex's sample values are drawn before any shading: they depend
            // only on the sample index, so their hash chains overlap the shading work.
            let base = dim::BOUNCE_BASE + bounce * dim::PER_BOUNCE;
            let u_light = sampler.get_2d(base + dim::LIGHT);
            let u_bsdf = sampler.get_2d(base + dim::BSDF);
            // Shade the side the ray arrives on. Leaving a plane, or a sphere on its
            // outside, never meets that surface again; leaving the inside of a sphere can.
            let mut leave_skip = Some(hit.surface);
            if hit.normal.dot(ray.dir) > 0.0 {
                hit.normal = -hit.normal;
                if hit.surface == Surface::Sphere {
                    leave_skip = None;
                }
            }
            let footprint = cone_width + hit.t * spread;
            let albedo = self.albedo(&hit, sphere, footprint, &ray);
            // Light sampling: one direction from the map, with a shadow ray.
            if let Some(s) = self.env.sample(u_light) {
                let cos = hit.normal.dot(s.direction);
                if cos > 0.0 {
                    let shadow = spawn_ray(&hit, s.direction);
                    if !geom.occluded(&shadow, leave_skip) {
                        // f cos / p_light x the power heuristic, with p_light = D / J and the
                        // BSDF density b = cos / pi: b D J / (D^2 + b^2 J^2).
                        let b = cos * FRAC_1_PI;
                        let bj = b * s.jacobian;
                        let weight = b * s.density * s.jacobian / (s.density * s.density + bj * bj);
                        let light = beta * albedo * self.env.sample_radiance(&s) * weight;
                        l += match medium.as_deref_mut() {
                            None => light,
                            Some(pm) => {
                                light
                                    * pm.medium.transmittance(shadow.origin, shadow.dir, f64::INFINITY, &mut pm.uniform)
                            }
                        };
                    }
                }
            }
            // BSDF sampling: continues the path; f cos / pdf = albedo.
            let (wi, pdf) = cosine_sample(hit.normal, u_bsdf);
            if pdf <= 0.0 {
                break;
            }
            beta *= albedo;
            bounce += 1;
            if bounce >= self.russian_roulette_from {
                let survive = beta.max_element().clamp(0.05, 1.0);
                if survive < 1.0 {
                    if sampler.get_1d(base + dim::ROULETTE) >= survive {
                        break;
                    }
                    beta /= survive;
                }
            }
            if beta == DVec3::ZERO {
                break;
            }
            ray = spawn_ray(&hit, wi);
            skip = leave_skip;
            prev_bsdf_pdf = pdf;
            cone_width = footprint;
            spread = spread.max(DIFFUSE_SPREAD);
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_samples_are_unit_vectors_in_the_hemisphere() {
        let mut x = 5_u64;
        let mut next = || {
            x = study::seed::splitmix64(x);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..100_000 {
            let n = if i % 3 == 0 {
                DVec3::Y
            } else {
                DVec3::new(next() - 0.5, next() - 0.5, if i % 3 == 1 { -1e-9 } else { next() - 0.5 }).normalize()
            };
            let (d, pdf) = cosine_sample(n, [next(), next()]);
            assert!((d.length() - 1.0).abs() < 1e-14, "{d} {n}");
            assert!(d.dot(n) >= -1e-15 && (pdf - d.dot(n).max(0.0) / std::f64::consts::PI).abs() < 1e-12);
        }
    }
}
