//! What accuracy costs in time (`blurlab cost`): the measured points of a cost sweep, as the
//! renderer records them (`render::measure::cost`) and the analysis reports them (`analysis::cost`),
//! and the table both agree on: one row per method setting, with the median and spread of
//! its repetitions.
//!
//! A point is one render of one frame by one method at one setting of its accuracy knob
//! (tracer samples per pixel, accumulation-buffer instants, filter taps at an input sample
//! level, analytic interval budget), repeated with independent seeds; its error is measured
//! against a converged tracer reference of the same frame on display values (exposure, tone
//! map, sRGB in [0, 1]): RMSE, PSNR (peak 1) and FLIP at the design's viewing geometry.

use serde::{Deserialize, Serialize};

use crate::Method;
use crate::method::CurveInput;
use crate::stats::median;

/// Format tag of `cost.json`.
pub const COST_FORMAT: &str = "blurlab-cost/1";

/// One measured render.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostPoint {
    /// The method.
    pub method: Method,
    /// The knob's name: `spp`, `instants`, `taps` or `intervals`.
    pub knob: String,
    /// The knob's value.
    pub value: u32,
    /// Samples per pixel of the method's input: the tracer's own, the accumulation buffer's
    /// per instant, the filters' G-buffer level, the analytic rasterizer's lighting samples.
    pub input_spp: u32,
    /// Frame index within the preset.
    pub frame: u32,
    /// Repetition, 0-based (its seeds are mixed with it).
    pub repetition: u32,
    /// Wall-clock seconds of the render.
    pub wall_seconds: f64,
    /// GPU seconds from timestamp queries, where measured.
    pub gpu_seconds: Option<f64>,
    /// Camera (or lighting) samples traced.
    pub camera_samples: u64,
    /// Work units of the knob summed over the pixels: samples, instants x samples, taps,
    /// intervals.
    pub work_units: u64,
    /// RMSE of the display values against the reference.
    pub rmse: f64,
    /// RMSE of the linear radiance against the reference.
    pub rmse_linear: f64,
    /// Mean FLIP against the reference (8-bit sRGB frames, as shown).
    pub flip: f64,
    /// ColorVideoVDP's quality of the frame as shown against the reference, JOD (10: the
    /// display shows them alike; 1 JOD lower: 75 % of people prefer the reference), at the
    /// design's display and viewing geometry, the mean over the eyes; `None` in points kept
    /// from sweeps measured before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jod: Option<f64>,
}

impl CostPoint {
    /// The file name a point is kept under: unique per method, setting, frame and repetition.
    pub fn key(&self) -> String {
        point_key(self.method, &self.knob, self.value, self.input_spp, self.frame, self.repetition)
    }
}

/// [`CostPoint::key`] of a point not yet measured.
pub fn point_key(method: Method, knob: &str, value: u32, input_spp: u32, frame: u32, repetition: u32) -> String {
    format!("{method}-{knob}{value}-in{input_spp}-f{frame:04}-r{repetition}")
}

/// The converged reference of one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostReference {
    /// Frame index within the preset.
    pub frame: u32,
    /// Tracer samples per pixel (two independent halves).
    pub spp: u32,
    /// Its own standard error on display values, RMS over pixels and channels: half the RMS
    /// difference of the two halves.
    pub standard_error: f64,
    /// Wall-clock seconds it took.
    pub wall_seconds: f64,
}

/// A whole sweep: what was asked, the references and every point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostSweep {
    /// [`COST_FORMAT`].
    pub format: String,
    /// The design's name.
    pub design: String,
    /// SHA-256 of the design file.
    pub design_sha256: String,
    /// Preset.
    pub preset: String,
    /// The material, speed and shutter swept, `M3-S3-T5`.
    pub cell: String,
    /// Stereo (both eyes side by side) or mono.
    pub stereo: bool,
    /// Frames measured.
    pub frames: Vec<u32>,
    /// Image size of one eye.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixels per degree of one eye's image at the design's viewing geometry (FLIP's).
    pub pixels_per_degree: f64,
    /// Repetitions per point.
    pub repetitions: u32,
    /// The design's sampling levels at this preset: `(A label, samples per pixel)`.
    pub levels: Vec<(String, u32)>,
    /// Where it was rendered.
    pub device: String,
    /// One per frame.
    pub references: Vec<CostReference>,
    /// Every point measured, in sweep order.
    pub points: Vec<CostPoint>,
}

