"""Dataset manifests (format version 1): a researcher's own recordings, loaded, converted and checked.

A manifest is a TOML file that describes recordings made with any robot and
IMU: where each file lies, how its columns are named, its rate, units and
axes, and its ground truth (an end point as the MoRPI routes give, or a
truth track). :func:`load_dataset` reads it into a :class:`Dataset` whose
recordings are in the package's frame and units (body axes x forward, y
left, z up; s, m/s^2, rad/s); :func:`check_dataset` reports every problem,
one line each (``morpi check --dataset FILE``). ``docs/manifest.md`` is the
reference of the format, key by key.

Layout of a manifest::

    format_version = 1
    name = "my robot"
    [defaults]            # keys every recording inherits (its own keys win, one by one)
    imu.rate_hz = 200.0
    [[recording]]         # one table per recording
    id = "run1"
    imu.file = "imu/run1.csv"
    truth = { kind = "route", distance_m = 6.3, end_point_m = [6.3, 0.0] }

Relative file names start at the manifest's folder, or at a ``root`` given
when it is read, so one manifest describes every copy of a dataset (the
package's MoRPI manifest, :func:`morpi_filters.resources.morpi_manifest`); an
``imu.file`` holding a glob pattern makes one recording of each file it
matches, its id the file's relative path. :func:`index_dataset` lists the
recordings with their labels without reading a file. ``latitude_deg`` sets
the gravity the calibrations take; ``imu.spec`` may name an IMU the package
knows.

Truth tracks are stored in a local ENU frame (x east, y north, z up: right
handed and z up like the package's navigation frame, from which it differs
by a rotation about z and the origin), whatever the file's frame (NED or
ENU), on the IMU file's clock in seconds: the truth time of the IMU file's
first sample is 0, and the truth file's first sample is at ``offset_s``.

Checks, each one line naming the manifest, the recording and the key (and
the data file and line where there is one): a manifest that is not TOML,
a format version other than 1, unknown keys (with the nearest known one),
wrong types, unknown units, frames or axes, left-handed or repeated axes,
duplicate ids, missing files, ``rate_hz`` missing without a time column or
disagreeing with it raise :class:`~morpi_filters.errors.ParameterError`
(exit 2); a file that does not load (every check of
:func:`~morpi_filters.dataset.read_columns` on the values converted to SI:
time increasing, gaps, limits) or a truth track shorter than its recording
raise :class:`~morpi_filters.errors.DataError` (exit 1). After conversion the
recording must pass :func:`~morpi_filters.dataset.rest_problems`, the checks
the MoRPI catalogue applies, with the IMU's error figures (``imu.spec``, else
:data:`~morpi_filters.dataset.MEMS_SPEC`) and the recording's ``rest``:
gravity up the body z axis, gyro offsets and noise at rest, the turns'
rates; otherwise a ParameterError names the key to fix (``accel_unit``,
``axes``, ``gyro_unit`` or ``columns``), and a dead channel is a DataError
naming ``imu.file``.
"""
from __future__ import annotations

import difflib
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .dataset import (
    COLUMNS, MAX_GAP_S, MEMS_SPEC, MIN_SAMPLES, ColumnLayout, Recording, check_recording, read_columns, rest_problems,
)
from .errors import DataError, MorpiError, ParameterError
from .units import DEG, DEG_S, DEG_S_SQRT_HZ, G0, MG, SENSORS, UG_SQRT_HZ, SensorSpec

__all__ = [
    "FORMAT_VERSION", "TIME_UNITS", "ACCEL_UNITS", "GYRO_UNITS", "SPEC_KEYS", "RATE_TOLERANCE", "RouteTruth",
    "TruthTrack",
    "DatasetRecording", "Dataset", "IndexedRecording", "DatasetIndex", "index_dataset", "load_dataset", "check_dataset",
    "GLOB_CHARS",
]

#: The manifest format this module reads.
FORMAT_VERSION = 1
#: File time units, as units per second (the file's time is divided by it).
TIME_UNITS = {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9}
#: Accelerometer units, as m/s^2 per unit (1 g is standard gravity, :data:`morpi_filters.units.G0`).
ACCEL_UNITS = {"m/s^2": 1.0, "g": G0}
#: Gyro units, as rad/s per unit.
GYRO_UNITS = {"rad/s": 1.0, "deg/s": DEG}
#: Keys of the optional ``imu.spec`` table: the IMU's datasheet error figures, in the units a datasheet
#: prints (those of :meth:`~morpi_filters.units.SensorSpec.from_datasheet`), each to SI; a key left out
#: keeps the figure of :data:`~morpi_filters.dataset.MEMS_SPEC`.
SPEC_KEYS = {"gyro_bias_deg_s": ("gyro_bias", DEG_S), "gyro_noise_deg_s_sqrt_hz": ("gyro_noise", DEG_S_SQRT_HZ),
             "accel_bias_mg": ("accel_bias", MG), "accel_noise_ug_sqrt_hz": ("accel_noise", UG_SQRT_HZ)}
#: Largest relative difference between a declared ``rate_hz`` and the median rate of a time column.
RATE_TOLERANCE = 0.05
#: An ``imu.file`` holding one of these characters is a glob pattern: one recording per file it matches.
GLOB_CHARS = "*?["

_SPLITS = ("train", "test", "none")
_MOTIONS = ("periodic", "straight")
_INITIALS = ("rest", "truth")
_FRAMES = ("NED", "ENU")
_FRAME_LETTERS = {"NED": ("n", "e", "d"), "ENU": ("e", "n", "u")}
_TOP_KEYS = ("format_version", "name", "description", "latitude_deg", "defaults", "recording")
_RECORDING_KEYS = ("id", "split", "group", "motion", "rest", "initial", "notes", "imu", "truth")
_IMU_KEYS = ("file", "format", "columns", "skip_rows", "rate_hz", "time_unit", "time_origin", "accel_unit",
             "gyro_unit", "axes", "spec")
_ROUTE_KEYS = ("kind", "distance_m", "end_point_m", "polyline_m")
_TRACK_KEYS = ("kind", "file", "format", "columns", "skip_rows", "rate_hz", "time_unit", "frame", "offset_s")
_TRUTH_KEYS = tuple(dict.fromkeys(_ROUTE_KEYS + _TRACK_KEYS))
_DEFAULTS = {"split": "none", "group": "all", "motion": "periodic", "rest": "auto", "initial": "rest", "notes": ""}


# --------------------------------------------------------------------------- truth

@dataclass(frozen=True, eq=False)
class RouteTruth:
    """End-point truth of a recording, as the MoRPI routes give (``data/routes.json``).

    The route's frame has its origin at the start point, x along the body's
    heading at the start, y to the left (z up): the package's navigation frame.

    Attributes
    ----------
    distance_m : float
        Travelled distance along the route [m].
    end_point_m : ndarray, shape (2,)
        True end point [m].
    polyline_m : ndarray, shape (k, 2), or None
        The route's centre line from the origin to the end point [m], when known.

    Examples
    --------
    >>> truth = RouteTruth(distance_m=28.0, end_point_m=np.array([18.0, -10.0]))
    >>> truth.polyline.tolist()
    [[0.0, 0.0], [18.0, -10.0]]
    """

    distance_m: float
    end_point_m: np.ndarray
    polyline_m: np.ndarray | None = None

    def __post_init__(self):
        end = np.asarray(self.end_point_m, dtype=float)
        if end.shape != (2,) or not np.isfinite(end).all():
            raise ParameterError(f"RouteTruth: end_point_m of shape {end.shape}, expected two finite numbers [x, y]")
        if not (isinstance(self.distance_m, (int, float)) and math.isfinite(self.distance_m) and self.distance_m > 0):
            raise ParameterError(f"RouteTruth: distance_m {self.distance_m!r}, expected a finite number > 0")
        object.__setattr__(self, "end_point_m", end)
        if self.polyline_m is not None:
            line = np.asarray(self.polyline_m, dtype=float)
            if line.ndim != 2 or line.shape[1] != 2 or line.shape[0] < 2 or not np.isfinite(line).all():
                raise ParameterError(f"RouteTruth: polyline_m of shape {line.shape}, expected (k >= 2, 2) finite "
                                     "points")
            object.__setattr__(self, "polyline_m", line)

    @property
    def polyline(self) -> np.ndarray:
        """The centre line [m], shape (k, 2): `polyline_m`, or the straight line to the end point."""
        return self.polyline_m if self.polyline_m is not None else np.array([[0.0, 0.0], list(self.end_point_m)])


