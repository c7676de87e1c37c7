//! `blurlab bench tracer [--json] [--device cpu|gpu|auto]`: with `--device gpu`, the GPU
//! tracer's benchmark (`render::measure::tracer_gpu`: camera samples per second from GPU
//! timestamps, the CPU tracer beside it, what each kernel specialisation saves). With the
//! default `--device cpu`: camera samples per second of the CPU tracer on the
//! full-resolution M3-S3-T5 frame, and, side by side in the same run, Mitsuba 3
//! (`scalar_rgb`, `path` integrator of the same depth) on the same static frame at the same
//! samples per pixel, with the noise of both at that sample count
//! (`render::measure::tracer::run_benchmark`). The peer runs as `python3
//! bench/mitsuba_peer.py DIR`.

use std::path::PathBuf;

use render::measure::tracer::{BenchOptions, run_benchmark};
use render::measure::tracer_gpu::{GpuBenchOptions, run_gpu_benchmark};

use crate::cmd::stimuli::DeviceArg;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: super::FrameBench,
    /// Samples per pixel of every render.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Peer renderer: `mitsuba` or `none`.
    #[arg(long, default_value = "mitsuba")]
    peer: String,
    /// Python interpreter that has the `mitsuba` package.
    #[arg(long, default_value = "python3")]
    python: String,
    /// The peer's driver script.
    #[arg(long, default_value = "bench/mitsuba_peer.py")]
    peer_script: PathBuf,
    /// Mitsuba sampler (`independent`, `stratified`, `multijitter`, `ldsampler`, ...).
    #[arg(long, default_value = "independent")]
    mitsuba_sampler: String,
    /// Mitsuba variant: `scalar_rgb`, or `llvm_ad_rgb` (vectorised and JIT-compiled; it loads
    /// the system's LLVM from `DRJIT_LIBLLVM_PATH`, which the driver sets to Debian's
    /// `libLLVM-19.so` when unset).
    #[arg(long, default_value = "scalar_rgb")]
    mitsuba_variant: String,
    /// Folder for the peer's scene and images (default: a new temporary folder).
    #[arg(long)]
    work: Option<PathBuf>,
    /// Rounds of the measurement (ours, then the peer's, alternating); each renderer's
    /// rate is its best render over all rounds.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    rounds: u32,
    /// Which tracer: `cpu` (against the peer), `gpu` (a hardware adapter, else a software
    /// one) or `auto` (a hardware GPU if there is one, else the CPU).
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    device: DeviceArg,
    /// With a GPU: samples per pixel of the CPU tracer's render of the same frame, measured
    /// in the same run (0: none).
    #[arg(long, default_value_t = 16)]
    cpu_spp: u32,
}

fn gpu_tracer(device: DeviceArg) -> anyhow::Result<Option<render::methods::tracer::GpuTracer>> {
    match super::bench_device(device)? {
        Some(ctx) => Ok(Some(render::methods::tracer::GpuTracer::new(ctx)?)),
        None => Ok(None),
    }
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(tracer) = gpu_tracer(args.device)? {
        let opts = GpuBenchOptions {
            design: args.frame.design.clone(),
            spp: args.spp,
            cpu_spp: args.cpu_spp,
            rounds: args.rounds,
        };
        let result = run_gpu_benchmark(&tracer, &opts)?;
        if args.frame.json {
            println!("{}", serde_json::to_string_pretty(&result)?);
        } else {
            let rate = |v: &serde_json::Value| v["camera_samples_per_second"].as_f64().unwrap_or(f64::NAN);
            println!(
                "{}: {:.1} M camera samples/s (moving M3-S3-T5, {} spp), {:.1} M/s static",
                result["adapter"]["name"].as_str().unwrap_or("?"),
                rate(&result["gpu"]["moving_frame"]) / 1e6,
                args.spp,
                rate(&result["gpu"]["static_frame"]) / 1e6
            );
            if let Some(r) = result["gpu_over_cpu"].as_f64() {
                println!("GPU over the CPU tracer on this machine: {r:.2}x");
            }
            for s in result["specialisations"].as_array().into_iter().flatten() {
                println!(
                    "  {}: {:.0} % of the time saved",
                    s["what"].as_str().unwrap_or("?"),
                    100.0 * s["time_saved_fraction"].as_f64().unwrap_or(f64::NAN)
                );
            }
            println!(
                "full set projected: {:.1} min independent, {:.1} min nested",
                result["full_set_projection"]["minutes_independent"].as_f64().unwrap_or(f64::NAN),
                result["full_set_projection"]["minutes_nested"].as_f64().unwrap_or(f64::NAN)
            );
        }
        return Ok(());
    }
    let opts = BenchOptions {
        design: args.frame.design.clone(),
        spp: args.spp,
        peer: args.peer.clone(),
        python: args.python.clone(),
        peer_script: args.peer_script.clone(),
        mitsuba_sampler: args.mitsuba_sampler.clone(),
        mitsuba_variant: args.mitsuba_variant.clone(),
        work: args.work.clone(),
        rounds: args.rounds,
    };
    let result = run_benchmark(&opts)?;
    if args.frame.json {
        println!("{}", serde_json::to_string_pretty(&result)?);
    } else {
        let m = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN) / 1e6;
        println!(
            "blurlab (wide, {}): {:.2} M camera samples/s (moving M3-S3-T5), {:.2} M/s static, noise {:.4}",
            result["blurlab"]["isa"].as_str().unwrap_or("?"),
            result["blurlab"]["moving_frame"]["camera_samples_per_second"].as_f64().unwrap_or(f64::NAN) / 1e6,
            result["blurlab"]["static_frame"]["camera_samples_per_second"].as_f64().unwrap_or(f64::NAN) / 1e6,
            result["blurlab"]["static_frame"]["noise_rms"].as_f64().unwrap_or(f64::NAN)
        );
        for path in result["dispatch_paths"].as_array().into_iter().flatten() {
            println!(
                "  {}: {:.2} M/s static",
                path["isa"].as_str().unwrap_or("?"),
                m(&path["camera_samples_per_second"])
            );
        }
        let t = &result["thread_scaling"];
        println!(
            "  1 thread {:.2} M/s, {} threads {:.2} M/s; f64 reference {:.2} M/s static",
            m(&t["threads_1"]),
            t["threads_all_count"],
            m(&t["threads_all"]),
            m(&result["reference_f64"]["camera_samples_per_second"])
        );
        if let Some(c) = result.get("comparison") {
            println!(
                "mitsuba {}: {:.2} M/s, noise {:.4}; speed-up {:.2}x (mean {:.2}x), noise ratio {:.3}; at equal noise {:.2}x (mean {:.2}x)",
                result["mitsuba"]["variant"].as_str().unwrap_or("?"),
                m(&result["mitsuba"]["camera_samples_per_second"]),
                result["mitsuba"]["noise_rms"].as_f64().unwrap_or(f64::NAN),
                c["speedup_static"].as_f64().unwrap_or(f64::NAN),
                c["speedup_static_mean"].as_f64().unwrap_or(f64::NAN),
                c["noise_ratio_blurlab_over_mitsuba"].as_f64().unwrap_or(f64::NAN),
                c["speedup_at_equal_noise"].as_f64().unwrap_or(f64::NAN),
                c["speedup_at_equal_noise_mean"].as_f64().unwrap_or(f64::NAN)
            );
        }
        println!("full set projected: {:.1} h", result["full_set_projection"]["hours"].as_f64().unwrap_or(f64::NAN));
    }
    Ok(())
}
