//! UI tests of the participant's window with egui_kittest: a scripted participant enters a
//! code and attributes, watches a briefing example, plays a practice trial, answers 2AFC and
//! matching trials by key and by button, replays, quits with Escape and resumes; the
//! assertions read the session CSV.
//!
//! The window logic runs headless (no GPU). The step that renders a trial's textures through
//! wgpu needs an adapter and follows the gpu crate's rule: with `BLURLAB_REQUIRE_GPU=1` a
//! missing adapter fails the test, otherwise that step is skipped with a
//! `SKIPPED: no GPU adapter ...` line in the test output.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use egui::Key;
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use runner::app::{AppConfig, RunnerApp};
use runner::display::transform;
use runner::stimuli::{StimulusSet, decode_frame, write_synthetic_set};
use study::experiment::{DisplayMode, ExperimentDefinition};
use study::response::SessionLog;
use study::testing::{AttributeToml, BriefingToml, ExampleToml, ExperimentToml, PresentationToml, pair};
use study::{StimulusId, View};

/// Mesa 22.3's lavapipe sometimes crashes this binary while it exits (SIGSEGV or abort in 2
/// of 12 local runs and once in CI, with `LP_NUM_THREADS=0`), after every test has passed and
/// libtest has printed its result: its teardown races with threads wgpu and the runner's
/// loader leave behind. So, once a test has used wgpu, the process ends at its first exit
/// handler with `_exit` and libtest's status (0, or 101 once any test has panicked),
/// skipping the libraries' teardown; nothing of the tests' is left unwritten by then.
/// (The only unsafe code of the workspace: two libc calls, in a test binary.)
#[allow(unsafe_code)]
mod exit_guard {
    use std::sync::atomic::{AtomicBool, Ordering};

    static PANICKED: AtomicBool = AtomicBool::new(false);

    unsafe extern "C" {
        fn atexit(handler: extern "C" fn()) -> std::ffi::c_int;
        fn _exit(status: std::ffi::c_int) -> !;
    }

    extern "C" fn end_now() {
        let status = if PANICKED.load(Ordering::SeqCst) { 101 } else { 0 };
        // SAFETY: `_exit` ends the process at once; nothing runs after it.
        unsafe { _exit(status) }
    }

    /// Registers the handler (again: exit handlers run last registered first, and Mesa
    /// registers its own when wgpu first uses it, so this is called after each use).
    pub fn arm() {
        static HOOK: std::sync::Once = std::sync::Once::new();
        HOOK.call_once(|| {
            let previous = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                PANICKED.store(true, Ordering::SeqCst);
                previous(info);
            }));
        });
        // SAFETY: registers a handler that takes no state but the atomic flag.
        unsafe {
            atexit(end_now);
        }
    }
}

fn definition(dir: &Path, task: &str) -> ExperimentDefinition {
    definition_of(dir, task, "mono")
}

/// A definition showing `view` (`mono` or `stereo`) sequences.
fn definition_of(dir: &Path, task: &str, view: &str) -> ExperimentDefinition {
    let suffix = if view == "stereo" { "-stereo" } else { "" };
    let stereo = |id: &str| format!("{id}{suffix}");
    let text = ExperimentToml {
        name: format!("ui-{task}"),
        task: task.into(),
        question: "Which one?".into(),
        view: view.into(),
        samples: vec![5],
        repeats: None,
        briefing: Some(BriefingToml {
            text: "Watch for noise.".into(),
            examples: vec![ExampleToml {
                label: "Noise".into(),
                description: Some("grain".into()),
                stimulus: stereo("M2-S2-T3-A1"),
            }],
        }),
        practice: vec![pair(&stereo("M2-S2-T1-A1"), &stereo("M2-S2-T5-A5"))],
        presentation: Some(PresentationToml { gap_ms: Some(100), replay: Some(true), loops: None }),
        keys: None,
        attributes: vec![AttributeToml {
            question: "Experience in computer graphics?".into(),
            ..ExperimentToml::base().attributes.remove(0)
        }],
        ..ExperimentToml::base()
    }
    .to_string();
    let path = dir.join(format!("ui-{task}.toml"));
    std::fs::write(&path, &text).unwrap();
    ExperimentDefinition::read(&path).unwrap()
}

fn config(dir: &Path, task: &str) -> AppConfig {
    config_sized(dir, task, 16, 8)
}

fn config_sized(dir: &Path, task: &str, width: u32, height: u32) -> AppConfig {
    config_of(definition(dir, task), dir, width, height)
}

