//! The `blurlab` binary: thin subcommands over the study, render, runner and analysis crates.

mod cmd;

use clap::{Parser, Subcommand};

/// blurlab: perceptual studies of motion-blurred rendering.
#[derive(Parser)]
#[command(name = "blurlab", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Stimulus sets: render, list, describe, write the default environment map.
    Stimuli(cmd::stimuli::Args),
    /// Render one frame of one stimulus with a chosen method.
    RenderFrame(cmd::render_frame::Args),
    /// Run an experiment with a participant (or a simulated observer).
    Run(cmd::run::Args),
    /// Analyse response logs (or a table of published vote totals).
    Analyze(cmd::analyze::Args),
    /// Statistical helpers (e.g. the studentized range quantile W).
    Stats(cmd::stats::Args),
    /// Benchmarks printing JSON.
    Bench(cmd::bench::Args),
    /// What accuracy costs in time: every method's error against its render time.
    Cost(cmd::cost::Args),
    /// The main job: render the quick set, run simulated participants, analyse them.
    Demo(cmd::demo::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Stimuli(args) => cmd::stimuli::run(&args),
        Command::RenderFrame(args) => cmd::render_frame::run(&args),
        Command::Run(args) => cmd::run::run(&args),
        Command::Analyze(args) => cmd::analyze::run(&args),
        Command::Stats(args) => cmd::stats::run(&args),
        Command::Bench(args) => cmd::bench::run(&args),
        Command::Cost(args) => cmd::cost::run(&args),
        Command::Demo(args) => cmd::demo::run(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            std::process::ExitCode::from(cmd::exit_code(&error))
        }
    }
}
