"""The analytical assessment section: the paper's eight numbers, the CLI, bad files.

Independent evidence: the paper's printed improvements (rounded to 0.01 m, so
0.01 m is the tolerance), solve_ivp of the error ODE written with numpy.
"""
from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from morpi_filters import assessment as A
from morpi_filters.cli import main
from morpi_filters.params import DEFAULT_PARAMS_FILE, load_params, params_from_dict

PAPER = np.array([n.paper_m for n in A.PAPER_IMPROVEMENTS])


def ode_horizontal(dv, ba, bg, g, times, ins="INS-3D"):
    """|dp_xy| of the z_up error ODE (paper's F signs), b_gz dropped; 2D: yaw-only."""
    bg = np.array([bg[0], bg[1], 0.0]) if ins == "INS-3D" else np.zeros(3)
    f = np.array([ba[0], ba[1], g + ba[2]])

    def rhs(t, x):
        dv_, eps = x[3:6], x[6:9]
        return np.concatenate([dv_, -np.cross(f, eps) + ba, bg])

    sol = solve_ivp(rhs, (0.0, max(times)), np.concatenate([np.zeros(3), dv, np.zeros(3)]), method="DOP853",
                    t_eval=times, rtol=1e-12, atol=1e-15)  # solver tolerances, far below the 1e-9 comparisons that use this reference
    assert sol.success
    return np.hypot(sol.y[0], sol.y[1])


def test_committed_parameters_reproduce_the_eight_numbers():
    ours = A.improvements(load_params())
    # the paper prints the eight improvements to 0.01 m
    assert np.max(np.abs(ours - PAPER)) <= 0.01


def test_committed_parameters_are_plausible():
    p = load_params()
    assert np.all(np.abs(p.dv0) <= 0.3)  # cm/s to dm/s
    assert np.all(np.abs(p.ba) <= 60e-3 * 9.81)  # the MPU-6500 turn-on bias, 60 mg
    assert np.all(np.abs(p.bg) <= np.deg2rad(6.0))  # the MPU-6500 turn-on bias, 6 deg/s
    assert 9.7 < p.g < 9.9
    assert np.all(p.dv0[:2] != 0) and np.all(p.ba[:2] != 0) and np.all(p.bg[:2] != 0)


def test_fit_reproduces_the_paper_numbers():
    fit = A.fit_paper_numbers()
    # Recompute the eight numbers from the fitted parameters through the closed form, against the paper.
    ours = A.improvements(params_from_dict(dict(fit.params)))
    # the paper prints the eight improvements to 0.01 m
    assert np.max(np.abs(ours - PAPER)) <= 0.01
    assert fit.max_abs_error_m == pytest.approx(np.max(np.abs(ours - PAPER)), abs=1e-12)  # float rounding


def test_the_numbers_do_not_determine_the_components():
    """Rotating every horizontal vector about z leaves e_3D, e_2D, and hence all eight numbers, unchanged."""
    p = load_params()
    c, s = np.cos(1.0), np.sin(1.0)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    q = params_from_dict({"dv0_mps": list(R @ p.dv0), "accel_bias_mps2": list(R @ p.ba), "gyro_bias_radps": list(R @ p.bg),
                          "g_mps2": p.g, "morpi_speed_mps": p.morpi_speed_mps})
    np.testing.assert_allclose(A.improvements(q), A.improvements(p), rtol=1e-12)  # a rotation about z only reorders sums: float rounding
    assert not np.allclose(q.ba, p.ba)  # the rotated vectors differ by far more than allclose's default 1e-5


def write(tmp_path, d, name="p.json"):
    path = tmp_path / name
    path.write_text(json.dumps(d))
    return path


FULL = {"dv0_mps": [0.04, -0.07, 0.02], "accel_bias_mps2": [-0.05, 0.08, 0.03], "gyro_bias_radps": [0.004, -0.006, 0.005],
        "g_mps2": 9.8, "dG": [0.05, 0.1, 0.2], "morpi_speed_mps": 0.7}


