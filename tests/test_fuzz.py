"""Seeded fuzzing of the recording loader and of the tables' handling of bad recordings.

Every case starts from a small synthetic recording written at test time (never
from the field files) and applies one corruption. A case must end either in a
successful load whose numbers equal an independent reference reading of the
same bytes (the standard-library ``csv`` module plus ``float``, with the
documented rules: UTF-8 with an optional byte-order mark, columns by header
name) or in one :class:`DataError` line naming the file. Any other exception
fails the test. Corruptions that keep the content (CRLF, BOM, quotes, column
order, blank lines) must load and equal the original exactly.

The plausible-but-wrong families (:data:`FAMILIES`: a dead or stuck channel,
the accelerometer in g, the gyro in deg/s, swapped columns under a kept header,
a z-down frame) rewrite the numbers of a clean recording of a synthetic dataset
instead of its bytes; the commands' loader must refuse every one, naming the
file.
"""
from __future__ import annotations

import csv
import io
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from morpi_filters import dataset as ds
from morpi_filters.dataset import fastcsv as dsf, loader as dsl
from morpi_filters import evaluate as ev
from morpi_filters import synthetic, units
from morpi_filters.errors import DataError, MorpiError
from morpi_filters.report.tables import report_tables
from morpi_filters.results import DataSource

COLS = list(ds.COLUMNS)


def _base_text(rng, n=300) -> str:
    """A recording of a phone at rest with small motion: 100 Hz with jitter, values well inside the limits."""
    t = 0.31 + np.cumsum(0.01 + rng.uniform(0.0, 0.002, n))
    f = np.array([0.1, -0.2, 9.81]) + rng.normal(0.0, 0.05, (n, 3))
    w = rng.normal(0.0, 0.01, (n, 3))
    data = np.column_stack([t, f, w])
    return ",".join(COLS) + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in data) + "\n"


# ------------------------------------------------------------------ corruptions: bytes -> bytes

def _ri(rng, lo, hi) -> int:
    """A random integer in [lo, hi), or lo when the range is empty (short inputs)."""
    return int(rng.integers(lo, hi)) if hi > lo else int(lo)


def _lines(b):
    return b.decode("utf-8", "surrogateescape").split("\n")


def _join(lines):
    return "\n".join(lines).encode("utf-8", "surrogateescape")


def _shift_time(lines, start, by):
    for i in range(start, len(lines)):
        c = lines[i].split(",")
        try:
            c[0] = repr(float(c[0]) + by)
        except ValueError:
            continue
        lines[i] = ",".join(c)


def crlf(b, rng):
    return b.replace(b"\n", b"\r\n")


def bom(b, rng):
    return b"\xef\xbb\xbf" + b


def quote_all(b, rng):
    return _join([",".join(f'"{c}"' for c in s.split(",")) if s else s for s in _lines(b)])


def quote_some(b, rng):
    out = []
    for s in _lines(b):
        cells = s.split(",") if s else []
        out.append(",".join(f'"{c}"' if rng.random() < 0.3 else c for c in cells))
    return _join(out)


def reorder(b, rng):
    perm = rng.permutation(len(COLS))
    return _join([",".join(np.array(s.split(","))[perm]) if s else s for s in _lines(b)])


def blank_lines(b, rng):
    lines = _lines(b)
    for _ in range(3):
        lines.insert(_ri(rng, 2, len(lines)), "")
    return _join(lines)


def spaces(b, rng):
    return _join([", ".join(s.split(",")) for s in _lines(b)])


HARMLESS = (crlf, bom, quote_all, quote_some, reorder, blank_lines, spaces)


def empty(b, rng):
    return b""


def bom_only(b, rng):
    return b"\xef\xbb\xbf"


def whitespace_only(b, rng):
    return b" \r\n\t\n  "


def header_only(b, rng):
    return _lines(b)[0].encode() + b"\n"


