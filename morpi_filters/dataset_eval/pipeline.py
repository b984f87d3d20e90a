"""The train-only choices of a dataset's evaluation and every estimate of one recording under them."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from .. import aided
from .. import field as fd
from .. import field_aided as fa
from .. import steps as st
from ..choice import choose
from ..errors import DataError, MorpiError, ParameterError
from ..manifest import RouteTruth, Settings, TruthTrack
from ..strapdown import ins2d, ins3d
from .results import (AIDED, AIDED_BY, CALIBRATIONS, COURSE_M, ESTIMATES, METHODS, V0_SIGMA_MIN, AblationRun,
                      EstimatedPath, ellipse_share, path_metrics)

# --------------------------------------------------------------------------- per recording

def _rot(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s], [s, c]])



def _rest_window(data, dr):
    """(RestWindow or None, why not): the manifest's ``rest`` as :class:`~morpi_filters.field.FieldData` reads it."""
    try:
        return data.rest_window(data.recording_at(dr.id)), ""
    except MorpiError as exc:
        if dr.rest == "none":
            return None, "rest = \"none\": no rest window"
        return None, f"rest = \"auto\": no rest window found ({exc})"


def _start(dr, course_m: float) -> dict:
    """Initial velocity (navigation frame), the truth frame's turn and origin, and what was used."""
    rec, truth = dr.recording, dr.truth
    t0 = float(rec.time[0])
    if isinstance(truth, RouteTruth):
        return {"v0": np.zeros(3), "psi": 0.0, "how": "route frame (x along the heading at the start)",
                "course_deg": None, "speed_mps": 0.0}
    if dr.initial == "truth":
        h = truth.interval
        a = max(t0 - h, float(truth.time[0]))
        b = a + 2 * h if a < t0 - 0.5 * h else t0 + h
        pa, pb, pc = truth.at([a, b, 2 * b - a])
        v = (pb - pa) / (b - a)
        psi = math.atan2(v[1], v[0])
        c, s = math.cos(psi), math.sin(psi)
        v0 = np.array([c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]])
        # the aided filter's sigma: how far the truth velocity moves from this span to the next
        sigma = max(V0_SIGMA_MIN, float(np.linalg.norm((pc - pb) / (b - a) - v)))
        return {"v0": v0, "psi": psi, "course_deg": math.degrees(psi), "speed_mps": float(np.hypot(v[0], v[1])),
                "v0_sigma": sigma,
                "how": f"truth velocity over [{a - t0:.4g}, {b - t0:.4g}] s from the first sample"}
    p0 = truth.at([t0])[0, :2]
    later = truth.time > t0
    away = np.hypot(*(truth.position[later, :2] - p0).T) >= course_m
    if not away.any():
        raise DataError(f"the truth track never moves {course_m:g} m from its position at the first sample")
    k = int(np.argmax(away))
    q = truth.position[later][k, :2]
    psi = math.atan2(q[1] - p0[1], q[0] - p0[0])
    return {"v0": np.zeros(3), "psi": psi, "course_deg": math.degrees(psi), "speed_mps": 0.0,
            "how": f"truth course over its first {course_m:g} m (reached {float(truth.time[later][k]) - t0:.4g} s "
                   "after the first sample)"}


def _place(start: dict, truth, t_first: float, xy: np.ndarray) -> np.ndarray:
    """Navigation-frame positions (origin at the estimate's first point) in the truth's frame."""
    out = xy @ _rot(start["psi"]).T
    if isinstance(truth, TruthTrack):
        out = out + truth.at([t_first])[0, :2]
    return out


