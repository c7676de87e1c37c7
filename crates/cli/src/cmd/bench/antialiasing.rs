//! `blurlab bench antialiasing`: each method level of one stimulus of an antialiasing design
//! (`stimuli/antialiasing.toml`: one point per pixel, with MLAA, 2 x 2 to 4 x 4 points)
//! against an 8 x 8-point reference, RMSE and FLIP on the edge pixels and over the whole
//! frame and, over consecutive frames, the edges' flicker (`render::measure::antialiasing`),
//! as JSON.

use render::measure::antialiasing::{AntialiasingOptions, run_antialiasing_quality};
use study::ids::Cell;

use crate::cmd::BadInput;
use crate::cmd::stimuli::load_design;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// The design with an antialiasing method factor.
    #[arg(long, default_value = "stimuli/antialiasing.toml")]
    design: std::path::PathBuf,
    /// Preset.
    #[arg(long, default_value = "quick")]
    preset: String,
    /// The stimulus without its method tag, e.g. `M2-S1-T1-A2`.
    #[arg(long, default_value = "M2-S1-T1-A2")]
    id: String,
    /// The first frame (default: the preset's middle one).
    #[arg(long)]
    frame: Option<u32>,
    /// Consecutive frames from --frame: two or more also measure temporal stability (the
    /// flicker of the edges against the reference's frame-to-frame change).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Lighting samples of every shading evaluation.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    lighting_samples: u32,
    /// Points per pixel along each axis of the reference (analytic `supersampling`).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=8))]
    reference_supersampling: u32,
    /// FLIP's pixels per degree (default: the design's viewing geometry at the preset's width).
    #[arg(long)]
    ppd: Option<f64>,
    /// Write the first frame of the reference and of each level (PNG) with each level's FLIP
    /// map into this folder.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
}

/// Runs the measurement.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let design = load_design(&args.design)?;
    let id: study::ids::StimulusId =
        args.id.parse().map_err(|e: study::ids::IdError| BadInput(format!("--id: {e}")))?;
    let (cell, samples): (Cell, u8) = (id.cell(), id.samples);
    let preset = design.preset(&args.preset).map_err(|e| BadInput(e.to_string()))?;
    let opts = AntialiasingOptions {
        preset: args.preset.clone(),
        cell,
        samples,
        frame: args.frame.unwrap_or(preset.frames / 2),
        frames: args.frames,
        lighting_samples: args.lighting_samples,
        reference_supersampling: args.reference_supersampling,
        out: args.out.clone(),
        pixels_per_degree: args.ppd,
    };
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("antialiasing {bar:40} {pos}/{len} renders {elapsed} ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let result = run_antialiasing_quality(&design, &opts, |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(|e| match e {
        render::measure::antialiasing::AntialiasingError::Request(m) => BadInput(m).into(),
        other => anyhow::Error::new(other),
    })?;
    bar.finish_and_clear();
    println!("{}", serde_json::to_string_pretty(&result)?);
    Ok(())
}
