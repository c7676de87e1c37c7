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
    /// Forecast a 2AFC experiment's votes and groups from the rendered sequences (an
    /// image-computable observer: ColorVideoVDP, or FLIP as the baseline).
    Predict(cmd::predict::Args),
    /// Benchmarks printing JSON.
    Bench(cmd::bench::Args),
    /// What accuracy costs in time: every method's error against its render time.
    Cost(cmd::cost::Args),
    /// The main job: render the quick set, run simulated participants, analyse them.
    Demo(cmd::demo::Args),
}

/// Keeps a library's false alarm off a successful run. Mesa's Vulkan device-select layer, an
/// implicit layer of every Vulkan instance on Mesa systems, connects to Wayland to find the
/// session's default GPU; without `XDG_RUNTIME_DIR` (no session: SSH, containers, CI)
/// libwayland then prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.`
/// twice while blurlab looks for an adapter, and the render goes on fine. Without a session
/// there is no display to select a GPU by, so the layer is turned off (`NODEVICE_SELECT=1`);
/// blurlab ranks the adapters itself. A user's own `NODEVICE_SELECT` is left alone.
fn quiet_device_select_without_a_session() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        #[allow(unsafe_code, reason = "set_var is sound here: the first call of main, before any thread")]
        // SAFETY: no other thread exists yet, so nothing reads the environment concurrently.
        unsafe {
            std::env::set_var("NODEVICE_SELECT", "1");
        }
    }
}

fn main() -> std::process::ExitCode {
    quiet_device_select_without_a_session();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Stimuli(args) => cmd::stimuli::run(&args),
        Command::RenderFrame(args) => cmd::render_frame::run(&args),
        Command::Run(args) => cmd::run::run(&args),
        Command::Analyze(args) => cmd::analyze::run(&args),
        Command::Stats(args) => cmd::stats::run(&args),
        Command::Predict(args) => cmd::predict::run(&args),
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
