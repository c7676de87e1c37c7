//! What accuracy costs in time (`blurlab cost`): every rendering method swept over its
//! accuracy knob on chosen frames of one material, speed and shutter, each point rendered
//! several times with independent seeds and measured against a converged tracer reference.
//!
//! - The reference is the tracer at `reference_spp` samples per pixel, rendered as two
//!   independent halves with seeds mixed apart from every point's (as in `quality`); half
//!   the RMS difference of the halves is its own standard error on display values. The sweep
//!   refuses a reference whose standard error is not below a tenth of the smallest median
//!   error it judges: before rendering, when it has fewer than a hundred times the finest
//!   tracer's samples; then measured, on each method's finest setting before the rest is
//!   swept, and on the whole table at the end.
//! - Knobs (`study::Method::sweep`, each method's own): tracer samples per pixel (powers of two up to `max_spp`
//!   and the preset's sampling levels); accumulation-buffer instants (centred, 4 samples per
//!   instant, up to `max_spp` samples in all); McGuire's and Guertin's taps at each of the
//!   preset's sampling levels as their G-buffer input; the analytic rasterizer's interval
//!   budget (lighting samples: the preset's highest level).
//! - Each point records wall time (and GPU time where measured), work units and its error:
//!   display RMSE (exposure, tone map, sRGB), linear RMSE and mean FLIP (`perceptual`) of the
//!   8-bit frame as shown, at the design's pixels per degree, and the observer's prediction:
//!   ColorVideoVDP's quality of that frame against the reference's, in JOD, on the display
//!   of the design's `[viewing]` section (each eye judged, their mean).
//! - Resumable: the request's identity is kept in `OUT/cost-request.json`, each reference
//!   in `OUT/reference/` and each point in `OUT/points/KEY.json` as soon as it is measured
//!   (atomic writes); a rerun keeps what is there and measures only what is missing, so a
//!   killed sweep continues and its table is the uninterrupted one's.
//! - FLIP error maps of each knob's coarsest and finest setting and of every lighting model
//!   of the marcher (frame of the first listed frame, first repetition) go to `OUT/maps/`
//!   beside the frames and the reference.

use std::path::{Path, PathBuf};
use std::time::Instant;

use perceptual::SrgbImage;
use perceptual::cvvdp::{Clip, CvvdpError, DisplayConditions, Threads, VideoObserver};
use serde::{Deserialize, Serialize};
use study::Method;
use study::cost::{COST_FORMAT, CostPoint, CostReference, CostSweep, point_key};
use study::design::{Design, Preset};
use study::ids::{Cell, Factor, StimulusId, View};
use study::method::antialias::{
    DEFAULT_MLAA_SEARCH_DISTANCE, SWEEP_KNOB_SEARCH_DISTANCE, SWEEP_KNOB_THRESHOLD, mlaa_sweep,
};
use study::method::marcher::SWEEP_KNOB_LIGHTING;
use study::method::{MethodSpec, SweepSetting as Setting};
use study::scene::FrameScene;
use study::seed::mix;

use crate::io::{LinearImage, decode_exr, encode_exr, encode_png_srgb, to_srgb8};
use crate::measure::methods::display_rmse;
use crate::{RenderError, Renderer};

/// Largest allowed `max_spp` and `reference_spp`.
pub const MAX_SPP: u32 = 1 << 20;

