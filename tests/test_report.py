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
        from morpi_filters.results import SectionSummary
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
        stage.mkdir(parents=True, exist_ok=True), __import__("morpi_filters.results").results.SectionSummary(
            name=name, title=name))[1])
    assert cli.main(["report", "--out", str(out)]) == 0
    assert (out / "index.md").read_text() != "previous complete report"
    assert (out / "extra" / "fig.png").read_bytes() == b"x"


def test_report_evaluates_the_field_data_once(tmp_path, monkeypatch):
    """`morpi report` evaluates the recordings once and hands the same result to every section."""
    from morpi_filters import cli, evaluate, synthetic
    from morpi_filters.results import SectionSummary

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


def test_aided_page_states_the_corrected_wins_and_names_the_cells_with_odd_step_nis():
    """The page's verdict reads the Holm-corrected counts, and lists each GC cell whose step NIS per degree
    of freedom lies outside the wording range, with the innovations that explain it."""
    from types import SimpleNamespace

    from morpi_filters.field_aided import AidedCell, AidedStudy, PairedDifference
    from morpi_filters.report.aided import NIS_WORDING_RANGE, _page

    def cell(name, step_nis, pair, along_rms, sigma):
        spec = SimpleNamespace(label=name, calibration="GC", method="MoRPI-G", table="short_route",
                               train=("s8", "short_distance"), paper_percent=4.0)
        tuning = {"vibration": 300.0, "step_sigma": 0.02, "gain_state": "considered", "step_heading": "route",
                  "nhc": False}
        inn = {"updates": 100, "along_mean_m": 0.0, "along_rms_m": along_rms, "cross_mean_m": 0.0,
               "cross_rms_m": 0.05, "predicted_along_sigma_m": sigma}
        return AidedCell(spec=spec, forward_percent=3.0, smoothed_percent=3.0, morpi_percent=3.2, ins_percent=500.0,
                         runs=({},) * 10, tuning=tuning, train_percent=3.1, train_loo_percent=3.1,
                         train_morpi_percent=3.3, nis={"step": (2 * step_nis, 2, 100)}, paths=(),
                         step_innovation=inn, paired=pair, steps_alone_percent=3.05,
                         paired_steps=PairedDifference(-0.05, 0.1, 10, 0.6, p_holm=1.0, mdd_pp=0.3),
                         coverage_95=0.9, coverage_95_forward=0.9,
                         coverage_axes={"smoothed": {"along_95": 0.9, "cross_95": 1.0}},
                         cross_zero_by_construction=True)

    odd = cell("odd cell", 0.01, PairedDifference(-0.2, 0.05, 10, 0.003, p_holm=0.006, mdd_pp=0.2), 0.2, 1.0)
    fine = cell("fine cell", 1.0, PairedDifference(-0.2, 0.08, 10, 0.03, p_holm=0.06, mdd_pp=0.3), 0.3, 0.3)
    sig = {"cells": 2, "wins_uncorrected": 2, "wins_corrected": 1, "losses_uncorrected": 0, "losses_corrected": 0,
           "ties_corrected": 1, "alpha": 0.05, "power": 0.8, "vs_steps_alone": {"wins_uncorrected": 0,
                                                                                "wins_corrected": 0}}
    study = AidedStudy(cells=(odd, fine), ablation=(), coverage_95=0.9, nis={}, significance=sig)
    page = _page(study, None, [])
    assert "better in 2 and worse in 0 before any correction" in page
    assert "over the 2 GC cells (the family-wise level 5 %), better in 1, worse in 0, and a tie in 1" in page
    # the tie states what the runs could have detected, not an equivalence
    assert "A tie is no equivalence" in page and "is 0.30 to 0.30 pp" in page
    listed = page.split(f"lies outside [{NIS_WORDING_RANGE[0]:.1f}, {NIS_WORDING_RANGE[1]:.1f}]:")[1].split("\n\n")[1]
    assert listed.startswith("- odd cell: step NIS per dof 0.010") and "fine cell" not in listed
    assert "0.200 m RMS along the step against the 1.000 m the filter expects" in listed


