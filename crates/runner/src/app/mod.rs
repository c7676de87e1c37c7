//! The participant's window: a thin egui layer over [`crate::session`],
//! [`crate::playback`], [`crate::display`] and [`crate::calibration`].
//!
//! Screens: start (the participant's questions above, the experimenter's part below:
//! participant code, calibration with the ruler check, refresh, earlier sessions) ->
//! briefing (reflowed text, the response keys, the glasses to wear, labelled example
//! sequences) -> for each trial: ready (a fixation mark on the neutral field for the
//! definition's `ready_ms`, or until Space, while the frames are decoded on worker threads
//! and uploaded as textures: on eframe's wgpu device by the loader thread and drawn by
//! [`crate::gpu`]'s pipelines, which compose the stereo modes; without one, by egui),
//! presentation (sequences one after the other at their frame rate, paced by [`Playback`],
//! centred in the view), answer (keys or buttons, replay when allowed) -> the end of practice
//! -> breaks -> done. Space or Enter moves on from every screen that waits. Escape asks
//! before quitting a running session; every answered trial is already synced to disk, so
//! quitting loses only the trial on screen, which is shown again when the session resumes.
//!
//! Everything is drawn once, in the participant's *view*, on a mid-grey field
//! ([`FIELD_GREY`]); [`Views`] then puts a copy of it where each eye looks in the
//! side-by-side and top-bottom modes, with each eye's own image in the stimulus's place.
//!
//! One job per file: this one holds the application and its flow from screen to screen;
//! `config` the configuration and layout, `loading` the decoding and uploading of a
//! trial's stimuli, `screens` what each screen draws, `start` the start screen.

use std::sync::Arc;

use egui::{Color32, Key};
use study::response::Task;

use crate::RunnerError;
use crate::calibration::Calibration;
use crate::gpu::{FrameUploader, StimulusPipelines};
use crate::playback::{Playback, RefreshEstimate, estimate_refresh};
use crate::schedule::Trial;
use crate::session::{Answer, Session, SessionOptions, check_participant};
use crate::views::Views;

mod config;
mod loading;
mod screens;
mod start;

pub use config::{ASSUMED_REFRESH_HZ, AppConfig, REFRESH_CALIBRATION_FRAMES, REFRESH_CALIBRATION_MAX_S, RefreshChoice};

/// The neutral field behind everything: the surround, the gap between sequences, the ready
/// screen and the place of a stimulus not playing. sRGB code 128 in every channel, CIE L* 54
/// (perceptual mid-grey), 21.6 % of the display's white in linear light. The thesis gives no
/// surround (its sequences were shown in "similar dim lighting conditions" on a 300 cd/m2 LCD);
/// a mid-grey field keeps the jump from a sequence to the gap small in both directions.
pub const FIELD_GREY: u8 = 128;
/// Text on the field (near-black: contrast 5:1 against it).
const TEXT: Color32 = Color32::from_gray(12);
/// Warnings for the experimenter on the field.
const WARNING: Color32 = Color32::from_rgb(120, 0, 0);
use loading::{GpuTarget, LOADING_REDRAW, LoadJob, Loaded};

// One phase exists at a time; boxing the example's state would only add indirection.
#[allow(clippy::large_enum_variant)]
enum Phase {
    Start,
    Briefing,
    LoadingExample(usize, LoadJob),
    Example { index: usize, loaded: Loaded, playback: Option<Playback> },
    Ready(Box<Ready>),
    Presenting(Box<Presenting>),
    PracticeOver,
    Break,
    Done,
    Closed,
}

/// The ready screen before a trial, while its frames load.
struct Ready {
    trial: Trial,
    job: LoadJob,
    loaded: Option<Loaded>,
    /// When the screen was first drawn.
    since: Option<f64>,
}

struct Presenting {
    trial: Trial,
    loaded: Loaded,
    playback: Option<Playback>,
    replays: u32,
    /// The smallest scale (and its visual angle) the stimuli were drawn at so far.
    shown: Option<(f64, f64)>,
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
    /// Where the view lies for each eye in the current frame.
    views: Views,
    /// Where the stimuli were drawn in the last frame (window points, per slot and eye).
    stimulus_rects: Vec<egui::Rect>,
    /// The experimenter confirmed the ruler check on the start screen.
    ruler_confirmed: bool,
    /// The experimenter confirmed starting a new session after completed ones.
    new_session_confirmed: bool,
    /// What the results hold for the participant code on the start screen (and the code).
    status: Option<(String, Result<crate::session::ParticipantStatus, String>)>,
    styled: bool,
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
            views: Views::of(study::experiment::DisplayMode::Mono, study::View::Mono, egui::Rect::ZERO),
            stimulus_rects: Vec::new(),
            ruler_confirmed: false,
            new_session_confirmed: false,
            status: None,
            styled: false,
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

