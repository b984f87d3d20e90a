"""The `morpi` command: help, one-line errors, exit codes."""
from __future__ import annotations

import math
import os
import re
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
    # 2 bad files, then the shipped manifest's counts: 3 of the 24 line_dataset runs, the other 10 folders absent
    assert lines[-1].startswith("1 recording(s) OK, 13 problem(s)")
    assert any(f"imu.file: 's8/line_dataset/*.csv' matches 3 file(s) under {tmp_path / 'ds'}, expected 24 "
               "(imu.count)" in s for s in lines)


def test_check_names_a_recording_in_g_and_one_in_deg_per_s(tmp_path):
    """Within every limit, but no phone at rest in SI units: one line each, naming the file and the unit."""
    import numpy as np

    rng = np.random.default_rng(8)
    d = tmp_path / "s8" / "line_dataset"
    d.mkdir(parents=True)
    rows = [[0.3 + 0.01 * k, 0.1, -0.1, 9.8, 0.01, -0.02, 0.03] for k in range(300)]
    noisy = np.asarray(rows) + np.c_[np.zeros(300), 0.01 * rng.standard_normal((300, 3)),
                                     0.001 * rng.standard_normal((300, 3))]
    write_rows(d / "1.csv", noisy.tolist())
    in_g, in_deg = noisy.copy(), noisy.copy()
    in_g[:, 1:4] /= 9.80665
    in_deg[:, 4:7] = np.degrees(in_deg[:, 4:7])
    write_rows(d / "2.csv", in_g.tolist())
    write_rows(d / "3.csv", in_deg.tolist())
    r = run("check", "--data", str(tmp_path))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    lines = r.stdout.strip().splitlines()
    # (0.1, -0.1, 9.8) m/s^2 read in g is (0.0102, -0.0102, 0.9993); 0.03 rad/s read in deg/s is 1.72; the
    # bounds are the S8's IMU's (the LSM6DSL the shipped manifest names): three zero-g offsets, 1.52 m/s^2
    (g,) = [s for s in lines if s.startswith(str(d / "2.csv"))]
    assert re.fullmatch(re.escape(f"{d / '2.csv'}: [[recording]] 1 of ") + r".*morpi\.toml: imu\.accel_unit: the "
                        r"median specific force at rest is \[0\.010\d, -0\.010\d, 0\.999\] m/s\^2, of magnitude "
                        r"0\.999 m/s\^2 after conversion, expected 9\.81 \+- 1\.52 \(gravity, three zero-g offsets of "
                        r"the IMU\): check accel_unit \(declared 'm/s\^2'\)", g), g
    (deg,) = [s for s in lines if s.startswith(str(d / "3.csv"))]
    assert deg.endswith("check gyro_unit (declared 'rad/s')") and \
        re.search(r"median angular rate at rest is 1\.7\d rad/s on g_z", deg), deg
    assert not any(s.startswith(str(d / "1.csv")) for s in lines)
    assert lines[-1].startswith("1 recording(s) OK")


def test_check_names_missing_folders(tmp_path):
    # One good folder is not the dataset: every other folder of data/routes.json is named.
    d = tmp_path / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    r = run("check", "--data", str(tmp_path))
    assert r.returncode == 1
    assert (f"imu.file: 's8/short_distance/train/*.csv' matches no file: missing folder "
            f"{tmp_path / 's8/short_distance/train'}, expected 12 file(s) (imu.count)") in r.stdout
    assert f"imu.file: 's6/L_line/*.csv' matches 1 file(s) under {tmp_path}, expected 10 (imu.count)" in r.stdout
    assert "Traceback" not in r.stderr


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
        assert f"missing folder {root / 'data' / 's8' / 'line_dataset'}," in r.stdout
        return
    assert f"{root}: no recordings: no file matches the imu.file patterns of " in r.stdout
    assert r.stdout.strip().splitlines()[-1].startswith("0 recording(s) OK")
    if make == "stray":   # a file outside the manifest's patterns is not read; directly in the root, it is named
        assert f"1 CSV file(s) directly in {root}, none where the manifest looks" in r.stdout


def test_check_points_at_data_inside_a_clone(tmp_path):
    from morpi_filters.field import check_recordings, missing_recordings

    d = tmp_path / "data" / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    assert any(f"pass --data {tmp_path / 'data'}" in s for s in check_recordings(tmp_path)[0])
    assert any(f"pass --data {tmp_path / 'data'}" in s for s in missing_recordings(tmp_path))


def _copy_of_the_shipped_manifest(folder):
    """The package's MoRPI manifest copied into `folder` (its files then relative to `folder`); its path."""
    from morpi_filters.resources import morpi_manifest

    copy = folder / "morpi.toml"
    copy.write_text(morpi_manifest().read_text())
    return copy


