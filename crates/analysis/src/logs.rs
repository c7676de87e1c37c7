//! Reading the runner's response logs (`blurlab-responses/2`, and `/1` without the scale
//! columns; docs/formats.md) into checked experiment data: every log of one experiment must
//! agree on the experiment's definition and stimulus set, every row's stimuli must belong to
//! the experiment, and the task and view must not change. Problems are errors naming the
//! file and line.
//!
//! Counted trials shown off-calibration (a recorded `scale` more than 0.5 % from the
//! calibrated `scale` in the header's `display`, the rule of
//! `study::response::off_calibration`) are kept but warned about, naming the file and the
//! trials: their judgements were made at another visual angle than the experiment asks for.
//! Practice trials are not checked (they are never analysed), nor are logs whose header
//! records no calibrated scale (simulated sessions) or rows without a scale (`/1` logs).
//!
//! Each `RESULTS` path is a log file or a folder searched recursively for `*.csv`. All logs
//! found under one path must belong to one experiment (a folder mixing experiments is an
//! error); different paths may hold different experiments (e.g. mono and stereo), which are
//! analysed separately.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Serialize;
use study::experiment::ExperimentDefinition;
use study::response::{CorruptRow, ResponseError, SessionLog, Task, off_calibration};
use study::{StimulusId, View};

/// Why logs cannot be analysed.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// A log could not be read or parsed (names file and line).
    #[error(transparent)]
    Response(#[from] ResponseError),
    /// A log disagrees with the others or with the experiment.
    #[error("{path}: line {line}: {message}")]
    Inconsistent {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// A path could not be listed, or held no logs.
    #[error("{path}: {message}")]
    Path {
        /// The path given.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
}

/// One session log's facts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Session {
    /// The log file.
    pub path: PathBuf,
    /// Participant code.
    pub participant: String,
    /// Session number or name.
    pub session: String,
    /// Participant attributes from the header's `attributes` JSON (values as text).
    pub attributes: BTreeMap<String, String>,
    /// Whether the session ran to its end.
    pub completed: bool,
    /// A partial last row that was reported and not counted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trailing_corrupt: Option<String>,
    /// Counted (non-practice) trials.
    pub trials: usize,
}

/// One counted trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Index into the experiment's sessions.
    pub session: usize,
    /// 1-based line in the log.
    pub line: usize,
    /// Stimuli in the order shown (matching: reference first).
    pub shown: Vec<StimulusId>,
    /// The chosen stimulus.
    pub choice: StimulusId,
    /// Matching: whether the answer was right.
    pub correct: Option<bool>,
}

/// The checked logs of one experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentData {
    /// Experiment name from the logs' headers.
    pub name: String,
    /// The definition's SHA-256 recorded in the logs.
    pub experiment_sha256: String,
    /// The stimulus set's SHA-256 recorded in the logs.
    pub stimulus_set_sha256: String,
    /// The task of every counted trial.
    pub task: Task,
    /// The view of every stimulus.
    pub view: View,
    /// The experiment's stimuli, sorted: from its definition when found, else those seen.
    pub stimuli: Vec<StimulusId>,
    /// Whether the definition file was found (and its hash matched).
    pub definition: Option<PathBuf>,
    /// Sessions in file-name order.
    pub sessions: Vec<Session>,
    /// Counted trials.
    pub trials: Vec<Trial>,
    /// Things the reader noticed that do not stop the analysis.
    pub warnings: Vec<String>,
}

/// Where to look for context.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Folder of experiment definitions (`NAME.toml`); used when the file's hash matches.
    pub experiments_dir: Option<PathBuf>,
    /// Stimuli of the rendered set (from its manifest); ids outside it are errors.
    pub known_stimuli: Option<BTreeSet<StimulusId>>,
}

/// The `*.csv` files under `path` (itself if it is a file), sorted.
pub fn find_logs(path: &Path) -> Result<Vec<PathBuf>, LogError> {
    let err = |message: String| LogError::Path { path: path.to_owned(), message };
    if path.is_file() {
        return Ok(vec![path.to_owned()]);
    }
    if !path.is_dir() {
        return Err(err("no such file or folder".into()));
    }
    let mut out = Vec::new();
    let mut stack = vec![path.to_owned()];
    while let Some(dir) = stack.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|e| err(format!("cannot list {}: {e}", dir.display())))?;
        for entry in entries {
            let p = entry.map_err(|e| err(e.to_string()))?.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "csv") {
                out.push(p);
            }
        }
    }
    out.sort();
    if out.is_empty() {
        return Err(err("holds no response logs (*.csv)".into()));
    }
    Ok(out)
}

/// The 1-based line of header field `key` in a log (1 if absent).
fn header_line(path: &Path, key: &str) -> usize {
    let prefix = format!("{key}:");
    std::fs::read_to_string(path)
        .ok()
        .and_then(|text| {
            text.lines().position(|l| l.strip_prefix('#').is_some_and(|c| c.trim_start().starts_with(&prefix)))
        })
        .map_or(1, |i| i + 1)
}

