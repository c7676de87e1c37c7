//! The ColorVideoVDP observer's qualities: each sequence of a stimulus set judged once against
//! its reference, over a clip of its frames, with the references rendered once and both
//! cached in the set folder (`SET/observer/`), so that a killed prediction resumes where it
//! stopped and every later prediction reuses them.
//!
//! References (what each sequence is compared with, [`ReferenceKind`]):
//! - `shutter`: the converged tracer rendering of the same material, speed, shutter and view
//!   (fidelity within a shutter: only noise costs quality);
//! - `eye`: the motion as the eye would see it, the same material, speed and view without a
//!   camera shutter: `K` sub-frames per displayed frame, each averaging its own `1/(K fps)` of
//!   the frame interval (what a display `K` times faster would show of the continuous
//!   motion). The test clip is held for `K` sub-frames, as the display holds it, so that
//!   ColorVideoVDP's temporal channels judge strobing (too little blur) and smear (too much)
//!   as well as noise.
//! - `sharp`: the motion without any blur, the same material, speed and view: `K` sub-frames
//!   per displayed frame, each the instant at the middle of its `1/(K fps)` (what a display
//!   `K` times faster would show with a closed shutter). Against it every blur costs quality,
//!   and so does the held frame's jump between displayed frames; people who were asked which
//!   sequence they preferred chose the sharper one (BENCHMARKS.md, "The ColorVideoVDP
//!   observer").
//!
//! Reference frames are rendered with the set's design and preset, at `reference_spp`
//! samples per pixel, and stamped with what they were rendered from ([`super::reference`]); a
//! cached score holds only while the manifests of the sequences and the stamp of the reference
//! it was judged from are the present ones.
//!
//! Eye movements ([`EyeMovement`]): the metric sees the screen as a fixating eye does, unless
//! the observer pursues the sphere: then every sub-frame of the test (held) and of the
//! reference is resampled around the sphere's centre at that sub-frame's middle instant, in
//! each eye's image (`perceptual::pursuit`), so the sphere stands still on the retina and a
//! held frame slides back while the gaze moves on. The gaze stays on the screen: while the
//! sphere is out of view it rests at the edge it left by, and it jumps to where it re-enters.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use perceptual::SrgbImage;
use perceptual::cvvdp::{Clip, DisplayConditions, Judgement, Threads, VideoObserver};
use runner::stimuli::StimulusSet;
use serde::{Deserialize, Serialize};
use study::StimulusId;
use study::design::{Design, Preset};
use study::scene::FrameScene;

use super::reference::References;
use crate::cmd::BadInput;

/// Sub-frames per displayed frame of the `eye` reference unless asked otherwise.
pub const DEFAULT_SUB_FRAMES: u32 = 4;

/// Format tag of the score cache.
const SCORES_FORMAT: &str = "blurlab-observer-scores/3";

/// Format tag of the score cache before references were stamped: its scores name no
/// reference, so only its pairs' (judged against each other) still hold.
const UNSTAMPED_SCORES_FORMAT: &str = "blurlab-observer-scores/2";

/// What each sequence is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReferenceKind {
    /// The converged rendering of the same shutter.
    Shutter,
    /// The continuous motion without a camera shutter, at several sub-frames per frame.
    Eye,
    /// The motion without blur: an instant per sub-frame, several sub-frames per frame.
    Sharp,
}

impl ReferenceKind {
    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            ReferenceKind::Shutter => "shutter",
            ReferenceKind::Eye => "eye",
            ReferenceKind::Sharp => "sharp",
        }
    }

    /// Whether the reference runs at several sub-frames per displayed frame.
    pub fn has_sub_frames(self) -> bool {
        matches!(self, ReferenceKind::Eye | ReferenceKind::Sharp)
    }
}

/// How the observer's eyes move while a sequence plays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EyeMovement {
    /// The eyes rest: the metric judges the frames as they lie on the screen.
    #[default]
    Fixation,
    /// The eyes follow the sphere (smooth pursuit).
    Pursuit,
}

impl EyeMovement {
    fn is_fixation(&self) -> bool {
        *self == EyeMovement::Fixation
    }
}

