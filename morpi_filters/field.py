"""The field recordings as cached data, and the train-only choice of the step rule.

:class:`FieldData` gives lazy, cached access to a dataset root: recordings,
calibrations, INS runs and step signals, each computed once and shared by
every cell, the gain training and the rule search. :func:`select_config`
chooses the step rule on the ``train`` runs only, by leave-one-out end-point
error (:func:`held_out_score`); :func:`nested_rule_comparison` checks that
choice with the training sets themselves held out in turn. The cells and
comparisons built on this data are in :mod:`morpi_filters.evaluate`.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _signal_kernel
from . import dataset as ds
from . import steps as st
from .calibration import NoRestError
from .choice import choose
from .errors import DataError, MorpiError, ParameterError

__all__ = ["HELD_OUT", "COURSE_M", "TrainSet", "RULES", "INS_SPANS", "LEVELED", "HEADING_ORIGINS", "HEADING_SOURCES", "Gain",
           "Selection", "Thresholds", "FieldData", "train_thresholds", "fold_thresholds", "select_config", "nested_rule_comparison",
           "READING_GRID", "TUNABLE_GRID", "SWING_MARGIN", "TURN_MARGIN", "SOURCE_SE", "trained_gain",
           "set_gain", "track_course", "check_recordings", "MORPI_METHODS", "train_summary", "loo_errors",
           "held_out_errors", "held_out_score"]

#: How a train run is held out of the gain that scores it (:func:`select_config`): with the mean gain of its
#: set's other runs (leave-one-recording-out), or of the other sets' runs (leave-one-group-out).
HELD_OUT = ("recording", "group")
#: Horizontal distance over which a truth track's course gives the heading of a start at rest [m]
#: (:func:`track_course`; :data:`morpi_filters.dataset_eval.COURSE_M` aligns the estimates alike).
COURSE_M = 0.3

#: How the step rule is chosen (see :func:`morpi_filters.evaluate.evaluate_tables`).
RULES = ("per_method", "joint")
#: INS integration spans (see :class:`FieldData`).
INS_SPANS = ("motion", "full")
#: INS start that measures the tilt at rest instead of assuming a level phone (3D INS only).
LEVELED = "GC+level"
#: Where the MoRPI heading is integrated from: the motion onset (default) or the first sample.
HEADING_ORIGINS = ("motion", "start")
#: What the MoRPI heading is read from (the step rule's ``heading_source``): the integrated z gyro, or
#: the yaw of the attitude matrix of the 3D mechanization started level with the rest specific force
#: (the paper's equation).
HEADING_SOURCES = st.HEADING_SOURCES
#: The least heading swing of a periodic run is this fraction of the smallest swing of the train runs.
SWING_MARGIN = 0.75
#: A full period turns (the ``"turns"`` heading reading) when its heading change exceeds this multiple of
#: the largest full-period heading change of the straight train runs.
TURN_MARGIN = 1.5
#: The MoRPI methods, in the tables' order.
MORPI_METHODS = tuple(st.METHODS)


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
    skipped : tuple of str
        One line per training file left out (unreadable, or no periodic motion).
    """

    phone: str
    route: str
    method: str
    calibration: str
    mean: float
    std: float
    per_run: tuple
    files: tuple
    skipped: tuple = ()


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
class Thresholds:
    """The detection thresholds the train runs set (:func:`train_thresholds`).

    Attributes
    ----------
    accel_floor : float
        Lowest accelerometer threshold of the rest detection [m/s^2]
        (:func:`morpi_filters.calibration.detect_rest`).
    min_swing_deg : float
        Least median heading swing per period of a periodic run [deg]
        (:attr:`morpi_filters.steps.StepConfig.min_swing_deg`).
    rest_std : tuple of float
        Per train run, the largest accelerometer moving standard deviation
        inside its gyro-only rest window [m/s^2].
    swings_deg : tuple of float
        Per train run, its median heading swing per period [deg].
    files : tuple of str
        The train runs, relative to the dataset root.
    turn_deg : float
        Least full-period heading change of a turn [deg]
        (:attr:`morpi_filters.steps.StepConfig.turn_deg`).
    period_changes_deg : tuple of float
        Per train run and method (MoRPI-A runs first, then MoRPI-G), its
        largest absolute full-period heading change [deg].
    rest_files, swing_files, change_files : tuple of str
        The train run of each value of `rest_std`, `swings_deg` and
        `period_changes_deg`.
    """

    accel_floor: float
    min_swing_deg: float
    rest_std: tuple = ()
    swings_deg: tuple = ()
    files: tuple = ()
    turn_deg: float = st.StepConfig().turn_deg
    period_changes_deg: tuple = ()
    rest_files: tuple = ()
    swing_files: tuple = ()
    change_files: tuple = ()


@dataclass(frozen=True, eq=False)
class TrainSet:
    """One train set of the rule search: runs that share a gain, each with its own truth.

    The train recordings with periodic motion of one group of the dataset's
    manifest (for the MoRPI dataset, a short-route folder such as
    ``s8/short_distance``, whose runs share the route's end point and distance).

    Attributes
    ----------
    name : str
        ``"<phone>/<route>"`` or the group.
    files : tuple of str
        The runs (paths relative to the root, or recording ids), in order.
    runs : tuple of Recording
    end_point_m : ndarray, shape (n, 2)
        Each run's true end point in the navigation frame of the MoRPI
        estimate (origin at the motion's start, x along the heading there) [m].
    distance_m : ndarray, shape (n,)
        Each run's true travelled distance [m].
    phone, route : str
        The group split at its first ``/`` (:class:`FieldData`'s folder).
    """

    name: str
    files: tuple
    runs: tuple
    end_point_m: np.ndarray
    distance_m: np.ndarray
    phone: str = ""
    route: str = ""


#: Used when a root has no train runs (no gains either, so no MoRPI cell): the library's defaults.
_DEFAULT_THRESHOLDS = Thresholds(accel_floor=0.1, min_swing_deg=st.StepConfig().min_swing_deg,
                                 turn_deg=st.StepConfig().turn_deg)


@dataclass(frozen=True, eq=False)
class _Entry:
    """A manifest recording as FieldData lists it: its folder ``(phone, route, split)`` (the group split at its
    first ``/``, else the dataset's name and the group; the split None for ``"none"``), its id as its relative
    path, its file, and how to load it (a DatasetRecording)."""

    phone: str
    route: str
    split: str | None
    relpath: str
    path: object
    group: str
    motion: str
    load: object


def _folder(name: str, group: str, split: str) -> tuple:
    phone, route = group.split("/", 1) if "/" in group else (name, group)
    return phone, route, None if split == "none" else split


