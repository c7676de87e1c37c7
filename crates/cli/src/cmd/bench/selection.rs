//! `blurlab bench selection`: what active pair selection (ASAP, the `selection` crate) saves,
//! measured by simulation (issue 30, items 4 and 1).
//!
//! **Accuracy against trials.** Simulated Thurstone Case V observers with known true scores
//! answer paired comparisons over 9, 45 and 225 stimuli: `P(i beats j) = Phi((s_i - s_j) /
//! 1.4826)` with the scores `s` in JOD, drawn anew for every repetition from `N(0,
//! TRUE_SD_JOD^2)`. Four ways of choosing the pairs are compared on the same true scores:
//! the complete design (every pair once a round in a random order, rounds repeated), uniformly
//! random pairs, ASAP one pair at a time as the runner chooses (`best_pair` with
//! `Search::Refine(REFINED_PAIRS)` after refitting the posterior to every answer) and ASAP's
//! batch mode (the paper's minimum spanning tree of `n - 1` pairs, `spanning_batch`, chosen
//! when the previous batch is used up). At log-spaced checkpoints (and at whole rounds of the
//! complete design) the answers so far are scaled as the analysis scales them (Thurstone Case
//! V MAP, `analysis::scaling::fit_case_v` with the analysis's default prior) and compared with
//! the true scores: RMSE in JOD (both centred to mean 0) and Spearman's rank correlation. Each
//! curve is the mean over repetitions with a 95 % band (mean +- 1.96 standard errors). From
//! the mean curves, read on a log axis of trials, comes the number of trials each method needs
//! to reach the complete design's RMSE after 1, 2, 3, 5, ... rounds.
//!
//! **Selection time.** For 225 stimuli after 0, 1,000, 4,500 and 10,000 answers (random pairs
//! answered by the same observers), single-threaded: the median wall time of one selection
//! (the posterior refitted from all answers, then `best_pair` with `Search::Refine`), of
//! the paper's full evaluation (`Search::Full`), how often the two choose the same pair over
//! several seeds, and the memory held (the posterior plus the vector of evaluated pairs).
//!
//! Every random choice draws from a PCG64 generator whose seed is derived from `--seed` and
//! written with the results. Writes `accuracy.csv`, `selection.json` and one figure per
//! stimulus count (`accuracy-N.png`, `.svg`) to `--out`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use analysis::paired::PreferenceMatrix;
use analysis::plots::{Figure, group_colour, save_figure};
use analysis::scaling::{ScaleOptions, fit_case_v};
use plotters::coord::Shift;
use plotters::prelude::*;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use selection::posterior::normal_cdf;
use selection::{
    Comparison, Evaluation, JOD_PER_UNIT, PairGain, Posterior, REFINED_PAIRS, Search, index_below, unit_f64,
};
use serde_json::json;

use crate::cmd::BadInput;

/// Standard deviation of the true scores (JOD): with 9 stimuli they span about 5 JOD, as the
/// thesis's 9-stimulus tests did; neighbours among 225 are about 0.03 JOD apart.
pub const TRUE_SD_JOD: f64 = 1.5;
/// Half-width of the bands in standard errors (95 % under normality).
const BAND_Z: f64 = 1.96;
/// Whole rounds of the complete design at which checkpoints are always taken.
const ROUNDS: [usize; 7] = [1, 2, 3, 5, 10, 15, 20];
/// Log-spaced checkpoints per stimulus count (whole rounds are added to them).
const LOG_CHECKPOINTS: usize = 14;
/// The stimulus counts the simulation knows sizes for.
const STIMULI: [usize; 3] = [9, 45, 225];

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Smoke-test sizes (about 30 s in a release build): fewer trials and repetitions.
    #[arg(long)]
    quick: bool,
    /// Stimulus counts simulated, comma-separated (of 9, 45, 225).
    #[arg(long, value_delimiter = ',', default_values_t = STIMULI)]
    stimuli: Vec<usize>,
    /// Base seed: every simulation's and timing's generator seed is derived from it.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Threads of the simulation (default: all cores; the selection timing is single-threaded).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=256))]
    threads: Option<u64>,
    /// Timed runs per selection-time measurement (the median is reported).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    timing_runs: u64,
    /// Seeds over which `Search::Refine`'s choice is compared with `Search::Full`'s.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=10000))]
    agreement_seeds: u64,
    /// Skip the selection timing (only the simulation study).
    #[arg(long)]
    no_timing: bool,
    /// Skip the simulation study (only the selection timing).
    #[arg(long)]
    no_study: bool,
    /// Only redraw the figures from the `accuracy.csv` already in `--out` (no simulation,
    /// no timing; `selection.json` is left as it is).
    #[arg(long)]
    plot_only: bool,
    /// Folder for the table, the figures and the JSON.
    #[arg(long, default_value = "bench/selection")]
    out: PathBuf,
    /// Print the full result as JSON (otherwise a summary).
    #[arg(long)]
    json: bool,
    /// The scores compared with the truth: `map`, the scale `analyze` reports (Thurstone MAP,
    /// prior sd 3 JOD), or `posterior`, ASAP's own posterior means (prior sd 1.05 JOD) fitted
    /// to the same answers whatever chose the pairs.
    #[arg(long, value_enum, default_value_t = Scores::Map)]
    scores: Scores,
}

/// Which estimate of the scores is judged against the truth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Scores {
    /// `analysis::scaling::fit_case_v` with the analysis's prior.
    Map,
    /// `selection::Posterior::fit`'s means, in JOD.
    Posterior,
}

/// A way of choosing the next pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Every pair once a round, in a random order.
    Complete,
    /// Uniformly random pairs.
    Random,
    /// ASAP one pair at a time (the runner's choice).
    AsapSequential,
    /// ASAP's minimum-spanning-tree batches of `n - 1` pairs (the paper's batch mode).
    AsapBatch,
}

