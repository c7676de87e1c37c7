//! Camera samples per second of the CPU tracer on the benchmark frame (M3-S3-T5, 640x360).
//!
//! `cargo bench -p blurlab-render --bench tracer -- [SPP] [OUT.png]`; `blurlab bench tracer
//! --json` is the reported benchmark (with the Mitsuba 3 comparison).

use std::time::Instant;

use render::env::EnvironmentMap;
use render::tracer::{bench::benchmark_frame, render_frame};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let spp: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(16);
    let design_path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let design = study::design::Design::load(&design_path).expect("design");
    for freeze in [false, true] {
        let scene = benchmark_frame(&design, spp, freeze).expect("scene");
        let env = EnvironmentMap::from_lighting(&scene.lighting).expect("environment");
        let start = Instant::now();
        let out = render_frame(&scene, &env);
        let secs = start.elapsed().as_secs_f64();
        println!(
            "{} frame {} spp {spp}: {:.3} s, {:.2} M camera samples/s, nonfinite {}",
            if freeze { "static" } else { "moving" },
            scene.frame,
            secs,
            out.camera_samples as f64 / secs / 1e6,
            out.nonfinite_samples
        );
        if let Some(path) = args.get(1) {
            let path = if freeze { path.replace(".png", "-static.png") } else { path.clone() };
            std::fs::write(path, render::io::encode_png_srgb(&out.eyes[0], &scene.exposure)).unwrap();
        }
    }
}