/// Why a sweep failed.
#[derive(Debug, thiserror::Error)]
pub enum CostError {
    /// The request does not fit the design or is malformed (bad input).
    #[error("{0}")]
    Request(String),
    /// The reference's own noise is too large for the errors it judges (bad input: raise
    /// `--reference-spp`).
    #[error(
        "the reference is not converged enough: its standard error {standard_error:.6} (display RMS, {spp} spp) is not below a tenth of the smallest error it judges, {smallest:.6} ({label}); use --reference-spp {suggested} or more (in a new --out), or a smaller --max-spp"
    )]
    NotConverged {
        /// The reference's standard error.
        standard_error: f64,
        /// Its samples per pixel.
        spp: u32,
        /// The smallest median error judged.
        smallest: f64,
        /// The setting that has it.
        label: String,
        /// Samples per pixel that would do (from 1/sqrt(spp)), rounded up to a power of two.
        suggested: u32,
    },
    /// The design could not give a frame.
    #[error(transparent)]
    Design(#[from] study::design::DesignError),
    /// A render failed.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// FLIP failed.
    #[error("FLIP: {0}")]
    Flip(#[from] perceptual::FlipError),
    /// ColorVideoVDP failed, or the design's display is out of its range.
    #[error("the observer's prediction: {0}")]
    Observer(#[from] CvvdpError),
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl CostError {
    /// Whether the user can fix it by changing the request.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            CostError::Request(_)
                | CostError::NotConverged { .. }
                | CostError::Design(_)
                | CostError::Observer(CvvdpError::Display { .. })
        )
    }
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct CostRequest {
    /// Preset name.
    pub preset: String,
    /// The cell, `M3-S3-T5` (an `-A<a>` level, a method tag and `-stereo` are accepted; the
    /// level and tag are ignored, `-stereo` sweeps stereo frames).
    pub cell: String,
    /// Frames (indices within the preset); empty: the preset's middle frame.
    pub frames: Vec<u32>,
    /// Methods swept; empty: every method.
    pub methods: Vec<Method>,
    /// Samples per pixel of the reference.
    pub reference_spp: u32,
    /// The tracer's largest samples per pixel (and the accumulation buffer's total).
    pub max_spp: u32,
    /// Renders per point.
    pub repetitions: u32,
    /// Output folder.
    pub out: PathBuf,
    /// Stop after measuring this many new points (the sweep stays resumable); `None`: all.
    pub max_new_points: Option<usize>,
    /// Also sweep MLAA on the centre-sampled tracer ([`study::method::antialias::mlaa_sweep`]).
    pub mlaa: bool,
}

/// The identity of a sweep folder: what every point in it was measured against.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Identity {
    format: String,
    design_sha256: String,
    preset: String,
    cell: String,
    stereo: bool,
    reference_spp: u32,
}

/// Work units of one render of `setting` over `pixels` pixels.
fn work_units(setting: &Setting, pixels: u64) -> u64 {
    setting.spec.kind().work_units(setting.knob, setting.value, setting.input_spp) * pixels
}

/// The cell and view of `text` (`M3-S3-T5`, optionally `-A<a>`, a method tag, `-stereo`:
/// [`Cell::parse_label`]), checked against the design.
pub fn parse_cell(design: &Design, text: &str) -> Result<(Cell, View), CostError> {
    let bad = |why: String| {
        CostError::Request(format!("--id `{text}`: {why} (expected material, speed and shutter, e.g. `M3-S3-T5`)"))
    };
    let (cell, view) = Cell::parse_label(text).map_err(|e| bad(e.reason))?;
    for (factor, number) in
        [(Factor::Material, cell.material), (Factor::Speed, cell.speed), (Factor::Shutter, cell.shutter)]
    {
        let (letter, count) = (factor.letter(), design.level_count(factor));
        if number > count {
            return Err(bad(format!(
                "{letter}{number} is not a level of the design (it has {letter}1..{letter}{count})"
            )));
        }
    }
    Ok((cell, view))
}

/// Whether `setting` is a point of MLAA's sweep.
fn is_mlaa(setting: &Setting) -> bool {
    [SWEEP_KNOB_SEARCH_DISTANCE, SWEEP_KNOB_THRESHOLD].contains(&setting.knob)
}

/// The scene with seeds mixed apart by `salt` and `spp` samples.
fn reseeded(scene: &FrameScene, salt: &[u64], spp: u32) -> FrameScene {
    let mut s = scene.clone();
    s.samples_per_pixel = spp;
    for v in &mut s.views {
        v.seed = mix(v.seed, salt);
    }
    s
}

fn file_error(path: &Path, e: impl std::fmt::Display) -> CostError {
    CostError::File { path: path.to_owned(), message: e.to_string() }
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), CostError> {
    study::fsio::write_atomic(path, bytes).map_err(|e| file_error(path, e))
}

/// An 8-bit RGB image as PNG bytes.
pub(crate) fn png_rgb8(width: u32, height: u32, bytes: &[u8]) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(bytes, width, height, image::ExtendedColorType::Rgb8)
        .expect("PNG encoding into memory cannot fail for a consistent image");
    out
}

