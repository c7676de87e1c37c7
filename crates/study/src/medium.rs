//! A participating medium in the scene (thesis Part I): where its density grids come from,
//! where the grids' box sits in the world, its optical properties, and which grid is shown
//! at which time. The renderer builds or reads the grids; this module only describes them.
//!
//! Grid `k` of a sequence belongs to frame `k` of the sequence's timeline, at time
//! `(k + frame_time_offset) / fps`; between two grids the density is interpolated linearly
//! in time, and before the first or after the last the end grid holds.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Where a medium's grids come from.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum GridSource {
    /// blurlab's smoke simulation (stable fluids with buoyancy and vorticity confinement),
    /// seeded and deterministic: one grid per frame after `warmup_frames` frames.
    Simulation {
        /// Cells along x, y (up) and z.
        resolution: [u32; 3],
        /// Seed of the source's flicker.
        seed: u64,
        /// Simulation steps per frame.
        steps_per_frame: u32,
        /// Frames simulated before the sequence's frame 0 (the plume has risen by then).
        warmup_frames: u32,
    },
    /// `blurlab-grid/1` files, one per frame: `pattern` with its run of `#` replaced by the
    /// timeline frame number, zero-padded to the run's length.
    Files {
        /// The pattern, resolved against the design file's folder.
        pattern: PathBuf,
    },
}

impl GridSource {
    /// The file of timeline frame `frame` (`None` for a simulation).
    pub fn file_of(&self, frame: u32) -> Option<PathBuf> {
        match self {
            GridSource::Simulation { .. } => None,
            GridSource::Files { pattern } => Some(frame_file(pattern, frame)),
        }
    }
}

/// `pattern` with its first run of `#` replaced by `frame`, zero-padded to the run's length
/// (`smoke/density-####.grid` -> `smoke/density-0042.grid`); a pattern without `#` names
/// the same file for every frame.
pub fn frame_file(pattern: &Path, frame: u32) -> PathBuf {
    let text = pattern.to_string_lossy();
    let Some(start) = text.find('#') else {
        return pattern.to_owned();
    };
    let run = text[start..].bytes().take_while(|&b| b == b'#').count();
    PathBuf::from(format!("{}{frame:0run$}{}", &text[..start], &text[start + run..]))
}

/// A medium as one frame of a stimulus sees it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneMedium {
    /// Where the grids come from.
    pub grids: GridSource,
    /// Centre of the grids' box in the world, metres.
    pub centre: [f64; 3],
    /// Size of the box along x, y and z, metres (the grid's cells stretch to fill it).
    pub size: [f64; 3],
    /// Extinction coefficient at density 1, per metre.
    pub extinction: f64,
    /// Single-scattering albedo in [0, 1].
    pub albedo: f64,
    /// Scattering events in the medium along one path (1: the thesis's single scattering).
    pub max_scatterings: u32,
    /// The sequence's frame rate (grids are one per frame).
    pub fps: f64,
    /// Where in its frame interval a frame's nominal time lies (the design's).
    pub frame_time_offset: f64,
    /// The timeline frames whose grids this render needs, first and last (inclusive).
    pub grid_frames: [u32; 2],
}

impl SceneMedium {
    /// Time `t` (seconds) on the grid timeline, in frames: grid `k` is at `k`.
    pub fn frame_position(&self, t: f64) -> f64 {
        t * self.fps - self.frame_time_offset
    }

    /// Whether the medium changes over time within this render (more than one grid).
    pub fn is_animated(&self) -> bool {
        self.grid_frames[0] != self.grid_frames[1]
    }

    /// The lower and upper corners of the box.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let lo = std::array::from_fn(|i| self.centre[i] - 0.5 * self.size[i]);
        let hi = std::array::from_fn(|i| self.centre[i] + 0.5 * self.size[i]);
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_files_pad_to_the_run_of_hashes() {
        let p = Path::new("smoke/density-####.grid");
        assert_eq!(frame_file(p, 42), PathBuf::from("smoke/density-0042.grid"));
        assert_eq!(frame_file(p, 123_456), PathBuf::from("smoke/density-123456.grid"));
        assert_eq!(frame_file(Path::new("a/#.grid"), 7), PathBuf::from("a/7.grid"));
        assert_eq!(frame_file(Path::new("still.grid"), 7), PathBuf::from("still.grid"));
        // only the first run is replaced
        assert_eq!(frame_file(Path::new("s##/d##.grid"), 3), PathBuf::from("s03/d##.grid"));
    }

    #[test]
    fn time_maps_to_grids_and_a_single_grid_is_still() {
        let m = SceneMedium {
            grids: GridSource::Files { pattern: "x.grid".into() },
            centre: [0.0, 1.0, 0.0],
            size: [2.0, 1.0, 4.0],
            extinction: 1.0,
            albedo: 1.0,
            max_scatterings: 1,
            fps: 30.0,
            frame_time_offset: 0.5,
            grid_frames: [3, 3],
        };
        assert_eq!(m.frame_position((4.0 + 0.5) / 30.0), 4.0);
        assert!(!m.is_animated());
        assert_eq!(m.bounds(), ([-1.0, 0.5, -2.0], [1.0, 1.5, 2.0]));
        assert!(SceneMedium { grid_frames: [3, 4], ..m }.is_animated());
    }
}
