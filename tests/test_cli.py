"""The `morpi` command: help, one-line errors, exit codes."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from morpi_filters.cli import main
from conftest import good_rows, write_rows


def run(*args, cwd=None, env=None):
    # The package under test is this checkout's, whatever the working directory and installation.
    env = dict(os.environ if env is None else env, PYTHONPATH=str(Path(__file__).resolve().parent.parent))
    return subprocess.run([sys.executable, "-m", "morpi_filters.cli", *args], capture_output=True,
                          text=True, cwd=cwd, env=env)


def test_help_lists_subcommands():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("check", "tables", "assess", "curves", "simulate", "montecarlo", "drift", "data", "report"):
        assert cmd in r.stdout


def test_check_reports_each_bad_file(tmp_path):
    d = tmp_path / "ds" / "s8" / "line_dataset"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    rows = good_rows()
    rows[5] = "0.1,0,x,0,0,0,0"
    write_rows(d / "2.csv", rows)
    (d / "3.csv").write_text("")
    r = run("check", "--data", str(tmp_path / "ds"))
    assert r.returncode == 1
    lines = r.stdout.strip().splitlines()
    assert any("2.csv: line 7: column f_y" in s for s in lines)
    assert any("3.csv: empty file" in s for s in lines)
    assert "Traceback" not in r.stdout + r.stderr
    # 2 bad files, then the layout: 3 of the 24 line_dataset runs, the other 10 folders absent
    assert lines[-1].startswith("1 recording(s) OK, 13 problem(s)")
    assert any("line_dataset: 3 recording(s), expected 24" in s for s in lines)


def test_check_names_missing_folders(tmp_path):
    # One good folder is not the dataset: every other folder of data/routes.json is named.
    d = tmp_path / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    r = run("check", "--data", str(tmp_path))
    assert r.returncode == 1
    assert "s8/short_distance/train: missing folder, expected 12 recording(s)" in r.stdout
    assert "L_line: 1 recording(s), expected 10" in r.stdout and "Traceback" not in r.stderr


@pytest.mark.parametrize("make", ["empty", "stray", "clone"])
def test_check_without_recordings_fails(tmp_path, make):
    root = tmp_path / "root"
    root.mkdir()
    if make == "stray":
        write_rows(root / "notes.csv", good_rows())
    if make == "clone":
        d = root / "data" / "s6" / "L_line"
        d.mkdir(parents=True)
        write_rows(d / "1.csv", good_rows())
    r = run("check", "--data", str(root))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    if make == "clone":   # the clone root stands for its data/ folder, whose missing folders are named
        assert f"{root / 'data' / 's8' / 'line_dataset'}: missing folder" in r.stdout
        return
    assert "no recordings in the MoRPI layout" in r.stdout
    assert r.stdout.strip().splitlines()[-1].startswith("0 recording(s) OK")
    if make == "stray":
        assert "1 CSV file(s) outside the MoRPI layout" in r.stdout


def test_layout_problems_point_at_data_inside_a_clone(tmp_path):
    from morpi_filters.dataset import layout_problems

    d = tmp_path / "data" / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    assert any(f"pass --data {tmp_path / 'data'}" in s for s in layout_problems(tmp_path))


def test_missing_dataset_is_one_line(tmp_path, monkeypatch):
    env = {k: v for k, v in __import__("os").environ.items() if k != "MORPI_DATA"}
    r = run("check", cwd=tmp_path, env=env)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "morpi data fetch" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("argv", [["montecarlo", "--runs", "0"], ["assess", "--times", "abc"],
                                  ["simulate", "--out", "x", "--seed", "-1"], ["aided", "--workers", "0"],
                                  ["report", "--workers", "257"], ["aided", "--workers", "two"]])
def test_bad_parameters_exit_nonzero(argv, tmp_path):
    r = run(*argv, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    if "--workers" in argv:
        assert "--workers" in r.stderr and not (tmp_path / "reports").exists()


@pytest.mark.parametrize("argv", [["tables"], ["curves", "--times", "1"], ["montecarlo", "--runs", "2"], ["aided"],
                                  ["report", "--runs", "2"]])
def test_data_commands_stop_on_a_bad_recording(tmp_path, argv):
    """Every command that reads the recordings names a bad one and exits 1 (before computing anything)."""
    from morpi_filters.synthetic import write_dataset

    root = write_dataset(tmp_path / "ds", seed=2, runs_per_folder=1)
    bad = root / "s6" / "L_line" / "1.csv"
    bad.write_bytes(b"\xef\xbb\xbf")
    out = tmp_path / "out"
    r = run(*argv, "--data", str(root), "--out", str(out))
    assert r.returncode == 1, r.stderr
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and f"{bad}: empty file" in err[0] and "--partial" in err[0]
    assert not out.exists() and "Traceback" not in r.stderr
    assert "[field evaluation]" not in r.stdout             # the report stops before evaluating


def _cut_in_first_movement(root, rel, seconds=0.5):
    """Cut a synthetic recording `seconds` after its motion starts (the manifest's start time); its path."""
    import json

    start = json.loads((root / "manifest.json").read_text())["runs"][rel]["start_time"]
    path = root / rel
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join([lines[0]] + [x for x in lines[1:] if float(x.split(",")[0]) < start + seconds]))
    return path


