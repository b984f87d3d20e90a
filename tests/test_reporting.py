"""Atomic files and staged folders: an interrupted write leaves the old output intact."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from morpi_filters.report.common import md_table
from morpi_filters.reporting import atomic_path, staged_dir, write_json, write_text


def test_write_json_converts_numpy_and_nonfinite(tmp_path):
    p = write_json(tmp_path / "a.json", {"x": np.arange(3), "y": np.float32(1.5), "z": math.nan,
                                         "w": [np.inf, 2], "b": np.bool_(True)})
    assert json.loads(p.read_text()) == {"x": [0, 1, 2], "y": 1.5, "z": None, "w": [None, 2], "b": True}


def test_atomic_path_failure_keeps_old_file(tmp_path):
    target = write_text(tmp_path / "r.md", "old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.md"]


def test_staged_dir_swaps_on_success_and_keeps_old_on_failure(tmp_path):
    final = tmp_path / "section"
    with staged_dir(final) as stage:
        (stage / "a.txt").write_text("v1")
    assert (final / "a.txt").read_text() == "v1"
    with pytest.raises(KeyboardInterrupt):
        with staged_dir(final) as stage:
            (stage / "a.txt").write_text("v2-partial")
            raise KeyboardInterrupt
    assert (final / "a.txt").read_text() == "v1"
    with staged_dir(final) as stage:
        (stage / "b.txt").write_text("v2")
    # The new folder holds the new files and the ownership marker only.
    assert sorted(p.name for p in final.iterdir()) == [".morpi-output", "b.txt"]
    # No staging or previous folders are left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["section"]


def test_md_table():
    assert md_table(["a", "b"], [[1, 2]]) == "| a | b |\n|---|---|\n| 1 | 2 |\n"
