"""Loops of the per-recording signal work that numba compiles.

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
- :func:`window_spread`, the moving spread and mean of the gyro on the uniform grid that
  :func:`morpi_filters.steps.activity_span` and ``field_aided.still_spans`` threshold;
- :func:`motion_flags`, the samples :func:`morpi_filters.calibration.detect_rest` takes as
  moving: a gyro deviation or spread, or an accelerometer spread, above its threshold on any axis;
- :func:`increments`, the integral of sampled signals over each interval of the real time grid
  (the corrected trapezoid of :mod:`morpi_filters.strapdown`: 3-point slopes, cubic Hermite
  interpolant), the element-wise arithmetic in numpy's order, the velocity and
  position they give (:func:`translation`), the attitude increments' coning term (:func:`coning`),
  :func:`running_integral`, the plain trapezoid's running sum, and :func:`time_order`, the check that
  sample times are finite and strictly increasing;
- :func:`filtfilt`, the zero-phase low-pass of :func:`morpi_filters.steps.lowpass`: the
  forward-backward second-order-sections filter of :func:`scipy.signal.sosfiltfilt` with its
  default odd padding, each section's update in the order scipy's own loop takes;
- :func:`interp1` and :func:`interp`, ``np.interp`` with numpy's arithmetic, for the compiled turn heading below (code
  outside the compiled loops calls ``np.interp`` itself), and :func:`swing_median`, the median heading
  swing of a step rule (``searchsorted`` and ``reduceat`` windows);
- :func:`turn_values`, the turn heading of ``steps.turn_heading`` at the step edges, with the turning
  stretches of ``steps.turn_stretches``, comparison for comparison and with :func:`interp1`;
- :func:`reading_sums`, what :func:`morpi_filters.steps.step_sums` returns for one step rule: the steps
  between the boundaries under each end and heading reading, summed in step order (the rule searches
  read thousands of rules per run);
- :func:`loo_errors`, the leave-one-out end-point errors the rule searches score
  (``field.loo_errors``), the gains summed in order (the search's choices are tie-tolerant,
  ``choice.choose``, so the numpy form is met within rounding, not bit for bit).

numba is imported on the first call (:func:`compiled`, through :func:`jit_functions`, which also
compiles the loops of ``_aided_kernel``), not with the package, and its machine code is cached on disk
(so no function here calls itself: numba's cache does not hold recursive functions). The functions run
as plain Python too (slowly): the tests compare both, and hold them to the numpy or scipy form they
restate within the rounding their sums and filters allow, each bound written beside it (``tests/oracles``).
"""
from __future__ import annotations

import math
import threading

import numpy as np

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


def window_spread(w, k, sd, mean):
    """``sd[r]`` (m - k + 1,): the standard deviations of the columns of ``w[r:r + k]`` (w (m, c)) summed
    over the columns, and ``mean[r]`` (m - k + 1, c) their means, from running sums as
    ``steps.activity_span`` and ``field_aided.still_spans`` take them (``cumsum`` of `w` and of ``w * w``,
    differences over `k`, ``sqrt(maximum(var, 0))``, the columns added in order from 0.0), so numpy's
    bits."""
    m, c = w.shape
    c1 = np.zeros((m + 1, c))
    c2 = np.zeros((m + 1, c))
    for j in range(c):
        c1[1, j] = w[0, j]
        c2[1, j] = w[0, j] * w[0, j]
        for i in range(1, m):
            c1[i + 1, j] = c1[i, j] + w[i, j]
            c2[i + 1, j] = c2[i, j] + w[i, j] * w[i, j]
    for r in range(m - k + 1):
        s = 0.0
        for j in range(c):
            mu = (c1[r + k, j] - c1[r, j]) / k
            var = (c2[r + k, j] - c2[r, j]) / k - mu * mu
            if var < 0.0:                                       # np.maximum(var, 0.0) (NaN stays)
                var = 0.0
            s += math.sqrt(var)
            mean[r, j] = mu
        sd[r] = s


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


def running_integral(t, x, out):
    """``out[0] = 0``, ``out[i + 1] = out[i] + (x[i + 1] + x[i]) / 2 (t[i + 1] - t[i])`` for `t`, `x` (n,)."""
    out[0] = 0.0
    for i in range(t.shape[0] - 1):
        out[i + 1] = out[i] + 0.5 * (x[i + 1] + x[i]) * (t[i + 1] - t[i])


