//! Milliseconds per frame of the post-process filters (`blurlab bench filters`): the study's
//! benchmark frame (M3-S3-T5, the sphere at the image centre, the shutter open the whole
//! frame) as a G-buffer at the benchmark's size (1280x720 by default, as Guertin et al. time
//! theirs), filtered by McGuire 2012 and Guertin 2014 on the GPU, timed by timestamp queries
//! around the filter's passes (upload and read-back excluded) over several rounds, and by
//! their CPU twins on the same G-buffer in the same run, so a software adapter's times are
//! reported as a ratio against the CPU twin measured beside them.

use std::time::Instant;

use serde_json::{Value, json};
use study::design::Design;
use study::method::{GuertinSettings, McGuireSettings};
use study::stats::median;

use crate::method::filter_seed;
use crate::methods::guertin::GuertinParams;
use crate::methods::guertin::guertin_cpu;
use crate::methods::mcguire::McGuireParams;
use crate::methods::mcguire::mcguire_cpu;
use crate::methods::post_process::gbuffer::{FloorMotion, gbuffers};
use crate::methods::post_process::{GBuffer, GpuFilters};

/// What to measure.
#[derive(Clone, Debug)]
pub struct FilterTimingOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Taps N of both filters.
    pub taps: u32,
    /// Rounds of GPU timing (the median and the best are reported).
    pub rounds: u32,
    /// Rounds of CPU-twin timing.
    pub cpu_rounds: u32,
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum FilterTimingError {
    /// The design cannot give the benchmark frame.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// The environment map could not be built.
    #[error(transparent)]
    Environment(#[from] crate::env::EnvError),
    /// A filter failed.
    #[error(transparent)]
    Filter(#[from] crate::methods::post_process::FilterError),
    /// The design's medium could not be made.
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
}

/// The benchmark frame's G-buffer at `width` x `height` (radiance traced at 1 sample per pixel
/// on the CPU: its noise does not change a filter's cost).
pub fn benchmark_gbuffer(design: &Design, width: u32, height: u32) -> Result<GBuffer, FilterTimingError> {
    let mut scene = crate::measure::tracer::benchmark_frame(design, 1, false)?;
    for view in &mut scene.views {
        let camera = &mut view.camera;
        (camera.width, camera.height) = (width, height);
    }
    let env = crate::env::EnvironmentMap::from_lighting(&scene.lighting)?;
    let centre = scene.at_instant(scene.shutter.centre());
    let eyes = crate::methods::tracer::render_frame(&centre, &env)?.eyes;
    Ok(gbuffers(&scene, eyes, FloorMotion::default()).remove(0))
}

/// Times both filters on `g`, on `filters`' device when given and by their CPU twins.
pub fn run_filter_timing(
    g: &GBuffer,
    filters: Option<&GpuFilters>,
    opts: &FilterTimingOptions,
) -> Result<Value, FilterTimingError> {
    let seed = filter_seed(0x5EED);
    let max_speed = g.velocity.iter().map(|v| v[0].hypot(v[1])).fold(0.0f32, f32::max);
    let mut results = serde_json::Map::new();
    for name in ["mcguire", "guertin"] {
        let m = McGuireParams::from_settings(&McGuireSettings { taps: Some(opts.taps), ..Default::default() }, seed);
        let gp = GuertinParams::from_settings(&GuertinSettings { taps: Some(opts.taps), ..Default::default() }, seed);
        let run_cpu = || if name == "mcguire" { mcguire_cpu(g, &m) } else { guertin_cpu(g, &gp) };
        let mut cpu = Vec::new();
        for _ in 0..opts.cpu_rounds.max(1) {
            let started = Instant::now();
            std::hint::black_box(run_cpu());
            cpu.push(started.elapsed().as_secs_f64() * 1e3);
        }
        let cpu_ms = median(&cpu);
        let mut entry = json!({ "cpu_twin_ms": cpu_ms, "cpu_rounds": opts.cpu_rounds.max(1) });
        if let Some(f) = filters {
            let (mut gpu_ms, mut wall_ms, mut source) = (Vec::new(), Vec::new(), None);
            // The first dispatch compiles and warms caches: not counted.
            for round in 0..=opts.rounds {
                let started = Instant::now();
                let out = if name == "mcguire" { f.mcguire(g, &m)? } else { f.guertin(g, &gp)? };
                if round > 0 {
                    wall_ms.push(started.elapsed().as_secs_f64() * 1e3);
                    gpu_ms.extend(out.gpu_seconds.map(|s| s * 1e3));
                    source = Some(format!("{:?}", out.timing_source));
                }
            }
            let gpu_median = median(&gpu_ms);
            entry["gpu_ms_median"] = json!(gpu_median);
            entry["gpu_ms_best"] = json!(gpu_ms.iter().copied().fold(f64::INFINITY, f64::min));
            entry["gpu_timing_source"] = json!(source);
            entry["wall_ms_median_with_transfers"] = json!(median(&wall_ms));
            entry["gpu_over_cpu_speedup"] = json!(cpu_ms / gpu_median);
        }
        results.insert(name.to_owned(), entry);
    }
    Ok(json!({
        "width": g.width,
        "height": g.height,
        "taps": opts.taps,
        "max_velocity_px": max_speed,
        "rounds": opts.rounds,
        "adapter": filters.map(|f| {
            let i = f.info();
            json!({"name": i.name, "backend": format!("{:?}", i.backend), "driver": i.driver, "software": i.is_software})
        }),
        "machine": crate::measure::tracer::machine_json(),
        "paper": {"guertin_2014_gtx780_ms": 1.68, "target_h200_ms": 0.25},
        "filters": results,
    }))
}