impl Method {
    const ALL: [Method; 4] = [Method::Complete, Method::Random, Method::AsapSequential, Method::AsapBatch];

    /// Name in the table and the legend.
    pub fn name(self) -> &'static str {
        match self {
            Method::Complete => "complete",
            Method::Random => "random",
            Method::AsapSequential => "asap-sequential",
            Method::AsapBatch => "asap-batch",
        }
    }

    fn colour(self) -> RGBColor {
        match self {
            Method::Complete => group_colour(0),
            Method::Random => group_colour(3),
            Method::AsapSequential => group_colour(1),
            Method::AsapBatch => group_colour(2),
        }
    }

    fn index(self) -> u64 {
        match self {
            Method::Complete => 0,
            Method::Random => 1,
            Method::AsapSequential => 2,
            Method::AsapBatch => 3,
        }
    }
}

/// The simulation's sizes for one stimulus count.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Stimuli.
    pub stimuli: usize,
    /// Repetitions of the complete design, random pairs and ASAP batches.
    pub repetitions: usize,
    /// Trials they run to.
    pub max_trials: usize,
    /// Repetitions of ASAP one pair at a time (a selection a trial: the costly one).
    pub sequential_repetitions: usize,
    /// Trials it runs to.
    pub sequential_max_trials: usize,
}

impl Plan {
    /// The default (`quick` false) or smoke-test sizes for `stimuli`; `None` for a count
    /// without stated sizes.
    pub fn for_stimuli(stimuli: usize, quick: bool) -> Option<Plan> {
        let pairs = stimuli * (stimuli - 1) / 2;
        let (repetitions, max_trials, sequential_repetitions, sequential_max_trials) = match (stimuli, quick) {
            (9, false) => (30, 20 * pairs, 30, 20 * pairs),
            (45, false) => (16, 4 * pairs, 8, 2 * pairs),
            (225, false) => (2, pairs, 2, 10 * stimuli),
            (9, true) => (8, 10 * pairs, 8, 10 * pairs),
            (45, true) => (2, 2 * pairs, 2, pairs),
            (225, true) => (1, 10 * stimuli, 1, 2 * stimuli),
            _ => return None,
        };
        Some(Plan { stimuli, repetitions, max_trials, sequential_repetitions, sequential_max_trials })
    }

    fn pairs(&self) -> usize {
        self.stimuli * (self.stimuli - 1) / 2
    }

    /// Repetitions and trials of `method`.
    fn budget(&self, method: Method) -> (usize, usize) {
        match method {
            Method::AsapSequential => (self.sequential_repetitions, self.sequential_max_trials),
            _ => (self.repetitions, self.max_trials),
        }
    }

    /// The trial counts at which the scale is fitted: log-spaced from `n` to the largest
    /// budget, and every whole round of [`ROUNDS`] within it.
    pub fn checkpoints(&self) -> Vec<usize> {
        let top = self.max_trials.max(self.sequential_max_trials);
        let low = self.stimuli.min(top).max(1);
        let mut out: Vec<usize> = (0..LOG_CHECKPOINTS)
            .map(|k| {
                let f = k as f64 / (LOG_CHECKPOINTS - 1) as f64;
                ((low as f64).ln() * (1.0 - f) + (top as f64).ln() * f).exp().round() as usize
            })
            .chain(ROUNDS.iter().map(|r| r * self.pairs()).filter(|&t| t <= top))
            .chain([self.sequential_max_trials])
            .collect();
        out.sort_unstable();
        out.dedup();
        // Checkpoints within 3 % of a larger one add nothing on a log axis.
        let mut kept: Vec<usize> = Vec::new();
        for &t in out.iter().rev() {
            let is_round = t % self.pairs() == 0 || t == self.sequential_max_trials;
            if kept.last().is_none_or(|&next| is_round || (next as f64) > 1.03 * t as f64) {
                kept.push(t);
            }
        }
        kept.reverse();
        kept
    }
}

/// Seed of a repetition's true scores (shared by the methods, so they are compared on the
/// same scores) and of a method's answers and choices.
fn seed_for(base: u64, stimuli: usize, repetition: usize, method: Option<Method>) -> u64 {
    let m = method.map_or(0, |m| m.index() + 1);
    base.wrapping_mul(1_000_003)
        .wrapping_add((stimuli as u64) * 100_000)
        .wrapping_add(repetition as u64 * 10)
        .wrapping_add(m)
}

const SEED_RULE: &str = "base * 1000003 + stimuli * 100000 + repetition * 10 + m, m = 0 for the true scores, 1 complete, 2 random, 3 asap-sequential, 4 asap-batch (PCG64 seed_from_u64)";

/// A standard normal draw (Box-Muller).
fn normal(rng: &mut Pcg64) -> f64 {
    let u = 1.0 - unit_f64(rng);
    let v = unit_f64(rng);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// True scores (JOD) of one repetition, centred to mean 0.
pub fn true_scores(stimuli: usize, seed: u64) -> Vec<f64> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let s: Vec<f64> = (0..stimuli).map(|_| TRUE_SD_JOD * normal(&mut rng)).collect();
    centred(&s)
}

fn centred(s: &[f64]) -> Vec<f64> {
    let mean = s.iter().sum::<f64>() / s.len().max(1) as f64;
    s.iter().map(|x| x - mean).collect()
}

/// The simulated observer's answer to `(i, j)`.
fn answer(truth: &[f64], i: usize, j: usize, rng: &mut Pcg64) -> Comparison {
    if unit_f64(rng) < normal_cdf((truth[i] - truth[j]) / JOD_PER_UNIT) {
        Comparison { winner: i, loser: j }
    } else {
        Comparison { winner: j, loser: i }
    }
}

