//! Producing whole stimulus sets from the renderer: `set` renders a design's sequences into
//! one folder (frames, manifests, the index, resume, verification, progress); `shard` cuts a
//! set into units for N shards (Slurm job arrays), renders a shard, and merges the shards
//! back into one verified set.

pub mod set;
pub mod shard;

pub use set::{SetError, SetReport, SetRequest, render_set};
