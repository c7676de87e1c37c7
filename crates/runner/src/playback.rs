//! The steps of a trial and frame pacing.
//!
//! A 2AFC trial plays sequence 1, a gap, sequence 2; a matching trial plays the reference,
//! a gap, the left candidate, a gap, the right candidate. Each sequence plays its frames
//! `loops` times at its own frame rate. [`Playback::update`] is called once per display
//! refresh with the refresh's time and answers what to show. Frame `k` of a slot is due at
//! `k / fps` after the slot starts and is shown at the first refresh at or after that time,
//! so 30 fps on a 60 Hz display shows each frame for two refreshes. A frame shown more than
//! one refresh interval after it was due, or skipped because an earlier refresh came too
//! late, counts as dropped. The timeline is ideal (each step starts exactly when the last
//! ends), so a stall never shifts later frames, it drops them.

use study::response::Task;

/// One frame put on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PresentedFrame {
    /// Position of the sequence in the trial's `shown` list.
    pub slot: u8,
    /// Frame index within the sequence.
    pub frame: u32,
    /// When it was due, milliseconds after the slot's playback began.
    pub due_ms: f64,
    /// When it was shown, milliseconds after the slot's playback began.
    pub shown_ms: f64,
    /// Shown more than one refresh late.
    pub late: bool,
}

/// A step of a trial's presentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Play the sequence at this position of `shown`.
    Play(usize),
    /// A blank gap.
    Gap,
}

/// The steps of a trial with `task`.
pub fn steps(task: Task) -> Vec<Step> {
    match task {
        Task::TwoAfc => vec![Step::Play(0), Step::Gap, Step::Play(1)],
        Task::Match => vec![Step::Play(0), Step::Gap, Step::Play(1), Step::Gap, Step::Play(2)],
    }
}

/// What to show at a refresh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Screen {
    /// Frame `frame` of the sequence in `slot`.
    Frame {
        /// Position in `shown`.
        slot: usize,
        /// Frame index.
        frame: usize,
    },
    /// The blank gap between sequences.
    Gap,
    /// The presentation is over.
    Done,
}

/// The presentation of one trial.
#[derive(Clone, Debug)]
pub struct Playback {
    steps: Vec<Step>,
    /// Per slot: frame count and rate.
    slots: Vec<(usize, f64)>,
    loops: u32,
    gap_s: f64,
    refresh_s: f64,
    step: usize,
    step_start: f64,
    last: Option<usize>,
    /// Every presented frame, over all presentations of the trial.
    pub presented: Vec<PresentedFrame>,
    /// Frames dropped (late or skipped), over all presentations of the trial.
    pub dropped: u32,
    /// When the last presentation ended.
    pub finished_at: Option<f64>,
}

impl Playback {
    /// A presentation of a trial with `task` whose slots have `(frames, fps)`, starting at `now` (seconds).
    pub fn new(task: Task, slots: Vec<(usize, f64)>, loops: u32, gap_ms: u32, refresh_hz: f64, now: f64) -> Self {
        Playback {
            steps: steps(task),
            slots,
            loops: loops.max(1),
            gap_s: f64::from(gap_ms) / 1000.0,
            refresh_s: 1.0 / refresh_hz,
            step: 0,
            step_start: now,
            last: None,
            presented: Vec::new(),
            dropped: 0,
            finished_at: None,
        }
    }

    /// A presentation of one sequence alone (a briefing example).
    pub fn single(frames: usize, fps: f64, loops: u32, refresh_hz: f64, now: f64) -> Self {
        let mut p = Playback::new(Task::TwoAfc, vec![(frames, fps)], loops, 0, refresh_hz, now);
        p.steps = vec![Step::Play(0)];
        p
    }

    /// Starts the presentation again (a replay); dropped frames keep accumulating.
    pub fn restart(&mut self, now: f64) {
        self.step = 0;
        self.step_start = now;
        self.last = None;
        self.finished_at = None;
    }

    /// Whether the presentation is over.
    pub fn is_done(&self) -> bool {
        self.step >= self.steps.len()
    }

