//! Tests of sharded rendering: plans, units, records, joins and merges.

use study::fsio::write_atomic;

use render::DeviceChoice;
use std::path::{Path, PathBuf};

use study::design::Design;
use study::fsio::sha256_hex;
use study::manifest::{Sampling, SequenceManifest};
use study::{Eye, Method};

use crate::set::{ProgressMode, SetRequest};

use super::merge::merge;
use super::plan::{Plan, Unit};
use super::run::render_shard;
use super::{PLAN_FILE, ShardSpec};

/// The shipped design with a preset `tiny` (8x4, 5 frames): a merge takes presets by name.
fn design() -> Design {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let text = std::fs::read_to_string(&shipped).unwrap();
    let dir = std::env::temp_dir().join(format!(
        "blurlab-shard-tests-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("tiny.toml");
    let tiny = "[presets.tiny]\nwidth = 8\nheight = 4\nframes = 5\nsamples_per_pixel = [1, 4, 8, 12, 16]\n";
    write_atomic(&path, format!("{text}\n{tiny}").as_bytes()).unwrap();
    let design = Design::load(&path).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    design
}

fn request<'a>(design: &'a Design, out: &Path, only: &[&str]) -> SetRequest<'a> {
    SetRequest {
        design,
        preset: design.preset("tiny").unwrap(),
        ids: only.iter().map(|s| s.parse().unwrap()).collect(),
        out: out.to_owned(),
        resume: false,
        exr: false,
        progress: ProgressMode::Quiet,
        device: DeviceChoice::Cpu,
        sampling: Sampling::Independent,
    }
}

#[test]
fn shard_specs_count_from_zero_and_bad_ones_say_what_is_expected() {
    assert_eq!("0/4".parse::<ShardSpec>(), Ok(ShardSpec { index: 0, count: 4 }));
    assert_eq!(" 3 / 4 ".parse::<ShardSpec>(), Ok(ShardSpec { index: 3, count: 4 }));
    let err = |t: &str| t.parse::<ShardSpec>().unwrap_err();
    assert!(err("4/4").contains("K = 4 is not below N = 4") && err("4/4").contains("0 to 3"), "{}", err("4/4"));
    assert!(err("0/0").contains("N = 0"), "{}", err("0/0"));
    assert!(err("3").contains("expected K/N"), "{}", err("3"));
    assert!(err("a/2").contains("K `a` is not a whole number"), "{}", err("a/2"));
    assert!(err("-1/2").contains("not a whole number"), "{}", err("-1/2"));
}

#[test]
fn the_plan_covers_every_frame_once_and_balances_the_cost() {
    let d = design();
    let ids = ["M1-S1-T1-A5", "M1-S1-T1-A1", "M2-S2-T3-A3-stereo", "M3-S1-T2-A2", "M1-S3-T5-A4-stereo"];
    let req = request(&d, Path::new("unused"), &ids);
    for n in [1u32, 2, 3, 4, 7] {
        let plan = Plan::compute(&req, n).unwrap();
        assert_eq!(plan, Plan::compute(&req, n).unwrap(), "deterministic");
        for id in &req.ids {
            // Every frame of every eye once: a stereo sequence's units are per eye.
            let eyes: Vec<Option<Eye>> = match Eye::of_view(id.view) {
                [_] => vec![None],
                eyes => eyes.iter().copied().map(Some).collect(),
            };
            for eye in eyes {
                let mut frames: Vec<u32> =
                    plan.units.iter().filter(|u| u.ids == [*id] && u.eye == eye).flat_map(|u| u.frames()).collect();
                frames.sort_unstable();
                assert_eq!(frames, (0..5).collect::<Vec<_>>(), "{id} {eye:?} with N = {n}");
            }
            assert!(
                plan.units
                    .iter()
                    .filter(|u| u.ids == [*id])
                    .all(|u| u.eye.is_some() == (id.view == study::View::Stereo))
            );
        }
        assert!(plan.units.iter().all(|u| u.shard < n && u.end > u.first));
        let loads = plan.loads();
        let (max, total) = (*loads.iter().max().unwrap(), loads.iter().sum::<u64>());
        let largest_unit = plan.units.iter().map(|u| u.cost).max().unwrap();
        // Greedy LPT: no shard exceeds an even share by more than one unit.
        assert!(max <= total / u64::from(n) + largest_unit, "N = {n}: {loads:?}");
        assert!(plan.describe().contains(&format!("shard {}/{n}:", n - 1)));
    }
    // Cost follows samples x pixels: an eye of A5 (16 spp) stereo costs 16 times A1 mono
    // per frame, and the pair 32 times.
    let plan = Plan::compute(&request(&d, Path::new("x"), &["M1-S1-T1-A1", "M1-S1-T1-A5-stereo"]), 1).unwrap();
    let per_frame = |u: &Unit| u.cost / u64::from(u.end - u.first);
    let eyes: Vec<&Unit> = plan.units.iter().filter(|u| u.eye.is_some()).collect();
    assert!([Eye::Left, Eye::Right].iter().all(|&e| eyes.iter().any(|u| u.eye == Some(e))));
    assert!(eyes.iter().all(|u| per_frame(u) == 16 * per_frame(&plan.units[0])));
    let right = eyes.iter().find(|u| u.eye == Some(Eye::Right) && u.first == 0).unwrap();
    let last = right.end - 1;
    assert_eq!(right.to_string(), format!("M1-S1-T1-A5-stereo right eye frames 0-{last}"));
    assert_eq!(right.record_name(), format!("frames-0000-{last:04}-right.json"));
    // Four shards of a two-sequence set split the costly sequence into frame ranges.
    let plan = Plan::compute(&request(&d, Path::new("x"), &["M1-S1-T1-A1", "M1-S1-T1-A5-stereo"]), 4).unwrap();
    assert!(plan.units.iter().filter(|u| u.ids[0].samples == 5).count() >= 4, "{}", plan.describe());
    assert!(plan.loads().iter().all(|&l| l > 0), "{}", plan.describe());
}

