//! Morphological antialiasing on the CPU: aliased edges of known coverage come closer to
//! their exact coverage, straight axis-aligned edges and isolated values stay as they are,
//! the search stops where the line ends, and bad settings are refused.

#![allow(clippy::unwrap_used, reason = "tests fail by panicking")]

use render::antialias::mlaa::area::MAX_DISTANCE;
use render::antialias::mlaa::edges::detect_edges;
use render::antialias::mlaa::weights::search;
use render::antialias::mlaa::{MlaaError, MlaaParams, mlaa_cpu};

const DARK: [f32; 3] = [0.05, 0.05, 0.05];
const BRIGHT: [f32; 3] = [0.9, 0.8, 0.7];

/// The half-plane `y > slope (x - x0) + y0` (y down) in bright over dark: the image sampled
/// at pixel centres (aliased) and its exact coverage (64 x 64 samples per pixel).
fn half_plane(w: u32, h: u32, slope: f64, x0: f64, y0: f64) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let inside = |x: f64, y: f64| y > slope * (x - x0) + y0;
    let mut aliased = Vec::new();
    let mut exact = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            aliased.push(if inside(cx, cy) { BRIGHT } else { DARK });
            let n = 64;
            let mut covered = 0;
            for j in 0..n {
                for i in 0..n {
                    let (sx, sy) =
                        (f64::from(x) + (f64::from(i) + 0.5) / 64.0, f64::from(y) + (f64::from(j) + 0.5) / 64.0);
                    covered += u32::from(inside(sx, sy));
                }
            }
            let a = f64::from(covered) / f64::from(n * n);
            exact.push(std::array::from_fn(|c| {
                (f64::from(DARK[c]) + (f64::from(BRIGHT[c]) - f64::from(DARK[c])) * a) as f32
            }));
        }
    }
    (aliased, exact)
}

fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let s: f64 =
        a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |c| (f64::from(p[c]) - f64::from(q[c])).powi(2))).sum();
    (s / (3 * a.len()) as f64).sqrt()
}

#[test]
fn shallow_steep_and_diagonal_edges_come_closer_to_their_coverage() {
    let (w, h) = (96, 64);
    // Nearly horizontal, shallow, 45 degrees, steep (west edges), nearly vertical, rising
    // and falling. Measured: 2.3-5.4x lower RMSE except at 45 degrees (1.3x and 8x).
    for slope in [0.06, 0.3, 1.0, 3.0, 12.0, -0.06, -0.3, -1.0, -3.0, -12.0] {
        let (aliased, exact) = half_plane(w, h, slope, 40.3, 30.2);
        let out = mlaa_cpu(w, h, &aliased, &MlaaParams::default()).unwrap();
        let (before, after) = (rmse(&aliased, &exact), rmse(&out, &exact));
        // 45 degrees is the classic weak case: every line is one pixel long.
        let bound = if slope.abs() == 1.0 { 0.85 } else { 0.5 };
        assert!(after < bound * before, "slope {slope}: RMSE {before:.4} aliased, {after:.4} after MLAA");
    }
}

#[test]
fn axis_aligned_edges_and_one_pixel_lines_are_left_alone() {
    let (w, h) = (40, 30);
    // A one-pixel-wide horizontal line, a one-pixel-wide vertical line, a column along the
    // image border, each alone (where lines meet, the corners are L patterns and blend).
    let lines: [&dyn Fn(u32, u32) -> bool; 3] = [&|_, y| y == 10, &|x, _| x == 25, &|x, _| x == 0];
    for line in lines {
        let img: Vec<[f32; 3]> = (0..w * h).map(|i| if line(i % w, i / w) { BRIGHT } else { DARK }).collect();
        let out = mlaa_cpu(w, h, &img, &MlaaParams::default()).unwrap();
        assert_eq!(out, img);
    }
}

