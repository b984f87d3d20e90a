"""Simulated datasets in other robots' layouts, with their manifests (exact truth for the manifest loader).

:func:`write_foreign_dataset` simulates recordings with exact kinematics
(:mod:`morpi_filters.simulate`) and writes them as another robot's logger
would (a :class:`ForeignLayout`: file format, rate, clock unit, axes, sensor
units, a logger's CSV quirks, a truth track in NED or ENU at its own rate and
offset, runs that start moving, train and test splits over several groups),
with the dataset manifest (``dataset.toml``, :mod:`morpi_filters.manifest`)
that describes them. It returns the simulator's own arrays (body axes x
forward, y left, z up; SI), so a test can hold what the manifest loader
makes of the files against the truth. :data:`LAYOUTS` names one layout per
option (``morpi simulate --layout NAME --out DIR``).

The conversions here are written from the definitions (a file axis letter
is a direction of the body; 1 g is :data:`morpi_filters.units.G0`; 1 deg/s
is :data:`morpi_filters.units.DEG` rad/s; NED is north, east, down), apart
from the manifest module's, so the two check each other.

Truth tracks lie in a local ENU frame turned from the simulator's navigation
frame (x to the end point, y left, z up) by :data:`TRACK_YAW_DEG` about the
vertical and shifted by :data:`TRACK_ORIGIN_M`.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from . import units
from .errors import ParameterError
from .simulate import ImuData, imu, sine, straight

__all__ = ["ForeignLayout", "ForeignRun", "ForeignDataset", "LAYOUTS", "TRACK_YAW_DEG", "TRACK_ORIGIN_M",
           "write_foreign_dataset", "enu_from_navigation"]

#: Heading of the simulator's navigation x axis in the truth tracks' ENU frame [deg], counter-clockwise from east.
TRACK_YAW_DEG = 30.0
#: Position of the simulator's start point in the truth tracks' ENU frame [m].
TRACK_ORIGIN_M = (120.0, -45.0, 3.5)

_PER_SECOND = {"s": 1.0, "ms": 1e3, "us": 1e6, "ns": 1e9}
_ACCEL = {"m/s^2": 1.0, "g": units.G0}
_GYRO = {"rad/s": 1.0, "deg/s": units.DEG}
_DIRECTION = {"F": (0, 1.0), "B": (0, -1.0), "L": (1, 1.0), "R": (1, -1.0), "U": (2, 1.0), "D": (2, -1.0)}


@dataclass(frozen=True)
class ForeignLayout:
    """How a simulated dataset is written: one robot's logger and truth system.

    Attributes
    ----------
    format : str
        IMU files: ``"csv"`` or ``"npy"``.
    time_column : bool
        Whether the IMU files hold time (else ``rate_hz`` in the manifest).
    rate_hz : float
        IMU sampling rate [Hz] (uniform).
    time_unit : str
        Unit of the IMU clock: ``"s"``, ``"ms"``, ``"us"`` or ``"ns"``.
    clock_start_s : float
        IMU clock at the first sample [s].
    accel_unit, gyro_unit : str
        ``"m/s^2"`` or ``"g"``; ``"rad/s"`` or ``"deg/s"``.
    axes : str
        Directions of the file's x, y, z axes (``"FRD"``: forward, right, down).
    preamble : int
        Lines before the CSV header.
    logger_style : bool
        A logger's CSV: its own column names, blanks after commas, a comma
        ending each line, quoted accelerometer fields and a temperature column.
    truth : str
        ``"route"`` (end point) or ``"track"``.
    truth_format : str
        Truth track files: ``"csv"`` or ``"npy"``.
    truth_frame : str
        ``"NED"`` or ``"ENU"``.
    truth_columns : str
        ``"letters"`` (columns n, e, d or e, n, u) or ``"xyz"`` (with the frame declared).
    truth_rate_hz : float
        Truth rate [Hz].
    truth_time_column : bool
        Whether truth files hold time (their own clock, starting at 5000 s).
    truth_time_unit : str
        Unit of the truth clock.
    truth_offset_s : float
        Truth time of the truth file's first sample, the IMU's first sample at 0 [s].
    start : str
        ``"rest"``: the runs start standing; ``"moving"``: at cruise speed (rest ``"none"``, initial ``"truth"``).
    groups : bool
        Six runs in three groups, each with a train and a test run (else two runs, one group, no split).
    """

    format: str = "csv"
    time_column: bool = True
    rate_hz: float = 100.0
    time_unit: str = "s"
    clock_start_s: float = 12.5
    accel_unit: str = "m/s^2"
    gyro_unit: str = "rad/s"
    axes: str = "FLU"
    preamble: int = 0
    logger_style: bool = False
    truth: str = "route"
    truth_format: str = "csv"
    truth_frame: str = "NED"
    truth_columns: str = "letters"
    truth_rate_hz: float = 10.0
    truth_time_column: bool = True
    truth_time_unit: str = "s"
    truth_offset_s: float = -0.35
    start: str = "rest"
    groups: bool = False


#: One layout per option a manifest describes (``morpi simulate --layout NAME``).
LAYOUTS = {
    "npy-120hz": ForeignLayout(format="npy", time_column=False, rate_hz=120.0),
    "frd": ForeignLayout(axes="FRD"),
    "gyro-deg": ForeignLayout(gyro_unit="deg/s"),
    "accel-g": ForeignLayout(accel_unit="g"),
    "logger-csv": ForeignLayout(preamble=1, time_unit="us", logger_style=True, clock_start_s=1234.56789),
    "truth-ned": ForeignLayout(truth="track", truth_frame="NED", truth_rate_hz=10.0, truth_offset_s=-0.35),
    "moving-start": ForeignLayout(start="moving", truth="track", truth_frame="ENU", truth_time_column=False),
    "groups": ForeignLayout(groups=True),
    "robot": ForeignLayout(format="npy", time_column=False, rate_hz=120.0, axes="FRD", accel_unit="g",
                           gyro_unit="deg/s", truth="track", truth_format="npy", truth_frame="NED",
                           truth_time_column=False, truth_offset_s=-0.4),
}


@dataclass(frozen=True, eq=False)
class ForeignRun:
    """One simulated run and where it was written.

    Attributes
    ----------
    id : str
        The recording's id in the manifest.
    split, group, motion : str
        Its labels in the manifest.
    imu : ImuData
        The simulator's readings (body axes x forward, y left, z up; SI) on
        the times the loader gives (``imu.time``), with the trajectory.
    truth_time : ndarray, shape (m,) or None
        Times of the truth samples on the IMU clock [s] (tracks only).
    truth_position : ndarray, shape (m, 3) or None
        The simulator's positions at those times, in its navigation frame [m].
    imu_file, truth_file : Path or None
        The files written.
    """

    id: str
    split: str
    group: str
    motion: str
    imu: ImuData
    truth_time: np.ndarray | None
    truth_position: np.ndarray | None
    imu_file: Path
    truth_file: Path | None


@dataclass(frozen=True, eq=False)
class ForeignDataset:
    """A simulated dataset written in a foreign layout.

    Attributes
    ----------
    manifest : Path
        The manifest (``dataset.toml``) in the dataset folder.
    layout : ForeignLayout
        How it was written.
    runs : tuple of ForeignRun
        In the manifest's order.
    """

    manifest: Path
    layout: ForeignLayout
    runs: tuple


def enu_from_navigation(position) -> np.ndarray:
    """Positions of the simulator's navigation frame in the truth tracks' ENU frame.

    Parameters
    ----------
    position : array_like, shape (m, 3)
        x to the end point, y left, z up [m].

    Returns
    -------
    ndarray, shape (m, 3)
        Turned by :data:`TRACK_YAW_DEG` about z and shifted by :data:`TRACK_ORIGIN_M` [m].

    Examples
    --------
    >>> enu_from_navigation([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]).round(6).tolist()
    [[120.0, -45.0, 3.5], [120.866025, -44.5, 3.5]]
    """
    p = np.asarray(position, dtype=float)
    c, s = math.cos(math.radians(TRACK_YAW_DEG)), math.sin(math.radians(TRACK_YAW_DEG))
    turned = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])
    return turned + np.asarray(TRACK_ORIGIN_M)


def _check(layout: ForeignLayout) -> None:
    choices = {"format": ("csv", "npy"), "time_unit": tuple(_PER_SECOND), "accel_unit": tuple(_ACCEL),
               "gyro_unit": tuple(_GYRO), "truth": ("route", "track"), "truth_format": ("csv", "npy"),
               "truth_frame": ("NED", "ENU"), "truth_columns": ("letters", "xyz"),
               "truth_time_unit": tuple(_PER_SECOND), "start": ("rest", "moving")}
    for key, options in choices.items():
        if getattr(layout, key) not in options:
            raise ParameterError(f"ForeignLayout.{key}: {getattr(layout, key)!r}, expected one of {options}")
    if layout.start == "moving" and layout.truth != "track":
        raise ParameterError("ForeignLayout.start: 'moving' needs truth = 'track' (the initial state comes from it)")
    if layout.format == "npy" and (layout.preamble or layout.logger_style):
        raise ParameterError("ForeignLayout: preamble and logger_style describe CSV files, not npy")
    if not (layout.rate_hz >= 1.0 and layout.truth_rate_hz >= 1.0):
        raise ParameterError("ForeignLayout: rate_hz and truth_rate_hz must be at least 1 Hz")


def _file_axes(v: np.ndarray, axes: str) -> np.ndarray:
    """Body-frame vectors (x forward, y left, z up) as components along the file's axes."""
    out = np.empty_like(v)
    for j, letter in enumerate(axes):
        i, sign = _DIRECTION[letter]
        out[:, j] = sign * v[:, i]
    return out


