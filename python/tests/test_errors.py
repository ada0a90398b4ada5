"""Every failure path: each a Python exception, none a crash of the interpreter."""

from __future__ import annotations

import traceback
from typing import Any, Callable

import numpy as np
import pytest
from conftest import numpy_bar

import mpm_dt


class Wrapped:
    """A stepper delegating to the numpy strip, with one method or state replaced."""

    def __init__(self, inner: Any, **overrides: Callable[..., Any]) -> None:
        self.inner = inner
        self.overrides = overrides

    def __getattr__(self, name: str) -> Any:
        return self.overrides.get(name, getattr(self.inner, name))


def edited_state(inner: Any, trial_only: bool, edit: Callable[[dict[str, Any]], None]) -> Callable[[bool], dict[str, Any]]:
    def state(trial: bool) -> dict[str, Any]:
        s = dict(inner.state(trial))
        if trial or not trial_only:
            edit(s)
        return s
    return state


def test_exception_in_try_step_propagates_unchanged(bar: Any) -> None:
    def try_step(dt: float) -> None:
        raise RuntimeError("solver exploded")
    with pytest.raises(RuntimeError, match="solver exploded") as info:
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, try_step=try_step), 0.01)
    # The traceback reaches into the stepper's own frame.
    assert any(f.name == "try_step" for f in traceback.extract_tb(info.value.__traceback__))


@pytest.mark.parametrize("method", ["accept", "reject", "time"])
def test_exception_in_other_methods_propagates(bar: Any, method: str) -> None:
    def boom(*args: Any) -> None:
        raise KeyError(method)
    if method == "reject":
        # Reject is only called after a rejected trial: fail the first trial.
        calls = {"n": 0}

        def try_step(dt: float) -> None:
            calls["n"] += 1
            if calls["n"] == 1:
                raise mpm_dt.StepFailed("first trial fails")
            bar.try_step(dt)
        stepper = Wrapped(bar, reject=boom, try_step=try_step)
    else:
        stepper = Wrapped(bar, **{method: boom})
    with pytest.raises(KeyError):
        mpm_dt.Controller(dim=2).run_until(stepper, 0.01)


def test_exception_in_on_decision_propagates(bar: Any) -> None:
    def on_decision(d: dict[str, Any]) -> None:
        raise ValueError("callback failed")
    with pytest.raises(ValueError, match="callback failed"):
        mpm_dt.Controller(dim=2).run_until(bar, 0.01, on_decision=on_decision)
    # The run stopped at the first decision.
    assert bar.time() > 0 and bar.time() < 0.01


def test_step_failed_is_retried_with_a_smaller_step(bar: Any) -> None:
    calls = {"n": 0}

    def try_step(dt: float) -> None:
        calls["n"] += 1
        if calls["n"] == 2:
            raise mpm_dt.StepFailed("Newton did not converge")
        bar.try_step(dt)
    decisions: list[dict[str, Any]] = []
    summary = mpm_dt.Controller(dim=2).run_until(Wrapped(bar, try_step=try_step), 0.01, decisions.append)
    assert summary["steps_rejected"] == 1 and summary["t_final"] == pytest.approx(0.01)
    rejected = decisions[1]
    assert rejected["outcome"] == "rejected" and rejected["rejected_by"] == "stepper"
    assert "Newton did not converge" in rejected["message"]
    assert decisions[2]["dt"] < rejected["dt"]


def test_try_step_returning_false_is_retried_then_gives_up(bar: Any) -> None:
    with pytest.raises(mpm_dt.TooManyRejections) as info:
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, try_step=lambda dt: False), 0.01)
    assert isinstance(info.value, mpm_dt.ControllerError)
    assert "consecutive rejections" in str(info.value)
    assert info.value.decision is not None and info.value.decision["outcome"] == "rejected"
    assert "returned False" in info.value.decision["message"]


def test_nan_in_the_committed_state_is_a_state_error(bar: Any) -> None:
    def edit(s: dict[str, Any]) -> None:
        s["x"] = s["x"].copy()
        s["x"][3, 1] = np.nan
    with pytest.raises(mpm_dt.StateError, match="non-finite x at particle 3"):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, state=edited_state(bar, False, edit)), 0.01)
    with pytest.raises(mpm_dt.StateError, match="non-finite x at particle 3"):
        mpm_dt.critical_dt(edited_state(bar, False, edit)(False))


