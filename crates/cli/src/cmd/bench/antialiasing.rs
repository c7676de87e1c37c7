//! `blurlab bench antialiasing`: each method level of one stimulus of an antialiasing design
//! (`stimuli/antialiasing.toml`: one point per pixel, with MLAA, 2 x 2 to 4 x 4 points)
//! against an 8 x 8-point reference, RMSE and FLIP on the edge pixels and over the whole
//! frame (`render::measure::antialiasing`), as JSON.

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
    /// The frame (default: the preset's middle one).
    #[arg(long)]
    frame: Option<u32>,
    /// Lighting samples of every shading evaluation.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    lighting_samples: u32,
    /// Points per pixel along each axis of the reference (analytic `supersampling`).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=8))]
    reference_supersampling: u32,
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
        lighting_samples: args.lighting_samples,
        reference_supersampling: args.reference_supersampling,
    };
    let result = run_antialiasing_quality(&design, &opts)?;
    println!("{}", serde_json::to_string_pretty(&result)?);
    Ok(())
}
