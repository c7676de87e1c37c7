//! `blurlab stats ceiling`: what a perfect forecast of vote tables reaches against their own
//! sampling noise (`analysis::ceiling`), with the forecasts actually made beside it, as
//! Markdown, JSON and a figure.

use std::path::{Path, PathBuf};

use analysis::ceiling::{Estimate, GoalChance, TableCeiling};
use analysis::votes::VoteTable;

use crate::cmd::BadInput;

/// Arguments of `stats ceiling`.
#[derive(clap::Args)]
pub(super) struct CeilingArgs {
    /// Vote tables (`blurlab-votes/1`), e.g. analysis/reference/*.csv.
    #[arg(required = true)]
    tables: Vec<PathBuf>,
    /// Judgements of each pair, for tables without a `judges` header.
    #[arg(long)]
    judges: Option<u32>,
    /// Replicate tables drawn per table.
    #[arg(long, default_value_t = 10_000)]
    replications: usize,
    /// Seed of the replicates (each table's generator: mix(seed, its totals)).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The goal's mean Spearman over the tables.
    #[arg(long, default_value_t = 0.8)]
    goal_mean: f64,
    /// The goal's lowest Spearman on any table.
    #[arg(long, default_value_t = 0.5)]
    floor: f64,
    /// Forecasts (`predict.json` of `blurlab predict`) to set beside the ceiling. One made
    /// with `--votes` must have been compared with one of the tables; one made without (before
    /// any votes existed) is taken with the only table given as the hypothesis of what people
    /// prefer, its stimuli matched by their factor levels.
    #[arg(long)]
    forecast: Vec<PathBuf>,
    /// Judgements of each pair in the replicate tables, for a test being planned (default:
    /// each table's own): the same truth, as many judges as the planned test will have.
    #[arg(long)]
    judges_planned: Option<u32>,
    /// Folder for ceiling.md, ceiling.json and ceiling.png/.svg (default: the Markdown on
    /// standard output).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print JSON instead of Markdown.
    #[arg(long)]
    json: bool,
}

/// Picks one estimate of a table's ceiling.
type Pick = fn(&TableCeiling) -> &Estimate;

/// The two estimates of a ceiling, by name.
const ESTIMATES: [(&str, Pick); 2] =
    [("perfect forecast, fitted qualities", |c| &c.fitted), ("perfect forecast, shrunk qualities", |c| &c.shrunk)];

/// A forecast set beside a table's ceiling.
#[derive(serde::Serialize)]
struct ForecastPoint {
    /// Its `predict.json`.
    file: String,
    /// The observer, as a series name (observer, reference, eye movement, judging).
    observer: String,
    /// Index of the table it was compared with.
    table: usize,
    /// Its Spearman correlation with the table (none where its forecast ties every stimulus,
    /// or where it was made before any votes and only takes the table as a hypothesis).
    spearman: Option<f64>,
    /// Whether it was made before any votes (the table is a hypothesis, not its comparison).
    hypothetical: bool,
    /// The share of replicates on which the perfect forecast does no better, from the
    /// fitted and from the shrunk qualities.
    perfect_no_better: (Option<f64>, Option<f64>),
    /// Its Spearman with the replicate tables, the test run again (or as planned): from the
    /// fitted and from the shrunk qualities, each the distribution and the share reaching the
    /// floor (none where it ties every stimulus).
    again: (Option<Again>, Option<Again>),
}

/// A forecast's Spearman over replicate tables.
#[derive(Clone, Copy, serde::Serialize)]
struct Again {
    /// The distribution.
    spearman: analysis::ceiling::Spread,
    /// The share reaching the floor.
    reaches_floor: f64,
}

