"""`morpi report` end to end: every section, index links, synthetic default, interruption safety."""
from __future__ import annotations

import os
from pathlib import Path
import re
import subprocess
import sys
from pathlib import Path

import pytest

from morpi_filters import cli

ROOT = Path(__file__).resolve().parents[1]
SECTIONS = ("tables", "aided", "assessment", "curves", "montecarlo", "drift")


@pytest.fixture(scope="module")
def synthetic_report(tmp_path_factory):
    """`morpi report` in an empty folder with no dataset configured (a fresh machine's main job)."""
    cwd = tmp_path_factory.mktemp("fresh")
    # The package under test is this checkout's, not whatever is installed.
    env = {k: v for k, v in os.environ.items() if k != "MORPI_DATA"}
    env["PYTHONPATH"] = str(ROOT)   # this checkout, not an installed copy
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "report", "--runs", "200"],
                       cwd=cwd, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    # The first console line says the report is synthetic and where it goes.
    first = r.stdout.splitlines()[0]
    assert "synthetic" in first and "reports/synthetic" in first, first
    # A synthetic run writes reports/synthetic/ only, never the field report's place.
    assert sorted(p.name for p in (cwd / "reports").iterdir()) == ["synthetic"]
    return cwd / "reports" / "synthetic"


def test_report_without_dataset_has_every_section(synthetic_report):
    index = (synthetic_report / "index.md").read_text()
    assert "Synthetic data" in index and "morpi data fetch" in index
    for name in SECTIONS:
        page = synthetic_report / name / "README.md"
        assert page.is_file() and (synthetic_report / name / "result.json").is_file()
        assert f"]({name}/README.md)" in index
    # Every figure the index shows exists.
    for png in re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", index):
        assert (synthetic_report / png).is_file(), png
    # Pages computed on the recordings say they are synthetic, on the page itself.
    for name in ("tables", "aided", "curves", "montecarlo"):
        assert (synthetic_report / name / "README.md").read_text().startswith("> **Synthetic data.**")
    # Nothing staged is left behind.
    assert not [p for p in synthetic_report.parent.iterdir() if p.name.startswith((".staging", ".previous"))]


def test_interrupted_report_keeps_previous(tmp_path, monkeypatch):
    out = tmp_path / "reports"
    (out / "tables").mkdir(parents=True)
    (out / ".morpi-output").write_text('{"morpi_output": 1, "command": "morpi report", "kind": "report", '
                                       '"files": ["index.md"], "folders": ["tables"]}')   # an earlier report's marker
    (out / "index.md").write_text("previous complete report")
    (out / "extra").mkdir()
    (out / "extra" / "fig.png").write_bytes(b"x")

    calls = []

    def fake_section(name, stage, args, source=None, tables=None):
        calls.append(name)
        stage.mkdir(parents=True, exist_ok=True)
        (stage / "README.md").write_text(name)
        if name == "curves":
            raise KeyboardInterrupt
        from morpi_filters.reporting import SectionSummary
        return SectionSummary(name=name, title=name)

    monkeypatch.setattr(cli, "_section", fake_section)
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    assert cli.main(["report", "--out", str(out)]) == 130
    assert calls == ["tables", "aided", "assessment", "curves"]
    assert (out / "index.md").read_text() == "previous complete report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reports"]
    assert sorted(p.name for p in out.iterdir()) == [".morpi-output", "extra", "index.md", "tables"]

    # A complete run replaces the report and keeps outputs it does not own (analysis figures).
    monkeypatch.setattr(cli, "_section", lambda name, stage, args, source=None, tables=None: (
        stage.mkdir(parents=True, exist_ok=True), __import__("morpi_filters.reporting").reporting.SectionSummary(
            name=name, title=name))[1])
    assert cli.main(["report", "--out", str(out)]) == 0
    assert (out / "index.md").read_text() != "previous complete report"
    assert (out / "extra" / "fig.png").read_bytes() == b"x"


def test_report_evaluates_the_field_data_once(tmp_path, monkeypatch):
    """`morpi report` evaluates the recordings once and hands the same result to every section."""
    from morpi_filters import cli, evaluate, synthetic
    from morpi_filters.reporting import SectionSummary

    root = synthetic.write_dataset(tmp_path / "ds", seed=2, runs_per_folder=1)
    calls, seen = [], {}
    real = evaluate.evaluate_tables

    def counting(*a, **k):
        calls.append(a)
        return real(*a, **k)

    def fake_section(name, stage, args, source=None, tables=None):
        seen[name] = tables
        (stage / "README.md").write_text(f"# {name}\n")
        return SectionSummary(name=name, title=name)

    monkeypatch.setattr(evaluate, "evaluate_tables", counting)
    monkeypatch.setattr(cli, "_section", fake_section)
    assert cli.main(["report", "--data", str(root), "--out", str(tmp_path / "r"), "--runs", "10"]) == 0
    assert len(calls) == 1
    assert set(seen) == set(cli.REPORT_SECTIONS)
    assert all(t is seen["tables"] for t in seen.values()) and seen["tables"] is not None


def test_aided_page_reads_the_step_innovations_by_their_numbers():
    from morpi_filters.report.aided import _innovation_sentence

    def cell(n, mean, rms, sigma):
        return {"updates": n, "along_mean_m": mean, "along_rms_m": rms, "cross_mean_m": 0.0, "cross_rms_m": 0.1,
                "predicted_along_sigma_m": sigma}

    # two cells pooled: mean (-1 * 100 + 0 * 300) / 400 = -0.25 m, RMS sqrt((1.2^2 * 100 + 0.6^2 * 300) / 400) = 0.794 m
    text = _innovation_sentence([cell(100, -1.0, 1.2, 0.3), cell(300, 0.0, 0.6, 0.5)])
    assert "over 400 updates is -0.250 m against an RMS of 0.794 m" in text
    assert "a steady overrun" in text and "beyond the spread the filter expects (median 0.40 m)" in text
    text = _innovation_sentence([cell(50, 0.01, 0.3, 0.7)])
    assert "not a steady over- or under-run" in text and "within the spread" in text
    assert _innovation_sentence([]) == ""


def test_aided_page_and_json_list_the_recordings_without_a_rest(tmp_path):
    # the filter starts at the rest window: the recordings without one are named, with why, on the page and in
    # the JSON (here an otherwise empty study)
    import json

    from morpi_filters.field_aided import AidedStudy
    from morpi_filters.report.aided import report_aided

    why = ("ds/s8/line_dataset/1.csv: no initial rest found: motion starts 0.000 s after the first sample",
           "ds/s6/L_line/2.csv: no initial rest found: motion starts 0.000 s after the first sample")
    for no_rest in ((), why):
        out = tmp_path / f"aided{len(no_rest)}"
        report_aided(out, AidedStudy(cells=(), ablation=(), coverage_95=float("nan"), nis={}, note="no cell",
                                     no_rest=no_rest))
        assert json.loads((out / "result.json").read_text())["no_rest"] == list(no_rest)
        page = (out / "README.md").read_text()
        assert ("Recordings without an initial rest" in page) == bool(no_rest)
        assert all(f"- {x}\n" in page for x in no_rest)
