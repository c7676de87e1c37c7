//! Getting a trial's stimuli onto the screen: the loader thread decodes the sequences
//! ([`LoadJob`], with a progress counter), uploads them as textures on eframe's wgpu device
//! when there is one ([`Prepared`]), and the window turns them into [`Frames`] it can draw
//! (egui's textures otherwise, with the CPU row-interleave placement).

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

use egui::{Color32, Rect, TextureHandle, Vec2};
use study::StimulusId;
use study::experiment::DisplayMode;

use super::RunnerApp;
use crate::RunnerError;
use crate::gpu::{Draw, FrameUploader, StimulusCallback, StimulusPipelines};
use crate::stimuli::decode_sequence_for;
use crate::views::Views;

/// How often the loading screen redraws its progress bar: not continuously, so the window
/// leaves the cores to the frame decoders (it is checked again within this delay).
pub(super) const LOADING_REDRAW: std::time::Duration = std::time::Duration::from_millis(15);

/// Stimuli decoded and uploaded for one trial or example.
pub(super) struct Loaded {
    pub(super) textures: HashMap<StimulusId, Frames>,
    pub(super) fps: HashMap<StimulusId, f64>,
    /// One eye's picture (pixels): the frame's size for mono, half its width for stereo.
    pub(super) size: HashMap<StimulusId, [usize; 2]>,
}

/// The textures of one sequence's frames.
pub(super) enum Frames {
    /// Managed by egui (uploaded by egui at the next paint; without a wgpu device).
    Egui {
        /// Per frame.
        handles: Vec<TextureHandle>,
        /// Row-interleaved stereo (image rows interleaved on the CPU), drawn only where each
        /// image row lands on one screen line of its eye ([`interleave_origin`]).
        interleaved: bool,
    },
    /// Uploaded by the loader thread ([`FrameUploader`]) and drawn by a paint callback with
    /// the [`StimulusPipelines`] (one bind group per frame, which keeps its texture alive).
    Native {
        /// Per frame.
        binds: Vec<eframe::wgpu::BindGroup>,
        /// A copy of the display image, or a composition of a stereo frame.
        draw: Draw,
        /// The sampler's filter the frames were bound with.
        filter: eframe::wgpu::FilterMode,
    },
}

impl Frames {
    pub(super) fn len(&self) -> usize {
        match self {
            Frames::Egui { handles, .. } => handles.len(),
            Frames::Native { binds, .. } => binds.len(),
        }
    }

    /// Draws frame `frame` into view rectangle `rect` (one eye's picture) for every eye of
    /// `views`, and returns where it landed in the window (per eye). In one-view modes it is
    /// painted in place; in the split modes each eye's part of the image goes into that eye's
    /// region, on the stimulus layer above the view (whose copies [`Views::compose`] makes).
    pub(super) fn paint(&self, ui: &mut egui::Ui, frame: usize, rect: Rect, views: &Views) -> Vec<Rect> {
        if !views.is_split() {
            let painter = ui.painter().clone();
            let (at, warning) = self.paint_one(ui, &painter, frame, rect, FULL_UV);
            if let Some(w) = warning {
                let below = Rect::from_min_size(at.left_bottom() + Vec2::new(0.0, 4.0), Vec2::new(at.width(), 40.0));
                ui.put(below, egui::Label::new(egui::RichText::new(w).color(Color32::from_rgb(140, 0, 0))));
            }
            return vec![at];
        }
        let layer = egui::LayerId::new(egui::Order::Foreground, egui::Id::unique("blurlab stimulus"));
        (0..views.eyes.len())
            .map(|eye| {
                let at = views.rect_to_window(eye, rect);
                let painter = ui.ctx().layer_painter(layer).with_clip_rect(at);
                self.paint_one(ui, &painter, frame, at, views.eyes[eye].uv).0
            })
            .collect()
    }

    /// Paints part `uv` (texture coordinates) of frame `frame` into window rectangle `at`;
    /// returns where it landed and a warning when the stereo shown is wrong.
    fn paint_one(
        &self,
        ui: &egui::Ui,
        painter: &egui::Painter,
        frame: usize,
        at: Rect,
        uv: Rect,
    ) -> (Rect, Option<String>) {
        match self {
            Frames::Egui { handles, interleaved: false } => {
                painter.image(handles[frame].id(), at, uv, Color32::WHITE);
                (at, None)
            }
            Frames::Egui { handles, interleaved: true } => {
                let ppp = ui.ctx().pixels_per_point();
                let image_h = handles[frame].size()[1];
                match interleave_origin(at.min, ppp, image_h, at.height()) {
                    // Up to 2 pixels lower and 1 to the right: within the margins.
                    Some(origin) => {
                        let moved = Rect::from_min_size(origin, at.size());
                        painter.image(handles[frame].id(), moved, uv, Color32::WHITE);
                        (moved, None)
                    }
                    None => {
                        painter.image(handles[frame].id(), at, uv, Color32::WHITE);
                        let lines = at.height() * ppp / image_h.max(1) as f32;
                        let warning = interleave_warning(lines);
                        if !INTERLEAVE_WARNED.swap(true, Ordering::Relaxed) {
                            eprintln!("warning: {warning}");
                        }
                        (at, Some(warning))
                    }
                }
            }
            Frames::Native { binds, draw, filter } => {
                // The viewport is the whole image, placed so that part `uv` lands on `at`; the
                // clip rectangle (the scissor) keeps the rest off the screen.
                let size = at.size() / uv.size();
                let viewport = Rect::from_min_size(at.min - uv.min.to_vec2() * size, size);
                let callback = StimulusCallback { bind: binds[frame].clone(), draw: *draw, filter: *filter };
                painter.add(eframe::egui_wgpu::Callback::new_paint_callback(viewport, callback));
                (at, None)
            }
        }
    }
}