@dataclass(frozen=True, eq=False)
class TruthTrack:
    """A truth track: positions over time, in a local ENU frame on the IMU's clock.

    Attributes
    ----------
    time : ndarray, shape (m,)
        Times [s] on the clock of the recording's :attr:`Recording.time`,
        strictly increasing.
    position : ndarray, shape (m, 3)
        Positions [m] in a local ENU frame: x east, y north, z up (from a
        NED file: x = e, y = n, z = -d); the origin is the truth file's.
    source_frame : str
        The frame letters of the file it came from (``"NED"`` or ``"ENU"``).
    source : str
        The file it came from (or a label).

    Examples
    --------
    >>> track = TruthTrack(time=np.array([0.0, 1.0, 2.0]), position=np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.0]]))
    >>> track.frame, track.at([0.5, 1.5]).tolist()
    ('ENU', [[0.5, 0.0, 0.0], [1.0, 0.5, 0.0]])
    """

    time: np.ndarray
    position: np.ndarray
    source_frame: str = "ENU"
    source: str = "<memory>"

    def __post_init__(self):
        t = np.asarray(self.time, dtype=float)
        p = np.asarray(self.position, dtype=float)
        if t.ndim != 1 or p.shape != (t.shape[0], 3) or t.shape[0] < 2:
            raise DataError(f"{self.source}: truth track of time {t.shape} and position {p.shape}, expected (m,) "
                            "and (m, 3) with m >= 2")
        if not (np.isfinite(t).all() and np.isfinite(p).all()):
            raise DataError(f"{self.source}: truth track holds a value that is not finite")
        if not (np.diff(t) > 0).all():
            raise DataError(f"{self.source}: truth track time not strictly increasing")
        if self.source_frame not in _FRAMES:
            raise ParameterError(f"{self.source}: source_frame {self.source_frame!r}, expected 'NED' or 'ENU'")
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "position", p)

    @property
    def frame(self) -> str:
        """The frame of :attr:`position`: always ``"ENU"``."""
        return "ENU"

    @property
    def interval(self) -> float:
        """Median time between two truth samples [s]."""
        return float(np.median(np.diff(self.time)))

    def at(self, time) -> np.ndarray:
        """Positions at other times, linearly interpolated (held at the ends) [m], shape (k, 3).

        Parameters
        ----------
        time : array_like, shape (k,)
            Times on the track's clock [s].

        Returns
        -------
        ndarray, shape (k, 3)
            ENU positions.
        """
        t = np.asarray(time, dtype=float)
        return np.stack([np.interp(t, self.time, self.position[:, j]) for j in range(3)], axis=-1)


# --------------------------------------------------------------------------- dataset

@dataclass(frozen=True, eq=False)
class DatasetRecording:
    """One recording of a dataset, converted, with its labels and truth.

    Attributes
    ----------
    id : str
        Unique name within the dataset.
    recording : Recording
        The samples in body axes x forward, y left, z up, in s, m/s^2 and
        rad/s; time on the IMU file's clock (from its first sample with
        ``time_origin = "first"``, from 0 without a time column).
    truth : RouteTruth or TruthTrack
        End point (and route), or a truth track.
    split : str
        ``"train"``, ``"test"`` or ``"none"``.
    group : str
        Results are averaged per group.
    motion : str
        ``"periodic"`` or ``"straight"``.
    rest : str or tuple of float
        ``"auto"`` (detect the initial rest), ``"none"`` (the recording
        starts moving) or ``(t0, t1)``: the rest window in seconds from the
        first sample.
    initial : str
        ``"rest"``: starts standing, velocity zero; ``"truth"``: position,
        velocity and heading from the truth track at its start.
    notes : str
        Free text.
    """

    id: str
    recording: Recording
    truth: RouteTruth | TruthTrack
    split: str = "none"
    group: str = "all"
    motion: str = "periodic"
    rest: str | tuple = "auto"
    initial: str = "rest"
    notes: str = ""


