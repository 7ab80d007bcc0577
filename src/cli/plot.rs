//! Line and scatter charts for the benchmark commands, drawn with
//! `plotters` into an RGB buffer and written as PNG through the golden
//! model's atomic writer.
//!
//! Text uses DejaVu Sans embedded from the `dejavu` crate and registered
//! with plotters' `ab_glyph` renderer, so plots draw the same on machines
//! with no system fonts (CI containers).

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, Result};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use super::method::MethodArg;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A solid line through the points, with a marker at each.
    LinePoints,
    /// A solid line without markers.
    Line,
    /// A dashed line (models, bounds).
    Dashed,
    /// Markers only.
    Points,
}

/// One labelled series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The points, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
    /// Line, dashed line or markers.
    pub kind: Kind,
}

impl Series {
    /// A series with the colour its label's method has in every plot.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, kind: Kind) -> Series {
        let label = label.into();
        Series {
            color: color_for(&label),
            label,
            points,
            kind,
        }
    }

    /// The same series in another colour.
    pub fn with_color(mut self, c: RGBColor) -> Series {
        self.color = c;
        self
    }
}

/// One chart: axes, title and series.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Caption above the chart.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// Logarithmic horizontal axis.
    pub x_log: bool,
    /// Logarithmic vertical axis.
    pub y_log: bool,
    /// The data.
    pub series: Vec<Series>,
}

/// A fixed colour per method name, so a method looks the same in every
/// plot; other labels take the palette in order of a hash of their name.
pub fn color_for(label: &str) -> RGBColor {
    let base = label.split([' ', ':', '(', ',']).next().unwrap_or(label);
    match MethodArg::parse(base) {
        Some(MethodArg::Reference) => RGBColor(0, 0, 0),
        Some(MethodArg::Er) => RGBColor(214, 39, 40),
        Some(MethodArg::ErFtb) => RGBColor(255, 127, 14),
        Some(MethodArg::Under) => RGBColor(44, 160, 44),
        Some(MethodArg::Over) => RGBColor(31, 119, 180),
        Some(MethodArg::Box) => RGBColor(148, 103, 189),
        Some(MethodArg::Mipmap) => RGBColor(0, 128, 128),
        Some(MethodArg::ShearWarp) => RGBColor(128, 128, 0),
        Some(MethodArg::Pipeline) => RGBColor(140, 86, 75),
        Some(MethodArg::PipelineFtb) | None => {
            const PALETTE: [RGBColor; 8] = [
                RGBColor(23, 190, 207),
                RGBColor(227, 119, 194),
                RGBColor(188, 189, 34),
                RGBColor(127, 127, 127),
                RGBColor(31, 119, 180),
                RGBColor(214, 39, 40),
                RGBColor(44, 160, 44),
                RGBColor(255, 127, 14),
            ];
            let h = label
                .bytes()
                .fold(5381u32, |h, b| h.wrapping_mul(33) ^ u32::from(b));
            PALETTE[h as usize % PALETTE.len()]
        }
    }
}

/// Registers the embedded font once per process under plotters' default
/// family name, so every `("sans-serif", size)` text style finds it.
fn register_font() -> Result<()> {
    static LOADED: OnceLock<bool> = OnceLock::new();
    let ok = *LOADED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the embedded DejaVu Sans font does not load"))
    }
}

/// Writes `charts` side by side (one row) as a PNG of `size` pixels per chart.
pub fn write_charts(path: &Path, charts: &[Chart], size: (u32, u32)) -> Result<()> {
    register_font()?;
    let n = charts.len().max(1) as u32;
    let (w, h) = (size.0 * n, size.1);
    let mut buf = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let areas = root.split_evenly((1, n as usize));
        for (chart, area) in charts.iter().zip(&areas) {
            draw_chart(area, chart)?;
        }
        root.present().map_err(plot_err)?;
    }
    golden::image::write_rgb_png(path, w as usize, h as usize, &buf)?;
    Ok(())
}

/// Writes one chart as a PNG.
pub fn write_chart(path: &Path, chart: &Chart, size: (u32, u32)) -> Result<()> {
    write_charts(path, std::slice::from_ref(chart), size)
}

fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing a plot: {e}")
}

/// The data range of one axis (positive values only on a log axis), padded.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { 0.1..10.0 } else { 0.0..1.0 };
    }
    if log {
        // Whole decades at least a factor 1.5 beyond the data, so the
        // extreme points do not sit on the frame.
        let l = (lo / 1.5).log10().floor();
        let h = (hi * 1.5).log10().ceil();
        10f64.powf(l)..10f64.powf(h.max(l + 1.0))
    } else if hi - lo < 1e-12 {
        (lo - 1.0)..(hi + 1.0)
    } else {
        let pad = (hi - lo) * 0.05;
        (if lo >= 0.0 && lo - pad < 0.0 {
            0.0
        } else {
            lo - pad
        })..(hi + pad)
    }
}

