"""The paper's protocol on the field recordings: every table cell, ours beside the paper's.

Cells (32 in all, the tables of Etzion and Klein [1]_):

========================  =====================================  ===========================
table (JSON name)         recordings                             what
========================  =====================================  ===========================
``ins_straight``          s8/line_dataset                        INS-3D/2D x RD/GAC
``short_route``           {s8 1 m, s8 1.5 m, s6 1 m} test        MoRPI-A/G x RD/GC
``long_route``            {s8, s6}/long_distance/test            MoRPI-A/G x RD/GC, indoor gains
``ins_l_shape``           s6/L_line                              INS-3D/2D x RD/GAC
``morpi_l_shape``         s6/L_shape/test                        MoRPI-A/G x RD/GC, s6 indoor gains
========================  =====================================  ===========================

Protocol
    Gains are trained per training set (phone, route), method and calibration
    on the ``train`` split with the known distance: each run's gain makes its
    summed steps equal the distance, the gain is the mean over runs (the std is
    kept). The long route and the L shape use the indoor 1 m gains of the same
    phone, without retraining.

Tunables
    The step rule (the paper's open readings and the thresholds, see
    :mod:`morpi_filters.steps`) is chosen by :func:`select_config` from the
    short-route ``train`` runs only: a coordinate search scored by the
    leave-one-out end-point error on the train runs (each held-out run is
    dead-reckoned with the gain of the other runs of its set). Either each
    method gets its own rule (``rule="per_method"``) or one rule serves both
    (``"joint"``, the paper's "in the same manner" reading); the other is
    reported beside the default. The default is the way of choosing that
    :func:`nested_rule_comparison` prefers: nested leave-one-out over the
    train runs, without the bias of scoring on the runs a rule was chosen
    on (a rule per method always has the lower plain train error). And
    :func:`rule_sensitivity` shows how far each rule the search tried moves
    the short-route cells. Nothing of a ``test`` folder enters the choice, so
    the result is the same with the test folders absent.

INS cells
    3D (:func:`morpi_filters.strapdown.ins3d`, level start) and 2D
    (:func:`~morpi_filters.strapdown.ins2d`) INS on the RD or GAC recording,
    integrated over the robot's motion (:func:`morpi_filters.steps.activity_span`;
    the whole recording is reported beside it).

Caching
    :class:`FieldData` computes each per-recording quantity once (the file,
    the rest window, calibrations, resampled and filtered step signals, peaks,
    INS runs) and every cell, the gain training and the rule search share it.

Errors
    ``ours_percent`` is the mean end-point error over the test runs, in % of
    the route's travelled distance (the paper's measure); the distance error
    ``|travelled estimate - true distance|`` is given beside it.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023 (tables "INS results", "weinberg results short",
   "tab:comparison methods", "weinberg results long", "tab:INS_Lshape",
   "tab:morpi_Lshape").
"""
from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from . import dataset as ds
from . import steps as st
from .choice import choose
from .errors import DataError, MissingDataError, MorpiError, ParameterError
from .field import (
    MORPI_METHODS, LEVELED, RULES, FieldData, Gain, Selection, held_out_errors, trained_gain,
    nested_rule_comparison, select_config,
)
from .parallel import heap_frozen

__all__ = [
    "TABLES", "PAPER_CELLS", "PAPER_COMPARISON", "CellSpec", "RunResult", "Cell",
    "TablesResult", "evaluate_tables", "TablesStudy", "RecordingView", "TrackView", "tables_study",
    "training_gain_spread", "rule_sensitivity", "comparison", "ins_full_span", "ins_leveled", "other_rule",
    "DEVIATION_PP", "check_cells", "dataset_problems", "heading_readings", "turn_reading", "rule_json",
    "short_route_sets",
]

# --------------------------------------------------------------------------- the paper's numbers

#: JSON table names, in the paper's order, with the .tex label of each.
TABLES = {
    "ins_straight": "INS results",
    "short_route": "weinberg results short",
    "long_route": "weinberg results long",
    "ins_l_shape": "tab:INS_Lshape",
    "morpi_l_shape": "tab:morpi_Lshape",
}

#: Every table cell of the paper: (table, phone, p2p [m], method, calibration, end-point error [%]).
#: Copied from morpi-paper.tex, tables labelled as in :data:`TABLES`.
PAPER_CELLS = (
    # \label{INS results}: s8 straight line, 6.3 m
    ("ins_straight", "s8", None, "INS-3D", "RD", 53.7), ("ins_straight", "s8", None, "INS-3D", "GAC", 53.1),
    ("ins_straight", "s8", None, "INS-2D", "RD", 62.0), ("ins_straight", "s8", None, "INS-2D", "GAC", 28.6),
    # \label{weinberg results short}: test split, 6.3 m
    ("short_route", "s8", 1.0, "MoRPI-A", "RD", 8.25), ("short_route", "s8", 1.0, "MoRPI-A", "GC", 5.87),
    ("short_route", "s8", 1.0, "MoRPI-G", "RD", 7.94), ("short_route", "s8", 1.0, "MoRPI-G", "GC", 4.76),
    ("short_route", "s8", 1.5, "MoRPI-A", "RD", 9.84), ("short_route", "s8", 1.5, "MoRPI-A", "GC", 8.25),
    ("short_route", "s8", 1.5, "MoRPI-G", "RD", 9.05), ("short_route", "s8", 1.5, "MoRPI-G", "GC", 6.67),
    ("short_route", "s6", 1.0, "MoRPI-A", "RD", 7.30), ("short_route", "s6", 1.0, "MoRPI-A", "GC", 7.14),
    ("short_route", "s6", 1.0, "MoRPI-G", "RD", 4.60), ("short_route", "s6", 1.0, "MoRPI-G", "GC", 4.60),
    # \label{weinberg results long}: outdoor, 13 m, indoor 1 m gains
    ("long_route", "s8", 1.0, "MoRPI-A", "RD", 7.15), ("long_route", "s8", 1.0, "MoRPI-A", "GC", 5.62),
    ("long_route", "s8", 1.0, "MoRPI-G", "RD", 5.85), ("long_route", "s8", 1.0, "MoRPI-G", "GC", 4.46),
    ("long_route", "s6", 1.0, "MoRPI-A", "RD", 8.62), ("long_route", "s6", 1.0, "MoRPI-A", "GC", 8.46),
    ("long_route", "s6", 1.0, "MoRPI-G", "RD", 4.77), ("long_route", "s6", 1.0, "MoRPI-G", "GC", 4.15),
    # \label{tab:INS_Lshape}: s6 L route in straight lines, 28 m
    ("ins_l_shape", "s6", None, "INS-3D", "RD", 1123.0), ("ins_l_shape", "s6", None, "INS-3D", "GAC", 161.0),
    ("ins_l_shape", "s6", None, "INS-2D", "RD", 1523.0), ("ins_l_shape", "s6", None, "INS-2D", "GAC", 156.0),
    # \label{tab:morpi_Lshape}: s6 L route in periodic motion, s6 indoor gains
    ("morpi_l_shape", "s6", 1.0, "MoRPI-A", "RD", 18.97), ("morpi_l_shape", "s6", 1.0, "MoRPI-A", "GC", 16.14),
    ("morpi_l_shape", "s6", 1.0, "MoRPI-G", "RD", 8.63), ("morpi_l_shape", "s6", 1.0, "MoRPI-G", "GC", 8.2),
)

