//! A participant's session: `RESULTS/EXPERIMENT/PARTICIPANT/session-N.csv` in the
//! `blurlab-responses/1` format (`study::response`), plus a frame-timing log beside it.
//!
//! [`Session::open`] resumes the participant's last session when it is incomplete (same
//! schedule, rebuilt from the seed in its header, continuing at the first trial without a
//! row) and otherwise starts session N+1. Resuming refuses a log whose experiment or stimulus
//! set changed, or whose rows disagree with the schedule. [`Session::record`] appends the
//! trial's row and syncs it before returning, so a kill at any moment loses at most the trial
//! on screen. A corrupt trailing row (a write cut by a kill) is reported in
//! [`Session::warnings`] and kept in the log as a comment; that trial is shown again.
//!
//! The frame log `session-N.frames.tsv` has one line per presented frame: `trial`, `slot`
//! (0-based position in the trial's `shown` list), `frame`, `due_ms` and `shown_ms` (from the
//! start of the slot's playback) and `late` (1 when shown more than one refresh after it was
//! due, or never shown). It is appended and synced just before the trial's row; a trial shown
//! again after a kill can appear twice there.
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
use study::response::{ResponseLog, SessionHeader, SessionLog, TrialRow, utc_timestamp_now};

use crate::RunnerError;
use crate::playback::PresentedFrame;
use crate::schedule::{self, Trial};
use crate::stimuli::StimulusSet;

/// Settings for a new session (ignored when resuming, except that a given seed must match).
#[derive(Clone, Debug, Default)]
pub struct SessionOptions {
    /// The schedule seed; a fresh one is drawn from the clock when absent.
    pub seed: Option<u64>,
    /// Display settings recorded in the header (one-line JSON).
    pub display: Option<serde_json::Value>,
    /// Participant attributes from the start screen, in definition order.
    pub attributes: Vec<(String, String)>,
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
}

/// An open session.
#[derive(Debug)]
pub struct Session {
    /// The definition.
    pub definition: ExperimentDefinition,
    /// The full schedule (practice included).
    pub schedule: Vec<Trial>,
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

fn fresh_seed(participant: &str) -> u64 {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_nanos();
    let code = participant.bytes().fold(0u64, |h, b| h.wrapping_mul(0x100_0000_01b3) ^ u64::from(b));
    study::seed::mix(nanos as u64, &[code, u64::from(std::process::id())])
}

impl Session {
    /// Resumes the participant's incomplete session or starts a new one.
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
        let last = existing_sessions(&dir).last().copied();
        if let Some(n) = last {
            let path = dir.join(format!("session-{n}.csv"));
            let log = SessionLog::read(&path)?;
            if !log.completed {
                return Self::resume(definition, set, &path, n, options, lock);
            }
        }
        let number = last.unwrap_or(0) + 1;
        let seed = options.seed.unwrap_or_else(|| fresh_seed(participant));
        let path = dir.join(format!("session-{number}.csv"));
        let schedule = schedule::build(definition, seed);
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
            .set("trials", schedule.len().to_string())
            .set("started", utc_timestamp_now());
        if let Some(display) = &options.display {
            header.set("display", display.to_string());
        }
        let attributes: serde_json::Map<String, serde_json::Value> =
            options.attributes.iter().map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone()))).collect();
        header.set("attributes", serde_json::Value::Object(attributes).to_string());
        let log = ResponseLog::create(&path, &header)?;
        let (frames, frames_path) = open_frame_log(&path)?;
        Ok(Session {
            definition: definition.clone(),
            schedule,
            next: 0,
            seed,
            number,
            resumed: false,
            warnings: Vec::new(),
            log,
            frames,
            frames_path,
            _lock: lock,
        })
    }

    fn resume(
        definition: &ExperimentDefinition,
        set: &StimulusSet,
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
        let schedule = schedule::build(definition, seed);
        if read.rows.len() > schedule.len() {
            return Err(bad(format!("it has {} rows but the schedule has {} trials", read.rows.len(), schedule.len())));
        }
        for (k, (line, row)) in read.rows.iter().enumerate() {
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
        let next = read.rows.len();
        if next == schedule.len() {
            log.mark_completed(&utc_timestamp_now())?;
        }
        let (frames, frames_path) = open_frame_log(path)?;
        Ok(Session {
            definition: definition.clone(),
            schedule,
            next,
            seed,
            number,
            resumed: true,
            warnings,
            log,
            frames,
            frames_path,
            _lock: lock,
        })
    }

    /// The trial to show now, if any remain.
    pub fn current(&self) -> Option<&Trial> {
        self.schedule.get(self.next)
    }

    /// Whether every trial has a row.
    pub fn is_finished(&self) -> bool {
        self.next >= self.schedule.len()
    }

    /// Counted (non-practice) trials done and in all.
    pub fn counted_progress(&self) -> (usize, usize) {
        let done = self.schedule[..self.next].iter().filter(|t| !t.practice).count();
        (done, self.schedule.iter().filter(|t| !t.practice).count())
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
        };
        self.log.append(&row)?;
        self.next += 1;
        if self.is_finished() {
            self.log.mark_completed(&utc_timestamp_now())?;
        }
        Ok(row)
    }
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
        // A completed session makes the next run a new session.
        let s = Session::open(&d, &set, &results, "P01", &opts).unwrap();
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
}
