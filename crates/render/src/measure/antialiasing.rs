//! How close each level of a design's antialiasing factor comes to a converged reference
//! (`blurlab bench antialiasing`, the thesis's MLAA quality claim measured): every method
//! level of one stimulus (e.g. `stimuli/antialiasing.toml`'s one point per pixel, the same
//! with MLAA, 2 x 2, 3 x 3 and 4 x 4 points) rendered on the CPU at one frame with many
//! lighting samples, so that shading noise is small beside aliasing; the reference is the
//! first level's analytic rasterizer at 8 x 8 points per pixel with the same lighting.
//!
//! Errors are on display values (8-bit sRGB as shown): RMSE and mean FLIP over the **edge
//! pixels**, the pixels on either side of an edgel that MLAA's edge detection finds in the
//! first level's frame (where antialiasing acts), and over the whole image, pooled over the
//! frames measured.
//!
//! The error's scale: the display-luminance error on the edge pixels after Gaussian low-pass
//! filters of 1 and 2 pixels ([`COARSE_SIGMAS`]), the part of it coarser than the pixel
//! grid's stair steps, which a viewer still sees where a pixel is too small to resolve.
//!
//! **Temporal stability** (the thesis calls MLAA "temporally stable"), over two or more
//! consecutive frames of a moving stimulus: a level's temporal difference is `D(t) = I(t+1) -
//! I(t)` on display values; its **flicker** is the RMS over the frame pairs, the edge pixels
//! of either frame and the channels of `D_level(t) - D_reference(t)`, the frame-to-frame
//! change that the converged reference does not have. An aliased edge that crawls as the
//! sphere moves scores high; a level that changes as the reference changes scores 0. The
//! RMS of `D` itself is reported beside it for each level and the reference. Every frame is
//! rendered with the first frame's seeds, so that shading noise on still surfaces does not
//! change from frame to frame and the differences are the motion's and the sampling's.

use std::time::Instant;

use perceptual::SrgbImage;
use serde_json::{Value, json};
use study::design::Design;
use study::ids::{Cell, StimulusId, View};
use study::method::MethodSpec;
use study::stats::Summary;

use crate::antialias::mlaa::edges::detect_edges;
use crate::env::EnvironmentMap;
use crate::io::to_srgb8;
use crate::{RenderError, Renderer};

/// What to measure.
#[derive(Clone, Debug)]
pub struct AntialiasingOptions {
    /// Preset.
    pub preset: String,
    /// The cell.
    pub cell: Cell,
    /// The A level.
    pub samples: u8,
    /// The first frame.
    pub frame: u32,
    /// Consecutive frames from `frame` (2 or more also measure temporal stability).
    pub frames: u32,
    /// Lighting samples of every shading (the analytic levels').
    pub lighting_samples: u32,
    /// Points per pixel along each axis of the reference.
    pub reference_supersampling: u32,
    /// FLIP's pixels per degree (`None`: the design's viewing geometry at the preset's width).
    pub pixels_per_degree: Option<f64>,
    /// Where to write the first frame of the reference and of each level as PNG, with each
    /// level's FLIP map (`None`: nothing written).
    pub out: Option<std::path::PathBuf>,
}

