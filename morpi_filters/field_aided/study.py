"""The aided filter on every MoRPI cell of the tables (:func:`aided_study`) and its frozen result."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import aided
from ..errors import MorpiError
from .ablation import ABLATIONS, ablation_row, aid_used
from .baselines import choose_length, choose_reading, period_length, period_sums, route_sums, steps_alone
from .inputs import prepared_runs
from .significance import ALPHA, POWER, PairedDifference, ellipse_coverage, holm, paired_difference
from .tuning import choose_tunables_many, tuning_from


@dataclass(frozen=True)
class AidedCell:
    """The aided filter on one MoRPI table cell (test runs).

    Attributes
    ----------
    spec : evaluate.CellSpec
    forward_percent, smoothed_percent, morpi_percent, ins_percent : float
        Mean end-point error over the runs [% of the route's distance].
    runs : tuple of dict
        Per run: ``file``, end-point errors [m] (``forward_m``, ``smoothed_m``, ``morpi_m``, ``ins_m``,
        ``steps_m`` and ``steps_alone_m``, the same: :func:`steps_alone`), ``mahalanobis2`` and
        ``inside_95`` of the true end point under the forward covariance, ``mahalanobis2_smoothed`` and
        ``inside_95_smoothed`` under the smoothed one, estimated gain error and its sigma.
    tuning : dict
        The grid point chosen on the train runs, and the noise densities used.
    train_percent : float
        Its mean train end-point error [%].
    train_loo_percent : float
        The same with the tunables chosen in a nested leave-one-out over the train runs [%].
    train_morpi_percent : float
        MoRPI alone on those train runs [%].
    nis : dict
        Measurement name -> (mean NIS per update, dof, updates), over the whole forward pass of every run.
    paths : tuple
        Per run, up to the epoch where the end point is read (``Prepared.stop_s``): (epoch time,
        forward xy, smoothed xy, MoRPI xy, forward P_xy) for figures.
    failed : tuple of str
        Runs of the tables' cell the filter could not run, one line each.
    steps_percent : float
        :attr:`steps_alone_percent` (the name of an earlier contract).
    step_innovation : dict
        The forward filter's step updates over the runs, up to the read-out
        (:func:`aided.step_innovation_components`): ``updates``, the measured
        step minus the INS's displacement since the last boundary along the
        step (``along_mean_m``, ``along_rms_m``; positive: the INS fell
        short) and across it (``cross_mean_m``, ``cross_rms_m``) [m], and the
        median spread the filter expected along the step
        (``predicted_along_sigma_m``) [m]; empty without step updates.
    paired : PairedDifference or None
        The smoothed filter minus MoRPI alone, run by run (:func:`paired_difference`; Holm-adjusted over
        the study's cells of its calibration).
    steps_alone_percent : float
        The filter's own step vectors summed without the INS (:func:`steps_alone`: the same lengths and
        directions the filter is fed; NaN when the direction is the filter's attitude) [%].
    paired_steps : PairedDifference or None
        The smoothed filter minus its steps alone, run by run: what the INS adds (negative: it helps).
    coverage_95, coverage_95_forward : float
        Share of the runs whose true end point lies inside the 95 % ellipse of the smoothed estimate
        (smoothed covariance) and of the forward one (forward covariance).
    coverage_axes : dict
        ``{"smoothed": {...}, "forward": {...}}``, each :func:`ellipse_coverage` (the ellipse and the
        along- and cross-track axes apart).
    cross_zero_by_construction : bool
        Every step vector of every run lies along the route's start-to-end line: the steps put no
        cross-track displacement, so the cross-track estimate is the INS's alone (near zero under a
        loose INS) and the ellipse tests the along-track axis.
    morpi_best_percent : float
        MoRPI alone (the same steps, Weinberg lengths, trained gain, method and calibration) under its best
        train-chosen heading reading (:func:`choose_reading`: the rule's own or the route's heading) and
        step length (:func:`choose_length`: the Weinberg length or the period count) [%];
        per run ``morpi_best_m`` in :attr:`runs`.
    morpi_reading : str
        That reading (:attr:`ReadingChoice.reading`).
    morpi_length : str
        Its step length (:attr:`LengthChoice.length`, chosen for the training phone and method).
    period_count_percent : float
        MoRPI alone with the period count (:func:`period_sums`, the half-period length
        :func:`period_length` of the training phone, method and calibration) and the chosen reading [%];
        per run ``period_count_m``.
    paired_best : PairedDifference or None
        The smoothed filter minus :attr:`morpi_best_percent`'s MoRPI alone, run by run (Holm-adjusted over
        the study's cells of its calibration).
    train_consistency : dict
        The chosen tunables on the train runs (:class:`TunableChoice`): ``consistent`` (every measurement
        type's NIS per dof in :data:`NIS_BAND` and the 95 % ellipse holding at least
        :data:`MIN_TRAIN_COVERAGE` of the end points; False: the least inconsistent grid point),
        ``nis`` (type -> ``{per_dof, updates, dof}``, the forward passes up to the read-out),
        ``coverage_95`` (forward ellipse), ``outside`` (the types outside the band) and ``loo_fallback``
        (nested leave-one-out folds whose choice was not consistent).
    """

    spec: object
    forward_percent: float
    smoothed_percent: float
    morpi_percent: float
    ins_percent: float
    runs: tuple
    tuning: dict
    train_percent: float
    train_loo_percent: float
    train_morpi_percent: float
    nis: dict
    paths: tuple
    failed: tuple = ()
    steps_percent: float = float("nan")
    step_innovation: dict = field(default_factory=dict)
    paired: PairedDifference | None = None
    steps_alone_percent: float = float("nan")
    paired_steps: PairedDifference | None = None
    coverage_95: float = float("nan")
    coverage_95_forward: float = float("nan")
    coverage_axes: dict = field(default_factory=dict)
    cross_zero_by_construction: bool = False
    morpi_best_percent: float = float("nan")
    morpi_reading: str = ""
    paired_best: PairedDifference | None = None
    morpi_length: str = ""
    period_count_percent: float = float("nan")
    train_consistency: dict = field(default_factory=dict)

    @property
    def label(self) -> str:
        return self.spec.label


@dataclass(frozen=True)
class AidedStudy:
    """Every MoRPI cell, the ablation on the GC cells, the field coverage, NIS and significance.

    Attributes
    ----------
    cells : tuple of AidedCell
    ablation : tuple of dict
        Per GC cell and aid of :data:`ABLATIONS`: ``cell``, ``removed``, ``used`` (:func:`aid_used`),
        the filter without the aid read smoothed (``smoothed_percent``) and forward
        (``forward_percent``), the filter it is compared with read the same two ways
        (``full_percent``, ``full_forward_percent``) and where both start (``start``: ``"rest window"``,
        the cells' filter; ``"motion onset"`` for the rest updates). An aid not used is not run: its
        values are the full filter's, its effect exactly zero. Without smoothing both read-outs are
        the forward filter's.
    coverage_95, coverage_95_forward : float
        Share of the GC cells' test runs, each (run, method) once, whose true end point is inside the
        smoothed (forward) filter's 95 % ellipse.
    nis : dict
        Measurement name -> (mean NIS per update, dof, updates) over the same runs.
    note : str
        Why the study is empty, when it is.
    coverage : dict
        ``{"smoothed": ..., "forward": ...}``: ``runs`` and the shares of :func:`ellipse_coverage` over
        the same runs (each run's axes those of its route).
    significance : dict
        The paired tests over the GC cells (``family``), Holm-corrected (``correction``): for the
        smoothed filter against MoRPI alone ``wins_uncorrected``, ``wins_corrected``,
        ``losses_uncorrected``, ``losses_corrected``, ``ties_corrected``; the same against its own steps
        alone under ``vs_steps_alone``, against MoRPI alone under its best train-chosen reading under
        ``vs_morpi_best``; ``alpha``, ``power`` (of the smallest detectable differences).
    readings : tuple of ReadingChoice
        MoRPI alone's train-chosen heading reading per method (:func:`choose_reading`).
    lengths : tuple of LengthChoice
        Its train-chosen step length per training phone and method (:func:`choose_length`).
    no_rest : tuple of str
        One line per recording without an initial rest
        (:meth:`~morpi_filters.field.FieldData.no_rest`): the filter starts
        at the rest window and takes its noise there, so it does not run on
        them (each cell names them among its failed runs).
    """

    cells: tuple
    ablation: tuple
    coverage_95: float
    nis: dict
    note: str = ""
    coverage_95_forward: float = float("nan")
    coverage: dict = field(default_factory=dict)
    significance: dict = field(default_factory=dict)
    readings: tuple = ()
    lengths: tuple = ()
    no_rest: tuple = ()


def _innovation_summary(parts) -> dict:
    """Along- and cross-track step innovations of a cell's runs (:func:`aided.step_innovation_components`)."""
    if not parts:
        return {}
    along, cross, sigma = (np.concatenate([q[j] for q in parts]) for j in range(3))
    ok = np.isfinite(along)
    along, cross, sigma = along[ok], cross[ok], sigma[ok]
    if not along.size:
        return {}
    rms = lambda a: float(np.sqrt(np.mean(a * a)))  # noqa: E731
    return {"updates": int(along.size), "along_mean_m": float(along.mean()), "along_rms_m": rms(along),
            "cross_mean_m": float(cross.mean()), "cross_rms_m": rms(cross),
            "predicted_along_sigma_m": float(np.median(sigma))}


def _merge_nis(acc, nis):
    for name, (s, c, dof) in nis.items():
        a = acc.setdefault(name, [0.0, 0, dof])
        a[0] += s
        a[1] += c


def _nis_means(acc) -> dict:
    return {k: (v[0] / max(v[1], 1), v[2], v[1]) for k, v in acc.items()}


def _family(cells, key) -> dict:
    """Holm over the cells' paired differences `key` (``paired`` or ``paired_steps``): the cells with
    the adjusted p-values, and the counts of wins, losses and ties before and after the correction."""
    pairs = [getattr(c, key) for c in cells]
    adj, _ = holm([np.nan if d is None else d.p_value for d in pairs])
    pairs = [None if d is None else replace(d, p_holm=float(a)) for d, a in zip(pairs, adj)]
    tested = [d for d in pairs if d is not None]
    count = lambda attr, v: sum(getattr(d, attr) == v for d in tested)  # noqa: E731
    summary = {"cells": len(tested), "wins_uncorrected": count("verdict", "better"),
               "wins_corrected": count("verdict_holm", "better"),
               "losses_uncorrected": count("verdict", "worse"), "losses_corrected": count("verdict_holm", "worse"),
               "ties_corrected": count("verdict_holm", "tie")}
    return pairs, summary


def aided_study(root=None, result=None, labels=None, ablation: bool = True,
                workers: int | None = None) -> AidedStudy:
    """The aided filter on every MoRPI cell of :func:`evaluate.evaluate_tables`.

    Parameters
    ----------
    root : path, optional
        Dataset root (when `result` is not given).
    result : evaluate.TablesResult, optional
        Reuse a computed evaluation (its cells, gains, step rules and caches).
    labels : collection of str, optional
        Only these cells (``CellSpec.label``).
    ablation : bool
        Also run the GC cells with each aid they use removed in turn.
    workers : int, optional
        Threads that run the filter (:func:`morpi_filters.aided.run_batch`;
        default: the cores this process may use). The results do not depend on it.

    Returns
    -------
    AidedStudy
        The cells in the tables' order, the ablation rows (GC cells only, when
        `ablation`), the 95 % coverage and the NIS per measurement over the GC
        cells' test runs, the paired tests Holm-corrected over the GC cells;
        empty with a ``note`` when no cell qualifies.
    """
    from .. import dataset as ds
    from ..evaluate import evaluate_tables

    # the MoRPI cells, their gains and step rules (the filter's own INS-alone column is computed here)
    res = result if result is not None else evaluate_tables(root, alternatives=False, ins=False)
    data = res.data
    gmap = {(g.phone, g.route, g.method, g.calibration): g for g in res.gains}
    wanted = [c for c in res.cells if c.spec.train is not None and c.runs
              and (labels is None or c.spec.label in labels)
              and (c.spec.train[0], c.spec.train[1], c.spec.method, c.spec.calibration) in gmap]
    # the tunables of every training set, method and calibration in one search
    keys = sorted({(c.spec.train, c.spec.method, c.spec.calibration) for c in wanted})
    picks = choose_tunables_many(data, [(tr, m, cal, res.selections[m].config, gmap[(tr[0], tr[1], m, cal)])
                                        for tr, m, cal in keys], workers=workers)
    chosen = {k: v for k, v in zip(keys, picks) if not isinstance(v, MorpiError)}
    # MoRPI alone's best train-chosen heading reading per method: the baseline the filter is also tested against
    readings = {m: choose_reading(data, m, res.selections[m].config) for m in sorted({c.spec.method for c in wanted})}
    # and its step length per training phone and method (the Weinberg length or the period count), the period
    # count's half-period length per phone, method and calibration
    lengths = {(ph, m): choose_length(data, ph, m, res.selections[m].config, readings[m].reading)
               for ph, m in sorted({(c.spec.train[0], c.spec.method) for c in wanted})}
    halves = {(ph, m, cal): period_length(data, ph, cal, m, res.selections[m].config, readings[m].reading)
              for ph, m, cal in sorted({(c.spec.train[0], c.spec.method, c.spec.calibration) for c in wanted})}
    todo = []
    for cell in wanted:
        sp = cell.spec
        g = gmap[(sp.train[0], sp.train[1], sp.method, sp.calibration)]
        config = res.selections[sp.method].config
        key = (sp.train, sp.method, sp.calibration)
        if key not in chosen:
            continue
        choice = chosen[key]
        score, info, noise = choice.score_percent, choice.info, choice.noise
        by_file = {r.file: r for r in cell.runs}
        failed = []
        runs = [p for p in prepared_runs(data, sp.phone, sp.route, sp.split, sp.calibration, sp.method, config,
                                          g.mean, failed) if p.rel in by_file]
        # every run of the tables' cell is evaluated, or named
        failed += [f"{rel}: not prepared for the aided filter" for rel in sorted(set(by_file) - {p.rel for p in runs})
                   if not any(rel in m for m in failed)]
        if runs:
            todo.append((cell, g, score, info, noise, runs, by_file, choice, tuple(failed)))
    no_rest = tuple(data.no_rest_lines())
    if not todo:
        return AidedStudy((), (), float("nan"), {}, note="No MoRPI table cell could be evaluated on these recordings.",
                          no_rest=no_rest)
    # one pass per route: every cell's test runs (smoothed, with the smoothed covariance) and, for the GC
    # cells, the filter with each aid it uses removed in turn (smoothed: both read-outs), the rest updates
    # removed from a filter started at the motion onset, beside that filter with them
    results, abl_res = {}, {}
    for route in sorted({c.spec.route for c, *_ in todo}):
        items, abl_items = [], []
        for i, (cell, g, score, info, noise, runs, by_file, _, _) in enumerate(todo):
            if cell.spec.route != route:
                continue
            base = tuning_from(noise, info, g.std / g.mean)
            items += [(i, p, None, base, p.input_for(info)) for p in runs]
            if ablation and cell.spec.calibration == "GC":
                for name, change in ABLATIONS.items():
                    if not change or not aid_used(name, base):
                        continue
                    if name == "rest updates":
                        abl_items += [(i, p, (name, "with"), base, p.onset_input(info)) for p in runs]
                        abl_items += [(i, p, (name, "without"), base.with_(**change), p.onset_input(info))
                                      for p in runs]
                    else:
                        abl_items += [(i, p, (name, "without"), base.with_(**change), p.input_for(info))
                                      for p in runs]
        out = aided.run_batch([q[4] for q in items], [q[3] for q in items], smooth=True, smoothed_covariance=True,
                              innovations=True, workers=workers)
        for (i, p, *_), r in zip(items, out):
            results[(i, p.rel)] = r
        out = aided.run_batch([q[4] for q in abl_items], [q[3] for q in abl_items], smooth=True,
                              smoothed_covariance=False, nis=False, workers=workers) if abl_items else []
        for (i, p, name, *_), r in zip(abl_items, out):
            abl_res[(i, p.rel, name)] = r
    cells, abl = [], []
    for i, (cell, g, score, info, noise, runs, by_file, choice, failed) in enumerate(todo):
        sp = cell.spec
        truth = ds.route(sp.route)
        d = truth.distance_m / 100
        end = np.asarray(truth.end_point_m, float)
        along = end / np.linalg.norm(end)
        rows, paths, nis, innov = [], [], {}, []
        err_sm, P_sm, err_fw, P_fw = [], [], [], []
        cross_free = info["step_heading"] == "route"
        for p in runs:
            r = results[(i, p.rel)]
            j = r.index_at(p.stop_s)
            if "step" in r.innovations:
                # the step updates up to the read-out epoch (after it the phone may be handled)
                inn = r.innovations["step"]
                k = int(np.searchsorted(inn.time, r.time[j], side="right"))
                innov.append([c[:k] for c in aided.step_innovation_components(inn)])
            rec = next(x for x in data.recordings(sp.phone, sp.route, sp.split) if data.relpath(x) == p.rel)
            try:
                ins = np.asarray(data.ins(rec, sp.calibration, "INS-3D").position)[-1, :2]
                ins_m = float(np.linalg.norm(ins - end))
            except MorpiError:
                ins_m = float("nan")
            end_xy, end_P, end_sm, end_Ps = r.position[j, :2], r.P_xy[j], r.smoothed[j, :2], r.P_xy_smoothed[j]
            dxy, dsm = end_xy - end, end_sm - end
            m2 = float(dxy @ np.linalg.solve(end_P, dxy))
            m2s = float(dsm @ np.linalg.solve(end_Ps, dsm))
            err_fw.append(dxy), P_fw.append(end_P), err_sm.append(dsm), P_sm.append(end_Ps)
            _merge_nis(nis, r.nis)
            inp = p.input_for(info)
            alone = steps_alone(inp) if info["step_heading"] == "route" else np.full(2, np.nan)
            morpi_m = float(by_file[p.rel].end_error_m)
            reading, rule = readings[sp.method].reading, res.selections[sp.method].config
            if reading == "route":
                u = route_sums(data, rec, sp.calibration, sp.method, rule)[1]
                best_m = float(np.linalg.norm(g.mean * u - end))
            else:
                best_m = morpi_m
            u = period_sums(data, rec, sp.calibration, sp.method, rule, reading)[1]
            period_m = float(np.linalg.norm(halves[(sp.train[0], sp.method, sp.calibration)] * u - end))
            if lengths[(sp.train[0], sp.method)].length == "period count":
                best_m = period_m
            alone_m = float(np.linalg.norm(alone - end))
            if cross_free:
                v = np.asarray(inp.step_vector, float)[aided.applied_steps(inp)]
                cross_free = bool(np.all(v @ np.array([-along[1], along[0]]) == 0.0))
            rows.append({"file": p.rel, "forward_m": float(np.linalg.norm(dxy)),
                         "smoothed_m": float(np.linalg.norm(dsm)),
                         "morpi_m": morpi_m, "morpi_best_m": best_m, "period_count_m": period_m, "ins_m": ins_m,
                         "mahalanobis2": m2, "inside_95": bool(m2 <= aided.CHI2_95_2DOF),
                         "mahalanobis2_smoothed": m2s, "inside_95_smoothed": bool(m2s <= aided.CHI2_95_2DOF),
                         "gain_error": r.gain_error, "gain_error_sigma": r.gain_sigma,
                         "steps_m": alone_m, "steps_alone_m": alone_m})
            # up to the read-out, where the end point is taken (after it the phone may be handled)
            paths.append((r.time[:j + 1], r.position[:j + 1, :2], r.smoothed[:j + 1, :2], p.morpi_xy,
                          r.P_xy[:j + 1]))
        mean = lambda k: float(np.nanmean([q[k] for q in rows]) / d)  # noqa: E731
        col = lambda k: [q[k] for q in rows]  # noqa: E731
        cov_sm, cov_fw = ellipse_coverage(err_sm, P_sm, along), ellipse_coverage(err_fw, P_fw, along)
        alone_pct = float(np.mean(col("steps_alone_m")) / d)
        cells.append(AidedCell(
            spec=sp, forward_percent=mean("forward_m"), smoothed_percent=mean("smoothed_m"),
            morpi_percent=mean("morpi_m"), ins_percent=mean("ins_m"), runs=tuple(rows),
            tuning={**info, "accel_noise": noise[0] * info["vibration"], "gyro_noise": noise[1] * info["vibration"],
                    "rest_accel_noise": noise[0], "rest_gyro_noise": noise[2], "gyro_walk": noise[3], "accel_jump": noise[4],
                    "gain_sigma": g.std / g.mean},
            train_percent=score, train_loo_percent=choice.loo_percent, train_morpi_percent=choice.morpi_percent,
            nis=_nis_means(nis), paths=tuple(paths), failed=failed,
            steps_percent=alone_pct, step_innovation=_innovation_summary(innov),
            paired=paired_difference(col("smoothed_m"), col("morpi_m"), truth.distance_m),
            steps_alone_percent=alone_pct,
            paired_steps=(paired_difference(col("smoothed_m"), col("steps_alone_m"), truth.distance_m)
                          if info["step_heading"] == "route" else None),
            coverage_95=cov_sm["inside_95"], coverage_95_forward=cov_fw["inside_95"],
            coverage_axes={"smoothed": cov_sm, "forward": cov_fw}, cross_zero_by_construction=cross_free,
            morpi_best_percent=mean("morpi_best_m"), morpi_reading=readings[sp.method].reading,
            morpi_length=lengths[(sp.train[0], sp.method)].length, period_count_percent=mean("period_count_m"),
            paired_best=paired_difference(col("smoothed_m"), col("morpi_best_m"), truth.distance_m),
            train_consistency={"consistent": choice.consistent, "nis": dict(choice.train_nis),
                               "coverage_95": choice.train_coverage, "outside": list(choice.outside),
                               "loo_fallback": choice.loo_fallback}))
        if ablation and sp.calibration == "GC":
            base = tuning_from(noise, info, g.std / g.mean)
            full = (cells[-1].smoothed_percent, cells[-1].forward_percent)

            def read(name, which):
                ends = [abl_res[(i, p.rel, (name, which))] for p in runs]
                sm = [np.linalg.norm(r.smoothed[r.index_at(p.stop_s), :2] - end) for p, r in zip(runs, ends)]
                fw = [np.linalg.norm(r.position[r.index_at(p.stop_s), :2] - end) for p, r in zip(runs, ends)]
                return float(np.mean(sm) / d), float(np.mean(fw) / d)

            for name, change in ABLATIONS.items():
                used = aid_used(name, base)
                if name == "rest updates" and used:
                    abl.append(ablation_row(sp.label, name, used, read(name, "with"), read(name, "without"),
                                            start="motion onset"))
                else:
                    abl.append(ablation_row(sp.label, name, used, full,
                                            read(name, "without") if used and change else None))
    # the paired tests, Holm-corrected over the GC cells (the RD cells: over theirs, apart)
    significance = {}
    for cal in ("GC", "RD", "GAC"):
        idx = [k for k, c in enumerate(cells) if c.spec.calibration == cal]
        if not idx:
            continue
        fam = [cells[k] for k in idx]
        vs_morpi, s_morpi = _family(fam, "paired")
        vs_steps, s_steps = _family(fam, "paired_steps")
        vs_best, s_best = _family(fam, "paired_best")
        for k, a, b, e in zip(idx, vs_morpi, vs_steps, vs_best):
            cells[k] = replace(cells[k], paired=a, paired_steps=b, paired_best=e)
        if cal == "GC":
            significance = {"family": "GC cells", "correction": "holm", "test": "two-sided paired t-test",
                            "alpha": ALPHA, "power": POWER, **s_morpi, "vs_steps_alone": s_steps,
                            "vs_morpi_best": s_best}
    # coverage and NIS over the GC cells' runs, each (run, method) once
    seen, per_run, nis_all = set(), {"smoothed": [], "forward": []}, {}
    for i, c in enumerate(cells):
        if c.spec.calibration != "GC":
            continue
        end = np.asarray(ds.route(c.spec.route).end_point_m, float)
        for p in todo[i][5]:
            if (p.rel, c.spec.method) in seen:
                continue
            seen.add((p.rel, c.spec.method))
            r = results[(i, p.rel)]
            j = r.index_at(p.stop_s)
            for which, xy, P in (("smoothed", r.smoothed[j, :2], r.P_xy_smoothed[j]),
                                 ("forward", r.position[j, :2], r.P_xy[j])):
                per_run[which].append(ellipse_coverage([xy - end], [P], end))
            _merge_nis(nis_all, r.nis)
    coverage = {which: {"runs": len(v), **{k: float(np.mean([q[k] for q in v]))
                                           for k in ("inside_95", "along_95", "cross_95")}}
                for which, v in per_run.items() if v}
    return AidedStudy(cells=tuple(cells), ablation=tuple(abl),
                      coverage_95=coverage.get("smoothed", {}).get("inside_95", float("nan")),
                      nis=_nis_means(nis_all),
                      coverage_95_forward=coverage.get("forward", {}).get("inside_95", float("nan")),
                      coverage=coverage, significance=significance, readings=tuple(readings.values()),
                      lengths=tuple(lengths.values()), no_rest=no_rest)
