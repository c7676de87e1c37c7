//! The GPU tracer's benchmark (`blurlab bench tracer --device gpu`): camera samples per
//! second on the benchmark frame ([`crate::measure::tracer::benchmark_frame`], full
//! resolution), GPU time from timestamp queries where the adapter has them, the CPU tracer
//! on the same frame in the same run (on a software adapter the ratio is the only number that
//! means anything), what each kernel specialisation saves, and the full set projected.

use std::time::Instant;

use serde_json::json;
use study::design::Design;
use study::ids::{StimulusId, View};
use study::scene::FrameScene;

use crate::env::EnvironmentMap;
use crate::measure::tracer::{BENCH_STIMULUS, BenchError, benchmark_frame, frame_json, full_set_camera_samples};
use crate::methods::tracer::{GpuEnvironment, GpuTracer};
use crate::shading::gpu::params::Specialisation;

/// Options of [`run_gpu_benchmark`].
#[derive(Clone, Debug)]
pub struct GpuBenchOptions {
    /// Design file.
    pub design: std::path::PathBuf,
    /// Samples per pixel of the GPU renders.
    pub spp: u32,
    /// Samples per pixel of the CPU tracer's render of the same frame (0: none).
    pub cpu_spp: u32,
    /// Rounds; each rate is the best over the rounds.
    pub rounds: u32,
}

/// Best times of a frame over rounds.
struct Best {
    gpu_seconds: Option<f64>,
    wall_seconds: f64,
    camera_samples: u64,
}

fn best_of(
    tracer: &GpuTracer,
    scene: &FrameScene,
    env: &GpuEnvironment,
    spec: Specialisation,
    rounds: u32,
) -> Result<Best, BenchError> {
    let gpu = |e: crate::methods::tracer::GpuTracerError| BenchError::Gpu(e.to_string());
    // Compiles the pipeline and warms the caches, untimed.
    let mut warm = scene.clone();
    warm.samples_per_pixel = 1;
    tracer.render_frame_with(&warm, env, spec).map_err(gpu)?;
    let mut best = Best { gpu_seconds: None, wall_seconds: f64::INFINITY, camera_samples: 0 };
    for _ in 0..rounds.max(1) {
        let start = Instant::now();
        let frame = tracer.render_frame_with(scene, env, spec).map_err(gpu)?;
        best.wall_seconds = best.wall_seconds.min(start.elapsed().as_secs_f64());
        best.gpu_seconds = match (best.gpu_seconds, frame.gpu_seconds) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (None, b) => b,
            (a, None) => a,
        };
        best.camera_samples = frame.camera_samples;
    }
    Ok(best)
}

impl Best {
    /// The GPU time where there is one, else the wall time.
    fn seconds(&self) -> f64 {
        self.gpu_seconds.unwrap_or(self.wall_seconds)
    }

    fn json(&self) -> serde_json::Value {
        json!({
            "camera_samples": self.camera_samples,
            "gpu_seconds": self.gpu_seconds,
            "wall_seconds": self.wall_seconds,
            "camera_samples_per_second": self.camera_samples as f64 / self.seconds(),
            "camera_samples_per_second_wall": self.camera_samples as f64 / self.wall_seconds,
        })
    }
}

/// A saving: the frame with the kernel it needs against a more general kernel.
fn saving(specialised: &Best, general: &Best, what: &str) -> serde_json::Value {
    json!({
        "what": what,
        "specialised": specialised.json(),
        "general": general.json(),
        "time_saved_fraction": 1.0 - specialised.seconds() / general.seconds(),
    })
}

