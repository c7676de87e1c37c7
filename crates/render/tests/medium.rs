//! The reference tracer with a participating medium (issue 27) in the study's scene types:
//! a medium of zero density changes no byte, an absorbing slab shadows the floor by the
//! closed form `2 E3(tau)`, the white furnace holds with a scattering medium of albedo 1,
//! renders are deterministic, a bad grid file is named, and every renderer that cannot
//! render a medium says so instead of leaving it out. The marcher method composites its f32
//! march over the tracer's surfaces: byte for byte the tracer's frame without density, the
//! closed form of an opaque medium, accelerations that change no byte, the smoke's shadow on
//! the floor with shadow rays only, agreement with the unbiased reference, and the same frame
//! from a GPU renderer (the GPU marcher) as from the CPU.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

mod common;

use std::path::Path;

use common::*;
use glam::DVec3;
use media::DensityGrid;
use render::env::EnvironmentMap;
use render::io::LinearImage;
use render::methods::tracer::render_frame;
use render::{RenderError, Renderer};
use study::medium::{GridSource, SceneMedium};
use study::scene::{Camera, FrameScene, Integrator};

/// A one-grid medium from `blurlab-grid/1` files written in `dir`.
fn medium_of(
    dir: &Path,
    grid: &DensityGrid,
    centre: [f64; 3],
    size: [f64; 3],
    extinction: f64,
    albedo: f64,
) -> SceneMedium {
    media::grid_file::write(grid, &dir.join("d-0.grid")).unwrap();
    SceneMedium {
        grids: GridSource::Files { pattern: dir.join("d-#.grid") },
        centre,
        size,
        extinction,
        albedo,
        max_scatterings: 1,
        fps: 30.0,
        frame_time_offset: 0.5,
        grid_frames: [0, 0],
    }
}

fn render(scene: &FrameScene) -> Vec<LinearImage> {
    let env = EnvironmentMap::from_lighting(&scene.lighting).unwrap();
    let out = render_frame(scene, &env).unwrap();
    assert_eq!(out.nonfinite_samples, 0);
    out.eyes
}

fn mean_and_se(img: &LinearImage) -> (f64, f64) {
    let values: Vec<f64> = img.pixels.iter().map(|p| f64::from(p[0])).collect();
    let s = study::stats::Summary::of(&values);
    (s.mean, s.standard_error())
}

/// E3(tau) = int_1^inf exp(-tau t) / t^3 dt, by the substitution t = 1/u on a fine midpoint rule.
fn e3(tau: f64) -> f64 {
    let n = 200_000;
    (0..n).map(|i| (i as f64 + 0.5) / n as f64).map(|u| u * (-tau / u).exp()).sum::<f64>() / n as f64
}

#[test]
fn the_box_is_placed_and_stretched_and_distances_are_metres() {
    use media::shutter::GridSequence;
    use media::tracking::Medium;
    use render::volume::{MediumGrids, WorldMedium};
    // a constant grid in a 2 m x 1 m x 4 m box centred at (0, 1, 0)
    let grids = MediumGrids {
        first_frame: 0,
        sequence: GridSequence::new(vec![DensityGrid::constant([2, 3, 4], 0.5).unwrap()]).unwrap(),
    };
    let medium = SceneMedium {
        grids: GridSource::Files { pattern: "x-#.grid".into() },
        centre: [0.0, 1.0, 0.0],
        size: [2.0, 1.0, 4.0],
        extinction: 3.0,
        albedo: 0.7,
        max_scatterings: 1,
        fps: 30.0,
        frame_time_offset: 0.5,
        grid_frames: [0, 0],
    };
    let m = WorldMedium::at(&medium, &grids, 0.0);
    // along x through the centre: enters at x = -1, leaves at x = 1
    let (a, b) = m.interval(DVec3::new(-5.0, 1.0, 0.0), DVec3::X).unwrap();
    assert!((a - 4.0).abs() < 1e-12 && (b - 6.0).abs() < 1e-12, "{a} {b}");
    // along z: 4 m of it
    let (a, b) = m.interval(DVec3::new(0.0, 1.0, -9.0), DVec3::Z).unwrap();
    assert!((b - a - 4.0).abs() < 1e-12);
    // above the box: nothing
    assert!(m.interval(DVec3::new(-5.0, 1.6, 0.0), DVec3::X).is_none());
    assert_eq!(m.extinction(DVec3::new(0.3, 1.2, -1.5)), 1.5);
    assert_eq!(m.extinction(DVec3::new(0.3, 1.6, -1.5)), 0.0);
    assert_eq!((m.majorant(), m.albedo()), (1.5, 0.7));
    // transmittance along 2 m at 1.5 per metre, by ratio tracking's mean
    let mut x = 1_u64;
    let mut u = || {
        x = study::seed::splitmix64(x);
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let n = 20_000;
    let mean =
        (0..n).map(|_| m.transmittance(DVec3::new(-5.0, 1.0, 0.0), DVec3::X, f64::INFINITY, &mut u)).sum::<f64>()
            / f64::from(n);
    assert!((mean - (-3.0f64).exp()).abs() < 0.005, "{mean}");
}

#[test]
fn a_medium_of_zero_density_changes_no_byte() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = furnace_scene();
    s.samples_per_pixel = 4;
    let plain = render(&s);
    s.medium = Some(medium_of(
        dir.path(),
        &DensityGrid::constant([3, 2, 4], 0.0).unwrap(),
        [0.0, 0.1, 0.0],
        [1.0; 3],
        50.0,
        0.5,
    ));
    assert_eq!(render(&s), plain);
}