/// RMSE (JOD, both centred) of `fit` against `truth`.
pub fn rmse(fit: &[f64], truth: &[f64]) -> f64 {
    let (f, t) = (centred(fit), centred(truth));
    (f.iter().zip(&t).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / f.len().max(1) as f64).sqrt()
}

/// Spearman's rank correlation ([`study::stats::spearman`]); 0 where either is constant.
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let r = study::stats::spearman(a, b);
    if r.is_nan() { 0.0 } else { r }
}

/// One repetition of one method: `(rmse, spearman)` at each checkpoint up to `max_trials`.
fn simulate(
    scores_by: Scores,
    method: Method,
    truth: &[f64],
    max_trials: usize,
    checkpoints: &[usize],
    seed: u64,
) -> anyhow::Result<Vec<(f64, f64)>> {
    let n = truth.len();
    let prior_sd = ScaleOptions::default().prior_sd;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut matrix = PreferenceMatrix::new(n);
    let mut answers: Vec<Comparison> = Vec::with_capacity(max_trials);
    let mut queue: Vec<(usize, usize)> = Vec::new();
    let mut fit: Option<Vec<f64>> = None;
    let mut out = Vec::new();
    let mut next = checkpoints.iter().copied().filter(|&t| t <= max_trials).peekable();
    for trial in 1..=max_trials {
        let (i, j) = match method {
            Method::Random => selection::random_pair(n, &mut rng),
            Method::Complete => {
                if queue.is_empty() {
                    queue = (1..n).flat_map(|i| (0..i).map(move |j| (i, j))).collect();
                    for k in (1..queue.len()).rev() {
                        let l = index_below(&mut rng, k + 1);
                        queue.swap(k, l);
                    }
                }
                queue.pop().ok_or_else(|| anyhow::anyhow!("no pairs of {n} stimuli"))?
            }
            Method::AsapSequential => {
                let post = Posterior::fit(n, &answers)?;
                match selection::best_pair(&post, Evaluation::Selective, Search::Refine(REFINED_PAIRS), &mut rng) {
                    Some(p) => p,
                    None => selection::random_pair(n, &mut rng),
                }
            }
            Method::AsapBatch => {
                if queue.is_empty() {
                    let post = Posterior::fit(n, &answers)?;
                    queue = selection::spanning_batch(&post, Evaluation::Selective, &mut rng);
                    // Shown largest gain first.
                    queue.reverse();
                }
                match queue.pop() {
                    Some(p) => p,
                    None => selection::random_pair(n, &mut rng),
                }
            }
        };
        let c = answer(truth, i, j, &mut rng);
        answers.push(c);
        matrix.add(c.winner, c.loser);
        if next.peek() == Some(&trial) {
            next.next();
            let scores = match scores_by {
                Scores::Map => fit_case_v(&matrix, prior_sd, fit.as_deref()).0,
                Scores::Posterior => {
                    Posterior::fit(n, &answers)?.means().iter().map(|m| m * selection::JOD_PER_UNIT).collect()
                }
            };
            out.push((rmse(&scores, truth), spearman(&scores, truth)));
            fit = Some(scores);
        }
    }
    Ok(out)
}

/// Mean and 95 % band of one checkpoint over the repetitions.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Trials.
    pub trials: usize,
    /// Mean RMSE (JOD).
    pub mean_rmse: f64,
    /// Lower end of its band.
    pub rmse_lo: f64,
    /// Upper end of its band.
    pub rmse_hi: f64,
    /// Mean Spearman correlation.
    pub mean_spearman: f64,
    /// Lower end of its band.
    pub spearman_lo: f64,
    /// Upper end of its band.
    pub spearman_hi: f64,
    /// Repetitions.
    pub repetitions: usize,
}

/// One method's curve for one stimulus count.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    /// Method name.
    pub method: &'static str,
    /// Stimuli.
    pub stimuli: usize,
    /// Checkpoints.
    pub points: Vec<Point>,
    /// Seconds of compute spent on the method's repetitions (all threads).
    pub seconds: f64,
}

impl Curve {
    fn to_json(&self) -> serde_json::Value {
        let points: Vec<serde_json::Value> = self
            .points
            .iter()
            .map(|p| {
                json!({
                    "trials": p.trials, "mean_rmse": p.mean_rmse, "rmse_lo": p.rmse_lo, "rmse_hi": p.rmse_hi,
                    "mean_spearman": p.mean_spearman, "spearman_lo": p.spearman_lo, "spearman_hi": p.spearman_hi,
                    "repetitions": p.repetitions,
                })
            })
            .collect();
        json!({ "method": self.method, "stimuli": self.stimuli, "seconds": self.seconds, "points": points })
    }
}

fn band(values: &[f64]) -> (f64, f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = if values.len() > 1 { values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0) } else { 0.0 };
    let half = BAND_Z * (var / n).sqrt();
    (mean, mean - half, mean + half)
}

