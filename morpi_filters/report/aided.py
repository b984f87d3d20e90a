"""The ``aided`` report section: the MoRPI-aided filter on every MoRPI table cell."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..deprecation import renamed_keywords
from ..outputs import write_json, write_text
from ..results import SectionSummary
from . import plots
from .common import collector_paused, banner, fmt, md_table, save_figure


def _nis(d: dict) -> dict:
    """Measurement -> ``{mean, dof, per_dof, band, updates}`` (:func:`field_aided.nis_consistency`)."""
    from ..field_aided import nis_consistency

    out = {}
    for k, (mean, dof, updates) in sorted(d.items()):
        out[k] = {"mean": mean, "dof": dof, **nis_consistency(mean * updates, updates, dof)}
    return out


def _paired(d) -> dict | None:
    if d is None:
        return None
    return {"mean_pp": d.mean_pp, "se_pp": d.se_pp, "runs": d.runs, "p_value": d.p_value, "alpha": d.alpha,
            "verdict": d.verdict, "p_holm": d.p_holm, "verdict_holm": d.verdict_holm,
            "min_detectable_pp": d.mdd_pp, "power": d.power}


def study_json(study) -> dict:
    """The section's JSON (the names of the contract are kept stable).

    Top level: ``cells`` (each with ``table``, ``phone``, ``p2p_m``,
    ``method``, ``calibration``, ``paper_percent``, ``morpi_percent``,
    ``forward_percent``, ``smoothed_percent``, ``runs``), ``ablation`` (list of
    ``{cell, removed, smoothed_percent, ...}``), ``coverage_95`` (fraction) and
    ``tunables``; newer keys beside them.

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
        ``ins_percent``, ``steps_percent`` and ``steps_alone_percent`` (the same: the filter's own step
        vectors summed without the INS), ``train_percent``, ``train_loo_percent``,
        ``train_morpi_percent``, ``nis`` (measurement -> ``{mean, dof, per_dof, band, updates}``: the
        NIS per degree of freedom and its 95 % chi-square band), ``step_innovation``,
        ``smoothed_vs_morpi`` and ``smoothed_vs_steps_alone`` (the smoothed filter minus MoRPI alone, and
        minus its steps alone, paired over the runs: ``mean_pp``, ``se_pp``, ``runs``, ``p_value``,
        ``alpha``, ``verdict``, ``p_holm`` and ``verdict_holm`` (Holm over the cells of the same
        calibration), ``min_detectable_pp`` at ``power``), ``coverage_95`` (smoothed estimate and
        covariance), ``coverage_95_forward``, ``coverage_axes`` (:func:`field_aided.ellipse_coverage` of
        each read-out), ``cross_zero_by_construction``, ``morpi_best_percent`` and ``morpi_reading``
        (MoRPI alone under its best train-chosen heading reading) and ``morpi_length`` (its step length)
        with ``smoothed_vs_morpi_best`` (as ``smoothed_vs_morpi``), ``period_count_percent``,
        ``train_consistency`` (:attr:`field_aided.AidedCell.train_consistency`: the chosen tunables'
        verdict, NIS and coverage on the train runs), ``runs``, ``failed``), ``ablation`` (rows of
        :attr:`field_aided.AidedStudy.ablation`: ``cell``, ``removed``, ``smoothed_percent``,
        ``forward_percent``, ``used``, ``full_percent``, ``full_forward_percent``, ``start``),
        ``coverage_95`` and ``coverage_95_forward`` (the GC cells, each run and method once),
        ``coverage`` (the same with the axes), ``significance`` (:attr:`field_aided.AidedStudy.significance`),
        ``nis`` (as a cell's, over those runs), ``note``, ``no_rest`` (one line per recording without an
        initial rest, on which the filter does not run), ``morpi_readings`` (per method the
        :class:`field_aided.ReadingChoice` fields), ``morpi_lengths`` (per training phone and method the
        :class:`field_aided.LengthChoice` fields) and ``tunables`` (``grid``, ``fixed``, ``chosen``).

    Examples
    --------
    >>> from morpi_filters.field_aided import GRID, AidedStudy
    >>> js = study_json(AidedStudy(cells=(), ablation=(), coverage_95=float("nan"), nis={}, note="no cell"))
    >>> sorted(js)[:5]
    ['ablation', 'cells', 'coverage', 'coverage_95', 'coverage_95_forward']
    >>> sorted(js)[5:]
    ['morpi_lengths', 'morpi_readings', 'nis', 'no_rest', 'note', 'significance', 'tunables']
    >>> js["tunables"]["grid"] == {k: list(v) for k, v in GRID.items()}
    True
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
                      "steps_alone_percent": c.steps_alone_percent,
                      "smoothed_vs_steps_alone": _paired(c.paired_steps),
                      "morpi_best_percent": c.morpi_best_percent, "morpi_reading": c.morpi_reading,
                      "morpi_length": c.morpi_length, "period_count_percent": c.period_count_percent,
                      "smoothed_vs_morpi_best": _paired(c.paired_best),
                      "coverage_95": c.coverage_95, "coverage_95_forward": c.coverage_95_forward,
                      "coverage_axes": c.coverage_axes,
                      "cross_zero_by_construction": c.cross_zero_by_construction,
                      "train_consistency": dict(c.train_consistency),
                      "runs": list(c.runs), "failed": list(c.failed)})
    return {"cells": cells, "ablation": list(study.ablation), "coverage_95": study.coverage_95,
            "coverage_95_forward": study.coverage_95_forward, "coverage": study.coverage,
            "significance": study.significance,
            "nis": _nis(study.nis), "note": study.note, "no_rest": list(study.no_rest),
            "morpi_readings": [dict(r.__dict__) for r in study.readings],
            "morpi_lengths": [dict(r.__dict__) for r in study.lengths],
            "tunables": {"grid": {k: list(v) for k, v in field_aided.GRID.items()},
                         "fixed": {"accel_walk": field_aided.ACCEL_WALK, "nhc_sigma": field_aided.NHC_SIGMA,
                                   "turn_sigma": field_aided.TURN_SIGMA,
                                   "min_train_coverage": field_aided.MIN_TRAIN_COVERAGE,
                                   "nis_band": list(field_aided.NIS_BAND),
                                   **{k: v for k, v in aided.AidTuning().__dict__.items()
                                      if k in ("gyro_walk", "zupt_sigma", "tilt0", "ba0", "bg0")}},
                         "chosen": [{"cell": c.label, "train_percent": c.train_percent, **c.tuning}
                                    for c in study.cells]}}


