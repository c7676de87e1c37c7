//! The tracer benchmark's frame: the full-resolution M3-S3-T5 mono frame of a design at the
//! instant the sphere is nearest the image centre, optionally made static (the frozen
//! sphere at that instant, for comparison with renderers that have no motion blur), and the
//! benchmark itself ([`run_benchmark`]), which `blurlab bench tracer` and the crate's bench
//! target run.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;
use study::design::Design;
use study::ids::{StimulusId, View};
use study::scene::{Environment, FrameScene};

use crate::env::{EnvironmentMap, default_map};
use crate::io::{LinearImage, decode_exr, encode_exr};
use crate::methods::tracer::render_frame;
use crate::methods::tracer::wide::{self, Isa};
use crate::numeric::CompensatedSum;
use crate::shading::gpu::params::EnvTables;

/// The stimulus the benchmark renders.
pub const BENCH_STIMULUS: StimulusId =
    StimulusId { material: 3, speed: 3, shutter: 5, samples: 1, method: None, view: View::Mono };

/// The benchmark frame of `design` at `spp` samples per pixel: the frame (of the full
/// preset) whose sphere centre projects nearest the image centre. `freeze` replaces the
/// motion by the sphere at the frame time and closes the shutter (the "static frame").
pub fn benchmark_frame(design: &Design, spp: u32, freeze: bool) -> Result<FrameScene, study::design::DesignError> {
    let first = design.frame_scene(&BENCH_STIMULUS, 0)?;
    let frames = design.spec.sequence.frames;
    let cam = &first.views[0].camera;
    let centre_px = glam::DVec2::new(f64::from(cam.width) * 0.5, f64::from(cam.height) * 0.5);
    let mut best = (f64::INFINITY, 0);
    for f in 0..frames {
        let t = design.frame_time(&design.preset("full")?, f);
        if let Some(p) = cam.project(first.sphere.centre_at(t)) {
            let d = (p - centre_px).length();
            if d < best.0 {
                best = (d, f);
            }
        }
    }
    let mut scene = design.frame_scene(&BENCH_STIMULUS, best.1)?;
    scene.samples_per_pixel = spp;
    if freeze {
        let t = scene.frame_time;
        freeze_at(&mut scene, t);
    }
    Ok(scene)
}

/// Replaces the scene's motion by the sphere as it is at time `t` (speed zero, same
/// position and orientation) and closes the shutter at `t`.
pub fn freeze_at(scene: &mut FrameScene, t: f64) {
    let s = &mut scene.sphere;
    let (centre, orientation) = (s.centre_at(t), s.orientation_at(t));
    s.start = centre;
    s.start_orientation = orientation;
    s.velocity = glam::DVec3::ZERO;
    s.wrap_length = None;
    scene.shutter = study::scene::Shutter { open: t, close: t };
}

/// Camera samples of the design's whole full-preset set, every (M, S, T) at every A level,
/// mono (1 eye) and stereo (2 eyes), every frame: rendered independently, and nested (each
/// stream once, at the highest level).
pub fn full_set_camera_samples(design: &Design) -> Result<(f64, f64), study::design::DesignError> {
    let preset = design.preset("full")?;
    let mst = f64::from(design.level_count(study::ids::Factor::Material))
        * f64::from(design.level_count(study::ids::Factor::Speed))
        * f64::from(design.level_count(study::ids::Factor::Shutter));
    let per_frame = 3.0 * f64::from(preset.frames) * f64::from(preset.width) * f64::from(preset.height);
    let spp_sum: f64 = preset.samples_per_pixel.iter().map(|&s| f64::from(s)).sum();
    let spp_max = preset.samples_per_pixel.iter().copied().max().map_or(0.0, f64::from);
    Ok((mst * spp_sum * per_frame, mst * spp_max * per_frame))
}

/// The benchmark frame as the benchmarks' JSON describes it.
pub fn frame_json(scene: &FrameScene) -> serde_json::Value {
    json!({
        "stimulus": BENCH_STIMULUS.to_string(),
        "frame": scene.frame,
        "width": scene.views[0].camera.width,
        "height": scene.views[0].camera.height,
        "samples_per_pixel": scene.samples_per_pixel,
        "max_bounces": scene.integrator.max_bounces,
        "russian_roulette_from": scene.integrator.russian_roulette_from,
    })
}

