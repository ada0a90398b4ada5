"""The API: Controller.run_until, Controller.step, decisions, logging, float32 input."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
import pytest

import mpm_dt
from conftest import numpy_bar

DECISION_FIELDS = {
    "step", "attempt", "t", "dt", "limits", "filter_dt", "binding", "bound58",
    "lambda_max", "dsm", "outcome", "cause", "rejected_by", "message",
}


def test_run_until_reaches_t_end_and_summarises(bar: Any) -> None:
    decisions: list[dict[str, Any]] = []
    ctrl = mpm_dt.Controller(dim=2, config={}, gravity=(0.0, 0.0))
    summary = ctrl.run_until(bar, 0.05, on_decision=decisions.append)
    assert summary["t_final"] == pytest.approx(0.05, rel=1e-12)
    assert bar.time() == pytest.approx(0.05, rel=1e-12)
    assert summary["steps_accepted"] > 0
    assert summary["steps_accepted"] + summary["steps_rejected"] == len(decisions)
    assert summary["dt_min"] <= summary["dt_mean"] <= summary["dt_max"]
    assert sum(summary["binding"].values()) == summary["steps_accepted"]
    accepted = [d for d in decisions if d["outcome"] == "accepted"]
    chosen = [d["dt"] for d in accepted if d["binding"] != "t_end"]
    assert summary["dt_min_chosen"] == min(chosen)
    assert summary["dt_min"] == min(d["dt"] for d in accepted)
    assert len(accepted) == summary["steps_accepted"]
    # The steps add up to the time covered.
    assert sum(d["dt"] for d in accepted) == pytest.approx(0.05, rel=1e-9)
    assert ctrl.stats["steps_accepted"] == summary["steps_accepted"]


def test_decision_fields(bar: Any) -> None:
    ctrl = mpm_dt.Controller(dim=2)
    d = ctrl.step(bar)
    assert set(d) == DECISION_FIELDS
    assert d["outcome"] == "accepted" and d["cause"] is None
    assert d["step"] == 0 and d["attempt"] == 1 and d["t"] == 0.0
    assert bar.time() == pytest.approx(d["dt"], rel=1e-15)
    names = [rec["name"] for rec in d["limits"]]
    assert "stability" in names and "sound_speed" in names
    # The stability limit reports the tracked lambda_max; the step respects its bound.
    lam = d["lambda_max"]
    assert lam is not None and lam > 0
    assert d["dt"] <= math.sqrt(2.0 / lam) * (1 + 1e-12)
    for rec in d["limits"]:
        assert set(rec) == {"name", "proposal", "verdict", "metrics"}
    d2 = ctrl.step(bar)
    assert d2["step"] == 1 and d2["t"] == pytest.approx(d["dt"], rel=1e-15)


def test_step_respects_t_end(bar: Any) -> None:
    ctrl = mpm_dt.Controller(dim=2)
    d = ctrl.step(bar, t_end=1e-5)
    assert d["dt"] <= 1e-5 and bar.time() == pytest.approx(1e-5, rel=1e-12)


def test_decisions_are_logged(bar: Any, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.DEBUG, logger="mpm_dt"):
        mpm_dt.Controller(dim=2).step(bar)
    records = [r for r in caplog.records if r.name == "mpm_dt"]
    assert len(records) == 1 and records[0].levelno == logging.DEBUG
    assert '"outcome":"accepted"' in records[0].getMessage()


def test_float32_and_non_contiguous_arrays_give_the_same_steps(bar: Any) -> None:
    base = bar.state(False)
    variants = {
        "float64": base,
        "float32": {k: (v.astype(np.float32) if isinstance(v, np.ndarray) and v.dtype == np.float64 else v)
                    for k, v in base.items()},
        # A Fortran-ordered copy: same values, not C-contiguous.
        "fortran": {k: (np.asfortranarray(v) if isinstance(v, np.ndarray) else v) for k, v in base.items()},
    }
    crit = {name: mpm_dt.critical_dt(s) for name, s in variants.items()}
    assert crit["fortran"]["lambda_max"] == pytest.approx(crit["float64"]["lambda_max"], rel=1e-12)
    assert crit["float32"]["lambda_max"] == pytest.approx(crit["float64"]["lambda_max"], rel=1e-5)


def test_config_is_applied(bar: Any) -> None:
    ctrl = mpm_dt.Controller(dim=2, config={"dt_max": 1e-4})
    d = ctrl.step(bar)
    assert d["dt"] <= 1e-4 and d["binding"] == "dt_max"
    assert ctrl.config == {"dt_max": 1e-4}
    assert "Controller(dim=2" in repr(ctrl)


def test_help_reads_like_docs() -> None:
    doc = mpm_dt.Controller.__doc__ or ""
    assert "try_step" in doc and "StepFailed" in doc and "eq 56" in doc
    assert "E_max" in (mpm_dt.max_stable_modulus.__doc__ or "")
    assert "dt_eq56" in (mpm_dt.critical_dt.__doc__ or "")


def test_gravity_from_the_config_is_the_gravity_argument() -> None:
    def dts(**kwargs: Any) -> list[float]:
        decisions: list[dict[str, Any]] = []
        mpm_dt.Controller(dim=2, **kwargs).run_until(numpy_bar.NumpyBar(cells=8), 0.05, decisions.append)
        return [d["dt"] for d in decisions]

    by_argument = dts(gravity=(0.0, -1.0))
    assert dts(config={"gravity": [0.0, -1.0]}) == by_argument
    assert dts(config={"gravity": [0.0, -1.0]}, gravity=(0.0, -1.0)) == by_argument
