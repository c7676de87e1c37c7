//! End-to-end: morphological antialiasing as a study factor. `stimuli/antialiasing.toml`
//! renders the study scene through the analytic rasterizer at one point per pixel without
//! and with MLAA and at 2 x 2 to 4 x 4 points; `experiments/mono-antialiasing.toml` compares
//! them (2AFC) with simulated participants and `blurlab analyze` groups the levels.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use blurlab_e2e::repo_root;
use study::manifest::SequenceManifest;

#[test]
fn an_antialiasing_set_renders_is_judged_and_grouped() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    blurlab_e2e::render_quick_set(&repo_root().join("stimuli/antialiasing.toml"), "M2 S1 T1 A2", &set);
    let tags = ["analytic", "analytic2", "analytic3", "analytic4", "analytic5", "analytic6"];
    for tag in tags {
        let m = SequenceManifest::read(&set.join(format!("M2-S1-T1-A2-{tag}")).join("manifest.json")).unwrap();
        assert_eq!(m.frames.len(), 8, "{tag}");
    }
    // MLAA changes the one-point frames (their edges), on luminance and on depth edges
    // differently.
    for f in 0..8 {
        let name = format!("frame-{f:04}.png");
        let aliased = std::fs::read(set.join("M2-S1-T1-A2-analytic").join(&name)).unwrap();
        let mlaa = std::fs::read(set.join("M2-S1-T1-A2-analytic2").join(&name)).unwrap();
        let depth = std::fs::read(set.join("M2-S1-T1-A2-analytic6").join(&name)).unwrap();
        assert!(aliased != mlaa && aliased != depth, "{name}: MLAA changed nothing");
        assert!(mlaa != depth, "{name}: depth edges found what luminance does");
    }
    let report = blurlab_e2e::simulate_and_analyze(
        &repo_root().join("experiments/mono-antialiasing.toml"),
        &set,
        &dir.path().join("results"),
        &dir.path().join("report"),
    );
    let varying: Vec<&str> =
        report["experiments"][0]["varying"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(varying, ["method"]);
}