fn draw_chart(area: &DrawingArea<BitMapBackend<'_>, Shift>, c: &Chart) -> Result<()> {
    let keep = |v: f64, log: bool| v.is_finite() && (!log || v > 0.0);
    let xs = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = c.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let xr = axis_range(xs, c.x_log);
    let mut yr = axis_range(ys, c.y_log);
    // A little headroom above the data, so the legend has a corner to sit in.
    if c.y_log {
        yr.end *= 10f64.powf(((yr.end / yr.start).log10() * 0.12).max(0.3));
    } else {
        yr.end += (yr.end - yr.start) * 0.12;
    }
    let series: Vec<Series> = c
        .series
        .iter()
        .map(|s| Series {
            points: s
                .points
                .iter()
                .copied()
                .filter(|&(x, y)| keep(x, c.x_log) && keep(y, c.y_log))
                .collect(),
            ..s.clone()
        })
        .collect();
    let corner = legend_corner(&series, &xr, &yr, c.x_log, c.y_log);
    match (c.x_log, c.y_log) {
        (false, false) => draw_in(area, c, &series, corner, lin(xr), lin(yr)),
        (true, false) => draw_in(area, c, &series, corner, log(xr), lin(yr)),
        (false, true) => draw_in(area, c, &series, corner, lin(xr), log(yr)),
        (true, true) => draw_in(area, c, &series, corner, log(xr), log(yr)),
    }
}

/// The corner of the plot the data crosses least (lines sampled along
/// their segments), for the legend; the upper right on ties.
fn legend_corner(
    series: &[Series],
    xr: &Range<f64>,
    yr: &Range<f64>,
    x_log: bool,
    y_log: bool,
) -> SeriesLabelPosition {
    let unit = |v: f64, r: &Range<f64>, log: bool| {
        if log {
            (v.log10() - r.start.log10()) / (r.end.log10() - r.start.log10())
        } else {
            (v - r.start) / (r.end - r.start)
        }
    };
    // Legend boxes are about 40% wide; their height grows with the entries.
    let h = (0.07 * series.len() as f64 + 0.04).min(0.9);
    let mut counts = [0usize; 4]; // upper right, upper left, lower right, lower left
    let mut count = |u: f64, v: f64| {
        let right = u > 0.6;
        let left = u < 0.4;
        let upper = v > 1.0 - h;
        let lower = v < h;
        for (k, hit) in [right && upper, left && upper, right && lower, left && lower]
            .into_iter()
            .enumerate()
        {
            counts[k] += usize::from(hit);
        }
    };
    for s in series {
        let p: Vec<(f64, f64)> = s
            .points
            .iter()
            .map(|&(x, y)| (unit(x, xr, x_log), unit(y, yr, y_log)))
            .collect();
        for &(u, v) in &p {
            count(u, v);
        }
        if s.kind != Kind::Points {
            for w in p.windows(2) {
                for k in 1..16 {
                    let f = k as f64 / 16.0;
                    count(
                        w[0].0 + (w[1].0 - w[0].0) * f,
                        w[0].1 + (w[1].1 - w[0].1) * f,
                    );
                }
            }
        }
    }
    let best = (0..4).min_by_key(|&k| (counts[k], k)).unwrap_or(0);
    [
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::UpperLeft,
        SeriesLabelPosition::LowerRight,
        SeriesLabelPosition::LowerLeft,
    ][best]
        .clone()
}

fn lin(r: Range<f64>) -> RangedCoordf64 {
    r.into()
}

fn log(r: Range<f64>) -> LogCoord<f64> {
    r.log_scale().into()
}

/// Tick labels: plain numbers, without float noise.
fn tick(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e6).contains(&a) {
        format!("{v:.0e}")
    } else if a >= 100.0 || (v.fract() == 0.0) {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn draw_in<X, Y>(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    c: &Chart,
    series: &[Series],
    corner: SeriesLabelPosition,
    x: X,
    y: Y,
) -> Result<()>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .caption(&c.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(x, y)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .x_labels(8)
        .y_labels(10)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
        .map_err(plot_err)?;
    for s in series {
        let style = ShapeStyle::from(&s.color).stroke_width(2);
        let color = s.color;
        let pts = s.points.clone();
        let anno = match s.kind {
            Kind::Line => chart
                .draw_series(LineSeries::new(pts, style))
                .map_err(plot_err)?,
            Kind::LinePoints => {
                chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(plot_err)?;
                chart
                    .draw_series(LineSeries::new(pts, style))
                    .map_err(plot_err)?
            }
            Kind::Dashed => chart
                .draw_series(DashedLineSeries::new(pts, 8, 5, style))
                .map_err(plot_err)?,
            Kind::Points => chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
                .map_err(plot_err)?,
        };
        match s.kind {
            Kind::Points => anno
                .label(s.label.clone())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled())),
            Kind::Dashed => anno.label(s.label.clone()).legend(move |(x, y)| {
                PathElement::new(
                    vec![(x, y), (x + 6, y)],
                    ShapeStyle::from(&color).stroke_width(2),
                )
            }),
            _ => anno.label(s.label.clone()).legend(move |(x, y)| {
                PathElement::new(
                    vec![(x, y), (x + 20, y)],
                    ShapeStyle::from(&color).stroke_width(2),
                )
            }),
        };
    }
    chart
        .configure_series_labels()
        .position(corner)
        .label_font(("sans-serif", 13))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ranges_cover_whole_decades() {
        let r = axis_range([2.0, 300.0, -1.0, 0.0].into_iter(), true);
        assert_eq!(r, 1.0..1000.0);
        let r = axis_range([0.0, 10.0].into_iter(), false);
        assert!(r.start == 0.0 && r.end > 10.0);
        assert_eq!(axis_range(std::iter::empty(), true), 0.1..10.0);
    }

    #[test]
    fn ticks_are_plain() {
        assert_eq!(tick(&0.5), "0.5");
        assert_eq!(tick(&100.0), "100");
        assert_eq!(tick(&1e7), "1e7");
        assert_eq!(tick(&0.25000000001), "0.25");
    }
}