def _clock(layout: ForeignLayout, n: int) -> tuple[np.ndarray | None, np.ndarray]:
    """The file's time readings (in its unit) and the times the loader makes of them [s]."""
    if not layout.time_column:
        return None, np.arange(n) / layout.rate_hz
    per_s = _PER_SECOND[layout.time_unit]
    step = per_s / layout.rate_hz
    start = round(layout.clock_start_s * per_s) if layout.time_unit != "s" else layout.clock_start_s
    if layout.time_unit != "s" and step == round(step):
        raw = start + np.arange(n, dtype=np.int64) * int(round(step))       # an integer clock
        return raw, raw / per_s
    raw = start + np.arange(n) * step
    return raw, (raw / per_s if per_s != 1.0 else raw)


def _runs_plan(layout: ForeignLayout):
    """(id, split, group, motion, trajectory keywords) of each run."""
    if layout.groups:
        plan = []
        for group, motion, kw in (("sine-1.0m", "periodic", dict(p2p_m=1.0, amplitude_m=0.1)),
                                  ("sine-1.5m", "periodic", dict(p2p_m=1.5, amplitude_m=0.15)),
                                  ("straight", "straight", {})):
            for split in ("train", "test"):
                plan.append((f"{group}-{split}", split, group, motion, kw))
        return plan
    return [("periodic-1", "none", "all", "periodic", dict(p2p_m=1.0, amplitude_m=0.1)),
            ("straight-1", "none", "all", "straight", {})]


