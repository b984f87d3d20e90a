"""The committed reports are what HEAD computes (the cheap sections).

The assessment (closed form, no data) and the tables (the field recordings)
are regenerated into a temporary folder and their result.json compared with
the committed ``reports/<section>/result.json``: same keys, same strings, and
numbers equal within ``REL`` relative / ``ABS`` absolute. Both sections are
deterministic (no random draw, no threads), so on the machine that wrote the
reports they agree exactly; the margin only covers a different summation
order of another BLAS or libm. A change of the code that moves a number fails
here until the reports are regenerated. No committed report names a place on
a disk: the dataset is named by what it is (``fetch.DatasetIdentity``).
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
from pathlib import Path

import pytest

from morpi_filters import evaluate as ev
from morpi_filters.assessment import assessment_study
from morpi_filters.fetch import CHECKSUMS_FILE
from morpi_filters.report.assessment import report_assessment
from morpi_filters.report.index import index_page
from morpi_filters.report.tables import report_tables
from morpi_filters.outputs import stamp_json
from morpi_filters.results import SAME_ABS, SAME_REL, DataSource

REPORTS = Path(__file__).resolve().parent.parent / "reports"
#: Relative and absolute tolerance of the numbers: the margin within which `morpi report` keeps a committed
#: file (results.SAME_REL, SAME_ABS). Machine arithmetic moves these numbers by a few 1e-11 relative at
#: most (3.3e-11 seen between two machines) and the JSON's 13 digits by at most 5e-13 more, 29 times below
#: 1e-9; near zero the absolute 1e-12 decides.
REL, ABS = SAME_REL, SAME_ABS
#: Keys a newer HEAD writes that an older committed report may not have yet.
NEWER_KEYS = {"partial", "left_out", "no_rest"}


def _diff(a, b, where="$", out=None):
    """Differences between committed `a` and regenerated `b`, as readable lines."""
    out = [] if out is None else out
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
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
    # the comparison itself: a change at the 1e-6 level is reported, one of another machine's digits is not
    a = {"x": [1.0, {"y": 2.0}], "s": "k"}
    assert _diff(a, {"x": [1.0, {"y": 2.0 * (1 + 5e-11)}], "s": "k"}) == []
    assert _diff(a, {"x": [1.0, {"y": 2.000002}], "s": "k"}) == [
        "$.x[1].y: 2.0 committed, 2.000002 regenerated"]
    assert _diff(a, {"x": [1.0, {"y": 2.0}], "s": "/elsewhere"}) == ["$.s: 'k' committed, '/elsewhere' regenerated"]


def test_committed_assessment_is_reproduced(tmp_path):
    committed = json.loads((REPORTS / "assessment" / "result.json").read_text())
    report_assessment(tmp_path / "assessment", assessment_study())
    stamp_json(tmp_path / "assessment" / "result.json", "morpi report", "assessment")   # as the command does
    fresh = json.loads((tmp_path / "assessment" / "result.json").read_text())
    assert _diff(committed, fresh) == []


@pytest.fixture(scope="module")
def field_tables(field_root):
    return ev.tables_study(field_root)


@pytest.mark.field
def test_committed_tables_are_reproduced(field_tables, field_root, tmp_path):
    committed = json.loads((REPORTS / "tables" / "result.json").read_text())
    assert committed["synthetic"] is False
    report_tables(tmp_path / "tables", field_tables, DataSource(field_root))
    stamp_json(tmp_path / "tables" / "result.json", "morpi report", "tables")   # as the command does
    fresh = json.loads((tmp_path / "tables" / "result.json").read_text())
    diffs = _diff(committed, fresh)
    assert diffs == [], f"{len(diffs)} difference(s), first: {diffs[:5]}"


# ----------------------------------------------------------------------------- no place on a disk

#: An absolute path (``/work/...``, ``~/...``) or a relative one climbing out of its folder (``../x``).
_ABSOLUTE = re.compile(r"(?:^|[\s`\"'(\[=])(~?/[\w.-]+/[\w./-]*)")
_CLIMBING = re.compile(r"(?:\.\./)+[\w./-]+")


def _places(text: str, folder: Path) -> list:
    """Paths in `text` that point outside the report (links to its own files are fine)."""
    found = [m for m in _ABSOLUTE.findall(text)]
    for m in _CLIMBING.findall(text):
        target = (folder / m).resolve()
        if not (target.is_relative_to(REPORTS.resolve()) and target.exists()):
            found.append(m)
    return found


def test_no_committed_report_names_a_place_on_a_disk():
    pages = sorted(p for p in REPORTS.rglob("*") if p.suffix in (".md", ".json"))
    assert len(pages) >= 10
    found = {str(p.relative_to(REPORTS)): hits for p in pages if (hits := _places(p.read_text(), p.parent))}
    assert found == {}
    # the rule sees the two kinds of place
    assert _places("Dataset: `../shared/morpi-dataset`; see [x](../aided/README.md) and /work/data/x.csv",
                   REPORTS / "tables") == ["/work/data/x.csv", "../shared/morpi-dataset"]


def test_committed_tables_name_the_published_dataset_by_its_checksums():
    # the fingerprint of the published recordings is the sha256 of the shipped checksum list's lines
    lines = [ln for ln in CHECKSUMS_FILE.read_text().splitlines(keepends=True) if not ln.startswith("#")]
    committed = json.loads((REPORTS / "tables" / "result.json").read_text())["dataset"]
    assert committed["kind"] == "field" and committed["published"] is True
    assert committed["recordings"] == len(lines) == 143
    assert committed["fingerprint"] == hashlib.sha256("".join(lines).encode()).hexdigest()


def _pages(study, root, out):
    """The tables page, its JSON and the index written from `study` with the dataset given as `root`."""
    summary = report_tables(out / "tables", study, DataSource(root))
    return [(out / "tables" / "README.md").read_text(), (out / "tables" / "result.json").read_text(),
            index_page([summary], DataSource(root))]


def test_pages_are_the_same_whatever_path_names_the_dataset(tmp_path):
    # one synthetic dataset at two places under two names: the tables page, its JSON and the index are the
    # same bytes, and none names either place
    from morpi_filters.synthetic import write_dataset

    first = write_dataset(tmp_path / "dirQ7x" / "ds", seed=2, runs_per_folder=1)
    second = shutil.copytree(first, tmp_path / "dirZ3k" / "another name")
    pages = [_pages(ev.tables_study(root), root, tmp_path / "out" / root.parent.name) for root in (first, second)]
    assert pages[0] == pages[1]
    for text in pages[0]:
        assert str(tmp_path) not in text and "dirQ7x" not in text and "dirZ3k" not in text
    assert json.loads(pages[0][1])["dataset"]["kind"] == "synthetic"


@pytest.mark.field
def test_field_pages_are_the_same_whatever_path_names_the_dataset(field_tables, field_root, tmp_path):
    # the field recordings as given and through a link of another name: the same bytes, no place named
    link = tmp_path / "dirQ7x" / "recordings"
    link.parent.mkdir()
    link.symlink_to(field_root.resolve(), target_is_directory=True)
    pages = [_pages(field_tables, root, tmp_path / name) for root, name in ((field_root, "a"), (link, "b"))]
    assert pages[0] == pages[1]
    for text in pages[0]:
        for place in (str(field_root), str(field_root.resolve()), field_root.name, "dirQ7x"):
            assert place not in text