/// Runs `stats ceiling`.
pub(super) fn run(args: &CeilingArgs) -> anyhow::Result<()> {
    let correlation = |name: &str, v: f64| {
        if (-1.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(BadInput(format!("--{name} {v}: expected a Spearman correlation in [-1, 1]")))
        }
    };
    correlation("goal-mean", args.goal_mean)?;
    correlation("floor", args.floor)?;
    let mut ceilings = Vec::new();
    let progress = indicatif::ProgressBar::new(args.tables.len() as u64).with_style(
        indicatif::ProgressStyle::with_template("ceiling {bar:30} {pos}/{len} {msg}")
            .map_err(|e| anyhow::anyhow!("progress template: {e}"))?,
    );
    for path in &args.tables {
        progress.set_message(path.display().to_string());
        let table = VoteTable::read(path).map_err(|e| BadInput(e.to_string()))?;
        let judges = match (table.judges().map_err(|e| BadInput(e.to_string()))?, args.judges) {
            (Some(j), _) | (None, Some(j)) => j,
            (None, None) => {
                return Err(BadInput(format!("{}: no `judges` header; give --judges", path.display())).into());
            }
        };
        ceilings.push(
            analysis::ceiling::table_ceiling(
                &table,
                judges,
                args.judges_planned.unwrap_or(judges),
                args.replications,
                args.seed,
                args.floor,
            )
            .map_err(|e| BadInput(e.to_string()))?,
        );
        progress.inc(1);
    }
    progress.finish_and_clear();
    let goal = |pick: Pick| {
        analysis::ceiling::goal_chance(&ceilings.iter().map(pick).collect::<Vec<_>>(), args.goal_mean, args.floor)
    };
    let goals = (goal(ESTIMATES[0].1), goal(ESTIMATES[1].1));
    let forecasts = args
        .forecast
        .iter()
        .map(|f| forecast_point(f, &args.tables, &ceilings, args.floor))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let command: String = std::env::args().collect::<Vec<_>>().join(" ");
    let json = serde_json::json!({
        "format": "blurlab-ceiling/1",
        "command": command,
        "replications": args.replications,
        "seed": args.seed,
        "tables": ceilings,
        "goal": { "fitted": goals.0, "shrunk": goals.1 },
        "forecasts": forecasts,
    });
    let json_text = serde_json::to_string_pretty(&json)? + "\n";
    let md = ceiling_markdown(&command, args, &ceilings, goals, &forecasts);
    match &args.out {
        None if args.json => print!("{json_text}"),
        None => print!("{md}"),
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", dir.display()))?;
            for (name, text) in [("ceiling.md", &md), ("ceiling.json", &json_text)] {
                let path = dir.join(name);
                study::fsio::write_atomic(&path, text.as_bytes())
                    .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
            }
            // Each forecast as measured; one made before any votes as its mean over the
            // replicates (fitted qualities) with their range.
            let mut series: Vec<(String, Vec<analysis::plots::ForecastMark>)> = Vec::new();
            for f in &forecasts {
                let (name, mark) = match (f.hypothetical, f.spearman, f.again.0) {
                    (false, Some(s), _) => (f.observer.clone(), (f.table, s, None)),
                    (true, _, Some(a)) => (
                        format!("{}: if run (mean, 5-95 %)", f.observer),
                        (f.table, a.spearman.mean, Some((a.spearman.q05, a.spearman.q95))),
                    ),
                    _ => continue,
                };
                match series.iter_mut().find(|(n, _)| *n == name) {
                    Some((_, points)) => points.push(mark),
                    None => series.push((name, vec![mark])),
                }
            }
            let figure = analysis::plots::CeilingFigure {
                title: format!(
                    "What a perfect forecast reaches against each table's noise ({} replicates)",
                    args.replications
                ),
                tables: args.tables.iter().map(|p| short_name(p)).collect(),
                perfect: ESTIMATES
                    .iter()
                    .map(|(name, pick)| {
                        let spreads = ceilings
                            .iter()
                            .map(|c| {
                                let s = pick(c).spearman;
                                (s.q05, s.median, s.mean, s.q95)
                            })
                            .collect();
                        (format!("{name}: mean, median, 5-95 %"), spreads)
                    })
                    .collect(),
                forecasts: series,
                lines: vec![
                    (format!("goal {}", args.goal_mean), args.goal_mean),
                    (format!("floor {}", args.floor), args.floor),
                ],
            };
            analysis::plots::save_figure(&figure, dir, "ceiling")?;
            println!("{}", dir.join("ceiling.md").display());
        }
    }
    Ok(())
}

/// A table's name in a figure: its file stem without the `thesis-` prefix.
fn short_name(path: &Path) -> String {
    let stem = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
    stem.strip_prefix("thesis-").unwrap_or(&stem).to_owned()
}

