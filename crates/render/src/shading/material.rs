//! Surface reflectance: the floor's constant albedo and the sphere's three materials (flat
//! colour, checker, band-limited noise), evaluated in the sphere's own frame.
//!
//! The noise is a sum of octaves of gradient noise. Each octave is faded out as its
//! frequency approaches the Nyquist limit of the footprint a sample represents (the
//! pixel's footprint on the sphere for camera rays, a wide cone after a diffuse bounce),
//! and replaced by its mean: detail the pixel grid cannot represent is removed before
//! sampling, so 4 samples per pixel show noise only from sampling, not from aliasing.
//! The checker keeps its abrupt edges on purpose (the study's M2).

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use study::scene::Material;
use study::seed::splitmix64;

use crate::numeric::trig::floor;

/// A material prepared for fast evaluation.
#[derive(Clone, Debug)]
pub enum Shader {
    /// Constant albedo; no texture is evaluated.
    Flat(DVec3),
    /// Checker over longitude and latitude.
    Checker {
        /// First colour.
        a: DVec3,
        /// Second colour.
        b: DVec3,
        /// Squares around the equator.
        around: f64,
        /// Squares from pole to pole.
        pole_to_pole: f64,
    },
    /// Band-limited noise.
    Noise {
        /// Colour at the lowest noise value.
        a: DVec3,
        /// Colour at the highest noise value.
        b: DVec3,
        /// First octave frequency, cycles per radius.
        base_frequency: f64,
        /// Octave count.
        octaves: u32,
        /// Lattice seed.
        seed: u32,
    },
}

fn v3(c: [f64; 3]) -> DVec3 {
    DVec3::new(c[0], c[1], c[2])
}

/// Contrast of the noise: the octave sum (normalised by the total amplitude) is scaled by
/// this before mapping to [0, 1].
pub(crate) const NOISE_GAIN: f64 = 2.2;

impl Shader {
    /// Prepares a scene material.
    pub fn new(material: &Material) -> Self {
        match material {
            Material::Flat { albedo } => Shader::Flat(v3(*albedo)),
            Material::Checker { albedo_a, albedo_b, squares_around, squares_pole_to_pole } => Shader::Checker {
                a: v3(*albedo_a),
                b: v3(*albedo_b),
                around: f64::from(*squares_around),
                pole_to_pole: f64::from(*squares_pole_to_pole),
            },
            Material::Noise { albedo_a, albedo_b, base_frequency, octaves, seed } => Shader::Noise {
                a: v3(*albedo_a),
                b: v3(*albedo_b),
                base_frequency: *base_frequency,
                octaves: *octaves,
                seed: splitmix64(*seed) as u32,
            },
        }
    }

    /// Whether evaluating the albedo needs the point in the sphere's frame.
    pub fn is_textured(&self) -> bool {
        !matches!(self, Shader::Flat(_))
    }

    /// Albedo at `local`, a point of the unit sphere in the sphere's own frame;
    /// `footprint` is the width (in sphere radii) of the surface patch the sample stands
    /// for.
    pub fn albedo(&self, local: DVec3, footprint: f64) -> DVec3 {
        match self {
            Shader::Flat(c) => *c,
            Shader::Checker { a, b, around, pole_to_pole } => {
                let lon = local.z.atan2(local.x); // [-pi, pi]
                let lat = local.y.clamp(-1.0, 1.0).asin(); // [-pi/2, pi/2]
                let u = (lon / (2.0 * PI) + 0.5) * around;
                let v = (lat / PI + 0.5) * pole_to_pole;
                if (floor(u) as i64 + floor(v) as i64).rem_euclid(2) == 0 { *a } else { *b }
            }
            Shader::Noise { a, b, base_frequency, octaves, seed } => {
                let n = filtered_noise(local, *base_frequency, *octaves, *seed, footprint);
                let s = (0.5 + NOISE_GAIN * n).clamp(0.0, 1.0);
                a.lerp(*b, s)
            }
        }
    }
}

#[inline]
pub(crate) fn lattice_hash(x: i64, y: i64, z: i64, seed: u32) -> u64 {
    splitmix64(
        (x as u64).wrapping_mul(0x8da6_b343)
            ^ (y as u64).wrapping_mul(0xd816_3841)
            ^ (z as u64).wrapping_mul(0xcb1a_b31f)
            ^ u64::from(seed) << 32,
    )
}

/// The dot product of `d = (x, y, z)` with gradient `h % 12`, one of the 12 edge directions
/// of a cube (Perlin's improved noise); generic so the GPU tracer's f32 twin shares it.
#[inline]
pub(crate) fn grad_dot<T>(h: u64, [x, y, z]: [T; 3]) -> T
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Neg<Output = T>,
{
    match h % 12 {
        0 => x + y,
        1 => -x + y,
        2 => x - y,
        3 => -x - y,
        4 => x + z,
        5 => -x + z,
        6 => x - z,
        7 => -x - z,
        8 => y + z,
        9 => -y + z,
        10 => y - z,
        _ => -y - z,
    }
}

