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

use std::path::PathBuf;

mod cdf16;
mod constellation;
mod distribution;
mod load;
mod procedural;
mod sample;

pub(crate) use cdf16::Cdf16;
pub use distribution::MAX_DISTRIBUTION_ROWS;
pub use procedural::default_map;
pub use sample::EnvSample;

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

impl EnvironmentMap {
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
    /// (`shading::gpu::params::EnvTables`).
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
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use glam::DVec3;
    use study::scene::{Environment, Lighting};

    use super::distribution::{pseudo_angle, pseudo_angle_direction};
    use super::*;
    use crate::io::LinearImage;

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
