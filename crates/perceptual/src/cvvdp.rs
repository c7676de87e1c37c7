//! ColorVideoVDP (Mantiuk, Hanji, Ashraf, Asano and Chapiro, "ColorVideoVDP: A visual
//! difference predictor for image, video and display distortions", SIGGRAPH 2024), through the
//! `colorvideovdp` crate (a pure-Rust port of the authors' PyTorch code, calibrated model
//! v0.5.7), at the study's display and viewing geometry.
//!
//! Where FLIP judges still images, ColorVideoVDP has temporal channels: noise that changes
//! every frame is integrated by the eye, and strobing or smear of a moving object is a
//! difference in time as well as in space. Its result is a quality in JOD
//! (just-objectionable differences): 10 for a test the display shows identically to the
//! reference, lower for more visible differences, and a difference of 1 JOD between two
//! conditions means that 75 % of people prefer the higher one.
//!
//! - The display model ([`DisplayConditions`]) comes from the design's `[viewing]` section:
//!   pixels per degree of one eye's image from the distance and the image's visual angle,
//!   the peak luminance, black level and ambient light of the screen, and the frame rate the
//!   sequences are shown at.
//! - Frames are the 8-bit sRGB images participants see ([`SrgbImage`]), decoded by the
//!   display's sRGB transfer curve between its black level and its peak.
//! - A stereo frame (two eyes side by side) is judged eye by eye; [`Judgement::jod`]
//!   combines the eyes by their mean, a rule fixed before any held-out table was looked at
//!   (ColorVideoVDP has no binocular model; the two eyes' images differ only by the parallax
//!   and independent noise, so they are equally distorted and the mean is the plainest
//!   summary).
//! - A test clip shown at a lower frame rate than its reference is held: each test frame is
//!   repeated for `reference fps / test fps` reference frames, as a display holds a frame
//!   until the next one ([`VideoObserver::judge`]).

use colorvideovdp::{Color, Cvvdp, DisplayModel, Execution, Geometry, Image, Options, Photometry};

use crate::SrgbImage;

/// Diffuse reflectivity of the screen (ColorVideoVDP's default for its displays).
pub const SCREEN_REFLECTIVITY: f64 = 0.005;

/// Why a ColorVideoVDP judgement could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CvvdpError {
    /// A display setting out of range.
    #[error("display model: {key} {message}")]
    Display {
        /// The setting.
        key: &'static str,
        /// What was expected.
        message: String,
    },
    /// Clips that cannot be compared.
    #[error("{0}")]
    Clips(String),
    /// The metric refused the input.
    #[error("ColorVideoVDP: {0}")]
    Metric(String),
}

/// How the observer sees the frames: the display and the viewing geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DisplayConditions {
    /// Pixels of one eye's image per degree of visual angle.
    pub pixels_per_degree: f64,
    /// Peak luminance of the display, cd/m².
    pub peak_luminance: f64,
    /// Black level of the display, cd/m².
    pub black_level: f64,
    /// Ambient illuminance at the screen, lux.
    pub ambient_lux: f64,
}

impl DisplayConditions {
    /// Checks every setting, naming the first one out of range.
    pub fn validate(&self) -> Result<(), CvvdpError> {
        let bad = |key: &'static str, message: String| Err(CvvdpError::Display { key, message });
        if !(self.pixels_per_degree.is_finite() && self.pixels_per_degree > 0.0) {
            return bad("pixels_per_degree", format!("must be a positive number, found {}", self.pixels_per_degree));
        }
        if !(self.peak_luminance.is_finite() && self.peak_luminance >= 0.005 && self.peak_luminance <= 1e5) {
            return bad("peak_luminance", format!("must lie in [0.005, 1e5] cd/m², found {}", self.peak_luminance));
        }
        if !(self.black_level.is_finite() && self.black_level > 0.0 && self.black_level < self.peak_luminance) {
            return bad(
                "black_level",
                format!(
                    "must be a positive luminance below the peak ({} cd/m²), found {}",
                    self.peak_luminance, self.black_level
                ),
            );
        }
        if !(self.ambient_lux.is_finite() && (0.0..=1e5).contains(&self.ambient_lux)) {
            return bad("ambient_lux", format!("must lie in [0, 1e5] lux, found {}", self.ambient_lux));
        }
        Ok(())
    }

    /// The display model ColorVideoVDP is given for images of `width` x `height` pixels.
    fn model(&self, width: usize, height: usize) -> Result<DisplayModel, CvvdpError> {
        self.validate()?;
        let metric = |e: colorvideovdp::Error| CvvdpError::Metric(e.to_string());
        let photometry = Photometry::new(
            self.peak_luminance,
            self.peak_luminance / self.black_level,
            self.ambient_lux,
            SCREEN_REFLECTIVITY,
            1.0,
        )
        .map_err(metric)?;
        let geometry = Geometry::from_ppd([width.max(1), height.max(1)], self.pixels_per_degree).map_err(metric)?;
        DisplayModel::new("blurlab viewing", photometry, geometry, "sRGB").map_err(metric)
    }
}

