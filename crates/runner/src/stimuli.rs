//! The rendered stimulus set as the runner sees it: `index.json`, the manifests of the
//! sequences an experiment shows, and their frames decoded to display pixels.
//!
//! [`StimulusSet::open_for`] checks, before the first trial, that every stimulus the
//! experiment shows (trials, practice, briefing examples) is in the set's index, that every
//! manifest of the index hashes as the index records, that each shown manifest is the
//! stimulus the index says and lists frames, and that every frame it will show hashes as its
//! manifest records (hashed on all cores); errors name the sequence and frame. The set's
//! identity in a log header is its content hash ([`SetIndex::content_sha256`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use study::experiment::{DisplayMode, ExperimentDefinition};
use study::manifest::{SequenceManifest, SetIndex};
use study::{StimulusId, View};

use crate::RunnerError;
use crate::display::{Rgba8, transform};

/// A stimulus set opened for one experiment.
#[derive(Clone, Debug)]
pub struct StimulusSet {
    /// The set's folder.
    pub dir: PathBuf,
    /// The parsed index.
    pub index: SetIndex,
    /// The set's content hash over its verified manifests ([`SetIndex::content_sha256`],
    /// recorded in every log header as `stimulus_set_sha256`).
    pub sha256: String,
    /// SHA-256 of index.json (what logs of earlier versions recorded).
    pub index_sha256: String,
    /// Manifests of the sequences the experiment shows.
    pub sequences: BTreeMap<StimulusId, Sequence>,
}

/// One sequence of the set.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// Its folder.
    pub folder: PathBuf,
    /// Its manifest.
    pub manifest: SequenceManifest,
}

impl Sequence {
    /// Paths of its frame PNGs in order.
    pub fn frame_paths(&self) -> Vec<PathBuf> {
        self.manifest.frames.iter().map(|f| self.folder.join(&f.png)).collect()
    }
}

impl StimulusSet {
    /// Opens `dir` and checks it holds everything `definition` shows.
    pub fn open_for(dir: &Path, definition: &ExperimentDefinition) -> Result<Self, RunnerError> {
        let index_path = dir.join("index.json");
        let bytes = std::fs::read(&index_path)
            .map_err(|source| study::manifest::ManifestError::Io { path: index_path.clone(), source })?;
        let index = SetIndex::read(&index_path)?;
        let index_sha256 = study::fsio::sha256_hex(&bytes);
        let listed: BTreeMap<StimulusId, &str> = index.sequences.iter().map(|e| (e.id, e.folder.as_str())).collect();
        let wanted = definition.all_stimuli();
        let missing: Vec<StimulusId> = wanted.iter().filter(|id| !listed.contains_key(id)).copied().collect();
        if !missing.is_empty() {
            return Err(RunnerError::MissingStimuli { set: index_path, experiment: definition.path.clone(), missing });
        }
        // Every manifest is the one the index lists: the content hash then names the set.
        for e in &index.sequences {
            let path = dir.join(&e.folder).join("manifest.json");
            let bytes = std::fs::read(&path).map_err(|source| RunnerError::Io { path: path.clone(), source })?;
            let actual = study::fsio::sha256_hex(&bytes);
            if actual != e.manifest_sha256 {
                return Err(RunnerError::Sequence {
                    path,
                    message: format!(
                        "sequence {}: the manifest's sha256 is {actual}, and index.json records {}: the set was altered or damaged; re-render it (`blurlab stimuli render --resume`)",
                        e.id, e.manifest_sha256
                    ),
                });
            }
        }
        let sha256 = index.content_sha256();
        let mut sequences = BTreeMap::new();
        for id in wanted {
            let folder = dir.join(listed[&id]);
            let path = folder.join("manifest.json");
            let manifest = SequenceManifest::read(&path)?;
            let bad = |message: String| RunnerError::Sequence { path: path.clone(), message };
            if manifest.id != id {
                return Err(bad(format!("field `id` is {}, but index.json lists this folder as {id}", manifest.id)));
            }
            if manifest.frames.is_empty() {
                return Err(bad("field `frames` is empty".into()));
            }
            if !(manifest.fps.is_finite() && manifest.fps > 0.0) {
                return Err(bad(format!("field `fps` is {}, expected a positive rate", manifest.fps)));
            }
            if manifest.view == View::Stereo && manifest.width % 2 != 0 {
                return Err(bad(format!(
                    "field `width` is {}: a side-by-side stereo frame needs an even width",
                    manifest.width
                )));
            }
            for frame in &manifest.frames {
                let png = folder.join(&frame.png);
                if !png.is_file() {
                    return Err(bad(format!("frame {} file {} is missing", frame.index, png.display())));
                }
            }
            sequences.insert(id, Sequence { folder, manifest });
        }
        verify_frames(&sequences)?;
        Ok(StimulusSet { dir: dir.to_owned(), index, sha256, index_sha256, sequences })
    }

