//! Simulated observers: whole sessions without a person, through the same schedule,
//! session log and resume logic as the window (only the answers come from a model).
//!
//! Models (`--simulate MODEL`):
//! - `thurstone[:sigma=S][,file=PATH]`: Thurstone case V. Each stimulus has a latent quality;
//!   each viewing perceives it plus Gaussian noise of standard deviation `S` (default 1).
//!   2AFC picks the larger percept; matching picks the candidate whose percept is closest to
//!   the reference's. Qualities come from `PATH` (CSV lines `id,quality`; `#` comments; a
//!   stereo id falls back to its mono twin) or from [`rule_quality`].
//! - `random`: a fair coin.
//! - `flip[:sigma=S]`: the image-computable observer of [`crate::flip_observer`]: FLIP
//!   distances of the frames themselves to the gold standard (2AFC) or to the reference
//!   (matching), plus Gaussian decision noise of `S` FLIP units.
//! - `cvvdp[:reference=shutter|eye|sharp]`: the ColorVideoVDP observer of `blurlab predict`
//!   (its default reference `shutter`, the one the protocol chose on the mono tables). Its
//!   qualities (JOD against the reference) and, for matching, its JOD distances of each
//!   candidate from the shown reference are computed by the caller (the command line renders
//!   the references) and handed over with [`ObserverModel::with_cvvdp`]. A 2AFC answer prefers
//!   the first sequence with probability `Phi(z75 (Q_1 - Q_2))` (1 JOD = 75 %), a matching
//!   answer picks the first candidate with `Phi(z75 (d_2 - d_1))`: the model's expected
//!   choices plus the binomial sampling of real ones.
//!
//! Every draw for trial `k` comes from a PCG-64 seeded with `mix(seed, [OBSERVER_STREAM, k])`,
//! so an interrupted and resumed simulated session writes the same answers as an
//! uninterrupted one.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Duration;

use rand::SeedableRng;
use rand_pcg::Pcg64;
use study::experiment::ExperimentDefinition;
use study::response::Task;
use study::{StimulusId, View};

use crate::RunnerError;
use crate::schedule::Trial;
use crate::session::{Answer, Session, SessionOptions};
use crate::stimuli::StimulusSet;

/// Stream constant for observer draws.
pub const OBSERVER_STREAM: u64 = 0x0B5E_72E4;

/// Where latent qualities come from.
#[derive(Clone, Debug, PartialEq)]
pub enum Quality {
    /// [`rule_quality`].
    Rule,
    /// A table read from a file.
    Table {
        /// The file.
        path: PathBuf,
        /// Quality per stimulus.
        values: HashMap<StimulusId, f64>,
    },
}

impl Quality {
    /// The latent quality of `id`, if known.
    pub fn of(&self, id: &StimulusId) -> Option<f64> {
        match self {
            Quality::Rule => Some(rule_quality(id)),
            Quality::Table { values, .. } => values.get(id).or_else(|| values.get(&id.with_view(View::Mono))).copied(),
        }
    }

    /// Reads a table: lines `id,quality`, blank lines and `#` comments ignored.
    pub fn read(path: &Path) -> Result<Quality, RunnerError> {
        let text = std::fs::read_to_string(path).map_err(|source| RunnerError::Io { path: path.to_owned(), source })?;
        let mut values = HashMap::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') || line.eq_ignore_ascii_case("id,quality") {
                continue;
            }
            let bad =
                |m: String| RunnerError::Input { what: format!("{}: line {}", path.display(), i + 1), message: m };
            let (id, q) = line.split_once(',').ok_or_else(|| bad(format!("`{line}` is not `id,quality`")))?;
            let id: StimulusId = id.trim().parse().map_err(|e: study::ids::IdError| bad(e.to_string()))?;
            let q: f64 = q
                .trim()
                .parse()
                .ok()
                .filter(|q: &f64| q.is_finite())
                .ok_or_else(|| bad(format!("quality `{}` is not a finite number", q.trim())))?;
            if values.insert(id, q).is_some() {
                return Err(bad(format!("{id} is listed twice")));
            }
        }
        Ok(Quality::Table { path: path.to_owned(), values })
    }
}

