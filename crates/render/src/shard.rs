//! Sharded set rendering (`stimuli render --shard K/N`, a Slurm job array's task K) and the
//! merge that proves the shards add up to the set (`stimuli merge`).
//!
//! **Plan.** The work of a set is cut into *units*: a sequence (or, with nested sampling,
//! the sample levels of one stream), one eye of it where it is stereo, and a range of its
//! frames. A unit's cost is its estimated camera samples (pixels x samples per pixel,
//! scaled by the method's work per sample, [`samples_cost`]) times its frames. Sequences costing more than a
//! quarter of a shard's share are cut into frame ranges, then units go, most expensive
//! first, to the shard with the least cost so far (ties: the lower shard), so shards
//! finish at about the same time. The plan depends only on the design, preset, selection,
//! sampling mode, `--exr` and N, so every task computes the same one; each writes it as
//! `plan.json` into its set folder and refuses a folder holding another plan (another N,
//! design, preset, selection or software version).
//!
//! **Units on disk.** A monoscopic unit's frames are written into the sequence folder as in
//! an unsharded set; an eye unit's frames (that camera alone, with the seed it has in the
//! pair) into `SEQ/eyes/EYE/`. Then its record `SEQ/units/frames-FIRST-LAST[-EYE].json`
//! (`blurlab-unit/1`: the sequence manifest of those frames, with the shard and eye that
//! rendered them). A record exists only for a unit whose frames are all on disk; `--resume`
//! skips a unit whose record and files verify. Where every unit of a sequence is in one
//! folder (a shared folder, or a shard that owns the whole sequence), the shard joins the
//! eyes' frames side by side into the sequence's frames (the 8-bit rows as the whole frame
//! encodes them, so the bytes are an unsharded render's), writes `manifest.json`, assembled
//! only from the records (so two shards finishing at once write the same bytes), and
//! publishes the index (`set`'s rules). The eyes' frames stay beside them, for `--resume`.
//!
//! **Merge.** [`merge`] reads the plan of every shard folder, refuses folders of different
//! plans by name, finds every unit of the plan exactly once with files that verify (else
//! lists precisely what is missing, damaged, duplicated or not in the plan, and writes
//! nothing), then copies the frames into the output folder (joining eye units' frames, which
//! may come from different shard folders), writes the manifests and the index. Given only the output folder, it checks a shared folder in place.
//!
//! Seeds depend only on (design seed, stimulus, eye, frame), so a unit's frames are the
//! bytes an unsharded render writes (on the CPU; on a GPU, for the same adapter and driver).

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};
use study::design::{Design, Preset};
use study::fsio::sha256_hex;
use study::manifest::{FrameRecord, Sampling, SequenceManifest};
use study::method::MethodSpec;
use study::{Eye, Method, SOFTWARE_VERSION, StimulusId};

use crate::device::Renderer;
use crate::env::EnvironmentMap;
use crate::set::{
    AtomicWriter, Expected, FileWriter, Progress, ProgressMode, SetError, SetFolder, SetRequest, eye_folder, eye_name,
    frame_index_of, frame_name, io_err, manifest_bytes, remove_temporaries_of, render_stream, streams,
};

/// Format tag of `plan.json`.
pub const PLAN_FORMAT: &str = "blurlab-plan/1";
/// Format tag of a unit record.
pub const UNIT_FORMAT: &str = "blurlab-unit/1";
/// The plan's file name in a set folder.
pub const PLAN_FILE: &str = "plan.json";
/// The folder, inside a sequence folder, of its unit records.
pub const UNITS_DIR: &str = "units";
/// Units a shard's share is cut into at least, where sequences are larger than that.
const UNITS_PER_SHARD: u64 = 4;

/// Shard K of N: `K/N`, K counted from 0 (as Slurm's `SLURM_ARRAY_TASK_ID` of
/// `--array=0-(N-1)`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardSpec {
    /// K, from 0.
    pub index: u32,
    /// N, at least 1.
    pub count: u32,
}

