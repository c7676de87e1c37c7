//! Hard values a design may not hold (issue 31): what no renderer can render, or renders
//! only as nonsense, is refused here, naming the file, the line and the key.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use study::design::{Design, MAX_BOUNCES, MAX_FRAME_SAMPLES};

fn stimuli(name: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli").join(name)).unwrap()
}

/// The error of `text` loaded as a design file, and the file's path.
fn load_err(text: &str) -> (String, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hard.toml");
    std::fs::write(&path, text).unwrap();
    let e = Design::load(&path).expect_err("design should not load");
    (e.to_string(), path)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap_or_else(|| panic!("{needle} not in text")) + 1
}

/// `from` replaced by `to` in the shipped design `file` is refused with `file:line: key `key`:`
/// (the line of `to` that sets the key, else its first) and a message containing `needle`.
fn refused(file: &str, from: &str, to: &str, key: &str, needle: &str) {
    let text = stimuli(file);
    assert!(text.contains(from), "{from}");
    let text = text.replacen(from, to, 1);
    let (msg, path) = load_err(&text);
    let leaf = key.rsplit('.').next().unwrap();
    let line = line_of(&text, to.lines().find(|l| l.starts_with(leaf)).unwrap_or_else(|| to.lines().next().unwrap()));
    let head = format!("{}:{line}: key `{key}`: ", path.display());
    assert!(msg.starts_with(&head), "{msg}\nwanted {head}");
    assert!(msg.contains(needle), "{msg}\nwanted {needle}");
    assert!(msg.len() < 400, "{msg}");
}

fn accepted(file: &str, from: &str, to: &str) {
    let text = stimuli(file).replacen(from, to, 1);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.toml");
    std::fs::write(&path, &text).unwrap();
    Design::load(&path).unwrap_or_else(|e| panic!("{to}: {e}"));
}

#[test]
fn a_camera_below_the_floor_or_inside_the_sphere_is_refused() {
    let nav = "navarro2011.toml";
    let above = "above the floor";
    refused(nav, "height = 0.50", "height = -0.5", "camera.height", "found -0.5");
    refused(nav, "height = 0.50", "height = 0.0", "camera.height", above);
    refused(nav, "height = 0.50", "height = -1e-300", "camera.height", "found -1e-300");
    // The path passes `camera.distance` from every eye: at most the radius (0.1) is inside.
    refused(nav, "distance = 3.0", "distance = 0.05\n", "camera.distance", "inside the sphere (radius 0.1)");
    let text =
        stimuli(nav).replacen("distance = 3.0", "distance = 0.1", 1).replacen("height = 0.50", "height = 0.12", 1);
    let (msg, _) = load_err(&text);
    assert!(msg.contains("key `camera.distance`: 0.1 puts the eye inside the sphere"), "{msg}");
    // Just outside, with the eye low and close, is legal.
    let text =
        stimuli(nav).replacen("distance = 3.0", "distance = 0.15", 1).replacen("height = 0.50", "height = 0.12", 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("d.toml"), text).unwrap();
    Design::load(&dir.path().join("d.toml")).unwrap();
    accepted(nav, "height = 0.50", "height = 0.01");
}

#[test]
fn max_bounces_has_an_upper_limit() {
    let nav = "navarro2011.toml";
    let limit = format!("is above the limit of {MAX_BOUNCES}");
    for n in [u32::MAX, 1_000_000, MAX_BOUNCES + 1] {
        refused(nav, "max_bounces = 4", &format!("max_bounces = {n}"), "integrator.max_bounces", &limit);
    }
    accepted(nav, "max_bounces = 4", &format!("max_bounces = {MAX_BOUNCES}"));
}

#[test]
fn method_settings_match_what_the_renderers_accept() {
    let m = "methods.toml";
    for g in ["0.0", "1e-300", "0.0009"] {
        refused(m, "gamma = 1.5", &format!("gamma = {g}"), "factors.method[4].gamma", "must lie in [0.001, 100]");
    }
    let (msg, _) = load_err(&stimuli(m).replacen("gamma = 1.5", "gamma = 1e-300", 1));
    assert!(msg.ends_with("found 1e-300"), "{msg}");
    accepted(m, "gamma = 1.5", "gamma = 0.001");
    for t in [1, 2, 4097] {
        refused(
            m,
            "intervals = 8",
            &format!("intervals = 8\ntessellation = {t}"),
            "factors.method[5].tessellation",
            &format!("must lie in 3..=4096, found {t}"),
        );
    }
    accepted(m, "intervals = 8", "intervals = 8\ntessellation = 3");
}

