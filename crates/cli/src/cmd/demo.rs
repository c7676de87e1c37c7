//! `blurlab demo`: the main job end to end, on a fresh machine without a GPU. Renders the
//! quick stimulus set for the interaction experiment (or reuses the sequences that verify),
//! runs simulated participants (Thurstone observers, recorded seeds) through
//! mono-3-interactions and stereo-3-interactions, analyses them, ends with a small cost
//! report of the quick set (`blurlab cost`, the groups marked) and prints where both are. With `--gui` it opens the runner's window on the same set instead of simulating.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use analysis::experiment::{AnalysisOptions, JudgeUnit};
use analysis::report::{build_report, write_report};
use analysis::scaling::ScaleOptions;
use anyhow::Context;
use runner::simulate::{ObserverModel, Quality, SimulateOptions, run_session_with};
use sets::set::{ProgressMode, SetRequest, render_set};
use study::StimulusId;
use study::design::Design;
use study::experiment::ExperimentDefinition;

use super::BadInput;

/// The experiments the demo runs.
const EXPERIMENTS: [&str; 2] = ["mono-3-interactions", "stereo-3-interactions"];
/// Marks a results folder as the demo's own, so a rerun may replace it.
const MARKER: &str = ".blurlab-demo";

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// The design file.
    #[arg(long, default_value = "stimuli/navarro2011.toml")]
    design: PathBuf,
    /// Folder of experiment definitions.
    #[arg(long, default_value = "experiments")]
    experiments: PathBuf,
    /// The quick stimulus set's folder (rendered or resumed there).
    #[arg(long, default_value = "stimuli/out/quick")]
    set: PathBuf,
    /// Output folder: `results/` (simulated logs) and `report/`.
    #[arg(long, default_value = "reports/demo")]
    out: PathBuf,
    /// Simulated participants per experiment.
    #[arg(long, default_value_t = 12)]
    participants: u32,
    /// Seed of the simulated participants (participant k uses seed + k) and the bootstrap.
    #[arg(long, default_value_t = 2026)]
    seed: u64,
    /// Open the runner's window on the set instead of simulating.
    #[arg(long)]
    gui: bool,
    /// Experiment shown by `--gui`.
    #[arg(long, default_value = "mono-3-interactions")]
    gui_experiment: String,
}

fn runner_error(e: runner::RunnerError) -> anyhow::Error {
    if e.is_bad_input() { BadInput(e.to_string()).into() } else { anyhow::Error::new(e) }
}

