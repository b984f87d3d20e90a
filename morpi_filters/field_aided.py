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

The choice is a consistency criterion before an error criterion
(:func:`choose_consistent`, fixed before any test run was scored with it): a
grid point competes on its mean train end-point error only when it is
consistent on the train runs, its 95 % ellipse holding the true end point of
at least :data:`MIN_TRAIN_COVERAGE` of them and the NIS per degree of freedom
of each measurement type it uses (steps, zero velocity, zero rate,
non-holonomic), summed over the train runs' forward passes up to the read-out,
inside :data:`NIS_BAND`. The least error alone picked points whose step updates
expect innovations tens of times wider than they come (a dead reckoning of the
steps with an INS beside it that the covariance does not describe). When no
point is consistent the least inconsistent wins: enough coverage first, then
the fewest measurement types outside the band, then the least error. The
nested leave-one-out repeats the same rule on each fold's runs, and the second
stage (non-holonomic updates, estimated gain) keeps a change only when it
leaves the filter no less consistent.

The filter starts at the calibration's initial rest window (what precedes it,
the phone placed and handled, is no motion of the robot). The rest updates run
on that window and on every
still stretch after the motion (:func:`still_spans`), zero velocity alone
between that window and the motion onset; the filter is read where MoRPI's own
track ends (:meth:`Prepared.end`).

