//! The f64 reference tracer with a participating medium beside Mitsuba 3's volumetric path
//! tracer (`volpath`, a `heterogeneous` medium reading the same grid through a `gridvolume`)
//! on the same frame, at the same samples per pixel (issue 27, item 7): whether the two
//! images agree within their noise, and their speeds.
//!
//! The frame is a design's stimulus frozen at its frame time (the shutter closed: Mitsuba
//! has no moving media), with every scattering order (up to 64 surface bounces and 64
//! collisions in the medium, Russian roulette ending paths long before), so that both
//! renderers estimate the same integral whatever their counting of depths.
//!
//! Agreement is judged on blocks of 8 x 8 pixels: each block's mean in each renderer (two
//! seeds each), its standard error from the two seeds' differences, and the z-score of the
//! two means' difference. With the same image the z-scores are standard normal: their RMS
//! near 1 and few beyond 4.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;
use study::design::Design;
use study::ids::StimulusId;
use study::medium::SceneMedium;
use study::scene::{FrameScene, Integrator};

use super::tracer::{BenchError, machine_json, mean_rgb, read, rms_noise, run_peer_script, write, write_peer_scene};
use crate::env::EnvironmentMap;
use crate::io::{LinearImage, decode_exr};
use crate::volume::grids_for;

/// Surface bounces and medium collisions of the compared frame: enough that no path the
/// comparison could notice is cut.
const DEPTH: u32 = 64;
/// Side of the blocks the images are compared on, pixels.
const BLOCK: u32 = 8;

/// Options of [`run_media_reference`].
#[derive(Clone, Debug)]
pub struct MediaReferenceOptions {
    /// Design with a `[medium]`.
    pub design: PathBuf,
    /// Its preset (image size, grids).
    pub preset: String,
    /// The stimulus.
    pub id: StimulusId,
    /// Frame of the preset.
    pub frame: u32,
    /// Samples per pixel of every render.
    pub spp: u32,
    /// Python interpreter that has the `mitsuba` package.
    pub python: String,
    /// The peer's driver script.
    pub peer_script: PathBuf,
    /// Mitsuba variant (`scalar_rgb` or `llvm_ad_rgb`).
    pub mitsuba_variant: String,
    /// Folder for the peer's scene and images (default: a new temporary folder).
    pub work: Option<PathBuf>,
}

/// Writes the medium's grid at the frame's instant as a Mitsuba `.vol` file in `dir`;
/// returns the scene.json block describing it and the Mitsuba depth that cuts no path our
/// tracer keeps (surface bounces plus collisions plus the camera segment).
pub(crate) fn write_peer_medium(
    scene: &FrameScene,
    medium: &SceneMedium,
    dir: &Path,
) -> Result<(serde_json::Value, u32), BenchError> {
    let grids = grids_for(medium, &mut |_, _| {}).map_err(|e| BenchError::Frame(e.to_string()))?;
    let grid = grids.sequence.grid_at(grids.position(medium, scene.shutter.open));
    let vol = dir.join("medium.vol");
    write(&vol, &mitsuba_vol(grid.dims(), grid.data()))?;
    let (lo, _) = medium.bounds();
    let json = json!({
        "vol": vol,
        "box_min": lo,
        "box_size": medium.size,
        "extinction": medium.extinction,
        "albedo": medium.albedo,
    });
    Ok((json, scene.integrator.max_bounces + medium.max_scatterings + 1))
}

