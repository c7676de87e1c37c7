//! `blurlab bench filters [--json] [--device gpu|cpu|auto]`: milliseconds per frame of the
//! McGuire 2012 and Guertin 2014 filters at 1280x720 and N = 35 (`render::measure::filters`):
//! GPU time from timestamp queries, the CPU twins beside it in the same run.

use render::measure::filters::{FilterTimingOptions, benchmark_gbuffer, run_filter_timing};

use crate::cmd::stimuli::{DeviceArg, load_design};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: super::FrameBench,
    #[command(flatten)]
    size: super::PostProcessSize,
    /// Taps N of both filters.
    #[arg(long, default_value_t = 35, value_parser = clap::value_parser!(u32).range(1..=1024))]
    taps: u32,
    /// Timed GPU rounds (after one warm-up).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Timed rounds of the CPU twins.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    cpu_rounds: u32,
    /// `gpu` (a hardware adapter, else a software one), `auto` (hardware only, else none) or
    /// `cpu` (the twins alone).
    #[arg(long, value_enum, default_value_t = DeviceArg::Gpu)]
    device: DeviceArg,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let design = load_design(&args.frame.design)?;
    let filters = match super::bench_device(args.device)? {
        Some(ctx) => Some(render::methods::post_process::GpuFilters::new(ctx)?),
        None => None,
    };
    let g = benchmark_gbuffer(&design, args.size.width, args.size.height)?;
    let opts = FilterTimingOptions {
        width: args.size.width,
        height: args.size.height,
        taps: args.taps,
        rounds: args.rounds,
        cpu_rounds: args.cpu_rounds,
    };
    let result = run_filter_timing(&g, filters.as_ref(), &opts)?;
    if args.frame.json {
        println!("{}", serde_json::to_string_pretty(&result)?);
    } else {
        for name in ["mcguire", "guertin"] {
            let r = &result["filters"][name];
            println!(
                "{name}: {:.3} ms on the GPU ({}), {:.1} ms by the CPU twin, {}x{} N = {}",
                r["gpu_ms_median"].as_f64().unwrap_or(f64::NAN),
                result["adapter"]["name"].as_str().unwrap_or("none"),
                r["cpu_twin_ms"].as_f64().unwrap_or(f64::NAN),
                args.size.width,
                args.size.height,
                args.taps
            );
        }
    }
    Ok(())
}
