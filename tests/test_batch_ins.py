"""The batched Monte Carlo strapdown kernel against morpi_filters.strapdown and closed forms."""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import _batch_ins as bi
from morpi_filters import montecarlo as mc


def _planes(a):
    return [np.ascontiguousarray(a[:, :, i].T) for i in range(3)]


@pytest.mark.parametrize("noise, tol", [
    # biases only: the kernel and strapdown.ins3d differ only by strapdown's Hermite end slopes
    # and coning term, O(dt^2); measured 1.4e-7 relative, bar 1e-6.
    (0.0, 1e-6),
    # with white noise the two rules integrate each noise sample slightly differently;
    # measured up to 5e-5 relative on 4 runs, bar 3e-4.
    (1.0, 3e-4),
])
def test_straight_line_kernels_match_strapdown(noise, tol):
    from morpi_filters import strapdown

    cfg = mc.StudyConfig()
    st = mc._paths(cfg)[0]
    n, R, h = st.time.size, 4, 1.0 / cfg.rate_hz
    keep = np.array([0, 500, n - 1])
    rng = np.random.default_rng(3)
    f = st.f_b + 0.5 * rng.standard_normal((R, 1, 3)) + noise * 0.03 * rng.standard_normal((R, n, 3))
    w = 0.05 * rng.standard_normal((R, 1, 3)) + noise * 0.002 * rng.standard_normal((R, n, 3))
    tx = bi.double_integral_at(st.f_b[:, 0, None], h, keep)
    x, y = bi.straight_errors_3d(h, _planes(f), _planes(w), keep)
    p = strapdown.ins3d(st.time, f, w).position
    e_sd = np.hypot(p[:, keep, 0] - st.position[keep, 0], p[:, keep, 1] - st.position[keep, 1])
    np.testing.assert_allclose(np.hypot(x - tx, y).T[:, 1:], e_sd[:, 1:], rtol=tol)
    wz = w[:, :, 2].T
    psi = np.zeros((n, R))
    psi[1:] = np.cumsum(wz[:-1], axis=0)
    psi = h * (psi + 0.5 * (wz - wz[0]))
    x, y = bi.straight_errors_2d(_planes(f), psi, h, keep)
    p = strapdown.ins2d(st.time, f, w).position
    e_sd = np.hypot(p[:, keep, 0] - st.position[keep, 0], p[:, keep, 1] - st.position[keep, 1])
    np.testing.assert_allclose(np.hypot(x - tx, y).T[:, 1:], e_sd[:, 1:], rtol=tol)


def test_double_integral_of_a_ramp_is_exact():
    # a = c t is linear in each interval, so the trapezoid rule gives p = c t^3 / 6 exactly
    h, n = 0.01, 301
    t = np.arange(n) * h
    keep = np.array([0, 1, 150, n - 1])
    p = bi.double_integral_at((2.5 * t)[:, None], h, keep)[:, 0]
    np.testing.assert_allclose(p, 2.5 * t[keep] ** 3 / 6, rtol=1e-12, atol=1e-15)


def test_quaternion_increments_match_exact_sin_cos():
    w = np.array([[1e-6, 0.0, 0.0], [0.3, -0.2, 0.1], [1.0, 1.5, -1.2], [40.0, 0.0, 0.0]]).T
    h = 0.01
    c, x, y, z = bi.quat_increments(w[0], w[1], w[2], h)
    ang = np.linalg.norm(w, axis=0) * h / 2
    np.testing.assert_allclose(c, np.cos(ang), rtol=0, atol=2e-16)
    np.testing.assert_allclose(x, np.sin(ang) * w[0] / np.linalg.norm(w, axis=0), rtol=1e-14, atol=1e-20)