/// Why the measurement failed.
#[derive(Debug, thiserror::Error)]
pub enum AntialiasingError {
    /// The design cannot give the frames.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// The environment map could not be built.
    #[error(transparent)]
    Environment(#[from] crate::env::EnvError),
    /// A render failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// FLIP refused an image.
    #[error(transparent)]
    Flip(#[from] perceptual::FlipError),
    /// The request does not fit the design.
    #[error("{0}")]
    Request(String),
    /// An image could not be written.
    #[error("{path}: {message}")]
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn write_png(dir: &std::path::Path, name: &str, (w, h): (u32, u32), rgb: &[u8]) -> Result<(), AntialiasingError> {
    let path = dir.join(name);
    let failed = |e: std::io::Error| AntialiasingError::Write { path: path.clone(), message: e.to_string() };
    std::fs::create_dir_all(dir).map_err(failed)?;
    study::fsio::write_atomic(&path, &crate::measure::cost::png_rgb8(w, h, rgb)).map_err(failed)
}

fn with_lighting(mut spec: MethodSpec, lighting: u32, supersampling: Option<u32>) -> MethodSpec {
    if let MethodSpec::Analytic(s) = &mut spec {
        s.lighting_samples = Some(lighting);
        if let Some(n) = supersampling {
            s.supersampling = Some(n);
        }
    }
    spec
}

/// Sums of one level's errors over the frames.
#[derive(Default)]
struct Tally {
    seconds: Vec<f64>,
    squared_edges: Vec<f64>,
    squared_all: Vec<f64>,
    flip_edges: Vec<f64>,
    /// Squared errors and FLIP on the edge pixels at corners and along lines ([`edge_mask`]).
    squared_corners: Vec<f64>,
    flip_corners: Vec<f64>,
    squared_lines: Vec<f64>,
    flip_lines: Vec<f64>,
    /// Squared low-passed luminance errors on the edge pixels, one list per [`COARSE_SIGMAS`].
    squared_coarse: Vec<Vec<f64>>,
    flip_all: Vec<f64>,
    /// Squared temporal differences on edge pixels: the level's own, and against the reference's.
    temporal: Vec<f64>,
    flicker: Vec<f64>,
    previous: Option<Vec<u8>>,
}

/// Widths (Gaussian sigma, pixels) of the low-pass filters whose output error is reported:
/// the part of the error coarser than the pixel grid's stair steps.
pub const COARSE_SIGMAS: [f64; 2] = [1.0, 2.0];

/// The display luminance of each pixel of an 8-bit frame, in [0, 1].
fn luminance_of(srgb: &[u8]) -> Vec<f64> {
    srgb.chunks_exact(3)
        .map(|c| (0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])) / 255.0)
        .collect()
}

/// `values` (`w x h`) filtered by a Gaussian of `sigma` pixels, separably, the border
/// clamped.
fn gaussian(values: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let r = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-r..=r).map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp()).collect();
    let total: f64 = kernel.iter().sum();
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as isize, (i / w) as isize);
                kernel
                    .iter()
                    .zip(-r..=r)
                    .map(|(k, d)| {
                        let (u, v) = if horizontal {
                            ((x + d).clamp(0, w as isize - 1), y)
                        } else {
                            (x, (y + d).clamp(0, h as isize - 1))
                        };
                        k * src[v as usize * w + u as usize]
                    })
                    .sum::<f64>()
                    / total
            })
            .collect()
    };
    pass(&pass(values, true), false)
}

/// Per pixel: the squared display difference of two 8-bit frames, the mean over the channels.
fn squared_per_pixel(a: &[u8], b: &[u8]) -> Vec<f64> {
    a.chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(p, q)| (0..3).map(|c| ((f64::from(p[c]) - f64::from(q[c])) / 255.0).powi(2)).sum::<f64>() / 3.0)
        .collect()
}

