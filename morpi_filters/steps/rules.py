"""Step rules: the tunables and readings of the step pipeline (:class:`StepConfig`), the chosen rules, and
what a rule finds (peaks, steps, a MoRPI track)."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from functools import cached_property

import numpy as np

from ..errors import ParameterError



#: Default rate of the uniform grid peak detection works on [Hz] (:attr:`StepConfig.grid_hz`).
GRID_HZ = 100.0
#: Window of :func:`activity_span` [s]: the motion onset is the last sample of the first active window.
ACTIVITY_WINDOW_S = 0.5
#: The readings of :attr:`StepConfig.heading`: what a step's heading change is.
HEADINGS = ("absolute", "mean", "change", "turns")
#: The readings of :attr:`StepConfig.segment`: where a step starts and ends.
SEGMENTS = ("maxima", "extrema")
#: The readings of :attr:`StepConfig.ends`: the partial steps before the first and after the last peak.
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
        from ..dataset import route as route_of

        r = route_of(route) if isinstance(route, str) else route
        return float(np.linalg.norm(self.end_point - np.asarray(r.end_point_m, float)))


# --------------------------------------------------------------------------- signals

#: The step rule of each method that :func:`morpi_filters.field.select_config`
#: picks on the field train runs (the defaults of :func:`extract_steps`).
DEFAULT_CONFIGS = {
    "MoRPI-A": StepConfig(ends="whole", prominence=0.2),
    "MoRPI-G": StepConfig(heading="turns", cutoff_hz=1.0),
}