def _entries_of(dataset) -> list:
    """The entries of a manifest Dataset (in memory) or DatasetIndex (read on demand), in the manifest's order.

    A recording whose file another recording reads too is told apart by its id in its source.
    """
    from dataclasses import replace

    from .manifest import Dataset

    items = dataset.recordings
    files = [dr.recording.source if isinstance(dataset, Dataset) else str(dr.file) for dr in items]
    out = []
    for dr, file in zip(items, files):
        if isinstance(dataset, Dataset):
            if files.count(file) > 1:
                dr = replace(dr, recording=replace(dr.recording, source=f"{file}#{dr.id}"))
            load = (lambda dr=dr: dr)
        else:
            load = dr.load
            if files.count(file) > 1:
                def load(dr=dr, file=file):
                    got = dr.load()
                    return replace(got, recording=replace(got.recording, source=f"{file}#{dr.id}"))
        out.append(_Entry(*_folder(dataset.name, dr.group, dr.split), dr.id, Path(file), dr.group, dr.motion, load))
    return out


def given_rest_window(rec, rest):
    """The rest window ``[t0, t1]`` given in seconds from the first sample, as a RestWindow on `rec`."""
    from .calibration import RestWindow

    t = rec.time - rec.time[0]
    i0 = int(np.searchsorted(t, rest[0]))
    i1 = int(np.searchsorted(t, rest[1], side="right"))
    return RestWindow(float(rec.time[i0]), float(rec.time[i1 - 1]), i0, i1, "given")


def track_course(truth, t: float, *, moving: bool = False, course_m: float = COURSE_M) -> float:
    """The course of a truth track at time `t` [rad], counter-clockwise from the track's x axis.

    ``moving``: the direction of the truth's velocity over one truth interval
    on each side of `t` (after it where the track starts there); otherwise
    the direction from the truth at `t` to its first later position
    `course_m` away horizontally. The same course aligns a method's estimate
    to the track in :mod:`morpi_filters.dataset_eval`.

    Parameters
    ----------
    truth : TruthTrack
        The track (:class:`morpi_filters.manifest.TruthTrack`).
    t : float
        Time on the track's clock [s].
    moving : bool
        The velocity's direction (a start in motion) instead of the first
        `course_m`.
    course_m : float
        Horizontal distance of the course of a start at rest [m].

    Returns
    -------
    float
        The course [rad].

    Examples
    --------
    >>> from morpi_filters.manifest import TruthTrack
    >>> track = TruthTrack(time=np.arange(5.0), position=[[0, 0, 0], [0, 0, 0], [0.1, 0.1, 0], [1, 1, 0], [2, 2, 0]])
    >>> round(float(np.degrees(track_course(track, 1.0))), 6), round(float(np.degrees(track_course(track, 3.0, moving=True))), 6)
    (45.0, 45.0)

    Raises
    ------
    DataError
        The track never moves `course_m` from its position at `t`.
    """
    import math

    if moving:
        h = truth.interval
        a = max(t - h, float(truth.time[0]))
        b = a + 2 * h if a < t - 0.5 * h else t + h
        pa, pb = truth.at([a, b])
        return math.atan2(pb[1] - pa[1], pb[0] - pa[0])
    p0 = truth.at([t])[0, :2]
    later = truth.time > t
    away = np.hypot(*(truth.position[later, :2] - p0).T) >= course_m
    if not away.any():
        raise DataError(f"{truth.source}: the truth track never moves {course_m:g} m from its position at "
                        f"{t:.6g} s")
    q = truth.position[later][int(np.argmax(away)), :2]
    return math.atan2(q[1] - p0[1], q[0] - p0[0])


