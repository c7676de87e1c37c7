//! The shipped design file, its error messages, and the scenes it produces.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use study::design::{Design, DesignError, Views};
use study::ids::{StimulusId, View};
use study::scene::Environment;
use study::seed::Eye;

fn shipped_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml")
}

fn shipped() -> Design {
    Design::load(&shipped_path()).unwrap_or_else(|e| panic!("{e}"))
}

fn shipped_text() -> String {
    std::fs::read_to_string(shipped_path()).unwrap()
}

/// Loads `text` as a design file in a temporary folder; returns the error message.
fn load_err(text: &str) -> (DesignError, String, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text).unwrap();
    let e = Design::load(&path).expect_err("design should not load");
    let msg = e.to_string();
    (e, msg, path)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap_or_else(|| panic!("{needle} not in text")) + 1
}

#[test]
fn shipped_design_has_225_mono_and_225_stereo_ids_that_round_trip() {
    let d = shipped();
    let mono = d.ids(Views::Mono);
    let stereo = d.ids(Views::Stereo);
    assert_eq!(mono.len(), 225);
    assert_eq!(stereo.len(), 225);
    assert!(mono.iter().all(|i| i.view == View::Mono) && stereo.iter().all(|i| i.view == View::Stereo));
    let both = d.ids(Views::Both);
    assert_eq!(both.len(), 450);
    let unique: std::collections::BTreeSet<_> = both.iter().collect();
    assert_eq!(unique.len(), 450);
    for id in &both {
        assert_eq!(&id.to_string().parse::<StimulusId>().unwrap(), id);
        d.check_id(id).unwrap();
    }
    assert!(d.check_id(&"M4-S1-T1-A1".parse().unwrap()).unwrap_err().to_string().contains("M4"));
    assert_eq!(d.name(), "navarro2011");
    let quick = d.preset("quick").unwrap();
    assert_eq!((quick.width, quick.height, quick.frames), (160, 90, 8));
    let full = d.preset("full").unwrap();
    assert_eq!((full.width, full.height, full.frames), (640, 360, 120));
    assert_eq!(full.samples_per_pixel, vec![4, 128, 256, 384, 512]);
    assert!(d.preset("huge").unwrap_err().to_string().contains("no preset `huge`"));
}

#[test]
fn unknown_key_names_file_line_and_key() {
    let text = shipped_text().replace("frames = 120\n", "frames = 120\nframerate = 30\n");
    let (_, msg, path) = load_err(&text);
    let line = line_of(&text, "framerate");
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains(&format!(":{line}:")), "{msg}");
    assert!(msg.contains("framerate"), "{msg}");
    assert!(msg.contains("sequence"), "{msg}");
}

#[test]
fn wrong_type_names_file_line_and_key() {
    let text = shipped_text().replace("fps = 30.0", "fps = \"thirty\"");
    let (e, msg, path) = load_err(&text);
    assert!(matches!(e, DesignError::Parse { .. }));
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains(&format!(":{}:", line_of(&text, "thirty"))), "{msg}");
    assert!(msg.contains("sequence.fps"), "{msg}");

    let text = shipped_text().replace("degrees_per_second = 10.0", "degrees_per_second = [10]");
    let (_, msg, _) = load_err(&text);
    assert!(msg.contains(&format!(":{}:", line_of(&text, "= [10]"))), "{msg}");
    assert!(msg.contains("degrees_per_second"), "{msg}");
}

#[test]
fn missing_key_and_bad_values_name_the_key() {
    let text = shipped_text().replace("sensor_width = 0.036\n", "");
    let (_, msg, _) = load_err(&text);
    assert!(msg.contains("sensor_width"), "{msg}");

    let text = shipped_text().replace("fraction = 0.75", "fraction = 1.75");
    let (_, msg, _) = load_err(&text);
    assert!(msg.contains(&format!(":{}:", line_of(&text, "1.75"))), "{msg}");
    assert!(msg.contains("factors.shutter[4].fraction"), "{msg}");

    let text = shipped_text().replace("squares_pole_to_pole = 8\n", "");
    let (_, msg, _) = load_err(&text);
    assert!(msg.contains("factors.material[2].squares_pole_to_pole") && msg.contains("needs"), "{msg}");
    // The missing key's line is that of the level's own `[[factors.material]]` header.
    let m2 = text.lines().enumerate().filter(|(_, l)| l.trim() == "[[factors.material]]").nth(1).unwrap().0 + 1;
    assert!(msg.contains(&format!(":{m2}:")), "{msg}");
}