/// Whether two paths name the same file (by their canonical forms, else as written).
fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// A forecast's `predict.json`, matched with the table it was compared with.
fn forecast_point(
    file: &Path,
    tables: &[PathBuf],
    ceilings: &[TableCeiling],
    floor: f64,
) -> anyhow::Result<ForecastPoint> {
    let bad = |what: String| BadInput(format!("{}: {what}", file.display()));
    let text = std::fs::read(file).map_err(|e| bad(format!("cannot read: {e}")))?;
    let json: serde_json::Value = serde_json::from_slice(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    if json["format"] != "blurlab-predict/1" {
        return Err(bad("not a forecast (expected format `blurlab-predict/1`)".into()).into());
    }
    let (table, spearman, hypothetical) = match json["published_table"].as_str() {
        Some(published) => {
            let table = tables
                .iter()
                .position(|t| same_file(t, Path::new(published)))
                .ok_or_else(|| bad(format!("compared with `{published}`, which is not one of the tables given")))?;
            let agreement = json["agreement"].as_object().ok_or_else(|| bad("no `agreement`".into()))?;
            // `null`: the forecast ties every stimulus, so it has no order to correlate.
            let spearman = match agreement.get("spearman") {
                Some(serde_json::Value::Null) => None,
                Some(v) => Some(v.as_f64().ok_or_else(|| bad("`agreement.spearman` is not a number".into()))?),
                None => return Err(bad("no `agreement.spearman`".into()).into()),
            };
            (table, spearman, false)
        }
        None if tables.len() == 1 => (0, None, true),
        None => {
            return Err(bad(format!(
                "made without --votes, so it names no table; with {} tables given it is not clear which one is the hypothesis (give one)",
                tables.len()
            ))
            .into());
        }
    };
    // Its stimuli must be the table's (by factor levels); the votes it was compared with
    // must be the table's as read now.
    let c = &ceilings[table];
    let rows = json["stimuli"].as_array().ok_or_else(|| bad("no `stimuli`".into()))?;
    if rows.len() != c.labels.len() {
        return Err(bad(format!("{} stimuli, but {} has {}", rows.len(), c.table, c.labels.len())).into());
    }
    let mut forecast = vec![f64::NAN; c.labels.len()];
    for row in rows {
        let label = row["label"].as_str().unwrap_or_default();
        let at = crate::cmd::predict::label_index(label, &c.labels)
            .ok_or_else(|| bad(format!("stimulus `{label}` is not one of {}'s", c.table)))?;
        if !hypothetical && row["published"].as_f64() != Some(c.votes[at]) {
            return Err(bad(format!("its published votes for `{label}` are not {}'s", c.table)).into());
        }
        forecast[at] = row["votes"].as_f64().ok_or_else(|| bad(format!("`{label}`: no expected `votes`")))?;
    }
    if forecast.iter().any(|v| v.is_nan()) {
        return Err(bad(format!("two of its stimuli are the same one of {}'s", c.table)).into());
    }
    let again = |e: &Estimate| {
        analysis::ceiling::forecast_again(e, &forecast, floor)
            .map(|(spearman, reaches_floor)| Again { spearman, reaches_floor })
    };
    let observer = match json["observer"].as_str() {
        Some("flip") => "FLIP".to_owned(),
        Some(o) => {
            let mut name = format!("{o} `{}`", json["settings"]["reference"].as_str().unwrap_or("?"));
            if let Some(e) = json["eye_movement"].as_str().filter(|e| *e != "fixation") {
                name.push_str(&format!(", {e}"));
            }
            if let Some(j) = json["judging"].as_str() {
                name.push_str(&format!(", judged as {j}s"));
            }
            name
        }
        None => return Err(bad("no `observer`".into()).into()),
    };
    let no_better = |e: &Estimate| {
        spearman
            .map(|s| e.spearman_samples.iter().filter(|&&r| r <= s).count() as f64 / e.spearman_samples.len() as f64)
    };
    Ok(ForecastPoint {
        file: file.display().to_string(),
        observer,
        table,
        spearman,
        hypothetical,
        perfect_no_better: (no_better(&c.fitted), no_better(&c.shrunk)),
        again: (again(&c.fitted), again(&c.shrunk)),
    })
}

fn ceiling_markdown(
    command: &str,
    args: &CeilingArgs,
    ceilings: &[TableCeiling],
    goals: (Option<GoalChance>, Option<GoalChance>),
    forecasts: &[ForecastPoint],
) -> String {
    let mut md = format!(
        "# What a perfect forecast can reach\n\nCommand: `{command}`\n\n\
         Each table's totals are fitted by Thurstone case V qualities (JOD; `P(i over j) = Phi(z75 (q_i - q_j))`, \
         the forecasts' own choice model) whose expected votes equal them. {} replicate tables are drawn from \
         those qualities (each pair's judgements binomial; seed {}, each table's generator `mix(seed, totals)`), \
         and the perfect forecast, which ranks the stimuli as the table does, is correlated with each. The \
         fitted qualities carry the table's noise as well as its signal, so their spread is larger than the \
         truth's and this estimate is optimistic. A second estimate draws {} more from the qualities shrunk \
         towards their mean by the noise the replicates' own fits show (the factor `shrink`: the truth's spread \
         estimated as the fit's less that noise); the truth's ceiling is expected between the two.{}\n\n\
         | table | stimuli | judges | fitted qualities (JOD) | fitted: Spearman mean (5-95 %) | reaches {} | shrink | shrunk: Spearman mean (5-95 %) | reaches {} |\n\
         | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: |\n",
        args.replications,
        args.seed,
        args.replications,
        args.judges_planned.map_or(String::new(), |m| format!(
            " The replicate tables have {m} judgements of each pair (`--judges-planned`): a test as planned, \
             with the truth fitted from each table's own judges."
        )),
        args.floor,
        args.floor
    );
    let spread = |e: &Estimate| format!("{:.3} ({:.3} to {:.3})", e.spearman.mean, e.spearman.q05, e.spearman.q95);
    for c in ceilings {
        let mut order: Vec<usize> = (0..c.labels.len()).collect();
        order.sort_by(|&a, &b| c.fitted.truth[b].total_cmp(&c.fitted.truth[a]));
        let qualities: Vec<String> =
            order.iter().map(|&i| format!("{} {:+.2}", c.labels[i], c.fitted.truth[i])).collect();
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.1} % | {:.2} | {} | {:.1} % |\n",
            c.table,
            c.labels.len(),
            c.judges,
            qualities.join(", "),
            spread(&c.fitted),
            100.0 * c.fitted.reaches_floor,
            c.shrink,
            spread(&c.shrunk),
            100.0 * c.shrunk.reaches_floor,
        ));
    }
    for c in ceilings {
        let mut notes = Vec::new();
        if !c.certain_splits.is_empty() {
            notes.push(format!(
                "the best {:?} stimuli won every judgement against the rest (no finite qualities: the fit holds them within {} JOD)",
                c.certain_splits,
                analysis::ceiling::QUALITY_CAP
            ));
        }
        let constant = c.fitted.constant_replicates + c.shrunk.constant_replicates;
        if constant > 0 {
            notes.push(format!("{constant} replicates tied every stimulus (counted as Spearman 0)"));
        }
        if c.unfittable_replicates > 0 {
            notes.push(format!(
                "{} replicates had no finite fit and were left out of the noise measure",
                c.unfittable_replicates
            ));
        }
        if !notes.is_empty() {
            md.push_str(&format!("\n{}: {}.\n", c.table, notes.join("; ")));
        }
    }
    // Over one table the goal is that table's column above.
    if let (Some(f), Some(s), true) = (goals.0, goals.1, ceilings.len() > 1) {
        md.push_str(&format!(
            "\n## The goal over the {} tables\n\nA mean Spearman of at least {} and none below {}, reached by a perfect \
             forecast in a replicate study (every table run again):\n\n\
             | estimate | mean over the tables (5-95 %) | reaches the mean | the floor on every table | **both** |\n\
             | --- | ---: | ---: | ---: | ---: |\n",
            ceilings.len(),
            f.mean_goal,
            f.floor
        ));
        for (name, g) in [("fitted qualities", f), ("shrunk qualities", s)] {
            md.push_str(&format!(
                "| {name} | {:.3} ({:.3} to {:.3}) | {:.1} % | {:.1} % | **{:.1} %** |\n",
                g.mean_spearman.mean,
                g.mean_spearman.q05,
                g.mean_spearman.q95,
                100.0 * g.reaches_mean,
                100.0 * g.reaches_floor_everywhere,
                100.0 * g.meets_goal
            ));
        }
    }
    if !forecasts.is_empty() {
        md.push_str(
            "\n## Forecasts beside the ceiling\n\n`perfect no better`: the share of replicate tables on which the \
             perfect forecast does no better than this forecast did on the table (from the fitted and the shrunk \
             qualities). `run again`: this forecast's own Spearman with the replicate tables, the test run again \
             with the replicates' judges: mean (5-95 %) and the share reaching the floor.\n\n\
             | forecast | observer | table | Spearman | perfect no better (fitted) | (shrunk) | run again (fitted) | reaches floor | run again (shrunk) | reaches floor |\n\
             | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        );
        let share = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.1} %", 100.0 * v));
        let again = |a: &Option<Again>| match a {
            Some(a) => (
                format!("{:.3} ({:.3} to {:.3})", a.spearman.mean, a.spearman.q05, a.spearman.q95),
                share(Some(a.reaches_floor)),
            ),
            None => ("every stimulus tied".to_owned(), "-".to_owned()),
        };
        for f in forecasts {
            let (fitted, fitted_floor) = again(&f.again.0);
            let (shrunk, shrunk_floor) = again(&f.again.1);
            let spearman = match (f.spearman, f.hypothetical) {
                (_, true) => "- (made before any votes)".to_owned(),
                (Some(s), false) => format!("{s:.3}"),
                (None, false) => "undefined: every stimulus tied".to_owned(),
            };
            md.push_str(&format!(
                "| `{}` | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                f.file,
                f.observer,
                short_name(Path::new(&ceilings[f.table].table)),
                spearman,
                share(f.perfect_no_better.0),
                share(f.perfect_no_better.1),
                fitted,
                fitted_floor,
                shrunk,
                shrunk_floor
            ));
        }
        if ceilings.len() > 1 {
            md.push_str(&series_means(ceilings, forecasts));
        }
    }
    if args.out.is_some() {
        md.push_str("\n![the perfect forecast's Spearman per table](ceiling.png)\n");
    }
    md
}

