//! Stimulus design files (`stimuli/*.toml`): the factors and their levels, the scene, the
//! viewing geometry that turns degrees of visual angle into metres per second, the stereo
//! rig, lighting, exposure, presets; and from them the [`FrameScene`](crate::scene::FrameScene)
//! of any frame of any stimulus.
//!
//! Every fact of the study lives in the design file; this module only applies geometry.
//! Errors name the file, the line and the key (`deny_unknown_fields` everywhere, spans from
//! the TOML parser, and a key search for errors found after parsing, both through
//! [`crate::toml_locate`]).
//!
//! One job per file: this one loads a design and answers questions about its ids, presets
//! and factor levels; [`spec`] holds the serde types of the file as written (re-exported
//! here), `validate` checks them and `scene` builds cameras, motion, shutters and frame
//! scenes.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::fsio::sha256_hex;
use crate::ids::{Factor, MethodTag, StimulusId, View};
use crate::manifest::{Factors, LevelInfo};
use crate::method::MethodSpec;
use crate::scene::{Environment, Lighting};
use crate::toml_locate::{TomlError, key_line};

mod medium;
mod scene;
pub mod spec;
mod validate;

pub use medium::{
    MAX_EXTINCTION, MAX_SCATTERINGS, MAX_SIMULATION_CELLS, MAX_SIMULATION_SIDE, MAX_STEPS_PER_FRAME, MAX_WARMUP_FRAMES,
};
pub use validate::{
    MAX_BOUNCES, MAX_FRAME_SAMPLES, MAX_FRAME_TRIANGLE_PIXELS, MAX_FRAMES, MAX_OCTAVES, MAX_PIXELS, MAX_SAMPLES,
    MAX_SIDE,
};

pub use spec::*;

/// Why a design file could not be used. Every variant names the file; parse and validation
/// errors also name the line and the key.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// The file could not be read.
    #[error("{}: cannot read design file: {source}", path.display())]
    Io {
        /// The design file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The file is not TOML of the expected shape (syntax, unknown key, wrong type, missing key).
    #[error("{}:{line}:{column}: {}{message}", path.display(), key_prefix(key))]
    Parse {
        /// The design file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// Dotted key the error is about, when known.
        key: Option<String>,
        /// What was wrong.
        message: String,
    },
    /// A value parsed but makes no sense (e.g. a negative speed, a missing environment map).
    #[error("{}:{}: {}{message}", path.display(), line.map_or("?".to_owned(), |l| l.to_string()), key_prefix(&Some(key.clone())))]
    Invalid {
        /// The design file.
        path: PathBuf,
        /// 1-based line of the key, when it could be located.
        line: Option<usize>,
        /// Dotted key, e.g. `factors.speed[2].degrees_per_second`.
        key: String,
        /// What was wrong.
        message: String,
    },
    /// A request does not fit the design (unknown preset, level or frame out of range).
    #[error("{}: {message}", path.display())]
    Request {
        /// The design file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
}

fn key_prefix(key: &Option<String>) -> String {
    key.as_ref().map_or(String::new(), |k| format!("key `{k}`: "))
}

// ---------------------------------------------------------------------------------------
// The design as used.

/// A resolved rendering preset: image size, frames and sampling.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Preset {
    /// Name (`full`, `quick`, ...).
    pub name: String,
    /// Width of one eye's image.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Frames rendered.
    pub frames: u32,
    /// Timeline index of the first rendered frame.
    pub first_frame: u32,
    /// Samples per pixel of each A level (index 0 is A1).
    pub samples_per_pixel: Vec<u32>,
}

impl Preset {
    /// Samples per pixel of `id`'s A level (`None` for a level the preset does not have).
    pub fn samples_of(&self, id: &StimulusId) -> Option<u32> {
        self.samples_per_pixel.get(usize::from(id.samples).wrapping_sub(1)).copied()
    }
}

/// Which views to list or render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Views {
    /// Monoscopic only.
    Mono,
    /// Stereo only.
    Stereo,
    /// Both, monoscopic first.
    Both,
}

impl Views {
    /// The views in order.
    pub fn list(self) -> &'static [View] {
        match self {
            Views::Mono => &[View::Mono],
            Views::Stereo => &[View::Stereo],
            Views::Both => &[View::Mono, View::Stereo],
        }
    }
}

/// A loaded, validated design file.
#[derive(Clone, Debug)]
pub struct Design {
    /// The file it was loaded from.
    pub path: PathBuf,
    /// SHA-256 of the file's bytes.
    pub sha256: String,
    /// The parsed content.
    pub spec: DesignSpec,
    /// The lighting with file paths resolved against the design's folder.
    pub lighting: Lighting,
    /// The `[medium]` resolved, over the whole sequence (`None` without one).
    pub medium: Option<crate::medium::SceneMedium>,
    /// The typed method of each method table: `[method]`, or each `[[factors.method]]`
    /// level in file order.
    methods: Vec<MethodSpec>,
    /// The antialiasing of each method table's display frames, in the same order.
    antialias: Vec<Option<crate::scene::Antialias>>,
    text: String,
}

