"""What the commands write: only folders they own, checked first, swapped in together.

Covers the ownership rule (a folder is replaced only when new, empty or
marked), the checks on ``--out`` and ``--json`` before any computation, the
user's umask, SIGTERM and SIGINT, leftovers of killed runs, the synthetic
report's own folder, and the bounds on ``--runs`` and ``--times``.
"""
from __future__ import annotations

import json
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
from morpi_filters.outputs import MARKER
from morpi_filters.results import DataSource, SectionSummary

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


#: The kind of output each command of WRITERS records in its folder's marker.
KINDS = {"tables": "tables", "assess": "assessment", "curves": "curves", "montecarlo": "montecarlo", "drift": "drift"}


def _earlier_output(folder: Path, kind: str, files: dict, command: str = "morpi earlier", folders=()) -> None:
    """`folder` as an earlier run of `command` left it: `files` and a marker in the documented format listing them."""
    folder.mkdir(parents=True, exist_ok=True)
    for rel, data in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)
    subfolders = {str(Path(rel).parent.as_posix()) for rel in files} - {"."}
    marker = {"morpi_output": 1, "command": command, "kind": kind, "files": sorted(files),
              "folders": sorted(subfolders | set(folders))}
    (folder / MARKER).write_text(json.dumps(marker))


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
    _earlier_output(out2, "report", {"index.md": b"earlier index"}, "morpi report", folders=["curves"])
    (out2 / "curves").mkdir(parents=True)
    (out2 / "curves" / "notes.md").write_text("mine")
    capsys.readouterr()
    assert cli.main(["report", "--out", str(out2)]) == 2
    assert fake_sections == [] and (out2 / "curves" / "notes.md").read_text() == "mine"
    err = capsys.readouterr().err
    assert "curves" in err and "notes.md" in err


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_marked_folder_is_replaced_and_marked_again(command, tmp_path, fake_sections):
    out = tmp_path / "sec"
    _earlier_output(out, KINDS[command], {"old.png": b"old"})
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "README.md", "result.json"]
    assert "morpi" in (out / MARKER).read_text()


def test_report_replaces_only_its_sections_and_index(tmp_path, fake_sections, monkeypatch):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "reports"
    (out / "simulation").mkdir(parents=True)
    (out / "simulation" / "run.png").write_bytes(b"figure of an analysis script")
    _earlier_output(out, "report", {"index.md": b"earlier index"}, "morpi report", folders=["tables"])
    _earlier_output(out / "tables", "tables", {"stale.png": b"stale"}, "morpi report")
    assert cli.main(["report", "--out", str(out)]) == 0
    assert fake_sections == list(cli.REPORT_SECTIONS)
    assert (out / "simulation" / "run.png").read_bytes() == b"figure of an analysis script"
    assert not (out / "tables" / "stale.png").exists()
    for name in cli.REPORT_SECTIONS:
        assert (out / name / MARKER).is_file() and (out / name / "README.md").is_file()
    assert (out / "index.md").is_file() and (out / MARKER).is_file()
    assert not [p for p in out.rglob(".staging-*")] and not [p for p in out.rglob(".previous-*")]


def test_committed_report_folders_carry_the_marker():
    from morpi_filters.outputs import check_output_dir, foreign_entry

    reports = ROOT / "reports"
    assert (reports / MARKER).is_file()
    for name in cli.REPORT_SECTIONS:
        assert (reports / name / MARKER).is_file(), name
        # each marker lists every committed file, so `morpi report` may replace the section
        assert foreign_entry(reports / name) is None, name
        assert json.loads((reports / name / MARKER).read_text())["kind"] == name
    check_output_dir(reports, kind="report", replace=False, writes=("index.md",))


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
    _earlier_output(out, "drift", {"old.txt": b"previous result"})

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
    _earlier_output(out, "montecarlo", {"old.txt": b"previous result"})
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


#: A run of ``drift --out D/sec --json D/r.json`` killed (SIGKILL, no cleanup of any kind) at a point
#: given on its command line: while the section is computed (both outputs staged), between moving the old
#: folder aside and renaming the new one in, or after both renames, before the old folder is removed.
_KILLED_RUN = """
import os, signal, sys
from pathlib import Path
from morpi_filters import outputs as out_mod

folder, point = Path(sys.argv[1]), sys.argv[2]


def die(*args, **kwargs):
    os.kill(os.getpid(), signal.SIGKILL)


outputs = out_mod.Outputs("morpi drift")
stage = outputs.folder(folder / "sec", "drift")
(stage / "README.md").write_text("new page")
outputs.file(folder / "r.json").write_text("{")
if point == "while computing":
    die()
if point == "between the renames":
    replace = os.replace
    os.replace = lambda src, dst: die() if Path(src) == stage else replace(src, dst)
if point == "after the renames":
    out_mod.claims._remove_owned = die
outputs.__exit__(None, None, None)
"""


