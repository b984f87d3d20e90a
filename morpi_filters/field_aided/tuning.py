"""The filter's tunables chosen on the train runs only: the grid, the consistency criterion
(:func:`choose_consistent`) and the second stage at the chosen point (non-holonomic updates, estimated gain)."""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product

import numpy as np

from .. import _aided_kernel, aided
from ..choice import choose
from ..deprecation import renamed_keywords
from ..errors import DataError, MorpiError, ParameterError
from .inputs import prepare


#: Train-only grid: factor on the rest-window noise densities (the moving robot vibrates far above
#: them), step displacement noise [m], whether the gain error is estimated or only considered (the
#: trained gain taken as exact, its spread kept in the covariance: :attr:`aided.AidTuning.gain_estimated`),
#: and the source of the step direction (the filter's attitude, or the route's heading: the turns
#: alone, :func:`route_vectors`), and whether the non-holonomic updates run. MoRPI's own heading reading
#: (its step vectors) is not a candidate: the route's heading took its place in every training set and
#: nested fold, with identical choices and scores without it, at a third less tuning time.
#: The search takes the gain as exact, with and without the non-holonomic updates, and keeps the
#: consistent points (:func:`choose_consistent`); at the chosen point the updates are then dropped unless
#: they pay, and the gain is estimated only where that pays, on the train runs (:func:`gain_estimate_pays`
#: and the one-standard-error rule). On every training set of the field data the grid holds consistent
#: points, so it is not extended below 100. A vibration factor of 30 (every
#: MoRPI-A training set picks it; train mean end-point error 3.93 -> 3.71 %) is not a candidate: with it the
#: filter's updates on the test runs are far more confident than their innovations (normalized innovation
#: squared of the steps 25, of zero velocity 15, against 2 and 3 expected; 5 and 0.7 without it) for the same
#: cells won, and it was tried after the test cells had been seen.
GRID = {"vibration": (100.0, 300.0, 3000.0), "step_sigma": (0.02, 0.05), "gain_state": ("estimated", "considered"),
        "step_heading": ("attitude", "route"), "nhc": (True, False)}
#: Non-holonomic velocity noise [m/s]: the phone rides off the robot's turning axis, so its lateral
#: velocity is about omega_z times the lever arm (0.5 rad/s x 0.2 m = 0.1 m/s) while turning.
NHC_SIGMA = 0.1
#: Error of a turn of the route's heading (:func:`route_vectors`) relative to its angle
#: (:attr:`aided.AidTuning.turn_sigma`): set a priori, since the train routes (sines) take no turn that
#: the route's heading reads; a few per cent, the order of a phone gyro's sensitivity tolerance and of
#: the z gyro's share of a turn on a tilted phone (1 - cos 15 deg = 3.4 %).
TURN_SIGMA = 0.03
#: Least share of the train runs whose true end point lies inside the filter's 95 % ellipse for a
#: grid point to be eligible: a filter that claims 95 % must hold it on the runs it is tuned on
#: (the bound leaves room for the sampling spread of 10-15 train runs).
MIN_TRAIN_COVERAGE = 0.85
#: Band of the train NIS per degree of freedom that a consistent grid point keeps for every measurement
#: type it uses (:func:`choose_consistent`). Not the chi-square band of the mean over the train updates:
#: with the hundreds to thousands of updates of a training set that band is a few per cent wide (1 +- 0.04
#: for 3000 two-dof updates) and tests a filter whose measurement noises are white and exactly known,
#: while the field filter's are modelling choices (the rest windows' densities, a zero-velocity sigma, a
#: step sigma from a two-value grid) and a step's error carries over to the next steps: a filter matched
#: within tens of per cent would fail it at every grid point and the criterion would see nothing. The band
#: is a factor 5 on either side of 1 (symmetric in the logarithm): outside it the innovations the filter
#: expects are off from those it sees by more than a factor sqrt(5) = 2.2 in spread, a gross mistuning
#: (a filter that hands its position to every step, or one that holds its INS against the steps).
NIS_BAND = (0.2, 5.0)
#: Accelerometer bias random walk [m/s^2/sqrt(s)]: a slow wander of the phone's accelerometer bias
#: (0.06 m/s^2 over a 40 s run, against the 0.2-0.3 m/s^2 offset of f_x while cruising, which it
#: does not try to follow).
ACCEL_WALK = 1e-2


