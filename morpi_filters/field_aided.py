"""The MoRPI-aided filter (:mod:`morpi_filters.aided`) on the field recordings.

Per MoRPI table cell of :func:`morpi_filters.evaluate.evaluate_tables` (its
steps, step rule and trained gain), the aided filter runs once over each test
recording, forward and smoothed, beside MoRPI alone and the INS alone.

Tunables are chosen per training set, method and calibration on the ``train``
runs only (:func:`choose_tunables`): the noise densities, the zero-rate noise
and the gyro bias walk come from what the train runs show at rest (the
densities while the robot stands); the grid
(:data:`GRID`) scales the densities for the vibration of the moving robot, sets
the step noise and where the step direction comes from (the filter's attitude,
or the route's heading: :func:`route_vectors`, whose turns carry a heading
error of :data:`TURN_SIGMA` of their angle, set a priori: the train routes take
no turn); at the chosen point the non-holonomic updates stay and the gain error is estimated
(rather than considered) only where the train runs show it pays. The gain
error's prior is the trained gain's spread. Nothing of a ``test`` folder
enters the choice.

The filter starts at the calibration's initial rest window (what precedes it,
the phone placed and handled, is no motion of the robot). The rest updates run
on that window and on every
still stretch after the motion (:func:`still_spans`), zero velocity alone
between that window and the motion onset; the filter is read where MoRPI's own
track ends (:meth:`Prepared.end`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import product

import numpy as np

from . import aided
from .errors import MorpiError

__all__ = ["GRID", "ABLATIONS", "AidedCell", "AidedStudy", "PairedDifference", "Prepared", "aided_study",
           "choose_tunables", "choose_tunables_many", "paired_difference", "prepare",
           "still_spans", "rest_noise", "gyro_drift", "gain_estimate_pays", "route_vectors"]

#: Train-only grid: factor on the rest-window noise densities (the moving robot vibrates far above
#: them), step displacement noise [m], whether the gain error is estimated or only considered (the
#: trained gain taken as exact, its spread kept in the covariance: :attr:`aided.AidTuning.gain_estimated`),
#: and the source of the step direction (the filter's attitude, or the route's heading: the turns
#: alone, :func:`route_vectors`), and whether the non-holonomic updates run. MoRPI's own heading reading
#: (its step vectors) is not a candidate: the route's heading took its place in every training set and
#: nested fold, with identical choices and scores without it, at a third less tuning time.
#: The search takes the gain as exact and the non-holonomic updates on first; at the chosen point the
#: updates are then dropped unless they pay, and the gain is estimated only where that pays, on the
#: train runs (:func:`gain_estimate_pays` and the one-standard-error rule). A vibration factor of 30 (every
#: MoRPI-A training set picks it; train mean end-point error 3.93 -> 3.71 %) is not a candidate: with it the
#: filter's updates on the test runs are far more confident than their innovations (normalized innovation
#: squared of the steps 25, of zero velocity 15, against 2 and 3 expected; 5 and 0.7 without it) for the same
#: cells won, and it was tried after the test cells had been seen.
GRID = {"vibration": (100.0, 300.0, 3000.0), "step_sigma": (0.02, 0.05), "gain_state": ("estimated", "considered"),
        "step_heading": ("attitude", "route"), "nhc": (True, False)}
#: Non-holonomic velocity noise [m/s]: the phone rides off the robot's turning axis, so its lateral
#: velocity is about omega_z times the lever arm (0.5 rad/s x 0.2 m = 0.1 m/s) while turning.
NHC_SIGMA = 0.1
#: Error of a turn of the route's heading (:func:`route_vectors`) relative to its angle
#: (:attr:`aided.AidTuning.turn_sigma`): set a priori, since the train routes (sines) take no turn that
#: the route's heading reads; a few per cent, the order of a phone gyro's sensitivity tolerance and of
#: the z gyro's share of a turn on a tilted phone (1 - cos 15 deg = 3.4 %).
TURN_SIGMA = 0.03
#: Least share of the train runs whose true end point lies inside the filter's 95 % ellipse for a
#: grid point to be eligible: a filter that claims 95 % must hold it on the runs it is tuned on
#: (the bound leaves room for the sampling spread of 10-15 train runs).
MIN_TRAIN_COVERAGE = 0.85
#: Accelerometer bias random walk [m/s^2/sqrt(s)]: a slow wander of the phone's accelerometer bias
#: (0.06 m/s^2 over a 40 s run, against the 0.2-0.3 m/s^2 offset of f_x while cruising, which it
#: does not try to follow).
ACCEL_WALK = 1e-2
#: Aids removed in turn in the ablation (AidTuning fields set to these values).
ABLATIONS = {"steps": {"steps": False}, "non-holonomic": {"nhc": False}, "rest updates": {"rest": False},
             "gain state": {"gain_sigma": 0.0}, "smoothing": {}}


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
    from .steps import GRID_HZ, resample_uniform, window_spread

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


def rest_noise(rec, window, epoch_s: float = 0.1) -> tuple[float, float, float]:
    """Noise densities the initial rest window shows.

    Parameters
    ----------
    rec : dataset.Recording
        The raw recording.
    window : calibration.RestWindow
        Its initial rest window.
    epoch_s : float
        Length of the epochs whose gyro means give `gyro_epoch` [s].

    Returns
    -------
    (accel, gyro, gyro_epoch)
        RMS over the axes of ``std * sqrt(dt)`` for the accelerometer
        [m/s^2/sqrt(Hz)] and the gyro [rad/s/sqrt(Hz)], and the gyro density
        that the scatter of its `epoch_s` means implies (``std(mean) *
        sqrt(epoch_s)``): the noise of a zero-rate update on one epoch, which
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
    block = np.floor((t - t[0]) / epoch_s).astype(int) if t.size else np.zeros(0, int)
    nb = int(block.max()) + 1 if block.size else 0
    if nb >= 4:
        cnt = np.bincount(block, minlength=nb)
        means = np.stack([np.bincount(block, rec.omega[sl][:, j], minlength=nb) for j in range(3)], axis=1)
        means = means[cnt > 0] / cnt[cnt > 0, None]
        ge = float(np.sqrt(np.mean(np.var(means, axis=0, ddof=1))) * np.sqrt(epoch_s))
    else:
        ge = g
    return a, g, max(ge, g)


