//! The ASAP posterior shared by every session of an experiment with `selection = "asap"`:
//! `RESULTS/EXPERIMENT/selection-posterior.json`, guarded by `RESULTS/EXPERIMENT/selection.lock`.
//!
//! The file holds the experiment's name and definition hash, its stimuli, every counted
//! answer so far (participant, session, trial, winner, loser; sorted by participant, session
//! and trial) and the posterior fitted to them (`mean_jod`, `sd_jod`). The posterior is a
//! function of the answers alone (`selection::Posterior::fit` starts from empty messages),
//! so the file is a cache the logs can always rebuild: a lost file is rebuilt from the
//! response logs, and a file whose posterior disagrees with a fit of its own answers is
//! damaged.
//!
//! **Order of writes.** A session appends and syncs the trial's row first, then updates the
//! file; a kill between the two leaves an answer the file lacks, which the next
//! [`SharedPosterior::open`] (every session start) takes from the logs. So the file's answers
//! are always a subset of the logs' counted rows; one the logs lack means the logs were
//! edited or the file belongs elsewhere, and is refused.
//!
//! **Two participants at once.** Every update is a read-modify-write of the file under the
//! experiment's selection lock (`study::lock`, waited for up to [`LOCK_WAIT`]), merging by the
//! answer's key, so concurrent sessions never lose each other's answers. Still under the lock,
//! the session chooses its next pair from the posterior that includes every answer recorded
//! so far, avoiding the pairs on other participants' screens (`pending`, one per
//! participant, kept in the file until answered): without that, two sessions at the same
//! posterior would often choose the same pair.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use selection::{Comparison, JOD_PER_UNIT, Posterior};
use serde::{Deserialize, Serialize};
use study::StimulusId;
use study::experiment::ExperimentDefinition;
use study::response::SessionLog;

use crate::RunnerError;

/// The file's format tag.
pub const POSTERIOR_FORMAT: &str = "blurlab-selection-posterior/1";
/// The file's name in the experiment's results folder.
pub const POSTERIOR_FILE: &str = "selection-posterior.json";
/// The lock's name in the experiment's results folder.
pub const LOCK_FILE: &str = "selection.lock";
/// How long an update waits for another session's update to finish.
pub const LOCK_WAIT: Duration = Duration::from_secs(30);

/// One counted answer of a session.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct RecordedAnswer {
    /// Participant code.
    pub participant: String,
    /// Session number.
    pub session: u32,
    /// Trial index in the session.
    pub trial: u32,
    /// Index of the chosen stimulus in the experiment's sorted stimuli.
    pub winner: usize,
    /// Index of the other one.
    pub loser: usize,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PosteriorFile {
    format: String,
    experiment: String,
    experiment_sha256: String,
    stimuli: Vec<String>,
    answers: Vec<RecordedAnswer>,
    #[serde(default)]
    pending: BTreeMap<String, [usize; 2]>,
    mean_jod: Vec<f64>,
    sd_jod: Vec<f64>,
}

/// The experiment's shared posterior, as read or rebuilt.
#[derive(Clone, Debug)]
pub struct SharedPosterior {
    /// The file.
    pub path: PathBuf,
    /// Every counted answer, sorted.
    pub answers: Vec<RecordedAnswer>,
    /// The posterior fitted to them.
    pub posterior: Posterior,
    /// The pair each participant has on screen (`i > j`), chosen but not yet answered.
    pub pending: BTreeMap<String, [usize; 2]>,
}

/// Chooses a participant's next pair under the lock: given the posterior and the pairs on
/// other participants' screens, the pair (`i > j`), or `None` when the session is over.
pub type Chooser<'a> = (&'a str, &'a mut dyn FnMut(&Posterior, &[(usize, usize)]) -> Option<(usize, usize)>);

/// The file as read: its posterior when it was checked.
struct ReadFile {
    path: PathBuf,
    answers: Vec<RecordedAnswer>,
    pending: BTreeMap<String, [usize; 2]>,
    posterior: Option<Posterior>,
}

