//! Stimulus design files (`stimuli/*.toml`): the factors and their levels, the scene, the
//! viewing geometry that turns degrees of visual angle into metres per second, the stereo
//! rig, lighting, exposure, presets; and from them the [`FrameScene`] of any frame of any
//! stimulus.
//!
//! Every fact of the study lives in the design file; this module only applies geometry.
//! Errors name the file, the line and the key (`deny_unknown_fields` everywhere, spans from
//! the TOML parser, and a key search for errors found after parsing).

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3, EulerRot};
use serde::Deserialize;

use crate::fsio::sha256_hex;
use crate::ids::{Factor, StimulusId, View};
use crate::manifest::{Factors, LevelInfo};
use crate::scene::{
    Camera, Environment, Exposure, EyeView, Floor, FrameScene, Integrator, Lighting, Material, RollingSphere, Shutter,
    StereoConvergence, ToneMap, eye_camera,
};
use crate::seed::{Eye, frame_seed};

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
// The file as written.

/// How each frame's shutter interval is placed relative to the frame time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShutterPlacement {
    /// Centred on the frame time (the default).
    Centred,
    /// Opening at the frame time.
    Opening,
}

/// Which way the sphere rolls across the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Direction {
    /// Towards the camera's right.
    LeftToRight,
    /// Towards the camera's left.
    RightToLeft,
}

/// `[sequence]`: timing and image size of the full-size sequences.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceSpec {
    /// Frames per sequence.
    pub frames: u32,
    /// Playback rate, frames per second.
    pub fps: f64,
    /// Width of one eye's image in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Where the shutter interval sits relative to the frame time.
    pub shutter_placement: ShutterPlacement,
    /// Where in its frame interval a frame's nominal time lies, as a fraction in [0, 1)
    /// (0.5: the middle of [i/fps, (i+1)/fps]).
    pub frame_time_offset: f64,
}

/// `[viewing]`: how the observer sees the image.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewingSpec {
    /// Eye-to-screen distance, metres.
    pub distance: f64,
    /// Visual angle subtended by the image width (one eye's image), degrees.
    pub image_angle_degrees: f64,
}

/// `[camera]`: the centre camera.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Distance from the centre of projection to the sphere's centre as it crosses the
    /// image centre, metres.
    pub distance: f64,
    /// Height of the centre of projection above the floor, metres.
    pub height: f64,
    /// Focal length, metres.
    pub focal_length: f64,
    /// Sensor width, metres (horizontal fit; the height follows the image aspect).
    pub sensor_width: f64,
}

/// `[stereo]`: the rig of the stereo sequences.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StereoSpec {
    /// Distance between the two eyes' centres of projection, metres.
    pub interocular: f64,
    /// How the eyes converge on the focus point.
    pub convergence: StereoConvergence,
}

/// `[sphere]`: the rolling sphere and its path.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Diameter, metres.
    pub diameter: f64,
    /// Direction of travel in the image.
    pub direction: Direction,
    /// Extra distance beyond the edge of view, metres, before the path wraps around.
    pub offscreen_margin: f64,
    /// Orientation at t = 0 as XYZ Euler angles, degrees.
    pub start_orientation_degrees: [f64; 3],
}

/// `[floor]`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorSpec {
    /// Height of the floor plane, metres.
    pub height: f64,
    /// Lambertian reflectance, linear RGB.
    pub albedo: [f64; 3],
}

/// Kinds of environment a design may name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EnvironmentKind {
    /// The built-in procedural map.
    Default,
    /// A latitude-longitude map from an EXR or Radiance HDR file.
    File,
    /// Constant radiance.
    Uniform,
}

/// `[lighting.environment]`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// Which kind.
    pub kind: EnvironmentKind,
    /// Width of the generated default map (kind `default`).
    pub width: Option<u32>,
    /// Path of the map, relative to the design file's folder (kind `file`).
    pub path: Option<String>,
    /// Radiance (kind `uniform`).
    pub radiance: Option<[f64; 3]>,
}

/// `[lighting]`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightingSpec {
    /// The map.
    pub environment: EnvironmentSpec,
    /// Radiance multiplier.
    pub intensity: f64,
    /// Rotation of the map about the vertical, degrees.
    pub rotation_degrees: f64,
}

