"""The committed reports are what HEAD computes (the cheap sections).

The assessment (closed form, no data) and the tables (the field recordings)
are regenerated into a temporary folder and their result.json compared with
the committed ``reports/<section>/result.json``: same keys, same strings, and
numbers equal within ``REL`` relative / ``ABS`` absolute. Both sections are
deterministic (no random draw, no threads), so on the machine that wrote the
reports they agree exactly; the margin only covers a different summation
order of another BLAS or libm. A change of the code that moves a number fails
here until the reports are regenerated.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from morpi_filters import evaluate as ev
from morpi_filters.assessment import assessment_study
from morpi_filters.report.assessment import report_assessment
from morpi_filters.report.tables import report_tables
from morpi_filters.reporting import DataSource, stamp_json

REPORTS = Path(__file__).resolve().parent.parent / "reports"
#: Relative and absolute tolerance of the numbers (see the module docstring).
REL, ABS = 1e-9, 1e-12
#: Keys that legitimately differ between machines: the dataset location.
MACHINE_KEYS = {"data_root"}
#: Keys a newer HEAD writes that an older committed report may not have yet.
NEWER_KEYS = {"partial", "left_out", "no_rest"}


def _diff(a, b, where="$", out=None):
    """Differences between committed `a` and regenerated `b`, as readable lines."""
    out = [] if out is None else out
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in MACHINE_KEYS:
                continue
            if k not in a:
                if k not in NEWER_KEYS:
                    out.append(f"{where}.{k}: only in the regenerated report")
            elif k not in b:
                out.append(f"{where}.{k}: only in the committed report")
            else:
                _diff(a[k], b[k], f"{where}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{where}: {len(a)} items committed, {len(b)} regenerated")
        for i, (x, y) in enumerate(zip(a, b)):
            _diff(x, y, f"{where}[{i}]", out)
    elif isinstance(a, bool) or isinstance(b, bool) or a is None or b is None or isinstance(a, str):
        if a != b:
            out.append(f"{where}: {a!r} committed, {b!r} regenerated")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if not (math.isclose(a, b, rel_tol=REL, abs_tol=ABS) or (math.isnan(a) and math.isnan(b))):
            out.append(f"{where}: {a!r} committed, {b!r} regenerated")
    elif a != b:
        out.append(f"{where}: {a!r} committed, {b!r} regenerated")
    return out


def test_diff_sees_a_moved_number():
    # the comparison itself: a change at the 1e-6 level is reported, a machine key is not
    a = {"x": [1.0, {"y": 2.0}], "data_root": "/a", "s": "k"}
    assert _diff(a, {"x": [1.0, {"y": 2.0}], "data_root": "/b", "s": "k"}) == []
    assert _diff(a, {"x": [1.0, {"y": 2.000002}], "data_root": "/a", "s": "k"}) == [
        "$.x[1].y: 2.0 committed, 2.000002 regenerated"]


def test_committed_assessment_is_reproduced(tmp_path):
    committed = json.loads((REPORTS / "assessment" / "result.json").read_text())
    report_assessment(tmp_path / "assessment", assessment_study())
    stamp_json(tmp_path / "assessment" / "result.json", "morpi report", "assessment")   # as the command does
    fresh = json.loads((tmp_path / "assessment" / "result.json").read_text())
    assert _diff(committed, fresh) == []


@pytest.mark.field
def test_committed_tables_are_reproduced(field_root, tmp_path):
    committed = json.loads((REPORTS / "tables" / "result.json").read_text())
    assert committed["synthetic"] is False
    report_tables(tmp_path / "tables", ev.tables_study(field_root), DataSource(field_root))
    stamp_json(tmp_path / "tables" / "result.json", "morpi report", "tables")   # as the command does
    fresh = json.loads((tmp_path / "tables" / "result.json").read_text())
    diffs = _diff(committed, fresh)
    assert diffs == [], f"{len(diffs)} difference(s), first: {diffs[:5]}"
