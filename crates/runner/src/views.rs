//! Where the participant's view lies in the window, per display mode.
//!
//! The window draws what one eye should see once, in *view coordinates* (points; a
//! rectangle the size of one eye's picture of the screen), and this module places that view
//! where the display or viewing device expects each eye's picture:
//!
//! - `mono`, `anaglyph`, `row-interleaved`: one view, the whole window (the stereo
//!   composition happens inside the stimulus's rectangle).
//! - `sbs-full` (a mirror stereoscope, or two displays side by side): the left eye's view is the
//!   left half of the window, the right eye's the right half, each at full resolution.
//! - `sbs-half` (a 3D display's side-by-side input, which stretches each half to the full
//!   width): each eye's view is as wide as the window and is drawn squeezed to half its width
//!   into its half.
//! - `top-bottom`: likewise, each view as tall as the window, squeezed to half its height, the
//!   left eye's on top.
//!
//! Everything but the stimulus is the same in both views, so text and buttons appear at the
//! same place for both eyes (zero disparity); only the stimulus's rectangle shows each eye its
//! own image. [`Views::compose`] copies what was drawn into the view to each eye's region (and
//! squeezes it), and [`Views::to_view`] maps the pointer back, so a click anywhere on either
//! eye's copy of a button presses it.

use std::sync::Arc;

use egui::epaint::{ClippedShape, Mesh, Shape, Tessellator};
use egui::{Pos2, Rect, Vec2, emath::TSTransform};
use study::View;
use study::experiment::DisplayMode;

/// One eye's picture: view coordinates `p` appear in the window at
/// `region.min + (p - view.min) * squeeze`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeRegion {
    /// Where this eye's view lies in the window (points).
    pub region: Rect,
    /// Horizontal and vertical factors from the view to the region (1, or 1/2 squeezed).
    pub squeeze: Vec2,
    /// Which part of a stimulus's displayed image belongs to this eye (texture coordinates,
    /// 0..1): all of it in one-view modes; in the split modes the eye's half of the
    /// side-by-side frame (`sbs-full`) or of the composed pair (`sbs-half`, `top-bottom`).
    pub uv: Rect,
}

/// The view and where each eye sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Views {
    /// The view, in window coordinates where it is drawn before [`Views::compose`] moves it.
    pub view: Rect,
    /// One region (one-view modes) or two (left eye first).
    pub eyes: Vec<EyeRegion>,
}

const FULL_UV: Rect = Rect { min: Pos2 { x: 0.0, y: 0.0 }, max: Pos2 { x: 1.0, y: 1.0 } };

impl Views {
    /// The views of a window covering `window` (points) showing `view` sequences in `mode`.
    /// Mono sequences always fill the window as one view.
    pub fn of(mode: DisplayMode, view: View, window: Rect) -> Views {
        let one =
            Views { view: window, eyes: vec![EyeRegion { region: window, squeeze: Vec2::splat(1.0), uv: FULL_UV }] };
        if view == View::Mono {
            return one;
        }
        let (w, h) = (window.width(), window.height());
        let left_right = |size: Vec2, squeeze: Vec2| {
            let half = |i: f32| Rect::from_min_size(window.min + Vec2::new(i * w / 2.0, 0.0), Vec2::new(w / 2.0, h));
            let uv = |i: f32| Rect::from_min_max(Pos2::new(i / 2.0, 0.0), Pos2::new((i + 1.0) / 2.0, 1.0));
            Views {
                view: Rect::from_min_size(window.min, size),
                eyes: vec![
                    EyeRegion { region: half(0.0), squeeze, uv: uv(0.0) },
                    EyeRegion { region: half(1.0), squeeze, uv: uv(1.0) },
                ],
            }
        };
        match mode {
            DisplayMode::Mono | DisplayMode::Anaglyph | DisplayMode::RowInterleaved => one,
            DisplayMode::SbsFull => left_right(Vec2::new(w / 2.0, h), Vec2::splat(1.0)),
            DisplayMode::SbsHalf => left_right(Vec2::new(w, h), Vec2::new(0.5, 1.0)),
            DisplayMode::TopBottom => {
                let half =
                    |i: f32| Rect::from_min_size(window.min + Vec2::new(0.0, i * h / 2.0), Vec2::new(w, h / 2.0));
                let uv = |i: f32| Rect::from_min_max(Pos2::new(0.0, i / 2.0), Pos2::new(1.0, (i + 1.0) / 2.0));
                let squeeze = Vec2::new(1.0, 0.5);
                Views {
                    view: window,
                    eyes: vec![
                        EyeRegion { region: half(0.0), squeeze, uv: uv(0.0) },
                        EyeRegion { region: half(1.0), squeeze, uv: uv(1.0) },
                    ],
                }
            }
        }
    }

