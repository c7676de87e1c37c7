//! The distribution (Monte Carlo) ray tracer's CPU reference, in f64.
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
//!
//! A scene with a participating medium ([`FrameScene::medium`]) gets its grids from
//! [`crate::volume::grids_for`] (made once per process) and tracks every path through the
//! medium as it is at the sample's time; the tracking's random numbers come from a stream
//! seeded per eye, pixel and sample. Without a medium no volume code runs.

use glam::{DQuat, DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use study::scene::FrameScene;
use study::seed::mix;

use crate::env::EnvironmentMap;
use crate::io::LinearImage;
use crate::shading::camera::CameraRays;
use crate::shading::integrator::{PathMedium, PathTracer, SphereState};
use crate::shading::intersect::Geometry;
use crate::shading::material::Shader;
use crate::shading::sampler::{PixelSampler, dim};
use crate::volume::{VolumeError, WorldMedium, grids_for};

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

/// One tile's pixels (row-major within the tile) and discarded samples.
type TileLevel = (Vec<[f32; 3]>, u64);

/// Renders every view of a frame. Deterministic: the same scene and map give the same
/// pixels, whatever the number of threads. Fails only for a medium whose grids cannot be
/// made.
pub fn render_frame(scene: &FrameScene, env: &EnvironmentMap) -> Result<FrameOutput, VolumeError> {
    let mut levels = render_frame_nested(scene, env, &[])?;
    Ok(levels.pop().unwrap_or(FrameOutput { eyes: Vec::new(), nonfinite_samples: 0, camera_samples: 0 }))
}

/// Renders every view of a frame and also reads it out after the first `k` samples per
/// pixel for each `k` of `checkpoints` below the scene's count (nested sampling: one sample
/// stream, several sample counts). Returns one output per distinct checkpoint, fewest
/// samples first, the full count last; each is exactly what rendering that count alone
/// gives.
pub fn render_frame_nested(
    scene: &FrameScene,
    env: &EnvironmentMap,
    checkpoints: &[u32],
) -> Result<Vec<FrameOutput>, VolumeError> {
    let setup = FrameSetup::new(scene);
    let medium = match &scene.medium {
        None => None,
        Some(m) => Some((m, grids_for(m, &mut |_, _| {})?)),
    };
    let tracer = PathTracer {
        env,
        shader: Shader::new(&scene.material),
        floor_albedo: DVec3::from_array(scene.floor.albedo),
        max_bounces: scene.integrator.max_bounces,
        russian_roulette_from: scene.integrator.russian_roulette_from,
    };
    let spp = scene.samples_per_pixel;
    let mut levels: Vec<u32> = checkpoints.iter().copied().filter(|&k| k > 0 && k < spp).collect();
    levels.sort_unstable();
    levels.dedup();
    levels.push(spp);
    let dims = dim::BOUNCE_BASE + dim::PER_BOUNCE * scene.integrator.max_bounces;
    let mut outputs: Vec<FrameOutput> = levels
        .iter()
        .map(|_| FrameOutput { eyes: Vec::with_capacity(scene.views.len()), nonfinite_samples: 0, camera_samples: 0 })
        .collect();
    for view in &scene.views {
        let cam = &view.camera;
        let rays = CameraRays::new(cam);
        let (w, h) = (cam.width, cam.height);
        let tiles: Vec<(u32, u32)> =
            (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE))).collect();
        // Per tile and level: its pixels and discarded samples.
        let results: Vec<(u32, u32, Vec<TileLevel>)> = tiles
            .par_iter()
            .map(|&(x0, y0)| {
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut per_level: Vec<TileLevel> =
                    levels.iter().map(|_| (Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize), 0)).collect();
                for y in y0..y1 {
                    for x in x0..x1 {
                        let mut sampler = PixelSampler::new(view.seed, x, y, w, dims);
                        let mut sum = DVec3::ZERO;
                        let mut bad = 0u64;
                        let mut next = 0;
                        for i in 0..spp {
                            sampler.start_sample(i);
                            let u = if scene.pixel_jitter { sampler.get_2d(dim::PIXEL) } else { [0.5, 0.5] };
                            let ray = rays.ray(DVec2::new(f64::from(x) + u[0], f64::from(y) + u[1]));
                            let time = if setup.time_sampling {
                                scene.shutter.time_at(sampler.get_1d(dim::TIME))
                            } else {
                                scene.shutter.open
                            };
                            let sphere = match &setup.fixed_sphere {
                                Some(s) => *s,
                                None => setup.sphere_at(scene, time),
                            };
                            let l = match &medium {
                                None => tracer.radiance(ray, &sphere, &sampler, rays.pixel_angle),
                                Some((m, grids)) => {
                                    let seed = mix(view.seed, &[u64::from(x), u64::from(y), u64::from(i)]);
                                    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
                                    let mut path_medium = PathMedium {
                                        medium: WorldMedium::at(m, grids, time),
                                        max_scatterings: m.max_scatterings,
                                        uniform: || rng.random::<f64>(),
                                    };
                                    tracer.radiance_in_medium(
                                        ray,
                                        &sphere,
                                        &sampler,
                                        rays.pixel_angle,
                                        &mut path_medium,
                                    )
                                }
                            };
                            if l.is_finite() {
                                sum += l;
                            } else {
                                bad += 1;
                            }
                            if i + 1 == levels[next] && next + 1 < levels.len() {
                                let mean = sum / f64::from(levels[next]);
                                per_level[next].0.push([mean.x as f32, mean.y as f32, mean.z as f32]);
                                per_level[next].1 += bad;
                                next += 1;
                            }
                        }
                        let mean = sum / f64::from(spp.max(1));
                        let last = per_level.len() - 1;
                        per_level[last].0.push([mean.x as f32, mean.y as f32, mean.z as f32]);
                        per_level[last].1 += bad;
                    }
                }
                (x0, y0, per_level)
            })
            .collect();
        for (j, out) in outputs.iter_mut().enumerate() {
            let mut img = LinearImage::new(w, h);
            out.nonfinite_samples += results.iter().map(|(_, _, levels)| levels[j].1).sum::<u64>();
            for (x0, y0, per_level) in &results {
                let tw = (x0 + TILE).min(w) - x0;
                for (i, p) in per_level[j].0.iter().enumerate() {
                    img.set(x0 + i as u32 % tw, y0 + i as u32 / tw, *p);
                }
            }
            out.camera_samples += u64::from(w) * u64::from(h) * u64::from(levels[j]);
            out.eyes.push(img);
        }
    }
    Ok(outputs)
}
