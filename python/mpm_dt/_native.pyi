"""Type stubs of the native part of :mod:`mpm_dt` (see ``help(mpm_dt.Controller)``)."""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional, Protocol, Sequence, Union

import numpy as np
import numpy.typing as npt

FloatArray = Union[npt.NDArray[np.float64], npt.NDArray[np.float32]]
StateDict = dict[str, Any]
Decision = dict[str, Any]

class Stepper(Protocol):
    """What the controller calls on a Python solver."""

    def time(self) -> float: ...
    def try_step(self, dt: float) -> Optional[bool]: ...
    def accept(self) -> None: ...
    def reject(self) -> None: ...
    def state(self, trial: bool) -> StateDict: ...

class StepperOnDemand(Stepper, Protocol):
    """A stepper that hands over on demand: its summary after every trial, its arrays
    (``state``) only when the controller asks (``help(mpm_dt.Controller)``)."""

    def summary(self, trial: bool) -> dict[str, Any]: ...

class Controller:
    def __init__(
        self,
        dim: int,
        config: Optional[Mapping[str, Any]] = None,
        gravity: Optional[Sequence[float]] = None,
    ) -> None: ...
    def run_until(
        self,
        stepper: Stepper,
        t_end: float,
        on_decision: Optional[Callable[[Decision], object]] = None,
    ) -> dict[str, Any]: ...
    def step(
        self,
        stepper: Stepper,
        t_end: float = ...,
        on_decision: Optional[Callable[[Decision], object]] = None,
    ) -> Decision: ...
    @property
    def dim(self) -> int: ...
    @property
    def config(self) -> dict[str, Any]: ...
    @property
    def stats(self) -> dict[str, Any]: ...

def critical_dt(state: StateDict, full_map: bool = False) -> dict[str, Any]: ...
def max_stable_modulus(state: StateDict, dt: float, method: str = "eq56") -> float: ...
def read_state(state: StateDict) -> tuple[int, int]: ...