@dataclass(frozen=True, eq=False)
class Dataset:
    """Recordings described by a manifest (or built in memory), converted and checked.

    Attributes
    ----------
    name : str
        The dataset's name.
    recordings : tuple of DatasetRecording
        In the manifest's order; ids unique.
    source : str
        The manifest file, or ``"<memory>"``.
    description : str
        Free text.
    latitude_deg : float or None
        The recordings' latitude [deg]: the calibrations and the 3D INS take
        the normal gravity there
        (:func:`morpi_filters.calibration.normal_gravity`); None: standard
        gravity :data:`morpi_filters.units.G0`.

    Examples
    --------
    >>> t = np.arange(300) / 100.0
    >>> still = {"time": t, "f": np.tile([0.0, 0.0, 9.81], (300, 1)), "omega": np.zeros((300, 3)),
    ...          "truth": RouteTruth(distance_m=1.0, end_point_m=np.array([1.0, 0.0]))}
    >>> ds = Dataset.from_arrays("bench", [dict(still, id="a", group="g1"), dict(still, id="b", split="train")])
    >>> [r.id for r in ds.recordings], sorted(ds.groups()), ds["b"].split
    (['a', 'b'], ['all', 'g1'], 'train')
    """

    name: str
    recordings: tuple
    source: str = "<memory>"
    description: str = ""
    latitude_deg: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "recordings", tuple(self.recordings))
        if self.latitude_deg is not None:
            try:
                object.__setattr__(self, "latitude_deg", _latitude(self.latitude_deg))
            except _Bad as bad:
                raise ParameterError(f"{self.source}: latitude_deg: {bad}") from None
        seen = set()
        for r in self.recordings:
            if r.id in seen:
                raise ParameterError(f"{self.source}: recording id {r.id!r} appears twice, expected unique ids")
            seen.add(r.id)

    def __getitem__(self, rec_id: str) -> DatasetRecording:
        for r in self.recordings:
            if r.id == rec_id:
                return r
        raise KeyError(rec_id)

    def __len__(self) -> int:
        return len(self.recordings)

    def groups(self) -> dict:
        """The recordings by group.

        Returns
        -------
        dict of str -> tuple of DatasetRecording
            In the order groups first appear.
        """
        out: dict = {}
        for r in self.recordings:
            out.setdefault(r.group, []).append(r)
        return {k: tuple(v) for k, v in out.items()}

    @classmethod
    def from_arrays(cls, name: str, recordings, *, description: str = "", latitude_deg: float | None = None
                    ) -> "Dataset":
        """A dataset from arrays in memory, with the checks of a manifest's recordings.

        Parameters
        ----------
        name : str
            The dataset's name.
        recordings : iterable of dict
            One mapping per recording with ``id``, ``time`` [s], ``f``
            [m/s^2] and ``omega`` [rad/s] in body axes x forward, y left,
            z up, ``truth`` (a :class:`RouteTruth` or :class:`TruthTrack`,
            the track on the same clock as ``time``), and optionally
            ``split``, ``group``, ``motion``, ``rest``, ``initial`` and
            ``notes`` with the meanings and defaults of the manifest keys.
        description : str, optional
            Free text.
        latitude_deg : float, optional
            The recordings' latitude [deg] (the manifest key ``latitude_deg``);
            default: standard gravity.

        Returns
        -------
        Dataset
            ``source`` ``"<memory>"``.

        Raises
        ------
        ParameterError
            An unknown or missing key, a bad value, a duplicate id, or a
            reading that does not show gravity up the z axis.
        DataError
            Arrays beyond the loader's limits (time not increasing, gaps,
            full scales), a dead channel, or a truth track shorter than the
            recording.
        """
        try:
            name = _text(name)
        except _Bad as bad:
            raise ParameterError(f"<memory>: name: {bad}") from None
        out = []
        known = ("id", "time", "f", "omega", "truth") + tuple(_DEFAULTS)
        for k, item in enumerate(recordings):
            where = f"<memory>: recordings[{k}]"
            unknown = [key for key in item if key not in known]
            if unknown:
                raise ParameterError(f"{where}: {_unknown(unknown[0], known)}")
            missing = [key for key in ("id", "time", "f", "omega", "truth") if key not in item]
            if missing:
                raise ParameterError(f"{where}: missing {', '.join(missing)}")
            labels = {}
            for key, default in _DEFAULTS.items():
                try:
                    labels[key] = _LABEL_CHECKS[key](item.get(key, default))
                except _Bad as bad:
                    raise ParameterError(f"{where}.{key}: {bad}") from None
            try:
                rec_id = _text(item["id"])
            except _Bad as bad:
                raise ParameterError(f"{where}.id: {bad}") from None
            truth = item["truth"]
            if not isinstance(truth, (RouteTruth, TruthTrack)):
                raise ParameterError(f"{where}.truth: {type(truth).__name__}, expected a RouteTruth or TruthTrack")
            rec = Recording(time=np.asarray(item["time"], dtype=float), f=np.asarray(item["f"], dtype=float),
                            omega=np.asarray(item["omega"], dtype=float), source=f"<memory>:{rec_id}",
                            split=None if labels["split"] == "none" else labels["split"], label=rec_id)
            check_recording(rec)
            ctx = _Context(where, {})
            _check_labels(ctx, rec, truth, labels)
            _check_physics(ctx, rec, labels["rest"], {"accel_unit": "m/s^2", "gyro_unit": "rad/s", "axes": "FLU"},
                           MEMS_SPEC)
            out.append(DatasetRecording(id=rec_id, recording=rec, truth=truth, **labels))
        return cls(name=name, recordings=tuple(out), description=description, latitude_deg=latitude_deg)


# --------------------------------------------------------------------------- values

class _Bad(Exception):
    """A value outside what a key accepts (the message says what was expected)."""


def _kind(v) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array",
            dict: "a table"}.get(type(v), type(v).__name__)


def _nearest(word: str, known, cutoff: float = 0.0):
    """The known word nearest to `word` (case aside; none below `cutoff`, difflib's similarity ratio), or None."""
    lowered = {str(k).lower(): k for k in known}
    near = difflib.get_close_matches(str(word).lower(), list(lowered), n=1, cutoff=cutoff)
    return lowered[near[0]] if near else None


def _unknown(key: str, known) -> str:
    near = _nearest(key, known)
    return f"unknown key {key!r}" + (f", the nearest known one is {near!r}" if near else "")


def _text(v) -> str:
    if not isinstance(v, str):
        raise _Bad(f"{_kind(v)} {v!r}, expected a string")
    if not v.strip():
        raise _Bad("an empty string, expected a name")
    return v


def _free_text(v) -> str:
    if not isinstance(v, str):
        raise _Bad(f"{_kind(v)} {v!r}, expected a string")
    return v


def _choice(options):
    def check(v):
        if not isinstance(v, str):
            raise _Bad(f"{_kind(v)} {v!r}, expected one of {', '.join(repr(o) for o in options)}")
        if v not in options:
            near = _nearest(v, options, cutoff=0.6)
            raise _Bad(f"{v!r} is not one of {', '.join(repr(o) for o in options)}"
                       + (f" (nearest: {near!r})" if near else ""))
        return v
    return check


def _integer(lowest: int):
    def check(v):
        if isinstance(v, bool) or not isinstance(v, int):
            raise _Bad(f"{_kind(v)} {v!r}, expected a whole number >= {lowest}")
        if v < lowest:
            raise _Bad(f"{v} is below {lowest}")
        return v
    return check


def _number(v, *, lowest=None, above=None) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _Bad(f"{_kind(v)} {v!r}, expected a number")
    v = float(v)
    if not math.isfinite(v):
        raise _Bad(f"{v!r}, expected a finite number")
    if lowest is not None and v < lowest:
        raise _Bad(f"{v!r}, expected at least {lowest:g}")
    if above is not None and v <= above:
        raise _Bad(f"{v!r}, expected a number above {above:g}")
    return v


def _rate(v) -> float:
    # one sample per MAX_GAP_S at least: a slower file breaks the loader's gap bound anyway
    return _number(v, lowest=1.0 / MAX_GAP_S)


def _rest(v):
    if isinstance(v, str):
        if v in ("auto", "none"):
            return v
        raise _Bad(f"{v!r}, expected 'auto', 'none' or [t0, t1] in seconds from the first sample")
    if not isinstance(v, list) or len(v) != 2:
        raise _Bad(f"{_kind(v)} {v!r}, expected 'auto', 'none' or [t0, t1] in seconds from the first sample")
    t0, t1 = (_number(x, lowest=0.0) for x in v)
    if not t1 > t0:
        raise _Bad(f"[{t0:g}, {t1:g}] is empty, expected t0 < t1")
    return (t0, t1)


def _point(v) -> np.ndarray:
    if not isinstance(v, list) or len(v) != 2:
        raise _Bad(f"{_kind(v)} {v!r}, expected [x, y] in metres (two numbers)")
    return np.array([_number(x) for x in v])


def _polyline(v) -> np.ndarray:
    if not isinstance(v, list) or len(v) < 2:
        raise _Bad(f"{_kind(v)} {v!r}, expected [[x, y], ...] with at least two points in metres")
    pts = []
    for k, p in enumerate(v):
        try:
            pts.append(_point(p))
        except _Bad as bad:
            raise _Bad(f"point {k}: {bad}") from None
    return np.array(pts)


def _axes(v):
    """The body axis and sign of each file axis: ``flu[:, i] = sign[i] * file[:, perm[i]]``."""
    if not isinstance(v, str) or len(v) != 3 or any(c not in "FBLRUD" for c in v):
        raise _Bad(f"{v!r}, expected three letters giving the file's x, y, z directions, each from F/B, L/R, "
                   "U/D, such as 'FLU' (x forward, y left, z up) or 'FRD'")
    axis = {"F": 0, "B": 0, "L": 1, "R": 1, "U": 2, "D": 2}
    sign = {"F": 1.0, "B": -1.0, "L": 1.0, "R": -1.0, "U": 1.0, "D": -1.0}
    body = [axis[c] for c in v]
    if sorted(body) != [0, 1, 2]:
        twice = [c for c in v if body.count(axis[c]) > 1]
        raise _Bad(f"{v!r} repeats an axis ({' and '.join(twice)} lie on one line), expected one letter each "
                   "from F/B, L/R and U/D")
    m = np.zeros((3, 3))
    for j, c in enumerate(v):
        m[axis[c], j] = sign[c]
    if np.linalg.det(m) < 0:
        raise _Bad(f"{v!r} is left-handed, expected a right-handed triple such as 'FLU', 'FRD', 'RFU' or 'LBU'")
    perm = tuple(body.index(i) for i in range(3))
    return perm, tuple(sign[v[perm[i]]] for i in range(3))


