//! The analytic rasterizer's f64 CPU reference: [`render_frame`] over the pipeline of the
//! sibling modules, the settings it reads ([`AnalyticParams`]) and the motion it refuses
//! ([`check_motion`]).

use glam::DVec3;
use study::method::AnalyticSettings;
use study::scene::FrameScene;

use super::frame::{RasterStats, render_image};
use super::geometry::{CameraFrame, scene_triangles};
use super::interval::SEARCH_RANGE_OPAQUE;
use super::shade::Shading;
use crate::env::EnvironmentMap;
use crate::io::LinearImage;
use crate::shading::camera::CameraRays;
use crate::shading::integrator::PathTracer;
use crate::shading::material::Shader;

/// The settings' defaults and ranges: one home, the study model's.
pub use study::method::{DEFAULT_INTERVALS, DEFAULT_TESSELLATION, INTERVALS_RANGE, SUPERSAMPLING_RANGE};
/// The largest tessellation (the design's own limit, `study::method::TESSELLATION_RANGE`).
pub const MAX_TESSELLATION: u32 = *study::method::TESSELLATION_RANGE.end();

/// Settings a frame could not be rendered with.
#[derive(Debug, thiserror::Error)]
pub enum AnalyticError {
    /// A setting outside its range.
    #[error("analytic rasterizer: {0}")]
    Settings(String),
    /// The sphere's path wraps onto itself within one exposure, which straight vertex paths
    /// cannot follow.
    #[error(
        "analytic rasterizer: the sphere travels {travel:e} m during the shutter, at least its path's wrap length {wrap} m, so it would cross the view more than once in one exposure; the analytic method moves its triangles in one straight line per exposure (lower the speed level's degrees_per_second or the shutter level)"
    )]
    WrapsOver {
        /// Distance over the shutter.
        travel: f64,
        /// Wrap length.
        wrap: f64,
    },
}

/// Refuses a frame whose sphere travels its path's whole wrap length (or more) during the
/// shutter: the same refusal on the CPU and the GPU (the GPU kernel's parameters cannot
/// express it either). A single wrap within an exposure is followed by neither: the wrap
/// points lie outside every view, and the straight path leaves the view as the wrapped one
/// does.
pub fn check_motion(scene: &FrameScene) -> Result<(), AnalyticError> {
    let Some(wrap) = scene.sphere.wrap_length.filter(|l| *l > 0.0) else { return Ok(()) };
    if !scene.needs_time_sampling() {
        return Ok(());
    }
    let duration = scene.shutter.duration();
    let travel = scene.sphere.velocity.length() * duration;
    if travel >= wrap || !travel.is_finite() {
        return Err(AnalyticError::WrapsOver { travel, wrap });
    }
    Ok(())
}

/// The rasterizer's settings, resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnalyticParams {
    /// Per-pixel interval budget.
    pub intervals: u32,
    /// Sphere segments around the equator.
    pub tessellation: u32,
    /// Lighting samples per shading evaluation; `None`: the frame's samples per pixel.
    pub lighting_samples: Option<u32>,
    /// Sample points per pixel along each axis ([`supersample`]); 1: the pixel's centre.
    pub supersampling: u32,
}

impl Default for AnalyticParams {
    fn default() -> Self {
        AnalyticParams {
            intervals: DEFAULT_INTERVALS,
            tessellation: DEFAULT_TESSELLATION,
            lighting_samples: None,
            supersampling: 1,
        }
    }
}

impl AnalyticParams {
    /// The settings a design wrote (defaults where unset), checked.
    pub fn from_settings(spec: &AnalyticSettings) -> Result<Self, AnalyticError> {
        let p = AnalyticParams {
            intervals: spec.intervals(),
            tessellation: spec.tessellation(),
            lighting_samples: spec.lighting_samples,
            supersampling: spec.supersampling(),
        };
        p.check()?;
        Ok(p)
    }

    /// Checks the ranges.
    pub fn check(&self) -> Result<(), AnalyticError> {
        if !INTERVALS_RANGE.contains(&self.intervals) {
            return Err(AnalyticError::Settings(format!("intervals must lie in 4..=64, found {}", self.intervals)));
        }
        let tessellation = study::method::TESSELLATION_RANGE;
        if !tessellation.contains(&self.tessellation) {
            return Err(AnalyticError::Settings(format!(
                "tessellation must lie in {}..={}, found {}",
                tessellation.start(),
                tessellation.end(),
                self.tessellation
            )));
        }
        if !SUPERSAMPLING_RANGE.contains(&self.supersampling) {
            return Err(AnalyticError::Settings(format!(
                "supersampling must lie in 1..=8, found {}",
                self.supersampling
            )));
        }
        if self.lighting_samples == Some(0) {
            return Err(AnalyticError::Settings("lighting_samples must be at least 1".into()));
        }
        Ok(())
    }
}

/// A rendered frame: one image per view and the rasterizer's counts.
#[derive(Clone, Debug)]
pub struct AnalyticFrame {
    /// One linear image per `scene.views` entry, in order.
    pub eyes: Vec<LinearImage>,
    /// Counts over all views.
    pub stats: RasterStats,
    /// Lighting samples taken (shaded intervals x lighting samples).
    pub lighting_samples: u64,
    /// GPU time of the kernel's dispatches (timestamps), when rendered on a GPU that has them.
    pub gpu_seconds: Option<f64>,
}

/// Renders every view of `scene` lit by `env`.
pub fn render_frame(
    scene: &FrameScene,
    env: &EnvironmentMap,
    params: &AnalyticParams,
) -> Result<AnalyticFrame, AnalyticError> {
    params.check()?;
    check_motion(scene)?;
    let lighting = params.lighting_samples.unwrap_or(scene.samples_per_pixel).max(1);
    let mut eyes = Vec::with_capacity(scene.views.len());
    let mut stats = RasterStats::default();
    let n = params.supersampling;
    let scaled = super::supersample::scaled(scene, n);
    let scene = &*scaled;
    for view in &scene.views {
        let cam = &view.camera;
        let camera = CameraFrame::new(cam);
        let triangles = scene_triangles(scene, &camera, params.tessellation);
        let tracer = PathTracer {
            env,
            shader: Shader::new(&scene.material),
            floor_albedo: DVec3::from_array(scene.floor.albedo),
            max_bounces: scene.integrator.max_bounces,
            russian_roulette_from: scene.integrator.russian_roulette_from,
        };
        // Texture footprints are the output pixel's, as the tracer filters a pixel's samples.
        let pixel_angle = CameraRays::new(cam).pixel_angle * f64::from(n);
        let mut shading = Shading::new(tracer, scene, camera, view.seed, cam.width, pixel_angle, lighting);
        shading.supersampling = n;
        let (pixels, st) = render_image(
            &triangles,
            &camera,
            cam.width,
            cam.height,
            params.intervals as usize,
            SEARCH_RANGE_OPAQUE,
            |b, iv, s, x, y, index| shading.shade(&b.setup, b.triangle.surface, iv, s, x, y, index),
            |s| shading.background(s),
        );
        stats.add(&st);
        eyes.push(super::supersample::downsample(&LinearImage { width: cam.width, height: cam.height, pixels }, n));
    }
    Ok(AnalyticFrame { eyes, lighting_samples: stats.shaded * u64::from(lighting), stats, gpu_seconds: None })
}
