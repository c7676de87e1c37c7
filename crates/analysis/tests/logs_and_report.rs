//! End-to-end tests of the analysis over synthetic response logs written with
//! `study::response::ResponseLog`: statistics, report folder, figures, cost-aware
//! equivalence, and bad input (errors naming file and line).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use analysis::experiment::{AnalysisOptions, JudgeUnit};
use analysis::report::{build_report, write_report};
use analysis::scaling::ScaleOptions;
use analysis::votes::{VoteTable, analyze_votes, groups_as_sets};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use study::StimulusId;
use study::manifest::{Factors, FrameRecord, IndexEntry, LevelInfo, SequenceManifest, SetIndex};
use study::response::{REQUIRED_KEYS, ResponseLog, SessionHeader, Task, TrialRow};

fn id(s: &str) -> StimulusId {
    s.parse().unwrap()
}

fn header(experiment: &str, participant: &str, session: u32, attributes: &str) -> SessionHeader {
    let mut h = SessionHeader::default();
    for k in REQUIRED_KEYS {
        h.set(k, "x");
    }
    h.set("experiment", experiment);
    h.set("experiment_sha256", format!("sha-{experiment}"));
    h.set("participant", participant);
    h.set("session", session.to_string());
    h.set("attributes", attributes);
    h
}

fn row(trial: u32, task: Task, shown: Vec<StimulusId>, choice: StimulusId, correct: Option<bool>) -> TrialRow {
    TrialRow {
        trial,
        practice: false,
        task,
        shown,
        choice,
        correct,
        response_ms: 900,
        replays: 0,
        dropped_frames: 0,
        timestamp: "2026-11-23T12:00:00.000Z".into(),
        scale: None,
        visual_angle_deg: None,
    }
}

/// A simulated observer preferring stimuli with higher `quality`, with uniform noise.
#[allow(clippy::too_many_arguments)]
fn write_2afc_session(
    path: &Path,
    experiment: &str,
    participant: &str,
    session: u32,
    attributes: &str,
    stimuli: &[StimulusId],
    quality: &dyn Fn(&StimulusId) -> f64,
    repeats: u32,
    rng: &mut Pcg64,
) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut log = ResponseLog::create(path, &header(experiment, participant, session, attributes)).unwrap();
    let mut trial = 0;
    for _ in 0..repeats {
        for i in 0..stimuli.len() {
            for j in i + 1..stimuli.len() {
                let (a, b) = if rng.random::<bool>() { (stimuli[i], stimuli[j]) } else { (stimuli[j], stimuli[i]) };
                let noise: f64 = (rng.random::<f64>() - 0.5) * 2.0;
                let choice = if quality(&a) - quality(&b) + noise > 0.0 { a } else { b };
                log.append(&row(trial, Task::TwoAfc, vec![a, b], choice, None)).unwrap();
                trial += 1;
            }
        }
    }
    log.mark_completed("2026-11-23T12:10:00.000Z").unwrap();
}

fn interaction_stimuli(view: &str) -> Vec<StimulusId> {
    let mut v = Vec::new();
    for t in 3..=5 {
        for a in 3..=5 {
            v.push(id(&format!("M2-S2-T{t}-A{a}{view}")));
        }
    }
    v
}

fn shutter_quality(s: &StimulusId) -> f64 {
    // T3 best, T5 worst; sampling matters little.
    -1.2 * f64::from(s.shutter) + 0.1 * f64::from(s.samples)
}