/// Runs the benchmark on `tracer`; returns the JSON report.
pub fn run_gpu_benchmark(tracer: &GpuTracer, opts: &GpuBenchOptions) -> Result<serde_json::Value, BenchError> {
    let design = Design::load(&opts.design)?;
    let moving = benchmark_frame(&design, opts.spp, false)?;
    let frozen = benchmark_frame(&design, opts.spp, true)?;
    let env = EnvironmentMap::from_lighting(&moving.lighting)?;
    let genv = tracer.environment(&env).map_err(|e| BenchError::Gpu(e.to_string()))?;
    let rounds = opts.rounds;
    let spec_of = Specialisation::of;
    let moving_run = best_of(tracer, &moving, &genv, spec_of(&moving), rounds)?;
    let static_run = best_of(tracer, &frozen, &genv, spec_of(&frozen), rounds)?;

    // What each specialisation saves, each against the same frame rendered by a more
    // general kernel (the same image: `tests/tracer_gpu.rs`).
    let forced_time = Specialisation { time_sampling: true, ..spec_of(&frozen) };
    let static_general = best_of(tracer, &frozen, &genv, forced_time, rounds)?;
    let flat_id = StimulusId { material: 1, ..BENCH_STIMULUS };
    let mut flat = design.frame_scene(&flat_id, moving.frame)?;
    flat.samples_per_pixel = opts.spp;
    let flat_run = best_of(tracer, &flat, &genv, spec_of(&flat), rounds)?;
    // The general kernel evaluates the study's noise texture blending two equal albedos:
    // the flat image, at the cost of the texture.
    let mut flat_as_noise = flat.clone();
    if let (
        study::scene::Material::Flat { albedo },
        study::scene::Material::Noise { base_frequency, octaves, seed, .. },
    ) = (&flat.material, &moving.material)
    {
        flat_as_noise.material = study::scene::Material::Noise {
            albedo_a: *albedo,
            albedo_b: *albedo,
            base_frequency: *base_frequency,
            octaves: *octaves,
            seed: *seed,
        };
    }
    let flat_general = best_of(tracer, &flat_as_noise, &genv, spec_of(&flat_as_noise), rounds)?;
    let stereo_id = StimulusId { view: View::Stereo, ..BENCH_STIMULUS };
    let mut stereo = design.frame_scene(&stereo_id, moving.frame)?;
    stereo.samples_per_pixel = opts.spp;
    let stereo_run = best_of(tracer, &stereo, &genv, spec_of(&stereo), rounds)?;

    // The CPU tracer on the moving frame, in the same run.
    let cpu = if opts.cpu_spp > 0 {
        let mut scene = moving.clone();
        scene.samples_per_pixel = opts.cpu_spp;
        let mut best = f64::INFINITY;
        let mut samples = 0;
        for _ in 0..rounds.max(1) {
            let start = Instant::now();
            let out =
                crate::methods::tracer::render_frame(&scene, &env).map_err(|e| BenchError::Frame(e.to_string()))?;
            best = best.min(start.elapsed().as_secs_f64());
            samples = out.camera_samples;
        }
        Some((samples as f64 / best, best, samples))
    } else {
        None
    };

    let (independent, nested) = full_set_camera_samples(&design)?;
    let moving_rate = moving_run.camera_samples as f64 / moving_run.seconds();
    let info = tracer.info();
    let mut report = json!({
        "benchmark": "tracer-gpu",
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "adapter": {
            "name": info.name,
            "backend": format!("{:?}", info.backend),
            "driver": info.driver,
            "driver_info": info.driver_info,
            "software": info.is_software,
            "timestamps": moving_run.gpu_seconds.is_some(),
        },
        "cpu_threads": rayon::current_num_threads(),
        "frame": frame_json(&moving),
        "rounds": rounds,
        "gpu": {
            "moving_frame": moving_run.json(),
            "static_frame": static_run.json(),
            "stereo_moving_frame": stereo_run.json(),
        },
        "specialisations": [
            saving(&static_run, &static_general, "still frame: no time dimension (against the time-sampling kernel)"),
            saving(&flat_run, &flat_general, "flat material: no texture (against the noise kernel)"),
            saving(&moving_run, &stereo_run, "mono frame: one eye (against the stereo frame's two)"),
        ],
        "full_set_projection": {
            "camera_samples_independent": independent,
            "minutes_independent": independent / moving_rate / 60.0,
            "camera_samples_nested": nested,
            "minutes_nested": nested / moving_rate / 60.0,
            "note": "tracing only, at the moving frame's rate; PNG writing overlaps it",
        },
    });
    if let Some((rate, seconds, samples)) = cpu {
        report["cpu"] = json!({
            "moving_frame": {
                "samples_per_pixel": opts.cpu_spp,
                "camera_samples": samples,
                "wall_seconds": seconds,
                "camera_samples_per_second": rate,
            },
        });
        report["gpu_over_cpu"] = json!(moving_rate / rate);
    }
    Ok(report)
}
