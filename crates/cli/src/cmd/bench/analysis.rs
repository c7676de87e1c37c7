//! `blurlab bench analysis` (not built yet).

/// Arguments.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the benchmark.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`bench analysis` is not built yet")
}