fn definition(dir: &Path, name: &str) -> anyhow::Result<ExperimentDefinition> {
    ExperimentDefinition::read(&dir.join(format!("{name}.toml"))).map_err(|e| BadInput(e.to_string()).into())
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let definitions: Vec<ExperimentDefinition> =
        EXPERIMENTS.iter().map(|n| definition(&args.experiments, n)).collect::<anyhow::Result<_>>()?;
    let design = Design::load(&args.design).map_err(|e| BadInput(e.to_string()))?;
    let preset = design.preset("quick").map_err(|e| BadInput(e.to_string()))?;
    let mut ids: BTreeSet<StimulusId> = BTreeSet::new();
    for d in &definitions {
        ids.extend(d.all_stimuli());
    }
    let gui_definition = if args.gui { Some(definition(&args.experiments, &args.gui_experiment)?) } else { None };
    if let Some(d) = &gui_definition {
        ids.extend(d.all_stimuli());
    }
    eprintln!(
        "demo: rendering {} sequences of the quick set into {} (reusing those that verify)",
        ids.len(),
        args.set.display()
    );
    let rendered = render_set(&SetRequest {
        design: &design,
        preset,
        ids: ids.into_iter().collect(),
        out: args.set.clone(),
        resume: true,
        exr: false,
        progress: ProgressMode::Lines,
        device: render::DeviceChoice::Auto,
        sampling: study::manifest::Sampling::Independent,
    })
    .map_err(|e| if e.is_bad_input() { anyhow::Error::new(BadInput(e.to_string())) } else { anyhow::Error::new(e) })?;
    eprintln!(
        "demo: {} rendered, {} reused, {:.1} s",
        rendered.rendered.len(),
        rendered.skipped.len(),
        rendered.wall_seconds
    );

    if let Some(d) = gui_definition {
        let set = runner::stimuli::StimulusSet::open_for(&args.set, &d).map_err(runner_error)?;
        let config = runner::app::AppConfig::new(d, set, PathBuf::from("results"));
        runner::app::run_window(config, false).map_err(runner_error)?;
        return Ok(());
    }

    let results = args.out.join("results");
    let model = ObserverModel::Thurstone { sigma: 1.0, quality: Quality::Rule };
    simulate_all(args, &definitions, &results, &model, "simulated participants")?;
    // The image-computable observer on the same trials: groups predicted from the frames.
    let predicted_results = args.out.join("results-flip");
    let flip: ObserverModel = "flip".parse().map_err(runner_error)?;
    simulate_all(args, &definitions, &predicted_results, &flip, "FLIP observers")?;

    let logs: Vec<PathBuf> = EXPERIMENTS.iter().map(|n| results.join(n)).collect();
    let options = AnalysisOptions {
        alpha: 0.01,
        judge_unit: JudgeUnit::Replicate,
        scale: ScaleOptions { seed: args.seed, ..ScaleOptions::default() },
    };
    let mut report = build_report(&logs, Some(&args.set), Some(&args.experiments), options)?;
    let folder = args.out.join("report");
    let md = write_report(&mut report, &folder)?;
    let predicted_logs: Vec<PathBuf> = EXPERIMENTS.iter().map(|n| predicted_results.join(n)).collect();
    let mut predicted = build_report(&predicted_logs, Some(&args.set), Some(&args.experiments), options)?;
    write_report(&mut predicted, &args.out.join("report-flip"))?;
    let side = analysis::prediction::side_by_side(
        &report,
        &predicted,
        "simulated FLIP observers (`--simulate flip`, default decision noise), the same trials and seeds",
    );
    let side = format!("{side}{}", cvvdp_forecasts(args, &definitions, &report)?);
    let side_path = folder.join("predicted-vs-measured.md");
    study::fsio::write_atomic(&side_path, side.as_bytes())
        .with_context(|| format!("writing {}", side_path.display()))?;
    for e in &report.experiments {
        if let Some(p) = &e.paired {
            let groups: Vec<String> = p
                .groups
                .iter()
                .map(|g| {
                    format!(
                        "G{} {{{}}}",
                        g.number,
                        g.members.iter().map(|m| m.label.as_str()).collect::<Vec<_>>().join(", ")
                    )
                })
                .collect();
            println!(
                "{}: m = {}, ceil(R_c) = {}, {}",
                e.name,
                p.complete_judges,
                p.critical.map_or(0, |c| c.ceil_rc),
                groups.join(" ")
            );
            if let Some(r) = &p.recommendation {
                println!(
                    "  {} ({:.2} s) is equivalent to {} ({:.2} s): saves {:.1} % of the render time",
                    r.cheapest,
                    r.cheapest_wall_seconds,
                    r.reference,
                    r.reference_wall_seconds,
                    r.saving * 100.0
                );
            }
        }
    }
    println!(
        "report: {} (groups forecast by ColorVideoVDP and FLIP beside them: {})",
        md.display(),
        side_path.display()
    );

    // What the equivalent groups cost: the tracer and the accumulation buffer swept on the
    // interaction experiments' cell (checker, medium speed, full shutter) at the quick
    // preset, the report's groups marked on the curves.
    let cost_args = super::cost::demo_args(&args.design, "M2-S2-T5", Some(folder.clone()), args.out.join("cost"));
    eprintln!("demo: cost sweep of {} (quick preset) into {}", cost_args.id, cost_args.out.display());
    let cost_md = super::cost::cost_report(&cost_args)?;
    println!("cost report: {}", cost_md.display());
    Ok(())
}

