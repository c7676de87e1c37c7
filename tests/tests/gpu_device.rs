//! `--device` through the built binary: a set rendered on the GPU (lavapipe in CI) records
//! its adapter and GPU times and resumes; `--nested` writes the levels of one stream and
//! records the mode; a set refuses the other mode; `--device gpu` without an adapter is a
//! clear error and `--device auto` falls back to the CPU.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::process::{Command, Output};

use blurlab_e2e::{blurlab, repo_root, shipped_design, stderr};
use study::manifest::{Sampling, SequenceManifest, SetIndex};

/// `stimuli render` of two sample levels of one quick-preset stream, with `extra` flags.
fn render(out: &std::path::Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let d = shipped_design();
    let mut args = vec![
        "stimuli",
        "render",
        "--design",
        d.to_str().unwrap(),
        "--preset",
        "quick",
        "--only",
        "M3 S3 T5 A1,A3 mono",
        "--out",
        out.to_str().unwrap(),
        "--progress",
        "lines",
    ];
    args.extend_from_slice(extra);
    let mut cmd = Command::new(blurlab());
    cmd.args(&args).current_dir(repo_root());
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("running blurlab")
}

fn manifest(out: &std::path::Path, id: &str) -> SequenceManifest {
    SequenceManifest::read(&out.join(id).join("manifest.json")).unwrap()
}

