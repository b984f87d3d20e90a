"""The loader, its validation, and the catalogue of the MoRPI layout."""
from __future__ import annotations

import re

import numpy as np
import pytest

from morpi_filters import MorpiError
from morpi_filters.dataset import fastcsv as dsf, loader as dsl, plausibility as dsp
from morpi_filters.dataset import (
    COLUMNS, Recording, catalogue, layout, load_csv, resolve_data_root, route, write_csv,
)
from morpi_filters.field import check_recordings
from conftest import good_rows, write_rows


def test_good_file_round_trip(tmp_path):
    rows = good_rows()
    rec = load_csv(write_rows(tmp_path / "a.csv", rows), phone="s8")
    data = np.asarray(rows)
    np.testing.assert_array_equal(rec.time, data[:, 0])
    np.testing.assert_array_equal(rec.f, data[:, 1:4])
    np.testing.assert_array_equal(rec.omega, data[:, 4:7])
    assert rec.phone == "s8" and rec.n == len(rows)
    # write_csv keeps every bit (%.17g round-trips a double exactly).
    write_csv(tmp_path / "b.csv", rec)
    again = load_csv(tmp_path / "b.csv")
    np.testing.assert_array_equal(again.time, rec.time)
    np.testing.assert_array_equal(again.f, rec.f)


def _bad(tmp_path, rows, header=COLUMNS):
    return write_rows(tmp_path / "bad.csv", rows, header=",".join(header) if header else None)