Each cell holds, beside MoRPI alone, the filter's own steps alone
(:func:`steps_alone`: the step vectors it is fed, summed without the INS), the
run-by-run tests against both with Holm's correction over the cells of a
calibration (:func:`paired_difference`, :func:`holm`, with the smallest
difference a tie could have shown: :func:`detectable_difference`), the same
tests against MoRPI alone under its best train-chosen heading reading (the
rule's own, or the route's heading where the train runs prefer it beyond the
tie tolerance: :func:`choose_reading`; with the Weinberg length or the period
count, :func:`choose_length`; the tables' cells are left as they are), the
share of
true end points inside the 95 % regions of the smoothed and the forward
estimate, each under its own covariance (:func:`ellipse_coverage`), and the
NIS of each measurement per degree of freedom with its chi-square band
(:func:`nis_consistency`). The ablation removes each aid the chosen filter
uses (:func:`aid_used`) and reads both filters the same two ways.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from itertools import product

import numpy as np

from . import _aided_kernel, aided
from .choice import choose
from .errors import DataError, MorpiError, ParameterError

__all__ = ["GRID", "ABLATIONS", "AidedCell", "AidedStudy", "PairedDifference", "Prepared", "aided_study",
           "choose_tunables", "choose_tunables_many", "paired_difference", "prepare",
           "still_spans", "rest_noise", "gyro_drift", "gain_estimate_pays", "route_vectors", "steps_alone",
           "holm", "detectable_difference", "READING_SE", "ReadingChoice", "route_sums",
           "route_reading_pays", "choose_reading", "LENGTHS", "period_sums", "period_length", "LengthChoice",
           "choose_length", "ellipse_coverage", "nis_consistency", "aid_used", "NIS_BAND",
           "choose_consistent", "route_steps", "tuning_from", "rest_terms"]

#: Train-only grid: factor on the rest-window noise densities (the moving robot vibrates far above
#: them), step displacement noise [m], whether the gain error is estimated or only considered (the
#: trained gain taken as exact, its spread kept in the covariance: :attr:`aided.AidTuning.gain_estimated`),
#: and the source of the step direction (the filter's attitude, or the route's heading: the turns
#: alone, :func:`route_vectors`), and whether the non-holonomic updates run. MoRPI's own heading reading
#: (its step vectors) is not a candidate: the route's heading took its place in every training set and
#: nested fold, with identical choices and scores without it, at a third less tuning time.
#: The search takes the gain as exact, with and without the non-holonomic updates, and keeps the
#: consistent points (:func:`choose_consistent`); at the chosen point the updates are then dropped unless
#: they pay, and the gain is estimated only where that pays, on the train runs (:func:`gain_estimate_pays`
#: and the one-standard-error rule). On every training set of the field data the grid holds consistent
#: points, so it is not extended below 100. A vibration factor of 30 (every
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
#: Band of the train NIS per degree of freedom that a consistent grid point keeps for every measurement
#: type it uses (:func:`choose_consistent`). Not the chi-square band of the mean over the train updates:
#: with the hundreds to thousands of updates of a training set that band is a few per cent wide (1 +- 0.04
#: for 3000 two-dof updates) and tests a filter whose measurement noises are white and exactly known,
#: while the field filter's are modelling choices (the rest windows' densities, a zero-velocity sigma, a
#: step sigma from a two-value grid) and a step's error carries over to the next steps: a filter matched
#: within tens of per cent would fail it at every grid point and the criterion would see nothing. The band
#: is a factor 5 on either side of 1 (symmetric in the logarithm): outside it the innovations the filter
#: expects are off from those it sees by more than a factor sqrt(5) = 2.2 in spread, a gross mistuning
#: (a filter that hands its position to every step, or one that holds its INS against the steps).
NIS_BAND = (0.2, 5.0)
#: Accelerometer bias random walk [m/s^2/sqrt(s)]: a slow wander of the phone's accelerometer bias
#: (0.06 m/s^2 over a 40 s run, against the 0.2-0.3 m/s^2 offset of f_x while cruising, which it
#: does not try to follow).
ACCEL_WALK = 1e-2
#: Aids removed in turn in the ablation (AidTuning fields set to these values; smoothing: the forward
#: filter read instead of the smoothed one). The rest updates are removed from a filter started at the
#: motion onset, and compared with the filter started there with them (:meth:`Prepared.onset_input`).
ABLATIONS = {"steps": {"steps": False}, "non-holonomic": {"nhc": False}, "rest updates": {"rest": False},
             "gain state": {"gain_sigma": 0.0}, "smoothing": {}}
#: Level of the paired tests, and the power at which a tie states the smallest difference the runs
#: could have detected (:func:`detectable_difference`).
ALPHA, POWER = 0.05, 0.8
#: Tie tolerance of MoRPI alone's reading choice (:func:`choose_reading`): the route's heading replaces the
#: step rule's own reading only when its train leave-one-out error is lower by more than this many standard
#: errors of the paired difference over the train runs (the one-standard-error rule of
#: :data:`morpi_filters.field.SOURCE_SE`): the reading the rule search chose is kept within it.
READING_SE = 1.0
#: Two-sided 95 % point of the standard normal: the bound of one axis' 95 % interval [sigma].
Z_95 = 1.959963984540054


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
    from .steps import GRID_HZ, resample_uniform
    from .steps.prepare import window_spread

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
        the gyro drift (:func:`gyro_drift`), the specific force's mean shift
        between rest and motion [m/s^2] and the motion onset [s].

    Raises
    ------
    DataError
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
    f_rest, rest, shift, drift, noise = rest_terms(data, rec, mode)
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
    along = route_steps(data, rec, mode, config, s, track.length)
    cache[key] = Prepared(data.relpath(rec), inp, replace(inp, step_vector=along), track.position, noise, float(stop),
                          drift, shift, onset)
    return cache[key]


def rest_terms(data, rec, mode):
    """What :func:`prepare` reads from one recording and calibration whatever the steps: the mean specific
    force of the rest window, the rest stretches, the specific force's shift under way, the gyro drift and the
    rest noise (cached in ``data.study_cache``).

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    rec : Recording
        The recording.
    mode : {"RD", "GC", "GAC"}
        Calibration.

    Returns
    -------
    tuple
        The terms above, in that order.
    """
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


def route_steps(data, rec, mode, config, s, length) -> np.ndarray:
    """:func:`route_vectors` of a recording's steps `s` (found under `config`) with the step lengths `length`.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    rec : Recording
        The recording.
    mode : {"RD", "GC", "GAC"}
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
    crec, _ = data.calibrated(rec, mode)
    bt = s.peaks.grid_time[s.peaks.grid_index]
    return route_vectors(length, s.start_time, s.end_time, bt, crec.time,
                         data.heading(rec, mode, config.heading_source), config.turn_deg,
                         2 if config.segment == "extrema" else 1)


def route_sums(data, rec, mode, method, config) -> tuple[float, np.ndarray]:
    """MoRPI alone's distance and end point per unit gain with the route's heading (:func:`route_vectors`).

    The steps, their Weinberg weights and fractions are those of `config`
    (:meth:`~morpi_filters.field.FieldData.steps`); only the heading is the
    route's, the same the filter's ``"route"`` step direction reads. A run
    dead-reckoned with gain ``G`` ends at ``G * u``.

    Parameters
    ----------
    data : field.FieldData
    rec : dataset.Recording
    mode : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig

    Returns
    -------
    w : float
        ``sum(weight * fraction)``: the distance per unit gain.
    u : ndarray, shape (2,)
        The end point per unit gain.

    Raises
    ------
    DataError
        When no steps are found (as :meth:`~morpi_filters.field.FieldData.steps`).
    """
    s = data.steps(rec, mode, method, config)
    unit = np.asarray(s.weight, float) * np.asarray(s.fraction, float)
    v = route_steps(data, rec, mode, config, s, unit)
    return float(unit.sum()), (v.sum(axis=0) if v.size else np.zeros(2))


@dataclass(frozen=True)
class ReadingChoice:
    """MoRPI alone's heading reading chosen on the train runs for one method (:func:`choose_reading`).

    Attributes
    ----------
    method : str
    reading : str
        ``"route"`` (:func:`route_sums`) or the step rule's own heading reading
        (:attr:`steps.StepConfig.heading`).
    rule_percent, route_percent : float
        Leave-one-out mean end-point error of the train runs under the rule's reading and under the
        route's heading [%] (infinite when a train run cannot be processed).
    difference_se_pp : float
        Standard error of the per-run difference (route minus rule) [pp].
    runs : int
        Train runs scored.
    """

    method: str
    reading: str
    rule_percent: float
    route_percent: float
    difference_se_pp: float
    runs: int


def route_reading_pays(rule_errors, route_errors, *, se_factor: float = READING_SE) -> bool:
    """Whether the route's heading beats the rule's reading on the train runs, beyond the tie tolerance.

    The per-run difference (route minus rule, the same runs in the same
    order) must have a mean below ``-se_factor`` standard errors of itself
    (:data:`READING_SE`): within that the rule's own reading is kept.

    Parameters
    ----------
    rule_errors, route_errors : array_like, shape (n,)
        Per train run, the leave-one-out end-point errors [%].
    se_factor : float
        Tie tolerance in standard errors of the paired difference.

    Returns
    -------
    bool

    Examples
    --------
    >>> route_reading_pays([3.0, 4.0, 5.0, 4.0], [2.0, 3.1, 3.9, 3.0])     # 1 pp better on every run
    True
    >>> route_reading_pays([3.0, 4.0, 5.0, 4.0], [3.5, 3.0, 5.0, 3.9])     # better on average, within the spread
    False
    """
    a = np.asarray(rule_errors, float)
    b = np.asarray(route_errors, float)
    if a.shape != b.shape or a.ndim != 1 or a.size < 2 or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return False
    d = b - a
    return bool(d.mean() < -se_factor * (d.std(ddof=1) / np.sqrt(d.size)))


def _route_loo(data, method, config, mode="GC"):
    """Per short-route train run, the leave-one-out end-point errors [%] of the rule's reading and of the
    route's heading, the same gains (:func:`morpi_filters.field.train_summary`); None when a run fails."""
    from . import field as fd

    rule, route = [], []
    for truth, _, _, g, u, loo, failed in fd.train_summary(data, method, config, mode):
        recs = truth.runs
        if failed:
            return None
        if loo is None:
            continue
        ur = np.empty_like(u)
        for i, r in enumerate(recs):
            try:
                ur[i] = route_sums(data, r, mode, method, config)[1]
            except MorpiError:
                return None
        rule.append(loo)
        route.append(fd.loo_errors(truth, g, ur))
    if not rule:
        return None
    return np.concatenate(rule), np.concatenate(route)


def choose_reading(data, method, config) -> ReadingChoice:
    """MoRPI alone's best heading reading on the train runs: the rule's own, or the route's heading.

    The rule (:func:`morpi_filters.field.select_config`) already holds the
    best of MoRPI alone's own readings; the route's heading
    (:func:`route_sums`, the filter's ``"route"`` step direction) is offered
    beside it and scored by the same criterion: the leave-one-out end-point
    error of the short-route train runs under GC (each run dead-reckoned with
    the mean gain of its set's other runs). It is chosen only when it beats
    the rule beyond the tie tolerance (:func:`route_reading_pays`). Nothing of
    a ``test`` folder is read.

    Parameters
    ----------
    data : field.FieldData
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
        The method's step rule.

    Returns
    -------
    ReadingChoice
    """
    errs = _route_loo(data, method, config)
    if errs is None:
        return ReadingChoice(method, config.heading, float("inf"), float("inf"), float("nan"), 0)
    rule, route = errs
    d = route - rule
    se = float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else float("nan")
    pick = "route" if route_reading_pays(rule, route) else config.heading
    return ReadingChoice(method, pick, float(rule.sum()) / rule.size, float(route.sum()) / route.size, se,
                         int(rule.size))


#: The step lengths MoRPI alone may use: the Weinberg length of the trained gain, or the period count (each
#: half period a fixed length learnt on the train runs: :func:`period_sums`).
LENGTHS = ("weinberg", "period count")


def period_sums(data, rec, mode, method, config, reading) -> tuple[float, np.ndarray]:
    """MoRPI alone's half periods and end point per unit half-period length: the period count.

    Each step of `config` counts its half periods (two between maxima, one
    between extrema) times its counted fraction; every half period has the
    same length. The step directions are those of `reading`: the route's
    heading (:func:`route_vectors`) or the rule's own.

    Parameters
    ----------
    data : field.FieldData
    rec : dataset.Recording
    mode : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        ``"route"`` or the rule's heading reading (:attr:`ReadingChoice.reading`).

    Returns
    -------
    n : float
        Half periods counted.
    u : ndarray, shape (2,)
        The end point per unit half-period length [m / m].

    Raises
    ------
    DataError
        When no steps are found.
    """
    s = data.steps(rec, mode, method, config)
    c = np.asarray(s.fraction, float) * (2.0 if config.segment == "maxima" else 1.0)
    if reading == "route":
        v = route_steps(data, rec, mode, config, s, c)
    else:
        h = np.asarray(s.heading, float)
        v = c[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)
    return float(c.sum()), (v.sum(axis=0) if v.size else np.zeros(2))


def _unit_sums(data, rec, mode, method, config, reading, length):
    """Distance and end point per unit gain (Weinberg) or per unit half-period length (period count)."""
    if length == "period count":
        return period_sums(data, rec, mode, method, config, reading)
    if reading == "route":
        return route_sums(data, rec, mode, method, config)
    w, ux, uy = data.step_sums(rec, mode, method, config)[:3]
    return float(w), np.array([ux, uy])


def _phone_sets(data, phone):
    """The phone's short-route training sets: (truth, train recordings) of those holding train runs."""
    from . import dataset as ds

    return [(ds.route(tset.route), tset.runs) for tset in data.train_sets() if tset.phone == phone and tset.runs]


def period_length(data, phone, mode, method, config, reading) -> float:
    """The period count's half-period length [m]: total train distance over total train half periods.

    Over every train run of the phone's short-route training sets
    (:meth:`morpi_filters.field.FieldData.train_sets`), the method's steps under
    `config` and `mode`. NaN when a train run has no steps or there are none.

    Parameters
    ----------
    data : field.FieldData
    phone : str
    mode : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        As for :func:`period_sums` (the count does not depend on it).

    Returns
    -------
    float
    """
    dist = halves = 0.0
    for truth, recs in _phone_sets(data, phone):
        for r in recs:
            try:
                halves += period_sums(data, r, mode, method, config, reading)[0]
            except MorpiError:
                return float("nan")
            dist += truth.distance_m
    return dist / halves if halves > 0 else float("nan")


@dataclass(frozen=True)
class LengthChoice:
    """MoRPI alone's step length chosen on one phone's train runs for one method (:func:`choose_length`).

    Attributes
    ----------
    phone, method : str
    length : str
        One of :data:`LENGTHS`.
    weinberg_percent, period_percent : float
        Held-out mean end-point error of the train runs with each length [%] (infinite when a run
        cannot be processed).
    held_out : str
        ``"training set"`` (each of several training sets held out in turn) or ``"run"`` (leave-one-out).
    runs : int
        Train runs scored.
    """

    phone: str
    method: str
    length: str
    weinberg_percent: float
    period_percent: float
    held_out: str
    runs: int


def choose_length(data, phone, method, config, reading) -> LengthChoice:
    """The Weinberg length or the period count for MoRPI alone, chosen on the phone's train runs.

    Each length is learnt on held-out data: with several short-route
    training sets for the phone, each set is held out in turn and scored with
    the length learnt on the others (the Weinberg gain: the mean of the runs'
    own gains; the period count: their total distance over their total half
    periods); with one set, each run is held out. Scored under GC with the
    method's `reading`; the period count is taken only when it beats the
    Weinberg length beyond the tie tolerance (:func:`route_reading_pays`'s
    one-standard-error rule). Nothing of a ``test`` folder is read.

    Parameters
    ----------
    data : field.FieldData
    phone : str
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        As for :func:`period_sums`.

    Returns
    -------
    LengthChoice
    """
    sets = []
    for truth, recs in _phone_sets(data, phone):
        rows = []
        for r in recs:
            try:
                rows.append([_unit_sums(data, r, "GC", method, config, reading, k) for k in LENGTHS])
            except MorpiError:
                return LengthChoice(phone, method, "weinberg", float("inf"), float("inf"), "-", 0)
        end = np.asarray(truth.end_point_m, float)
        d = truth.distance_m
        sets.append((d, end, np.array([[q[0] for q in row] for row in rows]),
                     np.array([[q[1] for q in row] for row in rows])))
    err = {k: [] for k in LENGTHS}
    by_set = len(sets) > 1
    for k, (d, end, n, u) in enumerate(sets):
        for i in range(n.shape[0]):
            if by_set:
                other = [x for j, x in enumerate(sets) if j != k]
            else:
                keep = np.arange(n.shape[0]) != i
                other = [(d, end, n[keep], u[keep])] if keep.sum() else []
            if not other:
                continue
            gain = np.mean(np.concatenate([dd / nn[:, 0] for dd, _, nn, _ in other]))
            half = sum(dd * nn.shape[0] for dd, _, nn, _ in other) / sum(nn[:, 1].sum() for _, _, nn, _ in other)
            err["weinberg"].append(np.linalg.norm(gain * u[i, 0] - end) / d * 100)
            err["period count"].append(np.linalg.norm(half * u[i, 1] - end) / d * 100)
    a, b = np.array(err["weinberg"]), np.array(err["period count"])
    if not a.size:
        return LengthChoice(phone, method, "weinberg", float("inf"), float("inf"), "-", 0)
    pick = "period count" if route_reading_pays(a, b) else "weinberg"
    return LengthChoice(phone, method, pick, float(a.mean()), float(b.mean()), "training set" if by_set else "run",
                        int(a.size))


def tuning_from(noise, info, gain_rel) -> aided.AidTuning:
    """The filter's tunables from a recording's rest noise and a grid point.

    Parameters
    ----------
    noise : tuple
        ``(accel, gyro, rest gyro, gyro walk, accel jump)`` noise densities of the rest window
        (:func:`rest_noise`).
    info : dict
        A grid point (:data:`GRID`'s keys).
    gain_rel : float
        The trained gain's relative spread (the gain error's prior).

    Returns
    -------
    aided.AidTuning
    """
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
    every train run in one batch, with and without the non-holonomic
    updates; only those consistent on the train runs compete
    (:func:`choose_consistent`: the 95 % ellipse holds the true end point of
    at least :data:`MIN_TRAIN_COVERAGE` of them and every measurement type's
    NIS per dof lies in :data:`NIS_BAND`; the least inconsistent when none
    is). At the chosen point the non-holonomic updates are then dropped
    unless they pay, and the gain is estimated instead where that pays, on
    the train runs (a less inconsistent filter first, then end points better
    by more than one standard error; for the gain also
    :func:`gain_estimate_pays`). The nested leave-one-out repeats both
    stages without the run it scores.

    Needs a :class:`~morpi_filters.field.FieldData`, so there is no example.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    train : (str, str) or field.TrainSet
        Phone and route of the training set (its ``train`` folder is read,
        every run scored against the route), or a train set of a manifest
        dataset (:meth:`~morpi_filters.field.FieldData.train_sets`: its runs,
        each scored against its own end point and distance).
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
    DataError
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
    from .field import TrainSet

    # stage 1: every grid point with the trained gain taken as exact (its spread considered), with and without
    # the non-holonomic updates (their NIS is judged like the others': a point without them may be the
    # consistent one)
    cands = [c for c in _candidates() if c["gain_state"] == "considered"]
    plans, groups = [], {}                        # training set -> (inputs, tunings)
    for train, method, mode, config, gain in requests:
        if isinstance(train, TrainSet):
            # a manifest group's train runs, each with its own truth (those the filter cannot run are left out)
            runs, ends, dist = [], [], []
            for rec, end, d in zip(train.runs, train.end_point_m, train.distance_m):
                try:
                    runs.append(prepare(data, rec, mode, method, config, gain.mean))
                except MorpiError:
                    continue
                ends.append(end)
                dist.append(d)
            where = train.name
            ends, dist = np.array(ends, float).reshape(-1, 2), np.array(dist, float)
        else:
            runs = _prepared_runs(data, train[0], train[1], "train", mode, method, config, gain.mean)
            truth, where = ds.route(train[1]), f"{train[0]}/{train[1]}/train"
            ends = np.tile(np.asarray(truth.end_point_m, float), (len(runs), 1))
            dist = np.full(len(runs), float(truth.distance_m))
        if not runs:
            plans.append(DataError(f"{where}: no train run with steps for the aided filter"))
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
        plans.append((train, len(inputs), runs, (ends, dist), noise, rel))
        inputs += [r.input_for(c, forward_only=True) for c in cands for r in runs]
        tunings += [tuning_from(noise, c, rel) for c in cands for _ in runs]
    # one batch per training set (one batch of every set is slower: a larger working set for the same work)
    res = {train: aided.run_batch(inputs, tunings, workers=workers)
           for train, (inputs, tunings) in groups.items()}
    # the measurement types of the filter and the degrees of freedom of one update of each
    kinds, dof = _aided_kernel.KINDS, np.array(_aided_kernel.KIND_DOF)

    def score(mine, runs, truth):
        true_end, dist = truth                    # per run: its true end point and distance
        ends = [runs[i % len(runs)].end(r) for i, r in enumerate(mine)]
        d = np.array([e[0] - true_end[i % len(runs)] for i, e in enumerate(ends)])
        m2 = np.array([x @ np.linalg.solve(e[1], x) for x, e in zip(d, ends)]).reshape(-1, len(runs))
        err = np.linalg.norm(d, axis=1).reshape(-1, len(runs)) / dist * 100
        # each run's NIS sum and update count per measurement type, over its forward pass up to the read-out
        nis = np.array([[r.nis.get(k, (0.0, 0, 0))[:2] for k in kinds] for r in mine]).reshape(-1, len(runs),
                                                                                              len(kinds), 2)
        return err, m2 <= aided.CHI2_95_2DOF, nis[..., 0], nis[..., 1]

    # stage 2, at the point each selection (all runs, and each leave-one-out fold) picks: without the
    # non-holonomic updates, and with the gain estimated (with and without them)
    variants = [{"nhc": False}, {"gain_state": "estimated"}, {"nhc": False, "gain_state": "estimated"}]
    firsts, inputs, tunings = [], [], []
    for plan in plans:
        if isinstance(plan, MorpiError):
            firsts.append(None)
            continue
        train, start, runs, truth, noise, rel = plan
        err, inside, ns, nc = score(res[train][start:start + len(cands) * len(runs)], runs, truth)
        keep = np.ones(len(runs), bool)
        folds = [keep] + [np.arange(len(runs)) != i for i in range(len(runs))] if len(runs) > 1 else [keep]
        # the same rule in every selection: all runs, and each nested leave-one-out fold without its run
        picks = [choose_consistent(err[:, f], inside[:, f], ns[:, f], nc[:, f], dof)[0] for f in folds]
        wins = sorted(set(picks))
        firsts.append((err, inside, ns, nc, folds, picks, wins, len(inputs)))
        more = [dict(cands[w], **v) for w in wins for v in variants]
        inputs += [r.input_for(c, forward_only=True) for c in more for r in runs]
        tunings += [tuning_from(noise, c, rel) for c in more for _ in runs]
    res2 = aided.run_batch(inputs, tunings, workers=workers)
    out = []
    for plan, first in zip(plans, firsts):
        if isinstance(plan, MorpiError):
            out.append(plan)
            continue
        _, _, runs, truth, noise, rel = plan
        err, inside, ns, nc, folds, picks, wins, at = first
        mine = res2[at:at + len(wins) * len(variants) * len(runs)]
        err2, inside2, ns2, nc2 = score(mine, runs, truth)
        k_hat = np.array([r.gain_error for r in mine]).reshape(-1, len(runs))
        # each train run's own gain error: its step sum against the route (z = (1 + k) x the true displacement)
        true_end, dist = truth
        k_true = np.array([np.linalg.norm(np.diff(r.morpi_xy, axis=0), axis=1).sum() for r in runs]) / dist - 1.0
        # the grid point and its variants, each with its runs: error, coverage, NIS sums and counts
        arms = {("grid", w): (err[w], inside[w], ns[w], nc[w]) for w in wins}
        arms.update({("variant", j): (err2[j], inside2[j], ns2[j], nc2[j]) for j in range(err2.shape[0])})

        def rank(arm, f):
            e, ins, s_, c_ = arms[arm]
            short, out = _rank(ins[None, f], s_[None, f], c_[None, f], dof)
            return int(short[0]), int(out[0])

        chosen = []
        for f, w in zip(folds, picks):
            i = wins.index(w) * len(variants)
            no_nhc, est, est_no_nhc = ("variant", i), ("variant", i + 1), ("variant", i + 2)
            if _aid_pays(err[w, f], rank(("grid", w), f), err2[no_nhc[1], f], rank(no_nhc, f)):
                base, arm, g = cands[w], ("grid", w), est
            else:
                base, arm, g = dict(cands[w], nhc=False), no_nhc, est_no_nhc
            if _estimate_wins(arms[arm][0][f], rank(arm, f), err2[g[1], f], rank(g, f), k_hat[g[1], f], k_true[f]):
                base, arm = dict(base, gain_state="estimated"), g
            chosen.append((base, arm))
        info, arm = chosen[0]
        e_all, ins_all, s_all, c_all = arms[arm]
        short, out_n = rank(arm, folds[0])
        per_dof = _nis_per_dof(s_all[None], c_all[None], dof)[0]
        train_nis = {k: {"per_dof": float(q), "updates": int(c_all[:, j].sum()), "dof": int(dof[j])}
                     for j, (k, q) in enumerate(zip(kinds, per_dof)) if c_all[:, j].sum() > 0}
        outside = sorted(k for k, q in train_nis.items() if not NIS_BAND[0] <= q["per_dof"] <= NIS_BAND[1])
        # nested leave-one-out: each train run scored by the choice made without it
        loo = [arms[c[1]][0][i] for i, c in enumerate(chosen[1:])]
        # the folds whose choice is not consistent on their own runs
        loo_fallback = sum(rank(c[1], f) != (0, 0) for c, f in zip(chosen[1:], folds[1:]))
        morpi_m = np.array([np.linalg.norm(r.morpi_xy[-1] - e) for r, e in zip(runs, true_end)])
        # the mean error in per cent of the distance (one route's distance: the mean error over it)
        morpi = (float(np.mean(morpi_m) / dist[0] * 100) if np.all(dist == dist[0])
                 else float(np.mean(morpi_m / dist) * 100))
        out.append(TunableChoice(float(e_all.mean()), float(np.mean(loo)) if loo else float("nan"),
                                 morpi, info, noise, consistent=(short, out_n) == (0, 0), train_nis=train_nis,
                                 train_coverage=float(np.mean(ins_all)), outside=tuple(outside),
                                 loo_fallback=int(loo_fallback)))
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


def _nis_per_dof(nis_sum, nis_count, dof):
    """NIS per degree of freedom per candidate and measurement type, summed over the runs (axis 1); NaN
    where a type has no update."""
    total, count = np.asarray(nis_sum, float).sum(axis=1), np.asarray(nis_count, float).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / (count * np.asarray(dof, float)), np.nan)


