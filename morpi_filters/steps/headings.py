"""Step headings over several periods: heading change per period, turn stretches and the turn heading."""
from __future__ import annotations


import numpy as np

from ..errors import ParameterError
from .prepare import running_integral



def period_changes(boundary_heading, per_period: int) -> np.ndarray:
    """Heading change over each full period of consecutive step boundaries [rad].

    Parameters
    ----------
    boundary_heading : array_like, shape (k,)
        Heading at the step boundaries (the peaks, partial end steps left
        out) [rad].
    per_period : int
        Steps per full period: 2 for half-period steps between extrema, 1 for
        steps between maxima.

    Returns
    -------
    ndarray, shape (k - per_period,)
        ``psi[j + per_period] - psi[j]``: sliding windows, one starting at
        each boundary. Between two boundaries of the same phase the sine's
        zigzag cancels, so on a straight run what is left is the drift over a
        period and the phase jitter of the boundaries.

    Examples
    --------
    >>> period_changes([0.0, 0.4, 0.1, 0.5, 1.1, 1.4], 2).round(12).tolist()
    [0.1, 0.1, 1.0, 0.9]
    """
    h = np.asarray(boundary_heading, float)
    if per_period not in (1, 2):
        raise ParameterError(f"per_period={per_period!r}: expected 1 (steps between maxima) or 2 (between extrema)")
    if h.shape[0] <= per_period:
        return np.empty(0)
    return h[per_period:] - h[:-per_period]


def turn_stretches(boundary_time, boundary_heading, threshold: float, per_period: int) -> list:
    """The turning stretches of a run, with the full periods around them [s].

    A full period (:func:`period_changes`) whose heading change exceeds
    `threshold` in magnitude is turning; turning periods that overlap or
    touch merge into one stretch, which is widened by one full period on each
    side (a turn eases in and out through periods below the threshold), and
    stretches that then overlap merge. A turn spread over several periods is
    so one stretch. The full periods just before and after each stretch are
    returned with it: the turn is measured between their mean headings
    (:func:`turn_heading`), where the zigzag of the sine cancels whatever
    the phase of the boundaries.

    Parameters
    ----------
    boundary_time, boundary_heading : array_like, shape (k,)
        Step boundaries [s] and the heading there [rad].
    threshold : float
        Least full-period heading change of a turn [rad].
    per_period : int
        Steps per full period (2 between extrema, 1 between maxima).

    Returns
    -------
    list of (float, float, float, float)
        ``(before, start, end, after)`` per stretch, in time order,
        non-overlapping: the stretch is ``[start, end]``, the full periods
        around it ``[before, start]`` and ``[end, after]`` (shorter or
        empty at the run's first or last boundary).

    Examples
    --------
    >>> t = np.arange(14.0)      # zigzag, a 90 deg turn over three half periods, zigzag
    >>> psi = np.radians([0, 20, 0, 20, 0, 20, 60, 90, 110, 90, 110, 90, 110, 90])
    >>> turn_stretches(t, psi, np.radians(45), 2)
    [(0.0, 2.0, 10.0, 12.0)]
    """
    bt = np.asarray(boundary_time, float)
    h = np.asarray(boundary_heading, float)
    c = period_changes(h, per_period)
    on = np.flatnonzero(np.abs(c) > threshold)
    if on.size == 0:
        return []
    last = h.shape[0] - 1
    spans = []
    # window j covers boundaries [j, j + per_period]; windows overlapping or touching merge
    breaks = np.flatnonzero(np.diff(on) > per_period)
    for a, b in zip(np.r_[on[0], on[breaks + 1]], np.r_[on[breaks], on[-1]] + per_period):
        a, b = max(int(a) - per_period, 0), min(int(b) + per_period, last)
        if spans and a <= spans[-1][1]:
            spans[-1] = (spans[-1][0], b)
        else:
            spans.append((a, b))
    return [(float(bt[max(a - per_period, 0)]), float(bt[a]), float(bt[b]), float(bt[min(b + per_period, last)]))
            for a, b in spans]


def turn_heading(time, t, psi, stretches, *, integral=None) -> np.ndarray:
    """The heading followed only through the turning stretches, at `time` [rad].

    Zero before the first stretch; between stretches it holds the sum of the
    turns passed. A stretch's turn is the mean heading over the full period
    after it minus the mean over the full period before it (the heading at
    the stretch's end or start when there is no such period); inside the
    stretch it grows with the heading, in proportion to how much of the
    stretch's heading change is done. The gyro drift outside the stretches
    and their neighbouring periods never enters it.

    Parameters
    ----------
    time : array_like
        Where to read it [s].
    t, psi : array_like, shape (n,)
        The heading on its samples [s], [rad].
    stretches : sequence of (float, float, float, float)
        :func:`turn_stretches`.
    integral : array_like, shape (n,), optional
        The heading's trapezoidal integral from the first sample [rad s]
        (:attr:`PreparedSignal.heading_integral`); computed when not given.

    Returns
    -------
    ndarray, shape like `time`
        The turn heading at `time` [rad].

    Examples
    --------
    >>> t = np.array([0.0, 1.0, 2.0, 3.0, 4.0]); psi = np.array([0.0, 0.2, 1.2, 1.4, 1.2])
    >>> turn_heading([0.0, 1.5, 4.0], t, psi, [(0.0, 1.0, 2.0, 4.0)]).round(12).tolist()
    [0.0, 0.6, 1.2]
    """
    time = np.asarray(time, float)
    t = np.asarray(t, float)
    psi = np.asarray(psi, float)
    out = np.zeros(time.shape)
    if not len(stretches):
        return out
    if integral is None:
        cpsi = running_integral(t, psi)
    else:
        cpsi = np.asarray(integral, float)
        if cpsi.shape != t.shape:
            raise ParameterError(f"turn_heading: integral of shape {cpsi.shape}, expected {t.shape} (one per sample)")

    def mean(a, b):
        if b - a <= 1e-9:
            return float(np.interp(a, t, psi))
        return float((np.interp(b, t, cpsi) - np.interp(a, t, cpsi)) / (b - a))

    for before, a, b, after in stretches:
        turn = mean(b, after) - mean(before, a)
        pa, pb = np.interp([a, b], t, psi)
        done = (np.interp(np.clip(time, a, b), t, psi) - pa) / (pb - pa) if pb != pa else (time >= b) * 1.0
        out += turn * np.clip(done, 0.0, 1.0)
    return out
