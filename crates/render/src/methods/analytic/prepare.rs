//! The analytic rasterizer on the GPU: the kernel `analytic_pixel.wgsl` (one invocation
//! per pixel, the pixel's interval list in a storage buffer with a fixed budget), its f32 CPU
//! twin [`super::analytic_pixel`], and the host [`super::host::GpuAnalytic`] read.
//!
//! What the kernel reads is prepared here, once per view, by the same code for the GPU and
//! the twin ([`Prepared::new`]): the tracer kernel's [`FrameParams`] (camera, sphere,
//! materials, environment: the kernel includes the shading layer's `radiance.wgsl` and shades with its integrator),
//! the rasterizer's [`RasterParams`], the moving triangles set up in f64 by
//! [`TriangleSetup`] and rounded once to f32 ([`GpuTriangle`]: rounding is symmetric, so an
//! edge shared with reversed vertices still negates exactly), and the [`TILE`]-pixel tile bins.
//!
//! Differences from the f64 rasterizer ([`crate::methods::analytic::frame`]), all forced by f32 and
//! WGSL and all measured by `tests/analytic_gpu.rs`: arithmetic is f32; the resolve computes,
//! for each entry, the part of its span where no other entry is nearer (an earlier entry
//! must be strictly nearer, a later one as near: the sweep's tie rule), which is the sweep's
//! integral without an event list whose length grows with the square of the budget; shading
//! uses the tracer kernel's u32 sampler, seeded from the eye's seed and [`ANALYTIC_STREAM`].

use bytemuck::{Pod, Zeroable};
use study::scene::{EyeView, FrameScene};

use super::AnalyticParams;
use super::edge::TriangleSetup;
use super::frame::{bin, tile_bins};
use super::geometry::{CameraFrame, SurfaceKind, scene_triangles};
use super::interval::SEARCH_RANGE_OPAQUE;
use crate::shading::gpu::params::{EnvTables, FrameParams, ParamsError};

/// Tile side of the kernel's bins in pixels (`ANALYTIC_TILE` in WGSL): smaller than the CPU
/// rasterizer's, so a pixel walks fewer triangles (see the kernel on llvmpipe's loop limit).
pub const TILE: u32 = 8;

/// Mixed into the eye's seed for the shading samples (distinct from the tracer's streams).
pub const ANALYTIC_STREAM: u32 = 0xA7A1_0C5E;

/// The rasterizer's uniform parameters (`AnalyticParams` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RasterParams {
    /// Camera right axis (world), w unused.
    pub right: [f32; 4],
    /// Camera up axis.
    pub up: [f32; 4],
    /// Camera viewing axis.
    pub forward: [f32; 4],
    /// Sample point of pixel position (0, 0) (x, y) and the step per pixel (z, w).
    pub sample_corner_step: [f32; 4],
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// First row of the band a dispatch renders.
    pub first_row: u32,
    /// Rows in the band.
    pub band_rows: u32,
    /// Interval budget per pixel.
    pub budget: u32,
    /// Compression search range.
    pub range: u32,
    /// Lighting samples per shading evaluation.
    pub lighting: u32,
    /// Tiles per row.
    pub tiles_x: u32,
    /// Sample points per output pixel along each axis (the image is the supersampled one:
    /// its `n x n` blocks are output pixels, which own the shading's sample sequences).
    pub supersampling: u32,
    /// Which pass over the band this dispatch is (0 starts every pixel's work; later passes
    /// resume it): see [`super::host::GpuAnalytic::render_view`].
    pub pass_index: u32,
    /// Steps one pass takes at most per pixel (0: no bound, the whole pixel in one pass).
    pub steps: u32,
    /// Lighting samples one shading step takes at most (0: all of the interval's).
    pub light_chunk: u32,
    /// The trip count of the kernel's loop-limit detector (2).
    pub sentinel: u32,
    /// Padding to 16 bytes.
    pub pad: [u32; 3],
}

/// A moving triangle as the kernel reads it (`Triangle` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// `[C0, C1, C2]` of edge 0, 1, 2 (xyz; w unused).
    pub edges: [[[f32; 4]; 3]; 3],
    /// Vertices at shutter open.
    pub base: [[f32; 4]; 3],
    /// Vertex motion over the shutter.
    pub motion: [[f32; 4]; 3],
    /// Pixel bounds `[x0, x1, y0, y1]`.
    pub bounds: [u32; 4],
    /// Surface (1 sphere, 2 floor), two-sided, static, unused.
    pub flags: [u32; 4],
}

/// One interval of a pixel's list (`Interval` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInterval {
    /// Start.
    pub ts: f32,
    /// End.
    pub te: f32,
    /// Depth at the start.
    pub z: f32,
    /// Depth slope.
    pub k: f32,
    /// Radiance.
    pub r: f32,
    /// Radiance.
    pub g: f32,
    /// Radiance.
    pub b: f32,
    /// Unused.
    pub pad: f32,
}

