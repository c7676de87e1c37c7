//! Perceptual image differences for blurlab: FLIP (Andersson, Nilsson, Akenine-Möller, Oskarsson,
//! Åström and Fairchild, "FLIP: A Difference Evaluator for Alternating Images", HPG 2020), the
//! LDR version, computed by NVIDIA's reference C++ code through the `nv-flip` crate.
//!
//! Inputs are 8-bit sRGB images: exactly what a participant is shown (the set's PNG frames, or
//! a linear render after exposure, tone map and the sRGB curve). FLIP's spatial filters depend
//! on how many pixels one degree of visual angle covers ([`pixels_per_degree`]); blurlab takes
//! it from the design's viewing section (`[viewing] distance`, `image_angle_degrees`) and the
//! width of one eye's image, so that a stereo frame (two eyes side by side) is judged at the
//! resolution each eye is seen at.
//!
//! [`cvvdp`] adds ColorVideoVDP (Mantiuk et al. 2024), a spatio-temporal metric in JOD units,
//! for the observer that forecasts people's choices between sequences (`blurlab predict`).
//!
//! Both the cost report (`render::measure::cost`) and the image-computable observer of the runner
//! (`--simulate flip`) use this crate; it links neither the renderer nor the runner.

pub mod cvvdp;
pub mod pursuit;

use std::fmt;

/// Why a FLIP comparison could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FlipError {
    /// The two images differ in size.
    #[error("FLIP needs images of one size: the reference is {reference:?}, the test image {test:?} (width, height)")]
    SizeMismatch {
        /// Reference size.
        reference: (u32, u32),
        /// Test size.
        test: (u32, u32),
    },
    /// An image's bytes do not match its size.
    #[error("an sRGB image of {width}x{height} needs {expected} bytes (RGB), got {got}")]
    BadData {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Bytes expected.
        expected: usize,
        /// Bytes given.
        got: usize,
    },
    /// An image without pixels.
    #[error("FLIP needs images with at least one pixel, got {width}x{height}")]
    Empty {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// Pixels per degree outside what FLIP's filters can use.
    #[error("pixels per degree must be a finite number in [0.5, 1000], got {0}")]
    PixelsPerDegree(f64),
}

/// An 8-bit sRGB RGB image, rows from the top, tightly packed.
#[derive(Clone, PartialEq, Eq)]
pub struct SrgbImage {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl fmt::Debug for SrgbImage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SrgbImage({}x{})", self.width, self.height)
    }
}

impl SrgbImage {
    /// An image of `width` x `height` pixels from `data` (3 bytes per pixel).
    pub fn new(width: u32, height: u32, data: Vec<u8>) -> Result<SrgbImage, FlipError> {
        if width == 0 || height == 0 {
            return Err(FlipError::Empty { width, height });
        }
        let expected = width as usize * height as usize * 3;
        if data.len() != expected {
            return Err(FlipError::BadData { width, height, expected, got: data.len() });
        }
        Ok(SrgbImage { width, height, data })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The bytes, RGB per pixel.
    pub fn data(&self) -> &[u8] {
        &self.data
    }
}

/// Pixels per degree of visual angle at the centre of a flat screen `distance` metres away,
/// for an image `width` pixels wide subtending `image_angle_degrees` horizontally (the
/// design's viewing geometry; `study::design::Design::pixels_per_degree` is the same formula).
pub fn pixels_per_degree(distance: f64, image_angle_degrees: f64, width: u32) -> f64 {
    let screen_width = 2.0 * distance * (0.5 * image_angle_degrees.to_radians()).tan();
    f64::from(width) / screen_width * distance * 1f64.to_radians()
}

/// A FLIP comparison: the per-pixel error map (each in [0, 1]) and its mean, the single
/// number the paper's authors recommend.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipMap {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Per-pixel FLIP error, rows from the top.
    pub values: Vec<f32>,
    /// Mean of `values`.
    pub mean: f64,
}

impl FlipMap {
    /// The error map coloured with FLIP's magma map (black no error, yellow-white most), as
    /// 8-bit RGB bytes.
    pub fn magma_rgb8(&self) -> Vec<u8> {
        let image = nv_flip::FlipImageFloat::with_data(self.width, self.height, &self.values);
        image.apply_color_lut(&nv_flip::magma_lut()).to_vec()
    }
}

/// FLIP of `test` against `reference` at `ppd` pixels per degree.
pub fn flip(reference: &SrgbImage, test: &SrgbImage, ppd: f64) -> Result<FlipMap, FlipError> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(FlipError::SizeMismatch {
            reference: (reference.width, reference.height),
            test: (test.width, test.height),
        });
    }
    if !(ppd.is_finite() && (0.5..=1000.0).contains(&ppd)) {
        return Err(FlipError::PixelsPerDegree(ppd));
    }
    let (w, h) = (reference.width, reference.height);
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &reference.data);
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &test.data);
    let values = nv_flip::flip(r, t, ppd as f32).to_vec();
    let sum: f64 = values.iter().map(|&v| f64::from(v)).sum();
    let mean = sum / values.len() as f64;
    Ok(FlipMap { width: w, height: h, values, mean })
}

