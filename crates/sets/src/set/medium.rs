//! A set whose design has a participating medium: the device that renders it (the tracer and
//! the accumulation buffer render media only with the f64 reference tracer, so `auto` picks
//! it for them and the other devices are refused before anything is written; the marcher
//! renders on any device), and the medium's grids made once before the first frame, with
//! progress (simulating the smoke can take minutes).

use std::io::{IsTerminal, Write as _};
use std::time::Instant;

use ::render::DeviceChoice;
use indicatif::{ProgressBar, ProgressStyle};
use study::design::{Design, Preset};

use super::{ProgressMode, SetError};

/// The device `choice` becomes for `design`'s sequences `ids`.
pub(crate) fn device_for(
    design: &Design,
    ids: &[study::ids::StimulusId],
    choice: DeviceChoice,
) -> Result<DeviceChoice, SetError> {
    if design.medium.is_none() {
        return Ok(choice);
    }
    let mut methods = ids.iter().map(|id| design.method_of(id).map(|m| m.kind()));
    if methods.try_fold(true, |all, m| m.map(|m| all && m == study::Method::Marcher))? {
        return Ok(choice);
    }
    match choice {
        DeviceChoice::Auto | DeviceChoice::CpuReference => Ok(DeviceChoice::CpuReference),
        other => Err(SetError::MediumDevice { device: other.to_string() }),
    }
}

/// Makes the grids `preset`'s frames need (kept for the whole process, so every frame and
/// sequence of the render shares them).
pub(crate) fn prepare(design: &Design, preset: &Preset, mode: ProgressMode) -> Result<(), SetError> {
    let Some(ids) = design.ids(study::design::Views::Mono).first().copied() else {
        return Ok(());
    };
    let Some(medium) = design.frame_scene_with(preset, &ids, 0)?.medium else {
        return Ok(());
    };
    let started = Instant::now();
    let bar = (mode == ProgressMode::Auto && std::io::stderr().is_terminal()).then(|| {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template("medium grids {bar:30} {pos}/{len} frames, {elapsed} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let grids = ::render::volume::grids_for(&medium, &mut |done, total| {
        if let Some(bar) = &bar {
            bar.set_length(total);
            bar.set_position(done);
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if mode != ProgressMode::Quiet {
        let [x, y, z] = grids.sequence.frames()[0].dims();
        let _ = writeln!(
            std::io::stderr(),
            "medium: {} grids of {x}x{y}x{z} (timeline frames {}-{}) ready in {:.1} s",
            grids.sequence.frames().len(),
            medium.grid_frames[0],
            medium.grid_frames[1],
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
