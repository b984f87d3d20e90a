"""Shared fixtures: the field dataset location and small CSV writers.

The field dataset is found at ``$MORPI_DATA`` or ``../shared/morpi-dataset``.
Tests that need it use the ``field_root`` fixture: they skip when it is absent,
except when ``MORPI_REQUIRE_DATA=1`` (CI), where they fail. The paper's source
(``$MORPI_PAPER`` or ``../shared/paper/``) is found the same way by ``paper_tex``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


def _field_root():
    env = os.environ.get("MORPI_DATA")
    for cand in ([Path(env)] if env else []) + [ROOT.parent / "shared" / "morpi-dataset"]:
        if cand.is_dir():
            return cand
    return None


def plain_kernels(module):
    """The loops module `module` loaded a second time and never compiled: its loops as plain Python, which the
    tests run beside the compiled ones (same bits). The loops it imports from another loops module are that
    module's plain copies too, so no compiled callee hides in a plain loop."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location(module.__name__ + "_plain", module.__file__)
    plain = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(plain)
    for name, value in list(vars(plain).items()):
        home = sys.modules.get(getattr(getattr(value, "py_func", value), "__module__", None) or "")
        if callable(value) and home not in (None, module) and name in getattr(home, "_FUNCTIONS", ()):
            setattr(plain, name, getattr(plain_kernels(home), name))
    return plain


@pytest.fixture(scope="session")
def field_root():
    root = _field_root()
    if root is None:
        if os.environ.get("MORPI_REQUIRE_DATA") == "1":
            pytest.fail("field dataset missing: set MORPI_DATA or place it at ../shared/morpi-dataset")
        pytest.skip("field dataset not available")
    return root


def _paper_tex():
    env = os.environ.get("MORPI_PAPER")
    for cand in ([Path(env)] if env else []) + [ROOT.parent / "shared" / "paper"]:
        tex = cand / "morpi-paper.tex"
        if tex.is_file():
            return tex
    return None


@pytest.fixture(scope="session")
def paper_tex():
    """The paper's LaTeX source: ``$MORPI_PAPER/morpi-paper.tex`` or ``../shared/paper/``."""
    tex = _paper_tex()
    if tex is None:
        if os.environ.get("MORPI_REQUIRE_DATA") == "1":
            pytest.fail("paper source missing: set MORPI_PAPER or place it at ../shared/paper/morpi-paper.tex")
        pytest.skip("paper source not available")
    return tex


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import sys
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


def write_rows(path, rows, header="time,f_x,f_y,f_z,g_x,g_y,g_z"):
    """Write a CSV with a header and rows given as lists or strings."""
    lines = [header] if header is not None else []
    for r in rows:
        lines.append(r if isinstance(r, str) else ",".join(repr(float(v)) for v in r))
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def good_rows(n=200, dt=0.01, t0=0.3):
    """Rows of a level phone at rest, sampled at a slightly irregular rate."""
    rng = np.random.default_rng(5)
    t = t0 + np.cumsum(np.full(n, dt) + rng.uniform(0, 0.002, n))
    f = np.tile([0.0, 0.0, 9.81], (n, 1))
    w = np.zeros((n, 3))
    return np.column_stack([t, f, w]).tolist()
