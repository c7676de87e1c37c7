//! Synthetic experiment data for benchmarks and examples: simulated judges of the
//! interaction test (T3..T5 x A3..A5) who follow Thurstone Case V with known qualities, from a
//! recorded seed, and incomplete designs ([`simulated_incomplete_experiment`]): observers of
//! known kinds judging random pairs on a trial budget. Tests write real log files where the
//! reading matters (see `tests/logs_and_report.rs`).

use std::collections::BTreeMap;
use std::path::PathBuf;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use study::StimulusId;
use study::response::Task;

use crate::logs::{ExperimentData, Session, Trial};
use crate::srange::normal_upper_quantile;

/// The nine stimuli of test #3 (checker, medium speed, T3..T5 x A3..A5), mono.
pub fn interaction_stimuli() -> Vec<StimulusId> {
    let mut out = Vec::new();
    for shutter in 3..=5 {
        for samples in 3..=5 {
            out.push(StimulusId { material: 2, speed: 2, shutter, samples, method: None, view: study::View::Mono });
        }
    }
    out
}

/// `judges` simulated sessions judging every pair of `stimuli` once. Stimulus quality
/// decreases with shutter (0.8 JOD per level) and rises slightly with samples (0.2 JOD);
/// each judgment adds standard normal noise scaled to the JOD unit.
pub fn simulated_experiment(stimuli: &[StimulusId], judges: usize, seed: u64) -> ExperimentData {
    let mut rng = Pcg64::seed_from_u64(seed);
    let quality = |s: &StimulusId| -0.8 * f64::from(s.shutter) + 0.2 * f64::from(s.samples);
    let mut sessions = Vec::new();
    let mut trials = Vec::new();
    for j in 0..judges {
        let mut line = 12;
        for a in 0..stimuli.len() {
            for b in a + 1..stimuli.len() {
                let (x, y) = if rng.random::<bool>() { (stimuli[a], stimuli[b]) } else { (stimuli[b], stimuli[a]) };
                let u: f64 = rng.random::<f64>().clamp(1e-12, 1.0 - 1e-12);
                let noise = normal_upper_quantile(u) * crate::scaling::JOD_SIGMA;
                let choice = if quality(&x) - quality(&y) + noise > 0.0 { x } else { y };
                trials.push(Trial { session: j, line, shown: vec![x, y], choice, correct: None });
                line += 1;
            }
        }
        let mut attributes = BTreeMap::new();
        attributes.insert("cg_experience".to_owned(), if j % 2 == 0 { "yes" } else { "no" }.to_owned());
        sessions.push(Session {
            path: PathBuf::from(format!("simulated/P{j:02}/session-1.csv")),
            participant: format!("P{j:02}"),
            session: "1".into(),
            attributes,
            completed: true,
            trailing_corrupt: None,
            trials: stimuli.len() * (stimuli.len() - 1) / 2,
        });
    }
    ExperimentData {
        name: "simulated-interactions".into(),
        experiment_sha256: String::new(),
        stimulus_set_sha256: String::new(),
        task: Task::TwoAfc,
        view: study::View::Mono,
        stimuli: stimuli.to_vec(),
        definition: None,
        sessions,
        trials,
        warnings: Vec::new(),
    }
}

/// The stimuli of the full study (3 materials x 3 speeds x 5 shutters x 5 sampling levels,
/// mono): the first `n` of the 225, at most 225.
pub fn study_stimuli(n: usize) -> Vec<StimulusId> {
    let mut out = Vec::new();
    for material in 1..=3 {
        for speed in 1..=3 {
            for shutter in 1..=5 {
                for samples in 1..=5 {
                    out.push(StimulusId { material, speed, shutter, samples, method: None, view: study::View::Mono });
                }
            }
        }
    }
    out.truncate(n);
    out
}

/// How a simulated participant answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observer {
    /// Thurstone Case V: `P(i beats j) = Phi((s_i - s_j) / 1.4826)` with the true scores.
    Thurstone,
    /// A coin flip on every trial.
    Random,
    /// Thurstone on the reversed scale (`-s`).
    Reversed,
}

