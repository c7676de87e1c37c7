//! The sampling distribution of a map: cells of one pixel, or of f x f pixels on maps taller
//! than [`MAX_DISTRIBUTION_ROWS`] rows, a 16-bit marginal over rows and conditional over each
//! row's cells proportional to `luminance x sin(theta)`, and the bins that start the
//! direction-to-cell searches.

use std::f64::consts::PI;

use glam::DVec3;

use super::load::LOADER_LIMIT;
use super::{Cdf16, EnvError, EnvironmentMap};
use crate::io::LinearImage;
use crate::numeric::trig::sin_cos_turns;

/// Bins per map row of the table that starts the row search (see `texel_of`): at the
/// equator a bin is far narrower than a row; at the poles, where rows crowd together in
/// `cos theta`, a bin spans a few.
const ROW_BINS_PER_ROW: u32 = 16;

/// Bins per map column of the table that starts the column search.
const COL_BINS_PER_COL: u32 = 4;

/// A number in [0, 4) that grows monotonically with the angle `atan2(a, b)` taken in
/// [0, 2 pi): per quadrant, the position along the diamond `|a| + |b| = 1`.
#[inline]
pub(super) fn pseudo_angle(a: f64, b: f64) -> f64 {
    let sum = a.abs() + b.abs();
    if sum == 0.0 {
        return 0.0;
    }
    let r = a / sum;
    // b >= 0: quadrants [0, 1) (a >= 0) and [3, 4) (a < 0); b < 0: [1, 3).
    if b >= 0.0 { if a >= 0.0 { r } else { 4.0 + r } } else { 2.0 - r }
}

/// A direction `(a, b)` whose [`pseudo_angle`] is `p`.
pub(super) fn pseudo_angle_direction(p: f64) -> (f64, f64) {
    match p {
        p if p < 1.0 => (p, 1.0 - p),
        p if p < 3.0 => (2.0 - p, -(1.0 - (2.0 - p).abs())),
        p => (p - 4.0, 1.0 - (4.0 - p)),
    }
}

/// Distributions with at least this many rows have cells small enough (at most pi / 128
/// on a side) for [`sin_cos_small`].
pub(super) const SMALL_CELL_ROWS: usize = 128;

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

pub(super) fn texel_radiance(t: &[f32; 3]) -> DVec3 {
    DVec3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]))
}

impl EnvironmentMap {
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
}
