//! The participant's window: a thin egui layer over [`crate::session`],
//! [`crate::playback`], [`crate::display`] and [`crate::calibration`].
//!
//! Screens: start (participant code, attributes, display check) -> briefing (text and
//! labelled example sequences) -> for each trial: loading (frames decoded on worker threads
//! with a progress bar, then uploaded as textures: on eframe's wgpu device by the loader
//! thread and drawn by [`crate::gpu`]'s pipelines, which compose the anaglyph; without one,
//! by egui), presentation (sequences one after the
//! other at their frame rate, paced by [`Playback`]), answer (keys or buttons, replay when
//! allowed) -> breaks -> done. Escape asks before quitting; every answered trial is already
//! synced to disk, so quitting loses only the trial on screen, which is shown again when the
//! session resumes.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

use egui::{Color32, Key, RichText, TextureHandle, TextureOptions, Vec2};
use study::StimulusId;
use study::experiment::{DisplayMode, ExperimentDefinition};
use study::response::Task;

use crate::RunnerError;
use crate::calibration::{Calibration, Layout, Viewing, calibrate, fit_scale, visual_angle_deg};
use crate::gpu::{Draw, FrameUploader, StimulusCallback, StimulusPipelines};
use crate::playback::{Playback, RefreshEstimate, Screen, estimate_refresh};
use crate::schedule::Trial;
use crate::session::{Answer, Session, SessionOptions, check_participant};
use crate::stimuli::{StimulusSet, decode_sequence_for};

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

/// How often the loading screen redraws its progress bar: not continuously, so the window
/// leaves the cores to the frame decoders (it is checked again within this delay).
const LOADING_REDRAW: std::time::Duration = std::time::Duration::from_millis(15);

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

/// Stimuli decoded and uploaded for one trial or example.
struct Loaded {
    textures: HashMap<StimulusId, Frames>,
    fps: HashMap<StimulusId, f64>,
    size: HashMap<StimulusId, [usize; 2]>,
}

/// The textures of one sequence's frames.
enum Frames {
    /// Managed by egui (uploaded by egui at the next paint; without a wgpu device).
    Egui {
        /// Per frame.
        handles: Vec<TextureHandle>,
        /// Row-interleaved stereo (image rows interleaved on the CPU), drawn only where each
        /// image row lands on one screen line of its eye ([`interleave_origin`]).
        interleaved: bool,
    },
    /// Uploaded by the loader thread ([`FrameUploader`]) and drawn by a paint callback with
    /// the [`StimulusPipelines`] (one bind group per frame, which keeps its texture alive).
    Native {
        /// Per frame.
        binds: Vec<eframe::wgpu::BindGroup>,
        /// A copy of the display image, or a composition of a stereo frame.
        draw: Draw,
        /// The sampler's filter the frames were bound with.
        filter: eframe::wgpu::FilterMode,
    },
}

impl Frames {
    fn len(&self) -> usize {
        match self {
            Frames::Egui { handles, .. } => handles.len(),
            Frames::Native { binds, .. } => binds.len(),
        }
    }

    /// Draws frame `frame` at `size` points.
    fn show(&self, ui: &mut egui::Ui, frame: usize, size: Vec2) {
        match self {
            Frames::Egui { handles, interleaved: false } => {
                ui.image(egui::load::SizedTexture::new(handles[frame].id(), size));
            }
            Frames::Egui { handles, interleaved: true } => {
                let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
                let ppp = ui.ctx().pixels_per_point();
                let image_h = handles[frame].size()[1];
                let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
                match interleave_origin(rect.min, ppp, image_h, size.y) {
                    // Up to 2 pixels lower and 1 to the right: within the item spacing.
                    Some(origin) => {
                        let at = egui::Rect::from_min_size(origin, size);
                        ui.painter().image(handles[frame].id(), at, uv, Color32::WHITE);
                    }
                    None => {
                        ui.painter().image(handles[frame].id(), rect, uv, Color32::WHITE);
                        let lines = size.y * ppp / image_h.max(1) as f32;
                        let warning = interleave_warning(lines);
                        if !INTERLEAVE_WARNED.swap(true, Ordering::Relaxed) {
                            eprintln!("warning: {warning}");
                        }
                        ui.colored_label(Color32::RED, warning);
                    }
                }
            }
            Frames::Native { binds, draw, filter } => {
                let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
                let callback = StimulusCallback { bind: binds[frame].clone(), draw: *draw, filter: *filter };
                ui.painter().add(eframe::egui_wgpu::Callback::new_paint_callback(rect, callback));
            }
        }
    }
}

/// A sequence made ready by the loader thread.
struct Prepared {
    id: StimulusId,
    fps: f64,
    eye_width: u32,
    /// Display image size.
    size: [usize; 2],
    content: Content,
}

