//! The experimenter's summary of what a window recorded: printed on the console at the end
//! of `blurlab run`, so that the experimenter sees at once whether the session went as
//! planned.
//!
//! [`SessionSummary::new`] counts the rows written in the window (practice and counted trials
//! separately), the replays, the late (dropped) frames and the trials that had any, and the
//! trials shown off-calibration: those whose recorded scale differs from the calibrated one
//! by more than `study::response::SCALE_TOLERANCE` (0.5 %), the rule the analysis warns by.
//! Trials are named by the log's `trial` column (0-based, practice included), so that the
//! experimenter can find them in the CSV. Rows without a recorded scale (no window drew
//! them) are counted apart: whether they were calibrated is unknown.

use std::fmt;

use study::response::{TrialRow, off_calibration};

use crate::calibration::Calibration;

/// A trial drawn at a scale other than the calibrated one.
#[derive(Clone, Debug, PartialEq)]
pub struct OffCalibrationTrial {
    /// The log's `trial` column.
    pub trial: u32,
    /// Whether it was a practice trial.
    pub practice: bool,
    /// Screen pixels per stimulus pixel it was drawn at.
    pub scale: f64,
    /// The visual angle it subtended, in degrees.
    pub visual_angle_deg: f64,
}

/// What a window recorded, for the experimenter's console.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionSummary {
    /// Counted (non-practice) trials answered.
    pub counted: usize,
    /// Practice trials answered.
    pub practice: usize,
    /// Replays requested, over all trials.
    pub replays: u64,
    /// Frames presented late or never, over all trials.
    pub late_frames: u64,
    /// The trials (`trial` column) with at least one late frame, in order.
    pub trials_with_late_frames: Vec<u32>,
    /// The calibrated scale (screen pixels per stimulus pixel).
    pub calibrated_scale: f64,
    /// The visual angle at the calibrated scale, in degrees.
    pub calibrated_angle_deg: f64,
    /// Trials drawn more than 0.5 % away from the calibrated scale, in order.
    pub off_calibration: Vec<OffCalibrationTrial>,
    /// Trials whose row records no scale.
    pub scale_unrecorded: usize,
}

impl SessionSummary {
    /// Summarises `rows` (those written in one window, in order) against `calibration`.
    pub fn new(rows: &[TrialRow], calibration: &Calibration) -> Self {
        let practice = rows.iter().filter(|r| r.practice).count();
        let mut off = Vec::new();
        let mut scale_unrecorded = 0;
        for r in rows {
            match (r.scale, r.visual_angle_deg) {
                (Some(scale), Some(angle)) if off_calibration(scale, calibration.scale) => off
                    .push(OffCalibrationTrial { trial: r.trial, practice: r.practice, scale, visual_angle_deg: angle }),
                (Some(_), Some(_)) => {}
                _ => scale_unrecorded += 1,
            }
        }
        SessionSummary {
            counted: rows.len() - practice,
            practice,
            replays: rows.iter().map(|r| u64::from(r.replays)).sum(),
            late_frames: rows.iter().map(|r| u64::from(r.dropped_frames)).sum(),
            trials_with_late_frames: rows.iter().filter(|r| r.dropped_frames > 0).map(|r| r.trial).collect(),
            calibrated_scale: calibration.scale,
            calibrated_angle_deg: calibration.angle_deg,
            off_calibration: off,
            scale_unrecorded,
        }
    }