@dataclass(frozen=True, eq=False)
class PreparedRecording:
    """One recording made ready for every method (:meth:`Pipeline.prepare`).

    Attributes
    ----------
    entry : morpi_filters.manifest.DatasetRecording
        The recording with its labels and truth.
    recording : morpi_filters.dataset.Recording
        Its samples, as the pipeline's per-recording work keys them.
    rest_window : morpi_filters.calibration.RestWindow or None
        The initial rest (the manifest's ``rest``: given, detected, or none).
    no_rest : str
        Why there is no rest window ("" with one).
    calibrated : dict
        Calibration -> the calibrated recording: ``"RD"`` always, ``"GC"`` and ``"GAC"`` with a rest window.
    start : dict
        The start every estimate shares: ``v0`` (navigation frame) [m/s], ``psi`` (the truth frame's turn)
        [rad], ``course_deg``, ``speed_mps``, ``how`` and, from a truth track's velocity, ``v0_sigma`` [m/s].
    """

    entry: object
    recording: object
    rest_window: object
    no_rest: str
    calibrated: dict
    start: dict


def _prepare(data, dr, course_m) -> PreparedRecording:
    """Per recording: rest window, calibrated recordings, start; raises when there is no start to align with."""
    window, why = _rest_window(data, dr)
    rec = data.recording_at(dr.id)
    cals = {"RD": rec}
    if window is not None:
        for mode in ("GC", "GAC"):
            cals[mode] = data.calibrated(rec, mode)[0]
    return PreparedRecording(entry=dr, recording=rec, rest_window=window, no_rest=why, calibrated=cals,
                             start=_start(dr, course_m))


_MORPI = ("MoRPI-A", "MoRPI-G")


def _why_not(data, rec, mode, method, config) -> str:
    try:
        data.step_sums(rec, mode, method, config)
    except MorpiError as exc:
        return str(exc)
    return f"{data.relpath(rec)}: no gain"


