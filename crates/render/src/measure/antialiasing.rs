//! How close each level of a design's antialiasing factor comes to a converged reference
//! (`blurlab bench antialiasing`, the thesis's MLAA quality claim measured): every method
//! level of one stimulus (e.g. `stimuli/antialiasing.toml`'s one point per pixel, the same
//! with MLAA, 2 x 2, 3 x 3 and 4 x 4 points) rendered on the CPU at one frame with many
//! lighting samples, so that shading noise is small beside aliasing; the reference is the
//! first level's analytic rasterizer at 8 x 8 points per pixel with the same lighting.
//!
//! Errors are on display values (8-bit sRGB as shown): RMSE and mean FLIP over the **edge
//! pixels**, the pixels on either side of an edgel that MLAA's edge detection finds in the
//! first level's frame (where antialiasing acts), and over the whole image.

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
    /// The frame.
    pub frame: u32,
    /// Lighting samples of every shading (the analytic levels').
    pub lighting_samples: u32,
    /// Points per pixel along each axis of the reference.
    pub reference_supersampling: u32,
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
    /// The design has no method factor to compare.
    #[error("{0}")]
    Request(String),
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

/// Measures every method level of `opts.cell` in `design`.
pub fn run_antialiasing_quality(design: &Design, opts: &AntialiasingOptions) -> Result<Value, AntialiasingError> {
    let tags = design.method_tags();
    if tags.is_empty() {
        return Err(AntialiasingError::Request(format!(
            "{}: the design has no method factor; use stimuli/antialiasing.toml",
            design.path.display()
        )));
    }
    let preset = design.preset(&opts.preset)?;
    let id_of = |tag| StimulusId {
        material: opts.cell.material,
        speed: opts.cell.speed,
        shutter: opts.cell.shutter,
        samples: opts.samples,
        method: Some(tag),
        view: View::Mono,
    };
    let first = id_of(tags[0]);
    let mut scene = design.frame_scene_with(&preset, &first, opts.frame)?;
    let env = EnvironmentMap::from_lighting(&scene.lighting)?;
    let renderer = Renderer::cpu(&env);
    let ppd = design.pixels_per_degree(preset.width);
    let (w, h) = (scene.views[0].camera.width, scene.views[0].camera.height);
    let exposure = scene.exposure;
    scene.antialias = None;
    let reference_spec =
        with_lighting(design.method_of(&first)?, opts.lighting_samples, Some(opts.reference_supersampling));
    if !matches!(reference_spec, MethodSpec::Analytic(_)) {
        return Err(AntialiasingError::Request("the first method level must be the analytic rasterizer".into()));
    }
    let started = Instant::now();
    let reference = to_srgb8(&renderer.render(&reference_spec, &scene)?.image, &exposure);
    let reference_seconds = started.elapsed().as_secs_f64();
    let reference_image = SrgbImage::new(w, h, reference.clone())?;
    let mut edge_pixels: Option<Vec<bool>> = None;
    let mut levels = Vec::new();
    for (k, tag) in tags.into_iter().enumerate() {
        let id = id_of(tag);
        let scene = design.frame_scene_with(&preset, &id, opts.frame)?;
        let spec = with_lighting(design.method_of(&id)?, opts.lighting_samples, None);
        let started = Instant::now();
        let image = renderer.render(&spec, &scene)?.image;
        let seconds = started.elapsed().as_secs_f64();
        let srgb = to_srgb8(&image, &exposure);
        let edges = edge_pixels.get_or_insert_with(|| edge_mask(w, h, &srgb));
        let flip = perceptual::flip(&reference_image, &SrgbImage::new(w, h, srgb.clone())?, ppd)?;
        // Per pixel: the squared display error (mean over the channels) and FLIP.
        let squared: Vec<f64> = srgb
            .chunks_exact(3)
            .zip(reference.chunks_exact(3))
            .map(|(p, q)| (0..3).map(|c| ((f64::from(p[c]) - f64::from(q[c])) / 255.0).powi(2)).sum::<f64>() / 3.0)
            .collect();
        let flips: Vec<f64> = flip.values.iter().map(|&v| f64::from(v)).collect();
        let on_edges =
            |v: &[f64]| -> Vec<f64> { v.iter().zip(edges.iter()).filter(|(_, e)| **e).map(|(x, _)| *x).collect() };
        levels.push(json!({
            "id": id.to_string(),
            "method": spec.kind().name(),
            "level": design.spec.factors.method.get(k).and_then(|m| m.name.clone()),
            "seconds": seconds,
            "rmse_edges": Summary::of(&on_edges(&squared)).mean.sqrt(),
            "rmse_all": Summary::of(&squared).mean.sqrt(),
            "flip_edges": Summary::of(&on_edges(&flips)).mean,
            "flip_all": flip.mean,
        }));
    }
    let edge_count = edge_pixels.map_or(0, |e| e.iter().filter(|&&b| b).count());
    Ok(json!({
        "design": design.path.display().to_string(),
        "preset": opts.preset,
        "cell": opts.cell.to_string(),
        "samples": opts.samples,
        "frame": opts.frame,
        "width": w,
        "height": h,
        "pixels_per_degree": ppd,
        "lighting_samples": opts.lighting_samples,
        "reference": {"supersampling": opts.reference_supersampling, "seconds": reference_seconds},
        "edge_pixels": edge_count,
        "levels": levels,
        "machine": crate::measure::tracer::machine_json(),
    }))
}

/// The pixels on either side of an edgel MLAA's edge detection (default threshold) finds in
/// `srgb` (8-bit display values, `w x h`).
fn edge_mask(w: u32, h: u32, srgb: &[u8]) -> Vec<bool> {
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
    mask
}
