//! What the window is configured with and how it lays a trial out: [`AppConfig`] (the
//! experiment, the set, the viewing set-up), the refresh rate used for pacing
//! ([`RefreshChoice`]), the window size a trial needs, and the scale and texture filter at
//! which stimuli fit the window.

use std::path::PathBuf;

use egui::{TextureOptions, Vec2};
use study::StimulusId;
use study::experiment::{DisplayMode, ExperimentDefinition};
use study::response::Task;

use super::RunnerApp;
use super::loading::Prepared;
use crate::RunnerError;
use crate::calibration::{Calibration, Layout, Viewing, calibrate, fit_scale, visual_angle_deg};
use crate::playback::RefreshEstimate;
use crate::stimuli::StimulusSet;

/// What the window needs to run a session.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// The experiment.
    pub definition: ExperimentDefinition,
    /// The stimulus set, already checked against the experiment.
    pub set: StimulusSet,
    /// Results root (`results/`).
    pub results_dir: PathBuf,
    /// Participant code to prefill.
    pub participant: Option<String>,
    /// Seed for a new session.
    pub seed: Option<u64>,
    /// Display mode (the definition's unless overridden).
    pub display: DisplayMode,
    /// Viewing geometry for calibration.
    pub viewing: Viewing,
    /// Display refresh rate for pacing given by the experimenter (Hz, `--refresh-hz`);
    /// `None`: measured on the start screen (see [`RefreshChoice`]).
    pub refresh_hz: Option<f64>,
    /// Decoder threads.
    pub decode_threads: usize,
    /// Answer every trial with the first option as soon as it may be answered, and close
    /// after this many trials (benchmarks and smoke tests of the real window).
    pub autopilot: Option<usize>,
}

impl AppConfig {
    /// A configuration with the definition's display mode, the thesis's viewing set-up,
    /// a measured refresh rate and all cores for decoding.
    pub fn new(definition: ExperimentDefinition, set: StimulusSet, results_dir: PathBuf) -> Self {
        let display = definition.display;
        AppConfig {
            definition,
            set,
            results_dir,
            participant: None,
            seed: None,
            display,
            viewing: Viewing::default(),
            refresh_hz: None,
            decode_threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
            autopilot: None,
        }
    }

    /// The calibration for this set's stimuli (all sequences of an experiment share a size).
    pub fn calibration(&self) -> Result<Calibration, RunnerError> {
        let eye = self
            .set
            .sequences
            .values()
            .next()
            .map_or(640, |s| crate::display::eye_width(s.manifest.view, s.manifest.width));
        calibrate(&self.viewing, eye, self.definition.presentation.visual_angle_deg)
            .map_err(|message| RunnerError::Input { what: "display calibration".into(), message })
    }

    /// Display settings recorded in the log header, with the refresh rate used for pacing.
    pub fn display_json(&self, refresh: &RefreshChoice) -> serde_json::Value {
        let cal = self.calibration().ok();
        serde_json::json!({
            "mode": self.display.name(),
            "screen_width_cm": self.viewing.screen_width_cm,
            "screen_width_px": self.viewing.screen_width_px,
            "distance_cm": self.viewing.distance_cm,
            "refresh_hz": refresh.hz,
            "refresh_source": refresh.source,
            "refresh_measured_hz": refresh.measured.map(|m| m.hz()),
            "refresh_measured_spread": refresh.measured.map(|m| m.spread),
            "refresh_measured_intervals": refresh.measured.map(|m| m.intervals),
            "scale": cal.as_ref().map(|c| c.scale),
            "visual_angle_deg": cal.as_ref().map(|c| c.angle_deg),
        })
    }

    /// The inner size (points at 1 pixel per point) a window needs to show a trial at the
    /// calibrated scale: the largest layout of the experiment plus labels and buttons, at
    /// least 800x600 for the start screen.
    pub fn window_size(&self) -> [f32; 2] {
        let scale = self.calibration().map_or(1.0, |c| c.scale);
        let (w, h) = self.set.sequences.values().next().map_or((640, 360), |s| {
            crate::display::output_size(self.display, s.manifest.view, s.manifest.width, s.manifest.height)
        });
        let layout = layout_of(self.definition.task);
        let content_w = f64::from(layout.columns) * f64::from(w) * scale + SLOT_GAP * f64::from(layout.columns - 1);
        let content_h = f64::from(layout.rows) * f64::from(h) * scale + SLOT_GAP * f64::from(layout.rows - 1);
        let chrome = chrome_lines(self.definition.task) as f64 * NOMINAL_LINE + NOMINAL_LINE + 2.0 * MARGIN;
        [(content_w + 2.0 * MARGIN).max(800.0).ceil() as f32, (content_h + chrome).max(600.0).ceil() as f32]
    }
}

/// Frames of the start screen whose times estimate the refresh rate (60 intervals).
pub const REFRESH_CALIBRATION_FRAMES: usize = 61;
/// The measurement ends after this long (seconds) even with fewer frames.
pub const REFRESH_CALIBRATION_MAX_S: f64 = 3.0;
/// The rate pacing assumes when it is neither given nor measurable.
pub const ASSUMED_REFRESH_HZ: f64 = 60.0;

