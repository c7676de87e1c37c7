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
        presentation: Some(PresentationToml {
            gap_ms: Some(100),
            replay: Some(true),
            loops: None,
            ready_ms: Some(100),
            break_every: Some(2),
        }),
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
    // The experimenter must confirm the ruler check.
    h.get_by_label("Start").click();
    h.run_steps(2);
    assert!(h.state().message().unwrap().contains("measure the bar with a ruler"), "{:?}", h.state().message());
    assert_eq!(h.state().screen(), "start");
    h.get_by_label_contains("I measured this bar with a ruler").click();
    h.run_steps(2);
    h.get_by_label("Start").click();
    h.run_steps(2);
}

/// The start screen of a participant whose session resumes: the recorded answers are shown,
/// not asked again, and the experimenter sees what is on record.
fn start_resuming(h: &mut Harness<'static, RunnerApp>, code: &str, on_record: &str) {
    h.get_by_role(Role::TextInput).focus();
    h.step();
    h.get_by_role(Role::TextInput).type_text(code);
    h.run_steps(2);
    assert!(h.query_by_label("Welcome back. Your answers from last time:").is_some());
    assert!(h.query_by_label("Experience in computer graphics? no").is_some());
    assert!(h.query_by_label("yes").is_none(), "the recorded question is asked again");
    assert!(h.query_by_label_contains(on_record).is_some(), "the experimenter is not shown `{on_record}`");
    h.get_by_label_contains("I measured this bar with a ruler").click();
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
    // The briefing states the response keys.
    assert!(
        h.query_by_label_contains(
            "Answer with the keys 1 (the first sequence) and 2 (the second); R plays the trial again"
        )
        .is_some()
    );

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
    // The end of practice is announced; Space begins the counted trials.
    until(&mut h, "practice-over");
    assert!(h.query_by_label("Practice is over").is_some());
    h.key_press(Key::Space);
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

    // A break after two counted trials (break_every = 2); Space continues.
    until(&mut h, "break");
    assert!(h.query_by_label_contains("2 of 3 trials done").is_some());
    h.key_press(Key::Space);
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
    let mut h = harness(cfg.clone());
    start_resuming(&mut h, "P07", "Session 1: 2 of 3 trials answered, 1 practice (incomplete)");
    // The resume notice and the trial screen count the same way (counted trials from 1).
    let note = h.state().message().unwrap().to_owned();
    assert!(note.contains("Resuming session 1: 2 of 3 trials answered, next is trial 3 of 3."), "{note}");
    assert_eq!(h.state().session().unwrap().next, 3);
    h.key_press(Key::Space);
    h.step();
    until(&mut h, "presenting");
    assert!(h.query_by_label("Trial 3 of 3").is_some());
    while h.state().screen() != "done" {
        until(&mut h, "answer");
        h.key_press(Key::Num2);
        h.step();
        h.step();
    }
    // Escape on the end screen closes without asking: the session is complete.
    h.key_press(Key::Escape);
    h.step();
    assert!(!h.state().confirming_quit());
    assert_eq!(h.state().screen(), "closed");
    let log = SessionLog::read(&path).unwrap();
    assert!(log.completed);
    let r = rows(&path);
    assert_eq!(r.len(), schedule.len());
    assert!(r.iter().zip(&schedule).all(|(row, t)| row.shown == t.shown && row.trial == t.index));
    assert!(r[3..].iter().all(|row| row.choice == row.shown[1]));

    // Again with the same code: the session is complete, so a new one starts only when the
    // experimenter confirms it.
    drop(h);
    let mut h = harness(cfg);
    h.get_by_role(Role::TextInput).focus();
    h.step();
    h.get_by_role(Role::TextInput).type_text("P07");
    h.run_steps(2);
    assert!(h.query_by_label_contains("Session 1: 3 of 3 trials answered, 1 practice (complete)").is_some());
    h.get_by_label_contains("I measured this bar with a ruler").click();
    h.run_steps(2);
    h.get_by_label("Start").click();
    h.run_steps(2);
    assert_eq!(h.state().screen(), "start");
    assert!(h.state().message().unwrap().contains("must be confirmed"), "{:?}", h.state().message());
    assert!(!path.with_file_name("session-2.csv").exists());
    h.get_by_label("Start a new session for this participant").click();
    h.run_steps(2);
    // A new session starts from the answers on record (shown and changeable): no question
    // is left unanswered.
    assert!(h.query_by_label("yes").is_some());
    h.get_by_label("Start").click();
    h.run_steps(2);
    assert_eq!(h.state().screen(), "briefing", "{:?}", h.state().message());
    assert!(h.state().session().unwrap().path().ends_with("P07/session-2.csv"));
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
    until(&mut h, "practice-over");
    h.get_by_label("Begin the experiment").click();
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
    until(&mut h, "practice-over");
    h.key_press(Key::Enter);
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
    until(&mut h, "presenting");
    while h.state().stimulus_rects().is_empty() {
        h.step();
    }
    let drawn_width = h.state().stimulus_rects()[0].width();
    until(&mut h, "answer");
    h.run_steps(2);
    let warned = h.query_by_label_contains("The window is too small for the calibrated size").is_some();
    let bottom =
        ["Reference", "Candidate A", "Candidate B", "Which one?", "Candidate A [1]", "Candidate B [2]", "Replay [R]"]
            .iter()
            .map(|l| h.get_by_label(l).rect().bottom())
            .fold(0.0, f32::max);
    // The answer still works, and its row records the scale the stimuli were drawn at (the
    // calibration is 1 screen pixel per stimulus pixel) and the angle they subtended.
    h.get_by_label("Candidate B [2]").click();
    h.step();
    let path = h.state().session().unwrap().path().to_owned();
    let r = rows(&path);
    assert_eq!(r.len(), 1);
    let (scale, angle) = (r[0].scale.unwrap(), r[0].visual_angle_deg.unwrap());
    assert!((scale - f64::from(drawn_width) / 640.0).abs() < 1e-3, "logged {scale}, drawn {drawn_width} px of 640");
    let viewing = runner::calibration::Viewing::default();
    assert!((angle - runner::calibration::visual_angle_deg(&viewing, 640, scale)).abs() < 1e-9);
    // `analyze` and the experimenter's summary judge a row against the calibrated scale.
    assert_eq!(warned, study::response::off_calibration(scale, 1.0), "scale {scale}");
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

/// Steps a 2AFC or matching practice trial of `task` in `mode` until a stimulus is on screen.
fn presenting_in(dir: &Path, task: &str, view: &str, mode: DisplayMode, size: [f32; 2]) -> Harness<'static, RunnerApp> {
    let mut cfg = config_of(definition_of(dir, task, view), dir, 64, 36);
    cfg.display = mode;
    let mut h = harness_sized(cfg, size);
    start(&mut h, "L01");
    h.key_press(Key::Space);
    h.step();
    until(&mut h, "presenting");
    while h.state().stimulus_rects().is_empty() {
        h.step();
    }
    h
}

