"""The page of ``morpi evaluate --dataset``: README.md, result.json and every estimated path as CSV."""
from __future__ import annotations

import os
import re
import signal
import sys
import threading
from itertools import chain
from pathlib import Path
from urllib.parse import quote

from ..dataset_eval import (ABLATION_METRICS, AIDED, CALIBRATIONS, ESTIMATES, METHODS, METRICS, DatasetEvaluation,
                            is_aided)
from ..outputs import write_json, write_text
from ..parallel import available_cores
from ..results import SectionSummary
from .common import fmt, md_table

__all__ = ["report_dataset_evaluation", "track_file_name", "ablation_file_name"]


def track_file_name(rec_id: str, method: str, calibration: str, estimate: str | None = None) -> str:
    """Where an estimated path is written, relative to the output folder.

    Parameters
    ----------
    rec_id, method, calibration : str
        The recording's id (characters other than letters, digits, ``.``,
        ``_`` and ``-`` become ``_``), the method and the calibration.
    estimate : str, optional
        The aided filter's read-out (``"forward"`` or ``"smoothed"``).

    Returns
    -------
    str
        ``tracks/<id>/<method>_<calibration>.csv``, or
        ``tracks/<id>/<method>_<calibration>_<estimate>.csv`` with an estimate.

    Examples
    --------
    >>> track_file_name("run 1", "INS-3D", "GC")
    'tracks/run_1/INS-3D_GC.csv'
    >>> track_file_name("run 1", "MoRPI-aided INS", "GC", "smoothed")
    'tracks/run_1/MoRPI-aided INS_GC_smoothed.csv'
    """
    safe = re.sub(r"[^A-Za-z0-9._-]", "_", rec_id).lstrip(".") or "_"
    return f"tracks/{safe}/{method}_{calibration}{'' if estimate is None else '_' + estimate}.csv"


def ablation_file_name(rec_id: str, calibration: str, removed: str, estimate: str, which: str,
                       method: str = AIDED) -> str:
    """Where a filter of the aided filter's ablation is written when no other track file holds it.

    Parameters
    ----------
    rec_id, calibration : str
        The recording's id (made safe as in :func:`track_file_name`) and the calibration.
    removed : str
        The aid removed (a key of :data:`morpi_filters.field_aided.ABLATIONS`; spaces become ``_``).
    estimate : str
        The read-out, ``"forward"`` or ``"smoothed"``.
    which : str
        ``"full"`` or ``"ablated"``.
    method : str
        The aided filter's method name; one other than
        :data:`~morpi_filters.dataset_eval.AIDED` (a filter per MoRPI
        method) starts the file name.

    Returns
    -------
    str
        ``tracks/<id>/ablation/<calibration>_<removed>_<estimate>_<which>.csv``
        (``<method>_<calibration>...`` for a filter per MoRPI method).

    Examples
    --------
    >>> ablation_file_name("run 1", "GC", "rest updates", "smoothed", "ablated")
    'tracks/run_1/ablation/GC_rest_updates_smoothed_ablated.csv'
    """
    folder = track_file_name(rec_id, "x", "x").rsplit("/", 1)[0]
    head = "" if method == AIDED else f"{method}_"
    name = re.sub(r"[^A-Za-z0-9._-]", "_", f"{head}{calibration}_{removed}_{estimate}_{which}")
    return f"{folder}/ablation/{name}.csv"


def _column_text(a) -> list:
    """Each value of the 1-D float array `a` as its ``repr`` (the shortest text that reads back as the same
    float), in order: the list's ``repr`` is split at its separators, which no float's text holds."""
    return repr(a.tolist())[1:-1].split(", ") if a.size else []


def _write_track(path: Path, p, times: dict) -> None:
    """An estimate's ``time,x,y`` (and ``p_xx,p_xy,p_yy`` with a covariance) as CSV, written plainly: `path`
    lies in the command's staging folder, which no one sees before it is complete (a file of its own per
    track, atomic, costs thousands of staging folders). Each column's text is made at once
    (:func:`_column_text`) and the rows joined from it; `times` keeps each time column's text by its bytes:
    a recording's estimates share their clock, and a float's text is most of the cost."""
    path.parent.mkdir(parents=True, exist_ok=True)
    key = p.time.tobytes()
    t_text = times.get(key)
    if t_text is None:
        t_text = times[key] = _column_text(p.time)
    if p.P_xy is None:
        head, cols = "time,x,y", (p.xy[:, 0], p.xy[:, 1])
    else:
        P = p.P_xy
        head, cols = "time,x,y,p_xx,p_xy,p_yy", (p.xy[:, 0], p.xy[:, 1], P[:, 0, 0], P[:, 0, 1], P[:, 1, 1])
    rows = map(",".join, zip(t_text, *map(_column_text, cols)))
    path.write_text("\n".join(chain((head,), rows, ("",))))


