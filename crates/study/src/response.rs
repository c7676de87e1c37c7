//! The durable response log: one CSV file per participant session with a commented header
//! and one row per trial, appended and synced before the next trial starts. The runner
//! writes it, the analysis reads it; docs/formats.md describes it.
//!
//! A log killed mid-write can end in a partial row. Reading reports such a trailing row
//! (it is never silently dropped); [`ResponseLog::resume`] keeps its text as a comment line
//! and appends after it.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::fsio::write_atomic;
use crate::ids::StimulusId;

/// First line of every log.
pub const RESPONSES_FORMAT: &str = "blurlab-responses/1";
/// The column header row.
pub const COLUMNS: &str = "trial,practice,task,shown,choice,correct,response_ms,replays,dropped_frames,timestamp";
const COLUMN_COUNT: usize = 10;
/// Header keys every log must have.
pub const REQUIRED_KEYS: [&str; 7] =
    ["experiment", "experiment_sha256", "stimulus_set_sha256", "software_version", "seed", "participant", "session"];

/// The kind of trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Task {
    /// Two-alternative forced choice: which of two sequences has higher quality.
    #[serde(rename = "2afc")]
    TwoAfc,
    /// Matching: which of two candidates matches the reference.
    #[serde(rename = "match")]
    Match,
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Task::TwoAfc => "2afc",
            Task::Match => "match",
        })
    }
}

impl FromStr for Task {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "2afc" => Ok(Task::TwoAfc),
            "match" => Ok(Task::Match),
            _ => Err(format!("task `{s}` is neither `2afc` nor `match`")),
        }
    }
}

/// The commented header: ordered `key: value` pairs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SessionHeader {
    /// Fields in file order.
    pub fields: Vec<(String, String)>,
}

impl SessionHeader {
    /// Adds or replaces a field.
    pub fn set(&mut self, key: &str, value: impl Into<String>) -> &mut Self {
        let value = value.into().replace(['\n', '\r'], " ");
        match self.fields.iter_mut().find(|(k, _)| k == key) {
            Some(slot) => slot.1 = value,
            None => self.fields.push((key.to_owned(), value)),
        }
        self
    }

    /// The value of a field.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.fields.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }
}

/// One trial's response.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRow {
    /// Trial index in the session's schedule, from 0 (practice trials included).
    pub trial: u32,
    /// Practice trials are logged but never analysed.
    pub practice: bool,
    /// Task of the trial.
    pub task: Task,
    /// Stimuli in the order shown; for matching the reference first, then the candidates.
    pub shown: Vec<StimulusId>,
    /// The stimulus the participant chose.
    pub choice: StimulusId,
    /// For matching: whether the chosen candidate is the reference's match.
    pub correct: Option<bool>,
    /// Milliseconds from the end of the last presentation to the answer.
    pub response_ms: u64,
    /// How many times the participant replayed.
    pub replays: u32,
    /// Frames presented late during the trial.
    pub dropped_frames: u32,
    /// UTC time of the answer, RFC 3339.
    pub timestamp: String,
}

impl TrialRow {
    /// The CSV line (without newline).
    pub fn to_line(&self) -> String {
        let shown: Vec<String> = self.shown.iter().map(ToString::to_string).collect();
        let correct = match self.correct {
            Some(true) => "1",
            Some(false) => "0",
            None => "",
        };
        format!(
            "{},{},{},{},{},{},{},{},{},{}",
            self.trial,
            u8::from(self.practice),
            self.task,
            shown.join("|"),
            self.choice,
            correct,
            self.response_ms,
            self.replays,
            self.dropped_frames,
            self.timestamp
        )
    }

