//! The thesis's Table 2.1 on this machine, CPU twin and (where an adapter opens) GPU:
//! `cargo run --release -p blurlab-media --example table_2_1 -- [SIZE] [LIGHTS] [SIM_RES] [STEPS]
//! [test-density]` (the last: test each segment's density before lighting it, where the
//! thesis's shader lights every segment).
//! The data sets are a simulated plume (`SIM_RES`^3 cells, `STEPS` steps) resampled to the
//! thesis's two shapes, 128x128x128 (its data set ii) and 256x256x64 (the shape of its
//! scanned set i); the lights are a median-cut constellation of a sky with a sun.

use media::bench::{Acceleration, BenchSetup, box_coverage, memory_bytes, model_name, run, table_camera};
use media::constellation::direction;
use media::gpu::GpuMarcher;
use media::{Constellation, LatLongMap, MarchLight, SmokeSettings, SmokeSimulation};

fn sky(w: usize, h: usize) -> LatLongMap {
    let sun = direction(0.3 * w as f64, 0.3 * h as f64, w, h);
    let radiance = (0..w * h)
        .map(|n| {
            let d = direction((n % w) as f64 + 0.5, (n / w) as f64 + 0.5, w, h);
            if d.dot(sun) > 0.995 {
                [200.0, 180.0, 150.0]
            } else if d.y > 0.0 {
                [0.3 + 0.4 * d.y as f32, 0.5 + 0.3 * d.y as f32, 1.0]
            } else {
                [0.1, 0.08, 0.05]
            }
        })
        .collect();
    LatLongMap { width: w, height: h, radiance }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |n: usize, default: usize| -> Result<usize, Box<dyn std::error::Error>> {
        Ok(std::env::args().nth(n).map_or(Ok(default), |s| s.parse())?)
    };
    let (size, lights, res, steps) = (arg(1, 128)? as u32, arg(2, 16)?, arg(3, 64)?, arg(4, 60)?);
    let mut sim = SmokeSimulation::new(SmokeSettings { resolution: [res; 3], ..SmokeSettings::default() })?;
    for _ in 0..steps {
        sim.step();
    }
    let plume = sim.density();
    let ii = plume.resample([128, 128, 128])?;
    let i = plume.resample([256, 256, 64])?;
    let constellation = Constellation::median_cut(&sky(256, 128), lights)?;
    let march_lights: Vec<MarchLight> = constellation
        .lights
        .iter()
        .map(|l| MarchLight { direction: l.direction.as_vec3(), irradiance: l.irradiance.as_vec3() / 10.0 })
        .collect();
    let setup = BenchSetup {
        size: (size, size),
        step: 0.5 / 128.0,
        sigma_t: 40.0,
        albedo: 0.9,
        lights: march_lights,
        rounds: 1,
        cpu: true,
        shade_empty: std::env::args().nth(5).is_none_or(|s| s != "test-density"),
    };
    let marcher = match gpu::acquire(gpu::AdapterChoice::HardwareThenSoftware, &gpu::DeviceRequest::default()) {
        Ok(ctx) => Some(GpuMarcher::new(ctx)?),
        Err(e) => {
            eprintln!("no GPU: {e}");
            None
        }
    };
    if let Some(m) = &marcher {
        println!("GPU: {}", m.info());
    }
    println!(
        "{size}x{size} pixels, {lights} lights, step {:.4} (half a voxel of 128), box covers {:.0} % of the image",
        setup.step,
        100.0 * box_coverage(&table_camera(setup.size), setup.size)
    );
    println!(
        "\n| data | model | acceleration | CPU s | CPU speed-up | GPU s | GPU speed-up | lookups | pixels with smoke |"
    );
    println!("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    let mut brute = (None, None);
    run(&[("ii 128x128x128".into(), &ii), ("i-shape 256x256x64".into(), &i)], &setup, marcher.as_ref(), |r| {
        if r.acceleration == Acceleration::BruteForce {
            brute = (r.cpu_seconds, r.gpu_seconds);
        }
        let speedup = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) => format!("{:.2}", b / a),
            _ => "-".into(),
        };
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.data_set,
            model_name(r.model),
            r.acceleration.name(),
            r.cpu_seconds.map_or("-".into(), |s| format!("{s:.3}")),
            speedup(r.cpu_seconds, brute.0),
            r.gpu_seconds.map_or("-".into(), |s| format!("{s:.3}")),
            speedup(r.gpu_seconds, brute.1),
            r.primary_lookups + r.shadow_lookups,
            r.pixels_with_medium
        );
    })?;
    let (grid, image) = memory_bytes([128, 128, 128], setup.size);
    println!(
        "\nmemory: grid and distance map {:.1} MB (128^3), mask and output {:.1} MB",
        grid as f64 / 1e6,
        image as f64 / 1e6
    );
    Ok(())
}