def huge_number(b, rng):
    lines = _lines(b)
    k, j = _ri(rng, 1, len(lines) - 1), _ri(rng, 1, len(COLS))
    cells = lines[k].split(",")
    cells[j] = rng.choice(["1e300", "-1.7e308", "1e20", "170", "-40", "3.9e5"])
    lines[k] = ",".join(cells)
    return _join(lines)


def non_finite(b, rng):
    lines = _lines(b)
    k, j = _ri(rng, 1, len(lines) - 1), _ri(rng, 0, len(COLS))
    cells = lines[k].split(",")
    cells[j] = rng.choice(["nan", "NaN", "inf", "-inf", "Infinity", "1e999"])
    lines[k] = ",".join(cells)
    return _join(lines)


def non_utf8(b, rng):
    k = _ri(rng, 0, len(b))
    return b[:k] + bytes([_ri(rng, 0x80, 0x100)]) + b"\xff" + b[k:]


def nul_byte(b, rng):
    k = _ri(rng, 0, len(b))
    return b[:k] + b"\x00" + b[k:]


def time_reversal(b, rng):
    lines = _lines(b)
    k = _ri(rng, 2, len(lines) - 2)
    c1, c2 = lines[k].split(","), lines[k + 1].split(",")
    c1[0], c2[0] = c2[0], c1[0]
    lines[k], lines[k + 1] = ",".join(c1), ",".join(c2)
    return _join(lines)


def time_gap(b, rng):
    lines = _lines(b)
    k = _ri(rng, 2, len(lines) - 1)
    _shift_time(lines, k, float(rng.choice([1.5, 10.0, 1e6])))
    return _join(lines)


def absurd_time(b, rng):
    lines = _lines(b)
    _shift_time(lines, 1, 5e8)
    return _join(lines)


def duplicated_header(b, rng):
    lines = _lines(b)
    lines.insert(_ri(rng, 2, len(lines)), lines[0])
    return _join(lines)


def deleted_header(b, rng):
    return _join(_lines(b)[1:])


def unknown_column(b, rng):
    lines = _lines(b)
    return _join([s + (",temp" if i == 0 else ",21.5") if s else s for i, s in enumerate(lines)])


def short_file(b, rng):
    lines = _lines(b)
    return _join(lines[:_ri(rng, 2, ds.MIN_SAMPLES)])


HARMFUL = (empty, bom_only, whitespace_only, header_only, huge_number, non_finite, non_utf8, nul_byte,
           time_reversal, time_gap, absurd_time, duplicated_header, deleted_header, unknown_column, short_file)


def truncate(b, rng):
    return b[:_ri(rng, 0, len(b))]


def byte_flips(b, rng):
    a = bytearray(b) or bytearray(b" ")
    for _ in range(_ri(rng, 1, 4)):
        k = _ri(rng, 0, len(a))
        a[k] = _ri(rng, 0, 256)
    return bytes(a)


def delete_lines(b, rng):
    lines = _lines(b)
    for _ in range(_ri(rng, 1, 5)):
        if lines:
            del lines[_ri(rng, 0, len(lines))]
    return _join(lines)


def duplicate_line(b, rng):
    lines = _lines(b)
    k = _ri(rng, 0, len(lines))
    lines.insert(k, lines[k])
    return _join(lines)


def swap_lines(b, rng):
    lines = _lines(b)
    i, j = _ri(rng, 0, len(lines)), _ri(rng, 0, len(lines))
    lines[i], lines[j] = lines[j], lines[i]
    return _join(lines)


def digit_noise(b, rng):
    a = bytearray(b) or bytearray(b" ")
    for _ in range(5):
        k = _ri(rng, 0, len(a))
        if chr(a[k]).isdigit():
            a[k] = ord(str(_ri(rng, 0, 10)))
    return bytes(a)


#: Corruptions whose outcome depends on where they hit: checked against the reference reading.
EITHER = (truncate, byte_flips, delete_lines, duplicate_line, swap_lines, digit_noise)

KINDS = HARMLESS + HARMFUL + EITHER


