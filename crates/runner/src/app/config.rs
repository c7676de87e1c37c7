//! What the window is configured with and how it lays a trial out: [`AppConfig`] (the
//! experiment, the set, the viewing set-up), the refresh rate used for pacing
//! ([`RefreshChoice`]), the window size a trial needs, and the scale and texture filter at
//! which stimuli fit the window.

use std::path::PathBuf;

use egui::{Pos2, Rect, TextureOptions, Vec2};
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
        let scale = self.calibration().map_or(1.0, |c| c.scale) as f32;
        // One eye's picture, which is what a view shows and the calibration sizes.
        let (w, h) =
            self.set.sequences.values().next().map_or((640, 360), |s| {
                (crate::display::eye_width(s.manifest.view, s.manifest.width), s.manifest.height)
            });
        let layout = layout_of(self.definition.task);
        let (columns, rows) = (layout.columns as f32, layout.rows as f32);
        let view_w = columns * w as f32 * scale + SLOT_GAP * (columns - 1.0) + 2.0 * MARGIN;
        let each_side = (3.0 * NOMINAL_LINE).max(1.5 * NOMINAL_LINE + NOMINAL_BUTTON) + MARGIN;
        let content_h = rows * h as f32 * scale + (SLOT_GAP + NOMINAL_LINE) * (rows - 1.0) + 2.0 * each_side;
        // Side by side at full resolution, the window holds both eyes' views.
        let stereo = self.definition.view == study::View::Stereo;
        let content_w = if self.display == DisplayMode::SbsFull && stereo { 2.0 * view_w } else { view_w };
        [content_w.max(800.0).ceil(), content_h.max(600.0).ceil()]
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

/// Points between the slots of a matching trial.
pub(super) const SLOT_GAP: f32 = 24.0;
/// The least distance from the stimuli and text to the edge of the view, points.
pub(super) const MARGIN: f32 = 24.0;
/// A text line with spacing at egui's default style, points (for sizing the window only).
const NOMINAL_LINE: f32 = 26.0;
/// A row of buttons, points (for sizing the window only).
const NOMINAL_BUTTON: f32 = 40.0;

fn layout_of(task: Task) -> Layout {
    match task {
        Task::TwoAfc => Layout { columns: 1, rows: 1 },
        Task::Match => Layout { columns: 2, rows: 2 },
    }
}

/// Where a trial's pieces lie in the view (points): the stimuli centred on the view's
/// centre (2AFC: one place for both sequences; matching: the reference centred above its
/// two candidates), each slot's label above it, the notice and progress lines above the
/// stimuli and the question and buttons below them.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TrialLayout {
    /// Stimulus rectangles: 2AFC one; matching the reference, then candidates A and B.
    pub(super) slots: Vec<Rect>,
    /// The label line above each slot.
    pub(super) labels: Vec<Rect>,
    /// The progress line ("Trial 3 of 36") and, above it, the notice line.
    pub(super) progress: Rect,
    pub(super) notice: Rect,
    /// The question line and the row of buttons below the stimuli.
    pub(super) question: Rect,
    pub(super) buttons: Rect,
}

impl TrialLayout {
    /// Lines of text above the stimuli (notice, progress) and below (question), besides the
    /// slot labels and the row of buttons.
    const LINES_ABOVE: f32 = 2.0;

    /// The layout of `task` with stimuli of `stimulus` points in `view`, for text lines of
    /// `line` points and buttons `button` points high.
    pub(super) fn new(view: Rect, task: Task, stimulus: Vec2, line: f32, button: f32) -> TrialLayout {
        let c = view.center();
        let (w, h) = (stimulus.x, stimulus.y);
        let slots: Vec<Rect> = match task {
            Task::TwoAfc => vec![Rect::from_center_size(c, stimulus)],
            Task::Match => {
                // Label, reference, gap, label, candidates: centred as a group.
                let group_h = 2.0 * (line + h) + SLOT_GAP;
                let top = c.y - group_h / 2.0 + line;
                let bottom = top + h + SLOT_GAP + line;
                vec![
                    Rect::from_min_size(Pos2::new(c.x - w / 2.0, top), stimulus),
                    Rect::from_min_size(Pos2::new(c.x - SLOT_GAP / 2.0 - w, bottom), stimulus),
                    Rect::from_min_size(Pos2::new(c.x + SLOT_GAP / 2.0, bottom), stimulus),
                ]
            }
        };
        let labels = slots
            .iter()
            .map(|r| Rect::from_min_max(Pos2::new(r.left(), r.top() - line), Pos2::new(r.right(), r.top())))
            .collect();
        let top = slots.iter().map(|r| r.top()).fold(f32::INFINITY, f32::min) - line;
        let bottom = slots.iter().map(|r| r.bottom()).fold(f32::NEG_INFINITY, f32::max);
        let row =
            |y: f32, height: f32| Rect::from_min_max(Pos2::new(view.left(), y), Pos2::new(view.right(), y + height));
        TrialLayout {
            slots,
            labels,
            progress: row(top - line, line),
            notice: row(top - 2.0 * line, line),
            question: row(bottom + line / 2.0, line),
            buttons: row(bottom + 1.5 * line, button),
        }
    }