/// `[integrator]`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// Maximum bounces after the first hit.
    pub max_bounces: u32,
    /// Bounce from which Russian roulette may end a path.
    pub russian_roulette_from: u32,
}

/// `[exposure]`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExposureSpec {
    /// Exposure in stops.
    pub stops: f64,
    /// Tone curve.
    pub tone_map: ToneMap,
}

/// Kinds of sphere material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MaterialKind {
    /// One colour.
    Flat,
    /// A two-colour checker.
    Checker,
    /// Band-limited noise blending two colours.
    Noise,
}

/// One `[[factors.material]]` level.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialLevel {
    /// Human name.
    pub name: String,
    /// Which kind; decides which of the other keys are required.
    pub kind: MaterialKind,
    /// Flat reflectance.
    pub albedo: Option<[f64; 3]>,
    /// First reflectance (checker, noise).
    pub albedo_a: Option<[f64; 3]>,
    /// Second reflectance (checker, noise).
    pub albedo_b: Option<[f64; 3]>,
    /// Checker squares around the equator.
    pub squares_around: Option<u32>,
    /// Checker squares from pole to pole.
    pub squares_pole_to_pole: Option<u32>,
    /// Noise frequency of the first octave, cycles per radius.
    pub base_frequency: Option<f64>,
    /// Noise octaves.
    pub octaves: Option<u32>,
    /// Noise lattice seed.
    pub seed: Option<u64>,
}

/// One `[[factors.speed]]` level.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedLevel {
    /// Human name.
    pub name: String,
    /// Speed in degrees of visual angle per second for the observer.
    pub degrees_per_second: f64,
}

/// One `[[factors.shutter]]` level.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShutterLevel {
    /// Human name.
    pub name: String,
    /// Open fraction of the frame time in [0, 1].
    pub fraction: f64,
}

/// One `[[factors.samples]]` level.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplesLevel {
    /// Human name.
    pub name: String,
    /// Camera samples per pixel in the full preset.
    pub samples_per_pixel: u32,
}

/// `[factors]`: the four factors' levels, in id order (level 1 first).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FactorsSpec {
    /// M levels.
    pub material: Vec<MaterialLevel>,
    /// S levels.
    pub speed: Vec<SpeedLevel>,
    /// T levels.
    pub shutter: Vec<ShutterLevel>,
    /// A levels.
    pub samples: Vec<SamplesLevel>,
}

/// One `[presets.NAME]` table: overrides of the full design for smaller renders.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresetSpec {
    /// Width of one eye's image.
    pub width: Option<u32>,
    /// Height.
    pub height: Option<u32>,
    /// Frames to render.
    pub frames: Option<u32>,
    /// Index on the full sequence's timeline of the first rendered frame.
    pub first_frame: Option<u32>,
    /// Samples per pixel for each A level, replacing the levels' own counts.
    pub samples_per_pixel: Option<Vec<u32>>,
}

/// The design file as written.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Design name (recorded in set indexes).
    pub name: String,
    /// Master seed from which every random choice derives.
    pub master_seed: u64,
    /// Timing and size.
    pub sequence: SequenceSpec,
    /// Viewing geometry.
    pub viewing: ViewingSpec,
    /// Centre camera.
    pub camera: CameraSpec,
    /// Stereo rig.
    pub stereo: StereoSpec,
    /// Sphere and path.
    pub sphere: SphereSpec,
    /// Floor.
    pub floor: FloorSpec,
    /// Environment lighting.
    pub lighting: LightingSpec,
    /// Path termination.
    pub integrator: IntegratorSpec,
    /// Display mapping.
    pub exposure: ExposureSpec,
    /// Factor levels.
    pub factors: FactorsSpec,
    /// Named presets (`full` applies none of its overrides unless given).
    #[serde(default)]
    pub presets: BTreeMap<String, PresetSpec>,
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
    text: String,
}

