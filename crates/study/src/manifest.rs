//! Manifests of a rendered stimulus set: one `manifest.json` per sequence folder and an
//! `index.json` at the set's root. The runner resolves stimuli through them, the analysis
//! reads render cost from them, and `--resume` trusts a sequence only when its manifest and
//! every frame hash verify. Format described in docs/formats.md.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::ids::{StimulusId, View};
use crate::method::Method;

/// Format tag of a sequence manifest.
pub const SEQUENCE_FORMAT: &str = "blurlab-sequence/1";
/// Format tag of a set index.
pub const INDEX_FORMAT: &str = "blurlab-set/1";

/// One factor level of a sequence, with its label, name and physical value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelInfo {
    /// Label as in the id, e.g. `T3`.
    pub label: String,
    /// Human name from the design file, e.g. `checker` or `50 %`.
    pub name: String,
    /// Physical value: material index, degrees per second, shutter fraction, samples per pixel.
    pub value: f64,
}

/// The factor levels of a sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Factors {
    /// Material level.
    pub material: LevelInfo,
    /// Speed level (value in degrees of visual angle per second).
    pub speed: LevelInfo,
    /// Shutter level (value: fraction of the frame time).
    pub shutter: LevelInfo,
    /// Sampling level (value: samples per pixel actually rendered).
    pub samples: LevelInfo,
    /// Rendering-method level, in designs with a method factor (label: its tag; value: the
    /// tag's code, `StimulusId::level`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<LevelInfo>,
}

/// One rendered frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// Frame index from 0.
    pub index: u32,
    /// PNG file (sRGB, 8-bit), relative to the sequence folder.
    pub png: String,
    /// SHA-256 of the PNG file.
    pub png_sha256: String,
    /// Linear EXR file relative to the sequence folder, when rendered with `--exr`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exr: Option<String>,
    /// SHA-256 of the EXR file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exr_sha256: Option<String>,
    /// Wall-clock seconds spent rendering this frame.
    pub wall_seconds: f64,
    /// CPU seconds (all threads) spent rendering this frame.
    pub cpu_seconds: f64,
    /// Radiance samples that were NaN or infinite and were discarded.
    pub nonfinite_samples: u64,
    /// Per-eye sample seeds, left to right (with nested sampling: the seeds of the stream
    /// the frame is a prefix of).
    pub seeds: Vec<u64>,
    /// GPU seconds of this frame's dispatches (timestamp queries), on a GPU that has them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_seconds: Option<f64>,
}

/// How the sample levels of a set were rendered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// Each sequence rendered on its own, with its own seeds (the study's way, as in the
    /// thesis).
    #[default]
    Independent,
    /// The sample levels of one material, speed, shutter and view are prefixes of one
    /// sample stream, seeded as the design's highest level, rendered once (`--nested`).
    Nested,
}

/// The GPU adapter that rendered a sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpuRecord {
    /// Adapter name.
    pub adapter: String,
    /// Backend (Vulkan, Metal, Dx12, Gl).
    pub backend: String,
    /// Driver name.
    pub driver: String,
    /// Driver version or description.
    pub driver_info: String,
    /// Whether it is a software (CPU) implementation such as lavapipe.
    pub software: bool,
}

/// The manifest of one sequence folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceManifest {
    /// Always [`SEQUENCE_FORMAT`].
    pub format: String,
    /// The stimulus.
    pub id: StimulusId,
    /// Mono or stereo (also in the id).
    pub view: View,
    /// Factor levels.
    pub factors: Factors,
    /// Rendering method (`tracer`, `accum`, `mcguire`, `guertin`, `analytic`).
    pub method: Method,
    /// Preset name (`full`, `quick`).
    pub preset: String,
    /// Composed frame width in pixels (stereo: both eyes).
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Playback rate.
    pub fps: f64,
    /// Samples per pixel rendered.
    pub samples_per_pixel: u32,
    /// The design's master seed.
    pub master_seed: u64,
    /// Where it was rendered, e.g. `cpu: 2 threads` or `gpu: NAME (BACKEND)`.
    pub device: String,
    /// The GPU adapter, for sequences rendered on one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu: Option<GpuRecord>,
    /// Independent or nested sample levels (absent in older manifests: independent).
    #[serde(default)]
    pub sampling: Sampling,
    /// blurlab version that rendered it.
    pub software_version: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// The frames in order.
    pub frames: Vec<FrameRecord>,
}

impl SequenceManifest {
    /// Total wall seconds over all frames: the sequence's measured render cost.
    pub fn wall_seconds(&self) -> f64 {
        self.frames.iter().map(|f| f.wall_seconds).sum()
    }

