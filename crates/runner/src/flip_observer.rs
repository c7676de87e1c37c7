//! The image-computable observer (`--simulate flip[:sigma=S]`): each trial is answered from
//! the frames themselves with FLIP (`perceptual`, Andersson et al. 2020) at the design's
//! viewing geometry.
//!
//! - The distance of a sequence `b` from a sequence `a` is the mean over frames of the mean
//!   FLIP of `b`'s frame against `a`'s (a stereo frame's eyes judged apart, each at the
//!   pixels per degree of one eye's image), on the 8-bit PNG frames of the set, as shown.
//! - 2AFC: each candidate's distance from its gold standard (the same material, speed,
//!   shutter, method and view at the highest sampling level the set holds: A5 in the study),
//!   plus Gaussian decision noise of standard deviation `S` (FLIP units, default
//!   [`DEFAULT_SIGMA`]); the smaller wins.
//! - Matching: each candidate's distance from the reference, plus the same noise; the
//!   candidate nearer the reference is picked.
//!
//! Pixels per degree come from the set's `design.toml` (`[viewing]`). The distances are
//! computed once before the first trial (the gold sequences' frames verified against their
//! manifests as the shown ones are), so answers stay deterministic in the session seed.

use std::collections::{BTreeMap, HashMap};

use perceptual::SrgbImage;
use study::manifest::SequenceManifest;
use study::response::Task;
use study::{StimulusId, View};

use crate::RunnerError;
use crate::schedule::Trial;
use crate::stimuli::{StimulusSet, decode_frame};

/// Default decision noise, in FLIP units.
pub const DEFAULT_SIGMA: f64 = 0.005;

/// A sequence's frames and how to judge them.
pub struct Frames {
    /// The 8-bit frames as shown (eyes side by side).
    pub images: Vec<SrgbImage>,
    /// Eyes per frame: 1 (mono) or 2 (side-by-side stereo).
    pub eyes: u32,
}

/// Where a sequence is: its folder and verified manifest.
fn open_sequence(set: &StimulusSet, id: &StimulusId) -> Result<(std::path::PathBuf, SequenceManifest), RunnerError> {
    if let Some(s) = set.sequences.get(id) {
        return Ok((s.folder.clone(), s.manifest.clone()));
    }
    let entry = set.index.sequences.iter().find(|e| e.id == *id).ok_or_else(|| RunnerError::Input {
        what: "--simulate flip".into(),
        message: format!(
            "the set {} has no sequence {id} (the gold standard a FLIP observer compares with)",
            set.dir.display()
        ),
    })?;
    let folder = set.dir.join(&entry.folder);
    let path = folder.join("manifest.json");
    let bytes = std::fs::read(&path).map_err(|source| RunnerError::Io { path: path.clone(), source })?;
    if study::fsio::sha256_hex(&bytes) != entry.manifest_sha256 {
        return Err(RunnerError::Sequence {
            path,
            message: format!("sequence {id}: the manifest is not the one index.json records"),
        });
    }
    let manifest = SequenceManifest::read(&path)?;
    for f in &manifest.frames {
        let png = folder.join(&f.png);
        let actual = study::fsio::sha256_file(&png).map_err(|source| RunnerError::Io { path: png.clone(), source })?;
        if actual != f.png_sha256 {
            return Err(RunnerError::Sequence {
                path: png,
                message: format!(
                    "sequence {id} frame {}: the file's sha256 is {actual}, and its manifest records {}",
                    f.index, f.png_sha256
                ),
            });
        }
    }
    Ok((folder, manifest))
}

/// The frames of `id` in `set`, each checked against its manifest's hash (the image-computable
/// observers judge exactly what a participant is shown).
pub fn load_frames(set: &StimulusSet, id: &StimulusId) -> Result<Frames, RunnerError> {
    let (folder, m) = open_sequence(set, id)?;
    let mut images = Vec::with_capacity(m.frames.len());
    for f in &m.frames {
        images.push(read_srgb(&folder.join(&f.png), m.width, m.height)?);
    }
    Ok(Frames { images, eyes: if m.view == View::Stereo { 2 } else { 1 } })
}

/// An 8-bit PNG frame of `width` x `height` as an RGB image.
pub fn read_srgb(path: &std::path::Path, width: u32, height: u32) -> Result<SrgbImage, RunnerError> {
    let rgba = decode_frame(path, width, height)?;
    let rgb: Vec<u8> = rgba.pixels.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    SrgbImage::new(width, height, rgb)
        .map_err(|e| RunnerError::Sequence { path: path.to_owned(), message: e.to_string() })
}

/// The gold standard of `id` in `set`: the highest sampling level the set's index holds for
/// its material, speed, shutter, method and view.
pub fn gold_standard(set: &StimulusSet, id: &StimulusId) -> StimulusId {
    set.index
        .sequences
        .iter()
        .map(|e| e.id)
        .filter(|g| StimulusId { samples: id.samples, ..*g } == *id)
        .max_by_key(|g| g.samples)
        .unwrap_or(*id)
}

/// The `(from, to)` pairs whose distances `schedule` needs.
pub fn needed_pairs(set: &StimulusSet, schedule: &[Trial]) -> Vec<(StimulusId, StimulusId)> {
    let mut pairs: Vec<(StimulusId, StimulusId)> = Vec::new();
    for t in schedule {
        for o in t.options() {
            let from = match t.task {
                Task::TwoAfc => gold_standard(set, o),
                Task::Match => t.shown[0],
            };
            if !pairs.contains(&(from, *o)) {
                pairs.push((from, *o));
            }
        }
    }
    pairs
}