# ------------------------------------------------------------------ plausible but wrong: numbers -> numbers
#
# Each family rewrites a clean recording (the header kept, every value written back exactly) into one that
# keeps every documented limit of the loader, or breaks one only where the family itself says so, but that no
# phone IMU at rest in SI units and the z-up frame records. The commands' loader must refuse each one, naming
# the file (dataset.plausibility_problems); none may be evaluated as if it were valid.

def _table(b):
    """The header's names and the rows of a clean recording's bytes."""
    head, _, rows = b.partition(b"\n")
    return head.decode().split(","), np.loadtxt(io.BytesIO(rows), delimiter=",", ndmin=2)


def _untable(header, data):
    """Bytes of a recording (17 significant digits: every value read back exactly)."""
    out = io.BytesIO()
    np.savetxt(out, data, delimiter=",", fmt="%.17g")
    return ",".join(header).encode() + b"\n" + out.getvalue()


def _col(header, name):
    return header.index(name)


def dead_channel(b, rng):
    """One sensor column (any of the six) reads 0 in every sample: a dead axis. Always told from a live one:
    every other column carries the sensor's white noise."""
    header, data = _table(b)
    data[:, _col(header, str(rng.choice(COLS[1:])))] = 0.0
    return _untable(header, data)


def constant_channel(b, rng):
    """One sensor column holds one of its own values in every sample (a stuck axis; its value is plausible,
    only its lack of noise tells)."""
    header, data = _table(b)
    j = _col(header, str(rng.choice(COLS[1:])))
    data[:, j] = data[_ri(rng, 0, data.shape[0]), j]
    return _untable(header, data)


def accel_in_g(b, rng):
    """The accelerometer written in g: every specific-force column divided by g."""
    header, data = _table(b)
    for c in ("f_x", "f_y", "f_z"):
        data[:, _col(header, c)] /= units.G0
    return _untable(header, data)


def gyro_in_deg_s(b, rng):
    """The gyro written in deg/s: every angular-rate column times 180 / pi. On a recording that turns faster
    than 36.65 deg/s the rates break the gyro's full scale and the parser refuses the file (still named)."""
    header, data = _table(b)
    for c in ("g_x", "g_y", "g_z"):
        data[:, _col(header, c)] = np.degrees(data[:, _col(header, c)])
    return _untable(header, data)


def swap_accel_gyro(b, rng):
    """f_z swapped with a gyro column under the kept header: gravity on a gyro column, none on the
    accelerometer. Swaps of f_x or f_y with a gyro column are left out by construction: at rest a nearly level
    phone's f_x and f_y read its tilt times g (0.26 m/s^2 for the synthetic mounting's 1.5 deg), within a
    gyro's zero-rate offsets (0.31 rad/s), and the gyro's few mrad/s barely change |f|: such a swap reads like
    a valid phone with a larger gyro offset, and no check at rest can tell it (only the motion could)."""
    header, data = _table(b)
    i, j = _col(header, "f_z"), _col(header, str(rng.choice(["g_x", "g_y", "g_z"])))
    data[:, [i, j]] = data[:, [j, i]]
    return _untable(header, data)


def swap_accel_axes(b, rng):
    """f_z swapped with f_x or f_y under the kept header: gravity on x or y while the frame says z up."""
    header, data = _table(b)
    i, j = _col(header, "f_z"), _col(header, str(rng.choice(["f_x", "f_y"])))
    data[:, [i, j]] = data[:, [j, i]]
    return _untable(header, data)


def z_down(b, rng):
    """The frame turned 180 deg about x or y: z and one other axis negated on both sensors (a right-handed
    z-down frame, as a phone lying face down or north-east-down axes write it)."""
    header, data = _table(b)
    other = str(rng.choice(["x", "y"]))
    for c in (f"f_{other}", "f_z", f"g_{other}", "g_z"):
        data[:, _col(header, c)] *= -1.0
    return _untable(header, data)


#: The plausible-but-wrong families: dead channel, wrong unit, swapped columns, z-down frame.
FAMILIES = (dead_channel, constant_channel, accel_in_g, gyro_in_deg_s, swap_accel_gyro, swap_accel_axes, z_down)


