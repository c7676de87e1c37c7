//! The report's figures, drawn with plotters into PNG and SVG: votes per stimulus with the
//! significance groups marked, the shutter x sampling grid coloured by group (thesis
//! figures 5.6 and 6.8), the matching accuracy heat map (figure 5.5), preference bars with
//! standard-error bars per factor and segment (figures 5.4 and 6.5), and the Thurstone scale
//! with confidence intervals, the counts of the pairs shown (a heat map with a colour bar,
//! readable at 225 x 225), the observer screening (one point per participant with the
//! threshold line) and what a perfect forecast of vote tables reaches beside the forecasts
//! made. Text uses the Ubuntu Light font bundled by the
//! `epaint_default_fonts` crate (no system fonts). Files are written atomically.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::factors::LevelPreference;

/// Why a figure could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Drawing failed.
    #[error("drawing {name}: {message}")]
    Draw {
        /// Figure name.
        name: String,
        /// Cause.
        message: String,
    },
    /// Writing failed.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

const FONT: &str = "sans-serif";

fn register_font() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        // The bytes are a valid TrueType font shipped with egui; failure would be a packaging bug.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Colours of groups 1, 2, 3, ... (blue, red, green, grey as in the thesis, then more).
pub fn group_colour(g: usize) -> RGBColor {
    const COLOURS: [RGBColor; 8] = [
        RGBColor(52, 101, 164),
        RGBColor(204, 0, 0),
        RGBColor(78, 154, 6),
        RGBColor(136, 138, 133),
        RGBColor(245, 121, 0),
        RGBColor(117, 80, 123),
        RGBColor(193, 125, 17),
        RGBColor(6, 152, 154),
    ];
    COLOURS[g % COLOURS.len()]
}

/// A figure that can draw itself on any plotters backend.
pub trait Figure {
    /// Pixel size.
    fn size(&self) -> (u32, u32);
    /// Draws on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Writes `DIR/STEM.png` and `DIR/STEM.svg`; returns their paths.
pub fn save_figure<F: Figure>(figure: &F, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let (w, h) = figure.size();
    let draw_err = |message: String| PlotError::Draw { name: stem.to_owned(), message };
    let mut pixels = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(err(e)))?;
        figure.draw(&root).map_err(draw_err)?;
        root.present().map_err(|e| draw_err(err(e)))?;
    }
    let mut png = Vec::new();
    {
        use image::ImageEncoder;
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(&pixels, w, h, image::ExtendedColorType::Rgb8)
            .map_err(|e| draw_err(e.to_string()))?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(err(e)))?;
        figure.draw(&root).map_err(draw_err)?;
        root.present().map_err(|e| draw_err(err(e)))?;
    }
    let mut out = Vec::new();
    for (ext, bytes) in [("png", png.as_slice()), ("svg", svg.as_bytes())] {
        let path = dir.join(format!("{stem}.{ext}"));
        study::fsio::write_atomic(&path, bytes).map_err(|source| PlotError::Io { path: path.clone(), source })?;
        out.push(path);
    }
    Ok(out)
}

/// A chart with both axes logarithmic.
pub type LogLogChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;
/// Formats a tick label.
pub type TickFormat<'f> = &'f dyn Fn(&f64) -> String;

/// A log-log chart with its titled, labelled mesh drawn (the cost and accuracy figures):
/// `x` and `y` are the axis ranges, `fmt` formats both axes' tick labels.
pub fn log_log_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    (x, x_desc): (std::ops::Range<f64>, &str),
    (y, y_desc): (std::ops::Range<f64>, &str),
    fmt: (TickFormat<'_>, TickFormat<'_>),
) -> Result<LogLogChart<'a, DB>, String> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 18.0).into_font())
        .margin(14)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x.log_scale(), y.log_scale())
        .map_err(err)?;
    // Plotters puts a tick at every 1..9 x 10^k on a short log axis; labels at all of them
    // run into each other, so only 1, 2 and 5 x 10^k are labelled.
    let (fx, fy) = fmt;
    let x_fmt = |v: &f64| if is_one_two_five(*v) { fx(v) } else { String::new() };
    let y_fmt = |v: &f64| if is_one_two_five(*v) { fy(v) } else { String::new() };
    chart
        .configure_mesh()
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .light_line_style(BLACK.mix(0.04))
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FONT, 13.0))
        .axis_desc_style((FONT, 14.0))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// Whether `v` is 1, 2 or 5 times a power of ten (to a relative 1e-6).
fn is_one_two_five(v: f64) -> bool {
    if !(v > 0.0 && v.is_finite()) {
        return false;
    }
    let mantissa = v / 10f64.powf(v.log10().floor());
    [1.0, 2.0, 5.0, 10.0].iter().any(|m| (mantissa - m).abs() < 1e-6 * m)
}

/// Draws the series' legend of a [`log_log_chart`] in its upper right corner.
pub fn draw_legend<'a, DB: DrawingBackend + 'a>(chart: &mut LogLogChart<'a, DB>) -> Result<(), String> {
    legend_at(chart, SeriesLabelPosition::UpperRight)
}

/// Draws the series' legend of any chart at `position`, on a light box.
fn legend_at<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font((FONT, 12.0))
        .position(position)
        .draw()
        .map_err(err)
}

fn text_style(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

fn centred(size: f64) -> TextStyle<'static> {
    text_style(size).pos(Pos::new(HPos::Center, VPos::Center))
}