def _simulate(layout: ForeignLayout, motion: str, kw: dict, rng, noise_free: bool = False) -> tuple:
    """A run's readings on the loader's times, the file's clock readings, the trajectory and the
    trajectory's time at the first sample."""
    rest = (2.0, 1.5)
    traj = sine(3.0, rest_s=rest, **kw) if motion == "periodic" else straight(3.0, rest_s=rest)
    if layout.start == "moving":
        begin = traj.start_time + 1.5                          # past the 1 s ramp: at cruise speed
    else:
        begin = 0.0
    n = int(math.floor((traj.end_time - begin) * layout.rate_hz)) + 1
    raw, loaded = _clock(layout, n)
    times = begin + (loaded - loaded[0])
    scales = dict(bias_scale=0.0, noise_scale=0.0) if noise_free else dict(bias_scale=(0.25, 0.3))
    data = imu(traj, units.LSM6DSL, rng, sampling=times, **scales)
    # the readings on the loader's clock (the trajectory was sampled at `times`, on its own clock)
    return replace(data, time=loaded), raw, traj, begin


def _fmt(v) -> str:
    return repr(float(v))


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _imu_columns(layout: ForeignLayout):
    """(columns table of the manifest, the order the file holds them in)."""
    names = ("time", "f_x", "f_y", "f_z", "g_x", "g_y", "g_z")
    if layout.format == "npy":
        order = ["g_x", "g_y", "g_z", "f_x", "f_y", "f_z"] + (["time"] if layout.time_column else [])
        return {c: order.index(c) for c in names if c in order}, order
    label = {"time": f"timestamp_{layout.time_unit}", "f_x": "AccX", "f_y": "AccY", "f_z": "AccZ",
             "g_x": "GyroX", "g_y": "GyroY", "g_z": "GyroZ"} if layout.logger_style else {c: c for c in names}
    order = (["time"] if layout.time_column else []) + ["g_z", "g_y", "g_x", "f_x", "f_y", "f_z"]
    return {c: label[c] for c in order}, order


