//! `blurlab bench media`: the thesis's Table 2.1 redone (`media::bench`): frames per second
//! of the participating-media marcher at 512x512 for both data shapes, each lighting model
//! and each acceleration (brute force, validity mask, mask and distance map), on the GPU and
//! on its CPU twin in the same run, with the speed-ups against brute force, the work behind
//! them (density lookups) and the memory the marcher holds. The lights are the design's
//! environment map as a median-cut constellation; the data sets one simulated plume
//! resampled to the thesis's two shapes.

use media::bench::{Acceleration, BenchRow, BenchSetup, box_coverage, memory_bytes, model_name, table_camera};
use media::gpu::GpuMarcher;
use media::march::MarchLight;
use serde::Serialize;

use crate::cmd::BadInput;
use crate::cmd::stimuli::{DeviceArg, load_design};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Print the result as JSON (otherwise a Markdown table).
    #[arg(long)]
    json: bool,
    /// Design whose environment map lights the medium.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    design: std::path::PathBuf,
    /// Image width and height (the thesis timed 512x512).
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(8..=8192))]
    size: u32,
    /// Lights in the constellation (the thesis used up to 20).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=1024))]
    lights: u32,
    /// Segment length in voxels of the 128-voxel side.
    #[arg(long, default_value_t = 0.5)]
    step_voxels: f32,
    /// Extinction at density 1, per unit-cube length.
    #[arg(long, default_value_t = 40.0)]
    sigma_t: f32,
    /// Cells per side of the simulated plume the data sets are resampled from.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u64).range(4..=256))]
    sim_resolution: u64,
    /// Simulation steps before the plume is taken.
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    sim_steps: u32,
    /// Timed rounds per case, the fastest counting: the GPU's after one warm-up, and the CPU
    /// twin's (at 512x512 the twin's self-shadowed brute force takes about 15 minutes a round
    /// on 2 cores).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    rounds: u32,
    /// Time the CPU twin too (`--rounds` rounds per case; otherwise it runs once, untimed, for
    /// the work counts).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    cpu: bool,
    /// `gpu` (a hardware adapter, else a software one), `auto` (hardware only, else none) or
    /// `cpu` (the twin alone).
    #[arg(long, value_enum, default_value_t = DeviceArg::Gpu)]
    device: DeviceArg,
}

#[derive(Serialize)]
struct Row {
    data_set: String,
    lighting_model: &'static str,
    acceleration: &'static str,
    gpu_ms: Option<f64>,
    gpu_fps: Option<f64>,
    gpu_speedup: Option<f64>,
    cpu_ms: Option<f64>,
    cpu_fps: Option<f64>,
    cpu_speedup: Option<f64>,
    density_lookups: u64,
    pixels_with_medium: u64,
}

#[derive(Serialize)]
struct Memory {
    grid_and_distance_map_bytes_128: u64,
    mask_and_output_bytes: u64,
}

