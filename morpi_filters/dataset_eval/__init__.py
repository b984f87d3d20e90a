"""The methods on a manifest dataset, each estimate held against the recording's truth.

:func:`evaluate` runs, on every recording of a
:class:`~morpi_filters.manifest.Dataset` (``morpi evaluate --dataset FILE``),
what :func:`train` chose on its train recordings (a :class:`Pipeline`, whose
:meth:`~Pipeline.estimates` give one recording's rows):

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

import numpy as np

from .. import field_aided as fa
from ..errors import MorpiError, ParameterError
from ..manifest import Dataset, RouteTruth, Settings  # noqa: F401  (RouteTruth: the examples')
from ..parallel import available_cores
from .pipeline import Pipeline, PreparedRecording, train
from .results import (ABLATION_METRICS, AIDED, AIDED_BY, CALIBRATIONS, COURSE_M, ESTIMATES, METHODS, METRICS,
                      ROW_LABELS, V0_SIGMA_MIN, AblationRun, DatasetEvaluation, EstimatedPath, ellipse_share,
                      is_aided, path_metrics)

__all__ = ["COURSE_M", "AIDED", "AIDED_BY", "is_aided", "METHODS", "CALIBRATIONS", "ESTIMATES", "METRICS",
           "V0_SIGMA_MIN", "ROW_LABELS", "ABLATION_METRICS", "EstimatedPath", "AblationRun", "DatasetEvaluation",
           "path_metrics", "ellipse_share", "evaluate", "train", "Pipeline", "PreparedRecording"]


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
    if not isinstance(ablation, bool):
        raise ParameterError(f"ablation: {ablation!r}, expected True or False")
    pipeline = train(dataset, settings=settings, course_m=course_m, workers=workers)
    where = dataset.source
    over = "test" if any(dr.split == "test" for dr in dataset.recordings) else "all"

    def prepare(dr):
        try:
            return pipeline.prepare(dr)
        except MorpiError as exc:           # no start to align with: the recording is listed, not evaluated
            return f"{where}: recording {dr.id!r}: {exc}"

    def one(dr):
        prep = prepared[dr.id]
        if isinstance(prep, str):
            return [], [{"id": dr.id, "what": "every method", "why": prep}], []
        return pipeline.estimates(dr, ablation=ablation and (over == "all" or dr.split == "test"), prepared=prep)

    with ThreadPoolExecutor(max_workers=workers or available_cores()) as pool:
        prepared = dict(zip((dr.id for dr in dataset.recordings), pool.map(prepare, dataset.recordings)))
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
        if isinstance(prep, str):
            continue
        w = prep.rest_window
        t0 = float(dr.recording.time[0])
        starts.append({"id": dr.id, "initial": dr.initial,
                       "rest": None if w is None else [w.start_s - t0, w.end_s - t0],
                       "course_deg": prep.start["course_deg"], "speed_mps": prep.start["speed_mps"],
                       "v0_sigma_mps": prep.start.get("v0_sigma"), "how": prep.start["how"]})
    return DatasetEvaluation(name=dataset.name, source=dataset.source, count=len(dataset), paths=paths,
                             choices=pipeline.choices, groups=_group_means(paths, over),
                             groups_over=over, left_out=left, course_m=pipeline.course_m, starts=tuple(starts),
                             ablation=_ablation_means(runs), ablation_runs=runs, pipeline=pipeline)


# --------------------------------------------------------------------------- entry point and tables


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

    from ..manifest import load_dataset

    if isinstance(dataset, (str, os.PathLike)):
        dataset = load_dataset(dataset)
    elif not isinstance(dataset, Dataset):
        raise ParameterError(f"dataset: {type(dataset).__name__}, expected a Dataset or the path of a manifest")
    return _evaluate(dataset, course_m=course_m, workers=workers, progress=progress, ablation=ablation,
                     settings=settings)