/// Everything a quality depends on besides the set's frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObserverSettings {
    /// The reference.
    pub reference: ReferenceKind,
    /// Samples per pixel of each reference frame (or sub-frame).
    pub reference_spp: u32,
    /// Sub-frames per displayed frame of the `eye` and `sharp` references (1 for `shutter`).
    pub sub_frames: u32,
    /// The clip: frames `first..end` of the set's sequences (0-based, end excluded).
    pub clip: (u32, u32),
    /// Pixels of one eye's image per degree.
    pub pixels_per_degree: f64,
    /// Frames per second the sequences are shown at.
    pub fps: f64,
    /// Display peak luminance, cd/m².
    pub peak_luminance: f64,
    /// Display black level, cd/m².
    pub black_level: f64,
    /// Ambient illuminance, lux.
    pub ambient_lux: f64,
    /// The metric's version.
    pub metric: String,
    /// How the eyes move (absent in the cache's name for fixation, so that scores cached
    /// before pursuit existed keep their names).
    #[serde(default, skip_serializing_if = "EyeMovement::is_fixation")]
    pub eye_movement: EyeMovement,
}

impl ObserverSettings {
    /// The settings for `set`'s design and preset: the display from the design's `[viewing]`.
    pub fn new(
        design: &Design,
        preset: &Preset,
        reference: ReferenceKind,
        reference_spp: Option<u32>,
        sub_frames: u32,
        clip: Option<(u32, u32)>,
    ) -> anyhow::Result<ObserverSettings> {
        let clip = clip.unwrap_or((0, preset.frames));
        if clip.0 >= clip.1 || clip.1 > preset.frames {
            return Err(BadInput(format!(
                "--clip {}..{}: the set's sequences (preset `{}`) have frames 0..{}; a clip needs at least one of them",
                clip.0, clip.1, preset.name, preset.frames
            ))
            .into());
        }
        if !(1..=64).contains(&sub_frames) {
            return Err(BadInput(format!("--sub-frames {sub_frames}: expected 1 to 64")).into());
        }
        let top = preset.samples_per_pixel.iter().copied().max().unwrap_or(1);
        let reference_spp = reference_spp.unwrap_or(2 * top);
        if reference_spp == 0 || reference_spp > 1 << 20 {
            return Err(BadInput(format!("--reference-spp {reference_spp}: expected 1 to 1048576")).into());
        }
        let v = &design.spec.viewing;
        Ok(ObserverSettings {
            reference,
            reference_spp,
            sub_frames: if reference.has_sub_frames() { sub_frames } else { 1 },
            clip,
            pixels_per_degree: design.pixels_per_degree(preset.width),
            fps: design.spec.sequence.fps,
            peak_luminance: v.peak_luminance,
            black_level: v.black_level,
            ambient_lux: v.ambient_lux,
            metric: format!("ColorVideoVDP {} (colorvideovdp crate 0.1)", colorvideovdp::Cvvdp::MODEL_VERSION),
            eye_movement: EyeMovement::Fixation,
        })
    }

    /// These settings with the eyes moving as `eye_movement` says.
    pub fn with_eye_movement(self, eye_movement: EyeMovement) -> ObserverSettings {
        ObserverSettings { eye_movement, ..self }
    }

    /// Where `scene`'s frame interval starts and how long each of its sub-frames lasts (one
    /// sub-frame per frame for `shutter`).
    pub(super) fn sub_frame_timing(&self, design: &Design, scene: &FrameScene) -> (f64, f64) {
        let fps = design.spec.sequence.fps;
        let start = scene.frame_time - design.spec.sequence.frame_time_offset / fps;
        (start, 1.0 / (fps * f64::from(self.sub_frames)))
    }

    /// The middle instant of each sub-frame of `scene`'s frame.
    fn sub_frame_instants(&self, design: &Design, scene: &FrameScene) -> Vec<f64> {
        let (start, step) = self.sub_frame_timing(design, scene);
        (0..self.sub_frames).map(|s| start + (f64::from(s) + 0.5) * step).collect()
    }

    /// The display conditions.
    pub fn display(&self) -> DisplayConditions {
        DisplayConditions {
            pixels_per_degree: self.pixels_per_degree,
            peak_luminance: self.peak_luminance,
            black_level: self.black_level,
            ambient_lux: self.ambient_lux,
        }
    }

    /// The reference folder's name: kind, samples, sub-frames and clip.
    pub(super) fn reference_folder(&self) -> String {
        match self.reference {
            ReferenceKind::Shutter => format!("shutter-{}spp-f{}-{}", self.reference_spp, self.clip.0, self.clip.1),
            ReferenceKind::Eye | ReferenceKind::Sharp => format!(
                "{}-{}spp-{}sub-f{}-{}",
                self.reference.name(),
                self.reference_spp,
                self.sub_frames,
                self.clip.0,
                self.clip.1
            ),
        }
    }

