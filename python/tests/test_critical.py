"""critical_dt and max_stable_modulus, checked against closed forms and real runs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from conftest import numpy_bar

import mpm_dt


def test_critical_dt_closed_forms(bar: Any) -> None:
    s = bar.state(False)
    c = mpm_dt.critical_dt(s)
    # c_p = sqrt((lambda + 2 mu) / rho) with rho = 1; h = 1/8 on both axes.
    c_p = math.sqrt(bar.lam + 2 * bar.mu)
    assert c["c_p"] == pytest.approx(c_p, rel=1e-14)
    assert c["cell_size"] == pytest.approx([0.125, 0.125], rel=1e-15)
    assert c["dt_sound"] == pytest.approx(0.125 / c_p, rel=1e-14)
    assert c["dt_eq56"] == pytest.approx(math.sqrt(2 / c["lambda_max"]), rel=1e-15)
    # Lanczos against the dense eigenvalue on this small layout (64 unknowns).
    assert c["lambda_max_dense"] == pytest.approx(c["lambda_max"], rel=1e-8)
    assert c["dt_full_map"] is None  # only on request


def test_lambda_max_is_linear_in_the_modulus(bar: Any) -> None:
    s = bar.state(False)
    stiff = dict(s, youngs_modulus=4 * s["youngs_modulus"])
    assert mpm_dt.critical_dt(stiff)["lambda_max"] == pytest.approx(
        4 * mpm_dt.critical_dt(s)["lambda_max"], rel=1e-9)
    lame = np.tile([bar.lam, bar.mu], (len(s["mass"]), 1))
    assert mpm_dt.critical_dt(dict(s, lame=lame))["lambda_max"] == pytest.approx(
        mpm_dt.critical_dt(s)["lambda_max"], rel=1e-9)
    # E_max from lame rows equals E_max from the scalars.
    assert mpm_dt.max_stable_modulus(dict(s, lame=lame), 0.01) == pytest.approx(
        mpm_dt.max_stable_modulus(s, 0.01), rel=1e-9)


def blows_up(E: float, dt: float, cells: int, steps: int = 400) -> bool:
    """A fixed-step run of the numpy strip from its wave plus seeded noise on every
    velocity component: unstable when the energy exceeds 10x its start or is not finite."""
    bar = numpy_bar.NumpyBar(cells=cells, E=E)
    rng = np.random.default_rng(7)
    c = math.sqrt(bar.lam + 2 * bar.mu)
    bar.committed["v"] = bar.committed["v"] + 1e-6 * c * rng.standard_normal(bar.committed["v"].shape)
    e0 = bar.energy()
    with np.errstate(all="ignore"):
        for _ in range(steps):
            bar.try_step(dt)
            bar.accept()
            e = bar.energy()
            if not math.isfinite(e) or e > 10 * e0:
                return True
    return False


def bisect_modulus(dt: float, cells: int, guess: float) -> float:
    """The largest E for which fixed steps dt stay stable (10 halvings, log scale)."""
    lo, hi = 0.5 * guess, 2.0 * guess
    assert not blows_up(lo, dt, cells) and blows_up(hi, dt, cells)
    for _ in range(10):
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if blows_up(mid, dt, cells) else (mid, hi)
    return math.sqrt(lo * hi)


def test_max_stable_modulus_matches_bisection_on_real_runs() -> None:
    # 64 particles (320 unknowns of the particle state; the full map reduced to the nodes).
    dt, cells = 0.02, 4
    state = numpy_bar.NumpyBar(cells=cells).state(False)
    e_eq56 = mpm_dt.max_stable_modulus(state, dt)
    e_full = mpm_dt.max_stable_modulus(state, dt, method="full_map")
    empirical = bisect_modulus(dt, cells, e_full)
    print(f"E_max: eq 56 {e_eq56:.4f}, full map {e_full:.4f}, bisection {empirical:.4f}")
    assert empirical == pytest.approx(e_full, rel=0.05)
    # Eq 56 is the conservative side.
    assert e_eq56 <= empirical


def test_eq56_modulus_on_a_larger_layout_is_conservative_within_20_percent() -> None:
    # 128 particles: 640 unknowns of the particle state; the full map from the nodes.
    dt, cells = 0.01, 8
    state = numpy_bar.NumpyBar(cells=cells).state(False)
    e_eq56 = mpm_dt.max_stable_modulus(state, dt)
    e_full = mpm_dt.max_stable_modulus(state, dt, method="full_map")
    empirical = bisect_modulus(dt, cells, e_eq56)
    print(f"E_max: eq 56 {e_eq56:.4f}, full map {e_full:.4f}, bisection {empirical:.4f}")
    assert e_eq56 <= empirical <= 1.2 * e_eq56
    assert empirical == pytest.approx(e_full, rel=0.05)


def test_material_reports_the_tangent_moduli(bar: Any) -> None:
    """``"material"``: each particle's tangent pair at its F (mpm_dt::tangent)."""
    s = bar.state(False)
    n = len(s["mass"])
    # At rest both models give the small-strain pair: the same critical steps.
    rest = mpm_dt.critical_dt(s)
    for material in ("linear_elastic", "neo_hookean", "fixed_corotated"):
        c = mpm_dt.critical_dt(dict(s, material=material))
        assert c["lambda_max"] == pytest.approx(rest["lambda_max"], rel=1e-12)
        assert c["c_p"] == pytest.approx(rest["c_p"], rel=1e-12)
    # Compressed along x: neo-Hookean's exact (lambda/J, (mu - lambda ln J)/J).
    f = np.tile(np.diag([0.9, 1.0]), (n, 1, 1))
    j = 0.9
    lam, mu = bar.lam, bar.mu
    lt, mt = lam / j, (mu - lam * math.log(j)) / j
    rho = s["mass"][0] / (j * s["volume0"][0])
    c = mpm_dt.critical_dt(dict(s, F=f, material="neo_hookean"))
    assert c["c_p"] == pytest.approx(math.sqrt((lt + 2 * mt) / rho), rel=1e-12)
    # The fixed-corotated bound is at least its rest pair's P-wave modulus here, and the
    # stiffness grows with it.
    fc = mpm_dt.critical_dt(dict(s, F=f, material="fixed_corotated"))
    plain = mpm_dt.critical_dt(dict(s, F=f))
    assert fc["c_p"] > plain["c_p"]
    assert fc["lambda_max"] > plain["lambda_max"]
    with pytest.raises(mpm_dt.StateError, match="material"):
        mpm_dt.critical_dt(dict(s, material="jelly"))
    with pytest.raises(mpm_dt.StateError, match="material"):
        mpm_dt.critical_dt(dict(s, material=3))
    # E_max under a material: from the scalars (the tangent pairs are linear in E), and
    # refused from "lame" rows, which are then tangent pairs, not the material's.
    e_nh = mpm_dt.max_stable_modulus(dict(s, F=f, material="neo_hookean"), 0.01)
    stiff = dict(s, F=f, material="neo_hookean", youngs_modulus=2 * s["youngs_modulus"])
    assert mpm_dt.max_stable_modulus(stiff, 0.01) == pytest.approx(e_nh, rel=1e-9)
    rows = {k: v for k, v in s.items() if k not in ("youngs_modulus", "poisson_ratio")}
    rows.update(F=f, lame=np.tile([lam, mu], (n, 1)), material="neo_hookean")
    assert mpm_dt.critical_dt(rows)["c_p"] == pytest.approx(c["c_p"], rel=1e-12)
    with pytest.raises(mpm_dt.StateError, match="youngs_modulus"):
        mpm_dt.max_stable_modulus(rows, 0.01)
