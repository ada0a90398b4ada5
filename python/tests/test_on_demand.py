"""A stepper with a ``summary(trial)`` method hands over on demand: its summary after every
trial, its arrays (``state``) only when the controller asks for them."""

from __future__ import annotations

from typing import Any, Callable

import mpm_dt
import pytest
from test_summary import library_summary


class OnDemand:
    """The numpy bar handing over on demand: ``summary`` is the library's totals of the
    state (edited by `edit` on trials), ``state`` calls are counted."""

    def __init__(self, bar: Any, edit: Callable[[dict[str, Any]], Any] = lambda d: None) -> None:
        self.bar, self.edit, self.state_calls = bar, edit, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.bar, name)

    def state(self, trial: bool) -> dict[str, Any]:
        self.state_calls += 1
        s = self.bar.state(trial)
        s["summary"] = library_summary(self.bar, s)
        return s

    def summary(self, trial: bool) -> dict[str, Any]:
        totals = library_summary(self.bar, self.bar.state(trial))
        if trial:
            self.edit(totals)
        return totals


class Eager(OnDemand):
    """The same with no ``summary`` method: the arrays with every trial."""

    summary = None  # type: ignore[assignment]


def run(stepper: Any, t_end: float = 0.05, config: Any = None) -> list[dict[str, Any]]:
    decisions: list[dict[str, Any]] = []
    mpm_dt.Controller(dim=2, config=config or {}).run_until(stepper, t_end, decisions.append)
    return decisions


@pytest.mark.parametrize("rtol", [0.05, 0.5])
def test_on_demand_takes_the_eager_steps_reading_the_arrays_only_when_needed(bar: Any, rtol: float) -> None:
    """The same steps; the arrays are read for the temporal error's checks (every trial at
    the default tolerance on this strip, whose error binds: dsm 0.6), so only where its
    checks are deferred (rtol 0.5: dsm below 0.1) does the hand-over shrink."""
    config = {"temporal": {"rtol": rtol}}
    eager = Eager(bar)
    plain = run(eager, 0.5, config)
    bar.__init__(cells=8)
    lazy = OnDemand(bar)
    handed = run(lazy, 0.5, config)
    assert len(handed) == len(plain) > 20
    for a, b in zip(plain, handed):
        assert b["dt"] == pytest.approx(a["dt"], rel=1e-9) and b["binding"] == a["binding"]
    assert eager.state_calls > len(plain)
    if rtol == 0.05:
        assert lazy.state_calls >= len(plain)
    else:
        assert 3 * lazy.state_calls < 2 * eager.state_calls, (lazy.state_calls, eager.state_calls)


def test_a_summary_that_is_not_a_dict_is_a_type_error(bar: Any) -> None:
    class Listed(OnDemand):
        def summary(self, trial: bool) -> Any:
            return [1.0]
    with pytest.raises(mpm_dt.StateTypeError, match=r"summary\(False\) must return a dict"):
        run(Listed(bar), 0.01)


def test_step_failed_from_summary_is_retried(bar: Any) -> None:
    class FailsOnce(OnDemand):
        failed = False

        def summary(self, trial: bool) -> dict[str, Any]:
            if trial and not self.failed:
                self.failed = True
                raise mpm_dt.StepFailed("inverted in the solver's own check")
            return super().summary(trial)
    decisions = run(FailsOnce(bar), 0.01)
    assert decisions[0]["outcome"] == "rejected" and decisions[0]["cause"] == "non_finite"
    assert "inverted in the solver's own check" in decisions[0]["message"]
    assert decisions[1]["outcome"] == "accepted" and decisions[1]["dt"] < decisions[0]["dt"]


def test_a_non_finite_summary_reads_the_arrays_then_gives_up(bar: Any) -> None:
    lazy = OnDemand(bar, lambda d: d.update(kinetic=float("nan")))
    decisions: list[dict[str, Any]] = []
    with pytest.raises(mpm_dt.TooManyRejections, match="non-finite summary"):
        mpm_dt.Controller(dim=2).run_until(lazy, 0.01, decisions.append)
    assert decisions and all(d["cause"] == "non_finite" for d in decisions)
    # Each rejected trial's arrays were read, to name a particle if one was not finite.
    assert lazy.state_calls >= len(decisions)


def test_an_exception_in_summary_propagates_unchanged(bar: Any) -> None:
    class Broken(OnDemand):
        def summary(self, trial: bool) -> dict[str, Any]:
            if trial:
                raise KeyError("the solver's own bug")
            return super().summary(trial)
    with pytest.raises(KeyError, match="the solver's own bug"):
        run(Broken(bar), 0.01)
