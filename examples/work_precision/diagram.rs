//! The diagram's data: every point run once for its end state, then timed in interleaved
//! rounds; the errors against the reference; the fixed rules' wall time at the
//! controller's errors (module docs of `work_precision`).

use super::measure::{errors, Errors, Scales};
use super::plot::Point;
use super::repeats::{median, more_rounds};
use super::runs::Policy;
use super::scene::Scene;
use serde::Serialize;

/// One point of the diagram.
#[derive(Debug, Serialize)]
pub struct PointRow {
    pub policy: String,
    pub steps: u64,
    pub rejected: u64,
    pub failure: Option<String>,
    pub wall_s: f64,
    pub wall_s_runs: Vec<f64>,
    pub errors: Option<Errors>,
    /// `(E − E₀)/E₀` at the end (the energy the run gained, negative when it lost).
    pub energy_change: f64,
    #[serde(skip)]
    kind: Policy,
}

/// The reference run and how far halving its step moves it.
#[derive(Debug, Serialize)]
pub struct ReferenceRow {
    /// `α_ref`; the reference itself runs at `α_ref/2`.
    pub alpha: f64,
    pub steps: u64,
    /// The run at `α_ref` measured against the one at `α_ref/2`.
    pub reference_change: Errors,
    /// Per measure: whether `reference_change ≤ 0.1 ×` the smallest error plotted.
    pub reference_converged: [bool; 3],
}

/// The controller point's wall time and, per measure, the interpolated fixed-rule wall
/// time at its error over it.
#[derive(Debug, Serialize)]
pub struct Match {
    pub policy: String,
    pub position: Option<f64>,
    pub velocity: Option<f64>,
    pub energy: Option<f64>,
}

/// The whole document.
#[derive(Debug, Serialize)]
pub struct Doc {
    pub particles: usize,
    pub t_end: f64,
    pub scales: Scales,
    pub reference: ReferenceRow,
    pub points: Vec<PointRow>,
    pub fixed_time_to_match: Vec<Match>,
    pub repeats: usize,
    /// `/proc/loadavg` before and after.
    pub load: [String; 2],
}

/// Wall time of the fixed-rule curve at error `e` (log–log interpolation between the two
/// rules whose errors bracket it), or `None`.
fn fixed_wall_at(fixed: &[(f64, f64)], e: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = fixed
        .iter()
        .copied()
        .filter(|&(w, err)| w > 0.0 && err > 0.0)
        .collect();
    pts.sort_by(|a, b| a.1.total_cmp(&b.1));
    pts.windows(2).find_map(|p| {
        let ((w0, e0), (w1, e1)) = (p[0], p[1]);
        (e0 <= e && e <= e1).then(|| {
            let s = if e1 > e0 {
                (e / e0).ln() / (e1 / e0).ln()
            } else {
                0.0
            };
            (w0.ln() + s * (w1.ln() - w0.ln())).exp()
        })
    })
}

/// Runs the points and the reference of `scene`.
pub fn diagram(
    scene: &Scene,
    alphas: &[f64],
    tols: &[f64],
    alpha_ref: f64,
    repeat: usize,
) -> Result<Doc, String> {
    let n = scene.particles;
    let s: Scales = scene.scales;
    let reference = scene.run(Policy::Fixed(alpha_ref / 2.0))?;
    let coarse = scene.run(Policy::Fixed(alpha_ref))?;
    if let Some(f) = reference.failure.as_ref().or(coarse.failure.as_ref()) {
        return Err(format!("the reference run failed: {f}"));
    }
    let reference_change = errors(&coarse, &reference, n, &s)?;
    let policies: Vec<Policy> = alphas
        .iter()
        .map(|&a| Policy::Fixed(a))
        .chain(scene.shipped_dt.map(Policy::Shipped))
        .chain(std::iter::once(Policy::Controller(None)))
        .chain(tols.iter().map(|&t| Policy::Controller(Some(t))))
        .collect();
    let mut points = Vec::new();
    for &p in &policies {
        let end = scene.run(p)?;
        eprintln!(
            "work_precision: {} {} steps, {:.3} s",
            p.name(),
            end.steps,
            end.wall_s
        );
        let errors = match end.failure {
            None => Some(errors(&end, &reference, n, &s)?),
            Some(_) => None,
        };
        points.push(PointRow {
            policy: p.name(),
            steps: end.steps,
            rejected: end.rejected,
            wall_s: end.wall_s,
            wall_s_runs: vec![end.wall_s],
            energy_change: (end.energy - s.energy) / s.energy,
            failure: end.failure,
            errors,
            kind: p,
        });
    }
    let mut walls: Vec<Vec<f64>> = points.iter().map(|p| p.wall_s_runs.clone()).collect();
    more_rounds(&mut walls, repeat, |i| {
        scene.run(policies[i]).map(|e| e.wall_s)
    })?;
    for (p, w) in points.iter_mut().zip(walls) {
        p.wall_s = median(&w);
        p.wall_s_runs = w;
    }
    let smallest = |k: usize| {
        points
            .iter()
            .filter_map(|p| p.errors.map(|e| e.named()[k].1))
            .filter(|&e| e > 0.0)
            .fold(f64::INFINITY, f64::min)
    };
    let change = reference_change.named();
    let reference_converged = [0, 1, 2].map(|k| change[k].1 <= 0.1 * smallest(k));
    let fixed_time_to_match = matches(&points);
    Ok(Doc {
        particles: n,
        t_end: scene.t_end,
        scales: s,
        reference: ReferenceRow {
            alpha: alpha_ref,
            steps: reference.steps,
            reference_change,
            reference_converged,
        },
        points,
        fixed_time_to_match,
        repeats: repeat,
        load: Default::default(),
    })
}