#: \label{tab:comparison methods}: mean position error [m] of the best calibration of each method
#: on the 6.3 m indoor route, and the improvement between methods, which the paper computes as the
#: difference of the end-point errors in percentage points (53.1 - 28.6 = 24.5 for 2D vs 3D INS).
PAPER_COMPARISON = {
    "label": "tab:comparison methods",
    "error_m": {"INS-3D": 3.34, "INS-2D": 1.80, "MoRPI-A": 0.37, "MoRPI-G": 0.29},
    "improvement_pp": {("INS-2D", "INS-3D"): 24.5, ("MoRPI-A", "INS-3D"): 47.2, ("MoRPI-A", "INS-2D"): 22.7,
                       ("MoRPI-G", "INS-3D"): 48.5, ("MoRPI-G", "INS-2D"): 24.0, ("MoRPI-G", "MoRPI-A"): 1.27},
}

#: The INS methods, in the tables' order.
INS_METHODS = ("INS-3D", "INS-2D")


@dataclass(frozen=True)
class CellSpec:
    """Where a cell's recordings and gains come from.

    Attributes
    ----------
    table, phone, method, calibration : str
    p2p_m : float or None
    paper_percent : float
    route : str
        Route folder of the evaluated runs.
    split : str or None
        ``"test"`` or None (folders without a split).
    train : tuple or None
        (phone, route) of the training set of the gains; None for INS cells.
    """

    table: str
    phone: str
    p2p_m: float | None
    method: str
    calibration: str
    paper_percent: float
    route: str
    split: str | None
    train: tuple | None

    @property
    def label(self) -> str:
        p2p = f" {self.p2p_m:g} m" if self.p2p_m is not None else ""
        return f"{self.table} {self.phone}{p2p} {self.method} {self.calibration}"


def cell_specs() -> list[CellSpec]:
    """The 32 cells with their data sources.

    Examples
    --------
    >>> specs = cell_specs()
    >>> len(specs), specs[0].label
    (32, 'ins_straight s8 INS-3D RD')
    """
    out = []
    for table, phone, p2p, method, cal, pct in PAPER_CELLS:
        if table == "ins_straight":
            route, split, train = "line_dataset", None, None
        elif table == "ins_l_shape":
            route, split, train = "L_line", None, None
        elif table == "short_route":
            route = "short_distance" if p2p == 1.0 else "short_distance_1.5p2p"
            split, train = "test", (phone, route)
        elif table == "long_route":
            route, split, train = "long_distance", "test", (phone, "short_distance")
        else:
            route, split, train = "L_shape", "test", ("s6", "short_distance")
        out.append(CellSpec(table, phone, p2p, method, cal, pct, route, split, train))
    return out


def short_route_sets(data: FieldData) -> list:
    """The short-route training sets of the paper's tables: ``(phone, route, p2p_m)`` of each of the dataset's
    train sets (:meth:`~morpi_filters.field.FieldData.train_sets`, in the manifest's order) that trains a cell of
    the short-route table (:func:`cell_specs`).

    Parameters
    ----------
    data : FieldData
        The dataset.

    Returns
    -------
    list of tuple
        ``(phone, route, p2p_m)`` per set.
    """
    p2p = {s.train: s.p2p_m for s in cell_specs() if s.table == "short_route"}
    return [(t.phone, t.route, p2p[(t.phone, t.route)]) for t in data.train_sets() if (t.phone, t.route) in p2p]


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class RunResult:
    """One run of a cell.

    Attributes
    ----------
    file : str
        Path relative to the dataset root.
    end_point : tuple of float
        Estimated end point (x, y) [m].
    end_error_m, end_error_percent : float
        Distance to the true end point [m] and in % of the travelled distance.
    distance_m, distance_error_percent : float
        Estimated travelled distance [m] and ``|estimate - truth|`` in %.
    n_steps : int or None
        Steps used (MoRPI), partial end steps included.
    rest_window_s, motion_window_s : tuple of float or None
        The detected initial rest window (None when the recording has none:
        :meth:`FieldData.no_rest`) and the motion window the run used, each
        (start, end) in seconds of the recording's own time.
    """

    file: str
    end_point: tuple
    end_error_m: float
    end_error_percent: float
    distance_m: float
    distance_error_percent: float
    n_steps: int | None = None
    rest_window_s: tuple | None = None
    motion_window_s: tuple | None = None


@dataclass(frozen=True)
class Cell:
    """One table cell: the paper's value and ours.

    Attributes
    ----------
    spec : CellSpec
    runs : tuple of RunResult
    gain : float or None
        Gain used (MoRPI).
    failed : tuple of str
        One line per run that could not be evaluated.
    missing : str or None
        Why the cell could not be computed (data absent).
    """

    spec: CellSpec
    runs: tuple
    gain: float | None = None
    failed: tuple = ()
    missing: str | None = None

    @property
    def ours_percent(self) -> float | None:
        """Mean end-point error over the runs [% of travelled distance]."""
        return float(np.mean([r.end_error_percent for r in self.runs])) if self.runs else None

    @property
    def ours_std_percent(self) -> float | None:
        return float(np.std([r.end_error_percent for r in self.runs])) if self.runs else None

    @property
    def ours_m(self) -> float | None:
        """Mean end-point error [m]."""
        return float(np.mean([r.end_error_m for r in self.runs])) if self.runs else None

    @property
    def distance_percent(self) -> float | None:
        """Mean distance error [% of travelled distance]."""
        return float(np.mean([r.distance_error_percent for r in self.runs])) if self.runs else None

    @property
    def deviation_pp(self) -> float | None:
        """ours - paper [percentage points]."""
        o = self.ours_percent
        return None if o is None else o - self.spec.paper_percent


@dataclass(frozen=True)
class TablesResult:
    """Everything :func:`evaluate_tables` computed.

    Attributes
    ----------
    cells : tuple of Cell
    gains : tuple of Gain
    selections : dict
        Method -> Selection.
    readings : tuple of dict
        Short-route GC cells under the alternative readings of the paper.
    missing : tuple of str
        Dataset folders that were absent.
    """

    cells: tuple
    gains: tuple
    selections: dict
    readings: tuple
    missing: tuple
    data: "FieldData" = field(repr=False, default=None)
    rule: str = "per_method"

    def cell(self, table, phone, p2p_m, method, calibration) -> Cell:
        for c in self.cells:
            s = c.spec
            if (s.table, s.phone, s.p2p_m, s.method, s.calibration) == (table, phone, p2p_m, method, calibration):
                return c
        raise KeyError((table, phone, p2p_m, method, calibration))

    def gain(self, phone, route, method, calibration) -> Gain | None:
        for g in self.gains:
            if (g.phone, g.route, g.method, g.calibration) == (phone, route, method, calibration):
                return g
        return None


# --------------------------------------------------------------------------- data access with caches

def rule_sensitivity(result: TablesResult) -> list[dict]:
    """How the step rules the search tried move the short-route GC cells.

    For every config the search scored for a method (:attr:`Selection.trials`):
    the method's own train leave-one-out error, the paired difference to the selected
    rule's with its standard error (over the same train runs), and the three
    short-route GC test cells with the gains trained under it. The train
    columns are what the choice sees; the test cells are shown, never used.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    list of dict
        One row per (method, config), best train score first: ``method``,
        ``config`` (the StepConfig fields), ``selected``,
        ``train_loo_percent`` [%], ``train_difference_pp`` and
        ``train_difference_se_pp`` [pp] (None when not comparable), and
        ``cells``: per short-route set ``phone``, ``p2p_m`` [m],
        ``paper_percent`` and ``ours_percent`` [%].
    """
    data = result.data
    specs = {(s.phone, s.p2p_m, s.method): s for s in cell_specs()
             if s.table == "short_route" and s.calibration == "GC"}
    sets = short_route_sets(data)
    out = []
    for m in MORPI_METHODS:
        sel = result.selections[m]
        if not sel.trials:
            continue
        base = held_out_errors(data, m, sel.config)
        vecs = [(cfg, held_out_errors(data, m, cfg)) for cfg, _ in sel.trials]
        # the method's own train error (with one rule for both methods the search scored their mean)
        own = [(cfg, vec, float(vec.mean()) if vec is not None and vec.size else float("inf")) for cfg, vec in vecs]
        for cfg, vec, score in sorted(own, key=lambda t: t[2]):
            ok = base is not None and vec is not None and vec.size == base.size > 1
            d = vec - base if ok else np.full(1, np.nan)
            row = {"method": m, "config": rule_json(cfg), "selected": cfg == sel.config,
                   "train_loo_percent": score,
                   "train_difference_pp": float(np.mean(d)) if np.all(np.isfinite(d)) else None,
                   "train_difference_se_pp": (float(np.std(d, ddof=1) / np.sqrt(d.size))
                                              if d.size > 1 and np.all(np.isfinite(d)) else None),
                   "cells": []}
            for phone, route, p2p in sets:
                g = trained_gain(data, phone, route, "GC", m, cfg)
                c = _morpi_cell(data, specs[(phone, p2p, m)], cfg, g)
                row["cells"].append({"phone": phone, "p2p_m": p2p, "paper_percent": specs[(phone, p2p, m)].paper_percent,
                                     "ours_percent": c.ours_percent})
            out.append(row)
    return out


