//! Whether a rendered sequence verifies: its manifest matches what the request expects
//! and every frame's hash is the recorded one.

use std::path::Path;

use study::design::{Design, Preset};
use study::fsio::{sha256_file, sha256_hex};
use study::manifest::SequenceManifest;
use study::{Eye, Method, StimulusId};

use study::manifest::Sampling;

/// Whether every file a manifest lists hashes as recorded.
pub(super) fn frames_verify(folder: &Path, m: &SequenceManifest) -> bool {
    m.frames.iter().all(|f| {
        sha256_file(&folder.join(&f.png)).is_ok_and(|h| h == f.png_sha256)
            && match (&f.exr, &f.exr_sha256) {
                (Some(name), Some(hash)) => sha256_file(&folder.join(name)).is_ok_and(|h| h == *hash),
                (None, None) => true,
                _ => false,
            }
    })
}

/// Whether `folder` holds a complete rendering of `id` as this request would produce it;
/// returns the manifest's hash when it does.
pub fn verify_sequence(
    folder: &Path,
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    method: Method,
    exr: bool,
    sampling: Sampling,
) -> Option<String> {
    let manifest_path = folder.join("manifest.json");
    let bytes = std::fs::read(&manifest_path).ok()?;
    let m = SequenceManifest::read(&manifest_path).ok()?;
    let expected = Expected { design, preset, id, method, exr, sampling, frames: 0..preset.frames, eye: None };
    expected.why_not(folder, &m).is_none().then(|| sha256_hex(&bytes))
}

/// What a manifest (of a whole sequence, or of a shard's unit of frames) must say and hold.
pub(crate) struct Expected<'a> {
    pub(crate) design: &'a Design,
    pub(crate) preset: &'a Preset,
    pub(crate) id: &'a StimulusId,
    pub(crate) method: Method,
    pub(crate) exr: bool,
    pub(crate) sampling: Sampling,
    pub(crate) frames: std::ops::Range<u32>,
    /// The one eye of a stereo pair the manifest holds (a shard's unit); `None`: every eye.
    pub(crate) eye: Option<Eye>,
}

impl Expected<'_> {
    /// Why `m`, in `folder`, is not what is expected (`None`: it is, and its files verify).
    pub(crate) fn why_not(&self, folder: &Path, m: &SequenceManifest) -> Option<String> {
        let (design, preset, id) = (self.design, self.preset, self.id);
        let spp = preset.samples_of(id);
        let eyes = if self.eye.is_some() { 1 } else { study::Eye::of_view(id.view).len() as u32 };
        let checks: [(bool, String); 9] = [
            (m.id == *id, format!("id {} (expected {id})", m.id)),
            (m.method == self.method, format!("method `{}` (expected `{}`)", m.method.name(), self.method.name())),
            (m.sampling == self.sampling, format!("sampling {:?} (expected {:?})", m.sampling, self.sampling)),
            (m.preset == preset.name, format!("preset `{}` (expected `{}`)", m.preset, preset.name)),
            (
                m.design_sha256 == design.sha256,
                format!("design_sha256 {} (expected {})", m.design_sha256, design.sha256),
            ),
            (Some(m.samples_per_pixel) == spp, format!("samples_per_pixel {}", m.samples_per_pixel)),
            (m.width == preset.width * eyes, format!("width {} (expected {})", m.width, preset.width * eyes)),
            (m.height == preset.height, format!("height {} (expected {})", m.height, preset.height)),
            (
                m.frames.len() == self.frames.len()
                    && m.frames.iter().zip(self.frames.clone()).all(|(f, i)| f.index == i),
                format!(
                    "frames {:?} (expected {}..={})",
                    m.frames.iter().map(|f| f.index).collect::<Vec<_>>(),
                    self.frames.start,
                    self.frames.end.saturating_sub(1)
                ),
            ),
        ];
        if let Some((_, what)) = checks.iter().find(|(ok, _)| !ok) {
            return Some(format!("records {what}"));
        }
        for f in &m.frames {
            if sha256_file(&folder.join(&f.png)).ok().as_deref() != Some(f.png_sha256.as_str()) {
                return Some(format!("{} is missing or does not hash as recorded", f.png));
            }
            match (&f.exr, &f.exr_sha256) {
                (Some(name), Some(hash)) if sha256_file(&folder.join(name)).ok().as_ref() != Some(hash) => {
                    return Some(format!("{name} is missing or does not hash as recorded"));
                }
                (Some(_), Some(_)) => {}
                _ if self.exr => return Some(format!("frame {} has no EXR file (expected with --exr)", f.index)),
                _ => {}
            }
        }
        None
    }
}
