//! Incomplete designs and observer screening over simulated Thurstone observers with known
//! true scores: each participant judges a random subset of the pairs (most never, some
//! twice); a few answer at random and some reverse the scale.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::collections::BTreeMap;

use analysis::experiment::{AnalysisOptions, ExperimentReport, analyze_experiment, analyze_experiment_screened};
use analysis::incomplete::Design;
use analysis::paired::{PreferenceMatrix, agreement};
use analysis::report::{REPORT_FORMAT, Report, markdown, write_report};
use analysis::scaling::{JOD_SIGMA, ScaleOptions};
use analysis::screening::screen_observers;
use analysis::srange::normal_upper_quantile;
use analysis::synthetic::{Observer, simulated_experiment, simulated_incomplete_experiment, study_stimuli};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// 16 stimuli in 4 levels of 4 equal true scores, 2 JOD apart: 0, 2, 4, 6.
fn levels() -> Vec<f64> {
    (0..16).map(|i| 2.0 * f64::from(i / 4)).collect()
}

fn options() -> AnalysisOptions {
    AnalysisOptions {
        alpha: 0.01,
        scale: ScaleOptions { resamples: 300, seed: 5, ..Default::default() },
        ..Default::default()
    }
}

/// 20 participants, 250 random pairs each (of 120): P04 and P09 answer at random, P14
/// reverses the scale.
fn observers() -> Vec<Observer> {
    let mut o = vec![Observer::Thurstone; 20];
    o[4] = Observer::Random;
    o[9] = Observer::Random;
    o[14] = Observer::Reversed;
    o
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

fn report_of(e: ExperimentReport) -> Report {
    Report {
        format: REPORT_FORMAT,
        software_version: study::SOFTWARE_VERSION,
        manifest: None,
        experiments: vec![e],
        mono_stereo_pairs: Vec::new(),
        figures: Vec::new(),
        vote_tables: Vec::new(),
    }
}

#[test]
fn an_incomplete_design_reports_the_scale_and_its_groups_instead_of_kendall() {
    let stimuli = study_stimuli(16);
    let truth = levels();
    let honest = vec![Observer::Thurstone; 20];
    let data = simulated_incomplete_experiment(&stimuli, &truth, &honest, 250, 21);
    let e = analyze_experiment(&data, &BTreeMap::new(), options());
    let p = e.paired.as_ref().unwrap();
    // The rule: no pass judged every pair.
    let Design::Incomplete { reason } = &p.design else { panic!("{:?}", p.design) };
    assert!(reason.contains("0 of") && reason.contains("at least 2 complete judges"), "{reason}");
    // Kendall's statistics are absent, and the reason is given.
    assert!(p.agreement.as_ref().is_err_and(|why| why.contains("incomplete design")));
    assert!(p.critical.is_none() && p.mean_zeta.is_none());
    assert!(p.judges.iter().all(|j| j.circular_triads.is_none() && j.zeta.is_none() && j.triad_test.is_none()));
    // One summary warning, not one per pass.
    assert_eq!(e.warnings.iter().filter(|w| w.contains("incomplete design")).count(), 1, "{:?}", e.warnings);
    assert!(!e.warnings.iter().any(|w| w.contains("left out of triads")), "{:?}", e.warnings);
    // The scale recovers the truth.
    let r = pearson(&p.scale.scores, &truth);
    assert!(r > 0.98, "correlation {r}: {:?}", p.scale.scores);
    // Groups: equal true scores share a group; true scores 4 JOD or more apart never do.
    let g = p.scale_grouping.as_ref().unwrap().as_ref().unwrap();
    assert_eq!(g.participants, 20);
    assert_eq!(
        g.groups,
        p.groups
            .iter()
            .map(|g| g.members.iter().map(|m| stimuli.iter().position(|s| *s == m.id).unwrap()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    );
    let together = |i: usize, j: usize| p.memberships[i].iter().any(|g| p.memberships[j].contains(g));
    for i in 0..16 {
        for j in 0..16 {
            if truth[i] == truth[j] {
                assert!(together(i, j), "{i} and {j} are equal but not grouped: {:?}", g.groups);
            }
            if (truth[i] - truth[j]).abs() >= 4.0 {
                assert!(!together(i, j), "{i} and {j} are 4 JOD apart but grouped: {:?}", g.groups);
            }
        }
    }
    // Adjacent levels (2 JOD) are told apart too with 5000 trials.
    assert_eq!(g.groups.len(), 4, "{:?}", g.groups);
    // Group members carry their scale value; the top group holds the best level.
    assert!(
        p.groups[0]
            .members
            .iter()
            .all(|m| m.scale.is_some() && truth[stimuli.iter().position(|s| *s == m.id).unwrap()] == 6.0)
    );
    // The report says so instead of printing the statistics.
    let md = markdown(&report_of(e.clone()));
    assert!(md.contains("**Incomplete design.**") && md.contains("not reported"), "{md}");
    assert!(!md.contains("Kendall's u =") && !md.contains("circular triads |") && !md.contains("ceil(R_c)"));
    assert!(md.contains("|s_i - s_j| / SD(s_i - s_j) >= W_{t,alpha} / sqrt(2)"), "{md}");
    assert!(md.contains("bootstrap resamples over participants"));
}

#[test]
fn screening_flags_random_and_reversed_participants_and_exclusion_leaves_them_out() {
    let stimuli = study_stimuli(16);
    let truth = levels();
    let data = simulated_incomplete_experiment(&stimuli, &truth, &observers(), 250, 8);
    let e = analyze_experiment(&data, &BTreeMap::new(), options());
    let p = e.paired.as_ref().unwrap();
    assert_eq!(p.screening.flagged, vec!["P04", "P09", "P14"], "{:#?}", p.screening.observers);
    assert!(p.excluded_participants.is_empty());
    // Margins: the outliers far beyond the threshold, the honest comfortably within.
    for o in &p.screening.observers {
        if o.flagged {
            assert!(o.distance > 5.0, "{o:?}");
        } else {
            assert!(o.distance < 1.0, "{o:?}");
        }
    }
    let reversed = &p.screening.observers[14];
    assert!(p.screening.observers.iter().all(|o| o.log10_likelihood >= reversed.log10_likelihood));
    let md = markdown(&report_of(e.clone()));
    assert!(md.contains("Flagged: P04, P09, P14. They are kept"), "{md}");
    assert!(md.contains("Q1 - 1.5 IQR"));
    // Excluding them: the analysis runs on the 17 others and the scale gets closer to the truth.
    let x = analyze_experiment_screened(&data, &BTreeMap::new(), options(), true);
    let q = x.paired.as_ref().unwrap();
    assert_eq!(q.excluded_participants, vec!["P04", "P09", "P14"]);
    assert_eq!(x.sessions.len(), 17);
    assert_eq!(q.matrix_all.total(), 17 * 250);
    assert_eq!(q.screening, p.screening, "screening is computed before the exclusion");
    assert!(x.warnings.iter().any(|w| w.contains("--exclude-outliers") && w.contains("P04, P09, P14")));
    let spread = |s: &[f64]| s.iter().copied().fold(f64::MIN, f64::max) - s.iter().copied().fold(f64::MAX, f64::min);
    assert!(spread(&q.scale.scores) > spread(&p.scale.scores), "reversed and random answers compress the scale");
    assert!((spread(&q.scale.scores) - 6.0).abs() < 1.0, "{:?}", q.scale.scores);
    let md = markdown(&report_of(x));
    assert!(md.contains("**Excluded** (`--exclude-outliers`): the sessions of P04, P09, P14"), "{md}");
}

#[test]
fn screening_works_on_complete_designs_too() {
    // 10 stimuli, every participant judges every pair twice; P02 reverses the scale, P07
    // answers at random.
    let t = 10;
    let truth: Vec<f64> = (0..t).map(|i| 0.6 * i as f64).collect();
    let mut rng = Pcg64::seed_from_u64(3);
    let mut list = Vec::new();
    for p in 0..12 {
        let mut m = PreferenceMatrix::new(t);
        for _ in 0..2 {
            for i in 0..t {
                for j in i + 1..t {
                    let noise = normal_upper_quantile(rng.random::<f64>().clamp(1e-12, 1.0 - 1e-12)) * JOD_SIGMA;
                    let d = match p {
                        2 => truth[j] - truth[i],
                        7 => 0.0,
                        _ => truth[i] - truth[j],
                    };
                    if d + noise > 0.0 { m.add(i, j) } else { m.add(j, i) }
                }
            }
        }
        list.push((format!("P{p:02}"), m));
    }
    let s = screen_observers(&list, 3.0);
    assert_eq!(s.flagged, vec!["P02", "P07"], "{:#?}", s.observers);
    assert!((s.threshold - (s.q1 - 1.5 * s.iqr)).abs() < 1e-12);
}

#[test]
fn a_complete_design_still_reports_kendall_statistics_and_david_groups() {
    let stimuli = analysis::synthetic::interaction_stimuli();
    let data = simulated_experiment(&stimuli, 12, 4);
    let e = analyze_experiment(&data, &BTreeMap::new(), options());
    let p = e.paired.as_ref().unwrap();
    assert_eq!(p.design, Design::Complete);
    assert!(p.scale_grouping.is_none());
    assert_eq!(p.complete_judges, 12);
    assert_eq!(p.agreement.as_ref().unwrap(), &agreement(&p.matrix).unwrap());
    let c = p.critical.unwrap();
    assert_eq!(c, analysis::grouping::critical_range(9, 12, 0.01).unwrap());
    let groups = analysis::grouping::significance_groups(
        &p.votes.iter().map(|&v| f64::from(v)).collect::<Vec<_>>(),
        c.ceil_rc as f64,
    );
    assert_eq!(p.groups.len(), groups.len());
    assert!(p.groups.iter().flat_map(|g| &g.members).all(|m| m.scale.is_none()));
    assert!(p.judges.iter().all(|j| j.zeta.is_some()));
    let md = markdown(&report_of(e));
    assert!(md.contains("Kendall's u =") && md.contains("ceil(R_c)") && !md.contains("Incomplete design"));
    assert!(md.contains("**Observer screening.**") && md.contains("**Pairs shown.** 36 of 36 pairs"));
}

#[test]
fn the_report_folder_has_the_pairs_heat_map_and_the_screening_plot() {
    let stimuli = study_stimuli(16);
    let data = simulated_incomplete_experiment(&stimuli, &levels(), &observers(), 120, 2);
    let mut report = report_of(analyze_experiment(&data, &BTreeMap::new(), options()));
    let out = std::env::var_os("BLURLAB_KEEP_REPORT")
        .map_or_else(|| tempfile::tempdir().unwrap().keep(), std::path::PathBuf::from);
    let md = write_report(&mut report, &out).unwrap();
    let text = std::fs::read_to_string(md).unwrap();
    for stem in ["simulated-incomplete-pairs", "simulated-incomplete-screening", "simulated-incomplete-scale"] {
        assert!(text.contains(&format!("({stem}.png)")), "{stem} not linked");
        for ext in ["png", "svg"] {
            let f = out.join(format!("{stem}.{ext}"));
            assert!(std::fs::metadata(&f).map(|m| m.len() > 1000).unwrap_or(false), "{}", f.display());
        }
    }
    // No vote figures: votes of complete judges do not exist here.
    assert!(!out.join("simulated-incomplete-votes.png").exists() && !text.contains("-votes.png"));
    // Nor a vote table: David's grouping does not apply to them.
    assert!(!out.join("simulated-incomplete-votes.csv").exists() && report.vote_tables.is_empty());
    assert!(!text.contains("-votes.csv"));
    // The heat map counts are the pairs shown.
    let p = report.experiments[0].paired.as_ref().unwrap();
    let counts = p.pair_counts();
    assert_eq!(counts.iter().flatten().sum::<u32>(), 2 * 20 * 120);
    assert!((0..16).all(|i| counts[i][i] == 0 && (0..16).all(|j| counts[i][j] == counts[j][i])));
}
