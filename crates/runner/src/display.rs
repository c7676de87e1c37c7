//! Display modes as pixel transforms from a decoded frame to the image put on screen.
//!
//! A stereo frame is `2W x H` with the left eye on the left (docs/formats.md). The modes:
//! `mono` (a mono frame unchanged; the left eye of a stereo frame), `sbs-full` (unchanged),
//! `sbs-half` (each eye squeezed to `W/2`, for 3D displays in side-by-side mode),
//! `top-bottom` (left eye above the right, each squeezed to `H/2`), `anaglyph` (red-cyan with
//! Dubois's least-squares matrices, applied in linear light) and `row-interleaved` (for
//! passive polarised monitors whose first line is polarised for the left eye: even *screen
//! lines*, physical pixel rows counted from 0 at the top of the window's framebuffer, show the
//! left eye, odd ones the right eye; [`line_eye`]).
//!
//! Row-interleaving depends on where the image lands: at scale 2 every image row covers two
//! screen lines, and at scale 1 an image whose top is on an odd line would swap the eyes. The
//! window composes it on the GPU by screen line ([`crate::gpu`]); its twin is
//! [`row_interleave_on_screen`] (the screen image for a given top line and drawn size).
//! [`transform`] interleaves image rows (even rows from the left eye), which is the same thing
//! on screen only at one screen pixel per image pixel with the image's top on an even line:
//! the CPU fallback draws it only so, and warns otherwise.
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
        Rgba8 { width, height, pixels: rgba.repeat(width as usize * height as usize) }
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

pub use study::color::{linear_to_srgb8, srgb8_to_linear};

/// Fast sRGB conversions: a 256-entry table from sRGB codes to linear light, and for the
/// way back the smallest linear value of every output code (found once by bisection over the
/// exact [`linear_to_srgb8`]) plus a 4096-bin table of the code at the start of each bin. No
/// bin spans more than one code boundary (the curve's steepest slope is 12.92 * 255 codes per
/// unit, 0.8 codes per bin), so one comparison with the next code's threshold finishes the
/// lookup. [`Tables::encode`] therefore returns exactly what [`linear_to_srgb8`] returns (it
/// is monotonic), with no `powf` per pixel, in debug builds too.
struct Tables {
    to_linear: [f32; 256],
    /// `coarse[i] = linear_to_srgb8(i / BINS)`, the code of any `l` in bin `i` or one less.
    coarse: [u8; BINS + 1],
    /// `split[i] = thresholds()[coarse[i] + 1]`: from there on bin `i` has the next code (kept
    /// per bin so the two loads of [`Tables::encode`] do not wait on each other).
    split: [f32; BINS + 1],
}

const BINS: usize = 4096;

static TABLES: std::sync::LazyLock<Tables> = std::sync::LazyLock::new(Tables::new);

/// `thresholds()[c]`: the smallest `l` in [0, 1] with `linear_to_srgb8(l) >= c` (c >= 1), by
/// bisection over the bit patterns of non-negative floats, which are ordered like the floats;
/// `thresholds()[256]` is infinite.
fn thresholds() -> [f32; 257] {
    std::array::from_fn(|c| {
        if c > 255 {
            return f32::INFINITY;
        }
        let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if usize::from(linear_to_srgb8(f32::from_bits(mid))) >= c { hi = mid } else { lo = mid + 1 }
        }
        f32::from_bits(lo)
    })
}

impl Tables {
    fn new() -> Self {
        let to_linear = std::array::from_fn(|i| srgb8_to_linear(i as u8));
        let threshold = thresholds();
        let coarse: [u8; BINS + 1] = std::array::from_fn(|i| linear_to_srgb8(i as f32 / BINS as f32));
        // The single comparison in `encode` needs every bin to cross at most one code boundary.
        assert!(coarse.windows(2).all(|w| w[1] - w[0] <= 1), "sRGB bins too coarse");
        let split = std::array::from_fn(|i| threshold[usize::from(coarse[i]) + 1]);
        Tables { to_linear, coarse, split }
    }

    fn lin(&self, p: &[u8; 4]) -> [f32; 3] {
        [self.to_linear[usize::from(p[0])], self.to_linear[usize::from(p[1])], self.to_linear[usize::from(p[2])]]
    }