@dataclass(frozen=True, eq=False)
class Prepared:
    """A recording ready for the aided filter in one cell: input, MoRPI track, noise from rest.

    :attr:`input` carries MoRPI's own step vectors, :attr:`route_input` the
    same steps along the route's heading (:func:`route_vectors`).
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

    rel: str
    input: aided.AidedInput
    route_input: aided.AidedInput
    morpi_xy: np.ndarray
    noise: tuple
    stop_s: float
    gyro_drift: tuple
    motion_shift: np.ndarray
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


def prepare(data, rec, mode, method, config, gain) -> Prepared:
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
    mode : {"RD", "GC", "GAC"}
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
        the gyro drift (:func:`gyro_drift`) and the specific force's mean shift
        between rest and motion [m/s^2].

    Raises
    ------
    MorpiError
        When no steps are found.
    """
    from . import steps as st
    from .strapdown import coarse_level

    key = (rec.source, mode, method, config, float(gain), "aided")
    cache = data.study_cache
    if key in cache:
        return cache[key]
    crec, _ = data.calibrated(rec, mode)
    w = data.rest_window(rec)
    f_rest, rest, shift, drift, noise = _rest_terms(data, rec, mode)
    s = data.steps(rec, mode, method, config)
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
    bt = s.peaks.grid_time[s.peaks.grid_index]
    along = route_vectors(track.length, s.start_time, s.end_time, bt, crec.time,
                          data.heading(rec, mode, config.heading_source), config.turn_deg,
                          2 if config.segment == "extrema" else 1)
    cache[key] = Prepared(data.relpath(rec), inp, replace(inp, step_vector=along), track.position, noise, float(stop),
                          drift, shift)
    return cache[key]


def _rest_terms(data, rec, mode):
    """What :func:`prepare` reads from one recording and calibration whatever the steps: the mean specific
    force of the rest window, the rest stretches, the specific force's shift under way, the gyro drift and the
    rest noise (cached in ``data.study_cache``)."""
    key = (rec.source, mode, "aided rest")
    cache = data.study_cache
    if key in cache:
        return cache[key]
    crec, _ = data.calibrated(rec, mode)
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
    from . import steps as st

    bt = np.asarray(boundaries, float)
    stretches = st.turn_stretches(bt, np.interp(bt, time, psi), np.radians(turn_deg), per_period)
    h = st.turn_heading(0.5 * (np.asarray(start, float) + np.asarray(end, float)), time, psi, stretches)
    return np.asarray(length, float)[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)


def _tuning(noise, info, gain_rel) -> aided.AidTuning:
    a, g, ge, walk, jump = noise
    return aided.AidTuning(accel_noise=a * info["vibration"], gyro_noise=g * info["vibration"], rest_gyro_noise=ge,
                           rest_accel_noise=a, turn_sigma=TURN_SIGMA,
                           gyro_walk=walk, accel_jump=jump,
                           accel_walk=ACCEL_WALK, step_sigma=info["step_sigma"], nhc_sigma=NHC_SIGMA,
                           nhc=bool(info.get("nhc", True)),
                           gain_sigma=float(gain_rel), gain_estimated=info["gain_state"] == "estimated",
                           step_heading="attitude" if info["step_heading"] == "attitude" else "gyro")