def tuning_from(noise, info, gain_rel) -> aided.AidTuning:
    """The filter's tunables from a recording's rest noise and a grid point.

    Parameters
    ----------
    noise : tuple
        ``(accel, gyro, rest gyro, gyro walk, accel jump)`` noise densities of the rest window
        (:func:`rest_noise`).
    info : dict
        A grid point (:data:`GRID`'s keys).
    gain_rel : float
        The trained gain's relative spread (the gain error's prior).

    Returns
    -------
    aided.AidTuning
    """
    a, g, ge, walk, jump = noise
    return aided.AidTuning(accel_noise=a * info["vibration"], gyro_noise=g * info["vibration"], rest_gyro_noise=ge,
                           rest_accel_noise=a, turn_sigma=TURN_SIGMA,
                           gyro_walk=walk, accel_jump=jump,
                           accel_walk=ACCEL_WALK, step_sigma=info["step_sigma"], nhc_sigma=NHC_SIGMA,
                           nhc=bool(info.get("nhc", True)),
                           gain_sigma=float(gain_rel), gain_estimated=info["gain_state"] == "estimated",
                           step_heading="attitude" if info["step_heading"] == "attitude" else "gyro")


def _candidates():
    keys = sorted(GRID)
    return [dict(zip(keys, vals)) for vals in product(*(GRID[k] for k in keys))]


@renamed_keywords(mode="calibration")
def choose_tunables(data, train, method, calibration, config, gain):
    """Tunables with the least mean end-point error on the ``train`` runs of `train` (phone, route).

    Every candidate of :data:`GRID` that takes the gain as exact runs on
    every train run in one batch, with and without the non-holonomic
    updates; only those consistent on the train runs compete
    (:func:`choose_consistent`: the 95 % ellipse holds the true end point of
    at least :data:`MIN_TRAIN_COVERAGE` of them and every measurement type's
    NIS per dof lies in :data:`NIS_BAND`; the least inconsistent when none
    is). At the chosen point the non-holonomic updates are then dropped
    unless they pay, and the gain is estimated instead where that pays, on
    the train runs (a less inconsistent filter first, then end points better
    by more than one standard error; for the gain also
    :func:`gain_estimate_pays`). The nested leave-one-out repeats both
    stages without the run it scores.

    Needs a :class:`~morpi_filters.field.FieldData`, so there is no example.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    train : field.TrainSet or (str, str)
        A train set of the dataset (:meth:`~morpi_filters.field.FieldData.train_sets`:
        its runs, each scored against its own end point and distance), or the
        phone and route of one (the train set of that group).
    method : {"MoRPI-A", "MoRPI-G"}
        MoRPI method.
    calibration : {"RD", "GC", "GAC"}
        Calibration.
    config : steps.StepConfig
        The method's step rule.
    gain : field.Gain
        The trained gain (``mean`` sets the step lengths, ``std / mean``
        the gain error's prior).

    Returns
    -------
    TunableChoice

    Raises
    ------
    DataError
        The training set has no train run with steps (:func:`choose_tunables_many`
        returns that error in its list; this single-request form raises it).
    """
    choice = choose_tunables_many(data, [(train, method, calibration, config, gain)])[0]
    if isinstance(choice, MorpiError):
        raise choice
    return choice


