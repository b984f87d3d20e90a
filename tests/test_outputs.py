"""What the commands write: only folders they own, checked first, swapped in together.

Covers the ownership rule (a folder is replaced only when new, empty or
marked), the checks on ``--out`` and ``--json`` before any computation, the
user's umask, SIGTERM and SIGINT, leftovers of killed runs, the synthetic
report's own folder, and the bounds on ``--runs`` and ``--times``.
"""
from __future__ import annotations

import os
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from morpi_filters import cli
from morpi_filters.dataset import resolve_data_root
from morpi_filters.errors import MorpiError
from morpi_filters.reporting import MARKER, DataSource, SectionSummary

ROOT = Path(__file__).resolve().parents[1]
WRITERS = {  # command line without --out, and the section it writes
    "tables": ["tables", "--data", "."],
    "assess": ["assess"],
    "curves": ["curves"],
    "montecarlo": ["montecarlo", "--runs", "10"],
    "drift": ["drift"],
}


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if k != "MORPI_DATA"}
    env["PYTHONPATH"] = str(ROOT)   # this checkout, not an installed copy
    env["MPLBACKEND"] = "Agg"
    env.update(extra)
    return env


def _foreign_tree(folder: Path) -> dict:
    """A user's folder: a thesis, a hidden file, a sub-folder, a .git folder and a .env."""
    files = {"thesis.tex": b"\\documentclass{article}", ".hidden": b"secret", "sub/data.csv": b"1,2,3\n",
             ".git/config": b"[core]\n", ".env": b"TOKEN=x\n"}
    for rel, data in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)
    return files


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.fixture
def fake_sections(monkeypatch):
    """Replace the computation of every section by a recorder that writes two small files."""
    calls = []

    def fake(name, stage, args, source=None, tables=None):
        calls.append(name)
        (stage / "README.md").write_text(f"# {name}\n")
        (stage / "result.json").write_text('{"section": "%s"}\n' % name)
        return SectionSummary(name=name, title=name)

    monkeypatch.setattr(cli, "_section", fake)
    return calls


# ----------------------------------------------------------------------------- ownership

@pytest.mark.parametrize("command", sorted(WRITERS))
def test_foreign_out_folder_is_refused_before_computing(command, tmp_path, fake_sections, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    before = _snapshot(out)
    before.update({k: v for k, v in _foreign_tree(out).items()})
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 2
    assert fake_sections == []                      # nothing computed
    assert _snapshot(out) == before                 # every byte in place
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0] and "refusing" in err[0]
    assert any(name in err[0] for name in (".env", ".git", ".hidden", "sub", "thesis.tex"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]   # no staging left


def test_simulate_refuses_a_foreign_folder(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    files = _foreign_tree(out)
    assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1"]) == 2
    assert _snapshot(out) == files
    err = capsys.readouterr().err.strip()
    assert str(out) in err and "\n" not in err


def test_report_refuses_a_foreign_folder_and_a_foreign_section(tmp_path, fake_sections, monkeypatch, capsys):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "r"
    out.mkdir()
    files = _foreign_tree(out)
    assert cli.main(["report", "--out", str(out)]) == 2
    assert fake_sections == [] and _snapshot(out) == files
    # A marked report folder whose section folder holds someone else's files.
    out2 = tmp_path / "r2"
    (out2 / "curves").mkdir(parents=True)
    (out2 / MARKER).write_text("earlier report\n")
    (out2 / "curves" / "notes.md").write_text("mine")
    capsys.readouterr()
    assert cli.main(["report", "--out", str(out2)]) == 2
    assert fake_sections == [] and (out2 / "curves" / "notes.md").read_text() == "mine"
    err = capsys.readouterr().err
    assert "curves" in err and "notes.md" in err


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_marked_folder_is_replaced_and_marked_again(command, tmp_path, fake_sections):
    out = tmp_path / "sec"
    out.mkdir()
    (out / MARKER).write_text("an earlier run\n")
    (out / "old.png").write_bytes(b"old")
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "README.md", "result.json"]
    assert "morpi" in (out / MARKER).read_text()


def test_report_replaces_only_its_sections_and_index(tmp_path, fake_sections, monkeypatch):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "reports"
    (out / "simulation").mkdir(parents=True)
    (out / "simulation" / "run.png").write_bytes(b"figure of an analysis script")
    (out / MARKER).write_text("earlier report\n")
    (out / "tables").mkdir()
    (out / "tables" / MARKER).write_text("earlier tables\n")
    (out / "tables" / "stale.png").write_bytes(b"stale")
    assert cli.main(["report", "--out", str(out)]) == 0
    assert fake_sections == list(cli.REPORT_SECTIONS)
    assert (out / "simulation" / "run.png").read_bytes() == b"figure of an analysis script"
    assert not (out / "tables" / "stale.png").exists()
    for name in cli.REPORT_SECTIONS:
        assert (out / name / MARKER).is_file() and (out / name / "README.md").is_file()
    assert (out / "index.md").is_file() and (out / MARKER).is_file()
    assert not [p for p in out.rglob(".staging-*")] and not [p for p in out.rglob(".previous-*")]


def test_committed_report_folders_carry_the_marker():
    reports = ROOT / "reports"
    assert (reports / MARKER).is_file()
    for name in cli.REPORT_SECTIONS:
        assert (reports / name / MARKER).is_file(), name


# ----------------------------------------------------------------------------- --out and --json checks

def _proc_target(name):
    return Path("/proc") / name if Path("/proc/self").is_dir() else None


@pytest.mark.parametrize("case", ["json_is_dir", "json_empty", "out_empty", "json_in_proc", "out_in_proc",
                                  "out_under_file", "json_under_file", "out_is_file"])
def test_out_and_json_checked_before_computing(case, tmp_path, fake_sections, capsys):
    out, js = tmp_path / "out", tmp_path / "r.json"
    (tmp_path / "afile").write_text("x")
    if case == "json_is_dir":
        js.mkdir()
    elif case == "json_empty":
        js = ""
    elif case == "out_empty":
        out = ""
    elif case in ("json_in_proc", "out_in_proc"):
        target = _proc_target("morpi-test-output")
        if target is None:
            pytest.skip("no /proc on this system")
        js, out = (target, out) if case == "json_in_proc" else (js, target)
    elif case == "out_under_file":
        out = tmp_path / "afile" / "out"
    elif case == "json_under_file":
        js = tmp_path / "afile" / "r.json"
    elif case == "out_is_file":
        out = tmp_path / "afile"
    argv = ["assess", "--out", str(out), "--json", str(js)]
    try:
        code = cli.main(argv)
    except SystemExit as exc:       # an empty path is refused by the argument parser
        code = exc.code
    assert code == 2
    assert fake_sections == []
    err = capsys.readouterr().err.strip().splitlines()
    assert "--out" in err[-1] or "--json" in err[-1]
    if "" not in (out, js):
        assert len(err) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["afile"] + (["r.json"] if case == "json_is_dir"
                                                                              else []))