@pytest.mark.parametrize("case, make, expect", [
    ("empty", lambda p: p.write_text(""), "empty file"),
    ("header only", lambda p: p.write_text(",".join(COLUMNS) + "\n"), "header only"),
    ("binary", lambda p: p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00"), "not CSV text"),
    ("latin-1", lambda p: p.write_bytes("time,f_x\n\xe9\xe8".encode("latin-1")), "not CSV text"),
])
def test_rejects_unreadable(tmp_path, case, make, expect):
    p = tmp_path / "x.csv"
    make(p)
    with pytest.raises(MorpiError, match=expect) as ei:
        load_csv(p)
    assert str(p) in str(ei.value) and "\n" not in str(ei.value)


def test_rejects_missing_and_unexpected_columns(tmp_path):
    rows = [r[:6] for r in good_rows()]
    with pytest.raises(MorpiError, match=r"line 1: missing column\(s\) g_z"):
        load_csv(write_rows(tmp_path / "m.csv", rows, header="time,f_x,f_y,f_z,g_x,g_y"))
    rows = [r + [0.0] for r in good_rows()]
    with pytest.raises(MorpiError, match="unexpected column.*'temp'"):
        load_csv(write_rows(tmp_path / "u.csv", rows, header="time,f_x,f_y,f_z,g_x,g_y,g_z,temp"))


def _with_row(k, row):
    rows = good_rows()
    rows[k] = row
    return rows


@pytest.mark.parametrize("k, row, expect", [
    (10, "0.5,0,0,9.8,0,0", r"line 12: short row, 6 fields, expected 7"),
    (10, "0.5,0,0,9.8,0,0,0,1", r"line 12: long row"),
    (20, "0.5,0,abc,9.8,0,0,0", r"line 22: column f_y: 'abc' is not a number"),
    (30, "0.5,0,0,nan,0,0,0", r"line 32: column f_z: nan is not finite"),
    (40, "0.5,0,0,9.8,0,inf,0", r"line 42: column g_y: inf is not finite"),
])
def test_rejects_bad_rows(tmp_path, k, row, expect):
    with pytest.raises(MorpiError, match=expect):
        load_csv(write_rows(tmp_path / "r.csv", _with_row(k, row)))


def test_rejects_repeated_and_decreasing_time(tmp_path):
    rows = good_rows()
    rows[50][0] = rows[49][0]
    with pytest.raises(MorpiError, match=r"line 52: repeated time stamp .*line 51"):
        load_csv(write_rows(tmp_path / "t.csv", rows))
    rows = good_rows()
    rows[60][0] = rows[59][0] - 0.5
    with pytest.raises(MorpiError, match=r"line 62: decreasing time stamp"):
        load_csv(write_rows(tmp_path / "t2.csv", rows))


def test_rejects_too_few_samples(tmp_path):
    with pytest.raises(MorpiError, match="too few samples: 20 rows"):
        load_csv(write_rows(tmp_path / "s.csv", good_rows(20)))


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(MorpiError, match="no such file"):
        load_csv(tmp_path / "nope.csv")
    with pytest.raises(MorpiError, match="is a directory"):
        load_csv(tmp_path)


def test_recording_shape_check():
    with pytest.raises(MorpiError, match="expected time"):
        Recording(np.zeros(3), np.zeros((3, 2)), np.zeros((3, 3)))


def test_resolve_data_root(monkeypatch, tmp_path):
    monkeypatch.delenv("MORPI_DATA", raising=False)
    with pytest.raises(MorpiError, match="morpi data fetch"):
        resolve_data_root(None)
    assert resolve_data_root(None, required=False) is None
    monkeypatch.setenv("MORPI_DATA", str(tmp_path))
    assert resolve_data_root(None) == tmp_path
    with pytest.raises(MorpiError, match="--data=.*not a directory"):
        resolve_data_root(tmp_path / "missing")


def test_routes_ground_truth():
    # The numbers of the dataset README and the paper: 6.3 m, 13 m, L = 18 m + 10 m.
    assert route("short_distance").distance_m == 6.3
    assert route("long_distance").distance_m == 13.0
    L = route("L_line")
    assert L.segments_m == (18.0, 10.0) and L.distance_m == 28.0 and abs(L.turn_deg) == 90
    assert sum(layout().values()) == 143
    with pytest.raises(MorpiError, match="unknown"):
        route("nowhere")


@pytest.mark.field
def test_field_dataset_loads_and_matches_layout(field_root):
    entries = catalogue(field_root)
    assert len(entries) == 143
    counts = {}
    for e in entries:
        key = "/".join([e.phone, e.route] + ([e.split] if e.split else []))
        counts[key] = counts.get(key, 0) + 1
    assert counts == layout()
    problems, n_ok, _ = check_recordings(field_root)
    assert problems == [] and n_ok == 143
    rec = entries[0].load()
    # A level phone at rest reads about +g on z (README): first 0.5 s.
    fz = rec.f[rec.time < rec.time[0] + 0.5, 2].mean()
    assert 9.3 < fz < 10.3


# ----------------------------------------------------------------- physical limits and standard CSV

from morpi_filters import units
from morpi_filters.dataset import ACCEL_LIMIT_MPS2, GYRO_LIMIT_RADPS, MAX_GAP_S, TIME_LIMIT_S
from morpi_filters.errors import DataError


def test_limits_are_the_datasheet_full_scales():
    # Full scales from the LSM6DSL and MPU-6500 datasheets (16 g, 2000 deg/s) with the 5 % margin
    # the loader states; computed here from the constants of units.py, independently of dataset.py.
    assert ACCEL_LIMIT_MPS2 == pytest.approx(16 * units.G0 * 1.05, rel=1e-15)
    assert GYRO_LIMIT_RADPS == pytest.approx(np.radians(2000) * 1.05, rel=1e-15)
    assert MAX_GAP_S == 1.0 and TIME_LIMIT_S == 1e8


@pytest.mark.parametrize("col, value, expect", [
    (3, "1.7e308", r"line 42: column f_z: specific force 1.7e\+308 m/s\^2 is beyond"),
    (1, "-170", r"line 42: column f_x: specific force -170.0 m/s\^2 is beyond \+-164.8 m/s\^2"),
    (5, "40", r"line 42: column g_y: angular rate 40.0 rad/s is beyond \+-36.65 rad/s"),
])
def test_rejects_values_beyond_full_scale(tmp_path, col, value, expect):
    rows = good_rows()
    rows[40] = ",".join(value if j == col else repr(v) for j, v in enumerate(rows[40]))
    with pytest.raises(DataError, match=expect) as ei:
        load_csv(write_rows(tmp_path / "v.csv", rows))
    assert str(tmp_path / "v.csv") in str(ei.value)


def test_accepts_values_at_full_scale(tmp_path):
    rows = good_rows()
    rows[40][1] = 16 * units.G0       # exactly full scale on the accelerometer
    rows[41][6] = -np.radians(2000)   # exactly full scale on the gyro
    rec = load_csv(write_rows(tmp_path / "fs.csv", rows))
    assert rec.f[40, 0] == 16 * units.G0 and rec.omega[41, 2] == -np.radians(2000)


def test_rejects_time_gaps_and_absurd_times(tmp_path):
    rows = good_rows()
    for r in rows[70:]:
        r[0] += 1e6
    with pytest.raises(DataError, match=r"line 72: time gap of 1e\+06 s after line 71, expected at most 1 s"):
        load_csv(write_rows(tmp_path / "g.csv", rows))
    rows = good_rows()
    for r in rows[70:]:
        r[0] += 1.5   # 1.5 s gap: above the stated bound
    with pytest.raises(DataError, match=r"line 72: time gap of 1.5\d* s"):
        load_csv(write_rows(tmp_path / "g2.csv", rows))
    rows = good_rows()
    for r in rows:
        r[0] += 2e8
    with pytest.raises(DataError, match=r"line 2: column time: .* beyond the limit of \+-1e\+08 s"):
        load_csv(write_rows(tmp_path / "t.csv", rows))


@pytest.mark.parametrize("content", [b"\xef\xbb\xbf", b"\xef\xbb\xbf\r\n  \r\n", b"   \n\t\n", b"\r\n"])
def test_rejects_bom_only_and_blank_files(tmp_path, content):
    p = tmp_path / "b.csv"
    p.write_bytes(content)
    with pytest.raises(DataError, match="empty file") as ei:
        load_csv(p)
    assert str(p) in str(ei.value) and "\n" not in str(ei.value)


def test_check_survives_a_bom_only_file(tmp_path):
    d = tmp_path / "s8" / "line_dataset"
    d.mkdir(parents=True)
    (d / "1.csv").write_bytes(b"\xef\xbb\xbf")
    write_rows(d / "2.csv", good_rows())
    problems, n_ok, _ = check_recordings(tmp_path)
    assert n_ok == 1 and any("1.csv: empty file" in p for p in problems)


def test_the_catalogue_takes_each_folders_imu_from_the_shipped_manifest(tmp_path):
    # which phone carries which IMU is data/morpi.toml's to say (analysis/morpi_manifest.py writes it from the
    # paper's table of sensors): the catalogue of `morpi check --data` and load_recording read it there
    import tomllib

    from morpi_filters import units
    from morpi_filters.dataset import catalogue, folder_imu, load_recording
    from morpi_filters.resources import morpi_manifest

    named = {r["imu"]["file"].rsplit("/", 1)[0]: r["imu"]["spec"]
             for r in tomllib.loads(morpi_manifest().read_text())["recording"]}
    for folder in ("s6/L_line", "s8/short_distance/test"):
        (tmp_path / folder).mkdir(parents=True)
        write_rows(tmp_path / folder / "1.csv", good_rows())
        assert folder_imu(folder) is units.IMUS[named[folder]]
    loaded = {e.relpath: e.load().imu for e in catalogue(tmp_path)}
    assert loaded == {"s6/L_line/1.csv": units.MPU6500, "s8/short_distance/test/1.csv": units.LSM6DSL}
    assert load_recording(tmp_path / "s8/short_distance/test/1.csv")[0].imu is units.LSM6DSL
    assert load_csv(tmp_path / "s6/L_line/1.csv", phone="s6").imu is None     # a label is not an IMU


def _reference(tmp_path):
    rows = good_rows()
    rows = [[r[0], 0.1 * k, -0.2, 9.81, 0.01, -0.02 * k, 0.03] for k, r in enumerate(rows)]
    return rows, load_csv(write_rows(tmp_path / "ref.csv", rows))


def _same(a, b):
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.f, b.f)
    np.testing.assert_array_equal(a.omega, b.omega)


def test_accepts_standard_csv_variants(tmp_path):
    rows, ref = _reference(tmp_path)
    text = (tmp_path / "ref.csv").read_text()
    # BOM + CRLF
    p = tmp_path / "crlf.csv"
    p.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    _same(load_csv(p), ref)
    # every field quoted
    p = tmp_path / "q.csv"
    p.write_text("\n".join(",".join(f'"{c}"' for c in line.split(",")) for line in text.splitlines()) + "\n")
    _same(load_csv(p), ref)
    # quoted header only
    p = tmp_path / "qh.csv"
    lines = text.splitlines()
    p.write_text(",".join(f'"{c}"' for c in COLUMNS) + "\n" + "\n".join(lines[1:]) + "\n")
    _same(load_csv(p), ref)
    # columns in another order, by header name
    perm = [3, 0, 6, 1, 5, 2, 4]
    p = tmp_path / "perm.csv"
    p.write_text(",".join(COLUMNS[j] for j in perm) + "\n"
                 + "\n".join(",".join(repr(float(r[j])) for j in perm) for r in rows) + "\n")
    _same(load_csv(p), ref)


