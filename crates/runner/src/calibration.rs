//! Calibration: the scale at which a stimulus subtends the visual angle the definition asks
//! for (14.4 degrees in the study), from the screen's width in centimetres, its horizontal
//! resolution and the viewing distance.
//!
//! The width on screen is `2 d tan(angle / 2)`; in pixels, times the screen's pixels per
//! centimetre. Integer scales (and 1/2, 1/3 ...) keep every pixel sharp, so a scale within
//! [`INTEGER_TOLERANCE`] of one is snapped to it; otherwise the exact scale is used, drawn
//! with linear filtering, and a warning says by how much the nearest integer scale would miss.

use serde::{Deserialize, Serialize};

/// Relative error of the visual angle accepted to snap to an integer scale.
pub const INTEGER_TOLERANCE: f64 = 0.05;

/// The viewing set-up.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Viewing {
    /// Visible width of the screen in centimetres.
    pub screen_width_cm: f64,
    /// Horizontal resolution of the screen in pixels.
    pub screen_width_px: u32,
    /// Eye-to-screen distance in centimetres.
    pub distance_cm: f64,
}

impl Default for Viewing {
    /// The thesis's set-up: a 17.3" 16:9 LCD (38.2 cm wide) at 1600x900, viewed from 60 cm.
    fn default() -> Self {
        Viewing { screen_width_cm: 38.2, screen_width_px: 1600, distance_cm: 60.0 }
    }
}

/// The result of calibrating one stimulus width.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Screen pixels per stimulus pixel.
    pub scale: f64,
    /// Whether `scale` is an integer or the reciprocal of one (sharp pixels).
    pub integer: bool,
    /// Width on screen in pixels that gives exactly the requested angle.
    pub target_px: f64,
    /// The visual angle actually subtended at `scale`, in degrees.
    pub angle_deg: f64,
    /// Set when the scale is not an integer, or the stimulus does not fit the screen.
    pub warning: Option<String>,
}

/// The visual angle in degrees of a stimulus `stimulus_px` wide drawn at `scale`.
pub fn visual_angle_deg(viewing: &Viewing, stimulus_px: u32, scale: f64) -> f64 {
    let cm = f64::from(stimulus_px) * scale * viewing.screen_width_cm / f64::from(viewing.screen_width_px);
    2.0 * (cm / (2.0 * viewing.distance_cm)).atan().to_degrees()
}

/// How the stimuli of a trial are laid out: `columns x rows` slots of one stimulus each
/// (2AFC: one slot; matching: the reference above two candidates, counted as 2 x 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Slots side by side.
    pub columns: u32,
    /// Rows of slots.
    pub rows: u32,
}

/// The scale at which stimuli of `stimulus` pixels (width, height of the displayed image) are
/// drawn in `layout` when `space` screen pixels (width, height) are left for them after the
/// labels and buttons, and `gap` pixels separate slots: the calibrated `scale`, or less when
/// that does not fit. Returns the scale and whether it was reduced.
pub fn fit_scale(scale: f64, stimulus: (f64, f64), layout: Layout, space: (f64, f64), gap: f64) -> (f64, bool) {
    let need_w = f64::from(layout.columns) * stimulus.0;
    let need_h = f64::from(layout.rows) * stimulus.1;
    let gaps_w = gap * f64::from(layout.columns.saturating_sub(1));
    let gaps_h = gap * f64::from(layout.rows.saturating_sub(1));
    let fit = ((space.0 - gaps_w) / need_w).min((space.1 - gaps_h) / need_h).max(0.05);
    if fit + 1e-9 < scale { (fit, true) } else { (scale, false) }
}