#[test]
fn a_set_renders_on_the_gpu_records_the_adapter_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    let o = render(&out, &["--device", "gpu"], &[]);
    if !o.status.success() && stderr(&o).contains("no GPU adapter") {
        gpu::skip_or_fail("a_set_renders_on_the_gpu_records_the_adapter_and_resumes", &stderr(&o));
        return;
    }
    assert!(o.status.success(), "{}", stderr(&o));
    for id in ["M3-S3-T5-A1", "M3-S3-T5-A3"] {
        let m = manifest(&out, id);
        assert!(m.device.starts_with("gpu: "), "{}", m.device);
        let gpu = m.gpu.as_ref().expect("the adapter is recorded");
        assert!(!gpu.adapter.is_empty() && !gpu.backend.is_empty() && !gpu.driver.is_empty());
        assert_eq!(m.sampling, Sampling::Independent);
        assert_eq!(m.frames.len(), 8);
        // GPU seconds come from timestamp queries (lavapipe has them): each frame has them or none does.
        let with_gpu_time = m.frames.iter().filter(|f| f.gpu_seconds.is_some_and(|s| s > 0.0)).count();
        assert!(with_gpu_time == 0 || with_gpu_time == m.frames.len());
        assert!(m.frames.iter().all(|f| f.wall_seconds > 0.0 && f.nonfinite_samples == 0));
    }
    assert_ne!(manifest(&out, "M3-S3-T5-A1").frames[0].seeds, manifest(&out, "M3-S3-T5-A3").frames[0].seeds);
    // The same adapter renders the same bytes: a second render into another folder, with
    // frames overlapping differently on the thread pool, writes identical frames.
    let again = dir.path().join("again");
    let o = render(&again, &["--device", "gpu"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for id in ["M3-S3-T5-A1", "M3-S3-T5-A3"] {
        let hashes = |set: &std::path::Path| -> Vec<String> {
            manifest(set, id).frames.into_iter().map(|f| f.png_sha256).collect()
        };
        assert_eq!(hashes(&out), hashes(&again), "{id}");
    }
    let o = render(&out, &["--device", "gpu", "--resume"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o).matches("verified, skipped").count(), 2, "{}", stderr(&o));

    // Nested: one stream seeded as the design's top level (A5), levels as prefixes.
    let nested = dir.path().join("nested");
    let o = render(&nested, &["--device", "gpu", "--nested"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(SetIndex::read(&nested.join("index.json")).unwrap().sampling, Sampling::Nested);
    let (a1, a3) = (manifest(&nested, "M3-S3-T5-A1"), manifest(&nested, "M3-S3-T5-A3"));
    assert_eq!((a1.sampling, a3.sampling), (Sampling::Nested, Sampling::Nested));
    assert_eq!((a1.samples_per_pixel, a3.samples_per_pixel), (1, 8));
    assert_eq!(a1.frames[3].seeds, a3.frames[3].seeds, "one stream");
    // Costs are recorded as if each level were rendered alone: in proportion to its samples.
    let ratio = a1.wall_seconds() / a3.wall_seconds();
    assert!((ratio - 1.0 / 8.0).abs() < 1e-9, "{ratio}");
    // One set, one mode.
    let o = render(&nested, &["--device", "gpu"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("rendered with --nested"), "{}", stderr(&o));
}

#[test]
fn device_gpu_without_an_adapter_is_an_error_and_auto_falls_back_to_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("set");
    let no_adapter = [("WGPU_ADAPTER_NAME", "no-such-adapter-anywhere")];
    let o = render(&out, &["--device", "gpu"], &no_adapter);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("--device gpu: no GPU adapter: looked for a hardware adapter, then a software one"), "{e}");
    assert!(!out.join("M3-S3-T5-A1").exists(), "nothing rendered");
    let o = render(&out, &["--device", "auto"], &no_adapter);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(manifest(&out, "M3-S3-T5-A1").device.starts_with("cpu: "));
    assert!(manifest(&out, "M3-S3-T5-A1").gpu.is_none());
}

#[test]
fn the_gpu_benchmark_reports_rates_the_adapter_and_the_cpu_beside_it() {
    let o = blurlab_e2e::run(&[
        "bench",
        "tracer",
        "--device",
        "gpu",
        "--json",
        "--spp",
        "1",
        "--cpu-spp",
        "1",
        "--rounds",
        "1",
    ]);
    if !o.status.success() && stderr(&o).contains("no GPU adapter") {
        gpu::skip_or_fail("the_gpu_benchmark_reports_rates_the_adapter_and_the_cpu_beside_it", &stderr(&o));
        return;
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_str(&blurlab_e2e::stdout(&o)).unwrap();
    assert_eq!(r["benchmark"], "tracer-gpu");
    assert!(r["adapter"]["name"].as_str().is_some_and(|n| !n.is_empty()));
    assert_eq!((r["frame"]["width"].as_u64(), r["frame"]["height"].as_u64()), (Some(640), Some(360)));
    let moving = &r["gpu"]["moving_frame"];
    assert_eq!(moving["camera_samples"].as_u64(), Some(640 * 360));
    assert!(moving["camera_samples_per_second"].as_f64().is_some_and(|v| v > 0.0));
    // GPU time from timestamps where the adapter has them.
    assert_eq!(moving["gpu_seconds"].is_number(), r["adapter"]["timestamps"] == true);
    assert!(r["cpu"]["moving_frame"]["camera_samples_per_second"].as_f64().is_some_and(|v| v > 0.0));
    assert!(r["gpu_over_cpu"].as_f64().is_some_and(|v| v > 0.0));
    let savings = r["specialisations"].as_array().unwrap();
    assert_eq!(savings.len(), 3);
    assert!(savings.iter().all(|s| s["time_saved_fraction"].is_number()));
    let projection = &r["full_set_projection"];
    assert!(projection["minutes_nested"].as_f64().unwrap() < projection["minutes_independent"].as_f64().unwrap());
}

#[test]
fn a_successful_command_without_a_session_prints_no_error_line() {
    // Issue 24: without XDG_RUNTIME_DIR, Mesa's device-select layer made libwayland print
    // `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` twice during every
    // adapter search, though the command succeeded.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.png");
    let d = shipped_design();
    for device in ["auto", "gpu"] {
        let o = Command::new(blurlab())
            .args(["render-frame", "--design", d.to_str().unwrap(), "--preset", "quick", "--frame", "5"])
            .args(["--device", device, "--out", out.to_str().unwrap(), "M3-S3-T5-A1"])
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("NODEVICE_SELECT")
            .current_dir(repo_root())
            .output()
            .expect("running blurlab");
        if device == "gpu" && !o.status.success() && stderr(&o).contains("no GPU adapter") {
            gpu::skip_or_fail("a_successful_command_without_a_session_prints_no_error_line", &stderr(&o));
            continue;
        }
        assert!(o.status.success(), "--device {device}: {}", stderr(&o));
        let alarms: Vec<&str> =
            std::str::from_utf8(&o.stderr).unwrap().lines().filter(|l| l.contains("error")).collect();
        assert!(alarms.is_empty(), "--device {device}: {alarms:?}");
    }
}

#[test]
fn the_media_benchmark_redoes_table_2_1_on_the_gpu_beside_its_twin() {
    let o = blurlab_e2e::run(&[
        "bench",
        "media",
        "--device",
        "gpu",
        "--json",
        "--size",
        "24",
        "--lights",
        "4",
        "--sim-resolution",
        "12",
        "--sim-steps",
        "8",
        "--rounds",
        "1",
    ]);
    if !o.status.success() && stderr(&o).contains("no GPU adapter") {
        gpu::skip_or_fail("the_media_benchmark_redoes_table_2_1_on_the_gpu_beside_its_twin", &stderr(&o));
        return;
    }
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_str(&blurlab_e2e::stdout(&o)).unwrap();
    assert_eq!(r["benchmark"], "media");
    assert!(r["adapter"].as_str().is_some_and(|n| !n.is_empty()));
    assert!(r["box_coverage"].as_f64().is_some_and(|c| (0.3..0.7).contains(&c)));
    let rows = r["rows"].as_array().unwrap();
    // two data shapes x three lighting models x three accelerations
    assert_eq!(rows.len(), 18);
    for case in rows.chunks(3) {
        assert_eq!(case[0]["acceleration"], "brute force");
        assert_eq!(case[2]["acceleration"], "mask + distance");
        assert_eq!(case[0]["gpu_speedup"].as_f64(), Some(1.0));
        for row in case {
            assert!(row["gpu_ms"].as_f64().is_some_and(|v| v > 0.0), "{row}");
            assert!(row["cpu_ms"].as_f64().is_some_and(|v| v > 0.0), "{row}");
            // the accelerations change the work, never which pixels hold smoke
            assert_eq!(row["pixels_with_medium"], case[0]["pixels_with_medium"]);
        }
        let lookups = |i: usize| case[i]["density_lookups"].as_u64().unwrap();
        assert!(lookups(2) < lookups(0), "{case:?}");
    }
    assert_eq!(r["memory"]["grid_and_distance_map_bytes_128"].as_u64(), Some(8 * 128 * 128 * 128));
}

#[test]
fn the_media_benchmark_refuses_a_step_it_cannot_march() {
    let o = blurlab_e2e::run(&["bench", "media", "--device", "cpu", "--step-voxels", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--step-voxels 0: expected a length in (0, 64]"), "{}", stderr(&o));
}