def _choose(data, dataset, settings: Settings) -> tuple[dict, dict, dict]:
    """The train-only choices on `data`: the step rule per MoRPI method, the JSON entries of every choice
    (``choices``) and per (group, method, calibration) the trained :class:`~morpi_filters.field.Gain` with its
    train set and scope."""
    th = data.thresholds
    sets = [s for s in data.train_sets() if s.runs]
    if settings.held_out != "auto":
        held_out = settings.held_out
        why = f"evaluation.held_out = {held_out!r}"
    else:
        held_out = "group" if len(sets) >= 2 else "recording"
        why = ("two train groups or more: each group's runs are scored with a gain none of its runs set, as a "
               "test run of a group without train recordings is" if held_out == "group"
               else "one train group: each run is scored with the mean gain of its group's other train runs")
    configs, rule = {}, {}
    for m in _MORPI:
        sel = fd.select_config(data, m, held_out=held_out)
        if math.isfinite(sel.score):
            cfg = sel.config
            src = (f"field.select_config on the train recordings ({m} alone, GC), scored by "
                   f"leave-one-{held_out}-out end-point error")
        else:
            cfg = st.DEFAULT_CONFIGS[m]
            src = ("steps.DEFAULT_CONFIGS: the rule chosen on the MoRPI field train runs, since "
                   + ("the dataset has no train recording with periodic motion" if not sets
                      else "its train recordings give no held-out score"))
        configs[m] = cfg
        scores = {h: fd.held_out_score(data, m, cfg, held_out=h) for h in fd.HELD_OUT}
        rule[m] = {"config": {f.name: getattr(cfg, f.name) for f in fields(cfg)}, "from": src,
                   "score_percent": {h: (v if math.isfinite(v) else None) for h, (v, _) in scores.items()},
                   "runs_scored": {h: n for h, (_, n) in scores.items()}}
    pooled = fd.TrainSet("every train group", tuple(f for s in sets for f in s.files),
                         tuple(r for s in sets for r in s.runs),
                         np.concatenate([s.end_point_m for s in sets]) if sets else np.empty((0, 2)),
                         np.concatenate([s.distance_m for s in sets]) if sets else np.empty(0))
    by_group = {s.name: s for s in sets}
    train_group = {dr.group: dr.train_group for dr in dataset.recordings}
    entries, trained = [], {}
    for group in dict.fromkeys(dr.group for dr in dataset.recordings):
        if train_group[group] is not None:
            tset, scope = by_group.get(train_group[group]), f"train_group {train_group[group]!r}"
            if tset is None:        # its train recordings do not load, or none has periodic motion
                tset = fd.TrainSet(train_group[group], (), (), np.empty((0, 2)), np.empty(0))
        else:
            tset, scope = by_group.get(group), "group"
            if tset is None:
                tset, scope = pooled, "dataset (no train recording in the group)"
        for m in _MORPI:
            for mode in CALIBRATIONS:
                g = fd.set_gain(data, tset, mode, m, configs[m], phone=dataset.name, route=group)
                entry = {"group": group, "method": m, "calibration": mode, "from": scope,
                         "train": list(g.files) if g else [],
                         "skipped": list(g.skipped) if g else [], "mean": None, "std": None, "per_run": []}
                if g is not None:
                    trained[group, m, mode] = (g, tset, scope)
                    entry.update(mean=g.mean, std=g.std, per_run=list(g.per_run))
                else:
                    entry["skipped"] = [_why_not(data, r, mode, m, configs[m]) for r in tset.runs]
                entries.append(entry)
    def where(values, files, what):
        return (f"{what} of the train recordings {', '.join(dict.fromkeys(files))}" if len(values)
                else "the library's default (no train recording measured it)")
    thresholds = {
        "accel_floor_mps2": {"value": th.accel_floor, "from": where(th.rest_std, th.rest_files,
                             "k_std of calibration.detect_rest times the median rest accelerometer spread")},
        "min_swing_deg": {"value": th.min_swing_deg, "from": where(th.swings_deg, th.swing_files,
                          f"{fd.SWING_MARGIN:g} times the least median heading swing")},
        "turn_deg": {"value": th.turn_deg, "from": where(th.period_changes_deg, th.change_files,
                     f"{fd.TURN_MARGIN:g} times the largest full-period heading change")},
    }
    choices = {"settings": settings.to_json(), "rule": rule, "held_out": {"used": held_out, "why": why},
               "train_sets": [{"group": s.name, "train": list(s.files),
                               "end_point_m": s.end_point_m.tolist(), "distance_m": s.distance_m.tolist()}
                              for s in sets],
               "thresholds": thresholds, "gains": entries}
    return configs, choices, trained


def _none_if_nan(v):
    return float(v) if v is not None and math.isfinite(v) else None