fn config_of(d: ExperimentDefinition, dir: &Path, width: u32, height: u32) -> AppConfig {
    let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
    let set_dir = dir.join("set");
    write_synthetic_set(&set_dir, &ids, width, height, 3, 30.0).unwrap();
    let set = StimulusSet::open_for(&set_dir, &d).unwrap();
    let mut c = AppConfig::new(d, set, dir.join("results"));
    c.seed = Some(5);
    c.decode_threads = 1;
    c
}

fn harness(config: AppConfig) -> Harness<'static, RunnerApp> {
    harness_sized(config, [1400.0, 1100.0])
}

/// A window of `size` points whose start screen has measured the refresh rate (the harness
/// steps at 60 Hz).
fn harness_sized(config: AppConfig, size: [f32; 2]) -> Harness<'static, RunnerApp> {
    let mut h =
        Harness::builder().with_size(size).with_step_dt(1.0 / 60.0).build_eframe(move |_cc| RunnerApp::new(config));
    assert!(!h.state().ready_to_start());
    h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES);
    assert!(h.state().ready_to_start());
    h
}

/// Sends the window a close request (its close button) and steps; returns whether the app
/// cancelled the close.
fn close_request(h: &mut Harness<'static, RunnerApp>) -> bool {
    let root = egui::ViewportId::ROOT;
    h.input_mut().viewports.get_mut(&root).unwrap().events.push(egui::ViewportEvent::Close);
    h.step();
    h.output().viewport_output[&root].commands.iter().any(|c| matches!(c, egui::ViewportCommand::CancelClose))
}