@pytest.mark.parametrize("argv", [["tables"], ["curves", "--times", "1"], ["montecarlo", "--runs", "2"], ["aided"],
                                  ["report", "--runs", "2"]])
def test_data_commands_stop_on_a_recording_too_short_for_its_motion(tmp_path, argv):
    """A recording cut 0.5 s into its first movement loads, but no rest window can be told from it: every
    command that reads the recordings names it on one line, with the length needed, and exits 1."""
    from morpi_filters.synthetic import write_dataset

    root = write_dataset(tmp_path / "ds", seed=2, runs_per_folder=1)
    short = _cut_in_first_movement(root, "s8/short_distance/test/1.csv")
    out = tmp_path / "out"
    r = run(*argv, "--data", str(root), "--out", str(out))
    assert r.returncode == 1, r.stderr
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and f"{short}: " in err[0] and "is too short" in err[0] and "needed" in err[0], err
    assert "--partial" in err[0] and "Traceback" not in r.stderr and not out.exists()


def test_check_names_a_recording_too_short_for_its_motion_and_tables_leave_it_out_with_partial(tmp_path):
    from morpi_filters.synthetic import write_dataset

    root = write_dataset(tmp_path / "ds", seed=2, runs_per_folder=1)
    assert run("check", "--data", str(root)).returncode == 0
    short = _cut_in_first_movement(root, "s8/short_distance/test/1.csv")
    r = run("check", "--data", str(root))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith(f"{short}: ") and "is too short" in lines[0]
    assert lines[1].startswith("10 recording(s) OK, 1 problem(s)")
    out, js = tmp_path / "out", tmp_path / "tables.json"
    r = run("tables", "--data", str(root), "--out", str(out), "--json", str(js), "--partial")
    assert r.returncode == 0, r.stderr
    payload = __import__("json").loads(js.read_text())
    assert payload["left_out"] == [lines[0]]
    for c in payload["cells"]:
        if (c["table"], c["phone"], c["p2p_m"]) == ("short_route", "s8", 1.0):
            assert c["n_runs"] == 0 and c["failed"] == [lines[0]], c
    assert str(short) in (out / "README.md").read_text()


