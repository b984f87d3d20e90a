"""The paper's protocol on the field recordings: every table cell, ours beside the paper's.

Cells (32 in all, the tables of Etzion and Klein [1]_):

========================  =====================================  ===========================
table (JSON name)         recordings                             what
========================  =====================================  ===========================
``ins_straight``          s8/line_dataset                        INS-3D/2D x RD/GAC
``short_route``           {s8 1 m, s8 1.5 m, s6 1 m} test        MoRPI-A/G x RD/GC
``long_route``            {s8, s6}/long_distance/test            MoRPI-A/G x RD/GC, indoor gains
``ins_l_shape``           s6/L_line                              INS-3D/2D x RD/GAC
``morpi_l_shape``         s6/L_shape/test                        MoRPI-A/G x RD/GC, s6 indoor gains
========================  =====================================  ===========================

Protocol
    Gains are trained per training set (phone, route), method and calibration
    on the ``train`` split with the known distance: each run's gain makes its
    summed steps equal the distance, the gain is the mean over runs (the std is
    kept). The long route and the L shape use the indoor 1 m gains of the same
    phone, without retraining.

Tunables
    The step rule (the paper's open readings and the thresholds, see
    :mod:`morpi_filters.steps`) is chosen by :func:`select_config` from the
    short-route ``train`` runs only: a coordinate search scored by the
    leave-one-out end-point error on the train runs (each held-out run is
    dead-reckoned with the gain of the other runs of its set). Nothing of a
    ``test`` folder enters the choice, so the result is the same with the test
    folders absent.

Errors
    ``ours_percent`` is the mean end-point error over the test runs, in % of
    the route's travelled distance (the paper's measure); the distance error
    ``|travelled estimate - true distance|`` is given beside it.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023 (tables "INS results", "weinberg results short",
   "tab:comparison methods", "weinberg results long", "tab:INS_Lshape",
   "tab:morpi_Lshape").
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import dataset as ds
from . import steps as st
from .errors import MorpiError

__all__ = [
    "TABLES", "PAPER_CELLS", "PAPER_COMPARISON", "CellSpec", "RunResult", "Cell", "Gain", "Selection",
    "TablesResult", "FieldData", "select_config", "evaluate_tables", "report_tables", "SHORT_SETS",
]

# --------------------------------------------------------------------------- the paper's numbers

#: JSON table names, in the paper's order, with the .tex label of each.
TABLES = {
    "ins_straight": "INS results",
    "short_route": "weinberg results short",
    "long_route": "weinberg results long",
    "ins_l_shape": "tab:INS_Lshape",
    "morpi_l_shape": "tab:morpi_Lshape",
}

#: Every table cell of the paper: (table, phone, p2p [m], method, calibration, end-point error [%]).
#: Copied from morpi-paper.tex, tables labelled as in :data:`TABLES`.
PAPER_CELLS = (
    # \label{INS results}: s8 straight line, 6.3 m
    ("ins_straight", "s8", None, "INS-3D", "RD", 53.7), ("ins_straight", "s8", None, "INS-3D", "GAC", 53.1),
    ("ins_straight", "s8", None, "INS-2D", "RD", 62.0), ("ins_straight", "s8", None, "INS-2D", "GAC", 28.6),
    # \label{weinberg results short}: test split, 6.3 m
    ("short_route", "s8", 1.0, "MoRPI-A", "RD", 8.25), ("short_route", "s8", 1.0, "MoRPI-A", "GC", 5.87),
    ("short_route", "s8", 1.0, "MoRPI-G", "RD", 7.94), ("short_route", "s8", 1.0, "MoRPI-G", "GC", 4.76),
    ("short_route", "s8", 1.5, "MoRPI-A", "RD", 9.84), ("short_route", "s8", 1.5, "MoRPI-A", "GC", 8.25),
    ("short_route", "s8", 1.5, "MoRPI-G", "RD", 9.05), ("short_route", "s8", 1.5, "MoRPI-G", "GC", 6.67),
    ("short_route", "s6", 1.0, "MoRPI-A", "RD", 7.30), ("short_route", "s6", 1.0, "MoRPI-A", "GC", 7.14),
    ("short_route", "s6", 1.0, "MoRPI-G", "RD", 4.60), ("short_route", "s6", 1.0, "MoRPI-G", "GC", 4.60),
    # \label{weinberg results long}: outdoor, 13 m, indoor 1 m gains
    ("long_route", "s8", 1.0, "MoRPI-A", "RD", 7.15), ("long_route", "s8", 1.0, "MoRPI-A", "GC", 5.62),
    ("long_route", "s8", 1.0, "MoRPI-G", "RD", 5.85), ("long_route", "s8", 1.0, "MoRPI-G", "GC", 4.46),
    ("long_route", "s6", 1.0, "MoRPI-A", "RD", 8.62), ("long_route", "s6", 1.0, "MoRPI-A", "GC", 8.46),
    ("long_route", "s6", 1.0, "MoRPI-G", "RD", 4.77), ("long_route", "s6", 1.0, "MoRPI-G", "GC", 4.15),
    # \label{tab:INS_Lshape}: s6 L route in straight lines, 28 m
    ("ins_l_shape", "s6", None, "INS-3D", "RD", 1123.0), ("ins_l_shape", "s6", None, "INS-3D", "GAC", 161.0),
    ("ins_l_shape", "s6", None, "INS-2D", "RD", 1523.0), ("ins_l_shape", "s6", None, "INS-2D", "GAC", 156.0),
    # \label{tab:morpi_Lshape}: s6 L route in periodic motion, s6 indoor gains
    ("morpi_l_shape", "s6", 1.0, "MoRPI-A", "RD", 18.97), ("morpi_l_shape", "s6", 1.0, "MoRPI-A", "GC", 16.14),
    ("morpi_l_shape", "s6", 1.0, "MoRPI-G", "RD", 8.63), ("morpi_l_shape", "s6", 1.0, "MoRPI-G", "GC", 8.2),
)

#: \label{tab:comparison methods}: mean position error [m] of the best calibration of each method
#: on the 6.3 m indoor route, and the improvement between methods, which the paper computes as the
#: difference of the end-point errors in percentage points (53.1 - 28.6 = 24.5 for 2D vs 3D INS).
PAPER_COMPARISON = {
    "label": "tab:comparison methods",
    "error_m": {"INS-3D": 3.34, "INS-2D": 1.80, "MoRPI-A": 0.37, "MoRPI-G": 0.29},
    "improvement_pp": {("INS-2D", "INS-3D"): 24.5, ("MoRPI-A", "INS-3D"): 47.2, ("MoRPI-A", "INS-2D"): 22.7,
                       ("MoRPI-G", "INS-3D"): 48.5, ("MoRPI-G", "INS-2D"): 24.0, ("MoRPI-G", "MoRPI-A"): 1.27},
}

#: Short-route training/test sets: (phone, route, p2p).
SHORT_SETS = (("s8", "short_distance", 1.0), ("s8", "short_distance_1.5p2p", 1.5), ("s6", "short_distance", 1.0))

_INS_METHODS = ("INS-3D", "INS-2D")
#: INS integration spans (see :class:`FieldData`).
INS_SPANS = ("motion", "full")
_MORPI_METHODS = tuple(st.METHODS)


@dataclass(frozen=True)
class CellSpec:
    """Where a cell's recordings and gains come from.

    Attributes
    ----------
    table, phone, method, calibration : str
    p2p_m : float or None
    paper_percent : float
    route : str
        Route folder of the evaluated runs.
    split : str or None
        ``"test"`` or None (folders without a split).
    train : tuple or None
        (phone, route) of the training set of the gains; None for INS cells.
    """

    table: str
    phone: str
    p2p_m: float | None
    method: str
    calibration: str
    paper_percent: float
    route: str
    split: str | None
    train: tuple | None

    @property
    def label(self) -> str:
        p2p = f" {self.p2p_m:g} m" if self.p2p_m is not None else ""
        return f"{self.table} {self.phone}{p2p} {self.method} {self.calibration}"


def cell_specs() -> list[CellSpec]:
    """The 32 cells with their data sources."""
    out = []
    for table, phone, p2p, method, cal, pct in PAPER_CELLS:
        if table == "ins_straight":
            route, split, train = "line_dataset", None, None
        elif table == "ins_l_shape":
            route, split, train = "L_line", None, None
        elif table == "short_route":
            route = "short_distance" if p2p == 1.0 else "short_distance_1.5p2p"
            split, train = "test", (phone, route)
        elif table == "long_route":
            route, split, train = "long_distance", "test", (phone, "short_distance")
        else:
            route, split, train = "L_shape", "test", ("s6", "short_distance")
        out.append(CellSpec(table, phone, p2p, method, cal, pct, route, split, train))
    return out


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class RunResult:
    """One run of a cell.

    Attributes
    ----------
    file : str
        Path relative to the dataset root.
    end_point : tuple of float
        Estimated end point (x, y) [m].
    end_error_m, end_error_percent : float
        Distance to the true end point [m] and in % of the travelled distance.
    distance_m, distance_error_percent : float
        Estimated travelled distance [m] and ``|estimate - truth|`` in %.
    n_steps : int or None
        Steps used (MoRPI), partial end steps included.
    """

    file: str
    end_point: tuple
    end_error_m: float
    end_error_percent: float
    distance_m: float
    distance_error_percent: float
    n_steps: int | None = None


@dataclass(frozen=True)
class Cell:
    """One table cell: the paper's value and ours.

    Attributes
    ----------
    spec : CellSpec
    runs : tuple of RunResult
    gain : float or None
        Gain used (MoRPI).
    failed : tuple of str
        One line per run that could not be evaluated.
    missing : str or None
        Why the cell could not be computed (data absent).
    """

    spec: CellSpec
    runs: tuple
    gain: float | None = None
    failed: tuple = ()
    missing: str | None = None

    @property
    def ours_percent(self) -> float | None:
        """Mean end-point error over the runs [% of travelled distance]."""
        return float(np.mean([r.end_error_percent for r in self.runs])) if self.runs else None

    @property
    def ours_std_percent(self) -> float | None:
        return float(np.std([r.end_error_percent for r in self.runs])) if self.runs else None

    @property
    def ours_m(self) -> float | None:
        """Mean end-point error [m]."""
        return float(np.mean([r.end_error_m for r in self.runs])) if self.runs else None

    @property
    def distance_percent(self) -> float | None:
        """Mean distance error [% of travelled distance]."""
        return float(np.mean([r.distance_error_percent for r in self.runs])) if self.runs else None

    @property
    def deviation_pp(self) -> float | None:
        """ours - paper [percentage points]."""
        o = self.ours_percent
        return None if o is None else o - self.spec.paper_percent


@dataclass(frozen=True)
class Gain:
    """A trained Weinberg gain.

    Attributes
    ----------
    phone, route, method, calibration : str
    mean, std : float
        Over the training runs [m / unit^(1/4)] (unit: m/s^2 for MoRPI-A, rad/s for MoRPI-G).
    per_run : tuple of float
    files : tuple of str
    """

    phone: str
    route: str
    method: str
    calibration: str
    mean: float
    std: float
    per_run: tuple
    files: tuple


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


@dataclass(frozen=True)
class TablesResult:
    """Everything :func:`evaluate_tables` computed.

    Attributes
    ----------
    cells : tuple of Cell
    gains : tuple of Gain
    selections : dict
        Method -> Selection.
    readings : tuple of dict
        Short-route GC cells under the alternative readings of the paper.
    missing : tuple of str
        Dataset folders that were absent.
    """

    cells: tuple
    gains: tuple
    selections: dict
    readings: tuple
    missing: tuple
    data: "FieldData" = field(repr=False, default=None)

    def cell(self, table, phone, p2p_m, method, calibration) -> Cell:
        for c in self.cells:
            s = c.spec
            if (s.table, s.phone, s.p2p_m, s.method, s.calibration) == (table, phone, p2p_m, method, calibration):
                return c
        raise KeyError((table, phone, p2p_m, method, calibration))

    def gain(self, phone, route, method, calibration) -> Gain | None:
        for g in self.gains:
            if (g.phone, g.route, g.method, g.calibration) == (phone, route, method, calibration):
                return g
        return None


# --------------------------------------------------------------------------- data access with caches

class FieldData:
    """Lazy, cached access to a dataset root: recordings, calibrations, INS runs, step signals.

    Every per-recording computation is done once and reused by all cells,
    the gain training and the config search.

    Parameters
    ----------
    root : path
        Dataset root in the MoRPI layout.
    include_test : bool
        False hides every ``test`` folder (as if absent).
    ins_span : str
        ``"motion"``: the INS integrates from the start to the end of the
        robot's motion (:func:`morpi_filters.steps.activity_span`, the rests
        are left out; default); ``"full"``: the whole recording.
    """

    def __init__(self, root, *, include_test: bool = True, ins_span: str = "motion"):
        if ins_span not in INS_SPANS:
            raise MorpiError(f"ins_span={ins_span!r}: expected one of {INS_SPANS}")
        self.ins_span = ins_span
        self.root = Path(root)
        self._entries = [e for e in ds.catalogue(self.root) if include_test or e.split != "test"]
        self._rec: dict = {}
        self._cal: dict = {}
        self._prep: dict = {}
        self._ins: dict = {}
        self._steps: dict = {}

    def entries(self, phone, route, split):
        return [e for e in self._entries if (e.phone, e.route, e.split) == (phone, route, split)]

    def folders(self) -> set:
        return {(e.phone, e.route, e.split) for e in self._entries}

    def recordings(self, phone, route, split) -> list:
        out = []
        for e in self.entries(phone, route, split):
            if e.relpath not in self._rec:
                self._rec[e.relpath] = e.load()
            out.append(self._rec[e.relpath])
        return out

    def relpath(self, rec) -> str:
        try:
            return Path(rec.source).relative_to(self.root).as_posix()
        except ValueError:
            return rec.source

    def calibrated(self, rec, mode: str):
        """(calibrated Recording, Calibration or None) for RD | GC | GAC."""
        from .calibration import calibrate

        key = (rec.source, mode)
        if key not in self._cal:
            cal = calibrate(rec, mode)
            self._cal[key] = (cal.apply(rec), cal)
        return self._cal[key]

    def rest_end(self, rec) -> float:
        """End time of the initial rest window [s]."""
        _, cal = self.calibrated(rec, "GC")
        return _window_end(cal, rec)

    def prepared(self, rec, mode: str, method: str, cutoff_hz):
        key = (rec.source, mode, method, cutoff_hz)
        if key not in self._prep:
            crec, _ = self.calibrated(rec, mode)
            motion = self._motion(rec, mode, method)
            self._prep[key] = st.prepare_signal(crec, method, cutoff_hz, motion=motion)
        return self._prep[key]

    def _motion(self, rec, mode, method):
        key = (rec.source, mode, method, "motion")
        if key not in self._prep:
            crec, _ = self.calibrated(rec, mode)
            attr, col = st.METHODS[method]
            self._prep[key] = st.motion_span(crec.time, getattr(crec, attr)[:, col], self.rest_end(rec))
        return self._prep[key]

    def steps(self, rec, mode, method, config):
        key = (rec.source, mode, method, config)
        if key not in self._steps:
            try:
                self._steps[key] = st.extract_steps(None, method, config,
                                                    prepared=self.prepared(rec, mode, method, config.cutoff_hz))
            except MorpiError as exc:
                self._steps[key] = exc
        out = self._steps[key]
        if isinstance(out, MorpiError):
            raise out
        return out

    def activity(self, rec) -> tuple:
        """Start and end of the robot's motion [s] (gyro vibration)."""
        key = (rec.source, "activity")
        if key not in self._prep:
            self._prep[key] = st.activity_span(rec.time, rec.omega)
        return self._prep[key]

    def ins(self, rec, mode: str, method: str, span: str | None = None):
        """INS solution (InsResult) of a recording, 3D or 2D, over `span` (default: the instance's)."""
        span = span or self.ins_span
        key = (rec.source, mode, method, span)
        if key not in self._ins:
            from .strapdown import ins2d, ins3d

            crec, _ = self.calibrated(rec, mode)
            if span == "motion":
                a, b = self.activity(rec)
                sl = slice(int(np.searchsorted(crec.time, a)), int(np.searchsorted(crec.time, b, side="right")))
            else:
                sl = slice(None)
            t, f, w = crec.time[sl], crec.f[sl], crec.omega[sl]
            if t.shape[0] < 2:
                raise MorpiError(f"{rec.source}: no motion found for the INS")
            self._ins[key] = ins3d(t, f, w) if method == "INS-3D" else ins2d(t, f, w)
        return self._ins[key]


