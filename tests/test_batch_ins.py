"""The batched Monte Carlo strapdown kernel against morpi_filters.strapdown and closed forms."""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import montecarlo as mc
from morpi_filters.montecarlo import _batch_ins as bi
from morpi_filters.montecarlo import engine as mce
from conftest import plain_kernels


def _planes(a):
    return [np.ascontiguousarray(a[:, :, i].T) for i in range(3)]


@pytest.mark.parametrize("path, noise, tol", [
    # biases only: the kernel and strapdown.ins3d differ only by strapdown's Hermite end slopes
    # and coning term, O(dt^2). Measured 3.9e-7 relative on the straight line (bar 1e-6) and
    # 1.9e-5 on the sine, whose heading turns at up to 1.6 rad/s (bar 1e-4).
    ("straight", 0.0, 1e-6),
    ("sine", 0.0, 1e-4),
    # with white noise the two rules integrate each noise sample slightly differently;
    # measured up to 1.6e-4 relative on 4 runs on either path, bar 3e-4.
    ("straight", 1.0, 3e-4),
    ("sine", 1.0, 3e-4),
])
def test_path_kernels_match_strapdown(path, noise, tol):
    # each side's error is its position from the measured signals minus its position from the
    # true ones, the same subtraction the study makes
    from morpi_filters import strapdown

    cfg = mc.StudyConfig(ins_path=path)
    ins_path = mce._paths(cfg)[0]
    assert (np.abs(ins_path.omega_b[:, 2]).max() > 0.1) == (path == "sine")
    n, R, h = ins_path.time.size, 4, 1.0 / cfg.rate_hz
    keep = np.array([0, 500, n - 1])
    rng = np.random.default_rng(3)
    f0, w0 = ins_path.f_b, ins_path.omega_b
    f = f0 + 0.5 * rng.standard_normal((R, 1, 3)) + noise * 0.03 * rng.standard_normal((R, n, 3))
    w = w0 + 0.05 * rng.standard_normal((R, 1, 3)) + noise * 0.002 * rng.standard_normal((R, n, 3))
    heading, ((tx3, ty3), (tx2, ty2)) = mce._ins_truth(ins_path, h, keep)
    x, y = bi.horizontal_3d(h, _planes(f), _planes(w), keep)
    t = ins_path.time
    p, p0 = strapdown.ins3d(t, f, w).position, strapdown.ins3d(t, f0, w0).position
    e_sd = np.hypot(p[:, keep, 0] - p0[keep, 0], p[:, keep, 1] - p0[keep, 1])
    np.testing.assert_allclose(np.hypot(x - tx3, y - ty3).T[:, 1:], e_sd[:, 1:], rtol=tol)
    # the planar INS: the heading is the truth's (same rule) plus the integrated rate error
    wz = (w - w0)[:, :, 2].T
    psi = np.zeros((n, R))
    psi[1:] = np.cumsum(wz[:-1], axis=0)
    psi = h * (psi + 0.5 * (wz - wz[0]))
    x, y = bi.horizontal_2d(_planes(f), psi, h, keep, heading=heading)
    p, p0 = strapdown.ins2d(t, f, w).position, strapdown.ins2d(t, f0, w0).position
    e_sd = np.hypot(p[:, keep, 0] - p0[keep, 0], p[:, keep, 1] - p0[keep, 1])
    np.testing.assert_allclose(np.hypot(x - tx2, y - ty2).T[:, 1:], e_sd[:, 1:], rtol=tol)


def test_truth_through_the_kernels_follows_the_path():
    # the kernels on the error-free signals retrace the simulated path: what the study
    # subtracts is the path itself up to the integration rule (trapezoid, O(dt^2))
    cfg = mc.StudyConfig(duration_s=20.0)
    sine = mce._paths(cfg)[1]
    keep = np.arange(0, sine.time.size, 100)
    _, ((x3, y3), (x2, y2)) = mce._ins_truth(sine, 1.0 / cfg.rate_hz, keep)
    for x, y in ((x3, y3), (x2, y2)):
        # measured 2e-5 m over 8.9 m; bar 1 mm
        np.testing.assert_allclose(x[:, 0], sine.position[keep, 0], atol=1e-3)
        np.testing.assert_allclose(y[:, 0], sine.position[keep, 1], atol=1e-3)


