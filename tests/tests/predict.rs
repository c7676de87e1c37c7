//! `blurlab predict` and `blurlab run --simulate cvvdp` through the built binary, on a quick
//! set of the mono sampling test: the forecast's files and numbers, the cache that lets a
//! prediction resume, and bad input.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;

use blurlab_e2e::{render_quick_set, repo_root, run, shipped_design, stderr};

fn text(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn predict(set: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let experiment = text(&repo_root().join("experiments/mono-2-sampling-2afc.toml"));
    let (set, out) = (text(set), text(out));
    let args = ["predict", &experiment, "--stimuli", &set, "--device", "cpu", "--out", &out];
    run(&[&args[..], extra].concat())
}

#[test]
fn a_forecast_ranks_noise_resumes_from_its_cache_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    render_quick_set(&shipped_design(), "M3 S2 T3 *", &set);
    let table = text(&repo_root().join("analysis/reference/thesis-5.6.3-mono-sampling-2afc.csv"));

    // The `eye` reference: four sub-frames per frame, so its stamping and resuming are tested
    // on the reference with the most frames.
    let eye = ["--reference", "eye", "--votes", table.as_str()];
    let out = dir.path().join("eye");
    let o = predict(&set, &out, &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["predict.md", "predict.json", "votes.csv", "matrix.csv", "groups.png", "predicted-vs-published.svg"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("predict.json")).unwrap()).unwrap();
    let rows = json["stimuli"].as_array().unwrap();
    assert_eq!(rows.len(), 5);
    let score = |label: &str| rows.iter().find(|r| r["label"] == label).unwrap()["score"].as_f64().unwrap();
    // 1 sample per pixel is far noisier than 16 against any converged reference.
    assert!(score("A1") < score("A5") - 0.5, "A1 {} A5 {}", score("A1"), score("A5"));
    assert!(rows.iter().all(|r| r["score"].as_f64().unwrap() <= 10.0 + 1e-6));
    // Each row names the rendering it judged: the manifest hash the set's index records.
    let index: serde_json::Value = serde_json::from_slice(&std::fs::read(set.join("index.json")).unwrap()).unwrap();
    for row in rows {
        let entry = index["sequences"].as_array().unwrap().iter().find(|e| e["id"] == row["id"]).unwrap();
        assert_eq!(row["manifest_sha256"], entry["manifest_sha256"], "{}", row["id"]);
        assert_eq!(row["manifest_sha256"].as_str().unwrap().len(), 64);
    }
    // The table's 20 judges: the expected votes total 20 judgements of each of 10 pairs.
    let total: f64 = rows.iter().map(|r| r["votes"].as_f64().unwrap()).sum();
    assert!((total - 200.0).abs() < 1e-6, "{total}");
    assert_eq!(json["judges"], 20);
    let a = &json["agreement"];
    assert!(a["spearman"].as_f64().unwrap().abs() <= 1.0 && a["adjusted_rand"].is_number(), "{a}");

    // The scores are cached in the set: a second run renders and judges nothing again and
    // writes the same forecast; a cache with one score removed recomputes it bit for bit.
    let cache = std::fs::read_dir(set.join("observer"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("scores-"))
        .unwrap();
    let reference_frame = std::fs::read_dir(set.join("observer/reference"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path()
        .join("M3-S2/frame-0000-00.png");
    let before = std::fs::metadata(&reference_frame).unwrap().modified().unwrap();
    let mut scores: serde_json::Value = serde_json::from_slice(&std::fs::read(&cache).unwrap()).unwrap();
    let kept = scores["scores"]["M3-S2-T3-A2"].clone();
    scores["scores"].as_object_mut().unwrap().remove("M3-S2-T3-A2");
    std::fs::write(&cache, serde_json::to_vec(&scores).unwrap()).unwrap();
    let again = dir.path().join("again");
    let o = predict(&set, &again, &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("votes.csv")).unwrap(), std::fs::read(again.join("votes.csv")).unwrap());
    let scores: serde_json::Value = serde_json::from_slice(&std::fs::read(&cache).unwrap()).unwrap();
    assert_eq!(scores["scores"]["M3-S2-T3-A2"], kept);
    assert_eq!(std::fs::metadata(&reference_frame).unwrap().modified().unwrap(), before);

    // The reference is stamped after its last frame with the design it was rendered from and
    // each frame's hash, and every row names it by the stamp's hash.
    let stamp_path = reference_frame.parent().unwrap().join("reference.json");
    let stamp_bytes = std::fs::read(&stamp_path).unwrap();
    let stamp: serde_json::Value = serde_json::from_slice(&stamp_bytes).unwrap();
    assert_eq!((&stamp["design_sha256"], &stamp["preset"]), (&index["design_sha256"], &index["preset"]));
    let stamped = stamp["frames"].as_array().unwrap();
    assert_eq!(stamped.len(), 8 * 4, "the `eye` reference: 8 frames of 4 sub-frames");
    for f in stamped {
        let bytes = std::fs::read(reference_frame.with_file_name(f["png"].as_str().unwrap())).unwrap();
        assert_eq!(f["png_sha256"], study::fsio::sha256_hex(&bytes), "{f}");
    }
    let stamp_sha = study::fsio::sha256_hex(&stamp_bytes);
    assert!(rows.iter().all(|r| r["reference_sha256"] == stamp_sha.as_str()), "{rows:?}");
    // A frame that no longer hashes as stamped is rendered again when a score needs it (the
    // same bytes: its seeds are recorded), and the forecast stays the same.
    let frame_bytes = std::fs::read(&reference_frame).unwrap();
    std::fs::write(&reference_frame, b"not the frame").unwrap();
    let mut scores: serde_json::Value = serde_json::from_slice(&std::fs::read(&cache).unwrap()).unwrap();
    scores["scores"].as_object_mut().unwrap().remove("M3-S2-T3-A3");
    std::fs::write(&cache, serde_json::to_vec(&scores).unwrap()).unwrap();
    let mended = dir.path().join("mended");
    let o = predict(&set, &mended, &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("frame-0000-00.png: does not hash as its reference's stamp records"), "{}", stderr(&o));
    assert!(std::fs::read(&reference_frame).unwrap() == frame_bytes);
    assert!(std::fs::read(&stamp_path).unwrap() == stamp_bytes);
    assert_eq!(std::fs::read(out.join("votes.csv")).unwrap(), std::fs::read(mended.join("votes.csv")).unwrap());
    let mended_at = std::fs::metadata(&reference_frame).unwrap().modified().unwrap();
    // A reference stamped for another version of the design is rendered again whole, and
    // every score judged against it is judged again.
    let mut other = stamp.clone();
    // (Not even a hash: a message quoting it must not split a character.)
    other["design_sha256"] = serde_json::Value::from(format!("x{}", "é".repeat(40)));
    std::fs::write(&stamp_path, serde_json::to_vec_pretty(&other).unwrap()).unwrap();
    let o = predict(&set, &dir.path().join("redone"), &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("rendering the reference again"), "{}", stderr(&o));
    assert!(std::fs::metadata(&reference_frame).unwrap().modified().unwrap() > mended_at);
    assert!(std::fs::read(&stamp_path).unwrap() == stamp_bytes);
    assert_eq!(
        std::fs::read(out.join("votes.csv")).unwrap(),
        std::fs::read(dir.path().join("redone/votes.csv")).unwrap()
    );
    // Frames without a stamp (rendered before references were stamped, when their seeds
    // depended on which sequence asked first) are rendered again: here to the same bytes.
    std::fs::remove_file(&stamp_path).unwrap();
    let o = predict(&set, &dir.path().join("restamped"), &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("frames without a stamp"), "{}", stderr(&o));
    assert!(
        std::fs::read(&stamp_path).unwrap() == stamp_bytes && std::fs::read(&reference_frame).unwrap() == frame_bytes
    );
    std::fs::write(&stamp_path, b"{ not a stamp").unwrap();
    let o = predict(&set, &dir.path().join("bad"), &["--reference", "eye"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("reference.json: not a reference stamp"), "{}", stderr(&o));
    std::fs::write(&stamp_path, &stamp_bytes).unwrap();

    // The other references and the FLIP baseline run on the same set, each reference in its
    // own folder (`sharp`: four instants per frame, as many frames as `eye`).
    // Without `--reference` the observer is the one the protocol froze: `shutter`.
    for (reference, args) in [("shutter", &[][..]), ("sharp", &["--reference", "sharp"][..])] {
        let o = predict(&set, &dir.path().join(reference), args);
        assert!(o.status.success(), "{reference}: {}", stderr(&o));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join(reference).join("predict.json")).unwrap()).unwrap();
        assert_eq!(json["settings"]["reference"], reference);
    }
    let folders: Vec<String> = std::fs::read_dir(set.join("observer/reference"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(folders.len(), 3, "{folders:?}");
    let sharp = folders.iter().find(|f| f.starts_with("sharp-")).unwrap();
    let frames = std::fs::read_dir(set.join("observer/reference").join(sharp).join("M3-S2"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "png"))
        .count();
    assert_eq!(frames, 8 * 4, "{sharp}");
    let o = predict(&set, &dir.path().join("flip"), &["--observer", "flip", "--votes", &table]);
    assert!(o.status.success(), "{}", stderr(&o));

    // Eye movements: half fixating, half pursuing, on the `sharp` reference rendered above;
    // each stimulus keeps both qualities, and its score is their mean. FLIP has none.
    let both = dir.path().join("both");
    let o = predict(&set, &both, &["--reference", "sharp", "--eye-movement", "both"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(both.join("predict.json")).unwrap()).unwrap();
    assert_eq!(json["eye_movement"], "both");
    for r in json["stimuli"].as_array().unwrap() {
        let q: Vec<f64> = r["by_eye_movement"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert_eq!(q.len(), 2, "{r}");
        assert!((r["score"].as_f64().unwrap() - 0.5 * (q[0] + q[1])).abs() < 1e-9, "{r}");
        assert_ne!(q[0], q[1], "{r}");
    }
    let o = predict(&set, &dir.path().join("flip-pursuit"), &["--observer", "flip", "--eye-movement", "pursuit"]);
    assert!(!o.status.success() && stderr(&o).contains("--eye-movement pursuit"), "{}", stderr(&o));

    // Each pair judged against itself by a pursuing eye: the `sharp` quality names the better
    // of the two, the worse one's JOD against it sets the probability; every pair is judged
    // once and cached, so a second forecast judges nothing and writes the same votes.
    let pair_args = ["--reference", "sharp", "--eye-movement", "pursuit", "--judging", "pair"];
    let pair = dir.path().join("pair");
    let o = predict(&set, &pair, &pair_args);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(pair.join("predict.json")).unwrap()).unwrap();
    assert_eq!(json["judging"], "pair");
    let d: Vec<Vec<f64>> = json["pair_jod"][0]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| row.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect())
        .collect();
    let q: Vec<f64> = json["stimuli"].as_array().unwrap().iter().map(|r| r["score"].as_f64().unwrap()).collect();
    let p: Vec<Vec<f64>> = json["probability"]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| row.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect())
        .collect();
    assert_eq!((d.len(), q.len()), (5, 5));
    for i in 0..5 {
        assert_eq!(d[i][i], 0.0);
        for j in 0..5 {
            if i == j {
                continue;
            }
            assert!(d[i][j] >= 0.0 && d[i][j] == d[j][i], "{i} {j}: {}", d[i][j]);
            let better = study::stats::jod_preference(d[i][j], 0.0);
            let expected = if q[i] > q[j] { better } else { 1.0 - better };
            assert!((p[i][j] - expected).abs() < 1e-12, "{i} over {j}: {} against {expected}", p[i][j]);
        }
    }
    // A1 (1 sample per pixel) and A5 (16) are far apart judged side by side.
    let (a1, a5) = (0, 4);
    assert!(d[a1][a5] > 0.5 && p[a5][a1] > 0.6, "A1-A5: {} JOD, P {}", d[a1][a5], p[a5][a1]);
    let pairs_cache = std::fs::read_dir(set.join("observer"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("pairs-"))
        .unwrap();
    let cached: serde_json::Value = serde_json::from_slice(&std::fs::read(&pairs_cache).unwrap()).unwrap();
    assert_eq!(cached["scores"].as_object().unwrap().len(), 10);
    let stamp = std::fs::metadata(&pairs_cache).unwrap().modified().unwrap();
    let o = predict(&set, &dir.path().join("pair-again"), &pair_args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(pair.join("votes.csv")).unwrap(),
        std::fs::read(dir.path().join("pair-again/votes.csv")).unwrap()
    );
    assert_eq!(std::fs::metadata(&pairs_cache).unwrap().modified().unwrap(), stamp);
    let o = predict(&set, &dir.path().join("flip-pair"), &["--observer", "flip", "--judging", "pair"]);
    assert!(!o.status.success() && stderr(&o).contains("--judging pair"), "{}", stderr(&o));

    // A set with only the counted trials' sequences (the practice pair's M2-S2-T1-A1 absent)
    // is enough for a forecast by either observer.
    let interactions = dir.path().join("interactions");
    render_quick_set(&shipped_design(), "M2 S2 T3-T5 A3-A5", &interactions);
    let experiment = text(&repo_root().join("experiments/mono-3-interactions.toml"));
    for observer in ["flip", "cvvdp"] {
        let out = text(&dir.path().join(format!("interactions-{observer}")));
        let args = ["predict", &experiment, "--stimuli", &text(&interactions), "--observer", observer, "--out", &out];
        let o = run(&[&args[..], &["--device", "cpu"]].concat());
        assert!(o.status.success(), "{observer}: {}", stderr(&o));
    }

    // A simulated session with the same model (the runner also shows the briefing's examples).
    // Rendering them into the set changes its content hash but none of the judged sequences:
    // each cached score keeps its sequence's manifest, so nothing is judged again.
    let stamp = std::fs::metadata(&cache).unwrap().modified().unwrap();
    render_quick_set(&shipped_design(), "M2 S3 T1,T5 A5", &set);
    let grown = dir.path().join("grown");
    let o = predict(&set, &grown, &eye);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("votes.csv")).unwrap(), std::fs::read(grown.join("votes.csv")).unwrap());
    assert_eq!(std::fs::metadata(&cache).unwrap().modified().unwrap(), stamp);
    let experiment = text(&repo_root().join("experiments/mono-2-sampling-2afc.toml"));
    let results = text(&dir.path().join("results"));
    let o = run(&[
        "run",
        &experiment,
        "--stimuli",
        &text(&set),
        "--participant",
        "C1",
        "--results",
        &results,
        "--simulate",
        "cvvdp",
        "--seed",
        "4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The loop a study closes: the measured votes, as `analyze` writes them, are the table a
    // forecast is compared with.
    let report = dir.path().join("report");
    let args = ["analyze", &results, "--manifest", &text(&set), "--out", &text(&report), "--bootstrap", "0"];
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let measured = report.join("mono-2-sampling-2afc-votes.csv");
    let table_text = std::fs::read_to_string(&measured).unwrap();
    assert!(table_text.starts_with("# blurlab-votes/1\n") && table_text.contains("# judges: 2\n"), "{table_text}");
    let compared = dir.path().join("compared");
    let o = predict(&set, &compared, &["--votes", &text(&measured)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(compared.join("predict.json")).unwrap()).unwrap();
    assert_eq!(json["judges"], 2);
    let published: u64 = json["stimuli"].as_array().unwrap().iter().map(|r| r["published"].as_u64().unwrap()).sum();
    assert_eq!(published, 2 * 10, "two passes over the ten pairs");
    assert!(json["agreement"]["spearman"].is_number(), "{}", json["agreement"]);

    // Bad input, each named.
    let bad = |extra: &[&str], needle: &str| {
        let o = predict(&set, &dir.path().join("bad"), extra);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(needle), "expected `{needle}` in: {}", stderr(&o));
    };
    bad(&["--clip", "0..9"], "frames 0..8");
    let shutter_table = text(&repo_root().join("analysis/reference/thesis-6.5.2-stereo-shutter.csv"));
    bad(&["--votes", &shutter_table], "stimulus `T1` is not one of the experiment's");
    // A matching experiment is answered by `run --simulate cvvdp`, not forecast as votes.
    let matching = text(&repo_root().join("experiments/mono-2-sampling-matching.toml"));
    let args =
        ["predict", &matching, "--stimuli", &text(&set), "--device", "cpu", "--out", &text(&dir.path().join("bad"))];
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("mono-2-sampling-matching.toml: a match experiment; `predict` forecasts 2AFC"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("bad").join("predict.md").exists());
    let sparse = dir.path().join("sparse");
    render_quick_set(&shipped_design(), "M3 S2 T3 A1,A2", &sparse);
    let o = predict(&sparse, &dir.path().join("bad"), &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("M3-S2-T3-A5"), "{}", stderr(&o));
}
