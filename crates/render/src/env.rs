//! Environment maps: loading (EXR, Radiance HDR), the built-in procedural default, and
//! importance sampling.
//!
//! A map is a latitude-longitude image of width `2 h` and height `h`. Pixel column `u`
//! (in [0, 1) across the width) is the azimuth `phi = 2 pi u`, row `v` (in [0, 1) down
//! the height) the polar angle from +y, `theta = pi v`; the direction is
//! `(sin phi sin theta, cos theta, -cos phi sin theta)` (Mitsuba's convention for a
//! y-up world, so the benchmark's peer sees the same lighting). The map's radiance is
//! piecewise constant over its pixels, which makes the sampling density below exactly
//! proportional to what it samples.
//!
//! Sampling follows the usual two-level construction: a marginal distribution over rows
//! and a conditional one over the pixels of each row, both proportional to
//! `luminance x sin(theta)` of the row centre. Every map, including the built-in default
//! and the uniform one of the furnace tests, goes through this same construction.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::DVec3;
use study::scene::{Environment, Lighting};

use crate::io::{LinearImage, decode_exr, decode_hdr};

/// Errors of building an environment map; each names the file (when there is one) and
/// what is wrong with it.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The file does not exist.
    #[error("environment map {path}: file not found")]
    Missing {
        /// The path.
        path: PathBuf,
    },
    /// The file could not be read.
    #[error("environment map {path}: cannot read: {source}")]
    Read {
        /// The path.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file extension is neither `.exr` nor `.hdr`.
    #[error("environment map {path}: unsupported format (expected .exr or .hdr)")]
    Format {
        /// The path.
        path: PathBuf,
    },
    /// The decoder rejected the file.
    #[error("environment map {path}: corrupt or unreadable image: {reason}")]
    Corrupt {
        /// The path.
        path: PathBuf,
        /// The decoder's message.
        reason: String,
    },
    /// The image is not a 2:1 latitude-longitude map.
    #[error(
        "environment map {source_name}: wrong dimensions {width}x{height}, expected a latitude-longitude map with width = 2 x height"
    )]
    Dimensions {
        /// The file, or the name of the built-in map.
        source_name: String,
        /// Width found.
        width: u32,
        /// Height found.
        height: u32,
    },
    /// A pixel holds a negative, NaN or infinite value.
    #[error("environment map {source_name}: pixel ({x}, {y}) has invalid radiance {value} (must be finite and >= 0)")]
    BadValue {
        /// The file, or the name of the built-in map.
        source_name: String,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The offending value.
        value: f32,
    },
    /// The lighting's parameters are unusable.
    #[error("environment: {0}")]
    Parameter(String),
}

/// A direction sampled from the map.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// Unit world direction towards the environment.
    pub direction: DVec3,
    /// Radiance arriving from that direction.
    pub radiance: DVec3,
    /// Probability density per unit solid angle.
    pub pdf: f64,
}

/// A latitude-longitude radiance map placed in the world, ready for look-ups and
/// importance sampling.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    width: u32,
    height: u32,
    /// Per pixel: radiance (already scaled by the lighting's intensity) and sampling
    /// density over the unit square (weight / mean weight), together so one look-up
    /// touches one cache line.
    texels: Vec<Texel>,
    /// World-from-map rotation about +y: cosine and sine.
    rot_cos: f64,
    rot_sin: f64,
    /// Cumulative row weights, `height + 1` entries from 0 to 1.
    marginal_cdf: Vec<f64>,
    /// Guide table of the marginal (see [`guide_table`]).
    marginal_guide: Vec<u32>,
    /// Per row, cumulative pixel weights, `width + 1` entries from 0 to 1 (a uniform row
    /// where the row has no weight).
    conditional_cdf: Vec<f64>,
    /// Per row, the guide table of its conditional, `width` entries.
    conditional_guide: Vec<u32>,
    /// Whether any pixel has weight (a black map cannot be sampled).
    samplable: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Texel {
    radiance: [f32; 3],
    density: f32,
}

fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl EnvironmentMap {
    /// Builds the map a scene's lighting asks for: loads the file, generates the default,
    /// or builds the uniform map; applies intensity and rotation.
    pub fn from_lighting(lighting: &Lighting) -> Result<EnvironmentMap, EnvError> {
        if !(lighting.intensity.is_finite() && lighting.intensity >= 0.0) {
            return Err(EnvError::Parameter(format!("intensity {} must be finite and >= 0", lighting.intensity)));
        }
        if !lighting.rotation_y.is_finite() {
            return Err(EnvError::Parameter(format!("rotation_y {} must be finite", lighting.rotation_y)));
        }
        let (image, name) = match &lighting.environment {
            Environment::Default { width } => {
                if *width < 2 || width % 2 != 0 {
                    return Err(EnvError::Parameter(format!("default map width {width} must be even and at least 2")));
                }
                (default_map(*width), "(built-in default)".to_string())
            }
            Environment::File { path } => (load_image(path)?, path.display().to_string()),
            Environment::Uniform { radiance } => {
                if radiance.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
                    return Err(EnvError::Parameter(format!("uniform radiance {radiance:?} must be finite and >= 0")));
                }
                let mut img = LinearImage::new(8, 4);
                img.pixels.fill(radiance.map(|c| c as f32));
                (img, "(uniform)".to_string())
            }
        };
        EnvironmentMap::from_image(&image, lighting.intensity, lighting.rotation_y, &name)
    }

    /// Builds the sampling structures of a latitude-longitude image. `name` names the map
    /// in errors.
    pub fn from_image(
        image: &LinearImage,
        intensity: f64,
        rotation_y: f64,
        name: &str,
    ) -> Result<EnvironmentMap, EnvError> {
        let (w, h) = (image.width, image.height);
        if h == 0 || w != 2 * h || image.pixels.len() != (w as usize) * (h as usize) {
            return Err(EnvError::Dimensions { source_name: name.to_string(), width: w, height: h });
        }
        for (i, p) in image.pixels.iter().enumerate() {
            if let Some(&value) = p.iter().find(|c| !(c.is_finite() && **c >= 0.0)) {
                return Err(EnvError::BadValue {
                    source_name: name.to_string(),
                    x: i as u32 % w,
                    y: i as u32 / w,
                    value,
                });
            }
        }
        let radiance: Vec<DVec3> = image
            .pixels
            .iter()
            .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) * intensity)
            .collect();
        if radiance.iter().any(|c| !c.is_finite()) {
            return Err(EnvError::Parameter(format!("{name}: radiance times intensity {intensity} overflows")));
        }
        let (wu, hu) = (w as usize, h as usize);
        // Weights are normalised by the largest luminance before summing so that huge
        // values (the sun in a real map) cannot overflow the sums.
        if radiance.iter().any(|c| c.max_element() > f64::from(f32::MAX)) {
            return Err(EnvError::Parameter(format!(
                "{name}: radiance times intensity {intensity} exceeds the f32 range"
            )));
        }
        let max_lum = radiance.iter().map(|c| luminance(*c)).fold(0.0, f64::max);
        let scale = if max_lum > 0.0 { 1.0 / max_lum } else { 0.0 };
        let mut weights = vec![0.0; wu * hu];
        let mut row_sums = vec![0.0; hu];
        for y in 0..hu {
            let sin_theta = (PI * (y as f64 + 0.5) / h as f64).sin();
            for x in 0..wu {
                let wgt = luminance(radiance[y * wu + x]) * scale * sin_theta;
                weights[y * wu + x] = wgt;
                row_sums[y] += wgt;
            }
        }
        let total: f64 = row_sums.iter().sum();
        let samplable = total > 0.0 && total.is_finite();
        let mut marginal_cdf = vec![0.0; hu + 1];
        let mut conditional_cdf = vec![0.0; hu * (wu + 1)];
        let mut pixel_density = vec![0.0f64; wu * hu];
        for y in 0..hu {
            marginal_cdf[y + 1] =
                if samplable { marginal_cdf[y] + row_sums[y] / total } else { (y + 1) as f64 / h as f64 };
            let row = &mut conditional_cdf[y * (wu + 1)..(y + 1) * (wu + 1)];
            for x in 0..wu {
                row[x + 1] = if row_sums[y] > 0.0 {
                    row[x] + weights[y * wu + x] / row_sums[y]
                } else {
                    (x + 1) as f64 / w as f64
                };
            }
            row[wu] = 1.0;
            if samplable {
                let mean = total / (wu * hu) as f64;
                for x in 0..wu {
                    pixel_density[y * wu + x] = weights[y * wu + x] / mean;
                }
            }
        }
        marginal_cdf[hu] = 1.0;
        let marginal_guide = guide_table(&marginal_cdf);
        let conditional_guide = conditional_cdf.chunks_exact(wu + 1).flat_map(guide_table).collect();
        let texels = radiance
            .iter()
            .zip(&pixel_density)
            .map(|(r, d)| Texel { radiance: [r.x as f32, r.y as f32, r.z as f32], density: *d as f32 })
            .collect();
        Ok(EnvironmentMap {
            width: w,
            height: h,
            texels,
            rot_cos: rotation_y.cos(),
            rot_sin: rotation_y.sin(),
            marginal_cdf,
            marginal_guide,
            conditional_cdf,
            conditional_guide,
            samplable,
        })
    }

    /// Width of the map in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of the map in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Whether the map has any radiance to importance sample.
    pub fn is_samplable(&self) -> bool {
        self.samplable
    }

    /// World direction to map direction (undoing the rotation about +y).
    fn to_map(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x - self.rot_sin * d.z, d.y, self.rot_sin * d.x + self.rot_cos * d.z)
    }

    fn to_world(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x + self.rot_sin * d.z, d.y, -self.rot_sin * d.x + self.rot_cos * d.z)
    }

    /// Map coordinates (u, v) in [0, 1) of a world direction (need not be normalised).
    fn uv(&self, d: DVec3) -> (f64, f64) {
        let m = self.to_map(d);
        let len = m.length();
        let cos_theta = (m.y / len).clamp(-1.0, 1.0);
        let theta = cos_theta.acos();
        let mut phi = m.x.atan2(-m.z);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        (phi / (2.0 * PI), theta / PI)
    }

    fn pixel_of(&self, u: f64, v: f64) -> usize {
        let x = ((u * self.width as f64) as usize).min(self.width as usize - 1);
        let y = ((v * self.height as f64) as usize).min(self.height as usize - 1);
        y * self.width as usize + x
    }

    /// Radiance arriving from world direction `d` (need not be normalised; a zero or
    /// non-finite direction gives black).
    pub fn radiance(&self, d: DVec3) -> DVec3 {
        if !d.is_finite() || d == DVec3::ZERO {
            return DVec3::ZERO;
        }
        let (u, v) = self.uv(d);
        texel_radiance(&self.texels[self.pixel_of(u, v)])
    }

    /// Density per unit solid angle with which [`EnvironmentMap::sample`] picks world
    /// direction `d`.
    pub fn pdf(&self, d: DVec3) -> f64 {
        if !self.samplable || !d.is_finite() || d == DVec3::ZERO {
            return 0.0;
        }
        let (u, v) = self.uv(d);
        let sin_theta = (PI * v).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        f64::from(self.texels[self.pixel_of(u, v)].density) / (2.0 * PI * PI * sin_theta)
    }

    /// Radiance and sampling density of a direction in one look-up.
    pub fn radiance_and_pdf(&self, d: DVec3) -> (DVec3, f64) {
        if !d.is_finite() || d == DVec3::ZERO {
            return (DVec3::ZERO, 0.0);
        }
        let (u, v) = self.uv(d);
        let texel = &self.texels[self.pixel_of(u, v)];
        let sin_theta = (PI * v).sin();
        let pdf = if self.samplable && sin_theta > 0.0 {
            f64::from(texel.density) / (2.0 * PI * PI * sin_theta)
        } else {
            0.0
        };
        (texel_radiance(texel), pdf)
    }

    /// Picks a direction with density proportional to luminance x sin(theta) per pixel,
    /// from two uniform numbers in [0, 1). `None` for a black map or a degenerate draw at
    /// a pole.
    pub fn sample(&self, u: [f64; 2]) -> Option<EnvSample> {
        if !self.samplable {
            return None;
        }
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, fy) = sample_cdf(&self.marginal_cdf, &self.marginal_guide, u[0]);
        let row = &self.conditional_cdf[y * (w + 1)..(y + 1) * (w + 1)];
        let (x, fx) = sample_cdf(row, &self.conditional_guide[y * w..(y + 1) * w], u[1]);
        let uu = (x as f64 + fx) / w as f64;
        let vv = (y as f64 + fy) / h as f64;
        let theta = PI * vv;
        let phi = 2.0 * PI * uu;
        let sin_theta = theta.sin();
        if sin_theta <= 0.0 {
            return None;
        }
        let texel = &self.texels[y * w + x];
        let density = f64::from(texel.density);
        if density <= 0.0 {
            return None;
        }
        let m = DVec3::new(phi.sin() * sin_theta, theta.cos(), -phi.cos() * sin_theta);
        Some(EnvSample {
            direction: self.to_world(m),
            radiance: texel_radiance(texel),
            pdf: density / (2.0 * PI * PI * sin_theta),
        })
    }
}

