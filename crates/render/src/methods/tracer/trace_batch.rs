//! The CPU twin of `trace_batch.wgsl`, the tracer's kernel, in f32: [`trace_batch`] is the
//! kernel's entry point with the same arguments (the frame's parameters, a batch, the
//! environment buffer, the accumulators, the specialisation; [`trace_pixel`] is its
//! per-invocation body), shading with the shading layer's twin
//! ([`crate::shading::gpu::radiance`]). [`render_frame`] renders a whole frame with it: the
//! reference the kernel's f32 numerics are tested against the f64 tracer with.

use glam::Vec3;
use study::scene::FrameScene;

use crate::io::LinearImage;
use crate::shading::gpu::params::{Accum, Batch, EnvTables, FrameParams, ParamsError, Specialisation, material_kind};
use crate::shading::gpu::radiance::{SphereAt, TAU, is_finite3, normalize3, radiance, sample_2d, sin_cos_turns, xyz};
use crate::shading::gpu::sampler32::{pixel_seed, sample_1d_bits, to_unit};
use crate::shading::sampler::dim;

/// The sphere at the time of fraction `u` of the shutter.
fn sphere_at(p: &FrameParams, spec: &Specialisation, u: f32) -> SphereAt {
    let mut s = SphereAt { centre: xyz(p.centre_open), radius: p.centre_open[3], spin_sc: (0.0, 1.0) };
    if spec.time_sampling {
        s.centre += xyz(p.travel) * u;
        if u >= p.travel[3] {
            s.centre += xyz(p.wrap_jump);
        }
        if spec.material != material_kind::FLAT {
            let (sn, cs) = sin_cos_turns(-p.spin[3] * u / TAU);
            s.spin_sc = (sn, cs);
        }
    }
    s
}

/// One pixel's samples of `batch`, added to `acc` (the kernel's per-invocation body).
pub fn trace_pixel(
    p: &FrameParams,
    batch: &Batch,
    env: &[u32],
    spec: &Specialisation,
    x: u32,
    y: u32,
    acc: &mut Accum,
) {
    let seed = pixel_seed(p.eye_seed, y * p.width + x);
    let inv_spp = p.floor_albedo[3];
    let (corner, sx, sy) = (xyz(p.cam_corner), xyz(p.cam_step_x), xyz(p.cam_step_y));
    let mut sum = Vec3::from_array(acc.sum);
    for i in 0..batch.count {
        let index = batch.first_sample + i;
        let u = if spec.pixel_jitter { sample_2d(seed, index, dim::PIXEL) } else { [0.5, 0.5] };
        let dir = normalize3(corner + sx * (x as f32 + u[0]) + sy * (y as f32 + u[1]));
        let t = if spec.time_sampling { to_unit(sample_1d_bits(seed, index, dim::TIME)) } else { 0.0 };
        let s = sphere_at(p, spec, t);
        let l = radiance(p, spec, env, &s, seed, index, dir);
        if is_finite3(l) {
            sum += l * inv_spp;
        } else {
            acc.nonfinite += 1;
        }
    }
    acc.sum = sum.to_array();
}

/// The kernel's entry point `trace_batch` over the whole image: adds `batch`'s samples of
/// every pixel to `accum` (one per pixel, row-major).
pub fn trace_batch(p: &FrameParams, batch: &Batch, env: &[u32], accum: &mut [Accum], spec: &Specialisation) {
    for y in 0..p.height {
        for x in 0..p.width {
            trace_pixel(p, batch, env, spec, x, y, &mut accum[(y * p.width + x) as usize]);
        }
    }
}

/// Renders every view of `scene` with the twin, the whole sample count as one batch (the
/// same sums as the GPU's batches: each carries the pixel's f32 sum on): the images and the
/// discarded samples. Rows run in parallel.
pub fn render_frame(
    scene: &FrameScene,
    env: &EnvTables,
    spec: &Specialisation,
) -> Result<(Vec<LinearImage>, u64), ParamsError> {
    use rayon::prelude::*;
    let batch = Batch { first_sample: 0, count: scene.samples_per_pixel, pad: [0; 2] };
    let mut eyes = Vec::new();
    let mut nonfinite = 0;
    for view in &scene.views {
        let p = FrameParams::new(scene, view, env)?;
        let mut accum = vec![Accum::default(); (p.width * p.height) as usize];
        accum.par_chunks_mut(p.width as usize).enumerate().for_each(|(y, row)| {
            for (x, acc) in row.iter_mut().enumerate() {
                trace_pixel(&p, &batch, &env.words, spec, x as u32, y as u32, acc);
            }
        });
        let mut img = LinearImage::new(p.width, p.height);
        for (dst, a) in img.pixels.iter_mut().zip(&accum) {
            *dst = a.sum;
            nonfinite += u64::from(a.nonfinite);
        }
        eyes.push(img);
    }
    Ok((eyes, nonfinite))
}
