//! The unbiased reference's light transport in a medium (f64): radiance along a ray through
//! a [`Medium`] lit by a distant sky, by delta tracking to the collisions, ratio tracking for
//! the shadow rays, and next-event estimation of the sky at every collision (the sky's own
//! importance sampling, the isotropic phase function). `max_scatterings = 1` is the thesis's
//! single scattering; more orders show what it leaves out (with albedo 1 under a constant sky
//! every order together gives back the sky's radiance: the white furnace).
//!
//! A path that leaves the medium after a collision adds nothing: its light is counted by the
//! next-event estimate at that collision, and the phase function is smooth enough that the
//! sky's sampling alone is a good estimator. The ray that never collides sees what lies
//! behind the medium (`behind`), which the scene supplies (the sky, the sphere or the floor).

use std::f64::consts::PI;

use glam::DVec3;

use crate::tracking::Medium;

/// The isotropic phase function's value.
pub const ISOTROPIC: f64 = 1.0 / (4.0 * PI);

/// Light arriving from infinitely far away.
pub trait Sky {
    /// Radiance arriving from direction `d` (unit length).
    fn radiance(&self, d: DVec3) -> DVec3;
    /// A direction drawn from the sky's sampling density, the radiance from it and that
    /// density (per steradian); `None` where the sky is black.
    fn sample(&self, u: [f64; 2]) -> Option<(DVec3, DVec3, f64)>;
}

/// The same radiance from every direction, sampled uniformly over the sphere.
#[derive(Debug, Clone, Copy)]
pub struct UniformSky(pub DVec3);

/// A uniformly distributed unit vector.
pub fn uniform_sphere(u: [f64; 2]) -> DVec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

impl Sky for UniformSky {
    fn radiance(&self, _d: DVec3) -> DVec3 {
        self.0
    }

    fn sample(&self, u: [f64; 2]) -> Option<(DVec3, DVec3, f64)> {
        (self.0 != DVec3::ZERO).then(|| (uniform_sphere(u), self.0, ISOTROPIC))
    }
}

/// A camera ray up to the first surface it meets.
#[derive(Debug, Clone, Copy)]
pub struct ViewRay {
    /// Origin.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// Distance to the first surface (infinity where the ray sees the sky).
    pub t_max: f64,
}