def _figures(study, out: Path) -> list[str]:
    from ..dataset import route

    if not study.cells:
        return []
    # the figures come with their margins fitted to their labels (no layout pass): each is saved in one draw
    with collector_paused():
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


#: The range of the step updates' NIS per degree of freedom inside which the page does not single a GC cell
#: out (a wording threshold: a consistent filter gives 1, within the cell's chi-square band).
NIS_WORDING_RANGE = (0.2, 5.0)


def _verdict_cell(d, digits: int = 2) -> str:
    """A paired difference as ``mean ± se (verdict at its level, verdict after Holm)``."""
    if d is None or not d.runs:
        return "-"
    return f"{fmt(d.mean_pp, digits)} ± {fmt(d.se_pp, digits)} ({d.verdict}, Holm: {d.verdict_holm})"


def _ins_benefit(c) -> str:
    """Whether the smoothed filter beats its own steps alone, by how much, and what the runs support."""
    d = c.paired_steps
    if d is None or not d.runs:
        return "- (the step direction is the filter's own attitude)"
    if not d.mean_pp < 0:
        return f"no: {fmt(d.mean_pp, 3)} pp behind"
    if d.verdict_holm == "better":
        return f"yes, by {fmt(-d.mean_pp, 3)} pp (significant after Holm)"
    support = (f"significant at {fmt(d.alpha * 100, 0)} % before the correction only" if d.verdict == "better" else
               "within the runs' spread")
    return f"not shown: {fmt(-d.mean_pp, 3)} pp lower on average, {support}"


