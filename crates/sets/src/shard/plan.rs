//! The plan of a sharded set: its sequences cut into units of frames, balanced over the
//! shards by their estimated cost (each method's `samples_cost`).

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use study::manifest::Sampling;
use study::{Eye, SOFTWARE_VERSION, StimulusId};

use super::{PLAN_FORMAT, UNITS_DIR};
use crate::set::{SetError, SetRequest, eye_name, streams};

/// Units a shard's share is cut into at least, where sequences are larger than that.
const UNITS_PER_SHARD: u64 = 4;

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

impl Plan {
    /// The plan of `request`'s sequences over `shards` shards.
    pub fn compute(request: &SetRequest<'_>, shards: u32) -> Result<Plan, SetError> {
        let preset = &request.preset;
        let mut pieces = Vec::new();
        for members in streams(&request.ids, request.sampling) {
            let spp = members.iter().map(|id| preset.samples_of(id).unwrap_or(1)).max().unwrap_or(1);
            let pixels = u64::from(preset.width) * u64::from(preset.height);
            let per_frame = pixels * request.method_of(&members[0])?.samples_cost(spp);
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
