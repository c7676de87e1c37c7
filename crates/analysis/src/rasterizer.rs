//! Figures of the analytic rasterizer's approximations (`blurlab bench analytic-accuracy`):
//! the histogram of the linear depth's relative error per visibility interval (the paper's
//! Figure 10) and the tessellated sphere's coverage error against the true sphere as the
//! tessellation grows. The numbers come from `render::measure::analytic_accuracy`; this module only
//! draws them (PNG and SVG, written atomically).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::plots::{Figure, PlotError, draw_legend, log_log_chart, save_figure};

fn err(e: &dyn std::fmt::Debug) -> String {
    format!("{e:?}")
}

/// Intervals per decade of relative depth error.
#[derive(Clone, Debug)]
pub struct DepthErrorFigure {
    /// Title line.
    pub title: String,
    /// Each bin's decade (the lower bound's power of ten) and its intervals; the first bin
    /// also counts smaller errors and zeros.
    pub bins: Vec<(i32, u64)>,
}

impl Figure for DepthErrorFigure {
    fn size(&self) -> (u32, u32) {
        (760, 420)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let total: u64 = self.bins.iter().map(|b| b.1).sum();
        if self.bins.is_empty() || total == 0 {
            return Err("no intervals measured".into());
        }
        let share = |c: u64| 100.0 * c as f64 / total as f64;
        let top = self.bins.iter().map(|b| share(b.1)).fold(0.0, f64::max);
        let n = self.bins.len() as u32;
        let labels: Vec<String> = self
            .bins
            .iter()
            .enumerate()
            .map(|(i, (d, _))| if i == 0 { format!("<1e{}", d + 1) } else { format!("1e{d}") })
            .collect();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 17.0).into_font())
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d((0u32..n).into_segmented(), 0.0..top * 1.12)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n as usize)
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => labels.get(*i as usize).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .y_label_formatter(&|v| format!("{v:.0} %"))
            .x_desc("largest relative error of the linear depth within an interval (decade)")
            .y_desc("intervals")
            .label_style(("sans-serif", 12.0))
            .axis_desc_style(("sans-serif", 14.0))
            .draw()
            .map_err(|e| err(&e))?;
        let colour = RGBColor(31, 119, 180);
        chart
            .draw_series(self.bins.iter().enumerate().map(|(i, b)| {
                let x = i as u32;
                Rectangle::new(
                    [(SegmentValue::Exact(x), 0.0), (SegmentValue::Exact(x + 1), share(b.1))],
                    colour.mix(0.8).filled(),
                )
            }))
            .map_err(|e| err(&e))?;
        Ok(())
    }
}

/// One tessellation's coverage error.
#[derive(Clone, Copy, Debug)]
pub struct TessellationPoint {
    /// Segments around the equator.
    pub segments: u32,
    /// Mean absolute difference of covered shutter fractions.
    pub mean: f64,
    /// Largest difference.
    pub max: f64,
}

/// Coverage error against the segments, log-log, with the chord's `segments^-2` slope.
#[derive(Clone, Debug)]
pub struct TessellationFigure {
    /// Title line.
    pub title: String,
    /// The rasterizer's (translated vertices), in any order.
    pub points: Vec<TessellationPoint>,
    /// The mean error with vertices on the rotation's chords (drawn dashed; may be empty).
    pub chords: Vec<TessellationPoint>,
}

impl Figure for TessellationFigure {
    fn size(&self) -> (u32, u32) {
        (760, 460)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let mut pts: Vec<TessellationPoint> =
            self.points.iter().copied().filter(|p| p.segments > 0 && p.mean > 0.0 && p.max > 0.0).collect();
        if pts.is_empty() {
            return Err("no tessellation with a positive error".into());
        }
        pts.sort_by_key(|p| p.segments);
        let (s0, s1) = (f64::from(pts[0].segments), f64::from(pts[pts.len() - 1].segments));
        let e0 = pts.iter().map(|p| p.mean).fold(f64::INFINITY, f64::min);
        let chords: Vec<(f64, f64)> = {
            let mut c: Vec<_> = self.chords.iter().filter(|p| p.segments > 0 && p.mean > 0.0).copied().collect();
            c.sort_by_key(|p| p.segments);
            c.iter().map(|p| (f64::from(p.segments), p.mean)).collect()
        };
        let e1 = pts.iter().map(|p| p.max).chain(chords.iter().map(|c| c.1)).fold(0.0, f64::max);
        let mut chart = log_log_chart(
            root,
            &self.title,
            (s0 / 1.3..s1 * 1.3, "sphere segments around the equator"),
            (e0 / 2.0..e1 * 2.0, "covered fraction of the shutter, |tessellated - true|"),
            (&|v| format!("{v:.0}"), &|v| format!("{v:.0e}")),
        )?;
        let series = [
            (
                "max over sample points",
                RGBColor(214, 39, 40),
                pts.iter().map(|p| (f64::from(p.segments), p.max)).collect::<Vec<_>>(),
            ),
            (
                "mean over covered sample points",
                RGBColor(31, 119, 180),
                pts.iter().map(|p| (f64::from(p.segments), p.mean)).collect(),
            ),
        ];
        for (label, colour, line) in series {
            chart
                .draw_series(LineSeries::new(line.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(|e| err(&e))?;
        }
        if !chords.is_empty() {
            let colour = RGBColor(148, 103, 189);
            chart
                .draw_series(DashedLineSeries::new(chords.clone(), 6, 4, colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label("mean, vertices on the rotation's chords")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart.draw_series(chords.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(|e| err(&e))?;
        }
        let anchor = (f64::from(pts[0].segments), pts[0].mean);
        let slope: Vec<(f64, f64)> = [anchor.0, s1].iter().map(|&s| (s, anchor.1 * (anchor.0 / s).powi(2))).collect();
        chart
            .draw_series(LineSeries::new(slope, BLACK.mix(0.5).stroke_width(1)))
            .map_err(|e| err(&e))?
            .label("segments^-2 (chord sagitta)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5)));
        draw_legend(&mut chart)?;
        Ok(())
    }
}

/// Writes `depth-error.{png,svg}` and `tessellation.{png,svg}` into `dir`; returns the paths.
pub fn write_figures(
    depth: &DepthErrorFigure,
    tessellation: &TessellationFigure,
    dir: &Path,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut out = save_figure(depth, dir, "depth-error")?;
    out.extend(save_figure(tessellation, dir, "tessellation")?);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_figures_are_drawn_and_empty_data_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let depth = DepthErrorFigure { title: "depth".into(), bins: vec![(-12, 10), (-11, 0), (-4, 3)] };
        let tess = TessellationFigure {
            title: "tessellation".into(),
            points: vec![
                TessellationPoint { segments: 16, mean: 1e-2, max: 0.2 },
                TessellationPoint { segments: 64, mean: 7e-4, max: 0.05 },
            ],
            chords: vec![TessellationPoint { segments: 64, mean: 0.05, max: 0.2 }],
        };
        let paths = write_figures(&depth, &tess, dir.path()).unwrap();
        assert_eq!(paths.len(), 4);
        for p in &paths {
            assert!(std::fs::metadata(p).unwrap().len() > 1000, "{}", p.display());
        }
        let svg = std::fs::read_to_string(dir.path().join("depth-error.svg")).unwrap();
        assert!(svg.contains("1e-4") && svg.contains("&lt;1e-11"), "bin labels missing");
        let empty = DepthErrorFigure { title: "none".into(), bins: vec![(-12, 0)] };
        assert!(save_figure(&empty, dir.path(), "empty").is_err());
        assert!(!dir.path().join("empty.png").exists());
    }
}