def _aided_choices(data, dataset, configs, trained, workers, settings) -> tuple[dict, list]:
    """The aided filter's train-only tunables per (group, calibration) of a group with periodic motion: a list
    of (method name, MoRPI method, :class:`~morpi_filters.field_aided.TunableChoice`, Gain), one filter with
    ``aided_methods = "chosen"``, one per MoRPI method with ``"each"``; and their JSON entries."""
    groups = [g for g in dict.fromkeys(dr.group for dr in dataset.recordings)
              if any(dr.group == g and dr.motion == "periodic" for dr in dataset.recordings)]
    keys, requests, index = [], [], {}
    for group in groups:
        for m in _MORPI:
            for mode in CALIBRATIONS:
                if (group, m, mode) not in trained:
                    continue
                g, tset, _ = trained[group, m, mode]
                at = index.setdefault((id(tset), m, mode), len(requests))
                if at == len(requests):                 # a set shared by several groups is tuned once
                    requests.append((tset, m, mode, configs[m], g))
                keys.append(((group, m, mode), at))
    picks = fa.choose_tunables_many(data, requests, workers=workers) if requests else []
    per = {k: picks[at] for k, at in keys}
    chosen, entries = {}, []
    for group in groups:
        for mode in CALIBRATIONS:
            cands, why = [], {}
            for m in _MORPI:
                c = per.get((group, m, mode))
                if c is None:
                    why[m] = "no gain: no train recording gave one"
                elif isinstance(c, MorpiError):
                    why[m] = str(c)
                else:
                    cands.append((m, c))
            entry = {"group": group, "calibration": mode, "method": None, "from": None, "train": [],
                     "candidates": {m: ({"score_percent": _none_if_nan(c.score_percent),
                                         "loo_percent": _none_if_nan(c.loo_percent),
                                         "morpi_percent": _none_if_nan(c.morpi_percent)} if m not in why
                                        else {"why": why[m]})
                                    for m, c in [(m, per.get((group, m, mode))) for m in _MORPI]},
                     "tunables": None}
            if not cands:
                entries.append(entry)
                continue
            if settings.aided_methods == "each":
                picked = [(AIDED_BY[m], m, c, "evaluation.aided_methods = 'each': one filter per MoRPI method")
                          for m, c in cands]
            else:
                loo = [c.loo_percent for _, c in cands]
                by = "loo_percent" if all(math.isfinite(v) for v in loo) else "score_percent"
                m, c = cands[choose(np.array([getattr(c, by) for _, c in cands]))]
                picked = [(AIDED, m, c, f"the method of least {by}")]
            for name, m, c, how in picked:
                g, tset, scope = trained[group, m, mode]
                noise, info = c.noise, c.info
                chosen.setdefault((group, mode), []).append((name, m, c, g))
                one = dict(entry)
                one.update(method=m, train=list(g.files),
                           **{"from": f"field_aided.choose_tunables_many on the train set {tset.name!r} ({scope}); "
                                      f"{how}"},
                           tunables={**info, "accel_noise": noise[0] * info["vibration"],
                                     "gyro_noise": noise[1] * info["vibration"], "rest_accel_noise": noise[0],
                                     "rest_gyro_noise": noise[2], "gyro_walk": noise[3], "accel_jump": noise[4],
                                     "gain_sigma": g.std / g.mean})
                entries.append(one)
    return chosen, entries


def _aided_input(data, dr, prep, mode, method, config, gain, info):
    """The aided filter's input for one recording, its read-out time and the input started at the motion
    onset: from the rest window (:func:`~morpi_filters.field_aided.prepare`,
    :meth:`~morpi_filters.field_aided.Prepared.onset_input`) or, for ``initial = "truth"``, from the first
    sample under way."""
    from ..strapdown import coarse_level

    rec = prep.recording
    if dr.initial == "rest":
        p = fa.prepare(data, rec, mode, method, config, gain.mean)
        return p.input_for(info), p.stop_s, p.onset_input(info)
    crec = prep.calibrated[mode]
    s = data.steps(rec, mode, method, config)
    track = st.morpi_track(s, gain.mean)
    window = prep.rest_window
    if window is not None:
        f_rest = crec.f[window.i0:window.i1].mean(axis=0)
        C0, g, rest = coarse_level(f_rest), float(np.linalg.norm(f_rest)), fa.rest_terms(data, rec, mode)[1][1:]
    else:
        C0, g, rest = np.eye(3), data.gravity, ()
    vectors = (fa.route_steps(data, rec, mode, config, s, track.length) if info["step_heading"] == "route"
               else np.diff(track.position, axis=0))
    inp = aided.AidedInput(time=crec.time, f=crec.f, omega=crec.omega, C0=C0, g=g, step_start=s.start_time,
                           step_end=s.end_time, step_length=track.length, rest=tuple(rest), standing=(),
                           step_vector=vectors, v0=prep.start["v0"], v0_sigma=prep.start["v0_sigma"])
    stop = float(s.end_time[-1]) if s.end_time.size else float(data.activity(rec)[1])
    # the same input started at the motion onset (Prepared.onset_input's cut): at the first sample when the
    # recording moves from there; the robot stands up to the onset, the initial velocity is kept
    return inp, stop, inp.since(float(data.activity(rec)[0]))


