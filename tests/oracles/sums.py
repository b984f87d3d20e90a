"""Numpy forms of the compiled loops' running and window sums, and the rounding bounds they are compared within.

The compiled loops add in row order; numpy adds in an order of its own (pairwise for a reduction, and free to
change between releases). Two evaluations of the same sum in different orders differ by at most the sum of their
two error bounds: a sum of k terms computed in any order lies within ``gamma(k - 1) * sum(|terms|)`` of the exact
one (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., section 4.2, eq. (4.4);
``gamma(k) = k u / (1 - k u)``, ``u`` the unit roundoff, lemma 3.1). Each further operation on a result adds one
rounding (``u`` relative, the standard model (2.4)).
"""
from __future__ import annotations

import numpy as np

U = np.finfo(float).eps / 2                                   # unit roundoff of binary64


def gamma(k):
    """Higham's ``gamma_k = k u / (1 - k u)`` (lemma 3.1), elementwise."""
    k = np.asarray(k, dtype=float)
    return k * U / (1.0 - k * U)


def assert_within(got, want, bound, err_msg=""):
    """``|got - want| <= bound`` elementwise; NaN matches NaN and an infinity the same infinity exactly."""
    got, want = np.asarray(got), np.asarray(want)
    assert got.shape == want.shape, (got.shape, want.shape, err_msg)
    bound = np.broadcast_to(np.asarray(bound, dtype=float), want.shape)
    same = (got == want) | (np.isnan(got) & np.isnan(want))
    with np.errstate(invalid="ignore"):
        err = np.abs(got - want)
    ok = same | (np.isfinite(want) & (err <= bound))
    if not ok.all():
        i = np.unravel_index(np.flatnonzero(~ok)[0], want.shape)
        raise AssertionError(f"{err_msg}: {(~ok).sum()} of {ok.size} outside the bound; first at {i}: "
                             f"got {got[i]!r}, want {want[i]!r}, bound {bound[i]!r}")


def prefix_bound(terms, axis=0):
    """Bound on the difference of two evaluations, in any orders, of the running sums ``0, t0, t0 + t1, ...`` of
    `terms` along `axis` (length n + 1 along `axis`): each lies within ``gamma(k) sum_{i<k} |t_i|`` of the exact
    sum of its k terms, so the two within twice that."""
    a = np.moveaxis(np.abs(np.asarray(terms, dtype=float)), axis, 0)
    s = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)])
    k = np.arange(s.shape[0]).reshape((-1,) + (1,) * (a.ndim - 1))
    # the sum of |t| is itself rounded: (1 + gamma(k)) covers it
    return np.moveaxis(2.0 * gamma(k) * (1.0 + gamma(k)) * s, 0, axis)


def window_moments(d, lo, hi):
    """Mean and variance of the rows ``d[lo[i]:hi[i]]`` (d (n, k)) from running sums of `d` and ``d * d`` written
    with numpy (``cumsum`` and differences, ``E[d^2] - E[d]^2``), with bounds on how far another evaluation order
    of the same sums can move each: ``(mean, var, mean_bound, var_bound)``, var not clamped."""
    c1 = np.vstack([np.zeros((1, d.shape[1])), np.cumsum(d, axis=0)])
    c2 = np.vstack([np.zeros((1, d.shape[1])), np.cumsum(d * d, axis=0)])
    b1, b2 = prefix_bound(d), prefix_bound(d * d)
    cnt = (hi - lo)[:, None].astype(float)
    s1, s2 = c1[hi] - c1[lo], c2[hi] - c2[lo]
    mean = s1 / cnt
    var = s2 / cnt - mean ** 2
    # the two sums' bounds, then a subtraction and a division per side (2 u of the result each, both sides)
    dm = (b1[hi] + b1[lo]) / cnt + 4.0 * U * np.abs(mean)
    # E[d^2]: as the mean; m^2 moves by 2 |m| dm + dm^2 and rounds; the difference rounds
    dv = (b2[hi] + b2[lo]) / cnt + 4.0 * U * np.abs(s2 / cnt) + (2.0 * np.abs(mean) + dm) * dm \
        + 4.0 * U * mean ** 2 + 2.0 * U * np.abs(var)
    return mean, var, dm, dv


