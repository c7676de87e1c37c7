//! Looking a direction up in a map and drawing directions from it: the texel and cell a
//! direction meets, its radiance, the density it is sampled with (the stored tables' own)
//! and the sampling itself.

use std::f64::consts::PI;

use glam::DVec3;

use super::EnvironmentMap;
use super::distribution::{SMALL_CELL_ROWS, pseudo_angle, texel_radiance};
use crate::numeric::trig::{sin_cos_small, sin_cos_turns};

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

/// Where a direction meets the map.
pub(super) struct TexelHit {
    /// Pixel index.
    pub(super) index: usize,
    /// Distribution cell column and row.
    pub(super) cell_x: usize,
    pub(super) cell_y: usize,
    /// `sin theta` of the direction.
    pub(super) sin_theta: f64,
}

impl EnvironmentMap {
    /// World direction to map direction (undoing the rotation about +y).
    pub(super) fn to_map(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x - self.rot_sin * d.z, d.y, self.rot_sin * d.x + self.rot_cos * d.z)
    }

    pub(super) fn to_world(&self, d: DVec3) -> DVec3 {
        DVec3::new(self.rot_cos * d.x + self.rot_sin * d.z, d.y, -self.rot_sin * d.x + self.rot_cos * d.z)
    }

    /// Map coordinates (u, v) in [0, 1) of a world direction (need not be normalised), by
    /// the exact inverse trigonometric functions (the reference of [`Self::texel_of`]).
    #[cfg(test)]
    pub(super) fn uv(&self, d: DVec3) -> (f64, f64) {
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
    pub(super) fn pixel_of(&self, u: f64, v: f64) -> usize {
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
    pub(super) fn texel_of(&self, d: DVec3) -> TexelHit {
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
    pub(super) fn cell_density(&self, x: usize, y: usize) -> f64 {
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