def test_check_data_gives_the_lines_check_dataset_gives_for_the_shipped_manifest(tmp_path):
    """`check --data DIR` is the shipped manifest applied to DIR: a malformed CSV and the files the manifest
    expects but DIR lacks are the lines `check --dataset` prints for a copy of that manifest in DIR (its own path
    in place of the shipped one's), with the same count of recordings OK."""
    from morpi_filters.resources import morpi_manifest

    d = tmp_path / "s6" / "L_line"
    d.mkdir(parents=True)
    for n in range(1, 10):                               # 9 of the 10 runs, one of them malformed
        write_rows(d / f"{n}.csv", good_rows())
    rows = good_rows()
    rows[3] = "0.4,0,0,9.81,zero,0,0"
    write_rows(d / "4.csv", rows)
    by_data = run("check", "--data", str(tmp_path))
    copy = _copy_of_the_shipped_manifest(tmp_path)
    by_manifest = run("check", "--dataset", str(copy))
    assert by_data.returncode == by_manifest.returncode == 1, (by_data.stderr, by_manifest.stderr)
    *data_lines, data_summary = by_data.stdout.strip().splitlines()
    *manifest_lines, manifest_summary = by_manifest.stdout.strip().splitlines()
    assert [s.replace(str(morpi_manifest()), str(copy)) for s in data_lines] == manifest_lines
    assert data_summary.startswith("8 recording(s) OK, 12 problem(s)")
    assert manifest_summary.startswith("8 recording(s) OK, 12 problem(s)")
    assert f"{d / '4.csv'}: line 5: column g_x: 'zero' is not a number" in by_data.stdout
    assert (f"imu.file: 's6/L_line/*.csv' matches 9 file(s) under {tmp_path}, expected 10 (imu.count)"
            in by_data.stdout)
    missing = [s for s in data_lines if "missing folder" in s]
    assert len(missing) == 10 and any(s.endswith(f"missing folder {tmp_path / 's8/line_dataset'}, expected 24 "
                                                 "file(s) (imu.count)") for s in missing)