    /// A short hash of the settings (the score cache's name).
    fn key(&self) -> anyhow::Result<String> {
        let json = serde_json::to_vec(self)?;
        Ok(study::fsio::sha256_hex(&json)[..16].to_owned())
    }
}

/// The cached qualities of one set under one setting, each stamped with the manifests of the
/// sequences it was judged from and the stamp of its rendered reference, so that rendering
/// more sequences into the set (or re-rendering some) keeps every other score, and a reference
/// rendered again drops the scores judged against the old one.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ScoreCache {
    format: String,
    settings: ObserverSettings,
    /// Per key (a sequence's id, or `TEST against REFERENCE` for a pair): the JOD of each eye
    /// and the manifests judged.
    scores: BTreeMap<String, CachedScore>,
}

/// One cached quality.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct CachedScore {
    /// SHA-256 of the manifest of each sequence judged (the test first, then a pair's
    /// reference), as the set's index records them.
    manifests: Vec<String>,
    /// SHA-256 of the stamp of the rendered reference it was judged against (none for a pair,
    /// judged against another sequence, or for a score cached before references were stamped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    reference_sha256: Option<String>,
    /// Each eye's JOD.
    eyes: Vec<f64>,
}

/// What a score was judged against, besides the sequences its key names.
#[derive(Clone, Copy, Debug)]
enum Against<'a> {
    /// Another sequence of the set (a pair): nothing rendered.
    Sequence,
    /// A finished rendered reference: its stamp's SHA-256.
    Rendered(&'a str),
    /// A rendered reference still to render (or to render again): no score holds.
    Unfinished,
}

impl<'a> Against<'a> {
    /// A rendered reference: finished with `identity`, or not.
    fn reference(identity: &'a Option<String>) -> Against<'a> {
        identity.as_deref().map_or(Against::Unfinished, Against::Rendered)
    }
}

impl CachedScore {
    /// Whether this score was judged against `against`.
    fn judged_against(&self, against: Against) -> bool {
        match (against, &self.reference_sha256) {
            (Against::Sequence, None) => true,
            (Against::Rendered(r), Some(sha)) => sha == r,
            _ => false,
        }
    }
}

/// The score cache of earlier versions, keyed by the whole set's content hash.
#[derive(Deserialize)]
struct WholeSetScoreCache {
    format: String,
    stimulus_set_sha256: String,
    settings: ObserverSettings,
    scores: BTreeMap<String, Vec<f64>>,
}

/// Format tag of the score cache of earlier versions.
const WHOLE_SET_SCORES_FORMAT: &str = "blurlab-observer-scores/1";

/// The manifests a cache key names in `set` (the test first), or `None` where the key is not
/// one or the set does not hold its sequences.
fn key_manifests(set: &StimulusSet, key: &str) -> Option<Vec<String>> {
    key.split(" against ")
        .map(|id| {
            let id: StimulusId = id.parse().ok()?;
            set.index.manifest_sha256(id).map(str::to_owned)
        })
        .collect()
}

impl ScoreCache {
    /// The cache at `path` for `set` under `settings`, holding only the scores judged from
    /// the set's present sequences; empty where there is none yet, or where the file holds
    /// another setting's scores under a colliding name. A cache of the earlier whole-set
    /// format is taken in where it was computed from this very set.
    fn open(path: &Path, set: &StimulusSet, settings: &ObserverSettings) -> anyhow::Result<ScoreCache> {
        let mut cache =
            ScoreCache { format: SCORES_FORMAT.into(), settings: settings.clone(), scores: BTreeMap::new() };
        let bytes = match std::fs::read(path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(cache),
            Err(e) => return Err(anyhow::Error::new(e).context(format!("{}: cannot read", path.display()))),
        };
        let not_a_cache = || format!("{}: not a score cache ({SCORES_FORMAT}); delete it to recompute", path.display());
        let format = serde_json::from_slice::<serde_json::Value>(&bytes).with_context(not_a_cache)?["format"].clone();
        if format == WHOLE_SET_SCORES_FORMAT {
            let old: WholeSetScoreCache = serde_json::from_slice(&bytes).with_context(not_a_cache)?;
            if old.format == WHOLE_SET_SCORES_FORMAT
                && old.settings == *settings
                && old.stimulus_set_sha256 == set.sha256
            {
                for (key, eyes) in old.scores {
                    if let Some(manifests) = key_manifests(set, &key) {
                        cache.scores.insert(key, CachedScore { manifests, reference_sha256: None, eyes });
                    }
                }
            }
            return Ok(cache);
        }
        let stored: ScoreCache = serde_json::from_slice(&bytes).with_context(not_a_cache)?;
        if [SCORES_FORMAT, UNSTAMPED_SCORES_FORMAT].contains(&stored.format.as_str()) && stored.settings == *settings {
            cache.scores = stored
                .scores
                .into_iter()
                .filter(|(key, score)| key_manifests(set, key).as_ref() == Some(&score.manifests))
                .collect();
        }
        Ok(cache)
    }