def test_reordered_columns_name_the_right_column(tmp_path):
    rows, _ = _reference(tmp_path)
    perm = [6, 5, 4, 3, 2, 1, 0]
    rows[30][5] = 50.0   # g_y, written in the file's second column
    p = tmp_path / "perm.csv"
    p.write_text(",".join(COLUMNS[j] for j in perm) + "\n"
                 + "\n".join(",".join(repr(float(r[j])) for j in perm) for r in rows) + "\n")
    with pytest.raises(DataError, match=r"line 32: column g_y: angular rate 50.0"):
        load_csv(p)


def test_rejects_repeated_and_unknown_columns(tmp_path):
    rows = [r + [0.0] for r in good_rows()]
    with pytest.raises(DataError, match=r"line 1: repeated column\(s\) f_x"):
        load_csv(write_rows(tmp_path / "r.csv", rows, header="time,f_x,f_y,f_z,g_x,g_y,g_z,f_x"))


def test_text_after_a_number_is_not_a_comment(tmp_path):
    # '#' starts no comment in CSV: the row is rejected, not silently cut
    rows = good_rows()
    rows[50] = ",".join(repr(v) for v in rows[50]) + " # note"
    with pytest.raises(DataError, match=r"line 52: column g_z: '.* # note' is not a number"):
        load_csv(write_rows(tmp_path / "c.csv", rows))


@pytest.mark.field
def test_fast_loader_is_bit_identical_to_a_line_by_line_reading(field_root):
    """Every field file through the C reader equals csv + float() cell by cell, bit for bit."""
    import csv as _csv

    from morpi_filters import dataset as ds

    for e in ds.catalogue(field_root):
        rec = ds.load_csv(e.path)
        with open(e.path, newline="", encoding="utf-8-sig") as fh:
            rows = list(_csv.reader(fh))
        header = [c.strip() for c in rows[0]]
        ref = np.array([[float(c) for c in r] for r in rows[1:] if r], dtype=float)
        ref = ref[:, [header.index(c) for c in ds.COLUMNS]]
        got = np.column_stack([rec.time, rec.f, rec.omega])
        assert got.shape == ref.shape and np.array_equal(got.view(np.int64), ref.view(np.int64)), e.relpath


@pytest.mark.field
def test_every_field_file_takes_the_c_reader_and_equals_csv_and_float(field_root):
    """The C reader (pandas) takes each of the 143 recordings, and its numbers are those of csv + float()."""
    import csv as _csv

    from morpi_filters import dataset as ds

    for e in ds.catalogue(field_root):
        cols = dsf.fast_parse(e.path)
        assert cols is not None, e.relpath
        # C order, as the line-by-line path gives them (a sum's last bits depend on the memory order)
        assert all(a.flags.c_contiguous for a in cols), e.relpath
        with open(e.path, newline="", encoding="utf-8-sig") as fh:
            rows = list(_csv.reader(fh))
        header = [c.strip() for c in rows[0]]
        ref = np.array([[float(c) for c in r] for r in rows[1:] if r], dtype=float)
        ref = ref[:, [header.index(c) for c in ds.COLUMNS]]
        got = np.column_stack(cols)
        assert got.shape == ref.shape and np.array_equal(got.view(np.int64), ref.view(np.int64)), e.relpath


def test_c_reader_options_round_correctly():
    """pandas' C reader with the loader's options returns float(s) for decimal strings that are hard to round:
    exact midpoints between two doubles (ties to even), a digit past them, and 17 to 25 significant digits."""
    import io
    from decimal import Decimal, getcontext

    import pandas as pd

    rng = np.random.default_rng(5)
    getcontext().prec = 80
    mids = [format(Decimal(1.0 + int(k) * 2.0 ** -52) + Decimal(2.0 ** -53), "f")
            for k in rng.integers(0, 2 ** 52, 3000)]
    strings = (mids + [m + "0000000001" for m in mids]
               + ["%.17g" % v for v in rng.normal(0.0, 10.0, 20000)]
               + ["-0." + "".join(map(str, rng.integers(0, 10, 25))) for _ in range(5000)])
    frame = pd.read_csv(io.StringIO("x\n" + "\n".join(strings) + "\n"), dtype=np.float64, **dsf._pandas_options())
    got = frame["x"].to_numpy()
    ref = np.array([float(s) for s in strings])
    assert np.array_equal(got.view(np.int64), ref.view(np.int64))


def test_float_options_by_pandas_version():
    from morpi_filters.dataset.fastcsv import _float_options

    assert _float_options("2.2.3") == {"float_precision": "round_trip"}
    assert _float_options("3.0.1") == {"float_precision": "round_trip"}
    assert _float_options("3.1.0") == {} and _float_options("3.1.1") == {} and _float_options("4.0.0.dev0") == {}


def test_long_file_in_blocks_names_a_bad_line_after_the_first_block(tmp_path, monkeypatch):
    """A file read in blocks (as a long recording is): good rows load the same as in one piece; a repeated time
    stamp, a gap or a non-number far into the file is named by its line."""
    rows = good_rows(400)
    path = write_rows(tmp_path / "long.csv", rows)
    whole = load_csv(path)
    monkeypatch.setattr(dsf, "_KEEP_BYTES", 0)
    monkeypatch.setattr(dsf, "BLOCK_BYTES", 512)
    monkeypatch.setattr(dsl, "BLOCK_BYTES", 512)
    assert dsf.fast_parse(path) is not None
    in_blocks = load_csv(path)
    _same(in_blocks, whole)
    assert all(a.flags.c_contiguous for rec in (whole, in_blocks) for a in (rec.time, rec.f, rec.omega))
    bad = [list(r) for r in rows]
    bad[350][0] = bad[349][0]
    with pytest.raises(DataError, match=r"line 352: repeated time stamp"):
        load_csv(write_rows(tmp_path / "rep.csv", bad))
    bad = [list(r) for r in rows]
    for r in bad[300:]:
        r[0] += 2.0
    with pytest.raises(DataError, match=r"line 302: time gap of 2.0\d* s after line 301"):
        load_csv(write_rows(tmp_path / "gap.csv", bad))
    bad = list(rows)
    bad[390] = "0.5,0,0,9.8,0,0,x"
    with pytest.raises(DataError, match=r"line 392: column g_z: 'x' is not a number"):
        load_csv(write_rows(tmp_path / "nan.csv", bad))


