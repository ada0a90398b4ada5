//! A Python stepper as a Rust `Stepper<D>`: every call goes to the Python object (the
//! GIL is held for the whole run), and the states it reports are read into the package's
//! storage once — the committed state before the run, each trial right after
//! `try_step` — so that the library's views borrow Rust memory that no Python code can
//! change under them.
//!
//! Failures:
//! * `try_step` (or `state(True)`) raising `mpm_dt.StepFailed`, `try_step` returning
//!   `False`, or a trial state that is
//!   not finite, inverted (`det F ≤ 0`) or outside the grid: a `StepError` the controller
//!   retries with a smaller step;
//! * any other Python exception (in any method, in `on_decision`), or an invalid trial
//!   dict: kept here, the run is ended with `StepError::Other`, and the caller re-raises
//!   the kept exception unchanged (with its traceback).
//!
//! A stepper with a `summary(trial)` method hands over on demand ([`on_demand`]).

mod on_demand;

use crate::errors::is_step_failed;
use crate::state::{Fault, StateNd};
use mpm_dt::nd::{Vector, ViewNd};
use mpm_dt::{Dim, Dimension, StepError, Stepper};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::rc::Rc;

/// The first Python exception of a run, shared by the stepper and the decision callback.
pub type Pending = Rc<RefCell<Option<PyErr>>>;

/// The adapter (module docs).
pub struct PyStepper<'py, const D: usize> {
    obj: Bound<'py, PyAny>,
    gravity: Vector<D>,
    committed: Box<StateNd<D>>,
    trial: Option<Box<StateNd<D>>>,
    spare: Option<Box<StateNd<D>>>,
    step: u64,
    pending: Pending,
    /// Whether the stepper hands over its arrays on demand ([`on_demand`]).
    on_demand: bool,
    /// Whether the committed state's and the trial's arrays are read (always, unless
    /// [`Self::on_demand`]).
    committed_loaded: bool,
    trial_loaded: bool,
    /// Whether their particle arrays are read without the weights and nodal fields
    /// ([`Stepper::load_particles`]; the views are then `ViewNd::without_nodal`).
    committed_particles: bool,
    trial_particles: bool,
}

/// `obj.time()` as a float.
fn py_time(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    obj.call_method0("time")?.extract()
}

/// `obj.state(trial)` as a dict.
fn py_state<'py>(obj: &Bound<'py, PyAny>, trial: bool) -> PyResult<Bound<'py, PyDict>> {
    let s = obj.call_method1("state", (trial,))?;
    s.downcast_into::<PyDict>().map_err(|e| {
        crate::errors::state_type_error(
            obj.py(),
            format!(
                "state({trial}) must return a dict, got {}",
                e.into_inner().get_type()
            ),
        )
    })
}

impl<'py, const D: usize> PyStepper<'py, D> {
    /// Reads the committed state of `obj` (a `StateError` if it is invalid or not finite).
    /// `step` counts the accepted steps so far (the controller's statistics).
    pub fn new(
        obj: Bound<'py, PyAny>,
        gravity: Vector<D>,
        step: u64,
        pending: Pending,
    ) -> PyResult<Self> {
        let py = obj.py();
        let t = py_time(&obj)?;
        if !t.is_finite() {
            return Err(crate::errors::state_error(
                py,
                format!("time() = {t} is not finite"),
            ));
        }
        let dict = py_state(&obj, false)?;
        let mut committed = Box::<StateNd<D>>::default();
        committed
            .read(&dict, &gravity, t, step)
            .map_err(|f| f.into_pyerr(py, "the committed state (state(False))"))?;
        let on_demand = on_demand::offers(&obj)?;
        if on_demand {
            committed.summary = Some(
                on_demand::py_summary(&obj, false)
                    .map_err(|f| f.into_pyerr(py, "the committed summary (summary(False))"))?,
            );
        }
        Ok(Self {
            obj,
            gravity,
            committed,
            trial: None,
            spare: None,
            step,
            pending,
            on_demand,
            committed_loaded: true,
            trial_loaded: false,
            committed_particles: false,
            trial_particles: false,
        })
    }

    /// The committed state.
    pub fn committed(&self) -> &StateNd<D> {
        &self.committed
    }

    /// Keeps `e` (the first one only) and returns the error that ends the run.
    fn fail(&self, e: PyErr) -> StepError {
        let msg = format!("Python exception: {e}");
        self.pending.borrow_mut().get_or_insert(e);
        StepError::Other(msg)
    }

    /// The trial's failure as a retryable `StepError`, or the run's end.
    fn trial_fault(&self, fault: Fault, dt: f64) -> StepError {
        let (t, step) = (self.committed.t, self.step);
        match fault {
            // No particle to name: the message says which total (the controller treats a
            // failed trial as a non-finite one).
            Fault::NonFiniteSummary(what) => StepError::Failed {
                message: format!("non-finite {what}"),
                t,
                step,
                dt,
            },
            Fault::NonFinite(field, index) => StepError::NonFinite {
                field,
                index,
                t,
                step,
                dt,
            },
            Fault::Inverted(index, det_f) => StepError::Inverted {
                index,
                det_f,
                t,
                step,
                dt,
            },
            Fault::OutOfGrid(index, axis, x) => StepError::OutOfDomain {
                index,
                axis,
                x,
                t,
                step,
                dt,
            },
            Fault::Invalid(e) => self.fail(e),
        }
    }
}

