"""The step rule chosen on the train runs only: the train sets' leave-one-out scores (:func:`train_summary`,
:func:`loo_errors`, :func:`held_out_score`), the coordinate search (:func:`select_config`) and its nested check
(:func:`nested_rule_comparison`)."""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from . import _loops
from .. import steps as st
from ..choice import choose
from ..deprecation import renamed_keywords
from ..errors import MorpiError, ParameterError
from .data import FieldData
from .thresholds import MORPI_METHODS, SEARCH_START, Thresholds, fold_thresholds


#: How a train run is held out of the gain that scores it (:func:`select_config`): with the mean gain of its
#: set's other runs (leave-one-recording-out), or of the other sets' runs (leave-one-group-out).
HELD_OUT = ("recording", "group")
#: How the step rule is chosen (see :func:`morpi_filters.evaluate.evaluate_tables`).
RULES = ("per_method", "joint")


@dataclass(frozen=True)
class Selection:
    """The step rule chosen on the train runs for one method.

    Attributes
    ----------
    method : str
    config : StepConfig
    score : float
        Leave-one-out mean end-point error on the train runs [%].
    trials : tuple of (StepConfig, float)
        Every config scored, in the order tried.
    n_train : int
        Train runs used.
    """

    method: str
    config: st.StepConfig
    score: float
    trials: tuple
    n_train: int


#: Coordinate search: first the readings (with the first tunables), then the tunables.
READING_GRID = {"heading": ("absolute", "mean", "turns"), "segment": st.SEGMENTS, "ends": st.ENDS}
#: The 3D attitude heading (more machinery than the z gyro: a whole 3D mechanization) is chosen only when
#: its train leave-one-out error is lower by more than this many standard errors of the paired
#: difference over the train runs: the "one-standard-error rule" of cross-validated model selection
#: (Hastie, Tibshirani and Friedman, The Elements of Statistical Learning, 2nd ed., section 7.10).
SOURCE_SE = 1.0
#: The detection tunables the rule search tries beside the readings: low-pass cut-off [Hz], peak
#: prominence (a fraction of the run's robust signal range) and shortest period [s].
TUNABLE_GRID = {"cutoff_hz": (1.0, 2.0, 3.0), "prominence": (0.2, 0.35, 0.5), "min_period_s": (0.5, 1.0)}


@renamed_keywords(mode="calibration")
def train_summary(data: FieldData, method, config, calibration="GC"):
    """Per train set (:meth:`FieldData.train_sets`), the train runs reduced to what a gain and an end point need.

    A tuple of ``(train_set, members, relpaths, g, u, loo, failed)`` per set:
    ``g`` each run's own gain (its distance / effective weight), ``u`` the end
    point per unit gain (``sum(weight * fraction * [cos, sin](heading))``,
    shape ``(n, 2)``), so that a run dead-reckoned with gain ``G`` ends at
    ``G u``, ``loo`` the runs' leave-one-out errors (:func:`loo_errors`; None
    below two runs or when a run fails) and ``failed`` the runs the rule cannot
    process (no periodic motion found; NaN in ``g`` and ``u``). Cached on
    `data`.

    Parameters
    ----------
    data : FieldData
        The dataset; only its train sets are read.
    method : {"MoRPI-A", "MoRPI-G"}
        MoRPI method.
    config : steps.StepConfig
        The step rule.
    calibration : {"RD", "GC", "GAC"}
        Calibration.

    Returns
    -------
    tuple of tuple
        One ``(train_set, members, relpaths, g, u, loo, failed)`` per train set.
    """
    key = (method, config, calibration)
    out = data._train_summaries.get(key)
    if out is None:
        out = []
        for tset in data.train_sets():
            recs, rels = tset.runs, tset.files
            g, u, failed = np.full(len(recs), np.nan), np.full((len(recs), 2), np.nan), set()
            for i, r in enumerate(recs):
                try:
                    w, ux, uy = data.step_sums(r, calibration, method, config)[:3]
                except MorpiError:
                    failed.add(rels[i])
                    continue
                g[i] = tset.distance_m[i] / w
                u[i] = ux, uy
            loo = loo_errors(tset, g, u) if g.size >= 2 and not failed else None
            out.append((tset, frozenset(rels), rels, g, u, loo, frozenset(failed)))
        out = data._train_summaries[key] = tuple(out)
    return out


