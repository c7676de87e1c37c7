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
//! and a conditional one over the cells of each row, both proportional to
//! `luminance x sin(theta)` summed over the cell's pixels. A cell is one pixel of maps up
//! to [`MAX_DISTRIBUTION_ROWS`] rows high and a square of `f x f` pixels (`f` a power of
//! two) of larger ones: the distribution then stays small enough to live in the caches
//! (a full-resolution one of a 1024 x 512 map is 14 MB and every light sample missed the
//! cache), while radiance is still looked up at full resolution. The marginal and the
//! rows are 16-bit fixed-point tables (see `cdf16`), which keeps them in a core's L2
//! cache. The density a sample is given is the one it was drawn with, computed from the stored cumulative tables
//! themselves, so the estimator stays unbiased whatever the cell size and rounding. Every
//! map, including the built-in default and the uniform one of the furnace tests, goes
//! through this same construction.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::DVec3;
use study::scene::{Environment, Lighting};

/// The most radiance (times intensity) a map may hold: the largest f32, which the GPU's
/// tables must represent. Designs are held to `study::scene::MAX_RADIANCE` (2^20 below it)
/// when they are validated, so that sums stay finite; a map file's pixels are known only
/// here, and the renderers keep their sums finite up to this limit (the tracer discards and
/// counts samples that overflow f32, the filters and the analytic kernel rescale).
const LOADER_LIMIT: f64 = f32::MAX as f64;

use crate::io::{LinearImage, decode_exr, decode_hdr};
use crate::numeric::trig::{sin_cos_small, sin_cos_turns};

mod cdf16;
pub(crate) use cdf16::Cdf16;

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

/// A direction sampled from the map. Its radiance is fetched separately
/// ([`EnvironmentMap::sample_radiance`]), only when the sample turns out to be unoccluded.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// Unit world direction towards the environment.
    pub direction: DVec3,
    /// Density over the unit square of map coordinates.
    pub density: f64,
    /// Solid angle per unit area of map coordinates there (`2 pi^2 sin theta`, > 0).
    pub jacobian: f64,
    /// The map pixel the direction falls in.
    texel: usize,
}

impl EnvSample {
    /// Probability density per unit solid angle.
    pub fn pdf(&self) -> f64 {
        self.density / self.jacobian
    }
}

/// A latitude-longitude radiance map placed in the world, ready for look-ups and
/// importance sampling.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    width: u32,
    height: u32,
    /// Per pixel: radiance, already scaled by the lighting's intensity.
    texels: Vec<[f32; 3]>,
    /// log2 of the pixels per side of a distribution cell.
    cell_shift: u32,
    /// Distribution size in cells.
    dist_width: u32,
    dist_height: u32,
    /// World-from-map rotation about +y: cosine and sine.
    rot_cos: f64,
    rot_sin: f64,
    /// The distribution over rows, in 16-bit fixed point.
    marginal: Cdf16,
    /// The rows' conditional distributions, in 16-bit fixed point.
    rows: Cdf16,
    /// Whether any pixel has weight (a black map cannot be sampled).
    samplable: bool,
    /// `cos theta` of the row edges, `height + 1` entries from 1 down to -1.
    row_edge_cos: Vec<f64>,
    /// `(sin phi, cos phi)` of the column edges, `width + 1` entries.
    col_edge: Vec<(f64, f64)>,
    /// The first row of each of `ROW_BINS_PER_ROW x height` equal bins of `1 - cos theta`
    /// over [0, 2].
    row_bins: Vec<u32>,
    /// The first column of each of `COL_BINS_PER_COL x width` equal bins of
    /// [`pseudo_angle`] over [0, 4).
    col_bins: Vec<u32>,
    /// `(sin theta, cos theta)` of the distribution's row edges, `dist_height + 1` entries.
    dist_row_sc: Vec<(f64, f64)>,
    /// `(sin phi, cos phi)` of the distribution's column edges, `dist_width + 1` entries.
    dist_col_sc: Vec<(f64, f64)>,
}

/// A view of a map's tables (see the fields of [`EnvironmentMap`]).
pub(crate) struct EnvTablesRef<'a> {
    pub width: u32,
    pub height: u32,
    pub texels: &'a [[f32; 3]],
    pub cell_shift: u32,
    pub dist_width: u32,
    pub dist_height: u32,
    pub rot_cos: f64,
    pub rot_sin: f64,
    pub marginal: &'a Cdf16,
    pub rows: &'a Cdf16,
    pub samplable: bool,
    pub row_edge_cos: &'a [f64],
    pub col_edge: &'a [(f64, f64)],
    pub row_bins: &'a [u32],
    pub col_bins: &'a [u32],
}

