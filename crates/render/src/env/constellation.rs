//! The environment as the participating-media marcher sees it: the map's pixels split into
//! N directional lights by `media::constellation` (median cut), turned into the world by the
//! map's rotation about +y. The map's radiance already carries the lighting's intensity, so
//! the constellation's total irradiance is the map's integral as the tracer sees it.

use media::constellation::{Constellation, ConstellationError, LatLongMap};

use super::EnvironmentMap;

impl EnvironmentMap {
    /// The map as `lights` directional lights in world space (energy conserved).
    pub fn light_constellation(&self, lights: usize) -> Result<Constellation, ConstellationError> {
        let map =
            LatLongMap { width: self.width as usize, height: self.height as usize, radiance: self.texels.clone() };
        let mut constellation = Constellation::median_cut(&map, lights)?;
        for light in &mut constellation.lights {
            light.direction = self.to_world(light.direction);
        }
        Ok(constellation)
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use crate::env::EnvironmentMap;
    use crate::io::LinearImage;

    #[test]
    fn one_bright_texel_becomes_a_light_where_the_tracer_looks_it_up() {
        let (w, h) = (64u32, 32u32);
        let mut img = LinearImage::new(w, h);
        img.set(41, 9, [500.0, 400.0, 300.0]);
        for rotation in [0.0, 0.7, -2.1] {
            let env = EnvironmentMap::from_image(&img, 2.0, rotation, "test").unwrap();
            let c = env.light_constellation(1).unwrap();
            let light = &c.lights[0];
            // the tracer, asked for the light's world direction, finds the bright texel
            assert_eq!(env.radiance(light.direction), DVec3::new(1000.0, 800.0, 600.0), "rotation {rotation}");
            // and the light carries the texel's radiance times its solid angle
            let theta = |y: f64| std::f64::consts::PI * y / f64::from(h);
            let solid_angle = 2.0 * std::f64::consts::PI / f64::from(w) * (theta(9.0).cos() - theta(10.0).cos());
            assert!((light.irradiance.x - 1000.0 * solid_angle).abs() < 1e-9 * light.irradiance.x);
        }
    }

    #[test]
    fn a_uniform_sky_gives_the_same_total_whatever_the_rotation() {
        let mut img = LinearImage::new(32, 16);
        img.pixels.fill([1.0, 1.0, 1.0]);
        let env = EnvironmentMap::from_image(&img, 1.0, 1.3, "uniform").unwrap();
        let c = env.light_constellation(16).unwrap();
        let total: f64 = c.lights.iter().map(|l| l.irradiance.x).sum();
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-9, "{total}");
        assert!(c.lights.iter().all(|l| (l.direction.length() - 1.0).abs() < 1e-12));
    }
}