def loo_errors(truth, g, u, keep=None) -> np.ndarray:
    """End-point errors [%] of each run (each flagged in `keep`) with the mean gain of the others (leave-one-out).

    ``gi = (sum(g) - g) / (n - 1)``, ``|gi u - end| / distance * 100``, each run
    against its own end point and distance: `truth` holds ``end_point_m``
    (shape (2,), shared by the runs, or (n, 2)) and ``distance_m`` (a number or
    shape (n,)), as a :class:`TrainSet` or a route does. A compiled loop
    (``field/_loops.py``: ``loo_errors``), the gains summed in order (the numpy form
    within rounding).

    Parameters
    ----------
    truth : TrainSet or Route
        ``end_point_m`` and ``distance_m`` of the runs.
    g : ndarray, shape (n,)
        Each run's own gain.
    u : ndarray, shape (n, 2)
        Each run's end point per unit gain [m].
    keep : ndarray of bool, shape (n,), optional
        The runs taken (default: all).

    Returns
    -------
    ndarray, shape (k,)
        The kept runs' errors [%], in order.

    Examples
    --------
    Three runs along x with gains 1, 2 and 3 and a true end point 2 m ahead: each
    run takes the mean of the other two gains (2.5, 2, 1.5).

    >>> from types import SimpleNamespace
    >>> truth = SimpleNamespace(end_point_m=np.array([2.0, 0.0]), distance_m=2.0)
    >>> loo_errors(truth, np.array([1.0, 2.0, 3.0]), np.tile([1.0, 0.0], (3, 1))).tolist()
    [25.0, 0.0, 25.0]
    """
    n = g.shape[0]
    out = np.empty(n)
    end, dist = np.asarray(truth.end_point_m, dtype=float), np.asarray(truth.distance_m, dtype=float)
    # a train set's arrays are already one row per run (the rule searches call this thousands of times)
    if end.shape != (n, 2) or not end.flags.c_contiguous:
        end = np.ascontiguousarray(np.broadcast_to(end, (n, 2)))
    if dist.shape != (n,) or not dist.flags.c_contiguous:
        dist = np.ascontiguousarray(np.broadcast_to(dist, (n,)))
    keep = np.ones(n, dtype=bool) if keep is None else keep
    m = _loops.compiled()["loo_errors"](g, u, keep, end, dist, out)
    return out[:m]


def _logo_errors(summary, keep_of) -> list:
    """Per set, the end-point errors [%] of its kept runs with the mean gain of the other sets' kept runs.

    `summary`: :func:`train_summary`'s tuples; `keep_of(k)`: the kept runs
    of set k (bool, shape (n_k,)). A set is scored when the other sets keep a
    run; the errors are ``|G u - end| / distance * 100`` with ``G`` the mean
    of the other sets' runs' own gains (leave-one-group-out).
    """
    keeps = [keep_of(k) for k in range(len(summary))]
    out = []
    for k, (tset, _, _, g, u, _, _) in enumerate(summary):
        if not keeps[k].any():
            continue
        others = [s[3][keeps[j]] for j, s in enumerate(summary) if j != k and keeps[j].any()]
        if not others:
            continue
        gain = float(np.mean(np.concatenate(others)))
        end = np.broadcast_to(np.asarray(tset.end_point_m, float), (g.size, 2))[keeps[k]]
        dist = np.broadcast_to(np.asarray(tset.distance_m, float), (g.size,))[keeps[k]]
        out.append(np.hypot(*(gain * u[keeps[k]] - end).T) / dist * 100)
    return out


@renamed_keywords(mode="calibration")
def held_out_errors(data: FieldData, method, config, calibration="GC", exclude=frozenset(), held_out: str = "recording"
                ) -> np.ndarray | None:
    """Per-run held-out end-point errors [%] of the train runs not in `exclude`.

    ``held_out="recording"``: each run with the mean gain of its set's other
    runs (sets with fewer than two runs left give none); ``"group"``: each
    run with the mean gain of the other sets' runs (:func:`_logo_errors`;
    none below two sets). In the train sets' order; None if a run not in
    `exclude` fails (the rule cannot process it).

    Parameters
    ----------
    data : FieldData
        The dataset; only its train sets are read.
    method, config, calibration
        As for :func:`train_summary`.
    exclude : frozenset of str
        Train runs (relative paths or ids) to leave out.
    held_out : {"recording", "group"}
        What a run is held out of (:data:`HELD_OUT`).

    Returns
    -------
    ndarray or None
        The errors [%], shape (k,).
    """
    if held_out not in HELD_OUT:
        raise ParameterError(f"held_out={held_out!r}: expected one of {HELD_OUT}")
    summary = train_summary(data, method, config, calibration)
    errs = []
    for tset, members, rels, g, u, loo, failed in summary:
        if failed - exclude:
            return None
    if held_out == "group":
        errs = _logo_errors(summary, lambda k: np.array([r not in exclude for r in summary[k][2]], dtype=bool))
        return np.concatenate(errs) if errs else np.empty(0)
    for tset, members, rels, g, u, loo, failed in summary:
        if members.isdisjoint(exclude):
            if loo is not None:
                errs.append(loo)
            continue
        keep = np.array([r not in exclude for r in rels], dtype=bool)
        if keep.sum() >= 2:
            errs.append(loo_errors(tset, g, u, keep))
    return np.concatenate(errs) if errs else np.empty(0)