@pytest.mark.parametrize("block", [1, 2, 3, 5, 64])
def test_text_lines_in_blocks_are_those_of_splitlines(tmp_path, monkeypatch, block):
    """The precise path's line reader, fed a few bytes at a time, cuts the text as str.splitlines cuts the whole
    of it: CRLF split between blocks, multi-byte characters split between blocks, every line boundary."""
    monkeypatch.setattr(dsl, "BLOCK_BYTES", block)
    rng = np.random.default_rng(block)
    pieces = ["a", "b,1", "\r", "\n", "\r\n", "\x0b", "\x0c", "\x1c", "\x1e", "\x85", "\u2028", "\u2029", "é", "€",
              "\U0001F600", " ", ""]
    for k in range(60):
        text = "".join(rng.choice(pieces) for _ in range(int(rng.integers(0, 25))))
        raw = (b"\xef\xbb\xbf" if k % 3 == 0 else b"") + text.encode("utf-8")
        path = tmp_path / f"t{k}.csv"
        path.write_bytes(raw)
        assert list(dsl._text_lines(path)) == raw.decode("utf-8-sig").splitlines(), repr(text)


def test_precise_path_in_blocks_keeps_the_order_of_its_errors(tmp_path, monkeypatch):
    """Read a few bytes at a time, the precise path still reports a NUL byte or invalid UTF-8 before any bad
    row (wherever they lie), and names the same lines as when the file is read in one piece."""
    rows = good_rows(150)
    bad = list(rows)
    bad[10] = "0.5,0,abc,9.8,0,0,0"
    monkeypatch.setattr(dsf, "BLOCK_BYTES", 7)
    monkeypatch.setattr(dsl, "BLOCK_BYTES", 7)
    p = write_rows(tmp_path / "r.csv", bad)
    with pytest.raises(DataError, match=r"line 12: column f_y: 'abc' is not a number"):
        load_csv(p)
    p.write_bytes(p.read_bytes() + b"0.9,0,0,9.8,0,0,\x00\n")
    with pytest.raises(DataError, match="binary content"):
        load_csv(p)
    p = write_rows(tmp_path / "u.csv", bad)
    p.write_bytes(p.read_bytes() + "0.9,0,0,9.8,0,0,\xe9\n".encode("latin-1"))
    with pytest.raises(DataError, match="not UTF-8"):
        load_csv(p)
    p = write_rows(tmp_path / "t.csv", rows)
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n").replace(b"\r\n", b"\n", 1) + b"\xe2\x80\xa8\r\n")
    rec = load_csv(p)                          # CRLF between blocks, a line separator and a blank line at the end
    np.testing.assert_array_equal(rec.time, np.asarray(rows)[:, 0])


def test_keep_parsed_parses_a_file_once_and_again_when_it_changes(tmp_path, monkeypatch):
    from morpi_filters import dataset as ds

    rows = good_rows()
    path = write_rows(tmp_path / "a.csv", rows)
    parsed = []
    real = dsf.fast_parse
    monkeypatch.setattr(dsl, "fast_parse", lambda p: parsed.append(p) or real(p))
    with ds.keep_parsed():
        first = load_csv(path)
        second = load_csv(path)
        assert len(parsed) == 1 and second.time is first.time
        with pytest.raises(ValueError):
            second.f[0, 0] = 1.0                  # shared arrays are read-only
        # the file rewritten (another size): parsed again, and its new values read
        write_rows(path, rows[:-1])
        third = load_csv(path)
        assert len(parsed) == 2 and third.n == len(rows) - 1
    # outside the block every call parses
    load_csv(path)
    load_csv(path)
    assert len(parsed) == 4
    np.testing.assert_array_equal(first.f, np.asarray(rows)[:, 1:4])


# --------------------------------------------------------------------------- a Recording made in memory

def _memory_recording(time, f=None):
    n = len(time)
    return Recording(time=np.asarray(time, dtype=float), f=np.zeros((n, 3)) if f is None else f,
                     omega=np.zeros((n, 3)), source="<arrays>")


@pytest.mark.parametrize("time, where", [
    ([0.0, 0.01, 0.01, 0.03], "sample 2"),          # a repeated time stamp
    ([0.0, 0.02, 0.01, 0.03], "sample 2"),          # going back
    ([0.0, 0.01, np.nan, 0.03], "sample 2"),        # not a number
    ([0.0, 0.01, 0.02, np.inf], "sample 3"),
])
def test_a_recording_in_memory_refuses_bad_time(time, where):
    with pytest.raises(DataError, match=f"<arrays>: time of {where}") as err:
        _memory_recording(time)
    assert "np." not in str(err.value)                              # plain numbers, not numpy's reprs


def test_a_recording_in_memory_refuses_non_finite_readings():
    f = np.zeros((4, 3))
    f[1, 2] = np.nan
    with pytest.raises(DataError, match=r"<arrays>: f of sample 1 is \[0\.0, 0\.0, nan\], expected finite"):
        _memory_recording([0.0, 0.01, 0.02, 0.03], f)
    assert _memory_recording([0.0, 0.01, 0.02, 0.03]).n == 4       # the same arrays, finite: accepted


def test_a_dataset_root_that_does_not_exist_is_an_error(tmp_path):
    with pytest.raises(DataError, match="not a directory"):
        catalogue(tmp_path / "nowhere")
    assert catalogue(tmp_path) == []                                  # an empty folder is a dataset of none


# ----------------------------------------------------------------- plausibility at rest

from morpi_filters import dataset as ds  # noqa: E402