class FieldData:
    """Lazy, cached access to a dataset: recordings, calibrations, INS runs, step signals.

    Every per-recording computation is done once and reused by all cells,
    the gain training and the config search. The dataset is a manifest's:
    a :class:`~morpi_filters.manifest.Dataset`, or a root in the MoRPI layout,
    read through the package's MoRPI manifest
    (:func:`morpi_filters.resources.morpi_manifest` applied to the root, its
    recordings read when first asked for). One code path serves both: a
    recording's folder ``(phone, route, split)`` is its group split at its
    first ``/`` (the MoRPI groups ``s8/short_distance``; a group without one
    has the dataset's name as its phone), and its split (None for
    ``"none"``); its id is its relative path; its rest window is the
    manifest's ``rest`` (``[t0, t1]`` as given, ``"none"`` none:
    :class:`~morpi_filters.calibration.NoRestError`, ``"auto"`` detected);
    its calibrations and 3D INS assume the normal gravity at the manifest's
    ``latitude_deg`` (:data:`morpi_filters.calibration.LOCAL_GRAVITY` for the
    MoRPI manifest), else :data:`morpi_filters.units.G0`; the train sets are
    its groups (:meth:`train_sets`).

    Parameters
    ----------
    root : path or Dataset
        Dataset root in the MoRPI layout, or a manifest dataset.

    Raises
    ------
    DataError
        `root` is a path but not a directory.
    include_test : bool
        False hides every ``test`` folder (as if absent).
    ins_span : str
        ``"motion"``: the INS integrates over the recording's motion window
        (:meth:`activity`, the rests are left out; default); ``"full"``: the
        whole recording.
    heading_from : str
        ``"motion"``: the MoRPI heading starts at zero at the motion window's
        start (default); ``"start"``: it is integrated from the first sample,
        through the initial rest.
    thresholds : Thresholds, optional
        Detection thresholds to use instead of :func:`train_thresholds` of
        this root's train runs.
    course_m : float
        A manifest dataset's truth tracks: the distance of the course of a
        start at rest (:func:`track_course`) [m].
    """

    def __init__(self, root, *, include_test: bool = True, ins_span: str = "motion", heading_from: str = "motion",
                 thresholds: Thresholds | None = None, course_m: float = COURSE_M):
        from .manifest import Dataset

        for name, v, allowed in (("ins_span", ins_span, INS_SPANS), ("heading_from", heading_from, HEADING_ORIGINS)):
            if v not in allowed:
                raise ParameterError(f"{name}={v!r}: expected one of {allowed}")
        self.ins_span = ins_span
        self.heading_from = heading_from
        self._thresholds = thresholds
        self._accel_floor = None if thresholds is None else thresholds.accel_floor
        self.course_m = float(course_m)
        if isinstance(root, Dataset):
            self.root, index = root, root
        else:
            from .manifest import index_dataset
            from .resources import morpi_manifest

            self.root = Path(root)
            if not self.root.is_dir():
                raise DataError(f"{self.root}: not a directory; expected a dataset root (the folder holding s6 and "
                                "s8)")
            index = index_dataset(morpi_manifest(), root=self.root)
        if index.latitude_deg is None:
            from .units import G0

            self._g_local = G0
        else:
            from .calibration import normal_gravity

            self._g_local = normal_gravity(index.latitude_deg)
        entries = _entries_of(index)
        declared = getattr(index, "declared", ()) or tuple((r.group, r.split, r.motion) for r in index.recordings)
        #: the groups of the train sets (:meth:`train_sets`): (group, phone, route) in the manifest's order
        self._train_groups = tuple(dict.fromkeys((g, *_folder(index.name, g, sp)[:2]) for g, sp, m in declared
                                                 if sp == "train" and m == "periodic"))
        #: per recording source, its manifest labels and truth (DatasetRecording), once loaded
        self._labels: dict = {}
        self._entries = [e for e in entries if include_test or e.split != "test"]
        self._by_folder: dict = {}
        for e in self._entries:
            self._by_folder.setdefault((e.phone, e.route, e.split), []).append(e)
        self._folder_recs: dict = {}
        self._rec: dict = {}
        self._cal: dict = {}
        self._prep: dict = {}
        self._signals: dict = {}
        #: Per-recording results of the studies built on this data (keyed by the study), reused across cells.
        self.study_cache: dict = {}
        self._ins: dict = {}
        self._steps: dict = {}
        self._peaks: dict = {}
        self._activity: dict = {}
        self._canon: dict = {}
        self._train_summaries: dict = {}

    @classmethod
    def sharing(cls, other: "FieldData", *, heading_from: str | None = None,
                ins_span: str | None = None) -> "FieldData":
        """The same root and thresholds read another way, reusing `other`'s loaded work.

        The recordings, rest windows, calibrations, motion windows, step
        signals (resampled and filtered), peaks and INS runs are shared with
        `other` (none depends on the heading origin; INS runs are keyed by
        their span); what depends on the heading is computed afresh.

        Parameters
        ----------
        other : FieldData
            The instance whose caches are shared.
        heading_from, ins_span : str, optional
            As for :class:`FieldData`; default: `other`'s.

        Returns
        -------
        FieldData
        """
        new = cls.__new__(cls)
        new.__dict__.update(other.__dict__)
        for name, v, allowed in (("ins_span", ins_span, INS_SPANS), ("heading_from", heading_from, HEADING_ORIGINS)):
            if v is not None and v not in allowed:
                raise ParameterError(f"{name}={v!r}: expected one of {allowed}")
        new.ins_span = ins_span or other.ins_span
        new.heading_from = heading_from or other.heading_from
        new._thresholds = other.thresholds
        new._accel_floor = other.accel_floor()
        new._prep, new._steps, new._train_summaries, new.study_cache = {}, {}, {}, {}
        return new

    def entries(self, phone, route, split):
        return list(self._by_folder.get((phone, route, split), ()))

    def folders(self) -> set:
        return {(e.phone, e.route, e.split) for e in self._entries}

    def recordings(self, phone, route, split) -> list:
        """The recordings of a folder that load cleanly and have an initial rest window (:meth:`problem`).

        See :meth:`load_errors` for the others.
        """
        key = (phone, route, split)
        if key in self._folder_recs:
            return list(self._folder_recs[key])
        out = [r for r in map(self._entry_recording, self.entries(phone, route, split))
               if r is not None and self.problem(r) is None]
        self._folder_recs[key] = tuple(out)
        return out

    def _entry_recording(self, entry):
        """The recording of a catalogue entry, loaded once, or None when it does not load (whether or not
        it has a :meth:`problem`)."""
        if entry.relpath not in self._rec:
            try:
                item = entry.load()
                self._labels[item.recording.source] = item
                self._rec[entry.relpath] = item.recording
            except MorpiError as exc:
                self._rec[entry.relpath] = exc
        r = self._rec[entry.relpath]
        return None if isinstance(r, MorpiError) else r

    def problem(self, rec) -> str | None:
        """Why a recording that loads cannot be evaluated (one line naming its file), or None when it can.

        Every calibration, motion window and method starts from the
        recording's initial rest (:meth:`rest_window`: the rest detection of
        :func:`morpi_filters.calibration.detect_rest` with this root's
        accelerometer floor). A recording too short to tell its motion from a
        disturbance is named here (the detection's DataError), listed by
        :meth:`load_errors` and left out of :meth:`recordings`. One that moves
        from its first samples has no rest (:meth:`no_rest`) but is no
        problem: it is evaluated under RD only.
        """
        key = (rec.source, "problem")
        if key not in self._cal:
            try:
                self.rest_window(rec)
                self._cal[key] = None
            except NoRestError:
                self._cal[key] = None
            except MorpiError as exc:
                self._cal[key] = str(exc)
        return self._cal[key]

    def no_rest(self, rec) -> str | None:
        """Why a recording has no initial rest (one line naming its file), or None when it has one.

        Such a recording moves from its first samples
        (:class:`morpi_filters.calibration.NoRestError`): what needs a rest
        window is not computed for it (the GC and GAC calibrations, the
        leveled INS start, the attitude heading, the aided filter, which starts
        at the rest), while raw data (RD) is, over a motion window found
        against the still bound (:meth:`activity`).
        """
        try:
            self.rest_window(rec)
        except NoRestError as exc:
            return str(exc)
        except MorpiError:
            return None
        return None

    def no_rest_lines(self) -> list[str]:
        """One line per recording of the root that loads, is no :meth:`problem` and has no rest (:meth:`no_rest`),
        in the folders' order."""
        out = []
        for phone, route, split in sorted(self.folders(), key=lambda k: (k[0], k[1], k[2] or "")):
            out += [line for line in map(self.no_rest, self.recordings(phone, route, split)) if line is not None]
        return out

    def load_errors(self, phone, route, split) -> list[str]:
        """One line per file of the folder that could not be loaded or cannot be evaluated (:meth:`problem`)."""
        self.recordings(phone, route, split)
        out = []
        for e in self.entries(phone, route, split):
            r = self._rec[e.relpath]
            line = str(r) if isinstance(r, MorpiError) else self.problem(r)
            if line is not None:
                out.append(line)
        return out

    def recording_at(self, relpath: str):
        """The recording at a path relative to the root (a manifest recording's id), or None when it does not
        load."""
        for e in self._entries:
            if e.relpath == relpath:
                return self._entry_recording(e)
        raise KeyError(relpath)

    def relpath(self, rec) -> str:
        """The recording's path relative to the root (its source when outside)."""
        key = (rec.source, "relpath")
        if rec.source in self._labels:
            return self._labels[rec.source].id
        if key not in self._rec:
            try:
                self._rec[key] = Path(rec.source).relative_to(self.root).as_posix()
            except ValueError:
                self._rec[key] = rec.source
        return self._rec[key]

    @property
    def gravity(self) -> float:
        """The gravity every calibration and 3D start of this dataset uses [m/s^2]: WGS84 normal gravity at the
        manifest's ``latitude_deg``, :data:`morpi_filters.units.G0` without one."""
        return float(self._g_local)

    @property
    def thresholds(self) -> Thresholds:
        """The detection thresholds in use (:func:`train_thresholds` unless given)."""
        if self._thresholds is None:
            self._thresholds = train_thresholds(self)
        return self._thresholds

    def accel_floor(self) -> float:
        """The rest detection's accelerometer floor [m/s^2] (:func:`train_thresholds`)."""
        if self._accel_floor is None:
            self._accel_floor = _train_accel_floor(self)[0]
        return self._accel_floor

    def train_entries(self, periodic: bool = False) -> list:
        """The entries of every ``train`` recording (with `periodic`, only those with ``motion = "periodic"``), by
        folder (sorted by phone and route, as :meth:`no_rest_lines` lists them), in the manifest's order within
        one: the order of the per-run measurements of :func:`train_thresholds`."""
        return sorted((e for e in self._entries if e.split == "train" and not (periodic and e.motion != "periodic")),
                      key=lambda e: (e.phone, e.route))

    def train_sets(self) -> tuple:
        """The train sets of the rule search and the gains (:class:`TrainSet`), each run with its truth (found
        once and kept: every rule's train summary reads them).

        One per group the manifest gives train recordings with periodic
        motion (a glob that matches no file counts), in the order the groups
        first appear: its train recordings with periodic motion that can be
        evaluated (:meth:`recordings`), each with its truth
        (:meth:`run_truth`); a run whose truth track gives no course is left
        out, and a set may be empty. For a MoRPI root (the package's manifest)
        these are its short-route folders, in the manifest's order.
        """
        out = self._train_summaries.get("train sets")
        if out is None:
            out = self._train_summaries["train sets"] = tuple(self._group_set(group, phone, route)
                                                              for group, phone, route in self._train_groups)
        return out

    def _group_set(self, group: str, phone: str, route: str) -> TrainSet:
        """The train runs of a group with periodic motion that can be evaluated, each with its truth."""
        runs, ends, dists = [], [], []
        for r in self.recordings(phone, route, "train"):
            if self._labels[r.source].motion != "periodic":
                continue
            try:
                end, dist = self.run_truth(r)
            except MorpiError:
                continue
            runs.append(r)
            ends.append(end)
            dists.append(dist)
        return TrainSet(group, tuple(self.relpath(r) for r in runs), tuple(runs),
                        np.array(ends, dtype=float).reshape(-1, 2), np.array(dists, dtype=float), phone, route)

    def straight_line_recordings(self) -> list:
        """The recordings the manifest labels ``motion = "straight"`` whose truth is a route along one straight
        segment (a polyline of two points, or none: start to end point), that load and are no :meth:`problem`,
        folder by folder (sorted as :meth:`no_rest_lines` lists them), in the manifest's order within one."""
        from .manifest import RouteTruth

        folders = sorted({(e.phone, e.route, e.split) for e in self._entries if e.motion == "straight"},
                         key=lambda k: (k[0], k[1], k[2] or ""))
        out = []
        for folder in folders:
            for rec in self.recordings(*folder):
                truth = self._labels[rec.source].truth
                if isinstance(truth, RouteTruth) and (truth.polyline_m is None or len(truth.polyline_m) == 2):
                    out.append(rec)
        return out

    def run_truth(self, rec) -> tuple[np.ndarray, float]:
        """A manifest recording's true end point in the MoRPI estimate's navigation frame [m], shape (2,), and
        its true distance [m].

        A route: its ``end_point_m`` and ``distance_m``. A truth track: over
        the recording's motion window (:meth:`activity`), the track's
        displacement turned by its course at the motion's start
        (:func:`track_course`: the velocity for ``initial = "truth"``, else the
        first `course_m`), and its horizontal path length (the truth samples
        inside the window and its ends).
        """
        from .manifest import RouteTruth

        item = self._labels[rec.source]
        truth = item.truth
        if isinstance(truth, RouteTruth):
            return np.asarray(truth.end_point_m, dtype=float), float(truth.distance_m)
        a, b = self.activity(rec)
        psi = track_course(truth, a, moving=item.initial == "truth", course_m=self.course_m)
        ts = np.r_[a, truth.time[(truth.time > a) & (truth.time < b)], b]
        p = truth.at(ts)[:, :2]
        c, s = np.cos(psi), np.sin(psi)
        d = p[-1] - p[0]
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]), float(np.sum(np.hypot(*np.diff(p, axis=0).T)))

    def rest_window(self, rec):
        """The initial rest window (calibration.detect_rest), found once per recording.

        Raises :class:`~morpi_filters.calibration.NoRestError` for a recording without one (:meth:`no_rest`).
        """
        return self.rest_window_at(rec, self.accel_floor())

    def rest_measures(self, rec):
        """What the rest detection measures on the recording (calibration.rest_measures), once per recording."""
        from .calibration import rest_measures

        key = (rec.source, "rest measures")
        if key not in self._cal:
            self._cal[key] = rest_measures(rec)
        return self._cal[key]

    def rest_window_at(self, rec, accel_floor: float):
        """The initial rest window with another accelerometer floor [m/s^2], found once per floor.

        Raises the detection's MorpiError (the same one each time) when there is none.
        """
        from .calibration import detect_rest

        key = (rec.source, "rest", accel_floor)
        if key not in self._cal:
            # a recording of no entry (one built in memory and passed in) has its rest detected
            rest = self._labels[rec.source].rest if rec.source in self._labels else "auto"
            try:
                if rest == "none":
                    raise NoRestError(f'{rec.source}: rest = "none": no rest window')
                self._cal[key] = (detect_rest(rec, accel_floor=accel_floor, measures=self.rest_measures(rec))
                                  if rest == "auto" else given_rest_window(rec, rest))
            except MorpiError as exc:
                self._cal[key] = exc.with_traceback(None)
        out = self._cal[key]
        if isinstance(out, MorpiError):
            raise out.with_traceback(None)
        return out

    def rest_specific_force(self, rec) -> np.ndarray:
        """Mean specific force over the initial rest window, body axes [m/s^2], shape (3,)."""
        w = self.rest_window(rec)
        return rec.f[w.i0:w.i1].mean(axis=0)

    def calibrated(self, rec, mode: str):
        """(calibrated Recording, Calibration) for RD | GC | GAC."""
        from .calibration import calibrate

        key = (rec.source, mode)
        if key not in self._cal:
            if mode == "RD":
                cal = calibrate(rec, mode)
                self._cal[key] = (rec, cal)
            else:
                cal = calibrate(rec, mode, window=self.rest_window(rec), g_local=self._g_local)
                self._cal[key] = (cal.apply(rec), cal)
        return self._cal[key]

    def rest_end(self, rec) -> float:
        """End time of the initial rest window [s]."""
        return float(self.rest_window(rec).end_s)

    def prepared(self, rec, mode: str, method: str, cutoff_hz, source: str = "gyro", *,
                 grid_hz: float | None = st.GRID_HZ, min_height: float | None = None):
        """The recording's MoRPI signal resampled on the rule's grid and filtered
        (:func:`morpi_filters.steps.prepare_signal`), with the heading of `mode` and `source`, cached.

        RD and GC differ by a constant on omega_z and not at all on f_y. A
        constant offset changes neither the peaks, the prominence threshold
        (relative to the signal's range) nor any max - min, so the signal is
        shared between RD and GC, between the heading sources and between
        the instances that share this one's work (:meth:`sharing`): only the
        heading differs. A rule with an absolute peak height (`min_height`
        set) sees the offset, so its RD and GC signals are each their own.

        Parameters
        ----------
        rec : Recording
        mode : {"RD", "GC", "GAC"}
        method : {"MoRPI-A", "MoRPI-G"}
        cutoff_hz : float or None
            The low-pass cut-off [Hz] (:attr:`morpi_filters.steps.StepConfig.cutoff_hz`).
        source : str
            The heading source (:data:`HEADING_SOURCES`).
        grid_hz : float or None
            The grid's rate [Hz] (:attr:`morpi_filters.steps.StepConfig.grid_hz`; None: the recording's).
        min_height : float or None
            The rule's absolute peak height (:attr:`morpi_filters.steps.StepConfig.min_height`): only
            whether it is set matters here.

        Returns
        -------
        PreparedSignal
        """
        offset_free = min_height is None
        key = (rec.source, mode, method, cutoff_hz, source, grid_hz, offset_free)
        if key not in self._prep:
            shared_mode = "RD|GC" if mode in ("RD", "GC") and offset_free else mode
            skey = (rec.source, shared_mode, method, cutoff_hz, grid_hz)
            shared = self._signals.get(skey)
            if shared is not None:
                from dataclasses import replace

                p = replace(shared, heading=self.heading(rec, mode, source))
                p.__dict__["motion_index"] = shared.motion_index       # the same grid and motion
            else:
                crec, _ = self.calibrated(rec, mode)
                p = self._signals[skey] = st.prepare_signal(
                    crec, method, cutoff_hz, motion=self.activity(rec), heading=self.heading(rec, mode, source),
                    grid_hz=grid_hz)
            # the heading's integral is the same for every method and cut-off: computed once, then given
            # to each signal as its cached property
            ikey = (rec.source, mode, "heading integral", source)
            if ikey in self._prep:
                p.__dict__["heading_integral"] = self._prep[ikey]
            else:
                self._prep[ikey] = p.heading_integral
            self._prep[key] = p
        return self._prep[key]

    def heading(self, rec, mode: str, source: str = "gyro") -> np.ndarray:
        """The MoRPI heading on the recording's samples [rad], shape (n,), for RD or GC.

        Read from `source` (:data:`HEADING_SOURCES`: ``"gyro"``, the integrated
        z rate; ``"attitude"``, the yaw of the 3D mechanization's attitude,
        started with the roll and pitch of the rest specific force), from the
        instance's `heading_from`: with ``"motion"`` it is zero up to the
        motion window's start (:meth:`activity`) and integrated from there;
        after the window's end it holds its last value.
        """
        if source not in HEADING_SOURCES:
            raise ParameterError(f"heading source {source!r}: expected one of {HEADING_SOURCES}")
        key = (rec.source, mode, "heading", source)
        if key not in self._prep:
            crec, _ = self.calibrated(rec, mode)
            t = crec.time
            a, b = self.activity(rec) if self.heading_from == "motion" else (t[0], t[-1])
            i0 = int(np.searchsorted(t, a))
            i1 = int(np.searchsorted(t, b, side="right"))
            if i1 - i0 < 2:
                raise DataError(f"{rec.source}: no motion found for the heading")
            psi = np.zeros(t.shape[0])
            if source == "gyro":
                part = st.integrate_heading(t[i0:i1], crec.omega[i0:i1, 2])
            else:
                from .strapdown import attitude_heading

                part = attitude_heading(t[i0:i1], crec.f[i0:i1], crec.omega[i0:i1], self.rest_specific_force(rec))
            psi[i0:i1] = part
            psi[i1:] = part[-1]
            self._prep[key] = psi
        return self._prep[key]

    def _canonical(self, config):
        # one extraction serves every least swing (a check on the result) and, unless the heading follows
        # turns, every turn threshold (unused)
        canon = self._canon.get(config)
        if canon is None:
            canon = self._canon[config] = config.with_(
                min_swing_deg=0.0, turn_deg=config.turn_deg if config.heading == "turns" else st.StepConfig.turn_deg)
        return canon

    def step_sums(self, rec, mode, method, config) -> st.StepSums:
        """:func:`morpi_filters.steps.step_sums` of a recording (:class:`~morpi_filters.steps.StepSums`), cached.

        What :meth:`steps` gives, reduced to what a gain and an end point need; raises as it does.
        """
        key = ("sums", rec.source, mode, method, config)
        out = self._steps.get(key)
        if out is None:
            canon = self._canonical(config)                    # the rules that differ only in a check share it
            ckey = ("sums", rec.source, mode, method, canon)
            out = self._steps.get(ckey)
            if out is None:
                try:
                    out = st.step_sums(self.prepared(rec, mode, method, config.cutoff_hz, config.heading_source,
                                                     grid_hz=config.grid_hz, min_height=config.min_height),
                                       method, canon, peak_cache=self._peaks)
                except MorpiError as exc:
                    out = exc
                self._steps[ckey] = out
            self._steps[key] = out
        if isinstance(out, MorpiError):
            raise out
        st.require_swing(rec.source, method, out[3], config.min_swing_deg)
        return out

    def steps(self, rec, mode, method, config):
        canon = self._canonical(config)
        key = (rec.source, mode, method, canon)
        if key not in self._steps:
            try:
                self._steps[key] = st.extract_steps(None, method, canon,
                                                    prepared=self.prepared(rec, mode, method, config.cutoff_hz,
                                                                           config.heading_source,
                                                                           grid_hz=config.grid_hz,
                                                                           min_height=config.min_height),
                                                    peak_cache=self._peaks)
            except MorpiError as exc:
                self._steps[key] = exc
        out = self._steps[key]
        if isinstance(out, MorpiError):
            raise out
        st.require_swing(rec.source, method, out.swing_deg, config.min_swing_deg)
        return out

    def activity(self, rec) -> tuple:
        """The recording's motion window (start, end) [s]: one per recording, for the INS, MoRPI-A and MoRPI-G.

        The gyro's vibration (:func:`morpi_filters.steps.activity_span`)
        against its level in the detected initial rest window
        (:meth:`rest_window`); the window starts after the rest ends and ends
        when the robot stops, before the final rest. Without a rest
        (:meth:`no_rest`) the threshold is what a still IMU's gyro stays
        within (:func:`morpi_filters.calibration.still_bound`, summed over
        the axes), and the window starts at the first sample when the robot
        moves there.
        """
        if rec.source not in self._activity:
            try:
                w = self.rest_window(rec)
            except NoRestError:
                # no rest to take the gyro's level in: the motion is what exceeds a still IMU's spread (summed
                # over the axes, as the motion window sums it), from the first sample when it moves there
                from .calibration import still_bound

                span = st.activity_span(rec.time, rec.omega, threshold=3.0 * still_bound(rec).gyro)
            else:
                span = st.activity_span(rec.time, rec.omega, rest=(w.start_s, w.end_s))
            self._activity[rec.source] = span
        return self._activity[rec.source]

    def ins(self, rec, mode: str, method: str, span: str | None = None):
        """INS solution (InsResult) of a recording, 3D or 2D, over `span` (default: the instance's).

        `mode` is RD, GAC (the paper's: level phone assumed) or :data:`LEVELED`
        (3D only: GC gyro, initial roll and pitch from the rest specific force).
        """
        span = span or self.ins_span
        key = (rec.source, mode, method, span)
        if key not in self._ins:
            from .strapdown import ins2d, ins3d

            # the gravity the calibration assumed at rest (GAC leaves (0, 0, g) there)
            C0, g = None, self._g_local
            if mode == LEVELED:
                # gyro zero-order calibration; the initial attitude from the rest specific force
                # instead of the level assumption (the accelerometer bias stays in, read as tilt)
                from .strapdown import coarse_level

                crec, cal = self.calibrated(rec, "GC")
                f_rest = self.rest_specific_force(rec)
                C0, g = coarse_level(f_rest), float(np.linalg.norm(f_rest))
            else:
                crec, _ = self.calibrated(rec, mode)
            if span == "motion":
                a, b = self.activity(rec)
                sl = slice(int(np.searchsorted(crec.time, a)), int(np.searchsorted(crec.time, b, side="right")))
            else:
                sl = slice(None)
            t, f, w = crec.time[sl], crec.f[sl], crec.omega[sl]
            if t.shape[0] < 2:
                raise DataError(f"{rec.source}: no motion found for the INS")
            if method == "INS-3D":
                self._ins[key] = ins3d(t, f, w, C0=C0, g=g)
            elif mode == LEVELED:
                raise ParameterError(f"{rec.source}: the planar INS has no tilt to level; {LEVELED} is for INS-3D")
            else:
                self._ins[key] = ins2d(t, f, w)
        return self._ins[key]


    def tilt_leak(self, rec, mode: str) -> tuple[float, float]:
        """Gravity that leaks into f_x through the tilt the 3D INS tracks, as the planar INS sees it.

        The planar INS takes f_x as horizontal acceleration. The 3D solution's
        attitude says how much of f_x is gravity, ``g C_bn[2, 0]``; integrated
        twice over the motion span (from rest) it is the along-track error the
        planar mechanization makes and the 3D one does not.

        Returns
        -------
        tilt_deg : float
            Mean of ``asin(C_bn[2, 0])`` over the motion [deg] (nose up positive).
        leak_m : float
            Double integral of ``g C_bn[2, 0]`` over the motion [m].
        """
        r3 = self.ins(rec, mode, "INS-3D")
        s = np.clip(np.asarray(r3.C_bn)[:, 2, 0], -1.0, 1.0)
        a = self._g_local * s
        dt = np.diff(r3.time)
        v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
        return float(np.degrees(np.mean(np.arcsin(s)))), float(np.sum(0.5 * (v[1:] + v[:-1]) * dt))