def _write_imu(path: Path, layout: ForeignLayout, raw, f_file, w_file) -> None:
    cols, order = _imu_columns(layout)
    value = {"f_x": f_file[:, 0], "f_y": f_file[:, 1], "f_z": f_file[:, 2],
             "g_x": w_file[:, 0], "g_y": w_file[:, 1], "g_z": w_file[:, 2]}
    if raw is not None:
        value["time"] = raw
    if layout.format == "npy":
        np.save(path, np.column_stack([np.asarray(value[c], dtype=float) for c in order]))
        return
    sep = ", " if layout.logger_style else ","
    end = "," if layout.logger_style else ""
    header = [cols[c] for c in order] + (["Temp"] if layout.logger_style else [])
    lines = [f"logger export, preamble line {k + 1}" for k in range(layout.preamble)]
    lines.append(sep.join(header) + end)
    integer_time = raw is not None and np.issubdtype(np.asarray(raw).dtype, np.integer)
    for k in range(f_file.shape[0]):
        cells = []
        for c in order:
            v = value[c][k]
            text = str(int(v)) if c == "time" and integer_time else _fmt(v)
            cells.append(f'"{text}"' if layout.logger_style and c.startswith("f_") else text)
        if layout.logger_style:
            cells.append("21.5")
        lines.append(sep.join(cells) + end)
    path.write_text("\n".join(lines) + "\n")


def _write_truth(path: Path, layout: ForeignLayout, raw, enu: np.ndarray) -> dict:
    """Write a truth track; its columns table."""
    ned = layout.truth_frame == "NED"
    file_pos = np.column_stack([enu[:, 1], enu[:, 0], -enu[:, 2]]) if ned else enu    # NED: north, east, down
    letters = ("n", "e", "d") if ned else ("e", "n", "u")
    keys = letters if layout.truth_columns == "letters" else ("x", "y", "z")
    if layout.truth_format == "npy":
        cols = {k: j for j, k in enumerate(keys)}
        data = [file_pos]
        if raw is not None:
            cols["time"] = 3
            data.append(np.asarray(raw, dtype=float)[:, None])
        np.save(path, np.hstack(data))
        return cols
    names = {k: f"pos_{k}" for k in keys}
    cols = ({"time": "t"} if raw is not None else {}) | names
    lines = [",".join(cols.values())]
    for k in range(file_pos.shape[0]):
        cells = ([_fmt(raw[k])] if raw is not None else []) + [_fmt(v) for v in file_pos[k]]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return cols