/// A fake rendered set: index.json and one manifest per stimulus, cost proportional to samples.
fn write_set(dir: &Path, stimuli: &[StimulusId]) {
    let level = |label: String, value: f64| LevelInfo { name: label.clone(), label, value };
    let mut entries = Vec::new();
    for s in stimuli {
        let folder = s.to_string();
        std::fs::create_dir_all(dir.join(&folder)).unwrap();
        let spp = [4, 128, 256, 384, 512][usize::from(s.samples) - 1];
        let manifest = SequenceManifest {
            format: study::manifest::SEQUENCE_FORMAT.into(),
            id: *s,
            view: s.view,
            factors: Factors {
                material: level(s.level_label(study::Factor::Material), f64::from(s.material)),
                speed: level(s.level_label(study::Factor::Speed), 10.0),
                shutter: level(s.level_label(study::Factor::Shutter), 0.25 * f64::from(s.shutter - 1)),
                samples: level(s.level_label(study::Factor::Samples), f64::from(spp)),
                method: None,
            },
            method: study::Method::Tracer,
            preset: "quick".into(),
            width: 64,
            height: 36,
            fps: 30.0,
            samples_per_pixel: spp,
            master_seed: 1,
            device: "test".into(),
            gpu: None,
            sampling: study::manifest::Sampling::Independent,
            software_version: "0".into(),
            design_sha256: "d".into(),
            frames: (0..2)
                .map(|i| FrameRecord {
                    index: i,
                    png: format!("frame-{i:04}.png"),
                    png_sha256: "p".into(),
                    exr: None,
                    exr_sha256: None,
                    wall_seconds: f64::from(spp) / 100.0,
                    cpu_seconds: f64::from(spp) / 50.0,
                    nonfinite_samples: 0,
                    seeds: vec![1],
                    gpu_seconds: None,
                })
                .collect(),
        };
        let text = serde_json::to_string_pretty(&manifest).unwrap();
        std::fs::write(dir.join(&folder).join("manifest.json"), &text).unwrap();
        entries.push(IndexEntry { id: *s, folder, manifest_sha256: study::fsio::sha256_hex(text.as_bytes()) });
    }
    let index = SetIndex {
        format: study::manifest::INDEX_FORMAT.into(),
        design: "test".into(),
        design_sha256: "d".into(),
        preset: "quick".into(),
        sampling: study::manifest::Sampling::Independent,
        sequences: entries,
    };
    std::fs::write(dir.join("index.json"), serde_json::to_string_pretty(&index).unwrap()).unwrap();
}

fn options() -> AnalysisOptions {
    AnalysisOptions {
        alpha: 0.01,
        judge_unit: JudgeUnit::Replicate,
        scale: ScaleOptions { resamples: 200, seed: 3, ..Default::default() },
    }
}

fn results_with_mono_and_stereo(root: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let mut rng = Pcg64::seed_from_u64(11);
    let mono = root.join("results/mono-3-interactions");
    let stereo = root.join("results/stereo-3-interactions");
    let (sm, ss) = (interaction_stimuli(""), interaction_stimuli("-stereo"));
    for p in 0..8 {
        let code = format!("P{p:02}");
        let attrs = if p % 2 == 0 { r#"{"cg_experience":"yes"}"# } else { r#"{"cg_experience":"no"}"# };
        write_2afc_session(
            &mono.join(&code).join("session-1.csv"),
            "mono-3-interactions",
            &code,
            1,
            attrs,
            &sm,
            &shutter_quality,
            1,
            &mut rng,
        );
        write_2afc_session(
            &stereo.join(&code).join("session-1.csv"),
            "stereo-3-interactions",
            &code,
            1,
            attrs,
            &ss,
            &shutter_quality,
            1,
            &mut rng,
        );
    }
    let set = root.join("set");
    let all: Vec<StimulusId> = sm.iter().chain(&ss).copied().collect();
    write_set(&set, &all);
    stamp_set_hash(&[&mono, &stereo], &set);
    (mono, stereo, set)
}

/// Records the set's content hash in every log under `dirs`, as the runner does.
fn stamp_set_hash(dirs: &[&Path], set: &Path) {
    let hash = study::manifest::SetIndex::read(&set.join("index.json")).unwrap().content_sha256();
    for dir in dirs {
        for log in analysis::logs::find_logs(dir).unwrap() {
            let text = std::fs::read_to_string(&log).unwrap();
            let text = text.replace("# stimulus_set_sha256: x\n", &format!("# stimulus_set_sha256: {hash}\n"));
            std::fs::write(&log, text).unwrap();
        }
    }
}

#[test]
fn a_set_other_than_the_logs_or_with_an_altered_manifest_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (mono, _, set) = results_with_mono_and_stereo(dir.path());
    // Another set: one manifest's hash differs (another design's render of it).
    let other = dir.path().join("other");
    let ids: Vec<StimulusId> =
        study::manifest::SetIndex::read(&set.join("index.json")).unwrap().sequences.iter().map(|e| e.id).collect();
    write_set(&other, &ids);
    let manifest = other.join(ids[0].to_string()).join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap().replace("\"master_seed\": 1", "\"master_seed\": 2");
    std::fs::write(&manifest, &text).unwrap();
    let mut index = study::manifest::SetIndex::read(&other.join("index.json")).unwrap();
    index.sequences[0].manifest_sha256 = study::fsio::sha256_hex(text.as_bytes());
    std::fs::write(other.join("index.json"), serde_json::to_string_pretty(&index).unwrap()).unwrap();
    expect_error(
        std::slice::from_ref(&mono),
        Some(&other),
        &["other/index.json", "the logs of experiment `mono-3-interactions`", "were run with stimulus set"],
    );
    // A manifest altered after the index was written.
    let manifest = set.join(ids[1].to_string()).join("manifest.json");
    let text = std::fs::read_to_string(&manifest).unwrap().replace("\"fps\": 30.0", "\"fps\": 25.0");
    std::fs::write(&manifest, text).unwrap();
    expect_error(std::slice::from_ref(&mono), Some(&set), &[&format!("sequence {}: the manifest's sha256", ids[1])]);
}