    /// The sequence of a stimulus checked by [`StimulusSet::open_for`].
    pub fn sequence(&self, id: &StimulusId) -> &Sequence {
        &self.sequences[id]
    }
}

/// Checks every frame of `sequences` against its manifest's hash, on all cores; the error
/// names the first damaged frame in id and frame order.
fn verify_frames(sequences: &BTreeMap<StimulusId, Sequence>) -> Result<(), RunnerError> {
    let jobs: Vec<(&Sequence, &study::manifest::FrameRecord)> =
        sequences.values().flat_map(|s| s.manifest.frames.iter().map(move |f| (s, f))).collect();
    let threads = std::thread::available_parallelism().map_or(1, usize::from).clamp(1, jobs.len().max(1));
    let next = AtomicUsize::new(0);
    let errors: Vec<(usize, RunnerError)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut errors = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some((s, f)) = jobs.get(i) else { break };
                        let path = s.folder.join(&f.png);
                        let error = match study::fsio::sha256_file(&path) {
                            Ok(h) if h == f.png_sha256 => continue,
                            Ok(h) => format!(
                                "sequence {} frame {}: the file's sha256 is {h}, and its manifest records {}: the set was altered or damaged; re-render it (`blurlab stimuli render --resume`)",
                                s.manifest.id, f.index, f.png_sha256
                            ),
                            Err(e) => format!("sequence {} frame {}: cannot read: {e}", s.manifest.id, f.index),
                        };
                        errors.push((i, RunnerError::Sequence { path, message: error }));
                    }
                    errors
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap_or_default()).collect()
    });
    match errors.into_iter().min_by_key(|(i, _)| *i) {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// A sequence decoded and transformed for display, each frame in the form egui uploads (so
/// the window moves it to the GPU without another conversion on its thread).
#[derive(Clone, Debug)]
pub struct Decoded {
    /// The stimulus.
    pub id: StimulusId,
    /// Playback rate.
    pub fps: f64,
    /// Width of one eye's image in source pixels (what calibration scales).
    pub eye_width: u32,
    /// Display frames in order; with [`Decoded::gpu_transform`], the stereo frames as stored.
    pub frames: Vec<egui::ColorImage>,
    /// The display mode still to be applied on the GPU ([`crate::gpu::FrameUploader`]);
    /// `None` when the frames are the display images.
    pub gpu_transform: Option<DisplayMode>,
}

impl Decoded {
    /// Bytes held by the frames.
    pub fn bytes(&self) -> usize {
        self.frames.iter().map(|f| f.pixels.len() * 4).sum()
    }

    /// The size of the display image (`[width, height]`), after any transform left to the GPU.
    pub fn display_size(&self) -> [usize; 2] {
        let [w, h] = self.frames.first().map_or([1, 1], |f| f.size);
        match self.gpu_transform {
            None => [w, h],
            Some(mode) => {
                let (w, h) = crate::display::output_size(mode, View::Stereo, w as u32, h as u32);
                [w as usize, h as usize]
            }
        }
    }
}

/// The display image as egui holds it. Rendered frames are opaque, so their bytes are
/// already premultiplied; others are premultiplied by egui.
pub fn to_color_image(frame: &Rgba8) -> egui::ColorImage {
    let size = [frame.width as usize, frame.height as usize];
    if frame.pixels.chunks_exact(4).all(|p| p[3] == 255) {
        egui::ColorImage::from_rgba_premultiplied(size, &frame.pixels)
    } else {
        egui::ColorImage::from_rgba_unmultiplied(size, &frame.pixels)
    }
}

/// Reads a PNG frame, checking its size: the samples as stored (8-bit grey, grey-alpha, RGB
/// or RGBA) at the front of a buffer with room for RGBA, and the number of channels.
fn read_png(path: &Path, width: u32, height: u32) -> Result<(Vec<u8>, usize), RunnerError> {
    use image::ImageDecoder;
    let bad = |message: String| RunnerError::Sequence { path: path.to_owned(), message };
    let bytes = std::fs::read(path).map_err(|source| RunnerError::Io { path: path.to_owned(), source })?;
    let decoder = image::codecs::png::PngDecoder::new(std::io::Cursor::new(bytes))
        .map_err(|e| bad(format!("cannot decode PNG: {e}")))?;
    let (w, h) = decoder.dimensions();
    if (w, h) != (width, height) {
        return Err(bad(format!("frame is {w}x{h}, the manifest says {width}x{height}")));
    }
    let channels = match decoder.color_type() {
        image::ColorType::L8 => 1,
        image::ColorType::La8 => 2,
        image::ColorType::Rgb8 => 3,
        image::ColorType::Rgba8 => 4,
        other => return Err(bad(format!("frame is {other:?}, expected 8-bit sRGB (grey, RGB or RGBA)"))),
    };
    let n = width as usize * height as usize;
    let mut pixels = vec![0u8; n * 4];
    decoder.read_image(&mut pixels[..n * channels]).map_err(|e| bad(format!("cannot decode PNG: {e}")))?;
    Ok((pixels, channels))
}

/// Widens `n` pixels of `channels` samples at the front of `pixels` to RGBA in place, from
/// the back, so no source pixel is overwritten before it is read.
fn widen(pixels: &mut [u8], n: usize, channels: usize) {
    match channels {
        1 => {
            for i in (0..n).rev() {
                let v = pixels[i];
                pixels[4 * i..4 * i + 4].copy_from_slice(&[v, v, v, 255]);
            }
        }
        2 => {
            for i in (0..n).rev() {
                let (v, a) = (pixels[2 * i], pixels[2 * i + 1]);
                pixels[4 * i..4 * i + 4].copy_from_slice(&[v, v, v, a]);
            }
        }
        3 => {
            for i in (0..n).rev() {
                let (r, g, b) = (pixels[3 * i], pixels[3 * i + 1], pixels[3 * i + 2]);
                pixels[4 * i..4 * i + 4].copy_from_slice(&[r, g, b, 255]);
            }
        }
        _ => {}
    }
}

/// Decodes one PNG frame to RGBA8, checking its size against the manifest. The file is read
/// whole and decoded straight into one buffer (8-bit grey, grey-alpha, RGB or RGBA; RGB, the
/// format of rendered frames, is widened to RGBA in place without a second image).
pub fn decode_frame(path: &Path, width: u32, height: u32) -> Result<Rgba8, RunnerError> {
    let (mut pixels, channels) = read_png(path, width, height)?;
    widen(&mut pixels, width as usize * height as usize, channels);
    Ok(Rgba8 { width, height, pixels })
}

/// Decodes one frame of a sequence to the image shown in `mode`. An RGB frame shown as it is
/// (mono, or stereo side by side at full width) goes straight from the PNG samples to egui's
/// pixels; the other modes transform the RGBA frame first.
pub fn decode_display_frame(
    path: &Path,
    m: &SequenceManifest,
    mode: DisplayMode,
) -> Result<egui::ColorImage, RunnerError> {
    let (mut pixels, channels) = read_png(path, m.width, m.height)?;
    let n = m.width as usize * m.height as usize;
    let unchanged = m.view == View::Mono || mode == DisplayMode::SbsFull;
    if unchanged && channels == 3 {
        return Ok(egui::ColorImage::from_rgb([m.width as usize, m.height as usize], &pixels[..3 * n]));
    }
    widen(&mut pixels, n, channels);
    let frame = Rgba8 { width: m.width, height: m.height, pixels };
    Ok(to_color_image(&transform(mode, m.view, frame)))
}

/// Decodes a frame as stored, as RGBA8 samples in an egui image used only as a buffer (no
/// premultiplication): the input of a display transform done on the GPU.
pub fn decode_stored_frame(path: &Path, m: &SequenceManifest) -> Result<egui::ColorImage, RunnerError> {
    let (mut pixels, channels) = read_png(path, m.width, m.height)?;
    let n = m.width as usize * m.height as usize;
    let size = [m.width as usize, m.height as usize];
    if channels == 3 {
        return Ok(egui::ColorImage::from_rgb(size, &pixels[..3 * n]));
    }
    widen(&mut pixels, n, channels);
    Ok(egui::ColorImage::from_rgba_premultiplied(size, &pixels))
}

/// Decodes every frame of `sequence` and applies the display mode on the CPU, counting
/// decoded frames in `progress`. Up to `threads` threads take frames from a shared counter
/// (so a slow frame does not hold up a whole share); the first error stops the others.
pub fn decode_sequence(
    sequence: &Sequence,
    mode: DisplayMode,
    progress: &AtomicUsize,
    threads: usize,
) -> Result<Decoded, RunnerError> {
    decode_sequence_for(sequence, mode, false, progress, threads)
}

/// As [`decode_sequence`], or, `for_gpu`, leaving a display mode the GPU composes
/// ([`crate::display::composes_on_gpu`]) to it: the frames are then decoded as stored and
/// [`Decoded::gpu_transform`] names the mode.
pub fn decode_sequence_for(
    sequence: &Sequence,
    mode: DisplayMode,
    for_gpu: bool,
    progress: &AtomicUsize,
    threads: usize,
) -> Result<Decoded, RunnerError> {
    let m = &sequence.manifest;
    let gpu_transform = (for_gpu && crate::display::composes_on_gpu(mode, m.view)).then_some(mode);
    let paths = sequence.frame_paths();
    let threads = threads.clamp(1, paths.len().max(1));
    let next = AtomicUsize::new(0);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let results: Vec<Vec<(usize, Result<egui::ColorImage, RunnerError>)>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    while !failed.load(Ordering::Relaxed) {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(p) = paths.get(i) else { break };
                        let frame = match gpu_transform {
                            Some(_) => decode_stored_frame(p, m),
                            None => decode_display_frame(p, m, mode),
                        };
                        failed.fetch_or(frame.is_err(), Ordering::Relaxed);
                        progress.fetch_add(usize::from(frame.is_ok()), Ordering::Relaxed);
                        done.push((i, frame));
                    }
                    done
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("decoder thread panicked")).collect()
    });
    let mut slots: Vec<Option<egui::ColorImage>> = (0..paths.len()).map(|_| None).collect();
    let mut first_error: Option<(usize, RunnerError)> = None;
    for (i, frame) in results.into_iter().flatten() {
        match frame {
            Ok(f) => slots[i] = Some(f),
            Err(e) if first_error.as_ref().is_none_or(|(j, _)| i < *j) => first_error = Some((i, e)),
            Err(_) => {}
        }
    }
    if let Some((_, e)) = first_error {
        return Err(e);
    }
    let frames = slots.into_iter().map(|f| f.expect("every frame decoded when none failed")).collect();
    Ok(Decoded { id: m.id, fps: m.fps, eye_width: crate::display::eye_width(m.view, m.width), frames, gpu_transform })
}

