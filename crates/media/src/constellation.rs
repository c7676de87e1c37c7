//! The light constellation of section 2.2.1: an environment map replaced by N directional
//! lights, so that a ray marcher's shadow rays go to N fixed directions instead of sampling
//! the map. The split is Debevec's median cut (2005; the thesis used Cohen and Debevec's
//! tool, which implements it): a region of the latitude-longitude map is cut across its
//! longer side (the width counted at the region's mean latitude) where the energy on either
//! side is equal, each region becomes one light at its energy centroid carrying exactly the
//! region's radiant energy. So that N need not be a power of two, the region with the most
//! energy is cut next; for N = 2^k this gives the classic median cut's regions up to the
//! rounding of the equal-energy cuts.
//!
//! Energy is conserved by construction: the lights' sum equals the map's integral
//! `sum L(pixel) dOmega(pixel)`, which is also the constellation's irradiance on a sphere's
//! average. The map's convention is the renderer's (see `render::env`): column `u` is the
//! azimuth `phi = 2 pi u`, row `v` the polar angle from +y, `theta = pi v`, direction
//! `(sin phi sin theta, cos theta, -cos phi sin theta)`.

use std::f64::consts::PI;

use glam::DVec3;

/// A latitude-longitude map of linear RGB radiance, row by row from the top (+y).
#[derive(Debug, Clone, PartialEq)]
pub struct LatLongMap {
    /// Width in pixels (twice the height in the renderer's maps; any width is accepted).
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` radiances.
    pub radiance: Vec<[f32; 3]>,
}

/// Why a map cannot be split.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConstellationError {
    /// The map's size does not match its pixels, or it is empty.
    #[error("environment map of {width}x{height} pixels with {found} radiances: expected width x height > 0")]
    Size {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Radiances found.
        found: usize,
    },
    /// A pixel is NaN, infinite or negative.
    #[error("environment map pixel ({x}, {y}) holds {value:?}: expected finite radiance >= 0")]
    Pixel {
        /// Column.
        x: usize,
        /// Row.
        y: usize,
        /// The value.
        value: [f32; 3],
    },
    /// The number of lights is zero.
    #[error("a light constellation needs at least 1 light, got 0")]
    NoLights,
}

/// One light of a constellation: a direction and the radiant energy it carries
/// (`integral of L over its region`, W m^-2 sr^0: the irradiance it gives a surface facing it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction towards the light.
    pub direction: DVec3,
    /// Linear RGB irradiance at normal incidence.
    pub irradiance: DVec3,
    /// The region of the map it stands for: columns `x0..x1`, rows `y0..y1`.
    pub region: [usize; 4],
}

/// An environment map as N directional lights.
#[derive(Debug, Clone, PartialEq)]
pub struct Constellation {
    /// The lights, in the order their regions were made.
    pub lights: Vec<DirectionalLight>,
}

/// The direction of a point `(x, y)` in pixel units on a `w x h` map.
pub fn direction(x: f64, y: f64, w: usize, h: usize) -> DVec3 {
    let phi = 2.0 * PI * x / w as f64;
    let theta = PI * y / h as f64;
    DVec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin())
}

/// The solid angle of row `y`'s pixels: `(2 pi / w) (cos theta0 - cos theta1)`.
fn pixel_solid_angle(y: usize, w: usize, h: usize) -> f64 {
    let (t0, t1) = (PI * y as f64 / h as f64, PI * (y + 1) as f64 / h as f64);
    2.0 * PI / w as f64 * (t0.cos() - t1.cos())
}

fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Summed-area tables of energy (luminance x solid angle), RGB energy and energy-weighted
/// pixel centres, so a region's sums cost four lookups.
struct Tables {
    w: usize,
    energy: Vec<f64>,
    rgb: Vec<DVec3>,
    xs: Vec<f64>,
    ys: Vec<f64>,
}

impl Tables {
    fn new(map: &LatLongMap) -> Self {
        let (w, h) = (map.width, map.height);
        let n = (w + 1) * (h + 1);
        let (mut energy, mut rgb, mut xs, mut ys) = (vec![0.0; n], vec![DVec3::ZERO; n], vec![0.0; n], vec![0.0; n]);
        for y in 0..h {
            let omega = pixel_solid_angle(y, w, h);
            for x in 0..w {
                let c = map.radiance[x + w * y];
                let l = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2])) * omega;
                let e = luminance(l);
                let (a, b, d, q) =
                    (x + (w + 1) * y, x + 1 + (w + 1) * y, x + (w + 1) * (y + 1), x + 1 + (w + 1) * (y + 1));
                energy[q] = e + energy[b] + energy[d] - energy[a];
                rgb[q] = l + rgb[b] + rgb[d] - rgb[a];
                xs[q] = e * (x as f64 + 0.5) + xs[b] + xs[d] - xs[a];
                ys[q] = e * (y as f64 + 0.5) + ys[b] + ys[d] - ys[a];
            }
        }
        Self { w, energy, rgb, xs, ys }
    }

    fn sum<T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T>>(&self, t: &[T], r: [usize; 4]) -> T {
        let [x0, x1, y0, y1] = r;
        let at = |x: usize, y: usize| t[x + (self.w + 1) * y];
        at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0)
    }
}

impl Constellation {
    /// Splits `map` into `lights` lights (fewer only if the map has fewer pixels than that,
    /// or no energy left to divide).
    pub fn median_cut(map: &LatLongMap, lights: usize) -> Result<Self, ConstellationError> {
        let (w, h) = (map.width, map.height);
        if w == 0 || h == 0 || map.radiance.len() != w * h {
            return Err(ConstellationError::Size { width: w, height: h, found: map.radiance.len() });
        }
        if let Some(n) = map.radiance.iter().position(|c| c.iter().any(|v| !(v.is_finite() && *v >= 0.0))) {
            return Err(ConstellationError::Pixel { x: n % w, y: n / w, value: map.radiance[n] });
        }
        if lights == 0 {
            return Err(ConstellationError::NoLights);
        }
        let t = Tables::new(map);
        let mut regions = vec![[0, w, 0, h]];
        while regions.len() < lights {
            // the splittable region with the most energy
            let Some((at, _)) = regions
                .iter()
                .enumerate()
                .filter(|(_, r)| r[1] - r[0] > 1 || r[3] - r[2] > 1)
                .map(|(n, r)| (n, t.sum(&t.energy, *r)))
                .filter(|(_, e)| *e > 0.0)
                .max_by(|a, b| a.1.total_cmp(&b.1))
            else {
                break;
            };
            let r = regions[at];
            let [x0, x1, y0, y1] = r;
            let mid_theta = PI * (y0 + y1) as f64 / (2 * h) as f64;
            let width_angle = (x1 - x0) as f64 * 2.0 * PI / w as f64 * mid_theta.sin();
            let height_angle = (y1 - y0) as f64 * PI / h as f64;
            let across_x = (width_angle >= height_angle && x1 - x0 > 1) || y1 - y0 == 1;
            let total = t.sum(&t.energy, r);
            // the cut whose two sides are closest to equal energy
            let (lo, hi) = if across_x { (x0 + 1, x1) } else { (y0 + 1, y1) };
            let side = |c: usize| {
                let part = if across_x { [x0, c, y0, y1] } else { [x0, x1, y0, c] };
                t.sum(&t.energy, part)
            };
            let (mut a, mut b) = (lo, hi - 1);
            while a < b {
                let m = (a + b) / 2;
                if side(m) < 0.5 * total { a = m + 1 } else { b = m }
            }
            let cut =
                if a > lo && (side(a - 1) - 0.5 * total).abs() < (side(a) - 0.5 * total).abs() { a - 1 } else { a };
            let (first, second) =
                if across_x { ([x0, cut, y0, y1], [cut, x1, y0, y1]) } else { ([x0, x1, y0, cut], [x0, x1, cut, y1]) };
            regions[at] = first;
            regions.push(second);
        }
        let lights = regions
            .into_iter()
            .map(|r| {
                let e = t.sum(&t.energy, r);
                let [x0, x1, y0, y1] = r;
                let (cx, cy) = if e > 0.0 {
                    (t.sum(&t.xs, r) / e, t.sum(&t.ys, r) / e)
                } else {
                    (0.5 * (x0 + x1) as f64, 0.5 * (y0 + y1) as f64)
                };
                DirectionalLight { direction: direction(cx, cy, w, h), irradiance: t.sum(&t.rgb, r), region: r }
            })
            .collect();
        Ok(Self { lights })
    }

    /// The constellation's irradiance on a surface with unit normal `n` (lights below the
    /// surface contribute nothing).
    pub fn irradiance(&self, n: DVec3) -> DVec3 {
        self.lights.iter().map(|l| l.irradiance * l.direction.dot(n).max(0.0)).sum()
    }

    /// The lights' total: the map's integral of radiance over the sphere.
    pub fn total(&self) -> DVec3 {
        self.lights.iter().map(|l| l.irradiance).sum()
    }
}

impl LatLongMap {
    /// The map's integral of radiance over the sphere, pixel by pixel.
    pub fn integral(&self) -> DVec3 {
        (0..self.height)
            .map(|y| {
                let omega = pixel_solid_angle(y, self.width, self.height);
                (0..self.width)
                    .map(|x| {
                        let c = self.radiance[x + self.width * y];
                        DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]))
                    })
                    .sum::<DVec3>()
                    * omega
            })
            .sum()
    }

    /// The map's irradiance on a surface with normal `n`, integrated pixel by pixel with
    /// `sub x sub` sub-samples each (the ground truth the constellation approaches).
    pub fn irradiance(&self, n: DVec3, sub: usize) -> DVec3 {
        let (w, h) = (self.width, self.height);
        let mut sum = DVec3::ZERO;
        for y in 0..h {
            for x in 0..w {
                let c = self.radiance[x + w * y];
                let l = DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2]));
                if l == DVec3::ZERO {
                    continue;
                }
                for sy in 0..sub {
                    let (t0, t1) = (
                        PI * (y as f64 + sy as f64 / sub as f64) / h as f64,
                        PI * (y as f64 + (sy + 1) as f64 / sub as f64) / h as f64,
                    );
                    let omega = 2.0 * PI / (w * sub) as f64 * (t0.cos() - t1.cos());
                    for sx in 0..sub {
                        let d = direction(
                            x as f64 + (sx as f64 + 0.5) / sub as f64,
                            y as f64 + (sy as f64 + 0.5) / sub as f64,
                            w,
                            h,
                        );
                        sum += l * omega * d.dot(n).max(0.0);
                    }
                }
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sky: a blue gradient, a bright sun and a dim ground.
    fn sky(w: usize, h: usize) -> LatLongMap {
        let sun = direction(0.3 * w as f64, 0.3 * h as f64, w, h);
        let radiance = (0..w * h)
            .map(|n| {
                let d = direction((n % w) as f64 + 0.5, (n / w) as f64 + 0.5, w, h);
                let mut c =
                    if d.y > 0.0 { [0.3 + 0.4 * d.y as f32, 0.5 + 0.3 * d.y as f32, 1.0] } else { [0.1, 0.08, 0.05] };
                if d.dot(sun) > 0.995 {
                    c = [200.0, 180.0, 150.0];
                }
                c
            })
            .collect();
        LatLongMap { width: w, height: h, radiance }
    }

    #[test]
    fn energy_is_conserved_for_every_n() {
        let map = sky(128, 64);
        let total = map.integral();
        for n in [1, 2, 3, 8, 20, 64] {
            let c = Constellation::median_cut(&map, n).unwrap();
            assert_eq!(c.lights.len(), n);
            let got = c.total();
            assert!((got - total).abs().max_element() < 1e-9 * total.max_element(), "{n}: {got} vs {total}");
            for l in &c.lights {
                assert!((l.direction.length() - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_uniform_map_gives_pi_irradiance_on_any_plane() {
        // closed form: a uniform unit-radiance sky gives irradiance pi on any plane
        let map = LatLongMap { width: 64, height: 32, radiance: vec![[1.0; 3]; 64 * 32] };
        assert!((map.integral().x - 4.0 * PI).abs() < 1e-9);
        for n in [DVec3::Y, DVec3::X, DVec3::new(1.0, -1.0, 0.5).normalize()] {
            assert!((map.irradiance(n, 4).x - PI).abs() < 2e-3, "{}", map.irradiance(n, 4).x);
        }
        let c = Constellation::median_cut(&map, 256).unwrap();
        for n in [DVec3::Y, DVec3::X, DVec3::new(1.0, -1.0, 0.5).normalize()] {
            assert!((c.irradiance(n).x - PI).abs() < 0.05 * PI, "{n}: {}", c.irradiance(n).x);
        }
    }

    #[test]
    fn irradiance_approaches_the_maps_as_n_grows() {
        let map = sky(128, 64);
        let normals = [DVec3::Y, DVec3::X, DVec3::Z, -DVec3::Z, DVec3::new(0.3, 0.5, -0.8).normalize(), -DVec3::Y];
        let truth: Vec<DVec3> = normals.iter().map(|n| map.irradiance(*n, 4)).collect();
        let error = |n: usize| {
            let c = Constellation::median_cut(&map, n).unwrap();
            normals
                .iter()
                .zip(&truth)
                .map(|(n, t)| ((c.irradiance(*n) - *t).length() / t.length()).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let errors: Vec<f64> = [1, 4, 16, 64, 256].iter().map(|n| error(*n)).collect();
        for pair in errors.windows(2) {
            assert!(pair[1] < pair[0], "error should fall as N grows: {errors:?}");
        }
        assert!(errors[4] < 0.02, "{errors:?}");
    }

    #[test]
    fn the_sun_gets_its_own_light() {
        let (w, h) = (128, 64);
        let map = sky(w, h);
        let sun = direction(0.3 * w as f64, 0.3 * h as f64, w, h);
        let c = Constellation::median_cut(&map, 16).unwrap();
        let brightest = c.lights.iter().max_by(|a, b| a.irradiance.x.total_cmp(&b.irradiance.x)).unwrap();
        assert!(brightest.direction.dot(sun) > 0.99, "{}", brightest.direction);
    }

    #[test]
    fn bad_maps_are_refused() {
        let mut map = sky(8, 4);
        map.radiance[9][1] = f32::NAN;
        assert!(matches!(Constellation::median_cut(&map, 4), Err(ConstellationError::Pixel { x: 1, y: 1, .. })));
        let empty = LatLongMap { width: 4, height: 2, radiance: vec![] };
        assert!(matches!(Constellation::median_cut(&empty, 4), Err(ConstellationError::Size { .. })));
        assert_eq!(Constellation::median_cut(&sky(8, 4), 0), Err(ConstellationError::NoLights));
    }
}