def _frozen_heap(study):
    """`study` run with the heap frozen (:func:`morpi_filters.parallel.heap_frozen`): its full collections
    walk only what it allocates, not the imported modules."""

    @functools.wraps(study)
    def run(*args, **kwargs):
        with heap_frozen():
            return study(*args, **kwargs)

    return run


# --------------------------------------------------------------------------- cells

def _run_result(rel, end, truth, distance, n_steps=None, data=None, rec=None, full_span=False) -> RunResult:
    d = np.array(end[:2], dtype=float) - truth.end_point_m
    e = math.sqrt(d.dot(d))                                     # numpy's norm: the same bits, less overhead
    rest = motion = None
    if data is not None:
        key = ("run windows", rec.source, full_span)            # the same for every cell of the recording
        windows = data.study_cache.get(key)
        if windows is None:
            # no rest window for a recording that moves from its first samples (evaluated under RD only)
            w = None if data.no_rest(rec) else data.rest_window(rec)
            motion = ((float(rec.time[0]), float(rec.time[-1])) if full_span
                      else tuple(float(v) for v in data.activity(rec)))
            windows = data.study_cache[key] = (None if w is None else (float(w.start_s), float(w.end_s)), motion)
        rest, motion = windows
    return RunResult(file=rel, end_point=(float(end[0]), float(end[1])), end_error_m=e,
                     end_error_percent=e / truth.distance_m * 100, distance_m=float(distance),
                     distance_error_percent=abs(distance - truth.distance_m) / truth.distance_m * 100,
                     n_steps=n_steps, rest_window_s=rest, motion_window_s=motion)


def _ins_cell(data: FieldData, spec: CellSpec) -> Cell:
    recs = data.recordings(spec.phone, spec.route, spec.split)
    bad = data.load_errors(spec.phone, spec.route, spec.split)
    if not recs:
        return Cell(spec, (), failed=tuple(bad), missing=f"{spec.phone}/{spec.route}: no recordings")
    truth = ds.route(spec.route)
    runs, failed = [], list(bad)
    for r in recs:
        try:
            res = data.ins(r, spec.calibration, spec.method)
        except MorpiError as exc:
            failed.append(str(exc))
            continue
        p = np.asarray(res.position)[:, :2]
        dist = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        runs.append(_run_result(data.relpath(r), p[-1], truth, dist, data=data, rec=r,
                                full_span=data.ins_span == "full"))
    return Cell(spec, tuple(runs), failed=tuple(failed))


def _morpi_cell(data: FieldData, spec: CellSpec, config, gain: Gain | None) -> Cell:
    # the report's alternatives evaluate some cells under the rule and gain the tables already used
    key = ("MoRPI cell", spec, config, None if gain is None else gain.mean)
    cell = data.study_cache.get(key)
    if cell is None:
        cell = data.study_cache[key] = _evaluate_morpi_cell(data, spec, config, gain)
    return cell


def _evaluate_morpi_cell(data: FieldData, spec: CellSpec, config, gain: Gain | None) -> Cell:
    folder = f"{spec.phone}/{spec.route}/{spec.split}"
    if gain is None:
        return Cell(spec, (), missing=f"{spec.train[0]}/{spec.train[1]}/train: no training runs for the gain")
    recs = data.recordings(spec.phone, spec.route, spec.split)
    bad = data.load_errors(spec.phone, spec.route, spec.split)
    if not recs:
        return Cell(spec, (), gain=gain.mean, failed=tuple(bad), missing=f"{folder}: no recordings")
    truth = ds.route(spec.route)
    runs, failed = [], list(bad)
    G = gain.mean
    for r in recs:
        try:
            w, ux, uy, _, n = data.step_sums(r, spec.calibration, spec.method, config)
        except MorpiError as exc:
            failed.append(str(exc))
            continue
        # the end point is linear in the gain (steps.step_sums): the track's end, to rounding
        runs.append(_run_result(data.relpath(r), (G * ux, G * uy), truth, G * w, n, data=data, rec=r))
    return Cell(spec, tuple(runs), gain=gain.mean, failed=tuple(failed))


@_frozen_heap
def evaluate_tables(root, *, include_test: bool = True, configs: dict | None = None,
                    data: FieldData | None = None, ins_span: str = "motion", rule: str = "per_method",
                    alternatives: bool = True, ins: bool = True) -> TablesResult:
    """Compute every table cell of the paper on a dataset root.

    Parameters
    ----------
    root : path
        Dataset root (MoRPI layout); missing folders leave their cells empty.
    include_test : bool
        False hides the test folders (the gains and configs must not change).
    configs : dict, optional
        Method -> StepConfig to use instead of :func:`select_config`.
    data : FieldData, optional
        Reuse caches.
    ins_span : str
        INS integration span (:class:`FieldData`).
    rule : str
        ``"per_method"`` (default): each method's own rule
        (:func:`select_config`), the choice the nested train-only check
        prefers (:func:`nested_rule_comparison`); ``"joint"``: one step rule
        for both methods.
    alternatives : bool
        Also compute the short-route cells under every reading.
    ins : bool
        Also compute the INS cells (without: the MoRPI cells only).

    Returns
    -------
    TablesResult
    """
    data = data or FieldData(root, include_test=include_test, ins_span=ins_span)
    present = data.folders()
    missing = []
    for folder in ds.layout():
        parts = folder.split("/")
        key = (parts[0], parts[1], parts[2] if len(parts) == 3 else None)
        if key not in present and (include_test or key[2] != "test"):
            missing.append(folder)
    if rule not in RULES:
        raise ParameterError(f"rule={rule!r}: expected one of {RULES}")
    selections = {}
    joint = select_config(data) if rule == "joint" and not configs else None
    for m in MORPI_METHODS:
        if configs and m in configs:
            selections[m] = Selection(m, configs[m], float("nan"), (), 0)
        else:
            selections[m] = joint if joint is not None else select_config(data, m)
    gains = []
    for (phone, route, _), m, mode in itertools.product(short_route_sets(data), MORPI_METHODS, ("RD", "GC")):
        g = trained_gain(data, phone, route, mode, m, selections[m].config)
        if g is not None:
            gains.append(g)
    gmap = {(g.phone, g.route, g.method, g.calibration): g for g in gains}
    cells = []
    for spec in cell_specs():
        if spec.method in INS_METHODS:
            if ins:
                cells.append(_ins_cell(data, spec))
        else:
            g = gmap.get((spec.train[0], spec.train[1], spec.method, spec.calibration))
            cells.append(_morpi_cell(data, spec, selections[spec.method].config, g))
    readings = _alternative_readings(data, selections) if alternatives else []
    return TablesResult(tuple(cells), tuple(gains), selections, tuple(readings), tuple(missing), data, rule)


