//! How far each rendering method's frames are from the truth, and what they cost
//! (`blurlab bench methods`): for every material, speed and shutter of a design with a method
//! factor, one frame rendered by each method level at one sampling level, against a
//! high-sample tracer reference of the same frame, with the RMSE (linear radiance and display
//! values) and PSNR (display values, peak 1) and the render time. For the accumulation buffer
//! it also finds what the tracer costs at the same error: the tracer is rendered at 1, 2, 4,
//! ... samples per pixel and its time interpolated log-log at the accumulation buffer's error.
//!
//! The reference's seeds are mixed apart from the methods' so that its noise is independent
//! of theirs (a tracer frame at 16 samples would otherwise be the first 16 of the reference's
//! 1024 samples, and its error underestimated); its own noise adds `sigma^2 / reference_spp`
//! to each squared error, reported as `reference_noise_rms`, estimated from two half-sample
//! references.

use std::time::Instant;

use serde_json::{Value, json};
use study::Method;
use study::cost::psnr;
use study::design::{Design, Preset};
use study::ids::{Cell, Factor, StimulusId, View};
use study::method::MethodSpec;
use study::scene::{Exposure, FrameScene};
use study::seed::mix;

use crate::io::{LinearImage, display_value};

use crate::{RenderError, Renderer};

/// What to measure.
#[derive(Clone, Debug)]
pub struct QualityOptions {
    /// Preset of the design.
    pub preset: String,
    /// Frame index within the preset.
    pub frame: u32,
    /// Sampling level (1-based A level) every method renders at.
    pub level: u8,
    /// Samples per pixel of the reference.
    pub reference_spp: u32,
    /// Largest tracer samples per pixel of the equal-error sweep (powers of two from 1).
    pub sweep_spp: u32,
}

/// Why the measurement failed.
#[derive(Debug, thiserror::Error)]
pub enum QualityError {
    /// The design cannot give the frames asked for.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// A render failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The request does not fit the design.
    #[error("{0}")]
    Request(String),
}

/// Root mean square difference of the display values (exposure, tone map, sRGB in [0, 1]).
pub fn display_rmse(a: &LinearImage, b: &LinearImage, exposure: &Exposure) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (display_value(p[c], exposure) - display_value(q[c], exposure)).powi(2)))
        .sum();
    (sum / (3 * a.pixels.len().max(1)) as f64).sqrt()
}

fn timed(
    renderer: &Renderer<'_>,
    spec: &MethodSpec,
    scene: &FrameScene,
) -> Result<(LinearImage, f64, u64), RenderError> {
    let started = Instant::now();
    let frame = renderer.render(spec, scene)?;
    Ok((frame.image, started.elapsed().as_secs_f64(), frame.camera_samples))
}

/// The scene with seeds mixed apart by `salt` and `spp` samples.
fn reseeded(scene: &FrameScene, salt: u64, spp: u32) -> FrameScene {
    let mut s = scene.clone();
    s.samples_per_pixel = spp;
    for v in &mut s.views {
        v.seed = mix(v.seed, &[salt]);
    }
    s
}

/// Linear interpolation of `log(time)` at `log(error)` along a falling error curve
/// `(error, seconds)`; `None` outside its range.
pub fn time_at_error(curve: &[(f64, f64)], error: f64) -> Option<f64> {
    curve.windows(2).find_map(|w| {
        let ((e0, t0), (e1, t1)) = (w[0], w[1]);
        let inside = (e1 <= error && error <= e0) || (e0 <= error && error <= e1);
        (inside && e0 != e1).then(|| {
            let u = (error.ln() - e0.ln()) / (e1.ln() - e0.ln());
            (t0.ln() + u * (t1.ln() - t0.ln())).exp()
        })
    })
}

