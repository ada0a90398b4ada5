"""The exceptions of :mod:`mpm_dt`.

Library errors derive from :class:`ControllerError` and carry the library's message.
:class:`StepFailed` is the one a stepper raises (or signals by returning ``False`` from
``try_step``) for a failure that a smaller step may cure.
"""

from __future__ import annotations

from typing import Any, Optional


class StepFailed(Exception):
    """Raised by a stepper's ``try_step`` for a retryable failure: the controller rejects
    the trial and retries with a smaller step (like a non-finite trial state)."""


class ControllerError(Exception):
    """The controller stopped: the library's error, with its message.

    ``decision`` is the last attempt's decision (a dict) when the library reports one
    (``TooManyRejections``, ``StepTooSmall``), else ``None``.
    """

    decision: Optional[dict[str, Any]] = None


class ConfigError(ControllerError, ValueError):
    """The controller configuration is invalid (unknown key, value out of range)."""


class StateError(ControllerError, ValueError):
    """A state dict is invalid: a missing key, a wrong shape, a non-positive mass, a
    non-finite value in a committed state, a particle outside the grid."""


class StateTypeError(StateError, TypeError):
    """A state field has a type or dtype mpm_dt does not read (integers, complex, objects)."""


class InvalidEnd(ControllerError, ValueError):
    """``t_end`` is not after the stepper's time."""


class NoProgress(ControllerError):
    """The stepper accepted a trial of step ``dt`` but its ``time()`` did not advance by it."""


class TooManyRejections(ControllerError):
    """One step was rejected ``max_consecutive_rejections`` times in a row."""


class StepTooSmall(ControllerError):
    """The step fell below ``dt_min`` (or too small to advance ``t`` in floating point)."""


class GrowthPersists(ControllerError):
    """The energy kept growing at every step the limits proposed (see the growth monitor)."""


class StepperError(ControllerError):
    """The stepper failed in a way a smaller step cannot fix (other than a Python
    exception, which propagates unchanged)."""


__all__ = [
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