def _latitude(v) -> float:
    v = _number(v)
    if not -90.0 <= v <= 90.0:
        raise _Bad(f"{v!r}, expected a latitude in degrees from -90 to 90")
    return v


def _spec(v) -> SensorSpec:
    if isinstance(v, str):
        known = {s.name: s for s in SENSORS.values()}
        if v not in known:
            near = _nearest(v, known, cutoff=0.6)
            raise _Bad(f"{v!r} is not an IMU the package knows ({', '.join(repr(k) for k in known)})"
                       + (f" (nearest: {near!r})" if near else "") + ", expected one of them or a table of the "
                       f"IMU's datasheet figures: {', '.join(SPEC_KEYS)}")
        return known[v]
    if not isinstance(v, dict):
        raise _Bad(f"{_kind(v)} {v!r}, expected the name of an IMU the package knows or a table of the IMU's "
                   f"datasheet figures: {', '.join(SPEC_KEYS)}")
    figures = {}
    for key, x in v.items():
        if key not in SPEC_KEYS:
            raise _Bad(_unknown(key, SPEC_KEYS))
        try:
            attr, unit = SPEC_KEYS[key]
            figures[attr] = _number(x, lowest=0.0) * unit
        except _Bad as bad:
            raise _Bad(f"{key}: {bad}") from None
    base = {k: getattr(MEMS_SPEC, k) for k in ("gyro_bias", "gyro_noise", "accel_bias", "accel_noise")}
    return SensorSpec("imu.spec", "", **{**base, **figures})


def _columns_table(v):
    if not isinstance(v, dict):
        raise _Bad(f"{_kind(v)} {v!r}, expected a table of column names (CSV) or 0-based indices (npy)")
    for key, name in v.items():
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise _Bad(f"{key}: {_kind(name)} {name!r}, expected a header name or a 0-based column index")
    return v


_LABEL_CHECKS = {"split": _choice(_SPLITS), "group": _text, "motion": _choice(_MOTIONS), "rest": _rest,
                 "initial": _choice(_INITIALS), "notes": _free_text}
_IMU_CHECKS = {"file": _text, "format": _choice(("csv", "npy")), "columns": _columns_table,
               "skip_rows": _integer(0), "rate_hz": _rate, "time_unit": _choice(tuple(TIME_UNITS)),
               "time_origin": _choice(("clock", "first")), "accel_unit": _choice(tuple(ACCEL_UNITS)),
               "gyro_unit": _choice(tuple(GYRO_UNITS)), "axes": _axes, "spec": _spec}
_TRUTH_CHECKS = {"kind": _choice(("route", "track")), "distance_m": lambda v: _number(v, above=0.0),
                 "end_point_m": _point, "polyline_m": _polyline, "file": _text, "format": _choice(("csv", "npy")),
                 "columns": _columns_table, "skip_rows": _integer(0), "rate_hz": _rate,
                 "time_unit": _choice(tuple(TIME_UNITS)), "frame": _choice(_FRAMES), "offset_s": _number}


# --------------------------------------------------------------------------- reading the manifest

class _Context:
    """Where the values of one recording come from, to name them in messages."""

    def __init__(self, head: str, origin: dict, manifest: str = "", rec_id=None, base=None, table: int = 0):
        self.head, self.origin, self.manifest, self.id, self.table = head, origin, manifest, rec_id, table
        #: the folder relative file names start at (the manifest's, unless a root is given)
        self.base = Path(base) if base is not None else Path(manifest).parent

    def where(self, key: str) -> str:
        if self.origin.get(key) == "defaults":
            label = f" (recording {self.id!r})" if self.id else ""
            return f"{self.manifest}: [defaults] {key}{label}"
        return f"{self.head}: {key}" if key else self.head

    def bad(self, key: str, message: str, kind=ParameterError):
        return kind(f"{self.where(key)}: {message}")


@dataclass(frozen=True)
class _Manifest:
    path: Path
    name: str
    description: str
    entries: tuple        # (context, merged values or None, problem or None)
    latitude_deg: float | None = None
    base: Path | None = None
    empty: tuple = ()     # (context, values) of each glob table that matches no file


def _toml():
    if sys.version_info >= (3, 11):
        import tomllib
        return tomllib
    import tomli      # the same parser, for Python 3.10
    return tomli


def _read_manifest(path, root=None) -> _Manifest:
    path = Path(path).expanduser()
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ParameterError(f"{path}: no such file, expected a dataset manifest (TOML)") from None
    except IsADirectoryError:
        raise ParameterError(f"{path}: is a directory, expected a dataset manifest (TOML)") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not UTF-8 text, expected a dataset manifest (TOML)") from None
    toml = _toml()
    try:
        doc = toml.loads(text)
    except toml.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML: {' '.join(str(exc).split())}") from None
    for key in doc:
        if key not in _TOP_KEYS:
            raise ParameterError(f"{path}: {_unknown(key, _TOP_KEYS)}")
    version = doc.get("format_version")
    if version is None:
        raise ParameterError(f"{path}: format_version: missing, expected format_version = {FORMAT_VERSION}")
    if isinstance(version, bool) or not isinstance(version, int) or version != FORMAT_VERSION:
        raise ParameterError(f"{path}: format_version: {version!r} is not supported, expected {FORMAT_VERSION} "
                             "(the manifest format this version of morpi_filters reads)")
    try:
        name = _text(doc["name"]) if "name" in doc else None
        description = _free_text(doc.get("description", ""))
    except _Bad as bad:
        raise ParameterError(f"{path}: {'name' if 'name' in doc else 'description'}: {bad}") from None
    if name is None:
        raise ParameterError(f"{path}: name: missing, expected the dataset's name (a string)")
    try:
        latitude = _latitude(doc["latitude_deg"]) if "latitude_deg" in doc else None
    except _Bad as bad:
        raise ParameterError(f"{path}: latitude_deg: {bad}") from None
    base = path.parent if root is None else Path(root).expanduser()
    if not base.is_dir():
        raise ParameterError(f"{base}: not a directory, expected the folder the manifest's file names start at")
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ParameterError(f"{path}: defaults: {_kind(defaults)}, expected a table [defaults]")
    _check_defaults(path, defaults)
    tables = doc.get("recording")
    if tables is None:
        raise ParameterError(f"{path}: recording: missing, expected one [[recording]] table per recording")
    if isinstance(tables, dict):
        raise ParameterError(f"{path}: recording: one table [recording], expected [[recording]] tables (an array)")
    if not isinstance(tables, list) or not tables or not all(isinstance(t, dict) for t in tables):
        raise ParameterError(f"{path}: recording: {_kind(tables)}, expected [[recording]] tables")
    entries, first_of, empty = [], {}, []
    for k, table in enumerate(tables, start=1):
        rec_id = table.get("id") if isinstance(table.get("id"), str) else None
        head = f"{path}: [[recording]] {k}" + (f" (id {rec_id!r})" if rec_id else "")
        try:
            values, origin = _merge(head, defaults, table)
            ctx = _Context(head, origin, str(path), rec_id, base, k)
            expanded = _expand(ctx, values, k)
            if not expanded:
                empty.append((ctx, values))
            for ctx, values in expanded:
                rec_id = ctx.id
                if rec_id is not None and rec_id in first_of:
                    raise ctx.bad("id", f"{rec_id!r} is the id of [[recording]] {first_of[rec_id]} too, expected "
                                        "unique ids")
                if rec_id is not None:
                    first_of[rec_id] = k
                entries.append((ctx, values, None))
        except ParameterError as exc:
            entries.append((_Context(head, {}, str(path), rec_id, base), None, exc))
    return _Manifest(path=path, name=name, description=description, entries=tuple(entries), latitude_deg=latitude,
                     base=base, empty=tuple(empty))


