//! The rendering method of a stimulus set: which algorithm turns a frame's scene into
//! pixels, and its settings. Design files name it (`[method] kind = "tracer"`, the default)
//! or make it a factor (`[[factors.method]]`, one table per level), manifests record it, and
//! `render::Renderer` dispatches on it.
//!
//! Everything the study model knows about a method lives in its own file here, behind
//! [`MethodSettings`]: the keys a design may write for it, their defaults and valid ranges,
//! what one frame costs (design limits and the shard planner) and the knob the cost sweep
//! turns with its report label. The renderer's side of a method (CPU reference, WGSL passes,
//! GPU host) lives in `render::methods::NAME`. The `methods!` table below is the one
//! place a method is registered in the study model; see `docs/architecture.md` for the
//! recipe of a new method.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::design::Preset;

/// The accessors of a settings struct that give each written setting or its default: one
/// table of a method's defaults.
macro_rules! defaults {
    ($settings:ty { $( $(#[$doc:meta])* $key:ident: $t:ty = $default:expr ),* $(,)? }) => {
        impl $settings {
            $( $(#[$doc])* pub fn $key(&self) -> $t { self.$key.unwrap_or($default) } )*
        }
    };
}

mod accum;
mod analytic;
pub mod antialias;
mod guertin;
pub mod marcher;
mod mcguire;
mod table;
mod tracer;

pub use accum::{AccumSettings, DEFAULT_INSTANTS};
pub use analytic::{
    AnalyticSettings, DEFAULT_INTERVALS, DEFAULT_TESSELLATION, INTERVALS_RANGE, SUPERSAMPLING_RANGE,
    TESSELLATION_RANGE, sphere_triangle_count,
};
pub use analytic::{SWEEP_INTERVALS, SWEEP_SUPERSAMPLING};
pub use guertin::GuertinSettings;
pub use marcher::{MarchLighting, MarcherSettings};
pub use mcguire::{McGuireSettings, SWEEP_TAPS};
pub use table::MethodTable;
pub use tracer::TracerSettings;

/// The filters' tap count (N) and tile size (k or r) limits: what the design accepts and the
/// render filters' own checks allow.
pub const FILTER_COUNT_RANGE: std::ops::RangeInclusive<u32> = 1..=1024;

/// A setting out of range or a key that does not apply: the key as the design writes it and
/// what was wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyError {
    /// The key (`taps`, `gamma`, ...).
    pub key: &'static str,
    /// What was wrong.
    pub message: String,
}

impl fmt::Display for KeyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// A number for a message: plain where short, in scientific notation where plain would print
/// hundreds of digits.
pub(crate) fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&v.abs()) { format!("{v}") } else { format!("{v:e}") }
}

/// `Err` when a written count lies outside `range`.
pub(crate) fn check_count(
    key: &'static str,
    v: Option<u32>,
    range: std::ops::RangeInclusive<u32>,
) -> Result<(), KeyError> {
    match v {
        Some(v) if !range.contains(&v) => {
            Err(KeyError { key, message: format!("must lie in {}..={}, found {v}", range.start(), range.end()) })
        }
        _ => Ok(()),
    }
}

/// `Err` when a written real is not finite or lies outside `[lo, hi]`.
pub(crate) fn check_real(key: &'static str, v: Option<f64>, lo: f64, hi: f64) -> Result<(), KeyError> {
    match v {
        Some(v) if !(v.is_finite() && v >= lo && v <= hi) => {
            Err(KeyError { key, message: format!("must lie in [{lo}, {hi}], found {}", num(v)) })
        }
        _ => Ok(()),
    }
}

/// What one frame of a method costs per pixel, for the design's limits: light paths (camera
/// or lighting samples) and, for a rasterizer, triangle-pixel pairs; each with the setting
/// that drives it where the design writes one, and how it was counted.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameWork {
    /// Light paths per pixel.
    pub light_paths: u64,
    /// The written key driving the light paths (`None`: the A level's samples).
    pub light_paths_key: Option<&'static str>,
    /// `16 samples per pixel`, `8 instants x 2 samples per instant`.
    pub light_paths_how: String,
    /// Triangle-pixel pairs per pixel, its key and how counted (rasterizers only).
    pub triangle_pairs: Option<(u64, Option<&'static str>, String)>,
}

impl FrameWork {
    /// `n` light paths per pixel at the A level's samples.
    pub fn samples(spp: u32) -> FrameWork {
        FrameWork {
            light_paths: u64::from(spp),
            light_paths_key: None,
            light_paths_how: format!("{spp} samples per pixel"),
            triangle_pairs: None,
        }
    }
}

/// One setting of a method's accuracy knob in the cost sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSetting {
    /// The method and its settings.
    pub spec: MethodSpec,
    /// The knob's name (`spp`, `instants`, `taps`, `intervals`, `supersampling`, `lights`,
    /// `slices_per_4_voxels`).
    pub knob: &'static str,
    /// Its value.
    pub value: u32,
    /// Samples per pixel of the frame scene handed to the method.
    pub input_spp: u32,
    /// Antialiasing of the rendered frame (MLAA's sweep, [`antialias::mlaa_sweep`]).
    pub antialias: Option<crate::scene::Antialias>,
}

/// Which of a sweep's input levels (samples per pixel handed to the method) the cost report
/// draws a curve for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveInput {
    /// One curve whatever the input (the tracer's input is its knob).
    Ignored,
    /// One curve per input level.
    Each,
    /// Only the highest input level's curve (the filters' taps are swept at every A level).
    Highest,
}

