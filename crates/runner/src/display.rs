//! Display modes as pixel transforms from a decoded frame to the image put on screen.
//!
//! A stereo frame is `2W x H` with the left eye on the left (docs/formats.md). The modes:
//! `mono` (a mono frame unchanged; the left eye of a stereo frame), `sbs-full` (unchanged),
//! `sbs-half` (each eye squeezed to `W/2`, for 3D displays in side-by-side mode),
//! `top-bottom` (left eye above the right, each squeezed to `H/2`), `anaglyph` (red-cyan with
//! Dubois's least-squares matrices, applied in linear light) and `row-interleaved` (even
//! rows, counted from 0 at the top, from the left eye; odd rows from the right eye, for
//! passive polarised monitors whose first line is polarised for the left eye).
//!
//! Squeezing averages adjacent pixel pairs in linear light, so a squeezed frame has the
//! mean luminance of the original.

use study::View;
use study::experiment::DisplayMode;

/// An 8-bit RGBA image, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgba8 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub pixels: Vec<u8>,
}

impl Rgba8 {
    /// A new image filled with one colour.
    pub fn filled(width: u32, height: u32, rgba: [u8; 4]) -> Self {
        let pixels = rgba.iter().copied().cycle().take(width as usize * height as usize * 4).collect();
        Rgba8 { width, height, pixels }
    }

    /// The pixel at (x, y).
    pub fn get(&self, x: u32, y: u32) -> [u8; 4] {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2], self.pixels[i + 3]]
    }

    /// Sets the pixel at (x, y).
    pub fn set(&mut self, x: u32, y: u32, rgba: [u8; 4]) {
        let i = (y as usize * self.width as usize + x as usize) * 4;
        self.pixels[i..i + 4].copy_from_slice(&rgba);
    }

    /// The rectangle `x0..x0+w` x `y0..y0+h`.
    pub fn crop(&self, x0: u32, y0: u32, w: u32, h: u32) -> Rgba8 {
        let mut pixels = Vec::with_capacity(w as usize * h as usize * 4);
        for y in y0..y0 + h {
            let start = (y as usize * self.width as usize + x0 as usize) * 4;
            pixels.extend_from_slice(&self.pixels[start..start + w as usize * 4]);
        }
        Rgba8 { width: w, height: h, pixels }
    }
}

/// Dubois's red-cyan matrix for the left eye (rows: output R, G, B; columns: input R, G, B).
pub const DUBOIS_LEFT: [[f32; 3]; 3] = [[0.437, 0.449, 0.164], [-0.062, -0.062, -0.024], [-0.048, -0.050, -0.017]];
/// Dubois's red-cyan matrix for the right eye.
pub const DUBOIS_RIGHT: [[f32; 3]; 3] = [[-0.011, -0.032, -0.007], [0.377, 0.761, 0.009], [-0.026, -0.093, 1.234]];

