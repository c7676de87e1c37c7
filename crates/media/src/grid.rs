//! A density grid: `nx x ny x nz` voxels of non-negative density over the unit cube,
//! x fastest. Voxel `(i, j, k)` is centred at `((i + 0.5) / nx, (j + 0.5) / ny,
//! (k + 0.5) / nz)` and the density between centres is trilinear, clamped to the outermost
//! centres at the faces (Mitsuba 3's `gridvolume` convention, so the reference peer reads
//! the same field); outside the cube the density is zero.

use glam::DVec3;

/// Errors of building a grid; the file reader adds the file and byte offset.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GridError {
    /// A dimension is zero or the voxel count overflows.
    #[error("grid dimensions {nx}x{ny}x{nz}: expected each between 1 and {max}")]
    Dimensions {
        /// Voxels along x.
        nx: usize,
        /// Voxels along y.
        ny: usize,
        /// Voxels along z.
        nz: usize,
        /// The largest dimension accepted.
        max: usize,
    },
    /// The data length does not match the dimensions.
    #[error("grid of {nx}x{ny}x{nz} voxels needs {expected} values, found {found}")]
    Length {
        /// Voxels along x.
        nx: usize,
        /// Voxels along y.
        ny: usize,
        /// Voxels along z.
        nz: usize,
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// A sequence without a grid.
    #[error("a grid sequence needs at least one grid")]
    EmptySequence,
    /// Two grids of one sequence differ in size.
    #[error("grids of {a:?} and {b:?} voxels cannot be interpolated: a sequence keeps one size")]
    Mismatch {
        /// The first grid's dimensions.
        a: [usize; 3],
        /// The second grid's dimensions.
        b: [usize; 3],
    },
    /// A voxel holds NaN, an infinity or a negative density.
    #[error("voxel ({i}, {j}, {k}) (index {index}) holds {value}: expected a finite density >= 0")]
    Value {
        /// x index.
        i: usize,
        /// y index.
        j: usize,
        /// z index.
        k: usize,
        /// Linear index, x fastest.
        index: usize,
        /// The value found.
        value: f32,
    },
}

/// The largest dimension a grid may have along one axis.
pub const MAX_DIMENSION: usize = 4096;

/// A validated density grid.
#[derive(Debug, Clone, PartialEq)]
pub struct DensityGrid {
    dims: [usize; 3],
    data: Vec<f32>,
    // the majorant of every tracking step: kept rather than found by a scan per ray
    max: f32,
}

