//! What the examples share: their log subscriber (the library never installs one; an
//! application chooses its own, as these examples do), the final-error measurement and the
//! fixed rule of thumb on the d-dimensional solver.
// Each example uses a part of this module.
#![allow(dead_code)]

pub mod controller_nd;
pub mod fixed_rule_nd;
pub mod history;
pub mod plot;
pub mod repeats;

use mpm_dt::scenario::Scenario;
use mpm_dt::View;

/// The final velocity errors of `view` against the scenario's exact solution,
/// `(synchronised, raw)` ([`mpm_dt::problems::StandingWave::velocity_errors`], `x0` the
/// particles' reference positions, `half_step` the closing half step `ℓ`): both `None`
/// without an exact solution; a synchronised velocity the view refuses is logged and `None`.
/// Only called with an exact solution does it build the view's weights.
pub fn velocity_errors(
    scenario: &Scenario,
    x0: &[f64],
    view: &View<'_>,
    half_step: f64,
) -> (Option<f64>, Option<f64>) {
    let Some(wave) = scenario.exact_solution() else {
        return (None, None);
    };
    let (synchronised, raw) = wave.velocity_errors(x0, view, half_step);
    let synchronised = synchronised
        .map_err(|e| tracing::error!(error = %e, "synchronised velocity"))
        .ok();
    (synchronised, Some(raw))
}

/// Installs the stderr subscriber of an example: `RUST_LOG` if set, else `default_level`;
/// human-readable (colour codes only on a terminal, so a redirected log stays plain text),
/// or JSON lines with the current span when `json`.
pub fn init_logs(default_level: &str, json: bool) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_level));
    let builder = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(filter);
    if json {
        builder.json().with_current_span(true).init();
    } else {
        builder.init();
    }
}
