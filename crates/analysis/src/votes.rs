//! Tables of vote totals (`blurlab-votes/1`): the scores `a_i` of a paired-comparison test
//! with the number of judges and the significance level, as published in the thesis
//! (`analysis/reference/*.csv`) or written by `blurlab analyze` from response logs
//! (`REPORT/EXPERIMENT-votes.csv`, [`VoteTable::to_text`]). Grouping them needs nothing else.
//!
//! ```text
//! # blurlab-votes/1
//! # source: where the numbers come from
//! # judges: 20
//! # alpha: 0.01
//! # expected_groups: A5 A4 A3; A4 A3 A2; A1      (optional: groups to reproduce)
//! stimulus,votes
//! A1,8
//! ...
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::grouping::{CriticalRange, critical_range, significance_groups};

/// Format tag of a vote table.
pub const VOTES_FORMAT: &str = "blurlab-votes/1";

/// Why a vote table cannot be read or analysed.
#[derive(Debug, thiserror::Error)]
pub enum VotesError {
    /// I/O failure.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A malformed line.
    #[error("{path}: line {line}: {message}")]
    Malformed {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// Missing or invalid parameters.
    #[error("{0}")]
    Parameters(String),
}

/// A parsed vote table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VoteTable {
    /// The file read.
    pub path: PathBuf,
    /// Header fields (`# key: value`) in file order.
    pub header: Vec<(String, String)>,
    /// Stimulus labels in file order.
    pub labels: Vec<String>,
    /// Votes (scores) per stimulus.
    pub votes: Vec<u32>,
}

impl VoteTable {
    /// Reads a vote table.
    pub fn read(path: &Path) -> Result<Self, VotesError> {
        let text = std::fs::read_to_string(path).map_err(|source| VotesError::Io { path: path.to_owned(), source })?;
        Self::parse(path, &text)
    }

    /// Parses the text of a vote table read from `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, VotesError> {
        let bad = |line: usize, message: String| VotesError::Malformed { path: path.to_owned(), line, message };
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
        match lines.next() {
            Some((_, l)) if l == format!("# {VOTES_FORMAT}") => {}
            _ => return Err(bad(1, format!("expected `# {VOTES_FORMAT}` as the first line"))),
        }
        let mut header = Vec::new();
        let mut labels: Vec<String> = Vec::new();
        let mut votes = Vec::new();
        let mut seen_columns = false;
        for (no, line) in lines {
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                if !seen_columns {
                    let (k, v) = comment
                        .split_once(':')
                        .ok_or_else(|| bad(no, format!("header line `{line}` is not `# key: value`")))?;
                    header.push((k.trim().to_owned(), v.trim().to_owned()));
                }
                continue;
            }
            if !seen_columns {
                if line != "stimulus,votes" {
                    return Err(bad(no, "expected the column row `stimulus,votes`".into()));
                }
                seen_columns = true;
                continue;
            }
            let cols: Vec<&str> = line.split(',').map(str::trim).collect();
            if cols.len() != 2 {
                return Err(bad(no, format!("found {} columns, expected 2 (stimulus,votes)", cols.len())));
            }
            if cols[0].is_empty() {
                return Err(bad(no, "column `stimulus` is empty".into()));
            }
            if labels.iter().any(|l| l == cols[0]) {
                return Err(bad(no, format!("stimulus `{}` appears twice", cols[0])));
            }
            let v = cols[1]
                .parse::<u32>()
                .map_err(|_| bad(no, format!("column `votes` is `{}`, expected a whole number", cols[1])))?;
            labels.push(cols[0].to_owned());
            votes.push(v);
        }
        if !seen_columns {
            return Err(bad(text.lines().count() + 1, "missing the column row `stimulus,votes`".into()));
        }
        if labels.len() < 2 {
            return Err(bad(text.lines().count(), format!("{} stimuli, expected at least 2", labels.len())));
        }
        Ok(VoteTable { path: path.to_owned(), header, labels, votes })
    }

    /// A header field.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.header.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn parsed<T: std::str::FromStr>(&self, key: &str) -> Result<Option<T>, VotesError> {
        self.get(key)
            .map(|v| {
                v.parse::<T>().map_err(|_| {
                    VotesError::Parameters(format!(
                        "{}: header field `{key}` is `{v}`, not a number",
                        self.path.display()
                    ))
                })
            })
            .transpose()
    }

    /// The number of judges in the header, if any.
    pub fn judges(&self) -> Result<Option<u32>, VotesError> {
        self.parsed("judges")
    }

    /// The significance level in the header, if any.
    pub fn alpha(&self) -> Result<Option<f64>, VotesError> {
        self.parsed("alpha")
    }

    /// The table as text, in the format [`VoteTable::parse`] reads back: header fields in
    /// order (line breaks in a value become spaces, so that one field stays one line), then
    /// one row per stimulus.
    pub fn to_text(&self) -> String {
        let mut s = format!("# {VOTES_FORMAT}\n");
        for (k, v) in &self.header {
            s.push_str(&format!("# {k}: {}\n", v.replace(['\n', '\r'], " ")));
        }
        s.push_str("stimulus,votes\n");
        for (label, v) in self.labels.iter().zip(&self.votes) {
            s.push_str(&format!("{label},{v}\n"));
        }
        s
    }

    /// Groups to reproduce (`expected_groups: A B; C D`), if given.
    pub fn expected_groups(&self) -> Option<Vec<Vec<String>>> {
        self.get("expected_groups")
            .map(|v| v.split(';').map(|g| g.split_whitespace().map(str::to_owned).collect::<Vec<_>>()).collect())
    }
}

