"""The ``aided`` report section: the MoRPI-aided filter on every MoRPI table cell."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..reporting import SectionSummary, write_json, write_text
from . import plots
from .common import _collector_paused, banner, fmt, md_table, save_figure


def _nis(d: dict) -> dict:
    return {k: {"mean": v[0], "dof": v[1]} for k, v in sorted(d.items())}


def _paired(d) -> dict | None:
    if d is None:
        return None
    return {"mean_pp": d.mean_pp, "se_pp": d.se_pp, "runs": d.runs, "p_value": d.p_value, "alpha": d.alpha,
            "verdict": d.verdict}


def study_json(study) -> dict:
    """The section's JSON (the names of the contract are kept stable).

    Top level: ``cells`` (each with ``table``, ``phone``, ``p2p_m``,
    ``method``, ``calibration``, ``paper_percent``, ``morpi_percent``,
    ``forward_percent``, ``smoothed_percent``, ``runs``), ``ablation`` (list of
    ``{cell, removed, smoothed_percent}``), ``coverage_95`` (fraction) and
    ``tunables``.

    Parameters
    ----------
    study : field_aided.AidedStudy
        What :func:`morpi_filters.field_aided.aided_study` computed.

    Returns
    -------
    dict
        ``cells`` (list of dict: ``table``, ``phone``, ``p2p_m``, ``method``,
        ``calibration``, ``route``, ``label``, ``paper_percent``,
        ``morpi_percent``, ``forward_percent``, ``smoothed_percent``,
        ``ins_percent``, ``steps_percent``, ``train_percent``, ``train_loo_percent``,
        ``train_morpi_percent``, ``nis``, ``step_innovation``, ``smoothed_vs_morpi`` (the smoothed
        filter minus MoRPI alone, paired over the runs: ``mean_pp``, ``se_pp``, ``runs``, ``p_value``,
        ``alpha``, ``verdict``), ``runs``, ``failed``), ``ablation``,
        ``coverage_95``, ``nis`` (measurement -> ``{mean, dof}``), ``note``,
        ``no_rest`` (one line per recording without an initial rest, on which
        the filter does not run) and ``tunables`` (``grid``, ``fixed``, ``chosen``).

    Examples
    --------
    >>> from morpi_filters.field_aided import GRID, AidedStudy
    >>> js = study_json(AidedStudy(cells=(), ablation=(), coverage_95=float("nan"), nis={}, note="no cell"))
    >>> sorted(js), js["tunables"]["grid"] == {k: list(v) for k, v in GRID.items()}
    (['ablation', 'cells', 'coverage_95', 'nis', 'no_rest', 'note', 'tunables'], True)
    """
    from .. import aided, field_aided

    cells = []
    for c in study.cells:
        sp = c.spec
        cells.append({"table": sp.table, "phone": sp.phone, "p2p_m": sp.p2p_m, "method": sp.method,
                      "calibration": sp.calibration, "route": sp.route, "label": sp.label,
                      "paper_percent": sp.paper_percent, "morpi_percent": c.morpi_percent,
                      "forward_percent": c.forward_percent, "smoothed_percent": c.smoothed_percent,
                      "ins_percent": c.ins_percent, "steps_percent": c.steps_percent,
                      "train_percent": c.train_percent,
                      "train_loo_percent": c.train_loo_percent, "train_morpi_percent": c.train_morpi_percent,
                      "nis": _nis(c.nis), "step_innovation": dict(c.step_innovation),
                      "smoothed_vs_morpi": _paired(c.paired),
                      "runs": list(c.runs), "failed": list(c.failed)})
    return {"cells": cells, "ablation": list(study.ablation), "coverage_95": study.coverage_95,
            "nis": _nis(study.nis), "note": study.note, "no_rest": list(study.no_rest),
            "tunables": {"grid": {k: list(v) for k, v in field_aided.GRID.items()},
                         "fixed": {"accel_walk": field_aided.ACCEL_WALK, "nhc_sigma": field_aided.NHC_SIGMA,
                                   "turn_sigma": field_aided.TURN_SIGMA,
                                   "min_train_coverage": field_aided.MIN_TRAIN_COVERAGE,
                                   **{k: v for k, v in aided.AidTuning().__dict__.items()
                                      if k in ("gyro_walk", "zupt_sigma", "tilt0", "ba0", "bg0")}},
                         "chosen": [{"cell": c.label, "train_percent": c.train_percent, **c.tuning}
                                    for c in study.cells]}}


def _paired_cell(d) -> str:
    if d is None or not d.runs:
        return "-"
    return f"{fmt(d.mean_pp)} ± {fmt(d.se_pp)} ({d.verdict})"


def _figures(study, out: Path) -> list[str]:
    from ..dataset import route

    if not study.cells:
        return []
    # the figures come with their margins fitted to their labels (no layout pass): each is saved in one draw
    with _collector_paused():
        names = ["aided_cells.png"]
        save_figure(plots.plot_aided_cells(study.cells), out / names[0])
        for c in study.cells:
            if c.spec.calibration == "GC" and c.spec.method == "MoRPI-G":
                name = f"aided_paths_{c.spec.phone}_{c.spec.route}.png"
                save_figure(plots.plot_aided_paths(c, route(c.spec.route).polyline), out / name)
                names.append(name)
        first = next((c for c in study.cells if c.spec.calibration == "GC" and c.spec.method == "MoRPI-G"),
                     study.cells[0])
        save_figure(plots.plot_aided_ellipses(first), out / "aided_ellipses.png")
        names.append("aided_ellipses.png")
    return names


def _ratio(cells, *, short: bool) -> float:
    """Mean of smoothed / MoRPI-alone over the cells of the short routes (or of the others)."""
    sel = [c.smoothed_percent / c.morpi_percent for c in cells
           if (c.spec.table == "short_route") == short and c.morpi_percent > 0]
    return float(np.mean(sel)) if sel else float("nan")


#: How the page words the step innovations (thresholds of the words, not of any test): the along-track mean
#: is called steady when it exceeds this share of the RMS (the mean square then holds more than 4 % of bias)...
STEADY_SHARE = 0.2
#: ... and the RMS beyond the spread the filter expects when it exceeds this multiple of the median expected
#: sigma (a mean squared ratio of 2.25, where a consistent filter gives 1).
BEYOND_FACTOR = 1.5


def _innovation_sentence(parts) -> str:
    """What the step innovations of some cells say: a steady part or a scatter, against the spread expected."""
    if not parts:
        return ""
    n = sum(v["updates"] for v in parts)
    mean = sum(v["along_mean_m"] * v["updates"] for v in parts) / n
    rms = float(np.sqrt(sum(v["along_rms_m"] ** 2 * v["updates"] for v in parts) / n))
    sigma = float(np.median([v["predicted_along_sigma_m"] for v in parts]))
    kind = ("the INS's scatter over one step, which each update pulls back, not a steady over- or under-run"
            if abs(mean) < STEADY_SHARE * rms else
            f"a steady {'overrun' if mean < 0 else 'shortfall'} of the INS at every step, which each update pulls back")
    spread = ("within" if rms <= BEYOND_FACTOR * sigma else "beyond") + f" the spread the filter expects (median {fmt(sigma, 2)} m)"
    return f"the along-track mean over {n} updates is {fmt(mean, 3)} m against an RMS of {fmt(rms, 3)} m: {kind}; {spread}."


def _page(study, source, figures) -> str:
    from .. import aided, field_aided

    cells = study.cells
    better = sum(c.forward_percent < c.morpi_percent for c in cells)
    sm_better = sum(c.smoothed_percent < c.morpi_percent for c in cells)
    gc = [c for c in cells if c.spec.calibration == "GC"]
    gc_better = sum(c.smoothed_percent < c.morpi_percent for c in gc)
    below_paper = [c for c in gc if c.spec.method == "MoRPI-G" and c.smoothed_percent <= c.spec.paper_percent]
    rows = [[c.label, len(c.runs), fmt(c.smoothed_percent), fmt(c.forward_percent), fmt(c.morpi_percent),
             _paired_cell(c.paired), fmt(c.steps_percent), fmt(c.ins_percent, 0), fmt(c.spec.paper_percent),
             fmt(c.train_percent), fmt(c.train_loo_percent), fmt(c.train_morpi_percent),
             ", ".join(f"{k} {('on' if v else 'off') if isinstance(v, bool) else v if isinstance(v, str) else f'{v:g}'}"
                       for k, v in c.tuning.items() if k in field_aided.GRID)] for c in cells]
    verdicts = {v: sum(c.paired is not None and c.paired.verdict == v for c in gc) for v in ("better", "worse", "tie")}
    alpha = next((c.paired.alpha for c in cells if c.paired is not None), 0.05)
    lost = [f"{c.label}, {fmt(c.paired.mean_pp)} ± {fmt(c.paired.se_pp)} pp" for c in gc
            if c.paired is not None and c.paired.verdict == "tie" and c.paired.mean_pp >= 0]
    with_steps = [c for c in cells if np.isfinite(c.steps_percent)]
    over_steps = sum(c.smoothed_percent < c.steps_percent for c in with_steps)
    base = {c.label: c.smoothed_percent for c in cells}
    abl_rows = [[a["cell"], a["removed"], fmt(base.get(a["cell"])), fmt(a["smoothed_percent"]),
                 fmt(a["smoothed_percent"] - base.get(a["cell"], np.nan))] for a in study.ablation]
    names = sorted({a["removed"] for a in study.ablation})
    mean_rows = []
    for name in names:
        d = [a["smoothed_percent"] - base[a["cell"]] for a in study.ablation if a["removed"] == name]
        mean_rows.append([name, len(d), fmt(float(np.mean(d))), fmt(float(np.median(d)))])
    nis_rows = [[k, v[1], fmt(v[0]), fmt(v[0] / v[1])] for k, v in sorted(study.nis.items())]
    innov = [(c.label, c.step_innovation) for c in cells if c.step_innovation]
    innov_rows = [[lab, v["updates"], fmt(v["along_mean_m"], 3), fmt(v["along_rms_m"], 3), fmt(v["cross_mean_m"], 3),
                   fmt(v["cross_rms_m"], 3), fmt(v["predicted_along_sigma_m"], 3)] for lab, v in innov]
    innov_text = ""
    if innov:
        groups = [(_innovation_sentence([c.step_innovation for c in cells if c.step_innovation
                                         and (c.spec.table == "short_route") == short]), what)
                  for short, what in ((True, "On the short routes (the routes the tunables are trained on)"),
                                      (False, "On the long and L routes"))]
        innov_text = (
            "\n\nStep updates of the forward filter (test runs, up to the read-out): the measured step minus the "
            "predicted one (the INS's displacement since the last step boundary), along the step (negative: the "
            "INS ran ahead) and across it (positive: the step lies to the INS's left), and the median spread the "
            "filter expected along the step. "
            + " ".join(f"{what} {text}" for text, what in groups if text)
            + "\n\n" + md_table(["cell", "updates", "along mean [m]", "along RMS [m]", "cross mean [m]",
                                  "cross RMS [m]", "expected sigma along [m]"], innov_rows))
    no_rest = ""
    if study.no_rest:
        no_rest = ("**Recordings without an initial rest** (they move from their first samples): the filter starts "
                   "at the rest window and takes its noise there, so it does not run on them (each cell names them "
                   "among its failed runs):\n\n" + "".join(f"- {x}\n" for x in study.no_rest) + "\n")
    return (
        f"{banner(source)}# The MoRPI-aided inertial filter on the field recordings\n\n"
        "One closed-loop error-state Kalman filter pass per recording (`morpi_filters.aided`): the 3D strapdown "
        "at every IMU sample on the real time steps, the covariance and the updates on 0.1 s epochs and at every "
        "step boundary, and the estimated errors (position, velocity, attitude, biases) fed back after each "
        "update, from the recording's initial rest window on (what precedes it is the phone being placed). "
        "States: the 15 INS errors, a clone of the horizontal position at the last step boundary, "
        "the relative gain error of the step length and the heading error of the route's heading, which "
        f"grows by {fmt(field_aided.TURN_SIGMA * 100, 0)} % of each turn it reads (set a priori: the train "
        "routes take no turn). Aids:\n\n"
        "- the MoRPI step displacement (the cell's steps and trained gain). Its direction is one of: the "
        "filter's attitude averaged over the step (the paper's heading equation; the step then turns with the "
        "filter's heading error and measures the length only), or the route's heading (the turns reading "
        "without the step's own change: straight between the detected turns). The "
        "gain error is either estimated, or considered: the trained gain taken as exact while its spread "
        "stays in the covariance (a consider analysis);\n"
        "- zero velocity and zero angular rate while the robot stands before and after its motion (the gyro's "
        "vibration says when; no ground truth), and zero velocity alone between the calibration's rest window "
        "and the motion onset (the motors may run); while the robot stands, the process noise is the still "
        "phone's own;\n"
        "- the non-holonomic constraint: the robot's lateral and vertical velocity are zero (phone-to-robot tilt "
        "from the rest specific force, mounting yaw zero), where the train runs show it pays;\n"
        "- biases started from the initial rest and kept as states;\n"
        "- a Rauch-Tung-Striebel smoother over the whole run for the path in between (the read-out at the last "
        "step boundary also hears the final rest).\n\n"
        "Tunables are chosen per training set, method and calibration on the train runs only, in two stages: "
        "least mean train end-point error over the grid with the gain considered and the non-holonomic updates "
        "on (grid points whose 95 % ellipse holds fewer than "
        f"{fmt(field_aided.MIN_TRAIN_COVERAGE * 100, 0)} % of the train end points are left out), then, at the "
        "chosen point, the non-holonomic updates are dropped unless they improve the train end points by more "
        "than one standard error, and the gain is estimated only where its estimates explain the train runs' own "
        "gain errors and improve the end points by more than one standard error. Grid "
        f"`{dict(field_aided.GRID)}`; the noise densities are the rest windows' own (median over the train runs) "
        "times the vibration factor; the gain error's prior is the trained gain's spread. `its steps alone` is "
        "the filter's step vectors summed without the INS: the difference to the filter is what the INS adds.\n\n"
        f"**Verdict.** The smoothed filter beats MoRPI alone in {sm_better} of {len(cells)} cells (forward: "
        f"{better}): {sum(c.smoothed_percent < c.morpi_percent for c in cells if c.spec.calibration == 'RD')} "
        f"of {sum(c.spec.calibration == 'RD' for c in cells)} RD cells, where MoRPI alone carries the raw gyro "
        f"bias in its heading (the rest updates calibrate it, and the route's heading leaves the drift between "
        f"turns out), and {gc_better} of {len(gc)} GC cells. MoRPI-G GC is at or "
        f"below the paper's number in {len(below_paper)} of {sum(c.spec.method == 'MoRPI-G' for c in gc)} route "
        f"cells. Mean ratio filter / MoRPI alone on the GC cells: {fmt(_ratio(gc, short=True))} on the short "
        f"routes (the routes the tunables are trained on), {fmt(_ratio(gc, short=False))} on the long and L "
        f"routes. Against its own step vectors summed without the INS, the smoothed filter is better in "
        f"{over_steps} of {len(with_steps)} cells: most of its gain over MoRPI alone comes from the step "
        "direction it reads, not from the INS. "
        f"Run by run (paired t-test at {fmt(alpha * 100, 0)} %), the smoothed filter is better than MoRPI alone in "
        f"{verdicts['better']} of the {len(gc)} GC cells and worse in {verdicts['worse']}; in "
        f"{verdicts['tie']} the difference lies within the spread of the cell's test runs"
        + (f"; within that spread the filter's mean is behind MoRPI alone's in {'; '.join(lost)}" if lost else "")
        + ". The ablation below shows what each aid contributes.\n\n"
        + no_rest
        + "## Cells (test runs, mean end-point error in % of the route's distance)\n\n"
        + "`train` is the filter's mean end-point error on the training set's train runs with the chosen "
        "tunables, `train LOO` the same with the tunables chosen without the run scored (nested "
        "leave-one-out), `train MoRPI` MoRPI alone on those runs. `smoothed - MoRPI` is the mean of the "
        "per-run differences with its standard error, and the paired t-test's verdict at "
        f"{fmt(alpha * 100, 0)} %: `better`, `worse`, or `tie` where the runs do not tell.\n\n"
        + md_table(["cell", "runs", "smoothed", "forward", "MoRPI alone", "smoothed - MoRPI [pp]",
                    "its steps alone", "INS alone", "paper",
                    "train",
                    "train LOO", "train MoRPI", "tunables (train)"], rows)
        + "\n\n## Ablation (GC cells, each aid removed in turn, smoothed end point)\n\n"
        "Mean change over the GC cells (positive: the aid helps; zero where the chosen filter does not use "
        "the aid, and for the gain state where it is only considered, which changes the covariance, not the "
        "estimate):\n\n"
        + md_table(["removed", "cells", "mean change [pp]", "median change [pp]"], mean_rows)
        + "\n\n" + md_table(["cell", "removed", "full filter %", "without it %", "change [pp]"], abl_rows)
        + "\n\n## Consistency on the field\n\n"
        f"Share of test runs whose true end point lies inside the filter's 95 % horizontal ellipse (chi-square, "
        f"2 dof, {aided.CHI2_95_2DOF:.3f}): **{fmt(study.coverage_95 * 100)} %** (a consistent filter gives 95 %).\n\n"
        "Mean normalized innovation squared per update (a consistent filter gives its degrees of freedom):\n\n"
        + md_table(["measurement", "dof", "mean NIS", "NIS / dof"], nis_rows) + innov_text + "\n"
        + "".join(f"\n![{f}]({f})\n" for f in figures))


def report_aided(out, study, source=None) -> SectionSummary:
    """Write the aided section (README.md, result.json, figures) into `out`.

    Parameters
    ----------
    out : path
        Section folder.
    study : field_aided.AidedStudy
        What :func:`morpi_filters.field_aided.aided_study` computed.
    source : reporting.DataSource, optional
        The recordings of the study (for the synthetic-data banner).

    Returns
    -------
    reporting.SectionSummary
        Name ``"aided"``, the page, the figures written and a one-line
        summary (cells where the smoothed filter beats MoRPI alone, coverage).

    Examples
    --------
    An empty study (no MoRPI cell qualified) still writes its page and JSON:

    >>> import tempfile
    >>> from morpi_filters.field_aided import AidedStudy
    >>> out = Path(tempfile.mkdtemp()) / "aided"
    >>> s = report_aided(out, AidedStudy(cells=(), ablation=(), coverage_95=float("nan"), nis={}, note="no cell"))
    >>> s.name, s.figures, sorted(p.name for p in out.iterdir())
    ('aided', (), ['README.md', 'result.json'])
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "result.json", study_json(study))
    figures = _figures(study, out)
    write_text(out / "README.md", _page(study, source, figures))
    cells = study.cells
    better = sum(c.smoothed_percent < c.morpi_percent for c in cells)
    gc = [c for c in cells if c.spec.calibration == "GC"]
    summary = (f"The MoRPI-aided filter (smoothed) beats MoRPI alone in {better} of {len(cells)} MoRPI cells "
               f"({sum(c.smoothed_percent < c.morpi_percent for c in gc)} of {len(gc)} GC); 95 % ellipse "
               f"coverage {fmt(study.coverage_95 * 100)} %.")
    return SectionSummary(name="aided", title="The MoRPI-aided inertial filter", page="README.md",
                          figures=tuple(figures), summary=summary, synthetic=bool(source is not None and source.synthetic))