#[test]
fn blends_stay_within_the_neighbourhood_and_non_finite_pixels_stay_put() {
    let (w, h) = (37, 23); // not a multiple of any work-group size
    let (mut img, _) = half_plane(w, h, 0.4, 10.0, 5.0);
    // A checker of high-contrast squares inside the image, and non-finite values.
    for y in 12..20 {
        for x in 20..34 {
            img[(y * w + x) as usize] = if (x / 3 + y / 3) % 2 == 0 { [1.0, 1.0, 1.0] } else { [0.0; 3] };
        }
    }
    let nan = (8 * w + 9) as usize;
    let inf = (15 * w + 4) as usize;
    img[nan] = [f32::NAN, 0.5, 0.5];
    img[inf] = [f32::INFINITY; 3];
    let out = mlaa_cpu(w, h, &img, &MlaaParams::default()).unwrap();
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if i == nan || i == inf {
                continue;
            }
            let mut near = vec![img[i]];
            if x > 0 {
                near.push(img[i - 1]);
            }
            if x + 1 < w {
                near.push(img[i + 1]);
            }
            if y > 0 {
                near.push(img[i - w as usize]);
            }
            if y + 1 < h {
                near.push(img[i + w as usize]);
            }
            let near: Vec<[f32; 3]> = near.into_iter().filter(|c| c.iter().all(|v| v.is_finite())).collect();
            for c in 0..3 {
                let lo = near.iter().map(|p| p[c]).fold(f32::INFINITY, f32::min);
                let hi = near.iter().map(|p| p[c]).fold(f32::NEG_INFINITY, f32::max);
                assert!(
                    out[i][c].is_finite() && out[i][c] >= lo - 1e-6 && out[i][c] <= hi + 1e-6,
                    "({x}, {y}): {:?}",
                    out[i]
                );
            }
        }
    }
    assert!(out[nan][0].is_nan() && out[inf] == [f32::INFINITY; 3]);
}

#[test]
fn a_longer_search_resolves_lines_longer_than_a_short_one() {
    // Runs of 40 pixels: a search of 8 sees only part of each line, 64 all of it.
    let (w, h) = (200, 24);
    let (aliased, exact) = half_plane(w, h, 1.0 / 40.0, 3.1, 9.3);
    let short = mlaa_cpu(w, h, &aliased, &MlaaParams { search_distance: 8, ..MlaaParams::default() }).unwrap();
    let long =
        mlaa_cpu(w, h, &aliased, &MlaaParams { search_distance: MAX_DISTANCE, ..MlaaParams::default() }).unwrap();
    let (a, s, l) = (rmse(&aliased, &exact), rmse(&short, &exact), rmse(&long, &exact));
    assert!(l < 0.5 * a && l < s && s <= a, "aliased {a:.4}, search 8 {s:.4}, search 64 {l:.4}");
}

#[test]
fn the_search_stops_where_the_line_ends_even_when_a_fetch_reads_half() {
    // North edges (channel 1) in row 0 at x = 0..=4 and x = 6..=9: from x = 4 the line has
    // 4 edgels to its left and none to its right, although the fetch of pixels 5 and 6
    // reads 1/2.
    let (w, h) = (10u32, 1u32);
    let pw = w + 2;
    let mut edges = vec![[0.0f32; 2]; (pw * (h + 2)) as usize];
    for x in (0..=4).chain(6..=9) {
        edges[(pw + x + 1) as usize][1] = 1.0;
    }
    let ph = h + 2;
    assert_eq!(search(&edges, pw, ph, (5, 1), (-1, 0), 1, 12), 4);
    assert_eq!(search(&edges, pw, ph, (5, 1), (1, 0), 1, 12), 0);
    assert_eq!(search(&edges, pw, ph, (7, 1), (1, 0), 1, 12), 3);
    assert_eq!(search(&edges, pw, ph, (7, 1), (-1, 0), 1, 12), 0);
    assert_eq!(search(&edges, pw, ph, (10, 1), (-1, 0), 1, 2), 2, "clamped to the search distance");
    // Detected edges agree with the layout the search reads.
    let img: Vec<[f32; 3]> = (0..20).map(|i| if i < 10 || i == 15 { DARK } else { BRIGHT }).collect();
    let e = detect_edges(10, 2, &img, 0.1);
    assert_eq!(e[(2 * pw + 1 + 4) as usize], [0.0, 1.0]);
    assert_eq!(e[(2 * pw + 1 + 5) as usize], [1.0, 0.0]);
}