enum Content {
    /// Decoded display images, for egui to upload, and whether they are row-interleaved
    /// stereo ([`Frames::Egui`]).
    Images(Vec<egui::ColorImage>, bool),
    /// Textures already on the GPU, drawn as `Draw` says.
    Textures(Vec<eframe::wgpu::Texture>, Draw, GpuTarget),
}

/// The device the loader thread uploads with and the pipelines that draw the frames (also in
/// egui-wgpu's callback resources), when eframe runs on wgpu.
#[derive(Clone)]
struct GpuTarget {
    uploader: Arc<FrameUploader>,
    pipelines: Arc<StimulusPipelines>,
}

struct LoadJob {
    total: usize,
    progress: Arc<AtomicUsize>,
    handle: Option<JoinHandle<Result<Vec<Prepared>, RunnerError>>>,
}

// One phase exists at a time; boxing the example's state would only add indirection.
#[allow(clippy::large_enum_variant)]
enum Phase {
    Start,
    Briefing,
    LoadingExample(usize, LoadJob),
    Example { index: usize, loaded: Loaded, playback: Option<Playback> },
    Loading(Trial, LoadJob),
    Presenting(Box<Presenting>),
    Break,
    Done,
    Closed,
}

struct Presenting {
    trial: Trial,
    loaded: Loaded,
    playback: Option<Playback>,
    replays: u32,
}

/// The eframe application.
pub struct RunnerApp {
    config: AppConfig,
    calibration: Option<Calibration>,
    phase: Phase,
    session: Option<Session>,
    code: String,
    attributes: Vec<Option<usize>>,
    confirm_quit: bool,
    message: Option<String>,
    /// Rows written by this window (for tests and the experimenter's summary).
    pub written: Vec<study::response::TrialRow>,
    /// Intervals (ms) between successive redraws while a trial plays (frame-pacing benchmarks).
    pub refresh_intervals_ms: Vec<f64>,
    last_refresh: Option<f64>,
    /// Frame times of the start screen's refresh measurement (seconds).
    present_times: Vec<f64>,
    measured: Option<RefreshEstimate>,
    measuring_done: bool,
    /// eframe's wgpu device and the stimulus pipelines, once the first frame has shown the
    /// device (`None` in headless tests and with the glow renderer: egui uploads the frames
    /// then, and the display transforms all run on the CPU).
    gpu: Option<GpuTarget>,
}

impl RunnerApp {
    /// A window at its start screen.
    pub fn new(config: AppConfig) -> Self {
        let calibration = config.calibration().ok();
        let code = config.participant.clone().unwrap_or_default();
        let attributes = vec![None; config.definition.attributes.len()];
        RunnerApp {
            config,
            calibration,
            phase: Phase::Start,
            session: None,
            code,
            attributes,
            confirm_quit: false,
            message: None,
            written: Vec::new(),
            refresh_intervals_ms: Vec::new(),
            last_refresh: None,
            present_times: Vec::new(),
            measured: None,
            measuring_done: false,
            gpu: None,
        }
    }

    /// Takes eframe's wgpu device (once) for uploading frames off the window's thread.
    fn attach_gpu(&mut self, frame: &eframe::Frame) {
        if self.gpu.is_none()
            && let Some(rs) = frame.wgpu_render_state()
        {
            let pipelines = Arc::new(StimulusPipelines::new(&rs.device, rs.target_format));
            rs.renderer.write().callback_resources.insert(pipelines.clone());
            self.gpu = Some(GpuTarget {
                uploader: Arc::new(FrameUploader::new(rs.device.clone(), rs.queue.clone())),
                pipelines,
            });
        }
    }

    /// The refresh rate used for pacing (measured on the start screen unless given).
    pub fn refresh(&self) -> RefreshChoice {
        RefreshChoice::choose(self.config.refresh_hz, self.measured, self.measuring_done)
    }

    /// Whether a close request (the window's close button) must ask first: while a session
    /// is open and not finished, as Escape does. The answered trials are on disk already; the
    /// question keeps a stray click from ending the session.
    pub fn close_needs_confirmation(&self) -> bool {
        self.session.is_some() && !matches!(self.phase, Phase::Done | Phase::Closed)
    }

    /// Whether the session may start: the refresh measurement is over or a rate was given.
    pub fn ready_to_start(&self) -> bool {
        self.measuring_done || self.config.refresh_hz.is_some()
    }

    /// Takes the time of a start-screen frame for the refresh measurement (frames are drawn
    /// back to back while it runs, so their spacing is the display's refresh on a window
    /// locked to it).
    fn measure_refresh(&mut self, ctx: &egui::Context, now: f64) {
        if self.measuring_done {
            return;
        }
        self.present_times.push(now);
        let first = self.present_times[0];
        if self.present_times.len() >= REFRESH_CALIBRATION_FRAMES || now - first >= REFRESH_CALIBRATION_MAX_S {
            self.measured = estimate_refresh(&self.present_times);
            self.measuring_done = true;
        } else {
            ctx.request_repaint();
        }
    }