/// The grouping of a vote table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VotesAnalysis {
    /// Stimulus labels in file order.
    pub labels: Vec<String>,
    /// Votes in file order.
    pub votes: Vec<u32>,
    /// `W`, `R_c`, `ceil(R_c)`.
    pub critical: CriticalRange,
    /// Groups by label, members by decreasing votes, groups by decreasing top score.
    pub groups: Vec<Vec<String>>,
    /// Votes a complete balanced design would total: `m t (t - 1) / 2`.
    pub expected_total: u64,
    /// The votes' actual total.
    pub total: u64,
}

/// Groups the stimuli of a vote table with `m` judges at level `alpha`.
pub fn analyze_votes(table: &VoteTable, judges: u32, alpha: f64) -> Result<VotesAnalysis, VotesError> {
    let t = table.labels.len();
    let critical = critical_range(t, judges, alpha)
        .map_err(|e| VotesError::Parameters(format!("{}: {e}", table.path.display())))?;
    let scores: Vec<f64> = table.votes.iter().map(|&v| f64::from(v)).collect();
    let groups = significance_groups(&scores, critical.ceil_rc as f64)
        .into_iter()
        .map(|g| g.into_iter().map(|i| table.labels[i].clone()).collect())
        .collect();
    Ok(VotesAnalysis {
        labels: table.labels.clone(),
        votes: table.votes.clone(),
        critical,
        groups,
        expected_total: u64::from(judges) * (t * (t - 1) / 2) as u64,
        total: table.votes.iter().map(|&v| u64::from(v)).sum(),
    })
}

/// Groups as sets of labels, for comparisons that ignore order.
pub fn groups_as_sets(groups: &[Vec<String>]) -> Vec<std::collections::BTreeSet<String>> {
    let mut sets: Vec<_> = groups.iter().map(|g| g.iter().cloned().collect()).collect();
    sets.sort();
    sets
}

/// A header map, for reports.
pub fn header_map(table: &VoteTable) -> BTreeMap<String, String> {
    table.header.iter().cloned().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_tables_name_the_line() {
        let p = Path::new("votes.csv");
        let head = "# blurlab-votes/1\n# judges: 3\nstimulus,votes\n";
        for (body, needle) in [
            ("A,1\nB,x\n", "line 5: column `votes` is `x`"),
            ("A,1\nB,2,3\n", "line 5: found 3 columns"),
            ("A,1\nA,2\n", "line 5: stimulus `A` appears twice"),
            ("A,1\n", "1 stimuli, expected at least 2"),
        ] {
            let e = VoteTable::parse(p, &format!("{head}{body}")).unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("votes.csv"), "{e}");
        }
        let e = VoteTable::parse(p, "stimulus,votes\n").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
    }

    #[test]
    fn a_table_written_as_text_reads_back_the_same() {
        let p = Path::new("votes.csv");
        let table = VoteTable {
            path: p.to_owned(),
            header: vec![
                ("source".into(), "two lines\nof text: with a colon".into()),
                ("judges".into(), "21".into()),
                ("alpha".into(), "0.01".into()),
            ],
            labels: vec!["T3-A5".into(), "T4-A5".into(), "T5-A5".into()],
            votes: vec![30, 21, 12],
        };
        let text = table.to_text();
        assert!(text.starts_with("# blurlab-votes/1\n# source: two lines of text: with a colon\n"), "{text}");
        let back = VoteTable::parse(p, &text).unwrap();
        assert_eq!(back.labels, table.labels);
        assert_eq!(back.votes, table.votes);
        assert_eq!(back.judges().unwrap(), Some(21));
        assert_eq!(back.alpha().unwrap(), Some(0.01));
        assert_eq!(back.get("source"), Some("two lines of text: with a colon"));
    }
}
