//! `blurlab bench analysis`: speed of the analysis: one full 2AFC analysis (matrices, triads,
//! agreement, grouping, Thurstone scale with bootstrap) of simulated judges of the 36
//! interaction pairs, and single W quantiles. Prints JSON with the machine and settings
//! (`analysis::synthetic::benchmark`).

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Simulated judges (each judges the 36 pairs of the 9 interaction stimuli once).
    #[arg(long, default_value_t = 36)]
    judges: usize,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 1000)]
    resamples: usize,
    /// Repetitions of the full analysis (the median is reported).
    #[arg(long, default_value_t = 5)]
    repeats: usize,
    /// Seed of the simulated judges and the bootstrap.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON (the output is always JSON; accepted for symmetry with other benches).
    #[arg(long)]
    json: bool,
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let value = analysis::synthetic::benchmark(args.judges, args.resamples, args.repeats, args.seed);
    println!("{}", serde_json::to_string_pretty(&value)?);
    Ok(())
}