#[test]
fn the_stimulus_is_centred_in_the_window_at_every_size() {
    // Calibrated 64x36 stimuli are drawn at 9.93x (635 px for 14.4 degrees): 1000x700 is too
    // small and they shrink, still centred.
    for size in [[1400.0, 1100.0], [1920.0, 1080.0], [1000.0, 700.0], [1333.0, 901.0]] {
        let dir = tempfile::tempdir().unwrap();
        let h = presenting_in(dir.path(), "2afc", "mono", DisplayMode::Mono, size);
        let rects = h.state().stimulus_rects();
        assert_eq!(rects.len(), 1);
        let centre = egui::pos2(size[0] / 2.0, size[1] / 2.0);
        assert!((rects[0].center() - centre).length() <= 1.0, "{size:?}: {:?}", rects[0]);
        let h = presenting_in(dir.path(), "match", "mono", DisplayMode::Mono, size);
        // The reference, playing first, is centred horizontally above its candidates.
        let r = h.state().stimulus_rects()[0];
        assert!((r.center().x - centre.x).abs() <= 1.0 && r.center().y < centre.y, "{size:?}: {r:?}");
    }
}

/// The shapes drawn on screen outside the stimuli (text, buttons, marks), as rectangles.
fn ui_shapes(h: &Harness<'static, RunnerApp>) -> Vec<egui::Rect> {
    let window = h.ctx.content_rect();
    h.output()
        .shapes
        .iter()
        .filter(|s| !matches!(s.shape, egui::Shape::Callback(_)))
        .map(|s| s.shape.visual_bounding_rect())
        .filter(|r| r.is_positive() && r.area() < 0.5 * window.area())
        .collect()
}

