# mypy: disable-error-code="valid-type,no-untyped-def,untyped-decorator"
# (taichi kernels: `ti.template()` annotations and untyped decorators; the mpm_dt calls are checked.)
"""taichi's mpm88 scene as an mpm_dt stepper (`examples/python/taichi_mpm88.py` runs it).

8192 particles at seeded random positions in [0.2, 0.6]^2 moving at (0, -1), a 128^2 grid
on [0, 1]^2 with walls 3 cells thick, quadratic B-splines, MLS-MPM / APIC, gravity 9.8,
E = 400, particle volume (h/2)^2, density 1: mpm88's weakly compressible fluid, or the
fixed-corotated jelly. `Mpm88` hands over its arrays with every trial; `Mpm88OnDemand`
hands over its summary after every trial and its arrays when the controller asks.
"""

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
    """One state of the particles: position, velocity, affine matrix C, J and F; and what
    the summary pass (`Mpm88.summarize`) found in it: each particle's tangent pair and the
    totals, `summarized` while they describe the state."""

    def __init__(self, n: int) -> None:
        self.x = ti.Vector.field(2, float, n)
        self.v = ti.Vector.field(2, float, n)
        self.C = ti.Matrix.field(2, 2, float, n)
        self.J = ti.field(float, n)
        self.F = ti.Matrix.field(2, 2, float, n)
        self.lame = ti.Vector.field(2, ti.f64, n)
        self.totals = np.zeros(8)
        self.summarized = False


