//! Shading of an interval: one evaluation at its temporal midpoint, with the tracer's own
//! material and lighting code ([`PathTracer::radiance_from_hit`]: the sphere's materials,
//! the floor's albedo, environment importance sampling with shadow rays against the true
//! sphere at that instant, diffuse bounces), averaged over a configurable number of
//! lighting samples. Visibility is exact, so the only noise left is the shading's.
//!
//! The point shaded is where the pixel's ray meets the moving triangle at the midpoint
//! (its exact depth, Eq. 15) on the floor, and where the same ray meets the true sphere at
//! the midpoint on the sphere, whose normal it takes, so the tessellation shows only in the
//! silhouette.

use glam::{DQuat, DVec2, DVec3};
use study::scene::FrameScene;
use study::seed::mix;

use super::edge::TriangleSetup;
use super::geometry::{CameraFrame, SurfaceKind};
use super::interval::Interval;
use crate::shading::integrator::{PathTracer, SphereState};
use crate::shading::intersect::{Geometry, Hit, Ray, Surface, intersect_sphere};
use crate::shading::sampler::{PixelSampler, dim};

/// What shading needs of a frame and one of its views.
pub struct Shading<'a> {
    /// The tracer's integrator (material, environment, floor, bounces).
    pub tracer: PathTracer<'a>,
    /// The scene.
    pub scene: &'a FrameScene,
    /// The view's camera.
    pub camera: CameraFrame,
    /// The view's seed.
    pub seed: u64,
    /// Image width (the sampler's pixel index).
    pub width: u32,
    /// Angle one pixel subtends (texture footprints).
    pub pixel_angle: f64,
    /// Lighting samples per evaluation.
    pub lighting_samples: u32,
    /// Sample points per output pixel along each axis (`super::supersample`): the image
    /// shaded is the supersampled one, and each `n x n` block's points draw consecutive
    /// samples of their output pixel's one sequence, so together they stay stratified.
    pub supersampling: u32,
    /// Sphere centre at shutter open and its motion over the shutter.
    centre: (DVec3, DVec3),
}

impl<'a> Shading<'a> {
    /// Prepares shading for one view.
    pub fn new(
        tracer: PathTracer<'a>,
        scene: &'a FrameScene,
        camera: CameraFrame,
        seed: u64,
        width: u32,
        pixel_angle: f64,
        lighting_samples: u32,
    ) -> Self {
        let open = scene.shutter.open;
        let c0 = scene.sphere.centre_at(open);
        let motion =
            if scene.needs_time_sampling() { scene.sphere.velocity * scene.shutter.duration() } else { DVec3::ZERO };
        Shading {
            tracer,
            scene,
            camera,
            seed,
            width,
            pixel_angle,
            lighting_samples,
            supersampling: 1,
            centre: (c0, motion),
        }
    }

    /// The radiance the environment sends along sample point `s`'s ray (no surface).
    pub fn background(&self, s: DVec2) -> [f64; 3] {
        self.tracer.env.radiance(self.camera.direction(s)).to_array()
    }

    /// The sphere as the tracer sees it at normalised time `t`.
    pub fn sphere_at(&self, t: f64) -> SphereState {
        let sc = self.scene;
        let centre = self.centre.0 + self.centre.1 * t;
        let time = sc.shutter.time_at(t);
        SphereState {
            geometry: Geometry { centre, radius: sc.sphere.radius, floor_height: sc.floor.height },
            world_to_object: if sc.material.is_textured() {
                sc.sphere.orientation_at(time).inverse()
            } else {
                DQuat::IDENTITY
            },
        }
    }

    /// The interval's radiance at pixel `(x, y)`, sample point `s`, on `surface` of the
    /// triangle `setup`; `index` numbers the pixel's evaluations (each its own samples).
    /// Returns the mean radiance and the lighting samples that were not finite (dropped).
    #[allow(clippy::too_many_arguments)]
    pub fn shade(
        &self,
        setup: &TriangleSetup,
        surface: SurfaceKind,
        iv: &Interval,
        s: DVec2,
        x: u32,
        y: u32,
        index: u32,
    ) -> ([f64; 3], u64) {
        let t = 0.5 * (iv.ts + iv.te);
        let mut depth = setup.depth(s, t);
        if !(depth.is_finite() && depth > 0.0) {
            depth = iv.depth_at(t);
        }
        let p = self.camera.to_world(DVec3::new(s.x * depth, s.y * depth, 1.0 * depth));
        let sphere = self.sphere_at(t);
        let origin = self.camera.origin;
        let ray = Ray { origin, dir: self.camera.direction(s) };
        let hit = match surface {
            SurfaceKind::Sphere => {
                let g = &sphere.geometry;
                // The ray's front hit on the true sphere: the tessellation is inscribed, so a
                // ray through a covering triangle meets the sphere in front of it. The radial
                // projection of the triangle's point is only the fallback (a midpoint off its
                // triangle after compression): at the limb it lands on the back hemisphere.
                let point = match intersect_sphere(&ray, g.centre, g.radius) {
                    Some(along) => ray.origin + ray.dir * along,
                    None => g.centre + (p - g.centre).normalize_or(DVec3::Y) * g.radius,
                };
                let n = (point - g.centre).normalize_or(DVec3::Y);
                Hit { t: (point - origin).length(), point, normal: n, surface: Surface::Sphere }
            }
            SurfaceKind::Floor => {
                let mut point = p;
                point.y = self.scene.floor.height;
                Hit { t: (point - origin).length(), point, normal: DVec3::Y, surface: Surface::Floor }
            }
        };
        // A sphere point facing away from the pixel's ray (a midpoint off the triangle, e.g.
        // after compression merged intervals) would be shaded from the sphere's inside: no
        // light reaches there (every shadow ray is occluded) and its path never escapes: its
        // throughput sticks at the smallest subnormal, so it would bounce to `max_bounces`
        // for a radiance of zero.
        if surface == SurfaceKind::Sphere && hit.normal.dot(ray.dir) > 0.0 {
            return ([0.0; 3], 0);
        }
        let dims = dim::BOUNCE_BASE + dim::PER_BOUNCE * self.scene.integrator.max_bounces;
        let k = self.supersampling.max(1);
        let mut sampler =
            PixelSampler::new(mix(self.seed, &[u64::from(index), 0xA7A1]), x / k, y / k, self.width / k, dims);
        let mut sum = DVec3::ZERO;
        let mut bad = 0;
        let n = self.lighting_samples.max(1);
        let first = ((y % k) * k + x % k) * n;
        for j in 0..n {
            sampler.start_sample(first + j);
            let l = self.tracer.radiance_from_hit(ray, Some(hit), &sphere, &sampler, self.pixel_angle);
            if l.is_finite() {
                sum += l;
            } else {
                bad += 1;
            }
        }
        ((sum / f64::from(n)).to_array(), bad)
    }
}
