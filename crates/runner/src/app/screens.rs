//! The participant's screens after the start screen, one method each: briefing, briefing
//! example, ready (fixation while a trial loads), trial (presentation, then the answer), the
//! quit question and the short message screens (end of practice, break, done), with the
//! layout helpers they share and the redraw timing that paces playback.
//!
//! Everything is laid out in the view ([`crate::views::Views`]): text in a centred column of
//! readable width, stimuli centred on the view's centre ([`TrialLayout`]).

use egui::{Color32, Key, Pos2, Rect, RichText, Vec2};
use study::experiment::DisplayMode;
use study::response::Task;

use super::config::{MARGIN, TrialLayout, text_metrics};
use super::{Phase, Presenting, Ready, RunnerApp, WARNING};
use crate::playback::{Playback, Screen};
use crate::session::Session;

/// The widest a column of text gets (points): about 80 characters of body text.
pub(super) const COLUMN_WIDTH: f32 = 760.0;
/// The width of each button of a trial's answer row (points).
const BUTTON_WIDTH: f32 = 210.0;

/// Runs `add` in a column of readable width centred in the view, starting `top` points down.
pub(super) fn column<R>(ui: &mut egui::Ui, top: f32, add: impl FnOnce(&mut egui::Ui) -> R) -> R {
    let view = ui.max_rect();
    let width = COLUMN_WIDTH.min(view.width() - 2.0 * MARGIN).max(100.0);
    let rect = Rect::from_min_max(
        Pos2::new(view.center().x - width / 2.0, view.top() + top),
        Pos2::new(view.center().x + width / 2.0, view.bottom() - MARGIN),
    );
    ui.scope_builder(egui::UiBuilder::new().max_rect(rect), add).inner
}

/// A short screen: a heading and lines, centred in the view, with one button. Returns whether
/// the button was clicked.
pub(super) fn message_screen(ui: &mut egui::Ui, heading: &str, lines: &[&str], button: &str) -> bool {
    let top = (ui.max_rect().height() / 2.0 - 90.0).max(MARGIN);
    column(ui, top, |ui| {
        ui.vertical_centered(|ui| {
            ui.heading(heading);
            ui.add_space(8.0);
            for l in lines {
                ui.label(*l);
            }
            ui.add_space(12.0);
            let clicked = ui.add(egui::Button::new(button).min_size(Vec2::new(BUTTON_WIDTH, 0.0))).clicked();
            ui.small("or press Space");
            clicked
        })
        .inner
    })
}

/// The fixation mark: a small dark cross where the stimulus will be.
pub(super) fn fixation(ui: &egui::Ui, centre: Pos2) {
    let stroke = egui::Stroke::new(2.0, Color32::from_gray(30));
    ui.painter().line_segment([centre - Vec2::new(10.0, 0.0), centre + Vec2::new(10.0, 0.0)], stroke);
    ui.painter().line_segment([centre - Vec2::new(0.0, 10.0), centre + Vec2::new(0.0, 10.0)], stroke);
}

/// A centred line of text in `rect` (a label, so that it is part of the accessibility tree).
fn centred_label(ui: &mut egui::Ui, rect: Rect, text: impl Into<egui::WidgetText>) {
    ui.put(rect, egui::Label::new(text).halign(egui::Align::Center).selectable(false));
}

/// The briefing's text with its paragraphs reflowed: the definition's line breaks inside a
/// paragraph become spaces; blank lines separate paragraphs.
pub(super) fn paragraphs(text: &str) -> Vec<String> {
    text.split("\n\n").map(|p| p.split_whitespace().collect::<Vec<_>>().join(" ")).filter(|p| !p.is_empty()).collect()
}

/// What to wear, for the modes that need glasses (participant-facing).
pub(super) fn glasses(mode: DisplayMode, stereo: bool) -> Option<&'static str> {
    if !stereo {
        return None;
    }
    match mode {
        DisplayMode::Anaglyph => {
            Some("Please wear the red-cyan glasses: red filter over your LEFT eye, cyan over your right.")
        }
        DisplayMode::RowInterleaved => Some("Please wear the polarised 3D glasses that belong to this monitor."),
        DisplayMode::SbsHalf | DisplayMode::TopBottom => {
            Some("Please wear the 3D glasses that belong to this display, and keep them on for the whole session.")
        }
        DisplayMode::SbsFull => Some("Look into the stereoscope so that each eye sees its own half of the screen."),
        DisplayMode::Mono => None,
    }
}