/// Calibrates a stimulus `stimulus_px` wide (one eye) to `angle_deg`.
pub fn calibrate(viewing: &Viewing, stimulus_px: u32, angle_deg: f64) -> Result<Calibration, String> {
    let Viewing { screen_width_cm, screen_width_px, distance_cm } = *viewing;
    for (name, v) in [("screen width", screen_width_cm), ("viewing distance", distance_cm)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{name} must be a positive number of centimetres, got {v}"));
        }
    }
    if screen_width_px == 0 || stimulus_px == 0 {
        return Err("screen and stimulus widths must be at least 1 pixel".into());
    }
    let px_per_cm = f64::from(screen_width_px) / screen_width_cm;
    let target_cm = 2.0 * distance_cm * (angle_deg.to_radians() / 2.0).tan();
    let target_px = target_cm * px_per_cm;
    let exact = target_px / f64::from(stimulus_px);
    let snapped = if exact >= 1.0 { exact.round() } else { 1.0 / (1.0 / exact).round() };
    let angle_of = |scale: f64| visual_angle_deg(viewing, stimulus_px, scale);
    let snapped_error = (angle_of(snapped) - angle_deg).abs() / angle_deg;
    let (scale, integer, mut warning) = if snapped_error <= INTEGER_TOLERANCE {
        (snapped, true, None)
    } else {
        let w = format!(
            "no integer scale gives {angle_deg} degrees (scale {exact:.3}; the nearest integer scale {snapped} would give {:.2} degrees): using {exact:.3} with smoothing",
            angle_of(snapped)
        );
        (exact, false, Some(w))
    };
    if f64::from(stimulus_px) * scale > f64::from(screen_width_px) + 0.5 {
        warning = Some(format!(
            "the stimulus needs {:.0} px but the screen is {screen_width_px} px wide{}",
            f64::from(stimulus_px) * scale,
            warning.map(|w| format!("; also {w}")).unwrap_or_default()
        ));
    }
    Ok(Calibration { scale, integer, target_px, angle_deg: angle_of(scale), warning })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_setup_gives_integer_scale_one() {
        // 60 cm, 14.4 degrees: 15.16 cm; at 1600 px / 38.2 cm that is 635 px for 640.
        let c = calibrate(&Viewing::default(), 640, 14.4).unwrap();
        assert!((c.target_px - 635.0).abs() < 1.0, "{c:?}");
        assert_eq!((c.scale, c.integer), (1.0, true));
        assert!((c.angle_deg - 14.51).abs() < 0.02, "{c:?}");
        assert!(c.warning.is_none());
    }

    #[test]
    fn doubles_on_a_dense_screen_and_halves_a_large_stimulus() {
        let dense = Viewing { screen_width_cm: 38.2, screen_width_px: 3200, distance_cm: 60.0 };
        assert_eq!(calibrate(&dense, 640, 14.4).unwrap().scale, 2.0);
        assert_eq!(calibrate(&Viewing::default(), 1280, 14.4).unwrap().scale, 0.5);
    }

    #[test]
    fn warns_when_no_integer_scale_is_close() {
        let v = Viewing { screen_width_cm: 38.2, screen_width_px: 2400, distance_cm: 60.0 };
        let c = calibrate(&v, 640, 14.4).unwrap();
        assert!(!c.integer && (c.scale - 1.488).abs() < 0.01, "{c:?}");
        assert!((c.angle_deg - 14.4).abs() < 1e-9);
        assert!(c.warning.unwrap().contains("no integer scale gives 14.4 degrees"));
        let tiny = Viewing { screen_width_cm: 10.0, screen_width_px: 300, distance_cm: 60.0 };
        assert!(calibrate(&tiny, 640, 14.4).unwrap().warning.unwrap().contains("screen is 300 px wide"));
        assert!(calibrate(&Viewing { distance_cm: 0.0, ..v }, 640, 14.4).unwrap_err().contains("viewing distance"));
    }

    #[test]
    fn fit_scale_shrinks_only_what_does_not_fit() {
        let two_afc = Layout { columns: 1, rows: 1 };
        let matching = Layout { columns: 2, rows: 2 };
        // 640x360 at scale 1 fits a 1264x560 space in one slot.
        assert_eq!(fit_scale(1.0, (640.0, 360.0), two_afc, (1264.0, 560.0), 8.0), (1.0, false));
        // Matching needs 1288x728 at scale 1: the height limits it to (560 - 8) / 720.
        let (s, reduced) = fit_scale(1.0, (640.0, 360.0), matching, (1264.0, 560.0), 8.0);
        assert!(reduced && (s - 552.0 / 720.0).abs() < 1e-12, "{s}");
        // Width-limited: stereo side by side 1280 wide in a 1264 wide space.
        let (s, reduced) = fit_scale(1.0, (1280.0, 360.0), two_afc, (1264.0, 900.0), 8.0);
        assert!(reduced && (s - 1264.0 / 1280.0).abs() < 1e-12);
        // A scale-2 calibration on a large space stays 2.
        assert_eq!(fit_scale(2.0, (640.0, 360.0), two_afc, (3000.0, 2000.0), 8.0), (2.0, false));
        // The angle at a reduced scale.
        let v = Viewing::default();
        assert!((visual_angle_deg(&v, 640, 1.0) - calibrate(&v, 640, 14.4).unwrap().angle_deg).abs() < 1e-12);
        assert!(visual_angle_deg(&v, 640, 0.5) < 7.3);
    }
}