fn texel_radiance(t: &Texel) -> DVec3 {
    DVec3::new(f64::from(t.radiance[0]), f64::from(t.radiance[1]), f64::from(t.radiance[2]))
}

/// A guide table for inverting a cumulative distribution of `n + 1` entries: entry `k` is
/// the interval holding `u = k / n`, so a search for `u` starts at most a few intervals
/// before its answer (a binary search over a large map misses the cache at every step).
fn guide_table(cdf: &[f64]) -> Vec<u32> {
    let n = cdf.len() - 1;
    let mut guide = Vec::with_capacity(n);
    let mut i = 0;
    for k in 0..n {
        let u = k as f64 / n as f64;
        while i + 1 < n && cdf[i + 1] <= u {
            i += 1;
        }
        guide.push(i as u32);
    }
    guide
}

/// Inverts a cumulative distribution of `n + 1` entries: the chosen interval and the
/// fractional position inside it. Intervals of zero width are never chosen.
fn sample_cdf(cdf: &[f64], guide: &[u32], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    // First index i with cdf[i + 1] > u, scanning forward from the guide.
    let mut i = guide[((u * n as f64) as usize).min(n - 1)] as usize;
    while i + 1 < n && cdf[i + 1] <= u {
        i += 1;
    }
    let width = cdf[i + 1] - cdf[i];
    let f = if width > 0.0 { ((u - cdf[i]) / width).clamp(0.0, 1.0 - f64::EPSILON) } else { 0.5 };
    (i, f)
}