#[test]
fn missing_environment_map_names_file_line_key_and_map() {
    let text = shipped_text().replace(
        "environment = { kind = \"default\", width = 1024 }",
        "environment = { kind = \"file\", path = \"env/none.exr\" }",
    );
    let (_, msg, path) = load_err(&text);
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains(&format!(":{}:", line_of(&text, "none.exr"))), "{msg}");
    assert!(msg.contains("lighting.environment.path"), "{msg}");
    assert!(msg.contains("env/none.exr") && msg.contains("does not exist"), "{msg}");
}

#[test]
fn environment_file_resolves_against_the_design_folder() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("env")).unwrap();
    std::fs::write(dir.path().join("env/map.exr"), b"not checked here").unwrap();
    let text = shipped_text().replace(
        "environment = { kind = \"default\", width = 1024 }",
        "environment = { kind = \"file\", path = \"env/map.exr\" }",
    );
    let path = dir.path().join("d.toml");
    std::fs::write(&path, text).unwrap();
    let d = Design::load(&path).unwrap();
    assert_eq!(d.lighting.environment, Environment::File { path: dir.path().join("env/map.exr") });
}

#[test]
fn camera_is_3_m_from_the_sphere_50_cm_up_with_a_50_mm_lens() {
    let d = shipped();
    let s = d.frame_scene(&"M2-S2-T3-A5".parse().unwrap(), 60).unwrap();
    let cam = &s.views[0].camera;
    let focus = d.focus_point();
    assert!(((cam.position - focus).length() - 3.0).abs() < 1e-12);
    assert!((cam.position.y - s.floor.height - 0.5).abs() < 1e-12);
    assert_eq!(cam.focal_length, 0.05);
    assert_eq!((cam.width, cam.height), (640, 360));
    assert_eq!(s.sphere.radius, 0.1);
    assert!((focus.y - s.floor.height - 0.1).abs() < 1e-12);
    // The path is parallel to the image plane, on the floor.
    assert!(s.sphere.velocity.dot(cam.forward).abs() < 1e-12 && s.sphere.velocity.y == 0.0);
    // The path passes through the focus point, which projects to the image centre.
    let t_cross = (focus - s.sphere.start).length() / s.sphere.speed();
    assert!((s.sphere.centre_at(t_cross) - focus).length() < 1e-9);
    assert!((cam.project(focus).unwrap() - DVec2::new(320.0, 180.0)).length() < 1e-6);
    assert_eq!(s.samples_per_pixel, 512);
}

#[test]
fn projected_speed_matches_degrees_per_second_times_pixels_per_degree() {
    let d = shipped();
    for preset in ["full", "quick"] {
        let p = d.preset(preset).unwrap();
        for (speed, deg) in [(1, 5.0), (2, 10.0), (3, 15.0)] {
            let id = StimulusId { material: 1, speed, shutter: 1, samples: 1, method: None, view: View::Mono };
            let s = d.frame_scene_with(&p, &id, 0).unwrap();
            let cam = &s.views[0].camera;
            let dt = 1e-4;
            let t_cross = (d.focus_point() - s.sphere.start).length() / s.sphere.speed();
            let a = cam.project(s.sphere.centre_at(t_cross - dt)).unwrap();
            let b = cam.project(s.sphere.centre_at(t_cross + dt)).unwrap();
            let px_per_s = (b - a).length() / (2.0 * dt);
            let ppd = d.pixels_per_degree(p.width);
            assert!((px_per_s - deg * ppd).abs() < 1e-3 * deg * ppd, "{preset} S{speed}: {px_per_s} vs {}", deg * ppd);
            // Left to right in the image.
            assert!(b.x > a.x);
        }
    }
    // 14.4 degrees at 60 cm: 640 px / (2 tan 7.2 deg) * pi/180 = 44.21 px/deg at the centre.
    assert!((d.pixels_per_degree(640) - 44.21).abs() < 0.01);
    assert!((d.metres_per_second(10.0) - 1.492).abs() < 1e-3);
}