/// A reference frame: the image and its record.
struct Reference {
    image: LinearImage,
    srgb: SrgbImage,
    record: CostReference,
}

/// The sweep's fixed context.
struct Context<'a, 'env> {
    design: &'a Design,
    renderer: &'a Renderer<'env>,
    preset: Preset,
    id: StimulusId,
    ppd: f64,
    eyes: u32,
    observer: VideoObserver,
    out: PathBuf,
}

impl Context<'_, '_> {
    fn base_scene(&self, frame: u32) -> Result<FrameScene, CostError> {
        Ok(self.design.frame_scene_with(&self.preset, &self.id, frame)?)
    }

    fn srgb(&self, image: &LinearImage, scene: &FrameScene) -> Result<SrgbImage, CostError> {
        Ok(SrgbImage::new(image.width, image.height, to_srgb8(image, &scene.exposure))?)
    }

    /// The reference of `frame`, from `OUT/reference/` or rendered (and kept there).
    fn reference(&self, frame: u32, spp: u32) -> Result<Reference, CostError> {
        let dir = self.out.join("reference");
        let exr = dir.join(format!("frame-{frame:04}.exr"));
        let json = dir.join(format!("frame-{frame:04}.json"));
        let scene = self.base_scene(frame)?;
        if exr.exists() && json.exists() {
            let record: CostReference =
                serde_json::from_slice(&std::fs::read(&json).map_err(|e| file_error(&json, e))?)
                    .map_err(|e| file_error(&json, e))?;
            let image =
                decode_exr(&std::fs::read(&exr).map_err(|e| file_error(&exr, e))?).map_err(|e| file_error(&exr, e))?;
            let srgb = self.srgb(&image, &scene)?;
            return Ok(Reference { image, srgb, record });
        }
        std::fs::create_dir_all(&dir).map_err(|e| file_error(&dir, e))?;
        let half = (spp / 2).max(1);
        let tracer = MethodSpec::of(Method::Tracer);
        let started = Instant::now();
        let a = self.renderer.render(&tracer, &reseeded(&scene, &[0x5EFA_C057], half))?.image;
        let b = self.renderer.render(&tracer, &reseeded(&scene, &[0x5EFB_C057], half))?.image;
        let wall_seconds = started.elapsed().as_secs_f64();
        let image = LinearImage::mean(&[&a, &b]);
        // The mean of two independent halves has half the variance of one: its standard
        // error is half the RMS difference of the halves.
        let standard_error = 0.5 * display_rmse(&a, &b, &scene.exposure);
        let record = CostReference { frame, spp: 2 * half, standard_error, wall_seconds };
        write(&exr, &encode_exr(&image).map_err(|e| file_error(&exr, e))?)?;
        write(&dir.join(format!("frame-{frame:04}.png")), &encode_png_srgb(&image, &scene.exposure))?;
        write(&json, &serde_json::to_vec_pretty(&record).map_err(|e| file_error(&json, e))?)?;
        let srgb = self.srgb(&image, &scene)?;
        Ok(Reference { image, srgb, record })
    }

