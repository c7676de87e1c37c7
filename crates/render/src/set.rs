//! Rendering whole stimulus sets: one folder of frames per sequence, its `manifest.json`,
//! the set's `index.json`, resume, and progress display.
//!
//! Crash safety: every file is written atomically; a sequence's frames come first and its
//! manifest last, so a manifest exists only for a sequence whose frames are all on disk.
//! Before a sequence is re-rendered it loses its manifest, so a kill at any moment leaves no
//! incomplete sequence marked complete. `--resume` trusts a sequence only when its manifest
//! matches the request and every frame's hash verifies.
//!
//! Several writers: the manifests are the truth and `index.json` is rebuilt from them (those
//! of this design, preset and sampling mode whose files verify) after each sequence, and
//! rewritten until a fresh rebuild equals the file on disk, so renders into one folder from
//! several processes or machines all keep every completed sequence without relying on
//! locks. A process takes `render.lock` in a sequence's folder (`study::lock`) while it
//! renders it, and leaves a sequence locked by another live process to that process. A
//! folder holding sequences of another version of the design (its `design_sha256`), another
//! preset or sampling mode is refused, naming the design keys that differ from the folder's
//! `design.toml` copy.

use std::io::{self, IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};
use study::design::{Design, DesignError, Preset};
use study::fsio::{sha256_file, sha256_hex, write_atomic};
use study::manifest::{
    FrameRecord, INDEX_FORMAT, IndexEntry, ManifestError, SEQUENCE_FORMAT, SequenceManifest, SetIndex,
};
use study::{Eye, Method, SOFTWARE_VERSION, StimulusId};

use study::manifest::Sampling;
use study::scene::FrameScene;

use crate::device::{DeviceChoice, DeviceError, Renderer, Submitted};
use crate::env::{EnvError, EnvironmentMap};
use crate::io::{IoError, LinearImage, encode_exr, encode_png_srgb};
use crate::method::RenderError;

/// Why a set could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum SetError {
    /// The design does not fit the request.
    #[error(transparent)]
    Design(#[from] DesignError),
    /// The environment map could not be built.
    #[error(transparent)]
    Environment(#[from] EnvError),
    /// A file or folder could not be written, read or removed.
    #[error("{}: {action}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// Cause (its kind tells a full disk or a permission problem).
        source: io::Error,
    },
    /// An image could not be encoded.
    #[error("{}: cannot encode", path.display())]
    Encode {
        /// The file being produced.
        path: PathBuf,
        /// Cause.
        source: IoError,
    },
    /// The method cannot render here, or the GPU failed.
    #[error(transparent)]
    Method(#[from] RenderError),
    /// The requested device cannot be opened.
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// The output folder holds a set that this request must not mix with.
    #[error("{}: {message}", path.display())]
    Mismatch {
        /// The conflicting file.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// Shards that do not add up to their set: every unit missing, damaged, duplicated or
    /// not in the plan, one per line.
    #[error("{summary}{}", lines.iter().map(|l| format!("\n  {l}")).collect::<String>())]
    Incomplete {
        /// What was checked.
        summary: String,
        /// One line per problem.
        lines: Vec<String>,
    },
}

impl SetError {
    /// Whether the error comes from the user's input (design, environment map, output
    /// folder holding another set) rather than from writing.
    pub fn is_bad_input(&self) -> bool {
        if let SetError::Method(e) = self {
            return e.is_bad_input();
        }
        matches!(
            self,
            SetError::Design(_)
                | SetError::Environment(_)
                | SetError::Device(DeviceError::NoGpu(_))
                | SetError::Mismatch { .. }
                | SetError::Incomplete { .. }
        )
    }
}

/// Where files go. The default writes atomically; tests substitute failing writers.
pub trait FileWriter: Sync {
    /// Writes `bytes` to `path`, replacing it atomically.
    fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()>;
}

/// Writes with [`study::fsio::write_atomic`].
pub struct AtomicWriter;

impl FileWriter for AtomicWriter {
    fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()> {
        write_atomic(path, bytes)
    }
}

/// How progress is shown on stderr.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars (overall with ETA, and the current sequence) on a terminal, lines otherwise.
    Auto,
    /// One line per finished sequence.
    Lines,
    /// Nothing.
    Quiet,
}

/// What to render and where.
pub struct SetRequest<'a> {
    /// The design.
    pub design: &'a Design,
    /// The resolved preset.
    pub preset: Preset,
    /// Sequences to render, in order.
    pub ids: Vec<StimulusId>,
    /// The rendering method (recorded in every manifest).
    pub method: Method,
    /// The set's folder.
    pub out: PathBuf,
    /// Skip sequences that verify.
    pub resume: bool,
    /// Also write linear EXR frames.
    pub exr: bool,
    /// Progress display.
    pub progress: ProgressMode,
    /// Where to render (`--device`).
    pub device: DeviceChoice,
    /// Independent sample levels (the study's way) or nested ones (`--nested`).
    pub sampling: Sampling,
}

impl SetRequest<'_> {
    /// The method and settings that render `id`: its method level's in a design with a
    /// method factor, else the request's method with the design's `[method]` settings.
    pub fn method_of(&self, id: &StimulusId) -> Result<study::method::MethodSpec, SetError> {
        if self.design.has_method_factor() {
            return Ok(self.design.method_of(id)?);
        }
        let spec = &self.design.spec.method;
        Ok(if spec.kind == self.method { spec.clone() } else { study::method::MethodSpec::of(self.method) })
    }
}

/// What a run did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SetReport {
    /// Sequences rendered by this run.
    pub rendered: Vec<StimulusId>,
    /// Sequences skipped because they verified (`--resume`).
    pub skipped: Vec<StimulusId>,
    /// Non-finite samples discarded in this run.
    pub nonfinite_samples: u64,
    /// Wall seconds of this run.
    pub wall_seconds: f64,
    /// The device that rendered, as manifests name it.
    pub device: String,
    /// Sequences another live process was rendering, left to it, and that process.
    pub left_to_others: Vec<(StimulusId, String)>,
}