/// The sphere of a static frame as another renderer needs it: centre, rotation (object to
/// world, row-major) and the albedo texture baked over Mitsuba's sphere parametrisation.
pub struct PeerSphere {
    /// Centre at the shutter's opening.
    pub centre: [f64; 3],
    /// Rotation matrix rows (object to world).
    pub rotation: [[f64; 3]; 3],
    /// Albedo, `2 h x h` texels: u = phi / 2 pi (phi from +x towards +y), v = theta / pi
    /// (theta from +z) of the point in the object frame, filtered for the footprint of a
    /// pixel at the sphere's distance as this tracer's camera rays see it.
    pub albedo: crate::io::LinearImage,
}

/// Bakes the sphere of `scene` (at its shutter's opening) for a peer renderer.
pub fn peer_sphere(scene: &FrameScene, height: u32) -> PeerSphere {
    use std::f64::consts::PI;
    let cam = &scene.views[0].camera;
    let s = &scene.sphere;
    let t = scene.shutter.open;
    let (centre, orientation) = (s.centre_at(t), s.orientation_at(t));
    let distance = (centre - cam.position).length();
    let footprint = distance * (cam.sensor_width / f64::from(cam.width) / cam.focal_length) / s.radius;
    let shader = crate::shading::material::Shader::new(&scene.material);
    let (tw, th) = (2 * height, height);
    let mut albedo = crate::io::LinearImage::new(tw, th);
    for y in 0..th {
        let theta = PI * (f64::from(y) + 0.5) / f64::from(th);
        for x in 0..tw {
            let phi = 2.0 * PI * (f64::from(x) + 0.5) / f64::from(tw);
            let local = glam::DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let a = shader.albedo(local, footprint);
            albedo.set(x, y, [a.x as f32, a.y as f32, a.z as f32]);
        }
    }
    let m = glam::DMat3::from_quat(orientation);
    let rotation = [0, 1, 2].map(|r| [m.col(0)[r], m.col(1)[r], m.col(2)[r]]);
    PeerSphere { centre: centre.to_array(), rotation, albedo }
}

/// Options of [`run_benchmark`].
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Design file whose M3-S3-T5 frame is rendered.
    pub design: PathBuf,
    /// Samples per pixel of every render.
    pub spp: u32,
    /// Peer renderer: `mitsuba` or `none`.
    pub peer: String,
    /// Python interpreter that has the `mitsuba` package.
    pub python: String,
    /// The peer's driver script.
    pub peer_script: PathBuf,
    /// Mitsuba sampler (`independent`, `stratified`, `multijitter`, `ldsampler`, ...).
    pub mitsuba_sampler: String,
    /// Mitsuba variant: `scalar_rgb` or `llvm_ad_rgb` (its vectorised, JIT-compiled one).
    pub mitsuba_variant: String,
    /// Folder for the peer's scene and images (default: a new temporary folder).
    pub work: Option<PathBuf>,
    /// Rounds of the whole measurement (ours, then the peer's); each renderer's rate is
    /// its best render over all rounds, so a passing disturbance of the machine does not
    /// decide the comparison.
    pub rounds: u32,
}