def _window_end(cal, rec) -> float:
    w = getattr(cal, "window", None)
    for name in ("end_time", "t_end", "end"):
        v = getattr(w, name, None)
        if v is not None:
            return float(v)
    return float(rec.time[0] + 2.0)


# --------------------------------------------------------------------------- gain training and config search

def _train(data: FieldData, phone, route, mode, method, config) -> Gain | None:
    recs = data.recordings(phone, route, "train")
    if not recs:
        return None
    truth = ds.route(route)
    steps_list, files = [], []
    for r in recs:
        try:
            steps_list.append(data.steps(r, mode, method, config))
            files.append(data.relpath(r))
        except MorpiError:
            continue
    if not steps_list:
        return None
    mean, std, per = st.train_gain(steps_list, truth.distance_m)
    return Gain(phone, route, method, mode, mean, std, tuple(float(g) for g in per), tuple(files))


#: Coordinate search: first the readings (with the first tunables), then the tunables.
READING_GRID = {"heading": ("absolute", "mean"), "segment": st.SEGMENTS, "ends": st.ENDS}
TUNABLE_GRID = {"cutoff_hz": (1.0, 2.0, 3.0), "prominence": (0.2, 0.35, 0.5), "min_period_s": (0.5, 1.0)}
_START = st.StepConfig(heading="absolute", segment="maxima", ends="drop", cutoff_hz=2.0, prominence=0.35,
                       min_period_s=0.5)


