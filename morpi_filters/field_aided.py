"""MoRPI-aided INS on the field recordings, against MoRPI alone and the INS alone.

Per MoRPI table cell of :func:`morpi_filters.evaluate.evaluate_tables`, the
error-state filter of :func:`morpi_filters.eskf.morpi_aided_ins` runs the 3D
strapdown over each test run with the cell's steps and trained gain as
pseudo-measurements. Its tunables are chosen per training set, method and
calibration on the ``train`` runs only (:func:`train_aided_tuning`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import units
from .errors import MorpiError

__all__ = ["AIDED_GRID", "AIDED_EVERY", "AidedCell", "field_aided_study", "train_aided_tuning"]

#: Grid of the aided-INS tunables searched on the training runs: factor on the datasheet
#: noise densities (the car's vibration is far above them) and white relative step
#: error; the other tunables are fixed in _tunings.
AIDED_GRID = {"noise_scale": (10.0, 100.0, 1000.0), "step_sigma": (0.05, 0.1, 0.2)}
#: Filter epochs every this many samples on the recordings (10 Hz at 100 Hz).
AIDED_EVERY = 10


@dataclass(frozen=True)
class AidedCell:
    """MoRPI-aided INS vs MoRPI alone vs INS alone on one table cell.

    Attributes
    ----------
    label : str
        The cell (table, phone, p2p, method, calibration).
    runs : int
        Test runs evaluated by all three.
    aided_percent, morpi_percent, ins_percent : float
        Mean end-point error over the runs [% of the travelled distance].
    aided_m, morpi_m, ins_m : float
        Mean end-point error [m].
    tuning : dict
        The tunables chosen on the training runs.
    train_score : float
        Mean train end-point error of the chosen tunables [%].
    """

    label: str
    runs: int
    aided_percent: float
    morpi_percent: float
    ins_percent: float
    aided_m: float
    morpi_m: float
    ins_m: float
    tuning: dict
    train_score: float


def _aided_end(data, rec, mode, method, config, gain, tuning):
    """Aided and INS-alone end points of one recording (MorpiError when it has no steps).

    The aided INS runs over the motion (the gyro activity span joined with the
    steps' span), levelled from the mean specific
    force over the initial rest window (roll and pitch; heading zero, i.e.
    along the route's start direction), with gravity equal to the magnitude of
    that mean (it absorbs the z-accelerometer bias).
    """
    from .eskf import morpi_aided_ins
    from .strapdown import coarse_level

    steps = data.steps(rec, mode, method, config)
    crec, _ = data.calibrated(rec, mode)
    _, gc = data.calibrated(rec, "GC")
    w = gc.window
    f_rest = crec.f[w.i0:w.i1].mean(axis=0)
    C0 = coarse_level(f_rest)
    a, b = data.activity(rec)
    a, b = min(a, float(steps.start_time[0])), max(b, float(steps.end_time[-1]))
    sl = slice(int(np.searchsorted(crec.time, a)), int(np.searchsorted(crec.time, b, side="right")))
    L = gain * steps.weight * steps.fraction
    run = morpi_aided_ins(crec.time[sl], crec.f[sl], crec.omega[sl], steps.start_time, steps.end_time, L,
                          units.sensor_for_phone(rec.phone), tuning, C0=C0, g=float(np.linalg.norm(f_rest)),
                          every=AIDED_EVERY)
    ins = data.ins(rec, mode, "INS-3D")
    return run.end_point, np.asarray(ins.position)[-1, :2]


def _tunings(gain_sigma):
    from itertools import product

    from .eskf import AidedTuning, StepModel

    for ns, ss in product(AIDED_GRID["noise_scale"], AIDED_GRID["step_sigma"]):
        yield ({"noise_scale": ns, "step_sigma": ss, "gain_sigma": gain_sigma},
               AidedTuning(dv0=0.02, ba=0.05, bg=0.5 * units.DEG_S, eps0=0.02, noise_scale=ns,
                           step=StepModel(gain_sigma=gain_sigma, step_sigma=ss, jitter_s=0.02, cross_sigma_m=0.05)))


def train_aided_tuning(data, train, method, mode, config, gain):
    """Choose the aided-INS tunables on one training set (``train`` split only).

    Parameters
    ----------
    data : field.FieldData
    train : (str, str)
        (phone, route) of the training set.
    method, mode : str
        MoRPI method and calibration.
    config : steps.StepConfig
    gain : field.Gain
        The trained gain (mean used for the steps, std / mean as the gain
        error's 1 sigma).

    Returns
    -------
    (score, info, tuning)
        Mean train end-point error [%], the tunables as a dict, the AidedTuning.
    """
    from . import dataset as ds

    recs = data.recordings(train[0], train[1], "train")
    truth = ds.route(train[1])
    best = None
    for info, tun in _tunings(gain.std / gain.mean):
        errs = []
        for rec in recs:
            try:
                end, _ = _aided_end(data, rec, mode, method, config, gain.mean, tun)
            except MorpiError:
                continue
            errs.append(np.linalg.norm(end - truth.end_point_m) / truth.distance_m * 100)
        score = float(np.mean(errs)) if errs else np.inf
        if best is None or score < best[0]:
            best = (score, info, tun)
    return best


def field_aided_study(root, result=None, labels=None):
    """MoRPI-aided INS (this filter) vs MoRPI alone vs INS alone per MoRPI table cell.

    The cells, gains, step rule and recordings are those of
    :func:`morpi_filters.evaluate.evaluate_tables`. The aided filter's
    tunables (:data:`AIDED_GRID`) are chosen per training set, method and
    calibration by the mean end-point error on the ``train`` runs; the
    relative gain error's 1 sigma is the trained gain's std over its mean.
    Nothing of a ``test`` folder enters the choice.

    Parameters
    ----------
    root : path
        Dataset root.
    result : evaluate.TablesResult, optional
        Reuse a computed evaluation.
    labels : collection of str, optional
        Only these cells (``CellSpec.label``); all MoRPI cells by default.

    Returns
    -------
    list of AidedCell
    """
    from . import dataset as ds
    from .evaluate import evaluate_tables

    res = result if result is not None else evaluate_tables(root, alternatives=False)
    data = res.data
    gmap = {(g.phone, g.route, g.method, g.calibration): g for g in res.gains}
    chosen = {}
    out = []
    for cell in res.cells:
        sp = cell.spec
        if sp.train is None or not cell.runs or (labels is not None and sp.label not in labels):
            continue
        g = gmap.get((sp.train[0], sp.train[1], sp.method, sp.calibration))
        if g is None:
            continue
        config = res.selections[sp.method].config
        key = (sp.train, sp.method, sp.calibration)
        if key not in chosen:
            chosen[key] = train_aided_tuning(data, sp.train, sp.method, sp.calibration, config, g)
        score, info, tun = chosen[key]
        truth = ds.route(sp.route)
        by_file = {r.file: r for r in cell.runs}
        a_e, m_e, i_e = [], [], []
        for rec in data.recordings(sp.phone, sp.route, sp.split):
            rel = data.relpath(rec)
            if rel not in by_file:
                continue
            try:
                end, ins_end = _aided_end(data, rec, sp.calibration, sp.method, config, g.mean, tun)
            except MorpiError:
                continue
            a_e.append(np.linalg.norm(end - truth.end_point_m))
            i_e.append(np.linalg.norm(ins_end - truth.end_point_m))
            m_e.append(by_file[rel].end_error_m)
        if not a_e:
            continue
        d = truth.distance_m / 100
        out.append(AidedCell(label=sp.label, runs=len(a_e), aided_percent=float(np.mean(a_e) / d),
                             morpi_percent=float(np.mean(m_e) / d), ins_percent=float(np.mean(i_e) / d),
                             aided_m=float(np.mean(a_e)), morpi_m=float(np.mean(m_e)), ins_m=float(np.mean(i_e)),
                             tuning=info, train_score=score))
    return out


def _field_aided(source, result=None):
    """The field study of :func:`field_aided_study`, or why it is not run."""
    if source is None or source.root is None:
        return [], "No data source configured: the MoRPI-aided INS is not run on recordings."
    cells = field_aided_study(source.root, result=result)
    if not cells:
        return [], "No MoRPI table cell could be evaluated on these recordings."
    better = sum(c.aided_percent < c.morpi_percent for c in cells)
    return cells, (
        "Per MoRPI table cell (test runs): this filter around the 3D strapdown (closed loop, levelled from the "
        "initial rest, the cell's steps and trained gain as pseudo-measurements) against MoRPI alone and the INS "
        "alone, mean end-point error in % of the travelled distance. The filter's tunables are chosen per "
        f"training set, method and calibration on the train runs only, over {AIDED_GRID}. The aided INS beats "
        f"MoRPI alone in {better} of {len(cells)} cells. The training runs choose process noise "
        f"{min(c.tuning['noise_scale'] for c in cells):g}-{max(c.tuning['noise_scale'] for c in cells):g} times "
        "the datasheet's (the car's vibration): between steps the smartphone INS carries little information, "
        "and the aided solution stays close to MoRPI's.")