impl<const D: usize> Stepper<D> for PyStepper<'_, D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    fn time(&self) -> f64 {
        self.committed.t
    }

    fn step_count(&self) -> u64 {
        self.step
    }

    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        if let Some(old) = self.trial.take() {
            self.spare = Some(old);
        }
        if self.pending.borrow().is_some() {
            return Err(StepError::Other("a Python exception is pending".into()));
        }
        let py = self.obj.py();
        let (t, step) = (self.committed.t, self.step);
        self.trial_loaded = false;
        self.trial_particles = false;
        match self.obj.call_method1("try_step", (dt,)) {
            Err(e) if is_step_failed(py, &e) => {
                return Err(StepError::Failed {
                    message: format!("StepFailed: {}", e.value(py)),
                    t,
                    step,
                    dt,
                })
            }
            Err(e) => return Err(self.fail(e)),
            Ok(r) if r.is(pyo3::types::PyBool::new(py, false)) => {
                return Err(StepError::Failed {
                    message: "try_step returned False".into(),
                    t,
                    step,
                    dt,
                })
            }
            Ok(_) => {}
        }
        if self.on_demand {
            return self.summary_of_trial(dt);
        }
        self.read_trial(dt)
    }

    fn accept(&mut self) -> Result<(), StepError> {
        let Some(mut trial) = self.trial.take() else {
            return Err(StepError::NoTrial);
        };
        if let Err(e) = self.obj.call_method0("accept") {
            self.spare = Some(trial);
            return Err(self.fail(e));
        }
        // The solver's own clock: a solver that does not advance it ends the run with
        // the controller's `NoProgress`.
        trial.t = py_time(&self.obj).map_err(|e| self.fail(e))?;
        self.step += 1;
        self.spare = Some(std::mem::replace(&mut self.committed, trial));
        self.committed_loaded = self.trial_loaded || !self.on_demand;
        self.committed_particles = self.trial_particles;
        self.trial_loaded = false;
        self.trial_particles = false;
        Ok(())
    }

    fn reject(&mut self) {
        if let Some(old) = self.trial.take() {
            self.spare = Some(old);
        }
        self.trial_loaded = false;
        self.trial_particles = false;
        if let Err(e) = self.obj.call_method0("reject") {
            let _ = self.fail(e);
        }
    }

    fn view(&self) -> ViewNd<'_, D> {
        match (self.committed_loaded, self.committed_particles) {
            (true, _) => self.committed.view(),
            (false, true) => self.committed.view().without_nodal(),
            (false, false) => on_demand::summary_only(&self.committed),
        }
    }

    fn trial_view(&self) -> Option<ViewNd<'_, D>> {
        let trial = self.trial.as_ref()?;
        Some(
            match (self.trial_loaded || !self.on_demand, self.trial_particles) {
                (true, _) => trial.view(),
                (false, true) => trial.view().without_nodal(),
                (false, false) => on_demand::summary_only(trial),
            },
        )
    }

    fn provide_arrays_on_demand(&mut self, on: bool) -> bool {
        on && self.on_demand
    }

    fn load_arrays(&mut self, trial: bool) -> Result<(), StepError> {
        match trial {
            true => self.load_trial(true),
            false => self.load_committed(true),
        }
    }

    fn load_particles(&mut self, trial: bool) -> Result<(), StepError> {
        match trial {
            true => self.load_trial(false),
            false => self.load_committed(false),
        }
    }
}

impl<const D: usize> PyStepper<'_, D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// Reads the trial's state dict (`state(True)`) into the package's storage, after the
    /// solver's `try_step(dt)`.
    fn read_trial(&mut self, dt: f64) -> Result<(), StepError> {
        let s = self.spare.take().unwrap_or_default();
        self.read_trial_into(s, dt, true)
    }

    /// [`Self::read_trial`] into the storage `s`: all of it (`full`) or the particle
    /// arrays (`StateNd::read_particles`).
    fn read_trial_into(
        &mut self,
        mut s: Box<StateNd<D>>,
        dt: f64,
        full: bool,
    ) -> Result<(), StepError> {
        let py = self.obj.py();
        let (t, step) = (self.committed.t, self.step);
        let dict = match py_state(&self.obj, true) {
            Ok(d) => d,
            // The solver's own check of the trial, in `state(True)`: retried too.
            Err(e) if is_step_failed(py, &e) => {
                self.spare = Some(s);
                return Err(StepError::Failed {
                    message: format!("StepFailed: {}", e.value(py)),
                    t,
                    step,
                    dt,
                });
            }
            Err(e) => {
                self.spare = Some(s);
                return Err(self.fail(e));
            }
        };
        let read = match full {
            true => s.read(&dict, &self.gravity, t + dt, step + 1),
            false => s.read_particles(&dict, t + dt, step + 1),
        };
        match read {
            Ok(()) => {
                self.trial = Some(s);
                Ok(())
            }
            Err(f) => {
                self.spare = Some(s);
                Err(self.trial_fault(f, dt))
            }
        }
    }
}
