//! A set's folder on disk: names of frames, eyes and locks, manifests written and read, the
//! index rebuilt from the manifests, temporaries of killed writers removed, and a folder of
//! another design version, preset or sampling mode refused with the keys that differ.

use std::io;
use std::path::{Path, PathBuf};

use study::design::{Design, Preset};
use study::fsio::{sha256_file, sha256_hex, write_atomic};
use study::manifest::{INDEX_FORMAT, IndexEntry, ManifestError, SEQUENCE_FORMAT, SequenceManifest, SetIndex};
use study::{Eye, StimulusId};

use study::manifest::Sampling;

use super::verify::frames_verify;
use super::{FileWriter, SetError};

pub(crate) fn io_err<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(io::Error) -> SetError + 'a {
    move |source| SetError::Io { path: path.to_owned(), action, source }
}

pub(crate) fn manifest_bytes(manifest: &SequenceManifest) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(manifest).unwrap_or_default();
    bytes.push(b'\n');
    bytes
}

/// Removes temporary files a killed write left behind (`.NAME.tmp-PID`).
pub(crate) fn remove_temporaries(folder: &Path) {
    remove_temporaries_of(folder, |_| true);
}

/// Removes the temporaries in `folder` whose target file name (`.NAME.tmp-PID` targets
/// NAME) satisfies `owned`. Shards rendering other frames of the same sequence write into
/// the same folder at the same time: each may only clear what its own frames left behind.
pub(crate) fn remove_temporaries_of(folder: &Path, owned: impl Fn(&str) -> bool) {
    if let Ok(entries) = std::fs::read_dir(folder) {
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            let target = name.strip_prefix('.').and_then(|rest| rest.rsplit_once(".tmp-")).map(|(target, _)| target);
            if target.is_some_and(&owned) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
}

/// The frame index a file name such as `frame-0042.png` holds.
pub(crate) fn frame_index_of(name: &str) -> Option<u32> {
    let digits = name.strip_prefix("frame-")?.split('.').next()?;
    if digits.len() >= 4 && digits.bytes().all(|b| b.is_ascii_digit()) { digits.parse().ok() } else { None }
}

/// The folder, inside a sequence folder, of the eyes' frames of a stereo sequence rendered
/// one eye at a time (by shards): `SEQ/eyes/left/frame-0000.png`, joined into the frames.
pub const EYES_DIR: &str = "eyes";

/// An eye's name in file names: `centre`, `left`, `right`.
pub fn eye_name(eye: Eye) -> &'static str {
    match eye {
        Eye::Centre => "centre",
        Eye::Left => "left",
        Eye::Right => "right",
    }
}

/// The folder of `eye`'s frames in sequence folder `seq`.
pub fn eye_folder(seq: &Path, eye: Eye) -> PathBuf {
    seq.join(EYES_DIR).join(eye_name(eye))
}

/// The lock file, in a sequence's folder, of the process rendering it (`study::lock`).
pub const SEQUENCE_LOCK: &str = "render.lock";

/// The copy of the design file a set folder keeps, to name the keys a later design changes.
pub const DESIGN_COPY: &str = "design.toml";

/// A manifest found in a set folder: its folder, bytes and content.
struct Found {
    folder: PathBuf,
    bytes: Vec<u8>,
    manifest: SequenceManifest,
}

/// A set folder being rendered into. The sequence manifests in it are the truth;
/// `index.json` is rebuilt from those of this design, preset and sampling mode whose files
/// verify, so several processes (or cluster nodes, without working locks) rendering into one
/// folder all keep every completed sequence.
pub(crate) struct SetFolder<'a> {
    root: PathBuf,
    design: &'a Design,
    preset: &'a Preset,
    sampling: Sampling,
    /// Sequences (id, manifest hash) whose listed files verified, or that an index listed.
    pub(crate) verified: std::collections::HashSet<(StimulusId, String)>,
}