impl fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for ShardSpec {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let shape = || format!("`{text}`: expected K/N, shard K (counted from 0) of N, e.g. 0/4");
        let (k, n) = text.split_once('/').ok_or_else(shape)?;
        let number = |s: &str, what: &str| {
            s.trim().parse::<u32>().map_err(|_| format!("`{text}`: {what} `{}` is not a whole number", s.trim()))
        };
        let (index, count) = (number(k, "K")?, number(n, "N")?);
        if count == 0 {
            return Err(format!("`{text}`: N = 0; a set is rendered in at least 1 shard"));
        }
        if index >= count {
            return Err(format!(
                "`{text}`: K = {index} is not below N = {count}; shards count from 0 (like SLURM_ARRAY_TASK_ID with --array=0-{}), so K is 0 to {}",
                count - 1,
                count - 1
            ));
        }
        Ok(ShardSpec { index, count })
    }
}

/// One unit of work: frames `first..end` of a sequence (or of the sample levels of one
/// nested stream), of one eye where the sequence is stereo, and the shard that renders it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Unit {
    /// The sequences rendered together: one, or a nested stream's levels.
    pub ids: Vec<StimulusId>,
    /// The eye of a stereo sequence; `None` for a monoscopic one (its only camera).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eye: Option<Eye>,
    /// First frame.
    pub first: u32,
    /// One past the last frame.
    pub end: u32,
    /// Estimated cost (camera samples, weighted by the method).
    pub cost: u64,
    /// The shard (K, from 0) that renders it.
    pub shard: u32,
}

impl Unit {
    /// The frames.
    pub fn frames(&self) -> Range<u32> {
        self.first..self.end
    }

    /// The record's file name inside `SEQ/units/`.
    pub fn record_name(&self) -> String {
        let eye = self.eye.map_or(String::new(), |e| format!("-{}", eye_name(e)));
        format!("frames-{:04}-{:04}{eye}.json", self.first, self.end.saturating_sub(1))
    }

    /// The unit's part of sequence `id`, as reports name it: `ID [left eye ]frames A-B`.
    pub fn name_for(&self, id: &StimulusId) -> String {
        self.describe(&id.to_string())
    }

    fn describe(&self, ids: &str) -> String {
        let eye = self.eye.map_or(String::new(), |e| format!(" {} eye", eye_name(e)));
        format!("{ids}{eye} frames {}-{}", self.first, self.end.saturating_sub(1))
    }

    /// The record's path for member `id` under `set`.
    pub fn record_path(&self, set: &Path, id: &StimulusId) -> PathBuf {
        set.join(id.to_string()).join(UNITS_DIR).join(self.record_name())
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ids: Vec<String> = self.ids.iter().map(ToString::to_string).collect();
        f.write_str(&self.describe(&ids.join("+")))
    }
}

/// The assignment of a set's units to N shards (`plan.json`, `blurlab-plan/1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Always [`PLAN_FORMAT`].
    pub format: String,
    /// Design name.
    pub design: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// Preset name.
    pub preset: String,
    /// Sampling mode.
    pub sampling: Sampling,
    /// Whether EXR frames are written.
    pub exr: bool,
    /// blurlab version that made the plan (and renders the units).
    pub software_version: String,
    /// N.
    pub shards: u32,
    /// The selected sequences, in order.
    pub ids: Vec<StimulusId>,
    /// Every unit, in order of the sequences and frames.
    pub units: Vec<Unit>,
}

/// Camera samples per pixel a method's frame costs about, relative to the tracer's: the
/// accumulation buffer traces K instants of its samples each; the filters trace the
/// centre instant and gather taps (about 8 taps per traced sample); the analytic
/// rasterizer shades its lighting samples per pixel.
pub fn samples_cost(method: &MethodSpec, spp: u32) -> u64 {
    let spp = u64::from(spp.max(1));
    match method.kind {
        Method::Tracer => spp,
        Method::Accum => {
            let k = u64::from(method.instants.unwrap_or(8).max(1));
            k * method.samples_per_instant.map_or(spp.div_ceil(k), u64::from)
        }
        Method::Mcguire | Method::Guertin => spp + u64::from(method.taps.unwrap_or(32)).div_ceil(8),
        Method::Analytic => {
            let points = u64::from(method.supersampling.unwrap_or(1).max(1)).pow(2);
            method.lighting_samples.map_or(spp, u64::from).max(1) * points
        }
    }
}