#[test]
fn the_sphere_is_in_view_most_of_the_sequence_and_wraps_out_of_view() {
    let d = shipped();
    for speed in 1..=3u8 {
        let id = StimulusId { material: 1, speed, shutter: 1, samples: 1, method: None, view: View::Mono };
        let s = d.frame_scene(&id, 0).unwrap();
        let cam = &s.views[0].camera;
        let frames = 120;
        let mut visible = 0;
        for f in 0..frames {
            let t = d.frame_time(&d.preset("full").unwrap(), f);
            let c = cam.project(s.sphere.centre_at(t)).unwrap();
            if (0.0..640.0).contains(&c.x) {
                visible += 1;
            }
        }
        // Centre in the image for most of the sequence at every speed.
        assert!(visible >= 85, "S{speed}: centre in view in {visible} of 120 frames");
        // In the quick preset's frames the sphere is entirely in view.
        let quick = d.preset("quick").unwrap();
        let r_px = 0.1 * 0.05 / 3.0 / 0.036 * 640.0;
        for f in 0..quick.frames {
            let c = cam.project(s.sphere.centre_at(d.frame_time(&quick, f))).unwrap();
            assert!(c.x > r_px && c.x < 640.0 - r_px, "S{speed} quick frame {f}: {c}");
        }
        // Wrapping happens out of view: just before and after a wrap the sphere is fully off-screen.
        if let Some(l) = s.sphere.wrap_length {
            let period = l / s.sphere.speed();
            let start_px = cam.project(s.sphere.start).unwrap();
            let end_px = cam.project(s.sphere.centre_at(period - 1e-9)).unwrap();
            let r_px = 0.1 * 0.05 / 3.0 / 0.036 * 640.0;
            assert!(start_px.x < -r_px && end_px.x > 640.0 + r_px, "S{speed}: {start_px} {end_px}");
        }
    }
}

#[test]
fn shutter_is_centred_on_the_frame_time_bounded_by_the_frame_and_t1_is_instantaneous() {
    let d = shipped();
    let fps = 30.0;
    for shutter in 1..=5u8 {
        let id = StimulusId { material: 2, speed: 3, shutter, samples: 1, method: None, view: View::Mono };
        for frame in [0, 57, 119] {
            let s = d.frame_scene(&id, frame).unwrap();
            assert!((s.frame_time - (f64::from(frame) + 0.5) / fps).abs() < 1e-12);
            let mid = 0.5 * (s.shutter.open + s.shutter.close);
            assert!((mid - s.frame_time).abs() < 1e-12);
            let fraction = [0.0, 0.25, 0.5, 0.75, 1.0][usize::from(shutter - 1)];
            assert!(((s.shutter.close - s.shutter.open) - fraction / fps).abs() < 1e-12);
            assert!(s.shutter.open >= f64::from(frame) / fps - 1e-12);
            assert!(s.shutter.close <= f64::from(frame + 1) / fps + 1e-12);
            assert_eq!(s.needs_time_sampling(), shutter > 1);
            if shutter == 1 {
                assert_eq!(s.shutter.open, s.shutter.close);
            }
        }
    }
}

