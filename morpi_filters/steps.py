"""MoRPI step machinery: peak detection, Weinberg length, gain training, dead reckoning.

The robot drives a sine path; each period ("step", by analogy with pedestrian
dead reckoning) is found between peaks of a periodic IMU signal, its length is
estimated with the Weinberg formula [2]_

    s = G (max - min)^(1/4)

on the lateral specific force ``f_y`` (MoRPI-A) or on the z angular rate
``omega_z`` (MoRPI-G) [1]_, and the position is advanced with the gyro heading,
``x += s cos(dpsi), y += s sin(dpsi)``.

Sampling
    The recordings are not uniformly sampled (the S6 files wander between about
    50 and 100 Hz). Peak detection therefore resamples the signal by linear
    interpolation onto a uniform grid (:data:`GRID_HZ`, or the recording's
    median sample rate: :attr:`StepConfig.grid_hz`), low-pass filters it
    there (zero-phase Butterworth), runs :func:`scipy.signal.find_peaks` with
    the period and width converted to grid samples, and maps the peaks back to
    the nearest original sample. Heading is integrated on the original time
    stamps (trapezoid rule on the real steps).

Readings of the paper
    The paper leaves three points open; :class:`StepConfig` implements each
    reading as an option:

    ``heading`` (what Delta psi_k is)
        ``"absolute"``: the heading accumulated since the start, taken at the
        step's end peak; ``"mean"``: its mean over the step; ``"change"``: the
        heading change inside the step (end minus start); ``"turns"``: the
        step's heading change plus the turn heading at the step's start
        (:func:`turn_heading`: the heading followed only through the
        stretches whose full-period heading change exceeds
        :attr:`StepConfig.turn_deg`, held still elsewhere).
    ``segment`` (where a step starts and ends)
        ``"maxima"``: between consecutive maxima (one period); ``"extrema"``:
        between consecutive extrema (half periods, two per period).
    ``ends`` (the partial steps before the first and after the last peak)
        ``"drop"``: ignored; ``"fraction"``: counted as the fraction of the
        run's median step duration they last, with the run's median step
        length; ``"whole"``: counted as whole steps when at least half a step
        long.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023.
.. [2] H. Weinberg, "Using the ADXL202 in pedometer and personal navigation
   applications", Analog Devices AN-602, 2002.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from functools import cached_property, lru_cache
from typing import NamedTuple

import numpy as np

from .errors import DataError, ParameterError


def _signal():
    """scipy.signal, imported on first use (the step length alone does not need it)."""
    from scipy import signal

    return signal

__all__ = [
    "GRID_HZ", "ACTIVITY_WINDOW_S", "HEADINGS", "SEGMENTS", "ENDS", "HEADING_SOURCES", "METHODS", "StepConfig",
    "Peaks", "Steps", "MorpiTrack",
    "resample_uniform", "lowpass", "detect_peaks", "weinberg_length", "integrate_heading",
    "motion_span", "activity_span", "PreparedSignal", "prepare_signal", "extract_steps", "StepSums", "step_sums",
    "train_gain", "dead_reckon", "morpi_track", "DEFAULT_CONFIGS", "require_swing", "period_changes", "turn_stretches",
    "turn_heading",
]

#: Default rate of the uniform grid peak detection works on [Hz] (:attr:`StepConfig.grid_hz`).
GRID_HZ = 100.0
#: Window of :func:`activity_span` [s]: the motion onset is the last sample of the first active window.
ACTIVITY_WINDOW_S = 0.5
HEADINGS = ("absolute", "mean", "change", "turns")
SEGMENTS = ("maxima", "extrema")
ENDS = ("drop", "fraction", "whole")
#: What the heading is read from (:attr:`StepConfig.heading_source`).
HEADING_SOURCES = ("gyro", "attitude")
#: MoRPI method -> (signal attribute, column).
METHODS = {"MoRPI-A": ("f", 1), "MoRPI-G": ("omega", 2)}


@dataclass(frozen=True)
class StepConfig:
    """Every tunable of the step pipeline.

    The rule :func:`morpi_filters.field.select_config` picks from the train
    runs of the MoRPI field dataset (one per method, the way of choosing the
    nested train-only check prefers) is
    :data:`DEFAULT_CONFIGS`; a test keeps it in step with the search.

    Attributes
    ----------
    heading, segment, ends : str
        The readings of the paper (module docstring).
    min_period_s : float
        Shortest time between two peaks of the same kind [s].
    prominence : float
        Least peak prominence, as a fraction of the run's robust signal
        range (98th minus 2nd percentile during motion) [-].
    cutoff_hz : float or None
        Low-pass cut-off applied before peak detection [Hz]; None: none.
    amplitude_from : str
        ``"filtered"`` or ``"raw"``: which signal the Weinberg max - min is
        read from inside each step.
    min_swing_deg : float
        Least median heading swing (max - min of the heading between two
        consecutive maxima of the signal) for the motion to count as periodic
        [deg]. The designed sine paths swing by about 2 atan(2 pi A / lambda)
        = 64 deg (A = 0.1 m, lambda = 1 m); on the field recordings the
        periodic runs swing by 20 deg or more, the straight runs by 11 deg or
        less, hence 15 deg.
    heading_source : str
        What the heading is read from: ``"gyro"``, the integrated z angular
        rate, or ``"attitude"``, the yaw of the attitude matrix of the 3D
        mechanization (the paper's heading equation). Read by
        :class:`morpi_filters.field.FieldData`, which builds the heading; a
        heading passed to :func:`prepare_signal` is used as given.
    turn_deg : float
        Least heading change over one full period (two half-period steps
        between extrema, one step between maxima) that counts as a turn for
        the ``"turns"`` heading reading [deg]. On a straight sine the
        full-period change is the gyro drift over a period plus what is left
        of the zigzag between two boundaries of the same phase; the default
        is what :func:`morpi_filters.field.train_thresholds` sets on the
        straight train runs of the field dataset (1.5 times the largest
        full-period change they show, 34 deg).
    min_height : float or None
        Least peak value of the step signal, filtered when ``cutoff_hz`` is
        set, in its own SI unit (m/s^2 for MoRPI-A, rad/s for MoRPI-G);
        the minima that bound half-period steps (``segment="extrema"``)
        must lie at ``-min_height`` or below. Unlike ``prominence`` it is
        absolute, so it moves with a constant offset of the signal (a gyro
        bias, the calibration). None (the default): no height threshold.
    min_width_s : float or None
        Least peak width [s], at half the peak's prominence as
        :func:`scipy.signal.find_peaks` measures it; narrow spikes fall
        below it. None (the default): no width threshold.
    grid_hz : float or None
        Rate of the uniform grid the peaks are found on [Hz]; the default
        :data:`GRID_HZ` keeps the MoRPI field numbers. None: the
        recording's own median sample rate (``1 / median(diff(time))``),
        against which ``cutoff_hz`` is then checked when the signal is
        prepared (:func:`prepare_signal`).
    """

    heading: str = "mean"
    segment: str = "extrema"
    ends: str = "fraction"
    min_period_s: float = 0.5
    prominence: float = 0.35
    cutoff_hz: float | None = 3.0
    amplitude_from: str = "raw"
    min_swing_deg: float = 15.0
    turn_deg: float = 51.0
    heading_source: str = "gyro"
    min_height: float | None = None
    min_width_s: float | None = None
    grid_hz: float | None = GRID_HZ

    def __post_init__(self):
        for name, allowed in (("heading", HEADINGS), ("segment", SEGMENTS), ("ends", ENDS),
                              ("amplitude_from", ("filtered", "raw")), ("heading_source", HEADING_SOURCES)):
            if getattr(self, name) not in allowed:
                raise ParameterError(f"StepConfig.{name}={getattr(self, name)!r}: expected one of {allowed}")
        if not self.min_period_s > 0:
            raise ParameterError(f"StepConfig.min_period_s={self.min_period_s}: expected a positive time [s]")
        if not self.prominence >= 0:
            raise ParameterError(f"StepConfig.prominence={self.prominence}: expected a fraction >= 0")
        if self.min_height is not None and not _finite(self.min_height):
            raise ParameterError(f"StepConfig.min_height={self.min_height!r}: expected None or a finite peak value "
                                 "in the signal's unit (m/s^2 or rad/s)")
        for name in ("min_width_s", "grid_hz"):
            v = getattr(self, name)
            if v is not None and not (_finite(v) and v > 0):
                unit = "time [s]" if name == "min_width_s" else "rate [Hz]"
                raise ParameterError(f"StepConfig.{name}={v!r}: expected None or a positive finite {unit}")
        if self.cutoff_hz is not None:
            top = math.inf if self.grid_hz is None else self.grid_hz / 2
            if not (_finite(self.cutoff_hz) and 0 < self.cutoff_hz < top):
                half = "" if self.grid_hz is None else f" < {top:g} Hz (half of grid_hz)"
                raise ParameterError(f"StepConfig.cutoff_hz={self.cutoff_hz!r}: expected None or 0 < f{half}")
        if not 0 < self.turn_deg < 360:
            raise ParameterError(f"StepConfig.turn_deg={self.turn_deg}: expected a heading change "
                                 "0 < turn_deg < 360 [deg]")
        # a rule keys every cache of its steps and scores: its fields are hashed once
        object.__setattr__(self, "_hash", hash(tuple(getattr(self, f.name) for f in fields(self))))

    def __hash__(self):
        return self._hash

    def __getstate__(self):
        # the hash of strings differs between processes: a copy or a pickle hashes again
        return {k: v for k, v in self.__dict__.items() if k != "_hash"}

    def __setstate__(self, state):
        self.__dict__.update(state)
        object.__setattr__(self, "_hash", hash(tuple(getattr(self, f.name) for f in fields(self))))

    def with_(self, **kw) -> "StepConfig":
        """A copy with some fields changed.

    Examples
    --------
    >>> StepConfig().with_(prominence=0.3).prominence
    0.3
    """
        # the rule searches derive the same rules over and over: one instance per rule and change, whose
        # hash is then computed once and which a cache finds by identity
        try:
            key = (self, tuple(sorted(kw.items())))
            out = _DERIVED.get(key)
        except TypeError:                                       # an unhashable value: refused by the check
            return replace(self, **kw)
        if out is None:
            out = replace(self, **kw)
            if len(_DERIVED) < _DERIVED_MAX:
                _DERIVED[key] = out
        return out


def _finite(v) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)


#: Rules derived by :meth:`StepConfig.with_`, by rule and change (bounded: a search derives a few hundred).
_DERIVED: dict = {}
_DERIVED_MAX = 1 << 14


@dataclass(frozen=True)
class Peaks:
    """Peaks of a signal found on a uniform grid.

    Attributes
    ----------
    grid_time : ndarray, shape (m,)
        The uniform grid [s].
    grid_signal : ndarray, shape (m,)
        The resampled (and filtered, when asked) signal.
    grid_index : ndarray of int, shape (k,)
        Peak positions on the grid.
    index : ndarray of int, shape (k,)
        Nearest original samples.
    properties : dict
        As returned by :func:`scipy.signal.find_peaks` (grid samples).
    """

    grid_time: np.ndarray
    grid_signal: np.ndarray
    grid_index: np.ndarray
    index: np.ndarray
    properties: dict


@dataclass(frozen=True)
class Steps:
    """The steps of one run for one signal.

    Attributes
    ----------
    start_time, end_time : ndarray, shape (k,)
        Step boundaries [s].
    weight : ndarray, shape (k,)
        ``(max - min)^(1/4)`` of each step, in the signal's units to the 1/4
        (step length = gain * weight * fraction).
    fraction : ndarray, shape (k,)
        1 for whole steps; the counted fraction for partial end steps.
    heading : ndarray, shape (k,)
        Delta psi of each step [rad] (per the config's heading reading).
    peaks : Peaks
        The detected peaks.
    motion : tuple of float
        Motion start and end time [s].
    swing_deg : float
        Median heading swing per period (max - min of the heading between two
        consecutive maxima of the signal) [deg]; NaN with fewer than two maxima.
    """

    start_time: np.ndarray
    end_time: np.ndarray
    weight: np.ndarray
    fraction: np.ndarray
    heading: np.ndarray
    peaks: Peaks
    motion: tuple
    swing_deg: float = float("nan")

    @property
    def n(self) -> int:
        """Number of steps (partial ones included)."""
        return int(self.weight.shape[0])

    @cached_property
    def effective_weight(self) -> float:
        """sum(weight * fraction): travelled distance = gain * this."""
        return float(np.sum(self.weight * self.fraction))


@dataclass(frozen=True)
class MorpiTrack:
    """A MoRPI dead-reckoning solution.

    Attributes
    ----------
    steps : Steps
    gain : float
        Weinberg gain used [m / unit^(1/4)].
    length : ndarray, shape (k,)
        Step lengths [m].
    position : ndarray, shape (k + 1, 2)
        Positions after each step, starting at the origin [m].
    """

    steps: Steps
    gain: float
    length: np.ndarray
    position: np.ndarray

    @property
    def distance(self) -> float:
        """Travelled distance estimate: sum of the step lengths [m]."""
        return float(np.sum(self.length))

    @property
    def end_point(self) -> np.ndarray:
        """Last position, shape (2,) [m]."""
        return self.position[-1]

    def error(self, route) -> float:
        """End-point error against a route's ground truth [m] (the tables' measure).

        Parameters
        ----------
        route : dataset.Route or str
            The route or its folder name.
        """
        from .dataset import route as route_of

        r = route_of(route) if isinstance(route, str) else route
        return float(np.linalg.norm(self.end_point - np.asarray(r.end_point_m, float)))


# --------------------------------------------------------------------------- signals

#: The step rule of each method that :func:`morpi_filters.field.select_config`
#: picks on the field train runs (the defaults of :func:`extract_steps`).
DEFAULT_CONFIGS = {
    "MoRPI-A": StepConfig(ends="whole", prominence=0.2),
    "MoRPI-G": StepConfig(heading="turns", cutoff_hz=1.0),
}

def resample_uniform(time, values, rate_hz: float = GRID_HZ):
    """Linear interpolation of `values` (n,) or (n, k) onto a uniform grid.

    Parameters
    ----------
    time : array_like, shape (n,)
        Increasing sample times [s].
    values : array_like, shape (n,) or (n, k)
        Samples at `time`, one column per channel (any unit).
    rate_hz : float
        Rate of the uniform grid [Hz].

    Returns
    -------
    grid : ndarray, shape (m,)
        ``time[0] + j / rate_hz`` up to ``time[-1]`` [s].
    out : ndarray, shape (m,) or (m, k)
        `values` interpolated at `grid`, same unit and column layout.

    Examples
    --------
    >>> grid, x = resample_uniform([0.0, 0.015, 0.03], [0.0, 1.5, 3.0])
    >>> grid.round(12).tolist(), x.round(12).tolist()
    ([0.0, 0.01, 0.02, 0.03], [0.0, 1.0, 2.0, 3.0])
    """
    time = np.asarray(time, dtype=float)
    values = np.asarray(values, dtype=float)
    m = int(np.floor((time[-1] - time[0]) * rate_hz)) + 1
    grid = time[0] + np.arange(m) / rate_hz
    if values.ndim == 1:
        return grid, np.interp(grid, time, values)
    return grid, np.column_stack([np.interp(grid, time, values[:, j]) for j in range(values.shape[1])])


@lru_cache(maxsize=64)
def _butter(order: int, cutoff_hz: float, rate_hz: float):
    """The Butterworth sections, their steady-state initial conditions and the odd padding of
    :func:`scipy.signal.sosfiltfilt` (its default: three times the taps), read-only."""
    sig = _signal()
    sos = sig.butter(order, cutoff_hz, btype="low", fs=rate_hz, output="sos")
    zi = sig.sosfilt_zi(sos)
    ntaps = 2 * sos.shape[0] + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    for a in (sos, zi):
        a.flags.writeable = False
    return sos, zi, 3 * ntaps


def _median(x) -> float:
    """Median of a small 1-D array (np.median's overhead dominates at this size)."""
    x = np.sort(np.asarray(x, dtype=float))
    n = x.shape[0]
    return float(x[n // 2]) if n % 2 else float(0.5 * (x[n // 2 - 1] + x[n // 2]))


def lowpass(x, cutoff_hz: float, rate_hz: float = GRID_HZ, order: int = 2):
    """Zero-phase Butterworth low-pass of a uniformly sampled signal (axis 0).

    Parameters
    ----------
    x : ndarray, shape (m,) or (m, k)
        Uniformly sampled signal, filtered along axis 0 (any unit).
    cutoff_hz : float
        Cut-off frequency [Hz], below ``rate_hz / 2``.
    rate_hz : float
        Sampling rate of `x` [Hz].
    order : int
        Butterworth order of the single pass (the forward-backward pass
        doubles it) [-].

    Returns
    -------
    ndarray, shape like `x`
        The filtered signal (float); `x` unchanged, as float, when it is too
        short for :func:`scipy.signal.sosfiltfilt`'s padding.

    Examples
    --------
    >>> float(lowpass(np.ones(200), 1.0)[100].round(6))      # a constant passes unchanged
    1.0
    """
    sos, zi, pad = _butter(int(order), float(cutoff_hz), float(rate_hz))
    x = np.asarray(x, dtype=float)
    if x.shape[0] <= 3 * (2 * sos.shape[0] + 1):
        return x
    # scipy's sosfiltfilt (odd padding, steady-state start of both passes) as a compiled loop, per column
    filt = (_KERNELS or _kernels())["filtfilt"]
    if x.ndim == 1:
        out = np.empty(x.shape[0])
        filt(sos, zi, pad, np.require(x, float, ["C"]), out)
        return out
    cols = x.reshape(x.shape[0], -1)
    out = np.empty(cols.shape)
    col = np.empty(x.shape[0])
    for j in range(cols.shape[1]):
        filt(sos, zi, pad, np.array(cols[:, j], order="C"), col)
        out[:, j] = col
    return out.reshape(x.shape)


def detect_peaks(signal, time, *, min_period_s: float, min_prominence: float = 0.0,
                 min_width_s: float | None = None, cutoff_hz: float | None = None,
                 height=None, rate_hz: float = GRID_HZ, source: str = "<signal>"):
    """Maxima of a non-uniformly sampled signal, with parameters in seconds.

    The signal is resampled to a uniform grid at `rate_hz` (linear
    interpolation), optionally low-pass filtered at `cutoff_hz`, and passed to
    :func:`scipy.signal.find_peaks` with ``distance = min_period_s * rate_hz``
    and ``width = min_width_s * rate_hz`` grid samples.

    Parameters
    ----------
    signal : array_like, shape (n,)
        Samples in physical units (m/s^2, rad/s).
    time : array_like, shape (n,)
        Strictly increasing sample times [s].
    min_period_s : float
        Least time between two peaks [s].
    min_prominence : float
        Least prominence, in the signal's units.
    min_width_s : float, optional
        Least peak width at half prominence [s].
    cutoff_hz : float, optional
        Low-pass cut-off [Hz].
    height : optional
        Passed to find_peaks (signal units).
    rate_hz : float
        Grid rate [Hz].
    source : str
        Name used in error messages.

    Returns
    -------
    indices : ndarray of int, shape (k,)
        Nearest original samples of the peaks.
    properties : dict
        find_peaks' properties (in grid samples; ``prominences``,
        ``left_bases``, ``right_bases`` always, the width and height entries
        when asked) plus ``"time"`` (peak times on the grid [s], shape (k,))
        and ``"grid_index"`` (peak positions on the grid, shape (k,)).

    Examples
    --------
    >>> t = np.arange(0.0, 3.0, 0.013)
    >>> idx, props = detect_peaks(np.sin(2 * np.pi * t), t, min_period_s=0.5, min_prominence=0.5)
    >>> props["time"].round(2).tolist()
    [0.25, 1.25, 2.25]
    """
    p = _detect(np.asarray(signal, float), np.asarray(time, float), min_period_s=min_period_s,
                min_prominence=min_prominence, min_width_s=min_width_s, cutoff_hz=cutoff_hz,
                height=height, rate_hz=rate_hz, source=source)
    props = dict(p.properties)
    props["time"] = p.grid_time[p.grid_index]
    props["grid_index"] = p.grid_index
    return p.index, props


def _detect(x, t, *, min_period_s, min_prominence, min_width_s=None, cutoff_hz=None, height=None,
            rate_hz=GRID_HZ, source="<signal>") -> Peaks:
    if x.ndim != 1 or t.shape != x.shape:
        raise ParameterError(f"{source}: expected signal and time of the same shape (n,), got {x.shape}, {t.shape}")
    if x.shape[0] < 3 or not np.all(np.diff(t) > 0):
        raise ParameterError(f"{source}: expected at least 3 samples with strictly increasing time")
    if not min_period_s > 0:
        raise ParameterError(f"min_period_s={min_period_s}: expected a positive time [s]")
    grid, g = resample_uniform(t, x, rate_hz)
    if cutoff_hz is not None:
        g = lowpass(g, cutoff_hz, rate_hz)
    kw = dict(distance=max(1, int(round(min_period_s * rate_hz))), prominence=min_prominence)
    if min_width_s is not None:
        kw["width"] = min_width_s * rate_hz
    if height is not None:
        kw["height"] = height
    gi, props = _signal().find_peaks(g, **kw)
    idx = np.clip(np.searchsorted(t, grid[gi]), 0, t.shape[0] - 1)
    prev = np.clip(idx - 1, 0, None)
    idx = np.where(np.abs(t[prev] - grid[gi]) < np.abs(t[idx] - grid[gi]), prev, idx)
    return Peaks(grid_time=grid, grid_signal=g, grid_index=gi, index=idx, properties=props)


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


def integrate_heading(time, omega_z, psi0: float = 0.0):
    """Heading from the z angular rate on the real time steps [rad], shape (n,).

    The rule of the INS (:func:`morpi_filters.strapdown.integrate_rate`), so
    MoRPI and the planar INS read the same gyro the same way.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s].
    omega_z : array_like, shape (n,)
        Angular rate about the z axis [rad/s].
    psi0 : float
        Heading at ``time[0]`` [rad].

    Returns
    -------
    ndarray, shape (n,)
        Heading at each sample [rad].

    Examples
    --------
    >>> integrate_heading([0.0, 1.0, 2.0], [0.1, 0.1, 0.1]).round(12).tolist()
    [0.0, 0.1, 0.2]
    """
    from .strapdown import integrate_rate

    return integrate_rate(time, omega_z, psi0)


def motion_span(time, values, rest_end_time: float | None = None, *, threshold: float = 0.15,
                cutoff_hz: float = 1.0):
    """Start and end time of the motion from a periodic signal [s].

    The signal's deviation from its rest mean (before `rest_end_time`, else
    the first 2 s) is low-passed on the uniform grid; the motion spans the first
    to the last grid sample whose deviation exceeds `threshold` times the
    robust range of the deviation.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s].
    values : array_like, shape (n,)
        The periodic signal (m/s^2 or rad/s).
    rest_end_time : float, optional
        End of the initial rest [s]; default: ``time[0] + 2``.
    threshold : float
        Fraction of the 98th percentile of the filtered deviation that marks
        motion [-].
    cutoff_hz : float
        Low-pass cut-off applied to the deviation [Hz].

    Returns
    -------
    (start, end) : (float, float)
        First and last grid time of the motion [s]; ``(time[0], time[-1])``
        when nothing deviates.

    Examples
    --------
    >>> t = np.arange(0.0, 10.0, 0.01)
    >>> x = np.where((t > 3) & (t < 8), np.sin(2 * np.pi * t), 0.0)
    >>> a, b = motion_span(t, x)
    >>> bool(2.5 < a < 3.5 and 7.5 < b < 8.5)
    True
    """
    time = np.asarray(time, float)
    rest_end = time[0] + 2.0 if rest_end_time is None else rest_end_time
    grid, g = resample_uniform(time, values)
    base = g[grid <= rest_end].mean() if np.any(grid <= rest_end) else np.median(g)
    d = np.abs(lowpass(g - base, cutoff_hz))
    scale = np.percentile(d, 98)
    on = np.flatnonzero(d > threshold * scale) if scale > 0 else np.array([], int)
    if on.size == 0:
        return float(time[0]), float(time[-1])
    return float(grid[on[0]]), float(grid[on[-1]])


@dataclass(frozen=True, eq=False)
class PreparedSignal:
    """One recording's step signal on the uniform grid, reusable across configs.

    Attributes
    ----------
    source : str
        The recording's file.
    method : str
        ``"MoRPI-A"`` or ``"MoRPI-G"``.
    grid : ndarray, shape (m,)
        Uniform grid [s].
    raw : ndarray, shape (m,)
        Resampled signal (signal units).
    filtered : ndarray, shape (m,)
        Low-passed at `cutoff_hz` (equal to `raw` when None).
    cutoff_hz : float or None
    motion : tuple of float
        Motion start and end time [s] (:func:`motion_span`).
    time, heading : ndarray, shape (n,)
        Original time stamps [s] and integrated heading [rad].
    span : tuple of float
        2nd and 98th percentile of the filtered signal during the motion
        (the scale of the prominence threshold).
    grid_hz : float or None
        The grid rate asked for (:attr:`StepConfig.grid_hz`; None: the
        recording's median sample rate).
    rate_hz : float
        The rate of `grid` [Hz].
    steps_memo : dict
        Filled by :func:`extract_steps` and :func:`step_sums`: what every
        heading reading of the same steps shares (boundary headings, end
        steps, swing, the turn heading and the heading's integral at the
        step edges), read-only.
    """

    source: str
    method: str
    grid: np.ndarray
    raw: np.ndarray
    filtered: np.ndarray
    cutoff_hz: float | None
    motion: tuple
    time: np.ndarray
    heading: np.ndarray
    span: tuple = (0.0, 0.0)
    grid_hz: float | None = GRID_HZ
    rate_hz: float = GRID_HZ
    #: What every heading reading of the same steps shares (:func:`extract_steps`); not copied by ``replace``.
    steps_memo: dict = field(default_factory=dict, init=False, repr=False)

    @cached_property
    def motion_index(self) -> tuple:
        """Grid indices ``(i0, i1)`` of the motion: ``grid[i0:i1]`` lies within :attr:`motion`."""
        i0, i1 = np.searchsorted(self.grid, [self.motion[0], self.motion[1] + 1e-9])
        return int(i0), int(i1)

    @cached_property
    def heading_integral(self) -> np.ndarray:
        """Trapezoidal integral of the heading from the first sample [rad s], shape (n,), read-only."""
        out = _running_integral(self.time, self.heading)
        out.flags.writeable = False
        return out


def _running_integral(t, x) -> np.ndarray:
    """Trapezoidal integral of `x` from the first sample, shape (n,): a compiled loop."""
    out = np.empty(t.shape[0])
    kernel = _KERNELS or _kernels()
    kernel["running_integral"](np.require(t, float, ["C", "W"]), np.require(x, float, ["C", "W"]), out)
    return out


def _attitude_heading(rec, rest_end_time=None) -> np.ndarray:
    """The attitude heading of a whole recording, levelled with its initial rest (the first 2 s by default)."""
    from .strapdown import attitude_heading

    t = np.asarray(rec.time, float)
    end = t[0] + 2.0 if rest_end_time is None else rest_end_time
    rest = t <= end
    if rest.sum() < 2:
        raise DataError(f"{rec.source}: no rest before {end:g} s to level the attitude heading")
    return attitude_heading(t, rec.f, rec.omega, np.asarray(rec.f)[rest].mean(axis=0))


def prepare_signal(rec, method: str, cutoff_hz: float | None, *, rest_end_time: float | None = None,
                   heading=None, motion=None, grid_hz: float | None = GRID_HZ) -> PreparedSignal:
    """Resample (and filter) a recording's MoRPI signal once for many step configs.

    Parameters
    ----------
    rec : Recording
        The recording (``time``, ``f``, ``omega``, ``source``).
    method : str
        ``"MoRPI-A"`` (f_y) or ``"MoRPI-G"`` (omega_z).
    cutoff_hz : float or None
        Low-pass cut-off [Hz]; None: no filtering.
    rest_end_time : float, optional
        End of the initial rest [s], passed to :func:`motion_span`.
    heading : array_like, shape (n,), optional
        Heading on the recording's samples [rad]; default: integrated omega_z.
    motion : (float, float), optional
        Motion start and end time [s]; default: :func:`motion_span` of the
        signal.
    grid_hz : float or None
        Rate of the uniform grid [Hz] (:attr:`StepConfig.grid_hz`); None:
        the recording's median sample rate.

    Returns
    -------
    PreparedSignal
        Grid, raw and filtered signal, motion span, heading and the 2nd/98th
        percentile span of the filtered signal during the motion.

    Raises
    ------
    DataError
        With ``grid_hz=None``, when `cutoff_hz` is not below half the
        recording's median sample rate.
    ParameterError
        When `cutoff_hz` is not below half of a given `grid_hz`.

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, period=1.0, amplitude=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> p = prepare_signal(rec, "MoRPI-G", 1.0)
    >>> p.grid.shape == p.raw.shape == p.filtered.shape, p.heading.shape == rec.time.shape
    (True, True)
    """
    if method not in METHODS:
        raise ParameterError(f"method={method!r}: expected one of {tuple(METHODS)}")
    attr, col = METHODS[method]
    x = getattr(rec, attr)[:, col]
    t = rec.time
    rate = _grid_rate(rec, cutoff_hz, grid_hz)
    grid, graw = resample_uniform(t, x, rate)
    g = lowpass(graw, cutoff_hz, rate) if cutoff_hz is not None else graw
    if motion is None:
        motion = motion_span(t, x, rest_end_time)
    psi = integrate_heading(t, rec.omega[:, 2]) if heading is None else np.asarray(heading, float)
    i0, i1 = np.searchsorted(grid, [motion[0], motion[1] + 1e-9])
    span = _percentiles(g[i0:i1], (2.0, 98.0)) if i1 - i0 >= 3 else (0.0, 0.0)
    out = PreparedSignal(source=rec.source, method=method, grid=grid, raw=graw, filtered=g,
                         cutoff_hz=cutoff_hz, motion=(float(motion[0]), float(motion[1])), time=t, heading=psi,
                         span=span, grid_hz=grid_hz, rate_hz=rate)
    out.__dict__["motion_index"] = (int(i0), int(i1))           # the cached property, found here already
    return out


def _grid_rate(rec, cutoff_hz, grid_hz) -> float:
    """The rate of the grid [Hz]: `grid_hz`, or the recording's median sample rate when None, above twice the
    cut-off."""
    if grid_hz is not None:
        if cutoff_hz is not None and not cutoff_hz < grid_hz / 2:
            raise ParameterError(f"StepConfig.cutoff_hz={cutoff_hz}: expected below half of grid_hz={grid_hz} Hz")
        return float(grid_hz)
    dt = np.diff(np.asarray(rec.time, float))
    rate = 1.0 / float(np.median(dt)) if dt.size else math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise DataError(f"{rec.source}: no median sample rate for StepConfig.grid_hz=None "
                        "(expected at least two samples with increasing time)")
    if cutoff_hz is not None and not cutoff_hz < rate / 2:
        raise DataError(f"{rec.source}: StepConfig.cutoff_hz={cutoff_hz} Hz with grid_hz=None: expected below half "
                        f"the recording's median sample rate ({rate:.6g} Hz)")
    return rate


def _percentiles(x, qs) -> tuple:
    """``np.percentile(x, qs)`` of a finite 1-D `x` (linear method) with numpy's arithmetic, so its bits: the
    order statistics from one partition, without the general function's set-up."""
    n = x.shape[0]
    at = []
    for q in qs:
        v = (n - 1) * (q / 100)
        i = min(int(math.floor(v)), n - 1)
        at.append((i, min(i + 1, n - 1), v - i))
    s = np.partition(x, sorted({k for i, j, _ in at for k in (i, j)}))
    out = []
    for i, j, gamma in at:
        a, b = s[i], s[j]
        d = b - a
        out.append(float(b - d * (1 - gamma)) if gamma >= 0.5 else float(a + d * gamma))
    return tuple(out)


def activity_span(time, omega, *, window_s: float = ACTIVITY_WINDOW_S, factor: float = 10.0, floor: float = 0.02,
                  rest_s: float = 2.0, min_pause_s: float = 1.5, rest=None, threshold: float | None = None):
    """Start and end time of the main motion from the gyro's vibration [s].

    The moving standard deviation (over `window_s`, on the uniform grid) of the
    angular rate, summed over the axes, is compared with `factor` times its
    median at rest (and at least `floor` rad/s). Active stretches separated by
    pauses shorter than `min_pause_s` are merged and the longest one is the
    motion (handling of the phone after the robot stopped is left out). The
    whole recording when nothing is active.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s].
    omega : array_like, shape (n, 3)
        Angular rate [rad/s].
    window_s : float
        Length of the moving window [s].
    factor : float
        Activity threshold as a multiple of the rest level [-].
    floor : float
        Least activity threshold [rad/s].
    rest_s : float
        Length of the initial stretch taken as rest when `rest` is None [s].
    min_pause_s : float
        Longest pause that still joins two active stretches [s].
    rest : (float, float), optional
        The recording's initial rest window (start, end) [s], as
        :func:`morpi_filters.calibration.detect_rest` finds it. The rest level
        of the moving standard deviation is then its median over the windows
        inside the rest (every window ending by the rest's end when the rest
        is shorter than `window_s`), and only windows ending after the rest's
        end can open the motion, so the motion starts after the rest ends.
        Without it the rest level is taken over the first `rest_s` seconds.
    threshold : float, optional
        The activity threshold itself [rad/s] (at least `floor`), for a
        recording that has no rest to take the level in (it moves from its
        first sample; `rest` and `factor` are then not used): a motion whose
        first window is already active starts at the first sample.

    Returns
    -------
    (start, end) : (float, float)
        Start and end time of the longest active stretch [s];
        ``(time[0], time[-1])`` when nothing is active.

    Examples
    --------
    >>> t = np.arange(0.0, 10.0, 0.01)
    >>> w = np.zeros((t.size, 3)); w[(t > 4) & (t < 7), 2] = np.sin(40 * t[(t > 4) & (t < 7)])
    >>> a, b = activity_span(t, w, rest=(0.0, 3.0))
    >>> bool(4.0 < a < 4.6 and 6.4 < b < 7.0)
    True
    """
    if threshold is not None and not threshold >= 0:
        raise ParameterError(f"threshold={threshold!r}: expected a non-negative spread [rad/s]")
    time = np.asarray(time, float)
    grid, w = resample_uniform(time, omega)
    k = max(2, int(round(window_s * GRID_HZ)))
    if grid.shape[0] <= k:
        return float(time[0]), float(time[-1])
    sd = window_spread(w, k)[0]
    first = 0
    if threshold is not None:
        base = None
    elif rest is None:
        n_rest = max(1, int(rest_s * GRID_HZ) - k)
        base = sd[:n_rest]
    else:
        r0, r1 = float(rest[0]), float(rest[1])
        if not r1 >= r0:
            raise ParameterError(f"rest={rest!r}: expected a window (start, end) with end >= start [s]")
        # window j covers the grid samples [j, j + k): the windows inside the rest; for a rest shorter
        # than a window, every window ending by the rest's end (the median passes over a brief tap)
        j0 = min(int(np.searchsorted(grid, r0)), sd.shape[0] - 1)
        j1 = int(np.searchsorted(grid, r1, side="right")) - k
        base = sd[j0:j1 + 1] if j1 >= j0 else (sd[:j1 + 1] if j1 >= 0 else sd[:1])
        first = int(np.searchsorted(grid, r1, side="right"))
    thr = max(factor * float(np.median(base)), floor) if base is not None else max(float(threshold), floor)
    on = np.flatnonzero(sd > thr)
    on = on[on + k - 1 >= first]    # an active window marks the motion from its last sample on
    if on.size == 0:
        return float(time[0]), float(time[-1])
    # window j covers grid samples [j, j + k): the first active window ends at the onset and the
    # last one starts at the end of the motion; split where the gap exceeds the pause
    breaks = np.flatnonzero(np.diff(on) > k + min_pause_s * GRID_HZ)
    starts = np.r_[on[0], on[breaks + 1]] + k - 1
    ends = np.r_[on[breaks], on[-1]]
    j = int(np.argmax(ends - starts))
    if base is None and on[0] == 0 and j == 0:
        # without a rest the first window active is the motion under way: it starts with the recording
        return float(time[0]), float(grid[max(ends[j], starts[j])])
    return float(grid[min(starts[j], grid.shape[0] - 1)]), float(grid[max(ends[j], starts[j])])


def window_spread(w, k: int) -> tuple:
    """The standard deviation of each column of `w` (m, c) over every window of `k` samples, summed over the
    columns, shape (m - k + 1,), and the windows' means, shape (m - k + 1, c): from running sums (a compiled
    loop, numpy's bits)."""
    w = np.require(w, float, ["C"])
    sd, mean = np.empty(w.shape[0] - k + 1), np.empty((w.shape[0] - k + 1, w.shape[1]))
    (_KERNELS or _kernels())["window_spread"](w, k, sd, mean)
    return sd, mean


def extract_steps(rec, method: str, config: StepConfig | None = None, *, rest_end_time: float | None = None,
                  heading=None, prepared: PreparedSignal | None = None, peak_cache: dict | None = None) -> Steps:
    """Find the steps of one run.

    Parameters
    ----------
    rec : Recording or None
        (Calibrated or raw) recording; may be None when `prepared` is given.
    method : str
        ``"MoRPI-A"`` (f_y) or ``"MoRPI-G"`` (omega_z).
    config : StepConfig, optional
        Default: ``DEFAULT_CONFIGS[method]``.
    rest_end_time : float, optional
        End of the initial rest [s] (baseline for the motion span).
    heading : ndarray, shape (n,), optional
        Heading on the recording's samples [rad]; default: as
        ``config.heading_source`` says, from the first sample: the integrated
        omega_z, or the yaw of the 3D attitude
        (:func:`morpi_filters.strapdown.attitude_heading`) started level with
        the mean specific force before `rest_end_time` (the first 2 s without
        it).
    prepared : PreparedSignal, optional
        Output of :func:`prepare_signal` with ``config.cutoff_hz`` and
        ``config.grid_hz`` (saves the
        resampling and filtering when many configs are tried).
    peak_cache : dict, optional
        Reuses the peaks found for the same recording, method, cut-off,
        grid, peak thresholds and segment rule, and the steps' Weinberg
        weights read from the same signal (``amplitude_from``). Without
        ``min_height`` the peaks do not depend on a constant offset of the
        signal (the prominence is relative to its range, the width measured
        from the prominence), so one entry serves the raw and the
        gyro-calibrated signal; with it the peaks are kept on the prepared
        signal only.

    Returns
    -------
    Steps
        Step boundaries, Weinberg weights, end-step fractions and headings,
        each of shape (k,), with the peaks, the motion span and the median
        heading swing.

    Raises
    ------
    DataError
        Naming the recording when fewer than two peaks are found (no periodic
        motion).

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, period=1.0, amplitude=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> s = extract_steps(rec, "MoRPI-G")
    >>> s.start_time.shape == s.end_time.shape == s.weight.shape == s.heading.shape, bool(s.n > 2)
    (True, True)
    """
    if config is None:
        if method not in DEFAULT_CONFIGS:
            raise ParameterError(f"method={method!r}: expected one of {tuple(DEFAULT_CONFIGS)}")
        config = DEFAULT_CONFIGS[method]
    if prepared is None:
        if heading is None and config.heading_source == "attitude":
            heading = _attitude_heading(rec, rest_end_time)
        prepared = prepare_signal(rec, method, config.cutoff_hz, rest_end_time=rest_end_time, heading=heading,
                                  grid_hz=config.grid_hz)
    else:
        _check_prepared(prepared, method, config)
    (st, et, weight, frac, _, _, med, peaks), dpsi = _find_steps(prepared, method, config, peak_cache)
    return Steps(start_time=st, end_time=et, weight=weight, fraction=frac, heading=dpsi, peaks=peaks,
                 motion=prepared.motion, swing_deg=med)


class StepSums(NamedTuple):
    """What a gain and an end point need of a run's steps (:func:`step_sums`)."""

    #: ``sum(weight * fraction)`` (:attr:`Steps.effective_weight`): the distance per unit gain.
    w: float
    #: The end point's x per unit gain, ``sum(weight * fraction * cos(heading))``.
    ux: float
    #: The end point's y per unit gain, ``sum(weight * fraction * sin(heading))``.
    uy: float
    #: Median heading swing per period [deg] (:attr:`Steps.swing_deg`).
    swing_deg: float
    #: Number of steps (:attr:`Steps.n`).
    n: int


def step_sums(prepared: PreparedSignal, method: str, config: StepConfig, *, peak_cache: dict | None = None
              ) -> StepSums:
    """What a gain and an end point need of a run's steps, without building them.

    MoRPI's end point is linear in the gain: a run dead-reckoned with gain
    ``G`` travels ``G * w`` and ends at ``G * (ux, uy)``. The train-only rule
    searches score thousands of rules on these sums alone.

    Parameters
    ----------
    prepared : PreparedSignal
        Output of :func:`prepare_signal` with ``config.cutoff_hz`` and ``config.grid_hz``.
    method : str
        ``"MoRPI-A"`` or ``"MoRPI-G"``.
    config : StepConfig
        The step rule.
    peak_cache : dict, optional
        As for :func:`extract_steps` (the two share it, and the prepared
        signal's memo).

    Returns
    -------
    StepSums
        ``w = sum(weight * fraction)`` (:attr:`Steps.effective_weight`), the
        end point per unit gain ``(ux, uy) = sum(weight * fraction * [cos,
        sin](heading))``, the median heading swing per period ``swing_deg``
        [deg] and the number of steps ``n``: what the :class:`Steps` of
        :func:`extract_steps` give, the sums to rounding (a compiled loop
        adds the steps' own terms in step order).

    Raises
    ------
    DataError
        As :func:`extract_steps`.

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, period=1.0, amplitude=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> cfg = DEFAULT_CONFIGS["MoRPI-G"]
    >>> w, ux, uy, _, n = step_sums(prepare_signal(rec, "MoRPI-G", cfg.cutoff_hz), "MoRPI-G", cfg)
    >>> end = morpi_track(extract_steps(rec, "MoRPI-G", cfg), gain=1.0).end_point
    >>> bool(np.allclose([ux, uy], end, rtol=1e-12, atol=1e-12))
    True
    """
    _check_prepared(prepared, method, config)
    pkey, _, bt, psi_b, psi_m, per, _, weight, med, wmed = _boundaries(prepared, method, config, peak_cache)
    require_swing(prepared.source, method, med, config.min_swing_deg)
    heading = _HEADING_CODES[config.heading]
    edge = _edge_values(prepared, config, pkey, bt, psi_b) if heading >= 2 else _NO_EDGES
    m0, m1 = prepared.motion
    w, ux, uy, n = (_KERNELS or _kernels())["reading_sums"](
        bt, psi_b, weight, edge, m0, m1, psi_m[0], psi_m[1], per, wmed, _ENDS_CODES[config.ends], heading)
    return StepSums(w, ux, uy, med, n)


_KERNELS = None


def _kernels() -> dict:
    """The compiled loops of ``_signal_kernel`` (numba is imported on the first call)."""
    global _KERNELS
    from ._signal_kernel import compiled

    _KERNELS = compiled()
    return _KERNELS


#: The codes of the readings in ``_signal_kernel.reading_sums``.
_HEADING_CODES = {"absolute": 0, "change": 1, "turns": 2, "mean": 3}
_ENDS_CODES = {"drop": 0, "fraction": 1, "whole": 2}
_NO_EDGES = np.zeros(0)


def _check_prepared(prepared, method, config):
    if prepared.cutoff_hz != config.cutoff_hz or prepared.method != method or prepared.grid_hz != config.grid_hz:
        raise ParameterError(f"{prepared.source}: prepared signal ({prepared.method}, cutoff {prepared.cutoff_hz}, "
                             f"grid_hz {prepared.grid_hz}) does not match ({method}, cutoff {config.cutoff_hz}, "
                             f"grid_hz {config.grid_hz})")


def _boundaries(p, method, config, peak_cache):
    """What every reading of a run's peaks shares, memoized on the prepared signal (its heading) and in
    `peak_cache`: ``(pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed)``, the peak set's key
    and with the weights' source, the boundary times and headings, the headings at the motion's ends, the
    median step duration, the boundaries' grid indices, the whole steps' Weinberg weights, the median
    heading swing [deg] and the median weight."""
    memo = p.steps_memo
    rule = (config.prominence, config.min_period_s, config.min_height, config.min_width_s, config.segment,
            config.amplitude_from)
    out = memo.get(rule)                                        # the rule's peaks on this signal, found before
    if out is not None:
        return out
    grid, g, graw, t = p.grid, p.filtered, p.raw, p.time
    m0, m1 = p.motion
    i0, i1 = p.motion_index
    if i1 - i0 < 3:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal")
    lo, hi = p.span
    if not hi - lo > 0:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal (flat signal)")
    prom = config.prominence * (hi - lo)
    # the peaks, the boundaries and the weights do not depend on the heading: kept in `peak_cache` (shared by
    # the prepared signals of the same recording, method and cut-off, which may differ by a constant offset:
    # an absolute height threshold keeps its peaks on the prepared signal); the headings on the prepared signal
    shared = peak_cache if config.min_height is None else None
    cache = p.steps_memo if shared is None else shared
    pkey = (p.source, method, config.cutoff_hz, config.prominence, config.min_period_s, config.min_height,
            config.min_width_s, p.rate_hz, config.segment)
    found = cache.get(pkey)
    if found is None:
        dist = max(1, int(round(config.min_period_s * p.rate_hz)))
        width = None if config.min_width_s is None else config.min_width_s * p.rate_hz
        seg = g[i0:i1]
        ckey = (p.source, method, config.cutoff_hz, config.min_period_s, config.min_height, p.rate_hz)
        imax = _prominent(seg, dist, prom, cache, ckey + ("max",), height=config.min_height, width=width) + i0
        if config.segment == "extrema":
            imin = _prominent(-seg, dist, prom, cache, ckey + ("min",), height=config.min_height, width=width) + i0
            bounds = np.sort(np.concatenate([imax, imin]))
        else:
            bounds = imax
        bt = grid[bounds]
        bt.flags.writeable = False                              # shared by the Steps of every reading
        found = cache[pkey] = (imax, bounds, bt, _median(bt[1:] - bt[:-1]) if bt.size >= 2 else float("nan"))
    imax, bounds, bt, per = found
    if bounds.size < 2:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal "
                        f"({bounds.size} peak(s) between {m0 - t[0]:.1f} s and {m1 - t[0]:.1f} s)")
    wkey = pkey + (config.amplitude_from,)
    found = cache.get(wkey)
    if found is None:
        amp = g if config.amplitude_from == "filtered" else graw
        # max and min over each closed interval [bounds[j], bounds[j+1]] of the grid
        vmax = np.maximum(np.maximum.reduceat(amp, bounds[:-1])[:bounds.size - 1], amp[bounds[1:]])
        vmin = np.minimum(np.minimum.reduceat(amp, bounds[:-1])[:bounds.size - 1], amp[bounds[1:]])
        weight = weinberg_length(vmax, vmin, 1.0)
        weight.flags.writeable = False                          # shared by every Steps of this key
        found = cache[wkey] = (weight, _median(weight))
    weight, wmed = found
    # the headings: at the motion's ends, at the boundaries, and the swing between the maxima
    psi = p.heading
    kernel = _KERNELS or _kernels()
    psi_m = memo.get("motion heading")
    if psi_m is None:
        psi_m = memo["motion heading"] = np.interp([m0, m1], t, psi)
    bkey = ("boundary heading", pkey)
    psi_b = memo.get(bkey)
    if psi_b is None:
        psi_b = memo[bkey] = np.interp(bt, t, psi)
        psi_b.flags.writeable = False                           # shared by the Steps of every reading
    skey = ("swing",) + pkey[3:8]                               # the maxima: their thresholds, the grid
    med = memo.get(skey)
    if med is None:
        med = memo[skey] = float(kernel["swing_median"](t, psi, grid[imax]))
    out = memo[rule] = (pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed)
    return out


def _edge_values(p, config, pkey, bt, psi_b) -> np.ndarray:
    """What the heading readings "turns" and "mean" read at ``[m0, bt..., m1]`` (the motion's ends and the
    boundaries, where every step starts and ends): the turn heading, or the heading's running integral.
    Memoized on the prepared signal; read-only."""
    memo = p.steps_memo
    if config.heading == "turns":
        key = ("turn values", pkey, config.turn_deg)            # the stretches do not depend on the ends
    else:
        key = ("integral values", pkey)
    out = memo.get(key)
    if out is None:
        x = np.empty(bt.shape[0] + 2)
        x[0], x[1:-1], x[-1] = p.motion[0], bt, p.motion[1]
        if config.heading == "turns":
            # turn_heading(x, t, psi, turn_stretches(bt, psi_b, ...), integral=...) in one compiled call
            out = np.empty(x.shape[0])
            (_KERNELS or _kernels())["turn_values"](bt, psi_b, np.radians(config.turn_deg),
                                                    2 if config.segment == "extrema" else 1,
                                                    x, p.time, p.heading, p.heading_integral, out)
        else:
            out = np.interp(x, p.time, p.heading_integral)
        out.flags.writeable = False
        memo[key] = out
    return out


def _find_steps(p, method, config, peak_cache):
    """The steps of :func:`extract_steps`: the parts every heading reading shares and the heading."""
    pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed = _boundaries(p, method, config, peak_cache)
    m0, m1 = p.motion
    memo = p.steps_memo
    peaks = memo.get(("peaks", pkey))
    if peaks is None:
        idx = np.minimum(np.searchsorted(p.time, bt), p.time.shape[0] - 1)
        idx.flags.writeable = False
        lo, hi = p.span
        peaks = memo[("peaks", pkey)] = Peaks(grid_time=p.grid, grid_signal=p.filtered, grid_index=bounds, index=idx,
                                              properties={"prominence_threshold": config.prominence * (hi - lo)})
    mkey = wkey + (config.ends,)
    if mkey in memo:
        st, et, weight, frac, psi_s, psi_e, med, peaks = memo[mkey]
    else:
        if config.ends == "drop":
            st, et, psi_s, psi_e = bt[:-1], bt[1:], psi_b[:-1], psi_b[1:]
            frac = np.ones_like(weight)
        else:
            parts = []
            for f in ((bt[0] - m0) / per, (m1 - bt[-1]) / per):
                f = min(max(f, 0.0), 1.0)
                if config.ends == "whole":
                    f = 1.0 if f >= 0.5 else 0.0
                parts.append(f)
            st = np.concatenate([[m0], bt])
            et = np.concatenate([bt, [m1]])
            psi_s = np.concatenate([psi_m[:1], psi_b])
            psi_e = np.concatenate([psi_b, psi_m[1:]])
            weight = np.concatenate([[wmed], weight, [wmed]])
            frac = np.concatenate([[parts[0]], np.ones(bt.shape[0] - 1), [parts[1]]])
        for a in (st, et, weight, frac, psi_s, psi_e):
            a.flags.writeable = False                           # shared by the Steps of every reading
        memo[mkey] = (st, et, weight, frac, psi_s, psi_e, med, peaks)
    require_swing(p.source, method, med, config.min_swing_deg)
    if config.heading == "absolute":
        return memo[mkey], psi_e
    if config.heading == "change":
        return memo[mkey], psi_e - psi_s
    # the turn heading or the heading's integral at the steps' edges: the steps tile the motion (each
    # starts where the one before ends), so the edges are [m0, bt..., m1], or bt when the ends are dropped
    edge = _edge_values(p, config, pkey, bt, psi_b)
    edge = edge[1:-1] if config.ends == "drop" else edge
    if config.heading == "turns":
        return memo[mkey], psi_e - psi_s + edge[:-1]
    # the mean heading over each step; the heading at its start for a step of no length
    span = et - st
    return memo[mkey], np.divide(edge[1:] - edge[:-1], span, out=np.array(psi_s), where=span > 1e-9)


def _prominent(x, distance, prominence, cache, key, *, height=None, width=None):
    """``scipy.signal.find_peaks(x, height=height, distance=distance, prominence=prominence, width=width)[0]``,
    with the peaks kept by the height and the distance, their prominences and, once asked, their widths cached
    under `key`: find_peaks applies the height and the distance before it measures the prominences, and
    measures each peak's width from its own prominence, so every prominence and width threshold selects from
    the same candidates."""
    found = cache.get(key)
    if found is None:
        peaks, props = _signal().find_peaks(x, height=height, distance=distance, prominence=0.0)
        found = cache[key] = {"peaks": peaks, "prominences": props["prominences"],
                              "bases": (props["left_bases"], props["right_bases"])}
    keep = found["prominences"] >= prominence
    if width is not None:
        widths = found.get("widths")
        if widths is None:
            widths = found["widths"] = _signal().peak_widths(
                x, found["peaks"], rel_height=0.5, prominence_data=(found["prominences"], *found["bases"]))[0]
        keep &= widths >= width
    return found["peaks"][keep]


def require_swing(source, method: str, swing_deg: float, min_swing_deg: float) -> None:
    """Refuse a run whose median heading swing per period is below `min_swing_deg` (not a sine path).

    Parameters
    ----------
    source : str
        The recording, named in the message.
    method : str
        The MoRPI method whose signal the periods were found on.
    swing_deg : float
        The run's median heading swing per period [deg] (:attr:`Steps.swing_deg`;
        NaN when fewer than two periods: nothing to check).
    min_swing_deg : float
        The least swing of a periodic run [deg] (:attr:`StepConfig.min_swing_deg`).

    Returns
    -------
    None

    Raises
    ------
    DataError
        Naming the recording, its swing and the least swing expected.

    Examples
    --------
    >>> require_swing("run.csv", "MoRPI-G", 40.0, 15.0)          # a sine path: nothing happens
    >>> require_swing("run.csv", "MoRPI-G", 6.0, 15.0)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: run.csv: no periodic motion found in the MoRPI-G signal (median heading swing 6.0 deg per period, expected at least 15 deg for a sine path)
    """
    if swing_deg < min_swing_deg:
        raise DataError(f"{source}: no periodic motion found in the {method} signal (median heading "
                        f"swing {swing_deg:.1f} deg per period, expected at least "
                        f"{min_swing_deg:g} deg for a sine path)")


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
        cpsi = _running_integral(t, psi)
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
    >>> traj = simulate.sine(6.3, period=1.0, amplitude=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
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
    >>> traj = simulate.sine(6.3, period=1.0, amplitude=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> track = morpi_track(extract_steps(rec, "MoRPI-G", DEFAULT_CONFIGS["MoRPI-G"]), gain=1.0)
    >>> track.position.shape[1], track.length.shape == track.steps.weight.shape
    (2, True)
    """
    length = gain * steps.weight * steps.fraction
    return MorpiTrack(steps=steps, gain=float(gain), length=length, position=dead_reckon(length, steps.heading))