def test_aided_page_compares_the_filter_with_morpi_alone_under_its_best_reading():
    """The page's best-reading section names the chosen readings and states the counts against that baseline."""
    from types import SimpleNamespace

    from morpi_filters.field_aided import AidedCell, AidedStudy, PairedDifference, ReadingChoice
    from morpi_filters.report.aided import _page, study_json

    spec = SimpleNamespace(label="a cell", calibration="GC", method="MoRPI-G", table="short_route",
                           train=("s8", "short_distance"), paper_percent=4.0, phone="s8", p2p_m=1.0,
                           route="short_distance")
    tuning = {"vibration": 300.0, "step_sigma": 0.02, "gain_state": "considered", "step_heading": "route", "nhc": False}
    best = PairedDifference(-0.04, 0.1, 10, 0.7, p_holm=0.7, mdd_pp=0.3)
    cell = AidedCell(spec=spec, forward_percent=3.0, smoothed_percent=3.0, morpi_percent=3.5, ins_percent=500.0,
                     runs=({},) * 10, tuning=tuning, train_percent=3.1, train_loo_percent=3.1,
                     train_morpi_percent=3.3, nis={}, paths=(), steps_alone_percent=3.05,
                     paired=PairedDifference(-0.5, 0.1, 10, 0.001, p_holm=0.001, mdd_pp=0.3),
                     morpi_best_percent=3.04, morpi_reading="route", paired_best=best, morpi_length="weinberg",
                     period_count_percent=3.6)
    sig = {"cells": 1, "wins_uncorrected": 1, "wins_corrected": 1, "losses_uncorrected": 0, "losses_corrected": 0,
           "ties_corrected": 0, "alpha": 0.05, "power": 0.8,
           "vs_morpi_best": {"cells": 1, "wins_uncorrected": 0, "wins_corrected": 0, "losses_uncorrected": 0,
                             "losses_corrected": 0, "ties_corrected": 1}}
    study = AidedStudy(cells=(cell,), ablation=(), coverage_95=0.9, nis={}, significance=sig,
                       readings=(ReadingChoice("MoRPI-G", "route", 4.2, 3.1, 0.2, 12),))
    page = _page(study, None, [])
    section = page.split("## Against MoRPI alone under its best train-chosen reading")[1].split("\n## ")[0]
    assert "MoRPI-G route (train LOO 4.20 % with the rule's reading, 3.10 % with the route's)" in section
    assert "better run by run in 0 and worse in 0 at 5 %" in section
    assert "after Holm over the 1 GC cells better in 0, worse in 0, a tie in 1" in section
    assert "| a cell | 3.50 | route | weinberg | 3.60 | 3.04 | 3.05 | 3.00 |" in section
    js = study_json(study)
    assert js["cells"][0]["morpi_best_percent"] == 3.04 and js["cells"][0]["morpi_reading"] == "route"
    assert js["cells"][0]["smoothed_vs_morpi_best"]["mean_pp"] == -0.04
    assert js["morpi_readings"] == [{"method": "MoRPI-G", "reading": "route", "rule_percent": 4.2,
                                     "route_percent": 3.1, "difference_se_pp": 0.2, "runs": 12}]


def test_the_ins_benefit_is_claimed_only_where_it_survives_holm():
    # The `What the INS adds` column says "yes" only for a difference significant after the correction;
    # a lower mean within the runs' spread, or significant before the correction only, is no claim.
    from types import SimpleNamespace as NS

    from morpi_filters.report.aided import _ins_benefit

    def cell(mean, verdict, holm):
        return NS(paired_steps=NS(runs=10, mean_pp=mean, verdict=verdict, verdict_holm=holm, alpha=0.05))

    assert _ins_benefit(cell(-0.25, "better", "better")).startswith("yes, by 0.250 pp")
    assert _ins_benefit(cell(-0.057, "better", "tie")).startswith("not shown: 0.057 pp lower")
    assert "before the correction only" in _ins_benefit(cell(-0.057, "better", "tie"))
    assert _ins_benefit(cell(-0.067, "tie", "tie")) == "not shown: 0.067 pp lower on average, within the runs' spread"
    assert _ins_benefit(cell(0.019, "tie", "tie")).startswith("no: 0.019 pp behind")


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
