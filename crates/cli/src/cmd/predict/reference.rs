//! The observer's rendered references: the frames each sequence is judged against, rendered
//! once per material, speed (and shutter, for `shutter`) and view into
//! `SET/observer/reference/FOLDER/KEY/`, with seeds drawn apart from the stimuli's (no noise
//! shared with a test sequence).
//!
//! Each reference is seeded by its own levels alone (material, speed, view, and the shutter
//! for `shutter`), so its frames are the same whichever sequence asks for it first.
//!
//! Each reference carries a stamp, `reference.json`: the design (name and SHA-256) and preset
//! it is rendered from, the reference's settings and, once its last frame is on disk, every
//! frame's SHA-256. A stamp without frames marks a reference being rendered: its frames on
//! disk are resumed from. The finished stamp's own SHA-256 names the reference: a forecast
//! records it beside each sequence's manifest hash, and a cached score holds only while its
//! reference's stamp is the one it was judged against. A reference stamped for another design
//! or preset (a set folder emptied and rendered again from an edited design), or frames with
//! no stamp (rendered before stamps existed, when a reference's seeds depended on which
//! sequence asked for it first), are rendered again; so is a frame that no longer hashes as
//! stamped.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use perceptual::SrgbImage;
use serde::{Deserialize, Serialize};
use study::design::{Design, Preset};
use study::scene::{FrameScene, Shutter};
use study::{StimulusId, View};

use super::observer::{ObserverSettings, ReferenceKind, observer_dir};
use crate::cmd::BadInput;

/// Stream constant of the references' sample seeds.
const REFERENCE_STREAM: u64 = 0x5EF3_2E9C;

/// Format tag of a reference's stamp.
pub const STAMP_FORMAT: &str = "blurlab-observer-reference/1";

/// The stamp's file name in a reference's folder.
pub const STAMP_FILE: &str = "reference.json";

/// What a reference's frames were rendered from, and each frame's hash.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ReferenceStamp {
    format: String,
    /// Material, speed (and shutter) and view: the reference's folder name.
    key: String,
    /// Kind, samples per pixel, sub-frames and clip: the name of the folder above.
    settings: String,
    /// The design's name.
    design: String,
    /// SHA-256 of the design file.
    design_sha256: String,
    /// The preset.
    preset: String,
    /// Every frame in display order, once the last is on disk; empty while the reference is
    /// rendered.
    frames: Vec<StampedFrame>,
}

/// One frame of a stamped reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct StampedFrame {
    /// The PNG file, relative to the reference's folder.
    png: String,
    /// Its SHA-256.
    png_sha256: String,
}

/// The first 12 characters of a hash, for messages (whatever a stamp file holds).
fn short(hash: &str) -> String {
    hash.chars().take(12).collect()
}

/// The folder name of a reference: material, speed (and shutter for `shutter`), view.
pub(super) fn reference_key(id: &StimulusId, kind: ReferenceKind) -> String {
    let view = if id.view == View::Stereo { "-stereo" } else { "" };
    match kind {
        ReferenceKind::Shutter => format!("M{}-S{}-T{}{view}", id.material, id.speed, id.shutter),
        ReferenceKind::Eye | ReferenceKind::Sharp => format!("M{}-S{}{view}", id.material, id.speed),
    }
}