#[test]
fn mono_and_stereo_interactions_give_a_full_report_with_costs_and_figures() {
    let dir = tempfile::tempdir().unwrap();
    let (mono, stereo, set) = results_with_mono_and_stereo(dir.path());
    let mut report = build_report(&[mono, stereo], Some(&set), None, options()).unwrap();
    assert_eq!(report.experiments.len(), 2);
    assert_eq!(report.mono_stereo_pairs, vec![("mono-3-interactions".to_owned(), "stereo-3-interactions".to_owned())]);
    let e = &report.experiments[0];
    let p = e.paired.as_ref().unwrap();
    assert_eq!(p.complete_judges, 8);
    assert_eq!(p.votes.iter().sum::<u32>(), 8 * 36);
    let c = p.critical.unwrap();
    assert_eq!(c.t, 9);
    // Observers prefer short shutters: the top group holds T3 stimuli only, the best is a T3.
    let top = &p.groups[0];
    assert!(top.members.iter().all(|m| m.id.shutter <= 4), "{top:?}");
    assert_eq!(top.members[0].id.shutter, 3);
    // Cost-aware equivalence: the cheapest member of the top group against its most expensive.
    let r = p.recommendation.as_ref().unwrap();
    assert!(r.cheapest_wall_seconds <= r.reference_wall_seconds);
    assert!((r.saving - (1.0 - r.cheapest_wall_seconds / r.reference_wall_seconds)).abs() < 1e-12);
    assert_eq!(top.saving_vs_top_most_expensive, Some(r.saving));
    // Agreement and consistency are present and in range.
    let a = p.agreement.as_ref().unwrap();
    assert!(a.u > a.u_min && a.u <= 1.0);
    assert!(p.judges.iter().all(|j| j.zeta.is_some_and(|z| (0.0..=1.0).contains(&z))));
    // Segments.
    assert!(p.factor_preferences.contains_key("cg_experience=yes") && p.factor_preferences.contains_key("all"));
    let shutter = p.factor_preferences["all"].iter().find(|q| q.level_a == "T3" && q.level_b == "T5").unwrap();
    assert!(shutter.p_a > 0.8 && shutter.p_value < 0.01, "{shutter:?}");

    // BLURLAB_KEEP_REPORT=DIR keeps a copy of the report for inspection.
    let out = std::env::var_os("BLURLAB_KEEP_REPORT").map_or_else(|| dir.path().join("report"), PathBuf::from);
    let md = write_report(&mut report, &out).unwrap();
    let text = std::fs::read_to_string(&md).unwrap();
    assert!(text.contains("ceil(R_c)") && text.contains("Recommendation") && text.contains("Kendall's u"));
    for stem in [
        "mono-3-interactions-votes",
        "mono-3-interactions-grid",
        "mono-3-interactions-scale",
        "3-interactions-mono-vs-stereo-votes",
        "3-interactions-mono-vs-stereo-preferences",
    ] {
        for ext in ["png", "svg"] {
            let f = out.join(format!("{stem}.{ext}"));
            assert!(std::fs::metadata(&f).map(|m| m.len() > 1000).unwrap_or(false), "{}", f.display());
        }
    }
    // Each experiment's vote totals as a vote table, which groups as the report did.
    assert_eq!(report.vote_tables, ["mono-3-interactions-votes.csv", "stereo-3-interactions-votes.csv"]);
    assert!(text.contains("[`mono-3-interactions-votes.csv`](mono-3-interactions-votes.csv)"));
    for e in &report.experiments {
        let p = e.paired.as_ref().unwrap();
        let table = VoteTable::read(&out.join(format!("{}-votes.csv", e.name))).unwrap();
        assert_eq!((&table.labels, &table.votes), (&e.labels, &p.votes));
        assert_eq!(table.get("experiment"), Some(e.name.as_str()));
        assert!(table.get("source").unwrap().contains(&e.experiment_sha256));
        let (judges, alpha) = (table.judges().unwrap().unwrap(), table.alpha().unwrap().unwrap());
        assert_eq!((judges, alpha), (p.complete_judges, options().alpha));
        let regrouped = analyze_votes(&table, judges, alpha).unwrap();
        let groups: Vec<Vec<String>> =
            p.groups.iter().map(|g| g.members.iter().map(|m| m.label.clone()).collect()).collect();
        assert_eq!(groups_as_sets(&regrouped.groups), groups_as_sets(&groups));
        assert_eq!(regrouped.critical.ceil_rc, p.critical.unwrap().ceil_rc);
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["format"], "blurlab-report/1");
    assert_eq!(json["vote_tables"][1], "stereo-3-interactions-votes.csv");
    assert_eq!(json["experiments"][0]["paired"]["critical"]["ceil_rc"], c.ceil_rc);
    assert_eq!(json["experiments"][0]["paired"]["scale"]["options"]["seed"], 3);
}