/// Radiance arriving at the ray's origin through the medium, with `behind` the radiance of
/// what the ray meets at `t_max` (the surface, or the sky).
pub fn radiance(
    medium: &impl Medium,
    sky: &impl Sky,
    ray: ViewRay,
    behind: DVec3,
    max_scatterings: u32,
    uniform: &mut impl FnMut() -> f64,
) -> DVec3 {
    let Some(t) = medium.sample_collision(ray.origin, ray.direction, ray.t_max, uniform) else {
        return behind;
    };
    let mut throughput = DVec3::ONE;
    let mut radiance = DVec3::ZERO;
    let mut x = ray.origin + t * ray.direction;
    for order in 1..=max_scatterings {
        // a real collision scatters with probability albedo: weight instead of killing
        throughput *= medium.albedo();
        if throughput == DVec3::ZERO {
            break;
        }
        if let Some((w, sky_radiance, pdf)) = sky.sample([uniform(), uniform()]) {
            let tr = medium.transmittance(x, w, f64::INFINITY, uniform);
            radiance += throughput * sky_radiance * (ISOTROPIC * tr / pdf);
        }
        if order == max_scatterings {
            break;
        }
        // the next collision along a direction drawn from the phase function; the weight
        // phase / pdf is one
        let w = uniform_sphere([uniform(), uniform()]);
        match medium.sample_collision(x, w, f64::INFINITY, uniform) {
            Some(t) => x += t * w,
            None => break,
        }
    }
    radiance
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;
    use crate::grid::DensityGrid;
    use crate::tracking::{ConstantSphere, GridMedium};

    fn ray(origin: DVec3, direction: DVec3) -> ViewRay {
        ViewRay { origin, direction, t_max: f64::INFINITY }
    }

    fn mean_and_error(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
        let xs: Vec<f64> = (0..n).map(|_| f()).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1) as f64;
        (m, (var / n as f64).sqrt())
    }

    /// Gauss-Legendre nodes and weights on [a, b] (Newton on the Legendre recurrence).
    fn gauss_legendre(n: usize, a: f64, b: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
                let mut dp = 0.0;
                for _ in 0..100 {
                    let (mut p0, mut p1) = (1.0, x);
                    for k in 2..=n {
                        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                        p0 = p1;
                        p1 = p2;
                    }
                    dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                    let dx = p1 / dp;
                    x -= dx;
                    if dx.abs() < 1e-15 {
                        break;
                    }
                }
                let w = 2.0 / ((1.0 - x * x) * dp * dp);
                (0.5 * (b - a) * x + 0.5 * (a + b), 0.5 * (b - a) * w)
            })
            .collect()
    }

    /// Single scattering along a diameter of a constant sphere (radius `r`, extinction `s`,
    /// albedo `a`) under a constant sky `l`, by quadrature: a point at distance `rho` from the
    /// centre sees the sky through `d(mu) = -rho mu + sqrt(R^2 - rho^2 (1 - mu^2))` of medium
    /// in the direction at cosine `mu` to its radius, so its in-scattered radiance is
    /// `a s l / (4 pi) * 2 pi * int exp(-s d(mu)) dmu`; the diameter's radiance adds it up
    /// attenuated, plus the sky straight through.
    fn sphere_single_scattering(r: f64, s: f64, a: f64, l: f64) -> f64 {
        let mus = gauss_legendre(64, -1.0, 1.0);
        let inscatter = |rho: f64| -> f64 {
            let escape: f64 = mus
                .iter()
                .map(|&(mu, w)| w * (-s * (-rho * mu + (r * r - rho * rho * (1.0 - mu * mu)).max(0.0).sqrt())).exp())
                .sum();
            a * s * l * ISOTROPIC * 2.0 * PI * escape
        };
        // the diameter from t = 0 (entry) to 2R: rho = |t - R|; split at the centre so each
        // half is smooth
        let half = |t0: f64, t1: f64| -> f64 {
            gauss_legendre(64, t0, t1).iter().map(|&(t, w)| w * (-s * t).exp() * inscatter((t - r).abs())).sum::<f64>()
        };
        half(0.0, r) + half(r, 2.0 * r) + l * (-2.0 * s * r).exp()
    }

    #[test]
    fn quadrature_is_exact_where_a_closed_form_exists() {
        // int_0^2 exp(-3x) dx and int_-1^1 x^10 dx
        let e: f64 = gauss_legendre(64, 0.0, 2.0).iter().map(|&(x, w)| w * (-3.0 * x).exp()).sum();
        assert!((e - (1.0 - (-6.0f64).exp()) / 3.0).abs() < 1e-14, "{e}");
        let p: f64 = gauss_legendre(64, -1.0, 1.0).iter().map(|&(x, w)| w * x.powi(10)).sum();
        assert!((p - 2.0 / 11.0).abs() < 1e-14, "{p}");
        let r = 0.8;
        // with no extinction the sky comes straight through
        assert!((sphere_single_scattering(r, 0.0, 1.0, 3.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_constant_sphere_single_scatters_the_closed_form_radiance() {
        let sky = UniformSky(DVec3::new(1.0, 2.0, 0.5));
        for (radius, sigma_t, albedo) in [(0.5, 1.0, 0.9), (0.4, 6.0, 0.7), (0.5, 0.2, 1.0)] {
            let sphere = ConstantSphere { centre: DVec3::splat(0.5), radius, sigma_t, albedo };
            let mut rng = Pcg64::seed_from_u64(7);
            let mut u = || rng.random::<f64>();
            let origin = DVec3::new(0.5, 0.5, -2.0);
            let (mean, se) =
                mean_and_error(60_000, || radiance(&sphere, &sky, ray(origin, DVec3::Z), sky.0, 1, &mut u).y);
            let expected = sphere_single_scattering(radius, sigma_t, albedo, sky.0.y);
            assert!(
                (mean - expected).abs() < 4.0 * se,
                "r {radius} s {sigma_t} a {albedo}: {mean} +- {se} vs {expected}"
            );
            // the light lost to absorption and to the second order is visible at this noise
            assert!(expected < sky.0.y);
        }
    }

    #[test]
    fn an_absorbing_slab_passes_beers_law() {
        // albedo 0: nothing scatters, the sky behind is attenuated by exp(-tau)
        let grid = DensityGrid::constant([4, 4, 4], 1.0).unwrap();
        let medium = GridMedium { grid: &grid, sigma_t: 1.7, albedo: 0.0 };
        let sky = UniformSky(DVec3::splat(2.0));
        let mut rng = Pcg64::seed_from_u64(8);
        let mut u = || rng.random::<f64>();
        let (mean, se) = mean_and_error(40_000, || {
            radiance(&medium, &sky, ray(DVec3::new(-1.0, 0.5, 0.5), DVec3::X), sky.0, 4, &mut u).x
        });
        let expected = 2.0 * (-1.7f64).exp();
        assert!((mean - expected).abs() < 4.0 * se, "{mean} +- {se} vs {expected}");
    }

    #[test]
    fn every_order_together_passes_the_white_furnace() {
        // albedo 1 under a constant sky: whatever the density, the radiance is the sky's
        let mut rng = Pcg64::seed_from_u64(9);
        let data = (0..5 * 5 * 5).map(|_| rng.random::<f32>() * 2.0).collect();
        let grid = DensityGrid::new([5, 5, 5], data).unwrap();
        let medium = GridMedium { grid: &grid, sigma_t: 3.0, albedo: 1.0 };
        let sky = UniformSky(DVec3::splat(1.5));
        let mut u = || rng.random::<f64>();
        let origin = DVec3::new(0.5, 0.45, -1.0);
        let (mean, se) =
            mean_and_error(20_000, || radiance(&medium, &sky, ray(origin, DVec3::Z), sky.0, 200, &mut u).x);
        assert!((mean - 1.5).abs() < 4.0 * se + 1e-3, "{mean} +- {se}");
        // single scattering alone loses the higher orders' light
        let (single, se1) =
            mean_and_error(20_000, || radiance(&medium, &sky, ray(origin, DVec3::Z), sky.0, 1, &mut u).x);
        assert!(single + 4.0 * se1 < 1.5, "{single} +- {se1}");
    }

    #[test]
    fn a_surface_before_the_medium_hides_it() {
        let sphere = ConstantSphere { centre: DVec3::new(0.0, 0.0, 5.0), radius: 1.0, sigma_t: 50.0, albedo: 1.0 };
        let sky = UniformSky(DVec3::ONE);
        let mut u = || 0.5;
        let behind = DVec3::new(0.2, 0.3, 0.4);
        assert_eq!(
            radiance(&sphere, &sky, ViewRay { t_max: 3.0, ..ray(DVec3::ZERO, DVec3::Z) }, behind, 1, &mut u),
            behind
        );
    }
}
