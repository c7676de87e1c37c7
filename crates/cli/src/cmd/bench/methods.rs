//! `blurlab bench methods [--json]`: each rendering method's error against a high-sample
//! tracer reference, and its render time, for every material, speed and shutter of a design
//! with a method factor (`render::measure::methods`); the accumulation buffer's cost against the
//! tracer's at equal error. Without `--json` it prints a Markdown table.

use std::path::PathBuf;

use render::measure::methods::{QualityOptions, markdown_table, run_quality};

use crate::cmd::BadInput;
use crate::cmd::stimuli::{DeviceArg, design_error, load_design};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Print the result as JSON (otherwise a Markdown table).
    #[arg(long)]
    json: bool,
    /// Design file with a rendering-method factor.
    #[arg(long, default_value = "stimuli/methods.toml")]
    design: PathBuf,
    /// Preset of the design.
    #[arg(long, default_value = "quick")]
    preset: String,
    /// Frame index within the preset.
    #[arg(long, default_value_t = 4)]
    frame: u32,
    /// Sampling level (A level number) every method renders at.
    #[arg(long, default_value_t = 5)]
    level: u8,
    /// Samples per pixel of the tracer reference.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(2..))]
    reference_spp: u32,
    /// Largest samples per pixel of the tracer sweep that prices the accumulation buffer.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..))]
    sweep_spp: u32,
    /// Rendering device.
    #[arg(long, value_enum, default_value_t = DeviceArg::Cpu)]
    device: DeviceArg,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let design = load_design(&args.design)?;
    let preset = design.preset(&args.preset).map_err(design_error)?;
    let probe =
        design.frame_scene_with(&preset, &design.ids(study::design::Views::Mono)[0], 0).map_err(design_error)?;
    let env = render::env::EnvironmentMap::from_lighting(&probe.lighting).map_err(|e| BadInput(e.to_string()))?;
    let renderer = render::Renderer::open(args.device.into(), &env).map_err(|e| BadInput(e.to_string()))?;
    let opts = QualityOptions {
        preset: args.preset.clone(),
        frame: args.frame,
        level: args.level,
        reference_spp: args.reference_spp,
        sweep_spp: args.sweep_spp,
    };
    let bar = indicatif::ProgressBar::new(0).with_message("cells");
    let result = run_quality(&design, &renderer, &opts, |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .map_err(|e| match e {
        render::measure::methods::QualityError::Request(_) | render::measure::methods::QualityError::Design(_) => {
            anyhow::Error::new(BadInput(e.to_string()))
        }
        e => anyhow::Error::new(e),
    })?;
    bar.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&result)?);
    } else {
        print!("{}", markdown_table(&result));
    }
    Ok(())
}