impl DensityGrid {
    /// Builds a grid from `nx * ny * nz` values, x fastest; refuses a wrong length and the
    /// first voxel that is NaN, infinite or negative, by its index.
    pub fn new(dims: [usize; 3], data: Vec<f32>) -> Result<Self, GridError> {
        let [nx, ny, nz] = dims;
        let expected = voxel_count(dims)?;
        if data.len() != expected {
            return Err(GridError::Length { nx, ny, nz, expected, found: data.len() });
        }
        if let Some(index) = data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(value_error(dims, index, data[index]));
        }
        Ok(Self::from_valid(dims, data))
    }

    /// A grid from values the caller has made finite and >= 0, of validated dimensions.
    pub(crate) fn from_valid(dims: [usize; 3], data: Vec<f32>) -> Self {
        debug_assert!(data.len() == dims[0] * dims[1] * dims[2] && data.iter().all(|v| v.is_finite() && *v >= 0.0));
        let max = data.iter().copied().fold(0.0, f32::max);
        Self { dims, data, max }
    }

    /// A grid of one constant density.
    pub fn constant(dims: [usize; 3], density: f32) -> Result<Self, GridError> {
        let n = voxel_count(dims)?;
        Self::new(dims, vec![density; n])
    }

    /// Voxels along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The values, x fastest.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The value of voxel `(i, j, k)`.
    pub fn voxel(&self, i: usize, j: usize, k: usize) -> f32 {
        self.data[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// The largest density.
    pub fn max_density(&self) -> f32 {
        self.max
    }

    /// Whether every voxel is zero.
    pub fn is_empty(&self) -> bool {
        self.data.iter().all(|v| *v == 0.0)
    }

    /// The trilinear density at `p` in the unit cube's coordinates; zero outside the cube.
    pub fn density(&self, p: DVec3) -> f64 {
        if !(0.0..=1.0).contains(&p.x) || !(0.0..=1.0).contains(&p.y) || !(0.0..=1.0).contains(&p.z) {
            return 0.0;
        }
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        let mut t = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let g = (p[a] * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
            let f = g.floor();
            lo[a] = f as usize;
            hi[a] = (lo[a] + 1).min(n - 1);
            t[a] = g - f;
        }
        let v = |i: usize, j: usize, k: usize| f64::from(self.voxel(i, j, k));
        let x00 = v(lo[0], lo[1], lo[2]) * (1.0 - t[0]) + v(hi[0], lo[1], lo[2]) * t[0];
        let x10 = v(lo[0], hi[1], lo[2]) * (1.0 - t[0]) + v(hi[0], hi[1], lo[2]) * t[0];
        let x01 = v(lo[0], lo[1], hi[2]) * (1.0 - t[0]) + v(hi[0], lo[1], hi[2]) * t[0];
        let x11 = v(lo[0], hi[1], hi[2]) * (1.0 - t[0]) + v(hi[0], hi[1], hi[2]) * t[0];
        let y0 = x00 * (1.0 - t[1]) + x10 * t[1];
        let y1 = x01 * (1.0 - t[1]) + x11 * t[1];
        y0 * (1.0 - t[2]) + y1 * t[2]
    }

    /// The density between two grids of a sequence: `(1 - t) a + t b`, for a time between
    /// two frames (both grids must have the same dimensions).
    pub fn lerp(a: &Self, b: &Self, t: f32) -> Result<Self, GridError> {
        if a.dims != b.dims {
            return Err(GridError::Mismatch { a: a.dims, b: b.dims });
        }
        let data = a.data.iter().zip(&b.data).map(|(x, y)| (1.0 - t) * x + t * y).collect();
        Self::new(a.dims, data)
    }
}

impl DensityGrid {
    /// The grid resampled to `dims` voxels by its own trilinear lookup at the new centres
    /// (a finer or coarser copy of the same field, e.g. a data set's shape from a simulation).
    pub fn resample(&self, dims: [usize; 3]) -> Result<Self, GridError> {
        let n = voxel_count(dims)?;
        let data = (0..n)
            .map(|v| {
                let (i, j, k) = (v % dims[0], (v / dims[0]) % dims[1], v / (dims[0] * dims[1]));
                let p = DVec3::new(
                    (i as f64 + 0.5) / dims[0] as f64,
                    (j as f64 + 0.5) / dims[1] as f64,
                    (k as f64 + 0.5) / dims[2] as f64,
                );
                self.density(p) as f32
            })
            .collect();
        Ok(Self::from_valid(dims, data))
    }
}

pub(crate) fn voxel_count(dims: [usize; 3]) -> Result<usize, GridError> {
    let [nx, ny, nz] = dims;
    if dims.iter().any(|d| *d == 0 || *d > MAX_DIMENSION) {
        return Err(GridError::Dimensions { nx, ny, nz, max: MAX_DIMENSION });
    }
    Ok(nx * ny * nz)
}

pub(crate) fn value_error(dims: [usize; 3], index: usize, value: f32) -> GridError {
    let i = index % dims[0];
    let j = (index / dims[0]) % dims[1];
    let k = index / (dims[0] * dims[1]);
    GridError::Value { i, j, k, index, value }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> DensityGrid {
        // density = 2 i + 3 j + 5 k at voxel centres: linear, so trilinear reproduces it
        let dims = [4, 3, 5];
        let data = (0..60)
            .map(|n| {
                let (i, j, k) = (n % 4, (n / 4) % 3, n / 12);
                (2 * i + 3 * j + 5 * k) as f32
            })
            .collect();
        DensityGrid::new(dims, data).unwrap()
    }

    #[test]
    fn trilinear_reproduces_a_linear_field_between_centres() {
        let g = ramp();
        for (x, y, z) in [(0.3, 0.5, 0.5), (0.77, 0.2, 0.41), (0.5, 0.5, 0.82)] {
            let (gi, gj, gk) = (x * 4.0 - 0.5, y * 3.0 - 0.5, z * 5.0 - 0.5);
            let expected = 2.0 * gi + 3.0 * gj + 5.0 * gk;
            let got = g.density(DVec3::new(x, y, z));
            assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
        }
    }

    #[test]
    fn voxel_centres_return_their_values_and_outside_is_empty() {
        let g = ramp();
        let c = DVec3::new(2.5 / 4.0, 1.5 / 3.0, 3.5 / 5.0);
        assert_eq!(g.density(c), f64::from(g.voxel(2, 1, 3)));
        assert_eq!(g.density(DVec3::new(1.01, 0.5, 0.5)), 0.0);
        assert_eq!(g.density(DVec3::new(0.5, -0.01, 0.5)), 0.0);
        // clamped between the face and the outermost centre
        assert_eq!(g.density(DVec3::new(0.01, 1.5 / 3.0, 0.5 / 5.0)), f64::from(g.voxel(0, 1, 0)));
    }

    #[test]
    fn one_voxel_grid_is_constant_inside() {
        let g = DensityGrid::constant([1, 1, 1], 0.7).unwrap();
        for p in [DVec3::splat(0.0), DVec3::splat(0.5), DVec3::new(1.0, 0.2, 0.9)] {
            assert!((g.density(p) - 0.7f32 as f64).abs() < 1e-15);
        }
    }

    #[test]
    fn bad_values_are_refused_by_voxel() {
        let mut data = vec![0.0f32; 24];
        data[10] = f32::NAN; // voxel (0, 2, 1): 0 + 2 (2 + 3 x 1)
        let e = DensityGrid::new([2, 3, 4], data).unwrap_err();
        assert!(matches!(e, GridError::Value { i: 0, j: 2, k: 1, index: 10, .. }), "{e}");
        assert!(e.to_string().contains("(0, 2, 1)"));
        let e = DensityGrid::new([2, 3, 4], vec![-1.0; 24]).unwrap_err();
        assert!(matches!(e, GridError::Value { index: 0, .. }));
        assert!(matches!(DensityGrid::new([2, 3, 4], vec![0.0; 23]), Err(GridError::Length { .. })));
        assert!(matches!(DensityGrid::constant([0, 3, 4], 1.0), Err(GridError::Dimensions { .. })));
    }

    #[test]
    fn resampling_keeps_a_linear_field_inside() {
        let g = ramp();
        let fine = g.resample([8, 6, 10]).unwrap();
        // away from the clamped border both are the same linear function
        for p in [DVec3::new(0.4, 0.5, 0.5), DVec3::new(0.6, 0.45, 0.62)] {
            assert!((fine.density(p) - g.density(p)).abs() < 1e-5, "{p}");
        }
        assert_eq!(g.resample(g.dims()).unwrap(), g);
    }

    #[test]
    fn lerp_is_between_frames() {
        let a = DensityGrid::constant([2, 2, 2], 1.0).unwrap();
        let b = DensityGrid::constant([2, 2, 2], 3.0).unwrap();
        let m = DensityGrid::lerp(&a, &b, 0.25).unwrap();
        assert!(m.data().iter().all(|v| *v == 1.5));
        let c = DensityGrid::constant([2, 2, 3], 3.0).unwrap();
        assert!(matches!(DensityGrid::lerp(&a, &c, 0.5), Err(GridError::Mismatch { .. })));
    }
}
