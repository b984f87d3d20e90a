"""What the filter is tested against beside the tables' MoRPI alone: its own steps alone (:func:`steps_alone`),
and MoRPI alone under its best train-chosen heading reading (:func:`choose_reading`) and step length
(:func:`choose_length`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import aided
from ..deprecation import renamed_keywords
from ..errors import MorpiError
from .inputs import route_steps


#: Tie tolerance of MoRPI alone's reading choice (:func:`choose_reading`): the route's heading replaces the
#: step rule's own reading only when its train leave-one-out error is lower by more than this many standard
#: errors of the paired difference over the train runs (the one-standard-error rule of
#: :data:`morpi_filters.field.SOURCE_SE`): the reading the rule search chose is kept within it.
READING_SE = 1.0
#: The step lengths MoRPI alone may use: the Weinberg length of the trained gain, or the period count (each
#: half period a fixed length learnt on the train runs: :func:`period_sums`).
LENGTHS = ("weinberg", "period count")


@renamed_keywords(mode="calibration")
def route_sums(data, rec, calibration, method, config) -> tuple[float, np.ndarray]:
    """MoRPI alone's distance and end point per unit gain with the route's heading (:func:`route_vectors`).

    The steps, their Weinberg weights and fractions are those of `config`
    (:meth:`~morpi_filters.field.FieldData.steps`); only the heading is the
    route's, the same the filter's ``"route"`` step direction reads. A run
    dead-reckoned with gain ``G`` ends at ``G * u``.

    Parameters
    ----------
    data : field.FieldData
    rec : dataset.Recording
    calibration : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig

    Returns
    -------
    w : float
        ``sum(weight * fraction)``: the distance per unit gain.
    u : ndarray, shape (2,)
        The end point per unit gain.

    Raises
    ------
    DataError
        When no steps are found (as :meth:`~morpi_filters.field.FieldData.steps`).
    """
    s = data.steps(rec, calibration, method, config)
    unit = np.asarray(s.weight, float) * np.asarray(s.fraction, float)
    v = route_steps(data, rec, calibration, config, s, unit)
    return float(unit.sum()), (v.sum(axis=0) if v.size else np.zeros(2))


@dataclass(frozen=True)
class ReadingChoice:
    """MoRPI alone's heading reading chosen on the train runs for one method (:func:`choose_reading`).

    Attributes
    ----------
    method : str
    reading : str
        ``"route"`` (:func:`route_sums`) or the step rule's own heading reading
        (:attr:`steps.StepConfig.heading`).
    rule_percent, route_percent : float
        Leave-one-out mean end-point error of the train runs under the rule's reading and under the
        route's heading [%] (infinite when a train run cannot be processed).
    difference_se_pp : float
        Standard error of the per-run difference (route minus rule) [pp].
    runs : int
        Train runs scored.
    """

    method: str
    reading: str
    rule_percent: float
    route_percent: float
    difference_se_pp: float
    runs: int


def route_reading_pays(rule_errors, route_errors, *, se_factor: float = READING_SE) -> bool:
    """Whether the route's heading beats the rule's reading on the train runs, beyond the tie tolerance.

    The per-run difference (route minus rule, the same runs in the same
    order) must have a mean below ``-se_factor`` standard errors of itself
    (:data:`READING_SE`): within that the rule's own reading is kept.

    Parameters
    ----------
    rule_errors, route_errors : array_like, shape (n,)
        Per train run, the leave-one-out end-point errors [%].
    se_factor : float
        Tie tolerance in standard errors of the paired difference.

    Returns
    -------
    bool

    Examples
    --------
    >>> route_reading_pays([3.0, 4.0, 5.0, 4.0], [2.0, 3.1, 3.9, 3.0])     # 1 pp better on every run
    True
    >>> route_reading_pays([3.0, 4.0, 5.0, 4.0], [3.5, 3.0, 5.0, 3.9])     # better on average, within the spread
    False
    """
    a = np.asarray(rule_errors, float)
    b = np.asarray(route_errors, float)
    if a.shape != b.shape or a.ndim != 1 or a.size < 2 or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return False
    d = b - a
    return bool(d.mean() < -se_factor * (d.std(ddof=1) / np.sqrt(d.size)))


def _route_loo(data, method, config, calibration="GC"):
    """Per train run, the leave-one-out end-point errors [%] of the rule's reading and of the
    route's heading, the same gains (:func:`morpi_filters.field.train_summary`); None when a run fails."""
    from .. import field as fd

    rule, route = [], []
    for truth, _, _, g, u, loo, failed in fd.train_summary(data, method, config, calibration):
        recs = truth.runs
        if failed:
            return None
        if loo is None:
            continue
        ur = np.empty_like(u)
        for i, r in enumerate(recs):
            try:
                ur[i] = route_sums(data, r, calibration, method, config)[1]
            except MorpiError:
                return None
        rule.append(loo)
        route.append(fd.loo_errors(truth, g, ur))
    if not rule:
        return None
    return np.concatenate(rule), np.concatenate(route)


