//! `blurlab stimuli` and `blurlab render-frame` through the built binary: listing, scene
//! description, rendering a small set, determinism, resume after a kill, and bad input.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use blurlab_e2e::{blurlab, repo_root, run, shipped_design, stderr, stdout};
use study::design::Design;
use study::manifest::{SequenceManifest, SetIndex};
use study::scene::FrameScene;

fn design_arg() -> String {
    shipped_design().display().to_string()
}

/// Every file of a set folder (relative path) and its hash, except the timing-bearing
/// manifests and index, whose frame hashes are compared separately.
fn frame_hashes(set: &Path) -> BTreeMap<String, String> {
    let index = SetIndex::read(&set.join("index.json")).unwrap();
    let mut out = BTreeMap::new();
    for e in &index.sequences {
        let m = SequenceManifest::read(&set.join(&e.folder).join("manifest.json")).unwrap();
        for f in &m.frames {
            let bytes = std::fs::read(set.join(&e.folder).join(&f.png)).unwrap();
            assert_eq!(study::fsio::sha256_hex(&bytes), f.png_sha256);
            out.insert(format!("{}/{}", e.folder, f.png), f.png_sha256.clone());
            out.insert(format!("{}/seeds{}", e.folder, f.index), format!("{:?}", f.seeds));
        }
    }
    out
}

fn render_args<'a>(out: &'a str, only: &'a str, design: &'a str) -> Vec<&'a str> {
    vec![
        "stimuli",
        "render",
        "--design",
        design,
        "--preset",
        "quick",
        "--only",
        only,
        "--out",
        out,
        "--progress",
        "lines",
    ]
}