def _sections(sos, zi, y, start, stop, step):
    """Run the sections over ``y[start:stop:step]`` in place, from the states `zi` (sections, 2)."""
    for i in range(start, stop, step):
        x_cur = y[i]
        for s in range(sos.shape[0]):
            x_new = sos[s, 0] * x_cur + zi[s, 0]
            zi[s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + zi[s, 1]
            zi[s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
            x_cur = x_new
        y[i] = x_cur


def filtfilt(sos, zi, pad, x, out):
    """Forward-backward filter of `x` (n,) into `out` (n,): ``scipy.signal.sosfiltfilt(sos, x)``.

    `zi` (sections, 2) is ``scipy.signal.sosfilt_zi(sos)``, `pad` the odd extension's length at
    each end (``n > pad``).
    """
    n = x.shape[0]
    m = n + 2 * pad
    y = np.empty(m)
    for i in range(pad):
        y[i] = 2.0 * x[0] - x[pad - i]
        y[pad + n + i] = 2.0 * x[n - 1] - x[n - 2 - i]
    for i in range(n):
        y[pad + i] = x[i]
    z = np.empty((sos.shape[0], 2))
    for s in range(sos.shape[0]):
        z[s, 0] = zi[s, 0] * y[0]
        z[s, 1] = zi[s, 1] * y[0]
    _sections(sos, z, y, np.int64(0), m, np.int64(1))          # run-time integers: one compiled _sections
    for s in range(sos.shape[0]):
        z[s, 0] = zi[s, 0] * y[m - 1]
        z[s, 1] = zi[s, 1] * y[m - 1]
    _sections(sos, z, y, m - 1, np.int64(-1), np.int64(-1))
    for i in range(n):
        out[i] = y[pad + i]


def interp1(v, xp, fp):
    """``np.interp(v, xp, fp)`` at one point `v` for `xp` (m,) strictly increasing, with numpy's arithmetic
    (``slope * (v - xp[j]) + fp[j]``, the far end's form when that is NaN)."""
    m = xp.shape[0]
    if v > xp[m - 1]:
        return fp[m - 1]
    if v < xp[0]:
        return fp[0]
    lo = 0                                                      # xp[lo] <= v < xp[hi]
    hi = m
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xp[mid] <= v:
            lo = mid
        else:
            hi = mid
    if lo == m - 1 or xp[lo] == v:
        return fp[lo]
    slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo])
    r = slope * (v - xp[lo]) + fp[lo]
    if r != r:
        r = slope * (v - xp[lo + 1]) + fp[lo + 1]
        if r != r and fp[lo] == fp[lo + 1]:
            r = fp[lo]
    return r


def interp(x, xp, fp, out):
    """``out[:] = np.interp(x, xp, fp)`` for `xp` (m,) strictly increasing (:func:`interp1` at each point)."""
    for i in range(x.shape[0]):
        out[i] = interp1(x[i], xp, fp)


def swing_median(t, psi, at):
    """Median heading swing [deg] between the samples first at or after the times `at` (k,): what
    ``steps.extract._boundaries`` reads with ``np.searchsorted`` and ``np.maximum.reduceat``, so the same
    windows (the last one runs to the end of `psi`; a window of no sample is the sample it starts
    on); NaN for k < 2. `psi` is finite (a heading integrated from checked samples)."""
    k = at.shape[0]
    if k < 2:
        return np.nan
    n = t.shape[0]
    b = np.empty(k, np.int64)
    j = 0
    for i in range(k):                                          # at is increasing: one pass
        while j < n and t[j] < at[i]:
            j += 1
        b[i] = j
    sw = np.empty(k - 1)
    for i in range(k - 1):
        a = b[i]
        e = b[i + 1] if i < k - 2 else n
        if e <= a:
            e = a + 1
        if a >= n:                                              # past the last sample: numpy's reduceat refuses
            return np.nan
        hi = psi[a]
        lo = psi[a]
        for r in range(a + 1, e):
            if psi[r] > hi:
                hi = psi[r]
            if psi[r] < lo:
                lo = psi[r]
        sw[i] = (hi - lo) * (180.0 / math.pi)
    sort_head(sw, k - 1)
    h = (k - 1) // 2
    return sw[h] if (k - 1) % 2 else 0.5 * (sw[h - 1] + sw[h])


def _window_mean(a, b, t, psi, integral):
    """The mean of the heading `psi` over ``[a, b]`` from its running `integral` (the heading at `a` for
    ``b - a <= 1e-9``), as ``steps.turn_heading`` reads it."""
    if b - a <= 1e-9:
        return interp1(a, t, psi)
    return (interp1(b, t, integral) - interp1(a, t, integral)) / (b - a)