/// The built-in latent quality, shaped after the thesis's findings: the noise material is
/// preferred (+0.5), the medium speed is best (-0.4 per level away), medium-to-long shutters
/// T3/T4 beat no blur (T1) and full blur (T5), and quality saturates with samples
/// (A4 and A5 nearly equal). Levels beyond 5 count as 5.
pub fn rule_quality(id: &StimulusId) -> f64 {
    const SHUTTER: [f64; 5] = [-1.2, -0.4, 0.3, 0.3, -0.3];
    const SAMPLES: [f64; 5] = [-1.0, -0.1, 0.1, 0.15, 0.2];
    let material = if id.material == 3 { 0.5 } else { 0.0 };
    let speed = -0.4 * (f64::from(id.speed) - 2.0).abs();
    let at = |table: &[f64; 5], level: u8| table[(usize::from(level.clamp(1, 5))) - 1];
    material + speed + at(&SHUTTER, id.shutter) + at(&SAMPLES, id.samples)
}

/// A simulated observer.
#[derive(Clone, Debug, PartialEq)]
pub enum ObserverModel {
    /// Thurstone case V with perceptual noise `sigma`.
    Thurstone {
        /// Standard deviation of each percept.
        sigma: f64,
        /// Latent qualities.
        quality: Quality,
    },
    /// Answers at random.
    Random,
    /// ColorVideoVDP qualities (JOD) and distances, with the choice probability of 1 JOD =
    /// 75 %.
    Cvvdp {
        /// The reference the qualities are judged against (`eye` or `shutter`).
        reference: String,
        /// Quality per stimulus, JOD.
        quality: HashMap<StimulusId, f64>,
        /// `(shown reference, candidate)`: `10 - JOD` of the candidate against the reference.
        distances: HashMap<(StimulusId, StimulusId), f64>,
    },
    /// FLIP distances of the frames (`crate::flip_observer`) plus Gaussian decision noise.
    Flip {
        /// Standard deviation of the decision noise, FLIP units.
        sigma: f64,
        /// `(from, to)` distances, filled by [`ObserverModel::prepare`] before the first trial.
        distances: HashMap<(StimulusId, StimulusId), f64>,
    },
}

/// A `sigma=S` parameter: finite and positive (or zero, where `zero_allowed`).
fn parse_sigma(v: &str, zero_allowed: bool) -> Result<f64, String> {
    let ok = |s: &f64| s.is_finite() && (*s > 0.0 || (zero_allowed && *s == 0.0));
    v.parse().ok().filter(ok).ok_or_else(|| {
        if zero_allowed {
            format!("sigma `{v}` is not a number >= 0")
        } else {
            format!("sigma `{v}` is not a positive number")
        }
    })
}