/// Steps until the window shows `screen` (loading runs on real threads, so steps also wait).
fn until(h: &mut Harness<'static, RunnerApp>, screen: &str) {
    let start = Instant::now();
    while h.state().screen() != screen {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "stuck on `{}` waiting for `{screen}`: {:?}",
            h.state().screen(),
            h.state().message()
        );
        h.step();
        if h.state().screen() == "loading" {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    // The screen changed during the last step: one more draws it for the accessibility tree.
    h.step();
    exit_guard::arm();
}

fn start(h: &mut Harness<'static, RunnerApp>, code: &str) {
    let field = h.get_by_role(Role::TextInput);
    field.focus();
    h.step();
    h.get_by_role(Role::TextInput).type_text(code);
    h.step();
    h.get_by_label("Start").click();
    h.step();
    // The attribute is required.
    assert!(h.state().message().unwrap().contains("Please answer: Experience in computer graphics?"));
    assert_eq!(h.state().screen(), "start");
    // The notice shifts the layout: let it settle before clicking by position.
    h.run_steps(2);
    h.get_by_label("no").click();
    h.run_steps(2);
    h.get_by_label("Start").click();
    h.run_steps(2);
}

fn rows(path: &Path) -> Vec<study::response::TrialRow> {
    SessionLog::read(path).unwrap().rows.into_iter().map(|(_, r)| r).collect()
}

#[test]
fn scripted_participant_2afc_practice_replay_quit_and_resume() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), "2afc");
    let mut h = harness(cfg.clone());
    assert_eq!(h.state().screen(), "start");
    // The display check shows the refresh rate measured on the start screen.
    assert!(h.query_by_label_contains("Display refresh: 60.00 Hz measured (median of 60 frame intervals").is_some());
    // A name is refused.
    h.get_by_role(Role::TextInput).focus();
    h.step();
    h.get_by_role(Role::TextInput).type_text("Jane Doe");
    h.step();
    h.get_by_label("Start").click();
    h.step();
    assert!(h.state().message().unwrap().contains("pseudonymous"), "{:?}", h.state().message());
    drop(h);

    let mut h = harness(cfg.clone());
    start(&mut h, "P07");
    assert_eq!(h.state().screen(), "briefing", "{:?}", h.state().message());
    let path: PathBuf = h.state().session().unwrap().path().to_owned();
    assert!(path.ends_with("results/ui-2afc/P07/session-1.csv"));

    // Briefing example.
    h.get_by_label("Show example: Noise").click();
    until(&mut h, "example");
    h.step();
    h.get_by_label("Back to the briefing").click();
    until(&mut h, "briefing");
    h.get_by_label("Begin practice").click();

    // Practice trial: presentation, then answer by key.
    until(&mut h, "presenting");
    assert!(h.query_by_label("Practice trial (not counted)").is_some());
    // Rendering the textures of a trial through wgpu (GPU or lavapipe). The harness's renderer
    // panics without an adapter, so the gpu crate's rule decides first whether there is one.
    let step = "scripted_participant_2afc_practice_replay_quit_and_resume (rendering the trial through wgpu)";
    if gpu::test_context(step).is_some() {
        exit_guard::arm();
        let rendered = h.render();
        exit_guard::arm();
        match rendered {
            Ok(image) => {
                // The synthetic frame's grey field (60, 60, 60) is on screen, scaled up.
                let grey = image.pixels().filter(|p| p.0[..3].iter().all(|&c| c.abs_diff(60) <= 1)).count();
                assert!(grey > 10_000, "{grey} stimulus pixels rendered");
            }
            Err(e) => gpu::skip_or_fail(step, &e),
        }
    }
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();

    // Trial 1: replay by button, then answer sequence 2 by button.
    until(&mut h, "answer");
    h.get_by_label("Replay [R]").click();
    h.step();
    assert_eq!(h.state().screen(), "presenting");
    until(&mut h, "answer");
    h.get_by_label("Sequence 2 [2]").click();
    h.step();

    // Trial 2: replay by key, answer sequence 1 by button.
    until(&mut h, "answer");
    h.key_press(Key::R);
    h.step();
    until(&mut h, "answer");
    h.get_by_label("Sequence 1 [1]").click();
    h.step();

    // Trial 3 on screen: Escape asks, Continue resumes, Escape + Quit closes.
    until(&mut h, "presenting");
    h.key_press(Key::Escape);
    h.step();
    assert!(h.state().confirming_quit());
    h.get_by_label("Continue").click();
    h.step();
    assert!(!h.state().confirming_quit());
    h.key_press(Key::Escape);
    h.step();
    h.get_by_label("Quit").click();
    h.step();
    assert_eq!(h.state().screen(), "closed");
    let schedule = h.state().session().unwrap().schedule.clone();
    drop(h);

    let log = SessionLog::read(&path).unwrap();
    assert!(!log.completed);
    assert_eq!(log.header.get("attributes"), Some(r#"{"cg_experience":"no"}"#));
    let display: serde_json::Value = serde_json::from_str(log.header.get("display").unwrap()).unwrap();
    assert_eq!(display["mode"], "mono");
    // The refresh rate was measured on the start screen (the harness steps at 60 Hz).
    assert_eq!(display["refresh_source"], "measured");
    // (egui's clock advances by the f32 step 1/60, hence 59.999997 Hz.)
    assert!((display["refresh_hz"].as_f64().unwrap() - 60.0).abs() < 1e-4, "{display}");
    assert_eq!(display["refresh_measured_intervals"], runner::app::REFRESH_CALIBRATION_FRAMES - 1);
    let r = rows(&path);
    assert_eq!(r.len(), 3);
    assert!(r[0].practice && !r[1].practice);
    assert_eq!((r[0].choice, r[0].replays), (r[0].shown[0], 0));
    assert_eq!((r[1].choice, r[1].replays), (r[1].shown[1], 1));
    assert_eq!((r[2].choice, r[2].replays), (r[2].shown[0], 1));
    for (row, trial) in r.iter().zip(&schedule) {
        assert_eq!(row.shown, trial.shown);
        assert_eq!(row.dropped_frames, 0, "paced at the harness's 60 Hz steps");
        assert_eq!(row.correct, None);
        // Each row records the scale and angle of the trial (the calibrated ones for now).
        assert_eq!(
            (row.scale, row.visual_angle_deg),
            (display["scale"].as_f64(), display["visual_angle_deg"].as_f64())
        );
        assert!(row.scale.is_some_and(|s| s > 0.0), "{display}");
    }
    // Every presented frame was logged: 3 frames per sequence, 2 sequences, replays doubled.
    let frames = std::fs::read_to_string(path.with_extension("frames.tsv")).unwrap();
    assert_eq!(frames.lines().count(), 1 + 6 + 12 + 12);

    // Resume: same code, continues at trial 3 in the same order, then runs to the end.
    let mut h = harness(cfg);
    start(&mut h, "P07");
    assert!(h.state().message().unwrap().contains("Resuming session 1 at trial 4"), "{:?}", h.state().message());
    assert_eq!(h.state().session().unwrap().next, 3);
    h.get_by_label("Begin").click();
    while h.state().screen() != "done" {
        until(&mut h, "answer");
        h.key_press(Key::Num2);
        h.step();
        h.step();
    }
    let log = SessionLog::read(&path).unwrap();
    assert!(log.completed);
    let r = rows(&path);
    assert_eq!(r.len(), schedule.len());
    assert!(r.iter().zip(&schedule).all(|(row, t)| row.shown == t.shown && row.trial == t.index));
    assert!(r[3..].iter().all(|row| row.choice == row.shown[1]));
}

#[test]
fn scripted_participant_matching_by_key_and_button() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(config(dir.path(), "match"));
    start(&mut h, "M01");
    h.get_by_label("Begin practice").click();
    until(&mut h, "presenting");
    assert!(h.query_by_label("Reference").is_some() && h.query_by_label("Candidate B").is_some());
    until(&mut h, "answer");
    h.get_by_label("Candidate B [2]").click();
    h.step();
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();
    until(&mut h, "answer");
    let path = h.state().session().unwrap().path().to_owned();
    drop(h);
    let r = rows(&path);
    assert_eq!(r.len(), 2);
    for (row, slot) in r.iter().zip([1, 0]) {
        assert_eq!(row.shown.len(), 3);
        assert_eq!(row.choice, row.shown[1 + slot]);
        assert_eq!(row.correct, Some(row.choice == row.shown[0]));
    }
    // The practice reference is the first of the practice pair.
    assert_eq!(r[0].shown[0].to_string(), "M2-S2-T1-A1");
}