def _rank(inside, nis_sum, nis_count, dof, band=NIS_BAND):
    """Per candidate, how far from consistent it is on these runs: (1 when its 95 % ellipse holds fewer
    than :data:`MIN_TRAIN_COVERAGE` of the true end points else 0, the number of measurement types whose
    NIS per dof lies outside `band`). ``(0, 0)`` is consistent; lower ranks are less inconsistent."""
    per_dof = _nis_per_dof(nis_sum, nis_count, dof)
    out = np.sum((per_dof < band[0]) | (per_dof > band[1]), axis=1)      # NaN (no update) is never outside
    short = (np.asarray(inside, float).mean(axis=1) < MIN_TRAIN_COVERAGE).astype(int)
    return short, out


def choose_consistent(err, inside, nis_sum, nis_count, dof, band=NIS_BAND) -> tuple[int, bool]:
    """The grid point of least mean train error among the consistent ones, else the least inconsistent.

    A candidate is consistent on the runs when its 95 % ellipse holds the
    true end point of at least :data:`MIN_TRAIN_COVERAGE` of them and, for
    every measurement type it updates with, the NIS summed over the runs'
    updates per degree of freedom (``sum NIS / (updates * dof)``) lies in
    `band` (:data:`NIS_BAND`, edges included). Among the consistent
    candidates the least mean error wins (:func:`morpi_filters.choice.choose`:
    the earliest within the tie tolerance). When none is consistent, the
    least inconsistent compete on the error: first those whose ellipse holds
    enough end points (all when none does), among them those with the fewest
    measurement types outside the band. A count of types, not a distance
    from the band: a type no candidate brings into the band (the rest
    updates, whose noise the grid does not move) then weighs the same on
    every candidate and the choice is made by the types the grid moves and
    by the error, not by the rounding of a distance all of them share.

    Parameters
    ----------
    err : array_like, shape (c, r)
        End-point error of each candidate on each run (any unit).
    inside : array_like of bool, shape (c, r)
        Whether the run's true end point lies inside the candidate's 95 % ellipse.
    nis_sum : array_like, shape (c, r, k)
        Sum of the NIS of each candidate's updates of each measurement type on each run.
    nis_count : array_like, shape (c, r, k)
        Number of those updates (a type without updates is not judged).
    dof : array_like, shape (k,)
        Degrees of freedom of one update of each type.
    band : (float, float)
        The consistent NIS per degree of freedom.

    Returns
    -------
    index : int
        The chosen candidate.
    consistent : bool
        Whether it is consistent (False: the least inconsistent).

    Examples
    --------
    Three candidates on two runs, one measurement type of 2 dof: the first
    has the least error but a NIS per dof of 0.01 (it expects innovations
    ten times the spread it sees); the third is consistent:

    >>> err = [[1.0, 1.0], [3.0, 3.0], [2.0, 2.0]]
    >>> inside = np.ones((3, 2), bool)
    >>> count = np.full((3, 2, 1), 50)
    >>> nis = count * 2 * np.array([0.01, 20.0, 0.9])[:, None, None]
    >>> choose_consistent(err, inside, nis, count, [2])
    (2, True)
    >>> nis[2] *= 10                                  # now none is consistent: each has one type outside,
    >>> choose_consistent(err, inside, nis, count, [2])       # and the least error of them wins
    (0, False)
    """
    score = np.asarray(err, float).mean(axis=1)
    short, out = _rank(inside, nis_sum, nis_count, dof, band)
    ok = (short == 0) & (out == 0)
    if ok.any():
        return choose(np.where(ok, score, np.inf)), True
    pool = short == short.min()
    pool &= out == out[pool].min()
    return choose(np.where(pool, score, np.inf)), False