def training_gain_spread(source, result: TablesResult | None = None) -> tuple[float, float]:
    """Run-to-run spread of the trained Weinberg gains, for Monte Carlo gain-error studies.

    Every training run of the short routes (GC calibration, both methods) has
    its own gain, the one that makes its steps add up to the known distance.
    Applying the training-set mean to a run is then a relative gain error of
    ``G_mean / G_run - 1``. This returns the pooled root-mean-square of that
    error over all training sets and both methods (the spread), and its mean
    (the mismatch, close to zero by construction: the gain is applied to the
    motion it was trained on). Only train folders are read.

    Parameters
    ----------
    source : results.DataSource
        A dataset in the MoRPI layout.
    result : TablesResult, optional
        An evaluation of the same root to take the gains from (they are
        trained on the train folders only, so they are the same with or
        without the test folders).

    Returns
    -------
    spread, mismatch : float
        Fractions of the gain.
    """
    res = result if result is not None else evaluate_tables(source.root, include_test=False, alternatives=False)
    rel = [g.mean / np.asarray(g.per_run, dtype=float) - 1.0
           for g in res.gains if g.calibration == "GC" and len(g.per_run) > 1]
    if not rel:
        raise DataError(f"{source.root}: no short-route training runs, expected folders like s8/short_distance/train")
    rel = np.concatenate(rel)
    return float(np.sqrt(np.mean(rel ** 2))), float(np.mean(rel))


def _alternative_readings(data: FieldData, selections) -> list[dict]:
    """Short-route cells under each reading of the paper, other tunables as selected.

    GC: every combination of the three readings; RD: the three heading readings with the
    selected step boundaries (the heading is what the raw gyro changes).
    """
    out = []
    specs = cell_specs()
    sets = short_route_sets(data)
    for m, mode in itertools.product(MORPI_METHODS, ("GC", "RD")):
        base = selections[m].config
        for h, sg, e in itertools.product(st.HEADINGS, st.SEGMENTS, st.ENDS):
            if mode == "RD" and (sg, e) != (base.segment, base.ends):
                continue  # raw data: only the heading readings, with the selected step boundaries
            cfg = base.with_(heading=h, segment=sg, ends=e)
            row = {"method": m, "calibration": mode, "heading": h, "segment": sg, "ends": e,
                   "selected": cfg == base, "cells": []}
            for phone, route, p2p in sets:
                spec = next(s for s in specs if (s.table, s.phone, s.p2p_m, s.method, s.calibration)
                            == ("short_route", phone, p2p, m, mode))
                g = trained_gain(data, phone, route, mode, m, cfg)
                c = _morpi_cell(data, spec, cfg, g)
                row["cells"].append({"phone": phone, "p2p_m": p2p, "paper_percent": spec.paper_percent,
                                     "ours_percent": c.ours_percent, "distance_percent": c.distance_percent})
            out.append(row)
    return out


# --------------------------------------------------------------------------- comparison and alternatives

def comparison(result: TablesResult) -> dict:
    """The paper's method comparison (6.3 m indoor route) recomputed from our cells.

    The best calibration of each method (GAC for the INS on the straight
    line, GC for MoRPI); for MoRPI the short-route set with the lowest error,
    as the paper's 0.37 m and 0.29 m are its best GC cells (s8 1 m MoRPI-A,
    s6 1 m MoRPI-G). Improvements are percentage-point differences of the
    end-point errors, as in the paper.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    dict
        ``label`` (the paper's route) and ``rows``: one dict per method with
        ``method``, ``paper_error_m`` [m], ``ours_error_m`` [m],
        ``ours_percent`` [%], ``cell`` (the cell's label) and
        ``improvement_pp``: earlier method -> ``paper`` and ``ours`` [pp]
        (None when not available).
    """
    best = {}
    for m in INS_METHODS:
        c = result.cell("ins_straight", "s8", None, m, "GAC")
        if c.runs:
            best[m] = c
    for m in MORPI_METHODS:
        cs = [c for c in result.cells if c.spec.table == "short_route" and c.spec.method == m
              and c.spec.calibration == "GC" and c.runs]
        if cs:
            best[m] = cs[choose([c.ours_percent for c in cs])]        # the first of ties (choice.choose)
    rows = []
    order = list(INS_METHODS) + list(MORPI_METHODS)
    for m in order:
        c = best.get(m)
        row = {"method": m, "paper_error_m": PAPER_COMPARISON["error_m"][m],
               "ours_error_m": c.ours_m if c else None, "ours_percent": c.ours_percent if c else None,
               "cell": c.spec.label if c else None, "improvement_pp": {}}
        for other in order[:order.index(m)]:
            key = (m, other)
            o = best.get(other)
            row["improvement_pp"][other] = {
                "paper": PAPER_COMPARISON["improvement_pp"].get(key),
                "ours": (o.ours_percent - c.ours_percent) if (c and o) else None}
        rows.append(row)
    return {"label": PAPER_COMPARISON["label"], "rows": rows}


def ins_full_span(result: TablesResult) -> list[dict]:
    """The INS cells again with the whole recording integrated (rests included).

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    list of dict
        One per INS cell with runs: ``table``, ``method``, ``calibration``,
        ``paper_percent``, ``motion_span_percent`` and ``full_span_percent``
        (mean end-point error, None when no run integrates) [%].
    """
    data = result.data
    out = []
    for c in result.cells:
        if c.spec.method not in INS_METHODS or not c.runs:
            continue
        truth = ds.route(c.spec.route)
        errs = []
        for r in data.recordings(c.spec.phone, c.spec.route, c.spec.split):
            try:
                p = np.asarray(data.ins(r, c.spec.calibration, c.spec.method, span="full").position)[:, :2]
            except MorpiError:
                continue
            errs.append(np.linalg.norm(p[-1] - truth.end_point_m) / truth.distance_m * 100)
        out.append({"table": c.spec.table, "method": c.spec.method, "calibration": c.spec.calibration,
                    "paper_percent": c.spec.paper_percent, "motion_span_percent": c.ours_percent,
                    "full_span_percent": float(np.mean(errs)) if errs else None})
    return out


def ins_leveled(result: TablesResult) -> list[dict]:
    """The 3D INS cells again, started from the tilt measured at rest instead of a level phone.

    The paper's GAC assumes the phone lies level and takes the whole rest
    specific force minus gravity as accelerometer bias. On a slope (the L
    route starts on one) that bias is really gravity, and it turns into a
    false acceleration as soon as the slope ends. Here the gyro is
    zero-order calibrated, the initial roll and pitch come from
    :func:`morpi_filters.strapdown.coarse_level`, and the accelerometer is
    left as it is.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    list of dict
        One per 3D INS GAC cell with runs: ``table``, ``phone``,
        ``paper_gac_percent``, ``gac_percent`` and ``leveled_percent`` [%],
        ``mean_rest_tilt_deg`` [deg] (None without runs) and ``runs``.
    """
    data = result.data
    out = []
    for c in result.cells:
        if c.spec.method != "INS-3D" or c.spec.calibration != "GAC" or not c.runs:
            continue
        truth = ds.route(c.spec.route)
        errs, tilts = [], []
        for r in data.recordings(c.spec.phone, c.spec.route, c.spec.split):
            try:
                p = np.asarray(data.ins(r, LEVELED, "INS-3D").position)[:, :2]
            except MorpiError:
                continue
            f_rest = data.rest_specific_force(r)
            tilts.append(np.degrees(np.arccos(np.clip(f_rest[2] / np.linalg.norm(f_rest), -1.0, 1.0))))
            errs.append(np.linalg.norm(p[-1] - truth.end_point_m) / truth.distance_m * 100)
        out.append({"table": c.spec.table, "phone": c.spec.phone, "paper_gac_percent": c.spec.paper_percent,
                    "gac_percent": c.ours_percent, "leveled_percent": float(np.mean(errs)) if errs else None,
                    "mean_rest_tilt_deg": float(np.mean(tilts)) if tilts else None, "runs": len(errs)})
    return out


