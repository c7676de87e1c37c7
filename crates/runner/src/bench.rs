//! Measurements behind `blurlab bench playback`: decoding a sequence and uploading it as
//! GPU textures (the same `create_texture` + `write_texture` per frame that egui-wgpu does
//! for a new texture), memory held while a stereo 2AFC trial's stimuli are resident, and
//! frame-interval statistics from a session's frame log.

use std::path::Path;
use std::sync::atomic::AtomicUsize;
use std::time::Instant;

use eframe::wgpu;
use serde::Serialize;
use study::experiment::DisplayMode;

use crate::RunnerError;
use crate::gpu::FrameUploader;
use crate::stimuli::{Decoded, Sequence, decode_sequence_for};

/// A headless wgpu device for upload measurements, uploading as the window does
/// ([`FrameUploader`]).
pub struct Gpu {
    uploader: FrameUploader,
    /// Adapter name and backend (`"NAME (BACKEND)"`).
    pub adapter: String,
}

impl Gpu {
    /// A device from the gpu crate: a hardware adapter, else a software one (on machines
    /// without a GPU, Mesa's lavapipe when installed).
    pub fn new() -> Result<Gpu, gpu::GpuError> {
        let ctx = gpu::acquire(gpu::AdapterChoice::HardwareThenSoftware, &gpu::DeviceRequest::default())?;
        let adapter = ctx.info.short();
        Ok(Gpu { uploader: FrameUploader::new(ctx.device, ctx.queue), adapter })
    }

    /// Uploads (and, where the GPU composes the display mode, composes) every frame as its own
    /// texture and waits for the queue; returns the textures.
    pub fn upload(&self, decoded: &Decoded) -> Result<Vec<wgpu::Texture>, RunnerError> {
        self.uploader.upload(decoded)
    }

    /// Decodes a sequence as the window does with this device (display modes the GPU composes
    /// are left to it).
    pub fn decode(
        sequence: &Sequence,
        mode: DisplayMode,
        progress: &AtomicUsize,
        threads: usize,
        gpu: Option<&Gpu>,
    ) -> Result<Decoded, RunnerError> {
        decode_sequence_for(sequence, mode, gpu.is_some(), progress, threads)
    }
}

/// Timing of one sequence's decode and upload.
#[derive(Clone, Debug, Serialize)]
pub struct DecodeUpload {
    /// The stimulus.
    pub id: String,
    /// Frames.
    pub frames: usize,
    /// Display image size (after the display transform, on the CPU or the GPU).
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Decoder threads.
    pub threads: usize,
    /// Milliseconds to decode all frames and apply the display transforms done on the CPU.
    pub decode_ms: f64,
    /// Milliseconds to upload all frames, with the transforms done on the GPU (None without an adapter).
    pub upload_ms: Option<f64>,
    /// Bytes of decoded pixels.
    pub bytes: usize,
    /// Milliseconds until the sequence is on the GPU (decode + upload; decode alone without
    /// an adapter).
    pub ready_ms: f64,
    /// Whether `ready_ms` is under [`READY_TARGET_MS`].
    pub target_met: bool,
}

/// The target: a trial's stimuli ready in under 1 s.
pub const READY_TARGET_MS: f64 = 1000.0;

/// Decodes (and uploads, given a device) one sequence, timing both.
pub fn decode_upload(
    sequence: &Sequence,
    mode: DisplayMode,
    threads: usize,
    gpu: Option<&Gpu>,
) -> Result<DecodeUpload, RunnerError> {
    let progress = AtomicUsize::new(0);
    let t = Instant::now();
    let decoded = Gpu::decode(sequence, mode, &progress, threads, gpu)?;
    let decode_ms = t.elapsed().as_secs_f64() * 1e3;
    let upload_ms = match gpu {
        Some(g) => {
            let t = Instant::now();
            let textures = g.upload(&decoded)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            drop(textures);
            Some(ms)
        }
        None => None,
    };
    let [width, height] = decoded.display_size();
    let ready_ms = decode_ms + upload_ms.unwrap_or(0.0);
    Ok(DecodeUpload {
        ready_ms,
        target_met: ready_ms < READY_TARGET_MS,
        id: decoded.id.to_string(),
        frames: decoded.frames.len(),
        width: width as u32,
        height: height as u32,
        threads,
        decode_ms,
        upload_ms,
        bytes: decoded.bytes(),
    })
}