def test_failing_json_leaves_out_untouched(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sec"
    out.mkdir()
    (out / MARKER).write_text("earlier run\n")
    (out / "old.txt").write_text("previous result")

    def no_result(name, stage, args, source=None):
        (stage / "README.md").write_text("new page")
        return SectionSummary(name=name, title=name)

    monkeypatch.setattr(cli, "_section", no_result)
    assert cli.main(["drift", "--out", str(out), "--json", str(tmp_path / "r.json")]) == 2
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "old.txt"]
    assert not (tmp_path / "r.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sec"]


def test_out_and_json_arrive_together(tmp_path, fake_sections):
    out, js = tmp_path / "a" / "sec", tmp_path / "b" / "r.json"
    assert cli.main(["drift", "--out", str(out), "--json", str(js)]) == 0
    assert js.read_text() == (out / "result.json").read_text()


# ----------------------------------------------------------------------------- permissions

@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_outputs_get_the_users_umask(umask, tmp_path):
    out, js = tmp_path / "sec", tmp_path / "j" / "r.json"
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "assess", "--out", str(out), "--json", str(js)],
                       env=_env(), capture_output=True, text=True, preexec_fn=lambda: os.umask(umask))
    assert r.returncode == 0, r.stderr[-2000:]
    paths = [out, *out.rglob("*"), js, js.parent]
    assert len(paths) > 4
    for p in paths:
        mode = stat.S_IMODE(p.stat().st_mode)
        want = (0o777 if p.is_dir() else 0o666) & ~umask
        assert mode == want, (p, oct(mode), oct(want))


# ----------------------------------------------------------------------------- signals