#[test]
fn bad_settings_are_refused() {
    let img = vec![DARK; 4];
    for (params, want) in [
        (MlaaParams { threshold: 0.0, ..MlaaParams::default() }, MlaaError::Threshold(0.0)),
        (MlaaParams { threshold: 1.5, ..MlaaParams::default() }, MlaaError::Threshold(1.5)),
        (MlaaParams { search_distance: 0, ..MlaaParams::default() }, MlaaError::SearchDistance(0)),
        (MlaaParams { search_distance: 65, ..MlaaParams::default() }, MlaaError::SearchDistance(65)),
    ] {
        assert_eq!(mlaa_cpu(2, 2, &img, &params).unwrap_err().to_string(), want.to_string());
    }
    assert!(matches!(
        mlaa_cpu(2, 2, &img, &MlaaParams { threshold: f32::NAN, ..MlaaParams::default() }),
        Err(MlaaError::Threshold(_))
    ));
    assert!(matches!(mlaa_cpu(3, 2, &img, &MlaaParams::default()), Err(MlaaError::Size { .. })));
}

mod common;

use render::Renderer;
use render::antialias::frame::antialias_frame;
use render::env::EnvironmentMap;
use render::io::{LinearImage, display_value, radiance_of_display};
use study::scene::{Antialias, Exposure, ToneMap};

const MLAA: Antialias =
    Antialias::Mlaa { threshold: 0.1, search_distance: 12, edges: study::scene::MlaaEdges::Luminance };

#[test]
fn display_values_map_back_to_their_radiance() {
    for tone_map in [ToneMap::Reinhard, ToneMap::Clamp] {
        for stops in [-1.0, 0.0, 2.0] {
            let e = Exposure { stops, tone_map };
            for r in [1e-4f32, 0.01, 0.1, 0.2, 0.5] {
                if tone_map == ToneMap::Clamp && f64::from(r) * stops.exp2() >= 1.0 {
                    continue; // clamped: no way back
                }
                let back = radiance_of_display(display_value(r, &e), &e);
                assert!((back - r).abs() <= 2e-6 * r.max(1.0), "{tone_map:?} {stops}: {r} -> {back}");
            }
        }
        assert_eq!(radiance_of_display(0.0, &Exposure { stops: 0.0, tone_map }), 0.0);
    }
}

#[test]
fn a_frame_is_antialiased_in_display_values_and_untouched_pixels_keep_their_radiance() {
    let mut s = common::scene(
        common::study_camera(96, 60),
        study::scene::Material::Checker {
            albedo_a: [0.9, 0.1, 0.1],
            albedo_b: [0.9, 0.9, 0.9],
            squares_around: 12,
            squares_pole_to_pole: 6,
        },
        common::uniform(common::L),
        2,
    );
    s.pixel_jitter = false;
    let env = EnvironmentMap::from_lighting(&s.lighting).unwrap();
    let renderer = Renderer::cpu(&env);
    let spec = study::method::MethodSpec::default();
    let plain = renderer.render(&spec, &s).unwrap().image;
    s.antialias = Some(MLAA);
    let smooth = renderer.render(&spec, &s).unwrap().image;
    let display: Vec<[f32; 3]> = plain.pixels.iter().map(|p| p.map(|c| display_value(c, &s.exposure) as f32)).collect();
    let expected = mlaa_cpu(96, 60, &display, &MlaaParams::default()).unwrap();
    let mut changed = 0;
    for i in 0..display.len() {
        if display[i] == expected[i] {
            assert_eq!(smooth.pixels[i], plain.pixels[i], "pixel {i} left alone keeps its radiance");
        } else {
            changed += 1;
            for (&radiance, &want) in smooth.pixels[i].iter().zip(&expected[i]) {
                let shown = display_value(radiance, &s.exposure) as f32;
                assert!((shown - want).abs() < 1e-5, "pixel {i}: shows {shown}, MLAA gave {want}");
            }
        }
    }
    assert!(changed > 50, "{changed} pixels blended");
}