def _is_glob(name) -> bool:
    return isinstance(name, str) and any(c in name for c in GLOB_CHARS)


def _natural(p: Path):
    """A file's place among the matches of a glob: by folder, then by the number its name is (``2.csv`` before
    ``10.csv``), then by name."""
    return (p.parent.parts, (0, int(p.stem), "") if p.stem.isdigit() else (1, 0, p.stem), p.name)


def _expand(ctx: _Context, values: dict, k: int) -> list:
    """A recording's (context, values), or one per file a glob ``imu.file`` matches (its id the file's path
    relative to the base folder), in the order of :func:`_natural`."""
    pattern = values.get("imu", {}).get("file") if isinstance(values.get("imu"), dict) else None
    if not _is_glob(pattern):
        return [(ctx, values)]
    if ctx.origin.get("id") == "recording":
        raise ctx.bad("id", "not used with a glob imu.file (each recording's id is the path of its file relative "
                            f"to {ctx.base}); remove it")
    truth = values.get("truth")
    if isinstance(truth, dict) and truth.get("kind") == "track":
        raise ctx.bad("truth.kind", "'track' with a glob imu.file: one truth file cannot serve every file it "
                                    "matches; expected 'route', or one [[recording]] per file")
    pat = Path(pattern).expanduser()
    start, rel_pattern = (Path(pat.anchor), str(pat.relative_to(pat.anchor))) if pat.is_absolute() else \
        (ctx.base, pattern)
    try:
        found = sorted((p for p in start.glob(rel_pattern) if p.is_file()), key=_natural)
    except (ValueError, OSError) as exc:
        raise ctx.bad("imu.file", f"{pattern!r} is not a glob pattern the package can read ({exc})") from None
    out = []
    for p in found:
        try:
            rel = p.relative_to(ctx.base).as_posix()
        except ValueError:
            rel = str(p)
        # one recording per file: what goes wrong with it names the file first, then the manifest's entry
        head = f"{p}: [[recording]] {k} of {ctx.manifest}"
        origin = dict(ctx.origin, id="recording")
        out.append((_Context(head, origin, ctx.manifest, rel, ctx.base, k),
                    {**values, "id": rel, "imu": {**values["imu"], "file": rel}}))
    return out


def _check_defaults(path: Path, defaults: dict) -> None:
    """Keys and context-free values of [defaults] (an error there would repeat for every recording)."""
    for key, v in defaults.items():
        where = f"{path}: [defaults] {key}"
        if key == "id":
            raise ParameterError(f"{where}: ids cannot have a default, expected one id in each [[recording]]")
        if key not in _RECORDING_KEYS:
            raise ParameterError(f"{path}: [defaults]: {_unknown(key, _RECORDING_KEYS[1:])}")
        if key in ("imu", "truth"):
            if not isinstance(v, dict):
                raise ParameterError(f"{where}: {_kind(v)}, expected a table")
            checks = _IMU_CHECKS if key == "imu" else _TRUTH_CHECKS
            for sub, sv in v.items():
                if sub not in checks:
                    raise ParameterError(f"{where}: {_unknown(sub, checks)}")
                try:
                    checks[sub](sv)
                except _Bad as bad:
                    raise ParameterError(f"{where}.{sub}: {bad}") from None
            continue
        try:
            _LABEL_CHECKS[key](v)
        except _Bad as bad:
            raise ParameterError(f"{where}: {bad}") from None


def _merge(head: str, defaults: dict, table: dict):
    """A recording's values over the defaults (sub-tables ``imu`` and ``truth`` key by key), and where
    each came from."""
    for key, v in table.items():
        if key not in _RECORDING_KEYS:
            raise ParameterError(f"{head}: {_unknown(key, _RECORDING_KEYS)}")
        if key in ("imu", "truth") and not isinstance(v, dict):
            raise ParameterError(f"{head}: {key}: {_kind(v)} {v!r}, expected a table")
        if key in ("imu", "truth"):
            known = _IMU_KEYS if key == "imu" else _TRUTH_KEYS
            for sub in v:
                if sub not in known:
                    raise ParameterError(f"{head}: {key}: {_unknown(sub, known)}")
    values, origin = {}, {}
    for source, t in (("defaults", defaults), ("recording", table)):
        for key, v in t.items():
            if key in ("imu", "truth"):
                sub = values.setdefault(key, {})
                for sk, sv in v.items():
                    sub[sk] = sv
                    origin[f"{key}.{sk}"] = source
            else:
                values[key] = v
                origin[key] = source
    return values, origin


# --------------------------------------------------------------------------- resolving one recording

def _get(ctx: _Context, table: dict, prefix: str, key: str, checks: dict, default=None, required=False):
    full = f"{prefix}.{key}" if prefix else key
    if key not in table:
        if required:
            raise ctx.bad(full, "missing")
        return None if default is None else checks[key](default)
    try:
        return checks[key](table[key])
    except _Bad as bad:
        raise ctx.bad(full, str(bad)) from None


def _not_used(ctx: _Context, table: dict, prefix: str, keys, why: str) -> None:
    """Refuse keys a recording sets that its other keys make meaningless (from [defaults] they are ignored)."""
    for key in keys:
        full = f"{prefix}.{key}"
        if key in table and ctx.origin.get(full) == "recording":
            raise ctx.bad(full, f"not used {why}; remove it")


def _file_of(ctx: _Context, table: dict, prefix: str) -> tuple[Path, str]:
    name = _get(ctx, table, prefix, "file", _IMU_CHECKS, required=True)
    path = Path(name).expanduser()
    if not path.is_absolute():
        path = ctx.base / path
    if not path.exists():
        where = "the manifest's folder" if ctx.base == Path(ctx.manifest).parent else f"{ctx.base}"
        raise ctx.bad(f"{prefix}.file", f"{path}: no such file (relative paths start at {where})")
    if path.is_dir():
        raise ctx.bad(f"{prefix}.file", f"{path}: is a directory, expected a file")
    fmt = table.get("format")
    if fmt is None:
        fmt = {".csv": "csv", ".npy": "npy"}.get(path.suffix.lower())
        if fmt is None:
            raise ctx.bad(f"{prefix}.format", f"missing, and {path.name} ends in neither .csv nor .npy; expected "
                                              "'csv' or 'npy'")
    else:
        fmt = _get(ctx, table, prefix, "format", _IMU_CHECKS)
    return path, fmt