impl RunnerApp {
    pub(super) fn briefing_screen(&mut self, ui: &mut egui::Ui) {
        let d = &self.config.definition;
        let practice = self.session.as_ref().and_then(Session::current).is_some_and(|t| t.practice);
        let stereo = d.view == study::View::Stereo;
        let mut chosen = None;
        let mut begin = false;
        column(ui, MARGIN, |ui| {
            ui.heading(&d.participant_title);
            if let Some(m) = &self.message {
                ui.colored_label(WARNING, m);
            }
            ui.add_space(6.0);
            for p in paragraphs(&d.briefing.text) {
                ui.label(p);
                ui.add_space(4.0);
            }
            if let Some(g) = glasses(self.config.display, stereo) {
                ui.label(RichText::new(g).strong());
                ui.add_space(4.0);
            }
            let k = &d.keys;
            let (first, second) = match d.task {
                Task::TwoAfc => ("the first sequence", "the second"),
                Task::Match => ("the left candidate", "the right one"),
            };
            let mut keys = format!("Answer with the keys {} ({first}) and {} ({second})", k.first, k.second);
            if d.presentation.replay {
                keys.push_str(&format!("; {} plays the trial again", k.replay));
            }
            keys.push_str(". You may also click the buttons.");
            ui.label(keys);
            for (i, e) in d.briefing.examples.iter().enumerate() {
                ui.horizontal_wrapped(|ui| {
                    if ui.button(format!("Show example: {}", e.label)).clicked() {
                        chosen = Some(i);
                    }
                    ui.label(&e.description);
                });
            }
            ui.add_space(8.0);
            ui.label(RichText::new(&d.question).strong());
            ui.add_space(8.0);
            ui.vertical_centered(|ui| {
                let label = if practice { "Begin practice" } else { "Begin" };
                begin = ui.add(egui::Button::new(label).min_size(Vec2::new(BUTTON_WIDTH, 0.0))).clicked();
                ui.small("or press Space");
            });
        });
        if begin || (chosen.is_none() && Self::continue_pressed(ui)) {
            self.message = None;
            self.next_trial();
        } else if let Some(i) = chosen {
            let id = self.config.definition.briefing.examples[i].stimulus;
            let job = self.load(&[id]);
            self.phase = Phase::LoadingExample(i, job);
        }
    }