    /// [`linear_to_srgb8`] by table.
    fn encode(&self, l: f32) -> u8 {
        let l = if l.is_finite() { l.clamp(0.0, 1.0) } else { 0.0 };
        let i = (l * BINS as f32) as usize;
        self.coarse[i] + u8::from(l >= self.split[i])
    }
}

/// [`linear_to_srgb8`] through lookup tables (the same result, much faster).
pub fn linear_to_srgb_fast(l: f32) -> u8 {
    TABLES.encode(l)
}

/// The pixels of a row as 4-byte arrays.
fn px(row: &[u8]) -> &[[u8; 4]] {
    row.as_chunks::<4>().0
}

fn average(t: &Tables, a: &[u8; 4], b: &[u8; 4], out: &mut [u8; 4]) {
    let (la, lb) = (t.lin(a), t.lin(b));
    out[0] = t.encode((la[0] + lb[0]) * 0.5);
    out[1] = t.encode((la[1] + lb[1]) * 0.5);
    out[2] = t.encode((la[2] + lb[2]) * 0.5);
    out[3] = (u16::from(a[3]) + u16::from(b[3])).div_ceil(2) as u8;
}

/// One pixel of the Dubois red-cyan anaglyph from a left and a right sRGB pixel.
pub fn anaglyph_pixel(left: [u8; 4], right: [u8; 4]) -> [u8; 4] {
    let mut out = [0u8; 4];
    anaglyph_with(&TABLES, &left, &right, &mut out);
    out
}

