//! Joining a sequence's unit records into one manifest, and a stereo sequence's eye frames
//! into side-by-side frames.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use study::fsio::sha256_hex;
use study::manifest::{FrameRecord, SequenceManifest};
use study::{Eye, StimulusId};

use super::UNITS_DIR;
use super::merge::{distinct_devices, write_if_changed};
use super::run::UnitRecord;
use crate::set::{FileWriter, SetError, eye_name, frame_name, io_err};

/// The manifest of a whole sequence from its units' records (in frame order): their
/// frames, and the devices that rendered them. Records of one sequence rendered on
/// different GPU adapters or drivers are refused.
pub fn assemble(records: &[UnitRecord]) -> Result<SequenceManifest, String> {
    let mut sorted: Vec<&UnitRecord> = records.iter().collect();
    sorted.sort_by_key(|r| r.first);
    let first = sorted.first().ok_or("no units")?;
    let mut manifest = first.sequence.clone();
    let mut frames = Vec::new();
    manifest.frames.clear();
    for r in &sorted {
        let mut header = r.sequence.clone();
        header.frames.clear();
        header.device.clone_from(&manifest.device);
        if header.gpu != manifest.gpu {
            return Err(format!(
                "frames {}..{} of {} were rendered on {}, and frames {}..{} on {}: one sequence is rendered on one GPU adapter and driver (or all on CPUs); render those units again",
                first.first, first.end, manifest.id, first.sequence.device, r.first, r.end, r.sequence.device
            ));
        }
        if header != manifest {
            let (a, b) = (serde_json::to_value(&manifest), serde_json::to_value(&header));
            let keys: Vec<String> = match (a, b) {
                (Ok(serde_json::Value::Object(a)), Ok(serde_json::Value::Object(b))) => {
                    a.iter().filter(|(k, v)| b.get(*k) != Some(*v)).map(|(k, _)| format!("`{k}`")).collect()
                }
                _ => Vec::new(),
            };
            return Err(format!(
                "the unit records of {} (frames {}..{} and {}..{}) disagree on {}",
                manifest.id,
                first.first,
                first.end,
                r.first,
                r.end,
                keys.join(", ")
            ));
        }
        frames.extend(r.sequence.frames.iter().cloned());
    }
    manifest.frames = frames;
    // A joined eye unit's device may already list two.
    manifest.device = distinct_devices(sorted.iter().flat_map(|r| r.sequence.device.split("; ")));
    Ok(manifest)
}

