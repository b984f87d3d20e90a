"""Renamed names keep working for one release: old keywords and attributes warn, old JSON keys ride along."""
from __future__ import annotations

import warnings

import pytest

from morpi_filters.deprecation import renamed_attribute, renamed_keywords, with_aliases
from morpi_filters.errors import ParameterError


def _old_keyword(func, old, new, *args, **kwargs):
    """func(*args, old=value) and func(*args, new=value): (old result, new result, the warnings of the old call)."""
    value = kwargs.pop("value")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got_old = func(*args, **kwargs, **{old: value})
    got_new = func(*args, **kwargs, **{new: value})
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    return got_old, got_new, deprecations


def test_an_old_keyword_is_passed_on_under_its_new_name_with_a_warning():
    @renamed_keywords(speed="speed_mps")
    def travel(seconds, *, speed_mps=1.0):
        return seconds * speed_mps

    old, new, caught = _old_keyword(travel, "speed", "speed_mps", 2.0, value=3.0)
    assert old == new == 6.0
    assert len(caught) == 1 and "speed_mps=" in str(caught[0].message) and "travel" in str(caught[0].message)
    assert caught[0].filename == __file__            # the warning points at the caller
    with pytest.raises(ParameterError, match="both speed= and speed_mps="):
        travel(1.0, speed=1.0, speed_mps=2.0)


def test_an_old_attribute_reads_the_new_one_with_a_warning():
    class Walk:
        speed_mps = 1.5
        speed = renamed_attribute("Walk", "speed", "speed_mps")

    with pytest.warns(DeprecationWarning, match="Walk.speed_mps"):
        assert Walk().speed == 1.5


def test_an_old_json_key_follows_its_new_key_with_the_same_value():
    out = with_aliases({"a": 1, "speed_mps": [0.5], "b": 2}, {"speed_m_s": "speed_mps", "gone": "absent"})
    assert list(out) == ["a", "speed_mps", "speed_m_s", "b"]
    assert out["speed_m_s"] is out["speed_mps"]


# --------------------------------------------------------------------------- the renamed public names

def _same_trajectory(a, b):
    import numpy as np

    return (a.kind == b.kind and a.p2p_m == b.p2p_m and a.amplitude_m == b.amplitude_m
            and np.array_equal(a.time, b.time) and np.array_equal(a.position, b.position))


@pytest.mark.parametrize("func, args, old, new, value", [
    ("straight", (6.3,), "speed", "speed_mps", 1.2),
    ("straight", (), "length", "length_m", 5.0),
    ("sine", (), "length", "length_m", 5.0),
    ("sine", (6.3,), "speed", "speed_mps", 0.5),
    ("sine", (6.3,), "period", "p2p_m", 1.5),
    ("sine", (6.3,), "amplitude", "amplitude_m", 0.15),
    ("l_route", (), "speed", "speed_mps", 0.7),
    ("route_trajectory", ("short_distance",), "speed", "speed_mps", 0.5),
    ("route_trajectory", ("short_distance",), "period", "p2p_m", 1.5),
    ("route_trajectory", ("short_distance",), "amplitude", "amplitude_m", 0.15),
    ("straight", (6.3,), "ramp", "ramp_s", 0.8),
    ("straight", (6.3,), "rest", "rest_s", 1.5),
    ("sine", (6.3,), "ramp", "ramp_s", 0.8),
    ("sine", (6.3,), "rest", "rest_s", (1.0, 2.0)),
    ("sine", (6.3,), "taper", "taper_m", 1.5),
    ("l_route", (), "turn_radius", "turn_radius_m", 1.5),
    ("l_route", (), "rest", "rest_s", 1.0),
    ("route_trajectory", ("short_distance",), "ramp", "ramp_s", 0.8),
])
def test_the_simulators_take_their_old_keywords_with_a_warning(func, args, old, new, value):
    from morpi_filters import simulate

    got_old, got_new, caught = _old_keyword(getattr(simulate, func), old, new, *args, value=value, rate_hz=50.0)
    assert _same_trajectory(got_old, got_new)
    assert len(caught) == 1 and f"use {new}=" in str(caught[0].message)


