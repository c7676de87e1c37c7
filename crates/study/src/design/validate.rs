//! Checks of a parsed design beyond its shape (ranges, required and forbidden keys per
//! kind), and the conversions that need them: a material level into a [`Material`], the
//! lighting table into a [`Lighting`] with its map's path resolved against the design's
//! folder. Every error names the key and, where it is written, its line.

use std::path::Path;

use super::{Design, DesignError, EnvironmentKind, MaterialKind, MaterialLevel};
use crate::ids::MethodTag;
use crate::method::{MethodSpec, MethodTable, num};
use crate::scene::{DEFAULT_MAP_PEAK_RADIANCE, Environment, Lighting, MAX_RADIANCE, Material};

/// The frame rates a design may set (frames per second).
pub const FPS_RANGE: std::ops::RangeInclusive<f64> = 1e-3..=1e5;

/// The largest image side (one eye) in pixels.
pub const MAX_SIDE: u32 = 16384;
/// The most pixels of one eye's image (a stereo frame holds twice as many).
pub const MAX_PIXELS: u64 = 1 << 26;
/// The most frames of a sequence.
pub const MAX_FRAMES: u32 = 100_000;
/// The most samples per pixel of a level.
pub const MAX_SAMPLES: u32 = 1 << 20;
/// The most octaves of a noise material.
pub const MAX_OCTAVES: u32 = 32;
/// The most bounces of a path (`integrator.max_bounces`). Light in this scene (a sphere on
/// an open floor under the sky) leaves within a few bounces; 10000 is a furnace test's "no
/// effective limit", and keeps every bounce's sampling dimensions within u32.
pub const MAX_BOUNCES: u32 = 10_000;
/// The most light paths (camera samples, or the analytic method's lighting samples) one
/// frame of a stereo pair (both eyes) may need: 4K stereo at 4096 samples per pixel.
pub const MAX_FRAME_SAMPLES: u64 = 1 << 36;
/// The most triangle-pixel pairs one frame of the analytic method (both eyes, every sample
/// point) may need: about `tessellation^2` triangles times the sample points.
pub const MAX_FRAME_TRIANGLE_PIXELS: u64 = 1 << 36;

impl Design {
    /// Two levels of one factor with the same name or the same value are ambiguous: the error
    /// names both (`factors.speed[2]` and `factors.speed[4]`).
    fn distinct_levels(&self) -> Result<(), DesignError> {
        let f = &self.spec.factors;
        let mut materials: Vec<(String, String)> = Vec::new();
        for m in &f.material {
            let mut unnamed = m.clone();
            unnamed.name.clear();
            materials.push((m.name.clone(), format!("{unnamed:?}")));
        }
        let levels: [(&str, Vec<(String, String)>); 4] = [
            ("material", materials),
            ("speed", f.speed.iter().map(|l| (l.name.clone(), l.degrees_per_second.to_string())).collect()),
            ("shutter", f.shutter.iter().map(|l| (l.name.clone(), l.fraction.to_string())).collect()),
            ("samples", f.samples.iter().map(|l| (l.name.clone(), l.samples_per_pixel.to_string())).collect()),
        ];
        for (factor, list) in levels {
            for (j, (name, value)) in list.iter().enumerate() {
                for (i, (other_name, other_value)) in list[..j].iter().enumerate() {
                    let what = if name == other_name {
                        format!("has the name `{name}` of factors.{factor}[{}] too", i + 1)
                    } else if value == other_value {
                        format!("is the same level as factors.{factor}[{}] (`{other_name}`)", i + 1)
                    } else {
                        continue;
                    };
                    let table = format!("factors.{factor}");
                    return Err(self.invalid(&table, Some(j), "name", format!("level {} `{name}` {what}", j + 1)));
                }
            }
        }
        Ok(())
    }