def write_foreign_dataset(out, layout: ForeignLayout, *, seed: int = 0, noise_free: bool = False) -> ForeignDataset:
    """Simulate a dataset and write it in a foreign layout with its manifest.

    Parameters
    ----------
    out : str or Path
        Destination folder: new, empty, or an earlier morpi output (it is
        built aside and swapped in when complete).
    layout : ForeignLayout
        How the files are written (:data:`LAYOUTS` names one per option).
    seed : int
        Seed of the sensor errors (each run draws from a child seed).
    noise_free : bool
        Readings without sensor errors (no bias, no noise): the files hold the
        true specific force and angular rate, for tests with exact answers.

    Returns
    -------
    ForeignDataset
        The manifest's path (``out/dataset.toml``) and, per run, the
        simulator's readings and truth.

    Raises
    ------
    ParameterError
        A layout option outside its choices, or an output folder morpi may
        not replace.

    Examples
    --------
    >>> import tempfile
    >>> ds = write_foreign_dataset(Path(tempfile.mkdtemp()) / "robot", LAYOUTS["frd"], seed=1)
    >>> ds.manifest.name, [r.id for r in ds.runs], sorted(p.name for p in (ds.manifest.parent / "imu").iterdir())
    ('dataset.toml', ['periodic-1', 'straight-1'], ['periodic-1.csv', 'straight-1.csv'])
    """
    from .outputs import staged_dir

    _check(layout)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: expected a non-negative integer, got {seed!r}")
    out = Path(out)
    plan = _runs_plan(layout)
    seeds = np.random.SeedSequence(int(seed)).spawn(len(plan))
    imu_cols, _ = _imu_columns(layout)
    defaults_imu = {"format": layout.format, "columns": imu_cols, "accel_unit": layout.accel_unit,
                    "gyro_unit": layout.gyro_unit, "axes": layout.axes}
    if layout.time_column:
        defaults_imu["time_unit"] = layout.time_unit
    else:
        defaults_imu["rate_hz"] = float(layout.rate_hz)
    if layout.preamble:
        defaults_imu["skip_rows"] = layout.preamble
    runs, records = [], []
    out.parent.mkdir(parents=True, exist_ok=True)
    with staged_dir(out, "morpi simulate --layout") as stage:
        (stage / "imu").mkdir()
        if layout.truth == "track":
            (stage / "truth").mkdir()
        truth_cols = None
        for k, ((rec_id, split, group, motion, kw), child) in enumerate(zip(plan, seeds)):
            data, raw, traj, begin = _simulate(layout, motion, kw, np.random.default_rng(child), noise_free)
            f_file = _file_axes(data.f, layout.axes) / _ACCEL[layout.accel_unit]
            w_file = _file_axes(data.omega, layout.axes) / _GYRO[layout.gyro_unit]
            imu_file = stage / "imu" / f"{rec_id}.{layout.format}"
            _write_imu(imu_file, layout, raw, f_file, w_file)
            record = {"id": rec_id}
            if layout.groups:
                record.update(split=split, group=group)
            record["motion"] = motion
            if layout.start == "moving":
                record.update(rest="none", initial="truth")
            elif k % 2:
                record["rest"] = [0.1, 1.8]        # inside the 2 s before the motion
            record["imu"] = {"file": f"imu/{imu_file.name}"}
            truth_time = truth_pos = truth_file = None
            if layout.truth == "route":
                record["truth"] = {"kind": "route", "distance_m": float(traj.distance),
                                   "end_point_m": [float(v) for v in traj.end_point[:2]]}
            else:
                span = data.time[-1] - data.time[0] - layout.truth_offset_s
                m = int(math.ceil(span * layout.truth_rate_hz)) + 2
                per_s = _PER_SECOND[layout.truth_time_unit]
                if layout.truth_time_column:
                    t_raw = 5000.0 * per_s + np.arange(m) * (per_s / layout.truth_rate_hz)
                    rel = (t_raw - t_raw[0]) / per_s if per_s != 1.0 else t_raw - t_raw[0]
                else:
                    t_raw, rel = None, np.arange(m) / layout.truth_rate_hz
                truth_time = data.time[0] + layout.truth_offset_s + rel
                truth_pos = traj.at(begin + (truth_time - data.time[0])).position
                truth_file = stage / "truth" / f"{rec_id}.{layout.truth_format}"
                truth_cols = _write_truth(truth_file, layout, t_raw, enu_from_navigation(truth_pos))
                record["truth"] = {"file": f"truth/{truth_file.name}", "offset_s": float(layout.truth_offset_s)}
            records.append(record)
            runs.append(ForeignRun(id=rec_id, split=split, group=group, motion=motion, imu=data,
                                   truth_time=truth_time, truth_position=truth_pos,
                                   imu_file=out / "imu" / imu_file.name,
                                   truth_file=None if truth_file is None else out / "truth" / truth_file.name))
        defaults_truth = None
        if layout.truth == "track":
            defaults_truth = {"kind": "track", "format": layout.truth_format, "columns": truth_cols}
            if layout.truth_columns == "xyz":
                defaults_truth["frame"] = layout.truth_frame
            if layout.truth_time_column:
                defaults_truth["time_unit"] = layout.truth_time_unit
            else:
                defaults_truth["rate_hz"] = float(layout.truth_rate_hz)
        (stage / "dataset.toml").write_text(_manifest_text(layout, defaults_imu, defaults_truth, records))
    return ForeignDataset(manifest=out / "dataset.toml", layout=layout, runs=tuple(runs))


def _manifest_text(layout: ForeignLayout, imu_defaults: dict, truth_defaults, records) -> str:
    options = ", ".join(f"{f.name} = {getattr(layout, f.name)!r}" for f in fields(layout)
                        if getattr(layout, f.name) != f.default)
    about = "simulated by morpi_filters.foreign (every run's truth is the simulator's); layout: "
    lines = ["format_version = 1", 'name = "simulated robot"',
             f"description = {json.dumps(about + (options or 'the defaults of ForeignLayout'))}", "",
             "[defaults.imu]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in imu_defaults.items()]
    if truth_defaults is not None:
        lines += ["", "[defaults.truth]"] + [f"{k} = {_toml_value(v)}" for k, v in truth_defaults.items()]
    for rec in records:
        lines += ["", "[[recording]]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in rec.items()]
    return "\n".join(lines) + "\n"
