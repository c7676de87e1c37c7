//! `blurlab bench playback`: decode and upload time of one sequence (640x360 mono, and
//! 1280x360 side-by-side stereo in every stereo display mode; synthetic frames) and of a 2AFC
//! trial's two sequences (each against the 1 s target), memory held during a stereo 2AFC trial, and, with
//! `--window` and a display, frame-interval statistics of real playback in the runner's
//! window driven by its autopilot.

use std::path::{Path, PathBuf};

use anyhow::Context;
use runner::bench::{Gpu, READY_TARGET_MS, decode_upload, frame_stats, trial_load};
use runner::stimuli::{StimulusSet, write_synthetic_set};
use study::StimulusId;
use study::experiment::{DisplayMode, ExperimentDefinition};

use crate::cmd::run::{check_refresh_hz, runner_error};

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Print JSON (the only output format; kept for symmetry with the other benchmarks).
    #[arg(long)]
    json: bool,
    /// Frames per sequence.
    #[arg(long, default_value_t = 120)]
    frames: u32,
    /// Decoder threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Also play trials in a real window (needs DISPLAY, e.g. Xvfb) and report frame intervals.
    #[arg(long)]
    window: bool,
    /// Display mode of the trials played in the window: `mono` plays the mono sequences, a
    /// stereo mode (e.g. `anaglyph`, `sbs-full`) the stereo ones.
    #[arg(long, default_value = "mono")]
    window_display: String,
    /// Trials played in the window.
    #[arg(long, default_value_t = 2)]
    trials: usize,
    /// Refresh rate (Hz) the window's pacing assumes, as `blurlab run --refresh-hz`; by default
    /// the rate measured on its start screen (which under Xvfb, without a display refresh, is
    /// how fast the window redraws). The measurement is reported either way.
    #[arg(long)]
    refresh_hz: Option<f64>,
    /// Work folder for the synthetic sets (default: a temporary folder, removed afterwards).
    #[arg(long)]
    work: Option<PathBuf>,
}

fn definition(dir: &Path, view: &str, samples: &str) -> anyhow::Result<ExperimentDefinition> {
    let text = format!(
        "format = \"blurlab-experiment/1\"\nname = \"bench-{view}\"\ntask = \"2afc\"\nquestion = \"Which?\"\nview = \"{view}\"\n\
         [stimuli]\nmaterial = [2]\nspeed = [2]\nshutter = [3]\nsamples = {samples}\n[presentation]\ngap_ms = 500\n"
    );
    let path = dir.join(format!("bench-{view}.toml"));
    std::fs::write(&path, text).with_context(|| path.display().to_string())?;
    Ok(ExperimentDefinition::read(&path)?)
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let _ = args.json;
    check_refresh_hz(args.refresh_hz)?;
    let threads = args.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()));
    let (work, temporary) = match &args.work {
        Some(w) => (w.clone(), false),
        None => (std::env::temp_dir().join(format!("blurlab-bench-playback-{}", std::process::id())), true),
    };
    std::fs::create_dir_all(&work).with_context(|| work.display().to_string())?;
    let result = measure(args, &work, threads);
    if temporary {
        let _ = std::fs::remove_dir_all(&work);
    }
    let report = result?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