#[derive(Serialize)]
struct Report {
    benchmark: &'static str,
    design: String,
    adapter: Option<String>,
    software_adapter: Option<bool>,
    gpu_clock: Option<String>,
    cores: usize,
    size: u32,
    lights: u32,
    step: f32,
    sigma_t: f32,
    plume: String,
    box_coverage: f64,
    rows: Vec<Row>,
    memory: Memory,
    peak_resident_bytes: Option<u64>,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if !(args.step_voxels.is_finite() && args.step_voxels > 0.0 && args.step_voxels <= 64.0) {
        return Err(BadInput(format!("--step-voxels {}: expected a length in (0, 64]", args.step_voxels)).into());
    }
    if !(args.sigma_t.is_finite() && args.sigma_t >= 0.0) {
        return Err(BadInput(format!("--sigma-t {}: expected a finite extinction >= 0", args.sigma_t)).into());
    }
    let design = load_design(&args.design)?;
    let env = render::env::EnvironmentMap::from_lighting(&design.lighting)?;
    let constellation = env
        .light_constellation(args.lights as usize)
        .map_err(|e| BadInput(format!("{}: the environment as {} lights: {e}", args.design.display(), args.lights)))?;
    let lights: Vec<MarchLight> = constellation
        .lights
        .iter()
        .map(|l| MarchLight { direction: l.direction.as_vec3(), irradiance: l.irradiance.as_vec3() })
        .collect();
    let marcher = match super::bench_device(args.device)? {
        Some(ctx) => Some(GpuMarcher::new(ctx)?),
        None => None,
    };
    let data_sets = media::bench::table_data_sets(args.sim_resolution as usize, args.sim_steps)?;
    let setup = BenchSetup {
        size: (args.size, args.size),
        step: args.step_voxels / 128.0,
        sigma_t: args.sigma_t,
        albedo: 0.9,
        lights,
        rounds: args.rounds,
        cpu: args.cpu,
        shade_empty: true,
    };
    let cases = data_sets.len() * 9;
    let bar = indicatif::ProgressBar::new(cases as u64).with_style(
        indicatif::ProgressStyle::with_template("bench media {bar:40} {pos}/{len} cases {elapsed} ETA {eta} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let named: Vec<(String, &media::DensityGrid)> = data_sets.iter().map(|(n, g)| (n.clone(), g)).collect();
    let mut brute: (Option<f64>, Option<f64>) = (None, None);
    let mut rows = Vec::new();
    let mut timing_source = None;
    media::bench::run(&named, &setup, marcher.as_ref(), |r: &BenchRow| {
        if r.acceleration == Acceleration::BruteForce {
            brute = (r.gpu_seconds, r.cpu_seconds);
        }
        let ratio = |base: Option<f64>, t: Option<f64>| base.zip(t).map(|(b, t)| b / t);
        rows.push(Row {
            data_set: r.data_set.clone(),
            lighting_model: model_name(r.model),
            acceleration: r.acceleration.name(),
            gpu_ms: r.gpu_seconds.map(|s| 1e3 * s),
            gpu_fps: r.gpu_seconds.map(|s| 1.0 / s),
            gpu_speedup: ratio(brute.0, r.gpu_seconds),
            cpu_ms: r.cpu_seconds.map(|s| 1e3 * s),
            cpu_fps: r.cpu_seconds.map(|s| 1.0 / s),
            cpu_speedup: ratio(brute.1, r.cpu_seconds),
            density_lookups: r.primary_lookups + r.shadow_lookups,
            pixels_with_medium: r.pixels_with_medium,
        });
        if let Some(clock) = r.gpu_clock {
            timing_source = Some(format!("{clock:?}"));
        }
        bar.set_message(format!("{} {} {}", r.data_set, model_name(r.model), r.acceleration.name()));
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let (grid_bytes, image_bytes) = memory_bytes([128, 128, 128], setup.size);
    let report = Report {
        benchmark: "media",
        design: args.design.display().to_string(),
        adapter: marcher.as_ref().map(|m| m.info().name.clone()),
        software_adapter: marcher.as_ref().map(|m| m.info().is_software),
        gpu_clock: timing_source,
        cores: rayon::current_num_threads(),
        size: args.size,
        lights: args.lights,
        step: setup.step,
        sigma_t: args.sigma_t,
        plume: format!("{0}^3 cells, {1} steps, resampled", args.sim_resolution, args.sim_steps),
        box_coverage: box_coverage(&table_camera(setup.size), setup.size),
        rows,
        memory: Memory { grid_and_distance_map_bytes_128: grid_bytes, mask_and_output_bytes: image_bytes },
        peak_resident_bytes: runner::bench::memory_kib().map(|(_, peak)| peak * 1024),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

fn print_table(report: &Report) {
    println!(
        "Table 2.1 at {0}x{0}, {1} lights, step {2:.5}, on {3} ({4} cores for the CPU twin); the box covers {5:.0} % of the image",
        report.size,
        report.lights,
        report.step,
        report.adapter.as_deref().unwrap_or("no GPU"),
        report.cores,
        100.0 * report.box_coverage
    );
    println!("\n| data | model | acceleration | GPU ms | GPU fps | GPU speed-up | CPU ms | CPU speed-up | lookups |");
    println!("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    let f = |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |v| format!("{v:.digits$}"));
    for r in &report.rows {
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.data_set,
            r.lighting_model,
            r.acceleration,
            f(r.gpu_ms, 3),
            f(r.gpu_fps, 1),
            f(r.gpu_speedup, 2),
            f(r.cpu_ms, 1),
            f(r.cpu_speedup, 2),
            r.density_lookups
        );
    }
    println!(
        "\nmemory: grid and distance map {:.1} MB at 128^3; mask and output {:.1} MB",
        report.memory.grid_and_distance_map_bytes_128 as f64 / 1e6,
        report.memory.mask_and_output_bytes as f64 / 1e6
    );
}