/// Votes per stimulus, sorted by votes, bars coloured by their first group, with a bracket
/// per group above the bars.
#[derive(Debug, Clone)]
pub struct VotesFigure {
    /// Title.
    pub title: String,
    /// Labels.
    pub labels: Vec<String>,
    /// Votes.
    pub votes: Vec<u32>,
    /// Groups (indices into labels), most voted first.
    pub groups: Vec<Vec<usize>>,
    /// `ceil(R_c)`, shown in the subtitle.
    pub ceil_rc: Option<u64>,
}

impl VotesFigure {
    fn draw_on<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.labels.len();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| self.votes[b].cmp(&self.votes[a]).then(a.cmp(&b)));
        let position: Vec<usize> = {
            let mut p = vec![0; n];
            for (k, &i) in order.iter().enumerate() {
                p[i] = k;
            }
            p
        };
        let max = f64::from(self.votes.iter().copied().max().unwrap_or(1).max(1));
        let bracket_step = max * 0.08;
        let top = max * 1.08 + bracket_step * self.groups.len() as f64;
        let caption = match self.ceil_rc {
            Some(c) => format!("{} (groups: differences < ceil(Rc) = {c})", self.title),
            None => self.title.clone(),
        };
        let mut chart = ChartBuilder::on(area)
            .caption(caption, text_style(20.0))
            .margin(12)
            .x_label_area_size(10)
            .y_label_area_size(50)
            .build_cartesian_2d(-0.6..n as f64 - 0.4, -max * 0.12..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("votes")
            .label_style(text_style(14.0))
            .axis_desc_style(text_style(15.0))
            .draw()
            .map_err(err)?;
        let first_group = |i: usize| self.groups.iter().position(|g| g.contains(&i));
        for (k, &i) in order.iter().enumerate() {
            let colour = first_group(i).map_or(BLACK.mix(0.4).to_rgba(), |g| group_colour(g).to_rgba());
            let x = k as f64;
            let v = f64::from(self.votes[i]);
            chart.draw_series([Rectangle::new([(x - 0.38, 0.0), (x + 0.38, v)], colour.filled())]).map_err(err)?;
            chart
                .draw_series([Text::new(format!("{}", self.votes[i]), (x, v + max * 0.03), centred(13.0))])
                .map_err(err)?;
            chart.draw_series([Text::new(self.labels[i].clone(), (x, -max * 0.06), centred(13.0))]).map_err(err)?;
        }
        for (g, members) in self.groups.iter().enumerate() {
            let xs: Vec<f64> = members.iter().map(|&i| position[i] as f64).collect();
            let (lo, hi) = (
                xs.iter().copied().fold(f64::INFINITY, f64::min),
                xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            );
            let y = max * 1.08 + bracket_step * (g as f64 + 0.5);
            let style = group_colour(g).stroke_width(3);
            chart
                .draw_series([PathElement::new(
                    vec![
                        (lo - 0.3, y - bracket_step * 0.3),
                        (lo - 0.3, y),
                        (hi + 0.3, y),
                        (hi + 0.3, y - bracket_step * 0.3),
                    ],
                    style,
                )])
                .map_err(err)?;
            chart
                .draw_series([Text::new(
                    format!("G{}", g + 1),
                    (hi + 0.35, y),
                    text_style(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
                )])
                .map_err(err)?;
        }
        Ok(())
    }
}

/// Forecast votes beside published ones: one point per stimulus (labelled), forecast on the
/// horizontal axis, published on the vertical, with the rank correlations in the caption.
#[derive(Debug, Clone)]
pub struct ForecastScatter {
    /// Title.
    pub title: String,
    /// Labels.
    pub labels: Vec<String>,
    /// Forecast (expected) votes.
    pub predicted: Vec<f64>,
    /// Published votes.
    pub published: Vec<f64>,
}

impl Figure for ForecastScatter {
    fn size(&self) -> (u32, u32) {
        (640, 560)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let span = |v: &[f64]| {
            let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            let pad = ((hi - lo) * 0.1).max(1.0);
            (lo - pad)..(hi + pad)
        };
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(18.0))
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d(span(&self.predicted), span(&self.published))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("forecast votes (expected)")
            .y_desc("published votes")
            .label_style(text_style(14.0))
            .axis_desc_style(text_style(15.0))
            .draw()
            .map_err(err)?;
        let (lo, hi) = (span(&self.predicted), span(&self.published));
        let (a, b) = (lo.start.max(hi.start), lo.end.min(hi.end));
        if a < b {
            chart.draw_series([PathElement::new(vec![(a, a), (b, b)], BLACK.mix(0.3).stroke_width(1))]).map_err(err)?;
        }
        let points: Vec<(f64, f64)> = self.predicted.iter().copied().zip(self.published.iter().copied()).collect();
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, POINT_RADIUS, group_colour(0).filled())))
            .map_err(err)?;
        let style = text_style(13.0).pos(Pos::new(HPos::Left, VPos::Top));
        let sizes = self
            .labels
            .iter()
            .map(|l| root.estimate_text_size(l, &style).map_err(err))
            .collect::<Result<Vec<_>, _>>()?;
        let pixels: Vec<(i32, i32)> = points.iter().map(|p| chart.backend_coord(p)).collect();
        let base = root.get_base_pixel();
        let (w, h) = root.dim_in_pixel();
        let area = (base.0, base.1, base.0 + w as i32, base.1 + h as i32);
        for (l, corner) in self.labels.iter().zip(place_labels(&pixels, &sizes, POINT_RADIUS as i32, area)) {
            root.draw(&Text::new(l.clone(), (corner.0 - base.0, corner.1 - base.1), style.clone())).map_err(err)?;
        }
        Ok(())
    }
}

