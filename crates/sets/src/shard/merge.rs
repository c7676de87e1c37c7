//! Merging the shard folders into one verified set: complete sequences joined, frames
//! copied only where they differ, the index rebuilt.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use study::design::Design;
use study::fsio::sha256_hex;
use study::{SOFTWARE_VERSION, StimulusId};

use super::join::{assemble, join_eyes, read_as_recorded};
use super::plan::{Plan, Unit};
use super::run::{ShardReport, UnitRecord, read_record};
use super::{PLAN_FILE, PLAN_FORMAT, UNITS_DIR};
use crate::set::{
    AtomicWriter, FileWriter, Progress, ProgressMode, SetError, SetFolder, SetRequest, io_err, manifest_bytes,
};

/// The distinct devices, in order, joined by `; ` (as manifests name them).
pub(super) fn distinct_devices<'a>(devices: impl Iterator<Item = &'a str>) -> String {
    let mut distinct: Vec<&str> = Vec::new();
    for d in devices {
        if !distinct.contains(&d) {
            distinct.push(d);
        }
    }
    distinct.join("; ")
}

/// Writes `bytes` to `path` unless it already holds them; returns the files written (0 or 1).
pub(super) fn write_if_changed(writer: &dyn FileWriter, path: &Path, bytes: &[u8]) -> Result<usize, SetError> {
    if std::fs::read(path).ok().as_deref() == Some(bytes) {
        return Ok(0);
    }
    writer.write(path, bytes).map_err(io_err(path, "cannot write"))?;
    Ok(1)
}

/// Writes the manifest of every sequence of `unit` whose units are all in the folder and
/// verify, and publishes the index.
pub(super) fn complete_sequences(
    request: &SetRequest<'_>,
    plan: &Plan,
    unit: &Unit,
    folder: &mut SetFolder<'_>,
    writer: &dyn FileWriter,
    report: &mut ShardReport,
) -> Result<(), SetError> {
    for id in &unit.ids {
        let seq = request.out.join(id.to_string());
        let path = seq.join("manifest.json");
        // A verified manifest is the sequence's (a re-rendered unit removes it first): no
        // need to verify every record and join the eyes again for each of its units.
        if std::fs::read(&path).is_ok_and(|bytes| folder.verified.contains(&(*id, sha256_hex(&bytes)))) {
            continue;
        }
        let method = request.method_of(id)?.kind();
        let records: Result<Vec<UnitRecord>, String> = plan
            .units
            .iter()
            .filter(|u| u.ids.contains(id))
            .map(|u| read_record(&request.out, request.design, &request.preset, plan, u, id, method))
            .collect();
        let Ok(records) = records else { continue };
        let parts: Vec<(PathBuf, UnitRecord)> = records.into_iter().map(|r| (seq.clone(), r)).collect();
        let (records, _) = join_eyes(id, &parts, &seq, writer)?;
        let manifest =
            assemble(&records).map_err(|message| SetError::Mismatch { path: seq.join(UNITS_DIR), message })?;
        let bytes = manifest_bytes(&manifest);
        if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
            writer.write(&path, &bytes).map_err(io_err(&path, "cannot write"))?;
            report.completed.push(*id);
        }
        folder.verified.insert((*id, sha256_hex(&bytes)));
    }
    folder.publish(writer)
}

/// What a merge found and did.
#[derive(Clone, Debug, Default)]
pub struct MergeReport {
    /// The plan.
    pub shards: u32,
    /// Units verified.
    pub units: usize,
    /// Sequences in the merged set.
    pub sequences: usize,
    /// Frame files copied into the output folder.
    pub copied_files: usize,
    /// Wall seconds.
    pub wall_seconds: f64,
}