fn matches(points: &[PointRow]) -> Vec<Match> {
    let fixed = |k: usize| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter(|p| matches!(p.kind, Policy::Fixed(_) | Policy::Shipped(_)))
            .filter_map(|p| p.errors.map(|e| (p.wall_s, e.named()[k].1)))
            .collect()
    };
    let curves = [fixed(0), fixed(1), fixed(2)];
    points
        .iter()
        .filter(|p| matches!(p.kind, Policy::Controller(_)))
        .filter_map(|p| {
            let e = p.errors?.named();
            let at = |k: usize| fixed_wall_at(&curves[k], e[k].1).map(|w| w / p.wall_s);
            Some(Match {
                policy: p.policy.clone(),
                position: at(0),
                velocity: at(1),
                energy: at(2),
            })
        })
        .collect()
}

impl Doc {
    /// The points the plot draws (those that reached the end).
    pub fn plot_points(&self) -> Vec<Point> {
        self.points
            .iter()
            .filter_map(|p| {
                let errors = p.errors?;
                let (label, controller, default) = match p.kind {
                    Policy::Fixed(a) => (format!("α={a}"), false, false),
                    Policy::Shipped(_) => ("shipped".into(), false, false),
                    Policy::Controller(None) => ("default".into(), true, true),
                    Policy::Controller(Some(t)) => (format!("{t}"), true, false),
                };
                Some(Point {
                    label,
                    wall_s: p.wall_s,
                    errors,
                    controller,
                    default,
                })
            })
            .collect()
    }

    /// The human table.
    pub fn print_table(&self) {
        let r = &self.reference;
        println!(
            "{} particles to t = {}; reference α = {} ({} steps); halving its step moves it by \
             position {:.2e}, velocity {:.2e}, energy {:.2e} (converged: {:?})",
            self.particles,
            self.t_end,
            r.alpha / 2.0,
            r.steps,
            r.reference_change.position,
            r.reference_change.velocity,
            r.reference_change.energy,
            r.reference_converged
        );
        println!(
            "{:<20} {:>6} {:>4} {:>9} {:>10} {:>10} {:>10} {:>9}",
            "policy", "steps", "rej", "wall_s", "e_x", "e_v", "e_E", "ΔE/E₀"
        );
        for p in &self.points {
            let e = p.errors.map_or("blew up".to_string(), |e| {
                format!(
                    "{:>10.3e} {:>10.3e} {:>10.3e}",
                    e.position, e.velocity, e.energy
                )
            });
            println!(
                "{:<20} {:>6} {:>4} {:>9.4} {e} {:>+9.4}",
                p.policy, p.steps, p.rejected, p.wall_s, p.energy_change
            );
        }
        let f = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.2}"));
        println!("fixed-rule wall time at the controller's error / controller's wall time:");
        for m in &self.fixed_time_to_match {
            println!(
                "  {:<20} position {:>5} velocity {:>5} energy {:>5}",
                m.policy,
                f(m.position),
                f(m.velocity),
                f(m.energy)
            );
        }
        println!("load: {} … {}", self.load[0], self.load[1]);
    }
}
