"""Rest detection's centred moving statistics: a plain loop that numba compiles.

:func:`moving_stats` is what :func:`morpi_filters.calibration.rest_measures` measures on every gyro
and accelerometer sample: the mean and standard deviation over the window ``[t - half, t + half]``,
from running sums of the deviations from the first sample (less cancellation in ``E[x^2] - E[x]^2``).
The window's ends advance with the samples (two pointers) instead of a binary search per sample.

numba is imported on the first call (:func:`compiled`), not with the package, and its machine code
is cached on disk. The function runs as plain Python too (slowly): the tests compare both, and
hold them to the same sums written with numpy.
"""
from __future__ import annotations

import math

import numpy as np


def moving_stats(t, x, half, mean, std):
    """Centred moving mean and standard deviation of each column of `x` (n, k) into `mean` and `std` (n, k).

    `t` (n,) strictly increasing; the window of sample i holds the samples with
    ``t[i] - half <= t <= t[i] + half``.
    """
    n, k = x.shape
    ref = np.empty(k)
    for j in range(k):
        ref[j] = x[0, j]
    c1 = np.zeros((n + 1, k))
    c2 = np.zeros((n + 1, k))
    for i in range(n):
        for j in range(k):
            d = x[i, j] - ref[j]
            c1[i + 1, j] = c1[i, j] + d
            c2[i + 1, j] = c2[i, j] + d * d
    lo = 0
    hi = 0
    for i in range(n):
        a = t[i] - half
        b = t[i] + half
        while lo < n and t[lo] < a:
            lo += 1
        while hi < n and t[hi] <= b:
            hi += 1
        cnt = float(hi - lo)
        for j in range(k):
            m = (c1[hi, j] - c1[lo, j]) / cnt
            v = (c2[hi, j] - c2[lo, j]) / cnt - m * m
            mean[i, j] = m + ref[j]
            std[i, j] = math.sqrt(max(v, 0.0))


_COMPILED = None


def compiled():
    """:func:`moving_stats` compiled by numba (once per process; the machine code is cached on disk)."""
    global _COMPILED
    if _COMPILED is None:
        import numba

        _COMPILED = numba.njit(cache=True, nogil=True)(moving_stats)
    return _COMPILED
