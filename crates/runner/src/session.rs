//! A participant's session: `RESULTS/EXPERIMENT/PARTICIPANT/session-N.csv` in the
//! `blurlab-responses/2` format (`study::response`), plus a frame-timing log beside it.
//!
//! [`Session::open`] resumes the participant's last session when it is incomplete (same
//! schedule, rebuilt from the seed in its header, continuing at the first trial without a
//! row; the participant attributes recorded in its header are kept, those given in the
//! options ignored, and reported in [`Session::recorded_attributes`]). When the last session
//! is complete it starts session N+1 only when [`SessionOptions::allow_new_session`] says the
//! experimenter confirmed it, and otherwise refuses with [`RunnerError::SessionsComplete`].
//! [`participant_status`] tells what exists beforehand, reading without locking or writing.
//! Resuming refuses a log whose experiment or stimulus set changed, or whose rows disagree
//! with the schedule. [`Session::record`] appends the
//! trial's row and syncs it before returning, so a kill at any moment loses at most the trial
//! on screen. A corrupt trailing row (a write cut by a kill) is reported in
//! [`Session::warnings`] and kept in the log as a comment; that trial is shown again.
//!
//! The frame log `session-N.frames.tsv` has one line per presented frame: `trial`, `slot`
//! (0-based position in the trial's `shown` list), `frame`, `due_ms` and `shown_ms` (from the
//! start of the slot's playback) and `late` (1 when shown more than one refresh after it was
//! due, or never shown). It is appended and synced just before the trial's row; a trial shown
//! again after a kill can appear twice there. It holds no scale: the scale and visual angle
//! at which a trial was drawn are per trial, not per frame, and are in the trial's row (the
//! `scale` and `visual_angle_deg` columns), which the frame log's `trial` column joins to;
//! repeating them on every frame line would only give two places that could disagree.
//!
//! One writer per participant: [`Session::open`] takes the lock file `session.lock` in the
//! participant's folder (`study::lock`: host, pid and start time inside) and holds it until
//! the session is dropped. A second process for the same experiment and participant is
//! refused with [`RunnerError::Locked`], naming the holder's host and pid; the lock of a
//! killed process on this host is stale and its successor takes it over.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use study::experiment::ExperimentDefinition;
use study::response::{ResponseError, ResponseLog, SessionHeader, SessionLog, TrialRow, utc_timestamp_now};

use crate::RunnerError;
use crate::playback::PresentedFrame;
use crate::schedule::{self, Trial};
use crate::stimuli::StimulusSet;

/// Settings for a new session (ignored when resuming, except that a given seed must match).
/// The default refuses a new session after a complete one (`allow_new_session` false).
#[derive(Clone, Debug, Default)]
pub struct SessionOptions {
    /// The schedule seed; a fresh one is drawn from the clock when absent.
    pub seed: Option<u64>,
    /// Display settings recorded in the header (one-line JSON).
    pub display: Option<serde_json::Value>,
    /// Participant attributes from the start screen, in definition order.
    pub attributes: Vec<(String, String)>,
    /// Whether a new session may start after the participant's last session, if that one is
    /// complete (the experimenter confirmed it). When false, [`Session::open`] refuses with
    /// [`RunnerError::SessionsComplete`] instead. Irrelevant for a first session and when
    /// resuming an incomplete one.
    pub allow_new_session: bool,
}

/// A participant's answer to the trial on screen.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Answer {
    /// 0 for the first sequence / left candidate, 1 for the second / right one.
    pub slot: usize,
    /// Milliseconds from the end of the last presentation to the answer.
    pub response_ms: u64,
    /// Replays requested.
    pub replays: u32,
    /// Frames presented late (or never).
    pub dropped_frames: u32,
    /// Every presented frame of the trial (for the frame log).
    pub frames: Vec<PresentedFrame>,
    /// Screen pixels per stimulus pixel at which the trial's stimuli were actually drawn
    /// (below the calibrated scale when the window was too small). 0 (the default) when no
    /// window drew the trial (simulated observers): the row's `scale` and `visual_angle_deg`
    /// columns are then left empty.
    pub scale: f64,
    /// The visual angle in degrees that one eye's image actually subtended at `scale`
    /// (ignored when `scale` is 0).
    pub visual_angle_deg: f64,
}

/// An open session.
#[derive(Debug)]
pub struct Session {
    /// The definition.
    pub definition: ExperimentDefinition,
    /// The schedule (practice included): every trial for a complete design; for a budgeted
    /// selection the trials shown so far and the one due, chosen when it became due.
    pub schedule: Vec<Trial>,
    /// Trials the session has in all (practice and counted).
    pub planned: usize,
    /// Index of the next trial to show (`schedule.len()` when done).
    pub next: usize,
    /// The schedule seed (from the header when resumed).
    pub seed: u64,
    /// Session number N.
    pub number: u32,
    /// Whether an incomplete session was resumed.
    pub resumed: bool,
    /// Things the participant or experimenter should know (e.g. a corrupt trailing row).
    pub warnings: Vec<String>,
    /// The participant attributes recorded in the log's header, in definition order (keys
    /// the definition does not ask for follow, alphabetically): those of the options for a new
    /// session, those recorded when it started for a resumed one.
    pub recorded_attributes: Vec<(String, String)>,
    results: PathBuf,
    log: ResponseLog,
    frames: File,
    frames_path: PathBuf,
    _lock: study::lock::LockFile,
}

/// Checks a participant code: 1-32 letters, digits, `-` or `_` (pseudonymous; no names).
pub fn check_participant(code: &str) -> Result<(), RunnerError> {
    let ok = (1..=32).contains(&code.len()) && code.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        Err(RunnerError::Input {
            what: format!("participant code `{code}`"),
            message: "use a pseudonymous code of 1-32 letters, digits, `-` or `_` (e.g. P01); never a name".into(),
        })
    }
}