/// The records of sequence `id`'s units as whole frames: a monoscopic unit's record as it
/// is, and the eye units of each frame range of a stereo sequence joined. `parts` pairs each
/// record with the sequence folder holding its files; joined frames are written into
/// `seq_out` (where they differ from what is there). The eyes' 8-bit frames are joined and
/// encoded as the frame rendered whole is (and their float EXRs composed exactly), so the
/// frames are the bytes of an unsharded render. Returns the records and the files written.
pub(super) fn join_eyes(
    id: &StimulusId,
    parts: &[(PathBuf, UnitRecord)],
    seq_out: &Path,
    writer: &dyn FileWriter,
) -> Result<(Vec<UnitRecord>, usize), SetError> {
    let mut whole = Vec::new();
    let mut ranges: BTreeMap<(u32, u32), Vec<&(PathBuf, UnitRecord)>> = BTreeMap::new();
    for part in parts {
        match part.1.eye {
            None => whole.push(part.1.clone()),
            Some(_) => ranges.entry((part.1.first, part.1.end)).or_default().push(part),
        }
    }
    let eyes = Eye::of_view(id.view);
    let mut written = 0;
    for ((first, end), mut range) in ranges {
        let mismatch = |message: String| SetError::Mismatch { path: seq_out.join(UNITS_DIR), message };
        range.sort_by_key(|p| eyes.iter().position(|e| Some(*e) == p.1.eye));
        let found: Vec<Option<Eye>> = range.iter().map(|p| p.1.eye).collect();
        if found != eyes.iter().copied().map(Some).collect::<Vec<_>>() {
            let names: Vec<&str> = found.iter().flatten().map(|&e| eye_name(e)).collect();
            return Err(mismatch(format!(
                "frames {first}..{end} of {id} have the eye units [{}], expected one of each of its eyes",
                names.join(", ")
            )));
        }
        let (lead, rest) = (&range[0].1, &range[1..]);
        if let Some(other) = rest.iter().find(|p| p.1.sequence.gpu != lead.sequence.gpu) {
            return Err(mismatch(format!(
                "frames {first}..{end} of {id}: the eyes were rendered on {} and on {}; one sequence is rendered on one GPU adapter and driver (or all on CPUs); render those units again",
                lead.sequence.device, other.1.sequence.device
            )));
        }
        let mut sequence = lead.sequence.clone();
        sequence.width = range.iter().map(|p| p.1.sequence.width).sum();
        sequence.device = distinct_devices(range.iter().map(|p| p.1.sequence.device.as_str()));
        sequence.frames.clear();
        for k in 0..lead.sequence.frames.len() {
            let frames: Vec<&FrameRecord> = range.iter().filter_map(|p| p.1.sequence.frames.get(k)).collect();
            let index = frames[0].index;
            if frames.len() != range.len() || frames.iter().any(|f| f.index != index) {
                return Err(mismatch(format!("frames {first}..{end} of {id}: its eye units list different frames")));
            }
            let mut halves = Vec::new();
            for (p, f) in range.iter().zip(&frames) {
                let path = p.0.join(&f.png);
                let bytes = read_as_recorded(&path, &f.png_sha256)?;
                halves.push(render::io::decode_png_rgb8(&bytes).map_err(|source| SetError::Encode { path, source })?);
            }
            let png_name = frame_name(index, "png");
            let png_path = seq_out.join(&png_name);
            let (w, h, rows) = render::io::join_rgb8_side_by_side(&halves)
                .map_err(|source| SetError::Encode { path: png_path.clone(), source })?;
            let png = render::io::encode_png_rgb8(w, h, &rows);
            written += write_if_changed(writer, &png_path, &png)?;
            let mut record = FrameRecord {
                index,
                png: png_name,
                png_sha256: sha256_hex(&png),
                exr: None,
                exr_sha256: None,
                wall_seconds: frames.iter().map(|f| f.wall_seconds).sum(),
                cpu_seconds: frames.iter().map(|f| f.cpu_seconds).sum(),
                nonfinite_samples: frames.iter().map(|f| f.nonfinite_samples).sum(),
                seeds: frames.iter().flat_map(|f| f.seeds.iter().copied()).collect(),
                gpu_seconds: frames.iter().filter_map(|f| f.gpu_seconds).reduce(|a, b| a + b),
            };
            if frames.iter().all(|f| f.exr.is_some()) {
                let mut images = Vec::new();
                for (p, f) in range.iter().zip(&frames) {
                    let (Some(name), Some(hash)) = (&f.exr, &f.exr_sha256) else { continue };
                    let path = p.0.join(name);
                    let bytes = read_as_recorded(&path, hash)?;
                    images.push(render::io::decode_exr(&bytes).map_err(|source| SetError::Encode { path, source })?);
                }
                let exr_name = frame_name(index, "exr");
                let exr_path = seq_out.join(&exr_name);
                let exr = render::io::encode_exr(&render::io::compose_side_by_side(&images))
                    .map_err(|source| SetError::Encode { path: exr_path.clone(), source })?;
                written += write_if_changed(writer, &exr_path, &exr)?;
                (record.exr, record.exr_sha256) = (Some(exr_name), Some(sha256_hex(&exr)));
            }
            sequence.frames.push(record);
        }
        whole.push(UnitRecord { eye: None, sequence, ..lead.clone() });
    }
    whole.sort_by_key(|r| r.first);
    Ok((whole, written))
}

/// The bytes of a file a verified record lists, checked against its hash again (it may have
/// changed since it was verified).
pub(super) fn read_as_recorded(path: &Path, hash: &str) -> Result<Vec<u8>, SetError> {
    let bytes = std::fs::read(path).map_err(io_err(path, "cannot read"))?;
    if sha256_hex(&bytes) != hash {
        return Err(SetError::Mismatch {
            path: path.to_owned(),
            message: "changed while being merged: it no longer hashes as recorded".into(),
        });
    }
    Ok(bytes)
}
