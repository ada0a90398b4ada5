//! `compare`'s command line (module docs of `compare`).

use crate::common;
use mpm_dt::stability::{Refresh, Tracking};

/// The fixed multipliers compared by default.
pub(crate) const ALPHAS: [f64; 4] = [0.3, 0.4, 0.5, 0.9];

pub(crate) const USAGE: &str = "usage: compare --scenario FILE [--json] \
[--tracking certified|lanczos|lanczos-cached] [--alpha A,B,...] [--no-matched] [--repeat N]";

/// Command-line options.
pub(crate) struct Args {
    pub(crate) scenario: String,
    pub(crate) json: bool,
    /// How the stability limit tracks λmax (`--tracking`; `None` keeps the scenario's).
    pub(crate) tracking: Option<(String, Tracking)>,
    /// The fixed multipliers (`--alpha`, default [`ALPHAS`]).
    pub(crate) alphas: Vec<f64>,
    /// Whether to search the fixed rule with mpm-dt's step count (`--no-matched`: not).
    pub(crate) matched: bool,
    /// Timed runs per policy (`--repeat`, default 1; module docs).
    pub(crate) repeat: usize,
}

pub(crate) fn parse_args() -> Result<Args, String> {
    let mut scenario = None;
    let mut json = false;
    let mut tracking = None;
    let mut alphas = ALPHAS.to_vec();
    let mut matched = true;
    let mut repeat = 1;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--scenario" => scenario = Some(it.next().ok_or("--scenario needs a value")?),
            "--json" => json = true,
            "--tracking" => {
                let mode = it.next().ok_or("--tracking needs a value")?;
                let t = match mode.as_str() {
                    "certified" => Tracking::default(),
                    "lanczos" => Tracking::Lanczos(Refresh::every_step()),
                    "lanczos-cached" => Tracking::Lanczos(Refresh::cached()),
                    other => return Err(format!("unknown tracking {other}\n{USAGE}")),
                };
                tracking = Some((mode, t));
            }
            "--alpha" => {
                let list = it.next().ok_or("--alpha needs a value")?;
                alphas = list
                    .split(',')
                    .map(|a| match a.trim().parse::<f64>() {
                        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
                        _ => Err(format!("--alpha: {a:?} is not a positive number\n{USAGE}")),
                    })
                    .collect::<Result<_, _>>()?;
            }
            "--no-matched" => matched = false,
            "--repeat" => {
                repeat =
                    common::repeats::parse_repeat(it.next()).map_err(|e| format!("{e}\n{USAGE}"))?
            }
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument {other}\n{USAGE}")),
        }
    }
    Ok(Args {
        scenario: scenario.ok_or(format!("--scenario is required\n{USAGE}"))?,
        json,
        tracking,
        alphas,
        matched,
        repeat,
    })
}
