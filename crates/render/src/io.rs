//! Image output: linear radiance buffers, tone mapping, sRGB PNG and linear EXR encoding,
//! and decoding of linear EXR / Radiance HDR files (used for environment maps).
//!
//! Encoding is deterministic: the same image gives the same bytes, so manifests can hash
//! frames.

use std::io::Cursor;

use study::color::{srgb_decode, srgb_encode};
use study::scene::{Exposure, ToneMap};

/// Errors of encoding or decoding images.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The EXR encoder or decoder failed.
    #[error("EXR: {0}")]
    Exr(String),
    /// The PNG encoder or the HDR decoder failed.
    #[error("image: {0}")]
    Image(String),
    /// Pixel buffer and dimensions disagree.
    #[error("image is {width}x{height} but holds {len} pixels")]
    Dimensions {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Number of pixels held.
        len: usize,
    },
}

/// A linear-radiance RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels, row by row from the top.
    pub pixels: Vec<[f32; 3]>,
}

impl LinearImage {
    /// The pixel-wise mean of `images` (all of the first one's size), summed in f64 and
    /// scaled by `1 / n`; an empty list gives an empty image. For two images it equals
    /// `0.5 * (a + b)` in f32 (the halving is exact) except where that sum overflows.
    pub fn mean(images: &[&LinearImage]) -> LinearImage {
        let Some(first) = images.first() else { return LinearImage::new(0, 0) };
        let scale = 1.0 / images.len() as f64;
        let mut sum = vec![[0.0f64; 3]; first.pixels.len()];
        for image in images {
            for (s, p) in sum.iter_mut().zip(&image.pixels) {
                for c in 0..3 {
                    s[c] += f64::from(p[c]);
                }
            }
        }
        LinearImage {
            width: first.width,
            height: first.height,
            pixels: sum.iter().map(|s| s.map(|v| (v * scale) as f32)).collect(),
        }
    }

    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        LinearImage { width, height, pixels: vec![[0.0; 3]; width as usize * height as usize] }
    }

    /// Root mean square of the difference to `other` over pixels and RGB channels (the
    /// images must have the same size).
    pub fn rms_difference(&self, other: &LinearImage) -> f64 {
        assert_eq!((self.width, self.height), (other.width, other.height), "images of different sizes");
        let sum: f64 = self
            .pixels
            .iter()
            .zip(&other.pixels)
            .map(|(p, q)| (0..3).map(|c| (f64::from(p[c]) - f64::from(q[c])).powi(2)).sum::<f64>())
            .sum();
        (sum / (3 * self.pixels.len().max(1)) as f64).sqrt()
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: u32, y: u32, value: [f32; 3]) {
        let w = self.width as usize;
        self.pixels[y as usize * w + x as usize] = value;
    }

    fn check(&self) -> Result<(), IoError> {
        if self.pixels.len() == self.width as usize * self.height as usize {
            Ok(())
        } else {
            Err(IoError::Dimensions { width: self.width, height: self.height, len: self.pixels.len() })
        }
    }
}

/// Composes images left to right (the eyes of a stereo pair) into one image whose height
/// is the tallest input's; shorter inputs are padded with black at the bottom.
pub fn compose_side_by_side(images: &[LinearImage]) -> LinearImage {
    let width: u32 = images.iter().map(|i| i.width).sum();
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let mut out = LinearImage::new(width, height);
    let mut x0 = 0;
    for img in images {
        for y in 0..img.height {
            let src = &img.pixels[(y * img.width) as usize..((y + 1) * img.width) as usize];
            let start = (y * width + x0) as usize;
            out.pixels[start..start + img.width as usize].copy_from_slice(src);
        }
        x0 += img.width;
    }
    out
}

/// Maps one linear radiance value to a display value in [0, 1]: exposure, tone curve,
/// sRGB transfer. Non-finite or negative radiance maps to black.
pub fn display_value(radiance: f32, exposure: &Exposure) -> f64 {
    let v = f64::from(radiance);
    if !v.is_finite() || v <= 0.0 {
        // +Inf is the only non-finite value with an obvious display value.
        return if v == f64::INFINITY { 1.0 } else { 0.0 };
    }
    let exposed = v * exposure.stops.exp2();
    let mapped = match exposure.tone_map {
        ToneMap::Clamp => exposed.min(1.0),
        ToneMap::Reinhard => exposed / (1.0 + exposed),
    };
    srgb_encode(mapped.clamp(0.0, 1.0))
}