#[test]
fn an_absorbing_slab_shadows_the_floor_by_the_closed_form() {
    // The camera looks down at a floor of albedo rho from under a wide horizontal slab that
    // absorbs (albedo 0) with optical depth tau across; the sky is uniform. The floor's
    // irradiance is 2 pi L E3(tau), so its radiance is 2 rho L E3(tau): both the shadow
    // rays' ratio tracking and the continued paths' delta tracking must carry it.
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.5;
    for tau in [0.5, 1.5] {
        let mut s = scene(
            Camera::look_at(DVec3::new(0.0, 0.3, 0.0), DVec3::new(0.0, 0.0, -0.05), 0.05, 0.036, 24, 16),
            flat(rho),
            uniform(L),
            64,
        );
        s.sphere.start = DVec3::new(0.0, 0.1, 1.0e4);
        s.floor.albedo = [rho; 3];
        s.integrator = Integrator { max_bounces: 1, russian_roulette_from: 3 };
        let slab = DensityGrid::constant([1, 1, 1], 1.0).unwrap();
        s.medium = Some(medium_of(dir.path(), &slab, [0.0, 0.55, 0.0], [2000.0, 0.1, 2000.0], tau / 0.1, 0.0));
        let (mean, se) = mean_and_se(&render(&s)[0]);
        let expected = 2.0 * rho * L * e3(tau);
        assert!((mean - expected).abs() < 4.0 * se + 1e-4, "tau {tau}: floor {mean} +- {se}, closed form {expected}");
        assert!(expected < 0.6 * rho * L, "the slab must visibly shadow the floor");
    }
}

#[test]
fn the_white_furnace_holds_with_a_scattering_medium() {
    // Albedo 1 everywhere (sphere, floor and medium), all scattering orders: every pixel's
    // expected value is still L, the smoke in front of the sphere included.
    let dir = tempfile::tempdir().unwrap();
    let mut s = furnace_scene();
    let grid = DensityGrid::new([2, 2, 2], vec![0.2, 1.0, 0.5, 0.0, 0.8, 0.3, 1.0, 0.6]).unwrap();
    let mut m = medium_of(dir.path(), &grid, [0.0, 0.12, 0.2], [0.3, 0.24, 0.3], 12.0, 1.0);
    m.max_scatterings = 256;
    s.medium = Some(m.clone());
    let img = &render(&s)[0];
    let (mean, se) = mean_and_se(img);
    assert!(se > 0.0 && se < 0.01, "se {se}");
    assert!((mean - L).abs() < 4.0 * se + 1e-6, "mean {mean} vs {L}, se {se}");
    // single scattering alone leaves light out
    m.max_scatterings = 1;
    s.medium = Some(m);
    let (single, se1) = mean_and_se(&render(&s)[0]);
    assert!(single < L - 4.0 * se1, "single scattering {single} +- {se1} should lose light");
}