#[test]
fn side_by_side_and_top_bottom_show_each_eye_its_half_with_the_same_text() {
    for mode in [DisplayMode::SbsFull, DisplayMode::SbsHalf, DisplayMode::TopBottom] {
        let dir = tempfile::tempdir().unwrap();
        let mut h = presenting_in(dir.path(), "2afc", "stereo", mode, [1920.0, 1080.0]);
        let views = h.state().views().clone();
        assert_eq!(views.eyes.len(), 2, "{mode}");
        // The stimulus: one rectangle per eye, centred in the eye's half of the screen.
        let rects = h.state().stimulus_rects().to_vec();
        assert_eq!(rects.len(), 2, "{mode}");
        for (eye, r) in views.eyes.iter().zip(&rects) {
            assert!((r.center() - eye.region.center()).length() <= 1.0, "{mode}: {r:?} in {:?}", eye.region);
        }
        until(&mut h, "answer");
        // Everything else is drawn twice, at the same place in each eye's half.
        let shapes = ui_shapes(&h);
        let offset = views.eyes[1].region.min - views.eyes[0].region.min;
        let key = |r: &egui::Rect| ((r.min.x * 4.0).round() as i64, (r.min.y * 4.0).round() as i64);
        let mut left: Vec<_> = shapes
            .iter()
            .filter(|r| views.eyes[0].region.contains_rect(**r))
            .map(|r| key(&r.translate(offset)))
            .collect();
        let mut right: Vec<_> = shapes.iter().filter(|r| views.eyes[1].region.contains_rect(**r)).map(key).collect();
        left.sort_unstable();
        right.sort_unstable();
        assert!(left.len() >= 8, "{mode}: only {} shapes in the left eye's half", left.len());
        assert_eq!(left, right, "{mode}: the eyes' halves differ");
        // Nothing is drawn across the seam.
        let straddling = shapes.iter().filter(|r| !views.eyes.iter().any(|e| e.region.contains_rect(**r))).count();
        assert_eq!(straddling, 0, "{mode}");
        // The answer buttons work by pointer on either copy: the right eye's copy of
        // "Sequence 2 [2]" maps back to the button.
        let button = h.get_by_label("Sequence 2 [2]").rect();
        let on_right = views.to_window(1, button.center());
        let mut input = egui::RawInput::default();
        input.events.push(egui::Event::PointerMoved(on_right));
        views.map_input(&mut input);
        assert_eq!(input.events[0], egui::Event::PointerMoved(button.center()), "{mode}");
        h.key_press(Key::Num2);
        h.step();
        assert_eq!(rows(h.state().session().unwrap().path()).len(), 1);
    }
}