    /// The open session, once started.
    pub fn session(&self) -> Option<&Session> {
        self.session.as_ref()
    }

    /// The name of the current screen (`start`, `briefing`, `loading`, `presenting`,
    /// `answer`, `break`, `done`, `closed`, `example`).
    pub fn screen(&self) -> &'static str {
        match &self.phase {
            Phase::Start => "start",
            Phase::Briefing => "briefing",
            Phase::LoadingExample(..) | Phase::Loading(..) => "loading",
            Phase::Example { .. } => "example",
            Phase::Presenting(p) => {
                if p.playback.as_ref().is_some_and(Playback::is_done) {
                    "answer"
                } else {
                    "presenting"
                }
            }
            Phase::Break => "break",
            Phase::Done => "done",
            Phase::Closed => "closed",
        }
    }

    /// Whether the quit confirmation is showing.
    pub fn confirming_quit(&self) -> bool {
        self.confirm_quit
    }

    /// The last error or notice shown.
    pub fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }

    fn start_session(&mut self) {
        if let Err(e) = check_participant(self.code.trim()) {
            self.message = Some(e.to_string());
            return;
        }
        if let Some(i) = self.attributes.iter().position(Option::is_none) {
            self.message = Some(format!("Please answer: {}", self.config.definition.attributes[i].question));
            return;
        }
        let attributes = self
            .config
            .definition
            .attributes
            .iter()
            .zip(&self.attributes)
            .map(|(a, sel)| (a.key.clone(), a.options[sel.unwrap_or(0)].clone()))
            .collect();
        let display = self.config.display_json(&self.refresh());
        let options = SessionOptions { seed: self.config.seed, display: Some(display), attributes };
        match Session::open(
            &self.config.definition,
            &self.config.set,
            &self.config.results_dir,
            self.code.trim(),
            &options,
        ) {
            Ok(session) => {
                let mut notes = session.warnings.clone();
                if session.resumed {
                    notes.push(format!("Resuming session {} at trial {}.", session.number, session.next + 1));
                }
                self.message = (!notes.is_empty()).then(|| notes.join("\n"));
                let finished = session.is_finished();
                self.session = Some(session);
                self.phase = if finished { Phase::Done } else { Phase::Briefing };
            }
            Err(e) => self.message = Some(e.to_string()),
        }
    }

    fn load(&self, ids: &[StimulusId]) -> LoadJob {
        let mut unique: Vec<StimulusId> = ids.to_vec();
        unique.sort();
        unique.dedup();
        let sequences: Vec<_> = unique.iter().map(|id| self.config.set.sequence(id).clone()).collect();
        let total = sequences.iter().map(|s| s.manifest.frames.len()).sum();
        let progress = Arc::new(AtomicUsize::new(0));
        let (mode, threads, counter) = (self.config.display, self.config.decode_threads, progress.clone());
        let gpu = self.gpu.clone();
        let handle = std::thread::spawn(move || {
            let prepare = |s: &crate::stimuli::Sequence| -> Result<Prepared, RunnerError> {
                let d = decode_sequence_for(s, mode, gpu.is_some(), &counter, threads)?;
                let size = d.display_size();
                let content = match &gpu {
                    Some(g) => Content::Textures(g.uploader.upload(&d)?, Draw::of(&d)?, g.clone()),
                    None => {
                        let interleaved = mode == DisplayMode::RowInterleaved && s.manifest.view == study::View::Stereo;
                        Content::Images(d.frames, interleaved)
                    }
                };
                Ok(Prepared { id: d.id, fps: d.fps, eye_width: d.eye_width, size, content })
            };
            sequences.iter().map(prepare).collect::<Result<Vec<_>, _>>()
        });
        LoadJob { total, progress, handle: Some(handle) }
    }

    fn next_trial(&mut self) {
        let Some(session) = &self.session else { return };
        match session.current().cloned() {
            None => self.phase = Phase::Done,
            Some(trial) => {
                let job = self.load(&trial.shown);
                self.phase = Phase::Loading(trial, job);
            }
        }
    }

    /// Hands prepared sequences to the window: images for egui to upload, or textures bound
    /// for the runner's stimulus pipelines.
    fn upload(ctx: &egui::Context, prepared: Vec<Prepared>, filter: TextureOptions) -> Loaded {
        let mut loaded = Loaded { textures: HashMap::new(), fps: HashMap::new(), size: HashMap::new() };
        for d in prepared {
            loaded.size.insert(d.id, d.size);
            let frames = match d.content {
                Content::Images(images, interleaved) => Frames::Egui {
                    handles: images
                        .into_iter()
                        .enumerate()
                        .map(|(i, image)| ctx.load_texture(format!("{}#{i}", d.id), image, filter))
                        .collect(),
                    interleaved,
                },
                Content::Textures(textures, draw, gpu) => {
                    let filter_mode = match filter.magnification {
                        egui::TextureFilter::Nearest => eframe::wgpu::FilterMode::Nearest,
                        egui::TextureFilter::Linear => eframe::wgpu::FilterMode::Linear,
                    };
                    let device = gpu.uploader.device();
                    let binds = textures.iter().map(|t| gpu.pipelines.bind(device, t, draw, filter_mode)).collect();
                    Frames::Native { binds, draw, filter: filter_mode }
                }
            };
            loaded.fps.insert(d.id, d.fps);
            loaded.textures.insert(d.id, frames);
        }
        loaded
    }

    fn answer(&mut self, slot: usize, now: f64) {
        let Phase::Presenting(p) = &mut self.phase else { return };
        let Some(playback) = &p.playback else { return };
        let Some(end) = playback.finished_at else { return };
        let answer = Answer {
            slot,
            response_ms: ((now - end).max(0.0) * 1000.0).round() as u64,
            replays: p.replays,
            dropped_frames: playback.dropped,
            frames: playback.presented.clone(),
        };
        let Some(session) = &mut self.session else { return };
        match session.record(&answer) {
            Ok(row) => {
                self.written.push(row);
                if self.config.autopilot.is_some_and(|n| self.written.len() >= n) {
                    self.phase = Phase::Closed;
                } else if session.is_finished() {
                    self.phase = Phase::Done;
                } else if session.break_due() {
                    self.phase = Phase::Break;
                } else {
                    self.next_trial();
                }
            }
            Err(e) => self.message = Some(format!("Could not save the answer: {e}")),
        }
    }

    fn key(&self, name: &str) -> Option<Key> {
        Key::from_name(name)
    }

    fn draw_ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let now = ui.input(|i| i.time);
        if ui.input(|i| i.key_pressed(Key::Escape)) && !matches!(self.phase, Phase::Closed) {
            self.confirm_quit = !self.confirm_quit;
        }
        if matches!(self.phase, Phase::Start) {
            self.measure_refresh(&ctx, now);
        }
        if self.config.autopilot.is_some() {
            match self.phase {
                // The autopilot (benchmarks) always lets the refresh measurement finish.
                Phase::Start if self.measuring_done => self.start_session(),
                Phase::Briefing | Phase::Break => self.next_trial(),
                Phase::Done => self.phase = Phase::Closed,
                _ => {}
            }
        }
        if self.confirm_quit {
            ui.heading("Quit the experiment?");
            ui.label("Every answer so far is saved. The trial on screen will be shown again when you resume.");
            if let Some(s) = &self.session {
                ui.label(format!("Saved in {}", s.path().display()));
            }
            ui.horizontal(|ui| {
                if ui.button("Quit").clicked() {
                    self.confirm_quit = false;
                    self.phase = Phase::Closed;
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
                if ui.button("Continue").clicked() {
                    self.confirm_quit = false;
                    if let Phase::Presenting(p) = &mut self.phase
                        && let Some(pb) = &mut p.playback
                        && !pb.is_done()
                    {
                        pb.restart(now);
                    }
                }
            });
            return;
        }
        if let Some(m) = &self.message {
            ui.colored_label(Color32::from_rgb(230, 160, 60), m);
        }
        match &mut self.phase {
            Phase::Start => self.start_screen(ui),
            Phase::Briefing => self.briefing_screen(ui),
            Phase::LoadingExample(index, job) => {
                let index = *index;
                if let Some(decoded) = Self::poll(ui, job, &mut self.message) {
                    let filter = self.filter(&ctx, Task::TwoAfc, &decoded);
                    let loaded = Self::upload(&ctx, decoded, filter);
                    self.phase = Phase::Example { index, loaded, playback: None };
                    ctx.request_repaint();
                } else {
                    ctx.request_repaint_after(LOADING_REDRAW);
                }
            }
            Phase::Example { .. } => self.example_screen(ui, now),
            Phase::Loading(trial, job) => {
                ui.label(format!("Preparing trial {}...", trial.index + 1));
                if let Some(decoded) = Self::poll(ui, job, &mut self.message) {
                    let trial = trial.clone();
                    let filter = self.filter(&ctx, trial.task, &decoded);
                    let loaded = Self::upload(&ctx, decoded, filter);
                    self.phase = Phase::Presenting(Box::new(Presenting { trial, loaded, playback: None, replays: 0 }));
                    ctx.request_repaint();
                } else {
                    ctx.request_repaint_after(LOADING_REDRAW);
                }
            }
            Phase::Presenting(_) => self.trial_screen(ui, now),
            Phase::Break => {
                ui.heading("Take a break");
                if let Some((done, total)) = self.session.as_ref().map(Session::counted_progress) {
                    ui.label(format!("{done} of {total} trials done. Continue when you are ready."));
                }
                if ui.button("Continue").clicked() {
                    self.next_trial();
                }
            }
            Phase::Done => {
                ui.heading("Thank you!");
                ui.label("The session is complete and saved.");
                if let Some(s) = &self.session {
                    ui.label(format!("{}", s.path().display()));
                }
                if ui.button("Close").clicked() {
                    self.phase = Phase::Closed;
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            }
            Phase::Closed => {
                ui.label("Closed.");
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
    }

    /// Sharp texels at an integer calibration that fits the window; smoothing otherwise.
    fn filter(&self, ctx: &egui::Context, task: Task, prepared: &[Prepared]) -> TextureOptions {
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
    fn drawn_size(&self, ctx: &egui::Context, task: Task, id: &StimulusId, size: [usize; 2]) -> (Vec2, Option<String>) {
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

    fn poll(ui: &mut egui::Ui, job: &mut LoadJob, message: &mut Option<String>) -> Option<Vec<Prepared>> {
        let done = job.progress.load(Ordering::Relaxed);
        ui.add(
            egui::ProgressBar::new(done as f32 / job.total.max(1) as f32)
                .text(format!("{done} / {} frames", job.total)),
        );
        if job.handle.as_ref().is_some_and(JoinHandle::is_finished) {
            let handle = job.handle.take().expect("checked above");
            match handle.join() {
                Ok(Ok(decoded)) => return Some(decoded),
                Ok(Err(e)) => *message = Some(e.to_string()),
                Err(_) => *message = Some("the frame decoder crashed".into()),
            }
        }
        None
    }

    fn start_screen(&mut self, ui: &mut egui::Ui) {
        let d = &self.config.definition;
        ui.heading(if d.title.is_empty() { d.name.as_str() } else { d.title.as_str() });
        ui.horizontal(|ui| {
            ui.label("Participant code");
            ui.add(egui::TextEdit::singleline(&mut self.code).hint_text("e.g. P01"));
        });
        ui.small("Use the code you were given. Never type your name.");
        for (a, sel) in d.attributes.iter().zip(self.attributes.iter_mut()) {
            ui.label(&a.question);
            ui.horizontal(|ui| {
                for (i, option) in a.options.iter().enumerate() {
                    ui.radio_value(sel, Some(i), option);
                }
            });
        }
        ui.separator();
        ui.label(format!("Display mode: {}", self.config.display));
        match &self.calibration {
            Some(c) => {
                let ppp = ui.ctx().pixels_per_point();
                let v = &self.config.viewing;
                ui.label(format!(
                    "Calibration: scale {:.3}{} for {:.2} degrees at {} cm",
                    c.scale,
                    if c.integer { " (integer)" } else { "" },
                    c.angle_deg,
                    v.distance_cm
                ));
                if let Some(w) = &c.warning {
                    ui.colored_label(Color32::YELLOW, format!("Warning: {w}"));
                }
                let cm = c.target_px * v.screen_width_cm / f64::from(v.screen_width_px);
                ui.label(format!("Display check: this bar should measure {cm:.1} cm on the screen."));
                let (rect, _) =
                    ui.allocate_exact_size(Vec2::new((c.target_px as f32) / ppp, 12.0), egui::Sense::hover());
                ui.painter().rect_filled(rect, 0.0, Color32::WHITE);
            }
            None => {
                ui.colored_label(Color32::YELLOW, "Calibration failed: check the screen size and distance.");
            }
        }
        let refresh = self.refresh();
        match (&refresh.measured, self.config.refresh_hz) {
            (_, None) if !self.measuring_done => {
                ui.label("Display refresh: measuring...");
            }
            (Some(m), given) => {
                let text = format!(
                    "Display refresh: {:.2} Hz measured (median of {} frame intervals, {:.2} ms, spread {:.1}%)",
                    m.hz(),
                    m.intervals,
                    m.interval_ms,
                    100.0 * m.spread
                );
                ui.label(text);
                if given.is_some() {
                    ui.label(format!("Pacing uses {:.2} Hz from --refresh-hz.", refresh.hz));
                } else if !m.is_display_refresh() {
                    ui.colored_label(
                        Color32::YELLOW,
                        format!("Warning: pacing uses {:.0} Hz, {}", refresh.hz, refresh.source),
                    );
                }
            }
            (None, Some(hz)) => {
                ui.label(format!("Display refresh: {hz:.2} Hz (--refresh-hz)"));
            }
            (None, None) => {
                ui.colored_label(
                    Color32::YELLOW,
                    format!("Warning: pacing uses {:.0} Hz, {}", refresh.hz, refresh.source),
                );
            }
        }
        ui.separator();
        let ready = self.ready_to_start();
        let clicked = ui.add_enabled(ready, egui::Button::new("Start")).clicked();
        if ready && (clicked || ui.input(|i| i.key_pressed(Key::Enter))) {
            self.start_session();
        }
    }

    fn briefing_screen(&mut self, ui: &mut egui::Ui) {
        let d = &self.config.definition;
        ui.heading("Briefing");
        ui.label(d.briefing.text.trim());
        let mut chosen = None;
        for (i, e) in d.briefing.examples.iter().enumerate() {
            ui.horizontal(|ui| {
                if ui.button(format!("Show example: {}", e.label)).clicked() {
                    chosen = Some(i);
                }
                ui.label(&e.description);
            });
        }
        ui.label(RichText::new(&d.question).strong());
        let practice = self.session.as_ref().and_then(Session::current).is_some_and(|t| t.practice);
        if ui.button(if practice { "Begin practice" } else { "Begin" }).clicked() {
            self.message = None;
            self.next_trial();
        } else if let Some(i) = chosen {
            let id = self.config.definition.briefing.examples[i].stimulus;
            let job = self.load(&[id]);
            self.phase = Phase::LoadingExample(i, job);
        }
    }

    fn example_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let (scale_points, warning) = match &self.phase {
            Phase::Example { index, loaded, .. } => {
                let id = self.config.definition.briefing.examples[*index].stimulus;
                let size = loaded.size[&id];
                let (drawn, warning) = self.drawn_size(ui.ctx(), Task::TwoAfc, &id, size);
                (drawn.x / size[0].max(1) as f32, warning)
            }
            _ => return,
        };
        let Phase::Example { index, loaded, playback } = &mut self.phase else { return };
        let example = &self.config.definition.briefing.examples[*index];
        let id = example.stimulus;
        let (frames, fps) = (loaded.textures[&id].len(), loaded.fps[&id]);
        let refresh_hz = RefreshChoice::choose(self.config.refresh_hz, self.measured, self.measuring_done).hz;
        let pb = playback.get_or_insert_with(|| Playback::single(frames, fps, 1, refresh_hz, now));
        ui.heading(&example.label);
        ui.label(&example.description);
        let size = loaded.size[&id];
        let size = Vec2::new(size[0] as f32, size[1] as f32) * scale_points;
        if let Some(w) = &warning {
            ui.colored_label(Color32::YELLOW, w);
        }
        match pb.update(now) {
            Screen::Frame { frame, .. } => {
                loaded.textures[&id].show(ui, frame, size);
                repaint_at(ui.ctx(), pb, now);
            }
            _ => {
                blank(ui, size, "");
            }
        }
        let mut back = false;
        ui.horizontal(|ui| {
            if ui.button("Play again").clicked() {
                pb.restart(now);
            }
            back = ui.button("Back to the briefing").clicked();
        });
        if back {
            self.phase = Phase::Briefing;
        }
    }

    fn trial_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let refresh = self.refresh().hz;
        let pres = &self.config.definition.presentation;
        let (loops, gap, replay_ok) = (pres.loops, pres.gap_ms, pres.replay);
        let keys = self.config.definition.keys.clone();
        let question = self.config.definition.question.clone();
        let progress = self.session.as_ref().map(|s| s.counted_progress()).unwrap_or_default();
        let (scale, warning) = match &self.phase {
            Phase::Presenting(p) => {
                let id = p.trial.shown[0];
                let size = p.loaded.size[&id];
                let (drawn, warning) = self.drawn_size(ui.ctx(), p.trial.task, &id, size);
                (drawn.x / size[0].max(1) as f32, warning)
            }
            _ => return,
        };
        let Phase::Presenting(p) = &mut self.phase else { return };
        let trial = p.trial.clone();
        let loaded = &p.loaded;
        let pb = p.playback.get_or_insert_with(|| {
            let slots = trial.shown.iter().map(|id| (loaded.textures[id].len(), loaded.fps[id])).collect();
            Playback::new(trial.task, slots, loops, gap, refresh, now)
        });
        let screen = pb.update(now);
        if pb.is_done() {
            self.last_refresh = None;
        } else {
            if let Some(prev) = self.last_refresh {
                self.refresh_intervals_ms.push((now - prev) * 1000.0);
            }
            self.last_refresh = Some(now);
            repaint_at(ui.ctx(), pb, now);
        }
        if trial.practice {
            ui.label(RichText::new("Practice trial (not counted)").italics());
        } else {
            ui.label(format!("Trial {} of {}", progress.0 + 1, progress.1));
        }
        if let Some(w) = &warning {
            ui.colored_label(Color32::YELLOW, w);
        }
        let size_of = |id: &StimulusId| {
            let s = loaded.size[id];
            Vec2::new(s[0] as f32, s[1] as f32) * scale
        };
        let labels: Vec<&str> = match trial.task {
            Task::TwoAfc => vec!["Sequence 1", "Sequence 2"],
            Task::Match => vec!["Reference", "Candidate A", "Candidate B"],
        };
        let draw_slot = |ui: &mut egui::Ui, slot: usize| {
            let id = &trial.shown[slot];
            ui.vertical(|ui| {
                ui.label(labels[slot]);
                match screen {
                    Screen::Frame { slot: s, frame } if s == slot => {
                        loaded.textures[id].show(ui, frame, size_of(id));
                    }
                    _ => blank(ui, size_of(id), ""),
                }
            });
        };
        match trial.task {
            Task::TwoAfc => {
                // One place on screen, labelled with the sequence playing (or last played).
                let slot = match screen {
                    Screen::Frame { slot, .. } => slot,
                    Screen::Gap => 1,
                    Screen::Done => 1,
                };
                draw_slot(ui, slot);
            }
            Task::Match => {
                draw_slot(ui, 0);
                ui.horizontal(|ui| {
                    draw_slot(ui, 1);
                    draw_slot(ui, 2);
                });
            }
        }
        if screen != Screen::Done {
            return;
        }
        ui.label(RichText::new(&question).strong());
        let (first, second) = match trial.task {
            Task::TwoAfc => ("Sequence 1", "Sequence 2"),
            Task::Match => ("Candidate A", "Candidate B"),
        };
        let mut choice = None;
        let mut replay = false;
        ui.horizontal(|ui| {
            if ui.button(format!("{first} [{}]", keys.first)).clicked() {
                choice = Some(0);
            }
            if ui.button(format!("{second} [{}]", keys.second)).clicked() {
                choice = Some(1);
            }
            if replay_ok && ui.button(format!("Replay [{}]", keys.replay)).clicked() {
                replay = true;
            }
        });
        let pressed = |k: &str| self.key(k).is_some_and(|k| ui.input(|i| i.key_pressed(k)));
        if pressed(&keys.first) {
            choice = Some(0);
        } else if pressed(&keys.second) {
            choice = Some(1);
        } else if replay_ok && pressed(&keys.replay) {
            replay = true;
        }
        if self.config.autopilot.is_some() {
            choice = Some(0);
        }
        if let Some(slot) = choice {
            self.answer(slot, now);
            ui.ctx().request_repaint();
        } else if replay && let Phase::Presenting(p) = &mut self.phase {
            p.replays += 1;
            if let Some(pb) = &mut p.playback {
                pb.restart(now);
            }
            ui.ctx().request_repaint();
        }
    }
}

/// How long after a change is due the redraw showing it is asked for (seconds): timers may
/// fire a little early, and a redraw before the change would show the old image and leave
/// the change to the redraw after it, a whole redraw later.
const WAKE_MARGIN_S: f64 = 0.001;

/// Asks for the next redraw when the screen next changes (the next frame or the end of a gap),
/// instead of redrawing in between, when a redraw would show the same image. egui hands the
/// delay to eframe at once, which counts it from then (a moment after `now`, the pass's start)
/// and starts the redraw at that time, or as soon as the current one is presented if that is
/// later; so one redraw per frame starts just after the frame is due.
fn repaint_at(ctx: &egui::Context, playback: &Playback, now: f64) {
    if let Some(change) = playback.next_change() {
        ctx.request_repaint_after(std::time::Duration::from_secs_f64((change - now).max(0.0) + WAKE_MARGIN_S));
    }
}

/// Whether the row-interleave warning has been logged (once per process).
static INTERLEAVE_WARNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Where the CPU fallback (no wgpu device: egui's textures) draws a row-interleaved image,
/// whose even image rows come from the left eye, so that every image row lands on one screen
/// line of its eye (even physical lines from the top of the framebuffer: left): at one screen
/// line per image row, its top on the first even physical line at or below `min.y` and its
/// left on a whole pixel (points: `min`; `pixels_per_point`; the image's height in pixels;
/// its drawn height in points). `None` at any other scale: image rows then cover several
/// lines or fall between them, and only the wgpu renderer (which picks the eye per screen
/// line) shows the right eye on every line.
fn interleave_origin(min: egui::Pos2, pixels_per_point: f32, image_h: usize, drawn_h: f32) -> Option<egui::Pos2> {
    let lines = drawn_h * pixels_per_point;
    if image_h == 0 || (lines - image_h as f32).abs() > 0.01 {
        return None;
    }
    let top = (min.y * pixels_per_point - 0.01).ceil();
    let top = if top.rem_euclid(2.0) == 1.0 { top + 1.0 } else { top };
    let left = (min.x * pixels_per_point - 0.01).ceil();
    Some(egui::pos2(left / pixels_per_point, top / pixels_per_point))
}

/// The warning shown (and logged once) when the CPU fallback cannot show row-interleaved
/// stereo right: the stimulus is drawn at `lines` screen lines per image row.
fn interleave_warning(lines: f32) -> String {
    format!(
        "Row-interleaved stereo is WRONG here: without the wgpu renderer each image row must cover exactly one screen line, but the stimulus is drawn at {lines:.2} screen lines per row, so each eye sees parts of the other's image. Run the runner with the wgpu renderer, or at a calibration of one screen pixel per stimulus pixel."
    )
}

fn blank(ui: &mut egui::Ui, size: Vec2, text: &str) {
    let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
    ui.painter().rect_filled(rect, 0.0, Color32::from_gray(40));
    if !text.is_empty() {
        ui.painter().text(rect.center(), egui::Align2::CENTER_CENTER, text, egui::FontId::default(), Color32::GRAY);
    }
}

impl eframe::App for RunnerApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        self.attach_gpu(frame);
        if ui.input(|i| i.viewport().close_requested()) && self.close_needs_confirmation() {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm_quit = true;
        }
        egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| self.draw_ui(ui));
    }
}