fn bad(path: &Path, key: &str, message: String) -> RunnerError {
    RunnerError::Selection { path: path.to_owned(), key: key.to_owned(), message }
}

/// The experiment's results folder (`RESULTS/EXPERIMENT`).
pub fn experiment_dir(results: &Path, definition: &ExperimentDefinition) -> PathBuf {
    results.join(&definition.name)
}

/// The counted answers in every session log of the experiment under `dir`.
pub fn answers_in_logs(dir: &Path, definition: &ExperimentDefinition) -> Result<Vec<RecordedAnswer>, RunnerError> {
    let index: BTreeMap<StimulusId, usize> = definition.stimuli.iter().enumerate().map(|(i, s)| (*s, i)).collect();
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(out) };
    let mut participants: Vec<PathBuf> = entries.flatten().map(|e| e.path()).filter(|p| p.is_dir()).collect();
    participants.sort();
    for folder in participants {
        for number in crate::session::existing_sessions(&folder) {
            let path = folder.join(format!("session-{number}.csv"));
            let log = SessionLog::read(&path)?;
            if log.header.get("experiment") != Some(definition.name.as_str()) {
                continue;
            }
            let participant = log.header.get("participant").unwrap_or("").to_owned();
            for (line, row) in &log.rows {
                if row.practice {
                    continue;
                }
                let (Some(&a), Some(&b), Some(&c)) =
                    (index.get(&row.shown[0]), index.get(&row.shown[1]), index.get(&row.choice))
                else {
                    return Err(RunnerError::Resume {
                        path: path.clone(),
                        message: format!("line {line}: shows a stimulus that is not one of the experiment's"),
                    });
                };
                let loser = if c == a { b } else { a };
                out.push(RecordedAnswer {
                    participant: participant.clone(),
                    session: number,
                    trial: row.trial,
                    winner: c,
                    loser,
                });
            }
        }
    }
    out.sort();
    Ok(out)
}

fn fit(path: &Path, n: usize, answers: &[RecordedAnswer]) -> Result<Posterior, RunnerError> {
    let list: Vec<Comparison> = answers.iter().map(|a| Comparison { winner: a.winner, loser: a.loser }).collect();
    Posterior::fit(n, &list).map_err(|e| bad(path, "answers", e.to_string()))
}

impl SharedPosterior {
    /// Reads the file under the lock, adds the logs' answers it lacks (rebuilding it from
    /// the logs when it is absent), and writes it back if anything changed.
    /// With a chooser, its participant's next pair is chosen and recorded as pending.
    pub fn open(
        results: &Path,
        definition: &ExperimentDefinition,
        chooser: Option<Chooser<'_>>,
    ) -> Result<SharedPosterior, RunnerError> {
        Self::update(results, definition, &[], true, chooser)
    }

    /// Adds `new` answers (already in the logs) under the lock, lets the chooser pick its
    /// participant's next pair, and writes the file.
    pub fn record(
        results: &Path,
        definition: &ExperimentDefinition,
        new: &[RecordedAnswer],
        chooser: Option<Chooser<'_>>,
    ) -> Result<SharedPosterior, RunnerError> {
        Self::update(results, definition, new, false, chooser)
    }

