//! The `[medium]` table: the shipped smoke design, the grids a preset needs, when time is
//! sampled, and errors that name the key and its line.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use study::design::Design;
use study::medium::GridSource;

fn media_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/media.toml")
}

fn media_text() -> String {
    std::fs::read_to_string(media_path()).unwrap()
}

/// Loads `text` as `bad.toml` in `dir` (with whatever else the test put there).
fn load_in(dir: &Path, text: &str) -> Result<Design, String> {
    let path = dir.join("bad.toml");
    std::fs::write(&path, text).unwrap();
    Design::load(&path).map_err(|e| e.to_string())
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap_or_else(|| panic!("{needle} not in text")) + 1
}

#[test]
fn the_shipped_smoke_design_places_a_simulated_plume_on_the_floor() {
    let d = Design::load(&media_path()).unwrap();
    let m = d.medium.as_ref().unwrap();
    assert_eq!(
        m.grids,
        GridSource::Simulation { resolution: [40, 64, 40], seed: 2027, steps_per_frame: 1, warmup_frames: 40 }
    );
    let (lo, hi) = m.bounds();
    assert_eq!(lo[1], 0.0, "the box stands on the floor");
    assert!(lo[0] < 0.0 && hi[0] > 0.0 && lo[2] < 0.0 && hi[2] > 0.0, "around the image centre");
    assert_eq!((m.extinction, m.albedo, m.max_scatterings), (25.0, 0.9, 1));
    // The quick preset renders frames 20..=27: its shutters reach grids 19..=28.
    let quick = d.preset("quick").unwrap();
    let id = "M1-S2-T3-A2-tracer".parse().unwrap();
    let scene = d.frame_scene_with(&quick, &id, 0).unwrap();
    assert_eq!(scene.medium.as_ref().unwrap().grid_frames, [19, 28]);
    // The full preset: the whole sequence.
    assert_eq!(d.frame_scene(&id, 0).unwrap().medium.unwrap().grid_frames, [0, 59]);
    // A changing medium is sampled in time with the shutter open, even around a sphere at
    // rest; with the shutter closed it is not.
    let text = media_text().replace("degrees_per_second = 10.0", "degrees_per_second = 0.0");
    let dir = tempfile::tempdir().unwrap();
    let still = load_in(dir.path(), &text).unwrap();
    let open = still.frame_scene_with(&quick, &"M1-S1-T3-A1-tracer".parse().unwrap(), 0).unwrap();
    assert!(open.sphere.speed() == 0.0 && open.needs_time_sampling());
    let closed = still.frame_scene_with(&quick, &"M1-S1-T1-A1-tracer".parse().unwrap(), 0).unwrap();
    assert!(!closed.needs_time_sampling());
}

#[test]
fn a_design_without_a_medium_has_none_in_its_scenes() {
    let nav = Design::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml")).unwrap();
    assert!(nav.medium.is_none());
    let scene = nav.frame_scene(&"M2-S2-T3-A5".parse().unwrap(), 3).unwrap();
    assert!(scene.medium.is_none());
    // and the scene's JSON has no medium key, as before media existed
    assert!(!serde_json::to_string(&scene).unwrap().contains("medium"));
}

#[test]
fn grid_files_resolve_against_the_design_folder_and_every_frame_needs_one() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("smoke")).unwrap();
    for f in 0..59 {
        std::fs::write(dir.path().join(format!("smoke/d-{f:03}.grid")), b"").unwrap();
    }
    let text = media_text()
        .replace("source = \"simulation\"", "source = \"files\"\npath = \"smoke/d-###.grid\"")
        .replace("[medium.simulation]\nresolution = [40, 64, 40]\nsteps_per_frame = 1\nwarmup_frames = 40\n", "");
    let msg = load_in(dir.path(), &text).unwrap_err();
    let line = line_of(&text, "path = \"smoke");
    assert!(msg.contains(&format!("bad.toml:{line}: key `medium.path`")), "{msg}");
    assert!(msg.contains("d-059.grid` does not exist") && msg.contains("60 frames"), "{msg}");
    std::fs::write(dir.path().join("smoke/d-059.grid"), b"").unwrap();
    let d = load_in(dir.path(), &text).unwrap();
    assert_eq!(d.medium.unwrap().grids.file_of(7).unwrap(), dir.path().join("smoke/d-007.grid"));
    // a pattern without a frame number is refused
    let msg = load_in(dir.path(), &text.replace("d-###.grid", "d-007.grid")).unwrap_err();
    assert!(msg.contains("key `medium.path`") && msg.contains("no run of `#`"), "{msg}");
}

