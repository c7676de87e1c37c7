//! Sharded set rendering (`stimuli render --shard K/N`, a Slurm job array's task K) and the
//! merge that proves the shards add up to the set (`stimuli merge`).
//!
//! **Plan.** The work of a set is cut into *units*: a sequence (or, with nested sampling,
//! the sample levels of one stream), one eye of it where it is stereo, and a range of its
//! frames. A unit's cost is its estimated camera samples (pixels x samples per pixel,
//! scaled by the method's work per sample, `MethodSpec::samples_cost`) times its frames. Sequences costing more than a
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

mod join;
mod merge;
mod plan;
mod run;
#[cfg(test)]
mod tests;

pub use join::assemble;
pub use merge::{MergeReport, merge};
pub use plan::{Plan, Unit};
pub use run::{ShardReport, UnitRecord, render_shard, render_shard_with};

use std::fmt;
use std::str::FromStr;

/// Format tag of `plan.json`.
pub const PLAN_FORMAT: &str = "blurlab-plan/1";

/// Format tag of a unit record.
pub const UNIT_FORMAT: &str = "blurlab-unit/1";

/// The plan's file name in a set folder.
pub const PLAN_FILE: &str = "plan.json";

/// The folder, inside a sequence folder, of its unit records.
pub const UNITS_DIR: &str = "units";

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
