//! Table 1 of the paper: error norms and error indices (eq 48) of the five MPM mappings.
//!
//! ```text
//! cargo run --release --example table1 -- [--json] [--field phase|eq45]
//!     [--boundary periodic|fixed] [--jitter J] [--tiling] [--seed S] [--recovery mapped|lsq]
//! ```
//!
//! Prints a human table by default, or one JSON document (`rows`: `case`, `cells`, `ppc`,
//! `error_norm`, `estimate_norm`, `index`) with `--json`.

use mpm_dt::estimators::table1::{self, Config, Field, Row, CASES, CELLS, PPC};
use mpm_dt::estimators::Recovery;
use mpm_dt::Boundary;
use std::process::ExitCode;

fn parse(args: &[String]) -> Result<(bool, Config), String> {
    let mut json = false;
    let mut config = Config::default();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--json" => json = true,
            "--tiling" => config.tiling = true,
            "--field" => {
                config.field = match value("--field")?.as_str() {
                    "phase" => Field::Phase,
                    "eq45" => Field::Eq45,
                    other => return Err(format!("--field: expected phase or eq45, got {other}")),
                }
            }
            "--boundary" => {
                config.boundary = match value("--boundary")?.as_str() {
                    "periodic" => Boundary::Periodic,
                    "fixed" => Boundary::Fixed,
                    other => {
                        return Err(format!("--boundary: expected periodic or fixed, got {other}"))
                    }
                }
            }
            "--recovery" => {
                config.recovery = match value("--recovery")?.as_str() {
                    "mapped" => Recovery::Mapped,
                    "lsq" => Recovery::LeastSquares,
                    other => return Err(format!("--recovery: expected mapped or lsq, got {other}")),
                }
            }
            "--jitter" => {
                let v = value("--jitter")?;
                config.jitter = v.parse().map_err(|_| format!("--jitter: not a number: {v}"))?;
            }
            "--seed" => {
                let v = value("--seed")?;
                config.seed = v.parse().map_err(|_| format!("--seed: not an integer: {v}"))?;
            }
            "-h" | "--help" => {
                return Err("usage: table1 [--json] [--field phase|eq45] [--boundary periodic|fixed] [--jitter J] [--tiling] [--seed S] [--recovery mapped|lsq]".into())
            }
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok((json, config))
}

fn print_human(config: &Config, rows: &[Row]) {
    println!(
        "Table 1 — field {:?}, boundary {:?}, jitter {} (tiling {}), recovery {:?}",
        config.field, config.boundary, config.jitter, config.tiling, config.recovery
    );
    print!("{:>4} {:>4} |", "case", "ppc");
    for n in CELLS {
        print!(" {:>9}", format!("‖e‖ N={n}"));
    }
    print!(" |");
    for n in CELLS {
        print!(" {:>7}", format!("EI {n}"));
    }
    println!();
    for case in CASES {
        for ppc in PPC {
            let r: Vec<&Row> = rows
                .iter()
                .filter(|r| r.case == case && r.ppc == ppc)
                .collect();
            print!("{case:>4} {ppc:>4} |");
            for n in CELLS {
                if let Some(r) = r.iter().find(|r| r.cells == n) {
                    print!(" {:>9.2e}", r.error_norm);
                }
            }
            print!(" |");
            for n in CELLS {
                if let Some(r) = r.iter().find(|r| r.cells == n) {
                    print!(" {:>7.3}", r.index);
                }
            }
            println!();
        }
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (json, config) = match parse(&args) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let rows = match table1::run(&config) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("table1: {e}");
            return ExitCode::FAILURE;
        }
    };
    if json {
        let doc = serde_json::json!({ "config": config, "rows": rows });
        println!("{doc}");
    } else {
        print_human(&config, &rows);
    }
    ExitCode::SUCCESS
}
