//! The wide CPU tracer: the f32 tracer of the GPU kernel's CPU twin
//! ([`super::trace_batch`]), traced sixteen camera samples at a time in SIMD lanes.
//!
//! It is a second implementation of the twin's algorithm, not a new one: every lane runs the
//! twin's operations in the twin's order ([`packet`]), and a pixel's samples are added in
//! index order, each divided by the sample count as the kernel adds them. A frame is
//! therefore **the same bytes** as [`super::trace_batch::render_frame`] (and its prefixes
//! those of the GPU tracer's nested read-outs), on every instruction set and thread count;
//! the twin, in turn, is held to the f64 reference ([`super::reference`]) within Monte
//! Carlo error and to the GPU per pixel.
//!
//! Why it is faster than the twin: sixteen samples share one pass through the bounce loop
//! (at 16 samples per pixel or more the lanes are the samples of one pixel, whose primary
//! rays are coherent; below that, every sample of several neighbouring pixels, so the lanes
//! stay full at the quick preset's and the accumulation buffer's few samples); the
//! scrambling seeds of a pixel's dimensions are hashed once per pixel, not once per value;
//! the light sample's CDF inversion bisects where the twin walks (the same cell); and each
//! row is compiled for the widest instruction set the CPU has ([`Isa`], chosen at run
//! time).
//!
//! [`Isa`] and run-time dispatch: `pulp` (a maintained crate of safe SIMD with run-time
//! detection, used by `faer`) compiles a closure with a target's features enabled and calls
//! it only where the CPU has them. The lanes ([`lanes`]) are plain fixed-size arrays the
//! compiler vectorises inside that closure, so one generic body serves AVX-512, AVX2 and the
//! SSE2 floor (NEON is the floor on aarch64): no `unsafe` in blurlab, and no intrinsics that
//! would tie the algorithm to one instruction set. No path fuses multiplies and adds (Rust
//! never contracts them), which is why every path gives the same bytes.

mod dispatch;
mod env;
mod lanes;
mod packet;

pub use dispatch::Isa;
use dispatch::Job;
use rayon::prelude::*;
use study::scene::FrameScene;

use self::lanes::{F, LANES, M, U};
use self::packet::{LaneSeeds, PixelSeeds, trace_packet};
use super::reference::FrameOutput;
use crate::io::LinearImage;
use crate::shading::gpu::params::{EnvTables, FrameParams, ParamsError, Specialisation};
use crate::shading::gpu::radiance::is_finite3;
use crate::shading::gpu::sampler32::pixel_seed;

/// Renders every view of `scene` on the widest instruction set.
pub fn render_frame(scene: &FrameScene, env: &EnvTables) -> Result<FrameOutput, ParamsError> {
    let mut levels = render_frame_nested(scene, env, &[], Isa::widest())?;
    Ok(levels.pop().unwrap_or(FrameOutput { eyes: Vec::new(), nonfinite_samples: 0, camera_samples: 0 }))
}

/// Renders every view of `scene` on `isa`, also read out after the first `k` samples per
/// pixel for each `k` of `checkpoints` below the scene's count: one output per distinct
/// checkpoint, fewest samples first, the full count last. A prefix is its pixels' sums
/// scaled by `spp / k`, as the GPU tracer reads its prefixes out.
///
/// `isa` must be available ([`Isa::available`]); an unavailable one renders on the widest
/// one available, which gives the same bytes.
pub fn render_frame_nested(
    scene: &FrameScene,
    env: &EnvTables,
    checkpoints: &[u32],
    isa: Isa,
) -> Result<Vec<FrameOutput>, ParamsError> {
    let spp = scene.samples_per_pixel;
    let mut levels: Vec<u32> = checkpoints.iter().copied().filter(|&k| k > 0 && k < spp).collect();
    levels.sort_unstable();
    levels.dedup();
    levels.push(spp);
    let isa = if isa.is_available() { isa } else { Isa::widest() };
    let spec = Specialisation::of(scene);
    let mut outputs: Vec<FrameOutput> = levels
        .iter()
        .map(|_| FrameOutput { eyes: Vec::with_capacity(scene.views.len()), nonfinite_samples: 0, camera_samples: 0 })
        .collect();
    for view in &scene.views {
        let p = FrameParams::new(scene, view, env)?;
        let rows: Vec<Vec<RowLevel>> = (0..p.height)
            .into_par_iter()
            .map(|y| isa.run(Row { p: &p, spec: &spec, env: &env.words, y, levels: &levels }))
            .collect();
        for (j, out) in outputs.iter_mut().enumerate() {
            let mut img = LinearImage::new(p.width, p.height);
            for (y, row) in rows.iter().enumerate() {
                let start = y * p.width as usize;
                img.pixels[start..start + p.width as usize].copy_from_slice(&row[j].pixels);
                out.nonfinite_samples += row[j].nonfinite;
            }
            out.camera_samples += u64::from(p.width) * u64::from(p.height) * u64::from(levels[j]);
            out.eyes.push(img);
        }
    }
    Ok(outputs)
}