def _aided_paths(data, dr, prep, chosen, configs, ablate: bool = False) -> tuple[list, list, list]:
    """The aided filter's rows of one recording (forward and smoothed per calibration), what was left out and,
    with `ablate`, its :class:`AblationRun` entries."""
    if dr.initial == "rest" and prep.rest_window is None:
        return [], [{"id": dr.id, "what": AIDED,
                     "why": "initial = \"rest\" without a rest window: the filter starts at the rest"}], []
    members, left = [], []
    for mode in prep.calibrated:
        if (dr.group, mode) not in chosen:
            left.append({"id": dr.id, "what": f"{AIDED} {mode}", "why": "no tunables: no train run served the filter"})
            continue
        for name, method, choice, gain in chosen[dr.group, mode]:
            try:
                inp, stop, onset = _aided_input(data, dr, prep, mode, method, configs[method], gain, choice.info)
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{name} {mode}", "why": str(exc)})
                continue
            members.append((name, mode, inp, stop, fa.tuning_from(choice.noise, choice.info, gain.std / gain.mean),
                            onset))
    results = aided.run_batch([q[2] for q in members], [q[4] for q in members], smooth=True,
                              smoothed_covariance=True, innovations=True, workers=1) if members else []
    start, truth = prep.start, dr.truth
    rot = _rot(start["psi"])
    paths = []
    for (name, mode, inp, stop, *_), r in zip(members, results):
        j = r.index_at(stop)
        t = r.time[:j + 1]
        nis = {k: {**fa.nis_consistency(total, n, dof), "dof": dof} for k, (total, n, dof) in r.nis.items()}
        for estimate, xy, P in (("forward", r.position, r.P_xy), ("smoothed", r.smoothed, r.P_xy_smoothed)):
            placed = _place(start, truth, float(t[0]), np.asarray(xy)[:j + 1, :2])
            P = rot @ np.asarray(P)[:j + 1] @ rot.T
            paths.append(EstimatedPath(id=dr.id, split=dr.split, group=dr.group, method=name, calibration=mode,
                                       time=t, xy=placed, metrics=path_metrics(t, placed, truth), estimate=estimate,
                                       P_xy=P, nis=nis, coverage_95=ellipse_share(t, placed, P, truth),
                                       innovations=r.innovations))
    return paths, left, (_ablation_runs(dr, prep, members, paths) if ablate else [])


def _ablation_runs(dr, prep, members, paths) -> list:
    """Per calibration the filter of `members` with each aid of :data:`~morpi_filters.field_aided.ABLATIONS`
    removed in turn, both read-outs, beside the filter it is compared with (`paths`: the full filter's rows)."""
    full = {(p.method, p.calibration, p.estimate): p for p in paths}
    t_first = float(dr.recording.time[0])
    items = []                                  # (filter, mode, aid, which, tuning, input, stop)
    for label, mode, inp, stop, tuning, onset in members:
        for name, change in fa.ABLATIONS.items():
            if not (change and fa.aid_used(name, tuning)):
                continue                        # not used: not run, the full filter's values; smoothing: no run
            if name == "rest updates":          # removed from a filter started at the motion onset, beside it
                items.append((label, mode, name, "full", tuning, onset, stop))
            items.append((label, mode, name, "ablated", tuning.with_(**change),
                          onset if name == "rest updates" else inp, stop))
    results = aided.run_batch([q[5] for q in items], [q[4] for q in items], smooth=True, smoothed_covariance=False,
                              nis=False, workers=1) if items else []
    start, truth = prep.start, dr.truth
    ran = {}
    for (label, mode, name, which, _, _, stop), r in zip(items, results):
        j = r.index_at(stop)
        t = r.time[:j + 1]
        for estimate, xy in (("forward", r.position), ("smoothed", r.smoothed)):
            placed = _place(start, truth, float(t[0]), np.asarray(xy)[:j + 1, :2])
            ran[label, mode, name, which, estimate] = EstimatedPath(
                id=dr.id, split=dr.split, group=dr.group, method=label, calibration=mode, time=t, xy=placed,
                metrics=path_metrics(t, placed, truth), estimate=estimate)
    begin = "rest window" if dr.initial == "rest" else "first sample"
    out = []
    for label, mode, _, _, tuning, _ in members:
        for name, change in fa.ABLATIONS.items():
            used = fa.aid_used(name, tuning)
            for estimate in ESTIMATES:
                base, where = full[label, mode, estimate], begin
                if name == "smoothing":         # the forward read-out in place of the smoothed one
                    without = full[label, mode, "forward"]
                elif not used:                  # the same filter: exactly no effect
                    without = base
                else:
                    without = ran[label, mode, name, "ablated", estimate]
                    if name == "rest updates":
                        base, where = ran[label, mode, name, "full", estimate], "motion onset"
                out.append(AblationRun(id=dr.id, split=dr.split, group=dr.group, calibration=mode, removed=name,
                                       used=bool(used), estimate=estimate, start=where,
                                       start_s=float(base.time[0]) - t_first, full=base, ablated=without,
                                       method=label))
    return out


