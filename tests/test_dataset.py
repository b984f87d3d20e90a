"""The loader, its validation, and the catalogue of the MoRPI layout."""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import MorpiError
from morpi_filters.dataset import (
    COLUMNS, Recording, catalogue, check_tree, layout, load_csv, resolve_data_root, route, write_csv,
)
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
    problems, n_ok = check_tree(field_root)
    assert problems == [] and n_ok == 143
    rec = entries[0].load()
    # A level phone at rest reads about +g on z (README): first 0.5 s.
    fz = rec.f[rec.time < rec.time[0] + 0.5, 2].mean()
    assert 9.3 < fz < 10.3