/// The file name of frame `index`.
pub fn frame_name(index: u32, extension: &str) -> String {
    format!("frame-{index:04}.{extension}")
}

/// CPU seconds used by this process so far (user + system, all threads), from
/// `/proc/self/stat`; `None` where that is not available.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = fields.get(11)?.parse().ok()?;
    let stime: f64 = fields.get(12)?.parse().ok()?;
    // Linux reports these in USER_HZ, which is 100 on every mainstream platform.
    Some((utime + stime) / 100.0)
}

pub(crate) fn io_err<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(io::Error) -> SetError + 'a {
    move |source| SetError::Io { path: path.to_owned(), action, source }
}

/// Camera samples of one frame of `id`: the unit of the overall progress bar, since render
/// time grows linearly with it.
pub(crate) fn frame_cost(preset: &Preset, id: &StimulusId) -> u64 {
    let eyes = study::Eye::of_view(id.view).len() as u64;
    let spp = u64::from(preset.samples_per_pixel[usize::from(id.samples - 1)]);
    u64::from(preset.width) * u64::from(preset.height) * eyes * spp
}

pub(crate) struct Progress {
    mode: ProgressMode,
    multi: Option<MultiProgress>,
    overall: Option<ProgressBar>,
    total_sequences: usize,
}

impl Progress {
    pub(crate) fn new(mode: ProgressMode, total_cost: u64, total_sequences: usize) -> Self {
        let mode = match mode {
            ProgressMode::Auto if io::stderr().is_terminal() => ProgressMode::Auto,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m,
        };
        if mode != ProgressMode::Auto {
            return Progress { mode, multi: None, overall: None, total_sequences };
        }
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let overall = multi.add(ProgressBar::new(total_cost.max(1)));
        overall.set_style(
            ProgressStyle::with_template(
                "{prefix:>18} [{elapsed_precise}] {wide_bar} {percent:>3}% ETA {eta_precise} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        overall.set_prefix("set");
        overall.set_message(format!("0/{total_sequences} sequences"));
        overall.enable_steady_tick(Duration::from_millis(500));
        Progress { mode, multi: Some(multi), overall: Some(overall), total_sequences }
    }

    pub(crate) fn sequence_bar(&self, id: &StimulusId, frames: u32) -> Option<ProgressBar> {
        let multi = self.multi.as_ref()?;
        let bar = multi.add(ProgressBar::new(u64::from(frames)));
        bar.set_style(
            ProgressStyle::with_template("{prefix:>18} {wide_bar} frame {pos}/{len} {rate} ETA {eta}")
                .map(|style| {
                    style.with_key("rate", |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                        let _ = write!(w, "{:.2} frames/s", state.per_sec());
                    })
                })
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(id.to_string());
        Some(bar)
    }

    pub(crate) fn advance(&self, cost: u64) {
        if let Some(o) = &self.overall {
            o.inc(cost);
        }
    }

    pub(crate) fn finished(&self, done: usize, id: &dyn std::fmt::Display, what: &str, seconds: f64) {
        let line = format!("[{done}/{}] {id}: {what} ({seconds:.1} s)", self.total_sequences);
        match self.mode {
            ProgressMode::Quiet => {}
            ProgressMode::Lines => {
                let _ = writeln!(io::stderr(), "{line}");
            }
            ProgressMode::Auto => {
                if let Some(o) = &self.overall {
                    o.set_message(format!("{done}/{} sequences", self.total_sequences));
                    o.println(line);
                }
            }
        }
    }

    pub(crate) fn finish(&self) {
        if let Some(o) = &self.overall {
            o.finish_and_clear();
        }
    }
}

/// Renders the requested sequences with the CPU tracer, writing through [`AtomicWriter`].
pub fn render_set(request: &SetRequest<'_>) -> Result<SetReport, SetError> {
    render_set_with(request, &AtomicWriter)
}

/// Renders the requested sequences, writing every file through `writer`.
pub fn render_set_with(request: &SetRequest<'_>, writer: &dyn FileWriter) -> Result<SetReport, SetError> {
    let started = Instant::now();
    let design = request.design;
    let preset = &request.preset;
    for id in &request.ids {
        design.check_id(id)?;
    }
    let out = &request.out;
    std::fs::create_dir_all(out).map_err(io_err(out, "cannot create the output folder"))?;
    let mut folder = SetFolder::open(out, design, preset, request.sampling)?;
    // Publishing the index first finds an unwritable folder before any rendering.
    folder.publish(writer)?;
    let env = EnvironmentMap::from_lighting(&design.lighting)?;
    let renderer = Renderer::open(request.device, &env)?;

    let total_cost: u64 = request.ids.iter().map(|id| frame_cost(preset, id) * u64::from(preset.frames)).sum();
    let progress = Progress::new(request.progress, total_cost, request.ids.len());
    let mut report = SetReport { device: renderer.device_name(), ..SetReport::default() };
    let mut done = 0;
    let result = (|| {
        for group in streams(&request.ids, request.sampling) {
            let group_started = Instant::now();
            // One writer per sequence: a sequence another live process is rendering is left
            // to it (its manifest joins the index when that process finishes it).
            let mut locks = Vec::new();
            let mut busy = None;
            for id in &group {
                let seq = out.join(id.to_string());
                std::fs::create_dir_all(&seq).map_err(io_err(&seq, "cannot create the sequence folder"))?;
                match study::lock::LockFile::acquire(&seq.join(SEQUENCE_LOCK)) {
                    Ok(lock) => locks.push(lock),
                    Err(study::lock::LockError::Held { holder, .. }) => {
                        busy = Some(holder);
                        break;
                    }
                    Err(study::lock::LockError::Io { path, source }) => {
                        return Err(SetError::Io { path, action: "cannot take the sequence's lock", source });
                    }
                }
            }
            if let Some(holder) = busy {
                drop(locks);
                for id in group {
                    progress.advance(frame_cost(preset, &id) * u64::from(preset.frames));
                    done += 1;
                    progress.finished(done, &id, &format!("left to the process rendering it ({holder})"), 0.0);
                    report.left_to_others.push((id, holder.to_string()));
                }
                continue;
            }
            let mut todo = Vec::new();
            for id in group {
                let seq = out.join(id.to_string());
                if request.resume
                    && let Some(manifest_sha) = verify_sequence(
                        &seq,
                        design,
                        preset,
                        &id,
                        request.method_of(&id)?.kind,
                        request.exr,
                        request.sampling,
                    )
                {
                    folder.verified.insert((id, manifest_sha));
                    folder.publish(writer)?;
                    progress.advance(frame_cost(preset, &id) * u64::from(preset.frames));
                    report.skipped.push(id);
                    done += 1;
                    progress.finished(done, &id, "verified, skipped", 0.0);
                } else {
                    todo.push(id);
                }
            }
            if todo.is_empty() {
                continue;
            }
            for id in &todo {
                let seq = out.join(id.to_string());
                let manifest_path = seq.join("manifest.json");
                // Un-mark the sequence before touching its files: without its manifest it
                // leaves the index.
                match std::fs::remove_file(&manifest_path) {
                    Ok(()) => folder.publish(writer)?,
                    Err(e) if e.kind() != io::ErrorKind::NotFound => {
                        return Err(SetError::Io {
                            path: manifest_path,
                            action: "cannot remove the old manifest",
                            source: e,
                        });
                    }
                    Err(_) => {}
                }
                remove_temporaries(&seq);
            }
            let bar = progress.sequence_bar(&todo[todo.len() - 1], preset.frames);
            let manifests = render_stream(request, &renderer, &todo, 0..preset.frames, None, writer, |cost| {
                progress.advance(cost);
                if let Some(b) = &bar {
                    b.inc(1);
                }
            })?;
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            for (id, manifest) in todo.iter().zip(manifests) {
                let manifest_path = out.join(id.to_string()).join("manifest.json");
                let bytes = manifest_bytes(&manifest);
                writer.write(&manifest_path, &bytes).map_err(io_err(&manifest_path, "cannot write"))?;
                // Its frames' hashes are those of the bytes this process wrote.
                folder.verified.insert((*id, sha256_hex(&bytes)));
                folder.publish(writer)?;
                report.nonfinite_samples += manifest.nonfinite_samples();
                report.rendered.push(*id);
                done += 1;
                progress.finished(done, id, "rendered", group_started.elapsed().as_secs_f64());
            }
            drop(locks);
        }
        // Another process may have completed sequences since the last publication.
        folder.publish(writer)
    })();
    progress.finish();
    result?;
    report.wall_seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

/// The sequences rendered together: each on its own, or (nested sampling) the sample levels
/// of one material, speed, shutter and view, in the order they were asked for.
pub(crate) fn streams(ids: &[StimulusId], sampling: Sampling) -> Vec<Vec<StimulusId>> {
    let mut groups: Vec<Vec<StimulusId>> = Vec::new();
    for id in ids {
        let same_stream = |g: &Vec<StimulusId>| StimulusId { samples: id.samples, ..g[0] } == *id;
        match groups.iter_mut().find(|g| sampling == Sampling::Nested && same_stream(g)) {
            Some(g) => g.push(*id),
            None => groups.push(vec![*id]),
        }
    }
    groups
}

/// Frames submitted to the GPU ahead of the one being read back.
const FRAMES_IN_FLIGHT: usize = 2;
/// Encoded frames waiting to be written at most, before the renderer waits for them.
const ENCODES_QUEUED: usize = 16;

/// A frame of one member of a stream, encoded and written.
type Written = Result<(usize, FrameRecord), SetError>;

/// Encodes and writes one frame image of sequence `folder`; the record of it.
fn write_frame(
    writer: &dyn FileWriter,
    folder: &Path,
    frame: u32,
    image: &LinearImage,
    exposure: &study::scene::Exposure,
    exr: bool,
) -> Result<FrameRecord, SetError> {
    let png_name = frame_name(frame, "png");
    let png_path = folder.join(&png_name);
    let png = encode_png_srgb(image, exposure);
    writer.write(&png_path, &png).map_err(io_err(&png_path, "cannot write"))?;
    let (exr_name, exr_sha256) = if exr {
        let name = frame_name(frame, "exr");
        let path = folder.join(&name);
        let bytes = encode_exr(image).map_err(|source| SetError::Encode { path: path.clone(), source })?;
        writer.write(&path, &bytes).map_err(io_err(&path, "cannot write"))?;
        (Some(name), Some(sha256_hex(&bytes)))
    } else {
        (None, None)
    };
    Ok(FrameRecord {
        index: frame,
        png: png_name,
        png_sha256: sha256_hex(&png),
        exr: exr_name,
        exr_sha256,
        wall_seconds: 0.0,
        cpu_seconds: 0.0,
        nonfinite_samples: 0,
        seeds: Vec::new(),
        gpu_seconds: None,
    })
}

/// Renders frames `frames` of the sequences `members` (one, or the sample levels of one
/// nested stream) frame by frame and writes them; returns their manifests (listing those
/// frames), in order. With `eye`, only that camera of a stereo pair is rendered (with the
/// seed it has in the pair), into the sequence's [`eye_folder`], whose files the manifest
/// names by their paths from the sequence folder. On a GPU the next
/// frames are submitted before a frame is read back, and frames are encoded and written on
/// the thread pool, so the GPU does not wait for the CPU.
pub(crate) fn render_stream(
    request: &SetRequest<'_>,
    renderer: &Renderer<'_>,
    members: &[StimulusId],
    frames: std::ops::Range<u32>,
    eye: Option<Eye>,
    writer: &dyn FileWriter,
    mut on_frame: impl FnMut(u64),
) -> Result<Vec<SequenceManifest>, SetError> {
    let (design, preset, exr) = (request.design, &request.preset, request.exr);
    let method = request.method_of(&members[0])?;
    let spp_of = |id: &StimulusId| preset.samples_per_pixel[usize::from(id.samples - 1)];
    let spps: Vec<u32> = members.iter().map(spp_of).collect();
    let stream_spp = spps.iter().copied().max().unwrap_or(0);
    // A nested stream is seeded as the design's highest sample level, whichever levels
    // are rendered, so a level's frames do not depend on the selection.
    let stream_id = match request.sampling {
        Sampling::Nested => {
            let top = (0..preset.samples_per_pixel.len()).max_by_key(|&i| preset.samples_per_pixel[i]).unwrap_or(0);
            StimulusId { samples: top as u8 + 1, ..members[0] }
        }
        Sampling::Independent => members[0],
    };
    let mut levels = spps.clone();
    levels.sort_unstable();
    levels.dedup();
    let subfolder = eye.map(|e| PathBuf::from(EYES_DIR).join(eye_name(e)));
    let folders: Vec<PathBuf> = members
        .iter()
        .map(|id| {
            let seq = request.out.join(id.to_string());
            subfolder.as_ref().map_or(seq.clone(), |sub| seq.join(sub))
        })
        .collect();
    for folder in &folders {
        std::fs::create_dir_all(folder).map_err(io_err(folder, "cannot create the folder"))?;
    }
    let in_sequence = |name: String| match &subfolder {
        Some(sub) => format!("{}/{name}", sub.display()),
        None => name,
    };
    // Progress counts the camera samples of the eyes rendered.
    let share = if eye.is_some() { Eye::of_view(members[0].view).len() as u64 } else { 1 };
    let cost: u64 = members.iter().map(|id| frame_cost(preset, id)).sum::<u64>() / share;
    let written: std::sync::Mutex<Vec<Written>> = std::sync::Mutex::new(Vec::new());
    let queued = std::sync::atomic::AtomicUsize::new(0);
    let mut size = (0, 0);
    let mut seeds_of_frame: Vec<Vec<u64>> = Vec::new();
    let asynchronous = renderer.is_asynchronous();
    rayon::in_place_scope(|scope| -> Result<(), SetError> {
        let mut in_flight = std::collections::VecDeque::new();
        let mut previous_done = Instant::now();
        let mut complete =
            |(frame, scene, submitted, started, cpu0): (u32, FrameScene, Submitted<'_>, Instant, Option<f64>),
             previous_done: &mut Instant|
             -> Result<(), SetError> {
                let rendered = submitted.finish()?;
                let now = Instant::now();
                // This frame's share of the wall clock: since it was submitted or since the
                // frame before it finished, whichever was later.
                let wall = now.duration_since(started.max(*previous_done)).as_secs_f64();
                *previous_done = now;
                let cpu = match (cpu0, process_cpu_seconds()) {
                    (Some(a), Some(b)) => (b - a).max(0.0),
                    _ => 0.0,
                };
                for (m, spp) in spps.iter().enumerate() {
                    let level = &rendered[levels.iter().position(|l| l == spp).unwrap_or(0)];
                    size = (level.image.width, level.image.height);
                    // Cost as if rendered alone: the stream's cost grows linearly with samples.
                    let share = if stream_spp > 0 { f64::from(*spp) / f64::from(stream_spp) } else { 1.0 };
                    let extra = (wall * share, cpu * share, level.nonfinite_samples, level.gpu_seconds);
                    let image = level.image.clone();
                    let (folder, exposure, written) = (&folders[m], scene.exposure, &written);
                    let in_sequence = &in_sequence;
                    let task = move || {
                        let record = write_frame(writer, folder, frame, &image, &exposure, exr).map(|r| FrameRecord {
                            png: in_sequence(r.png),
                            exr: r.exr.map(in_sequence),
                            wall_seconds: extra.0,
                            cpu_seconds: extra.1,
                            nonfinite_samples: extra.2,
                            gpu_seconds: extra.3,
                            ..r
                        });
                        written.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(record.map(|r| (m, r)));
                    };
                    if asynchronous {
                        queued.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                        let queued = &queued;
                        scope.spawn(move |_| {
                            task();
                            queued.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
                        });
                    } else {
                        task();
                    }
                }
                while queued.load(std::sync::atomic::Ordering::SeqCst) > ENCODES_QUEUED {
                    rayon::yield_now();
                }
                // A failed write (a full disk) stops the sequence at once.
                let mut results = written.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                if let Some(i) = results.iter().position(Result::is_err) {
                    return results.swap_remove(i).map(|_| ());
                }
                drop(results);
                on_frame(cost);
                Ok(())
            };
        for frame in frames.clone() {
            let mut scene = design.frame_scene_with(preset, &stream_id, frame)?;
            scene.samples_per_pixel = stream_spp;
            if let Some(eye) = eye {
                scene.views.retain(|v| v.eye == eye);
            }
            seeds_of_frame.push(scene.views.iter().map(|v| v.seed).collect());
            let (started, cpu0) = (Instant::now(), process_cpu_seconds());
            let submitted = renderer.submit(&method, &scene, &levels)?;
            in_flight.push_back((frame, scene, submitted, started, cpu0));
            while in_flight.len() > if asynchronous { FRAMES_IN_FLIGHT } else { 0 } {
                if let Some(next) = in_flight.pop_front() {
                    complete(next, &mut previous_done)?;
                }
            }
        }
        while let Some(next) = in_flight.pop_front() {
            complete(next, &mut previous_done)?;
        }
        Ok(())
    })?;
    let first_frame = frames.start;
    let mut frames: Vec<Vec<FrameRecord>> = members.iter().map(|_| Vec::new()).collect();
    for w in written.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner) {
        let (m, record) = w?;
        frames[m].push(record);
    }
    members
        .iter()
        .zip(frames)
        .map(|(id, mut records)| {
            records.sort_by_key(|r| r.index);
            for r in &mut records {
                r.seeds = seeds_of_frame[(r.index - first_frame) as usize].clone();
            }
            Ok(SequenceManifest {
                format: SEQUENCE_FORMAT.to_owned(),
                id: *id,
                view: id.view,
                factors: design.factors(id, preset)?,
                method: method.kind,
                preset: preset.name.clone(),
                width: size.0,
                height: size.1,
                fps: design.spec.sequence.fps,
                samples_per_pixel: spp_of(id),
                master_seed: design.spec.master_seed,
                device: renderer.device_name(),
                gpu: renderer.gpu_record(),
                sampling: request.sampling,
                software_version: SOFTWARE_VERSION.to_owned(),
                design_sha256: design.sha256.clone(),
                frames: records,
            })
        })
        .collect()
}

pub(crate) fn manifest_bytes(manifest: &SequenceManifest) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(manifest).unwrap_or_default();
    bytes.push(b'\n');
    bytes
}

/// Removes temporary files a killed write left behind (`.NAME.tmp-PID`).
pub(crate) fn remove_temporaries(folder: &Path) {
    remove_temporaries_of(folder, |_| true);
}

/// Removes the temporaries in `folder` whose target file name (`.NAME.tmp-PID` targets
/// NAME) satisfies `owned`. Shards rendering other frames of the same sequence write into
/// the same folder at the same time: each may only clear what its own frames left behind.
pub(crate) fn remove_temporaries_of(folder: &Path, owned: impl Fn(&str) -> bool) {
    if let Ok(entries) = std::fs::read_dir(folder) {
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            let target = name.strip_prefix('.').and_then(|rest| rest.rsplit_once(".tmp-")).map(|(target, _)| target);
            if target.is_some_and(&owned) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
}

/// The frame index a file name such as `frame-0042.png` holds.
pub(crate) fn frame_index_of(name: &str) -> Option<u32> {
    let digits = name.strip_prefix("frame-")?.split('.').next()?;
    if digits.len() >= 4 && digits.bytes().all(|b| b.is_ascii_digit()) { digits.parse().ok() } else { None }
}

/// The folder, inside a sequence folder, of the eyes' frames of a stereo sequence rendered
/// one eye at a time (by shards): `SEQ/eyes/left/frame-0000.png`, joined into the frames.
pub const EYES_DIR: &str = "eyes";

/// An eye's name in file names: `centre`, `left`, `right`.
pub fn eye_name(eye: Eye) -> &'static str {
    match eye {
        Eye::Centre => "centre",
        Eye::Left => "left",
        Eye::Right => "right",
    }
}

/// The folder of `eye`'s frames in sequence folder `seq`.
pub fn eye_folder(seq: &Path, eye: Eye) -> PathBuf {
    seq.join(EYES_DIR).join(eye_name(eye))
}

/// The lock file, in a sequence's folder, of the process rendering it (`study::lock`).
pub const SEQUENCE_LOCK: &str = "render.lock";
/// The copy of the design file a set folder keeps, to name the keys a later design changes.
pub const DESIGN_COPY: &str = "design.toml";

/// A manifest found in a set folder: its folder, bytes and content.
struct Found {
    folder: PathBuf,
    bytes: Vec<u8>,
    manifest: SequenceManifest,
}

/// A set folder being rendered into. The sequence manifests in it are the truth;
/// `index.json` is rebuilt from those of this design, preset and sampling mode whose files
/// verify, so several processes (or cluster nodes, without working locks) rendering into one
/// folder all keep every completed sequence.
pub(crate) struct SetFolder<'a> {
    root: PathBuf,
    design: &'a Design,
    preset: &'a Preset,
    sampling: Sampling,
    /// Sequences (id, manifest hash) whose listed files verified, or that an index listed.
    pub(crate) verified: std::collections::HashSet<(StimulusId, String)>,
}

impl<'a> SetFolder<'a> {
    /// Checks that the folder holds nothing of another design, preset or sampling mode, and
    /// keeps a copy of the design file in it.
    pub(crate) fn open(
        root: &Path,
        design: &'a Design,
        preset: &'a Preset,
        sampling: Sampling,
    ) -> Result<Self, SetError> {
        let mut folder =
            SetFolder { root: root.to_owned(), design, preset, sampling, verified: std::collections::HashSet::new() };
        let index_path = root.join("index.json");
        if index_path.exists() {
            let old = match SetIndex::read(&index_path) {
                Ok(old) => old,
                Err(ManifestError::Io { source, .. }) => {
                    return Err(SetError::Io { path: index_path, action: "cannot read the set index", source });
                }
                Err(e) => {
                    return Err(SetError::Mismatch {
                        path: index_path,
                        message: format!("not a readable set index ({e}); remove it or render into another folder"),
                    });
                }
            };
            if old.design != design.name() || old.preset != preset.name {
                return Err(SetError::Mismatch {
                    path: index_path,
                    message: format!(
                        "this folder holds design `{}` rendered with preset `{}`, not design `{}` with preset `{}`; render into another folder",
                        old.design,
                        old.preset,
                        design.name(),
                        preset.name
                    ),
                });
            }
            if !old.sequences.is_empty() {
                if old.design_sha256 != design.sha256 {
                    return Err(folder.design_mismatch(&index_path, &old.design_sha256));
                }
                if old.sampling != sampling {
                    return Err(sampling_mismatch(&index_path, old.sampling, sampling));
                }
            }
            // What an index lists was verified by the process that listed it.
            folder.verified.extend(old.sequences.into_iter().map(|e| (e.id, e.manifest_sha256)));
        }
        folder.scan()?;
        let copy = root.join(DESIGN_COPY);
        if sha256_file(&copy).ok().as_deref() != Some(design.sha256.as_str()) {
            write_atomic(&copy, design.text().as_bytes()).map_err(io_err(&copy, "cannot write"))?;
        }
        Ok(folder)
    }