def choose_tunables_many(data, requests, *, workers: int | None = None) -> list:
    """:func:`choose_tunables` for several (train, method, mode, config, gain) at once: the grid in one
    batch per training set, the second stage of every request in one batch.

    A request without train runs gives a MorpiError in its place of the returned list.
    Needs a :class:`~morpi_filters.field.FieldData`, so there is no example.

    Parameters
    ----------
    data : field.FieldData
        The dataset's cached per-recording work.
    requests : sequence of tuple
        ``(train, method, mode, config, gain)`` as the arguments of
        :func:`choose_tunables`.
    workers : int, optional
        Threads that run the filter (:func:`morpi_filters.aided.run_batch`;
        default: the cores this process may use). The choice does not depend on it.

    Returns
    -------
    list of TunableChoice or MorpiError
        One per request, in order.
    """
    from ..field import TrainSet

    sets = {(t.phone, t.route): t for t in data.train_sets()}
    # stage 1: every grid point with the trained gain taken as exact (its spread considered), with and without
    # the non-holonomic updates (their NIS is judged like the others': a point without them may be the
    # consistent one)
    cands = [c for c in _candidates() if c["gain_state"] == "considered"]
    plans, groups = [], {}                        # training set -> (inputs, tunings)
    for train, method, mode, config, gain in requests:
        if not isinstance(train, TrainSet):
            if tuple(train) not in sets:
                raise ParameterError(f"train: {train!r} names no train set of the dataset, expected one of "
                                     f"{sorted(sets)}")
            train = sets[tuple(train)]
        # the group's train runs, each with its own truth (those the filter cannot run are left out)
        runs, ends, dist = [], [], []
        for rec, end, d in zip(train.runs, train.end_point_m, train.distance_m):
            try:
                runs.append(prepare(data, rec, mode, method, config, gain.mean))
            except MorpiError:
                continue
            ends.append(end)
            dist.append(d)
        where = train.name
        ends, dist = np.array(ends, float).reshape(-1, 2), np.array(dist, float)
        if not runs:
            plans.append(DataError(f"{where}: no train run with steps for the aided filter"))
            continue
        noise = tuple(float(np.median([r.noise[j] for r in runs])) for j in range(3))
        # the gyro bias walk that the train runs' rest stretches show: E[dm^2] = q dt per axis
        drift = [r.gyro_drift for r in runs if r.gyro_drift[1] is not None and r.gyro_drift[1] > 0]
        walk = (float(np.sqrt(np.mean([d[0].mean() / d[1] for d in drift]))) if drift
                else aided.AidTuning().gyro_walk)
        # the step of the apparent accelerometer bias between rest and motion: RMS of the train runs' shifts
        jump = float(np.sqrt(np.mean([r.motion_shift ** 2 for r in runs])))
        noise = noise + (walk, jump)
        rel = gain.std / gain.mean
        inputs, tunings = groups.setdefault(train, ([], []))
        plans.append((train, len(inputs), runs, (ends, dist), noise, rel))
        inputs += [r.input_for(c, forward_only=True) for c in cands for r in runs]
        tunings += [t for t in (tuning_from(noise, c, rel) for c in cands) for _ in runs]
    # one batch per training set (one batch of every set is slower: a larger working set for the same work)
    res = {train: aided.run_batch(inputs, tunings, workers=workers)
           for train, (inputs, tunings) in groups.items()}
    # every run so far by its input and tuning: a second stage's variant that is a grid point already run
    # (the updates off where they were), or another variant of the same run, takes that run's result
    ran = {(i, t): r for train, (inputs, tunings) in groups.items()
           for i, t, r in zip(inputs, tunings, res[train])}
    # the measurement types of the filter and the degrees of freedom of one update of each
    kinds, dof = _aided_kernel.KINDS, np.array(_aided_kernel.KIND_DOF)

    def score(mine, runs, truth):
        true_end, dist = truth                    # per run: its true end point and distance
        ends = [runs[i % len(runs)].end(r) for i, r in enumerate(mine)]
        d = np.array([e[0] - true_end[i % len(runs)] for i, e in enumerate(ends)])
        m2 = np.array([x @ np.linalg.solve(e[1], x) for x, e in zip(d, ends)]).reshape(-1, len(runs))
        err = np.linalg.norm(d, axis=1).reshape(-1, len(runs)) / dist * 100
        # each run's NIS sum and update count per measurement type, over its forward pass up to the read-out
        nis = np.array([[r.nis.get(k, (0.0, 0, 0))[:2] for k in kinds] for r in mine]).reshape(-1, len(runs),
                                                                                              len(kinds), 2)
        return err, m2 <= aided.CHI2_95_2DOF, nis[..., 0], nis[..., 1]

    # stage 2, at the point each selection (all runs, and each leave-one-out fold) picks: without the
    # non-holonomic updates, and with the gain estimated (with and without them)
    variants = [{"nhc": False}, {"gain_state": "estimated"}, {"nhc": False, "gain_state": "estimated"}]
    firsts, inputs, tunings = [], [], []
    for plan in plans:
        if isinstance(plan, MorpiError):
            firsts.append(None)
            continue
        train, start, runs, truth, noise, rel = plan
        err, inside, ns, nc = score(res[train][start:start + len(cands) * len(runs)], runs, truth)
        keep = np.ones(len(runs), bool)
        folds = [keep] + [np.arange(len(runs)) != i for i in range(len(runs))] if len(runs) > 1 else [keep]
        # the same rule in every selection: all runs, and each nested leave-one-out fold without its run
        picks = [choose_consistent(err[:, f], inside[:, f], ns[:, f], nc[:, f], dof)[0] for f in folds]
        wins = sorted(set(picks))
        firsts.append((err, inside, ns, nc, folds, picks, wins, len(inputs)))
        more = [dict(cands[w], **v) for w in wins for v in variants]
        inputs += [r.input_for(c, forward_only=True) for c in more for r in runs]
        tunings += [t for t in (tuning_from(noise, c, rel) for c in more) for _ in runs]
    todo = list(dict.fromkeys(k for k in zip(inputs, tunings) if k not in ran))
    ran.update(zip(todo, aided.run_batch([k[0] for k in todo], [k[1] for k in todo], workers=workers)))
    res2 = [ran[k] for k in zip(inputs, tunings)]
    out = []
    for plan, first in zip(plans, firsts):
        if isinstance(plan, MorpiError):
            out.append(plan)
            continue
        _, _, runs, truth, noise, rel = plan
        err, inside, ns, nc, folds, picks, wins, at = first
        mine = res2[at:at + len(wins) * len(variants) * len(runs)]
        err2, inside2, ns2, nc2 = score(mine, runs, truth)
        k_hat = np.array([r.gain_error for r in mine]).reshape(-1, len(runs))
        # each train run's own gain error: its step sum against the route (z = (1 + k) x the true displacement)
        true_end, dist = truth
        k_true = np.array([np.linalg.norm(np.diff(r.morpi_xy, axis=0), axis=1).sum() for r in runs]) / dist - 1.0
        # the grid point and its variants, each with its runs: error, coverage, NIS sums and counts
        arms = {("grid", w): (err[w], inside[w], ns[w], nc[w]) for w in wins}
        arms.update({("variant", j): (err2[j], inside2[j], ns2[j], nc2[j]) for j in range(err2.shape[0])})

        def rank(arm, f):
            e, ins, s_, c_ = arms[arm]
            short, out = _rank(ins[None, f], s_[None, f], c_[None, f], dof)
            return int(short[0]), int(out[0])

        chosen = []
        for f, w in zip(folds, picks):
            i = wins.index(w) * len(variants)
            no_nhc, est, est_no_nhc = ("variant", i), ("variant", i + 1), ("variant", i + 2)
            if _aid_pays(err[w, f], rank(("grid", w), f), err2[no_nhc[1], f], rank(no_nhc, f)):
                base, arm, g = cands[w], ("grid", w), est
            else:
                base, arm, g = dict(cands[w], nhc=False), no_nhc, est_no_nhc
            if _estimate_wins(arms[arm][0][f], rank(arm, f), err2[g[1], f], rank(g, f), k_hat[g[1], f], k_true[f]):
                base, arm = dict(base, gain_state="estimated"), g
            chosen.append((base, arm))
        info, arm = chosen[0]
        e_all, ins_all, s_all, c_all = arms[arm]
        short, out_n = rank(arm, folds[0])
        per_dof = _nis_per_dof(s_all[None], c_all[None], dof)[0]
        train_nis = {k: {"per_dof": float(q), "updates": int(c_all[:, j].sum()), "dof": int(dof[j])}
                     for j, (k, q) in enumerate(zip(kinds, per_dof)) if c_all[:, j].sum() > 0}
        outside = sorted(k for k, q in train_nis.items() if not NIS_BAND[0] <= q["per_dof"] <= NIS_BAND[1])
        # nested leave-one-out: each train run scored by the choice made without it
        loo = [arms[c[1]][0][i] for i, c in enumerate(chosen[1:])]
        # the folds whose choice is not consistent on their own runs
        loo_fallback = sum(rank(c[1], f) != (0, 0) for c, f in zip(chosen[1:], folds[1:]))
        morpi_m = np.array([np.linalg.norm(r.morpi_xy[-1] - e) for r, e in zip(runs, true_end)])
        # the mean error in per cent of the distance (one route's distance: the mean error over it)
        morpi = (float(np.mean(morpi_m) / dist[0] * 100) if np.all(dist == dist[0])
                 else float(np.mean(morpi_m / dist) * 100))
        out.append(TunableChoice(float(e_all.mean()), float(np.mean(loo)) if loo else float("nan"),
                                 morpi, info, noise, consistent=(short, out_n) == (0, 0), train_nis=train_nis,
                                 train_coverage=float(np.mean(ins_all)), outside=tuple(outside),
                                 loo_fallback=int(loo_fallback)))
    return out