    /// The cached JOD of each eye under `key`, if it was judged from `set`'s present sequences
    /// against `against`.
    fn get(&self, set: &StimulusSet, key: &str, against: Against) -> Option<&Vec<f64>> {
        let score = self.scores.get(key)?;
        (key_manifests(set, key).as_ref() == Some(&score.manifests) && score.judged_against(against))
            .then_some(&score.eyes)
    }

    /// Records the JOD of each eye under `key`, judged from `set`'s present sequences against
    /// `against` (a finished reference or another sequence).
    fn insert(&mut self, set: &StimulusSet, key: String, against: Against, eyes: Vec<f64>) -> anyhow::Result<()> {
        let manifests = key_manifests(set, &key)
            .ok_or_else(|| anyhow::anyhow!("{key}: not a sequence (or pair of sequences) of {}", set.dir.display()))?;
        let reference_sha256 = match against {
            Against::Sequence => None,
            Against::Rendered(r) => Some(r.to_owned()),
            Against::Unfinished => anyhow::bail!("{key}: judged against a reference that is not finished"),
        };
        self.scores.insert(key, CachedScore { manifests, reference_sha256, eyes });
        Ok(())
    }

    /// Writes the cache to `path` atomically, first taking in the scores another prediction
    /// under the same settings wrote there since this one read it (two predictions running
    /// side by side would otherwise drop each other's scores); a score of its own wins.
    fn save(&mut self, path: &Path) -> anyhow::Result<()> {
        if let Ok(bytes) = std::fs::read(path)
            && let Ok(other) = serde_json::from_slice::<ScoreCache>(&bytes)
            && other.format == self.format
            && other.settings == self.settings
        {
            for (key, score) in other.scores {
                self.scores.entry(key).or_insert(score);
            }
        }
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
        }
        study::fsio::write_atomic(path, &serde_json::to_vec_pretty(self)?)
            .with_context(|| format!("{}: cannot write", path.display()))
    }
}

/// Where the observer keeps its work in a set.
pub fn observer_dir(set: &Path) -> PathBuf {
    set.join("observer")
}