#[test]
fn stereo_rig_has_zero_disparity_at_focus_and_geometric_disparity_elsewhere() {
    let d = shipped();
    let s = d.frame_scene(&"M2-S2-T3-A5-stereo".parse().unwrap(), 10).unwrap();
    assert_eq!(s.views.len(), 2);
    assert_eq!((s.views[0].eye, s.views[1].eye), (Eye::Left, Eye::Right));
    assert_eq!(s.composed_width(), 1280);
    assert_ne!(s.views[0].seed, s.views[1].seed);
    let (l, r) = (&s.views[0].camera, &s.views[1].camera);
    assert!(((r.position - l.position).length() - 0.065).abs() < 1e-12);
    let centre = d.centre_camera(640, 360);
    let focus = d.focus_point();
    let disparity = |p: DVec3| l.project(p).unwrap().x - r.project(p).unwrap().x;
    assert!(disparity(focus).abs() < 1e-9);
    assert!((l.project(focus).unwrap() - DVec2::new(320.0, 180.0)).length() < 1e-9);
    // Parallel off-axis rig: disparity in pixels = f * I * (1/Z - 1/Z_focus) * W / sensor width,
    // positive (crossed: left image point right of the right one) in front of the focus point.
    let px_per_m = 640.0 / 0.036;
    for z in [2.0, 2.5, 4.0, 6.0] {
        let p = centre.position + centre.forward * z;
        let expected = 0.05 * 0.065 * (1.0 / z - 1.0 / 3.0) * px_per_m;
        assert!((disparity(p) - expected).abs() < 1e-9, "z {z}: {} vs {expected}", disparity(p));
        assert_eq!(disparity(p) > 0.0, z < 3.0);
    }
    // 1 m in front of the focus point: about 9.6 px crossed.
    assert!((disparity(centre.position + centre.forward * 2.0) - 9.630).abs() < 1e-3);
}

#[test]
fn seeds_follow_the_master_seed_and_differ_per_eye_and_frame() {
    let d = shipped();
    let id: StimulusId = "M3-S1-T5-A2-stereo".parse().unwrap();
    let a = d.frame_scene(&id, 3).unwrap();
    let b = d.frame_scene(&id, 4).unwrap();
    assert_eq!(a.views[0].seed, study::seed::frame_seed(2011, &id, Eye::Left, 3));
    assert_ne!(a.views[0].seed, b.views[0].seed);
    assert_eq!(a, d.frame_scene(&id, 3).unwrap());
    assert!(d.frame_scene(&id, 120).unwrap_err().to_string().contains("frame 120"));
}

#[test]
fn the_method_defaults_to_the_tracer_and_a_design_may_name_another() {
    assert_eq!(shipped().method(), study::Method::Tracer);
    let text = shipped_text() + "\n[method]\nkind = \"guertin\"\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.toml");
    std::fs::write(&path, &text).unwrap();
    assert_eq!(Design::load(&path).unwrap().method(), study::Method::Guertin);
    let bad = text.replace("kind = \"guertin\"", "kind = \"raytracer\"");
    let (_, shown, _) = load_err(&bad);
    assert!(shown.contains(&format!(":{}:", line_of(&bad, "kind = \"raytracer\""))), "{shown}");
    assert!(shown.contains("key `method.kind`") && shown.contains("raytracer"), "{shown}");
}