/// The scene of sub-frame `sub` of frame `frame` of `id`'s reference.
pub(super) fn reference_scene(
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    frame: u32,
    sub: u32,
    settings: &ObserverSettings,
) -> anyhow::Result<FrameScene> {
    // The reference's own levels, the others at their first: the seeds (and so the frames)
    // are the same whichever sequence the reference is rendered for.
    let own = StimulusId {
        samples: 1,
        shutter: if settings.reference == ReferenceKind::Shutter { id.shutter } else { 1 },
        ..*id
    };
    let mut scene = design.frame_scene_with(preset, &own, frame).map_err(|e| BadInput(e.to_string()))?;
    scene.samples_per_pixel = settings.reference_spp;
    scene.antialias = None;
    let (start, step) = settings.sub_frame_timing(design, &scene);
    match settings.reference {
        ReferenceKind::Shutter => {}
        ReferenceKind::Eye => {
            scene.shutter = Shutter { open: start + f64::from(sub) * step, close: start + f64::from(sub + 1) * step };
        }
        ReferenceKind::Sharp => {
            let instant = start + (f64::from(sub) + 0.5) * step;
            scene.shutter = Shutter { open: instant, close: instant };
        }
    }
    for view in &mut scene.views {
        view.seed = study::seed::mix(view.seed, &[REFERENCE_STREAM, u64::from(sub)]);
    }
    Ok(scene)
}

/// The references of one observer setting in one set: where their frames are, which are
/// still to render, and their stamps.
pub struct References<'a> {
    set_dir: &'a Path,
    design: &'a Design,
    preset: &'a Preset,
    settings: &'a ObserverSettings,
    device: render::DeviceChoice,
    /// The design's environment map, made when the first frame is rendered.
    env: std::cell::OnceCell<render::env::EnvironmentMap>,
}

