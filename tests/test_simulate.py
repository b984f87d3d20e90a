"""Tests of the simulator: exact kinematics, IMU noise statistics, the synthetic dataset.

Evidence: finite differences of the simulated position and attitude at a high rate (with
tolerances from the difference formulas' truncation error), chi-square bounds on the
synthesized noise, noise-free recovery through the strapdown INS, sine peaks found
independently in the sampled path, and the dataset checker.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from morpi_filters import dataset, simulate, synthetic, units
from morpi_filters.errors import MorpiError
from morpi_filters.strapdown import ins2d, ins3d

ROOT = Path(__file__).resolve().parent.parent
G = units.G0
EPS = np.finfo(float).eps


def _vee_log(R):
    """Rotation vectors of rotation matrices (n, 3, 3), angles < pi/2."""
    ang = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    k = np.where(ang < 1e-12, 0.5, ang / (2 * np.sin(np.maximum(ang, 1e-300))))  # guard against division by zero for a null rotation, not a tolerance
    v = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=-1)
    return k[:, None] * v


TRAJECTORIES = {
    "straight": lambda **kw: simulate.straight(6.3, rest_s=0.5, **kw),
    "sine": lambda **kw: simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rest_s=0.5, **kw),
    "sine_1.5": lambda **kw: simulate.sine(6.3, p2p_m=1.5, amplitude_m=0.2, rest_s=0.5, **kw),
    "L_shape": lambda **kw: simulate.l_route((18.0, 10.0), turn_deg=-90, slope_deg=15, p2p_m=1.0,
                                             amplitude_m=0.1, rest_s=0.5, **kw),
    "L_line": lambda **kw: simulate.l_route((18.0, 10.0), turn_deg=90, slope_deg=15, rest_s=0.5, **kw),
}


@pytest.mark.parametrize("name", sorted(TRAJECTORIES))
def test_kinematics_match_finite_differences(name):
    h = 1e-3                                            # 1 kHz
    tr = TRAJECTORIES[name](rate_hz=1.0 / h)
    p, v, a, C, w = tr.position, tr.velocity, tr.acceleration, tr.C_bn, tr.omega_b
    scale = np.abs(p).max() + 1.0
    # velocity: central difference, truncation h^2/6 |p'''| (|p'''| bounded by the differences of
    # the analytic acceleration) plus rounding eps |p| / h; factor 2 for the bound estimate
    jerk = np.abs(np.diff(a, axis=0)).max() / h
    tol_v = 2 * (h * h / 6 * jerk + 4 * EPS * scale / h)
    assert np.abs((p[2:] - p[:-2]) / (2 * h) - v[1:-1]).max() < tol_v
    # acceleration: second difference, truncation h^2/12 |p''''| plus rounding 4 eps |p| / h^2
    snap = np.abs(np.diff(a, 2, axis=0)).max() / h ** 2
    tol_a = 2 * (h * h / 12 * snap + 4 * EPS * scale / h ** 2)
    fd_acc = (p[2:] - 2 * p[1:-1] + p[:-2]) / h ** 2
    assert np.abs(fd_acc - a[1:-1]).max() < tol_a
    # specific force from the finite-difference acceleration and the attitude: f = C^T (a + g)
    fn = fd_acc.copy()
    fn[:, 2] += G
    f_fd = np.einsum("nji,nj->ni", C[1:-1], fn)
    assert np.abs(f_fd - tr.f_b[1:-1]).max() < tol_a + 1e-9
    # angular rate: log(C_k-1^T C_k+1) / 2h; truncation h^2/6 |w''| (+ the w x w' term, h^2/12
    # |w| |w'|), both bounded from differences of the analytic rate
    dw = np.abs(np.diff(w, axis=0)).max() / h
    ddw = np.abs(np.diff(w, 2, axis=0)).max() / h ** 2
    tol_w = 2 * (h * h / 6 * ddw + h * h / 12 * np.abs(w).max() * dw + 10 * EPS / h)
    rel = np.einsum("nji,njk->nik", C[:-2], C[2:])
    assert np.abs(_vee_log(rel) / (2 * h) - w[1:-1]).max() < tol_w
    # the attitude is a rotation, body x along the velocity, body y horizontal (no roll)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", C, C), np.broadcast_to(np.eye(3), C.shape), atol=1e-13)
    moving = np.linalg.norm(v, axis=1) > 1e-6
    xb = C[moving, :, 0]
    np.testing.assert_allclose(np.cross(xb, v[moving] / np.linalg.norm(v[moving], axis=1)[:, None]), 0, atol=1e-12)  # the body x axis is the velocity direction by construction: float rounding
    np.testing.assert_allclose(C[:, 2, 1], 0.0, atol=1e-15)  # no roll on a level route by construction: float rounding
    # at rest a level body reads f = (0, 0, g); on the slope it reads the tilt
    np.testing.assert_allclose(np.linalg.norm(tr.f_b[0]), G, rtol=1e-12)
    np.testing.assert_allclose(tr.position[-1], tr.end_point, atol=1e-12)


def test_route_end_points_match_ground_truth():
    for name in ("line_dataset", "short_distance", "short_distance_1.5p2p", "long_distance", "L_line", "L_shape"):
        r = dataset.route(name)
        tr = simulate.route_trajectory(name)
        # the analytic path ends exactly at the ground-truth end point (rounding of the quadrature)
        np.testing.assert_allclose(tr.end_point[:2], r.end_point_m, atol=1e-9)
        if name.startswith("L_"):
            # 15 deg over 5 m (horizontal), easing out over 1 m: drop 5 tan(15 deg)
            np.testing.assert_allclose(tr.end_point[2], -5 * np.tan(np.radians(15)), atol=1e-12)
            assert np.sign(tr.heading[-1]) == np.sign(r.turn_deg)
            np.testing.assert_allclose(tr.heading[-1], np.radians(r.turn_deg), atol=1e-12)  # the path ends on the route's turn angle; only rounding


@pytest.mark.parametrize("sampling", ["uniform", "two-rate", "jittered"])
@pytest.mark.parametrize("name", ["line_dataset", "short_distance", "short_distance_1.5p2p", "L_line", "L_shape"])
def test_noise_free_ins_recovers_route(name, sampling):
    tr = simulate.route_trajectory(name)
    d = simulate.imu(tr, units.MPU6500, np.random.default_rng(4), sampling=sampling, bias_scale=0, noise_scale=0)
    assert np.array_equal(d.f, d.truth.f_b) and np.array_equal(d.omega, d.truth.omega_b)
    T = d.truth
    r = ins3d(d.time, d.f, d.omega, C0=T.C_bn[0], p0=T.position[0])
    err = np.linalg.norm(r.position - T.position, axis=1)
    # the acceptance bar: under 1 mm after 15 s of recording at 100 Hz (irregular grids included)
    k15 = min(np.searchsorted(d.time, d.time[0] + 15.0), d.time.size - 1)
    assert err[k15] < 1e-3
    if sampling != "two-rate":
        # whole route (up to 53 s for the L routes) at ~100 Hz: still under 1 mm
        assert err[-1] < 1e-3
    if not name.startswith("L_"):
        r2 = ins2d(d.time, d.f, d.omega, psi0=T.heading[0], p0=T.position[0])
        assert np.linalg.norm(r2.position[k15, :2] - T.position[k15, :2]) < 1e-3  # the simulator's acceptance bar (1 mm after 15 s), as for the 3D INS above


def test_sine_peaks_at_known_times():
    h = 1e-3
    tr = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=1 / h)
    y = tr.position[:, 1]
    # lateral extremes found independently in the sampled path, refined by a parabola
    i = np.flatnonzero((np.diff(np.sign(np.diff(y))) != 0)) + 1
    i = i[np.abs(y[i]) > 1e-6]                          # not the flat rest at both ends
    den = y[i - 1] - 2 * y[i] + y[i + 1]
    t_peak = tr.time[i] + h * 0.5 * (y[i - 1] - y[i + 1]) / den
    assert t_peak.size == tr.peak_times.size
    # parabolic refinement error ~ h^2 |y'''| / |y''| scale: well below 0.1 ms at 1 kHz
    np.testing.assert_allclose(t_peak, tr.peak_times, atol=1e-4)
    np.testing.assert_array_equal(np.sign(y[i]), tr.peak_side)
    # one extreme per half period over 6.3 m (tapered first and last period included)
    assert 12 <= tr.peak_times.size <= 13
    assert tr.start_time < tr.peak_times[0] and tr.peak_times[-1] < tr.stop_time
    # the steady part: consecutive extremes of a sine of period P are P/2 apart in x
    x = np.interp(tr.peak_times, tr.time, tr.position[:, 0])
    np.testing.assert_allclose(np.diff(x)[2:-2], 0.5, atol=2e-3)
    # period boundaries: x passes 1, 2, ... 6 m (x = u on a straight route; linear
    # interpolation of the 1 kHz samples is exact to h * speed / 2 < 0.3 mm)
    xb = np.interp(tr.period_times, tr.time, tr.position[:, 0])
    np.testing.assert_allclose(xb, np.arange(1, 7), atol=3e-4)


def test_white_noise_matches_density_with_chi_square():
    tr = simulate.straight(1.0, speed_mps=1.0, rest_s=0.2, ramp_s=0.5)
    spec = units.MPU6500
    d = simulate.imu(tr, spec, np.random.default_rng(11), runs=400, sampling="two-rate", bias_scale=0)
    dt = np.diff(d.time)
    dt_k = np.concatenate([dt[:1], dt])
    for meas, true, density in ((d.f, d.truth.f_b, spec.accel_noise), (d.omega, d.truth.omega_b, spec.gyro_noise)):
        z = (meas - true) * np.sqrt(dt_k)[None, :, None] / density     # should be N(0, 1)
        N = z.size
        s2 = np.sum(z ** 2)
        # two-sided 99.9 % chi-square bounds on the sum of N squared standard normals
        assert stats.chi2.ppf(0.0005, N) < s2 < stats.chi2.ppf(0.9995, N)
        assert abs(z.mean()) < 4 / np.sqrt(N)                           # 4 sigma of the mean
    # the interval spread really differs (S6-like): the per-sample sigma follows the actual dt
    assert dt.min() < 0.0105 and dt.max() > 0.018


def test_turn_on_bias_statistics():
    tr = simulate.straight(1.0, speed_mps=1.0, rest_s=0.0, ramp_s=0.5, rate_hz=20)
    spec = units.LSM6DSL
    runs = 4000
    d = simulate.imu(tr, spec, np.random.default_rng(12), runs=runs, bias_scale=(0.5, 0.25))
    for b, sigma in ((d.accel_bias, 0.5 * spec.accel_bias), (d.gyro_bias, 0.25 * spec.gyro_bias)):
        s2 = np.sum((b / sigma) ** 2)
        N = b.size
        assert stats.chi2.ppf(0.0005, N) < s2 < stats.chi2.ppf(0.9995, N)
    # the readings carry the drawn bias: the mean error of each run is its bias (noise averages
    # to density / sqrt(T) per axis, 5 sigma)
    err = (d.omega - d.truth.omega_b[None]).mean(axis=1) - d.gyro_bias
    assert np.abs(err).max() < 5 * spec.gyro_noise / np.sqrt(d.time[-1] - d.time[0]) * 1.5


def test_scale_factor_misalignment_and_bias_random_walk():
    tr = simulate.sine(6.3, rest_s=0.5)
    rng = np.random.default_rng(13)
    d = simulate.imu(tr, units.LSM6DSL, rng, runs=3, sampling=tr.time, bias_scale=0, noise_scale=0,
                     scale_factor=0.01, misalignment=0.02, gyro_bias_rw=1e-3)
    from morpi_filters.strapdown import rotvec_to_C
    for i in range(3):
        M = rotvec_to_C(d.misalignment[i])
        expect = (tr.f_b @ M) * (1 + d.accel_scale[i])
        np.testing.assert_allclose(d.f[i], expect, atol=1e-12)  # the closed-form specific force at the sample: float rounding
        expect_w = (tr.omega_b @ M) * (1 + d.gyro_scale[i]) + d.gyro_bias_drift[i]
        np.testing.assert_allclose(d.omega[i], expect_w, atol=1e-12)  # the closed-form angular rate at the sample: float rounding
    steps = np.diff(d.gyro_bias_drift, axis=1) / (1e-3 * np.sqrt(np.diff(d.time)))[None, :, None]
    N = steps.size
    assert stats.chi2.ppf(0.0005, N) < np.sum(steps ** 2) < stats.chi2.ppf(0.9995, N)


def test_gauss_markov_bias_instability_statistics():
    tr = simulate.straight(2.0, rest_s=2.0, rate_hz=50)
    sigma, tau = 0.01, 0.5
    d = simulate.imu(tr, units.LSM6DSL, np.random.default_rng(14), runs=300, sampling="two-rate", bias_scale=0,
                     noise_scale=0, bias_instability=(0.0, sigma), correlation_time=tau)
    b = d.gyro_bias_drift
    dt = np.diff(d.time)
    phi = np.exp(-dt / tau)
    # the innovations of the exact discretization are independent N(0, sigma^2 (1 - phi^2))
    z = (b[:, 1:] - phi[None, :, None] * b[:, :-1]) / (sigma * np.sqrt(1 - phi * phi))[None, :, None]
    N = z.size
    assert stats.chi2.ppf(0.0005, N) < np.sum(z ** 2) < stats.chi2.ppf(0.9995, N)
    # started in steady state: the first sample has variance sigma^2 (chi-square, 900 values)
    N0 = b[:, 0].size
    assert stats.chi2.ppf(0.0005, N0) < np.sum((b[:, 0] / sigma) ** 2) < stats.chi2.ppf(0.9995, N0)
    assert d.accel_bias_drift is None
    # the block-vectorized sequence equals the sample-by-sample recurrence (long record, 200 tau,
    # several blocks); 1e-12 is rounding of the rescaled partial sums
    from morpi_filters.simulate import _gauss_markov
    rng = np.random.default_rng(15)
    t = np.cumsum(rng.uniform(0.0095, 0.023, 4000))
    z = rng.standard_normal((2, t.size, 3))
    tau = (t[-1] - t[0]) / 200
    fast = _gauss_markov(z, t, 0.3, tau)
    ref = np.empty_like(z)
    ref[:, 0] = 0.3 * z[:, 0]
    for k in range(1, t.size):
        p = np.exp(-(t[k] - t[k - 1]) / tau)
        ref[:, k] = p * ref[:, k - 1] + 0.3 * np.sqrt(1 - p * p) * z[:, k]
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-12)  # the fast path evaluates the same formulas: float rounding


def test_per_run_generators_make_batching_irrelevant():
    tr = simulate.straight(2.0, rest_s=0.3)
    seeds = np.random.SeedSequence(7).spawn(4)
    a = simulate.imu(tr, units.MPU6500, [np.random.default_rng(s) for s in seeds], runs=4, sampling=tr.time,
                     scale_factor=0.01, misalignment=0.01)
    b = simulate.imu(tr, units.MPU6500, [np.random.default_rng(s) for s in seeds[2:]], runs=2, sampling=tr.time,
                     scale_factor=0.01, misalignment=0.01)
    np.testing.assert_array_equal(a.f[2:], b.f)
    np.testing.assert_array_equal(a.omega[2:], b.omega)
    rec = a.recording(3, phone="s6", route="line_dataset")
    assert isinstance(rec, dataset.Recording) and rec.phone == "s6" and np.array_equal(rec.f, a.f[3])


def test_sampling_patterns_like_the_field_files():
    rng = np.random.default_rng(21)
    for _ in range(20):
        t = simulate.sample_times(0.4, 30.0, rng, pattern="two-rate")
        dt = np.diff(t)
        # dataset README: S6 median dt 0.011 to 0.019 s, range 0.0095 to 0.023 s
        assert 0.0105 <= np.median(dt) <= 0.0195 and dt.min() >= 0.0095 and dt.max() <= 0.023
        t8 = simulate.sample_times(0.4, 30.0, rng, pattern="jittered")
        dt8 = np.diff(t8)
        # S8: close to 100 Hz, dt 0.0099 to 0.019 s
        assert abs(np.median(dt8) - 0.01) < 2e-4 and dt8.min() >= 0.0099 and dt8.max() <= 0.019


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("syn") / "ds"
    return synthetic.write_dataset(root, seed=3, runs_per_folder=1)


def test_write_dataset_layout_and_check(small_dataset, tmp_path):
    from morpi_filters.field import check_recordings

    problems, n_ok, _ = check_recordings(small_dataset)
    layout = dataset.layout()
    assert problems == [] and n_ok == len(layout)
    entries = dataset.catalogue(small_dataset)
    assert sorted(e.relpath.rsplit("/", 1)[0] for e in entries) == sorted(layout)
    for e in entries:
        rec = e.load()
        assert rec.time[0] > 0                                   # time does not start at 0
        dt = np.diff(rec.time)
        if e.phone == "s6":
            assert dt.max() > 0.018 and dt.min() < 0.0105          # irregular, like the S6 files
        # at rest at both ends: |f| close to g (noise, bias, vibration off at rest)
        assert abs(np.linalg.norm(rec.f[:50].mean(axis=0)) - G) < 0.5
    assert not list(small_dataset.parent.glob(".staging-*"))
    # reproducible: same seed, same bytes; the run's file does not depend on how many runs are written
    again = synthetic.write_dataset(tmp_path / "again", seed=3, runs_per_folder=2)
    for e in entries:
        assert (again / e.relpath).read_bytes() == e.path.read_bytes()
    other = synthetic.write_dataset(tmp_path / "other", seed=4, runs_per_folder=1)
    assert (other / entries[0].relpath).read_bytes() != entries[0].path.read_bytes()
    # both phones recorded the long route at once: same trajectory draws
    m = json.loads((again / "manifest.json").read_text())["runs"]
    assert m["s6/long_distance/test/1.csv"]["speed_mps"] == m["s8/long_distance/test/1.csv"]["speed_mps"]
    # the run keys renamed in 0.2 stay for one release beside the new ones, with the same values
    assert all(r["speed_m_s"] == r["speed_mps"] and r["period_m"] == r["p2p_m"] for r in m.values())
    assert any(r["p2p_m"] is not None for r in m.values())


def test_write_dataset_refuses_foreign_folder_and_cleans_up(tmp_path, monkeypatch):
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(MorpiError, match="not a synthetic dataset"):
        synthetic.write_dataset(foreign, runs_per_folder=1)
    assert (foreign / "notes.txt").read_text() == "keep me"
    calls = []
    real_write = dataset.write_csv

    def failing(path, rec):
        calls.append(path)
        if len(calls) == 3:
            raise RuntimeError("disk full")
        return real_write(path, rec)

    monkeypatch.setattr(dataset, "write_csv", failing)
    with pytest.raises(RuntimeError):
        synthetic.write_dataset(tmp_path / "broken", runs_per_folder=1)
    assert not (tmp_path / "broken").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["mine"]


def test_ensure_synthetic_dataset_reuses_and_repairs(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    root = synthetic.ensure_synthetic_dataset(cache, seed=1)
    files = sorted(root.rglob("*.csv"))
    assert len(files) == sum(dataset.layout().values())
    real_write = synthetic.write_dataset
    calls = []
    def recording_write(*a, **k):
        calls.append(k.get("seed"))
        return real_write(*a, **k) if k.get("seed") == 1 else Path(a[0])   # seed 2: only note the call

    monkeypatch.setattr(synthetic, "write_dataset", recording_write)
    synthetic.ensure_synthetic_dataset(cache, seed=1)
    assert calls == []                                            # verified and reused
    original = files[5].read_bytes()
    files[5].write_bytes(original[:-20])                          # tamper with one file
    synthetic.ensure_synthetic_dataset(cache, seed=1)
    assert len(calls) == 1 and files[5].read_bytes() == original  # regenerated, identical
    synthetic.ensure_synthetic_dataset(cache, seed=2)
    assert calls == [1, 2]                                        # another seed: rebuilt


def test_cli_simulate_end_to_end(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = tmp_path / "syn"
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "simulate", "--out", str(out), "--seed", "5",
                        "--runs-per-folder", "1"], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    assert str(out) in r.stdout
    c = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "check", "--data", str(out)],
                       capture_output=True, text=True, cwd=tmp_path, env=env)
    assert c.returncode == 0, c.stdout + c.stderr
    bad = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "simulate", "--out", str(tmp_path),
                          "--runs-per-folder", "1"], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "not a synthetic dataset" in bad.stderr + bad.stdout


@pytest.mark.parametrize("call, word", [
    (lambda: simulate.straight(6.3, speed_mps=-1.0), "speed_mps"),
    (lambda: simulate.straight(-2.0), "length_m"),
    (lambda: simulate.straight(6.3, speed_mps=10.0), "speed_mps"),
    (lambda: simulate.sine(6.3, p2p_m=0.0), "p2p_m"),
    (lambda: simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.5), "amplitude_m"),
    (lambda: simulate.sine(6.3, amplitude_m=float("nan")), "amplitude_m"),
    (lambda: simulate.sine(1.0, p2p_m=1.0), "taper"),
    (lambda: simulate.sine(6.3, rest_s=-1.0), "rest"),
    (lambda: simulate.straight(6.3, rate_hz=0), "rate_hz"),
    (lambda: simulate.l_route((18.0, 10.0), turn_deg=0.0), "turn_deg"),
    (lambda: simulate.l_route((18.0, 10.0), turn_radius_m=-1.0), "turn_radius"),
    (lambda: simulate.l_route((18.0, 10.0), turn_radius_m=30.0), "turn_radius"),
    (lambda: simulate.l_route((18.0,)), "legs"),
    (lambda: simulate.l_route((18.0, 10.0), p2p_m=1.0), "p2p_m, amplitude_m"),
    (lambda: simulate.l_route((18.0, 10.0), slope_deg=15, slope_length_m=17.0), "slope_length_m"),
    (lambda: simulate.l_route((18.0, 10.0), p2p_m=1.0, amplitude_m=0.6), "amplitude_m"),
    (lambda: simulate.imu(simulate.straight(), units.MPU6500, np.random.default_rng(0), runs=0), "runs"),
    (lambda: simulate.imu(simulate.straight(), units.MPU6500, np.random.default_rng(0), sampling="s7"), "sampling"),
    (lambda: simulate.imu(simulate.straight(), units.MPU6500, np.random.default_rng(0), noise_scale=-1), "noise_scale"),
    (lambda: simulate.imu(simulate.straight(), units.MPU6500, [np.random.default_rng(0)], runs=2), "rng"),
    (lambda: simulate.imu(simulate.straight(), units.MPU6500, [np.random.default_rng(0)], runs=1, sampling="two-rate"),
     "sampling"),
    (lambda: simulate.route_trajectory("nowhere"), "route"),
    (lambda: synthetic.write_dataset("/tmp/never-written-x", seed=-1), "seed"),
    (lambda: synthetic.write_dataset("/tmp/never-written-x", runs_per_folder=0), "runs_per_folder"),
])
def test_bad_parameters_raise_naming_them(call, word):
    with pytest.raises(MorpiError) as exc:
        call()
    msg = str(exc.value)
    assert word in msg and "\n" not in msg


def test_analysis_script_writes_figure(tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "analysis"))
    try:
        import synthetic_dataset
    finally:
        sys.path.pop(0)
    out = tmp_path / "fig" / "run.png"
    synthetic_dataset.main(["--seed", "2", "--phone", "s6", "--out", str(out)])
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = capsys.readouterr().out
    # the noise-free line of the printout: integration error only, under the 1 mm bar
    line = next(s for s in text.splitlines() if s.startswith("3D INS, noise-free"))
    assert float(line.split()[-2]) < 1.0


def _rest_stats(recordings):
    """Per-phone gyro offset RMS over the first 2.5 s [rad/s] and median sample intervals."""
    out = {}
    for rec in recordings:
        k = rec.time < rec.time[0] + 2.5
        out.setdefault(rec.phone, {"w": [], "dt": []})
        out[rec.phone]["w"].append(rec.omega[k].mean(axis=0))
        out[rec.phone]["dt"].append(np.median(np.diff(rec.time)))
    return {p: (np.sqrt(np.mean(np.square(v["w"]))), np.array(v["dt"])) for p, v in out.items()}


@pytest.mark.field
def test_synthetic_rest_periods_resemble_the_field(field_root, small_dataset):
    """The realism choices, checked against the recordings: gyro offsets at rest (turn-on bias
    at REALISTIC_BIAS_FRACTION) of the same order, and S6 time stamps in the field's range."""
    field = _rest_stats(e.load() for e in dataset.catalogue(field_root))
    syn = _rest_stats(e.load() for e in dataset.catalogue(small_dataset))
    for phone in ("s6", "s8"):
        # same order of magnitude: within a factor 3 (field: 0.3-2 deg/s per axis; the synthetic
        # estimate rests on five or six runs, so a tighter bar would test the draw, not the model)
        assert 1 / 3 < syn[phone][0] / field[phone][0] < 3
    lo, hi = field["s6"][1].min(), field["s6"][1].max()
    # 1 ms slack: the synthetic S6 share of slow intervals is drawn per run
    assert np.all((syn["s6"][1] > lo - 1e-3) & (syn["s6"][1] < hi + 1e-3))
    assert np.all(np.abs(syn["s8"][1] - np.median(field["s8"][1])) < 2e-4)


