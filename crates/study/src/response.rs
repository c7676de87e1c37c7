//! The durable response log: one CSV file per participant session with a commented header
//! and one row per trial, appended and synced before the next trial starts. The runner
//! writes it, the analysis reads it; docs/formats.md describes it.
//!
//! Format `blurlab-responses/2` adds the columns `scale` and `visual_angle_deg` (the scale
//! and visual angle at which the trial was actually drawn); logs of `blurlab-responses/1`
//! (without them) are still read, their rows with `None` there, and resuming one rewrites it
//! as `/2` first (see [`ResponseLog::resume`]).
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

/// First line of every log written now.
pub const RESPONSES_FORMAT: &str = "blurlab-responses/2";
/// First line of logs of the previous format, still read.
pub const RESPONSES_FORMAT_V1: &str = "blurlab-responses/1";
/// The column header row.
pub const COLUMNS: &str =
    "trial,practice,task,shown,choice,correct,response_ms,replays,dropped_frames,timestamp,scale,visual_angle_deg";
/// The column header row of `blurlab-responses/1` logs.
pub const COLUMNS_V1: &str = "trial,practice,task,shown,choice,correct,response_ms,replays,dropped_frames,timestamp";
/// Relative difference between a trial's recorded scale and the calibrated one above which
/// the trial counts as shown off-calibration (0.5 %).
pub const SCALE_TOLERANCE: f64 = 0.005;

/// Whether a trial drawn at `recorded` screen pixels per stimulus pixel was shown
/// off-calibration, i.e. differs from the `calibrated` scale by more than
/// [`SCALE_TOLERANCE`] of it. The one rule shared by the runner's summary and the analysis.
pub fn off_calibration(recorded: f64, calibrated: f64) -> bool {
    (recorded - calibrated).abs() > SCALE_TOLERANCE * calibrated.abs()
}

/// The format version (1 or 2) named by a first line's text after `#`, if it names one.
fn format_version(comment: &str) -> Option<u32> {
    match comment.trim() {
        RESPONSES_FORMAT => Some(2),
        RESPONSES_FORMAT_V1 => Some(1),
        _ => None,
    }
}