#[test]
fn a_medium_renders_the_same_bytes_twice_and_a_bad_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = furnace_scene();
    s.samples_per_pixel = 4;
    let grid = DensityGrid::new([2, 1, 1], vec![1.0, 0.25]).unwrap();
    s.medium = Some(medium_of(dir.path(), &grid, [0.0, 0.1, 0.1], [0.4, 0.2, 0.2], 20.0, 0.8));
    assert_eq!(render(&s), render(&s));
    // a truncated grid file is refused with its name (a new folder: a new cache key)
    let bad = tempfile::tempdir().unwrap();
    let mut m = medium_of(bad.path(), &grid, [0.0, 0.1, 0.1], [0.4, 0.2, 0.2], 20.0, 0.8);
    let bytes = std::fs::read(bad.path().join("d-0.grid")).unwrap();
    std::fs::write(bad.path().join("d-0.grid"), &bytes[..bytes.len() - 3]).unwrap();
    m.grid_frames = [0, 0];
    s.medium = Some(m);
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let e = render_frame(&s, &env).unwrap_err().to_string();
    assert!(e.contains("d-0.grid") && e.contains("byte"), "{e}");
}

#[test]
fn renderers_that_cannot_render_a_medium_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = furnace_scene();
    s.samples_per_pixel = 1;
    let grid = DensityGrid::constant([1, 1, 1], 1.0).unwrap();
    s.medium = Some(medium_of(dir.path(), &grid, [0.0, 0.1, 0.1], [0.4, 0.2, 0.2], 20.0, 0.8));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let tracer = study::method::MethodSpec::default();
    // the wide CPU tracer (the GPU kernel's f32 algorithm) refuses and names the device to use
    let wide = Renderer::cpu(&env);
    let e = wide.render(&tracer, &s).unwrap_err();
    assert!(matches!(e, RenderError::Scene(_)) && e.to_string().contains("--device cpu-reference"), "{e}");
    // a method that does not trace its frames refuses on any device
    let reference = Renderer::cpu_reference(&env);
    let analytic = study::method::MethodSpec::of(study::Method::Analytic);
    let e = reference.render(&analytic, &s).unwrap_err().to_string();
    assert!(e.contains("participating medium") && e.contains("analytic"), "{e}");
    // the reference tracer renders it
    let frame = reference.render(&tracer, &s).unwrap();
    assert_eq!(frame.nonfinite_samples, 0);
}

#[test]
fn a_vol_file_has_mitsubas_header_and_x_fastest_values() {
    let bytes = render::measure::media_reference::mitsuba_vol([2, 1, 3], &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    assert_eq!(&bytes[..4], b"VOL\x03");
    let int = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    assert_eq!([int(4), int(8), int(12), int(16), int(20)], [1, 2, 1, 3, 1]);
    assert_eq!(bytes.len(), 48 + 24);
    assert_eq!(f32::from_le_bytes(bytes[48 + 8..48 + 12].try_into().unwrap()), 2.0);
}

#[test]
fn z_scores_are_zero_for_equal_images_and_large_for_different_ones() {
    let mut a = LinearImage::new(16, 8);
    let mut b = LinearImage::new(16, 8);
    for (i, (p, q)) in a.pixels.iter_mut().zip(b.pixels.iter_mut()).enumerate() {
        let noise = if i % 2 == 0 { 0.1 } else { -0.1 };
        *p = [0.5 + noise; 3];
        *q = [0.5 - noise; 3];
    }
    let z = render::measure::media_reference::block_z_scores([&a, &b], [&b, &a]);
    assert_eq!(z.len(), 2 * 3);
    assert!(z.iter().all(|v| v.abs() < 1e-9), "{z:?}");
    // each block's mean has a standard error of 0.018 per renderer here: 0.1 brighter is z = -5.7
    let mut brighter = [a.clone(), b.clone()];
    for img in &mut brighter {
        img.pixels.iter_mut().for_each(|p| p[0] += 0.1);
    }
    let z = render::measure::media_reference::block_z_scores([&a, &b], [&brighter[0], &brighter[1]]);
    assert!(z.iter().step_by(3).all(|v| *v < -4.0), "{z:?}");
}

// The marcher method (the thesis's renderer over the tracer's surfaces).

fn marcher(settings: study::method::MarcherSettings) -> study::method::MethodSpec {
    study::method::MethodSpec::Marcher(settings)
}

/// The study camera over a grey sphere and floor under a uniform sky, `spp` samples.
fn marcher_scene(spp: u32) -> FrameScene {
    scene(study_camera(48, 27), flat(0.5), uniform(L), spp)
}

/// A box of smoke in front of the sphere: 0.8 m wide, 0.4 m high and deep.
fn box_medium(dir: &Path, grid: &DensityGrid, extinction: f64, albedo: f64) -> SceneMedium {
    medium_of(dir, grid, [0.0, 0.2, 0.4], [0.8, 0.4, 0.4], extinction, albedo)
}

fn pixel(img: &LinearImage, x: u32, y: u32) -> [f32; 3] {
    img.pixels[(y * img.width + x) as usize]
}

#[test]
fn the_marcher_without_density_is_the_tracers_frame_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(4);
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let cpu = Renderer::cpu(&env);
    let tracer = cpu.render(&study::method::MethodSpec::default(), &s).unwrap().image;
    // no medium at all, then a medium of zero density, in every lighting model
    assert_eq!(cpu.render(&marcher(Default::default()), &s).unwrap().image, tracer);
    s.medium = Some(box_medium(dir.path(), &DensityGrid::constant([4, 2, 2], 0.0).unwrap(), 30.0, 0.8));
    for lighting in study::method::MarchLighting::ALL {
        let settings = study::method::MarcherSettings { lighting: Some(lighting), ..Default::default() };
        assert_eq!(cpu.render(&marcher(settings), &s).unwrap().image, tracer, "{lighting:?}");
    }
}

