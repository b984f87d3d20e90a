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
