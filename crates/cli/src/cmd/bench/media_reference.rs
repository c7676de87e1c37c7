//! `blurlab bench media-reference`: the f64 reference tracer with a participating medium
//! beside Mitsuba 3 (`volpath`, a `heterogeneous` medium on a `gridvolume` of the same grid)
//! on one frozen frame of a design, at the same samples per pixel
//! (`render::measure::media_reference`): whether the images agree within their noise (z-scores
//! of 8 x 8-pixel block means), and camera samples per second of each, also at equal noise.
//! The peer runs as `python3 bench/mitsuba_peer.py DIR`.

use std::path::PathBuf;

use render::measure::media_reference::{MediaReferenceOptions, run_media_reference};

use crate::cmd::BadInput;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Print the report as JSON (otherwise a summary).
    #[arg(long)]
    json: bool,
    /// Design with a `[medium]`.
    #[arg(long, default_value = "stimuli/media.toml")]
    design: PathBuf,
    /// Preset (image size and the grids it needs).
    #[arg(long, default_value = "quick")]
    preset: String,
    /// Stimulus whose frame is compared (frozen at its frame time).
    #[arg(long, default_value = "M1-S2-T1-A1-tracer")]
    id: String,
    /// Frame of the preset.
    #[arg(long, default_value_t = 4)]
    frame: u32,
    /// Samples per pixel of every render.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65_536))]
    spp: u32,
    /// Python interpreter that has the `mitsuba` package.
    #[arg(long, default_value = "python3")]
    python: String,
    /// The peer's driver script.
    #[arg(long, default_value = "bench/mitsuba_peer.py")]
    peer_script: PathBuf,
    /// Mitsuba variant: `scalar_rgb` or `llvm_ad_rgb`.
    #[arg(long, default_value = "scalar_rgb")]
    mitsuba_variant: String,
    /// Folder for the peer's scene and images (default: a new temporary folder).
    #[arg(long)]
    work: Option<PathBuf>,
}

/// Runs the comparison.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let id = args.id.parse().map_err(|e| BadInput(format!("--id {}: {e}", args.id)))?;
    let opts = MediaReferenceOptions {
        design: args.design.clone(),
        preset: args.preset.clone(),
        id,
        frame: args.frame,
        spp: args.spp,
        python: args.python.clone(),
        peer_script: args.peer_script.clone(),
        mitsuba_variant: args.mitsuba_variant.clone(),
        work: args.work.clone(),
    };
    let r = run_media_reference(&opts).map_err(|e| match e {
        render::measure::tracer::BenchError::Design(_) | render::measure::tracer::BenchError::Frame(_) => {
            anyhow::Error::new(BadInput(e.to_string()))
        }
        e => anyhow::Error::new(e),
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    println!(
        "{} frame {} of `{}` at {}x{}, {} spp, every scattering order:",
        r["stimulus"].as_str().unwrap_or("?"),
        r["frame"],
        r["preset"].as_str().unwrap_or("?"),
        r["width"],
        r["height"],
        r["samples_per_pixel"]
    );
    for (name, key) in [("blurlab reference", "ours"), ("Mitsuba 3 volpath", "mitsuba")] {
        let v = &r[key];
        println!(
            "  {name:18} {:8.3} M camera samples/s, noise {:.4}, mean RGB {:.4} {:.4} {:.4}",
            f(&v["camera_samples_per_second"]) / 1e6,
            f(&v["noise_rms"]),
            f(&v["mean_rgb"][0]),
            f(&v["mean_rgb"][1]),
            f(&v["mean_rgb"][2])
        );
    }
    let a = &r["agreement"];
    println!(
        "  agreement over {} block means: RMS z {:.2}, max |z| {:.2}, {} beyond 3, {} beyond 4",
        a["block_count"],
        f(&a["rms_z"]),
        f(&a["max_abs_z"]),
        a["beyond_3"],
        a["beyond_4"]
    );
    println!(
        "  speed: {:.2}x Mitsuba's at equal spp, {:.2}x at equal noise",
        f(&r["speed_ratio"]),
        f(&r["speed_ratio_at_equal_noise"])
    );
    Ok(())
}
