//! `blurlab stimuli`: render a design's stimulus set (whole, or one shard of it), merge
//! shards into one verified set, list its ids, describe a frame's scene, write the built-in
//! environment map.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::{Subcommand, ValueEnum};
use sets::set::{ProgressMode, SetError, SetRequest, render_set};
use sets::shard::{Plan, ShardSpec, merge as merge_shards, render_shard};
use study::design::{Design, DesignError, Preset, Views};
use study::ids::{Factor, StimulusId};
use study::manifest::Sampling;
use study::scene::FrameScene;
use study::select::Selection;

use super::BadInput;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render every selected sequence of a design into a set folder.
    Render(RenderArgs),
    /// Merge shard folders into one set, verifying that every unit of their plan is present
    /// exactly once with files that hash as recorded; with no shard folders, check (and
    /// complete) a shared set folder in place.
    Merge(MergeArgs),
    /// Print the ids of the selected sequences, one per line.
    List(ListArgs),
    /// Print the scene of one frame of one stimulus.
    Describe(DescribeArgs),
    /// Write the built-in procedural environment map as an EXR file.
    Env(EnvArgs),
}

/// Which views to use (mono, stereo or both).
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ViewsArg {
    /// Monoscopic sequences.
    Mono,
    /// Side-by-side stereo sequences.
    Stereo,
    /// Both (monoscopic first).
    Both,
}

impl From<ViewsArg> for Views {
    fn from(v: ViewsArg) -> Views {
        match v {
            ViewsArg::Mono => Views::Mono,
            ViewsArg::Stereo => Views::Stereo,
            ViewsArg::Both => Views::Both,
        }
    }
}

/// Rendering device.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DeviceArg {
    /// A hardware GPU adapter if there is one, else the CPU tracer (never a software
    /// adapter such as lavapipe, which is slower than the CPU tracer).
    Auto,
    /// The CPU: the wide tracer (SIMD lanes, the widest instruction set the CPU has).
    Cpu,
    /// The CPU: the f64 reference tracer (slower; for checks).
    CpuReference,
    /// The GPU tracer: a hardware adapter, else a software one; an error without either.
    Gpu,
}

impl From<DeviceArg> for render::DeviceChoice {
    fn from(d: DeviceArg) -> Self {
        match d {
            DeviceArg::Auto => render::DeviceChoice::Auto,
            DeviceArg::Cpu => render::DeviceChoice::Cpu,
            DeviceArg::CpuReference => render::DeviceChoice::CpuReference,
            DeviceArg::Gpu => render::DeviceChoice::Gpu,
        }
    }
}