#[test]
fn method_costs_scale_with_their_work() {
    use study::method::{AccumSettings, AnalyticSettings, GuertinSettings, McGuireSettings, MethodSpec};
    let accum = MethodSpec::Accum(AccumSettings { instants: Some(4), ..Default::default() });
    assert_eq!(accum.samples_cost(10), 12);
    assert_eq!(MethodSpec::of(Method::Tracer).samples_cost(10), 10);
    // The filters at their defaults (McGuire 15 taps, Guertin 35) and at a written count.
    assert_eq!(MethodSpec::of(Method::Mcguire).samples_cost(10), 12);
    assert_eq!(MethodSpec::of(Method::Guertin).samples_cost(10), 15);
    let mcguire = MethodSpec::Mcguire(McGuireSettings { taps: Some(64), ..Default::default() });
    assert_eq!(mcguire.samples_cost(10), 18);
    let guertin = MethodSpec::Guertin(GuertinSettings { taps: Some(3), ..Default::default() });
    assert_eq!(guertin.samples_cost(10), 11);
    assert_eq!(MethodSpec::of(Method::Analytic).samples_cost(10), 10);
    let analytic = MethodSpec::Analytic(AnalyticSettings {
        supersampling: Some(4),
        lighting_samples: Some(2),
        ..Default::default()
    });
    assert_eq!(analytic.samples_cost(10), 32);
}

#[test]
fn shards_merge_into_the_unsharded_set_and_merge_lists_what_is_missing_or_duplicated() {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let ids = ["M2-S3-T5-A2", "M1-S1-T3-A1-stereo", "M3-S2-T4-A3"];
    let whole = dir.path().join("whole");
    crate::set::render_set(&request(&d, &whole, &ids)).unwrap();
    let n = 3;
    let shards: Vec<PathBuf> = (0..n).map(|k| dir.path().join(format!("shard{k}"))).collect();
    for (k, out) in shards.iter().enumerate() {
        let report = render_shard(&request(&d, out, &ids), ShardSpec { index: k as u32, count: n }).unwrap();
        assert!(!report.rendered.is_empty(), "shard {k} has work");
    }
    // Shard 2 alone is missing shards 0 and 1's units, named with their shard.
    let e = merge(&dir.path().join("partial"), &shards[2..], ProgressMode::Quiet).unwrap_err();
    let text = e.to_string();
    assert!(e.is_bad_input() && text.contains("missing: ") && text.contains("(shard 0/3)"), "{text}");
    assert!(!dir.path().join("partial").exists(), "nothing written");
    // A shard given twice is duplicated.
    let copy = dir.path().join("copy1");
    copy_tree(&shards[1], &copy);
    let e = merge(&dir.path().join("dup"), &[shards.clone(), vec![copy]].concat(), ProgressMode::Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("duplicated: ") && e.contains("(shard 1/3) in "), "{e}");
    assert!(!e.contains("missing"), "{e}");
    // Complete: the frames are the unsharded bytes.
    let merged = dir.path().join("merged");
    let report = merge(&merged, &shards, ProgressMode::Quiet).unwrap();
    assert_eq!(report.sequences, 3);
    for id in ids {
        let a = SequenceManifest::read(&whole.join(id).join("manifest.json")).unwrap();
        let b = SequenceManifest::read(&merged.join(id).join("manifest.json")).unwrap();
        assert_eq!(without_timing(a.clone()), without_timing(b.clone()), "{id}");
        for f in &a.frames {
            let bytes = std::fs::read(merged.join(id).join(&f.png)).unwrap();
            assert_eq!(sha256_hex(&bytes), f.png_sha256, "{id} {}", f.png);
        }
    }
    // A damaged frame is named.
    let plan: Plan = serde_json::from_slice(&std::fs::read(shards[0].join(PLAN_FILE)).unwrap()).unwrap();
    let victim = plan.units.iter().find(|u| u.shard == 0).unwrap();
    let png = shards[0].join(victim.ids[0].to_string()).join(crate::set::frame_name(victim.first, "png"));
    std::fs::write(&png, b"damaged").unwrap();
    let e = merge(&dir.path().join("bad"), &shards, ProgressMode::Quiet).unwrap_err().to_string();
    assert!(e.contains("damaged: ") && e.contains("does not hash as recorded"), "{e}");
    // --resume renders only the damaged unit again.
    let mut again = request(&d, &shards[0], &ids);
    again.resume = true;
    let r = render_shard(&again, ShardSpec { index: 0, count: n }).unwrap();
    assert_eq!(r.rendered, vec![victim.to_string()], "{r:?}");
    merge(&dir.path().join("merged2"), &shards, ProgressMode::Quiet).unwrap();
}