#[test]
fn closing_the_window_during_a_session_asks_first() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(config(dir.path(), "2afc"));
    // Before a session starts, the close button closes.
    assert!(!close_request(&mut h));
    assert!(!h.state().confirming_quit());
    start(&mut h, "C01");
    assert_eq!(h.state().screen(), "briefing");
    assert!(close_request(&mut h), "close not cancelled on the briefing");
    assert!(h.state().confirming_quit());
    h.run_steps(2);
    h.get_by_label("Continue").click();
    h.step();
    assert!(!h.state().confirming_quit());
    h.run_steps(2);
    h.get_by_label("Begin practice").click();
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();
    // During a trial the close is cancelled and the quit question shows; Quit then closes.
    until(&mut h, "presenting");
    assert!(close_request(&mut h), "close not cancelled during a trial");
    assert!(h.state().confirming_quit());
    h.run_steps(2);
    assert!(h.query_by_label("Quit the experiment?").is_some());
    h.get_by_label("Quit").click();
    h.step();
    assert_eq!(h.state().screen(), "closed");
    assert!(!close_request(&mut h), "a closed session must let the window close");
    let path = h.state().session().unwrap().path().to_owned();
    drop(h);
    // The answered practice trial is on disk; the trial on screen is not.
    let r = rows(&path);
    assert_eq!(r.len(), 1);
    assert!(r[0].practice);
}

/// Steps through a matching trial of 640x360 stimuli in a window of `size`; returns the
/// notice shown and the lowest edge of the answer buttons and labels.
fn matching_trial_in(size: [f32; 2]) -> (bool, f32) {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness_sized(config_sized(dir.path(), "match", 640, 360), size);
    start(&mut h, "W01");
    h.get_by_label("Begin practice").click();
    until(&mut h, "answer");
    h.run_steps(2);
    let warned = h.query_by_label_contains("The window is too small for the calibrated size").is_some();
    let bottom =
        ["Reference", "Candidate A", "Candidate B", "Which one?", "Candidate A [1]", "Candidate B [2]", "Replay [R]"]
            .iter()
            .map(|l| h.get_by_label(l).rect().bottom())
            .fold(0.0, f32::max);
    // The answer still works.
    h.get_by_label("Candidate B [2]").click();
    h.step();
    assert_eq!(rows(h.state().session().unwrap().path()).len(), 1);
    (warned, bottom)
}

#[test]
fn matching_fits_a_1280x720_window_with_a_warning() {
    let (warned, bottom) = matching_trial_in([1280.0, 720.0]);
    assert!(warned, "no warning that the stimuli are drawn smaller than calibrated");
    assert!(bottom <= 720.0, "the layout ends at {bottom} px, below the 720 px window");
    // A window as large as the calibrated layout needs shows it unscaled, without a warning.
    let (warned, bottom) = matching_trial_in([1400.0, 1000.0]);
    assert!(!warned);
    assert!(bottom > 720.0 && bottom <= 1000.0, "{bottom}");
}

#[test]
fn a_given_refresh_rate_overrides_the_measurement_and_both_are_logged() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path(), "2afc");
    cfg.refresh_hz = Some(75.0);
    let mut h = Harness::builder()
        .with_size([1400.0, 1100.0])
        .with_step_dt(1.0 / 60.0)
        .build_eframe(move |_cc| RunnerApp::new(cfg));
    // No need to wait for the measurement, but it still runs.
    assert!(h.state().ready_to_start());
    h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES);
    assert!(h.query_by_label_contains("Pacing uses 75.00 Hz from --refresh-hz.").is_some());
    start(&mut h, "R01");
    let path = h.state().session().unwrap().path().to_owned();
    drop(h);
    let log = SessionLog::read(&path).unwrap();
    let display: serde_json::Value = serde_json::from_str(log.header.get("display").unwrap()).unwrap();
    assert_eq!(
        (display["refresh_hz"].as_f64(), display["refresh_source"].as_str()),
        (Some(75.0), Some("--refresh-hz"))
    );
    assert!((display["refresh_measured_hz"].as_f64().unwrap() - 60.0).abs() < 1e-4, "{display}");
}

