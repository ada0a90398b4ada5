# mypy: disable-error-code="valid-type,no-untyped-def,untyped-decorator"
# (taichi kernels: `ti.template()` annotations and untyped decorators; the mpm_dt calls are checked.)
"""taichi's mpm88 scene under mpm_dt's controller, against mpm88's fixed step.

The scene, written here from its description: 8192 particles at seeded random positions
in [0.2, 0.6]^2 moving at (0, -1), a 128^2 grid on [0, 1]^2 with walls 3 cells thick,
quadratic B-splines, MLS-MPM / APIC, gravity 9.8, E = 400, particle volume (h/2)^2,
density 1: mpm88's weakly compressible fluid (Kirchhoff stress E (J - 1) I), or with
``--jelly`` a fixed-corotated elastic jelly (E = 400, nu = 0.2, as mpm99's). mpm88 ships the
fixed step 2e-4 s.

    python examples/python/taichi_mpm88.py [--jelly] [--t-end 0.5] [--repeat 3]
        [--find-failure] [--arch cpu|gpu] [--threads N] [--handover N_PARTICLES] [--fp64]
        [--config JSON] [--no-summary]

* every run times mpm88's fixed step and the controlled run ``--repeat`` times,
  interleaved (the controller first in every other round), and prints the medians;
* ``--find-failure`` finds the smallest fixed step at which the run blows up before ``t_end``
  (non-finite values, a particle past a wall, J <= 0, or kinetic plus elastic energy above
  10x what the block has to give: its initial kinetic plus potential energy) by a 1 % scan
  from mpm88's step and a bisection;
* the stepper hands over, with the arrays, a ``"summary"`` its export kernel computes
  (energies, the element bound of MLS-MPM's gradients, the speed-of-sound step), so that
  the limits make no passes of their own for them; ``--no-summary`` hands over the arrays
  only;
* ``--handover N`` times one substep, the state export and the package's read of it at N
  particles (the hand-over's cost per controlled step) and exits.
"""


import argparse
import json
import statistics
import time
from typing import Any, Optional

import mpm_dt
import numpy as np
import taichi as ti  # type: ignore[import-untyped]

MPM88_DT = 2e-4
GRAVITY = 9.8
BOUND = 3


@ti.data_oriented
class State:
    """One state of the particles: position, velocity, affine matrix C, J and F."""

    def __init__(self, n: int) -> None:
        self.x = ti.Vector.field(2, float, n)
        self.v = ti.Vector.field(2, float, n)
        self.C = ti.Matrix.field(2, 2, float, n)
        self.J = ti.field(float, n)
        self.F = ti.Matrix.field(2, 2, float, n)