impl Plan {
    /// The plan of `request`'s sequences over `shards` shards.
    pub fn compute(request: &SetRequest<'_>, shards: u32) -> Result<Plan, SetError> {
        let preset = &request.preset;
        let mut pieces = Vec::new();
        for members in streams(&request.ids, request.sampling) {
            let spp = members
                .iter()
                .map(|id| preset.samples_per_pixel.get(usize::from(id.samples).wrapping_sub(1)).copied().unwrap_or(1))
                .max()
                .unwrap_or(1);
            let pixels = u64::from(preset.width) * u64::from(preset.height);
            let per_frame = pixels * samples_cost(&request.method_of(&members[0])?, spp);
            match Eye::of_view(members[0].view) {
                [_] => pieces.push((members, None, per_frame)),
                eyes => pieces.extend(eyes.iter().map(|&eye| (members.clone(), Some(eye), per_frame))),
            }
        }
        let total: u64 = pieces.iter().map(|(_, _, c)| c * u64::from(preset.frames)).sum();
        let target = (total / (u64::from(shards.max(1)) * UNITS_PER_SHARD)).max(1);
        let mut units = Vec::new();
        for (members, eye, per_frame) in pieces {
            let frames = preset.frames;
            let chunks = (per_frame * u64::from(frames)).div_ceil(target).clamp(1, u64::from(frames.max(1))) as u32;
            let (base, extra) = (frames / chunks, frames % chunks);
            let mut first = 0;
            for c in 0..chunks {
                let len = base + u32::from(c < extra);
                units.push(Unit {
                    ids: members.clone(),
                    eye,
                    first,
                    end: first + len,
                    cost: per_frame * u64::from(len),
                    shard: 0,
                });
                first += len;
            }
        }
        // Longest processing time first, onto the least loaded shard.
        let mut order: Vec<usize> = (0..units.len()).collect();
        order.sort_by(|&a, &b| units[b].cost.cmp(&units[a].cost).then(a.cmp(&b)));
        let mut loads = vec![0u64; shards.max(1) as usize];
        for i in order {
            let k = (0..loads.len()).min_by_key(|&k| (loads[k], k)).unwrap_or(0);
            loads[k] += units[i].cost;
            units[i].shard = k as u32;
        }
        Ok(Plan {
            format: PLAN_FORMAT.to_owned(),
            design: request.design.name().to_owned(),
            design_sha256: request.design.sha256.clone(),
            preset: preset.name.clone(),
            sampling: request.sampling,
            exr: request.exr,
            software_version: SOFTWARE_VERSION.to_owned(),
            shards,
            ids: request.ids.clone(),
            units,
        })
    }

    /// Estimated cost of each shard.
    pub fn loads(&self) -> Vec<u64> {
        let mut loads = vec![0u64; self.shards as usize];
        for u in &self.units {
            if let Some(l) = loads.get_mut(u.shard as usize) {
                *l += u.cost;
            }
        }
        loads
    }

    /// The assignment as text (`--plan`): a line per shard with its share, then its units.
    pub fn describe(&self) -> String {
        let loads = self.loads();
        let total: u64 = loads.iter().sum::<u64>().max(1);
        let mut s = format!(
            "plan: design `{}`, preset `{}`, {} sequences in {} units over {} shards (cost: estimated camera samples)\n",
            self.design,
            self.preset,
            self.ids.len(),
            self.units.len(),
            self.shards
        );
        for (k, load) in loads.iter().enumerate() {
            let mine: Vec<&Unit> = self.units.iter().filter(|u| u.shard as usize == k).collect();
            s.push_str(&format!(
                "shard {k}/{}: {} units, cost {load} ({:.1} %)\n",
                self.shards,
                mine.len(),
                100.0 * *load as f64 / total as f64
            ));
            for u in mine {
                s.push_str(&format!("  {u}  cost {}\n", u.cost));
            }
        }
        s
    }

