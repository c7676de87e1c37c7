//! The `[medium]` table checked and resolved into a [`SceneMedium`]: each source kind's
//! required and forbidden keys, ranges (every error names the key and its line), the files'
//! pattern resolved against the design's folder with every frame's file present, and the
//! grids a preset's frames need; and the warnings of a medium that loads but cannot show.

use std::path::Path;

use glam::{DVec2, DVec3};

use super::{Design, DesignError, MediumSourceKind, Preset};
use crate::medium::{GridSource, SceneMedium};
use crate::method::num;
use crate::toml_locate::key_line;

/// The most cells along one side of a simulated grid.
pub const MAX_SIMULATION_SIDE: u32 = 512;
/// The most cells of a simulated grid (the solver keeps about ten fields of this size).
pub const MAX_SIMULATION_CELLS: u64 = 1 << 24;
/// The largest extinction coefficient, per metre (a millimetre of it is already opaque).
pub const MAX_EXTINCTION: f64 = 1e6;
/// The most scattering events of a path in the medium.
pub const MAX_SCATTERINGS: u32 = 256;
/// The most simulation steps per frame.
pub const MAX_STEPS_PER_FRAME: u32 = 64;
/// The most warm-up frames of a simulation.
pub const MAX_WARMUP_FRAMES: u32 = 100_000;

impl Design {
    /// The design's medium over the whole sequence, or `None` without a `[medium]` table.
    pub(super) fn resolve_medium(&self) -> Result<Option<SceneMedium>, DesignError> {
        let Some(m) = &self.spec.medium else {
            return Ok(None);
        };
        let table = "medium";
        let bad = |key: &str, message: String| Err(self.invalid(table, None, key, message));
        if !m.centre.iter().all(|c| c.is_finite()) {
            return bad("centre", format!("must be finite, found {:?}", m.centre));
        }
        if !m.size.iter().all(|s| s.is_finite() && *s > 0.0 && *s <= 1e4) {
            return bad("size", format!("each side must be a positive number of metres up to 1e4, found {:?}", m.size));
        }
        if !(m.extinction.is_finite() && (0.0..=MAX_EXTINCTION).contains(&m.extinction)) {
            return bad(
                "extinction",
                format!("must lie in [0, {}] per metre, found {}", num(MAX_EXTINCTION), num(m.extinction)),
            );
        }
        if !(m.albedo.is_finite() && (0.0..=1.0).contains(&m.albedo)) {
            return bad("albedo", format!("must lie in [0, 1], found {}", num(m.albedo)));
        }
        if !(1..=MAX_SCATTERINGS).contains(&m.max_scatterings) {
            return bad("max_scatterings", format!("must lie in 1..={MAX_SCATTERINGS}, found {}", m.max_scatterings));
        }
        let frames = self.spec.sequence.frames;
        let grids = match m.source {
            MediumSourceKind::Simulation => {
                if m.path.is_some() {
                    return bad("path", "not used by source `simulation`".to_owned());
                }
                let sim = m.simulation.as_ref().ok_or_else(|| {
                    self.invalid(table, None, "simulation", "source `simulation` needs a [medium.simulation] table")
                })?;
                let t = "medium.simulation";
                let r = sim.resolution;
                if r.iter().any(|&n| !(2..=MAX_SIMULATION_SIDE).contains(&n)) {
                    return Err(self.invalid(
                        t,
                        None,
                        "resolution",
                        format!("each side must lie in 2..={MAX_SIMULATION_SIDE} cells, found {r:?}"),
                    ));
                }
                let cells = r.iter().map(|&n| u64::from(n)).product::<u64>();
                if cells > MAX_SIMULATION_CELLS {
                    return Err(self.invalid(
                        t,
                        None,
                        "resolution",
                        format!("{cells} cells is above the limit of {MAX_SIMULATION_CELLS} (256^3)"),
                    ));
                }
                if !(1..=MAX_STEPS_PER_FRAME).contains(&sim.steps_per_frame) {
                    return Err(self.invalid(
                        t,
                        None,
                        "steps_per_frame",
                        format!("must lie in 1..={MAX_STEPS_PER_FRAME}, found {}", sim.steps_per_frame),
                    ));
                }
                if sim.warmup_frames > MAX_WARMUP_FRAMES {
                    return Err(self.invalid(
                        t,
                        None,
                        "warmup_frames",
                        format!("must be at most {MAX_WARMUP_FRAMES}, found {}", sim.warmup_frames),
                    ));
                }
                GridSource::Simulation {
                    resolution: r,
                    seed: sim.seed.unwrap_or(self.spec.master_seed),
                    steps_per_frame: sim.steps_per_frame,
                    warmup_frames: sim.warmup_frames,
                }
            }
            MediumSourceKind::Files => {
                if m.simulation.is_some() {
                    return bad("simulation", "not used by source `files`".to_owned());
                }
                let rel = m
                    .path
                    .as_ref()
                    .ok_or_else(|| self.invalid(table, None, "path", "source `files` needs this key"))?;
                if !rel.contains('#') {
                    return bad(
                        "path",
                        format!(
                            "`{rel}` has no run of `#` for the frame number (e.g. `smoke/density-####.grid`; \
                             one file per frame)"
                        ),
                    );
                }
                let pattern = self.path.parent().unwrap_or(Path::new("")).join(rel);
                let grids = GridSource::Files { pattern };
                if let Some(missing) = (0..frames).filter_map(|f| grids.file_of(f)).find(|p| !p.is_file()) {
                    return bad(
                        "path",
                        format!(
                            "grid file `{}` does not exist ({frames} frames need one file each, numbered from 0; \
                             paths are relative to the design file's folder)",
                            missing.display()
                        ),
                    );
                }
                grids
            }
        };
        Ok(Some(SceneMedium {
            grids,
            centre: m.centre,
            size: m.size,
            extinction: m.extinction,
            albedo: m.albedo,
            max_scatterings: m.max_scatterings,
            fps: self.spec.sequence.fps,
            frame_time_offset: self.spec.sequence.frame_time_offset,
            grid_frames: [0, frames - 1],
        }))
    }