/// Runs every plan's repetitions of every method on `threads` threads.
pub fn run_study(
    scores_by: Scores,
    plans: &[Plan],
    seed: u64,
    threads: usize,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<Vec<Curve>> {
    struct Job {
        plan: usize,
        method: Method,
        repetition: usize,
    }
    let mut jobs = Vec::new();
    for (p, plan) in plans.iter().enumerate() {
        for method in Method::ALL {
            for repetition in 0..plan.budget(method).0 {
                jobs.push(Job { plan: p, method, repetition });
            }
        }
    }
    // The costliest first (ASAP one pair at a time over many stimuli), for a balanced finish.
    jobs.sort_by_key(|j| {
        let plan = &plans[j.plan];
        let cost = plan.budget(j.method).1 * if j.method == Method::AsapSequential { plan.stimuli * 20 } else { 1 };
        std::cmp::Reverse(cost)
    });
    bar.set_length(jobs.len() as u64);
    let checkpoints: Vec<Vec<usize>> = plans.iter().map(Plan::checkpoints).collect();
    type Outcome = (usize, Method, usize, Vec<(f64, f64)>, f64);
    let results: Mutex<Vec<Outcome>> = Mutex::new(Vec::new());
    let failure: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(job) = jobs.get(k) else { break };
                    let plan = &plans[job.plan];
                    let truth = true_scores(plan.stimuli, seed_for(seed, plan.stimuli, job.repetition, None));
                    let start = Instant::now();
                    let run = simulate(
                        scores_by,
                        job.method,
                        &truth,
                        plan.budget(job.method).1,
                        &checkpoints[job.plan],
                        seed_for(seed, plan.stimuli, job.repetition, Some(job.method)),
                    );
                    let seconds = start.elapsed().as_secs_f64();
                    match run {
                        Ok(r) => {
                            if let Ok(mut all) = results.lock() {
                                all.push((job.plan, job.method, job.repetition, r, seconds));
                            }
                        }
                        Err(e) => {
                            if let Ok(mut f) = failure.lock() {
                                f.get_or_insert(e);
                            }
                            next.store(jobs.len(), Ordering::Relaxed);
                        }
                    }
                    bar.inc(1);
                    bar.set_message(format!("{} x {}", job.method.name(), plan.stimuli));
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().map_err(|_| anyhow::anyhow!("a simulation thread panicked"))? {
        return Err(e);
    }
    let results = results.into_inner().map_err(|_| anyhow::anyhow!("a simulation thread panicked"))?;
    let mut curves = Vec::new();
    for (p, plan) in plans.iter().enumerate() {
        for method in Method::ALL {
            let (reps, max) = plan.budget(method);
            let mine: Vec<&Outcome> = results.iter().filter(|r| r.0 == p && r.1 == method).collect();
            if mine.len() != reps {
                return Err(anyhow::anyhow!(
                    "{} x {}: {} of {reps} repetitions ran",
                    method.name(),
                    plan.stimuli,
                    mine.len()
                ));
            }
            let points = checkpoints[p]
                .iter()
                .filter(|&&t| t <= max)
                .enumerate()
                .map(|(k, &trials)| {
                    let r: Vec<f64> = mine.iter().map(|o| o.3[k].0).collect();
                    let s: Vec<f64> = mine.iter().map(|o| o.3[k].1).collect();
                    let (mean_rmse, rmse_lo, rmse_hi) = band(&r);
                    let (mean_spearman, spearman_lo, spearman_hi) = band(&s);
                    Point {
                        trials,
                        mean_rmse,
                        rmse_lo,
                        rmse_hi,
                        mean_spearman,
                        spearman_lo,
                        spearman_hi,
                        repetitions: reps,
                    }
                })
                .collect();
            let seconds = mine.iter().map(|o| o.4).sum();
            curves.push(Curve { method: method.name(), stimuli: plan.stimuli, points, seconds });
        }
    }
    Ok(curves)
}

/// Trials at which `curve`'s mean RMSE first reaches `target`, interpolated linearly in RMSE
/// against log trials between the checkpoints around the crossing; `None` if it never does.
pub fn trials_to_reach(points: &[Point], target: f64) -> Option<f64> {
    let k = points.iter().position(|p| p.mean_rmse <= target)?;
    if k == 0 {
        return Some(points[0].trials as f64);
    }
    let (a, b) = (&points[k - 1], &points[k]);
    let (xa, xb) = ((a.trials as f64).ln(), (b.trials as f64).ln());
    let f = (a.mean_rmse - target) / (a.mean_rmse - b.mean_rmse);
    Some((xa + f * (xb - xa)).exp())
}

/// How many trials each method needs to match the complete design after whole rounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Match {
    /// Stimuli.
    pub stimuli: usize,
    /// Rounds of the complete design.
    pub rounds: usize,
    /// Its trials (`rounds * n (n - 1) / 2`).
    pub complete_trials: usize,
    /// Its mean RMSE there (JOD).
    pub complete_rmse: f64,
    /// Method.
    pub method: &'static str,
    /// Trials the method needs for that RMSE (`None`: not reached within its budget).
    pub trials: Option<f64>,
    /// `trials / complete_trials`.
    pub fraction: Option<f64>,
    /// The method's budget.
    pub max_trials: usize,
}

impl Match {
    fn to_json(&self) -> serde_json::Value {
        json!({
            "stimuli": self.stimuli, "rounds": self.rounds, "complete_trials": self.complete_trials,
            "complete_rmse": self.complete_rmse, "method": self.method, "trials": self.trials,
            "fraction": self.fraction, "max_trials": self.max_trials,
        })
    }
}

/// The matches of every method against every whole round the complete design reached.
pub fn matches(curves: &[Curve]) -> Vec<Match> {
    let mut out = Vec::new();
    for complete in curves.iter().filter(|c| c.method == Method::Complete.name()) {
        let n = complete.stimuli;
        let pairs = n * (n - 1) / 2;
        for rounds in ROUNDS {
            let Some(p) = complete.points.iter().find(|p| p.trials == rounds * pairs) else { continue };
            for other in curves.iter().filter(|c| c.stimuli == n && c.method != complete.method) {
                let trials = trials_to_reach(&other.points, p.mean_rmse);
                out.push(Match {
                    stimuli: n,
                    rounds,
                    complete_trials: p.trials,
                    complete_rmse: p.mean_rmse,
                    method: other.method,
                    trials,
                    fraction: trials.map(|t| t / p.trials as f64),
                    max_trials: other.points.last().map_or(0, |q| q.trials),
                });
            }
        }
    }
    out
}

/// The RMSE and Spearman figure of one stimulus count.
struct AccuracyFigure<'a> {
    stimuli: usize,
    curves: Vec<&'a Curve>,
    repetitions: String,
}