#[test]
fn an_opaque_medium_shows_its_source_and_hides_the_surfaces() {
    // Uniform sky L, single scattering without shadows: the source is albedo L, and an opaque
    // medium shows exactly that; a one-voxel grid is a constant box.
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(4);
    s.medium = Some(box_medium(dir.path(), &DensityGrid::constant([1, 1, 1], 1.0).unwrap(), 1e5, 0.6));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let settings = study::method::MarcherSettings {
        lighting: Some(study::method::MarchLighting::Primary),
        lights: Some(32),
        ..Default::default()
    };
    let img = Renderer::cpu(&env).render(&marcher(settings), &s).unwrap().image;
    let centre = pixel(&img, 24, 16);
    let expected = (0.6 * L) as f32;
    assert!(centre.iter().all(|&c| (c - expected).abs() < 1e-4 * expected), "{centre:?} vs {expected}");
}

/// A blob of smoke with an empty hole through its middle along z.
fn holed_blob() -> DensityGrid {
    let n = [24usize, 12, 12];
    let mut data = Vec::with_capacity(n[0] * n[1] * n[2]);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let p = [(i as f64 + 0.5) / 24.0 - 0.5, (j as f64 + 0.5) / 12.0 - 0.5, (k as f64 + 0.5) / 12.0 - 0.5];
                let r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
                let hole = p[0].abs() < 0.08 && p[1].abs() < 0.12;
                data.push(if hole || r2 > 0.2 { 0.0 } else { (1.0 - 4.0 * r2) as f32 });
            }
        }
    }
    DensityGrid::new(n, data).unwrap()
}

#[test]
fn the_accelerations_change_the_marchers_work_not_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(2);
    s.medium = Some(box_medium(dir.path(), &holed_blob(), 12.0, 0.9));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let cpu = Renderer::cpu(&env);
    for lighting in study::method::MarchLighting::ALL {
        let with = |mask, map| {
            let settings = study::method::MarcherSettings {
                lighting: Some(lighting),
                validity_mask: Some(mask),
                distance_map: Some(map),
                lights: Some(6),
                ..Default::default()
            };
            cpu.render(&marcher(settings), &s).unwrap().image
        };
        let brute = with(false, false);
        assert_eq!(with(true, false), brute, "{lighting:?}");
        assert_eq!(with(true, true), brute, "{lighting:?}");
        assert_eq!(with(false, true), brute, "{lighting:?}");
    }
}

#[test]
fn the_smoke_shadows_the_floor_only_with_shadow_rays() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(4);
    s.medium = Some(box_medium(dir.path(), &DensityGrid::constant([2, 2, 2], 1.0).unwrap(), 10.0, 0.8));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let cpu = Renderer::cpu(&env);
    let render = |lighting| {
        let settings = study::method::MarcherSettings { lighting: Some(lighting), ..Default::default() };
        cpu.render(&marcher(settings), &s).unwrap().image
    };
    let primary = render(study::method::MarchLighting::Primary);
    let shadowed = render(study::method::MarchLighting::PrimaryAndShadow);
    let tracer = cpu.render(&study::method::MethodSpec::default(), &FrameScene { medium: None, ..s.clone() }).unwrap();
    // row 20 sees the floor 0.27 m in front of the box (z about 0.87 m): no smoke on the way,
    // so primary rays leave it as the tracer drew it, and shadow rays darken it (the box
    // hides a quarter of its sky or more)
    let (x, y) = (24, 20);
    assert_eq!(pixel(&primary, x, y), pixel(&tracer.image, x, y));
    assert!(pixel(&shadowed, x, y)[0] < 0.97 * pixel(&primary, x, y)[0], "{:?}", pixel(&shadowed, x, y));
    // and the medium itself is darker where its shadow rays cross it
    assert!(pixel(&shadowed, 24, 16)[0] < pixel(&primary, 24, 16)[0]);
}

