"""Shared fixtures: the numpy solver of examples/python/numpy_bar.py, loaded by path."""

from __future__ import annotations

import importlib.util
import pathlib
import sys
from typing import Any

import pytest

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "numpy_bar.py"


def load_example() -> Any:
    spec = importlib.util.spec_from_file_location("numpy_bar", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["numpy_bar"] = module
    spec.loader.exec_module(module)
    return module


numpy_bar = load_example()


@pytest.fixture
def bar() -> Any:
    """A small periodic strip: 8 x 4 cells, 4 particles per cell, E = 100."""
    return numpy_bar.NumpyBar(cells=8)
