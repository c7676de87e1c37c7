//! Unbiased estimators of a grid medium along a ray, for the f64 reference tracer: free
//! flight by delta tracking and transmittance by ratio tracking (Woodcock et al. 1965;
//! Novák et al. 2014), both against the grid's global majorant. Positions and distances are
//! in the unit cube's coordinates; [`GridMedium::sigma_t`] is the extinction per unit of
//! that length at density 1, so the renderer scales it when it places the cube in the world.
//!
//! The estimators are written once for any [`Medium`]: the grid, and a constant sphere whose
//! closed forms check them.
//!
//! The random numbers come from the caller (`uniform` returns values in [0, 1)), so the
//! tracer's own seeded sampler drives them and frames stay reproducible.

use glam::DVec3;

use crate::grid::DensityGrid;

/// A grid with its optical properties.
#[derive(Debug, Clone, Copy)]
pub struct GridMedium<'a> {
    /// The density grid.
    pub grid: &'a DensityGrid,
    /// Extinction at density 1, per unit-cube length.
    pub sigma_t: f64,
    /// Single-scattering albedo in [0, 1].
    pub albedo: f64,
}

/// The parametric interval of a ray inside the unit cube, if any (`t >= 0`).
pub fn unit_cube_interval(origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
    let inv = direction.recip();
    let t0 = (DVec3::ZERO - origin) * inv;
    let t1 = (DVec3::ONE - origin) * inv;
    let near = t0.min(t1);
    let far = t0.max(t1);
    // a direction component of zero gives +-inf and NaN for an origin on the face: ignore NaN
    let enter = near.x.max(near.y).max(near.z).max(0.0);
    let exit = far.x.min(far.y).min(far.z);
    (exit > enter).then_some((enter, exit))
}

/// What the estimators need of a medium: where a ray is inside it, its extinction at a
/// point, a majorant of that extinction, and its albedo. The grid is the medium blurlab
/// renders; an analytic one (a constant sphere, [`ConstantSphere`]) checks the estimators
/// against closed forms.
pub trait Medium {
    /// The parametric interval (`t >= 0`) of a ray inside the medium's bounds, if any.
    fn interval(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)>;
    /// The extinction coefficient at `p`.
    fn extinction(&self, p: DVec3) -> f64;
    /// An upper bound of the extinction everywhere in the bounds.
    fn majorant(&self) -> f64;
    /// Single-scattering albedo in [0, 1].
    fn albedo(&self) -> f64;

    /// Delta tracking: the distance of the first real collision along the ray within
    /// `[0, t_max]`, or `None` if the ray leaves the interval unscattered.
    fn sample_collision(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_max: f64,
        uniform: &mut impl FnMut() -> f64,
    ) -> Option<f64>
    where
        Self: Sized,
    {
        let mu = self.majorant();
        let (enter, exit) = self.interval(origin, direction)?;
        let exit = exit.min(t_max);
        if mu <= 0.0 || enter >= exit {
            return None;
        }
        let mut t = enter;
        loop {
            t -= (1.0 - uniform()).ln() / mu;
            if t >= exit {
                return None;
            }
            if uniform() * mu < self.extinction(origin + t * direction) {
                return Some(t);
            }
        }
    }

    /// Ratio tracking: an unbiased estimate of the transmittance over `[0, t_max]`.
    fn transmittance(&self, origin: DVec3, direction: DVec3, t_max: f64, uniform: &mut impl FnMut() -> f64) -> f64
    where
        Self: Sized,
    {
        let mu = self.majorant();
        let Some((enter, exit)) = self.interval(origin, direction) else {
            return 1.0;
        };
        let exit = exit.min(t_max);
        if mu <= 0.0 || enter >= exit {
            return 1.0;
        }
        let (mut t, mut tr) = (enter, 1.0);
        loop {
            t -= (1.0 - uniform()).ln() / mu;
            if t >= exit {
                return tr;
            }
            tr *= 1.0 - self.extinction(origin + t * direction) / mu;
            if tr <= 0.0 {
                return 0.0;
            }
        }
    }
}

impl Medium for GridMedium<'_> {
    fn interval(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
        unit_cube_interval(origin, direction)
    }

    fn extinction(&self, p: DVec3) -> f64 {
        self.sigma_t * self.grid.density(p)
    }

    fn majorant(&self) -> f64 {
        self.sigma_t * f64::from(self.grid.max_density())
    }

    fn albedo(&self) -> f64 {
        self.albedo
    }
}

/// A sphere of constant extinction: the analytic medium of the closed-form checks.
#[derive(Debug, Clone, Copy)]
pub struct ConstantSphere {
    /// Centre.
    pub centre: DVec3,
    /// Radius.
    pub radius: f64,
    /// Extinction inside.
    pub sigma_t: f64,
    /// Single-scattering albedo.
    pub albedo: f64,
}

impl Medium for ConstantSphere {
    fn interval(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
        let d = direction.normalize();
        let scale = direction.length();
        let oc = origin - self.centre;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - self.radius * self.radius);
        if disc <= 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let (near, far) = (-b - root, -b + root);
        (far > 0.0).then(|| (near.max(0.0) / scale, far / scale))
    }

    fn extinction(&self, p: DVec3) -> f64 {
        if (p - self.centre).length_squared() <= self.radius * self.radius { self.sigma_t } else { 0.0 }
    }

    fn majorant(&self) -> f64 {
        self.sigma_t
    }

    fn albedo(&self) -> f64 {
        self.albedo
    }
}

