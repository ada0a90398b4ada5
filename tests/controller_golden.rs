//! Golden log: the JSON decision lines of a short fixed scenario (reference solver, GIMP,
//! 16 cells × 2 particles, standing wave A = 10⁻², stability + temporal error + growth
//! monitor, to t = 0.5) match the committed `tests/golden/controller_decisions.jsonl`, numbers
//! compared with a relative tolerance of 10⁻⁹ (absolute 10⁻¹²).
//!
//! Regenerate after an intended change with `MPM_DT_UPDATE_GOLDEN=1 cargo test --test
//! controller_golden` and review the diff.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::limit::StepLimit;
use mpm_dt::scenario::Scenario;
use mpm_dt::stability::{Stability, StabilityConfig};
use serde_json::Value;

const GOLDEN: &str = "tests/golden/controller_decisions.jsonl";

fn decisions() -> Vec<String> {
    let scenario = Scenario::from_json(
        r#"{"cells": 16, "particles": {"per_cell": 2}, "t_end": 0.5,
            "initial": {"standing_wave": {"amplitude": 1e-2, "mode": 1}},
            "controller": {"temporal": {"rtol": 1e-3, "atol_rel": 1e-3}}}"#,
    )
    .unwrap();
    let config = ControllerConfig::from_value(scenario.controller.clone().unwrap()).unwrap();
    let mut s = scenario.build().unwrap();
    // The safety the log was recorded with (the 1D limit's default until it took the
    // controller's 0.95).
    let limits: Vec<Box<dyn StepLimit>> = vec![Box::new(
        Stability::new(StabilityConfig {
            safety: 0.9,
            ..StabilityConfig::default()
        })
        .unwrap(),
    )];
    let mut c = Controller::with_default_limits(config, limits).unwrap();
    let mut lines = Vec::new();
    c.run_until(&mut s, scenario.t_end, &mut |d| {
        lines.push(d.to_json_line())
    })
    .unwrap();
    lines
}

fn close(a: &Value, b: &Value, path: &str) -> Result<(), String> {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (
                x.as_f64().unwrap_or(f64::NAN),
                y.as_f64().unwrap_or(f64::NAN),
            );
            if (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) + 1e-12 {
                Ok(())
            } else {
                Err(format!("{path}: {x} vs golden {y}"))
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            let kx: Vec<_> = x.keys().collect();
            let ky: Vec<_> = y.keys().collect();
            if kx != ky {
                return Err(format!("{path}: keys {kx:?} vs golden {ky:?}"));
            }
            for (k, v) in x {
                close(v, &y[k], &format!("{path}.{k}"))?;
            }
            Ok(())
        }
        (Value::Array(x), Value::Array(y)) => {
            if x.len() != y.len() {
                return Err(format!("{path}: length {} vs golden {}", x.len(), y.len()));
            }
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                close(u, v, &format!("{path}[{i}]"))?;
            }
            Ok(())
        }
        _ if a == b => Ok(()),
        _ => Err(format!("{path}: {a} vs golden {b}")),
    }
}

#[test]
fn decision_log_matches_golden_file() {
    let lines = decisions();
    if std::env::var_os("MPM_DT_UPDATE_GOLDEN").is_some() {
        std::fs::write(GOLDEN, lines.join("\n") + "\n").unwrap();
    }
    let golden = std::fs::read_to_string(GOLDEN)
        .expect("golden file (regenerate with MPM_DT_UPDATE_GOLDEN=1)");
    let golden: Vec<&str> = golden.lines().collect();
    assert_eq!(lines.len(), golden.len(), "number of decisions");
    for (i, (l, g)) in lines.iter().zip(&golden).enumerate() {
        let a: Value = serde_json::from_str(l).unwrap();
        let b: Value = serde_json::from_str(g).unwrap();
        if let Err(e) = close(&a, &b, &format!("line {}", i + 1)) {
            panic!("{e}");
        }
    }
}
