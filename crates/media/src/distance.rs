//! The view-independent distance map of section 2.3.1: for every voxel, the Euclidean
//! distance (in voxels, between centres) to the nearest voxel whose density exceeds a
//! threshold, computed exactly with separable squared-distance transforms along x, y and z
//! (Felzenszwalb and Huttenlocher 2012's lower envelope of parabolas).
//!
//! The thesis jumps `delta(x)` along the ray. Between voxel centres the density is
//! trilinear, so an empty voxel next to a full one is not empty everywhere: a voxel's tent
//! reaches one voxel along each axis, up to `sqrt(3)` voxels away. [`DistanceMap::skip`]
//! therefore returns the distance that is empty for certain from any point: the map's value
//! at the point's nearest centre less that centre's distance (at most `sqrt(3) / 2`) and the
//! tent's reach, so that skipping never steps over density.

use glam::DVec3;

use crate::grid::DensityGrid;

/// How far a voxel's trilinear tent reaches, in voxels: `sqrt(3)`.
pub const TENT_REACH: f64 = 1.732_050_807_568_877_2;

/// Distances to the nearest non-empty voxel, in voxels.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceMap {
    dims: [usize; 3],
    distance: Vec<f32>,
}

/// Squared distance transform of one line in place (`f` holds 0 or infinity on entry).
fn transform_line(f: &mut [f64], v: &mut [usize], z: &mut [f64], out: &mut [f64]) {
    let n = f.len();
    let mut k = 0usize;
    let mut first = None;
    for (q, value) in f.iter().enumerate() {
        if value.is_finite() {
            first = Some(q);
            break;
        }
    }
    let Some(start) = first else {
        return; // no finite value: the line stays infinite
    };
    v[0] = start;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in start + 1..n {
        if !f[q].is_finite() {
            continue;
        }
        loop {
            let p = v[k];
            let s = ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
            if s <= z[k] && k > 0 {
                k -= 1;
            } else {
                k += 1;
                v[k] = q;
                z[k] = s;
                z[k + 1] = f64::INFINITY;
                break;
            }
        }
    }
    let mut k = 0;
    for (q, o) in out.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
    f.copy_from_slice(&out[..n]);
}

impl DistanceMap {
    /// The map of voxels whose density is above `threshold`. A grid with no such voxel
    /// gets infinite distances everywhere.
    pub fn new(grid: &DensityGrid, threshold: f32) -> Self {
        let dims = grid.dims();
        let [nx, ny, nz] = dims;
        let mut d2: Vec<f64> = grid.data().iter().map(|v| if *v > threshold { 0.0 } else { f64::INFINITY }).collect();
        let longest = nx.max(ny).max(nz);
        let (mut line, mut v, mut z, mut out) =
            (vec![0.0; longest], vec![0usize; longest], vec![0.0; longest + 1], vec![0.0; longest]);
        let index = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        for axis in 0..3 {
            let (n, others) = match axis {
                0 => (nx, [ny, nz]),
                1 => (ny, [nx, nz]),
                _ => (nz, [nx, ny]),
            };
            for a in 0..others[0] {
                for b in 0..others[1] {
                    let at = |q: usize| match axis {
                        0 => index(q, a, b),
                        1 => index(a, q, b),
                        _ => index(a, b, q),
                    };
                    for q in 0..n {
                        line[q] = d2[at(q)];
                    }
                    transform_line(&mut line[..n], &mut v, &mut z, &mut out);
                    for q in 0..n {
                        d2[at(q)] = line[q];
                    }
                }
            }
        }
        Self { dims, distance: d2.iter().map(|d| d.sqrt() as f32).collect() }
    }

    /// Voxels along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The distances, x fastest (the GPU copy uploads these).
    pub fn data(&self) -> &[f32] {
        &self.distance
    }

    /// The distance at voxel `(i, j, k)`.
    pub fn voxel(&self, i: usize, j: usize, k: usize) -> f32 {
        self.distance[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// How far, in voxels, a ray may jump from `p` (unit-cube coordinates, inside the cube)
    /// without passing any non-zero density: zero near the medium.
    pub fn skip(&self, p: DVec3) -> f64 {
        let mut c = [0usize; 3];
        let mut off2 = 0.0;
        for a in 0..3 {
            let g = p[a] * self.dims[a] as f64 - 0.5;
            let i = g.round().clamp(0.0, (self.dims[a] - 1) as f64);
            off2 += (g - i) * (g - i);
            c[a] = i as usize;
        }
        let d = f64::from(self.voxel(c[0], c[1], c[2]));
        (d - off2.sqrt() - TENT_REACH).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn sparse(dims: [usize; 3], fill: f64, seed: u64) -> DensityGrid {
        let mut rng = Pcg64::seed_from_u64(seed);
        let n = dims[0] * dims[1] * dims[2];
        let data = (0..n).map(|_| if rng.random::<f64>() < fill { rng.random::<f32>() + 0.1 } else { 0.0 }).collect();
        DensityGrid::new(dims, data).unwrap()
    }

    #[test]
    fn exact_against_brute_force() {
        for (dims, fill, seed) in
            [([7, 5, 9], 0.02, 1), ([12, 12, 12], 0.005, 2), ([1, 6, 3], 0.2, 3), ([9, 1, 1], 0.15, 4)]
        {
            let g = sparse(dims, fill, seed);
            let m = DistanceMap::new(&g, 0.0);
            let full: Vec<[usize; 3]> = (0..g.data().len())
                .filter(|n| g.data()[*n] > 0.0)
                .map(|n| [n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1])])
                .collect();
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let brute = full
                            .iter()
                            .map(|c| {
                                let d = [i as f64 - c[0] as f64, j as f64 - c[1] as f64, k as f64 - c[2] as f64];
                                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                            })
                            .fold(f64::INFINITY, f64::min);
                        let got = f64::from(m.voxel(i, j, k));
                        assert!(
                            (got - brute).abs() < 1e-5 || (got.is_infinite() && brute.is_infinite()),
                            "{dims:?} ({i},{j},{k}): {got} vs {brute}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn skipping_never_steps_over_density() {
        let g = sparse([16, 16, 16], 0.003, 5);
        let m = DistanceMap::new(&g, 0.0);
        let mut rng = Pcg64::seed_from_u64(6);
        let mut jumped = 0;
        for _ in 0..4000 {
            let p = DVec3::new(rng.random(), rng.random(), rng.random());
            let dir =
                DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5).normalize();
            let s = m.skip(p);
            if s == 0.0 {
                continue; // near the medium: nothing is skipped
            }
            jumped += 1;
            // every point within the skipped stretch has zero density
            for t in 0..=32 {
                let q = p + dir * (s / 16.0) * f64::from(t) / 32.0;
                assert_eq!(g.density(q), 0.0, "density inside a skipped stretch at {q}");
            }
        }
        assert!(jumped > 1000, "the map should allow skipping in a sparse grid ({jumped})");
    }

    #[test]
    fn empty_and_full_grids() {
        let empty = DensityGrid::constant([4, 4, 4], 0.0).unwrap();
        assert!(DistanceMap::new(&empty, 0.0).data().iter().all(|d| d.is_infinite()));
        let full = DensityGrid::constant([4, 4, 4], 1.0).unwrap();
        let m = DistanceMap::new(&full, 0.0);
        assert!(m.data().iter().all(|d| *d == 0.0));
        assert_eq!(m.skip(DVec3::splat(0.5)), 0.0);
    }
}
