//! The start screen: the participant's part (the participant-facing title and the
//! attributes asked, or the answers recorded when a session resumes) above the
//! experimenter's part (experiment, participant code, earlier sessions, display mode, screen
//! size against the window system's, calibration with the ruler check, the refresh rate), and
//! the Start button, which stays disabled until the checks allow a session.

use egui::{Color32, Key, RichText, Vec2};

use super::screens::{column, glasses};
use super::{RunnerApp, WARNING};
use crate::session::{ParticipantStatus, participant_status};

/// The screen's width in pixels as the window system reports it (the monitor's size in
/// points times pixels per point), when it does.
pub(super) fn monitor_width_px(ctx: &egui::Context) -> Option<u32> {
    let (size, ppp) = ctx.input(|i| (i.viewport().monitor_size, i.pixels_per_point));
    size.filter(|s| s.x > 0.0).map(|s| (s.x * ppp).round() as u32)
}

impl RunnerApp {
    /// Looks at the results for the code on the start screen when it changes.
    fn refresh_status(&mut self) {
        let code = self.code.trim().to_owned();
        if self.status.as_ref().is_some_and(|(c, _)| *c == code) {
            return;
        }
        self.new_session_confirmed = false;
        self.status = crate::session::check_participant(&code).is_ok().then(|| {
            let status = participant_status(&self.config.results_dir, &self.config.definition, &code);
            (code, status.map_err(|e| e.to_string()))
        });
        // A new session of a known participant starts from the answers on record (shown, and
        // changeable); a resumed one keeps them as they are.
        if let Some((_, Ok(status))) = &self.status {
            for (a, sel) in self.config.definition.attributes.iter().zip(self.attributes.iter_mut()) {
                let recorded = status.attributes.iter().find(|(k, _)| *k == a.key);
                if sel.is_none()
                    && let Some(i) = recorded.and_then(|(_, v)| a.options.iter().position(|o| o == v))
                {
                    *sel = Some(i);
                }
            }
        }
    }

    pub(super) fn start_screen(&mut self, ui: &mut egui::Ui) {
        self.refresh_status();
        let recorded = self.recorded_attributes();
        let d = self.config.definition.clone();
        let ctx = ui.ctx().clone();
        let mut start = false;
        let ready = self.ready_to_start();
        column(ui, 24.0, |ui| {
            ui.heading(&d.participant_title);
            if let Some(m) = &self.message {
                ui.colored_label(WARNING, m);
            }
            ui.add_space(6.0);
            match &recorded {
                Some(answers) => {
                    ui.label("Welcome back. Your answers from last time:");
                    for (a, (_, value)) in d.attributes.iter().zip(answers) {
                        ui.label(format!("{} {value}", a.question));
                    }
                }
                None => {
                    for (a, sel) in d.attributes.iter().zip(self.attributes.iter_mut()) {
                        ui.label(&a.question);
                        ui.horizontal(|ui| {
                            for (i, option) in a.options.iter().enumerate() {
                                ui.radio_value(sel, Some(i), option);
                            }
                        });
                    }
                }
            }
            ui.add_space(10.0);
            ui.separator();
            ui.label(RichText::new("Experimenter").strong());
            let title = if d.title.is_empty() { String::new() } else { format!(": {}", d.title) };
            ui.small(format!("Experiment {}{title}", d.name));
            if self.config.participant.is_some() {
                ui.label(format!("Participant code: {}", self.code.trim()));
            } else {
                ui.horizontal(|ui| {
                    ui.label("Participant code");
                    ui.add(egui::TextEdit::singleline(&mut self.code).hint_text("e.g. P01").desired_width(120.0));
                });
                ui.small("A pseudonymous code, never a name.");
            }
            match &self.status {
                Some((_, Ok(status))) => {
                    for line in describe(status) {
                        ui.small(line);
                    }
                    if status.new_session_needs_confirmation() {
                        ui.checkbox(&mut self.new_session_confirmed, "Start a new session for this participant");
                    }
                }
                Some((_, Err(e))) => {
                    ui.colored_label(WARNING, e);
                }
                None => {}
            }
            let stereo = d.view == study::View::Stereo;
            ui.small(format!("Display mode: {}", self.config.display));
            if let Some(g) = glasses(self.config.display, stereo) {
                ui.small(format!("Participant is told: {g}"));
            }
            let v = &self.config.viewing;
            ui.small(format!(
                "Screen: {} px and {:.1} cm wide, viewed from {:.0} cm",
                v.screen_width_px, v.screen_width_cm, v.distance_cm
            ));
            if let Some(px) = monitor_width_px(&ctx)
                && px != v.screen_width_px
            {
                ui.colored_label(
                    WARNING,
                    format!(
                        "The window system reports a screen {px} px wide, but the calibration assumes {} px: quit and pass --screen-width-px {px} with the screen's width in cm (--screen-width-cm).",
                        v.screen_width_px
                    ),
                );
            }
            match &self.calibration {
                Some(c) => {
                    ui.small(format!(
                        "Calibration: scale {:.3}{} for {:.2} degrees",
                        c.scale,
                        if c.integer { " (integer)" } else { "" },
                        c.angle_deg
                    ));
                    if let Some(w) = &c.warning {
                        ui.colored_label(WARNING, format!("Warning: {w}"));
                    }
                    let ppp = ctx.pixels_per_point();
                    let cm = c.target_px * v.screen_width_cm / f64::from(v.screen_width_px);
                    let (rect, _) =
                        ui.allocate_exact_size(Vec2::new((c.target_px as f32) / ppp, 12.0), egui::Sense::hover());
                    ui.painter().rect_filled(rect, 0.0, Color32::from_gray(20));
                    ui.checkbox(
                        &mut self.ruler_confirmed,
                        format!("I measured this bar with a ruler: it is {cm:.1} cm long"),
                    );
                }
                None => {
                    ui.colored_label(WARNING, "Calibration failed: check the screen size and distance.");
                }
            }
            self.refresh_lines(ui);
            ui.add_space(8.0);
            ui.vertical_centered(|ui| {
                let button = egui::Button::new("Start").min_size(Vec2::new(190.0, 0.0));
                start = ui.add_enabled(ready, button).clicked();
                ui.small("or press Enter");
            });
        });
        // Enter starts unless a widget has the keyboard focus: then it presses that widget
        // (egui's keyboard use), and a focused checkbox must not be toggled and ignored.
        let focused = ctx.memory(|m| m.focused().is_some());
        if ready && (start || (!focused && ui.input(|i| i.key_pressed(Key::Enter)))) {
            self.start_session();
        }
    }