def test_double_integral_of_a_ramp_is_exact():
    # a = c t is linear in each interval, so the trapezoid rule gives p = c t^3 / 6 exactly
    h, n = 0.01, 301
    t = np.arange(n) * h
    keep = np.array([0, 1, 150, n - 1])
    p = bi.double_integral_at((2.5 * t)[:, None], h, keep)[:, 0]
    np.testing.assert_allclose(p, 2.5 * t[keep] ** 3 / 6, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("rate", [
    (1e-6, 0.0, 0.0),           # far inside the series branch
    (0.3, -0.2, 0.1),           # the series branch at 100 Hz
    (40.0, 0.0, 0.0),           # beyond it: sin and cos
    (1.0, 1.5, -120.0),         # a half angle of 0.6 rad per sample, about a tilted axis
])
def test_3d_kernel_turns_the_force_as_the_exact_rotation(rate):
    # a constant body rate: every trapezoid rate is that rate and each increment the exact rotation
    # by |w| h about it, so after k samples C = exp([w x] k h) (Rodrigues' formula, strapdown) and
    # the kernel's C f must be that rotation of f to rounding. Measured up to 2.1e-13 m/s^2 over
    # 300 steps (both sides round in proportion to the angle, up to 360 rad here); bar 1e-12
    from morpi_filters.strapdown import rotvec_to_C

    n, h = 301, 0.01
    w = np.array(rate, float)
    fb = np.array([0.3, -1.2, 9.8])
    f = [np.full((n, 1), fb[i]) for i in range(3)]
    ax, ay = np.empty((n, 1)), np.empty((n, 1))
    bi.horizontal_accel_3d(h, f, [np.full((n, 1), w[i]) for i in range(3)], ax, ay)
    C = rotvec_to_C(np.arange(n)[:, None] * h * w)
    want = C @ fb
    np.testing.assert_allclose(ax[:, 0], want[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ay[:, 0], want[:, 1], rtol=0, atol=1e-12)


def test_3d_kernel_is_its_python_rule_compiled_run_by_run():
    # numba compiles the plain Python loop (no fast-math): both give the same bits, and each run's
    # column is independent of the others (a chunk of other runs, or strided planes, changes nothing)
    rng = np.random.default_rng(5)
    n, R, h = 203, 6, 0.01
    f = [rng.normal(c, 0.3, (n, R)) for c in (0.2, -0.1, 9.8)]
    w = [rng.normal(c, 0.05, (n, R)) for c in (0.0, 0.0, 0.8)]
    w[0][50:60] += 30.0                        # some increments beyond the series branch
    ax, ay = np.empty((n, R)), np.empty((n, R))
    bi.horizontal_accel_3d(h, f, w, ax, ay)
    px, py = np.empty((n, R)), np.empty((n, R))
    plain_kernels(bi)._accel_3d_rows(h, *f, *w, px, py)
    assert np.array_equal(ax, px) and np.array_equal(ay, py)
    part = np.empty((2, n, 2))
    bi.horizontal_accel_3d(h, [c[:, 2:4] for c in f], [c[:, 2:4] for c in w], part[0], part[1])
    assert np.array_equal(part, np.stack([ax, ay])[:, :, 2:4])


def test_3d_kernel_may_write_over_the_x_and_y_rates():
    # the Monte Carlo chunk hands the x and y rate planes as the outputs: each sample's rates are
    # read before its row is written, so the result is the same bits as with outputs of their own
    rng = np.random.default_rng(11)
    n, R, h = 157, 5, 0.01
    f = [rng.normal(c, 0.3, (n, R)) for c in (0.2, -0.1, 9.8)]
    w = [rng.normal(c, 0.05, (n, R)) for c in (0.1, -0.1, 0.8)]
    ax, ay = np.empty((n, R)), np.empty((n, R))
    bi.horizontal_accel_3d(h, f, w, ax, ay)
    w2 = [c.copy() for c in w]
    bi.horizontal_accel_3d(h, f, w2, w2[0], w2[1])
    assert np.array_equal(w2[0], ax) and np.array_equal(w2[1], ay)


def test_double_integral_by_groups_matches_the_plain_recursion():
    # kept rows close together, one gap far longer than a group, and the last row; the grouped
    # prefix sums must give the same formula over the whole array within the rounding of its sums (another
    # order of the same running sums: Higham's bound, oracles.sums.prefix_bound), and the step by
    # step rule of a linear in each interval (v += h (a_k + a_k+1) / 2, p += v_k h + h^2 (a_k / 3 +
    # a_k+1 / 6)) to rounding
    rng = np.random.default_rng(3)
    n, R, h = 700, 4, 0.01
    a = rng.normal(0.0, 1.0, (n, R))
    keep = np.r_[0, 1, 2, 5, 40, 41, 63, 64, 65, 300, 301, np.arange(400, 700, 37), n - 1]
    got = bi.double_integral_at(a, h, keep)
    # the formula over the whole array: P_k = sum_{i<k} a_i row by row, Q over the kept segments
    P = np.zeros((n, R))
    for k in range(1, n):
        P[k] = P[k - 1] + a[k - 1]
    kk = keep[keep > 0]
    Q = np.cumsum(np.add.reduceat(P[:kk[-1]], np.r_[0, kk][:-1], axis=0), axis=0)
    whole = np.zeros((keep.size, R))
    whole[keep > 0] = Q
    whole[keep > 0] += P[kk]
    whole[keep > 0] += a[kk] / 6
    whole[keep > 0] -= a[0] * (kk / 2 + 1 / 6)[:, None]
    whole *= h * h
    # P_k and the sums of P over the kept segments in any order: twice gamma(n) of the sums of |a| and |P| (a
    # P's own error adds to each later sum of P); the three corrections and the scaling round a few times
    from oracles.sums import U, gamma
    abs_p = np.abs(P)
    bound = np.zeros((keep.size, R))
    bound[keep > 0] = (2.0 * gamma(n) * (np.cumsum(abs_p, axis=0)[kk - 1]
                                         + np.cumsum(np.cumsum(np.abs(a), axis=0), axis=0)[kk - 1])
                       + 8.0 * U * (np.abs(Q) + abs_p[kk] + np.abs(a[kk]) / 6 + np.abs(a[0]) * (kk / 2 + 1 / 6)[:, None]))
    bound *= h * h * (1.0 + 4.0 * U)
    assert np.all(np.abs(got - whole) <= bound)
    v, p, ref = np.zeros(R), np.zeros(R), np.zeros((n, R))
    for k in range(n - 1):
        p = p + v * h + h * h * (a[k] / 3 + a[k + 1] / 6)
        v = v + h * (a[k] + a[k + 1]) / 2
        ref[k + 1] = p
    np.testing.assert_allclose(got, ref[keep], rtol=1e-10, atol=1e-12)
    # planes of one array (any strides) give each plane's own result: the same loop on the same values, so
    # exact whatever numpy does
    planes = np.stack([a, 2 * a, -a], axis=1)                 # (n, 3, R)
    got3 = bi.double_integral_at(planes, h, keep)
    assert np.array_equal(got3[:, 0], got) and np.array_equal(got3[:, 2], bi.double_integral_at(-a, h, keep))
