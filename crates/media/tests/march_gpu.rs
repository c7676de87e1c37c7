//! The WGSL marcher against its CPU twin (`media::march`): the validity mask's first segment
//! per pixel and each pixel's radiance and transmittance, for the three lighting models with
//! and without the two accelerations, on a simulated plume. Runs on lavapipe in CI
//! (`BLURLAB_REQUIRE_GPU=1` makes a missing adapter a failure).

use glam::Vec3;
use media::gpu::GpuMarcher;
use media::march::{LightingModel, MarchLight, MarchMedium, MarchSettings, PixelCamera, first_segment, march_image};
use media::{DistanceMap, SmokeSettings, SmokeSimulation};

#[test]
fn gpu_marcher_matches_its_cpu_twin() {
    let Some(ctx) = gpu::test_context("gpu_marcher_matches_its_cpu_twin") else { return };
    let marcher = GpuMarcher::new(ctx).expect("the marcher's pipelines");
    let mut sim = SmokeSimulation::new(SmokeSettings { resolution: [20, 28, 20], ..SmokeSettings::default() }).unwrap();
    for _ in 0..22 {
        sim.step();
    }
    let grid = sim.density();
    let map = DistanceMap::new(&grid, 0.0);
    let lights = [
        MarchLight { direction: Vec3::new(0.2, 0.9, 0.3).normalize(), irradiance: Vec3::new(3.0, 2.6, 2.1) },
        MarchLight { direction: Vec3::new(-0.7, 0.1, 0.7).normalize(), irradiance: Vec3::new(0.3, 0.4, 0.6) },
        MarchLight { direction: Vec3::new(0.0, -1.0, 0.0), irradiance: Vec3::new(0.1, 0.1, 0.08) },
    ];
    let (w, h) = (40, 36);
    let camera = PixelCamera::look_at(Vec3::new(0.4, 0.6, -1.4), Vec3::new(0.5, 0.45, 0.5), 0.9, w, h);
    let plain = MarchMedium {
        grid: &grid,
        distance: None,
        sigma_t: 25.0,
        albedo: 0.85,
        alpha_colour: Vec3::splat(0.6),
        voxel_length: MarchMedium::unit_cube_voxel(&grid),
    };
    let skipping = MarchMedium { distance: Some(&map), ..plain };
    for model in [LightingModel::AlphaCompositing, LightingModel::PrimaryRays, LightingModel::PrimaryAndShadowRays] {
        // the thesis's way (light every segment) for one model, the density test for the others
        let shade_empty = model == LightingModel::PrimaryAndShadowRays;
        let settings = MarchSettings { step: 1.0 / 48.0, model, threshold: 0.0, shade_empty };
        for (medium, use_mask) in [(&plain, false), (&plain, true), (&skipping, true)] {
            let what = format!("{model:?}, mask {use_mask}, distance map {}", medium.distance.is_some());
            let volume = marcher.upload(medium);
            let gpu =
                marcher.render(&volume, medium, &lights, &camera, (w, h), &settings, use_mask).expect("the passes");
            let cpu = march_image(medium, &lights, &camera, (w, h), &settings, use_mask);
            let (mut lit, mut mask_differs) = (0, 0);
            for (n, (g, c)) in gpu.pixels.iter().zip(&cpu).enumerate() {
                let radiance = Vec3::new(g[0], g[1], g[2]);
                let scale = c.radiance.max_element().max(1e-3);
                assert!(
                    (radiance - c.radiance).abs().max_element() <= 2e-3 * scale + 1e-6,
                    "{what}: pixel {n}: GPU {radiance} vs CPU {}",
                    c.radiance
                );
                assert!((g[3] - c.transmittance).abs() <= 1e-4, "{what}: pixel {n}: T {} vs {}", g[3], c.transmittance);
                lit += usize::from(c.transmittance < 0.999);
                if use_mask {
                    let mut lookups = 0;
                    let cpu_first = first_segment(
                        medium,
                        camera.eye,
                        camera.ray(n as u32 % w, n as u32 / w),
                        &settings,
                        &mut lookups,
                    )
                    .map_or(-1, |i| i as i32);
                    mask_differs += usize::from(cpu_first != gpu.mask[n]);
                }
            }
            assert!(lit > 50, "{what}: the plume should cover part of the image ({lit} pixels)");
            // a density exactly at a lattice point may round to the other side on the GPU
            assert!(mask_differs * 200 <= (w * h) as usize, "{what}: {mask_differs} mask pixels differ");
        }
    }
}
