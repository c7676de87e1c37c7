//! Milliseconds per frame of morphological antialiasing (`blurlab bench mlaa`): the study's
//! benchmark frame (M3-S3-T5, the sphere at the image centre) frozen at its time (no blur,
//! so its edges are sharp), traced at the benchmark's size (1280x720 by default, the
//! thesis's screenshots' size) and mapped to display values as a participant sees them;
//! then MLAA's three passes on the GPU, timed by timestamp queries around the passes
//! (upload and read-back excluded) over several rounds, and its CPU twin on the same image
//! in the same run, so a software adapter's times are reported as a ratio against it.

use std::time::Instant;

use serde_json::{Value, json};
use study::design::Design;
use study::stats::median;

use crate::antialias::mlaa::host::GpuMlaa;
use crate::antialias::mlaa::{MlaaError, MlaaParams, edges, mlaa_cpu, weights};
use crate::io::display_value;

/// What to measure.
#[derive(Clone, Debug)]
pub struct MlaaTimingOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel of the traced image (its noise makes edges too).
    pub spp: u32,
    /// MLAA's settings.
    pub params: MlaaParams,
    /// Rounds of GPU timing (the median and the best are reported).
    pub rounds: u32,
    /// Rounds of CPU-twin timing.
    pub cpu_rounds: u32,
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum MlaaTimingError {
    /// The design cannot give the benchmark frame.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// The environment map could not be built.
    #[error(transparent)]
    Environment(#[from] crate::env::EnvError),
    /// MLAA refused or failed.
    #[error(transparent)]
    Mlaa(#[from] MlaaError),
    /// The design's medium could not be made.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
}

/// The benchmark frame's display values at `width` x `height` and `spp` samples per pixel.
pub fn benchmark_display(design: &Design, width: u32, height: u32, spp: u32) -> Result<Vec<[f32; 3]>, MlaaTimingError> {
    let mut scene = crate::measure::tracer::benchmark_frame(design, spp, true)?;
    for view in &mut scene.views {
        (view.camera.width, view.camera.height) = (width, height);
    }
    let env = crate::env::EnvironmentMap::from_lighting(&scene.lighting)?;
    let eye = crate::methods::tracer::render_frame(&scene, &env)?.eyes.remove(0);
    let exposure = scene.exposure;
    Ok(eye.pixels.iter().map(|p| p.map(|c| display_value(c, &exposure) as f32)).collect())
}

/// Times MLAA on `display` (`opts.width x opts.height`), on `gpu` when given and by the CPU
/// twin.
pub fn run_mlaa_timing(
    display: &[[f32; 3]],
    gpu: Option<&GpuMlaa>,
    opts: &MlaaTimingOptions,
) -> Result<Value, MlaaTimingError> {
    let (w, h) = (opts.width, opts.height);
    let mut cpu = Vec::new();
    for _ in 0..opts.cpu_rounds.max(1) {
        let started = Instant::now();
        std::hint::black_box(mlaa_cpu(w, h, display, &opts.params)?);
        cpu.push(started.elapsed().as_secs_f64() * 1e3);
    }
    let cpu_ms = median(&cpu);
    let e = edges::detect_edges(w, h, display, opts.params.threshold);
    let wt = weights::blending_weights(&e, w, h, opts.params.search_distance);
    let edgels = e.iter().map(|t| (t[0] + t[1]) as u64).sum::<u64>();
    let blended = wt.iter().filter(|v| v.iter().any(|a| *a > 0.0)).count();
    let mut result = json!({
        "width": w,
        "height": h,
        "spp": opts.spp,
        "threshold": opts.params.threshold,
        "search_distance": opts.params.search_distance,
        "edgels": edgels,
        "blended_pixel_fraction": blended as f64 / f64::from(w * h),
        "cpu_twin_ms": cpu_ms,
        "cpu_rounds": opts.cpu_rounds.max(1),
        "memory_bytes_per_pixel": 52,
        "memory_bytes_area_texture": std::mem::size_of_val(crate::antialias::mlaa::area::area_texture()),
        "machine": crate::measure::tracer::machine_json(),
        "thesis": {"geforce_9800_gtx_plus_ms": 0.44, "xbox_360_ms": 3.8, "speedup_over_8x_msaa": 11.8, "memory_over_back_buffer": 1.5},
        "target_h200_ms": 0.05,
    });
    if let Some(g) = gpu {
        let (mut gpu_ms, mut wall_ms, mut source) = (Vec::new(), Vec::new(), None);
        // The first run compiles and warms caches: not counted.
        for round in 0..=opts.rounds {
            let started = Instant::now();
            let run = g.run(w, h, display, &opts.params)?;
            if round > 0 {
                wall_ms.push(started.elapsed().as_secs_f64() * 1e3);
                gpu_ms.push(run.seconds * 1e3);
                source = Some(format!("{:?}", run.timing_source));
            }
        }
        let gpu_median = median(&gpu_ms);
        let i = g.info();
        result["adapter"] = json!({"name": i.name, "backend": format!("{:?}", i.backend), "driver": i.driver, "software": i.is_software});
        result["gpu_ms_median"] = json!(gpu_median);
        result["gpu_ms_best"] = json!(gpu_ms.iter().copied().fold(f64::INFINITY, f64::min));
        result["gpu_timing_source"] = json!(source);
        result["wall_ms_median_with_transfers"] = json!(median(&wall_ms));
        result["gpu_over_cpu_speedup"] = json!(cpu_ms / gpu_median);
        result["rounds"] = json!(opts.rounds);
    }
    Ok(result)
}
