//! Sharded rendering through the built binary: N shards as separate processes reproduce the
//! unsharded set byte for byte (separate folders merged, and one shared folder); merge names
//! missing, duplicated and damaged units; a killed shard completes with `--resume`; bad
//! shard specifications are clear errors that leave verified data alone.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use blurlab_e2e::{blurlab, repo_root, run, shipped_design, stderr, stdout};
use study::manifest::{SequenceManifest, SetIndex};

/// Selection of the tests: 12 sequences (mono and stereo, 1 to 16 samples per pixel).
const ONLY: &str = "M1,M3 S2 T4 A1,A3,A5 *";

/// The shipped design with a `tiny` preset (16x9, 6 frames) appended.
fn tiny_design(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(shipped_design()).unwrap();
    let path = dir.join("tiny.toml");
    std::fs::write(
        &path,
        format!("{text}\n[presets.tiny]\nwidth = 16\nheight = 9\nframes = 6\nfirst_frame = 10\nsamples_per_pixel = [1, 2, 4, 8, 16]\n"),
    )
    .unwrap();
    path
}

fn render_command(design: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(blurlab());
    c.args(["stimuli", "render", "--design", design.to_str().unwrap(), "--preset", "tiny", "--only", ONLY])
        .args(["--out", out.to_str().unwrap(), "--device", "cpu", "--progress", "lines"])
        .args(extra)
        .current_dir(repo_root());
    c
}

fn render(design: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    render_command(design, out, extra).output().unwrap()
}

fn spawn(design: &Path, out: &Path, extra: &[&str]) -> Child {
    render_command(design, out, extra).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap()
}

fn wait_ok(child: Child) {
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Every frame file of a set (by its relative path) with its bytes' hash, and each
/// manifest without its timings and device: what an unsharded and a sharded render share.
fn set_content(set: &Path) -> BTreeMap<String, String> {
    let index = SetIndex::read(&set.join("index.json")).unwrap();
    let mut out = BTreeMap::new();
    for e in &index.sequences {
        let mut m = SequenceManifest::read(&set.join(&e.folder).join("manifest.json")).unwrap();
        for f in &mut m.frames {
            let bytes = std::fs::read(set.join(&e.folder).join(&f.png)).unwrap();
            out.insert(format!("{}/{}", e.folder, f.png), study::fsio::sha256_hex(&bytes));
            (f.wall_seconds, f.cpu_seconds) = (0.0, 0.0);
        }
        m.device.clear();
        out.insert(format!("{}/manifest.json", e.folder), serde_json::to_string(&m).unwrap());
    }
    out
}

/// Hashes of every file under `dir` (relative paths), to show nothing changed.
fn tree_hashes(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap().flatten() {
            if entry.file_type().unwrap().is_dir() {
                stack.push(entry.path());
            } else {
                let bytes = std::fs::read(entry.path()).unwrap();
                out.insert(entry.path().strip_prefix(dir).unwrap().to_owned(), study::fsio::sha256_hex(&bytes));
            }
        }
    }
    out
}

fn merge(out: &Path, dirs: &[&Path]) -> std::process::Output {
    let mut args = vec!["stimuli", "merge", "--progress", "lines", out.to_str().unwrap()];
    args.extend(dirs.iter().map(|d| d.to_str().unwrap()));
    run(&args)
}