/// Writes a 2AFC log whose header's `display` records the calibrated scale 4 (14.5 degrees)
/// and whose rows record `scales[k]` (practice for the first row).
fn write_scaled_session(path: &Path, participant: &str, display: &str, scales: &[Option<f64>]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut h = header("scaled", participant, 1, "{}");
    h.set("display", display);
    let mut log = ResponseLog::create(path, &h).unwrap();
    let stimuli: Vec<StimulusId> = (1..=3).map(|a| id(&format!("M3-S2-T3-A{a}"))).collect();
    for (k, scale) in scales.iter().enumerate() {
        let (a, b) = (stimuli[k % 3], stimuli[(k + 1) % 3]);
        let mut r = row(k as u32, Task::TwoAfc, vec![a, b], a, None);
        r.practice = k == 0;
        r.scale = *scale;
        r.visual_angle_deg = scale.map(|s| 14.5 * s / 4.0);
        log.append(&r).unwrap();
    }
    log.mark_completed("2026-11-23T12:10:00.000Z").unwrap();
}

#[test]
fn trials_shown_off_calibration_are_warned_about_naming_file_and_trials() {
    use analysis::logs::{LoadOptions, load_experiments};
    let dir = tempfile::tempdir().unwrap();
    let results = dir.path().join("results");
    let display = r#"{"mode":"mono","scale":4.0,"visual_angle_deg":14.5}"#;
    // P1: the practice trial (0) and trials 2 and 4 off; trial 3 is 0.4 % off, within 0.5 %.
    let off = results.join("P1/session-1.csv");
    write_scaled_session(
        &off,
        "P1",
        display,
        &[Some(2.0), Some(4.0), Some(2.4), Some(4.016), Some(4.0 * 0.994), None, Some(4.0)],
    );
    // P2: every trial as calibrated (exactly, and within the tolerance either side).
    write_scaled_session(
        &results.join("P2/session-1.csv"),
        "P2",
        display,
        &[Some(4.0), Some(4.0), Some(3.99), Some(4.019)],
    );
    // P3: a simulated session, no calibrated scale in the header, rows without a scale.
    write_scaled_session(&results.join("P3/session-1.csv"), "P3", r#"{"mode":"simulated"}"#, &[None, None, None]);
    // P4: a blurlab-responses/1 log (rows have no scale) under a calibrated header.
    let v1 = results.join("P4/session-1.csv");
    std::fs::create_dir_all(v1.parent().unwrap()).unwrap();
    let mut text = "# blurlab-responses/1\n".to_owned();
    for (k, v) in &header("scaled", "P4", 1, "{}").fields {
        text.push_str(&format!("# {k}: {v}\n"));
    }
    text.push_str(&format!("# display: {display}\n"));
    text.push_str("trial,practice,task,shown,choice,correct,response_ms,replays,dropped_frames,timestamp\n");
    text.push_str("0,0,2afc,M3-S2-T3-A1|M3-S2-T3-A2,M3-S2-T3-A1,,900,0,0,t\n# completed: t\n");
    std::fs::write(&v1, text).unwrap();

    let data = load_experiments(std::slice::from_ref(&results), &LoadOptions::default()).unwrap();
    assert_eq!(data.len(), 1);
    let warnings: Vec<&String> = data[0].warnings.iter().filter(|w| w.contains("off-calibration")).collect();
    assert_eq!(warnings.len(), 1, "{:?}", data[0].warnings);
    let w = warnings[0];
    assert!(w.starts_with(&format!("{}: 2 counted trials shown off-calibration (trials 2, 4)", off.display())), "{w}");
    assert!(w.contains("calibrated scale 4.000 (14.50 degrees)"), "{w}");
    assert!(w.contains("trial 2 (line 14) at scale 2.400, 8.70 degrees"), "{w}");
    assert!(w.contains("trial 4 (line 16) at scale 3.976, 14.41 degrees"), "{w}");
    assert!(!w.contains("trial 3 ") && !w.contains("trial 0 "), "{w}");
    // The v1 log is read: its one counted trial counts, with no scale.
    assert_eq!(data[0].sessions.iter().find(|s| s.participant == "P4").unwrap().trials, 1);

    // Without any off-calibration trial, no warning.
    std::fs::remove_file(&off).unwrap();
    write_scaled_session(&off, "P1", display, &[Some(4.0), Some(4.0), Some(4.0)]);
    let data = load_experiments(std::slice::from_ref(&results), &LoadOptions::default()).unwrap();
    assert!(data[0].warnings.iter().all(|w| !w.contains("calibrat")), "{:?}", data[0].warnings);

    // A `display` that is not JSON is said, with its line.
    std::fs::remove_file(&off).unwrap();
    write_scaled_session(&off, "P1", "{not json", &[Some(4.0), Some(2.0)]);
    let data = load_experiments(std::slice::from_ref(&results), &LoadOptions::default()).unwrap();
    assert!(
        data[0]
            .warnings
            .iter()
            .any(|w| w.contains(&format!("{}: line 10: header `display` is not JSON", off.display()))),
        "{:?}",
        data[0].warnings
    );
}

#[test]
fn repeated_pairs_and_sessions_count_as_separate_judges_or_pooled() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Pcg64::seed_from_u64(5);
    let stimuli: Vec<StimulusId> = (1..=5).map(|a| id(&format!("M3-S2-T3-A{a}"))).collect();
    let results = dir.path().join("results");
    let q = |s: &StimulusId| f64::from(s.samples) * 0.4;
    for p in 0..3 {
        let code = format!("P{p}");
        // Every pair twice within a session, as thesis 5.6.3, and a second session for P0.
        write_2afc_session(
            &results.join(&code).join("session-1.csv"),
            "mono-2-sampling-2afc",
            &code,
            1,
            "{}",
            &stimuli,
            &q,
            2,
            &mut rng,
        );
    }
    write_2afc_session(
        &results.join("P0/session-2.csv"),
        "mono-2-sampling-2afc",
        "P0",
        2,
        "{}",
        &stimuli,
        &q,
        1,
        &mut rng,
    );
    let report = build_report(std::slice::from_ref(&results), None, None, options()).unwrap();
    let p = report.experiments[0].paired.as_ref().unwrap();
    assert_eq!(p.complete_judges, 7);
    assert_eq!(p.judges.len(), 7);
    assert_eq!(p.critical.unwrap().judges, 7);
    let mut pooled = options();
    pooled.judge_unit = JudgeUnit::Participant;
    let report = build_report(&[results], None, None, pooled).unwrap();
    let p = report.experiments[0].paired.as_ref().unwrap();
    assert_eq!(p.judges.len(), 3);
    assert_eq!(p.judges[0].judgments, 30);
    assert_eq!(p.complete_judges, 7);
    assert!(p.judges_statement.contains("pooled"));
}