impl<'a> SetFolder<'a> {
    /// Checks that the folder holds nothing of another design, preset or sampling mode, and
    /// keeps a copy of the design file in it.
    pub(crate) fn open(
        root: &Path,
        design: &'a Design,
        preset: &'a Preset,
        sampling: Sampling,
    ) -> Result<Self, SetError> {
        let mut folder =
            SetFolder { root: root.to_owned(), design, preset, sampling, verified: std::collections::HashSet::new() };
        let index_path = root.join("index.json");
        if index_path.exists() {
            let old = match SetIndex::read(&index_path) {
                Ok(old) => old,
                Err(ManifestError::Io { source, .. }) => {
                    return Err(SetError::Io { path: index_path, action: "cannot read the set index", source });
                }
                Err(e) => {
                    return Err(SetError::Mismatch {
                        path: index_path,
                        message: format!("not a readable set index ({e}); remove it or render into another folder"),
                    });
                }
            };
            if old.design != design.name() || old.preset != preset.name {
                return Err(SetError::Mismatch {
                    path: index_path,
                    message: format!(
                        "this folder holds design `{}` rendered with preset `{}`, not design `{}` with preset `{}`; render into another folder",
                        old.design,
                        old.preset,
                        design.name(),
                        preset.name
                    ),
                });
            }
            if !old.sequences.is_empty() {
                if old.design_sha256 != design.sha256 {
                    return Err(folder.design_mismatch(&index_path, &old.design_sha256));
                }
                if old.sampling != sampling {
                    return Err(sampling_mismatch(&index_path, old.sampling, sampling));
                }
            }
            // What an index lists was verified by the process that listed it.
            folder.verified.extend(old.sequences.into_iter().map(|e| (e.id, e.manifest_sha256)));
        }
        folder.scan()?;
        let copy = root.join(DESIGN_COPY);
        if sha256_file(&copy).ok().as_deref() != Some(design.sha256.as_str()) {
            write_atomic(&copy, design.text().as_bytes()).map_err(io_err(&copy, "cannot write"))?;
        }
        Ok(folder)
    }

    /// The manifests in the folder, refusing one of another design, preset or sampling mode.
    fn scan(&self) -> Result<Vec<Found>, SetError> {
        let entries = std::fs::read_dir(&self.root).map_err(io_err(&self.root, "cannot list the set folder"))?;
        let mut found = Vec::new();
        for entry in entries.flatten() {
            let name = entry.file_name();
            let Some(id) = name.to_str().and_then(|n| n.parse::<StimulusId>().ok()) else { continue };
            let path = entry.path().join("manifest.json");
            let Ok(bytes) = std::fs::read(&path) else { continue };
            // A manifest that does not parse is not a complete sequence (never listed).
            let Ok(manifest) = serde_json::from_slice::<SequenceManifest>(&bytes) else { continue };
            if manifest.format != SEQUENCE_FORMAT || manifest.id != id {
                continue;
            }
            if manifest.design_sha256 != self.design.sha256 {
                return Err(self.design_mismatch(&path, &manifest.design_sha256));
            }
            if manifest.preset != self.preset.name {
                return Err(SetError::Mismatch {
                    path,
                    message: format!(
                        "rendered with preset `{}`, and this run renders preset `{}`; render into another folder",
                        manifest.preset, self.preset.name
                    ),
                });
            }
            if manifest.sampling != self.sampling {
                return Err(sampling_mismatch(&path, manifest.sampling, self.sampling));
            }
            found.push(Found { folder: entry.path(), bytes, manifest });
        }
        Ok(found)
    }

    /// The index of the complete sequences in the folder now.
    pub(crate) fn rebuild(&mut self) -> Result<SetIndex, SetError> {
        let mut sequences = Vec::new();
        for f in self.scan()? {
            let m = &f.manifest;
            let eyes = study::Eye::of_view(m.id.view).len() as u32;
            let spp = self.preset.samples_of(&m.id);
            let fits = Some(m.samples_per_pixel) == spp
                && m.width == self.preset.width * eyes
                && m.height == self.preset.height
                && m.frames.len() == self.preset.frames as usize
                && m.frames.iter().enumerate().all(|(i, r)| r.index as usize == i);
            if !fits {
                continue;
            }
            let key = (m.id, sha256_hex(&f.bytes));
            if !self.verified.contains(&key) {
                if !frames_verify(&f.folder, m) {
                    continue;
                }
                self.verified.insert(key.clone());
            }
            sequences.push(IndexEntry { id: m.id, folder: m.id.to_string(), manifest_sha256: key.1 });
        }
        sequences.sort_by_key(|e| e.id);
        Ok(SetIndex {
            format: INDEX_FORMAT.to_owned(),
            design: self.design.name().to_owned(),
            design_sha256: self.design.sha256.clone(),
            preset: self.preset.name.clone(),
            sampling: self.sampling,
            sequences,
        })
    }