def _candidates():
    keys = sorted(GRID)
    return [dict(zip(keys, vals)) for vals in product(*(GRID[k] for k in keys))]


def _prepared_runs(data, phone, route, split, mode, method, config, gain, failed=None):
    """The folder's recordings prepared for the filter; those without steps go to `failed` (one line each)."""
    out = []
    for rec in data.recordings(phone, route, split):
        try:
            out.append(prepare(data, rec, mode, method, config, gain))
        except MorpiError as exc:
            if failed is not None:
                failed.append(str(exc))
    return out


def choose_tunables(data, train, method, mode, config, gain):
    """Tunables with the least mean end-point error on the ``train`` runs of `train` (phone, route).

    Every candidate of :data:`GRID` that takes the gain as exact runs on
    every train run in one batch; only those whose 95 % ellipse holds the
    true end point of at least :data:`MIN_TRAIN_COVERAGE` of the train runs
    compete (all of them when none does). At the chosen point the
    non-holonomic updates are then dropped unless they pay, and the gain is
    estimated instead where that pays, on the train runs (end points better
    by more than one standard error; for the gain also
    :func:`gain_estimate_pays`). The nested leave-one-out repeats both
    stages without the run it scores.

    Needs a :class:`~morpi_filters.field.FieldData`, so there is no example.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    train : (str, str)
        Phone and route of the training set (its ``train`` folder is read).
    method : {"MoRPI-A", "MoRPI-G"}
        MoRPI method.
    mode : {"RD", "GC", "GAC"}
        Calibration.
    config : steps.StepConfig
        The method's step rule.
    gain : field.Gain
        The trained gain (``mean`` sets the step lengths, ``std / mean``
        the gain error's prior).

    Returns
    -------
    TunableChoice

    Raises
    ------
    MorpiError
        The training set has no train run with steps (:func:`choose_tunables_many`
        returns that error in its list; this single-request form raises it).
    """
    choice = choose_tunables_many(data, [(train, method, mode, config, gain)])[0]
    if isinstance(choice, MorpiError):
        raise choice
    return choice