def choose_reading(data, method, config) -> ReadingChoice:
    """MoRPI alone's best heading reading on the train runs: the rule's own, or the route's heading.

    The rule (:func:`morpi_filters.field.select_config`) already holds the
    best of MoRPI alone's own readings; the route's heading
    (:func:`route_sums`, the filter's ``"route"`` step direction) is offered
    beside it and scored by the same criterion: the leave-one-out end-point
    error of the train runs under GC (each run dead-reckoned with
    the mean gain of its set's other runs). It is chosen only when it beats
    the rule beyond the tie tolerance (:func:`route_reading_pays`). Nothing of
    a ``test`` folder is read.

    Parameters
    ----------
    data : field.FieldData
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
        The method's step rule.

    Returns
    -------
    ReadingChoice
    """
    errs = _route_loo(data, method, config)
    if errs is None:
        return ReadingChoice(method, config.heading, float("inf"), float("inf"), float("nan"), 0)
    rule, route = errs
    d = route - rule
    se = float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else float("nan")
    pick = "route" if route_reading_pays(rule, route) else config.heading
    return ReadingChoice(method, pick, float(rule.sum()) / rule.size, float(route.sum()) / route.size, se,
                         int(rule.size))


@renamed_keywords(mode="calibration")
def period_sums(data, rec, calibration, method, config, reading) -> tuple[float, np.ndarray]:
    """MoRPI alone's half periods and end point per unit half-period length: the period count.

    Each step of `config` counts its half periods (two between maxima, one
    between extrema) times its counted fraction; every half period has the
    same length. The step directions are those of `reading`: the route's
    heading (:func:`route_vectors`) or the rule's own.

    Parameters
    ----------
    data : field.FieldData
    rec : dataset.Recording
    calibration : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        ``"route"`` or the rule's heading reading (:attr:`ReadingChoice.reading`).

    Returns
    -------
    n : float
        Half periods counted.
    u : ndarray, shape (2,)
        The end point per unit half-period length [m / m].

    Raises
    ------
    DataError
        When no steps are found.
    """
    s = data.steps(rec, calibration, method, config)
    c = np.asarray(s.fraction, float) * (2.0 if config.segment == "maxima" else 1.0)
    if reading == "route":
        v = route_steps(data, rec, calibration, config, s, c)
    else:
        h = np.asarray(s.heading, float)
        v = c[:, None] * np.stack([np.cos(h), np.sin(h)], axis=1)
    return float(c.sum()), (v.sum(axis=0) if v.size else np.zeros(2))


def _unit_sums(data, rec, calibration, method, config, reading, length):
    """Distance and end point per unit gain (Weinberg) or per unit half-period length (period count)."""
    if length == "period count":
        return period_sums(data, rec, calibration, method, config, reading)
    if reading == "route":
        return route_sums(data, rec, calibration, method, config)
    w, ux, uy = data.step_sums(rec, calibration, method, config)[:3]
    return float(w), np.array([ux, uy])


def _phone_sets(data, phone):
    """The phone's training sets that hold train runs (:class:`~morpi_filters.field.TrainSet`: each run with its
    own end point and distance)."""
    return [tset for tset in data.train_sets() if tset.phone == phone and tset.runs]


@renamed_keywords(mode="calibration")
def period_length(data, phone, calibration, method, config, reading) -> float:
    """The period count's half-period length [m]: total train distance over total train half periods.

    Over every train run of the phone's training sets
    (:meth:`morpi_filters.field.FieldData.train_sets`), the method's steps under
    `config` and `calibration`. NaN when a train run has no steps or there are none.

    Parameters
    ----------
    data : field.FieldData
    phone : str
    calibration : {"RD", "GC", "GAC"}
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        As for :func:`period_sums` (the count does not depend on it).

    Returns
    -------
    float
    """
    dist = halves = 0.0
    for tset in _phone_sets(data, phone):
        for r, d in zip(tset.runs, tset.distance_m):
            try:
                halves += period_sums(data, r, calibration, method, config, reading)[0]
            except MorpiError:
                return float("nan")
            dist += float(d)
    return dist / halves if halves > 0 else float("nan")