def corrupt(text: str, rng, n_ops: int, family=None):
    """Apply `family` (one of :data:`FAMILIES`, when given) to the clean text, then `n_ops` corruptions drawn
    from :data:`KINDS`; return the bytes and their names."""
    b, names = text.encode(), []
    if family is not None:
        b = family(b, rng)
        names.append(family.__name__)
    for _ in range(n_ops):
        kind = KINDS[_ri(rng, 0, len(KINDS))]
        try:
            b = kind(b, rng)
        except IndexError:   # a line-level corruption on what an earlier one left too short: not applied
            continue
        names.append(kind.__name__)
    return b, names


# ------------------------------------------------------------------ the independent reference reading

def reference(raw: bytes):
    """Read the bytes with csv + float under the documented rules; None where they are not a recording."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return None
    if "\x00" in text:
        return None
    rows = [r for r in csv.reader(text.splitlines()) if any(c.strip() for c in r)]
    if len(rows) < 1 + ds.MIN_SAMPLES or not text.splitlines()[0].strip():
        return None
    header = [c.strip() for c in rows[0]]
    if sorted(header) != sorted(COLS):
        return None
    idx = [header.index(c) for c in COLS]
    data = []
    for r in rows[1:]:
        if len(r) != len(COLS):
            return None
        try:
            vals = [float(r[j].strip()) for j in idx]
        except ValueError:
            return None
        data.append(vals)
    a = np.array(data)
    if not np.isfinite(a).all():
        return None
    dt = np.diff(a[:, 0])
    if (dt <= 0).any() or (dt > ds.MAX_GAP_S).any() or np.abs(a[:, 0]).max() > ds.TIME_LIMIT_S:
        return None
    if np.abs(a[:, 1:4]).max() > ds.ACCEL_LIMIT_MPS2 or np.abs(a[:, 4:7]).max() > ds.GYRO_LIMIT_RADPS:
        return None
    return a


def _run_case(path: Path, raw: bytes, names, original: np.ndarray):
    """One case; returns "loaded" or "rejected", or raises AssertionError describing the fault."""
    path.write_bytes(raw)
    ref = reference(raw)
    try:
        rec = ds.load_csv(path)
    except DataError as exc:
        msg = str(exc)
        assert str(path) in msg and "\n" not in msg, (names, msg)
        harmless = len(names) == 1 and names[0] in {k.__name__ for k in HARMLESS}
        assert not harmless, (names, msg)
        # the reference may still read numbers the loader refuses only where a rule is stricter
        # than csv + float (underscores in numbers, a quoted field with embedded commas)
        assert ref is None or b"_" in raw or b'"' in raw, (names, msg)
        return "rejected"
    got = np.column_stack([rec.time, rec.f, rec.omega])
    assert ref is not None, (names, "loaded what the reference rejects")
    np.testing.assert_array_equal(got, ref, err_msg=str(names))
    if len(names) == 1 and names[0] in {k.__name__ for k in HARMLESS}:
        np.testing.assert_array_equal(got, original, err_msg=str(names))
    return "loaded"


def _campaign(tmp_path, seed: int, n_cases: int):
    rng = np.random.default_rng(seed)
    text = _base_text(rng)
    original = np.array([[float(c) for c in s.split(",")] for s in text.splitlines()[1:]])
    outcome, per_kind = {"loaded": 0, "rejected": 0}, {}
    for i in range(n_cases):
        raw, names = corrupt(text, rng, n_ops=1 if i % 3 else _ri(rng, 2, 4))
        try:
            result = _run_case(tmp_path / f"case{i}.csv", raw, names, original)
        except AssertionError:
            raise
        except MorpiError as exc:  # a MorpiError that is not a DataError: wrong kind
            pytest.fail(f"case {i} {names}: {type(exc).__name__}: {exc}")
        except Exception as exc:  # noqa: BLE001 - the point of the test: no other exception
            pytest.fail(f"case {i} {names}: traceback-worthy {type(exc).__name__}: {exc}")
        outcome[result] += 1
        for n in names:
            per_kind[n] = per_kind.get(n, 0) + 1
        (tmp_path / f"case{i}.csv").unlink()
    return outcome, per_kind


def test_fuzz_loader_few_hundred(tmp_path):
    outcome, per_kind = _campaign(tmp_path, seed=20261123, n_cases=300)
    assert set(per_kind) == {k.__name__ for k in KINDS}   # every kind drawn at least once
    assert outcome["loaded"] > 0 and outcome["rejected"] > 0


def test_fuzz_loader_campaign_of_1000(tmp_path):
    outcome, per_kind = _campaign(tmp_path, seed=7, n_cases=1000)
    assert sum(outcome.values()) == 1000
    assert min(per_kind.values()) >= 20                  # each of the 28 kinds about 1000 * 1.3 / 28 times


@pytest.mark.parametrize("kind", HARMLESS)
def test_harmless_variants_load_the_same_numbers(tmp_path, kind):
    rng = np.random.default_rng(11)
    text = _base_text(rng)
    original = np.array([[float(c) for c in s.split(",")] for s in text.splitlines()[1:]])
    assert _run_case(tmp_path / "h.csv", kind(text.encode(), rng), [kind.__name__], original) == "loaded"


@pytest.mark.parametrize("kind", HARMFUL)
def test_harmful_corruptions_are_rejected(tmp_path, kind):
    rng = np.random.default_rng(12)
    text = _base_text(rng)
    original = np.array([[float(c) for c in s.split(",")] for s in text.splitlines()[1:]])
    assert _run_case(tmp_path / "b.csv", kind(text.encode(), rng), [kind.__name__], original) == "rejected"


# ------------------------------------------------------------------ through the tables

@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory):
    return synthetic.write_dataset(tmp_path_factory.mktemp("fuzz") / "ds", seed=4, runs_per_folder=2)


TARGET = "s8/short_distance/test/1.csv"


def test_fuzz_through_the_tables(tiny_dataset, tmp_path):
    """Corrupted recordings inside a dataset: no absurd cell, no silent drop.

    40 seeded corruptions of one test recording: those the loader rejects must
    stop the tables naming the file (and with ``partial`` be listed as left
    out); every one that loads is evaluated, and its cells must be finite and
    sane (:func:`evaluate.check_cells`) with the file among the runs or the
    failed runs of its cell. The first 3 rejections are run through the whole
    section (:func:`evaluate.tables_study` and its page, with and without ``partial``),
    the rest through :func:`evaluate.dataset_problems`, the same gate; the
    first 3 that load are evaluated (:func:`evaluate.evaluate_tables`).
    """
    root = tmp_path / "ds"
    shutil.copytree(tiny_dataset, root)
    target = root / TARGET
    text = (tiny_dataset / TARGET).read_text()
    rng = np.random.default_rng(99)
    full = {"rejected": 0, "loaded": 0}
    for i in range(40):
        raw, names = corrupt(text, rng, n_ops=1)
        target.write_bytes(raw)
        try:
            ds.load_csv(target)
            loads = True
        except DataError:
            loads = False
        kind = "loaded" if loads else "rejected"
        if not loads:
            data = ev.FieldData(root)
            problems = ev.dataset_problems(data)
            assert any(str(target) in p for p in problems), names
            if full[kind] < 3:
                with pytest.raises(DataError, match=str(target)):
                    ev.tables_study(root)
                report_tables(tmp_path / "out", ev.tables_study(root, partial=True), DataSource(root))
                payload = json.loads((tmp_path / "out" / "result.json").read_text())
                assert any(str(target) in x for x in payload["left_out"])
                assert str(target) in (tmp_path / "out" / "README.md").read_text()
                full[kind] += 1
        elif full[kind] < 3:
            res = ev.evaluate_tables(root, alternatives=False)
            ev.check_cells(res)                            # raises on a non-finite or absurd cell
            named = [c for c in res.cells if any(TARGET in r.file for r in c.runs)
                     or any(str(target) in f for f in c.failed)]
            assert named, names                            # the file is used or named, never dropped
            for c in res.cells:
                if c.runs:
                    assert math.isfinite(c.ours_percent) and abs(c.ours_percent) <= ev.CELL_SANITY_PERCENT
            full[kind] += 1
    assert full["rejected"] == 3 and full["loaded"] >= 1


#: Recordings the families are applied to: a periodic route, a straight line, an L route and a long straight
#: run, both phones. The periodic and long runs turn faster than 36.65 deg/s, the line and the L do not.
FAMILY_TARGETS = ("s8/short_distance/test/1.csv", "s8/line_dataset/1.csv", "s6/L_line/1.csv",
                  "s6/long_distance/test/1.csv")


def _parser_takes(family, rel) -> bool:
    """Whether the mutant keeps every limit of the parser (all but deg/s rates of a fast-turning run)."""
    return family is not gyro_in_deg_s or rel in ("s8/line_dataset/1.csv", "s6/L_line/1.csv")


@pytest.mark.parametrize("family", FAMILIES)
def test_each_plausible_but_wrong_family_is_refused_and_named(tiny_dataset, tmp_path, family):
    """Each family on each target: within the parser's limits (where the family says so), refused by the
    commands' loader with one line naming the file, and listed by the tables' gate."""
    root = tmp_path / "ds"
    shutil.copytree(tiny_dataset, root)
    rng = np.random.default_rng(31)
    entries = {e.relpath: e for e in ds.catalogue(root)}
    for rel in FAMILY_TARGETS:
        clean = (tiny_dataset / rel).read_bytes()
        (root / rel).write_bytes(family(clean, rng))
        try:
            ds.load_csv(root / rel)
            parsed = True
        except DataError:
            parsed = False
        assert parsed == _parser_takes(family, rel), rel
        with pytest.raises(DataError) as ei:
            entries[rel].load()
        msg = str(ei.value)
        assert msg.startswith(f"{root / rel}: ") and "\n" not in msg, msg
        if parsed:
            assert ds.plausibility_problems(ds.load_csv(root / rel)), rel
    problems = ev.dataset_problems(ev.FieldData(root))      # the last target's mutant, at the tables' gate
    assert any(p.startswith(f"{root / FAMILY_TARGETS[-1]}: ") for p in problems)


def test_families_under_further_corruption_are_never_accepted(tiny_dataset, tmp_path):
    """30 seeded cases: a family on a target, then 0 to 2 corruptions of KINDS. None loads through the
    commands' loader, each refusal names the file, and nothing but DataError is raised."""
    root = tmp_path / "ds"
    shutil.copytree(tiny_dataset, root)
    rng = np.random.default_rng(77)
    entries = {e.relpath: e for e in ds.catalogue(root)}
    drawn = set()
    for i in range(30):
        family = FAMILIES[i % len(FAMILIES)]
        rel = FAMILY_TARGETS[_ri(rng, 0, len(FAMILY_TARGETS))]
        clean = (tiny_dataset / rel).read_text()
        raw, names = corrupt(clean, rng, n_ops=_ri(rng, 0, 3), family=family)
        (root / rel).write_bytes(raw)
        with pytest.raises(DataError) as ei:
            entries[rel].load()
        assert str(root / rel) in str(ei.value) and "\n" not in str(ei.value), names
        (root / rel).write_text(clean)
        drawn.update(names)
    assert {f.__name__ for f in FAMILIES} <= drawn