const POINT_RADIUS: u32 = 5;

/// Draws a dashed horizontal line at `y` across `x` (from, to): a dash of `dash.0` every
/// `dash.1`, the last one cut at the end.
fn dashed_line<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    y: f64,
    x: (f64, f64),
    dash: (f64, f64),
    style: ShapeStyle,
) -> Result<(), String> {
    let mut from = x.0;
    while from < x.1 {
        let to = (from + dash.0).min(x.1);
        chart.draw_series([PathElement::new(vec![(from, y), (to, y)], style)]).map_err(err)?;
        from += dash.1;
    }
    Ok(())
}

/// A distribution as [`CeilingFigure`] marks it: (5 %, median, mean, 95 %).
pub type SpreadMarks = (f64, f64, f64, f64);

/// A forecast as [`CeilingFigure`] marks it: the table's index, its Spearman, and the 5-95 %
/// range where the Spearman is a mean over replicate tables.
pub type ForecastMark = (usize, f64, Option<(f64, f64)>);

/// What a perfect forecast of each vote table reaches against the table's own noise
/// (`crate::ceiling`): per table and estimate, the 5-95 % range of its Spearman correlation
/// over replicate tables, a tick at the median and a dot at the mean; the forecasts actually
/// made as crosses; the goal's floor and mean as dashed lines.
#[derive(Debug, Clone)]
pub struct CeilingFigure {
    /// Title.
    pub title: String,
    /// The tables' short names, left to right.
    pub tables: Vec<String>,
    /// Estimates: a name and per table the perfect forecast's Spearman.
    pub perfect: Vec<(String, Vec<SpreadMarks>)>,
    /// Forecasts: a name and, on some tables (index into `tables`), its Spearman: as measured
    /// (no range), or its mean over replicate tables with their 5-95 % range (a forecast made
    /// before any votes, against a hypothesis).
    pub forecasts: Vec<(String, Vec<ForecastMark>)>,
    /// Dashed reference lines: a label and its Spearman (e.g. the goal's floor and mean).
    pub lines: Vec<(String, f64)>,
}