    /// The manifests in the folder, refusing one of another design, preset or sampling mode.
    fn scan(&self) -> Result<Vec<Found>, SetError> {
        let entries = std::fs::read_dir(&self.root).map_err(io_err(&self.root, "cannot list the set folder"))?;
        let mut found = Vec::new();
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some(id) = name.to_str().and_then(|n| n.parse::<StimulusId>().ok()) else { continue };
            let path = entry.path().join("manifest.json");
            let Ok(bytes) = std::fs::read(&path) else { continue };
            // A manifest that does not parse is not a complete sequence (never listed).
            let Ok(manifest) = serde_json::from_slice::<SequenceManifest>(&bytes) else { continue };
            if manifest.format != SEQUENCE_FORMAT || manifest.id != id {
                continue;
            }
            if manifest.design_sha256 != self.design.sha256 {
                return Err(self.design_mismatch(&path, &manifest.design_sha256));
            }
            if manifest.preset != self.preset.name {
                return Err(SetError::Mismatch {
                    path,
                    message: format!(
                        "rendered with preset `{}`, and this run renders preset `{}`; render into another folder",
                        manifest.preset, self.preset.name
                    ),
                });
            }
            if manifest.sampling != self.sampling {
                return Err(sampling_mismatch(&path, manifest.sampling, self.sampling));
            }
            found.push(Found { folder: entry.path(), bytes, manifest });
        }
        Ok(found)
    }