def test_absurd_cell_is_an_error_not_a_number(tiny_dataset):
    """check_cells names the cell and its recordings for a non-finite or huge value."""
    import dataclasses

    res = ev.evaluate_tables(tiny_dataset, alternatives=False)
    ev.check_cells(res)
    c = next(c for c in res.cells if c.runs)
    bad_run = dataclasses.replace(c.runs[0], end_error_percent=3.7e75)
    cells = tuple(dataclasses.replace(x, runs=(bad_run,) + x.runs[1:]) if x is c else x for x in res.cells)
    with pytest.raises(DataError, match=rf"cell {c.spec.label}.*{bad_run.file}"):
        ev.check_cells(dataclasses.replace(res, cells=cells))
    nan_run = dataclasses.replace(c.runs[0], end_error_percent=float("nan"))
    cells = tuple(dataclasses.replace(x, runs=(nan_run,) + x.runs[1:]) if x is c else x for x in res.cells)
    with pytest.raises(DataError, match="not finite or beyond"):
        ev.check_cells(dataclasses.replace(res, cells=cells))


# ------------------------------------------------------------------ the C reader against the precise path

def _cell_spot(lines, rng):
    """A random data line index and the list of its cells (None when there are no data lines)."""
    if len(lines) < 3:
        return None, None
    k = _ri(rng, 1, len(lines) - 1)
    return k, lines[k].split(",")


