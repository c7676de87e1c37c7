//! MLAA's WGSL passes (`antialias/mlaa/{edges,weights,blend}.wgsl`) against their CPU twins
//! on lavapipe in CI: the edges texture and the blending weights agree exactly (they are
//! discrete: 0/1 edgels, integer distances, texels of one area texture), the blended image
//! to rounding; on images with the hard cases (shallow, steep and diagonal edges, a
//! checker's high-contrast edges, one-pixel lines, lines longer than the search, edges at the
//! border, NaN and Inf, a size that is not a multiple of the work-group size).

#![allow(clippy::unwrap_used, reason = "tests fail by panicking")]

use render::antialias::mlaa::host::{BLEND_WGSL, EDGES_WGSL, GpuMlaa, WEIGHTS_WGSL, assemble};
use render::antialias::mlaa::weights::blending_weights;
use render::antialias::mlaa::{MlaaParams, blend::blend, edges::detect_edges};

fn mlaa(test: &str) -> Option<GpuMlaa> {
    let ctx = gpu::test_context(test)?;
    Some(GpuMlaa::new(ctx).unwrap())
}

/// A test image of `w x h`: a shallow and a steep half-plane boundary, a checker, a
/// one-pixel diagonal line and a long, nearly horizontal edge, non-finite pixels.
fn scene(w: u32, h: u32) -> Vec<[f32; 3]> {
    let mut img = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            let mut c = if fy > 0.23 * fx + 3.0 { [0.8, 0.7, 0.6] } else { [0.1, 0.15, 0.2] };
            if fx > 2.7 * (fy - 5.0) + 30.0 {
                c = [0.3, 0.9, 0.2];
            }
            if (20..44).contains(&x) && (18..30).contains(&y) {
                c = if (x / 3 + y / 3) % 2 == 0 { [1.0, 1.0, 1.0] } else { [0.0, 0.0, 0.0] };
            }
            if x == y + 3 && x < 18 {
                c = [1.0, 1.0, 0.0];
            }
            if fy > fx / 60.0 + f64::from(h) - 6.0 {
                c = [0.5, 0.2, 0.9];
            }
            img.push(c);
        }
    }
    img[(4 * w + 7) as usize] = [f32::NAN, 0.2, 0.2];
    img[(30 * w + 50) as usize] = [f32::INFINITY, 1.0, 1.0];
    img
}

#[test]
fn the_passes_assemble_and_validate() {
    for (file, source) in [("edges.wgsl", EDGES_WGSL), ("weights.wgsl", WEIGHTS_WGSL), ("blend.wgsl", BLEND_WGSL)] {
        let wgsl = assemble(file, source).unwrap();
        gpu::validate_wgsl(file, &wgsl).unwrap();
    }
}

#[test]
fn every_pass_agrees_with_its_cpu_twin() {
    let Some(gpu) = mlaa("every_pass_agrees_with_its_cpu_twin") else { return };
    for (w, h, params) in [
        (77, 45, MlaaParams::default()),
        (77, 45, MlaaParams { threshold: 0.3, search_distance: 3 }),
        (130, 41, MlaaParams { threshold: 0.05, search_distance: 64 }),
        (1, 1, MlaaParams::default()),
        (9, 40, MlaaParams::default()),
    ] {
        let img = if w > 60 {
            scene(w, h)
        } else {
            (0..w * h).map(|i| if (i % w) * 3 > i / w { [0.9; 3] } else { [0.1; 3] }).collect()
        };
        let edges = detect_edges(w, h, &img, params.threshold);
        let weights = blending_weights(&edges, w, h, params.search_distance);
        let color = blend(w, h, &img, &weights);
        if w > 60 {
            let blended = weights.iter().filter(|w| w.iter().any(|v| *v > 0.0)).count();
            assert!(blended > 100, "{w}x{h} {params:?}: only {blended} pixels to blend");
        }
        let run = gpu.run(w, h, &img, &params).unwrap();
        assert_eq!(run.edges, edges, "{w}x{h} {params:?}: edges");
        let differing = run.weights.iter().zip(&weights).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{w}x{h} {params:?}: {differing} pixels' weights differ");
        for (i, (a, b)) in run.color.iter().zip(&color).enumerate() {
            for c in 0..3 {
                let same = (a[c].is_nan() && b[c].is_nan()) || a[c] == b[c] || (a[c] - b[c]).abs() <= 1e-6;
                assert!(same, "{w}x{h} {params:?}: pixel {i}: {a:?} against {b:?}");
            }
        }
        assert!(run.seconds > 0.0);
    }
}

