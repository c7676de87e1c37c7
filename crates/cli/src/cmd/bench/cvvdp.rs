//! `blurlab bench cvvdp`: ColorVideoVDP's speed at the study's frame size, on the calling
//! thread and on every core, and the process's peak memory: a 640x360 clip of a textured
//! image with fresh noise each frame judged against its clean twin at 30 fps (the crate's
//! README times 1920x1080 clips of 8 frames on a 16-core Ryzen: 9.24 s on one thread).

use std::time::Instant;

use perceptual::SrgbImage;
use perceptual::cvvdp::{Clip, DisplayConditions, Threads, VideoObserver};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Frame width.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(4..=8192))]
    width: u32,
    /// Frame height.
    #[arg(long, default_value_t = 360, value_parser = clap::value_parser!(u32).range(4..=8192))]
    height: u32,
    /// Frames per clip.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Timed runs of each configuration (the fastest is reported beside the mean).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=100))]
    rounds: u32,
}

#[derive(Serialize)]
struct Timing {
    threads: String,
    seconds: Vec<f64>,
    best_frames_per_second: f64,
    mean_frames_per_second: f64,
}

#[derive(Serialize)]
struct Report {
    benchmark: &'static str,
    width: u32,
    height: u32,
    frames: u32,
    fps_shown: f64,
    pixels_per_degree: f64,
    jod: f64,
    cores: usize,
    timings: Vec<Timing>,
    peak_resident_bytes: Option<u64>,
}

fn clip(w: u32, h: u32, frames: u32, noise: f64, seed: u64) -> Vec<SrgbImage> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..frames)
        .map(|_| {
            let data = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .flat_map(|(x, y)| {
                    let base = 0.45 + 0.2 * (f64::from(x) * 0.05).sin() * (f64::from(y) * 0.07).cos();
                    let n: f64 = noise * (rng.random::<f64>() - 0.5);
                    let v = ((base + n).clamp(0.0, 1.0) * 255.0).round() as u8;
                    [v, v.saturating_sub(20), v.saturating_add(10)]
                })
                .collect();
            SrgbImage::new(w, h, data).map_err(|e| anyhow::anyhow!("{e}"))
        })
        .collect::<anyhow::Result<_>>()
        .unwrap_or_default()
}

/// Runs the benchmark.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (w, h, n) = (args.width, args.height, args.frames);
    let test = clip(w, h, n, 0.15, 1);
    let reference = clip(w, h, n, 0.0, 2);
    let conditions = DisplayConditions {
        pixels_per_degree: 44.21,
        peak_luminance: study::design::spec::DEFAULT_PEAK_LUMINANCE,
        black_level: study::design::spec::DEFAULT_BLACK_LEVEL,
        ambient_lux: study::design::spec::DEFAULT_AMBIENT_LUX,
    };
    let mut timings = Vec::new();
    let mut jod = f64::NAN;
    for (threads, name) in [(Threads::One, "1"), (Threads::Pool, "all")] {
        let observer = VideoObserver::new(conditions, threads)?;
        let mut seconds = Vec::new();
        for _ in 0..args.rounds {
            let started = Instant::now();
            let j = observer.judge(&Clip { frames: &test, fps: 30.0 }, &Clip { frames: &reference, fps: 30.0 }, 1)?;
            seconds.push(started.elapsed().as_secs_f64());
            jod = j.jod();
        }
        let best = seconds.iter().copied().fold(f64::INFINITY, f64::min);
        let mean = seconds.iter().sum::<f64>() / seconds.len() as f64;
        timings.push(Timing {
            threads: name.into(),
            best_frames_per_second: f64::from(n) / best,
            mean_frames_per_second: f64::from(n) / mean,
            seconds,
        });
    }
    let report = Report {
        benchmark: "cvvdp",
        width: w,
        height: h,
        frames: n,
        fps_shown: 30.0,
        pixels_per_degree: conditions.pixels_per_degree,
        jod,
        cores: rayon::current_num_threads(),
        timings,
        peak_resident_bytes: runner::bench::memory_kib().map(|(_, peak)| peak * 1024),
    };
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