#[test]
fn the_marcher_agrees_with_the_unbiased_reference_where_the_lights_are_many_and_the_steps_fine() {
    // Single scattering with self-shadowing is what the reference tracer computes with
    // max_scatterings = 1; under a uniform sky the constellation's only approximation is the
    // lights' directions. The marcher's frame and the reference's agree in the medium's
    // pixels to within a few per cent; with 2 lights and a 4-voxel step they do not.
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(256);
    s.medium = Some(box_medium(dir.path(), &holed_blob(), 12.0, 0.9));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let reference = Renderer::cpu_reference(&env).render(&study::method::MethodSpec::default(), &s).unwrap().image;
    let error = |lights, step| {
        let settings = study::method::MarcherSettings { lights: Some(lights), step: Some(step), ..Default::default() };
        let img = Renderer::cpu_reference(&env).render(&marcher(settings), &s).unwrap().image;
        // rows through the box (y 10..22 of 27), relative mean absolute difference
        let (mut diff, mut sum) = (0.0, 0.0);
        for y in 10..22 {
            for x in 4..44 {
                let (a, b) = (pixel(&img, x, y)[1], pixel(&reference, x, y)[1]);
                diff += f64::from((a - b).abs());
                sum += f64::from(b);
            }
        }
        diff / sum
    };
    let fine = error(64, 0.25);
    let coarse = error(2, 4.0);
    assert!(fine < 0.04, "fine {fine}");
    assert!(coarse > 1.5 * fine, "coarse {coarse} fine {fine}");
}

#[test]
fn the_marcher_on_a_gpu_renderer_composites_as_on_the_cpu() {
    // The GPU renderer traces the surfaces with the GPU tracer (its twin is the CPU's wide
    // tracer, 1e-4 apart) and marches on the GPU (its twin is `media::march`, 2e-3 apart in
    // radiance): the frames agree per pixel within both, with a moving sphere over sub-frames.
    let dir = tempfile::tempdir().unwrap();
    let mut s = marcher_scene(4);
    s.sphere.velocity = DVec3::new(1.5, 0.0, 0.0);
    s.shutter = study::scene::Shutter { open: -1.0 / 60.0, close: 1.0 / 60.0 };
    s.medium = Some(box_medium(dir.path(), &holed_blob(), 12.0, 0.9));
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let gpu = match Renderer::open(render::DeviceChoice::Gpu, &env) {
        Ok(r) => r,
        Err(e) => {
            gpu::skip_or_fail("the_marcher_on_a_gpu_renderer_composites_as_on_the_cpu", &e);
            return;
        }
    };
    let cpu = Renderer::cpu(&env);
    let surfaces =
        cpu.render(&study::method::MethodSpec::default(), &FrameScene { medium: None, ..s.clone() }).unwrap();
    for lighting in study::method::MarchLighting::ALL {
        let settings =
            study::method::MarcherSettings { lighting: Some(lighting), lights: Some(6), ..Default::default() };
        let g = gpu.render(&marcher(settings.clone()), &s).unwrap();
        let c = cpu.render(&marcher(settings), &s).unwrap();
        let mut worst = (0.0f32, 0);
        for (i, (p, q)) in g.image.pixels.iter().zip(&c.image.pixels).enumerate() {
            for ch in 0..3 {
                let d = (p[ch] - q[ch]).abs() / (1e-2 + q[ch].abs());
                if d > worst.0 {
                    worst = (d, i);
                }
            }
        }
        assert!(
            worst.0 < 3e-3,
            "{lighting:?}: pixel {}: GPU {:?} CPU {:?}",
            worst.1,
            g.image.pixels[worst.1],
            c.image.pixels[worst.1]
        );
        let changed = c.image.pixels.iter().zip(&surfaces.image.pixels).filter(|(a, b)| a != b).count();
        assert!(changed > 50, "{lighting:?}: the smoke should change the frame ({changed} pixels)");
    }
}