/// Frames shown at one rate.
#[derive(Debug, Clone)]
pub struct Clip<'a> {
    /// The frames in order (each eye side by side for stereo).
    pub frames: &'a [SrgbImage],
    /// Frames per second.
    pub fps: f64,
}

/// One clip judged against its reference.
#[derive(Debug, Clone, PartialEq)]
pub struct Judgement {
    /// Quality of each eye's view, JOD (one value for a monoscopic clip).
    pub eyes: Vec<f64>,
}

impl Judgement {
    /// The clip's quality, JOD: the mean over the eyes.
    pub fn jod(&self) -> f64 {
        self.eyes.iter().sum::<f64>() / self.eyes.len().max(1) as f64
    }
}

/// Whether the metric uses the calling thread only or the current Rayon pool (both give
/// the same numbers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threads {
    /// The calling thread.
    One,
    /// The current Rayon pool.
    Pool,
}

/// ColorVideoVDP at fixed display conditions.
pub struct VideoObserver {
    conditions: DisplayConditions,
    threads: Threads,
}

impl VideoObserver {
    /// An observer that sees the frames under `conditions`.
    pub fn new(conditions: DisplayConditions, threads: Threads) -> Result<VideoObserver, CvvdpError> {
        conditions.validate()?;
        Ok(VideoObserver { conditions, threads })
    }

    /// The display conditions.
    pub fn conditions(&self) -> &DisplayConditions {
        &self.conditions
    }

    /// The quality of `test` against `reference`, each of `eyes` views side by side judged
    /// apart. The reference's frame rate must be a whole multiple `k` of the test's and it
    /// must have `k` times its frames: each test frame is then held for `k` reference frames.
    pub fn judge(&self, test: &Clip, reference: &Clip, eyes: u32) -> Result<Judgement, CvvdpError> {
        let Some(first) = test.frames.first() else {
            return Err(CvvdpError::Clips("a clip without frames cannot be judged".into()));
        };
        if !(test.fps.is_finite() && test.fps > 0.0 && reference.fps.is_finite() && reference.fps > 0.0) {
            return Err(CvvdpError::Clips(format!(
                "frame rates must be positive, found {} (test) and {} (reference)",
                test.fps, reference.fps
            )));
        }
        let ratio = reference.fps / test.fps;
        let hold = ratio.round();
        if hold < 1.0 || (ratio - hold).abs() > 1e-9 * ratio {
            return Err(CvvdpError::Clips(format!(
                "the reference's frame rate ({} fps) must be a whole multiple of the test's ({} fps)",
                reference.fps, test.fps
            )));
        }
        let hold = hold as usize;
        if reference.frames.len() != test.frames.len() * hold {
            return Err(CvvdpError::Clips(format!(
                "a reference at {hold}x the test's frame rate needs {hold}x its frames: {} test frames, {} reference frames",
                test.frames.len(),
                reference.frames.len()
            )));
        }
        let size = (first.width(), first.height());
        if let Some(f) = test.frames.iter().chain(reference.frames).find(|f| (f.width(), f.height()) != size) {
            return Err(CvvdpError::Clips(format!(
                "frames differ in size: {}x{} and {}x{}",
                size.0,
                size.1,
                f.width(),
                f.height()
            )));
        }
        if eyes == 0 || size.0 % eyes != 0 {
            return Err(CvvdpError::Clips(format!(
                "a {}-pixel-wide frame cannot hold {eyes} eyes side by side",
                size.0
            )));
        }
        let eye_width = size.0 / eyes;
        if eye_width < 4 || size.1 < 4 {
            return Err(CvvdpError::Clips(format!(
                "ColorVideoVDP needs images of at least 4x4 pixels per eye, found {eye_width}x{}",
                size.1
            )));
        }
        let model = self.conditions.model(eye_width as usize, size.1 as usize)?;
        let execution = match self.threads {
            Threads::One => Execution::SingleThread,
            Threads::Pool => Execution::Parallel,
        };
        let metric_error = |e: colorvideovdp::Error| CvvdpError::Metric(e.to_string());
        let metric = Cvvdp::new(model, Options::default().with_execution(execution).with_memory_limit_bytes(8 << 30))
            .map_err(metric_error)?;
        let mut out = Vec::with_capacity(eyes as usize);
        for eye in 0..eyes {
            let crop = |f: &SrgbImage| eye_image(f, eye, eye_width);
            let test_frames: Vec<Image> = test
                .frames
                .iter()
                .map(crop)
                .collect::<Result<Vec<_>, _>>()?
                .into_iter()
                .flat_map(|i| std::iter::repeat_n(i, hold))
                .collect();
            let reference_frames: Vec<Image> = reference.frames.iter().map(crop).collect::<Result<_, _>>()?;
            let prediction = if test_frames.len() == 1 {
                metric.predict_image(&test_frames[0], &reference_frames[0], Color::Srgb)
            } else {
                metric.predict_video(&test_frames, &reference_frames, reference.fps as f32, Color::Srgb)
            }
            .map_err(metric_error)?;
            out.push(f64::from(prediction.jod));
        }
        Ok(Judgement { eyes: out })
    }
}

