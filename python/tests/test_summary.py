"""The state dict's optional "summary": totals a solver hands over from its own passes."""

from __future__ import annotations

from typing import Any, Callable

import mpm_dt
import numpy as np
import pytest


def library_summary(bar: Any, s: dict[str, Any]) -> dict[str, Any]:
    """What the library computes from the state itself (growth energies, sound-speed step)."""
    lam, mu = bar.lam, bar.mu
    vol = np.linalg.det(s["F"]) * bar.volume0
    sig = s["stress"]
    tr = np.trace(sig, axis1=1, axis2=2)
    strain = 0.5 * vol * ((sig**2).sum((1, 2)) - lam * tr * tr / (2 * mu + 2 * lam)) / (2 * mu)
    c = np.sqrt((lam + 2 * mu) * vol / bar.mass)
    return dict(kinetic=float(0.5 * bar.mass @ (s["v"] ** 2).sum(1)), strain=float(strain.sum()),
                first_moment=bar.mass @ s["x"],
                sound_unit_step=float((bar.h[None, :] / (c[:, None] + np.abs(s["v"]))).min()))


class WithSummary:
    """The numpy bar handing over a summary, edited by `edit` (trial states only if `trial_only`)."""

    def __init__(self, bar: Any, edit: Callable[[dict[str, Any]], None] = lambda d: None,
                 trial_only: bool = False) -> None:
        self.bar, self.edit, self.trial_only = bar, edit, trial_only

    def __getattr__(self, name: str) -> Any:
        return getattr(self.bar, name)

    def state(self, trial: bool) -> dict[str, Any]:
        s = self.bar.state(trial)
        summary = library_summary(self.bar, s)
        if trial or not self.trial_only:
            self.edit(summary)
        s["summary"] = summary
        return s


def run(stepper: Any, t_end: float = 0.05) -> list[dict[str, Any]]:
    decisions: list[dict[str, Any]] = []
    mpm_dt.Controller(dim=2, config={}).run_until(stepper, t_end, decisions.append)
    return decisions


def test_the_library_s_own_totals_take_the_same_steps(bar: Any) -> None:
    plain = run(bar)
    bar.__init__(cells=8)
    handed = run(WithSummary(bar))
    assert len(handed) == len(plain) > 5
    for a, b in zip(plain, handed):
        assert b["dt"] == pytest.approx(a["dt"], rel=1e-12)
        assert b["binding"] == a["binding"]


def test_the_handed_sound_speed_step_is_the_one_used(bar: Any) -> None:
    def halve(d: dict[str, Any]) -> None:
        d["sound_unit_step"] *= 0.5
    plain = run(bar, 0.01)
    bar.__init__(cells=8)
    halved = run(WithSummary(bar, halve), 0.01)
    sound = [next(r["proposal"] for r in d["limits"] if r["name"] == "sound_speed") for d in (plain[0], halved[0])]
    assert sound[1] == pytest.approx(0.5 * sound[0], rel=1e-12)


@pytest.mark.parametrize("edit, match", [
    (lambda d: d.pop("kinetic"), "needs \"kinetic\""),
    (lambda d: d.update(first_moment=np.zeros(3)), r"first_moment.*expected \(2,\)"),
    (lambda d: d.update(sound_unit_step=-1.0), "sound_unit_step.*not a positive number"),
    (lambda d: d.update(element_bound="large"), "element_bound.*a number or None"),
])
def test_a_malformed_summary_is_a_state_error(bar: Any, edit: Callable[[dict[str, Any]], None],
                                             match: str) -> None:
    with pytest.raises((mpm_dt.StateError, mpm_dt.StateTypeError), match=match):
        run(WithSummary(bar, edit), 0.01)


def test_a_non_finite_trial_summary_is_retried_then_gives_up(bar: Any) -> None:
    def blow_up(d: dict[str, Any]) -> None:
        d["kinetic"] = float("nan")
    decisions: list[dict[str, Any]] = []
    with pytest.raises(mpm_dt.TooManyRejections, match="non-finite summary"):
        mpm_dt.Controller(dim=2).run_until(WithSummary(bar, blow_up, trial_only=True), 0.01, decisions.append)
    assert decisions and all(d["cause"] == "non_finite" for d in decisions)