    pub(super) fn example_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let (line, button) = text_metrics(ui.ctx());
        let drawn = match &self.phase {
            Phase::Example { index, loaded, .. } => {
                let id = self.config.definition.briefing.examples[*index].stimulus;
                self.drawn(ui.ctx(), Task::TwoAfc, loaded.size[&id])
            }
            _ => return,
        };
        let layout = TrialLayout::new(self.views.view, Task::TwoAfc, drawn.size, line, button);
        let refresh_hz = self.refresh().hz;
        let views = self.views.clone();
        let Phase::Example { index, loaded, playback } = &mut self.phase else { return };
        let example = &self.config.definition.briefing.examples[*index];
        let id = example.stimulus;
        let (frames, fps) = (loaded.textures[&id].len(), loaded.fps[&id]);
        let pb = playback.get_or_insert_with(|| Playback::single(frames, fps, 1, refresh_hz, now));
        centred_label(ui, layout.notice, RichText::new(format!("Example: {}", example.label)).strong());
        centred_label(ui, layout.progress, example.description.as_str());
        if let Some(w) = &drawn.warning {
            centred_label(ui, layout.labels[0], RichText::new(w).color(WARNING).small());
        }
        // The example plays until the participant goes back.
        let mut screen = pb.update(now);
        if screen == Screen::Done {
            pb.restart(now);
            screen = pb.update(now);
        }
        if let Screen::Frame { frame, .. } = screen {
            let rects = loaded.textures[&id].paint(ui, frame, layout.slots[0], &views);
            self.stimulus_rects.extend(rects);
            repaint_at(ui.ctx(), pb, now);
        }
        let again = button_row(ui, layout.buttons, &["Play again", "Back to the briefing"]);
        if again == Some(0) {
            pb.restart(now);
        } else if again == Some(1) || ui.input(|i| i.key_pressed(Key::Backspace)) {
            self.phase = Phase::Briefing;
        }
    }

    pub(super) fn ready_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let pres = &self.config.definition.presentation;
        let (ready_s, press) = (f64::from(pres.ready_ms) / 1000.0, pres.ready_press);
        let centre = self.views.view.center();
        let ctx = ui.ctx().clone();
        let progress = self.session.as_ref().map(Session::counted_progress).unwrap_or_default();
        let (line, _) = text_metrics(&ctx);
        let Phase::Ready(r) = &mut self.phase else { return };
        let since = *r.since.get_or_insert(now);
        fixation(ui, centre);
        let row = |k: f32| Rect::from_center_size(centre + Vec2::new(0.0, k * line), Vec2::new(COLUMN_WIDTH, line));
        let label = if r.trial.practice {
            "Practice trial (not counted)".to_owned()
        } else {
            format!("Trial {} of {}", progress.0 + 1, progress.1)
        };
        centred_label(ui, row(-3.0), label);
        if r.loaded.is_none() {
            if let Some(decoded) = Self::poll(&mut r.job, &mut self.message) {
                let task = r.trial.task;
                let loaded = self.upload(&ctx, task, decoded);
                let Phase::Ready(r) = &mut self.phase else { return };
                r.loaded = Some(loaded);
                ctx.request_repaint();
                return;
            }
            if now - since > ready_s {
                // Loading outlasts the ready time: say why the trial has not started.
                ui.put(row(3.0), Self::progress_bar(&r.job, COLUMN_WIDTH / 2.0));
            }
            if let Some(m) = &self.message {
                centred_label(ui, row(5.0), RichText::new(m).color(WARNING));
            }
            ctx.request_repaint_after(super::LOADING_REDRAW);
            return;
        }
        let waited = now - since >= ready_s;
        if press {
            centred_label(ui, row(3.0), "Press Space when you are ready");
        }
        let go = waited && (!press || Self::continue_pressed(ui) || self.config.autopilot.is_some());
        if !go {
            if !press {
                ctx.request_repaint_after(std::time::Duration::from_secs_f64((since + ready_s - now).max(0.0)));
            }
            return;
        }
        let Phase::Ready(r) = std::mem::replace(&mut self.phase, Phase::Briefing) else { return };
        let Ready { trial, loaded, .. } = *r;
        let loaded = loaded.expect("checked above");
        self.phase = Phase::Presenting(Box::new(Presenting { trial, loaded, playback: None, replays: 0, shown: None }));
        ctx.request_repaint();
    }

    pub(super) fn trial_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let refresh = self.refresh().hz;
        let pres = &self.config.definition.presentation;
        let (loops, gap, replay_ok) = (pres.loops, pres.gap_ms, pres.replay);
        let keys = self.config.definition.keys.clone();
        let question = self.config.definition.question.clone();
        let progress = self.session.as_ref().map(|s| s.counted_progress()).unwrap_or_default();
        let (line, button) = text_metrics(ui.ctx());
        let drawn = match &self.phase {
            Phase::Presenting(p) => self.drawn(ui.ctx(), p.trial.task, p.loaded.size[&p.trial.shown[0]]),
            _ => return,
        };
        let views = self.views.clone();
        let Phase::Presenting(p) = &mut self.phase else { return };
        let trial = p.trial.clone();
        let layout = TrialLayout::new(views.view, trial.task, drawn.size, line, button);
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
            // The smallest size the stimuli were shown at is what the log records.
            if p.shown.is_none_or(|(s, _)| drawn.scale < s) {
                p.shown = Some((drawn.scale, drawn.angle_deg));
            }
        }
        if let Some(m) = &self.message {
            centred_label(ui, layout.notice, RichText::new(m).color(WARNING));
        } else if let Some(w) = &drawn.warning {
            centred_label(ui, layout.notice, RichText::new(w).color(WARNING).small());
        }
        if trial.practice {
            centred_label(ui, layout.progress, RichText::new("Practice trial (not counted)").italics());
        } else {
            centred_label(ui, layout.progress, format!("Trial {} of {}", progress.0 + 1, progress.1));
        }
        let labels: &[&str] = match trial.task {
            Task::TwoAfc => &["Sequence 1", "Sequence 2"],
            Task::Match => &["Reference", "Candidate A", "Candidate B"],
        };
        match trial.task {
            Task::TwoAfc => {
                // One place on screen, labelled with the sequence playing (or last played).
                let slot = match screen {
                    Screen::Frame { slot, .. } => slot,
                    Screen::Gap | Screen::Done => 1,
                };
                centred_label(ui, layout.labels[0], labels[slot]);
                if let Screen::Frame { frame, .. } = screen {
                    let rects = loaded.textures[&trial.shown[slot]].paint(ui, frame, layout.slots[0], &views);
                    self.stimulus_rects.extend(rects);
                }
            }
            Task::Match => {
                for (slot, rect) in layout.slots.iter().enumerate() {
                    centred_label(ui, layout.labels[slot], labels[slot]);
                    if let Screen::Frame { slot: s, frame } = screen
                        && s == slot
                    {
                        let rects = loaded.textures[&trial.shown[slot]].paint(ui, frame, *rect, &views);
                        self.stimulus_rects.extend(rects);
                    }
                }
            }
        }
        if screen != Screen::Done {
            return;
        }
        centred_label(ui, layout.question, RichText::new(&question).strong());
        let (first, second) = match trial.task {
            Task::TwoAfc => ("Sequence 1", "Sequence 2"),
            Task::Match => ("Candidate A", "Candidate B"),
        };
        let mut texts = vec![format!("{first} [{}]", keys.first), format!("{second} [{}]", keys.second)];
        if replay_ok {
            texts.push(format!("Replay [{}]", keys.replay));
        }
        let texts: Vec<&str> = texts.iter().map(String::as_str).collect();
        let clicked = button_row(ui, layout.buttons, &texts);
        let mut choice = clicked.filter(|&b| b < 2);
        let mut replay = clicked == Some(2);
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

    /// The question Escape (or the window's close button) asks during a session.
    pub(super) fn quit_screen(&mut self, ui: &mut egui::Ui, now: f64) {
        let ctx = ui.ctx().clone();
        let path = self.session.as_ref().map(|s| s.path().display().to_string());
        let running = matches!(self.phase, Phase::Ready(_) | Phase::Presenting(_));
        let top = (ui.max_rect().height() / 2.0 - 90.0).max(MARGIN);
        let choice = column(ui, top, |ui| {
            ui.vertical_centered(|ui| {
                ui.heading("Quit the experiment?");
                if self.session.is_some() {
                    ui.label("Every answer so far is saved.");
                }
                if running {
                    ui.label("The trial on screen will be shown again when you resume.");
                }
                if let Some(p) = &path {
                    ui.small(format!("Saved in {p}"));
                }
                ui.add_space(12.0);
                let quit = ui.add(egui::Button::new("Quit").min_size(Vec2::new(BUTTON_WIDTH, 0.0))).clicked();
                let cont = ui.add(egui::Button::new("Continue").min_size(Vec2::new(BUTTON_WIDTH, 0.0))).clicked();
                ui.small("Escape continues");
                (quit, cont)
            })
            .inner
        });
        match choice {
            (true, _) => {
                self.confirm_quit = false;
                self.phase = super::Phase::Closed;
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
            (_, true) => {
                self.confirm_quit = false;
                if let Phase::Presenting(p) = &mut self.phase
                    && let Some(pb) = &mut p.playback
                    && !pb.is_done()
                {
                    pb.restart(now);
                }
            }
            _ => {}
        }
    }
}