#[test]
fn lighting_beyond_f32_is_refused_in_the_design_with_short_numbers() {
    let nav = "navarro2011.toml";
    let limit = "above the limit of 3.2";
    refused(nav, "intensity = 1.0", "intensity = 3e36", "lighting.intensity", "times the map's brightest radiance 160");
    refused(nav, "intensity = 1.0", "intensity = 1e300", "lighting.intensity", limit);
    let (msg, _) = load_err(&stimuli(nav).replacen("intensity = 1.0", "intensity = 1e300", 1));
    assert!(msg.contains("1e300") && !msg.contains("0000000000"), "{msg}");
    accepted(nav, "intensity = 1.0", "intensity = 1e30");
    let uniform = |r: &str| format!("environment = {{ kind = \"uniform\", radiance = [{r}, 1.0, 1.0] }}");
    let default = "environment = { kind = \"default\", width = 1024 }";
    refused(nav, default, &uniform("1e300"), "lighting.environment.radiance", "1e300 is above the limit of 3.2");
    refused(nav, default, &uniform("1e38"), "lighting.environment.radiance", limit);
    accepted(nav, default, &uniform("1e32"));
    let text = stimuli(nav).replacen(default, &uniform("1e32"), 1).replacen("intensity = 1.0", "intensity = 10.0", 1);
    let (msg, _) = load_err(&text);
    assert!(msg.contains("key `lighting.intensity`: 10 times the map's brightest radiance 1e32 is 1"), "{msg}");
}

#[test]
fn the_work_of_one_frame_is_bounded() {
    let m = "methods.toml";
    // One pixel of 4096 instants x 2^20 samples is 4096 times the tracer's 2^20 per pixel.
    refused(
        m,
        "instants = 8",
        "instants = 4096\nsamples_per_instant = 1048576",
        "factors.method[2].samples_per_instant",
        "4096 instants x 1048576 samples per instant is 4294967296 samples per pixel, above the limit of 1048576",
    );
    refused(
        m,
        "instants = 8",
        "instants = 4096\nsamples_per_instant = 256",
        "factors.method[2].samples_per_instant",
        "light paths per frame, above the limit of 6.8719476736e10 (2^36)",
    );
    refused(
        m,
        "intervals = 8",
        "intervals = 8\ntessellation = 4096",
        "factors.method[5].tessellation",
        "triangle-pixel pairs per frame",
    );
    refused(
        m,
        "intervals = 8",
        "intervals = 8\nsupersampling = 8\nlighting_samples = 65536",
        "factors.method[5].lighting_samples",
        "64 sample points x 65536 lighting samples x 460800 pixels",
    );
    // Without a method setting to blame, the samples or the image size are named.
    let text = stimuli("navarro2011.toml").replacen("samples_per_pixel = 512", "samples_per_pixel = 1048576", 1);
    let (msg, _) = load_err(&text);
    assert!(msg.contains("key `factors.samples[5].samples_per_pixel`: the `tracer` method at preset `full`"), "{msg}");
    const { assert!(MAX_FRAME_SAMPLES >= 2 * 3840 * 2160 * 4096) };
}

#[test]
fn every_shipped_design_validates() {
    for name in ["navarro2011.toml", "methods.toml", "antialiasing.toml", "media.toml"] {
        let d = Design::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli").join(name)).unwrap();
        for preset in ["full", "quick"] {
            d.preset(preset).unwrap();
        }
    }
}

/// Issue 31, defect 5's `fps = 1e-300`: frame times of 1e300 s put the sphere's centre at NaN,
/// so no method drew it; such rates are refused.
#[test]
fn a_frame_rate_whose_times_overflow_the_path_is_refused() {
    let nav = "navarro2011.toml";
    refused(nav, "fps = 30.0", "fps = 1e-300", "sequence.fps", "must lie in [1e-3, 1e5]");
    refused(nav, "fps = 30.0", "fps = 1e300", "sequence.fps", "must lie in [1e-3, 1e5]");
    accepted(nav, "fps = 30.0", "fps = 0.001");
}

/// The display model of the image-computable observer: a luminance or distance that is zero
/// or negative, or a black level at or above the peak, is refused naming file, line and key.
#[test]
fn a_display_without_light_or_distance_is_refused() {
    let nav = "navarro2011.toml";
    refused(
        nav,
        "peak_luminance = 200.0",
        "peak_luminance = 0.0",
        "viewing.peak_luminance",
        "must be a positive number",
    );
    refused(nav, "black_level = 0.2", "black_level = -0.2", "viewing.black_level", "must be a positive number");
    refused(nav, "black_level = 0.2", "black_level = 250.0", "viewing.black_level", "must lie below peak_luminance");
    refused(nav, "ambient_lux = 250.0", "ambient_lux = -1.0", "viewing.ambient_lux", "must be a finite number >= 0");
    refused(nav, "distance = 0.60", "distance = 0.0", "viewing.distance", "must be a positive number");
    accepted(nav, "ambient_lux = 250.0", "ambient_lux = 0.0");
    let d = Design::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/methods.toml")).unwrap();
    assert_eq!(d.spec.viewing.peak_luminance, study::design::spec::DEFAULT_PEAK_LUMINANCE);
}