#[test]
fn shards_as_separate_processes_reproduce_the_unsharded_set_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let whole = dir.path().join("whole");
    let o = render(&design, &whole, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = set_content(&whole);
    assert_eq!(expected.keys().filter(|k| k.ends_with("manifest.json")).count(), 12);

    // The plan: every shard has work, and the printout names each one.
    let o = render(&design, &dir.path().join("unused"), &["--shard", "0/4", "--plan"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for k in 0..4 {
        assert!(stdout(&o).contains(&format!("shard {k}/4: ")), "{}", stdout(&o));
    }
    assert!(!dir.path().join("unused").exists(), "--plan renders nothing");

    // Four processes, each into its own folder, at once; then merged.
    let folders: Vec<PathBuf> = (0..4).map(|k| dir.path().join(format!("shard-{k}"))).collect();
    let children: Vec<Child> =
        folders.iter().enumerate().map(|(k, f)| spawn(&design, f, &["--shard", &format!("{k}/4")])).collect();
    children.into_iter().for_each(wait_ok);
    let merged = dir.path().join("merged");
    let refs: Vec<&Path> = folders.iter().map(PathBuf::as_path).collect();
    let o = merge(&merged, &refs);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("12 sequences in the set"), "{}", stderr(&o));
    assert_eq!(set_content(&merged), expected);

    // Three processes into one shared folder complete it themselves; merge checks it in place.
    let shared = dir.path().join("shared");
    let children: Vec<Child> = (0..3).map(|k| spawn(&design, &shared, &["--shard", &format!("{k}/3")])).collect();
    children.into_iter().for_each(wait_ok);
    assert_eq!(set_content(&shared), expected);
    let before = tree_hashes(&shared);
    let o = merge(&shared, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(tree_hashes(&shared), before, "checking a complete shared folder changes nothing");
}

#[test]
fn the_eyes_of_a_stereo_sequence_rendered_by_different_shards_join_to_the_unsharded_png_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let stereo = |out: &Path, extra: &[&str]| {
        Command::new(blurlab())
            .args(["stimuli", "render", "--design", design.to_str().unwrap(), "--preset", "tiny", "--exr"])
            .args(["--only", "M3 S2 T4 A5 stereo", "--device", "cpu", "--progress", "lines"])
            .args(["--out", out.to_str().unwrap()])
            .args(extra)
            .current_dir(repo_root())
            .output()
            .unwrap()
    };
    let whole = dir.path().join("whole");
    let o = stereo(&whole, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Two shards, one sequence: each renders one eye of every frame (the eyes cost the same).
    let o = stereo(&dir.path().join("unused"), &["--shard", "0/2", "--plan"]);
    let plan = stdout(&o);
    assert!(plan.contains("left eye frames") && plan.contains("right eye frames"), "{plan}");
    let folders: Vec<PathBuf> = (0..2).map(|k| dir.path().join(format!("shard-{k}"))).collect();
    for (k, f) in folders.iter().enumerate() {
        let o = stereo(f, &["--shard", &format!("{k}/2")]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let merged = dir.path().join("merged");
    let mut args = vec!["stimuli", "merge", "--progress", "lines", merged.to_str().unwrap()];
    args.extend(folders.iter().map(|f| f.to_str().unwrap()));
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = |set: &Path| {
        let seq = set.join("M3-S2-T4-A5-stereo");
        let mut names: Vec<String> = std::fs::read_dir(&seq)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("frame-"))
            .collect();
        names.sort();
        names.into_iter().map(|n| (std::fs::read(seq.join(&n)).unwrap(), n)).collect::<Vec<_>>()
    };
    let (a, b) = (frames(&whole), frames(&merged));
    assert_eq!(a.len(), 12, "6 PNG and 6 EXR frames");
    assert!(a == b, "the joined frames are the unsharded bytes");
}

#[test]
fn merge_names_missing_duplicated_and_damaged_units_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let folders: Vec<PathBuf> = (0..3).map(|k| dir.path().join(format!("shard-{k}"))).collect();
    for (k, f) in folders.iter().enumerate() {
        let o = render(&design, f, &["--shard", &format!("{k}/3")]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let out = dir.path().join("merged");
    // Shard 1 left out: its units are missing, each named with its frames and shard.
    let o = merge(&out, &[&folders[0], &folders[2]]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let plan = stdout(&render(&design, &out, &["--shard", "1/3", "--plan"]));
    let shard1_units =
        plan.lines().skip_while(|l| !l.starts_with("shard 1/3")).skip(1).take_while(|l| l.starts_with("  "));
    let mut n = 0;
    for line in shard1_units {
        // "  M1-S2-T4-A5 frames 0-2  cost 123" -> "missing: M1-S2-T4-A5 frames 0-2 (shard 1/3)"
        let unit = line.trim().split("  cost").next().unwrap();
        assert!(stderr(&o).contains(&format!("missing: {unit} (shard 1/3)")), "{unit}: {}", stderr(&o));
        n += 1;
    }
    assert!(n > 0, "{plan}");
    assert_eq!(stderr(&o).matches("missing: ").count(), n, "{}", stderr(&o));
    assert!(stderr(&o).contains("nothing was written") && !out.exists(), "{}", stderr(&o));

    // Shard 2 given twice (a copy of its folder): its units are duplicated.
    let copy = dir.path().join("shard-2-copy");
    let status = Command::new("cp").arg("-r").arg(&folders[2]).arg(&copy).status().unwrap();
    assert!(status.success());
    let o = merge(&out, &[&folders[0], &folders[1], &folders[2], &copy]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("duplicated: ") && stderr(&o).contains("(shard 2/3) in "), "{}", stderr(&o));
    assert!(!stderr(&o).contains("missing: ") && !out.exists(), "{}", stderr(&o));

    // A damaged frame is named with its file.
    let victim = std::fs::read_dir(&folders[0])
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.join("units").is_dir() && std::fs::read_dir(p.join("units")).unwrap().next().is_some())
        .unwrap();
    let record = std::fs::read_dir(victim.join("units")).unwrap().flatten().next().unwrap().path();
    let record: serde_json::Value = serde_json::from_slice(&std::fs::read(&record).unwrap()).unwrap();
    // A frame of the sequence, or of one eye (`eyes/left/frame-0003.png`) for an eye unit.
    let png = record["sequence"]["frames"][0]["png"].as_str().unwrap().to_owned();
    std::fs::write(victim.join(&png), b"damaged").unwrap();
    let o = merge(&out, &[&folders[0], &folders[1], &folders[2]]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("damaged: ") && stderr(&o).contains(&png), "{}", stderr(&o));

    // Shards of another shard count or preset are refused by name.
    let other = dir.path().join("other-n");
    assert!(render(&design, &other, &["--shard", "0/2"]).status.success());
    let o = merge(&out, &[&folders[1], &other]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("shard count N (3, 2)"), "{}", stderr(&o));
    let quick = dir.path().join("quick");
    let o = Command::new(blurlab())
        .args([
            "stimuli",
            "render",
            "--design",
            design.to_str().unwrap(),
            "--preset",
            "quick",
            "--only",
            "M1 S1 T1 A1 mono",
        ])
        .args(["--out", quick.to_str().unwrap(), "--device", "cpu", "--shard", "0/3"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = merge(&out, &[&folders[1], &quick]);
    assert!(stderr(&o).contains("preset (`tiny`, `quick`)"), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn a_killed_shard_completes_with_resume() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let whole = dir.path().join("whole");
    assert!(render(&design, &whole, &[]).status.success());
    let folders: Vec<PathBuf> = (0..2).map(|k| dir.path().join(format!("shard-{k}"))).collect();
    assert!(render(&design, &folders[1], &["--shard", "1/2"]).status.success());
    // Shard 0 is killed once its first unit is recorded.
    let mut child = spawn(&design, &folders[0], &["--shard", "0/2"]);
    let start = Instant::now();
    let recorded = |f: &Path| {
        std::fs::read_dir(f).into_iter().flatten().flatten().any(|e| {
            std::fs::read_dir(e.path().join("units"))
                .into_iter()
                .flatten()
                .flatten()
                .any(|u| u.file_name().to_string_lossy().ends_with(".json"))
        })
    };
    while !recorded(&folders[0]) && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let _ = child.kill();
    let killed = child.wait_with_output().unwrap();
    let finished = killed.status.success();
    let o = merge(&dir.path().join("early"), &[&folders[0], &folders[1]]);
    if !finished {
        assert!(stderr(&o).contains("(shard 0/2)"), "the killed shard's units are missing: {}", stderr(&o));
    }
    let o = render(&design, &folders[0], &["--shard", "0/2", "--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("verified, skipped"), "{}", stderr(&o));
    let merged = dir.path().join("merged");
    let o = merge(&merged, &[&folders[0], &folders[1]]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(set_content(&merged), set_content(&whole));
}

#[test]
fn bad_shard_specifications_are_clear_errors_and_leave_verified_data_alone() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let out = dir.path().join("set");
    for (spec, says) in [
        ("4/4", "K = 4 is not below N = 4"),
        ("0/0", "N = 0"),
        ("1", "expected K/N"),
        ("x/3", "K `x` is not a whole number"),
    ] {
        let o = render(&design, &out, &["--shard", spec]);
        assert_eq!(o.status.code(), Some(2), "{spec}: {}", stderr(&o));
        assert!(stderr(&o).contains(&format!("--shard `{spec}`")) && stderr(&o).contains(says), "{}", stderr(&o));
        assert!(!out.exists(), "{spec}: nothing written");
    }
    // A shared folder of 2 shards refuses a shard of 3, and keeps every file as it was.
    for k in 0..2 {
        assert!(render(&design, &out, &["--shard", &format!("{k}/2")]).status.success());
    }
    let before = tree_hashes(&out);
    let o = render(&design, &out, &["--shard", "2/3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("plan.json") && stderr(&o).contains("shard count N (2, 3)"), "{}", stderr(&o));
    // Another selection into the same folder is refused as well.
    let o = render_command(&design, &out, &["--shard", "0/2", "--views", "mono"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("selected sequences (12, 6 sequences)"), "{}", stderr(&o));
    assert_eq!(tree_hashes(&out), before);
    let o = merge(&out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // --plan needs --shard.
    let o = render(&design, &out, &["--plan"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--shard"), "{}", stderr(&o));
}
