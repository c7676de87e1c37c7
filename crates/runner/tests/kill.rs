//! Kill-and-resume on a real process: this test binary re-runs itself as a child that runs a
//! simulated session slowly; the parent kills it with SIGKILL mid-session (twice), resumes
//! it to the end, and checks that no answered trial was lost and that the log equals that of
//! an uninterrupted session with the same seed (timestamps aside).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use runner::simulate::{ObserverModel, SimulateOptions, run_session, run_session_with};
use study::StimulusId;
use study::experiment::ExperimentDefinition;
use study::response::{SessionLog, TrialRow};
use study::testing::{ExperimentToml, pair};

const CHILD_ENV: &str = "BLURLAB_KILL_TEST_DIR";

fn setup(dir: &Path) -> ExperimentDefinition {
    let text = ExperimentToml {
        name: "kill".into(),
        task: "match".into(),
        question: "Which matches?".into(),
        material: vec![3],
        shutter: vec![1, 2, 3, 4, 5],
        samples: vec![5],
        repeats: Some(2),
        practice: vec![pair("M3-S2-T1-A5", "M3-S2-T5-A5")],
        ..ExperimentToml::minimal()
    }
    .to_string();
    let path = dir.join("kill.toml");
    if !path.exists() {
        std::fs::write(&path, text).unwrap();
    }
    let d = ExperimentDefinition::read(&path).unwrap();
    if !dir.join("set/index.json").exists() {
        let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        runner::stimuli::write_synthetic_set(&dir.join("set"), &ids, 8, 4, 2, 30.0).unwrap();
    }
    d
}

/// The child: runs participant K01 with a delay per trial until killed or done.
#[test]
#[ignore = "run by kill_9_mid_session_loses_at_most_the_trial_on_screen as a child process"]
fn child_session() {
    let Some(dir) = std::env::var_os(CHILD_ENV) else { return };
    let dir = PathBuf::from(dir);
    let d = setup(&dir);
    let delay: u64 = std::env::var("BLURLAB_KILL_TEST_DELAY_MS").unwrap().parse().unwrap();
    let options = SimulateOptions { trial_delay: Duration::from_millis(delay), ..Default::default() };
    let model: ObserverModel = "thurstone".parse().unwrap();
    run_session_with(&d, &dir.join("set"), &dir.join("results"), "K01", &model, 77, &options).unwrap();
}

fn spawn(dir: &Path, delay_ms: u64) -> Child {
    Command::new(std::env::current_exe().unwrap())
        .args(["child_session", "--exact", "--ignored", "--nocapture", "--test-threads=1"])
        .env(CHILD_ENV, dir)
        .env("BLURLAB_KILL_TEST_DELAY_MS", delay_ms.to_string())
        .spawn()
        .unwrap()
}

fn row_count(path: &Path) -> usize {
    SessionLog::read(path).map(|l| l.rows.len()).unwrap_or(0)
}

fn answers(path: &Path) -> Vec<String> {
    let log = SessionLog::read(path).unwrap();
    assert!(log.trailing_corrupt.is_none());
    // Timestamps aside: every other column, the scale included, must agree.
    log.rows.iter().map(|(_, r)| TrialRow { timestamp: String::new(), ..r.clone() }.to_line()).collect()
}

#[test]
fn kill_9_mid_session_loses_at_most_the_trial_on_screen() {
    let dir = tempfile::tempdir().unwrap();
    let d = setup(dir.path());
    let log = dir.path().join("results/kill/K01/session-1.csv");
    let mut seen = 0;
    for target in [4, 11] {
        let mut child = spawn(dir.path(), 30);
        let start = Instant::now();
        while row_count(&log) < target {
            assert!(start.elapsed() < Duration::from_secs(60), "child too slow");
            assert!(child.try_wait().unwrap().is_none(), "child exited early");
            std::thread::sleep(Duration::from_millis(5));
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let n = row_count(&log);
        assert!(n >= target && n >= seen, "rows went from {seen} to {n}");
        seen = n;
        let read = SessionLog::read(&log).unwrap();
        assert!(!read.completed);
    }
    let status = spawn(dir.path(), 0).wait().unwrap();
    assert!(status.success());
    let whole =
        run_session(&d, &dir.path().join("set"), &dir.path().join("results"), "K02", &"thurstone".parse().unwrap(), 77)
            .unwrap();
    let resumed = answers(&log);
    assert_eq!(resumed.len(), 21);
    assert_eq!(resumed, answers(&whole));
    assert!(SessionLog::read(&log).unwrap().completed);
}
