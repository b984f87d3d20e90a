"""Tests of the error-state filter: closed forms, Monte Carlo, consistency, long-run P health."""
from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from morpi_filters import units
from morpi_filters.error_model import (
    DP, DV, EPS, discretize, noise_coupling, noise_density, paper_trajectory,
    simulate_linear, system_matrix,
)
from morpi_filters.errors import MorpiError
from morpi_filters.eskf import (
    C_DP, C_EPS, GAIN, SYMMETRIZE_EVERY, Measurement, StepModel, augment, augment_covariance, chi2_band,
    initial_covariance, nees, propagate_covariance, run_filter, simulate_steps, step_update, step_z,
)

G_MPS2 = 9.81
SV, SA, SG = np.array([0.05, 0.08, 0.02]), np.array([0.3, 0.2, 0.1]), np.array([0.01, 0.02, 0.005])


def _paper_model(noise, dt):
    C, f = paper_trajectory(G_MPS2)
    F, G = system_matrix(C, f), noise_coupling(C)
    Q = noise_density(units.MPU6500) * (1.0 if noise else 0.0)
    return F, G, Q, discretize(F, G, Q, dt)


def _hand_horizontal_variance(t):
    """E[dp_x^2 + dp_y^2] from the z-up polynomials, independent 1-sigma terms.

    dp_x = dv_x t + b_ax t^2/2 + g b_gy t^3/6,  dp_y = dv_y t + b_ay t^2/2 - g b_gx t^3/6
    """
    return ((SV[0] ** 2 + SV[1] ** 2) * t ** 2 + (SA[0] ** 2 + SA[1] ** 2) * t ** 4 / 4
            + G_MPS2 ** 2 * (SG[0] ** 2 + SG[1] ** 2) * t ** 6 / 36)


def test_noise_off_variance_equals_the_closed_form_expectation():
    dt, n = 0.01, 1500
    _, _, _, (Phi, Qd) = _paper_model(False, dt)
    t = np.arange(n + 1) * dt
    r = run_filter(Phi, Qd, initial_covariance(SV, SA, SG), t)
    want = _hand_horizontal_variance(t)
    got = r.horizontal_sigma ** 2
    assert got[0] == 0.0
    # bar 1e-9 relative (acceptance bar); the two differ only by rounding of 1500 products
    assert np.max(np.abs(got[1:] / want[1:] - 1)) < 1e-9
    # second, independent route: the sympy-derived mean square of the same polynomials
    from morpi_filters.symbolic import closed_form_mean_square

    sig = {"dv0_mps": SV.tolist(), "accel_bias_mps2": SA.tolist(), "gyro_bias_radps": SG.tolist(), "g_mps2": G_MPS2}
    sym = closed_form_mean_square(sig, t, "INS-3D", "z_up", linearized=True, keep_bgz=False)
    assert np.max(np.abs(got[1:] / sym[1:] - 1)) < 1e-9


def test_noise_on_variance_matches_the_linear_monte_carlo():
    dt, n, N = 0.05, 300, 3000
    F, G, Q, (Phi, Qd) = _paper_model(True, dt)
    P0 = initial_covariance(SV, SA, SG)
    t = np.arange(n + 1) * dt
    r = run_filter(Phi, Qd, P0, t)
    X = simulate_linear(F, G, Q, P0, dt, n, N, np.random.default_rng(4242))
    for axis in (0, 1):
        var_mc = (X[:, -1, axis] ** 2).mean()
        # N * var_mc / var is chi-square with N dof (zero-mean Gaussian); the
        # 99.9% two-sided band, i.e. roughly 1 +/- 3.3 sqrt(2/N) = 1 +/- 8.5%.
        lo, hi = chi2_band(1, N, confidence=0.999)
        assert lo < var_mc / r.sigma[-1, axis] ** 2 < hi
    # the noise matters at this size: the noise-free variance is measurably smaller
    _, _, _, (Phi0, Qd0) = _paper_model(False, dt)
    r0 = run_filter(Phi0, Qd0, P0, t)
    assert r0.horizontal_sigma[-1] < r.horizontal_sigma[-1]