def test_check_data_reads_no_file_outside_the_manifests_patterns(tmp_path, monkeypatch, capsys):
    """Files the shipped manifest's patterns do not match (another folder, a deeper one, an unknown route, a
    file not ending .csv) are neither read nor listed, however malformed: the check lists only the folders its
    patterns name, and its lines are those of the same root without them."""
    from morpi_filters.resources import morpi_manifest

    d = tmp_path / "s6" / "L_line"
    d.mkdir(parents=True)
    write_rows(d / "1.csv", good_rows())
    assert main(["check", "--data", str(tmp_path)]) == 1
    clean = capsys.readouterr().out
    strays = [tmp_path / "notes" / "x.csv", d / "sub" / "2.csv", tmp_path / "s8" / "L_line" / "1.csv", d / "3.txt"]
    for p in strays:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("not,a,recording\n")
    listed = []
    real_scandir = os.scandir

    def scandir(path="."):
        listed.append(Path(os.fsdecode(path)).absolute())
        return real_scandir(path)

    monkeypatch.setattr(os, "scandir", scandir)
    assert main(["check", "--data", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert out == clean and not any(str(p) in out for p in strays)
    below = {p for p in listed if p.is_relative_to(tmp_path)}
    patterns = [r.split('"')[1] for r in morpi_manifest().read_text().splitlines() if r.startswith("imu = { file")]
    allowed = {(tmp_path / pattern).parent for pattern in patterns}      # the folders of the manifest's globs
    assert below and below <= allowed, sorted(below - allowed)
    assert not any(p.is_relative_to(tmp_path / "notes") or p.is_relative_to(d / "sub") for p in below)


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


# ----------------------------------------------------------------------------- every numeric option bounded

def _value_options():
    """(command words, option, type) of every option of every subcommand that takes a value."""
    import argparse

    from morpi_filters.cli import build_parser

    found = []

    def walk(parser, words):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, words + [name])
            elif action.option_strings and action.nargs != 0:
                found.append((tuple(words), action.option_strings[-1], action.type))

    walk(build_parser(), [])
    return found


def _is_numeric(kind):
    """Whether an option's type refuses text that is not a number (a number option, bounded or not)."""
    if kind is None or kind is str:
        return False
    try:
        kind("not-a-number")
    except Exception:
        return True
    return False


NUMERIC = [(w, o, t) for w, o, t in _value_options() if _is_numeric(t)]
#: What a user may type where a number is expected: zero, signs, NaN, infinities, the float range's ends and
#: beyond, integers longer than any bound (and than Python converts), fractions, text.
BAD_VALUES = ["0", "-1", "nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e309", "1" + "0" * 40,
              "-" + "9" * 5000, "1.5", "abc", "", "0x10", "1,5"]
#: Required options given so that the value under test is the only problem.
REQUIRED = {("simulate",): ["--out", "unused"]}


def test_the_number_options_are_found():
    # the enumeration below reads the parser: every subcommand with a number option is in it
    options = {(w, o) for w, o, _ in NUMERIC}
    assert {(("montecarlo",), "--runs"), (("montecarlo",), "--duration-s"), (("assess",), "--times"),
            (("curves",), "--times"), (("simulate",), "--seed"), (("aided",), "--workers"),
            (("report",), "--runs"), (("curves",), "--seed"), (("drift",), "--seed")} <= options
    # and the text options are not numbers
    assert not {o for _, o, _ in NUMERIC} & {"--out", "--json", "--data", "--params", "--scheduler", "--url", "--dest"}


@pytest.mark.parametrize("words, option, kind", NUMERIC, ids=[" ".join(w) + " " + o for w, o, _ in NUMERIC])
def test_every_number_option_has_a_finite_range(words, option, kind):
    from morpi_filters.cli import _Number

    assert isinstance(kind, _Number), f"morpi {' '.join(words)} {option}: a number option without a stated range"
    assert math.isfinite(kind.lo) and math.isfinite(kind.hi) and kind.lo <= kind.hi


def _in_range(kind, text):
    from morpi_filters.cli import _real, _whole

    v = (_whole if kind.whole else _real)(text)
    return v is not None and kind.lo <= v <= kind.hi


@pytest.mark.parametrize("words, option, kind", NUMERIC, ids=[" ".join(w) + " " + o for w, o, _ in NUMERIC])
def test_every_number_option_refuses_bad_values_in_one_line(words, option, kind, monkeypatch, capsys):
    from morpi_filters import cli

    def no_computation(args):
        raise AssertionError(f"morpi {' '.join(words)} {option}: went on to compute")

    monkeypatch.setattr(cli, "_dispatch", no_computation)
    for text in BAD_VALUES:
        argv = [*words, *REQUIRED.get(tuple(words), []), option, text]
        if _in_range(kind, text):               # e.g. a seed of 0 or a time of 0 s: accepted when parsed
            assert cli.build_parser().parse_args(argv) is not None
            continue
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2, (argv[-1][:20], err)
        assert err.count("\n") == 1 and err.endswith("\n"), err
        assert option in err and kind.accepted in err and "Traceback" not in err, err
        assert len(err) < 400, err


# ----------------------------------------------------------------------------- the Monte Carlo time budget

@pytest.fixture
def no_sections(monkeypatch):
    """Replace the section run of every command by a recorder (nothing is computed)."""
    from morpi_filters import cli

    calls = []
    monkeypatch.setattr(cli, "_run_section", lambda name, args, source_of=None: calls.append(name) or 0)
    monkeypatch.delenv("MORPI_DATA", raising=False)
    return calls


def test_a_montecarlo_run_beyond_the_budget_is_refused_with_its_estimate(no_sections, capsys):
    from morpi_filters import cli
    from morpi_filters.montecarlo import page_cost

    # a million runs of the default 15 s fit the budget; of 600 s, they do not: the duration counts
    assert page_cost(1_000_000).seconds < cli.MC_BUDGET_SECONDS < page_cost(1_000_000, duration_s=600.0).seconds
    assert cli.main(["montecarlo", "--runs", "1000000", "--duration-s", "600"]) == 2
    out, err = capsys.readouterr()
    assert no_sections == [] and out == ""
    assert err.count("\n") == 1 and "--allow-long" in err and "1000000 runs of 600 s" in err, err
    hours = page_cost(1_000_000, duration_s=600.0).seconds / 3600
    assert f"about {hours:.2g} h" in err and "GB" in err, err


def test_allow_long_runs_it_and_states_the_estimate_first(no_sections, capsys):
    from morpi_filters import cli

    assert cli.main(["montecarlo", "--runs", "1000000", "--duration-s", "600", "--allow-long"]) == 0
    out = capsys.readouterr().out
    assert no_sections == ["montecarlo"] and "1000000 runs of 600 s, estimated at about" in out


def test_a_long_run_within_the_budget_states_its_estimate_and_a_short_one_does_not(no_sections, capsys):
    from morpi_filters import cli
    from morpi_filters.montecarlo import page_cost

    assert page_cost(1_000_000).seconds > cli.MC_ANNOUNCE_SECONDS > page_cost(2000).seconds
    assert cli.main(["montecarlo", "--runs", "1000000"]) == 0
    assert "1000000 runs of 15 s, estimated at about" in capsys.readouterr().out
    assert cli.main(["montecarlo", "--runs", "2000"]) == 0
    assert capsys.readouterr().out == "" and no_sections == ["montecarlo", "montecarlo"]


@pytest.mark.parametrize("argv, words", [
    (["--speed-mps", "0.01"], ("--speed-mps", "631 s", "at most 600 s")),           # the 6.3 m path at 1 cm/s
    (["--runs", "1000000", "--chunk", "1000000"], ("--chunk", "GB")),        # one chunk holding every run
])
def test_montecarlo_shapes_beyond_their_bounds_are_refused(argv, words, no_sections, capsys):
    from morpi_filters import cli

    assert cli.main(["montecarlo", *argv]) == 2
    err = capsys.readouterr().err
    assert no_sections == [] and err.count("\n") == 1 and all(w in err for w in words), err