def _edit_cell(lines, rng, make):
    k, cells = _cell_spot(lines, rng)
    if k is not None:
        j = _ri(rng, 0, len(cells))
        cells[j] = make(cells[j])
        lines[k] = ",".join(cells)


def _insert_char(lines, rng, chars):
    k, _ = _cell_spot(lines, rng)
    if k is not None:
        s = lines[k]
        i = _ri(rng, 0, len(s) + 1)
        lines[k] = s[:i] + chars + s[i:]


def _fast_edit(lines, rng):
    """One edit made of what the C reader's alphabet allows (so that the file may still take its path)."""
    op = _ri(rng, 0, 21)
    if op == 0:
        _edit_cell(lines, rng, lambda c: f'"{c}"')                    # a quoted cell
    elif op == 1:
        _insert_char(lines, rng, '"')                                 # a stray quote
    elif op == 2:                                                     # a quote open across a line end
        k, _ = _cell_spot(lines, rng)
        if k is not None and k + 1 < len(lines):
            lines[k] += '"'
            lines[k + 1] = '"' + lines[k + 1]
    elif op == 3:
        _insert_char(lines, rng, str(rng.choice(list("0123456789.eE+-, \""))))
    elif op == 4:                                                     # a character deleted
        k, _ = _cell_spot(lines, rng)
        if k is not None and lines[k]:
            i = _ri(rng, 0, len(lines[k]))
            lines[k] = lines[k][:i] + lines[k][i + 1:]
    elif op == 5:
        lines.insert(_ri(rng, 1, len(lines) + 1), str(rng.choice(["", "   ", " \r", "\r", '""', ",,,,,,"])))
    elif op == 6:
        _insert_char(lines, rng, "\r")                                # a lone carriage return
    elif op == 7:
        lines[:] = [s + "\r" for s in lines]                          # CRLF
    elif op == 8:
        _edit_cell(lines, rng, lambda c: str(rng.choice(["", '""', " ", '" "', "e", ".", "-", "+"])))
    elif op == 9:                                                     # the same value in another spelling
        _edit_cell(lines, rng, lambda c: _respell(c, rng))
    elif op == 10:
        _edit_cell(lines, rng, lambda c: str(rng.choice(["+", "-", "--", "+-", " ", "0"])) + c)
    elif op == 11:
        _edit_cell(lines, rng, lambda c: c + str(rng.choice([" ", ",", "e", "e1", "E-1", ".", "0", '"'])))
    elif op == 12:                                                    # spaces around the separators
        k, cells = _cell_spot(lines, rng)
        if k is not None:
            lines[k] = ", ".join(cells) if rng.random() < 0.5 else " ,".join(cells)
    elif op == 13:                                                    # the header quoted, padded or with a BOM
        h = lines[0].split(",")
        lines[0] = str(rng.choice(["\ufeff", "", ""])) + ",".join(
            f'"{c}"' if rng.random() < 0.5 else (f" {c} " if rng.random() < 0.3 else c) for c in h)
    elif op == 14:                                                    # columns in another order
        perm = rng.permutation(len(COLS))
        lines[:] = [",".join(np.array(s.split(","))[perm]) if s.count(",") == 6 else s for s in lines]
    elif op == 15:                                                    # a trailing comma
        k, _ = _cell_spot(lines, rng)
        if k is not None:
            lines[k] += ","
    elif op == 16:                                                    # a quote opened on the last cell, closed alone
        k, cells = _cell_spot(lines, rng)                             # on the next line
        if k is not None:
            lines[k] = ",".join(cells[:-1] + ['"' + cells[-1]])
            lines.insert(k + 1, '"')
    elif op == 17:                                                    # a line end inside a quoted cell
        _edit_cell(lines, rng, lambda c: '"' + c + str(rng.choice(["\r", "\n", "\r\n", " \r"])) + '"')
    elif op == 18:                                                    # a line repeated (repeated time)
        k, _ = _cell_spot(lines, rng)
        if k is not None:
            lines.insert(k, lines[k])
    elif op == 19:                                                    # two lines swapped (time goes back)
        k, _ = _cell_spot(lines, rng)
        if k is not None and k + 1 < len(lines):
            lines[k], lines[k + 1] = lines[k + 1], lines[k]
    else:                                                             # a gap in time
        k, _ = _cell_spot(lines, rng)
        if k is not None:
            _shift_time(lines, k, float(rng.choice([0.999, 1.5, -2.0])))


