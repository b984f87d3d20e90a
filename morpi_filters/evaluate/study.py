"""The tables section computed once (:func:`tables_study`): the evaluation, every comparison built on it, and what
the page's figures and explanations draw on, as a frozen :class:`TablesStudy`."""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .. import dataset as ds
from .. import steps as st
from ..errors import DataError, MissingDataError, MorpiError
from ..field import MORPI_METHODS, FieldData, nested_rule_comparison
from .cells import (DEVIATION_PP, INS_METHODS, Cell, TablesResult, check_cells, dataset_problems, evaluate_tables,
                    frozen_heap, rule_sensitivity)
from .compare import comparison, heading_readings, ins_full_span, ins_leveled, other_rule, paper_claims, turn_reading


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


@frozen_heap
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


def _require_complete(problems: list[str], root) -> None:
    if problems:
        shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more" if len(problems) > 5 else "")
        raise DataError(f"{root}: {len(problems)} recording problem(s) the tables cannot go on with: {shown} "
                        "(run `morpi check` for the full list, or pass --partial to evaluate without them)")


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
