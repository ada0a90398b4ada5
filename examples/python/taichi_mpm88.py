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
        [--config JSON] [--no-summary] [--eager]

* every run times mpm88's fixed step and the controlled run ``--repeat`` times,
  interleaved (the controller first in every other round), and prints the medians;
* ``--find-failure`` finds the smallest fixed step at which the run blows up before ``t_end``
  (non-finite values, a particle past a wall, J <= 0, or kinetic plus elastic energy above
  10x what the block has to give: its initial kinetic plus potential energy) by a 1 % scan
  from mpm88's step and a bisection;
* the stepper hands over, with the arrays, a ``"summary"`` its summary pass computes
  (energies, the element bound of MLS-MPM's gradients, the speed-of-sound step; one kernel
  a state, run serially on one CPU thread), so that the limits make no passes of their
  own for them; ``--no-summary`` hands over the arrays only;
* by default the stepper hands over on demand: after every trial the summary alone, the
  arrays only when the controller asks for them (a lambda_max refresh, a temporal-error
  check, the door check every 64 steps); ``--eager`` hands over the arrays with every
  trial;
* ``--handover N`` times one substep, the summary pass, the state export and the
  package's read of it at N particles (the hand-over's cost per controlled step) and exits.
"""

import argparse
import json
import statistics
import time
from typing import Any, Optional

import mpm_dt
import taichi as ti  # type: ignore[import-untyped]

from mpm88_scene import GRAVITY, MPM88_DT, Mpm88, Mpm88OnDemand, State  # noqa: F401

def warm_up(sim: Mpm88) -> None:
    """Compiles every kernel for both orders of the two states."""
    sim.reset()
    for _ in range(2):
        sim.try_step(1e-6)
        sim.state(True)
        sim.summary_dict(True)
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

    def substep() -> None:
        sim.substep(sim.states[0], sim.states[1], MPM88_DT)
        ti.sync()
    trial = sim.states[1]
    for name, f in (("substep", substep),
                    ("summary pass (`summarize`)", lambda: sim.summarize(trial, trial.totals)),
                    ("state(True) export (the arrays)", lambda: sim.state(True)),
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
    p.add_argument("--eager", action="store_true",
                   help="hand over the arrays with every trial, not on demand")
    args = p.parse_args()
    ti.init(arch=ti.cpu if args.arch == "cpu" else ti.gpu, cpu_max_num_threads=args.threads,
            default_fp=ti.f64 if args.fp64 else ti.f32, log_level=ti.WARN)
    scene = "jelly" if args.jelly else "fluid"
    if args.handover:
        print(f"hand-over at {args.handover} particles ({scene}, {args.arch}, {args.threads} thread(s)):")
        handover(args.handover, args.jelly)
        return
    kind = Mpm88 if args.eager or args.no_summary else Mpm88OnDemand
    sim = kind(jelly=args.jelly, summary=not args.no_summary)
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
