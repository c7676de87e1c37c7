//! End-to-end: `blurlab cost` on the study scene shrunk to 64 x 36 pixels (a `tiny` preset
//! added to the shipped design). It writes the table, the plots and the FLIP maps; a sweep
//! killed mid-way continues when rerun and gives the uninterrupted sweep's errors; bad
//! arguments are clear errors with exit code 2.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use blurlab_e2e::{blurlab, repo_root, run, stderr};

fn tiny_design(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repo_root().join("stimuli/navarro2011.toml")).unwrap()
        + "\n[presets.tiny]\nwidth = 64\nheight = 36\nframes = 2\nfirst_frame = 21\nsamples_per_pixel = [1, 2, 4, 8, 16]\n";
    let path = dir.join("tiny.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn args<'a>(design: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "cost",
        "--design",
        design,
        "--preset",
        "tiny",
        "--id",
        "M3-S3-T5",
        "--frames",
        "0,1",
        "--methods",
        "tracer,accum",
        "--max-spp",
        "4",
        "--reference-spp",
        "4096",
        "--repetitions",
        "2",
        "--device",
        "cpu",
        "--quiet",
        "--out",
        out,
    ]
}

/// The columns of cost.csv that do not depend on the machine's speed.
fn error_columns(csv: &str) -> Vec<String> {
    csv.lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [&f[0..5], &f[10..20]].concat().join(",")
        })
        .collect()
}

#[test]
fn a_cost_sweep_writes_its_report_and_a_killed_one_continues_to_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let design = design.to_str().unwrap();
    let whole = dir.path().join("whole");
    let out = run(&args(design, whole.to_str().unwrap()));
    assert!(out.status.success(), "{}", stderr(&out));
    for f in ["cost.csv", "cost.md", "cost.json", "cost-rmse.png", "cost-rmse.svg", "cost-flip.png", "cost-flip.svg"] {
        assert!(whole.join(f).is_file(), "{f}");
    }
    let csv = std::fs::read_to_string(whole.join("cost.csv")).unwrap();
    // Tracer 1, 2, 4 spp and the accumulation buffer's single instant (4 spp): 4 rows.
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(csv.lines().nth(1).unwrap().starts_with("tracer,spp,1,1,4,"), "{csv}");
    assert!(csv.lines().next().unwrap().ends_with(",jod_median,jod_min,jod_max"), "{csv}");
    for line in csv.lines().skip(1) {
        let jod: f64 = line.split(',').nth(17).unwrap().parse().unwrap_or_else(|e| panic!("{line}: {e}"));
        assert!(jod > 0.0 && jod <= 10.0 + 1e-6, "{line}");
    }
    let md = std::fs::read_to_string(whole.join("cost.md")).unwrap();
    assert!(md.contains("## Reference") && md.contains("FLIP error maps"), "{md}");
    assert!(whole.join("maps/tracer-spp4-in4-f0000-r0-flip.png").is_file());

    // Killed after its first points, then rerun: the same errors.
    let killed = dir.path().join("killed");
    let mut child = Command::new(blurlab())
        .args(args(design, killed.to_str().unwrap()))
        .current_dir(repo_root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let points = killed.join("points");
    // Measured points only: a kill can leave an atomic write's hidden temporary file behind.
    let measured = |dir: &std::path::Path| {
        std::fs::read_dir(dir).map_or(0, |d| {
            d.filter_map(Result::ok)
                .filter(|e| {
                    let name = e.file_name();
                    let name = name.to_string_lossy();
                    !name.starts_with('.') && name.ends_with(".json")
                })
                .count()
        })
    };
    while measured(&points) < 2 && started.elapsed() < Duration::from_secs(300) {
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let kept = measured(&points);
    assert!(kept >= 2, "{kept} points before the kill");
    let out = run(&args(design, killed.to_str().unwrap()));
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains(&format!("{kept} kept from an earlier run")) || kept == 16, "{}", stderr(&out));
    let resumed = std::fs::read_to_string(killed.join("cost.csv")).unwrap();
    assert_eq!(error_columns(&resumed), error_columns(&csv));
}

#[test]
fn bad_cost_arguments_are_named_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let design = design.to_str().unwrap();
    let out_dir = dir.path().join("out");
    let out_arg = out_dir.to_str().unwrap();
    for (change, needle) in [
        (("--methods", "raster"), "--methods: unknown rendering method `raster`"),
        (("--id", "M3-S7-T5"), "S7 is not a level of the design"),
        (("--frames", "0,9"), "frame 9 is outside the sequence"),
        (("--reference-spp", "8"), "the reference is not converged enough"),
    ] {
        let mut a = args(design, out_arg);
        let i = a.iter().position(|x| *x == change.0).unwrap();
        a[i + 1] = change.1;
        let out = run(&a);
        assert_eq!(out.status.code(), Some(2), "{change:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{change:?}: {}", stderr(&out));
        let _ = std::fs::remove_dir_all(&out_dir);
    }
}
