//! Rendering one shard: claiming the plan, rendering each of the shard's units with a
//! record of its frames, and skipping units whose records verify.

use std::io;
use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use study::design::{Design, Preset};
use study::manifest::SequenceManifest;
use study::{Eye, Method, StimulusId};

use super::merge::complete_sequences;
use super::plan::{Plan, Unit};
use super::{PLAN_FILE, ShardSpec, UNIT_FORMAT, UNITS_DIR};
use crate::set::{
    AtomicWriter, Expected, FileWriter, Progress, SetError, SetFolder, SetRequest, eye_folder, eye_name,
    frame_index_of, io_err, remove_temporaries_of, render_stream,
};
use render::env::EnvironmentMap;
use render::renderer::Renderer;

/// A unit's record (`SEQ/units/frames-FIRST-LAST.json`): the manifest of its frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UnitRecord {
    /// Always [`UNIT_FORMAT`].
    pub format: String,
    /// K, the shard that rendered it.
    pub shard: u32,
    /// N.
    pub shards: u32,
    /// First frame.
    pub first: u32,
    /// One past the last frame.
    pub end: u32,
    /// The eye of a stereo sequence; its frames are in [`eye_folder`] and name it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eye: Option<Eye>,
    /// The sequence manifest, listing only these frames.
    pub sequence: SequenceManifest,
}

/// What a shard run did.
#[derive(Clone, Debug, Default)]
pub struct ShardReport {
    /// The shard's units (all of them).
    pub units: usize,
    /// Units rendered by this run.
    pub rendered: Vec<String>,
    /// Units skipped because they verified (`--resume`).
    pub skipped: Vec<String>,
    /// Units another live process was rendering, and that process (a shard run with any
    /// ends in an error naming them).
    pub left_to_others: Vec<(String, String)>,
    /// Sequences whose manifest this run wrote (every unit of them was in the folder).
    pub completed: Vec<StimulusId>,
    /// Non-finite samples discarded.
    pub nonfinite_samples: u64,
    /// Wall seconds.
    pub wall_seconds: f64,
    /// The device, as manifests name it.
    pub device: String,
}

/// Renders shard `shard` of `request`'s set into `request.out`.
pub fn render_shard(request: &SetRequest<'_>, shard: ShardSpec) -> Result<ShardReport, SetError> {
    render_shard_with(request, shard, &AtomicWriter)
}

/// Renders shard `shard`, writing every file through `writer`.
pub fn render_shard_with(
    request: &SetRequest<'_>,
    shard: ShardSpec,
    writer: &dyn FileWriter,
) -> Result<ShardReport, SetError> {
    let started = Instant::now();
    let (design, preset, out) = (request.design, &request.preset, &request.out);
    for id in &request.ids {
        design.check_id(id)?;
    }
    let device = crate::set::medium::device_for(design, &request.ids, request.device)?;
    let plan = Plan::compute(request, shard.count)?;
    std::fs::create_dir_all(out).map_err(io_err(out, "cannot create the output folder"))?;
    let mut folder = SetFolder::open(out, design, preset, request.sampling)?;
    claim_plan(out, &plan, writer)?;
    folder.publish(writer)?;
    let env = EnvironmentMap::from_lighting(&design.lighting)?;
    let renderer = Renderer::open(device, &env)?;
    crate::set::medium::prepare(design, preset, request.progress)?;

    let mine: Vec<&Unit> = plan.units.iter().filter(|u| u.shard == shard.index).collect();
    let progress = Progress::new(request.progress, mine.iter().map(|u| u.cost).sum(), mine.len());
    let mut report = ShardReport { units: mine.len(), device: renderer.device_name(), ..ShardReport::default() };
    let mut done = 0;
    let result = (|| {
        for unit in mine {
            let unit_started = Instant::now();
            let lead = unit.ids[0];
            let units_dir = out.join(lead.to_string()).join(UNITS_DIR);
            std::fs::create_dir_all(&units_dir).map_err(io_err(&units_dir, "cannot create the units folder"))?;
            let lock_path = units_dir.join(unit.record_name().replace(".json", ".lock"));
            let _lock = match study::lock::LockFile::acquire(&lock_path) {
                Ok(lock) => lock,
                Err(study::lock::LockError::Held { holder, .. }) => {
                    progress.advance(unit.cost);
                    done += 1;
                    progress.finished(done, unit, &format!("left to the process rendering it ({holder})"), 0.0);
                    report.left_to_others.push((unit.to_string(), format!("{holder}: {}", lock_path.display())));
                    continue;
                }
                Err(study::lock::LockError::Io { path, source }) => {
                    return Err(SetError::Io { path, action: "cannot take the unit's lock", source });
                }
            };
            if request.resume && unit.ids.iter().all(|id| unit_verifies(request, &plan, unit, id)) {
                progress.advance(unit.cost);
                done += 1;
                progress.finished(done, unit, "verified, skipped", 0.0);
                report.skipped.push(unit.to_string());
                complete_sequences(request, &plan, unit, &mut folder, writer, &mut report)?;
                continue;
            }
            // Un-mark before touching files: without its record the unit is not done, and
            // without its manifest the sequence leaves the index.
            for id in &unit.ids {
                let seq = out.join(id.to_string());
                std::fs::create_dir_all(seq.join(UNITS_DIR))
                    .map_err(io_err(&seq, "cannot create the sequence folder"))?;
                for path in [unit.record_path(out, id), seq.join("manifest.json")] {
                    match std::fs::remove_file(&path) {
                        Ok(()) => {}
                        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                        Err(source) => return Err(SetError::Io { path, action: "cannot remove", source }),
                    }
                }
                let frames = unit.frames();
                let folder = unit.eye.map_or_else(|| seq.clone(), |eye| eye_folder(&seq, eye));
                remove_temporaries_of(&folder, |target| frame_index_of(target).is_some_and(|f| frames.contains(&f)));
            }
            folder.publish(writer)?;
            let bar = progress.sequence_bar(&lead, unit.end - unit.first);
            let frame_cost = unit.cost / u64::from((unit.end - unit.first).max(1));
            let manifests = render_stream(request, &renderer, &unit.ids, unit.frames(), unit.eye, writer, |_| {
                progress.advance(frame_cost);
                if let Some(b) = &bar {
                    b.inc(1);
                }
            })?;
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            for (id, sequence) in unit.ids.iter().zip(manifests) {
                report.nonfinite_samples += sequence.nonfinite_samples();
                let record = UnitRecord {
                    format: UNIT_FORMAT.to_owned(),
                    shard: shard.index,
                    shards: shard.count,
                    first: unit.first,
                    end: unit.end,
                    eye: unit.eye,
                    sequence,
                };
                let path = unit.record_path(out, id);
                writer.write(&path, &json_bytes(&record)).map_err(io_err(&path, "cannot write"))?;
            }
            report.rendered.push(unit.to_string());
            done += 1;
            progress.finished(done, unit, "rendered", unit_started.elapsed().as_secs_f64());
            complete_sequences(request, &plan, unit, &mut folder, writer, &mut report)?;
        }
        folder.publish(writer)
    })();
    progress.finish();
    result?;
    if !report.left_to_others.is_empty() {
        // Only one process renders a shard's units: a lock held elsewhere is another copy of
        // this shard, or one that died on another host (whose locks are never judged stale).
        return Err(SetError::Incomplete {
            summary: format!(
                "shard {shard}: {} of its units are locked by other processes and were not rendered; if those processes have ended (e.g. a task killed on another node and resubmitted as a new job; a requeued Slurm task takes over its own job's locks), remove their lock files and run the shard again with --resume",
                report.left_to_others.len()
            ),
            lines: report.left_to_others.iter().map(|(unit, holder)| format!("{unit}: {holder}")).collect(),
        });
    }
    report.wall_seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

pub(super) fn json_bytes<T: Serialize>(value: &T) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(value).unwrap_or_default();
    bytes.push(b'\n');
    bytes
}