def _loo_score(data: FieldData, method, config, mode="GC") -> tuple[float, int]:
    """Leave-one-out mean end-point error [%] over the short-route train runs."""
    errs = []
    for phone, route, _ in SHORT_SETS:
        truth = ds.route(route)
        recs = data.recordings(phone, route, "train")
        if len(recs) < 2:
            continue
        try:
            sl = [data.steps(r, mode, method, config) for r in recs]
        except MorpiError:
            return float("inf"), 0
        g = truth.distance_m / np.array([s.effective_weight for s in sl])
        n = g.size
        for i, s in enumerate(sl):
            gi = (g.sum() - g[i]) / (n - 1)
            end = st.morpi_track(s, gi).end_point
            errs.append(np.linalg.norm(end - truth.end_point_m) / truth.distance_m * 100)
    return (float(np.mean(errs)) if errs else float("inf")), len(errs)


def select_config(data: FieldData, method: str) -> Selection:
    """Choose the step rule for `method` from the short-route train runs only.

    A coordinate search: the paper's readings (heading absolute or mean over
    the step; segments between maxima or extrema; partial end steps dropped,
    fractional or whole) are scored with the start tunables, then each tunable
    (low-pass cut-off, prominence fraction, least period) is scanned in turn
    with the best readings. The score is the leave-one-out end-point error of
    the train runs (GC calibration). The heading reading "change" is not a
    candidate: it cannot represent a turn (the L route), so it is reported as
    an alternative only. Ties keep the earlier config.
    """
    trials = []
    best, best_score, n = _START, float("inf"), 0
    keys = list(READING_GRID)
    for combo in itertools.product(*(READING_GRID[k] for k in keys)):
        cfg = _START.with_(**dict(zip(keys, combo)))
        score, n_ = _loo_score(data, method, cfg)
        trials.append((cfg, score))
        if score < best_score:
            best, best_score, n = cfg, score, n_
    for k, values in TUNABLE_GRID.items():
        base = best
        for v in values:
            cfg = base.with_(**{k: v})
            if cfg == base and any(c == cfg for c, _ in trials):
                continue
            score, n_ = _loo_score(data, method, cfg)
            trials.append((cfg, score))
            if score < best_score:
                best, best_score, n = cfg, score, n_
    if not np.isfinite(best_score):
        best = st.StepConfig()
    return Selection(method, best, best_score, tuple(trials), n)


