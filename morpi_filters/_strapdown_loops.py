"""Loops of the strapdown that numba compiles (:mod:`morpi_filters.strapdown`).

- :func:`increments`, the integral of sampled signals over each interval of the real time grid
  (the corrected trapezoid of :mod:`morpi_filters.strapdown`: 3-point slopes, cubic Hermite
  interpolant), the element-wise arithmetic in numpy's order, the velocity and
  position they give (:func:`translation`), the attitude increments' coning term (:func:`coning`),
  and :func:`time_order`, the check that sample times are finite and strictly increasing;
- Rodrigues' formula of :func:`morpi_filters.strapdown.rotvec_to_C` (:func:`rodrigues`), the 3 x 3
  product (:func:`matmul3`), and with them the running attitude product of each run of
  :func:`morpi_filters.strapdown.ins3d` (:func:`attitude_chain`, :func:`attitude_chains`); the aided
  filter's pass (``_aided_kernel``) calls the first two as well.

numba is imported on the first call (:data:`compiled`, made by ``_jit.loops``), not with the package, and its
machine code is cached on disk (so no function here calls itself: numba's cache does not hold recursive
functions). The functions run as plain Python too (slowly): the tests compare both, and hold them to the
numpy form they restate within the rounding their sums allow, each bound written beside it (``tests/oracles``).
"""
from __future__ import annotations

import math

import numpy as np

from ._jit import loops


def increments(time, x, inc, d):
    """Slopes `d` (B, n, k) and interval integrals `inc` (B, n - 1, k) of samples `x` (B, n, k) on `time` (n,).

    ``d`` the 3-point non-uniform differences (one-sided quadratics at both ends; the chord for
    n = 2), ``inc = dt (x_j + x_j+1) / 2 + dt^2 (d_j - d_j+1) / 12``. The coefficients of the time
    steps are computed once; each column then runs along time (the loop the compiler vectorizes).
    """
    B, n, K = x.shape
    if n == 2:
        for r in range(B):
            for j in range(K):
                d[r, 0, j] = (x[r, 1, j] - x[r, 0, j]) / (time[1] - time[0])
                d[r, 1, j] = d[r, 0, j]
    else:
        c0 = np.empty(n)
        c1 = np.empty(n)
        c2 = np.empty(n)
        for i in range(1, n - 1):
            h1 = time[i] - time[i - 1]
            h2 = time[i + 1] - time[i]
            c0[i] = -h2 / (h1 * (h1 + h2))
            c1[i] = (h2 - h1) / (h1 * h2)
            c2[i] = h1 / (h2 * (h1 + h2))
        a = time[1] - time[0]
        b = time[2] - time[1]
        e0 = -(2 * a + b) / (a * (a + b))
        e1 = (a + b) / (a * b)
        e2 = a / (b * (a + b))
        a = time[n - 2] - time[n - 3]
        b = time[n - 1] - time[n - 2]
        f0 = b / (a * (a + b))
        f1 = (a + b) / (a * b)
        f2 = (a + 2 * b) / (b * (a + b))
        for r in range(B):
            for j in range(K):
                for i in range(1, n - 1):
                    d[r, i, j] = c0[i] * x[r, i - 1, j] + c1[i] * x[r, i, j] + c2[i] * x[r, i + 1, j]
                d[r, 0, j] = e0 * x[r, 0, j] + e1 * x[r, 1, j] - e2 * x[r, 2, j]
                d[r, n - 1, j] = f0 * x[r, n - 3, j] - f1 * x[r, n - 2, j] + f2 * x[r, n - 1, j]
    dt = np.empty(n - 1)
    q = np.empty(n - 1)
    for i in range(n - 1):
        dt[i] = time[i + 1] - time[i]
        q[i] = dt[i] * dt[i] / 12.0
    for r in range(B):
        for j in range(K):
            for i in range(n - 1):
                inc[r, i, j] = 0.5 * (x[r, i, j] + x[r, i + 1, j]) * dt[i] + (d[r, i, j] - d[r, i + 1, j]) * q[i]


def coning(time, w, phi):
    """Add the coning term to the rotation increments `phi` (B, n - 1, 3) of the rates `w` (B, n, 3):
    ``phi_j += (w_j x w_j+1) dt^2 / 12``, in numpy's order."""
    B, n, _ = w.shape
    for r in range(B):
        for i in range(n - 1):
            dt = time[i + 1] - time[i]
            c = dt * dt / 12.0
            phi[r, i, 0] += (w[r, i, 1] * w[r, i + 1, 2] - w[r, i, 2] * w[r, i + 1, 1]) * c
            phi[r, i, 1] += (w[r, i, 2] * w[r, i + 1, 0] - w[r, i, 0] * w[r, i + 1, 2]) * c
            phi[r, i, 2] += (w[r, i, 0] * w[r, i + 1, 1] - w[r, i, 1] * w[r, i + 1, 0]) * c


