"""Atomic files and staged folders: an interrupted write leaves the old output intact."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from morpi_filters.report.common import md_table
from morpi_filters.outputs import atomic_path, staged_dir, write_json, write_text


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


# ----------------------------------------------------------------------------- what morpi owns

@pytest.mark.parametrize("obj, indent", [({"x": [1, 2], "y": {"z": None}}, 2), ({}, 2), ({"a": "b"}, None),
                                         ({"morpi_output": {"format": 0}, "a": 1}, 2)])
def test_stamp_json_puts_the_header_first_and_keeps_the_rest(obj, indent, tmp_path):
    from morpi_filters.outputs import is_morpi_json, stamp_json

    p = tmp_path / "r.json"
    p.write_text(json.dumps(obj, indent=indent))
    assert not is_morpi_json(p) or "morpi_output" in obj
    stamp_json(p, "morpi curves", "curves")
    got = json.loads(p.read_text())
    assert list(got)[0] == "morpi_output"
    assert got.pop("morpi_output") == {"format": 1, "command": "morpi curves", "section": "curves"}
    assert got == {k: v for k, v in obj.items() if k != "morpi_output"}
    assert is_morpi_json(p) and p.read_text().endswith("}\n")


def _marked(folder, files: dict, folders=()):
    """An earlier output in `folder`: `files` and the marker listing them (the documented format)."""
    folder.mkdir()
    for rel, data in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(data)
    listed = sorted(set(folders) | {rel.rsplit("/", 1)[0] for rel in files if "/" in rel})
    (folder / ".morpi-output").write_text(json.dumps({"morpi_output": 1, "command": "morpi drift", "kind": "drift",
                                                      "files": sorted(files), "folders": listed}))


def test_swap_in_removes_only_what_the_old_marker_lists(tmp_path):
    # a file added to the old folder after it was checked (while the new one was computed) is not deleted:
    # the folder holding it stays aside, and a later run's cleanup leaves it too, naming it
    from morpi_filters.outputs import remove_stale

    final = tmp_path / "sec"
    _marked(final, {"README.md": b"old page", "fig/a.png": b"old figure"})
    (final / "added.txt").write_bytes(b"written during the run")
    (final / "fig" / "mine.png").write_bytes(b"the user's figure")
    code = ("import sys\nfrom pathlib import Path\nfrom morpi_filters.outputs import new_stage_dir, swap_in\n"
            "final = Path(sys.argv[1])\nstage = new_stage_dir(final)\n(stage / 'README.md').write_text('new page')\n"
            "print(swap_in(stage, final).name)\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))   # this checkout's package
    r = subprocess.run([sys.executable, "-c", code, str(final)], capture_output=True, text=True, check=True, env=env)
    keep = tmp_path / r.stdout.strip()
    assert (final / "README.md").read_text() == "new page"
    assert keep.name.startswith(".previous-sec-")
    assert sorted(p.relative_to(keep / "sec").as_posix() for p in (keep / "sec").rglob("*")) == [
        ".morpi-output", "added.txt", "fig", "fig/mine.png"]
    assert remove_stale(tmp_path) == [keep]       # its process is gone: named, not emptied
    assert (keep / "sec" / "added.txt").read_bytes() == b"written during the run"
    assert (keep / "sec" / "fig" / "mine.png").read_bytes() == b"the user's figure"


def test_a_marker_never_reaches_outside_its_folder(tmp_path):
    from morpi_filters.outputs import new_stage_dir, swap_in

    outside = tmp_path / "home"
    outside.mkdir()
    (outside / "secret.txt").write_bytes(b"keep")
    (tmp_path / "top.txt").write_bytes(b"keep too")
    final = tmp_path / "sec"
    _marked(final, {"README.md": b"old"})
    (final / "link").symlink_to(outside)
    marker = json.loads((final / ".morpi-output").read_text())
    marker["files"] += ["link/secret.txt", "../../top.txt", str(tmp_path / "top.txt")]
    marker["folders"] += ["link"]
    (final / ".morpi-output").write_text(json.dumps(marker))
    stage = new_stage_dir(final)
    keep = swap_in(stage, final)
    assert (outside / "secret.txt").read_bytes() == b"keep" and (tmp_path / "top.txt").read_bytes() == b"keep too"
    assert keep is not None and (keep / "sec" / "link").is_symlink()


# ----------------------------------------------------------------------------- stated precision, same result

def test_write_json_states_floats_at_json_digits(tmp_path):
    # against decimal's own rounding of the exact binary value (half to even, JSON_DIGITS digits)
    import decimal

    from morpi_filters.results import JSON_DIGITS

    ctx = decimal.Context(prec=JSON_DIGITS, rounding=decimal.ROUND_HALF_EVEN)
    xs = [1.0 / 3.0, -2.0 / 3.0 * 1e-7, 123456.78901234567, 9.87654321098765e5, 0.1 + 0.2, 5e-324, 1.0]
    got = json.loads(write_json(tmp_path / "r.json", {"x": np.array(xs), "n": 7}).read_text())
    assert got["x"] == [float(ctx.plus(decimal.Decimal(x))) for x in xs] and got["n"] == 7
    assert got["x"][0] == float("0." + "3" * JSON_DIGITS) and got["x"][4] == 0.3


def _write_section(out, number, word="runs", digest="2a8affc79930"):
    from morpi_filters.outputs import Outputs

    with Outputs("morpi test") as outputs:
        outputs.root(out)
        stage = outputs.folder(out / "sec")
        write_json(stage / "result.json", {"rms_m": number, "what": word, "digest": digest})
        write_text(stage / "README.md", f"RMS {number!r} m over 40 {word}; digest `{digest}`.\n")
        outputs.file(out / "index.md").write_text(f"# report\n\nRMS {number!r} m.\n")


def test_the_same_output_gives_the_same_marker_bytes(tmp_path):
    # The staging proof (pid and token) leaves the marker once the folder is in place: two runs that write the
    # same output leave every marker byte for byte as it was, so a regenerated report leaves git status clean.
    out = tmp_path / "reports"
    _write_section(out, 0.5)
    markers = [out / ".morpi-output", out / "sec" / ".morpi-output"]
    first = [m.read_bytes() for m in markers]
    assert all(b"staged_as" not in b for b in first)
    _write_section(out, 0.5)
    assert [m.read_bytes() for m in markers] == first
    assert json.loads(first[1])["files"] == ["README.md", "result.json"]


def test_outputs_keep_a_file_that_states_the_same_result(tmp_path):
    import os

    out = tmp_path / "reports"
    x = 0.123456789012345
    _write_section(out, x)
    files = [out / "sec" / "result.json", out / "sec" / "README.md", out / "index.md"]
    past = 1_000_000_000
    for f in files:
        os.utime(f, ns=(past, past))
    before = [f.read_bytes() for f in files]
    # another machine's last digits: 1e-10 relative moves the written digits, within the 1e-9 margin
    _write_section(out, x * (1 + 1e-10))
    assert [f.read_bytes() for f in files] == before
    assert [f.stat().st_mtime_ns for f in files] == [past] * 3
    # a number beyond the margin, a word, a digest: written anew (the index holds only the number)
    for kw, rewritten in (({"number": x * (1 + 1e-6)}, files), ({"word": "walks"}, files[:2]),
                          ({"digest": "2a8affc79931"}, files[:2])):
        _write_section(out, x)
        for f in files:
            os.utime(f, ns=(past, past))
        _write_section(out, **{"number": x, **kw})
        assert [f.stat().st_mtime_ns != past for f in files] == [f in rewritten for f in files], kw
        assert str(next(iter(kw.values()))) in (out / "sec" / "README.md").read_text()
    assert sorted(p.name for p in out.iterdir()) == [".morpi-output", "index.md", "sec"]


def test_outputs_replace_a_json_file_of_another_precision(tmp_path):
    # a result.json written with every float's 17 digits (an older writer) is replaced by the 13-digit one,
    # though its numbers agree within the margin
    out = tmp_path / "reports"
    x = 0.123456789012345
    _write_section(out, x)
    old = '{"rms_m": 0.12345678901234512, "what": "runs", "digest": "2a8affc79930"}\n'
    (out / "sec" / "result.json").write_text(old)
    _write_section(out, x)
    assert json.loads((out / "sec" / "result.json").read_text())["rms_m"] == 0.1234567890123


@pytest.mark.parametrize("old, new, same", [
    ("digest `2a8affc79930ffd4`", "digest `2a8affc79930ffd5`", False),
    ("digest `1234567890123456`", "digest `1234567890123457`", False),   # integers: written the same
    ("seed 20230901, 2000 runs", "seed 20230901, 2001 runs", False),
    ("from s6/L_line/10.csv", "from s6/L_line/11.csv", False),
    ("spread 5.0236 %, 40 runs.", "spread 5.02360000001 %, 40 runs.", True),
    ("spread 5.0236 %, 40 runs.", "spread 5.0237 %, 40 runs.", False),
    ("mean -0.25 m", "mean -0.2500000000001 m", True),
    ("mean -0.25 m", "mean 0.25 m", False),
    ("zero 0.0", "zero 1e-13", True),
])
def test_same_output_reads_the_numbers_of_a_page(tmp_path, old, new, same):
    from morpi_filters.results import same_output

    (tmp_path / "old.md").write_text(old)
    (tmp_path / "new.md").write_text(new)
    assert same_output(tmp_path / "old.md", tmp_path / "new.md") is same