#[derive(clap::Args)]
struct Selecting {
    /// The design file.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    design: PathBuf,
    /// Preset: `full` (the design as written) or one the design defines, e.g. `quick`.
    #[arg(long, default_value = "full")]
    preset: String,
    /// Views to include.
    #[arg(long, value_enum, default_value_t = ViewsArg::Both)]
    views: ViewsArg,
    /// Select sequences by factor levels, e.g. "M2 S2 T3-T5 *" (terms: `M2`, `T3-T5`,
    /// `M1,M3`, `*`, `mono`, `stereo`).
    #[arg(long)]
    only: Option<String>,
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    select: Selecting,
    /// The set folder.
    #[arg(long)]
    out: PathBuf,
    /// Skip sequences whose manifest and frame hashes verify.
    #[arg(long)]
    resume: bool,
    /// Also write linear EXR frames.
    #[arg(long)]
    exr: bool,
    /// Rendering device.
    #[arg(long, value_enum, default_value_t = DeviceArg::Auto)]
    device: DeviceArg,
    /// Render the sample levels of each material, speed, shutter and view once, as prefixes
    /// of one sample stream seeded as the highest level (faster; off by default: the study
    /// renders every level independently). The manifests and index record the mode.
    #[arg(long)]
    nested: bool,
    /// Render only shard K of N (`K/N`, K from 0 to N-1 as Slurm's SLURM_ARRAY_TASK_ID):
    /// the units (sequence, frame range) the cost-balanced plan gives it. Every shard of a
    /// set takes the same design, preset, selection, --exr and --nested.
    #[arg(long)]
    shard: Option<String>,
    /// With --shard: print the plan (every shard's units and estimated cost) and render
    /// nothing.
    #[arg(long, requires = "shard")]
    plan: bool,
    /// Progress on stderr: bars on a terminal, else one line per sequence.
    #[arg(long, value_enum, default_value_t = ProgressArg::Auto)]
    progress: ProgressArg,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ProgressArg {
    Auto,
    Lines,
    Quiet,
}

#[derive(clap::Args)]
struct MergeArgs {
    /// The merged set folder (new, or a set merged before); alone, the shared folder to check.
    out: PathBuf,
    /// Shard folders (each rendered with --shard into its own folder).
    dirs: Vec<PathBuf>,
    /// Progress on stderr: bars on a terminal, else one line per sequence.
    #[arg(long, value_enum, default_value_t = ProgressArg::Auto)]
    progress: ProgressArg,
}

#[derive(clap::Args)]
struct ListArgs {
    #[command(flatten)]
    select: Selecting,
}

/// One frame of one stimulus of a design: the arguments `stimuli describe` and
/// `render-frame` share.
#[derive(clap::Args)]
pub struct FrameArgs {
    /// The design file.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    design: PathBuf,
    /// Preset: `full` or one the design defines.
    #[arg(long, default_value = "full")]
    preset: String,
    /// Stimulus id, e.g. `M2-S2-T3-A5` or `M2-S2-T3-A5-stereo`.
    id: String,
    /// Frame index (0-based within the preset).
    #[arg(long, default_value_t = 0)]
    pub frame: u32,
}

/// A frame resolved against its design.
pub struct Frame {
    /// The loaded design.
    pub design: Design,
    /// The preset.
    pub preset: Preset,
    /// The stimulus.
    pub id: StimulusId,
    /// The exact scene of the frame.
    pub scene: FrameScene,
}

impl FrameArgs {
    /// Loads the design and builds the frame's scene; bad input names what is wrong.
    pub fn resolve(&self) -> anyhow::Result<Frame> {
        let design = load_design(&self.design)?;
        let id: StimulusId = self.id.parse().map_err(|e: study::ids::IdError| BadInput(e.to_string()))?;
        let preset = design.preset(&self.preset).map_err(design_error)?;
        let scene = design.frame_scene_with(&preset, &id, self.frame).map_err(design_error)?;
        Ok(Frame { design, preset, id, scene })
    }
}

#[derive(clap::Args)]
struct DescribeArgs {
    #[command(flatten)]
    frame: FrameArgs,
    /// Print the exact scene as JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct EnvArgs {
    /// Output EXR file.
    #[arg(long)]
    out: PathBuf,
    /// Width of the map in pixels: even, 4 to 8192 (the height is half); default 1024, the
    /// width the shipped design's `lighting.environment` gives its built-in map. This command
    /// reads no design.
    #[arg(long)]
    width: Option<u32>,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.command {
        Command::Render(a) => render(a),
        Command::Merge(a) => merge(a),
        Command::List(a) => list(a),
        Command::Describe(a) => describe(a),
        Command::Env(a) => env(a),
    }
}

/// Loads a design file; its errors are bad input, its warnings go to stderr.
pub fn load_design(path: &Path) -> anyhow::Result<Design> {
    let design = Design::load(path).map_err(design_error)?;
    for w in design.warnings() {
        eprintln!("warning: {w}");
    }
    Ok(design)
}

/// Marks a design error as bad input (exit code 2).
#[expect(clippy::needless_pass_by_value, reason = "the `map_err` adapter of every design call")]
pub fn design_error(e: DesignError) -> anyhow::Error {
    BadInput(e.to_string()).into()
}

fn selected(design: &Design, select: &Selecting) -> anyhow::Result<Vec<StimulusId>> {
    let selection = match &select.only {
        Some(text) => text.parse::<Selection>().map_err(|e| BadInput(format!("--only: {e}")))?,
        None => Selection::all(),
    };
    for factor in Factor::ALL {
        let missing = selection.missing_levels(factor, design.level_count(factor));
        if let Some(level) = missing.first() {
            return Err(BadInput(format!(
                "--only `{selection}`: level {}{level} does not exist in {} ({}1..{}{})",
                factor.letter(),
                design.path.display(),
                factor.letter(),
                factor.letter(),
                design.level_count(factor)
            ))
            .into());
        }
    }
    let ids: Vec<StimulusId> = design.ids(select.views.into()).into_iter().filter(|id| selection.matches(id)).collect();
    if ids.is_empty() {
        return Err(
            BadInput(format!("--only `{selection}` with --views {:?} selects no sequence", select.views)).into()
        );
    }
    Ok(ids)
}

fn render(a: &RenderArgs) -> anyhow::Result<()> {
    let design = load_design(&a.select.design)?;
    let preset = design.preset(&a.select.preset).map_err(design_error)?;
    let ids = selected(&design, &a.select)?;
    let shard = match &a.shard {
        Some(text) => Some(text.parse::<ShardSpec>().map_err(|e| BadInput(format!("--shard {e}")))?),
        None => None,
    };
    let request = SetRequest {
        design: &design,
        preset,
        ids,
        out: a.out.clone(),
        resume: a.resume,
        exr: a.exr,
        progress: a.progress.into(),
        device: a.device.into(),
        sampling: if a.nested { Sampling::Nested } else { Sampling::Independent },
    };
    if let Some(shard) = shard {
        if a.plan {
            let plan = Plan::compute(&request, shard.count).map_err(set_error)?;
            print!("{}", plan.describe());
            return Ok(());
        }
        let r = render_shard(&request, shard).map_err(set_error)?;
        eprintln!(
            "{}: shard {shard}: {} of its {} units rendered on {}, {} verified and skipped, {} left to other processes, {} sequences completed, {} non-finite samples discarded, {:.1} s",
            a.out.display(),
            r.rendered.len(),
            r.units,
            r.device,
            r.skipped.len(),
            r.left_to_others.len(),
            r.completed.len(),
            r.nonfinite_samples,
            r.wall_seconds
        );
        return Ok(());
    }
    let report = render_set(&request).map_err(set_error)?;
    eprintln!(
        "{}: {} sequences rendered on {}, {} verified and skipped, {} non-finite samples discarded, {:.1} s",
        a.out.display(),
        report.rendered.len(),
        report.device,
        report.skipped.len(),
        report.nonfinite_samples,
        report.wall_seconds
    );
    Ok(())
}

fn merge(a: &MergeArgs) -> anyhow::Result<()> {
    let r = merge_shards(&a.out, &a.dirs, a.progress.into()).map_err(set_error)?;
    eprintln!(
        "{}: {} units of {} shards verified, {} sequences in the set, {} frame files copied, {:.1} s",
        a.out.display(),
        r.units,
        r.shards,
        r.sequences,
        r.copied_files,
        r.wall_seconds
    );
    Ok(())
}

impl From<ProgressArg> for ProgressMode {
    fn from(p: ProgressArg) -> Self {
        match p {
            ProgressArg::Auto => ProgressMode::Auto,
            ProgressArg::Lines => ProgressMode::Lines,
            ProgressArg::Quiet => ProgressMode::Quiet,
        }
    }
}

/// Turns a set error into an `anyhow` error with the right exit code.
pub fn set_error(e: SetError) -> anyhow::Error {
    if e.is_bad_input() { BadInput(e.to_string()).into() } else { anyhow::Error::new(e) }
}

fn list(a: &ListArgs) -> anyhow::Result<()> {
    let design = load_design(&a.select.design)?;
    design.preset(&a.select.preset).map_err(design_error)?;
    for id in selected(&design, &a.select)? {
        println!("{id}");
    }
    Ok(())
}

fn describe(a: &DescribeArgs) -> anyhow::Result<()> {
    let Frame { design, preset, id, scene } = a.frame.resolve()?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&scene)?);
        return Ok(());
    }
    let f = design.factors(&id, &preset).map_err(design_error)?;
    println!("{id}, frame {} of preset `{}` ({})", a.frame.frame, preset.name, design.path.display());
    println!(
        "  factors: {} {}, {} {} ({} deg/s), {} {} ({} of the frame), {} {} ({} spp)",
        f.material.label,
        f.material.name,
        f.speed.label,
        f.speed.name,
        f.speed.value,
        f.shutter.label,
        f.shutter.name,
        f.shutter.value,
        f.samples.label,
        f.samples.name,
        scene.samples_per_pixel
    );
    println!(
        "  time {:.6} s, shutter open {:.6} s, close {:.6} s",
        scene.frame_time, scene.shutter.open, scene.shutter.close
    );
    for v in &scene.views {
        let c = &v.camera;
        println!(
            "  {:?} camera at {:.4?} looking {:.4?}, {} mm lens, {} mm sensor (shift {:.4?} mm), {}x{}, seed {}",
            v.eye,
            c.position.to_array(),
            c.forward.to_array(),
            c.focal_length * 1000.0,
            c.sensor_width * 1000.0,
            (c.sensor_shift * 1000.0).to_array(),
            c.width,
            c.height,
            v.seed
        );
    }
    let s = &scene.sphere;
    for (what, t) in [("open", scene.shutter.open), ("close", scene.shutter.close)] {
        println!(
            "  sphere at shutter {what}: centre {:.4?}, orientation {:.4?}",
            s.centre_at(t).to_array(),
            s.orientation_at(t).to_array()
        );
    }
    println!(
        "  sphere: radius {} m, velocity {:.4?} m/s, path wraps every {:?} m",
        s.radius,
        s.velocity.to_array(),
        s.wrap_length
    );
    println!("  material: {:?}", scene.material);
    println!("  floor: height {} m, albedo {:?}", scene.floor.height, scene.floor.albedo);
    println!("  lighting: {:?}", scene.lighting);
    println!("  integrator: {:?}; exposure: {:?}", scene.integrator, scene.exposure);
    Ok(())
}

fn env(a: &EnvArgs) -> anyhow::Result<()> {
    let width = a.width.unwrap_or(1024);
    if !(4..=8192).contains(&width) || !width.is_multiple_of(2) {
        return Err(BadInput(format!("--width {width}: must be an even number from 4 to 8192")).into());
    }
    let image = render::env::default_map(width);
    let bytes = render::io::encode_exr(&image).context("cannot encode the environment map")?;
    if let Some(parent) = a.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("{}: cannot create the folder", parent.display()))?;
    }
    study::fsio::write_atomic(&a.out, &bytes).with_context(|| format!("{}: cannot write", a.out.display()))?;
    eprintln!("{}: {}x{} linear EXR", a.out.display(), image.width, image.height);
    Ok(())
}