#[test]
fn medium_values_out_of_range_name_the_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = media_text();
    let cases = [
        ("albedo = 0.9", "albedo = 1.5", "medium.albedo", "must lie in [0, 1], found 1.5"),
        ("extinction = 25.0", "extinction = -1.0", "medium.extinction", "must lie in [0, 1000000]"),
        ("size = [0.6, 0.96, 0.6]", "size = [0.6, 0.0, 0.6]", "medium.size", "positive number of metres"),
        ("max_scatterings = 1", "max_scatterings = 0", "medium.max_scatterings", "must lie in 1..=256"),
        ("resolution = [40, 64, 40]", "resolution = [40, 1, 40]", "medium.simulation.resolution", "2..=512"),
        ("resolution = [40, 64, 40]", "resolution = [512, 512, 512]", "medium.simulation.resolution", "256^3"),
        ("steps_per_frame = 1", "steps_per_frame = 0", "medium.simulation.steps_per_frame", "1..=64"),
        ("source = \"simulation\"", "source = \"simulation\"\npath = \"x-#.grid\"", "medium.path", "not used"),
    ];
    for (from, to, key, needle) in cases {
        let bad = text.replacen(from, to, 1);
        let msg = load_in(dir.path(), &bad).unwrap_err();
        let line = line_of(&bad, to.lines().last().unwrap());
        assert!(
            msg.contains(&format!("bad.toml:{line}: key `{key}`")) && msg.contains(needle),
            "{from} -> {to}: {msg}"
        );
    }
    // a simulation without its table, an unknown source, an unknown key
    let msg = load_in(
        dir.path(),
        &text.replace("[medium.simulation]\nresolution = [40, 64, 40]\nsteps_per_frame = 1\nwarmup_frames = 40\n", ""),
    )
    .unwrap_err();
    assert!(msg.contains("key `medium.simulation`") && msg.contains("needs a [medium.simulation] table"), "{msg}");
    let msg = load_in(dir.path(), &text.replace("source = \"simulation\"", "source = \"vdb\"")).unwrap_err();
    assert!(msg.contains(&format!("bad.toml:{}:", line_of(&text, "source = \"simulation\""))), "{msg}");
    assert!(msg.contains("simulation") && msg.contains("files"), "{msg}");
    let msg = load_in(dir.path(), &text.replace("albedo = 0.9", "albedo = 0.9\ndensity = 2.0")).unwrap_err();
    assert!(msg.contains("density"), "{msg}");
}

#[test]
fn a_medium_no_camera_can_see_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let text = media_text();
    assert!(Design::load(&media_path()).unwrap().warnings().is_empty());
    let line = line_of(&text, "centre = [0.0, 0.48, 0.0]");
    // far to the side of the view, behind the camera, under the floor
    for (centre, needle) in [
        ("centre = [30.0, 0.48, 0.0]", "outside the centre camera's view"),
        ("centre = [0.0, 0.48, 30.0]", "outside the centre camera's view"),
        ("centre = [0.0, -0.6, 0.0]", "under the floor"),
    ] {
        let d = load_in(dir.path(), &text.replace("centre = [0.0, 0.48, 0.0]", centre)).unwrap();
        let w = d.warnings();
        assert_eq!(w.len(), 1, "{centre}: {w:?}");
        assert!(w[0].contains(&format!("bad.toml:{line}: key `medium.centre`")) && w[0].contains(needle), "{w:?}");
    }
    // a box that covers the whole view (corners all outside the image) is seen
    let d = load_in(dir.path(), &text.replace("size = [0.6, 0.96, 0.6]", "size = [40.0, 20.0, 40.0]")).unwrap();
    assert!(d.warnings().is_empty(), "{:?}", d.warnings());
    let d = load_in(dir.path(), &text.replace("extinction = 25.0", "extinction = 0.0")).unwrap();
    assert!(d.warnings()[0].contains("key `medium.extinction`: 0 makes the medium invisible"), "{:?}", d.warnings());
}
