"""The per-recording work of a dataset, computed once: :class:`FieldData`, and the check of a root's recordings
as the evaluation reads them (:func:`check_recordings`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import dataset as ds
from .. import steps as st
from ..calibration import NoRestError
from ..deprecation import renamed_keywords
from ..errors import DataError, MorpiError, ParameterError
from ..manifest.settings import INS_SPANS
from .entries import COURSE_M, TrainSet, entries_of, folder_of, given_rest_window, track_course
from .thresholds import Thresholds, train_accel_floor, train_thresholds


#: INS start that measures the tilt at rest instead of assuming a level phone (3D INS only).
LEVELED = "GC+level"
#: Where the MoRPI heading is integrated from: the motion onset (default) or the first sample.
HEADING_ORIGINS = ("motion", "start")
#: What the MoRPI heading is read from (the step rule's ``heading_source``): the integrated z gyro, or
#: the yaw of the attitude matrix of the 3D mechanization started level with the rest specific force
#: (the paper's equation).
HEADING_SOURCES = st.HEADING_SOURCES


class RecordingWork:
    """One recording's work for every method and study, done once and kept (:meth:`FieldData.work`).

    The part that does not depend on where the heading starts is shared by
    the instances that share a dataset's work (:meth:`FieldData.sharing`);
    the headings, the prepared signals that carry them and the steps are
    kept per heading origin (:attr:`by_heading`).

    Attributes
    ----------
    recording : Recording
        The samples.
    rest : dict
        Accelerometer floor [m/s^2] -> the initial rest window, or the
        detection's MorpiError.
    measures : object or None
        What the rest detection measures (:func:`morpi_filters.calibration.rest_measures`).
    problem : str or None or Ellipsis
        Why the recording cannot be evaluated (:meth:`FieldData.problem`); Ellipsis until asked.
    calibrated : dict
        ``"RD"``, ``"GC"``, ``"GAC"`` -> (calibrated Recording, Calibration).
    activity : tuple or None
        The motion window (start, end) [s].
    signals : dict
        The step signals resampled and filtered, before a heading is given to them.
    ins : dict
        ``(calibration, method, span)`` -> InsResult.
    by_heading : dict
        Heading origin -> dict of the headings, prepared signals and steps.
    """

    __slots__ = ("recording", "rest", "measures", "problem", "calibrated", "activity", "signals", "ins",
                 "by_heading")

    def __init__(self, recording):
        self.recording = recording
        self.rest, self.calibrated, self.signals, self.ins, self.by_heading = {}, {}, {}, {}, {}
        self.measures, self.problem, self.activity = None, ..., None

    def heading_work(self, origin: str) -> dict:
        """The work that depends on the heading's origin (``"motion"`` or ``"start"``)."""
        out = self.by_heading.get(origin)
        if out is None:
            out = self.by_heading.setdefault(origin, {})
        return out