def choose_tunables_many(data, requests, *, workers: int | None = None) -> list:
    """:func:`choose_tunables` for several (train, method, mode, config, gain) at once: the grid in one
    batch per training set, the second stage of every request in one batch.

    A request without train runs gives a MorpiError in its place of the returned list.
    Needs a :class:`~morpi_filters.field.FieldData`, so there is no example.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    requests : sequence of tuple
        ``(train, method, mode, config, gain)`` as the arguments of
        :func:`choose_tunables`.
    workers : int, optional
        Threads that run the filter (:func:`morpi_filters.aided.run_batch`;
        default: the cores this process may use). The choice does not depend on it.

    Returns
    -------
    list of TunableChoice or MorpiError
        One per request, in order.
    """
    from . import dataset as ds

    # stage 1: every grid point with the trained gain taken as exact (its spread considered)
    cands = [c for c in _candidates() if c["gain_state"] == "considered" and c["nhc"]]
    plans, groups = [], {}                        # training set -> (inputs, tunings)
    for train, method, mode, config, gain in requests:
        runs = _prepared_runs(data, train[0], train[1], "train", mode, method, config, gain.mean)
        if not runs:
            plans.append(MorpiError(f"{train[0]}/{train[1]}/train: no train run with steps for the aided filter"))
            continue
        noise = tuple(float(np.median([r.noise[j] for r in runs])) for j in range(3))
        # the gyro bias walk that the train runs' rest stretches show: E[dm^2] = q dt per axis
        drift = [r.gyro_drift for r in runs if r.gyro_drift[1] is not None and r.gyro_drift[1] > 0]
        walk = (float(np.sqrt(np.mean([d[0].mean() / d[1] for d in drift]))) if drift
                else aided.AidTuning().gyro_walk)
        # the step of the apparent accelerometer bias between rest and motion: RMS of the train runs' shifts
        jump = float(np.sqrt(np.mean([r.motion_shift ** 2 for r in runs])))
        noise = noise + (walk, jump)
        rel = gain.std / gain.mean
        inputs, tunings = groups.setdefault(train, ([], []))
        plans.append((train, len(inputs), runs, ds.route(train[1]), noise, rel))
        inputs += [r.input_for(c, forward_only=True) for c in cands for r in runs]
        tunings += [_tuning(noise, c, rel) for c in cands for _ in runs]
    # one batch per training set (one batch of every set is slower: a larger working set for the same work)
    res = {train: aided.run_batch(inputs, tunings, nis=False, workers=workers)
           for train, (inputs, tunings) in groups.items()}

    def score(mine, runs, truth):
        ends = [runs[i % len(runs)].end(r) for i, r in enumerate(mine)]
        d = np.array([e[0] - truth.end_point_m for e in ends])
        m2 = np.array([x @ np.linalg.solve(e[1], x) for x, e in zip(d, ends)]).reshape(-1, len(runs))
        err = np.linalg.norm(d, axis=1).reshape(-1, len(runs)) / truth.distance_m * 100
        return err, m2 <= aided.CHI2_95_2DOF

    # stage 2, at the point each selection (all runs, and each leave-one-out fold) picks: without the
    # non-holonomic updates, and with the gain estimated (with and without them)
    variants = [{"nhc": False}, {"gain_state": "estimated"}, {"nhc": False, "gain_state": "estimated"}]
    firsts, inputs, tunings = [], [], []
    for plan in plans:
        if isinstance(plan, MorpiError):
            firsts.append(None)
            continue
        train, start, runs, truth, noise, rel = plan
        err, inside = score(res[train][start:start + len(cands) * len(runs)], runs, truth)
        keep = np.ones(len(runs), bool)
        folds = [keep] + [np.arange(len(runs)) != i for i in range(len(runs))] if len(runs) > 1 else [keep]
        picks = [_best(err[:, f], inside[:, f]) for f in folds]
        wins = sorted(set(picks))
        firsts.append((err, inside, folds, picks, wins, len(inputs)))
        more = [dict(cands[w], **v) for w in wins for v in variants]
        inputs += [r.input_for(c, forward_only=True) for c in more for r in runs]
        tunings += [_tuning(noise, c, rel) for c in more for _ in runs]
    res2 = aided.run_batch(inputs, tunings, nis=False, workers=workers)
    out = []
    for plan, first in zip(plans, firsts):
        if isinstance(plan, MorpiError):
            out.append(plan)
            continue
        _, _, runs, truth, noise, rel = plan
        err, inside, folds, picks, wins, at = first
        mine = res2[at:at + len(wins) * len(variants) * len(runs)]
        err2, inside2 = score(mine, runs, truth)
        k_hat = np.array([r.gain_error for r in mine]).reshape(-1, len(runs))
        # each train run's own gain error: its step sum against the route (z = (1 + k) x the true displacement)
        k_true = np.array([np.linalg.norm(np.diff(r.morpi_xy, axis=0), axis=1).sum() for r in runs]) \
            / truth.distance_m - 1.0
        chosen = []
        for f, w in zip(folds, picks):
            i = wins.index(w) * len(variants)
            no_nhc, est, est_no_nhc = i, i + 1, i + 2
            if _aid_pays(err[w, f], inside[w, f], err2[no_nhc, f], inside2[no_nhc, f]):
                base, e, g = cands[w], err[w], est
            else:
                base, e, g = dict(cands[w], nhc=False), err2[no_nhc], est_no_nhc
            if _estimate_wins(e[f], err2[g, f], inside2[g, f], k_hat[g, f], k_true[f]):
                base, e = dict(base, gain_state="estimated"), err2[g]
            chosen.append((base, e))
        info, e_all = chosen[0]
        # nested leave-one-out: each train run scored by the choice made without it
        loo = [c[1][i] for i, c in enumerate(chosen[1:])]
        morpi = float(np.mean([np.linalg.norm(r.morpi_xy[-1] - truth.end_point_m) for r in runs])
                      / truth.distance_m * 100)
        out.append(TunableChoice(float(e_all.mean()), float(np.mean(loo)) if loo else float("nan"),
                                 morpi, info, noise))
    return out


def gain_estimate_pays(k_hat, k_true) -> bool:
    """Whether the filter's gain estimates explain the train runs' own gain errors, beyond chance.

    The gain error ``k`` is observable only through the INS's velocity, whose
    own errors under way (the phone's specific-force shift, vibration) it
    may absorb instead, the more so the longer the run. An estimated gain is
    kept only when, over the train runs, its end-of-run estimates bring each
    run's true gain error (its step sum against the route's length) closer
    than zero does, by more than one standard error: with
    ``d_i = k_true_i^2 - (k_hat_i - k_true_i)^2``, ``mean(d) > std(d) / sqrt(r)``
    (the one-standard-error rule of model choice: the simpler model, the
    trained gain as exact, unless the data show the richer one pays).

    Parameters
    ----------
    k_hat, k_true : array_like, shape (r,)
        Estimated and true relative gain errors of the train runs.

    Returns
    -------
    bool
        False with fewer than two runs.

    Examples
    --------
    >>> gain_estimate_pays([0.04, -0.02, 0.03], [0.05, -0.03, 0.04])
    True
    >>> gain_estimate_pays([0.03, 0.02, -0.03, 0.0], [0.05, -0.03, 0.04, 0.01])   # as often wrong as right
    False
    """
    k_hat, k_true = np.asarray(k_hat, float), np.asarray(k_true, float)
    if k_true.size < 2:
        return False
    d = k_true ** 2 - (k_hat - k_true) ** 2
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