#[test]
fn a_side_by_side_frame_is_filtered_one_eye_at_a_time() {
    // Both eyes show the same shallow edge, which runs on across the seam: filtered as one
    // image, the line would continue through the seam and the halves would differ.
    let (w, h) = (48u32, 20u32);
    let (eye, _) = half_plane(w, h, 0.08, 2.0, 8.0);
    let mut s = common::scene(common::study_camera(w, h), common::flat(0.5), common::uniform(common::L), 1);
    let mut right = s.views[0].clone();
    right.seed += 1;
    s.views.push(right);
    s.antialias = Some(MLAA);
    s.exposure = Exposure { stops: 0.0, tone_map: ToneMap::Clamp };
    let linear: Vec<[f32; 3]> = eye.iter().map(|p| p.map(|d| radiance_of_display(f64::from(d), &s.exposure))).collect();
    let mut image = LinearImage::new(2 * w, h);
    for y in 0..h {
        for x in 0..w {
            let p = linear[(y * w + x) as usize];
            image.set(x, y, p);
            image.set(x + w, y, p);
        }
    }
    let whole: Vec<[f32; 3]> = image.pixels.iter().map(|p| p.map(|c| display_value(c, &s.exposure) as f32)).collect();
    let across = mlaa_cpu(2 * w, h, &whole, &MlaaParams::default()).unwrap();
    let halves_differ =
        (0..h).any(|y| (0..w).any(|x| across[(y * 2 * w + x) as usize] != across[(y * 2 * w + x + w) as usize]));
    assert!(halves_differ, "the test image must have a line across the seam");
    antialias_frame(&mut image, &s, None).unwrap();
    let mut blended = 0;
    for y in 0..h {
        for x in 0..w {
            assert_eq!(image.get(x, y), image.get(x + w, y), "({x}, {y})");
            blended += u32::from(image.get(x, y) != linear[(y * w + x) as usize]);
        }
    }
    assert!(blended > 10, "{blended} pixels blended per eye");
}

#[test]
fn non_finite_radiance_stays_in_its_pixel() {
    let (w, h) = (120u32, 40u32);
    let (eye, _) = half_plane(w, h, 0.15, 3.0, 9.0);
    let mut s = common::scene(common::study_camera(w, h), common::flat(0.5), common::uniform(common::L), 1);
    s.antialias = Some(MLAA);
    let mut image = LinearImage::new(w, h);
    for (p, d) in image.pixels.iter_mut().zip(&eye) {
        *p = d.map(|d| radiance_of_display(f64::from(d), &s.exposure));
    }
    let mut plain = image.clone();
    antialias_frame(&mut plain, &s, None).unwrap();
    // Non-finite values on the edge, and an HDR value far above the display's white.
    let (nan, inf, hot) = ((20, 11), (60, 17), (100, 23));
    image.set(nan.0, nan.1, [f32::NAN, 1.0, 1.0]);
    image.set(inf.0, inf.1, [f32::INFINITY; 3]);
    image.set(hot.0, hot.1, [1e6; 3]);
    antialias_frame(&mut image, &s, None).unwrap();
    assert!(image.get(nan.0, nan.1)[0].is_nan() && image.get(inf.0, inf.1) == [f32::INFINITY; 3]);
    for y in 0..h {
        for x in 0..w {
            assert!(image.get(x, y).iter().all(|v| v.is_finite()) || (x, y) == nan || (x, y) == inf, "({x}, {y})");
            // They break the edge's lines, which changes blends within a search distance
            // along them, and no further.
            let near = |p: (u32, u32)| x.abs_diff(p.0).max(y.abs_diff(p.1)) <= 13;
            if !near(nan) && !near(inf) && !near(hot) {
                assert_eq!(image.get(x, y), plain.get(x, y), "({x}, {y}) away from the special pixels");
            }
        }
    }
}

