//! Motion blur of a medium: the smoke changes between frames, one grid per frame, and with
//! the shutter open a pixel shows the average over the shutter interval.
//!
//! Between two frames the density is interpolated linearly in time (`(1 - w) a + w b`).
//! - The reference draws a time for each path within the shutter and tracks the medium as
//!   it is at that time ([`GridSequence::at`], a [`Medium`] that blends two grids at every
//!   lookup, so no grid is built per sample).
//! - The marcher uses the accumulation buffer ([`march_shutter`]): `n` sub-frames at the
//!   centres of `n` equal parts of the shutter, each marched on its interpolated grid, their
//!   radiance and transmittance averaged. Averaging the density over the shutter and marching
//!   once would be cheaper but wrong: transmittance is convex in the density, so the average
//!   of `exp(-tau)` is not `exp` of the average (a test shows the size of that error).

use glam::DVec3;

use crate::distance::DistanceMap;
use crate::grid::{DensityGrid, GridError};
use crate::march::{MarchLight, MarchMedium, MarchResult, MarchSettings, PixelCamera, march_image};
use crate::tracking::{Medium, unit_cube_interval};

/// A medium's grids, one per frame, all of one size.
#[derive(Debug, Clone)]
pub struct GridSequence {
    frames: Vec<DensityGrid>,
}

impl GridSequence {
    /// A sequence of at least one grid, all of the same dimensions.
    pub fn new(frames: Vec<DensityGrid>) -> Result<Self, GridError> {
        let Some(first) = frames.first() else {
            return Err(GridError::EmptySequence);
        };
        if let Some(other) = frames.iter().find(|g| g.dims() != first.dims()) {
            return Err(GridError::Mismatch { a: first.dims(), b: other.dims() });
        }
        Ok(Self { frames })
    }

    /// The grids.
    pub fn frames(&self) -> &[DensityGrid] {
        &self.frames
    }

    /// The two grids around `time` (in frames: frame `i` is at time `i`) and the weight of
    /// the second; times outside the sequence hold its first or last grid.
    pub fn bracket(&self, time: f64) -> (usize, usize, f64) {
        let last = self.frames.len() - 1;
        if time.is_nan() || time <= 0.0 {
            return (0, 0, 0.0);
        }
        if time >= last as f64 {
            return (last, last, 0.0);
        }
        let i = time.floor() as usize;
        (i, i + 1, time - i as f64)
    }

    /// The medium as it is at `time`, for the reference.
    pub fn at(&self, time: f64, sigma_t: f64, albedo: f64) -> BlendedGridMedium<'_> {
        let (a, b, weight) = self.bracket(time);
        BlendedGridMedium { a: &self.frames[a], b: &self.frames[b], weight, sigma_t, albedo }
    }

    /// The grid at `time`, built by interpolation (for the marcher's sub-frames).
    pub fn grid_at(&self, time: f64) -> DensityGrid {
        let (a, b, weight) = self.bracket(time);
        if weight == 0.0 {
            return self.frames[a].clone();
        }
        // same dimensions by construction
        DensityGrid::lerp(&self.frames[a], &self.frames[b], weight as f32).unwrap_or_else(|_| self.frames[a].clone())
    }
}

/// Two grids blended at every lookup: `(1 - weight) a + weight b`.
#[derive(Debug, Clone, Copy)]
pub struct BlendedGridMedium<'a> {
    /// The earlier frame's grid.
    pub a: &'a DensityGrid,
    /// The later frame's grid.
    pub b: &'a DensityGrid,
    /// The later grid's weight in [0, 1].
    pub weight: f64,
    /// Extinction at density 1, per unit-cube length.
    pub sigma_t: f64,
    /// Single-scattering albedo.
    pub albedo: f64,
}

impl Medium for BlendedGridMedium<'_> {
    fn interval(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
        unit_cube_interval(origin, direction)
    }

    fn extinction(&self, p: DVec3) -> f64 {
        let a = if self.weight < 1.0 { self.a.density(p) } else { 0.0 };
        let b = if self.weight > 0.0 { self.b.density(p) } else { 0.0 };
        self.sigma_t * ((1.0 - self.weight) * a + self.weight * b)
    }

    fn majorant(&self) -> f64 {
        self.sigma_t * f64::from(self.a.max_density().max(self.b.max_density()))
    }

    fn albedo(&self) -> f64 {
        self.albedo
    }
}

/// What [`march_shutter`] marches: the sequence, the shutter and the sub-frames.
#[derive(Debug, Clone, Copy)]
pub struct ShutterMarch<'a> {
    /// The grids.
    pub sequence: &'a GridSequence,
    /// The shutter's open and close times, in frames.
    pub shutter: (f64, f64),
    /// Sub-frames (at least one).
    pub sub_frames: u32,
    /// Extinction at density 1, per unit-cube length.
    pub sigma_t: f32,
    /// Albedo.
    pub albedo: f32,
    /// Colour of alpha compositing.
    pub alpha_colour: glam::Vec3,
    /// Build each sub-frame's distance map and skip empty space with it.
    pub distance_map: bool,
}