    /// The index of the complete sequences in the folder now.
    pub(crate) fn rebuild(&mut self) -> Result<SetIndex, SetError> {
        let mut sequences = Vec::new();
        for f in self.scan()? {
            let m = &f.manifest;
            let eyes = study::Eye::of_view(m.id.view).len() as u32;
            let spp = self.preset.samples_per_pixel.get(usize::from(m.id.samples).wrapping_sub(1)).copied();
            let fits = Some(m.samples_per_pixel) == spp
                && m.width == self.preset.width * eyes
                && m.height == self.preset.height
                && m.frames.len() == self.preset.frames as usize
                && m.frames.iter().enumerate().all(|(i, r)| r.index as usize == i);
            if !fits {
                continue;
            }
            let key = (m.id, sha256_hex(&f.bytes));
            if !self.verified.contains(&key) {
                if !frames_verify(&f.folder, m) {
                    continue;
                }
                self.verified.insert(key.clone());
            }
            sequences.push(IndexEntry { id: m.id, folder: m.id.to_string(), manifest_sha256: key.1 });
        }
        sequences.sort_by_key(|e| e.id);
        Ok(SetIndex {
            format: INDEX_FORMAT.to_owned(),
            design: self.design.name().to_owned(),
            design_sha256: self.design.sha256.clone(),
            preset: self.preset.name.clone(),
            sampling: self.sampling,
            sequences,
        })
    }