    /// Parses a CSV line.
    pub fn parse_line(line: &str) -> Result<Self, String> {
        let cols: Vec<&str> = line.split(',').collect();
        if cols.len() != COLUMN_COUNT {
            return Err(format!("found {} columns, expected {COLUMN_COUNT} ({COLUMNS})", cols.len()));
        }
        let num = |i: usize, name: &str| -> Result<u64, String> {
            cols[i].parse::<u64>().map_err(|_| format!("column `{name}` is `{}`, expected a whole number", cols[i]))
        };
        let flag = |i: usize, name: &str| -> Result<Option<bool>, String> {
            match cols[i] {
                "1" => Ok(Some(true)),
                "0" => Ok(Some(false)),
                "" => Ok(None),
                other => Err(format!("column `{name}` is `{other}`, expected 0, 1 or empty")),
            }
        };
        let id = |text: &str| text.parse::<StimulusId>().map_err(|e| e.to_string());
        let shown = cols[3].split('|').map(id).collect::<Result<Vec<_>, _>>()?;
        let choice = id(cols[4])?;
        let task: Task = cols[2].parse()?;
        let expected_shown = match task {
            Task::TwoAfc => 2,
            Task::Match => 3,
        };
        if shown.len() != expected_shown {
            return Err(format!("task {task} shows {expected_shown} stimuli, column `shown` lists {}", shown.len()));
        }
        let offered = if task == Task::Match { &shown[1..] } else { &shown[..] };
        if !offered.contains(&choice) {
            return Err(format!("choice {choice} is not one of the offered stimuli"));
        }
        let to_u32 = |v: u64, name: &str| u32::try_from(v).map_err(|_| format!("column `{name}` is too large"));
        Ok(TrialRow {
            trial: to_u32(num(0, "trial")?, "trial")?,
            practice: flag(1, "practice")?.ok_or("column `practice` is empty, expected 0 or 1")?,
            task,
            shown,
            choice,
            correct: flag(5, "correct")?,
            response_ms: num(6, "response_ms")?,
            replays: to_u32(num(7, "replays")?, "replays")?,
            dropped_frames: to_u32(num(8, "dropped_frames")?, "dropped_frames")?,
            timestamp: cols[9].to_owned(),
        })
    }
}

/// A trailing line that is not a complete row (a write interrupted by a kill).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CorruptRow {
    /// 1-based line number.
    pub line: usize,
    /// The text found.
    pub text: String,
    /// Why it is not a row.
    pub reason: String,
}

/// A parsed session log.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionLog {
    /// The file read.
    pub path: PathBuf,
    /// Header fields.
    pub header: SessionHeader,
    /// Complete rows in order, with their 1-based line numbers.
    pub rows: Vec<(usize, TrialRow)>,
    /// A partial last row, reported rather than dropped.
    pub trailing_corrupt: Option<CorruptRow>,
    /// Whether the session ran to its end (`# completed:` line present).
    pub completed: bool,
}

/// Why a log cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ResponseError {
    /// I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: io::Error,
    },
    /// A malformed line other than a trailing partial row.
    #[error("{path}: line {line}: {message}")]
    Malformed {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What was wrong.
        message: String,
    },
}

impl SessionLog {
    /// Reads a session log, validating header and rows.
    pub fn read(path: &Path) -> Result<Self, ResponseError> {
        let bytes = std::fs::read(path).map_err(|source| ResponseError::Io { path: path.to_owned(), source })?;
        let text = String::from_utf8_lossy(&bytes);
        Self::parse(path, &text)
    }

