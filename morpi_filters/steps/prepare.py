"""A run's step signal: resampled on a uniform grid, low-passed, its peaks, heading and motion span."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

import numpy as np

from . import _loops
from ..errors import DataError, ParameterError
from .rules import ACTIVITY_WINDOW_S, GRID_HZ, METHODS, Peaks



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
    from scipy import signal as sig
    sos = sig.butter(order, cutoff_hz, btype="low", fs=rate_hz, output="sos")
    zi = sig.sosfilt_zi(sos)
    ntaps = 2 * sos.shape[0] + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    for a in (sos, zi):
        a.flags.writeable = False
    return sos, zi, 3 * ntaps


def small_median(x) -> float:
    """Median of a small 1-D array (np.median's overhead dominates at this size).

    Parameters
    ----------
    x : array_like, shape (n,)
        The values, n >= 1.

    Returns
    -------
    float
        The middle value, or the mean of the two middle values.
    """
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
    filt = _loops.compiled()["filtfilt"]
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
    from scipy import signal as scipy_signal

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
    gi, props = scipy_signal.find_peaks(g, **kw)
    idx = np.clip(np.searchsorted(t, grid[gi]), 0, t.shape[0] - 1)
    prev = np.clip(idx - 1, 0, None)
    idx = np.where(np.abs(t[prev] - grid[gi]) < np.abs(t[idx] - grid[gi]), prev, idx)
    return Peaks(grid_time=grid, grid_signal=g, grid_index=gi, index=idx, properties=props)


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
    from ..strapdown import integrate_rate

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
        out = running_integral(self.time, self.heading)
        out.flags.writeable = False
        return out


def running_integral(t, x) -> np.ndarray:
    """Trapezoidal integral of `x` from the first sample: a compiled loop.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times [s].
    x : ndarray, shape (n,)
        The values.

    Returns
    -------
    ndarray, shape (n,)
        The integral at every sample, 0 at the first.
    """
    out = np.empty(t.shape[0])
    kernel = _loops.compiled()
    kernel["running_integral"](np.require(t, float, ["C", "W"]), np.require(x, float, ["C", "W"]), out)
    return out


def recording_heading(rec, rest_end_time=None) -> np.ndarray:
    """The attitude heading of a whole recording, levelled with its initial rest (the first 2 s by default).

    Parameters
    ----------
    rec : Recording
        The recording.
    rest_end_time : float, optional
        End of its initial rest [s]; default: 2 s after its first sample.

    Returns
    -------
    ndarray, shape (n,)
        :func:`morpi_filters.strapdown.attitude_heading` at every sample [rad].
    """
    from ..strapdown import attitude_heading

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
    >>> traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1)
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
    """``np.percentile(x, qs)`` of a finite 1-D `x` (linear method) with numpy's arithmetic: the
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
    """The spread and the mean of every window of `k` consecutive rows, from running sums (a compiled loop).

    Parameters
    ----------
    w : ndarray, shape (m, c)
        The samples, one column per channel.
    k : int
        Window length [samples], 1 <= k <= m.

    Returns
    -------
    sd : ndarray, shape (m - k + 1,)
        Each window's standard deviation per column, summed over the columns.
    mean : ndarray, shape (m - k + 1, c)
        Each window's mean per column.
    """
    w = np.require(w, float, ["C"])
    sd, mean = np.empty(w.shape[0] - k + 1), np.empty((w.shape[0] - k + 1, w.shape[1]))
    _loops.compiled()["window_spread"](w, k, sd, mean)
    return sd, mean
