//! The medium composited over the tracer's surfaces, one eye at a time: the f32 marcher
//! along each pixel's centre ray, on the renderer's GPU (`media::gpu::GpuMarcher::render_rays`)
//! or on the CPU (`media::march::march_surface_ray`, its twin).
//!
//! Rays are marched in the grid box's unit-cube coordinates with directions scaled by the
//! inverse box size but not renormalised, so that ray lengths, the step and the extinction
//! stay in world metres whatever the box's proportions. Per instant `k` of the open shutter
//! (the settings' sub-frames, at the centres of equal parts; one instant where nothing
//! moves) the grid is interpolated in time, the sphere placed, and each pixel gets
//!
//! `L_k = S T_k F_k + L_medium,k`
//!
//! where `S` is the tracer's (motion-blurred) surface radiance, `T_k` the medium's
//! transmittance up to the first surface at that instant (the sky: the whole box), `L_medium`
//! the light it scatters towards the eye, and `F_k` the smoke's shadow on the surface (the
//! primary-and-shadow model only): the constellation's irradiance on the surface point
//! through the medium over that without it, `sum E_n max(0, n.l_n) T_n / sum E_n max(0, n.l_n)`.
//! The pixel is the mean over the instants. The stated approximations: one ray per pixel for
//! the medium (the tracer's samples antialias the surfaces), the surface's radiance scaled
//! as a whole by the shadow ratio, and the surfaces' blur taken over the whole shutter while
//! the medium's depth limit moves with the sphere per sub-frame.

use glam::{DVec2, DVec3, Vec3};
use media::constellation::{Constellation, DirectionalLight};
use media::gpu::{GpuMarcher, GpuVolume};
use media::march::{
    LightingModel, MarchLight, MarchMedium, MarchSettings, NO_LIMIT, SurfacePoint, SurfaceRay, march_surface_ray,
};
use media::{DensityGrid, DistanceMap};
use rayon::prelude::*;
use study::medium::SceneMedium;
use study::method::{MarchLighting, MarcherSettings};
use study::scene::{Camera, FrameScene};

use crate::io::LinearImage;
use crate::shading::camera::CameraRays;
use crate::shading::intersect::Geometry;
use crate::volume::MediumGrids;

/// Rec. 709 luminance of a linear colour.
fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The marcher's lighting model for a setting.
pub fn lighting_model(l: MarchLighting) -> LightingModel {
    match l {
        MarchLighting::AlphaCompositing => LightingModel::AlphaCompositing,
        MarchLighting::Primary => LightingModel::PrimaryRays,
        MarchLighting::PrimaryAndShadow => LightingModel::PrimaryAndShadowRays,
    }
}

/// The instants (seconds) the medium is marched at: the centres of `sub_frames` equal parts
/// of the open shutter, or the shutter's one instant where nothing moves.
pub fn instants(scene: &FrameScene, sub_frames: u32) -> Vec<f64> {
    if !scene.needs_time_sampling() {
        return vec![scene.shutter.centre()];
    }
    let k = sub_frames.max(1);
    (0..k).map(|i| scene.shutter.time_at((f64::from(i) + 0.5) / f64::from(k))).collect()
}

/// The medium and the surfaces at one instant, in the frame the marcher works in.
pub struct Instant {
    grid: DensityGrid,
    distance: Option<DistanceMap>,
    lo: DVec3,
    inv_size: DVec3,
    sigma_t: f32,
    albedo: f32,
    /// The shortest voxel edge, metres.
    voxel_length: f32,
    geometry: Geometry,
}

impl Instant {
    /// `medium` at time `t` over the scene's surfaces, with its distance map if asked for.
    pub fn new(scene: &FrameScene, medium: &SceneMedium, grids: &MediumGrids, t: f64, distance_map: bool) -> Self {
        let grid = grids.sequence.grid_at(grids.position(medium, t));
        let (lo, hi) = medium.bounds();
        let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
        let dims = grid.dims();
        let voxel_length = (0..3).map(|a| (hi[a] - lo[a]) / dims[a] as f64).fold(f64::INFINITY, f64::min);
        let distance = distance_map.then(|| DistanceMap::new(&grid, 0.0));
        Instant {
            grid,
            distance,
            lo,
            inv_size: (hi - lo).recip(),
            sigma_t: medium.extinction as f32,
            albedo: medium.albedo as f32,
            voxel_length: voxel_length as f32,
            geometry: Geometry {
                centre: scene.sphere.centre_at(t),
                radius: scene.sphere.radius,
                floor_height: scene.floor.height,
            },
        }
    }

    /// The instant's grids on `marcher`'s device.
    pub fn upload(&self, marcher: &GpuMarcher) -> GpuVolume {
        marcher.upload(&self.march_medium(Vec3::ZERO))
    }

    /// The medium as the marcher sees it.
    fn march_medium(&self, alpha_colour: Vec3) -> MarchMedium<'_> {
        MarchMedium {
            grid: &self.grid,
            distance: self.distance.as_ref(),
            sigma_t: self.sigma_t,
            albedo: self.albedo,
            alpha_colour,
            voxel_length: self.voxel_length,
        }
    }

    /// A world direction in the box's coordinates, lengths kept in metres.
    fn to_box(&self, d: DVec3) -> Vec3 {
        (d * self.inv_size).as_vec3()
    }

    /// A world point in the box's coordinates.
    fn point_to_box(&self, p: DVec3) -> Vec3 {
        ((p - self.lo) * self.inv_size).as_vec3()
    }
}