def test_nan_in_every_trial_is_rejected_then_gives_up(bar: Any) -> None:
    def edit(s: dict[str, Any]) -> None:
        s["stress"] = np.full_like(s["stress"], np.nan)
    decisions: list[dict[str, Any]] = []
    with pytest.raises(mpm_dt.TooManyRejections, match="non-finite stress"):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, state=edited_state(bar, True, edit)), 0.01, decisions.append)
    assert all(d["cause"] == "non_finite" for d in decisions)
    assert [d["dt"] for d in decisions] == sorted((d["dt"] for d in decisions), reverse=True)


@pytest.mark.parametrize("key, value, match", [
    ("v", np.zeros((5, 2)), r"state\[\"v\"\] has shape \(5, 2\), expected \(128, 2\)"),
    ("F", np.zeros((128, 3, 3)), r"shape \(128, 3, 3\), expected \(128, 2, 2\)"),
    ("mass", np.ones((128, 1)), r"mass.*shape \(n,\)"),
    ("cells", (8, 4, 2), "cells"),
    ("shape", "cubic", "shape \"cubic\""),
    ("boundary", "open", "boundary \"open\""),
    ("volume0", -np.ones(128), r"volume0.*not a positive number"),
    ("transfer", "apic", "\"bspline2\" only"),
])
def test_invalid_fields_are_state_errors(bar: Any, key: str, value: Any, match: str) -> None:
    def edit(s: dict[str, Any]) -> None:
        s[key] = value
    with pytest.raises(mpm_dt.StateError, match=match):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, state=edited_state(bar, False, edit)), 0.01)


def test_invalid_trial_ends_the_run(bar: Any) -> None:
    def edit(s: dict[str, Any]) -> None:
        del s["v"]
    with pytest.raises(mpm_dt.StateError, match="missing key \"v\""):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, state=edited_state(bar, True, edit)), 0.01)


@pytest.mark.parametrize("dtype", [np.int64, np.complex128, object])
def test_wrong_dtypes_are_type_errors(bar: Any, dtype: Any) -> None:
    s = dict(bar.state(False))
    s["mass"] = np.ones(128, dtype=dtype)
    with pytest.raises(mpm_dt.StateTypeError, match="dtype") as info:
        mpm_dt.critical_dt(s)
    assert isinstance(info.value, TypeError)


def test_state_must_be_a_dict(bar: Any) -> None:
    with pytest.raises(mpm_dt.StateTypeError, match="must return a dict"):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, state=lambda trial: [1, 2]), 0.01)


def test_time_that_does_not_advance_is_no_progress(bar: Any) -> None:
    with pytest.raises(mpm_dt.NoProgress, match="did not advance"):
        mpm_dt.Controller(dim=2).run_until(Wrapped(bar, time=lambda: 0.0), 0.01)


def test_t_end_not_after_time_is_invalid_end(bar: Any) -> None:
    with pytest.raises(mpm_dt.InvalidEnd):
        mpm_dt.Controller(dim=2).run_until(bar, 0.0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(dim=4), "dim = 4"),
    (dict(dim=2, config={"no_such_key": 1}), "no_such_key"),
    (dict(dim=2, config={"safety": -1.0}), "safety"),
    (dict(dim=2, gravity=(0.0, 1.0, 2.0)), "gravity"),
    (dict(dim=2, config={"gravity": [0.0, -9.8, 0.0]}), "gravity"),
    (dict(dim=2, config={"gravity": [0.0, -9.8]}, gravity=(0.0, -1.0)), "contradicts"),
])
def test_invalid_controllers_are_config_errors(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(mpm_dt.ConfigError, match=match):
        mpm_dt.Controller(**kwargs)


def test_max_stable_modulus_needs_a_positive_step_and_a_known_method(bar: Any) -> None:
    with pytest.raises(mpm_dt.StateError, match="dt"):
        mpm_dt.max_stable_modulus(bar.state(False), 0.0)
    with pytest.raises(mpm_dt.StateError, match="method"):
        mpm_dt.max_stable_modulus(bar.state(False), 0.01, method="guess")
    # The full map from the nodes reaches past the dense map's 400 unknowns: the
    # 128-particle strip (640) gets it, between eq 56's answer and twice it (the
    # reduction's bounds, sqrt(2) on the step).
    e56 = mpm_dt.max_stable_modulus(bar.state(False), 0.01)
    e_full = mpm_dt.max_stable_modulus(bar.state(False), 0.01, method="full_map")
    assert e56 < e_full <= 2 * e56
    # Above 20 000 nodal unknowns (2 600 x 4 periodic cells, 2 per node) it is refused.
    big = numpy_bar.NumpyBar(cells=2600)
    with pytest.raises(mpm_dt.StateError, match="at most 20000 active nodal unknowns"):
        mpm_dt.max_stable_modulus(big.state(False), 0.01, method="full_map")