@ti.data_oriented
class Mpm88:
    """The solver as an mpm_dt stepper: ``try_step`` writes the trial into the second
    state, ``accept`` swaps the two."""

    def __init__(self, n: int = 8192, n_grid: int = 128, jelly: bool = False, seed: int = 88,
                 summary: bool = True):
        self.n, self.n_grid, self.jelly, self.with_summary = n, n_grid, jelly, summary
        # The summary pass runs serially on one CPU thread: taichi's parallel loop costs
        # about 10 ns a particle there (0.08 ms of a 0.3 ms pass at 8192 particles).
        cfg = ti.lang.impl.current_cfg()
        self.serial = cfg.arch == ti.cpu and cfg.cpu_max_num_threads == 1
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
        # as contiguous blocks x (n, 2), v (n, 2), F (n, 2, 2), stress (n, 2, 2) and the
        # tangent moduli (n, 2), so that the package reads each field in place.
        self.buf = np.empty(14 * n)
        self.out = dict(x=self.buf[: 2 * n].reshape(n, 2), v=self.buf[2 * n: 4 * n].reshape(n, 2),
                        F=self.buf[4 * n: 8 * n].reshape(n, 2, 2),
                        stress=self.buf[8 * n: 12 * n].reshape(n, 2, 2),
                        lame=self.buf[12 * n: 14 * n].reshape(n, 2))
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
        """x, v, F (sqrt(J) I for the fluid), the Cauchy stress tau / J and the summary
        pass's tangent pairs in float64 into `buf` (layout in `__init__`)."""
        n = self.n
        ti.loop_config(serialize=ti.static(self.serial))
        for p in range(n):
            sigma = self.kirchhoff(s.F[p], s.J[p]) / s.J[p]
            xp, vp = s.x[p].cast(ti.f64), s.v[p].cast(ti.f64)
            Fp, sp = s.F[p].cast(ti.f64), sigma.cast(ti.f64)
            for a in ti.static(range(2)):
                buf[2 * p + a] = xp[a]
                buf[2 * n + 2 * p + a] = vp[a]
                buf[12 * n + 2 * p + a] = s.lame[p][a]
                for b in ti.static(range(2)):
                    buf[4 * n + 4 * p + 2 * a + b] = Fp[a, b]
                    buf[8 * n + 4 * p + 2 * a + b] = sp[a, b]

    @ti.kernel
    def summarize(self, s: ti.template(), buf: ti.types.ndarray()):
        """The summary pass: each particle's tangent pair (lambda_t, mu_t) (`tangent`) into
        `s.lame`, and from the values `export` hands over, in float64, the summary's totals
        into `buf` (8 numbers): kinetic energy, the growth monitor's complementary energy
        1/2 sigma : C^-1 : sigma V (rest moduli), the first moment, the element bound
        (V/m) min((4/h^2) max(2 lambda_t + 2 mu_t, 2 mu_t), 2 (4/h^2) max(lambda_t + 2 mu_t, 2 mu_t))
        of MLS-MPM's gradients, the speed-of-sound step min h / (c_p + |v_a|) with
        c_p = sqrt((lambda_t + 2 mu_t) / rho), the number of particles within a cell of
        the box's edge and the number with J <= 0."""
        for k in ti.static(range(8)):
            buf[k] = 0.0
        buf[5] = 1e30
        lam, mu = self.consts[0], self.consts[1]
        ti.loop_config(serialize=ti.static(self.serial))
        for p in range(self.n):
            sigma = self.kirchhoff(s.F[p], s.J[p]) / s.J[p]
            Fp = s.F[p].cast(ti.f64)
            lt, mt = self.tangent(Fp, lam, mu)
            s.lame[p] = ti.Vector([lt, mt])
            self.add_totals(s.x[p].cast(ti.f64), s.v[p].cast(ti.f64), Fp, sigma.cast(ti.f64),
                            lt, mt, buf)

    @ti.func
    def add_totals(self, xp, vp, Fp, sp, lt, mt, buf: ti.template()):
        """One particle's share of the summary's totals (`summarize`) in `buf`."""
        lam, mu, h = self.consts[0], self.consts[1], self.consts[2]
        m, vol0 = self.consts[3], self.consts[4]
        inv = 4.0 / (h * h)
        vol = Fp.determinant() * vol0
        tr = sp.trace()
        strain = ti.cast(0.0, ti.f64)
        if mu > 0.0:
            strain = 0.5 * vol * (sp.norm_sqr() - lam * tr * tr / (2.0 * mu + 2.0 * lam)) / (2.0 * mu)
        elif lam > 0.0:
            strain = 0.5 * vol * 2.0 * (tr / 2.0) ** 2 / (2.0 * lam)
        buf[0] += 0.5 * m * vp.norm_sqr()
        buf[1] += strain
        buf[2] += m * xp[0]
        buf[3] += m * xp[1]
        bound = vol / m * ti.min(inv * ti.max(2.0 * lt + 2.0 * mt, 2.0 * mt),
                                 2.0 * inv * ti.max(lt + 2.0 * mt, 2.0 * mt))
        ti.atomic_max(buf[4], bound)
        c = ti.sqrt((lt + 2.0 * mt) * vol / m)
        ti.atomic_min(buf[5], h / (c + ti.max(ti.abs(vp[0]), ti.abs(vp[1]))))
        if not (h <= xp[0] <= 1.0 - h and h <= xp[1] <= 1.0 - h):
            buf[6] += 1.0
        if vol <= 0.0:
            buf[7] += 1.0

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
        self.states[1].summarized = False
        self.t_trial = self.t + dt

    def accept(self) -> None:
        self.states.reverse()
        self.t = self.t_trial

    def reject(self) -> None:
        pass

    def summarized(self, trial: bool) -> State:
        """The state, its summary pass run (once a state: a trial's summary and arrays
        share it)."""
        s = self.states[1 if trial else 0]
        if not s.summarized:
            self.summarize(s, s.totals)
            s.summarized = True
        return s

    def state(self, trial: bool) -> dict[str, Any]:
        # The arrays are views of one buffer that the next call overwrites: mpm_dt copies
        # what it reads at once; a caller that keeps a state copies it first.
        start = time.perf_counter()
        s = self.summarized(trial)
        self.export(s, self.buf)
        tot = s.totals
        if trial and tot[6] > 0:
            raise mpm_dt.StepFailed("a particle crossed a wall")
        out = dict(self.out, mass=self.mass, volume0=self.volume0,
                   cells=(self.n_grid,) * 2, length=(1.0, 1.0), boundary="fixed", shape="bspline2",
                   transfer="apic", gradient="mls")
        if self.with_summary:
            out["summary"] = totals_dict(tot)
        self.export_s += time.perf_counter() - start
        return out

    def summary_dict(self, trial: bool) -> dict[str, Any]:
        """The summary alone (the summary pass), with the checks the package makes only
        on the states whose arrays it reads: no particle past a wall, none inverted."""
        start = time.perf_counter()
        tot = self.summarized(trial).totals
        self.export_s += time.perf_counter() - start
        if trial and tot[6] > 0:
            raise mpm_dt.StepFailed("a particle crossed a wall")
        if trial and tot[7] > 0:
            raise mpm_dt.StepFailed(f"{int(tot[7])} particles inverted (J <= 0)")
        return totals_dict(tot)

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
        for s in self.states:
            s.summarized = False
        self.escaped[None] = 0
        self.t = self.t_trial = self.solver_s = self.export_s = 0.0


def totals_dict(tot: np.ndarray) -> dict[str, Any]:
    """The package's summary dict of the summary pass's totals (`Mpm88.summarize`)."""
    return dict(kinetic=tot[0], strain=tot[1], first_moment=tot[2:4],
                element_bound=tot[4], sound_unit_step=tot[5])


class Mpm88OnDemand(Mpm88):
    """The same stepper handing over on demand: its `summary(trial)` after every trial, its
    arrays (`state`) only when the controller asks (a lambda_max refresh, a temporal-error
    check, the door check)."""

    def summary(self, trial: bool) -> dict[str, Any]:
        return self.summary_dict(trial)