/// With a wgpu device, as in the real window, the loader thread uploads the frames and the
/// runner's own pipelines draw them; in anaglyph mode the GPU composes the red-cyan image from
/// the side-by-side frame when it is drawn.
#[test]
fn anaglyph_trial_is_composed_on_the_gpu_when_drawn() {
    if gpu::test_context("anaglyph_trial_is_composed_on_the_gpu_when_drawn").is_none() {
        return;
    }
    exit_guard::arm();
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config_of(definition_of(dir.path(), "2afc", "stereo"), dir.path(), 64, 36);
    cfg.display = DisplayMode::Anaglyph;
    let set = cfg.set.clone();
    let mut h = Harness::builder()
        .with_size([1400.0, 1100.0])
        .with_step_dt(1.0 / 60.0)
        .wgpu()
        .build_eframe(move |_cc| RunnerApp::new(cfg));
    h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES);
    start(&mut h, "A01");
    h.get_by_label("Begin practice").click();
    until(&mut h, "presenting");
    let image = h.render().unwrap();
    exit_guard::arm();
    // Colours of the anaglyphs the CPU composes from the trial's frames, and of the eyes'
    // own pixels, apart from the grey field (which the Dubois matrices keep grey).
    let trial = h.state().session().unwrap().current().unwrap().clone();
    let (mut composed, mut eyes) = (HashSet::new(), HashSet::new());
    let mut per_frame = 0;
    for id in &trial.shown {
        let seq = set.sequence(id);
        for path in seq.frame_paths() {
            let frame = decode_frame(&path, seq.manifest.width, seq.manifest.height).unwrap();
            eyes.extend(frame.pixels.chunks(4).map(|p| [p[0], p[1], p[2]]));
            let ana = transform(DisplayMode::Anaglyph, View::Stereo, frame);
            per_frame = ana.pixels.chunks(4).filter(|p| p[..3] != [60, 60, 60]).count();
            composed.extend(ana.pixels.chunks(4).map(|p| [p[0], p[1], p[2]]));
        }
    }
    composed.remove(&[60, 60, 60]);
    eyes.retain(|c| !composed.contains(c) && *c != [60, 60, 60]);
    assert!(per_frame > 0 && !eyes.is_empty());
    let rgb = |p: &image::Rgba<u8>| [p.0[0], p.0[1], p.0[2]];
    let drawn = image.pixels().filter(|p| composed.contains(&rgb(p))).count();
    let raw = image.pixels().filter(|p| eyes.contains(&rgb(p))).count();
    // At least one frame's worth of the anaglyph's colours (more where the scale is above 1),
    // and none of the eyes' own colours.
    assert!(drawn >= per_frame, "{drawn} pixels with the anaglyph's colours, want {per_frame}");
    assert_eq!(raw, 0, "pixels with an eye's colour shown unchanged");
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();
    let path = h.state().session().unwrap().path().to_owned();
    drop(h);
    let r = rows(&path);
    assert_eq!(r.len(), 1);
    assert!(r[0].shown.iter().all(|id| id.view == View::Stereo));
}

/// Without a wgpu device (egui's own textures, as with the glow renderer) row-interleaved
/// stereo is right only at one screen pixel per stimulus pixel; a small stimulus calibrated
/// to 14.4 degrees is drawn much larger, so the trial says the stereo is wrong instead of
/// showing it silently.
#[test]
fn row_interleave_without_wgpu_warns_when_the_scale_is_not_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config_of(definition_of(dir.path(), "2afc", "stereo"), dir.path(), 64, 36);
    cfg.display = DisplayMode::RowInterleaved;
    let mut h = harness(cfg);
    start(&mut h, "I01");
    h.get_by_label("Begin practice").click();
    until(&mut h, "presenting");
    h.run_steps(2);
    let warning = h.query_by_label_contains("Row-interleaved stereo is WRONG here");
    assert!(warning.is_some(), "no warning that row-interleaved stereo needs the wgpu renderer");
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();
    assert_eq!(rows(h.state().session().unwrap().path()).len(), 1);
}