/// Writes `plan` as the folder's `plan.json`, or checks that the one there is the same.
pub(super) fn claim_plan(out: &Path, plan: &Plan, writer: &dyn FileWriter) -> Result<(), SetError> {
    let path = out.join(PLAN_FILE);
    match std::fs::read(&path) {
        Ok(bytes) => {
            let theirs: Plan = serde_json::from_slice(&bytes).map_err(|e| SetError::Mismatch {
                path: path.clone(),
                message: format!("not a readable shard plan ({e}); remove it or render into another folder"),
            })?;
            let differences = theirs.differences(plan);
            if !differences.is_empty() {
                return Err(SetError::Mismatch {
                    path,
                    message: format!(
                        "this folder holds shards of another plan; differs in {} (there, this run); every shard of one set must use the same design, preset, selection, --exr, --nested, blurlab version and N: render into another folder",
                        differences.join(", ")
                    ),
                });
            }
            Ok(())
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            writer.write(&path, &json_bytes(plan)).map_err(io_err(&path, "cannot write"))
        }
        Err(source) => Err(SetError::Io { path, action: "cannot read", source }),
    }
}

/// Reads the record of `unit`'s member `id` under `set` and says why it is not valid
/// (`Err`), or returns it.
pub(super) fn read_record(
    set: &Path,
    design: &Design,
    preset: &Preset,
    plan: &Plan,
    unit: &Unit,
    id: &StimulusId,
    method: Method,
) -> Result<UnitRecord, String> {
    let path = unit.record_path(set, id);
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let record: UnitRecord =
        serde_json::from_slice(&bytes).map_err(|e| format!("{}: not a unit record ({e})", path.display()))?;
    if record.format != UNIT_FORMAT {
        return Err(format!("{}: format `{}`, expected `{UNIT_FORMAT}`", path.display(), record.format));
    }
    if (record.shard, record.shards, record.first, record.end, record.eye)
        != (unit.shard, plan.shards, unit.first, unit.end, unit.eye)
    {
        let eye = |e: Option<Eye>| e.map_or(String::new(), |e| format!(" {} eye", eye_name(e)));
        return Err(format!(
            "{}: rendered as shard {}/{}{} frames {}..{}, and the plan gives it to shard {}/{}{} frames {}..{}",
            path.display(),
            record.shard,
            record.shards,
            eye(record.eye),
            record.first,
            record.end,
            unit.shard,
            plan.shards,
            eye(unit.eye),
            unit.first,
            unit.end
        ));
    }
    if record.sequence.software_version != plan.software_version {
        return Err(format!(
            "{}: rendered by blurlab {}, and the plan is of blurlab {}",
            path.display(),
            record.sequence.software_version,
            plan.software_version
        ));
    }
    let expected = Expected {
        design,
        preset,
        id,
        method,
        exr: plan.exr,
        sampling: plan.sampling,
        frames: unit.frames(),
        eye: unit.eye,
    };
    match expected.why_not(&set.join(id.to_string()), &record.sequence) {
        Some(why) => Err(format!("{}: {why}", path.display())),
        None => Ok(record),
    }
}

pub(super) fn unit_verifies(request: &SetRequest<'_>, plan: &Plan, unit: &Unit, id: &StimulusId) -> bool {
    request
        .method_of(id)
        .is_ok_and(|m| read_record(&request.out, request.design, &request.preset, plan, unit, id, m.kind()).is_ok())
}