/// The ColorVideoVDP forecast of each experiment (`blurlab predict`, its `shutter` reference, as
/// many judges as the simulated participants' analysis counts) into `OUT/predict/NAME/`, and a
/// Markdown section of its groups beside the measured ones.
fn cvvdp_forecasts(
    args: &Args,
    definitions: &[ExperimentDefinition],
    measured: &analysis::report::Report,
) -> anyhow::Result<String> {
    let mut md = String::from(
        "\n# Forecast by ColorVideoVDP\n\nExpected votes of `blurlab predict` (the `shutter` reference, no sampling noise), grouped \
         with as many judges as the measured analysis counts. On the quick preset (160x90, 8 frames, 1-16 samples per \
         pixel) this is not the study's forecast: see BENCHMARKS.md for the full preset's.\n",
    );
    for d in definitions {
        let Some(e) = measured.experiments.iter().find(|e| e.name == d.name) else { continue };
        let Some(p) = &e.paired else { continue };
        let out = args.out.join("predict").join(&d.name);
        let predict_args = super::predict::Args {
            experiment: d.path.clone(),
            stimuli: args.set.clone(),
            observer: super::predict::ObserverArg::Cvvdp,
            reference: super::predict::observer::ReferenceKind::Shutter,
            reference_spp: None,
            sub_frames: super::predict::observer::DEFAULT_SUB_FRAMES,
            eye_movement: super::predict::EyeMovementArg::Fixation,
            judging: super::predict::JudgingArg::Reference,
            clip: None,
            votes: None,
            judges: Some(p.complete_judges.max(1)),
            alpha: Some(0.01),
            device: super::stimuli::DeviceArg::Auto,
            out: out.clone(),
        };
        let f = super::predict::forecast(d, &predict_args)?;
        super::predict::write(
            &f,
            &out,
            &format!(
                "blurlab predict {} --stimuli {} --judges {} --out {}",
                d.path.display(),
                args.set.display(),
                f.judges,
                out.display()
            ),
        )?;
        let measured: Vec<Vec<String>> =
            p.groups.iter().map(|g| g.members.iter().map(|m| m.label.clone()).collect()).collect();
        md.push_str(&format!(
            "\n## {}\n\n{} Forecast report: `{}`.\n\n| group | measured | forecast |\n| --- | --- | --- |\n",
            d.name,
            if analysis::prediction::same_groups(&measured, &f.groups) {
                "The groups agree."
            } else {
                "The groups differ."
            },
            out.join("predict.md").display()
        ));
        for k in 0..measured.len().max(f.groups.len()) {
            let cell = |g: &[Vec<String>]| g.get(k).map_or("-".to_owned(), |m| format!("{{{}}}", m.join(", ")));
            md.push_str(&format!("| G{} | {} | {} |\n", k + 1, cell(&measured), cell(&f.groups)));
        }
        eprintln!("demo: ColorVideoVDP forecast of {} in {}", d.name, out.display());
    }
    Ok(md)
}

/// Runs every experiment's simulated participants with `model` into a fresh `results`
/// folder (one the demo made before is replaced; any other is refused).
fn simulate_all(
    args: &Args,
    definitions: &[ExperimentDefinition],
    results: &Path,
    model: &ObserverModel,
    who: &str,
) -> anyhow::Result<()> {
    if results.exists() {
        if !results.join(MARKER).exists() {
            return Err(BadInput(format!(
                "{} exists and was not made by the demo; choose another --out",
                results.display()
            ))
            .into());
        }
        std::fs::remove_dir_all(results).with_context(|| format!("removing the previous {}", results.display()))?;
    }
    std::fs::create_dir_all(results).with_context(|| format!("creating {}", results.display()))?;
    study::fsio::write_atomic(&results.join(MARKER), b"simulated results of `blurlab demo`; replaced on every run\n")
        .with_context(|| format!("writing into {}", results.display()))?;
    for d in definitions {
        for k in 1..=args.participants {
            let experienced = if k % 2 == 0 { "yes" } else { "no" };
            let options = SimulateOptions {
                attributes: vec![("cg_experience".to_owned(), experienced.to_owned())],
                ..SimulateOptions::default()
            };
            run_session_with(d, &args.set, results, &format!("SIM{k:02}"), model, args.seed + u64::from(k), &options)
                .map_err(runner_error)?;
        }
        eprintln!("demo: {} {who} ran {}", args.participants, d.name);
    }
    Ok(())
}
