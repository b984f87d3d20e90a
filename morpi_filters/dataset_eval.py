"""The methods on a manifest dataset, each estimate held against the recording's truth.

:func:`evaluate` runs, on every recording of a
:class:`~morpi_filters.manifest.Dataset` (``morpi evaluate --dataset FILE``):

Methods
    ``"INS-3D"`` and ``"INS-2D"`` (:func:`~morpi_filters.strapdown.ins3d`,
    :func:`~morpi_filters.strapdown.ins2d`) from the recording's first sample
    to its last, on its own time steps, level start (identity attitude),
    gravity :attr:`morpi_filters.field.FieldData.gravity` (normal gravity at
    the manifest's ``latitude_deg``, :data:`morpi_filters.units.G0` without
    one); ``"MoRPI-A"`` and ``"MoRPI-G"``
    (the steps of :meth:`morpi_filters.field.FieldData.steps` over the
    dataset: motion window and heading as for the MoRPI recordings, the step
    rule chosen on this dataset's train recordings) only on
    ``motion = "periodic"``; ``"MoRPI-aided INS"``
    (:mod:`morpi_filters.aided`, as :mod:`morpi_filters.field_aided` runs it
    on the MoRPI cells) on the same recordings, read forward and smoothed
    (``estimate``), under every calibration the recording has: it starts
    at the rest window (GC and GAC need it, as for the other methods) or,
    with ``initial = "truth"``, at the first sample under way, where RD
    serves without a rest window. A recording without a rest window and
    with ``initial = "rest"`` has no start for it: it is left out with the
    reason.
Calibrations
    ``"RD"`` always; ``"GC"`` and ``"GAC"`` (:func:`~morpi_filters.calibration.calibrate`,
    the same gravity) when the recording has a rest window: ``rest = [t0, t1]``
    as given, ``"auto"`` as :func:`~morpi_filters.calibration.detect_rest`
    finds it with the trained accelerometer floor; ``"none"`` (or no rest
    found) gives RD only, listed in :attr:`DatasetEvaluation.left_out` with
    the reason.
Choices (train only)
    Every choice reads the ``train`` recordings only, through the functions
    of the MoRPI tables on a :class:`~morpi_filters.field.FieldData` over the
    dataset; no ``test`` recording is read for any. The train sets are the
    groups' train recordings with periodic motion (:meth:`~morpi_filters.field.FieldData.train_sets`),
    each run with its truth in the MoRPI estimate's frame: a route's end point
    and distance, or a truth track's displacement and path length over the
    run's motion window, turned by the track's course at the motion start.
    The detection thresholds are :func:`~morpi_filters.field.train_thresholds`.
    The step rule of each MoRPI method is :func:`~morpi_filters.field.select_config`
    for that method alone (as the tables' per-method rule), scored by the
    held-out end-point error of the train runs under GC, two ways:
    leave-one-recording-out (each run dead-reckoned with the mean gain of its
    group's other train runs) and leave-one-group-out (each run dead-reckoned
    with the mean gain of the train runs of the other groups). With two
    train groups or more the search scores by leave-one-group-out: the rule
    must serve runs whose gain none of their own group's runs set, as it does
    for a test run of a group without train recordings, and the score exists
    even when every group has a single train run; with one group, by
    leave-one-recording-out; the manifest's ``evaluation.held_out``
    (:class:`~morpi_filters.manifest.Settings`) can fix either. Both scores of
    the chosen rule are reported. A
    dataset whose train recordings give no score (none, or one run) falls
    back to :data:`morpi_filters.steps.DEFAULT_CONFIGS`, as ``choices`` says.
The aided filter (train only)
    Per group and calibration, for the step rule and gain of each MoRPI
    method, the tunables are :func:`~morpi_filters.field_aided.choose_tunables_many`
    on the group's train set (the gains' set), each run scored against its
    own truth; the train runs need their rest window (the noise densities
    are read there). The filter takes the steps of the MoRPI method whose
    tuned filter has the lower nested leave-one-out train error (the train
    error when a set has one run; :func:`morpi_filters.choice.choose`,
    MoRPI-A first on a tie); with ``evaluation.aided_methods = "each"`` one
    filter runs on each method's steps (:data:`AIDED_BY`).
    ``choices["aided"]`` lists every one. ``initial = "rest"``: the input of
    :func:`~morpi_filters.field_aided.prepare` (calibrated IMU from the rest
    window on, coarse-level attitude, the rest updates on the window and on
    the still stretches after the motion, zero velocity up to the motion's
    onset). ``initial = "truth"``: from the first sample, at the initial
    velocity below with a 1-sigma of ``v0_sigma_mps`` on each axis (the
    change of the truth velocity from the difference's span to the next one
    of the same length, at least :data:`V0_SIGMA_MIN`: how far the velocity
    moves over the track's own sampling), level attitude (roll and pitch of
    the rest window's specific force where there is one) and no rest update
    at the start (still stretches after the motion only). Both are read up to
    the last step boundary, where MoRPI's track ends. Per row also the NIS
    of each measurement type over the forward pass (per degree of freedom,
    with its 95 % chi-square band: :func:`~morpi_filters.field_aided.nis_consistency`)
    and ``coverage_95``: the share of the truth samples inside the estimate's
    time span that lie inside its 95 % horizontal ellipse (:data:`morpi_filters.aided.CHI2_95_2DOF`;
    the estimate and its covariance, forward or smoothed, interpolated
    linearly in time; a point counts inside when ``d^T adj(P) d <= chi2 det(P)``,
    which holds a zero error under a zero covariance); for a route, whose
    truth is its end point, whether the end point lies inside the last
    point's ellipse (1 or 0).
Gains (train only)
    The Weinberg gain of each group, method and calibration is
    :func:`~morpi_filters.field.set_gain` (:func:`~morpi_filters.steps.train_gain`,
    the function the MoRPI tables train with) over the group's train set
    under the chosen rule: the set of the recordings' ``train_group``, else
    the group's own, else (a group without train recordings) every train
    set's runs.
INS
    From the first sample, or with ``evaluation.ins_span = "motion"`` over
    the motion window of a recording that starts at rest
    (:meth:`~morpi_filters.field.FieldData.ins`, as the tables).
Initial state
    ``initial = "rest"``: velocity zero, heading zero (the navigation x axis
    is the body's heading at the first sample, as in the tables).
    ``initial = "truth"``: the velocity is the truth track's over the first
    moments (the difference of the truth positions one truth interval on
    each side of the recording's first sample, or after it where the track
    starts there), its direction the initial heading.
Alignment (the truth's frame)
    A route's frame is the navigation frame itself (origin at the start, x
    along the body's heading at the start). A truth track is in a local ENU
    frame: each estimate is turned by the truth's course and put, at its
    first time, on the truth's position at that time. The course is, for
    ``initial = "truth"``, the direction of the initial velocity above; for
    ``initial = "rest"``, the direction from the truth at the first sample to
    the first truth position ``course_m`` (default :data:`COURSE_M`) away
    horizontally.

Ablation (the aided filter)
    On every recording the group means read (the test recordings, or all
    without a test split) where the aided filter runs, per calibration, each
    aid of :data:`~morpi_filters.field_aided.ABLATIONS` is removed in turn
    from the chosen filter (its :class:`~morpi_filters.aided.AidTuning` with
    the ablation's change), both filters read forward and smoothed up to the
    same read-out time, with ``end_error_percent``, ``path_rmse_m`` and
    ``cross_track_rmse_m`` (:data:`ABLATION_METRICS`). As the MoRPI ablation
    (:func:`~morpi_filters.field_aided.aided_study`): an aid the filter does
    not use (:func:`~morpi_filters.field_aided.aid_used`) is not run, its
    values are the full filter's (an effect of exactly zero); without
    smoothing the smoothed read-out is the forward one; the rest updates are
    removed from the filter started at the motion onset (the input cut there:
    :meth:`~morpi_filters.field_aided.Prepared.onset_input`, or the same cut
    of a start from the truth, which keeps its initial velocity) and compared
    with that filter with them. :attr:`DatasetEvaluation.ablation` holds the
    group means, :attr:`DatasetEvaluation.ablation_runs` the recordings.

Metrics, per recording, method and calibration (horizontal, in metres)
    ``end_error_m`` (estimate's last point against the route's end point or
    the truth at the estimate's last time); ``end_error_percent`` (of the
    route's distance, or of the truth track's horizontal path length over the
    estimate's time span); ``path_rmse_m`` (the error at the truth samples
    inside the estimate's time span, the estimate interpolated linearly in
    time; None for route truth); ``cross_track_rmse_m`` (distance of the
    estimate's points, at the truth samples for a track, to the truth's
    polyline: the route's, its start to end point without one); and
    ``distance_error_percent`` (the estimate's horizontal path length minus
    the truth's, in percent of the truth's; for a track both sampled at the
    truth samples inside the span and the span's ends).
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields

import numpy as np

from . import aided
from . import field as fd
from . import field_aided as fa
from . import steps as st
from .choice import choose
from .errors import DataError, MorpiError, ParameterError
from .manifest import Dataset, RouteTruth, Settings, TruthTrack
from .strapdown import ins2d, ins3d

__all__ = ["COURSE_M", "AIDED", "AIDED_BY", "is_aided", "METHODS", "CALIBRATIONS", "ESTIMATES", "METRICS", "V0_SIGMA_MIN", "ROW_LABELS",
           "ABLATION_METRICS", "EstimatedPath", "AblationRun", "DatasetEvaluation", "path_metrics", "ellipse_share", "evaluate"]

#: Horizontal distance over which the truth's course gives the heading of a start at rest [m].
COURSE_M = 0.3
#: The aided filter's method name.
AIDED = "MoRPI-aided INS"
#: The aided filter driven by one MoRPI method's steps, by that method (``evaluation.aided_methods = "each"``).
AIDED_BY = {"MoRPI-A": "MoRPI-A-aided INS", "MoRPI-G": "MoRPI-G-aided INS"}
#: The methods, in the page's order (the aided filter per MoRPI method last).
METHODS = ("INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G", AIDED, *AIDED_BY.values())
#: The calibrations, in the page's order.
CALIBRATIONS = ("RD", "GC", "GAC")
#: The aided filter's read-outs (the ``estimate`` of its rows; None for the other methods).
ESTIMATES = ("forward", "smoothed")
#: Least 1-sigma of the aided filter's initial velocity from a truth track, per axis [m/s]: a
#: centimetre-level truth differenced over a tenth of a second.
V0_SIGMA_MIN = 0.01
#: The metrics of each estimate.
METRICS = ("end_error_m", "end_error_percent", "path_rmse_m", "cross_track_rmse_m", "distance_error_percent")
#: The metrics of the aided filter's ablation.
ABLATION_METRICS = ("end_error_percent", "path_rmse_m", "cross_track_rmse_m")


def is_aided(method: str) -> bool:
    """Whether `method` names the aided filter (:data:`AIDED` or one of :data:`AIDED_BY`)."""
    return method == AIDED or method in AIDED_BY.values()


@dataclass(frozen=True, eq=False)
class EstimatedPath:
    """One method's estimate of one recording, in the truth's frame, with its metrics.

    Attributes
    ----------
    id, split, group : str
        The recording's labels.
    method, calibration : str
        ``"INS-3D"`` ... ``"MoRPI-aided INS"``; ``"RD"``, ``"GC"`` or ``"GAC"``.
    time : ndarray, shape (k,)
        Times of the estimate's points on the IMU clock [s].
    xy : ndarray, shape (k, 2)
        Horizontal positions in the truth frame's first two axes [m].
    metrics : dict
        :data:`METRICS` -> float or None.
    estimate : str or None
        The aided filter's read-out, ``"forward"`` or ``"smoothed"``; None for the other methods.
    P_xy : ndarray, shape (k, 2, 2), or None
        The aided filter's horizontal covariance of `xy` in the truth's frame (the forward one for
        forward rows, the smoothed one for smoothed rows) [m^2].
    nis : dict or None
        The aided filter's forward pass: measurement name -> ``per_dof``, ``band``, ``updates`` and
        ``dof`` (:func:`~morpi_filters.field_aided.nis_consistency`).
    coverage_95 : float or None
        The share of the truth inside the 95 % ellipse (:func:`ellipse_share`).
    innovations : dict or None
        The forward pass's updates, measurement name -> :class:`morpi_filters.aided.Innovations`.
    """

    id: str
    split: str
    group: str
    method: str
    calibration: str
    time: np.ndarray
    xy: np.ndarray
    metrics: dict
    estimate: str | None = None
    P_xy: np.ndarray | None = None
    nis: dict | None = None
    coverage_95: float | None = None
    innovations: dict | None = None


@dataclass(frozen=True, eq=False)
class AblationRun:
    """One recording's aided filter with one aid removed, beside the filter it is compared with.

    Attributes
    ----------
    id, split, group, calibration : str
        The recording's labels and the calibration.
    method : str
        The aided filter's method name (:data:`AIDED`, or one of :data:`AIDED_BY`).
    removed : str
        A key of :data:`morpi_filters.field_aided.ABLATIONS`.
    used : bool
        Whether the chosen filter uses the aid (:func:`morpi_filters.field_aided.aid_used`); an aid
        not used is not run: :attr:`ablated` is :attr:`full`.
    estimate : str
        The read-out of both filters, ``"forward"`` or ``"smoothed"`` (``"smoothing"`` removed: the
        ablated filter is read forward).
    start : str
        Where both filters start: ``"rest window"`` or ``"first sample"`` (the full filter's start,
        as for ``initial = "rest"`` or ``"truth"``) or ``"motion onset"`` (the rest updates, removed
        from a filter started there and compared with that filter with them).
    start_s : float
        The first time of :attr:`full`, from the recording's first sample [s].
    full, ablated : EstimatedPath
        The compared filters' estimates with their metrics (without covariance); :attr:`full` is
        the aided filter's row of :attr:`DatasetEvaluation.paths` unless it starts at the motion onset.
    """

    id: str
    split: str
    group: str
    calibration: str
    removed: str
    used: bool
    estimate: str
    start: str
    start_s: float
    full: EstimatedPath
    ablated: EstimatedPath
    method: str = AIDED


@dataclass(frozen=True, eq=False)
class DatasetEvaluation:
    """What :func:`evaluate` found on a dataset.

    Attributes
    ----------
    name, source : str
        The dataset's name and manifest file.
    count : int
        Recordings in the dataset.
    paths : tuple of EstimatedPath
        In the manifest's order, then :data:`METHODS`, then :data:`CALIBRATIONS`, then
        :data:`ESTIMATES`.
    choices : dict
        Every train-only choice: ``rule`` (per MoRPI method, the step rule's
        fields, where it comes from and its train scores), ``held_out`` (the
        score the search used and why), ``train_sets``, ``thresholds`` (each
        value and where it came from) and ``gains`` (one entry per group,
        method and calibration: mean, std, per run, the train recordings and
        those left out) and ``aided`` (per group and calibration, the aided
        filter's tunables and the MoRPI method whose steps it takes);
        ``docs/manifest.md`` lists the keys.
    groups : tuple of dict
        Per group, method, calibration and estimate, the mean of each metric over
        :attr:`groups_over` recordings, and their count.
    groups_over : str
        ``"test"`` (the dataset has test recordings: each group's, or a
        group without them its recordings outside the train split) or
        ``"all"``.
    left_out : tuple of dict
        ``id``, ``what`` (methods or calibrations) and ``why``.
    course_m : float
        The course distance of a start at rest [m].
    starts : tuple of dict
        Per recording: ``id``, ``initial``, ``rest`` window [s from the first
        sample] or None, ``course_deg`` (the truth's course, counter-clockwise
        from the truth frame's x axis; None for a route), ``speed_mps``
        (initial speed), ``v0_sigma_mps`` (the aided filter's initial
        velocity sigma for ``initial = "truth"``, else None) and how they were
        found (``how``).
    ablation : tuple of dict
        Per group, calibration, aid of :data:`morpi_filters.field_aided.ABLATIONS` and read-out
        (``estimate``), over the aided filter's :attr:`groups_over` recordings: ``used``, ``start``,
        ``n`` and, for each of :data:`ABLATION_METRICS`, the mean of the full filter (``full``), of
        the ablated one (``ablated``) over the recordings where both have it, and ``difference``
        (ablated minus full).
    ablation_runs : tuple of AblationRun
        Per recording the entries the rows average.
    """

    name: str
    source: str
    count: int
    paths: tuple
    choices: dict
    groups: tuple
    groups_over: str
    left_out: tuple
    course_m: float
    starts: tuple
    ablation: tuple = ()
    ablation_runs: tuple = ()

    def to_json(self, track_files: dict | None = None) -> dict:
        """The result as JSON values.

        Parameters
        ----------
        track_files : dict, optional
            ``(id, method, calibration, estimate)`` (or without the estimate
            for the methods other than the aided filter) -> the track file's
            path relative to the output folder; ``("ablation", id,
            calibration, removed, estimate, "full")`` (or ``"ablated"``) ->
            the track file of an :class:`AblationRun`'s filter; without it
            every ``track_file`` is None.

        Returns
        -------
        dict
            ``dataset`` (``name``, ``manifest``, ``count``), ``choices``,
            ``recordings`` (one row per estimate: ``id``, ``split``, ``group``,
            ``method``, ``calibration``, ``estimate`` (``"forward"`` or
            ``"smoothed"`` for the aided filter, else None), the metrics,
            ``track_file``; the aided filter's rows also ``nis`` and
            ``coverage_95``), ``groups`` (with ``over``), ``left_out``,
            ``starts``, ``course_m`` and ``ablation`` (the rows of
            :attr:`ablation`, each with its ``runs``: per recording ``id``,
            ``split``, ``start``, ``start_s``, the metrics of ``full`` and
            ``ablated``, their ``difference``, ``full_track_file`` and
            ``ablated_track_file``).
        """
        from pathlib import Path

        files = track_files or {}
        rows = []
        for p in self.paths:
            key = (p.id, p.method, p.calibration)
            row = {"id": p.id, "split": p.split, "group": p.group, "method": p.method, "calibration": p.calibration,
                   "estimate": p.estimate, **p.metrics,
                   "track_file": files.get(key + (p.estimate,), files.get(key) if p.estimate is None else None)}
            if is_aided(p.method):
                row.update(nis=p.nis, coverage_95=p.coverage_95)
            rows.append(row)
        return {"dataset": {"name": self.name, "manifest": Path(self.source).name, "count": self.count},
                "choices": self.choices, "recordings": rows,
                "groups": {"over": self.groups_over, "rows": list(self.groups)},
                "left_out": list(self.left_out), "starts": list(self.starts), "course_m": self.course_m,
                "ablation": self._ablation_json(files)}

    def _ablation_json(self, files: dict) -> list:
        per = {}
        for a in self.ablation_runs:
            key = (a.id, a.method, a.calibration, a.removed, a.estimate)
            full = {m: a.full.metrics[m] for m in ABLATION_METRICS}
            ablated = {m: a.ablated.metrics[m] for m in ABLATION_METRICS}
            per.setdefault((a.group, a.method, a.calibration, a.removed, a.estimate), []).append(
                {"id": a.id, "split": a.split, "start": a.start, "start_s": a.start_s, "full": full,
                 "ablated": ablated, "difference": {m: None if full[m] is None or ablated[m] is None
                                                    else ablated[m] - full[m] for m in ABLATION_METRICS},
                 "full_track_file": files.get(("ablation",) + key + ("full",)),
                 "ablated_track_file": files.get(("ablation",) + key + ("ablated",))})
        return [{**row, "runs": per.get((row["group"], row["method"], row["calibration"], row["removed"],
                                         row["estimate"]), [])}
                for row in self.ablation]

    def table(self):
        """One row per estimate, as a pandas DataFrame: the ``recordings`` rows of :meth:`to_json`.

        Returns
        -------
        pandas.DataFrame
            Columns :data:`ROW_LABELS` (``id``, ``split``, ``group``,
            ``method``, ``calibration``, ``estimate``) then :data:`METRICS`,
            one row per path in the order of :attr:`paths`. The metric columns
            are float64: a metric None in the JSON (``path_rmse_m`` of a route)
            or not finite (null in the JSON) is NaN. The JSON's ``track_file``
            is not a column. pandas is imported by this call, not by the
            package.
        """
        return _table(self.to_json()["recordings"], ROW_LABELS)

    def group_table(self):
        """The group means of :attr:`groups` as a pandas DataFrame.

        Returns
        -------
        pandas.DataFrame
            Columns ``group``, ``method``, ``calibration``, ``estimate``,
            ``n`` (int64: the recordings averaged) then :data:`METRICS`
            (float64; a mean with no value to average is NaN), one row per
            group, method, calibration and estimate. ``attrs["over"]`` is
            :attr:`groups_over`.
        """
        out = _table(self.groups, ("group", "method", "calibration", "estimate", "n"), counts=("n",))
        out.attrs["over"] = self.groups_over
        return out


# --------------------------------------------------------------------------- geometry

def _rot(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [s, c]])


def _length(xy: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if xy.shape[0] > 1 else 0.0


def _to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Horizontal distance of each point (m, 2) to the polyline (k, 2) [m]."""
    if line.shape[0] == 1:
        return np.hypot(*(points - line[0]).T)
    a, b = line[:-1], line[1:]
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    out = np.empty(points.shape[0])
    for i0 in range(0, points.shape[0], 512):
        p = points[i0:i0 + 512, None, :]
        u = np.clip(np.einsum("mkj,kj->mk", p - a, d) / dd, 0.0, 1.0)
        near = a + u[..., None] * d
        out[i0:i0 + 512] = np.sqrt(np.min(np.sum((p - near) ** 2, axis=-1), axis=1))
    return out


def path_metrics(time, xy, truth) -> dict:
    """The metrics of an estimate in the truth's frame against its truth.

    Parameters
    ----------
    time : array_like, shape (k,)
        Increasing times of the estimate's points on the IMU clock [s].
    xy : array_like, shape (k, 2)
        Horizontal positions in the truth frame's first two axes [m].
    truth : RouteTruth or TruthTrack
        The recording's truth.

    Returns
    -------
    dict
        :data:`METRICS` -> float (``path_rmse_m`` None for a route), as the
        module docstring defines them.

    Examples
    --------
    An estimate running 1 m to the left of a straight 10 m route, ending 1 m short:

    >>> route = RouteTruth(distance_m=10.0, end_point_m=np.array([10.0, 0.0]))
    >>> m = path_metrics([0.0, 1.0], [[0.0, 1.0], [9.0, 1.0]], route)
    >>> round(m["end_error_m"], 6), m["path_rmse_m"], round(m["distance_error_percent"], 6)
    (1.414214, None, -10.0)
    """
    t = np.asarray(time, dtype=float)
    xy = np.asarray(xy, dtype=float)
    if isinstance(truth, RouteTruth):
        line = truth.polyline_m if truth.polyline_m is not None else np.array([[0.0, 0.0], truth.end_point_m])
        dist = float(truth.distance_m)
        end = float(np.hypot(*(xy[-1] - truth.end_point_m)))
        cross = _to_polyline(xy, np.asarray(line, float))
        return {"end_error_m": end, "end_error_percent": 100.0 * end / dist, "path_rmse_m": None,
                "cross_track_rmse_m": float(np.sqrt(np.mean(cross ** 2))),
                "distance_error_percent": 100.0 * (_length(xy) - dist) / dist}
    inside = (truth.time >= t[0]) & (truth.time <= t[-1])
    tt = truth.time[inside]
    ref = truth.position[inside, :2]
    est = np.column_stack([np.interp(tt, t, xy[:, 0]), np.interp(tt, t, xy[:, 1])])
    err = np.hypot(*(est - ref).T)
    # both paths over the span: the truth samples inside it and the span's ends
    ts = np.r_[t[0], tt, t[-1]]
    ref_full = truth.at(ts)[:, :2]
    est_full = np.column_stack([np.interp(ts, t, xy[:, 0]), np.interp(ts, t, xy[:, 1])])
    dist = _length(ref_full)
    end = float(np.hypot(*(xy[-1] - ref_full[-1])))
    cross = _to_polyline(est_full, ref_full)
    pct = (lambda v: 100.0 * v / dist) if dist > 0 else (lambda v: float("nan"))
    return {"end_error_m": end, "end_error_percent": pct(end),
            "path_rmse_m": float(np.sqrt(np.mean(err ** 2))) if err.size else None,
            "cross_track_rmse_m": float(np.sqrt(np.mean(cross ** 2))),
            "distance_error_percent": pct(_length(est_full) - dist)}


def ellipse_share(time, xy, P_xy, truth) -> float:
    """The share of the truth inside an estimate's 95 % horizontal error ellipse.

    A point with error ``d`` (estimate minus truth) under the covariance ``P``
    is inside when ``d^T adj(P) d <= q det(P)``, ``q`` the 2-dof chi-square
    95 % point (:data:`morpi_filters.aided.CHI2_95_2DOF`): ``d^T P^-1 d <= q``
    for a positive definite ``P``, and a zero error under a zero covariance.

    Parameters
    ----------
    time : array_like, shape (k,)
        Increasing times of the estimate's points on the IMU clock [s].
    xy : array_like, shape (k, 2)
        Horizontal positions in the truth frame's first two axes [m].
    P_xy : array_like, shape (k, 2, 2)
        Their covariances in that frame [m^2].
    truth : RouteTruth or TruthTrack
        The recording's truth.

    Returns
    -------
    float
        A truth track: the share of its samples inside the estimate's time
        span (estimate and covariance interpolated linearly in time; NaN
        without one). A route: 1.0 when its end point lies inside the last
        point's ellipse, else 0.0.

    Examples
    --------
    An estimate 1 m and then 3 m east of a track, with 1 m^2 variances:

    >>> track = TruthTrack(time=[0.0, 1.0], position=[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    >>> ellipse_share([0.0, 1.0], [[1.0, 0.0], [4.0, 0.0]], [np.eye(2), np.eye(2)], track)
    0.5
    """
    t = np.asarray(time, dtype=float)
    xy = np.asarray(xy, dtype=float)
    P = np.asarray(P_xy, dtype=float)
    if isinstance(truth, RouteTruth):
        d, Q = (xy[-1] - np.asarray(truth.end_point_m, float))[None], P[-1:]
    else:
        inside = (truth.time >= t[0]) & (truth.time <= t[-1])
        tt = truth.time[inside]
        if not tt.size:
            return float("nan")
        d = np.column_stack([np.interp(tt, t, xy[:, j]) for j in range(2)]) - truth.position[inside, :2]
        Q = np.stack([np.interp(tt, t, P[:, 0, 0]), np.interp(tt, t, P[:, 0, 1]),
                      np.interp(tt, t, P[:, 1, 1])], axis=1)
        Q = np.stack([Q[:, [0, 1]], Q[:, [1, 2]]], axis=1)
    det = Q[:, 0, 0] * Q[:, 1, 1] - Q[:, 0, 1] * Q[:, 1, 0]
    adj = d[:, 0] ** 2 * Q[:, 1, 1] - d[:, 0] * d[:, 1] * (Q[:, 0, 1] + Q[:, 1, 0]) + d[:, 1] ** 2 * Q[:, 0, 0]
    return float(np.mean(adj <= aided.CHI2_95_2DOF * det))


# --------------------------------------------------------------------------- per recording

def _rest_window(data, dr):
    """(RestWindow or None, why not): the manifest's ``rest`` as :class:`~morpi_filters.field.FieldData` reads it."""
    try:
        return data.rest_window(data.recording_at(dr.id)), ""
    except MorpiError as exc:
        if dr.rest == "none":
            return None, "rest = \"none\": no rest window"
        return None, f"rest = \"auto\": no rest window found ({exc})"


def _start(dr, course_m: float) -> dict:
    """Initial velocity (navigation frame), the truth frame's turn and origin, and what was used."""
    rec, truth = dr.recording, dr.truth
    t0 = float(rec.time[0])
    if isinstance(truth, RouteTruth):
        return {"v0": np.zeros(3), "psi": 0.0, "how": "route frame (x along the heading at the start)",
                "course_deg": None, "speed_mps": 0.0}
    if dr.initial == "truth":
        h = truth.interval
        a = max(t0 - h, float(truth.time[0]))
        b = a + 2 * h if a < t0 - 0.5 * h else t0 + h
        pa, pb, pc = truth.at([a, b, 2 * b - a])
        v = (pb - pa) / (b - a)
        psi = math.atan2(v[1], v[0])
        c, s = math.cos(psi), math.sin(psi)
        v0 = np.array([c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]])
        # the aided filter's sigma: how far the truth velocity moves from this span to the next
        sigma = max(V0_SIGMA_MIN, float(np.linalg.norm((pc - pb) / (b - a) - v)))
        return {"v0": v0, "psi": psi, "course_deg": math.degrees(psi), "speed_mps": float(np.hypot(v[0], v[1])),
                "v0_sigma": sigma,
                "how": f"truth velocity over [{a - t0:.4g}, {b - t0:.4g}] s from the first sample"}
    p0 = truth.at([t0])[0, :2]
    later = truth.time > t0
    away = np.hypot(*(truth.position[later, :2] - p0).T) >= course_m
    if not away.any():
        raise DataError(f"the truth track never moves {course_m:g} m from its position at the first sample")
    k = int(np.argmax(away))
    q = truth.position[later][k, :2]
    psi = math.atan2(q[1] - p0[1], q[0] - p0[0])
    return {"v0": np.zeros(3), "psi": psi, "course_deg": math.degrees(psi), "speed_mps": 0.0,
            "how": f"truth course over its first {course_m:g} m (reached {float(truth.time[later][k]) - t0:.4g} s "
                   "after the first sample)"}


def _place(start: dict, truth, t_first: float, xy: np.ndarray) -> np.ndarray:
    """Navigation-frame positions (origin at the estimate's first point) in the truth's frame."""
    out = xy @ _rot(start["psi"]).T
    if isinstance(truth, TruthTrack):
        out = out + truth.at([t_first])[0, :2]
    return out


def _prepare(data, dr, course_m):
    """Per recording: rest window, calibrated recordings, start; or the reason it cannot be evaluated."""
    window, why = _rest_window(data, dr)
    rec = data.recording_at(dr.id)
    cals = {"RD": rec}
    if window is not None:
        for mode in ("GC", "GAC"):
            cals[mode] = data.calibrated(rec, mode)[0]
    return {"window": window, "why": why, "cals": cals, "start": _start(dr, course_m), "rec": rec}


_MORPI = ("MoRPI-A", "MoRPI-G")


def _why_not(data, rec, mode, method, config) -> str:
    try:
        data.step_sums(rec, mode, method, config)
    except MorpiError as exc:
        return str(exc)
    return f"{data.relpath(rec)}: no gain"


def _choose(data, dataset, settings: Settings) -> tuple[dict, dict, dict, dict]:
    """The train-only choices on `data`: the step rule per MoRPI method, the gains per (group, method,
    calibration), their JSON entries (``choices``) and per (group, method, calibration) the trained
    :class:`~morpi_filters.field.Gain` with its train set and scope."""
    th = data.thresholds
    sets = [s for s in data.train_sets() if s.runs]
    if settings.held_out != "auto":
        held_out = settings.held_out
        why = f"evaluation.held_out = {held_out!r}"
    else:
        held_out = "group" if len(sets) >= 2 else "recording"
        why = ("two train groups or more: each group's runs are scored with a gain none of its runs set, as a "
               "test run of a group without train recordings is" if held_out == "group"
               else "one train group: each run is scored with the mean gain of its group's other train runs")
    configs, rule = {}, {}
    for m in _MORPI:
        sel = fd.select_config(data, m, held_out=held_out)
        if math.isfinite(sel.score):
            cfg = sel.config
            src = (f"field.select_config on the train recordings ({m} alone, GC), scored by "
                   f"leave-one-{held_out}-out end-point error")
        else:
            cfg = st.DEFAULT_CONFIGS[m]
            src = ("steps.DEFAULT_CONFIGS: the rule chosen on the MoRPI field train runs, since "
                   + ("the dataset has no train recording with periodic motion" if not sets
                      else "its train recordings give no held-out score"))
        configs[m] = cfg
        scores = {h: fd.held_out_score(data, m, cfg, held_out=h) for h in fd.HELD_OUT}
        rule[m] = {"config": {f.name: getattr(cfg, f.name) for f in fields(cfg)}, "from": src,
                   "score_percent": {h: (v if math.isfinite(v) else None) for h, (v, _) in scores.items()},
                   "runs_scored": {h: n for h, (_, n) in scores.items()}}
    pooled = fd.TrainSet("every train group", tuple(f for s in sets for f in s.files),
                         tuple(r for s in sets for r in s.runs),
                         np.concatenate([s.end_point_m for s in sets]) if sets else np.empty((0, 2)),
                         np.concatenate([s.distance_m for s in sets]) if sets else np.empty(0))
    by_group = {s.name: s for s in sets}
    train_group = {dr.group: dr.train_group for dr in dataset.recordings}
    gains, entries, trained = {}, [], {}
    for group in dict.fromkeys(dr.group for dr in dataset.recordings):
        if train_group[group] is not None:
            tset, scope = by_group.get(train_group[group]), f"train_group {train_group[group]!r}"
            if tset is None:        # its train recordings do not load, or none has periodic motion
                tset = fd.TrainSet(train_group[group], (), (), np.empty((0, 2)), np.empty(0))
        else:
            tset, scope = by_group.get(group), "group"
            if tset is None:
                tset, scope = pooled, "dataset (no train recording in the group)"
        for m in _MORPI:
            for mode in CALIBRATIONS:
                g = fd.set_gain(data, tset, mode, m, configs[m], phone=dataset.name, route=group)
                entry = {"group": group, "method": m, "calibration": mode, "from": scope,
                         "train": list(g.files) if g else [],
                         "skipped": list(g.skipped) if g else [], "mean": None, "std": None, "per_run": []}
                if g is not None:
                    gains[group, m, mode] = g.mean
                    trained[group, m, mode] = (g, tset, scope)
                    entry.update(mean=g.mean, std=g.std, per_run=list(g.per_run))
                else:
                    entry["skipped"] = [_why_not(data, r, mode, m, configs[m]) for r in tset.runs]
                entries.append(entry)
    def where(values, files, what):
        return (f"{what} of the train recordings {', '.join(dict.fromkeys(files))}" if len(values)
                else "the library's default (no train recording measured it)")
    thresholds = {
        "accel_floor_mps2": {"value": th.accel_floor, "from": where(th.rest_std, th.rest_files,
                             "k_std of calibration.detect_rest times the median rest accelerometer spread")},
        "min_swing_deg": {"value": th.min_swing_deg, "from": where(th.swings_deg, th.swing_files,
                          f"{fd.SWING_MARGIN:g} times the least median heading swing")},
        "turn_deg": {"value": th.turn_deg, "from": where(th.period_changes_deg, th.change_files,
                     f"{fd.TURN_MARGIN:g} times the largest full-period heading change")},
    }
    choices = {"settings": settings.to_json(), "rule": rule, "held_out": {"used": held_out, "why": why},
               "train_sets": [{"group": s.name, "train": list(s.files),
                               "end_point_m": s.end_point_m.tolist(), "distance_m": s.distance_m.tolist()}
                              for s in sets],
               "thresholds": thresholds, "gains": entries}
    return configs, gains, choices, trained


def _none_if_nan(v):
    return float(v) if v is not None and math.isfinite(v) else None


def _aided_choices(data, dataset, configs, trained, workers, settings) -> tuple[dict, list]:
    """The aided filter's train-only tunables per (group, calibration) of a group with periodic motion: a list
    of (method name, MoRPI method, :class:`~morpi_filters.field_aided.TunableChoice`, Gain), one filter with
    ``aided_methods = "chosen"``, one per MoRPI method with ``"each"``; and their JSON entries."""
    groups = [g for g in dict.fromkeys(dr.group for dr in dataset.recordings)
              if any(dr.group == g and dr.motion == "periodic" for dr in dataset.recordings)]
    keys, requests, index = [], [], {}
    for group in groups:
        for m in _MORPI:
            for mode in CALIBRATIONS:
                if (group, m, mode) not in trained:
                    continue
                g, tset, _ = trained[group, m, mode]
                at = index.setdefault((id(tset), m, mode), len(requests))
                if at == len(requests):                 # a set shared by several groups is tuned once
                    requests.append((tset, m, mode, configs[m], g))
                keys.append(((group, m, mode), at))
    picks = fa.choose_tunables_many(data, requests, workers=workers) if requests else []
    per = {k: picks[at] for k, at in keys}
    chosen, entries = {}, []
    for group in groups:
        for mode in CALIBRATIONS:
            cands, why = [], {}
            for m in _MORPI:
                c = per.get((group, m, mode))
                if c is None:
                    why[m] = "no gain: no train recording gave one"
                elif isinstance(c, MorpiError):
                    why[m] = str(c)
                else:
                    cands.append((m, c))
            entry = {"group": group, "calibration": mode, "method": None, "from": None, "train": [],
                     "candidates": {m: ({"score_percent": _none_if_nan(c.score_percent),
                                         "loo_percent": _none_if_nan(c.loo_percent),
                                         "morpi_percent": _none_if_nan(c.morpi_percent)} if m not in why
                                        else {"why": why[m]})
                                    for m, c in [(m, per.get((group, m, mode))) for m in _MORPI]},
                     "tunables": None}
            if not cands:
                entries.append(entry)
                continue
            if settings.aided_methods == "each":
                picked = [(AIDED_BY[m], m, c, "evaluation.aided_methods = 'each': one filter per MoRPI method")
                          for m, c in cands]
            else:
                loo = [c.loo_percent for _, c in cands]
                by = "loo_percent" if all(math.isfinite(v) for v in loo) else "score_percent"
                m, c = cands[choose(np.array([getattr(c, by) for _, c in cands]))]
                picked = [(AIDED, m, c, f"the method of least {by}")]
            for name, m, c, how in picked:
                g, tset, scope = trained[group, m, mode]
                noise, info = c.noise, c.info
                chosen.setdefault((group, mode), []).append((name, m, c, g))
                one = dict(entry)
                one.update(method=m, train=list(g.files),
                           **{"from": f"field_aided.choose_tunables_many on the train set {tset.name!r} ({scope}); "
                                      f"{how}"},
                           tunables={**info, "accel_noise": noise[0] * info["vibration"],
                                     "gyro_noise": noise[1] * info["vibration"], "rest_accel_noise": noise[0],
                                     "rest_gyro_noise": noise[2], "gyro_walk": noise[3], "accel_jump": noise[4],
                                     "gain_sigma": g.std / g.mean})
                entries.append(one)
    return chosen, entries


def _aided_input(data, dr, prep, mode, method, config, gain, info):
    """The aided filter's input for one recording, its read-out time and the input started at the motion
    onset: from the rest window (:func:`~morpi_filters.field_aided.prepare`,
    :meth:`~morpi_filters.field_aided.Prepared.onset_input`) or, for ``initial = "truth"``, from the first
    sample under way."""
    from .strapdown import coarse_level

    rec = prep["rec"]
    if dr.initial == "rest":
        p = fa.prepare(data, rec, mode, method, config, gain.mean)
        return p.input_for(info), p.stop_s, p.onset_input(info)
    crec = prep["cals"][mode]
    s = data.steps(rec, mode, method, config)
    track = st.morpi_track(s, gain.mean)
    window = prep["window"]
    if window is not None:
        f_rest = crec.f[window.i0:window.i1].mean(axis=0)
        C0, g, rest = coarse_level(f_rest), float(np.linalg.norm(f_rest)), fa.rest_terms(data, rec, mode)[1][1:]
    else:
        C0, g, rest = np.eye(3), data.gravity, ()
    vectors = (fa.route_steps(data, rec, mode, config, s, track.length) if info["step_heading"] == "route"
               else np.diff(track.position, axis=0))
    inp = aided.AidedInput(time=crec.time, f=crec.f, omega=crec.omega, C0=C0, g=g, step_start=s.start_time,
                           step_end=s.end_time, step_length=track.length, rest=tuple(rest), standing=(),
                           step_vector=vectors, v0=prep["start"]["v0"], v0_sigma=prep["start"]["v0_sigma"])
    stop = float(s.end_time[-1]) if s.end_time.size else float(data.activity(rec)[1])
    # the same input started at the motion onset (Prepared.onset_input's cut): at the first sample when the
    # recording moves from there; the robot stands up to the onset, the initial velocity is kept
    return inp, stop, inp.since(float(data.activity(rec)[0]))


def _aided_paths(data, dr, prep, chosen, configs, ablate: bool = False) -> tuple[list, list, list]:
    """The aided filter's rows of one recording (forward and smoothed per calibration), what was left out and,
    with `ablate`, its :class:`AblationRun` entries."""
    if dr.initial == "rest" and prep["window"] is None:
        return [], [{"id": dr.id, "what": AIDED,
                     "why": "initial = \"rest\" without a rest window: the filter starts at the rest"}], []
    members, left = [], []
    for mode in prep["cals"]:
        if (dr.group, mode) not in chosen:
            left.append({"id": dr.id, "what": f"{AIDED} {mode}", "why": "no tunables: no train run served the filter"})
            continue
        for name, method, choice, gain in chosen[dr.group, mode]:
            try:
                inp, stop, onset = _aided_input(data, dr, prep, mode, method, configs[method], gain, choice.info)
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{name} {mode}", "why": str(exc)})
                continue
            members.append((name, mode, inp, stop, fa.tuning_from(choice.noise, choice.info, gain.std / gain.mean),
                            onset))
    results = aided.run_batch([q[2] for q in members], [q[4] for q in members], smooth=True,
                              smoothed_covariance=True, innovations=True, workers=1) if members else []
    start, truth = prep["start"], dr.truth
    rot = _rot(start["psi"])
    paths = []
    for (name, mode, inp, stop, *_), r in zip(members, results):
        j = r.index_at(stop)
        t = r.time[:j + 1]
        nis = {k: {**fa.nis_consistency(total, n, dof), "dof": dof} for k, (total, n, dof) in r.nis.items()}
        for estimate, xy, P in (("forward", r.position, r.P_xy), ("smoothed", r.smoothed, r.P_xy_smoothed)):
            placed = _place(start, truth, float(t[0]), np.asarray(xy)[:j + 1, :2])
            P = rot @ np.asarray(P)[:j + 1] @ rot.T
            paths.append(EstimatedPath(id=dr.id, split=dr.split, group=dr.group, method=name, calibration=mode,
                                       time=t, xy=placed, metrics=path_metrics(t, placed, truth), estimate=estimate,
                                       P_xy=P, nis=nis, coverage_95=ellipse_share(t, placed, P, truth),
                                       innovations=r.innovations))
    return paths, left, (_ablation_runs(dr, prep, members, paths) if ablate else [])


def _ablation_runs(dr, prep, members, paths) -> list:
    """Per calibration the filter of `members` with each aid of :data:`~morpi_filters.field_aided.ABLATIONS`
    removed in turn, both read-outs, beside the filter it is compared with (`paths`: the full filter's rows)."""
    full = {(p.method, p.calibration, p.estimate): p for p in paths}
    t_first = float(dr.recording.time[0])
    items = []                                  # (filter, mode, aid, which, tuning, input, stop)
    for label, mode, inp, stop, tuning, onset in members:
        for name, change in fa.ABLATIONS.items():
            if not (change and fa.aid_used(name, tuning)):
                continue                        # not used: not run, the full filter's values; smoothing: no run
            if name == "rest updates":          # removed from a filter started at the motion onset, beside it
                items.append((label, mode, name, "full", tuning, onset, stop))
            items.append((label, mode, name, "ablated", tuning.with_(**change),
                          onset if name == "rest updates" else inp, stop))
    results = aided.run_batch([q[5] for q in items], [q[4] for q in items], smooth=True, smoothed_covariance=False,
                              nis=False, workers=1) if items else []
    start, truth = prep["start"], dr.truth
    ran = {}
    for (label, mode, name, which, _, _, stop), r in zip(items, results):
        j = r.index_at(stop)
        t = r.time[:j + 1]
        for estimate, xy in (("forward", r.position), ("smoothed", r.smoothed)):
            placed = _place(start, truth, float(t[0]), np.asarray(xy)[:j + 1, :2])
            ran[label, mode, name, which, estimate] = EstimatedPath(
                id=dr.id, split=dr.split, group=dr.group, method=label, calibration=mode, time=t, xy=placed,
                metrics=path_metrics(t, placed, truth), estimate=estimate)
    begin = "rest window" if dr.initial == "rest" else "first sample"
    out = []
    for label, mode, _, _, tuning, _ in members:
        for name, change in fa.ABLATIONS.items():
            used = fa.aid_used(name, tuning)
            for estimate in ESTIMATES:
                base, where = full[label, mode, estimate], begin
                if name == "smoothing":         # the forward read-out in place of the smoothed one
                    without = full[label, mode, "forward"]
                elif not used:                  # the same filter: exactly no effect
                    without = base
                else:
                    without = ran[label, mode, name, "ablated", estimate]
                    if name == "rest updates":
                        base, where = ran[label, mode, name, "full", estimate], "motion onset"
                out.append(AblationRun(id=dr.id, split=dr.split, group=dr.group, calibration=mode, removed=name,
                                       used=bool(used), estimate=estimate, start=where,
                                       start_s=float(base.time[0]) - t_first, full=base, ablated=without,
                                       method=label))
    return out


def _ins(data, dr, prep, crec, mode, method, span):
    """The INS run of one calibrated recording: over its motion window (``span = "motion"``, a recording that
    starts at rest: :meth:`~morpi_filters.field.FieldData.ins`) or over the whole recording from its start."""
    if span == "motion" and dr.initial == "rest":
        return data.ins(prep["rec"], mode, method, span="motion")
    v0 = prep["start"]["v0"]
    return (ins3d(crec.time, crec.f, crec.omega, v0=v0, g=data.gravity) if method == "INS-3D"
            else ins2d(crec.time, crec.f, crec.omega, v0=v0))


def _evaluate_one(data, dr, prep, gains, configs, chosen, settings, ablate=False) -> tuple[list, list, list]:
    truth, start = dr.truth, prep["start"]
    paths, left, ablated = [], [], []
    label = dict(id=dr.id, split=dr.split, group=dr.group)
    for mode, crec in prep["cals"].items():
        for method in ("INS-3D", "INS-2D"):
            try:
                run = _ins(data, dr, prep, crec, mode, method, settings.ins_span)
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": str(exc)})
                continue
            t = np.asarray(run.time)
            xy = _place(start, truth, float(t[0]), np.asarray(run.position)[:, :2])
            paths.append(EstimatedPath(**label, method=method, calibration=mode, time=t, xy=xy,
                                       metrics=path_metrics(t, xy, truth)))
        if dr.motion != "periodic":
            continue
        for method in ("MoRPI-A", "MoRPI-G"):
            gain = gains.get((dr.group, method, mode))
            if gain is None:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": "no gain: no train recording gave one"})
                continue
            try:
                s = data.steps(prep["rec"], mode, method, configs[method])
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": str(exc)})
                continue
            track = st.morpi_track(s, gain)
            tm = np.r_[s.start_time[:1], s.end_time]
            xy = _place(start, truth, float(tm[0]), track.position)
            paths.append(EstimatedPath(**label, method=method, calibration=mode, time=tm, xy=xy,
                                       metrics=path_metrics(tm, xy, truth)))
    if dr.motion == "periodic":
        more, why, ablated = _aided_paths(data, dr, prep, chosen, configs, ablate)
        paths += more
        left += why
    order = {(m, c): i for i, (m, c) in enumerate((m, c) for m in METHODS for c in CALIBRATIONS)}
    paths.sort(key=lambda p: (order[p.method, p.calibration], ESTIMATES.index(p.estimate) if p.estimate else 0))
    if prep["window"] is None:
        left.insert(0, {"id": dr.id, "what": "GC, GAC", "why": prep["why"]})
    if dr.motion != "periodic":
        left.append({"id": dr.id, "what": f"MoRPI-A, MoRPI-G, {AIDED}",
                     "why": f"motion = {dr.motion!r}: no periodic motion"})
    return paths, left, ablated


def _group_means(paths, over: str) -> tuple:
    """Per group, method, calibration and estimate the mean of each metric: with ``over = "test"`` over the
    group's test recordings, or over its recordings outside the train split when it has no test recording."""
    tested = {p.group for p in paths if p.split == "test"}
    out = {}
    for p in paths:
        if over == "test" and p.split != "test" and (p.group in tested or p.split == "train"):
            continue
        out.setdefault((p.group, p.method, p.calibration, p.estimate), []).append(p)
    rows = []
    for (group, method, mode, estimate), ps in out.items():
        row = {"group": group, "method": method, "calibration": mode, "estimate": estimate, "n": len(ps)}
        for key in METRICS:
            vals = [p.metrics[key] for p in ps if p.metrics[key] is not None and math.isfinite(p.metrics[key])]
            row[key] = float(np.mean(vals)) if vals else None
        rows.append(row)
    return tuple(rows)


def _ablation_means(runs) -> tuple:
    """The ablation rows: per group, filter (method), calibration, aid and read-out, the mean of each of
    :data:`ABLATION_METRICS` of the full and the ablated filter over the recordings where both have it,
    and their difference (ablated minus full)."""
    out = {}
    for a in runs:
        out.setdefault((a.group, a.method, a.calibration, a.removed, a.estimate), []).append(a)
    order = ({g: i for i, g in enumerate(dict.fromkeys(a.group for a in runs))}, METHODS, CALIBRATIONS,
             tuple(fa.ABLATIONS), ESTIMATES)
    rows = []
    for key in sorted(out, key=lambda k: (order[0][k[0]], *(o.index(v) for o, v in zip(order[1:], k[1:])))):
        group, method, mode, name, estimate = key
        ps = out[key]
        full, ablated, diff = {}, {}, {}
        for m in ABLATION_METRICS:
            pairs = [(a.full.metrics[m], a.ablated.metrics[m]) for a in ps
                     if all(v is not None and math.isfinite(v) for v in (a.full.metrics[m], a.ablated.metrics[m]))]
            if pairs:
                full[m], ablated[m] = (float(np.mean([q[k] for q in pairs])) for k in (0, 1))
                diff[m] = ablated[m] - full[m]
            else:
                full[m] = ablated[m] = diff[m] = None
        rows.append({"group": group, "method": method, "calibration": mode, "removed": name, "used": any(a.used for a in ps),
                     "estimate": estimate, "start": " / ".join(dict.fromkeys(a.start for a in ps)), "n": len(ps),
                     "full": full, "ablated": ablated, "difference": diff})
    return tuple(rows)


def _evaluate(dataset: Dataset, *, course_m: float = COURSE_M, workers: int | None = None,
              progress=None, ablation: bool = True, settings: Settings | None = None) -> DatasetEvaluation:
    """:func:`evaluate` of a loaded dataset (its parameters and result)."""
    if settings is None:
        settings = dataset.settings
    elif not isinstance(settings, Settings):
        raise ParameterError(f"settings: {type(settings).__name__}, expected a morpi_filters.manifest.Settings")
    if not (isinstance(course_m, (int, float)) and math.isfinite(course_m) and course_m > 0):
        raise ParameterError(f"course_m: {course_m!r}, expected a positive distance in metres")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ParameterError(f"workers: {workers!r}, expected a positive whole number")
    if not isinstance(ablation, bool):
        raise ParameterError(f"ablation: {ablation!r}, expected True or False")
    where = dataset.source
    over = "test" if any(dr.split == "test" for dr in dataset.recordings) else "all"
    data = fd.FieldData(dataset, course_m=float(course_m))
    configs, gains, choices, trained = _choose(data, dataset, settings)
    if workers is None:
        from .parallel import available_cores

        workers = available_cores()
    chosen, choices["aided"] = _aided_choices(data, dataset, configs, trained, workers, settings)

    def prepare(dr):
        try:
            return _prepare(data, dr, course_m)
        except MorpiError as exc:           # no start to align with: the recording is listed, not evaluated
            return {"error": f"{where}: recording {dr.id!r}: {exc}"}

    with ThreadPoolExecutor(max_workers=workers) as pool:
        prepared = dict(zip((dr.id for dr in dataset.recordings), pool.map(prepare, dataset.recordings)))

        def one(dr):
            prep = prepared[dr.id]
            return (([], [{"id": dr.id, "what": "every method", "why": prep["error"]}], []) if "error" in prep
                    else _evaluate_one(data, dr, prep, gains, configs, chosen, settings,
                                       ablation and (over == "all" or dr.split == "test")))

        results = []
        for out in pool.map(one, dataset.recordings):      # in order; the progress line from this thread
            results.append(out)
            if progress is not None:
                progress.update(1)
    paths = tuple(p for ps, _, _ in results for p in ps)
    left = tuple(x for _, lo, _ in results for x in lo)
    runs = tuple(a for _, _, ab in results for a in ab)
    starts = []
    for dr in dataset.recordings:
        prep = prepared[dr.id]
        if "error" in prep:
            continue
        w = prep["window"]
        t0 = float(dr.recording.time[0])
        starts.append({"id": dr.id, "initial": dr.initial,
                       "rest": None if w is None else [w.start_s - t0, w.end_s - t0],
                       "course_deg": prep["start"]["course_deg"], "speed_mps": prep["start"]["speed_mps"],
                       "v0_sigma_mps": prep["start"].get("v0_sigma"), "how": prep["start"]["how"]})
    return DatasetEvaluation(name=dataset.name, source=dataset.source, count=len(dataset), paths=paths,
                             choices=choices, groups=_group_means(paths, over),
                             groups_over=over, left_out=left, course_m=float(course_m), starts=tuple(starts),
                             ablation=_ablation_means(runs), ablation_runs=runs)


# --------------------------------------------------------------------------- entry point and tables

#: The label columns of :meth:`DatasetEvaluation.table`, before the :data:`METRICS`.
ROW_LABELS = ("id", "split", "group", "method", "calibration", "estimate")


def _table(rows, labels: tuple, counts: tuple = ()):
    """A DataFrame of `rows` (dicts): the `labels` as given, `counts` as int64, the metrics as float64."""
    import pandas as pd

    data = {}
    for key in labels:
        values = [r[key] for r in rows]
        data[key] = pd.Series(values, dtype="int64" if key in counts else object)
    for key in METRICS:
        data[key] = pd.Series([np.nan if r[key] is None else r[key] for r in rows], dtype="float64")
    return pd.DataFrame(data, columns=list(labels + METRICS))


def evaluate(dataset, *, course_m: float = COURSE_M, workers: int | None = None,
             progress=None, ablation: bool = True, settings: Settings | None = None) -> DatasetEvaluation:
    """Evaluate a dataset: the entry point for a manifest or a :class:`~morpi_filters.manifest.Dataset`.

    What ``morpi evaluate --dataset FILE`` computes, without its files:
    every method and calibration on every recording, against its truth
    (the module docstring). The result's
    :meth:`~DatasetEvaluation.table` and
    :meth:`~DatasetEvaluation.group_table` are the JSON's rows and group
    means as pandas DataFrames; each :class:`EstimatedPath` of its ``paths``
    holds an estimate's times and positions in the truth's frame.

    Parameters
    ----------
    dataset : Dataset or str or path-like
        A dataset (:func:`~morpi_filters.manifest.load_dataset`,
        :meth:`~morpi_filters.manifest.Dataset.from_arrays`), or the path of
        its manifest, which is loaded and checked first.
    course_m : float
        Horizontal distance over which the truth's course gives the heading
        of a track recording that starts at rest [m].
    workers : int, optional
        Threads that evaluate the recordings and run the aided filter's
        tuning (default: the cores the process may use); the result does
        not depend on it.
    progress : morpi_filters.parallel.Progress, optional
        Counts one run per recording.
    ablation : bool
        Also run the aided filter's ablation.
    settings : morpi_filters.manifest.Settings, optional
        How to evaluate (rule scoring, INS span, the aided filter's steps);
        default: the dataset's own (its manifest's ``[evaluation]``).

    Returns
    -------
    DatasetEvaluation
        The estimates with their metrics, the train-only choices, the group
        means, the ablation and what was left out.

    Raises
    ------
    ParameterError
        `dataset` neither a Dataset nor a path, a problem of the manifest,
        or a bad `course_m`, `workers` or `ablation`.
    DataError
        A data file of the manifest that does not load.

    Examples
    --------
    A level robot at rest for 2 s, then 1 m/s^2 forward for 2 s (2 m), with
    its route:

    >>> t = np.arange(401) / 100.0
    >>> from morpi_filters.units import G0
    >>> f = np.tile([0.0, 0.0, G0], (401, 1)); f[t > 2.0, 0] = 1.0
    >>> ds = Dataset.from_arrays("bench", [{"id": "a", "time": t, "f": f, "omega": np.zeros((401, 3)),
    ...     "motion": "straight", "rest": [0.0, 1.5],
    ...     "truth": RouteTruth(distance_m=2.0, end_point_m=np.array([2.0, 0.0]))}])
    >>> table = evaluate(ds).table()
    >>> print(table[["id", "method", "calibration", "end_error_m"]].head(3).round(2).to_string(index=False))
    id method calibration  end_error_m
     a INS-3D          RD         0.01
     a INS-3D          GC         0.01
     a INS-3D         GAC         0.01
    >>> bool(table["path_rmse_m"].isna().all()), str(table["path_rmse_m"].dtype)   # None for a route: NaN
    (True, 'float64')
    """
    import os

    from .manifest import load_dataset

    if isinstance(dataset, (str, os.PathLike)):
        dataset = load_dataset(dataset)
    elif not isinstance(dataset, Dataset):
        raise ParameterError(f"dataset: {type(dataset).__name__}, expected a Dataset or the path of a manifest")
    return _evaluate(dataset, course_m=course_m, workers=workers, progress=progress, ablation=ablation,
                     settings=settings)