def gain_estimate_pays(k_hat, k_true) -> bool:
    """Whether the filter's gain estimates explain the train runs' own gain errors, beyond chance.

    The gain error ``k`` is observable only through the INS's velocity, whose
    own errors under way (the phone's specific-force shift, vibration) it
    may absorb instead, the more so the longer the run. An estimated gain is
    kept only when, over the train runs, its end-of-run estimates bring each
    run's true gain error (its step sum against the route's length) closer
    than zero does, by more than one standard error: with
    ``d_i = k_true_i^2 - (k_hat_i - k_true_i)^2``, ``mean(d) > std(d) / sqrt(r)``
    (the one-standard-error rule of model choice: the simpler model, the
    trained gain as exact, unless the data show the richer one pays).

    Parameters
    ----------
    k_hat, k_true : array_like, shape (r,)
        Estimated and true relative gain errors of the train runs.

    Returns
    -------
    bool
        False with fewer than two runs.

    Examples
    --------
    >>> gain_estimate_pays([0.04, -0.02, 0.03], [0.05, -0.03, 0.04])
    True
    >>> gain_estimate_pays([0.03, 0.02, -0.03, 0.0], [0.05, -0.03, 0.04, 0.01])   # as often wrong as right
    False
    """
    k_hat, k_true = np.asarray(k_hat, float), np.asarray(k_true, float)
    if k_true.size < 2:
        return False
    d = k_true ** 2 - (k_hat - k_true) ** 2
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


