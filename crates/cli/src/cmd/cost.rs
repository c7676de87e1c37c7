//! `blurlab cost`: what accuracy costs in time. Sweeps every rendering method over its
//! accuracy knob against a converged tracer reference (`render::measure::cost`, resumable in `--out`)
//! and writes the report (`analysis::cost`): `cost.csv`, `cost.md`, log-log plots, FLIP
//! error maps and, with `--report`, the analysis report's equivalent groups on the curves.

use std::path::{Path, PathBuf};

use render::measure::cost::{CostError, CostRequest, run_cost};
use study::Method;

use super::BadInput;
use super::stimuli::{DeviceArg, load_design};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// The design file.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    pub design: PathBuf,
    /// Preset of the design.
    #[arg(long, default_value = "full")]
    pub preset: String,
    /// The material, speed and shutter swept, e.g. `M3-S3-T5` (`-stereo` for stereo frames).
    #[arg(long)]
    pub id: String,
    /// Frames (indices within the preset), comma-separated; default the middle frame.
    #[arg(long, value_delimiter = ',')]
    pub frames: Vec<u32>,
    /// Rendering device.
    #[arg(long, value_enum, default_value_t = DeviceArg::Auto)]
    pub device: DeviceArg,
    /// Methods swept, comma-separated (tracer, accum, mcguire, guertin, analytic, marcher);
    /// default all.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// Samples per pixel of the reference (its standard error must be below a tenth of the
    /// smallest error judged: at least 100 times --max-spp).
    #[arg(long, default_value_t = 131072)]
    pub reference_spp: u32,
    /// The tracer's largest samples per pixel (powers of two from 1, and the preset's levels).
    #[arg(long, default_value_t = 1024)]
    pub max_spp: u32,
    /// Renders per point (independent seeds): median and spread.
    #[arg(long, default_value_t = 3)]
    pub repetitions: u32,
    /// An analysis report (folder or report.json) whose equivalent groups are marked.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Output folder (kept points are reused: a killed sweep continues).
    #[arg(long)]
    pub out: PathBuf,
    /// Measure at most this many new points, then write the report so far and stop.
    #[arg(long)]
    pub max_new_points: Option<usize>,
    /// Also sweep morphological antialiasing: the tracer with every sample through the pixel
    /// centre at the preset's highest sampling level, filtered by MLAA along its search
    /// distance (0 = unfiltered) and its threshold (needs tracer among --methods).
    #[arg(long)]
    pub mlaa: bool,
    /// No progress bar (lines on stderr instead).
    #[arg(long)]
    pub quiet: bool,
}

fn cost_error(e: CostError) -> anyhow::Error {
    if e.is_bad_input() { BadInput(e.to_string()).into() } else { anyhow::Error::new(e) }
}

/// Runs the sweep and writes the report; returns cost.md's path.
pub fn cost_report(args: &Args) -> anyhow::Result<PathBuf> {
    let design = load_design(&args.design)?;
    let methods: Vec<Method> = args
        .methods
        .iter()
        .map(|m| m.trim().parse::<Method>().map_err(|e| BadInput(format!("--methods: {e}"))))
        .collect::<Result<_, _>>()?;
    let preset = design.preset(&args.preset).map_err(super::stimuli::design_error)?;
    let probe = design
        .frame_scene_with(&preset, &design.ids(study::design::Views::Mono)[0], 0)
        .map_err(super::stimuli::design_error)?;
    let env = render::env::EnvironmentMap::from_lighting(&probe.lighting).map_err(|e| BadInput(e.to_string()))?;
    let renderer = render::Renderer::open(args.device.into(), &env).map_err(|e| BadInput(e.to_string()))?;
    let request = CostRequest {
        preset: args.preset.clone(),
        cell: args.id.clone(),
        frames: args.frames.clone(),
        methods,
        reference_spp: args.reference_spp,
        max_spp: args.max_spp,
        repetitions: args.repetitions,
        out: args.out.clone(),
        max_new_points: args.max_new_points,
        mlaa: args.mlaa,
    };
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new(0).with_style(
            indicatif::ProgressStyle::with_template("cost {bar:40} {pos}/{len} points ({msg}) {elapsed} ETA {eta}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        )
    };
    let outcome = run_cost(&design, &renderer, &request, |p| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
        bar.set_message(format!("{} measured now", p.measured));
    })
    .map_err(cost_error)?;
    bar.finish_and_clear();
    eprintln!(
        "cost: {} points measured, {} kept from an earlier run{}",
        outcome.measured,
        outcome.kept,
        if outcome.complete { "" } else { "; stopped early (--max-new-points): rerun to continue" }
    );
    let groups = match &args.report {
        Some(dir) => analysis::cost::groups_from_report(dir, &outcome.sweep).map_err(|e| BadInput(e.to_string()))?,
        None => Vec::new(),
    };
    Ok(analysis::cost::write_cost_report(&outcome.sweep, &groups, &args.out)?)
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let md = cost_report(args)?;
    println!("cost report: {}", md.display());
    Ok(())
}

/// The demo's small cost report: the quick preset's cell, few samples, one repetition.
pub fn demo_args(design: &Path, cell: &str, report: Option<PathBuf>, out: PathBuf) -> Args {
    Args {
        design: design.to_owned(),
        preset: "quick".into(),
        id: cell.into(),
        frames: Vec::new(),
        device: DeviceArg::Auto,
        methods: vec!["tracer".into(), "accum".into()],
        reference_spp: 4096,
        max_spp: 16,
        repetitions: 2,
        report,
        out,
        max_new_points: None,
        mlaa: false,
        quiet: true,
    }
}
