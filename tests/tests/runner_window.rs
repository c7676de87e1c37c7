//! The participant's window end to end: `blurlab run` and `blurlab bench playback --window`
//! as a user starts them, on a virtual X server (Xvfb, which `.ci/run` installs). The window
//! plays whole trials through the ready screen in mono and in every split stereo mode and
//! logs each trial's scale; a window that cannot open says why and leaves nothing behind.
//!
//! Without Xvfb the window tests are skipped with a `SKIPPED:` line, unless
//! `BLURLAB_REQUIRE_GPU=1` (set by `.ci/run`) asks for every device the tests use.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;
use std::process::{Child, Command};

use blurlab_e2e::{blurlab, repo_root, skipped, stderr};

/// A virtual X server on a free display, stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start(test: &str) -> Option<Xvfb> {
        let found = Command::new("sh").args(["-c", "command -v Xvfb"]).output().is_ok_and(|o| o.status.success());
        if !found {
            assert!(std::env::var_os("BLURLAB_REQUIRE_GPU").is_none(), "{test}: Xvfb is not installed");
            skipped(test, "Xvfb is not installed (apt-get install xvfb xauth)");
            return None;
        }
        // A display number of this process's own, so parallel test binaries do not meet, and
        // not one whose lock a killed server left behind.
        let mut number = 200 + std::process::id() % 500;
        while Path::new(&format!("/tmp/.X{number}-lock")).exists() {
            number += 1;
        }
        let display = format!(":{number}");
        // -noreset: the server resets when its last client leaves, and a window opening during
        // the reset fails to connect.
        let child = Command::new("Xvfb")
            .args([display.as_str(), "-screen", "0", "1920x1080x24", "-nolisten", "tcp", "-noreset"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let socket = format!("/tmp/.X11-unix/X{}", &display[1..]);
        for _ in 0..100 {
            if Path::new(&socket).exists() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        Some(Xvfb { child, display })
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM, so that the server removes its lock file; SIGKILL if that fails.
        let terminated = Command::new("kill").arg(self.child.id().to_string()).status().is_ok_and(|s| s.success());
        if !terminated {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// `blurlab ARGS` with `DISPLAY` set to `display` (and no Wayland display).
fn run_on(display: &str, args: &[&str]) -> std::process::Output {
    let runtime = tempfile::tempdir().unwrap();
    Command::new(blurlab())
        .args(args)
        .current_dir(repo_root())
        .env("DISPLAY", display)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", runtime.path())
        .output()
        .unwrap()
}

#[test]
fn trials_play_in_a_real_window_in_mono_and_every_split_stereo_mode() {
    let test = "trials_play_in_a_real_window_in_mono_and_every_split_stereo_mode";
    let Some(x) = Xvfb::start(test) else { return };
    for mode in ["mono", "sbs-full", "sbs-half", "top-bottom"] {
        let work = tempfile::tempdir().unwrap();
        let work_arg = work.path().to_string_lossy().into_owned();
        let out = run_on(
            &x.display,
            &[
                "bench",
                "playback",
                "--window",
                "--window-display",
                mode,
                "--frames",
                "8",
                "--trials",
                "1",
                "--work",
                &work_arg,
            ],
        );
        assert!(out.status.success(), "{mode}: {}", stderr(&out));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let window = &report["window_playback"];
        assert_eq!(window["trials"], 1, "{mode}: {window}");
        assert_eq!(window["display"], mode);
        // The trial went through the ready screen and played both sequences' frames.
        assert!(window["frames"]["frames"].as_u64().unwrap() >= 2, "{mode}: {window}");
        // Its row records the scale the stimuli were drawn at, within the calibration.
        let results = work.path().join("results");
        let log = std::fs::read_dir(&results)
            .unwrap()
            .flatten()
            .flat_map(|e| std::fs::read_dir(e.path()).unwrap().flatten())
            .map(|e| e.path().join("session-1.csv"))
            .find(|p| p.is_file())
            .unwrap();
        let log = study::response::SessionLog::read(&log).unwrap();
        let display: serde_json::Value = serde_json::from_str(log.header.get("display").unwrap()).unwrap();
        let calibrated = display["scale"].as_f64().unwrap();
        let (_, row) = &log.rows[0];
        let scale = row.scale.unwrap();
        assert!(scale > 0.0 && scale <= calibrated + 1e-9, "{mode}: scale {scale}, calibrated {calibrated}");
        assert!(row.visual_angle_deg.unwrap() > 0.0);
    }
}

#[test]
fn a_window_that_cannot_open_says_why_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let ids: Vec<study::StimulusId> = ["M2-S2-T3-A3", "M2-S2-T3-A5"].iter().map(|s| s.parse().unwrap()).collect();
    let set = dir.path().join("set");
    runner::stimuli::write_synthetic_set(&set, &ids, 32, 18, 2, 30.0).unwrap();
    let experiment = dir.path().join("tiny.toml");
    std::fs::write(
        &experiment,
        "format = \"blurlab-experiment/1\"\nname = \"tiny\"\ntask = \"2afc\"\nquestion = \"Which?\"\nview = \"mono\"\n\
         [stimuli]\nmaterial = [2]\nspeed = [2]\nshutter = [3]\nsamples = [3, 5]\n",
    )
    .unwrap();
    let results = dir.path().join("results");
    let text = |p: &Path| p.to_string_lossy().into_owned();
    // An X display nobody serves.
    let out = run_on(
        ":4321",
        &["run", &text(&experiment), "--stimuli", &text(&set), "--participant", "P01", "--results", &text(&results)],
    );
    assert!(!out.status.success());
    let message = stderr(&out);
    assert!(message.contains("no display found") && message.contains("xvfb-run"), "{message}");
    assert!(!message.contains("panicked"), "{message}");
    assert!(!results.exists(), "a results folder was created for a window that never opened");
}