def test_batched_epoch_propagation_equals_the_filterpy_loop():
    dt, n = 0.01, 1500
    _, _, _, (Phi, Qd) = _paper_model(True, dt)
    P0 = initial_covariance(SV, SA, SG, dp0=0.01, eps0=1e-3)
    r = run_filter(Phi, Qd, P0, np.arange(n + 1) * dt, keep_P=True)
    Pb = propagate_covariance(Phi, Qd, P0, n)
    # same algebra, different association of ~1500 products: rounding only
    np.testing.assert_allclose(Pb, r.P, rtol=1e-10, atol=1e-14)


def test_filterpy_predict_update_equivalence():
    """One predict/update of run_filter equals filterpy driven by hand (no mutation of F)."""
    rng = np.random.default_rng(9)
    k = 4
    Phi = np.eye(k) + 0.1 * rng.normal(size=(k, k))
    Qd = np.diag(rng.uniform(0.1, 1.0, k))
    H = rng.normal(size=(2, k))
    R = np.diag([0.3, 0.5])
    z = rng.normal(size=2)
    P0 = np.eye(k)
    r = run_filter(Phi, Qd, P0, [0.0, 1.0], [Measurement(1, z, H, R)])
    kf = KalmanFilter(dim_x=k, dim_z=2)
    kf.x, kf.P = np.zeros(k), P0.copy()
    kf.predict(F=Phi, Q=Qd)
    y = z - H @ kf.x
    kf.update(z, R=R, H=H)
    # identical operations; only the symmetrization of P differs, by rounding
    assert np.allclose(r.x[-1], kf.x, rtol=1e-14, atol=1e-15)
    assert np.allclose(r.P_end, 0.5 * (kf.P + kf.P.T), rtol=1e-14, atol=1e-15)
    assert np.allclose(r.innovations[0], y)  # the innovation y itself; default tolerances
    assert np.allclose(r.nis[0], y @ np.linalg.solve(kf.S, y), rtol=1e-12)  # the same quadratic form two ways: float rounding


def test_run_filter_predictions_are_filterpy_predict_bit_for_bit():
    """The written-out prediction of run_filter gives filterpy's predict() numbers exactly."""
    # exact: both sides make the same numpy calls (dot(dot(F, P), F.T) + Q) on the same values in the same order,
    # so whatever order numpy sums in, it sums in on both sides
    rng = np.random.default_rng(11)
    k, n = 6, 250
    Phi = np.eye(k) + 0.05 * rng.normal(size=(n, k, k))
    Qd = np.diag(rng.uniform(0.1, 1.0, k))
    P0, x0 = np.eye(k), rng.normal(size=k)
    r = run_filter(Phi, Qd, P0, np.arange(n + 1.0), x0=x0, keep_P=True)
    kf = KalmanFilter(dim_x=k, dim_z=1)
    kf.x, kf.P = x0.copy(), P0.copy()
    for i in range(n):
        kf.predict(F=Phi[i], Q=Qd)
        if (i + 1) % SYMMETRIZE_EVERY == 0 or i + 1 == n:
            kf.P = 0.5 * (kf.P + kf.P.T)
        assert np.array_equal(r.x[i + 1], kf.x)
        assert np.array_equal(r.P[i + 1], 0.5 * (kf.P + kf.P.T))
    assert np.array_equal(r.P_end, kf.P)


def _sine_path(n, dt):
    """A heading oscillating like the MoRPI sine path, with horizontal accelerations."""
    t = np.arange(n) * dt
    psi = 0.4 * np.sin(2 * np.pi * t)
    c, s = np.cos(psi), np.sin(psi)
    C = np.zeros((n, 3, 3))
    C[:, 0, 0], C[:, 0, 1], C[:, 1, 0], C[:, 1, 1], C[:, 2, 2] = c, -s, s, c, 1.0
    f = np.column_stack([0.3 * np.cos(2 * np.pi * t), 1.5 * np.sin(2 * np.pi * t), np.full(n, G_MPS2)])
    return C, f


@pytest.fixture(scope="module")
def sine_runs():
    """500 seeded runs of the linear model along the sine path (15 s at 100 Hz)."""
    dt, n, N = 0.01, 1500, 500
    C, f = _sine_path(n, dt)
    F, G = system_matrix(C, f), noise_coupling(C)
    Q = noise_density(units.LSM6DSL)
    P0 = initial_covariance(SV, SA, SG, dp0=0.01, eps0=2e-3)
    X = simulate_linear(F, G, Q, P0, dt, n, N, np.random.default_rng(20230915))
    return dict(dt=dt, n=n, N=N, D=discretize(F, G, Q, dt), P0=P0, X=X, t=np.arange(n + 1) * dt)