def check_recordings(root) -> tuple[list[str], int, list[str]]:
    """Validate every recording under a dataset root as the evaluation reads it (``morpi check``).

    :func:`morpi_filters.dataset.check_tree` (each file, the layout), and for
    each file that loads, :meth:`FieldData.problem`: a recording too short to
    tell its motion from a disturbance is a problem too, so what passes is
    what the commands evaluate. A recording that moves from its first samples
    has no initial rest (:meth:`FieldData.no_rest`): it is evaluated under RD
    only, and named apart from the problems.

    Parameters
    ----------
    root : str or Path
        The dataset root.

    Returns
    -------
    problems : list of str
        One line per bad file and per difference from the expected layout.
    n_ok : int
        Number of files that load and can be evaluated (with or without a
        rest).
    no_rest : list of str
        One line per recording among them without an initial rest: why.

    Examples
    --------
    Three recordings of 4 s: at rest; at rest, then turning from 3 s on, so
    that it ends before the turn can be told from a disturbance; and
    vibrating from its first sample (0.015 rad/s at 13 Hz), which has no rest.

    >>> import json, pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> files = {f"s8/line_dataset/{i}.csv": "" for i in (1, 2, 3)}
    >>> _ = (root / "manifest.json").write_text(json.dumps({"generator": "morpi_filters.simulate", "files": files}))
    >>> (root / "s8" / "line_dataset").mkdir(parents=True)
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(400) * 0.01
    >>> f = [0.0, 0.0, 9.8] + 0.01 * rng.standard_normal((400, 3))
    >>> w = 0.002 * rng.standard_normal((400, 3))
    >>> ds.write_csv(root / "s8/line_dataset/1.csv", ds.Recording(time=t, f=f, omega=w))
    >>> shake = 0.015 * np.sin(2 * np.pi * 13.0 * t)[:, None]
    >>> ds.write_csv(root / "s8/line_dataset/3.csv", ds.Recording(time=t, f=f, omega=w + shake))
    >>> w[300:, 2] += 0.5 * np.sin(2 * np.pi * t[300:])
    >>> ds.write_csv(root / "s8/line_dataset/2.csv", ds.Recording(time=t, f=f, omega=w))
    >>> problems, n_ok, no_rest = check_recordings(root)
    >>> n_ok, [p.replace(str(root), "ROOT") for p in problems]    # doctest: +NORMALIZE_WHITESPACE
    (2, ['ROOT/s8/line_dataset/2.csv: 400 samples (3.99 s) is too short: it ends 1.10 s into a movement that
    starts at 2.89 s, which is told from a disturbance only once it lasts sustain_s=1.5 s: at least 4.39 s
    (about 440 samples) needed'])
    >>> [p.replace(str(root), "ROOT").split(";")[0] for p in no_rest]    # doctest: +NORMALIZE_WHITESPACE
    ['ROOT/s8/line_dataset/3.csv: no initial rest found: motion starts 0.000 s after the first sample
    (0 samples at rest, expected at least 10)']
    """
    data = FieldData(root)
    usable = []

    def problem(rec):
        line = data.problem(rec)
        if line is None:
            usable.append(rec)
        return line

    problems, n_ok = ds.check_tree(root, usable=problem)
    return problems, n_ok, [line for line in map(data.no_rest, usable) if line is not None]