/// For each observer with a forecast of every table: its mean Spearman over the tables (a
/// forecast that ties every stimulus counted as 0), and the share of replicate studies in
/// which the perfect forecast's mean is no higher.
fn series_means(ceilings: &[TableCeiling], forecasts: &[ForecastPoint]) -> String {
    let mut observers: Vec<&str> = Vec::new();
    for f in forecasts {
        if !observers.contains(&f.observer.as_str()) {
            observers.push(&f.observer);
        }
    }
    let mut out = String::new();
    for observer in observers {
        let mine: Vec<&ForecastPoint> = forecasts.iter().filter(|f| f.observer == observer).collect();
        let covers = (0..ceilings.len()).all(|t| mine.iter().filter(|f| f.table == t).count() == 1);
        if !covers {
            continue;
        }
        let mean = mine.iter().map(|f| f.spearman.unwrap_or(0.0)).sum::<f64>() / ceilings.len() as f64;
        let no_higher = |pick: Pick| {
            let n = ceilings.iter().map(|c| pick(c).spearman_samples.len()).min().unwrap_or(0);
            let count = (0..n)
                .filter(|&k| {
                    ceilings.iter().map(|c| pick(c).spearman_samples[k]).sum::<f64>() / ceilings.len() as f64 <= mean
                })
                .count();
            100.0 * count as f64 / n.max(1) as f64
        };
        let tied = mine.iter().filter(|f| f.spearman.is_none()).count();
        out.push_str(&format!(
            "\n{observer}: mean Spearman {mean:.3} over the {} tables{}; the perfect forecast's mean is no higher in {:.1} % \
             (fitted) and {:.1} % (shrunk) of replicate studies.\n",
            ceilings.len(),
            if tied > 0 { format!(" ({tied} with every stimulus tied, counted as 0)") } else { String::new() },
            no_higher(ESTIMATES[0].1),
            no_higher(ESTIMATES[1].1)
        ));
    }
    out
}