impl Design {
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
        let spec: DesignSpec = toml::from_str(text).map_err(|e| parse_error(path, text, &e))?;
        let mut design = Design {
            path: path.to_owned(),
            sha256: sha256.to_owned(),
            lighting: Lighting {
                environment: Environment::Uniform { radiance: [0.0; 3] },
                intensity: 0.0,
                rotation_y: 0.0,
            },
            spec,
            text: text.to_owned(),
        };
        design.validate()?;
        design.lighting = design.resolve_lighting()?;
        Ok(design)
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
            line: find_key_line(&self.text, table, index, key),
            key: dotted,
            message: message.into(),
        }
    }

    fn request(&self, message: impl Into<String>) -> DesignError {
        DesignError::Request { path: self.path.clone(), message: message.into() }
    }

    fn validate(&self) -> Result<(), DesignError> {
        let s = &self.spec;
        let positive = |table: &str, key: &str, v: f64| -> Result<(), DesignError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.invalid(table, None, key, format!("must be a positive number, found {v}")))
            }
        };
        let albedo = |table: &str, index: Option<usize>, key: &str, a: [f64; 3]| -> Result<(), DesignError> {
            if a.iter().all(|c| c.is_finite() && (0.0..=1.0).contains(c)) {
                Ok(())
            } else {
                Err(self.invalid(table, index, key, format!("reflectances must lie in [0, 1], found {a:?}")))
            }
        };
        if s.sequence.frames == 0 {
            return Err(self.invalid("sequence", None, "frames", "must be at least 1"));
        }
        positive("sequence", "fps", s.sequence.fps)?;
        if s.sequence.width == 0 || s.sequence.height == 0 {
            return Err(self.invalid("sequence", None, "width", "image size must be at least 1x1"));
        }
        if !(0.0..1.0).contains(&s.sequence.frame_time_offset) {
            return Err(self.invalid("sequence", None, "frame_time_offset", "must lie in [0, 1)"));
        }
        positive("viewing", "distance", s.viewing.distance)?;
        if !(s.viewing.image_angle_degrees > 0.0 && s.viewing.image_angle_degrees < 180.0) {
            return Err(self.invalid("viewing", None, "image_angle_degrees", "must lie in (0, 180)"));
        }
        positive("camera", "distance", s.camera.distance)?;
        positive("camera", "focal_length", s.camera.focal_length)?;
        positive("camera", "sensor_width", s.camera.sensor_width)?;
        positive("sphere", "diameter", s.sphere.diameter)?;
        let rise = s.camera.height - 0.5 * s.sphere.diameter;
        if !s.camera.height.is_finite() || rise.abs() >= s.camera.distance {
            return Err(self.invalid(
                "camera",
                None,
                "height",
                format!(
                    "the camera must be less than `camera.distance` ({}) above the sphere's centre, found {rise}",
                    s.camera.distance
                ),
            ));
        }
        if !(s.stereo.interocular.is_finite() && s.stereo.interocular >= 0.0) {
            return Err(self.invalid("stereo", None, "interocular", "must be zero or positive"));
        }
        if !(s.sphere.offscreen_margin.is_finite() && s.sphere.offscreen_margin >= 0.0) {
            return Err(self.invalid("sphere", None, "offscreen_margin", "must be zero or positive"));
        }
        if !s.sphere.start_orientation_degrees.iter().all(|a| a.is_finite()) {
            return Err(self.invalid("sphere", None, "start_orientation_degrees", "must be finite"));
        }
        if !s.floor.height.is_finite() {
            return Err(self.invalid("floor", None, "height", "must be finite"));
        }
        albedo("floor", None, "albedo", s.floor.albedo)?;
        if !(s.lighting.intensity.is_finite() && s.lighting.intensity >= 0.0) {
            return Err(self.invalid("lighting", None, "intensity", "must be zero or positive"));
        }
        if !s.lighting.rotation_degrees.is_finite() {
            return Err(self.invalid("lighting", None, "rotation_degrees", "must be finite"));
        }
        if s.integrator.max_bounces < 3 {
            return Err(self.invalid(
                "integrator",
                None,
                "max_bounces",
                "must be at least 3 (soft shadows and colour bleeding need indirect light)",
            ));
        }
        if !s.exposure.stops.is_finite() {
            return Err(self.invalid("exposure", None, "stops", "must be finite"));
        }
        for (factor, count) in [
            ("material", s.factors.material.len()),
            ("speed", s.factors.speed.len()),
            ("shutter", s.factors.shutter.len()),
            ("samples", s.factors.samples.len()),
        ] {
            if count == 0 || count > usize::from(u8::MAX) {
                return Err(self.invalid("factors", None, factor, format!("needs 1 to 255 levels, found {count}")));
            }
        }
        for (i, m) in s.factors.material.iter().enumerate() {
            self.material_of(i, m)?;
        }
        for (i, v) in s.factors.speed.iter().enumerate() {
            if !(v.degrees_per_second.is_finite() && v.degrees_per_second >= 0.0) {
                return Err(self.invalid("factors.speed", Some(i), "degrees_per_second", "must be zero or positive"));
            }
        }
        for (i, t) in s.factors.shutter.iter().enumerate() {
            if !(0.0..=1.0).contains(&t.fraction) {
                return Err(self.invalid(
                    "factors.shutter",
                    Some(i),
                    "fraction",
                    format!("must lie in [0, 1], found {}", t.fraction),
                ));
            }
        }
        for (i, a) in s.factors.samples.iter().enumerate() {
            if a.samples_per_pixel == 0 {
                return Err(self.invalid("factors.samples", Some(i), "samples_per_pixel", "must be at least 1"));
            }
        }
        for (name, p) in &s.presets {
            let table = format!("presets.{name}");
            if p.width == Some(0) || p.height == Some(0) {
                return Err(self.invalid(&table, None, "width", "image size must be at least 1x1"));
            }
            if p.frames == Some(0) {
                return Err(self.invalid(&table, None, "frames", "must be at least 1"));
            }
            if let Some(spp) = &p.samples_per_pixel
                && (spp.len() != s.factors.samples.len() || spp.contains(&0))
            {
                return Err(self.invalid(
                    &table,
                    None,
                    "samples_per_pixel",
                    format!("needs one count of at least 1 per A level ({}), found {spp:?}", s.factors.samples.len()),
                ));
            }
            let frames = p.frames.unwrap_or(s.sequence.frames);
            let first = p.first_frame.unwrap_or(0);
            if u64::from(first) + u64::from(frames) > u64::from(s.sequence.frames) {
                return Err(self.invalid(
                    &table,
                    None,
                    "first_frame",
                    format!(
                        "frames {first}..{} lie beyond the sequence's {} frames",
                        first + frames,
                        s.sequence.frames
                    ),
                ));
            }
        }
        Ok(())
    }

    fn material_of(&self, index: usize, m: &MaterialLevel) -> Result<Material, DesignError> {
        let table = "factors.material";
        let need = |key: &str, v: Option<[f64; 3]>| -> Result<[f64; 3], DesignError> {
            let a = v.ok_or_else(|| {
                self.invalid(table, Some(index), key, format!("kind `{:?}` needs this key", m.kind).to_lowercase())
            })?;
            if a.iter().all(|c| c.is_finite() && (0.0..=1.0).contains(c)) {
                Ok(a)
            } else {
                Err(self.invalid(table, Some(index), key, format!("reflectances must lie in [0, 1], found {a:?}")))
            }
        };
        let forbid = |key: &str, present: bool| -> Result<(), DesignError> {
            if present {
                Err(self.invalid(
                    table,
                    Some(index),
                    key,
                    format!("not used by kind `{}`", format!("{:?}", m.kind).to_lowercase()),
                ))
            } else {
                Ok(())
            }
        };
        let count = |key: &str, v: Option<u32>| -> Result<u32, DesignError> {
            v.filter(|&n| n >= 1).ok_or_else(|| self.invalid(table, Some(index), key, "needs a count of at least 1"))
        };
        match m.kind {
            MaterialKind::Flat => {
                for (key, present) in [
                    ("albedo_a", m.albedo_a.is_some()),
                    ("albedo_b", m.albedo_b.is_some()),
                    ("squares_around", m.squares_around.is_some()),
                    ("squares_pole_to_pole", m.squares_pole_to_pole.is_some()),
                    ("base_frequency", m.base_frequency.is_some()),
                    ("octaves", m.octaves.is_some()),
                    ("seed", m.seed.is_some()),
                ] {
                    forbid(key, present)?;
                }
                Ok(Material::Flat { albedo: need("albedo", m.albedo)? })
            }
            MaterialKind::Checker => {
                for (key, present) in [
                    ("albedo", m.albedo.is_some()),
                    ("base_frequency", m.base_frequency.is_some()),
                    ("octaves", m.octaves.is_some()),
                    ("seed", m.seed.is_some()),
                ] {
                    forbid(key, present)?;
                }
                Ok(Material::Checker {
                    albedo_a: need("albedo_a", m.albedo_a)?,
                    albedo_b: need("albedo_b", m.albedo_b)?,
                    squares_around: count("squares_around", m.squares_around)?,
                    squares_pole_to_pole: count("squares_pole_to_pole", m.squares_pole_to_pole)?,
                })
            }
            MaterialKind::Noise => {
                for (key, present) in [
                    ("albedo", m.albedo.is_some()),
                    ("squares_around", m.squares_around.is_some()),
                    ("squares_pole_to_pole", m.squares_pole_to_pole.is_some()),
                ] {
                    forbid(key, present)?;
                }
                let base_frequency = m
                    .base_frequency
                    .filter(|f| f.is_finite() && *f > 0.0)
                    .ok_or_else(|| self.invalid(table, Some(index), "base_frequency", "needs a positive frequency"))?;
                Ok(Material::Noise {
                    albedo_a: need("albedo_a", m.albedo_a)?,
                    albedo_b: need("albedo_b", m.albedo_b)?,
                    base_frequency,
                    octaves: count("octaves", m.octaves)?,
                    seed: m
                        .seed
                        .ok_or_else(|| self.invalid(table, Some(index), "seed", "kind `noise` needs this key"))?,
                })
            }
        }
    }

    fn resolve_lighting(&self) -> Result<Lighting, DesignError> {
        let spec = &self.spec.lighting;
        let env = &spec.environment;
        let table = "lighting.environment";
        let forbid = |key: &str, present: bool| {
            if present {
                Err(self.invalid(table, None, key, format!("not used by kind `{:?}`", env.kind).to_lowercase()))
            } else {
                Ok(())
            }
        };
        let environment = match env.kind {
            EnvironmentKind::Default => {
                forbid("path", env.path.is_some())?;
                forbid("radiance", env.radiance.is_some())?;
                let width =
                    env.width.ok_or_else(|| self.invalid(table, None, "width", "kind `default` needs this key"))?;
                if width < 4 || width % 2 != 0 {
                    return Err(self.invalid(
                        table,
                        None,
                        "width",
                        format!("must be an even number of at least 4, found {width}"),
                    ));
                }
                Environment::Default { width }
            }
            EnvironmentKind::File => {
                forbid("width", env.width.is_some())?;
                forbid("radiance", env.radiance.is_some())?;
                let rel =
                    env.path.as_ref().ok_or_else(|| self.invalid(table, None, "path", "kind `file` needs this key"))?;
                let folder = self.path.parent().unwrap_or(Path::new(""));
                let path = folder.join(rel);
                if !path.is_file() {
                    return Err(self.invalid(
                        table,
                        None,
                        "path",
                        format!(
                            "environment map `{}` does not exist (paths are relative to the design file's folder)",
                            path.display()
                        ),
                    ));
                }
                Environment::File { path }
            }
            EnvironmentKind::Uniform => {
                forbid("width", env.width.is_some())?;
                forbid("path", env.path.is_some())?;
                let radiance = env
                    .radiance
                    .ok_or_else(|| self.invalid(table, None, "radiance", "kind `uniform` needs this key"))?;
                if !radiance.iter().all(|c| c.is_finite() && *c >= 0.0) {
                    return Err(self.invalid(table, None, "radiance", "must be finite and non-negative"));
                }
                Environment::Uniform { radiance }
            }
        };
        Ok(Lighting { environment, intensity: spec.intensity, rotation_y: spec.rotation_degrees.to_radians() })
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
        };
        n as u8 // validated to be at most 255
    }

    /// Every stimulus id of the chosen views, ordered by view (mono first), then M, S, T, A.
    pub fn ids(&self, views: Views) -> Vec<StimulusId> {
        let mut ids = Vec::new();
        for &view in views.list() {
            for material in 1..=self.level_count(Factor::Material) {
                for speed in 1..=self.level_count(Factor::Speed) {
                    for shutter in 1..=self.level_count(Factor::Shutter) {
                        for samples in 1..=self.level_count(Factor::Samples) {
                            ids.push(StimulusId { material, speed, shutter, samples, view });
                        }
                    }
                }
            }
        }
        ids
    }

    /// Checks that every level of `id` exists in this design.
    pub fn check_id(&self, id: &StimulusId) -> Result<(), DesignError> {
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
        })
    }

    /// Pixels per degree of visual angle at the centre of the screen, for an image `width`
    /// pixels wide: the screen is flat, so a degree covers `d * pi/180` metres there, and
    /// the image is `2 d tan(angle/2)` metres wide.
    pub fn pixels_per_degree(&self, width: u32) -> f64 {
        let v = &self.spec.viewing;
        let screen_width = 2.0 * v.distance * (0.5 * v.image_angle_degrees.to_radians()).tan();
        f64::from(width) / screen_width * v.distance * 1f64.to_radians()
    }

    /// Speed on the sphere's plane (m/s) that the observer sees as `degrees_per_second` at
    /// the screen centre. Independent of the resolution: image pixels per degree times the
    /// object-plane metres per image pixel at the focus distance `D` (`D * sensor / (f * W)`).
    pub fn metres_per_second(&self, degrees_per_second: f64) -> f64 {
        let c = &self.spec.camera;
        let v = &self.spec.viewing;
        let object_plane_width = c.distance * c.sensor_width / c.focal_length;
        degrees_per_second * 1f64.to_radians() / (2.0 * (0.5 * v.image_angle_degrees.to_radians()).tan())
            * object_plane_width
    }

    /// Centre of the sphere as it crosses the image centre (the focus point).
    pub fn focus_point(&self) -> DVec3 {
        DVec3::new(0.0, self.spec.floor.height + 0.5 * self.spec.sphere.diameter, 0.0)
    }

    /// The centre camera at `width` x `height` pixels: `camera.distance` from the focus
    /// point, `camera.height` above the floor, looking at the focus point, on the +z side.
    pub fn centre_camera(&self, width: u32, height: u32) -> Camera {
        let c = &self.spec.camera;
        let focus = self.focus_point();
        let eye_y = self.spec.floor.height + c.height;
        let rise = eye_y - focus.y;
        let horizontal = (c.distance * c.distance - rise * rise).sqrt();
        Camera::look_at(
            DVec3::new(focus.x, eye_y, focus.z + horizontal),
            focus,
            c.focal_length,
            c.sensor_width,
            width,
            height,
        )
    }

    /// The sphere's motion at speed level `speed` (1-based).
    ///
    /// The path runs along the camera's right axis through the focus point. A sphere
    /// crossing the view takes less time than a sequence at the study's speeds, so the path
    /// wraps: the sphere leaves the view and re-enters on the other side, and does so as
    /// soon as it is out of view. Both wrap points lie `h = D tan(a) + r / cos(a) + margin`
    /// from the focus point (`a` the half field of view: the sphere is then entirely
    /// outside the view's side planes); the path starts at the entry point at t = 0 and
    /// wraps every `2h`. A sphere at rest stays at the focus point.
    pub fn sphere_motion(&self, speed: u8) -> Result<RollingSphere, DesignError> {
        let level = self
            .spec
            .factors
            .speed
            .get(usize::from(speed).wrapping_sub(1))
            .ok_or_else(|| self.request(format!("speed level S{speed} does not exist")))?;
        let s = &self.spec.sphere;
        let c = &self.spec.camera;
        let radius = 0.5 * s.diameter;
        let camera = self.centre_camera(self.spec.sequence.width, self.spec.sequence.height);
        let sign = match s.direction {
            Direction::LeftToRight => 1.0,
            Direction::RightToLeft => -1.0,
        };
        let axis = camera.right * sign;
        let speed_ms = self.metres_per_second(level.degrees_per_second);
        let start_orientation = {
            let [x, y, z] = s.start_orientation_degrees;
            DQuat::from_euler(EulerRot::XYZ, x.to_radians(), y.to_radians(), z.to_radians())
        };
        let tan_half = 0.5 * c.sensor_width / c.focal_length;
        let half_view = c.distance * tan_half + radius * (1.0 + tan_half * tan_half).sqrt() + s.offscreen_margin;
        let (offset, wrap_length) = if speed_ms > 0.0 { (-half_view, Some(2.0 * half_view)) } else { (0.0, None) };
        Ok(RollingSphere {
            radius,
            start: self.focus_point() + axis * offset,
            velocity: axis * speed_ms,
            start_orientation,
            floor_normal: DVec3::Y,
            wrap_length,
        })
    }

    /// The nominal time of frame `frame` of `preset` (seconds from the sequence start).
    pub fn frame_time(&self, preset: &Preset, frame: u32) -> f64 {
        (f64::from(preset.first_frame + frame) + self.spec.sequence.frame_time_offset) / self.spec.sequence.fps
    }

    /// The shutter interval of a frame at `frame_time` for shutter level `shutter` (1-based).
    pub fn shutter(&self, shutter: u8, frame_time: f64) -> Result<Shutter, DesignError> {
        let level = self
            .spec
            .factors
            .shutter
            .get(usize::from(shutter).wrapping_sub(1))
            .ok_or_else(|| self.request(format!("shutter level T{shutter} does not exist")))?;
        let duration = level.fraction / self.spec.sequence.fps;
        Ok(match self.spec.sequence.shutter_placement {
            ShutterPlacement::Centred if duration == 0.0 => Shutter { open: frame_time, close: frame_time },
            ShutterPlacement::Centred => {
                Shutter { open: frame_time - 0.5 * duration, close: frame_time + 0.5 * duration }
            }
            ShutterPlacement::Opening => Shutter { open: frame_time, close: frame_time + duration },
        })
    }

    /// The scene of frame `frame` of `id` in the full preset.
    pub fn frame_scene(&self, id: &StimulusId, frame: u32) -> Result<FrameScene, DesignError> {
        self.frame_scene_with(&self.preset("full")?, id, frame)
    }

    /// The scene of frame `frame` (0-based within the preset's frames) of `id` in `preset`.
    pub fn frame_scene_with(&self, preset: &Preset, id: &StimulusId, frame: u32) -> Result<FrameScene, DesignError> {
        self.check_id(id)?;
        if frame >= preset.frames {
            return Err(self.request(format!(
                "stimulus {id}: frame {frame} does not exist (preset `{}` has frames 0..{})",
                preset.name,
                preset.frames - 1
            )));
        }
        let s = &self.spec;
        let frame_time = self.frame_time(preset, frame);
        let centre = self.centre_camera(preset.width, preset.height);
        let views = Eye::of_view(id.view)
            .iter()
            .map(|&eye| EyeView {
                eye,
                camera: eye_camera(&centre, eye, s.stereo.interocular, s.camera.distance, s.stereo.convergence),
                seed: frame_seed(s.master_seed, id, eye, frame),
            })
            .collect();
        Ok(FrameScene {
            stimulus: *id,
            frame,
            frame_time,
            shutter: self.shutter(id.shutter, frame_time)?,
            views,
            sphere: self.sphere_motion(id.speed)?,
            material: self
                .material_of(usize::from(id.material - 1), &s.factors.material[usize::from(id.material - 1)])?,
            floor: Floor { height: s.floor.height, albedo: s.floor.albedo },
            lighting: self.lighting.clone(),
            samples_per_pixel: preset.samples_per_pixel[usize::from(id.samples - 1)],
            integrator: Integrator {
                max_bounces: s.integrator.max_bounces,
                russian_roulette_from: s.integrator.russian_roulette_from,
            },
            exposure: Exposure { stops: s.exposure.stops, tone_map: s.exposure.tone_map },
        })
    }
}