/// Bins per map row of the table that starts the row search (see `texel_of`): at the
/// equator a bin is far narrower than a row; at the poles, where rows crowd together in
/// `cos theta`, a bin spans a few.
const ROW_BINS_PER_ROW: u32 = 16;
/// Bins per map column of the table that starts the column search.
const COL_BINS_PER_COL: u32 = 4;

/// A number in [0, 4) that grows monotonically with the angle `atan2(a, b)` taken in
/// [0, 2 pi): per quadrant, the position along the diamond `|a| + |b| = 1`.
#[inline]
fn pseudo_angle(a: f64, b: f64) -> f64 {
    let sum = a.abs() + b.abs();
    if sum == 0.0 {
        return 0.0;
    }
    let r = a / sum;
    // b >= 0: quadrants [0, 1) (a >= 0) and [3, 4) (a < 0); b < 0: [1, 3).
    if b >= 0.0 { if a >= 0.0 { r } else { 4.0 + r } } else { 2.0 - r }
}

/// A direction `(a, b)` whose [`pseudo_angle`] is `p`.
fn pseudo_angle_direction(p: f64) -> (f64, f64) {
    match p {
        p if p < 1.0 => (p, 1.0 - p),
        p if p < 3.0 => (2.0 - p, -(1.0 - (2.0 - p).abs())),
        p => (p - 4.0, 1.0 - (4.0 - p)),
    }
}

/// Distributions with at least this many rows have cells small enough (at most pi / 128
/// on a side) for [`sin_cos_small`].
const SMALL_CELL_ROWS: usize = 128;

/// Where a direction meets the map.
struct TexelHit {
    /// Pixel index.
    index: usize,
    /// Distribution cell column and row.
    cell_x: usize,
    cell_y: usize,
    /// `sin theta` of the direction.
    sin_theta: f64,
}

/// Rows of the sampling distribution at most (see the module documentation).
pub const MAX_DISTRIBUTION_ROWS: u32 = 256;

/// Pixels per side of a distribution cell of a map `height` pixels high.
fn cell_factor(height: u32) -> u32 {
    let mut f = 1;
    while height / f > MAX_DISTRIBUTION_ROWS && (height / f).is_multiple_of(2) {
        f *= 2;
    }
    f
}

fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl EnvironmentMap {
    /// Builds the map a scene's lighting asks for: loads the file, generates the default,
    /// or builds the uniform map; applies intensity and rotation.
    pub fn from_lighting(lighting: &Lighting) -> Result<EnvironmentMap, EnvError> {
        if !(lighting.intensity.is_finite() && lighting.intensity >= 0.0) {
            return Err(EnvError::Parameter(format!("intensity {:e} must be finite and >= 0", lighting.intensity)));
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
                if radiance.iter().any(|c| !(c.is_finite() && *c >= 0.0 && *c <= LOADER_LIMIT)) {
                    return Err(EnvError::Parameter(format!(
                        "uniform radiance [{:e}, {:e}, {:e}] must be finite, >= 0 and at most {LOADER_LIMIT:e}",
                        radiance[0], radiance[1], radiance[2]
                    )));
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
        let (wu, hu) = (w as usize, h as usize);
        // Weights are normalised by the largest luminance before summing so that huge
        // values (the sun in a real map) cannot overflow the sums.
        let peak = radiance.iter().map(|c| c.max_element()).fold(0.0, f64::max);
        if peak.is_nan() || peak > LOADER_LIMIT {
            return Err(EnvError::Parameter(format!(
                "{name}: radiance times intensity {intensity:e} reaches {peak:e}, above the limit of {LOADER_LIMIT:e} (the largest f32)"
            )));
        }
        let max_lum = radiance.iter().map(|c| luminance(*c)).fold(0.0, f64::max);
        let scale = if max_lum > 0.0 { 1.0 / max_lum } else { 0.0 };
        let f = cell_factor(h);
        let (wd, hd) = ((w / f) as usize, (h / f) as usize);
        let fu = f as usize;
        let mut weights = vec![0.0; wd * hd];
        for y in 0..hu {
            let sin_theta = (PI * (y as f64 + 0.5) / h as f64).sin();
            for x in 0..wu {
                weights[(y / fu) * wd + x / fu] += luminance(radiance[y * wu + x]) * scale * sin_theta;
            }
        }
        let row_sums: Vec<f64> = weights.chunks_exact(wd).map(|r| r.iter().sum()).collect();
        let total: f64 = row_sums.iter().sum();
        let samplable = total > 0.0 && total.is_finite();
        // Cell columns fit 16 bits (a map would need more than 2^17 pixels across to
        // exceed them); 16-bit tables keep the distribution in the caches.
        if wd >= usize::from(u16::MAX) {
            return Err(EnvError::Parameter(format!(
                "{name}: a map {w} pixels wide is too large to sample (at most {} pixels)",
                (u32::from(u16::MAX) - 1) * f
            )));
        }
        let marginal = Cdf16::new(&row_sums, hd);
        let rows = Cdf16::new(&weights, wd);
        let texels = radiance.iter().map(|r| [r.x as f32, r.y as f32, r.z as f32]).collect();
        let row_edge_cos = (0..=h).map(|j| sin_cos_turns(0.5 * f64::from(j) / f64::from(h)).1).collect();
        let col_edge: Vec<(f64, f64)> = (0..=w).map(|j| sin_cos_turns(f64::from(j) / f64::from(w))).collect();
        let row_bins = (0..ROW_BINS_PER_ROW * h)
            .map(|k| {
                let cos = 1.0 - 2.0 * f64::from(k) / f64::from(ROW_BINS_PER_ROW * h);
                ((cos.clamp(-1.0, 1.0).acos() / PI * f64::from(h)) as u32).min(h - 1)
            })
            .collect();
        let col_bins = (0..COL_BINS_PER_COL * w)
            .map(|k| {
                let p = 4.0 * f64::from(k) / f64::from(COL_BINS_PER_COL * w);
                // The direction at pseudo-angle p, and its column.
                let (a, b) = pseudo_angle_direction(p);
                let mut phi = a.atan2(b);
                if phi < 0.0 {
                    phi += 2.0 * PI;
                }
                ((phi / (2.0 * PI) * f64::from(w)) as u32).min(w - 1)
            })
            .collect();
        Ok(EnvironmentMap {
            row_edge_cos,
            col_edge,
            row_bins,
            col_bins,
            dist_row_sc: (0..=hd).map(|j| sin_cos_turns(0.5 * j as f64 / hd as f64)).collect(),
            dist_col_sc: (0..=wd).map(|j| sin_cos_turns(j as f64 / wd as f64)).collect(),
            width: w,
            height: h,
            texels,
            cell_shift: f.trailing_zeros(),
            dist_width: wd as u32,
            dist_height: hd as u32,
            rot_cos: rotation_y.cos(),
            rot_sin: rotation_y.sin(),
            marginal,
            rows,
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

    /// The look-up and sampling tables, for the GPU tracer's f32 copy of them
    /// (`tracer::gpu::params::EnvTables`).
    pub(crate) fn tables(&self) -> EnvTablesRef<'_> {
        EnvTablesRef {
            width: self.width,
            height: self.height,
            texels: &self.texels,
            cell_shift: self.cell_shift,
            dist_width: self.dist_width,
            dist_height: self.dist_height,
            rot_cos: self.rot_cos,
            rot_sin: self.rot_sin,
            marginal: &self.marginal,
            rows: &self.rows,
            samplable: self.samplable,
            row_edge_cos: &self.row_edge_cos,
            col_edge: &self.col_edge,
            row_bins: &self.row_bins,
            col_bins: &self.col_bins,
        }
    }

    /// World direction to map direction (undoing the rotation about +y).
    fn to_map(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x - self.rot_sin * d.z, d.y, self.rot_sin * d.x + self.rot_cos * d.z)
    }

    fn to_world(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x + self.rot_sin * d.z, d.y, -self.rot_sin * d.x + self.rot_cos * d.z)
    }

    /// Map coordinates (u, v) in [0, 1) of a world direction (need not be normalised), by
    /// the exact inverse trigonometric functions (the reference of [`Self::texel_of`]).
    #[cfg(test)]
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

    #[cfg(test)]
    fn pixel_of(&self, u: f64, v: f64) -> usize {
        let x = ((u * self.width as f64) as usize).min(self.width as usize - 1);
        let y = ((v * self.height as f64) as usize).min(self.height as usize - 1);
        y * self.width as usize + x
    }

    /// The texel a finite, non-zero world direction falls in, and the direction's
    /// `sin theta`. Tables indexed by `1 - cos theta` and by a pseudo-angle (monotonic in
    /// `phi`, one division, no trigonometry) give the row and column to within a few
    /// texels; comparisons with the texel edges then settle the exact one, so the result
    /// equals the exact look-up except on the edges themselves.
    #[inline]
    fn texel_of(&self, d: DVec3) -> TexelHit {
        let m = self.to_map(d);
        let inv_len = 1.0 / m.length();
        let cos_theta = (m.y * inv_len).clamp(-1.0, 1.0);
        let sin_theta = (m.x * m.x + m.z * m.z).sqrt() * inv_len;
        let (w, h) = (self.width as usize, self.height as usize);
        let edges = &self.row_edge_cos;
        let bins = self.row_bins.len();
        let k = (((1.0 - cos_theta) * (0.5 * bins as f64)) as usize).min(bins - 1);
        let mut y = self.row_bins[k] as usize;
        while y + 1 < h && cos_theta <= edges[y + 1] {
            y += 1;
        }
        while y > 0 && cos_theta > edges[y] {
            y -= 1;
        }
        // phi = atan2(m.x, -m.z); the point lies after column edge j when
        // sin(phi - phi_j) = m.x cos phi_j + m.z sin phi_j >= 0.
        let bins = self.col_bins.len();
        let k = ((pseudo_angle(m.x, -m.z) * (0.25 * bins as f64)) as usize).min(bins - 1);
        let mut x = self.col_bins[k] as usize;
        let after = |j: usize| {
            let (s, c) = self.col_edge[j];
            m.x * c + m.z * s >= 0.0
        };
        for _ in 0..4 {
            if !after(x) {
                x = if x == 0 { w - 1 } else { x - 1 };
            } else if after(x + 1) {
                x = if x + 1 == w { 0 } else { x + 1 };
            } else {
                break;
            }
        }
        let shift = self.cell_shift;
        TexelHit { index: y * w + x, cell_x: x >> shift, cell_y: y >> shift, sin_theta }
    }

    /// Radiance arriving from world direction `d` (need not be normalised; a zero or
    /// non-finite direction gives black).
    pub fn radiance(&self, d: DVec3) -> DVec3 {
        if !d.is_finite() || d == DVec3::ZERO {
            return DVec3::ZERO;
        }
        texel_radiance(&self.texels[self.texel_of(d).index])
    }

    /// Radiance arriving from the direction of a sample drawn from this map.
    #[inline]
    pub fn sample_radiance(&self, sample: &EnvSample) -> DVec3 {
        texel_radiance(&self.texels[sample.texel])
    }

    /// Density per unit solid angle with which [`EnvironmentMap::sample`] picks world
    /// direction `d`.
    pub fn pdf(&self, d: DVec3) -> f64 {
        self.radiance_and_pdf(d).1
    }

    /// Radiance, density over map coordinates and `2 pi^2 sin theta` of a direction in one
    /// look-up (so a caller can form ratios of densities without dividing twice); the
    /// density is 0 where the map is black or at the poles.
    #[inline]
    pub fn radiance_and_density(&self, d: DVec3) -> (DVec3, f64, f64) {
        if !d.is_finite() || d == DVec3::ZERO {
            return (DVec3::ZERO, 0.0, 0.0);
        }
        let hit = self.texel_of(d);
        let density = if hit.sin_theta > 0.0 { self.cell_density(hit.cell_x, hit.cell_y) } else { 0.0 };
        (texel_radiance(&self.texels[hit.index]), density, 2.0 * PI * PI * hit.sin_theta)
    }

    /// Radiance and sampling density of a direction in one look-up.
    pub fn radiance_and_pdf(&self, d: DVec3) -> (DVec3, f64) {
        let (radiance, density, jacobian) = self.radiance_and_density(d);
        (radiance, if density > 0.0 { density / jacobian } else { 0.0 })
    }

    /// The density over the unit square of map coordinates with which [`Self::sample`]
    /// draws cell `(x, y)`: computed from the cumulative tables as stored, so it is the
    /// density samples are actually drawn with, whatever their rounding.
    #[inline]
    fn cell_density(&self, x: usize, y: usize) -> f64 {
        if !self.samplable {
            return 0.0;
        }
        let (wd, hd) = (self.dist_width as usize, self.dist_height as usize);
        let p_row = self.marginal.probability(0, y);
        p_row * self.rows.probability(y, x) * (wd * hd) as f64
    }

    /// Picks a direction with density proportional to luminance x sin(theta) per pixel,
    /// from two uniform numbers in [0, 1). `None` for a black map or a degenerate draw at
    /// a pole.
    pub fn sample(&self, u: [f64; 2]) -> Option<EnvSample> {
        if !self.samplable {
            return None;
        }
        let (wd, hd) = (self.dist_width as usize, self.dist_height as usize);
        let (y, fy, p_y) = self.marginal.sample(0, u[0]);
        let (x, fx, p_x) = self.rows.sample(y, u[1]);
        let density = p_y * p_x * (wd * hd) as f64;
        if density <= 0.0 {
            return None;
        }
        let ((sin_theta, cos_theta), (sin_phi, cos_phi)) = if hd >= SMALL_CELL_ROWS {
            // theta = theta_y + d_theta with the cell edge's sine and cosine tabulated and
            // the small offset's by a short series.
            let add = |(s0, c0): (f64, f64), (sd, cd): (f64, f64)| (s0 * cd + c0 * sd, c0 * cd - s0 * sd);
            (
                add(self.dist_row_sc[y], sin_cos_small(fy * (PI / hd as f64))),
                add(self.dist_col_sc[x], sin_cos_small(fx * (2.0 * PI / wd as f64))),
            )
        } else {
            (sin_cos_turns(0.5 * (y as f64 + fy) / hd as f64), sin_cos_turns((x as f64 + fx) / wd as f64))
        };
        if sin_theta <= 0.0 {
            return None;
        }
        // The pixel inside the cell.
        let f = 1usize << self.cell_shift;
        let px = (((x as f64 + fx) * f as f64) as usize).clamp(x * f, x * f + f - 1);
        let py = (((y as f64 + fy) * f as f64) as usize).clamp(y * f, y * f + f - 1);
        let m = DVec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta);
        Some(EnvSample {
            direction: self.to_world(m),
            density,
            jacobian: 2.0 * PI * PI * sin_theta,
            texel: py * self.width as usize + px,
        })
    }
}

fn texel_radiance(t: &[f32; 3]) -> DVec3 {
    DVec3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]))
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

    /// A seeded stream of uniform numbers in [0, 1).
    fn uniforms(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = study::seed::splitmix64(state);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
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
        let mut next = uniforms(0x1234_5678_u64);
        for _ in 0..n {
            let s = map.sample([next(), next()]).unwrap();
            assert!(s.pdf().is_finite() && s.pdf() > 0.0 && s.direction.is_finite());
            assert!((s.pdf() - map.pdf(s.direction)).abs() <= 1e-6 * s.pdf());
            let (u, v) = map.uv(s.direction);
            counts[map.pixel_of(u, v)] += 1.0;
        }
        let mut chi2 = 0.0;
        let mut dof = 0;
        for (i, &c) in counts.iter().enumerate() {
            let expected = map.cell_density(i % w, i / w) / (w * h) as f64 * n as f64;
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
                assert!(s.pdf().is_finite() && map.sample_radiance(&s).is_finite());
            }
        }
        for u in [0.0, 1.0 - f64::EPSILON, 0.5] {
            for v in [0.0, 1.0 - f64::EPSILON] {
                if let Some(s) = map.sample([u, v]) {
                    assert!(s.pdf().is_finite() && s.direction.is_finite());
                }
            }
        }
        assert_eq!(map.pdf(DVec3::Y), 0.0);
        assert!(map.radiance(DVec3::ZERO) == DVec3::ZERO);
    }

    #[test]
    fn large_maps_are_sampled_through_cells_with_the_density_they_report() {
        let mut img = default_map(1024);
        img.set(700, 300, [5.0e4, 5.0e4, 5.0e4]);
        let map = EnvironmentMap::from_image(&img, 1.0, 0.4, "big").unwrap();
        assert_eq!((map.cell_shift, map.dist_width, map.dist_height), (1, 512, 256));
        let total = integrate_sphere(|d| map.pdf(d), 1024);
        assert!((total - 1.0).abs() < 2e-3, "integral {total}");
        let (wd, hd) = (512usize, 256usize);
        let n = 2_000_000;
        let mut counts = vec![0.0; wd * hd];
        let mut next = uniforms(0xfeed_u64);
        let mut radiance_mismatches = 0;
        for _ in 0..n {
            let s = map.sample([next(), next()]).unwrap();
            assert!((s.pdf() - map.pdf(s.direction)).abs() <= 1e-6 * s.pdf());
            if map.sample_radiance(&s) != map.radiance(s.direction) {
                radiance_mismatches += 1;
            }
            let hit = map.texel_of(s.direction);
            counts[hit.cell_y * wd + hit.cell_x] += 1.0;
        }
        // Only directions on a pixel's edge may round to the neighbour.
        assert!(radiance_mismatches < n / 10_000, "{radiance_mismatches} mismatches");
        let (mut chi2, mut dof) = (0.0, 0);
        for (i, &c) in counts.iter().enumerate() {
            let expected = map.cell_density(i % wd, i / wd) / (wd * hd) as f64 * n as f64;
            if expected > 20.0 {
                chi2 += (c - expected) * (c - expected) / expected;
                dof += 1;
            }
        }
        assert!(dof > 1000 && chi2 < dof as f64 + 5.0 * (2.0 * dof as f64).sqrt(), "chi2 {chi2} dof {dof}");
    }

    #[test]
    fn pseudo_angle_is_monotonic_in_phi_and_inverted_by_its_direction() {
        let mut last = -1.0;
        for k in 0..100_000 {
            let phi = 2.0 * PI * k as f64 / 100_000.0;
            let p = pseudo_angle(phi.sin(), phi.cos());
            assert!((0.0..4.0).contains(&p) && p >= last, "phi {phi}: {p} after {last}");
            last = p;
            let (a, b) = pseudo_angle_direction(p);
            assert!((pseudo_angle(a, b) - p).abs() < 1e-12, "p {p}");
            assert!((a.atan2(b).rem_euclid(2.0 * PI) - phi).abs() < 1e-9 || k == 0);
        }
    }

    #[test]
    fn fast_texel_lookup_equals_the_exact_one() {
        for (w, rot) in [(1024u32, 0.0), (64, 0.7), (8, -2.0)] {
            let map = EnvironmentMap::from_image(&default_map(w), 1.0, rot, "t").unwrap();
            let mut uniform = uniforms(7_u64);
            let mut next = || uniform() * 2.0 - 1.0;
            for i in 0..100_000 {
                // Random directions, and some near the poles and the phi = 0 seam.
                let mut d = DVec3::new(next(), next(), next());
                if i % 10 == 0 {
                    d.x *= 1e-6;
                    d.z *= 1e-6;
                } else if i % 10 == 1 {
                    d.x *= 1e-7;
                    d.z = -d.z.abs();
                }
                if d == DVec3::ZERO {
                    continue;
                }
                let (u, v) = map.uv(d);
                assert_eq!(map.texel_of(d).index, map.pixel_of(u, v), "map {w}: direction {d}");
            }
        }
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
        assert_eq!((&loaded.marginal, &loaded.rows), (&direct.marginal, &direct.rows));
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

    #[test]
    fn radiance_above_the_design_limit_is_refused_in_short_numbers() {
        let peak = default_map(1024).pixels.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
        let bound = study::scene::DEFAULT_MAP_PEAK_RADIANCE;
        assert!(f64::from(peak) <= bound && f64::from(peak) > 0.9 * bound, "{peak}");
        for (environment, intensity, needle) in [
            (Environment::Default { width: 64 }, 3e36, "radiance times intensity 3e36 reaches"),
            (Environment::Default { width: 64 }, 1e300, "above the limit of 3.4"),
            (Environment::Uniform { radiance: [1.0, 1e300, 1.0] }, 1.0, "uniform radiance [1e0, 1e300, 1e0]"),
        ] {
            let e = EnvironmentMap::from_lighting(&Lighting { environment, intensity, rotation_y: 0.0 })
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains(needle) && e.len() < 300, "{e}");
        }
        let edge = study::scene::MAX_RADIANCE / bound;
        assert!(
            EnvironmentMap::from_lighting(&Lighting {
                intensity: edge,
                ..lighting(Environment::Default { width: 64 })
            })
            .is_ok()
        );
    }
}