#[test]
fn matching_logs_give_the_accuracy_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let stimuli: Vec<StimulusId> = (1..=3).map(|t| id(&format!("M3-S2-T{t}-A5"))).collect();
    let path = dir.path().join("results/P1/session-1.csv");
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut log = ResponseLog::create(&path, &header("mono-2-shutter-matching", "P1", 1, "{}")).unwrap();
    let mut n = 0;
    for i in 0..3 {
        for j in i + 1..3 {
            // Right when the candidates are two levels apart, wrong for neighbours.
            let right = j - i == 2;
            let (reference, other) = (stimuli[i], stimuli[j]);
            let choice = if right { reference } else { other };
            log.append(&row(n, Task::Match, vec![reference, reference, other], choice, Some(right))).unwrap();
            n += 1;
        }
    }
    log.mark_completed("t").unwrap();
    let report = build_report(&[dir.path().join("results")], None, None, options()).unwrap();
    let m = report.experiments[0].matching.as_ref().unwrap();
    assert_eq!(m.trials, 3);
    assert!((m.overall - 1.0 / 3.0).abs() < 1e-12);
    assert_eq!(m.accuracy[0][2], Some(1.0));
    assert_eq!(m.accuracy[2][0], Some(1.0));
    assert_eq!(m.accuracy[0][1], Some(0.0));
    assert_eq!(m.accuracy[1][1], None);
    let mut report = report;
    write_report(&mut report, &dir.path().join("out")).unwrap();
    assert!(dir.path().join("out/mono-2-shutter-matching-matching.png").exists());
}

