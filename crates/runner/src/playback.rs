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
use study::stats::median;

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

    /// When the screen next changes (the next frame or the end of a gap is due), in seconds on
    /// the clock of `new`; `None` when the presentation is over. Call after [`Playback::update`].
    pub fn next_change(&self) -> Option<f64> {
        let step = *self.steps.get(self.step)?;
        Some(match step {
            Step::Gap => self.step_start + self.gap_s,
            Step::Play(slot) => {
                let (frames, fps) = self.slots[slot];
                let total = frames * self.loops as usize;
                let next = self.last.map_or(0, |l| l + 1).min(total);
                self.step_start + next as f64 / fps
            }
        })
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

/// The display's refresh interval estimated from the times of successive presents.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RefreshEstimate {
    /// Median interval between successive presents, milliseconds.
    pub interval_ms: f64,
    /// Intervals measured.
    pub intervals: usize,
    /// Median absolute deviation of the intervals over their median: near 0 when the window
    /// is locked to a regular refresh, large when presents follow render times instead.
    pub spread: f64,
}

/// Fewest intervals [`estimate_refresh`] accepts.
pub const MIN_REFRESH_INTERVALS: usize = 20;
/// Refresh rates displays run at (Hz): film, PAL and NTSC rates, office and gaming monitors,
/// 3D displays and VR headsets. A measurement is a display refresh only near one of them.
pub const COMMON_REFRESH_HZ: [f64; 18] = [
    24.0, 25.0, 30.0, 48.0, 50.0, 60.0, 72.0, 75.0, 85.0, 90.0, 100.0, 120.0, 144.0, 165.0, 180.0, 200.0, 240.0, 360.0,
];
/// How far (relative) a measured rate may be from a [`COMMON_REFRESH_HZ`] rate: 59.94 Hz
/// (NTSC-derived) and 143.9 Hz panels pass, a free-running window at 86-131 Hz does not.
pub const REFRESH_RATE_TOLERANCE: f64 = 0.015;
/// Largest [`RefreshEstimate::spread`] of a window locked to the display's refresh: the
/// intervals of a synchronised window differ by far less than 2 % (scheduling jitter moves
/// the times a present is recorded, not the refresh), an unsynchronised one's by 5 % and more.
pub const MAX_REFRESH_SPREAD: f64 = 0.02;

/// Estimates the refresh interval from present times (seconds, increasing) as the median of
/// the frame-to-frame intervals, so a few stalls (a missed refresh doubles an interval) or
/// doubled presents do not move it. `None` with fewer than [`MIN_REFRESH_INTERVALS`] positive
/// intervals.
pub fn estimate_refresh(times_s: &[f64]) -> Option<RefreshEstimate> {
    let d: Vec<f64> =
        times_s.windows(2).map(|w| (w[1] - w[0]) * 1000.0).filter(|x| x.is_finite() && *x > 0.0).collect();
    if d.len() < MIN_REFRESH_INTERVALS {
        return None;
    }
    let m = median(&d);
    let dev: Vec<f64> = d.iter().map(|x| (x - m).abs()).collect();
    let mad = median(&dev);
    Some(RefreshEstimate { interval_ms: m, intervals: d.len(), spread: mad / m })
}

impl RefreshEstimate {
    /// The refresh rate, Hz.
    pub fn hz(&self) -> f64 {
        1000.0 / self.interval_ms
    }

    /// Whether it looks like a display refresh: regular (spread at most
    /// [`MAX_REFRESH_SPREAD`]) and within [`REFRESH_RATE_TOLERANCE`] of a common rate.
    pub fn is_display_refresh(&self) -> bool {
        let hz = self.hz();
        self.spread <= MAX_REFRESH_SPREAD
            && COMMON_REFRESH_HZ.iter().any(|r| (hz - r).abs() <= REFRESH_RATE_TOLERANCE * r)
    }
}