def _nis_reason(c) -> str:
    """Why a cell's step NIS is far from its degrees of freedom, read from its step innovations."""
    v = c.step_innovation
    if not v:
        return "no step innovations kept"
    ratio = v["along_rms_m"] / v["predicted_along_sigma_m"]
    text = (f"its step innovations spread {fmt(v['along_rms_m'], 3)} m RMS along the step against the "
            f"{fmt(v['predicted_along_sigma_m'], 3)} m the filter expects (median), {fmt(ratio)} times")
    if ratio < 1:
        return (text + f": the filter's INS prediction over one step is far looser than the steps show (vibration "
                f"factor {c.tuning['vibration']:g} on the rest noise, chosen on the train runs), so it expects "
                "innovations several times larger than they are, and each update hands the position to the step "
                "(close to a dead reckoning of the steps)")
    steady = (f", with a steady along-track mean of {fmt(v['along_mean_m'], 3)} m (the INS "
              f"{'overruns' if v['along_mean_m'] < 0 else 'falls short of'} every step)"
              if abs(v["along_mean_m"]) >= STEADY_SHARE * v["along_rms_m"] else "")
    where = ("" if c.spec.table == "short_route" else
             f" on a route the tunables were not trained on (trained on {c.spec.train[0]} {c.spec.train[1]})")
    return text + steady + f": the INS drifts between steps further than the filter's noise allows{where}"


def _consistency(c, kind) -> dict:
    """A cell's NIS of one measurement per degree of freedom and its band (:func:`field_aided.nis_consistency`)."""
    from ..field_aided import nis_consistency

    mean, dof, n = c.nis[kind]
    return nis_consistency(mean * n, n, dof)


def _train_consistency_text(cells, gc) -> str:
    """The chosen tunables' consistency on the train runs, per cell: the verdict, the train NIS per dof of each
    measurement beside the test step NIS, the train ellipse coverage, the nested folds that fell back."""
    from .. import field_aided

    have = [c for c in cells if c.train_consistency]
    if not have:
        return ""
    lo, hi = field_aided.NIS_BAND
    kinds = [k for k in ("step", "zero velocity", "zero rate", "non-holonomic")
             if any(k in c.train_consistency.get("nis", {}) for c in have)]

    def verdict(t):
        if t.get("consistent"):
            return "consistent"
        short = ["ellipse coverage"] if t.get("coverage_95", 1.0) < field_aided.MIN_TRAIN_COVERAGE else []
        return "least inconsistent (outside: " + ", ".join([*t.get("outside", ()), *short]) + ")"

    def train_nis(t, k):
        q = t.get("nis", {}).get(k)
        return "-" if q is None else fmt(q["per_dof"])

    rows = [[c.label, verdict(c.train_consistency), fmt(c.train_consistency.get("coverage_95", np.nan) * 100, 0),
             *[train_nis(c.train_consistency, k) for k in kinds],
             fmt(_consistency(c, "step")["per_dof"]) if "step" in c.nis else "-",
             c.train_consistency.get("loo_fallback", 0)] for c in have]
    fall = [c.label for c in have if not c.train_consistency.get("consistent")]
    gc_have = [c for c in gc if c.train_consistency]
    gc_in = [c for c in gc_have if "step" in c.nis and lo <= _consistency(c, "step")["per_dof"] <= hi]
    return (
        "\n\nThe tunables' consistency on their train runs (the criterion of the choice: the train runs' 95 % "
        f"ellipse holds at least {fmt(field_aided.MIN_TRAIN_COVERAGE * 100, 0)} % of the end points and the NIS "
        f"per dof of every measurement the filter uses, over the train runs' forward passes up to the read-out, "
        f"lies in [{fmt(lo, 1)}, {fmt(hi, 1)}]). "
        + f"{len(have) - len(fall)} of {len(have)} cells' tunables are consistent on their train runs"
        + ("; the others are the least inconsistent grid point: " + "; ".join(fall) + ". " if fall else ". ")
        + f"On the test runs the step NIS per dof of {len(gc_in)} of the {len(gc_have)} GC cells lies in that "
        "range (`test step` below; the whole forward pass, the same step updates as up to the read-out). "
        "`LOO folds not consistent`: nested leave-one-out folds whose own choice found no consistent grid point.\n\n"
        + md_table(["cell", "train verdict", "train ellipse %", *[f"train NIS/dof {k}" for k in kinds],
                    "test NIS/dof step", "LOO folds not consistent"], rows))


def _mean(values) -> float:
    v = [x for x in values if x is not None and np.isfinite(x)]
    return float(np.mean(v)) if v else float("nan")


