//! Rendering a set's sequences: the streams of sequences rendered together, frames in
//! flight on the device while earlier ones are encoded, and each sequence's manifest last.

use std::io;
use std::path::{Path, PathBuf};
use std::time::Instant;

use study::design::Preset;
use study::fsio::sha256_hex;
use study::manifest::{FrameRecord, SEQUENCE_FORMAT, SequenceManifest};
use study::{Eye, SOFTWARE_VERSION, StimulusId};

use study::manifest::Sampling;
use study::scene::FrameScene;

use super::progress::{Progress, process_cpu_seconds};
use super::store::{EYES_DIR, SEQUENCE_LOCK, SetFolder, eye_name, io_err, manifest_bytes, remove_temporaries};
use super::verify::verify_sequence;
use super::{AtomicWriter, FileWriter, SetError, SetReport, SetRequest, Written, frame_name};
use ::render::env::EnvironmentMap;
use ::render::io::{LinearImage, encode_exr, encode_png_srgb};
use ::render::renderer::{Renderer, Submitted};

/// Camera samples of one frame of `id`: the unit of the overall progress bar, since render
/// time grows linearly with it.
pub(crate) fn frame_cost(preset: &Preset, id: &StimulusId) -> u64 {
    let eyes = study::Eye::of_view(id.view).len() as u64;
    let spp = u64::from(preset.samples_of(id).unwrap_or(1));
    u64::from(preset.width) * u64::from(preset.height) * eyes * spp
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
    let device = super::medium::device_for(design, &request.ids, request.device)?;
    let out = &request.out;
    std::fs::create_dir_all(out).map_err(io_err(out, "cannot create the output folder"))?;
    let mut folder = SetFolder::open(out, design, preset, request.sampling)?;
    // Publishing the index first finds an unwritable folder before any rendering.
    folder.publish(writer)?;
    let env = EnvironmentMap::from_lighting(&design.lighting)?;
    let renderer = Renderer::open(device, &env)?;
    super::medium::prepare(design, preset, request.progress)?;

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
                        request.method_of(&id)?.kind(),
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
    let spp_of = |id: &StimulusId| preset.samples_of(id).unwrap_or(1);
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
                method: method.kind(),
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