def _phone_at_rest_then_turning(seed=3, n=700, lead=None):
    """A noisy recording built here from known truth: a phone tilted 3 deg about x standing for 3.5 s (gravity
    on +z, datasheet-sized offsets, white noise), then swinging about z at 1 Hz (0.5 rad/s, 29 deg/s) while its y axis
    accelerates. `lead` prepends that many samples of a hand turning the phone (1.5 rad/s about x and z)."""
    rng = np.random.default_rng(seed)
    t = 0.25 + np.cumsum(np.full(n, 0.01) + rng.uniform(-0.001, 0.001, n))
    tilt = np.radians(3.0)
    f = np.tile([0.05, units.G0 * np.sin(tilt) - 0.1, units.G0 * np.cos(tilt) + 0.2], (n, 1))
    w = np.tile([0.012, -0.02, 0.031], (n, 1))
    moving = t > t[0] + 3.5
    f[moving, 1] += 0.5 * np.sin(2 * np.pi * (t[moving] - t[0]))
    w[moving, 2] += 0.5 * np.sin(2 * np.pi * (t[moving] - t[0]))
    f += 0.01 * rng.standard_normal((n, 3))
    w += 0.0015 * rng.standard_normal((n, 3))
    if lead:
        tl = t[0] - 0.01 * np.arange(lead, 0, -1)
        hand = np.sin(np.pi * (tl - tl[0]) / (tl[-1] - tl[0]))[:, None]
        t = np.r_[tl, t]
        f = np.vstack([f[:lead] + 2.0 * hand * [1.0, 1.0, 0.0], f])
        w = np.vstack([w[:lead] + 1.5 * hand * [1.0, 0.0, 1.0], w])
    return Recording(time=t, f=f, omega=w)


def _written(tmp_path, rec, rel="s8/line_dataset/1.csv"):
    path = tmp_path / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    write_csv(path, rec)
    return path


def test_a_phone_at_rest_in_si_units_and_z_up_is_plausible(tmp_path):
    rec = _phone_at_rest_then_turning()
    path = _written(tmp_path, rec)
    assert ds.plausibility_problems(load_csv(path)) == []
    assert catalogue(tmp_path)[0].load().n == rec.n
    problems, n_ok, _ = check_recordings(tmp_path)
    assert n_ok == 1 and not any(str(path) in p for p in problems)


def _swap(a, i, b, j):
    a[:, i], b[:, j] = b[:, j].copy(), a[:, i].copy()


def _mutant(kind):
    rec = _phone_at_rest_then_turning()
    f, w = rec.f.copy(), rec.omega.copy()
    if kind == "dead gyro axis":
        w[:, 1] = 0.0
    elif kind == "stuck accelerometer axis":
        f[:, 0] = f[7, 0]
    elif kind == "accelerometer in g":
        f /= units.G0
    elif kind == "gravity removed":
        f -= np.median(f[:300], axis=0)
    elif kind == "gyro in deg/s":
        w = np.degrees(w)
    elif kind == "gyro in deg/s, no offset":          # only its noise tells: mean rates at rest near zero
        w = np.degrees(w - np.median(w[:300], axis=0))
    elif kind == "f_z and g_x swapped":
        _swap(f, 2, w, 0)
    elif kind == "f_x and g_y swapped on a tilted phone":   # the horizontal specific force read as a rate
        f[:, 0] += units.G0 * np.sin(np.radians(5.0))
        _swap(f, 0, w, 1)
    elif kind == "f_x and f_z swapped":
        f[:, [0, 2]] = f[:, [2, 0]]
    elif kind == "f_y and f_z swapped":
        f[:, [1, 2]] = f[:, [2, 1]]
    elif kind == "z down":                            # turned 180 deg about x: a right-handed z-down frame
        f[:, 1:] *= -1
        w[:, 1:] *= -1
    return Recording(time=rec.time, f=f, omega=w)


@pytest.mark.parametrize("kind, expect", [
    ("dead gyro axis", r"column g_y is all zero in all 700 samples: a dead channel"),
    ("stuck accelerometer axis", r"column f_x is stuck at [-0-9.e]+ in all 700 samples: a dead channel"),
    ("accelerometer in g", r"specific force at rest is 1\.0\d m/s\^2 \(f = .*\), expected \|f\| = 9\.81 \+- 2\.11 "
                           r"m/s\^2: looks like the accelerometer is in g, not m/s\^2"),
    ("gravity removed", r"specific force at rest is 0\.00 m/s\^2 .*: no gravity"),
    ("gyro in deg/s", r"angular rate at rest: mean .* rad/s on g_z .*; noise .*: looks like deg/s, not rad/s"),
    ("gyro in deg/s, no offset", r"angular rate at rest: noise .* rad/s on g_[xyz] \(expected at most 0\.017\d rad/s, "
                                 r"10 times the datasheet noise at \d+ Hz\): looks like deg/s, not rad/s"),
    ("f_z and g_x swapped", r"specific force at rest is 0\.4\d m/s\^2 .*: the gyro columns carry it instead "
                            r"\(\|w\| = 9\.\d+ at rest"),
    ("f_x and g_y swapped on a tilted phone", r"angular rate at rest: mean 0\.9\d+ rad/s on g_y \(expected within "
                                              r"\+-0\.31 rad/s.*specific force under the g_y header"),
    ("f_x and f_z swapped", r"gravity at rest is on f_x \(f = .*\), expected at least 0\.71 of \|f\| on \+f_z"),
    ("f_y and f_z swapped", r"gravity at rest is on f_y .*looks like f_y and f_z swapped"),
    ("z down", r"f_z at rest is -9\.\d+ .*expected \+\|f\| on z .*: a z-down frame"),
])
def test_implausible_recordings_are_named_by_the_loader_and_by_check(tmp_path, kind, expect):
    """Each mutant keeps every documented limit (the plain reader takes it) and is refused by the catalogue's
    loader and listed by `morpi check --data` (the shipped manifest's check, which judges by the folder's IMU),
    one line naming the file and the manifest key that would declare the reading right."""
    path = _written(tmp_path, _mutant(kind))
    load_csv(path)                                          # within the limits: the parser alone accepts it
    with pytest.raises(DataError, match=expect) as ei:
        catalogue(tmp_path)[0].load()
    assert str(ei.value).startswith(f"{path}: ") and "\n" not in str(ei.value)
    with pytest.raises(DataError, match=expect):
        ds.load_recording(path)
    problems, n_ok, _ = check_recordings(tmp_path)
    mine = [p for p in problems if p.startswith(f"{path}: ")]
    assert n_ok == 0 and len(mine) == 1 and "\n" not in mine[0]
    assert f": {_MANIFEST_KEY[kind]}: " in mine[0], mine


