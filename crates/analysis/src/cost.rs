//! The cost report (`blurlab cost`): a measured sweep (`study::cost::CostSweep`, made by
//! `render::measure::cost`) as `cost.csv`, `cost.md` and log-log plots of error against time (RMSE and
//! FLIP, PNG and SVG: one curve per method, the Monte Carlo 1/sqrt(N) slope drawn from the
//! tracer's first point), and, given an analysis report (`report.json` of `blurlab analyze`),
//! the perceptually equivalent groups marked on the curves with each group's cheapest member:
//! what people could not tell apart and what it costs.
//!
//! A group member lies on the curves when its material, speed, shutter and view are the
//! sweep's cell: its sampling level is then the tracer's point at that level's samples per
//! pixel (the sweep always includes the preset's levels). Members of other cells are listed
//! as such.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::Value;
use study::Method;
use study::StimulusId;
use study::cost::{CostRow, CostSweep};
use study::method::CurveInput;

use crate::plots::{Figure, PlotError, draw_legend, group_colour, log_log_chart, save_figure};

/// Why the report could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CostReportError {
    /// The analysis report could not be read or is not one.
    #[error("{path}: {message}")]
    Report {
        /// File.
        path: PathBuf,
        /// Cause.
        message: String,
    },
    /// A figure failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// Writing failed.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

/// One member of an equivalent group, placed on the sweep when it can be.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkedMember {
    /// Stimulus id.
    pub id: StimulusId,
    /// The table row it is (tracer at its level's samples), when in the sweep's cell.
    pub row: Option<CostRow>,
}

/// A perceptually equivalent group of an analysis report.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkedGroup {
    /// The experiment.
    pub experiment: String,
    /// Group number (1 = most preferred).
    pub number: usize,
    /// Its members.
    pub members: Vec<MarkedMember>,
}

impl MarkedGroup {
    /// The member on the curves with the smallest median time.
    pub fn cheapest(&self) -> Option<&MarkedMember> {
        self.members
            .iter()
            .filter_map(|m| m.row.as_ref().map(|row| (m, row.wall_seconds.median)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(m, _)| m)
    }
}

/// The tracer row at samples-per-pixel level `a` (1-based) of the sweep's preset.
fn level_row(sweep: &CostSweep, rows: &[CostRow], a: u8) -> Option<CostRow> {
    let spp = sweep.levels.get(usize::from(a).checked_sub(1)?)?.1;
    rows.iter().find(|r| r.method == Method::Tracer && r.knob == "spp" && r.value == spp).cloned()
}

/// The paired groups of every experiment of `report.json` (a report folder or the file),
/// placed on `sweep`.
pub fn groups_from_report(path: &Path, sweep: &CostSweep) -> Result<Vec<MarkedGroup>, CostReportError> {
    let file = if path.is_dir() { path.join("report.json") } else { path.to_owned() };
    let bad = |message: String| CostReportError::Report { path: file.clone(), message };
    let text = std::fs::read_to_string(&file).map_err(|e| bad(format!("cannot read: {e}")))?;
    let json: Value = serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let format = json["format"].as_str().unwrap_or("");
    if !format.starts_with("blurlab-report/") {
        return Err(bad(format!(
            "field `format` is `{format}`, expected a blurlab analysis report (`blurlab-report/...`)"
        )));
    }
    let rows = sweep.rows();
    let mut out = Vec::new();
    for e in json["experiments"].as_array().into_iter().flatten() {
        let name = e["name"].as_str().unwrap_or("?").to_owned();
        for g in e["paired"]["groups"].as_array().into_iter().flatten() {
            let number = g["number"].as_u64().unwrap_or(0) as usize;
            let mut members = Vec::new();
            for m in g["members"].as_array().into_iter().flatten() {
                let text = m["id"].as_str().ok_or_else(|| bad(format!("{name}: a group member without an `id`")))?;
                let id: StimulusId = text.parse().map_err(|e: study::ids::IdError| bad(format!("{name}: {e}")))?;
                let cell = id.cell().label(id.view);
                let tracer = id.method.is_none_or(|t| t.kind == Method::Tracer);
                let row = (cell == sweep.cell && tracer).then(|| level_row(sweep, &rows, id.samples)).flatten();
                members.push(MarkedMember { id, row });
            }
            out.push(MarkedGroup { experiment: name.clone(), number, members });
        }
    }
    Ok(out)
}

/// The gold standard: the tracer at the preset's highest level.
fn gold(sweep: &CostSweep, rows: &[CostRow]) -> Option<CostRow> {
    let a = sweep.levels.iter().enumerate().max_by_key(|(_, (_, s))| *s).map(|(i, _)| i + 1)?;
    level_row(sweep, rows, a as u8)
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.digits$}"))
}