def _respell(cell: str, rng) -> str:
    try:
        v = float(cell)
    except ValueError:
        return cell
    forms = [f"{v:.17e}", f"{v:.17E}", f"{v:.25f}", f"{v:.3g}", f"{v!r}0000", f"+{v!r}", f"{v:.17g}e0", f"{v * 10:.17g}e-1"]
    return str(rng.choice(forms))


def _differential_cases(tmp_path, seed: int, n_cases: int, n_rows: int = 150):
    """Seeded files made with :func:`_fast_edit` (1 to 3 edits): each taken by the C reader must be read
    by the precise path too, bit for bit. Returns the number of cases the C reader took."""
    rng = np.random.default_rng(seed)
    text = _base_text(rng, n=n_rows)
    taken = 0
    for i in range(n_cases):
        lines = text.rstrip("\n").split("\n")
        for _ in range(_ri(rng, 1, 4)):
            _fast_edit(lines, rng)
        raw = ("\n".join(lines) + str(rng.choice(["\n", "", "\n\n"]))).encode("utf-8")
        path = tmp_path / f"d{i}.csv"
        path.write_bytes(raw)
        fast = dsf.fast_parse(path)
        try:
            precise = np.column_stack(dsl._parse(path))
        except DataError as exc:
            assert fast is None, (i, raw[:300], str(exc))
            continue
        if fast is not None:
            taken += 1
            assert all(a.flags.c_contiguous for a in fast), i
            got = np.column_stack(fast)
            assert got.shape == precise.shape, (i, got.shape, precise.shape)
            assert np.array_equal(got.view(np.int64), precise.view(np.int64)), i
        path.unlink()
    return taken


def test_c_reader_takes_only_what_the_precise_path_reads_the_same(tmp_path):
    """Whenever the C reader takes a file, the line-by-line path reads the same numbers bit for bit (and never
    rejects it); the C reader takes a good share of the cases, so the comparison is not empty."""
    taken = _differential_cases(tmp_path, seed=20261201, n_cases=600)
    assert taken >= 100, taken


def test_c_reader_in_blocks_takes_only_what_the_precise_path_reads_the_same(tmp_path, monkeypatch):
    """The same with the file read in small blocks (a long recording's path): rows, limits and time order
    across block ends."""
    monkeypatch.setattr(dsf, "_KEEP_BYTES", 0)
    monkeypatch.setattr(dsf, "BLOCK_BYTES", 700)
    monkeypatch.setattr(dsl, "BLOCK_BYTES", 700)
    taken = _differential_cases(tmp_path, seed=20261202, n_cases=300)
    assert taken >= 50, taken