/// One session per observer (`P00`, `P01`, ...), each judging `trials` pairs drawn uniformly
/// with replacement from all pairs of `stimuli` (so most pairs are never shown to one
/// participant and some twice), answering as its [`Observer`] kind with `truth` (JOD).
pub fn simulated_incomplete_experiment(
    stimuli: &[StimulusId],
    truth: &[f64],
    observers: &[Observer],
    trials: usize,
    seed: u64,
) -> ExperimentData {
    let mut rng = Pcg64::seed_from_u64(seed);
    let t = stimuli.len();
    let mut sessions = Vec::new();
    let mut rows = Vec::new();
    for (p, kind) in observers.iter().enumerate() {
        for k in 0..trials {
            let a = rng.random_range(0..t);
            let b = (a + 1 + rng.random_range(0..t - 1)) % t;
            let u: f64 = rng.random::<f64>().clamp(1e-12, 1.0 - 1e-12);
            let noise = normal_upper_quantile(u) * crate::scaling::JOD_SIGMA;
            let a_wins = match kind {
                Observer::Thurstone => truth[a] - truth[b] + noise > 0.0,
                Observer::Reversed => truth[b] - truth[a] + noise > 0.0,
                Observer::Random => noise > 0.0,
            };
            let choice = if a_wins { stimuli[a] } else { stimuli[b] };
            rows.push(Trial { session: p, line: 12 + k, shown: vec![stimuli[a], stimuli[b]], choice, correct: None });
        }
        sessions.push(Session {
            path: PathBuf::from(format!("simulated/P{p:02}/session-1.csv")),
            participant: format!("P{p:02}"),
            session: "1".into(),
            attributes: BTreeMap::new(),
            completed: true,
            trailing_corrupt: None,
            trials,
        });
    }
    ExperimentData {
        name: "simulated-incomplete".into(),
        experiment_sha256: String::new(),
        stimulus_set_sha256: String::new(),
        task: Task::TwoAfc,
        view: study::View::Mono,
        stimuli: stimuli.to_vec(),
        definition: None,
        sessions,
        trials: rows,
        warnings: Vec::new(),
    }
}

/// Times the analysis: the median of `repeats` full analyses of `judges` simulated judges of
/// the 36 interaction pairs with `resamples` bootstrap resamples, and single `W` quantiles.
/// Returns a JSON object (used by `blurlab bench analysis` and the `bench_analysis` example).
pub fn benchmark(judges: usize, resamples: usize, repeats: usize, seed: u64) -> serde_json::Value {
    use std::time::Instant;

    use crate::experiment::{AnalysisOptions, JudgeUnit, analyze_experiment};
    use crate::scaling::ScaleOptions;

    let stimuli = interaction_stimuli();
    let data = simulated_experiment(&stimuli, judges, seed);
    let options = AnalysisOptions {
        alpha: 0.01,
        judge_unit: JudgeUnit::Replicate,
        scale: ScaleOptions { resamples, seed, ..ScaleOptions::default() },
    };
    let mut full = Vec::new();
    let mut groups = 0;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        let report = analyze_experiment(&data, &BTreeMap::new(), options);
        full.push(start.elapsed().as_secs_f64());
        groups = report.paired.map_or(0, |p| p.groups.len());
    }
    let mut sorted = full.clone();
    sorted.sort_by(f64::total_cmp);
    let mut quantiles = Vec::new();
    for (t, alpha) in [(2usize, 0.05), (5, 0.01), (9, 0.01), (36, 0.05), (100, 0.01), (100, 1e-9)] {
        let n = 200;
        let start = Instant::now();
        let mut w = 0.0;
        for _ in 0..n {
            w = crate::srange::srange_quantile(std::hint::black_box(t), std::hint::black_box(alpha))
                .unwrap_or(f64::NAN);
        }
        let per = start.elapsed().as_secs_f64() / f64::from(n);
        quantiles.push(serde_json::json!({ "t": t, "alpha": alpha, "w": w, "seconds": per }));
    }
    serde_json::json!({
        "benchmark": "analysis",
        "profile": if cfg!(debug_assertions) { "debug" } else { "release" },
        "threads_available": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "judges": judges,
        "stimuli": stimuli.len(),
        "pairs": stimuli.len() * (stimuli.len() - 1) / 2,
        "resamples": resamples,
        "seed": seed,
        "groups_found": groups,
        "full_analysis_seconds_median": sorted[sorted.len() / 2],
        "full_analysis_seconds": full,
        "w_quantile": quantiles,
    })
}
