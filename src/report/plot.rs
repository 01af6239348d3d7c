//! The report's plots: scatter and line charts as SVG, drawn by `plotters`
//! (SVG backend only: text goes into the SVG as `<text>`, so no system fonts
//! are needed), written atomically.

use std::path::Path;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use crate::error::{Result, VoxkitError};

/// One named set of points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// `(x, y)` points; non-finite ones (and non-positive ones on a log
    /// axis) are left out of the plot.
    pub points: Vec<(f64, f64)>,
    /// Join the points (sorted by x) with a line.
    pub line: bool,
    /// Draw the markers hollow (a variant of a neighbouring series).
    pub hollow: bool,
}

impl Series {
    /// Markers only, filled.
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            name: name.into(),
            points,
            line: false,
            hollow: false,
        }
    }

    /// Markers joined by a line.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            line: true,
            ..Series::points(name, points)
        }
    }
}

/// A chart: title, axes and series; optionally a highlighted front.
#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    /// Caption.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The series.
    pub series: Vec<Series>,
    /// Points drawn as a thick black line on top (e.g. a Pareto front).
    pub front: Option<Series>,
}

const WIDTH: u32 = 900;
const HEIGHT: u32 = 560;

/// Points of `chart` that can be drawn, per series (finite; positive on log axes).
fn drawable(chart: &Chart, s: &Series) -> Vec<(f64, f64)> {
    s.points
        .iter()
        .copied()
        .filter(|&(x, y)| {
            x.is_finite() && y.is_finite() && (!chart.log_x || x > 0.0) && (!chart.log_y || y > 0.0)
        })
        .collect()
}

/// An axis range covering `values` with a margin; a sensible range when
/// they are all equal or empty.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (0.1, 10.0) } else { (0.0, 1.0) };
    }
    if log {
        let (l, h) = (lo.log10(), hi.log10());
        let pad = ((h - l) * 0.08).max(0.15);
        (10f64.powf(l - pad), 10f64.powf(h + pad))
    } else if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.5 };
        let lo = if lo >= 0.0 {
            (lo - pad).max(0.0)
        } else {
            lo - pad
        };
        (lo, hi + pad)
    } else {
        let pad = (hi - lo) * 0.08;
        let lo = if lo >= 0.0 {
            (lo - pad).max(0.0)
        } else {
            lo - pad
        };
        (lo, hi + pad)
    }
}

/// Draws `chart` to an SVG document (a string).
pub fn render_svg(chart: &Chart) -> Result<String> {
    // A log axis over less than a decade gets no tick labels from plotters:
    // such an axis is drawn linear instead.
    let mut chart = chart.clone();
    let spans_decade = |log: bool, f: fn(&(f64, f64)) -> f64, chart: &Chart| {
        let vals: Vec<f64> = chart
            .series
            .iter()
            .chain(chart.front.iter())
            .flat_map(|s| drawable(chart, s))
            .map(|p| f(&p))
            .collect();
        let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = vals.iter().copied().fold(0.0, f64::max);
        !log || vals.is_empty() || hi / lo >= 10.0
    };
    chart.log_x = chart.log_x && spans_decade(true, |p| p.0, &chart);
    chart.log_y = chart.log_y && spans_decade(true, |p| p.1, &chart);
    let chart = &chart;
    let all: Vec<(f64, f64)> = chart
        .series
        .iter()
        .chain(chart.front.iter())
        .flat_map(|s| drawable(chart, s))
        .collect();
    let (x0, x1) = axis_range(all.iter().map(|p| p.0), chart.log_x);
    let (y0, y1) = axis_range(all.iter().map(|p| p.1), chart.log_y);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        let r = match (chart.log_x, chart.log_y) {
            (false, false) => draw(&root, chart, x0..x1, y0..y1),
            (true, false) => draw(&root, chart, (x0..x1).log_scale(), y0..y1),
            (false, true) => draw(&root, chart, x0..x1, (y0..y1).log_scale()),
            (true, true) => draw(&root, chart, (x0..x1).log_scale(), (y0..y1).log_scale()),
        };
        r.and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|e| VoxkitError::invalid(format!("plot '{}': {e}", chart.title)))?;
    }
    Ok(svg)
}

