"""The state dict's optional "summary": totals a solver hands over from its own passes."""

from __future__ import annotations

from typing import Any, Callable, Optional

import mpm_dt
import numpy as np
import pytest


def library_summary(bar: Any, s: dict[str, Any]) -> dict[str, Any]:
    """What the library computes from the state itself: the growth monitor's energies, the
    speed-of-sound step and the element bound of the bar's linear hats."""
    lam, mu = bar.lam, bar.mu
    vol = np.linalg.det(s["F"]) * bar.volume0
    sig = s["stress"]
    tr = np.trace(sig, axis1=1, axis2=2)
    strain = 0.5 * vol * ((sig**2).sum((1, 2)) - lam * tr * tr / (2 * mu + 2 * lam)) / (2 * mu)
    c = np.sqrt((lam + 2 * mu) * vol / bar.mass)
    # H_p = sum_i grad S grad S^T / S; lambda_p = (V/m) min(rowsum max(2l+2m, 2m), tr max(l+2m, 2m)).
    _, w, g = bar.weights(s["x"])
    h = np.einsum("pk,pka,pkb->pab", 1.0 / w, g, g)
    rows, trace = np.abs(h).sum(2).max(1), np.trace(h, axis1=1, axis2=2)
    bound = vol / bar.mass * np.minimum(rows * max(2 * lam + 2 * mu, 2 * mu), trace * max(lam + 2 * mu, 2 * mu))
    return dict(kinetic=float(0.5 * bar.mass @ (s["v"] ** 2).sum(1)), strain=float(strain.sum()),
                first_moment=bar.mass @ s["x"], element_bound=float(bound.max()),
                sound_unit_step=float((bar.h[None, :] / (c[:, None] + np.abs(s["v"]))).min()))


class WithSummary:
    """The numpy bar handing over a summary: the library's totals, edited by `edit` (on
    trial states only if `trial_only`); `keep` lists the keys handed over."""

    def __init__(self, bar: Any, edit: Callable[[dict[str, Any]], Any] = lambda d: None,
                 trial_only: bool = False, keep: Optional[tuple[str, ...]] = None) -> None:
        self.bar, self.edit, self.trial_only, self.keep = bar, edit, trial_only, keep

    def __getattr__(self, name: str) -> Any:
        return getattr(self.bar, name)

    def state(self, trial: bool) -> dict[str, Any]:
        s = self.bar.state(trial)
        summary = library_summary(self.bar, s)
        if self.keep is not None:
            summary = {k: v for k, v in summary.items() if k in self.keep}
        if trial or not self.trial_only:
            self.edit(summary)
        s["summary"] = summary
        return s


ENERGIES = ("kinetic", "strain", "first_moment", "sound_unit_step")


def run(stepper: Any, t_end: float = 0.05) -> list[dict[str, Any]]:
    decisions: list[dict[str, Any]] = []
    mpm_dt.Controller(dim=2, config={}).run_until(stepper, t_end, decisions.append)
    return decisions


def record(d: dict[str, Any], limit: str) -> dict[str, Any]:
    return next(r for r in d["limits"] if r["name"] == limit)


def test_the_library_s_own_totals_take_the_same_steps(bar: Any) -> None:
    plain = run(bar)
    bar.__init__(cells=8)
    handed = run(WithSummary(bar, keep=ENERGIES))
    assert len(handed) == len(plain) > 5
    for a, b in zip(plain, handed):
        assert b["dt"] == pytest.approx(a["dt"], rel=1e-12) and b["binding"] == a["binding"]
        # What the growth monitor and the sound-speed limit read is the handed-over totals.
        for limit, value in (("growth", lambda r: r["metrics"]["energy"]), ("sound_speed", lambda r: r["proposal"])):
            assert value(record(b, limit)) == pytest.approx(value(record(a, limit)), rel=1e-10)


def test_the_handed_sound_speed_step_is_the_one_used(bar: Any) -> None:
    def halve(d: dict[str, Any]) -> None:
        d["sound_unit_step"] *= 0.5
    plain = run(bar, 0.01)
    bar.__init__(cells=8)
    halved = run(WithSummary(bar, halve, keep=ENERGIES), 0.01)
    sound = [record(d, "sound_speed")["proposal"] for d in (plain[0], halved[0])]
    assert sound[1] == pytest.approx(0.5 * sound[0], rel=1e-12)