def test_l_route_takes_its_old_sine_keywords_and_paper_speed_its_old_period():
    from morpi_filters import simulate

    with pytest.warns(DeprecationWarning, match="use p2p_m="):
        old = simulate.l_route(period=1.0, amplitude_m=0.1, rate_hz=50.0)
    assert _same_trajectory(old, simulate.l_route(p2p_m=1.0, amplitude_m=0.1, rate_hz=50.0))
    old, new, caught = _old_keyword(simulate.l_route, "slope_length", "slope_length_m", slope_deg=10.0, rate_hz=50.0,
                                    value=4.0)
    assert _same_trajectory(old, new) and len(caught) == 1
    got_old, got_new, caught = _old_keyword(simulate.paper_speed, "period", "p2p_m", value=1.5)
    assert got_old == got_new == simulate.paper_speed(1.5) and len(caught) == 1


def test_a_trajectory_reads_its_old_period_and_amplitude_with_a_warning():
    from morpi_filters import simulate

    traj = simulate.sine(6.3, p2p_m=1.5, amplitude_m=0.2, rate_hz=50.0)
    with pytest.warns(DeprecationWarning, match="Trajectory.p2p_m"):
        assert traj.period == traj.p2p_m == 1.5
    with pytest.warns(DeprecationWarning, match="Trajectory.amplitude_m"):
        assert traj.amplitude == traj.amplitude_m == 0.2


def test_a_study_config_takes_and_reads_its_old_period_and_its_json_repeats_it():
    from morpi_filters import montecarlo as mc
    from morpi_filters.montecarlo.pages import study_config_json

    got_old, got_new, caught = _old_keyword(mc.StudyConfig, "period_m", "p2p_m", value=1.5, duration_s=20.0)
    assert got_old == got_new and got_old.p2p_m == 1.5 and len(caught) == 1
    assert "StudyConfig: the keyword period_m=" in str(caught[0].message)
    with pytest.warns(DeprecationWarning, match="StudyConfig.p2p_m"):
        assert got_new.period_m == 1.5
    out = study_config_json(got_new)
    assert out["period_m"] == out["p2p_m"] == 1.5