def _held_out_error(data: FieldData, method, config, k: int, rel: str) -> float:
    """End-point error [%] of train run `rel` of short-route set `k` with the mean gain of the set's other runs.

    NaN when the rule cannot process `rel` or when no other run of the set gives a gain.
    """
    truth, _, rels, g, u, _, failed = train_summary(data, method, config)[k]
    ok = [r for r in rels if r not in failed]
    if rel not in ok or len(ok) < 2:
        return float("nan")
    keep = np.array([r not in failed for r in rels], dtype=bool)
    return float(loo_errors(truth, g, u, keep)[ok.index(rel)])


@renamed_keywords(mode="calibration")
def held_out_score(data: FieldData, method, config, calibration="GC", exclude=frozenset(), held_out: str = "recording"
               ) -> tuple[float, int]:
    """Held-out mean end-point error [%] over the train runs not in `exclude` (:func:`held_out_errors`).

    Cached on `data` with the train summaries: the searches of one method, of the other and of both
    (:func:`select_config`) score many of the same rules.

    Parameters
    ----------
    data, method, config, calibration, exclude, held_out
        As for :func:`held_out_errors`.

    Returns
    -------
    tuple of (float, int)
        The mean error [%] (infinite when no run scores) and the number of runs scored.
    """
    key = ("loo score", method, config, calibration, exclude, held_out)
    out = data._train_summaries.get(key)
    if out is None:
        errs = held_out_errors(data, method, config, calibration, exclude, held_out)
        # np.mean's bits: numpy's sum, divided by the count
        out = (float("inf"), 0) if errs is None or not errs.size else (float(errs.sum()) / errs.size, int(errs.size))
        data._train_summaries[key] = out
    return out


def select_config(data: FieldData, methods=MORPI_METHODS, *, exclude=(), thresholds: Thresholds | None = None,
                  held_out: str = "recording") -> Selection:
    """Choose the step rule from the train runs only (the train sets of :meth:`FieldData.train_sets`).

    A coordinate search: the paper's readings (heading absolute, mean over
    the step, or the step's own change plus the turns so far, ``"turns"``;
    segments between maxima or extrema; partial end steps dropped,
    fractional or whole) are scored with the start tunables, then each
    tunable (low-pass cut-off, prominence fraction, least period) is scanned
    in turn with the best readings. The score is the leave-one-out end-point
    error of the train runs (GC calibration), averaged over `methods`: with
    both methods (the default) one rule serves MoRPI-A and MoRPI-G, as the
    paper extracts both "in the same manner". The heading reading "change" is
    not a candidate: it cannot represent a turn (the L route), so it is
    reported as an alternative only; ``"turns"`` is its turn-following form,
    with the turn threshold of :func:`train_thresholds`. Scores within the
    tie tolerance of the least (:func:`morpi_filters.choice.choose`) keep the
    earlier config.

    The search runs once per heading source (the z gyro, and the 3D attitude
    of the paper's heading equation). The attitude's rule is chosen when its
    train error is lower than the gyro rule's by more than :data:`SOURCE_SE`
    standard errors of their paired difference over the train runs (the
    one-standard-error rule); otherwise the gyro's, the reading with less
    machinery.

    Parameters
    ----------
    data : FieldData
        The dataset root; only its ``train`` folders are read.
    methods : str or tuple of str
        Methods whose train scores are averaged.
    exclude : iterable of str
        Train recordings (paths relative to the dataset root) to leave out,
        as if absent; used by :func:`nested_rule_comparison`.
    thresholds : Thresholds, optional
        The least swing and least turn of the rules; default:
        ``data.thresholds`` (:func:`fold_thresholds` gives those of a fold).
    held_out : {"recording", "group"}
        How a train run is held out (:data:`HELD_OUT`): ``"recording"``
        (default, the MoRPI tables' score) dead-reckons it with the mean gain
        of its set's other runs; ``"group"`` with the mean gain of the runs
        of the other sets (leave-one-group-out: the rule is scored on sets
        none of whose runs set the gain).

    Returns
    -------
    Selection
        The chosen :class:`~morpi_filters.steps.StepConfig`, its mean
        leave-one-out end-point error [%], every config tried with its score,
        and the number of train runs scored. When no config scores (no train
        runs), the default config with the trained thresholds and an infinite
        score.
    """
    if isinstance(methods, str):
        methods = (methods,)
    exclude = frozenset(exclude)
    th = thresholds or data.thresholds
    start = SEARCH_START.with_(min_swing_deg=th.min_swing_deg, turn_deg=th.turn_deg)
    found = {h: _search(data, methods, exclude, start.with_(heading_source=h), held_out)
             for h in st.HEADING_SOURCES}
    trials = tuple(t for h in st.HEADING_SOURCES for t in found[h][3])
    best, best_score, n, _ = found["gyro"]
    att = found["attitude"]
    if np.isfinite(att[1]):
        d = _source_difference(data, methods, exclude, best, att[0], held_out)
        if d is not None and d.mean() < -SOURCE_SE * _se(d):
            best, best_score, n = att[:3]
    if not np.isfinite(best_score):
        best = st.StepConfig(min_swing_deg=th.min_swing_deg, turn_deg=th.turn_deg)
    return Selection("+".join(methods), best, best_score, trials, n)