#[test]
fn antialiasing_levels_approach_the_reference_in_order_and_mlaa_improves_on_one_point() {
    use render::measure::antialiasing::{AntialiasingOptions, run_antialiasing_quality};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/antialiasing.toml");
    let design = study::design::Design::load(&path).unwrap();
    let out = tempfile::tempdir().unwrap();
    // Two consecutive frames of the checker moving at S1 with the shutter closed.
    let opts = AntialiasingOptions {
        preset: "quick".into(),
        cell: study::ids::Cell { material: 2, speed: 1, shutter: 1 },
        samples: 2,
        frame: 4,
        frames: 2,
        lighting_samples: 8,
        reference_supersampling: 8,
        out: Some(out.path().to_owned()),
        pixels_per_degree: None,
    };
    let mut seen = Vec::new();
    let r = run_antialiasing_quality(&design, &opts, |done, total| seen.push((done, total))).unwrap();
    assert_eq!(seen.last(), Some(&(14, 14)));
    assert!(r["edge_pixels"].as_u64().unwrap() > 200, "{r}");
    let levels = r["levels"].as_array().unwrap();
    let of = |key: &str| -> Vec<f64> { levels.iter().map(|l| l[key].as_f64().unwrap()).collect() };
    let edges = of("rmse_edges");
    // One point, one point + MLAA, 2 x 2, 3 x 3, 4 x 4 points, one point + MLAA on depth.
    assert_eq!(edges.len(), 6, "{r}");
    assert!(edges[1] < edges[0], "MLAA lowers the edge error: {edges:?}");
    assert!(edges[2] < edges[0] && edges[3] < edges[2] && edges[4] < edges[3], "more points, less error: {edges:?}");
    // Temporal stability: one point's edges crawl as the sphere moves; more points follow
    // the reference's change more closely.
    let flicker = of("flicker_edges");
    eprintln!("flicker {flicker:?}, temporal {:?}, reference {}", of("temporal_rms_edges"), r["reference"]);
    assert!(flicker[2] < flicker[0] && flicker[4] < flicker[2], "{flicker:?}");
    // MLAA smooths the crawl a little; far less than 2 x 2 points (measured: 0.117 against
    // 0.150 without it and 0.049 with 2 x 2 points).
    assert!(flicker[1] < flicker[0] && flicker[1] > flicker[2], "{flicker:?}");
    // Depth edges leave the checker's edges alone: between one point and MLAA on luminance.
    assert!(edges[5] < edges[0] && edges[5] > edges[1], "{edges:?}");
    assert!(flicker.iter().all(|&f| f > 0.0));
    // The frames moved: the reference itself changes on the edges.
    assert!(r["reference"]["temporal_rms_edges"].as_f64().unwrap() > 0.01, "{r}");
    // The first frame's images for a person to look at.
    for name in ["reference.png", "M2-S1-T1-A2-analytic.png", "M2-S1-T1-A2-analytic6-flip.png"] {
        assert!(out.path().join(name).is_file(), "{name}");
    }
    // Frames past the preset and a FLIP resolution it cannot judge at are refused before
    // anything is rendered.
    let blind = AntialiasingOptions { pixels_per_degree: Some(0.1), ..opts.clone() };
    let e = run_antialiasing_quality(&design, &blind, |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("--ppd 0.1: must lie in 0.5..=1000"), "{e}");
    let past = AntialiasingOptions { frame: 7, ..opts };
    let e = run_antialiasing_quality(&design, &past, |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("outside the preset `quick`"), "{e}");
}

