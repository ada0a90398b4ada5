//! `mpm_dt.Controller`: the library's adaptive controller with its standard limits,
//! driving a Python stepper.

use crate::convert::{decision_dict, summary_dict};
use crate::errors::{controller_error, error};
use crate::stepper::{Pending, PyStepper};
use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig, Decision, Outcome};
use mpm_dt::limits_nd::TransferNd;
use mpm_dt::nd::{Vector, ViewNd};
use mpm_dt::{Dim, Dimension};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::rc::Rc;

/// Python's `logging` levels the decisions are logged at.
const DEBUG: u8 = 10;
const INFO: u8 = 20;

/// The library controller of one dimension, built at the first run (its stability limit
/// analyses the transfer the first state names).
struct Slot<const D: usize>
where
    Dim<D>: Dimension,
{
    controller: Option<Controller<D>>,
}

/// What a run hands back.
enum Ask {
    /// `run_until(t_end)`: the summary.
    Run(f64),
    /// `step(t_end)`: the accepted step's decision.
    Step(f64),
}

/// Sends one decision to `on_decision` (as a dict) and to the `mpm_dt` logger (the JSON
/// line: DEBUG for an accepted attempt, INFO for a rejected one).
fn emit(
    py: Python<'_>,
    logger: &Bound<'_, PyAny>,
    on_decision: Option<&Bound<'_, PyAny>>,
    d: &Decision,
) -> PyResult<()> {
    let level = if d.outcome == Outcome::Accepted {
        DEBUG
    } else {
        INFO
    };
    if logger.call_method1("isEnabledFor", (level,))?.is_truthy()? {
        logger.call_method1("log", (level, "%s", d.to_json_line()))?;
    }
    if let Some(f) = on_decision {
        f.call1((decision_dict(py, d)?,))?;
    }
    Ok(())
}

impl<const D: usize> Slot<D>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    /// The standard limits of `config` (sound speed, stability, temporal error, growth),
    /// the stability limit analysing `transfer`.
    fn build(
        py: Python<'_>,
        config: &ControllerConfig,
        gravity: Vector<D>,
        transfer: TransferNd,
    ) -> PyResult<Controller<D>> {
        let mut config = config.clone();
        // The state's `"transfer"` when it names one; else the config's `stability_nd`.
        if transfer != TransferNd::Flip {
            config.stability_nd.transfer = transfer;
        }
        let limits = standard_limits::<D>(&config, gravity);
        Controller::new(config, limits).map_err(|e| controller_error(py, &e))
    }

    fn run<'py>(
        &mut self,
        py: Python<'py>,
        config: &ControllerConfig,
        gravity: &[f64],
        stepper: Bound<'py, PyAny>,
        on_decision: Option<Bound<'py, PyAny>>,
        ask: Ask,
    ) -> PyResult<Bound<'py, PyAny>> {
        let gravity = Vector::<D>::from_column_slice(gravity);
        let pending: Pending = Rc::new(RefCell::new(None));
        let step0 = self.controller.as_ref().map_or(0, |c| c.stats().accepted);
        let mut st = PyStepper::<D>::new(stepper, gravity, step0, Rc::clone(&pending))?;
        if self.controller.is_none() {
            self.controller = Some(Self::build(py, config, gravity, st.committed().transfer)?);
        }
        let Some(ctrl) = self.controller.as_mut() else {
            unreachable!("built just above")
        };
        let logger = py
            .import("logging")?
            .call_method1("getLogger", ("mpm_dt",))?;
        let mut on = |d: &Decision| {
            if pending.borrow().is_none() {
                if let Err(e) = emit(py, &logger, on_decision.as_ref(), d) {
                    *pending.borrow_mut() = Some(e);
                }
            }
        };
        let out = match ask {
            Ask::Run(t_end) => ctrl.run_until(&mut st, t_end, &mut on).map(|_| None),
            Ask::Step(t_end) => ctrl.step(&mut st, t_end).map(|ds| {
                ds.iter().for_each(&mut on);
                ds.into_iter().last()
            }),
        };
        // A Python exception ends the run as it was raised.
        if let Some(e) = pending.borrow_mut().take() {
            return Err(e);
        }
        match out {
            Err(e) => Err(controller_error(py, &e)),
            Ok(Some(d)) => decision_dict(py, &d),
            Ok(None) => Ok(summary_dict(py, ctrl.stats(), st.committed().t)?.into_any()),
        }
    }
}