const FONT: &str = "sans-serif";

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Tick labels at 1, 2 and 5 x 10^k only (a log axis has a tick at every 1..9 x 10^k).
fn log_tick(v: &f64) -> String {
    if !(*v > 0.0 && v.is_finite()) {
        return String::new();
    }
    let mantissa = v / 10f64.powf(v.log10().floor());
    if [1.0, 2.0, 5.0, 10.0].iter().any(|m| (mantissa - m).abs() < 1e-6 * m) {
        if *v >= 10_000.0 { format!("{}k", (v / 1000.0).round()) } else { format!("{}", v.round()) }
    } else {
        String::new()
    }
}

impl AccuracyFigure<'_> {
    fn panel<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, spearman: bool) -> Result<(), String> {
        let pairs = (self.stimuli * (self.stimuli - 1) / 2) as f64;
        let all = || self.curves.iter().flat_map(|c| c.points.iter());
        let x0 = all().map(|p| p.trials).min().unwrap_or(1) as f64 / 1.15;
        let x1 = all().map(|p| p.trials).max().unwrap_or(10) as f64 * 1.15;
        let value = |p: &Point| {
            if spearman { (p.mean_spearman, p.spearman_lo, p.spearman_hi) } else { (p.mean_rmse, p.rmse_lo, p.rmse_hi) }
        };
        let (y0, y1) = if spearman {
            let lo = all().map(|p| value(p).1).fold(1.0f64, f64::min);
            ((lo - 0.05).clamp(-1.0, 0.9), 1.0)
        } else {
            (0.0, all().map(|p| value(p).2).fold(0.0f64, f64::max) * 1.05 + 1e-9)
        };
        let (title, y_desc) = if spearman {
            (format!("Rank correlation, {} stimuli", self.stimuli), "Spearman correlation with the true scores")
        } else {
            (
                format!("Scale error, {} stimuli (true sd {TRUE_SD_JOD} JOD)", self.stimuli),
                "RMSE to the true scores (JOD)",
            )
        };
        let mut chart = ChartBuilder::on(area)
            .caption(title, (FONT, 18.0).into_font())
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_label_formatter(&log_tick)
            .y_label_formatter(&|v: &f64| format!("{v:.2}"))
            .light_line_style(BLACK.mix(0.04))
            .x_desc(format!(
                "trials (log scale); 1 round = {} pairs; repetitions: {}",
                pairs as usize, self.repetitions
            ))
            .y_desc(y_desc)
            .label_style((FONT, 13.0))
            .axis_desc_style((FONT, 14.0))
            .draw()
            .map_err(err)?;
        // Whole rounds of the complete design, as faint verticals (1, 2, 5, 10, 20).
        for r in [1, 2, 5, 10, 20] {
            let x = r as f64 * pairs;
            if x > x0 && x < x1 / 1.3 {
                chart
                    .draw_series(std::iter::once(PathElement::new(vec![(x, y0), (x, y1)], BLACK.mix(0.25))))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        format!("{r} round{}", if r == 1 { "" } else { "s" }),
                        (x * 1.02, y0 + 0.03 * (y1 - y0)),
                        (FONT, 11.0).into_font().color(&BLACK.mix(0.6)),
                    )))
                    .map_err(err)?;
            }
        }
        for curve in &self.curves {
            let colour = Method::ALL.into_iter().find(|m| m.name() == curve.method).map_or(BLACK, Method::colour);
            let mut band: Vec<(f64, f64)> =
                curve.points.iter().map(|p| (p.trials as f64, value(p).1.max(y0))).collect();
            band.extend(curve.points.iter().rev().map(|p| (p.trials as f64, value(p).2.min(y1))));
            chart.draw_series(std::iter::once(Polygon::new(band, colour.mix(0.15).filled()))).map_err(err)?;
            let line: Vec<(f64, f64)> = curve.points.iter().map(|p| (p.trials as f64, value(p).0)).collect();
            chart
                .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
                .map_err(err)?
                .label(curve.method)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart.draw_series(line.into_iter().map(|(x, y)| Circle::new((x, y), 3, colour.filled()))).map_err(err)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font((FONT, 13.0))
            .position(if spearman { SeriesLabelPosition::LowerRight } else { SeriesLabelPosition::UpperRight })
            .draw()
            .map_err(err)
    }
}

impl Figure for AccuracyFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (1400, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (left, right) = root.split_horizontally(700);
        self.panel(&left, false)?;
        self.panel(&right, true)
    }
}

fn write(dir: &Path, name: &str, text: &str) -> anyhow::Result<()> {
    let path = dir.join(name);
    study::fsio::write_atomic(&path, text.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))
}

/// The curves of an `accuracy.csv` written by [`write_study`].
pub fn read_study(path: &Path) -> anyhow::Result<Vec<Curve>> {
    let text = std::fs::read_to_string(path).map_err(|e| BadInput(format!("{}: cannot read: {e}", path.display())))?;
    let mut curves: Vec<Curve> = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let bad = |what: &str| BadInput(format!("{}: line {}: {what}", path.display(), k + 1));
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 10 {
            return Err(bad("expected 10 fields").into());
        }
        let method = Method::ALL.into_iter().find(|m| m.name() == f[0]).ok_or_else(|| bad("unknown method"))?.name();
        let int = |s: &str| s.parse::<usize>().map_err(|_| bad("not a count"));
        let num = |s: &str| s.parse::<f64>().map_err(|_| bad("not a number"));
        let stimuli = int(f[1])?;
        let point = Point {
            trials: int(f[2])?,
            mean_rmse: num(f[3])?,
            rmse_lo: num(f[4])?,
            rmse_hi: num(f[5])?,
            mean_spearman: num(f[6])?,
            spearman_lo: num(f[7])?,
            spearman_hi: num(f[8])?,
            repetitions: int(f[9])?,
        };
        match curves.iter_mut().find(|c| c.method == method && c.stimuli == stimuli) {
            Some(c) => c.points.push(point),
            None => curves.push(Curve { method, stimuli, points: vec![point], seconds: 0.0 }),
        }
    }
    Ok(curves)
}