#[test]
fn list_prints_225_mono_and_225_stereo_ids() {
    let d = design_arg();
    let o = run(&["stimuli", "list", "--design", &d]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ids: Vec<String> = stdout(&o).lines().map(str::to_owned).collect();
    assert_eq!(ids.len(), 450);
    assert_eq!(ids.iter().filter(|i| i.ends_with("-stereo")).count(), 225);
    assert!(ids.contains(&"M2-S2-T3-A5".to_owned()) && ids.contains(&"M2-S2-T3-A5-stereo".to_owned()));
    let o = run(&["stimuli", "list", "--design", &d, "--views", "mono", "--only", "M2 S2 T3-T5 *"]);
    assert_eq!(stdout(&o).lines().collect::<Vec<_>>().len(), 15, "{}", stdout(&o));
}

#[test]
fn describe_json_prints_the_exact_frame_scene() {
    let d = design_arg();
    for (id, frame, preset) in [("M2-S2-T3-A5", "17", "full"), ("M3-S3-T5-A1-stereo", "5", "quick")] {
        let o = run(&["stimuli", "describe", "--design", &d, "--preset", preset, id, "--frame", frame, "--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let printed: FrameScene = serde_json::from_str(&stdout(&o)).unwrap();
        let design = Design::load(&shipped_design()).unwrap();
        let expected = design
            .frame_scene_with(&design.preset(preset).unwrap(), &id.parse().unwrap(), frame.parse().unwrap())
            .unwrap();
        // Shortest round-trip float formatting: equal text means bit-equal numbers.
        assert_eq!(stdout(&o).trim_end(), serde_json::to_string_pretty(&expected).unwrap());
        assert_eq!(printed.stimulus, expected.stimulus);
        assert_eq!(printed.views.len(), expected.views.len());
    }
    let o = run(&["stimuli", "describe", "--design", &d, "M2-S2-T3-A5", "--frame", "3"]);
    assert!(o.status.success() && stdout(&o).contains("sphere at shutter open"), "{}", stdout(&o));
    let o = run(&["stimuli", "describe", "--design", &d, "M2-S2-T3-A5", "--frame", "120"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).starts_with("error:") && stderr(&o).contains("frame 120"), "{}", stderr(&o));
}

#[test]
fn rendering_the_same_quick_sequences_twice_gives_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = design_arg();
    let only = "M2 S3 T5 A1,A2";
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for out in [&a, &b] {
        let o = run(&render_args(out.to_str().unwrap(), only, &d));
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let (ha, hb) = (frame_hashes(&a), frame_hashes(&b));
    assert_eq!(ha.len(), 4 * 8 * 2, "2 mono + 2 stereo sequences of 8 frames: {ha:?}");
    assert_eq!(ha, hb);
    // Manifests describe what was rendered.
    let m = SequenceManifest::read(&a.join("M2-S3-T5-A2-stereo/manifest.json")).unwrap();
    assert_eq!((m.width, m.height, m.samples_per_pixel, m.frames.len()), (320, 90, 4, 8));
    assert_eq!(m.factors.shutter.value, 1.0);
    assert_eq!(m.factors.speed.value, 15.0);
    assert!(m.frames.iter().all(|f| f.seeds.len() == 2 && f.wall_seconds > 0.0));
    let png = image_size(&a.join("M2-S3-T5-A2-stereo/frame-0000.png"));
    assert_eq!(png, (320, 90));
    // The frames differ between sampling levels (different noise).
    assert_ne!(ha["M2-S3-T5-A1/frame-0000.png"], ha["M2-S3-T5-A2/frame-0000.png"]);
}

fn image_size(png: &Path) -> (u32, u32) {
    let bytes = std::fs::read(png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

#[test]
fn resume_after_a_kill_gives_the_same_set_as_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = design_arg();
    let only = "M3 S2 T2,T5 A2,A3 mono";
    let whole = dir.path().join("whole");
    let o = run(&render_args(whole.to_str().unwrap(), only, &d));
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = frame_hashes(&whole);
    assert_eq!(expected.len(), 4 * 8 * 2);

    // Kill a real run at several moments: after some frames of the first sequence, and
    // after the first sequence completed.
    let killed = dir.path().join("killed");
    for wait_for in ["M3-S2-T2-A2/frame-0003.png", "M3-S2-T2-A3/frame-0001.png"] {
        let mut child = Command::new(blurlab())
            .args(render_args(killed.to_str().unwrap(), only, &d))
            .arg("--resume")
            .current_dir(repo_root())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while !killed.join(wait_for).exists() && start.elapsed() < Duration::from_secs(60) {
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let _ = child.kill();
        child.wait().unwrap();
        // Whatever the index lists at this moment is complete and verifies.
        if let Ok(index) = SetIndex::read(&killed.join("index.json")) {
            for e in &index.sequences {
                let m = SequenceManifest::read(&killed.join(&e.folder).join("manifest.json")).unwrap();
                assert_eq!(m.frames.len(), 8);
                for f in &m.frames {
                    let bytes = std::fs::read(killed.join(&e.folder).join(&f.png)).unwrap();
                    assert_eq!(study::fsio::sha256_hex(&bytes), f.png_sha256);
                }
            }
        }
    }
    let o = run(&[render_args(killed.to_str().unwrap(), only, &d), vec!["--resume"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("verified, skipped"), "the resumed run should skip what was done: {}", stderr(&o));
    assert_eq!(frame_hashes(&killed), expected);

    // A corrupted frame is detected and its sequence re-rendered.
    std::fs::write(killed.join("M3-S2-T5-A3/frame-0002.png"), b"damaged").unwrap();
    let o = run(&[render_args(killed.to_str().unwrap(), only, &d), vec!["--resume"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("M3-S2-T5-A3: rendered"), "{}", stderr(&o));
    assert!(stderr(&o).contains("3 verified and skipped"), "{}", stderr(&o));
    assert_eq!(frame_hashes(&killed), expected);
}

#[test]
fn render_frame_writes_png_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    let d = design_arg();
    let png = dir.path().join("f.png");
    let o = run(&[
        "render-frame",
        "--design",
        &d,
        "--preset",
        "quick",
        "M2-S2-T3-A1-stereo",
        "--frame",
        "2",
        "--method",
        "tracer",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image_size(&png), (320, 90));
    let exr = dir.path().join("f.exr");
    let o = run(&["render-frame", "--design", &d, "--preset", "quick", "M2-S2-T3-A1", "--out", exr.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&exr).unwrap();
    assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic number");
    let o = run(&["render-frame", "--design", &d, "M2-S2-T3-A1", "--out", dir.path().join("f.jpg").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains(".exr or .png"), "{}", stderr(&o));
    // Every method of the design model renders (the analytic rasterizer last to land); a
    // method it does not know is refused.
    let g = dir.path().join("g.png");
    let o = run(&[
        "render-frame",
        "--design",
        &d,
        "--preset",
        "quick",
        "M2-S2-T3-A1",
        "--method",
        "analytic",
        "--out",
        g.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image_size(&g), (160, 90));
    let f = dir.path().join("h.png");
    let o = run(&["render-frame", "--design", &d, "M2-S2-T3-A1", "--method", "raster", "--out", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("unknown rendering method `raster`"), "{}", stderr(&o));
    assert!(!f.exists(), "nothing is written for a refused method");
}

#[test]
fn env_writes_the_default_map_and_a_design_can_load_it() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("env/default.exr");
    let o = run(&["stimuli", "env", "--out", map.to_str().unwrap(), "--width", "64"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(shipped_design()).unwrap().replace(
        "environment = { kind = \"default\", width = 1024 }",
        "environment = { kind = \"file\", path = \"env/default.exr\" }",
    );
    let design = dir.path().join("d.toml");
    std::fs::write(&design, text).unwrap();
    let out = dir.path().join("set");
    let o = run(&render_args(out.to_str().unwrap(), "M1 S1 T1 A1 mono", design.to_str().unwrap()));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(SetIndex::read(&out.join("index.json")).unwrap().sequences.len(), 1);
}

/// A copy of the shipped design in a temporary folder, edited by `edit`.
fn edited_design(dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let text = edit(std::fs::read_to_string(shipped_design()).unwrap());
    let path = dir.join("design.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn line_of(path: &Path, needle: &str) -> usize {
    std::fs::read_to_string(path).unwrap().lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn bad_design_files_fail_with_file_line_key_and_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    for (edit, needle, key) in [
        (("frames = 120\n", "frames = 120\nfrme_rate = 30\n"), "frme_rate", "frme_rate"),
        (("fps = 30.0", "fps = \"fast\""), "\"fast\"", "sequence.fps"),
        (("octaves = 4", "octaves = -4"), "-4", "octaves"),
        (
            (
                "environment = { kind = \"default\", width = 1024 }",
                "environment = { kind = \"file\", path = \"maps/gone.hdr\" }",
            ),
            "gone.hdr",
            "lighting.environment.path",
        ),
    ] {
        let design = edited_design(dir.path(), |t| t.replace(edit.0, edit.1));
        let line = line_of(&design, needle);
        let o = run(&render_args(out.to_str().unwrap(), "M1 S1 T1 A1 mono", design.to_str().unwrap()));
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.starts_with("error: "), "{err}");
        assert!(err.contains(&format!("{}:{line}:", design.display())), "{needle}: {err}");
        assert!(err.contains(key), "{key}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let o = run(&render_args(out.to_str().unwrap(), "M1 S1 T1 A1 mono", "no/such/design.toml"));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no/such/design.toml"), "{}", stderr(&o));
    let o = run(&render_args(out.to_str().unwrap(), "M4", &design_arg()));
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("M4 does not exist"), "{}", stderr(&o));
}

#[test]
fn corrupt_environment_map_fails_with_its_name_and_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("env")).unwrap();
    std::fs::write(dir.path().join("env/broken.exr"), b"this is not an OpenEXR file at all").unwrap();
    let design = edited_design(dir.path(), |t| {
        t.replace(
            "environment = { kind = \"default\", width = 1024 }",
            "environment = { kind = \"file\", path = \"env/broken.exr\" }",
        )
    });
    let out = dir.path().join("set");
    let o = run(&render_args(out.to_str().unwrap(), "M1 S1 T1 A1 mono", design.to_str().unwrap()));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("broken.exr"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

#[test]
fn unwritable_output_folder_fails_with_exit_code_3() {
    // /sys refuses new folders even to root.
    if !Path::new("/sys/kernel").exists() {
        blurlab_e2e::skipped("unwritable_output_folder_fails_with_exit_code_3", "no /sys");
        return;
    }
    let o = run(&render_args("/sys/blurlab-e2e-set", "M1 S1 T1 A1 mono", &design_arg()));
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("/sys/blurlab-e2e-set") && stderr(&o).contains("cannot create"), "{}", stderr(&o));
}

#[test]
fn full_disk_fails_with_exit_code_3_and_keeps_finished_sequences() {
    // A tiny tmpfs needs root and mount rights; elsewhere the injected-writer test in
    // crates/render/src/set.rs covers the same path.
    let dir = tempfile::tempdir().unwrap();
    let mnt = dir.path().join("small");
    std::fs::create_dir(&mnt).unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=8m", "tmpfs", mnt.to_str().unwrap()])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        blurlab_e2e::skipped(
            "full_disk_fails_with_exit_code_3_and_keeps_finished_sequences",
            "cannot mount a tmpfs here (needs root and mount rights; the injected-writer test covers the path)",
        );
        return;
    }
    let out = mnt.join("set");
    let o = run(&render_args(out.to_str().unwrap(), "M3 S3 T5 A1 mono", &design_arg()));
    let first = o.status.success();
    // Leave room for little more than what is there: the next sequences cannot fit.
    let used = fs_used_bytes(&mnt);
    let _ = Command::new("mount")
        .args(["-o", &format!("remount,size={}", used + 64 * 1024), mnt.to_str().unwrap()])
        .status();
    let o2 = run(&[render_args(out.to_str().unwrap(), "M3 S3 T5 A1-A5", &design_arg()), vec!["--resume"]].concat());
    let index = SetIndex::read(&out.join("index.json"));
    let kept = frame_hashes_if_complete(&out);
    let _ = Command::new("umount").arg(&mnt).status();
    assert!(first, "the first sequence fits: {}", stderr(&o));
    assert_eq!(o2.status.code(), Some(3), "{}", stderr(&o2));
    assert!(stderr(&o2).contains("No space left"), "{}", stderr(&o2));
    let index = index.expect("the index survives a full disk");
    assert_eq!(index.sequences.iter().map(|e| e.folder.as_str()).collect::<Vec<_>>(), ["M3-S3-T5-A1"]);
    assert_eq!(kept, Some(8));
}

fn fs_used_bytes(path: &Path) -> u64 {
    let o = Command::new("df").args(["--output=used", "-B1"]).arg(path).output().unwrap();
    String::from_utf8_lossy(&o.stdout).lines().nth(1).and_then(|l| l.trim().parse().ok()).unwrap_or(0)
}

/// Number of verified frames listed by the set's index, if it reads.
fn frame_hashes_if_complete(set: &Path) -> Option<usize> {
    std::panic::catch_unwind(|| frame_hashes(set).keys().filter(|k| k.ends_with(".png")).count()).ok()
}
