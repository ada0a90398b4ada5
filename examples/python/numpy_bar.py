"""A 2D MPM solver in plain numpy under mpm_dt's controller: a periodic elastic strip
with a standing compression wave (USL, FLIP, linear hats, hypoelastic linear elasticity).

    python examples/python/numpy_bar.py [--cells 32] [--t-end 1.0] [--E 100]
"""

from __future__ import annotations

import argparse
import time
from typing import Any, Optional

import numpy as np
import numpy.typing as npt

import mpm_dt

Array = npt.NDArray[np.float64]


class NumpyBar:
    """The stepper: `try_step` writes a trial beside the committed state, `accept` keeps it."""

    def __init__(self, cells: int = 32, E: float = 100.0, nu: float = 0.3, amplitude: float = 1e-3):
        self.cells, self.length = np.array([cells, 4]), np.array([1.0, 4.0 / cells])
        self.h = self.length / self.cells
        self.lam, self.mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        k = np.stack(np.meshgrid(np.arange(2 * cells), np.arange(8), indexing="ij"), -1).reshape(-1, 2)
        n = len(k)
        self.volume0 = np.full(n, np.prod(self.h) / 4)
        self.mass = 1.0 * self.volume0
        x = (k + 0.5) * self.h / 2
        v = np.zeros((n, 2))
        v[:, 0] = amplitude * np.sqrt((self.lam + 2 * self.mu) / 1.0) * np.sin(2 * np.pi * x[:, 0])
        self.t, self.t_trial, self.E_nu = 0.0, 0.0, (E, nu)
        self.committed = dict(x=x, v=v, F=np.tile(np.eye(2), (n, 1, 1)), stress=np.zeros((n, 2, 2)))
        self.trial: Optional[dict[str, Array]] = None

    def weights(self, x: Array) -> tuple[Any, Array, Array]:
        """Linear hats: the 4 nodes of each particle's cell, S_ip and grad S_ip (periodic)."""
        q = x / self.h
        base = np.floor(q).astype(int)
        f = q - base
        nodes, w, g = [], [], []
        for a in (0, 1):
            for b in (0, 1):
                wx, wy = (f[:, 0] if a else 1 - f[:, 0]), (f[:, 1] if b else 1 - f[:, 1])
                sx, sy = (1 if a else -1) / self.h[0], (1 if b else -1) / self.h[1]
                i = (base[:, 0] + a) % self.cells[0] + self.cells[0] * ((base[:, 1] + b) % self.cells[1])
                nodes.append(i), w.append(wx * wy), g.append(np.stack([sx * wy, wx * sy], -1))
        return np.stack(nodes, 1), np.stack(w, 1), np.stack(g, 1)

    def try_step(self, dt: float) -> None:
        s, nn = self.committed, int(np.prod(self.cells))
        nodes, w, g = self.weights(s["x"])
        vol = np.linalg.det(s["F"]) * self.volume0
        m = np.bincount(nodes.ravel(), (w * self.mass[:, None]).ravel(), nn)
        force = np.zeros((nn, 2))  # f_i = -sum_p V_p sigma_p grad S_ip (eq 18)
        mv = np.zeros((nn, 2))
        for c in range(2):
            mv[:, c] = np.bincount(nodes.ravel(), (w * (self.mass * s["v"][:, c])[:, None]).ravel(), nn)
            fc = -np.einsum("p,pj,pkj->pk", vol, s["stress"][:, c, :], g)
            force[:, c] = np.bincount(nodes.ravel(), fc.ravel(), nn)
        a = force / np.maximum(m, 1e-300)[:, None]
        v1 = mv / np.maximum(m, 1e-300)[:, None] + dt * a
        v = s["v"] + dt * np.einsum("pk,pkc->pc", w, a[nodes])  # FLIP
        L = np.einsum("pkc,pkd->pcd", v1[nodes], g)
        F = s["F"] + dt * L @ s["F"]
        D = 0.5 * (L + L.transpose(0, 2, 1))
        tr = np.trace(D, axis1=1, axis2=2)[:, None, None]
        stress = s["stress"] + dt * (self.lam * tr * np.eye(2) + 2 * self.mu * D)
        x = (s["x"] + dt * v) % self.length
        self.trial, self.t_trial = dict(x=x, v=v, F=F, stress=stress), self.t + dt

    def accept(self) -> None:
        assert self.trial is not None
        self.committed, self.trial, self.t = self.trial, None, self.t_trial

    def reject(self) -> None:
        self.trial = None

    def time(self) -> float:
        return self.t

    def state(self, trial: bool) -> dict[str, Any]:
        s = self.trial if trial else self.committed
        assert s is not None
        return dict(s, mass=self.mass, volume0=self.volume0, youngs_modulus=self.E_nu[0],
                    poisson_ratio=self.E_nu[1], cells=self.cells, length=self.length,
                    boundary="periodic", shape="linear")


    def energy(self) -> float:
        s = self.committed
        eps = 0.5 * (s["F"] + s["F"].transpose(0, 2, 1)) - np.eye(2)
        return float(0.5 * self.mass @ (s["v"] ** 2).sum(1)
                     + 0.5 * self.volume0 @ np.einsum("pij,pij->p", s["stress"], eps))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cells", type=int, default=32)
    p.add_argument("--t-end", type=float, default=1.0)
    p.add_argument("--E", type=float, default=100.0)
    args = p.parse_args()
    bar = NumpyBar(cells=args.cells, E=args.E)
    crit = mpm_dt.critical_dt(bar.state(False))
    e0, start = bar.energy(), time.perf_counter()
    ctrl = mpm_dt.Controller(dim=2, config={}, gravity=(0.0, 0.0))
    summary = ctrl.run_until(bar, args.t_end)
    wall = time.perf_counter() - start
    print(f"dt_sound = {crit['dt_sound']:.4e}, dt_eq56 = {crit['dt_eq56']:.4e} s")
    print(f"{summary['steps_accepted']} steps ({summary['steps_rejected']} rejected), "
          f"dt mean {summary['dt_mean']:.4e} = {summary['dt_mean'] / crit['dt_eq56']:.3f} dt_eq56, "
          f"bound by {summary['binding']}")
    print(f"energy {e0:.4e} -> {bar.energy():.4e}; wall {wall:.2f} s")


if __name__ == "__main__":
    main()