impl FromStr for ObserverModel {
    type Err = RunnerError;
    fn from_str(text: &str) -> Result<Self, RunnerError> {
        let bad = |m: String| RunnerError::Input { what: format!("--simulate `{text}`"), message: m };
        let (name, params) = text.split_once(':').unwrap_or((text, ""));
        match name {
            "random" if params.is_empty() => Ok(ObserverModel::Random),
            "flip" => {
                let mut sigma = crate::flip_observer::DEFAULT_SIGMA;
                for param in params.split(',').filter(|p| !p.is_empty()) {
                    match param.split_once('=') {
                        Some(("sigma", v)) => sigma = parse_sigma(v, true).map_err(bad)?,
                        _ => return Err(bad(format!("unknown parameter `{param}` (expected sigma=S)"))),
                    }
                }
                Ok(ObserverModel::Flip { sigma, distances: HashMap::new() })
            }
            "thurstone" => {
                let mut sigma = 1.0;
                let mut quality = Quality::Rule;
                for param in params.split(',').filter(|p| !p.is_empty()) {
                    match param.split_once('=') {
                        Some(("sigma", v)) => sigma = parse_sigma(v, false).map_err(bad)?,
                        Some(("file", v)) => quality = Quality::read(Path::new(v))?,
                        _ => return Err(bad(format!("unknown parameter `{param}` (expected sigma=S or file=PATH)"))),
                    }
                }
                Ok(ObserverModel::Thurstone { sigma, quality })
            }
            "cvvdp" => {
                let mut reference = "shutter".to_owned();
                for param in params.split(',').filter(|p| !p.is_empty()) {
                    match param.split_once('=') {
                        Some(("reference", v @ ("eye" | "shutter" | "sharp"))) => reference = v.to_owned(),
                        _ => {
                            return Err(bad(format!(
                                "unknown parameter `{param}` (expected reference=shutter, reference=eye or reference=sharp)"
                            )));
                        }
                    }
                }
                Ok(ObserverModel::Cvvdp { reference, quality: HashMap::new(), distances: HashMap::new() })
            }
            _ => Err(bad(
                "expected `thurstone[:sigma=S][,file=PATH]`, `flip[:sigma=S]`, `cvvdp[:reference=shutter|eye|sharp]` or `random`"
                    .into(),
            )),
        }
    }
}

impl ObserverModel {
    /// The model ready for `schedule` on `set`: a FLIP observer with the distances it needs
    /// (computed from the frames); other models as they are.
    pub fn prepare(&self, set: &StimulusSet, schedule: &[Trial]) -> Result<ObserverModel, RunnerError> {
        match self {
            ObserverModel::Flip { sigma, distances } if distances.is_empty() => {
                Ok(ObserverModel::Flip { sigma: *sigma, distances: crate::flip_observer::distances(set, schedule)? })
            }
            other => Ok(other.clone()),
        }
    }

    /// A ColorVideoVDP observer with its qualities and distances filled in.
    pub fn with_cvvdp(
        &self,
        quality: HashMap<StimulusId, f64>,
        distances: HashMap<(StimulusId, StimulusId), f64>,
    ) -> ObserverModel {
        match self {
            ObserverModel::Cvvdp { reference, .. } => {
                ObserverModel::Cvvdp { reference: reference.clone(), quality, distances }
            }
            other => other.clone(),
        }
    }

    /// Checks the model knows every stimulus of the schedule.
    pub fn check(&self, schedule: &[Trial]) -> Result<(), RunnerError> {
        if let ObserverModel::Cvvdp { quality, distances, .. } = self {
            let known = |t: &Trial, o: &StimulusId| match t.task {
                Task::TwoAfc => quality.contains_key(o),
                Task::Match => distances.contains_key(&(t.shown[0], *o)),
            };
            if let Some(t) = schedule.iter().find(|t| t.options().iter().any(|o| !known(t, o))) {
                return Err(RunnerError::Input {
                    what: "--simulate cvvdp".into(),
                    message: format!("no ColorVideoVDP quality for trial {} ({})", t.index, crate::join_ids(&t.shown)),
                });
            }
        }
        if let ObserverModel::Flip { distances, .. } = self {
            let known = |t: &Trial, o: &StimulusId| match t.task {
                Task::TwoAfc => distances.keys().any(|(_, to)| to == o),
                Task::Match => distances.contains_key(&(t.shown[0], *o)),
            };
            let missing = schedule.iter().find(|t| t.options().iter().any(|o| !known(t, o)));
            if let Some(t) = missing {
                return Err(RunnerError::Input {
                    what: "--simulate flip".into(),
                    message: format!("no FLIP distance for trial {} ({})", t.index, crate::join_ids(&t.shown)),
                });
            }
        }
        if let ObserverModel::Thurstone { quality: quality @ Quality::Table { path, .. }, .. } = self {
            let mut missing: Vec<StimulusId> =
                schedule.iter().flat_map(|t| t.shown.iter()).filter(|id| quality.of(id).is_none()).copied().collect();
            missing.sort();
            missing.dedup();
            if !missing.is_empty() {
                return Err(RunnerError::Input {
                    what: path.display().to_string(),
                    message: format!("no quality for {}", crate::join_ids(&missing)),
                });
            }
        }
        Ok(())
    }