/// Errors of the benchmark.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The design file.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// The environment map.
    #[error(transparent)]
    Env(#[from] crate::env::EnvError),
    /// Image encoding or decoding.
    #[error(transparent)]
    Image(#[from] crate::io::IoError),
    /// A file of the work folder.
    #[error("{0}: {1}")]
    File(PathBuf, std::io::Error),
    /// The peer renderer.
    #[error("{0}")]
    Peer(String),
    /// The GPU tracer.
    #[error("GPU tracer: {0}")]
    Gpu(String),
    /// A frame the f32 tracer cannot express.
    #[error("benchmark frame: {0}")]
    Frame(String),
}

pub(crate) fn read(path: &Path) -> Result<Vec<u8>, BenchError> {
    std::fs::read(path).map_err(|e| BenchError::File(path.to_path_buf(), e))
}

pub(crate) fn write(path: &Path, bytes: &[u8]) -> Result<(), BenchError> {
    std::fs::write(path, bytes).map_err(|e| BenchError::File(path.to_path_buf(), e))
}

/// Per-pixel noise from two independently seeded renders: their RMS difference over
/// sqrt(2).
pub(crate) fn rms_noise(a: &LinearImage, b: &LinearImage) -> f64 {
    a.rms_difference(b) / std::f64::consts::SQRT_2
}

pub(crate) fn mean_rgb(images: &[&LinearImage]) -> [f64; 3] {
    let n: usize = images.iter().map(|i| i.pixels.len()).sum();
    std::array::from_fn(|c| {
        let sum: CompensatedSum = images.iter().flat_map(|i| i.pixels.iter().map(move |p| f64::from(p[c]))).collect();
        sum.value() / n as f64
    })
}

/// What the benchmark ran on: cores, rayon threads, CPU model, load at the start.
pub fn machine_json() -> serde_json::Value {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name").map(|r| r.trim_start_matches([' ', '\t', ':']).to_string()));
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    json!({
        "nproc": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "rayon_threads": rayon_threads(),
        "cpu_model": model,
        "loadavg_at_start": load.split_whitespace().take(3).collect::<Vec<_>>().join(" "),
    })
}

fn rayon_threads() -> usize {
    // The render crate's parallel loops use rayon's global pool.
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
}

struct Timed {
    image: LinearImage,
    seconds: f64,
    samples: u64,
    nonfinite: u64,
}

/// Which CPU tracer a timed render uses.
#[derive(Clone, Copy)]
enum TimedTracer<'a> {
    /// The wide tracer on an instruction set.
    Wide(&'a EnvTables, Isa),
    /// The f64 reference.
    Reference,
}

fn timed_render(scene: &FrameScene, env: &EnvironmentMap, tracer: TimedTracer<'_>) -> Result<Timed, BenchError> {
    let start = Instant::now();
    let mut out = match tracer {
        TimedTracer::Wide(tables, isa) => wide::render_frame_nested(scene, tables, &[], isa)
            .map_err(|e| BenchError::Frame(e.to_string()))?
            .pop()
            .ok_or_else(|| BenchError::Frame("no image".into()))?,
        TimedTracer::Reference => render_frame(scene, env).map_err(|e| BenchError::Frame(e.to_string()))?,
    };
    let seconds = start.elapsed().as_secs_f64();
    Ok(Timed { image: out.eyes.remove(0), seconds, samples: out.camera_samples, nonfinite: out.nonfinite_samples })
}

/// Speed-up at equal noise: the ratio of rates times the ratio of variances at equal spp
/// (variance falls as 1 / spp, so the noisier renderer needs `(noise ratio)^2` the samples).
fn at_equal_noise(speedup: f64, ours_noise: f64, their_noise: f64) -> f64 {
    speedup * (their_noise / ours_noise).powi(2)
}

/// Renders the benchmark frames with the wide CPU tracer (on the widest instruction set)
/// and, with `peer = "mitsuba"`, runs the Mitsuba 3 driver (variant `mitsuba_variant`) on
/// the same static frame; returns the JSON report (machine, speeds, noise, comparison at
/// equal spp and at equal noise, projected time of the full set). Beside them, in the same
/// rounds: the static frame on every instruction set this CPU has, on one thread and on
/// all, and with the f64 reference tracer.
///
/// Noise is the RMS over pixels and channels of the difference of two independently
/// seeded renders divided by sqrt(2): an unbiased estimate of the per-pixel standard
/// deviation that needs no reference image. Each round renders our moving frame and both
/// static seeds, then runs the peer (which renders its two seeds); rates are each
/// renderer's best render over all rounds (Mitsuba's driver has always reported its best),
/// and the means are reported beside them.
pub fn run_benchmark(opts: &BenchOptions) -> Result<serde_json::Value, BenchError> {
    let machine = machine_json();
    let design = Design::load(&opts.design)?;
    let moving = benchmark_frame(&design, opts.spp, false)?;
    let frozen = benchmark_frame(&design, opts.spp, true)?;
    let env = EnvironmentMap::from_lighting(&moving.lighting)?;
    let tables = EnvTables::new(&env);
    let widest = Isa::widest();
    let ours = TimedTracer::Wide(&tables, widest);
    let peer = match opts.peer.as_str() {
        "mitsuba" => {
            let work = match &opts.work {
                Some(w) => w.clone(),
                None => std::env::temp_dir().join(format!("blurlab-bench-tracer-{}", std::process::id())),
            };
            std::fs::create_dir_all(&work).map_err(|e| BenchError::File(work.clone(), e))?;
            write_peer_scene(&frozen, &work, &opts.mitsuba_sampler, &opts.mitsuba_variant)?;
            Some(work)
        }
        "none" => None,
        other => return Err(BenchError::Peer(format!("unknown peer `{other}` (expected mitsuba or none)"))),
    };

    // Warm-up (page faults, thread pool start) on a small copy, not timed.
    let mut warm = frozen.clone();
    warm.samples_per_pixel = 1;
    timed_render(&warm, &env, ours)?;
    timed_render(&warm, &env, TimedTracer::Reference)?;

    let mut frozen_b = frozen.clone();
    frozen_b.views[0].seed ^= 0x9e37_79b9_7f4a_7c15;

    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| BenchError::Frame(format!("a one-thread pool: {e}")))?;
    let isas = Isa::available();
    // Rounds alternate the renderers; the images of the last round are kept (the same
    // seeds give the same images every round).
    let (mut moving_seconds, mut static_seconds, mut peer_runs) = (Vec::new(), Vec::new(), Vec::new());
    let mut isa_seconds: Vec<Vec<f64>> = vec![Vec::new(); isas.len()];
    let (mut one_thread_seconds, mut reference_seconds) = (Vec::new(), Vec::new());
    let mut last = None;
    let mut reference_images = None;
    for _ in 0..opts.rounds.max(1) {
        let moving_run = timed_render(&moving, &env, ours)?;
        let static_a = timed_render(&frozen, &env, ours)?;
        let static_b = timed_render(&frozen_b, &env, ours)?;
        moving_seconds.push(moving_run.seconds);
        static_seconds.extend([static_a.seconds, static_b.seconds]);
        for (isa, seconds) in isas.iter().zip(&mut isa_seconds) {
            let run = timed_render(&frozen, &env, TimedTracer::Wide(&tables, *isa))?;
            if run.image != static_a.image {
                return Err(BenchError::Frame(format!("the {isa} path rendered other bytes than the {widest} path")));
            }
            seconds.push(run.seconds);
        }
        one_thread_seconds.push(one_thread.install(|| timed_render(&frozen, &env, ours))?.seconds);
        let reference_a = timed_render(&frozen, &env, TimedTracer::Reference)?;
        reference_seconds.push(reference_a.seconds);
        if reference_images.is_none() {
            let reference_b = timed_render(&frozen_b, &env, TimedTracer::Reference)?;
            reference_images = Some((reference_a.image, reference_b.image));
        }
        if let Some(work) = &peer {
            peer_runs.push(run_peer(opts, work)?);
        }
        last = Some((moving_run, static_a, static_b));
    }
    let (moving_run, static_a, static_b) = last.expect("at least one round");
    let (reference_a, reference_b) = reference_images.expect("at least one round");
    let best = |samples: u64, seconds: &[f64]| samples as f64 / seconds.iter().copied().fold(f64::INFINITY, f64::min);
    let mean = |samples: u64, seconds: &[f64]| samples as f64 * seconds.len() as f64 / seconds.iter().sum::<f64>();
    let ours_static_sps = best(static_a.samples, &static_seconds);
    let ours_static_sps_mean = mean(static_a.samples, &static_seconds);
    let ours_noise = rms_noise(&static_a.image, &static_b.image);
    let ours_mean = mean_rgb(&[&static_a.image, &static_b.image]);
    let moving_sps = best(moving_run.samples, &moving_seconds);
    let n = static_a.samples;
    let reference_sps = best(n, &reference_seconds);
    let one_thread_sps = best(n, &one_thread_seconds);
    let cam = &frozen.views[0].camera;

    let (set_samples, _) = full_set_camera_samples(&design)?;
    let set_seconds = set_samples / moving_sps;

    let mut result = json!({
        "benchmark": "tracer",
        "command": std::env::args().collect::<Vec<_>>().join(" "),
        "machine": machine,
        // The instruction set this binary was compiled for; the wide tracer picks its own at
        // run time (`dispatch_paths`).
        "build": {
            "avx2": cfg!(target_feature = "avx2"),
            "fma": cfg!(target_feature = "fma"),
            "bmi2": cfg!(target_feature = "bmi2"),
        },
        "frame": frame_json(&moving),
        "blurlab": {
            "tracer": "wide",
            "isa": widest.name(),
            "moving_frame": {
                "seconds": moving_seconds,
                "camera_samples": moving_run.samples,
                "camera_samples_per_second": moving_sps,
                "camera_samples_per_second_mean": mean(moving_run.samples, &moving_seconds),
                "nonfinite_samples": moving_run.nonfinite,
            },
            "static_frame": {
                "seconds": static_seconds,
                "camera_samples_per_second": ours_static_sps,
                "camera_samples_per_second_mean": ours_static_sps_mean,
                "noise_rms": ours_noise,
                "mean_rgb": ours_mean,
            },
        },
        "dispatch_paths": isas.iter().zip(&isa_seconds).map(|(isa, seconds)| json!({
            "isa": isa.name(),
            "seconds": seconds,
            "camera_samples_per_second": best(n, seconds),
            "camera_samples_per_second_mean": mean(n, seconds),
            "same_bytes_as_widest": true,
        })).collect::<Vec<_>>(),
        "thread_scaling": {
            "threads_1": one_thread_sps,
            "threads_all": ours_static_sps,
            "threads_all_count": rayon::current_num_threads(),
            "speedup": ours_static_sps / one_thread_sps,
        },
        "memory": {
            "per_thread_heap_bytes": wide::per_thread_heap_bytes(cam.width, 1, frozen.integrator.max_bounces),
            "per_thread_packet_state_bytes": wide::packet_state_bytes(),
            "shared_environment_bytes": tables.words.len() * 4,
        },
        "reference_f64": {
            "seconds": reference_seconds,
            "camera_samples_per_second": reference_sps,
            "camera_samples_per_second_mean": mean(n, &reference_seconds),
            "noise_rms": rms_noise(&reference_a, &reference_b),
            "mean_rgb": mean_rgb(&[&reference_a, &reference_b]),
            "wide_speedup": ours_static_sps / reference_sps,
        },
        "full_set_projection": {
            "camera_samples": set_samples,
            "at_camera_samples_per_second": moving_sps,
            "seconds": set_seconds,
            "hours": set_seconds / 3600.0,
        },
    });

    if let Some(work) = &peer {
        let peer_samples = static_a.samples;
        let peer_seconds: Vec<f64> = peer_runs
            .iter()
            .flat_map(|r| r["render_seconds"].as_array().into_iter().flatten().filter_map(serde_json::Value::as_f64))
            .collect();
        if peer_seconds.is_empty() {
            return Err(BenchError::Peer("the Mitsuba peer reported no render times".into()));
        }
        let their_sps = best(peer_samples, &peer_seconds);
        let their_sps_mean = mean(peer_samples, &peer_seconds);
        let load = |name: &str| -> Result<LinearImage, BenchError> {
            let path = work.join(name);
            decode_exr(&read(&path)?).map_err(|e| BenchError::Peer(format!("{}: {e}", path.display())))
        };
        let (ma, mb) = (load("mitsuba-seed1.exr")?, load("mitsuba-seed2.exr")?);
        let their_noise = rms_noise(&ma, &mb);
        let ours_avg = LinearImage::mean(&[&static_a.image, &static_b.image]);
        let theirs_avg = LinearImage::mean(&[&ma, &mb]);
        // Agreement of the two renderers' images (includes both noises).
        let image_rms_difference = ours_avg.rms_difference(&theirs_avg);
        let speedup = ours_static_sps / their_sps;
        let speedup_mean = ours_static_sps_mean / their_sps_mean;
        let equal_noise = at_equal_noise(speedup, ours_noise, their_noise);
        let equal_noise_mean = at_equal_noise(speedup_mean, ours_noise, their_noise);
        result["mitsuba"] = json!({
            "variant": opts.mitsuba_variant,
            "driver": peer_runs,
            "render_seconds": peer_seconds,
            "camera_samples_per_second": their_sps,
            "camera_samples_per_second_mean": their_sps_mean,
            "noise_rms": their_noise,
            "mean_rgb": mean_rgb(&[&ma, &mb]),
        });
        result["comparison"] = json!({
            "rate": "best render of all rounds (and mean of all renders), for both renderers",
            "speedup_static": speedup,
            "speedup_static_mean": speedup_mean,
            "speedup_moving_vs_mitsuba_static": moving_sps / their_sps,
            "noise_ratio_blurlab_over_mitsuba": ours_noise / their_noise,
            "speedup_at_equal_noise": equal_noise,
            "speedup_at_equal_noise_mean": equal_noise_mean,
            "image_rms_difference": image_rms_difference,
            // Against scalar_rgb: 5x at no more noise; against llvm_ad_rgb: 2x at equal
            // noise, best against best and mean against mean.
            "target_met": if opts.mitsuba_variant.starts_with("llvm") {
                equal_noise >= 2.0 && equal_noise_mean >= 2.0
            } else {
                speedup >= 5.0 && ours_noise <= their_noise
            },
        });
        write(&work.join("blurlab-seed1.exr"), &encode_exr(&static_a.image)?)?;
        write(&work.join("blurlab-seed2.exr"), &encode_exr(&static_b.image)?)?;
        result["work_dir"] = json!(work);
    }

    Ok(result)
}