def other_rule(result: TablesResult, rule: str | None = None) -> dict:
    """The MoRPI cells again under another way of choosing the step rule.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.
    rule : str, optional
        One of :data:`morpi_filters.field.RULES`; default: the one `result`
        did not use.

    Returns
    -------
    dict
        ``rule``; ``step_rule``: method -> ``config`` (the StepConfig fields)
        and ``train_loo_percent`` [%]; ``cells``: one dict per MoRPI cell with
        ``table``, ``phone``, ``p2p_m`` [m], ``method``, ``calibration``,
        ``paper_percent``, ``ours_percent`` and ``distance_error_percent`` [%].
    """
    if rule is None:
        rule = next(r for r in RULES if r != result.rule)
    alt = evaluate_tables(result.data.root, data=result.data, rule=rule, alternatives=False)
    return {"rule": rule,
            "step_rule": {m: {"config": rule_json(s.config), "train_loo_percent": s.score}
                          for m, s in alt.selections.items()},
            "cells": [{"table": c.spec.table, "phone": c.spec.phone, "p2p_m": c.spec.p2p_m, "method": c.spec.method,
                       "calibration": c.spec.calibration, "paper_percent": c.spec.paper_percent,
                       "ours_percent": c.ours_percent, "distance_error_percent": c.distance_percent}
                      for c in alt.cells if c.spec.method in MORPI_METHODS]}


def heading_readings(result: TablesResult) -> dict:
    """Every MoRPI cell under the two heading sources and the two heading origins.

    The heading source is part of the step rule the train runs choose
    (:attr:`morpi_filters.steps.StepConfig.heading_source`, searched by
    :func:`morpi_filters.field.select_config`): ``"gyro"``, the z gyro
    integrated from the motion window's start, or ``"attitude"``, the yaw of
    the attitude matrix of the 3D mechanization started with the roll and
    pitch of the rest specific force (the paper's heading equation). Here
    every MoRPI cell is shown under both, from the motion window's start, and
    under the chosen source integrated from the first sample, through the
    initial rest (``from_start``, the project's earlier reading). The other
    fields of the step rules are the chosen ones; the gains are retrained under
    each reading on the train runs, as the detection thresholds are kept.
    ``train`` gives what the choice saw: per method, the leave-one-out train
    error of the chosen rule under each source, and their paired difference
    (attitude minus gyro) with its standard error over the train runs.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    dict
        ``used``: ``heading_from`` and, per method, the chosen
        ``heading_source``; ``cells``: one dict per MoRPI cell with ``table``,
        ``phone``, ``p2p_m`` [m], ``method``, ``calibration``,
        ``paper_percent``, ``chosen_source``, ``from_motion_percent`` (the
        cell of the tables), ``gyro_percent``, ``attitude_percent`` and
        ``from_start_percent`` [%]; ``train``: method -> ``chosen_source``,
        ``gyro_loo_percent``, ``attitude_loo_percent`` [%],
        ``difference_pp``, ``difference_se_pp`` [pp] and ``n_train_runs``.
    """
    from .field import HEADING_SOURCES, FieldData

    data = result.data
    chosen = {m: s.config for m, s in result.selections.items()}
    under = {}
    for h in HEADING_SOURCES:
        cfgs = {m: c.with_(heading_source=h) for m, c in chosen.items()}
        under[h] = cfgs, (result if cfgs == chosen
                          else evaluate_tables(data.root, data=data, configs=cfgs, alternatives=False))
    start = FieldData.sharing(data, heading_from="start")
    from_start = evaluate_tables(data.root, data=start, configs=chosen, alternatives=False)
    cells = []
    for c in result.cells:
        s = c.spec
        if s.method not in MORPI_METHODS:
            continue
        key = (s.table, s.phone, s.p2p_m, s.method, s.calibration)
        cells.append({"table": s.table, "phone": s.phone, "p2p_m": s.p2p_m, "method": s.method,
                      "calibration": s.calibration, "paper_percent": s.paper_percent,
                      "chosen_source": chosen[s.method].heading_source, "from_motion_percent": c.ours_percent,
                      **{f"{h}_percent": under[h][1].cell(*key).ours_percent for h in HEADING_SOURCES},
                      "from_start_percent": from_start.cell(*key).ours_percent})
    train = {}
    for m in MORPI_METHODS:
        g = held_out_errors(data, m, under["gyro"][0][m])
        a = held_out_errors(data, m, under["attitude"][0][m])
        ok = g is not None and a is not None and g.size == a.size > 1
        d = a - g if ok else None
        train[m] = {"chosen_source": chosen[m].heading_source,
                    "gyro_loo_percent": None if g is None or not g.size else float(g.mean()),
                    "attitude_loo_percent": None if a is None or not a.size else float(a.mean()),
                    "difference_pp": float(d.mean()) if ok else None,
                    "difference_se_pp": float(d.std(ddof=1) / np.sqrt(d.size)) if ok else None,
                    "n_train_runs": int(g.size) if g is not None else 0}
    return {"used": {"heading_from": data.heading_from,
                     "heading_source": {m: c.heading_source for m, c in chosen.items()}},
            "cells": cells, "train": train}


def turn_reading(result: TablesResult) -> dict:
    """The long-route and L-route MoRPI cells under every heading reading, with the turn threshold.

    Each MoRPI cell of the long route and the L route is recomputed with the
    chosen step rule of its method and the heading reading replaced by each of
    :data:`morpi_filters.steps.HEADINGS` (``"change"``: the step's own heading
    change; ``"turns"``: that plus the turns so far), gains retrained under
    each on the train runs. ``train`` gives each reading's leave-one-out train
    error per method (what the search sees); ``threshold`` where the turn
    threshold comes from (:func:`morpi_filters.field.train_thresholds`); and
    ``l_route_turns_deg`` the turn the ``"turns"`` reading finds in each L-route
    test run (GC), against the route's turn. The test cells are shown, never
    used for a choice.

    Parameters
    ----------
    result : TablesResult
        The field evaluation (:func:`evaluate_tables`), whose data and caches are reused.

    Returns
    -------
    dict
        ``threshold``: ``turn_deg`` [deg], ``margin``,
        ``largest_train_period_change_deg`` [deg] and ``n_train_values``;
        ``headings``; ``cells``: one dict per long-route and L-route MoRPI
        cell with ``table``, ``phone``, ``p2p_m`` [m], ``method``,
        ``calibration``, ``paper_percent``, ``chosen_heading``,
        ``chosen_percent`` and ``<heading>_percent`` per heading reading
        (``absolute_percent``, ``mean_percent``, ``change_percent``,
        ``turns_percent``) [%]; ``train``: method -> heading -> leave-one-out
        train error [%]; ``route_turn_deg`` [deg]; ``l_route_turns_deg``:
        method -> one dict per L-route test run with ``file``,
        ``stretches`` and ``turn_deg`` [deg].
    """
    from .field import TURN_MARGIN

    data = result.data
    chosen = {m: s.config for m, s in result.selections.items()}
    under = {}
    for h in st.HEADINGS:
        cfgs = {m: c.with_(heading=h) for m, c in chosen.items()}
        under[h] = cfgs, evaluate_tables(data.root, data=data, configs=cfgs, alternatives=False)
    cells = []
    for c in result.cells:
        s = c.spec
        if s.method not in MORPI_METHODS or s.table not in ("long_route", "morpi_l_shape"):
            continue
        key = (s.table, s.phone, s.p2p_m, s.method, s.calibration)
        cells.append({"table": s.table, "phone": s.phone, "p2p_m": s.p2p_m, "method": s.method,
                      "calibration": s.calibration, "paper_percent": s.paper_percent,
                      "chosen_heading": chosen[s.method].heading, "chosen_percent": c.ours_percent,
                      **{f"{h}_percent": under[h][1].cell(*key).ours_percent for h in st.HEADINGS}})
    train = {m: {h: (lambda v: None if v is None or not v.size else float(v.mean()))(
        held_out_errors(data, m, under[h][0][m])) for h in st.HEADINGS} for m in MORPI_METHODS}
    th = data.thresholds
    turns = {}
    truth = ds.route("L_shape")
    for m in MORPI_METHODS:
        cfg = under["turns"][0][m]
        found = []
        for r in data.recordings("s6", "L_shape", "test"):
            try:
                s = data.steps(r, "GC", m, cfg)
            except MorpiError:
                continue
            psi = data.heading(r, "GC", cfg.heading_source)
            bt = s.peaks.grid_time[s.peaks.grid_index]
            stretches = st.turn_stretches(bt, np.interp(bt, r.time, psi), np.radians(cfg.turn_deg),
                                          2 if cfg.segment == "extrema" else 1)
            found.append({"file": data.relpath(r), "stretches": len(stretches),
                          "turn_deg": float(np.degrees(st.turn_heading([r.time[-1]], r.time, psi, stretches)[0]))})
        turns[m] = found
    return {"threshold": {"turn_deg": th.turn_deg, "margin": TURN_MARGIN,
                          "largest_train_period_change_deg": max(th.period_changes_deg) if th.period_changes_deg
                          else None, "n_train_values": len(th.period_changes_deg)},
            "headings": list(st.HEADINGS), "cells": cells, "train": train,
            "route_turn_deg": truth.turn_deg, "l_route_turns_deg": turns}