/// The refresh rate used for frame pacing and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct RefreshChoice {
    /// Hz.
    pub hz: f64,
    /// `--refresh-hz`, `measured`, or `assumed: WHY`.
    pub source: String,
    /// The start screen's measurement, when it was taken.
    pub measured: Option<RefreshEstimate>,
}

impl RefreshChoice {
    /// The experimenter's rate if given, else the measurement when it looks like a display
    /// refresh, else [`ASSUMED_REFRESH_HZ`] with the reason.
    pub fn choose(given: Option<f64>, measured: Option<RefreshEstimate>, measuring_done: bool) -> RefreshChoice {
        let (hz, source) = match (given, measured) {
            (Some(hz), _) => (hz, "--refresh-hz".to_owned()),
            (None, Some(m)) if m.is_display_refresh() => (m.hz(), "measured".to_owned()),
            (None, Some(m)) => (
                ASSUMED_REFRESH_HZ,
                format!(
                    "assumed: the window redraws every {:.1} ms with a spread of {:.0}%, not a display refresh (no vsync, or drawing is slower than the display)",
                    m.interval_ms,
                    100.0 * m.spread
                ),
            ),
            (None, None) if measuring_done => (ASSUMED_REFRESH_HZ, "assumed: too few frames to measure".to_owned()),
            (None, None) => (ASSUMED_REFRESH_HZ, "assumed: not measured yet".to_owned()),
        };
        RefreshChoice { hz, source, measured }
    }
}

/// Pixels between slots of a layout (egui's default item spacing).
const SLOT_GAP: f64 = 8.0;
/// The central panel's margin, points.
const MARGIN: f64 = 8.0;
/// A text line with spacing at egui's default style, points (for sizing the window only).
const NOMINAL_LINE: f64 = 22.0;

fn layout_of(task: Task) -> Layout {
    match task {
        Task::TwoAfc => Layout { columns: 1, rows: 1 },
        Task::Match => Layout { columns: 2, rows: 2 },
    }
}

/// Text lines of a trial screen around the stimuli: the trial label, a notice, the slot
/// labels (one per row), the fit warning and the question (the buttons come on top).
fn chrome_lines(task: Task) -> u32 {
    2 + layout_of(task).rows + 2
}

/// The scale (screen pixels per stimulus pixel) at which a trial's stimuli of `stimulus`
/// pixels fit the window, and a warning when that is below the calibration.
fn fitted_scale(
    ctx: &egui::Context,
    calibration: Option<&Calibration>,
    viewing: &Viewing,
    eye_width: u32,
    task: Task,
    stimulus: [usize; 2],
) -> (f64, Option<String>) {
    let calibrated = calibration.map_or(1.0, |c| c.scale);
    let ppp = f64::from(ctx.pixels_per_point());
    let style = ctx.global_style();
    let spacing = f64::from(style.spacing.item_spacing.y);
    let line = f64::from(ctx.fonts_mut(|f| f.row_height(&egui::TextStyle::Body.resolve(&style)))) + spacing;
    let button = f64::from(style.spacing.interact_size.y) + spacing;
    let rect = ctx.content_rect();
    let chrome = f64::from(chrome_lines(task)) * line + button + 2.0 * MARGIN;
    let space = ((f64::from(rect.width()) - 2.0 * MARGIN) * ppp, (f64::from(rect.height()) - chrome) * ppp);
    let stim = (stimulus[0] as f64, stimulus[1] as f64);
    let (scale, reduced) = fit_scale(calibrated, stim, layout_of(task), space, SLOT_GAP * ppp);
    let warning = reduced.then(|| {
        format!(
            "The window is too small for the calibrated size: stimuli are drawn at {:.0}% ({:.1} instead of {:.1} degrees). Enlarge the window or run full screen.",
            100.0 * scale / calibrated,
            visual_angle_deg(viewing, eye_width, scale),
            visual_angle_deg(viewing, eye_width, calibrated)
        )
    });
    (scale, warning)
}

impl RunnerApp {
    /// Sharp texels at an integer calibration that fits the window; smoothing otherwise.
    pub(super) fn filter(&self, ctx: &egui::Context, task: Task, prepared: &[Prepared]) -> TextureOptions {
        let reduced = prepared.first().is_some_and(|d| {
            fitted_scale(ctx, self.calibration.as_ref(), &self.config.viewing, d.eye_width, task, d.size).1.is_some()
        });
        if !reduced && self.calibration.as_ref().is_none_or(|c| c.integer) {
            TextureOptions::NEAREST
        } else {
            TextureOptions::LINEAR
        }
    }

    /// The size in points of a stimulus drawn in a trial (or example) of `task`, and the
    /// warning when the window is too small for the calibrated size.
    pub(super) fn drawn_size(
        &self,
        ctx: &egui::Context,
        task: Task,
        id: &StimulusId,
        size: [usize; 2],
    ) -> (Vec2, Option<String>) {
        let eye = self
            .config
            .set
            .sequences
            .get(id)
            .map_or(size[0] as u32, |s| crate::display::eye_width(s.manifest.view, s.manifest.width));
        let (scale, warning) = fitted_scale(ctx, self.calibration.as_ref(), &self.config.viewing, eye, task, size);
        let points = scale as f32 / ctx.pixels_per_point();
        (Vec2::new(size[0] as f32, size[1] as f32) * points, warning)
    }
}