impl Figure for CeilingFigure {
    fn size(&self) -> (u32, u32) {
        ((240 + 160 * self.tables.len() as u32).max(720), 600)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.tables.len();
        let low = self
            .perfect
            .iter()
            .flat_map(|(_, v)| v.iter().map(|p| p.0))
            .chain(self.forecasts.iter().flat_map(|(_, v)| v.iter().map(|p| p.2.map_or(p.1, |r| r.0))))
            .fold(0.0f64, f64::min);
        // Room below the lowest point for the legend, so that it covers no point.
        let data_bottom = (low * 10.0).floor() / 10.0 - 0.1;
        let legend_px = 20.0 * (self.perfect.len() + self.forecasts.len()) as f64 + 16.0;
        let plot_px = f64::from(self.size().1) - 120.0;
        let bottom = data_bottom - (1.08 - data_bottom) * legend_px / (plot_px - legend_px);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(18.0))
            .margin(14)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(-0.6..n as f64 - 0.4, bottom..1.08)
            .map_err(err)?;
        let names = self.tables.clone();
        let label = move |x: &f64| {
            let k = x.round();
            if (x - k).abs() < 1e-9 && k >= 0.0 {
                names.get(k as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n.max(1) * 4 + 1)
            .x_label_formatter(&label)
            .y_label_formatter(&|v: &f64| format!("{:.1}", if v.abs() < 1e-9 { 0.0 } else { *v }))
            .y_desc("Spearman with the table's votes")
            .label_style(text_style(13.0))
            .axis_desc_style(text_style(15.0))
            .draw()
            .map_err(err)?;
        for (name, y) in &self.lines {
            // Twelve dashes per table, the last one whole.
            let dashes = (n * 12).max(1) as f64;
            let period = (n as f64 + 0.2) / dashes;
            let end = -0.6 + (dashes - 0.25) * period;
            dashed_line(&mut chart, *y, (-0.6, end), (0.05, period), BLACK.mix(0.45).stroke_width(1))?;
            chart
                .draw_series([Text::new(
                    name.clone(),
                    (-0.55, *y + 0.015),
                    text_style(12.0).pos(Pos::new(HPos::Left, VPos::Bottom)),
                )])
                .map_err(err)?;
        }
        let estimates = self.perfect.len().max(1) as f64;
        for (e, (name, per_table)) in self.perfect.iter().enumerate() {
            let colour = if e == 0 { group_colour(0) } else { RGBColor(114, 159, 207) };
            let dx = -0.12 * (estimates - 1.0) / 2.0 + 0.12 * e as f64 - 0.1;
            for (k, &(q05, median, _, q95)) in per_table.iter().enumerate() {
                let x = k as f64 + dx;
                chart.draw_series([PathElement::new(vec![(x, q05), (x, q95)], colour.stroke_width(4))]).map_err(err)?;
                chart
                    .draw_series([PathElement::new(
                        vec![(x - 0.05, median), (x + 0.05, median)],
                        colour.stroke_width(2),
                    )])
                    .map_err(err)?;
            }
            chart
                .draw_series(
                    per_table
                        .iter()
                        .enumerate()
                        .map(|(k, p)| Circle::new((k as f64 + dx, p.2), POINT_RADIUS, colour.filled())),
                )
                .map_err(err)?
                .label(name.clone())
                .legend(move |(x, y)| Circle::new((x + 8, y), POINT_RADIUS, colour.filled()));
        }
        for (f, (name, points)) in self.forecasts.iter().enumerate() {
            // The group colours but blue (the estimates') and grey (the lines').
            let c = group_colour([1, 2, 4, 5, 6, 7][f % 6]);
            let dx = 0.2 + 0.07 * f as f64;
            for &(k, _, range) in points {
                if let Some((lo, hi)) = range {
                    let x = k as f64 + dx;
                    chart.draw_series([PathElement::new(vec![(x, lo), (x, hi)], c.stroke_width(1))]).map_err(err)?;
                }
            }
            chart
                .draw_series(points.iter().map(|&(k, r, _)| Cross::new((k as f64 + dx, r), 6, c.stroke_width(3))))
                .map_err(err)?
                .label(name.clone())
                .legend(move |(x, y)| Cross::new((x + 8, y), 6, c.stroke_width(3)));
        }
        legend_at(&mut chart, SeriesLabelPosition::LowerRight)
    }
}

/// Where each point's label goes (top-left corners, in pixels): beside its point (a dot of
/// `radius`), on the first of eight sides where the label stays inside `area` (left, top,
/// right, bottom) and overlaps neither a label placed before it nor another point; where
/// every side is taken, the first side with the least overlap. Stimuli with nearly equal
/// scores sit side by side, and labels drawn always to the upper right would cover each other.
fn place_labels(
    points: &[(i32, i32)],
    sizes: &[(u32, u32)],
    radius: i32,
    area: (i32, i32, i32, i32),
) -> Vec<(i32, i32)> {
    type Rect = (i32, i32, i32, i32);
    let overlap = |a: Rect, b: Rect| -> i64 {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0);
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0);
        i64::from(w) * i64::from(h)
    };
    let gap = radius + 2;
    let dots: Vec<Rect> = points.iter().map(|&(x, y)| (x - radius, y - radius, x + radius, y + radius)).collect();
    let mut placed: Vec<Rect> = Vec::new();
    let mut corners = Vec::with_capacity(points.len());
    for (i, (&(x, y), &(w, h))) in points.iter().zip(sizes).enumerate() {
        let (w, h) = (w as i32, h as i32);
        let candidates = [
            (x + gap, y - h),
            (x + gap, y),
            (x - gap - w, y - h),
            (x - gap - w, y),
            (x - w / 2, y - gap - h),
            (x - w / 2, y + gap),
            (x + gap, y - h / 2),
            (x - gap - w, y - h / 2),
        ];
        let cost = |&(cx, cy): &(i32, i32)| -> i64 {
            let b = (cx, cy, cx + w, cy + h);
            let outside = overlap(b, area) < i64::from(w) * i64::from(h);
            let covered: i64 = placed.iter().map(|&p| overlap(b, p)).sum::<i64>()
                + dots.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, &d)| overlap(b, d)).sum::<i64>();
            if outside { i64::MAX / 2 + covered } else { covered }
        };
        // The first of the least covered sides: a free side where there is one.
        let best = candidates.iter().copied().min_by_key(|c| cost(c)).unwrap_or(candidates[0]);
        placed.push((best.0, best.1, best.0 + w, best.1 + h));
        corners.push(best);
    }
    corners
}

/// Two vote figures side by side (a forecast's groups beside the published ones).
#[derive(Debug, Clone)]
pub struct SideBySideVotes {
    /// Left.
    pub left: VotesFigure,
    /// Right.
    pub right: VotesFigure,
}

impl Figure for SideBySideVotes {
    fn size(&self) -> (u32, u32) {
        let (a, b) = (self.left.size(), self.right.size());
        (a.0 + b.0, a.1.max(b.1))
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (l, r) = root.split_horizontally(self.left.size().0);
        self.left.draw_on(&l)?;
        self.right.draw_on(&r)
    }
}

impl Figure for VotesFigure {
    fn size(&self) -> (u32, u32) {
        ((180 + 70 * self.labels.len() as u32).max(640), 480)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        self.draw_on(root)
    }
}

/// Several figures of one kind side by side (e.g. mono and stereo).
#[derive(Debug, Clone)]
pub struct SideBySide<F> {
    /// The panels, left to right.
    pub panels: Vec<F>,
}

impl Figure for SideBySide<VotesFigure> {
    fn size(&self) -> (u32, u32) {
        let (w, h) = self.panels.iter().map(Figure::size).fold((0, 0), |a, b| (a.0 + b.0, a.1.max(b.1)));
        (w.max(1), h.max(1))
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let areas = root.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(&areas) {
            panel.draw_on(area)?;
        }
        Ok(())
    }
}

/// One cell of the shutter x sampling grid.
#[derive(Debug, Clone)]
pub struct GridCell {
    /// Column (shutter level index, left to right).
    pub column: usize,
    /// Row (sampling level index, bottom to top).
    pub row: usize,
    /// Label, e.g. `T3-A4`.
    pub label: String,
    /// Votes.
    pub votes: u32,
    /// Groups it belongs to (0-based).
    pub groups: Vec<usize>,
}