    /// The observer's answer to `trial` (deterministic in `seed` and the trial index).
    pub fn answer(&self, trial: &Trial, seed: u64) -> Answer {
        let mut rng = Pcg64::seed_from_u64(study::seed::mix(seed, &[OBSERVER_STREAM, u64::from(trial.index)]));
        let options = trial.options();
        let (slot, difficulty) = match self {
            ObserverModel::Random => (crate::index_below(&mut rng, 2), 1.0),
            ObserverModel::Flip { sigma, distances } => {
                // 2AFC schedules hold one pair per option: (its gold standard, itself).
                let to_gold = |o: &StimulusId| distances.iter().find(|((_, to), _)| to == o).map_or(0.0, |(_, v)| *v);
                let from = |r: StimulusId, o: &StimulusId| distances.get(&(r, *o)).copied().unwrap_or(0.0);
                let (a, b) = match trial.task {
                    Task::TwoAfc => (to_gold(&options[0]), to_gold(&options[1])),
                    Task::Match => (from(trial.shown[0], &options[0]), from(trial.shown[0], &options[1])),
                };
                let (pa, pb) = (a + sigma * crate::normal(&mut rng), b + sigma * crate::normal(&mut rng));
                (usize::from(pb < pa), (a - b).abs() / sigma.max(1e-9))
            }
            ObserverModel::Cvvdp { quality, distances, .. } => {
                // `check` has made sure every value is there.
                let q = |o: &StimulusId| quality.get(o).copied().unwrap_or(0.0);
                let d = |o: &StimulusId| distances.get(&(trial.shown[0], *o)).copied().unwrap_or(0.0);
                let (a, b) = match trial.task {
                    Task::TwoAfc => (q(&options[0]), q(&options[1])),
                    // Nearer the reference is better: distances enter with their sign flipped.
                    Task::Match => (-d(&options[0]), -d(&options[1])),
                };
                let first = study::stats::jod_preference(a, b);
                (usize::from(crate::unit_f64(&mut rng) >= first), study::stats::Z75 * (a - b).abs())
            }
            ObserverModel::Thurstone { sigma, quality } => {
                let q = |id: &StimulusId| quality.of(id).unwrap_or(0.0);
                let mut percept = |id: &StimulusId| q(id) + sigma * crate::normal(&mut rng);
                match trial.task {
                    Task::TwoAfc => {
                        let (a, b) = (percept(&options[0]), percept(&options[1]));
                        (usize::from(b > a), (q(&options[0]) - q(&options[1])).abs() / sigma)
                    }
                    Task::Match => {
                        let r = percept(&trial.shown[0]);
                        let (a, b) = (percept(&options[0]), percept(&options[1]));
                        (usize::from((b - r).abs() < (a - r).abs()), (q(&options[0]) - q(&options[1])).abs() / sigma)
                    }
                }
            }
        };
        // Harder trials take longer and are replayed more often.
        let response_ms = (600.0 + 1500.0 * (-difficulty).exp() + 250.0 * crate::normal(&mut rng).abs()).round() as u64;
        let replays = u32::from(crate::unit_f64(&mut rng) < 0.4 * (-2.0 * difficulty).exp());
        // No window draws a simulated trial: scale 0 leaves the row's scale columns empty.
        Answer { slot, response_ms, replays, dropped_frames: 0, frames: Vec::new(), scale: 0.0, visual_angle_deg: 0.0 }
    }
}