    /// Rewrites `index.json` from the folder until a fresh rebuild equals what is on disk: the
    /// last process to write the index checks it after its write, so a concurrent writer's
    /// older view never has the last word.
    pub(crate) fn publish(&mut self, writer: &dyn FileWriter) -> Result<(), SetError> {
        let path = self.root.join("index.json");
        for _ in 0..100 {
            let index = self.rebuild()?;
            let mut bytes = serde_json::to_vec_pretty(&index).unwrap_or_default();
            bytes.push(b'\n');
            if std::fs::read(&path).is_ok_and(|disk| disk == bytes) {
                return Ok(());
            }
            writer.write(&path, &bytes).map_err(io_err(&path, "cannot write the set index"))?;
        }
        Ok(())
    }

    /// The error for a folder (at `path`) of another version of the design, naming the keys
    /// that differ from the folder's design copy.
    fn design_mismatch(&self, path: &Path, theirs: &str) -> SetError {
        let copy = self.root.join(DESIGN_COPY);
        let differences = match std::fs::read_to_string(&copy) {
            Ok(text) if sha256_hex(text.as_bytes()) == theirs => {
                match (text.parse::<toml::Table>(), self.design.text().parse::<toml::Table>()) {
                    (Ok(a), Ok(b)) => {
                        let mut keys = Vec::new();
                        toml_differences("", &toml::Value::Table(a), &toml::Value::Table(b), &mut keys);
                        if keys.is_empty() {
                            "the files differ only in comments or layout".to_owned()
                        } else {
                            let more = keys.len().saturating_sub(8);
                            keys.truncate(8);
                            let mut s = format!("keys that differ: {}", keys.join(", "));
                            if more > 0 {
                                s.push_str(&format!(" and {more} more"));
                            }
                            s
                        }
                    }
                    _ => format!("{} does not parse", copy.display()),
                }
            }
            _ => format!("no copy of that design in {} to compare keys with", copy.display()),
        };
        SetError::Mismatch {
            path: path.to_owned(),
            message: format!(
                "this folder holds a set of another version of design `{}` (design_sha256 {theirs}), and {} has sha256 {}: {differences}; render into another folder, or restore the design the set was rendered from",
                self.design.name(),
                self.design.path.display(),
                self.design.sha256
            ),
        }
    }
}

