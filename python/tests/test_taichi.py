"""The taichi mpm88 scene under the controller: a short run (skipped without taichi)."""

import importlib.util
import pathlib
import sys
from typing import Any

import numpy as np
import pytest

ti = pytest.importorskip("taichi")

import mpm_dt  # noqa: E402

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "taichi_mpm88.py"


@pytest.fixture(scope="module")
def mpm88() -> Any:
    sys.path.insert(0, str(EXAMPLE.parent))  # the scene module beside it
    spec = importlib.util.spec_from_file_location("taichi_mpm88", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["taichi_mpm88"] = module
    spec.loader.exec_module(module)
    ti.init(arch=ti.cpu, cpu_max_num_threads=1, default_fp=ti.f32, log_level=ti.WARN)
    return module


@pytest.mark.parametrize("jelly", [False, True])
def test_short_run_under_the_controller(mpm88: Any, jelly: bool) -> None:
    sim = mpm88.Mpm88(jelly=jelly)
    decisions: list[dict[str, Any]] = []
    summary = mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.01, decisions.append)
    assert summary["t_final"] == pytest.approx(0.01, rel=1e-9) and sim.time() == pytest.approx(0.01, rel=1e-9)
    assert summary["steps_accepted"] > 0 and sim.blown_up() is None
    # The stability limit tracks lambda_max on the MLS gradients; no step exceeds a proposal.
    assert all(d["lambda_max"] is not None and d["lambda_max"] > 0 for d in decisions)
    for d in decisions:
        assert all(d["dt"] <= rec["proposal"] * (1 + 1e-12) for rec in d["limits"] if rec["proposal"])
    # mpm88's own step is below the controller's on this scene.
    assert summary["dt_mean"] > mpm88.MPM88_DT


def test_the_kernel_s_summary_takes_the_library_s_steps(mpm88: Any) -> None:
    """The summary the summary pass computes (in float64, from the exported values) is what the
    library computes from the arrays: the same steps with and without it."""
    runs = []
    for summary in (False, True):
        sim = mpm88.Mpm88(jelly=True, summary=summary)
        decisions: list[dict[str, Any]] = []
        mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.005, decisions.append)
        runs.append(decisions)
    assert len(runs[0]) == len(runs[1]) > 3

    def record(d: dict[str, Any], limit: str) -> dict[str, Any]:
        return next(r for r in d["limits"] if r["name"] == limit)
    for a, b in zip(*runs):
        assert b["dt"] == pytest.approx(a["dt"], rel=1e-9) and b["binding"] == a["binding"]
        # The growth monitor's energy and the speed-of-sound step: the kernel's, in float64.
        for limit, value in (("growth", lambda r: r["metrics"]["energy"]), ("sound_speed", lambda r: r["proposal"])):
            assert value(record(b, limit)) == pytest.approx(value(record(a, limit)), rel=1e-12)


def test_the_kernel_s_summary_is_the_arrays_totals(mpm88: Any) -> None:
    """The summary pass's totals against numpy over the float64 arrays the export wrote, on a
    deformed jelly (a few steps after a shear): energies, moment, bound and sound step."""
    sim = mpm88.Mpm88(jelly=True)
    mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.005)
    s = sim.state(False)
    lam, mu, h, m, v0 = sim.lam, sim.mu, sim.dx, sim.p_mass, sim.p_vol
    vol = np.linalg.det(s["F"]) * v0
    sig = s["stress"]
    tr = np.trace(sig, axis1=1, axis2=2)
    strain = 0.5 * vol * ((sig**2).sum((1, 2)) - lam * tr * tr / (2 * mu + 2 * lam)) / (2 * mu)
    inv = 4.0 / h**2
    lt, mt = s["lame"][:, 0], s["lame"][:, 1]
    bound = vol / m * np.minimum(inv * np.maximum(2 * lt + 2 * mt, 2 * mt),
                                 2 * inv * np.maximum(lt + 2 * mt, 2 * mt))
    c = np.sqrt((lt + 2 * mt) * vol / m)
    want = dict(kinetic=0.5 * m * (s["v"] ** 2).sum(), strain=strain.sum(), element_bound=bound.max(),
                sound_unit_step=(h / (c + np.abs(s["v"]).max(1))).min())
    assert abs(strain.sum()) > 0
    for key, value in want.items():
        assert s["summary"][key] == pytest.approx(value, rel=1e-12), key
    assert s["summary"]["first_moment"] == pytest.approx(m * s["x"].sum(0), rel=1e-12)


def test_the_kernel_s_tangent_moduli_are_the_library_s(mpm88: Any) -> None:
    """The summary pass's fixed-corotated pair (a port of mpm_dt::tangent) against the
    package's own (``"material"``) on a jelly deformed by its impact, where the pair is
    above the rest moduli."""
    sim = mpm88.Mpm88(jelly=True)
    mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.2)
    s = dict(sim.state(False))
    s["lame"] = s["lame"].copy()
    rest = np.tile([sim.lam, sim.mu], (len(s["mass"]), 1))
    p_wave = s["lame"][:, 0] + 2 * s["lame"][:, 1]
    assert p_wave.max() > 1.01 * (sim.lam + 2 * sim.mu)
    ours = mpm_dt.critical_dt(s)
    theirs = mpm_dt.critical_dt(dict(s, lame=rest, material="fixed_corotated"))
    for key in ("lambda_max", "c_p"):
        assert ours[key] == pytest.approx(theirs[key], rel=1e-12), key


def test_on_demand_hands_over_the_export_s_totals_and_takes_the_eager_steps(mpm88: Any) -> None:
    """The on-demand stepper's `summary(True)` (the `summarize` kernel) is the summary
    `state(True)` hands over with the arrays, and a run handing over on demand takes the
    eager run's steps (to a few parts in a million: between its layout checks the
    stability limit carries the last check's moduli factor) reading the arrays on a
    fraction of the states."""
    sim = mpm88.Mpm88OnDemand(jelly=True)
    mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.005)
    sim.try_step(3e-4)
    alone = dict(sim.summary(True))
    alone["first_moment"] = np.array(alone["first_moment"])
    exported = sim.state(True)["summary"]
    for key, value in exported.items():
        assert alone[key] == pytest.approx(value, rel=1e-12), key
    sim.reject()
    runs = []
    for kind in (mpm88.Mpm88, mpm88.Mpm88OnDemand):
        s = kind(jelly=True)
        calls = [0]
        original = s.state
        s.state = lambda trial, f=original, c=calls: (c.__setitem__(0, c[0] + 1), f(trial))[1]
        decisions: list[dict[str, Any]] = []
        mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(s, 0.03, decisions.append)
        runs.append(([d["dt"] for d in decisions], calls[0]))
    (eager, n_eager), (lazy, n_lazy) = runs
    assert len(lazy) == len(eager) > 50
    assert lazy == pytest.approx(eager, rel=1e-4)
    assert 2 * n_lazy < n_eager, (n_lazy, n_eager)