def test_the_handed_energies_reach_the_growth_monitor(bar: Any) -> None:
    """Trials whose strain energy is handed over a thousand times too large are growth."""
    def grow(d: dict[str, Any]) -> None:
        d["strain"] = 1e3 * d["strain"] + 1e3 * d["kinetic"]
    decisions: list[dict[str, Any]] = []
    with pytest.raises(mpm_dt.ControllerError):
        mpm_dt.Controller(dim=2).run_until(WithSummary(bar, grow, trial_only=True, keep=ENERGIES), 0.05,
                                           decisions.append)
    assert any(d["cause"] == "growth" for d in decisions)


def test_the_handed_element_bound_is_the_one_used(bar: Any) -> None:
    """The stability limit reports B / lambda_max at its Lanczos runs: twice the bound, twice
    the ratio (the first run's lambda_max is the same state's)."""
    ratios = []
    for scale in (1.0, 2.0):
        bar.__init__(cells=8)
        decisions = run(WithSummary(bar, lambda d, k=scale: d.update(element_bound=k * d["element_bound"])), 0.01)
        ratios.append(record(decisions[0], "stability")["metrics"]["bound_ratio"])
    assert ratios[0] >= 1.0 - 1e-9
    assert ratios[1] == pytest.approx(2.0 * ratios[0], rel=1e-9)


def test_none_is_no_summary(bar: Any) -> None:
    class NoneSummary(WithSummary):
        def state(self, trial: bool) -> dict[str, Any]:
            return dict(self.bar.state(trial), summary=None)
    plain = run(bar, 0.01)
    bar.__init__(cells=8)
    with_none = run(NoneSummary(bar), 0.01)
    assert [d["dt"] for d in with_none] == [d["dt"] for d in plain]


@pytest.mark.parametrize("edit, error, match", [
    (lambda d: d.pop("kinetic"), mpm_dt.StateError, "needs \"kinetic\""),
    (lambda d: d.pop("first_moment"), mpm_dt.StateError, "needs \"first_moment\""),
    (lambda d: d.update(first_moment=np.zeros(3)), mpm_dt.StateError, r"first_moment.*expected \(2,\)"),
    (lambda d: d.update(sound_unit_step=-1.0), mpm_dt.StateError, "sound_unit_step.*not a positive number"),
    (lambda d: d.update(element_bound=-1.0), mpm_dt.StateError, "element_bound.*negative"),
    (lambda d: d.update(element_bound="large"), mpm_dt.StateTypeError, "element_bound.*a number or None"),
    (lambda d: d.update(element_bounds=1.0), mpm_dt.StateError, "unknown key \"element_bounds\""),
])
def test_a_malformed_summary_is_a_state_error(bar: Any, edit: Callable[[dict[str, Any]], Any],
                                             error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        run(WithSummary(bar, edit), 0.01)


def test_a_malformed_trial_summary_ends_the_run(bar: Any) -> None:
    with pytest.raises(mpm_dt.StateError, match="needs \"strain\""):
        run(WithSummary(bar, lambda d: d.pop("strain"), trial_only=True), 0.01)


def test_a_summary_that_is_not_a_dict_is_a_type_error(bar: Any) -> None:
    class Listed(WithSummary):
        def state(self, trial: bool) -> dict[str, Any]:
            return dict(self.bar.state(trial), summary=[1.0, 2.0])
    with pytest.raises(mpm_dt.StateTypeError, match="must be a dict or None"):
        run(Listed(bar), 0.01)


@pytest.mark.parametrize("key", ["kinetic", "element_bound", "sound_unit_step"])
def test_a_non_finite_trial_summary_is_retried_then_gives_up(bar: Any, key: str) -> None:
    def blow_up(d: dict[str, Any]) -> None:
        d[key] = float("nan")
    decisions: list[dict[str, Any]] = []
    with pytest.raises(mpm_dt.TooManyRejections, match="non-finite summary"):
        mpm_dt.Controller(dim=2).run_until(WithSummary(bar, blow_up, trial_only=True), 0.01, decisions.append)
    assert decisions and all(d["cause"] == "non_finite" for d in decisions)


def test_a_non_finite_committed_summary_is_a_state_error(bar: Any) -> None:
    with pytest.raises(mpm_dt.StateError, match="non-finite summary"):
        run(WithSummary(bar, lambda d: d.update(strain=float("inf"))), 0.01)
