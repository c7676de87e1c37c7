//! Reliability under concurrent use and damaged sets, through the built binary with real
//! processes: one writer per session log, one writer per set folder with an index rebuilt
//! from verified manifests, and stimuli verified before a participant sees them.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use blurlab_e2e::{blurlab, repo_root, run, stderr, stdout};
use study::StimulusId;
use study::response::SessionLog;

const EXPERIMENT: &str = r#"format = "blurlab-experiment/1"
name = "lock"
task = "2afc"
question = "Which is better?"
view = "mono"

[stimuli]
material = [2]
speed = [2]
shutter = [1, 2, 3]
samples = [5]

[pairs]
repeats = 4
"#;

/// An experiment of 12 trials and a synthetic set holding its stimuli.
fn setup(dir: &Path) -> (PathBuf, PathBuf) {
    let exp = dir.join("lock.toml");
    std::fs::write(&exp, EXPERIMENT).unwrap();
    let ids: Vec<StimulusId> =
        ["M2-S2-T1-A5", "M2-S2-T2-A5", "M2-S2-T3-A5"].iter().map(|s| s.parse().unwrap()).collect();
    let set = dir.join("set");
    runner::stimuli::write_synthetic_set(&set, &ids, 8, 4, 3, 30.0).unwrap();
    (exp, set)
}

fn run_args<'a>(exp: &'a Path, set: &'a Path, results: &'a Path, participant: &'a str, delay: &'a str) -> Vec<String> {
    [
        "run",
        exp.to_str().unwrap(),
        "--stimuli",
        set.to_str().unwrap(),
        "--results",
        results.to_str().unwrap(),
        "--participant",
        participant,
        "--simulate",
        "random",
        "--seed",
        "5",
        "--trial-delay-ms",
        delay,
    ]
    .iter()
    .map(|s| (*s).to_owned())
    .collect()
}