fn expect_error(results: &[PathBuf], manifest: Option<&Path>, needles: &[&str]) {
    let e = build_report(results, manifest, None, options()).unwrap_err().to_string();
    for needle in needles {
        assert!(e.contains(needle), "`{e}` lacks `{needle}`");
    }
}

#[test]
fn bad_logs_are_errors_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let (mono, _, set) = results_with_mono_and_stereo(dir.path());
    let log = mono.join("P00/session-1.csv");
    let original = std::fs::read_to_string(&log).unwrap();
    let lines: Vec<&str> = original.lines().collect();
    let first_row = lines.iter().position(|l| l.starts_with("0,")).unwrap();

    // Unknown stimulus id (not in the set's manifest), in the middle of the file.
    let mut bad: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    bad[first_row + 2] = "2,0,2afc,M2-S2-T9-A3|M2-S2-T3-A3,M2-S2-T9-A3,,900,0,0,t,,".into();
    std::fs::write(&log, bad.join("\n") + "\n").unwrap();
    let line = format!("line {}", first_row + 3);
    expect_error(std::slice::from_ref(&mono), Some(&set), &["session-1.csv", &line, "unknown stimulus id M2-S2-T9"]);

    // Wrong column count in the middle of the file.
    let mut bad: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    bad[first_row + 1].push_str(",extra");
    std::fs::write(&log, bad.join("\n") + "\n").unwrap();
    let line = format!("line {}", first_row + 2);
    expect_error(std::slice::from_ref(&mono), None, &["P00/session-1.csv", &line, "found 13 columns"]);
    std::fs::write(&log, &original).unwrap();

    // Mixed experiments in one folder.
    let other = mono.join("P99/session-1.csv");
    std::fs::create_dir_all(other.parent().unwrap()).unwrap();
    std::fs::write(&other, original.replace("# experiment: mono-3-interactions", "# experiment: mono-1-broad"))
        .unwrap();
    expect_error(std::slice::from_ref(&mono), None, &["P99/session-1.csv", "line 2", "mixed experiments"]);

    // Same experiment, different definition hash.
    std::fs::write(
        &other,
        original
            .replace("# experiment_sha256: sha-mono-3-interactions", "# experiment_sha256: other")
            .replace("# participant: P00", "# participant: P99"),
    )
    .unwrap();
    expect_error(std::slice::from_ref(&mono), None, &["P99/session-1.csv", "line 3", "`experiment_sha256` is `other`"]);

    // Mixed views within one experiment.
    let mut stereo_row: Vec<String> =
        original.replace("# participant: P00", "# participant: P99").lines().map(str::to_owned).collect();
    stereo_row[first_row + 4] = "4,0,2afc,M2-S2-T3-A3-stereo|M2-S2-T3-A4-stereo,M2-S2-T3-A4-stereo,,900,0,0,t,,".into();
    std::fs::write(&other, stereo_row.join("\n") + "\n").unwrap();
    expect_error(std::slice::from_ref(&mono), None, &["P99/session-1.csv", "mixed views"]);
    std::fs::remove_file(&other).unwrap();

    // A partial last row is reported, not counted.
    std::fs::write(&log, original.replace("# completed: 2026-11-23T12:10:00.000Z\n", "") + "36,0,2afc,M2-S2").unwrap();
    let report = build_report(&[mono], None, None, options()).unwrap();
    assert!(
        report.experiments[0].warnings.iter().any(|w| w.contains("partial last row")),
        "{:?}",
        report.experiments[0].warnings
    );
}
