//! `blurlab analyze`: analyse response logs into a report folder (report.md, report.json,
//! PNG and SVG figures), or group a table of published vote totals (`--votes`).

use std::path::{Path, PathBuf};

use analysis::experiment::{AnalysisOptions, JudgeUnit};
use analysis::report::{build_report_screened, votes_table_figure, write_report};
use analysis::scaling::ScaleOptions;
use analysis::votes::{VoteTable, analyze_votes};
use anyhow::Context;

use super::BadInput;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Response logs: files or folders searched recursively for `*.csv` (one experiment per
    /// folder; give mono and stereo folders together to compare them).
    results: Vec<PathBuf>,
    /// A table of vote totals (`blurlab-votes/1`, e.g. analysis/reference/*.csv) instead of logs.
    #[arg(long, conflicts_with = "results")]
    votes: Option<PathBuf>,
    /// Number of judges for `--votes` (default: the table's `judges` field).
    #[arg(long, requires = "votes")]
    judges: Option<u32>,
    /// Significance level of the grouping (default: the table's `alpha`, else 0.01).
    #[arg(long)]
    alpha: Option<f64>,
    /// Rendered stimulus set (folder or its index.json): render costs and known stimulus ids.
    #[arg(long)]
    manifest: Option<PathBuf>,
    /// Folder of experiment definitions (`NAME.toml`), used when the logs' hash matches.
    #[arg(long, default_value = "experiments")]
    experiments: PathBuf,
    /// Print report.json (or the vote analysis) on stdout.
    #[arg(long)]
    json: bool,
    /// Report folder (for `--votes`, written only when given).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Pool each participant's sessions into one judge for per-judge scores and the bootstrap.
    #[arg(long)]
    pool_participants: bool,
    /// Bootstrap resamples of the Thurstone scale (0 for none, at most 100000).
    #[arg(long, default_value_t = 1000)]
    bootstrap: usize,
    /// Seed of the bootstrap (recorded in the report).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Leave out the sessions of the participants observer screening flags (answers far less
    /// likely than the others' under the scale fitted without them); the report names them.
    #[arg(long, conflicts_with = "votes")]
    exclude_outliers: bool,
}

fn bad(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::Error::new(BadInput(e.to_string()))
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(alpha) = args.alpha
        && !(alpha > 0.0 && alpha < 1.0)
    {
        return Err(bad(format!("--alpha {alpha}: expected a number strictly between 0 and 1")));
    }
    if let Some(path) = &args.votes {
        return run_votes(path, args);
    }
    if args.results.is_empty() {
        return Err(bad("give response logs (files or folders) or --votes FILE"));
    }
    let options = AnalysisOptions {
        alpha: args.alpha.unwrap_or(0.01),
        judge_unit: if args.pool_participants { JudgeUnit::Participant } else { JudgeUnit::Replicate },
        scale: ScaleOptions { resamples: args.bootstrap, seed: args.seed, ..ScaleOptions::default() },
    };
    if args.bootstrap > analysis::scaling::MAX_RESAMPLES {
        return Err(BadInput(format!(
            "--bootstrap {}: above the limit of {} resamples",
            args.bootstrap,
            analysis::scaling::MAX_RESAMPLES
        ))
        .into());
    }
    let experiments = args.experiments.is_dir().then_some(args.experiments.as_path());
    let mut report =
        build_report_screened(&args.results, args.manifest.as_deref(), experiments, options, args.exclude_outliers)
            .map_err(|e| match e {
                analysis::report::ReportError::Io { .. } => anyhow::Error::new(e),
                other => bad(other),
            })?;
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from("report"));
    let md = write_report(&mut report, &out).with_context(|| format!("writing the report into {}", out.display()))?;
    let replacement = |p: &analysis::experiment::PairedReport| {
        p.recommendation
            .as_ref()
            .map(|r| format!("; {} can replace {} (saves {:.1} %)", r.cheapest, r.reference, r.saving * 100.0))
            .unwrap_or_default()
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        for e in &report.experiments {
            let summary = match (&e.paired, &e.matching) {
                (Some(p), _) if p.design.is_incomplete() => format!(
                    "incomplete design, Kendall's statistics not computed; {} participants, {} trials, {} groups on the Thurstone scale{}",
                    p.screening.observers.len() - p.excluded_participants.len(),
                    p.matrix_all.total(),
                    p.groups.len(),
                    replacement(p)
                ),
                (Some(p), _) => format!("{} judges, {} groups{}", p.complete_judges, p.groups.len(), replacement(p)),
                (None, Some(m)) => format!("matching accuracy {:.2} % of {} trials", m.overall * 100.0, m.trials),
                _ => String::new(),
            };
            println!("{}: {summary}", e.name);
            if let Some(p) = &e.paired {
                if !p.excluded_participants.is_empty() {
                    println!(
                        "{}: excluded outlying participants (--exclude-outliers): {}",
                        e.name,
                        p.excluded_participants.join(", ")
                    );
                } else if !p.screening.flagged.is_empty() {
                    println!(
                        "{}: flagged participants (kept; --exclude-outliers leaves them out): {}",
                        e.name,
                        p.screening.flagged.join(", ")
                    );
                }
            }
            for w in &e.warnings {
                eprintln!("warning: {w}");
            }
        }
        println!("report: {}", md.display());
    }
    Ok(())
}

fn run_votes(path: &Path, args: &Args) -> anyhow::Result<()> {
    let table = VoteTable::read(path).map_err(bad)?;
    let judges = match args.judges {
        Some(m) => m,
        None => table
            .judges()
            .map_err(bad)?
            .ok_or_else(|| bad(format!("{}: no `# judges:` header line; give --judges M", path.display())))?,
    };
    if judges == 0 {
        return Err(bad("--judges must be at least 1"));
    }
    let alpha = match args.alpha {
        Some(a) => a,
        None => table.alpha().map_err(bad)?.unwrap_or(0.01),
    };
    let analysis = analyze_votes(&table, judges, alpha).map_err(bad)?;
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        let stem = path.file_stem().map_or("votes".into(), |s| s.to_string_lossy().into_owned());
        let figure =
            votes_table_figure(&stem, &analysis.labels, &analysis.votes, &analysis.groups, analysis.critical.ceil_rc);
        analysis::plots::save_figure(&figure, out, &format!("{stem}-votes"))?;
        let json_path = out.join(format!("{stem}.json"));
        study::fsio::write_atomic(&json_path, serde_json::to_string_pretty(&analysis)?.as_bytes())
            .with_context(|| format!("writing {}", json_path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&analysis)?);
        return Ok(());
    }
    let c = analysis.critical;
    println!("{}: t = {}, m = {}, alpha = {}", path.display(), c.t, c.judges, c.alpha);
    println!("W = {:.6}, R_c = {:.4}, ceil(R_c) = {}", c.w, c.rc, c.ceil_rc);
    for (g, members) in analysis.groups.iter().enumerate() {
        let list: Vec<String> = members
            .iter()
            .map(|m| {
                let i = analysis.labels.iter().position(|l| l == m).unwrap_or(0);
                format!("{m} ({})", analysis.votes[i])
            })
            .collect();
        println!("G{}: {}", g + 1, list.join(", "));
    }
    if analysis.total != analysis.expected_total {
        eprintln!(
            "warning: the votes total {}, a complete design of {} judges totals {}",
            analysis.total, judges, analysis.expected_total
        );
    }
    Ok(())
}