fn spawn(args: &[String]) -> Child {
    Command::new(blurlab())
        .args(args)
        .current_dir(repo_root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < Duration::from_secs(60), "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn rows(log: &Path) -> usize {
    SessionLog::read(log).map(|l| l.rows.len()).unwrap_or(0)
}

#[test]
fn a_second_run_of_a_participant_is_refused_naming_the_holder_and_a_killed_ones_lock_is_taken_over() {
    let dir = tempfile::tempdir().unwrap();
    let (exp, set) = setup(dir.path());
    let results = dir.path().join("results");
    let participant_dir = results.join("lock/P01");

    // The first process runs slowly; a second one started meanwhile is refused.
    let first = spawn(&run_args(&exp, &set, &results, "P01", "150"));
    wait_for("the first session's first row", || rows(&participant_dir.join("session-1.csv")) >= 1);
    let second = run(&run_args(&exp, &set, &results, "P01", "0").iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(second.status.code(), Some(2), "{}\n{}", stdout(&second), stderr(&second));
    let message = stderr(&second);
    assert!(message.contains(&format!("pid {}", first.id())), "{message}");
    assert!(message.contains(&format!("host {}", study::lock::host_name())), "{message}");
    assert!(message.contains("session.lock") && message.contains("participant P01"), "{message}");
    let out = first.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // One complete session, every trial once, in order; the lock is gone.
    let log = SessionLog::read(&participant_dir.join("session-1.csv")).unwrap();
    assert!(log.completed);
    let trials: Vec<u32> = log.rows.iter().map(|(_, r)| r.trial).collect();
    assert_eq!(trials, (0..12).collect::<Vec<u32>>());
    assert!(!participant_dir.join("session-2.csv").exists());
    assert!(!participant_dir.join("session.lock").exists());

    // A killed process leaves its lock; the next run finds it stale and resumes.
    let p02 = results.join("lock/P02");
    let mut killed = spawn(&run_args(&exp, &set, &results, "P02", "150"));
    wait_for("the killed session's second row", || rows(&p02.join("session-1.csv")) >= 2);
    killed.kill().unwrap();
    killed.wait().unwrap();
    assert!(p02.join("session.lock").exists());
    let o = run(&run_args(&exp, &set, &results, "P02", "0").iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("resumed at trial") && stdout(&o).contains("complete"), "{}", stdout(&o));
    let log = SessionLog::read(&p02.join("session-1.csv")).unwrap();
    let trials: Vec<u32> = log.rows.iter().map(|(_, r)| r.trial).collect();
    assert_eq!(trials, (0..12).collect::<Vec<u32>>());
}

fn render_args(design: &Path, out: &Path, only: &str) -> Vec<String> {
    let (design, out) = (design.to_str().unwrap(), out.to_str().unwrap());
    ["stimuli", "render", "--design", design, "--preset", "quick", "--only", only, "--out", out, "--progress", "lines"]
        .iter()
        .map(|s| (*s).to_owned())
        .collect()
}

/// Every sequence the index lists, after checking that its manifest and frames verify.
fn verified_index(set: &Path) -> Vec<String> {
    let index = study::manifest::SetIndex::read(&set.join("index.json")).unwrap();
    for e in &index.sequences {
        let bytes = std::fs::read(set.join(&e.folder).join("manifest.json")).unwrap();
        assert_eq!(study::fsio::sha256_hex(&bytes), e.manifest_sha256, "{}", e.id);
        let m = study::manifest::SequenceManifest::read(&set.join(&e.folder).join("manifest.json")).unwrap();
        for f in &m.frames {
            assert_eq!(study::fsio::sha256_file(&set.join(&e.folder).join(&f.png)).unwrap(), f.png_sha256);
        }
    }
    index.sequences.iter().map(|e| e.id.to_string()).collect()
}

#[test]
fn two_concurrent_renders_into_one_folder_keep_every_sequence_and_another_design_is_refused_by_key() {
    let dir = tempfile::tempdir().unwrap();
    let design = blurlab_e2e::shipped_design();
    let set = dir.path().join("set");
    // Overlapping selections (T2 in both), started together.
    let a = spawn(&render_args(&design, &set, "M1 S1 T1,T2 A1,A2 mono"));
    let b = spawn(&render_args(&design, &set, "M1 S1 T2,T3 A1,A2 mono"));
    for child in [a, b] {
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let expected: Vec<String> = ["T1", "T2", "T3"]
        .iter()
        .flat_map(|t| ["A1", "A2"].map(|a| format!("M1-S1-{t}-{a}")))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    assert_eq!(verified_index(&set), expected);
    assert!(set.join("design.toml").is_file());
    assert!(!set.join("M1-S1-T2-A1/render.lock").exists());

    // A render of an edited design (another master_seed) is refused by key and changes nothing.
    let index_before = std::fs::read(set.join("index.json")).unwrap();
    let edited = dir.path().join("edited.toml");
    let text = std::fs::read_to_string(&design).unwrap().replace("master_seed = 2011", "master_seed = 7");
    std::fs::write(&edited, text).unwrap();
    let o = run(&render_args(&edited, &set, "M1 S1 T1 A1 mono").iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("`master_seed` (2011 there, 7 here)"), "{}", stderr(&o));
    assert!(stderr(&o).contains("another version of design `navarro2011`"), "{}", stderr(&o));
    assert_eq!(std::fs::read(set.join("index.json")).unwrap(), index_before);
}

#[test]
fn oversized_values_are_errors_naming_the_limit_never_aborts() {
    let dir = tempfile::tempdir().unwrap();
    let env_out = dir.path().join("env.exr");
    let env_out = env_out.to_str().unwrap();
    for (args, needle) in [
        (vec!["stats", "srange-quantile", "--t", "18446744073709551615", "--alpha", "0.01"], "above the limit of 1000"),
        (vec!["stats", "srange-quantile", "--t", "1001", "--alpha", "0.01"], "above the limit of 1000"),
        (vec!["stats", "srange-quantile", "--t", "5", "--alpha", "1e-300"], "from 1e-12 to 1 - 1e-12"),
        (vec!["stats", "srange-quantile", "--t", "5", "--alpha", "0.01", "--judges", "0"], "judges is 0"),
        (vec!["stimuli", "env", "--out", env_out, "--width", "4294967294"], "from 4 to 8192"),
        (vec!["analyze", "results", "--bootstrap", "18446744073709551615"], "above the limit of 100000"),
    ] {
        let o = run(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.contains("backtrace"), "{args:?}: {err}");
    }
    // Every t and alpha accepted gives a finite quantile.
    for (t, alpha) in [("1000", "1e-12"), ("2", "0.9999999999"), ("1000", "0.9999999999")] {
        let o = run(&["stats", "srange-quantile", "--t", t, "--alpha", alpha, "--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        assert!(v["w"].as_f64().unwrap().is_finite() && v["w"].as_f64().unwrap() > 0.0, "{v}");
    }
}
