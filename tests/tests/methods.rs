//! End-to-end: the rendering method as a study factor. `stimuli/methods.toml` renders the
//! study scene through the tracer, the accumulation buffer and both post-process filters;
//! `experiments/mono-methods.toml` compares them (2AFC, all pairs) with simulated
//! participants; `blurlab analyze` groups the methods like any other factor, with their cost
//! from the manifests. `render-frame --method` renders one frame with any method.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;

use blurlab_e2e::{repo_root, run};
use study::manifest::SequenceManifest;

fn methods_design() -> String {
    repo_root().join("stimuli/methods.toml").to_string_lossy().into_owned()
}

#[test]
fn a_methods_set_renders_is_judged_and_grouped_by_method() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    blurlab_e2e::render_quick_set(&repo_root().join("stimuli/methods.toml"), "M3 S3 T5 A1,A5", &set);
    let index: serde_json::Value = serde_json::from_slice(&std::fs::read(set.join("index.json")).unwrap()).unwrap();
    let ids: Vec<&str> = index["sequences"].as_array().unwrap().iter().map(|s| s["id"].as_str().unwrap()).collect();
    assert_eq!(ids.len(), 10, "{ids:?}");
    for method in ["tracer", "accum", "mcguire", "guertin", "analytic"] {
        for level in ["A1", "A5"] {
            let id = format!("M3-S3-T5-{level}-{method}");
            let m = SequenceManifest::read(&set.join(&id).join("manifest.json")).unwrap();
            assert_eq!(m.method.name(), method, "{id}");
            assert_eq!(m.factors.method.as_ref().unwrap().label, method);
            assert_eq!(m.frames.len(), 8);
        }
    }
    // The tracer level is navarro2011's sequence, byte for byte: its seeds ignore the method.
    let navarro = dir.path().join("navarro");
    let out = run(&[
        "stimuli",
        "render",
        "--design",
        repo_root().join("stimuli/navarro2011.toml").to_str().unwrap(),
        "--preset",
        "quick",
        "--views",
        "mono",
        "--only",
        "M3 S3 T5 A1",
        "--device",
        "cpu",
        "--out",
        navarro.to_str().unwrap(),
        "--progress",
        "quiet",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in 0..8 {
        let name = format!("frame-{f:04}.png");
        let a = std::fs::read(set.join("M3-S3-T5-A1-tracer").join(&name)).unwrap();
        let b = std::fs::read(navarro.join("M3-S3-T5-A1").join(&name)).unwrap();
        assert!(a == b, "{name}");
        // The methods differ from the tracer where the sphere moves.
        let g = std::fs::read(set.join("M3-S3-T5-A1-guertin").join(&name)).unwrap();
        assert!(g != a, "{name}");
    }

    let report = blurlab_e2e::simulate_and_analyze(
        &repo_root().join("experiments/mono-methods.toml"),
        &set,
        &dir.path().join("results"),
        &dir.path().join("report"),
    );
    let text = report.to_string();
    let experiment = &report["experiments"][0];
    let varying: Vec<&str> = experiment["varying"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(varying, ["samples", "method"], "{text}");
    let labels: Vec<&str> = experiment["labels"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert!(labels.contains(&"A1-guertin") && labels.contains(&"A5-tracer"), "{labels:?}");
    assert!(text.contains("\"guertin\""), "method levels appear in the factor preferences: {text}");
}

/// `render-frame` of quick-preset frame 3 of `id` from methods.toml on the CPU, to `out`.
fn render_frame(id: &str, extra: &[&str], out: &Path) -> std::process::Output {
    let design = methods_design();
    let mut args = vec!["render-frame", "--design", &design, "--preset", "quick", id, "--frame", "3"];
    args.extend_from_slice(&["--device", "cpu", "--out", out.to_str().unwrap()]);
    args.extend_from_slice(extra);
    run(&args)
}

#[test]
fn render_frame_renders_with_each_method_and_names_a_missing_method_level() {
    let dir = tempfile::tempdir().unwrap();
    let mut images = Vec::new();
    for method in ["tracer", "accum", "mcguire", "guertin", "analytic"] {
        let out_path = dir.path().join(format!("{method}.exr"));
        let out = render_frame(&format!("M3-S3-T5-A2-{method}"), &[], &out_path);
        assert!(out.status.success(), "{method}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(String::from_utf8_lossy(&out.stderr).contains(&format!("with the {method}")));
        images.push(std::fs::read(&out_path).unwrap());
    }
    for i in 1..images.len() {
        assert!(images[i] != images[0], "method {i} renders the tracer's image");
    }
    // --method overrides the id's method level with that method's defaults.
    let out = render_frame("M3-S3-T5-A1-tracer", &["--method", "guertin"], &dir.path().join("override.png"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("with the guertin"));
    let out = render_frame("M3-S3-T5-A1", &[], &dir.path().join("x.png"));
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("name a level after A (tracer, accum, mcguire, guertin, analytic)"), "{err}");
    assert!(!dir.path().join("x.png").exists());
    let out = render_frame("M3-S3-T5-A1-guertin", &["--method", "analytic"], &dir.path().join("y.png"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("with the analytic"));
}

#[test]
fn the_analytic_rasterizers_accuracy_is_written_and_its_bad_settings_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("accuracy");
    let small = [
        "--width",
        "64",
        "--height",
        "36",
        "--tessellations",
        "8,32",
        "--shadow-speeds",
        "15,144",
        "--shadow-width",
        "48",
        "--shadow-spp",
        "4",
    ];
    let mut args = vec!["bench", "analytic-accuracy", "--out", out_dir.to_str().unwrap()];
    args.extend_from_slice(&small);
    let out = run(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for f in ["accuracy.json", "depth-error.csv", "depth-error.png", "depth-error.svg", "tessellation.csv"] {
        assert!(out_dir.join(f).exists(), "{f} missing");
    }
    let csv = std::fs::read_to_string(out_dir.join("tessellation.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 2, "{csv}");
    assert!(csv.starts_with("paths,segments,samples,max,mean,bias\ntranslated,8,"), "{csv}");
    let csv = std::fs::read_to_string(out_dir.join("contact-shadow.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2, "{csv}");
    assert!(csv.lines().nth(2).is_some_and(|l| l.starts_with("144,")), "{csv}");

    let out = run(&["bench", "analytic-accuracy", "--tessellations", "16,2"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--tessellation(s): 2 is outside 3..=4096"), "{err}");
    let out = run(&["bench", "analytic", "--supersampling", "9", "--width", "8", "--height", "8"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("supersampling must lie in 1..=8, found 9"), "{err}");
}