def _anees_checks(err, P, N, dof):
    a = nees(err, P).mean(axis=0)
    lo, hi = chi2_band(dof, N)
    inside = np.mean((a > lo) & (a < hi))
    return a, lo, hi, inside


def test_ins_alone_nees_inside_the_chi_square_band(sine_runs):
    d = sine_runs
    idx = np.arange(10, d["n"] + 1, 10)
    r = run_filter(d["D"].Phi, d["D"].Qd, d["P0"], d["t"], keep_P=idx)
    sel = np.r_[np.arange(15)[DP], np.arange(15)[DV]]
    err = 0.0 - d["X"][:, idx][..., sel]  # no measurement: the estimate stays zero
    P = r.P[:, sel][:, :, sel]
    a, lo, hi, inside = _anees_checks(err, P, d["N"], 6)
    assert lo < a[-1] < hi
    # per-epoch averages are correlated over time; a consistent filter lands in
    # the 95% band at ~95% of the epochs, a wrong one at few. Bar: 80%.
    assert inside >= 0.8


def _morpi_setup(d, model, rng):
    every = 100  # one step per second
    steps = np.arange(every, d["n"] + 1, every)
    gain = model.gain_sigma * rng.standard_normal(d["N"])
    meas = simulate_steps(d["X"], steps, 1.0, 0.0, model, 1.0, gain, rng)
    Phi_a, Qd_a = augment(d["D"].Phi, d["D"].Qd, model)
    return steps, gain, meas, Phi_a, Qd_a, augment_covariance(d["P0"], model)


def test_morpi_aided_nees_and_nis_inside_the_chi_square_band(sine_runs):
    d = sine_runs
    model = StepModel(gain_sigma=0.05, jitter_s=0.01, step_sigma=0.02, cross_sigma_m=0.02)
    steps, gain, meas, Phi_a, Qd_a, P0a = _morpi_setup(d, model, np.random.default_rng(77))
    idx = np.arange(10, d["n"] + 1, 10)
    r = run_filter(Phi_a, Qd_a, P0a, d["t"], meas, keep_P=idx)
    sel = np.r_[np.arange(15)[DP], np.arange(15)[DV]]
    err = r.x[:, idx][..., sel] - d["X"][:, idx][..., sel]
    P = r.P[:, sel][:, :, sel]
    a, lo, hi, inside = _anees_checks(err, P, d["N"], 6)
    assert lo < a[-1] < hi
    assert inside >= 0.8  # see test_ins_alone_nees_inside_the_chi_square_band
    # the aiding works: the horizontal sigma at 15 s is far below INS alone
    assert r.horizontal_sigma[-1] < 0.1 * run_filter(d["D"].Phi, d["D"].Qd, d["P0"], d["t"]).horizontal_sigma[-1]
    # gain state: error against the true gain is consistent (1 dof)
    eg = (r.x[:, -1, GAIN.start] - gain) ** 2 / r.sigma[-1, GAIN.start] ** 2
    lo1, hi1 = chi2_band(1, d["N"])
    assert lo1 < eg.mean() < hi1
    # innovations of a consistent filter are white: the NIS averaged over all
    # runs and updates is chi-square with runs * updates * 2 dof
    nis = r.nis
    lo2, hi2 = chi2_band(2, nis.size)
    assert lo2 < nis.mean() < hi2
    # each whitened component has unit variance (same band, 1 dof per sample)
    w = r.normalized_innovations
    lo3, hi3 = chi2_band(1, w[..., 0].size)
    assert lo3 < (w[..., 0] ** 2).mean() < hi3 and lo3 < (w[..., 1] ** 2).mean() < hi3


def test_white_gain_model_is_detected_as_inconsistent(sine_runs):
    """A gain error treated as white noise (shared in truth) fails the same NEES check."""
    d = sine_runs
    model = StepModel(gain_sigma=0.05, augment_gain=False)
    steps, gain, meas, Phi_a, Qd_a, P0a = _morpi_setup(d, model, np.random.default_rng(78))
    r = run_filter(Phi_a, Qd_a, P0a, d["t"], meas, keep_P=[d["n"]])
    sel = np.r_[np.arange(15)[DP], np.arange(15)[DV]]
    err = r.x[:, -1][:, sel] - d["X"][:, -1][:, sel]
    a = nees(err[:, None], r.P[:, sel][:, :, sel]).mean()
    assert a > chi2_band(6, d["N"])[1]