    /// The names of the fields in which `other` differs from this plan.
    pub fn differences(&self, other: &Plan) -> Vec<String> {
        let mut d = Vec::new();
        let mut field = |same: bool, what: String| {
            if !same {
                d.push(what);
            }
        };
        field(self.format == other.format, format!("format (`{}`, `{}`)", self.format, other.format));
        field(
            self.design == other.design && self.design_sha256 == other.design_sha256,
            format!(
                "design (`{}` sha256 {}, `{}` sha256 {})",
                self.design, self.design_sha256, other.design, other.design_sha256
            ),
        );
        field(self.preset == other.preset, format!("preset (`{}`, `{}`)", self.preset, other.preset));
        field(
            self.software_version == other.software_version,
            format!("software version ({}, {})", self.software_version, other.software_version),
        );
        field(self.shards == other.shards, format!("shard count N ({}, {})", self.shards, other.shards));
        field(self.sampling == other.sampling, format!("sampling ({:?}, {:?})", self.sampling, other.sampling));
        field(self.exr == other.exr, format!("--exr ({}, {})", self.exr, other.exr));
        field(self.ids == other.ids, format!("selected sequences ({}, {} sequences)", self.ids.len(), other.ids.len()));
        if d.is_empty() && self.units != other.units {
            d.push("units (the same request planned differently)".to_owned());
        }
        d
    }
}

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
    let plan = Plan::compute(request, shard.count)?;
    std::fs::create_dir_all(out).map_err(io_err(out, "cannot create the output folder"))?;
    let mut folder = SetFolder::open(out, design, preset, request.sampling)?;
    claim_plan(out, &plan, writer)?;
    folder.publish(writer)?;
    let env = EnvironmentMap::from_lighting(&design.lighting)?;
    let renderer = Renderer::open(request.device, &env)?;

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

fn json_bytes<T: Serialize>(value: &T) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(value).unwrap_or_default();
    bytes.push(b'\n');
    bytes
}

/// Writes `plan` as the folder's `plan.json`, or checks that the one there is the same.
fn claim_plan(out: &Path, plan: &Plan, writer: &dyn FileWriter) -> Result<(), SetError> {
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
fn read_record(
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

fn unit_verifies(request: &SetRequest<'_>, plan: &Plan, unit: &Unit, id: &StimulusId) -> bool {
    request
        .method_of(id)
        .is_ok_and(|m| read_record(&request.out, request.design, &request.preset, plan, unit, id, m.kind).is_ok())
}

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
fn join_eyes(
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
                halves.push(crate::io::decode_png_rgb8(&bytes).map_err(|source| SetError::Encode { path, source })?);
            }
            let png_name = frame_name(index, "png");
            let png_path = seq_out.join(&png_name);
            let (w, h, rows) = crate::io::join_rgb8_side_by_side(&halves)
                .map_err(|source| SetError::Encode { path: png_path.clone(), source })?;
            let png = crate::io::encode_png_rgb8(w, h, &rows);
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
                    images.push(crate::io::decode_exr(&bytes).map_err(|source| SetError::Encode { path, source })?);
                }
                let exr_name = frame_name(index, "exr");
                let exr_path = seq_out.join(&exr_name);
                let exr = crate::io::encode_exr(&crate::io::compose_side_by_side(&images))
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
fn read_as_recorded(path: &Path, hash: &str) -> Result<Vec<u8>, SetError> {
    let bytes = std::fs::read(path).map_err(io_err(path, "cannot read"))?;
    if sha256_hex(&bytes) != hash {
        return Err(SetError::Mismatch {
            path: path.to_owned(),
            message: "changed while being merged: it no longer hashes as recorded".into(),
        });
    }
    Ok(bytes)
}

/// The distinct devices, in order, joined by `; ` (as manifests name them).
fn distinct_devices<'a>(devices: impl Iterator<Item = &'a str>) -> String {
    let mut distinct: Vec<&str> = Vec::new();
    for d in devices {
        if !distinct.contains(&d) {
            distinct.push(d);
        }
    }
    distinct.join("; ")
}

/// Writes `bytes` to `path` unless it already holds them; returns the files written (0 or 1).
fn write_if_changed(writer: &dyn FileWriter, path: &Path, bytes: &[u8]) -> Result<usize, SetError> {
    if std::fs::read(path).ok().as_deref() == Some(bytes) {
        return Ok(0);
    }
    writer.write(path, bytes).map_err(io_err(path, "cannot write"))?;
    Ok(1)
}

