//! The analysis benchmark without the CLI's dependencies (fast to build in release):
//! `cargo run --release -p blurlab-analysis --example bench_analysis [JUDGES RESAMPLES]`.
//! `blurlab bench analysis --json` runs the same code.

fn main() {
    let mut args = std::env::args().skip(1);
    let judges = args.next().and_then(|a| a.parse().ok()).unwrap_or(36);
    let resamples = args.next().and_then(|a| a.parse().ok()).unwrap_or(1000);
    let value = analysis::synthetic::benchmark(judges, resamples, 5, 1);
    println!("{}", serde_json::to_string_pretty(&value).expect("json"));
}