/// Merges the shard folders `dirs` into the set folder `out` (with no `dirs`: checks and
/// completes the shared folder `out` in place). Refuses shard folders of different plans,
/// and lists every unit missing, damaged, duplicated or not in the plan without writing.
pub fn merge(out: &Path, dirs: &[PathBuf], progress: ProgressMode) -> Result<MergeReport, SetError> {
    let started = Instant::now();
    let dirs: Vec<PathBuf> = if dirs.is_empty() { vec![out.to_owned()] } else { dirs.to_vec() };
    let canonical = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_owned());
    let in_place = dirs.len() == 1 && canonical(&dirs[0]) == canonical(out);
    if !in_place && dirs.iter().any(|d| canonical(d) == canonical(out)) {
        return Err(SetError::Mismatch {
            path: out.to_owned(),
            message: "the output folder is one of several shard folders; merge into a new folder, or give a shared folder alone to check it in place".to_owned(),
        });
    }
    let mut plans = Vec::new();
    for dir in &dirs {
        let path = dir.join(PLAN_FILE);
        let bytes = std::fs::read(&path).map_err(|source| SetError::Io {
            path: path.clone(),
            action: "cannot read the shard plan (is this a folder rendered with --shard?)",
            source,
        })?;
        let plan: Plan = serde_json::from_slice(&bytes)
            .map_err(|e| SetError::Mismatch { path: path.clone(), message: format!("not a shard plan ({e})") })?;
        if plan.format != PLAN_FORMAT {
            return Err(SetError::Mismatch {
                path,
                message: format!("format `{}`, expected `{PLAN_FORMAT}`", plan.format),
            });
        }
        plans.push(plan);
    }
    let plan = plans[0].clone();
    for (dir, other) in dirs.iter().zip(&plans).skip(1) {
        let differences = plan.differences(other);
        if !differences.is_empty() {
            return Err(SetError::Mismatch {
                path: dir.join(PLAN_FILE),
                message: format!(
                    "not a shard of the same set as {}: differs in {} ({}, this folder); shards of different design files, presets, selections or blurlab versions are not merged",
                    dirs[0].display(),
                    differences.join(", "),
                    dirs[0].display()
                ),
            });
        }
    }
    if plan.software_version != SOFTWARE_VERSION {
        return Err(SetError::Mismatch {
            path: dirs[0].join(PLAN_FILE),
            message: format!(
                "rendered by blurlab {}, and this is blurlab {SOFTWARE_VERSION}; merge with the version that rendered the shards",
                plan.software_version
            ),
        });
    }
    let design_path = dirs[0].join(crate::set::DESIGN_COPY);
    let design = Design::load(&design_path)?;
    if design.sha256 != plan.design_sha256 {
        return Err(SetError::Mismatch {
            path: design_path,
            message: format!(
                "has sha256 {}, and the plan's design `{}` has {}; the shard folder was changed by hand",
                design.sha256, plan.design, plan.design_sha256
            ),
        });
    }
    let preset = design.preset(&plan.preset)?;
    let request = SetRequest {
        design: &design,
        preset: preset.clone(),
        ids: plan.ids.clone(),
        out: out.to_owned(),
        resume: false,
        exr: plan.exr,
        progress,
        device: render::DeviceChoice::Cpu,
        sampling: plan.sampling,
    };
    if Plan::compute(&request, plan.shards)? != plan {
        return Err(SetError::Mismatch {
            path: dirs[0].join(PLAN_FILE),
            message: format!("its units are not the plan blurlab {SOFTWARE_VERSION} computes for this request"),
        });
    }

    // Find every unit of the plan, exactly once.
    let bar = if progress == ProgressMode::Quiet || !io::IsTerminal::is_terminal(&io::stderr()) {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::with_draw_target(Some(plan.units.len() as u64), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template("{prefix:>8} [{elapsed_precise}] {wide_bar} {pos}/{len} units ETA {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b.set_prefix("verify");
        b
    };
    let mut found: BTreeMap<StimulusId, Vec<(usize, UnitRecord)>> = BTreeMap::new();
    let (mut missing, mut duplicated) = (Vec::new(), Vec::new());
    for unit in &plan.units {
        for id in &unit.ids {
            let method = request.method_of(id)?.kind();
            let mut valid = Vec::new();
            let mut damaged = Vec::new();
            for (d, dir) in dirs.iter().enumerate() {
                if !unit.record_path(dir, id).exists() {
                    continue;
                }
                match read_record(dir, &design, &preset, &plan, unit, id, method) {
                    Ok(record) => valid.push((d, record)),
                    Err(why) => damaged.push(why),
                }
            }
            let name = format!("{} (shard {}/{})", unit.name_for(id), unit.shard, plan.shards);
            match valid.len() {
                0 if damaged.is_empty() => missing.push(format!("missing: {name}")),
                0 => missing.push(format!("damaged: {name}: {}", damaged.join("; "))),
                1 => found.entry(*id).or_default().extend(valid),
                _ => duplicated.push(format!(
                    "duplicated: {name} in {}",
                    valid.iter().map(|(d, _)| dirs[*d].display().to_string()).collect::<Vec<_>>().join(" and ")
                )),
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    // Records that no unit of the plan explains.
    let mut unexpected = Vec::new();
    for dir in &dirs {
        for id in &plan.ids {
            let Ok(entries) = std::fs::read_dir(dir.join(id.to_string()).join(UNITS_DIR)) else { continue };
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if !name.ends_with(".json") || name.starts_with('.') {
                    continue;
                }
                if !plan.units.iter().any(|u| u.ids.contains(id) && u.record_name() == name) {
                    unexpected.push(format!("not in the plan: {}", entry.path().display()));
                }
            }
        }
    }
    if !missing.is_empty() || !duplicated.is_empty() || !unexpected.is_empty() {
        let mut lines = missing;
        lines.extend(duplicated);
        lines.extend(unexpected);
        return Err(SetError::Incomplete {
            summary: format!(
                "the shards do not add up to the set of {} units over {} shards ({} problems); nothing was written",
                plan.units.len(),
                plan.shards,
                lines.len()
            ),
            lines,
        });
    }

    // Assemble the set.
    std::fs::create_dir_all(out).map_err(io_err(out, "cannot create the output folder"))?;
    let mut folder = SetFolder::open(out, &design, &preset, plan.sampling)?;
    let mut report = MergeReport { shards: plan.shards, ..MergeReport::default() };
    let writer = AtomicWriter;
    let total_units: usize = plan.units.iter().map(|u| u.ids.len()).sum();
    let progress = Progress::new(progress, total_units as u64, found.len());
    let mut done = 0;
    let result = (|| {
        for (id, records) in &found {
            let seq = out.join(id.to_string());
            std::fs::create_dir_all(&seq).map_err(io_err(&seq, "cannot create the sequence folder"))?;
            if !in_place {
                // The old manifest goes first: a kill mid-copy leaves no complete-looking
                // sequence.
                let manifest_path = seq.join("manifest.json");
                if manifest_path.exists() {
                    std::fs::remove_file(&manifest_path).map_err(io_err(&manifest_path, "cannot remove"))?;
                }
                // Eye units are joined into frames below.
                for (d, record) in records.iter().filter(|(_, r)| r.eye.is_none()) {
                    let from = dirs[*d].join(id.to_string());
                    for f in &record.sequence.frames {
                        let files = [Some((&f.png, &f.png_sha256)), f.exr.as_ref().zip(f.exr_sha256.as_ref())];
                        for (name, hash) in files.into_iter().flatten() {
                            let bytes = read_as_recorded(&from.join(name), hash)?;
                            let target = seq.join(name);
                            writer.write(&target, &bytes).map_err(io_err(&target, "cannot write"))?;
                            report.copied_files += 1;
                        }
                    }
                }
            }
            let parts: Vec<(PathBuf, UnitRecord)> =
                records.iter().map(|(d, r)| (dirs[*d].join(id.to_string()), r.clone())).collect();
            let (records, joined) = join_eyes(id, &parts, &seq, &writer)?;
            report.copied_files += joined;
            let units = parts.len();
            let manifest =
                assemble(&records).map_err(|message| SetError::Mismatch { path: seq.join(UNITS_DIR), message })?;
            let path = seq.join("manifest.json");
            let bytes = manifest_bytes(&manifest);
            if std::fs::read(&path).ok().as_deref() != Some(bytes.as_slice()) {
                writer.write(&path, &bytes).map_err(io_err(&path, "cannot write"))?;
            }
            folder.verified.insert((*id, sha256_hex(&bytes)));
            report.units += units;
            progress.advance(units as u64);
            done += 1;
            progress.finished(done, id, &format!("{units} units verified"), 0.0);
        }
        folder.publish(&writer)
    })();
    progress.finish();
    result?;
    let index = folder.rebuild()?;
    if index.sequences.len() != found.len() {
        return Err(SetError::Incomplete {
            summary: format!(
                "{}: the index lists {} sequences after the merge, expected {}",
                out.display(),
                index.sequences.len(),
                found.len()
            ),
            lines: Vec::new(),
        });
    }
    report.sequences = index.sequences.len();
    report.wall_seconds = started.elapsed().as_secs_f64();
    Ok(report)
}