def _se(d) -> float:
    return float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else float("inf")


def _source_difference(data, methods, exclude, gyro_cfg, attitude_cfg, held_out="recording") -> np.ndarray | None:
    """Per train run, the leave-one-out error of `attitude_cfg` minus `gyro_cfg` [pp], averaged over `methods`."""
    diffs = []
    for m in methods:
        g = held_out_errors(data, m, gyro_cfg, exclude=exclude, held_out=held_out)
        a = held_out_errors(data, m, attitude_cfg, exclude=exclude, held_out=held_out)
        if g is None or a is None or g.size != a.size or not g.size:
            return None
        diffs.append(a - g)
    return np.mean(diffs, axis=0)


def _search(data: FieldData, methods, exclude, start, held_out="recording") -> tuple:
    """The coordinate search of :func:`select_config` from `start`: (best, score, n_train, trials)."""

    def score(cfg):
        vals = [held_out_score(data, m, cfg, exclude=exclude, held_out=held_out) for m in methods]
        return sum(v for v, _ in vals) / len(vals), int(sum(n for _, n in vals))       # np.mean's bits

    trials, counts = [], []

    def add(cfg):
        sc, n_ = score(cfg)
        trials.append((cfg, sc))
        counts.append(n_)

    def leader():
        # the earliest config tried within the tie tolerance of the least score (choice.choose); `start`
        # while no config scores
        i = choose([sc for _, sc in trials])
        return (trials[i][0], trials[i][1], counts[i]) if np.isfinite(trials[i][1]) else (start, float("inf"), 0)

    keys = list(READING_GRID)
    for combo in itertools.product(*(READING_GRID[k] for k in keys)):
        add(start.with_(**dict(zip(keys, combo))))
    tried = {c for c, _ in trials}
    for k, values in TUNABLE_GRID.items():
        base = leader()[0]
        for v in values:
            cfg = base.with_(**{k: v})
            if cfg in tried:
                continue
            tried.add(cfg)
            add(cfg)
    best, best_score, n = leader()
    return best, best_score, n, trials


