//! The tracer benchmark without the CLI: `cargo bench -p blurlab-render --bench tracer --
//! [SPP] [none|mitsuba] [SAMPLER] [VARIANT]` prints the same JSON as `blurlab bench tracer --json` (run from the
//! workspace root so `stimuli/` and `bench/mitsuba_peer.py` are found).

use render::measure::tracer::{BenchOptions, run_benchmark};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let opts = BenchOptions {
        design: root.join("stimuli/navarro2011.toml"),
        spp: args.first().and_then(|s| s.parse().ok()).unwrap_or(16),
        peer: args.get(1).cloned().unwrap_or_else(|| "none".into()),
        python: "python3".into(),
        peer_script: root.join("bench/mitsuba_peer.py"),
        mitsuba_sampler: args.get(2).cloned().unwrap_or_else(|| "independent".into()),
        mitsuba_variant: args.get(3).cloned().unwrap_or_else(|| "scalar_rgb".into()),
        work: None,
        rounds: 3,
    };
    match run_benchmark(&opts) {
        Ok(result) => println!("{}", serde_json::to_string_pretty(&result).expect("JSON")),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
