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
    assert lines[-1].startswith("1 recording(s) OK, 2 problem(s)")


def test_check_good_tree_exits_zero(tmp_path):
    d = tmp_path / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    assert main(["check", "--data", str(tmp_path)]) == 0


def test_missing_dataset_is_one_line(tmp_path, monkeypatch):
    env = {k: v for k, v in __import__("os").environ.items() if k != "MORPI_DATA"}
    r = run("check", cwd=tmp_path, env=env)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "morpi data fetch" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("argv", [["montecarlo", "--runs", "0"], ["assess", "--times", "abc"],
                                  ["simulate", "--out", "x", "--seed", "-1"]])
def test_bad_parameters_exit_nonzero(argv, tmp_path):
    r = run(*argv, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