impl<'a> References<'a> {
    /// The references of `settings` for the set in `set_dir`.
    pub fn new(
        set_dir: &'a Path,
        design: &'a Design,
        preset: &'a Preset,
        settings: &'a ObserverSettings,
        device: render::DeviceChoice,
    ) -> References<'a> {
        References { set_dir, design, preset, settings, device, env: std::cell::OnceCell::new() }
    }

    /// The reference `id` is judged against: its folder's name (ids with the same key share it).
    pub fn key(&self, id: &StimulusId) -> String {
        reference_key(id, self.settings.reference)
    }

    fn folder(&self, id: &StimulusId) -> PathBuf {
        observer_dir(self.set_dir).join("reference").join(self.settings.reference_folder()).join(self.key(id))
    }

    fn frame_name(frame: u32, sub: u32) -> String {
        format!("frame-{frame:04}-{sub:02}.png")
    }

    /// The frames (frame, sub-frame) of a reference in display order.
    fn frames(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (self.settings.clip.0..self.settings.clip.1).flat_map(|f| (0..self.settings.sub_frames).map(move |s| (f, s)))
    }

    /// `id`'s stamp for `frames` (none while it is rendered).
    fn stamp_for(&self, id: &StimulusId, frames: Vec<StampedFrame>) -> ReferenceStamp {
        ReferenceStamp {
            format: STAMP_FORMAT.into(),
            key: self.key(id),
            settings: self.settings.reference_folder(),
            design: self.design.name().to_owned(),
            design_sha256: self.design.sha256.clone(),
            preset: self.preset.name.clone(),
            frames,
        }
    }

    /// Whether `stamp` is `id`'s reference under these settings, design and preset (being
    /// rendered, or finished with the frames they call for).
    fn is_current(&self, id: &StimulusId, stamp: &ReferenceStamp) -> bool {
        let names = self.frames().map(|(f, s)| Self::frame_name(f, s));
        *stamp == self.stamp_for(id, stamp.frames.clone())
            && (stamp.frames.is_empty() || stamp.frames.iter().map(|f| f.png.clone()).eq(names))
    }

    /// `id`'s stamp and its file's SHA-256, if there is one; an error where the file is not
    /// a stamp.
    fn read_stamp(&self, id: &StimulusId) -> anyhow::Result<Option<(ReferenceStamp, String)>> {
        let path = self.folder(id).join(STAMP_FILE);
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(anyhow::Error::new(e).context(format!("{}: cannot read", path.display()))),
        };
        let stamp: ReferenceStamp = serde_json::from_slice(&bytes)
            .ok()
            .filter(|s: &ReferenceStamp| s.format == STAMP_FORMAT)
            .ok_or_else(|| {
                BadInput(format!(
                    "{}: not a reference stamp ({STAMP_FORMAT}); delete its folder to render the reference again",
                    path.display()
                ))
            })?;
        Ok(Some((stamp, study::fsio::sha256_hex(&bytes))))
    }

    /// Writes `id`'s stamp for `frames` atomically and returns its SHA-256.
    fn write_stamp(&self, id: &StimulusId, frames: Vec<StampedFrame>) -> anyhow::Result<String> {
        let path = self.folder(id).join(STAMP_FILE);
        let bytes = serde_json::to_vec_pretty(&self.stamp_for(id, frames))?;
        study::fsio::write_atomic(&path, &bytes).with_context(|| format!("{}: cannot write", path.display()))?;
        Ok(study::fsio::sha256_hex(&bytes))
    }

    /// The SHA-256 of `id`'s reference's stamp if the reference is finished for this design,
    /// preset and settings; `None` while it is still to render (or to render again).
    pub fn identity(&self, id: &StimulusId) -> anyhow::Result<Option<String>> {
        Ok(self
            .read_stamp(id)?
            .filter(|(stamp, _)| !stamp.frames.is_empty() && self.is_current(id, stamp))
            .map(|(_, sha256)| sha256))
    }

    /// How many reference frames of `ids` are still to render.
    pub fn missing(&self, ids: &[StimulusId]) -> anyhow::Result<usize> {
        let mut n = 0;
        let mut seen = std::collections::BTreeSet::new();
        for id in ids {
            if seen.insert(self.key(id)) {
                let resumable = self.read_stamp(id)?.is_some_and(|(stamp, _)| self.is_current(id, &stamp));
                let folder = self.folder(id);
                n +=
                    self.frames().filter(|&(f, s)| !resumable || !folder.join(Self::frame_name(f, s)).exists()).count();
            }
        }
        Ok(n)
    }

    /// Removes the frames in `id`'s folder (`frame-*.png`) that no stamp of this design vouches
    /// for, saying why.
    fn remove_frames(&self, id: &StimulusId, why: &str) -> anyhow::Result<()> {
        let folder = self.folder(id);
        let mut removed = 0;
        for entry in std::fs::read_dir(&folder).with_context(|| format!("{}: cannot list", folder.display()))? {
            let path = entry?.path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if name.starts_with("frame-") && name.ends_with(".png") {
                std::fs::remove_file(&path).with_context(|| format!("{}: cannot remove", path.display()))?;
                removed += 1;
            }
        }
        if removed > 0 {
            eprintln!("{}: {why}: rendering the reference again", folder.display());
        }
        Ok(())
    }

    /// `id`'s reference frames and the SHA-256 of its stamp: frames on disk are read (each
    /// checked against the stamp once it is finished), missing ones rendered (each written
    /// atomically, so an interrupted render resumes at the first missing frame), and the stamp
    /// finished after the last frame. A frame that does not hash as stamped is rendered again;
    /// a reference of another design or preset, or unstamped frames, are rendered again whole.
    pub fn load_or_render<'e>(
        &'e self,
        id: &StimulusId,
        renderer: &mut Option<render::Renderer<'e>>,
        progress: &indicatif::ProgressBar,
    ) -> anyhow::Result<(Vec<SrgbImage>, String)> {
        let eyes = if id.view == View::Stereo { 2 } else { 1 };
        let (w, h) = (self.preset.width * eyes, self.preset.height);
        let folder = self.folder(id);
        std::fs::create_dir_all(&folder).with_context(|| format!("{}: cannot create", folder.display()))?;
        // The finished stamp (and its hash) the frames on disk are checked against, if any.
        let mut finished = None;
        match self.read_stamp(id)? {
            Some((stamp, sha256)) if self.is_current(id, &stamp) => {
                if !stamp.frames.is_empty() {
                    finished = Some((stamp, sha256));
                }
            }
            Some((stale, _)) => {
                let why = format!(
                    "rendered for design `{}` ({}) with preset `{}`, settings `{}`; this set is design `{}` ({}) with preset `{}`",
                    stale.design,
                    short(&stale.design_sha256),
                    stale.preset,
                    stale.settings,
                    self.design.name(),
                    short(&self.design.sha256),
                    self.preset.name
                );
                self.remove_frames(id, &why)?;
                self.write_stamp(id, Vec::new())?;
            }
            None => {
                self.remove_frames(id, "frames without a stamp (rendered before references were stamped)")?;
                self.write_stamp(id, Vec::new())?;
            }
        }
        let mut unchanged = finished.is_some();
        let method = self.design.method_with(id, Some(study::Method::Tracer)).map_err(|e| BadInput(e.to_string()))?;
        let mut out = Vec::new();
        let mut hashes = Vec::new();
        for (frame, sub) in self.frames().collect::<Vec<_>>() {
            let png = Self::frame_name(frame, sub);
            let path = folder.join(&png);
            let mut found = None;
            if path.exists() {
                let sha =
                    study::fsio::sha256_file(&path).with_context(|| format!("{}: cannot read", path.display()))?;
                let stamped = finished.as_ref().map(|(s, _)| &s.frames[hashes.len()].png_sha256);
                if stamped.is_some_and(|s| *s != sha) {
                    eprintln!("{}: does not hash as its reference's stamp records; rendering it again", path.display());
                    progress.inc_length(1);
                } else {
                    found = Some((runner::flip_observer::read_srgb(&path, w, h)?, sha));
                }
            }
            let (image, sha) = match found {
                Some(found) => found,
                None => {
                    if unchanged {
                        // Back to being rendered, so that a kill leaves no stamp vouching for
                        // frames it does not describe.
                        self.write_stamp(id, Vec::new())?;
                        unchanged = false;
                    }
                    let r = match renderer {
                        Some(r) => r,
                        None => {
                            let env = match self.env.get() {
                                Some(env) => env,
                                None => {
                                    let map = render::env::EnvironmentMap::from_lighting(&self.design.lighting)
                                        .map_err(|e| BadInput(e.to_string()))?;
                                    self.env.get_or_init(|| map)
                                }
                            };
                            renderer.insert(render::Renderer::open(self.device, env)?)
                        }
                    };
                    let scene = reference_scene(self.design, self.preset, id, frame, sub, self.settings)?;
                    let rendered = r.render(&method, &scene)?;
                    let rgb = render::io::to_srgb8(&rendered.image, &scene.exposure);
                    let bytes = render::io::encode_png_rgb8(rendered.image.width, rendered.image.height, &rgb);
                    study::fsio::write_atomic(&path, &bytes)
                        .with_context(|| format!("{}: cannot write", path.display()))?;
                    progress.inc(1);
                    let image = SrgbImage::new(w, h, rgb).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
                    (image, study::fsio::sha256_hex(&bytes))
                }
            };
            out.push(image);
            hashes.push(StampedFrame { png, png_sha256: sha });
        }
        let sha256 = match finished {
            Some((_, sha256)) if unchanged => sha256,
            _ => self.write_stamp(id, hashes)?,
        };
        Ok((out, sha256))
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// The shipped design and its clip preset.
    pub(in crate::cmd::predict) fn shipped() -> (Design, Preset) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
        let design = Design::load(&path).expect("the shipped design loads");
        let preset = design.preset("clip").expect("the design has a clip preset");
        (design, preset)
    }

    /// `kind`'s settings at 64 samples per pixel, 4 sub-frames, clip frames 15-16.
    pub(in crate::cmd::predict) fn settings(design: &Design, preset: &Preset, kind: ReferenceKind) -> ObserverSettings {
        ObserverSettings::new(design, preset, kind, Some(64), 4, Some((15, 17))).expect("valid settings")
    }

    #[test]
    fn each_reference_sees_the_frame_interval_as_its_definition_says() {
        let (design, preset) = shipped();
        let id: StimulusId = "M2-S2-T5-A3".parse().expect("an id");
        let fps = design.spec.sequence.fps;
        let stimulus = design.frame_scene_with(&preset, &id, 16).expect("the stimulus's scene");
        let start = stimulus.frame_time - design.spec.sequence.frame_time_offset / fps;
        let sub = 1.0 / (4.0 * fps);

        let shutter = settings(&design, &preset, ReferenceKind::Shutter);
        assert_eq!(shutter.sub_frames, 1);
        let s = reference_scene(&design, &preset, &id, 16, 0, &shutter).expect("scene");
        assert_eq!((s.shutter, s.samples_per_pixel), (stimulus.shutter, 64));

        // `eye`: four sub-frames tiling the frame interval, each open for its quarter.
        let eye = settings(&design, &preset, ReferenceKind::Eye);
        let mut edge = start;
        for k in 0..4 {
            let s = reference_scene(&design, &preset, &id, 16, k, &eye).expect("scene");
            assert!((s.shutter.open - edge).abs() < 1e-12 && (s.shutter.close - edge - sub).abs() < 1e-12);
            edge = s.shutter.close;
        }
        assert!((edge - start - 1.0 / fps).abs() < 1e-12);

        // `sharp`: the same sub-frames closed to the instant at each one's middle.
        let sharp = settings(&design, &preset, ReferenceKind::Sharp);
        assert_eq!(sharp.sub_frames, 4);
        for k in 0..4 {
            let s = reference_scene(&design, &preset, &id, 16, k, &sharp).expect("scene");
            let e = reference_scene(&design, &preset, &id, 16, k, &eye).expect("scene");
            assert!(!s.shutter.is_open_interval(), "sub-frame {k}: {:?}", s.shutter);
            assert!((s.shutter.open - 0.5 * (e.shutter.open + e.shutter.close)).abs() < 1e-12);
            // The seeds differ from the stimulus's and between sub-frames.
            assert_ne!(s.views[0].seed, stimulus.views[0].seed);
        }
        let seeds: std::collections::BTreeSet<u64> = (0..4)
            .map(|k| reference_scene(&design, &preset, &id, 16, k, &sharp).expect("scene").views[0].seed)
            .collect();
        assert_eq!(seeds.len(), 4);

        // Each kind keeps its frames apart from the others'.
        let folders: std::collections::BTreeSet<String> =
            [&shutter, &eye, &sharp].iter().map(|s| s.reference_folder()).collect();
        assert_eq!(folders.len(), 3);
        assert_eq!(reference_key(&id, ReferenceKind::Sharp), "M2-S2");
        assert_eq!(reference_key(&id, ReferenceKind::Shutter), "M2-S2-T5");

        // A reference's scene, seeds included, comes from its own levels alone: the same for
        // every sequence that shares it, whichever asks first.
        let scene = |text: &str, settings: &ObserverSettings| {
            reference_scene(&design, &preset, &text.parse().expect("an id"), 16, 1, settings).expect("scene")
        };
        for (settings, same, other) in [
            (&sharp, "M2-S2-T1-A5", "M2-S1-T5-A3"),
            (&eye, "M2-S2-T3-A1", "M3-S2-T5-A3"),
            (&shutter, "M2-S2-T5-A5", "M2-S2-T4-A3"),
        ] {
            let name = settings.reference.name();
            assert_eq!(scene("M2-S2-T5-A3", settings), scene(same, settings), "{name}: {same}");
            assert_ne!(scene("M2-S2-T5-A3", settings), scene(other, settings), "{name}: {other}");
        }
        assert_ne!(scene("M2-S2-T5-A3", &sharp).views[0].seed, scene("M2-S2-T5-A3-stereo", &sharp).views[0].seed);
    }
}