# --------------------------------------------------------------------------- cells

def _run_result(rel, end, truth, distance, n_steps=None) -> RunResult:
    e = float(np.linalg.norm(np.asarray(end[:2]) - truth.end_point_m))
    return RunResult(file=rel, end_point=(float(end[0]), float(end[1])), end_error_m=e,
                     end_error_percent=e / truth.distance_m * 100, distance_m=float(distance),
                     distance_error_percent=abs(distance - truth.distance_m) / truth.distance_m * 100,
                     n_steps=n_steps)


def _ins_cell(data: FieldData, spec: CellSpec) -> Cell:
    recs = data.recordings(spec.phone, spec.route, spec.split)
    if not recs:
        return Cell(spec, (), missing=f"{spec.phone}/{spec.route}: no recordings")
    truth = ds.route(spec.route)
    runs, failed = [], []
    for r in recs:
        try:
            res = data.ins(r, spec.calibration, spec.method)
        except MorpiError as exc:
            failed.append(str(exc))
            continue
        p = np.asarray(res.position)[:, :2]
        dist = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        runs.append(_run_result(data.relpath(r), p[-1], truth, dist))
    return Cell(spec, tuple(runs), failed=tuple(failed))


def _morpi_cell(data: FieldData, spec: CellSpec, config, gain: Gain | None) -> Cell:
    folder = f"{spec.phone}/{spec.route}/{spec.split}"
    if gain is None:
        return Cell(spec, (), missing=f"{spec.train[0]}/{spec.train[1]}/train: no training runs for the gain")
    recs = data.recordings(spec.phone, spec.route, spec.split)
    if not recs:
        return Cell(spec, (), gain=gain.mean, missing=f"{folder}: no recordings")
    truth = ds.route(spec.route)
    runs, failed = [], []
    for r in recs:
        try:
            s = data.steps(r, spec.calibration, spec.method, config)
        except MorpiError as exc:
            failed.append(str(exc))
            continue
        tr = st.morpi_track(s, gain.mean)
        runs.append(_run_result(data.relpath(r), tr.end_point, truth, tr.distance, s.n))
    return Cell(spec, tuple(runs), gain=gain.mean, failed=tuple(failed))