/// Opens the participant's window and runs until it closes. Returns the rows written.
pub fn run_window(config: AppConfig, fullscreen: bool) -> Result<RunnerApp, RunnerError> {
    let title = format!("blurlab: {}", config.definition.name);
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(title.clone())
            .with_inner_size(config.window_size())
            .with_fullscreen(fullscreen),
        ..Default::default()
    };
    let shared: Arc<std::sync::Mutex<Option<RunnerApp>>> = Arc::new(std::sync::Mutex::new(None));
    let out = shared.clone();
    let app = RunnerApp::new(config);
    eframe::run_native(
        &title,
        options,
        Box::new(move |_cc| Ok(Box::new(Holder { app: Some(app), out }) as Box<dyn eframe::App>)),
    )
    .map_err(|e| RunnerError::Input { what: "window".into(), message: format!("cannot open the window: {e}") })?;
    let app =
        shared.lock().map_err(|_| RunnerError::Input { what: "window".into(), message: "state lost".into() })?.take();
    app.ok_or_else(|| RunnerError::Input { what: "window".into(), message: "the window closed before starting".into() })
}

/// Hands the app back to [`run_window`] when eframe drops it.
struct Holder {
    app: Option<RunnerApp>,
    out: Arc<std::sync::Mutex<Option<RunnerApp>>>,
}

