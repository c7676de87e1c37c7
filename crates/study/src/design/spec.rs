//! The design file as written: the serde types of every table of a `stimuli/*.toml` file,
//! one struct per table, with `deny_unknown_fields` so that a misspelt key is an error
//! naming it. Checking the values and building scenes from them is the job of the sibling
//! modules; this one only says what may be written.

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::method::MethodTable;
use crate::scene::{StereoConvergence, ToneMap};

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
    /// The display's peak luminance, cd/m² (what the image-computable observer's display
    /// model assumes; default [`DEFAULT_PEAK_LUMINANCE`]).
    #[serde(default = "default_peak_luminance")]
    pub peak_luminance: f64,
    /// The display's black level, cd/m² (default [`DEFAULT_BLACK_LEVEL`]).
    #[serde(default = "default_black_level")]
    pub black_level: f64,
    /// Ambient illuminance at the screen, lux (default [`DEFAULT_AMBIENT_LUX`]).
    #[serde(default = "default_ambient_lux")]
    pub ambient_lux: f64,
}

/// Peak luminance of an office LCD, cd/m² (ColorVideoVDP's `standard_fhd` display).
pub const DEFAULT_PEAK_LUMINANCE: f64 = 200.0;
/// Black level of an office LCD with a 1000:1 contrast, cd/m².
pub const DEFAULT_BLACK_LEVEL: f64 = 0.2;
/// Office lighting, lux (ColorVideoVDP's `standard_fhd` display).
pub const DEFAULT_AMBIENT_LUX: f64 = 250.0;

fn default_peak_luminance() -> f64 {
    DEFAULT_PEAK_LUMINANCE
}

fn default_black_level() -> f64 {
    DEFAULT_BLACK_LEVEL
}

fn default_ambient_lux() -> f64 {
    DEFAULT_AMBIENT_LUX
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
    /// Rendering-method levels (optional): with them every id names its method level
    /// (`M3-S3-T5-A1-guertin`) and `[method]` must be absent.
    #[serde(default)]
    pub method: Vec<MethodTable>,
}

/// Where a `[medium]`'s grids come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MediumSourceKind {
    /// blurlab's smoke simulation (`[medium.simulation]`).
    Simulation,
    /// `blurlab-grid/1` files, one per frame (`path`, a pattern with a run of `#`).
    Files,
}

/// `[medium.simulation]`: the smoke simulation that makes a medium's grids.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationSpec {
    /// Cells along x, y (up) and z.
    pub resolution: [u32; 3],
    /// Seed of the source's flicker (default: the design's `master_seed`).
    pub seed: Option<u64>,
    /// Simulation steps per frame (default 1).
    #[serde(default = "one")]
    pub steps_per_frame: u32,
    /// Frames simulated before the sequence's frame 0, so that the plume has risen (default 0).
    #[serde(default)]
    pub warmup_frames: u32,
}

fn one() -> u32 {
    1
}

/// `[medium]`: a participating medium in the scene (optional; a design without it runs no
/// volume code).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSpec {
    /// Where the grids come from.
    pub source: MediumSourceKind,
    /// Source `files`: the grid files' pattern, relative to the design file's folder, with a
    /// run of `#` for the zero-padded timeline frame number (`smoke/density-####.grid`).
    pub path: Option<String>,
    /// Source `simulation`: its settings.
    pub simulation: Option<SimulationSpec>,
    /// Centre of the grids' box in the world, metres (the sphere crosses the image centre at
    /// x = z = 0, standing on the floor).
    pub centre: [f64; 3],
    /// Size of the box along x, y and z, metres.
    pub size: [f64; 3],
    /// Extinction coefficient at density 1, per metre.
    pub extinction: f64,
    /// Single-scattering albedo in [0, 1].
    pub albedo: f64,
    /// Scattering events in the medium along one path of the reference tracer (default 1,
    /// the thesis's single scattering; more adds multiple scattering).
    #[serde(default = "one")]
    pub max_scatterings: u32,
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
    /// The set's rendering method (`[method] kind = "tracer"` when absent).
    #[serde(default)]
    pub method: MethodTable,
    /// A participating medium (optional).
    #[serde(default)]
    pub medium: Option<MediumSpec>,
    /// Named presets (`full` applies none of its overrides unless given).
    #[serde(default)]
    pub presets: BTreeMap<String, PresetSpec>,
}
