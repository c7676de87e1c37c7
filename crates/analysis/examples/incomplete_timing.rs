//! Times `analyze` on an incomplete design of 225 stimuli x 20 participants (300 random
//! pairs each, two answering at random and one reversing the scale) with the default
//! options, and writes its report folder: `cargo run --release -p blurlab-analysis
//! --example incomplete_timing -- OUT [RESAMPLES]`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use analysis::experiment::{AnalysisOptions, analyze_experiment};
use analysis::report::{REPORT_FORMAT, Report, write_report};
use analysis::scaling::ScaleOptions;
use analysis::synthetic::{Observer, simulated_incomplete_experiment, study_stimuli};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "incomplete-report".into()));
    let resamples = args.next().map(|r| r.parse()).transpose()?.unwrap_or(ScaleOptions::default().resamples);
    let stimuli = study_stimuli(225);
    let truth: Vec<f64> = stimuli.iter().map(|s| -0.8 * f64::from(s.shutter) + 0.3 * f64::from(s.samples)).collect();
    let mut observers = vec![Observer::Thurstone; 20];
    observers[3] = Observer::Random;
    observers[11] = Observer::Random;
    observers[17] = Observer::Reversed;
    let data = simulated_incomplete_experiment(&stimuli, &truth, &observers, 300, 7);
    let options =
        AnalysisOptions { scale: ScaleOptions { resamples, ..ScaleOptions::default() }, ..Default::default() };
    let start = Instant::now();
    let e = analyze_experiment(&data, &BTreeMap::new(), options);
    let analysis = start.elapsed().as_secs_f64();
    let p = e.paired.as_ref().ok_or("no paired analysis")?;
    println!(
        "225 stimuli x 20 participants x 300 trials, {resamples} resamples: analysis {analysis:.2} s; {} groups; flagged {:?}",
        p.groups.len(),
        p.screening.flagged
    );
    let mut report = Report {
        format: REPORT_FORMAT,
        software_version: study::SOFTWARE_VERSION,
        manifest: None,
        experiments: vec![e],
        mono_stereo_pairs: Vec::new(),
        figures: Vec::new(),
        vote_tables: Vec::new(),
    };
    let start = Instant::now();
    write_report(&mut report, &out)?;
    println!("report written in {:.2} s: {}", start.elapsed().as_secs_f64(), out.display());
    Ok(())
}
