//! Progress of a set render: the bars (indicatif) or plain lines, with throughput and
//! the process's CPU time.

use std::io::{self, IsTerminal, Write as _};
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use study::StimulusId;

use super::ProgressMode;

/// CPU seconds used by this process so far (user + system, all threads), from
/// `/proc/self/stat`; `None` where that is not available.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    // Linux reports these in USER_HZ, which is 100 on every mainstream platform.
    Some((utime + stime) / 100.0)
}

pub(crate) struct Progress {
    mode: ProgressMode,
    multi: Option<MultiProgress>,
    overall: Option<ProgressBar>,
    total_sequences: usize,
}

impl Progress {
    pub(crate) fn new(mode: ProgressMode, total_cost: u64, total_sequences: usize) -> Self {
        let mode = match mode {
            ProgressMode::Auto if io::stderr().is_terminal() => ProgressMode::Auto,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m,
        };
        if mode != ProgressMode::Auto {
            return Progress { mode, multi: None, overall: None, total_sequences };
        }
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let overall = multi.add(ProgressBar::new(total_cost.max(1)));
        overall.set_style(
            ProgressStyle::with_template(
                "{prefix:>18} [{elapsed_precise}] {wide_bar} {percent:>3}% ETA {eta_precise} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        overall.set_prefix("set");
        overall.set_message(format!("0/{total_sequences} sequences"));
        overall.enable_steady_tick(Duration::from_millis(500));
        Progress { mode, multi: Some(multi), overall: Some(overall), total_sequences }
    }

    pub(crate) fn sequence_bar(&self, id: &StimulusId, frames: u32) -> Option<ProgressBar> {
        let multi = self.multi.as_ref()?;
        let bar = multi.add(ProgressBar::new(u64::from(frames)));
        bar.set_style(
            ProgressStyle::with_template("{prefix:>18} {wide_bar} frame {pos}/{len} {rate} ETA {eta}")
                .map(|style| {
                    style.with_key("rate", |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                        let _ = write!(w, "{:.2} frames/s", state.per_sec());
                    })
                })
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(id.to_string());
        Some(bar)
    }

    pub(crate) fn advance(&self, cost: u64) {
        if let Some(o) = &self.overall {
            o.inc(cost);
        }
    }

    pub(crate) fn finished(&self, done: usize, id: &dyn std::fmt::Display, what: &str, seconds: f64) {
        let line = format!("[{done}/{}] {id}: {what} ({seconds:.1} s)", self.total_sequences);
        match self.mode {
            ProgressMode::Quiet => {}
            ProgressMode::Lines => {
                let _ = writeln!(io::stderr(), "{line}");
            }
            ProgressMode::Auto => {
                if let Some(o) = &self.overall {
                    o.set_message(format!("{done}/{} sequences", self.total_sequences));
                    o.println(line);
                }
            }
        }
    }

    pub(crate) fn finish(&self) {
        if let Some(o) = &self.overall {
            o.finish_and_clear();
        }
    }
}