def _aid_pays(err_with, rank_with, err_without, rank_without) -> bool:
    """Whether an aid (the non-holonomic updates) earns its place at the chosen point on the train runs.

    It stays when the filter with it is less inconsistent on the train runs
    (:func:`_rank`: its ellipse holds enough train end points and fewer
    measurement types leave :data:`NIS_BAND`; ``(0, 0)`` consistent), and
    goes when it is more; at the same rank, it stays when it improves the
    end points by more than one standard error of the paired per-run
    differences (the one-standard-error rule, for the simpler filter without it).
    """
    if tuple(rank_with) != tuple(rank_without):
        return tuple(rank_with) < tuple(rank_without)
    d = np.asarray(err_without) - np.asarray(err_with)
    if d.size < 2:
        return False
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


def _estimate_wins(err, rank, err_e, rank_e, k_hat, k_true) -> bool:
    """Whether estimating the gain at the chosen point replaces taking it as exact.

    Only when the estimate's ellipse still holds enough train end points and
    it is no less consistent than the filter taking the gain as exact
    (:func:`_rank`), the estimates explain the runs' gain errors
    (:func:`gain_estimate_pays`) and the end points improve by more than one
    standard error of the paired per-run differences (the one-standard-error rule).
    """
    d = np.asarray(err) - np.asarray(err_e)
    if d.size < 2 or rank_e[0] or tuple(rank_e) > tuple(rank) or not gain_estimate_pays(k_hat, k_true):
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
    p_holm : float
        :attr:`p_value` adjusted by Holm's step-down over a family of cells (:func:`holm`; NaN outside
        one).
    mdd_pp : float
        The smallest true mean difference the test detects with probability :attr:`power` at
        :attr:`alpha`, with these runs and their spread (:func:`detectable_difference`) [pp].
    power : float
        The power of :attr:`mdd_pp`.
    """

    mean_pp: float
    se_pp: float
    runs: int
    p_value: float
    alpha: float = ALPHA
    p_holm: float = float("nan")
    mdd_pp: float = float("nan")
    power: float = POWER

    @property
    def verdict(self) -> str:
        """``"better"`` or ``"worse"`` where the test rejects a zero difference at :attr:`alpha`, else ``"tie"``."""
        if not self.p_value < self.alpha:
            return "tie"
        return "better" if self.mean_pp < 0 else "worse"

    @property
    def verdict_holm(self) -> str:
        """:attr:`verdict` with the Holm-adjusted p-value (:attr:`p_holm`); ``"tie"`` outside a family."""
        if not self.p_holm < self.alpha:
            return "tie"
        return "better" if self.mean_pp < 0 else "worse"


def paired_difference(errors_m, reference_m, distance_m: float, *, alpha: float = ALPHA) -> PairedDifference:
    """Compare two methods' end-point errors run by run (paired t-test).

    With ten or so test runs per cell, a mean difference of a few tenths of a
    per cent is often within the runs' own spread; the test says which
    differences the runs support, and :attr:`PairedDifference.mdd_pp` how
    large a difference they could have shown (a tie is no equivalence).

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
        Outside a family of cells (:attr:`PairedDifference.p_holm` NaN).

    Raises
    ------
    ParameterError
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
        raise ParameterError(f"paired_difference: errors of shapes {a.shape} and {b.shape}, expected two (n,) arrays")
    if not (np.isfinite(distance_m) and distance_m > 0):
        raise ParameterError(f"distance_m={distance_m!r}: expected a positive route distance [m]")
    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    ok = np.isfinite(a) & np.isfinite(b)
    d = (a[ok] - b[ok]) / distance_m * 100
    n = int(d.size)
    if n < 2:
        return PairedDifference(float(d.mean()) if n else float("nan"), float("nan"), n, float("nan"), alpha)
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    se = sd / np.sqrt(n)
    if se > 0:
        from scipy import stats

        p = float(2 * stats.t.sf(abs(mean) / se, n - 1))
    else:
        p = 1.0 if mean == 0 else 0.0
    return PairedDifference(mean, se, n, p, alpha, mdd_pp=detectable_difference(sd, n, alpha=alpha))