/// The heap one rendering thread holds: a row of pixels per sample-count level and the
/// scrambling seeds of a pixel's dimensions, once per pixel and once per lane (the
/// environment's tables and the images are shared by all threads).
pub fn per_thread_heap_bytes(width: u32, levels: usize, max_bounces: u32) -> usize {
    let dims =
        (crate::shading::sampler::dim::BOUNCE_BASE + crate::shading::sampler::dim::PER_BOUNCE * max_bounces) as usize;
    levels * width as usize * std::mem::size_of::<[f32; 3]>()
        + dims * std::mem::size_of::<crate::shading::gpu::sampler32::DimSeeds>()
        + dims * 3 * std::mem::size_of::<U>()
}

/// The state one packet carries through the bounce loop (ray, hit, sphere, throughput,
/// radiance and the per-vertex values; in registers and on the stack).
pub fn packet_state_bytes() -> usize {
    packet::state_bytes()
}

/// One row at one sample count: its pixels and discarded samples.
struct RowLevel {
    pixels: Vec<[f32; 3]>,
    nonfinite: u64,
}

/// Row `y` at every level of `levels` (increasing, the last the full count).
struct Row<'a> {
    p: &'a FrameParams,
    spec: &'a Specialisation,
    env: &'a [u32],
    y: u32,
    levels: &'a [u32],
}

impl Job for Row<'_> {
    type Output = Vec<RowLevel>;

    #[inline(always)]
    fn call(self) -> Vec<RowLevel> {
        let Row { p, spec, env, y, levels } = self;
        trace_row(p, spec, env, y, levels)
    }
}

/// A pixel's running sum: its samples added in index order, read out at each level.
struct PixelSum {
    sum: glam::Vec3,
    bad: u64,
    next: usize,
}

impl PixelSum {
    const NEW: PixelSum = PixelSum { sum: glam::Vec3::ZERO, bad: 0, next: 0 };

    /// Adds sample `index` (radiance `l`); pushes a level's pixel when it is complete.
    #[inline(always)]
    fn add(&mut self, l: glam::Vec3, index: u32, inv_spp: f32, spp: u32, levels: &[u32], out: &mut [RowLevel]) {
        if is_finite3(l) {
            self.sum += l * inv_spp;
        } else {
            self.bad += 1;
        }
        let done = index + 1;
        if self.next + 1 < levels.len() && done == levels[self.next] {
            let scale = spp as f32 / done as f32;
            out[self.next].pixels.push((self.sum * scale).to_array());
            out[self.next].nonfinite += self.bad;
            self.next += 1;
        }
    }

    /// Pushes the pixel at the full count.
    #[inline(always)]
    fn finish(self, out: &mut [RowLevel]) {
        let last = out.len() - 1;
        out[last].pixels.push(self.sum.to_array());
        out[last].nonfinite += self.bad;
    }
}

/// Row `y`: with at least [`LANES`] samples per pixel, each pixel's samples in packets of
/// [`LANES`] consecutive ones; with fewer, every sample of `LANES / spp` neighbouring pixels
/// in one packet, so that the lanes stay full at the study's 1 to 12 samples per pixel.
/// Either way each pixel's samples are added in index order, so the bytes are the same.
#[inline(always)]
fn trace_row(p: &FrameParams, spec: &Specialisation, env: &[u32], y: u32, levels: &[u32]) -> Vec<RowLevel> {
    let spp = levels.last().copied().unwrap_or(0);
    let inv_spp = p.floor_albedo[3];
    let mut out: Vec<RowLevel> =
        levels.iter().map(|_| RowLevel { pixels: Vec::with_capacity(p.width as usize), nonfinite: 0 }).collect();
    let mut seeds = PixelSeeds::new(p.max_bounces);
    let mut lane_seeds = LaneSeeds::new(p.max_bounces);
    let lanes = LANES as u32;
    if spp >= lanes || spp == 0 {
        for x in 0..p.width {
            seeds.set_pixel(pixel_seed(p.eye_seed, y * p.width + x));
            lane_seeds.set_all(&seeds);
            let mut pixel = PixelSum::NEW;
            let mut first = 0u32;
            while first < spp {
                let count = (spp - first).min(lanes);
                let l = trace_packet(p, spec, env, &lane_seeds, F::splat(x as f32), y, U::ramp(first), M::first(count));
                for i in 0..count {
                    pixel.add(l.lane(i as usize), first + i, inv_spp, spp, levels, &mut out);
                }
                first += count;
            }
            pixel.finish(&mut out);
        }
        return out;
    }
    let per_packet = lanes / spp;
    let mut x0 = 0;
    while x0 < p.width {
        let pixels = per_packet.min(p.width - x0);
        let (mut xs, mut index) = (F::splat(0.0), U::splat(0));
        for k in 0..pixels {
            let x = x0 + k;
            seeds.set_pixel(pixel_seed(p.eye_seed, y * p.width + x));
            let lanes = (k * spp) as usize..((k + 1) * spp) as usize;
            lane_seeds.set_lanes(lanes.clone(), &seeds);
            for (i, lane) in lanes.enumerate() {
                (xs.0[lane], index.0[lane]) = (x as f32, i as u32);
            }
        }
        let l = trace_packet(p, spec, env, &lane_seeds, xs, y, index, M::first(pixels * spp));
        for k in 0..pixels {
            let mut pixel = PixelSum::NEW;
            for i in 0..spp {
                pixel.add(l.lane((k * spp + i) as usize), i, inv_spp, spp, levels, &mut out);
            }
            pixel.finish(&mut out);
        }
        x0 += pixels;
    }
    out
}