def _nis_per_dof(nis_sum, nis_count, dof):
    """NIS per degree of freedom per candidate and measurement type, summed over the runs (axis 1); NaN
    where a type has no update."""
    total, count = np.asarray(nis_sum, float).sum(axis=1), np.asarray(nis_count, float).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / (count * np.asarray(dof, float)), np.nan)


def _rank(inside, nis_sum, nis_count, dof, band=NIS_BAND):
    """Per candidate, how far from consistent it is on these runs: (1 when its 95 % ellipse holds fewer
    than :data:`MIN_TRAIN_COVERAGE` of the true end points else 0, the number of measurement types whose
    NIS per dof lies outside `band`). ``(0, 0)`` is consistent; lower ranks are less inconsistent."""
    per_dof = _nis_per_dof(nis_sum, nis_count, dof)
    out = np.sum((per_dof < band[0]) | (per_dof > band[1]), axis=1)      # NaN (no update) is never outside
    short = (np.asarray(inside, float).mean(axis=1) < MIN_TRAIN_COVERAGE).astype(int)
    return short, out


def choose_consistent(err, inside, nis_sum, nis_count, dof, band=NIS_BAND) -> tuple[int, bool]:
    """The grid point of least mean train error among the consistent ones, else the least inconsistent.

    A candidate is consistent on the runs when its 95 % ellipse holds the
    true end point of at least :data:`MIN_TRAIN_COVERAGE` of them and, for
    every measurement type it updates with, the NIS summed over the runs'
    updates per degree of freedom (``sum NIS / (updates * dof)``) lies in
    `band` (:data:`NIS_BAND`, edges included). Among the consistent
    candidates the least mean error wins (:func:`morpi_filters.choice.choose`:
    the earliest within the tie tolerance). When none is consistent, the
    least inconsistent compete on the error: first those whose ellipse holds
    enough end points (all when none does), among them those with the fewest
    measurement types outside the band. A count of types, not a distance
    from the band: a type no candidate brings into the band (the rest
    updates, whose noise the grid does not move) then weighs the same on
    every candidate and the choice is made by the types the grid moves and
    by the error, not by the rounding of a distance all of them share.

    Parameters
    ----------
    err : array_like, shape (c, r)
        End-point error of each candidate on each run (any unit).
    inside : array_like of bool, shape (c, r)
        Whether the run's true end point lies inside the candidate's 95 % ellipse.
    nis_sum : array_like, shape (c, r, k)
        Sum of the NIS of each candidate's updates of each measurement type on each run.
    nis_count : array_like, shape (c, r, k)
        Number of those updates (a type without updates is not judged).
    dof : array_like, shape (k,)
        Degrees of freedom of one update of each type.
    band : (float, float)
        The consistent NIS per degree of freedom.

    Returns
    -------
    index : int
        The chosen candidate.
    consistent : bool
        Whether it is consistent (False: the least inconsistent).

    Examples
    --------
    Three candidates on two runs, one measurement type of 2 dof: the first
    has the least error but a NIS per dof of 0.01 (it expects innovations
    ten times the spread it sees); the third is consistent:

    >>> err = [[1.0, 1.0], [3.0, 3.0], [2.0, 2.0]]
    >>> inside = np.ones((3, 2), bool)
    >>> count = np.full((3, 2, 1), 50)
    >>> nis = count * 2 * np.array([0.01, 20.0, 0.9])[:, None, None]
    >>> choose_consistent(err, inside, nis, count, [2])
    (2, True)
    >>> nis[2] *= 10                                  # now none is consistent: each has one type outside,
    >>> choose_consistent(err, inside, nis, count, [2])       # and the least error of them wins
    (0, False)
    """
    score = np.asarray(err, float).mean(axis=1)
    short, out = _rank(inside, nis_sum, nis_count, dof, band)
    ok = (short == 0) & (out == 0)
    if ok.any():
        return choose(np.where(ok, score, np.inf)), True
    pool = short == short.min()
    pool &= out == out[pool].min()
    return choose(np.where(pool, score, np.inf)), False


