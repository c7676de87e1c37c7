//! Measurements of the rasterizer's approximations. [`depth_error_histogram`] is the data of
//! the paper's Figure 10: for every visibility interval of a frame, the largest relative
//! error of its linear depth against the exact cubic-rational depth (Eq. 15), counted in
//! decade bins. (The paper measures the error relative to the far-near range of its depth
//! buffer; here it is relative to the true view depth, which is stricter for distant
//! surfaces.) [`tessellation_error`] compares the tessellated sphere's coverage at each
//! pixel's sample point with the true sphere's ([`super::sphere`]): what the triangles and
//! their straight vertex paths cost before any compression.

use glam::DVec2;
use serde::Serialize;
use study::scene::FrameScene;

use super::frame::{RasterStats, bin, rasterize_sample};
use super::geometry::{CameraFrame, VertexPaths, floor_triangles, sphere_triangles};
use super::interval::SEARCH_RANGE_OPAQUE;
use super::resolve::resolve_opaque;
use super::sphere;

/// Decade bins of the largest relative depth error per interval.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DepthErrorHistogram {
    /// Lower bound of each bin as a power of ten (`1e-12` .. `1e-1`); the first bin also
    /// counts smaller errors (and exact zeros), the last also larger ones.
    pub decades: Vec<i32>,
    /// Intervals per bin.
    pub counts: Vec<u64>,
    /// Intervals measured.
    pub intervals: u64,
    /// The largest error seen.
    pub max: f64,
    /// Mean error.
    pub mean: f64,
}

/// The histogram for view `view` of `scene` with the sphere tessellated into `segments`, its
/// vertices moving along `paths`, over every `stride`-th pixel in each direction. A triangle
/// that translates rigidly keeps its normal, so its depth along a ray is linear in time and
/// the approximation exact up to rounding ([`VertexPaths::Translated`], the rasterizer's
/// geometry); vertices on the rotation's chords ([`VertexPaths::RollingChords`]) deform the
/// triangles as the paper's moving geometry does.
pub fn depth_error_histogram(
    scene: &FrameScene,
    view: usize,
    segments: u32,
    paths: VertexPaths,
    stride: u32,
) -> DepthErrorHistogram {
    let decades: Vec<i32> = (-12..=-1).collect();
    let mut counts = vec![0u64; decades.len()];
    let (mut n, mut max, mut sum) = (0u64, 0.0f64, 0.0f64);
    if let Some(v) = scene.views.get(view) {
        let cam = &v.camera;
        let camera = CameraFrame::new(cam);
        let mut tris = sphere_triangles(scene, &camera, segments, paths);
        tris.extend(floor_triangles(scene, &camera));
        let binned = bin(&tris, &camera, cam.width, cam.height);
        let stride = stride.max(1);
        for y in (0..cam.height).step_by(stride as usize) {
            for x in (0..cam.width).step_by(stride as usize) {
                let s = camera.sample(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
                for b in binned.iter().filter(|b| b.covers(x, y)) {
                    for &(ts, te) in b.setup.visibility(s).spans() {
                        let e = b.setup.depth_error(s, ts, te);
                        let d = if e > 0.0 { e.log10().floor() as i32 } else { i32::MIN };
                        let i = (d.clamp(-12, -1) + 12) as usize;
                        counts[i] += 1;
                        n += 1;
                        max = max.max(e);
                        sum += e;
                    }
                }
            }
        }
    }
    DepthErrorHistogram { decades, counts, intervals: n, max, mean: if n > 0 { sum / n as f64 } else { 0.0 } }
}

/// The tessellated sphere's coverage against the true sphere's, over a frame's sample points.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TessellationError {
    /// Segments around the equator.
    pub segments: u32,
    /// The vertices' paths: `translated` (the rasterizer's) or `rolling_chords`.
    pub paths: &'static str,
    /// Sample points where either sphere covers some of the shutter.
    pub samples: u64,
    /// The largest difference of covered shutter fractions.
    pub max: f64,
    /// The mean absolute difference over those sample points.
    pub mean: f64,
    /// The mean signed difference (tessellated minus true; negative: the polygon lies inside).
    pub bias: f64,
}

/// [`TessellationError`] of view `view` of `scene` with the sphere tessellated into
/// `segments`, its vertices moving along `paths`, over every `stride`-th pixel centre in each
/// direction. The sphere's triangles alone are rasterized (no floor), with the largest
/// interval budget, so compression does not enter.
pub fn tessellation_error(
    scene: &FrameScene,
    view: usize,
    segments: u32,
    paths: VertexPaths,
    stride: u32,
) -> TessellationError {
    let (mut n, mut max, mut sum, mut signed) = (0u64, 0.0f64, 0.0f64, 0.0f64);
    if let Some(v) = scene.views.get(view) {
        let cam = &v.camera;
        let camera = CameraFrame::new(cam);
        let tris = sphere_triangles(scene, &camera, segments, paths);
        let binned = bin(&tris, &camera, cam.width, cam.height);
        let budget = *super::INTERVALS_RANGE.end() as usize;
        let true_sphere = sphere::MovingSphere::of(scene);
        let mut stats = RasterStats::default();
        for y in (0..cam.height).step_by(stride.max(1) as usize) {
            for x in (0..cam.width).step_by(stride.max(1) as usize) {
                let pixel = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                let here = binned.iter().filter(|b| b.covers(x, y));
                let list =
                    rasterize_sample(here, camera.sample(pixel), budget, SEARCH_RANGE_OPAQUE, &mut stats, |_, _, _| {
                        ([1.0; 3], 0)
                    });
                let tessellated = resolve_opaque(&list, [0.0; 3]).1;
                let exact = true_sphere.coverage(cam.position, cam.ray_direction(pixel));
                if tessellated > 0.0 || exact > 0.0 {
                    let d = tessellated - exact;
                    n += 1;
                    max = max.max(d.abs());
                    sum += d.abs();
                    signed += d;
                }
            }
        }
    }
    let mean_of = |s: f64| if n > 0 { s / n as f64 } else { 0.0 };
    let paths = match paths {
        VertexPaths::Translated => "translated",
        VertexPaths::RollingChords => "rolling_chords",
    };
    TessellationError { segments, paths, samples: n, max, mean: mean_of(sum), bias: mean_of(signed) }
}
