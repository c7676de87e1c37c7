//! `blurlab bench tracer` (not built yet).

/// Arguments.
#[derive(clap::Args)]
pub struct Args {}

/// Runs the benchmark.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`bench tracer` is not built yet")
}