#[test]
fn a_shared_folder_completes_itself_and_refuses_another_shard_count() {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let ids = ["M2-S3-T5-A2", "M1-S1-T3-A5"];
    let shared = dir.path().join("shared");
    for k in 0..2 {
        render_shard(&request(&d, &shared, &ids), ShardSpec { index: k, count: 2 }).unwrap();
    }
    let index = study::manifest::SetIndex::read(&shared.join("index.json")).unwrap();
    assert_eq!(index.sequences.len(), 2);
    let before = std::fs::read(shared.join("index.json")).unwrap();
    merge(&shared, &[], ProgressMode::Quiet).unwrap();
    assert_eq!(std::fs::read(shared.join("index.json")).unwrap(), before);
    let plan_before = std::fs::read(shared.join(PLAN_FILE)).unwrap();
    let e = render_shard(&request(&d, &shared, &ids), ShardSpec { index: 0, count: 3 }).unwrap_err();
    assert!(e.is_bad_input() && e.to_string().contains("shard count N (2, 3)"), "{e}");
    assert_eq!(std::fs::read(shared.join(PLAN_FILE)).unwrap(), plan_before);
    assert_eq!(std::fs::read(shared.join("index.json")).unwrap(), before);
    // Merging shards of different plans is refused by name.
    let other = dir.path().join("other");
    render_shard(&request(&d, &other, &ids), ShardSpec { index: 0, count: 3 }).unwrap();
    let e = merge(&dir.path().join("m"), &[shared.clone(), other], ProgressMode::Quiet).unwrap_err().to_string();
    assert!(e.contains("shard count N (2, 3)"), "{e}");
}

#[test]
fn nested_streams_are_units_of_all_their_levels() {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let ids = ["M2-S1-T3-A1", "M2-S1-T3-A4", "M2-S1-T3-A2"];
    let nested = |out: &Path| SetRequest { sampling: Sampling::Nested, ..request(&d, out, &ids) };
    let whole = dir.path().join("whole");
    crate::set::render_set(&nested(&whole)).unwrap();
    let plan = Plan::compute(&nested(&whole), 2).unwrap();
    assert!(plan.units.iter().all(|u| u.ids.len() == 3), "{}", plan.describe());
    let shards: Vec<PathBuf> = (0..2).map(|k| dir.path().join(format!("s{k}"))).collect();
    for (k, out) in shards.iter().enumerate() {
        render_shard(&nested(out), ShardSpec { index: k as u32, count: 2 }).unwrap();
    }
    let merged = dir.path().join("merged");
    merge(&merged, &shards, ProgressMode::Quiet).unwrap();
    for id in ids {
        let a = SequenceManifest::read(&whole.join(id).join("manifest.json")).unwrap();
        let b = SequenceManifest::read(&merged.join(id).join("manifest.json")).unwrap();
        assert_eq!(without_timing(a), without_timing(b), "{id}");
    }
}

fn without_timing(mut m: SequenceManifest) -> SequenceManifest {
    for f in &mut m.frames {
        (f.wall_seconds, f.cpu_seconds) = (0.0, 0.0);
    }
    m.device.clear();
    m
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}