/// sRGB 8-bit to linear.
pub fn srgb_to_linear(v: u8) -> f32 {
    let c = f32::from(v) / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Linear to sRGB 8-bit (clamped, rounded).
pub fn linear_to_srgb(l: f32) -> u8 {
    let l = if l.is_finite() { l.clamp(0.0, 1.0) } else { 0.0 };
    let c = if l <= 0.003_130_8 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (c * 255.0 + 0.5) as u8
}

struct Lut([f32; 256]);
impl Lut {
    fn new() -> Self {
        Lut(std::array::from_fn(|i| srgb_to_linear(i as u8)))
    }
    fn lin(&self, p: [u8; 4]) -> [f32; 3] {
        [self.0[p[0] as usize], self.0[p[1] as usize], self.0[p[2] as usize]]
    }
}

fn average(lut: &Lut, a: [u8; 4], b: [u8; 4]) -> [u8; 4] {
    let (la, lb) = (lut.lin(a), lut.lin(b));
    [
        linear_to_srgb((la[0] + lb[0]) * 0.5),
        linear_to_srgb((la[1] + lb[1]) * 0.5),
        linear_to_srgb((la[2] + lb[2]) * 0.5),
        (u16::from(a[3]) + u16::from(b[3])).div_ceil(2) as u8,
    ]
}

/// One pixel of the Dubois red-cyan anaglyph from a left and a right sRGB pixel.
pub fn anaglyph_pixel(left: [u8; 4], right: [u8; 4]) -> [u8; 4] {
    let lut = Lut::new();
    anaglyph_with(&lut, left, right)
}

fn anaglyph_with(lut: &Lut, left: [u8; 4], right: [u8; 4]) -> [u8; 4] {
    let (l, r) = (lut.lin(left), lut.lin(right));
    let mut out = [0u8; 4];
    for (c, o) in out.iter_mut().take(3).enumerate() {
        let v: f32 = (0..3).map(|k| DUBOIS_LEFT[c][k] * l[k] + DUBOIS_RIGHT[c][k] * r[k]).sum();
        *o = linear_to_srgb(v);
    }
    out[3] = 255;
    out
}

/// The size of the displayed image for a frame of `width x height` in `view`.
pub fn output_size(mode: DisplayMode, view: View, width: u32, height: u32) -> (u32, u32) {
    match (view, mode) {
        (View::Mono, _) | (View::Stereo, DisplayMode::SbsFull) => (width, height),
        (View::Stereo, DisplayMode::Mono | DisplayMode::Anaglyph | DisplayMode::RowInterleaved) => (width / 2, height),
        (View::Stereo, DisplayMode::SbsHalf) => (width / 2, height),
        (View::Stereo, DisplayMode::TopBottom) => (width / 2, height),
    }
}

/// Transforms a decoded frame into the image shown in `mode`. Mono frames are returned
/// unchanged whatever the mode; stereo frames need an even width.
pub fn transform(mode: DisplayMode, view: View, frame: &Rgba8) -> Rgba8 {
    if view == View::Mono || mode == DisplayMode::SbsFull {
        return frame.clone();
    }
    let eye_w = frame.width / 2;
    let h = frame.height;
    let left = |x: u32, y: u32| frame.get(x, y);
    let right = |x: u32, y: u32| frame.get(eye_w + x, y);
    let lut = Lut::new();
    match mode {
        DisplayMode::SbsFull => unreachable!("handled above"),
        DisplayMode::Mono => frame.crop(0, 0, eye_w, h),
        DisplayMode::Anaglyph => {
            let mut out = Rgba8::filled(eye_w, h, [0, 0, 0, 255]);
            for y in 0..h {
                for x in 0..eye_w {
                    out.set(x, y, anaglyph_with(&lut, left(x, y), right(x, y)));
                }
            }
            out
        }
        DisplayMode::RowInterleaved => {
            let mut out = Rgba8::filled(eye_w, h, [0, 0, 0, 255]);
            for y in 0..h {
                for x in 0..eye_w {
                    out.set(x, y, if y % 2 == 0 { left(x, y) } else { right(x, y) });
                }
            }
            out
        }
        DisplayMode::SbsHalf => {
            // Each eye of width eye_w becomes eye_w / 2 wide: output is eye_w wide in all.
            let half = eye_w / 2;
            let mut out = Rgba8::filled(eye_w, h, [0, 0, 0, 255]);
            for y in 0..h {
                for x in 0..half {
                    out.set(x, y, average(&lut, left(2 * x, y), left(2 * x + 1, y)));
                    out.set(half + x, y, average(&lut, right(2 * x, y), right(2 * x + 1, y)));
                }
            }
            out
        }
        DisplayMode::TopBottom => {
            let half = h / 2;
            let mut out = Rgba8::filled(eye_w, h, [0, 0, 0, 255]);
            for y in 0..half {
                for x in 0..eye_w {
                    out.set(x, y, average(&lut, left(x, 2 * y), left(x, 2 * y + 1)));
                    out.set(x, half + y, average(&lut, right(x, 2 * y), right(x, 2 * y + 1)));
                }
            }
            out
        }
    }
}

/// The width in source pixels of one eye's image: the width that must subtend the
/// definition's visual angle (for squeezed modes the display stretches it back).
pub fn eye_width(view: View, frame_width: u32) -> u32 {
    match view {
        View::Mono => frame_width,
        View::Stereo => frame_width / 2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4x2 stereo frame: left eye pure red, right eye pure cyan, alpha 255.
    fn stereo(left: [u8; 4], right: [u8; 4], w: u32, h: u32) -> Rgba8 {
        let mut f = Rgba8::filled(2 * w, h, [0, 0, 0, 255]);
        for y in 0..h {
            for x in 0..w {
                f.set(x, y, left);
                f.set(w + x, y, right);
            }
        }
        f
    }

    #[test]
    fn srgb_round_trips_every_code() {
        for v in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(v)), v);
        }
        assert!((srgb_to_linear(128) - 0.2158605).abs() < 1e-5);
    }

    #[test]
    fn anaglyph_applies_dubois_matrices_in_linear_light() {
        // White left, black right: output = Dubois left row sums, clamped.
        let p = anaglyph_pixel([255, 255, 255, 255], [0, 0, 0, 255]);
        assert_eq!(p, [linear_to_srgb(0.437 + 0.449 + 0.164), 0, 0, 255]);
        // Black left, white right: red clamps to 0; green 1.147 clamps to 255; blue 1.115 clamps.
        assert_eq!(anaglyph_pixel([0, 0, 0, 255], [255, 255, 255, 255]), [0, 255, 255, 255]);
        // Mid grey in both eyes: each channel is the column sum of both matrices times 0.2159.
        let g = srgb_to_linear(128);
        let expect =
            |c: usize| -> u8 { linear_to_srgb((0..3).map(|k| (DUBOIS_LEFT[c][k] + DUBOIS_RIGHT[c][k]) * g).sum()) };
        assert_eq!(anaglyph_pixel([128, 128, 128, 255], [128, 128, 128, 255]), [expect(0), expect(1), expect(2), 255]);
        // A pure red left-eye pixel with black right gives 0.437 red.
        assert_eq!(anaglyph_pixel([255, 0, 0, 255], [0, 0, 0, 255]), [linear_to_srgb(0.437), 0, 0, 255]);
        // The transform covers each pixel pair of a whole frame.
        let out = transform(DisplayMode::Anaglyph, View::Stereo, &stereo([255, 0, 0, 255], [0, 255, 255, 255], 3, 2));
        assert_eq!((out.width, out.height), (3, 2));
        let one = anaglyph_pixel([255, 0, 0, 255], [0, 255, 255, 255]);
        assert!(out.pixels.chunks(4).all(|p| p == one));
    }

    #[test]
    fn row_interleave_takes_even_rows_from_the_left_eye() {
        let l = [10, 20, 30, 255];
        let r = [200, 210, 220, 255];
        let out = transform(DisplayMode::RowInterleaved, View::Stereo, &stereo(l, r, 3, 5));
        assert_eq!((out.width, out.height), (3, 5));
        for y in 0..5 {
            for x in 0..3 {
                assert_eq!(out.get(x, y), if y % 2 == 0 { l } else { r }, "({x},{y})");
            }
        }
    }

    #[test]
    fn squeezes_average_in_linear_light_and_keep_eyes_apart() {
        // Left eye: columns alternate black/white; right eye: uniform 100.
        let mut f = stereo([0, 0, 0, 255], [100, 100, 100, 255], 4, 4);
        for y in 0..4 {
            for x in (1..4).step_by(2) {
                f.set(x, y, [255, 255, 255, 255]);
            }
        }
        let half = transform(DisplayMode::SbsHalf, View::Stereo, &f);
        assert_eq!((half.width, half.height), (4, 4));
        let mid = linear_to_srgb(0.5);
        assert_eq!(half.get(0, 0), [mid, mid, mid, 255]);
        assert_eq!(half.get(1, 3), [mid, mid, mid, 255]);
        assert_eq!(half.get(2, 0), [100, 100, 100, 255]);
        let tb = transform(DisplayMode::TopBottom, View::Stereo, &f);
        assert_eq!((tb.width, tb.height), (4, 4));
        assert_eq!(tb.get(0, 0), [0, 0, 0, 255]);
        assert_eq!(tb.get(1, 1), [255, 255, 255, 255]);
        assert_eq!(tb.get(3, 2), [100, 100, 100, 255]);
        assert_eq!(transform(DisplayMode::Mono, View::Stereo, &f), f.crop(0, 0, 4, 4));
        assert_eq!(transform(DisplayMode::SbsFull, View::Stereo, &f), f);
        assert_eq!(transform(DisplayMode::Anaglyph, View::Mono, &f), f);
        for mode in DisplayMode::ALL {
            let out = transform(mode, View::Stereo, &f);
            assert_eq!(output_size(mode, View::Stereo, 8, 4), (out.width, out.height), "{mode}");
        }
    }
}