#[test]
fn the_start_screen_checks_the_screen_size_the_ruler_and_the_refresh() {
    let dir = tempfile::tempdir().unwrap();
    // A window system reporting a 1920-pixel screen while the calibration assumes 1600.
    let mut h = harness(config(dir.path(), "2afc"));
    h.input_mut().viewports.get_mut(&egui::ViewportId::ROOT).unwrap().monitor_size = Some(egui::vec2(1920.0, 1080.0));
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("reports a screen 1920 px wide, but the calibration assumes 1600 px").is_some(),
        "no warning about the screen's width"
    );
    // Participants see the participant-facing title; the design's name is for the experimenter.
    assert!(h.query_by_label(study::experiment::DEFAULT_PARTICIPANT_TITLE).is_some());
    drop(h);
    // A window redrawing at 87 Hz (no display runs at that) is not a display refresh: Start
    // stays disabled without --refresh-hz.
    let cfg = config(dir.path(), "2afc");
    let mut h = Harness::builder()
        .with_size([1400.0, 1100.0])
        .with_step_dt(1.0 / 87.0)
        .build_eframe(move |_cc| RunnerApp::new(cfg.clone()));
    h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES + 2);
    assert!(h.state().refresh_unreliable() && !h.state().ready_to_start());
    assert!(h.query_by_label_contains("COULD NOT BE MEASURED RELIABLY").is_some());
    assert!(h.query_by_label_contains("--refresh-hz HZ").is_some());
    // A given rate lets the session start.
    let mut cfg = config(dir.path(), "2afc");
    cfg.refresh_hz = Some(60.0);
    let mut h = Harness::builder()
        .with_size([1400.0, 1100.0])
        .with_step_dt(1.0 / 87.0)
        .build_eframe(move |_cc| RunnerApp::new(cfg.clone()));
    h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES + 2);
    assert!(h.state().ready_to_start() && !h.state().refresh_unreliable());
    // A code given on the command line is shown, not editable.
    let mut cfg = config(dir.path(), "2afc");
    cfg.participant = Some("P42".into());
    let h = harness(cfg);
    assert!(h.query_by_role(Role::TextInput).is_none());
    assert!(h.query_by_label("Participant code: P42").is_some());
}

#[test]
fn the_ready_screen_shows_a_fixation_mark_for_its_time_before_each_trial() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(config(dir.path(), "2afc"));
    start(&mut h, "F01");
    h.key_press(Key::Enter);
    h.step();
    // ready_ms = 100: at 60 steps a second, 6 or 7 steps before the presentation starts.
    let mut waiting = 0;
    while matches!(h.state().screen(), "loading" | "ready") {
        waiting += 1;
        assert!(h.state().stimulus_rects().is_empty());
        h.step();
        std::thread::sleep(Duration::from_millis(1));
    }
    assert_eq!(h.state().screen(), "presenting");
    assert!(waiting >= 6, "the ready screen lasted {waiting} steps");
}

/// With a wgpu device, each eye's half of the screen shows exactly that eye's image in the
/// side-by-side and top-bottom modes (the composition on the GPU, clipped to the eye's
/// region): every pixel of the left eye's stimulus rectangle is the left eye's picture of
/// one frame, scaled by nearest sampling, and likewise on the right.
#[test]
fn each_eye_region_shows_its_own_eye_on_the_gpu() {
    if gpu::test_context("each_eye_region_shows_its_own_eye_on_the_gpu").is_none() {
        return;
    }
    exit_guard::arm();
    for mode in [DisplayMode::SbsFull, DisplayMode::SbsHalf, DisplayMode::TopBottom] {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = config_of(definition_of(dir.path(), "2afc", "stereo"), dir.path(), 64, 36);
        cfg.display = mode;
        // 640 px for 14.4 degrees: an integer scale of 10, drawn with a nearest sampler.
        assert_eq!(cfg.calibration().unwrap().scale, 10.0);
        let set = cfg.set.clone();
        let mut h = Harness::builder()
            .with_size([1920.0, 1080.0])
            .with_step_dt(1.0 / 60.0)
            .wgpu()
            .build_eframe(move |_cc| RunnerApp::new(cfg));
        h.run_steps(runner::app::REFRESH_CALIBRATION_FRAMES);
        start(&mut h, "G01");
        h.key_press(Key::Space);
        h.step();
        until(&mut h, "presenting");
        while h.state().stimulus_rects().is_empty() {
            h.step();
        }
        // The harness draws the pointer where the last click was: move it off the stimuli.
        h.input_mut().events.push(egui::Event::PointerMoved(egui::pos2(2.0, 2.0)));
        h.step();
        let rects = h.state().stimulus_rects().to_vec();
        let image = h.render().unwrap();
        exit_guard::arm();
        // The display images of every frame of the trial's stimuli, as the CPU makes them.
        let trial = h.state().session().unwrap().current().unwrap().clone();
        let mut displays = Vec::new();
        for id in &trial.shown {
            let seq = set.sequence(id);
            for path in seq.frame_paths() {
                let frame = decode_frame(&path, seq.manifest.width, seq.manifest.height).unwrap();
                displays.push(transform(mode, View::Stereo, frame));
            }
        }
        for (eye, rect) in rects.iter().enumerate() {
            let (x0, y0) = (rect.min.x.round() as u32, rect.min.y.round() as u32);
            let (w, hgt) = (rect.width().round() as u32, rect.height().round() as u32);
            // The source pixel of eye `eye` under screen pixel (i, j) of its rectangle.
            let source = |d: &runner::display::Rgba8, i: u32, j: u32| match mode {
                DisplayMode::SbsFull => d.get(eye as u32 * 64 + i / 10, j / 10),
                DisplayMode::SbsHalf => d.get(eye as u32 * 32 + i / 10, j / 10),
                _ => d.get(i / 10, eye as u32 * 18 + j / 10),
            };
            let matches = |d: &runner::display::Rgba8| {
                (0..hgt).step_by(3).all(|j| {
                    (0..w).step_by(3).all(|i| {
                        let got = image.get_pixel(x0 + i, y0 + j).0;
                        let want = source(d, i, j);
                        (0..3).all(|c| got[c].abs_diff(want[c]) <= 1)
                    })
                })
            };
            assert!(displays.iter().any(matches), "{mode}: eye {eye}'s region {rect:?} shows none of its frames");
            // The other eye's picture (the bar 2 pixels away) is not what this eye sees.
            let other = |d: &runner::display::Rgba8| {
                let mut swapped = d.clone();
                let (ew, eh) = (d.width, d.height);
                for y in 0..eh {
                    for x in 0..ew {
                        let (sx, sy) = match mode {
                            DisplayMode::TopBottom => (x, (y + eh / 2) % eh),
                            _ => ((x + ew / 2) % ew, y),
                        };
                        swapped.set(x, y, d.get(sx, sy));
                    }
                }
                swapped
            };
            assert!(!displays.iter().map(other).any(|d| matches(&d)), "{mode}: eye {eye} shows the other eye");
        }
        drop(h);
    }
}

