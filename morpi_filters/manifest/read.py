"""One recording of a manifest: its truth (a route or a truth track), its files read and converted to the body
frame and SI, and the checks after conversion."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dataset import COLUMNS, MEMS_SPEC, MIN_SAMPLES, ColumnLayout, Recording, read_columns, rest_problems
from ..errors import DataError, MorpiError, ParameterError
from ..units import DEG, G0, SensorSpec
from .schema import (ACCEL_UNITS, DEFAULTS, FRAME_LETTERS, FRAMES, GYRO_UNITS, IMU_CHECKS, LABEL_CHECKS,
                     RATE_TOLERANCE, ROUTE_KEYS, TIME_UNITS, TRACK_KEYS, TRUTH_CHECKS, Context, check_columns,
                     check_text, refuse_unused, unknown_key, value_of)


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
        if self.source_frame not in FRAMES:
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
    train_group : str or None
        The group whose train recordings set this recording's gains and the
        aided filter's tuning; None: its own group when that has train
        recordings, else every train group together.
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
    train_group: str | None = None
    notes: str = ""

# --------------------------------------------------------------------------- resolving one recording

def _file_of(ctx: Context, table: dict, prefix: str) -> tuple[Path, str]:
    name = value_of(ctx, table, prefix, "file", IMU_CHECKS, required=True)
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
        fmt = value_of(ctx, table, prefix, "format", IMU_CHECKS)
    return path, fmt


def _column_names(ctx: Context, table: dict, prefix: str, fmt: str, wanted, optional, default) -> dict:
    """The columns table of a file: every key known, the required ones present, names or indices by format."""
    full = f"{prefix}.columns"
    cols = value_of(ctx, table, prefix, "columns", {"columns": check_columns}, default=None)
    if cols is None:
        if default is None:
            raise ctx.bad(full, "missing, expected a table mapping " + ", ".join(wanted)
                          + (" (0-based indices)" if fmt == "npy" else " (header names)"))
        cols = default
    for key in cols:
        if key not in wanted:
            raise ctx.bad(full, unknown_key(key, wanted))
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


def _imu_layout(ctx: Context, imu: dict) -> tuple[Path, ColumnLayout, dict]:
    path, fmt = _file_of(ctx, imu, "imu")
    cols = _column_names(ctx, imu, "imu", fmt, COLUMNS, ("time",), {c: c for c in COLUMNS} if fmt == "csv" else None)
    if fmt == "npy":
        refuse_unused(ctx, imu, "imu", ("skip_rows",), "by an .npy file")
    timed = "time" in cols
    rate = value_of(ctx, imu, "imu", "rate_hz", IMU_CHECKS)
    if not timed and rate is None:
        raise ctx.bad("imu.rate_hz", "missing, expected the sampling rate [Hz] of a file without a time column "
                                     "(columns.time)")
    if not timed:
        refuse_unused(ctx, imu, "imu", ("time_unit", "time_origin"), "without a time column")
    settings = {k: value_of(ctx, imu, "imu", k, IMU_CHECKS, default=d) for k, d in
                (("time_unit", "s"), ("time_origin", "clock"), ("accel_unit", "m/s^2"), ("gyro_unit", "rad/s"),
                 ("axes", "FLU"))}
    settings["axes_letters"] = imu.get("axes", "FLU")
    settings["imu"] = value_of(ctx, imu, "imu", "spec", IMU_CHECKS)          # the recording's IMU, when given
    settings["spec"] = settings["imu"] or MEMS_SPEC
    settings["rate_hz"] = rate
    layout = ColumnLayout(COLUMNS, tuple(cols.get(c) for c in COLUMNS), format=fmt,
                          skip_rows=(value_of(ctx, imu, "imu", "skip_rows", IMU_CHECKS, default=0) if fmt == "csv"
                                     else 0),
                          time_per_s=TIME_UNITS[settings["time_unit"]],
                          factors=(ACCEL_UNITS[settings["accel_unit"]],) * 3 + (GYRO_UNITS[settings["gyro_unit"]],) * 3,
                          units=(settings["accel_unit"],) * 3 + (settings["gyro_unit"],) * 3,
                          rate_hz=None if timed else rate, time_from_first=settings["time_origin"] == "first")
    return path, layout, settings


def _read(ctx: Context, key: str, path: Path, layout: ColumnLayout, min_rows: int) -> tuple:
    try:
        return read_columns(path, layout, min_rows=min_rows)
    except DataError as exc:
        raise ctx.bad(key, str(exc), DataError) from None


def _check_rate(ctx: Context, key: str, declared, time: np.ndarray) -> None:
    if declared is None or time.shape[0] < 2:
        return
    median = 1.0 / float(np.median(np.diff(time)))
    if abs(median / declared - 1.0) > RATE_TOLERANCE:
        raise ctx.bad(key, f"{declared:g} Hz, but the time column gives {median:.6g} Hz (median), expected them "
                           f"within {RATE_TOLERANCE:.0%}: check rate_hz and time_unit")


def load_entry(ctx: Context, values: dict) -> DatasetRecording:
    """Resolve, read, convert and check one recording."""
    rec_id = value_of(ctx, values, "", "id", {"id": check_text}, required=True)
    labels = {k: value_of(ctx, values, "", k, LABEL_CHECKS, default=d) for k, d in DEFAULTS.items()}
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
    check_labels(ctx, rec, truth, labels)
    check_physics(ctx, rec, labels["rest"], {"accel_unit": settings["accel_unit"], "gyro_unit": settings["gyro_unit"],
                                             "axes": settings["axes_letters"]},
                  settings["spec"])
    return DatasetRecording(id=rec_id, recording=rec, truth=truth, **labels)


def _truth(ctx: Context, truth: dict, rec: Recording):
    kind = value_of(ctx, truth, "truth", "kind", TRUTH_CHECKS, required=True)
    if kind == "route":
        refuse_unused(ctx, truth, "truth", [k for k in TRACK_KEYS if k != "kind"], "by kind = 'route'")
        distance = value_of(ctx, truth, "truth", "distance_m", TRUTH_CHECKS, required=True)
        end = value_of(ctx, truth, "truth", "end_point_m", TRUTH_CHECKS, required=True)
        line = value_of(ctx, truth, "truth", "polyline_m", TRUTH_CHECKS)
        if line is not None:
            if not np.allclose(line[0], 0.0, atol=1e-9, rtol=0.0):
                raise ctx.bad("truth.polyline_m", f"starts at {line[0].tolist()}, expected the start point [0, 0]")
            if not np.allclose(line[-1], end, atol=1e-6, rtol=0.0):
                raise ctx.bad("truth.polyline_m", f"ends at {line[-1].tolist()}, expected end_point_m "
                                                  f"{end.tolist()}")
        return RouteTruth(distance_m=distance, end_point_m=end, polyline_m=line)
    refuse_unused(ctx, truth, "truth", [k for k in ROUTE_KEYS if k != "kind"], "by kind = 'track'")
    path, fmt = _file_of(ctx, truth, "truth")
    if fmt == "npy":
        refuse_unused(ctx, truth, "truth", ("skip_rows",), "by an .npy file")
    raw = truth.get("columns")
    frame = value_of(ctx, truth, "truth", "frame", TRUTH_CHECKS)
    letters = None
    if isinstance(raw, dict):
        keys = set(raw) - {"time"}
        if frame is not None and keys and keys <= set(FRAME_LETTERS[frame]):
            letters = frame
        else:
            letters = next((fr for fr, ls in FRAME_LETTERS.items() if keys and keys <= set(ls)), None)
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
                                         f"{', '.join(FRAME_LETTERS[letters])}")
        axes = FRAME_LETTERS[frame] if frame else ("x", "y", "z")
    cols = _column_names(ctx, truth, "truth", fmt, ("time",) + axes, ("time",), None)
    timed = "time" in cols
    rate = value_of(ctx, truth, "truth", "rate_hz", TRUTH_CHECKS)
    if not timed and rate is None:
        raise ctx.bad("truth.rate_hz", "missing, expected the truth's rate [Hz] for a file without a time column")
    if not timed:
        refuse_unused(ctx, truth, "truth", ("time_unit",), "without a time column")
    skip = value_of(ctx, truth, "truth", "skip_rows", TRUTH_CHECKS, default=0) if fmt == "csv" else 0
    per_s = TIME_UNITS[value_of(ctx, truth, "truth", "time_unit", TRUTH_CHECKS, default="s")]
    layout = ColumnLayout(("time",) + axes, tuple(cols.get(c) for c in ("time",) + axes), format=fmt,
                          skip_rows=skip, time_per_s=per_s, rate_hz=None if timed else rate, time_from_first=True)
    t, p = _read(ctx, "truth.file", path, layout, 2)
    if timed:
        _check_rate(ctx, "truth.rate_hz", rate, t)
    offset = value_of(ctx, truth, "truth", "offset_s", TRUTH_CHECKS, default=0.0)
    enu = p if frame == "ENU" else np.ascontiguousarray(np.stack([p[:, 1], p[:, 0], -p[:, 2]], axis=-1))
    try:
        track = TruthTrack(time=rec.time[0] + offset + t, position=enu, source_frame=frame, source=str(path))
    except MorpiError as exc:
        raise ctx.bad("truth.file", str(exc), DataError) from None
    return track


def check_labels(ctx: Context, rec: Recording, truth, labels: dict) -> None:
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


def check_physics(ctx: Context, rec: Recording, rest, declared: dict, spec: SensorSpec) -> None:
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