# --------------------------------------------------------------------------- thresholds from the train runs

def _train_accel_floor(data: FieldData) -> tuple[float, tuple, tuple]:
    """The rest detection's accelerometer floor from the train runs, with the per-run values behind it.

    Each train run's rest is found on the gyro alone (accelerometer floor
    out of reach); inside it, the largest moving standard deviation of the
    accelerometer axes (over the detector's window) is what the settling of
    the phone's filtered accelerometer channels reaches at rest. The floor is
    ``k_std`` (the detector's threshold in noise sigmas) times the median of
    those values over the train runs.
    """
    vals, files = [], []
    for e in data.train_entries():
        r = data._entry_recording(e)
        if r is None:
            continue
        try:
            w = data.rest_window_at(r, 1e9)
        except MorpiError:
            continue
        vals.append(float(data.rest_measures(r).s_a[w.i0:w.i1].max()))
        files.append(e.relpath)
    return _floor_from(vals), tuple(vals), tuple(files)


def _floor_from(rest_std) -> float:
    """The accelerometer floor: ``k_std`` of the rest detection times the median of the runs' rest values."""
    import inspect

    from .calibration import detect_rest

    if not len(rest_std):
        return _DEFAULT_THRESHOLDS.accel_floor
    return float(inspect.signature(detect_rest).parameters["k_std"].default * np.median(rest_std))


