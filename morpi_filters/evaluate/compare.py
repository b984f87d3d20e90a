"""Comparisons built on the table cells: the paper's method comparison, the INS over the whole recording and from
a leveled start, the MoRPI cells under the other way of choosing the rule, under each heading source, origin and
reading, and every numeric claim of the paper beside ours (:func:`paper_claims`)."""
from __future__ import annotations

import numpy as np

from .. import dataset as ds
from .. import steps as st
from ..choice import choose
from ..errors import MorpiError
from ..field import LEVELED, MORPI_METHODS, RULES, held_out_errors
from .cells import INS_METHODS, PAPER_COMPARISON, TablesResult, evaluate_tables, rule_json


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
    from ..field import HEADING_SOURCES, FieldData

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
    from ..field import TURN_MARGIN

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