def _column_names(ctx: _Context, table: dict, prefix: str, fmt: str, wanted, optional, default) -> dict:
    """The columns table of a file: every key known, the required ones present, names or indices by format."""
    full = f"{prefix}.columns"
    cols = _get(ctx, table, prefix, "columns", {"columns": _columns_table}, default=None)
    if cols is None:
        if default is None:
            raise ctx.bad(full, "missing, expected a table mapping " + ", ".join(wanted)
                          + (" (0-based indices)" if fmt == "npy" else " (header names)"))
        cols = default
    for key in cols:
        if key not in wanted:
            raise ctx.bad(full, _unknown(key, wanted))
    missing = [k for k in wanted if k not in cols and k not in optional]
    if missing:
        raise ctx.bad(full, f"missing {', '.join(missing)}")
    seen: dict = {}
    for key, name in cols.items():
        if fmt == "npy" and (isinstance(name, bool) or not isinstance(name, int) or name < 0):
            raise ctx.bad(f"{full}.{key}", f"{name!r}, expected a 0-based column index of the .npy array")
        if fmt == "csv" and (not isinstance(name, str) or not name.strip()):
            raise ctx.bad(f"{full}.{key}", f"{name!r}, expected a header name of the CSV file")
        if name in seen:
            raise ctx.bad(f"{full}.{key}", f"{name!r} is also {seen[name]}, expected one column each")
        seen[name] = key
    return cols


def _imu_layout(ctx: _Context, imu: dict) -> tuple[Path, ColumnLayout, dict]:
    path, fmt = _file_of(ctx, imu, "imu")
    cols = _column_names(ctx, imu, "imu", fmt, COLUMNS, ("time",), {c: c for c in COLUMNS} if fmt == "csv" else None)
    if fmt == "npy":
        _not_used(ctx, imu, "imu", ("skip_rows",), "by an .npy file")
    timed = "time" in cols
    rate = _get(ctx, imu, "imu", "rate_hz", _IMU_CHECKS)
    if not timed and rate is None:
        raise ctx.bad("imu.rate_hz", "missing, expected the sampling rate [Hz] of a file without a time column "
                                     "(columns.time)")
    if not timed:
        _not_used(ctx, imu, "imu", ("time_unit", "time_origin"), "without a time column")
    settings = {k: _get(ctx, imu, "imu", k, _IMU_CHECKS, default=d) for k, d in
                (("time_unit", "s"), ("time_origin", "clock"), ("accel_unit", "m/s^2"), ("gyro_unit", "rad/s"),
                 ("axes", "FLU"))}
    settings["axes_letters"] = imu.get("axes", "FLU")
    settings["imu"] = _get(ctx, imu, "imu", "spec", _IMU_CHECKS)          # the recording's IMU, when given
    settings["spec"] = settings["imu"] or MEMS_SPEC
    settings["rate_hz"] = rate
    layout = ColumnLayout(COLUMNS, tuple(cols.get(c) for c in COLUMNS), format=fmt,
                          skip_rows=_get(ctx, imu, "imu", "skip_rows", _IMU_CHECKS, default=0) if fmt == "csv" else 0,
                          time_per_s=TIME_UNITS[settings["time_unit"]],
                          factors=(ACCEL_UNITS[settings["accel_unit"]],) * 3 + (GYRO_UNITS[settings["gyro_unit"]],) * 3,
                          units=(settings["accel_unit"],) * 3 + (settings["gyro_unit"],) * 3,
                          rate_hz=None if timed else rate, time_from_first=settings["time_origin"] == "first")
    return path, layout, settings


def _read(ctx: _Context, key: str, path: Path, layout: ColumnLayout, min_rows: int) -> tuple:
    try:
        return read_columns(path, layout, min_rows=min_rows)
    except DataError as exc:
        raise ctx.bad(key, str(exc), DataError) from None


def _check_rate(ctx: _Context, key: str, declared, time: np.ndarray) -> None:
    if declared is None or time.shape[0] < 2:
        return
    median = 1.0 / float(np.median(np.diff(time)))
    if abs(median / declared - 1.0) > RATE_TOLERANCE:
        raise ctx.bad(key, f"{declared:g} Hz, but the time column gives {median:.6g} Hz (median), expected them "
                           f"within {RATE_TOLERANCE:.0%}: check rate_hz and time_unit")


def _load_entry(ctx: _Context, values: dict) -> DatasetRecording:
    """Resolve, read, convert and check one recording."""
    rec_id = _get(ctx, values, "", "id", {"id": _text}, required=True)
    labels = {k: _get(ctx, values, "", k, _LABEL_CHECKS, default=d) for k, d in _DEFAULTS.items()}
    if "imu" not in values:
        raise ctx.bad("imu", "missing, expected a table with at least imu.file")
    if "truth" not in values:
        raise ctx.bad("truth", "missing, expected a table with truth.kind = 'route' or 'track'")
    path, layout, settings = _imu_layout(ctx, values["imu"])
    time, f_file, w_file = _read(ctx, "imu.file", path, layout, MIN_SAMPLES)
    if layout.has_time:
        _check_rate(ctx, "imu.rate_hz", settings["rate_hz"], time)
    perm, sign = settings["axes"]
    if perm == (0, 1, 2) and sign == (1.0, 1.0, 1.0):
        f, omega = f_file, w_file
    else:       # a signed permutation: each value moves (and may change sign), exactly
        f = np.ascontiguousarray(np.stack([sign[i] * f_file[:, perm[i]] for i in range(3)], axis=-1))
        omega = np.ascontiguousarray(np.stack([sign[i] * w_file[:, perm[i]] for i in range(3)], axis=-1))
    rec = Recording(time=time, f=f, omega=omega, source=str(path),
                    split=None if labels["split"] == "none" else labels["split"], imu=settings["imu"], label=rec_id)
    truth = _truth(ctx, values["truth"], rec)
    _check_labels(ctx, rec, truth, labels)
    _check_physics(ctx, rec, labels["rest"], {"accel_unit": settings["accel_unit"], "gyro_unit": settings["gyro_unit"],
                                              "axes": settings["axes_letters"]},
                   settings["spec"])
    return DatasetRecording(id=rec_id, recording=rec, truth=truth, **labels)


