//! The thesis's Table 2.1, redone: frames per second of the marcher for each data set,
//! lighting model and acceleration (brute force, validity mask, mask and distance map), on
//! the CPU twin and, where a device is open, on the GPU, with the speed-ups against brute
//! force and the work behind them (density lookups, marched pixels). The camera frames the
//! medium's box so that it covers about half the image, as in the thesis.

use std::time::Instant;

use glam::Vec3;

use crate::distance::DistanceMap;
use crate::gpu::GpuMarcher;
use crate::grid::{DensityGrid, GridError};
use crate::march::{LightingModel, MarchLight, MarchMedium, MarchSettings, PixelCamera, march_image};
use crate::smoke::{SettingError, SmokeSettings, SmokeSimulation};

/// Which of the thesis's accelerations are on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acceleration {
    /// Every pixel marched from the box's entry, every segment looked at.
    BruteForce,
    /// The validity mask: only pixels with density are marched, from their first segment.
    Mask,
    /// The mask, and the distance map on primary and shadow rays.
    MaskAndDistance,
}

impl Acceleration {
    /// All three, in Table 2.1's order.
    pub const ALL: [Acceleration; 3] = [Acceleration::BruteForce, Acceleration::Mask, Acceleration::MaskAndDistance];

    /// The name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Acceleration::BruteForce => "brute force",
            Acceleration::Mask => "mask",
            Acceleration::MaskAndDistance => "mask + distance",
        }
    }
}

/// The lighting model's name in reports.
pub fn model_name(model: LightingModel) -> &'static str {
    match model {
        LightingModel::AlphaCompositing => "alpha",
        LightingModel::PrimaryRays => "primary",
        LightingModel::PrimaryAndShadowRays => "self shadows",
    }
}

/// What a run measures.
#[derive(Debug, Clone)]
pub struct BenchSetup {
    /// Image width and height.
    pub size: (u32, u32),
    /// Segment length in unit-cube lengths.
    pub step: f32,
    /// Extinction at density 1 per unit-cube length.
    pub sigma_t: f32,
    /// Albedo.
    pub albedo: f32,
    /// The lights.
    pub lights: Vec<MarchLight>,
    /// Timed runs per case (the fastest counts).
    pub rounds: u32,
    /// Whether to time the CPU twin too.
    pub cpu: bool,
    /// Light every segment, empty or not, as the thesis's shader does (its brute force).
    pub shade_empty: bool,
}

/// One row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchRow {
    /// The data set's name.
    pub data_set: String,
    /// The lighting model.
    pub model: LightingModel,
    /// The accelerations.
    pub acceleration: Acceleration,
    /// Fastest CPU-twin seconds per frame.
    pub cpu_seconds: Option<f64>,
    /// Fastest GPU seconds per frame.
    pub gpu_seconds: Option<f64>,
    /// The clock the GPU's time was read from.
    pub gpu_clock: Option<gpu::TimingSource>,
    /// Density lookups on primary rays and in the mask.
    pub primary_lookups: u64,
    /// Density lookups on shadow rays.
    pub shadow_lookups: u64,
    /// Pixels whose ray meets density.
    pub pixels_with_medium: u64,
}