def train_thresholds(data: FieldData) -> Thresholds:
    """The detection thresholds of the rest and of periodic motion, set on the train runs only.

    Rest detection
        The gyro thresholds are in noise sigmas measured on each recording
        (:func:`morpi_filters.calibration.detect_rest`: ``k_std``, ``k_dev``),
        and the motion window's threshold is a multiple of the gyro's level
        in the recording's own rest (:func:`morpi_filters.steps.activity_span`).
        The accelerometer's floor cannot be set from its white noise: the
        phones filter their accelerometer channels, which settle slowly
        after start-up. It is ``k_std`` times the median, over the train
        runs, of the largest accelerometer moving standard deviation inside
        each run's gyro-only rest window.
    Periodic motion
        Each train run's median heading swing per period is measured (GC,
        MoRPI-G signal, the search's start rule, no swing limit); the least
        swing of a periodic run is :data:`SWING_MARGIN` times the smallest
        of them, rounded down to a whole degree.
    Turns
        The train runs are all straight, so whatever heading change they show
        over one full period is not a turn: the drift over the period and
        the phase jitter of the step boundaries. Each train run's largest
        absolute full-period change (:func:`morpi_filters.steps.period_changes`;
        GC heading, the search's start rule with half-period steps between
        extrema, so that max-to-max and min-to-min periods are both seen,
        both methods' boundaries) is measured; the least turn is
        :data:`TURN_MARGIN` times the largest of them, rounded down to a
        whole degree.

    Only ``train`` folders are read; a root without them gets the library's
    defaults (0.1 m/s^2, 15 deg, 51 deg; it has no gains either).

    Parameters
    ----------
    data : FieldData
        The dataset root; its accelerometer floor is set as a side effect
        when it was not set before.

    Returns
    -------
    Thresholds
        The accelerometer floor [m/s^2], least heading swing [deg] and least
        turn [deg], with the per-run measurements they come from and the
        train files read.
    """
    floor, rest_std, files = _train_accel_floor(data)
    data._accel_floor = floor if data._accel_floor is None else data._accel_floor
    swings, sfiles = [], []
    cfg = _START.with_(min_swing_deg=0.0)
    for e in data.train_entries(periodic=True):
        for r in data.recordings(e.phone, e.route, e.split):
            if data.relpath(r) != e.relpath:
                continue
            try:
                sw = data.steps(r, "GC", "MoRPI-G", cfg).swing_deg
            except MorpiError:
                continue
            if np.isfinite(sw):
                swings.append(float(sw))
                sfiles.append(e.relpath)
    changes, cfiles = _train_period_changes(data)
    return _thresholds_from(data.accel_floor(), rest_std, files, swings, sfiles, changes, cfiles)


