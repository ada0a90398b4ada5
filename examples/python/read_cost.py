"""What mpm_dt's read of one state dict costs (arrays, weights, nodal fields), by dtype and
layout: 8192 particles on a 128^2 grid, quadratic B-splines with MLS gradients.
Usage: python examples/python/read_cost.py [--particles N]  (CPU time per read)"""

import argparse
import time
from typing import Any

import mpm_dt
import numpy as np


def cpu_ms(state: dict[str, Any], reps: int) -> float:
    mpm_dt.read_state(state)
    start = time.process_time()
    for _ in range(reps):
        mpm_dt.read_state(state)
    return (time.process_time() - start) / reps * 1e3


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--particles", type=int, default=8192)
    n = p.parse_args().particles
    x = np.random.default_rng(1).random((n, 2)) * 0.4 + 0.2
    base = dict(x=x, v=np.zeros((n, 2)), F=np.tile(np.eye(2), (n, 1, 1)), stress=np.zeros((n, 2, 2)),
                mass=np.full(n, 1e-5), volume0=np.full(n, 1e-5), lame=np.tile([400.0, 0.0], (n, 1)),
                cells=(128, 128), length=(1.0, 1.0), boundary="fixed", shape="bspline2",
                transfer="apic", gradient="mls")
    packed = np.zeros((n, 12), np.float32)
    packed[:, 0:2], packed[:, 4:8] = x, [1, 0, 0, 1]
    f32 = {k: v.astype(np.float32) if isinstance(v, np.ndarray) else v for k, v in base.items()}
    cases = {
        "float64, C-contiguous (read in place)": base,
        "float32, C-contiguous (converted)": f32,
        "float32, strided views of one packed array": dict(
            base, x=packed[:, 0:2], v=packed[:, 2:4], F=packed[:, 4:8].reshape(-1, 2, 2),
            stress=packed[:, 8:12].reshape(-1, 2, 2)),
    }
    reps = max(3, 2_000_000 // n)
    for name, state in cases.items():
        print(f"{name:45s} {cpu_ms(state, reps):8.3f} ms CPU per read")


if __name__ == "__main__":
    main()
