//! `blurlab bench analytic-accuracy`: the analytic rasterizer's approximations on the
//! design's M3-S3-T5 benchmark frame (`render::measure::analytic_accuracy`): the linear depth's error
//! histogram (the paper's Figure 10) and the tessellated sphere's coverage error against the
//! true sphere per tessellation, and the contact shadow against the tracer per speed (the
//! method's measured limit: one shading per interval leaves the moving shadow sharp). Prints
//! JSON or a summary; with `--out`, writes `accuracy.json`, `depth-error.csv`,
//! `tessellation.csv`, `contact-shadow.csv` and the figures (PNG, SVG).

use std::fmt::Write as _;
use std::path::PathBuf;

use analysis::rasterizer::{DepthErrorFigure, TessellationFigure, TessellationPoint, write_figures};
use render::measure::analytic_accuracy::{
    ShadowError, contact_shadow_error, depth_error_histogram, tessellation_error,
};
use render::methods::analytic::geometry::VertexPaths;
use serde_json::json;

use crate::cmd::BadInput;
use crate::cmd::stimuli::load_design;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: super::FrameBench,
    #[command(flatten)]
    size: super::FrameSize,
    /// Sphere segments of the depth histogram.
    #[arg(long, default_value_t = render::methods::analytic::DEFAULT_TESSELLATION)]
    tessellation: u32,
    /// Tessellations whose coverage error is measured, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [8u32, 16, 32, 64, 128, 256])]
    tessellations: Vec<u32>,
    /// Measure every `stride`-th pixel in each direction.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    stride: u32,
    /// Speeds (degrees per second) at which the contact shadow is compared with the tracer;
    /// empty (`--shadow-speeds ''`) skips it.
    #[arg(long, value_delimiter = ',', default_values_t = [5.0f64, 10.0, 15.0, 30.0, 60.0, 144.0])]
    shadow_speeds: Vec<f64>,
    /// Width of the contact-shadow frames (the height keeps the design's aspect ratio).
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(8..=4096))]
    shadow_width: u32,
    /// The tracer's samples per pixel in the contact-shadow comparison (the rasterizer's
    /// lighting samples per interval are the same).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    shadow_spp: u32,
    /// Folder for the tables and figures.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The contact shadow of the M3-S3-T5 benchmark frame at each speed of `args`, the tracer
/// against the rasterizer (`SHADOW_PARAMS`: its defaults with 4 x 4 points per pixel).
fn contact_shadows(design: &study::design::Design, args: &Args) -> anyhow::Result<Vec<ShadowError>> {
    let mut out = Vec::new();
    for &speed in &args.shadow_speeds {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(BadInput(format!("--shadow-speeds: {speed} is not a positive speed")).into());
        }
        let mut d = design.clone();
        let level =
            d.spec.factors.speed.get_mut(2).ok_or_else(|| BadInput("the design has no third speed level".into()))?;
        level.degrees_per_second = speed;
        let mut scene = render::measure::tracer::benchmark_frame(&d, args.shadow_spp, false)
            .map_err(|e| BadInput(e.to_string()))?;
        let aspect = f64::from(scene.views[0].camera.height) / f64::from(scene.views[0].camera.width);
        let height = ((f64::from(args.shadow_width) * aspect).round() as u32).max(1);
        for view in &mut scene.views {
            (view.camera.width, view.camera.height) = (args.shadow_width, height);
        }
        let env = render::env::EnvironmentMap::from_lighting(&scene.lighting).map_err(|e| BadInput(e.to_string()))?;
        render::methods::analytic::check_motion(&scene)
            .map_err(|e| BadInput(format!("--shadow-speeds {speed}: {e}")))?;
        let traced = render::methods::tracer::render_frame(&scene, &env).map_err(|e| BadInput(e.to_string()))?;
        let raster =
            render::methods::analytic::render_frame(&scene, &env, &render::measure::analytic_accuracy::SHADOW_PARAMS)?;
        out.push(contact_shadow_error(&scene, speed, &traced.eyes[0], &raster.eyes[0]));
    }
    Ok(out)
}

