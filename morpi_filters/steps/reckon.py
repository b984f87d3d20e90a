"""Step length and dead reckoning: the Weinberg length, gain training and the MoRPI track."""
from __future__ import annotations


import numpy as np

from ..errors import DataError, ParameterError
from .rules import MorpiTrack, Steps



def weinberg_length(vmax, vmin, gain):
    """Weinberg step length ``gain * (vmax - vmin)^(1/4)`` (broadcasts).

    Parameters
    ----------
    vmax, vmin : array_like
        Largest and smallest signal value in each step (vmax >= vmin).
    gain : float or array_like
        Weinberg gain [m / unit^(1/4)].

    Returns
    -------
    ndarray
        Step lengths [m].

    Examples
    --------
    >>> float(weinberg_length(3.0, -13.0, 0.5))     # 0.5 * 16 ** 0.25
    1.0
    """
    d = np.asarray(vmax, dtype=float) - np.asarray(vmin, dtype=float)
    if np.any(d < 0):
        raise ParameterError("weinberg_length: expected vmax >= vmin in every step")
    return np.asarray(gain, dtype=float) * d ** 0.25


def train_gain(steps_list, distances):
    """Weinberg gain from training runs with known travelled distances.

    Each run's gain solves ``gain * sum(weight * fraction) = distance``; the
    result is the mean over runs (the paper's protocol) and their std.

    Parameters
    ----------
    steps_list : sequence of Steps or of float
        The steps of each training run (:func:`extract_steps`), or their
        effective weights (:attr:`Steps.effective_weight`, the ``w`` of
        :func:`step_sums`).
    distances : float or sequence of float
        Travelled distance of each run [m]; one value serves every run.

    Returns
    -------
    (mean, std, per_run) : (float, float, ndarray of shape (runs,))
        A flat 3-tuple: the mean and std (ddof=0) of the per-run gains, and the
        per-run gains [m / unit^(1/4)].

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> from morpi_filters.steps import extract_steps
    >>> s = extract_steps(rec, "MoRPI-G")
    >>> mean, std, per_run = train_gain([s, s], 6.3)
    >>> per_run.shape, std, bool(mean == per_run[0])
    ((2,), 0.0, True)
    """
    steps_list = list(steps_list)
    if not steps_list:
        raise ParameterError("train_gain: no training runs")
    d = np.broadcast_to(np.asarray(distances, float), (len(steps_list),))
    w = np.array([s if isinstance(s, (float, int, np.floating)) else s.effective_weight for s in steps_list],
                 dtype=float)
    if np.any(w <= 0):
        raise DataError("train_gain: a training run has no step amplitude")
    g = d / w
    return float(g.mean()), float(g.std()), g


def dead_reckon(length, heading, p0=(0.0, 0.0)):
    """Positions ``x += s cos(dpsi), y += s sin(dpsi)``, shape (k + 1, 2) [m].

    Parameters
    ----------
    length : array_like, shape (k,)
        Step lengths [m].
    heading : array_like, shape (k,)
        Heading of each step [rad].
    p0 : (float, float)
        Starting position [m].

    Returns
    -------
    ndarray, shape (k + 1, 2)
        `p0` followed by the position after each step [m].

    Examples
    --------
    >>> dead_reckon([1.0, 2.0], [0.0, np.pi / 2]).round(12).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]]
    """
    length = np.asarray(length, float)
    heading = np.asarray(heading, float)
    d = np.column_stack([length * np.cos(heading), length * np.sin(heading)])
    out = np.empty((length.shape[0] + 1, 2))
    out[0] = p0
    np.cumsum(d, axis=0, out=out[1:])
    out[1:] += np.asarray(p0, float)
    return out


def morpi_track(steps: Steps, gain: float) -> MorpiTrack:
    """Dead-reckon a run's steps with a trained gain.

    Parameters
    ----------
    steps : Steps
        The run's steps (:func:`extract_steps`).
    gain : float
        Weinberg gain [m / unit^(1/4)].

    Returns
    -------
    MorpiTrack
        Step lengths ``gain * weight * fraction``, shape (k,), and positions,
        shape (k + 1, 2), starting at the origin [m].

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> from morpi_filters.steps import DEFAULT_CONFIGS, extract_steps
    >>> track = morpi_track(extract_steps(rec, "MoRPI-G", DEFAULT_CONFIGS["MoRPI-G"]), gain=1.0)
    >>> track.position.shape[1], track.length.shape == track.steps.weight.shape
    (2, True)
    """
    length = gain * steps.weight * steps.fraction
    return MorpiTrack(steps=steps, gain=float(gain), length=length, position=dead_reckon(length, steps.heading))