def test_batched_runs_equal_single_filterpy_runs(sine_runs):
    d = sine_runs
    model = StepModel()
    steps, gain, meas, Phi_a, Qd_a, P0a = _morpi_setup(d, model, np.random.default_rng(5))
    n = 400
    meas = [m for m in meas if m.index <= n]
    rb = run_filter(Phi_a[:n], Qd_a[:n], P0a, d["t"][: n + 1], meas)
    for j in (0, 3, 17):
        mj = [Measurement(m.index, m.z[j], m.H, m.R, m.reset) for m in meas]
        rj = run_filter(Phi_a[:n], Qd_a[:n], P0a, d["t"][: n + 1], mj)
        # same gains, same operations on one row vs a stacked matrix: BLAS rounding only
        np.testing.assert_allclose(rb.x[j], rj.x, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(rb.innovations[j], rj.innovations, rtol=1e-10, atol=1e-12)


def test_P_stays_symmetric_and_psd_over_ten_minutes():
    dt, n = 0.01, 60_000  # 10 min at 100 Hz
    _, _, _, (Phi, Qd) = _paper_model(True, dt)
    model = StepModel()
    Phi_a, Qd_a = augment(Phi, Qd, model)
    P0a = augment_covariance(initial_covariance(SV, SA, SG, dp0=0.01, eps0=1e-3), model)
    steps = np.arange(100, n + 1, 100)  # one MoRPI update per second
    meas = [step_update(i, 1.0, 0.0, model, 1.0) for i in steps]
    keep = np.r_[steps - 1, steps]  # right before and after every update
    r = run_filter(Phi_a, Qd_a, P0a, np.arange(n + 1) * dt, meas, keep_P=keep)
    P = r.P
    scale = np.abs(P).max(axis=(1, 2))
    asym = np.abs(P - np.swapaxes(P, 1, 2)).max(axis=(1, 2)) / scale
    # symmetrized after each update; filterpy's Phi P Phi^T + Qd between updates
    # is symmetric only to rounding (a few float64 ulps, 2.2e-16 each): bar 1e-14
    assert asym.max() < 1e-14
    eig = np.linalg.eigvalsh(P)
    # PSD to rounding: eigenvalues >= -1e-12 of the largest (float64 eps ~ 2e-16, 15-22 states)
    assert (eig.min(axis=1) >= -1e-12 * scale).all()
    assert np.isfinite(r.sigma).all()


def test_step_measurement_model_matches_a_direct_computation():
    """H x equals the first-order difference of the INS and MoRPI displacements."""
    rng = np.random.default_rng(31)
    s, psi, model = 1.2, 0.7, StepModel()
    m = step_update(5, s, psi, model, 1.0)
    x = np.zeros(model.n_states)
    x[DP], x[C_DP] = 1e-6 * rng.normal(size=3), 1e-6 * rng.normal(size=3)
    x[EPS], x[C_EPS] = 1e-6 * rng.normal(size=3), 1e-6 * rng.normal(size=3)
    x[GAIN] = 1e-6 * rng.normal()
    p_c, p_k = np.array([2.0, 1.0]), np.array([2.0, 1.0]) + s * np.array([np.cos(psi), np.sin(psi)])
    psi_hat = psi + 0.5 * (x[EPS][2] + x[C_EPS][2])
    z = step_z(p_k + x[DP][:2], p_c + x[C_DP][:2], s * (1 + x[GAIN][0]), psi_hat)
    # second-order terms ~ (1e-6)^2
    assert np.allclose(m.H @ x, z, rtol=0, atol=1e-11)
    assert np.allclose(m.reset @ x, np.r_[x[:15], x[DP], x[EPS], x[GAIN]])


def test_bad_inputs_raise():
    with pytest.raises(MorpiError, match="jitter_s"):
        StepModel(jitter_s=-1)
    with pytest.raises(MorpiError, match="P0"):
        run_filter(np.eye(3), np.eye(3), np.eye(2), [0.0, 1.0])
    with pytest.raises(MorpiError, match="index"):
        bad = Measurement(5, np.zeros(1), np.ones((1, 2)), np.eye(1))
        run_filter(np.eye(2), np.eye(2), np.eye(2), [0.0, 1.0], [bad])


