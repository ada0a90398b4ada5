//! Capability: the examples a new user runs first answer with the right exit status — 0 for
//! `--help` and a run that reaches its end, 1 for a run that blows up or cannot go on, 2 for
//! a usage error — and say why on stderr.
//!
//! `cargo test` builds the examples next to the test binaries (`target/<profile>/examples/`);
//! the tests run those binaries.

use std::path::PathBuf;
use std::process::{Command, Output};

/// The built example `name` (beside this test's own directory).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> -> target/<profile>/examples/<name>
    let dir = exe
        .parent()
        .and_then(|d| d.parent())
        .expect("target/<profile>")
        .join("examples");
    let path = dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.exists(),
        "example binary {} not found: `cargo test` builds examples; run it from the workspace",
        path.display()
    );
    path
}

fn run(name: &str, args: &[&str]) -> Output {
    Command::new(example(name))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("example runs")
}

/// Runs example `name`, asserts it exits 0 (stderr in the message) and parses its stdout as
/// one JSON document.
fn run_json(name: &str, args: &[&str]) -> serde_json::Value {
    let out = run(name, args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON document")
}

fn scenario_file(name: &str, json: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mpm-dt-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn help_exits_zero_with_usage_on_stdout() {
    for name in ["vibrating_bar", "simulate"] {
        let out = run(name, &["--help"]);
        assert_eq!(out.status.code(), Some(0), "{name}");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("usage"),
            "{name}"
        );
    }
}

#[test]
fn a_blow_up_exits_one() {
    let out = run("vibrating_bar", &["--fixed-dt", "10", "--steps", "100"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("error"));
}

#[test]
fn a_controller_that_cannot_go_on_exits_one() {
    let path = scenario_file("dt_min.json", r#"{"controller": {"dt_min": 0.5}}"#);
    let out = run("vibrating_bar", &["--scenario", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("too small"), "{err}");
}

#[test]
fn zero_steps_is_a_usage_error() {
    let out = run("vibrating_bar", &["--fixed-dt", "0.01", "--steps", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!String::from_utf8_lossy(&out.stdout).contains("NaN"));
}

#[test]
fn a_bad_scenario_exits_one_naming_the_field() {
    let path = scenario_file(
        "bad_nd.json",
        r#"{"dim": 2, "cells": 4, "poisson_ratio": 0.5, "t_end": 0.1}"#,
    );
    let out = run("simulate", &["--scenario", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("poisson_ratio"));
}

#[test]
fn simulate_runs_a_2d_scenario_and_reports_the_contract_keys() {
    let v = run_json(
        "simulate",
        &["--scenario", "scenarios/nd/plane_p_2d.json", "--json"],
    );
    for key in [
        "t_final",
        "steps_accepted",
        "steps_rejected",
        "blew_up",
        "dt_min",
        "dt_mean",
        "dt_max",
        "binding",
        "velocity_error_linf",
        "energy_initial",
        "energy_final",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["blew_up"], serde_json::Value::Bool(false));
    assert!((v["t_final"].as_f64().unwrap() - 0.5).abs() < 1e-12);
}

#[test]
fn simulate_fixed_dt_reports_the_full_state() {
    let out = run(
        "simulate",
        &[
            "--scenario",
            "scenarios/nd/plane_p_2d.json",
            "--json",
            "--fixed-dt",
            "0.005",
            "--steps",
            "3",
        ],
    );
    assert_eq!(out.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let state = &v["state"];
    let n = state["x"].as_array().unwrap().len();
    assert_eq!(n, 16 * 16 * 4);
    assert_eq!(state["x"][0].as_array().unwrap().len(), 2);
    assert_eq!(state["F"][0].as_array().unwrap().len(), 2);
    assert_eq!(state["F"][0][0].as_array().unwrap().len(), 2);
    assert_eq!(v["steps_accepted"], 3);
}

#[test]
fn a_size_that_cannot_be_allocated_is_refused_up_front() {
    let path = scenario_file(
        "huge.json",
        r#"{"cells": 3, "particles": {"per_cell": 333333333}}"#,
    );
    let out = run("vibrating_bar", &["--scenario", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("GiB"), "{err}");
}

#[test]
fn critical_dt_answers_quickly_on_a_large_1d_scenario() {
    // 10⁵ particles: the dense and real-run columns are skipped (null), not attempted (a
    // dense matrix of this size does not fit in memory; the runs would take minutes).
    let start = std::time::Instant::now();
    let v = run_json(
        "critical_dt",
        &["--scenario", "scenarios/gimp_uniform_1e5.json", "--json"],
    );
    assert_eq!(v["particles"], 100_000);
    assert!(v["dt_empirical"].is_null() && v["lambda_max_dense"].is_null());
    let skipped = v["skipped"].as_str().expect("skipped says why");
    assert!(
        skipped.contains("lambda_max_dense") && skipped.contains("empirical"),
        "{skipped}"
    );
    let ratio = v["ratios_to_h_over_c"]["eq56"]
        .as_f64()
        .expect("eq56 ratio");
    assert!((ratio - 0.5_f64.sqrt()).abs() < 1e-3, "{ratio}");
    assert!(start.elapsed().as_secs() < 10, "{:?}", start.elapsed());
}

#[test]
fn critical_dt_names_every_column_it_skips_in_2d() {
    // 10⁵ particles in 2D: the dense check, the full map and the bisection are beyond their
    // size limits; `skipped` says which and why, and the columns it computed are numbers.
    let v = run_json(
        "critical_dt",
        &["--scenario", "scenarios/nd/gimp_2d_1e5.json", "--json"],
    );
    let skipped = v["skipped"]
        .as_str()
        .expect("skipped names the null columns");
    for column in ["lambda_max_dense", "dt_full_map", "dt_empirical"] {
        assert!(v[column].is_null(), "{column}");
        assert!(skipped.contains(column), "{column} not named in {skipped}");
    }
    assert!(v["dt_eq56"].as_f64().is_some_and(|d| d > 0.0));
    assert!(v["dt_sound_over_critical"].as_f64().is_some());
}

#[test]
fn critical_dt_says_why_the_controller_step_is_null() {
    // No limit that proposes a step: `dt_controller` is infinite, which JSON writes as
    // `null`; `skipped` says why.
    let path = scenario_file(
        "no_proposal.json",
        r#"{"cells": 10, "particles": {"per_cell": 2},
            "controller": {"stability": null, "sound_speed": null}}"#,
    );
    let v = run_json(
        "critical_dt",
        &["--scenario", path.to_str().unwrap(), "--json"],
    );
    assert!(v["dt_controller"].is_null());
    let skipped = v["skipped"].as_str().expect("skipped says why");
    assert!(skipped.contains("dt_controller"), "{skipped}");
}

#[test]
fn simulate_compare_repeats_the_timed_runs_and_reports_medians() {
    let v = run_json(
        "simulate",
        &[
            "--scenario",
            "scenarios/nd/plane_p_2d.json",
            "--json",
            "--compare",
            "--repeat",
            "2",
        ],
    );
    let median2 = |runs: &serde_json::Value| {
        let r: Vec<f64> = runs
            .as_array()
            .expect("wall_s_runs")
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(r.len(), 2, "two timed runs per policy");
        0.5 * (r[0] + r[1])
    };
    let ours = median2(&v["wall_s_runs"]);
    assert_eq!(v["wall_s"].as_f64(), Some(ours));
    let rules = v["fixed_rules"].as_array().expect("fixed_rules");
    assert_eq!(rules.len(), 2);
    for r in rules {
        let theirs = median2(&r["wall_s_runs"]);
        assert_eq!(r["wall_s"].as_f64(), Some(theirs));
        assert_eq!(r["wall_ratio"].as_f64(), Some(ours / theirs));
        let pairs = r["wall_ratio_of_pairs"].as_array().expect("range");
        let (lo, hi) = (pairs[0].as_f64().unwrap(), pairs[1].as_f64().unwrap());
        assert!(lo > 0.0 && lo <= hi, "{lo} {hi}");
    }
}

#[test]
fn simulate_repeat_needs_compare_and_a_positive_count() {
    for args in [
        &["--repeat", "2"][..],
        &["--compare", "--repeat", "0"][..],
        &["--compare", "--repeat", "two"][..],
    ] {
        let mut all = vec!["--scenario", "scenarios/nd/plane_p_2d.json"];
        all.extend_from_slice(args);
        let out = run("simulate", &all);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--repeat"));
    }
}

#[test]
fn compare_repeat_times_every_policy_and_reports_medians() {
    let v = run_json(
        "compare",
        &[
            "--scenario",
            "scenarios/vibrating_bar.json",
            "--json",
            "--no-matched",
            "--alpha",
            "0.4,0.5",
            "--repeat",
            "3",
        ],
    );
    assert_eq!(v["repeats"].as_u64(), Some(3));
    let policies = v["policies"].as_array().expect("policies");
    assert_eq!(policies.len(), 3, "two rules and mpm-dt");
    for p in policies {
        let mut runs: Vec<f64> = p["wall_s_runs"]
            .as_array()
            .expect("wall_s_runs")
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(runs.len(), 3, "{}", p["policy"]);
        runs.sort_by(f64::total_cmp);
        assert_eq!(p["wall_s"].as_f64(), Some(runs[1]), "the median");
    }
    let pairs = v["wall_ratio_of_pairs"].as_array().expect("ranges");
    assert_eq!(pairs.len(), 2);
    for r in pairs {
        let (lo, hi) = (
            r["range"][0].as_f64().unwrap(),
            r["range"][1].as_f64().unwrap(),
        );
        assert!(lo > 0.0 && lo <= hi, "{r}");
    }
}

#[test]
fn simulate_compare_does_not_repeat_or_compare_a_failed_controlled_run() {
    // The controller cannot take a step as large as dt_min: it stops at once.
    let text = std::fs::read_to_string("scenarios/nd/plane_p_2d.json").unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["controller"] = serde_json::json!({"dt_min": 0.4});
    let path = scenario_file("failing_2d.json", &v.to_string());
    let out = run(
        "simulate",
        &[
            "--scenario",
            path.to_str().unwrap(),
            "--json",
            "--compare",
            "--repeat",
            "3",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the summary");
    assert_eq!(doc["blew_up"], serde_json::Value::Bool(true));
    assert_eq!(doc["wall_s_runs"].as_array().map(Vec::len), Some(1));
    for r in doc["fixed_rules"].as_array().expect("the rules still run") {
        assert_eq!(r["wall_s_runs"].as_array().map(Vec::len), Some(1));
        assert!(
            r["wall_ratio"].is_null() && r["wall_ratio_of_pairs"].is_null(),
            "{r}"
        );
    }
}

#[test]
fn simulate_compare_on_a_1d_scenario_says_where_to_go() {
    let out = run(
        "simulate",
        &["--scenario", "scenarios/vibrating_bar.json", "--compare"],
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--compare runs 2D/3D scenarios"), "{err}");
}

#[test]
fn mls_mpm_refuses_a_repeat_of_zero() {
    let out = run("mls_mpm", &["--repeat", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--repeat"));
}

#[test]
fn user_flip_refuses_an_unknown_scene_and_a_repeat_of_zero() {
    let out = run("user_flip", &["--scene", "sphere"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--scene"));
    let out = run("user_flip", &["--repeat", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--repeat"));
}

#[test]
fn work_precision_refuses_bad_arguments_and_a_bad_scenario() {
    let out = run(
        "work_precision",
        &["--scenario", "scenarios/vibrating_bar.json", "--tol", "0"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tol"));
    let out = run(
        "work_precision",
        &["--scenario", "x.json", "--reference-alpha", "0.1"],
    );
    assert_eq!(out.status.code(), Some(2));
    let bad = scenario_file("wp_bad.json", r#"{"cells": 0, "length": 1.0}"#);
    let out = run("work_precision", &["--scenario", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let out = run("work_precision", &["--help"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("usage"));
}

#[test]
fn work_precision_reports_errors_against_the_reference() {
    let doc = run_json(
        "work_precision",
        &[
            "--scenario",
            "scenarios/vibrating_bar.json",
            "--alpha",
            "0.2,0.7",
            "--tol",
            "0.0003",
            "--repeat",
            "2",
            "--json",
        ],
    );
    let points = doc["points"].as_array().expect("points");
    let names: Vec<&str> = points.iter().filter_map(|p| p["policy"].as_str()).collect();
    assert_eq!(
        names,
        [
            "alpha=0.2",
            "alpha=0.7",
            "mpm-dt default",
            "mpm-dt tol=0.0003"
        ]
    );
    let energy = |i: usize| {
        points[i]["errors"]["energy"]
            .as_f64()
            .expect("energy error")
    };
    // A smaller fixed step is closer to the converged run; so is the tighter tolerance.
    assert!(energy(0) < energy(1), "{points:?}");
    assert!(energy(3) < energy(2), "{points:?}");
    assert_eq!(points[0]["wall_s_runs"].as_array().map(Vec::len), Some(2));
    assert!(doc["reference"]["reference_change"]["velocity"]
        .as_f64()
        .is_some());
    assert_eq!(doc["fixed_time_to_match"].as_array().map(Vec::len), Some(2));
}

#[test]
fn custom_stepper_2d_runs_to_t_end_and_reports_json() {
    let v = run_json("custom_stepper_2d", &["--json"]);
    // The same keys as the 1D example's, plus the dimension.
    let one_d = run_json("custom_stepper", &["--json"]);
    let keys = |v: &serde_json::Value| -> Vec<String> {
        v.as_object().expect("an object").keys().cloned().collect()
    };
    let mut expected = keys(&one_d);
    expected.push("dim".into());
    expected.sort();
    assert_eq!(keys(&v), expected);
    assert_eq!(v["dim"], serde_json::json!(2));
    assert_eq!(v["ok"], serde_json::Value::Bool(true), "{v}");
    let t_end = 2.0;
    let t_final = v["t_final"].as_f64().unwrap();
    assert!(
        (t_final - t_end).abs() <= 1e-12 * t_end,
        "t_final {t_final}"
    );
    assert!(v["steps_accepted"].as_u64().unwrap() > 0);
    assert_eq!(v["steps_rejected"].as_u64(), Some(0));
    // The user's limit is the tightest here (0.5 h/(c + |v|), c = √1.2, h = 1/16; the
    // standard sound-speed and stability limits allow about 2× and 2.7× that): it must
    // bind, and no step may exceed it.
    let binding = v["binding"].as_object().expect("binding counts");
    assert!(binding.contains_key("user_cfl"), "{binding:?}");
    let known = [
        "user_cfl",
        "sound_speed",
        "stability",
        "temporal_error",
        "growth",
        "hold",
        "t_end",
        "growth_cap",
        "filter",
        "dt_initial",
    ];
    assert!(
        binding.keys().all(|k| known.contains(&k.as_str())),
        "{binding:?}"
    );
    let cfl = 0.5 * (1.0 / 16.0) / 1.2_f64.sqrt();
    let dt_max = v["dt_max"].as_f64().unwrap();
    assert!(
        dt_max > 0.5 * cfl && dt_max <= cfl,
        "dt_max {dt_max} vs {cfl}"
    );
    let (dt_min, dt_mean) = (
        v["dt_min"].as_f64().unwrap(),
        v["dt_mean"].as_f64().unwrap(),
    );
    assert!(dt_min <= dt_mean && dt_mean <= dt_max);
}
