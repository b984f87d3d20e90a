"""The results of a dataset's evaluation: the estimates (:class:`EstimatedPath`), the ablation's runs
(:class:`AblationRun`), the whole (:class:`DatasetEvaluation`) and the metrics of a path against its truth
(:func:`path_metrics`, :func:`ellipse_share`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import aided
from ..manifest import RouteTruth, TruthTrack  # noqa: F401  (TruthTrack: the examples')

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
    pipeline : Pipeline or None
        The trained choices (:func:`train`): :meth:`Pipeline.estimates` of
        one recording are its rows here.
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
    pipeline: object = None

    def to_json(self, track_files: dict | None = None) -> dict:
        """The result as JSON values.

        Parameters
        ----------
        track_files : dict, optional
            ``(id, method, calibration, estimate)`` (or without the estimate
            for the methods other than the aided filter) -> the track file's
            path relative to the output folder; ``("ablation", id, method,
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