/// Mean FLIP of `test` against `reference` for images made of `eyes` equal-width views side
/// by side (1 for mono, 2 for a stereo frame): each eye is compared on its own at `ppd` (the
/// pixels per degree of one eye's image), so that FLIP's filters never straddle the seam,
/// and the means are averaged.
pub fn flip_eyes(reference: &SrgbImage, test: &SrgbImage, eyes: u32, ppd: f64) -> Result<f64, FlipError> {
    if eyes <= 1 {
        return Ok(flip(reference, test, ppd)?.mean);
    }
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(FlipError::SizeMismatch {
            reference: (reference.width, reference.height),
            test: (test.width, test.height),
        });
    }
    let eye_width = reference.width / eyes;
    let mut total = 0.0;
    for e in 0..eyes {
        let crop = |img: &SrgbImage| -> Result<SrgbImage, FlipError> {
            let mut data = Vec::with_capacity(eye_width as usize * img.height as usize * 3);
            for y in 0..img.height as usize {
                let row = (y * img.width as usize + (e * eye_width) as usize) * 3;
                data.extend_from_slice(&img.data[row..row + eye_width as usize * 3]);
            }
            SrgbImage::new(eye_width, img.height, data)
        };
        total += flip(&crop(reference)?, &crop(test)?, ppd)?.mean;
    }
    Ok(total / f64::from(eyes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A smooth test pattern with an edge: gradients plus a bright square.
    fn pattern(w: u32, h: u32) -> SrgbImage {
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let inside = (w / 3..2 * w / 3).contains(&x) && (h / 3..2 * h / 3).contains(&y);
                let r = if inside { 230 } else { (40 + 120 * x / w) as u8 };
                data.extend_from_slice(&[r, (60 + 100 * y / h) as u8, 90]);
            }
        }
        SrgbImage::new(w, h, data).unwrap()
    }

    fn noisy(img: &SrgbImage, amplitude: f64, seed: u64) -> SrgbImage {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let data = img
            .data()
            .iter()
            .map(|&v| (f64::from(v) + amplitude * (rng.random::<f64>() * 2.0 - 1.0)).round().clamp(0.0, 255.0) as u8)
            .collect();
        SrgbImage::new(img.width(), img.height(), data).unwrap()
    }

    #[test]
    fn an_image_against_itself_is_zero_and_error_grows_with_noise() {
        let ppd = pixels_per_degree(0.6, 14.4, 64);
        let img = pattern(64, 36);
        let same = flip(&img, &img, ppd).unwrap();
        assert_eq!(same.mean, 0.0);
        assert!(same.values.iter().all(|&v| v == 0.0));
        let mut last = 0.0;
        for amplitude in [4.0, 16.0, 64.0] {
            let e = flip(&img, &noisy(&img, amplitude, 3), ppd).unwrap().mean;
            assert!(e > last * 1.2 && e <= 1.0, "amplitude {amplitude}: {e} after {last}");
            last = e;
        }
        // Stereo: two eyes judged apart; equal eyes give the mono value.
        let mut twice = Vec::new();
        for y in 0..36usize {
            let row = &img.data()[y * 64 * 3..(y + 1) * 64 * 3];
            twice.extend_from_slice(row);
            twice.extend_from_slice(row);
        }
        let sbs = SrgbImage::new(128, 36, twice).unwrap();
        assert_eq!(flip_eyes(&sbs, &sbs, 2, ppd).unwrap(), 0.0);
        let noisy_sbs = noisy(&sbs, 16.0, 5);
        let e = flip_eyes(&sbs, &noisy_sbs, 2, ppd).unwrap();
        assert!(e > 0.0 && e < 1.0);
        // The colour map has the image's size.
        assert_eq!(flip(&img, &noisy(&img, 16.0, 3), ppd).unwrap().magma_rgb8().len(), 64 * 36 * 3);
    }

    #[test]
    fn pixels_per_degree_follows_the_viewing_geometry_and_changes_flip() {
        // The study: 14.4 degrees at 60 cm is a 15.16 cm wide image; a degree at the centre
        // covers 1.047 cm of it, so 640 pixels give 44.21 pixels per degree.
        let ppd = pixels_per_degree(0.6, 14.4, 640);
        assert!((ppd - 44.21).abs() < 0.01, "{ppd}");
        assert!((pixels_per_degree(0.6, 14.4, 160) - ppd / 4.0).abs() < 1e-12);
        // The same noise is less visible when the pixels are smaller (more per degree).
        let img = pattern(64, 36);
        let test = noisy(&img, 24.0, 8);
        let coarse = flip(&img, &test, 5.0).unwrap().mean;
        let fine = flip(&img, &test, 60.0).unwrap().mean;
        assert!(fine < coarse, "{fine} vs {coarse}");
    }

    #[test]
    fn bad_input_is_an_error_naming_what_is_wrong() {
        let img = pattern(8, 4);
        let other = pattern(4, 8);
        let e = flip(&img, &other, 10.0).unwrap_err().to_string();
        assert!(e.contains("(8, 4)") && e.contains("(4, 8)"), "{e}");
        assert!(flip(&img, &img, f64::NAN).unwrap_err().to_string().contains("pixels per degree"));
        assert!(flip(&img, &img, 0.0).is_err());
        assert!(SrgbImage::new(2, 2, vec![0; 11]).unwrap_err().to_string().contains("needs 12 bytes"));
        assert!(SrgbImage::new(0, 2, vec![]).is_err());
    }
}