/// A row of equal buttons centred in `rect`; the index of the one clicked.
fn button_row(ui: &mut egui::Ui, rect: Rect, texts: &[&str]) -> Option<usize> {
    let gap = 16.0;
    let n = texts.len() as f32;
    let width = (BUTTON_WIDTH * n + gap * (n - 1.0)).min(rect.width());
    let each = (width - gap * (n - 1.0)) / n;
    let mut clicked = None;
    for (i, t) in texts.iter().enumerate() {
        let x = rect.center().x - width / 2.0 + i as f32 * (each + gap);
        let r = Rect::from_min_size(Pos2::new(x, rect.top()), Vec2::new(each, rect.height() - 8.0));
        if ui.put(r, egui::Button::new(*t)).clicked() {
            clicked = Some(i);
        }
    }
    clicked
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn briefing_paragraphs_are_reflowed() {
        let text = "You will watch short\nanimations of a ball.\n\n  Watch for\nnoise.  \n\n\n";
        assert_eq!(paragraphs(text), vec!["You will watch short animations of a ball.", "Watch for noise."]);
    }

    #[test]
    fn glasses_are_named_for_every_stereo_mode_that_needs_them() {
        assert!(glasses(DisplayMode::Anaglyph, true).unwrap().contains("red filter over your LEFT eye"));
        assert!(glasses(DisplayMode::RowInterleaved, true).unwrap().contains("polarised"));
        assert_eq!(glasses(DisplayMode::Mono, true), None);
        assert_eq!(glasses(DisplayMode::Anaglyph, false), None);
    }

    #[test]
    fn trial_layout_centres_the_stimuli_in_the_view() {
        let view = Rect::from_min_size(Pos2::new(0.0, 0.0), Vec2::new(1920.0, 1080.0));
        let stim = Vec2::new(640.0, 360.0);
        let two = TrialLayout::new(view, Task::TwoAfc, stim, 20.0, 30.0);
        assert_eq!(two.slots, vec![Rect::from_center_size(view.center(), stim)]);
        assert!(two.progress.bottom() <= two.labels[0].top() && two.buttons.top() > two.slots[0].bottom());
        let m = TrialLayout::new(view, Task::Match, stim, 20.0, 30.0);
        // The reference centred over its candidates; the group centred in the view.
        assert_eq!(m.slots[0].center().x, view.center().x);
        assert_eq!((m.slots[1].right() + m.slots[2].left()) / 2.0, view.center().x);
        let group = Rect::from_min_max(m.labels[0].min, m.slots[2].max);
        assert!((group.center().y - view.center().y).abs() < 1e-3, "{group:?}");
        assert_eq!(m.slots[1].top(), m.slots[2].top());
        assert!(m.slots[1].top() > m.slots[0].bottom() + 20.0);
    }
}