    /// Measures one point (or reads it back), writing its map when `map` is set.
    fn point(
        &self,
        setting: &Setting,
        frame: u32,
        repetition: u32,
        reference: &Reference,
        map: bool,
        may_measure: bool,
    ) -> Result<Option<(CostPoint, bool)>, CostError> {
        let key = point_key(setting.spec.kind(), setting.knob, setting.value, setting.input_spp, frame, repetition);
        let path = self.out.join("points").join(format!("{key}.json"));
        if path.exists() {
            let point: CostPoint = serde_json::from_slice(&std::fs::read(&path).map_err(|e| file_error(&path, e))?)
                .map_err(|e| file_error(&path, e))?;
            return Ok(Some((point, false)));
        }
        if !may_measure {
            return Ok(None);
        }
        let base = self.base_scene(frame)?;
        // MLAA's settings share their input's seeds, so that its curve shows the filter's
        // effect on one frame, not the differences between frames.
        let salt = if is_mlaa(setting) {
            [0xC057, setting.spec.kind() as u64, 0x4D4C_4141, u64::from(repetition)]
        } else {
            [0xC057, setting.spec.kind() as u64, u64::from(setting.value), u64::from(repetition)]
        };
        let mut scene = reseeded(&base, &salt, setting.input_spp);
        scene.antialias = setting.antialias;
        let started = Instant::now();
        let frame_out = self.renderer.render(&setting.spec, &scene)?;
        let wall_seconds = started.elapsed().as_secs_f64();
        let image = frame_out.image;
        let srgb = self.srgb(&image, &scene)?;
        let flip_mean = perceptual::flip_eyes(&reference.srgb, &srgb, self.eyes, self.ppd)?;
        // One frame is an image to ColorVideoVDP: its spatial and colour channels judge it.
        let fps = self.design.spec.sequence.fps;
        let test = Clip { frames: std::slice::from_ref(&srgb), fps };
        let shown = Clip { frames: std::slice::from_ref(&reference.srgb), fps };
        let jod = self.observer.judge(&test, &shown, self.eyes)?.jod();
        let pixels = u64::from(image.width) * u64::from(image.height);
        let point = CostPoint {
            method: setting.spec.kind(),
            knob: setting.knob.to_owned(),
            value: setting.value,
            input_spp: setting.input_spp,
            frame,
            repetition,
            wall_seconds,
            gpu_seconds: frame_out.gpu_seconds,
            camera_samples: frame_out.camera_samples,
            work_units: work_units(setting, pixels),
            rmse: display_rmse(&image, &reference.image, &scene.exposure),
            rmse_linear: image.rms_difference(&reference.image),
            flip: flip_mean,
            jod: Some(jod),
        };
        if map {
            let dir = self.out.join("maps");
            std::fs::create_dir_all(&dir).map_err(|e| file_error(&dir, e))?;
            write(&dir.join(format!("{key}.png")), &encode_png_srgb(&image, &scene.exposure))?;
            let flip = perceptual::flip(&reference.srgb, &srgb, self.ppd)?;
            write(&dir.join(format!("{key}-flip.png")), &png_rgb8(flip.width, flip.height, &flip.magma_rgb8()))?;
        }
        let dir = self.out.join("points");
        std::fs::create_dir_all(&dir).map_err(|e| file_error(&dir, e))?;
        write(&path, &serde_json::to_vec_pretty(&point).map_err(|e| file_error(&path, e))?)?;
        Ok(Some((point, true)))
    }
}

/// How far the sweep is, for a progress bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Points done (measured or kept).
    pub done: usize,
    /// Points in all.
    pub total: usize,
    /// Points measured by this run.
    pub measured: usize,
}

/// What a run did.
#[derive(Clone, Debug)]
pub struct CostOutcome {
    /// The sweep as far as it got (complete unless `max_new_points` stopped it).
    pub sweep: CostSweep,
    /// Points measured by this run.
    pub measured: usize,
    /// Points read back from an earlier run.
    pub kept: usize,
    /// Whether every point is measured.
    pub complete: bool,
}

fn check_converged(sweep: &CostSweep) -> Result<(), CostError> {
    let se = sweep.reference_standard_error();
    if let Some((smallest, label)) = sweep.smallest_error()
        && se >= 0.1 * smallest
    {
        let spp = sweep.references.first().map_or(0, |r| r.spp);
        let needed = f64::from(spp) * (se / (0.1 * smallest)).powi(2) * 1.1;
        let suggested = (needed.ceil().min(f64::from(MAX_SPP)) as u32).next_power_of_two();
        return Err(CostError::NotConverged { standard_error: se, spp, smallest, label, suggested });
    }
    Ok(())
}