def _page(study, source, figures) -> str:
    from .. import aided, field_aided

    cells = study.cells
    gc = [c for c in cells if c.spec.calibration == "GC"]
    rd = [c for c in cells if c.spec.calibration == "RD"]
    sig = study.significance or {}
    steps_sig = sig.get("vs_steps_alone", {})
    alpha, power = sig.get("alpha", field_aided.ALPHA), sig.get("power", field_aided.POWER)
    below_paper = [c for c in gc if c.spec.method == "MoRPI-G" and c.smoothed_percent <= c.spec.paper_percent]
    vib = sorted({c.tuning["vibration"] for c in cells})
    headings = sorted({c.tuning["step_heading"] for c in cells})
    mdds = [c.paired.mdd_pp for c in gc if c.paired is not None and c.paired.verdict_holm == "tie"]
    with_steps = [c for c in gc if c.paired_steps is not None and c.paired_steps.runs]
    # the three means over the same cells: those where the filter's steps alone are defined
    m_morpi, m_alone, m_sm = (_mean([getattr(c, k) for c in with_steps])
                              for k in ("morpi_percent", "steps_alone_percent", "smoothed_percent"))
    ins_wins = [c for c in with_steps if c.paired_steps.mean_pp < 0]
    ins_holm = [c.label for c in with_steps if c.paired_steps.verdict_holm == "better"]
    gain = [-c.paired_steps.mean_pp for c in ins_wins]
    rows = [[c.label, len(c.runs), fmt(c.smoothed_percent), fmt(c.forward_percent), fmt(c.morpi_percent),
             _verdict_cell(c.paired), fmt(c.paired.mdd_pp if c.paired is not None else None),
             fmt(c.steps_alone_percent), fmt(c.ins_percent, 0), fmt(c.spec.paper_percent),
             fmt(c.train_percent), fmt(c.train_loo_percent), fmt(c.train_morpi_percent),
             ", ".join(f"{k} {('on' if v else 'off') if isinstance(v, bool) else v if isinstance(v, str) else f'{v:g}'}"
                       for k, v in c.tuning.items() if k in field_aided.GRID)] for c in cells]
    best_sig = sig.get("vs_morpi_best", {})
    best_rows = [[c.label, fmt(c.morpi_percent), c.morpi_reading or "-", c.morpi_length or "-",
                  fmt(c.period_count_percent), fmt(c.morpi_best_percent),
                  fmt(c.steps_alone_percent), fmt(c.smoothed_percent), _verdict_cell(c.paired_best, 3),
                  fmt(c.paired_best.mdd_pp if c.paired_best is not None else None, 3)] for c in cells]
    best_text = (
        "\n\n## Against MoRPI alone under its best train-chosen reading\n\n"
        "MoRPI alone (the cell's steps, Weinberg lengths and trained gain) with the heading reading its own "
        "train runs prefer when the route's heading (the filter's `route` step direction) is offered beside the "
        "rule's reading: the same leave-one-out criterion over the short-route train runs (GC), the route's "
        "heading taken only when it is better by more than "
        f"{field_aided.READING_SE:g} standard error of the paired difference (else the rule's reading stays). "
        "Chosen: " + (", ".join(f"{r.method} {r.reading} (train LOO {fmt(r.rule_percent)} % with the rule's "
                               f"reading, {fmt(r.route_percent)} % with the route's)" for r in study.readings)
                      or "-")
        + ". A second step length is offered beside the Weinberg length: the period count (every half period "
        "the same length, the phone's train distance over its train half periods, per method and calibration), "
        "scored with each phone's training sets held out in turn where it has several (else each run), and "
        "taken with the same tolerance. Chosen: "
        + (", ".join(f"{r.phone} {r.method} {r.length} (held-out error {fmt(r.weinberg_percent)} % Weinberg, "
                     f"{fmt(r.period_percent)} % period count, per {r.held_out})" for r in study.lengths) or "-")
        + f". Over the GC cells the smoothed filter is better run by run in "
        f"{best_sig.get('wins_uncorrected', '-')} and worse in {best_sig.get('losses_uncorrected', '-')} at "
        f"{fmt(alpha * 100, 0)} %; after Holm over the {best_sig.get('cells', '-')} GC cells better in "
        f"{best_sig.get('wins_corrected', '-')}, worse in {best_sig.get('losses_corrected', '-')}, a tie in "
        f"{best_sig.get('ties_corrected', '-')}.\n\n"
        + md_table(["cell", "MoRPI alone %", "best reading", "best length", "period count %", "MoRPI best %",
                    "its steps alone %", "smoothed %",
                    "smoothed - MoRPI best [pp]", "smallest detectable [pp]"], best_rows))
    ins_rows = [[c.label, fmt(c.steps_alone_percent), fmt(c.smoothed_percent), _verdict_cell(c.paired_steps, 3),
                 fmt(c.paired_steps.mdd_pp if c.paired_steps is not None else None, 3), _ins_benefit(c)]
                for c in cells]
    # the ablation: both read-outs of the filter without the aid against the same read-outs of the filter
    # it is compared with
    abl = study.ablation
    change = lambda a, k, f: a[k] - a[f]  # noqa: E731
    abl_rows = [[a["cell"], a["removed"], "yes" if a["used"] else "no (not run)", a["start"],
                 fmt(a["full_percent"]), fmt(a["smoothed_percent"]), fmt(change(a, "smoothed_percent", "full_percent")),
                 fmt(a["full_forward_percent"]), fmt(a["forward_percent"]),
                 fmt(change(a, "forward_percent", "full_forward_percent"))] for a in abl]
    mean_rows = []
    for name in field_aided.ABLATIONS:
        sel = [a for a in abl if a["removed"] == name]
        if not sel:
            continue
        used = [a for a in sel if a["used"]]
        ds = [change(a, "smoothed_percent", "full_percent") for a in sel]
        df = [change(a, "forward_percent", "full_forward_percent") for a in sel]
        mean_rows.append([name, f"{len(used)} of {len(sel)}", fmt(float(np.mean(ds))), fmt(float(np.median(ds))),
                          fmt(float(np.mean(df))), fmt(float(np.median(df)))])
    # consistency per cell
    kinds = sorted({k for c in cells for k in c.nis})

    def nis_cell(c, k):
        if k not in c.nis:
            return "-"
        q = _consistency(c, k)
        return f"{fmt(q['per_dof'])} [{fmt(q['band'][0])}, {fmt(q['band'][1])}]"

    cons_rows = [[c.label, len(c.runs), fmt(c.coverage_95 * 100, 0), fmt(c.coverage_95_forward * 100, 0),
                  fmt(c.coverage_axes.get("smoothed", {}).get("along_95", np.nan) * 100, 0),
                  fmt(c.coverage_axes.get("smoothed", {}).get("cross_95", np.nan) * 100, 0)
                  + (" (by construction)" if c.cross_zero_by_construction else ""),
                  *[nis_cell(c, k) for k in kinds]] for c in cells]
    lo, hi = NIS_WORDING_RANGE
    odd = []
    for c in gc:
        if "step" in c.nis:
            q = _consistency(c, "step")
            if not lo <= q["per_dof"] <= hi:
                odd.append(f"- {c.label}: step NIS per dof {fmt(q['per_dof'], 3)} (band {fmt(q['band'][0])} to "
                           f"{fmt(q['band'][1])}); {_nis_reason(c)}.")
    others = []
    for k in kinds:
        if k == "step":
            continue
        off = [(c.label, _consistency(c, k)["per_dof"]) for c in gc if k in c.nis]
        off = [(lab, v) for lab, v in off if not lo <= v <= hi]
        if off:
            vals = [v for _, v in off]
            others.append(f"{k} in {len(off)} of {len(gc)} ({fmt(min(vals))} to {fmt(max(vals))})")
    steps_q = [_consistency(c, "step") for c in gc if "step" in c.nis]
    per_dof = [q["per_dof"] for q in steps_q]
    in_band = sum(q["band"][0] <= q["per_dof"] <= q["band"][1] for q in steps_q)
    straight = [c for c in gc if c.cross_zero_by_construction]
    train_text = _train_consistency_text(cells, gc)
    nis_rows = []
    for k, (mean, dof, n) in sorted(study.nis.items()):
        q = field_aided.nis_consistency(mean * n, n, dof)
        nis_rows.append([k, dof, n, fmt(mean), fmt(q["per_dof"]), f"[{fmt(q['band'][0])}, {fmt(q['band'][1])}]"])
    cov = study.coverage or {}
    cs, cf = cov.get("smoothed", {}), cov.get("forward", {})
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
    rd_text = ""
    if rd:
        rd_better = sum(c.smoothed_percent < c.morpi_percent for c in rd)
        rd_holm = sum(c.paired is not None and c.paired.verdict_holm == "better" for c in rd)
        rd_text = (
            f" On the RD cells the smoothed filter's mean is below MoRPI alone's in {rd_better} of {len(rd)} "
            f"({rd_holm} after Holm over the RD cells): there MoRPI alone carries the raw gyro bias in its heading, "
            "and the filter's rest updates calibrate the gyro at rest, as the GC calibration does for MoRPI alone; "
            "these wins are that calibration, not the aiding.")
    gc_text = ""
    if gc:
        gc_text = (
            f"Against the baselines that say whether the INS adds anything, on the GC cells run by run with Holm's "
            f"correction: against MoRPI alone under its best train-chosen reading (below) the smoothed filter is "
            f"better in {best_sig.get('wins_corrected', '-')} and worse in {best_sig.get('losses_corrected', '-')} "
            f"of {best_sig.get('cells', '-')}; against its own steps summed without the INS, better in "
            f"{steps_sig.get('wins_corrected', '-')} and worse in {steps_sig.get('losses_corrected', '-')} of the "
            f"{steps_sig.get('cells', '-')} cells where they are defined. Against plain MoRPI alone: "
            f"on the GC cells (the gyro's rest bias removed for both), the smoothed filter's mean end-point error is "
            f"below MoRPI alone's in {sum(c.smoothed_percent < c.morpi_percent for c in gc)} of {len(gc)}. Run by "
            f"run (two-sided paired t-test at {fmt(alpha * 100, 0)} %), it is better in "
            f"{sig.get('wins_uncorrected', '-')} and worse in {sig.get('losses_uncorrected', '-')} before any "
            f"correction; with Holm's step-down correction over the {sig.get('cells', len(gc))} GC cells (the "
            f"family-wise level {fmt(alpha * 100, 0)} %), better in {sig.get('wins_corrected', '-')}, worse in "
            f"{sig.get('losses_corrected', '-')}, and a tie in {sig.get('ties_corrected', '-')}. A tie is no "
            f"equivalence: the smallest true difference each tied cell's runs would have shown with "
            f"{fmt(power * 100, 0)} % probability (paired t, {fmt(alpha * 100, 0)} %, before the correction; "
            f"`smallest detectable` below) is {fmt(min(mdds) if mdds else None)} to "
            f"{fmt(max(mdds) if mdds else None)} pp. MoRPI-G GC is at or below the paper's number in "
            f"{len(below_paper)} of {sum(c.spec.method == 'MoRPI-G' for c in gc)} route cells.")
    margin_text = ""
    if gc:
        on_route = [c for c in gc if c.tuning.get("step_heading") == "route"]
        gaps = [abs(c.smoothed_percent - c.steps_alone_percent) for c in with_steps]
        reading = (f"The filter reads its step directions from the route's heading (straight between the turns the "
                   f"gyro shows) in {len(on_route)} of the {len(gc)} GC cells (the train runs' choice), a reading "
                   "MoRPI alone is offered too (its best train-chosen reading, below)" if on_route else
                   "The filter reads its step directions from its own attitude")
        margin_text = (
            f"\n\n**What the margin is made of.** {reading}; and the train runs choose vibration factors of "
            + ", ".join(f"{v:g}" for v in vib) +
            " on the rest noise (the least error among the grid points consistent on the train runs)"
            + (f": the smoothed filter's mean end-point error differs from that of its own steps alone (the same "
               f"step vectors summed without the INS) by {fmt(float(np.mean(gaps)), 3)} pp on average over the "
               f"GC cells, at most {fmt(max(gaps), 3)} pp. Over the {len(with_steps)} GC cells where its steps alone "
               f"are defined, they reach {fmt(m_alone)} % on average, against {fmt(m_morpi)} % for MoRPI alone and "
               f"{fmt(m_sm)} % for the smoothed filter: the step direction it reads changes the mean error by "
               f"{m_alone - m_morpi:+.2f} pp against MoRPI alone, the INS by {m_sm - m_alone:+.2f} pp more "
               f"(negative: a smaller error). The smoothed filter beats its own steps "
               f"alone in {len(ins_wins)} of {len(with_steps)} GC cells"
               + (f", by {fmt(min(gain), 3)} to {fmt(max(gain), 3)} pp" if gain else "")
               + f"; run by run the difference is significant in {steps_sig.get('wins_uncorrected', '-')} at "
               f"{fmt(alpha * 100, 0)} % and in {steps_sig.get('wins_corrected', '-')} after Holm over the GC "
               "cells" + (f" ({'; '.join(ins_holm)})" if ins_holm else "")
               + ". An INS benefit is claimed only there; the table `What the INS adds` gives every cell."
               if with_steps else "."))
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
        "Tunables are chosen per training set, method and calibration on the train runs only, in two stages. "
        "First, over the grid with the gain considered, with and without the non-holonomic updates, the least "
        "mean train end-point error among the grid points consistent on the train runs: their 95 % ellipse holds "
        "at least "
        f"{fmt(field_aided.MIN_TRAIN_COVERAGE * 100, 0)} % of the train end points and the normalized innovation "
        "squared per degree of freedom of every measurement they use (steps, zero velocity, zero rate, "
        "non-holonomic), over the train runs' forward passes up to the read-out, lies in "
        f"[{fmt(field_aided.NIS_BAND[0], 1)}, {fmt(field_aided.NIS_BAND[1], 1)}] (a factor "
        f"{fmt(field_aided.NIS_BAND[1], 0)} on either side of 1: the chi-square band of the mean over the train "
        "updates is a few per cent wide and no field filter with modelled noise keeps it). When no grid point is "
        "consistent, the least inconsistent compete: those whose ellipse holds enough end points, among them those "
        "with the fewest measurement types outside the band, and the least error of them wins (the page names "
        "these cells). Then, at the chosen point, the non-holonomic updates are dropped unless the filter with "
        "them is less inconsistent on the train runs or, as consistent, improves the train end points by more "
        "than one standard error, and the gain is estimated only where that filter is no less consistent, its "
        "estimates explain the train runs' own gain errors and it improves the end points by more than one "
        "standard error. The nested leave-one-out (`train LOO`) repeats the whole rule without the run it "
        "scores. Grid "
        f"`{dict(field_aided.GRID)}`; the noise densities are the rest windows' own (median over the train runs) "
        "times the vibration factor; the gain error's prior is the trained gain's spread.\n\n"
        "**Verdict.** " + gc_text + rd_text + margin_text + "\n\n"
        + no_rest
        + "## Cells (test runs, mean end-point error in % of the route's distance)\n\n"
        "`train` is the filter's mean end-point error on the training set's train runs with the chosen "
        "tunables, `train LOO` the same with the tunables chosen without the run scored (nested "
        "leave-one-out), `train MoRPI` MoRPI alone on those runs, `its steps alone` the filter's own step "
        "vectors (the lengths and directions it is fed) summed without the INS. `smoothed - MoRPI` is the mean "
        "of the per-run differences with its standard error and the paired t-test's verdict at "
        f"{fmt(alpha * 100, 0)} % (`better`, `worse`, or `tie` where the runs do not tell), then after Holm's "
        "correction over the cells of the same calibration; `smallest detectable` is the true mean difference "
        f"the test would have found with {fmt(power * 100, 0)} % probability at {fmt(alpha * 100, 0)} %, given "
        "the cell's runs and their spread (noncentral t).\n\n"
        + md_table(["cell", "runs", "smoothed", "forward", "MoRPI alone", "smoothed - MoRPI [pp]",
                    "smallest detectable [pp]", "its steps alone", "INS alone", "paper", "train",
                    "train LOO", "train MoRPI", "tunables (train)"], rows)
        + "\n\n## What the INS adds (the smoothed filter against its own steps alone)\n\n"
        "Per cell: the steps alone, the smoothed filter, their paired difference (negative: the INS helps), "
        "with the same tests as above, and whether the filter beats its steps alone.\n\n"
        + md_table(["cell", "its steps alone %", "smoothed %", "smoothed - steps alone [pp]",
                    "smallest detectable [pp]", "INS benefit"], ins_rows)
        + best_text
        + "\n\n## Ablation (GC cells, each aid removed in turn)\n\n"
        "The filter without the aid against the filter with it, both read the same way: smoothed, and forward. "
        "An aid the chosen filter does not use is not run (`used`: no): its row repeats the full filter, its "
        "effect is zero by construction; the gain state counts as used only where it is estimated (a considered "
        "gain changes the covariance, not the estimate). Without smoothing both read-outs are the forward "
        "filter's. The rest updates are removed from a filter started at the motion onset and compared with the "
        "filter started there with them (`start`): from the initial rest window, the same removal would also "
        "drop the zero-velocity hold between that window and the onset, and measure the drift of a filter "
        "left free before the robot moves. Positive changes: the aid helps.\n\n"
        + md_table(["removed", "used in", "mean change smoothed [pp]", "median change smoothed [pp]",
                    "mean change forward [pp]", "median change forward [pp]"], mean_rows)
        + "\n\n" + md_table(["cell", "removed", "used", "start", "with it, smoothed %", "without it, smoothed %",
                             "change [pp]", "with it, forward %", "without it, forward %", "change [pp]"], abl_rows)
        + "\n\n## Consistency on the field\n\n"
        "Share of test runs whose true end point lies inside the filter's 95 % horizontal ellipse (chi-square, "
        f"2 dof, {aided.CHI2_95_2DOF:.3f}), over the GC cells with each (run, method) counted once "
        f"({cs.get('runs', 0)} runs): **{fmt(cs.get('inside_95', np.nan) * 100)} %** for the smoothed estimate "
        f"with the smoothed covariance, {fmt(cf.get('inside_95', np.nan) * 100)} % for the forward estimate "
        "with the forward covariance (a consistent filter gives 95 %). Each axis apart (within 1.96 sigma): "
        f"along the route {fmt(cs.get('along_95', np.nan) * 100)} % smoothed, "
        f"{fmt(cf.get('along_95', np.nan) * 100)} % forward; across it {fmt(cs.get('cross_95', np.nan) * 100)} % "
        f"smoothed, {fmt(cf.get('cross_95', np.nan) * 100)} % forward. In {len(straight)} of the {len(gc)} GC "
        "cells (the straight routes, `by construction` below) every step vector points along the route: the "
        "steps put no cross-track displacement, the cross-track estimate is the INS's residue under a loose INS, "
        "and the ellipse there tests the along-track axis only.\n\n"
        "Per cell, the coverage (smoothed and forward ellipse, smoothed along- and cross-track) and the "
        "normalized innovation squared per degree of freedom of each measurement, over the whole forward pass of "
        "every run, with the two-sided 95 % chi-square band of its number of updates (a consistent filter "
        f"stays inside). The step NIS per dof of the GC cells runs from {fmt(min(per_dof) if per_dof else None, 3)} "
        f"to {fmt(max(per_dof) if per_dof else None, 3)}; {in_band} of {len(per_dof)} lie inside their band.\n\n"
        + md_table(["cell", "runs", "ellipse smoothed %", "ellipse forward %", "along smoothed %",
                    "cross smoothed %", *[f"NIS/dof {k} [band]" for k in kinds]], cons_rows)
        + (("\n\nGC cells whose step NIS per dof lies outside "
            f"[{fmt(lo, 1)}, {fmt(hi, 1)}]:\n\n" + "\n".join(odd)) if odd else
           f"\n\nNo GC cell's step NIS per dof lies outside [{fmt(lo, 1)}, {fmt(hi, 1)}].")
        + (f"\n\nOutside that range too, for the other measurements of the GC cells: {'; '.join(others)}."
           if others else "")
        + train_text
        + "\n\nMean normalized innovation squared per update over the same GC runs as the coverage:\n\n"
        + md_table(["measurement", "dof", "updates", "mean NIS", "NIS / dof", "95 % band"], nis_rows)
        + innov_text + "\n"
        + "".join(f"\n![{f}]({f})\n" for f in figures))


