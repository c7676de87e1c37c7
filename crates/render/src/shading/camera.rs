//! Camera rays: a pinhole camera with an optionally shifted sensor, as described by
//! `study::scene::Camera`, reduced to a base vector and per-pixel steps so a ray costs
//! one normalisation.

use glam::{DVec2, DVec3};
use study::scene::Camera;

use super::intersect::Ray;

/// Precomputed ray generation for one camera.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    origin: DVec3,
    /// Unnormalised direction through the image's top-left corner.
    corner: DVec3,
    /// Step of one pixel to the right.
    step_x: DVec3,
    /// Step of one pixel down.
    step_y: DVec3,
    /// Angle one pixel subtends at the image centre (radians), for texture footprints.
    pub pixel_angle: f64,
}

impl CameraRays {
    /// Prepares a camera.
    pub fn new(camera: &Camera) -> Self {
        let (w, h) = (f64::from(camera.width), f64::from(camera.height));
        let sensor_h = camera.sensor_height();
        let corner = camera.forward * camera.focal_length
            + camera.right * (camera.sensor_shift.x - 0.5 * camera.sensor_width)
            + camera.up * (camera.sensor_shift.y + 0.5 * sensor_h);
        CameraRays {
            origin: camera.position,
            corner,
            step_x: camera.right * (camera.sensor_width / w),
            step_y: -camera.up * (sensor_h / h),
            pixel_angle: camera.sensor_width / w / camera.focal_length,
        }
    }

    /// The camera position.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The unnormalised direction through the image's top-left corner.
    pub fn corner(&self) -> DVec3 {
        self.corner
    }

    /// The step of one pixel to the right.
    pub fn step_x(&self) -> DVec3 {
        self.step_x
    }

    /// The step of one pixel down.
    pub fn step_y(&self) -> DVec3 {
        self.step_y
    }

    /// The ray through continuous pixel coordinates (x right, y down).
    #[inline]
    pub fn ray(&self, pixel: DVec2) -> Ray {
        Ray { origin: self.origin, dir: (self.corner + self.step_x * pixel.x + self.step_y * pixel.y).normalize() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_scene_camera() {
        let mut cam = Camera::look_at(DVec3::new(0.1, 0.5, 3.0), DVec3::new(0.0, 0.1, 0.0), 0.05, 0.036, 640, 360);
        cam.sensor_shift = DVec2::new(0.001, -0.0005);
        let rays = CameraRays::new(&cam);
        for px in [DVec2::new(0.0, 0.0), DVec2::new(320.5, 180.25), DVec2::new(640.0, 360.0)] {
            assert!((rays.ray(px).dir - cam.ray_direction(px)).length() < 1e-14);
        }
    }
}