def _ins(data, dr, prep, crec, mode, method, span):
    """The INS run of one calibrated recording: over its motion window (``span = "motion"``, a recording that
    starts at rest: :meth:`~morpi_filters.field.FieldData.ins`) or over the whole recording from its start."""
    if span == "motion" and dr.initial == "rest":
        return data.ins(prep.recording, mode, method, span="motion")
    v0 = prep.start["v0"]
    return (ins3d(crec.time, crec.f, crec.omega, v0=v0, g=data.gravity) if method == "INS-3D"
            else ins2d(crec.time, crec.f, crec.omega, v0=v0))


def _evaluate_one(data, dr, prep, gains, configs, chosen, settings, ablate=False) -> tuple[list, list, list]:
    truth, start = dr.truth, prep.start
    paths, left, ablated = [], [], []
    label = dict(id=dr.id, split=dr.split, group=dr.group)
    for mode, crec in prep.calibrated.items():
        for method in ("INS-3D", "INS-2D"):
            try:
                run = _ins(data, dr, prep, crec, mode, method, settings.ins_span)
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": str(exc)})
                continue
            t = np.asarray(run.time)
            xy = _place(start, truth, float(t[0]), np.asarray(run.position)[:, :2])
            paths.append(EstimatedPath(**label, method=method, calibration=mode, time=t, xy=xy,
                                       metrics=path_metrics(t, xy, truth)))
        if dr.motion != "periodic":
            continue
        for method in ("MoRPI-A", "MoRPI-G"):
            gain = gains.get((dr.group, method, mode))
            if gain is None:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": "no gain: no train recording gave one"})
                continue
            try:
                s = data.steps(prep.recording, mode, method, configs[method])
            except MorpiError as exc:
                left.append({"id": dr.id, "what": f"{method} {mode}", "why": str(exc)})
                continue
            track = st.morpi_track(s, gain.mean)
            tm = np.r_[s.start_time[:1], s.end_time]
            xy = _place(start, truth, float(tm[0]), track.position)
            paths.append(EstimatedPath(**label, method=method, calibration=mode, time=tm, xy=xy,
                                       metrics=path_metrics(tm, xy, truth)))
    if dr.motion == "periodic":
        more, why, ablated = _aided_paths(data, dr, prep, chosen, configs, ablate)
        paths += more
        left += why
    order = {(m, c): i for i, (m, c) in enumerate((m, c) for m in METHODS for c in CALIBRATIONS)}
    paths.sort(key=lambda p: (order[p.method, p.calibration], ESTIMATES.index(p.estimate) if p.estimate else 0))
    if prep.rest_window is None:
        left.insert(0, {"id": dr.id, "what": "GC, GAC", "why": prep.no_rest})
    if dr.motion != "periodic":
        left.append({"id": dr.id, "what": f"MoRPI-A, MoRPI-G, {AIDED}",
                     "why": f"motion = {dr.motion!r}: no periodic motion"})
    return paths, left, ablated