    /// Whether each eye has its own region (the side-by-side and top-bottom modes).
    pub fn is_split(&self) -> bool {
        self.eyes.len() > 1
    }

    /// Where view point `p` appears for eye `eye`.
    pub fn to_window(&self, eye: usize, p: Pos2) -> Pos2 {
        let e = &self.eyes[eye];
        e.region.min + (p - self.view.min) * e.squeeze
    }

    /// Where view rectangle `r` appears for eye `eye`.
    pub fn rect_to_window(&self, eye: usize, r: Rect) -> Rect {
        Rect::from_min_max(self.to_window(eye, r.min), self.to_window(eye, r.max))
    }

    /// The view point shown at window point `p` (the pointer), whichever eye's region it is
    /// in; `None` outside every region.
    pub fn to_view(&self, p: Pos2) -> Option<Pos2> {
        let e = self.eyes.iter().find(|e| e.region.contains(p))?;
        Some(self.view.min + (p - e.region.min) / e.squeeze)
    }

    /// Maps the pointer positions of the window's input events into view coordinates (eframe's
    /// `raw_input_hook`), so that widgets drawn in the view react to clicks on either eye's copy.
    pub fn map_input(&self, input: &mut egui::RawInput) {
        if !self.is_split() {
            return;
        }
        for event in &mut input.events {
            match event {
                egui::Event::PointerMoved(p) | egui::Event::PointerButton { pos: p, .. } => {
                    if let Some(v) = self.to_view(*p) {
                        *p = v;
                    }
                }
                _ => {}
            }
        }
    }