    /// Parses log text read from `path`. A leading byte-order mark is skipped. Ambiguous
    /// logs are errors naming the line: a header key given twice with different values (in
    /// the header or as a comment among the rows), a `session` that is not a number, a second
    /// format line or column row (two logs concatenated), a row after `# completed`, and a
    /// trial number that repeats an earlier row's or does not follow it.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ResponseError> {
        let bad = |line: usize, message: String| ResponseError::Malformed { path: path.to_owned(), line, message };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let ends_with_newline = text.ends_with('\n');
        let lines: Vec<&str> = text.lines().collect();
        if lines.first().map(|l| l.trim()) != Some(&format!("# {RESPONSES_FORMAT}")[..]) {
            return Err(bad(1, format!("expected `# {RESPONSES_FORMAT}` as the first line")));
        }
        let mut header = SessionHeader::default();
        let mut header_lines: Vec<usize> = Vec::new();
        let mut rows: Vec<(usize, TrialRow)> = Vec::new();
        let mut completed: Option<usize> = None;
        let mut trailing_corrupt = None;
        let mut seen_columns = false;
        let mut trial_lines: std::collections::BTreeMap<u32, usize> = std::collections::BTreeMap::new();
        for (i, raw) in lines.iter().enumerate().skip(1) {
            let line_no = i + 1;
            let is_last = i + 1 == lines.len();
            if let Some(comment) = raw.strip_prefix('#') {
                let comment = comment.trim();
                if comment.starts_with("completed:") {
                    completed.get_or_insert(line_no);
                } else if comment == RESPONSES_FORMAT {
                    return Err(bad(line_no, "a second log begins here (two logs concatenated into one file)".into()));
                } else if !seen_columns {
                    let (k, v) = comment
                        .split_once(':')
                        .ok_or_else(|| bad(line_no, format!("header line `{raw}` is not `# key: value`")))?;
                    let (k, v) = (k.trim(), v.trim());
                    if let Some(at) = header.fields.iter().position(|(key, _)| key == k) {
                        if header.fields[at].1 != v {
                            return Err(bad(
                                line_no,
                                format!(
                                    "header key `{k}` is `{v}` here and `{}` on line {}: ambiguous",
                                    header.fields[at].1, header_lines[at]
                                ),
                            ));
                        }
                    } else {
                        header.fields.push((k.to_owned(), v.to_owned()));
                        header_lines.push(line_no);
                    }
                } else if let Some((k, v)) = comment.split_once(':')
                    && let Some(at) = header.fields.iter().position(|(key, _)| key == k.trim())
                    && header.fields[at].1 != v.trim()
                {
                    return Err(bad(
                        line_no,
                        format!(
                            "header key `{}` is repeated among the rows as `{}`, and is `{}` on line {}: ambiguous",
                            k.trim(),
                            v.trim(),
                            header.fields[at].1,
                            header_lines[at]
                        ),
                    ));
                }
                continue;
            }
            if !seen_columns {
                if raw.trim() != COLUMNS {
                    return Err(bad(line_no, format!("expected the column row `{COLUMNS}`")));
                }
                seen_columns = true;
                continue;
            }
            if raw.trim() == COLUMNS {
                return Err(bad(line_no, "a second column row (two logs concatenated into one file)".into()));
            }
            let row = match TrialRow::parse_line(raw) {
                Ok(row) if !is_last || ends_with_newline => row,
                Ok(_) => {
                    trailing_corrupt = Some(CorruptRow {
                        line: line_no,
                        text: (*raw).to_owned(),
                        reason: "the last row has no line end (interrupted write)".into(),
                    });
                    continue;
                }
                Err(reason) if is_last => {
                    trailing_corrupt = Some(CorruptRow { line: line_no, text: (*raw).to_owned(), reason });
                    continue;
                }
                Err(message) => return Err(bad(line_no, message)),
            };
            if let Some(done) = completed {
                return Err(bad(line_no, format!("a row after `# completed` on line {done}")));
            }
            if let Some(other) = trial_lines.insert(row.trial, line_no) {
                return Err(bad(line_no, format!("trial {} is also on line {other} (duplicated trial)", row.trial)));
            }
            let expected = rows.last().map_or(0, |(_, r)| r.trial.saturating_add(1));
            if row.trial != expected {
                return Err(bad(line_no, format!("trial {} where trial {expected} was expected", row.trial)));
            }
            rows.push((line_no, row));
        }
        if !seen_columns {
            return Err(bad(lines.len() + 1, format!("missing the column row `{COLUMNS}`")));
        }
        for key in REQUIRED_KEYS {
            if header.get(key).is_none() {
                return Err(bad(1, format!("header has no `# {key}: ...` line")));
            }
        }
        if let Some(at) = header.fields.iter().position(|(k, _)| k == "session")
            && header.fields[at].1.parse::<u32>().is_err()
        {
            return Err(bad(
                header_lines[at],
                format!("header key `session` is `{}`, not a session number", header.fields[at].1),
            ));
        }
        Ok(SessionLog { path: path.to_owned(), header, rows, trailing_corrupt, completed: completed.is_some() })
    }
}

/// An open log that rows are appended to, each synced to disk before `append` returns.
#[derive(Debug)]
pub struct ResponseLog {
    path: PathBuf,
    file: File,
}

impl ResponseLog {
    /// Creates a new log with `header` (atomically: the file appears complete or not at all).
    /// Fails if the file exists.
    pub fn create(path: &Path, header: &SessionHeader) -> Result<Self, ResponseError> {
        let io_err = |source| ResponseError::Io { path: path.to_owned(), source };
        if path.exists() {
            return Err(io_err(io::Error::new(io::ErrorKind::AlreadyExists, "session log already exists")));
        }
        let mut text = format!("# {RESPONSES_FORMAT}\n");
        for (k, v) in &header.fields {
            text.push_str(&format!("# {k}: {v}\n"));
        }
        text.push_str(COLUMNS);
        text.push('\n');
        write_atomic(path, text.as_bytes()).map_err(io_err)?;
        let file = OpenOptions::new().append(true).open(path).map_err(io_err)?;
        Ok(ResponseLog { path: path.to_owned(), file })
    }