/// Depth edges (`mlaa_edges = "depth"`) on the study scene with the checker: they follow the
/// sphere's silhouette and nothing else (not the checker's squares, not the floor running to
/// the horizon), where luminance edges find the squares too; and MLAA with them blends only
/// pixels beside the silhouette.
#[test]
fn depth_edges_follow_the_silhouette_and_ignore_texture_and_the_floor() {
    use render::antialias::frame::inverse_depth;
    use render::antialias::mlaa::edges::{detect_depth_edges, detect_edges};
    use render::antialias::mlaa::mlaa_cpu_depth;
    let checker = study::scene::Material::Checker {
        albedo_a: [0.8, 0.76, 0.65],
        albedo_b: [0.45, 0.06, 0.05],
        squares_around: 16,
        squares_pole_to_pole: 8,
    };
    let (w, h) = (160, 90);
    // The study camera narrowed 4x: the sphere about 60 pixels across.
    let mut camera = common::study_camera(w, h);
    camera.sensor_width /= 4.0;
    let mut s = common::scene(camera, checker, common::default_env(), 4);
    s.pixel_jitter = false;
    let camera = &s.views[0].camera;
    let depth = inverse_depth(&s, camera);
    // Which pixel centres see the sphere (the ray passes within a radius of its centre).
    let centre = s.sphere.centre_at(s.shutter.centre());
    let on_sphere: Vec<bool> = (0..w * h)
        .map(|i| {
            let d = camera.ray_direction(glam::DVec2::new(f64::from(i % w) + 0.5, f64::from(i / w) + 0.5));
            let oc = centre - camera.position;
            let along = oc.dot(d);
            along > 0.0 && (oc - d * along).length() < s.sphere.radius
        })
        .collect();
    let sphere_pixels = on_sphere.iter().filter(|&&b| b).count();
    let centre_y = camera.project(centre).unwrap().y;
    assert!(sphere_pixels > 2000, "{sphere_pixels}");
    let image = render::Renderer::cpu(&render::env::EnvironmentMap::from_lighting(&s.lighting).unwrap())
        .render(&study::method::MethodSpec::default(), &s)
        .unwrap()
        .image;
    let display: Vec<[f32; 3]> =
        image.pixels.iter().map(|c| c.map(|v| render::io::display_value(v, &s.exposure) as f32)).collect();
    let threshold = study::method::antialias::DEFAULT_MLAA_DEPTH_THRESHOLD as f32;
    let by_depth = detect_depth_edges(w, h, &depth, threshold);
    let by_luminance = detect_edges(w, h, &display, 0.1);
    let pw = (w + 2) as usize;
    let (mut depth_edgels, mut silhouette, mut found, mut luminance_edgels) = (0, 0, 0, 0);
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = y * w as usize + x;
            let texel = (y + 1) * pw + x + 1;
            for (k, neighbour) in [(0, (x > 0).then(|| i - 1)), (1, (y > 0).then(|| i - w as usize))] {
                let Some(j) = neighbour else { continue };
                let across = on_sphere[i] != on_sphere[j];
                let edge = by_depth[texel][k] > 0.5;
                depth_edgels += usize::from(edge);
                luminance_edgels += usize::from(by_luminance[texel][k] > 0.5);
                assert!(!edge || across, "a depth edgel off the silhouette at ({x}, {y}), {k}");
                if across {
                    silhouette += 1;
                    found += usize::from(edge);
                    // Missed only low on the sphere, where the floor behind it comes within
                    // the threshold of its depth (it touches the floor).
                    assert!(edge || y as f64 > centre_y, "a silhouette edgel missed at ({x}, {y}), {k}");
                }
            }
        }
    }
    assert!(found as f64 > 0.7 * silhouette as f64, "{found} of {silhouette} silhouette edgels");
    // The checker's squares are edges of luminance, not of depth.
    assert!(luminance_edgels > 2 * depth_edgels, "{luminance_edgels} luminance against {depth_edgels} depth edgels");
    let params = render::antialias::mlaa::MlaaParams { threshold, search_distance: 12 };
    let blended = mlaa_cpu_depth(w, h, &display, &depth, &params).unwrap();
    for (i, (a, b)) in blended.iter().zip(&display).enumerate() {
        if a != b {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let near = (0..=2u32).any(|r| {
                let at = |x: u32, y: u32| on_sphere[(y * w + x) as usize];
                [(x.saturating_sub(r), y), ((x + r).min(w - 1), y), (x, y.saturating_sub(r)), (x, (y + r).min(h - 1))]
                    .iter()
                    .any(|&(u, v)| at(u, v) != at(x, y))
            });
            assert!(near, "({x}, {y}) blended away from the silhouette");
        }
    }
    assert_ne!(blended, display);
}
