//! Smooth pursuit: the images on the retina of an eye that follows a moving object.
//!
//! ColorVideoVDP judges frames as they lie on the screen, i.e. as an eye fixating one point
//! sees them. An eye that tracks the moving sphere sees something else: the tracked object
//! stands still on the retina and the screen slides across it. A frame held on a display for
//! `1/fps` then slides as well, by the distance the gaze moves during the hold, so a sharp
//! object held for a whole frame is smeared on the retina (the "hold-type" blur of
//! sample-and-hold displays) and a camera's motion blur adds to that smear instead of
//! standing in for the continuous motion.
//!
//! [`retinal_image`] resamples one frame (each eye of a side-by-side frame apart) around a
//! gaze point: pixel `(i, j)` of the result is the display at
//! `gaze + (i + 0.5 - w/2, j + 0.5 - h/2)`, bilinear in linear light, black outside the
//! display (a dark surround). A gaze at the display's centre returns the frame unchanged.
//! [`retinal_clip`] does it for a clip shown at `hold` sub-frames per frame, one gaze per
//! sub-frame, so that the metric sees the slide during each hold.

use crate::SrgbImage;
use crate::cvvdp::CvvdpError;

/// Where one eye looks at one instant, in that eye's continuous pixel coordinates (x right,
/// y down; pixel `(i, j)` covers `[i, i + 1) x [j, j + 1)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaze {
    /// Horizontal position, pixels.
    pub x: f64,
    /// Vertical position, pixels.
    pub y: f64,
}

/// sRGB code to linear light, for the 256 codes.
fn decode_table() -> [f32; 256] {
    std::array::from_fn(|c| {
        let v = c as f64 / 255.0;
        (if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }) as f32
    })
}

/// Linear light in [0, 1] to the nearest sRGB code.
fn encode(linear: f32) -> u8 {
    let l = f64::from(linear.clamp(0.0, 1.0));
    let v = if l <= 0.003_130_8 { 12.92 * l } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (v * 255.0).round().clamp(0.0, 255.0) as u8
}

/// `frame` as seen by an eye whose gaze is at `gaze[e]` in eye `e`'s image, the `eyes` views
/// side by side (see the module's documentation).
pub fn retinal_image(frame: &SrgbImage, eyes: u32, gaze: &[Gaze]) -> Result<SrgbImage, CvvdpError> {
    let (width, height) = (frame.width(), frame.height());
    if eyes == 0 || width % eyes != 0 {
        return Err(CvvdpError::Clips(format!("a {width}-pixel-wide frame cannot hold {eyes} eyes side by side")));
    }
    if gaze.len() != eyes as usize {
        return Err(CvvdpError::Clips(format!("{} gaze points for a frame of {eyes} eyes", gaze.len())));
    }
    if let Some(g) = gaze.iter().find(|g| !(g.x.is_finite() && g.y.is_finite())) {
        return Err(CvvdpError::Clips(format!("a gaze point must be finite, found ({}, {})", g.x, g.y)));
    }
    let table = decode_table();
    let (w, h) = (width as usize / eyes as usize, height as usize);
    let data = frame.data();
    let mut out = vec![0u8; data.len()];
    for (e, g) in gaze.iter().enumerate() {
        let x0 = e * w;
        // Display pixel `k`'s centre is at k + 0.5: the sample at continuous x lies between
        // pixels floor(x - 0.5) and the next.
        let ox = g.x - 0.5 * w as f64;
        let oy = g.y - 0.5 * h as f64;
        let tap = |xi: i64, yi: i64, c: usize| -> f32 {
            if xi < 0 || yi < 0 || xi >= w as i64 || yi >= h as i64 {
                0.0
            } else {
                table[usize::from(data[(yi as usize * width as usize + x0 + xi as usize) * 3 + c])]
            }
        };
        for j in 0..h {
            let sy = oy + j as f64;
            let fy = sy.floor();
            let ty = (sy - fy) as f32;
            let yi = fy as i64;
            for i in 0..w {
                let sx = ox + i as f64;
                let fx = sx.floor();
                let tx = (sx - fx) as f32;
                let xi = fx as i64;
                let at = (j * width as usize + x0 + i) * 3;
                for c in 0..3 {
                    let top = tap(xi, yi, c) * (1.0 - tx) + tap(xi + 1, yi, c) * tx;
                    let bottom = tap(xi, yi + 1, c) * (1.0 - tx) + tap(xi + 1, yi + 1, c) * tx;
                    out[at + c] = encode(top * (1.0 - ty) + bottom * ty);
                }
            }
        }
    }
    SrgbImage::new(width, height, out).map_err(|e| CvvdpError::Clips(e.to_string()))
}