@ti.data_oriented
class Mpm88:
    """The solver as an mpm_dt stepper: ``try_step`` writes the trial into the second
    state, ``accept`` swaps the two."""

    def __init__(self, n: int = 8192, n_grid: int = 128, jelly: bool = False, seed: int = 88,
                 summary: bool = True):
        self.n, self.n_grid, self.jelly, self.summary = n, n_grid, jelly, summary
        self.dx = 1.0 / n_grid
        self.p_vol = (0.5 * self.dx) ** 2
        self.p_mass = self.p_vol * 1.0
        E, nu = 400.0, (0.2 if jelly else 0.0)
        self.lam, self.mu = (E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))) if jelly else (E, 0.0)
        self.states = [State(n), State(n)]
        self.grid_v = ti.Vector.field(2, float, (n_grid, n_grid))
        self.grid_m = ti.field(float, (n_grid, n_grid))
        # What the view reads, written by one kernel into one float64 numpy buffer
        # (taichi's CPU backend hands a kernel the numpy buffer itself: no copy), laid out
        # as contiguous blocks x (n, 2), v (n, 2), F (n, 2, 2), stress (n, 2, 2), the
        # tangent moduli (n, 2) and the summary's totals, so that the package reads each
        # field in place.
        self.buf = np.empty(14 * n + 8)
        self.out = dict(x=self.buf[: 2 * n].reshape(n, 2), v=self.buf[2 * n: 4 * n].reshape(n, 2),
                        F=self.buf[4 * n: 8 * n].reshape(n, 2, 2),
                        stress=self.buf[8 * n: 12 * n].reshape(n, 2, 2),
                        lame=self.buf[12 * n: 14 * n].reshape(n, 2))
        self.totals = self.buf[14 * n:]
        # The summary's constants in float64 (a Python float in a kernel is a literal of
        # taichi's default precision, float32 here): lambda, mu, h, m, V0.
        self.consts = ti.field(ti.f64, 5)
        self.consts.from_numpy(np.array([self.lam, self.mu, self.dx, self.p_mass, self.p_vol]))
        self.sums = ti.field(ti.f64, 5)
        self.escaped = ti.field(int, ())
        rng = np.random.default_rng(seed)
        s = self.states[0]
        real = s.x.to_numpy().dtype  # float32, or float64 with --fp64
        s.x.from_numpy((rng.random((n, 2)) * 0.4 + 0.2).astype(real))
        s.v.from_numpy(np.tile(np.array([0.0, -1.0], real), (n, 1)))
        self.reset_rest(s)
        self.t = self.t_trial = 0.0
        self.solver_s = self.export_s = 0.0
        self.mass = np.full(n, self.p_mass)
        self.volume0 = np.full(n, self.p_vol)
        self.budget = self.energies()[0] + self.energies()[2]

    @ti.kernel
    def reset_rest(self, s: ti.template()):
        for p in s.x:
            s.C[p] = ti.Matrix.zero(float, 2, 2)
            s.J[p] = 1.0
            s.F[p] = ti.Matrix.identity(float, 2)

    @ti.func
    def kirchhoff(self, F, J):
        tau = ti.Matrix.identity(float, 2) * (self.lam * (J - 1.0))
        if ti.static(self.jelly):
            R, _ = ti.polar_decompose(F)
            tau = 2.0 * self.mu * (F - R) @ F.transpose() + ti.Matrix.identity(float, 2) * (self.lam * (J - 1.0) * J)
        return tau

    @ti.func
    def inside(self, base):
        """Whether the 3 x 3 stencil from `base` is on the grid (not so only after a
        blow-up, which mpm88 does not guard against: its walls keep sane runs inside)."""
        return 0 <= base.x <= self.n_grid - 3 and 0 <= base.y <= self.n_grid - 3

    @ti.kernel
    def substep(self, a: ti.template(), b: ti.template(), dt: float):
        """mpm88's substep from state a into state b (particle to grid, grid, grid to particle)."""
        for i, j in self.grid_m:
            self.grid_v[i, j] = [0, 0]
            self.grid_m[i, j] = 0
        for p in a.x:
            Xp = a.x[p] / self.dx
            base = int(Xp - 0.5)
            if not self.inside(base):
                continue
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            stress = -dt * 4 * self.p_vol * self.kirchhoff(a.F[p], a.J[p]) / self.dx**2
            affine = stress + self.p_mass * a.C[p]
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * self.dx
                weight = w[i].x * w[j].y
                self.grid_v[base + offset] += weight * (self.p_mass * a.v[p] + affine @ dpos)
                self.grid_m[base + offset] += weight * self.p_mass
        for i, j in self.grid_m:
            if self.grid_m[i, j] > 0:
                self.grid_v[i, j] /= self.grid_m[i, j]
            self.grid_v[i, j].y -= dt * GRAVITY
            if i < BOUND and self.grid_v[i, j].x < 0:
                self.grid_v[i, j].x = 0
            if i > self.n_grid - BOUND and self.grid_v[i, j].x > 0:
                self.grid_v[i, j].x = 0
            if j < BOUND and self.grid_v[i, j].y < 0:
                self.grid_v[i, j].y = 0
            if j > self.n_grid - BOUND and self.grid_v[i, j].y > 0:
                self.grid_v[i, j].y = 0
        for p in a.x:
            Xp = a.x[p] / self.dx
            base = int(Xp - 0.5)
            if not self.inside(base):
                # A blown-up run (fixed steps): the particle stays out and is counted.
                b.x[p] = a.x[p]
                self.escaped[None] += 1
                continue
            fx = Xp - base
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(float, 2)
            new_C = ti.Matrix.zero(float, 2, 2)
            for i, j in ti.static(ti.ndrange(3, 3)):
                offset = ti.Vector([i, j])
                dpos = (offset - fx) * self.dx
                weight = w[i].x * w[j].y
                g_v = self.grid_v[base + offset]
                new_v += weight * g_v
                new_C += 4 * weight * g_v.outer_product(dpos) / self.dx**2
            b.v[p] = new_v
            b.x[p] = a.x[p] + dt * new_v
            b.C[p] = new_C
            if ti.static(self.jelly):
                b.F[p] = (ti.Matrix.identity(float, 2) + dt * new_C) @ a.F[p]
                b.J[p] = b.F[p].determinant()
            else:
                b.J[p] = a.J[p] * (1 + dt * new_C.trace())
                b.F[p] = ti.Matrix.identity(float, 2) * ti.sqrt(ti.max(b.J[p], 0.0))

    @ti.func
    def tangent(self, F, lam, mu):
        """The jelly's tangent pair at F, float64: the fixed-corotated bound of mpm_dt's
        `tangent::fixed_corotated` in 2D (its P-wave modulus bounds the acoustic tensor in
        every direction; (lam, mu) at rest), from F's singular values in closed form. The
        fluid keeps (E, 0), the linearisation of the grid force V0 tau (not its acoustic
        modulus E/J; examples/mls_mpm/model.rs says why), and an inverted F keeps the rest
        pair for the package to refuse the state."""
        lt, mt = lam, mu
        a, b, c, d = F[0, 0], F[0, 1], F[1, 0], F[1, 1]
        J = a * d - b * c
        if ti.static(self.jelly):
            if J > 0.0:
                q = ti.sqrt((a + d) ** 2 + (c - b) ** 2)
                r = ti.sqrt((a - d) ** 2 + (b + c) ** 2)
                s0, s1 = 0.5 * (q + r), ti.abs(0.5 * (q - r))
                lp, inv_j, inv_sum = ti.max(lam, 0.0), 1.0 / J, 1.0 / (s0 + s1)
                twist = 2.0 * (1.0 - inv_sum)
                m = ti.max(ti.max(2.0 * s0 * s0 - s0, 2.0 * s1 * s1 - s1),
                           ti.max(twist * s1 * s1, twist * s0 * s0))
                g = (s0 * s0 + s1 * s1 - (s0 - s1) ** 2 * inv_sum) * inv_j
                dp = lp * (J - 1.0) + mu * ((ti.max(s0, s1) + m) * inv_j - 2.0)
                ds_diag = 2.0 * mu * (ti.max(s0 * s0, s1 * s1) * inv_j - 1.0) - lam * (J - 1.0) \
                    + 2.0 * (ti.max(lam * (2.0 * J - 1.0), 0.0) - lp)
                ds = ti.max(ds_diag, mu * (g - 2.0) - lam * (J - 1.0) - 2.0 * lp)
                p_bound = ti.max(lp + 2.0 * mu + dp, 0.0)
                s_bound = ti.max(2.0 * lp + 2.0 * mu + ds, 0.0)
                lt = lp + ds - dp
                mt = mu + (dp - (lt - lp)) / 2.0
                if lt < 0.0:
                    lt, mt = 0.0, 0.5 * p_bound
                elif mt < 0.0:
                    lt, mt = ti.max(s_bound / 2.0, p_bound), 0.0
        return lt, mt

    @ti.kernel
    def export(self, s: ti.template(), buf: ti.types.ndarray()):
        """x, v, F (sqrt(J) I for the fluid) and the Cauchy stress tau / J in float64 into
        `buf` (layout in `__init__`), each particle's tangent pair (lambda_t, mu_t)
        (`tangent`), and from the same values, in float64, the summary's totals: kinetic
        energy, the growth monitor's complementary energy 1/2 sigma : C^-1 : sigma V (rest
        moduli), the first moment, the element bound
        (V/m) min((4/h^2) max(2 lambda_t + 2 mu_t, 2 mu_t), 2 (4/h^2) max(lambda_t + 2 mu_t, 2 mu_t))
        of MLS-MPM's gradients, the speed-of-sound step min h / (c_p + |v_a|) with
        c_p = sqrt((lambda_t + 2 mu_t) / rho), and the number of particles within a cell of
        the box's edge."""
        n = self.n
        t0 = 14 * n
        for k in ti.static(range(8)):
            buf[t0 + k] = 0.0
        buf[t0 + 5] = 1e30
        lam, mu, h = self.consts[0], self.consts[1], self.consts[2]
        m, vol0 = self.consts[3], self.consts[4]
        inv = 4.0 / (h * h)
        for p in s.x:
            sigma = self.kirchhoff(s.F[p], s.J[p]) / s.J[p]
            xp, vp = s.x[p].cast(ti.f64), s.v[p].cast(ti.f64)
            Fp, sp = s.F[p].cast(ti.f64), sigma.cast(ti.f64)
            for a in ti.static(range(2)):
                buf[2 * p + a] = xp[a]
                buf[2 * n + 2 * p + a] = vp[a]
                for b in ti.static(range(2)):
                    buf[4 * n + 4 * p + 2 * a + b] = Fp[a, b]
                    buf[8 * n + 4 * p + 2 * a + b] = sp[a, b]
            lt, mt = self.tangent(Fp, lam, mu)
            buf[12 * n + 2 * p] = lt
            buf[12 * n + 2 * p + 1] = mt
            vol = Fp.determinant() * vol0
            tr = sp.trace()
            strain = ti.cast(0.0, ti.f64)
            if mu > 0.0:
                strain = 0.5 * vol * (sp.norm_sqr() - lam * tr * tr / (2.0 * mu + 2.0 * lam)) / (2.0 * mu)
            elif lam > 0.0:
                strain = 0.5 * vol * 2.0 * (tr / 2.0) ** 2 / (2.0 * lam)
            buf[t0 + 0] += 0.5 * m * vp.norm_sqr()
            buf[t0 + 1] += strain
            buf[t0 + 2] += m * xp[0]
            buf[t0 + 3] += m * xp[1]
            bound = vol / m * ti.min(inv * ti.max(2.0 * lt + 2.0 * mt, 2.0 * mt),
                                     2.0 * inv * ti.max(lt + 2.0 * mt, 2.0 * mt))
            ti.atomic_max(buf[t0 + 4], bound)
            c = ti.sqrt((lt + 2.0 * mt) * vol / m)
            ti.atomic_min(buf[t0 + 5], h / (c + ti.max(ti.abs(vp[0]), ti.abs(vp[1]))))
            if not (h <= xp[0] <= 1.0 - h and h <= xp[1] <= 1.0 - h):
                buf[t0 + 6] += 1.0

    @ti.kernel
    def reduce(self, s: ti.template()):
        """Kinetic, elastic and potential energy, min J, and particles off the box."""
        for k in ti.static(range(5)):
            self.sums[k] = 0.0
        self.sums[3] = 1e30
        for p in s.x:
            J = s.J[p]
            el = 0.5 * self.lam * (J - 1.0) ** 2
            if ti.static(self.jelly):
                R, _ = ti.polar_decompose(s.F[p])
                el += self.mu * (s.F[p] - R).norm_sqr()
            self.sums[0] += ti.cast(0.5 * self.p_mass * s.v[p].norm_sqr(), ti.f64)
            self.sums[1] += ti.cast(self.p_vol * el, ti.f64)
            self.sums[2] += ti.cast(self.p_mass * GRAVITY * s.x[p].y, ti.f64)
            ti.atomic_min(self.sums[3], ti.cast(J, ti.f64))
            lo, hi = self.dx, 1.0 - self.dx
            if not (lo <= s.x[p].x <= hi and lo <= s.x[p].y <= hi):
                self.sums[4] += 1.0

    def energies(self, s: Optional[State] = None) -> list[float]:
        self.reduce(s or self.states[0])
        return [float(v) for v in self.sums.to_numpy()]

    def blown_up(self, s: Optional[State] = None) -> Optional[str]:
        kin, el, _, min_j, out = self.energies(s)
        if self.escaped[None] > 0:
            return f"particles left the grid ({self.escaped[None]} times)"
        if not np.isfinite(kin + el + min_j):
            return "non-finite values"
        if out > 0 or min_j <= 0:
            return f"{int(out)} particles off the box, min J = {min_j:.3g}"
        return f"energy {kin + el:.3g} > 10x budget" if kin + el > 10 * self.budget else None

    # The mpm_dt stepper protocol.
    def time(self) -> float:
        return self.t

    def try_step(self, dt: float) -> None:
        start = time.perf_counter()
        self.substep(self.states[0], self.states[1], dt)
        ti.sync()
        self.solver_s += time.perf_counter() - start
        self.t_trial = self.t + dt

    def accept(self) -> None:
        self.states.reverse()
        self.t = self.t_trial

    def reject(self) -> None:
        pass

    def state(self, trial: bool) -> dict[str, Any]:
        # The arrays are views of one buffer that the next call overwrites: mpm_dt copies
        # what it reads at once; a caller that keeps a state copies it first.
        start = time.perf_counter()
        self.export(self.states[1 if trial else 0], self.buf)
        tot = self.totals
        if trial and tot[6] > 0:
            raise mpm_dt.StepFailed("a particle crossed a wall")
        out = dict(self.out, mass=self.mass, volume0=self.volume0,
                   cells=(self.n_grid,) * 2, length=(1.0, 1.0), boundary="fixed", shape="bspline2",
                   transfer="apic", gradient="mls")
        if self.summary:
            out["summary"] = dict(kinetic=tot[0], strain=tot[1], first_moment=tot[2:4],
                                  element_bound=tot[4], sound_unit_step=tot[5])
        self.export_s += time.perf_counter() - start
        return out

    def reset(self) -> None:
        """Back to the initial state (the same fields, so that no kernel is compiled again)."""
        if not hasattr(self, "initial"):
            self.initial = (self.states[0], self.states[0].x.to_numpy(), self.states[0].v.to_numpy())
        first, x, v = self.initial
        if self.states[0] is not first:
            self.states.reverse()
        first.x.from_numpy(x)
        first.v.from_numpy(v)
        self.reset_rest(first)
        self.escaped[None] = 0
        self.t = self.t_trial = self.solver_s = self.export_s = 0.0