    /// Reopens an existing log to continue it. A corrupt trailing row is kept as a comment
    /// (`# corrupt-trailing-row line N: ...`) so nothing is lost, and returned in the log.
    pub fn resume(path: &Path) -> Result<(Self, SessionLog), ResponseError> {
        let io_err = |source| ResponseError::Io { path: path.to_owned(), source };
        let log = SessionLog::read(path)?;
        if let Some(corrupt) = &log.trailing_corrupt {
            let text = std::fs::read_to_string(path).map_err(io_err)?;
            let mut kept: Vec<&str> = text.lines().collect();
            kept.truncate(corrupt.line - 1);
            let mut repaired = kept.join("\n");
            repaired.push_str(&format!(
                "\n# corrupt-trailing-row line {}: {} ({})\n",
                corrupt.line, corrupt.text, corrupt.reason
            ));
            write_atomic(path, repaired.as_bytes()).map_err(io_err)?;
        }
        let file = OpenOptions::new().append(true).open(path).map_err(io_err)?;
        Ok((ResponseLog { path: path.to_owned(), file }, log))
    }

    /// Appends one row and syncs it to disk.
    pub fn append(&mut self, row: &TrialRow) -> Result<(), ResponseError> {
        self.write_synced(&format!("{}\n", row.to_line()))
    }

    /// Marks the session complete.
    pub fn mark_completed(&mut self, timestamp: &str) -> Result<(), ResponseError> {
        self.write_synced(&format!("# completed: {timestamp}\n"))
    }

    fn write_synced(&mut self, text: &str) -> Result<(), ResponseError> {
        let io_err = |source| ResponseError::Io { path: self.path.clone(), source };
        self.file.write_all(text.as_bytes()).map_err(io_err)?;
        self.file.sync_data().map_err(io_err)
    }

    /// The log's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// The current UTC time as RFC 3339 with milliseconds, e.g. `2026-11-23T11:24:00.123Z`.
pub fn utc_timestamp_now() -> String {
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    utc_timestamp(now.as_millis() as i64)
}

/// Formats milliseconds since the Unix epoch as RFC 3339 UTC.
pub fn utc_timestamp(unix_ms: i64) -> String {
    let secs = unix_ms.div_euclid(1000);
    let ms = unix_ms.rem_euclid(1000);
    let days = secs.div_euclid(86_400);
    let sod = secs.rem_euclid(86_400);
    // Civil-from-days (proleptic Gregorian), after H. Hinnant's published algorithm.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{ms:03}Z", sod / 3600, (sod / 60) % 60, sod % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> SessionHeader {
        let mut h = SessionHeader::default();
        for k in REQUIRED_KEYS {
            h.set(k, format!("{k}-value"));
        }
        h.set("session", "1");
        h
    }

    fn row(trial: u32) -> TrialRow {
        TrialRow {
            trial,
            practice: trial == 0,
            task: Task::TwoAfc,
            shown: vec!["M2-S2-T3-A5".parse().unwrap(), "M2-S2-T5-A5".parse().unwrap()],
            choice: "M2-S2-T5-A5".parse().unwrap(),
            correct: None,
            response_ms: 1200,
            replays: 1,
            dropped_frames: 0,
            timestamp: utc_timestamp(0),
        }
    }

