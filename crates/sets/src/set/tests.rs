//! Tests of set rendering: resume, verification, crash safety, several writers.

use std::sync::atomic::{AtomicUsize, Ordering};

use study::Method;
use study::fsio::sha256_file;
use study::manifest::{SequenceManifest, SetIndex};

use super::render::{render_set, render_set_with};
use super::store::{frame_index_of, remove_temporaries, remove_temporaries_of};
use super::verify::verify_sequence;
use super::*;
use super::{FileWriter, ProgressMode, SetError, SetRequest};

fn design() -> Design {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    Design::load(&path).unwrap()
}

#[test]
fn temporaries_are_cleared_only_for_the_frames_a_process_owns() {
    // Two shards render frames 0-2 and 3-5 of one sequence into one folder at once:
    // clearing its own leftovers, one must not delete the other's write in progress.
    let dir = tempfile::tempdir().unwrap();
    let names = [".frame-0002.png.tmp-11", ".frame-0003.png.tmp-12", ".manifest.json.tmp-12", "frame-0001.png"];
    for name in names {
        std::fs::write(dir.path().join(name), b"x").unwrap();
    }
    remove_temporaries_of(dir.path(), |target| frame_index_of(target).is_some_and(|f| (3..6).contains(&f)));
    let left = |name: &str| dir.path().join(name).exists();
    assert!(left(".frame-0002.png.tmp-11") && left(".manifest.json.tmp-12") && left("frame-0001.png"));
    assert!(!left(".frame-0003.png.tmp-12"));
    assert_eq!(frame_index_of("frame-0042.exr"), Some(42));
    assert_eq!(frame_index_of("frame-12345.png"), Some(12345));
    for not_a_frame in ["frame-42.png", "frame-00a1.png", "manifest.json", "frames-0000-0002.json"] {
        assert_eq!(frame_index_of(not_a_frame), None, "{not_a_frame}");
    }
    remove_temporaries(dir.path());
    assert!(!left(".frame-0002.png.tmp-11") && !left(".manifest.json.tmp-12") && left("frame-0001.png"));
}

/// A disk that fills up after `room` successful writes.
struct FillingDisk {
    room: usize,
    writes: AtomicUsize,
}

impl FileWriter for FillingDisk {
    fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()> {
        if self.writes.fetch_add(1, Ordering::SeqCst) >= self.room {
            return Err(io::Error::new(io::ErrorKind::StorageFull, "No space left on device (injected)"));
        }
        write_atomic(path, bytes)
    }
}

fn request<'a>(design: &'a Design, out: &Path, only: &[&str]) -> SetRequest<'a> {
    let mut preset = design.preset("quick").unwrap();
    preset.frames = 2;
    preset.width = 16;
    preset.height = 9;
    SetRequest {
        design,
        preset,
        ids: only.iter().map(|s| s.parse().unwrap()).collect(),
        out: out.to_owned(),
        resume: false,
        exr: true,
        progress: ProgressMode::Quiet,
        device: DeviceChoice::Cpu,
        sampling: Sampling::Independent,
    }
}

#[test]
fn a_full_disk_is_reported_with_the_file_and_keeps_finished_sequences() {
    full_disk(DeviceChoice::Cpu);
}

#[test]
fn a_full_disk_on_the_gpu_path_stops_the_set_the_same_way() {
    // Frames are written on the thread pool while the GPU renders the next ones.
    if let Err(e) = gpu::acquire(gpu::AdapterChoice::HardwareThenSoftware, &gpu::DeviceRequest::default()) {
        gpu::skip_or_fail("set::tests::a_full_disk_on_the_gpu_path_stops_the_set_the_same_way", &e);
        return;
    }
    full_disk(DeviceChoice::Gpu);
}

fn full_disk(device: DeviceChoice) {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let ids = ["M1-S1-T1-A1", "M1-S1-T1-A2"];
    // index, 2 frames x (png + exr), manifest, index: 7 writes finish the first sequence.
    let disk = FillingDisk { room: 8, writes: AtomicUsize::new(0) };
    let e = render_set_with(&SetRequest { device, ..request(&d, dir.path(), &ids) }, &disk).unwrap_err();
    let SetError::Io { path, source, .. } = &e else { panic!("{e}") };
    assert_eq!(source.kind(), io::ErrorKind::StorageFull);
    assert!(path.starts_with(dir.path().join("M1-S1-T1-A2")), "{e}");
    // The CPU writes frames in order; the GPU path's pool may reach frame 1 first.
    assert!(e.to_string().contains("frame-000"), "{e}");
    assert!(device != DeviceChoice::Cpu || e.to_string().contains("frame-0000"), "{e}");
    let index = SetIndex::read(&dir.path().join("index.json")).unwrap();
    assert_eq!(index.sequences.len(), 1);
    let req = request(&d, dir.path(), &ids);
    assert!(
        verify_sequence(
            &dir.path().join("M1-S1-T1-A1"),
            &d,
            &req.preset,
            &index.sequences[0].id,
            Method::Tracer,
            true,
            Sampling::Independent
        )
        .is_some()
    );
    assert!(
        verify_sequence(
            &dir.path().join("M1-S1-T1-A2"),
            &d,
            &req.preset,
            &"M1-S1-T1-A2".parse().unwrap(),
            Method::Tracer,
            true,
            Sampling::Independent
        )
        .is_none()
    );
}

#[test]
fn resume_skips_verified_sequences_and_rerenders_damaged_ones() {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let ids = ["M2-S3-T5-A1", "M2-S3-T5-A1-stereo"];
    let first = render_set(&request(&d, dir.path(), &ids)).unwrap();
    assert_eq!(first.rendered.len(), 2);
    let manifest = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1-stereo/manifest.json")).unwrap();
    assert_eq!((manifest.width, manifest.height), (32, 9));
    assert!(manifest.frames.iter().all(|f| f.exr.is_some()));
    std::fs::write(dir.path().join("M2-S3-T5-A1/frame-0001.exr"), b"damaged").unwrap();
    let mut again = request(&d, dir.path(), &ids);
    again.resume = true;
    let second = render_set(&again).unwrap();
    assert_eq!(second.skipped, vec!["M2-S3-T5-A1-stereo".parse().unwrap()]);
    assert_eq!(second.rendered, vec!["M2-S3-T5-A1".parse().unwrap()]);
    let redone = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1/manifest.json")).unwrap();
    let before = SequenceManifest::read(&dir.path().join("M2-S3-T5-A1-stereo/manifest.json")).unwrap();
    assert_eq!(before, manifest);
    assert_eq!(redone.frames[1].exr_sha256, Some(sha256_file(&dir.path().join("M2-S3-T5-A1/frame-0001.exr")).unwrap()));
    // Another preset may not be mixed into the folder.
    let mut other = request(&d, dir.path(), &ids);
    other.preset.name = "full".into();
    let e = render_set(&other).unwrap_err();
    assert!(e.is_bad_input() && e.to_string().contains("preset `quick`"), "{e}");
}