def holm(p_values, alpha: float = ALPHA):
    """Holm's step-down correction of a family of tests.

    The ``m`` finite p-values sorted ascending, the i-th (from 0) is
    multiplied by ``m - i``; each adjusted value is the running maximum of
    these products (capped at 1), so the order of the p-values is kept. A
    test is rejected where its adjusted value is below `alpha`: the chance of
    any false rejection in the family stays at most `alpha`.

    Parameters
    ----------
    p_values : array_like, shape (m,)
        The family's p-values; NaN (no test) is left out of the family.
    alpha : float
        Family-wise level, in (0, 1).

    Returns
    -------
    adjusted : ndarray, shape (m,)
        Adjusted p-values (NaN where the input is NaN).
    reject : ndarray of bool, shape (m,)
        ``adjusted < alpha``.

    Raises
    ------
    ParameterError
        For `alpha` outside (0, 1) or p-values outside [0, 1].

    Examples
    --------
    Four tests: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, and 0.04 x 1
    raised to the 0.06 before it:

    >>> adj, rej = holm([0.01, 0.04, 0.03, 0.005])
    >>> adj.round(12).tolist(), rej.tolist()
    ([0.03, 0.06, 0.06, 0.02], [True, False, False, True])
    """
    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    p = np.asarray(p_values, dtype=float).ravel()
    ok = np.flatnonzero(np.isfinite(p))
    if np.any((p[ok] < 0) | (p[ok] > 1)):
        raise ParameterError(f"holm: p-values {p.tolist()}: expected values in [0, 1] (or NaN)")
    adj = np.full(p.shape, np.nan)
    run = 0.0
    for i, j in enumerate(ok[np.argsort(p[ok], kind="stable")]):
        run = max(run, min(1.0, (ok.size - i) * p[j]))
        adj[j] = run
    with np.errstate(invalid="ignore"):
        return adj, adj < alpha


def detectable_difference(sd: float, runs: int, *, alpha: float = ALPHA, power: float = POWER) -> float:
    """The smallest true mean difference a two-sided paired t-test detects with probability `power`.

    With ``runs`` paired differences of standard deviation `sd`, the t
    statistic of a true mean difference ``delta`` follows the noncentral t
    distribution with ``runs - 1`` degrees of freedom and noncentrality
    ``delta sqrt(runs) / sd`` (scipy.stats.nct); the returned ``delta`` is
    the one whose rejection probability at `alpha` is `power`. Smaller true
    differences may well end in a tie: a tie says no more than this.

    Parameters
    ----------
    sd : float
        Standard deviation of the paired differences (any unit; the result is in it).
    runs : int
        Number of pairs.
    alpha : float
        Two-sided level, in (0, 1).
    power : float
        Wanted probability of detection, in (alpha, 1).

    Returns
    -------
    float
        The difference, in the unit of `sd`; NaN below two runs, 0 for ``sd == 0``.

    Raises
    ------
    ParameterError
        For `alpha`, `power` or `sd` out of range.

    Examples
    --------
    Ten pairs of unit spread (near the rule of thumb ``(t_0.975 + t_0.8) / sqrt(10) = 0.995``):

    >>> round(detectable_difference(1.0, 10), 3)
    0.996
    """
    from scipy import optimize, stats

    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    if not alpha < power < 1:
        raise ParameterError(f"power={power!r}: expected a probability in (alpha, 1)")
    if not (np.isfinite(sd) and sd >= 0):
        raise ParameterError(f"sd={sd!r}: expected a finite standard deviation >= 0")
    if runs < 2:
        return float("nan")
    if sd == 0:
        return 0.0
    df = runs - 1
    se = sd / np.sqrt(runs)
    tc = stats.t.ppf(1 - alpha / 2, df)

    def gap(delta):
        nc = delta / se
        return stats.nct.sf(tc, df, nc) + stats.nct.cdf(-tc, df, nc) - power

    hi = (tc + stats.norm.ppf(power)) * se
    while gap(hi) <= 0:
        hi *= 2
    return float(optimize.brentq(gap, 0.0, hi, xtol=1e-12 * se, rtol=1e-12))


def steps_alone(inp: aided.AidedInput) -> np.ndarray:
    """Where the filter's own step vectors lead without the INS: their sum [m].

    The steps the filter updates with (:func:`aided.applied_steps`: the same
    lengths and directions), summed from the filter's start (the origin):
    dead reckoning with the filter's step direction. What the INS adds is
    the difference between the filter and this.

    Parameters
    ----------
    inp : aided.AidedInput
        The filter's input; its step directions are
        :attr:`aided.AidedInput.step_vector`.

    Returns
    -------
    ndarray, shape (2,)
        The end point [m]; NaN without step vectors (the filter reads its own attitude).

    Examples
    --------
    >>> t = np.arange(31) * 0.1
    >>> inp = aided.AidedInput(time=t, f=np.zeros((31, 3)), omega=np.zeros((31, 3)), C0=np.eye(3), g=9.8,
    ...                        step_start=np.array([0.0, 1.0, 2.0]), step_end=np.array([1.0, 2.0, 3.0]),
    ...                        step_length=np.array([0.5, 0.5, np.nan]),
    ...                        step_vector=np.array([[0.5, 0.0], [0.0, 0.5], [9.0, 9.0]]))
    >>> steps_alone(inp).tolist()          # the third step has no length: the filter does not use it
    [0.5, 0.5]
    """
    if inp.step_vector is None:
        return np.full(2, np.nan)
    v = np.asarray(inp.step_vector, float)[aided.applied_steps(inp)]
    return v.sum(axis=0) if v.size else np.zeros(2)


def ellipse_coverage(errors_xy, P_xy, along) -> dict:
    """How often the true end points lie inside the filter's 95 % regions: the ellipse and each axis.

    Parameters
    ----------
    errors_xy : array_like, shape (r, 2)
        Estimated minus true end points [m].
    P_xy : array_like, shape (r, 2, 2)
        Their covariances [m^2].
    along : array_like, shape (2,)
        Direction of the along-track axis (the route's start to its end); the
        cross-track axis is to its left.

    Returns
    -------
    dict
        ``runs``; ``inside_95``: share inside the 95 % ellipse (squared
        Mahalanobis distance at most the 2-dof chi-square point
        :data:`aided.CHI2_95_2DOF`); ``along_95``, ``cross_95``: share inside
        each axis' 95 % interval (``|e| <= 1.96 sigma`` of that axis'
        variance ``u^T P u``). NaN shares without runs.

    Raises
    ------
    ParameterError
        For mismatched shapes or a zero `along`.

    Examples
    --------
    Two end points with a unit covariance: one 1 m ahead (inside), one 2.5 m
    to the left (outside the ellipse, 2.5^2 > 5.99, and the cross-track interval):

    >>> cov = ellipse_coverage([[1.0, 0.0], [0.0, 2.5]], [np.eye(2), np.eye(2)], [2.0, 0.0])
    >>> cov["inside_95"], cov["along_95"], cov["cross_95"]
    (0.5, 1.0, 0.5)
    """
    e = np.asarray(errors_xy, dtype=float).reshape(-1, 2)
    P = np.asarray(P_xy, dtype=float).reshape(-1, 2, 2)
    if e.shape[0] != P.shape[0]:
        raise ParameterError(f"ellipse_coverage: {e.shape[0]} errors and {P.shape[0]} covariances; expected one each")
    u = np.asarray(along, dtype=float)
    if u.shape != (2,) or not np.linalg.norm(u) > 0:
        raise ParameterError(f"ellipse_coverage: along={u.tolist()}: expected a non-zero 2-vector")
    u = u / np.linalg.norm(u)
    c = np.array([-u[1], u[0]])
    if not e.shape[0]:
        return {"runs": 0, "inside_95": float("nan"), "along_95": float("nan"), "cross_95": float("nan")}
    m2 = np.einsum("ri,ri->r", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])

    def axis(w):
        return float(np.mean(np.abs(e @ w) <= Z_95 * np.sqrt(np.einsum("i,rij,j->r", w, P, w))))

    return {"runs": int(e.shape[0]), "inside_95": float(np.mean(m2 <= aided.CHI2_95_2DOF)),
            "along_95": axis(u), "cross_95": axis(c)}