/// One eye's part of a side-by-side frame as sRGB values in [0, 1].
fn eye_image(frame: &SrgbImage, eye: u32, eye_width: u32) -> Result<Image, CvvdpError> {
    let (w, h) = (frame.width() as usize, frame.height() as usize);
    let (x0, ew) = ((eye * eye_width) as usize, eye_width as usize);
    let mut data = Vec::with_capacity(ew * h * 3);
    for row in frame.data().chunks_exact(w * 3) {
        data.extend(row[x0 * 3..(x0 + ew) * 3].iter().map(|&v| f32::from(v) / 255.0));
    }
    Image::new(ew, h, 3, data).map_err(|e| CvvdpError::Metric(e.to_string()))
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;

    const FPS: f64 = 30.0;

    fn office(ppd: f64) -> DisplayConditions {
        DisplayConditions { pixels_per_degree: ppd, peak_luminance: 200.0, black_level: 0.2, ambient_lux: 250.0 }
    }

    /// A smooth, textured grey frame of `w` x `h`.
    fn scene(w: u32, h: u32) -> Vec<f64> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| 0.45 + 0.2 * (f64::from(x) * 0.21).sin() * (f64::from(y) * 0.13).cos()))
            .collect()
    }

    fn to_image(w: u32, h: u32, v: &[f64]) -> SrgbImage {
        let data = v.iter().flat_map(|&g| [(g.clamp(0.0, 1.0) * 255.0).round() as u8; 3]).collect();
        SrgbImage::new(w, h, data).unwrap()
    }

    /// `frames` frames of the scene with uniform noise of amplitude `amplitude`: fresh noise
    /// every frame, or the first frame's noise frozen.
    fn noisy(w: u32, h: u32, frames: usize, amplitude: f64, dynamic: bool, seed: u64) -> Vec<SrgbImage> {
        let base = scene(w, h);
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut noise: Vec<f64> = Vec::new();
        (0..frames)
            .map(|k| {
                if k == 0 || dynamic {
                    noise = base.iter().map(|_| amplitude * (rng.random::<f64>() - 0.5)).collect();
                }
                let v: Vec<f64> = base.iter().zip(&noise).map(|(b, n)| b + n).collect();
                to_image(w, h, &v)
            })
            .collect()
    }

    fn jod(observer: &VideoObserver, test: &[SrgbImage], reference: &[SrgbImage]) -> f64 {
        observer.judge(&Clip { frames: test, fps: FPS }, &Clip { frames: reference, fps: FPS }, 1).unwrap().jod()
    }

    #[test]
    fn identical_clips_score_the_maximum() {
        let observer = VideoObserver::new(office(40.0), Threads::One).unwrap();
        let clip = noisy(48, 32, 6, 0.2, true, 1);
        let q = jod(&observer, &clip, &clip);
        assert!((q - 10.0).abs() < 1e-4, "{q}");
    }

    #[test]
    fn more_noise_scores_lower() {
        let observer = VideoObserver::new(office(40.0), Threads::One).unwrap();
        let reference = noisy(48, 32, 6, 0.0, true, 1);
        let scores: Vec<f64> = [0.02, 0.05, 0.1, 0.2, 0.4]
            .iter()
            .map(|&a| jod(&observer, &noisy(48, 32, 6, a, true, 2), &reference))
            .collect();
        assert!(scores.windows(2).all(|w| w[1] < w[0]), "{scores:?}");
        assert!(scores[0] < 10.0 && scores[4] < scores[0] - 1.0, "{scores:?}");
    }

    #[test]
    fn noise_that_changes_every_frame_is_less_visible_than_frozen_noise() {
        // At 30 fps the eye integrates fresh noise over frames; the same amplitude standing
        // still is seen in full. A metric without a temporal model scores them alike.
        let observer = VideoObserver::new(office(40.0), Threads::One).unwrap();
        let reference = noisy(48, 32, 12, 0.0, true, 1);
        let dynamic = jod(&observer, &noisy(48, 32, 12, 0.15, true, 3), &reference);
        let frozen = jod(&observer, &noisy(48, 32, 12, 0.15, false, 3), &reference);
        assert!(dynamic > frozen + 0.1, "dynamic {dynamic}, frozen {frozen}");
    }

    #[test]
    fn finer_pixels_hide_pixel_noise() {
        // The same image seen from further away (more pixels per degree) puts per-pixel
        // noise at higher spatial frequencies, where the eye is less sensitive.
        let reference = noisy(48, 32, 4, 0.0, true, 1);
        let test = noisy(48, 32, 4, 0.15, true, 5);
        let at = |ppd: f64| jod(&VideoObserver::new(office(ppd), Threads::One).unwrap(), &test, &reference);
        let (near, mid, far) = (at(15.0), at(40.0), at(120.0));
        assert!(near < mid && mid < far, "{near} {mid} {far}");
    }

    #[test]
    fn a_held_clip_equals_its_frames_repeated() {
        let observer = VideoObserver::new(office(40.0), Threads::One).unwrap();
        let test = noisy(32, 16, 3, 0.1, true, 7);
        let reference = noisy(32, 16, 6, 0.02, true, 8);
        let held =
            observer.judge(&Clip { frames: &test, fps: 30.0 }, &Clip { frames: &reference, fps: 60.0 }, 1).unwrap();
        let repeated: Vec<SrgbImage> = test.iter().flat_map(|f| [f.clone(), f.clone()]).collect();
        let explicit =
            observer.judge(&Clip { frames: &repeated, fps: 60.0 }, &Clip { frames: &reference, fps: 60.0 }, 1).unwrap();
        assert_eq!(held, explicit);
    }

    #[test]
    fn stereo_eyes_are_judged_apart_and_averaged() {
        let observer = VideoObserver::new(office(40.0), Threads::Pool).unwrap();
        let (w, h) = (32, 16);
        let clean = noisy(w, h, 3, 0.0, true, 1);
        let dirty = noisy(w, h, 3, 0.3, true, 9);
        // Left eye clean, right eye noisy, side by side.
        let sbs = |l: &[SrgbImage], r: &[SrgbImage]| -> Vec<SrgbImage> {
            l.iter()
                .zip(r)
                .map(|(a, b)| {
                    let mut data = Vec::new();
                    for y in 0..h as usize {
                        let row = |i: &SrgbImage| i.data()[y * w as usize * 3..(y + 1) * w as usize * 3].to_vec();
                        data.extend(row(a));
                        data.extend(row(b));
                    }
                    SrgbImage::new(2 * w, h, data).unwrap()
                })
                .collect()
        };
        let test = sbs(&clean, &dirty);
        let reference = sbs(&clean, &clean);
        let j = observer.judge(&Clip { frames: &test, fps: FPS }, &Clip { frames: &reference, fps: FPS }, 2).unwrap();
        let right_alone = jod(&VideoObserver::new(office(40.0), Threads::One).unwrap(), &dirty, &clean);
        assert!((j.eyes[0] - 10.0).abs() < 1e-4, "{:?}", j.eyes);
        assert!((j.eyes[1] - right_alone).abs() < 1e-5, "{:?} {right_alone}", j.eyes);
        assert!((j.jod() - 0.5 * (10.0 + right_alone)).abs() < 1e-5);
    }

    #[test]
    fn bad_displays_and_clips_are_named() {
        let e = VideoObserver::new(DisplayConditions { peak_luminance: 0.0, ..office(40.0) }, Threads::One);
        assert!(e.err().unwrap().to_string().contains("peak_luminance"));
        let e = VideoObserver::new(DisplayConditions { black_level: -1.0, ..office(40.0) }, Threads::One);
        assert!(e.err().unwrap().to_string().contains("black_level"));
        let e = VideoObserver::new(DisplayConditions { pixels_per_degree: 0.0, ..office(40.0) }, Threads::One);
        assert!(e.err().unwrap().to_string().contains("pixels_per_degree"));
        let observer = VideoObserver::new(office(40.0), Threads::One).unwrap();
        let a = noisy(16, 8, 3, 0.1, true, 1);
        let b = noisy(16, 8, 4, 0.1, true, 1);
        let e = observer.judge(&Clip { frames: &a, fps: 30.0 }, &Clip { frames: &b, fps: 30.0 }, 1).unwrap_err();
        assert!(e.to_string().contains("3 test frames, 4 reference frames"), "{e}");
        let e = observer.judge(&Clip { frames: &a, fps: 30.0 }, &Clip { frames: &a, fps: 45.0 }, 1).unwrap_err();
        assert!(e.to_string().contains("whole multiple"), "{e}");
    }
}