/// Runs the measurement.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let max = render::methods::analytic::MAX_TESSELLATION;
    if let Some(bad) = args.tessellations.iter().chain([&args.tessellation]).find(|&&s| !(3..=max).contains(&s)) {
        return Err(BadInput(format!("--tessellation(s): {bad} is outside 3..={max}")).into());
    }
    let design = load_design(&args.frame.design)?;
    let mut scene = render::measure::tracer::benchmark_frame(&design, 1, false).map_err(|e| BadInput(e.to_string()))?;
    for view in &mut scene.views {
        (view.camera.width, view.camera.height) = (args.size.width, args.size.height);
    }
    // The paper's Figure 10 is of deforming triangles: vertices on the rotation's chords.
    // The rasterizer's translating triangles have exactly linear depth (max error reported).
    let depth = depth_error_histogram(&scene, 0, args.tessellation, VertexPaths::RollingChords, args.stride);
    let depth_translated = depth_error_histogram(&scene, 0, args.tessellation, VertexPaths::Translated, args.stride);
    let measure = |paths| -> Vec<_> {
        args.tessellations.iter().map(|&s| tessellation_error(&scene, 0, s, paths, args.stride)).collect()
    };
    let tessellation = measure(VertexPaths::Translated);
    let chords = measure(VertexPaths::RollingChords);
    let shadows = contact_shadows(&design, args)?;
    let report = json!({
        "frame": {"id": "M3-S3-T5", "width": args.size.width, "height": args.size.height, "stride": args.stride},
        "depth_error": {"segments": args.tessellation, "paths": "rolling_chords", "histogram": depth},
        "depth_error_translated": {"segments": args.tessellation, "paths": "translated", "histogram": depth_translated},
        "tessellation_error": tessellation,
        "tessellation_error_rolling_chords": chords,
        "contact_shadow": {"width": args.shadow_width, "spp": args.shadow_spp, "speeds": shadows},
    });
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", dir.display()))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            study::fsio::write_atomic(&path, text.as_bytes())
                .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))
        };
        write("accuracy.json", serde_json::to_string_pretty(&report)? + "\n")?;
        let mut csv = String::from("decade,intervals_rolling_chords,intervals_translated\n");
        for ((d, c), t) in depth.decades.iter().zip(&depth.counts).zip(&depth_translated.counts) {
            writeln!(csv, "{d},{c},{t}")?;
        }
        write("depth-error.csv", csv)?;
        let mut csv = String::from("paths,segments,samples,max,mean,bias\n");
        for t in tessellation.iter().chain(&chords) {
            writeln!(csv, "{},{},{},{:e},{:e},{:e}", t.paths, t.segments, t.samples, t.max, t.mean, t.bias)?;
        }
        write("tessellation.csv", csv)?;
        let mut csv = String::from(
            "degrees_per_second,travel_radii,pixels,tracer_mean,analytic_mean,mean_abs_error,tracer_darkest,analytic_darkest\n",
        );
        for e in &shadows {
            writeln!(
                csv,
                "{},{:.4},{},{:.6},{:.6},{:.6},{:.6},{:.6}",
                e.degrees_per_second,
                e.travel_radii,
                e.pixels,
                e.tracer_mean,
                e.analytic_mean,
                e.mean_abs_error,
                e.tracer_darkest,
                e.analytic_darkest
            )?;
        }
        write("contact-shadow.csv", csv)?;
        let size = format!("{}x{}", args.size.width, args.size.height);
        let depth_fig = DepthErrorFigure {
            title: format!(
                "Linear depth (Eq. 15) error, M3-S3-T5 {size}, {} segments, vertices on chords: max {:.1e}",
                args.tessellation, depth.max
            ),
            bins: depth.decades.iter().copied().zip(depth.counts.iter().copied()).collect(),
        };
        let tess_fig = TessellationFigure {
            title: format!("Tessellated vs true sphere coverage, M3-S3-T5 {size}"),
            points: tessellation
                .iter()
                .map(|t| TessellationPoint { segments: t.segments, mean: t.mean, max: t.max })
                .collect(),
            chords: chords
                .iter()
                .map(|t| TessellationPoint { segments: t.segments, mean: t.mean, max: t.max })
                .collect(),
        };
        write_figures(&depth_fig, &tess_fig, dir)?;
    }
    if args.frame.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        for (h, paths) in [(&depth, "rolling_chords"), (&depth_translated, "translated")] {
            println!(
                "linear depth ({} segments, {paths}): {} intervals, relative error max {:.2e}, mean {:.2e}",
                args.tessellation, h.intervals, h.max, h.mean
            );
        }
        for t in tessellation.iter().chain(&chords) {
            println!(
                "tessellation {:>4} ({}): coverage error max {:.2e}, mean {:.2e}, bias {:+.2e} over {} sample points",
                t.segments, t.paths, t.max, t.mean, t.bias, t.samples
            );
        }
        for e in &shadows {
            println!(
                "contact shadow at {:>5} deg/s ({:.2} radii a shutter): {} pixels, error {:.1} % of the tracer's mean, darkest pixel {:.4} (tracer {:.4})",
                e.degrees_per_second,
                e.travel_radii,
                e.pixels,
                100.0 * e.mean_abs_error,
                e.analytic_darkest,
                e.tracer_darkest
            );
        }
        if let Some(dir) = &args.out {
            println!("tables and figures in {}", dir.display());
        }
    }
    Ok(())
}
