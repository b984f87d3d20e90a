"""Loops of rest detection that numba compiles (:mod:`morpi_filters.calibration`).

- :func:`moving_stats`, what :func:`morpi_filters.calibration.rest_measures` measures on every
  gyro and accelerometer sample: the mean and standard deviation over the window
  ``[t - half, t + half]``, from running sums of the deviations from the first sample (less
  cancellation in ``E[x^2] - E[x]^2``). The window's ends advance with the samples (two pointers)
  instead of a binary search per sample.
- :func:`block_sigma_loops` (:func:`block_edges`, :func:`block_noise`, :func:`block_pick`,
  :func:`sort_head`), what :func:`morpi_filters.calibration.rest_measures` reads of the first
  seconds of a recording: each block's noise sigma (the robust sigma of the first differences,
  :func:`morpi_filters.calibration.noise_sigma`) and spread, the lower quartile of the sigmas and
  the median of the quietest block (a deviation within the tie margin of the 90 % quantile is kept,
  so rounding cannot move it across the cut; the numpy form is ``tests/oracles/noise.py``);
- :func:`motion_flags`, the samples :func:`morpi_filters.calibration.detect_rest` takes as
  moving: a gyro deviation or spread, or an accelerometer spread, above its threshold on any axis;
- :func:`sort_head` (:func:`sift_down`), the short sort of the block loops, which the steps' swing
  median takes too (``steps/_loops.py``).

numba is imported on the first call (:data:`compiled`, made by ``_jit.loops``), not with the package, and its
machine code is cached on disk (so no function here calls itself: numba's cache does not hold recursive
functions). The functions run as plain Python too (slowly): the tests compare both, and hold them to the
numpy form they restate within the rounding their sums allow, each bound written beside it (``tests/oracles``).
"""
from __future__ import annotations

import math

import numpy as np

from ._jit import loops
from .choice import TIE_ABS, TIE_REL


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


def motion_flags(s_g, m_g, s_a, g_spread, g_level, g_dev, a_spread, out):
    """``out[i]`` (n,): any axis j with ``s_g[i, j] > g_spread[j]``, ``|m_g[i, j] - g_level[j]| > g_dev[j]``
    or ``s_a[i, j] > a_spread[j]`` (each of `s_g`, `m_g`, `s_a` (n, 3))."""
    for i in range(s_g.shape[0]):
        flag = False
        for j in range(s_g.shape[1]):
            if s_g[i, j] > g_spread[j] or abs(m_g[i, j] - g_level[j]) > g_dev[j] or s_a[i, j] > a_spread[j]:
                flag = True
                break
        out[i] = flag


#: The smallest positive float, the bound of the block noise sigmas (:func:`block_noise`).
_TINY = float(np.finfo(float).tiny)
_SQRT2 = math.sqrt(2.0)
_SQRT12 = math.sqrt(12.0)


def sift_down(a, i, n):
    """Restore the max-heap order of ``a[:n]`` below position `i` (:func:`sort_head`)."""
    v = a[i]
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and a[c + 1] > a[c]:
            c += 1
        if a[c] <= v:
            break
        a[i] = a[c]
        i = c
    a[i] = v