def _equal(a, b):
    import numpy as np

    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if hasattr(a, "__dataclass_fields__"):
        return all(_equal(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    return np.array_equal(np.asarray(a), np.asarray(b))


def test_the_time_step_keywords_take_their_old_names_with_a_warning():
    import numpy as np

    from morpi_filters.curves import time_grid
    from morpi_filters.error_model import discretize, simulate_linear

    F, G, Q = [[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0]]
    for func, args, kw in [(discretize, (F, G, Q), {}),
                           (simulate_linear, (F, G, Q, np.eye(2)), dict(n_steps=3, runs=2, rng=None)),
                           (time_grid, ([0.5, 1.0],), dict(step_period_s=0.4))]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got_old = func(*args, dt=0.3, **{k: (np.random.default_rng(1) if k == "rng" else v) for k, v in kw.items()})
        got_new = func(*args, dt_s=0.3, **{k: (np.random.default_rng(1) if k == "rng" else v) for k, v in kw.items()})
        assert _equal(got_old, got_new), func.__name__
        assert [str(w.message).endswith("use dt_s=") for w in caught] == [True], func.__name__
    old, new, caught = _old_keyword(time_grid, "step_period", "step_period_s", [0.5, 1.0], 0.3, value=0.4)
    assert _equal(old, new) and new[1].tolist() == [2, 5] and len(caught) == 1


def test_the_speed_keywords_of_the_step_models_take_their_old_name_with_a_warning():
    import numpy as np

    from morpi_filters.curves import CurveCase, error_realisation
    from morpi_filters.eskf import StepModel, simulate_steps, step_update

    old, new, caught = _old_keyword(step_update, "speed", "speed_mps", 10, 1.0, 0.0, StepModel(), value=2.0)
    assert _equal(old, new) and len(caught) == 1
    X = np.zeros((2, 20, 15))
    old, new, caught = _old_keyword(lambda **kw: simulate_steps(X, [2], 1.0, 0.0, StepModel(), gain=np.zeros(2),
                                                                rng=np.random.default_rng(0), **kw),
                                    "speed", "speed_mps", value=2.0)
    assert _equal(old, new) and len(caught) == 1
    args = ([0.03, 0.04, 0.0], [0.0] * 3, [0.0] * 3, 0.1, 9.81)
    old, new, caught = _old_keyword(error_realisation, "speed", "speed_mps", *args, t=[0.0, 2.0], kind="INS-2D",
                                    value=0.5)
    assert _equal(old, new) and len(caught) == 1
    fields = dict(name="x", title="x", dv0=np.zeros(3), ba=np.zeros(3), bg=np.zeros(3), g=9.81, gain_sigma=0.1)
    old, new, caught = _old_keyword(CurveCase, "speed", "speed_mps", **fields, value=0.5)
    assert _equal(old, new) and new.speed_mps == 0.5 and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="CurveCase.speed_mps"):
        assert new.speed == 0.5


def test_the_aided_filter_takes_its_old_epoch_keyword_with_a_warning():
    import numpy as np

    from morpi_filters.aided import AidedInput, AidTuning, run_batch

    t = np.arange(301) * 0.01
    still = AidedInput(time=t, f=np.tile([0.0, 0.0, 9.8], (301, 1)), omega=np.zeros((301, 3)), C0=np.eye(3),
                       g=9.8, rest=((0.0, 3.0),))
    old, new, caught = _old_keyword(run_batch, "epoch_s", "dt_s", [still], AidTuning(), value=0.2)
    assert _equal(old[0].end_point, new[0].end_point) and _equal(old[0].P_xy, new[0].P_xy) and len(caught) == 1


def test_a_calibration_takes_and_reads_its_old_mode_name_with_a_warning():
    import numpy as np

    from morpi_filters import calibration as cal
    from morpi_filters.dataset import Recording

    rec = Recording(time=np.arange(400) * 0.01, f=np.tile([0.0, 0.05, 9.9], (400, 1)),
                    omega=np.tile([0.001, 0.0, -0.002], (400, 1)))
    for func in (cal.calibrate, lambda *a, **k: cal.calibrated(*a, **k)[1]):
        old, new, caught = _old_keyword(func, "mode", "calibration", rec, value="GAC")
        assert _equal(old, new) and new.calibration == "GAC" and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="Calibration.calibration"):
        assert new.mode == "GAC"
    old, new, caught = _old_keyword(cal.Calibration, "mode", "calibration", gyro_bias=np.zeros(3),
                                    accel_bias=np.zeros(3), window=None, value="RD")
    assert _equal(old, new) and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="CALIBRATIONS"):
        assert cal.MODES == cal.CALIBRATIONS == ("RD", "GC", "GAC")


def test_the_tables_json_names_each_folds_accel_floor_with_its_unit_and_keeps_the_old_key():
    from types import SimpleNamespace

    from morpi_filters.report.tables import result_json

    folds = [{"file": "s6/a/train/1.csv", "accel_floor": 0.094, "min_swing_deg": 12.0},
             {"file": "s6/a/train/2.csv", "accel_floor": 0.093, "min_swing_deg": 11.0}]
    result = SimpleNamespace(missing=(), cells=(), gains=(), selections={}, readings=(), data=None)
    study = SimpleNamespace(result=result, comparison=None, ins_full_span=None, other_rule=None,
                            nested={"folds": folds, "preferred": "x"}, rule_sensitivity=None, ins_leveled=None,
                            claims=(), heading_readings=None, turn_reading=None)
    out = result_json(study)["step_rule_nested"]
    assert out["preferred"] == "x" and len(out["folds"]) == 2
    for f, given in zip(out["folds"], folds):
        assert list(f) == ["file", "accel_floor_mps2", "accel_floor", "min_swing_deg"]
        assert f["accel_floor_mps2"] == f["accel_floor"] == given["accel_floor"]