/// Writes the manifest of every sequence of `unit` whose units are all in the folder and
/// verify, and publishes the index.
fn complete_sequences(
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
        let method = request.method_of(id)?.kind;
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
        method: design.method(),
        out: out.to_owned(),
        resume: false,
        exr: plan.exr,
        progress,
        device: crate::DeviceChoice::Cpu,
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
            let method = request.method_of(id)?.kind;
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

#[cfg(test)]
mod tests {
    use study::fsio::write_atomic;

    use super::*;
    use crate::DeviceChoice;

    /// The shipped design with a preset `tiny` (8x4, 5 frames): a merge takes presets by name.
    fn design() -> Design {
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
        let text = std::fs::read_to_string(&shipped).unwrap();
        let dir = std::env::temp_dir().join(format!(
            "blurlab-shard-tests-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("tiny.toml");
        let tiny = "[presets.tiny]\nwidth = 8\nheight = 4\nframes = 5\nsamples_per_pixel = [1, 4, 8, 12, 16]\n";
        write_atomic(&path, format!("{text}\n{tiny}").as_bytes()).unwrap();
        let design = Design::load(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        design
    }

    fn request<'a>(design: &'a Design, out: &Path, only: &[&str]) -> SetRequest<'a> {
        SetRequest {
            design,
            preset: design.preset("tiny").unwrap(),
            ids: only.iter().map(|s| s.parse().unwrap()).collect(),
            method: Method::Tracer,
            out: out.to_owned(),
            resume: false,
            exr: false,
            progress: ProgressMode::Quiet,
            device: DeviceChoice::Cpu,
            sampling: Sampling::Independent,
        }
    }

    #[test]
    fn shard_specs_count_from_zero_and_bad_ones_say_what_is_expected() {
        assert_eq!("0/4".parse::<ShardSpec>(), Ok(ShardSpec { index: 0, count: 4 }));
        assert_eq!(" 3 / 4 ".parse::<ShardSpec>(), Ok(ShardSpec { index: 3, count: 4 }));
        let err = |t: &str| t.parse::<ShardSpec>().unwrap_err();
        assert!(err("4/4").contains("K = 4 is not below N = 4") && err("4/4").contains("0 to 3"), "{}", err("4/4"));
        assert!(err("0/0").contains("N = 0"), "{}", err("0/0"));
        assert!(err("3").contains("expected K/N"), "{}", err("3"));
        assert!(err("a/2").contains("K `a` is not a whole number"), "{}", err("a/2"));
        assert!(err("-1/2").contains("not a whole number"), "{}", err("-1/2"));
    }

    #[test]
    fn the_plan_covers_every_frame_once_and_balances_the_cost() {
        let d = design();
        let ids = ["M1-S1-T1-A5", "M1-S1-T1-A1", "M2-S2-T3-A3-stereo", "M3-S1-T2-A2", "M1-S3-T5-A4-stereo"];
        let req = request(&d, Path::new("unused"), &ids);
        for n in [1u32, 2, 3, 4, 7] {
            let plan = Plan::compute(&req, n).unwrap();
            assert_eq!(plan, Plan::compute(&req, n).unwrap(), "deterministic");
            for id in &req.ids {
                // Every frame of every eye once: a stereo sequence's units are per eye.
                let eyes: Vec<Option<Eye>> = match Eye::of_view(id.view) {
                    [_] => vec![None],
                    eyes => eyes.iter().copied().map(Some).collect(),
                };
                for eye in eyes {
                    let mut frames: Vec<u32> =
                        plan.units.iter().filter(|u| u.ids == [*id] && u.eye == eye).flat_map(|u| u.frames()).collect();
                    frames.sort_unstable();
                    assert_eq!(frames, (0..5).collect::<Vec<_>>(), "{id} {eye:?} with N = {n}");
                }
                assert!(
                    plan.units
                        .iter()
                        .filter(|u| u.ids == [*id])
                        .all(|u| u.eye.is_some() == (id.view == study::View::Stereo))
                );
            }
            assert!(plan.units.iter().all(|u| u.shard < n && u.end > u.first));
            let loads = plan.loads();
            let (max, total) = (*loads.iter().max().unwrap(), loads.iter().sum::<u64>());
            let largest_unit = plan.units.iter().map(|u| u.cost).max().unwrap();
            // Greedy LPT: no shard exceeds an even share by more than one unit.
            assert!(max <= total / u64::from(n) + largest_unit, "N = {n}: {loads:?}");
            assert!(plan.describe().contains(&format!("shard {}/{n}:", n - 1)));
        }
        // Cost follows samples x pixels: an eye of A5 (16 spp) stereo costs 16 times A1 mono
        // per frame, and the pair 32 times.
        let plan = Plan::compute(&request(&d, Path::new("x"), &["M1-S1-T1-A1", "M1-S1-T1-A5-stereo"]), 1).unwrap();
        let per_frame = |u: &Unit| u.cost / u64::from(u.end - u.first);
        let eyes: Vec<&Unit> = plan.units.iter().filter(|u| u.eye.is_some()).collect();
        assert!([Eye::Left, Eye::Right].iter().all(|&e| eyes.iter().any(|u| u.eye == Some(e))));
        assert!(eyes.iter().all(|u| per_frame(u) == 16 * per_frame(&plan.units[0])));
        let right = eyes.iter().find(|u| u.eye == Some(Eye::Right) && u.first == 0).unwrap();
        let last = right.end - 1;
        assert_eq!(right.to_string(), format!("M1-S1-T1-A5-stereo right eye frames 0-{last}"));
        assert_eq!(right.record_name(), format!("frames-0000-{last:04}-right.json"));
        // Four shards of a two-sequence set split the costly sequence into frame ranges.
        let plan = Plan::compute(&request(&d, Path::new("x"), &["M1-S1-T1-A1", "M1-S1-T1-A5-stereo"]), 4).unwrap();
        assert!(plan.units.iter().filter(|u| u.ids[0].samples == 5).count() >= 4, "{}", plan.describe());
        assert!(plan.loads().iter().all(|&l| l > 0), "{}", plan.describe());
    }

    #[test]
    fn method_costs_scale_with_their_work() {
        let mut accum = MethodSpec::of(Method::Accum);
        accum.instants = Some(4);
        assert_eq!(samples_cost(&accum, 10), 12);
        assert_eq!(samples_cost(&MethodSpec::of(Method::Tracer), 10), 10);
        let mut guertin = MethodSpec::of(Method::Guertin);
        guertin.taps = Some(35);
        assert_eq!(samples_cost(&guertin, 10), 15);
        let mut analytic = MethodSpec::of(Method::Analytic);
        assert_eq!(samples_cost(&analytic, 10), 10);
        analytic.supersampling = Some(4);
        analytic.lighting_samples = Some(2);
        assert_eq!(samples_cost(&analytic, 10), 32);
    }

    #[test]
    fn shards_merge_into_the_unsharded_set_and_merge_lists_what_is_missing_or_duplicated() {
        let d = design();
        let dir = tempfile::tempdir().unwrap();
        let ids = ["M2-S3-T5-A2", "M1-S1-T3-A1-stereo", "M3-S2-T4-A3"];
        let whole = dir.path().join("whole");
        crate::set::render_set(&request(&d, &whole, &ids)).unwrap();
        let n = 3;
        let shards: Vec<PathBuf> = (0..n).map(|k| dir.path().join(format!("shard{k}"))).collect();
        for (k, out) in shards.iter().enumerate() {
            let report = render_shard(&request(&d, out, &ids), ShardSpec { index: k as u32, count: n }).unwrap();
            assert!(!report.rendered.is_empty(), "shard {k} has work");
        }
        // Shard 2 alone is missing shards 0 and 1's units, named with their shard.
        let e = merge(&dir.path().join("partial"), &shards[2..], ProgressMode::Quiet).unwrap_err();
        let text = e.to_string();
        assert!(e.is_bad_input() && text.contains("missing: ") && text.contains("(shard 0/3)"), "{text}");
        assert!(!dir.path().join("partial").exists(), "nothing written");
        // A shard given twice is duplicated.
        let copy = dir.path().join("copy1");
        copy_tree(&shards[1], &copy);
        let e = merge(&dir.path().join("dup"), &[shards.clone(), vec![copy]].concat(), ProgressMode::Quiet)
            .unwrap_err()
            .to_string();
        assert!(e.contains("duplicated: ") && e.contains("(shard 1/3) in "), "{e}");
        assert!(!e.contains("missing"), "{e}");
        // Complete: the frames are the unsharded bytes.
        let merged = dir.path().join("merged");
        let report = merge(&merged, &shards, ProgressMode::Quiet).unwrap();
        assert_eq!(report.sequences, 3);
        for id in ids {
            let a = SequenceManifest::read(&whole.join(id).join("manifest.json")).unwrap();
            let b = SequenceManifest::read(&merged.join(id).join("manifest.json")).unwrap();
            assert_eq!(without_timing(a.clone()), without_timing(b.clone()), "{id}");
            for f in &a.frames {
                let bytes = std::fs::read(merged.join(id).join(&f.png)).unwrap();
                assert_eq!(sha256_hex(&bytes), f.png_sha256, "{id} {}", f.png);
            }
        }
        // A damaged frame is named.
        let plan: Plan = serde_json::from_slice(&std::fs::read(shards[0].join(PLAN_FILE)).unwrap()).unwrap();
        let victim = plan.units.iter().find(|u| u.shard == 0).unwrap();
        let png = shards[0].join(victim.ids[0].to_string()).join(crate::set::frame_name(victim.first, "png"));
        std::fs::write(&png, b"damaged").unwrap();
        let e = merge(&dir.path().join("bad"), &shards, ProgressMode::Quiet).unwrap_err().to_string();
        assert!(e.contains("damaged: ") && e.contains("does not hash as recorded"), "{e}");
        // --resume renders only the damaged unit again.
        let mut again = request(&d, &shards[0], &ids);
        again.resume = true;
        let r = render_shard(&again, ShardSpec { index: 0, count: n }).unwrap();
        assert_eq!(r.rendered, vec![victim.to_string()], "{r:?}");
        merge(&dir.path().join("merged2"), &shards, ProgressMode::Quiet).unwrap();
    }

    #[test]
    fn a_shared_folder_completes_itself_and_refuses_another_shard_count() {
        let d = design();
        let dir = tempfile::tempdir().unwrap();
        let ids = ["M2-S3-T5-A2", "M1-S1-T3-A5"];
        let shared = dir.path().join("shared");
        for k in 0..2 {
            render_shard(&request(&d, &shared, &ids), ShardSpec { index: k, count: 2 }).unwrap();
        }
        let index = study::manifest::SetIndex::read(&shared.join("index.json")).unwrap();
        assert_eq!(index.sequences.len(), 2);
        let before = std::fs::read(shared.join("index.json")).unwrap();
        merge(&shared, &[], ProgressMode::Quiet).unwrap();
        assert_eq!(std::fs::read(shared.join("index.json")).unwrap(), before);
        let plan_before = std::fs::read(shared.join(PLAN_FILE)).unwrap();
        let e = render_shard(&request(&d, &shared, &ids), ShardSpec { index: 0, count: 3 }).unwrap_err();
        assert!(e.is_bad_input() && e.to_string().contains("shard count N (2, 3)"), "{e}");
        assert_eq!(std::fs::read(shared.join(PLAN_FILE)).unwrap(), plan_before);
        assert_eq!(std::fs::read(shared.join("index.json")).unwrap(), before);
        // Merging shards of different plans is refused by name.
        let other = dir.path().join("other");
        render_shard(&request(&d, &other, &ids), ShardSpec { index: 0, count: 3 }).unwrap();
        let e = merge(&dir.path().join("m"), &[shared.clone(), other], ProgressMode::Quiet).unwrap_err().to_string();
        assert!(e.contains("shard count N (2, 3)"), "{e}");
    }

    #[test]
    fn nested_streams_are_units_of_all_their_levels() {
        let d = design();
        let dir = tempfile::tempdir().unwrap();
        let ids = ["M2-S1-T3-A1", "M2-S1-T3-A4", "M2-S1-T3-A2"];
        let nested = |out: &Path| SetRequest { sampling: Sampling::Nested, ..request(&d, out, &ids) };
        let whole = dir.path().join("whole");
        crate::set::render_set(&nested(&whole)).unwrap();
        let plan = Plan::compute(&nested(&whole), 2).unwrap();
        assert!(plan.units.iter().all(|u| u.ids.len() == 3), "{}", plan.describe());
        let shards: Vec<PathBuf> = (0..2).map(|k| dir.path().join(format!("s{k}"))).collect();
        for (k, out) in shards.iter().enumerate() {
            render_shard(&nested(out), ShardSpec { index: k as u32, count: 2 }).unwrap();
        }
        let merged = dir.path().join("merged");
        merge(&merged, &shards, ProgressMode::Quiet).unwrap();
        for id in ids {
            let a = SequenceManifest::read(&whole.join(id).join("manifest.json")).unwrap();
            let b = SequenceManifest::read(&merged.join(id).join("manifest.json")).unwrap();
            assert_eq!(without_timing(a), without_timing(b), "{id}");
        }
    }

    fn without_timing(mut m: SequenceManifest) -> SequenceManifest {
        for f in &mut m.frames {
            (f.wall_seconds, f.cpu_seconds) = (0.0, 0.0);
        }
        m.device.clear();
        m
    }

    fn copy_tree(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap().flatten() {
            let target = to.join(entry.file_name());
            if entry.file_type().unwrap().is_dir() {
                copy_tree(&entry.path(), &target);
            } else {
                std::fs::copy(entry.path(), target).unwrap();
            }
        }
    }
}