/// Options of a simulated session beyond the model and seed.
#[derive(Clone, Debug, Default)]
pub struct SimulateOptions {
    /// Sleep before each answer (lets tests kill a real process mid-session).
    pub trial_delay: Duration,
    /// Stop after this many trials (the session stays incomplete and resumable).
    pub max_trials: Option<usize>,
    /// Participant attributes recorded in a new session's header.
    pub attributes: Vec<(String, String)>,
}

/// What a simulated session did.
#[derive(Clone, Debug)]
pub struct SimulationReport {
    /// The session log.
    pub path: PathBuf,
    /// Session number.
    pub session: u32,
    /// Whether an incomplete session was resumed.
    pub resumed: bool,
    /// Trial index the run started at.
    pub started_at: usize,
    /// Trials answered by this run.
    pub answered: usize,
    /// Whether the session is complete.
    pub completed: bool,
    /// Warnings from opening the session (e.g. a corrupt trailing row).
    pub warnings: Vec<String>,
}

/// Runs (or resumes) a whole session of `participant` with a simulated observer and returns
/// the session log's path: `results_dir/EXPERIMENT/PARTICIPANT/session-N.csv`. The stimulus
/// set is checked exactly as for a person (every stimulus present) before the first trial.
pub fn run_session(
    definition: &ExperimentDefinition,
    set_dir: &Path,
    results_dir: &Path,
    participant: &str,
    model: &ObserverModel,
    seed: u64,
) -> Result<PathBuf, RunnerError> {
    run_session_with(definition, set_dir, results_dir, participant, model, seed, &SimulateOptions::default())
        .map(|r| r.path)
}

