"""A 2D MPM solver in plain numpy under mpm_dt's controller: a periodic elastic strip with a
standing compression wave (USL, FLIP, linear hats, hypoelastic linear elasticity).
Usage: python examples/python/numpy_bar.py [--cells 32] [--t-end 1.0] [--E 100]"""

from __future__ import annotations

import argparse
import time
from typing import Any, Optional

import mpm_dt
import numpy as np


class NumpyBar:
    """The stepper: `try_step` writes a trial beside the committed state, `accept` keeps it."""

    def __init__(self, cells: int = 32, E: float = 100.0, nu: float = 0.3, amplitude: float = 1e-3):
        self.cells, self.length = np.array([cells, 4]), np.array([1.0, 4.0 / cells])
        self.h, self.E_nu = self.length / self.cells, (E, nu)
        self.lam, self.mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        k = np.stack(np.meshgrid(np.arange(2 * cells), np.arange(8), indexing="ij"), -1).reshape(-1, 2)
        n, x = len(k), (k + 0.5) * self.h / 2  # 2 x 2 particles per cell, density 1
        self.volume0 = self.mass = np.full(n, np.prod(self.h) / 4)
        v = np.stack([amplitude * np.sqrt(self.lam + 2 * self.mu) * np.sin(2 * np.pi * x[:, 0]), 0 * x[:, 1]], 1)
        self.committed = dict(x=x, v=v, F=np.tile(np.eye(2), (n, 1, 1)), stress=np.zeros((n, 2, 2)))
        self.trial: Optional[dict[str, Any]] = None
        self.t, self.t_trial, self.solver_s = 0.0, 0.0, 0.0

    def weights(self, x: Any) -> tuple[Any, Any, Any]:
        """Linear hats: the 4 nodes of each particle's cell, S_ip and grad S_ip (periodic)."""
        base = np.floor(x / self.h).astype(int)
        f, out = x / self.h - base, []
        for a, b in ((0, 0), (1, 0), (0, 1), (1, 1)):
            wx, wy = (f[:, 0] if a else 1 - f[:, 0]), (f[:, 1] if b else 1 - f[:, 1])
            sx, sy = (1 if a else -1) / self.h[0], (1 if b else -1) / self.h[1]
            i = (base[:, 0] + a) % self.cells[0] + self.cells[0] * ((base[:, 1] + b) % self.cells[1])
            out.append((i, wx * wy, np.stack([sx * wy, wx * sy], -1)))
        nodes, w, g = (np.stack(z, 1) for z in zip(*out))
        return nodes, w, g

    def try_step(self, dt: float) -> None:
        start, s, nn = time.perf_counter(), self.committed, int(np.prod(self.cells))
        nodes, w, g = self.weights(s["x"])
        vol, idx = np.linalg.det(s["F"]) * self.volume0, nodes.ravel()
        m = np.maximum(np.bincount(idx, (w * self.mass[:, None]).ravel(), nn), 1e-300)[:, None]
        mv = np.stack([np.bincount(idx, (w * (self.mass * s["v"][:, c])[:, None]).ravel(), nn)
                       for c in (0, 1)], 1)
        f = -np.einsum("p,pcj,pkj->pkc", vol, s["stress"], g)  # f_i = -sum V sigma grad S (eq 18)
        a = np.stack([np.bincount(idx, f[..., c].ravel(), nn) for c in (0, 1)], 1) / m
        v1 = mv / m + dt * a
        v = s["v"] + dt * np.einsum("pk,pkc->pc", w, a[nodes])  # FLIP
        L = np.einsum("pkc,pkd->pcd", v1[nodes], g)
        D = 0.5 * (L + L.transpose(0, 2, 1))
        tr = np.trace(D, axis1=1, axis2=2)[:, None, None]
        stress = s["stress"] + dt * (self.lam * tr * np.eye(2) + 2 * self.mu * D)
        x, F = (s["x"] + dt * v) % self.length, s["F"] + dt * L @ s["F"]
        self.trial, self.t_trial = dict(x=x, v=v, F=F, stress=stress), self.t + dt
        self.solver_s += time.perf_counter() - start

    def accept(self) -> None:
        self.committed, self.trial, self.t = self.trial or self.committed, None, self.t_trial

    def reject(self) -> None:
        self.trial = None

    def time(self) -> float:  # the committed state's time
        return self.t

    def state(self, trial: bool) -> dict[str, Any]:
        return dict((self.trial if trial else self.committed) or {}, mass=self.mass,
                    volume0=self.volume0, youngs_modulus=self.E_nu[0], poisson_ratio=self.E_nu[1],
                    cells=self.cells, length=self.length, boundary="periodic", shape="linear")

    def energy(self) -> float:
        s = self.committed
        eps = 0.5 * (s["F"] + s["F"].transpose(0, 2, 1)) - np.eye(2)
        return float(0.5 * self.mass @ (s["v"] ** 2).sum(1)
                     + 0.5 * self.volume0 @ np.einsum("pij,pij->p", s["stress"], eps))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in (("--cells", 32), ("--t-end", 1.0), ("--E", 100.0)):
        p.add_argument(name, type=type(default), default=default)
    args = p.parse_args()
    bar = NumpyBar(cells=args.cells, E=args.E)
    crit, e0, start = mpm_dt.critical_dt(bar.state(False)), bar.energy(), time.perf_counter()
    summary = mpm_dt.Controller(dim=2, config={}).run_until(bar, args.t_end)
    wall, n = time.perf_counter() - start, summary["steps_accepted"] + summary["steps_rejected"]
    print(f"dt_sound = {crit['dt_sound']:.4e} s, dt_eq56 = {crit['dt_eq56']:.4e} s\n"
          f"{summary['steps_accepted']} steps ({summary['steps_rejected']} rejected), dt mean "
          f"{summary['dt_mean']:.4e} s = {summary['dt_mean'] / crit['dt_eq56']:.3f} dt_eq56, "
          f"bound by {summary['binding']}\nenergy {e0:.4e} -> {bar.energy():.4e}; wall {wall:.2f} s, "
          f"solver {bar.solver_s:.2f} s, controller + hand-over {(wall - bar.solver_s) / n * 1e6:.0f} us/step")


if __name__ == "__main__":
    main()