def warm_up(sim: Mpm88) -> None:
    """Compiles every kernel for both orders of the two states."""
    sim.reset()
    for _ in range(2):
        sim.try_step(1e-6)
        sim.state(True)
        sim.accept()
        sim.energies(sim.states[0])
    sim.reset()


def run_fixed(sim: Mpm88, dt: float, t_end: float, check_every: int = 0) -> tuple[int, Optional[str], float]:
    """mpm88's loop with a fixed step: (steps, blow-up, wall time of the stepping)."""
    sim.reset()
    steps, blown, start = 0, None, time.perf_counter()
    t = 0.0
    while t < t_end * (1 - 1e-12):
        step = min(dt, t_end - t)
        sim.substep(sim.states[0], sim.states[1], step)
        sim.states.reverse()
        t += step
        steps += 1
        if check_every and steps % check_every == 0:
            blown = sim.blown_up()
            if blown:
                break
    ti.sync()
    wall = time.perf_counter() - start
    return steps, blown or sim.blown_up(), wall


def run_controlled(sim: Mpm88, t_end: float, config: dict[str, Any]) -> dict[str, Any]:
    """The scene under the controller with the standard limits (no tuning unless `config`
    says so); a controller error is reported in the summary's "error"."""
    sim.reset()
    start = time.perf_counter()
    ctrl = mpm_dt.Controller(dim=2, config=config, gravity=(0.0, -GRAVITY))
    try:
        summary = ctrl.run_until(sim, t_end)
        summary["error"] = None
    except mpm_dt.ControllerError as e:
        summary = dict(ctrl.stats, t_final=sim.time(), error=f"{type(e).__name__}: {e}")
    summary["wall_s"] = time.perf_counter() - start
    summary["solver_s"], summary["export_s"] = sim.solver_s, sim.export_s
    summary["blew_up"] = sim.blown_up()
    return summary