fn anaglyph_with(t: &Tables, left: &[u8; 4], right: &[u8; 4], out: &mut [u8; 4]) {
    let (l, r) = (t.lin(left), t.lin(right));
    let (a, b) = (&DUBOIS_LEFT, &DUBOIS_RIGHT);
    for c in 0..3 {
        let v =
            (a[c][0] * l[0] + b[c][0] * r[0]) + (a[c][1] * l[1] + b[c][1] * r[1]) + (a[c][2] * l[2] + b[c][2] * r[2]);
        out[c] = t.encode(v);
    }
    out[3] = 255;
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
/// unchanged (not copied) whatever the mode; stereo frames need an even width.
pub fn transform(mode: DisplayMode, view: View, frame: Rgba8) -> Rgba8 {
    if view == View::Mono || mode == DisplayMode::SbsFull {
        return frame;
    }
    let t: &Tables = &TABLES;
    let eye_w = frame.width as usize / 2;
    let h = frame.height as usize;
    let row_bytes = frame.width as usize * 4;
    let eye_bytes = eye_w * 4;
    // Row y of the left and right eye.
    let eyes = |y: usize| {
        let row = &frame.pixels[y * row_bytes..(y + 1) * row_bytes];
        (&row[..eye_bytes], &row[eye_bytes..2 * eye_bytes])
    };
    // Opaque black where a squeeze of an odd size leaves a last column or row unfilled.
    let mut out = Rgba8::filled(eye_w as u32, h as u32, [0, 0, 0, 255]);
    match mode {
        DisplayMode::SbsFull => unreachable!("handled above"),
        DisplayMode::Mono => {
            for (y, o) in out.pixels.chunks_exact_mut(eye_bytes).enumerate() {
                o.copy_from_slice(eyes(y).0);
            }
        }
        DisplayMode::RowInterleaved => {
            // Image rows: right on screen only at scale 1 with the top on an even line.
            for (y, o) in out.pixels.chunks_exact_mut(eye_bytes).enumerate() {
                let (l, r) = eyes(y);
                o.copy_from_slice(if y % 2 == 0 { l } else { r });
            }
        }
        DisplayMode::Anaglyph => {
            for (y, o) in out.pixels.chunks_exact_mut(eye_bytes).enumerate() {
                let (l, r) = eyes(y);
                for ((o, l), r) in
                    o.as_chunks_mut::<4>().0.iter_mut().zip(l.as_chunks::<4>().0).zip(r.as_chunks::<4>().0)
                {
                    anaglyph_with(t, l, r, o);
                }
            }
        }
        DisplayMode::SbsHalf => {
            // Each eye of width eye_w becomes eye_w / 2 wide: the output is eye_w wide in all.
            let half = eye_w / 2;
            for (y, o) in out.pixels.chunks_exact_mut(eye_bytes).enumerate() {
                let (l, r) = eyes(y);
                let (ol, or) = o.split_at_mut(half * 4);
                for (src, dst) in [(l, ol), (r, or)] {
                    for (pair, d) in src.as_chunks::<8>().0.iter().zip(dst.as_chunks_mut::<4>().0) {
                        let (a, b) = pair.split_at(4);
                        average(t, a.try_into().expect("4 bytes"), b.try_into().expect("4 bytes"), d);
                    }
                }
            }
        }
        DisplayMode::TopBottom => {
            let half = h / 2;
            let (top, bottom) = out.pixels.split_at_mut(half * eye_bytes);
            for (y, (ot, ob)) in top.chunks_exact_mut(eye_bytes).zip(bottom.chunks_exact_mut(eye_bytes)).enumerate() {
                let ((l0, r0), (l1, r1)) = (eyes(2 * y), eyes(2 * y + 1));
                for ((o, a), b) in ot.as_chunks_mut::<4>().0.iter_mut().zip(px(l0)).zip(px(l1)) {
                    average(t, a, b, o);
                }
                for ((o, a), b) in ob.as_chunks_mut::<4>().0.iter_mut().zip(px(r0)).zip(px(r1)) {
                    average(t, a, b, o);
                }
            }
        }
    }
    out
}

/// The eye a screen line shows in `row-interleaved`: 0 (left) for even lines, 1 (right) for
/// odd ones, lines counted in physical pixels from 0 at the top of the framebuffer.
pub fn line_eye(screen_line: u32) -> usize {
    (screen_line % 2) as usize
}

/// The screen image of a side-by-side stereo `frame` (`2W x H`) in `row-interleaved`, drawn
/// at `size` screen pixels (`w x h`, any scale) with a nearest sampler, its top on screen
/// line `top_line`: pixel (x, y) is pixel (floor((x + 1/2) W / w), floor((y + 1/2) H / h)) of
/// the eye of line `top_line + y` ([`line_eye`]), the image pixel under the screen pixel's
/// centre. The CPU twin of the GPU's composition (`fs_compose` in `stimulus.wgsl`).
pub fn row_interleave_on_screen(frame: &Rgba8, (w, h): (u32, u32), top_line: u32) -> Rgba8 {
    let eye_w = u64::from(frame.width / 2);
    let src = |i: u32, n: u32, image: u64| ((2 * u64::from(i) + 1) * image / (2 * u64::from(n))) as u32;
    let mut out = Rgba8::filled(w, h, [0, 0, 0, 255]);
    for y in 0..h {
        let (sy, eye) = (src(y, h, u64::from(frame.height)), line_eye(top_line + y) as u32);
        for x in 0..w {
            out.set(x, y, frame.get(eye * eye_w as u32 + src(x, w, eye_w), sy));
        }
    }
    out
}

/// The width in source pixels of one eye's image: the width that must subtend the
/// definition's visual angle (for squeezed modes the display stretches it back).
pub fn eye_width(view: View, frame_width: u32) -> u32 {
    match view {
        View::Mono => frame_width,
        View::Stereo => frame_width / 2,
    }
}

/// Whether frames of `view` shown in `mode` are composed on the GPU when drawn: the stereo
/// modes that compute new pixels (anaglyph, sbs-half, top-bottom) and row-interleaving,
/// whose eye per pixel depends on the screen line it lands on (known only when drawn). `mono`
/// (the left eye) is a crop the CPU does while decoding for less than uploading the other
/// half costs.
pub fn composes_on_gpu(mode: DisplayMode, view: View) -> bool {
    view == View::Stereo
        && matches!(
            mode,
            DisplayMode::Anaglyph | DisplayMode::SbsHalf | DisplayMode::TopBottom | DisplayMode::RowInterleaved
        )
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
            assert_eq!(linear_to_srgb8(srgb8_to_linear(v)), v);
        }
        assert!((srgb8_to_linear(128) - 0.2158605).abs() < 1e-5);
    }

    #[test]
    fn anaglyph_applies_dubois_matrices_in_linear_light() {
        // White left, black right: output = Dubois left row sums, clamped.
        let p = anaglyph_pixel([255, 255, 255, 255], [0, 0, 0, 255]);
        assert_eq!(p, [linear_to_srgb8(0.437 + 0.449 + 0.164), 0, 0, 255]);
        // Black left, white right: red clamps to 0; green 1.147 clamps to 255; blue 1.115 clamps.
        assert_eq!(anaglyph_pixel([0, 0, 0, 255], [255, 255, 255, 255]), [0, 255, 255, 255]);
        // Mid grey in both eyes: each channel is the column sum of both matrices times 0.2159.
        let g = srgb8_to_linear(128);
        let expect =
            |c: usize| -> u8 { linear_to_srgb8((0..3).map(|k| (DUBOIS_LEFT[c][k] + DUBOIS_RIGHT[c][k]) * g).sum()) };
        assert_eq!(anaglyph_pixel([128, 128, 128, 255], [128, 128, 128, 255]), [expect(0), expect(1), expect(2), 255]);
        // A pure red left-eye pixel with black right gives 0.437 red.
        assert_eq!(anaglyph_pixel([255, 0, 0, 255], [0, 0, 0, 255]), [linear_to_srgb8(0.437), 0, 0, 255]);
        // The transform covers each pixel pair of a whole frame.
        let out = transform(DisplayMode::Anaglyph, View::Stereo, stereo([255, 0, 0, 255], [0, 255, 255, 255], 3, 2));
        assert_eq!((out.width, out.height), (3, 2));
        let one = anaglyph_pixel([255, 0, 0, 255], [0, 255, 255, 255]);
        assert!(out.pixels.chunks(4).all(|p| p == one));
    }

    #[test]
    fn row_interleave_takes_even_rows_from_the_left_eye() {
        let l = [10, 20, 30, 255];
        let r = [200, 210, 220, 255];
        let out = transform(DisplayMode::RowInterleaved, View::Stereo, stereo(l, r, 3, 5));
        assert_eq!((out.width, out.height), (3, 5));
        for y in 0..5 {
            for x in 0..3 {
                assert_eq!(out.get(x, y), if y % 2 == 0 { l } else { r }, "({x},{y})");
            }
        }
    }

    #[test]
    fn row_interleave_on_screen_takes_each_line_from_its_eye() {
        // Each pixel codes its eye, column and row, so every lookup can be checked.
        let (eye, h) = (5u32, 3u32);
        let mut f = Rgba8::filled(2 * eye, h, [0, 0, 0, 255]);
        for y in 0..h {
            for x in 0..2 * eye {
                f.set(x, y, [(x / eye) as u8, (x % eye) as u8, y as u8, 255]);
            }
        }
        for top in [0u32, 1, 2, 7] {
            for s in [1u32, 2, 3] {
                let out = row_interleave_on_screen(&f, (s * eye, s * h), top);
                for y in 0..s * h {
                    for x in 0..s * eye {
                        let want = [((top + y) % 2) as u8, (x / s) as u8, (y / s) as u8, 255];
                        assert_eq!(out.get(x, y), want, "top {top} scale {s} ({x},{y})");
                    }
                }
            }
        }
        // At scale 1 with the top on an even line it is the image-row interleave.
        let cpu = transform(DisplayMode::RowInterleaved, View::Stereo, f.clone());
        assert_eq!(row_interleave_on_screen(&f, (eye, h), 4), cpu);
        assert_ne!(row_interleave_on_screen(&f, (eye, h), 3), cpu);
        // A scale of 1.5: pixel centres map to the image pixel under them.
        let out = row_interleave_on_screen(&f, (7, 4), 1);
        assert_eq!(out.get(6, 3), [0, 4, 2, 255]);
        assert_eq!(out.get(1, 0), [1, 1, 0, 255]);
        assert_eq!(out.get(2, 1), [0, 1, 1, 255]);
        assert_eq!(out.get(0, 2), [1, 0, 1, 255]);
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
        let half = transform(DisplayMode::SbsHalf, View::Stereo, f.clone());
        assert_eq!((half.width, half.height), (4, 4));
        let mid = linear_to_srgb8(0.5);
        assert_eq!(half.get(0, 0), [mid, mid, mid, 255]);
        assert_eq!(half.get(1, 3), [mid, mid, mid, 255]);
        assert_eq!(half.get(2, 0), [100, 100, 100, 255]);
        let tb = transform(DisplayMode::TopBottom, View::Stereo, f.clone());
        assert_eq!((tb.width, tb.height), (4, 4));
        assert_eq!(tb.get(0, 0), [0, 0, 0, 255]);
        assert_eq!(tb.get(1, 1), [255, 255, 255, 255]);
        assert_eq!(tb.get(3, 2), [100, 100, 100, 255]);
        assert_eq!(transform(DisplayMode::Mono, View::Stereo, f.clone()), f.crop(0, 0, 4, 4));
        assert_eq!(transform(DisplayMode::SbsFull, View::Stereo, f.clone()), f);
        assert_eq!(transform(DisplayMode::Anaglyph, View::Mono, f.clone()), f);
        for mode in DisplayMode::ALL {
            let out = transform(mode, View::Stereo, f.clone());
            assert_eq!(output_size(mode, View::Stereo, 8, 4), (out.width, out.height), "{mode}");
        }
    }

    /// The exact formulas in f64 (`powf` per value), the reference of the table path.
    fn exact_linear(v: u8) -> f64 {
        study::color::srgb_decode(f64::from(v) / 255.0)
    }
    fn exact_code(l: f64) -> f64 {
        255.0 * study::color::srgb_encode(l.clamp(0.0, 1.0))
    }

    #[test]
    fn table_encoding_equals_the_formula() {
        // Dense samples over [0, 1] (every 331st float bit pattern) and the edges of every code.
        let mut checked = 0;
        for bits in (0..=1.0f32.to_bits()).step_by(331) {
            let l = f32::from_bits(bits);
            assert_eq!(linear_to_srgb_fast(l), linear_to_srgb8(l), "l = {l:e}");
            checked += 1;
        }
        assert!(checked > 3_000_000);
        let threshold = thresholds();
        for c in 1..=255u8 {
            let t = threshold[usize::from(c)];
            let below = f32::from_bits(t.to_bits() - 1);
            assert_eq!((linear_to_srgb8(t), linear_to_srgb8(below)), (c, c - 1), "code {c}");
            assert_eq!((linear_to_srgb_fast(t), linear_to_srgb_fast(below)), (c, c - 1), "code {c}");
        }
        for l in [-1.0, 1.5, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(linear_to_srgb_fast(l), linear_to_srgb8(l), "{l}");
        }
    }

    #[test]
    fn fast_anaglyph_is_within_one_code_of_the_exact_formula() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let mut px = || -> [u8; 4] {
            let v = rng.next_u32().to_le_bytes();
            [v[0], v[1], v[2], 255]
        };
        let mut pairs: Vec<([u8; 4], [u8; 4])> = (0..200_000).map(|_| (px(), px())).collect();
        // Greys and primaries, where clamping and the linear toe of the curve meet.
        for v in [0u8, 1, 2, 5, 10, 11, 12, 50, 128, 200, 254, 255] {
            pairs.push(([v, v, v, 255], [v, v, v, 255]));
            pairs.push(([v, 0, 0, 255], [0, v, v, 255]));
        }
        let mut frame = Rgba8::filled(2 * pairs.len() as u32, 1, [0, 0, 0, 255]);
        for (x, (l, r)) in pairs.iter().enumerate() {
            frame.set(x as u32, 0, *l);
            frame.set((pairs.len() + x) as u32, 0, *r);
        }
        let out = transform(DisplayMode::Anaglyph, View::Stereo, frame);
        let mut exact_matches = 0;
        for (x, (l, r)) in pairs.iter().enumerate() {
            let got = out.get(x as u32, 0);
            for c in 0..3 {
                let v: f64 = (0..3)
                    .map(|k| {
                        f64::from(DUBOIS_LEFT[c][k]) * exact_linear(l[k])
                            + f64::from(DUBOIS_RIGHT[c][k]) * exact_linear(r[k])
                    })
                    .sum();
                let want = exact_code(v);
                assert!((f64::from(got[c]) - want).abs() <= 1.0, "{l:?} {r:?} channel {c}: {} vs {want}", got[c]);
                exact_matches += usize::from(got[c] == (want + 0.5) as u8);
            }
            assert_eq!(got[3], 255);
        }
        // Rounding differs from the f64 formula only where it sits on a half code.
        assert!(exact_matches as f64 > 0.999 * 3.0 * pairs.len() as f64, "{exact_matches}");
    }
}