def _thresholds_from(floor, rest_std, rest_files, swings, swing_files, changes, change_files) -> Thresholds:
    """The thresholds the per-run measurements set (:func:`train_thresholds`)."""
    turn = float(np.floor(TURN_MARGIN * max(changes))) if changes else _DEFAULT_THRESHOLDS.turn_deg
    per_run = dict(rest_std=tuple(rest_std), rest_files=tuple(rest_files), turn_deg=turn,
                   period_changes_deg=tuple(changes), change_files=tuple(change_files))
    if not swings:
        return Thresholds(accel_floor=floor, min_swing_deg=_DEFAULT_THRESHOLDS.min_swing_deg,
                          files=tuple(rest_files), **per_run)
    return Thresholds(accel_floor=floor, min_swing_deg=float(np.floor(SWING_MARGIN * min(swings))),
                      swings_deg=tuple(swings), swing_files=tuple(swing_files),
                      files=tuple(sorted(set(rest_files) | set(swing_files) | set(change_files))), **per_run)


def fold_thresholds(data: FieldData, held_out: str) -> tuple[Thresholds, bool]:
    """The thresholds the train runs set with one of them held out, and whether the rest windows stay.

    The per-run measurements of :func:`train_thresholds` are kept and the
    held-out run's are dropped, so the floor, the least swing and the least
    turn are what the remaining train runs set. The measurements themselves
    were taken under the full floor; when the fold's floor finds the same rest
    window in every remaining train run (then the motion windows, the
    calibrations and every step signal are the same too), they are exactly
    the fold's own.

    Parameters
    ----------
    data : FieldData
        The dataset root; only its ``train`` folders are read.
    held_out : str
        The train recording to leave out (path relative to the root).

    Returns
    -------
    thresholds : Thresholds
        The fold's thresholds.
    same_windows : bool
        True when the fold's floor finds the same rest window in every
        remaining train run (the thresholds are then exactly the fold's own;
        otherwise the fold needs its own :class:`FieldData`).
    """
    th = data.thresholds
    floor = _floor_from([v for v, f in zip(th.rest_std, th.rest_files) if f != held_out])
    keep = lambda vals, files: ([v for v, f in zip(vals, files) if f != held_out],
                                [f for f in files if f != held_out])
    fold = _thresholds_from(floor, *keep(th.rest_std, th.rest_files), *keep(th.swings_deg, th.swing_files),
                            *keep(th.period_changes_deg, th.change_files))
    same = True
    if floor != th.accel_floor:
        for e in data.train_entries():
            if e.relpath == held_out:
                continue
            r = data._entry_recording(e)
            if r is not None and data.problem(r) is None:
                w, w0 = (_window_or_error(data, r, f) for f in (floor, data.accel_floor()))
                if isinstance(w, MorpiError) or isinstance(w0, MorpiError):
                    # without a rest window under either floor: the same only when neither has a rest
                    same = same and isinstance(w, NoRestError) and isinstance(w0, NoRestError)
                    continue
                same = same and (w.i0, w.i1) == (w0.i0, w0.i1)
    return fold, same