fn sampling_mismatch(path: &Path, theirs: Sampling, ours: Sampling) -> SetError {
    let flag = |s: Sampling| if s == Sampling::Nested { "with --nested" } else { "without --nested" };
    SetError::Mismatch {
        path: path.to_owned(),
        message: format!(
            "this folder holds a set rendered {}, and this run is {}; one set has one sampling mode: render into another folder",
            flag(theirs),
            flag(ours)
        ),
    }
}

/// The dotted keys whose values differ between two TOML values (`key (A there, B here)`).
fn toml_differences(prefix: &str, a: &toml::Value, b: &toml::Value, out: &mut Vec<String>) {
    let show = |v: Option<&toml::Value>| v.map_or_else(|| "absent".to_owned(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(p), Some(q)) => toml_differences(&key, p, q, out),
                    (p, q) => out.push(format!("`{key}` ({} there, {} here)", show(p), show(q))),
                }
            }
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                toml_differences(&format!("{prefix}[{i}]"), p, q, out);
            }
        }
        _ if a != b => out.push(format!("`{prefix}` ({} there, {} here)", show(Some(a)), show(Some(b)))),
        _ => {}
    }
}

/// Whether every file a manifest lists hashes as recorded.
fn frames_verify(folder: &Path, m: &SequenceManifest) -> bool {
    m.frames.iter().all(|f| {
        sha256_file(&folder.join(&f.png)).is_ok_and(|h| h == f.png_sha256)
            && match (&f.exr, &f.exr_sha256) {
                (Some(name), Some(hash)) => sha256_file(&folder.join(name)).is_ok_and(|h| h == *hash),
                (None, None) => true,
                _ => false,
            }
    })
}

