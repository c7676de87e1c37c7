//! Hard values through the built binary (issue 31): what a renderer cannot do is refused
//! before rendering, with exit code 2 and the design's file, line and key; what a renderer
//! refuses of a frame (the GPU's one wrap per exposure) is bad input too.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};
use std::process::Output;

use blurlab_e2e::{repo_root, run, stderr};

/// The shipped design `file` with `from` replaced by `to`, written into `dir`.
fn edited(dir: &Path, file: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo_root().join("stimuli").join(file)).unwrap();
    assert!(text.contains(from), "{from}");
    let path = dir.join("d.toml");
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path
}

fn render_frame(design: &Path, id: &str, device: &str, out: &Path) -> Output {
    run(&[
        "render-frame",
        "--design",
        design.to_str().unwrap(),
        "--preset",
        "quick",
        id,
        "--frame",
        "3",
        "--device",
        device,
        "--out",
        out.to_str().unwrap(),
    ])
}

fn line_of(path: &Path, needle: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn hard_design_values_are_refused_with_exit_2_naming_file_line_and_key() {
    let nav = "navarro2011.toml";
    let m = "methods.toml";
    let cases: [(&str, &str, &str, &str, &str, &str); 9] = [
        (nav, "height = 0.50", "height = -0.5", "M1-S3-T5-A1", "camera.height", "above the floor"),
        (nav, "distance = 3.0", "distance = 0.05", "M1-S3-T5-A1", "camera.distance", "inside the sphere"),
        (
            nav,
            "max_bounces = 4",
            "max_bounces = 4294967295",
            "M1-S3-T5-A1",
            "integrator.max_bounces",
            "above the limit",
        ),
        (nav, "intensity = 1.0", "intensity = 3e36", "M1-S3-T5-A1", "lighting.intensity", "above the limit"),
        (
            nav,
            "environment = { kind = \"default\", width = 1024 }",
            "environment = { kind = \"uniform\", radiance = [1e300, 1e300, 1e300] }",
            "M1-S3-T5-A1",
            "lighting.environment.radiance",
            "1e300 is above the limit",
        ),
        (m, "gamma = 1.5", "gamma = 0.0", "M1-S3-T5-A1-guertin", "factors.method[4].gamma", "[0.001, 100]"),
        (m, "gamma = 1.5", "gamma = 1e-300", "M1-S3-T5-A1-guertin", "factors.method[4].gamma", "found 1e-300"),
        (
            m,
            "intervals = 8",
            "intervals = 8\ntessellation = 2",
            "M1-S3-T5-A1-analytic",
            "factors.method[5].tessellation",
            "3..=4096",
        ),
        (
            m,
            "instants = 8",
            "instants = 4096\nsamples_per_instant = 1048576",
            "M1-S3-T5-A1-accum",
            "factors.method[2].samples_per_instant",
            "samples per pixel, above the limit of 1048576",
        ),
    ];
    for (file, from, to, id, key, needle) in cases {
        let dir = tempfile::tempdir().unwrap();
        let design = edited(dir.path(), file, from, to);
        let out_path = dir.path().join("f.exr");
        let o = render_frame(&design, id, "cpu", &out_path);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{to}: {err}");
        let leaf = key.rsplit('.').next().unwrap();
        let line = line_of(&design, to.lines().find(|l| l.contains(leaf)).unwrap_or(to));
        let head = format!("{}:{line}: key `{key}`: ", design.display());
        assert!(err.contains(&head) && err.contains(needle), "{to}: {err}\nwanted {head} ... {needle}");
        assert!(!err.contains("0000000000"), "numbers in short form: {err}");
        assert!(!out_path.exists());
    }
}

#[test]
fn the_shipped_designs_validate_in_both_presets() {
    for file in ["navarro2011.toml", "methods.toml"] {
        for preset in ["full", "quick"] {
            let design = repo_root().join("stimuli").join(file);
            let o = run(&["stimuli", "list", "--design", design.to_str().unwrap(), "--preset", preset]);
            assert!(o.status.success(), "{file} {preset}: {}", stderr(&o));
        }
    }
}

/// The GPU refuses a sphere whose path wraps more than once in one exposure (the tracer's
/// and the analytic kernel's one wrap per exposure): the frame's scene, so exit code 2.
#[test]
fn the_gpus_wrap_refusal_is_bad_input() {
    for (file, id) in [("navarro2011.toml", "M1-S3-T5-A1"), ("methods.toml", "M1-S3-T5-A1-analytic")] {
        let dir = tempfile::tempdir().unwrap();
        let design = edited(dir.path(), file, "degrees_per_second = 15.0", "degrees_per_second = 1000.0");
        let o = render_frame(&design, id, "gpu", &dir.path().join("f.exr"));
        let err = stderr(&o);
        if !o.status.success() && err.contains("no GPU adapter") {
            gpu::skip_or_fail("the_gpus_wrap_refusal_is_bad_input", &err);
            return;
        }
        assert_eq!(o.status.code(), Some(2), "{id}: {err}");
        assert!(err.contains("its path's wrap length"), "{id}: {err}");
    }
}