/// Writes a small synthetic stimulus set (for tests, benchmarks and demos without the
/// renderer): for each id, `frames` PNG frames of `width x height` (stereo: `2*width`) whose
/// content is a bright bar moving across a grey field, shaded by the id's levels, with
/// manifests and index.json in the documented formats.
pub fn write_synthetic_set(
    dir: &Path,
    ids: &[StimulusId],
    width: u32,
    height: u32,
    frames: u32,
    fps: f64,
) -> Result<(), RunnerError> {
    use study::manifest::{
        Factors, FrameRecord, INDEX_FORMAT, IndexEntry, LevelInfo, SEQUENCE_FORMAT, SequenceManifest,
    };
    let io = |path: &Path| {
        let path = path.to_owned();
        move |source| RunnerError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut ids: Vec<StimulusId> = ids.to_vec();
    ids.sort();
    ids.dedup();
    let mut entries = Vec::new();
    for id in &ids {
        let folder_name = id.to_string();
        let folder = dir.join(&folder_name);
        std::fs::create_dir_all(&folder).map_err(io(&folder))?;
        let full_w = if id.view == View::Stereo { 2 * width } else { width };
        let mut records = Vec::new();
        for f in 0..frames {
            let mut img = image::RgbaImage::from_pixel(full_w, height, image::Rgba([60, 60, 60, 255]));
            let eyes = if id.view == View::Stereo { 2 } else { 1 };
            for eye in 0..eyes {
                let bar_x = (f * width / frames.max(1) + eye * 2) % width.max(1);
                let shade = (80 + 30 * u32::from(id.material) + 20 * u32::from(id.shutter)).min(255) as u8;
                for y in height / 4..(3 * height / 4).max(height / 4 + 1).min(height) {
                    for x in bar_x..(bar_x + (width / 8).max(1)).min(width) {
                        let noise = ((x * 7 + y * 13 + f * 31) % (6 - u32::from(id.samples.min(5)) + 1)) as u8 * 8;
                        img.put_pixel(eye * width + x, y, image::Rgba([shade, shade.saturating_sub(noise), 200, 255]));
                    }
                }
            }
            let name = format!("frame-{f:04}.png");
            let path = folder.join(&name);
            let mut bytes = Vec::new();
            image::DynamicImage::ImageRgba8(img)
                .to_rgb8()
                .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
                .map_err(|e| RunnerError::Sequence { path: path.clone(), message: e.to_string() })?;
            study::fsio::write_atomic(&path, &bytes).map_err(io(&path))?;
            records.push(FrameRecord {
                index: f,
                png: name,
                png_sha256: study::fsio::sha256_hex(&bytes),
                exr: None,
                exr_sha256: None,
                wall_seconds: 0.01 * f64::from(id.samples),
                cpu_seconds: 0.02 * f64::from(id.samples),
                nonfinite_samples: 0,
                seeds: vec![u64::from(f)],
                gpu_seconds: None,
            });
        }
        let level = |label: String, value: f64| LevelInfo { name: label.clone(), label, value };
        let manifest = SequenceManifest {
            format: SEQUENCE_FORMAT.into(),
            id: *id,
            view: id.view,
            factors: Factors {
                material: level(id.level_label(study::Factor::Material), f64::from(id.material)),
                speed: level(id.level_label(study::Factor::Speed), 5.0 * f64::from(id.speed)),
                shutter: level(id.level_label(study::Factor::Shutter), 0.25 * f64::from(id.shutter - 1)),
                samples: level(id.level_label(study::Factor::Samples), f64::from(id.samples)),
                method: None,
            },
            method: study::Method::Tracer,
            preset: "test".into(),
            width: full_w,
            height,
            fps,
            samples_per_pixel: u32::from(id.samples),
            master_seed: 0,
            device: "synthetic".into(),
            gpu: None,
            sampling: study::manifest::Sampling::Independent,
            software_version: study::SOFTWARE_VERSION.into(),
            design_sha256: String::new(),
            frames: records,
        };
        let text = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
        let path = folder.join("manifest.json");
        study::fsio::write_atomic(&path, text.as_bytes()).map_err(io(&path))?;
        entries.push(IndexEntry {
            id: *id,
            folder: folder_name,
            manifest_sha256: study::fsio::sha256_hex(text.as_bytes()),
        });
    }
    let index = SetIndex {
        format: INDEX_FORMAT.into(),
        design: "synthetic".into(),
        design_sha256: String::new(),
        preset: "test".into(),
        sampling: study::manifest::Sampling::Independent,
        sequences: entries,
    };
    let path = dir.join("index.json");
    let text = serde_json::to_string_pretty(&index).expect("index serialises");
    study::fsio::write_atomic(&path, text.as_bytes()).map_err(io(&path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_stimuli_and_frames_are_named_before_the_first_trial() {
        let dir = tempfile::tempdir().unwrap();
        let d = crate::schedule::tests::definition("2afc", 1);
        // All but two of the stimuli (the practice pair needs M2-S2-T1-A1 and T5-A5 too).
        let ids: Vec<StimulusId> =
            d.all_stimuli().into_iter().filter(|id| id.shutter != 3 && id.shutter != 4).collect();
        write_synthetic_set(dir.path(), &ids, 8, 4, 3, 30.0).unwrap();
        let e = StimulusSet::open_for(dir.path(), &d).unwrap_err().to_string();
        assert!(
            e.contains("index.json: the stimulus set lacks 2 stimuli that t.toml shows: M2-S2-T3-A5, M2-S2-T4-A5"),
            "{e}"
        );

        let all: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        write_synthetic_set(dir.path(), &all, 8, 4, 3, 30.0).unwrap();
        let set = StimulusSet::open_for(dir.path(), &d).unwrap();
        assert_eq!(set.sequences.len(), 6);
        let seq = set.sequence(&all[0]);
        let progress = AtomicUsize::new(0);
        let decoded = decode_sequence(seq, DisplayMode::Mono, &progress, 2).unwrap();
        assert_eq!((decoded.frames.len(), progress.load(Ordering::Relaxed)), (3, 3));
        assert_eq!((decoded.frames[0].size, decoded.eye_width), ([8, 4], 8));
        // The bar's pixels arrive as written: RGB widened to opaque RGBA.
        let frame = decode_frame(&seq.frame_paths()[0], 8, 4).unwrap();
        let bar = frame.get(0, 1);
        assert_eq!((bar[2], bar[3]), (200, 255));
        assert_eq!(decoded.frames[0].as_raw(), &frame.pixels[..]);
        // Every display mode of a stereo frame equals the transform of its RGBA decode.
        let id: StimulusId = "M2-S2-T3-A5-stereo".parse().unwrap();
        write_synthetic_set(&dir.path().join("stereo"), &[id], 8, 4, 1, 30.0).unwrap();
        let folder = dir.path().join("stereo").join(id.to_string());
        let manifest = SequenceManifest::read(&folder.join("manifest.json")).unwrap();
        let png = folder.join(&manifest.frames[0].png);
        for mode in DisplayMode::ALL {
            let rgba = decode_frame(&png, 16, 4).unwrap();
            let want = transform(mode, View::Stereo, rgba);
            let got = decode_display_frame(&png, &manifest, mode).unwrap();
            assert_eq!(
                (got.size, got.as_raw()),
                ([want.width as usize, want.height as usize], &want.pixels[..]),
                "{mode}"
            );
        }

        std::fs::remove_file(dir.path().join("M2-S2-T4-A5/frame-0002.png")).unwrap();
        let e = StimulusSet::open_for(dir.path(), &d).unwrap_err().to_string();
        assert!(e.contains("M2-S2-T4-A5/manifest.json: frame 2 file") && e.contains("is missing"), "{e}");
    }

    #[test]
    fn a_damaged_frame_or_an_altered_manifest_is_refused_naming_sequence_and_frame() {
        let dir = tempfile::tempdir().unwrap();
        let d = crate::schedule::tests::definition("2afc", 1);
        let all: Vec<StimulusId> = d.all_stimuli().into_iter().collect();
        write_synthetic_set(dir.path(), &all, 8, 4, 3, 30.0).unwrap();
        let set = StimulusSet::open_for(dir.path(), &d).unwrap();
        assert_eq!(set.sha256, set.index.content_sha256());
        assert_ne!(set.sha256, set.index_sha256);
        // One flipped byte in a frame that still decodes as a PNG of the right size is found.
        let frame = dir.path().join("M2-S2-T4-A5/frame-0001.png");
        let mut bytes = std::fs::read(&frame).unwrap();
        let other = dir.path().join("M2-S2-T3-A5/frame-0001.png");
        let replacement = std::fs::read(&other).unwrap();
        assert_ne!(bytes, replacement);
        std::fs::write(&frame, &replacement).unwrap();
        let e = StimulusSet::open_for(dir.path(), &d).unwrap_err().to_string();
        assert!(e.contains("sequence M2-S2-T4-A5 frame 1: the file's sha256 is"), "{e}");
        assert!(e.contains("frame-0001.png") && e.contains("altered or damaged"), "{e}");
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        std::fs::write(&frame, &bytes).unwrap();
        assert!(StimulusSet::open_for(dir.path(), &d).unwrap_err().to_string().contains("frame 1"));
        // A manifest edited after rendering no longer matches the index.
        write_synthetic_set(dir.path(), &all, 8, 4, 3, 30.0).unwrap();
        let manifest = dir.path().join("M2-S2-T1-A1/manifest.json");
        let text = std::fs::read_to_string(&manifest).unwrap().replace("\"fps\": 30.0", "\"fps\": 60.0");
        std::fs::write(&manifest, text).unwrap();
        let e = StimulusSet::open_for(dir.path(), &d).unwrap_err().to_string();
        assert!(e.contains("sequence M2-S2-T1-A1: the manifest's sha256"), "{e}");
    }

    #[test]
    fn stereo_frames_are_transformed_and_sizes_checked() {
        let dir = tempfile::tempdir().unwrap();
        let id: StimulusId = "M2-S2-T3-A5-stereo".parse().unwrap();
        write_synthetic_set(dir.path(), &[id], 8, 4, 2, 30.0).unwrap();
        let folder = dir.path().join(id.to_string());
        let manifest = SequenceManifest::read(&folder.join("manifest.json")).unwrap();
        let seq = Sequence { folder: folder.clone(), manifest };
        let progress = AtomicUsize::new(0);
        let d = decode_sequence(&seq, DisplayMode::Anaglyph, &progress, 1).unwrap();
        assert_eq!((d.frames[0].size, d.eye_width), ([8, 4], 8));
        assert_eq!((d.gpu_transform, d.display_size()), (None, [8, 4]));
        // For the GPU the frames of the modes it composes stay side by side, as stored
        // (row-interleaving too: its eye per line is chosen when drawn); mono (the left eye)
        // is cropped on the CPU as before.
        let stored = decode_frame(&seq.frame_paths()[1], 16, 4).unwrap();
        for mode in [DisplayMode::Anaglyph, DisplayMode::SbsHalf, DisplayMode::TopBottom, DisplayMode::RowInterleaved] {
            let g = decode_sequence_for(&seq, mode, true, &progress, 1).unwrap();
            assert_eq!((g.frames[0].size, g.eye_width), ([16, 4], 8), "{mode}");
            assert_eq!((g.gpu_transform, g.display_size()), (Some(mode), [8, 4]));
            assert_eq!(g.frames[1].as_raw(), &stored.pixels[..], "{mode}");
        }
        let mono = decode_sequence_for(&seq, DisplayMode::Mono, true, &progress, 1).unwrap();
        assert_eq!((mono.gpu_transform, mono.frames[0].size), (None, [8, 4]));
        let cpu = decode_sequence(&seq, DisplayMode::Mono, &progress, 1).unwrap();
        assert_eq!(mono.frames[0].as_raw(), cpu.frames[0].as_raw());
        let mut wrong = seq.clone();
        wrong.manifest.height = 5;
        let e = decode_sequence(&wrong, DisplayMode::SbsFull, &progress, 1).unwrap_err().to_string();
        assert!(e.contains("frame-0000.png: frame is 16x4, the manifest says 16x5"), "{e}");
    }
}