def _truth(ctx: _Context, truth: dict, rec: Recording):
    kind = _get(ctx, truth, "truth", "kind", _TRUTH_CHECKS, required=True)
    if kind == "route":
        _not_used(ctx, truth, "truth", [k for k in _TRACK_KEYS if k != "kind"], "by kind = 'route'")
        distance = _get(ctx, truth, "truth", "distance_m", _TRUTH_CHECKS, required=True)
        end = _get(ctx, truth, "truth", "end_point_m", _TRUTH_CHECKS, required=True)
        line = _get(ctx, truth, "truth", "polyline_m", _TRUTH_CHECKS)
        if line is not None:
            if not np.allclose(line[0], 0.0, atol=1e-9, rtol=0.0):
                raise ctx.bad("truth.polyline_m", f"starts at {line[0].tolist()}, expected the start point [0, 0]")
            if not np.allclose(line[-1], end, atol=1e-6, rtol=0.0):
                raise ctx.bad("truth.polyline_m", f"ends at {line[-1].tolist()}, expected end_point_m "
                                                  f"{end.tolist()}")
        return RouteTruth(distance_m=distance, end_point_m=end, polyline_m=line)
    _not_used(ctx, truth, "truth", [k for k in _ROUTE_KEYS if k != "kind"], "by kind = 'track'")
    path, fmt = _file_of(ctx, truth, "truth")
    if fmt == "npy":
        _not_used(ctx, truth, "truth", ("skip_rows",), "by an .npy file")
    raw = truth.get("columns")
    frame = _get(ctx, truth, "truth", "frame", _TRUTH_CHECKS)
    letters = None
    if isinstance(raw, dict):
        keys = set(raw) - {"time"}
        if frame is not None and keys and keys <= set(_FRAME_LETTERS[frame]):
            letters = frame
        else:
            letters = next((fr for fr, ls in _FRAME_LETTERS.items() if keys and keys <= set(ls)), None)
    if isinstance(raw, dict) and set(raw) - {"time"} <= {"x", "y", "z"}:
        axes = ("x", "y", "z")
        if frame is None:
            raise ctx.bad("truth.frame", "missing, expected 'NED' or 'ENU' for columns x, y, z")
    else:
        if letters is None and isinstance(raw, dict):
            raise ctx.bad("truth.columns", "expected time (optional) and x, y, z, or the frame's letters: n, e, d "
                                           f"(NED) or e, n, u (ENU); got {', '.join(raw)}")
        frame = frame or letters
        if letters is not None and frame != letters:
            raise ctx.bad("truth.frame", f"{frame!r}, but columns name the {letters} axes "
                                         f"{', '.join(_FRAME_LETTERS[letters])}")
        axes = _FRAME_LETTERS[frame] if frame else ("x", "y", "z")
    cols = _column_names(ctx, truth, "truth", fmt, ("time",) + axes, ("time",), None)
    timed = "time" in cols
    rate = _get(ctx, truth, "truth", "rate_hz", _TRUTH_CHECKS)
    if not timed and rate is None:
        raise ctx.bad("truth.rate_hz", "missing, expected the truth's rate [Hz] for a file without a time column")
    if not timed:
        _not_used(ctx, truth, "truth", ("time_unit",), "without a time column")
    skip = _get(ctx, truth, "truth", "skip_rows", _TRUTH_CHECKS, default=0) if fmt == "csv" else 0
    per_s = TIME_UNITS[_get(ctx, truth, "truth", "time_unit", _TRUTH_CHECKS, default="s")]
    layout = ColumnLayout(("time",) + axes, tuple(cols.get(c) for c in ("time",) + axes), format=fmt,
                          skip_rows=skip, time_per_s=per_s, rate_hz=None if timed else rate, time_from_first=True)
    t, p = _read(ctx, "truth.file", path, layout, 2)
    if timed:
        _check_rate(ctx, "truth.rate_hz", rate, t)
    offset = _get(ctx, truth, "truth", "offset_s", _TRUTH_CHECKS, default=0.0)
    enu = p if frame == "ENU" else np.ascontiguousarray(np.stack([p[:, 1], p[:, 0], -p[:, 2]], axis=-1))
    try:
        track = TruthTrack(time=rec.time[0] + offset + t, position=enu, source_frame=frame, source=str(path))
    except MorpiError as exc:
        raise ctx.bad("truth.file", str(exc), DataError) from None
    return track


def _check_labels(ctx: _Context, rec: Recording, truth, labels: dict) -> None:
    """The truth covers the recording; the rest window lies inside it; ``initial = "truth"`` has a track."""
    if isinstance(truth, TruthTrack):
        tol = truth.interval
        if truth.time[0] > rec.time[0] + tol or truth.time[-1] < rec.time[-1] - tol:
            a, b = truth.time[0] - rec.time[0], truth.time[-1] - rec.time[0]
            raise ctx.bad("truth", f"the track covers {a:.6g} to {b:.6g} s from the recording's first sample, the "
                                   f"recording 0 to {rec.duration:.6g} s: truth shorter than the recording (one truth "
                                   "interval of slack at each end); check truth.offset_s", DataError)
    elif labels["initial"] == "truth":
        raise ctx.bad("initial", "'truth' needs a truth track (truth.kind = 'track'), expected 'rest' with a route")
    rest = labels["rest"]
    if isinstance(rest, tuple):
        if rest[1] > rec.duration:
            raise ctx.bad("rest", f"[{rest[0]:g}, {rest[1]:g}] ends after the recording ({rec.duration:.6g} s from "
                                  "its first sample), expected a window inside it")
        inside = (rec.time >= rec.time[0] + rest[0]) & (rec.time <= rec.time[0] + rest[1])
        if inside.sum() < 2:
            raise ctx.bad("rest", f"[{rest[0]:g}, {rest[1]:g}] holds {int(inside.sum())} sample(s), expected a "
                                  "window of several samples")


#: The manifest key each kind of :class:`~morpi_filters.dataset.RestProblem` names.
_PHYSICS_KEYS = {"accel_unit": "imu.accel_unit", "axes": "imu.axes", "gyro_unit": "imu.gyro_unit",
                 "columns": "imu.columns", "dead_channel": "imu.file"}


def _check_physics(ctx: _Context, rec: Recording, rest, declared: dict, spec: SensorSpec) -> None:
    """The first problem of :func:`~morpi_filters.dataset.rest_problems` after conversion, naming its key."""
    problems = rest_problems(rec, spec=spec, rest=rest)
    if not problems:
        return
    p = problems[0]
    key = _PHYSICS_KEYS[p.kind]
    where = "in the rest window" if isinstance(rest, tuple) else "at rest" if rest == "auto" else "over the recording"
    shown = "[" + ", ".join(f"{v:.3g}" for v in p.f_rest) + "] m/s^2"
    if p.kind in declared:
        check = f"check {p.kind} (declared {declared[p.kind]!r})"
    else:
        check = {"columns": "check columns (the f_* and g_* names)"}.get(p.kind)
    if p.cause in ("in_g", "no_gravity", "not_gravity"):
        line = (f"the median specific force {where} is {shown}, of magnitude {p.value:.3g} m/s^2 after conversion, "
                f"expected {G0:.2f} +- {p.bound:.2f} (gravity, three zero-g offsets of the IMU): {check}")
    elif p.cause == "z_down":
        line = (f"the median specific force {where} points down the body z axis ({shown} after conversion): looks "
                f"like z down: check `axes` (declared {declared['axes']!r}; 'FRD' is x forward, y right, z down)")
    elif p.cause == "across":
        line = (f"the median specific force {where} lies across the body z axis ({shown} after conversion), expected "
                f"gravity within 45 deg of up z: check `axes` (declared {declared['axes']!r})")
    elif p.cause == "rest_bias":
        line = (f"the median angular rate at rest is {p.value:.3g} rad/s on {p.column} after conversion "
                f"({p.value / DEG:.3g} deg/s), beyond three zero-rate offsets of the IMU ({p.bound:.2g} rad/s): "
                f"{check}")
    elif p.cause == "percentile":
        line = (f"1 % of the angular rates exceed {p.value:.3g} rad/s after conversion, beyond a ground robot's "
                f"turns ({p.bound:g} rad/s): {check}")
    else:        # the reading's own line (noise, swapped columns, a dead channel), with the file
        line = p.message + (f": {check}" if check else "")
    raise ctx.bad(key, line, DataError if p.kind == "dead_channel" else ParameterError)


# --------------------------------------------------------------------------- entry points

