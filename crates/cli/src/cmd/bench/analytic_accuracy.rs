//! `blurlab bench analytic-accuracy`: the analytic rasterizer's approximations on the
//! design's M3-S3-T5 benchmark frame (`render::analytic::accuracy`): the linear depth's error
//! histogram (the paper's Figure 10) and the tessellated sphere's coverage error against the
//! true sphere per tessellation. Prints JSON or a summary; with `--out`, writes
//! `accuracy.json`, `depth-error.csv`, `tessellation.csv` and their figures (PNG, SVG).

use std::fmt::Write as _;
use std::path::PathBuf;

use analysis::rasterizer::{DepthErrorFigure, TessellationFigure, TessellationPoint, write_figures};
use render::analytic::accuracy::{depth_error_histogram, tessellation_error};
use render::analytic::geometry::VertexPaths;
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
    #[arg(long, default_value_t = render::analytic::DEFAULT_TESSELLATION)]
    tessellation: u32,
    /// Tessellations whose coverage error is measured, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [8u32, 16, 32, 64, 128, 256])]
    tessellations: Vec<u32>,
    /// Measure every `stride`-th pixel in each direction.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    stride: u32,
    /// Folder for the tables and figures.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs the measurement.
pub fn run(args: Args) -> anyhow::Result<()> {
    let max = render::analytic::MAX_TESSELLATION;
    if let Some(bad) = args.tessellations.iter().chain([&args.tessellation]).find(|&&s| !(3..=max).contains(&s)) {
        return Err(BadInput(format!("--tessellation(s): {bad} is outside 3..={max}")).into());
    }
    let design = load_design(&args.frame.design)?;
    let mut scene = render::tracer::bench::benchmark_frame(&design, 1, false).map_err(|e| BadInput(e.to_string()))?;
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
    let report = json!({
        "frame": {"id": "M3-S3-T5", "width": args.size.width, "height": args.size.height, "stride": args.stride},
        "depth_error": {"segments": args.tessellation, "paths": "rolling_chords", "histogram": depth},
        "depth_error_translated": {"segments": args.tessellation, "paths": "translated", "histogram": depth_translated},
        "tessellation_error": tessellation,
        "tessellation_error_rolling_chords": chords,
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
        if let Some(dir) = &args.out {
            println!("tables and figures in {}", dir.display());
        }
    }
    Ok(())
}