/// Draws `chart` and writes it to `path` atomically (overwriting).
pub fn write_svg(chart: &Chart, path: &Path) -> Result<()> {
    let svg = render_svg(chart)?;
    crate::io::atomic_write(path, true, |w| Ok(w.write_all(svg.as_bytes())?))
}

fn draw<DB, X, Y>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
    x: X,
    y: Y,
) -> std::result::Result<(), String>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let mut ctx = ChartBuilder::on(root)
        .caption(&chart.title, ("sans-serif", 20))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)
        .map_err(e)?;
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .x_label_formatter(&|v| short_number(*v))
        .y_label_formatter(&|v| short_number(*v))
        .draw()
        .map_err(e)?;
    for (k, s) in chart.series.iter().enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        let mut pts = drawable(chart, s);
        if s.line {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            ctx.draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))
                .map_err(e)?;
        }
        let style = if s.hollow {
            colour.stroke_width(2)
        } else {
            colour.filled()
        };
        ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 5, style)))
            .map_err(e)?
            .label(&s.name)
            .legend(move |(lx, ly)| Circle::new((lx + 8, ly), 5, style));
    }
    if let Some(front) = &chart.front {
        let mut pts = drawable(chart, front);
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        ctx.draw_series(LineSeries::new(pts.iter().copied(), BLACK.stroke_width(2)))
            .map_err(e)?
            .label(&front.name)
            .legend(|(lx, ly)| PathElement::new(vec![(lx, ly), (lx + 16, ly)], BLACK));
        ctx.draw_series(
            pts.iter()
                .map(|&p| Circle::new(p, 9, BLACK.stroke_width(2))),
        )
        .map_err(e)?;
    }
    ctx.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(e)?;
    Ok(())
}

/// Tick labels: plain for moderate magnitudes, scientific otherwise.
fn short_number(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-2..1e5).contains(&a) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.1e}")
    }
}

/// The Pareto front of `(cost, error)` points, both minimized: the points
/// no other point beats in both (ties in both kept once), sorted by cost.
///
/// ```
/// use voxkit::report::plot::pareto_front;
/// let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (2.0, 3.0)];
/// assert_eq!(pareto_front(&pts), vec![(1.0, 5.0), (2.0, 3.0), (4.0, 1.0)]);
/// ```
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in pts {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The front against a brute-force definition on seeded random points.
    #[test]
    fn pareto_front_is_the_undominated_set() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..200 {
            let n = rng.random_range(1..40);
            let pts: Vec<(f64, f64)> = (0..n)
                .map(|_| {
                    (
                        rng.random_range(0..10) as f64,
                        rng.random_range(0..10) as f64,
                    )
                })
                .collect();
            let front = pareto_front(&pts);
            let dominated = |p: &(f64, f64)| {
                pts.iter()
                    .any(|q| q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
            };
            let mut want: Vec<(f64, f64)> = pts.iter().copied().filter(|p| !dominated(p)).collect();
            want.sort_by(|a, b| a.0.total_cmp(&b.0));
            want.dedup();
            assert_eq!(front, want, "{pts:?}");
        }
    }

    /// A chart with every kind of axis renders to an SVG with its markers,
    /// and degenerate data (one point, zeros on a log axis) does not fail.
    #[test]
    fn renders_svg() {
        for (log_x, log_y) in [(false, false), (true, false), (false, true), (true, true)] {
            let chart = Chart {
                title: "t".into(),
                x_label: "x".into(),
                y_label: "y".into(),
                log_x,
                log_y,
                series: vec![
                    Series::line("a", vec![(1.0, 2.0), (10.0, 3.0), (0.0, 0.0)]),
                    Series::points("b", vec![(5.0, 5.0)]),
                ],
                front: Some(Series::line("front", vec![(1.0, 2.0)])),
            };
            let svg = render_svg(&chart).unwrap();
            assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
            assert!(svg.matches("<circle").count() >= 3);
            assert!(svg.contains("<polyline"));
        }
        let empty = Chart {
            title: "empty".into(),
            x_label: String::new(),
            y_label: String::new(),
            log_x: true,
            log_y: false,
            series: vec![],
            front: None,
        };
        assert!(render_svg(&empty).unwrap().starts_with("<svg"));
    }
}