# --------------------------------------------------------------------------- checks and shared pieces

#: Cells further than this from the paper are listed and explained on the page [percentage points].
#: The acceptance bar of the reproduction (2.5 pp on the short-route GC cells).
DEVIATION_PP = 2.5


def rule_json(cfg: st.StepConfig) -> dict:
    """A step rule as the JSON of the tables shows it: its readings and tunables by name.

    Parameters
    ----------
    cfg : StepConfig
        The rule.

    Returns
    -------
    dict
        Field name -> value, for the fields the tables' JSON lists.

    Examples
    --------
    >>> from morpi_filters.steps import StepConfig
    >>> rule_json(StepConfig())["heading"]
    'mean'
    """
    return {k: getattr(cfg, k) for k in ("heading", "segment", "ends", "min_period_s", "prominence",
                                          "cutoff_hz", "amplitude_from", "turn_deg", "heading_source")}


def _heading_stats(c: Cell, res: TablesResult) -> tuple[float, float]:
    """(mean heading drift of the raw z-gyro bias over the motion, mean |GC heading at the end|) [deg]."""
    data = res.data
    drift, final = [], []
    for r in data.recordings(c.spec.phone, c.spec.route, c.spec.split):
        if data.no_rest(r):                                     # no gyro calibration without a rest
            continue
        crec, cal = data.calibrated(r, "GC")
        a, b = data.activity(r)
        drift.append(abs(np.degrees(cal.gyro_bias[2] * (b - a))))
        truth = ds.route(c.spec.route)
        turn = truth.turn_deg if len(truth.segments_m) > 1 else 0.0
        final.append(abs(np.degrees(st.integrate_heading(crec.time, crec.omega[:, 2])[-1]) - turn))
    return (float(np.mean(drift)), float(np.mean(final))) if drift else (float("nan"), float("nan"))


#: Largest value a table cell (or one of its runs) may show [% of the route distance]. A
#: recording within the loader's limits (|f| <= dataset.ACCEL_LIMIT_MPS2) lasting under
#: 15 minutes cannot be double-integrated farther than 0.5 * 164.8 m/s^2 * (900 s)^2 = 6.7e7 m,
#: about 1e9 % of the shortest (6.3 m) route; the field recordings last at most 90 s and their
#: worst run is below 1e4 %. A value beyond it (or not finite) is a fault, not a result.
CELL_SANITY_PERCENT = 1e9


def dataset_problems(data: FieldData) -> list[str]:
    """One line per recording the tables need that is bad or missing.

    Loads every recording of `data` (cached for the evaluation) and lists the
    files that fail to load, then the differences from the expected layout
    (:func:`morpi_filters.dataset.layout_problems`: absent folders, missing
    runs, no recordings at all).

    Parameters
    ----------
    data : FieldData
        The dataset root to check.

    Returns
    -------
    list of str
        Load errors first, then layout problems; empty when the dataset is
        complete.
    """
    errors = []
    for phone, route, split in sorted(data.folders(), key=lambda k: (k[0], k[1], k[2] or "")):
        errors += data.load_errors(phone, route, split)
    return errors + ds.layout_problems(data.root, data._entries)


def _require_complete(problems: list[str], root) -> None:
    if problems:
        shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more" if len(problems) > 5 else "")
        raise DataError(f"{root}: {len(problems)} recording problem(s) the tables cannot go on with: {shown} "
                        "(run `morpi check` for the full list, or pass --partial to evaluate without them)")


def check_cells(result: TablesResult) -> None:
    """Raise DataError for a cell value that is not finite or beyond :data:`CELL_SANITY_PERCENT`.

    The message names the cell and its recordings. With the loader's input
    limits this does not happen; it guards against printing an absurd number.

    Parameters
    ----------
    result : TablesResult
        The field evaluation to check.

    Returns
    -------
    None
        Returns only when every cell with runs is finite and within bounds.

    Raises
    ------
    DataError
        Naming the first bad cell and its recordings.
    """
    def bad(v):
        return v is not None and not (math.isfinite(v) and abs(v) <= CELL_SANITY_PERCENT)

    for c in result.cells:
        if not c.runs:
            continue
        worst = [r.file for r in c.runs if bad(r.end_error_percent) or bad(r.distance_error_percent)]
        values = (c.ours_percent, c.ours_std_percent, c.distance_percent)
        if worst or any(bad(v) for v in values):
            files = worst or [r.file for r in c.runs]
            raise DataError(f"cell {c.spec.label}: end-point error {c.ours_percent} % is not finite or beyond "
                            f"{CELL_SANITY_PERCENT:g} %, not a result; recordings: {', '.join(files)}")




# --------------------------------------------------------------------------- the section's study

@dataclass(frozen=True)
class RecordingView:
    """One recording drawn on the tables page, with its rest window, motion span or step boundaries.

    Attributes
    ----------
    name : str
        PNG file name.
    title : str
        The recording's path relative to the dataset root.
    time : ndarray, shape (n,)
    f, omega : ndarray, shape (n, 3)
    rest : tuple of float or None
        Rest window (start, end) [s] (None: the recording has none).
    motion : tuple of float or None
        Motion span (start, end) [s] (straight-line recording).
    peaks : ndarray or None
        Step boundary times [s] (periodic recording).
    """

    name: str
    title: str
    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    rest: tuple
    motion: tuple | None = None
    peaks: np.ndarray | None = None


@dataclass(frozen=True)
class TrackView:
    """INS tracks of one run against the true route.

    Attributes
    ----------
    name : str
        PNG file name.
    title : str
    tracks : dict
        ``"<method> <calibration>"`` -> ndarray (k, 2) positions [m].
    truth : ndarray, shape (m, 2)
        True route polyline [m].
    """

    name: str
    title: str
    tracks: dict
    truth: np.ndarray