/// The radiance whose display value is `display` (the inverse of [`display_value`] on
/// (0, 1)): what a pixel an antialiasing filter blended in display values stores. A display
/// value of 1 under the Reinhard curve, which no finite radiance reaches, gives the largest
/// finite radiance; 0 gives 0.
pub fn radiance_of_display(display: f64, exposure: &Exposure) -> f32 {
    if display.is_nan() || display <= 0.0 {
        return 0.0;
    }
    let mapped = srgb_decode(display.min(1.0));
    let exposed = match exposure.tone_map {
        ToneMap::Clamp => mapped,
        ToneMap::Reinhard if mapped >= 1.0 => return f32::MAX,
        ToneMap::Reinhard => mapped / (1.0 - mapped),
    };
    (exposed / exposure.stops.exp2()) as f32
}

/// 8-bit sRGB bytes (RGB, row-major) of the display image.
pub fn to_srgb8(image: &LinearImage, exposure: &Exposure) -> Vec<u8> {
    image
        .pixels
        .iter()
        .flat_map(|p| p.map(|c| (display_value(c, exposure) * 255.0).round().clamp(0.0, 255.0) as u8))
        .collect()
}

/// Encodes the display image as an 8-bit sRGB PNG (exposure in stops, tone map, sRGB).
///
/// # Panics
/// Only if the image's pixel count disagrees with its dimensions (a programming error).
pub fn encode_png_srgb(image: &LinearImage, exposure: &Exposure) -> Vec<u8> {
    image.check().expect("LinearImage dimensions");
    encode_png_rgb8(image.width, image.height, &to_srgb8(image, exposure))
}

/// Encodes 8-bit RGB rows as a PNG, with the settings of [`encode_png_srgb`]: the display
/// mapping is per pixel, so frames joined from their eyes' 8-bit halves encode to the bytes
/// of the frame rendered whole.
///
/// # Panics
/// Only if `rgb` does not hold `width * height` pixels (a programming error).
pub fn encode_png_rgb8(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .expect("PNG encoding into memory cannot fail for a consistent image");
    out
}

/// Decodes an 8-bit RGB PNG (as [`encode_png_rgb8`] writes) into its size and rows.
pub fn decode_png_rgb8(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), IoError> {
    let decoded = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(|e| IoError::Image(e.to_string()))?;
    let rgb = decoded.to_rgb8();
    Ok((rgb.width(), rgb.height(), rgb.into_raw()))
}

/// Joins 8-bit RGB images of equal height left to right.
pub fn join_rgb8_side_by_side(parts: &[(u32, u32, Vec<u8>)]) -> Result<(u32, u32, Vec<u8>), IoError> {
    let height = parts.first().map_or(0, |p| p.1);
    if let Some(p) = parts.iter().find(|p| p.1 != height || p.2.len() != 3 * (p.0 * p.1) as usize) {
        return Err(IoError::Dimensions { width: p.0, height: p.1, len: p.2.len() / 3 });
    }
    let width: u32 = parts.iter().map(|p| p.0).sum();
    let mut out = Vec::with_capacity(3 * (width * height) as usize);
    for y in 0..height as usize {
        for (w, _, rows) in parts {
            let row = 3 * *w as usize;
            out.extend_from_slice(&rows[y * row..(y + 1) * row]);
        }
    }
    Ok((width, height, out))
}

/// Encodes linear radiance as a 32-bit float RGB EXR file.
pub fn encode_exr(image: &LinearImage) -> Result<Vec<u8>, IoError> {
    use exr::prelude::*;
    image.check()?;
    let w = image.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = image.pixels[y * w + x];
        (p[0], p[1], p[2])
    });
    let exr_image = Image::from_channels((w, image.height as usize), channels);
    let mut cursor = Cursor::new(Vec::new());
    exr_image.write().non_parallel().to_buffered(&mut cursor).map_err(|e| IoError::Exr(e.to_string()))?;
    Ok(cursor.into_inner())
}

/// The largest side of an image file read (environment maps), in pixels.
pub const MAX_DECODE_SIDE: u32 = 16384;
/// The most pixels of an image file read: 8192 x 4096.
pub const MAX_DECODE_PIXELS: u64 = 1 << 25;

/// Checks an image size declared by a file before anything of that size is allocated.
fn check_size(width: u64, height: u64) -> Result<(), IoError> {
    if width > u64::from(MAX_DECODE_SIDE) || height > u64::from(MAX_DECODE_SIDE) || width * height > MAX_DECODE_PIXELS {
        return Err(IoError::Image(format!(
            "the file declares {width}x{height} pixels, above the limit of {MAX_DECODE_SIDE} per side and {MAX_DECODE_PIXELS} in all"
        )));
    }
    Ok(())
}