/// Where each eye looks at each sub-frame of `id`'s clip when it follows the sphere: the
/// projection of the sphere's centre at the sub-frame's middle instant, kept on the screen.
fn pursuit_gaze(
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    settings: &ObserverSettings,
) -> anyhow::Result<Vec<Vec<perceptual::pursuit::Gaze>>> {
    let mut out = Vec::new();
    for frame in settings.clip.0..settings.clip.1 {
        let scene = design.frame_scene_with(preset, id, frame).map_err(|e| BadInput(e.to_string()))?;
        for t in settings.sub_frame_instants(design, &scene) {
            let centre = scene.sphere.centre_at(t);
            let gaze = scene
                .views
                .iter()
                .map(|view| {
                    let c = &view.camera;
                    let p = c.project(centre).ok_or_else(|| {
                        BadInput(format!("{id}, frame {frame}: the sphere is behind the {:?} camera", view.eye))
                    })?;
                    Ok(perceptual::pursuit::Gaze {
                        x: p.x.clamp(0.0, f64::from(c.width)),
                        y: p.y.clamp(0.0, f64::from(c.height)),
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            out.push(gaze);
        }
    }
    Ok(out)
}

/// Frames `settings.clip` of `id`'s sequence in the set, and the eyes side by side in them.
fn load_clip(set: &StimulusSet, id: &StimulusId, settings: &ObserverSettings) -> anyhow::Result<(Vec<SrgbImage>, u32)> {
    let mut frames = runner::flip_observer::load_frames(set, id)?;
    let (first, end) = (settings.clip.0 as usize, settings.clip.1 as usize);
    if end > frames.images.len() {
        return Err(BadInput(format!(
            "--clip {first}..{end}: sequence {id} has {} frames in {}",
            frames.images.len(),
            set.dir.display()
        ))
        .into());
    }
    Ok((frames.images.drain(first..end).collect(), frames.eyes))
}

/// Where a pursuing eye looks at each sub-frame of `id`'s clip ([`pursuit_gaze`]), or `None`
/// for a fixating one.
fn pursuit_gaze_if_pursuing(
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    settings: &ObserverSettings,
) -> anyhow::Result<Option<Vec<Vec<perceptual::pursuit::Gaze>>>> {
    match settings.eye_movement {
        EyeMovement::Fixation => Ok(None),
        EyeMovement::Pursuit => pursuit_gaze(design, preset, id, settings).map(Some),
    }
}

/// `id`'s clip as the metric sees it, and its rate: the frames as shown for a fixating eye
/// (no `gaze`), else each held for the settings' sub-frames and followed along `gaze`.
fn clip_as_seen(
    clip: Vec<SrgbImage>,
    eyes: u32,
    id: &StimulusId,
    settings: &ObserverSettings,
    gaze: Option<&[Vec<perceptual::pursuit::Gaze>]>,
) -> anyhow::Result<(Vec<SrgbImage>, f64)> {
    match gaze {
        None => Ok((clip, settings.fps)),
        Some(gaze) => {
            let held = perceptual::pursuit::retinal_clip(&clip, settings.sub_frames, eyes, gaze)
                .with_context(|| format!("{id}: following the sphere"))?;
            Ok((held, settings.fps * f64::from(settings.sub_frames)))
        }
    }
}

/// The observer's progress bar over `len` steps of `what` (hidden when there are none).
fn progress_bar(len: usize, what: &str) -> indicatif::ProgressBar {
    if len == 0 {
        return indicatif::ProgressBar::hidden();
    }
    let template = format!("observer {{bar:40}} {{pos}}/{{len}} {what} ({{msg}}) {{elapsed}} ETA {{eta}}");
    indicatif::ProgressBar::new(len as u64).with_style(
        indicatif::ProgressStyle::with_template(&template).unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    )
}

/// A sequence's quality and the reference it was judged against.
#[derive(Clone, Debug)]
pub struct Quality {
    /// Each eye's JOD.
    pub judgement: Judgement,
    /// SHA-256 of the reference's stamp ([`super::reference`]).
    pub reference_sha256: String,
}

/// Each stimulus's quality (each eye's JOD) under `settings`, from the cache where it holds
/// them, else judged (references rendered as needed) and cached one by one.
pub fn qualities(
    set: &StimulusSet,
    design: &Design,
    preset: &Preset,
    ids: &[StimulusId],
    settings: &ObserverSettings,
    device: render::DeviceChoice,
) -> anyhow::Result<BTreeMap<StimulusId, Quality>> {
    let cache_path = observer_dir(&set.dir).join(format!("scores-{}.json", settings.key()?));
    let mut cache = ScoreCache::open(&cache_path, set, settings)?;
    let references = References::new(&set.dir, design, preset, settings, device);
    let found: BTreeMap<StimulusId, Option<String>> =
        ids.iter().map(|id| Ok((*id, references.identity(id)?))).collect::<anyhow::Result<_>>()?;
    let todo: Vec<StimulusId> = ids
        .iter()
        .filter(|id| cache.get(set, &id.to_string(), Against::reference(&found[*id])).is_none())
        .copied()
        .collect();
    let to_render = references.missing(&todo)?;
    let progress = progress_bar(to_render + todo.len(), "reference frames and sequences");
    let observer = VideoObserver::new(settings.display(), Threads::Pool).map_err(|e| BadInput(e.to_string()))?;
    let mut renderer = None;
    // Each reference the sequences still to judge need is loaded (rendered, checked, mended)
    // once, before any sequence is judged against it: a reference that changes on the way
    // (a frame rendered again) drops the scores judged against the old one, and those
    // sequences are judged again.
    let mut judged_against: BTreeMap<StimulusId, String> = BTreeMap::new();
    let mut loaded = std::collections::BTreeSet::new();
    for first in &todo {
        let key = references.key(first);
        if !loaded.insert(key.clone()) {
            continue;
        }
        progress.set_message(first.to_string());
        let (reference, identity) = references.load_or_render(first, &mut renderer, &progress)?;
        for id in ids.iter().filter(|id| references.key(id) == key) {
            if cache.get(set, &id.to_string(), Against::Rendered(&identity)).is_none() {
                if !todo.contains(id) {
                    progress.inc_length(1);
                }
                progress.set_message(id.to_string());
                let judgement = judge_against_reference(&observer, set, design, preset, id, settings, &reference)?;
                cache.insert(set, id.to_string(), Against::Rendered(&identity), judgement.eyes)?;
                cache.save(&cache_path)?;
                progress.inc(1);
            }
            judged_against.insert(*id, identity.clone());
        }
    }
    progress.finish_and_clear();
    let mut out = BTreeMap::new();
    for (id, found) in found {
        let identity = judged_against
            .remove(&id)
            .or(found)
            .ok_or_else(|| anyhow::anyhow!("{id}: its reference was not rendered"))?;
        let eyes = cache
            .get(set, &id.to_string(), Against::Rendered(&identity))
            .ok_or_else(|| anyhow::anyhow!("{id}: no score judged against its reference"))?;
        out.insert(id, Quality { judgement: Judgement { eyes: eyes.clone() }, reference_sha256: identity });
    }
    Ok(out)
}

/// `id`'s clip judged against the frames of its rendered `reference` (both followed by a
/// pursuing eye).
fn judge_against_reference(
    observer: &VideoObserver,
    set: &StimulusSet,
    design: &Design,
    preset: &Preset,
    id: &StimulusId,
    settings: &ObserverSettings,
    reference: &[SrgbImage],
) -> anyhow::Result<Judgement> {
    let (test, eyes) = load_clip(set, id, settings)?;
    let gaze = pursuit_gaze_if_pursuing(design, preset, id, settings)?;
    let (test, test_fps) = clip_as_seen(test, eyes, id, settings, gaze.as_deref())?;
    let followed;
    let reference = match &gaze {
        None => reference,
        Some(gaze) => {
            followed = reference
                .iter()
                .zip(gaze)
                .map(|(f, g)| perceptual::pursuit::retinal_image(f, eyes, g))
                .collect::<Result<Vec<_>, _>>()
                .with_context(|| format!("{id}: following the sphere in the reference"))?;
            &followed[..]
        }
    };
    let sub_fps = settings.fps * f64::from(settings.sub_frames);
    observer
        .judge(&Clip { frames: &test, fps: test_fps }, &Clip { frames: reference, fps: sub_fps }, eyes)
        .with_context(|| format!("judging {id}"))
}

/// The key of a pair in a pair cache.
fn pair_key(reference: &StimulusId, test: &StimulusId) -> String {
    format!("{test} against {reference}")
}

/// Each pair's quality: the `test` sequence judged with another sequence of the set, the
/// pair's `reference`, as its reference, over the clip (no rendered reference). Under
/// fixation both clips are judged at the frame rate; under pursuit each is held for the
/// settings' sub-frames and followed around its own sphere. Cached one pair at a time in
/// `SET/observer/pairs-KEY.json`, so a killed prediction resumes.
pub fn pair_qualities(
    set: &StimulusSet,
    design: &Design,
    preset: &Preset,
    pairs: &[(StimulusId, StimulusId)],
    settings: &ObserverSettings,
) -> anyhow::Result<BTreeMap<(StimulusId, StimulusId), Judgement>> {
    let cache_path = observer_dir(&set.dir).join(format!("pairs-{}.json", settings.key()?));
    let mut cache = ScoreCache::open(&cache_path, set, settings)?;
    let todo: Vec<&(StimulusId, StimulusId)> =
        pairs.iter().filter(|(r, t)| cache.get(set, &pair_key(r, t), Against::Sequence).is_none()).collect();
    let progress = progress_bar(todo.len(), "pairs");
    let observer = VideoObserver::new(settings.display(), Threads::Pool).map_err(|e| BadInput(e.to_string()))?;
    // Each sequence's clip as the metric sees it, loaded once: the frames (held and followed
    // under pursuit), their rate and the eyes side by side.
    let mut clips: BTreeMap<StimulusId, (Vec<SrgbImage>, f64, u32)> = BTreeMap::new();
    for (r, t) in todo {
        progress.set_message(format!("{t} against {r}"));
        for id in [r, t] {
            if clips.contains_key(id) {
                continue;
            }
            let (clip, eyes) = load_clip(set, id, settings)?;
            let gaze = pursuit_gaze_if_pursuing(design, preset, id, settings)?;
            let (seen, fps) = clip_as_seen(clip, eyes, id, settings, gaze.as_deref())?;
            clips.insert(*id, (seen, fps, eyes));
        }
        let ((test, fps, eyes), (reference, ..)) = (&clips[t], &clips[r]);
        let judgement = observer
            .judge(&Clip { frames: test, fps: *fps }, &Clip { frames: reference, fps: *fps }, *eyes)
            .with_context(|| format!("judging {t} against {r}"))?;
        cache.insert(set, pair_key(r, t), Against::Sequence, judgement.eyes)?;
        cache.save(&cache_path)?;
        progress.inc(1);
    }
    progress.finish_and_clear();
    Ok(pairs
        .iter()
        .filter_map(|(r, t)| {
            cache.get(set, &pair_key(r, t), Against::Sequence).map(|eyes| ((*r, *t), Judgement { eyes: eyes.clone() }))
        })
        .collect())
}

/// JOD distances `10 - Q(candidate against reference)` of each `(reference, candidate)` pair,
/// over the clip (matching trials: the candidate nearer the shown reference is picked).
pub fn distances(
    set: &StimulusSet,
    design: &Design,
    preset: &Preset,
    pairs: &[(StimulusId, StimulusId)],
    settings: &ObserverSettings,
) -> anyhow::Result<BTreeMap<(StimulusId, StimulusId), f64>> {
    Ok(pair_qualities(set, design, preset, pairs, settings)?.into_iter().map(|(k, j)| (k, 10.0 - j.jod())).collect())
}

#[cfg(test)]
mod tests {
    use super::super::reference::reference_scene;
    use super::super::reference::tests::{settings, shipped};
    use super::*;

    /// A set of the sequences `(id, manifest sha256)` as its index lists them (no files).
    fn indexed_set(entries: &[(&str, &str)]) -> StimulusSet {
        let index = study::manifest::SetIndex {
            format: study::manifest::INDEX_FORMAT.into(),
            design: "navarro2011".into(),
            design_sha256: "design".into(),
            preset: "clip".into(),
            sampling: Default::default(),
            sequences: entries
                .iter()
                .map(|(id, sha)| study::manifest::IndexEntry {
                    id: id.parse().expect("an id"),
                    folder: (*id).to_owned(),
                    manifest_sha256: (*sha).to_owned(),
                })
                .collect(),
        };
        StimulusSet {
            dir: PathBuf::from("set"),
            sha256: index.content_sha256(),
            index,
            index_sha256: String::new(),
            sequences: BTreeMap::new(),
        }
    }

    #[test]
    fn cached_scores_outlive_changes_to_other_sequences_of_the_set() {
        let (design, preset) = shipped();
        let settings = settings(&design, &preset, ReferenceKind::Sharp);
        let dir = std::env::temp_dir().join(format!("blurlab-score-cache-{}", std::process::id()));
        let path = dir.join("scores.json");
        let (a, b, c) = ("M1-S1-T1-A1", "M1-S1-T1-A2", "M1-S1-T1-A3");
        let pair = format!("{a} against {b}");
        let set = indexed_set(&[(a, "a"), (b, "b")]);
        let (rendered, itself) = (Against::Rendered("r1"), Against::Sequence);
        let against = |key: &str| if key.contains(" against ") { itself } else { rendered };
        let open = |set: &StimulusSet| ScoreCache::open(&path, set, &settings).expect("opened");
        let with = |set: &StimulusSet, scores: &[(&str, f64)]| {
            let mut cache = open(set);
            cache.scores.clear();
            for (key, q) in scores {
                cache.insert(set, (*key).to_owned(), against(key), vec![*q]).expect("a key of the set");
            }
            cache
        };

        // Two predictions side by side, both from an empty cache: each keeps the other's.
        with(&set, &[(a, 9.0)]).save(&path).expect("saved");
        with(&set, &[(b, 8.0), (pair.as_str(), 7.5)]).save(&path).expect("saved");
        let cache = open(&set);
        assert_eq!((cache.get(&set, a, rendered), cache.get(&set, b, rendered)), (Some(&vec![9.0]), Some(&vec![8.0])));
        assert_eq!(cache.get(&set, &pair, itself), Some(&vec![7.5]));
        assert_eq!(cache.scores[&pair].manifests, ["a", "b"]);
        // A score of its own wins.
        with(&set, &[(a, 7.0)]).save(&path).expect("saved");
        assert_eq!(open(&set).get(&set, a, rendered), Some(&vec![7.0]));

        // A score holds for the reference it was judged against only: not for one rendered
        // again (another stamp), nor for one still to render.
        let cache = open(&set);
        assert_eq!(cache.get(&set, a, Against::Rendered("r2")), None);
        assert_eq!((cache.get(&set, a, Against::Unfinished), cache.get(&set, a, itself)), (None, None));
        assert_eq!(cache.get(&set, &pair, rendered), None);
        assert!(open(&set).insert(&set, a.to_owned(), Against::Unfinished, vec![1.0]).is_err());

        // A new sequence rendered into the set keeps every score; a re-rendered one drops its
        // own and its pairs', and nothing else.
        let grown = indexed_set(&[(a, "a"), (b, "b"), (c, "c")]);
        assert_ne!(grown.sha256, set.sha256);
        let cache = open(&grown);
        assert_eq!(cache.scores.len(), 3);
        let rerendered = indexed_set(&[(a, "a"), (b, "b2"), (c, "c")]);
        let cache = open(&rerendered);
        assert_eq!(cache.scores.keys().collect::<Vec<_>>(), [a]);
        // An entry that does not match is never handed out, whatever the file says.
        let stale = open(&set);
        assert_eq!(stale.get(&rerendered, b, rendered), None);
        assert!(open(&set).insert(&set, c.to_owned(), rendered, vec![1.0]).is_err(), "{c} is not in the first set");

        // Another setting's scores under the same name are not taken in.
        let other = ObserverSettings { reference_spp: 65, ..settings.clone() };
        assert!(ScoreCache::open(&path, &set, &other).expect("opened").scores.is_empty());

        // A cache from before references were stamped names none of them: its pairs hold,
        // its scores against a rendered reference do not.
        let unstamped = serde_json::json!({
            "format": UNSTAMPED_SCORES_FORMAT,
            "settings": settings,
            "scores": {
                a: { "manifests": ["a"], "eyes": [6.5] },
                pair.as_str(): { "manifests": ["a", "b"], "eyes": [6.4] },
            },
        });
        std::fs::write(&path, serde_json::to_vec(&unstamped).expect("json")).expect("written");
        let cache = open(&set);
        assert_eq!((cache.get(&set, a, rendered), cache.get(&set, &pair, itself)), (None, Some(&vec![6.4])));

        // The earlier whole-set cache is taken in for the set it was computed from only (its
        // pairs, for the same reason).
        let whole_set = |sha: &str| {
            let json = serde_json::json!({
                "format": WHOLE_SET_SCORES_FORMAT,
                "stimulus_set_sha256": sha,
                "settings": settings,
                "scores": { a: [6.0], pair.as_str(): [5.0] },
            });
            std::fs::write(&path, serde_json::to_vec(&json).expect("json")).expect("written");
        };
        whole_set(&set.sha256);
        let cache = open(&set);
        assert_eq!((cache.get(&set, a, rendered), cache.get(&set, &pair, itself)), (None, Some(&vec![5.0])));
        whole_set(&grown.sha256);
        assert!(open(&set).scores.is_empty());
        std::fs::write(&path, b"{ not json").expect("written");
        let e = ScoreCache::open(&path, &set, &settings).expect_err("not a cache");
        assert!(format!("{e:#}").contains("not a score cache"), "{e:#}");
        std::fs::remove_dir_all(&dir).expect("cleaned up");
    }

    #[test]
    fn a_pursuing_eye_looks_at_the_sphere_at_each_reference_instant() {
        let (design, preset) = shipped();
        let sharp = settings(&design, &preset, ReferenceKind::Sharp).with_eye_movement(EyeMovement::Pursuit);
        for text in ["M2-S2-T3-A3", "M2-S2-T3-A3-stereo"] {
            let id: StimulusId = text.parse().expect("an id");
            let gaze = pursuit_gaze(&design, &preset, &id, &sharp).expect("gaze");
            assert_eq!(gaze.len(), 2 * 4, "{text}: two frames of four sub-frames");
            for (k, g) in gaze.iter().enumerate() {
                let (frame, sub) = (15 + k as u32 / 4, k as u32 % 4);
                let scene = reference_scene(&design, &preset, &id, frame, sub, &sharp).expect("scene");
                let centre = scene.sphere.centre_at(scene.shutter.open);
                assert_eq!(g.len(), scene.views.len());
                for (v, view) in g.iter().zip(&scene.views) {
                    let p = view.camera.project(centre).expect("in front");
                    let (w, h) = (f64::from(view.camera.width), f64::from(view.camera.height));
                    assert!((v.x - p.x.clamp(0.0, w)).abs() < 1e-9 && (v.y - p.y.clamp(0.0, h)).abs() < 1e-9);
                }
            }
            // Left to right, a few pixels per sub-frame while the sphere is in view.
            let step = gaze[1][0].x - gaze[0][0].x;
            assert!(step > 1.0 && step < 10.0, "{text}: {step} pixels per sub-frame");
        }
        // Fixation leaves the settings as they were before eye movements existed (the score
        // caches keep their names); pursuit gets caches of its own.
        let fixation = settings(&design, &preset, ReferenceKind::Sharp);
        assert!(!serde_json::to_string(&fixation).expect("json").contains("eye_movement"));
        assert_ne!(fixation.key().expect("key"), sharp.key().expect("key"));
    }
}
