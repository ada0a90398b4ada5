//! The dt-against-time plot of a controlled run (SVG): the accepted step (a thick grey line
//! under the limits' dashed proposals, so a binding limit shows on it) in units of `h/c`
//! (seconds on the caption), each limit's proposal in a fixed colour and dash, rejected
//! attempts when there are any, and the last step — shortened to land on `t_end` — marked
//! apart instead of drawn as a drop of the line.

use super::history::DtHistory;
use plotters::prelude::*;

/// A fixed colour per limit name, so that plots of different runs compare at a glance.
fn colour(name: &str) -> RGBColor {
    match name {
        "sound_speed" => RGBColor(31, 119, 180),
        "stability" => RGBColor(230, 120, 0),
        "temporal_error" => RGBColor(44, 160, 44),
        "filter" => RGBColor(148, 103, 189),
        _ => RGBColor(120, 120, 120),
    }
}

fn label(name: &str) -> String {
    match name {
        "sound_speed" => "sound-speed limit (eq 49)".into(),
        "stability" => "stability limit (eq 56)".into(),
        "temporal_error" => "temporal error limit (eqs 20-30)".into(),
        "filter" => "step-size filter".into(),
        other => format!("{other} limit"),
    }
}

/// The plot's points, `(t, dt / unit)`.
struct Curves {
    accepted: Vec<(f64, f64)>,
    /// The last step, shortened to land on `t_end`.
    landing: Vec<(f64, f64)>,
    rejected: Vec<(f64, f64)>,
    /// Each limit's proposals, and the filter's when it acted.
    series: Vec<(String, Vec<(f64, f64)>)>,
}

/// Draws `history` to `path`; `unit` is `h/c` in seconds, `title` names the run.
pub fn plot_dt(
    path: &str,
    history: &DtHistory,
    unit: f64,
    title: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let curves = curves(history, unit);
    let Curves {
        accepted,
        landing,
        rejected,
        series,
    } = &curves;
    let all = accepted
        .iter()
        .chain(landing)
        .chain(rejected)
        .chain(series.iter().flat_map(|(_, s)| s));
    let (mut t1, mut lo, mut hi) = (0.0_f64, f64::INFINITY, 0.0_f64);
    for &(t, y) in all {
        t1 = t1.max(t);
        lo = lo.min(y);
        hi = hi.max(y);
    }
    if !(lo.is_finite() && hi > 0.0) {
        return Err("nothing to plot".into());
    }
    draw(path, title, unit, &curves, (t1, hi))
}

/// The points of `history` in units of `unit`.
fn curves(history: &DtHistory, unit: f64) -> Curves {
    let pts = &history.points;
    let accepted: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| p.accepted && !p.landing)
        .map(|p| (p.t, p.dt / unit))
        .collect();
    let landing: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| p.landing)
        .map(|p| (p.t, p.dt / unit))
        .collect();
    let rejected: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| !p.accepted)
        .map(|p| (p.t, p.dt / unit))
        .collect();
    let mut series: Vec<(String, Vec<(f64, f64)>)> = history
        .names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let s = pts
                .iter()
                .filter_map(|p| {
                    p.proposals
                        .iter()
                        .find(|(j, _)| *j == i)
                        .map(|&(_, dt)| (p.t, dt / unit))
                })
                .collect();
            (n.clone(), s)
        })
        .collect();
    let filter: Vec<(f64, f64)> = pts
        .iter()
        .filter_map(|p| p.filter.map(|f| (p.t, f / unit)))
        .collect();
    if !filter.is_empty() {
        series.push(("filter".into(), filter));
    }
    Curves {
        accepted,
        landing,
        rejected,
        series,
    }
}

/// Draws `curves` to `path`, the time axis to `t1` and the step axis with head room above
/// `hi`.
fn draw(
    path: &str,
    title: &str,
    unit: f64,
    curves: &Curves,
    (t1, hi): (f64, f64),
) -> Result<(), Box<dyn std::error::Error>> {
    let Curves {
        accepted,
        landing,
        rejected,
        series,
    } = curves;
    let root = SVGBackend::new(path, (1100, 650)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(16)
        .x_label_area_size(55)
        .y_label_area_size(85)
        // A linear axis from 0 (a collapse of dt shows as such), head room for the legend.
        .build_cartesian_2d(0.0..t1.max(1e-300) * 1.02, 0.0..hi * 1.6)?;
    chart
        .configure_mesh()
        .x_desc("time t (s)")
        .y_desc(format!("time step dt / (h/c),   h/c = {unit:.3e} s"))
        .axis_desc_style(("sans-serif", 20))
        .label_style(("sans-serif", 16))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            accepted.iter().copied(),
            RGBColor(60, 60, 60).stroke_width(5),
        ))?
        .label("accepted step")
        .legend(|(x, y)| {
            PathElement::new(
                vec![(x, y), (x + 24, y)],
                RGBColor(60, 60, 60).stroke_width(5),
            )
        });
    for (name, s) in series {
        let c = colour(name);
        chart
            .draw_series(DashedLineSeries::new(
                s.iter().copied(),
                8,
                5,
                c.stroke_width(2),
            ))?
            .label(label(name))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2)));
    }
    if !landing.is_empty() {
        chart
            .draw_series(
                landing
                    .iter()
                    .map(|&p| Circle::new(p, 6, BLACK.stroke_width(2))),
            )?
            .label("last step, shortened to end at t_end")
            .legend(|(x, y)| Circle::new((x + 12, y), 5, BLACK.stroke_width(2)));
    }
    if !rejected.is_empty() {
        chart
            .draw_series(
                rejected
                    .iter()
                    .map(|&p| Cross::new(p, 6, RED.stroke_width(2))),
            )?
            .label("rejected attempt")
            .legend(|(x, y)| Cross::new((x + 12, y), 5, RED.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 16))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()?;
    root.present()?;
    Ok(())
}