/// The FLIP distance of every pair `schedule` needs.
pub fn distances(set: &StimulusSet, schedule: &[Trial]) -> Result<HashMap<(StimulusId, StimulusId), f64>, RunnerError> {
    let design_path = set.dir.join("design.toml");
    let design = study::design::Design::load(&design_path).map_err(|e| RunnerError::Input {
        what: "--simulate flip".into(),
        message: format!("the set's design (for its viewing geometry): {e}"),
    })?;
    let pairs = needed_pairs(set, schedule);
    let mut frames: BTreeMap<StimulusId, Frames> = BTreeMap::new();
    for (a, b) in &pairs {
        for id in [a, b] {
            if !frames.contains_key(id) {
                frames.insert(*id, load_frames(set, id)?);
            }
        }
    }
    let mut out = HashMap::new();
    for (a, b) in pairs {
        let (fa, fb) = (&frames[&a], &frames[&b]);
        if fa.images.len() != fb.images.len() || fa.eyes != fb.eyes {
            return Err(RunnerError::Input {
                what: "--simulate flip".into(),
                message: format!(
                    "{a} and {b} differ in frames ({} and {}) or view: FLIP compares frame by frame",
                    fa.images.len(),
                    fb.images.len()
                ),
            });
        }
        let eye_width = fa.images.first().map_or(1, |i| i.width() / fa.eyes);
        let ppd = design.pixels_per_degree(eye_width);
        let mut total = 0.0;
        for (x, y) in fa.images.iter().zip(&fb.images) {
            total += perceptual::flip_eyes(x, y, fa.eyes, ppd).map_err(|e| RunnerError::Input {
                what: format!("--simulate flip: {a} against {b}"),
                message: e.to_string(),
            })?;
        }
        out.insert((a, b), total / fa.images.len().max(1) as f64);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use study::experiment::ExperimentDefinition;
    use study::response::SessionLog;
    use study::testing::ExperimentToml;

    use crate::simulate::{ObserverModel, run_session};

    /// A synthetic set of A1..A5 at T5 (noise falling with the level) with the shipped design.
    fn set(dir: &Path, task: &str) -> (ExperimentDefinition, std::path::PathBuf) {
        let text = ExperimentToml {
            task: task.into(),
            question: "q".into(),
            shutter: vec![5],
            samples: vec![1, 2, 3, 4, 5],
            repeats: Some(2),
            ..ExperimentToml::minimal()
        }
        .to_string();
        let d = ExperimentDefinition::parse(Path::new("t.toml"), &text).unwrap();
        let ids: Vec<_> = d.all_stimuli().into_iter().collect();
        let set = dir.join("set");
        crate::stimuli::write_synthetic_set(&set, &ids, 48, 24, 3, 30.0).unwrap();
        let design = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
        std::fs::copy(design, set.join("design.toml")).unwrap();
        (d, set)
    }

    #[test]
    fn the_flip_observer_prefers_sequences_nearer_the_gold_standard_and_is_reproducible() {
        let dir = tempfile::tempdir().unwrap();
        let (d, set_dir) = set(dir.path(), "2afc");
        let opened = crate::stimuli::StimulusSet::open_for(&set_dir, &d).unwrap();
        let schedule = crate::schedule::build(&d, 3);
        let table = super::distances(&opened, &schedule).unwrap();
        let a5: study::StimulusId = "M2-S2-T5-A5".parse().unwrap();
        let a1: study::StimulusId = "M2-S2-T5-A1".parse().unwrap();
        assert_eq!(super::gold_standard(&opened, &a1), a5);
        assert_eq!(table[&(a5, a5)], 0.0);
        assert!(table[&(a5, a1)] > 0.0);
        // Without decision noise the observer always prefers the smaller distance.
        let model: ObserverModel = "flip:sigma=0".parse().unwrap();
        let results = dir.path().join("results");
        let log = run_session(&d, &set_dir, &results, "F1", &model, 3).unwrap();
        let rows = SessionLog::read(&log).unwrap().rows;
        for (_, r) in rows.iter().filter(|(_, r)| !r.practice) {
            let other = if r.shown[0] == r.choice { r.shown[1] } else { r.shown[0] };
            assert!(table[&(a5, r.choice)] <= table[&(a5, other)], "{} over {}", r.choice, other);
        }
        // Reproducible from the seed.
        let again = run_session(&d, &set_dir, &results, "F2", &model, 3).unwrap();
        let choices = |p: &Path| -> Vec<String> {
            SessionLog::read(p).unwrap().rows.iter().map(|(_, r)| r.choice.to_string()).collect()
        };
        assert_eq!(choices(&log), choices(&again));
        // Bad parameters are named.
        let e = "flip:sigma=x".parse::<ObserverModel>().unwrap_err().to_string();
        assert!(e.contains("sigma `x`"), "{e}");
        let e = "flip:mu=1".parse::<ObserverModel>().unwrap_err().to_string();
        assert!(e.contains("unknown parameter `mu=1`"), "{e}");
    }

    #[test]
    fn the_flip_observer_matches_the_candidate_nearer_the_reference() {
        let dir = tempfile::tempdir().unwrap();
        let (d, set_dir) = set(dir.path(), "match");
        let model: ObserverModel = "flip:sigma=0".parse().unwrap();
        let log = run_session(&d, &set_dir, &dir.path().join("results"), "F1", &model, 5).unwrap();
        let rows = SessionLog::read(&log).unwrap().rows;
        // The reference is one of the candidates, at distance 0 from itself: always found.
        assert!(rows.iter().filter(|(_, r)| !r.practice).all(|(_, r)| r.correct == Some(true)));
    }
}