    /// Image size and frame count within the limits above (checked before anything is
    /// allocated); the error names the key and the limit.
    fn limits(
        &self,
        table: &str,
        width: Option<u32>,
        height: Option<u32>,
        frames: Option<u32>,
    ) -> Result<(), DesignError> {
        for (key, v) in [("width", width), ("height", height)] {
            if let Some(v) = v.filter(|&v| v > MAX_SIDE) {
                return Err(self.invalid(table, None, key, format!("{v} pixels is above the limit of {MAX_SIDE}")));
            }
        }
        let w = width.unwrap_or(self.spec.sequence.width);
        let h = height.unwrap_or(self.spec.sequence.height);
        if u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(self.invalid(
                table,
                None,
                "height",
                format!("{w}x{h} is {} pixels, above the limit of {MAX_PIXELS}", u64::from(w) * u64::from(h)),
            ));
        }
        if let Some(f) = frames.filter(|&f| f > MAX_FRAMES) {
            return Err(self.invalid(table, None, "frames", format!("{f} is above the limit of {MAX_FRAMES}")));
        }
        Ok(())
    }

    pub(super) fn validate(&self) -> Result<(), DesignError> {
        let s = &self.spec;
        let positive = |table: &str, key: &str, v: f64| -> Result<(), DesignError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.invalid(table, None, key, format!("must be a positive number, found {}", num(v))))
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
        self.limits("sequence", Some(s.sequence.width), Some(s.sequence.height), Some(s.sequence.frames))?;
        positive("sequence", "fps", s.sequence.fps)?;
        // Frame times are (i + offset) / fps: at 1e-300 fps they overflow the sphere's path to
        // NaN and no method draws the sphere.
        if !FPS_RANGE.contains(&s.sequence.fps) {
            return Err(self.invalid(
                "sequence",
                None,
                "fps",
                format!(
                    "must lie in [{:e}, {:e}] frames per second, found {}",
                    FPS_RANGE.start(),
                    FPS_RANGE.end(),
                    num(s.sequence.fps)
                ),
            ));
        }
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
        positive("viewing", "peak_luminance", s.viewing.peak_luminance)?;
        positive("viewing", "black_level", s.viewing.black_level)?;
        if s.viewing.black_level >= s.viewing.peak_luminance {
            return Err(self.invalid(
                "viewing",
                None,
                "black_level",
                format!(
                    "must lie below peak_luminance ({} cd/m²), found {}",
                    num(s.viewing.peak_luminance),
                    num(s.viewing.black_level)
                ),
            ));
        }
        if !(s.viewing.ambient_lux.is_finite() && s.viewing.ambient_lux >= 0.0) {
            return Err(self.invalid(
                "viewing",
                None,
                "ambient_lux",
                format!("must be a finite number >= 0, found {}", num(s.viewing.ambient_lux)),
            ));
        }
        positive("camera", "distance", s.camera.distance)?;
        positive("camera", "focal_length", s.camera.focal_length)?;
        positive("camera", "sensor_width", s.camera.sensor_width)?;
        positive("sphere", "diameter", s.sphere.diameter)?;
        // The stereo eyes sit beside the centre camera along its right axis, at its height:
        // what holds for the centre camera's height holds for every eye.
        if !(s.camera.height.is_finite() && s.camera.height > 0.0) {
            return Err(self.invalid(
                "camera",
                None,
                "height",
                format!("must put the eye above the floor (a positive height), found {}", num(s.camera.height)),
            ));
        }
        // The sphere's path runs through the focus point along the eyes' baseline, so it
        // passes exactly `camera.distance` from every eye (and a sphere at rest sits there).
        let radius = 0.5 * s.sphere.diameter;
        if s.camera.distance <= radius {
            return Err(self.invalid(
                "camera",
                None,
                "distance",
                format!(
                    "{} puts the eye inside the sphere (radius {}) as it passes: the path runs `camera.distance` from every eye",
                    num(s.camera.distance),
                    num(radius)
                ),
            ));
        }
        let rise = s.camera.height - 0.5 * s.sphere.diameter;
        if !s.camera.height.is_finite() || rise.abs() >= s.camera.distance {
            return Err(self.invalid(
                "camera",
                None,
                "height",
                format!(
                    "the camera must be less than `camera.distance` ({}) above the sphere's centre, found {}",
                    num(s.camera.distance),
                    num(rise)
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
        if s.integrator.max_bounces > MAX_BOUNCES {
            return Err(self.invalid(
                "integrator",
                None,
                "max_bounces",
                format!("{} is above the limit of {MAX_BOUNCES}", s.integrator.max_bounces),
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
                    format!("must lie in [0, 1], found {}", num(t.fraction)),
                ));
            }
        }
        for (i, a) in s.factors.samples.iter().enumerate() {
            if a.samples_per_pixel == 0 {
                return Err(self.invalid("factors.samples", Some(i), "samples_per_pixel", "must be at least 1"));
            }
            if a.samples_per_pixel > MAX_SAMPLES {
                return Err(self.invalid(
                    "factors.samples",
                    Some(i),
                    "samples_per_pixel",
                    format!("{} is above the limit of {MAX_SAMPLES}", a.samples_per_pixel),
                ));
            }
        }
        self.distinct_levels()?;
        self.validate_methods()?;
        for (name, p) in &s.presets {
            let table = format!("presets.{name}");
            if p.width == Some(0) || p.height == Some(0) {
                return Err(self.invalid(&table, None, "width", "image size must be at least 1x1"));
            }
            if p.frames == Some(0) {
                return Err(self.invalid(&table, None, "frames", "must be at least 1"));
            }
            self.limits(&table, p.width, p.height, p.frames)?;
            if let Some(n) = p.samples_per_pixel.as_ref().and_then(|v| v.iter().copied().find(|&n| n > MAX_SAMPLES)) {
                return Err(self.invalid(
                    &table,
                    None,
                    "samples_per_pixel",
                    format!("{n} is above the limit of {MAX_SAMPLES}"),
                ));
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
                        u64::from(first) + u64::from(frames),
                        s.sequence.frames
                    ),
                ));
            }
        }
        self.frame_work()
    }

    /// The method tables of the design: `[method]`, or each `[[factors.method]]` level.
    fn method_tables(&self) -> Vec<(&'static str, Option<usize>, &MethodTable)> {
        let s = &self.spec;
        if s.factors.method.is_empty() {
            vec![("method", None, &s.method)]
        } else {
            s.factors.method.iter().enumerate().map(|(i, m)| ("factors.method", Some(i), m)).collect()
        }
    }

    /// The typed method of each method table ([`Design::method_tables`]' order): a key that
    /// does not apply to the table's method, or a setting out of range, is refused with the
    /// file, line and key.
    pub(super) fn typed_methods(&self) -> Result<Vec<MethodSpec>, DesignError> {
        self.method_tables()
            .into_iter()
            .map(|(table, index, m)| {
                MethodSpec::from_table(m).map_err(|e| self.invalid(table, index, e.key, e.message))
            })
            .collect()
    }

    /// The antialiasing each method table asks for ([`Design::method_tables`]' order), its
    /// settings checked with the file, line and key named.
    pub(super) fn typed_antialias(&self) -> Result<Vec<Option<crate::scene::Antialias>>, DesignError> {
        self.method_tables()
            .into_iter()
            .map(|(table, index, m)| {
                crate::method::antialias::antialias_of(m).map_err(|e| self.invalid(table, index, e.key, e.message))
            })
            .collect()
    }

    /// What one frame of each method costs, in every preset at every A level, within
    /// [`MAX_FRAME_SAMPLES`] light paths and (rasterizers) [`MAX_FRAME_TRIANGLE_PIXELS`]
    /// triangle-pixel pairs, counting both eyes of a stereo frame. The error names the
    /// method's setting that drives the cost where one is written, else the samples or the
    /// image size.
    fn frame_work(&self) -> Result<(), DesignError> {
        let s = &self.spec;
        let methods = self.typed_methods()?;
        for name in self.preset_names() {
            let preset = self.preset(&name)?;
            let written = s.presets.get(&name);
            let size_table = if written.is_some_and(|p| p.width.is_some() || p.height.is_some()) {
                format!("presets.{name}")
            } else {
                "sequence".to_owned()
            };
            let pixels = 2 * u64::from(preset.width) * u64::from(preset.height);
            let what =
                format!("preset `{name}` ({}x{} per eye, both eyes of a stereo frame)", preset.width, preset.height);
            for (a, &spp) in preset.samples_per_pixel.iter().enumerate() {
                let samples_key = if written.is_some_and(|p| p.samples_per_pixel.is_some()) {
                    (format!("presets.{name}"), None)
                } else {
                    ("factors.samples".to_owned(), Some(a))
                };
                for ((table, index, _), m) in self.method_tables().into_iter().zip(&methods) {
                    let work = m.frame_work(spp);
                    // The key named: the method's setting that drives the cost where one is
                    // written, else the A level's samples (light paths) or the image size.
                    let limit = |total: u64, max: u64, unit: &str, how: &str, key: Option<&str>, by_samples: bool| {
                        if total <= max {
                            return Ok(());
                        }
                        let message = format!(
                            "the `{}` method at {what}, A{}: {how} x {pixels} pixels is {} {unit} per frame, above the limit of {} (2^{})",
                            m.kind(),
                            a + 1,
                            num(total as f64),
                            num(max as f64),
                            max.ilog2()
                        );
                        Err(match key {
                            Some(key) => self.invalid(table, index, key, message),
                            None if by_samples && spp > 1 => {
                                self.invalid(&samples_key.0, samples_key.1, "samples_per_pixel", message)
                            }
                            None => self.invalid(&size_table, None, "height", message),
                        })
                    };
                    let paths = work.light_paths.saturating_mul(pixels);
                    limit(paths, MAX_FRAME_SAMPLES, "light paths", &work.light_paths_how, work.light_paths_key, true)?;
                    if let Some((per_pixel, key, how)) = &work.triangle_pairs {
                        let pairs = per_pixel.saturating_mul(pixels);
                        limit(pairs, MAX_FRAME_TRIANGLE_PIXELS, "triangle-pixel pairs", how, *key, false)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// `[method]` or the `[[factors.method]]` levels: settings that apply to their method,
    /// in range; at most [`MethodTag::MAX_VARIANTS`] levels of one method.
    fn validate_methods(&self) -> Result<(), DesignError> {
        let s = &self.spec;
        let levels = &s.factors.method;
        if !levels.is_empty() && s.method != MethodTable::default() {
            return Err(self.invalid(
                "",
                None,
                "method",
                "a design with `[[factors.method]]` levels names each level's method there; remove `[method]`",
            ));
        }
        self.typed_methods()?;
        for kind in crate::Method::ALL {
            let n = levels.iter().filter(|m| m.kind == kind).count();
            if n > usize::from(MethodTag::MAX_VARIANTS) {
                return Err(self.invalid(
                    "factors",
                    None,
                    "method",
                    format!("at most {} levels of `{kind}`, found {n}", MethodTag::MAX_VARIANTS),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn material_of(&self, index: usize, m: &MaterialLevel) -> Result<Material, DesignError> {
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
                    octaves: match count("octaves", m.octaves)? {
                        n if n > MAX_OCTAVES => {
                            return Err(self.invalid(
                                table,
                                Some(index),
                                "octaves",
                                format!("{n} is above the limit of {MAX_OCTAVES} (each octave doubles the frequency)"),
                            ));
                        }
                        n => n,
                    },
                    seed: m
                        .seed
                        .ok_or_else(|| self.invalid(table, Some(index), "seed", "kind `noise` needs this key"))?,
                })
            }
        }
    }

    pub(super) fn resolve_lighting(&self) -> Result<Lighting, DesignError> {
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
                if !(4..=8192).contains(&width) || width % 2 != 0 {
                    return Err(self.invalid(
                        table,
                        None,
                        "width",
                        format!("must be an even number from 4 to 8192, found {width}"),
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
                if let Some(&c) = radiance.iter().find(|&&c| c > MAX_RADIANCE) {
                    return Err(self.invalid(
                        table,
                        None,
                        "radiance",
                        format!("{} is above the limit of {}", num(c), num(MAX_RADIANCE)),
                    ));
                }
                Environment::Uniform { radiance }
            }
        };
        // The brightest radiance the renderers see is the map's times the intensity; a map
        // file's own pixels are checked when it is loaded.
        let peak = match &environment {
            Environment::Default { .. } => DEFAULT_MAP_PEAK_RADIANCE,
            Environment::Uniform { radiance } => radiance.iter().copied().fold(0.0, f64::max),
            Environment::File { .. } => 1.0,
        };
        if spec.intensity * peak > MAX_RADIANCE {
            let of = match &environment {
                Environment::File { .. } => String::new(),
                _ => format!(" times the map's brightest radiance {} is {}", num(peak), num(spec.intensity * peak)),
            };
            return Err(self.invalid(
                "lighting",
                None,
                "intensity",
                format!(
                    "{}{of}, above the limit of {} (f32::MAX / 2^20, so that renderers' sums stay finite)",
                    num(spec.intensity),
                    num(MAX_RADIANCE)
                ),
            ));
        }
        Ok(Lighting { environment, intensity: spec.intensity, rotation_y: spec.rotation_degrees.to_radians() })
    }
}