def _write_tracks(jobs, workers: int, meanwhile=None, meanwhile_cost: float | None = None) -> None:
    """Write the tracks `jobs` (``(path, estimate, folder)``, :func:`_write_track`), with two workers or more
    on two processes where the system forks (Linux): formatting floats holds the interpreter, so a thread
    would not share it. A forked child writes the folders of about half the rows (a recording's tracks
    stay together, in their order: they share their time column's text) while this process calls `meanwhile`
    (if given, on one process too) and writes the others; a child that does not finish (killed, a failed
    write) leaves its share to this process, which writes it again. Only a process that runs no other thread
    forks (the command's, once its thread pools are done); otherwise one process writes everything.
    `meanwhile_cost` is what `meanwhile` costs in the units of a track's cost (values formatted); default:
    the JSON's, about a sixth of the tracks' on the field data."""
    # a fork while other threads run could copy a lock one of them holds: only from a single-threaded process
    if (workers < 2 or len(jobs) < 2 or not sys.platform.startswith("linux") or not hasattr(os, "fork")
            or threading.active_count() > 1):
        times = {}
        for path, p, _ in jobs:
            _write_track(path, p, times)
        if meanwhile is not None:
            meanwhile()
        return
    folders = {}
    for path, p, rec in jobs:
        folders.setdefault(rec, []).append((path, p))
    cost = {k: sum(len(p.time) * (3 if p.P_xy is None else 6) for _, p in v) for k, v in folders.items()}
    # the child takes more than half the rows: this process also runs `meanwhile`
    total = sum(cost.values())
    extra = 0.0 if meanwhile is None else 0.16 * total if meanwhile_cost is None else float(meanwhile_cost)
    share = min(total, 0.5 * (total + extra))
    theirs, mine, held = [], [], 0.0
    for k in sorted(folders, key=cost.get, reverse=True):
        if held + cost[k] <= share or not theirs:
            theirs += folders[k]
            held += cost[k]
        else:
            mine += folders[k]
    pid = os.fork()
    if pid == 0:                                # the child: its share, then out without the parent's exit work
        code = 1
        try:
            import gc

            gc.disable()
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            times = {}
            for path, p in theirs:
                _write_track(path, p, times)
            code = 0
        finally:
            os._exit(code)
    try:
        if meanwhile is not None:
            meanwhile()
        times = {}
        for path, p in mine:
            _write_track(path, p, times)
        _, status = os.waitpid(pid, 0)
    except BaseException:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise
    if status != 0:
        for path, p in theirs:
            _write_track(path, p, times)


#: Recordings drawn per group on the page: the first of those its means read.
FIGURE_RECORDINGS = 6
#: What one panel of the page's figures costs to draw, in the track writer's units (values formatted): about
#: 0.05 s, as formatting 80,000 values, on the field data (:func:`_write_tracks` shares the work by it).
PANEL_COST = 80_000


def _truth_line(truth):
    """The truth's horizontal line [m]: a route's polyline (start to end point without one), a track's positions."""
    import numpy as np

    from ..manifest import RouteTruth

    if isinstance(truth, RouteTruth):
        line = truth.polyline_m if truth.polyline_m is not None else [[0.0, 0.0], truth.end_point_m]
        return np.asarray(line, dtype=float)
    return np.asarray(truth.position, dtype=float)[:, :2]


def _shown(paths) -> list:
    """The estimates a figure draws, one per method: under GC where the recording has it (else RD), the aided
    filter smoothed."""
    have = {p.calibration for p in paths}
    cal = "GC" if "GC" in have else "RD"
    return [p for p in paths if p.calibration == cal and p.estimate in (None, "smoothed")]