def nested_rule_comparison(data: FieldData) -> dict:
    """Compare the two ways of choosing the step rule by nested leave-one-out on the train runs.

    The train score of :func:`select_config` is measured on the runs the rule
    was chosen on, so it favours the choice with more freedom: a rule per
    method can never score worse than one rule for both. Here each train run
    is held out in turn, the whole selection (per method, and joint) is
    repeated on the remaining train runs, and the held-out run is
    dead-reckoned with the chosen rule and the mean gain of the other runs of
    its set. The mean held-out error estimates how each procedure does on
    runs it has not seen. The detection thresholds are set again in each fold
    without the held-out run (:func:`fold_thresholds`). Only train folders are
    read.

    Parameters
    ----------
    data : FieldData
        The dataset root; only its ``train`` folders are read.

    Returns
    -------
    dict
        ``rules``: rule -> method -> mean held-out end-point error [%];
        ``mean``: rule -> mean over both methods [%]; ``difference_pp`` and
        ``difference_se_pp``: joint minus per-method, paired over the held-out
        runs, and its standard error; ``n_folds``; ``same_as_full``: rule ->
        method -> fraction of folds whose chosen rule equals the one chosen
        on all train runs; ``preferred``: the rule with the lower mean (the
        earlier in :data:`RULES` within the tie tolerance of :func:`morpi_filters.choice.choose`);
        ``folds``: one dict per held-out run, with its ``file`` (path relative
        to the root), the fold's ``accel_floor`` [m/s^2], ``min_swing_deg`` and
        ``turn_deg`` [deg], ``same_rest_windows`` and rule -> method -> its
        held-out error [%] (NaN when its set has no gain);
        ``folds_with_other_thresholds``: how many folds set thresholds other
        than the full train set's. The means, differences, fractions and
        ``preferred`` are None without train runs.
    """
    folds = [(k, rel) for k, tset in enumerate(data.train_sets()) for rel in tset.files]
    full = {"per_method": {m: select_config(data, m).config for m in MORPI_METHODS}}
    cj = select_config(data).config
    full["joint"] = {m: cj for m in MORPI_METHODS}
    errs = {rule: {m: [] for m in MORPI_METHODS} for rule in RULES}
    same = {rule: {m: 0 for m in MORPI_METHODS} for rule in RULES}
    own = []
    for k, rel in folds:
        th, same_windows = fold_thresholds(data, rel)
        d = data
        if not same_windows:
            # the fold's floor moves a rest window: the fold gets its own windows, calibrations and steps
            d = FieldData(data.root, include_test=False, ins_span=data.ins_span, heading_from=data.heading_from,
                          thresholds=th, course_m=data.course_m)
            d._rec, d._labels = data._rec, data._labels
        own.append({"file": rel, "accel_floor": th.accel_floor, "min_swing_deg": th.min_swing_deg,
                    "turn_deg": th.turn_deg, "same_rest_windows": same_windows})
        chosen = {"per_method": {m: select_config(d, m, exclude=(rel,), thresholds=th).config
                                 for m in MORPI_METHODS}}
        cj = select_config(d, exclude=(rel,), thresholds=th).config
        chosen["joint"] = {m: cj for m in MORPI_METHODS}
        for rule in RULES:
            for m in MORPI_METHODS:
                cfg = chosen[rule][m]
                # the rule is compared with the full selection's apart from the fold's own thresholds
                same[rule][m] += cfg.with_(min_swing_deg=full[rule][m].min_swing_deg,
                                           turn_deg=full[rule][m].turn_deg) == full[rule][m]
                errs[rule][m].append(_held_out_error(d, m, cfg, k, rel))
    n = len(folds)
    # per fold, the mean over the methods whose held-out run could be dead-reckoned (NaN when none)
    per_rule = {}
    for rule in RULES:
        e = np.array([errs[rule][m] for m in MORPI_METHODS]).reshape(len(MORPI_METHODS), n)
        ok = np.isfinite(e)
        per_rule[rule] = np.where(ok.any(axis=0), np.where(ok, e, 0.0).sum(axis=0) / np.maximum(ok.sum(axis=0), 1),
                                  np.nan)
    def finite_mean(x):
        x = np.asarray(x, float)
        return float(x[np.isfinite(x)].mean()) if np.isfinite(x).any() else None

    d = per_rule["joint"] - per_rule["per_method"]
    d = d[np.isfinite(d)]
    mean = {rule: finite_mean(per_rule[rule]) for rule in RULES}
    return {
        "rules": {rule: {m: finite_mean(errs[rule][m]) for m in MORPI_METHODS} for rule in RULES},
        "mean": mean,
        "difference_pp": float(d.mean()) if d.size else None,
        "difference_se_pp": float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else None,
        "n_folds": n,
        "same_as_full": {rule: {m: same[rule][m] / n if n else None for m in MORPI_METHODS} for rule in RULES},
        "preferred": (RULES[choose([mean[r] for r in RULES])] if all(v is not None for v in mean.values())
                      else None),
        "folds": [{**own[i], **{rule: {m: errs[rule][m][i] for m in MORPI_METHODS} for rule in RULES}}
                  for i in range(n)],
        "folds_with_other_thresholds": sum((f["accel_floor"], f["min_swing_deg"], f["turn_deg"])
                                           != (data.thresholds.accel_floor, data.thresholds.min_swing_deg,
                                               data.thresholds.turn_deg) for f in own),
    }