fn load_image(path: &Path) -> Result<LinearImage, EnvError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(EnvError::Missing { path: path.to_path_buf() });
        }
        Err(source) => return Err(EnvError::Read { path: path.to_path_buf(), source }),
    };
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let decoded = match ext.as_deref() {
        Some("exr") => decode_exr(&bytes),
        Some("hdr") | Some("pic") => decode_hdr(&bytes),
        _ => return Err(EnvError::Format { path: path.to_path_buf() }),
    };
    decoded.map_err(|e| EnvError::Corrupt { path: path.to_path_buf(), reason: e.to_string() })
}

fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The built-in procedural environment, `width x width/2`: a soft overcast-to-blue sky
/// with a warm key light (a broad sun-like lobe, so shadows are soft but have a
/// direction), a cooler fill light from the other side and a darker ground. Its structure
/// (key/fill from different sides, a bright horizon band) makes the shading of the three
/// materials clearly different.
pub fn default_map(width: u32) -> LinearImage {
    let width = width.max(2) & !1;
    let height = width / 2;
    let mut img = LinearImage::new(width, height);
    let dir = |elev_deg: f64, azim_deg: f64| {
        let (e, a) = (elev_deg.to_radians(), azim_deg.to_radians());
        // phi = azimuth: same convention as EnvironmentMap (phi 0 looks towards -z).
        DVec3::new(a.sin() * e.cos(), e.sin(), -a.cos() * e.cos())
    };
    // The camera looks along -z; the key light sits behind and to the right of the
    // camera, so the lit side of the sphere faces the viewer and the shadow falls
    // back-left on the floor.
    let key = dir(38.0, 150.0);
    let fill = dir(20.0, -120.0);
    for y in 0..height {
        let theta = PI * (y as f64 + 0.5) / height as f64;
        for x in 0..width {
            let phi = 2.0 * PI * (x as f64 + 0.5) / width as f64;
            let d = DVec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
            let elev = d.y;
            let c = if elev >= 0.0 {
                let horizon = DVec3::new(1.0, 0.97, 0.92);
                let zenith = DVec3::new(0.35, 0.5, 0.85);
                let t = elev.powf(0.6);
                horizon.lerp(zenith, t) * 0.9
            } else {
                let ground = DVec3::new(0.22, 0.2, 0.18);
                ground * (0.6 + 0.4 * (1.0 - smoothstep(0.0, 0.3, -elev)))
            };
            let key_angle = d.dot(key).clamp(-1.0, 1.0).acos();
            let fill_angle = d.dot(fill).clamp(-1.0, 1.0).acos();
            // Key: ~6 degree soft disc (radiance 150) with a wide glow; fill: broad and dim.
            let key_light = DVec3::new(1.0, 0.9, 0.75)
                * (150.0 * (1.0 - smoothstep(0.08, 0.14, key_angle)) + 1.5 * (-key_angle * key_angle / 0.18).exp());
            let fill_light = DVec3::new(0.7, 0.8, 1.0) * (2.0 * (-fill_angle * fill_angle / 0.08).exp());
            let v = c + key_light + fill_light;
            img.set(x, y, [v.x as f32, v.y as f32, v.z as f32]);
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lighting(environment: Environment) -> Lighting {
        Lighting { environment, intensity: 1.0, rotation_y: 0.0 }
    }

    /// Integrates `f` over the sphere with a fine midpoint rule in (theta, phi).
    fn integrate_sphere(f: impl Fn(DVec3) -> f64, n: usize) -> f64 {
        let mut sum = 0.0;
        for i in 0..n {
            let theta = PI * (i as f64 + 0.5) / n as f64;
            for j in 0..2 * n {
                let phi = 2.0 * PI * (j as f64 + 0.5) / (2 * n) as f64;
                let d = DVec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
                sum += f(d) * theta.sin();
            }
        }
        sum * (PI / n as f64) * (2.0 * PI / (2 * n) as f64)
    }

    fn test_map() -> EnvironmentMap {
        let mut img = default_map(64);
        // A black row and a huge value, the hard cases.
        for x in 0..64 {
            img.set(x, 5, [0.0; 3]);
        }
        img.set(10, 20, [1.0e30, 1.0e30, 1.0e30]);
        EnvironmentMap::from_image(&img, 1.0, 0.7, "test").unwrap()
    }

    #[test]
    fn pdf_integrates_to_one() {
        for map in [test_map(), EnvironmentMap::from_lighting(&lighting(Environment::Default { width: 32 })).unwrap()] {
            let total = integrate_sphere(|d| map.pdf(d), 512);
            assert!((total - 1.0).abs() < 2e-3, "integral {total}");
        }
    }

    #[test]
    fn sampled_directions_follow_the_pdf_and_stay_finite() {
        let map = EnvironmentMap::from_image(&default_map(16), 1.0, 0.3, "t").unwrap();
        // Histogram over map pixels vs. expected probability (pdf integrated over each
        // pixel), chi-square with a generous critical value.
        let (w, h) = (16usize, 8usize);
        let n = 200_000;
        let mut counts = vec![0.0; w * h];
        let mut rng = 0x1234_5678_u64;
        let mut next = || {
            rng = study::seed::splitmix64(rng);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..n {
            let s = map.sample([next(), next()]).unwrap();
            assert!(s.pdf.is_finite() && s.pdf > 0.0 && s.direction.is_finite());
            assert!((s.pdf - map.pdf(s.direction)).abs() <= 1e-6 * s.pdf);
            let (u, v) = map.uv(s.direction);
            counts[map.pixel_of(u, v)] += 1.0;
        }
        let mut chi2 = 0.0;
        let mut dof = 0;
        for (i, &c) in counts.iter().enumerate() {
            let expected = f64::from(map.texels[i].density) / (w * h) as f64 * n as f64;
            if expected > 5.0 {
                chi2 += (c - expected) * (c - expected) / expected;
                dof += 1;
            }
        }
        // Mean dof, sd sqrt(2 dof): 5 sd is far beyond chance.
        assert!(chi2 < dof as f64 + 5.0 * (2.0 * dof as f64).sqrt(), "chi2 {chi2} dof {dof}");
    }

    #[test]
    fn zero_rows_are_never_sampled_and_huge_values_stay_finite() {
        let map = test_map();
        let mut rng = 99_u64;
        for _ in 0..50_000 {
            rng = study::seed::splitmix64(rng);
            let u0 = (rng >> 11) as f64 / (1u64 << 53) as f64;
            rng = study::seed::splitmix64(rng);
            let u1 = (rng >> 11) as f64 / (1u64 << 53) as f64;
            if let Some(s) = map.sample([u0, u1]) {
                let (_, v) = map.uv(s.direction);
                assert_ne!((v * 32.0) as usize, 5, "sampled a black row");
                assert!(s.pdf.is_finite() && s.radiance.is_finite());
            }
        }
        for u in [0.0, 1.0 - f64::EPSILON, 0.5] {
            for v in [0.0, 1.0 - f64::EPSILON] {
                if let Some(s) = map.sample([u, v]) {
                    assert!(s.pdf.is_finite() && s.direction.is_finite());
                }
            }
        }
        assert_eq!(map.pdf(DVec3::Y), 0.0);
        assert!(map.radiance(DVec3::ZERO) == DVec3::ZERO);
    }

    #[test]
    fn uniform_and_black_maps() {
        let map = EnvironmentMap::from_lighting(&lighting(Environment::Uniform { radiance: [2.0, 2.0, 2.0] })).unwrap();
        assert_eq!(map.radiance(DVec3::new(0.3, -0.2, 0.9)), DVec3::splat(2.0));
        let black = EnvironmentMap::from_lighting(&lighting(Environment::Uniform { radiance: [0.0; 3] })).unwrap();
        assert!(!black.is_samplable() && black.sample([0.5, 0.5]).is_none() && black.pdf(DVec3::X) == 0.0);
    }

    #[test]
    fn rotation_turns_the_map_about_y() {
        let base = EnvironmentMap::from_image(&default_map(64), 1.0, 0.0, "a").unwrap();
        let rot = EnvironmentMap::from_image(&default_map(64), 1.0, 1.0, "b").unwrap();
        let d = DVec3::new(0.6, 0.3, -0.5).normalize();
        let turned = DVec3::new(1.0f64.cos() * d.x + 1.0f64.sin() * d.z, d.y, -1.0f64.sin() * d.x + 1.0f64.cos() * d.z);
        assert_eq!(base.radiance(d), rot.radiance(turned));
    }

    #[test]
    fn file_errors_name_the_file_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str| dir.path().join(name);
        let err = |p: PathBuf| {
            EnvironmentMap::from_lighting(&lighting(Environment::File { path: p })).unwrap_err().to_string()
        };
        let missing = err(file("nope.exr"));
        assert!(missing.contains("nope.exr") && missing.contains("not found"), "{missing}");
        std::fs::write(file("bad.exr"), b"not an exr").unwrap();
        let corrupt = err(file("bad.exr"));
        assert!(corrupt.contains("bad.exr") && corrupt.contains("corrupt"), "{corrupt}");
        std::fs::write(file("bad.hdr"), b"#?RADIANCE\njunk").unwrap();
        assert!(err(file("bad.hdr")).contains("corrupt"));
        std::fs::write(file("map.png"), b"x").unwrap();
        assert!(err(file("map.png")).contains("unsupported format"));

        let square = LinearImage::new(8, 8);
        std::fs::write(file("square.exr"), crate::io::encode_exr(&square).unwrap()).unwrap();
        let dims = err(file("square.exr"));
        assert!(dims.contains("square.exr") && dims.contains("wrong dimensions 8x8"), "{dims}");

        let mut nan = LinearImage::new(8, 4);
        nan.set(3, 2, [0.0, f32::NAN, 0.0]);
        std::fs::write(file("nan.exr"), crate::io::encode_exr(&nan).unwrap()).unwrap();
        let bad = err(file("nan.exr"));
        assert!(bad.contains("nan.exr") && bad.contains("(3, 2)") && bad.contains("NaN"), "{bad}");
        let mut neg = LinearImage::new(8, 4);
        neg.set(0, 0, [-1.0, 0.0, 0.0]);
        std::fs::write(file("neg.exr"), crate::io::encode_exr(&neg).unwrap()).unwrap();
        assert!(err(file("neg.exr")).contains("-1"));

        // A good EXR loads and matches the image it was written from.
        let img = default_map(32);
        std::fs::write(file("good.exr"), crate::io::encode_exr(&img).unwrap()).unwrap();
        let loaded = EnvironmentMap::from_lighting(&lighting(Environment::File { path: file("good.exr") })).unwrap();
        let direct = EnvironmentMap::from_image(&img, 1.0, 0.0, "x").unwrap();
        assert_eq!(loaded.texels, direct.texels);
    }

    #[test]
    fn hdr_files_load() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.hdr");
        let img = default_map(16);
        let buf = image::Rgb32FImage::from_fn(16, 8, |x, y| image::Rgb(img.get(x, y)));
        image::DynamicImage::ImageRgb32F(buf).save_with_format(&path, image::ImageFormat::Hdr).unwrap();
        let map = EnvironmentMap::from_lighting(&lighting(Environment::File { path })).unwrap();
        // RGBE keeps about 1 % precision.
        let d = DVec3::new(0.2, 0.5, -0.8);
        let expected = EnvironmentMap::from_image(&img, 1.0, 0.0, "x").unwrap().radiance(d);
        assert!((map.radiance(d) - expected).length() < 0.02 * expected.length());
    }
}