def _figure_ids(result: DatasetEvaluation, group: str) -> tuple[list, list]:
    """The recordings a group's figures draw, and those its means read (none without the dataset)."""
    if result.pipeline is None:
        return [], []
    tested = any(p.group == group and p.split == "test" for p in result.paths)
    have = {p.id for p in result.paths}
    read = [dr.id for dr in result.pipeline.dataset.recordings if dr.group == group and dr.id in have
            and (dr.split == "test" if tested else dr.split != "train" or result.groups_over == "all")]
    return read[:FIGURE_RECORDINGS], read


def _group_figures(out: Path, result: DatasetEvaluation, group: str) -> list:
    """The group's figures (paths against the truth; for truth tracks, the error against time) and their lines
    on the page; none without the evaluation's dataset (:attr:`DatasetEvaluation.pipeline`)."""
    import numpy as np

    from ..manifest import TruthTrack
    from . import plots
    from .common import collector_paused, save_figure

    ids, read = _figure_ids(result, group)
    if not ids:
        return []
    dataset = result.pipeline.dataset
    paths_panels, error_panels = [], []
    for rec_id in ids:
        truth = dataset[rec_id].truth
        shown = _shown([p for p in result.paths if p.id == rec_id])
        paths_panels.append({"title": rec_id, "truth": _truth_line(truth),
                             "paths": {f"{p.method} {p.calibration}": [p.xy] for p in shown}})
        if isinstance(truth, TruthTrack):
            error_panels.append({"title": rec_id, "curves": {
                f"{p.method} {p.calibration}": (p.time, np.hypot(*(p.xy - truth.at(p.time)[:, :2]).T))
                for p in shown}})
    safe = re.sub(r"[^A-Za-z0-9._-]", "_", group)
    lines = [f"Paths against the truth ({len(ids)} of the {len(read)} recording(s) the means read; each method "
             "under GC where the recording has it, else RD, the aided filter smoothed; the axes show the truth "
             "and half its extent around it):", "", f"![paths of group {group}](figures/{quote(safe)}_paths.png)", ""]
    with collector_paused():
        save_figure(plots.plot_path_sets(paths_panels, around_truth=0.5, legend="first"), out / "figures" / f"{safe}_paths.png",
                    dpi=90)
        if error_panels:
            save_figure(plots.plot_error_sets(error_panels, legend="first"), out / "figures" / f"{safe}_errors.png", dpi=90)
    if error_panels:
        lines += ["Horizontal error against the truth track over time, the same estimates:", "",
                  f"![errors of group {group}](figures/{quote(safe)}_errors.png)", ""]
    else:
        lines += ["A route's truth is its end point and line: there is no error over time to draw.", ""]
    return lines


def _change(full, ablated) -> str:
    """``full -> ablated (+difference)``, or ``-`` without values."""
    if full is None or ablated is None:
        return "-"
    return f"{fmt(full, 3)} -> {fmt(ablated, 3)} ({'+' if ablated - full >= 0 else ''}{fmt(ablated - full, 3)})"


def _ablation_section(result: DatasetEvaluation, group: str) -> list:
    """The ablation table of one group: a row per calibration and aid, a column per metric and read-out."""
    rows = [r for r in result.ablation if r["group"] == group]
    if not rows:
        return []
    names = {"end_error_percent": "end error [%]", "path_rmse_m": "path RMSE [m]",
             "cross_track_rmse_m": "cross-track RMSE [m]"}
    each = any(r["method"] != AIDED for r in rows)
    heads = ["method"] * each + ["calibration", "removed", "used", "start", "n"] + [
        f"{names[m]}, {e}: full -> without" for m in ABLATION_METRICS for e in ("smoothed", "forward")]
    table = []
    for key in dict.fromkeys((r["method"], r["calibration"], r["removed"]) for r in rows):
        by = {r["estimate"]: r for r in rows if (r["method"], r["calibration"], r["removed"]) == key}
        first = by.get("smoothed") or by["forward"]
        table.append([*key[1 - each:], "yes" if first["used"] else "no (exactly 0)", first["start"], first["n"],
                      *(_change(by[e]["full"][m], by[e]["ablated"][m]) if e in by else "-"
                        for m in ABLATION_METRICS for e in ("smoothed", "forward"))])
    return [f"### {AIDED} ablation, group {group}", "",
            "Each aid removed in turn from the chosen filter, on the same recordings as the group means: the full "
            "filter's mean, the mean without the aid and their difference. `smoothed` columns read both filters "
            "smoothed (removing the smoothing: the forward read-out against the smoothed one), `forward` columns "
            "read both forward. An aid the filter does not use is not run (exactly 0). The rest updates are "
            "removed from the filter started at the motion onset and compared with that filter with them.", "",
            md_table(heads, table)]


