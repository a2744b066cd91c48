//! Shared by the study programs: a PNG line chart (markers joined by lines, several series,
//! title, axis labels, legend) on logarithmic or linear axes, drawn with `plotters` and
//! Debian's DejaVu Sans (package `fonts-dejavu-core`), so no system font library is needed.
#![allow(dead_code)]

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
pub use plotters::prelude::SeriesLabelPosition;
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
    /// Markers at the points (data), or a plain line (a reference value).
    pub marked: bool,
    /// The markers joined by lines (false: markers alone, see [`Series::points`]).
    pub joined: bool,
    /// The colour's index (default: the series' own place), to pair a data series with its
    /// reference line.
    pub colour: Option<usize>,
}

impl Series {
    /// Data: markers joined by lines.
    pub fn new(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.to_string(),
            points,
            marked: true,
            joined: true,
            colour: None,
        }
    }

    /// Data as markers alone, not joined (e.g. nodal values against a formula's line).
    pub fn points(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            joined: false,
            ..Series::new(label, points)
        }
    }

    /// The same series drawn in colour `index` (of the chart's palette).
    pub fn coloured(self, index: usize) -> Self {
        Series {
            colour: Some(index),
            ..self
        }
    }

    /// A reference line without markers, e.g. a constant between two abscissae.
    pub fn line(label: &str, points: Vec<(f64, f64)>) -> Self {
        Series {
            marked: false,
            ..Series::new(label, points)
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
    /// Where the legend goes (away from the curves).
    pub legend: SeriesLabelPosition,
}

/// Register DejaVu Sans as plotters' "sans-serif" (once per process); exits with a one-line
/// message naming the package to install when the font file is missing. `line_chart` calls
/// it; call it first too, to fail before the runs rather than after.
pub fn register_font() {
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
/// factor on a logarithmic one (whose values must be positive).
fn range(values: impl Iterator<Item = f64>, scale: Scale) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (scale == Scale::Linear || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    assert!(lo <= hi, "plot: no plottable value");
    match scale {
        Scale::Log => {
            let pad = (hi / lo).powf(0.04).max(1.25);
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

/// The ticks of a logarithmic axis on [lo, hi]: labelled at 1, 2, 5 × 10^k (at 10^k only over
/// more than four decades) and grid lines at 1…9 × 10^k (at 10^k over more than six).
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let decades = (hi / lo).log10();
    let ticks = |mantissas: &[f64]| -> Vec<f64> {
        let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| (lo..=hi).contains(v))
            .collect()
    };
    let all: Vec<f64> = (1..10).map(f64::from).collect();
    let labelled = ticks(if decades > 4.0 {
        &[1.0]
    } else {
        &[1.0, 2.0, 5.0]
    });
    let lines = if decades > 6.0 {
        labelled.clone()
    } else {
        ticks(&all)
    };
    (labelled, lines)
}

/// Draw `series` into the PNG file `path` (800 × 560 pixels).
pub fn line_chart(path: &Path, chart: &Chart, series: &[Series]) -> Result<(), String> {
    register_font();
    let points = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) = range(points().map(|p| p.0), chart.x_scale);
    let (y0, y1) = range(points().map(|p| p.1), chart.y_scale);
    let log = |lo: f64, hi: f64| {
        let (labelled, lines) = log_ticks(lo, hi);
        (lo..hi)
            .log_scale()
            .with_key_points(labelled)
            .with_light_points(lines)
    };
    // A linear axis' tick at zero can come out as ±1e−17: labelled 0.
    let zero = |lo: f64, hi: f64, scale| match scale {
        Scale::Linear => 1e-9 * (hi - lo),
        Scale::Log => 0.0,
    };
    let z = (zero(x0, x1, chart.x_scale), zero(y0, y1, chart.y_scale));
    use Scale::*;
    match (chart.x_scale, chart.y_scale) {
        (Linear, Linear) => draw(path, chart, series, x0..x1, y0..y1, z),
        (Linear, Log) => draw(path, chart, series, x0..x1, log(y0, y1), z),
        (Log, Linear) => draw(path, chart, series, log(x0, x1), y0..y1, z),
        (Log, Log) => draw(path, chart, series, log(x0, x1), log(y0, y1), z),
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
    zero: (f64, f64),
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
        .light_line_style(RGBColor(235, 235, 235))
        .max_light_lines(4)
        .x_label_formatter(&|v| short(if v.abs() < zero.0 { 0.0 } else { *v }))
        .y_label_formatter(&|v| short(if v.abs() < zero.1 { 0.0 } else { *v }))
        .draw()?;
    for (k, s) in series.iter().enumerate() {
        let colour = COLOURS[s.colour.unwrap_or(k) % COLOURS.len()];
        let style = ShapeStyle::from(&colour).stroke_width(2);
        if s.joined || !s.marked {
            ctx.draw_series(LineSeries::new(s.points.iter().copied(), style))?
                .label(s.label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], style.stroke_width(2))
                });
        } else {
            // Markers alone: a marker in the legend.
            ctx.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label(s.label.as_str())
                .legend(move |(x, y)| Circle::new((x + 12, y), 4, style.filled()));
        }
        if !s.marked {
            continue;
        }
        // A different marker per series, so the curves stay apart in grey print too.
        let pts = s.points.iter().copied();
        // (markers alone: circles, as in the legend)
        match if s.joined { k % 3 } else { 0 } {
            0 => ctx.draw_series(pts.map(|p| Circle::new(p, 4, style.filled())))?,
            1 => ctx.draw_series(pts.map(|p| TriangleMarker::new(p, 6, style.filled())))?,
            _ => ctx.draw_series(pts.map(|p| Cross::new(p, 5, style)))?,
        };
    }
    ctx.configure_series_labels()
        .position(chart.legend.clone())
        .label_font(("sans-serif", 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// A number in a few characters: plain for moderate magnitudes, else in scientific notation
/// with as few digits as show it (up to 3: a linear axis' 1.2e9 is not 1e9).
fn short(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-2..1e6).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        (0..3)
            .map(|d| format!("{v:.d$e}"))
            .find(|s| s.parse::<f64>().is_ok_and(|w| (w - v).abs() <= 1e-6 * a))
            .unwrap_or_else(|| format!("{v:.3e}"))
    }
}