@dataclass(frozen=True)
class TablesStudy:
    """The tables section computed once: the evaluation and every comparison built on it.

    Attributes
    ----------
    result : TablesResult
    partial : bool
        Whether recordings with problems were left out instead of stopping.
    left_out : tuple of str
        One line per recording problem (:func:`dataset_problems`).
    no_rest : tuple of str
        One line per recording without an initial rest
        (:meth:`FieldData.no_rest`): evaluated under RD only, its GC and GAC
        runs are not computed (each cell names it among its failed runs).
    comparison : dict
        :func:`comparison`.
    ins_full_span : list of dict
        :func:`ins_full_span`.
    other_rule : dict
        :func:`other_rule`: the MoRPI cells under one step rule for both methods.
    nested : dict
        :func:`morpi_filters.field.nested_rule_comparison`.
    rule_sensitivity : list of dict
        :func:`rule_sensitivity`.
    ins_leveled : list of dict
        :func:`ins_leveled`.
    recordings : tuple of RecordingView
    tracks : tuple of TrackView
    path_panels : tuple of dict
        MoRPI paths (GC) of every test set: ``title``, ``truth`` (m, 2) and
        ``paths`` (label -> list of (k, 2) arrays).
    cell_notes : dict
        Label of each cell further than :data:`DEVIATION_PP` from the paper ->
        what its explanation quotes: ``heading_drift_deg`` and
        ``heading_final_deg`` (MoRPI: mean raw-gyro heading drift over the
        motion, mean absolute GC heading at the end minus the route's turn), or
        ``tilt_deg``, ``tilt_m`` and ``along_m`` (planar INS after GAC: mean
        tilt about y during the motion, its double-integrated share of
        gravity, mean along-track overshoot).
    claims : tuple of dict
        :func:`paper_claims`.
    heading_readings : dict
        :func:`heading_readings`.
    turn_reading : dict
        :func:`turn_reading`.
    """

    result: TablesResult
    partial: bool
    left_out: tuple
    comparison: dict
    ins_full_span: list
    other_rule: dict
    nested: dict
    rule_sensitivity: list
    ins_leveled: list
    recordings: tuple = ()
    tracks: tuple = ()
    path_panels: tuple = ()
    cell_notes: dict = field(default_factory=dict)
    claims: tuple = ()
    heading_readings: dict = field(default_factory=dict)
    turn_reading: dict = field(default_factory=dict)
    no_rest: tuple = ()


@_frozen_heap
def tables_study(root, *, partial: bool = False, result: TablesResult | None = None) -> TablesStudy:
    """Compute everything the tables section shows.

    Parameters
    ----------
    root : path
        Dataset root (MoRPI layout).
    partial : bool
        Go on when recordings are bad or missing (:func:`dataset_problems`);
        they are then listed under ``left_out``. Without it they raise a
        DataError naming them.
    result : TablesResult, optional
        The evaluation of `root` when it is already computed (``morpi report``
        evaluates the field data once for every section).

    Returns
    -------
    TablesStudy

    Raises
    ------
    DataError
        A bad or missing recording (unless `partial`), or an absurd cell
        (:func:`check_cells`).
    """
    if root is None:
        raise MissingDataError(f"tables: no dataset configured; {ds.missing_data_message()}")
    data = result.data if result is not None else FieldData(root)
    left_out = dataset_problems(data)
    if not partial:
        _require_complete(left_out, root)
    res = result if result is not None else evaluate_tables(root, data=data)
    check_cells(res)
    comp = comparison(res)
    full = ins_full_span(res)
    other = other_rule(res)
    nested = nested_rule_comparison(res.data)
    sens = rule_sensitivity(res)
    leveled = ins_leveled(res)
    recordings, tracks, panels = _figure_data(res)
    return TablesStudy(result=res, partial=bool(partial), left_out=tuple(left_out), comparison=comp,
                       ins_full_span=full, other_rule=other, nested=nested, rule_sensitivity=sens,
                       ins_leveled=leveled, recordings=recordings, tracks=tracks, path_panels=panels,
                       cell_notes=_cell_notes(res), claims=tuple(paper_claims(res)),
                       heading_readings=heading_readings(res), turn_reading=turn_reading(res),
                       no_rest=tuple(res.data.no_rest_lines()))


#: Agreement bands of :func:`paper_claims` (each with its reason).
#: A percentage claim agrees when ours is within 1 pp: the spread of our cells under the step rules
#: the train runs could not tell apart (:func:`rule_sensitivity`) is of that order.
CLAIM_PP = 1.0
#: A duration claim agrees within 15 %: the paper writes "about" and rounds to half seconds.
CLAIM_DURATION = 0.15
#: "The error increased in a linear manner": the long route's percentage within 25 % of the short one's.
CLAIM_LINEAR = 0.25