@pytest.mark.parametrize("sig, code, word", [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130, "interrupted")])
def test_signal_ends_cleanly_and_keeps_the_previous_output(sig, code, word, tmp_path):
    out = tmp_path / "mc"
    out.mkdir()
    (out / MARKER).write_text("earlier run\n")
    (out / "old.txt").write_text("previous result")
    p = subprocess.Popen([sys.executable, "-m", "morpi_filters.cli", "montecarlo", "--runs", "150000",
                          "--out", str(out)], env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not list(tmp_path.glob(".staging-mc-*")):     # the outputs are staged
            assert p.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        # the study is computing once its first progress line is out (its modules are imported by then:
        # a SIGINT that lands inside an import is reported by Python itself, not by morpi)
        first = p.stderr.readline()
        assert "montecarlo gain-error study" in first and p.poll() is None, first
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        err = first + err
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == code, err[-2000:]
    assert word in err and "Traceback" not in err
    assert sorted(x.name for x in out.iterdir()) == [MARKER, "old.txt"]
    assert sorted(x.name for x in tmp_path.iterdir()) == ["mc"]


# ----------------------------------------------------------------------------- leftovers of killed runs

def _dead_pid():
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_stale_staging_of_dead_runs_removed_live_ones_kept(tmp_path, fake_sections):
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        dead = _dead_pid()
        stale = [tmp_path / f".staging-sec-{dead}-abcd1234", tmp_path / f".previous-sec-{dead}-efgh_678"]
        for s in stale:
            (s / "sec").mkdir(parents=True)
            (s / "sec" / "half.png").write_bytes(b"half")
        stale_file = tmp_path / f".staging-r.json-{dead}-ab12cd34.tmp"
        stale_file.write_text("{")
        kept = tmp_path / f".staging-sec-{live.pid}-live1234"
        kept.mkdir()
        other = tmp_path / ".staging-notes"          # not a morpi name: left alone
        other.mkdir()
        assert cli.main(["drift", "--out", str(tmp_path / "sec"), "--json", str(tmp_path / "r.json")]) == 0
        names = sorted(p.name for p in tmp_path.iterdir())
        assert names == sorted([kept.name, other.name, "r.json", "sec"])
    finally:
        live.kill()
        live.wait()


def test_stale_staging_that_cannot_be_removed_is_named(tmp_path, fake_sections, monkeypatch, capsys):
    import morpi_filters.reporting as reporting

    stale = tmp_path / f".staging-sec-{_dead_pid()}-abcd1234"
    stale.mkdir()

    def refuse(path, *a, **k):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(reporting.shutil, "rmtree", refuse)
    assert cli.main(["drift", "--out", str(tmp_path / "sec")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and stale.name in err[0] and "interrupted run" in err[0]


def test_report_removes_stale_staging_inside_the_report_folder(tmp_path, fake_sections, monkeypatch):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "reports"
    out.mkdir()
    (out / MARKER).write_text("earlier report\n")
    dead = _dead_pid()
    (out / f".staging-tables-{dead}-zz99zz99").mkdir()
    assert cli.main(["report", "--out", str(out)]) == 0
    assert not list(out.glob(".staging-*"))


# ----------------------------------------------------------------------------- a first run that tells the truth

def test_synthetic_report_says_so_first_and_goes_to_its_own_folder(tmp_path, fake_sections, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MORPI_DATA", raising=False)
    monkeypatch.setattr(cli, "_report_source", lambda args: DataSource(tmp_path, synthetic=True, seed=0))
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / MARKER).write_text("the field report\n")
    (tmp_path / "reports" / "index.md").write_text("field index")
    assert cli.main(["report"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert "synthetic" in first and "reports/synthetic" in first
    assert (tmp_path / "reports" / "index.md").read_text() == "field index"
    assert (tmp_path / "reports" / "synthetic" / "index.md").is_file()


def test_field_report_goes_to_reports(tmp_path, fake_sections, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ds" / "s6").mkdir(parents=True)
    monkeypatch.setattr(cli, "_report_source", lambda args: DataSource(tmp_path / "ds"))
    # the folder holds no recordings: the report stops on that (exit 1) unless --partial
    assert cli.main(["report", "--data", str(tmp_path / "ds")]) == 1
    assert "no recordings in the MoRPI layout" in capsys.readouterr().err
    assert cli.main(["report", "--data", str(tmp_path / "ds"), "--partial"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert "synthetic" not in first and "field dataset" in first
    assert (tmp_path / "reports" / "index.md").is_file() and not (tmp_path / "reports" / "synthetic").exists()


def test_data_accepts_a_clone_root(tmp_path):
    (tmp_path / "clone" / "data" / "s6").mkdir(parents=True)
    assert resolve_data_root(tmp_path / "clone") == tmp_path / "clone" / "data"
    assert resolve_data_root(tmp_path / "clone" / "data") == tmp_path / "clone" / "data"
    (tmp_path / "plain").mkdir()
    assert resolve_data_root(tmp_path / "plain") == tmp_path / "plain"


def test_offline_fetch_names_the_alternatives(tmp_path):
    from morpi_filters.fetch import fetch_dataset

    with socket.socket() as s:          # a port that was free a moment ago and has no listener now
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(MorpiError) as exc:
        fetch_dataset(tmp_path / "d", url=f"http://127.0.0.1:{port}/x.zip", checksums={"s6/a/1.csv": "0" * 64},
                      progress=lambda msg: None, timeout=5)
    msg = str(exc.value)
    assert "git clone" in msg and "--data" in msg and "morpi simulate" in msg and "\n" not in msg


def test_progress_lines_name_the_study(capsys):
    from morpi_filters.montecarlo import run_study

    run_study(20, seed=0, progress=True)
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert lines and all(ln.lstrip("\r").startswith("montecarlo gain-error study: ") for ln in lines)


# ----------------------------------------------------------------------------- absurd sizes

@pytest.mark.parametrize("argv, words", [
    (["montecarlo", "--runs", "10000000"], ("10000000", "GB", "at most")),
    (["report", "--runs", "10000000"], ("10000000", "GB", "at most")),
    (["curves", "--times", "0", "1e6"], ("1e6", "GB", "at most")),
])
def test_absurd_sizes_are_refused_with_an_estimate(argv, words, tmp_path, fake_sections, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--out", str(tmp_path / "o")])
    assert exc.value.code == 2 and fake_sections == []
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