/// `cost.md`.
pub fn markdown(sweep: &CostSweep, groups: &[MarkedGroup], figures: &[String], maps: &[String]) -> String {
    let rows = sweep.rows();
    let mut md = format!(
        "# What accuracy costs: {} {}, preset {}\n\nFrames {:?} of {}x{} per eye ({}), {} repetitions per point, rendered on {}. \
         Errors are against a converged tracer reference on display values (exposure, tone map, sRGB in [0, 1]); \
         FLIP (Andersson et al. 2020, NVIDIA's reference code) of the 8-bit frames as shown, at {:.2} pixels per degree \
         (the design's viewing geometry); the observer's prediction, ColorVideoVDP's quality (Mantiuk et al. 2024) of the frame as shown \
         against the reference on the design's display, in JOD: 10 where people would see no difference, 1 JOD lower where 75 % of them \
         would prefer the reference (`-` for points kept from a sweep measured before it was recorded). \
         Times are wall-clock seconds per frame: median and range over frames and repetitions.\n\n",
        sweep.design,
        sweep.cell,
        sweep.preset,
        sweep.frames,
        sweep.width,
        sweep.height,
        if sweep.stereo { "stereo" } else { "mono" },
        sweep.repetitions,
        sweep.device,
        sweep.pixels_per_degree
    );
    md.push_str(
        "## Reference\n\n| frame | spp | standard error (display RMS) | seconds |\n| --- | --- | --- | --- |\n",
    );
    for r in &sweep.references {
        md.push_str(&format!("| {} | {} | {:.6} | {:.2} |\n", r.frame, r.spp, r.standard_error, r.wall_seconds));
    }
    if let Some((smallest, label)) = sweep.smallest_error() {
        md.push_str(&format!(
            "\nSmallest median error judged: {smallest:.6} ({label}); the reference's standard error is {:.3} of it (must be below 0.1).\n",
            sweep.reference_standard_error() / smallest
        ));
    }
    if let Some(b) = sweep.tracer_exponent() {
        md.push_str(&format!(
            "\nThe tracer's RMSE falls as spp^{b:.2} (least squares over its settings; independent Monte Carlo gives spp^-0.50, drawn on the plots as the 1/sqrt(N) line; the tracer's Owen-scrambled Sobol samples stratify the pixel area and the shutter and converge faster).\n"
        ));
    }
    md.push_str(
        "\n## Table\n\n| setting | renders | seconds (median, range) | GPU s | work units | RMSE (median, range) | PSNR dB | FLIP (median, range) | JOD (median, range) |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in &rows {
        md.push_str(&format!(
            "| {} | {} | {:.4} ({:.4}-{:.4}) | {} | {:.3e} | {:.5} ({:.5}-{:.5}) | {:.2} | {:.5} ({:.5}-{:.5}) | {} |\n",
            r.label(),
            r.renders,
            r.wall_seconds.median,
            r.wall_seconds.min,
            r.wall_seconds.max,
            fmt_opt(r.gpu_seconds, 4),
            r.work_units,
            r.rmse.median,
            r.rmse.min,
            r.rmse.max,
            r.psnr_db,
            r.flip.median,
            r.flip.min,
            r.flip.max,
            r.jod.map_or("-".into(), |j| format!("{:.3} ({:.3}-{:.3})", j.median, j.min, j.max))
        ));
    }
    if rows.iter().any(|r| r.method == Method::Analytic) {
        md.push_str(
            "\nThe analytic method's error on moving frames has a floor that no interval budget or supersampling removes: \
             it shades each visibility interval once, at its temporal midpoint (Gribel et al. 2010), and the floor's interval \
             spans the whole shutter, so the sphere's moving contact shadow is drawn sharp where the tracer smears it. \
             `blurlab bench analytic-accuracy` measures that error in the shadow region per speed (`analysis/analytic/contact-shadow.csv`).\n",
        );
    }
    if let Some(input) = rows.iter().find(|r| r.knob.starts_with("mlaa")).map(|r| r.input_spp) {
        md.push_str(&format!(
            "\nThe `mlaa_*` rows are morphological antialiasing (`--mlaa`): the tracer at {input} spp with every camera sample \
             through its pixel's centre (one visibility sample per pixel: edges alias as a rasterizer's do, the shading is that of \
             {input} samples), filtered by MLAA on its display values. `mlaa_search_distance` runs at the default threshold \
             (0.1), its value 0 being the unfiltered frame; `mlaa_threshold_percent` runs at the default search distance (12 \
             pixels), its value in hundredths of display luminance. They share their input frame's seeds, so differences \
             between them are the filter's; their time includes the render. Set it beside the jittered tracer's row at {input} \
             spp, which antialiases by supersampling.\n"
        ));
    }
    if !groups.is_empty() {
        let gold = gold(sweep, &rows);
        md.push_str(&format!(
            "\n## Perceptually equivalent groups on the curves\n\nMembers in this sweep's cell ({}) are the tracer at their level's samples per pixel; \
             the cheapest is the member with the smallest median time; the saving is against the gold standard {}.\n\n\
             | experiment | group | members (on the curves: seconds / RMSE / FLIP) | cheapest | its seconds, RMSE, FLIP | saves vs gold |\n| --- | --- | --- | --- | --- | --- |\n",
            sweep.cell,
            gold.as_ref().map_or("(not measured)".into(), |g| format!("{} ({:.4} s)", g.label(), g.wall_seconds.median))
        ));
        for g in groups {
            let members: Vec<String> = g
                .members
                .iter()
                .map(|m| match &m.row {
                    Some(r) => format!(
                        "{} ({:.4} s / {:.5} / {:.5})",
                        m.id, r.wall_seconds.median, r.rmse.median, r.flip.median
                    ),
                    None => format!("{} (other cell)", m.id),
                })
                .collect();
            let (cheapest, numbers, saving) = match g.cheapest() {
                Some(m) => {
                    let r = m.row.as_ref().expect("cheapest is on the curves");
                    let saving = gold.as_ref().map(|gd| 1.0 - r.wall_seconds.median / gd.wall_seconds.median);
                    (
                        format!("{} ({})", m.id, r.label()),
                        format!("{:.4} s, {:.5}, {:.5}", r.wall_seconds.median, r.rmse.median, r.flip.median),
                        saving.map_or("-".into(), |s| format!("{:.1} %", s * 100.0)),
                    )
                }
                None => ("-".into(), "no member in this cell".into(), "-".into()),
            };
            md.push_str(&format!(
                "| {} | G{} | {} | {} | {} | {} |\n",
                g.experiment,
                g.number,
                members.join(", "),
                cheapest,
                numbers,
                saving
            ));
        }
    }
    if !figures.is_empty() {
        md.push_str("\n## Plots\n\n");
        for f in figures.iter().filter(|f| f.ends_with(".png")) {
            md.push_str(&format!("![{f}]({f})\n\n"));
        }
    }
    if !maps.is_empty() {
        md.push_str(
            "\n## FLIP error maps\n\nEach knob's coarsest and finest setting (and every lighting model of the marcher), first frame, first repetition: the frame, then its FLIP map (magma: black no error). Reference frames are in `reference/`.\n\n",
        );
        for m in maps.iter().filter(|m| !m.ends_with("-flip.png")) {
            let flip = m.replace(".png", "-flip.png");
            md.push_str(&format!("`{m}`: ![frame]({m}) ![FLIP]({flip})\n\n"));
        }
    }
    md
}