@dataclass(frozen=True)
class LengthChoice:
    """MoRPI alone's step length chosen on one phone's train runs for one method (:func:`choose_length`).

    Attributes
    ----------
    phone, method : str
    length : str
        One of :data:`LENGTHS`.
    weinberg_percent, period_percent : float
        Held-out mean end-point error of the train runs with each length [%] (infinite when a run
        cannot be processed).
    held_out : str
        ``"training set"`` (each of several training sets held out in turn) or ``"run"`` (leave-one-out).
    runs : int
        Train runs scored.
    """

    phone: str
    method: str
    length: str
    weinberg_percent: float
    period_percent: float
    held_out: str
    runs: int


def choose_length(data, phone, method, config, reading) -> LengthChoice:
    """The Weinberg length or the period count for MoRPI alone, chosen on the phone's train runs.

    Each length is learnt on held-out data: with several
    training sets for the phone, each set is held out in turn and scored with
    the length learnt on the others (the Weinberg gain: the mean of the runs'
    own gains; the period count: their total distance over their total half
    periods); with one set, each run is held out. Scored under GC with the
    method's `reading`; the period count is taken only when it beats the
    Weinberg length beyond the tie tolerance (:func:`route_reading_pays`'s
    one-standard-error rule). Nothing of a ``test`` folder is read.

    Parameters
    ----------
    data : field.FieldData
    phone : str
    method : {"MoRPI-A", "MoRPI-G"}
    config : steps.StepConfig
    reading : str
        As for :func:`period_sums`.

    Returns
    -------
    LengthChoice
    """
    sets = []
    for tset in _phone_sets(data, phone):
        rows = []
        for r in tset.runs:
            try:
                rows.append([_unit_sums(data, r, "GC", method, config, reading, k) for k in LENGTHS])
            except MorpiError:
                return LengthChoice(phone, method, "weinberg", float("inf"), float("inf"), "-", 0)
        sets.append((np.asarray(tset.distance_m, float), np.asarray(tset.end_point_m, float),
                     np.array([[q[0] for q in row] for row in rows]),
                     np.array([[q[1] for q in row] for row in rows])))
    err = {k: [] for k in LENGTHS}
    by_set = len(sets) > 1
    for k, (d, end, n, u) in enumerate(sets):
        for i in range(n.shape[0]):
            if by_set:
                other = [x for j, x in enumerate(sets) if j != k]
            else:
                keep = np.arange(n.shape[0]) != i
                other = [(d[keep], end[keep], n[keep], u[keep])] if keep.sum() else []
            if not other:
                continue
            gain = np.mean(np.concatenate([dd / nn[:, 0] for dd, _, nn, _ in other]))
            half = sum(dd.sum() for dd, _, _, _ in other) / sum(nn[:, 1].sum() for _, _, nn, _ in other)
            err["weinberg"].append(np.linalg.norm(gain * u[i, 0] - end[i]) / d[i] * 100)
            err["period count"].append(np.linalg.norm(half * u[i, 1] - end[i]) / d[i] * 100)
    a, b = np.array(err["weinberg"]), np.array(err["period count"])
    if not a.size:
        return LengthChoice(phone, method, "weinberg", float("inf"), float("inf"), "-", 0)
    pick = "period count" if route_reading_pays(a, b) else "weinberg"
    return LengthChoice(phone, method, pick, float(a.mean()), float(b.mean()), "training set" if by_set else "run",
                        int(a.size))


def steps_alone(inp: aided.AidedInput) -> np.ndarray:
    """Where the filter's own step vectors lead without the INS: their sum [m].

    The steps the filter updates with (:func:`aided.applied_steps`: the same
    lengths and directions), summed from the filter's start (the origin):
    dead reckoning with the filter's step direction. What the INS adds is
    the difference between the filter and this.

    Parameters
    ----------
    inp : aided.AidedInput
        The filter's input; its step directions are
        :attr:`aided.AidedInput.step_vector`.

    Returns
    -------
    ndarray, shape (2,)
        The end point [m]; NaN without step vectors (the filter reads its own attitude).

    Examples
    --------
    >>> t = np.arange(31) * 0.1
    >>> inp = aided.AidedInput(time=t, f=np.zeros((31, 3)), omega=np.zeros((31, 3)), C0=np.eye(3), g=9.8,
    ...                        step_start=np.array([0.0, 1.0, 2.0]), step_end=np.array([1.0, 2.0, 3.0]),
    ...                        step_length=np.array([0.5, 0.5, np.nan]),
    ...                        step_vector=np.array([[0.5, 0.0], [0.0, 0.5], [9.0, 9.0]]))
    >>> steps_alone(inp).tolist()          # the third step has no length: the filter does not use it
    [0.5, 0.5]
    """
    if inp.step_vector is None:
        return np.full(2, np.nan)
    v = np.asarray(inp.step_vector, float)[aided.applied_steps(inp)]
    return v.sum(axis=0) if v.size else np.zeros(2)