def paper_claims(res: TablesResult) -> list[dict]:
    """Every numeric claim of the paper's results and conclusions, ours beside it.

    Returns
    -------
    list of dict
        ``claim``, ``paper``, ``ours``, ``holds`` (None when ours cannot be computed) and
        ``evidence`` (one sentence: what ours is and how it was compared).
    """
    data = res.data
    out = []

    def add(claim, paper, ours, holds, evidence):
        out.append({"claim": claim, "paper": paper, "ours": ours, "holds": None if holds is None else bool(holds),
                    "evidence": evidence})

    def pct(table, phone, p2p, method, cal):
        try:
            return res.cell(table, phone, p2p, method, cal).ours_percent
        except (KeyError, StopIteration, MorpiError):
            return None

    recs = []
    for phone, route, split in sorted(data.folders(), key=lambda k: tuple(str(v) for v in k)):
        recs += [(phone, route, r) for r in data.recordings(phone, route, split)]
    minutes = sum(float(r.time[-1] - r.time[0]) for _, _, r in recs) / 60.0
    add("143 trajectories were recorded", 143, len(recs), len(recs) == 143,
        f"{len(recs)} recordings load under the dataset root.")
    add("with a total time of 75 minutes", 75.0, round(minutes, 1), abs(minutes - 75.0) <= 2.5,
        "Sum of the recordings' durations (first to last sample), agreeing within 2.5 min (the paper rounds).")
    n8 = sum(p == "s8" for p, _, _ in recs)
    add("83 recordings with the Samsung Galaxy S8 and 60 with the S6", [83, 60], [n8, len(recs) - n8],
        n8 == 83 and len(recs) - n8 == 60, "Recordings per phone folder.")
    indoor = sum(ds.route(route).environment == "indoor" for _, route, _ in recs)
    add("103 recordings indoors and 40 outdoors", [103, 40], [indoor, len(recs) - indoor],
        indoor == 103 and len(recs) - indoor == 40, "Recordings per route environment (data/routes.json).")
    for route, paper_s, label in (("short_distance", 14.5, "1 m"), ("short_distance_1.5p2p", 11.0, "1.5 m"),
                                  ("line_dataset", 5.0, "straight line")):
        d = [float(np.subtract(*data.activity(r)[::-1])) for _, rr, r in recs if rr == route]
        mean = float(np.mean(d)) if d else None
        add(f"the {label} trajectories last about {paper_s:g} s", paper_s, None if mean is None else round(mean, 2),
            None if mean is None else abs(mean - paper_s) <= CLAIM_DURATION * paper_s,
            f"Mean duration of the robot's motion (gyro vibration) over {len(d)} recordings, agreeing within 15 %.")
    ins = {(m, c): pct("ins_straight", "s8", None, m, c) for m in ("INS-3D", "INS-2D") for c in ("RD", "GAC")}
    known = {k: v for k, v in ins.items() if v is not None}
    best = list(known)[choose(list(known.values()))] if known else None
    add("2D INS with GAC is the best baseline, 28.6 % of the distance (1.8 m over 6.3 m)", 28.6,
        None if best is None else round(known[best], 2), None if best is None else best == ("INS-2D", "GAC"),
        "The straight-line INS cells; the best is "
        + ("-" if best is None else f"{best[0]} {best[1]} at {known[best]:.2f} %") + ".")
    a = [pct("short_route", p, 1.0, "MoRPI-A", "GC") for p in ("s8", "s6")]
    g = [pct("short_route", p, 1.0, "MoRPI-G", "GC") for p in ("s8", "s6")]
    ma = float(np.mean(a)) if None not in a else None
    mg = float(np.mean(g)) if None not in g else None
    add("MoRPI-A averages 6.5 % over the two phones", 6.5, None if ma is None else round(ma, 2),
        None if ma is None else abs(ma - 6.5) <= CLAIM_PP,
        "Mean of the s8 and s6 1 m short-route MoRPI-A GC cells, agreeing within 1 pp.")
    add("MoRPI-G averages 4.68 % over the two phones", 4.68, None if mg is None else round(mg, 2),
        None if mg is None else abs(mg - 4.68) <= CLAIM_PP,
        "Mean of the s8 and s6 1 m short-route MoRPI-G GC cells, agreeing within 1 pp.")
    short = {(p, m, c): pct("short_route", p, 1.0, m, c) for p in ("s8", "s6") for m in ("MoRPI-A", "MoRPI-G")
             for c in ("RD", "GC")}
    of_phone = {p: [(k, v) for k, v in short.items() if k[0] == p and v is not None] for p in ("s8", "s6")}
    best_g = [kv[choose([v for _, v in kv])][0] for kv in of_phone.values() if kv]
    add("MoRPI-G with GC is the best approach for both phones (4.60-4.76 %)", [4.60, 4.76],
        [None if v is None else round(v, 2) for v in g],
        len(best_g) == 2 and all(k[1:] == ("MoRPI-G", "GC") for k in best_g),
        "The lowest of the four 1 m short-route MoRPI cells of each phone.")
    factor = known[best] / mg if best is not None and mg else None
    add("MoRPI improves the best INS by a factor of five to six", 6.1, None if factor is None else round(factor, 2),
        None if factor is None else factor >= 5.0,
        "Best straight-line INS cell over the MoRPI-G average; holds at a factor of 5 or more.")
    s, lg = pct("short_route", "s8", 1.0, "MoRPI-G", "GC"), pct("long_route", "s8", 1.0, "MoRPI-G", "GC")
    add("the error grows linearly with distance (s8 MoRPI-G GC: 4.76 % over 6.3 m, 4.46 % over 13 m)", [4.76, 4.46],
        None if s is None or lg is None else [round(s, 2), round(lg, 2)],
        None if s is None or lg is None else abs(lg - s) <= CLAIM_LINEAR * s,
        "A constant percentage is a linear growth in metres; holds when the long route's percentage is within "
        "25 % of the short route's.")
    stds = [c.ours_std_percent / 100 * ds.route(c.spec.route).distance_m for c in res.cells
            if c.spec.table == "short_route" and c.runs]
    worst = max(stds) if stds else None
    add("the variance of the results in each short-route configuration is below 2.5 cm", 0.025,
        None if worst is None else round(worst, 3), None if worst is None else worst < 0.025,
        "Largest standard deviation of the per-run end-point errors over the short-route cells [m].")
    l_ins = [v for v in (pct("ins_l_shape", "s6", None, m, c) for m in ("INS-3D", "INS-2D") for c in ("RD", "GAC"))
             if v is not None]
    l_g = pct("morpi_l_shape", "s6", 1.0, "MoRPI-G", "GC")
    add("on the L route the best INS has 156 % and MoRPI-G 8.2 %", [156, 8.2],
        None if not l_ins or l_g is None else [round(min(l_ins), 1), round(l_g, 2)],
        None if not l_ins or l_g is None else (l_g <= 8.2 + CLAIM_PP and min(l_ins) > 10 * l_g),
        "Best L-route INS cell and the L-route MoRPI-G GC cell; holds when MoRPI-G is at 8.2 % or better (1 pp "
        "band) and beats the INS tenfold.")
    return out


def _figure_data(res: TablesResult):
    """What the page's figures draw: two recordings, INS tracks of two runs, the MoRPI paths of every test set."""
    data = res.data
    recordings = []
    # recordings: a straight line and a periodic run, with rest window and step boundaries
    for phone, route, split, name, method in (("s8", "line_dataset", None, "recording_line.png", None),
                                              ("s8", "short_distance", "test", "recording_periodic.png", "MoRPI-G")):
        recs = data.recordings(phone, route, split)
        if not recs:
            continue
        r = recs[0]
        w = None if data.no_rest(r) else data.rest_window(r)
        rest = None if w is None else (float(w.start_s), float(w.end_s))
        peaks = None
        if method:
            try:
                s = data.steps(r, "GC", method, res.selections[method].config)
                peaks = s.peaks.grid_time[s.peaks.grid_index]
            except MorpiError:
                pass
        recordings.append(RecordingView(name=name, title=data.relpath(r), time=r.time, f=r.f, omega=r.omega,
                                        rest=rest, motion=data.activity(r) if method is None else None, peaks=peaks))
    # INS trajectories: a typical straight run and an L run
    tracks = []
    for route, name in (("line_dataset", "ins_straight.png"), ("L_line", "ins_l_shape.png")):
        phone = "s8" if route == "line_dataset" else "s6"
        recs = data.recordings(phone, route, None)
        if not recs:
            continue
        cell = res.cell("ins_straight" if route == "line_dataset" else "ins_l_shape", phone, None, "INS-2D", "GAC")
        errs = [x.end_error_percent for x in cell.runs]
        r = recs[int(np.argsort(errs)[len(errs) // 2])] if errs else recs[0]
        ins = {}
        for m, mode in itertools.product(INS_METHODS, ("RD", "GAC")):
            try:
                ins[f"{m} {mode}"] = np.asarray(data.ins(r, mode, m).position)[:, :2]
            except MorpiError:
                pass
        tracks.append(TrackView(name=name, title=f"INS on {data.relpath(r)} (median 2D GAC run)", tracks=ins,
                                truth=ds.route(route).polyline))
    # MoRPI paths of every test set (GC), both methods
    panels = []
    for table, phone, p2p in (("short_route", "s8", 1.0), ("short_route", "s8", 1.5), ("short_route", "s6", 1.0),
                              ("long_route", "s8", 1.0), ("long_route", "s6", 1.0), ("morpi_l_shape", "s6", 1.0)):
        paths = {}
        route_name = None
        for m in MORPI_METHODS:
            c = res.cell(table, phone, p2p, m, "GC")
            route_name = c.spec.route
            if not c.runs or c.gain is None:
                continue
            runs = []
            for r in data.recordings(c.spec.phone, c.spec.route, c.spec.split):
                try:
                    runs.append(st.morpi_track(data.steps(r, "GC", m, res.selections[m].config), c.gain).position)
                except MorpiError:
                    pass
            paths[f"{m} GC"] = runs
        if paths:
            panels.append({"title": f"{table} {phone} {p2p:g} m", "truth": ds.route(route_name).polyline,
                           "paths": paths})
    return tuple(recordings), tuple(tracks), tuple(panels)


def _cell_notes(res: TablesResult) -> dict:
    """The measurements quoted by the explanation of each cell further than DEVIATION_PP from the paper."""
    notes = {}
    for c in res.cells:
        if not c.runs or abs(c.deviation_pp) <= DEVIATION_PP:
            continue
        s = c.spec
        if s.method in INS_METHODS:
            if s.method == "INS-2D" and s.calibration == "GAC" and res.data is not None:
                recs = [r for r in res.data.recordings(s.phone, s.route, s.split) if not res.data.no_rest(r)]
                if recs:
                    tl = np.array([res.data.tilt_leak(r, s.calibration) for r in recs])
                    along = np.mean([r.end_point[0] for r in c.runs]) - ds.route(s.route).end_point_m[0]
                    notes[s.label] = {"tilt_deg": tl[:, 0].mean(), "tilt_m": tl[:, 1].mean(), "along_m": along}
            continue
        drift, final = _heading_stats(c, res)
        notes[s.label] = {"heading_drift_deg": drift, "heading_final_deg": final}
    return notes
