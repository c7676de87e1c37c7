//! Measurements of the rasterizer's approximations. [`depth_error_histogram`] is the data of
//! the paper's Figure 10: for every visibility interval of a frame, the largest relative
//! error of its linear depth against the exact cubic-rational depth (Eq. 15), counted in
//! decade bins. (The paper measures the error relative to the far-near range of its depth
//! buffer; here it is relative to the true view depth, which is stricter for distant
//! surfaces.) [`tessellation_error`] compares the tessellated sphere's coverage at each
//! pixel's sample point with the true sphere's ([`crate::methods::analytic::sphere`]): what the triangles and
//! their straight vertex paths cost before any compression.

use glam::DVec2;
use serde::Serialize;
use study::scene::FrameScene;

use crate::methods::analytic::frame::{RasterStats, bin, rasterize_sample};
use crate::methods::analytic::geometry::{CameraFrame, VertexPaths, floor_triangles, sphere_triangles};
use crate::methods::analytic::interval::SEARCH_RANGE_OPAQUE;
use crate::methods::analytic::resolve::resolve_opaque;
use crate::methods::analytic::sphere;

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
        let budget = *crate::methods::analytic::INTERVALS_RANGE.end() as usize;
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

/// The rasterizer's settings for [`contact_shadow_error`]: the defaults with 4 x 4 sample
/// points per pixel, so that a pixel's area is covered as the tracer covers it and what
/// remains is the shading's limit, not the one-point sampling's aliasing.
pub const SHADOW_PARAMS: crate::methods::analytic::AnalyticParams = crate::methods::analytic::AnalyticParams {
    intervals: crate::methods::analytic::DEFAULT_INTERVALS,
    tessellation: crate::methods::analytic::DEFAULT_TESSELLATION,
    lighting_samples: None,
    supersampling: 4,
};

/// The rasterizer's contact shadow against the tracer at one speed
/// ([`contact_shadow_error`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShadowError {
    /// The sphere's speed (degrees of visual angle per second).
    pub degrees_per_second: f64,
    /// The sphere's travel during the shutter, in sphere radii.
    pub travel_radii: f64,
    /// Pixels of the shadow region.
    pub pixels: u64,
    /// Mean luminance of the region in the tracer's frame.
    pub tracer_mean: f64,
    /// Mean luminance of the region in the rasterizer's frame.
    pub analytic_mean: f64,
    /// Mean absolute luminance difference over the region, relative to `tracer_mean`.
    pub mean_abs_error: f64,
    /// The darkest pixel of the region in the tracer's frame.
    pub tracer_darkest: f64,
    /// The darkest pixel of the region in the rasterizer's frame.
    pub analytic_darkest: f64,
}

/// The shadow region of view 0 of `scene`: the pixels whose ray meets the floor within two
/// sphere radii of the contact point's path over the shutter and passes farther than a
/// radius from the centre's path (so the sphere itself never covers them). Row-major
/// indices.
pub fn shadow_region(scene: &FrameScene) -> Vec<usize> {
    let Some(view) = scene.views.first() else { return Vec::new() };
    let cam = &view.camera;
    let camera = CameraFrame::new(cam);
    let s = &scene.sphere;
    let open = scene.shutter.open;
    let (c0, c1) = (s.centre_at(open), s.centre_at(open) + s.velocity * scene.shutter.duration());
    let floor = scene.floor.height;
    let mut out = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = camera.direction(camera.sample(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5)));
            if d.y >= 0.0 {
                continue;
            }
            let hit = camera.origin + d * ((floor - camera.origin.y) / d.y);
            let contact = |c: glam::DVec3| glam::DVec2::new(c.x, c.z);
            let near_path = segment_distance(glam::DVec2::new(hit.x, hit.z), contact(c0), contact(c1)) < 2.0 * s.radius;
            let covered = ray_segment_distance(camera.origin, d, c0, c1) < s.radius;
            if near_path && !covered {
                out.push((y * cam.width + x) as usize);
            }
        }
    }
    out
}

fn segment_distance(p: glam::DVec2, a: glam::DVec2, b: glam::DVec2) -> f64 {
    let ab = b - a;
    let u = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * u)).length()
}

/// The smallest distance between the ray `o + t d` (t >= 0) and the segment `a b`, by
/// sampling the segment finely (a measurement's region test, not a renderer's).
fn ray_segment_distance(o: glam::DVec3, d: glam::DVec3, a: glam::DVec3, b: glam::DVec3) -> f64 {
    (0..=64)
        .map(|i| {
            let p = a + (b - a) * (f64::from(i) / 64.0);
            let t = (p - o).dot(d).max(0.0);
            (o + d * t - p).length()
        })
        .fold(f64::INFINITY, f64::min)
}

fn luminance(p: [f32; 3]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Compares the rasterizer's frame `analytic` of `scene` with the tracer's `tracer` (view
/// 0 of each, the same size) in the [`shadow_region`]. The rasterizer shades each interval
/// once, at its temporal midpoint; the floor's interval spans the whole shutter, so the
/// sphere's moving contact shadow is shaded as it stands mid-shutter: a sharp dark ellipse
/// where the tracer shows a smear whose darkness is spread over the travel.
pub fn contact_shadow_error(
    scene: &FrameScene,
    degrees_per_second: f64,
    tracer: &crate::io::LinearImage,
    analytic: &crate::io::LinearImage,
) -> ShadowError {
    let region = shadow_region(scene);
    let n = region.len().max(1) as f64;
    let (mut t_sum, mut a_sum, mut abs_sum) = (0.0, 0.0, 0.0);
    let (mut t_min, mut a_min) = (f64::INFINITY, f64::INFINITY);
    for &i in &region {
        let (t, a) = (luminance(tracer.pixels[i]), luminance(analytic.pixels[i]));
        t_sum += t;
        a_sum += a;
        abs_sum += (t - a).abs();
        t_min = t_min.min(t);
        a_min = a_min.min(a);
    }
    let duration = scene.shutter.duration();
    ShadowError {
        degrees_per_second,
        travel_radii: scene.sphere.velocity.length() * duration / scene.sphere.radius,
        pixels: region.len() as u64,
        tracer_mean: t_sum / n,
        analytic_mean: a_sum / n,
        mean_abs_error: if t_sum > 0.0 { abs_sum / t_sum } else { abs_sum / n },
        tracer_darkest: t_min,
        analytic_darkest: a_min,
    }
}
