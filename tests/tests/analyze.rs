//! End-to-end: `blurlab analyze --votes` reproduces every transcribed thesis table's
//! ceil(R_c) and groups as published, `blurlab stats srange-quantile` prints W, and `blurlab
//! stats ceiling` sets forecasts beside what a perfect one reaches against a table's noise.

use blurlab_e2e::{repo_root, run, stderr, stdout};

fn header(text: &str, key: &str) -> String {
    text.lines()
        .find_map(|l| l.strip_prefix(&format!("# {key}:")))
        .unwrap_or_else(|| panic!("no `# {key}:` header"))
        .trim()
        .to_owned()
}

#[test]
fn analyze_votes_reproduces_every_thesis_table() {
    let dir = repo_root().join("analysis/reference");
    let mut tables: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    tables.sort();
    assert!(tables.len() >= 5, "expected the five transcribed tables, found {}", tables.len());
    for table in tables {
        let text = std::fs::read_to_string(&table).unwrap();
        let out = run(&["analyze", "--votes", table.to_str().unwrap(), "--json"]);
        assert!(out.status.success(), "{}: {}", table.display(), String::from_utf8_lossy(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let ceil_rc = report["critical"]["ceil_rc"].as_u64().unwrap();
        assert_eq!(ceil_rc.to_string(), header(&text, "published_ceil_rc"), "{}", table.display());
        let groups: Vec<String> = report["groups"]
            .as_array()
            .unwrap()
            .iter()
            .map(|g| g.as_array().unwrap().iter().map(|s| s.as_str().unwrap()).collect::<Vec<_>>().join(" "))
            .collect();
        assert_eq!(groups.join("; "), header(&text, "expected_groups"), "{}", table.display());
    }
}

#[test]
fn srange_quantile_matches_the_published_table() {
    // Harter's table of the range of normals (df infinite): W(5, 0.01) = 4.603, W(10, 0.05) = 4.474.
    for (t, alpha, expected) in [("5", "0.01", 4.603), ("10", "0.05", 4.474)] {
        let out = run(&["stats", "srange-quantile", "--t", t, "--alpha", alpha, "--json"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let w = v["w"].as_f64().unwrap();
        assert!((w - expected).abs() < 6e-4, "W({t}, {alpha}) = {w}, expected {expected}");
    }
}

#[test]
fn the_ceiling_of_the_thesis_tables_and_the_forecasts_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let sampling = "analysis/reference/thesis-5.6.3-mono-sampling-2afc.csv";
    let interactions = "analysis/reference/thesis-5.7.2-mono-interactions.csv";
    let forecasts = ["analysis/observer/5.6.3-shutter/predict.json", "analysis/observer/5.7.2-shutter/predict.json"];
    let out = dir.path().join("ceiling");
    let args = ["stats", "ceiling", sampling, interactions, "--replications", "500", "--seed", "3"];
    let o =
        run(&[&args[..], &["--forecast", forecasts[0], "--forecast", forecasts[1], "--out", out.to_str().unwrap()]]
            .concat());
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["ceiling.md", "ceiling.json", "ceiling.png", "ceiling.svg"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("ceiling.json")).unwrap()).unwrap();
    assert_eq!(json["format"], "blurlab-ceiling/1");
    for (t, stimuli) in [(0, 5), (1, 9)] {
        let table = &json["tables"][t];
        // The fitted qualities give back the table's totals (within the fit's tolerance).
        let q: Vec<f64> = table["fitted"]["truth"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let votes: Vec<f64> = table["votes"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        let judges = table["judges"].as_f64().unwrap();
        assert_eq!(q.len(), stimuli);
        for i in 0..stimuli {
            let expected: f64 =
                (0..stimuli).filter(|&j| j != i).map(|j| judges * study::stats::jod_preference(q[i], q[j])).sum();
            assert!((expected - votes[i]).abs() < 1e-6, "table {t} stimulus {i}: {expected} against {}", votes[i]);
        }
        let fitted = &table["fitted"]["spearman"];
        let shrunk = &table["shrunk"]["spearman"];
        assert!(fitted["mean"].as_f64().unwrap() > 0.8 && fitted["q95"].as_f64().unwrap() <= 1.0, "{fitted}");
        assert!(shrunk["mean"].as_f64().unwrap() <= fitted["mean"].as_f64().unwrap() + 0.01, "{shrunk}");
        assert!((0.0..=1.0).contains(&table["shrink"].as_f64().unwrap()));
    }
    // The frozen observer's 1.000 on 5.6.3 is never beaten; its 0.450 on 5.7.2 nearly always.
    let points = json["forecasts"].as_array().unwrap();
    assert_eq!(points[0]["perfect_no_better"][0], 1.0);
    assert!(points[1]["perfect_no_better"][0].as_f64().unwrap() < 0.01, "{}", points[1]);
    let md = std::fs::read_to_string(out.join("ceiling.md")).unwrap();
    assert!(md.contains("cvvdp `shutter`: mean Spearman 0.725 over the 2 tables"), "{md}");
    // The same seed, the same numbers; JSON on standard output without --out.
    let o = run(&[&args[..], &["--json"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let again: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(again["tables"], json["tables"]);

    // Run again, each forecast's own Spearman with the replicates: the frozen observer's
    // 1.000 on 5.6.3 is the perfect forecast's order, so it meets the ceiling itself.
    assert_eq!(points[0]["again"][0]["spearman"], json["tables"][0]["fitted"]["spearman"]);

    // A forecast made before any votes, with a table as the hypothesis of what people prefer
    // and a planned number of judges: the recorded pursuit-pair forecast for the fast test,
    // if people there prefer as they did at the medium speed, with 5 judges.
    let recorded = "analysis/observer/preregistered/mono-3-interactions-fast/sharp-pursuit-pair/predict.json";
    let o = run(&[
        "stats",
        "ceiling",
        interactions,
        "--judges-planned",
        "5",
        "--forecast",
        recorded,
        "--replications",
        "400",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let planned: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((&planned["tables"][0]["judges"], &planned["tables"][0]["replicate_judges"]), (&21.into(), &5.into()));
    let f = &planned["forecasts"][0];
    assert!(f["hypothetical"] == true && f["spearman"].is_null(), "{f}");
    let again = f["again"][0]["spearman"]["mean"].as_f64().unwrap();
    assert!(again > 0.8 && f["again"][0]["reaches_floor"].as_f64().unwrap() > 0.95, "{f}");

    // Bad input, each named.
    let bad = |extra: &[&str], needle: &str| {
        let o = run(&[&["stats", "ceiling"][..], extra].concat());
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(needle), "expected `{needle}` in: {}", stderr(&o));
    };
    bad(&[sampling, "--forecast", forecasts[1]], "is not one of the tables given");
    bad(&[sampling, interactions, "--forecast", recorded], "made without --votes, so it names no table");
    bad(
        &[sampling, "--forecast", recorded],
        "9 stimuli, but analysis/reference/thesis-5.6.3-mono-sampling-2afc.csv has 5",
    );
    bad(&[sampling, "--goal-mean", "1.5"], "--goal-mean 1.5: expected a Spearman correlation in [-1, 1]");
    // Forecast files that are not forecasts, or whose stimuli do not fit the table.
    bad(&[sampling, "--forecast", sampling], "thesis-5.6.3-mono-sampling-2afc.csv: not JSON");
    let other = dir.path().join("other.json");
    std::fs::write(&other, r#"{"format": "blurlab-report/1"}"#).unwrap();
    bad(&[sampling, "--forecast", other.to_str().unwrap()], "other.json: not a forecast");
    let mut doubled: serde_json::Value =
        serde_json::from_slice(&std::fs::read(blurlab_e2e::repo_root().join(recorded)).unwrap()).unwrap();
    doubled["stimuli"][1]["label"] = doubled["stimuli"][0]["label"].clone();
    let doubled_path = dir.path().join("doubled.json");
    std::fs::write(&doubled_path, serde_json::to_vec(&doubled).unwrap()).unwrap();
    bad(&[interactions, "--forecast", doubled_path.to_str().unwrap()], "two of its stimuli are the same one");
    doubled["stimuli"][1]["label"] = "T9-A9".into();
    std::fs::write(&doubled_path, serde_json::to_vec(&doubled).unwrap()).unwrap();
    bad(&[interactions, "--forecast", doubled_path.to_str().unwrap()], "stimulus `T9-A9` is not one of");
    bad(&[sampling, "--replications", "1"], "1 replications: expected 2 to 1000000");
    let no_judges = dir.path().join("no-judges.csv");
    std::fs::write(&no_judges, "# blurlab-votes/1\nstimulus,votes\nA,15\nB,5\n").unwrap();
    bad(&[no_judges.to_str().unwrap()], "no-judges.csv: no `judges` header; give --judges");
    bad(&[no_judges.to_str().unwrap(), "--judges", "19"], "the votes total 20, but 19 judgements");
    let o = run(&["stats", "ceiling", no_judges.to_str().unwrap(), "--judges", "20", "--replications", "100"]);
    assert!(o.status.success() && stdout(&o).contains("| 2 | 20 | A +0.50, B -0.50 |"), "{}", stdout(&o));
}

#[test]
fn missing_votes_file_is_a_bad_input_naming_the_file() {
    let out = run(&["analyze", "--votes", "no/such/votes.csv"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/votes.csv"));
}

/// Writes one session of 150 random pairs of `stimuli` (true quality: the stimulus's
/// index in JOD), answered by a logistic stand-in for a Thurstone observer, or on the
/// reversed scale.
#[allow(clippy::unwrap_used, reason = "a test helper fails the test by panicking")]
fn write_random_pairs_session(
    path: &std::path::Path,
    participant: &str,
    stimuli: &[study::StimulusId],
    reversed: bool,
    seed: u64,
) {
    use study::response::{REQUIRED_KEYS, ResponseLog, SessionHeader, Task, TrialRow};
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut h = SessionHeader::default();
    for k in REQUIRED_KEYS {
        h.set(k, "x");
    }
    h.set("experiment", "random-pairs-e2e");
    h.set("experiment_sha256", "sha-random-pairs-e2e");
    h.set("participant", participant);
    h.set("session", "1");
    h.set("attributes", "{}");
    let mut log = ResponseLog::create(path, &h).unwrap();
    // A small LCG: the test needs no statistics crate, only a fixed, varied sequence.
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let t = stimuli.len();
    for trial in 0..150u32 {
        let a = (uniform() * t as f64) as usize % t;
        let b = (a + 1 + (uniform() * (t - 1) as f64) as usize % (t - 1)) % t;
        // Logistic noise close to the JOD's normal: P(a wins) = 1 / (1 + exp(-1.7 d / 1.4826)).
        let d = if reversed { b as f64 - a as f64 } else { a as f64 - b as f64 };
        let p = 1.0 / (1.0 + (-1.7 * d / 1.4826).exp());
        let choice = if uniform() < p { stimuli[a] } else { stimuli[b] };
        log.append(&TrialRow {
            trial,
            practice: false,
            task: Task::TwoAfc,
            shown: vec![stimuli[a], stimuli[b]],
            choice,
            correct: None,
            response_ms: 900,
            replays: 0,
            dropped_frames: 0,
            timestamp: "2026-12-04T12:00:00.000Z".into(),
            scale: None,
            visual_angle_deg: None,
        })
        .unwrap();
    }
    log.mark_completed("2026-12-04T12:10:00.000Z").unwrap();
}

#[test]
fn analyze_an_incomplete_design_screens_and_excludes_outliers() {
    let dir = tempfile::tempdir().unwrap();
    let results = dir.path().join("results");
    let stimuli: Vec<study::StimulusId> =
        (1..=5).flat_map(|t| (1..=2).map(move |a| format!("M2-S2-T{t}-A{a}").parse().unwrap())).collect();
    for p in 0..8 {
        let code = format!("P{p:02}");
        write_random_pairs_session(&results.join(&code).join("session-1.csv"), &code, &stimuli, p == 5, p as u64 + 1);
    }
    let out_dir = dir.path().join("report");
    let args = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> =
            ["analyze", results.to_str().unwrap(), "--out", out_dir.to_str().unwrap(), "--bootstrap", "100"]
                .iter()
                .map(|s| s.to_string())
                .collect();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    // Without the flag: the design is called incomplete, P05 is flagged and kept.
    let kept = run(&args(&[]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(kept.status.success(), "{}", stderr(&kept));
    let (so, se) = (stdout(&kept), stderr(&kept));
    assert!(
        so.contains("random-pairs-e2e: incomplete design, Kendall's statistics not computed; 8 participants"),
        "{so}"
    );
    assert!(so.contains("flagged participants (kept; --exclude-outliers leaves them out): P05"), "{so}");
    // One warning about the design, not one per participant.
    assert_eq!(se.matches("warning:").count(), 1, "{se}");
    let md = std::fs::read_to_string(out_dir.join("report.md")).unwrap();
    assert!(md.contains("**Incomplete design.**") && md.contains("Flagged: P05. They are kept"), "{md}");
    assert!(!md.contains("Kendall's u ="));
    for stem in ["random-pairs-e2e-pairs", "random-pairs-e2e-screening"] {
        assert!(out_dir.join(format!("{stem}.png")).is_file() && out_dir.join(format!("{stem}.svg")).is_file());
    }
    // With --exclude-outliers: P05's session is left out and named.
    let excluded = run(&args(&["--exclude-outliers"]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(excluded.status.success(), "{}", stderr(&excluded));
    let so = stdout(&excluded);
    assert!(so.contains("7 participants, 1050 trials"), "{so}");
    assert!(so.contains("random-pairs-e2e: excluded outlying participants (--exclude-outliers): P05"), "{so}");
    let md = std::fs::read_to_string(out_dir.join("report.md")).unwrap();
    assert!(md.contains("**Excluded** (`--exclude-outliers`): the sessions of P05"), "{md}");
    assert!(md.contains("7 sessions (7 completed) from 7 participants"), "{md}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["experiments"][0]["paired"]["excluded_participants"][0], "P05");
    assert_eq!(json["experiments"][0]["paired"]["design"]["kind"], "incomplete");
}