fn attributes(log: &SessionLog) -> Result<BTreeMap<String, String>, LogError> {
    let Some(text) = log.header.get("attributes") else { return Ok(BTreeMap::new()) };
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| LogError::Inconsistent {
        path: log.path.clone(),
        line: header_line(&log.path, "attributes"),
        message: format!("header `attributes` is not JSON: {e}"),
    })?;
    let serde_json::Value::Object(map) = value else {
        return Err(LogError::Inconsistent {
            path: log.path.clone(),
            line: header_line(&log.path, "attributes"),
            message: "header `attributes` is not a JSON object".into(),
        });
    };
    Ok(map
        .into_iter()
        .map(|(k, v)| {
            let v = match v {
                serde_json::Value::String(s) => s,
                other => other.to_string(),
            };
            (k, v)
        })
        .collect())
}

/// The calibrated scale and visual angle recorded in a log's `display` header, if it
/// records a scale; a `display` that is not JSON is reported in `warnings`.
fn calibrated_scale(log: &SessionLog, warnings: &mut Vec<String>) -> Option<(f64, Option<f64>)> {
    let text = log.header.get("display")?;
    match serde_json::from_str::<serde_json::Value>(text) {
        Ok(display) => {
            let scale = display.get("scale")?.as_f64().filter(|s| s.is_finite() && *s > 0.0)?;
            Some((scale, display.get("visual_angle_deg").and_then(serde_json::Value::as_f64)))
        }
        Err(e) => {
            warnings.push(format!(
                "{}: line {}: header `display` is not JSON ({e}); its trials' scale is not checked against the calibration",
                log.path.display(),
                header_line(&log.path, "display")
            ));
            None
        }
    }
}

/// Reads every log under `paths` and groups them by experiment, checking consistency.
pub fn load_experiments(paths: &[PathBuf], options: &LoadOptions) -> Result<Vec<ExperimentData>, LogError> {
    let mut by_name: BTreeMap<String, Vec<SessionLog>> = BTreeMap::new();
    for path in paths {
        let mut first: Option<(String, PathBuf)> = None;
        for file in find_logs(path)? {
            let log = SessionLog::read(&file)?;
            let name = log.header.get("experiment").unwrap_or_default().to_owned();
            match &first {
                None => first = Some((name.clone(), file.clone())),
                Some((first_name, first_file)) if *first_name != name => {
                    return Err(LogError::Inconsistent {
                        line: header_line(&file, "experiment"),
                        path: file,
                        message: format!(
                            "mixed experiments under {}: this log is `{name}`, {} is `{first_name}`",
                            path.display(),
                            first_file.display()
                        ),
                    });
                }
                Some(_) => {}
            }
            by_name.entry(name).or_default().push(log);
        }
    }
    by_name.into_iter().map(|(name, logs)| check_experiment(name, logs, options)).collect()
}