    /// What to show at the refresh at time `now` (seconds, same clock as `new`).
    pub fn update(&mut self, now: f64) -> Screen {
        loop {
            let Some(&step) = self.steps.get(self.step) else {
                return Screen::Done;
            };
            let elapsed = now - self.step_start;
            match step {
                Step::Gap => {
                    if elapsed + 1e-9 < self.gap_s {
                        return Screen::Gap;
                    }
                    self.step_start += self.gap_s;
                }
                Step::Play(slot) => {
                    let (frames, fps) = self.slots[slot];
                    let total = frames * self.loops as usize;
                    let due = (elapsed * fps + 1e-6).floor().max(0.0) as usize;
                    if due >= total {
                        let first_missing = self.last.map_or(0, |l| l + 1);
                        self.dropped += (total.saturating_sub(first_missing)) as u32;
                        self.step_start += total as f64 / fps;
                        self.last = None;
                        self.step += 1;
                        if self.is_done() {
                            self.finished_at = Some(self.step_start);
                        }
                        continue;
                    }
                    if self.last != Some(due) {
                        let first_missing = self.last.map_or(0, |l| l + 1);
                        self.dropped += due.saturating_sub(first_missing) as u32;
                        let due_s = due as f64 / fps;
                        let late = elapsed - due_s > self.refresh_s + 1e-6;
                        self.dropped += u32::from(late);
                        self.presented.push(PresentedFrame {
                            slot: slot as u8,
                            frame: (due % frames) as u32,
                            due_ms: due_s * 1000.0,
                            shown_ms: elapsed * 1000.0,
                            late,
                        });
                        self.last = Some(due);
                    }
                    return Screen::Frame { slot, frame: due % frames };
                }
            }
            self.step += 1;
            if self.is_done() {
                self.finished_at = Some(self.step_start);
            }
        }
    }
}

/// Mean, standard deviation and maximum of the intervals between successive times (ms).
pub fn interval_stats(times_ms: &[f64]) -> (f64, f64, f64) {
    let d: Vec<f64> = times_ms.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64;
    (mean, var.sqrt(), d.iter().copied().fold(0.0, f64::max))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(p: &mut Playback, times: impl Iterator<Item = f64>) -> Vec<Screen> {
        times.map(|t| p.update(t)).collect()
    }

    #[test]
    fn thirty_fps_on_sixty_hz_shows_each_frame_for_two_refreshes() {
        let mut p = Playback::new(Task::TwoAfc, vec![(4, 30.0), (4, 30.0)], 1, 100, 60.0, 10.0);
        let screens = run(&mut p, (0..40).map(|i| 10.0 + f64::from(i) / 60.0));
        let frame = |slot, frame| Screen::Frame { slot, frame };
        assert_eq!(
            &screens[..8],
            &[frame(0, 0), frame(0, 0), frame(0, 1), frame(0, 1), frame(0, 2), frame(0, 2), frame(0, 3), frame(0, 3)]
        );
        // 4 frames = 133 ms, then a 100 ms gap (6 refreshes), then slot 1.
        assert_eq!(&screens[8..14], &[Screen::Gap; 6]);
        assert_eq!(screens[14], frame(1, 0));
        assert_eq!(screens[21], frame(1, 3));
        assert_eq!(screens[22], Screen::Done);
        assert_eq!(p.dropped, 0);
        assert_eq!(p.presented.len(), 8);
        assert!((p.finished_at.unwrap() - (10.0 + 2.0 * 4.0 / 30.0 + 0.1)).abs() < 1e-9);
    }

    #[test]
    fn a_stall_drops_the_frames_it_skips_and_loops_repeat_frames() {
        let mut p = Playback::new(Task::Match, vec![(3, 30.0); 3], 2, 0, 60.0, 0.0);
        // Refreshes at 60 Hz except a 120 ms stall after the first one.
        let mut times: Vec<f64> = vec![0.0];
        times.extend((8..80).map(|i| f64::from(i) / 60.0));
        let screens = run(&mut p, times.into_iter());
        // Due frames 1, 2, 3 at 33, 67, 100 ms were skipped; frame 4 at 133 ms shown on time.
        assert_eq!(screens[1], Screen::Frame { slot: 0, frame: 1 });
        assert_eq!(p.presented[1].frame, 1);
        assert_eq!(p.dropped, 3);
        // Each slot shows 6 frames (3 frames x 2 loops); the first slot showed 3 of them.
        assert_eq!(p.presented.iter().filter(|f| f.slot == 0).count(), 3);
        assert_eq!(p.presented.iter().filter(|f| f.slot == 2).count(), 6);
        assert_eq!(*screens.last().unwrap(), Screen::Done);
        // Replay: starts over, counts accumulate.
        p.restart(100.0);
        assert_eq!(p.update(100.0), Screen::Frame { slot: 0, frame: 0 });
        assert_eq!(p.update(100.25), Screen::Frame { slot: 1, frame: 1 });
        assert!(p.dropped > 3);
        assert_eq!(interval_stats(&[0.0, 10.0, 30.0]), (15.0, 5.0, 20.0));
    }

    #[test]
    fn a_frame_shown_more_than_a_refresh_late_is_dropped() {
        let mut p = Playback::new(Task::TwoAfc, vec![(2, 30.0), (2, 30.0)], 1, 0, 60.0, 0.0);
        p.update(0.0);
        // Frame 1 due at 33.3 ms, shown at 60 ms (more than 16.7 ms late).
        assert_eq!(p.update(0.060), Screen::Frame { slot: 0, frame: 1 });
        assert_eq!(p.dropped, 1);
        assert!(p.presented[1].late);
    }
}
