//! `blurlab run EXPERIMENT --stimuli DIR --participant CODE`: runs (or resumes) a
//! participant's session in the runner's window, or headlessly with `--simulate MODEL`.
//! After a window closes, the experimenter's summary (`runner::summary`) is printed: trials
//! answered, replays, late frames and any trial shown off-calibration.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use runner::RunnerError;
use runner::calibration::Viewing;
use runner::simulate::{ObserverModel, SimulateOptions, run_session_with};
use study::experiment::{DisplayMode, ExperimentDefinition};

use super::BadInput;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Experiment definition: a file, or a name looked up as experiments/NAME.toml.
    experiment: PathBuf,
    /// Rendered stimulus set (folder with index.json).
    #[arg(long)]
    stimuli: PathBuf,
    /// Pseudonymous participant code (letters, digits, `-`, `_`); never a name.
    #[arg(long)]
    participant: String,
    /// Results root: logs go to RESULTS/EXPERIMENT/PARTICIPANT/session-N.csv.
    #[arg(long, default_value = "results")]
    results: PathBuf,
    /// Run headlessly with a simulated observer: `thurstone[:sigma=S][,file=PATH]`, `random`, or
    /// `flip[:sigma=S]` (answers from the frames: FLIP distance to the gold standard A5 of the
    /// same material, speed and shutter; matching picks the candidate nearer the reference), or
    /// `cvvdp[:reference=shutter|eye|sharp]` (the ColorVideoVDP observer of `blurlab predict`, its
    /// choice probabilities sampled; the reference by default `shutter`, as in `predict`).
    #[arg(long)]
    simulate: Option<String>,
    /// Seed of a new session's schedule (and of the simulated observer). A resumed session
    /// keeps the seed in its log; giving another one is an error.
    #[arg(long)]
    seed: Option<u64>,
    /// Simulation only: wait this long before each answer (for kill-and-resume tests).
    #[arg(long, default_value_t = 0)]
    trial_delay_ms: u64,
    /// Simulation only: stop after this many trials, leaving the session resumable.
    #[arg(long)]
    max_trials: Option<usize>,
    /// Simulation only: participant attributes `KEY=VALUE` recorded in a new session's header.
    #[arg(long = "attribute")]
    attributes: Vec<String>,
    /// Display mode instead of the definition's: mono, sbs-full, sbs-half, top-bottom,
    /// anaglyph, row-interleaved.
    #[arg(long)]
    display: Option<String>,
    /// Visible screen width in centimetres (calibration).
    #[arg(long, default_value_t = Viewing::default().screen_width_cm)]
    screen_width_cm: f64,
    /// Horizontal screen resolution in pixels (calibration).
    #[arg(long, default_value_t = Viewing::default().screen_width_px)]
    screen_width_px: u32,
    /// Viewing distance in centimetres (calibration).
    #[arg(long, default_value_t = Viewing::default().distance_cm)]
    distance_cm: f64,
    /// Display refresh rate in Hz for frame pacing. Default: measured on the start screen
    /// (the median interval of its redraws); 60 Hz is assumed, with a warning on the display
    /// check, when the window is not locked to a regular refresh.
    #[arg(long)]
    refresh_hz: Option<f64>,
    /// Open the window full screen.
    #[arg(long)]
    fullscreen: bool,
}

/// Finds a definition by path or by name under experiments/.
pub fn resolve_experiment(arg: &Path) -> PathBuf {
    if arg.exists() || arg.extension().is_some() || arg.components().count() > 1 {
        return arg.to_owned();
    }
    Path::new("experiments").join(arg).with_extension("toml")
}

/// Converts a runner error into an anyhow error with the CLI's exit-code conventions.
pub fn runner_error(e: RunnerError) -> anyhow::Error {
    if e.is_bad_input() { anyhow::Error::new(BadInput(e.to_string())) } else { anyhow::Error::new(e) }
}