/// [`run_session`] with options; returns what was done.
pub fn run_session_with(
    definition: &ExperimentDefinition,
    set_dir: &Path,
    results_dir: &Path,
    participant: &str,
    model: &ObserverModel,
    seed: u64,
    options: &SimulateOptions,
) -> Result<SimulationReport, RunnerError> {
    let set = StimulusSet::open_for(set_dir, definition)?;
    let display =
        serde_json::json!({ "mode": "simulated", "model": format!("{model:?}").chars().take(120).collect::<String>() });
    // A simulation continues with a new session after a complete one, as it always has.
    let session_options = SessionOptions {
        seed: Some(seed),
        display: Some(display),
        attributes: options.attributes.clone(),
        allow_new_session: true,
    };
    let mut session = Session::open(definition, &set, results_dir, participant, &session_options)?;
    // A budgeted selection chooses its trials as it goes: prepare the model for any pair,
    // through one trial per neighbouring pair of stimuli, which shows every stimulus.
    let mut coverage = session.schedule.clone();
    if !definition.selection.is_complete() {
        coverage.extend(definition.stimuli.windows(2).map(|w| Trial {
            index: 0,
            practice: false,
            task: definition.task,
            shown: w.to_vec(),
        }));
    }
    let model = &model.prepare(&set, &coverage)?;
    model.check(&coverage)?;
    let started_at = session.next;
    let mut answered = 0;
    while let Some(trial) = session.current().cloned() {
        if options.max_trials.is_some_and(|m| answered >= m) {
            break;
        }
        if !options.trial_delay.is_zero() {
            std::thread::sleep(options.trial_delay);
        }
        let answer = model.answer(&trial, session.seed);
        session.record(&answer)?;
        answered += 1;
    }
    Ok(SimulationReport {
        path: session.path().to_owned(),
        session: session.number,
        resumed: session.resumed,
        started_at,
        answered,
        completed: session.is_finished(),
        warnings: session.warnings.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use study::response::{SessionLog, TrialRow};

    #[test]
    fn models_parse_and_bad_ones_are_named() {
        assert_eq!("random".parse::<ObserverModel>().unwrap(), ObserverModel::Random);
        let m: ObserverModel = "thurstone:sigma=0.5".parse().unwrap();
        assert_eq!(m, ObserverModel::Thurstone { sigma: 0.5, quality: Quality::Rule });
        for (text, needle) in [
            ("gauss", "--simulate `gauss`: expected"),
            ("thurstone:sigma=-1", "sigma `-1` is not a positive number"),
            ("thurstone:mu=1", "unknown parameter `mu=1`"),
            ("thurstone:file=/nonexistent/q.csv", "/nonexistent/q.csv"),
        ] {
            let e = text.parse::<ObserverModel>().unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
        let dir = tempfile::tempdir().unwrap();
        let q = dir.path().join("q.csv");
        std::fs::write(&q, "id,quality\n# c\nM2-S2-T3-A5,1.5\nM2-S2-T3-A1,oops\n").unwrap();
        let e = format!("thurstone:file={}", q.display()).parse::<ObserverModel>().unwrap_err().to_string();
        assert!(e.contains("q.csv: line 4: quality `oops` is not a finite number"), "{e}");
        std::fs::write(&q, "M2-S2-T3-A5,1.5\n").unwrap();
        let m: ObserverModel = format!("thurstone:file={}", q.display()).parse().unwrap();
        let ObserverModel::Thurstone { quality, .. } = m else { panic!("a thurstone model") };
        assert_eq!(quality.of(&"M2-S2-T3-A5-stereo".parse().unwrap()), Some(1.5));
    }

    #[test]
    fn thurstone_observer_prefers_higher_quality_at_the_expected_rate() {
        // Quality difference 1 with sigma 1: P(prefer) = Phi(1 / sqrt 2) = 0.760.
        let a: StimulusId = "M2-S2-T3-A5".parse().unwrap();
        let b: StimulusId = "M2-S2-T3-A1".parse().unwrap();
        let values = HashMap::from([(a, 1.0), (b, 0.0)]);
        let m = ObserverModel::Thurstone { sigma: 1.0, quality: Quality::Table { path: "q".into(), values } };
        let n = 4000;
        let wins = (0..n)
            .filter(|&i| {
                let t = Trial { index: i, practice: false, task: Task::TwoAfc, shown: vec![b, a] };
                m.answer(&t, 5).slot == 1
            })
            .count();
        let p = wins as f64 / f64::from(n);
        // Binomial standard error 0.0068: allow 4.5 of them.
        assert!((p - 0.760).abs() < 0.031, "{p}");
        let t = Trial { index: 3, practice: false, task: Task::TwoAfc, shown: vec![b, a] };
        assert_eq!(m.answer(&t, 5), m.answer(&t, 5));
    }

    #[test]
    fn the_cvvdp_observer_prefers_one_jod_better_three_times_in_four() {
        let a: StimulusId = "M2-S2-T3-A5".parse().unwrap();
        let b: StimulusId = "M2-S2-T3-A1".parse().unwrap();
        let c: StimulusId = "M2-S2-T3-A3".parse().unwrap();
        let m: ObserverModel = "cvvdp:reference=shutter".parse().unwrap();
        let m = m.with_cvvdp(
            HashMap::from([(a, 8.0), (b, 7.0)]),
            // Matching: from reference a, c is 0.5 JOD away and b 1.5: c is nearer by 1 JOD.
            HashMap::from([((a, b), 1.5), ((a, c), 0.5)]),
        );
        let n = 4000;
        let rate = |task: Task, shown: Vec<StimulusId>, winner: usize| {
            let wins = (0..n)
                .filter(|&i| {
                    m.answer(&Trial { index: i, practice: false, task, shown: shown.clone() }, 9).slot == winner
                })
                .count();
            wins as f64 / f64::from(n)
        };
        // Binomial standard error 0.0068: allow 4.5 of them.
        let p = rate(Task::TwoAfc, vec![b, a], 1);
        assert!((p - 0.75).abs() < 0.031, "{p}");
        let p = rate(Task::Match, vec![a, b, c], 1);
        assert!((p - 0.75).abs() < 0.031, "{p}");
        // Without its qualities the model refuses the schedule, naming the trial.
        let bare: ObserverModel = "cvvdp".parse().unwrap();
        assert!(matches!(&bare, ObserverModel::Cvvdp { reference, .. } if reference == "shutter"));
        let e = bare.check(&[Trial { index: 0, practice: false, task: Task::TwoAfc, shown: vec![a, b] }]).unwrap_err();
        assert!(e.to_string().contains("no ColorVideoVDP quality for trial 0"), "{e}");
        let sharp: ObserverModel = "cvvdp:reference=sharp".parse().unwrap();
        assert!(matches!(&sharp, ObserverModel::Cvvdp { reference, .. } if reference == "sharp"));
        let e = "cvvdp:reference=film".parse::<ObserverModel>().unwrap_err().to_string();
        assert!(e.contains("unknown parameter `reference=film`"), "{e}");
    }

    #[test]
    fn a_whole_session_runs_headlessly_and_an_interrupted_one_resumes_identically() {
        let dir = tempfile::tempdir().unwrap();
        let d = crate::schedule::tests::definition("match", 2);
        let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        let set = dir.path().join("set");
        crate::stimuli::write_synthetic_set(&set, &ids, 8, 4, 2, 30.0).unwrap();
        let model: ObserverModel = "thurstone".parse().unwrap();
        let results = dir.path().join("results");
        let whole = run_session(&d, &set, &results, "S01", &model, 11).unwrap();
        let part_opts = SimulateOptions { max_trials: Some(7), ..Default::default() };
        let r = run_session_with(&d, &set, &results, "S02", &model, 11, &part_opts).unwrap();
        assert_eq!((r.answered, r.completed), (7, false));
        let r = run_session_with(&d, &set, &results, "S02", &model, 11, &SimulateOptions::default()).unwrap();
        assert_eq!((r.resumed, r.started_at, r.completed), (true, 7, true));
        let strip = |p: &Path| -> Vec<String> {
            SessionLog::read(p)
                .unwrap()
                .rows
                .iter()
                .map(|(_, r)| TrialRow { timestamp: String::new(), ..r.clone() }.to_line())
                .collect()
        };
        assert_eq!(strip(&whole), strip(&r.path));
        assert_eq!(strip(&whole).len(), 21);
        let log = SessionLog::read(&whole).unwrap();
        assert!(log.completed);
        assert!(log.rows.iter().all(|(_, r)| r.correct == Some(r.choice == r.shown[0])));
    }

    #[test]
    fn matching_observer_picks_the_reference_more_often_when_levels_differ_more() {
        let near: StimulusId = "M2-S2-T3-A5".parse().unwrap();
        let far: StimulusId = "M2-S2-T1-A5".parse().unwrap();
        let refq: StimulusId = "M2-S2-T5-A5".parse().unwrap();
        let values = HashMap::from([(refq, 0.0), (near, 0.5), (far, 3.0)]);
        let m = ObserverModel::Thurstone { sigma: 0.5, quality: Quality::Table { path: "q".into(), values } };
        let rate = |other: StimulusId| {
            let n = 2000;
            (0..n)
                .filter(|&i| {
                    let shown = if i % 2 == 0 { vec![refq, refq, other] } else { vec![refq, other, refq] };
                    let t = Trial { index: i, practice: false, task: Task::Match, shown };
                    let a = m.answer(&t, 9);
                    t.options()[a.slot] == refq
                })
                .count() as f64
                / f64::from(n)
        };
        let (easy, hard) = (rate(far), rate(near));
        assert!(easy > 0.97, "{easy}");
        assert!(hard > 0.55 && hard < 0.85, "{hard}");
    }
}