/// The lights of one instant: as the marcher holds them (in the box's frame), in the world
/// (for the surfaces' shadow), and the grey of alpha compositing.
struct Lights {
    march: Vec<MarchLight>,
    world: Vec<Vec3>,
    alpha_colour: Vec3,
}

/// The constellation's lights for `model`. With shadow rays, lights below the horizon are
/// left out: the floor hides them from every point above it (the sphere's own shadow on the
/// smoke is not modelled). Without shadow rays every light shines at full strength, as in the
/// thesis's model. The grey of alpha compositing is the albedo times the environment's mean
/// luminance (a white medium lit evenly by the sky's average), so that the model differs
/// from primary rays by having no lights, not by its brightness.
fn lights_for(instant: &Instant, constellation: &Constellation, model: LightingModel) -> Lights {
    let world: Vec<DirectionalLight> = constellation
        .lights
        .iter()
        .filter(|l| model != LightingModel::PrimaryAndShadowRays || l.direction.y > 0.0)
        .cloned()
        .collect();
    let march = world
        .iter()
        .map(|l| MarchLight { direction: instant.to_box(l.direction), irradiance: l.irradiance.as_vec3() })
        .collect();
    let total: DVec3 = constellation.lights.iter().map(|l| l.irradiance).sum();
    let grey = f64::from(instant.albedo) * luminance(total) / (4.0 * std::f64::consts::PI);
    Lights {
        march,
        world: world.iter().map(|l| l.direction.as_vec3()).collect(),
        alpha_colour: Vec3::splat(grey as f32),
    }
}

/// What the medium does to one eye's pixels at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelMedium {
    /// Radiance the medium scatters towards the eye.
    pub radiance: Vec3,
    /// How much of the surface behind shows through: the transmittance times the smoke's
    /// shadow on it (per channel).
    pub surface_weight: Vec3,
}

/// Each pixel's centre ray of `camera` in the box's frame, up to its first surface at the
/// instant.
fn eye_rays(instant: &Instant, camera: &Camera) -> Vec<SurfaceRay> {
    let rays = CameraRays::new(camera);
    let (w, h) = (camera.width, camera.height);
    (0..w * h)
        .into_par_iter()
        .map(|n| {
            let ray = rays.ray(DVec2::new(f64::from(n % w) + 0.5, f64::from(n / w) + 0.5));
            let hit = instant.geometry.intersect(&ray, None);
            SurfaceRay {
                origin: instant.point_to_box(ray.origin),
                direction: instant.to_box(ray.dir),
                limit: hit.map_or(NO_LIMIT, |h| (h.t as f32).min(NO_LIMIT)),
                surface: hit.map(|h| SurfacePoint { point: instant.point_to_box(h.point), normal: h.normal.as_vec3() }),
            }
        })
        .collect()
}

/// The medium over every pixel of `camera` at one instant, on `gpu` where given (the
/// instant's grids uploaded once per call), else on the CPU.
pub fn march_eye(
    instant: &Instant,
    camera: &Camera,
    constellation: &Constellation,
    settings: &MarcherSettings,
    gpu: Option<(&GpuMarcher, &GpuVolume)>,
) -> Result<(Vec<PixelMedium>, Option<f64>), gpu::GpuError> {
    let model = lighting_model(settings.lighting());
    let lights = lights_for(instant, constellation, model);
    let medium = instant.march_medium(lights.alpha_colour);
    let march = MarchSettings {
        step: (settings.step() * f64::from(instant.voxel_length)) as f32,
        model,
        threshold: 0.0,
        shade_empty: false,
    };
    let rays = eye_rays(instant, camera);
    match gpu {
        Some((marcher, volume)) => {
            let size = (camera.width, camera.height);
            let out = marcher.render_rays(
                volume,
                &medium,
                &lights.march,
                &lights.world,
                &rays,
                size,
                &march,
                settings.validity_mask(),
            )?;
            let pixels = out
                .pixels
                .iter()
                .zip(&out.surface_shadow)
                .map(|(p, s)| PixelMedium {
                    radiance: Vec3::new(p[0], p[1], p[2]),
                    surface_weight: Vec3::from_array(*s) * p[3],
                })
                .collect();
            Ok((pixels, Some(out.seconds)))
        }
        None => {
            let pixels = rays
                .par_iter()
                .map(|ray| {
                    let (r, shadowed) =
                        march_surface_ray(&medium, &lights.march, &lights.world, ray, &march, settings.validity_mask());
                    PixelMedium { radiance: r.radiance, surface_weight: shadowed * r.transmittance }
                })
                .collect();
            Ok((pixels, None))
        }
    }
}

/// Composites the medium of every instant over one eye's surfaces: `S mean(w_k) + mean(L_k)`
/// ([`PixelMedium`]), divided rather than multiplied by the reciprocal so that an empty
/// medium leaves every surface pixel's bytes as they were.
pub fn composite(surfaces: &LinearImage, per_instant: &[Vec<PixelMedium>]) -> LinearImage {
    let k = per_instant.len().max(1) as f32;
    let pixels = (0..surfaces.pixels.len())
        .map(|i| {
            let s = Vec3::from_array(surfaces.pixels[i]);
            let weight: Vec3 = per_instant.iter().map(|m| m[i].surface_weight).sum();
            let radiance: Vec3 = per_instant.iter().map(|m| m[i].radiance).sum();
            (s * (weight / k) + radiance / k).to_array()
        })
        .collect();
    LinearImage { width: surfaces.width, height: surfaces.height, pixels }
}