def test_a_parameter_file_with_the_old_bias_keys_reads_as_the_new_ones_with_a_warning(tmp_path):
    import json

    import numpy as np

    from morpi_filters.params import load_params, params_from_dict

    new = {"dv0_mps": [0.1, 0.2, 0.0], "accel_bias_mps2": [0.01, 0.02, 0.03], "gyro_bias_radps": [1e-3, 2e-3, 3e-3],
           "g_mps2": 9.81}
    old = {"dv0_mps": new["dv0_mps"], "ba_mps2": new["accel_bias_mps2"], "bg_radps": new["gyro_bias_radps"],
           "g_mps2": 9.81}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = load_params(path)
    messages = sorted(str(w.message) for w in caught if issubclass(w.category, DeprecationWarning))
    assert len(messages) == 2 and "use 'accel_bias_mps2'" in messages[0] and "use 'gyro_bias_radps'" in messages[1]
    assert str(path) in messages[0]
    want = params_from_dict(new)
    assert np.array_equal(got.ba, want.ba) and np.array_equal(got.bg, want.bg)
    with pytest.raises(ParameterError, match="both keys 'bg_radps' and 'gyro_bias_radps'"):
        params_from_dict(new | {"bg_radps": [0.0] * 3})


def test_the_pages_take_their_old_source_keyword_with_a_warning(tmp_path):
    from morpi_filters.report.common import banner
    from morpi_filters.report.index import index_page
    from morpi_filters.results import DataSource

    src = DataSource(root=None, synthetic=True, seed=0)
    for func, args in ((banner, ()), (index_page, ([],))):
        old, new, caught = _old_keyword(func, "source", "data_source", *args, value=src)
        assert old == new and "Synthetic" in new and len(caught) == 1


@pytest.mark.parametrize("where, name", [
    ("morpi_filters.curves", "curves_study"), ("morpi_filters.montecarlo", "gain_error_page"),
    ("morpi_filters.report.aided", "report_aided"), ("morpi_filters.report.tables", "report_tables"),
    ("morpi_filters.report.tables", "result_json"), ("morpi_filters.report.montecarlo", "report_montecarlo"),
    ("morpi_filters.report.curves", "report_curves"),
])
def test_the_studies_and_pages_know_their_old_source_keyword(where, name):
    """Each takes source= as data_source= (given both, it refuses before computing anything)."""
    import importlib
    import inspect

    func = getattr(importlib.import_module(where), name)
    assert "data_source" in inspect.signature(func).parameters
    with pytest.raises(ParameterError, match="both source= and data_source="):
        func(source=None, data_source=None)


def test_a_still_bound_takes_and_reads_its_old_source_name_with_a_warning():
    from morpi_filters.calibration import StillBound

    old, new, caught = _old_keyword(StillBound, "source", "basis", gyro=0.01, accel=0.1, value="datasheet x 4")
    assert old == new and new.basis == "datasheet x 4" and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="StillBound.basis"):
        assert new.source == "datasheet x 4"