/// Per pixel: the squared difference of two frame-to-frame changes, `(a1 - a0) - (b1 - b0)`,
/// the mean over the channels (`b` absent: the change `a1 - a0` itself).
fn squared_change(a0: &[u8], a1: &[u8], b: Option<(&[u8], &[u8])>) -> Vec<f64> {
    let value = |v: u8| f64::from(v) / 255.0;
    (0..a0.len() / 3)
        .map(|i| {
            (0..3)
                .map(|c| {
                    let k = 3 * i + c;
                    let d = value(a1[k]) - value(a0[k]);
                    let r = b.map_or(0.0, |(b0, b1)| value(b1[k]) - value(b0[k]));
                    (d - r).powi(2)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect()
}

fn on_mask(values: &[f64], mask: &[bool]) -> impl Iterator<Item = f64> {
    values.iter().zip(mask).filter(|(_, m)| **m).map(|(v, _)| *v)
}

/// Measures every method level of `opts.cell` in `design`; `progress(done, total)` is told
/// after each render.
pub fn run_antialiasing_quality(
    design: &Design,
    opts: &AntialiasingOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<Value, AntialiasingError> {
    let tags = design.method_tags();
    if tags.is_empty() {
        return Err(AntialiasingError::Request(format!(
            "{}: the design has no method factor; use stimuli/antialiasing.toml",
            design.path.display()
        )));
    }
    let preset = design.preset(&opts.preset)?;
    if opts.frames == 0 || opts.frame + opts.frames > preset.frames {
        return Err(AntialiasingError::Request(format!(
            "frames {}..{} are outside the preset `{}`'s 0..{}",
            opts.frame,
            opts.frame + opts.frames,
            preset.name,
            preset.frames
        )));
    }
    let id_of = |tag| StimulusId {
        material: opts.cell.material,
        speed: opts.cell.speed,
        shutter: opts.cell.shutter,
        samples: opts.samples,
        method: Some(tag),
        view: View::Mono,
    };
    let first = id_of(tags[0]);
    // Every frame with the first frame's seeds (the module's note).
    let scene_at = |id: &StimulusId, frame: u32| -> Result<study::scene::FrameScene, AntialiasingError> {
        let seeds = design.frame_scene_with(&preset, id, opts.frame)?.views;
        let mut scene = design.frame_scene_with(&preset, id, frame)?;
        for (view, seeded) in scene.views.iter_mut().zip(seeds) {
            view.seed = seeded.seed;
        }
        Ok(scene)
    };
    let scene = scene_at(&first, opts.frame)?;
    let env = EnvironmentMap::from_lighting(&scene.lighting)?;
    let renderer = Renderer::cpu(&env);
    let ppd = opts.pixels_per_degree.unwrap_or_else(|| design.pixels_per_degree(preset.width));
    if !(ppd.is_finite() && (0.5..=1000.0).contains(&ppd)) {
        return Err(AntialiasingError::Request(format!("--ppd {ppd}: must lie in 0.5..=1000 pixels per degree")));
    }
    let (w, h) = (scene.views[0].camera.width, scene.views[0].camera.height);
    let exposure = scene.exposure;
    let reference_spec =
        with_lighting(design.method_of(&first)?, opts.lighting_samples, Some(opts.reference_supersampling));
    if !matches!(reference_spec, MethodSpec::Analytic(_)) {
        return Err(AntialiasingError::Request("the first method level must be the analytic rasterizer".into()));
    }
    let total = opts.frames as usize * (tags.len() + 1);
    let mut done = 0;
    progress(done, total);
    let mut reference_seconds = Vec::new();
    let mut reference_temporal = Vec::new();
    let mut previous_reference: Option<Vec<u8>> = None;
    let mut previous_mask: Option<Vec<bool>> = None;
    let (mut edge_count, mut corner_count) = (0, 0);
    let mut tallies: Vec<Tally> = tags.iter().map(|_| Tally::default()).collect();
    for frame in opts.frame..opts.frame + opts.frames {
        let mut scene = scene_at(&first, frame)?;
        scene.antialias = None;
        let started = Instant::now();
        let reference = to_srgb8(&renderer.render(&reference_spec, &scene)?.image, &exposure);
        reference_seconds.push(started.elapsed().as_secs_f64());
        done += 1;
        progress(done, total);
        let reference_image = SrgbImage::new(w, h, reference.clone())?;
        let written = opts.out.as_deref().filter(|_| frame == opts.frame);
        if let Some(dir) = written {
            write_png(dir, "reference.png", (w, h), &reference)?;
        }
        let mut mask: Option<(Vec<bool>, Vec<bool>)> = None;
        for (tag, tally) in tags.iter().zip(&mut tallies) {
            let id = id_of(*tag);
            let scene = scene_at(&id, frame)?;
            let spec = with_lighting(design.method_of(&id)?, opts.lighting_samples, None);
            let started = Instant::now();
            let image = renderer.render(&spec, &scene)?.image;
            tally.seconds.push(started.elapsed().as_secs_f64());
            let srgb = to_srgb8(&image, &exposure);
            let (edges, corners) = mask.get_or_insert_with(|| edge_mask(w, h, &srgb));
            let flip = perceptual::flip(&reference_image, &SrgbImage::new(w, h, srgb.clone())?, ppd)?;
            if let Some(dir) = written {
                write_png(dir, &format!("{id}.png"), (w, h), &srgb)?;
                write_png(dir, &format!("{id}-flip.png"), (w, h), &flip.magma_rgb8())?;
            }
            let squared = squared_per_pixel(&srgb, &reference);
            let flips: Vec<f64> = flip.values.iter().map(|&v| f64::from(v)).collect();
            tally.squared_edges.extend(on_mask(&squared, edges));
            tally.squared_all.extend(&squared);
            tally.flip_edges.extend(on_mask(&flips, edges));
            tally.flip_all.extend(&flips);
            let lines: Vec<bool> = edges.iter().zip(corners.iter()).map(|(e, c)| *e && !*c).collect();
            tally.squared_corners.extend(on_mask(&squared, corners));
            tally.flip_corners.extend(on_mask(&flips, corners));
            tally.squared_lines.extend(on_mask(&squared, &lines));
            tally.flip_lines.extend(on_mask(&flips, &lines));
            let error: Vec<f64> =
                luminance_of(&srgb).iter().zip(luminance_of(&reference)).map(|(a, b)| a - b).collect();
            tally.squared_coarse.resize(COARSE_SIGMAS.len(), Vec::new());
            for (sigma, out) in COARSE_SIGMAS.iter().zip(&mut tally.squared_coarse) {
                let low = gaussian(&error, w as usize, h as usize, *sigma);
                out.extend(on_mask(&low.iter().map(|e| e * e).collect::<Vec<_>>(), edges));
            }
            if let (Some(before), Some(reference_before), Some(mask_before)) =
                (&tally.previous, &previous_reference, &previous_mask)
            {
                let either: Vec<bool> = edges.iter().zip(mask_before).map(|(a, b)| *a || *b).collect();
                tally.temporal.extend(on_mask(&squared_change(before, &srgb, None), &either));
                let against = squared_change(before, &srgb, Some((reference_before, &reference)));
                tally.flicker.extend(on_mask(&against, &either));
            }
            tally.previous = Some(srgb);
            done += 1;
            progress(done, total);
        }
        let (mask, corners) = mask.unwrap_or_default();
        edge_count += mask.iter().filter(|&&b| b).count();
        corner_count += corners.iter().filter(|&&b| b).count();
        if let (Some(reference_before), Some(mask_before)) = (&previous_reference, &previous_mask) {
            let either: Vec<bool> = mask.iter().zip(mask_before).map(|(a, b)| *a || *b).collect();
            reference_temporal.extend(on_mask(&squared_change(reference_before, &reference, None), &either));
        }
        previous_reference = Some(reference);
        previous_mask = Some(mask);
    }
    let rms = |v: &[f64]| (!v.is_empty()).then(|| Summary::of(v).mean.sqrt());
    let levels: Vec<Value> = tags
        .iter()
        .zip(&tallies)
        .enumerate()
        .map(|(k, (tag, t))| -> Result<Value, AntialiasingError> {
            let id = id_of(*tag);
            Ok(json!({
                "id": id.to_string(),
                "method": design.method_of(&id)?.kind().name(),
                "level": design.spec.factors.method.get(k).and_then(|m| m.name.clone()),
                "seconds": Summary::of(&t.seconds).mean,
                "rmse_edges": rms(&t.squared_edges),
                "rmse_all": rms(&t.squared_all),
                "flip_edges": Summary::of(&t.flip_edges).mean,
                "flip_all": Summary::of(&t.flip_all).mean,
                "rmse_corners": rms(&t.squared_corners),
                "flip_corners": Summary::of(&t.flip_corners).mean,
                "rmse_lines": rms(&t.squared_lines),
                "flip_lines": Summary::of(&t.flip_lines).mean,
                "luminance_rmse_edges_low_passed": COARSE_SIGMAS
                    .iter()
                    .zip(&t.squared_coarse)
                    .map(|(sigma, v)| json!({"sigma_pixels": sigma, "rmse": rms(v)}))
                    .collect::<Vec<_>>(),
                "temporal_rms_edges": rms(&t.temporal),
                "flicker_edges": rms(&t.flicker),
            }))
        })
        .collect::<Result<_, _>>()?;
    Ok(json!({
        "design": design.path.display().to_string(),
        "preset": opts.preset,
        "cell": opts.cell.to_string(),
        "samples": opts.samples,
        "frame": opts.frame,
        "frames": opts.frames,
        "width": w,
        "height": h,
        "pixels_per_degree": ppd,
        "lighting_samples": opts.lighting_samples,
        "reference": {
            "supersampling": opts.reference_supersampling,
            "seconds": Summary::of(&reference_seconds).mean,
            "temporal_rms_edges": rms(&reference_temporal),
        },
        "edge_pixels": edge_count,
        "corner_pixels": corner_count,
        "levels": levels,
        "machine": crate::measure::tracer::machine_json(),
    }))
}

/// The pixels on either side of an edgel MLAA's edge detection (default threshold) finds in
/// `srgb` (8-bit display values, `w x h`), and those of them at a **corner**: an edge pixel
/// whose 3 x 3 neighbourhood holds both a vertical (west) and a horizontal (north) edgel,
/// where a line turns or two lines cross (the checker's square corners, which MLAA reads as
/// L and Z patterns). The other edge pixels lie along straight runs.
fn edge_mask(w: u32, h: u32, srgb: &[u8]) -> (Vec<bool>, Vec<bool>) {
    let display: Vec<[f32; 3]> = srgb
        .chunks_exact(3)
        .map(|c| [f32::from(c[0]) / 255.0, f32::from(c[1]) / 255.0, f32::from(c[2]) / 255.0])
        .collect();
    let edges = detect_edges(w, h, &display, crate::antialias::mlaa::DEFAULT_THRESHOLD);
    let pw = (w + 2) as usize;
    let mut mask = vec![false; (w * h) as usize];
    for y in 0..h as usize {
        for x in 0..w as usize {
            let [west, north] = edges[(y + 1) * pw + x + 1];
            let i = y * w as usize + x;
            if west > 0.5 {
                mask[i] = true;
                mask[i - 1] = true;
            }
            if north > 0.5 {
                mask[i] = true;
                mask[i - w as usize] = true;
            }
        }
    }
    // The padded texture's border is zero, so the 3 x 3 texel block of every pixel exists.
    let edges = &edges;
    let corners = (0..(w * h) as usize)
        .map(|i| {
            let (x, y) = (i % w as usize + 1, i / w as usize + 1);
            let block = || (y - 1..=y + 1).flat_map(move |ty| (x - 1..=x + 1).map(move |tx| edges[ty * pw + tx]));
            mask[i] && block().any(|e| e[0] > 0.5) && block().any(|e| e[1] > 0.5)
        })
        .collect();
    (mask, corners)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_low_pass_keeps_constants_and_removes_a_checkerboard() {
        let (w, h) = (9, 7);
        let flat = vec![0.25; w * h];
        assert!(gaussian(&flat, w, h, 1.0).iter().all(|v| (v - 0.25).abs() < 1e-12));
        // A pixel-scale alternation (the stair steps' scale) nearly vanishes at sigma 1.
        let fine: Vec<f64> = (0..w * h).map(|i| if (i % w + i / w) % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let low = gaussian(&fine, w, h, 1.0);
        assert!(low[3 * w + 4].abs() < 0.02, "{}", low[3 * w + 4]);
        // Its integral is kept: a single pixel spreads into a kernel of sum 1.
        let mut one = vec![0.0; w * h];
        one[3 * w + 4] = 1.0;
        assert!((gaussian(&one, w, h, 1.0).iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn temporal_changes_cancel_against_the_same_change() {
        let (a0, a1) = (vec![10u8, 20, 30, 40, 50, 60], vec![20u8, 20, 30, 40, 50, 90]);
        assert_eq!(squared_change(&a0, &a1, Some((&a0, &a1))), vec![0.0, 0.0]);
        let own = squared_change(&a0, &a1, None);
        assert!((own[0] - (10.0f64 / 255.0).powi(2) / 3.0).abs() < 1e-15);
        assert!((own[1] - (30.0f64 / 255.0).powi(2) / 3.0).abs() < 1e-15);
    }
}
