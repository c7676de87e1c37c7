//! The screens of the participant's window, one method each: start (participant code,
//! attributes, display check), briefing, briefing example and trial (presentation, then
//! the answer), and the redraw timing that paces playback.

use egui::{Color32, Key, RichText, Vec2};
use study::StimulusId;
use study::response::Task;

use super::{Phase, RefreshChoice, RunnerApp};
use crate::playback::{Playback, Screen};
use crate::session::Session;

impl RunnerApp {
    pub(super) fn start_screen(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn briefing_screen(&mut self, ui: &mut egui::Ui) {
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

    pub(super) fn example_screen(&mut self, ui: &mut egui::Ui, now: f64) {
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

    pub(super) fn trial_screen(&mut self, ui: &mut egui::Ui, now: f64) {
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

fn blank(ui: &mut egui::Ui, size: Vec2, text: &str) {
    let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
    ui.painter().rect_filled(rect, 0.0, Color32::from_gray(40));
    if !text.is_empty() {
        ui.painter().text(rect.center(), egui::Align2::CENTER_CENTER, text, egui::FontId::default(), Color32::GRAY);
    }
}