def _best(err, inside) -> int:
    """The grid point of least mean error among those whose ellipse holds enough train end points."""
    score = err.mean(axis=1)
    eligible = inside.mean(axis=1) >= MIN_TRAIN_COVERAGE
    return int(np.argmin(np.where(eligible, score, np.inf))) if eligible.any() else int(np.argmin(score))


def _aid_pays(err_with, inside_with, err_without, inside_without) -> bool:
    """Whether an aid (the non-holonomic updates) earns its place at the chosen point on the train runs.

    It stays when only with it the ellipse holds enough train end points, or
    when it improves the end points by more than one standard error of the
    paired per-run differences (the one-standard-error rule, for the simpler
    filter without it).
    """
    ok_with = np.mean(inside_with) >= MIN_TRAIN_COVERAGE
    ok_without = np.mean(inside_without) >= MIN_TRAIN_COVERAGE
    if ok_with != ok_without:
        return bool(ok_with)
    d = np.asarray(err_without) - np.asarray(err_with)
    if d.size < 2:
        return False
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


def _estimate_wins(err, err_e, inside_e, k_hat, k_true) -> bool:
    """Whether estimating the gain at the chosen point replaces taking it as exact.

    Only when the estimate's ellipse still holds enough train end points,
    the estimates explain the runs' gain errors (:func:`gain_estimate_pays`)
    and the end points improve by more than one standard error of the paired
    per-run differences (the one-standard-error rule).
    """
    d = np.asarray(err) - np.asarray(err_e)
    if d.size < 2 or np.mean(inside_e) < MIN_TRAIN_COVERAGE or not gain_estimate_pays(k_hat, k_true):
        return False
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


@dataclass(frozen=True)
class PairedDifference:
    """End-point errors of one method minus another's over the same runs [pp of the route's distance].

    Attributes
    ----------
    mean_pp : float
        Mean of the per-run differences (negative: the first method is better).
    se_pp : float
        Its standard error (sample standard deviation / sqrt(runs)); NaN below two runs.
    runs : int
        Runs where both errors are finite.
    p_value : float
        Two-sided paired t-test of a zero mean difference (NaN below two runs, 1 when every difference
        is zero).
    alpha : float
        Level of :attr:`verdict`.
    """

    mean_pp: float
    se_pp: float
    runs: int
    p_value: float
    alpha: float = 0.05

    @property
    def verdict(self) -> str:
        """``"better"`` or ``"worse"`` where the test rejects a zero difference at :attr:`alpha`, else ``"tie"``."""
        if not self.p_value < self.alpha:
            return "tie"
        return "better" if self.mean_pp < 0 else "worse"


def paired_difference(errors_m, reference_m, distance_m: float, *, alpha: float = 0.05) -> PairedDifference:
    """Compare two methods' end-point errors run by run (paired t-test).

    With ten or so test runs per cell, a mean difference of a few tenths of a
    per cent is often within the runs' own spread; the test says which
    differences the runs support.

    Parameters
    ----------
    errors_m, reference_m : array_like, shape (n,)
        End-point errors of the method and of the reference on the same runs [m]; pairs with a NaN are
        left out.
    distance_m : float
        The route's distance [m] (the errors are reported in % of it).
    alpha : float
        Level of the test, in (0, 1).

    Returns
    -------
    PairedDifference

    Raises
    ------
    MorpiError
        For arrays of different shapes, a distance that is not positive or `alpha` outside (0, 1).

    Examples
    --------
    >>> d = paired_difference([1.0, 1.2, 0.9, 1.1], [1.5, 1.6, 1.4, 1.7], 50.0)
    >>> round(d.mean_pp, 3), d.runs, d.verdict
    (-1.0, 4, 'better')
    """
    a = np.asarray(errors_m, dtype=float)
    b = np.asarray(reference_m, dtype=float)
    if a.ndim != 1 or a.shape != b.shape:
        raise MorpiError(f"paired_difference: errors of shapes {a.shape} and {b.shape}, expected two (n,) arrays")
    if not (np.isfinite(distance_m) and distance_m > 0):
        raise MorpiError(f"distance_m={distance_m!r}: expected a positive route distance [m]")
    if not 0 < alpha < 1:
        raise MorpiError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    ok = np.isfinite(a) & np.isfinite(b)
    d = (a[ok] - b[ok]) / distance_m * 100
    n = int(d.size)
    if n < 2:
        return PairedDifference(float(d.mean()) if n else float("nan"), float("nan"), n, float("nan"), alpha)
    mean, se = float(d.mean()), float(d.std(ddof=1) / np.sqrt(n))
    if se > 0:
        from scipy import stats

        p = float(2 * stats.t.sf(abs(mean) / se, n - 1))
    else:
        p = 1.0 if mean == 0 else 0.0
    return PairedDifference(mean, se, n, p, alpha)


