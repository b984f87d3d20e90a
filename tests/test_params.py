"""The shared parameter file: every malformed case gets one clear message."""
from __future__ import annotations

import json

import numpy as np
import pytest

from morpi_filters import MorpiError
from morpi_filters.params import load_params, params_from_dict

GOOD = {"dv0_mps": [0.1, 0.2, 0.0], "ba_mps2": [0.01, 0.02, 0.03], "bg_radps": [1e-3, 2e-3, 3e-3], "g_mps2": 9.81}


def test_good_file(tmp_path):
    p = tmp_path / "p.json"
    p.write_text(json.dumps(GOOD | {"dG": [0.1], "process_noise": True}))
    par = load_params(p)
    np.testing.assert_array_equal(par.ba, GOOD["ba_mps2"])
    assert par.dG == (0.1,) and par.process_noise is True and par.g == 9.81


@pytest.mark.parametrize("patch, expect", [
    ({"g_mps2": None}, "key 'g_mps2'"),
    ({"g_mps2": -9.8}, "must be a positive gravity"),
    ({"ba_mps2": [1, 2]}, "key 'ba_mps2': expected a list of 3 numbers, got length 2"),
    ({"bg_radps": [1, "x", 2]}, r"key 'bg_radps\[1\]': 'x' is not a finite number"),
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
