//! Shared by the study programs: a PNG line chart (markers joined by lines, several series,
//! title, axis labels, legend) on logarithmic or linear axes, drawn with `plotters` and
//! Debian's DejaVu Sans (package `fonts-dejavu-core`), so no system font library is needed.
#![allow(dead_code)]

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use std::path::Path;

/// The TrueType font of the labels (Debian package `fonts-dejavu-core`).
pub const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// How an axis maps values.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Scale {
    Linear,
    Log,
}

/// One curve: its legend entry and its (x, y) points, drawn in the given order.
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

impl Series {
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.to_string(),
            points,
        }
    }
}

/// What a chart shows besides its series.
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub x_scale: Scale,
    pub y_scale: Scale,
}

/// Register DejaVu Sans as plotters' "sans-serif" (once per process); exits with a one-line
/// message naming the package to install when the font file is missing.
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let bytes = std::fs::read(FONT).unwrap_or_else(|_| {
            eprintln!("plot: font {FONT} is missing: install the Debian package fonts-dejavu-core");
            std::process::exit(1);
        });
        if plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into()))
            .is_err()
        {
            eprintln!("plot: {FONT} is not a valid TrueType font: reinstall fonts-dejavu-core");
            std::process::exit(1);
        }
    });
}

/// The plotted range of some values: padded by 5 % of the span on a linear axis and by a
/// factor on a logarithmic one (whose values must be positive); a single value gets a band.
fn range(values: impl Iterator<Item = f64>, scale: Scale) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (scale == Scale::Linear || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    assert!(lo <= hi, "plot: no plottable value");
    match scale {
        Scale::Log => {
            let pad = (hi / lo).powf(0.05).max(1.5);
            (lo / pad, hi * pad)
        }
        Scale::Linear => {
            let pad = if hi > lo {
                0.05 * (hi - lo)
            } else {
                0.1 * hi.abs().max(1.0)
            };
            (lo - pad, hi + pad)
        }
    }
}

/// Draw `series` into the PNG file `path` (800 × 560 pixels).
pub fn line_chart(path: &Path, chart: &Chart, series: &[Series]) -> Result<(), String> {
    register_font();
    let points = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = range(points().map(|p| p.0), chart.x_scale);
    let (y0, y1) = range(points().map(|p| p.1), chart.y_scale);
    use Scale::*;
    match (chart.x_scale, chart.y_scale) {
        (Linear, Linear) => draw(path, chart, series, x0..x1, y0..y1),
        (Linear, Log) => draw(path, chart, series, x0..x1, (y0..y1).log_scale()),
        (Log, Linear) => draw(path, chart, series, (x0..x1).log_scale(), y0..y1),
        (Log, Log) => draw(
            path,
            chart,
            series,
            (x0..x1).log_scale(),
            (y0..y1).log_scale(),
        ),
    }
    .map_err(|e| format!("plot {}: {e}", path.display()))
}

/// Series styles: colour and marker, in the order of the series.
const COLOURS: [RGBColor; 5] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 90, 200),
    RGBColor(20, 150, 60),
    RGBColor(150, 60, 180),
    RGBColor(220, 130, 0),
];

fn draw<X, Y>(
    path: &Path,
    chart: &Chart,
    series: &[Series],
    x: X,
    y: Y,
) -> Result<(), Box<dyn std::error::Error>>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut ctx = ChartBuilder::on(&root)
        .caption(chart.title, ("sans-serif", 24))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(x, y)?;
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 18))
        .x_label_formatter(&|v| short(*v))
        .y_label_formatter(&|v| short(*v))
        .draw()?;
    for (k, s) in series.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        let style = ShapeStyle::from(&colour).stroke_width(2);
        ctx.draw_series(LineSeries::new(s.points.iter().copied(), style))?
            .label(s.label.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], style.stroke_width(2))
            });
        // A different marker per series, so the curves stay apart in grey print too.
        let pts = s.points.iter().copied();
        match k % 3 {
            0 => ctx.draw_series(pts.map(|p| Circle::new(p, 4, style.filled())))?,
            1 => ctx.draw_series(pts.map(|p| TriangleMarker::new(p, 6, style.filled())))?,
            _ => ctx.draw_series(pts.map(|p| Cross::new(p, 5, style)))?,
        };
    }
    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// A tick label: plain for moderate magnitudes, else in scientific notation.
fn short(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-2..1e5).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}
