//! A medium's grids for the frames a render needs, made once per process and shared by every
//! frame and stimulus of the render: a set of 24 stimuli over one plume simulates it once.
//!
//! The simulation runs from its start through the warm-up and the frames before the first
//! one needed, keeping only the needed grids (memory: one grid per needed frame). Files are
//! read one per frame and refused, naming the file and the byte, when malformed or when their
//! sizes differ.

use std::sync::{Arc, Mutex};

use media::grid_file::{self, GridFileError};
use media::shutter::GridSequence;
use media::smoke::{SettingError, SmokeSettings, SmokeSimulation};
use media::{DensityGrid, GridError};
use study::medium::{GridSource, SceneMedium};

/// Why a medium's grids could not be made.
#[derive(Debug, Clone, thiserror::Error)]
pub enum VolumeError {
    /// The simulation refused its settings.
    #[error("medium: smoke simulation: {0}")]
    Simulation(String),
    /// A grid file is missing or malformed.
    #[error("medium: {0}")]
    File(String),
    /// The grids do not form one sequence (sizes differ).
    #[error("medium: {0}")]
    Sequence(String),
}

impl From<SettingError> for VolumeError {
    fn from(e: SettingError) -> Self {
        VolumeError::Simulation(e.to_string())
    }
}

impl From<GridFileError> for VolumeError {
    fn from(e: GridFileError) -> Self {
        VolumeError::File(e.to_string())
    }
}

/// The grids of timeline frames `first..=last`.
#[derive(Debug)]
pub struct MediumGrids {
    /// Timeline frame of the sequence's first grid.
    pub first_frame: u32,
    /// The grids, one per frame.
    pub sequence: GridSequence,
}

impl MediumGrids {
    /// Position of time `t` (seconds) within [`Self::sequence`], in frames.
    pub fn position(&self, medium: &SceneMedium, t: f64) -> f64 {
        medium.frame_position(t) - f64::from(self.first_frame)
    }
}

type Key = (GridSource, [u32; 2]);

/// The last medium made: a render uses one medium throughout.
static LAST: Mutex<Option<(Key, Arc<MediumGrids>)>> = Mutex::new(None);

/// The grids `medium` needs, made on first use and kept for the next call with the same
/// source and frames. `progress(done, total)` is told as grids are made (not when cached).
pub fn grids_for(medium: &SceneMedium, progress: &mut dyn FnMut(u64, u64)) -> Result<Arc<MediumGrids>, VolumeError> {
    let key = (medium.grids.clone(), medium.grid_frames);
    // Held while making the grids: a second caller waits for them instead of making its own.
    let mut last = LAST.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((k, grids)) = last.as_ref()
        && *k == key
    {
        return Ok(grids.clone());
    }
    let made = Arc::new(make(medium, progress)?);
    *last = Some((key, made.clone()));
    Ok(made)
}

fn make(medium: &SceneMedium, progress: &mut dyn FnMut(u64, u64)) -> Result<MediumGrids, VolumeError> {
    let [first, last] = medium.grid_frames;
    let frames: Vec<DensityGrid> = match &medium.grids {
        GridSource::Simulation { resolution, seed, steps_per_frame, warmup_frames } => {
            let settings = SmokeSettings {
                resolution: resolution.map(|n| n as usize),
                seed: *seed,
                steps_per_frame: *steps_per_frame,
                ..SmokeSettings::default()
            };
            let mut sim = SmokeSimulation::new(settings)?;
            let skipped = u64::from(*warmup_frames) + u64::from(first);
            let total = skipped + u64::from(last - first) + 1;
            for done in 0..skipped {
                for _ in 0..*steps_per_frame {
                    sim.step();
                }
                progress(done + 1, total);
            }
            (first..=last)
                .enumerate()
                .map(|(i, _)| {
                    let grid = sim.next_frame();
                    progress(skipped + i as u64 + 1, total);
                    grid
                })
                .collect()
        }
        GridSource::Files { .. } => {
            let total = u64::from(last - first) + 1;
            (first..=last)
                .enumerate()
                .map(|(i, f)| {
                    let path = medium.grids.file_of(f).expect("a files source names a file per frame");
                    let grid = grid_file::read(&path)?;
                    progress(i as u64 + 1, total);
                    Ok(grid)
                })
                .collect::<Result<_, VolumeError>>()?
        }
    };
    let sequence = GridSequence::new(frames).map_err(|e| match (&medium.grids, e) {
        (GridSource::Files { pattern }, GridError::Mismatch { a, b }) => VolumeError::Sequence(format!(
            "the grid files `{}` differ in size ({a:?} and {b:?}); a sequence has one size",
            pattern.display()
        )),
        (_, e) => VolumeError::Sequence(e.to_string()),
    })?;
    Ok(MediumGrids { first_frame: first, sequence })
}