fn methods_design() -> Design {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/methods.toml");
    Design::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn methods_design_adds_a_method_factor_whose_ids_name_the_method_and_share_the_tracer_seeds() {
    let d = methods_design();
    let tags: Vec<String> = d.method_tags().iter().map(|t| t.to_string()).collect();
    assert_eq!(tags, ["tracer", "accum", "mcguire", "guertin", "analytic"]);
    let mono = d.ids(Views::Mono);
    assert_eq!(mono.len(), 225 * 5);
    assert_eq!(mono[0].to_string(), "M1-S1-T1-A1-tracer");
    assert_eq!(mono[3].to_string(), "M1-S1-T1-A1-guertin");
    for id in &mono {
        assert_eq!(id.to_string().parse::<StimulusId>().unwrap(), *id);
    }
    let id: StimulusId = "M3-S3-T5-A1-guertin".parse().unwrap();
    let spec = d.method_of(&id).unwrap();
    let study::method::MethodSpec::Guertin(g) = spec else { panic!("{spec:?} is not guertin") };
    assert_eq!((g.taps, g.tile, g.phi), (Some(35), Some(40), Some(27.0)));
    assert_eq!(d.factors(&id, &d.preset("full").unwrap()).unwrap().method.unwrap().label, "guertin");
    // The tracer level renders navarro2011's frames: the same scene and seeds.
    let navarro = shipped();
    let plain: StimulusId = "M3-S3-T5-A1".parse().unwrap();
    let quick = d.preset("quick").unwrap();
    let a = d.frame_scene_with(&quick, &"M3-S3-T5-A1-tracer".parse().unwrap(), 3).unwrap();
    let b = navarro.frame_scene_with(&navarro.preset("quick").unwrap(), &plain, 3).unwrap();
    assert_eq!(a.views, b.views);
    assert_eq!((a.shutter, a.samples_per_pixel), (b.shutter, b.samples_per_pixel));
    // Ids must say their method in this design, and only here.
    assert!(
        d.check_id(&plain)
            .unwrap_err()
            .to_string()
            .contains("name a level after A (tracer, accum, mcguire, guertin, analytic)")
    );
    let e = navarro.check_id(&id).unwrap_err().to_string();
    assert!(e.contains("has no rendering-method factor"), "{e}");
    let e = d.check_id(&"M3-S3-T5-A1-guertin2".parse().unwrap()).unwrap_err().to_string();
    assert!(e.contains("no method level `guertin2`"), "{e}");
}

#[test]
fn method_settings_must_belong_to_their_method_and_lie_in_range() {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/methods.toml")).unwrap();
    let (_, msg, path) = load_err(&text.replace("instants = 8", "instants = 8\ntaps = 3"));
    let line = line_of(&text.replace("instants = 8", "instants = 8\ntaps = 3"), "taps = 3");
    assert_eq!(
        msg,
        format!(
            "{}:{line}: key `factors.method[2].taps`: applies to mcguire and guertin only, not to `accum`",
            path.display()
        )
    );
    let (_, msg, _) = load_err(&text.replace("eta = 0.95", "eta = 1.5"));
    assert!(msg.contains("key `factors.method[4].eta`: must lie in [0, 1], found 1.5"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("taps = 35", "taps = 35\nintervals = 8"));
    assert!(msg.contains("key `factors.method[4].intervals`: applies to analytic only, not to `guertin`"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("taps = 35", "taps = 35\nsupersampling = 2"));
    assert!(msg.contains("key `factors.method[4].supersampling`: applies to analytic only"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("intervals = 8", "intervals = 8\nsupersampling = 9"));
    assert!(msg.contains("key `factors.method[5].supersampling`: must lie in 1..=8, found 9"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("taps = 35", "taps = 0"));
    assert!(msg.contains("key `factors.method[4].taps`: must lie in 1..=1024, found 0"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("kind = \"guertin\"", "kind = \"blur\""));
    assert!(msg.contains("unknown variant `blur`"), "{msg}");
    let (_, msg, _) = load_err(&format!("{text}\n[method]\nkind = \"accum\"\n"));
    assert!(msg.contains("key `method`: a design with `[[factors.method]]` levels"), "{msg}");
    let (_, msg, _) = load_err(&format!("{}\n[method]\nkind = \"tracer\"\ntau = 2.0\n", shipped_text()));
    assert!(msg.contains("key `method.tau`: applies to guertin only, not to `tracer`"), "{msg}");
    // Antialiasing of the display frame: any method's level, its settings checked.
    let (_, msg, _) = load_err(&text.replace("taps = 35", "taps = 35\nantialias = \"mlaa\"\nmlaa_threshold = 1.5"));
    assert!(msg.contains("key `factors.method[4].mlaa_threshold`: must lie in (0, 1], found 1.5"), "{msg}");
    let (_, msg, _) = load_err(&text.replace("intervals = 8", "intervals = 8\nmlaa_search_distance = 8"));
    assert!(
        msg.contains("key `factors.method[5].mlaa_search_distance`: applies only with antialias = \"mlaa\""),
        "{msg}"
    );
    let (_, msg, _) =
        load_err(&format!("{}\n[method]\nantialias = \"mlaa\"\nmlaa_search_distance = 65\n", shipped_text()));
    assert!(msg.contains("key `method.mlaa_search_distance`: must lie in 1..=64, found 65"), "{msg}");
    let (_, msg, _) = load_err(&format!("{}\n[method]\nantialias = \"fxaa\"\n", shipped_text()));
    assert!(msg.contains("unknown variant `fxaa`, expected `none` or `mlaa`"), "{msg}");
    let bad_edges = format!("{}\n[method]\nantialias = \"mlaa\"\nmlaa_edges = \"normals\"\n", shipped_text());
    let (_, msg, _) = load_err(&bad_edges);
    assert!(msg.contains("unknown variant `normals`, expected `luminance` or `depth`"), "{msg}");
    assert!(msg.contains(&format!(":{}", line_of(&bad_edges, "mlaa_edges"))), "{msg}");
    let (_, msg, _) = load_err(&format!("{}\n[method]\nmlaa_edges = \"depth\"\n", shipped_text()));
    assert!(msg.contains("key `method.mlaa_edges`: applies only with antialias = \"mlaa\""), "{msg}");
}

#[test]
fn two_levels_with_one_name_or_one_value_are_an_error_naming_both() {
    let text = shipped_text().replace("name = \"checker\"", "name = \"flat\"");
    let (_, msg, _) = load_err(&text);
    assert!(
        msg.contains("factors.material[2].name") && msg.contains("has the name `flat` of factors.material[1]"),
        "{msg}"
    );
    let text = shipped_text().replace("degrees_per_second = 15.0", "degrees_per_second = 5.0");
    let (_, msg, _) = load_err(&text);
    assert!(
        msg.contains("factors.speed[3].name")
            && msg.contains("level 3 `fast` is the same level as factors.speed[1] (`slow`)"),
        "{msg}"
    );
}

#[test]
fn sizes_beyond_the_limits_are_errors_naming_key_and_limit() {
    for (from, to, needle) in [
        ("width = 640", "width = 4000000000", "key `sequence.width`: 4000000000 pixels is above the limit of 16384"),
        (
            "width = 640\nheight = 360",
            "width = 16000\nheight = 16000",
            "key `sequence.height`: 16000x16000 is 256000000 pixels",
        ),
        ("frames = 120\n", "frames = 4000000000\n", "key `sequence.frames`: 4000000000 is above the limit of 100000"),
        ("octaves = ", "octaves = 4000000000 #", "octaves`: 4000000000 is above the limit of 32"),
        (
            "samples_per_pixel = 512",
            "samples_per_pixel = 4000000000",
            "samples_per_pixel`: 4000000000 is above the limit of 1048576",
        ),
        ("width = 1024 }", "width = 4000000000 }", "must be an even number from 4 to 8192, found 4000000000"),
        // Found by the fuzz test: the message's end frame overflowed u32.
        ("first_frame = 17", "first_frame = 4294967295", "frames 4294967295..4294967303 lie beyond"),
    ] {
        let text = shipped_text().replacen(from, to, 1);
        assert_ne!(text, shipped_text(), "{from}");
        let (_, msg, _) = load_err(&text);
        assert!(msg.contains(needle), "{msg}");
    }
}

#[test]
fn a_preset_gives_each_ids_samples_and_a_scene_its_instants() {
    let d = shipped();
    let quick = d.preset("quick").unwrap();
    for a in 1..=5u8 {
        let id: StimulusId = format!("M3-S3-T5-A{a}").parse().unwrap();
        assert_eq!(quick.samples_of(&id), Some(quick.samples_per_pixel[usize::from(a - 1)]));
        assert_eq!(d.frame_scene_with(&quick, &id, 2).unwrap().samples_per_pixel, quick.samples_of(&id).unwrap());
    }
    let mut short = quick.clone();
    short.samples_per_pixel.truncate(2);
    let id: StimulusId = "M3-S3-T5-A3".parse().unwrap();
    assert_eq!(short.samples_of(&id), None);
    let e = d.frame_scene_with(&short, &id, 2).unwrap_err().to_string();
    assert!(e.contains("has 2 sample levels"), "{e}");
    let scene = d.frame_scene_with(&quick, &id, 2).unwrap();
    let t = scene.shutter.centre();
    let instant = scene.at_instant(t);
    assert_eq!((instant.shutter.open, instant.shutter.close), (t, t));
    assert!(!instant.needs_time_sampling() && scene.needs_time_sampling());
    assert_eq!(instant.views, scene.views);
}
