"""Tests of the covariance-curves section: contract, closed-form agreement, CLI, bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from morpi_filters import units
from morpi_filters.cli import main
from morpi_filters.curves import (
    DEFAULT_TIMES, MC_SEED, case_from_params, case_from_sensor, case_mean_square, error_realisation,
    compute_curves, curves_study, horizontal_sigma, time_grid,
)
from morpi_filters.errors import MorpiError, ParameterError
from morpi_filters.params import params_from_dict
from morpi_filters.report.curves import report_curves

PARAMS = {"dv0_mps": [0.06, 0.03, 0.02], "accel_bias_mps2": [0.08, 0.03, 0.03], "gyro_bias_radps": [0.002, 0.003, 0.004],
          "g_mps2": 9.81, "dG": [0.05, 0.10], "morpi_speed_mps": 0.5}


def _write(tmp_path, **over):
    p = tmp_path / "params.json"
    p.write_text(json.dumps({**PARAMS, **over}))
    return p


def test_time_grid_contains_requested_and_step_times():
    grid, steps, at = time_grid([0.0, 2.5, 3.333], 0.01, 0.7)
    assert grid[0] == 0.0 and grid[-1] == pytest.approx(3.333)  # pytest's default 1e-6 relative; the grid ends at the requested time up to rounding
    assert np.allclose(grid[at], [0.0, 2.5, 3.333])  # requested times are inserted exactly; default tolerances cover the grid's rounding
    assert np.allclose(grid[steps], 0.7 * np.arange(1, 5))  # step times 0.7 k are inserted exactly; default tolerances cover the grid's rounding
    assert np.all(np.diff(grid) > 0)


def test_noise_off_sigma_equals_the_closed_form_rms():
    case = case_from_params(params_from_dict(PARAMS))
    cc = compute_curves(case, times=[1.0, 5.0, 15.0], runs=0)
    v = cc.at_eval_times()
    for k in ("INS-3D", "INS-2D"):
        # both are sqrt(E[e^2]) of the same linear model, one from the filterpy
        # recursion, one from the hand polynomials: rounding only (bar 1e-9)
        np.testing.assert_allclose(v["sigma_m"][k], v["rms_closed_form_m"][k], rtol=1e-9)
        # the one-call sigma is the same filter
        np.testing.assert_array_equal(horizontal_sigma(params_from_dict(PARAMS), [1.0, 5.0, 15.0], k),
                                      v["sigma_m"][k])
    # MoRPI aiding bounds the error far below the 2D INS at 15 s
    assert v["sigma_m"]["MoRPI-aided INS"][-1] < 0.5 * v["sigma_m"]["INS-2D"][-1]
    np.testing.assert_array_equal(horizontal_sigma(case, [1.0, 5.0, 15.0], "MoRPI-aided INS"),
                                  v["sigma_m"]["MoRPI-aided INS"])
    with pytest.raises(MorpiError, match="method 'ins3d'"):
        horizontal_sigma(case, [1.0], "ins3d")


def test_monte_carlo_rms_agrees_with_sigma():
    case = case_from_sensor(units.LSM6DSL, params_from_dict({**PARAMS, "process_noise": True}))
    N = 1000
    v = compute_curves(case, times=[3.0, 10.0], runs=N, rng=np.random.default_rng(12)).at_eval_times()
    for k in ("INS-3D", "INS-2D", "MoRPI-aided INS"):
        ratio = v["mc_rms_m"][k] ** 2 / v["sigma_m"][k] ** 2
        # mean square over N runs of a sum of two Gaussian squares: relative std
        # at most sqrt(2/N) = 4.5%; bar 4 of those
        assert np.all(np.abs(ratio - 1) < 4 * np.sqrt(2 / N)), (k, ratio)


def test_closed_form_realisation_and_mean_square_by_hand():
    p = params_from_dict(PARAMS)
    t = np.array([2.0])
    e = error_realisation(p.dv0, p.ba, p.bg, 0.05, p.g, 0.5, t, "INS-3D")
    alpha = 9.81 + 0.03  # the paper's alpha = g + b_az for one realisation
    dx = 0.06 * 2 + 0.08 * 2 + alpha * 0.003 * 8 / 6
    dy = 0.03 * 2 + 0.03 * 2 - alpha * 0.002 * 8 / 6
    assert e[0] == pytest.approx(np.hypot(dx, dy), rel=1e-12)  # the norm of the same two components: float rounding
    case = case_from_params(p)
    # linearized mean square by hand (alpha = g), b_gz dropped
    ms = ((0.06 ** 2 + 0.03 ** 2) * 4 + (0.08 ** 2 + 0.03 ** 2) * 16 / 4
          + 9.81 ** 2 * (0.002 ** 2 + 0.003 ** 2) * 64 / 36)
    assert case_mean_square(case, t, "INS-3D")[0] == pytest.approx(ms, rel=1e-12)  # the same closed form through two call paths: float rounding
    assert case_mean_square(case, t, "MoRPI-aided INS")[0] == pytest.approx((0.05 * 0.5 * 2) ** 2)  # (dG v t)^2 exactly; pytest's default 1e-6 relative
    with pytest.raises(MorpiError, match="kind"):
        case_mean_square(case, t, "ins3d")


def test_report_contract(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    s = report_curves(out, curves_study(params_path=_write(tmp_path, process_noise=True), times=[2.0, 6.0]))
    r = json.loads((out / "result.json").read_text())
    assert len(r["time_s"]) == 2 and r["times"] == r["time_s"]      # the old key beside the new one
    for key in ("sigma_m", "rms_closed_form_m"):
        assert set(r[key]) == {"INS-3D", "INS-2D", "MoRPI-aided INS"}
        assert all(len(v) == 2 for v in r[key].values()), key
    assert r["time_s"] == [2.0, 6.0] and r["process_noise"] is True
    assert r["seed"] == r["mc_seed"] and isinstance(r["seed"], int)    # mc_seed: the name before 0.2, for one release
    assert set(r["cases"]) == {"params", "mpu6500", "lsm6dsl"}
    assert s.name == "curves" and s.page == "README.md" and not s.synthetic
    for png in s.figures:
        assert (out / png).stat().st_size > 1000
    assert "Covariance curves" in (out / "README.md").read_text()


def test_default_times_and_cli(tmp_path, monkeypatch):
    monkeypatch.delenv("MORPI_DATA", raising=False)  # no field study here (see the field tests)
    assert DEFAULT_TIMES[0] == 0.0 and DEFAULT_TIMES[-1] == 15.0 and len(DEFAULT_TIMES) == 16
    js = tmp_path / "r.json"
    rc = main(["curves", "--params", str(_write(tmp_path)), "--out", str(tmp_path / "c"), "--json", str(js)])
    assert rc == 0
    r = json.loads(js.read_text())
    assert r["time_s"] == list(DEFAULT_TIMES) and r["process_noise"] is False
    assert r["sigma_m"]["INS-3D"][0] == 0.0


def test_the_monte_carlo_draws_only_from_the_callers_generator():
    case = case_from_sensor(units.LSM6DSL, params_from_dict(PARAMS))
    for kw in (dict(runs=5, nonlinear_runs=0), dict(runs=0, nonlinear_runs=3)):
        with pytest.raises(ParameterError, match="rng"):
            compute_curves(case, times=[1.0], **kw)
    # without a Monte Carlo there is nothing to draw and no generator is needed
    assert compute_curves(case, times=[1.0], runs=0, nonlinear_runs=0).mc_runs == 0
    a, b = (compute_curves(case, times=[1.0], runs=5, nonlinear_runs=3, rng=np.random.default_rng(4))
            for _ in range(2))
    c = compute_curves(case, times=[1.0], runs=5, nonlinear_runs=3, rng=np.random.default_rng(5))
    for k in ("INS-3D", "INS-2D"):
        assert np.array_equal(a.mc_rms[k], b.mc_rms[k]) and np.array_equal(a.nl_rms[k], b.nl_rms[k])
        assert not np.array_equal(a.mc_rms[k], c.mc_rms[k]) and not np.array_equal(a.nl_rms[k], c.nl_rms[k])


def test_cli_seed_sets_the_monte_carlo(tmp_path, monkeypatch):
    monkeypatch.delenv("MORPI_DATA", raising=False)
    params = str(_write(tmp_path))
    got = []
    for k, seed in enumerate((None, "5", "5", "6")):
        js = tmp_path / f"r{k}.json"
        argv = ["curves", "--params", params, "--times", "1", "--out", str(tmp_path / f"c{k}"), "--json", str(js)]
        assert main(argv + (["--seed", seed] if seed else [])) == 0
        got.append(json.loads(js.read_text()))
    assert [r["mc_seed"] for r in got] == [MC_SEED, 5, 5, 6]
    mc = [r["cases"]["mpu6500"]["mc_rms_m"] for r in got]
    assert mc[1] == mc[2] and mc[3] != mc[1] and mc[0] != mc[1]


def test_bad_parameter_file_is_one_clear_error(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("MORPI_DATA", raising=False)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**PARAMS, "process_noise": "yes"}))
    out = tmp_path / "c"
    rc = main(["curves", "--params", str(bad), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "process_noise" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
    with pytest.raises(MorpiError, match="times"):
        compute_curves(case_from_params(params_from_dict(PARAMS)), times=[0.0])


def test_nonlinear_strapdown_monte_carlo_agrees_where_the_model_is_linear():
    """Small biases (0.2 deg/s, 5 mg): tilt stays < 1 deg over 3 s, the linear model holds."""
    spec = units.SensorSpec("small", 0.2 * units.DEG_S, 0.004 * units.DEG_S_SQRT_HZ, 5 * units.MG,
                            130 * units.UG_SQRT_HZ)
    case = case_from_sensor(spec, params_from_dict({**PARAMS, "process_noise": True}))
    N = 400
    cc = compute_curves(case, times=[1.0, 3.0], runs=0, rng=np.random.default_rng(3), nonlinear_runs=N)
    v = cc.at_eval_times()
    for k in ("INS-3D", "INS-2D"):
        ratio = v["nonlinear_mc_rms_m"][k] ** 2 / v["sigma_m"][k] ** 2
        # mean square of N runs: relative std <= sqrt(2/N) = 7%; 4 of those
        assert np.all(np.abs(ratio - 1) < 4 * np.sqrt(2 / N)), (k, ratio)


def test_synthetic_source_banner_and_empty_field(tmp_path):
    from morpi_filters.report.common import SYNTHETIC_BANNER
    from morpi_filters.results import DataSource

    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "empty").mkdir()                     # a dataset folder without recordings
    src = DataSource(tmp_path / "empty", synthetic=True, seed=0)
    s = report_curves(out, curves_study(params_path=_write(tmp_path), times=[1.0], data_source=src), src)
    text = (out / "README.md").read_text()
    assert text.startswith(SYNTHETIC_BANNER) and s.synthetic
    assert "no straight-line" in json.loads((out / "result.json").read_text())["field"]["note"]
    assert json.loads((out / "result.json").read_text())["field_aided"]["section"] == "aided"


@pytest.mark.field
def test_field_straight_line_end_points(field_root):
    from morpi_filters.curves import _field_points
    from morpi_filters.results import DataSource

    pts, note = _field_points(DataSource(field_root))
    assert len(pts["INS-3D"]) == len(pts["INS-2D"]) >= 20  # 24 recordings in s8/line_dataset
    d = np.array(pts["INS-3D"])
    # the paper: 6.3 m in about 5 s; motion spans between 3 and 10 s
    assert np.all((d[:, 0] > 3) & (d[:, 0] < 10))
    # Independent of the curves' own loop: the end-point errors of the paper's INS table, computed by
    # evaluate's cell code on the same recordings (GAC, the robot's motion), against the end point
    # read directly from data/routes.json.
    from morpi_filters import evaluate as ev
    from conftest import ROOT
    truth_end = np.array(json.loads((ROOT / "data" / "routes.json").read_text())["routes"]["line_dataset"]["end_point_m"])
    result = ev.evaluate_tables(field_root, alternatives=False)
    for key in ("INS-3D", "INS-2D"):
        runs = result.cell("ins_straight", "s8", None, key, "GAC").runs
        table = sorted(float(np.linalg.norm(np.asarray(r.end_point) - truth_end)) for r in runs)
        # same recordings and the same integration: equal up to float rounding (1e-9 m)
        np.testing.assert_allclose(sorted(e for _, e in pts[key]), table, atol=1e-9)