/// Per-pixel counts (`PixelStats` in WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PixelStats {
    /// Visibility intervals offered to the list.
    pub offered: u32,
    /// Intervals kept and shaded.
    pub kept: u32,
    /// Merges of the compression.
    pub merges: u32,
    /// Lighting samples dropped as NaN or infinite.
    pub nonfinite: u32,
}

/// The surface codes of the tracer kernel.
const SURFACE_SPHERE: u32 = 1;
const SURFACE_FLOOR: u32 = 2;

fn v4(v: glam::DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// Everything the kernel reads for one view.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The tracer kernel's parameters (camera, sphere, materials, environment layout).
    pub frame: FrameParams,
    /// The rasterizer's parameters (`first_row`, `band_rows` cover the whole image).
    pub raster: RasterParams,
    /// The triangles that may cover some pixel, in the f64 rasterizer's order.
    pub triangles: Vec<GpuTriangle>,
    /// Tile bins: `tiles + 1` offsets into the triangle indices that follow them.
    pub bins: Vec<u32>,
}

impl Prepared {
    /// Prepares view `view` of `scene` for the kernel with `params`.
    pub fn new(
        scene: &FrameScene,
        view: &EyeView,
        env: &EnvTables,
        params: &AnalyticParams,
    ) -> Result<Self, ParamsError> {
        let mut frame = FrameParams::new(scene, view, env)?;
        let cam = &view.camera;
        // Texture footprints are the output pixel's, as the tracer filters a pixel's samples.
        let n = params.supersampling.max(1);
        frame.cam_origin[3] = (crate::shading::camera::CameraRays::new(cam).pixel_angle * f64::from(n)) as f32;
        let camera = CameraFrame::new(cam);
        let (width, height) = (cam.width, cam.height);
        let binned = bin(&scene_triangles(scene, &camera, params.tessellation), &camera, width, height);
        let triangles: Vec<GpuTriangle> = binned
            .iter()
            .map(|b| gpu_triangle(&b.setup, b.triangle.surface, b.triangle.is_static(), b.bounds))
            .collect();
        let tw = width.div_ceil(TILE);
        let per_tile = tile_bins(&binned, width, height, TILE);
        let head = per_tile.len() as u32 + 1;
        let mut bins = Vec::with_capacity(head as usize + per_tile.iter().map(Vec::len).sum::<usize>());
        let mut at = head;
        for list in &per_tile {
            bins.push(at);
            at += list.len() as u32;
        }
        bins.push(at);
        for list in &per_tile {
            bins.extend_from_slice(list);
        }
        let corner = camera.sample(glam::DVec2::ZERO);
        let step = camera.sample(glam::DVec2::ONE) - corner;
        let lighting = params.lighting_samples.unwrap_or(scene.samples_per_pixel).max(1);
        let raster = RasterParams {
            right: v4(camera.right),
            up: v4(camera.up),
            forward: v4(camera.forward),
            sample_corner_step: [corner.x as f32, corner.y as f32, step.x as f32, step.y as f32],
            width,
            height,
            first_row: 0,
            band_rows: height,
            budget: params.intervals,
            range: SEARCH_RANGE_OPAQUE as u32,
            lighting,
            tiles_x: tw,
            supersampling: params.supersampling.max(1),
            pass_index: 0,
            steps: 0,
            light_chunk: 0,
            sentinel: 2,
            pad: [0; 3],
        };
        Ok(Prepared { frame, raster, triangles, bins })
    }
}

/// `setup` rounded to f32 for the kernel.
pub fn gpu_triangle(setup: &TriangleSetup, surface: SurfaceKind, is_static: bool, bounds: [u32; 4]) -> GpuTriangle {
    GpuTriangle {
        edges: setup.edges.map(|e| e.map(v4)),
        base: setup.base.map(v4),
        motion: setup.motion.map(v4),
        bounds,
        flags: [
            match surface {
                SurfaceKind::Sphere => SURFACE_SPHERE,
                SurfaceKind::Floor => SURFACE_FLOOR,
            },
            u32::from(setup.two_sided),
            u32::from(is_static),
            0,
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_assembles_and_validates() {
        let source = super::super::host::kernel_source().unwrap();
        ::gpu::validate_wgsl("analytic_pixel.wgsl", &source).unwrap();
        assert!(source.contains("fn radiance_from(") && source.contains("fn analytic_pixel("));
    }

    #[test]
    fn layouts_match_the_wgsl_structs() {
        assert_eq!(std::mem::size_of::<RasterParams>(), 128);
        assert_eq!(std::mem::size_of::<GpuTriangle>(), 15 * 16 + 32);
        assert_eq!(std::mem::size_of::<GpuInterval>(), 32);
        assert_eq!(std::mem::size_of::<PixelStats>(), 16);
    }
}