def turn_values(bt, psi_b, threshold, per_period, x, t, psi, integral, out):
    """``steps.turn_heading(x, t, psi, steps.turn_stretches(bt, psi_b, threshold, per_period),
    integral=integral)`` into `out` (like `x`), comparison for comparison and with numpy's
    arithmetic (:func:`interp1`); returns the number of turning stretches.

    A full period's heading change ``psi_b[j + per_period] - psi_b[j]`` above `threshold` in
    magnitude turns; turning windows that overlap or touch merge, widen by a period on each side
    and merge again; each stretch's turn is the mean heading over the period after it minus the
    mean over the period before, followed in proportion to the heading inside the stretch.
    """
    k = bt.shape[0]
    for i in range(x.shape[0]):
        out[i] = 0.0
    last = k - 1
    count = 0
    j = 0
    span_a = np.int64(-1)                                       # run-time integers: one compiled _add_turn
    span_b = np.int64(-1)
    while j <= k - 1 - per_period:
        if abs(psi_b[j + per_period] - psi_b[j]) > threshold:
            # a run of turning windows, consecutive ones at most per_period apart
            first = j
            end = j
            j += 1
            while j <= k - 1 - per_period:
                if abs(psi_b[j + per_period] - psi_b[j]) > threshold:
                    if j - end > per_period:
                        break
                    end = j
                j += 1
            a = first - per_period
            a = a if a > 0 else 0
            b = end + per_period + per_period
            b = b if b < last else last
            if span_b >= 0 and a <= span_b:
                span_b = b                                      # merges with the stretch before
            else:
                if span_b >= 0:
                    _add_turn(bt, span_a, span_b, per_period, last, x, t, psi, integral, out)
                    count += 1
                span_a = a
                span_b = b
        else:
            j += 1
    if span_b >= 0:
        _add_turn(bt, span_a, span_b, per_period, last, x, t, psi, integral, out)
        count += 1
    return count


def _add_turn(bt, a, b, per_period, last, x, t, psi, integral, out):
    """Add the turn of the stretch between boundaries `a` and `b` to `out` (``steps.turn_heading``)."""
    i0 = a - per_period
    before = bt[i0 if i0 > 0 else 0]
    i1 = b + per_period
    after = bt[i1 if i1 < last else last]
    sa = bt[a]
    sb = bt[b]
    turn = _window_mean(sb, after, t, psi, integral) - _window_mean(before, sa, t, psi, integral)
    pa = interp1(sa, t, psi)
    pb = interp1(sb, t, psi)
    for i in range(x.shape[0]):
        v = x[i]
        if pb != pa:
            c = v if v > sa else sa                             # np.clip(time, a, b)
            c = c if c < sb else sb
            done = (interp1(c, t, psi) - pa) / (pb - pa)
        else:
            done = 1.0 if v >= sb else 0.0
        done = done if done > 0.0 else 0.0                      # np.clip(done, 0, 1)
        done = done if done < 1.0 else 1.0
        out[i] += turn * done


def loo_errors(g, u, keep, end, dist, out):
    """End-point errors [%] of the runs flagged in `keep` with the mean gain of the other flagged runs:
    ``field._loo_errors`` of ``g[keep]``, ``u[keep]`` (g (n,), u (n, 2)), each run against its own true
    end point ``end[i]`` (n, 2) and distance ``dist[i]`` (n,) (the gains summed in order: a score, chosen
    among within the tie tolerance of ``choice.choose``, so another order's rounding does not matter);
    the m errors in ``out[:m]``, returns m."""
    m = 0
    total = 0.0
    for i in range(g.shape[0]):
        if keep[i]:
            total += g[i]
            m += 1
    j = 0
    for i in range(g.shape[0]):
        if keep[i]:
            gi = (total - g[i]) / (m - 1)
            dx = gi * u[i, 0] - end[i, 0]
            dy = gi * u[i, 1] - end[i, 1]
            out[j] = math.sqrt(dx * dx + dy * dy) / dist[i] * 100
            j += 1
    return m