@renamed_keywords(source="data_source")
def report_aided(out, study, data_source=None) -> SectionSummary:
    """Write the aided section (README.md, result.json, figures) into `out`.

    Parameters
    ----------
    out : path
        Section folder.
    study : field_aided.AidedStudy
        What :func:`morpi_filters.field_aided.aided_study` computed.
    data_source : results.DataSource, optional
        The recordings of the study (for the synthetic-data banner).

    Returns
    -------
    results.SectionSummary
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
    write_text(out / "README.md", _page(study, data_source, figures))
    sig = study.significance or {}
    summary = (f"The MoRPI-aided filter (smoothed) against MoRPI alone on the GC cells, run by run: better in "
               f"{sig.get('wins_uncorrected', '-')} of {sig.get('cells', 0)} at 5 %, "
               f"{sig.get('wins_corrected', '-')} after Holm's correction; against its own steps alone better in "
               f"{sig.get('vs_steps_alone', {}).get('wins_corrected', '-')} after Holm; 95 % ellipse coverage "
               f"{fmt(study.coverage_95 * 100)} % (smoothed, each GC run and method once).")
    return SectionSummary(name="aided", title="The MoRPI-aided inertial filter", page="README.md",
                          figures=tuple(figures), summary=summary, synthetic=bool(data_source is not None and data_source.synthetic))