/// Decodes the first RGB(A) layer of an EXR file into linear radiance (alpha ignored).
/// Sizes above [`MAX_DECODE_SIDE`] or [`MAX_DECODE_PIXELS`] are errors, found from the
/// headers before the pixels are read.
pub fn decode_exr(bytes: &[u8]) -> Result<LinearImage, IoError> {
    use exr::prelude::*;
    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| IoError::Exr(e.to_string()))?;
    for header in &meta.headers {
        let size = header.layer_size;
        check_size(size.width() as u64, size.height() as u64)?;
    }
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res: Vec2<usize>, _: &RgbaChannels| LinearImage::new(res.width() as u32, res.height() as u32),
            |img: &mut LinearImage, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                img.set(pos.x() as u32, pos.y() as u32, [r, g, b]);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| IoError::Exr(e.to_string()))?;
    Ok(img.layer_data.channel_data.pixels)
}

/// Decodes a Radiance HDR (RGBE) file into linear radiance; sizes as for [`decode_exr`].
pub fn decode_hdr(bytes: &[u8]) -> Result<LinearImage, IoError> {
    use image::ImageDecoder;
    let decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes)).map_err(|e| IoError::Image(e.to_string()))?;
    let (w, h) = decoder.dimensions();
    check_size(u64::from(w), u64::from(h))?;
    let reader = image::ImageReader::with_format(Cursor::new(bytes), image::ImageFormat::Hdr);
    let img = reader.decode().map_err(|e| IoError::Image(e.to_string()))?.into_rgb32f();
    let (width, height) = img.dimensions();
    let pixels = img.pixels().map(|p| p.0).collect();
    Ok(LinearImage { width, height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_of_images_is_pixel_wise_and_halves_exactly() {
        let a = LinearImage { width: 2, height: 1, pixels: vec![[1.0, 2.0, 3.0], [0.1, 0.2, 0.3]] };
        let b = LinearImage { width: 2, height: 1, pixels: vec![[3.0, 2.0, 1.0], [0.7, 0.5, 0.3]] };
        let c = LinearImage { width: 2, height: 1, pixels: vec![[2.0, 5.0, 2.0], [0.1, 0.2, 0.3]] };
        let two = LinearImage::mean(&[&a, &b]);
        for (m, (p, q)) in two.pixels.iter().zip(a.pixels.iter().zip(&b.pixels)) {
            for k in 0..3 {
                assert_eq!(m[k], 0.5 * (p[k] + q[k]));
            }
        }
        assert_eq!(LinearImage::mean(&[&a, &b, &c]).pixels[0], [2.0, 3.0, 2.0]);
        assert_eq!(LinearImage::mean(&[&a]), a);
        assert_eq!(LinearImage::mean(&[]).pixels.len(), 0);
    }

    fn gradient(w: u32, h: u32) -> LinearImage {
        let mut img = LinearImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                img.set(x, y, [x as f32 * 0.1, y as f32 * 0.25, 1000.0]);
            }
        }
        img
    }

    #[test]
    fn eyes_joined_as_8_bit_png_encode_to_the_bytes_of_the_frame_composed_whole() {
        let exposure = Exposure { stops: 0.5, tone_map: ToneMap::Clamp };
        let mut right = gradient(5, 3);
        right.set(4, 2, [0.3, f32::NAN, 7.0]);
        let left = gradient(7, 3);
        let whole = encode_png_srgb(&compose_side_by_side(&[left.clone(), right.clone()]), &exposure);
        let halves: Vec<_> =
            [left, right].iter().map(|eye| decode_png_rgb8(&encode_png_srgb(eye, &exposure)).unwrap()).collect();
        let (w, h, rows) = join_rgb8_side_by_side(&halves).unwrap();
        assert_eq!((w, h), (12, 3));
        assert_eq!(encode_png_rgb8(w, h, &rows), whole);
        let short = (2, 2, vec![0; 12]);
        assert!(join_rgb8_side_by_side(&[halves[0].clone(), short]).is_err());
        assert!(decode_png_rgb8(b"not a png").is_err());
    }

    /// Fuzzing of the environment-map decoders (`BLURLAB_FUZZ_CASES` cases, default 64):
    /// arbitrary bytes and mutated valid files never panic, and a decoded image encodes and
    /// decodes to itself.
    mod fuzz {
        use super::*;
        use proptest::prelude::*;

        fn config() -> ProptestConfig {
            let cases = std::env::var("BLURLAB_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
            ProptestConfig { cases, failure_persistence: None, ..ProptestConfig::default() }
        }

        fn check(bytes: &[u8]) {
            for decoded in [decode_exr(bytes), decode_hdr(bytes)].into_iter().flatten() {
                let again = decode_exr(&encode_exr(&decoded).unwrap()).unwrap();
                assert_eq!((again.width, again.height), (decoded.width, decoded.height));
                let same = again
                    .pixels
                    .iter()
                    .flatten()
                    .zip(decoded.pixels.iter().flatten())
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same);
            }
        }

        fn mutated(valid: &[u8], at: usize, len: usize, with: &[u8], cut: bool) -> Vec<u8> {
            let mut v = valid.to_vec();
            let at = at % (v.len() + 1);
            if cut {
                v.truncate(at);
            } else {
                let end = (at + len % 8).min(v.len());
                v.splice(at..end, with.iter().copied());
            }
            v
        }

        fn hdr_file() -> Vec<u8> {
            let mut v = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n".to_vec();
            v.extend(std::iter::repeat_n([128u8, 64, 32, 129], 8).flatten());
            v
        }

        proptest! {
            #![proptest_config(config())]

            #[test]
            fn environment_maps(
                bytes in proptest::collection::vec(any::<u8>(), 0..256),
                at in any::<usize>(),
                len in any::<usize>(),
                with in proptest::collection::vec(any::<u8>(), 0..8),
                cut in any::<bool>(),
            ) {
                check(&bytes);
                check(&mutated(&encode_exr(&gradient(4, 2)).unwrap(), at, len, &with, cut));
                check(&mutated(&hdr_file(), at, len, &with, cut));
            }
        }
    }

    #[test]
    fn oversized_image_files_are_errors_before_allocation() {
        // An HDR header declaring 100000 x 100000 pixels and no data.
        let hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n";
        let e = decode_hdr(hdr).unwrap_err().to_string();
        assert!(e.contains("100000x100000") && e.contains("above the limit"), "{e}");
        // A valid EXR whose data window is patched to 100000 x 100000.
        let mut bytes = encode_exr(&gradient(4, 2)).unwrap();
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        for (k, v) in [0i32, 0, 99_999, 99_999].iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        let e = decode_exr(&bytes).unwrap_err().to_string();
        assert!(e.contains("100000x100000") && e.contains("above the limit"), "{e}");
    }

    #[test]
    fn exr_round_trips_exactly() {
        let img = gradient(7, 5);
        let bytes = encode_exr(&img).unwrap();
        assert_eq!(decode_exr(&bytes).unwrap(), img);
        assert_eq!(bytes, encode_exr(&img).unwrap(), "deterministic bytes");
    }

    #[test]
    fn png_is_srgb_with_exposure_and_tone_map() {
        let mut img = LinearImage::new(3, 1);
        img.pixels = vec![[0.0; 3], [0.5, 0.5, 0.5], [f32::NAN, 4.0, -1.0]];
        let clamp = Exposure { stops: 0.0, tone_map: ToneMap::Clamp };
        let bytes = to_srgb8(&img, &clamp);
        assert_eq!(&bytes[0..3], &[0, 0, 0]);
        // sRGB(0.5) = 0.7354 -> 188.
        assert_eq!(&bytes[3..6], &[188, 188, 188]);
        assert_eq!(&bytes[6..9], &[0, 255, 0]);
        let plus_one = Exposure { stops: 1.0, tone_map: ToneMap::Reinhard };
        // 0.5 * 2 = 1 -> Reinhard 0.5 -> 188.
        assert_eq!(to_srgb8(&img, &plus_one)[3], 188);
        let png = encode_png_srgb(&img, &clamp);
        let decoded = image::load_from_memory(&png).unwrap().into_rgb8();
        assert_eq!(decoded.into_raw(), bytes);
    }

    #[test]
    fn side_by_side_puts_left_eye_first() {
        let mut a = LinearImage::new(2, 2);
        a.pixels.fill([1.0, 0.0, 0.0]);
        let mut b = LinearImage::new(3, 2);
        b.pixels.fill([0.0, 1.0, 0.0]);
        let c = compose_side_by_side(&[a, b]);
        assert_eq!((c.width, c.height), (5, 2));
        assert_eq!(c.get(1, 1), [1.0, 0.0, 0.0]);
        assert_eq!(c.get(2, 0), [0.0, 1.0, 0.0]);
        assert_eq!(c.get(4, 1), [0.0, 1.0, 0.0]);
    }
}