/// The folder of a participant's sessions.
pub fn participant_dir(results: &Path, experiment: &str, participant: &str) -> PathBuf {
    results.join(experiment).join(participant)
}

/// The lock file of a participant's sessions.
pub fn lock_path(dir: &Path) -> PathBuf {
    dir.join("session.lock")
}

/// Takes the participant folder's session lock (creating the folder).
pub fn lock_participant(dir: &Path, participant: &str) -> Result<study::lock::LockFile, RunnerError> {
    std::fs::create_dir_all(dir).map_err(|source| RunnerError::Io { path: dir.to_owned(), source })?;
    study::lock::LockFile::acquire(&lock_path(dir)).map_err(|e| match e {
        study::lock::LockError::Held { path, holder } => {
            RunnerError::Locked { path, participant: participant.to_owned(), holder: Box::new(holder) }
        }
        study::lock::LockError::Io { path, source } => RunnerError::Io { path, source },
    })
}

/// Session numbers present in a participant folder, ascending.
pub fn existing_sessions(dir: &Path) -> Vec<u32> {
    let mut numbers: Vec<u32> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            name.strip_prefix("session-")?.strip_suffix(".csv")?.parse().ok()
        })
        .collect();
    numbers.sort_unstable();
    numbers
}

/// One session log of a participant, as [`participant_status`] found it.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionStatus {
    /// Session number N.
    pub number: u32,
    /// The log, `session-N.csv`.
    pub path: PathBuf,
    /// Counted (non-practice) trials answered (a partial last row not included).
    pub counted_answered: usize,
    /// Counted trials a session of the definition schedules (the same for every seed).
    pub counted_total: usize,
    /// Practice trials answered.
    pub practice_answered: usize,
    /// Whether the session ran to its end (`# completed` line).
    pub completed: bool,
}

/// What a participant's folder holds: see [`participant_status`].
#[derive(Clone, Debug, PartialEq)]
pub struct ParticipantStatus {
    /// The participant code.
    pub participant: String,
    /// The participant's folder (it need not exist).
    pub dir: PathBuf,
    /// The session logs, by ascending session number; empty for a new participant.
    pub sessions: Vec<SessionStatus>,
    /// The attributes recorded in the most recent session's header (`attributes` JSON), in
    /// definition order, other keys after them alphabetically; values as text. Empty for a
    /// new participant.
    pub attributes: Vec<(String, String)>,
}

impl ParticipantStatus {
    /// The most recent session.
    pub fn last(&self) -> Option<&SessionStatus> {
        self.sessions.last()
    }

    /// Whether starting now would begin a new session after a complete one, which
    /// [`Session::open`] does only with [`SessionOptions::allow_new_session`].
    pub fn new_session_needs_confirmation(&self) -> bool {
        self.last().is_some_and(|s| s.completed)
    }

    /// The session that starting now opens: the last one when it is incomplete (resumed),
    /// otherwise the next number (1 for a new participant).
    pub fn next_session(&self) -> u32 {
        match self.last() {
            Some(s) if !s.completed => s.number,
            Some(s) => s.number + 1,
            None => 1,
        }
    }
}

/// Reads the participant's existing session logs under `results` (without locking or
/// writing anything): per session the counted trials answered out of the definition's
/// counted trials, the practice trials answered and whether it is complete, and the
/// attributes recorded in the most recent session's header. A participant without a folder
/// or logs has no sessions. An invalid code, an unreadable or corrupt log, or a malformed
/// `attributes` header is an error naming the file (and line).
pub fn participant_status(
    results: &Path,
    definition: &ExperimentDefinition,
    participant: &str,
) -> Result<ParticipantStatus, RunnerError> {
    check_participant(participant)?;
    let dir = participant_dir(results, &definition.name, participant);
    let counted_total = definition.selection.counted_trials(definition.stimuli.len());
    let mut sessions = Vec::new();
    let mut attributes = Vec::new();
    for number in existing_sessions(&dir) {
        let path = dir.join(format!("session-{number}.csv"));
        let log = SessionLog::read(&path)?;
        let practice_answered = log.rows.iter().filter(|(_, r)| r.practice).count();
        attributes = recorded_attributes(&log, definition)?;
        sessions.push(SessionStatus {
            number,
            path,
            counted_answered: log.rows.len() - practice_answered,
            counted_total,
            practice_answered,
            completed: log.completed,
        });
    }
    Ok(ParticipantStatus { participant: participant.to_owned(), dir, sessions, attributes })
}

/// Attribute pairs in definition order, then the keys the definition does not ask for
/// (alphabetically, as the JSON map holds them); values as text.
fn ordered_attributes(
    mut map: serde_json::Map<String, serde_json::Value>,
    definition: &ExperimentDefinition,
) -> Vec<(String, String)> {
    let text = |v: serde_json::Value| match v {
        serde_json::Value::String(s) => s,
        other => other.to_string(),
    };
    let mut out = Vec::new();
    for a in &definition.attributes {
        if let Some(v) = map.remove(&a.key) {
            out.push((a.key.clone(), text(v)));
        }
    }
    out.extend(map.into_iter().map(|(k, v)| (k, text(v))));
    out
}

/// The attributes in a log's header (`attributes` JSON object); empty when absent.
fn recorded_attributes(
    log: &SessionLog,
    definition: &ExperimentDefinition,
) -> Result<Vec<(String, String)>, RunnerError> {
    let Some(text) = log.header.get("attributes") else { return Ok(Vec::new()) };
    let malformed = |message: String| {
        let line = std::fs::read_to_string(&log.path)
            .ok()
            .and_then(|t| {
                t.lines().position(|l| l.strip_prefix('#').is_some_and(|c| c.trim_start().starts_with("attributes:")))
            })
            .map_or(1, |i| i + 1);
        RunnerError::Response(ResponseError::Malformed { path: log.path.clone(), line, message })
    };
    match serde_json::from_str(text) {
        Ok(serde_json::Value::Object(map)) => Ok(ordered_attributes(map, definition)),
        Ok(_) => Err(malformed(format!("header `attributes` is `{text}`, not a JSON object"))),
        Err(e) => Err(malformed(format!("header `attributes` is not JSON ({e})"))),
    }
}

