//! End-to-end: a design with a participating medium (`stimuli/media.toml`, issue 27). The
//! smoke is simulated once and rendered by the f64 reference tracer, which `--device auto`
//! picks for the tracer's sequences; `--device cpu` is refused for them before anything is
//! written; the marcher's sequences render on `--device cpu`; the smoke shows in both
//! methods' frames where the same design without its `[medium]` table has none; and
//! `experiments/mono-media.toml` shows only sequences the design has.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;

use blurlab_e2e::{repo_root, run, stderr};
use study::manifest::SequenceManifest;

fn render(design: &Path, out: &Path, only: &str, device: &str) -> std::process::Output {
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
        only,
        "--device",
        device,
        "--out",
        &out,
        "--progress",
        "lines",
    ])
}

/// Mean luminance-ish value (mean of the channels) of frame `f`'s centre columns.
fn centre_mean(set: &Path, sequence: &str, f: u32) -> f64 {
    let img = image::open(set.join(sequence).join(format!("frame-{f:04}.png"))).unwrap().to_rgb8();
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
    let out = render(&design, &refused, "M1 S2 T2 A1 tracer", "cpu");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("--device cpu-reference"), "{}", stderr(&out));
    assert!(!refused.exists());
    // auto picks the reference tracer; the grids are simulated once, before the frames
    let smoke = dir.path().join("smoke");
    let out = render(&design, &smoke, "M1 S2 T2 A1 tracer", "auto");
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("medium: 10 grids of 40x64x40 (timeline frames 19-28)"), "{}", stderr(&out));
    let m = SequenceManifest::read(&smoke.join("M1-S2-T2-A1-tracer/manifest.json")).unwrap();
    assert_eq!(m.frames.len(), 8);
    assert!(m.device.starts_with("cpu-reference"), "{}", m.device);
    // the marcher's sequences render on the wide CPU tracer
    let marched = dir.path().join("marched");
    let out = render(&design, &marched, "M1 S2 T2 A1 marcher,marcher3", "cpu");
    assert!(out.status.success(), "{}", stderr(&out));
    let m = SequenceManifest::read(&marched.join("M1-S2-T2-A1-marcher3/manifest.json")).unwrap();
    assert!(m.device.starts_with("cpu: "), "{}", m.device);
    // the same design without the medium: the plume at the image centre is gone
    let text = std::fs::read_to_string(&design).unwrap();
    let start = text.find("\n[medium]\n").unwrap();
    let end = text.find("\n[[factors.material]]").unwrap();
    let clear_design = dir.path().join("clear.toml");
    std::fs::write(&clear_design, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let clear = dir.path().join("clear");
    let out = render(&clear_design, &clear, "M1 S2 T2 A1 tracer,marcher3", "cpu-reference");
    assert!(out.status.success(), "{}", stderr(&out));
    for f in [0, 7] {
        let (with, without) =
            (centre_mean(&smoke, "M1-S2-T2-A1-tracer", f), centre_mean(&clear, "M1-S2-T2-A1-tracer", f));
        assert!((with - without).abs() > 3.0, "frame {f}: centre {with} with smoke, {without} without");
        // the marcher's full model shows the smoke as the reference does, to within what its
        // approximations leave
        let marcher = centre_mean(&marched, "M1-S2-T2-A1-marcher3", f);
        let without = centre_mean(&clear, "M1-S2-T2-A1-marcher3", f);
        assert!((marcher - without).abs() > 3.0, "frame {f}: marcher {marcher}, without smoke {without}");
        assert!(
            (marcher - with).abs() < 0.5 * (with - without).abs(),
            "frame {f}: marcher {marcher}, reference {with}"
        );
    }
    // the experiment comparing the lighting models shows sequences of this design only
    let experiment =
        study::experiment::ExperimentDefinition::read(&repo_root().join("experiments/mono-media.toml")).unwrap();
    let design = study::design::Design::load(&design).unwrap();
    let ids = design.ids(study::design::Views::Mono);
    for id in experiment.all_stimuli() {
        assert!(ids.contains(&id), "{id} is not in stimuli/media.toml");
    }
}