/// Mean, standard deviation and maximum of the intervals between successive times (ms).
pub fn interval_stats(times_ms: &[f64]) -> (f64, f64, f64) {
    let d: Vec<f64> = times_ms.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let s = study::stats::Summary::of(&d);
    (s.mean, s.population_sd(), s.max.max(0.0))
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

    #[test]
    fn next_change_is_the_next_due_frame_or_the_gap_end() {
        let mut p = Playback::new(Task::TwoAfc, vec![(2, 30.0), (2, 30.0)], 1, 100, 60.0, 1.0);
        assert_eq!(p.update(1.0), Screen::Frame { slot: 0, frame: 0 });
        assert!((p.next_change().unwrap() - (1.0 + 1.0 / 30.0)).abs() < 1e-12);
        assert_eq!(p.update(1.04), Screen::Frame { slot: 0, frame: 1 });
        // After the last frame of slot 0, the next change is the start of the gap.
        assert!((p.next_change().unwrap() - (1.0 + 2.0 / 30.0)).abs() < 1e-12);
        assert_eq!(p.update(1.07), Screen::Gap);
        assert!((p.next_change().unwrap() - (1.0 + 2.0 / 30.0 + 0.1)).abs() < 1e-12);
        assert_eq!(p.update(1.18), Screen::Frame { slot: 1, frame: 0 });
        p.update(2.0);
        assert_eq!(p.next_change(), None);
    }

    #[test]
    fn refresh_estimate_is_the_median_interval_and_ignores_outliers() {
        // 60 Hz with jitter of +-0.3 ms, three missed refreshes (33 ms) and a 250 ms stall.
        let mut t = vec![0.0];
        for i in 1..=120 {
            let jitter = 0.0003 * f64::from(i % 3) - 0.0003;
            let gap = match i {
                17 | 40 | 90 => 2.0 / 60.0,
                60 => 0.25,
                _ => 1.0 / 60.0,
            };
            let last = t.last().copied().unwrap();
            t.push(last + gap + jitter * 0.5);
        }
        let e = estimate_refresh(&t).unwrap();
        assert_eq!(e.intervals, 120);
        assert!((e.hz() - 60.0).abs() < 0.3, "{e:?}");
        assert!(e.spread < 0.02 && e.is_display_refresh(), "{e:?}");
        // 144 Hz.
        let t: Vec<f64> = (0..50).map(|i| f64::from(i) / 144.0).collect();
        assert!((estimate_refresh(&t).unwrap().hz() - 144.0).abs() < 1e-6);
        // Too few intervals, and repeated or out-of-order times, give no estimate.
        assert_eq!(estimate_refresh(&t[..MIN_REFRESH_INTERVALS]), None);
        assert_eq!(estimate_refresh(&[1.0; 40]), None);
        // A window redrawing whenever rendering ends (8 Hz, irregular) is not a display refresh.
        let slow: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.125 + 0.04 * f64::from(i % 4)).collect();
        let e = estimate_refresh(&slow).unwrap();
        assert!(!e.is_display_refresh(), "{e:?}");
        let regular_slow: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.125).collect();
        assert!(!estimate_refresh(&regular_slow).unwrap().is_display_refresh());
    }

    #[test]
    fn an_unsynchronised_window_is_not_taken_for_a_display_refresh() {
        let of = |interval_ms: f64, spread: f64| RefreshEstimate { interval_ms, intervals: 60, spread };
        // Regular, but at rates no display runs at (Xvfb measured 86-131 Hz; 86 Hz would pass
        // as an 85 Hz monitor, and is caught by its spread).
        for hz in [95.0, 110.0, 131.0, 40.0] {
            assert!(!of(1000.0 / hz, 0.0).is_display_refresh(), "{hz}");
        }
        // A common rate with the 5.4 % spread of a free-running window.
        assert!(!of(1000.0 / 60.0, 0.054).is_display_refresh());
        // Synchronised displays, NTSC-derived rates included.
        for hz in [59.94, 60.0, 75.0, 119.88, 143.86, 144.0, 240.0] {
            assert!(of(1000.0 / hz, 0.005).is_display_refresh(), "{hz}");
        }
    }
}