/// Why the table's data sets cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum DataSetError {
    /// The simulation refused its settings.
    #[error("smoke simulation: {0}")]
    Smoke(#[from] SettingError),
    /// The plume could not be resampled.
    #[error("resampling the plume: {0}")]
    Grid(#[from] GridError),
}

/// The table's two data sets from one simulated plume: `resolution`^3 cells run for `steps`
/// steps, resampled to the thesis's two shapes, 128x128x128 (its simulated data set ii) and
/// 256x256x64 (the shape of its scanned data set i).
pub fn table_data_sets(resolution: usize, steps: u32) -> Result<Vec<(String, DensityGrid)>, DataSetError> {
    let mut sim = SmokeSimulation::new(SmokeSettings { resolution: [resolution; 3], ..SmokeSettings::default() })?;
    for _ in 0..steps {
        sim.step();
    }
    let plume = sim.density();
    Ok(vec![
        ("ii 128x128x128".to_string(), plume.resample([128, 128, 128])?),
        ("i-shape 256x256x64".to_string(), plume.resample([256, 256, 64])?),
    ])
}

/// The camera of the table: the box's centre from the front, covering about half the image.
pub fn table_camera(size: (u32, u32)) -> PixelCamera {
    PixelCamera::look_at(Vec3::new(0.5, 0.5, -1.95), Vec3::splat(0.5), 0.7, size.0, size.1)
}

/// The fraction of pixels whose ray meets the box.
pub fn box_coverage(camera: &PixelCamera, size: (u32, u32)) -> f64 {
    let n = size.0 * size.1;
    let hits = (0..n)
        .filter(|p| crate::march::cube_interval(camera.eye, camera.ray(p % size.0, p / size.0)).is_some())
        .count();
    hits as f64 / f64::from(n)
}

/// Runs every lighting model and acceleration on every data set; `progress` hears each
/// finished row.
pub fn run(
    data_sets: &[(String, &DensityGrid)],
    setup: &BenchSetup,
    gpu: Option<&GpuMarcher>,
    mut progress: impl FnMut(&BenchRow),
) -> Result<Vec<BenchRow>, gpu::GpuError> {
    let camera = table_camera(setup.size);
    let mut rows = Vec::new();
    for (name, grid) in data_sets {
        let map = DistanceMap::new(grid, 0.0);
        let plain = MarchMedium {
            grid,
            distance: None,
            sigma_t: setup.sigma_t,
            albedo: setup.albedo,
            alpha_colour: Vec3::splat(setup.albedo * 0.5),
            voxel_length: MarchMedium::unit_cube_voxel(grid),
        };
        let skipping = MarchMedium { distance: Some(&map), ..plain };
        let plain_volume = gpu.map(|g| g.upload(&plain));
        let skipping_volume = gpu.map(|g| g.upload(&skipping));
        for model in [LightingModel::AlphaCompositing, LightingModel::PrimaryRays, LightingModel::PrimaryAndShadowRays]
        {
            let settings = MarchSettings { step: setup.step, model, threshold: 0.0, shade_empty: setup.shade_empty };
            for acceleration in Acceleration::ALL {
                let (medium, volume, use_mask) = match acceleration {
                    Acceleration::BruteForce => (&plain, plain_volume.as_ref(), false),
                    Acceleration::Mask => (&plain, plain_volume.as_ref(), true),
                    Acceleration::MaskAndDistance => (&skipping, skipping_volume.as_ref(), true),
                };
                let mut cpu_best = f64::INFINITY;
                let mut pixels = Vec::new();
                if setup.cpu {
                    for _ in 0..setup.rounds.max(1) {
                        let started = Instant::now();
                        pixels = march_image(medium, &setup.lights, &camera, setup.size, &settings, use_mask);
                        cpu_best = cpu_best.min(started.elapsed().as_secs_f64());
                    }
                } else {
                    // the work counts come from the twin; one untimed run
                    pixels = march_image(medium, &setup.lights, &camera, setup.size, &settings, use_mask);
                }
                let mut gpu_best = None;
                let mut gpu_clock = None;
                if let (Some(g), Some(v)) = (gpu, volume) {
                    // one warm-up run compiles and uploads what the driver defers
                    g.render(v, medium, &setup.lights, &camera, setup.size, &settings, use_mask)?;
                    for _ in 0..setup.rounds.max(1) {
                        let r = g.render(v, medium, &setup.lights, &camera, setup.size, &settings, use_mask)?;
                        gpu_best = Some(gpu_best.map_or(r.seconds, |b: f64| b.min(r.seconds)));
                        gpu_clock = Some(r.timing_source);
                    }
                }
                let row = BenchRow {
                    data_set: name.clone(),
                    model,
                    acceleration,
                    cpu_seconds: setup.cpu.then_some(cpu_best),
                    gpu_seconds: gpu_best,
                    gpu_clock,
                    primary_lookups: pixels.iter().map(|p| u64::from(p.primary_lookups)).sum(),
                    shadow_lookups: pixels.iter().map(|p| u64::from(p.shadow_lookups)).sum(),
                    pixels_with_medium: pixels.iter().filter(|p| p.transmittance < 1.0).count() as u64,
                };
                progress(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// Bytes the marcher holds for a grid of `dims` and an image of `size`: density and
/// distance map (4 bytes a voxel each), the mask (4 bytes a pixel) and the output (16).
pub fn memory_bytes(dims: [usize; 3], size: (u32, u32)) -> (u64, u64) {
    let voxels = (dims[0] * dims[1] * dims[2]) as u64;
    let pixels = u64::from(size.0) * u64::from(size.1);
    (8 * voxels, 20 * pixels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::smoke::{SmokeSettings, SmokeSimulation};

    #[test]
    fn the_table_counts_less_work_with_each_acceleration() {
        let mut sim =
            SmokeSimulation::new(SmokeSettings { resolution: [16, 24, 16], ..SmokeSettings::default() }).unwrap();
        for _ in 0..20 {
            sim.step();
        }
        let grid = sim.density();
        let setup = BenchSetup {
            size: (24, 24),
            step: 1.0 / 32.0,
            sigma_t: 20.0,
            albedo: 0.9,
            lights: vec![MarchLight { direction: Vec3::Y, irradiance: Vec3::ONE }],
            rounds: 1,
            cpu: true,
            shade_empty: true,
        };
        let rows = run(&[("plume".into(), &grid)], &setup, None, |_| {}).unwrap();
        assert_eq!(rows.len(), 9);
        for model in rows.chunks(3) {
            let work = |r: &BenchRow| r.primary_lookups + r.shadow_lookups;
            assert!(work(&model[2]) < work(&model[0]), "{:?}", model);
            // the same image whatever the acceleration
            assert!(model.iter().all(|r| r.pixels_with_medium == model[0].pixels_with_medium));
            assert!(model[0].pixels_with_medium > 0);
        }
        let cover = box_coverage(&table_camera((64, 64)), (64, 64));
        assert!((0.35..0.65).contains(&cover), "the box should cover about half the image: {cover}");
        assert_eq!(memory_bytes([128, 128, 128], (512, 512)), (16_777_216, 5_242_880));
    }
}
