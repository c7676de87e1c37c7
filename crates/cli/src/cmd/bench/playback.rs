//! `blurlab bench playback` (not built yet).

/// Arguments.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the benchmark.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`bench playback` is not built yet")
}