def load_dataset(path, *, root=None) -> Dataset:
    """Read a manifest and every recording it describes, converted and checked.

    Parameters
    ----------
    path : str or Path
        The manifest (TOML, format version 1; ``docs/manifest.md``).
    root : str or Path, optional
        The folder relative file names start at; default: the manifest's
        folder. One manifest describes every copy of a dataset this way (the
        package's MoRPI manifest, :func:`morpi_filters.resources.morpi_manifest`).

    Returns
    -------
    Dataset
        Every recording in the package's frame and units with its labels
        and truth, in the manifest's order.

    Raises
    ------
    ParameterError
        The first problem of the manifest (one line naming the file, the
        recording and the key), or of a reading that looks declared wrong
        (gravity not up the z axis at about 1 g, implausible rates).
    DataError
        The first file that does not load (naming the manifest, the key,
        the file and the line), a dead channel (naming ``imu.file``), or a
        truth track shorter than its recording.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> rows = "\\n".join(f"{k * 10}, 0, 0, 1, 0, 0, 0" for k in range(200))
    >>> _ = (root / "run1.csv").write_text("# logger v2\\nt_ms, ax, ay, az, gx, gy, gz\\n" + rows + "\\n")
    >>> _ = (root / "dataset.toml").write_text('''
    ... format_version = 1
    ... name = "bench"
    ... [defaults.imu]
    ... skip_rows = 1
    ... time_unit = "ms"
    ... accel_unit = "g"
    ... columns = { time = "t_ms", f_x = "ax", f_y = "ay", f_z = "az", g_x = "gx", g_y = "gy", g_z = "gz" }
    ... [[recording]]
    ... id = "run1"
    ... imu.file = "run1.csv"
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... ''')
    >>> ds = load_dataset(root / "dataset.toml")
    >>> rec = ds["run1"].recording
    >>> ds.name, rec.n, float(rec.time[1]), rec.f[0].tolist() == [0.0, 0.0, G0]     # 1 g is G0 m/s^2
    ('bench', 200, 0.01, True)
    """
    manifest = _read_manifest(path, root)
    out = []
    for ctx, values, problem in manifest.entries:
        if problem is not None:
            raise problem
        out.append(_load_entry(ctx, values))
    if not out:
        raise _no_match(manifest)
    return Dataset(name=manifest.name, recordings=tuple(out), source=str(manifest.path),
                   description=manifest.description, latitude_deg=manifest.latitude_deg)


def _no_match(manifest: _Manifest) -> ParameterError:
    return ParameterError(f"{manifest.path}: recording: the glob imu.file patterns match no file under "
                          f"{manifest.base}, expected at least one recording")


@dataclass(frozen=True, eq=False)
class IndexedRecording:
    """A manifest recording before its files are read: its labels and its IMU file (:func:`index_dataset`).

    Attributes
    ----------
    id, split, group, motion, rest, initial
        As in :class:`DatasetRecording`.
    file : Path
        The IMU file (not yet checked to exist).
    """

    id: str
    split: str
    group: str
    motion: str
    rest: object
    initial: str
    file: Path
    _ctx: object = field(default=None, repr=False)
    _values: dict = field(default=None, repr=False)

    def load(self) -> DatasetRecording:
        """Read, convert and check the recording as :func:`load_dataset` does.

        Returns
        -------
        DatasetRecording

        Raises
        ------
        ParameterError, DataError
            As :func:`load_dataset`, for this recording.
        """
        return _load_entry(self._ctx, self._values)


@dataclass(frozen=True, eq=False)
class DatasetIndex:
    """A manifest's recordings, labelled, none read yet (:func:`index_dataset`).

    Attributes
    ----------
    name, description, latitude_deg
        As in :class:`Dataset`.
    source : str
        The manifest file.
    root : Path
        The folder its relative file names start at.
    recordings : tuple of IndexedRecording
        In the manifest's order (the files of a glob in the order of their
        folders and numbers).
    declared : tuple of (str, str, str)
        ``(group, split, motion)`` of every ``[[recording]]`` table in order,
        a glob table's once, whether or not it matches a file.
    """

    name: str
    source: str
    root: Path
    recordings: tuple
    description: str = ""
    latitude_deg: float | None = None
    declared: tuple = ()


def index_dataset(path, *, root=None) -> DatasetIndex:
    """A manifest's recordings with their labels and files, without reading a file.

    What :func:`load_dataset` reads, one recording at a time
    (:meth:`IndexedRecording.load`): a caller that reads a few recordings,
    or keeps going past one that does not load, starts here. A glob that
    matches no file gives no recording (no error).

    Parameters
    ----------
    path : str or Path
        The manifest.
    root : str or Path, optional
        As for :func:`load_dataset`.

    Returns
    -------
    DatasetIndex

    Raises
    ------
    ParameterError
        The first problem of the manifest's keys and labels (one line naming
        the file, the recording and the key).

    Examples
    --------
    >>> from morpi_filters.resources import morpi_manifest
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for rel in ("s8/short_distance/train/10.csv", "s8/short_distance/train/2.csv", "s6/L_line/1.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     (root / rel).touch()
    >>> index = index_dataset(morpi_manifest(), root=root)
    >>> [(r.id, r.group, r.split, r.motion) for r in index.recordings]    # doctest: +NORMALIZE_WHITESPACE
    [('s8/short_distance/train/2.csv', 's8/short_distance', 'train', 'periodic'),
     ('s8/short_distance/train/10.csv', 's8/short_distance', 'train', 'periodic'),
     ('s6/L_line/1.csv', 's6/L_line', 'none', 'straight')]
    """
    manifest = _read_manifest(path, root)
    out, declared = [], {}
    for ctx, values in manifest.empty:
        labels = [_get(ctx, values, "", k, _LABEL_CHECKS, default=_DEFAULTS[k]) for k in ("group", "split", "motion")]
        declared[ctx.table] = tuple(labels)
    for ctx, values, problem in manifest.entries:
        if problem is not None:
            raise problem
        rec_id = _get(ctx, values, "", "id", {"id": _text}, required=True)
        labels = {k: _get(ctx, values, "", k, _LABEL_CHECKS, default=d) for k, d in _DEFAULTS.items()}
        imu = values.get("imu")
        if not isinstance(imu, dict) or "file" not in imu:
            raise ctx.bad("imu", "missing, expected a table with at least imu.file")
        name = Path(_get(ctx, imu, "imu", "file", _IMU_CHECKS, required=True)).expanduser()
        out.append(IndexedRecording(id=rec_id, file=name if name.is_absolute() else ctx.base / name,
                                    _ctx=ctx, _values=values, **{k: labels[k] for k in
                                                                 ("split", "group", "motion", "rest", "initial")}))
        declared[ctx.table] = (labels["group"], labels["split"], labels["motion"])
    order = sorted(declared)
    return DatasetIndex(name=manifest.name, source=str(manifest.path), root=manifest.base, recordings=tuple(out),
                        description=manifest.description, latitude_deg=manifest.latitude_deg,
                        declared=tuple(declared[k] for k in order))


def check_dataset(path, *, root=None) -> tuple[list, int]:
    """Load every recording of a manifest in turn and collect the problems, one per recording.

    Parameters
    ----------
    path : str or Path
        The manifest.
    root : str or Path, optional
        As for :func:`load_dataset`.

    Returns
    -------
    problems : list of MorpiError
        The first problem of each recording that does not load
        (:class:`ParameterError` for the manifest, :class:`DataError` for
        the data), each a one-line message.
    n_ok : int
        Number of recordings that loaded cleanly.

    Raises
    ------
    ParameterError
        A manifest that cannot be read at all (not TOML, a format version
        other than 1, an unknown top-level key, a bad [defaults] table).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (root / "dataset.toml").write_text('''
    ... format_version = 1
    ... name = "bench"
    ... [[recording]]
    ... id = "run1"
    ... imu = { file = "run1.csv", axes = "FRU" }
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... ''')
    >>> problems, n_ok = check_dataset(root / "dataset.toml")
    >>> n_ok, [str(p).replace(str(root), "ROOT") for p in problems]
    (0, ["ROOT/dataset.toml: [[recording]] 1 (id 'run1'): imu.file: ROOT/run1.csv: no such file (...)"])
    """
    manifest = _read_manifest(path, root)
    problems, n_ok = [], 0
    for ctx, values, problem in manifest.entries:
        if problem is None:
            try:
                _load_entry(ctx, values)
                n_ok += 1
                continue
            except MorpiError as exc:
                problem = exc
        problems.append(problem)
    if not manifest.entries:
        problems.append(_no_match(manifest))
    return problems, n_ok