fn fresh_seed(participant: &str) -> u64 {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_nanos();
    let code = participant.bytes().fold(0u64, |h, b| h.wrapping_mul(0x100_0000_01b3) ^ u64::from(b));
    study::seed::mix(nanos as u64, &[code, u64::from(std::process::id())])
}

impl Session {
    /// Resumes the participant's incomplete session, or starts a new one: the first, or
    /// after a complete session only when `options.allow_new_session` (else
    /// [`RunnerError::SessionsComplete`], listing the sessions on record).
    pub fn open(
        definition: &ExperimentDefinition,
        set: &StimulusSet,
        results: &Path,
        participant: &str,
        options: &SessionOptions,
    ) -> Result<Session, RunnerError> {
        check_participant(participant)?;
        let dir = participant_dir(results, &definition.name, participant);
        let lock = lock_participant(&dir, participant)?;
        let existing = existing_sessions(&dir);
        let last = existing.last().copied();
        if let Some(n) = last {
            let path = dir.join(format!("session-{n}.csv"));
            let log = SessionLog::read(&path)?;
            if !log.completed {
                return Self::resume(definition, set, results, &path, n, options, lock);
            }
            if !options.allow_new_session {
                return Err(RunnerError::SessionsComplete {
                    participant: participant.to_owned(),
                    sessions: existing,
                    dir,
                });
            }
        }
        let number = last.unwrap_or(0) + 1;
        let seed = options.seed.unwrap_or_else(|| fresh_seed(participant));
        let path = dir.join(format!("session-{number}.csv"));
        let schedule = schedule::build(definition, seed);
        let planned = planned_trials(definition);
        let mut header = SessionHeader::default();
        header
            .set("experiment", &definition.name)
            .set("experiment_sha256", &definition.sha256)
            .set("stimulus_set_sha256", &set.sha256)
            .set("stimulus_set", set.dir.display().to_string())
            .set("software_version", study::SOFTWARE_VERSION)
            .set("seed", seed.to_string())
            .set("participant", participant)
            .set("session", number.to_string())
            .set("trials", planned.to_string())
            .set("selection", definition.selection.name())
            .set("started", utc_timestamp_now());
        if let Some(display) = &options.display {
            header.set("display", display.to_string());
        }
        let attributes: serde_json::Map<String, serde_json::Value> =
            options.attributes.iter().map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone()))).collect();
        header.set("attributes", serde_json::Value::Object(attributes.clone()).to_string());
        let recorded_attributes = ordered_attributes(attributes, definition);
        let log = ResponseLog::create(&path, &header)?;
        let (frames, frames_path) = open_frame_log(&path)?;
        let mut session = Session {
            definition: definition.clone(),
            schedule,
            planned,
            next: 0,
            seed,
            number,
            resumed: false,
            warnings: Vec::new(),
            recorded_attributes,
            results: results.to_owned(),
            log,
            frames,
            frames_path,
            _lock: lock,
        };
        session.select_due(None)?;
        Ok(session)
    }

    #[allow(clippy::too_many_arguments)]
    fn resume(
        definition: &ExperimentDefinition,
        set: &StimulusSet,
        results: &Path,
        path: &Path,
        number: u32,
        options: &SessionOptions,
        lock: study::lock::LockFile,
    ) -> Result<Session, RunnerError> {
        let bad = |message: String| RunnerError::Resume { path: path.to_owned(), message };
        let (mut log, read) = ResponseLog::resume(path)?;
        let h = &read.header;
        let get = |k: &str| h.get(k).unwrap_or("");
        if get("experiment") != definition.name {
            return Err(bad(format!(
                "it is a session of experiment `{}`, not `{}`",
                get("experiment"),
                definition.name
            )));
        }
        if get("experiment_sha256") != definition.sha256 {
            return Err(bad(format!(
                "{} changed since this session started (experiment_sha256 {} in the log, {} now); restore it or use a new participant code",
                definition.path.display(),
                get("experiment_sha256"),
                definition.sha256
            )));
        }
        // Logs of earlier versions recorded the index's hash.
        if get("stimulus_set_sha256") != set.sha256 && get("stimulus_set_sha256") != set.index_sha256 {
            return Err(bad(format!(
                "the stimulus set differs from the one this session started with (stimulus_set_sha256 {} in the log, {} for {})",
                get("stimulus_set_sha256"),
                set.sha256,
                set.dir.join("index.json").display()
            )));
        }
        let seed: u64 =
            get("seed").parse().map_err(|_| bad(format!("header `seed` is `{}`, not a number", get("seed"))))?;
        if let Some(s) = options.seed
            && s != seed
        {
            return Err(bad(format!("it was started with seed {seed}, not {s}; drop --seed to resume it")));
        }
        let mut schedule = schedule::build(definition, seed);
        let planned = planned_trials(definition);
        if read.rows.len() > planned {
            return Err(bad(format!("it has {} rows but the session has {planned} trials", read.rows.len())));
        }
        for (k, (line, row)) in read.rows.iter().enumerate() {
            if k >= schedule.len() {
                // A selected trial: whatever was chosen then, if it is a counted pair of two
                // of the experiment's stimuli.
                let known = row.shown.len() == 2
                    && row.shown[0] != row.shown[1]
                    && row.shown.iter().all(|s| definition.stimuli.binary_search(s).is_ok());
                if row.trial as usize != k || row.practice || !known || definition.selection.is_complete() {
                    return Err(bad(format!(
                        "line {line}: trial {} showed {}, which is not counted trial {k} of a {} selection over the experiment's stimuli",
                        row.trial,
                        crate::join_ids(&row.shown),
                        definition.selection.name()
                    )));
                }
                schedule.push(Trial { index: row.trial, practice: false, task: row.task, shown: row.shown.clone() });
                continue;
            }
            let t = &schedule[k];
            if row.trial as usize != k || row.shown != t.shown || row.practice != t.practice {
                return Err(bad(format!(
                    "line {line}: trial {} showed {}, but trial {k} of the schedule from seed {seed} shows {}",
                    row.trial,
                    crate::join_ids(&row.shown),
                    crate::join_ids(&t.shown)
                )));
            }
        }
        let mut warnings = Vec::new();
        if let Some(c) = &read.trailing_corrupt {
            warnings.push(format!(
                "{}: line {}: corrupt trailing row ({}) kept as a comment; trial {} will be shown again",
                path.display(),
                c.line,
                c.reason,
                read.rows.len()
            ));
        }
        let recorded_attributes = recorded_attributes(&read, definition)?;
        let next = read.rows.len();
        if next == planned {
            log.mark_completed(&utc_timestamp_now())?;
        }
        let (frames, frames_path) = open_frame_log(path)?;
        let mut session = Session {
            definition: definition.clone(),
            schedule,
            planned,
            next,
            seed,
            number,
            resumed: true,
            warnings,
            recorded_attributes,
            results: results.to_owned(),
            log,
            frames,
            frames_path,
            _lock: lock,
        };
        session.select_due(None)?;
        Ok(session)
    }

    /// Chooses the counted trial now due under a budgeted selection, if none is scheduled.
    /// ASAP reads the shared posterior, adding `answered` (this session's newest answer) or,
    /// when `None`, every answer in the experiment's logs that it lacks.
    fn select_due(&mut self, answered: Option<&TrialRow>) -> Result<(), RunnerError> {
        let d = &self.definition;
        if d.selection.is_complete() {
            return Ok(());
        }
        let due = self.next == self.schedule.len() && self.next < self.planned;
        let none_selectable = || RunnerError::Input {
            what: "selection".into(),
            message: format!("no pair could be selected among {} stimuli", d.stimuli.len()),
        };
        if !matches!(d.selection, study::experiment::PairSelection::Asap { .. }) {
            if due {
                let trial = schedule::select(d, self.seed, self.next as u32, None, &[]).ok_or_else(none_selectable)?;
                self.schedule.push(trial);
            }
            return Ok(());
        }
        let index = |s: &study::StimulusId| d.stimuli.binary_search(s).ok();
        let (seed, next) = (self.seed, self.next as u32);
        let mut chosen: Option<Trial> = None;
        let mut choose = |post: &selection::Posterior, avoid: &[(usize, usize)]| {
            if !due {
                return None;
            }
            let trial = schedule::select(d, seed, next, Some(post), avoid)?;
            let (a, b) = (index(&trial.shown[0])?, index(&trial.shown[1])?);
            chosen = Some(trial);
            Some((a.max(b), a.min(b)))
        };
        let participant = self.log_participant();
        match answered {
            Some(row) if !row.practice => {
                let (Some(a), Some(b), Some(c)) = (index(&row.shown[0]), index(&row.shown[1]), index(&row.choice))
                else {
                    return Err(RunnerError::Input {
                        what: "answer".into(),
                        message: "a counted trial showed a stimulus outside the experiment".into(),
                    });
                };
                let answer = crate::shared_posterior::RecordedAnswer {
                    participant: participant.clone(),
                    session: self.number,
                    trial: row.trial,
                    winner: c,
                    loser: if c == a { b } else { a },
                };
                crate::shared_posterior::SharedPosterior::record(
                    &self.results,
                    d,
                    &[answer],
                    Some((&participant, &mut choose)),
                )?;
            }
            _ if due => {
                crate::shared_posterior::SharedPosterior::open(&self.results, d, Some((&participant, &mut choose)))?;
            }
            _ => {}
        }
        if due {
            self.schedule.push(chosen.ok_or_else(none_selectable)?);
        }
        Ok(())
    }

    /// The participant code, from the session folder's name.
    fn log_participant(&self) -> String {
        self.log
            .path()
            .parent()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// The trial to show now, if any remain.
    pub fn current(&self) -> Option<&Trial> {
        self.schedule.get(self.next)
    }

    /// Whether every trial has a row.
    pub fn is_finished(&self) -> bool {
        self.next >= self.planned
    }

    /// Counted (non-practice) trials done and in all.
    pub fn counted_progress(&self) -> (usize, usize) {
        let done = self.schedule[..self.next].iter().filter(|t| !t.practice).count();
        (done, self.planned - self.definition.practice.len())
    }

    /// Whether a break is due before the next trial: after every `break_every` counted trials.
    pub fn break_due(&self) -> bool {
        let every = self.definition.presentation.break_every as usize;
        let (done, _) = self.counted_progress();
        let last_counted = self.next > 0 && !self.schedule[self.next - 1].practice;
        every > 0 && !self.is_finished() && last_counted && done > 0 && done % every == 0
    }

    /// The session log's path.
    pub fn path(&self) -> &Path {
        self.log.path()
    }

    /// The frame log's path.
    pub fn frames_path(&self) -> &Path {
        &self.frames_path
    }

    /// Records the answer to the current trial: frame log lines, then the row, each synced;
    /// marks the session completed after its last trial. Returns the row written.
    pub fn record(&mut self, answer: &Answer) -> Result<TrialRow, RunnerError> {
        let trial = self.current().cloned().ok_or_else(|| RunnerError::Input {
            what: "answer".into(),
            message: "the session has no trial left".into(),
        })?;
        let options = trial.options();
        let choice = *options.get(answer.slot).ok_or_else(|| RunnerError::Input {
            what: "answer".into(),
            message: format!("slot {} is not one of the {} options", answer.slot, options.len()),
        })?;
        let drawn = match (answer.scale, answer.visual_angle_deg) {
            (0.0, _) => None,
            (s, a) if s.is_finite() && s > 0.0 && a.is_finite() && a > 0.0 => Some((s, a)),
            (s, a) => {
                return Err(RunnerError::Input {
                    what: "answer".into(),
                    message: format!(
                        "the trial was drawn at scale {s} and {a} degrees; expected positive numbers (scale 0 when no window drew it)"
                    ),
                });
            }
        };
        if !answer.frames.is_empty() {
            let mut text = String::new();
            for f in &answer.frames {
                text.push_str(&format!(
                    "{}\t{}\t{}\t{:.3}\t{:.3}\t{}\n",
                    trial.index,
                    f.slot,
                    f.frame,
                    f.due_ms,
                    f.shown_ms,
                    u8::from(f.late)
                ));
            }
            let io = |source| RunnerError::Io { path: self.frames_path.clone(), source };
            self.frames.write_all(text.as_bytes()).map_err(io)?;
            self.frames.sync_data().map_err(io)?;
        }
        let row = TrialRow {
            trial: trial.index,
            practice: trial.practice,
            task: trial.task,
            shown: trial.shown.clone(),
            choice,
            correct: trial.reference().map(|r| r == choice),
            response_ms: answer.response_ms,
            replays: answer.replays,
            dropped_frames: answer.dropped_frames,
            timestamp: utc_timestamp_now(),
            scale: drawn.map(|(scale, _)| scale),
            visual_angle_deg: drawn.map(|(_, angle)| angle),
        };
        self.log.append(&row)?;
        self.next += 1;
        if self.is_finished() {
            self.log.mark_completed(&utc_timestamp_now())?;
        }
        self.select_due(Some(&row))?;
        Ok(row)
    }
}