@dataclass(frozen=True)
class TunableChoice:
    """The tunables chosen on a training set's train runs.

    Attributes
    ----------
    score_percent : float
        Mean train end-point error of the chosen grid point [% of the route].
    loo_percent : float
        Nested leave-one-out: each train run's error under the grid point chosen without it [%].
    morpi_percent : float
        MoRPI alone on the same train runs with the same gain [%].
    info : dict
        The grid point (:data:`GRID`).
    noise : tuple
        What the train runs show: noise densities at rest (accel, gyro, gyro per epoch), the gyro
        bias walk [rad/s/sqrt(s)] and the shift of the mean specific force between rest and motion
        [m/s^2] (the accelerometer bias step of :class:`aided.AidTuning`).
    """

    score_percent: float
    loo_percent: float
    morpi_percent: float
    info: dict
    noise: tuple


@dataclass(frozen=True)
class AidedCell:
    """The aided filter on one MoRPI table cell (test runs).

    Attributes
    ----------
    spec : evaluate.CellSpec
    forward_percent, smoothed_percent, morpi_percent, ins_percent : float
        Mean end-point error over the runs [% of the route's distance].
    runs : tuple of dict
        Per run: ``file``, end-point errors [m] (``forward_m``, ``smoothed_m``, ``morpi_m``, ``ins_m``,
        ``steps_m``),
        ``mahalanobis2`` of the true end point, ``inside_95``, estimated gain error and its sigma.
    tuning : dict
        The grid point chosen on the train runs, and the noise densities used.
    train_percent : float
        Its mean train end-point error [%].
    train_loo_percent : float
        The same with the tunables chosen in a nested leave-one-out over the train runs [%].
    train_morpi_percent : float
        MoRPI alone on those train runs [%].
    nis : dict
        Measurement name -> (mean NIS per update, dof).
    paths : tuple
        Per run, up to the epoch where the end point is read (``Prepared.stop_s``): (epoch time,
        forward xy, smoothed xy, MoRPI xy, forward P_xy) for figures.
    failed : tuple of str
        Runs of the tables' cell the filter could not run, one line each.
    steps_percent : float
        The filter's own step vectors summed, without the INS (dead reckoning with the chosen step
        direction; NaN when the direction is the filter's attitude) [%]: what the INS adds is the
        difference to the filter.
    step_innovation : dict
        The forward filter's step updates over the runs, up to the read-out
        (:func:`aided.step_innovation_components`): ``updates``, the measured
        step minus the INS's displacement since the last boundary along the
        step (``along_mean_m``, ``along_rms_m``; positive: the INS fell
        short) and across it (``cross_mean_m``, ``cross_rms_m``) [m], and the
        median spread the filter expected along the step
        (``predicted_along_sigma_m``) [m]; empty without step updates.
    paired : PairedDifference or None
        The smoothed filter minus MoRPI alone, run by run (:func:`paired_difference`).
    """

    spec: object
    forward_percent: float
    smoothed_percent: float
    morpi_percent: float
    ins_percent: float
    runs: tuple
    tuning: dict
    train_percent: float
    train_loo_percent: float
    train_morpi_percent: float
    nis: dict
    paths: tuple
    failed: tuple = ()
    steps_percent: float = float("nan")
    step_innovation: dict = field(default_factory=dict)
    paired: PairedDifference | None = None

    @property
    def label(self) -> str:
        return self.spec.label


@dataclass(frozen=True)
class AidedStudy:
    """Every MoRPI cell, the ablation on the GC cells, the field coverage and NIS.

    Attributes
    ----------
    cells : tuple of AidedCell
    ablation : tuple of dict
        ``{cell, removed, smoothed_percent}``: the full filter with one aid removed.
    coverage_95 : float
        Share of test runs whose true end point is inside the filter's 95 % ellipse.
    nis : dict
        Measurement name -> (mean NIS per update, dof) over all test runs.
    note : str
        Why the study is empty, when it is.
    no_rest : tuple of str
        One line per recording without an initial rest
        (:meth:`~morpi_filters.field.FieldData.no_rest`): the filter starts
        at the rest window and takes its noise there, so it does not run on
        them (each cell names them among its failed runs).
    """

    cells: tuple
    ablation: tuple
    coverage_95: float
    nis: dict
    note: str = ""
    no_rest: tuple = ()


def _innovation_summary(parts) -> dict:
    """Along- and cross-track step innovations of a cell's runs (:func:`aided.step_innovation_components`)."""
    if not parts:
        return {}
    along, cross, sigma = (np.concatenate([q[j] for q in parts]) for j in range(3))
    ok = np.isfinite(along)
    along, cross, sigma = along[ok], cross[ok], sigma[ok]
    if not along.size:
        return {}
    rms = lambda a: float(np.sqrt(np.mean(a * a)))  # noqa: E731
    return {"updates": int(along.size), "along_mean_m": float(along.mean()), "along_rms_m": rms(along),
            "cross_mean_m": float(cross.mean()), "cross_rms_m": rms(cross),
            "predicted_along_sigma_m": float(np.median(sigma))}


