//! End-to-end: a design with a participating medium (`stimuli/media.toml`, issue 27). The
//! smoke is simulated once and rendered by the f64 reference tracer, which `--device auto`
//! picks; `--device cpu` is refused before anything is written; the smoke shows in the
//! frames where the same design without its `[medium]` table has none.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;

use blurlab_e2e::{repo_root, run, stderr};
use study::manifest::SequenceManifest;

fn render(design: &Path, out: &Path, device: &str) -> std::process::Output {
    let (design, out) = (design.to_string_lossy().into_owned(), out.to_string_lossy().into_owned());
    run(&[
        "stimuli",
        "render",
        "--design",
        &design,
        "--preset",
        "quick",
        "--views",
        "mono",
        "--only",
        "M1 S2 T2 A1",
        "--device",
        device,
        "--out",
        &out,
        "--progress",
        "lines",
    ])
}

/// Mean luminance-ish value (mean of the channels) of frame `f`'s centre columns.
fn centre_mean(set: &Path, f: u32) -> f64 {
    let img = image::open(set.join("M1-S2-T2-A1").join(format!("frame-{f:04}.png"))).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in h / 4..h * 3 / 4 {
        for x in w * 2 / 5..w * 3 / 5 {
            let p = img.get_pixel(x, y);
            sum += (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0;
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_smoke_design_renders_on_the_reference_tracer_and_the_smoke_shows() {
    let dir = tempfile::tempdir().unwrap();
    let design = repo_root().join("stimuli/media.toml");
    // the f32 tracer cannot render a medium: refused, nothing written
    let refused = dir.path().join("refused");
    let out = render(&design, &refused, "cpu");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("--device cpu-reference"), "{}", stderr(&out));
    assert!(!refused.exists());
    // auto picks the reference tracer; the grids are simulated once, before the frames
    let smoke = dir.path().join("smoke");
    let out = render(&design, &smoke, "auto");
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("medium: 10 grids of 40x64x40 (timeline frames 19-28)"), "{}", stderr(&out));
    let m = SequenceManifest::read(&smoke.join("M1-S2-T2-A1/manifest.json")).unwrap();
    assert_eq!(m.frames.len(), 8);
    assert!(m.device.starts_with("cpu-reference"), "{}", m.device);
    // the same design without the medium: the plume at the image centre is gone
    let text = std::fs::read_to_string(&design).unwrap();
    let start = text.find("\n[medium]\n").unwrap();
    let end = text.find("\n[[factors.material]]").unwrap();
    let clear_design = dir.path().join("clear.toml");
    std::fs::write(&clear_design, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let clear = dir.path().join("clear");
    let out = render(&clear_design, &clear, "cpu-reference");
    assert!(out.status.success(), "{}", stderr(&out));
    for f in [0, 7] {
        let (with, without) = (centre_mean(&smoke, f), centre_mean(&clear, f));
        assert!((with - without).abs() > 3.0, "frame {f}: centre {with} with smoke, {without} without");
    }
}
