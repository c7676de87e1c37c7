//! Measurements of the rasterizer's approximations. [`depth_error_histogram`] is the data of
//! the paper's Figure 10: for every visibility interval of a frame, the largest relative
//! error of its linear depth against the exact cubic-rational depth (Eq. 15), counted in
//! decade bins. (The paper measures the error relative to the far-near range of its depth
//! buffer; here it is relative to the true view depth, which is stricter for distant
//! surfaces.)

use glam::DVec2;
use serde::Serialize;
use study::scene::FrameScene;

use super::frame::bin;
use super::geometry::{CameraFrame, scene_triangles};

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

/// The histogram for view `view` of `scene` with the sphere tessellated into `segments`,
/// over every `stride`-th pixel in each direction.
pub fn depth_error_histogram(scene: &FrameScene, view: usize, segments: u32, stride: u32) -> DepthErrorHistogram {
    let decades: Vec<i32> = (-12..=-1).collect();
    let mut counts = vec![0u64; decades.len()];
    let (mut n, mut max, mut sum) = (0u64, 0.0f64, 0.0f64);
    if let Some(v) = scene.views.get(view) {
        let cam = &v.camera;
        let camera = CameraFrame::new(cam);
        let tris = scene_triangles(scene, &camera, segments);
        let binned = bin(&tris, &camera, cam.width, cam.height);
        let stride = stride.max(1);
        for y in (0..cam.height).step_by(stride as usize) {
            for x in (0..cam.width).step_by(stride as usize) {
                let s = camera.sample(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
                for b in
                    binned.iter().filter(|b| x >= b.bounds[0] && x < b.bounds[1] && y >= b.bounds[2] && y < b.bounds[3])
                {
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