impl eframe::App for Holder {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        if let Some(app) = &mut self.app {
            eframe::App::ui(app, ui, frame);
        }
    }
}

impl Drop for Holder {
    fn drop(&mut self) {
        if let Ok(mut slot) = self.out.lock() {
            *slot = self.app.take();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_row_interleave_is_placed_on_an_even_screen_line_or_refused() {
        let at = |y: f32, ppp: f32, image_h: usize, drawn_h: f32| {
            interleave_origin(egui::pos2(10.3, y), ppp, image_h, drawn_h)
        };
        // One screen line per image row: the top moves down to the next even physical line.
        assert_eq!(at(20.0, 1.0, 360, 360.0), Some(egui::pos2(11.0, 20.0)));
        assert_eq!(at(21.0, 1.0, 360, 360.0), Some(egui::pos2(11.0, 22.0)));
        assert_eq!(at(20.4, 1.0, 360, 360.0), Some(egui::pos2(11.0, 22.0)));
        // pixels_per_point 2: 180 points are 360 lines; point 10.75 is line 21.5, so line 22.
        assert_eq!(at(10.75, 2.0, 360, 180.0), Some(egui::pos2(10.5, 11.0)));
        // pixels_per_point 1.5: point 7 is line 10.5, so line 12 (point 8).
        assert_eq!(at(7.0, 1.5, 360, 240.0), Some(egui::pos2(16.0 / 1.5, 8.0)));
        // Any other scale cannot be right on the CPU: 2 lines per row, 1.5, half a line.
        assert_eq!(at(20.0, 1.0, 360, 720.0), None);
        assert_eq!(at(20.0, 1.0, 360, 540.0), None);
        assert_eq!(at(20.0, 2.0, 360, 360.0), None);
        assert_eq!(at(20.0, 1.0, 0, 0.0), None);
        let w = interleave_warning(2.0);
        assert!(w.contains("2.00 screen lines per row") && w.contains("wgpu renderer"), "{w}");
    }
}