def std_bound(var, dv):
    """Bound on ``|sqrt(max(v1, 0)) - sqrt(max(v2, 0))|`` for ``|v1 - v2| <= dv`` around `var`, plus the square
    root's own rounding on both sides: the clamp is 1-Lipschitz, and ``|sqrt a - sqrt b| = |a - b| / (sqrt a +
    sqrt b) <= min(|a - b| / sqrt(max(a, b)), sqrt |a - b|)``."""
    top = np.sqrt(np.maximum(var, 0.0) + dv)
    with np.errstate(divide="ignore", invalid="ignore"):
        lin = np.where(top > 0, dv / top, 0.0)
    return np.minimum(lin, np.sqrt(dv)) + 2.0 * U * top


def moving_stats(t, x, half):
    """``calibration._moving_stats`` with numpy: each window's ends by a binary search, the sums taken from
    ``x[0]``. Returns ``(mean, std, mean_bound, std_bound)``, each (n, k)."""
    ref = x[0]
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    m, v, dm, dv = window_moments(x - ref, lo, hi)
    mean = m + ref
    return mean, np.sqrt(np.maximum(v, 0.0)), dm + 2.0 * U * np.abs(mean), std_bound(v, dv)


def window_spread(w, k):
    """``steps.prepare.window_spread`` with numpy: the standard deviations of the columns of each ``w[r:r + k]``
    summed over the columns, and their means. Returns ``(sd, mean, sd_bound, mean_bound)``."""
    m = w.shape[0]
    lo = np.arange(m - k + 1)
    mean, v, dm, dv = window_moments(w, lo, lo + k)
    std = np.sqrt(np.maximum(v, 0.0))
    sd = std.sum(axis=1)
    # the columns' bounds add; the sum of c columns rounds c - 1 times (gamma(c) of the sum of |terms|)
    return sd, mean, std_bound(v, dv).sum(axis=1) + 2.0 * gamma(w.shape[1]) * sd, dm


def filtfilt_bound(sos, x_max):
    """Bound on the difference of two evaluations in other orders of ``scipy.signal.sosfiltfilt(sos, x)``, with
    ``|x| <= x_max`` (the odd extension: ``<= 3 x_max``), from the filter's condition. With ``K`` the product of
    the sections' impulse-response l1 norms (at least 1 each: the gain of the cascade and of any part of it),
    ``L`` that of their recursive parts ``1 / A`` (how far an error made inside a section carries) and ``C`` the
    largest section coefficient sum, each step of a section rounds three results of size at most ``C K X``; an
    error carried through the rest of the pass grows by at most ``K L``. One pass: ``3 s u C K^2 L X`` over the
    s sections; the backward pass carries the forward pass's error (gain ``K``) and adds its own on a signal up
    to ``K X``: ``6 s u C K^3 L X``; both sides: twice that."""
    from scipy import signal

    imp = np.zeros(1 << 18)
    imp[0] = 1.0
    K = np.prod([max(1.0, np.abs(signal.sosfilt(s[None], imp)).sum()) for s in sos])
    L = np.prod([max(1.0, np.abs(signal.lfilter([1.0], s[3:], imp)).sum()) for s in sos])
    C = max(np.abs(s).sum() for s in sos)
    return 2.0 * 6.0 * len(sos) * U * C * K ** 3 * L * (3.0 * x_max)


def percentile_bound(x, q):
    """Bound on the difference of two evaluations of the linear-method percentile `q` (in %) of `x`: both
    interpolate between the same two order statistics a <= b; the position ``(n - 1) q / 100`` may round
    differently (2 u of it: its fraction moves by up to ``2 u (n - 1)``, the value by that times ``b - a``) and
    the interpolation ``a + g (b - a)`` (or its mirror from b) rounds three times, each at most u of
    ``max(|a|, |b|)``, on both sides."""
    s = np.sort(np.asarray(x, dtype=float))
    n = s.size
    v = (n - 1) * (q / 100.0)
    i = min(int(np.floor(v)), n - 1)
    a, b = s[i], s[min(i + 1, n - 1)]
    return 2.0 * (2.0 * U * (n - 1) * (b - a) + 3.0 * U * max(abs(a), abs(b)) * 2.0)