    /// Whether the session may start as far as the display's refresh goes: a rate was given,
    /// or the measurement is over and found a display refresh (the autopilot of benchmarks
    /// also runs on an assumed rate).
    pub fn ready_to_start(&self) -> bool {
        self.config.refresh_hz.is_some()
            || (self.measuring_done
                && (self.config.autopilot.is_some() || self.measured.is_some_and(|m| m.is_display_refresh())))
    }

    /// Whether the refresh measurement is over and unreliable, so that a session may start
    /// only with `--refresh-hz`.
    pub fn refresh_unreliable(&self) -> bool {
        self.config.refresh_hz.is_none()
            && self.measuring_done
            && !self.measured.is_some_and(|m| m.is_display_refresh())
    }

    /// Where the stimuli were drawn in the last frame, window points: per slot on screen, one
    /// rectangle per eye (two in the side-by-side and top-bottom modes).
    pub fn stimulus_rects(&self) -> &[egui::Rect] {
        &self.stimulus_rects
    }

    /// The view and each eye's region in the last frame.
    pub fn views(&self) -> &Views {
        &self.views
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

    /// The name of the current screen (`start`, `briefing`, `loading`, `ready`,
    /// `presenting`, `answer`, `practice-over`, `break`, `done`, `closed`, `example`).
    pub fn screen(&self) -> &'static str {
        match &self.phase {
            Phase::Start => "start",
            Phase::Briefing => "briefing",
            Phase::LoadingExample(..) => "loading",
            Phase::Ready(r) => {
                if r.loaded.is_some() {
                    "ready"
                } else {
                    "loading"
                }
            }
            Phase::PracticeOver => "practice-over",
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
        let recorded = self.recorded_attributes();
        if recorded.is_none()
            && let Some(i) = self.attributes.iter().position(Option::is_none)
        {
            self.message = Some(format!("Please answer: {}", self.config.definition.attributes[i].question));
            return;
        }
        if self.config.autopilot.is_none() && !self.ruler_confirmed {
            self.message = Some("Experimenter: measure the bar with a ruler and tick the check first.".into());
            return;
        }
        let attributes = match recorded {
            Some(r) => r,
            None => self
                .config
                .definition
                .attributes
                .iter()
                .zip(&self.attributes)
                .map(|(a, sel)| (a.key.clone(), a.options[sel.unwrap_or(0)].clone()))
                .collect(),
        };
        let display = self.config.display_json(&self.refresh());
        let options = SessionOptions {
            seed: self.config.seed,
            display: Some(display),
            attributes,
            allow_new_session: self.new_session_confirmed || self.config.autopilot.is_some(),
        };
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
                    notes.push(resume_note(&session));
                }
                self.message = (!notes.is_empty()).then(|| notes.join("\n"));
                let finished = session.is_finished();
                self.session = Some(session);
                self.phase = if finished { Phase::Done } else { Phase::Briefing };
            }
            Err(e) => self.message = Some(e.to_string()),
        }
    }

    fn next_trial(&mut self) {
        let Some(session) = &self.session else { return };
        match session.current().cloned() {
            None => self.phase = Phase::Done,
            Some(trial) => {
                let job = self.load(&trial.shown);
                self.phase = Phase::Ready(Box::new(Ready { trial, job, loaded: None, since: None }));
            }
        }
    }

    fn answer(&mut self, slot: usize, now: f64) {
        let Phase::Presenting(p) = &mut self.phase else { return };
        let Some(playback) = &p.playback else { return };
        let Some(end) = playback.finished_at else { return };
        let calibrated = self.calibration.as_ref().map(|c| (c.scale, c.angle_deg));
        // No calibration (a failed one): 0 records no scale rather than a guessed one.
        let (scale, visual_angle_deg) = p.shown.or(calibrated).unwrap_or((0.0, 0.0));
        let was_practice = p.trial.practice;
        let answer = Answer {
            slot,
            response_ms: ((now - end).max(0.0) * 1000.0).round() as u64,
            replays: p.replays,
            dropped_frames: playback.dropped,
            frames: playback.presented.clone(),
            scale,
            visual_angle_deg,
        };
        let Some(session) = &mut self.session else { return };
        match session.record(&answer) {
            Ok(row) => {
                self.written.push(row);
                let practice_over = was_practice && session.current().is_some_and(|t| !t.practice);
                if self.config.autopilot.is_some_and(|n| self.written.len() >= n) {
                    self.phase = Phase::Closed;
                } else if session.is_finished() {
                    self.phase = Phase::Done;
                } else if practice_over {
                    self.phase = Phase::PracticeOver;
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

    /// Whether Space or Enter was pressed (moving on from a screen that waits).
    fn continue_pressed(ui: &egui::Ui) -> bool {
        ui.input(|i| i.key_pressed(Key::Space) || i.key_pressed(Key::Enter))
    }

    fn draw_ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let now = ui.input(|i| i.time);
        let escape = ui.input(|i| i.key_pressed(Key::Escape));
        if escape && matches!(self.phase, Phase::Done) {
            // The session is complete and saved: nothing to ask.
            self.phase = Phase::Closed;
        } else if escape && !matches!(self.phase, Phase::Closed) {
            self.confirm_quit = !self.confirm_quit;
        }
        if matches!(self.phase, Phase::Start) {
            self.measure_refresh(&ctx, now);
        }
        if self.config.autopilot.is_some() {
            match self.phase {
                // The autopilot (benchmarks) always lets the refresh measurement finish.
                Phase::Start if self.measuring_done => self.start_session(),
                Phase::Briefing | Phase::Break | Phase::PracticeOver => self.next_trial(),
                Phase::Done => self.phase = Phase::Closed,
                _ => {}
            }
        }
        if self.confirm_quit {
            self.quit_screen(ui, now);
            return;
        }
        match &mut self.phase {
            Phase::Start => self.start_screen(ui),
            Phase::Briefing => self.briefing_screen(ui),
            Phase::LoadingExample(index, job) => {
                let index = *index;
                screens::fixation(ui, self.views.view.center());
                if let Some(decoded) = Self::poll(job, &mut self.message) {
                    let loaded = self.upload(&ctx, Task::TwoAfc, decoded);
                    self.phase = Phase::Example { index, loaded, playback: None };
                    ctx.request_repaint();
                } else {
                    ctx.request_repaint_after(LOADING_REDRAW);
                }
            }
            Phase::Example { .. } => self.example_screen(ui, now),
            Phase::Ready(_) => self.ready_screen(ui, now),
            Phase::Presenting(_) => self.trial_screen(ui, now),
            Phase::PracticeOver => {
                let go = screens::message_screen(
                    ui,
                    "Practice is over",
                    &[
                        "The experiment starts now: from here on your answers count.",
                        "Answer as you did in practice, by your first impression.",
                    ],
                    "Begin the experiment",
                );
                if go || Self::continue_pressed(ui) {
                    self.message = None;
                    self.next_trial();
                }
            }
            Phase::Break => {
                let progress = self.session.as_ref().map(Session::counted_progress).unwrap_or_default();
                let line = format!(
                    "{} done. Rest your eyes, then continue when you are ready.",
                    trials(progress.0, progress.1)
                );
                if screens::message_screen(ui, "Take a break", &[&line], "Continue") || Self::continue_pressed(ui) {
                    self.next_trial();
                }
            }
            Phase::Done => {
                let close = screens::message_screen(
                    ui,
                    "Thank you!",
                    &["The session is complete and your answers are saved.", "Please tell the experimenter."],
                    "Close",
                );
                if close || Self::continue_pressed(ui) {
                    self.phase = Phase::Closed;
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            }
            Phase::Closed => {
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
    }

    /// The answers recorded for a participant whose session will resume (shown instead of
    /// asking again), from the start screen's look at the results.
    fn recorded_attributes(&self) -> Option<Vec<(String, String)>> {
        match &self.status {
            Some((code, Ok(status))) if code == self.code.trim() && start::resumes(status) => {
                Some(status.attributes.clone())
            }
            _ => None,
        }
    }
}

/// "1 trial", "36 trials", "3 of 36 trials".
fn trials(done: usize, total: usize) -> String {
    let noun = |n: usize| if n == 1 { "trial" } else { "trials" };
    if done == total { format!("{done} {}", noun(done)) } else { format!("{done} of {total} {}", noun(total)) }
}

/// What a resumed session says: counted trials answered and the next one, in the numbering
/// the trial screen uses.
fn resume_note(session: &Session) -> String {
    let (done, total) = session.counted_progress();
    match session.current() {
        Some(t) if t.practice => format!("Resuming session {}: practice is not finished.", session.number),
        Some(_) => format!(
            "Resuming session {}: {} answered, next is trial {} of {total}.",
            session.number,
            trials(done, total),
            done + 1
        ),
        None => format!("Session {} is complete.", session.number),
    }
}

impl RunnerApp {
    /// Draws one frame: the field, the view (once), then each eye's copy of it.
    fn frame_ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        if !self.styled {
            style(&ctx);
            self.styled = true;
        }
        if ui.input(|i| i.viewport().close_requested()) && self.close_needs_confirmation() {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm_quit = true;
        }
        let window = ctx.content_rect();
        let view = self.config.set.sequences.values().next().map_or(study::View::Mono, |s| s.manifest.view);
        self.views = Views::of(self.config.display, view, window);
        self.stimulus_rects.clear();
        let layer = ui.layer_id();
        ui.painter().rect_filled(window, 0.0, Color32::from_gray(FIELD_GREY));
        let from = ctx.graphics(|g| g.get(layer).map_or(0, |l| l.next_idx().0));
        let builder = egui::UiBuilder::new().max_rect(self.views.view);
        ui.scope_builder(builder, |ui| {
            ui.set_clip_rect(self.views.view);
            self.draw_ui(ui);
        });
        self.views.compose(&ctx, layer, from);
    }
}

/// The participant's style: dark text on the mid-grey field, buttons a little lighter.
fn style(ctx: &egui::Context) {
    let mut visuals = egui::Visuals::light();
    let field = Color32::from_gray(FIELD_GREY);
    visuals.panel_fill = field;
    visuals.window_fill = field;
    visuals.extreme_bg_color = Color32::from_gray(150);
    visuals.override_text_color = Some(TEXT);
    visuals.warn_fg_color = WARNING;
    visuals.widgets.inactive.weak_bg_fill = Color32::from_gray(160);
    visuals.widgets.inactive.bg_fill = Color32::from_gray(160);
    visuals.widgets.hovered.weak_bg_fill = Color32::from_gray(175);
    visuals.widgets.active.weak_bg_fill = Color32::from_gray(190);
    visuals.selection.bg_fill = Color32::from_gray(100);
    ctx.set_visuals(visuals);
    // Text a participant reads comfortably at 60 cm: 16-point body text.
    ctx.all_styles_mut(|style| {
        use egui::{FontFamily, FontId, TextStyle};
        style.text_styles = [
            (TextStyle::Heading, FontId::new(26.0, FontFamily::Proportional)),
            (TextStyle::Body, FontId::new(16.0, FontFamily::Proportional)),
            (TextStyle::Button, FontId::new(16.0, FontFamily::Proportional)),
            (TextStyle::Small, FontId::new(13.0, FontFamily::Proportional)),
            (TextStyle::Monospace, FontId::new(14.0, FontFamily::Monospace)),
        ]
        .into();
        style.spacing.button_padding = egui::vec2(10.0, 5.0);
    });
}

impl eframe::App for RunnerApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        self.attach_gpu(frame);
        self.frame_ui(ui);
    }

    fn raw_input_hook(&mut self, _ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        self.views.map_input(raw_input);
    }
}

/// Opens the participant's window and runs until it closes. Returns the rows written.
pub fn run_window(config: AppConfig, fullscreen: bool) -> Result<RunnerApp, RunnerError> {
    let no_display = |detail: String| RunnerError::Input {
        what: "window".into(),
        message: format!(
            "no display found{detail}: run in a desktop session, or headless under a virtual X server (`xvfb-run -s \"-screen 0 1920x1080x24\" blurlab run ...`), or simulate participants without a window (`blurlab run --simulate MODEL --seed S`)"
        ),
    };
    if cfg!(target_os = "linux")
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        return Err(no_display(" (DISPLAY and WAYLAND_DISPLAY are unset)".into()));
    }
    // The participant sees the window's title: the participant-facing one.
    let title = config.definition.participant_title.clone();
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
    .map_err(|e| {
        let text = e.to_string();
        let lower = text.to_lowercase();
        if lower.contains("x server") || lower.contains("display") || lower.contains("wayland") {
            no_display(format!(" ({text})"))
        } else {
            RunnerError::Input { what: "window".into(), message: format!("cannot open the window: {text}") }
        }
    })?;
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

    fn raw_input_hook(&mut self, ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        if let Some(app) = &mut self.app {
            eframe::App::raw_input_hook(app, ctx, raw_input);
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