/// Turns a TOML error into one naming the file, line, column and key.
fn parse_error(path: &Path, text: &str, error: &toml::de::Error) -> DesignError {
    let (line, column) = error.span().map_or((1, 1), |span| line_column(text, span.start));
    // toml names the key path only in its display without input context.
    let mut bare = error.clone();
    bare.set_input(None);
    let shown = bare.to_string();
    let mut key =
        shown.lines().find_map(|l| l.strip_prefix("in `").and_then(|r| r.strip_suffix('`'))).map(str::to_owned);
    if key.is_none() {
        key = error.span().and_then(|span| key_at(text, span.start));
    }
    DesignError::Parse { path: path.to_owned(), line, column, key, message: error.message().trim().to_owned() }
}

/// 1-based line and column of byte `offset`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// The dotted key whose value (or name) is at byte `offset`: the last `[table]` header
/// before it and the nearest `key =` on its line at or before the offset.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
    let line = &text[line_start..line_end];
    let upto = offset - line_start;
    let table = text[..line_start].lines().rev().find_map(|l| {
        let l = l.trim();
        l.strip_prefix('[').map(|h| h.trim_start_matches('[').trim_end_matches(']').trim().to_owned())
    });
    if line.trim_start().starts_with('[') {
        return table;
    }
    // The key: either the word at the offset (an unknown key) or the one before the last `=`.
    let head = &line[..upto.min(line.len())];
    let name = match head.rfind('=') {
        Some(eq) => {
            let before = head[..eq].trim_end();
            let start =
                before.rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == '-' || c == '.')).map_or(0, |i| i + 1);
            before[start..].to_owned()
        }
        None => line[upto.min(line.len())..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == '-' || *c == '.')
            .collect(),
    };
    if name.is_empty() {
        return table;
    }
    Some(match table {
        Some(t) => format!("{t}.{name}"),
        None => name,
    })
}

