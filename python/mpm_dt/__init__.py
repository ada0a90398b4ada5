"""mpm_dt: time steps for explicit Material Point Method solvers written in Python.

The Rust library mpm-dt chooses each step of an explicit MPM solver from the method's
own error and stability analysis (M. Berzins, *Time stepping with space and time errors
and stability of the Material Point Method*; equation numbers refer to it). This package
drives a solver written in Python -- numpy, taichi, warp -- through a small protocol:

    import mpm_dt
    ctrl = mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8))
    summary = ctrl.run_until(stepper, t_end, on_decision=None)
    decision = ctrl.step(stepper)

The stepper has ``time()``, ``try_step(dt)``, ``accept()``, ``reject()`` and
``state(trial) -> dict`` (the keys are listed in ``help(mpm_dt.critical_dt)``); with a
``summary(trial) -> dict`` method as well it hands over its arrays only when a limit
needs them (``help(mpm_dt.Controller)``).
``mpm_dt.critical_dt(state)`` and ``mpm_dt.max_stable_modulus(state, dt)`` answer "what
step is stable here" and "how stiff may the material be at this step" for one state.
"""

from __future__ import annotations

from ._errors import (
    ConfigError,
    ControllerError,
    GrowthPersists,
    InvalidEnd,
    NoProgress,
    StateError,
    StateTypeError,
    StepFailed,
    StepperError,
    StepTooSmall,
    TooManyRejections,
)
from ._native import Controller, critical_dt, max_stable_modulus, read_state

__all__ = [
    "Controller",
    "critical_dt",
    "max_stable_modulus",
    "read_state",
    "StepFailed",
    "ControllerError",
    "ConfigError",
    "StateError",
    "StateTypeError",
    "InvalidEnd",
    "NoProgress",
    "TooManyRejections",
    "StepTooSmall",
    "GrowthPersists",
    "StepperError",
]
