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
//!
//! One job per file: this one holds the application and its flow from screen to screen;
//! `config` the configuration and layout, `loading` the decoding and uploading of a
//! trial's stimuli, `screens` what each screen draws.

use std::sync::Arc;

use egui::{Color32, Key};
use study::response::Task;

use crate::RunnerError;
use crate::calibration::Calibration;
use crate::gpu::{FrameUploader, StimulusPipelines};
use crate::playback::{Playback, RefreshEstimate, estimate_refresh};
use crate::schedule::Trial;
use crate::session::{Answer, Session, SessionOptions, check_participant};

mod config;
mod loading;
mod screens;

pub use config::{ASSUMED_REFRESH_HZ, AppConfig, REFRESH_CALIBRATION_FRAMES, REFRESH_CALIBRATION_MAX_S, RefreshChoice};
use loading::{GpuTarget, LOADING_REDRAW, LoadJob, Loaded};

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
        let options =
            SessionOptions { seed: self.config.seed, display: Some(display), attributes, allow_new_session: false };
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
            scale: self.calibration.as_ref().map_or(0.0, |c| c.scale),
            visual_angle_deg: self.calibration.as_ref().map_or(0.0, |c| c.angle_deg),
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