# --------------------------------------------------------------------------- the trained pipeline

@dataclass(frozen=True, eq=False)
class Pipeline:
    """A dataset's train-only choices, and the calls that apply them to one recording (:func:`train`).

    What :func:`~morpi_filters.dataset_eval.evaluate` runs on every
    recording, open to a script: :meth:`estimates` of one recording are the
    rows the evaluation's table holds for it, number for number, and
    :meth:`aided_input` hands the aided filter's input with its trained
    tuning to :func:`morpi_filters.aided.run_batch`.

    Attributes
    ----------
    dataset : morpi_filters.manifest.Dataset
        The dataset trained on.
    settings : morpi_filters.manifest.Settings
        How it is evaluated.
    course_m : float
        The course distance of a start at rest [m].
    data : morpi_filters.field.FieldData
        The per-recording work (rest and motion windows, calibrations,
        steps), done once and shared by every call.
    rules : dict
        MoRPI method -> the chosen :class:`~morpi_filters.steps.StepConfig`.
    gains : dict
        ``(group, method, calibration)`` -> the trained
        :class:`~morpi_filters.field.Gain`.
    tunings : dict
        ``(group, calibration)`` -> the aided filters: a list of ``(name,
        MoRPI method, TunableChoice, Gain)``.
    choices : dict
        The JSON's ``choices``: every choice, where it comes from and its
        train scores.
    """

    dataset: object
    settings: Settings
    course_m: float
    data: object
    rules: dict
    gains: dict
    tunings: dict
    choices: dict

    @property
    def thresholds(self):
        """The detection thresholds trained on the train recordings (:class:`~morpi_filters.field.Thresholds`)."""
        return self.data.thresholds

    def _entry(self, recording):
        if isinstance(recording, str):
            try:
                return self.dataset[recording]
            except KeyError:
                raise ParameterError(f"recording: {recording!r} is not an id of the dataset "
                                     f"{self.dataset.name!r}") from None
        if not any(recording is r for r in self.dataset.recordings):
            raise ParameterError("recording: expected an id or a recording of the trained dataset")
        return recording

    def prepare(self, recording) -> PreparedRecording:
        """The recording's rest window, calibrations and start (what every method of it shares).

        Parameters
        ----------
        recording : str or morpi_filters.manifest.DatasetRecording
            Its id, or the recording of :attr:`dataset`.

        Returns
        -------
        PreparedRecording

        Raises
        ------
        ParameterError
            Not a recording of the dataset.
        DataError
            A truth track that never moves the course distance (no heading to align with).
        """
        return _prepare(self.data, self._entry(recording), self.course_m)

    def estimates(self, recording, *, ablation: bool = False, prepared: PreparedRecording | None = None) -> tuple:
        """Every method's estimate of one recording under the trained choices: its rows of the evaluation.

        Parameters
        ----------
        recording : str or morpi_filters.manifest.DatasetRecording
            Its id, or the recording of :attr:`dataset`.
        ablation : bool
            Also run the aided filter's ablation on it.
        prepared : PreparedRecording, optional
            Its :meth:`prepare`, when already made.

        Returns
        -------
        paths : list of EstimatedPath
            In the order of :data:`METHODS`, :data:`CALIBRATIONS`, :data:`ESTIMATES`.
        left_out : list of dict
            ``id``, ``what`` and ``why`` of each estimate it does not have.
        ablation_runs : list of AblationRun
            Empty without `ablation`.
        """
        dr = self._entry(recording)
        prep = prepared if prepared is not None else self.prepare(dr)
        return _evaluate_one(self.data, dr, prep, self.gains, self.rules, self.tunings, self.settings, ablation)

    def aided_input(self, recording, calibration: str = "GC", method: str | None = None) -> tuple:
        """The aided filter's input of one recording, with the tuning trained for its group.

        Parameters
        ----------
        recording : str or morpi_filters.manifest.DatasetRecording
            Its id, or the recording of :attr:`dataset`.
        calibration : {"RD", "GC", "GAC"}
            The calibration.
        method : {"MoRPI-A", "MoRPI-G"}, optional
            The MoRPI method whose steps the filter takes; default: the one
            the evaluation runs (the chosen one, or the first with
            ``aided_methods = "each"``).

        Returns
        -------
        inp : morpi_filters.aided.AidedInput
        tuning : morpi_filters.aided.AidTuning
        stop_s : float
            The read-out time: the last step boundary [s].

        Raises
        ------
        ParameterError
            No trained filter for the recording's group, calibration and method.
        DataError
            No steps found (or, with ``initial = "rest"``, no rest window).
        """
        dr = self._entry(recording)
        filters = [f for f in self.tunings.get((dr.group, calibration), ()) if method in (None, f[1])]
        if not filters:
            raise ParameterError(f"recording {dr.id!r}: no aided filter trained for group {dr.group!r}, "
                                 f"calibration {calibration!r}" + (f" and {method}" if method else ""))
        _, m, choice, gain = filters[0]
        prep = self.prepare(dr)
        if dr.initial == "rest" and prep.rest_window is None:
            raise DataError(f"recording {dr.id!r}: initial = \"rest\" without a rest window ({prep.no_rest})")
        inp, stop, _ = _aided_input(self.data, dr, prep, calibration, m, self.rules[m], gain, choice.info)
        return inp, fa.tuning_from(choice.noise, choice.info, gain.std / gain.mean), stop