/// Whether `folder` holds a complete rendering of `id` as this request would produce it;
/// returns the manifest's hash when it does.
pub fn verify_sequence(
    folder: &Path,
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    method: Method,
    exr: bool,
    sampling: Sampling,
) -> Option<String> {
    let manifest_path = folder.join("manifest.json");
    let bytes = std::fs::read(&manifest_path).ok()?;
    let m = SequenceManifest::read(&manifest_path).ok()?;
    let expected = Expected { design, preset, id, method, exr, sampling, frames: 0..preset.frames, eye: None };
    expected.why_not(folder, &m).is_none().then(|| sha256_hex(&bytes))
}

/// What a manifest (of a whole sequence, or of a shard's unit of frames) must say and hold.
pub(crate) struct Expected<'a> {
    pub(crate) design: &'a Design,
    pub(crate) preset: &'a Preset,
    pub(crate) id: &'a StimulusId,
    pub(crate) method: Method,
    pub(crate) exr: bool,
    pub(crate) sampling: Sampling,
    pub(crate) frames: std::ops::Range<u32>,
    /// The one eye of a stereo pair the manifest holds (a shard's unit); `None`: every eye.
    pub(crate) eye: Option<Eye>,
}

impl Expected<'_> {
    /// Why `m`, in `folder`, is not what is expected (`None`: it is, and its files verify).
    pub(crate) fn why_not(&self, folder: &Path, m: &SequenceManifest) -> Option<String> {
        let (design, preset, id) = (self.design, self.preset, self.id);
        let spp = preset.samples_per_pixel.get(usize::from(id.samples).wrapping_sub(1)).copied();
        let eyes = if self.eye.is_some() { 1 } else { study::Eye::of_view(id.view).len() as u32 };
        let checks: [(bool, String); 9] = [
            (m.id == *id, format!("id {} (expected {id})", m.id)),
            (m.method == self.method, format!("method `{}` (expected `{}`)", m.method.name(), self.method.name())),
            (m.sampling == self.sampling, format!("sampling {:?} (expected {:?})", m.sampling, self.sampling)),
            (m.preset == preset.name, format!("preset `{}` (expected `{}`)", m.preset, preset.name)),
            (
                m.design_sha256 == design.sha256,
                format!("design_sha256 {} (expected {})", m.design_sha256, design.sha256),
            ),
            (Some(m.samples_per_pixel) == spp, format!("samples_per_pixel {}", m.samples_per_pixel)),
            (m.width == preset.width * eyes, format!("width {} (expected {})", m.width, preset.width * eyes)),
            (m.height == preset.height, format!("height {} (expected {})", m.height, preset.height)),
            (
                m.frames.len() == self.frames.len()
                    && m.frames.iter().zip(self.frames.clone()).all(|(f, i)| f.index == i),
                format!(
                    "frames {:?} (expected {}..={})",
                    m.frames.iter().map(|f| f.index).collect::<Vec<_>>(),
                    self.frames.start,
                    self.frames.end.saturating_sub(1)
                ),
            ),
        ];
        if let Some((_, what)) = checks.iter().find(|(ok, _)| !ok) {
            return Some(format!("records {what}"));
        }
        for f in &m.frames {
            if sha256_file(&folder.join(&f.png)).ok().as_deref() != Some(f.png_sha256.as_str()) {
                return Some(format!("{} is missing or does not hash as recorded", f.png));
            }
            match (&f.exr, &f.exr_sha256) {
                (Some(name), Some(hash)) if sha256_file(&folder.join(name)).ok().as_ref() != Some(hash) => {
                    return Some(format!("{name} is missing or does not hash as recorded"));
                }
                (Some(_), Some(_)) => {}
                _ if self.exr => return Some(format!("frame {} has no EXR file (expected with --exr)", f.index)),
                _ => {}
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;

    fn design() -> Design {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
        Design::load(&path).unwrap()
    }

    #[test]
    fn temporaries_are_cleared_only_for_the_frames_a_process_owns() {
        // Two shards render frames 0-2 and 3-5 of one sequence into one folder at once:
        // clearing its own leftovers, one must not delete the other's write in progress.
        let dir = tempfile::tempdir().unwrap();
        let names = [".frame-0002.png.tmp-11", ".frame-0003.png.tmp-12", ".manifest.json.tmp-12", "frame-0001.png"];
        for name in names {
            std::fs::write(dir.path().join(name), b"x").unwrap();
        }
        remove_temporaries_of(dir.path(), |target| frame_index_of(target).is_some_and(|f| (3..6).contains(&f)));
        let left = |name: &str| dir.path().join(name).exists();
        assert!(left(".frame-0002.png.tmp-11") && left(".manifest.json.tmp-12") && left("frame-0001.png"));
        assert!(!left(".frame-0003.png.tmp-12"));
        assert_eq!(frame_index_of("frame-0042.exr"), Some(42));
        assert_eq!(frame_index_of("frame-12345.png"), Some(12345));
        for not_a_frame in ["frame-42.png", "frame-00a1.png", "manifest.json", "frames-0000-0002.json"] {
            assert_eq!(frame_index_of(not_a_frame), None, "{not_a_frame}");
        }
        remove_temporaries(dir.path());
        assert!(!left(".frame-0002.png.tmp-11") && !left(".manifest.json.tmp-12") && left("frame-0001.png"));
    }

    /// A disk that fills up after `room` successful writes.
    struct FillingDisk {
        room: usize,
        writes: AtomicUsize,
    }

    impl FileWriter for FillingDisk {
        fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()> {
            if self.writes.fetch_add(1, Ordering::SeqCst) >= self.room {
                return Err(io::Error::new(io::ErrorKind::StorageFull, "No space left on device (injected)"));
            }
            write_atomic(path, bytes)
        }
    }

    fn request<'a>(design: &'a Design, out: &Path, only: &[&str]) -> SetRequest<'a> {
        let mut preset = design.preset("quick").unwrap();
        preset.frames = 2;
        preset.width = 16;
        preset.height = 9;
        SetRequest {
            design,
            preset,
            ids: only.iter().map(|s| s.parse().unwrap()).collect(),
            method: Method::Tracer,
            out: out.to_owned(),
            resume: false,
            exr: true,
            progress: ProgressMode::Quiet,
            device: DeviceChoice::Cpu,
            sampling: Sampling::Independent,
        }
    }

    #[test]
    fn a_full_disk_is_reported_with_the_file_and_keeps_finished_sequences() {
        full_disk(DeviceChoice::Cpu);
    }

    #[test]
    fn a_full_disk_on_the_gpu_path_stops_the_set_the_same_way() {
        // Frames are written on the thread pool while the GPU renders the next ones.
        if let Err(e) = gpu::acquire(gpu::AdapterChoice::HardwareThenSoftware, &gpu::DeviceRequest::default()) {
            gpu::skip_or_fail("set::tests::a_full_disk_on_the_gpu_path_stops_the_set_the_same_way", &e);
            return;
        }
        full_disk(DeviceChoice::Gpu);
    }

    fn full_disk(device: DeviceChoice) {
        let d = design();
        let dir = tempfile::tempdir().unwrap();
        let ids = ["M1-S1-T1-A1", "M1-S1-T1-A2"];
        // index, 2 frames x (png + exr), manifest, index: 7 writes finish the first sequence.
        let disk = FillingDisk { room: 8, writes: AtomicUsize::new(0) };
        let e = render_set_with(&SetRequest { device, ..request(&d, dir.path(), &ids) }, &disk).unwrap_err();
        let SetError::Io { path, source, .. } = &e else { panic!("{e}") };
        assert_eq!(source.kind(), io::ErrorKind::StorageFull);
        assert!(path.starts_with(dir.path().join("M1-S1-T1-A2")), "{e}");
        // The CPU writes frames in order; the GPU path's pool may reach frame 1 first.
        assert!(e.to_string().contains("frame-000"), "{e}");
        assert!(device != DeviceChoice::Cpu || e.to_string().contains("frame-0000"), "{e}");
        let index = SetIndex::read(&dir.path().join("index.json")).unwrap();
        assert_eq!(index.sequences.len(), 1);
        let req = request(&d, dir.path(), &ids);
        assert!(
            verify_sequence(
                &dir.path().join("M1-S1-T1-A1"),
                &d,
                &req.preset,
                &index.sequences[0].id,
                Method::Tracer,
                true,
                Sampling::Independent
            )
            .is_some()
        );
        assert!(
            verify_sequence(
                &dir.path().join("M1-S1-T1-A2"),
                &d,
                &req.preset,
                &"M1-S1-T1-A2".parse().unwrap(),
                Method::Tracer,
                true,
                Sampling::Independent
            )
            .is_none()
        );
    }

    #[test]
    fn resume_skips_verified_sequences_and_rerenders_damaged_ones() {
        let d = design();
        let dir = tempfile::tempdir().unwrap();
        let ids = ["M2-S3-T5-A1", "M2-S3-T5-A1-stereo"];
        let first = render_set(&request(&d, dir.path(), &ids)).unwrap();
        assert_eq!(first.rendered.len(), 2);
        let manifest = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1-stereo/manifest.json")).unwrap();
        assert_eq!((manifest.width, manifest.height), (32, 9));
        assert!(manifest.frames.iter().all(|f| f.exr.is_some()));
        std::fs::write(dir.path().join("M2-S3-T5-A1/frame-0001.exr"), b"damaged").unwrap();
        let mut again = request(&d, dir.path(), &ids);
        again.resume = true;
        let second = render_set(&again).unwrap();
        assert_eq!(second.skipped, vec!["M2-S3-T5-A1-stereo".parse().unwrap()]);
        assert_eq!(second.rendered, vec!["M2-S3-T5-A1".parse().unwrap()]);
        let redone = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1/manifest.json")).unwrap();
        let before = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1-stereo/manifest.json")).unwrap();
        assert_eq!(before, manifest);
        assert_eq!(
            redone.frames[1].exr_sha256,
            Some(sha256_file(&dir.path().join("M2-S3-T5-A1/frame-0001.exr")).unwrap())
        );
        // Another preset may not be mixed into the folder.
        let mut other = request(&d, dir.path(), &ids);
        other.preset.name = "full".into();
        let e = render_set(&other).unwrap_err();
        assert!(e.is_bad_input() && e.to_string().contains("preset `quick`"), "{e}");
    }
}