#: The manifest key `morpi check --data` names for each mutant: a dead channel is the file's; the units, the
#: columns and the axes are what a manifest would declare otherwise.
_MANIFEST_KEY = {"dead gyro axis": "imu.file", "stuck accelerometer axis": "imu.file", "accelerometer in g": "imu.accel_unit",
                 "gravity removed": "imu.accel_unit", "gyro in deg/s": "imu.gyro_unit",
                 "gyro in deg/s, no offset": "imu.gyro_unit", "f_z and g_x swapped": "imu.columns",
                 "f_x and g_y swapped on a tilted phone": "imu.gyro_unit", "f_x and f_z swapped": "imu.axes",
                 "f_y and f_z swapped": "imu.axes", "z down": "imu.axes"}


def test_a_handling_before_the_rest_is_skipped(tmp_path):
    """A hand turning the phone for the first second (1.5 rad/s) is no rest: the still stretch starts after it,
    and the recording passes; read over the first second, its gyro would exceed the rest bound."""
    rec = _phone_at_rest_then_turning(lead=100)
    i0, i1 = dsp._still_stretch(rec.time, rec.omega)
    assert rec.time[i0] >= rec.time[100] - dsp._STILL_BLOCK_S and rec.time[i1 - 1] < rec.time[100] + 3.5
    assert np.abs(np.median(rec.omega[:100], axis=0)).max() > ds.GYRO_REST_LIMIT_RADPS
    assert ds.plausibility_problems(rec) == []
    _written(tmp_path, rec)
    assert catalogue(tmp_path)[0].load().n == rec.n


def test_a_noise_free_recording_is_not_judged_dead_but_a_noisy_one_is():
    """Without noise on any column at rest (an ideal simulation) a column that never moves proves nothing;
    with noise on the others it is a dead channel."""
    t = np.arange(300) * 0.01
    ideal = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (300, 1)), omega=np.zeros((300, 3)))
    assert ds.plausibility_problems(ideal) == []
    noisy = Recording(time=t, f=ideal.f + 0.01 * np.random.default_rng(0).standard_normal((300, 3)),
                      omega=ideal.omega)
    assert [p.split(": ")[1][:20] for p in ds.plausibility_problems(noisy)] == ["column g_x is all ze",
                                                                                "column g_y is all ze",
                                                                                "column g_z is all ze"]


def test_the_rest_bounds_are_the_datasheet_figures():
    # recomputed from the figures the constants' comments cite: 3 x 60 mg + 3 % of g + 0.05 m/s^2 for the
    # place on Earth; 3 x 6 deg/s per gyro axis; cos 45 deg; 10 x 0.01 deg/s/sqrt(Hz) at the sampling rate
    assert ds.GRAVITY_BAND_MPS2 == pytest.approx(3 * 0.060 * units.G0 + 0.03 * units.G0 + 0.05, rel=1e-12)
    assert ds.GYRO_REST_LIMIT_RADPS == pytest.approx(np.radians(18.0), rel=1e-12)
    assert ds.UP_FRACTION_MIN == pytest.approx(np.sqrt(0.5), rel=1e-12)
    assert ds.GYRO_NOISE_FACTOR * units.MPU6500.gyro_noise * 10 == pytest.approx(np.radians(1.0), rel=1e-12)
    # an accelerometer in g, or without gravity, is far outside the band; so is the smallest gravity on Earth
    assert abs(1.0 - units.G0) > 3 * ds.GRAVITY_BAND_MPS2 and ds.GRAVITY_BAND_MPS2 < units.G0 / 4


@pytest.mark.field
def test_every_field_recording_reads_gravity_and_a_quiet_gyro_at_rest(field_root):
    """The 143 recordings pass with room: at rest |f| - g, the gyro offsets and noise stay well inside the bounds."""
    for e in catalogue(field_root):
        rec = load_csv(e.path)
        assert ds.plausibility_problems(rec) == [], e.relpath
        i0, i1 = dsp._still_stretch(rec.time, rec.omega)
        f = np.median(rec.f[i0:i1], axis=0)
        assert abs(np.linalg.norm(f) - units.G0) < 0.01 * ds.GRAVITY_BAND_MPS2, e.relpath
        assert f[2] / np.linalg.norm(f) > 0.97, e.relpath
        assert np.abs(np.median(rec.omega[i0:i1], axis=0)).max() < 0.2 * ds.GYRO_REST_LIMIT_RADPS, e.relpath


# ----------------------------------------------------------------- other layouts and units (read_columns)

import math

from morpi_filters.dataset import ColumnLayout, read_columns

#: A logger's names for the columns of a recording.
_LOGGER = ("t", "ax", "ay", "az", "gx", "gy", "gz")


def _logger_layout(**kw):
    return ColumnLayout(COLUMNS, _LOGGER, **kw)


def _logger_text(rows, *, preamble=(), extra=True, trailing=True, quote=False, space=", ", crlf=False):
    """A logger's CSV of rows (time, f, omega cells as strings or numbers), written by hand."""
    header = list(_LOGGER) + (["temp"] if extra else [])
    lines = list(preamble) + [space.join(header) + ("," if trailing else "")]
    for r in rows:
        cells = [repr(float(v)) if not isinstance(v, str) else v for v in r] + (["21.5"] if extra else [])
        if quote:
            cells = [f'"{c}"' for c in cells]
        lines.append(space.join(cells) + ("," if trailing else ""))
    return ("\r\n" if crlf else "\n").join(lines) + "\n"


def test_read_columns_converts_units_closed_form(tmp_path):
    # milliseconds, g and deg/s: 1500 ms is 1.5 s, 1 g is 9.80665 m/s^2 (units.G0), 180 deg/s is pi rad/s
    p = tmp_path / "u.csv"
    rows = [[1500 + 10 * k, 0.0, -0.5, 1.0, 180.0, 0.0, -90.0] for k in range(5)]
    p.write_text(_logger_text(rows, extra=False, trailing=False))
    lay = _logger_layout(time_per_s=1e3, factors=(units.G0,) * 3 + (math.pi / 180,) * 3)
    time, f, omega = read_columns(p, lay)
    assert time[0] == 1.5 and time[1] == 1.51
    assert f[0].tolist() == [0.0, -0.5 * 9.80665, 9.80665]
    assert omega[0, 0] == pytest.approx(math.pi, rel=1e-15) and omega[0, 2] == pytest.approx(-math.pi / 2, rel=1e-15)
    # no time column: time is k / rate_hz from 0
    p.write_text(_logger_text([r[1:] for r in rows], extra=False, trailing=False).replace("t, ", "", 1))
    time, f, _ = read_columns(p, ColumnLayout(COLUMNS, (None,) + _LOGGER[1:], rate_hz=120.0, factors=lay.factors))
    assert time.tolist() == [k / 120.0 for k in range(5)] and f[0, 2] == 9.80665