/// The adaptive time-step controller of mpm-dt, driving a solver written in Python.
///
/// ``Controller(dim, config=None, gravity=None)``
///
/// * ``dim`` -- 2 or 3, the solver's spatial dimension;
/// * ``config`` -- the controller configuration as a dict, the JSON ``ControllerConfig`` of
///   the Rust library (e.g. ``{"stability": {"safety": 0.9}, "temporal": {"enabled":
///   False}}``); ``None`` for the defaults. Unknown keys raise ``ConfigError``;
/// * ``gravity`` -- the body force, ``dim`` floats (zero by default; the config's
///   ``"gravity"`` may give it instead).
///
/// The controller applies the library's standard limits as ``config`` enables them: the
/// sound-speed cap ``alpha * min_p min_a h_a / (c_p + |v_a|)`` (eq 49), the stability
/// limit ``safety * sqrt(2 / lambda_max(M^-1 K))`` with ``lambda_max`` tracked by Lanczos
/// (eq 56; for ``"transfer": "apic"`` the APIC bound ``sqrt(2 (1 + p) / lambda_max)``), the
/// temporal-error estimate (eqs 20-30) and the energy-growth monitor.
///
/// The stepper is any object with ``time() -> float``, ``try_step(dt)`` (compute a trial
/// state at ``time() + dt`` beside the committed one; raise ``mpm_dt.StepFailed`` or
/// return ``False`` for a failure that a smaller step may cure), ``accept()`` (the trial
/// becomes the committed state; ``time()`` must then have advanced by ``dt``),
/// ``reject()`` (discard the trial; also called after a failed ``try_step``, when no
/// trial is pending) and ``state(trial: bool) -> dict`` (see
/// ``mpm_dt.critical_dt`` for the keys). Any other exception raised by the stepper or by
/// ``on_decision`` ends the run and propagates unchanged.
///
/// A stepper that also has ``summary(trial: bool) -> dict`` hands over on demand: after
/// each trial the controller reads only that dict (the keys of a state's ``"summary"``:
/// ``kinetic``, ``strain``, ``first_moment``, and for the saving ``element_bound`` and
/// ``sound_unit_step``) and calls ``state(trial)`` only when a limit needs the arrays (a
/// ``lambda_max`` refresh or the layout check on its cadence, a temporal-error check, the
/// state check every 64 steps, a summary that is not finite). A state whose arrays are not
/// read is not checked by the package: such a stepper raises ``mpm_dt.StepFailed`` itself
/// (in ``try_step`` or ``summary(True)``) for a particle outside the grid or inverted. For
/// a solver whose particles live on a GPU this avoids copying them out at every step.
///
/// Every attempt's decision goes to ``on_decision`` (a dict with the fields of the Rust
/// ``Decision``: ``step``, ``attempt``, ``t``, ``dt``, ``limits``, ``filter_dt``,
/// ``binding``, ``bound58``, ``lambda_max``, ``dsm``, ``outcome``, ``cause``,
/// ``rejected_by``, ``message``) and, as a JSON line, to the ``logging`` logger
/// ``"mpm_dt"`` (DEBUG for accepted attempts, INFO for rejected ones).
///
/// The limits are built at the first run, from the first state (its ``"transfer"``), and
/// keep their state (the tracked ``lambda_max``, the filter's history) from call to call:
/// one controller per run. Example::
///
///     ctrl = mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8))
///     summary = ctrl.run_until(solver, 0.5, on_decision=print)
///     print(summary["steps_accepted"], summary["dt_mean"], summary["binding"])
#[pyclass(name = "Controller", module = "mpm_dt", unsendable)]
pub struct PyController {
    dim: usize,
    config: ControllerConfig,
    config_json: String,
    gravity: Vec<f64>,
    d2: Slot<2>,
    d3: Slot<3>,
}