/// Measures every method level of `design` on every material, speed and shutter.
pub fn run_quality(
    design: &Design,
    renderer: &Renderer<'_>,
    opts: &QualityOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<Value, QualityError> {
    let tags = design.method_tags();
    if tags.is_empty() {
        return Err(QualityError::Request(format!(
            "{}: the design has no rendering-method factor (`[[factors.method]]`); use stimuli/methods.toml",
            design.path.display()
        )));
    }
    let preset: Preset = design.preset(&opts.preset)?;
    if opts.frame >= preset.frames || opts.level == 0 || opts.level > design.level_count(Factor::Samples) {
        return Err(QualityError::Request(format!(
            "frame {} and level A{} must lie within the preset's {} frames and the design's {} levels",
            opts.frame,
            opts.level,
            preset.frames,
            design.level_count(Factor::Samples)
        )));
    }
    let cells: Vec<(u8, u8, u8)> = (1..=design.level_count(Factor::Material))
        .flat_map(|m| (1..=design.level_count(Factor::Speed)).map(move |s| (m, s)))
        .flat_map(|(m, s)| (1..=design.level_count(Factor::Shutter)).map(move |t| (m, s, t)))
        .collect();
    let mut rows = Vec::new();
    for (i, &(material, speed, shutter)) in cells.iter().enumerate() {
        progress(i, cells.len());
        let id =
            |tag| StimulusId { material, speed, shutter, samples: opts.level, method: Some(tag), view: View::Mono };
        let base = design.frame_scene_with(&preset, &id(tags[0]), opts.frame)?;
        let tracer = MethodSpec::of(Method::Tracer);
        let half = (opts.reference_spp / 2).max(1);
        let (ref_a, ref_seconds, _) = timed(renderer, &tracer, &reseeded(&base, 0x5EFA, half))?;
        let (ref_b, _, _) = timed(renderer, &tracer, &reseeded(&base, 0x5EFB, half))?;
        // The mean of two independent halves; their difference estimates its noise.
        let reference = LinearImage::mean(&[&ref_a, &ref_b]);
        let reference_noise = 0.5 * ref_a.rms_difference(&ref_b);
        let exposure = base.exposure;
        let mut methods = serde_json::Map::new();
        let mut accum_error = None;
        for &tag in &tags {
            let spec = design.method_of(&id(tag))?;
            let scene = design.frame_scene_with(&preset, &id(tag), opts.frame)?;
            let (image, seconds, samples) = timed(renderer, &spec, &scene)?;
            let rmse = display_rmse(&image, &reference, &exposure);
            if spec.kind() == Method::Accum {
                accum_error = Some((tag, rmse, seconds));
            }
            methods.insert(
                tag.to_string(),
                json!({
                    "kind": spec.kind(),
                    "rmse_linear": image.rms_difference(&reference),
                    "rmse_display": rmse,
                    "psnr_db": psnr(rmse),
                    "seconds": seconds,
                    "camera_samples": samples,
                }),
            );
        }
        let mut row = json!({
            "cell": Cell { material, speed, shutter }.to_string(),
            "samples_per_pixel": base.samples_per_pixel,
            "moving_in_shutter": base.needs_time_sampling(),
            "reference_seconds": ref_seconds * 2.0,
            "reference_noise_rms": reference_noise,
            "methods": methods,
        });
        if let Some((tag, error, seconds)) = accum_error.filter(|_| base.needs_time_sampling()) {
            let mut curve = Vec::new();
            let mut spp = 1;
            while spp <= opts.sweep_spp {
                let (image, secs, _) = timed(renderer, &tracer, &reseeded(&base, 0x5EE9, spp))?;
                curve.push((display_rmse(&image, &reference, &exposure), secs));
                spp *= 2;
            }
            row["accum_equal_error"] = json!({
                "method": tag.to_string(),
                "accum_seconds": seconds,
                "accum_rmse_display": error,
                "tracer_seconds_at_equal_error": time_at_error(&curve, error),
                "tracer_sweep": curve.iter().enumerate().map(|(k, (e, s))| json!({"spp": 1u32 << k, "rmse_display": e, "seconds": s})).collect::<Vec<_>>(),
            });
        }
        rows.push(row);
    }
    progress(cells.len(), cells.len());
    Ok(json!({
        "design": design.name(),
        "design_sha256": design.sha256,
        "preset": preset.name,
        "frame": opts.frame,
        "level": format!("A{}", opts.level),
        "reference_spp": opts.reference_spp,
        "device": renderer.device_name(),
        "machine": crate::measure::tracer::machine_json(),
        "methods": tags.iter().map(|t| t.to_string()).collect::<Vec<_>>(),
        "cells": rows,
    }))
}

/// The measurement as a Markdown table: display RMSE and PSNR of each method per cell.
pub fn markdown_table(result: &Value) -> String {
    let methods: Vec<&str> = result["methods"].as_array().into_iter().flatten().filter_map(Value::as_str).collect();
    let mut out = format!("| cell | {} |\n| --- |{}\n", methods.join(" | "), " --- |".repeat(methods.len()));
    for row in result["cells"].as_array().into_iter().flatten() {
        let cells: Vec<String> = methods
            .iter()
            .map(|m| {
                let r = &row["methods"][m];
                format!(
                    "{:.4} / {:.1} dB / {:.2} s",
                    r["rmse_display"].as_f64().unwrap_or(f64::NAN),
                    r["psnr_db"].as_f64().unwrap_or(f64::NAN),
                    r["seconds"].as_f64().unwrap_or(f64::NAN)
                )
            })
            .collect();
        out.push_str(&format!("| {} | {} |\n", row["cell"].as_str().unwrap_or("?"), cells.join(" | ")));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_error_time_interpolates_log_log_and_refuses_to_extrapolate() {
        // error = 1/sqrt(time): the time at error 0.25 is 16.
        let curve: Vec<(f64, f64)> = [1.0f64, 4.0, 64.0].iter().map(|&t| (1.0 / t.sqrt(), t)).collect();
        assert!((time_at_error(&curve, 0.25).unwrap() - 16.0).abs() < 1e-9);
        assert_eq!(time_at_error(&curve, 0.01), None);
        assert_eq!(time_at_error(&curve, 2.0), None);
        assert!((psnr(0.1) - 20.0).abs() < 1e-12);
    }
}
