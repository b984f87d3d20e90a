"""The tutorial (docs/tutorial.py): each study is short, uses public names only, and gives the CLI's numbers."""
from __future__ import annotations

import ast
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from morpi_filters.cli import main
from morpi_filters.results import JSON_DIGITS, to_jsonable

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "tutorial.py"
STUDIES = ("field_run", "closed_form_vs_filter", "shaped_monte_carlo")


@pytest.fixture(scope="module")
def tutorial():
    spec = importlib.util.spec_from_file_location("morpi_tutorial", TUTORIAL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _functions():
    tree = ast.parse(TUTORIAL.read_text())
    return {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}


@pytest.mark.parametrize("name", STUDIES)
def test_each_study_is_at_most_15_lines_of_public_api(name):
    f = _functions()[name]
    lines = TUTORIAL.read_text().splitlines()[f.body[0].lineno - 1:f.end_lineno]
    code = [ln for ln in lines if ln.strip() and not ln.strip().startswith("#")]
    assert len(code) <= 15, (name, len(code))
    for node in ast.walk(f):
        if isinstance(node, ast.Attribute):
            assert not (node.attr.startswith("_") and not node.attr.startswith("__")), (name, node.attr)
        if isinstance(node, ast.ImportFrom):
            assert node.module.startswith("morpi_filters") or node.module in ("pathlib", "numpy"), node.module
            assert all(not a.name.startswith("_") for a in node.names), (name, [a.name for a in node.names])
            assert not any(part.startswith("_") for part in node.module.split(".")), node.module


def test_closed_form_study_gives_the_curves_json(tutorial, tmp_path, monkeypatch):
    monkeypatch.delenv("MORPI_DATA", raising=False)
    js = tmp_path / "curves.json"
    assert main(["curves", "--out", str(tmp_path / "curves"), "--json", str(js)]) == 0
    cli = json.loads(js.read_text())
    times = [0.0, 5.0, 10.0, 15.0]
    idx = [cli["time_s"].index(t) for t in times]
    ours = tutorial.closed_form_vs_filter(tuple(times))
    for method, v in ours.items():
        # the same filter and the same polynomials on the same grid: equal to the last bits
        np.testing.assert_allclose(v["sigma_m"], np.array(cli["sigma_m"][method])[idx], rtol=1e-12, atol=0)
        np.testing.assert_allclose(v["closed_form_rms_m"], np.array(cli["rms_closed_form_m"][method])[idx],
                                   rtol=1e-12, atol=0)
    # and the study's point: without noise the INS sigmas are the closed forms (rounding only, 1e-9)
    for method in ("INS-3D", "INS-2D"):
        np.testing.assert_allclose(ours[method]["sigma_m"], ours[method]["closed_form_rms_m"], rtol=1e-9)


def test_monte_carlo_study_gives_the_montecarlo_json(tutorial, tmp_path, monkeypatch):
    monkeypatch.delenv("MORPI_DATA", raising=False)
    js = tmp_path / "mc.json"
    argv = ["montecarlo", "--runs", "120", "--seed", "4", "--duration-s", "20", "--out", str(tmp_path / "mc"),
            "--json", str(js)]
    assert main(argv) == 0
    cli = json.loads(js.read_text())
    result, stats, checks = tutorial.shaped_monte_carlo(runs=120, seed=4, duration=20.0)
    assert result.digest == cli["digest"]                      # bit for bit the command's calibrated study
    assert cli["config"]["duration_s"] == 20.0 and result.time[-1] == pytest.approx(20.0)
    for m, s in stats.items():
        assert to_jsonable(s, JSON_DIGITS) == cli[m]           # exactly, at the JSON's stated precision
    assert [c["label"] for c in checks] == [c["label"] for c in cli["scenarios"]]


@pytest.mark.field
def test_field_study_gives_the_tables_json(tutorial, field_root, tmp_path):
    js = tmp_path / "tables.json"
    assert main(["tables", "--data", str(field_root), "--out", str(tmp_path / "tables"), "--json", str(js)]) == 0
    cells = json.loads(js.read_text())["cells"]
    cell = next(c for c in cells if c["table"] == "short_route" and c["phone"] == "s8" and c["p2p_m"] == 1.0
                and c["method"] == "MoRPI-G" and c["calibration"] == "GC")
    run = next(r for r in cell["runs"] if r["file"] == "s8/short_distance/test/2.csv")
    ours = tutorial.field_run(field_root)
    # the same recording through the same steps, gain and dead reckoning: float rounding only
    assert ours["end_error_percent"] == pytest.approx(run["end_error_percent"], rel=1e-9)
    assert ours["steps"] == run["n_steps"] and ours["gain"] == pytest.approx(cell["gain"], rel=1e-12)