/// Error against time on log-log axes.
#[derive(Clone, Debug)]
pub struct CostFigure {
    /// Title.
    pub title: String,
    /// Y axis label.
    pub y_desc: String,
    /// Curves: label and `(seconds, error)` points.
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
    /// The 1/sqrt(N) reference line's anchor `(seconds, error)`.
    pub slope_anchor: Option<(f64, f64)>,
    /// Group marks: `(group index, label, (seconds, error))`.
    pub marks: Vec<(usize, String, (f64, f64))>,
}

impl Figure for CostFigure {
    fn size(&self) -> (u32, u32) {
        (900, 600)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let err = |e: &dyn std::fmt::Debug| format!("{e:?}");
        let all: Vec<(f64, f64)> = self
            .curves
            .iter()
            .flat_map(|(_, p)| p.iter().copied())
            .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
            .collect();
        if all.is_empty() {
            return Err("no points with positive time and error".into());
        }
        let (t0, t1) = all.iter().fold((f64::INFINITY, 0f64), |a, p| (a.0.min(p.0), a.1.max(p.0)));
        let (e0, e1) = all.iter().fold((f64::INFINITY, 0f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
        let mut chart = log_log_chart(
            root,
            &self.title,
            (t0 / 1.5..t1 * 1.5, "seconds per frame (median)"),
            (e0 / 1.5..e1 * 1.5, self.y_desc.as_str()),
            (&|v| format!("{v:.3}"), &|v| format!("{v:.3}")),
        )?;
        if let Some((ta, ea)) = self.slope_anchor {
            let line: Vec<(f64, f64)> =
                [ta, t1 * 1.4].iter().map(|&t| (t, ea * (ta / t).sqrt())).filter(|p| p.1 >= e0 / 1.5).collect();
            chart
                .draw_series(LineSeries::new(line, BLACK.mix(0.5).stroke_width(1)))
                .map_err(|e| err(&e))?
                .label("1/sqrt(N) (Monte Carlo)")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5)));
        }
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(214, 39, 40),
            RGBColor(44, 160, 44),
            RGBColor(148, 103, 189),
            RGBColor(255, 127, 14),
            RGBColor(140, 86, 75),
            RGBColor(227, 119, 194),
            RGBColor(23, 190, 207),
        ];
        for (i, (label, points)) in self.curves.iter().enumerate() {
            let colour = palette[i % palette.len()];
            let pts: Vec<(f64, f64)> = points.iter().copied().filter(|(t, e)| *t > 0.0 && *e > 0.0).collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(|e| err(&e))?;
        }
        for (g, label, p) in &self.marks {
            let colour = group_colour(*g);
            chart.draw_series([Circle::new(*p, 8, colour.stroke_width(2))]).map_err(|e| err(&e))?;
            chart
                .draw_series([Text::new(
                    label.clone(),
                    (p.0 * 1.08, p.1 * 1.08),
                    ("sans-serif", 12.0).into_font().color(&colour),
                )])
                .map_err(|e| err(&e))?;
        }
        draw_legend(&mut chart)?;
        Ok(())
    }
}

