"""Batched strapdown kernel of the Monte Carlo gain-error study.

The horizontal INS positions of a level path that starts along x (C_bn = I
at the start: the study's sine path or straight line), vectorized over runs:
time-major planes ``(n, R)`` (n samples, R runs), a quaternion attitude step
and trapezoid integration. It does what :func:`morpi_filters.strapdown.ins3d`
and :func:`morpi_filters.strapdown.ins2d` do for that case without keeping every
C_bn matrix (the general strapdown costs about 8 times the drawing of the
random numbers); the tests check it against them. Every operation is
elementwise over runs in a fixed order, so a run's result does not depend on
the chunk it is computed in.

The 3D attitude recursion is a loop over samples that numpy can only run as
many passes over small arrays; it is compiled by numba (through ``_jit``, on
the first call, so importing the package does not load it) from the plain
Python function :func:`_accel_3d_rows`, whose operations, in their order, are
those of the reference rule described in :func:`horizontal_accel_3d`.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import loops

__all__ = ["prefix_rows", "cos_sin", "double_integral_at", "horizontal_3d", "horizontal_2d", "horizontal_accel_3d",
           "horizontal_accel_2d"]


def prefix_rows(a, out, start=None):
    """Exclusive prefix sums along axis 0 of time-major planes, in place.

    ``out[0] = 0`` and ``out[k] = a[0] + ... + a[k-1]``: a loop of row
    additions, the same sequential sums as ``np.cumsum(axis=0)`` but about 2.5
    times faster on (n, R) planes, whose column-wise accumulation numpy runs
    with strided access. With `start`, the sums go on from it (``out[0] =
    start``): a long array taken block by block gives the same bits.

    Parameters
    ----------
    a : ndarray, shape (n, R)
        Rows to accumulate (any trailing shape and strides).
    out : ndarray, shape (m, R), m <= n + 1
        Array written in place; its length sets how many sums are formed.
    start : ndarray, shape (R,), optional
        The first row (default zero).

    Returns
    -------
    ndarray, shape (m, R)
        `out` itself.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[1.0], [2.0], [3.0]])
    >>> prefix_rows(a, np.empty((4, 1)))[:, 0].tolist()
    [0.0, 1.0, 3.0, 6.0]
    """
    out[0] = 0.0 if start is None else start
    rows, add = list(out), np.add               # views made once; the ufunc called with a positional output
    for k, ak in enumerate(a[:len(rows) - 1], start=1):
        add(rows[k - 1], ak, rows[k])
    return out


def cos_sin(psi, block: int = 32):
    """cos and sin of time-major angles, exact trig only every `block` rows.

    Within a block, ``cos(b + d) = cos b cos d - sin b sin d`` (and likewise
    sin) with the offset d from the block's first row through Taylor series
    to d^10 (truncation below d^12 / 12! <= 1e-17 for |d| <= 0.2); elements
    with a larger offset are recomputed with cos/sin (an elementwise rule).
    About three times faster than ``np.cos`` and ``np.sin`` of every element.

    Parameters
    ----------
    psi : ndarray, shape (n, R)
        Angles [rad], time on axis 0.
    block : int, optional
        Rows per block sharing one exact cos/sin evaluation (default 32).

    Returns
    -------
    c, s : tuple of 2 ndarray, each shape (n, R)
        cos(psi) and sin(psi).

    Examples
    --------
    >>> import numpy as np
    >>> psi = np.linspace(0.0, 3.0, 100).reshape(50, 2)
    >>> c, s = cos_sin(psi, block=8)
    >>> bool(np.allclose(c, np.cos(psi), atol=1e-14) and np.allclose(s, np.sin(psi), atol=1e-14))
    True
    """
    n, R = psi.shape
    c, s = np.empty((n, R)), np.empty((n, R))
    for k0 in range(0, n, block):
        k1 = min(k0 + block, n)
        _cos_sin_rows(psi[k0:k1], c[k0:k1], s[k0:k1])
    return c, s


def _cos_sin_rows(psi, c, s):
    """One block of :func:`cos_sin`: exact cos/sin of the first row, series offsets for the others; into c, s."""
    base = psi[0]
    cb, sb = np.cos(base), np.sin(base)
    d = psi - base
    d2 = d * d
    cd = d2 * (-1 / 3628800)
    sd = d2 * (-1 / 39916800)
    for cc, ss in ((1 / 40320, 1 / 362880), (-1 / 720, -1 / 5040), (1 / 24, 1 / 120), (-1 / 2, -1 / 6)):
        cd += cc
        cd *= d2
        sd += ss
        sd *= d2
    cd += 1
    sd += 1
    sd *= d
    big = d2 > 0.04
    if big.any():
        cd[big] = np.cos(d[big])
        sd[big] = np.sin(d[big])
    np.multiply(cb, cd, out=c)
    c -= sb * sd
    np.multiply(sb, cd, out=s)
    s += cb * sd


def double_integral_at(a, h, keep):
    """Trapezoid double integral from rest, evaluated at chosen rows.

    ``v_{k+1} = v_k + h (a_k + a_{k+1}) / 2`` and
    ``p_{k+1} = p_k + v_k h + h^2 (a_k / 3 + a_{k+1} / 6)`` (a linear in each
    interval), evaluated in closed form from two prefix sums:
    ``p_k = h^2 (Q_k + P_k + a_k / 6 - a_0 (k / 2 + 1 / 6))`` for k >= 1, with
    ``P_k = sum_{i<k} a_i`` and ``Q_k = sum_{j<k} P_j``; ``p_0 = 0``.

    Parameters
    ----------
    a : ndarray, shape (n, R)
        Acceleration samples, time-major [m/s^2].
    h : float
        Sampling interval [s].
    keep : ndarray of int, shape (K,)
        Increasing row indices in [0, n) to return; at least one must be
        positive.

    Returns
    -------
    ndarray, shape (K, R)
        Position at the rows `keep`, from rest at the origin [m].

    Examples
    --------
    A constant 1 m/s^2 is integrated exactly: t^2 / 2 at t = 0, 0.5 and 1 s.

    >>> import numpy as np
    >>> double_integral_at(np.ones((11, 1)), 0.1, np.array([0, 5, 10]))[:, 0].round(12).tolist()
    [0.0, 0.125, 0.5]
    """
    return _double_integral_at(a, h, keep)


def _double_integral_at(a, h, keep, block: int = 64):
    """:func:`double_integral_at` without the whole (n, R) array of prefix sums.

    The rows go group by group, each a run of consecutive segments between
    kept rows of about `block` rows: the group's prefix sums P are formed in a
    small buffer that stays in cache (:func:`prefix_rows`, carried on from
    the last row of the group before), the sums of P over
    its segments are taken there, and Q continues the running sum of the
    segment sums (the carry added to the group's first segment sum first).
    The same additions in the same order as the prefix sums of the whole
    array followed by ``np.add.reduceat`` and ``np.cumsum`` over the segments.
    `a` may have any shape (n, ...) and strides (e.g. the (n, 4, R) view of
    four component-major (n, R) planes); the result is shaped (len(keep), ...).
    """
    n, row = a.shape[0], a.shape[1:]
    kk = keep[keep > 0]
    edges = np.r_[0, kk]
    K = kk.size
    out = np.empty((K,) + row)
    work = np.empty((block + 1,) + row)
    last = np.zeros(row)            # P at the first row of the group
    carry = None                    # Q after the segments before the group
    j0 = 0
    while j0 < K:
        # the group: segments j0 .. j1-1, rows r0 .. r1 - 1, and P at row r1 (the kept row kk[j1 - 1])
        j1 = j0 + 1
        while j1 < K and edges[j1 + 1] - edges[j0] <= block:
            j1 += 1
        r0, r1 = edges[j0], edges[j1]
        if r1 - r0 + 1 > work.shape[0]:
            work = np.empty((r1 - r0 + 1,) + row)
        P = prefix_rows(a[r0:r1], work[:r1 - r0 + 1], start=last)
        seg = np.add.reduceat(P[:-1], edges[j0:j1] - r0, axis=0)
        if carry is not None:
            seg[0] = carry + seg[0]
        Q = np.cumsum(seg, axis=0)
        out[j0:j1] = Q
        out[j0:j1] += P[edges[j0 + 1:j1 + 1] - r0]
        carry = Q[-1]
        last = P[-1].copy()
        j0 = j1
    out += a[kk] / 6
    out -= a[0] * (kk / 2 + 1 / 6).reshape((K,) + (1,) * len(row))
    full = np.zeros((keep.size,) + row)
    full[keep > 0] = out
    full *= h * h
    return full


def horizontal_3d(h, f, w, keep):
    """Horizontal position of a 3D strapdown from rest, starting at C_bn = I.

    The horizontal position is the double integral of ``C f`` with C
    propagated from the measured rates (exact rotation by the trapezoid mean
    rate of each interval) and trapezoid integration
    (:func:`double_integral_at`); gravity acts along the navigation z axis
    only, so it does not enter. The caller subtracts the same computation on
    the true signals, so the difference is the error the sensor errors cause. It agrees with
    :func:`morpi_filters.strapdown.ins3d` to their O(dt) integration-rule
    difference (tests/test_montecarlo.py).

    Parameters
    ----------
    h : float
        Sampling interval [s].
    f, w : sequence of 3 ndarrays, shape (n, R)
        Measured specific force [m/s^2] and angular rate [rad/s] planes, time-major.
    keep : ndarray of int
        Rows to return (increasing, at least one positive).

    Returns
    -------
    x, y : tuple of 2 ndarray, each shape (len(keep), R)
        Horizontal position from rest at the origin [m].

    Examples
    --------
    A level phone with 1 m/s^2 forward for 1 s, no rotation, travels 0.5 m:

    >>> import numpy as np
    >>> n = 11
    >>> f = [np.ones((n, 1)), np.zeros((n, 1)), np.full((n, 1), 9.81)]
    >>> w = [np.zeros((n, 1))] * 3
    >>> x, y = horizontal_3d(0.1, f, w, np.array([n - 1]))
    >>> round(float(x[0, 0]), 12), round(float(y[0, 0]), 12)
    (0.5, 0.0)
    """
    n, R = f[0].shape
    a = np.empty((2, n, R))
    horizontal_accel_3d(h, f, w, a[0], a[1])
    return double_integral_at(a[0], h, keep), double_integral_at(a[1], h, keep)


def horizontal_accel_3d(h, f, w, ax, ay):
    """The horizontal rows of ``C f`` that :func:`horizontal_3d` integrates, written into `ax`, `ay`.

    C is propagated from rest (the identity) as a scalar-first quaternion,
    ``q_{k+1} = q_k (x) exp(omega_k h / 2)`` with the trapezoid rate of each
    interval, ``omega_k = (w_k + w_k+1) / 2``. The half angle
    ``x = |omega_k| h / 2`` enters through the Taylor series of ``cos x`` and
    ``sin(x) / x`` to ``x^4`` (truncation below ``x^6 / 720 <= 1.4e-15`` for
    ``x <= 0.01``, i.e. ``|omega| <= 2`` rad/s at 100 Hz); a larger ``x`` uses
    sin and cos. The product sums each component in the order
    ``((M[i,0] q_0 + M[i,1] q_1) + M[i,2] q_2) + M[i,3] q_3`` with ``M`` the
    right-multiplication matrix of the increment, and
    ``C f = f + 2 q_0 (u x f) + 2 u x (u x f)`` with ``u = (q_1, q_2, q_3)``.
    The rule is elementwise over runs, so a run's result does not depend on
    the others in the chunk. Compiled by numba (:func:`_accel_3d_rows`).

    Parameters
    ----------
    h : float
        Sampling interval [s].
    f, w : sequence of 3 ndarrays, shape (n, R)
        Measured specific force [m/s^2] and angular rate [rad/s] planes, time-major.
    ax, ay : ndarray, shape (n, R)
        Written with the north and east components of ``C f`` [m/s^2] (any
        strides, e.g. planes of one larger array). They may be the arrays
        ``w[0]`` and ``w[1]``: the rates of a sample are read before its
        row of `ax`, `ay` is written.

    Returns
    -------
    None

    Examples
    --------
    A quarter turn about z over the first second turns body x into navigation y:

    >>> import numpy as np
    >>> n, h = 11, 0.1
    >>> f = [np.ones((n, 1)), np.zeros((n, 1)), np.full((n, 1), 9.81)]
    >>> w = [np.zeros((n, 1)), np.zeros((n, 1)), np.full((n, 1), np.pi / 2)]
    >>> ax, ay = np.empty((n, 1)), np.empty((n, 1))
    >>> horizontal_accel_3d(h, f, w, ax, ay)
    >>> round(float(ax[-1, 0]), 12) + 0.0, round(float(ay[-1, 0]), 12)
    (0.0, 1.0)
    """
    compiled()["_accel_3d_rows"](float(h), f[0], f[1], f[2], w[0], w[1], w[2], ax, ay)


def _accel_3d_rows(h, fx, fy, fz, wx, wy, wz, ax, ay):
    """The loop of :func:`horizontal_accel_3d` over samples (outer) and runs (inner), in plain Python.

    Each line is one rounded operation of the rule in the order it states
    (no fused multiply-add: numba compiles without fast-math). Runs as is,
    slowly, without numba; the tests check that both give the same bits.
    """
    n, R = fx.shape
    hh = 0.5 * h                    # the increment's interval, halved: the rate is the sum of two samples
    s2 = 0.25 * hh * hh
    kh = 0.5 * hh
    q0 = np.ones(R)
    q1 = np.zeros(R)
    q2 = np.zeros(R)
    q3 = np.zeros(R)
    for k in range(n):
        more = k < n - 1
        for r in range(R):
            a0 = q0[r]
            a1 = q1[r]
            a2 = q2[r]
            a3 = q3[r]
            if more:
                # the increment exp(omega h / 2) from the sum of the rates at k and k + 1
                u = wx[k, r] + wx[k + 1, r]
                v = wy[k, r] + wy[k + 1, r]
                z = wz[k, r] + wz[k + 1, r]
                x2 = u * u
                x2 = x2 + v * v
                x2 = x2 + z * z
                x2 = x2 * s2
                c = x2 * (1 / 24)
                c = c - 0.5
                c = c * x2
                c = c + 1
                sx = x2 * (1 / 120)
                sx = sx - 1 / 6
                sx = sx * x2
                sx = sx + 1
                if x2 > 1e-4:
                    x = math.sqrt(x2)
                    c = math.cos(x)
                    sx = math.sin(x) / x
                sx = sx * kh
                p1 = sx * u
                p2 = sx * v
                p3 = sx * z
                # q (x) p = M(p) q, M's rows (c, -p1, -p2, -p3), (p1, c, p3, -p2), (p2, -p3, c, p1), (p3, p2, -p1, c)
                n0 = ((c * a0 + (-p1) * a1) + (-p2) * a2) + (-p3) * a3
                n1 = ((p1 * a0 + c * a1) + p3 * a2) + (-p2) * a3
                n2 = ((p2 * a0 + (-p3) * a1) + c * a2) + p1 * a3
                n3 = ((p3 * a0 + p2 * a1) + (-p1) * a2) + c * a3
            # the horizontal rows of C(q_k) f_k
            fxk = fx[k, r]
            fyk = fy[k, r]
            fzk = fz[k, r]
            cx = a2 * fzk - a3 * fyk
            cy = a3 * fxk - a1 * fzk
            cz = a1 * fyk - a2 * fxk
            bx = a2 * cz - a3 * cy
            bx = bx + a0 * cx
            bx = bx * 2
            ax[k, r] = bx + fxk
            by = a3 * cx - a1 * cz
            by = by + a0 * cy
            by = by * 2
            ay[k, r] = by + fyk
            if more:
                q0[r] = n0
                q1[r] = n1
                q2[r] = n2
                q3[r] = n3


def horizontal_2d(f, psi, h, keep, heading=None):
    """Horizontal position of the planar INS from rest, starting at heading 0.

    The heading is ``heading[:, None] + psi``: `heading` the same for every
    run (the true heading integrated by the same rule; zero when None), and
    `psi` the part each run's z-rate error adds (small: its cos/sin come from
    :func:`cos_sin`). f_x, f_y are rotated by it and integrated twice
    (:func:`double_integral_at`).

    Parameters
    ----------
    f : sequence of at least 2 ndarrays, shape (n, R)
        Specific force planes f_x, f_y in the body frame [m/s^2], time-major;
        further entries (f_z) are not used.
    psi : ndarray, shape (n, R)
        Heading added to `heading`, per run [rad].
    h : float
        Sampling interval [s].
    keep : ndarray of int
        Rows to return (increasing, at least one positive).
    heading : ndarray, shape (n,), optional
        Heading shared by all runs [rad]; zero when None.

    Returns
    -------
    x, y : tuple of 2 ndarray, each shape (len(keep), R)
        Horizontal position from rest at the origin [m].

    Examples
    --------
    1 m/s^2 along the body x axis for 1 s, heading 90 degrees: 0.5 m along y.

    >>> import numpy as np
    >>> n = 11
    >>> f = [np.ones((n, 1)), np.zeros((n, 1))]
    >>> x, y = horizontal_2d(f, np.zeros((n, 1)), 0.1, np.array([n - 1]), heading=np.full(n, np.pi / 2))
    >>> round(float(x[0, 0]), 12), round(float(y[0, 0]), 12)
    (0.0, 0.5)
    """
    n, R = psi.shape
    a = np.empty((2, n, R))
    horizontal_accel_2d(f, psi, a[0], a[1], heading=heading)
    return double_integral_at(a[0], h, keep), double_integral_at(a[1], h, keep)


def horizontal_accel_2d(f, psi, ax, ay, heading=None, block: int = 32):
    """The body specific force rotated by the heading, as :func:`horizontal_2d` integrates it, into `ax`, `ay`.

    The heading is ``heading[:, None] + psi``; the cos and sin of `psi` come
    from :func:`cos_sin` (blocks of `block` rows, which also set how the
    result is computed: keep the default to reproduce :func:`horizontal_2d`),
    and are combined with those of `heading` by the angle-sum rule.

    Parameters
    ----------
    f : sequence of at least 2 ndarrays, shape (n, R)
        Specific force planes f_x, f_y in the body frame [m/s^2], time-major.
    psi : ndarray, shape (n, R)
        Heading added to `heading`, per run [rad].
    ax, ay : ndarray, shape (n, R)
        Written with the north and east components [m/s^2] (any strides).
    heading : ndarray, shape (n,), optional
        Heading shared by all runs [rad]; zero when None.
    block : int, optional
        Rows per block (default 32, that of :func:`cos_sin`).

    Returns
    -------
    None

    Examples
    --------
    >>> import numpy as np
    >>> f = [np.ones((3, 1)), np.zeros((3, 1))]
    >>> ax, ay = np.empty((3, 1)), np.empty((3, 1))
    >>> horizontal_accel_2d(f, np.full((3, 1), np.pi / 2), ax, ay)
    >>> np.round(ax[:, 0], 12).tolist(), np.round(ay[:, 0], 12).tolist()
    ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    """
    n, R = psi.shape
    ch = sh = None
    if heading is not None:
        ch, sh = np.cos(heading)[:, None], np.sin(heading)[:, None]
    t = np.empty((5, block, R))
    for k0 in range(0, n, block):
        k1 = min(k0 + block, n)
        c, s, c2, s2, u = t[:, :k1 - k0]
        _cos_sin_rows(psi[k0:k1], c, s)
        if ch is not None:
            # c, s = c ch - s sh, s ch + c sh
            np.multiply(c, ch[k0:k1], out=c2)
            c2 -= np.multiply(s, sh[k0:k1], out=u)
            np.multiply(s, ch[k0:k1], out=s2)
            s2 += np.multiply(c, sh[k0:k1], out=u)
            c, s = c2, s2
        f0, f1 = f[0][k0:k1], f[1][k0:k1]
        bx, by = ax[k0:k1], ay[k0:k1]
        np.multiply(c, f0, out=bx)
        bx -= np.multiply(s, f1, out=u)
        np.multiply(s, f0, out=by)
        by += np.multiply(c, f1, out=u)


#: The functions numba compiles.
_FUNCTIONS = ("_accel_3d_rows",)
compiled = loops(globals(), _FUNCTIONS)