    /// Total CPU seconds over all frames.
    pub fn cpu_seconds(&self) -> f64 {
        self.frames.iter().map(|f| f.cpu_seconds).sum()
    }

    /// Total discarded non-finite samples.
    pub fn nonfinite_samples(&self) -> u64 {
        self.frames.iter().map(|f| f.nonfinite_samples).sum()
    }
}

/// An entry of the set index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexEntry {
    /// The stimulus.
    pub id: StimulusId,
    /// Sequence folder relative to the set root.
    pub folder: String,
    /// SHA-256 of the sequence's manifest.json.
    pub manifest_sha256: String,
}

/// `index.json` at the root of a rendered set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetIndex {
    /// Always [`INDEX_FORMAT`].
    pub format: String,
    /// Design name (e.g. `navarro2011`).
    pub design: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// Preset the set was rendered with.
    pub preset: String,
    /// Independent or nested sample levels (absent in older indexes: independent).
    #[serde(default)]
    pub sampling: Sampling,
    /// The complete sequences, sorted by id.
    pub sequences: Vec<IndexEntry>,
}

impl SetIndex {
    /// The SHA-256 of `id`'s manifest as the index records it, or `None` where the set lacks it.
    pub fn manifest_sha256(&self, id: StimulusId) -> Option<&str> {
        self.sequences.iter().find(|e| e.id == id).map(|e| e.manifest_sha256.as_str())
    }

    /// The set's content hash: SHA-256 of the lines `ID MANIFEST_SHA256\n` of its entries in
    /// id order. Once each entry's manifest is checked against its hash (and each manifest's
    /// frames against theirs), it identifies every byte of the set, whatever the index's
    /// layout; `stimulus_set_sha256` in response logs.
    pub fn content_sha256(&self) -> String {
        let mut entries: Vec<&IndexEntry> = self.sequences.iter().collect();
        entries.sort_by_key(|e| e.id);
        let text: String = entries.iter().map(|e| format!("{} {}\n", e.id, e.manifest_sha256)).collect();
        crate::fsio::sha256_hex(text.as_bytes())
    }
}

/// Why a manifest could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The file is not valid JSON of the expected shape.
    #[error("{path}: line {line}, column {column}: {message}")]
    Parse {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was wrong.
        message: String,
    },
    /// The format tag is not the one this version reads.
    #[error("{path}: field `format` is `{found}`, expected `{expected}`")]
    Format {
        /// File.
        path: PathBuf,
        /// Tag found.
        found: String,
        /// Tag expected.
        expected: &'static str,
    },
}

fn parse_json<T: serde::de::DeserializeOwned>(path: &Path, text: &str) -> Result<T, ManifestError> {
    serde_json::from_str(text).map_err(|e| ManifestError::Parse {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })
}

/// A JSON file tagged with a `format` field this version reads.
trait Tagged: serde::de::DeserializeOwned {
    /// The tag expected.
    const FORMAT: &'static str;
    /// The tag found.
    fn format(&self) -> &str;

    /// Parses text read from `path` and checks its tag.
    fn parse_checked(path: &Path, text: &str) -> Result<Self, ManifestError> {
        let m: Self = parse_json(path, text)?;
        if m.format() != Self::FORMAT {
            return Err(ManifestError::Format {
                path: path.to_owned(),
                found: m.format().to_owned(),
                expected: Self::FORMAT,
            });
        }
        Ok(m)
    }

    /// Reads `path` and checks its tag.
    fn read_checked(path: &Path) -> Result<Self, ManifestError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ManifestError::Io { path: path.to_owned(), source })?;
        Self::parse_checked(path, &text)
    }
}

impl Tagged for SequenceManifest {
    const FORMAT: &'static str = SEQUENCE_FORMAT;
    fn format(&self) -> &str {
        &self.format
    }
}

impl Tagged for SetIndex {
    const FORMAT: &'static str = INDEX_FORMAT;
    fn format(&self) -> &str {
        &self.format
    }
}

impl SequenceManifest {
    /// Reads and checks a sequence manifest.
    pub fn read(path: &Path) -> Result<Self, ManifestError> {
        Self::read_checked(path)
    }

    /// Parses and checks manifest text read from `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ManifestError> {
        Self::parse_checked(path, text)
    }
}

impl SetIndex {
    /// Reads and checks a set index.
    pub fn read(path: &Path) -> Result<Self, ManifestError> {
        Self::read_checked(path)
    }

    /// Parses and checks index text read from `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ManifestError> {
        Self::parse_checked(path, text)
    }
}