/// The shutter (columns) x sampling (rows) grid coloured by group, as thesis figures 5.6/6.8.
#[derive(Debug, Clone)]
pub struct GridFigure {
    /// Title.
    pub title: String,
    /// Column titles (shutter levels).
    pub columns: Vec<String>,
    /// Row titles (sampling levels), bottom to top.
    pub rows: Vec<String>,
    /// Cells.
    pub cells: Vec<GridCell>,
}

impl Figure for GridFigure {
    fn size(&self) -> (u32, u32) {
        (160 + 170 * self.columns.len() as u32, 140 + 120 * self.rows.len() as u32)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let (nc, nr) = (self.columns.len() as f64, self.rows.len() as f64);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(20.0))
            .margin(12)
            .build_cartesian_2d(-0.7..nc, -0.5..nr)
            .map_err(err)?;
        for cell in &self.cells {
            let (x, y) = (cell.column as f64, cell.row as f64);
            let colour = cell.groups.first().map_or(WHITE.to_rgba(), |&g| group_colour(g).mix(0.55));
            chart
                .draw_series([Rectangle::new([(x + 0.03, y + 0.03), (x + 0.97, y + 0.97)], colour.filled())])
                .map_err(err)?;
            // Every group the cell belongs to, as a stripe along its bottom edge.
            let k = cell.groups.len().max(1) as f64;
            for (s, &g) in cell.groups.iter().enumerate() {
                let x0 = x + 0.03 + 0.94 * s as f64 / k;
                chart
                    .draw_series([Rectangle::new(
                        [(x0, y + 0.03), (x0 + 0.94 / k, y + 0.18)],
                        group_colour(g).filled(),
                    )])
                    .map_err(err)?;
            }
            let groups = cell.groups.iter().map(|g| format!("G{}", g + 1)).collect::<Vec<_>>().join(" ");
            chart.draw_series([Text::new(cell.label.clone(), (x + 0.5, y + 0.75), centred(16.0))]).map_err(err)?;
            chart
                .draw_series([Text::new(format!("{} votes", cell.votes), (x + 0.5, y + 0.52), centred(14.0))])
                .map_err(err)?;
            chart.draw_series([Text::new(groups, (x + 0.5, y + 0.32), centred(14.0))]).map_err(err)?;
        }
        for (c, title) in self.columns.iter().enumerate() {
            chart.draw_series([Text::new(title.clone(), (c as f64 + 0.5, -0.25), centred(16.0))]).map_err(err)?;
        }
        for (r, title) in self.rows.iter().enumerate() {
            chart.draw_series([Text::new(title.clone(), (-0.35, r as f64 + 0.5), centred(16.0))]).map_err(err)?;
        }
        Ok(())
    }
}

/// A t x t heat map of matching accuracy (darker = less accurate, as thesis figure 5.5).
#[derive(Debug, Clone)]
pub struct HeatmapFigure {
    /// Title.
    pub title: String,
    /// Labels of rows and columns.
    pub labels: Vec<String>,
    /// Accuracy per cell.
    pub values: Vec<Vec<Option<f64>>>,
}

impl Figure for HeatmapFigure {
    fn size(&self) -> (u32, u32) {
        let n = self.labels.len() as u32;
        (140 + 90 * n, 140 + 90 * n)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.labels.len() as f64;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(20.0))
            .margin(12)
            .build_cartesian_2d(-0.8..n, -0.1..n + 0.8)
            .map_err(err)?;
        for (i, row) in self.values.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                // Row i from the top.
                let (x, y) = (j as f64, n - 1.0 - i as f64);
                let (fill, text) = match v {
                    Some(a) => {
                        let g = (40.0 + 215.0 * a.clamp(0.0, 1.0)) as u8;
                        (RGBColor(g, g, g), format!("{:.0} %", a * 100.0))
                    }
                    None => (RGBColor(250, 240, 230), "-".to_owned()),
                };
                chart.draw_series([Rectangle::new([(x, y), (x + 1.0, y + 1.0)], fill.filled())]).map_err(err)?;
                let colour = if v.is_some_and(|a| a < 0.55) { WHITE } else { BLACK };
                chart.draw_series([Text::new(text, (x + 0.5, y + 0.5), centred(15.0).color(&colour))]).map_err(err)?;
            }
        }
        for (k, label) in self.labels.iter().enumerate() {
            chart.draw_series([Text::new(label.clone(), (k as f64 + 0.5, n + 0.35), centred(15.0))]).map_err(err)?;
            chart.draw_series([Text::new(label.clone(), (-0.4, n - 0.5 - k as f64), centred(15.0))]).map_err(err)?;
        }
        Ok(())
    }
}

/// Preference bars with standard-error bars: for every factor level pair, one pair of bars
/// (first level, second level) per series (segments, or mono and stereo).
#[derive(Debug, Clone)]
pub struct PreferenceFigure {
    /// Title.
    pub title: String,
    /// Series name and its preferences.
    pub series: Vec<(String, Vec<LevelPreference>)>,
}

