"""The shared parameter file: every malformed case gets one clear message."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from morpi_filters import MorpiError
from morpi_filters.params import load_params, params_from_dict

GOOD = {"dv0_mps": [0.1, 0.2, 0.0], "accel_bias_mps2": [0.01, 0.02, 0.03], "gyro_bias_radps": [1e-3, 2e-3, 3e-3], "g_mps2": 9.81}


def test_good_file(tmp_path):
    p = tmp_path / "p.json"
    p.write_text(json.dumps(GOOD | {"dG": [0.1], "process_noise": True}))
    par = load_params(p)
    np.testing.assert_array_equal(par.ba, GOOD["accel_bias_mps2"])
    assert par.dG == (0.1,) and par.process_noise is True and par.g == 9.81


@pytest.mark.parametrize("patch, expect", [
    ({"g_mps2": None}, "key 'g_mps2'"),
    ({"g_mps2": -9.8}, "must be a positive gravity"),
    ({"accel_bias_mps2": [1, 2]}, "key 'accel_bias_mps2': expected a list of 3 numbers, got length 2"),
    ({"gyro_bias_radps": [1, "x", 2]}, r"key 'gyro_bias_radps\[1\]': 'x' is not a finite number"),
    ({"dG": []}, "key 'dG'"),
    ({"process_noise": "yes"}, "key 'process_noise'"),
    ({"morpi_speed_mps": 0}, "must be positive"),
])
def test_bad_values(patch, expect):
    with pytest.raises(MorpiError, match=expect):
        params_from_dict(GOOD | patch, "f.json")


def test_missing_key_and_bad_json(tmp_path):
    d = dict(GOOD)
    del d["dv0_mps"]
    with pytest.raises(MorpiError, match="missing key.*dv0_mps"):
        params_from_dict(d, "f.json")
    p = tmp_path / "bad.json"
    p.write_text("{\n  \"g_mps2\": ,\n}")
    with pytest.raises(MorpiError, match=r"bad.json: line 2: not valid JSON"):
        load_params(p)
    with pytest.raises(MorpiError, match="no such parameter file"):
        load_params(tmp_path / "none.json")


# ----------------------------------------------------------------- schema: unknown keys, bounds, hostile JSON

from morpi_filters import params as P
from morpi_filters import units
from morpi_filters.errors import ParameterError


def test_bounds_have_their_stated_sources():
    # about 17 times the larger datasheet offsets of the two IMUs (units.MPU6500): 60 mg and 6 deg/s
    assert P.BA_MAX_MPS2 == pytest.approx(units.MPU6500.accel_bias * 1000 / 60, rel=1e-12)
    assert P.BG_MAX_RADPS == pytest.approx(units.MPU6500.gyro_bias * 100 / 6, rel=1e-12)
    # Earth's surface gravity, 9.780 (equator) to 9.832 (poles) m/s^2, inside the accepted range
    assert P.G_MIN_MPS2 < 9.780 and 9.832 < P.G_MAX_MPS2


@pytest.mark.parametrize("patch, key, expect", [
    ({"accel_bias_mps2": [1e300, 0, 0]}, r"accel_bias_mps2\[0\]", r"beyond the physical bound \+-9.807 m/s\^2"),
    ({"accel_bias_mps2": [0, -10.0, 0]}, r"accel_bias_mps2\[1\]", "beyond the physical bound"),
    ({"gyro_bias_radps": [0, 0, 2.0]}, r"gyro_bias_radps\[2\]", r"beyond the physical bound \+-1.745 rad/s"),
    ({"dv0_mps": [11.0, 0, 0]}, r"dv0_mps\[0\]", r"\+-10 m/s"),
    ({"dG": [0.05, 1.5]}, r"dG\[1\]", "beyond the physical bound"),
    ({"dG": [0.01] * 21}, "dG", "at most 20"),
    ({"g_mps2": 1e300}, "g_mps2", "between 9.7 and 9.9"),
    ({"g_mps2": 1.62}, "g_mps2", "between 9.7 and 9.9"),
    ({"morpi_speed_mps": 1e6}, "morpi_speed_mps", "at most 10 m/s"),
    ({"accel_bias_mps2": [10 ** 400, 0, 0]}, r"accel_bias_mps2\[0\]", "an integer of 401 digits is not a finite number"),
    ({"accel_bias_mps2": [[0.1], 0, 0]}, r"accel_bias_mps2\[0\]", "not a finite number"),
    ({"accel_bias_mps2": [True, 0, 0]}, r"accel_bias_mps2\[0\]", "not a finite number"),
    ({"g_mps2": "9.81"}, "g_mps2", "not a finite number"),
    ({"note": 3}, "note", "expected a text string"),
    ({"bogus": 1}, None, r"unknown key\(s\) 'bogus'; expected only"),
    ({"times": [1e6]}, None, "time grids and run counts are command-line options"),
    ({"runs": 10 ** 7}, None, r"unknown key\(s\) 'runs'"),
])
def test_schema_rejects_with_one_line(patch, key, expect):
    with pytest.raises(ParameterError, match=expect) as ei:
        params_from_dict(GOOD | patch, "f.json")
    msg = str(ei.value)
    assert msg.startswith("f.json: ") and "\n" not in msg and len(msg) < 400
    if key:
        assert re.search(f"key '{key}'", msg)


@pytest.mark.parametrize("text, expect", [
    ('{"g_mps2": NaN}', "NaN is not a finite number"),
    ('{"g_mps2": Infinity}', "Infinity is not a finite number"),
    (json.dumps(GOOD).replace("9.81", "1e400"), "key 'g_mps2': inf is not a finite number"),
    ('{"g_mps2": 9.81, "g_mps2": 9.8}', "key 'g_mps2' appears twice"),
    ("[" * 20000 + "]" * 20000, "nested too deeply"),
    ('{"g_mps2": ' + "9" * 5000 + "}", "digits"),
    ("\ufeff" + json.dumps(GOOD), None),
])
def test_hostile_json_is_one_line(tmp_path, text, expect):
    p = tmp_path / "p.json"
    p.write_text(text)
    if expect is None:   # a UTF-8 byte-order mark is accepted
        assert load_params(p).g == 9.81
        return
    with pytest.raises(ParameterError, match=expect) as ei:
        load_params(p)
    assert str(p) in str(ei.value) and "\n" not in str(ei.value)


def test_oversized_and_binary_files(tmp_path):
    p = tmp_path / "big.json"
    p.write_text(json.dumps(GOOD | {"note": "x" * 100000}))
    with pytest.raises(ParameterError, match="larger than 64 kB"):
        load_params(p)
    p.write_bytes(b"\xff\xfe{}")
    with pytest.raises(ParameterError, match="not UTF-8"):
        load_params(p)


def test_committed_file_passes_the_schema():
    par = load_params()
    assert par.g == 9.81 and abs(par.ba).max() < P.BA_MAX_MPS2


def test_cli_assess_rejects_a_huge_bias_with_exit_2(tmp_path, capsys):
    from morpi_filters.cli import main

    p = tmp_path / "p.json"
    p.write_text(json.dumps(GOOD | {"accel_bias_mps2": [1e300, 0, 0]}))
    out = tmp_path / "rep"
    assert main(["assess", "--params", str(p), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "accel_bias_mps2[0]" in err[0] and not out.exists()
