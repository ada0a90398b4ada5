//! The on-demand hand-over: a Python stepper with a `summary(trial)` method hands over
//! its pass totals after every trial and its arrays (`state(trial)`) only when the
//! controller asks for them (`mpm_dt::Stepper::provide_arrays_on_demand`: a λmax refresh,
//! the layout guard's cadence, a temporal-error check, the door check every 64 steps, a
//! trial whose summary is not finite). For a call that reads the particle arrays alone (a
//! temporal-error check against its history, `mpm_dt::Stepper::load_particles`) only they
//! are read: not the weights and nodal fields, and so not the check that every
//! particle's stencil is on the grid.
//!
//! `summary(trial)` returns the dict of a state's `"summary"` (`crate::summary`: the
//! energies and first moment, and — for the saving — `"element_bound"` and
//! `"sound_unit_step"`). A summary that is not finite has the trial's arrays read at
//! once, so that the particle is named; `mpm_dt.StepFailed` raised by `summary(True)` is a
//! retryable failure, as from `try_step`. A state whose arrays are not read is not checked
//! by the package: a solver handing over on demand reports an inverted particle or one
//! outside the grid itself (raising `StepFailed` in `try_step` or `summary(True)`).

use super::{py_state, PyStepper};
use crate::errors::{is_step_failed, state_type_error};
use crate::state::{Fault, StateNd};
use crate::summary::read_totals;
use mpm_dt::nd::{SummaryNd, ViewNd};
use mpm_dt::{Dim, Dimension, StepError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Whether the Python stepper offers a `summary` method.
pub(super) fn offers(obj: &Bound<'_, PyAny>) -> PyResult<bool> {
    Ok(obj.hasattr("summary")? && obj.getattr("summary")?.is_callable())
}

/// `obj.summary(trial)`, read.
pub(super) fn py_summary<const D: usize>(
    obj: &Bound<'_, PyAny>,
    trial: bool,
) -> Result<SummaryNd<D>, Fault> {
    let returned = obj.call_method1("summary", (trial,))?;
    let dict = returned.downcast_into::<PyDict>().map_err(|e| {
        state_type_error(
            obj.py(),
            format!(
                "summary({}) must return a dict, got {}",
                if trial { "True" } else { "False" },
                e.into_inner().get_type()
            ),
        )
    })?;
    read_totals(&dict)
}

/// The view of a state whose arrays are not read: its time, step, grid and summary.
pub(super) fn summary_only<const D: usize>(s: &StateNd<D>) -> ViewNd<'_, D> {
    ViewNd::summary_only(
        s.t,
        s.step,
        &s.grid,
        s.summary.unwrap_or(SummaryNd::zero(false)),
    )
}

impl<const D: usize> PyStepper<'_, D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// After the solver's `try_step(dt)`: the trial's summary only (module docs).
    pub(super) fn summary_of_trial(&mut self, dt: f64) -> Result<(), StepError> {
        let py = self.obj.py();
        let (t, step) = (self.committed.t, self.step);
        match py_summary::<D>(&self.obj, true) {
            Ok(summary) => {
                let mut s = self.spare.take().unwrap_or_default();
                s.t = t + dt;
                s.step = step + 1;
                s.summary = Some(summary);
                self.trial = Some(s);
                Ok(())
            }
            Err(Fault::NonFiniteSummary(what)) => {
                // The arrays name the particle where one is not finite.
                self.read_trial(dt)?;
                if let Some(s) = self.trial.take() {
                    self.spare = Some(s);
                }
                Err(self.trial_fault(Fault::NonFiniteSummary(what), dt))
            }
            Err(Fault::Invalid(e)) if is_step_failed(py, &e) => Err(StepError::Failed {
                message: format!("StepFailed: {}", e.value(py)),
                t,
                step,
                dt,
            }),
            Err(f) => Err(self.trial_fault(f, dt)),
        }
    }

    /// Reads the pending trial's arrays (`state(True)`): all of them (`full`) or the
    /// particle arrays, keeping its time and summary.
    pub(super) fn load_trial(&mut self, full: bool) -> Result<(), StepError> {
        if self.trial_loaded || !self.on_demand || (self.trial_particles && !full) {
            return Ok(());
        }
        let Some(trial) = self.trial.take() else {
            return Err(StepError::NoTrial);
        };
        let (t, summary) = (trial.t, trial.summary);
        self.read_trial_into(trial, t - self.committed.t, full)?;
        if let Some(s) = self.trial.as_mut() {
            s.t = t;
            s.summary = summary;
        }
        self.trial_loaded = full;
        self.trial_particles = true;
        Ok(())
    }

    /// Reads the committed state's arrays (`state(False)`): all of them (`full`) or the
    /// particle arrays, keeping its time, step and summary; a failure ends the run.
    pub(super) fn load_committed(&mut self, full: bool) -> Result<(), StepError> {
        if self.committed_loaded || (self.committed_particles && !full) {
            return Ok(());
        }
        let py = self.obj.py();
        let dict = py_state(&self.obj, false).map_err(|e| self.fail(e))?;
        let (t, step, summary) = (
            self.committed.t,
            self.committed.step,
            self.committed.summary,
        );
        let read = match full {
            true => self.committed.read(&dict, &self.gravity, t, step),
            false => self.committed.read_particles(&dict, t, step),
        };
        match read {
            Ok(()) => {
                self.committed.summary = summary;
                self.committed_loaded = full;
                self.committed_particles = true;
                Ok(())
            }
            Err(f) => {
                let e = f.into_pyerr(py, "the committed state (state(False))");
                Err(self.fail(e))
            }
        }
    }
}