    /// Rewrites `index.json` from the folder until a fresh rebuild equals what is on disk: the
    /// last process to write the index checks it after its write, so a concurrent writer's
    /// older view never has the last word.
    pub(crate) fn publish(&mut self, writer: &dyn FileWriter) -> Result<(), SetError> {
        let path = self.root.join("index.json");
        for _ in 0..100 {
            let index = self.rebuild()?;
            let mut bytes = serde_json::to_vec_pretty(&index).unwrap_or_default();
            bytes.push(b'\n');
            if std::fs::read(&path).is_ok_and(|disk| disk == bytes) {
                return Ok(());
            }
            writer.write(&path, &bytes).map_err(io_err(&path, "cannot write the set index"))?;
        }
        Ok(())
    }

    /// The error for a folder (at `path`) of another version of the design, naming the keys
    /// that differ from the folder's design copy.
    fn design_mismatch(&self, path: &Path, theirs: &str) -> SetError {
        let copy = self.root.join(DESIGN_COPY);
        let differences = match std::fs::read_to_string(&copy) {
            Ok(text) if sha256_hex(text.as_bytes()) == theirs => {
                match (text.parse::<toml::Table>(), self.design.text().parse::<toml::Table>()) {
                    (Ok(a), Ok(b)) => {
                        let mut keys = Vec::new();
                        toml_differences("", &toml::Value::Table(a), &toml::Value::Table(b), &mut keys);
                        if keys.is_empty() {
                            "the files differ only in comments or layout".to_owned()
                        } else {
                            let more = keys.len().saturating_sub(8);
                            keys.truncate(8);
                            let mut s = format!("keys that differ: {}", keys.join(", "));
                            if more > 0 {
                                s.push_str(&format!(" and {more} more"));
                            }
                            s
                        }
                    }
                    _ => format!("{} does not parse", copy.display()),
                }
            }
            _ => format!("no copy of that design in {} to compare keys with", copy.display()),
        };
        SetError::Mismatch {
            path: path.to_owned(),
            message: format!(
                "this folder holds a set of another version of design `{}` (design_sha256 {theirs}), and {} has sha256 {}: {differences}; render into another folder, or restore the design the set was rendered from",
                self.design.name(),
                self.design.path.display(),
                self.design.sha256
            ),
        }
    }
}

fn sampling_mismatch(path: &Path, theirs: Sampling, ours: Sampling) -> SetError {
    let flag = |s: Sampling| if s == Sampling::Nested { "with --nested" } else { "without --nested" };
    SetError::Mismatch {
        path: path.to_owned(),
        message: format!(
            "this folder holds a set rendered {}, and this run is {}; one set has one sampling mode: render into another folder",
            flag(theirs),
            flag(ours)
        ),
    }
}

/// The dotted keys whose values differ between two TOML values (`key (A there, B here)`).
fn toml_differences(prefix: &str, a: &toml::Value, b: &toml::Value, out: &mut Vec<String>) {
    let show = |v: Option<&toml::Value>| v.map_or_else(|| "absent".to_owned(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(p), Some(q)) => toml_differences(&key, p, q, out),
                    (p, q) => out.push(format!("`{key}` ({} there, {} here)", show(p), show(q))),
                }
            }
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                toml_differences(&format!("{prefix}[{i}]"), p, q, out);
            }
        }
        _ if a != b => out.push(format!("`{prefix}` ({} there, {} here)", show(Some(a)), show(Some(b)))),
        _ => {}
    }
}
