//! `blurlab bench analytic [--json]`: milliseconds per frame of the analytic motion blur
//! rasterizer (`render::measure::analytic`) on the design's M3-S3-T5 benchmark frame, with the
//! average and largest number of intervals per pixel and the machine.

use render::measure::analytic::{BenchOptions, run as run_bench};
use render::methods::analytic::AnalyticParams;

use crate::cmd::BadInput;
use crate::cmd::stimuli::load_design;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: super::FrameBench,
    #[command(flatten)]
    size: super::FrameSize,
    /// Per-pixel interval budget (4-64).
    #[arg(long, default_value_t = 8)]
    intervals: u32,
    /// Sphere segments around the equator.
    #[arg(long, default_value_t = render::methods::analytic::DEFAULT_TESSELLATION)]
    tessellation: u32,
    /// Lighting samples per shading evaluation.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..))]
    lighting_samples: u32,
    /// Sample points per pixel along each axis (1-8).
    #[arg(long, default_value_t = 1)]
    supersampling: u32,
    /// Timed rounds (after one warm-up).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Also time the WGSL kernel on a GPU (hardware first, else a software adapter) in the
    /// same run, with its speed-up over the CPU rasterizer.
    #[arg(long)]
    gpu: bool,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let design = load_design(&args.frame.design)?;
    let params = AnalyticParams {
        intervals: args.intervals,
        tessellation: args.tessellation,
        lighting_samples: Some(args.lighting_samples),
        supersampling: args.supersampling,
    };
    params.check().map_err(|e| BadInput(e.to_string()))?;
    let opts = BenchOptions {
        width: args.size.width,
        height: args.size.height,
        params,
        spp: args.lighting_samples,
        rounds: args.rounds,
        gpu: args.gpu,
    };
    let result = run_bench(&design, &opts).map_err(|e| anyhow::anyhow!(e))?;
    if args.frame.json {
        println!("{}", serde_json::to_string(&result)?);
    } else {
        println!(
            "analytic: {:.1} ms per {}x{} frame (mean of {}), {} intervals per pixel, {:.2} offered on average, {} at most",
            result["ms_per_frame"]["mean"].as_f64().unwrap_or(f64::NAN),
            args.size.width,
            args.size.height,
            args.rounds,
            args.intervals,
            result["intervals_per_pixel"]["mean"].as_f64().unwrap_or(f64::NAN),
            result["intervals_per_pixel"]["max"].as_u64().unwrap_or(0),
        );
        if let Some(g) = result.get("gpu").filter(|g| !g.is_null()) {
            println!(
                "analytic on {}: {:.1} ms per frame (wall, mean), {:.1}x the CPU rasterizer's speed",
                g["adapter"].as_str().unwrap_or("?"),
                g["ms_per_frame_wall"]["mean"].as_f64().unwrap_or(f64::NAN),
                g["cpu_over_gpu_wall"].as_f64().unwrap_or(f64::NAN),
            );
        }
    }
    Ok(())
}