def _z_rate_peaks(recordings):
    """Median |omega_z| at its peaks (15-sample moving average, rest offset removed) [rad/s]."""
    from scipy.ndimage import uniform_filter1d
    from scipy.signal import find_peaks

    out = []
    for rec in recordings:
        w = uniform_filter1d(rec.omega[:, 2] - rec.omega[:150, 2].mean(), 15)
        k, _ = find_peaks(np.abs(w), prominence=0.3, distance=40)
        out.append(np.median(np.abs(w[k])))
    return float(np.median(out))


@pytest.mark.field
def test_synthetic_periodic_motion_resembles_the_field(field_root, small_dataset):
    """The amplitude choice (DATASET_OPTIONS["amplitude_factor"]) against the recordings: the
    z-rate peaks of the periodic routes are of the field's size, not 2.5 times larger."""
    for folder in ("s8/short_distance/train", "s8/short_distance_1.5p2p/train", "s6/short_distance/train"):
        phone, route, split = folder.split("/")
        field = _z_rate_peaks(dataset.load_catalogue(field_root, phone=phone, route=route, split=split))
        syn = _z_rate_peaks(dataset.load_catalogue(small_dataset, phone=phone, route=route, split=split))
        # field medians 0.72-0.99 rad/s; one synthetic run per folder varies by about +-30 %
        # (speed and amplitude spread), so the bar is a factor 1.6 either way; the full
        # stated amplitude gives a ratio near 2.5
        assert 1 / 1.6 < syn / field < 1.6, (folder, syn, field)