/// Runs one round of the Mitsuba driver in `work` (scene already written) and returns
/// its report.
fn run_peer(opts: &BenchOptions, work: &Path) -> Result<serde_json::Value, BenchError> {
    run_peer_script(&opts.python, &opts.peer_script, work)
}

/// Runs the Mitsuba driver `script` with `python` on the work folder and reads its report.
pub(crate) fn run_peer_script(python: &str, script: &Path, work: &Path) -> Result<serde_json::Value, BenchError> {
    let status = std::process::Command::new(python)
        .arg(script)
        .arg(work)
        .status()
        .map_err(|e| BenchError::Peer(format!("cannot start {python} {}: {e}", script.display())))?;
    if !status.success() {
        return Err(BenchError::Peer(format!("the Mitsuba peer failed ({status}); is `pip install mitsuba` done?")));
    }
    let peer_json = work.join("mitsuba.json");
    serde_json::from_slice(&read(&peer_json)?).map_err(|e| BenchError::Peer(format!("{}: {e}", peer_json.display())))
}

/// Writes `scene.json`, the environment map and the sphere's baked albedo for the peer; a
/// scene with a medium also gets its grid at the frame's instant as a Mitsuba `.vol` file
/// (`crate::measure::media_reference`).
pub(crate) fn write_peer_scene(scene: &FrameScene, dir: &Path, sampler: &str, variant: &str) -> Result<(), BenchError> {
    let cam = &scene.views[0].camera;
    let env_image = match &scene.lighting.environment {
        Environment::Default { width } => default_map(*width),
        Environment::File { path } => {
            let bytes = read(path)?;
            match path.extension().and_then(|e| e.to_str()) {
                Some("exr") => decode_exr(&bytes)?,
                _ => crate::io::decode_hdr(&bytes)?,
            }
        }
        Environment::Uniform { radiance } => {
            let mut img = LinearImage::new(8, 4);
            img.pixels.fill(radiance.map(|c| c as f32));
            img
        }
    };
    if scene.lighting.rotation_y != 0.0 {
        return Err(BenchError::Peer(
            "the Mitsuba peer does not rotate the environment; use an unrotated design".into(),
        ));
    }
    let env_path = dir.join("environment.exr");
    write(&env_path, &encode_exr(&env_image)?)?;

    let sphere = peer_sphere(scene, 1024);
    let tex_path = dir.join("sphere-albedo.exr");
    write(&tex_path, &encode_exr(&sphere.albedo)?)?;

    let mut desc = json!({
        "camera": {
            "position": cam.position.to_array(),
            "target": (cam.position + cam.forward).to_array(),
            "up": cam.up.to_array(),
            "horizontal_fov_degrees": cam.horizontal_fov().to_degrees(),
            "width": cam.width,
            "height": cam.height,
        },
        "sphere": {
            "centre": sphere.centre,
            "radius": scene.sphere.radius,
            "rotation": sphere.rotation,
            "albedo_exr": tex_path,
        },
        "floor": { "height": scene.floor.height, "albedo": scene.floor.albedo },
        "environment_exr": env_path,
        "environment_scale": scene.lighting.intensity,
        "samples_per_pixel": scene.samples_per_pixel,
        // blurlab's B bounces are B scattering events: B + 1 path segments.
        "mitsuba_max_depth": scene.integrator.max_bounces + 1,
        "mitsuba_rr_depth": scene.integrator.russian_roulette_from + 1,
        "mitsuba_sampler": sampler,
        "mitsuba_variant": variant,
    });
    if let Some(medium) = &scene.medium {
        let (json, depth) = crate::measure::media_reference::write_peer_medium(scene, medium, dir)?;
        desc["medium"] = json;
        desc["mitsuba_max_depth"] = json!(depth);
    }
    write(&dir.join("scene.json"), &serde_json::to_vec_pretty(&desc).expect("JSON of plain values"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unknown_peer_is_named_before_anything_is_rendered() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let opts = BenchOptions {
            design: root.join("stimuli/navarro2011.toml"),
            spp: 1,
            peer: "blender".into(),
            python: "python3".into(),
            peer_script: root.join("bench/mitsuba_peer.py"),
            mitsuba_sampler: "independent".into(),
            mitsuba_variant: "scalar_rgb".into(),
            work: None,
            rounds: 1,
        };
        let err = run_benchmark(&opts).unwrap_err().to_string();
        assert!(err.contains("unknown peer `blender` (expected mitsuba or none)"), "{err}");
    }
}