def train(dataset, *, settings: Settings | None = None, course_m: float = COURSE_M,
          workers: int | None = None) -> Pipeline:
    """Make every train-only choice of a dataset's evaluation.

    The detection thresholds, each MoRPI method's step rule, the gains and
    the aided filter's tunings, from the dataset's ``train`` recordings only
    (:mod:`morpi_filters.dataset_eval`).

    Parameters
    ----------
    dataset : morpi_filters.manifest.Dataset
        The dataset.
    settings : morpi_filters.manifest.Settings, optional
        How to evaluate; default: the dataset's own.
    course_m : float
        Horizontal distance over which a truth track's course gives the
        heading of a start at rest [m].
    workers : int, optional
        Threads that run the aided filter's tuning (default: the cores the
        process may use); the choices do not depend on it.

    Returns
    -------
    Pipeline

    Raises
    ------
    ParameterError
        A bad `settings`, `course_m` or `workers`.
    """
    from ..manifest import Dataset

    if not isinstance(dataset, Dataset):
        raise ParameterError(f"dataset: {type(dataset).__name__}, expected a morpi_filters.manifest.Dataset")
    if settings is None:
        settings = dataset.settings
    elif not isinstance(settings, Settings):
        raise ParameterError(f"settings: {type(settings).__name__}, expected a morpi_filters.manifest.Settings")
    if not (isinstance(course_m, (int, float)) and not isinstance(course_m, bool) and math.isfinite(course_m)
            and course_m > 0):
        raise ParameterError(f"course_m: {course_m!r}, expected a positive distance in metres")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ParameterError(f"workers: {workers!r}, expected a positive whole number")
    if workers is None:
        from ..parallel import available_cores

        workers = available_cores()
    data = fd.FieldData(dataset, course_m=float(course_m))
    rules, choices, trained = _choose(data, dataset, settings)
    tunings, choices["aided"] = _aided_choices(data, dataset, rules, trained, workers, settings)
    return Pipeline(dataset=dataset, settings=settings, course_m=float(course_m), data=data, rules=rules,
                    gains={k: v[0] for k, v in trained.items()}, tunings=tunings, choices=choices)
