//! The work–precision diagram (SVG): one panel per error measure, x = wall time (median of
//! the repeats), y = the error against the converged-step reference, both logarithmic; the
//! fixed rules as a grey line of squares labelled by `α`, the controller's tolerances as a
//! green line of circles labelled by the tolerance, its default as a filled triangle.

use super::measure::Errors;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One plotted point: its label, wall time and errors, and whether it is the controller's.
pub struct Point {
    pub label: String,
    pub wall_s: f64,
    pub errors: Errors,
    pub controller: bool,
    pub default: bool,
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// Log-axis range around the positive values `v` (a decade's tenth of head room).
fn range(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::INFINITY, 0.0_f64), |(l, h), x| (l.min(x), h.max(x)));
    if lo.is_finite() {
        lo / 1.6..hi * 1.6
    } else {
        1e-3..1.0
    }
}

fn series(
    chart: &mut Chart<'_, '_>,
    pts: &[(f64, f64, String, bool)],
    c: RGBColor,
    legend: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let squares = legend.starts_with("fixed");
    let line: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1)).collect();
    chart
        .draw_series(LineSeries::new(line, c.stroke_width(2)))?
        .label(legend)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    for (x, y, label, filled) in pts {
        let style = if *filled {
            c.filled()
        } else {
            c.stroke_width(2)
        };
        let at = EmptyElement::at((*x, *y));
        if squares {
            chart.draw_series(std::iter::once(
                at + Rectangle::new([(-4, -4), (4, 4)], style),
            ))?;
        } else if *filled {
            chart.draw_series(std::iter::once(at + TriangleMarker::new((0, 0), 9, style)))?;
        } else {
            chart.draw_series(std::iter::once(at + Circle::new((0, 0), 5, style)))?;
        }
        let text = ("sans-serif", 12).into_font().color(&c);
        chart.draw_series(std::iter::once(
            EmptyElement::at((*x, *y))
                + Text::new(label.clone(), (7, if squares { -14 } else { 4 }), text),
        ))?;
    }
    Ok(())
}

fn panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    points: &[Point],
    k: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    let name = points.first().map_or("", |p| p.errors.named()[k].0);
    let err = |p: &Point| p.errors.named()[k].1;
    let ok = |p: &&Point| err(p) > 0.0 && err(p).is_finite();
    let xr = range(points.iter().map(|p| p.wall_s));
    let yr = range(points.iter().filter(ok).map(err));
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{name} error"), ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())?;
    chart
        .configure_mesh()
        .x_labels(6)
        .y_labels(8)
        .x_desc("wall time (s)")
        .y_desc(format!("{name} error (relative)"))
        .x_label_formatter(&|x| format!("{x:.2e}"))
        .y_label_formatter(&|y| format!("{y:.1e}"))
        .label_style(("sans-serif", 12))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    let pick = |controller: bool| -> Vec<(f64, f64, String, bool)> {
        points
            .iter()
            .filter(|p| p.controller == controller)
            .filter(ok)
            .map(|p| (p.wall_s, err(p), p.label.clone(), p.default))
            .collect()
    };
    series(
        &mut chart,
        &pick(false),
        RGBColor(110, 110, 110),
        "fixed rule (α)",
    )?;
    let mut ours = pick(true);
    ours.sort_by(|a, b| a.0.total_cmp(&b.0));
    series(
        &mut chart,
        &ours,
        RGBColor(30, 140, 50),
        "mpm-dt (tolerance; ▲ default)",
    )?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 13))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    Ok(())
}

/// Draws the diagram of `points` to `path` with `title`.
pub fn plot(path: &str, title: &str, points: &[Point]) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1500, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let panels = root.split_evenly((1, 3));
    for (k, area) in panels.iter().enumerate() {
        panel(area, points, k)?;
    }
    root.present()?;
    Ok(())
}