def _aid_pays(err_with, rank_with, err_without, rank_without) -> bool:
    """Whether an aid (the non-holonomic updates) earns its place at the chosen point on the train runs.

    It stays when the filter with it is less inconsistent on the train runs
    (:func:`_rank`: its ellipse holds enough train end points and fewer
    measurement types leave :data:`NIS_BAND`; ``(0, 0)`` consistent), and
    goes when it is more; at the same rank, it stays when it improves the
    end points by more than one standard error of the paired per-run
    differences (the one-standard-error rule, for the simpler filter without it).
    """
    if tuple(rank_with) != tuple(rank_without):
        return tuple(rank_with) < tuple(rank_without)
    d = np.asarray(err_without) - np.asarray(err_with)
    if d.size < 2:
        return False
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


def _estimate_wins(err, rank, err_e, rank_e, k_hat, k_true) -> bool:
    """Whether estimating the gain at the chosen point replaces taking it as exact.

    Only when the estimate's ellipse still holds enough train end points and
    it is no less consistent than the filter taking the gain as exact
    (:func:`_rank`), the estimates explain the runs' gain errors
    (:func:`gain_estimate_pays`) and the end points improve by more than one
    standard error of the paired per-run differences (the one-standard-error rule).
    """
    d = np.asarray(err) - np.asarray(err_e)
    if d.size < 2 or rank_e[0] or tuple(rank_e) > tuple(rank) or not gain_estimate_pays(k_hat, k_true):
        return False
    return bool(d.mean() > d.std(ddof=1) / np.sqrt(d.size))


@dataclass(frozen=True)
class TunableChoice:
    """The tunables chosen on a training set's train runs.

    Attributes
    ----------
    score_percent : float
        Mean train end-point error of the chosen grid point [% of the route].
    loo_percent : float
        Nested leave-one-out: each train run's error under the grid point chosen without it [%].
    morpi_percent : float
        MoRPI alone on the same train runs with the same gain [%].
    info : dict
        The grid point (:data:`GRID`).
    noise : tuple
        What the train runs show: noise densities at rest (accel, gyro, gyro per epoch), the gyro
        bias walk [rad/s/sqrt(s)] and the shift of the mean specific force between rest and motion
        [m/s^2] (the accelerometer bias step of :class:`aided.AidTuning`).
    consistent : bool
        Whether the chosen filter is consistent on the train runs (:func:`choose_consistent`: its 95 %
        ellipse holds at least :data:`MIN_TRAIN_COVERAGE` of the true end points and every measurement
        type's NIS per dof lies in :data:`NIS_BAND`); False: no grid point was, the least inconsistent won.
    train_nis : dict
        Measurement type -> ``{per_dof, updates, dof}``: the chosen filter's NIS on the train runs' forward
        passes up to the read-out.
    train_coverage : float
        Share of the train runs whose true end point lies inside its forward 95 % ellipse.
    outside : tuple of str
        The measurement types whose train NIS per dof lies outside :data:`NIS_BAND`.
    loo_fallback : int
        Nested leave-one-out folds whose choice was not consistent on the fold's runs.
    """

    score_percent: float
    loo_percent: float
    morpi_percent: float
    info: dict
    noise: tuple
    consistent: bool = True
    train_nis: dict = field(default_factory=dict)
    train_coverage: float = float("nan")
    outside: tuple = ()
    loo_fallback: int = 0