impl GridMedium<'_> {
    /// The optical depth over `[0, t_max]` by the midpoint rule with `steps` steps: a
    /// deterministic check for the estimators, not for rendering.
    pub fn optical_depth(&self, origin: DVec3, direction: DVec3, t_max: f64, steps: usize) -> f64 {
        let Some((enter, exit)) = self.interval(origin, direction) else {
            return 0.0;
        };
        let exit = exit.min(t_max);
        if enter >= exit {
            return 0.0;
        }
        let dt = (exit - enter) / steps as f64;
        (0..steps).map(|i| self.extinction(origin + (enter + (i as f64 + 0.5) * dt) * direction) * dt).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn mean_and_error(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
        let xs: Vec<f64> = (0..n).map(|_| f()).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1) as f64;
        (m, (var / n as f64).sqrt())
    }

    #[test]
    fn interval_of_the_cube() {
        let (a, b) = unit_cube_interval(DVec3::new(-1.0, 0.5, 0.5), DVec3::X).unwrap();
        assert!((a - 1.0).abs() < 1e-15 && (b - 2.0).abs() < 1e-15);
        let (a, b) = unit_cube_interval(DVec3::splat(0.5), DVec3::new(1.0, 1.0, 0.0).normalize()).unwrap();
        assert_eq!(a, 0.0);
        assert!((b - 0.5 * 2f64.sqrt()).abs() < 1e-12);
        assert!(unit_cube_interval(DVec3::new(-1.0, 2.0, 0.5), DVec3::X).is_none());
        assert!(unit_cube_interval(DVec3::new(2.0, 0.5, 0.5), DVec3::X).is_none());
    }

    #[test]
    fn homogeneous_slab_transmittance_is_beers_law() {
        // a constant cube crossed along x: T = exp(-sigma * 1), and half way exp(-sigma / 2)
        let grid = DensityGrid::constant([4, 4, 4], 0.5).unwrap();
        let m = GridMedium { grid: &grid, sigma_t: 3.0, albedo: 1.0 };
        let mut rng = Pcg64::seed_from_u64(1);
        let mut u = || rng.random::<f64>();
        for (t_max, expected) in [(10.0, (-1.5f64).exp()), (0.5, (-0.75f64).exp())] {
            let (mean, se) =
                mean_and_error(40_000, || m.transmittance(DVec3::new(0.0, 0.3, 0.6), DVec3::X, t_max, &mut u));
            assert!((mean - expected).abs() < 4.0 * se + 1e-12, "{mean} +- {se} vs {expected}");
            // delta tracking: the escape probability is the same transmittance
            let (escape, se) = mean_and_error(40_000, || {
                f64::from(u8::from(m.sample_collision(DVec3::new(0.0, 0.3, 0.6), DVec3::X, t_max, &mut u).is_none()))
            });
            assert!((escape - expected).abs() < 4.0 * se, "{escape} +- {se} vs {expected}");
        }
    }

    #[test]
    fn collision_distances_are_exponential_in_a_constant_medium() {
        // the mean free path in a medium of extinction 40 is 1/40 (far from the faces)
        let grid = DensityGrid::constant([2, 2, 2], 1.0).unwrap();
        let m = GridMedium { grid: &grid, sigma_t: 40.0, albedo: 1.0 };
        let mut rng = Pcg64::seed_from_u64(2);
        let mut u = || rng.random::<f64>();
        let (mean, se) = mean_and_error(20_000, || {
            m.sample_collision(DVec3::new(0.0, 0.5, 0.5), DVec3::X, 10.0, &mut u).unwrap_or(f64::NAN)
        });
        // exp(-40) of escapes is negligible; the truncation at 1 shifts the mean by ~4e-17
        assert!((mean - 1.0 / 40.0).abs() < 4.0 * se, "{mean} +- {se}");
    }

    #[test]
    fn heterogeneous_transmittance_matches_the_optical_depth() {
        let mut rng = Pcg64::seed_from_u64(3);
        let data =
            (0..6 * 5 * 7).map(|_| if rng.random::<f64>() < 0.4 { 0.0 } else { rng.random::<f32>() * 2.0 }).collect();
        let grid = DensityGrid::new([6, 5, 7], data).unwrap();
        let m = GridMedium { grid: &grid, sigma_t: 2.5, albedo: 0.8 };
        let origin = DVec3::new(-0.2, 0.1, 0.3);
        let direction = DVec3::new(1.0, 0.6, 0.35).normalize();
        let expected = (-m.optical_depth(origin, direction, 10.0, 200_000)).exp();
        let mut u = || rng.random::<f64>();
        let (mean, se) = mean_and_error(40_000, || m.transmittance(origin, direction, 10.0, &mut u));
        assert!(expected > 0.05 && expected < 0.95, "{expected}");
        assert!((mean - expected).abs() < 4.0 * se, "{mean} +- {se} vs {expected}");
    }

    #[test]
    fn an_empty_medium_is_transparent_without_sampling() {
        let grid = DensityGrid::constant([3, 3, 3], 0.0).unwrap();
        let m = GridMedium { grid: &grid, sigma_t: 5.0, albedo: 1.0 };
        let mut calls = 0;
        let mut u = || {
            calls += 1;
            0.5
        };
        assert_eq!(m.transmittance(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 10.0, &mut u), 1.0);
        assert_eq!(m.sample_collision(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 10.0, &mut u), None);
        assert_eq!(calls, 0);
    }
}