    /// With `from_logs`, `new` is ignored and every answer in the logs is read, under the
    /// lock: a row reaches its log before its answer reaches the file, so the logs read then
    /// hold every answer the file holds.
    fn update(
        results: &Path,
        definition: &ExperimentDefinition,
        new: &[RecordedAnswer],
        from_logs: bool,
        chooser: Option<Chooser<'_>>,
    ) -> Result<SharedPosterior, RunnerError> {
        let dir = experiment_dir(results, definition);
        std::fs::create_dir_all(&dir).map_err(|source| RunnerError::Io { path: dir.clone(), source })?;
        let _lock = lock(&dir.join(LOCK_FILE))?;
        let logged;
        let new = if from_logs {
            logged = answers_in_logs(&dir, definition)?;
            &logged[..]
        } else {
            new
        };
        let path = dir.join(POSTERIOR_FILE);
        // A session start checks the file's posterior against its answers; an answer's update
        // refits them anyway and writes the result.
        let existing = if path.exists() { Some(Self::read_checked(&path, definition, from_logs)?) } else { None };
        let exists = existing.is_some();
        let (mut answers, mut pending, checked) = match existing {
            Some(read) => (read.answers, read.pending, read.posterior),
            None => (Vec::new(), BTreeMap::new(), None),
        };
        let pending_before = pending.clone();
        if from_logs && let Some(a) = answers.iter().find(|a| new.binary_search(a).is_err()) {
            return Err(bad(
                &path,
                "answers",
                format!(
                    "holds {} session {} trial {}, which no response log under {} has; the file belongs to other logs or was edited (remove it to rebuild it from the logs)",
                    a.participant,
                    a.session,
                    a.trial,
                    dir.display()
                ),
            ));
        }
        let before = answers.len();
        for a in new {
            if let Err(at) = answers.binary_search(a) {
                answers.insert(at, a.clone());
            }
        }
        let posterior = match checked {
            Some(p) if answers.len() == before => p,
            _ => fit(&path, definition.stimuli.len(), &answers)?,
        };
        if let Some((participant, choose)) = chooser {
            let others: Vec<(usize, usize)> =
                pending.iter().filter(|(p, _)| *p != participant).map(|(_, &[i, j])| (i, j)).collect();
            match choose(&posterior, &others) {
                Some((i, j)) => pending.insert(participant.to_owned(), [i, j]),
                None => pending.remove(participant),
            };
        }
        let shared = SharedPosterior { path: path.clone(), answers, posterior, pending };
        if !exists || shared.answers.len() != before || shared.pending != pending_before {
            shared.write(definition)?;
        }
        Ok(shared)
    }

    /// Reads and checks the file: format, experiment, stimuli, answers in range, and a
    /// posterior equal to a fit of its answers.
    pub fn read(path: &Path, definition: &ExperimentDefinition) -> Result<SharedPosterior, RunnerError> {
        let read = Self::read_checked(path, definition, true)?;
        let posterior = match read.posterior {
            Some(p) => p,
            None => fit(path, definition.stimuli.len(), &read.answers)?,
        };
        Ok(SharedPosterior { path: read.path, answers: read.answers, posterior, pending: read.pending })
    }