class FieldData:
    """Lazy, cached access to a dataset: recordings, calibrations, INS runs, step signals.

    Every per-recording computation is done once, kept in the recording's
    :class:`RecordingWork` (:meth:`work`), and reused by all cells, the gain
    training and the config search. The dataset is a manifest's:
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
    ``latitude_deg`` (:func:`morpi_filters.calibration.normal_gravity`; the site's for the
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
        from ..manifest import Dataset

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
            from ..manifest import index_dataset
            from ..resources import morpi_manifest

            self.root = Path(root)
            if not self.root.is_dir():
                raise DataError(f"{self.root}: not a directory; expected a dataset root (the folder holding s6 and "
                                "s8)")
            index = index_dataset(morpi_manifest(), root=self.root)
        if index.latitude_deg is None:
            from ..units import G0

            self._g_local = G0
        else:
            from ..calibration import normal_gravity

            self._g_local = normal_gravity(index.latitude_deg)
        entries = entries_of(index)
        declared = getattr(index, "declared", ()) or tuple((r.group, r.split, r.motion) for r in index.recordings)
        #: the groups of the train sets (:meth:`train_sets`): (group, phone, route) in the manifest's order
        self._train_groups = tuple(dict.fromkeys((g, *folder_of(index.name, g, sp)[:2]) for g, sp, m in declared
                                                 if sp == "train" and m == "periodic"))
        #: per recording source, its manifest labels and truth (DatasetRecording), once loaded
        self._labels: dict = {}
        self._entries = [e for e in entries if include_test or e.split != "test"]
        self._by_folder: dict = {}
        for e in self._entries:
            self._by_folder.setdefault((e.phone, e.route, e.split), []).append(e)
        self._folder_recs: dict = {}
        self._rec: dict = {}
        #: per recording source, its RecordingWork
        self._work: dict = {}
        #: Per-recording results of the studies built on this data (keyed by the study), reused across cells.
        self.study_cache: dict = {}
        self._peaks: dict = {}
        self._canon: dict = {}
        self._train_summaries: dict = {}

    @classmethod
    def sharing(cls, other: "FieldData", *, heading_from: str | None = None,
                ins_span: str | None = None) -> "FieldData":
        """The same root and thresholds read another way, reusing `other`'s loaded work.

        The recordings and their :class:`RecordingWork` (rest windows,
        calibrations, motion windows, step signals, INS runs keyed by their
        span, and the headings and steps of each heading origin) and the
        peaks are shared with `other`; the train summaries and the studies'
        caches start afresh.

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
        new._train_summaries, new.study_cache = {}, {}
        return new

    def work(self, rec) -> RecordingWork:
        """The recording's :class:`RecordingWork`, made on first use."""
        out = self._work.get(rec.source)
        if out is None:
            out = self._work.setdefault(rec.source, RecordingWork(rec))
        return out

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
        w = self.work(rec)
        if w.problem is ...:
            try:
                self.rest_window(rec)
                w.problem = None
            except NoRestError:
                w.problem = None
            except MorpiError as exc:
                w.problem = str(exc)
        return w.problem

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
            self._accel_floor = train_accel_floor(self)[0]
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
        from ..manifest import RouteTruth

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
        from ..manifest import RouteTruth

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
        from ..calibration import rest_measures

        w = self.work(rec)
        if w.measures is None:
            w.measures = rest_measures(rec)
        return w.measures

    def rest_window_at(self, rec, accel_floor: float):
        """The initial rest window with another accelerometer floor [m/s^2], found once per floor.

        Raises the detection's MorpiError (the same one each time) when there is none.
        """
        from ..calibration import detect_rest

        cache = self.work(rec).rest
        if accel_floor not in cache:
            # a recording of no entry (one built in memory and passed in) has its rest detected
            rest = self._labels[rec.source].rest if rec.source in self._labels else "auto"
            try:
                if rest == "none":
                    raise NoRestError(f'{rec.source}: rest = "none": no rest window')
                cache[accel_floor] = (detect_rest(rec, accel_floor=accel_floor, measures=self.rest_measures(rec))
                                      if rest == "auto" else given_rest_window(rec, rest))
            except MorpiError as exc:
                cache[accel_floor] = exc.with_traceback(None)
        out = cache[accel_floor]
        if isinstance(out, MorpiError):
            raise out.with_traceback(None)
        return out

    def rest_specific_force(self, rec) -> np.ndarray:
        """Mean specific force over the initial rest window, body axes [m/s^2], shape (3,)."""
        w = self.rest_window(rec)
        return rec.f[w.i0:w.i1].mean(axis=0)

    @renamed_keywords(mode="calibration")
    def calibrated(self, rec, calibration: str):
        """(calibrated Recording, Calibration) for RD | GC | GAC."""
        from ..calibration import calibrate

        cache = self.work(rec).calibrated
        if calibration not in cache:
            if calibration == "RD":
                cal = calibrate(rec, calibration)
                cache[calibration] = (rec, cal)
            else:
                cal = calibrate(rec, calibration, window=self.rest_window(rec), g_local=self._g_local)
                cache[calibration] = (cal.apply(rec), cal)
        return cache[calibration]

    def rest_end(self, rec) -> float:
        """End time of the initial rest window [s]."""
        return float(self.rest_window(rec).end_s)

    @renamed_keywords(mode="calibration")
    def prepared(self, rec, calibration: str, method: str, cutoff_hz, source: str = "gyro", *,
                 grid_hz: float | None = st.GRID_HZ, min_height: float | None = None):
        """The recording's MoRPI signal resampled on the rule's grid and filtered
        (:func:`morpi_filters.steps.prepare_signal`), with the heading of `calibration` and `source`, cached.

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
        calibration : {"RD", "GC", "GAC"}
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
        work = self.work(rec)
        cache = work.heading_work(self.heading_from)
        key = ("prepared", calibration, method, cutoff_hz, source, grid_hz, offset_free)
        if key not in cache:
            shared_mode = "RD|GC" if calibration in ("RD", "GC") and offset_free else calibration
            skey = (shared_mode, method, cutoff_hz, grid_hz)
            shared = work.signals.get(skey)
            if shared is not None:
                from dataclasses import replace

                p = replace(shared, heading=self.heading(rec, calibration, source))
                p.__dict__["motion_index"] = shared.motion_index       # the same grid and motion
            else:
                crec, _ = self.calibrated(rec, calibration)
                p = work.signals[skey] = st.prepare_signal(
                    crec, method, cutoff_hz, motion=self.activity(rec), heading=self.heading(rec, calibration, source),
                    grid_hz=grid_hz)
            # the heading's integral is the same for every method and cut-off: computed once, then given
            # to each signal as its cached property
            ikey = ("heading integral", calibration, source)
            if ikey in cache:
                p.__dict__["heading_integral"] = cache[ikey]
            else:
                cache[ikey] = p.heading_integral
            cache[key] = p
        return cache[key]

    @renamed_keywords(mode="calibration")
    def heading(self, rec, calibration: str, source: str = "gyro") -> np.ndarray:
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
        cache = self.work(rec).heading_work(self.heading_from)
        key = ("heading", calibration, source)
        if key not in cache:
            crec, _ = self.calibrated(rec, calibration)
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
                from ..strapdown import attitude_heading

                part = attitude_heading(t[i0:i1], crec.f[i0:i1], crec.omega[i0:i1], self.rest_specific_force(rec))
            psi[i0:i1] = part
            psi[i1:] = part[-1]
            cache[key] = psi
        return cache[key]

    def _canonical(self, config):
        # one extraction serves every least swing (a check on the result) and, unless the heading follows
        # turns, every turn threshold (unused)
        canon = self._canon.get(config)
        if canon is None:
            canon = self._canon[config] = config.with_(
                min_swing_deg=0.0, turn_deg=config.turn_deg if config.heading == "turns" else st.StepConfig.turn_deg)
        return canon

    @renamed_keywords(mode="calibration")
    def step_sums(self, rec, calibration, method, config) -> st.StepSums:
        """:func:`morpi_filters.steps.step_sums` of a recording (:class:`~morpi_filters.steps.StepSums`), cached.

        What :meth:`steps` gives, reduced to what a gain and an end point need; raises as it does.
        """
        cache = self.work(rec).heading_work(self.heading_from)
        key = ("sums", calibration, method, config)
        out = cache.get(key)
        if out is None:
            canon = self._canonical(config)                    # the rules that differ only in a check share it
            ckey = ("sums", calibration, method, canon)
            out = cache.get(ckey)
            if out is None:
                try:
                    out = st.step_sums(self.prepared(rec, calibration, method, config.cutoff_hz, config.heading_source,
                                                     grid_hz=config.grid_hz, min_height=config.min_height),
                                       method, canon, peak_cache=self._peaks)
                except MorpiError as exc:
                    out = exc
                cache[ckey] = out
            cache[key] = out
        if isinstance(out, MorpiError):
            raise out
        st.require_swing(rec.source, method, out[3], config.min_swing_deg)
        return out

    @renamed_keywords(mode="calibration")
    def steps(self, rec, calibration, method, config):
        canon = self._canonical(config)
        cache = self.work(rec).heading_work(self.heading_from)
        key = ("steps", calibration, method, canon)
        if key not in cache:
            try:
                cache[key] = st.extract_steps(None, method, canon,
                                                    prepared=self.prepared(rec, calibration, method, config.cutoff_hz,
                                                                           config.heading_source,
                                                                           grid_hz=config.grid_hz,
                                                                           min_height=config.min_height),
                                                    peak_cache=self._peaks)
            except MorpiError as exc:
                cache[key] = exc
        out = cache[key]
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
        work = self.work(rec)
        if work.activity is None:
            try:
                w = self.rest_window(rec)
            except NoRestError:
                # no rest to take the gyro's level in: the motion is what exceeds a still IMU's spread (summed
                # over the axes, as the motion window sums it), from the first sample when it moves there
                from ..calibration import still_bound

                span = st.activity_span(rec.time, rec.omega, threshold=3.0 * still_bound(rec).gyro)
            else:
                span = st.activity_span(rec.time, rec.omega, rest=(w.start_s, w.end_s))
            work.activity = span
        return work.activity

    @renamed_keywords(mode="calibration")
    def ins(self, rec, calibration: str, method: str, span: str | None = None):
        """INS solution (InsResult) of a recording, 3D or 2D, over `span` (default: the instance's).

        `calibration` is RD, GAC (the paper's: level phone assumed) or :data:`LEVELED`
        (3D only: GC gyro, initial roll and pitch from the rest specific force).
        """
        span = span or self.ins_span
        cache = self.work(rec).ins
        key = (calibration, method, span)
        if key not in cache:
            from ..strapdown import ins2d, ins3d

            # the gravity the calibration assumed at rest (GAC leaves (0, 0, g) there)
            C0, g = None, self._g_local
            if calibration == LEVELED:
                # gyro zero-order calibration; the initial attitude from the rest specific force
                # instead of the level assumption (the accelerometer bias stays in, read as tilt)
                from ..strapdown import coarse_level

                crec, cal = self.calibrated(rec, "GC")
                f_rest = self.rest_specific_force(rec)
                C0, g = coarse_level(f_rest), float(np.linalg.norm(f_rest))
            else:
                crec, _ = self.calibrated(rec, calibration)
            if span == "motion":
                a, b = self.activity(rec)
                sl = slice(int(np.searchsorted(crec.time, a)), int(np.searchsorted(crec.time, b, side="right")))
            else:
                sl = slice(None)
            t, f, w = crec.time[sl], crec.f[sl], crec.omega[sl]
            if t.shape[0] < 2:
                raise DataError(f"{rec.source}: no motion found for the INS")
            if method == "INS-3D":
                cache[key] = ins3d(t, f, w, C0=C0, g=g)
            elif calibration == LEVELED:
                raise ParameterError(f"{rec.source}: the planar INS has no tilt to level; {LEVELED} is for INS-3D")
            else:
                cache[key] = ins2d(t, f, w)
        return cache[key]


    @renamed_keywords(mode="calibration")
    def tilt_leak(self, rec, calibration: str) -> tuple[float, float]:
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
        r3 = self.ins(rec, calibration, "INS-3D")
        s = np.clip(np.asarray(r3.C_bn)[:, 2, 0], -1.0, 1.0)
        a = self._g_local * s
        dt = np.diff(r3.time)
        v = np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)])
        return float(np.degrees(np.mean(np.arcsin(s)))), float(np.sum(0.5 * (v[1:] + v[:-1]) * dt))


def check_recordings(root) -> tuple[list[str], int, list[str]]:
    """Validate the recordings of a dataset root as the evaluation reads them (``morpi check --data``).

    The package's MoRPI manifest applied to the root, through
    :func:`morpi_filters.manifest.check_dataset` (the check of ``morpi check
    --dataset``, one line per problem, the same lines): each file its globs
    match is loaded and checked, and each glob that matches another number of
    files than its ``imu.count`` is named (a missing folder, missing runs; a
    dataset written by :func:`morpi_filters.synthetic.write_dataset` is held
    to the runs its ``manifest.json`` lists instead). Nothing else under the
    root is read or listed: a file or folder outside the manifest's patterns
    is ignored. For each file that loads, :meth:`FieldData.problem`: a
    recording too short to tell its motion from a disturbance is a problem
    too, so what passes is what the commands evaluate. A recording that moves
    from its first samples has no initial rest (:meth:`FieldData.no_rest`):
    it is evaluated under RD only, and named apart from the problems. A root
    where no pattern matches is one line, with a hint: the ``data/`` folder
    inside it when that holds the dataset, the CSV files directly in it.

    Parameters
    ----------
    root : str or Path
        The dataset root.

    Returns
    -------
    problems : list of str
        One line per bad file and per pattern that matches another number of files than expected.
    n_ok : int
        Number of files that load and can be evaluated (with or without a
        rest).
    no_rest : list of str
        One line per recording among them without an initial rest: why.

    Raises
    ------
    DataError
        `root` is not a directory.

    Examples
    --------
    Three recordings of 4 s: at rest; at rest, then turning from 3 s on, so
    that it ends before the turn can be told from a disturbance; and
    vibrating from its first sample (0.008 rad/s at 13 Hz, within the LSM6DSL's gyro noise the manifest's
    check allows), which has no rest.

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
    >>> shake = 0.008 * np.sin(2 * np.pi * 13.0 * t)[:, None]
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
    from ..manifest import check_dataset
    from ..resources import morpi_manifest
    from ..synthetic import written_counts

    data = FieldData(root)
    root = data.root
    usable = []

    def problem(item):
        data._labels[item.recording.source] = item        # its manifest labels (its rest) for the detection
        line = data.problem(item.recording)
        if line is None:
            usable.append(item.recording)
        return line

    found, n_ok = check_dataset(morpi_manifest(), root=root, counts=written_counts(root), usable=problem)
    problems = [str(p) for p in found]
    if not data.folders() and problems:                 # no recording: the line check_dataset gives, and a hint
        problems[-1] += _hint(root)
    return problems, n_ok, [line for line in map(data.no_rest, usable) if line is not None]


def missing_recordings(root) -> list[str]:
    """What :func:`check_recordings` says of the files a root lacks, without reading one.

    Parameters
    ----------
    root : str or Path
        The dataset root.

    Returns
    -------
    list of str
        One line per glob of the package's MoRPI manifest that matches another
        number of files under `root` than expected
        (:func:`morpi_filters.manifest.count_problems`, with the counts of
        :func:`check_recordings`); when none matches anything, the one line
        saying so, with its hint. Empty when every expected file is there.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "s6" / "L_line").mkdir(parents=True)
    >>> _ = (root / "s6" / "L_line" / "1.csv").write_text("")       # not read
    >>> lines = [line.split(": imu.file: ")[1].replace(str(root), "ROOT") for line in missing_recordings(root)]
    >>> len(lines), lines[0], lines[6]       # doctest: +NORMALIZE_WHITESPACE
    (11, "'s8/line_dataset/*.csv' matches no file: missing folder ROOT/s8/line_dataset, expected 24 file(s)
    (imu.count)", "'s6/L_line/*.csv' matches 1 file(s) under ROOT, expected 10 (imu.count)")
    """
    from ..manifest import check_dataset, count_problems
    from ..resources import morpi_manifest
    from ..synthetic import written_counts

    root, counts = Path(root), written_counts(root)
    if FieldData(root).folders():
        return [str(p) for p in count_problems(morpi_manifest(), root=root, counts=counts)]
    return [str(p) + _hint(root) for p in check_dataset(morpi_manifest(), root=root, counts=counts)[0]]


def _hint(root: Path) -> str:
    """Where the recordings may be, for a root where the manifest's patterns match no file: its ``data/``
    folder when that holds them, else the CSV files directly in the root (no other folder is listed)."""
    inner = root / "data"
    if inner.is_dir() and FieldData(inner).folders():
        return f"; {inner} looks like the dataset root, pass --data {inner}"
    loose = [p for p in root.glob("*.csv") if p.is_file()]
    return ((f"; {len(loose)} CSV file(s) directly in {root}, none where the manifest looks" if loose else "")
            + f"; {ds.missing_data_message()}")