#[test]
fn depth_edges_agree_with_their_cpu_twin() {
    use render::antialias::mlaa::edges::detect_depth_edges;
    let Some(gpu) = mlaa("depth_edges_agree_with_their_cpu_twin") else { return };
    let (w, h) = (83, 47);
    // A disc at 3 m over a floor whose inverse depth falls towards a horizon (sky: 0), a
    // NaN and an infinity; the colours a checker, so luminance would find other edges.
    let depth: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (f64::from(i % w) + 0.5, f64::from(i / w) + 0.5);
            let d = if (x - 40.0).powi(2) + (y - 25.0).powi(2) < 15.0f64.powi(2) {
                1.0 / 3.0
            } else if y > 12.0 {
                0.004 * (y - 12.0)
            } else {
                0.0
            };
            match i {
                300 => f32::NAN,
                2000 => f32::INFINITY,
                _ => d as f32,
            }
        })
        .collect();
    let img: Vec<[f32; 3]> =
        (0..w * h).map(|i| if (i % w / 4 + i / w / 4) % 2 == 0 { [0.9; 3] } else { [0.1; 3] }).collect();
    let params = MlaaParams { threshold: 0.02, search_distance: 12 };
    let edges = detect_depth_edges(w, h, &depth, params.threshold);
    let weights = blending_weights(&edges, w, h, params.search_distance);
    let color = blend(w, h, &img, &weights);
    assert!(edges.iter().filter(|e| e[0] + e[1] > 0.0).count() > 50);
    let run = gpu.run_with_depth(w, h, &img, Some(&depth), &params).unwrap();
    assert_eq!(run.edges, edges);
    assert_eq!(run.weights, weights);
    for (a, b) in run.color.iter().zip(&color) {
        assert!((0..3).all(|c| (a[c] - b[c]).abs() <= 1e-6), "{a:?} against {b:?}");
    }
    // Not the luminance's edges.
    assert_ne!(edges, detect_edges(w, h, &img, params.threshold));
    let short = gpu.run_with_depth(w, h, &img, Some(&depth[1..]), &params).unwrap_err();
    assert!(matches!(short, render::antialias::mlaa::MlaaError::Size { .. }), "{short}");
}

mod common;

#[test]
fn a_gpu_renderer_antialiases_with_the_kernels_as_the_cpu_twin_does() {
    use render::{DeviceChoice, Renderer};
    if gpu::test_context("a_gpu_renderer_antialiases_with_the_kernels_as_the_cpu_twin_does").is_none() {
        return;
    }
    let checker = study::scene::Material::Checker {
        albedo_a: [0.9, 0.1, 0.1],
        albedo_b: [0.9, 0.9, 0.9],
        squares_around: 12,
        squares_pole_to_pole: 6,
    };
    let mut s = common::scene(common::study_camera(72, 40), checker, common::uniform(common::L), 2);
    s.pixel_jitter = false;
    let env = render::env::EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let renderer = Renderer::open(DeviceChoice::Gpu, &env).unwrap();
    let spec = study::method::MethodSpec::default();
    let mut by_twin = renderer.render(&spec, &s).unwrap().image;
    s.antialias = Some(study::scene::Antialias::Mlaa {
        threshold: 0.1,
        search_distance: 12,
        edges: study::scene::MlaaEdges::Luminance,
    });
    let by_kernels = renderer.render(&spec, &s).unwrap().image;
    render::antialias::frame::antialias_frame(&mut by_twin, &s, None).unwrap();
    let worst_relative = |a: &render::io::LinearImage, b: &render::io::LinearImage| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-3)))
            .fold(0.0f32, f32::max)
    };
    let worst = worst_relative(&by_kernels, &by_twin);
    assert!(worst < 1e-4, "largest relative difference {worst}");
    // With depth edges: the kernels with the depth buffer uploaded, the twin on the CPU.
    let mut depth_scene = s.clone();
    depth_scene.antialias = Some(study::scene::Antialias::Mlaa {
        threshold: 0.02,
        search_distance: 12,
        edges: study::scene::MlaaEdges::Depth,
    });
    let by_kernels_depth = renderer.render(&spec, &depth_scene).unwrap().image;
    let mut by_twin_depth = renderer
        .render(&spec, &{
            let mut plain = s.clone();
            plain.antialias = None;
            plain
        })
        .unwrap()
        .image;
    let unfiltered = by_twin_depth.clone();
    render::antialias::frame::antialias_frame(&mut by_twin_depth, &depth_scene, None).unwrap();
    assert_ne!(by_twin_depth, unfiltered, "depth edges changed nothing");
    let worst_depth = worst_relative(&by_kernels_depth, &by_twin_depth);
    assert!(worst_depth < 1e-4, "depth edges: largest relative difference {worst_depth}");
    assert_ne!(
        by_kernels,
        renderer
            .render(&study::method::MethodSpec::default(), &{
                let mut plain = s.clone();
                plain.antialias = None;
                plain
            })
            .unwrap()
            .image,
        "antialiasing changed nothing"
    );
}
