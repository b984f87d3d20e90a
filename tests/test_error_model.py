"""Tests of the numeric error model: F, G, Q, Van Loan discretization, linear Monte Carlo."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from morpi_filters import units
from morpi_filters.error_model import (
    BA, BG, DP, DV, EPS, N_STATES, P2_BA, P2_BG, P2_DP, P2_DV, P2_PSI, STATE_NAMES,
    discretize, noise_coupling, noise_density, paper_trajectory, planar_noise_coupling,
    planar_noise_density, planar_system_matrix, simulate_linear, skew, system_matrix,
)
from morpi_filters.errors import MorpiError


def test_slices_cover_the_state_once():
    idx = np.concatenate([np.arange(N_STATES)[s] for s in (DP, DV, EPS, BA, BG)])
    assert np.array_equal(idx, np.arange(N_STATES))
    assert len(STATE_NAMES) == N_STATES and STATE_NAMES[EPS] == ("eps_x", "eps_y", "eps_z")


def test_skew_is_the_cross_product():
    rng = np.random.default_rng(11)
    a, b = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    assert np.allclose(skew(a) @ b[..., None], np.cross(a, b)[..., None], atol=1e-15)  # cross product two ways on unit-scale vectors: float rounding


def test_F_blocks_and_stack():
    rng = np.random.default_rng(3)
    C = Rotation.random(5, random_state=4).as_matrix()
    f = rng.normal(size=(5, 3))
    F = system_matrix(C, f)
    assert F.shape == (5, 15, 15)
    assert np.array_equal(F[2], system_matrix(C[2], f[2]))
    assert np.array_equal(F[:, DP, DV], np.broadcast_to(np.eye(3), (5, 3, 3)))
    assert np.array_equal(F[:, DV, EPS], -skew(f))
    assert np.array_equal(F[:, DV, BA], C) and np.array_equal(F[:, EPS, BG], C)
    # everything else zero
    mask = np.ones((15, 15), bool)
    for r, c in ((DP, DV), (DV, EPS), (DV, BA), (EPS, BG)):
        mask[r, c] = False
    assert not F[:, mask].any()


def test_F_sign_convention_matches_the_linearized_mechanization():
    """dv_dot = C_hat f_hat - C f with C_hat = (I + [eps x]) C, f_hat = f + b_a (first order)."""
    rng = np.random.default_rng(8)
    C = Rotation.random(random_state=9).as_matrix()
    f_b = rng.normal(size=3)
    eps, ba = 1e-7 * rng.normal(size=3), 1e-7 * rng.normal(size=3)
    C_hat = Rotation.from_rotvec(eps).as_matrix() @ C
    dv_dot = C_hat @ (f_b + ba) - C @ f_b
    x = np.zeros(15)
    x[EPS], x[BA] = eps, ba
    F = system_matrix(C, C @ f_b)
    # second-order residual ~ |eps| |ba| ~ 1e-14 relative to 1e-7 terms
    assert np.allclose((F @ x)[DV], dv_dot, rtol=0, atol=1e-12)


def test_paper_polynomials_z_up():
    """dp_x = dv_x t + b_ax t^2/2 + g b_gy t^3/6; dp_y = ... - g b_gx t^3/6 (z-up)."""
    g, t = 9.81, 2.7
    C, f = paper_trajectory(g)
    x0 = np.zeros(15)
    x0[DV] = [0.1, -0.2, 0.05]
    x0[BA] = [0.03, 0.02, -0.01]
    x0[BG] = [0.004, -0.003, 0.002]
    x = expm(system_matrix(C, f) * t) @ x0
    dvx, dvy = x0[DV][:2]
    bax, bay = x0[BA][:2]
    bgx, bgy = x0[BG][:2]
    # exact: the z-up linear model has no b_a x b_g products; expm to rounding
    assert x[DP][0] == pytest.approx(dvx * t + bax * t**2 / 2 + g * bgy * t**3 / 6, rel=1e-12)
    assert x[DP][1] == pytest.approx(dvy * t + bay * t**2 / 2 - g * bgx * t**3 / 6, rel=1e-12)


def test_discretize_double_integrator_closed_form():
    """x = [p, v], w on v: Phi = [[1, dt], [0, 1]], Qd = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]."""
    F = np.array([[0.0, 1.0], [0.0, 0.0]])
    G = np.array([[0.0], [1.0]])
    q, dt = 0.7, 0.37
    Phi, Qd = discretize(F, G, [[q]], dt)
    assert np.allclose(Phi, [[1, dt], [0, 1]], rtol=0, atol=1e-15)  # exact for a nilpotent F: float rounding
    want = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    assert np.allclose(Qd, want, rtol=1e-13, atol=0)  # nilpotent: finite series, exact to rounding


def test_discretize_random_15_state_against_quadrature():
    rng = np.random.default_rng(20240501)
    F = 0.3 * rng.normal(size=(15, 15))
    G = rng.normal(size=(15, 6))
    A = rng.normal(size=(6, 6))
    Q = A @ A.T
    dt = 0.5
    Phi, Qd = discretize(F, G, Q, dt)
    # both are scipy's expm here (F is not nilpotent): rounding only
    assert np.allclose(Phi, expm(F * dt), rtol=1e-12, atol=1e-13)
    ref, err = quad_vec(lambda s: expm(F * s) @ G @ Q @ G.T @ expm(F * s).T, 0, dt, epsabs=1e-13, epsrel=1e-12)
    # quad_vec's own error estimate is ~1e-13; allow 1e-10 relative to the norm
    assert np.abs(Qd - ref).max() <= 1e-10 * np.abs(ref).max()
    assert np.array_equal(Qd, Qd.T)


def test_discretize_stack_equals_single_steps():
    rng = np.random.default_rng(5)
    C = Rotation.random(4, random_state=6).as_matrix()
    f = rng.normal(size=(4, 3)) + [0, 0, 9.8]
    F, G = system_matrix(C, f), noise_coupling(C)
    Q = noise_density(units.MPU6500, 1e-4, 1e-5)
    dt = np.array([0.01, 0.011, 0.009, 0.0105])
    D = discretize(F, G, Q, dt)
    for i in range(4):
        # the same arithmetic on a stack or one matrix: rounding-level differences only
        Phi_i, Qd_i = discretize(F[i], G[i], Q, dt[i])
        assert np.allclose(D.Phi[i], Phi_i, rtol=1e-14, atol=1e-16)
        assert np.allclose(D.Qd[i], Qd_i, rtol=1e-12, atol=1e-22)  # the same integral two ways: float rounding (atol for zero entries of size 1e-22)


def test_noise_density_from_spec():
    Q = noise_density(units.LSM6DSL)
    assert Q.shape == (12, 12)
    assert np.allclose(np.diag(Q)[:3], (130 * units.UG_SQRT_HZ) ** 2)  # the datasheet density squared; default tolerances, values are exact up to rounding
    assert np.allclose(np.diag(Q)[3:6], (0.004 * units.DEG_S_SQRT_HZ) ** 2)  # the datasheet density squared; default tolerances, values are exact up to rounding
    assert not np.diag(Q)[6:].any()
    with pytest.raises(MorpiError, match="gyro_bias_walk"):
        noise_density(units.LSM6DSL, gyro_bias_walk=-1.0)


def test_planar_model_is_the_heading_restriction_of_the_15_state_model():
    rng = np.random.default_rng(12)
    psi = rng.uniform(-3, 3, size=5)
    f_xy = rng.normal(size=(5, 2))
    C = Rotation.from_euler("z", psi[:, None]).as_matrix()
    f = np.column_stack([f_xy, np.full(5, 9.81)])
    F3 = system_matrix(C, f)
    G3 = noise_coupling(C)
    # map planar states into the 15-state vector
    idx = [0, 1, 3, 4, 8, 9, 10, 14]
    F2 = planar_system_matrix(psi, f_xy)
    assert np.allclose(F2, F3[:, idx][:, :, idx], atol=1e-15)  # the planar model is a sub-block of the 3D one: exact up to rounding
    G2 = planar_noise_coupling(psi)
    assert np.allclose(G2, G3[:, idx][:, :, [0, 1, 5, 6, 7, 11]], atol=1e-15)  # cos/sin entries: rounding
    Q2 = planar_noise_density(units.MPU6500)
    assert np.allclose(np.diag(Q2), np.diag(noise_density(units.MPU6500))[[0, 1, 5, 6, 7, 11]])  # sub-block of the 3D noise density: default tolerances, exact up to rounding
    names = [s.start for s in (P2_DP, P2_DV, P2_PSI, P2_BA, P2_BG)]
    assert names == [0, 2, 4, 5, 7]


def test_bad_shapes_raise():
    with pytest.raises(MorpiError, match="C_b"):
        system_matrix(np.eye(2), [0, 0, 1])
    with pytest.raises(MorpiError, match="dt_s"):
        discretize(np.zeros((2, 2)), np.zeros((2, 1)), [[1.0]], -0.1)
    with pytest.raises(MorpiError, match="Q"):
        discretize(np.zeros((2, 2)), np.zeros((2, 1)), np.eye(2), 0.1)


def test_linear_monte_carlo_matches_van_loan_covariance():
    """Sampled-noise runs vs Phi P0 Phi^T + sum Phi Qd Phi^T.

    Tolerance: each diagonal sample variance over N runs has relative standard
    deviation sqrt(2/N) (chi-square with N degrees of freedom); 4 of those.
    """
    C, f = paper_trajectory(9.81)
    F, G = system_matrix(C, f), noise_coupling(C)
    Q = noise_density(units.MPU6500, accel_bias_walk=1e-3, gyro_bias_walk=1e-4)
    P0 = np.diag(np.r_[np.zeros(3), np.full(3, 0.05**2), np.zeros(3), np.full(3, 0.01**2), np.full(3, 1e-3**2)])
    dt, n, N = 0.05, 100, 4000
    X = simulate_linear(F, G, Q, P0, dt, n, N, np.random.default_rng(77))
    Phi, Qd = discretize(F, G, Q, dt)
    P = P0
    for _ in range(n):
        P = Phi @ P @ Phi.T + Qd
    var = (X[:, -1] ** 2).mean(axis=0)
    d = np.diag(P)
    keep = d > 0
    rel = np.abs(var[keep] / d[keep] - 1)
    assert rel.max() < 4 * np.sqrt(2 / N)


def test_nilpotent_series_path_against_scipy_expm_and_quadrature():
    """The INS model is nilpotent: discretize() sums a finite series; check it independently."""
    rng = np.random.default_rng(21)
    C = Rotation.random(3, random_state=22).as_matrix()
    f = rng.normal(size=(3, 3)) + [0, 0, 9.8]
    F, G = system_matrix(C, f), noise_coupling(C)
    assert not np.linalg.matrix_power(F[0], 5).any()  # F^5 = 0 exactly
    Q = noise_density(units.MPU6500, 1e-3, 1e-4)
    dt = np.array([0.01, 0.5, 2.0])
    D = discretize(F, G, Q, dt)
    for i in range(3):
        # finite series vs Pade approximant: both accurate to ~1e-15 relative
        assert np.allclose(D.Phi[i], expm(F[i] * dt[i]), rtol=1e-13, atol=1e-14)
    ref, _ = quad_vec(lambda s: expm(F[1] * s) @ G[1] @ Q @ G[1].T @ expm(F[1] * s).T, 0, dt[1],
                      epsabs=1e-16, epsrel=1e-12)
    # quadrature error estimate ~1e-13 relative; bar 1e-10 of the largest entry
    assert np.abs(D.Qd[1] - ref).max() <= 1e-10 * np.abs(ref).max()