    /// The medium as `preset`'s frames see it: only the grids its shutters can reach (one
    /// frame either side of the rendered ones, within the sequence).
    pub(super) fn medium_for(&self, preset: &Preset) -> Option<SceneMedium> {
        let last = self.spec.sequence.frames - 1;
        self.medium.as_ref().map(|m| SceneMedium {
            grid_frames: [
                preset.first_frame.saturating_sub(1).min(last),
                preset.first_frame.saturating_add(preset.frames).min(last),
            ],
            ..m.clone()
        })
    }
}

impl Design {
    /// What loads but may not show what the design's author meant, one message per problem
    /// naming the file, line and key: a medium whose box no eye can see (outside the centre
    /// camera's view, behind it, or under the floor), or one of extinction 0.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let Some(m) = &self.medium else {
            return out;
        };
        let at = |key: &str| {
            let line = key_line(&self.text, "medium", None, key).map_or("?".to_owned(), |l| l.to_string());
            format!("{}:{line}: key `medium.{key}`", self.path.display())
        };
        if m.extinction == 0.0 {
            out.push(format!("{}: 0 makes the medium invisible", at("extinction")));
        }
        let (lo, hi) = m.bounds();
        let corners: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { lo[0] } else { hi[0] },
                    if i & 2 == 0 { lo[1] } else { hi[1] },
                    if i & 4 == 0 { lo[2] } else { hi[2] },
                )
            })
            .collect();
        let s = &self.spec.sequence;
        let camera = self.centre_camera(s.width, s.height);
        if !box_may_be_seen(&camera, &corners) {
            out.push(format!(
                "{}: the medium's box {lo:?}-{hi:?} (m) lies outside the centre camera's view: only its shadow \
                 can show",
                at("centre")
            ));
        } else if hi[1] <= self.spec.floor.height {
            out.push(format!(
                "{}: the medium's box lies under the floor (its top at y = {} m, the floor at {} m): nothing \
                 of it can show",
                at("centre"),
                num(hi[1]),
                num(self.spec.floor.height)
            ));
        }
        out
    }
}

/// Whether some of a box (its 8 corners) may lie inside the camera's view: false when all
/// corners lie outside one of the view's planes (behind the camera, or beyond one side of
/// the image). Conservative: a box near a corner of the view may be reported as seen.
fn box_may_be_seen(camera: &crate::scene::Camera, corners: &[DVec3]) -> bool {
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let edges = [DVec2::new(0.0, 0.0), DVec2::new(w, 0.0), DVec2::new(w, h), DVec2::new(0.0, h)]
        .map(|p| camera.ray_direction(p));
    let mut normals: Vec<DVec3> = (0..4)
        .map(|i| {
            let n = edges[i].cross(edges[(i + 1) % 4]);
            if n.dot(camera.forward) < 0.0 { -n } else { n }
        })
        .collect();
    normals.push(camera.forward);
    normals.iter().all(|n| corners.iter().any(|c| (*c - camera.position).dot(*n) >= 0.0))
}