def test_a_loggers_export_reads_the_numbers_of_the_plain_file(tmp_path):
    # a preamble, blanks after commas, a comma ending each line, quoted fields, a column not read, CRLF:
    # the numbers of the same rows written plainly, bit for bit, and the C reader takes the unquoted forms
    rows = [[0.3 + 0.01 * k + 1e-4 * (k % 3), 0.1 * k, -0.2, 9.81, 0.01, -0.02 * k, 1 / 3] for k in range(150)]
    plain = tmp_path / "plain.csv"
    plain.write_text(_logger_text(rows, extra=False, trailing=False, space=","))
    ref = read_columns(plain, _logger_layout())
    variants = {
        "preamble": (dict(preamble=["logger v2.1, unit 7", "started 2024-05-01"]), True),
        "spaces, trailing comma, extra column": (dict(), True),
        "crlf": (dict(crlf=True, preamble=["# exported"]), True),
        "quoted": (dict(quote=True), True),
        "quoted after blanks, no trailing comma": (dict(quote=True, trailing=False), True),
    }
    for label, (kw, fast) in variants.items():
        p = tmp_path / "v.csv"
        p.write_text(_logger_text(rows, **kw))
        lay = _logger_layout(skip_rows=len(kw.get("preamble", ())))
        got = read_columns(p, lay)
        for a, b in zip(got, ref):
            assert np.array_equal(a.view(np.int64), b.view(np.int64)), label
        precise = dsl._parse(p, lay)
        for a, b in zip(precise, ref):
            assert np.array_equal(a.view(np.int64), b.view(np.int64)), label
        assert (dsf.fast_parse(p, lay) is not None) == fast, label


def test_read_columns_checks_the_converted_values(tmp_path):
    lay = _logger_layout(time_per_s=1e3, factors=(1.0,) * 3 + (math.pi / 180,) * 3,
                         units=("m/s^2",) * 3 + ("deg/s",) * 3)
    rows = [[10.0 * k, 0.0, 0.0, 9.8, 0.0, 0.0, 100.0] for k in range(50)]   # 10 ms steps, 100 deg/s
    p = tmp_path / "c.csv"
    p.write_text(_logger_text(rows))
    time, _, omega = read_columns(p, lay)            # 10 ms steps and 100 deg/s are within every limit
    assert time[-1] == 0.49 and omega[0, 2] == pytest.approx(100 * math.pi / 180, rel=1e-15)
    bad = [list(r) for r in rows]
    bad[20][6] = 2200.0                              # above 2000 deg/s * 1.05
    p.write_text(_logger_text(bad))
    with pytest.raises(DataError, match=r"c.csv: line 22: column gz: angular rate 38.39\d* rad/s \(converted from "
                                        r"deg/s\) is beyond \+-36.65 rad/s"):
        read_columns(p, lay)
    bad = [[v + (1500.0 if k >= 30 and j == 0 else 0.0) for j, v in enumerate(r)] for k, r in enumerate(rows)]
    p.write_text(_logger_text(bad))
    with pytest.raises(DataError, match=r"line 32: time gap of 1.51 s after line 31"):
        read_columns(p, lay)


@pytest.mark.parametrize("edit, expect", [
    (lambda ls: ls.__setitem__(8, ls[8].replace(", 21.5,", "")), r"line 9: short row, 7 fields, expected 9"),
    (lambda ls: ls.__setitem__(8, ls[8] + "1,"), r"line 9: long row, 10 fields, expected 9"),
    (lambda ls: ls.__setitem__(8, ls[8].replace("9.8", "")), r"line 9: column az: '' is not a number"),
    (lambda ls: ls.__setitem__(0, "t, ax, ay, accz, gx, gy, gz, temp,"),
     r"line 1: missing column\(s\) 'az'; the header has 't'"),
    (lambda ls: ls.__setitem__(0, "t, ax, ay, az, gx, gy, gz, gz,"), r"line 1: repeated column\(s\) 'gz'"),
])
def test_a_loggers_export_names_its_bad_line(tmp_path, edit, expect):
    rows = [[0.01 * k, 0.0, 0.0, 9.8, 0.0, 0.0, 0.1] for k in range(50)]
    lines = _logger_text(rows).splitlines()
    edit(lines)
    p = tmp_path / "b.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=expect):
        read_columns(p, _logger_layout())


def test_a_column_not_read_may_hold_anything(tmp_path):
    rows = [[0.01 * k, 0.0, 0.0, 9.8, 0.0, 0.0, 0.1] for k in range(50)]
    text = _logger_text(rows).replace("21.5", "ok", 3).replace("21.5", "", 3)
    p = tmp_path / "x.csv"
    p.write_text(text)
    time, f, _ = read_columns(p, _logger_layout())
    assert time.size == 50 and f[0, 2] == 9.8