def find_failure(sim: Mpm88, t_end: float) -> float:
    """The smallest fixed step found to blow up: a scan up by 1 % from mpm88's step while it
    is stable, then 6 halvings between the last stable and the first unstable step. A bisection over a
    wide bracket alone is not enough: the splashing fluid's unstable steps are not an
    interval, so it can answer a step far above the smallest failing one. A failing window
    narrower than 1 % can still be missed."""
    def blows_up(dt: float) -> bool:
        blown = run_fixed(sim, dt, t_end, 10)[1]
        print(f"  dt = {dt:.4e}: {blown or 'stable'}")
        return blown is not None
    lo = MPM88_DT
    assert not blows_up(lo), "mpm88's own step blows up"
    while lo < 5 * MPM88_DT and not blows_up(lo * 1.01):
        lo *= 1.01
    hi = lo * 1.01
    for _ in range(6):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if blows_up(mid) else (mid, hi)
    return hi


def handover(n: int, jelly: bool, reps: int = 20) -> None:
    """The hand-over per controlled step against one substep, at n particles."""
    sim = Mpm88(n=n, jelly=jelly)
    warm_up(sim)
    sim.try_step(MPM88_DT)
    s = sim.state(True)
    mpm_dt.read_state(s)
    times = {}
    for name, f in (("substep", lambda: (sim.substep(sim.states[0], sim.states[1], MPM88_DT), ti.sync())),
                    ("state(True) export", lambda: sim.state(True)),
                    ("mpm_dt read (arrays, weights, nodal fields)", lambda: mpm_dt.read_state(s))):
        start = time.perf_counter()
        for _ in range(reps):
            f()
        times[name] = (time.perf_counter() - start) / reps
    for name, t in times.items():
        print(f"  {name:45s} {t * 1e3:8.3f} ms  ({t / times['substep']:.2f} substeps)")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--jelly", action="store_true")
    p.add_argument("--t-end", type=float, default=0.5)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--find-failure", action="store_true")
    p.add_argument("--arch", choices=["cpu", "gpu"], default="cpu")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--handover", type=int, default=0, metavar="N_PARTICLES")
    p.add_argument("--config", default="{}", help="the controller config as JSON (default: {})")
    p.add_argument("--fp64", action="store_true", help="taichi in float64 (mpm88 runs float32)")
    p.add_argument("--no-summary", action="store_true",
                   help="hand over the arrays only: the limits make their own passes")
    args = p.parse_args()
    ti.init(arch=ti.cpu if args.arch == "cpu" else ti.gpu, cpu_max_num_threads=args.threads,
            default_fp=ti.f64 if args.fp64 else ti.f32, log_level=ti.WARN)
    scene = "jelly" if args.jelly else "fluid"
    if args.handover:
        print(f"hand-over at {args.handover} particles ({scene}, {args.arch}, {args.threads} thread(s)):")
        handover(args.handover, args.jelly)
        return
    sim = Mpm88(jelly=args.jelly, summary=not args.no_summary)
    warm_up(sim)
    print(f"mpm88 {scene}: {sim.n} particles, {sim.n_grid}^2 cells, to t = {args.t_end} "
          f"({args.arch}, {args.threads} thread(s))")
    failure = find_failure(sim, args.t_end) if args.find_failure else None
    if failure:
        print(f"failure step: the smallest fixed step found to blow up is {failure:.4e} s (mpm88's 2e-4 = {MPM88_DT / failure:.2f} of it)")
    fixed, controlled = [], []
    for r in range(args.repeat):
        for which in (("c", "f") if r % 2 == 0 else ("f", "c")):
            if which == "f":
                fixed.append(run_fixed(sim, MPM88_DT, args.t_end))
            else:
                controlled.append(run_controlled(sim, args.t_end, json.loads(args.config)))
    f_wall = statistics.median(w for _, _, w in fixed)
    c_wall = statistics.median(c["wall_s"] for c in controlled)
    c = controlled[0]
    steps = c["steps_accepted"] + c["steps_rejected"]
    runs = ", ".join(f"{w:.3f}" for _, _, w in fixed)
    print(f"mpm88 fixed 2e-4: {fixed[0][0]} steps, blow-up: {fixed[0][1] or 'none'}; "
          f"wall median {f_wall:.3f} s ({runs})")
    print(f"controller: {c['steps_accepted']} steps ({c['steps_rejected']} rejected), blow-up: "
          f"{c['blew_up'] or 'none'}; dt mean {c['dt_mean']:.4e} s"
          + (f" = {c['dt_mean'] / failure:.3f} of the failure step" if failure else "")
          + f"; bound by {c['binding']}" + (f"\n  run ended at t = {c['t_final']:.4f}: {c['error']}" if c["error"] else ""))
    runs = ", ".join(f"{x['wall_s']:.3f}" for x in controlled)
    print(f"  wall median {c_wall:.3f} s ({runs}): "
          f"{c_wall / f_wall:.2f}x mpm88's; per attempt: substep {c['solver_s'] / steps * 1e3:.3f} ms, "
          f"state export {c['export_s'] / steps * 1e3:.3f} ms, mpm_dt (read, weights, nodal fields, "
          f"limits) {(c['wall_s'] - c['solver_s'] - c['export_s']) / steps * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