    #[test]
    fn timestamps_match_known_dates() {
        assert_eq!(utc_timestamp(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(utc_timestamp(951_782_400_000), "2000-02-29T00:00:00.000Z");
        assert_eq!(utc_timestamp(1_795_433_040_123), "2026-11-23T11:24:00.123Z");
    }

    #[test]
    fn written_rows_read_back_and_partial_row_is_reported_then_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session-1.csv");
        let mut log = ResponseLog::create(&path, &header()).unwrap();
        log.append(&row(0)).unwrap();
        log.append(&row(1)).unwrap();
        drop(log);
        let read = SessionLog::read(&path).unwrap();
        assert_eq!(read.rows.iter().map(|(_, r)| r.clone()).collect::<Vec<_>>(), vec![row(0), row(1)]);
        assert!(read.trailing_corrupt.is_none() && !read.completed);

        // A kill in the middle of a write leaves half a row.
        let mut text = std::fs::read_to_string(&path).unwrap();
        text.push_str("2,0,2afc,M2-S2-T3-A5|M2");
        std::fs::write(&path, &text).unwrap();
        let read = SessionLog::read(&path).unwrap();
        assert_eq!(read.rows.len(), 2);
        let corrupt = read.trailing_corrupt.unwrap();
        assert_eq!(corrupt.line, 12);

        let (mut log, before) = ResponseLog::resume(&path).unwrap();
        assert!(before.trailing_corrupt.is_some());
        log.append(&row(2)).unwrap();
        log.mark_completed("now").unwrap();
        let after = std::fs::read_to_string(&path).unwrap();
        assert!(after.contains("# corrupt-trailing-row line 12: 2,0,2afc,M2-S2-T3-A5|M2"));
        let read = SessionLog::read(&path).unwrap();
        assert_eq!(read.rows.len(), 3);
        assert!(read.completed && read.trailing_corrupt.is_none());
    }

    #[test]
    fn ambiguous_logs_are_errors_naming_the_line_and_a_bom_is_accepted() {
        let path = Path::new("results/x/P01/session-1.csv");
        let mut valid = format!("# {RESPONSES_FORMAT}\n");
        for (k, v) in &header().fields {
            valid.push_str(&format!("# {k}: {v}\n"));
        }
        valid.push_str(COLUMNS);
        valid.push('\n');
        for t in 0..3 {
            valid.push_str(&row(t).to_line());
            valid.push('\n');
        }
        // Rows are lines 10-12.
        assert_eq!(SessionLog::parse(path, &valid).unwrap().rows.len(), 3);
        let bom = format!("\u{feff}{valid}");
        assert_eq!(SessionLog::parse(path, &bom).unwrap().rows.len(), 3);
        let err = |text: &str| SessionLog::parse(path, text).unwrap_err().to_string();

        let duplicated = format!("{valid}{}\n", row(1).to_line());
        let e = err(&duplicated);
        assert!(e.contains("session-1.csv: line 13: trial 1 is also on line 11 (duplicated trial)"), "{e}");
        let skipped = format!("{valid}{}\n", row(5).to_line());
        assert!(err(&skipped).contains("line 13: trial 5 where trial 3 was expected"));
        let changed = format!("{valid}# seed: 99\n");
        let e = err(&changed);
        assert!(
            e.contains("line 13: header key `seed` is repeated among the rows as `99`, and is `seed-value` on line 6"),
            "{e}"
        );
        let twice = valid.replacen("# seed: seed-value\n", "# seed: seed-value\n# seed: 7\n", 1);
        assert!(err(&twice).contains("line 7: header key `seed` is `7` here and `seed-value` on line 6"));
        let session = valid.replace("# session: 1\n", "# session: one\n");
        assert!(err(&session).contains("line 8: header key `session` is `one`, not a session number"));
        let concatenated = format!("{valid}{valid}");
        assert!(err(&concatenated).contains("line 13: a second log begins here (two logs concatenated"));
        let headless = format!("{valid}{COLUMNS}\n{}\n", row(3).to_line());
        assert!(err(&headless).contains("line 13: a second column row"));
        let after = format!("{valid}# completed: now\n{}\n", row(3).to_line());
        assert!(err(&after).contains("line 14: a row after `# completed` on line 13"));
    }

    #[test]
    fn malformed_rows_name_the_line() {
        let path = Path::new("results/x/P01/session-1.csv");
        let mut text = format!("# {RESPONSES_FORMAT}\n");
        for k in REQUIRED_KEYS {
            text.push_str(&format!("# {k}: v\n"));
        }
        text.push_str(COLUMNS);
        text.push('\n');
        text.push_str("0,0,2afc,M2-S2-T3-A5|M2-S2-T5-A5,M2-S2-T4-A5,,10,0,0,t\n");
        text.push_str(&row(1).to_line());
        text.push('\n');
        let e = SessionLog::parse(path, &text).unwrap_err().to_string();
        assert!(e.contains("session-1.csv: line 10: choice M2-S2-T4-A5 is not one of the offered"), "{e}");
        let e = SessionLog::parse(path, "hello\n").unwrap_err().to_string();
        assert!(e.contains("line 1: expected `# blurlab-responses/1`"), "{e}");
    }
}
