//! The WGSL marcher against its CPU twin (`media::march`): the validity mask's first segment
//! per pixel and each pixel's radiance and transmittance, for the three lighting models with
//! and without the two accelerations, on a simulated plume. Runs on lavapipe in CI
//! (`BLURLAB_REQUIRE_GPU=1` makes a missing adapter a failure).

use glam::Vec3;
use media::gpu::GpuMarcher;
use media::march::{
    LightingModel, MarchLight, MarchMedium, MarchSettings, NO_LIMIT, PixelCamera, SurfacePoint, SurfaceRay,
    first_segment, march, march_image, march_surface_ray,
};
use media::{DistanceMap, SmokeSettings, SmokeSimulation};

/// The marcher's pipelines, a simulated plume and its distance map.
fn marcher_and_plume(ctx: gpu::GpuContext) -> (GpuMarcher, media::DensityGrid, DistanceMap) {
    let marcher = GpuMarcher::new(ctx).expect("the marcher's pipelines");
    let mut sim = SmokeSimulation::new(SmokeSettings { resolution: [20, 28, 20], ..SmokeSettings::default() })
        .expect("the simulation settings");
    for _ in 0..22 {
        sim.step();
    }
    let grid = sim.density();
    let map = DistanceMap::new(&grid, 0.0);
    (marcher, grid, map)
}

/// A GPU pixel (radiance, transmittance) against its twin's: radiance within 0.2 % of the
/// brighter channel, transmittance within 1e-4.
fn assert_pixel_agrees(g: &[f32; 4], c: &media::MarchResult, what: &str) {
    let radiance = Vec3::new(g[0], g[1], g[2]);
    let scale = c.radiance.max_element().max(1e-3);
    assert!(
        (radiance - c.radiance).abs().max_element() <= 2e-3 * scale + 1e-6,
        "{what}: GPU {radiance} vs CPU {}",
        c.radiance
    );
    assert!((g[3] - c.transmittance).abs() <= 1e-4, "{what}: T {} vs {}", g[3], c.transmittance);
}

#[test]
fn gpu_marcher_matches_its_cpu_twin() {
    let Some(ctx) = gpu::test_context("gpu_marcher_matches_its_cpu_twin") else { return };
    let (marcher, grid, map) = marcher_and_plume(ctx);
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
                assert_pixel_agrees(g, c, &format!("{what}: pixel {n}"));
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

/// The first hit of `(origin, direction)` on a floor at `y = floor` or a sphere, with the
/// surface's point and upward or outward normal.
fn first_surface(origin: Vec3, direction: Vec3, floor: f32, centre: Vec3, radius: f32) -> Option<(f32, SurfacePoint)> {
    let mut best: Option<(f32, Vec3)> = None;
    if direction.y < 0.0 {
        let t = (floor - origin.y) / direction.y;
        if t > 0.0 {
            best = Some((t, Vec3::Y));
        }
    }
    let oc = origin - centre;
    let (a, b, c) = (direction.dot(direction), oc.dot(direction), oc.dot(oc) - radius * radius);
    let disc = b * b - a * c;
    if disc > 0.0 {
        let t = (-b - disc.sqrt()) / a;
        if t > 0.0 && best.is_none_or(|(tb, _)| t < tb) {
            best = Some((t, (origin + t * direction - centre).normalize()));
        }
    }
    best.map(|(t, normal)| (t, SurfacePoint { point: origin + t * direction, normal }))
}

#[test]
fn gpu_marcher_along_surface_rays_matches_its_cpu_twin() {
    let Some(ctx) = gpu::test_context("gpu_marcher_along_surface_rays_matches_its_cpu_twin") else { return };
    let (marcher, grid, map) = marcher_and_plume(ctx);
    // lights in the cube's frame (a box of 0.5 x 0.8 x 0.5 m: directions scaled by its
    // inverse size, not renormalised) and in the world
    let inv_size = Vec3::new(2.0, 1.25, 2.0);
    let world =
        [Vec3::new(0.2, 0.9, 0.3).normalize(), Vec3::new(-0.7, 0.1, 0.7).normalize(), Vec3::new(0.0, -1.0, 0.0)];
    let irradiance = [Vec3::new(3.0, 2.6, 2.1), Vec3::new(0.3, 0.4, 0.6), Vec3::new(0.1, 0.1, 0.08)];
    let lights: Vec<MarchLight> =
        world.iter().zip(irradiance).map(|(w, e)| MarchLight { direction: *w * inv_size, irradiance: e }).collect();
    let (w, h) = (40, 36);
    let camera = PixelCamera::look_at(Vec3::new(0.4, 0.6, -1.4), Vec3::new(0.5, 0.35, 0.5), 1.0, w, h);
    // a floor just above the plume's source and a sphere in the plume
    let rays: Vec<SurfaceRay> = (0..w * h)
        .map(|n| {
            let direction = camera.ray(n % w, n / w) * inv_size;
            let hit = first_surface(camera.eye, direction, 0.06, Vec3::new(0.55, 0.3, 0.45), 0.08);
            SurfaceRay {
                origin: camera.eye,
                direction,
                limit: hit.map_or(NO_LIMIT, |(t, _)| t),
                surface: hit.map(|(_, s)| s),
            }
        })
        .collect();
    let plain = MarchMedium {
        grid: &grid,
        distance: None,
        sigma_t: 12.0,
        albedo: 0.85,
        alpha_colour: Vec3::splat(0.6),
        voxel_length: 0.8 / 28.0,
    };
    let skipping = MarchMedium { distance: Some(&map), ..plain };
    for model in [LightingModel::AlphaCompositing, LightingModel::PrimaryRays, LightingModel::PrimaryAndShadowRays] {
        let settings = MarchSettings { step: 0.02, model, threshold: 0.0, shade_empty: false };
        for (medium, use_mask) in [(&plain, false), (&skipping, true)] {
            let what = format!("{model:?}, mask {use_mask}, distance map {}", medium.distance.is_some());
            let volume = marcher.upload(medium);
            let gpu = marcher
                .render_rays(&volume, medium, &lights, &world, &rays, (w, h), &settings, use_mask)
                .expect("the passes");
            let (mut lit, mut cut, mut shadowed) = (0, 0, 0);
            for (n, ray) in rays.iter().enumerate() {
                let (c, c_shadow) = march_surface_ray(medium, &lights, &world, ray, &settings, use_mask);
                assert_pixel_agrees(&gpu.pixels[n], &c, &format!("{what}: pixel {n}"));
                let g_shadow = Vec3::from_array(gpu.surface_shadow[n]);
                assert!(
                    (g_shadow - c_shadow).abs().max_element() <= 1e-4,
                    "{what}: pixel {n}: surface shadow GPU {g_shadow} vs CPU {c_shadow}"
                );
                lit += usize::from(c.transmittance < 0.999);
                shadowed += usize::from(c_shadow.min_element() < 0.95);
                // the surface hides smoke behind it: the unlimited ray sees more
                let whole = march(medium, &lights, ray.origin, ray.direction, &settings, use_mask);
                cut += usize::from(whole.transmittance < c.transmittance - 0.01);
            }
            assert!(lit > 50, "{what}: the plume should cover part of the image ({lit} pixels)");
            assert!(cut > 10, "{what}: the surfaces should hide some smoke ({cut} pixels)");
            if model == LightingModel::PrimaryAndShadowRays {
                assert!(shadowed > 10, "{what}: the smoke should shadow some surface ({shadowed} pixels)");
            } else {
                assert_eq!(shadowed, 0, "{what}: only shadow rays shadow the surfaces");
            }
        }
    }
}
