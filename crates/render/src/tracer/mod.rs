//! The distribution (Monte Carlo) ray tracer: the CPU reference renderer.
//!
//! [`render_frame`] renders every camera of a [`FrameScene`]. Each camera sample draws a
//! position in its pixel (box filter), a time in the open shutter (box shutter filter) and
//! the dimensions of its path from a padded Owen-scrambled Sobol sampler seeded per pixel
//! from the eye's seed, so the result does not depend on tiling or thread count and each
//! eye and frame has independent noise. The sphere's position and orientation are
//! evaluated at each sample's own time.
//!
//! The per-frame setup ([`FrameSetup`]) decides what needs simulating: a frame with a
//! closed shutter or no motion samples no time dimension (the sphere is placed once), and
//! a flat material evaluates no texture.

pub mod bench;
pub mod camera;
pub mod gpu;
pub mod integrator;
pub mod intersect;
pub mod material;
pub mod sampler;

use glam::{DQuat, DVec2, DVec3};
use rayon::prelude::*;
use study::scene::FrameScene;

use crate::env::EnvironmentMap;
use crate::io::LinearImage;
use camera::CameraRays;
use integrator::{PathTracer, SphereState};
use intersect::Geometry;
use material::Shader;
use sampler::{PixelSampler, dim};

/// The images of one frame and its sample statistics.
#[derive(Clone, Debug)]
pub struct FrameOutput {
    /// One linear image per `scene.views` entry, in order.
    pub eyes: Vec<LinearImage>,
    /// Camera samples whose radiance was NaN or infinite (dropped, not accumulated).
    pub nonfinite_samples: u64,
    /// Camera samples taken (all eyes).
    pub camera_samples: u64,
}

/// What a frame needs simulated, decided once per frame from the scene.
#[derive(Clone, Debug)]
pub struct FrameSetup {
    /// Whether each sample draws its own time (open shutter and a moving sphere).
    pub time_sampling: bool,
    /// Whether shading evaluates a texture (and so needs the sphere's orientation).
    pub textured: bool,
    /// The sphere for the whole frame when time is not sampled.
    pub fixed_sphere: Option<SphereState>,
}

impl FrameSetup {
    /// Decides the setup of `scene`.
    pub fn new(scene: &FrameScene) -> Self {
        let time_sampling = scene.needs_time_sampling();
        let textured = scene.material.is_textured();
        let mut setup = FrameSetup { time_sampling, textured, fixed_sphere: None };
        if !time_sampling {
            setup.fixed_sphere = Some(setup.sphere_at(scene, scene.shutter.open));
        }
        setup
    }

    /// The sphere at time `t`.
    pub fn sphere_at(&self, scene: &FrameScene, t: f64) -> SphereState {
        let s = &scene.sphere;
        SphereState {
            geometry: Geometry { centre: s.centre_at(t), radius: s.radius, floor_height: scene.floor.height },
            world_to_object: if self.textured { s.orientation_at(t).inverse() } else { DQuat::IDENTITY },
        }
    }
}

const TILE: u32 = 16;

/// Renders every view of a frame. Deterministic: the same scene and map give the same
/// pixels, whatever the number of threads.
pub fn render_frame(scene: &FrameScene, env: &EnvironmentMap) -> FrameOutput {
    let setup = FrameSetup::new(scene);
    let tracer = PathTracer {
        env,
        shader: Shader::new(&scene.material),
        floor_albedo: DVec3::from_array(scene.floor.albedo),
        max_bounces: scene.integrator.max_bounces,
        russian_roulette_from: scene.integrator.russian_roulette_from,
    };
    let spp = scene.samples_per_pixel;
    let dims = dim::BOUNCE_BASE + dim::PER_BOUNCE * scene.integrator.max_bounces;
    let mut eyes = Vec::with_capacity(scene.views.len());
    let mut nonfinite = 0u64;
    let mut samples = 0u64;
    for view in &scene.views {
        let cam = &view.camera;
        let rays = CameraRays::new(cam);
        let (w, h) = (cam.width, cam.height);
        let tiles: Vec<(u32, u32)> =
            (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE))).collect();
        let results: Vec<(u32, u32, Vec<[f32; 3]>, u64)> = tiles
            .par_iter()
            .map(|&(x0, y0)| {
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                let mut bad = 0u64;
                for y in y0..y1 {
                    for x in x0..x1 {
                        let mut sampler = PixelSampler::new(view.seed, x, y, w, dims);
                        let mut sum = DVec3::ZERO;
                        for i in 0..spp {
                            sampler.start_sample(i);
                            let u = sampler.get_2d(dim::PIXEL);
                            let ray = rays.ray(DVec2::new(f64::from(x) + u[0], f64::from(y) + u[1]));
                            let sphere = match &setup.fixed_sphere {
                                Some(s) => *s,
                                None => setup.sphere_at(scene, scene.shutter.time_at(sampler.get_1d(dim::TIME))),
                            };
                            let l = tracer.radiance(ray, &sphere, &sampler, rays.pixel_angle);
                            if l.is_finite() {
                                sum += l;
                            } else {
                                bad += 1;
                            }
                        }
                        let mean = sum / f64::from(spp.max(1));
                        pixels.push([mean.x as f32, mean.y as f32, mean.z as f32]);
                    }
                }
                (x0, y0, pixels, bad)
            })
            .collect();
        let mut img = LinearImage::new(w, h);
        for (x0, y0, pixels, bad) in results {
            let tw = (x0 + TILE).min(w) - x0;
            for (i, p) in pixels.into_iter().enumerate() {
                img.set(x0 + i as u32 % tw, y0 + i as u32 / tw, p);
            }
            nonfinite += bad;
        }
        samples += u64::from(w) * u64::from(h) * u64::from(spp);
        eyes.push(img);
    }
    FrameOutput { eyes, nonfinite_samples: nonfinite, camera_samples: samples }
}