def _window_or_error(data: FieldData, rec, floor: float):
    """The recording's rest window under an accelerometer floor, or the detection's MorpiError."""
    try:
        return data.rest_window_at(rec, floor)
    except MorpiError as exc:
        return exc


def _train_period_changes(data: FieldData) -> tuple[list, list]:
    """Per train run and method, the largest absolute full-period heading change [deg], and the runs' paths."""
    cfg = _START.with_(segment="extrema", min_swing_deg=0.0)
    changes, files = [], []
    for m in MORPI_METHODS:
        for e in data.train_entries(periodic=True):
            for r in data.recordings(e.phone, e.route, e.split):
                if data.relpath(r) != e.relpath:
                    continue
                try:
                    s = data.steps(r, "GC", m, cfg)
                except MorpiError:
                    continue
                bt = s.peaks.grid_time[s.peaks.grid_index]
                c = st.period_changes(np.interp(bt, r.time, data.heading(r, "GC")), 2)
                if c.size:
                    changes.append(float(np.degrees(np.abs(c).max())))
                    files.append(e.relpath)
    return changes, files


# --------------------------------------------------------------------------- gain training and config search

def trained_gain(data: FieldData, phone, route, calibration, method, config) -> Gain | None:
    """The Weinberg gain of one route, phone, calibration and method, from its train recordings only.

    Parameters
    ----------
    data : FieldData
        The dataset root the train recordings are read from.
    phone, route : str
        Dataset folder names (``"s8"``, ``"short_distance"``).
    calibration : {"RD", "GC", "GAC"}
        Calibration applied to the recordings before step extraction.
    method : {"MoRPI-A", "MoRPI-G"}
        Signal the steps are found on.
    config : steps.StepConfig
        The step rule (for example ``select_config(data).config``).

    Returns
    -------
    Gain or None
        None when the folder has no train recordings or none with periodic motion;
        the recordings left out are named in :attr:`Gain.skipped`.
    """
    if not data.recordings(phone, route, "train"):
        return None
    group = data.entries(phone, route, "train")[0].group
    tset = next((s for s in data.train_sets() if s.name == group), None)
    if tset is None:
        return None
    return set_gain(data, tset, calibration, method, config, phone=phone, route=route,
                    skipped=data.load_errors(phone, route, "train"))


def set_gain(data: FieldData, train_set: TrainSet, calibration, method, config, *, phone: str = "", route: str = "",
             skipped=()) -> Gain | None:
    """The Weinberg gain of a train set's runs (:func:`morpi_filters.steps.train_gain`), each with its distance.

    Parameters
    ----------
    data : FieldData
        The dataset the runs are read from.
    train_set : TrainSet
        The runs and their true distances (:meth:`FieldData.train_sets`).
    calibration, method, config
        As for :func:`trained_gain`.
    phone, route : str
        The labels of the :class:`Gain`.
    skipped : iterable of str
        Lines naming runs left out before (they open :attr:`Gain.skipped`).

    Returns
    -------
    Gain or None
        None when no run has periodic motion under `config`; the runs left
        out are named in :attr:`Gain.skipped`.
    """
    weights, dists, files, skipped = [], [], [], list(skipped)
    for r, d in zip(train_set.runs, train_set.distance_m):
        try:
            weights.append(data.step_sums(r, calibration, method, config)[0])
            dists.append(d)
            files.append(data.relpath(r))
        except MorpiError as exc:
            skipped.append(str(exc))
    if not weights:
        return None
    mean, std, per = st.train_gain(weights, np.array(dists, dtype=float))
    return Gain(phone, route, method, calibration, mean, std, tuple(float(g) for g in per), tuple(files),
                tuple(skipped))


#: Coordinate search: first the readings (with the first tunables), then the tunables.
READING_GRID = {"heading": ("absolute", "mean", "turns"), "segment": st.SEGMENTS, "ends": st.ENDS}
#: The 3D attitude heading (more machinery than the z gyro: a whole 3D mechanization) is chosen only when
#: its train leave-one-out error is lower by more than this many standard errors of the paired
#: difference over the train runs: the "one-standard-error rule" of cross-validated model selection
#: (Hastie, Tibshirani and Friedman, The Elements of Statistical Learning, 2nd ed., section 7.10).
SOURCE_SE = 1.0
TUNABLE_GRID = {"cutoff_hz": (1.0, 2.0, 3.0), "prominence": (0.2, 0.35, 0.5), "min_period_s": (0.5, 1.0)}
_START = st.StepConfig(heading="absolute", segment="maxima", ends="drop", cutoff_hz=2.0, prominence=0.35,
                       min_period_s=0.5)


def train_summary(data: FieldData, method, config, mode="GC"):
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
    mode : {"RD", "GC", "GAC"}
        Calibration.

    Returns
    -------
    tuple of tuple
        One ``(train_set, members, relpaths, g, u, loo, failed)`` per train set.
    """
    key = (method, config, mode)
    out = data._train_summaries.get(key)
    if out is None:
        out = []
        for tset in data.train_sets():
            recs, rels = tset.runs, tset.files
            g, u, failed = np.full(len(recs), np.nan), np.full((len(recs), 2), np.nan), set()
            for i, r in enumerate(recs):
                try:
                    w, ux, uy = data.step_sums(r, mode, method, config)[:3]
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
    (``_signal_kernel.loo_errors``), the gains summed in order (the numpy form
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
    m = _signal_kernel.compiled()["loo_errors"](g, u, keep, end, dist, out)
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


def held_out_errors(data: FieldData, method, config, mode="GC", exclude=frozenset(), held_out: str = "recording"
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
    method, config, mode
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
    summary = train_summary(data, method, config, mode)
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


def held_out_score(data: FieldData, method, config, mode="GC", exclude=frozenset(), held_out: str = "recording"
               ) -> tuple[float, int]:
    """Held-out mean end-point error [%] over the train runs not in `exclude` (:func:`held_out_errors`).

    Cached on `data` with the train summaries: the searches of one method, of the other and of both
    (:func:`select_config`) score many of the same rules.

    Parameters
    ----------
    data, method, config, mode, exclude, held_out
        As for :func:`held_out_errors`.

    Returns
    -------
    tuple of (float, int)
        The mean error [%] (infinite when no run scores) and the number of runs scored.
    """
    key = ("loo score", method, config, mode, exclude, held_out)
    out = data._train_summaries.get(key)
    if out is None:
        errs = held_out_errors(data, method, config, mode, exclude, held_out)
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
    start = _START.with_(min_swing_deg=th.min_swing_deg, turn_deg=th.turn_deg)
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