/// The column row of a format version.
fn columns_of(version: u32) -> &'static str {
    if version == 1 { COLUMNS_V1 } else { COLUMNS }
}
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
    /// Screen pixels per stimulus pixel at which the trial was actually drawn (`None` in
    /// `blurlab-responses/1` logs and for trials no window drew, e.g. simulated observers).
    pub scale: Option<f64>,
    /// The visual angle in degrees that one eye's image actually subtended (`None` where
    /// `scale` is).
    pub visual_angle_deg: Option<f64>,
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
        let number = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            self.trial,
            u8::from(self.practice),
            self.task,
            shown.join("|"),
            self.choice,
            correct,
            self.response_ms,
            self.replays,
            self.dropped_frames,
            self.timestamp,
            number(self.scale),
            number(self.visual_angle_deg)
        )
    }

    /// Parses a CSV line of the current format (`blurlab-responses/2`).
    pub fn parse_line(line: &str) -> Result<Self, String> {
        Self::parse_line_of(line, 2)
    }

    /// Parses a CSV line of a `blurlab-responses/1` log (no `scale` and `visual_angle_deg`
    /// columns: both are `None`).
    pub fn parse_line_v1(line: &str) -> Result<Self, String> {
        Self::parse_line_of(line, 1)
    }

    fn parse_line_of(line: &str, version: u32) -> Result<Self, String> {
        let columns = columns_of(version);
        let count = columns.split(',').count();
        let cols: Vec<&str> = line.split(',').collect();
        if cols.len() != count {
            return Err(format!("found {} columns, expected {count} ({columns})", cols.len()));
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
        let positive = |i: usize, name: &str| -> Result<Option<f64>, String> {
            if cols[i].is_empty() {
                return Ok(None);
            }
            match cols[i].parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(Some(v)),
                _ => Err(format!("column `{name}` is `{}`, expected a positive number or empty", cols[i])),
            }
        };
        let (scale, visual_angle_deg) = if version == 1 {
            (None, None)
        } else {
            let pair = (positive(10, "scale")?, positive(11, "visual_angle_deg")?);
            if pair.0.is_some() != pair.1.is_some() {
                return Err("columns `scale` and `visual_angle_deg` must both be given or both be empty".into());
            }
            pair
        };
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
            scale,
            visual_angle_deg,
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
    /// The format version of the file: 2 (`blurlab-responses/2`) or 1 (read, never written).
    pub format_version: u32,
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

    /// Parses log text read from `path`, of format `blurlab-responses/2` or `/1` (whose rows
    /// have no scale). A leading byte-order mark is skipped. Ambiguous
    /// logs are errors naming the line: a header key given twice with different values (in
    /// the header or as a comment among the rows), a `session` that is not a number, a second
    /// format line or column row (two logs concatenated), a row after `# completed`, and a
    /// trial number that repeats an earlier row's or does not follow it.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ResponseError> {
        let bad = |line: usize, message: String| ResponseError::Malformed { path: path.to_owned(), line, message };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let ends_with_newline = text.ends_with('\n');
        let lines: Vec<&str> = text.lines().collect();
        let Some(version) = lines.first().and_then(|l| l.trim().strip_prefix('#')).and_then(format_version) else {
            return Err(bad(
                1,
                format!("expected `# {RESPONSES_FORMAT}` (or `# {RESPONSES_FORMAT_V1}`) as the first line"),
            ));
        };
        let columns = columns_of(version);
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
                } else if format_version(comment).is_some() {
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
                if raw.trim() != columns {
                    return Err(bad(line_no, format!("expected the column row `{columns}`")));
                }
                seen_columns = true;
                continue;
            }
            if raw.trim() == COLUMNS || raw.trim() == COLUMNS_V1 {
                return Err(bad(line_no, "a second column row (two logs concatenated into one file)".into()));
            }
            let row = match TrialRow::parse_line_of(raw, version) {
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
            return Err(bad(lines.len() + 1, format!("missing the column row `{columns}`")));
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
        Ok(SessionLog {
            path: path.to_owned(),
            header,
            rows,
            trailing_corrupt,
            completed: completed.is_some(),
            format_version: version,
        })
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
    /// (`# corrupt-trailing-row line N: ...`) so nothing is lost, and returned in the log. A
    /// `blurlab-responses/1` log is rewritten as `/2` first (format line, column row, and its
    /// rows with empty `scale` and `visual_angle_deg`; every other line kept), so that the rows
    /// appended after it have the columns the file declares. Rewrites are atomic. The returned
    /// log is the file as read, before any rewrite (its line numbers stay valid).
    pub fn resume(path: &Path) -> Result<(Self, SessionLog), ResponseError> {
        let io_err = |source| ResponseError::Io { path: path.to_owned(), source };
        let log = SessionLog::read(path)?;
        if log.trailing_corrupt.is_some() || log.format_version != 2 {
            let bytes = std::fs::read(path).map_err(io_err)?;
            let text = String::from_utf8_lossy(&bytes);
            let mut kept: Vec<String> = text.lines().map(str::to_owned).collect();
            if let Some(corrupt) = &log.trailing_corrupt {
                kept.truncate(corrupt.line - 1);
            }
            if log.format_version == 1 {
                kept[0] = format!("# {RESPONSES_FORMAT}");
                if let Some(columns) = kept.iter_mut().find(|l| l.trim() == COLUMNS_V1) {
                    *columns = COLUMNS.to_owned();
                }
                for (line, row) in &log.rows {
                    kept[line - 1] = row.to_line();
                }
            }
            let mut repaired = kept.join("\n");
            repaired.push('\n');
            if let Some(corrupt) = &log.trailing_corrupt {
                repaired.push_str(&format!(
                    "# corrupt-trailing-row line {}: {} ({})\n",
                    corrupt.line, corrupt.text, corrupt.reason
                ));
            }
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

    /// The format line, the header of [`header`] and the column row of a log.
    fn header_text() -> String {
        let mut text = format!("# {RESPONSES_FORMAT}\n");
        for (k, v) in &header().fields {
            text.push_str(&format!("# {k}: {v}\n"));
        }
        text.push_str(COLUMNS);
        text.push('\n');
        text
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
            scale: Some(2.5),
            visual_angle_deg: Some(14.512_345_678_9),
        }
    }

    /// A `blurlab-responses/1` log of three rows (lines 10-12), the last without a line end
    /// when `partial`.
    fn v1_log(partial: bool) -> String {
        let mut text = format!("# {RESPONSES_FORMAT_V1}\n");
        for (k, v) in &header().fields {
            text.push_str(&format!("# {k}: {v}\n"));
        }
        text.push_str(COLUMNS_V1);
        text.push('\n');
        text.push_str("0,1,2afc,M2-S2-T3-A5|M2-S2-T5-A5,M2-S2-T5-A5,,1200,1,0,1970-01-01T00:00:00.000Z\n");
        text.push_str("1,0,2afc,M2-S2-T5-A5|M2-S2-T3-A5,M2-S2-T3-A5,,900,0,2,1970-01-01T00:00:01.000Z\n");
        text.push_str("2,0,2afc,M2-S2-T3-A5|M2-S2-T5-A5,M2-S2-T3-A5,,800,0,0,1970-01-01T00:00:02.000Z");
        if !partial {
            text.push('\n');
        }
        text
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
        let mut valid = header_text();
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
        text.push_str("0,0,2afc,M2-S2-T3-A5|M2-S2-T5-A5,M2-S2-T4-A5,,10,0,0,t,,\n");
        text.push_str(&row(1).to_line());
        text.push('\n');
        let e = SessionLog::parse(path, &text).unwrap_err().to_string();
        assert!(e.contains("session-1.csv: line 10: choice M2-S2-T4-A5 is not one of the offered"), "{e}");
        let e = SessionLog::parse(path, "hello\n").unwrap_err().to_string();
        assert!(e.contains("line 1: expected `# blurlab-responses/2` (or `# blurlab-responses/1`)"), "{e}");
    }

    #[test]
    fn a_v2_row_round_trips_its_scale_and_angle_exactly() {
        let mut r = row(3);
        r.scale = Some(0.613_725_490_196_078_4);
        r.visual_angle_deg = Some(8.901_234_567_890_123);
        let line = r.to_line();
        assert_eq!(line.split(',').count(), COLUMNS.split(',').count());
        assert!(line.ends_with(",0.6137254901960784,8.901234567890123"), "{line}");
        assert_eq!(TrialRow::parse_line(&line).unwrap(), r);
        // No window drew the trial: both columns empty, read back as None.
        let unscaled = TrialRow { scale: None, visual_angle_deg: None, ..row(1) };
        assert!(unscaled.to_line().ends_with("Z,,"), "{}", unscaled.to_line());
        assert_eq!(TrialRow::parse_line(&unscaled.to_line()).unwrap(), unscaled);
        // A v2 line is not a v1 line and the other way round.
        assert!(TrialRow::parse_line_v1(&line).unwrap_err().contains("found 12 columns, expected 10"));
        let v1 = line.rsplitn(3, ',').nth(2).unwrap();
        assert!(TrialRow::parse_line(v1).unwrap_err().contains("found 10 columns, expected 12"));
    }

    #[test]
    fn bad_scale_columns_are_errors_naming_the_line() {
        let path = Path::new("results/x/P01/session-1.csv");
        let mut valid = header_text();
        valid.push_str(&row(0).to_line());
        valid.push('\n');
        let log = SessionLog::parse(path, &valid).unwrap();
        assert_eq!((log.format_version, log.rows[0].1.scale), (2, Some(2.5)));
        let good = row(1).to_line();
        for (bad, message) in [
            (good.replace(",2.5,", ",-2.5,"), "column `scale` is `-2.5`, expected a positive number or empty"),
            (good.replace(",2.5,", ",x,"), "column `scale` is `x`"),
            (good.replace(",14.5123456789", ",NaN"), "column `visual_angle_deg` is `NaN`"),
            (good.replace(",2.5,", ",,"), "columns `scale` and `visual_angle_deg` must both be given or both be empty"),
        ] {
            let text = format!("{valid}{bad}\n{}\n", row(2).to_line());
            let e = SessionLog::parse(path, &text).unwrap_err().to_string();
            assert!(e.contains(&format!("session-1.csv: line 11: {message}")), "{e}");
        }
        // A v1 column row under a v2 format line (and the reverse) is refused.
        let mixed = valid.replace(COLUMNS, COLUMNS_V1);
        let e = SessionLog::parse(path, &mixed).unwrap_err().to_string();
        assert!(e.contains(&format!("line 9: expected the column row `{COLUMNS}`")), "{e}");
        let e = SessionLog::parse(path, &format!("{valid}# {RESPONSES_FORMAT_V1}\n")).unwrap_err().to_string();
        assert!(e.contains("line 11: a second log begins here"), "{e}");
    }

    #[test]
    fn a_v1_log_is_still_read_and_resuming_rewrites_it_as_v2() {
        let path = Path::new("results/x/P01/session-1.csv");
        let log = SessionLog::parse(path, &v1_log(false)).unwrap();
        assert_eq!(log.format_version, 1);
        let rows: Vec<&TrialRow> = log.rows.iter().map(|(_, r)| r).collect();
        assert_eq!(rows.len(), 3);
        assert_eq!((rows[1].trial, rows[1].response_ms, rows[1].dropped_frames), (1, 900, 2));
        assert!(rows.iter().all(|r| r.scale.is_none() && r.visual_angle_deg.is_none()));
        assert_eq!(log.rows.iter().map(|(l, _)| *l).collect::<Vec<_>>(), vec![10, 11, 12]);
        // The v1 parser keeps its errors naming the line.
        let bad = v1_log(false).replace(",900,", ",fast,");
        let e = SessionLog::parse(path, &bad).unwrap_err().to_string();
        assert!(e.contains("line 11: column `response_ms` is `fast`, expected a whole number"), "{e}");

        // Resuming a v1 log with a partial last row: upgraded to v2, the partial row kept as
        // a comment, new rows appended in v2; the old rows keep their values.
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("session-1.csv");
        std::fs::write(&file, v1_log(true)).unwrap();
        let (mut log, before) = ResponseLog::resume(&file).unwrap();
        assert_eq!((before.format_version, before.rows.len()), (1, 2));
        assert_eq!(before.trailing_corrupt.as_ref().unwrap().line, 12);
        log.append(&row(2)).unwrap();
        drop(log);
        let text = std::fs::read_to_string(&file).unwrap();
        assert!(text.starts_with(&format!("# {RESPONSES_FORMAT}\n")), "{text}");
        assert!(text.contains(&format!("\n{COLUMNS}\n")) && !text.contains(&format!("{COLUMNS_V1}\n")), "{text}");
        assert!(text.contains("# corrupt-trailing-row line 12: 2,0,2afc,"), "{text}");
        let after = SessionLog::read(&file).unwrap();
        assert_eq!(after.format_version, 2);
        let old: Vec<TrialRow> = before.rows.iter().map(|(_, r)| r.clone()).collect();
        let now: Vec<TrialRow> = after.rows.iter().map(|(_, r)| r.clone()).collect();
        assert_eq!(now[..2], old[..]);
        assert_eq!(now[2], row(2));
        assert_eq!(after.header, before.header);
    }

    #[test]
    fn off_calibration_is_a_difference_above_half_a_percent() {
        assert!(!off_calibration(4.0, 4.0));
        assert!(!off_calibration(4.0 * 1.0049, 4.0) && !off_calibration(4.0 * 0.9951, 4.0));
        assert!(off_calibration(4.0 * 1.0051, 4.0) && off_calibration(4.0 * 0.9949, 4.0));
        assert!(off_calibration(2.44, 4.0));
    }
}