    /// The height the text needs on each side of the stimuli for them to stay centred: the
    /// larger of what lies above (notice, progress, a slot label) and below (question,
    /// buttons), plus the margin.
    fn chrome_each_side(line: f32, button: f32) -> f32 {
        ((Self::LINES_ABOVE + 1.0) * line).max(1.5 * line + button) + MARGIN
    }
}

/// The scale (screen pixels per stimulus pixel) at which a trial's stimuli of `stimulus`
/// pixels (one eye's picture) fit the view, and a warning when that is below the
/// calibration.
#[allow(clippy::too_many_arguments)]
fn fitted_scale(
    ctx: &egui::Context,
    view: Rect,
    calibration: Option<&Calibration>,
    viewing: &Viewing,
    eye_width: u32,
    task: Task,
    stimulus: [usize; 2],
) -> (f64, Option<String>) {
    let calibrated = calibration.map_or(1.0, |c| c.scale);
    let ppp = f64::from(ctx.pixels_per_point());
    let (line, button) = text_metrics(ctx);
    let layout = layout_of(task);
    // Matching stacks a second label line between its rows.
    let labels_inside = (layout.rows - 1) as f32 * line;
    let chrome = 2.0 * TrialLayout::chrome_each_side(line, button) + labels_inside;
    let space = (f64::from(view.width() - 2.0 * MARGIN) * ppp, f64::from(view.height() - chrome) * ppp);
    let stim = (stimulus[0] as f64, stimulus[1] as f64);
    let (scale, reduced) = fit_scale(calibrated, stim, layout, space, f64::from(SLOT_GAP) * ppp);
    let warning = reduced.then(|| {
        format!(
            "The window is too small for the calibrated size: stimuli are drawn at {:.0}% ({:.1} instead of {:.1} degrees); this is logged with each trial. Enlarge the window or run full screen.",
            100.0 * scale / calibrated,
            visual_angle_deg(viewing, eye_width, scale),
            visual_angle_deg(viewing, eye_width, calibrated)
        )
    });
    (scale, warning)
}

/// The height of a line of body text and of a button row at the context's style (points).
pub(super) fn text_metrics(ctx: &egui::Context) -> (f32, f32) {
    let style = ctx.global_style();
    let spacing = style.spacing.item_spacing.y;
    let line = ctx.fonts_mut(|f| f.row_height(&egui::TextStyle::Body.resolve(&style))) + spacing;
    let button = style.spacing.interact_size.y + 2.0 * style.spacing.button_padding.y + spacing;
    (line, button)
}

/// How large a trial's stimuli are drawn.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Drawn {
    /// One eye's picture of a stimulus in view points.
    pub(super) size: Vec2,
    /// Screen pixels per stimulus pixel.
    pub(super) scale: f64,
    /// The visual angle one eye's picture subtends at that scale, degrees.
    pub(super) angle_deg: f64,
    /// Set when the view is too small for the calibrated size.
    pub(super) warning: Option<String>,
}

impl RunnerApp {
    /// Sharp texels at an integer calibration that fits the window; smoothing otherwise.
    pub(super) fn filter(&self, ctx: &egui::Context, task: Task, prepared: &[Prepared]) -> TextureOptions {
        let reduced = prepared.first().is_some_and(|d| {
            let eye = [d.eye_width as usize, d.size[1]];
            let cal = self.calibration.as_ref();
            fitted_scale(ctx, self.views.view, cal, &self.config.viewing, d.eye_width, task, eye).1.is_some()
        });
        if !reduced && self.calibration.as_ref().is_none_or(|c| c.integer) {
            TextureOptions::NEAREST
        } else {
            TextureOptions::LINEAR
        }
    }

    /// How a stimulus whose eye's picture is `eye_size` pixels is drawn in a trial (or
    /// example) of `task` in the current view.
    pub(super) fn drawn(&self, ctx: &egui::Context, task: Task, eye_size: [usize; 2]) -> Drawn {
        let eye = eye_size[0] as u32;
        let (scale, warning) =
            fitted_scale(ctx, self.views.view, self.calibration.as_ref(), &self.config.viewing, eye, task, eye_size);
        let points = scale as f32 / ctx.pixels_per_point();
        Drawn {
            size: Vec2::new(eye_size[0] as f32, eye_size[1] as f32) * points,
            scale,
            angle_deg: visual_angle_deg(&self.config.viewing, eye, scale),
            warning,
        }
    }
}
