"""Loops of the MoRPI steps that numba compiles (:mod:`morpi_filters.steps`).

- :func:`window_spread`, the moving spread and mean of the gyro on the uniform grid that
  :func:`morpi_filters.steps.activity_span` and ``field_aided.still_spans`` threshold (through
  ``steps.prepare.window_spread``);
- :func:`running_integral`, the plain trapezoid's running sum of a heading
  (``steps.prepare.running_integral``, the mean heading over a step or a period);
- :func:`filtfilt`, the zero-phase low-pass of :func:`morpi_filters.steps.lowpass`: the
  forward-backward second-order-sections filter of :func:`scipy.signal.sosfiltfilt` with its
  default odd padding, each section's update in the order scipy's own loop takes (:func:`_sections`);
- :func:`interp1`, ``np.interp`` at one point with numpy's arithmetic, for the compiled turn heading below (code
  outside the compiled loops calls ``np.interp`` itself), and :func:`swing_median`, the median heading
  swing of a step rule (``searchsorted`` and ``reduceat`` windows; sorted by calibration's
  ``sort_head``, ``_calibration_loops``);
- :func:`turn_values`, the turn heading of ``steps.turn_heading`` at the step edges, with the turning
  stretches of ``steps.turn_stretches``, comparison for comparison and with :func:`interp1`
  (:func:`_add_turn`, :func:`_window_mean`);
- :func:`reading_sums`, what :func:`morpi_filters.steps.step_sums` returns for one step rule: the steps
  between the boundaries under each end and heading reading, summed in step order (the rule searches
  read thousands of rules per run).

numba is imported on the first call (:data:`compiled`, made by ``_jit.loops``), not with the package, and its
machine code is cached on disk (so no function here calls itself: numba's cache does not hold recursive
functions). The functions run as plain Python too (slowly): the tests compare both, and hold them to the
numpy or scipy form they restate within the rounding their sums and filters allow, each bound written beside
it (``tests/oracles``).
"""
from __future__ import annotations

import math

import numpy as np

from .._calibration_loops import compiled as calibration_loops, sort_head
from .._jit import loops


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


#: The functions numba compiles, callees first.
_FUNCTIONS = ("window_spread", "running_integral", "_sections", "filtfilt", "interp1",
              "swing_median", "_window_mean", "_add_turn", "turn_values", "reading_sums")
compiled = loops(globals(), _FUNCTIONS, uses=(calibration_loops,))