/// The whole image in texture coordinates.
const FULL_UV: Rect = Rect { min: egui::Pos2 { x: 0.0, y: 0.0 }, max: egui::Pos2 { x: 1.0, y: 1.0 } };

/// A sequence made ready by the loader thread.
pub(super) struct Prepared {
    pub(super) id: StimulusId,
    pub(super) fps: f64,
    pub(super) eye_width: u32,
    /// Display image size.
    pub(super) size: [usize; 2],
    pub(super) content: Content,
}

pub(super) enum Content {
    /// Decoded display images, for egui to upload, and whether they are row-interleaved
    /// stereo ([`Frames::Egui`]).
    Images(Vec<egui::ColorImage>, bool),
    /// Textures already on the GPU, drawn as `Draw` says.
    Textures(Vec<eframe::wgpu::Texture>, Draw, GpuTarget),
}

/// The device the loader thread uploads with and the pipelines that draw the frames (also in
/// egui-wgpu's callback resources), when eframe runs on wgpu.
#[derive(Clone)]
pub(super) struct GpuTarget {
    pub(super) uploader: Arc<FrameUploader>,
    pub(super) pipelines: Arc<StimulusPipelines>,
}

pub(super) struct LoadJob {
    pub(super) total: usize,
    pub(super) progress: Arc<AtomicUsize>,
    pub(super) handle: Option<JoinHandle<Result<Vec<Prepared>, RunnerError>>>,
}

impl RunnerApp {
    pub(super) fn load(&self, ids: &[StimulusId]) -> LoadJob {
        let mut unique: Vec<StimulusId> = ids.to_vec();
        unique.sort();
        unique.dedup();
        let sequences: Vec<_> = unique.iter().map(|id| self.config.set.sequence(id).clone()).collect();
        let total = sequences.iter().map(|s| s.manifest.frames.len()).sum();
        let progress = Arc::new(AtomicUsize::new(0));
        let (mode, threads, counter) = (self.config.display, self.config.decode_threads, progress.clone());
        let gpu = self.gpu.clone();
        let handle = std::thread::spawn(move || {
            let prepare = |s: &crate::stimuli::Sequence| -> Result<Prepared, RunnerError> {
                let d = decode_sequence_for(s, mode, gpu.is_some(), &counter, threads)?;
                let size = d.display_size();
                let content = match &gpu {
                    Some(g) => Content::Textures(g.uploader.upload(&d)?, Draw::of(&d)?, g.clone()),
                    None => {
                        let interleaved = mode == DisplayMode::RowInterleaved && s.manifest.view == study::View::Stereo;
                        Content::Images(d.frames, interleaved)
                    }
                };
                Ok(Prepared { id: d.id, fps: d.fps, eye_width: d.eye_width, size, content })
            };
            sequences.iter().map(prepare).collect::<Result<Vec<_>, _>>()
        });
        LoadJob { total, progress, handle: Some(handle) }
    }

    /// Hands prepared sequences of a trial (or example) of `task` to the window: images for
    /// egui to upload, or textures bound for the runner's stimulus pipelines, with the texture
    /// filter their drawn size calls for ([`RunnerApp::filter`]).
    pub(super) fn upload(&self, ctx: &egui::Context, task: study::response::Task, prepared: Vec<Prepared>) -> Loaded {
        let filter = self.filter(ctx, task, &prepared);
        let mut loaded = Loaded { textures: HashMap::new(), fps: HashMap::new(), size: HashMap::new() };
        for d in prepared {
            // One eye's picture: what the view shows and the calibration sizes.
            loaded.size.insert(d.id, [d.eye_width as usize, d.size[1]]);
            let frames = match d.content {
                Content::Images(images, interleaved) => Frames::Egui {
                    handles: images
                        .into_iter()
                        .enumerate()
                        .map(|(i, image)| ctx.load_texture(format!("{}#{i}", d.id), image, filter))
                        .collect(),
                    interleaved,
                },
                Content::Textures(textures, draw, gpu) => {
                    let filter_mode = match filter.magnification {
                        egui::TextureFilter::Nearest => eframe::wgpu::FilterMode::Nearest,
                        egui::TextureFilter::Linear => eframe::wgpu::FilterMode::Linear,
                    };
                    let device = gpu.uploader.device();
                    let binds = textures.iter().map(|t| gpu.pipelines.bind(device, t, draw, filter_mode)).collect();
                    Frames::Native { binds, draw, filter: filter_mode }
                }
            };
            loaded.fps.insert(d.id, d.fps);
            loaded.textures.insert(d.id, frames);
        }
        loaded
    }

