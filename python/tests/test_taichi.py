"""The taichi mpm88 scene under the controller: a short run (skipped without taichi)."""

import importlib.util
import pathlib
import sys
from typing import Any

import pytest

ti = pytest.importorskip("taichi")

import mpm_dt  # noqa: E402

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "taichi_mpm88.py"


@pytest.fixture(scope="module")
def mpm88() -> Any:
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
    """The summary the export kernel computes (in float64, from the same values) is what the
    library computes from the arrays: the same steps with and without it."""
    runs = []
    for summary in (False, True):
        sim = mpm88.Mpm88(jelly=True, summary=summary)
        decisions: list[dict[str, Any]] = []
        mpm_dt.Controller(dim=2, config={}, gravity=(0.0, -9.8)).run_until(sim, 0.005, decisions.append)
        runs.append(decisions)
    assert len(runs[0]) == len(runs[1]) > 3
    for a, b in zip(*runs):
        assert b["dt"] == pytest.approx(a["dt"], rel=1e-9) and b["binding"] == a["binding"]
