"""A recording ready for the aided filter: its rest terms and still stretches, its steps along the route's
heading, its :class:`Prepared` input per calibration, method and gain."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import aided
from ..deprecation import renamed_keywords
from ..errors import MorpiError


#: A stretch is still when the moving standard deviation of the gyro (summed over the axes, over
#: STILL_WINDOW_S) is at most STILL_FACTOR times its median over the initial rest window, and the
#: moving mean stays as close to the rest's as STILL_FACTOR times the rest's own 95th percentile. For white
#: noise the standard deviation of 25-50 samples exceeds twice its expected value with negligible
#: probability; the phones' coarse gyro quantization is covered by taking the rest's own median.
STILL_WINDOW_S, STILL_FACTOR, STILL_MIN_S = 0.5, 2.0, 0.5


def still_spans(time, omega, motion, rest_slice) -> tuple:
    """Stretches outside the motion where the gyro is as quiet as at rest [s].

    The gyro is resampled on the uniform step grid; a window of
    :data:`STILL_WINDOW_S` is still when its summed standard deviation and
    the distance of its mean from the rest's stay within :data:`STILL_FACTOR`
    of what the initial rest window shows.

    Parameters
    ----------
    time : ndarray, shape (n,)
        Sample times [s].
    omega : ndarray, shape (n, 3)
        Angular rate [rad/s].
    motion : (float, float)
        Start and end of the robot's motion [s].
    rest_slice : (int, int)
        Sample range of the initial rest window (the reference quietness).

    Returns
    -------
    tuple of (start_s, end_s)
        Still stretches of at least :data:`STILL_MIN_S`, before the motion's start or after its end
        [s], in time order; empty when the recording is shorter than one window.

    Examples
    --------
    Ten seconds of gyro noise with a 0.5 rad/s yaw swing from 3 s to 6 s:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(1000) * 0.01
    >>> omega = rng.normal(0.0, 0.002, (1000, 3))
    >>> moving = (t >= 3.0) & (t <= 6.0)
    >>> omega[moving, 2] += 0.5 * np.sin(2 * np.pi * (t[moving] - 3.0))
    >>> still_spans(t, omega, (3.0, 6.0), (0, 300))
    ((0.0, 2.99), (6.01, 9.99))
    """
    from ..steps import GRID_HZ, resample_uniform
    from ..steps.prepare import window_spread

    grid, g = resample_uniform(time, omega)
    k = max(2, int(round(STILL_WINDOW_S * GRID_HZ)))
    if grid.size <= k:
        return ()
    sd, mean = window_spread(g, k)
    lo, hi = grid[: sd.size], grid[k - 1: k - 1 + sd.size]     # window j covers [lo[j], hi[j]]
    i0, i1 = rest_slice
    ref = (lo >= time[i0]) & (hi <= time[max(i1 - 1, i0)])
    base = float(np.median(sd[ref])) if ref.any() else float(np.median(sd[: max(1, sd.size // 10)]))
    # a slow turn (the robot settling) is quiet but not still: its mean rate leaves the rest's, by more
    # than the scatter of the window means over the rest window allows
    m0 = np.median(mean[ref], axis=0) if ref.any() else np.median(mean[: max(1, sd.size // 10)], axis=0)
    dev = np.linalg.norm(mean - m0, axis=1)
    dev_ref = float(np.percentile(dev[ref], 95)) if ref.sum() >= 5 else float(np.median(dev))
    quiet = ((sd <= STILL_FACTOR * base) & (dev <= STILL_FACTOR * dev_ref)
             & ((hi < motion[0]) | (lo > motion[1])))
    spans = []
    edges = np.flatnonzero(np.diff(np.r_[0, quiet.astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        t0, t1 = float(lo[a]), float(hi[b - 1])
        if t1 - t0 >= STILL_MIN_S:
            spans.append((t0, t1))
    return tuple(spans)


def gyro_drift(rec, window, rest) -> tuple:
    """How far the gyro's rest mean moved between the initial rest and the last still stretch.

    Parameters
    ----------
    rec : dataset.Recording
        The (calibrated) recording.
    window : calibration.RestWindow
        Its initial rest window (samples ``window.i0:window.i1``).
    rest : sequence of (float, float)
        Still stretches [s], the initial rest first (as :func:`prepare` builds them).

    Returns
    -------
    dm2 : ndarray, shape (3,) or None
        Squared change of the mean per axis [(rad/s)^2].
    dt : float or None
        Time between the two stretches' centres [s]; ``(None, None)`` with
        one still stretch only.

    Examples
    --------
    A gyro x offset of 0.01 rad/s appears after 7 s:

    >>> from morpi_filters.calibration import RestWindow
    >>> from morpi_filters.dataset import Recording
    >>> t = np.arange(1000) * 0.01
    >>> omega = np.zeros((1000, 3))
    >>> omega[t > 7.0, 0] = 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (1000, 1)), omega=omega, source="example")
    >>> win = RestWindow(0.0, 2.99, 0, 300, "full")
    >>> dm2, dt = gyro_drift(rec, win, ((0.0, 2.99), (7.5, 9.99)))
    >>> np.sqrt(dm2).round(12).tolist(), round(dt, 9)          # centres 1.495 s and 8.745 s
    ([0.01, 0.0, 0.0], 7.25)
    >>> gyro_drift(rec, win, ((0.0, 2.99),))
    (None, None)
    """
    if len(rest) < 2:
        return (None, None)
    t0, t1 = rest[-1]
    m = (rec.time >= t0) & (rec.time <= t1)
    first = rec.omega[window.i0:window.i1].mean(axis=0)
    dm = rec.omega[m].mean(axis=0) - first
    dt = 0.5 * (t0 + t1) - 0.5 * (rec.time[window.i0] + rec.time[window.i1 - 1])
    return (dm * dm, float(dt))


@renamed_keywords(epoch_s="dt_s")
def rest_noise(rec, window, dt_s: float = 0.1) -> tuple[float, float, float]:
    """Noise densities the initial rest window shows.

    Parameters
    ----------
    rec : dataset.Recording
        The raw recording.
    window : calibration.RestWindow
        Its initial rest window.
    dt_s : float
        Length of the epochs whose gyro means give `gyro_epoch` [s].

    Returns
    -------
    (accel, gyro, gyro_epoch)
        RMS over the axes of ``std * sqrt(dt)`` for the accelerometer
        [m/s^2/sqrt(Hz)] and the gyro [rad/s/sqrt(Hz)], and the gyro density
        that the scatter of its `dt_s` means implies (``std(mean) *
        sqrt(dt_s)``): the noise of a zero-rate update on one epoch, which
        the quantization and slow wander of a phone gyro put above the white
        part. `gyro_epoch` is at least `gyro`, and equals it when the window
        holds fewer than 4 epochs. ``dt`` is the median sample interval.

    Examples
    --------
    White noise of 0.05 m/s^2 and 0.002 rad/s at 100 Hz has densities
    ``0.05 * sqrt(0.01) = 0.005`` and ``0.0002``:

    >>> from morpi_filters.calibration import RestWindow
    >>> from morpi_filters.dataset import Recording
    >>> rng = np.random.default_rng(0)
    >>> f = rng.normal(0.0, 0.05, (1000, 3)) + [0.0, 0.0, 9.8]
    >>> rec = Recording(time=np.arange(1000) * 0.01, f=f, omega=rng.normal(0.0, 0.002, (1000, 3)), source="x")
    >>> a, g, ge = rest_noise(rec, RestWindow(0.0, 2.99, 0, 300, "full"))
    >>> round(a, 3), round(g, 4), ge >= g
    (0.005, 0.0002, True)
    """
    sl = slice(window.i0, window.i1)
    t = rec.time[sl]
    dt = float(np.median(np.diff(t))) if t.size > 2 else float(np.median(np.diff(rec.time)))
    a = float(np.sqrt(np.mean(np.var(rec.f[sl], axis=0))) * np.sqrt(dt))
    g = float(np.sqrt(np.mean(np.var(rec.omega[sl], axis=0))) * np.sqrt(dt))
    block = np.floor((t - t[0]) / dt_s).astype(int) if t.size else np.zeros(0, int)
    nb = int(block.max()) + 1 if block.size else 0
    if nb >= 4:
        cnt = np.bincount(block, minlength=nb)
        means = np.stack([np.bincount(block, rec.omega[sl][:, j], minlength=nb) for j in range(3)], axis=1)
        means = means[cnt > 0] / cnt[cnt > 0, None]
        ge = float(np.sqrt(np.mean(np.var(means, axis=0, ddof=1))) * np.sqrt(dt_s))
    else:
        ge = g
    return a, g, max(ge, g)


@dataclass(frozen=True, eq=False)
class Prepared:
    """A recording ready for the aided filter in one cell: input, MoRPI track, noise from rest.

    :attr:`input` carries MoRPI's own step vectors, :attr:`route_input` the
    same steps along the route's heading (:func:`route_vectors`);
    :attr:`onset_s` is the motion onset [s].
    """

    def input_for(self, info, forward_only: bool = False) -> aided.AidedInput:
        """The input whose step vectors a grid point's ``step_heading`` reads.

        With `forward_only`, cut just after :attr:`stop_s` (:meth:`aided.AidedInput.until`): the
        forward filter's read-out there is the same, the smoother needs the rest.
        """
        inp = self.route_input if info["step_heading"] == "route" else self.input
        if forward_only:
            key = (id(inp), "until")
            cut = self._cut.get(key)
            if cut is None:
                cut = self._cut[key] = inp.until(self.stop_s)
            return cut
        return inp

    def onset_input(self, info) -> aided.AidedInput:
        """The input of :meth:`input_for`, started at the motion onset (:attr:`onset_s`).

        The initial rest window and the standing stretch before the onset are
        left out (:meth:`aided.AidedInput.since`): a filter run on it holds
        the robot still before the motion by nothing but its start.
        """
        inp = self.input_for(info)
        key = (id(inp), "since")
        cut = self._cut.get(key)
        if cut is None:
            cut = self._cut[key] = inp.since(self.onset_s)
        return cut

    rel: str
    input: aided.AidedInput
    route_input: aided.AidedInput
    morpi_xy: np.ndarray
    noise: tuple
    stop_s: float
    gyro_drift: tuple
    motion_shift: np.ndarray
    onset_s: float = float("nan")
    _cut: dict = field(default_factory=dict, repr=False)

    def end(self, r: aided.AidedResult):
        """The filter's horizontal position and covariance (forward, and smoothed) at ``stop_s``.

        ``stop_s`` is the last step boundary, where MoRPI's own track ends: the
        trained gain makes MoRPI's step sum match the route, so the filter is
        read at the same instant (after it the robot creeps to a halt and the
        phone may be handled).

        Parameters
        ----------
        r : aided.AidedResult
            The filter's run on this recording's :attr:`input`.

        Returns
        -------
        xy : ndarray, shape (2,)
            Forward horizontal position [m].
        P_xy : ndarray, shape (2, 2)
            Its covariance [m^2].
        smoothed_xy : ndarray, shape (2,) or None
            Smoothed horizontal position [m] (None without smoothing).
        """
        j = r.index_at(self.stop_s)
        return r.position[j, :2], r.P_xy[j], (None if r.smoothed is None else r.smoothed[j, :2])


@renamed_keywords(mode="calibration")
def prepare(data, rec, calibration, method, config, gain) -> Prepared:
    """The aided filter's input for one recording, calibration, method and gain.

    Needs a :class:`~morpi_filters.field.FieldData` (the dataset's cached
    per-recording work), so there is no example. The result is cached in
    ``data.study_cache``.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached calibrations, rest windows, steps and motion windows.
    rec : dataset.Recording
        The raw recording.
    calibration : {"RD", "GC", "GAC"}
        Calibration.
    method : {"MoRPI-A", "MoRPI-G"}
        MoRPI method whose steps drive the step updates.
    config : steps.StepConfig
        The method's step rule.
    gain : float
        Trained Weinberg gain [m / unit^(1/4)].

    Returns
    -------
    Prepared
        The :class:`aided.AidedInput` (calibrated IMU from the initial rest
        window on: the robot's path starts where it stands, whatever the phone
        did before; coarse-level attitude, steps, rest stretches), MoRPI's track, the rest noise
        (:func:`rest_noise`), the read-out time (the last step boundary),
        the gyro drift (:func:`gyro_drift`), the specific force's mean shift
        between rest and motion [m/s^2] and the motion onset [s].

    Raises
    ------
    DataError
        When no steps are found.
    """
    from .. import steps as st
    from ..strapdown import coarse_level

    key = (rec.source, calibration, method, config, float(gain), "aided")
    cache = data.study_cache
    if key in cache:
        return cache[key]
    crec, _ = data.calibrated(rec, calibration)
    w = data.rest_window(rec)
    f_rest, rest, shift, drift, noise = rest_terms(data, rec, calibration)
    s = data.steps(rec, calibration, method, config)
    track = st.morpi_track(s, gain)
    # between the rest window and the motion onset (the start of the motion window, where MoRPI's steps
    # begin) the robot stands, its motors may run: zero velocity up to the onset, so the path starts from
    # where the robot stood
    onset = float(data.activity(rec)[0])
    standing = ((float(w.end_s), onset),) if onset > w.end_s else ()
    # the filter starts where the robot is known to stand, at the initial rest window: what comes before it
    # (the phone placed on the robot, handled) is no motion of the robot, and the coarse-level attitude is
    # that of the rest window
    i0 = int(w.i0)
    inp = aided.AidedInput(time=crec.time[i0:], f=crec.f[i0:], omega=crec.omega[i0:], C0=coarse_level(f_rest),
                           g=float(np.linalg.norm(f_rest)), step_start=s.start_time, step_end=s.end_time,
                           step_length=track.length, rest=rest, standing=standing,
                           step_vector=np.diff(track.position, axis=0))
    # read where MoRPI's track ends: the gain is trained on MoRPI's step sum, which covers the motion up
    # to the last step boundary (the robot's creep after it is part of what the gain absorbs)
    stop = float(s.end_time[-1]) if s.end_time.size else data.activity(rec)[1]
    along = route_steps(data, rec, calibration, config, s, track.length)
    cache[key] = Prepared(data.relpath(rec), inp, replace(inp, step_vector=along), track.position, noise, float(stop),
                          drift, shift, onset)
    return cache[key]


@renamed_keywords(mode="calibration")
def prepared_runs(data, phone, route, split, calibration, method, config, gain, failed=None):
    """The folder's recordings prepared for the filter (:func:`prepare`); those without steps go to `failed`.

    Parameters
    ----------
    data : field.FieldData
    phone, route, split : str
        The folder.
    calibration, method, config, gain
        As for :func:`prepare`.
    failed : list, optional
        Receives one line per recording that cannot be prepared.

    Returns
    -------
    list of Prepared
    """
    out = []
    for rec in data.recordings(phone, route, split):
        try:
            out.append(prepare(data, rec, calibration, method, config, gain))
        except MorpiError as exc:
            if failed is not None:
                failed.append(str(exc))
    return out


@renamed_keywords(mode="calibration")
def rest_terms(data, rec, calibration):
    """What :func:`prepare` reads from one recording and calibration whatever the steps: the mean specific
    force of the rest window, the rest stretches, the specific force's shift under way, the gyro drift and the
    rest noise (cached in ``data.study_cache``).

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    rec : Recording
        The recording.
    calibration : {"RD", "GC", "GAC"}
        Calibration.

    Returns
    -------
    tuple
        The terms above, in that order.
    """
    key = (rec.source, calibration, "aided rest")
    cache = data.study_cache
    if key in cache:
        return cache[key]
    crec, _ = data.calibrated(rec, calibration)
    w = data.rest_window(rec)
    f_rest = crec.f[w.i0:w.i1].mean(axis=0)
    # rest updates: before the motion the calibration's own rest window (the stretch up to the onset may
    # carry the motors' start), after it every stretch where the gyro is as quiet as at rest (the phone
    # is handled after some runs)
    after = still_spans(crec.time, crec.omega, data.activity(rec), (w.i0, w.i1))
    rest = ((float(w.start_s), float(w.end_s)),) + tuple(s for s in after if s[0] > w.end_s)
    a, b = data.activity(rec)
    moving = (crec.time >= a) & (crec.time <= b)
    # the specific force's mean shift under way (the run starts and ends at rest: no net acceleration)
    shift = crec.f[moving].mean(axis=0) - f_rest if moving.any() else np.zeros(3)
    cache[key] = f_rest, rest, shift, gyro_drift(crec, w, rest), rest_noise(rec, w)
    return cache[key]


def route_vectors(length, start, end, boundaries, time, psi, turn_deg, per_period):
    """Step displacements along the route's heading: the turns alone, at each step's middle.

    The heading of the ``"turns"`` reading without the step's own change
    (:func:`morpi_filters.steps.turn_heading` over the stretches of
    :func:`morpi_filters.steps.turn_stretches`): straight between turns, so a
    sine's zigzag and the gyro's drift between turns stay out of the step
    directions, whatever the method that found the steps.

    Parameters
    ----------
    length, start, end : ndarray, shape (k,)
        Step lengths [m] and boundaries [s].
    boundaries : ndarray
        The step boundaries of whole steps (the signal's peaks) [s].
    time, psi : ndarray, shape (n,)
        The heading on the recording's samples [s], [rad].
    turn_deg : float
        Least full-period heading change of a turn [deg].
    per_period : int
        Steps per full period (2 between extrema, 1 between maxima).

    Returns
    -------
    ndarray, shape (k, 2)
        Step displacements [m].

    Examples
    --------
    Steps of 0.5 m every second on a straight stretch, a 90 degree left turn from 4 s to 5 s:

    >>> t = np.arange(0.0, 10.01, 0.01)
    >>> psi = np.clip(t - 4.0, 0.0, 1.0) * np.pi / 2
    >>> b = np.arange(0.0, 11.0)
    >>> v = route_vectors(np.full(10, 0.5), b[:-1], b[1:], b, t, psi, 51.0, 1)
    >>> v[0].round(6).tolist(), v[-1].round(6).tolist()
    ([0.5, 0.0], [0.0, 0.5])
    """
    from .. import steps as st

    bt = np.asarray(boundaries, float)
    stretches = st.turn_stretches(bt, np.interp(bt, time, psi), np.radians(turn_deg), per_period)
    h = st.turn_heading(0.5 * (np.asarray(start, float) + np.asarray(end, float)), time, psi, stretches)
    return np.asarray(length, float)[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)


@renamed_keywords(mode="calibration")
def route_steps(data, rec, calibration, config, s, length) -> np.ndarray:
    """:func:`route_vectors` of a recording's steps `s` (found under `config`) with the step lengths `length`.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    rec : Recording
        The recording.
    calibration : {"RD", "GC", "GAC"}
        Calibration.
    config : steps.StepConfig
        The rule `s` was found under.
    s : steps.Steps
        The recording's steps.
    length : ndarray, shape (k,)
        The steps' lengths [m].

    Returns
    -------
    ndarray, shape (k, 2)
        The step vectors along the route's heading [m].
    """
    crec, _ = data.calibrated(rec, calibration)
    bt = s.peaks.grid_time[s.peaks.grid_index]
    return route_vectors(length, s.start_time, s.end_time, bt, crec.time,
                         data.heading(rec, calibration, config.heading_source), config.turn_deg,
                         2 if config.segment == "extrema" else 1)