def _same_estimate(base, changed) -> bool:
    """Whether two tunings give the same estimate: equal, or differing only in a gain error that is
    considered, not estimated (its prior then changes the covariance alone)."""
    if changed == base:
        return True
    return (not base.gain_estimated and not changed.gain_estimated
            and changed.with_(gain_sigma=base.gain_sigma) == base)


def _merge_nis(acc, nis):
    for name, (s, c, dof) in nis.items():
        a = acc.setdefault(name, [0.0, 0, dof])
        a[0] += s
        a[1] += c


def aided_study(root=None, result=None, labels=None, ablation: bool = True,
                workers: int | None = None) -> AidedStudy:
    """The aided filter on every MoRPI cell of :func:`evaluate.evaluate_tables`.

    Parameters
    ----------
    root : path, optional
        Dataset root (when `result` is not given).
    result : evaluate.TablesResult, optional
        Reuse a computed evaluation (its cells, gains, step rules and caches).
    labels : collection of str, optional
        Only these cells (``CellSpec.label``).
    ablation : bool
        Also run the GC cells with each aid removed in turn.
    workers : int, optional
        Threads that run the filter (:func:`morpi_filters.aided.run_batch`;
        default: the cores this process may use). The results do not depend on it.

    Returns
    -------
    AidedStudy
        The cells in the tables' order, the ablation rows (GC cells only, when
        `ablation`), the 95 % coverage over the test runs and the NIS per
        measurement; empty with a ``note`` when no cell qualifies.
    """
    from . import dataset as ds
    from .evaluate import evaluate_tables

    # the MoRPI cells, their gains and step rules (the filter's own INS-alone column is computed here)
    res = result if result is not None else evaluate_tables(root, alternatives=False, ins=False)
    data = res.data
    gmap = {(g.phone, g.route, g.method, g.calibration): g for g in res.gains}
    wanted = [c for c in res.cells if c.spec.train is not None and c.runs
              and (labels is None or c.spec.label in labels)
              and (c.spec.train[0], c.spec.train[1], c.spec.method, c.spec.calibration) in gmap]
    # the tunables of every training set, method and calibration in one search
    keys = sorted({(c.spec.train, c.spec.method, c.spec.calibration) for c in wanted})
    picks = choose_tunables_many(data, [(tr, m, cal, res.selections[m].config, gmap[(tr[0], tr[1], m, cal)])
                                        for tr, m, cal in keys], workers=workers)
    chosen = {k: v for k, v in zip(keys, picks) if not isinstance(v, MorpiError)}
    todo = []
    for cell in wanted:
        sp = cell.spec
        g = gmap[(sp.train[0], sp.train[1], sp.method, sp.calibration)]
        config = res.selections[sp.method].config
        key = (sp.train, sp.method, sp.calibration)
        if key not in chosen:
            continue
        choice = chosen[key]
        score, info, noise = choice.score_percent, choice.info, choice.noise
        by_file = {r.file: r for r in cell.runs}
        failed = []
        runs = [p for p in _prepared_runs(data, sp.phone, sp.route, sp.split, sp.calibration, sp.method, config,
                                          g.mean, failed) if p.rel in by_file]
        # every run of the tables' cell is evaluated, or named
        failed += [f"{rel}: not prepared for the aided filter" for rel in sorted(set(by_file) - {p.rel for p in runs})
                   if not any(rel in m for m in failed)]
        if runs:
            todo.append((cell, g, score, info, noise, runs, by_file, choice, tuple(failed)))
    no_rest = tuple(data.no_rest_lines())
    if not todo:
        return AidedStudy((), (), float("nan"), {}, note="No MoRPI table cell could be evaluated on these recordings.",
                          no_rest=no_rest)
    # one pass per route: every cell's test runs (smoothed) and, for the GC cells, each aid removed in turn
    results, abl_res = {}, {}
    for route in sorted({c.spec.route for c, *_ in todo}):
        items = []
        for i, (cell, g, score, info, noise, runs, by_file, _, _) in enumerate(todo):
            if cell.spec.route != route:
                continue
            base = _tuning(noise, info, g.std / g.mean)
            items += [(i, p, None, base) for p in runs]
            if ablation and cell.spec.calibration == "GC":
                items += [(i, p, name, base.with_(**change)) for name, change in ABLATIONS.items() if change
                          and not _same_estimate(base, base.with_(**change)) for p in runs]
        # the ablation reads the forward filter only: cut at the read-out
        out = aided.run_batch([p.input_for(todo[i][3], forward_only=name is not None) for i, p, name, _ in items],
                              [t for *_, t in items],
                              smooth=[name is None for _, _, name, _ in items], smoothed_covariance=False,
                              innovations=[name is None for _, _, name, _ in items], workers=workers)
        for (i, p, name, _), r in zip(items, out):
            if name is None:
                results[(i, p.rel)] = r
            else:
                abl_res[(i, p.rel, name)] = r
    cells, abl, nis_all = [], [], {}
    inside = total = 0
    for i, (cell, g, score, info, noise, runs, by_file, choice, failed) in enumerate(todo):
        sp = cell.spec
        truth = ds.route(sp.route)
        d = truth.distance_m / 100
        rows, paths, nis, innov = [], [], {}, []
        for p in runs:
            r = results[(i, p.rel)]
            if "step" in r.innovations:
                # the step updates up to the read-out (after it the phone may be handled)
                inn = r.innovations["step"]
                k = int(np.searchsorted(inn.time, p.stop_s, side="right"))
                innov.append([c[:k] for c in aided.step_innovation_components(inn)])
            rec = next(x for x in data.recordings(sp.phone, sp.route, sp.split) if data.relpath(x) == p.rel)
            try:
                ins = np.asarray(data.ins(rec, sp.calibration, "INS-3D").position)[-1, :2]
                ins_m = float(np.linalg.norm(ins - truth.end_point_m))
            except MorpiError:
                ins_m = float("nan")
            end_xy, end_P, end_sm = p.end(r)
            dxy = end_xy - truth.end_point_m
            m2 = float(dxy @ np.linalg.solve(end_P, dxy))
            inside += m2 <= aided.CHI2_95_2DOF
            total += 1
            _merge_nis(nis, r.nis)
            _merge_nis(nis_all, r.nis)
            rows.append({"file": p.rel, "forward_m": float(np.linalg.norm(dxy)),
                         "smoothed_m": float(np.linalg.norm(end_sm - truth.end_point_m)),
                         "morpi_m": float(by_file[p.rel].end_error_m), "ins_m": ins_m,
                         "mahalanobis2": m2, "inside_95": bool(m2 <= aided.CHI2_95_2DOF),
                         "gain_error": r.gain_error, "gain_error_sigma": r.gain_sigma,
                         "steps_m": (float("nan") if info["step_heading"] == "attitude" else
                                     float(np.linalg.norm(p.input_for(info).step_vector.sum(axis=0)
                                                          - truth.end_point_m)))})
            # up to the read-out, where the end point is taken (after it the phone may be handled)
            cut = r.index_at(p.stop_s) + 1
            paths.append((r.time[:cut], r.position[:cut, :2], r.smoothed[:cut, :2], p.morpi_xy, r.P_xy[:cut]))
        mean = lambda k: float(np.nanmean([q[k] for q in rows]) / d)  # noqa: E731
        cells.append(AidedCell(
            spec=sp, forward_percent=mean("forward_m"), smoothed_percent=mean("smoothed_m"),
            morpi_percent=mean("morpi_m"), ins_percent=mean("ins_m"), runs=tuple(rows),
            tuning={**info, "accel_noise": noise[0] * info["vibration"], "gyro_noise": noise[1] * info["vibration"],
                    "rest_accel_noise": noise[0], "rest_gyro_noise": noise[2], "gyro_walk": noise[3], "accel_jump": noise[4],
                    "gain_sigma": g.std / g.mean},
            train_percent=score, train_loo_percent=choice.loo_percent, train_morpi_percent=choice.morpi_percent,
            nis={k: (v[0] / max(v[1], 1), v[2]) for k, v in nis.items()}, paths=tuple(paths), failed=failed,
            steps_percent=float(np.mean([q["steps_m"] for q in rows]) / d),
            step_innovation=_innovation_summary(innov),
            paired=paired_difference([q["smoothed_m"] for q in rows], [q["morpi_m"] for q in rows],
                                     truth.distance_m)))
        if ablation and sp.calibration == "GC":
            for name, change in ABLATIONS.items():
                if not change:
                    # without smoothing: the forward filter's end points
                    val = mean("forward_m")
                else:
                    # an aid the chosen filter does not use (or a gain it only considers) leaves the
                    # forward estimate as it is
                    e = [np.linalg.norm(p.end(abl_res.get((i, p.rel, name), results[(i, p.rel)]))[0]
                                        - truth.end_point_m) for p in runs]
                    val = float(np.mean(e) / d)
                abl.append({"cell": sp.label, "removed": name, "smoothed_percent": val})
    return AidedStudy(cells=tuple(cells), ablation=tuple(abl), coverage_95=inside / total if total else float("nan"),
                      nis={k: (v[0] / max(v[1], 1), v[2]) for k, v in nis_all.items()},
                      no_rest=no_rest)
