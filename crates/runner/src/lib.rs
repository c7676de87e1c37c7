//! The experiment runner: schedules, presentation, stereo display modes, calibration,
//! durable response logs and simulated observers.
//!
//! Everything a session decides (the trial order, what is logged, when a break is due, which
//! frame is due on screen, how a stereo frame becomes display pixels, how large a stimulus
//! is drawn) lives in plain Rust modules with unit tests; [`app`] is a thin egui/eframe layer
//! over them. The runner reads a rendered stimulus set through `study::manifest` and never
//! links the renderer.
//!
//! - [`schedule`]: the trial list of a session, derived from the definition and a seed;
//!   with `selection = "asap"` or `"random"`, each counted trial chosen when it is due.
//! - [`shared_posterior`]: the ASAP posterior every session of an experiment shares.
//! - [`stimuli`]: the rendered set, checks that every stimulus exists, frame decoding.
//! - [`session`]: opening, resuming and appending to a participant's session log.
//! - [`playback`]: the steps of a trial and frame pacing locked to the display refresh.
//! - [`display`]: stereo display-mode pixel transforms (anaglyph, row interleave, ...).
//! - [`gpu`]: frames onto the GPU as textures; the anaglyph composed there by a kernel.
//! - [`calibration`]: scaling a stimulus to the visual angle the definition asks for.
//! - [`simulate`]: simulated observers running whole sessions headlessly.
//! - [`summary`]: the experimenter's summary of what a window recorded.
//! - [`flip_observer`]: the image-computable observer's FLIP distances between sequences.
//! - [`views`]: where each eye's picture of the participant's view lies in the window.
//! - [`app`]: the participant's window.
//! - [`bench`]: measurements for `blurlab bench playback`.

pub mod app;
pub mod bench;
pub mod calibration;
pub mod display;
pub mod flip_observer;
pub mod gpu;
pub mod playback;
pub mod schedule;
pub mod session;
pub mod shared_posterior;
pub mod simulate;
pub mod stimuli;
pub mod summary;
pub mod views;

use std::path::PathBuf;

use study::StimulusId;

/// Everything that can stop a session from starting or continuing.
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
    /// The experiment definition is unreadable or invalid.
    #[error(transparent)]
    Experiment(#[from] study::experiment::ExperimentError),
    /// A manifest of the stimulus set is unreadable or invalid.
    #[error(transparent)]
    Manifest(#[from] study::manifest::ManifestError),
    /// The response log could not be read or written.
    #[error(transparent)]
    Response(#[from] study::response::ResponseError),
    /// The set lacks stimuli the experiment shows.
    #[error("{set}: the stimulus set lacks {} stimuli that {experiment} shows: {}", missing.len(), join_ids(missing))]
    MissingStimuli {
        /// The set's index.json.
        set: PathBuf,
        /// The definition.
        experiment: PathBuf,
        /// The missing stimuli.
        missing: Vec<StimulusId>,
    },
    /// A sequence of the set is inconsistent with itself or the experiment.
    #[error("{path}: {message}")]
    Sequence {
        /// The manifest or frame.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An existing session cannot be resumed.
    #[error("{path}: cannot resume: {message}")]
    Resume {
        /// The session log.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// Another process is running a session of this participant.
    #[error(
        "{}: participant {participant} already has a session running in another process ({holder}); wait for it to end, or, if that process is gone, remove this file",
        path.display()
    )]
    Locked {
        /// The lock file.
        path: PathBuf,
        /// The participant code.
        participant: String,
        /// Who holds it (boxed: it is the largest variant).
        holder: Box<study::lock::Holder>,
    },
    /// The participant's last session is complete and starting another one was not
    /// confirmed ([`session::SessionOptions::allow_new_session`]).
    #[error("{}", sessions_complete_message(participant, sessions, dir))]
    SessionsComplete {
        /// The participant code.
        participant: String,
        /// The session numbers on record, ascending (the last one complete).
        sessions: Vec<u32>,
        /// The participant's folder.
        dir: PathBuf,
    },
    /// The experiment's shared selection posterior is unusable (another experiment's, damaged,
    /// or its lock is held too long).
    #[error("{}: key `{key}`: {message}", path.display())]
    Selection {
        /// The posterior file (or its lock).
        path: PathBuf,
        /// The key at fault.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// A command-line or start-screen value is unusable (participant code, model, display).
    #[error("{what}: {message}")]
    Input {
        /// Which value.
        what: String,
        /// Why.
        message: String,
    },
    /// The GPU failed (no adapter, device lost, read-back).
    #[error(transparent)]
    Gpu(#[from] ::gpu::GpuError),
    /// A file or folder could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl RunnerError {
    /// Whether the error is caused by bad input (definitions, sets, codes, logs) rather than
    /// by the machine (I/O). The CLI maps it to exit code 2.
    pub fn is_bad_input(&self) -> bool {
        match self {
            RunnerError::Io { .. } | RunnerError::Gpu(_) => false,
            RunnerError::Response(study::response::ResponseError::Io { .. }) => false,
            RunnerError::Experiment(study::experiment::ExperimentError::Io { .. }) => true,
            _ => true,
        }
    }
}

fn sessions_complete_message(participant: &str, sessions: &[u32], dir: &std::path::Path) -> String {
    let files: Vec<String> = sessions.iter().map(|n| format!("session-{n}.csv")).collect();
    let last = sessions.last().copied().unwrap_or(0);
    format!(
        "{}: participant {participant} has completed session {last} (on record: {}); starting a new session (session {}) must be confirmed by the experimenter first",
        dir.display(),
        files.join(", "),
        last + 1
    )
}

fn join_ids(ids: &[StimulusId]) -> String {
    ids.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
}

/// A uniform number in [0, 1) from a generator (53 random bits).
pub(crate) fn unit_f64(rng: &mut impl rand::Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform index in `0..n` (Lemire's multiply-shift; bias below 2^-50 for study sizes).
pub(crate) fn index_below(rng: &mut impl rand::Rng, n: usize) -> usize {
    ((u128::from(rng.next_u64()) * n as u128) >> 64) as usize
}

/// A standard normal number (Box-Muller).
pub(crate) fn normal(rng: &mut impl rand::Rng) -> f64 {
    let u1 = 1.0 - unit_f64(rng);
    let u2 = unit_f64(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Fisher-Yates shuffle with [`index_below`].
pub(crate) fn shuffle<T>(items: &mut [T], rng: &mut impl rand::Rng) {
    for i in (1..items.len()).rev() {
        let j = index_below(rng, i + 1);
        items.swap(i, j);
    }
}