/// The samples per pixel levels of `preset` up to `max_spp`, sorted, without repeats.
pub fn sweep_levels(preset: &Preset, max_spp: u32) -> Vec<u32> {
    let mut l: Vec<u32> = preset.samples_per_pixel.iter().copied().filter(|&s| s <= max_spp).collect();
    l.sort_unstable();
    l.dedup();
    l
}

/// A method's settings as a design writes them, and what the study model derives from them.
pub trait MethodSettings: Clone + Default + PartialEq + fmt::Debug + Sized {
    /// The keys a design may write for this method (besides `kind` and `name`).
    const KEYS: &'static [&'static str];
    /// The settings from a design's method table (keys of other methods already refused).
    fn from_table(table: &MethodTable) -> Self;
    /// Writes the settings into a method table (the inverse of [`MethodSettings::from_table`]).
    fn write_table(&self, table: &mut MethodTable);
    /// Checks the written settings' ranges.
    fn check(&self) -> Result<(), KeyError>;
    /// Camera samples per pixel one frame costs about, relative to the tracer's at `spp`
    /// (the shard planner's estimate).
    fn samples_cost(&self, spp: u32) -> u64;
    /// What one frame costs per pixel at the A level's `spp`, for the design's limits (by
    /// default the A level's samples, as the tracer traces them).
    fn frame_work(&self, spp: u32) -> FrameWork {
        FrameWork::samples(spp)
    }
    /// Every setting the cost sweep measures for this method, coarsest first.
    fn sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting>;
    /// Work units per pixel of one render at a sweep setting (by default the knob's value).
    fn work_units(_knob: &str, value: u32, _input_spp: u32) -> u64 {
        u64::from(value)
    }
    /// The cost report's curve label of the sweep along `knob` at `input_spp`.
    fn curve_label(knob: &str, input_spp: u32) -> String;
    /// Which of the sweep's input levels the cost report draws a curve for.
    const CURVE_INPUT: CurveInput;
}