def translation(dt, a, d, dv, c3, v0, p0, v, p):
    """Velocity `v` and position `p` (B, n, k) from accelerations `a` (B, n, k), their slopes `d` and
    interval integrals `dv` (:func:`increments`), the time steps `dt` (n - 1,) and ``c3 = dt**3 / 60``
    (numpy's power), from `v0`, `p0` (B, k): ``v`` the running sum of `dv`,
    ``dp = v dt + (7 a_j + 3 a_j+1) dt^2 / 20 + (3 d_j - 2 d_j+1) c3`` and its running sum, each in
    numpy's order (``cumsum``, then the start added)."""
    B, n, K = a.shape
    for r in range(B):
        for j in range(K):
            v[r, 0, j] = v0[r, j]
            p[r, 0, j] = p0[r, j]
            sv = 0.0
            sp = 0.0
            for i in range(n - 1):
                sv = dv[r, i, j] if i == 0 else sv + dv[r, i, j]
                v[r, i + 1, j] = sv + v0[r, j]
            for i in range(n - 1):
                dp = v[r, i, j] * dt[i]
                dp = dp + (7.0 * a[r, i, j] + 3.0 * a[r, i + 1, j]) * (dt[i] * dt[i] / 20.0)
                dp = dp + (3.0 * d[r, i, j] - 2.0 * d[r, i + 1, j]) * c3[i]
                sp = dp if i == 0 else sp + dp
                p[r, i + 1, j] = sp + p0[r, j]


def time_order(t):
    """0 when the times `t` (n,) are finite and strictly increasing, 1 when one is not finite, else 2."""
    bad = 0
    for i in range(t.shape[0]):
        if not abs(t[i]) < np.inf:
            return 1
        if i > 0 and not t[i] > t[i - 1]:
            bad = 2
    return bad


def rodrigues(px, py, pz, out):
    """``exp([phi x])`` into `out` (3, 3): :func:`strapdown.rotvec_to_C` for one vector."""
    t2 = px * px + py * py + pz * pz
    if t2 < 1e-8:
        a = 1.0 - t2 / 6.0 + t2 * t2 / 120.0
        b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0
    else:
        t = math.sqrt(t2)
        a = math.sin(t) / t
        b = (1.0 - math.cos(t)) / (t * t)
    c = 1.0 - b * t2
    out[0, 0] = b * (px * px) + c
    out[1, 1] = b * (py * py) + c
    out[2, 2] = b * (pz * pz) + c
    out[0, 1] = b * (px * py) - a * pz
    out[1, 0] = b * (py * px) + a * pz
    out[0, 2] = b * (px * pz) + a * py
    out[2, 0] = b * (pz * px) - a * py
    out[1, 2] = b * (py * pz) - a * px
    out[2, 1] = b * (pz * py) + a * px


def matmul3(a, b, out):
    """``out = a b`` for 3 x 3 matrices (`out` distinct from both)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


def attitude_chain(phi, C0, out):
    """``out[0] = C0``, ``out[k + 1] = out[k] exp([phi[k] x])`` for the rotation vectors `phi` (m, 3): the
    attitude of one run of :func:`strapdown.ins3d`, `out` (m + 1, 3, 3)."""
    for i in range(3):
        for j in range(3):
            out[0, i, j] = C0[i, j]
    E = np.empty((3, 3))
    for k in range(phi.shape[0]):
        rodrigues(phi[k, 0], phi[k, 1], phi[k, 2], E)
        matmul3(out[k], E, out[k + 1])


def attitude_chains(phi, C0, out):
    """:func:`attitude_chain` for each of B runs: `phi` (B, m, 3), `C0` (B, 3, 3), `out` (B, m + 1, 3, 3)."""
    for b in range(phi.shape[0]):
        attitude_chain(phi[b], C0[b], out[b])


#: The functions numba compiles, callees first.
_FUNCTIONS = ("increments", "coning", "translation", "time_order", "rodrigues", "matmul3", "attitude_chain",
              "attitude_chains")
compiled = loops(globals(), _FUNCTIONS)