/// The retinal images of `frames` shown at `hold` sub-frames each: sub-frame `s` of frame
/// `k` is frame `k` seen with the gaze `gaze[k * hold + s]` (one point per eye).
pub fn retinal_clip(
    frames: &[SrgbImage],
    hold: u32,
    eyes: u32,
    gaze: &[Vec<Gaze>],
) -> Result<Vec<SrgbImage>, CvvdpError> {
    if hold == 0 {
        return Err(CvvdpError::Clips("a frame must be held for at least one sub-frame".into()));
    }
    if gaze.len() != frames.len() * hold as usize {
        return Err(CvvdpError::Clips(format!(
            "{} frames held for {hold} sub-frames need {} gaze points per eye, found {}",
            frames.len(),
            frames.len() * hold as usize,
            gaze.len()
        )));
    }
    gaze.iter().enumerate().map(|(k, g)| retinal_image(&frames[k / hold as usize], eyes, g)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mid-grey `w` x `h` frame with a bright square of side `side` whose left top corner is
    /// at `x` (integer pixels, clipped to the frame).
    fn square(w: u32, h: u32, x: i64, side: i64) -> SrgbImage {
        let mut data = vec![110u8; (w * h * 3) as usize];
        for j in (h as i64 / 2 - side / 2)..(h as i64 / 2 - side / 2 + side) {
            for i in x..x + side {
                if (0..w as i64).contains(&i) && (0..h as i64).contains(&j) {
                    let at = ((j as u32 * w + i as u32) * 3) as usize;
                    data[at..at + 3].copy_from_slice(&[240, 230, 200]);
                }
            }
        }
        SrgbImage::new(w, h, data).unwrap()
    }

    /// The luminance-weighted horizontal centroid of the bright pixels.
    fn centroid_x(image: &SrgbImage) -> f64 {
        let w = image.width() as usize;
        let (mut sum, mut weight) = (0.0, 0.0);
        for (k, px) in image.data().chunks_exact(3).enumerate() {
            let v = f64::from(px[0]) - 110.0;
            if v > 0.0 {
                sum += v * ((k % w) as f64 + 0.5);
                weight += v;
            }
        }
        sum / weight
    }

    #[test]
    fn a_gaze_at_the_centre_leaves_the_frame_unchanged() {
        let frame = square(40, 20, 7, 5);
        let same = retinal_image(&frame, 1, &[Gaze { x: 20.0, y: 10.0 }]).unwrap();
        assert_eq!(same, frame);
        // Every code survives the trip to linear light and back.
        let ramp = SrgbImage::new(256, 1, (0..=255u8).flat_map(|c| [c; 3]).collect()).unwrap();
        assert_eq!(retinal_image(&ramp, 1, &[Gaze { x: 128.0, y: 0.5 }]).unwrap(), ramp);
    }

    #[test]
    fn following_a_moving_object_holds_it_still_and_moves_the_rest() {
        // The square moves 3 pixels a frame; a gaze that follows it sees it at one place.
        let (w, h) = (48, 16);
        let frames: Vec<SrgbImage> = (0..5).map(|k| square(w, h, 10 + 3 * k, 4)).collect();
        let gaze: Vec<Vec<Gaze>> = (0..5).map(|k| vec![Gaze { x: 12.0 + 3.0 * k as f64, y: 8.0 }]).collect();
        let retina = retinal_clip(&frames, 1, 1, &gaze).unwrap();
        for r in &retina {
            assert!((centroid_x(r) - 24.0).abs() < 1e-9, "{}", centroid_x(r));
        }
        // The display slides the other way: at first the gaze is 12 pixels left of the
        // display's centre, so 12 columns of dark surround show on the left; at the end none.
        let px = |r: &SrgbImage, i: usize| r.data()[(8 * w as usize + i) * 3];
        assert_eq!((px(&retina[0], 11), px(&retina[0], 12)), (0, 110));
        assert_eq!(px(&retina[4], 0), 110);
    }

    #[test]
    fn a_held_frame_slides_back_while_the_gaze_moves_on() {
        // One frame held for four sub-frames while the gaze moves 1.5 pixels per sub-frame:
        // the square steps back by 1.5 pixels each sub-frame (sub-pixel steps interpolated).
        let frame = square(48, 16, 20, 4);
        let gaze: Vec<Vec<Gaze>> = (0..4).map(|s| vec![Gaze { x: 22.0 + 1.5 * f64::from(s), y: 8.0 }]).collect();
        let retina = retinal_clip(std::slice::from_ref(&frame), 4, 1, &gaze).unwrap();
        let xs: Vec<f64> = retina.iter().map(centroid_x).collect();
        for (s, x) in xs.iter().enumerate() {
            assert!((x - (24.0 - 1.5 * s as f64)).abs() < 0.05, "{xs:?}");
        }
    }

    #[test]
    fn each_eye_of_a_stereo_frame_follows_its_own_gaze() {
        let (w, h) = (32, 8);
        let left = square(w, h, 4, 2);
        let right = square(w, h, 20, 2);
        let mut data = Vec::new();
        for j in 0..h as usize {
            let row = |i: &SrgbImage| i.data()[j * w as usize * 3..(j + 1) * w as usize * 3].to_vec();
            data.extend(row(&left));
            data.extend(row(&right));
        }
        let sbs = SrgbImage::new(2 * w, h, data).unwrap();
        let r = retinal_image(&sbs, 2, &[Gaze { x: 5.0, y: 4.0 }, Gaze { x: 21.0, y: 4.0 }]).unwrap();
        // Both squares land at each eye's centre; nothing of one eye leaks into the other.
        let eye = |e: usize| {
            let data = (0..h as usize)
                .flat_map(|j| r.data()[(j * 2 * w as usize + e * w as usize) * 3..][..w as usize * 3].to_vec())
                .collect();
            SrgbImage::new(w, h, data).unwrap()
        };
        assert!((centroid_x(&eye(0)) - 16.0).abs() < 1e-9);
        assert!((centroid_x(&eye(1)) - 16.0).abs() < 1e-9);
    }

    /// A grey `w` x `h` frame with a bright bar `side` pixels wide over the middle rows, its
    /// left edge swept over `[x, x + blur]` during the exposure (box-filtered coverage).
    fn moving_bar(w: u32, h: u32, x: f64, side: f64, blur: f64) -> SrgbImage {
        let steps = 256;
        let coverage: Vec<f64> = (0..w)
            .map(|i| {
                let (a, b) = (f64::from(i), f64::from(i) + 1.0);
                (0..steps)
                    .map(|s| {
                        let left = x + blur * (f64::from(s) + 0.5) / f64::from(steps);
                        (b.min(left + side) - a.max(left)).clamp(0.0, 1.0)
                    })
                    .sum::<f64>()
                    / f64::from(steps)
            })
            .collect();
        let table = decode_table();
        let (grey, bright) = (f64::from(table[110]), f64::from(table[235]));
        let mut data = Vec::new();
        for j in 0..h {
            for c in &coverage {
                let lit = (h / 3..h - h / 3).contains(&j);
                let v = if lit { grey + (bright - grey) * c } else { grey };
                data.extend([encode(v as f32); 3]);
            }
        }
        SrgbImage::new(w, h, data).unwrap()
    }

    #[test]
    fn a_pursuing_eye_sees_a_camera_shutter_as_extra_blur() {
        // A bar moving 6 pixels per displayed frame at 30 fps, shown as a 0 % shutter (sharp,
        // jumping) and a 100 % shutter (swept over the frame), judged against the sharp motion
        // at 4 sub-frames per frame. Fixating, the eye sees the sharp bar jump and the swept
        // bar fill the gaps; pursuing, it sees both slide back during each hold, the swept
        // one smeared on top of that, so the sharp bar is the nearer to the motion.
        use crate::cvvdp::{Clip, DisplayConditions, Threads, VideoObserver};
        let (w, h, side, speed, frames, hold) = (96, 24, 5.0, 6.0, 6, 4);
        let start = |k: usize| 16.0 + speed * k as f64;
        let instant = |t: f64| 16.0 + speed * t; // left edge at time t, in displayed frames
        let sharp: Vec<SrgbImage> = (0..frames).map(|k| moving_bar(w, h, start(k) + 0.5 * speed, side, 0.0)).collect();
        let swept: Vec<SrgbImage> = (0..frames).map(|k| moving_bar(w, h, start(k), side, speed)).collect();
        let times: Vec<f64> = (0..frames * hold).map(|s| (s as f64 + 0.5) / hold as f64).collect();
        let reference: Vec<SrgbImage> = times.iter().map(|&t| moving_bar(w, h, instant(t), side, 0.0)).collect();
        let gaze: Vec<Vec<Gaze>> =
            times.iter().map(|&t| vec![Gaze { x: instant(t) + 0.5 * side, y: f64::from(h) / 2.0 }]).collect();
        let display =
            DisplayConditions { pixels_per_degree: 40.0, peak_luminance: 200.0, black_level: 0.2, ambient_lux: 250.0 };
        let observer = VideoObserver::new(display, Threads::One).unwrap();
        let sub_fps = 30.0 * hold as f64;
        let fixating = |test: &[SrgbImage]| {
            observer
                .judge(&Clip { frames: test, fps: 30.0 }, &Clip { frames: &reference, fps: sub_fps }, 1)
                .unwrap()
                .jod()
        };
        let retinal_reference: Vec<SrgbImage> =
            reference.iter().zip(&gaze).map(|(f, g)| retinal_image(f, 1, g).unwrap()).collect();
        let pursuing = |test: &[SrgbImage]| {
            let retina = retinal_clip(test, hold as u32, 1, &gaze).unwrap();
            observer
                .judge(&Clip { frames: &retina, fps: sub_fps }, &Clip { frames: &retinal_reference, fps: sub_fps }, 1)
                .unwrap()
                .jod()
        };
        // The tracked reference stands still on the retina.
        for r in &retinal_reference {
            assert!((centroid_x(r) - f64::from(w) / 2.0).abs() < 0.05, "{}", centroid_x(r));
        }
        let (fix_sharp, fix_swept) = (fixating(&sharp), fixating(&swept));
        let (pur_sharp, pur_swept) = (pursuing(&sharp), pursuing(&swept));
        assert!(pur_sharp > pur_swept + 0.1, "pursuit: sharp {pur_sharp}, swept {pur_swept}");
        assert!(fix_swept > fix_sharp, "fixation: sharp {fix_sharp}, swept {fix_swept}");
    }

    #[test]
    fn bad_gaze_is_named() {
        let frame = square(16, 8, 2, 2);
        let e = retinal_image(&frame, 1, &[]).unwrap_err();
        assert!(e.to_string().contains("0 gaze points"), "{e}");
        let e = retinal_image(&frame, 1, &[Gaze { x: f64::NAN, y: 0.0 }]).unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
        let e = retinal_clip(std::slice::from_ref(&frame), 4, 1, &[vec![Gaze { x: 8.0, y: 4.0 }]]).unwrap_err();
        assert!(e.to_string().contains("need 4 gaze points"), "{e}");
        let e = retinal_image(&frame, 3, &[Gaze { x: 0.0, y: 0.0 }; 3]).unwrap_err();
        assert!(e.to_string().contains("3 eyes"), "{e}");
    }
}