/// Median and spread of one quantity over a setting's renders.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Median.
    pub median: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Spread {
    /// Of `values` (NaN for none).
    pub fn of(values: &[f64]) -> Spread {
        Spread {
            median: median(values),
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// One row of the table: a method at one setting, over every frame and repetition.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostRow {
    /// The method.
    pub method: Method,
    /// The knob.
    pub knob: String,
    /// Its value.
    pub value: u32,
    /// Input samples per pixel.
    pub input_spp: u32,
    /// Renders summarised (frames x repetitions).
    pub renders: usize,
    /// Wall seconds per frame.
    pub wall_seconds: Spread,
    /// GPU seconds per frame (median), where every render measured it.
    pub gpu_seconds: Option<f64>,
    /// Work units per frame (median).
    pub work_units: f64,
    /// Display RMSE.
    pub rmse: Spread,
    /// PSNR of the median RMSE, dB.
    pub psnr_db: f64,
    /// Mean FLIP.
    pub flip: Spread,
    /// ColorVideoVDP quality, JOD, where every render recorded it.
    pub jod: Option<Spread>,
}

impl CostRow {
    /// `tracer spp=16`, `guertin taps=35 (16 spp in)`.
    pub fn label(&self) -> String {
        match self.method.curve_input() {
            // The tracer's input is its knob.
            CurveInput::Ignored => format!("{} {}={}", self.method, self.knob, self.value),
            CurveInput::Each | CurveInput::Highest => {
                format!("{} {}={} ({} spp in)", self.method, self.knob, self.value, self.input_spp)
            }
        }
    }
}

/// PSNR in dB of a display RMSE with peak 1 (infinite for identical images).
pub fn psnr(rmse: f64) -> f64 {
    -20.0 * rmse.log10()
}

impl CostSweep {
    /// The table: one row per method setting in the order the sweep first measured them.
    pub fn rows(&self) -> Vec<CostRow> {
        let mut keys: Vec<(Method, String, u32, u32)> = Vec::new();
        for p in &self.points {
            let k = (p.method, p.knob.clone(), p.value, p.input_spp);
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
        keys.into_iter()
            .map(|(method, knob, value, input_spp)| {
                let pts: Vec<&CostPoint> = self
                    .points
                    .iter()
                    .filter(|p| p.method == method && p.knob == knob && p.value == value && p.input_spp == input_spp)
                    .collect();
                let of = |f: &dyn Fn(&CostPoint) -> f64| Spread::of(&pts.iter().map(|p| f(p)).collect::<Vec<_>>());
                let gpu: Option<Vec<f64>> = pts.iter().map(|p| p.gpu_seconds).collect();
                let jod: Option<Vec<f64>> = pts.iter().map(|p| p.jod).collect();
                let rmse = of(&|p| p.rmse);
                CostRow {
                    method,
                    knob,
                    value,
                    input_spp,
                    renders: pts.len(),
                    wall_seconds: of(&|p| p.wall_seconds),
                    gpu_seconds: gpu.map(|g| median(&g)),
                    work_units: of(&|p| p.work_units as f64).median,
                    psnr_db: psnr(rmse.median),
                    rmse,
                    flip: of(&|p| p.flip),
                    jod: jod.map(|j| Spread::of(&j)),
                }
            })
            .collect()
    }

    /// The smallest median RMSE of any row: what the reference must be well below.
    pub fn smallest_error(&self) -> Option<(f64, String)> {
        self.rows().into_iter().map(|r| (r.rmse.median, r.label())).min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// The exponent `b` of the tracer's RMSE ~ spp^b: the least-squares slope of log median
    /// RMSE against log samples per pixel (independent Monte Carlo gives -1/2); `None` with
    /// fewer than two tracer settings.
    pub fn tracer_exponent(&self) -> Option<f64> {
        let pts: Vec<(f64, f64)> = self
            .rows()
            .iter()
            .filter(|r| r.method == Method::Tracer && r.knob == "spp" && r.rmse.median > 0.0)
            .map(|r| (f64::from(r.value).ln(), r.rmse.median.ln()))
            .collect();
        if pts.len() < 2 {
            return None;
        }
        let n = pts.len() as f64;
        let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        Some(pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx)
    }

    /// The largest standard error of the references.
    pub fn reference_standard_error(&self) -> f64 {
        self.references.iter().map(|r| r.standard_error).fold(0.0, f64::max)
    }

    /// `cost.csv`: one line per row, the columns named in its header.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "method,knob,value,input_spp,renders,wall_seconds_median,wall_seconds_min,wall_seconds_max,gpu_seconds_median,work_units,rmse_median,rmse_min,rmse_max,psnr_db,flip_median,flip_min,flip_max,jod_median,jod_min,jod_max\n",
        );
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
        for r in self.rows() {
            out.push_str(&format!(
                "{},{},{},{},{},{:.6},{:.6},{:.6},{},{:.0},{:.6},{:.6},{:.6},{:.3},{:.6},{:.6},{:.6},{},{},{}\n",
                r.method,
                r.knob,
                r.value,
                r.input_spp,
                r.renders,
                r.wall_seconds.median,
                r.wall_seconds.min,
                r.wall_seconds.max,
                opt(r.gpu_seconds),
                r.work_units,
                r.rmse.median,
                r.rmse.min,
                r.rmse.max,
                r.psnr_db,
                r.flip.median,
                r.flip.min,
                r.flip.max,
                opt(r.jod.map(|j| j.median)),
                opt(r.jod.map(|j| j.min)),
                opt(r.jod.map(|j| j.max))
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(method: Method, value: u32, rep: u32, rmse: f64) -> CostPoint {
        CostPoint {
            method,
            knob: "spp".into(),
            value,
            input_spp: value,
            frame: 0,
            repetition: rep,
            wall_seconds: f64::from(value) * 0.01,
            gpu_seconds: None,
            camera_samples: u64::from(value) * 100,
            work_units: u64::from(value) * 100,
            rmse,
            rmse_linear: rmse,
            flip: rmse * 2.0,
            jod: Some(10.0 - rmse),
        }
    }

    /// A 4 x 4 sweep of `points` with one reference.
    fn sweep_of(points: Vec<CostPoint>, repetitions: u32) -> CostSweep {
        CostSweep {
            format: COST_FORMAT.into(),
            design: "d".into(),
            design_sha256: "0".into(),
            preset: "quick".into(),
            cell: "M1-S1-T1".into(),
            stereo: false,
            frames: vec![0],
            width: 4,
            height: 4,
            pixels_per_degree: 10.0,
            repetitions,
            levels: vec![],
            device: "cpu".into(),
            references: vec![CostReference { frame: 0, spp: 64, standard_error: 0.001, wall_seconds: 1.0 }],
            points,
        }
    }

    #[test]
    fn rows_take_the_median_and_spread_of_the_repetitions_in_sweep_order() {
        let sweep = sweep_of(
            vec![
                point(Method::Tracer, 4, 0, 0.3),
                point(Method::Tracer, 4, 1, 0.1),
                point(Method::Tracer, 4, 2, 0.2),
                point(Method::Tracer, 1, 0, 0.5),
            ],
            3,
        );
        let rows = sweep.rows();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].value, rows[0].renders), (4, 3));
        assert_eq!(rows[0].rmse, Spread { median: 0.2, min: 0.1, max: 0.3 });
        assert!((rows[0].psnr_db - 13.979).abs() < 1e-3);
        let jod = rows[0].jod.unwrap();
        assert!((jod.median - 9.8).abs() < 1e-12 && (jod.min - 9.7).abs() < 1e-12 && (jod.max - 9.9).abs() < 1e-12);
        assert_eq!(rows[0].label(), "tracer spp=4");
        assert_eq!(sweep.smallest_error().unwrap().0, 0.2);
        // 0.5 at 1 spp, 0.2 at 4: log(0.4) / log(4).
        assert!((sweep.tracer_exponent().unwrap() - 0.4f64.ln() / 4f64.ln()).abs() < 1e-12);
        let csv = sweep.csv();
        assert_eq!(csv.lines().count(), 3);
        assert!(csv.lines().nth(1).unwrap().starts_with("tracer,spp,4,4,3,0.040000"), "{csv}");
        assert!(csv.lines().nth(1).unwrap().ends_with(",9.800000,9.700000,9.900000"), "{csv}");
        assert_eq!(sweep.points[0].key(), "tracer-spp4-in4-f0000-r0");
        let json = serde_json::to_string(&sweep).unwrap();
        assert_eq!(serde_json::from_str::<CostSweep>(&json).unwrap(), sweep);
    }

    #[test]
    fn points_kept_from_before_the_observer_leave_its_columns_empty() {
        let mut old = serde_json::to_value(point(Method::Tracer, 2, 0, 0.1)).unwrap();
        old.as_object_mut().unwrap().remove("jod");
        let old: CostPoint = serde_json::from_value(old).unwrap();
        assert_eq!(old.jod, None);
        let sweep = sweep_of(vec![old, point(Method::Tracer, 2, 1, 0.2)], 2);
        // One render without a quality: the row has none rather than the other's alone.
        assert_eq!(sweep.rows()[0].jod, None);
        assert!(sweep.csv().lines().nth(1).unwrap().ends_with(",,,"), "{}", sweep.csv());
    }
}
