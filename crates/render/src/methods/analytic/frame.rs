//! The frame renderer: every view of a frame rasterized over the shutter. Triangles are set
//! up once ([`TriangleSetup`]), those facing away for the whole shutter culled, binned into 16x16-pixel tiles by the screen bounds of their
//! motion (the hull of the vertices' projections at open and close, or the whole image when
//! a vertex has `w <= 0` at either end), and the tiles are rendered in parallel with rayon.
//! Each pixel has one sample point at its centre (the paper's setting: the analytic
//! visibility removes temporal, not spatial, aliasing) and one interval list: triangles
//! arrive in a fixed order (the sphere, then the floor), each visibility interval is
//! inserted with the opaque `LESS_EQUAL` rules and shaded if kept, and the list is
//! compressed to its budget after each insertion; the opaque resolve gives the pixel.
//! Nothing depends on the thread count or tiling: the same scene gives the same bytes.

use glam::DVec2;
use rayon::prelude::*;

use super::edge::TriangleSetup;
use super::geometry::{CameraFrame, MovingTriangle};
use super::interval::{Insertion, Interval, compress, insert_opaque};
use super::resolve::resolve_opaque;

/// Tile side in pixels.
pub const TILE: u32 = 16;

/// Per-pixel counts of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RasterStats {
    /// Pixels rendered.
    pub pixels: u64,
    /// Visibility intervals offered to the pixels' lists (before the `LESS_EQUAL` rules and
    /// compression), over all pixels.
    pub intervals: u64,
    /// The most intervals offered to one pixel.
    pub max_intervals: u32,
    /// Intervals kept and shaded.
    pub shaded: u64,
    /// Merges done by the compression.
    pub merges: u64,
    /// Lighting samples dropped as NaN or infinite.
    pub nonfinite: u64,
}

impl RasterStats {
    /// Adds `o`'s counts.
    pub fn add(&mut self, o: &RasterStats) {
        self.pixels += o.pixels;
        self.intervals += o.intervals;
        self.max_intervals = self.max_intervals.max(o.max_intervals);
        self.shaded += o.shaded;
        self.merges += o.merges;
        self.nonfinite += o.nonfinite;
    }

    /// Mean intervals offered per pixel.
    pub fn mean_intervals(&self) -> f64 {
        if self.pixels == 0 { 0.0 } else { self.intervals as f64 / self.pixels as f64 }
    }
}

/// A set-up triangle with its pixel bounds `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug)]
pub struct Binned {
    /// The triangle as given.
    pub triangle: MovingTriangle,
    /// Its edge equations' constants.
    pub setup: TriangleSetup,
    /// Pixel bounds, `[x0, x1, y0, y1]`.
    pub bounds: [u32; 4],
}

impl Binned {
    /// Whether pixel `(x, y)` lies within its bounds.
    pub fn covers(&self, x: u32, y: u32) -> bool {
        let [x0, x1, y0, y1] = self.bounds;
        x >= x0 && x < x1 && y >= y0 && y < y1
    }
}

/// The pixel bounds of `tri`'s motion in a `width` x `height` image of `camera`, or `None`
/// when it is behind the eye throughout.
pub fn pixel_bounds(tri: &MovingTriangle, camera: &CameraFrame, width: u32, height: u32) -> Option<[u32; 4]> {
    let all = [tri.open, tri.close].concat();
    if all.iter().all(|p| p.z <= 0.0) {
        return None;
    }
    if all.iter().any(|p| p.z <= 0.0 || !p.is_finite()) {
        return Some([0, width, 0, height]);
    }
    let origin = camera.sample(DVec2::ZERO);
    let step = camera.sample(DVec2::ONE) - origin;
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in &all {
        let px = (DVec2::new(p.x / p.z, p.y / p.z) - origin) / step;
        lo = lo.min(px);
        hi = hi.max(px);
    }
    // Pixel i's sample is at i + 0.5; one pixel of margin for rounding.
    let clamp = |v: f64, n: u32| v.clamp(0.0, f64::from(n)) as u32;
    let b = [
        clamp(lo.x.floor() - 1.0, width),
        clamp(hi.x.ceil() + 1.0, width),
        clamp(lo.y.floor() - 1.0, height),
        clamp(hi.y.ceil() + 1.0, height),
    ];
    (b[0] < b[1] && b[2] < b[3]).then_some(b)
}

/// Sets up and bins `triangles` for an image.
pub fn bin(triangles: &[MovingTriangle], camera: &CameraFrame, width: u32, height: u32) -> Vec<Binned> {
    triangles
        .iter()
        .filter_map(|t| {
            let setup = TriangleSetup::new(t);
            // A one-sided triangle facing away for the whole shutter covers no sample.
            if setup.back_facing_throughout() {
                return None;
            }
            pixel_bounds(t, camera, width, height).map(|bounds| Binned { triangle: *t, setup, bounds })
        })
        .collect()
}