def reading_sums(bt, psi_b, weight, aux, m0, m1, psi_m0, psi_m1, per, wmed, ends, heading):
    """``(w, ux, uy, n)`` of the steps between the boundaries `bt` (k,), in the order the steps run.

    `psi_b` (k,) the heading at the boundaries, `weight` (k - 1,) the Weinberg weights of the whole
    steps, `m0`, `m1` the motion's ends with their headings `psi_m0`, `psi_m1`, `per` and `wmed` the
    median step duration and weight (the partial end steps'); `ends` 0 drop, 1 fraction, 2 whole;
    `heading` 0 the heading at the step's end, 1 its change over the step, 2 the change plus the turn
    heading at the step's start, 3 the mean over the step. `aux` (k + 2,) holds a value at
    ``[m0, bt..., m1]``: the turn heading (2) or the heading's running integral (3). A step's heading
    and weight are those of ``steps.extract._find_steps``, element for element; ``w = sum(weight * fraction)``,
    ``(ux, uy) = sum(weight * fraction * [cos, sin](heading))``.
    """
    k = bt.shape[0]
    f0 = 1.0
    f1 = 1.0
    if ends != 0:
        f0 = (bt[0] - m0) / per
        f1 = (m1 - bt[k - 1]) / per
        f0 = 0.0 if f0 < 0.0 else (1.0 if f0 > 1.0 else f0)
        f1 = 0.0 if f1 < 0.0 else (1.0 if f1 > 1.0 else f1)
        if ends == 2:
            f0 = 1.0 if f0 >= 0.5 else 0.0
            f1 = 1.0 if f1 >= 0.5 else 0.0
    n = k - 1 if ends == 0 else k + 1
    w = 0.0
    ux = 0.0
    uy = 0.0
    for j in range(n):
        if ends == 0:
            s = j + 1                                           # aux index of the step's start
            st, et, ps, pe, wf = bt[j], bt[j + 1], psi_b[j], psi_b[j + 1], weight[j]
        elif j == 0:
            s = 0
            st, et, ps, pe, wf = m0, bt[0], psi_m0, psi_b[0], wmed * f0
        elif j == k:
            s = k
            st, et, ps, pe, wf = bt[k - 1], m1, psi_b[k - 1], psi_m1, wmed * f1
        else:
            s = j
            st, et, ps, pe, wf = bt[j - 1], bt[j], psi_b[j - 1], psi_b[j], weight[j - 1] * 1.0
        if heading == 0:
            d = pe
        elif heading == 1:
            d = pe - ps
        elif heading == 2:
            d = pe - ps + aux[s]
        else:
            span = et - st
            d = (aux[s + 1] - aux[s]) / span if span > 1e-9 else ps
        w += wf
        ux += wf * math.cos(d)
        uy += wf * math.sin(d)
    return w, ux, uy, n


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
_FUNCTIONS = (
    "moving_stats", "window_spread", "motion_flags",
    "sift_down", "sort_head", "block_edges", "block_noise", "block_pick", "block_sigma_loops",
    "increments", "coning", "translation", "time_order", "running_integral",
    "_sections", "filtfilt",
    "loo_errors",
    "interp1", "interp", "swing_median", "_window_mean", "_add_turn", "turn_values", "reading_sums",
)
_COMPILED = None
#: Held while a module's functions are put through numba: threads that reach a kernel at once (a study's
#: chunks on threads or Dask workers) wrap each function once, never a function already wrapped.
COMPILE_LOCK = threading.Lock()


def jit_functions(space: dict, names) -> dict:
    """Compile the functions `names` of a module's namespace `space` with numba (callees first), each put
    back in `space` so the later ones call the compiled forms; returns them by name. numba is imported
    here, and its machine code is cached on disk."""
    import numba

    out = {}
    for name in names:
        out[name] = space[name] = numba.njit(cache=True, nogil=True)(space[name])
    return out


def read_only(a, dtype=float) -> np.ndarray:
    """A read-only C-ordered view of `a` as `dtype` (a copy only where `a` is not already one).

    numba compiles a loop once per argument type, and a read-only array is another type than a
    writeable one: the callers hand every input array of a compiled loop through here, so a loop
    compiles once whether its caller's array is frozen or not (each compilation costs up to seconds on
    a fresh install)."""
    v = np.ascontiguousarray(a, dtype=dtype).view()
    v.flags.writeable = False
    return v


def compiled():
    """The functions of :data:`_FUNCTIONS` compiled by numba, by name (once per process)."""
    global _COMPILED
    if _COMPILED is None:
        with COMPILE_LOCK:
            if _COMPILED is None:
                _COMPILED = jit_functions(globals(), _FUNCTIONS)
    return _COMPILED