/// An ASAP experiment in the window: each counted trial is chosen when it is due, the
/// progress counts the budget, and every answer reaches the shared posterior.
#[test]
fn an_asap_session_runs_in_the_window_to_its_budget() {
    let dir = tempfile::tempdir().unwrap();
    let d = definition(dir.path(), "2afc");
    let text = std::fs::read_to_string(&d.path).unwrap() + "\n[pairs]\nselection = \"asap\"\nbudget = 4\n";
    std::fs::write(&d.path, text).unwrap();
    let d = ExperimentDefinition::read(&d.path).unwrap();
    assert_eq!(d.selection, study::experiment::PairSelection::Asap { budget: 4 });
    let mut h = harness(config_of(d.clone(), dir.path(), 16, 8));
    start(&mut h, "A01");
    h.get_by_label("Begin practice").click();
    until(&mut h, "answer");
    h.key_press(Key::Num1);
    h.step();
    until(&mut h, "practice-over");
    h.key_press(Key::Space);
    h.step();
    for k in 0..4 {
        if k == 2 {
            until(&mut h, "break");
            assert!(h.query_by_label_contains("2 of 4 trials done").is_some());
            h.key_press(Key::Space);
            h.step();
        }
        until(&mut h, "answer");
        h.key_press(if k % 2 == 0 { Key::Num1 } else { Key::Num2 });
        h.step();
    }
    until(&mut h, "done");
    let path = h.state().session().unwrap().path().to_owned();
    drop(h);
    let log = SessionLog::read(&path).unwrap();
    assert!(log.completed);
    assert_eq!(log.header.get("selection"), Some("asap"));
    assert_eq!(log.rows.iter().filter(|(_, r)| !r.practice).count(), 4);
    let shared = runner::shared_posterior::SharedPosterior::read(
        &dir.path().join("results/ui-2afc").join(runner::shared_posterior::POSTERIOR_FILE),
        &d,
    )
    .unwrap();
    assert_eq!(shared.answers.len(), 4);
    assert!(shared.pending.is_empty());
}
