//! `blurlab bench ...`: benchmarks that print JSON, one submodule per measured component.

pub mod analysis;
pub mod analytic;
pub mod analytic_accuracy;
pub mod antialiasing;
pub mod cvvdp;
pub mod filters;
pub mod media;
pub mod media_reference;
pub mod methods;
pub mod mlaa;
pub mod playback;
pub mod selection;
pub mod tracer;

/// What the benchmarks of the design's M3-S3-T5 frame (tracer, filters, analytic) share.
#[derive(clap::Args)]
pub struct FrameBench {
    /// Print the result as JSON (otherwise a short summary).
    #[arg(long)]
    json: bool,
    /// Design file whose M3-S3-T5 benchmark frame is rendered.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    design: std::path::PathBuf,
}

/// The GPU a benchmark's `--device` asks for: none for `cpu`; for `auto` a hardware adapter
/// or none; for `gpu` a hardware adapter, else a software one, else an error.
pub fn bench_device(device: crate::cmd::stimuli::DeviceArg) -> anyhow::Result<Option<gpu::GpuContext>> {
    use crate::cmd::stimuli::DeviceArg;
    let adapters = match device {
        DeviceArg::Cpu | DeviceArg::CpuReference => return Ok(None),
        DeviceArg::Auto => gpu::AdapterChoice::HardwareOnly,
        DeviceArg::Gpu => gpu::AdapterChoice::HardwareThenSoftware,
    };
    match gpu::acquire(adapters, &render::methods::tracer::host::device_request()) {
        Ok(ctx) => Ok(Some(ctx)),
        Err(_) if matches!(device, DeviceArg::Auto) => Ok(None),
        Err(e) => Err(crate::cmd::BadInput(format!("--device gpu: {e}")).into()),
    }
}

/// An image-space post-process's benchmark size: 1280x720 unless given, the size its
/// papers time it at (the filters', MLAA's).
#[derive(clap::Args)]
pub struct PostProcessSize {
    /// Image width.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
}

/// The benchmark frame's size (the analytic rasterizer's benchmarks).
#[derive(clap::Args)]
pub struct FrameSize {
    /// Image width.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 360, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
}

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    which: Which,
}

#[derive(clap::Subcommand)]
enum Which {
    /// Camera samples per second of the CPU tracer (optionally against Mitsuba 3).
    Tracer(tracer::Args),
    /// Milliseconds per frame of the post-process filters (GPU timestamps, CPU twins beside).
    Filters(filters::Args),
    /// Each rendering method's error against a tracer reference, and its time.
    Methods(methods::Args),
    /// Milliseconds per frame of morphological antialiasing (GPU timestamps, CPU twin beside).
    Mlaa(mlaa::Args),
    /// Each antialiasing level's error on edge pixels against an 8 x 8-point reference.
    Antialiasing(antialiasing::Args),
    /// ColorVideoVDP frames per second at 640x360, one thread and every core; peak memory.
    Cvvdp(cvvdp::Args),
    /// Frames per second of the participating-media marcher: Table 2.1 (GPU and CPU twin).
    Media(media::Args),
    /// The reference tracer with a participating medium beside Mitsuba 3's volpath: agreement and speed.
    MediaReference(media_reference::Args),
    /// Analysis speed: grouping, bootstrap scaling, W quantiles.
    Analysis(analysis::Args),
    /// Active pair selection (ASAP) against complete and random designs: accuracy per trial, selection time.
    Selection(selection::Args),
    /// Runner: sequence decode/upload time, memory, frame pacing.
    Playback(playback::Args),
    /// Milliseconds per frame of the analytic rasterizer, intervals per pixel.
    Analytic(analytic::Args),
    /// The analytic rasterizer's approximations: depth error histogram, tessellation error.
    AnalyticAccuracy(analytic_accuracy::Args),
}

/// Runs the chosen benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.which {
        Which::Tracer(a) => tracer::run(a),
        Which::Filters(a) => filters::run(a),
        Which::Methods(a) => methods::run(a),
        Which::Mlaa(a) => mlaa::run(a),
        Which::Antialiasing(a) => antialiasing::run(a),
        Which::Cvvdp(a) => cvvdp::run(a),
        Which::Media(a) => media::run(a),
        Which::MediaReference(a) => media_reference::run(a),
        Which::Analysis(a) => analysis::run(a),
        Which::Selection(a) => selection::run(a),
        Which::Playback(a) => playback::run(a),
        Which::Analytic(a) => analytic::run(a),
        Which::AnalyticAccuracy(a) => analytic_accuracy::run(a),
    }
}