fn measure(args: &Args, work: &Path, threads: usize) -> anyhow::Result<serde_json::Value> {
    let mono = definition(work, "mono", "[3, 5]")?;
    let stereo = definition(work, "stereo", "[3, 5]")?;
    let mono_ids: Vec<StimulusId> = mono.all_stimuli().into_iter().collect();
    let stereo_ids: Vec<StimulusId> = stereo.all_stimuli().into_iter().collect();
    let set_dir = work.join("set");
    if !set_dir.join("index.json").exists() {
        let all: Vec<StimulusId> = mono_ids.iter().chain(&stereo_ids).copied().collect();
        write_synthetic_set(&set_dir, &all, 640, 360, args.frames, 30.0).map_err(runner_error)?;
    }
    let mono_set = StimulusSet::open_for(&set_dir, &mono).map_err(runner_error)?;
    let stereo_set = StimulusSet::open_for(&set_dir, &stereo).map_err(runner_error)?;
    let gpu = Gpu::new();
    let (gpu, adapter) = match gpu {
        Ok(g) => {
            let name = g.adapter.clone();
            (Some(g), serde_json::Value::String(name))
        }
        Err(e) => (None, serde_json::json!({ "unavailable": e.to_string() })),
    };
    // Mono sequences shown in mono, then the stereo sequences in every stereo display mode
    // (sbs-full first: its trial is the one whose memory is reported).
    let modes: Vec<(&StimulusSet, &Vec<StimulusId>, DisplayMode)> =
        std::iter::once((&mono_set, &mono_ids, DisplayMode::Mono))
            .chain(
                DisplayMode::ALL.into_iter().filter(|m| *m != DisplayMode::Mono).map(|m| (&stereo_set, &stereo_ids, m)),
            )
            .collect();
    let mut sequences = Vec::new();
    for &(set, ids, mode) in &modes {
        // Once to warm the file cache, then measured.
        let _ = decode_upload(set.sequence(&ids[0]), mode, threads, None).map_err(runner_error)?;
        let r = decode_upload(set.sequence(&ids[0]), mode, threads, gpu.as_ref()).map_err(runner_error)?;
        sequences.push(serde_json::json!({ "mode": mode.name(), "result": r }));
    }
    // A 2AFC trial shows two sequences: both decoded, then both uploaded, as the window does.
    let mut trials = Vec::new();
    for &(set, ids, mode) in &modes {
        let r = trial_load(set.sequence(&ids[0]), set.sequence(&ids[1]), mode, threads, gpu.as_ref())
            .map_err(runner_error)?;
        trials.push(r);
    }
    let memory = trials[1].clone();
    drop(gpu);
    let target = serde_json::json!({
        "ready_under_ms": READY_TARGET_MS,
        "per_sequence_met": sequences.iter().all(|s| s["result"]["target_met"] == true),
        "per_trial_met": trials.iter().all(|t| t.target_met),
        "note": "a 2AFC trial's stimuli are two sequences; per_trial is the target of the issue",
    });

    let window = if !args.window {
        serde_json::json!("not run (pass --window with a DISPLAY)")
    } else if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        serde_json::json!("skipped: no DISPLAY")
    } else {
        let results = work.join("results");
        let _ = std::fs::remove_dir_all(&results);
        let display: DisplayMode =
            args.window_display.parse().map_err(|m: String| anyhow::anyhow!("--window-display: {m}"))?;
        let (definition, set) = if display == DisplayMode::Mono { (&mono, &mono_set) } else { (&stereo, &stereo_set) };
        let mut config = runner::app::AppConfig::new(definition.clone(), set.clone(), results);
        config.display = display;
        config.participant = Some("BENCH".into());
        config.seed = Some(1);
        config.autopilot = Some(args.trials);
        config.refresh_hz = args.refresh_hz;
        config.decode_threads = threads;
        let window_size = config.window_size();
        let app = runner::app::run_window(config, false).map_err(runner_error)?;
        let session = app.session().context("the window closed before the session started")?;
        let stats = frame_stats(session.path(), 30.0).map_err(runner_error)?;
        let d = &app.refresh_intervals_ms;
        let summary = study::stats::Summary::of(d);
        let (mean, sd, max) = (summary.mean, summary.population_sd(), summary.max.max(0.0));
        let refresh = app.refresh();
        serde_json::json!({
            "trials": app.written.len(),
            "display": display.name(),
            "window_size": window_size,
            "refresh_used_hz": refresh.hz,
            "refresh_source": refresh.source,
            "refresh_measured": refresh.measured,
            "frames": stats,
            "redraw_intervals_ms": { "mean": mean, "sd": sd, "max": max, "count": d.len() },
        })
    };
    Ok(serde_json::json!({
        "benchmark": "playback",
        "threads": threads,
        "frames_per_sequence": args.frames,
        "adapter": adapter,
        "decode_upload": sequences,
        "trial_ready": trials,
        "target": target,
        "stereo_2afc_trial_memory": memory,
        "window_playback": window,
    }))
}