impl Design {
    /// The design file's text as read.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Reads, parses and validates a design file.
    pub fn load(path: &Path) -> Result<Design, DesignError> {
        let bytes = std::fs::read(path).map_err(|source| DesignError::Io { path: path.to_owned(), source })?;
        let text = String::from_utf8(bytes.clone()).map_err(|e| DesignError::Io {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8: {e}")),
        })?;
        Self::parse(path, &text, &sha256_hex(&bytes))
    }

    /// Parses and validates design text as if read from `path` (relative environment paths
    /// resolve against `path`'s folder).
    pub fn parse(path: &Path, text: &str, sha256: &str) -> Result<Design, DesignError> {
        let spec: DesignSpec = toml::from_str(text).map_err(|e| {
            // Turns a TOML error into one naming the file, line, column and key.
            let at = TomlError::new(text, &e);
            DesignError::Parse {
                path: path.to_owned(),
                line: at.line,
                column: at.column,
                key: at.key,
                message: at.message.trim().to_owned(),
            }
        })?;
        let mut design = Design {
            path: path.to_owned(),
            sha256: sha256.to_owned(),
            lighting: Lighting {
                environment: Environment::Uniform { radiance: [0.0; 3] },
                intensity: 0.0,
                rotation_y: 0.0,
            },
            medium: None,
            spec,
            methods: Vec::new(),
            antialias: Vec::new(),
            text: text.to_owned(),
        };
        design.validate()?;
        design.methods = design.typed_methods()?;
        design.antialias = design.typed_antialias()?;
        design.lighting = design.resolve_lighting()?;
        design.medium = design.resolve_medium()?;
        Ok(design)
    }

    /// The rendering method the design names for its set (the tracer unless `[method]` says
    /// otherwise); in a design with a method factor, each id's own ([`Design::method_of`]).
    pub fn method(&self) -> crate::Method {
        self.spec.method.kind
    }

    /// The design's `[method]` with its settings (the tracer's defaults when absent; in a
    /// design with a method factor, each id's own is [`Design::method_of`]).
    pub fn method_spec(&self) -> MethodSpec {
        if self.has_method_factor() { MethodSpec::of(self.method()) } else { self.methods[0].clone() }
    }

    /// Whether the design has a rendering-method factor (`[[factors.method]]`).
    pub fn has_method_factor(&self) -> bool {
        !self.spec.factors.method.is_empty()
    }

    /// The method levels' tags in file order (`tracer`, `guertin`, `guertin2`, ...).
    pub fn method_tags(&self) -> Vec<MethodTag> {
        let levels = &self.spec.factors.method;
        (0..levels.len())
            .map(|i| {
                let kind = levels[i].kind;
                let variant = levels[..=i].iter().filter(|m| m.kind == kind).count() as u8;
                MethodTag { kind, variant }
            })
            .collect()
    }

    /// The method and settings that render `id` when a command line asks for `method`: the
    /// design's own ([`Design::method_of`]) where it names none or the design's `[method]`,
    /// else that method at its defaults.
    pub fn method_with(&self, id: &StimulusId, method: Option<crate::Method>) -> Result<MethodSpec, DesignError> {
        match method {
            Some(m) if m == self.method() && !self.has_method_factor() => Ok(self.method_spec()),
            Some(m) => Ok(MethodSpec::of(m)),
            None => self.method_of(id),
        }
    }

    /// The method and settings that render `id`: its method level's, or the design's `[method]`.
    pub fn method_of(&self, id: &StimulusId) -> Result<MethodSpec, DesignError> {
        self.check_id(id)?;
        Ok(self.methods[self.method_level(id)].clone())
    }

    /// The antialiasing of `id`'s display frames: its method level's, or the design's
    /// `[method]`'s.
    pub fn antialias_of(&self, id: &StimulusId) -> Result<Option<crate::scene::Antialias>, DesignError> {
        self.check_id(id)?;
        Ok(self.antialias.get(self.method_level(id)).copied().flatten())
    }

    fn method_level(&self, id: &StimulusId) -> usize {
        match id.method {
            Some(tag) => self.method_tags().iter().position(|t| *t == tag).unwrap_or(0),
            None => 0,
        }
    }

    /// The design's name.
    pub fn name(&self) -> &str {
        &self.spec.name
    }

    fn invalid(&self, table: &str, index: Option<usize>, key: &str, message: impl Into<String>) -> DesignError {
        let dotted = match index {
            Some(i) => format!("{table}[{}].{key}", i + 1),
            None if table.is_empty() => key.to_owned(),
            None => format!("{table}.{key}"),
        };
        DesignError::Invalid {
            path: self.path.clone(),
            line: key_line(&self.text, table, index, key),
            key: dotted,
            message: message.into(),
        }
    }

    fn request(&self, message: impl Into<String>) -> DesignError {
        DesignError::Request { path: self.path.clone(), message: message.into() }
    }