/// Mitsuba's `.vol` grid: `VOL`, version 3, encoding 1 (f32), the three sizes, one channel,
/// the bounding box (Mitsuba 3 places the grid by its `to_world` instead), then the values
/// with x fastest, then y, then z (blurlab's order too); all little-endian.
pub fn mitsuba_vol(dims: [usize; 3], data: &[f32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(48 + 4 * data.len());
    out.extend_from_slice(b"VOL");
    out.push(3);
    out.extend_from_slice(&1i32.to_le_bytes());
    for n in dims {
        out.extend_from_slice(&(n as i32).to_le_bytes());
    }
    out.extend_from_slice(&1i32.to_le_bytes());
    for v in [0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Per-block z-scores of the difference of two renderers' means, each from two seeds.
pub fn block_z_scores(ours: [&LinearImage; 2], theirs: [&LinearImage; 2]) -> Vec<f64> {
    let (w, h) = (ours[0].width, ours[0].height);
    let mut z = Vec::new();
    for by in (0..h).step_by(BLOCK as usize) {
        for bx in (0..w).step_by(BLOCK as usize) {
            for c in 0..3 {
                let stats = |pair: [&LinearImage; 2]| {
                    let (mut sum, mut diff2, mut n) = (0.0, 0.0, 0.0);
                    for y in by..(by + BLOCK).min(h) {
                        for x in bx..(bx + BLOCK).min(w) {
                            let (a, b) = (f64::from(pair[0].get(x, y)[c]), f64::from(pair[1].get(x, y)[c]));
                            sum += a + b;
                            diff2 += (a - b) * (a - b);
                            n += 1.0;
                        }
                    }
                    // per-pixel variance of one render: E[(a - b)^2] / 2; the block's mean of
                    // 2n values has a quarter of that over n
                    (sum / (2.0 * n), diff2 / (2.0 * n) / (2.0 * n))
                };
                let ((ma, va), (mb, vb)) = (stats(ours), stats(theirs));
                if va + vb > 0.0 {
                    z.push((ma - mb) / (va + vb).sqrt());
                }
            }
        }
    }
    z
}

/// Renders the frame with the reference tracer (two seeds, timed) and runs the Mitsuba
/// driver on it; returns the JSON report.
pub fn run_media_reference(opts: &MediaReferenceOptions) -> Result<serde_json::Value, BenchError> {
    let machine = machine_json();
    let design = Design::load(&opts.design)?;
    let preset = design.preset(&opts.preset)?;
    let mut scene = design.frame_scene_with(&preset, &opts.id, opts.frame)?;
    scene = scene.at_instant(scene.frame_time);
    let Some(medium) = scene.medium.as_mut() else {
        return Err(BenchError::Frame(format!("{}: the design has no [medium]", opts.design.display())));
    };
    medium.max_scatterings = DEPTH;
    scene.integrator = Integrator { max_bounces: DEPTH, russian_roulette_from: scene.integrator.russian_roulette_from };
    scene.samples_per_pixel = opts.spp;
    scene.views.truncate(1);
    let work = match &opts.work {
        Some(w) => w.clone(),
        None => std::env::temp_dir().join(format!("blurlab-bench-media-reference-{}", std::process::id())),
    };
    std::fs::create_dir_all(&work).map_err(|e| BenchError::File(work.clone(), e))?;
    write_peer_scene(&scene, &work, "independent", &opts.mitsuba_variant)?;
    let env = EnvironmentMap::from_lighting(&scene.lighting)?;
    // the grids are made before the clock starts
    if let Some(m) = &scene.medium {
        grids_for(m, &mut |_, _| {}).map_err(|e| BenchError::Frame(e.to_string()))?;
    }
    let mut ours = Vec::new();
    let mut seconds = Vec::new();
    for salt in [1u64, 2] {
        let mut s = scene.clone();
        s.views[0].seed = study::seed::mix(s.views[0].seed, &[salt]);
        let start = Instant::now();
        let mut out = crate::methods::tracer::render_frame(&s, &env).map_err(|e| BenchError::Frame(e.to_string()))?;
        seconds.push(start.elapsed().as_secs_f64());
        ours.push(out.eyes.remove(0));
    }
    let peer = run_peer_script(&opts.python, &opts.peer_script, &work)?;
    let load = |name: &str| {
        let path = work.join(name);
        decode_exr(&read(&path)?).map_err(|e| BenchError::Peer(format!("{}: {e}", path.display())))
    };
    let theirs = [load("mitsuba-seed1.exr")?, load("mitsuba-seed2.exr")?];
    let (w, h) = (ours[0].width, ours[0].height);
    if (theirs[0].width, theirs[0].height) != (w, h) {
        return Err(BenchError::Peer(format!(
            "Mitsuba rendered {}x{}, not {w}x{h}",
            theirs[0].width, theirs[0].height
        )));
    }
    let samples = f64::from(w) * f64::from(h) * f64::from(opts.spp);
    let our_sps = samples / seconds.iter().copied().fold(f64::INFINITY, f64::min);
    let their_sps = peer["camera_samples_per_second"].as_f64().unwrap_or(f64::NAN);
    let (our_noise, their_noise) = (rms_noise(&ours[0], &ours[1]), rms_noise(&theirs[0], &theirs[1]));
    let z = block_z_scores([&ours[0], &ours[1]], [&theirs[0], &theirs[1]]);
    let rms_z = (z.iter().map(|v| v * v).sum::<f64>() / z.len().max(1) as f64).sqrt();
    let beyond = |k: f64| z.iter().filter(|v| v.abs() > k).count();
    let (our_mean, their_mean) = (mean_rgb(&[&ours[0], &ours[1]]), mean_rgb(&[&theirs[0], &theirs[1]]));
    Ok(json!({
        "benchmark": "media-reference",
        "machine": machine,
        "design": opts.design,
        "preset": opts.preset,
        "stimulus": opts.id.to_string(),
        "frame": opts.frame,
        "width": w,
        "height": h,
        "samples_per_pixel": opts.spp,
        "depth": { "surface_bounces": DEPTH, "medium_collisions": DEPTH },
        "ours": {
            "renderer": "blurlab f64 reference tracer (delta and ratio tracking)",
            "threads": rayon::current_num_threads(),
            "render_seconds": seconds,
            "camera_samples_per_second": our_sps,
            "noise_rms": our_noise,
            "mean_rgb": our_mean,
        },
        "mitsuba": {
            "driver": peer,
            "camera_samples_per_second": their_sps,
            "noise_rms": their_noise,
            "mean_rgb": their_mean,
        },
        "agreement": {
            "blocks": format!("{BLOCK}x{BLOCK} pixels, per channel"),
            "block_count": z.len(),
            "rms_z": rms_z,
            "max_abs_z": z.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            "beyond_3": beyond(3.0),
            "beyond_4": beyond(4.0),
        },
        "speed_ratio": our_sps / their_sps,
        "speed_ratio_at_equal_noise": our_sps / their_sps * (their_noise / our_noise).powi(2),
        "work": work,
    }))
}