#[pymethods]
impl PyController {
    #[new]
    #[pyo3(signature = (dim, config = None, gravity = None))]
    fn new(
        py: Python<'_>,
        dim: usize,
        config: Option<Bound<'_, PyDict>>,
        gravity: Option<Vec<f64>>,
    ) -> PyResult<Self> {
        if !(2..=3).contains(&dim) {
            return Err(error(
                py,
                "ConfigError",
                format!("dim = {dim}: mpm_dt drives 2D and 3D Python solvers (dim 2 or 3)"),
            ));
        }
        let config_json = match config {
            Some(c) => py
                .import("json")?
                .call_method1("dumps", (c,))?
                .extract::<String>()?,
            None => "{}".to_string(),
        };
        let mut config = ControllerConfig::from_json(&config_json)
            .map_err(|e| error(py, "ConfigError", e.to_string()))?;
        config
            .validate()
            .map_err(|e| error(py, "ConfigError", e.to_string()))?;
        // The body force from the argument or the config's `"gravity"` (the same value if
        // both are given), zero when neither is.
        if let (Some(arg), Some(set)) = (&gravity, &config.gravity) {
            if arg != set {
                return Err(error(
                    py,
                    "ConfigError",
                    format!("gravity = {arg:?} contradicts config[\"gravity\"] = {set:?}"),
                ));
            }
        }
        let gravity = gravity
            .or_else(|| config.gravity.clone())
            .unwrap_or_else(|| vec![0.0; dim]);
        if gravity.len() != dim || gravity.iter().any(|g| !g.is_finite()) {
            return Err(error(
                py,
                "ConfigError",
                format!("gravity must be {dim} finite numbers, got {gravity:?}"),
            ));
        }
        config.gravity = Some(gravity.clone());
        Ok(Self {
            dim,
            config,
            config_json,
            gravity,
            d2: Slot { controller: None },
            d3: Slot { controller: None },
        })
    }

    /// Advances ``stepper`` to ``t_end`` and returns the controller's statistics (since it
    /// was made) as a dict: ``steps_accepted``, ``steps_rejected``, ``dt_mean``, ``dt_min``
    /// (the last step, cut to land on ``t_end``, included), ``dt_min_chosen`` (without the
    /// steps cut to land on ``t_end``), ``dt_max``, ``t_final``, ``binding`` (accepted steps per bound that set ``dt``),
    /// ``rejected_by_cause``, ``growth_events``.
    #[pyo3(signature = (stepper, t_end, on_decision = None))]
    fn run_until<'py>(
        &mut self,
        py: Python<'py>,
        stepper: Bound<'py, PyAny>,
        t_end: f64,
        on_decision: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.drive(py, stepper, on_decision, Ask::Run(t_end))
    }

    /// Advances ``stepper`` by one accepted step (retrying rejected attempts, whose
    /// decisions go to ``on_decision``; never past ``t_end``) and returns that step's
    /// decision as a dict. Each call reads the stepper's committed state once more
    /// (``state(False)``), which ``run_until`` does only at its start.
    #[pyo3(signature = (stepper, t_end = f64::INFINITY, on_decision = None))]
    #[pyo3(text_signature = "(self, stepper, t_end=math.inf, on_decision=None)")]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        stepper: Bound<'py, PyAny>,
        t_end: f64,
        on_decision: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.drive(py, stepper, on_decision, Ask::Step(t_end))
    }

    /// The spatial dimension.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
    }

    /// The configuration as given (a dict).
    #[getter]
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.config_json.as_str(),))
    }

    /// The controller's statistics so far (the dict ``run_until`` returns, without
    /// ``t_final``).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let stats = match self.dim {
            2 => self.d2.controller.as_ref().map(|c| c.stats().clone()),
            _ => self.d3.controller.as_ref().map(|c| c.stats().clone()),
        }
        .unwrap_or_default();
        let d = summary_dict(py, &stats, f64::NAN)?;
        d.del_item("t_final")?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "mpm_dt.Controller(dim={}, config={}, gravity={:?})",
            self.dim, self.config_json, self.gravity
        )
    }
}

impl PyController {
    fn drive<'py>(
        &mut self,
        py: Python<'py>,
        stepper: Bound<'py, PyAny>,
        on_decision: Option<Bound<'py, PyAny>>,
        ask: Ask,
    ) -> PyResult<Bound<'py, PyAny>> {
        match self.dim {
            2 => self
                .d2
                .run(py, &self.config, &self.gravity, stepper, on_decision, ask),
            _ => self
                .d3
                .run(py, &self.config, &self.gravity, stepper, on_decision, ask),
        }
    }
}
