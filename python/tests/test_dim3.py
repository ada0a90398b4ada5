"""The 3D path: a drifting periodic block (rigid translation, no stress) under the
controller, and the critical steps of a 3D layout."""

from typing import Any

import numpy as np
import pytest

import mpm_dt


class Drift3D:
    """Particles on a periodic 4^3 grid moving at one velocity: the exact solution is a
    translation, which the stepper computes (positions wrapped into the box)."""

    def __init__(self) -> None:
        k = np.stack(np.meshgrid(*[np.arange(8)] * 3, indexing="ij"), -1).reshape(-1, 3)
        self.n = len(k)
        self.x = (k + 0.5) / 8.0
        self.v = np.tile([0.3, -0.2, 0.1], (self.n, 1))
        self.t = 0.0
        self.trial: Any = None

    def time(self) -> float:
        return self.t

    def try_step(self, dt: float) -> None:
        self.trial = ((self.x + dt * self.v) % 1.0, self.t + dt)

    def accept(self) -> None:
        self.x, self.t = self.trial

    def reject(self) -> None:
        self.trial = None

    def state(self, trial: bool) -> dict[str, Any]:
        x = self.trial[0] if trial else self.x
        return dict(x=x, v=self.v, mass=np.full(self.n, 1 / 512), volume0=np.full(self.n, 1 / 512),
                    F=np.tile(np.eye(3), (self.n, 1, 1)), stress=np.zeros((self.n, 3, 3)),
                    youngs_modulus=10.0, poisson_ratio=0.25, cells=(4, 4, 4), length=(1.0, 1.0, 1.0),
                    boundary="periodic", shape="gimp")


def test_a_3d_stepper_runs_to_t_end() -> None:
    s = Drift3D()
    summary = mpm_dt.Controller(dim=3, config={}, gravity=(0.0, 0.0, 0.0)).run_until(s, 0.2)
    assert summary["t_final"] == pytest.approx(0.2, rel=1e-12)
    assert summary["steps_accepted"] > 0 and summary["steps_rejected"] == 0
    # Translated, not deformed: every particle moved by v t (modulo the box).
    d = (s.x - (np.stack(np.meshgrid(*[np.arange(8)] * 3, indexing="ij"), -1).reshape(-1, 3) + 0.5) / 8.0
         - 0.2 * s.v)
    assert np.allclose(d - np.round(d), 0.0, atol=1e-12)


def test_critical_dt_in_3d() -> None:
    c = mpm_dt.critical_dt(Drift3D().state(False))
    E, nu = 10.0, 0.25
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    assert c["c_p"] == pytest.approx(np.sqrt((lam + 2 * mu) / 1.0), rel=1e-12)
    assert c["dt_sound"] == pytest.approx(0.25 / c["c_p"], rel=1e-12)
    # 4^3 nodes x 3 components = 192 unknowns: the dense check runs.
    assert c["lambda_max_dense"] == pytest.approx(c["lambda_max"], rel=1e-8)
    assert c["dt_eq56"] < c["dt_sound"]


def test_a_3d_state_in_a_2d_controller_is_a_state_error() -> None:
    with pytest.raises(mpm_dt.StateError, match=r"expected \(n, 2\) for dimension 2"):
        mpm_dt.Controller(dim=2).run_until(Drift3D(), 0.1)