/// Runs (or resumes) the sweep of `request` on `renderer`; `progress` is told after each
/// point.
pub fn run_cost(
    design: &Design,
    renderer: &Renderer<'_>,
    request: &CostRequest,
    mut progress: impl FnMut(Progress),
) -> Result<CostOutcome, CostError> {
    let bad = |m: String| Err(CostError::Request(m));
    let preset = design.preset(&request.preset)?;
    let (cell, view) = parse_cell(design, &request.cell)?;
    if request.repetitions == 0 || request.repetitions > 1000 {
        return bad(format!("--repetitions must lie in 1..=1000, got {}", request.repetitions));
    }
    if request.max_spp == 0 || request.max_spp > MAX_SPP {
        return bad(format!("--max-spp must lie in 1..={MAX_SPP}, got {}", request.max_spp));
    }
    if request.reference_spp < 2 || request.reference_spp > MAX_SPP {
        return bad(format!("--reference-spp must lie in 2..={MAX_SPP}, got {}", request.reference_spp));
    }
    // The reference's noise relative to the finest tracer's error is about
    // sqrt(max_spp / reference_spp) (both fall alike with the samples): below a tenth of it
    // needs a hundred times the samples. Refused before anything is rendered.
    let sampled =
        request.methods.is_empty() || request.methods.iter().any(|m| matches!(m, Method::Tracer | Method::Accum));
    if sampled && u64::from(request.reference_spp) < 100 * u64::from(request.max_spp) {
        let needed = (100 * request.max_spp).min(MAX_SPP).next_power_of_two();
        return bad(format!(
            "the reference is not converged enough for this sweep: a {}-spp reference's standard error is about {:.2} of the {}-spp tracer's error, and must be below 0.1; use --reference-spp {needed} or more, or a smaller --max-spp",
            request.reference_spp,
            (f64::from(request.max_spp) / f64::from(request.reference_spp)).sqrt(),
            request.max_spp
        ));
    }
    let frames: Vec<u32> = if request.frames.is_empty() { vec![preset.frames / 2] } else { request.frames.clone() };
    if let Some(&f) = frames.iter().find(|&&f| f >= preset.frames) {
        return bad(format!(
            "--frames: frame {f} is outside the sequence: the preset `{}` has frames 0..={}",
            preset.name,
            preset.frames.saturating_sub(1)
        ));
    }
    let methods: Vec<Method> = if request.methods.is_empty() { Method::ALL.to_vec() } else { request.methods.clone() };
    let tag = design.method_tags().first().copied();
    let id =
        StimulusId { material: cell.material, speed: cell.speed, shutter: cell.shutter, samples: 1, method: tag, view };
    let cell = cell.label(view);
    let identity = Identity {
        format: COST_FORMAT.to_owned(),
        design_sha256: design.sha256.clone(),
        preset: preset.name.clone(),
        cell: cell.clone(),
        stereo: view == View::Stereo,
        reference_spp: request.reference_spp,
    };
    std::fs::create_dir_all(&request.out).map_err(|e| file_error(&request.out, e))?;
    let identity_path = request.out.join("cost-request.json");
    if identity_path.exists() {
        let there: Identity =
            serde_json::from_slice(&std::fs::read(&identity_path).map_err(|e| file_error(&identity_path, e))?)
                .map_err(|e| file_error(&identity_path, e))?;
        if there != identity {
            let fields = [
                ("design_sha256", there.design_sha256 != identity.design_sha256),
                ("preset", there.preset != identity.preset),
                ("--id", there.cell != identity.cell),
                ("--reference-spp", there.reference_spp != identity.reference_spp),
                ("format", there.format != identity.format),
            ];
            let differ: Vec<&str> = fields.iter().filter(|(_, d)| *d).map(|(n, _)| *n).collect();
            return bad(format!(
                "{} holds a cost sweep of another request ({} differ: there {} {} {} spp); choose another --out",
                request.out.display(),
                differ.join(", "),
                there.preset,
                there.cell,
                there.reference_spp
            ));
        }
    } else {
        write(&identity_path, &serde_json::to_vec_pretty(&identity).map_err(|e| file_error(&identity_path, e))?)?;
    }
    let viewing = &design.spec.viewing;
    let ppd = design.pixels_per_degree(preset.width);
    let display = DisplayConditions {
        pixels_per_degree: ppd,
        peak_luminance: viewing.peak_luminance,
        black_level: viewing.black_level,
        ambient_lux: viewing.ambient_lux,
    };
    let ctx = Context {
        design,
        renderer,
        ppd,
        observer: VideoObserver::new(display, Threads::Pool)?,
        eyes: if view == View::Stereo { 2 } else { 1 },
        preset: preset.clone(),
        id,
        out: request.out.clone(),
    };
    if request.mlaa && !methods.contains(&Method::Tracer) {
        return bad("--mlaa filters the tracer's frames: add tracer to --methods".into());
    }
    let mut settings: Vec<(Method, Vec<Setting>)> =
        methods.iter().map(|&m| (m, m.sweep(&preset, request.max_spp))).collect();
    if request.mlaa {
        for (m, s) in &mut settings {
            if *m == Method::Tracer {
                s.extend(mlaa_sweep(&preset, request.max_spp));
            }
        }
    }
    // Every method's finest setting (its last without MLAA) first, repetition 0 of the first
    // frame: the reference is checked against them before the rest is swept.
    let finest = |s: &[Setting]| s.iter().rposition(|x| !is_mlaa(x));
    let mut order: Vec<(u32, Setting, u32, bool)> = Vec::new();
    for (_, s) in &settings {
        if let Some(i) = finest(s) {
            order.push((frames[0], s[i].clone(), 0, true));
        }
    }
    let first_check = order.len();
    for &frame in &frames {
        for (_, s) in &settings {
            for (i, setting) in s.iter().enumerate() {
                for rep in 0..request.repetitions {
                    // Maps of each knob's coarsest and finest settings (of the method's
                    // finest too), of every lighting model of the marcher, and of MLAA at its
                    // defaults.
                    let mlaa_default =
                        setting.knob == SWEEP_KNOB_SEARCH_DISTANCE && setting.value == DEFAULT_MLAA_SEARCH_DISTANCE;
                    let knob_end = s.iter().position(|x| x.knob == setting.knob) == Some(i)
                        || s.iter().rposition(|x| x.knob == setting.knob) == Some(i);
                    let map = frame == frames[0]
                        && rep == 0
                        && (knob_end || Some(i) == finest(s) || mlaa_default || setting.knob == SWEEP_KNOB_LIGHTING);
                    let item = (frame, setting.clone(), rep, map);
                    if !order.iter().any(|o| o.0 == item.0 && o.1 == item.1 && o.2 == item.2) {
                        order.push(item);
                    }
                }
            }
        }
    }
    let mut sweep = CostSweep {
        format: COST_FORMAT.to_owned(),
        design: design.name().to_owned(),
        design_sha256: design.sha256.clone(),
        preset: preset.name.clone(),
        cell,
        stereo: view == View::Stereo,
        frames: frames.clone(),
        width: preset.width,
        height: preset.height,
        pixels_per_degree: ctx.ppd,
        repetitions: request.repetitions,
        levels: preset.samples_per_pixel.iter().enumerate().map(|(i, &s)| (format!("A{}", i + 1), s)).collect(),
        device: renderer.device_name(),
        references: Vec::new(),
        points: Vec::new(),
    };
    let mut references = std::collections::BTreeMap::new();
    for &frame in &frames {
        let r = ctx.reference(frame, request.reference_spp)?;
        sweep.references.push(r.record.clone());
        references.insert(frame, r);
    }
    // What a process makes once and every later render shares (a medium's grids: the smoke is
    // simulated on first use) is made here, untimed; otherwise the first point measured pays
    // for it whenever the references come from disk.
    for &frame in &frames {
        if let Some(medium) = &ctx.base_scene(frame)?.medium {
            crate::volume::grids_for(medium, &mut |_, _| {}).map_err(|e| RenderError::Scene(e.to_string()))?;
        }
    }
    let total = order.len();
    let (mut measured, mut kept, mut complete) = (0, 0, true);
    progress(Progress { done: 0, total, measured: 0 });
    for (i, (frame, setting, rep, map)) in order.iter().enumerate() {
        // Past the budget of new points, kept points still count: the report so far has
        // every point measured before.
        let may_measure = request.max_new_points.is_none_or(|m| measured < m);
        let Some((point, new)) = ctx.point(setting, *frame, *rep, &references[frame], *map, may_measure)? else {
            complete = false;
            continue;
        };
        if new {
            measured += 1;
        } else {
            kept += 1;
        }
        sweep.points.push(point);
        progress(Progress { done: i + 1, total, measured });
        if i + 1 == first_check {
            check_converged(&sweep)?;
        }
    }
    // The table in sweep order (the finest settings were measured first).
    let position = |p: &CostPoint| {
        settings
            .iter()
            .flat_map(|(_, s)| s.iter())
            .position(|s| {
                s.spec.kind() == p.method && s.knob == p.knob && s.value == p.value && s.input_spp == p.input_spp
            })
            .unwrap_or(usize::MAX)
    };
    sweep.points.sort_by_key(|p| (position(p), p.frame, p.repetition));
    check_converged(&sweep)?;
    Ok(CostOutcome { sweep, measured, kept, complete })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn preset(levels: Vec<u32>) -> Preset {
        Preset { name: "p".into(), width: 8, height: 4, frames: 2, first_frame: 0, samples_per_pixel: levels }
    }

    #[test]
    fn settings_cover_each_knob_coarsest_first() {
        use study::method::{AnalyticSettings, SWEEP_TAPS};
        let p = preset(vec![1, 4, 8, 12, 16]);
        let spp: Vec<u32> = Method::Tracer.sweep(&p, 16).iter().map(|s| s.value).collect();
        assert_eq!(spp, vec![1, 2, 4, 8, 12, 16]);
        let spp: Vec<u32> = Method::Tracer.sweep(&p, 1024).iter().map(|s| s.value).collect();
        assert_eq!(spp.len(), 12);
        let accum = Method::Accum.sweep(&p, 16);
        assert_eq!(accum.iter().map(|s| s.value).collect::<Vec<_>>(), vec![1, 2, 4]);
        assert_eq!(work_units(&accum[2], 10), 160);
        let guertin = Method::Guertin.sweep(&p, 8);
        assert_eq!(guertin.len(), 3 * SWEEP_TAPS.len());
        let taps = |s: &Setting| match &s.spec {
            MethodSpec::Guertin(g) => g.taps,
            _ => None,
        };
        assert_eq!((guertin[0].input_spp, guertin[0].value, taps(&guertin[0])), (1, 3, Some(3)));
        let analytic = Method::Analytic.sweep(&p, 16);
        let settings = |s: &Setting| match &s.spec {
            MethodSpec::Analytic(a) => a.clone(),
            _ => AnalyticSettings::default(),
        };
        let budgets: Vec<_> = analytic.iter().filter(|s| s.knob == "intervals").collect();
        assert_eq!(settings(budgets.last().unwrap()).intervals, Some(64));
        assert_eq!(analytic[0].input_spp, 16);
        // Supersampled last (the finest): 4 x 4 points share the 16 lighting samples.
        let finest = analytic.last().unwrap();
        let a = settings(finest);
        assert_eq!((finest.knob, a.supersampling, a.lighting_samples), ("supersampling", Some(4), Some(1)));
        assert_eq!(work_units(finest, 10), 8 * 16 * 10);
    }
}