/// Declares the methods: the [`Method`] enum, [`Method::ALL`], names, and the tagged
/// [`MethodSpec`] with one variant per method holding its settings type. A method is
/// registered here with one line.
macro_rules! methods {
    ($( $(#[$doc:meta])* $variant:ident = $name:literal => $settings:ty ),* $(,)?) => {
        /// A rendering method. The tracer is the reference every other method is compared with.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "lowercase")]
        pub enum Method {
            $( $(#[$doc])* $variant, )*
        }

        impl Method {
            /// Every method, in the order reports list them.
            pub const ALL: [Method; [$($name),*].len()] = [$(Method::$variant),*];

            /// The name used in design files, manifests and on the command line.
            pub fn name(self) -> &'static str {
                match self { $( Method::$variant => $name, )* }
            }

            /// The keys a design may write for this method.
            pub fn keys(self) -> &'static [&'static str] {
                match self { $( Method::$variant => <$settings as MethodSettings>::KEYS, )* }
            }

            /// Every setting the cost sweep measures for this method, coarsest first.
            pub fn sweep(self, preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
                match self { $( Method::$variant => <$settings as MethodSettings>::sweep(preset, max_spp), )* }
            }

            /// Work units per pixel of one render at a sweep setting.
            pub fn work_units(self, knob: &str, value: u32, input_spp: u32) -> u64 {
                match self { $( Method::$variant => <$settings as MethodSettings>::work_units(knob, value, input_spp), )* }
            }

            /// The cost report's curve label of the sweep along `knob` at `input_spp`.
            pub fn curve_label(self, knob: &str, input_spp: u32) -> String {
                match self { $( Method::$variant => <$settings as MethodSettings>::curve_label(knob, input_spp), )* }
            }

            /// Which of the sweep's input levels the cost report draws a curve for.
            pub fn curve_input(self) -> CurveInput {
                match self { $( Method::$variant => <$settings as MethodSettings>::CURVE_INPUT, )* }
            }
        }

        /// A method with its settings: `[method]` of a design file or one `[[factors.method]]`
        /// level, typed. Settings left unwritten take the method's defaults.
        #[derive(Clone, Debug, PartialEq)]
        pub enum MethodSpec {
            $( $(#[$doc])* $variant($settings), )*
        }

        impl MethodSpec {
            /// The method's defaults.
            pub fn of(kind: Method) -> MethodSpec {
                match kind { $( Method::$variant => MethodSpec::$variant(<$settings>::default()), )* }
            }

            /// The method.
            pub fn kind(&self) -> Method {
                match self { $( MethodSpec::$variant(_) => Method::$variant, )* }
            }

            /// The settings of a method table whose keys all apply to its kind.
            fn from_applicable(table: &MethodTable) -> MethodSpec {
                match table.kind {
                    $( Method::$variant => MethodSpec::$variant(<$settings as MethodSettings>::from_table(table)), )*
                }
            }

            /// The method table that writes these settings.
            pub fn to_table(&self) -> MethodTable {
                let mut table = MethodTable { kind: self.kind(), ..MethodTable::default() };
                match self { $( MethodSpec::$variant(s) => s.write_table(&mut table), )* }
                table
            }

            /// Checks the settings' ranges.
            pub fn check(&self) -> Result<(), KeyError> {
                match self { $( MethodSpec::$variant(s) => s.check(), )* }
            }

            /// Camera samples per pixel one frame costs about, relative to the tracer's at
            /// `spp` (the shard planner's estimate).
            pub fn samples_cost(&self, spp: u32) -> u64 {
                match self { $( MethodSpec::$variant(s) => s.samples_cost(spp), )* }
            }

            /// What one frame costs per pixel at the A level's `spp`.
            pub fn frame_work(&self, spp: u32) -> FrameWork {
                match self { $( MethodSpec::$variant(s) => s.frame_work(spp), )* }
            }
        }
    };
}

methods! {
    /// The distribution (Monte Carlo) ray tracer: pixel area and shutter time sampled.
    Tracer = "tracer" => TracerSettings,
    /// Accumulation buffer: instantaneous renders at several times in the shutter, averaged.
    Accum = "accum" => AccumSettings,
    /// McGuire et al. 2012 post-process motion blur (reconstruction filter).
    Mcguire = "mcguire" => McGuireSettings,
    /// Guertin et al. 2014 post-process motion blur (filtering approach).
    Guertin = "guertin" => GuertinSettings,
    /// Gribel et al. 2010 analytic motion blur rasterizer (visibility over the shutter).
    Analytic = "analytic" => AnalyticSettings,
    /// The thesis's participating-media ray marcher over the tracer's surfaces.
    Marcher = "marcher" => MarcherSettings,
}

/// The tracer, the method of a design that names none.
impl Default for Method {
    fn default() -> Self {
        Method::Tracer
    }
}

impl Default for MethodSpec {
    fn default() -> Self {
        MethodSpec::of(Method::default())
    }
}

impl MethodSpec {
    /// The typed settings of a design's method table: a key that does not apply to the
    /// table's method, or a value out of range, is refused with the key named.
    pub fn from_table(table: &MethodTable) -> Result<MethodSpec, KeyError> {
        let kind = table.kind;
        for key in table.written_keys() {
            if !kind.keys().contains(&key) && !antialias::KEYS.contains(&key) {
                let takes: Vec<&str> =
                    Method::ALL.into_iter().filter(|m| m.keys().contains(&key)).map(Method::name).collect();
                return Err(KeyError {
                    key,
                    message: format!("applies to {} only, not to `{kind}`", takes.join(" and ")),
                });
            }
        }
        let spec = MethodSpec::from_applicable(table);
        spec.check()?;
        Ok(spec)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            format!("unknown rendering method `{s}`; expected one of {}", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_text_and_serde() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
            assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{}\"", m.name()));
            assert_eq!(serde_json::from_str::<Method>(&format!("\"{m}\"")).unwrap(), m);
            assert_eq!(MethodSpec::of(m).kind(), m);
            assert_eq!(MethodSpec::from_table(&MethodSpec::of(m).to_table()), Ok(MethodSpec::of(m)));
        }
        let e = "raster".parse::<Method>().unwrap_err();
        assert_eq!(
            e,
            "unknown rendering method `raster`; expected one of tracer, accum, mcguire, guertin, analytic, marcher"
        );
        assert_eq!(Method::default(), Method::Tracer);
        let table: MethodTable = toml::from_str("kind = \"guertin\"").unwrap();
        assert_eq!(MethodSpec::from_table(&table).unwrap().kind(), Method::Guertin);
        assert!(toml::from_str::<MethodTable>("kind = \"x\"").is_err());
        assert!(toml::from_str::<MethodTable>("sort = \"tracer\"").is_err());
    }

    #[test]
    fn a_key_of_another_method_is_refused_with_the_methods_that_take_it() {
        let table: MethodTable = toml::from_str("kind = \"accum\"\ninstants = 8\ntau = 1.0").unwrap();
        let e = MethodSpec::from_table(&table).unwrap_err();
        assert_eq!(e, KeyError { key: "tau", message: "applies to guertin only, not to `accum`".into() });
        let table: MethodTable = toml::from_str("kind = \"analytic\"\ntaps = 8").unwrap();
        let e = MethodSpec::from_table(&table).unwrap_err();
        assert_eq!(e.message, "applies to mcguire and guertin only, not to `analytic`");
        let table: MethodTable = toml::from_str("kind = \"guertin\"\ntile = 1025").unwrap();
        assert_eq!(MethodSpec::from_table(&table).unwrap_err().message, "must lie in 1..=1024, found 1025");
    }

    #[test]
    fn every_key_of_the_table_belongs_to_some_method_and_round_trips() {
        // Each method's keys, and the display frame's antialiasing keys every method takes.
        let mut all: Vec<&str> =
            Method::ALL.into_iter().flat_map(Method::keys).copied().chain(antialias::KEYS).collect();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), MethodTable::KEYS.len(), "{all:?}");
        for key in MethodTable::KEYS {
            assert!(all.contains(key), "`{key}` is taken by no method");
        }
        let written = "kind = \"guertin\"\ntaps = 9\ntile = 30\ntau = 2.0\nkappa = 3.0\neta = 0.5\ngamma = 1.25\nphi = 4.0\ntile_variance = true";
        let table: MethodTable = toml::from_str(written).unwrap();
        let spec = MethodSpec::from_table(&table).unwrap();
        assert_eq!(spec.to_table(), table);
    }

    #[test]
    fn the_shard_cost_of_every_method_at_its_defaults() {
        // At 16 samples per pixel: the tracer traces 16; the accumulation buffer 8 instants
        // of 2; the filters trace 16 and gather their default taps (McGuire 15, Guertin 35)
        // at 8 taps per traced sample; the analytic rasterizer shades 16 lighting samples at
        // its one sample point.
        let cost = |m: Method| MethodSpec::of(m).samples_cost(16);
        assert_eq!(cost(Method::Tracer), 16);
        assert_eq!(cost(Method::Accum), 16);
        assert_eq!(cost(Method::Mcguire), 16 + 2);
        assert_eq!(cost(Method::Guertin), 16 + 5);
        assert_eq!(cost(Method::Analytic), 16);
        assert_eq!(cost(Method::Marcher), 16 + 4);
        for m in Method::ALL {
            assert!(cost(m) >= 16, "{m}");
        }
    }
}