def nis_consistency(total: float, updates: int, dof: int, confidence: float = 0.95) -> dict:
    """The normalized innovation squared of some updates per degree of freedom, and the band it keeps.

    For a consistent filter the sum of ``updates`` NIS values, each of
    `dof` degrees of freedom, is chi-square with ``updates * dof`` degrees
    of freedom (:func:`morpi_filters.eskf.chi2_band`, from scipy.stats.chi2);
    divided by ``updates * dof``, its two-sided band at `confidence`.

    Parameters
    ----------
    total : float
        Sum of the NIS values.
    updates : int
        Number of updates.
    dof : int
        Degrees of freedom of one update (the measurement's size).
    confidence : float
        Probability inside the band.

    Returns
    -------
    dict
        ``per_dof`` (``total / (updates * dof)``; NaN without updates),
        ``band`` (``[lo, hi]``, NaN without updates) and ``updates``.

    Examples
    --------
    >>> out = nis_consistency(190.0, 100, 2)
    >>> out["per_dof"], [round(float(v), 3) for v in out["band"]]
    (0.95, [0.814, 1.205])
    """
    from .eskf import chi2_band

    if updates < 1 or dof < 1:
        return {"per_dof": float("nan"), "band": [float("nan"), float("nan")], "updates": int(updates)}
    lo, hi = chi2_band(dof, updates, confidence)
    return {"per_dof": float(total) / (updates * dof), "band": [float(lo) / dof, float(hi) / dof],
            "updates": int(updates)}


