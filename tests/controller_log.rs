//! The human-readable decision log: the INFO event of each attempt carries the decision's
//! fields, and leaves out those the decision does not have (`cause` and `rejected_by` of an
//! accepted step; `bound58` on the steps that do not evaluate it) instead of printing empty
//! strings or NaN.

use mpm_dt::controller::{Controller, ControllerConfig};
use mpm_dt::scenario::Scenario;
use std::io::Write;
use std::sync::{Arc, Mutex};

/// A writer into a shared buffer (the subscriber's sink).
struct Sink(Arc<Mutex<Vec<u8>>>);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.0.lock() {
            Ok(mut v) => v.extend_from_slice(buf),
            Err(poisoned) => poisoned.into_inner().extend_from_slice(buf),
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn info_events_leave_out_absent_fields() {
    let scenario = Scenario::from_json(
        r#"{"cells": 16, "particles": {"per_cell": 2}, "t_end": 0.3,
            "initial": {"standing_wave": {"amplitude": 1e-2, "mode": 1}}}"#,
    )
    .expect("scenario parses");
    let buf = Arc::new(Mutex::new(Vec::new()));
    let writer = buf.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_ansi(false)
        .with_max_level(tracing::Level::INFO)
        .with_writer(move || Sink(writer.clone()))
        .finish();
    tracing::subscriber::with_default(subscriber, || {
        let mut s = scenario.build().expect("scenario builds");
        let mut c = Controller::standard(ControllerConfig::default()).expect("valid config");
        c.run_until(&mut s, scenario.t_end, &mut |_| {})
            .expect("the run completes");
    });
    let text = String::from_utf8(buf.lock().expect("not poisoned").clone()).expect("utf-8");
    let accepted: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("outcome=\"accepted\""))
        .collect();
    assert!(accepted.len() > 5, "too few accepted events:\n{text}");
    for line in &accepted {
        assert!(!line.contains("NaN"), "NaN printed: {line}");
        assert!(
            !line.contains("cause="),
            "cause on an accepted step: {line}"
        );
        assert!(
            !line.contains("rejected_by="),
            "rejected_by on an accepted step: {line}"
        );
        assert!(line.contains(" dt="), "no dt: {line}");
        assert!(line.contains("lambda_max="), "no lambda_max: {line}");
    }
    // eq 58 runs on the first trial and then every 50th (`bound58_every`): both kinds occur.
    let with_bound = accepted.iter().filter(|l| l.contains("bound58=")).count();
    assert!(with_bound >= 1, "no step shows bound58:\n{text}");
    assert!(with_bound < accepted.len(), "every step shows bound58");
}