    /// [`SharedPosterior::read`], fitting and comparing the posterior only with `check_fit`.
    fn read_checked(path: &Path, definition: &ExperimentDefinition, check_fit: bool) -> Result<ReadFile, RunnerError> {
        let text = std::fs::read_to_string(path).map_err(|source| RunnerError::Io { path: path.to_owned(), source })?;
        let file: PosteriorFile = serde_json::from_str(&text).map_err(|e| {
            let message = e.to_string();
            let key = ["format", "experiment", "experiment_sha256", "stimuli", "answers", "mean_jod", "sd_jod"]
                .into_iter()
                .find(|k| message.contains(&format!("`{k}`")))
                .unwrap_or("(file)");
            bad(path, key, format!("damaged: {message} (remove the file to rebuild it from the response logs)"))
        })?;
        if file.format != POSTERIOR_FORMAT {
            return Err(bad(path, "format", format!("`{}`, expected `{POSTERIOR_FORMAT}`", file.format)));
        }
        if file.experiment != definition.name {
            return Err(bad(
                path,
                "experiment",
                format!(
                    "is `{}`: this is another experiment's posterior, not `{}`'s",
                    file.experiment, definition.name
                ),
            ));
        }
        if file.experiment_sha256 != definition.sha256 {
            return Err(bad(
                path,
                "experiment_sha256",
                format!(
                    "{} changed since the posterior was started ({} in the file, {} now); restore it or start a new experiment name",
                    definition.path.display(),
                    file.experiment_sha256,
                    definition.sha256
                ),
            ));
        }
        let ids: Vec<String> = definition.stimuli.iter().map(ToString::to_string).collect();
        if file.stimuli != ids {
            return Err(bad(
                path,
                "stimuli",
                format!("lists {} stimuli that are not the definition's {}", file.stimuli.len(), ids.len()),
            ));
        }
        let n = ids.len();
        if let Some(a) = file.answers.iter().find(|a| a.winner >= n || a.loser >= n || a.winner == a.loser) {
            return Err(bad(
                path,
                "answers",
                format!(
                    "{} session {} trial {}: {} over {} is not a pair of the {n} stimuli",
                    a.participant, a.session, a.trial, a.winner, a.loser
                ),
            ));
        }
        if let Some((p, pair)) = file.pending.iter().find(|(_, pair)| pair[0] >= n || pair[1] >= pair[0]) {
            return Err(bad(path, "pending", format!("{p}: {pair:?} is not a pair (i > j) of the {n} stimuli")));
        }
        if !file.answers.windows(2).all(|w| w[0] < w[1]) {
            return Err(bad(path, "answers", "are not sorted by participant, session and trial, or repeat one".into()));
        }
        if !check_fit {
            return Ok(ReadFile {
                path: path.to_owned(),
                answers: file.answers,
                pending: file.pending,
                posterior: None,
            });
        }
        let posterior = fit(path, n, &file.answers)?;
        let (mean, sd) = jod(&posterior);
        // JSON's decimal text round-trips a float to within an ulp, not always exactly.
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(1.0))
        };
        let (mean_ok, sd_ok) = (same(&mean, &file.mean_jod), same(&sd, &file.sd_jod));
        if !mean_ok || !sd_ok {
            return Err(bad(
                path,
                if mean_ok { "sd_jod" } else { "mean_jod" },
                "damaged: disagrees with a fit of the file's answers (remove the file to rebuild it from the response logs)".into(),
            ));
        }
        Ok(ReadFile { path: path.to_owned(), answers: file.answers, pending: file.pending, posterior: Some(posterior) })
    }

    fn write(&self, definition: &ExperimentDefinition) -> Result<(), RunnerError> {
        let (mean_jod, sd_jod) = jod(&self.posterior);
        let file = PosteriorFile {
            format: POSTERIOR_FORMAT.to_owned(),
            experiment: definition.name.clone(),
            experiment_sha256: definition.sha256.clone(),
            stimuli: definition.stimuli.iter().map(ToString::to_string).collect(),
            answers: self.answers.clone(),
            pending: self.pending.clone(),
            mean_jod,
            sd_jod,
        };
        let text = serde_json::to_string_pretty(&file)
            .map_err(|e| bad(&self.path, "(file)", format!("cannot serialise: {e}")))?;
        study::fsio::write_atomic(&self.path, text.as_bytes())
            .map_err(|source| RunnerError::Io { path: self.path.clone(), source })
    }
}

/// Posterior means and standard deviations in JOD.
fn jod(posterior: &Posterior) -> (Vec<f64>, Vec<f64>) {
    (
        posterior.means().iter().map(|m| m * JOD_PER_UNIT).collect(),
        posterior.variances().iter().map(|v| v.sqrt() * JOD_PER_UNIT).collect(),
    )
}

/// Takes the selection lock, waiting while another live session holds it.
fn lock(path: &Path) -> Result<study::lock::LockFile, RunnerError> {
    let deadline = std::time::Instant::now() + LOCK_WAIT;
    loop {
        match study::lock::LockFile::acquire(path) {
            Ok(l) => return Ok(l),
            Err(study::lock::LockError::Held { path, holder }) => {
                if std::time::Instant::now() > deadline {
                    return Err(RunnerError::Selection {
                        path,
                        key: "(lock)".into(),
                        message: format!("held by {holder} for over {} s", LOCK_WAIT.as_secs()),
                    });
                }
                std::thread::sleep(Duration::from_millis(3));
            }
            Err(study::lock::LockError::Io { path, source }) => return Err(RunnerError::Io { path, source }),
        }
    }
}