/// 1-based line where `key` is set inside `table` (the `index`-th `[[table]]` for arrays of
/// tables), also finding `table = { key = ... }` inline forms and `key` under `[table.sub]`.
fn find_key_line(text: &str, table: &str, index: Option<usize>, key: &str) -> Option<usize> {
    let mut current = String::new();
    let mut occurrence: Option<usize> = None;
    let (parent, last) = table.rsplit_once('.').unwrap_or(("", table));
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if let Some(h) = line.strip_prefix("[[") {
            current = h.trim_end_matches("]]").trim().to_owned();
            if current == table {
                occurrence = Some(occurrence.map_or(0, |o| o + 1));
            }
            continue;
        }
        if let Some(h) = line.strip_prefix('[') {
            current = h.trim_end_matches(']').trim().to_owned();
            continue;
        }
        let in_table = current == table && index.is_none_or(|i| occurrence == Some(i));
        let starts_with_key =
            |l: &str, k: &str| l.strip_prefix(k).is_some_and(|rest| rest.trim_start().starts_with('='));
        if in_table && starts_with_key(line, key) {
            return Some(n + 1);
        }
        // `last = { key = ... }` inside `[parent]`.
        if current == parent && index.is_none() && starts_with_key(line, last) && line.contains(&format!("{key} ")) {
            return Some(n + 1);
        }
        if table.is_empty() && current.is_empty() && starts_with_key(line, key) {
            return Some(n + 1);
        }
    }
    // Fall back to the table's header.
    text.lines()
        .position(|l| {
            let l = l.trim();
            l == format!("[{table}]") || l == format!("[[{table}]]")
        })
        .map(|n| n + 1)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_at_finds_keys_of_values_and_unknown_names() {
        let text = "name = \"x\"\n[sequence]\nfps = \"thirty\"\nbogus = 1\n[lighting]\nenvironment = { kind = \"file\", path = 3 }\n";
        let at = |needle: &str| key_at(text, text.find(needle).unwrap());
        assert_eq!(at("\"thirty\"").as_deref(), Some("sequence.fps"));
        assert_eq!(at("bogus").as_deref(), Some("sequence.bogus"));
        assert_eq!(at("3 }").as_deref(), Some("lighting.path"));
        assert_eq!(find_key_line(text, "sequence", None, "fps"), Some(3));
        assert_eq!(find_key_line(text, "lighting.environment", None, "path"), Some(6));
    }
}