impl Figure for PreferenceFigure {
    fn size(&self) -> (u32, u32) {
        let pairs = self.series.first().map_or(1, |s| s.1.len()) as u32;
        ((200 + pairs * self.series.len() as u32 * 110).max(640), 520)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let Some((_, first)) = self.series.first() else { return Ok(()) };
        let ns = self.series.len() as f64;
        let width = first.len() as f64 * (ns + 0.6);
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(20.0))
            .margin(12)
            .y_label_area_size(55)
            .build_cartesian_2d(-0.4..width, -0.2..1.08)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("share of trials preferring")
            .y_label_formatter(&|y| if *y < 0.0 { String::new() } else { format!("{:.0} %", y * 100.0) })
            .label_style(text_style(14.0))
            .axis_desc_style(text_style(15.0))
            .draw()
            .map_err(err)?;
        chart
            .draw_series([PathElement::new(vec![(-0.4, 0.5), (width, 0.5)], BLACK.mix(0.5).stroke_width(1))])
            .map_err(err)?;
        let colours = [RGBColor(52, 101, 164), RGBColor(245, 121, 0)];
        for (p, pref) in first.iter().enumerate() {
            let base = p as f64 * (ns + 0.6);
            for (s, (name, prefs)) in self.series.iter().enumerate() {
                let Some(q) = prefs.iter().find(|q| q.level_a == pref.level_a && q.level_b == pref.level_b) else {
                    continue;
                };
                let x = base + s as f64;
                for (k, share) in [q.p_a, q.p_b].into_iter().enumerate() {
                    if !share.is_finite() {
                        continue;
                    }
                    let x0 = x + k as f64 * 0.45;
                    chart
                        .draw_series([Rectangle::new([(x0, 0.0), (x0 + 0.42, share)], colours[k].filled())])
                        .map_err(err)?;
                    let xc = x0 + 0.21;
                    chart
                        .draw_series([PathElement::new(
                            vec![(xc, (share - q.se).max(0.0)), (xc, (share + q.se).min(1.0))],
                            BLACK.stroke_width(2),
                        )])
                        .map_err(err)?;
                    let level = if k == 0 { &q.level_a } else { &q.level_b };
                    chart
                        .draw_series([Text::new(level.clone(), (xc, (share + q.se).min(1.0) + 0.035), centred(12.0))])
                        .map_err(err)?;
                }
                chart.draw_series([Text::new(name.clone(), (x + 0.43, -0.06), centred(12.0))]).map_err(err)?;
            }
            let star = if pref.p_value < 0.05 { " *" } else { "" };
            chart
                .draw_series([Text::new(
                    format!("{} vs {}{star}", pref.level_a, pref.level_b),
                    (base + ns / 2.0 - 0.05, -0.14),
                    centred(15.0),
                )])
                .map_err(err)?;
        }
        Ok(())
    }
}

/// Thurstone scale values with confidence intervals, sorted by value.
#[derive(Debug, Clone)]
pub struct ScaleFigure {
    /// Title.
    pub title: String,
    /// Labels.
    pub labels: Vec<String>,
    /// Scores.
    pub scores: Vec<f64>,
    /// Lower interval ends (may be empty).
    pub lower: Vec<f64>,
    /// Upper interval ends (may be empty).
    pub upper: Vec<f64>,
}

impl ScaleFigure {
    /// Pixels per stimulus: room for a label each up to 30 stimuli, else narrow columns.
    fn column(&self) -> u32 {
        if self.labels.len() <= 30 { 70 } else { 8 }
    }
}

impl Figure for ScaleFigure {
    fn size(&self) -> (u32, u32) {
        let n = self.labels.len() as u32;
        ((180 + self.column() * n).max(640), if n <= 30 { 460 } else { 560 })
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.labels.len();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| self.scores[b].total_cmp(&self.scores[a]));
        let all: Vec<f64> =
            self.scores.iter().chain(&self.lower).chain(&self.upper).copied().filter(|v| v.is_finite()).collect();
        let lo = all.iter().copied().fold(0.0_f64, f64::min) - 0.3;
        let hi = all.iter().copied().fold(0.0_f64, f64::max) + 0.3;
        let pad = (hi - lo) * 0.1;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(20.0))
            .margin(12)
            .y_label_area_size(55)
            .x_label_area_size(if n <= 30 { 0 } else { 100 })
            .build_cartesian_2d(-0.6..n as f64 - 0.4, lo - pad..hi)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("quality (JOD, mean 0)")
            .label_style(text_style(14.0))
            .axis_desc_style(text_style(15.0))
            .draw()
            .map_err(err)?;
        for (k, &i) in order.iter().enumerate() {
            let x = k as f64;
            if let (Some(&l), Some(&u)) = (self.lower.get(i), self.upper.get(i)) {
                chart.draw_series([PathElement::new(vec![(x, l), (x, u)], BLACK.stroke_width(2))]).map_err(err)?;
                for y in [l, u] {
                    chart
                        .draw_series([PathElement::new(vec![(x - 0.12, y), (x + 0.12, y)], BLACK.stroke_width(2))])
                        .map_err(err)?;
                }
            }
            let radius = if n <= 30 { 6 } else { 3 };
            chart.draw_series([Circle::new((x, self.scores[i]), radius, group_colour(0).filled())]).map_err(err)?;
            if n <= 30 {
                chart
                    .draw_series([Text::new(self.labels[i].clone(), (x, lo - pad * 0.5), centred(13.0))])
                    .map_err(err)?;
            } else if k % n.div_ceil(60) == 0 {
                // Every k-th label, rotated below the axis (sorted by value, best first).
                let (px, py) = chart.backend_coord(&(x, lo - pad));
                root.draw(&Text::new(
                    self.labels[i].clone(),
                    (px, py + 4),
                    text_style(10.0).transform(FontTransform::Rotate90).pos(Pos::new(HPos::Left, VPos::Center)),
                ))
                .map_err(err)?;
            }
        }
        Ok(())
    }
}