    /// Replaces the shapes of `layer` from index `from` on (what was drawn into the view) by
    /// a copy in each eye's region: moved for `sbs-full`; for the squeezed modes tessellated
    /// and then squeezed, since egui's own transforms scale both axes alike.
    pub fn compose(&self, ctx: &egui::Context, layer: egui::LayerId, from: usize) {
        if !self.is_split() {
            return;
        }
        let shapes: Vec<ClippedShape> =
            ctx.graphics(|g| g.get(layer).map(|l| l.all_entries().skip(from).cloned().collect())).unwrap_or_default();
        let squeezed = self.eyes[0].squeeze != Vec2::splat(1.0);
        let mut tessellator = squeezed.then(|| {
            let font_size = ctx.fonts(|f| f.font_image_size());
            let options = ctx.tessellation_options(|o| *o);
            Tessellator::new(ctx.pixels_per_point(), options, font_size, Vec::new())
        });
        let mut per_eye: Vec<Vec<ClippedShape>> = vec![Vec::with_capacity(shapes.len()); self.eyes.len()];
        for ClippedShape { clip_rect, shape, .. } in shapes {
            for (eye, out) in per_eye.iter_mut().enumerate() {
                let clip = self.rect_to_window(eye, clip_rect).intersect(self.eyes[eye].region);
                let shape = match &mut tessellator {
                    None => {
                        let mut s = shape.clone();
                        s.transform(TSTransform::from_translation(self.to_window(eye, Pos2::ZERO) - Pos2::ZERO));
                        s
                    }
                    Some(t) => {
                        let mut mesh = Mesh::default();
                        t.tessellate_shape(shape.clone(), &mut mesh);
                        for v in &mut mesh.vertices {
                            v.pos = self.to_window(eye, v.pos);
                        }
                        Shape::Mesh(Arc::new(mesh))
                    }
                };
                out.push(ClippedShape::new(clip, shape));
            }
        }
        ctx.graphics_mut(|g| {
            let list = g.entry(layer);
            let mut idx = from;
            for out in per_eye {
                for s in out {
                    if idx < list.next_idx().0 {
                        list.set(egui::layers::ShapeIdx(idx), s.clip_rect, s.shape);
                    } else {
                        list.add(s.clip_rect, s.shape);
                    }
                    idx += 1;
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> Rect {
        Rect::from_min_size(Pos2::ZERO, Vec2::new(1920.0, 1080.0))
    }

    #[test]
    fn side_by_side_halves_take_each_eye_to_its_half_of_the_screen() {
        let full = Views::of(DisplayMode::SbsFull, View::Stereo, window());
        assert_eq!(full.view.size(), Vec2::new(960.0, 1080.0));
        // The view's centre is the centre of each half.
        assert_eq!(full.to_window(0, full.view.center()), Pos2::new(480.0, 540.0));
        assert_eq!(full.to_window(1, full.view.center()), Pos2::new(1440.0, 540.0));
        assert_eq!(full.eyes[1].uv, Rect::from_min_max(Pos2::new(0.5, 0.0), Pos2::new(1.0, 1.0)));
        let half = Views::of(DisplayMode::SbsHalf, View::Stereo, window());
        // Each eye's view is the whole screen, squeezed into its half.
        assert_eq!(half.view, window());
        let r = Rect::from_center_size(half.view.center(), Vec2::new(640.0, 360.0));
        assert_eq!(half.rect_to_window(0, r), Rect::from_center_size(Pos2::new(480.0, 540.0), Vec2::new(320.0, 360.0)));
        assert_eq!(
            half.rect_to_window(1, r),
            Rect::from_center_size(Pos2::new(1440.0, 540.0), Vec2::new(320.0, 360.0))
        );
        let tb = Views::of(DisplayMode::TopBottom, View::Stereo, window());
        assert_eq!(tb.rect_to_window(1, r), Rect::from_center_size(Pos2::new(960.0, 810.0), Vec2::new(640.0, 180.0)));
        assert_eq!(tb.eyes[0].uv.max, Pos2::new(1.0, 0.5));
        for mode in [DisplayMode::Mono, DisplayMode::Anaglyph, DisplayMode::RowInterleaved] {
            let one = Views::of(mode, View::Stereo, window());
            assert!(!one.is_split() && one.view == window() && one.eyes[0].uv == FULL_UV, "{mode}");
        }
        // Mono sequences are never split.
        assert!(!Views::of(DisplayMode::SbsFull, View::Mono, window()).is_split());
    }

    #[test]
    fn the_pointer_maps_back_from_either_eye_to_the_same_view_point() {
        for mode in [DisplayMode::SbsFull, DisplayMode::SbsHalf, DisplayMode::TopBottom] {
            let v = Views::of(mode, View::Stereo, window());
            let p = Pos2::new(700.0, 300.0).min(v.view.max);
            for eye in 0..2 {
                let on_screen = v.to_window(eye, p);
                let back = v.to_view(on_screen).unwrap();
                assert!((back - p).length() < 1e-3, "{mode} eye {eye}: {back:?}");
            }
            let mut input = egui::RawInput::default();
            input.events.push(egui::Event::PointerMoved(v.to_window(1, p)));
            v.map_input(&mut input);
            assert_eq!(input.events[0], egui::Event::PointerMoved(p), "{mode}");
        }
    }

    #[test]
    fn compose_draws_the_view_in_both_eyes_at_equal_positions() {
        for mode in [DisplayMode::SbsFull, DisplayMode::SbsHalf, DisplayMode::TopBottom] {
            let ctx = egui::Context::default();
            let v = Views::of(mode, View::Stereo, window());
            let mut input = egui::RawInput { screen_rect: Some(window()), ..Default::default() };
            input.events.clear();
            let layer = egui::LayerId::background();
            let mut output = ctx.run_ui(input, |ui| {
                let painter = ui.ctx().layer_painter(layer);
                let from = ctx.graphics(|g| g.get(layer).map_or(0, |l| l.next_idx().0));
                painter.rect_filled(
                    Rect::from_min_size(Pos2::new(100.0, 200.0), Vec2::new(40.0, 20.0)),
                    0.0,
                    egui::Color32::RED,
                );
                painter.text(
                    Pos2::new(300.0, 400.0),
                    egui::Align2::LEFT_TOP,
                    "Ready",
                    egui::FontId::default(),
                    egui::Color32::BLACK,
                );
                v.compose(ui.ctx(), layer, from);
                let bounds: Vec<Rect> = ctx.graphics(|g| {
                    g.get(layer).unwrap().all_entries().skip(from).map(|s| s.shape.visual_bounding_rect()).collect()
                });
                // Two shapes, each drawn once per eye: left eye's first.
                assert_eq!(bounds.len(), 4, "{mode}");
                for k in 0..2 {
                    let (l, r) = (bounds[k], bounds[k + 2]);
                    assert!(v.eyes[0].region.contains_rect(l) && v.eyes[1].region.contains_rect(r), "{mode} {k}");
                    let offset = v.eyes[1].region.min - v.eyes[0].region.min;
                    assert!(((r.min - offset) - l.min).length() < 1e-3, "{mode} {k}: {l:?} {r:?}");
                    assert!((r.size() - l.size()).length() < 1e-3);
                }
                // The rectangle lands where the view says, squeezed.
                let want = v.rect_to_window(0, Rect::from_min_size(Pos2::new(100.0, 200.0), Vec2::new(40.0, 20.0)));
                assert!((bounds[0].center() - want.center()).length() < 1.0, "{mode}: {:?} vs {want:?}", bounds[0]);
                assert!((bounds[0].width() - want.width()).abs() < 1.5, "{mode}: {:?} vs {want:?}", bounds[0]);
            });
            // The font atlas's upload is nobody's here.
            output.textures_delta.clear();
        }
    }
}