/// The accumulation buffer over the shutter: each sub-frame marched on the grid at its time
/// (the centre of its part of the shutter), radiance and transmittance averaged.
pub fn march_shutter(
    what: &ShutterMarch,
    lights: &[MarchLight],
    camera: &PixelCamera,
    size: (u32, u32),
    settings: &MarchSettings,
    use_mask: bool,
) -> Vec<MarchResult> {
    let n = what.sub_frames.max(1);
    let (open, close) = what.shutter;
    let mut sum = vec![MarchResult::default(); (size.0 * size.1) as usize];
    for s in 0..n {
        let time = open + (close - open) * (f64::from(s) + 0.5) / f64::from(n);
        let grid = what.sequence.grid_at(time);
        let map = what.distance_map.then(|| DistanceMap::new(&grid, 0.0));
        let medium = MarchMedium {
            grid: &grid,
            distance: map.as_ref(),
            sigma_t: what.sigma_t,
            albedo: what.albedo,
            alpha_colour: what.alpha_colour,
            voxel_length: MarchMedium::unit_cube_voxel(&grid),
        };
        for (acc, r) in sum.iter_mut().zip(march_image(&medium, lights, camera, size, settings, use_mask)) {
            acc.radiance += r.radiance;
            acc.transmittance += r.transmittance;
            acc.primary_lookups += r.primary_lookups;
            acc.shadow_lookups += r.shadow_lookups;
        }
    }
    let inv = 1.0 / n as f32;
    for acc in &mut sum {
        acc.radiance *= inv;
        acc.transmittance *= inv;
    }
    sum
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;
    use crate::march::LightingModel;
    use crate::scatter::{UniformSky, ViewRay, radiance};

    /// Smoke that appears during the shutter: empty at frame 0, density 1 at frame 1.
    fn appearing() -> GridSequence {
        GridSequence::new(vec![
            DensityGrid::constant([4, 4, 4], 0.0).unwrap(),
            DensityGrid::constant([4, 4, 4], 1.0).unwrap(),
        ])
        .unwrap()
    }

    fn settings() -> MarchSettings {
        MarchSettings {
            step: 1.0 / 64.0,
            model: LightingModel::PrimaryAndShadowRays,
            threshold: 0.0,
            shade_empty: false,
        }
    }

    #[test]
    fn a_sequence_keeps_one_size_and_holds_its_ends() {
        let a = DensityGrid::constant([2, 2, 2], 0.0).unwrap();
        let b = DensityGrid::constant([3, 2, 2], 0.0).unwrap();
        assert!(matches!(GridSequence::new(vec![a.clone(), b]), Err(GridError::Mismatch { .. })));
        assert!(matches!(GridSequence::new(Vec::new()), Err(GridError::EmptySequence)));
        let s = appearing();
        assert_eq!(s.bracket(-1.0), (0, 0, 0.0));
        assert_eq!(s.bracket(f64::NAN), (0, 0, 0.0));
        assert_eq!(s.bracket(0.25), (0, 1, 0.25));
        assert_eq!(s.bracket(7.0), (1, 1, 0.0));
        let m = s.at(0.25, 2.0, 1.0);
        assert!((m.extinction(DVec3::splat(0.5)) - 0.5).abs() < 1e-12);
        assert_eq!(s.grid_at(0.25).voxel(1, 1, 1), 0.25);
    }

    #[test]
    fn the_reference_averages_transmittance_over_the_shutter() {
        // density rising from 0 to 1 over the shutter, a ray crossing the cube: the mean
        // transmittance is int_0^1 exp(-sigma s) ds = (1 - exp(-sigma)) / sigma
        let sigma = 3.0;
        let s = appearing();
        let mut rng = Pcg64::seed_from_u64(11);
        let sky = UniformSky(DVec3::ONE);
        let n = 40_000;
        let ray = ViewRay { origin: DVec3::new(-1.0, 0.5, 0.5), direction: DVec3::X, t_max: f64::INFINITY };
        let samples: Vec<f64> = (0..n)
            .map(|_| {
                let time = rng.random::<f64>();
                let medium = s.at(time, sigma, 0.0);
                let mut u = || rng.random::<f64>();
                radiance(&medium, &sky, ray, DVec3::ONE, 1, &mut u).x
            })
            .collect();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let se = (samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n * (n - 1)) as f64).sqrt();
        let expected = (1.0 - (-sigma).exp()) / sigma;
        assert!((mean - expected).abs() < 4.0 * se, "{mean} +- {se} vs {expected}");
    }

    #[test]
    fn the_accumulation_buffer_converges_where_averaged_density_does_not() {
        let sigma = 3.0f32;
        let s = appearing();
        let camera = PixelCamera::look_at(Vec3::new(0.5, 0.5, -1.5), Vec3::splat(0.5), 0.1, 1, 1);
        let expected = (1.0 - (-f64::from(sigma)).exp()) / f64::from(sigma);
        let transmittance = |sub_frames: u32, shutter: (f64, f64)| {
            let what = ShutterMarch {
                sequence: &s,
                shutter,
                sub_frames,
                sigma_t: sigma,
                albedo: 0.9,
                alpha_colour: Vec3::ONE,
                distance_map: true,
            };
            f64::from(march_shutter(&what, &[], &camera, (1, 1), &settings(), true)[0].transmittance)
        };
        let errors: Vec<f64> =
            [1, 2, 4, 8, 16].iter().map(|&n| (transmittance(n, (0.0, 1.0)) - expected).abs()).collect();
        assert!(errors.windows(2).all(|e| e[1] < e[0]), "{errors:?}");
        assert!(errors[4] < 1e-3, "{errors:?}");
        // one march at the shutter's mean density: exp(-sigma / 2), far off
        let averaged = transmittance(1, (0.5, 0.5));
        assert!((averaged - (-1.5f64).exp()).abs() < 1e-4, "{averaged}");
        assert!((averaged - expected).abs() > 0.09);
        // a closed shutter is the frame at its time
        assert!((transmittance(8, (1.0, 1.0)) - (-f64::from(sigma)).exp()).abs() < 1e-4);
    }
}