def test_the_old_cli_flags_are_hidden_aliases_of_the_new(capsys):
    import argparse
    from pathlib import Path

    from morpi_filters.cli import build_parser

    p = build_parser()
    # each old flag is an option of its own (not only a prefix argparse completes), writing the new one's value
    sub = {a.dest: a for a in p._actions if a.dest == "command"}["command"].choices
    fetch = {a.dest: a for a in sub["data"]._actions if a.dest == "data_command"}["data_command"].choices["fetch"]
    for parser, old_flag, dest in ((sub["montecarlo"], "--duration", "duration_s"),
                                   (sub["montecarlo"], "--speed", "speed_mps"), (fetch, "--dest", "out")):
        action = parser._option_string_actions.get(old_flag)
        assert action is not None and action.dest == dest and action.help == argparse.SUPPRESS, old_flag
    old = p.parse_args(["montecarlo", "--duration", "20", "--speed", "0.5"])
    new = p.parse_args(["montecarlo", "--duration-s", "20", "--speed-mps", "0.5"])
    assert vars(old) == vars(new) and new.duration_s == 20.0 and new.speed_mps == 0.5
    assert p.parse_args(["data", "fetch", "--dest", "d"]).out == p.parse_args(["data", "fetch", "--out", "d"]).out \
        == Path("d")
    for argv, shown, hidden in ((["montecarlo", "--help"], ("--duration-s", "--speed-mps"), ("--duration ", "--speed ")),
                                (["data", "fetch", "--help"], ("--out",), ("--dest",))):
        with pytest.raises(SystemExit):
            p.parse_args(argv)
        text = capsys.readouterr().out
        assert all(s in text for s in shown) and not any(h in text for h in hidden), text


def test_the_montecarlo_names_of_a_duration_and_a_calibration_window_take_their_old_names_with_a_warning():
    from morpi_filters import montecarlo as mc

    old, new, caught = _old_keyword(mc.StudyConfig, "duration", "duration_s", value=20.0)
    assert old == new and new.motion()[2] == 20.0 and len(caught) == 1
    old, new, caught = _old_keyword(mc.StudyConfig, "cal_seconds", "cal_window_s", value=4.0)
    assert old == new and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="StudyConfig.duration_s"):
        assert mc.StudyConfig(duration_s=20.0).duration == 20.0
    with pytest.warns(DeprecationWarning, match="StudyConfig.cal_window_s"):
        assert new.cal_seconds == 4.0
    old, new, caught = _old_keyword(mc.page_cost, "duration", "duration_s", 100, value=60.0)
    assert old == new and new.duration_s == 60.0 and len(caught) == 1
    with pytest.warns(DeprecationWarning, match="PageCost.duration_s"):
        assert new.duration == 60.0
    from morpi_filters.montecarlo.engine import sample_count

    old, new, caught = _old_keyword(sample_count, "duration", "duration_s", rate_hz=100.0, value=2.0)
    assert old == new == 201 and len(caught) == 1
    with pytest.raises(ParameterError, match="both duration= and duration_s="):
        mc.gain_error_page(runs=1, seed=0, duration=20.0, duration_s=20.0)
    with pytest.raises(ParameterError, match="both duration= and duration_s="):
        mc.drift_map(duration=2.0, duration_s=2.0)
    from morpi_filters.montecarlo.pages import study_config_json

    out = study_config_json(mc.StudyConfig(cal_window_s=4.0))
    assert out["cal_seconds"] == out["cal_window_s"] == 4.0


def test_fetch_takes_its_old_destination_keyword():
    from morpi_filters.fetch import fetch_dataset

    with pytest.raises(ParameterError, match="both dest= and out="):
        fetch_dataset(dest="a", out="a")


def test_the_morpi_sites_latitude_and_gravity_still_read_from_calibration_with_a_warning():
    from morpi_filters import calibration

    with pytest.warns(DeprecationWarning, match="MoRPI manifest's latitude_deg"):
        assert calibration.SITE_LATITUDE_DEG == 32.8
    with pytest.warns(DeprecationWarning, match="MoRPI manifest's latitude_deg"):
        assert calibration.LOCAL_GRAVITY == calibration.normal_gravity(32.8)


def test_a_recordings_route_truth_still_reads_with_a_warning():
    import numpy as np

    from morpi_filters.dataset import Recording, route

    t = np.arange(200) * 0.01
    rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (200, 1)), omega=np.zeros((200, 3)), route="L_shape")
    with pytest.warns(DeprecationWarning, match="DatasetRecording.truth"):
        assert rec.ground_truth is route("L_shape")
