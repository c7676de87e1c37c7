//! End-to-end: `blurlab analyze --votes` reproduces every transcribed thesis table's
//! ceil(R_c) and groups as published, and `blurlab stats srange-quantile` prints W.

use blurlab_e2e::{repo_root, run};

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
fn missing_votes_file_is_a_bad_input_naming_the_file() {
    let out = run(&["analyze", "--votes", "no/such/votes.csv"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/votes.csv"));
}