def aid_used(name: str, tuning: aided.AidTuning) -> bool:
    """Whether a filter with `tuning` uses the aid of the ablation named `name` (:data:`ABLATIONS`).

    The steps, the non-holonomic and the rest updates where they run; the gain
    state where it is estimated (a considered gain changes the covariance,
    not the estimate); the smoother always (the cells read it).

    Parameters
    ----------
    name : str
        A key of :data:`ABLATIONS`.
    tuning : aided.AidTuning
        The chosen filter's tunables.

    Returns
    -------
    bool

    Raises
    ------
    ParameterError
        For a name that is not an ablation.

    Examples
    --------
    >>> t = aided.AidTuning(nhc=False, gain_estimated=False)
    >>> [n for n in ABLATIONS if aid_used(n, t)]
    ['steps', 'rest updates', 'smoothing']
    """
    if name not in ABLATIONS:
        raise ParameterError(f"aid_used: name={name!r}: expected one of {sorted(ABLATIONS)}")
    return {"steps": tuning.steps, "non-holonomic": tuning.nhc, "rest updates": tuning.rest,
            "gain state": tuning.gain_estimated and tuning.gain_sigma > 0, "smoothing": True}[name]


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
    consistent : bool
        Whether the chosen filter is consistent on the train runs (:func:`choose_consistent`: its 95 %
        ellipse holds at least :data:`MIN_TRAIN_COVERAGE` of the true end points and every measurement
        type's NIS per dof lies in :data:`NIS_BAND`); False: no grid point was, the least inconsistent won.
    train_nis : dict
        Measurement type -> ``{per_dof, updates, dof}``: the chosen filter's NIS on the train runs' forward
        passes up to the read-out.
    train_coverage : float
        Share of the train runs whose true end point lies inside its forward 95 % ellipse.
    outside : tuple of str
        The measurement types whose train NIS per dof lies outside :data:`NIS_BAND`.
    loo_fallback : int
        Nested leave-one-out folds whose choice was not consistent on the fold's runs.
    """

    score_percent: float
    loo_percent: float
    morpi_percent: float
    info: dict
    noise: tuple
    consistent: bool = True
    train_nis: dict = field(default_factory=dict)
    train_coverage: float = float("nan")
    outside: tuple = ()
    loo_fallback: int = 0


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
        ``steps_m`` and ``steps_alone_m``, the same: :func:`steps_alone`), ``mahalanobis2`` and
        ``inside_95`` of the true end point under the forward covariance, ``mahalanobis2_smoothed`` and
        ``inside_95_smoothed`` under the smoothed one, estimated gain error and its sigma.
    tuning : dict
        The grid point chosen on the train runs, and the noise densities used.
    train_percent : float
        Its mean train end-point error [%].
    train_loo_percent : float
        The same with the tunables chosen in a nested leave-one-out over the train runs [%].
    train_morpi_percent : float
        MoRPI alone on those train runs [%].
    nis : dict
        Measurement name -> (mean NIS per update, dof, updates), over the whole forward pass of every run.
    paths : tuple
        Per run, up to the epoch where the end point is read (``Prepared.stop_s``): (epoch time,
        forward xy, smoothed xy, MoRPI xy, forward P_xy) for figures.
    failed : tuple of str
        Runs of the tables' cell the filter could not run, one line each.
    steps_percent : float
        :attr:`steps_alone_percent` (the name of an earlier contract).
    step_innovation : dict
        The forward filter's step updates over the runs, up to the read-out
        (:func:`aided.step_innovation_components`): ``updates``, the measured
        step minus the INS's displacement since the last boundary along the
        step (``along_mean_m``, ``along_rms_m``; positive: the INS fell
        short) and across it (``cross_mean_m``, ``cross_rms_m``) [m], and the
        median spread the filter expected along the step
        (``predicted_along_sigma_m``) [m]; empty without step updates.
    paired : PairedDifference or None
        The smoothed filter minus MoRPI alone, run by run (:func:`paired_difference`; Holm-adjusted over
        the study's cells of its calibration).
    steps_alone_percent : float
        The filter's own step vectors summed without the INS (:func:`steps_alone`: the same lengths and
        directions the filter is fed; NaN when the direction is the filter's attitude) [%].
    paired_steps : PairedDifference or None
        The smoothed filter minus its steps alone, run by run: what the INS adds (negative: it helps).
    coverage_95, coverage_95_forward : float
        Share of the runs whose true end point lies inside the 95 % ellipse of the smoothed estimate
        (smoothed covariance) and of the forward one (forward covariance).
    coverage_axes : dict
        ``{"smoothed": {...}, "forward": {...}}``, each :func:`ellipse_coverage` (the ellipse and the
        along- and cross-track axes apart).
    cross_zero_by_construction : bool
        Every step vector of every run lies along the route's start-to-end line: the steps put no
        cross-track displacement, so the cross-track estimate is the INS's alone (near zero under a
        loose INS) and the ellipse tests the along-track axis.
    morpi_best_percent : float
        MoRPI alone (the same steps, Weinberg lengths, trained gain, method and calibration) under its best
        train-chosen heading reading (:func:`choose_reading`: the rule's own or the route's heading) and
        step length (:func:`choose_length`: the Weinberg length or the period count) [%];
        per run ``morpi_best_m`` in :attr:`runs`.
    morpi_reading : str
        That reading (:attr:`ReadingChoice.reading`).
    morpi_length : str
        Its step length (:attr:`LengthChoice.length`, chosen for the training phone and method).
    period_count_percent : float
        MoRPI alone with the period count (:func:`period_sums`, the half-period length
        :func:`period_length` of the training phone, method and calibration) and the chosen reading [%];
        per run ``period_count_m``.
    paired_best : PairedDifference or None
        The smoothed filter minus :attr:`morpi_best_percent`'s MoRPI alone, run by run (Holm-adjusted over
        the study's cells of its calibration).
    train_consistency : dict
        The chosen tunables on the train runs (:class:`TunableChoice`): ``consistent`` (every measurement
        type's NIS per dof in :data:`NIS_BAND` and the 95 % ellipse holding at least
        :data:`MIN_TRAIN_COVERAGE` of the end points; False: the least inconsistent grid point),
        ``nis`` (type -> ``{per_dof, updates, dof}``, the forward passes up to the read-out),
        ``coverage_95`` (forward ellipse), ``outside`` (the types outside the band) and ``loo_fallback``
        (nested leave-one-out folds whose choice was not consistent).
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
    steps_alone_percent: float = float("nan")
    paired_steps: PairedDifference | None = None
    coverage_95: float = float("nan")
    coverage_95_forward: float = float("nan")
    coverage_axes: dict = field(default_factory=dict)
    cross_zero_by_construction: bool = False
    morpi_best_percent: float = float("nan")
    morpi_reading: str = ""
    paired_best: PairedDifference | None = None
    morpi_length: str = ""
    period_count_percent: float = float("nan")
    train_consistency: dict = field(default_factory=dict)

    @property
    def label(self) -> str:
        return self.spec.label


@dataclass(frozen=True)
class AidedStudy:
    """Every MoRPI cell, the ablation on the GC cells, the field coverage, NIS and significance.

    Attributes
    ----------
    cells : tuple of AidedCell
    ablation : tuple of dict
        Per GC cell and aid of :data:`ABLATIONS`: ``cell``, ``removed``, ``used`` (:func:`aid_used`),
        the filter without the aid read smoothed (``smoothed_percent``) and forward
        (``forward_percent``), the filter it is compared with read the same two ways
        (``full_percent``, ``full_forward_percent``) and where both start (``start``: ``"rest window"``,
        the cells' filter; ``"motion onset"`` for the rest updates). An aid not used is not run: its
        values are the full filter's, its effect exactly zero. Without smoothing both read-outs are
        the forward filter's.
    coverage_95, coverage_95_forward : float
        Share of the GC cells' test runs, each (run, method) once, whose true end point is inside the
        smoothed (forward) filter's 95 % ellipse.
    nis : dict
        Measurement name -> (mean NIS per update, dof, updates) over the same runs.
    note : str
        Why the study is empty, when it is.
    coverage : dict
        ``{"smoothed": ..., "forward": ...}``: ``runs`` and the shares of :func:`ellipse_coverage` over
        the same runs (each run's axes those of its route).
    significance : dict
        The paired tests over the GC cells (``family``), Holm-corrected (``correction``): for the
        smoothed filter against MoRPI alone ``wins_uncorrected``, ``wins_corrected``,
        ``losses_uncorrected``, ``losses_corrected``, ``ties_corrected``; the same against its own steps
        alone under ``vs_steps_alone``, against MoRPI alone under its best train-chosen reading under
        ``vs_morpi_best``; ``alpha``, ``power`` (of the smallest detectable differences).
    readings : tuple of ReadingChoice
        MoRPI alone's train-chosen heading reading per method (:func:`choose_reading`).
    lengths : tuple of LengthChoice
        Its train-chosen step length per training phone and method (:func:`choose_length`).
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
    coverage_95_forward: float = float("nan")
    coverage: dict = field(default_factory=dict)
    significance: dict = field(default_factory=dict)
    readings: tuple = ()
    lengths: tuple = ()
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


def _merge_nis(acc, nis):
    for name, (s, c, dof) in nis.items():
        a = acc.setdefault(name, [0.0, 0, dof])
        a[0] += s
        a[1] += c


def _nis_means(acc) -> dict:
    return {k: (v[0] / max(v[1], 1), v[2], v[1]) for k, v in acc.items()}


def _family(cells, key) -> dict:
    """Holm over the cells' paired differences `key` (``paired`` or ``paired_steps``): the cells with
    the adjusted p-values, and the counts of wins, losses and ties before and after the correction."""
    pairs = [getattr(c, key) for c in cells]
    adj, _ = holm([np.nan if d is None else d.p_value for d in pairs])
    pairs = [None if d is None else replace(d, p_holm=float(a)) for d, a in zip(pairs, adj)]
    tested = [d for d in pairs if d is not None]
    count = lambda attr, v: sum(getattr(d, attr) == v for d in tested)  # noqa: E731
    summary = {"cells": len(tested), "wins_uncorrected": count("verdict", "better"),
               "wins_corrected": count("verdict_holm", "better"),
               "losses_uncorrected": count("verdict", "worse"), "losses_corrected": count("verdict_holm", "worse"),
               "ties_corrected": count("verdict_holm", "tie")}
    return pairs, summary


def _ablation_row(label, name, used, full, without=None, start="rest window") -> dict:
    """One ablation row: the filter without the aid against the full filter, both read smoothed and
    forward. An aid not used takes the full filter's values (it is not run: the effect is zero)."""
    sm, fw = full
    if without is None:
        if used and name != "smoothing":
            raise ParameterError(f"ablation of {label!r}: {name!r} is used but was not run")
        # not used: the same filter; without smoothing: the forward read-out for both columns
        without = (fw, fw) if name == "smoothing" else (sm, fw)
    return {"cell": label, "removed": name, "smoothed_percent": float(without[0]),
            "forward_percent": float(without[1]), "used": bool(used), "full_percent": float(sm),
            "full_forward_percent": float(fw), "start": start}


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
        Also run the GC cells with each aid they use removed in turn.
    workers : int, optional
        Threads that run the filter (:func:`morpi_filters.aided.run_batch`;
        default: the cores this process may use). The results do not depend on it.

    Returns
    -------
    AidedStudy
        The cells in the tables' order, the ablation rows (GC cells only, when
        `ablation`), the 95 % coverage and the NIS per measurement over the GC
        cells' test runs, the paired tests Holm-corrected over the GC cells;
        empty with a ``note`` when no cell qualifies.
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
    # MoRPI alone's best train-chosen heading reading per method: the baseline the filter is also tested against
    readings = {m: choose_reading(data, m, res.selections[m].config) for m in sorted({c.spec.method for c in wanted})}
    # and its step length per training phone and method (the Weinberg length or the period count), the period
    # count's half-period length per phone, method and calibration
    lengths = {(ph, m): choose_length(data, ph, m, res.selections[m].config, readings[m].reading)
               for ph, m in sorted({(c.spec.train[0], c.spec.method) for c in wanted})}
    halves = {(ph, m, cal): period_length(data, ph, cal, m, res.selections[m].config, readings[m].reading)
              for ph, m, cal in sorted({(c.spec.train[0], c.spec.method, c.spec.calibration) for c in wanted})}
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
    # one pass per route: every cell's test runs (smoothed, with the smoothed covariance) and, for the GC
    # cells, the filter with each aid it uses removed in turn (smoothed: both read-outs), the rest updates
    # removed from a filter started at the motion onset, beside that filter with them
    results, abl_res = {}, {}
    for route in sorted({c.spec.route for c, *_ in todo}):
        items, abl_items = [], []
        for i, (cell, g, score, info, noise, runs, by_file, _, _) in enumerate(todo):
            if cell.spec.route != route:
                continue
            base = tuning_from(noise, info, g.std / g.mean)
            items += [(i, p, None, base, p.input_for(info)) for p in runs]
            if ablation and cell.spec.calibration == "GC":
                for name, change in ABLATIONS.items():
                    if not change or not aid_used(name, base):
                        continue
                    if name == "rest updates":
                        abl_items += [(i, p, (name, "with"), base, p.onset_input(info)) for p in runs]
                        abl_items += [(i, p, (name, "without"), base.with_(**change), p.onset_input(info))
                                      for p in runs]
                    else:
                        abl_items += [(i, p, (name, "without"), base.with_(**change), p.input_for(info))
                                      for p in runs]
        out = aided.run_batch([q[4] for q in items], [q[3] for q in items], smooth=True, smoothed_covariance=True,
                              innovations=True, workers=workers)
        for (i, p, *_), r in zip(items, out):
            results[(i, p.rel)] = r
        out = aided.run_batch([q[4] for q in abl_items], [q[3] for q in abl_items], smooth=True,
                              smoothed_covariance=False, nis=False, workers=workers) if abl_items else []
        for (i, p, name, *_), r in zip(abl_items, out):
            abl_res[(i, p.rel, name)] = r
    cells, abl = [], []
    for i, (cell, g, score, info, noise, runs, by_file, choice, failed) in enumerate(todo):
        sp = cell.spec
        truth = ds.route(sp.route)
        d = truth.distance_m / 100
        end = np.asarray(truth.end_point_m, float)
        along = end / np.linalg.norm(end)
        rows, paths, nis, innov = [], [], {}, []
        err_sm, P_sm, err_fw, P_fw = [], [], [], []
        cross_free = info["step_heading"] == "route"
        for p in runs:
            r = results[(i, p.rel)]
            j = r.index_at(p.stop_s)
            if "step" in r.innovations:
                # the step updates up to the read-out epoch (after it the phone may be handled)
                inn = r.innovations["step"]
                k = int(np.searchsorted(inn.time, r.time[j], side="right"))
                innov.append([c[:k] for c in aided.step_innovation_components(inn)])
            rec = next(x for x in data.recordings(sp.phone, sp.route, sp.split) if data.relpath(x) == p.rel)
            try:
                ins = np.asarray(data.ins(rec, sp.calibration, "INS-3D").position)[-1, :2]
                ins_m = float(np.linalg.norm(ins - end))
            except MorpiError:
                ins_m = float("nan")
            end_xy, end_P, end_sm, end_Ps = r.position[j, :2], r.P_xy[j], r.smoothed[j, :2], r.P_xy_smoothed[j]
            dxy, dsm = end_xy - end, end_sm - end
            m2 = float(dxy @ np.linalg.solve(end_P, dxy))
            m2s = float(dsm @ np.linalg.solve(end_Ps, dsm))
            err_fw.append(dxy), P_fw.append(end_P), err_sm.append(dsm), P_sm.append(end_Ps)
            _merge_nis(nis, r.nis)
            inp = p.input_for(info)
            alone = steps_alone(inp) if info["step_heading"] == "route" else np.full(2, np.nan)
            morpi_m = float(by_file[p.rel].end_error_m)
            reading, rule = readings[sp.method].reading, res.selections[sp.method].config
            if reading == "route":
                u = route_sums(data, rec, sp.calibration, sp.method, rule)[1]
                best_m = float(np.linalg.norm(g.mean * u - end))
            else:
                best_m = morpi_m
            u = period_sums(data, rec, sp.calibration, sp.method, rule, reading)[1]
            period_m = float(np.linalg.norm(halves[(sp.train[0], sp.method, sp.calibration)] * u - end))
            if lengths[(sp.train[0], sp.method)].length == "period count":
                best_m = period_m
            alone_m = float(np.linalg.norm(alone - end))
            if cross_free:
                v = np.asarray(inp.step_vector, float)[aided.applied_steps(inp)]
                cross_free = bool(np.all(v @ np.array([-along[1], along[0]]) == 0.0))
            rows.append({"file": p.rel, "forward_m": float(np.linalg.norm(dxy)),
                         "smoothed_m": float(np.linalg.norm(dsm)),
                         "morpi_m": morpi_m, "morpi_best_m": best_m, "period_count_m": period_m, "ins_m": ins_m,
                         "mahalanobis2": m2, "inside_95": bool(m2 <= aided.CHI2_95_2DOF),
                         "mahalanobis2_smoothed": m2s, "inside_95_smoothed": bool(m2s <= aided.CHI2_95_2DOF),
                         "gain_error": r.gain_error, "gain_error_sigma": r.gain_sigma,
                         "steps_m": alone_m, "steps_alone_m": alone_m})
            # up to the read-out, where the end point is taken (after it the phone may be handled)
            paths.append((r.time[:j + 1], r.position[:j + 1, :2], r.smoothed[:j + 1, :2], p.morpi_xy,
                          r.P_xy[:j + 1]))
        mean = lambda k: float(np.nanmean([q[k] for q in rows]) / d)  # noqa: E731
        col = lambda k: [q[k] for q in rows]  # noqa: E731
        cov_sm, cov_fw = ellipse_coverage(err_sm, P_sm, along), ellipse_coverage(err_fw, P_fw, along)
        alone_pct = float(np.mean(col("steps_alone_m")) / d)
        cells.append(AidedCell(
            spec=sp, forward_percent=mean("forward_m"), smoothed_percent=mean("smoothed_m"),
            morpi_percent=mean("morpi_m"), ins_percent=mean("ins_m"), runs=tuple(rows),
            tuning={**info, "accel_noise": noise[0] * info["vibration"], "gyro_noise": noise[1] * info["vibration"],
                    "rest_accel_noise": noise[0], "rest_gyro_noise": noise[2], "gyro_walk": noise[3], "accel_jump": noise[4],
                    "gain_sigma": g.std / g.mean},
            train_percent=score, train_loo_percent=choice.loo_percent, train_morpi_percent=choice.morpi_percent,
            nis=_nis_means(nis), paths=tuple(paths), failed=failed,
            steps_percent=alone_pct, step_innovation=_innovation_summary(innov),
            paired=paired_difference(col("smoothed_m"), col("morpi_m"), truth.distance_m),
            steps_alone_percent=alone_pct,
            paired_steps=(paired_difference(col("smoothed_m"), col("steps_alone_m"), truth.distance_m)
                          if info["step_heading"] == "route" else None),
            coverage_95=cov_sm["inside_95"], coverage_95_forward=cov_fw["inside_95"],
            coverage_axes={"smoothed": cov_sm, "forward": cov_fw}, cross_zero_by_construction=cross_free,
            morpi_best_percent=mean("morpi_best_m"), morpi_reading=readings[sp.method].reading,
            morpi_length=lengths[(sp.train[0], sp.method)].length, period_count_percent=mean("period_count_m"),
            paired_best=paired_difference(col("smoothed_m"), col("morpi_best_m"), truth.distance_m),
            train_consistency={"consistent": choice.consistent, "nis": dict(choice.train_nis),
                               "coverage_95": choice.train_coverage, "outside": list(choice.outside),
                               "loo_fallback": choice.loo_fallback}))
        if ablation and sp.calibration == "GC":
            base = tuning_from(noise, info, g.std / g.mean)
            full = (cells[-1].smoothed_percent, cells[-1].forward_percent)

            def read(name, which):
                ends = [abl_res[(i, p.rel, (name, which))] for p in runs]
                sm = [np.linalg.norm(r.smoothed[r.index_at(p.stop_s), :2] - end) for p, r in zip(runs, ends)]
                fw = [np.linalg.norm(r.position[r.index_at(p.stop_s), :2] - end) for p, r in zip(runs, ends)]
                return float(np.mean(sm) / d), float(np.mean(fw) / d)

            for name, change in ABLATIONS.items():
                used = aid_used(name, base)
                if name == "rest updates" and used:
                    abl.append(_ablation_row(sp.label, name, used, read(name, "with"), read(name, "without"),
                                             start="motion onset"))
                else:
                    abl.append(_ablation_row(sp.label, name, used, full,
                                             read(name, "without") if used and change else None))
    # the paired tests, Holm-corrected over the GC cells (the RD cells: over theirs, apart)
    significance = {}
    for cal in ("GC", "RD", "GAC"):
        idx = [k for k, c in enumerate(cells) if c.spec.calibration == cal]
        if not idx:
            continue
        fam = [cells[k] for k in idx]
        vs_morpi, s_morpi = _family(fam, "paired")
        vs_steps, s_steps = _family(fam, "paired_steps")
        vs_best, s_best = _family(fam, "paired_best")
        for k, a, b, e in zip(idx, vs_morpi, vs_steps, vs_best):
            cells[k] = replace(cells[k], paired=a, paired_steps=b, paired_best=e)
        if cal == "GC":
            significance = {"family": "GC cells", "correction": "holm", "test": "two-sided paired t-test",
                            "alpha": ALPHA, "power": POWER, **s_morpi, "vs_steps_alone": s_steps,
                            "vs_morpi_best": s_best}
    # coverage and NIS over the GC cells' runs, each (run, method) once
    seen, per_run, nis_all = set(), {"smoothed": [], "forward": []}, {}
    for i, c in enumerate(cells):
        if c.spec.calibration != "GC":
            continue
        end = np.asarray(ds.route(c.spec.route).end_point_m, float)
        for p in todo[i][5]:
            if (p.rel, c.spec.method) in seen:
                continue
            seen.add((p.rel, c.spec.method))
            r = results[(i, p.rel)]
            j = r.index_at(p.stop_s)
            for which, xy, P in (("smoothed", r.smoothed[j, :2], r.P_xy_smoothed[j]),
                                 ("forward", r.position[j, :2], r.P_xy[j])):
                per_run[which].append(ellipse_coverage([xy - end], [P], end))
            _merge_nis(nis_all, r.nis)
    coverage = {which: {"runs": len(v), **{k: float(np.mean([q[k] for q in v]))
                                           for k in ("inside_95", "along_95", "cross_95")}}
                for which, v in per_run.items() if v}
    return AidedStudy(cells=tuple(cells), ablation=tuple(abl),
                      coverage_95=coverage.get("smoothed", {}).get("inside_95", float("nan")),
                      nis=_nis_means(nis_all),
                      coverage_95_forward=coverage.get("forward", {}).get("inside_95", float("nan")),
                      coverage=coverage, significance=significance, readings=tuple(readings.values()),
                      lengths=tuple(lengths.values()), no_rest=no_rest)