/// One body for both widths: the f64 reference and the GPU kernels' f32 twin
/// (`shading::gpu::radiance`, mirrored by `radiance.wgsl`, which keeps the lattice in i32
/// and emulates the 64-bit hash with pairs of u32) run these same operations.
macro_rules! noise_impl {
    ($t:ty, $v:ty, $int:ty, $floor:path, $weight:ident, $noise:ident, $filtered:ident) => {
        /// Weight of an octave of `frequency` (cycles per unit) seen through `footprint`
        /// (units): 1 well below the Nyquist limit, fading to 0 at half a cycle per footprint.
        pub fn $weight(frequency: $t, footprint: $t) -> $t {
            let smoothstep = |e0: $t, e1: $t, x: $t| {
                let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            };
            1.0 - smoothstep(0.25, 0.5, frequency * footprint)
        }

        /// Sum of octaves of gradient noise, normalised by the total amplitude, with octaves
        /// the footprint cannot resolve faded to their mean (zero).
        pub fn $filtered(p: $v, base_frequency: $t, octaves: u32, seed: u32, footprint: $t) -> $t {
            let mut sum = 0.0;
            let mut norm = 0.0;
            let mut freq = base_frequency;
            let mut amp = 1.0;
            for k in 0..octaves {
                norm += amp;
                let w = $weight(freq, footprint);
                if w > 0.0 {
                    sum += amp * w * $noise(p * freq, seed.wrapping_add(k.wrapping_mul(0x9e37_79b9)));
                }
                freq *= 2.0;
                amp *= 0.5;
            }
            if norm > 0.0 { sum / norm } else { 0.0 }
        }

        /// 3D gradient noise of one octave, zero at lattice points, about [-1, 1].
        pub fn $noise(p: $v, seed: u32) -> $t {
            let fade = |t: $t| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
            let cell = <$v>::new($floor(p.x), $floor(p.y), $floor(p.z));
            let f = p - cell;
            let (ix, iy, iz) = (cell.x as $int, cell.y as $int, cell.z as $int);
            let (u, v, w) = (fade(f.x), fade(f.y), fade(f.z));
            let corner = |dx: $int, dy: $int, dz: $int| {
                let h = lattice_hash(i64::from(ix + dx), i64::from(iy + dy), i64::from(iz + dz), seed);
                grad_dot(h, (f - <$v>::new(dx as $t, dy as $t, dz as $t)).to_array())
            };
            let lerp = |a: $t, b: $t, t: $t| a + (b - a) * t;
            let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), u);
            let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), u);
            let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), u);
            let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), u);
            lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
        }
    };
}

noise_impl!(f64, DVec3, i64, floor, octave_weight, gradient_noise, filtered_noise);
noise_impl!(f32, Vec3, i32, f32::floor, octave_weight_f32, gradient_noise_f32, filtered_noise_f32);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_widths_of_the_noise_agree_to_f32_rounding() {
        // Away from lattice planes, where the f32 cell can differ from the f64 one.
        for i in 0..2000 {
            let t = f64::from(i);
            let p = DVec3::new((t * 0.377).sin() * 0.9, (t * 0.211).cos() * 0.9, (t * 0.123).sin() * 0.5);
            let footprint = 0.002 + 0.02 * (t * 0.05).sin().abs();
            let wide = filtered_noise(p, 4.0, 5, 7, footprint);
            let narrow = filtered_noise_f32(p.as_vec3(), 4.0, 5, 7, footprint as f32);
            assert!((wide - f64::from(narrow)).abs() < 2e-5, "{p}: {wide} {narrow}");
        }
    }

    #[test]
    fn checker_alternates_and_flat_ignores_position() {
        let m = Shader::new(&Material::Checker {
            albedo_a: [1.0; 3],
            albedo_b: [0.0; 3],
            squares_around: 8,
            squares_pole_to_pole: 4,
        });
        let at = |lon: f64, lat: f64| DVec3::new(lat.cos() * lon.cos(), lat.sin(), lat.cos() * lon.sin());
        let step = 2.0 * PI / 8.0;
        let c0 = m.albedo(at(0.1, 0.1), 0.0);
        let c1 = m.albedo(at(0.1 + step, 0.1), 0.0);
        let c2 = m.albedo(at(0.1, 0.1 + PI / 4.0), 0.0);
        assert_ne!(c0, c1);
        assert_ne!(c0, c2);
        assert_eq!(c0, m.albedo(at(0.1 + 2.0 * step, 0.1), 0.0));
        let flat = Shader::new(&Material::Flat { albedo: [0.3, 0.4, 0.5] });
        assert!(!flat.is_textured());
        assert_eq!(flat.albedo(DVec3::X, 1.0), DVec3::new(0.3, 0.4, 0.5));
    }

    #[test]
    fn filtering_removes_only_unresolvable_octaves() {
        // Variance of the noise along a line, with a fine and a coarse footprint: the
        // coarse footprint keeps only low octaves (lower variance, smoother), and a
        // footprint wider than the first octave's Nyquist limit gives the mean.
        let sample = |fp: f64| -> (f64, f64) {
            let vals: Vec<f64> =
                (0..4000).map(|i| filtered_noise(DVec3::new(i as f64 * 0.0037, 0.31, 0.77), 4.0, 5, 7, fp)).collect();
            let mean = vals.iter().sum::<f64>() / vals.len() as f64;
            let var = vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / vals.len() as f64;
            let rough = vals.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (vals.len() - 1) as f64;
            (var, rough)
        };
        let (v_fine, r_fine) = sample(0.0);
        let (v_coarse, r_coarse) = sample(1.0 / 16.0);
        assert!(
            v_fine > 0.005 && v_coarse < v_fine && r_coarse < 0.5 * r_fine,
            "{v_fine} {v_coarse} {r_fine} {r_coarse}"
        );
        assert_eq!(filtered_noise(DVec3::new(0.3, 0.2, 0.1), 4.0, 5, 7, 0.2), 0.0);
        assert_eq!(octave_weight(64.0, 1.0 / 64.0), 0.0);
        assert_eq!(octave_weight(4.0, 1.0 / 64.0), 1.0);
    }
}