def test_logger_reader_takes_only_what_the_line_by_line_reading_reads_the_same(tmp_path):
    """Seeded edits of a logger's export: whenever the C reader takes a file, the precise path reads the same
    bits, and when the precise path refuses it, the C reader did not take it."""
    from morpi_filters.errors import DataError as DE

    rng = np.random.default_rng(20260601)
    rows = [[0.01 * k, 0.1, -0.2, 9.8, 0.01, -0.02, 0.3] for k in range(60)]
    base = _logger_text(rows, preamble=["# log"]).splitlines()
    lay = _logger_layout(skip_rows=1, factors=(units.G0,) * 3 + (1.0,) * 3)
    edits = [
        lambda c: c[:-2],                                  # a row without its last field (extra column)
        lambda c: c[:3] + [""] + c[4:],                    # an empty cell read
        lambda c: c[:-2] + [""] + c[-1:],                  # an empty cell not read
        lambda c: c + [""],                                # a long row
        lambda c: [f' "{x.strip()}"' if x else x for x in c],   # quoted after a blank
        lambda c: c[:1] + [" 1e400"] + c[2:],              # infinite after conversion
        lambda c: c[:-2] + ["1,5"] + c[-1:],               # a comma inside a field not read
        lambda c: c[:-2] + ['"1,5"'] + c[-1:],             # the same, quoted
        lambda c: c[:6] + ["40"] + c[7:],                  # beyond the gyro limit
    ]
    taken = 0
    for case in range(250):
        lines = list(base)
        for _ in range(int(rng.integers(1, 3))):
            k = int(rng.integers(2, len(lines)))
            cells = lines[k].split(",")
            kind = int(rng.integers(len(edits) + 2))
            if kind == len(edits):
                lines.insert(k, " " * int(rng.integers(0, 3)))     # a blank line
            elif kind == len(edits) + 1:
                lines[k] = lines[k].replace(", ", ",")
            else:
                lines[k] = ",".join(edits[kind](cells))
        p = tmp_path / f"f{case}.csv"
        p.write_text("\n".join(lines) + "\n")
        fast = dsf.fast_parse(p, lay)
        try:
            precise = dsl._parse(p, lay)
        except DE:
            assert fast is None, case
            continue
        if fast is not None:
            taken += 1
            for a, b in zip(fast, precise):
                assert a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64)), case
    assert taken >= 20, taken


def test_read_columns_of_npy_arrays(tmp_path):
    p = tmp_path / "a.npy"
    data = np.column_stack([np.zeros(10), np.zeros(10), np.ones(10), np.full(10, 90.0), np.zeros(10), np.zeros(10)])
    np.save(p, data.astype(np.float32))
    lay = ColumnLayout(COLUMNS, (None, 0, 1, 2, 3, 4, 5), format="npy", rate_hz=120.0,
                       factors=(units.G0,) * 3 + (math.pi / 180,) * 3)
    time, f, omega = read_columns(p, lay)
    assert time[1] == 1 / 120.0 and f[0, 2] == units.G0 and omega[0, 0] == pytest.approx(math.pi / 2, rel=1e-15)
    data[7, 3] = 2200.0
    np.save(p, data)
    with pytest.raises(DataError, match=r"a.npy: row index 7: column 3: angular rate 38.39\d* rad/s"):
        read_columns(p, lay)
    for content, expect in ((np.zeros(5), r"shape \(5,\), expected 2-D"),
                            (np.zeros((5, 4)), r"no column 4 \(g_y\), 5 \(g_z\)"),
                            (np.zeros((5, 6), dtype=bool), "expected numbers"), (np.zeros((0, 6)), "no rows")):
        np.save(p, content)
        with pytest.raises(DataError, match=expect):
            read_columns(p, lay)
    p.write_text("0,0,9.8,0,0,0\n")
    with pytest.raises(DataError, match="not a .npy array file"):
        read_columns(p, lay)


def test_keep_parsed_keeps_a_file_per_layout(tmp_path):
    from morpi_filters import dataset as ds

    rows = [[10.0 * k, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0] for k in range(20)]
    p = tmp_path / "k.csv"
    p.write_text(_logger_text(rows))
    in_g = _logger_layout(time_per_s=1e3, factors=(units.G0,) * 3 + (1.0,) * 3)
    in_si = _logger_layout(time_per_s=1e3)
    with ds.keep_parsed():
        a, b = read_columns(p, in_g), read_columns(p, in_si)
        assert a[1][0, 2] == units.G0 and b[1][0, 2] == 1.0
        assert read_columns(p, in_g)[1] is a[1]


def test_time_from_first_counts_a_unix_clock_from_its_first_row(tmp_path):
    rows = [[1_700_000_000_000 + 10 * k, 0.0, 0.0, 9.8, 0.0, 0.0, 0.1] for k in range(50)]   # Unix time in ms
    p = tmp_path / "u.csv"
    p.write_text(_logger_text(rows))
    with pytest.raises(DataError, match=r"line 2: column t: 1700000000.0 s is beyond the limit of \+-1e\+08 s"):
        read_columns(p, _logger_layout(time_per_s=1e3))
    lay = _logger_layout(time_per_s=1e3, time_from_first=True)
    time, _, _ = read_columns(p, lay)
    assert time[0] == 0.0 and time[1] == 0.01 and time[-1] == 0.49
    for a, b in zip(dsf.fast_parse(p, lay), dsl._parse(p, lay)):
        assert np.array_equal(a, b)


def test_a_layout_reading_every_column_takes_only_what_the_line_by_line_reading_reads_the_same(tmp_path):
    """Seeded edits of a file whose every column is read (no trailing comma, no column left over): short and
    long rows, empty cells and blank lines; whenever the C reader takes a file, the precise path reads the same
    bits, and when the precise path refuses it, the C reader did not take it."""
    from morpi_filters.errors import DataError as DE

    rng = np.random.default_rng(20261127)
    rows = [[0.01 * k, 0.1, -0.2, 9.8, 0.01, -0.02, 0.3] for k in range(60)]
    base = _logger_text(rows, extra=False, trailing=False).splitlines()
    lay = _logger_layout()
    edits = [
        lambda c: c[:-1],                                  # a short row (the last field read is missing)
        lambda c: c[:2] + c[3:],                           # a short row (a middle field missing)
        lambda c: c[:3] + [""] + c[4:],                    # an empty cell
        lambda c: c + [""],                                # a long row (a trailing comma)
        lambda c: c + [" 1.0"],                            # a long row
        lambda c: [f' "{x.strip()}"' for x in c],          # quoted after a blank
        lambda c: c[:-1] + [" "],                          # a blank last cell
    ]
    taken = refused = 0
    for case in range(200):
        lines = list(base)
        for _ in range(int(rng.integers(1, 3))):
            k = int(rng.integers(1, len(lines)))
            kind = int(rng.integers(len(edits) + 1))
            if kind == len(edits):
                lines.insert(k, " " * int(rng.integers(0, 3)))     # a blank line
            else:
                lines[k] = ",".join(edits[kind](lines[k].split(",")))
        p = tmp_path / f"f{case}.csv"
        p.write_text("\n".join(lines) + "\n")
        fast = dsf.fast_parse(p, lay)
        try:
            precise = dsl._parse(p, lay)
        except DE:
            refused += 1
            assert fast is None, case
            continue
        if fast is not None:
            taken += 1
            for a, b in zip(fast, precise):
                assert a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64)), case
    assert taken >= 20 and refused >= 20, (taken, refused)