def sort_head(a, n):
    """Sort ``a[:n]`` in place (a 1-d float array without NaN): insertion sort up to 48 values, else heap
    sort (a short loop numba compiles quickly, where its own sort takes seconds). Sorting is exact, so the
    sorted values are numpy's whatever the method."""
    if n <= 48:
        for i in range(1, n):
            v = a[i]
            p = i
            while p > 0 and a[p - 1] > v:
                a[p] = a[p - 1]
                p -= 1
            a[p] = v
    else:
        for i in range(n // 2 - 1, -1, -1):
            sift_down(a, i, n)
        for end in range(n - 1, 0, -1):
            v = a[0]
            a[0] = a[end]
            a[end] = v
            sift_down(a, np.int64(0), end)


def block_edges(t, span, block):
    """The block edges of ``_block_sigma``: ``np.searchsorted(t, np.arange(0.0, max(span, block) + 1e-12,
    block), side="left")`` for strictly increasing `t` (n,), as an int64 array.

    numpy's float ``arange`` has ``ceil(stop / block)`` values ``0.0 + i * block`` (its fill adds
    ``i * (buffer[1] - buffer[0])`` to the start); each edge is the first index with ``t >= value``.
    """
    stop = max(span, block) + 1e-12
    count = max(int(math.ceil(stop / block)), 0)
    edges = np.empty(count, dtype=np.int64)
    p = 0
    n = t.shape[0]
    for i in range(count):
        v = 0.0 + i * block
        while p < n and t[p] < v:
            p += 1
        edges[i] = p
    return edges


def block_noise(x, edges, bounds, sig, spread):
    """Noise sigma and standard deviation of each block of five samples or more, per column; their count.

    `x` (n, k) samples, `edges` (e,) ascending sample indices: the candidate blocks are
    ``x[edges[i]:edges[i + 1]]``, those of ``edges[i + 1] - edges[i] >= 5`` rows are taken, in order.
    For the b-th taken block ``x[a:b_]`` it writes ``bounds[b] = (a, b_)`` ((e - 1, 2) integers), its
    :func:`morpi_filters.calibration.noise_sigma` into ``sig[b]`` and ``x[a:b_].std(axis=0)`` into
    ``spread[b]`` (each (e - 1, k)), and returns the number of blocks taken; -1 as soon as a block's
    sum, difference, variance or sigma is not finite (a NaN or an infinity in `x`, or an overflow:
    numpy's sorts, comparisons and reductions then follow their own NaN rules; left to the numpy
    code). So every value it writes is finite.

    Per column the noise sigma of the ``n = b_ - a - 1`` first differences ``d`` is: ``med`` their
    median; ``dev = |d - med|``; ``q90`` the linear-interpolation 0.9 quantile of ``dev``
    (``pos = (n - 1) 0.9``, ``lo = floor(pos)``, ``hi = min(lo + 1, n - 1)``, ``f = pos - lo``: ``s[hi] -
    (s[hi] - s[lo]) (1 - f)`` when ``f >= 0.5``, else ``s[lo] + (s[hi] - s[lo]) f``, ``s`` the sorted
    ``dev``); ``sigma = sqrt(sum(dev^2 | dev <= q90 + tie) / count) / 0.7891 / sqrt(2)`` (``tie`` the tie margin
    of ``choice.tie_margin(q90)``: a deviation that rounding puts a hair above the quantile is kept), the kept squares
    added in row order from 0.0; at least the smallest positive ``|d|`` over ``sqrt(12)`` (0 without
    one) and the smallest positive float.

    The differences are sorted (:func:`sort_head`); the deviations are not: ``|s_d[i] - med|``
    decreases up to the median and increases after it (rounding is monotone), so the two runs are
    merged from the ends of the sorted differences inwards, largest first, down to the rank ``lo``
    (about n / 10 steps).
    """
    k = x.shape[1]
    width = 1
    for e in range(edges.shape[0] - 1):
        if edges[e + 1] - edges[e] > width:
            width = edges[e + 1] - edges[e]
    d = np.empty(width)
    srt = np.empty(width)
    nb = 0
    for e in range(edges.shape[0] - 1):
        a = edges[e]
        b = edges[e + 1]
        m = b - a
        if m < 5:
            continue
        bounds[nb, 0] = a
        bounds[nb, 1] = b
        n = m - 1
        pos = (n - 1) * 0.9
        lo = int(math.floor(pos))
        hi = min(lo + 1, n - 1)
        frac = pos - lo
        mid = (n - 1) // 2
        for j in range(k):
            # standard deviation of the samples: two sequential sums
            s = 0.0
            for i in range(a, b):
                s += x[i, j]
            if not abs(s) < np.inf:
                return -1
            mean = s / m
            s = 0.0
            for i in range(a, b):
                v = x[i, j] - mean
                s += v * v
            if not s < np.inf:
                return -1
            spread[nb, j] = math.sqrt(s / m)
            # first differences, sorted
            for i in range(n):
                v = x[a + i + 1, j] - x[a + i, j]
                if not abs(v) < np.inf:
                    return -1
                d[i] = v
                srt[i] = v
            sort_head(srt, n)
            if n % 2 == 1:
                med = srt[mid]
            else:
                med = (srt[mid] + srt[min(mid + 1, n - 1)]) / 2.0
            # ranks lo and hi of |d - med|: the largest deviations lie at the ends of the sorted
            # differences; merge the two runs from the ends inwards down to rank lo
            p = 0
            while p < n and srt[p] < med:
                p += 1
            il = 0
            ir = n - 1
            s_lo = 0.0
            s_hi = 0.0
            for r in range(n - 1, lo - 1, -1):                  # r: the rank taken
                vl = abs(srt[il] - med) if il < p else -1.0
                vr = abs(srt[ir] - med) if ir >= p else -1.0
                if vl >= vr:
                    v = vl
                    il += 1
                else:
                    v = vr
                    ir -= 1
                if r == hi:
                    s_hi = v
                s_lo = v
            step = s_hi - s_lo
            if frac >= 0.5:
                q90 = s_hi - step * (1.0 - frac)
            else:
                q90 = s_lo + step * frac
            # sum of the kept squares in row order; the smallest positive step
            ss = 0.0
            cnt = 0
            pos_min = np.inf
            cut = q90 + (TIE_REL * abs(q90) + TIE_ABS)            # choice.tie_margin: rounding cannot flip a kept value
            for i in range(n):
                v = abs(d[i] - med)
                if v <= cut:
                    ss += v * v
                    cnt += 1
                ad = abs(d[i])
                if ad > 0.0 and ad < pos_min:
                    pos_min = ad
            sigma = math.sqrt(ss / cnt) / 0.7891 / _SQRT2
            floor = (pos_min if pos_min < np.inf else 0.0) / _SQRT12
            if not sigma < np.inf:
                return -1
            r = sigma if sigma >= floor else floor
            sig[nb, j] = r if r >= _TINY else _TINY
        nb += 1
    return nb


def block_pick(x, bounds, nb, sig, spread, q, med):
    """The quietest of the `nb` blocks of :func:`block_noise`, the lower quartile of their sigmas and its median.

    The quietest block is the first block within the tie tolerance (``choice.choose``) of the least
    score ``sum_j spread[b, j] / max(min_b sig[b, j], 1e-300)`` (summed in column order from 0.0).
    Writes per column ``q`` (k,)
    ``np.quantile(sig[:nb], 0.25, axis=0)`` (linear interpolation between the sorted values at
    ``floor((nb - 1) / 4)`` and the next, with numpy's rule of ``b - (b - a)(1 - g)`` for a weight
    ``g >= 0.5``) and ``med`` (k,) ``np.median`` of the block's rows (``(0.0 + a) / 1`` or
    ``(0.0 + a + b) / 2`` of the middle values, as numpy's mean takes them); returns the block's
    index.
    """
    k = x.shape[1]
    den = np.empty(k)
    for j in range(k):
        lo = sig[0, j]
        for i in range(1, nb):
            if sig[i, j] < lo:
                lo = sig[i, j]
        den[j] = lo if lo >= 1e-300 else 1e-300
    score = np.empty(nb)
    least = 0.0
    for i in range(nb):
        s = 0.0
        for j in range(k):
            s += spread[i, j] / den[j]
        score[i] = s
        if i == 0 or s < least:
            least = s
    best = 0                                               # the first within the tie band, as choice.choose
    while score[best] > least + (TIE_REL * abs(least) + TIE_ABS):
        best += 1
    # lower quartile over the blocks
    col = np.empty(max(nb, bounds[best, 1] - bounds[best, 0]))
    vi = (nb - 1) * 0.25
    if vi >= nb - 1:
        prev = nb - 1
        nxt = nb - 1
        gamma = vi + 1.0                                   # numpy's gamma from the index -1
    else:
        prev = int(math.floor(vi))
        nxt = prev + 1
        gamma = vi - prev
    for j in range(k):
        for i in range(nb):
            col[i] = sig[i, j]
        sort_head(col, nb)
        lo_v = col[prev]
        hi_v = col[nxt]
        step = hi_v - lo_v
        if gamma >= 0.5:
            q[j] = hi_v - step * (1.0 - gamma)
        else:
            q[j] = lo_v + step * gamma
    # median of the quietest block
    a = bounds[best, 0]
    m = bounds[best, 1] - a
    h = m // 2
    for j in range(k):
        for i in range(m):
            col[i] = x[a + i, j]
        sort_head(col, m)
        if m % 2 == 1:
            med[j] = (0.0 + col[h]) / 1.0
        else:
            med[j] = (0.0 + col[h - 1] + col[h]) / 2.0
    return best


def block_sigma_loops(t, x, span, block, q, med):
    """The whole per-block work of ``_block_sigma(t, x, span, block)`` in one call: :func:`block_edges`,
    :func:`block_noise`, then :func:`block_pick` writing the lower quartile of the sigmas into `q` (k,)
    and the quietest block's median into `med` (k,). Returns the number of blocks (0: none of five
    samples, -1: a non-finite value; `q` and `med` are then not written)."""
    edges = block_edges(t, span, block)
    nc = max(edges.shape[0] - 1, 0)
    k = x.shape[1]
    bounds = np.empty((nc, 2), dtype=np.int64)
    sig = np.empty((nc, k))
    spread = np.empty((nc, k))
    nb = block_noise(x, edges, bounds, sig, spread)
    if nb > 0:
        block_pick(x, bounds, nb, sig, spread, q, med)
    return nb


#: The functions numba compiles, callees first.
_FUNCTIONS = ("moving_stats", "motion_flags", "sift_down", "sort_head", "block_edges", "block_noise",
              "block_pick", "block_sigma_loops")
compiled = loops(globals(), _FUNCTIONS)