/// The curves of the plots: one per method (the filters at their highest input level).
fn curves(rows: &[CostRow], error: impl Fn(&CostRow) -> f64) -> Vec<(String, Vec<(f64, f64)>)> {
    let mut by: BTreeMap<(Method, &str, u32), Vec<&CostRow>> = BTreeMap::new();
    for r in rows {
        let input = if r.method.curve_input() == CurveInput::Ignored { 0 } else { r.input_spp };
        by.entry((r.method, r.knob.as_str(), input)).or_default().push(r);
    }
    let top_input = |m: Method| by.keys().filter(|k| k.0 == m).map(|k| k.2).max();
    by.iter()
        .filter(|((m, _, input), _)| m.curve_input() != CurveInput::Highest || Some(*input) == top_input(*m))
        .map(|((m, knob, input), rs)| {
            let label = m.curve_label(knob, *input);
            // Along the knob, coarsest first (measured times can be out of order).
            let mut rs = rs.clone();
            rs.sort_by_key(|r| r.value);
            (label, rs.iter().map(|r| (r.wall_seconds.median, error(r))).collect())
        })
        .collect()
}

/// Writes `cost.json`, `cost.csv`, `cost.md` and the plots into `dir`; returns cost.md's path.
pub fn write_cost_report(sweep: &CostSweep, groups: &[MarkedGroup], dir: &Path) -> Result<PathBuf, CostReportError> {
    std::fs::create_dir_all(dir).map_err(|source| CostReportError::Io { path: dir.to_owned(), source })?;
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        study::fsio::write_atomic(&path, bytes).map_err(|source| CostReportError::Io { path, source })
    };
    write("cost.json", serde_json::to_string_pretty(sweep).unwrap_or_default().as_bytes())?;
    write("cost.csv", sweep.csv().as_bytes())?;
    let rows = sweep.rows();
    let tracer_first = rows.iter().find(|r| r.method == Method::Tracer && r.knob == "spp");
    let mut figures = Vec::new();
    for (stem, y_desc, which) in [("cost-rmse", "display RMSE (median)", 0), ("cost-flip", "mean FLIP (median)", 1)] {
        let error = |r: &CostRow| if which == 0 { r.rmse.median } else { r.flip.median };
        let mut marks = Vec::new();
        for g in groups {
            for m in &g.members {
                if let Some(r) = &m.row {
                    marks.push((
                        g.number.saturating_sub(1),
                        format!("G{} {}", g.number, m.id),
                        (r.wall_seconds.median, error(r)),
                    ));
                }
            }
        }
        let fig = CostFigure {
            title: format!("{} {} ({}): {} against time", sweep.design, sweep.cell, sweep.preset, y_desc),
            y_desc: y_desc.to_owned(),
            curves: curves(&rows, error),
            slope_anchor: tracer_first.map(|r| (r.wall_seconds.median, error(r))),
            marks,
        };
        for p in save_figure(&fig, dir, stem)? {
            figures.push(p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
        }
    }
    let mut maps: Vec<String> = std::fs::read_dir(dir.join("maps"))
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| format!("maps/{}", e.file_name().to_string_lossy()))
                .filter(|n| n.ends_with(".png"))
                .collect()
        })
        .unwrap_or_default();
    maps.sort();
    let md = markdown(sweep, groups, &figures, &maps);
    write("cost.md", md.as_bytes())?;
    Ok(dir.join("cost.md"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use study::cost::{COST_FORMAT, CostPoint, CostReference};

    fn sweep() -> CostSweep {
        let mut points = Vec::new();
        for (i, spp) in [1u32, 2, 4, 8, 16].into_iter().enumerate() {
            for rep in 0..3 {
                points.push(CostPoint {
                    method: Method::Tracer,
                    knob: "spp".into(),
                    value: spp,
                    input_spp: spp,
                    frame: 0,
                    repetition: rep,
                    wall_seconds: 0.01 * f64::from(spp),
                    gpu_seconds: None,
                    camera_samples: u64::from(spp),
                    work_units: u64::from(spp),
                    rmse: 0.1 / f64::from(spp).sqrt() * (1.0 + 0.01 * f64::from(rep)),
                    rmse_linear: 0.1,
                    flip: 0.2 / (i as f64 + 1.0),
                    jod: Some(9.0 + 0.1 * i as f64),
                });
            }
        }
        CostSweep {
            format: COST_FORMAT.into(),
            design: "navarro2011".into(),
            design_sha256: "0".into(),
            preset: "quick".into(),
            cell: "M2-S2-T5".into(),
            stereo: false,
            frames: vec![0],
            width: 16,
            height: 9,
            pixels_per_degree: 1.1,
            repetitions: 3,
            levels: vec![("A1".into(), 1), ("A2".into(), 4), ("A3".into(), 8), ("A4".into(), 12), ("A5".into(), 16)],
            device: "cpu: 2 threads".into(),
            references: vec![CostReference { frame: 0, spp: 4096, standard_error: 0.0001, wall_seconds: 1.0 }],
            points,
        }
    }

    #[test]
    fn groups_are_placed_on_the_curves_and_the_report_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let s = sweep();
        let report = serde_json::json!({
            "format": "blurlab-report/1",
            "experiments": [{"name": "mono-3-interactions", "paired": {"groups": [
                {"number": 1, "members": [{"id": "M2-S2-T5-A5"}, {"id": "M2-S2-T5-A3"}, {"id": "M2-S2-T4-A5"}]},
                {"number": 2, "members": [{"id": "M2-S2-T3-A3"}]}
            ]}}]
        });
        std::fs::write(dir.path().join("report.json"), report.to_string()).unwrap();
        let groups = groups_from_report(dir.path(), &s).unwrap();
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members[0].row.as_ref().unwrap().value, 16);
        assert!(groups[0].members[2].row.is_none());
        assert_eq!(groups[0].cheapest().unwrap().id.to_string(), "M2-S2-T5-A3");
        assert!(groups[1].cheapest().is_none());
        let out = dir.path().join("cost");
        let md = write_cost_report(&s, &groups, &out).unwrap();
        let text = std::fs::read_to_string(md).unwrap();
        // A3 is 8 spp (0.08 s) against the gold 16 spp (0.16 s): half the time saved.
        assert!(text.contains("| mono-3-interactions | G1 |") && text.contains("50.0 %"), "{text}");
        assert!(text.contains("M2-S2-T4-A5 (other cell)"), "{text}");
        assert!(text.contains("| tracer spp=16 | 3 |") && text.contains("| 9.400 (9.400-9.400) |"), "{text}");
        for f in ["cost.csv", "cost.json", "cost-rmse.png", "cost-rmse.svg", "cost-flip.png", "cost-flip.svg"] {
            assert!(out.join(f).exists(), "{f}");
        }
        std::fs::write(dir.path().join("bad.json"), "{\"format\": \"x\"}").unwrap();
        let e = groups_from_report(&dir.path().join("bad.json"), &s).unwrap_err().to_string();
        assert!(e.contains("field `format`"), "{e}");
    }

    #[test]
    fn mlaa_rows_are_their_own_curve_and_leave_the_tracer_fit_alone() {
        let mut s = sweep();
        let exponent = s.tracer_exponent().unwrap();
        let tracer_point = s.points[0].clone();
        for (d, rmse) in [(0u32, 0.5), (12, 0.4)] {
            s.points.push(CostPoint {
                knob: "mlaa_search_distance".into(),
                value: d,
                input_spp: 16,
                wall_seconds: 0.17,
                rmse,
                ..tracer_point.clone()
            });
        }
        assert_eq!(s.tracer_exponent().unwrap().to_bits(), exponent.to_bits());
        let rows = s.rows();
        let curves = curves(&rows, |r| r.rmse.median);
        let labels: Vec<&str> = curves.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(labels, ["tracer at pixel centres + MLAA (search distance)", "tracer (spp)"]);
        assert_eq!(curves[0].1, vec![(0.17, 0.5), (0.17, 0.4)]);
        let md = markdown(&s, &[], &[], &[]);
        assert!(md.contains("the tracer at 16 spp with every camera sample through its pixel's centre"), "{md}");
        assert!(md.contains("| tracer mlaa_search_distance=12 |"), "{md}");
    }
}
