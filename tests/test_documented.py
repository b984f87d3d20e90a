"""Entry points return what their docstrings promise (keys, tuple shapes)."""
from __future__ import annotations

import numpy as np

from morpi_filters import simulate, steps, symbolic, units


def test_closed_form_errors_takes_the_documented_keys():
    params = {"dv0_mps": [0.01] * 3, "ba_mps2": [0.02] * 3, "bg_radps": [1e-3] * 3, "g_mps2": 9.81}
    t = np.array([0.0, 1.0, 2.0])
    assert symbolic.closed_form_errors(params, t, "3d").shape == (3,)
    assert symbolic.closed_form_errors(params, t, "dp").shape == (3, 3)
    assert symbolic.closed_form_errors(params, t, "dp2d").shape == (3, 2)


def test_train_gain_returns_a_flat_triple():
    rng = np.random.default_rng(0)
    traj = simulate.sine(6.3, period=1.0, amplitude=0.1, rate_hz=100.0)
    data = simulate.imu(traj, units.LSM6DSL, rng, bias_scale=(0.0, 0.0))
    s = steps.extract_steps(data.recording(), "MoRPI-G", steps.DEFAULT_CONFIGS["MoRPI-G"])
    out = steps.train_gain([s, s], [6.3, 6.3])
    mean, std, per_run = out
    assert len(out) == 3 and isinstance(mean, float) and isinstance(std, float)
    assert per_run.shape == (2,) and std == 0.0 and mean == per_run[0]



def test_no_two_public_functions_share_a_name():
    """A function name exported by two modules is one function (one vocabulary across the package)."""
    import importlib
    import inspect
    import pkgutil

    import morpi_filters

    seen = {}
    for info in pkgutil.walk_packages(morpi_filters.__path__, "morpi_filters."):
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name, None)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                other = seen.setdefault(name, (info.name, obj))
                assert other[1] is obj, f"{name}: {other[0]} and {info.name} define different things"


def test_a_recording_by_path_knows_its_labels_and_truth(tmp_path):
    import warnings

    import pytest

    from morpi_filters import dataset as ds

    t = np.arange(300) * 0.01
    rec = ds.Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (300, 1)), omega=np.zeros((300, 3)), source="x")
    inside = tmp_path / "s6" / "L_shape" / "test" / "3.csv"
    inside.parent.mkdir(parents=True)
    ds.write_csv(inside, rec)
    got, truth = ds.load_recording(inside)
    assert (got.phone, got.route, got.split) == ("s6", "L_shape", "test") and truth.name == "L_shape"
    outside = tmp_path / "mine.csv"
    ds.write_csv(outside, rec)
    with pytest.warns(UserWarning, match="not in the MoRPI layout"):
        got, truth = ds.load_recording(outside)
    assert got.phone is None and truth is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds.load_recording(inside)


def test_a_track_measures_its_error_against_a_route():
    from morpi_filters import dataset as ds

    traj = simulate.sine(6.3, period=1.0, amplitude=0.1, rate_hz=100.0)
    data = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(1), bias_scale=(0.0, 0.0))
    s = steps.extract_steps(data.recording(), "MoRPI-G", steps.DEFAULT_CONFIGS["MoRPI-G"])
    track = steps.morpi_track(s, 1.0)
    truth = ds.route("short_distance")
    assert track.error(truth) == track.error("short_distance")
    assert track.error(truth) == float(np.hypot(*(track.end_point - truth.end_point_m)))