    /// The names of the presets: `full` and those the file defines.
    pub fn preset_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.spec.presets.keys().cloned().collect();
        if !names.iter().any(|n| n == "full") {
            names.insert(0, "full".to_owned());
        }
        names
    }

    /// The resolved preset `name`; `full` is the design as written unless the file overrides it.
    pub fn preset(&self, name: &str) -> Result<Preset, DesignError> {
        let empty = PresetSpec::default();
        let spec = match self.spec.presets.get(name) {
            Some(spec) => spec,
            None if name == "full" => &empty,
            None => {
                return Err(self.request(format!(
                    "the design has no preset `{name}` (available: {})",
                    self.preset_names().join(", ")
                )));
            }
        };
        let s = &self.spec;
        Ok(Preset {
            name: name.to_owned(),
            width: spec.width.unwrap_or(s.sequence.width),
            height: spec.height.unwrap_or(s.sequence.height),
            frames: spec.frames.unwrap_or(s.sequence.frames),
            first_frame: spec.first_frame.unwrap_or(0),
            samples_per_pixel: spec
                .samples_per_pixel
                .clone()
                .unwrap_or_else(|| s.factors.samples.iter().map(|a| a.samples_per_pixel).collect()),
        })
    }

    /// Number of levels of `factor`.
    pub fn level_count(&self, factor: Factor) -> u8 {
        let f = &self.spec.factors;
        let n = match factor {
            Factor::Material => f.material.len(),
            Factor::Speed => f.speed.len(),
            Factor::Shutter => f.shutter.len(),
            Factor::Samples => f.samples.len(),
            Factor::Method => f.method.len(),
        };
        n as u8 // validated to be at most 255
    }

    /// Every stimulus id of the chosen views, ordered by view (mono first), then M, S, T, A
    /// and the method levels in file order.
    pub fn ids(&self, views: Views) -> Vec<StimulusId> {
        let methods: Vec<Option<MethodTag>> = match self.method_tags() {
            tags if tags.is_empty() => vec![None],
            tags => tags.into_iter().map(Some).collect(),
        };
        let mut ids = Vec::new();
        for &view in views.list() {
            for material in 1..=self.level_count(Factor::Material) {
                for speed in 1..=self.level_count(Factor::Speed) {
                    for shutter in 1..=self.level_count(Factor::Shutter) {
                        for samples in 1..=self.level_count(Factor::Samples) {
                            for &method in &methods {
                                ids.push(StimulusId { material, speed, shutter, samples, method, view });
                            }
                        }
                    }
                }
            }
        }
        ids
    }

    /// Checks that every level of `id` exists in this design, and that it names a method
    /// level exactly when the design has a method factor.
    pub fn check_id(&self, id: &StimulusId) -> Result<(), DesignError> {
        let tags = self.method_tags();
        let names = || tags.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(", ");
        match id.method {
            None if !tags.is_empty() => {
                return Err(self.request(format!(
                    "stimulus {id}: this design has a rendering-method factor; name a level after A ({})",
                    names()
                )));
            }
            Some(tag) if tags.is_empty() => {
                return Err(self.request(format!(
                    "stimulus {id}: this design has no rendering-method factor (`{tag}`); its method is `[method]`'s"
                )));
            }
            Some(tag) if !tags.contains(&tag) => {
                return Err(
                    self.request(format!("stimulus {id}: the design has no method level `{tag}` (it has {})", names()))
                );
            }
            _ => {}
        }
        for factor in Factor::ALL {
            let count = self.level_count(factor);
            if id.level(factor) > count {
                return Err(self.request(format!(
                    "stimulus {id}: level {} does not exist (the design has {}1..{}{count})",
                    id.level_label(factor),
                    factor.letter(),
                    factor.letter()
                )));
            }
        }
        Ok(())
    }

    /// The factor levels of `id` as recorded in manifests, with the preset's sample count.
    pub fn factors(&self, id: &StimulusId, preset: &Preset) -> Result<Factors, DesignError> {
        self.check_id(id)?;
        let f = &self.spec.factors;
        let (m, s, t, a) = (
            usize::from(id.material - 1),
            usize::from(id.speed - 1),
            usize::from(id.shutter - 1),
            usize::from(id.samples - 1),
        );
        let info = |factor: Factor, name: &str, value: f64| LevelInfo {
            label: id.level_label(factor),
            name: name.to_owned(),
            value,
        };
        Ok(Factors {
            material: info(Factor::Material, &f.material[m].name, f64::from(id.material)),
            speed: info(Factor::Speed, &f.speed[s].name, f.speed[s].degrees_per_second),
            shutter: info(Factor::Shutter, &f.shutter[t].name, f.shutter[t].fraction),
            samples: info(Factor::Samples, &f.samples[a].name, f64::from(preset.samples_per_pixel[a])),
            method: match id.method {
                Some(tag) => {
                    self.check_id(id)?;
                    let level = self.method_tags().iter().position(|t| *t == tag).unwrap_or(0);
                    Some(LevelInfo {
                        label: tag.to_string(),
                        name: f.method[level].name.clone().unwrap_or_else(|| tag.to_string()),
                        value: f64::from(tag.code()),
                    })
                }
                None => None,
            },
        })
    }
}

impl fmt::Display for Views {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Views::Mono => "mono",
            Views::Stereo => "stereo",
            Views::Both => "both",
        })
    }
}