def evaluate_tables(root, *, include_test: bool = True, configs: dict | None = None,
                    data: FieldData | None = None, ins_span: str = "motion") -> TablesResult:
    """Compute every table cell of the paper on a dataset root.

    Parameters
    ----------
    root : path
        Dataset root (MoRPI layout); missing folders leave their cells empty.
    include_test : bool
        False hides the test folders (the gains and configs must not change).
    configs : dict, optional
        Method -> StepConfig to use instead of :func:`select_config`.
    data : FieldData, optional
        Reuse caches.
    ins_span : str
        INS integration span (:class:`FieldData`).

    Returns
    -------
    TablesResult
    """
    data = data or FieldData(root, include_test=include_test, ins_span=ins_span)
    present = data.folders()
    missing = []
    for folder in ds.layout():
        parts = folder.split("/")
        key = (parts[0], parts[1], parts[2] if len(parts) == 3 else None)
        if key not in present and (include_test or key[2] != "test"):
            missing.append(folder)
    selections = {}
    for m in _MORPI_METHODS:
        if configs and m in configs:
            selections[m] = Selection(m, configs[m], float("nan"), (), 0)
        else:
            selections[m] = select_config(data, m)
    gains = []
    for (phone, route, _), m, mode in itertools.product(SHORT_SETS, _MORPI_METHODS, ("RD", "GC")):
        g = _train(data, phone, route, mode, m, selections[m].config)
        if g is not None:
            gains.append(g)
    gmap = {(g.phone, g.route, g.method, g.calibration): g for g in gains}
    cells = []
    for spec in cell_specs():
        if spec.method in _INS_METHODS:
            cells.append(_ins_cell(data, spec))
        else:
            g = gmap.get((spec.train[0], spec.train[1], spec.method, spec.calibration))
            cells.append(_morpi_cell(data, spec, selections[spec.method].config, g))
    readings = _alternative_readings(data, selections)
    return TablesResult(tuple(cells), tuple(gains), selections, tuple(readings), tuple(missing), data)


def _alternative_readings(data: FieldData, selections) -> list[dict]:
    """Short-route cells under each reading of the paper, other tunables as selected."""
    out = []
    specs = cell_specs()
    for m, mode in itertools.product(_MORPI_METHODS, ("GC", "RD")):
        base = selections[m].config
        for h, sg, e in itertools.product(st.HEADINGS, st.SEGMENTS, st.ENDS):
            cfg = base.with_(heading=h, segment=sg, ends=e)
            row = {"method": m, "calibration": mode, "heading": h, "segment": sg, "ends": e,
                   "selected": cfg == base, "cells": []}
            for phone, route, p2p in SHORT_SETS:
                spec = next(s for s in specs if (s.table, s.phone, s.p2p_m, s.method, s.calibration)
                            == ("short_route", phone, p2p, m, mode))
                g = _train(data, phone, route, mode, m, cfg)
                c = _morpi_cell(data, spec, cfg, g)
                row["cells"].append({"phone": phone, "p2p_m": p2p, "paper_percent": spec.paper_percent,
                                     "ours_percent": c.ours_percent, "distance_percent": c.distance_percent})
            out.append(row)
    return out
