"""The paper's table cells: their specs and paper values (:func:`cell_specs`), the results of a cell and of the
tables (:class:`Cell`, :class:`TablesResult`), every cell computed on a dataset (:func:`evaluate_tables`), and the
checks of a dataset and of the cells (:func:`dataset_problems`, :func:`check_cells`)."""
from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import dataset as ds
from .. import steps as st
from ..errors import DataError, MorpiError, ParameterError
from ..field import (MORPI_METHODS, RULES, FieldData, Gain, Selection, held_out_errors, missing_recordings,
                     select_config, trained_gain)
from ..parallel import heap_frozen


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


def frozen_heap(study):
    """`study` run with the heap frozen (:func:`morpi_filters.parallel.heap_frozen`): its full collections
    walk only what it allocates, not the imported modules.

    Parameters
    ----------
    study : callable
        The study.

    Returns
    -------
    callable
        `study` with the same arguments and result, run inside ``heap_frozen()``.
    """

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


@frozen_heap
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


#: Largest value a table cell (or one of its runs) may show [% of the route distance]. A
#: recording within the loader's limits (|f| <= dataset.ACCEL_LIMIT_MPS2) lasting under
#: 15 minutes cannot be double-integrated farther than 0.5 * 164.8 m/s^2 * (900 s)^2 = 6.7e7 m,
#: about 1e9 % of the shortest (6.3 m) route; the field recordings last at most 90 s and their
#: worst run is below 1e4 %. A value beyond it (or not finite) is a fault, not a result.
CELL_SANITY_PERCENT = 1e9


def dataset_problems(data: FieldData) -> list[str]:
    """One line per recording the tables need that is bad or missing.

    Loads every recording of `data` (cached for the evaluation) and lists the
    files that fail to load, then the files its root lacks
    (:func:`morpi_filters.field.missing_recordings`: a glob of the MoRPI
    manifest matching another number of files than expected, a missing
    folder, no recordings at all).

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
    return errors + (missing_recordings(data.root) if isinstance(data.root, Path) else [])


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