/// Draws `accuracy-N.png` and `.svg` for every stimulus count of `curves`.
fn write_figures(curves: &[Curve], dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut counts: Vec<usize> = curves.iter().map(|c| c.stimuli).collect();
    counts.dedup();
    for n in counts {
        let mine: Vec<&Curve> = curves.iter().filter(|c| c.stimuli == n && !c.points.is_empty()).collect();
        let repetitions = mine
            .iter()
            .map(|c| format!("{} {}", c.method, c.points.first().map_or(0, |p| p.repetitions)))
            .collect::<Vec<_>>()
            .join(", ");
        let figure = AccuracyFigure { stimuli: n, curves: mine, repetitions };
        files.extend(save_figure(&figure, dir, &format!("accuracy-{n}"))?);
    }
    Ok(files)
}

/// Writes `accuracy.csv` and the figures; returns the files written.
pub fn write_study(curves: &[Curve], dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let mut csv = String::from(
        "method,stimuli,trials,mean_rmse,rmse_lo,rmse_hi,mean_spearman,spearman_lo,spearman_hi,repetitions\n",
    );
    for c in curves {
        for p in &c.points {
            writeln!(
                csv,
                "{},{},{},{:.5},{:.5},{:.5},{:.5},{:.5},{:.5},{}",
                c.method,
                c.stimuli,
                p.trials,
                p.mean_rmse,
                p.rmse_lo,
                p.rmse_hi,
                p.mean_spearman,
                p.spearman_lo,
                p.spearman_hi,
                p.repetitions
            )?;
        }
    }
    write(dir, "accuracy.csv", &csv)?;
    let mut files = vec![dir.join("accuracy.csv")];
    files.extend(write_figures(curves, dir)?);
    Ok(files)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Selection time, agreement and memory after `answers` random-pair answers of `stimuli`
/// stimuli; single-threaded.
pub fn selection_time(
    stimuli: usize,
    answers: &[usize],
    runs: usize,
    agreement_seeds: usize,
    seed: u64,
) -> anyhow::Result<serde_json::Value> {
    let truth_seed = seed_for(seed, stimuli, 999, None);
    let answer_seed = truth_seed.wrapping_add(1);
    let truth = true_scores(stimuli, truth_seed);
    let mut rng = Pcg64::seed_from_u64(answer_seed);
    let most = answers.iter().copied().max().unwrap_or(0);
    let list: Vec<Comparison> = (0..most)
        .map(|_| {
            let (i, j) = selection::random_pair(stimuli, &mut rng);
            answer(&truth, i, j, &mut rng)
        })
        .collect();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    let mut rows = Vec::new();
    for &m in answers {
        let list = &list[..m];
        let (mut fit, mut select, mut search, mut full) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut post = Posterior::prior(stimuli);
        for r in 0..runs {
            let start = Instant::now();
            post = Posterior::fit(stimuli, list)?;
            let fitted = start.elapsed();
            let mut rng = Pcg64::seed_from_u64(seed.wrapping_add(r as u64));
            let pair = selection::best_pair(&post, Evaluation::Selective, Search::Refine(REFINED_PAIRS), &mut rng);
            let total = start.elapsed();
            std::hint::black_box(pair);
            fit.push(ms(fitted));
            select.push(ms(total));
            search.push(ms(total - fitted));
        }
        for r in 0..runs.min(3) {
            let mut rng = Pcg64::seed_from_u64(seed.wrapping_add(r as u64));
            let start = Instant::now();
            std::hint::black_box(selection::best_pair(&post, Evaluation::Selective, Search::Full, &mut rng));
            full.push(ms(start.elapsed()));
        }
        // The same seed keeps the same pairs in both searches (the selective draws come
        // first, in the same order), so a difference is the refined search's alone.
        let (mut same, mut ratio) = (0usize, Vec::new());
        if m > 0 {
            for s in 0..agreement_seeds {
                let draw = |search| {
                    selection::best_pair(&post, Evaluation::Selective, search, &mut Pcg64::seed_from_u64(s as u64))
                };
                let (a, b) = (draw(Search::Refine(REFINED_PAIRS)), draw(Search::Full));
                if a == b {
                    same += 1;
                }
                if let (Some((ai, aj)), Some((bi, bj))) = (a, b) {
                    let best = selection::pair_gain(&post, bi, bj);
                    if best > 0.0 {
                        ratio.push(selection::pair_gain(&post, ai, aj) / best);
                    }
                }
            }
        }
        let kept = selection::gains(&post, Evaluation::Selective, &mut Pcg64::seed_from_u64(seed)).len();
        let pairs = stimuli * (stimuli - 1) / 2;
        let gain_size = std::mem::size_of::<PairGain>();
        rows.push(json!({
            "answers": m,
            "fit_sweeps": post.sweeps(),
            "fit_ms": median(fit),
            "refine_search_ms": median(search),
            "selection_ms": median(select),
            "full_search_ms": median(full),
            "refine_agrees_with_full": if m > 0 { json!(same as f64 / agreement_seeds as f64) } else { json!(null) },
            "refine_gain_over_full_mean": if ratio.is_empty() { json!(null) } else { json!(ratio.iter().sum::<f64>() / ratio.len() as f64) },
            "refine_gain_over_full_min": ratio.iter().copied().reduce(f64::min),
            "pairs_kept_by_selective_evaluation": kept,
            "memory_bytes": {
                "posterior": post.memory_bytes(),
                "evaluated_pairs": kept * gain_size,
                "total": post.memory_bytes() + kept * gain_size,
                "total_if_every_pair_evaluated": post.memory_bytes() + pairs * gain_size,
            },
        }));
    }
    Ok(json!({
        "stimuli": stimuli,
        "refined_pairs": REFINED_PAIRS,
        "runs": runs,
        "agreement_seeds": agreement_seeds,
        "threads": 1,
        "answers_from": format!("uniformly random pairs answered by a Thurstone observer (true scores N(0, {TRUE_SD_JOD}^2) JOD)"),
        "truth_seed": truth_seed,
        "answer_seed": answer_seed,
        "selection_includes": "Posterior::fit from all answers + best_pair(Selective, Refine(REFINED_PAIRS)); full_* is best_pair(Selective, Full) on the fitted posterior (without the fit)",
        "rows": rows,
    }))
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut plans = Vec::new();
    for &n in &args.stimuli {
        plans.push(
            Plan::for_stimuli(n, args.quick)
                .ok_or_else(|| BadInput(format!("--stimuli: {n} is not one of the simulated counts {STIMULI:?}")))?,
        );
    }
    if args.plot_only {
        let curves = read_study(&args.out.join("accuracy.csv"))?;
        for f in write_figures(&curves, &args.out)? {
            println!("{}", f.display());
        }
        return Ok(());
    }
    let threads =
        args.threads.map_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()), |t| t as usize);
    std::fs::create_dir_all(&args.out).map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", args.out.display()))?;
    let started = Instant::now();
    let (curves, found) = if args.no_study {
        (Vec::new(), Vec::new())
    } else {
        let bar = indicatif::ProgressBar::new(0).with_style(
            indicatif::ProgressStyle::with_template(
                "selection {bar:40} {pos}/{len} simulations ({msg}) {elapsed} ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let curves = run_study(args.scores, &plans, args.seed, threads, &bar)?;
        bar.finish_and_clear();
        write_study(&curves, &args.out)?;
        let found = matches(&curves);
        (curves, found)
    };
    let study_seconds = started.elapsed().as_secs_f64();
    let timing = if args.no_timing {
        json!("not run (--no-timing)")
    } else {
        let answers = if args.quick { vec![0, 1000] } else { vec![0, 1000, 4500, 10_000] };
        selection_time(225, &answers, args.timing_runs as usize, args.agreement_seeds as usize, args.seed)?
    };
    let report = json!({
        "benchmark": "selection",
        "quick": args.quick,
        "seed": args.seed,
        "seed_rule": SEED_RULE,
        "threads": threads,
        "true_scores": format!("N(0, {TRUE_SD_JOD}^2) JOD per stimulus, drawn per repetition and centred"),
        "observer": "P(i beats j) = Phi((s_i - s_j) / 1.4826), s in JOD",
        "scaling": match args.scores {
            Scores::Map => format!("analysis::scaling::fit_case_v, prior sd {} JOD", ScaleOptions::default().prior_sd),
            Scores::Posterior => "selection::Posterior::fit means x JOD_PER_UNIT (prior variance 0.5 model units)".to_owned(),
        },
        "band": "mean +- 1.96 standard errors over repetitions",
        "refined_pairs": REFINED_PAIRS,
        "plans": plans.iter().map(|p| json!({
            "stimuli": p.stimuli, "repetitions": p.repetitions, "max_trials": p.max_trials,
            "sequential_repetitions": p.sequential_repetitions, "sequential_max_trials": p.sequential_max_trials,
            "checkpoints": p.checkpoints(),
        })).collect::<Vec<_>>(),
        "study_seconds": study_seconds,
        "curves": curves.iter().map(Curve::to_json).collect::<Vec<_>>(),
        "trials_to_match_complete": found.iter().map(Match::to_json).collect::<Vec<_>>(),
        "selection_time": timing,
    });
    write(&args.out, "selection.json", &(serde_json::to_string_pretty(&report)? + "\n"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    for c in &curves {
        if let Some(p) = c.points.last() {
            println!(
                "{:>3} stimuli {:<16} {:>6} trials: RMSE {:.3} JOD [{:.3}, {:.3}], Spearman {:.3} ({} repetitions, {:.0} s)",
                c.stimuli,
                c.method,
                p.trials,
                p.mean_rmse,
                p.rmse_lo,
                p.rmse_hi,
                p.mean_spearman,
                p.repetitions,
                c.seconds
            );
        }
    }
    for m in &found {
        match m.trials {
            Some(t) => println!(
                "{:>3} stimuli: {:<16} matches the complete design's {} round(s) ({} trials, RMSE {:.3}) after {:.0} trials ({:.0} %)",
                m.stimuli,
                m.method,
                m.rounds,
                m.complete_trials,
                m.complete_rmse,
                t,
                100.0 * t / m.complete_trials as f64
            ),
            None => println!(
                "{:>3} stimuli: {:<16} does not reach the complete design's {} round(s) (RMSE {:.3}) within {} trials",
                m.stimuli, m.method, m.rounds, m.complete_rmse, m.max_trials
            ),
        }
    }
    if let Some(rows) = timing.get("rows").and_then(|r| r.as_array()) {
        for r in rows {
            println!(
                "225 stimuli after {:>5} answers: selection {:.1} ms (fit {:.1} ms + refined search {:.1} ms), full search {:.1} ms, agreement {}, memory {} bytes",
                r["answers"],
                r["selection_ms"].as_f64().unwrap_or(f64::NAN),
                r["fit_ms"].as_f64().unwrap_or(f64::NAN),
                r["refine_search_ms"].as_f64().unwrap_or(f64::NAN),
                r["full_search_ms"].as_f64().unwrap_or(f64::NAN),
                r["refine_agrees_with_full"],
                r["memory_bytes"]["total"]
            );
        }
    }
    println!("tables and figures in {}", args.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_and_rmse_of_known_vectors() {
        assert!((spearman(&[1.0, 2.0, 3.0], &[10.0, 20.0, 30.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        // Ties get mid-ranks: ranks (1.5, 1.5, 3) against (1, 2, 3).
        assert!((spearman(&[0.0, 0.0, 1.0], &[1.0, 2.0, 3.0]) - 0.866_025_403_784_438_6).abs() < 1e-12);
        assert_eq!(spearman(&[1.0, 1.0], &[1.0, 2.0]), 0.0);
        // A common shift is not an error.
        assert!(rmse(&[1.0, 2.0, 3.0], &[11.0, 12.0, 13.0]) < 1e-12);
        assert!((rmse(&[1.0, -1.0], &[0.0, 0.0]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn trials_to_reach_interpolates_on_log_trials() {
        let p = |trials, mean_rmse| Point {
            trials,
            mean_rmse,
            rmse_lo: 0.0,
            rmse_hi: 0.0,
            mean_spearman: 0.0,
            spearman_lo: 0.0,
            spearman_hi: 0.0,
            repetitions: 1,
        };
        let points = [p(10, 1.0), p(1000, 0.5), p(10_000, 0.25)];
        // Half way from 1.0 to 0.5 is half way from 10 to 1000 on a log axis: 100.
        assert!((trials_to_reach(&points, 0.75).unwrap_or(0.0) - 100.0).abs() < 1e-9);
        assert_eq!(trials_to_reach(&points, 2.0), Some(10.0));
        assert_eq!(trials_to_reach(&points, 0.1), None);
    }

    #[test]
    fn checkpoints_hold_whole_rounds_and_both_ends() {
        let plan = Plan::for_stimuli(9, false).unwrap();
        let c = plan.checkpoints();
        assert_eq!(c.first(), Some(&9));
        assert_eq!(c.last(), Some(&720));
        for r in [1, 2, 3, 5, 10, 20] {
            assert!(c.contains(&(36 * r)), "{r} rounds missing from {c:?}");
        }
        assert!(c.windows(2).all(|w| w[0] < w[1]));
        let big = Plan::for_stimuli(225, false).unwrap().checkpoints();
        assert!(big.contains(&25_200) && big.contains(&2250), "{big:?}");
    }

    /// The quick path end to end on 9 stimuli: every method learns the scale (the error falls
    /// and the ranks converge), and ASAP is not worse than random pairs after two rounds'
    /// trials by more than the noise of the repetitions; the table and figures are written.
    #[test]
    fn a_small_study_learns_the_scale_and_asap_is_not_worse_than_random() {
        let plan = Plan {
            stimuli: 9,
            repetitions: 12,
            max_trials: 5 * 36,
            sequential_repetitions: 12,
            sequential_max_trials: 5 * 36,
        };
        let curves =
            run_study(Scores::Map, std::slice::from_ref(&plan), 7, 2, &indicatif::ProgressBar::hidden()).unwrap();
        assert_eq!(curves.len(), 4);
        let curve = |m: Method| curves.iter().find(|c| c.method == m.name()).unwrap();
        let at = |m: Method, t: usize| curve(m).points.iter().find(|p| p.trials == t).unwrap().clone();
        for m in Method::ALL {
            let c = curve(m);
            let (first, last) = (&c.points[0], c.points.last().unwrap());
            assert_eq!(last.trials, 180);
            assert!(last.mean_rmse < 0.6 * first.mean_rmse, "{}: {} -> {}", m.name(), first.mean_rmse, last.mean_rmse);
            assert!(last.mean_spearman > 0.9, "{}: Spearman {}", m.name(), last.mean_spearman);
            assert!(at(m, 36).mean_rmse > at(m, 180).mean_rmse, "{}", m.name());
        }
        for m in [Method::AsapSequential, Method::AsapBatch] {
            let (a, r) = (at(m, 72), at(Method::Random, 72));
            let noise = (a.rmse_hi - a.mean_rmse).hypot(r.rmse_hi - r.mean_rmse);
            assert!(a.mean_rmse <= r.mean_rmse + noise, "{}: {} vs random {}", m.name(), a.mean_rmse, r.mean_rmse);
        }
        // Every method reaches the complete design's one-round accuracy within five rounds.
        let found = matches(&curves);
        for m in [Method::Random, Method::AsapSequential, Method::AsapBatch] {
            let one = found.iter().find(|f| f.rounds == 1 && f.method == m.name()).unwrap();
            assert!(one.trials.is_some_and(|t| t < 180.0), "{one:?}");
        }
        // The outputs: the table has a row per method and checkpoint, both figures exist.
        let dir = std::env::temp_dir().join(format!("blurlab-bench-selection-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let files = write_study(&curves, &dir).unwrap();
        let csv = std::fs::read_to_string(dir.join("accuracy.csv")).unwrap();
        let back = read_study(&dir.join("accuracy.csv")).unwrap();
        assert_eq!(back.len(), curves.len());
        assert_eq!(back[2].points.len(), curves[2].points.len());
        assert!((back[2].points[3].mean_rmse - curves[2].points[3].mean_rmse).abs() < 1e-5);
        assert_eq!(csv.lines().count(), 1 + curves.iter().map(|c| c.points.len()).sum::<usize>());
        assert!(files.iter().any(|f| f.ends_with("accuracy-9.png")) && dir.join("accuracy-9.svg").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn selection_time_reports_every_answer_count() {
        let v = selection_time(12, &[0, 40], 2, 3, 1).unwrap();
        let rows = v["rows"].as_array().unwrap();
        assert_eq!(rows.len(), 2);
        assert!(rows[0]["refine_agrees_with_full"].is_null());
        let agree = rows[1]["refine_agrees_with_full"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&agree));
        assert!(
            rows[1]["memory_bytes"]["posterior"].as_u64().unwrap()
                > rows[0]["memory_bytes"]["posterior"].as_u64().unwrap()
        );
        assert!(rows[1]["selection_ms"].as_f64().unwrap() > 0.0);
    }
}
