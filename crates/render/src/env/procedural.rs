//! The built-in procedural environment map (`kind = "default"`): a sky with a sun and a
//! ground, generated at any width.

use std::f64::consts::PI;

use glam::DVec3;

use crate::io::LinearImage;

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
