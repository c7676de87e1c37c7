//! Rendering whole stimulus sets: one folder of frames per sequence, its `manifest.json`,
//! the set's `index.json`, resume, and progress display.
//!
//! Crash safety: every file is written atomically; a sequence's frames come first and its
//! manifest last, so a manifest exists only for a sequence whose frames are all on disk.
//! Before a sequence is re-rendered it loses its manifest, so a kill at any moment leaves no
//! incomplete sequence marked complete. `--resume` trusts a sequence only when its manifest
//! matches the request and every frame's hash verifies.
//!
//! Several writers: the manifests are the truth and `index.json` is rebuilt from them (those
//! of this design, preset and sampling mode whose files verify) after each sequence, and
//! rewritten until a fresh rebuild equals the file on disk, so renders into one folder from
//! several processes or machines all keep every completed sequence without relying on
//! locks. A process takes `render.lock` in a sequence's folder (`study::lock`) while it
//! renders it, and leaves a sequence locked by another live process to that process. A
//! folder holding sequences of another version of the design (its `design_sha256`), another
//! preset or sampling mode is refused, naming the design keys that differ from the folder's
//! `design.toml` copy.

pub(crate) mod medium;
mod progress;
mod render;
mod store;
mod verify;

pub(crate) use progress::Progress;
pub use progress::process_cpu_seconds;
pub use render::{render_set, render_set_with};
pub(crate) use render::{render_stream, streams};
pub use store::{DESIGN_COPY, EYES_DIR, SEQUENCE_LOCK, eye_folder, eye_name};
pub(crate) use store::{SetFolder, frame_index_of, io_err, manifest_bytes, remove_temporaries_of};
pub(crate) use verify::Expected;
pub use verify::verify_sequence;
#[cfg(test)]
mod tests;

use std::io;
use std::path::{Path, PathBuf};

use study::StimulusId;
use study::design::{Design, DesignError, Preset};
use study::fsio::write_atomic;
use study::manifest::{FrameRecord, Sampling};

use ::render::env::EnvError;
use ::render::io::IoError;
use ::render::method::RenderError;
use ::render::renderer::{DeviceChoice, DeviceError};

/// Why a set could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum SetError {
    /// The design does not fit the request.
    #[error(transparent)]
    Design(#[from] DesignError),
    /// The environment map could not be built.
    #[error(transparent)]
    Environment(#[from] EnvError),
    /// A file or folder could not be written, read or removed.
    #[error("{}: {action}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// Cause (its kind tells a full disk or a permission problem).
        source: io::Error,
    },
    /// An image could not be encoded.
    #[error("{}: cannot encode", path.display())]
    Encode {
        /// The file being produced.
        path: PathBuf,
        /// Cause.
        source: IoError,
    },
    /// The method cannot render here, or the GPU failed.
    #[error(transparent)]
    Method(#[from] RenderError),
    /// The requested device cannot be opened.
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// The design has a participating medium and the device's tracer does not render one.
    #[error(
        "the design has a participating medium (its [medium] table), which the tracer and the accumulation buffer render only with the f64 reference tracer: --device {device} cannot; use --device cpu-reference (auto picks it), or the marcher method, which renders on any device"
    )]
    MediumDevice {
        /// The device asked for.
        device: String,
    },
    /// The design's medium's grids could not be made.
    #[error(transparent)]
    Medium(#[from] ::render::volume::VolumeError),
    /// The output folder holds a set that this request must not mix with.
    #[error("{}: {message}", path.display())]
    Mismatch {
        /// The conflicting file.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// Shards that do not add up to their set: every unit missing, damaged, duplicated or
    /// not in the plan, one per line.
    #[error("{summary}{}", lines.iter().map(|l| format!("\n  {l}")).collect::<String>())]
    Incomplete {
        /// What was checked.
        summary: String,
        /// One line per problem.
        lines: Vec<String>,
    },
}

impl SetError {
    /// Whether the error comes from the user's input (design, environment map, output
    /// folder holding another set) rather than from writing.
    pub fn is_bad_input(&self) -> bool {
        if let SetError::Method(e) = self {
            return e.is_bad_input();
        }
        matches!(
            self,
            SetError::Design(_)
                | SetError::Environment(_)
                | SetError::Device(DeviceError::NoGpu(_))
                | SetError::Mismatch { .. }
                | SetError::Incomplete { .. }
                | SetError::MediumDevice { .. }
                | SetError::Medium(_)
        )
    }
}

/// Where files go. The default writes atomically; tests substitute failing writers.
pub trait FileWriter: Sync {
    /// Writes `bytes` to `path`, replacing it atomically.
    fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()>;
}

/// Writes with [`study::fsio::write_atomic`].
pub struct AtomicWriter;

impl FileWriter for AtomicWriter {
    fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()> {
        write_atomic(path, bytes)
    }
}

/// How progress is shown on stderr.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars (overall with ETA, and the current sequence) on a terminal, lines otherwise.
    Auto,
    /// One line per finished sequence.
    Lines,
    /// Nothing.
    Quiet,
}

/// What to render and where.
pub struct SetRequest<'a> {
    /// The design.
    pub design: &'a Design,
    /// The resolved preset.
    pub preset: Preset,
    /// Sequences to render, in order.
    pub ids: Vec<StimulusId>,
    /// The set's folder.
    pub out: PathBuf,
    /// Skip sequences that verify.
    pub resume: bool,
    /// Also write linear EXR frames.
    pub exr: bool,
    /// Progress display.
    pub progress: ProgressMode,
    /// Where to render (`--device`).
    pub device: DeviceChoice,
    /// Independent sample levels (the study's way) or nested ones (`--nested`).
    pub sampling: Sampling,
}

impl SetRequest<'_> {
    /// The method and settings that render `id` ([`Design::method_of`]).
    pub fn method_of(&self, id: &StimulusId) -> Result<study::method::MethodSpec, SetError> {
        Ok(self.design.method_of(id)?)
    }
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SetReport {
    /// Sequences rendered by this run.
    pub rendered: Vec<StimulusId>,
    /// Sequences skipped because they verified (`--resume`).
    pub skipped: Vec<StimulusId>,
    /// Non-finite samples discarded in this run.
    pub nonfinite_samples: u64,
    /// Wall seconds of this run.
    pub wall_seconds: f64,
    /// The device that rendered, as manifests name it.
    pub device: String,
    /// Sequences another live process was rendering, left to it, and that process.
    pub left_to_others: Vec<(StimulusId, String)>,
}

/// The file name of frame `index`.
pub fn frame_name(index: u32, extension: &str) -> String {
    format!("frame-{index:04}.{extension}")
}

/// A frame of one member of a stream, encoded and written.
type Written = Result<(usize, FrameRecord), SetError>;
