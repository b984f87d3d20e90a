"""The page of ``morpi evaluate --dataset``: README.md, result.json and every estimated path as CSV."""
from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import quote

from ..dataset_eval import AIDED, CALIBRATIONS, ESTIMATES, METHODS, METRICS, DatasetEvaluation
from ..outputs import write_json, write_text
from ..results import SectionSummary
from .common import fmt, md_table

__all__ = ["report_dataset_evaluation", "track_file_name"]


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


def _metric(v) -> str:
    return "-" if v is None else fmt(v, 3)


def _label(method: str, estimate) -> str:
    return method if estimate is None else f"{method} ({estimate})"


def _nis_cell(nis: dict) -> str:
    return "; ".join(f"{k} {fmt(v['per_dof'], 3)} [{fmt(v['band'][0], 3)}, {fmt(v['band'][1], 3)}]"
                     for k, v in nis.items()) or "-"


def report_dataset_evaluation(out, result: DatasetEvaluation) -> SectionSummary:
    """Write the evaluation of a manifest dataset into folder `out`.

    Files: ``README.md`` (per group, every method and calibration side by
    side; the starts, the train-only choices and what was left out),
    ``result.json`` (:meth:`DatasetEvaluation.to_json` with the track files)
    and ``tracks/<id>/<method>_<calibration>.csv`` (columns ``time,x,y``:
    seconds on the IMU clock, metres in the truth frame's first two axes;
    the aided filter's ``tracks/<id>/MoRPI-aided INS_<calibration>_<estimate>.csv``
    add its horizontal covariance in that frame, ``p_xx,p_xy,p_yy`` [m^2]).

    Parameters
    ----------
    out : path-like
        Staging folder.
    result : DatasetEvaluation
        What :func:`morpi_filters.dataset_eval.evaluate_dataset` found.

    Returns
    -------
    results.SectionSummary
        Name ``"evaluate"``, page ``README.md``.
    """
    out = Path(out)
    files = {}
    for p in result.paths:
        rel = track_file_name(p.id, p.method, p.calibration, p.estimate)
        files[p.id, p.method, p.calibration, p.estimate] = rel
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        if p.P_xy is None:
            lines = ["time,x,y"] + [f"{t!r},{x!r},{y!r}" for t, (x, y) in
                                    zip(p.time.tolist(), p.xy.tolist())]
        else:
            lines = ["time,x,y,p_xx,p_xy,p_yy"] + [
                f"{t!r},{x!r},{y!r},{P[0][0]!r},{P[0][1]!r},{P[1][1]!r}"
                for t, (x, y), P in zip(p.time.tolist(), p.xy.tolist(), p.P_xy.tolist())]
        write_text(path, "\n".join(lines) + "\n")
    write_json(out / "result.json", result.to_json(files))

    over = ("the test recordings" if result.groups_over == "test"
            else "all recordings (the dataset has no test split)")
    L = [f"# Evaluation of the dataset {result.name!r}", "",
         f"Manifest `{Path(result.source).name}`, {result.count} recording(s). Every estimate is compared in the "
         "truth's frame: a route's frame, or the truth track's local ENU frame with the estimate turned by the "
         "truth's course and put on the truth's position at its first time. The course: for a start at rest, "
         f"over the truth's first {result.course_m:g} m from its position at the first sample; for "
         "`initial = \"truth\"`, the direction of the truth velocity over the first moments (one truth interval "
         "on each side of the first sample).", "",
         f"Group means over {over}. Errors in metres and in percent of the route's distance or the truth "
         "track's horizontal path length; `path RMSE` only for truth tracks.", ""]
    groups = list(dict.fromkeys(g["group"] for g in result.groups))
    heads = ["method", "calibration", "n", "end error [m]", "end error [%]", "path RMSE [m]",
             "cross-track RMSE [m]", "distance error [%]"]
    order = {(m, c): i for i, (m, c) in enumerate((m, c) for m in METHODS for c in CALIBRATIONS)}
    rank = {None: 0, **{e: i for i, e in enumerate(ESTIMATES)}}
    for group in groups:
        rows = sorted((g for g in result.groups if g["group"] == group),
                      key=lambda g: (order[g["method"], g["calibration"]], rank[g.get("estimate")]))
        L += [f"## Group {group}", "",
              md_table(heads, [[_label(g["method"], g.get("estimate")), g["calibration"], g["n"],
                                *(_metric(g[k]) for k in METRICS)] for g in rows])]
    aided_rows = [p for p in result.paths if p.method == AIDED]
    if aided_rows:
        L += [f"## {AIDED}: consistency", "",
              "The forward filter's normalized innovation squared per measurement and degree of freedom, with its "
              "95 % chi-square band, and the share of the truth inside the 95 % horizontal ellipse (`coverage_95`: "
              "the truth track's samples, the forward or smoothed covariance as the row; a route: its end point). "
              "Tunables and the MoRPI steps the filter takes are chosen on the train recordings (below).", "",
              md_table(["id", "split", "group", "calibration", "estimate", "coverage 95 %", "NIS per dof [band]"],
                       [[p.id, p.split, p.group, p.calibration, p.estimate, _metric(p.coverage_95), _nis_cell(p.nis)]
                        for p in aided_rows])]
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