/// Trials of a session of `definition`: practice and counted.
pub fn planned_trials(definition: &ExperimentDefinition) -> usize {
    definition.practice.len() + definition.selection.counted_trials(definition.stimuli.len())
}

fn open_frame_log(csv: &Path) -> Result<(File, PathBuf), RunnerError> {
    let path = csv.with_extension("frames.tsv");
    let io = |source| RunnerError::Io { path: path.clone(), source };
    let new = !path.exists();
    let mut file = OpenOptions::new().create(true).append(true).open(&path).map_err(io)?;
    if new {
        file.write_all(b"trial\tslot\tframe\tdue_ms\tshown_ms\tlate\n").map_err(io)?;
        file.sync_data().map_err(io)?;
    }
    Ok((file, path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stimuli::write_synthetic_set;
    use study::StimulusId;

    fn setup(task: &str) -> (tempfile::TempDir, ExperimentDefinition, StimulusSet) {
        let dir = tempfile::tempdir().unwrap();
        let d = crate::schedule::tests::definition(task, 1);
        let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        write_synthetic_set(&dir.path().join("set"), &ids, 8, 4, 2, 30.0).unwrap();
        let set = StimulusSet::open_for(&dir.path().join("set"), &d).unwrap();
        (dir, d, set)
    }

    #[test]
    fn new_session_then_resume_continues_in_the_same_order() {
        let (dir, d, set) = setup("match");
        let results = dir.path().join("results");
        let opts = SessionOptions { seed: Some(9), ..Default::default() };
        let mut s = Session::open(&d, &set, &results, "P01", &opts).unwrap();
        assert_eq!((s.number, s.next, s.resumed), (1, 0, false));
        let schedule = s.schedule.clone();
        for (k, trial) in schedule.iter().enumerate().take(4) {
            let row = s.record(&Answer { slot: k % 2, response_ms: 100, ..Default::default() }).unwrap();
            assert_eq!(row.trial, k as u32);
            assert_eq!(row.correct, Some(row.choice == trial.shown[0]));
        }
        drop(s);
        let mut s = Session::open(&d, &set, &results, "P01", &SessionOptions::default()).unwrap();
        assert_eq!((s.number, s.next, s.resumed, s.seed), (1, 4, true, 9));
        assert_eq!(s.schedule, schedule);
        while !s.is_finished() {
            s.record(&Answer::default()).unwrap();
        }
        let log = SessionLog::read(s.path()).unwrap();
        assert!(log.completed);
        assert_eq!(log.rows.len(), schedule.len());
        assert!(log.rows.iter().zip(&schedule).all(|((_, r), t)| r.shown == t.shown && r.practice == t.practice));
        assert_eq!(log.header.get("participant"), Some("P01"));
        // One writer: while the session is open, another is refused naming this process.
        let e = Session::open(&d, &set, &results, "P01", &opts).unwrap_err().to_string();
        assert!(e.contains(&format!("pid {}", std::process::id())) && e.contains("session.lock"), "{e}");
        drop(s);
        // A completed session makes the next run a new session, once confirmed.
        let confirmed = SessionOptions { allow_new_session: true, ..opts.clone() };
        let s = Session::open(&d, &set, &results, "P01", &confirmed).unwrap();
        assert_eq!((s.number, s.next), (2, 0));
    }

    #[test]
    fn resume_refuses_changed_inputs_and_reports_a_corrupt_row() {
        let (dir, d, set) = setup("2afc");
        let results = dir.path().join("results");
        let mut s =
            Session::open(&d, &set, &results, "P02", &SessionOptions { seed: Some(3), ..Default::default() }).unwrap();
        s.record(&Answer::default()).unwrap();
        s.record(&Answer::default()).unwrap();
        let path = s.path().to_owned();
        drop(s);
        let e = Session::open(&d, &set, &results, "P02", &SessionOptions { seed: Some(4), ..Default::default() })
            .unwrap_err()
            .to_string();
        assert!(e.contains("session-1.csv: cannot resume: it was started with seed 3, not 4"), "{e}");
        let mut changed = d.clone();
        changed.sha256 = "0".repeat(64);
        let e = Session::open(&changed, &set, &results, "P02", &SessionOptions::default()).unwrap_err().to_string();
        assert!(e.contains("t.toml changed since this session started"), "{e}");

        let mut text = std::fs::read_to_string(&path).unwrap();
        text.push_str("2,0,2afc,M2-S2-T1-A5|M2");
        std::fs::write(&path, text).unwrap();
        let s = Session::open(&d, &set, &results, "P02", &SessionOptions::default()).unwrap();
        assert_eq!(s.next, 2);
        assert!(
            s.warnings[0].contains("corrupt trailing row") && s.warnings[0].contains("trial 2 will be shown again")
        );

        let e = Session::open(&d, &set, &results, "Jane Doe", &SessionOptions::default()).unwrap_err().to_string();
        assert!(e.contains("participant code `Jane Doe`: use a pseudonymous code"), "{e}");
    }

    fn attribute(key: &str, options: &[&str]) -> study::experiment::Attribute {
        study::experiment::Attribute {
            key: key.into(),
            question: format!("{key}?"),
            options: options.iter().map(|o| (*o).to_owned()).collect(),
        }
    }

    fn pairs(items: &[(&str, &str)]) -> Vec<(String, String)> {
        items.iter().map(|(k, v)| ((*k).to_owned(), (*v).to_owned())).collect()
    }

    fn finish(s: &mut Session) {
        while !s.is_finished() {
            s.record(&Answer::default()).unwrap();
        }
    }

    #[test]
    fn a_complete_session_is_refused_without_confirmation_and_continued_with_it() {
        let (dir, d, set) = setup("2afc");
        let results = dir.path().join("results");
        let opts = SessionOptions { seed: Some(5), ..Default::default() };
        assert!(!opts.allow_new_session, "the default asks for confirmation");
        // A first session needs no confirmation.
        let mut s = Session::open(&d, &set, &results, "P04", &opts).unwrap();
        assert_eq!(s.number, 1);
        finish(&mut s);
        drop(s);
        let refused = Session::open(&d, &set, &results, "P04", &opts).unwrap_err();
        let e = refused.to_string();
        assert!(
            matches!(&refused, RunnerError::SessionsComplete { participant, sessions, .. } if participant == "P04" && *sessions == vec![1])
        );
        assert!(
            e.contains("P04: participant P04 has completed session 1 (on record: session-1.csv); starting a new session (session 2) must be confirmed"),
            "{e}"
        );
        assert!(refused.is_bad_input());
        // Nothing was written by the refusal, and the lock was released.
        let folder = participant_dir(&results, &d.name, "P04");
        assert_eq!(existing_sessions(&folder), vec![1]);
        assert!(!lock_path(&folder).exists());

        let confirmed = SessionOptions { allow_new_session: true, ..opts.clone() };
        let mut s = Session::open(&d, &set, &results, "P04", &confirmed).unwrap();
        assert_eq!((s.number, s.next, s.resumed), (2, 0, false));
        finish(&mut s);
        drop(s);
        let e = Session::open(&d, &set, &results, "P04", &opts).unwrap_err().to_string();
        assert!(
            e.contains(
                "has completed session 2 (on record: session-1.csv, session-2.csv); starting a new session (session 3)"
            ),
            "{e}"
        );
        // An incomplete last session resumes whatever the flag says.
        let mut s = Session::open(&d, &set, &results, "P04", &confirmed).unwrap();
        s.record(&Answer::default()).unwrap();
        drop(s);
        let s = Session::open(&d, &set, &results, "P04", &opts).unwrap();
        assert_eq!((s.number, s.next, s.resumed), (3, 1, true));
    }

    #[test]
    fn resuming_keeps_and_reports_the_recorded_attributes() {
        let (dir, mut d, set) = setup("2afc");
        d.attributes = vec![attribute("vision", &["normal", "corrected"]), attribute("cg_experience", &["yes", "no"])];
        let results = dir.path().join("results");
        // Given out of order and with a key the definition does not ask for.
        let given = pairs(&[("cg_experience", "yes"), ("zz_note", "x"), ("vision", "corrected")]);
        let opts = SessionOptions { seed: Some(2), attributes: given, ..Default::default() };
        let mut s = Session::open(&d, &set, &results, "P05", &opts).unwrap();
        let expected = pairs(&[("vision", "corrected"), ("cg_experience", "yes"), ("zz_note", "x")]);
        assert_eq!(s.recorded_attributes, expected, "definition order, then the others");
        s.record(&Answer::default()).unwrap();
        let path = s.path().to_owned();
        drop(s);
        let other = SessionOptions { attributes: pairs(&[("vision", "normal"), ("cg_experience", "no")]), ..opts };
        let s = Session::open(&d, &set, &results, "P05", &other).unwrap();
        assert!(s.resumed);
        assert_eq!(s.recorded_attributes, expected);
        drop(s);
        let log = SessionLog::read(&path).unwrap();
        assert_eq!(
            log.header.get("attributes"),
            Some(r#"{"cg_experience":"yes","vision":"corrected","zz_note":"x"}"#),
            "the header is never rewritten with the new answers"
        );
        let status = participant_status(&results, &d, "P05").unwrap();
        assert_eq!(status.attributes, expected);

        // A malformed `attributes` header refuses the resume, naming the file and line.
        let text = std::fs::read_to_string(&path).unwrap();
        let at = text.lines().position(|l| l.starts_with("# attributes:")).unwrap() + 1;
        let broken = text.replace(r#""zz_note":"x"}"#, r#""zz_note":"x""#);
        std::fs::write(&path, broken).unwrap();
        let e = Session::open(&d, &set, &results, "P05", &SessionOptions::default()).unwrap_err().to_string();
        assert!(e.contains(&format!("session-1.csv: line {at}: header `attributes` is not JSON")), "{e}");
        let e = participant_status(&results, &d, "P05").unwrap_err().to_string();
        assert!(e.contains(&format!("session-1.csv: line {at}: header `attributes` is not JSON")), "{e}");
    }

    #[test]
    fn status_of_a_new_participant_and_of_partly_done_sessions() {
        let (dir, mut d, set) = setup("match");
        d.attributes = vec![attribute("cg_experience", &["yes", "no"])];
        let results = dir.path().join("results");
        let status = participant_status(&results, &d, "P06").unwrap();
        assert!(status.sessions.is_empty() && status.attributes.is_empty());
        assert!(status.last().is_none() && !status.new_session_needs_confirmation());
        assert_eq!(status.next_session(), 1);
        assert_eq!(status.dir, participant_dir(&results, &d.name, "P06"));
        assert!(!status.dir.exists(), "reading the status creates nothing");
        let e = participant_status(&results, &d, "Jane Doe").unwrap_err().to_string();
        assert!(e.contains("participant code `Jane Doe`"), "{e}");

        // One practice trial and 10 counted ones; session 1 complete, session 2 at 1 + 3.
        let counted = schedule::build(&d, 0).iter().filter(|t| !t.practice).count();
        assert_eq!(counted, 10);
        let first = SessionOptions {
            seed: Some(8),
            attributes: pairs(&[("cg_experience", "no")]),
            allow_new_session: true,
            ..Default::default()
        };
        let mut s = Session::open(&d, &set, &results, "P06", &first).unwrap();
        finish(&mut s);
        drop(s);
        let status = participant_status(&results, &d, "P06").unwrap();
        assert!(status.new_session_needs_confirmation());
        assert_eq!(status.next_session(), 2);
        let second = SessionOptions { seed: Some(9), attributes: pairs(&[("cg_experience", "yes")]), ..first };
        let mut s = Session::open(&d, &set, &results, "P06", &second).unwrap();
        for _ in 0..4 {
            s.record(&Answer::default()).unwrap();
        }
        let lock = lock_path(s.path().parent().unwrap());
        assert!(lock.exists());
        // Read while the session is open: no lock is needed, nothing is written.
        let before = std::fs::read(s.path()).unwrap();
        let status = participant_status(&results, &d, "P06").unwrap();
        assert_eq!(std::fs::read(s.path()).unwrap(), before);
        drop(s);
        let folder = participant_dir(&results, &d.name, "P06");
        assert_eq!(
            status.sessions,
            vec![
                SessionStatus {
                    number: 1,
                    path: folder.join("session-1.csv"),
                    counted_answered: 10,
                    counted_total: 10,
                    practice_answered: 1,
                    completed: true,
                },
                SessionStatus {
                    number: 2,
                    path: folder.join("session-2.csv"),
                    counted_answered: 3,
                    counted_total: 10,
                    practice_answered: 1,
                    completed: false,
                },
            ]
        );
        assert_eq!(status.attributes, pairs(&[("cg_experience", "yes")]), "the most recent session's");
        assert!(!status.new_session_needs_confirmation());
        assert_eq!(status.next_session(), 2);

        // A corrupt log is an error naming the file and line.
        let path = folder.join("session-1.csv");
        let text = std::fs::read_to_string(&path).unwrap().replacen("\n2,0,", "\n2,x,", 1);
        std::fs::write(&path, text).unwrap();
        let e = participant_status(&results, &d, "P06").unwrap_err().to_string();
        assert!(e.contains("session-1.csv: line ") && e.contains("column `practice` is `x`"), "{e}");
    }

    #[test]
    fn the_drawn_scale_and_angle_are_logged_per_trial() {
        let (dir, d, set) = setup("2afc");
        let mut s = Session::open(&d, &set, dir.path(), "P07", &SessionOptions { seed: Some(1), ..Default::default() })
            .unwrap();
        let drawn = Answer { scale: 2.44, visual_angle_deg: 8.9, ..Default::default() };
        assert_eq!((s.record(&drawn).unwrap().scale, s.record(&Answer::default()).unwrap().scale), (Some(2.44), None));
        for bad in [(-1.0, 8.9), (f64::NAN, 8.9), (2.0, 0.0), (2.0, f64::INFINITY)] {
            let answer = Answer { scale: bad.0, visual_angle_deg: bad.1, ..Default::default() };
            let e = s.record(&answer).unwrap_err().to_string();
            assert!(e.contains("expected positive numbers (scale 0 when no window drew it)"), "{e}");
        }
        let rows: Vec<TrialRow> = SessionLog::read(s.path()).unwrap().rows.into_iter().map(|(_, r)| r).collect();
        assert_eq!(rows.len(), 2, "a refused answer writes nothing");
        assert_eq!((rows[0].scale, rows[0].visual_angle_deg), (Some(2.44), Some(8.9)));
        assert_eq!((rows[1].scale, rows[1].visual_angle_deg), (None, None));
    }

    #[test]
    fn breaks_fall_after_every_n_counted_trials() {
        let (dir, mut d, set) = setup("2afc");
        d.presentation.break_every = 4;
        let mut s = Session::open(&d, &set, dir.path(), "P03", &SessionOptions { seed: Some(1), ..Default::default() })
            .unwrap();
        let mut breaks = Vec::new();
        while !s.is_finished() {
            s.record(&Answer::default()).unwrap();
            if s.break_due() {
                breaks.push(s.counted_progress().0);
            }
        }
        assert_eq!(breaks, vec![4, 8]);
    }

    fn asap_setup(budget: u32) -> (tempfile::TempDir, ExperimentDefinition, StimulusSet) {
        let dir = tempfile::tempdir().unwrap();
        let toml = study::testing::ExperimentToml {
            task: "2afc".into(),
            question: "q".into(),
            shutter: vec![1, 2, 3, 4, 5],
            samples: vec![5],
            repeats: Some(1),
            practice: vec![study::testing::pair("M2-S2-T1-A1", "M2-S2-T5-A5")],
            ..study::testing::ExperimentToml::minimal()
        }
        .to_string()
        .replacen("[pairs]\nrepeats = 1", &format!("[pairs]\nselection = \"asap\"\nbudget = {budget}"), 1);
        let d = ExperimentDefinition::parse(Path::new("asap.toml"), &toml).unwrap();
        let ids: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        write_synthetic_set(&dir.path().join("set"), &ids, 8, 4, 2, 30.0).unwrap();
        let set = StimulusSet::open_for(&dir.path().join("set"), &d).unwrap();
        (dir, d, set)
    }

    /// Prefers the stimulus with the longer shutter (a consistent observer).
    fn prefer_longer_shutter(s: &Session) -> Answer {
        let t = s.current().unwrap();
        let o = t.options();
        Answer { slot: usize::from(o[1].shutter > o[0].shutter), ..Default::default() }
    }

    #[test]
    fn asap_sessions_share_one_posterior_that_the_logs_rebuild() {
        use crate::shared_posterior::{POSTERIOR_FILE, SharedPosterior, answers_in_logs};
        let (dir, d, set) = asap_setup(12);
        let results = dir.path().join("results");
        // Two participants at once, each answering every trial in its own thread.
        std::thread::scope(|scope| {
            for (p, seed) in [("P01", 1u64), ("P02", 2)] {
                let (d, set, results) = (&d, &set, &results);
                scope.spawn(move || {
                    let opts = SessionOptions { seed: Some(seed), ..Default::default() };
                    let mut s = Session::open(d, set, results, p, &opts).unwrap();
                    assert_eq!((s.planned, s.counted_progress()), (13, (0, 12)));
                    while !s.is_finished() {
                        let a = prefer_longer_shutter(&s);
                        s.record(&a).unwrap();
                    }
                });
            }
        });
        let exp = results.join(&d.name);
        let file = exp.join(POSTERIOR_FILE);
        let shared = SharedPosterior::read(&file, &d).unwrap();
        assert_eq!(shared.answers.len(), 24, "an update was lost");
        assert!(shared.pending.is_empty(), "finished sessions left pairs pending: {:?}", shared.pending);
        assert_eq!(shared.answers, answers_in_logs(&exp, &d).unwrap());
        // The posterior orders the stimuli as the answers did (longer shutter preferred).
        let means = shared.posterior.means();
        assert!(means.windows(2).all(|w| w[0] < w[1]), "{means:?}");
        // ASAP spreads the trials over the stimuli: every stimulus was shown.
        let shown: std::collections::BTreeSet<usize> =
            shared.answers.iter().flat_map(|a| [a.winner, a.loser]).collect();
        assert_eq!(shown.len(), 5);
        // Lost: rebuilt from the logs, byte for byte.
        let bytes = std::fs::read(&file).unwrap();
        std::fs::remove_file(&file).unwrap();
        SharedPosterior::open(&results, &d, None).unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), bytes);
    }

    #[test]
    fn a_killed_asap_session_resumes_where_it_stopped() {
        let (dir, d, set) = asap_setup(10);
        let results = dir.path().join("results");
        let opts = SessionOptions { seed: Some(5), ..Default::default() };
        let mut s = Session::open(&d, &set, &results, "P01", &opts).unwrap();
        for _ in 0..6 {
            let a = prefer_longer_shutter(&s);
            s.record(&a).unwrap();
        }
        let shown: Vec<Trial> = s.schedule[..6].to_vec();
        drop(s);
        let mut s = Session::open(&d, &set, &results, "P01", &SessionOptions::default()).unwrap();
        assert!(s.resumed);
        assert_eq!((s.next, &s.schedule[..6]), (6, &shown[..]));
        while !s.is_finished() {
            let a = prefer_longer_shutter(&s);
            s.record(&a).unwrap();
        }
        let log = SessionLog::read(s.path()).unwrap();
        assert!(log.completed);
        assert_eq!(log.rows.iter().filter(|(_, r)| !r.practice).count(), 10);
        assert_eq!(log.header.get("selection"), Some("asap"));
    }

    #[test]
    fn a_foreign_or_damaged_posterior_is_refused_naming_file_and_key() {
        use crate::shared_posterior::POSTERIOR_FILE;
        let (dir, d, set) = asap_setup(4);
        let results = dir.path().join("results");
        let opts = SessionOptions { seed: Some(3), ..Default::default() };
        let mut s = Session::open(&d, &set, &results, "P01", &opts).unwrap();
        for _ in 0..3 {
            let a = prefer_longer_shutter(&s);
            s.record(&a).unwrap();
        }
        let log_path = s.path().to_owned();
        drop(s);
        let file = results.join(&d.name).join(POSTERIOR_FILE);
        let good = std::fs::read_to_string(&file).unwrap();
        let log_bytes = std::fs::read(&log_path).unwrap();
        let cases = [
            (
                good.replacen(&format!("\"experiment\": \"{}\"", d.name), "\"experiment\": \"other\"", 1),
                "key `experiment`: is `other`",
            ),
            (good[..good.len() / 2].to_owned(), "damaged"),
            (
                good.replacen("\"mean_jod\": [\n    ", "\"mean_jod\": [\n    1.5", 1).replacen("1.5-", "1.5, -", 1),
                "key `mean_jod`",
            ),
            (good.replacen("\"winner\": ", "\"winner\": 9", 1), "key `answers`"),
        ];
        for (text, expected) in cases {
            assert_ne!(text, good);
            std::fs::write(&file, &text).unwrap();
            let e = Session::open(&d, &set, &results, "P01", &SessionOptions::default()).unwrap_err().to_string();
            assert!(e.contains(&file.display().to_string()) && e.contains(expected), "{expected}: {e}");
            assert_eq!(std::fs::read(&log_path).unwrap(), log_bytes, "the log changed");
        }
    }
}
