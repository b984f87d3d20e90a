"""The detection thresholds the train runs set: the rest detection's accelerometer floor, the least heading swing
of a periodic run and the least turn (:func:`train_thresholds`), and those of a fold that holds one train run out
(:func:`fold_thresholds`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import steps as st
from ..calibration import NoRestError
from ..errors import MorpiError


#: The least heading swing of a periodic run is this fraction of the smallest swing of the train runs.
SWING_MARGIN = 0.75
#: A full period turns (the ``"turns"`` heading reading) when its heading change exceeds this multiple of
#: the largest full-period heading change of the straight train runs.
TURN_MARGIN = 1.5
#: The MoRPI methods, in the tables' order.
MORPI_METHODS = tuple(st.METHODS)
#: The step rule the rule search starts from (:func:`select_config`); the train thresholds measure the runs'
#: swings and turns under it.
SEARCH_START = st.StepConfig(heading="absolute", segment="maxima", ends="drop", cutoff_hz=2.0, prominence=0.35,
                             min_period_s=0.5)


@dataclass(frozen=True)
class Thresholds:
    """The detection thresholds the train runs set (:func:`train_thresholds`).

    Attributes
    ----------
    accel_floor : float
        Lowest accelerometer threshold of the rest detection [m/s^2]
        (:func:`morpi_filters.calibration.detect_rest`).
    min_swing_deg : float
        Least median heading swing per period of a periodic run [deg]
        (:attr:`morpi_filters.steps.StepConfig.min_swing_deg`).
    rest_std : tuple of float
        Per train run, the largest accelerometer moving standard deviation
        inside its gyro-only rest window [m/s^2].
    swings_deg : tuple of float
        Per train run, its median heading swing per period [deg].
    files : tuple of str
        The train runs, relative to the dataset root.
    turn_deg : float
        Least full-period heading change of a turn [deg]
        (:attr:`morpi_filters.steps.StepConfig.turn_deg`).
    period_changes_deg : tuple of float
        Per train run and method (MoRPI-A runs first, then MoRPI-G), its
        largest absolute full-period heading change [deg].
    rest_files, swing_files, change_files : tuple of str
        The train run of each value of `rest_std`, `swings_deg` and
        `period_changes_deg`.
    """

    accel_floor: float
    min_swing_deg: float
    rest_std: tuple = ()
    swings_deg: tuple = ()
    files: tuple = ()
    turn_deg: float = st.StepConfig().turn_deg
    period_changes_deg: tuple = ()
    rest_files: tuple = ()
    swing_files: tuple = ()
    change_files: tuple = ()


#: Used when a root has no train runs (no gains either, so no MoRPI cell): the library's defaults.
_DEFAULT_THRESHOLDS = Thresholds(accel_floor=0.1, min_swing_deg=st.StepConfig().min_swing_deg,
                                 turn_deg=st.StepConfig().turn_deg)


def train_accel_floor(data) -> tuple[float, tuple, tuple]:
    """The rest detection's accelerometer floor from the train runs, with the per-run values behind it.

    Each train run's rest is found on the gyro alone (accelerometer floor
    out of reach); inside it, the largest moving standard deviation of the
    accelerometer axes (over the detector's window) is what the settling of
    the phone's filtered accelerometer channels reaches at rest. The floor is
    ``k_std`` (the detector's threshold in noise sigmas) times the median of
    those values over the train runs.

    Parameters
    ----------
    data : FieldData
        The dataset; only its ``train`` recordings are read.

    Returns
    -------
    floor : float
        The accelerometer floor [m/s^2].
    rest_std, files : tuple
        Per train run with a gyro-only rest, its value [m/s^2] and its path.
    """
    vals, files = [], []
    for e in data.train_entries():
        r = data._entry_recording(e)
        if r is None:
            continue
        try:
            w = data.rest_window_at(r, 1e9)
        except MorpiError:
            continue
        vals.append(float(data.rest_measures(r).s_a[w.i0:w.i1].max()))
        files.append(e.relpath)
    return _floor_from(vals), tuple(vals), tuple(files)


def _floor_from(rest_std) -> float:
    """The accelerometer floor: ``k_std`` of the rest detection times the median of the runs' rest values."""
    import inspect

    from ..calibration import detect_rest

    if not len(rest_std):
        return _DEFAULT_THRESHOLDS.accel_floor
    return float(inspect.signature(detect_rest).parameters["k_std"].default * np.median(rest_std))


def train_thresholds(data) -> Thresholds:
    """The detection thresholds of the rest and of periodic motion, set on the train runs only.

    Rest detection
        The gyro thresholds are in noise sigmas measured on each recording
        (:func:`morpi_filters.calibration.detect_rest`: ``k_std``, ``k_dev``),
        and the motion window's threshold is a multiple of the gyro's level
        in the recording's own rest (:func:`morpi_filters.steps.activity_span`).
        The accelerometer's floor cannot be set from its white noise: the
        phones filter their accelerometer channels, which settle slowly
        after start-up. It is ``k_std`` times the median, over the train
        runs, of the largest accelerometer moving standard deviation inside
        each run's gyro-only rest window.
    Periodic motion
        Each train run's median heading swing per period is measured (GC,
        MoRPI-G signal, the search's start rule, no swing limit); the least
        swing of a periodic run is :data:`SWING_MARGIN` times the smallest
        of them, rounded down to a whole degree.
    Turns
        The train runs are all straight, so whatever heading change they show
        over one full period is not a turn: the drift over the period and
        the phase jitter of the step boundaries. Each train run's largest
        absolute full-period change (:func:`morpi_filters.steps.period_changes`;
        GC heading, the search's start rule with half-period steps between
        extrema, so that max-to-max and min-to-min periods are both seen,
        both methods' boundaries) is measured; the least turn is
        :data:`TURN_MARGIN` times the largest of them, rounded down to a
        whole degree.

    Only ``train`` folders are read; a root without them gets the library's
    defaults (0.1 m/s^2, 15 deg, 51 deg; it has no gains either).

    Parameters
    ----------
    data : FieldData
        The dataset root; its accelerometer floor is set as a side effect
        when it was not set before.

    Returns
    -------
    Thresholds
        The accelerometer floor [m/s^2], least heading swing [deg] and least
        turn [deg], with the per-run measurements they come from and the
        train files read.
    """
    floor, rest_std, files = train_accel_floor(data)
    data._accel_floor = floor if data._accel_floor is None else data._accel_floor
    swings, sfiles = [], []
    cfg = SEARCH_START.with_(min_swing_deg=0.0)
    for e in data.train_entries(periodic=True):
        for r in data.recordings(e.phone, e.route, e.split):
            if data.relpath(r) != e.relpath:
                continue
            try:
                sw = data.steps(r, "GC", "MoRPI-G", cfg).swing_deg
            except MorpiError:
                continue
            if np.isfinite(sw):
                swings.append(float(sw))
                sfiles.append(e.relpath)
    changes, cfiles = _train_period_changes(data)
    return _thresholds_from(data.accel_floor(), rest_std, files, swings, sfiles, changes, cfiles)


def _thresholds_from(floor, rest_std, rest_files, swings, swing_files, changes, change_files) -> Thresholds:
    """The thresholds the per-run measurements set (:func:`train_thresholds`)."""
    turn = float(np.floor(TURN_MARGIN * max(changes))) if changes else _DEFAULT_THRESHOLDS.turn_deg
    per_run = dict(rest_std=tuple(rest_std), rest_files=tuple(rest_files), turn_deg=turn,
                   period_changes_deg=tuple(changes), change_files=tuple(change_files))
    if not swings:
        return Thresholds(accel_floor=floor, min_swing_deg=_DEFAULT_THRESHOLDS.min_swing_deg,
                          files=tuple(rest_files), **per_run)
    return Thresholds(accel_floor=floor, min_swing_deg=float(np.floor(SWING_MARGIN * min(swings))),
                      swings_deg=tuple(swings), swing_files=tuple(swing_files),
                      files=tuple(sorted(set(rest_files) | set(swing_files) | set(change_files))), **per_run)


def fold_thresholds(data, held_out: str) -> tuple[Thresholds, bool]:
    """The thresholds the train runs set with one of them held out, and whether the rest windows stay.

    The per-run measurements of :func:`train_thresholds` are kept and the
    held-out run's are dropped, so the floor, the least swing and the least
    turn are what the remaining train runs set. The measurements themselves
    were taken under the full floor; when the fold's floor finds the same rest
    window in every remaining train run (then the motion windows, the
    calibrations and every step signal are the same too), they are exactly
    the fold's own.

    Parameters
    ----------
    data : FieldData
        The dataset root; only its ``train`` folders are read.
    held_out : str
        The train recording to leave out (path relative to the root).

    Returns
    -------
    thresholds : Thresholds
        The fold's thresholds.
    same_windows : bool
        True when the fold's floor finds the same rest window in every
        remaining train run (the thresholds are then exactly the fold's own;
        otherwise the fold needs its own :class:`FieldData`).
    """
    th = data.thresholds
    floor = _floor_from([v for v, f in zip(th.rest_std, th.rest_files) if f != held_out])
    keep = lambda vals, files: ([v for v, f in zip(vals, files) if f != held_out],
                                [f for f in files if f != held_out])
    fold = _thresholds_from(floor, *keep(th.rest_std, th.rest_files), *keep(th.swings_deg, th.swing_files),
                            *keep(th.period_changes_deg, th.change_files))
    same = True
    if floor != th.accel_floor:
        for e in data.train_entries():
            if e.relpath == held_out:
                continue
            r = data._entry_recording(e)
            if r is not None and data.problem(r) is None:
                w, w0 = (_window_or_error(data, r, f) for f in (floor, data.accel_floor()))
                if isinstance(w, MorpiError) or isinstance(w0, MorpiError):
                    # without a rest window under either floor: the same only when neither has a rest
                    same = same and isinstance(w, NoRestError) and isinstance(w0, NoRestError)
                    continue
                same = same and (w.i0, w.i1) == (w0.i0, w0.i1)
    return fold, same


def _window_or_error(data, rec, floor: float):
    """The recording's rest window under an accelerometer floor, or the detection's MorpiError."""
    try:
        return data.rest_window_at(rec, floor)
    except MorpiError as exc:
        return exc


def _train_period_changes(data) -> tuple[list, list]:
    """Per train run and method, the largest absolute full-period heading change [deg], and the runs' paths."""
    cfg = SEARCH_START.with_(segment="extrema", min_swing_deg=0.0)
    changes, files = [], []
    for m in MORPI_METHODS:
        for e in data.train_entries(periodic=True):
            for r in data.recordings(e.phone, e.route, e.split):
                if data.relpath(r) != e.relpath:
                    continue
                try:
                    s = data.steps(r, "GC", m, cfg)
                except MorpiError:
                    continue
                bt = s.peaks.grid_time[s.peaks.grid_index]
                c = st.period_changes(np.interp(bt, r.time, data.heading(r, "GC")), 2)
                if c.size:
                    changes.append(float(np.degrees(np.abs(c).max())))
                    files.append(e.relpath)
    return changes, files
