//! The rasterizer's benchmark: milliseconds per frame of the study scene's benchmark frame
//! (M3-S3-T5, the sphere nearest the image centre, `crate::measure::tracer::benchmark_frame`)
//! at a given size and interval budget, with the average and largest number of intervals
//! offered per pixel (the paper reports 16 s per frame single-threaded, and 7.2 and 177
//! intervals for its bunny scene), and the machine. `blurlab bench analytic` prints it.
//! With a GPU ([`BenchOptions::gpu`]) the WGSL kernel renders the same frame in the same
//! run: wall and timestamp milliseconds, and its speed-up over the CPU rasterizer (the only
//! figure that means something on a software adapter such as lavapipe).

use std::time::Instant;

use serde_json::{Value, json};
use study::design::Design;

use crate::env::EnvironmentMap;
use crate::methods::analytic::{AnalyticParams, render_frame};

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct BenchOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The rasterizer's settings.
    pub params: AnalyticParams,
    /// Lighting samples per shading evaluation (the frame's A1 level by default).
    pub spp: u32,
    /// Timed rounds (after one untimed warm-up).
    pub rounds: u32,
    /// Also time the GPU kernel, on the first adapter found (hardware first).
    pub gpu: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions { width: 640, height: 360, params: AnalyticParams::default(), spp: 4, rounds: 3, gpu: false }
    }
}

/// Renders the benchmark frame of `design` `opts.rounds` times and reports the timings.
pub fn run(design: &Design, opts: &BenchOptions) -> Result<Value, String> {
    let mut scene = crate::measure::tracer::benchmark_frame(design, opts.spp, false).map_err(|e| e.to_string())?;
    for view in &mut scene.views {
        (view.camera.width, view.camera.height) = (opts.width, opts.height);
    }
    let env = EnvironmentMap::from_lighting(&scene.lighting).map_err(|e| e.to_string())?;
    let warm = render_frame(&scene, &env, &opts.params).map_err(|e| e.to_string())?;
    let mut ms = Vec::new();
    for _ in 0..opts.rounds.max(1) {
        let start = Instant::now();
        let frame = render_frame(&scene, &env, &opts.params).map_err(|e| e.to_string())?;
        ms.push(start.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(frame);
    }
    let mean = ms.iter().sum::<f64>() / ms.len() as f64;
    let best = ms.iter().copied().fold(f64::INFINITY, f64::min);
    let st = warm.stats;
    let gpu = if opts.gpu { Some(run_gpu(&scene, &env, opts, mean)?) } else { None };
    Ok(json!({
        "benchmark": "analytic",
        "stimulus": "M3-S3-T5",
        "frame": scene.frame,
        "width": opts.width,
        "height": opts.height,
        "intervals_budget": opts.params.intervals,
        "tessellation": opts.params.tessellation,
        "lighting_samples": opts.params.lighting_samples.unwrap_or(opts.spp),
        "threads": rayon::current_num_threads(),
        "ms_per_frame": { "mean": mean, "best": best, "rounds": ms },
        "supersampling": opts.params.supersampling,
        // Per sample point: with supersampling, n x n of them per pixel.
        "intervals_per_pixel": { "mean": st.mean_intervals(), "max": st.max_intervals },
        "shaded_intervals": st.shaded,
        "merges": st.merges,
        "paper_ms_per_frame_single_threaded": 16000.0,
        "target_ms_per_frame": 500.0,
        "gpu": gpu,
        "machine": crate::measure::tracer::machine_json(),
    }))
}

fn ms_stats(ms: &[f64]) -> Value {
    let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
    json!({ "mean": mean, "best": ms.iter().copied().fold(f64::INFINITY, f64::min), "rounds": ms })
}

/// The GPU kernel on the same frame: wall and timestamp milliseconds, the speed-up over the
/// CPU rasterizer's `cpu_mean_ms`, and how far its image is from the CPU one (different
/// shading samples: a noise-level difference, not zero).
fn run_gpu(
    scene: &study::scene::FrameScene,
    env: &EnvironmentMap,
    opts: &BenchOptions,
    cpu_mean_ms: f64,
) -> Result<Value, String> {
    let ctx =
        ::gpu::acquire(::gpu::AdapterChoice::HardwareThenSoftware, &crate::methods::tracer::host::device_request())
            .map_err(|e| e.to_string())?;
    let adapter = ctx.info.short();
    let software = ctx.info.is_software;
    let tracer = crate::methods::tracer::GpuTracer::new(ctx.clone()).map_err(|e| e.to_string())?;
    let genv = tracer.environment(env).map_err(|e| e.to_string())?;
    let kernel = crate::methods::analytic::GpuAnalytic::new(ctx).map_err(|e| e.to_string())?;
    let warm = kernel.render_frame(scene, &genv, &opts.params).map_err(|e| e.to_string())?;
    let (mut wall, mut stamps) = (Vec::new(), Vec::new());
    for _ in 0..opts.rounds.max(1) {
        let start = Instant::now();
        let frame = kernel.render_frame(scene, &genv, &opts.params).map_err(|e| e.to_string())?;
        wall.push(start.elapsed().as_secs_f64() * 1e3);
        if let Some(s) = frame.gpu_seconds {
            stamps.push(s * 1e3);
        }
    }
    let wall_mean = wall.iter().sum::<f64>() / wall.len() as f64;
    let st = warm.stats;
    Ok(json!({
        "adapter": adapter,
        "software_adapter": software,
        "ms_per_frame_wall": ms_stats(&wall),
        "ms_per_frame_timestamps": if stamps.is_empty() { Value::Null } else { ms_stats(&stamps) },
        "cpu_over_gpu_wall": cpu_mean_ms / wall_mean,
        "supersampling": opts.params.supersampling,
        // Per sample point: with supersampling, n x n of them per pixel.
        "intervals_per_pixel": { "mean": st.mean_intervals(), "max": st.max_intervals },
        "shaded_intervals": st.shaded,
        "merges": st.merges,
    }))
}