    /// The refresh measurement's lines, loud when it is unreliable.
    fn refresh_lines(&self, ui: &mut egui::Ui) {
        let refresh = self.refresh();
        match (&refresh.measured, self.config.refresh_hz) {
            (_, None) if !self.measuring_done => {
                ui.small("Display refresh: measuring...");
            }
            (Some(m), given) => {
                ui.small(format!(
                    "Display refresh: {:.2} Hz measured (median of {} frame intervals, {:.2} ms, spread {:.1}%)",
                    m.hz(),
                    m.intervals,
                    m.interval_ms,
                    100.0 * m.spread
                ));
                if given.is_some() {
                    ui.small(format!("Pacing uses {:.2} Hz from --refresh-hz.", refresh.hz));
                } else if !m.is_display_refresh() {
                    ui.colored_label(WARNING, RichText::new(unreliable(&refresh.source)).strong());
                }
            }
            (None, Some(hz)) => {
                ui.small(format!("Display refresh: {hz:.2} Hz (--refresh-hz)"));
            }
            (None, None) => {
                ui.colored_label(WARNING, RichText::new(unreliable(&refresh.source)).strong());
            }
        }
    }
}

/// Whether starting now resumes an incomplete session.
pub(super) fn resumes(status: &ParticipantStatus) -> bool {
    status.last().is_some_and(|s| !s.completed)
}

/// The experimenter's lines about a participant's earlier sessions and what Start does.
fn describe(status: &ParticipantStatus) -> Vec<String> {
    let mut lines: Vec<String> = status
        .sessions
        .iter()
        .map(|s| {
            let state = if s.completed { "complete" } else { "incomplete" };
            format!(
                "Session {}: {} of {} trials answered, {} practice ({state})",
                s.number, s.counted_answered, s.counted_total, s.practice_answered
            )
        })
        .collect();
    let next = status.next_session();
    lines.push(match status.last() {
        None => format!("New participant: Start begins session {next}."),
        Some(s) if !s.completed => format!("Start resumes session {next} with the answers recorded."),
        Some(_) => format!("Every session is complete: Start begins session {next} once you confirm below."),
    });
    lines
}

fn unreliable(source: &str) -> String {
    format!(
        "THE DISPLAY'S REFRESH COULD NOT BE MEASURED RELIABLY ({source}). Frames would not be paced to the display. Quit and run again with --refresh-hz HZ, the monitor's refresh rate."
    )
}