    /// Whether anything needs the experimenter's attention: late frames, trials shown
    /// off-calibration, or trials without a recorded scale.
    pub fn needs_attention(&self) -> bool {
        self.late_frames > 0 || !self.off_calibration.is_empty() || self.scale_unrecorded > 0
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

impl fmt::Display for SessionSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "Session summary (trials numbered as in the log's `trial` column):")?;
        writeln!(
            f,
            "  answered:  {} and {} in this window",
            plural(self.counted, "counted trial", "counted trials"),
            plural(self.practice, "practice trial", "practice trials")
        )?;
        writeln!(f, "  replays:   {}", self.replays)?;
        if self.late_frames == 0 {
            writeln!(f, "  late frames: none")?;
        } else {
            let trials: Vec<String> = self.trials_with_late_frames.iter().map(ToString::to_string).collect();
            writeln!(
                f,
                "  late frames: {} in {} ({})",
                self.late_frames,
                plural(trials.len(), "trial", "trials"),
                trials.join(", ")
            )?;
        }
        let calibrated = format!("scale {:.3}, {:.2} degrees", self.calibrated_scale, self.calibrated_angle_deg);
        if self.off_calibration.is_empty() {
            writeln!(f, "  calibration: every trial with a recorded scale was shown as calibrated ({calibrated})")?;
        } else {
            writeln!(
                f,
                "  calibration: {} shown off-calibration (calibrated: {calibrated}):",
                plural(self.off_calibration.len(), "trial", "trials")
            )?;
            for t in &self.off_calibration {
                writeln!(
                    f,
                    "    trial {}{}: scale {:.3} ({:.0} % of calibrated), {:.2} degrees",
                    t.trial,
                    if t.practice { " (practice)" } else { "" },
                    t.scale,
                    100.0 * t.scale / self.calibrated_scale,
                    t.visual_angle_deg
                )?;
            }
        }
        if self.scale_unrecorded > 0 {
            writeln!(
                f,
                "  calibration unknown for {} (no scale recorded)",
                plural(self.scale_unrecorded, "trial", "trials")
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use study::response::Task;

    fn row(trial: u32, practice: bool, replays: u32, dropped: u32, scale: Option<f64>) -> TrialRow {
        TrialRow {
            trial,
            practice,
            task: Task::TwoAfc,
            shown: vec!["M2-S2-T3-A5".parse().unwrap(), "M2-S2-T5-A5".parse().unwrap()],
            choice: "M2-S2-T5-A5".parse().unwrap(),
            correct: None,
            response_ms: 900,
            replays,
            dropped_frames: dropped,
            timestamp: "t".into(),
            scale,
            visual_angle_deg: scale.map(|s| 14.5 * s / 4.0),
        }
    }

    fn calibration() -> Calibration {
        Calibration { scale: 4.0, integer: true, target_px: 2560.0, angle_deg: 14.5, warning: None }
    }

    #[test]
    fn counts_trials_replays_late_frames_and_off_calibration_trials() {
        let rows = vec![
            row(0, true, 1, 0, Some(4.0)),
            row(1, true, 0, 2, Some(2.4)),
            row(2, false, 2, 0, Some(4.0)),
            row(3, false, 0, 3, Some(4.0 * 1.004)),
            row(4, false, 1, 1, Some(4.0 * 0.994)),
            row(5, false, 0, 0, None),
        ];
        let s = SessionSummary::new(&rows, &calibration());
        assert_eq!((s.counted, s.practice, s.replays, s.late_frames), (4, 2, 4, 6));
        assert_eq!(s.trials_with_late_frames, vec![1, 3, 4]);
        // 0.4 % off is within the tolerance, 0.6 % is not.
        let off: Vec<(u32, bool)> = s.off_calibration.iter().map(|t| (t.trial, t.practice)).collect();
        assert_eq!(off, vec![(1, true), (4, false)]);
        assert_eq!((s.off_calibration[0].scale, s.off_calibration[0].visual_angle_deg), (2.4, 14.5 * 2.4 / 4.0));
        assert_eq!(s.scale_unrecorded, 1);
        assert!(s.needs_attention());

        let text = s.to_string();
        assert!(text.contains("answered:  4 counted trials and 2 practice trials"), "{text}");
        assert!(text.contains("replays:   4"), "{text}");
        assert!(text.contains("late frames: 6 in 3 trials (1, 3, 4)"), "{text}");
        assert!(text.contains("2 trials shown off-calibration (calibrated: scale 4.000, 14.50 degrees)"), "{text}");
        assert!(text.contains("trial 1 (practice): scale 2.400 (60 % of calibrated), 8.70 degrees"), "{text}");
        assert!(text.contains("trial 4: scale 3.976 (99 % of calibrated), 14.41 degrees"), "{text}");
        assert!(text.contains("calibration unknown for 1 trial (no scale recorded)"), "{text}");
    }

    #[test]
    fn a_clean_window_says_so() {
        let rows = vec![row(7, false, 0, 0, Some(4.0)), row(8, false, 0, 0, Some(4.0))];
        let s = SessionSummary::new(&rows, &calibration());
        assert_eq!((s.counted, s.practice, s.replays, s.late_frames), (2, 0, 0, 0));
        assert!(s.trials_with_late_frames.is_empty() && s.off_calibration.is_empty() && !s.needs_attention());
        let text = s.to_string();
        assert!(text.contains("answered:  2 counted trials and 0 practice trials"), "{text}");
        assert!(text.contains("late frames: none"), "{text}");
        assert!(
            text.contains("every trial with a recorded scale was shown as calibrated (scale 4.000, 14.50 degrees)")
        );
        assert!(!text.contains("unknown"), "{text}");
        let empty = SessionSummary::new(&[], &calibration());
        assert_eq!((empty.counted, empty.practice), (0, 0));
        assert!(empty.to_string().contains("0 counted trials and 0 practice trials"));
    }
}