def test_recordings_moving_from_their_first_sample_are_a_warning_for_check_and_rd_only_for_tables(tmp_path):
    # Two synthetic runs, a straight line and a periodic test run, whose first second of motion is cut off (the
    # robot under way at the first sample, with its vibration): check warns on one line each and exits 0;
    # tables evaluates them under RD and lists them, with why, in the JSON's no_rest and on the page, their
    # GAC and GC cells naming them among their failed runs.
    import json

    from morpi_filters.synthetic import write_dataset

    root = write_dataset(tmp_path / "ds", seed=2, runs_per_folder=1)
    runs = json.loads((root / "manifest.json").read_text())["runs"]
    cut = {"s8/line_dataset/1.csv": ("ins_straight", None), "s8/short_distance/test/1.csv": ("short_route", 1.0)}
    for rel in cut:
        lines = (root / rel).read_text().splitlines(keepends=True)
        start = runs[rel]["start_time"] + 1.0
        (root / rel).write_text("".join([lines[0]] + [x for x in lines[1:] if float(x.split(",")[0]) >= start]))
    r = run("check", "--data", str(root))
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    *warnings, summary = r.stdout.strip().splitlines()
    tail = "; evaluated under RD only, without GC and GAC"
    assert len(warnings) == 2 and all(w.endswith(tail) for w in warnings), warnings
    why = {rel: w[len("warning: "):-len(tail)] for rel, w in zip(sorted(cut), sorted(warnings))}
    for rel, line in why.items():
        assert line.startswith(f"{root / rel}: no initial rest found: motion starts 0.000 s"), line
    assert summary.startswith("11 recording(s) OK, 0 problem(s)") and summary.endswith(
        "; 2 OK recording(s) without an initial rest (RD only)"), summary
    out, js = tmp_path / "out", tmp_path / "tables.json"
    r = run("tables", "--data", str(root), "--out", str(out), "--json", str(js))
    assert r.returncode == 0, r.stderr
    payload = json.loads(js.read_text())
    assert payload["left_out"] == [] and payload["no_rest"] == [why[rel] for rel in sorted(cut)]
    page = (out / "README.md").read_text()
    assert "Recordings without an initial rest" in page
    for rel, (table, p2p) in cut.items():
        assert f"- {why[rel]}" in page
        cells = [c for c in payload["cells"] if (c["table"], c["phone"], c["p2p_m"]) == (table, "s8", p2p)]
        assert len(cells) == 4
        for c in cells:
            if c["calibration"] == "RD":
                assert [x["file"] for x in c["runs"]] == [rel] and c["failed"] == [], c
                assert c["runs"][0]["rest_window_s"] is None
                assert c["runs"][0]["motion_window_s"][0] >= runs[rel]["start_time"] + 1.0
            else:
                assert c["n_runs"] == 0 and c["failed"] == [why[rel]], c


def test_the_command_skips_the_collectors_shutdown_sweeps_and_a_call_does_not(tmp_path):
    # as the process's command (argv from sys.argv), main leaves an exit handler that freezes the garbage
    # collector, so the interpreter's shutdown does not sweep every object; an exit handler registered before
    # main runs after it and sees the frozen objects; the output is complete
    code = ("import atexit, gc, sys\n"
            "atexit.register(lambda: print('frozen', gc.get_freeze_count() > 0))\n"
            "from morpi_filters import cli\n"
            f"sys.argv = ['morpi', 'assess', '--out', {str(tmp_path / 'a')!r}]\n"
            "print('status', cli.main())\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parent.parent), MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert "status 0" in r.stdout and "frozen True" in r.stdout
    assert (tmp_path / "a" / "result.json").is_file()
    # called from Python with its own arguments, main registers nothing
    code = code.replace("sys.argv = ", "argv = ").replace("cli.main()", "cli.main(argv[1:])")
    r = subprocess.run([sys.executable, "-c", code.replace("'a'", "'b'")], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert "status 0" in r.stdout and "frozen False" in r.stdout


def test_a_report_section_runs_with_the_heap_frozen_and_leaves_it_as_it_was(monkeypatch, tmp_path):
    # the collector's full collections (sympy's import, the figures) walk only what the section allocates
    import gc

    from morpi_filters import cli

    seen = []
    monkeypatch.setattr(cli, "_study", lambda name, *a: seen.append(gc.get_freeze_count()) or "study")
    monkeypatch.setattr(cli, "_write",
                        lambda name, out, study, source=None: seen.append(gc.get_freeze_count()) or study)
    assert gc.get_freeze_count() == 0
    assert cli._section("drift", tmp_path, None) == "study"
    assert len(seen) == 2 and min(seen) > 0 and gc.get_freeze_count() == 0