fn check_experiment(name: String, logs: Vec<SessionLog>, options: &LoadOptions) -> Result<ExperimentData, LogError> {
    let first = &logs[0];
    let experiment_sha256 = first.header.get("experiment_sha256").unwrap_or_default().to_owned();
    let stimulus_set_sha256 = first.header.get("stimulus_set_sha256").unwrap_or_default().to_owned();
    let mut warnings = Vec::new();
    let mut seen_sessions: BTreeMap<(String, String), PathBuf> = BTreeMap::new();
    for log in &logs {
        for (key, expected) in
            [("experiment_sha256", &experiment_sha256), ("stimulus_set_sha256", &stimulus_set_sha256)]
        {
            let found = log.header.get(key).unwrap_or_default();
            if found != expected {
                return Err(LogError::Inconsistent {
                    path: log.path.clone(),
                    line: header_line(&log.path, key),
                    message: format!(
                        "`{key}` is `{found}` but {} of the same experiment `{name}` has `{expected}`",
                        first.path.display()
                    ),
                });
            }
        }
        let key = (
            log.header.get("participant").unwrap_or_default().to_owned(),
            log.header.get("session").unwrap_or_default().to_owned(),
        );
        if let Some(other) = seen_sessions.insert(key.clone(), log.path.clone()) {
            return Err(LogError::Inconsistent {
                path: log.path.clone(),
                line: header_line(&log.path, "session"),
                message: format!("participant {} session {} is also logged in {}", key.0, key.1, other.display()),
            });
        }
    }

    // The definition, when it can be found and is the one the logs were made with.
    let mut definition = None;
    let mut defined_stimuli: Option<BTreeSet<StimulusId>> = None;
    let mut defined_task = None;
    if let Some(dir) = &options.experiments_dir {
        let file = dir.join(format!("{name}.toml"));
        if file.is_file() {
            match ExperimentDefinition::read(&file) {
                Ok(def) if def.sha256 == experiment_sha256 => {
                    defined_stimuli = Some(def.stimuli.iter().copied().collect());
                    defined_task = Some(def.task);
                    definition = Some(file);
                }
                Ok(_) => warnings.push(format!(
                    "{} differs from the definition the logs were made with (hash); stimuli taken from the logs",
                    file.display()
                )),
                Err(e) => warnings.push(format!("{e}; stimuli taken from the logs")),
            }
        }
    }

    let mut sessions = Vec::new();
    let mut trials = Vec::new();
    let mut task: Option<(Task, PathBuf, usize)> = defined_task.map(|t| (t, PathBuf::from("the definition"), 0));
    let mut view: Option<(View, PathBuf, usize)> = None;
    let mut seen = BTreeSet::new();
    for log in logs {
        let index = sessions.len();
        let mut count = 0;
        let calibrated = calibrated_scale(&log, &mut warnings);
        let mut off = Vec::new();
        for (line, row) in &log.rows {
            if row.practice {
                continue;
            }
            if let (Some((calibrated, _)), Some(scale)) = (calibrated, row.scale)
                && off_calibration(scale, calibrated)
            {
                let angle = row.visual_angle_deg.map(|a| format!(", {a:.2} degrees")).unwrap_or_default();
                off.push((row.trial, format!("trial {} (line {line}) at scale {scale:.3}{angle}", row.trial)));
            }
            let bad = |message: String| LogError::Inconsistent { path: log.path.clone(), line: *line, message };
            match &task {
                None => task = Some((row.task, log.path.clone(), *line)),
                Some((t, p, l)) if *t != row.task => {
                    return Err(bad(format!(
                        "task `{}` but experiment `{name}` is `{t}` ({} line {l})",
                        row.task,
                        p.display()
                    )));
                }
                Some(_) => {}
            }
            for id in row.shown.iter().chain([&row.choice]) {
                if let Some(known) = &defined_stimuli
                    && !known.contains(id)
                {
                    return Err(bad(format!("unknown stimulus id {id}: not a stimulus of experiment `{name}`")));
                }
                if let Some(known) = &options.known_stimuli
                    && !known.contains(id)
                {
                    return Err(bad(format!("unknown stimulus id {id}: not in the stimulus set's manifest")));
                }
                match &view {
                    None => view = Some((id.view, log.path.clone(), *line)),
                    Some((v, p, l)) if *v != id.view => {
                        return Err(bad(format!(
                            "stimulus {id} is {:?} but earlier trials are {v:?} ({} line {l}): mixed views",
                            id.view,
                            p.display()
                        )));
                    }
                    Some(_) => {}
                }
            }
            match row.task {
                Task::TwoAfc if row.shown[0] == row.shown[1] => {
                    return Err(bad(format!("2AFC trial shows {} twice", row.shown[0])));
                }
                Task::Match if row.correct.is_none() => {
                    return Err(bad("matching trial has an empty `correct` column".into()));
                }
                _ => {}
            }
            seen.extend(row.shown.iter().copied());
            trials.push(Trial {
                session: index,
                line: *line,
                shown: row.shown.clone(),
                choice: row.choice,
                correct: row.correct,
            });
            count += 1;
        }
        if let (Some((scale, angle)), false) = (calibrated, off.is_empty()) {
            let trials: Vec<String> = off.iter().map(|(t, _)| t.to_string()).collect();
            let details: Vec<String> = off.into_iter().map(|(_, d)| d).collect();
            warnings.push(format!(
                "{}: {} shown off-calibration (trials {}): the recorded scale differs by more than 0.5 % from the calibrated scale {scale:.3}{} in the header's `display`, so they subtended another visual angle than calibrated: {}",
                log.path.display(),
                if trials.len() == 1 { "1 counted trial".to_owned() } else { format!("{} counted trials", trials.len()) },
                trials.join(", "),
                angle.map(|a| format!(" ({a:.2} degrees)")).unwrap_or_default(),
                details.join("; ")
            ));
        }
        if let Some(CorruptRow { line, reason, .. }) = &log.trailing_corrupt {
            warnings.push(format!("{}: line {line}: partial last row not counted ({reason})", log.path.display()));
        }
        if !log.completed {
            warnings.push(format!("{}: session did not run to its end", log.path.display()));
        }
        sessions.push(Session {
            attributes: attributes(&log)?,
            participant: log.header.get("participant").unwrap_or_default().to_owned(),
            session: log.header.get("session").unwrap_or_default().to_owned(),
            completed: log.completed,
            trailing_corrupt: log.trailing_corrupt.as_ref().map(|c| format!("line {}: {}", c.line, c.reason)),
            trials: count,
            path: log.path,
        });
    }
    let Some((task, _, _)) = task else {
        return Err(LogError::Path {
            path: sessions[0].path.clone(),
            message: format!("experiment `{name}` has no counted trials"),
        });
    };
    let view = view.map_or(View::Mono, |v| v.0);
    let stimuli: Vec<StimulusId> = defined_stimuli.unwrap_or(seen).into_iter().collect();
    Ok(ExperimentData {
        name,
        experiment_sha256,
        stimulus_set_sha256,
        task,
        view,
        stimuli,
        definition,
        sessions,
        trials,
        warnings,
    })
}