/// The indices into `binned` of the triangles whose bounds meet each `tile` x `tile`-pixel
/// tile of a `width` x `height` image, tiles in rows, triangles in order.
pub fn tile_bins(binned: &[Binned], width: u32, height: u32, tile: u32) -> Vec<Vec<u32>> {
    let (tw, th) = (width.div_ceil(tile), height.div_ceil(tile));
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); (tw * th) as usize];
    for (i, b) in binned.iter().enumerate() {
        let [x0, x1, y0, y1] = b.bounds;
        for ty in y0 / tile..y1.div_ceil(tile).min(th) {
            for tx in x0 / tile..x1.div_ceil(tile).min(tw) {
                bins[(ty * tw + tx) as usize].push(i as u32);
            }
        }
    }
    bins
}

/// The interval list of one sample point `s` at pixel `(x, y)` after every triangle of
/// `tris` (in order) has been inserted and the list compressed to `budget` with search
/// range `range`. `shade(binned, interval, index)` gives a kept interval's colour and its
/// dropped lighting samples.
pub fn rasterize_sample<'t>(
    tris: impl IntoIterator<Item = &'t Binned>,
    s: DVec2,
    budget: usize,
    range: usize,
    stats: &mut RasterStats,
    mut shade: impl FnMut(&Binned, &Interval, u32) -> ([f64; 3], u64),
) -> Vec<Interval> {
    let mut list: Vec<Interval> = Vec::with_capacity(budget + 1);
    let mut offered = 0u32;
    let mut kept = 0u32;
    for b in tris {
        let vis = b.setup.visibility(s);
        for &(ts, te) in vis.spans() {
            offered += 1;
            let (z, k) = b.setup.linear_depth(s, ts, te);
            let iv = Interval { ts, te, z, k, color: [0.0; 3], alpha: 1.0 };
            let index = kept;
            let mut bad = 0;
            let done = insert_opaque(&mut list, iv, |kept| {
                let (c, nb) = shade(b, kept, index);
                bad = nb;
                c
            });
            if let Insertion::Inserted { .. } = done {
                kept += 1;
                stats.shaded += 1;
                stats.nonfinite += bad;
                stats.merges += compress(&mut list, budget, range) as u64;
            }
        }
    }
    stats.pixels += 1;
    stats.intervals += u64::from(offered);
    stats.max_intervals = stats.max_intervals.max(offered);
    list
}

/// The fraction of the shutter in which any of `triangles` covers sample point `s`
/// (unshaded; compressed to `budget`): the rasterizer's per-sample coverage.
pub fn sample_coverage(triangles: &[MovingTriangle], s: DVec2, budget: usize) -> f64 {
    let binned: Vec<Binned> = triangles
        .iter()
        .map(|t| Binned { triangle: *t, setup: TriangleSetup::new(t), bounds: [0, u32::MAX, 0, u32::MAX] })
        .collect();
    let mut stats = RasterStats::default();
    let list =
        rasterize_sample(&binned, s, budget, super::interval::SEARCH_RANGE_OPAQUE, &mut stats, |_, _, _| ([1.0; 3], 0));
    resolve_opaque(&list, [0.0; 3]).1
}

/// Renders one image: `shade(binned, interval, s, x, y, index)` colours kept intervals,
/// `background(s)` is seen where nothing covers. Parallel over tiles; deterministic.
#[allow(clippy::too_many_arguments)]
pub fn render_image<S, B>(
    triangles: &[MovingTriangle],
    camera: &CameraFrame,
    width: u32,
    height: u32,
    budget: usize,
    range: usize,
    shade: S,
    background: B,
) -> (Vec<[f32; 3]>, RasterStats)
where
    S: Fn(&Binned, &Interval, DVec2, u32, u32, u32) -> ([f64; 3], u64) + Sync,
    B: Fn(DVec2) -> [f64; 3] + Sync,
{
    let binned = bin(triangles, camera, width, height);
    let (tw, th) = (width.div_ceil(TILE), height.div_ceil(TILE));
    let bins = tile_bins(&binned, width, height, TILE);
    let tiles: Vec<(Vec<[f32; 3]>, RasterStats)> = (0..tw * th)
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tw) * TILE, (tile / tw) * TILE);
            let (x1, y1) = ((x0 + TILE).min(width), (y0 + TILE).min(height));
            let mut stats = RasterStats::default();
            let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let list = &bins[tile as usize];
            for y in y0..y1 {
                for x in x0..x1 {
                    let s = camera.sample(DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5));
                    let here = list.iter().map(|&i| &binned[i as usize]).filter(|b| b.covers(x, y));
                    let ivs = rasterize_sample(here, s, budget, range, &mut stats, |b, iv, index| {
                        shade(b, iv, s, x, y, index)
                    });
                    let bg = background(s);
                    let (sum, covered) = resolve_opaque(&ivs, [0.0; 3]);
                    let rest = (1.0 - covered).max(0.0);
                    pixels.push([0, 1, 2].map(|c| (sum[c] + rest * bg[c]) as f32));
                }
            }
            (pixels, stats)
        })
        .collect();
    let mut image = vec![[0.0f32; 3]; (width * height) as usize];
    let mut stats = RasterStats::default();
    for (tile, (pixels, st)) in tiles.iter().enumerate() {
        let tile = tile as u32;
        let (x0, y0) = ((tile % tw) * TILE, (tile / tw) * TILE);
        let x1 = (x0 + TILE).min(width);
        let w = x1 - x0;
        for (i, p) in pixels.iter().enumerate() {
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            image[(y * width + x) as usize] = *p;
        }
        stats.add(st);
    }
    (image, stats)
}