/// A colour on a perceptually ordered ramp (viridis, by its 5 anchor colours), `v` in [0, 1].
pub fn ramp_colour(v: f64) -> RGBColor {
    const ANCHORS: [(f64, f64, f64); 5] =
        [(68.0, 1.0, 84.0), (59.0, 82.0, 139.0), (33.0, 145.0, 140.0), (94.0, 201.0, 98.0), (253.0, 231.0, 37.0)];
    let x = if v.is_finite() { v.clamp(0.0, 1.0) * 4.0 } else { 0.0 };
    let k = (x.floor() as usize).min(3);
    let f = x - k as f64;
    let (a, b) = (ANCHORS[k], ANCHORS[k + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// How many times each pair was shown: a symmetric `t x t` heat map, light grey where a pair
/// was never shown, a colour bar on the right. Labels name every stimulus up to 40 of them,
/// else every k-th (no per-cell numbers).
#[derive(Debug, Clone)]
pub struct PairCountFigure {
    /// Title.
    pub title: String,
    /// Labels of rows and columns.
    pub labels: Vec<String>,
    /// Times shown per pair (symmetric).
    pub counts: Vec<Vec<u32>>,
}

impl PairCountFigure {
    fn cell(&self) -> u32 {
        (900 / self.labels.len().max(1) as u32).clamp(3, 40)
    }
}

impl Figure for PairCountFigure {
    fn size(&self) -> (u32, u32) {
        let side = self.cell() * self.labels.len() as u32;
        (side + 330, side + 200)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.labels.len();
        let cell = self.cell() as i32;
        let side = cell * n as i32;
        let (x0, y0) = (150, 60);
        let max = self.counts.iter().flatten().copied().max().unwrap_or(0).max(1);
        let shown = self.counts.iter().flatten().filter(|&&c| c > 0).count() / 2;
        let pairs = n * n.saturating_sub(1) / 2;
        root.draw(&Text::new(format!("{} ({shown} of {pairs} pairs shown)", self.title), (x0, 18), text_style(20.0)))
            .map_err(err)?;
        root.draw(&Rectangle::new([(x0, y0), (x0 + side, y0 + side)], RGBColor(235, 235, 235).filled()))
            .map_err(err)?;
        for (i, row) in self.counts.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                if c == 0 {
                    continue;
                }
                let v = f64::from(c) / f64::from(max);
                let (x, y) = (x0 + cell * j as i32, y0 + cell * i as i32);
                root.draw(&Rectangle::new([(x, y), (x + cell, y + cell)], ramp_colour(v).filled())).map_err(err)?;
            }
        }
        root.draw(&Rectangle::new([(x0, y0), (x0 + side, y0 + side)], BLACK.stroke_width(1))).map_err(err)?;
        let step = n.div_ceil(40).max(1);
        let size = if n <= 20 { 13.0 } else { 11.0 };
        for k in (0..n).step_by(step) {
            let centre = x0 + cell * k as i32 + cell / 2;
            root.draw(&Text::new(
                self.labels[k].clone(),
                (x0 - 6, y0 + cell * k as i32 + cell / 2),
                text_style(size).pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(err)?;
            root.draw(&Text::new(
                self.labels[k].clone(),
                (centre, y0 + side + 6),
                text_style(size).transform(FontTransform::Rotate90).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(err)?;
        }
        // Colour bar.
        let (bx, bw) = (x0 + side + 40, 24);
        let steps = 100;
        for k in 0..steps {
            let v0 = f64::from(k) / f64::from(steps);
            let ya = y0 + side - (f64::from(side) * v0) as i32;
            let yb = y0 + side - (f64::from(side) * (v0 + 1.0 / f64::from(steps))) as i32;
            // One pixel of overlap so rounding leaves no gaps.
            root.draw(&Rectangle::new(
                [(bx, yb - 1), (bx + bw, ya)],
                ramp_colour(v0 + 0.5 / f64::from(steps)).filled(),
            ))
            .map_err(err)?;
        }
        root.draw(&Rectangle::new([(bx, y0), (bx + bw, y0 + side)], BLACK.stroke_width(1))).map_err(err)?;
        let ticks = max.min(5);
        for k in 0..=ticks {
            let value = (f64::from(max) * f64::from(k) / f64::from(ticks)).round();
            let y = y0 + side - (f64::from(side) * value / f64::from(max)) as i32;
            root.draw(&PathElement::new(vec![(bx + bw, y), (bx + bw + 5, y)], BLACK.stroke_width(1))).map_err(err)?;
            root.draw(&Text::new(
                format!("{value:.0}"),
                (bx + bw + 8, y),
                text_style(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(err)?;
        }
        root.draw(&Text::new("times shown", (bx - 4, y0 - 30), text_style(13.0))).map_err(err)?;
        root.draw(&Rectangle::new([(bx, y0 + side + 20), (bx + bw, y0 + side + 36)], RGBColor(235, 235, 235).filled()))
            .map_err(err)?;
        root.draw(&Text::new(
            "never",
            (bx + bw + 8, y0 + side + 28),
            text_style(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(err)?;
        Ok(())
    }
}

/// Observer screening: each participant's mean log-10 likelihood per trial under the scale
/// fitted without them (sorted, lowest first), the flagging threshold as a dashed red line,
/// flagged participants in red.
#[derive(Debug, Clone)]
pub struct ScreeningFigure {
    /// Title.
    pub title: String,
    /// Participant codes.
    pub participants: Vec<String>,
    /// Their statistic.
    pub values: Vec<f64>,
    /// Whether each is flagged.
    pub flagged: Vec<bool>,
    /// Values below this are flagged.
    pub threshold: f64,
    /// First quartile (drawn as a grey line).
    pub q1: f64,
}

impl Figure for ScreeningFigure {
    fn size(&self) -> (u32, u32) {
        ((220 + 36 * self.participants.len() as u32).max(640), 480)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let n = self.participants.len();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| self.values[a].total_cmp(&self.values[b]));
        let finite: Vec<f64> =
            self.values.iter().copied().chain([self.threshold, self.q1]).filter(|v| v.is_finite()).collect();
        let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > lo { (lo, hi) } else { (-1.0, 0.0) };
        let pad = (hi - lo) * 0.08;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, text_style(18.0))
            .margin(12)
            .x_label_area_size(60)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.6..n as f64 - 0.4, lo - pad..hi + 4.0 * pad)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("mean log10 likelihood per trial")
            .y_label_formatter(&|v| if v.abs() < 1e-9 { "0.00".to_owned() } else { format!("{v:.2}") })
            .label_style(text_style(13.0))
            .axis_desc_style(text_style(14.0))
            .draw()
            .map_err(err)?;
        let x_range = (-0.6, n as f64 - 0.4);
        if self.q1.is_finite() {
            chart
                .draw_series([PathElement::new(
                    vec![(x_range.0, self.q1), (x_range.1, self.q1)],
                    BLACK.mix(0.6).stroke_width(1),
                )])
                .map_err(err)?;
        }
        if self.threshold.is_finite() {
            dashed_line(&mut chart, self.threshold, x_range, (0.25, 0.4), RGBColor(204, 0, 0).stroke_width(2))?;
            // The legend sits top left, above the lowest (leftmost) participants.
            chart
                .draw_series([Text::new(
                    format!(
                        "dashed red: threshold Q1 - {} IQR (flagged below, in red); grey: first quartile Q1",
                        crate::screening::OUTLIER_DISTANCE
                    ),
                    (x_range.0 + 0.2, hi + 3.0 * pad),
                    text_style(13.0).pos(Pos::new(HPos::Left, VPos::Center)),
                )])
                .map_err(err)?;
        }
        for (k, &i) in order.iter().enumerate() {
            let x = k as f64;
            let v = self.values[i];
            if !v.is_finite() {
                continue;
            }
            let colour = if self.flagged[i] { RGBColor(204, 0, 0) } else { group_colour(0) };
            chart
                .draw_series([PathElement::new(vec![(x, lo - pad), (x, v)], colour.mix(0.35).stroke_width(2))])
                .map_err(err)?;
            chart.draw_series([Circle::new((x, v), 6, colour.filled())]).map_err(err)?;
        }
        for (k, &i) in order.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(k as f64, lo - pad));
            root.draw(&Text::new(
                self.participants[i].clone(),
                (px, py + 6),
                text_style(12.0).transform(FontTransform::Rotate90).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(err)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_of_neighbouring_points_do_not_cover_each_other() {
        // Two stimuli 15 px apart on one line (6.6.2's T5-A4 and T5-A5) and one far away.
        let points = [(300, 400), (315, 400), (100, 100)];
        let sizes = [(40, 14), (40, 14), (40, 14)];
        let corners = place_labels(&points, &sizes, 5, (0, 0, 640, 560));
        let boxes: Vec<_> =
            corners.iter().zip(&sizes).map(|(&(x, y), &(w, h))| (x, y, x + w as i32, y + h as i32)).collect();
        let disjoint =
            |a: (i32, i32, i32, i32), b: (i32, i32, i32, i32)| a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1;
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                assert!(disjoint(boxes[i], boxes[j]), "{:?} and {:?} overlap", boxes[i], boxes[j]);
            }
            for (j, &(x, y)) in points.iter().enumerate() {
                if i != j {
                    assert!(disjoint(boxes[i], (x - 5, y - 5, x + 5, y + 5)), "label {i} covers point {j}");
                }
            }
        }
        // A lone point keeps the usual place: above and to the right.
        assert_eq!(corners[2], (107, 86));
        // A point at the right edge puts its label on its left, inside the figure.
        let edge = place_labels(&[(630, 300)], &[(40, 14)], 5, (0, 0, 640, 560));
        assert_eq!(edge[0], (630 - 7 - 40, 286));
    }

    #[test]
    fn log_axes_label_one_two_five_only() {
        for v in [1.0, 0.2, 0.05, 500.0, 0.001, 0.010_000_000_000_000_002] {
            assert!(is_one_two_five(v), "{v}");
        }
        for v in [0.03, 0.07, 3.0, 0.0, -1.0, f64::NAN, 0.15] {
            assert!(!is_one_two_five(v), "{v}");
        }
    }
}