def test_cli_assess_gives_the_derived_errors(tmp_path, capsys):
    pf = write(tmp_path, FULL)
    out, js = tmp_path / "rep", tmp_path / "r.json"
    times = ["0", "1.5", "5", "14", "15"]
    assert main(["assess", "--params", str(pf), "--times", *times, "--json", str(js), "--out", str(out)]) == 0
    r = json.loads(js.read_text())
    t = np.array([float(x) for x in times])
    assert r["time_s"] == list(t) and r["times"] == r["time_s"] and r["convention"] == "z_up"   # and its old key
    dv, ba, bg = (np.array(FULL[k]) for k in ("dv0_mps", "accel_bias_mps2", "gyro_bias_radps"))
    # 1e-9: closed form vs DOP853 at rtol 1e-12 (t = 0 is exactly 0 on both sides)
    np.testing.assert_allclose(r["e3d_m"], ode_horizontal(dv, ba, bg, 9.8, t), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(r["e2d_m"], ode_horizontal(dv, ba, bg, 9.8, t, "INS-2D"), rtol=1e-9, atol=1e-15)
    assert set(r["morpi_m"]) == {"0.05", "0.1", "0.2"}
    np.testing.assert_allclose(r["morpi_m"]["0.2"], 0.2 * 0.7 * t, rtol=1e-15)  # the same product dG v t: exact up to one rounding
    # the printed eq:error-3d gives different numbers for these parameters
    printed = printed_e3d(dv, ba, bg, 9.8, t)
    assert np.max(np.abs(printed - np.array(r["e3d_m"]))) > 0.1
    for f in ("README.md", "audit.md", "result.json", "assessment.png"):
        assert (out / f).is_file()
    readme = (out / "README.md").read_text()
    assert "(audit.md)" in readme and "![" in readme and "2.95" in readme
    assert (out / "assessment.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def printed_e3d(dv, ba, bg, g, t):
    a = g + ba[2]
    e2 = ((dv[0]**2 + dv[1]**2) * t**2 + (dv[0] * ba[0] + dv[1] * ba[1]) * t**3
          + (0.25 * (ba[0]**2 + ba[1]**2) - a / 3 * (dv[0] * bg[1] + dv[1] * bg[0])) * t**4
          - a / 6 * (ba[0] * bg[1] + ba[1] * bg[0]) * t**5 + a**2 / 36 * (bg[0]**2 + bg[1]**2) * t**6)
    return np.sqrt(e2)


def test_report_default_parameters(tmp_path):
    from morpi_filters.report.assessment import report_assessment

    s = report_assessment(tmp_path, A.assessment_study())
    assert s.name == "assessment" and s.figures == ("assessment.png",) and not s.synthetic
    r = json.loads((tmp_path / "result.json").read_text())
    assert r["time_s"][0] == 0.0 and r["time_s"][-1] == 15.0
    assert len(r["e3d_m"]) == len(r["time_s"]) == len(r["morpi_m"]["0.1"])
    assert max(abs(i["ours_m"] - i["paper_m"]) for i in r["improvements"]) <= 0.01
    assert len(r["audit"]) == 9
    # the parameter keys renamed in 0.2 are written beside the new ones for one release, with the same values
    p = r["params"]
    assert p["ba_mps2"] == p["accel_bias_mps2"] and p["bg_radps"] == p["gyro_bias_radps"] and len(p["bg_radps"]) == 3
    audit = (tmp_path / "audit.md").read_text()
    assert audit.startswith("# Audit of the printed equations")


@pytest.mark.parametrize("patch, expect", [
    ({"g_mps2": None}, "g_mps2"),
    ({"g_mps2": -9.8}, "positive gravity"),
    ({"accel_bias_mps2": [0.1, 0.2]}, "expected a list of 3 numbers"),
    ({"gyro_bias_radps": [0.1, "x", 0.2]}, "is not a finite number"),
])
def test_cli_bad_parameter_file(tmp_path, capsys, patch, expect):
    d = {k: v for k, v in FULL.items()} | patch
    if patch.get("g_mps2", 0) is None:
        del d["g_mps2"]
    pf = write(tmp_path, d)
    out = tmp_path / "rep"
    assert main(["assess", "--params", str(pf), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("morpi: error:") and expect in err[0] and str(pf) in err[0]
    assert not out.exists()


def test_cli_missing_parameter_file(tmp_path, capsys):
    assert main(["assess", "--params", str(tmp_path / "nope.json"), "--out", str(tmp_path / "o")]) == 2
    assert "no such parameter file" in capsys.readouterr().err


def test_assessment_module_does_not_import_sympy_at_module_level():
    import os
    import subprocess
    from pathlib import Path

    root = str(Path(A.__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=root)
    code = "import sys, morpi_filters.assessment; print('sympy' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert res.stdout.strip() == "False"


def test_z_down_equals_z_up_with_tilt_biases_flipped():
    """The README's claim: z_down with (b_gx, b_gy, b_az) negated gives the z_up curves."""
    from morpi_filters import symbolic as S

    p = load_params()
    q = params_from_dict({"dv0_mps": list(p.dv0), "accel_bias_mps2": [p.ba[0], p.ba[1], -p.ba[2]],
                          "gyro_bias_radps": [-p.bg[0], -p.bg[1], p.bg[2]], "g_mps2": p.g})
    t = np.arange(16.0)
    for kind in ("INS-3D", "INS-2D"):
        np.testing.assert_allclose(S.closed_form_errors(q, t, kind, "z_down"), S.closed_form_errors(p, t, kind),
                                   rtol=1e-12)  # the two conventions give the same polynomial: float rounding
    assert not np.allclose(S.closed_form_errors(p, t, "INS-3D", "z_down"), S.closed_form_errors(p, t, "INS-3D"))  # the z-down 3D error differs by far more than allclose's default 1e-5
