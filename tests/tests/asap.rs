//! End to end: the shipped `experiments/mono-all-asap.toml` (all 225 mono sequences, pairs
//! chosen by ASAP) run by simulated Thurstone participants through `blurlab run`, two
//! processes at a time sharing the experiment's posterior, then `blurlab analyze`: the
//! incomplete design's scale and groups, from a synthetic set holding every stimulus.
//!
//! With `BLURLAB_ASAP_REPORT=DIR` the report folder is copied to `DIR` (how
//! `analysis/mono-all-asap-simulated/` (its report.md and PNG figures) was made).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::Path;
use std::process::{Command, Stdio};

use blurlab_e2e::{blurlab, repo_root, run};
use study::StimulusId;
use study::experiment::ExperimentDefinition;

const PARTICIPANTS: u64 = 8;

fn text(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn the_whole_mono_set_with_asap_runs_end_to_end_and_groups_by_quality() {
    let root = repo_root();
    let experiment = root.join("experiments/mono-all-asap.toml");
    let d = ExperimentDefinition::read(&experiment).unwrap();
    assert_eq!(d.stimuli.len(), 225);
    let study::experiment::PairSelection::Asap { budget } = d.selection else { panic!("an ASAP experiment") };
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
    runner::stimuli::write_synthetic_set(&set, &ids, 8, 4, 2, 30.0).unwrap();
    let results = dir.path().join("results");
    // Two participants at a time: two processes updating the shared posterior.
    for first in (1..=PARTICIPANTS).step_by(2) {
        let children: Vec<_> = (first..first + 2)
            .map(|k| {
                Command::new(blurlab())
                    .args([
                        "run",
                        text(&experiment),
                        "--stimuli",
                        text(&set),
                        "--results",
                        text(&results),
                        "--participant",
                        &format!("P{k:02}"),
                        "--simulate",
                        "thurstone",
                        "--seed",
                        &(2026 + k).to_string(),
                    ])
                    .current_dir(&root)
                    .stdout(Stdio::piped())
                    .stderr(Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for child in children {
            let out = child.wait_with_output().unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        }
    }
    // Every answer of every session is in the shared posterior.
    let posterior: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results.join("mono-all-asap/selection-posterior.json")).unwrap())
            .unwrap();
    let answers = posterior["answers"].as_array().unwrap();
    assert_eq!(answers.len() as u64, PARTICIPANTS * u64::from(budget));
    // Concurrent sessions avoid the pair on the other's screen: few pairs are shown twice.
    let distinct: std::collections::BTreeSet<(u64, u64)> = answers
        .iter()
        .map(|a| {
            let (w, l) = (a["winner"].as_u64().unwrap(), a["loser"].as_u64().unwrap());
            (w.max(l), w.min(l))
        })
        .collect();
    assert!(distinct.len() * 10 >= answers.len() * 9, "{} distinct pairs in {} trials", distinct.len(), answers.len());

    let report_dir = dir.path().join("report");
    let out = run(&[
        "analyze",
        text(&results),
        "--manifest",
        text(&set),
        "--out",
        text(&report_dir),
        "--bootstrap",
        "200",
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    if let Ok(keep) = std::env::var("BLURLAB_ASAP_REPORT") {
        let keep = Path::new(&keep);
        std::fs::create_dir_all(keep).unwrap();
        for e in std::fs::read_dir(&report_dir).unwrap().flatten() {
            std::fs::copy(e.path(), keep.join(e.file_name())).unwrap();
        }
    }
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let report = &report["experiments"][0];
    let paired = &report["paired"];
    // Kendall's statistics do not apply to an incomplete design: absent, with the reason.
    let markdown = std::fs::read_to_string(report_dir.join("report.md")).unwrap();
    assert!(markdown.contains("incomplete"), "{markdown}");
    assert_eq!(paired["design"]["kind"], "incomplete", "{}", paired["design"]);
    assert!(paired["mean_zeta"].is_null());
    // Groups from the scale: several, and the best stimulus's group holds none of the worst
    // latent qualities.
    let groups =
        paired["scale_grouping"]["Ok"]["groups"].as_array().unwrap_or_else(|| panic!("{}", paired["scale_grouping"]));
    assert!(groups.len() >= 3, "{} groups", groups.len());
    // The scale follows the simulated participants' latent quality.
    let stimuli: Vec<StimulusId> =
        report["stimuli"].as_array().unwrap().iter().map(|s| s.as_str().unwrap().parse().unwrap()).collect();
    let scores: Vec<f64> = paired["scale"]["scores"].as_array().unwrap().iter().map(|s| s.as_f64().unwrap()).collect();
    let truth: Vec<f64> = stimuli.iter().map(runner::simulate::rule_quality).collect();
    let rho = study::stats::spearman(&scores, &truth);
    assert!(rho > 0.7, "rank correlation of the scale with the latent quality {rho}");
    let worst = truth.iter().copied().fold(f64::INFINITY, f64::min);
    let best = (0..scores.len()).max_by(|&a, &b| scores[a].total_cmp(&scores[b])).unwrap();
    let top: Vec<usize> = groups
        .iter()
        .map(|g| g.as_array().unwrap().iter().map(|i| i.as_u64().unwrap() as usize).collect::<Vec<_>>())
        .find(|g| g.contains(&best))
        .unwrap();
    assert!(top.iter().all(|&i| truth[i] > worst + 1.0), "{top:?}");
    eprintln!("225 stimuli, {PARTICIPANTS} participants x {budget} trials: Spearman {rho:.3}");
}
