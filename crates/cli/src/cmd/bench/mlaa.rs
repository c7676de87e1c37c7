//! `blurlab bench mlaa [--json] [--device gpu|cpu|auto]`: milliseconds per 1280x720 frame of
//! morphological antialiasing (`render::measure::mlaa`): GPU time from timestamp queries,
//! the CPU twin beside it in the same run.

use render::antialias::mlaa::MlaaParams;
use render::antialias::mlaa::host::GpuMlaa;
use render::measure::mlaa::{MlaaTimingOptions, benchmark_display, run_mlaa_timing};

use crate::cmd::BadInput;
use crate::cmd::stimuli::{DeviceArg, load_design};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: super::FrameBench,
    #[command(flatten)]
    size: super::PostProcessSize,
    /// Samples per pixel of the traced input.
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=4096))]
    spp: u32,
    /// Luminance step that makes an edge, in (0, 1].
    #[arg(long, default_value_t = render::antialias::mlaa::DEFAULT_THRESHOLD)]
    threshold: f32,
    /// Longest search towards each end of a line, in pixels (1-64).
    #[arg(long, default_value_t = render::antialias::mlaa::DEFAULT_SEARCH_DISTANCE)]
    search_distance: u32,
    /// Timed GPU rounds (after one warm-up).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Timed rounds of the CPU twin.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    cpu_rounds: u32,
    /// `gpu` (a hardware adapter, else a software one), `auto` (hardware only, else none) or
    /// `cpu` (the twin alone).
    #[arg(long, value_enum, default_value_t = DeviceArg::Gpu)]
    device: DeviceArg,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let params = MlaaParams { threshold: args.threshold, search_distance: args.search_distance };
    params.check().map_err(|e| BadInput(format!("--threshold/--search-distance: {e}")))?;
    let design = load_design(&args.frame.design)?;
    let mlaa = match super::bench_device(args.device)? {
        Some(ctx) => Some(GpuMlaa::new(ctx)?),
        None => None,
    };
    let display = benchmark_display(&design, args.size.width, args.size.height, args.spp)?;
    let opts = MlaaTimingOptions {
        width: args.size.width,
        height: args.size.height,
        spp: args.spp,
        params,
        rounds: args.rounds,
        cpu_rounds: args.cpu_rounds,
    };
    let result = run_mlaa_timing(&display, mlaa.as_ref(), &opts)?;
    if args.frame.json {
        println!("{}", serde_json::to_string_pretty(&result)?);
    } else {
        println!(
            "mlaa: {:.3} ms on the GPU ({}), {:.1} ms by the CPU twin, {}x{}, {:.1} % of pixels blended",
            result["gpu_ms_median"].as_f64().unwrap_or(f64::NAN),
            result["adapter"]["name"].as_str().unwrap_or("none"),
            result["cpu_twin_ms"].as_f64().unwrap_or(f64::NAN),
            args.size.width,
            args.size.height,
            100.0 * result["blended_pixel_fraction"].as_f64().unwrap_or(f64::NAN),
        );
    }
    Ok(())
}