/// Checks a `--refresh-hz` value: a rate in Hz between 1 and 1000.
pub fn check_refresh_hz(hz: Option<f64>) -> anyhow::Result<()> {
    match hz {
        Some(hz) if !(hz.is_finite() && (1.0..=1000.0).contains(&hz)) => {
            Err(BadInput(format!("--refresh-hz {hz}: expected a refresh rate in Hz between 1 and 1000")).into())
        }
        _ => Ok(()),
    }
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let path = resolve_experiment(&args.experiment);
    let definition = ExperimentDefinition::read(&path).map_err(|e| runner_error(e.into()))?;
    let display: DisplayMode = match &args.display {
        Some(text) => text.parse().map_err(|m: String| BadInput(format!("--display: {m}")))?,
        None => definition.display,
    };
    if definition.view == study::View::Mono && display != DisplayMode::Mono {
        return Err(BadInput(format!("--display {display}: {} is a mono experiment", definition.name)).into());
    }
    runner::session::check_participant(&args.participant).map_err(runner_error)?;
    check_refresh_hz(args.refresh_hz)?;

    if let Some(model_text) = &args.simulate {
        let model: ObserverModel = model_text.parse().map_err(runner_error)?;
        let seed = args
            .seed
            .ok_or_else(|| BadInput("--simulate needs --seed S (simulated sessions are reproducible)".into()))?;
        let model = match &model {
            ObserverModel::Cvvdp { reference, .. } => cvvdp_model(&model, reference, &definition, &args.stimuli, seed)?,
            _ => model,
        };
        let mut attributes = Vec::new();
        for a in &args.attributes {
            let (k, v) = a.split_once('=').ok_or_else(|| BadInput(format!("--attribute `{a}` is not KEY=VALUE")))?;
            attributes.push((k.to_owned(), v.to_owned()));
        }
        let options = SimulateOptions {
            trial_delay: Duration::from_millis(args.trial_delay_ms),
            max_trials: args.max_trials,
            attributes,
        };
        let report =
            run_session_with(&definition, &args.stimuli, &args.results, &args.participant, &model, seed, &options)
                .map_err(runner_error)?;
        for w in &report.warnings {
            eprintln!("warning: {w}");
        }
        println!(
            "{}: session {}, {} answered{}{}",
            report.path.display(),
            report.session,
            trials(report.answered),
            if report.resumed { format!(" (resumed at trial {})", report.started_at) } else { String::new() },
            if report.completed { ", complete" } else { ", incomplete (run again to resume)" }
        );
        return Ok(());
    }

    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        return Err(BadInput("no display (DISPLAY and WAYLAND_DISPLAY are unset): run in a desktop session, or use --simulate MODEL --seed S".into()).into());
    }
    // Refuse at once when another process runs this participant's session (the window takes
    // the lock itself when the session starts). A participant without a folder has no session
    // to hold: nothing is created before the session starts, so a window that fails to open
    // leaves no empty folders behind.
    let participant_dir = runner::session::participant_dir(&args.results, &definition.name, &args.participant);
    if participant_dir.is_dir() {
        drop(runner::session::lock_participant(&participant_dir, &args.participant).map_err(runner_error)?);
    }
    let set = runner::stimuli::StimulusSet::open_for(&args.stimuli, &definition).map_err(runner_error)?;
    let mut config = runner::app::AppConfig::new(definition, set, args.results.clone());
    config.participant = Some(args.participant.clone());
    config.seed = args.seed;
    config.display = display;
    config.viewing = Viewing {
        screen_width_cm: args.screen_width_cm,
        screen_width_px: args.screen_width_px,
        distance_cm: args.distance_cm,
    };
    config.refresh_hz = args.refresh_hz;
    let calibration = config.calibration().map_err(runner_error)?;
    if let Some(w) = &calibration.warning {
        eprintln!("warning: calibration: {w}");
    }
    let app = runner::app::run_window(config, args.fullscreen).map_err(runner_error).context("running the window")?;
    match app.session() {
        Some(s) => {
            println!(
                "{}: {} answered in this window; {}",
                s.path().display(),
                trials(app.written.len()),
                if s.is_finished() { "session complete" } else { "session incomplete (run again to resume)" }
            );
            print!("{}", runner::summary::SessionSummary::new(&app.written, &calibration));
        }
        None => println!("no session was started"),
    }
    Ok(())
}

/// "1 trial", "2 trials".
fn trials(n: usize) -> String {
    format!("{n} trial{}", if n == 1 { "" } else { "s" })
}

/// The ColorVideoVDP observer with what it needs for `definition`'s trials: every stimulus's
/// quality (2AFC) or the JOD distance of each candidate from its shown reference (matching),
/// computed as `blurlab predict` computes them (references rendered and cached in the set).
fn cvvdp_model(
    model: &ObserverModel,
    reference: &str,
    definition: &ExperimentDefinition,
    set_dir: &Path,
    seed: u64,
) -> anyhow::Result<ObserverModel> {
    use super::predict::observer::{ObserverSettings, ReferenceKind, distances};
    // The runner's parser has already refused names outside the enum.
    let kind = <ReferenceKind as clap::ValueEnum>::from_str(reference, false)
        .map_err(|e| BadInput(format!("--simulate cvvdp:reference={reference}: {e}")))?;
    match definition.task {
        study::response::Task::TwoAfc => {
            let (q, _) = super::predict::qualities_for(definition, set_dir, kind, None, render::DeviceChoice::Auto)?;
            Ok(model.with_cvvdp(q.into_iter().collect(), Default::default()))
        }
        study::response::Task::Match => {
            let (set, design, preset) = super::predict::open_set(set_dir, definition, true)?;
            let settings = ObserverSettings::new(
                &design,
                &preset,
                kind,
                None,
                super::predict::observer::DEFAULT_SUB_FRAMES,
                None,
            )?;
            let mut pairs: Vec<(study::StimulusId, study::StimulusId)> = runner::schedule::build(definition, seed)
                .iter()
                .flat_map(|t| t.options().iter().map(|o| (t.shown[0], *o)).collect::<Vec<_>>())
                .collect();
            pairs.sort();
            pairs.dedup();
            let d = distances(&set, &design, &preset, &pairs, &settings)?;
            Ok(model.with_cvvdp(Default::default(), d.into_iter().collect()))
        }
    }
}