def _killed_run(folder: Path, point: str) -> None:
    r = subprocess.run([sys.executable, "-c", _KILLED_RUN, str(folder), point], env=_env(), capture_output=True,
                       text=True)
    assert r.returncode == -signal.SIGKILL, r.stderr[-2000:]


@pytest.mark.parametrize("point", ["while computing", "between the renames", "after the renames"])
def test_a_killed_run_leaves_only_what_the_next_run_removes(point, tmp_path, fake_sections):
    from morpi_filters.outputs import remove_stale

    _earlier_output(tmp_path / "sec", "drift", {"README.md": b"old page"}, "morpi drift")
    _killed_run(tmp_path, point)
    left = sorted(p.name for p in tmp_path.iterdir() if p.name != "sec")
    assert left and all(n.startswith((".staging-", ".previous-")) for n in left), left
    # the leftovers go; an output moved aside and not yet replaced comes back
    assert remove_stale(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sec"]
    page = "new page" if point == "after the renames" else "old page"
    assert (tmp_path / "sec" / "README.md").read_text() == page
    _killed_run(tmp_path, point)
    # the next command removes them too, then writes its own outputs
    assert cli.main(["drift", "--out", str(tmp_path / "sec"), "--json", str(tmp_path / "r.json")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "sec"]
    assert (tmp_path / "sec" / "README.md").read_text() == "# drift\n"


def test_stale_staging_of_dead_runs_removed_live_ones_kept(tmp_path, fake_sections):
    live_code = ("import sys, time\nfrom morpi_filters.outputs import new_stage_dir\n"
                 "print(new_stage_dir(sys.argv[1]).name, flush=True)\ntime.sleep(60)\n")
    live = subprocess.Popen([sys.executable, "-c", live_code, str(tmp_path / "other")], env=_env(),
                            stdout=subprocess.PIPE, text=True)
    try:
        kept = live.stdout.readline().strip()
        _killed_run(tmp_path, "while computing")
        assert cli.main(["drift", "--out", str(tmp_path / "sec"), "--json", str(tmp_path / "r.json")]) == 0
        names = sorted(p.name for p in tmp_path.iterdir())
        assert names == sorted([kept, "r.json", "sec"])
    finally:
        live.kill()
        live.wait()


def test_cleanup_touches_only_what_it_can_prove_a_killed_run_left(tmp_path, fake_sections):
    dead = _dead_pid()
    # a staging folder a killed run really left, to copy its marker from (the proof of another name)
    (tmp_path / "x").mkdir()
    _killed_run(tmp_path / "x", "while computing")
    real = next((tmp_path / "x").glob(".staging-sec-*"))
    forged = tmp_path / f".staging-sec-{dead}-0123456789abcdef"
    forged.mkdir()
    (forged / MARKER).write_bytes((real / MARKER).read_bytes())   # a marker, for another pid and token
    user = {   # the user's files and folders whose names look like morpi's staging names
        ".previous-draft-2023-abcdefgh/notes.md": b"draft of 2023",
        f".staging-thesis-{dead}-abcd1234/chapter.tex": b"chapter one",
        f".previous-sec-{dead}-fedcba9876543210/sec/result.json": b"{}",
        f".staging-r.json-{dead}-ab12cd34.tmp": b"{\"mine\": 1}",
        f".staging-r.json-{dead}-0123456789abcdef": b"a file, not a folder",
        f".staging-sec-{dead}-0123456789abcdef/page.md": b"mine too",
    }
    for rel, data in user.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    assert cli.main(["drift", "--out", str(tmp_path / "sec"), "--json", str(tmp_path / "r.json")]) == 0
    for rel, data in user.items():
        assert (tmp_path / rel).read_bytes() == data, rel
    assert (forged / MARKER).read_bytes() == (real / MARKER).read_bytes()


def test_stale_staging_that_cannot_be_removed_is_named(tmp_path, fake_sections, monkeypatch, capsys):
    import morpi_filters.outputs as out_mod

    _killed_run(tmp_path, "while computing")
    stale = next(tmp_path.glob(".staging-sec-*"))

    def refuse(path, *a, **k):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(out_mod.claims.shutil, "rmtree", refuse)
    assert cli.main(["drift", "--out", str(tmp_path / "sec")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and stale.name in err[0] and "interrupted run" in err[0]


def test_report_removes_stale_staging_inside_the_report_folder(tmp_path, fake_sections, monkeypatch):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "reports"
    _earlier_output(out, "report", {"index.md": b"earlier index"}, "morpi report")
    _killed_run(out, "while computing")
    assert list(out.glob(".staging-*"))
    assert cli.main(["report", "--out", str(out)]) == 0
    assert not list(out.glob(".staging-*"))


# ----------------------------------------------------------------------------- what the user owns survives

#: Files a user keeps where a morpi command writes, and what they hold.
_FOREIGN_JSON = {
    "plain JSON": b'{"my": "own results"}\n',
    "not JSON": b"a lab notebook\n",
    "empty": b"",
    "the key, not first": b'{"data": 1, "morpi_output": {"format": 1, "command": "morpi drift"}}\n',
    "the key, not morpi's": b'{"morpi_output": "my own field"}\n',
}


@pytest.mark.parametrize("content", sorted(_FOREIGN_JSON))
def test_json_refuses_a_file_morpi_did_not_write_before_computing(content, tmp_path, fake_sections, capsys):
    js, out = tmp_path / "results.json", tmp_path / "sec"
    js.write_bytes(_FOREIGN_JSON[content])
    assert cli.main(["drift", "--out", str(out), "--json", str(js)]) == 2
    assert fake_sections == [] and js.read_bytes() == _FOREIGN_JSON[content]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(js) in err[0] and "--force" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]
    # --force overwrites it; the file is then morpi's: its first key says which command wrote it
    assert cli.main(["drift", "--out", str(out), "--json", str(js), "--force"]) == 0
    written = json.loads(js.read_text())
    assert next(iter(written)) == "morpi_output"
    assert written["morpi_output"] == {"format": 1, "command": "morpi drift", "section": "drift"}
    assert js.read_text() == (out / "result.json").read_text()
    # a morpi JSON is replaced without --force, by any command
    assert cli.main(["assess", "--out", str(tmp_path / "a"), "--json", str(js)]) == 0
    assert json.loads(js.read_text())["morpi_output"]["command"] == "morpi assess"


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_files_added_to_a_morpi_folder_survive_the_next_run(command, tmp_path, fake_sections, capsys):
    out = tmp_path / "sec"
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 0
    fake_sections.clear()
    for rel, data in {"notes.txt": b"my notes", "more/extra.csv": b"1,2\n"}.items():
        (out / rel).parent.mkdir(exist_ok=True)
        (out / rel).write_bytes(data)
    before = _snapshot(out)
    capsys.readouterr()
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 2
    assert fake_sections == [] and _snapshot(out) == before
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0] and "notes.txt" in err[0] and "more" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sec"]
    # moved out, the folder is morpi's again
    (out / "notes.txt").unlink()
    (out / "more" / "extra.csv").unlink()
    (out / "more").rmdir()
    assert cli.main([*WRITERS[command], "--out", str(out)]) == 0


def test_files_added_to_a_report_survive_the_next_report(tmp_path, fake_sections, monkeypatch, capsys):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "r"
    assert cli.main(["report", "--out", str(out)]) == 0
    (out / "tables" / "notes.md").write_text("my reading of table 2")
    (out / "mine.txt").write_text("next to the sections")
    fake_sections.clear()
    capsys.readouterr()
    assert cli.main(["report", "--out", str(out)]) == 2
    assert fake_sections == [] and (out / "tables" / "notes.md").read_text() == "my reading of table 2"
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out / "tables") in err[0] and "notes.md" in err[0]
    (out / "tables" / "notes.md").unlink()
    assert cli.main(["report", "--out", str(out)]) == 0
    assert (out / "mine.txt").read_text() == "next to the sections"     # the report folder keeps what it does not own


def test_a_marker_of_an_earlier_version_vouches_for_nothing_else(tmp_path, fake_sections, capsys):
    out = tmp_path / "sec"
    out.mkdir()
    (out / MARKER).write_text("Written by morpi drift (drift). The next run of a morpi command may replace this "
                              "folder or the entries it writes in it; files added to it are then lost.\n")
    (out / "notes.txt").write_text("added later")
    assert cli.main(["drift", "--out", str(out)]) == 2
    assert fake_sections == [] and (out / "notes.txt").read_text() == "added later"
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "notes.txt" in err[0] and "earlier morpi version" in err[0]
    (out / "notes.txt").unlink()          # the marker alone: an empty folder
    assert cli.main(["drift", "--out", str(out)]) == 0


def _no_simulation(monkeypatch):
    from morpi_filters import synthetic

    def boom(*args, **kwargs):
        raise AssertionError("the dataset was computed")

    monkeypatch.setattr(synthetic, "_synthetic_run", boom)


def test_simulate_refuses_a_dataset_holding_the_users_files(tmp_path, monkeypatch, capsys):
    out = tmp_path / "syn"
    assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1", "--seed", "1"]) == 0
    dataset = _snapshot(out)
    user = {"notes.txt": b"what I changed", "s6/L_line/99.csv": b"time,f_x\n0,1\n", "mine/plot.py": b"print(1)\n"}
    for rel, data in user.items():
        (out / rel).parent.mkdir(exist_ok=True)
        (out / rel).write_bytes(data)
    capsys.readouterr()
    with monkeypatch.context() as m:
        _no_simulation(m)
        assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1", "--seed", "2"]) == 2
    assert _snapshot(out) == {**dataset, **user}
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and all(n in err[0] for n in ("notes.txt", "s6/L_line/99.csv", "mine"))
    # a dataset of an earlier version (a plain-text marker) is known by its manifest: the same rule
    (out / MARKER).write_text("Written by morpi simulate (synthetic dataset). The next run may replace this "
                              "folder; files added to it are then lost.\n")
    with monkeypatch.context() as m:
        _no_simulation(m)
        assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1", "--seed", "2"]) == 2
    assert (out / "notes.txt").read_bytes() == user["notes.txt"]
    (out / MARKER).unlink()               # no marker at all: the manifest still tells morpi's files apart
    with monkeypatch.context() as m:
        _no_simulation(m)
        assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1", "--seed", "2"]) == 2
    assert _snapshot(out) == {k: v for k, v in {**dataset, **user}.items() if k != MARKER}
    for rel in user:
        (out / rel).unlink()
    (out / "mine").rmdir()
    assert cli.main(["simulate", "--out", str(out), "--runs-per-folder", "1", "--seed", "2"]) == 0
    assert json.loads((out / "manifest.json").read_text())["seed"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["syn"]


def test_json_inside_out_goes_into_the_new_folder(tmp_path, fake_sections):
    out = tmp_path / "sec"
    for _ in range(2):
        assert cli.main(["drift", "--out", str(out), "--json", str(out / "copy" / "r.json")]) == 0
        assert (out / "copy" / "r.json").read_text() == (out / "result.json").read_text()
        assert "copy/r.json" in json.loads((out / MARKER).read_text())["files"]
        assert sorted(p.name for p in tmp_path.iterdir()) == ["sec"]
    assert fake_sections == ["drift", "drift"]


@pytest.mark.parametrize("case", ["the folder itself", "the marker", "around the folder"])
def test_json_that_collides_with_out_is_refused_before_computing(case, tmp_path, fake_sections, capsys):
    out = tmp_path / "sec"
    js = {"the folder itself": out, "the marker": out / MARKER, "around the folder": tmp_path}[case]
    if case == "around the folder":
        out = tmp_path / "r.json" / "sec"
        js = tmp_path / "r.json"
    assert cli.main(["drift", "--out", str(out), "--json", str(js)]) == 2
    assert fake_sections == []
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--json" in err[0] and ("output folder" in err[0] or MARKER in err[0])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("case", [".", "the current directory by name", "..", "/"])
def test_a_folder_that_holds_the_current_directory_is_refused_before_computing(case, tmp_path, fake_sections,
                                                                                monkeypatch, capsys):
    work = tmp_path / "work"
    _earlier_output(work, "drift", {"README.md": b"earlier page"}, "morpi drift")   # a morpi folder of this kind
    monkeypatch.chdir(work)
    out = str(work) if case == "the current directory by name" else case
    assert cli.main(["drift", "--out", out]) == 2
    assert fake_sections == []
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--out {out}:" in err[0] and "current directory" in err[0]
    assert (work / "README.md").read_bytes() == b"earlier page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]
    assert sorted(p.name for p in work.iterdir()) == [MARKER, "README.md"]


def test_a_mount_point_is_refused_before_computing(tmp_path, fake_sections, capsys):
    mount = next((Path(p) for p in ("/proc", "/sys", "/dev") if os.path.ismount(p)), None)
    if mount is None:
        pytest.skip("no mount point to try")
    assert cli.main(["drift", "--out", str(mount)]) == 2
    assert fake_sections == []
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mount point" in err[0]


@pytest.mark.parametrize("first, second", [
    (["assess"], ["report"]), (["report"], ["assess"]), (["drift"], ["assess"]), (["assess"], ["simulate"]),
    (["simulate", "--runs-per-folder", "1"], ["drift"]),
])
def test_a_command_never_mixes_its_output_with_another_commands(first, second, tmp_path, fake_sections, monkeypatch,
                                                                 capsys):
    monkeypatch.setattr(cli, "_report_source", lambda args: None)
    out = tmp_path / "out"
    assert cli.main([*first, "--out", str(out)]) == 0
    before = _snapshot(out)
    fake_sections.clear()
    capsys.readouterr()
    with monkeypatch.context() as m:
        _no_simulation(m)
        assert cli.main([*second, "--out", str(out)]) == 2
    assert fake_sections == [] and _snapshot(out) == before
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"morpi {first[0]}" in err[0] and str(out) in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


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
    assert f"{tmp_path / 'ds'}: no recordings: no file matches the imu.file patterns of" in capsys.readouterr().err
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