/// Resident and peak resident memory of this process in KiB (Linux `/proc/self/status`).
pub fn memory_kib() -> Option<(u64, u64)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field =
        |name: &str| status.lines().find(|l| l.starts_with(name))?.split_whitespace().nth(1)?.parse::<u64>().ok();
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// Time and memory to get a 2AFC trial's two sequences ready, as the window does it (both
/// decoded, then both uploaded).
#[derive(Clone, Debug, Serialize)]
pub struct TrialLoad {
    /// Display mode used.
    pub mode: String,
    /// The two stimuli.
    pub ids: [String; 2],
    /// Milliseconds to decode both sequences and apply the display transforms done on the CPU.
    pub decode_ms: f64,
    /// Milliseconds to upload both (None without an adapter).
    pub upload_ms: Option<f64>,
    /// Milliseconds until both are on the GPU.
    pub ready_ms: f64,
    /// Whether `ready_ms` is under [`READY_TARGET_MS`].
    pub target_met: bool,
    /// Bytes of decoded pixels of both sequences (the CPU copies the window frees after upload).
    pub decoded_bytes: usize,
    /// Bytes of texture data on the GPU (one RGBA8 texel per pixel).
    pub texture_bytes: usize,
    /// Resident memory before loading, KiB.
    pub rss_before_kib: u64,
    /// Resident memory with both sequences decoded and uploaded, KiB.
    pub rss_loaded_kib: u64,
    /// Resident memory after the CPU copies are dropped (textures kept), KiB.
    pub rss_textures_only_kib: u64,
}

/// Loads two sequences as a 2AFC trial does and reports time and memory.
pub fn trial_load(
    a: &Sequence,
    b: &Sequence,
    mode: DisplayMode,
    threads: usize,
    gpu: Option<&Gpu>,
) -> Result<TrialLoad, RunnerError> {
    let before = memory_kib().map_or(0, |m| m.0);
    let progress = AtomicUsize::new(0);
    let t = Instant::now();
    let da = Gpu::decode(a, mode, &progress, threads, gpu)?;
    let db = Gpu::decode(b, mode, &progress, threads, gpu)?;
    let decode_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut textures = Vec::new();
    if let Some(g) = gpu {
        textures.push(g.upload(&da)?);
        textures.push(g.upload(&db)?);
    }
    let upload_ms = gpu.map(|_| t.elapsed().as_secs_f64() * 1e3);
    let texture_bytes: usize = textures.iter().flatten().map(|t| 4 * t.width() as usize * t.height() as usize).sum();
    let ready_ms = decode_ms + upload_ms.unwrap_or(0.0);
    let loaded = memory_kib().map_or(0, |m| m.0);
    let ids = [da.id.to_string(), db.id.to_string()];
    let decoded_bytes = da.bytes() + db.bytes();
    drop((da, db));
    let textures_only = memory_kib().map_or(0, |m| m.0);
    drop(textures);
    Ok(TrialLoad {
        mode: mode.name().into(),
        ids,
        decode_ms,
        upload_ms,
        ready_ms,
        target_met: ready_ms < READY_TARGET_MS,
        decoded_bytes,
        texture_bytes,
        rss_before_kib: before,
        rss_loaded_kib: loaded,
        rss_textures_only_kib: textures_only,
    })
}

/// Frame-interval statistics of a session's frame log.
#[derive(Clone, Debug, Serialize)]
pub struct FrameStats {
    /// Frames presented.
    pub frames: usize,
    /// Frames late or skipped (sum of `dropped_frames` over the session's rows).
    pub dropped: u64,
    /// Frames flagged late in the frame log.
    pub late: usize,
    /// Mean interval between successive frames of a sequence, ms.
    pub mean_interval_ms: f64,
    /// Standard deviation of the intervals, ms.
    pub sd_interval_ms: f64,
    /// Largest interval, ms.
    pub max_interval_ms: f64,
    /// Expected interval (1000 / fps), ms.
    pub expected_interval_ms: f64,
}

/// Reads `session-N.frames.tsv` and the session's rows and computes frame statistics.
pub fn frame_stats(csv: &Path, fps: f64) -> Result<FrameStats, RunnerError> {
    let frames_path = csv.with_extension("frames.tsv");
    let text = std::fs::read_to_string(&frames_path)
        .map_err(|source| RunnerError::Io { path: frames_path.clone(), source })?;
    let mut intervals = Vec::new();
    let mut last: Option<(String, String, f64)> = None;
    let (mut frames, mut late) = (0, 0);
    for line in text.lines().skip(1) {
        let cols: Vec<&str> = line.split('\t').collect();
        if cols.len() != 6 {
            continue;
        }
        let shown: f64 = cols[4].parse().unwrap_or(f64::NAN);
        frames += 1;
        late += usize::from(cols[5] == "1");
        if let Some((t, s, prev)) = &last
            && t == cols[0]
            && s == cols[1]
            && shown > *prev
        {
            intervals.push(shown - prev);
        }
        last = Some((cols[0].to_owned(), cols[1].to_owned(), shown));
    }
    let log = study::response::SessionLog::read(csv)?;
    let dropped = log.rows.iter().map(|(_, r)| u64::from(r.dropped_frames)).sum();
    let summary = study::stats::Summary::of(&intervals);
    let (mean, sd, max) = (summary.mean, summary.population_sd(), summary.max.max(0.0));
    Ok(FrameStats {
        frames,
        dropped,
        late,
        mean_interval_ms: mean,
        sd_interval_ms: sd,
        max_interval_ms: max,
        expected_interval_ms: 1000.0 / fps,
    })
}
