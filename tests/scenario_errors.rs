//! Every bad scenario is a typed `ScenarioError` naming the field — never a panic.
//! Table-driven: JSON texts, plus scenarios built in code (NaN cannot be written in JSON).

use mpm_dt::scenario::{Initial, Particles, Scenario, ScenarioError};
use mpm_dt::Boundary;

/// The error a case must produce.
#[derive(Debug)]
enum Expect {
    Syntax,
    Unknown(&'static str),
    Type(&'static str),
    Invalid(&'static str),
}

fn check(name: &str, result: Result<Scenario, ScenarioError>, expect: &Expect) {
    let err = match result {
        Ok(_) => panic!("case `{name}`: accepted, expected {expect:?}"),
        Err(e) => e,
    };
    let msg = err.to_string();
    let ok = match (expect, &err) {
        (Expect::Syntax, ScenarioError::Syntax { .. }) => true,
        (Expect::Unknown(f), ScenarioError::UnknownField { field }) => field == f,
        (Expect::Type(f), ScenarioError::Type { field, .. }) => field == f,
        (Expect::Invalid(f), ScenarioError::Invalid { field, .. }) => field == f,
        _ => false,
    };
    assert!(ok, "case `{name}`: got {err:?}, expected {expect:?}");
    // The message names the field.
    if let Expect::Unknown(f) | Expect::Type(f) | Expect::Invalid(f) = expect {
        assert!(
            msg.contains(f),
            "case `{name}`: message `{msg}` does not name `{f}`"
        );
    }
}

/// The bad JSON scenarios: a name, the text and the error it must produce.
const BAD_JSON: &[(&str, &str, Expect)] = {
    use Expect::*;
    &[
        ("truncated", r#"{"cells": 10"#, Syntax),
        ("not an object", r#"[1, 2, 3]"#, Syntax),
        ("NaN literal", r#"{"youngs_modulus": NaN}"#, Syntax),
        (
            "unknown top-level field",
            r#"{"cellz": 10}"#,
            Unknown("cellz"),
        ),
        ("zero cells", r#"{"cells": 0}"#, Invalid("cells")),
        ("negative cells", r#"{"cells": -4}"#, Type("cells")),
        ("cells as text", r#"{"cells": "ten"}"#, Type("cells")),
        ("fractional cells", r#"{"cells": 10.5}"#, Type("cells")),
        (
            "periodic ring of 2 cells",
            r#"{"cells": 2}"#,
            Invalid("cells"),
        ),
        ("zero length", r#"{"length": 0}"#, Invalid("length")),
        ("negative length", r#"{"length": -1.0}"#, Invalid("length")),
        (
            "zero E",
            r#"{"youngs_modulus": 0}"#,
            Invalid("youngs_modulus"),
        ),
        (
            "negative E",
            r#"{"youngs_modulus": -3}"#,
            Invalid("youngs_modulus"),
        ),
        ("zero density", r#"{"density": 0}"#, Invalid("density")),
        ("negative density", r#"{"density": -1}"#, Invalid("density")),
        ("zero t_end", r#"{"t_end": 0}"#, Invalid("t_end")),
        ("negative t_end", r#"{"t_end": -0.5}"#, Invalid("t_end")),
        ("t_end as text", r#"{"t_end": "1"}"#, Type("t_end")),
        (
            "unknown boundary",
            r#"{"boundary": "circular"}"#,
            Type("boundary"),
        ),
        (
            "unknown shape",
            r#"{"shape": "cubic_bspline"}"#,
            Type("shape"),
        ),
        (
            "unknown material",
            r#"{"material": "rubber"}"#,
            Type("material"),
        ),
        (
            "zero per cell",
            r#"{"particles": {"per_cell": 0}}"#,
            Invalid("particles.per_cell"),
        ),
        (
            "both layouts",
            r#"{"particles": {"per_cell": 2, "positions": [0.5]}}"#,
            Invalid("particles"),
        ),
        ("no layout", r#"{"particles": {}}"#, Invalid("particles")),
        (
            "unknown particles field",
            r#"{"particles": {"ppc": 2}}"#,
            Type("particles"),
        ),
        (
            "position beyond the end",
            r#"{"cells": 3, "particles": {"positions": [0.1, 0.5, 1.5]}}"#,
            Invalid("particles.positions"),
        ),
        (
            "negative position",
            r#"{"cells": 3, "particles": {"positions": [-0.1, 0.5, 0.9]}}"#,
            Invalid("particles.positions"),
        ),
        (
            "position at L on a periodic bar",
            r#"{"cells": 3, "particles": {"positions": [0.1, 0.5, 1.0]}}"#,
            Invalid("particles.positions"),
        ),
        (
            "fewer particles than cells (GIMP width > h)",
            r#"{"cells": 4, "particles": {"positions": [0.1, 0.5, 0.9]}}"#,
            Invalid("particles.positions"),
        ),
        (
            "masses of the wrong length",
            r#"{"cells": 3, "particles": {"per_cell": 1, "masses": [1, 1]}}"#,
            Invalid("particles.masses"),
        ),
        (
            "negative mass",
            r#"{"cells": 3, "particles": {"per_cell": 1, "masses": [1, -1, 1]}}"#,
            Invalid("particles.masses"),
        ),
        (
            "zero mode",
            r#"{"initial": {"standing_wave": {"amplitude": 0.1, "mode": 0}}}"#,
            Invalid("initial.standing_wave.mode"),
        ),
        (
            "half mode on a periodic bar",
            r#"{"initial": {"standing_wave": {"amplitude": 0.1, "mode": 1.5}}}"#,
            Invalid("initial.standing_wave.mode"),
        ),
        (
            "quarter mode on a clamped bar",
            r#"{"boundary": "fixed", "initial": {"standing_wave": {"amplitude": 0.1, "mode": 0.25}}}"#,
            Invalid("initial.standing_wave.mode"),
        ),
        (
            "missing amplitude",
            r#"{"initial": {"standing_wave": {"mode": 1}}}"#,
            Type("initial"),
        ),
        (
            "unknown wave field",
            r#"{"initial": {"standing_wave": {"amplitude": 0.1, "mode": 1, "phase": 0}}}"#,
            Type("initial"),
        ),
        (
            "unknown initial condition",
            r#"{"initial": {"gaussian": {}}}"#,
            Type("initial"),
        ),
        (
            "unknown controller setting",
            r#"{"controller": {"anything": 1}}"#,
            Invalid("controller"),
        ),
        (
            "controller stability safety above 1",
            r#"{"controller": {"stability": {"safety": 1.5}}}"#,
            Invalid("controller"),
        ),
        (
            "controller sound-speed factor zero",
            r#"{"controller": {"sound_speed": {"alpha": 0}}}"#,
            Invalid("controller"),
        ),
    ]
};

#[test]
fn bad_json_scenarios_are_typed_errors_naming_the_field() {
    let cases = BAD_JSON;
    assert!(cases.len() >= 15);
    for (name, json, expect) in cases {
        check(name, Scenario::from_json(json), expect);
    }
}

#[test]
fn bad_scenarios_built_in_code_are_caught_by_validate() {
    use Expect::*;
    let nan_position = Scenario {
        cells: 3,
        particles: Particles {
            per_cell: None,
            positions: Some(vec![0.1, f64::NAN, 0.9]),
            masses: None,
        },
        ..Scenario::default()
    };
    let nan_mass = Scenario {
        cells: 3,
        particles: Particles {
            per_cell: Some(1),
            positions: None,
            masses: Some(vec![1.0, f64::NAN, 1.0]),
        },
        ..Scenario::default()
    };
    let infinite_e = Scenario {
        youngs_modulus: f64::INFINITY,
        ..Scenario::default()
    };
    let nan_amplitude = Scenario {
        initial: Initial::StandingWave {
            amplitude: f64::NAN,
            mode: 1.0,
        },
        ..Scenario::default()
    };
    let nan_t_end = Scenario {
        t_end: f64::NAN,
        ..Scenario::default()
    };
    let cases = [
        ("NaN position", nan_position, Invalid("particles.positions")),
        ("NaN mass", nan_mass, Invalid("particles.masses")),
        ("infinite E", infinite_e, Invalid("youngs_modulus")),
        (
            "NaN amplitude",
            nan_amplitude,
            Invalid("initial.standing_wave.amplitude"),
        ),
        ("NaN t_end", nan_t_end, Invalid("t_end")),
    ];
    for (name, scenario, expect) in cases {
        check(
            name,
            scenario.validate().map(|()| scenario.clone()),
            &expect,
        );
        // build() refuses it too, with the same error.
        assert!(
            scenario.build().is_err(),
            "case `{name}`: build accepted it"
        );
        assert!(scenario.grid().is_err() && scenario.particle_init().is_err());
    }
}

#[test]
fn a_missing_file_is_an_io_error() {
    let err = Scenario::from_file("/nonexistent/scenario.json").unwrap_err();
    assert!(matches!(err, ScenarioError::Io { .. }), "{err:?}");
}

#[test]
fn good_scenarios_parse_and_build() {
    // Defaults, a clamped fundamental, explicit positions with masses, the rest state.
    let texts = [
        "{}",
        r#"{"boundary": "fixed", "initial": {"standing_wave": {"amplitude": 0.01, "mode": 0.5}}}"#,
        r#"{"cells": 3, "boundary": "fixed", "particles": {"positions": [0.0, 0.5, 1.0], "masses": [0.3, 0.4, 0.3]}}"#,
        r#"{"material": "neo_hookean", "shape": "linear", "initial": "rest", "controller": {"stability": {"safety": 0.8}, "sound_speed": null}}"#,
    ];
    for text in texts {
        let s = Scenario::from_json(text).unwrap_or_else(|e| panic!("{text}: {e}"));
        s.build().unwrap_or_else(|e| panic!("{text}: {e}"));
    }
    let s = Scenario::from_json(texts[2]).unwrap();
    assert_eq!(s.boundary, Boundary::Fixed);
    assert_eq!(s.particle_init().unwrap().mass, vec![0.3, 0.4, 0.3]);
    // The default scenario round-trips through serde.
    let d = Scenario::default();
    let back = Scenario::from_json(&serde_json::to_string(&d).unwrap()).unwrap();
    assert_eq!(back, d);
}

#[test]
fn shipped_scenario_files_parse_and_build() {
    // Every `*.json` under `scenarios/`, subdirectories included (e.g. the comparison suite).
    let mut dirs = vec![std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios"
    ))];
    let mut count = 0;
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "json") {
                // Scenarios of any dimension: `dim` 2 or 3 use the d-dimensional format.
                let text = std::fs::read_to_string(&path).unwrap();
                match mpm_dt::nd::scenario::ScenarioNd::dim_of(&text) {
                    Ok(1) => {
                        let s =
                            Scenario::from_file(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
                        s.build().unwrap_or_else(|e| panic!("{path:?}: {e}"));
                    }
                    Ok(d) => {
                        let s = mpm_dt::nd::scenario::ScenarioNd::from_json(&text)
                            .unwrap_or_else(|e| panic!("{path:?}: {e}"));
                        let built = if d == 2 {
                            s.build::<2>().map(|_| ())
                        } else {
                            s.build::<3>().map(|_| ())
                        };
                        built.unwrap_or_else(|e| panic!("{path:?}: {e}"));
                    }
                    Err(e) => panic!("{path:?}: {e}"),
                }
                count += 1;
            }
        }
    }
    assert!(count >= 5, "found {count} scenario files");
}
