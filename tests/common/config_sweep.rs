//! The harness of the config sweeps (`tests/config_shared_fields*.rs`): a config from the
//! body of its JSON, and what a controlled run did — one line per attempt (outcome, step,
//! binding bound, rejection cause, measured temporal error), then how it ended.

#![allow(dead_code)] // each sweep uses its part

use mpm_dt::controller::{ControllerConfig, ControllerError, Decision};

/// The config of a JSON document.
pub fn config(json: &str) -> ControllerConfig {
    ControllerConfig::from_json(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// The config whose JSON body is `fields` (`{fields}`).
pub fn with(fields: &str) -> ControllerConfig {
    config(&format!("{{{fields}}}"))
}

/// What a controlled run did: one line per attempt, then how the run ended.
#[derive(Debug, PartialEq)]
pub struct Run {
    pub log: Vec<String>,
    pub end: String,
}

impl Run {
    /// The run of `drive`, which runs a controller to its end with the decision callback it
    /// is given.
    pub fn of<T>(
        drive: impl FnOnce(&mut dyn FnMut(&Decision)) -> Result<T, ControllerError>,
    ) -> Self {
        let mut log = Vec::new();
        let mut record = |d: &Decision| {
            log.push(format!(
                "{:?} {:e} {} {:?} {:?}",
                d.outcome,
                d.dt,
                d.binding,
                d.cause,
                d.dsm.map(|e| format!("{e:e}"))
            ));
        };
        let end = match drive(&mut record) {
            Ok(_) => "finished".to_string(),
            Err(ControllerError::StepTooSmall { .. }) => "StepTooSmall".to_string(),
            Err(ControllerError::TooManyRejections { count, .. }) => {
                format!("TooManyRejections({count})")
            }
            Err(ControllerError::GrowthPersists { detections, .. }) => {
                format!("GrowthPersists({detections})")
            }
            Err(e) => format!("error: {e}"),
        };
        Self { log, end }
    }

    /// Rejected attempts.
    pub fn rejections(&self) -> usize {
        self.log
            .iter()
            .filter(|l| l.starts_with("Rejected"))
            .count()
    }

    /// Rejected attempts with `cause` (a `RejectCause` as `Debug` prints it).
    pub fn rejections_by(&self, cause: &str) -> usize {
        let tag = format!("Some({cause})");
        self.log
            .iter()
            .filter(|l| l.starts_with("Rejected") && l.contains(&tag))
            .count()
    }

    /// Steps rejected twice in a row.
    pub fn rejected_twice(&self) -> usize {
        self.log
            .windows(2)
            .filter(|w| w[0].starts_with("Rejected") && w[1].starts_with("Rejected"))
            .count()
    }
}