    /// The loader's progress as a bar of `width` points ("12 / 30 frames").
    pub(super) fn progress_bar(job: &LoadJob, width: f32) -> egui::ProgressBar {
        let done = job.progress.load(Ordering::Relaxed);
        egui::ProgressBar::new(done as f32 / job.total.max(1) as f32)
            .desired_width(width)
            .text(format!("Loading: {done} / {} frames", job.total))
    }

    /// The prepared sequences once the loader has finished (an error goes to `message`).
    pub(super) fn poll(job: &mut LoadJob, message: &mut Option<String>) -> Option<Vec<Prepared>> {
        if job.handle.as_ref().is_some_and(JoinHandle::is_finished) {
            let handle = job.handle.take().expect("checked above");
            match handle.join() {
                Ok(Ok(decoded)) => return Some(decoded),
                Ok(Err(e)) => *message = Some(e.to_string()),
                Err(_) => *message = Some("the frame decoder crashed".into()),
            }
        }
        None
    }
}

/// Whether the row-interleave warning has been logged (once per process).
static INTERLEAVE_WARNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Where the CPU fallback (no wgpu device: egui's textures) draws a row-interleaved image,
/// whose even image rows come from the left eye, so that every image row lands on one screen
/// line of its eye (even physical lines from the top of the framebuffer: left): at one screen
/// line per image row, its top on the first even physical line at or below `min.y` and its
/// left on a whole pixel (points: `min`; `pixels_per_point`; the image's height in pixels;
/// its drawn height in points). `None` at any other scale: image rows then cover several
/// lines or fall between them, and only the wgpu renderer (which picks the eye per screen
/// line) shows the right eye on every line.
fn interleave_origin(min: egui::Pos2, pixels_per_point: f32, image_h: usize, drawn_h: f32) -> Option<egui::Pos2> {
    let lines = drawn_h * pixels_per_point;
    if image_h == 0 || (lines - image_h as f32).abs() > 0.01 {
        return None;
    }
    let top = (min.y * pixels_per_point - 0.01).ceil();
    let top = if top.rem_euclid(2.0) == 1.0 { top + 1.0 } else { top };
    let left = (min.x * pixels_per_point - 0.01).ceil();
    Some(egui::pos2(left / pixels_per_point, top / pixels_per_point))
}

/// The warning shown (and logged once) when the CPU fallback cannot show row-interleaved
/// stereo right: the stimulus is drawn at `lines` screen lines per image row.
fn interleave_warning(lines: f32) -> String {
    format!(
        "Row-interleaved stereo is WRONG here: without the wgpu renderer each image row must cover exactly one screen line, but the stimulus is drawn at {lines:.2} screen lines per row, so each eye sees parts of the other's image. Run the runner with the wgpu renderer, or at a calibration of one screen pixel per stimulus pixel."
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_row_interleave_is_placed_on_an_even_screen_line_or_refused() {
        let at = |y: f32, ppp: f32, image_h: usize, drawn_h: f32| {
            interleave_origin(egui::pos2(10.3, y), ppp, image_h, drawn_h)
        };
        // One screen line per image row: the top moves down to the next even physical line.
        assert_eq!(at(20.0, 1.0, 360, 360.0), Some(egui::pos2(11.0, 20.0)));
        assert_eq!(at(21.0, 1.0, 360, 360.0), Some(egui::pos2(11.0, 22.0)));
        assert_eq!(at(20.4, 1.0, 360, 360.0), Some(egui::pos2(11.0, 22.0)));
        // pixels_per_point 2: 180 points are 360 lines; point 10.75 is line 21.5, so line 22.
        assert_eq!(at(10.75, 2.0, 360, 180.0), Some(egui::pos2(10.5, 11.0)));
        // pixels_per_point 1.5: point 7 is line 10.5, so line 12 (point 8).
        assert_eq!(at(7.0, 1.5, 360, 240.0), Some(egui::pos2(16.0 / 1.5, 8.0)));
        // Any other scale cannot be right on the CPU: 2 lines per row, 1.5, half a line.
        assert_eq!(at(20.0, 1.0, 360, 720.0), None);
        assert_eq!(at(20.0, 1.0, 360, 540.0), None);
        assert_eq!(at(20.0, 2.0, 360, 360.0), None);
        assert_eq!(at(20.0, 1.0, 0, 0.0), None);
        let w = interleave_warning(2.0);
        assert!(w.contains("2.00 screen lines per row") && w.contains("wgpu renderer"), "{w}");
    }
}