def _metric(v) -> str:
    return "-" if v is None else fmt(v, 3)


def _label(method: str, estimate) -> str:
    return method if estimate is None else f"{method} ({estimate})"


def _nis_cell(nis: dict) -> str:
    return "; ".join(f"{k} {fmt(v['per_dof'], 3)} [{fmt(v['band'][0], 3)}, {fmt(v['band'][1], 3)}]"
                     for k, v in nis.items()) or "-"


def report_dataset_evaluation(out, result: DatasetEvaluation, workers: int | None = None) -> SectionSummary:
    """Write the evaluation of a manifest dataset into folder `out`.

    Files: ``README.md`` (per group, every method and calibration side by
    side; the starts, the train-only choices and what was left out),
    ``result.json`` (:meth:`DatasetEvaluation.to_json` with the track files)
    and ``tracks/<id>/<method>_<calibration>.csv`` (columns ``time,x,y``:
    seconds on the IMU clock, metres in the truth frame's first two axes;
    the aided filter's ``tracks/<id>/MoRPI-aided INS_<calibration>_<estimate>.csv``
    add its horizontal covariance in that frame, ``p_xx,p_xy,p_yy`` [m^2]; the
    ablation's filters that no such file holds:
    :func:`ablation_file_name`). Per group, after its means, its figures
    (``figures/<group>_paths.png``: the paths against the truth of up to
    :data:`FIGURE_RECORDINGS` recordings; ``figures/<group>_errors.png``: for
    truth tracks, the error against time) and the aided filter's ablation
    table.

    Parameters
    ----------
    out : path-like
        Staging folder.
    result : DatasetEvaluation
        What :func:`morpi_filters.dataset_eval.evaluate` found.
    workers : int, optional
        Processes that write the track files (default: the cores this
        process may use; two at most, on Linux: :func:`_write_tracks`). The
        files do not depend on it.

    Returns
    -------
    results.SectionSummary
        Name ``"evaluate"``, page ``README.md``.
    """
    out = Path(out)
    files, written, jobs = {}, {}, []
    for p in result.paths:
        rel = track_file_name(p.id, p.method, p.calibration, p.estimate)
        files[p.id, p.method, p.calibration, p.estimate] = written[id(p)] = rel
        jobs.append((out / rel, p, rel.split("/")[1]))
    # the ablation's filters: a row of the paths keeps its file, the others get one each
    for a in result.ablation_runs:
        for which, p in (("full", a.full), ("ablated", a.ablated)):
            if id(p) not in written:
                written[id(p)] = ablation_file_name(a.id, a.calibration, a.removed, a.estimate, which, a.method)
                jobs.append((out / written[id(p)], p, written[id(p)].split("/")[1]))
            files["ablation", a.id, a.method, a.calibration, a.removed, a.estimate, which] = written[id(p)]
    if workers is None:
        workers = available_cores()
    groups = list(dict.fromkeys(g["group"] for g in result.groups))
    figures = {}

    def meanwhile():                            # the JSON and the figures, while a second process writes tracks
        write_json(out / "result.json", result.to_json(files))
        for group in groups:
            figures[group] = _group_figures(out, result, group)

    panels = sum(len(_figure_ids(result, g)[0]) * 2 for g in groups)       # paths, and at most as many errors
    total = sum(len(p.time) * (3 if p.P_xy is None else 6) for _, p, _ in jobs)
    _write_tracks(jobs, workers, meanwhile=meanwhile, meanwhile_cost=0.16 * total + PANEL_COST * panels)

    over = ("the test recordings (a group without test recordings: its recordings outside the train split)"
            if result.groups_over == "test" else "all recordings (the dataset has no test split)")
    L = [f"# Evaluation of the dataset {result.name!r}", "",
         f"Manifest `{Path(result.source).name}`, {result.count} recording(s). Every estimate is compared in the "
         "truth's frame: a route's frame, or the truth track's local ENU frame with the estimate turned by the "
         "truth's course and put on the truth's position at its first time. The course: for a start at rest, "
         f"over the truth's first {result.course_m:g} m from its position at the first sample; for "
         "`initial = \"truth\"`, the direction of the truth velocity over the first moments (one truth interval "
         "on each side of the first sample).", "",
         f"Group means over {over}. Errors in metres and in percent of the route's distance or the truth "
         "track's horizontal path length; `path RMSE` only for truth tracks.", ""]
    heads = ["method", "calibration", "n", "end error [m]", "end error [%]", "path RMSE [m]",
             "cross-track RMSE [m]", "distance error [%]"]
    order = {(m, c): i for i, (m, c) in enumerate((m, c) for m in METHODS for c in CALIBRATIONS)}
    rank = {None: 0, **{e: i for i, e in enumerate(ESTIMATES)}}
    for group in groups:
        rows = sorted((g for g in result.groups if g["group"] == group),
                      key=lambda g: (order[g["method"], g["calibration"]], rank[g.get("estimate")]))
        L += [f"## Group {group}", "",
              md_table(heads, [[_label(g["method"], g.get("estimate")), g["calibration"], g["n"],
                                *(_metric(g[k]) for k in METRICS)] for g in rows]),
              *figures[group],
              *_ablation_section(result, group)]
    aided_rows = [p for p in result.paths if is_aided(p.method)]
    if aided_rows:
        L += [f"## {AIDED}: consistency", "",
              "The forward filter's normalized innovation squared per measurement and degree of freedom, with its "
              "95 % chi-square band, and the share of the truth inside the 95 % horizontal ellipse (`coverage_95`: "
              "the truth track's samples, the forward or smoothed covariance as the row; a route: its end point). "
              "Tunables and the MoRPI steps the filter takes are chosen on the train recordings (below).", "",
              md_table(["id", "split", "group", "method", "calibration", "estimate", "coverage 95 %",
                        "NIS per dof [band]"],
                       [[p.id, p.split, p.group, p.method, p.calibration, p.estimate, _metric(p.coverage_95),
                         _nis_cell(p.nis)] for p in aided_rows])]
    L += ["## Every recording", "",
          md_table(["id", "split", "group", "method", "calibration", *heads[3:], "track"],
                   [[p.id, p.split, p.group, _label(p.method, p.estimate), p.calibration,
                     *(_metric(p.metrics[k]) for k in METRICS),
                     f"[csv]({quote(files[p.id, p.method, p.calibration, p.estimate])})"] for p in result.paths]),
          "## Starts", "",
          md_table(["id", "initial", "rest window [s]", "course [deg]", "speed [m/s]", "how"],
                   [[s["id"], s["initial"], "-" if s["rest"] is None else f"{s['rest'][0]:.3g} to {s['rest'][1]:.3g}",
                     _metric(s["course_deg"]), fmt(s["speed_mps"], 3), s["how"]] for s in result.starts]),
          "## Train-only choices", "",
          "Step rules: " + "; ".join(f"{m}: {c['from']}" for m, c in result.choices["rule"].items()) + ".", "",
          f"Held out: {result.choices['held_out']['used']} ({result.choices['held_out']['why']}).", "",
          md_table(["threshold", "value", "from"], [[k, fmt(v["value"], 4), v["from"]]
                                                   for k, v in result.choices["thresholds"].items()]),
          md_table(["group", "method", "calibration", "gain", "std", "from", "train recordings"],
                   [[e["group"], e["method"], e["calibration"], _metric(e["mean"]), _metric(e["std"]), e["from"],
                     ", ".join(e["train"]) or "none"] for e in result.choices["gains"]]),
          *([md_table([f"{AIDED}: group", "calibration", "steps of", "tunables", "train recordings"],
                      [[e["group"], e["calibration"], e["method"] or "none",
                        "-" if e["tunables"] is None else
                        ", ".join(f"{k} {v if isinstance(v, (str, bool)) else format(v, '.3g')}"
                                  for k, v in e["tunables"].items()),
                        ", ".join(e["train"]) or "none"] for e in result.choices.get("aided", [])])]
            if result.choices.get("aided") else []),
          "## Left out", ""]
    L += ([md_table(["id", "what", "why"], [[x["id"], x["what"], x["why"]] for x in result.left_out])]
          if result.left_out else ["Nothing.", ""])
    write_text(out / "README.md", "\n".join(L))
    return SectionSummary(name="evaluate", title=f"Evaluation of {result.name}", page="README.md",
                          summary=f"{len(result.paths)} estimates on {result.count} recording(s).")
