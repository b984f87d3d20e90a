"""Recordings: the CSV loader with validation, and the MoRPI dataset catalogue.

A :class:`Recording` holds one IMU recording in SI units and phone axes (see
the package docstring for frames). :func:`load_csv` reads one file and rejects
anything that is not a clean recording with a :class:`MorpiError` naming the
file, and the line where there is one; :func:`read_columns` reads a table in
another layout and units (a :class:`ColumnLayout`: a logger's CSV or an
``.npy`` array) with the same checks on the values converted to SI.
:func:`plausibility_problems` reads what
a clean file says at rest (gravity's magnitude and direction, the gyro's offset
and noise, channels that never move) and names what no phone IMU in SI units
and the z-up frame would record; the catalogue's loader and :func:`check_tree`
apply it (:func:`check_plausible`). Its checks live in :func:`rest_problems`,
structured and scaled by a sensor's error figures, which dataset manifests
call too. :func:`catalogue` walks a dataset root
laid out as the public MoRPI repository (``s8/short_distance/train/3.csv``)
and attaches phone, route, split and the route's ground truth, which lives in
``data/routes.json`` (a file this project owns).

The dataset root is found by :func:`resolve_data_root`: an explicit path, else
the environment variable ``MORPI_DATA``.
"""
from __future__ import annotations

import array
import codecs
import csv
import io
import json
import math
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .choice import choose
from .errors import DataError, MissingDataError, MorpiError, ParameterError
from .resources import project_data
from .units import DEG, G0, SENSORS, SensorSpec

__all__ = [
    "COLUMNS", "MIN_SAMPLES", "ACCEL_LIMIT_MPS2", "GYRO_LIMIT_RADPS", "MAX_GAP_S", "TIME_LIMIT_S", "DATA_ENV", "Route", "Recording", "CatalogueEntry",
    "ColumnLayout", "load_csv", "read_columns", "check_recording", "load_recording", "write_csv", "routes", "route",
    "catalogue", "load_catalogue",
    "resolve_data_root", "missing_data_message", "check_tree", "keep_parsed", "PROJECT_DATA",
    "layout", "expected_layout", "layout_problems", "folder_key", "GRAVITY_BAND_MPS2", "UP_FRACTION_MIN",
    "GYRO_REST_LIMIT_RADPS", "GYRO_NOISE_FACTOR", "MOVING_RATE_LIMIT_RADPS", "MEMS_SPEC", "RestProblem",
    "rest_problems", "plausibility_problems", "check_plausible",
]

#: The columns every recording must have (the header names them; any order is read).
COLUMNS = ("time", "f_x", "f_y", "f_z", "g_x", "g_y", "g_z")
#: Fewest samples a recording may have (1 s at the nominal 100 Hz).
MIN_SAMPLES = 100
#: Largest absolute specific force accepted [m/s^2]: 16 g, the widest accelerometer full scale of the
#: two phones' IMUs (LSM6DSL in the Galaxy S8 and MPU-6500 in the S6, as named in the paper:
#: both datasheets list +-2/4/8/16 g), plus a 5 % margin for scale-factor and offset errors.
#: No real reading can exceed it; the field recordings peak at about 1 g.
ACCEL_LIMIT_MPS2 = 16 * G0 * 1.05
#: Largest absolute angular rate accepted [rad/s]: 2000 deg/s, the widest gyro full scale of both
#: IMUs (datasheets: +-125/250/500/1000/2000 deg/s for the LSM6DSL, +-250/.../2000 for the
#: MPU-6500), plus the same 5 % margin. The field recordings peak at about 12.3 rad/s.
GYRO_LIMIT_RADPS = 2000 * math.pi / 180 * 1.05
#: Largest time between two samples [s]. The 143 field recordings sample at about 100 Hz and
#: their largest gap is 0.023 s; a gap of 1 s (100 missing samples) means lost data, which the
#: strapdown integration would bridge with one Euler step and report as motion.
MAX_GAP_S = 1.0
#: Largest absolute time stamp accepted [s] (about 3 years). Recordings count from the start or from
#: the phone's boot; beyond this a float64 time stamp is no plausible clock reading (and its
#: resolution, 1.5e-8 s at 1e8 s, would start to eat into the 10 ms sample interval).
TIME_LIMIT_S = 1e8
#: Error figures the plausibility checks (:func:`rest_problems`) assume unless told another sensor's:
#: the larger of each figure of the MoRPI phones' IMUs (MPU-6500 in the Galaxy S6, LSM6DSL in the S8:
#: the paper's table of manufacturer errors, 1 sigma per axis), so that one bound serves both phone
#: folders. The bounds below are this spec's; the MoRPI catalogue uses it, and so does a dataset
#: manifest that gives no ``imu.spec``: the two are widely used consumer MEMS IMUs, and a ground robot's
#: IMU with smaller errors passes bounds set for larger ones.
MEMS_SPEC = SensorSpec("MPU-6500/LSM6DSL (larger figure of each)", "",
                       gyro_bias=max(s.gyro_bias for s in SENSORS.values()),
                       gyro_noise=max(s.gyro_noise for s in SENSORS.values()),
                       accel_bias=max(s.accel_bias for s in SENSORS.values()),
                       accel_noise=max(s.accel_noise for s in SENSORS.values()))
#: Initial sensitivity (scale-factor) tolerance of the accelerometer, as a fraction of the reading:
#: +-3 %, the figure InvenSense's MPU-6000/6050 product specification (table 6.2) gives for its
#: accelerometer, taken for the MPU-6500 of the same family (the LSM6DSL's is tighter).
_SENSITIVITY_TOLERANCE = 0.03
#: Spread of gravity over the Earth's surface [m/s^2]: normal gravity runs from 9.780 m/s^2 at the
#: equator to 9.832 at the poles, 0.003 less per km of height.
_PLACE_MPS2 = 0.05


def _gravity_band(spec: SensorSpec) -> float:
    """Half-width [m/s^2] of the band around :data:`G0` a sensor's rest specific force lies in (:data:`GRAVITY_BAND_MPS2`)."""
    return 3 * spec.accel_bias + _SENSITIVITY_TOLERANCE * G0 + _PLACE_MPS2


#: Plausibility at rest (:func:`rest_problems`): the magnitude of the specific force over the
#: recording's rest must lie within this band around standard gravity :data:`G0` [m/s^2]. It adds
#: three times the sensor's zero-g offset (here :data:`MEMS_SPEC`'s 60 mg, the MPU-6500's; the
#: LSM6DSL lists 40 mg), 1.77 m/s^2; the initial sensitivity tolerance of +-3 %, 0.29 m/s^2 at 1 g;
#: and 0.05 m/s^2 for the place on Earth. Tilt changes the direction of the specific force at rest,
#: not its magnitude, and the medians over the rest average vibration out, so neither takes a margin.
#: About 2.11 m/s^2: an accelerometer written in g (reading about 1) or without gravity (about 0,
#: linear acceleration) lies more than 6 m/s^2 outside it. The field recordings read 9.8066 to
#: 9.8067 m/s^2. (Dataset manifests once accepted 0.75 to 1.25 g, a round band without a source;
#: the datasheet band replaces it, and a manifest's ``imu.spec`` widens it for a worse sensor.)
GRAVITY_BAND_MPS2 = _gravity_band(MEMS_SPEC)
#: Least share of the rest specific force the z axis must carry, positive: cos 45 deg. The phone
#: frame is z up (a level phone at rest reads f_z = +g), and z is the axis nearest the vertical as
#: long as the phone is tilted less than 45 deg about a horizontal axis; beyond that x or y is nearer
#: the vertical (columns swapped under a kept header, or a phone standing on its edge), and a
#: negative f_z is a z-down frame (a phone face down, or axes written north-east-down). Both break the
#: paper's level start and its calibration, which puts gravity on +z. The field recordings carry at
#: least 0.977 of it on z (12 deg of tilt). (Dataset manifests once accepted 60 deg, a round figure;
#: 45 deg is where another axis becomes the nearer one to the vertical, so it is kept for both.)
UP_FRACTION_MIN = math.cos(math.radians(45.0))
#: Largest mean angular rate of one gyro axis at rest [rad/s]: three times the sensor's zero-rate
#: offset (here :data:`MEMS_SPEC`'s 6 deg/s, the MPU-6500's; the LSM6DSL lists 3 deg/s; 1 sigma per
#: axis in the paper's table), 18 deg/s; the earth's rate (7.3e-5 rad/s) is negligible beside it. A gyro
#: column holding gravity (9.8) or a tilted phone's horizontal specific force lies beyond it, and so
#: do rates written in deg/s (57.3 times larger) from a gyro whose offset exceeds 0.31 deg/s on some
#: axis. The field rest periods read at most 0.032 rad/s. (Dataset manifests once accepted 0.5 rad/s on
#: the magnitude, a round figure; three datasheet offsets per axis replace it.)
GYRO_REST_LIMIT_RADPS = 3 * MEMS_SPEC.gyro_bias
#: Largest white noise of a gyro axis at rest, as a multiple of the sensor's datasheet noise at the
#: recording's sampling rate (for :data:`MEMS_SPEC` the MPU-6500's 0.01 deg/s/sqrt(Hz) times sqrt(rate),
#: the sample standard deviation :func:`morpi_filters.simulate.imu` draws): 10, or 1 deg/s rms at
#: 100 Hz. Rates written in deg/s carry 57.3 times their noise, beyond the bound for any gyro whose
#: noise exceeds 10 / 57.3 = 0.17 of that density (the LSM6DSL's datasheet density is 0.4 of it). The
#: field rest periods read at most 1.8 times the density (a median change of two quantization steps on
#: the S6).
GYRO_NOISE_FACTOR = 10.0
#: Largest 99th percentile of the angular rate's magnitude over a whole recording [rad/s] (573 deg/s):
#: no ground robot turns that fast for 1 % of a run, while rates written in deg/s from turns above
#: 10 deg/s pass it; it needs no rest, so it also judges a recording that starts moving. The field
#: recordings read at most 1.9 rad/s (their peak is 12.3 rad/s).
MOVING_RATE_LIMIT_RADPS = 10.0
#: Environment variable naming the dataset root.
DATA_ENV = "MORPI_DATA"
#: Folder of the small files this project owns (ground truth, checksums).
PROJECT_DATA = project_data()

_HOW_TO_GET = (
    "get the field recordings with `morpi data fetch --dest DIR` (or clone the public "
    "repository ansfl/MoRPI and use its data/ folder), then pass --data DIR or set "
    f"{DATA_ENV}=DIR"
)


@dataclass(frozen=True)
class Route:
    """Ground truth of one route of the dataset.

    Attributes
    ----------
    name : str
        Route folder name (``"short_distance"``, ``"L_line"``, ...).
    kind : str
        ``"straight"`` or ``"periodic"``.
    environment : str
        ``"indoor"`` or ``"outdoor"``.
    p2p_m : float or None
        Designed peak-to-peak (period) length [m]; None for straight routes.
    amplitude_m : float or None
        Designed lateral amplitude [m].
    distance_m : float
        Travelled distance along the route [m].
    end_point_m : ndarray, shape (2,)
        True end point in the navigation frame [m].
    segments_m : tuple of float
        Lengths of the straight legs [m].
    turn_deg : float
        Heading change between legs [deg], positive to the left.
    slope_deg, slope_length_m : float
        Downhill slope at the start of the first leg (0 where none).
    """

    name: str
    kind: str
    environment: str
    p2p_m: float | None
    amplitude_m: float | None
    distance_m: float
    end_point_m: np.ndarray
    segments_m: tuple
    turn_deg: float
    slope_deg: float = 0.0
    slope_length_m: float = 0.0

    @property
    def polyline(self) -> np.ndarray:
        """The route's centre line: the corners of its straight legs, from the origin [m], shape (legs + 1, 2).

        Examples
        --------
        >>> route("L_shape").polyline.tolist()
        [[0.0, 0.0], [18.0, 0.0], [18.0, -10.0]]
        """
        pts = [np.zeros(2)]
        heading = 0.0
        for i, length in enumerate(self.segments_m):
            if i > 0:
                heading += np.radians(self.turn_deg)
            pts.append(pts[-1] + length * np.array([np.cos(heading), np.sin(heading)]))
        return np.array(pts)


@dataclass(frozen=True, eq=False)
class Recording:
    """One IMU recording in SI units and phone axes.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s], strictly increasing, not uniformly spaced.
    f : ndarray, shape (n, 3)
        Specific force in the body frame [m/s^2].
    omega : ndarray, shape (n, 3)
        Angular rate in the body frame [rad/s].
    source : str
        The file it came from (or a label for synthetic data).
    phone : str or None
        ``"s6"`` or ``"s8"``.
    route : str or None
        Route folder name, key of :func:`routes`.
    split : str or None
        ``"train"``, ``"test"`` or None for folders without a split.
    imu : SensorSpec or None
        The error figures of the IMU that recorded it, when the dataset names
        them (the MoRPI catalogue: the phone's IMU; a manifest: ``imu.spec``;
        a simulation: its spec). What reads a recording's noise floor (rest
        detection) reads it here, never from the phone's name.
    label : str or None
        The recording's name within its dataset, when the dataset gives it
        one (a manifest: the recording's id); otherwise :attr:`name` is made
        from the labels above.

    Raises
    ------
    ParameterError
        Arrays of the wrong shapes.
    DataError
        A value that is not finite, or times that do not strictly increase (naming the sample).

    Examples
    --------
    >>> t = 10.0 + np.arange(201) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (201, 1)), omega=np.zeros((201, 3)),
    ...                 source="/data/s8/L_shape/test/3.csv", phone="s8", route="L_shape", split="test")
    >>> rec.n, round(rec.duration, 9), round(rec.rate_hz, 6), rec.name, rec.ground_truth.distance_m
    (201, 2.0, 100.0, 's8/L_shape/test/3.csv', 28.0)
    """

    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    source: str = "<memory>"
    phone: str | None = None
    route: str | None = None
    split: str | None = None
    imu: SensorSpec | None = None
    label: str | None = None

    def __post_init__(self):
        n = self.time.shape[0]
        if self.time.ndim != 1 or self.f.shape != (n, 3) or self.omega.shape != (n, 3):
            raise ParameterError(
                f"{self.source}: expected time (n,), f (n, 3), omega (n, 3); got "
                f"{self.time.shape}, {self.f.shape}, {self.omega.shape}")
        for label, values in (("time", self.time), ("f", self.f), ("omega", self.omega)):
            bad = ~np.isfinite(values)
            if bad.any():
                i = int(np.flatnonzero(bad.reshape(n, -1).any(axis=1))[0])
                raise DataError(f"{self.source}: {label} of sample {i} is {values[i]!r}, expected finite numbers")
        if n > 1:
            step = np.diff(self.time)
            if not (step > 0).all():
                i = int(np.flatnonzero(~(step > 0))[0]) + 1
                raise DataError(f"{self.source}: time of sample {i} ({self.time[i]!r}) is not after the one before "
                                f"({self.time[i - 1]!r}), expected strictly increasing times")

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.time.shape[0])

    @property
    def dt(self) -> np.ndarray:
        """Sample intervals, shape (n - 1,) [s]."""
        return np.diff(self.time)

    @property
    def duration(self) -> float:
        """Time from first to last sample [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def rate_hz(self) -> float:
        """Median sampling rate [Hz]."""
        return float(1.0 / np.median(np.diff(self.time)))

    @property
    def ground_truth(self) -> Route | None:
        """The route's ground truth, when the route is known."""
        return route(self.route) if self.route is not None else None

    @property
    def name(self) -> str:
        """Short label: :attr:`label` when given, else ``phone/route/split/file`` (the source without labels)."""
        if self.label:
            return self.label
        parts = [p for p in (self.phone, self.route, self.split) if p]
        return "/".join(parts + [Path(self.source).name]) if parts else self.source


@dataclass(frozen=True)
class CatalogueEntry:
    """A recording's place in the dataset layout, before it is read.

    Attributes
    ----------
    path : Path
        The CSV file.
    relpath : str
        Its POSIX path below the dataset root.
    phone, route : str
        Labels read from the folders.
    split : str or None
        ``"train"``, ``"test"``, or None for a folder without a split.
    """

    path: Path
    relpath: str
    phone: str
    route: str
    split: str | None

    def load(self) -> Recording:
        """Read and validate the file, with the entry's labels.

        Returns
        -------
        Recording
            :func:`load_csv` of ``path`` with ``phone``, ``route`` and ``split``
            set, checked by :func:`check_plausible`.

        Raises
        ------
        DataError
            Every error of :func:`load_csv` and :func:`check_plausible`.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> root = pathlib.Path(tempfile.mkdtemp())
        >>> (root / "s6" / "L_line").mkdir(parents=True)
        >>> t = np.arange(100) * 0.01
        >>> write_csv(root / "s6" / "L_line" / "1.csv",
        ...           Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)), omega=np.zeros((100, 3))))
        >>> rec = catalogue(root)[0].load()
        >>> rec.name, rec.n
        ('s6/L_line/1.csv', 100)
        """
        return check_plausible(load_csv(self.path, phone=self.phone, route=self.route, split=self.split))


# --------------------------------------------------------------------------- loading

@dataclass(frozen=True)
class ColumnLayout:
    """Where a file other than the dataset's own CSV holds the columns of a table, and in which units.

    A table is a time column followed by groups of three columns: a
    recording's :data:`COLUMNS`, or a truth track's ``("time", "x", "y",
    "z")``. :func:`read_columns` reads a file through a layout with the
    checks of :func:`load_csv`, on the values converted to SI: finite numbers,
    time strictly increasing with no gap above :data:`MAX_GAP_S` and within
    :data:`TIME_LIMIT_S`, specific force (columns ``f_*``) within
    :data:`ACCEL_LIMIT_MPS2` and angular rate (columns ``g_*``) within
    :data:`GYRO_LIMIT_RADPS`; other columns need only be finite.

    A CSV read through a layout may be a logger's export: lines before the
    header (`skip_rows`), columns besides those named (ignored, their cells
    not read), blanks after a comma (also before a quoted field), and a comma
    at the end of every line (an unnamed, empty last column).

    Attributes
    ----------
    columns : tuple of str
        The table's columns: ``"time"`` first, then groups of three.
    names : tuple
        For each of `columns`, its header name (``format="csv"``) or its
        0-based column index (``format="npy"``); None for a time column the
        file does not have (time is then ``k / rate_hz``, from 0).
    format : str
        ``"csv"`` or ``"npy"`` (a 2-D array of numbers, samples on axis 0).
    skip_rows : int
        Lines before the CSV header.
    time_per_s : float
        Units of the file's time per second (1000 for milliseconds): time
        is divided by it.
    factors : tuple of float
        For each column after time, the SI value of one unit of the file
        (standard gravity, :data:`~morpi_filters.units.G0`, for g): the
        column is multiplied by it. Empty: all 1.
    units : tuple of str
        For each column after time, the file's unit, named in messages
        when its factor is not 1. Empty: SI.
    rate_hz : float or None
        Sampling rate [Hz] when the file has no time column.
    time_from_first : bool
        Count time from the first row (its reading subtracted, in the
        file's unit, before the division): for a clock beyond
        :data:`TIME_LIMIT_S`, such as Unix time, whose origin does not matter.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "log.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write('logger v2\\nt_ms, ax, ay, az, gx, gy, gz, temp,\\n0, 0, 0, "1", 0, 0, 90, 21.5,\\n'
    ...                  '10, 0, 0, "1", 0, 0, 90, 21.5,\\n')
    >>> lay = ColumnLayout(COLUMNS, ("t_ms", "ax", "ay", "az", "gx", "gy", "gz"), skip_rows=1,
    ...                    time_per_s=1e3, factors=(G0,) * 3 + (math.pi / 180,) * 3,
    ...                    units=("g",) * 3 + ("deg/s",) * 3)
    >>> time, f, omega = read_columns(path, lay)
    >>> time.tolist(), f[0].tolist() == [0.0, 0.0, G0], round(float(omega[0, 2]), 12)
    ([0.0, 0.01], True, 1.570796326795)
    """

    columns: tuple
    names: tuple
    format: str = "csv"
    skip_rows: int = 0
    time_per_s: float = 1.0
    factors: tuple = ()
    units: tuple = ()
    rate_hz: float | None = None
    time_from_first: bool = False

    def __post_init__(self):
        cols = tuple(self.columns)
        problems = []
        if not cols or cols[0] != "time" or (len(cols) - 1) % 3 or len(cols) < 4:
            problems.append(f"columns {cols}: expected 'time' then groups of three")
        if len(self.names) != len(cols):
            problems.append(f"names: {len(self.names)} given for {len(cols)} columns")
        elif any(n is None for n in self.names[1:]):
            problems.append("names: only the time column may be absent (None)")
        elif self.names[0] is None and not (isinstance(self.rate_hz, (int, float)) and self.rate_hz > 0):
            problems.append("rate_hz: expected a rate > 0 for a file without a time column")
        if self.format not in ("csv", "npy"):
            problems.append(f"format {self.format!r}: expected 'csv' or 'npy'")
        for label, seq in (("factors", self.factors), ("units", self.units)):
            if seq and len(seq) != len(cols) - 1:
                problems.append(f"{label}: {len(seq)} given, expected one per column after time ({len(cols) - 1})")
        if problems:
            raise ParameterError("ColumnLayout: " + "; ".join(problems))

    @property
    def has_time(self) -> bool:
        """Whether the file has a time column."""
        return self.names[0] is not None

    def _present(self) -> list[int]:
        """Indices (in `columns`) of the columns the file holds."""
        return [j for j, n in enumerate(self.names) if n is not None]

    def _factor(self, j: int) -> float:
        return float(self.factors[j - 1]) if self.factors else 1.0

    def _unit(self, j: int) -> str:
        return self.units[j - 1] if self.units else ""


#: The dataset's own CSV format: :data:`COLUMNS` by header name, SI units, nothing else on a line.
_IMU = ColumnLayout(COLUMNS, COLUMNS)


def _limit(column: str):
    """(limit, what, unit, sensor) of a column by its name in the table, or None (finite only)."""
    if column.startswith("f_"):
        return ACCEL_LIMIT_MPS2, "specific force", "m/s^2", "accelerometer"
    if column.startswith("g_"):
        return GYRO_LIMIT_RADPS, "angular rate", "rad/s", "gyro"
    return None


def _header_text(lay: ColumnLayout) -> str:
    if lay is _IMU:
        return ",".join(COLUMNS)
    return "naming the columns " + ", ".join(repr(str(n)) for n in lay.names if n is not None)


def load_csv(path, *, phone=None, route=None, split=None, min_samples: int = MIN_SAMPLES) -> Recording:
    r"""Read one recording and validate it.

    Parameters
    ----------
    path : str or Path
        CSV file whose header names the columns ``time,f_x,f_y,f_z,g_x,g_y,g_z``
        (in any order; standard CSV: quoted fields, a UTF-8 byte-order mark
        and CRLF line ends are accepted): time [s], specific force [m/s^2] and
        angular rate [rad/s] in phone axes.
    phone, route, split : str, optional
        Catalogue labels stored on the result (not checked against the path;
        :func:`load_recording` reads them from it).
    min_samples : int, optional
        Fewest data rows accepted (default :data:`MIN_SAMPLES`).

    Returns
    -------
    Recording
        The samples in the column order of :data:`COLUMNS`, ``source`` set to
        the path. Each value is ``float(cell)`` to the last bit.

    Raises
    ------
    DataError
        With one line naming the file (and line) for: a missing or unreadable
        file, an empty, blank or header-only file, a file that is not UTF-8
        CSV text, missing, repeated or unknown columns, a short or long row,
        a non-numeric cell, NaN or inf, a value beyond :data:`ACCEL_LIMIT_MPS2`
        or :data:`GYRO_LIMIT_RADPS`, a time beyond :data:`TIME_LIMIT_S`, a
        non-increasing or repeated time stamp, a gap above :data:`MAX_GAP_S`,
        or fewer than `min_samples` rows.

    Notes
    -----
    A well-formed file is parsed by pandas' C tokenizer (imported on the
    first call), block by block into arrays allocated once: memory stays near
    the float64 result, 56 bytes per row. Anything the fast reader is not sure
    of (a bad row, a limit broken, an unusual but valid spelling) is decided
    by a line-by-line reading, which names the first bad line. Files in
    other layouts and units are read by :func:`read_columns`.

    Examples
    --------
    Columns in another order are read; a repeated time stamp is named by line:

    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write("f_x,f_y,f_z,g_x,g_y,g_z,time\n0,0,9.8,0,0,0.1,0.00\n0,0,9.8,0,0,0.1,0.01\n")
    >>> rec = load_csv(path, min_samples=2)
    >>> rec.time.tolist(), rec.f[0].tolist(), rec.omega[0].tolist()
    ([0.0, 0.01], [0.0, 0.0, 9.8], [0.0, 0.0, 0.1])
    >>> with open(path, "a") as fh:
    ...     _ = fh.write("0,0,9.8,0,0,0.1,0.01\n")
    >>> load_csv(path, min_samples=2)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: ...: line 4: repeated time stamp 0.01 (line 3 has 0.01), expected strictly increasing time
    """
    path = Path(path)
    time, f, omega = _read(path, _IMU)
    if time.shape[0] < min_samples:
        raise DataError(f"{path}: too few samples: {time.shape[0]} rows, expected at least {min_samples}")
    return Recording(time=time, f=f, omega=omega, source=str(path), phone=phone, route=route, split=split,
                     imu=SENSORS.get(phone))      # the MoRPI catalogue's phones and their IMUs


def read_columns(path, layout: ColumnLayout, *, min_rows: int = 1) -> tuple:
    r"""Read a table (a recording or a truth track) in another layout and units, converted to SI and validated.

    Parameters
    ----------
    path : str or Path
        The CSV or ``.npy`` file (as ``layout.format`` says).
    layout : ColumnLayout
        Where the file holds each column and in which unit.
    min_rows : int, optional
        Fewest rows accepted (default 1).

    Returns
    -------
    tuple of ndarray
        ``(time, group, ...)``: time [s], shape (n,) (``k / rate_hz`` when
        the file has none), and one array of shape (n, 3) per group of three
        columns after it, in SI units; C-contiguous, each value the file's
        number (``float(cell)`` for a CSV) times its factor (time divided by
        ``time_per_s``).

    Raises
    ------
    DataError
        With one line naming the file and the line (a CSV) or the row index
        (an ``.npy`` array): every check of :func:`load_csv`, on the converted
        values; for an ``.npy`` file, one that is not a 2-D array of numbers
        or lacks a column; fewer than `min_rows` rows.

    Examples
    --------
    A truth track in an ``.npy`` array at 10 Hz without a time column:

    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "truth.npy")
    >>> np.save(path, np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.05, 0.0]]))
    >>> lay = ColumnLayout(("time", "n", "e", "d"), (None, 0, 1, 2), format="npy", rate_hz=10.0)
    >>> time, ned = read_columns(path, lay)
    >>> time.tolist(), ned[2].tolist()
    ([0.0, 0.1, 0.2], [0.2, 0.05, 0.0])
    >>> np.save(path, np.array([[0.0, 0.0, np.nan]]))
    >>> read_columns(path, lay)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: ...truth.npy: row index 0: column 2: nan is not finite, expected a real number
    """
    path = Path(path)
    cols = _read(path, layout)
    if cols[0].shape[0] < min_rows:
        raise DataError(f"{path}: too few rows: {cols[0].shape[0]}, expected at least {min_rows}")
    return cols


def check_recording(recording: Recording, *, min_samples: int = MIN_SAMPLES) -> None:
    r"""Apply the checks of :func:`load_csv` to a recording built in memory.

    Parameters
    ----------
    recording : Recording
        The samples (SI units).
    min_samples : int, optional
        Fewest samples accepted (default :data:`MIN_SAMPLES`).

    Returns
    -------
    None
        When every check passes.

    Raises
    ------
    DataError
        One line naming the recording's ``source`` and the first bad row by
        its index: a value that is not finite or beyond a limit, time not
        strictly increasing or with a gap above :data:`MAX_GAP_S`; or fewer
        than `min_samples` samples.

    Examples
    --------
    >>> t = np.arange(200) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (200, 1)), omega=np.zeros((200, 3)), source="mine")
    >>> check_recording(rec)
    >>> rec.time[50] = rec.time[49]
    >>> check_recording(rec)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: mine: row index 50: repeated time stamp 0.49 (row index 49 has 0.49), expected strictly increasing time
    """
    data = np.column_stack([recording.time, recording.f, recording.omega])
    if data.shape[0] < min_samples:
        raise DataError(f"{recording.source}: too few samples: {data.shape[0]} rows, expected at least {min_samples}")
    if not (np.isfinite(data).all() and _within_limits(data)):
        _name_bad_line(data, range(data.shape[0]), recording.source, word="row index")


def _read(path: Path, lay: ColumnLayout) -> tuple:
    """The columns ``(time, group, ...)`` of a file in layout `lay`, parsed once inside :func:`keep_parsed`."""
    key = _kept_key(path)
    if key is not None and lay is not _IMU:
        key = key + (lay,)
    if key is not None and key in _KEPT:
        return _KEPT[key]
    if lay.format == "npy":
        cols = _read_npy(path, lay)
    elif lay is _IMU:
        cols = _fast_parse(path) if path.is_file() else None
        cols = cols if cols is not None else _parse(path)
    else:
        cols = _fast_parse(path, lay) if path.is_file() else None
        cols = cols if cols is not None else _parse(path, lay)
    if cols[0] is None:
        cols = (np.arange(cols[1].shape[0]) / float(lay.rate_hz),) + tuple(cols[1:])
    if key is not None:
        for a in cols:
            a.flags.writeable = False         # shared by every later reading of the file
        _KEPT[key] = cols
    return cols


#: Files parsed inside :func:`keep_parsed`: (path, size, modification time[, layout]) -> (time, f, omega) or
#: the columns of :func:`read_columns`.
_KEPT: dict | None = None


def _kept_key(path: Path):
    if _KEPT is None:
        return None
    try:
        st = path.stat()
    except OSError:
        return None
    return str(path.resolve()), st.st_size, st.st_mtime_ns


@contextmanager
def keep_parsed():
    r"""Within the block, :func:`load_csv` and :func:`read_columns` parse a file once: a later call on the
    unchanged file (same size and modification time, and layout) returns its arrays
    (read-only, shared). Files that fail are read again. For a command that
    checks every recording before its study reads them.

    Yields
    ------
    None
        The files parsed are kept until the outermost block ends.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write("time,f_x,f_y,f_z,g_x,g_y,g_z\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n")
    >>> with keep_parsed():
    ...     a, b = load_csv(path, min_samples=2), load_csv(path, min_samples=2)
    >>> a.time is b.time, a.time.flags.writeable, load_csv(path, min_samples=2).time is a.time
    (True, False, False)
    """
    global _KEPT
    outer = _KEPT
    if outer is None:
        _KEPT = {}
    try:
        yield
    finally:
        if outer is None:
            _KEPT = None


def _csv_fields(line: str, lenient: bool = False) -> list[str]:
    """The fields of one CSV line (standard quoting), stripped of blanks; `lenient` also reads a quoted field
    after blanks (a logger's ``1.5, "2.5"``)."""
    return [c.strip() for c in next(csv.reader([line], skipinitialspace=lenient), [])]


def _header_order(header: list[str], name: str, lay: ColumnLayout = _IMU, line: int = 1) -> list[int] | None:
    """Column index in the file of each column the layout reads, in its order; None when already in order."""
    if lay is not _IMU:
        wanted = [n for n in lay.names if n is not None]
        missing = [n for n in wanted if n not in header]
        repeated = [n for n in wanted if header.count(n) > 1]
        if missing or repeated:
            what = (["missing column(s) " + ", ".join(repr(n) for n in missing)] if missing else []) + \
                   (["repeated column(s) " + ", ".join(repr(n) for n in repeated)] if repeated else [])
            shown = ", ".join(repr(c) for c in header[:12]) + (", ..." if len(header) > 12 else "")
            raise DataError(f"{name}: line {line}: {'; '.join(what)}; the header has {shown}")
        return [header.index(n) for n in wanted]
    if header == list(COLUMNS):
        return None
    missing = [c for c in COLUMNS if c not in header]
    extra = [c for c in header if c not in COLUMNS]
    repeated = sorted({c for c in header if c in COLUMNS and header.count(c) > 1})
    what = []
    if missing:
        what.append("missing column(s) " + ", ".join(missing))
    if extra:
        what.append("unexpected column(s) " + ", ".join(repr(c) for c in extra))
    if repeated:
        what.append("repeated column(s) " + ", ".join(repeated))
    if what:
        raise DataError(f"{name}: line {line}: {'; '.join(what)}; expected the header {','.join(COLUMNS)} "
                        "(in any order)")
    return [header.index(c) for c in COLUMNS]


def _parse(path: Path, lay: ColumnLayout | None = None):
    """Read and validate a file line by line, naming the first bad line; the columns ``(time, f, omega)``
    (``(time or None, group, ...)`` for a layout `lay`).

    The precise path, which decides whatever :func:`_fast_parse` leaves (it is
    tried first). Its rules are the documented ones: UTF-8 text with an
    optional byte-order mark, lines as ``str.splitlines`` cuts them, blank
    lines skipped, each row read by the ``csv`` module and each cell by
    ``float`` (no underscores). The file is read twice in blocks, never held
    whole: a scan for NUL bytes, invalid UTF-8 and content (so those errors
    come first, whatever line they are on), then the rows, kept as float64
    values with their line numbers (64 bytes per row).
    """
    lay = _IMU if lay is None else lay
    name = str(path)
    binary = not_utf8 = False
    content = False
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    try:
        with open(path, "rb") as fh:
            while block := fh.read(_BLOCK_BYTES):
                binary = binary or b"\x00" in block
                if not not_utf8:
                    try:
                        content = bool(decoder.decode(block).strip()) or content
                    except UnicodeDecodeError:
                        not_utf8 = True
            if not not_utf8:
                try:
                    content = bool(decoder.decode(b"", final=True).strip()) or content
                except UnicodeDecodeError:
                    not_utf8 = True
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise DataError(f"{name}: is a directory, expected a CSV file") from None
    except OSError as exc:
        raise DataError(f"{name}: cannot read ({exc.strerror})") from None
    if binary:
        raise DataError(f"{name}: not CSV text (binary content)")
    if not_utf8:
        raise DataError(f"{name}: not CSV text (not UTF-8)")
    if not content:
        raise DataError(f"{name}: empty file, expected the header {_header_text(lay)} and data rows")
    try:
        return _parse_lines(_text_lines(path), name, lay)
    except OSError as exc:
        raise DataError(f"{name}: cannot read ({exc.strerror})") from None


def _text_lines(path: Path):
    """The lines of a UTF-8 file (an optional byte-order mark dropped), exactly as ``str.splitlines`` cuts
    its whole text, decoded block by block."""
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    carry = ""
    with open(path, "rb") as fh:
        while block := fh.read(_BLOCK_BYTES):
            parts = (carry + decoder.decode(block)).splitlines(keepends=True)
            # the last part waits for the next block: it may lack its line end, or end in a "\r" whose "\n" follows
            carry = parts.pop() if parts else ""
            for part in parts:
                yield part.splitlines()[0]
        yield from (carry + decoder.decode(b"", final=True)).splitlines()


def _parse_lines(lines, name: str, lay: ColumnLayout = _IMU):
    """Validate the lines of a table (an iterator), naming the first bad line; ``(time, f, omega)`` (or the
    columns of layout `lay`, time None when the file has none)."""
    lenient = lay is not _IMU
    for k in range(lay.skip_rows):
        if next(lines, None) is None:
            raise DataError(f"{name}: {k} line(s), expected {lay.skip_rows} line(s) before the header "
                            f"(skip_rows) and the header {_header_text(lay)}")
    h = lay.skip_rows + 1
    first = next(lines, "")
    if not first.strip():
        raise DataError(f"{name}: line {h}: blank line before the header {_header_text(lay)}")
    try:
        header = _csv_fields(first, lenient)
    except csv.Error as exc:
        raise DataError(f"{name}: line {h}: not a CSV header ({exc})") from None
    order = _header_order(header, name, lay, h)
    read = list(range(len(COLUMNS))) if order is None else order
    in_file = sorted(read)                      # the cells read, in the file's order
    values, line_of = array.array("d"), array.array("q")
    for i, s in enumerate(lines, start=h + 1):
        if s.strip():
            values.extend(_row_values(s, i, header, name, in_file if lenient else None, lenient))
            line_of.append(i)
    if not line_of:
        raise DataError(f"{name}: header only, no data rows")
    data = np.frombuffer(values, dtype=np.float64).reshape(-1, len(read))
    back = [in_file.index(j) for j in read]
    if back != list(range(len(read))):
        data = data[:, back]
    data = _convert(data, lay)
    if not (np.isfinite(data).all() and _within_limits(data, lay)):
        _name_bad_line(data, line_of, name, lay)
    return _split_columns(data, lay)


def _convert(data: np.ndarray, lay: ColumnLayout) -> np.ndarray:
    """The columns read (in the layout's order, the absent time left out) in SI: time less its first reading
    when ``time_from_first``, divided by ``time_per_s``, each other column times its factor. Unchanged (the
    same array) when nothing is to be done."""
    present = lay._present()
    scale = [(k, j) for k, j in enumerate(present)
             if (j == 0 and lay.time_per_s != 1.0) or (j > 0 and lay._factor(j) != 1.0)]
    shift = lay.has_time and lay.time_from_first
    if not scale and not shift:
        return data
    data = np.array(data, dtype=np.float64)
    if shift and data.shape[0]:
        data[:, 0] -= data[0, 0]
    for k, j in scale:
        if j == 0:
            data[:, k] /= lay.time_per_s
        else:
            data[:, k] *= lay._factor(j)
    return data


def _split_columns(data: np.ndarray, lay: ColumnLayout) -> tuple:
    """``(time or None, group, ...)`` of the converted columns, each C-contiguous."""
    k = 1 if lay.has_time else 0
    time = np.ascontiguousarray(data[:, 0]) if lay.has_time else None
    groups = tuple(np.ascontiguousarray(data[:, p:p + 3]) for p in range(k, data.shape[1], 3))
    return (time,) + groups


def _read_npy(path: Path, lay: ColumnLayout) -> tuple:
    """The columns ``(time or None, group, ...)`` of an ``.npy`` array, converted and validated."""
    name = str(path)
    try:
        with open(path, "rb") as fh:
            magic = fh.read(6)
        if magic != b"\x93NUMPY":
            raise DataError(f"{name}: not a .npy array file (it does not start with the NumPy format's "
                            "header), expected one 2-D array written by numpy.save")
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise DataError(f"{name}: is a directory, expected a .npy file") from None
    except (ValueError, OSError, EOFError) as exc:
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise DataError(f"{name}: not a .npy array file ({reason})") from None
    if arr.ndim != 2:
        raise DataError(f"{name}: array of shape {arr.shape}, expected 2-D (samples, columns)")
    if arr.dtype.kind not in "fiu":
        raise DataError(f"{name}: array of {arr.dtype}, expected numbers (float or integer)")
    index = [lay.names[j] for j in lay._present()]
    beyond = [f"{i} ({lay.columns[j]})" for j, i in zip(lay._present(), index) if i >= arr.shape[1]]
    if beyond:
        raise DataError(f"{name}: no column {', '.join(beyond)}: the array has {arr.shape[1]} column(s), "
                        f"indices 0 to {arr.shape[1] - 1}")
    if arr.shape[0] == 0:
        raise DataError(f"{name}: no rows")
    data = _convert(np.array(arr[:, index], dtype=np.float64), lay)
    del arr
    if not (np.isfinite(data).all() and _within_limits(data, lay)):
        _name_bad_line(data, range(data.shape[0]), name, lay, word="row index")
    return _split_columns(data, lay)


#: The bytes a data line may hold for the C reader to take the file: digits, the characters of a
#: decimal number (sign, point, exponent), comma, blank, double quote and the line ends. Anything else
#: (letters of nan/inf, tabs, NUL, other line breaks, non-ASCII) sends the file to the precise path.
_DATA_BYTES = b"0123456789.eE+-, \"\r\n"
#: Characters a header line may not hold for the C reader to take the file: NUL and the line
#: boundaries of ``str.splitlines`` other than the ``\n`` that ends it.
_HEADER_BREAKS = ("\x00", "\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")
#: Bytes read at a time; a file up to :data:`_KEEP_BYTES` is read at once, a larger one twice (a count
#: of its lines, then the parse into arrays of that many rows, block by block).
_BLOCK_BYTES = 1 << 19
_KEEP_BYTES = 8 << 20
#: Bytes read to find the header line of a file above :data:`_KEEP_BYTES`.
_HEAD_BYTES = 1 << 16


def _line_blocks(fh):
    """Blocks of a binary file, from where it stands, that each end at a ``\\n`` (the last one as the file ends)."""
    carry = b""
    while True:
        block = fh.read(_BLOCK_BYTES)
        if not block:
            if carry:
                yield carry
            return
        block = carry + block
        cut = block.rfind(b"\n") + 1
        carry = block[cut:]
        if cut:
            yield block[:cut]


@lru_cache(maxsize=1)
def _pandas_options() -> dict:
    """Options of ``pandas.read_csv`` for correctly rounded floats, bit-identical to ``float(cell)``."""
    import pandas as pd

    return _float_options(pd.__version__)


def _float_options(version: str) -> dict:
    """:func:`_pandas_options` for a pandas version string.

    From pandas 3.1 the C engine has one float converter, fast_float, which
    rounds correctly; earlier versions round correctly only with the
    ``round_trip`` converter (Python's own; their default, ``high``, is off by
    one unit in the last place on about a quarter of 17-digit numbers).
    """
    major, minor = (int(x) for x in re.match(r"(\d+)\.(\d+)", version).groups())
    return {} if (major, minor) >= (3, 1) else {"float_precision": "round_trip"}


def _fast_parse(path: Path, lay: ColumnLayout | None = None):
    """The columns ``(time, f, omega)`` of a well-formed file, read by pandas' C tokenizer, or None.

    None means "let the precise path decide" (:func:`_parse`, which names the
    bad line when there is one). The fast path takes a file only when it can
    be sure of the precise path's answer: a header line that is exactly the
    columns (any order, standard quoting, an optional byte-order mark), data
    lines made only of :data:`_DATA_BYTES` with ``\\r`` only in ``\\r\\n`` and
    an even number of quotes each, every row seven numbers, every value finite
    and within the limits, time strictly increasing with no gap above
    :data:`MAX_GAP_S`. Floats are correctly rounded (:func:`_pandas_options`):
    bit-identical to ``float(cell)``.

    Through a layout `lay` (``(time or None, group, ...)``): the `skip_rows`
    lines before the header free of line breaks other than ``\\n`` (or
    ``\\r\\n``), a header naming each column read once, and every data line
    holding as many fields as the header (its commas outside quotes counted),
    blank lines aside; the values read are converted before the limits.

    A file up to :data:`_KEEP_BYTES` is read at once. A longer one is read
    twice in blocks: once to count its lines, then block by block (each
    ending at a line end) into arrays allocated for that many rows, so memory
    stays near the float64 result (56 bytes per row) whatever its length.
    """
    lay = _IMU if lay is None else lay
    try:
        with open(path, "rb") as fh:
            whole = os.fstat(fh.fileno()).st_size <= _KEEP_BYTES
            head = fh.read() if whole else fh.read(_HEAD_BYTES)
            start = 0
            for _ in range(lay.skip_rows):
                start = head.find(b"\n", start) + 1
                if not start:
                    return None
            if start and not _plain_preamble(head[:start]):
                return None
            end = head.find(b"\n", start)
            header = _fast_header(head[start:end], lay, bom=start == 0) if end >= 0 else None
            if header is None:
                return None
            order = [header.index(c) for c in COLUMNS] if lay is _IMU else \
                [header.index(n) for n in lay.names if n is not None]
            if whole:
                rest = head[end + 1:]
                del head
                return _fast_columns([rest], None, order, lay, len(header))
            del head
            fh.seek(end + 1)
            n_lines = 1
            while chunk := fh.read(_BLOCK_BYTES):
                n_lines += chunk.count(b"\n")
            del chunk
            fh.seek(end + 1)
            return _fast_columns(_line_blocks(fh), n_lines, order, lay, len(header))
    except OSError:
        return None


def _plain_preamble(block: bytes) -> bool:
    """Whether the lines before a header (ending at a ``\\n``) are UTF-8 with no line break of
    ``str.splitlines`` but their ``\\n`` (or ``\\r\\n``), so both readers count them alike."""
    try:
        text = block.decode("utf-8-sig")
    except UnicodeDecodeError:
        return False
    return not any(c in text.replace("\r\n", "\n") for c in _HEADER_BREAKS)


def _plain_block(block: bytes) -> bool:
    """Whether data lines hold only :data:`_DATA_BYTES`, ``\\r`` only before ``\\n``, and an even number of
    quotes on each line (so no quoted field runs across a line end, where the C reader and a line-by-line
    reading would split the fields differently)."""
    if block.translate(None, _DATA_BYTES) or (b"\r" in block and block.count(b"\r") != block.count(b"\r\n")):
        return False
    if b'"' not in block:
        return True
    a = np.frombuffer(block, dtype=np.uint8)
    parity = np.cumsum(a == ord('"'), dtype=np.uint8) & 1     # quotes so far, mod 2 (the uint8 sum wraps at 256)
    return not parity[-1] and not parity[a == ord("\n")].any()


def _fields_per_line(block: bytes, width: int) -> bool:
    """Whether every line of a plain block (:func:`_plain_block`) holds `width` fields (its commas outside
    quotes counted) or is blank: the C reader would fill a short row's missing cells with NaN, which
    a column left unread would not show."""
    a = np.frombuffer(block, dtype=np.uint8)
    ends = np.flatnonzero(a == ord("\n"))
    if a.size and a[-1] != ord("\n"):
        ends = np.append(ends, a.size)
    if not ends.size:
        return True
    comma = a == ord(",")
    if b'"' in block:
        comma &= (np.cumsum(a == ord('"'), dtype=np.uint8) & 1) == 0
    per_line = np.bincount(np.searchsorted(ends, np.flatnonzero(comma)), minlength=ends.size)
    starts = np.concatenate([[0], ends[:-1] + 1])
    return all(not block[starts[k]:ends[k]].strip() for k in np.flatnonzero(per_line != width - 1))


def _fast_header(line: bytes, lay: ColumnLayout | None = None, *, bom: bool = True) -> list[str] | None:
    """The header's column names when the line is exactly a permutation of :data:`COLUMNS` (or, for a
    layout, names each column read once), else None. A byte-order mark is dropped when `bom` (the file's
    first line)."""
    lay = _IMU if lay is None else lay
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError:
        return None
    text = text[1:] if bom and text.startswith("\ufeff") else text
    text = text[:-1] if text.endswith("\r") else text
    if any(c in text for c in _HEADER_BREAKS) or text.count('"') % 2:
        return None
    try:
        header = _csv_fields(text, lay is not _IMU)
    except csv.Error:
        return None
    if lay is not _IMU:
        return header if all(header.count(n) == 1 for n in lay.names if n is not None) else None
    return header if len(header) == len(COLUMNS) and sorted(header) == sorted(COLUMNS) else None


def _fast_columns(blocks, capacity: int | None, order: list[int], lay: ColumnLayout | None = None,
                  width: int = len(COLUMNS)):
    """Parse blocks of data lines into C-ordered ``(time, f, omega)`` (the groups of a layout); None at
    the first doubt.

    `capacity` bounds the number of rows (the arrays are allocated once); None when `blocks`
    holds one block, whose rows then set it. `order` holds the file's index of each column read,
    `width` the number of fields of a line.
    """
    lay = _IMU if lay is None else lay
    lenient = lay is not _IMU
    present = lay._present()
    pos_t = 0 if lay.has_time else None
    first = 1 if lay.has_time else 0
    group_idx = [order[p:p + 3] for p in range(first, len(order), 3)]
    group_cols = [present[p:p + 3] for p in range(first, len(present), 3)]
    limits = [_limit(lay.columns[cols[0]]) for cols in group_cols]
    # a short row's missing cells are NaN, which the limits refuse in a column read: the fields are counted
    # only when some column is left unread
    counted = lenient and len(order) < width
    if capacity is None:
        (block,) = blocks
        rows = _read_rows(block, width, lenient, counted)
        if rows is None:
            return None
        parsed, capacity = iter([rows]), rows.shape[0]
        del rows
    else:
        parsed = (_read_rows(block, width, lenient, counted) for block in blocks)
    time = np.empty(capacity) if pos_t is not None else None
    groups = [np.empty((capacity, 3)) for _ in group_idx]
    n, prev_t, t_first = 0, None, None
    for rows in parsed:
        if rows is None:
            return None
        m = rows.shape[0]
        if n + m > capacity:
            return None
        t = None
        if time is not None:
            t = time[n:n + m]
            t[:] = rows[:, order[pos_t]]
            if lay.time_from_first and m:
                t_first = t[0] if t_first is None else t_first
                t -= t_first
            if lay.time_per_s != 1.0:
                t /= lay.time_per_s
        parts = []
        for g, idx, cols in zip(groups, group_idx, group_cols):
            part = g[n:n + m]
            for j in range(3):      # column by column: pandas' rows are in Fortran order
                part[:, j] = rows[:, idx[j]]
                if lay._factor(cols[j]) != 1.0:
                    part[:, j] *= lay._factor(cols[j])
            parts.append(part)
        if not _block_within_limits(t, parts, limits, prev_t):
            return None
        n += m
        prev_t = t[-1] if m and t is not None else prev_t
    if n == 0:
        return None
    out = [time] + groups
    if n < capacity:       # blank lines and the final line end: a trimmed copy only when much is spare
        out = [None if a is None else (a[:n] if n > capacity // 2 else a[:n].copy()) for a in out]
    return tuple(out)


def _read_rows(block: bytes, width: int = len(COLUMNS), lenient: bool = False,
               counted: bool = False) -> np.ndarray | None:
    """The rows of a block of data lines as float64, shape (m, width) (m = 0 for blank lines); None when the
    bytes are not plain (:func:`_plain_block`), pandas' C reader refuses them (a cell that is not a
    number, a long row) or they are not `width` columns (`counted`: a line of another width,
    :func:`_fields_per_line`). `lenient` skips the spaces that start a field."""
    import warnings

    import pandas as pd

    if not _plain_block(block) or (counted and not _fields_per_line(block, width)):
        return None
    if not block or block.isspace():
        return np.empty((0, width))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            frame = pd.read_csv(io.BytesIO(block), header=None, index_col=False, dtype=np.float64,
                                engine="c", low_memory=False, skipinitialspace=lenient, **_pandas_options())
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    rows = frame.to_numpy(dtype=np.float64)
    return rows if rows.ndim == 2 and rows.shape[1] == width else None


def _block_within_limits(t, groups, limits, prev_t) -> bool:
    """Whether rows are finite and within every limit (NaN fails every comparison), time following `prev_t`.
    `t` is None for a table without time; `limits` holds one :func:`_limit` (or None: finite) per group."""
    if t is not None and t.size:
        dt = np.diff(t) if prev_t is None else np.diff(t, prepend=prev_t)
        if not (t.max() <= TIME_LIMIT_S and -t.min() <= TIME_LIMIT_S and (dt > 0).all() and (dt <= MAX_GAP_S).all()):
            return False
    for g, lim in zip(groups, limits):
        if not g.size:
            continue
        if lim is None:
            if not np.isfinite(g).all():
                return False
        elif not (g.max() <= lim[0] and -g.min() <= lim[0]):
            return False
    return True


def _within_limits(data: np.ndarray, lay: ColumnLayout = _IMU) -> bool:
    """Whether finite rows (columns in the layout's order, the absent time left out) are within every limit."""
    present = lay._present()
    ok = True
    if lay.has_time:
        t = data[:, 0]
        dt = np.diff(t)
        ok = bool(np.abs(t).max() <= TIME_LIMIT_S and (dt > 0).all() and (dt <= MAX_GAP_S).all())
    for k, j in enumerate(present):
        lim = _limit(lay.columns[j]) if j else None
        if ok and lim is not None:
            ok = bool(np.abs(data[:, k]).max() <= lim[0])
    return ok


def _name_bad_line(data: np.ndarray, line_of, name: str, lay: ColumnLayout = _IMU, word: str = "line") -> None:
    """Raise the error of the first row that breaks a limit (the data parsed as numbers and converted, `line_of`
    the line number of each row, or its index: `word`)."""
    present = lay._present()
    cols = [str(lay.names[j]) for j in present]
    timed = lay.has_time
    checked = [(k, j, _limit(lay.columns[j])) for k, j in enumerate(present) if j and _limit(lay.columns[j])]
    prev_t = -math.inf
    for k in range(data.shape[0]):
        row, i = data[k], line_of[k]
        for j, col in enumerate(cols):
            v = float(row[j])
            if not math.isfinite(v):
                raise DataError(f"{name}: {word} {i}: column {col}: {v} is not finite, expected a real number")
        t = float(row[0]) if timed else 0.0
        if timed and abs(t) > TIME_LIMIT_S:
            raise DataError(f"{name}: {word} {i}: column {cols[0]}: {t!r} s is beyond the limit of "
                            f"+-{TIME_LIMIT_S:g} s, expected a plausible clock reading")
        for c, j, (limit, what, unit, sensor) in checked:
            v = float(row[c])
            if abs(v) > limit:
                read = f" (converted from {lay._unit(j)})" if lay._factor(j) != 1.0 and lay._unit(j) else ""
                raise DataError(f"{name}: {word} {i}: column {cols[c]}: {what} {v!r} {unit}{read} is beyond "
                                f"+-{limit:.4g} {unit}, the {sensor} full scale of a phone IMU")
        if timed and k:
            if t <= prev_t:
                what = "repeated" if t == prev_t else "decreasing"
                raise DataError(f"{name}: {word} {i}: {what} time stamp {t!r} ({word} {line_of[k - 1]} has "
                                f"{prev_t!r}), expected strictly increasing time")
            if t - prev_t > MAX_GAP_S:
                raise DataError(f"{name}: {word} {i}: time gap of {t - prev_t:.6g} s after {word} "
                                f"{line_of[k - 1]}, expected at most {MAX_GAP_S:g} s between samples")
        prev_t = t
    raise AssertionError("limits broken but no row found")  # pragma: no cover


def _row_values(s: str, i: int, header: list[str], name: str, read=None, lenient: bool = False) -> list[float]:
    """The numbers of data line `i` (text `s`, cells in the file's column order), or the error naming it.
    `read`: the indices of the cells to read (ascending); None reads every cell."""
    if '"' in s:
        try:
            cells = _csv_fields(s, lenient)
        except csv.Error as exc:
            raise DataError(f"{name}: line {i}: not a CSV row ({exc})") from None
    else:       # without quotes the csv module splits at every comma
        cells = [c.strip() for c in s.split(",")]
    if len(cells) != len(header):
        kind = "short" if len(cells) < len(header) else "long"
        raise DataError(f"{name}: line {i}: {kind} row, {len(cells)} fields, expected {len(header)}")
    vals = []
    for j in (range(len(cells)) if read is None else read):
        c = cells[j]
        try:
            if "_" in c:
                raise ValueError(c)
            v = float(c)
        except ValueError:
            raise DataError(f"{name}: line {i}: column {header[j]}: {c!r} is not a number") from None
        if not math.isfinite(v):
            raise DataError(f"{name}: line {i}: column {header[j]}: {c} is not finite, expected a real number")
        vals.append(v)
    return vals


# --------------------------------------------------------------------------- plausibility at rest

#: Still-stretch search of :func:`rest_problems`: blocks of this length [s] ...
_STILL_BLOCK_S = 0.5
#: ... each still when every gyro column's peak-to-peak stays within this multiple of its quietest
#: block's (at least one quantization step): the peak-to-peak of white noise over a block of 50
#: samples is about 4.5 sigma and rarely leaves 3 to 6.5 sigma, so rest blocks stay within about
#: twice the quietest one, while a turn or a hand moves the gyro by hundreds of noise sigmas.
_STILL_RATIO = 4.0
#: Shortest and longest still stretch used [blocks]: 1 to 3 s (the paper calibrates on 3 s).
_STILL_BLOCKS = (2, 6)
#: Fewest samples a block needs to count (a block at a gap or at the end may hold a few).
_STILL_MIN_SAMPLES = 5


def _still_stretch(time: np.ndarray, omega: np.ndarray) -> tuple[int, int]:
    """Sample slice ``(i0, i1)`` of the first still stretch of a recording.

    The recording is cut into blocks of :data:`_STILL_BLOCK_S` from its first
    sample; a block is still when the peak-to-peak of each gyro column is at
    most :data:`_STILL_RATIO` times that column's quietest block (floored at
    its smallest step, the quantization). The stretch is the first run of at
    least ``_STILL_BLOCKS[0]`` still blocks, cut at ``_STILL_BLOCKS[1]``; when
    there is none, the quietest block. Stillness is read from the gyro
    columns alone, each against itself, so it does not depend on their units:
    the phones' accelerometer channels are low-pass filtered and settle during
    the first seconds (whole blocks of repeated values, then slow drifts, in
    the field recordings), while a hand or a turn shows on the gyro.
    """
    n = time.shape[0]
    block = np.floor((time - time[0]) / _STILL_BLOCK_S)
    starts = np.concatenate(([0], np.flatnonzero(block[1:] != block[:-1]) + 1))
    ends = np.concatenate((starts[1:], [n]))
    ptp = np.maximum.reduceat(omega, starts, axis=0) - np.minimum.reduceat(omega, starts, axis=0)
    counted = (ends - starts) >= _STILL_MIN_SAMPLES
    if not counted.any():
        return 0, n
    ref = ptp[counted].min(axis=0)
    for j in np.flatnonzero(ref == 0):              # a block without a change: its quantization step instead
        steps = np.abs(np.diff(omega[:, j]))
        ref[j] = steps[steps > 0].min() if (steps > 0).any() else 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(ptp > 0, ptp / ref, 0.0).max(axis=1)      # a column never moving: ratio 0
    still = counted & (ratio <= _STILL_RATIO)
    shortest, longest = _STILL_BLOCKS
    b = 0
    while b < still.size:
        if still[b]:
            e = b
            while e + 1 < still.size and still[e + 1]:
                e += 1
            if e - b + 1 >= shortest:
                return int(starts[b]), int(ends[min(e, b + longest - 1)])
            b = e + 1
        else:
            b += 1
    quiet = choose(np.where(counted, ratio, np.inf))                # the first of ties (choice.choose)
    return int(starts[quiet]), int(ends[quiet])


def _gyro_noise(omega: np.ndarray) -> np.ndarray:
    """White-noise standard deviation per gyro axis, from the median absolute sample-to-sample change.

    For white noise of standard deviation sigma the changes have standard deviation sqrt(2) sigma and
    their median absolute value is 0.6745 of it; the median ignores a few outliers. Zeros with fewer
    than three samples.
    """
    if omega.shape[0] < 3:
        return np.zeros(omega.shape[1])
    return np.median(np.abs(np.diff(omega, axis=0)), axis=0) / (0.6745 * math.sqrt(2.0))


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"


#: Least share of a column's successive changes that turn back for a recording without a known rest
#: (``rest="none"``) to count as carrying sensor noise (so that a column that never moves is a dead
#: channel): white noise turns back in 2/3 of its sample-to-sample changes (two consecutive differences
#: of independent samples correlate by -1/2), while motion sampled far above its bandwidth turns back
#: only at its extremes; the bound lies halfway between 0 and 2/3.
_NOISE_TURNS = 1.0 / 3.0


def _turns_like_noise(x: np.ndarray) -> bool:
    """Whether some column of `x` changes direction between successive samples as white noise does."""
    for j in range(x.shape[1]):
        d = np.diff(x[:, j])
        d = d[d != 0]
        if d.size > 2 and float(np.mean(np.sign(d[1:]) != np.sign(d[:-1]))) > _NOISE_TURNS:
            return True
    return False


@dataclass(frozen=True)
class RestProblem:
    """One way a recording is implausible for an IMU in SI units and the z-up frame (:func:`rest_problems`).

    Attributes
    ----------
    kind : str
        What is wrong, as the setting to fix: ``"dead_channel"`` (a sensor
        column that never moves), ``"accel_unit"`` (the specific force's
        magnitude is not gravity's), ``"axes"`` (gravity not up the z axis),
        ``"gyro_unit"`` (rates beyond a gyro's offset or noise at rest, or
        beyond a ground robot's turns) or ``"columns"`` (specific force under
        the gyro columns).
    cause : str
        The finding within its kind: ``"dead"``; ``"in_g"``, ``"no_gravity"``,
        ``"not_gravity"``; ``"z_down"``, ``"across"``; ``"rest_bias"``,
        ``"rest_noise"``, ``"percentile"``; ``"gravity_on_gyro"``.
    message : str
        One line starting with the recording's source: what was read, what
        was expected and the likely cause.
    value : float
        The figure that broke the bound, SI: the magnitude of the rest
        specific force [m/s^2] (``accel_unit``, ``columns``), its share on +z
        (``axes``), the largest rest rate or noise [rad/s] or the rate
        percentile [rad/s] (``gyro_unit``); NaN for a dead channel.
    bound : float
        The bound it broke, in the same unit.
    column : str
        The column named (``"f_x"`` ... ``"g_z"``), or ``""``.
    f_rest : tuple of float
        The median specific force over the rest, or over the recording
        without one [m/s^2].
    """

    kind: str
    cause: str
    message: str
    value: float
    bound: float
    column: str
    f_rest: tuple


def _rest_slice(rec: Recording, rest) -> tuple[int, int] | None:
    """Sample slice of the rest: the first still stretch (``"auto"``), a window ``(t0, t1)`` [s from the first
    sample], or None (``"none"``)."""
    if isinstance(rest, str) and rest == "auto":
        return _still_stretch(rec.time, rec.omega)
    if isinstance(rest, str) and rest == "none":
        return None
    try:
        if isinstance(rest, str):
            raise ValueError(rest)
        t0, t1 = (float(v) for v in rest)
    except (TypeError, ValueError):
        raise ParameterError(f"{rec.source}: rest={rest!r}, expected 'auto', 'none' or (t0, t1) in seconds from "
                             "the first sample") from None
    t = rec.time - rec.time[0]
    inside = np.flatnonzero((t >= t0) & (t <= t1))
    if inside.size < 2:
        raise ParameterError(f"{rec.source}: rest=({t0:g}, {t1:g}) holds {inside.size} sample(s), expected a "
                             "window of several samples inside the recording")
    return int(inside[0]), int(inside[-1]) + 1


def rest_problems(rec: Recording, *, spec: SensorSpec | None = None, rest="auto") -> tuple:
    """Every way a recording is implausible for an IMU in SI units and the z-up frame, structured.

    The one home of these checks: the MoRPI catalogue (:func:`plausibility_problems`,
    :func:`check_plausible`, ``morpi check --data``) and dataset manifests
    (:func:`morpi_filters.manifest.load_dataset`, ``morpi check --dataset``)
    both call it. The checks read the recording's rest: its first still
    stretch (``rest="auto"``: the MoRPI recordings start at rest; a handling
    disturbance before the rest is skipped), a known window, or none. Each
    bound is a sensor or physics figure, given with its source beside its
    constant, and scales with the sensor's error figures `spec`:

    - dead channel: a sensor column that reads the same value in every sample
      (all zero, or stuck), when the recording carries sensor noise (some
      column moves during the rest; without a rest, some column turns back
      between successive samples as often as white noise does); a
      noise-free synthetic recording is not judged on this;
    - gravity: the magnitude of the median specific force over the rest (over
      the recording with ``rest="none"``: a ground robot's accelerations
      average out beside gravity) within :data:`GRAVITY_BAND_MPS2` of
      :data:`G0` (for `spec`: three zero-g offsets, the sensitivity
      tolerance and the place on Earth); an accelerometer in g, one without
      gravity, or specific force on the gyro columns is named;
    - up axis: ``f_z`` at least :data:`UP_FRACTION_MIN` of that magnitude,
      positive (gravity on x or y, or a z-down frame, is named);
    - gyro at rest (not with ``rest="none"``): each axis's median within
      three zero-rate offsets of `spec` (:data:`GYRO_REST_LIMIT_RADPS`) and
      its white noise within :data:`GYRO_NOISE_FACTOR` times the noise
      density of `spec` at the rest's sampling rate (deg/s, or gravity on a
      gyro column, is named);
    - turns: the 99th percentile of the rate's magnitude over the recording
      within :data:`MOVING_RATE_LIMIT_RADPS` (said when the rest found the
      gyro plausible, or without a rest).

    Parameters
    ----------
    rec : Recording
        The recording in SI units and the body or phone frame (z up).
    spec : SensorSpec, optional
        The IMU's error figures; default :data:`MEMS_SPEC`.
    rest : str or tuple of float
        ``"auto"`` (the first still stretch), ``"none"`` (no rest is assumed:
        only dead channels, gravity over the recording and the turns are
        checked) or ``(t0, t1)``: the rest window in seconds from the first
        sample.

    Returns
    -------
    tuple of RestProblem
        In the order above; empty when the recording is plausible.

    Raises
    ------
    ParameterError
        A `rest` that is none of the three forms, or a window holding fewer
        than two samples.

    Examples
    --------
    A level IMU at rest whose z axis points down:

    >>> rng = np.random.default_rng(2)
    >>> t = np.arange(300) * 0.01
    >>> f = [0.1, 0.0, -9.8] + 0.02 * rng.standard_normal((300, 3))
    >>> w = 0.002 * rng.standard_normal((300, 3))
    >>> [(p.kind, p.cause) for p in rest_problems(Recording(time=t, f=f, omega=w))]
    [('axes', 'z_down')]
    """
    spec = MEMS_SPEC if spec is None else spec
    if rec.n == 0:
        return ()
    src = rec.source
    out = []
    window = _rest_slice(rec, rest)
    i0, i1 = window if window is not None else (0, rec.n)
    resting = np.concatenate((rec.f[i0:i1], rec.omega[i0:i1]), axis=1)
    noisy = (resting.max(axis=0) > resting.min(axis=0)).any() if window is not None else \
        _turns_like_noise(resting)
    f_mean, w_mean = np.split(np.median(resting, axis=0), 2)
    f_rest = tuple(float(v) for v in f_mean)

    def add(kind, cause, message, value=math.nan, bound=math.nan, column=""):
        out.append(RestProblem(kind, cause, message, float(value), float(bound), column, f_rest))

    if noisy:
        dead = np.concatenate([np.maximum.reduceat(x, [0], axis=0)[0] == np.minimum.reduceat(x, [0], axis=0)[0]
                               for x in (rec.f, rec.omega)])     # (reduceat: much faster than max(axis=0) here)
        first = np.concatenate((rec.f[0], rec.omega[0]))
        for j in np.flatnonzero(dead):
            v, col = float(first[j]), COLUMNS[1 + j]
            what = "all zero" if v == 0 else f"stuck at {v!r}"
            add("dead_channel", "dead", f"{src}: column {col} is {what} in all {rec.n} samples: a dead channel, "
                "expected a live sensor (white noise moves every MEMS axis, as the recording's other columns move "
                "at rest)", column=col)
    mag, w_mag = float(np.linalg.norm(f_mean)), float(np.linalg.norm(w_mean))
    band = _gravity_band(spec)
    gravity_ok = abs(mag - G0) <= band
    in_g = abs(mag * G0 - G0) <= band
    gravity_on_gyro = abs(w_mag - G0) <= band
    expect_f = f"expected |f| = {G0:.2f} +- {band:.2f} m/s^2"
    if not gravity_ok:
        kind = "accel_unit"
        if in_g:
            cause, hint = "in_g", "looks like the accelerometer is in g, not m/s^2"
        elif gravity_on_gyro:
            kind, cause = "columns", "gravity_on_gyro"
            hint = (f"the gyro columns carry it instead (|w| = {w_mag:.3g} at rest, w = {_vec(w_mean)}): "
                    "looks like specific-force and angular-rate columns swapped under their header")
        elif mag < band:
            cause = "no_gravity"
            hint = "no gravity: looks like linear acceleration (gravity removed) or a column that is not specific force"
        else:
            cause = "not_gravity"
            hint = "not the gravity a phone at rest reads: another unit or another quantity under the header"
        add(kind, cause, f"{src}: specific force at rest is {mag:.2f} m/s^2 (f = {_vec(f_mean)}), {expect_f}: {hint}",
            mag, band)
    if gravity_ok or in_g:
        share = f_mean[2] / mag
        if share < UP_FRACTION_MIN:
            if -share >= UP_FRACTION_MIN:
                add("axes", "z_down", f"{src}: f_z at rest is {f_mean[2]:.3g} (f = {_vec(f_mean)}), expected +|f| on "
                    "z (the phone frame is z up): a z-down frame (north-east-down axes) or a phone lying face down",
                    share, UP_FRACTION_MIN, "f_z")
            else:
                j = int(np.argmax(np.abs(f_mean)))
                other = COLUMNS[1 + j]
                cause = (f"looks like {other} and f_z swapped under their header, or a phone standing on its edge"
                         if j < 2 else "a phone tilted beyond 45 deg")
                add("axes", "across", f"{src}: gravity at rest is on {other} (f = {_vec(f_mean)}), expected at least "
                    f"{UP_FRACTION_MIN:.2f} of |f| on +f_z (the phone frame is z up): {cause}", share,
                    UP_FRACTION_MIN, other)
    rest_limit = 3 * spec.gyro_bias
    gyro_said = gravity_on_gyro
    if window is not None:
        noise = _gyro_noise(resting[:, 3:])
        dt = np.diff(rec.time[i0:i1] if i1 - i0 > 1 else rec.time)
        rate = float(1.0 / np.median(dt)) if dt.size else 100.0      # the rest's median sampling rate [Hz]
        noise_limit = GYRO_NOISE_FACTOR * spec.gyro_noise * math.sqrt(rate)
        bias_bad = np.abs(w_mean) > rest_limit
        noise_bad = noise > noise_limit
        if bias_bad.any() or noise_bad.any():
            gyro_said = True
            said = []
            jb, jn = int(np.argmax(np.abs(w_mean))), int(np.argmax(noise))
            if bias_bad.any():
                said.append(f"mean {w_mean[jb]:.3g} rad/s on {COLUMNS[4 + jb]} (expected within "
                            f"+-{rest_limit:.2f} rad/s, three zero-rate offsets)")
            if noise_bad.any():
                said.append(f"noise {noise[jn]:.3g} rad/s on {COLUMNS[4 + jn]} (expected at most {noise_limit:.3g} "
                            f"rad/s, {GYRO_NOISE_FACTOR:g} times the datasheet noise at {rate:.0f} Hz)")
            as_deg = (np.abs(w_mean) * DEG <= rest_limit).all() and (noise * DEG <= noise_limit).all()
            odd = np.flatnonzero(bias_bad | noise_bad)
            kind = "gyro_unit"
            if gravity_on_gyro:
                # said with the specific force when the accelerometer lacks it
                kind, hint = "columns", "looks like gravity, specific force under a gyro header" if gravity_ok else None
            elif as_deg and odd.size > 1:            # deg/s scales every axis, its noise too
                hint = "looks like deg/s, not rad/s"
            elif as_deg:
                hint = f"looks like deg/s (not rad/s), or specific force under the {COLUMNS[4 + odd[0]]} header"
            else:
                hint = "the gyro columns do not read a gyro at rest: another unit or another quantity under the header"
            if hint is not None:
                if kind == "columns":
                    cause, value, bound, col = "gravity_on_gyro", w_mag, band, ""
                elif bias_bad.any():
                    cause, value, bound, col = "rest_bias", abs(w_mean[jb]), rest_limit, COLUMNS[4 + jb]
                else:
                    cause, value, bound, col = "rest_noise", noise[jn], noise_limit, COLUMNS[4 + jn]
                add(kind, cause, f"{src}: angular rate at rest: {'; '.join(said)}: {hint}", value, bound, col)
    if not gyro_said:
        p99 = float(np.percentile(np.linalg.norm(rec.omega, axis=1), 99))
        if p99 > MOVING_RATE_LIMIT_RADPS:
            add("gyro_unit", "percentile", f"{src}: angular rate: 1 % of the samples exceed {p99:.3g} rad/s, expected "
                f"at most {MOVING_RATE_LIMIT_RADPS:g} rad/s (a ground robot's turns): looks like deg/s, not rad/s, "
                "or another quantity under the gyro header", p99, MOVING_RATE_LIMIT_RADPS)
    return tuple(out)


def plausibility_problems(rec: Recording) -> list[str]:
    """One line per way a recording of the MoRPI layout is implausible for a phone IMU in SI units and z up.

    The lines of :func:`rest_problems` with the phones' error figures
    (:data:`MEMS_SPEC`) and the first still stretch as the rest.

    Parameters
    ----------
    rec : Recording
        The recording, as loaded (SI units claimed, phone axes).

    Returns
    -------
    list of str
        The problems, each one line starting with ``rec.source``; empty when
        the recording is plausible.

    Examples
    --------
    A phone at rest, then the same recording with the accelerometer written in g:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(400) * 0.01
    >>> f = [0.1, -0.2, 9.8] + 0.02 * rng.standard_normal((400, 3))
    >>> w = [0.01, 0.0, -0.02] + 0.002 * rng.standard_normal((400, 3))
    >>> plausibility_problems(Recording(time=t, f=f, omega=w, source="a.csv"))
    []
    >>> import textwrap
    >>> for line in plausibility_problems(Recording(time=t, f=f / G0, omega=w, source="a.csv")):
    ...     print(textwrap.fill(line, 90))
    a.csv: specific force at rest is 1.00 m/s^2 (f = (0.00994, -0.0204, 0.999)), expected |f|
    = 9.81 +- 2.11 m/s^2: looks like the accelerometer is in g, not m/s^2
    """
    return [p.message for p in rest_problems(rec, spec=MEMS_SPEC, rest="auto")]


def check_plausible(rec: Recording) -> Recording:
    """Return `rec` when it is plausible (:func:`plausibility_problems`), else raise.

    Parameters
    ----------
    rec : Recording
        The recording to check.

    Returns
    -------
    Recording
        `rec` itself.

    Raises
    ------
    DataError
        One line: the source, then every problem of :func:`plausibility_problems`.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> t = np.arange(300) * 0.01
    >>> w = 0.002 * rng.standard_normal((300, 3))
    >>> f = np.column_stack([np.zeros(300), 0.02 * rng.standard_normal(300), 9.8 + 0.02 * rng.standard_normal(300)])
    >>> check_plausible(Recording(time=t, f=f, omega=w, source="b.csv"))
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: b.csv: column f_x is all zero in all 300 samples: a dead channel, ...
    """
    problems = plausibility_problems(rec)
    if problems:
        prefix = f"{rec.source}: "
        raise DataError(prefix + "; ".join(p[len(prefix):] if p.startswith(prefix) else p for p in problems))
    return rec


def write_csv(path, recording: Recording) -> None:
    """Write a recording in the dataset's CSV format (atomically: temp file, then rename).

    The header is :data:`COLUMNS`; every value is written with 17 significant
    digits, so :func:`load_csv` reads back the same floats. The recording's
    labels are not written (they come from where the file lies).

    Parameters
    ----------
    path : str or Path
        File to write; its folder must exist.
    recording : Recording
        The samples to write.

    Returns
    -------
    None

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> t = 0.1 + np.arange(100) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.1, 0.0, 9.8], (100, 1)), omega=np.full((100, 3), 1 / 3))
    >>> write_csv(path, rec)
    >>> back = load_csv(path)
    >>> bool(np.array_equal(back.time, rec.time) and np.array_equal(back.omega, rec.omega))
    True
    >>> open(path).readline().strip()
    'time,f_x,f_y,f_z,g_x,g_y,g_z'
    """
    from .outputs import atomic_path

    data = np.column_stack([recording.time, recording.f, recording.omega])
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(",".join(COLUMNS) + "\n")
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")


# --------------------------------------------------------------------------- catalogue

@lru_cache(maxsize=None)
def _routes_file() -> dict:
    with open(PROJECT_DATA / "routes.json") as fh:
        return json.load(fh)


@lru_cache(maxsize=1)
def _route_table() -> dict:
    """The routes of ``data/routes.json``, read once per process (end points read-only: shared)."""
    out = {}
    for name, r in _routes_file()["routes"].items():
        end = np.asarray(r["end_point_m"], dtype=float)
        end.flags.writeable = False
        out[name] = Route(name=name, kind=r["kind"], environment=r["environment"], p2p_m=r["p2p_m"],
                          amplitude_m=r["amplitude_m"], distance_m=r["distance_m"], end_point_m=end,
                          segments_m=tuple(r["segments_m"]), turn_deg=r["turn_deg"],
                          slope_deg=r.get("slope_deg", 0.0), slope_length_m=r.get("slope_length_m", 0.0))
    return out


def routes() -> dict[str, Route]:
    """Ground truth of every route, by route folder name.

    Read from the project's ``data/routes.json``.

    Returns
    -------
    dict of str -> Route
        One :class:`Route` per route folder name of the dataset.

    Examples
    --------
    >>> r = routes()
    >>> len(r), r["long_distance"].distance_m
    (6, 13.0)
    """
    return dict(_route_table())


def route(name: str) -> Route:
    """Ground truth of one route (see :func:`routes`).

    Parameters
    ----------
    name : str
        Route folder name, a key of :func:`routes`.

    Returns
    -------
    Route
        The route's kind, environment, distances, end point and legs.

    Raises
    ------
    ParameterError
        For an unknown route name.

    Examples
    --------
    >>> r = route("short_distance")
    >>> r.kind, r.distance_m, r.p2p_m, r.end_point_m.tolist()
    ('periodic', 6.3, 1.0, [6.3, 0.0])
    """
    r = routes()
    if name not in r:
        raise ParameterError(f"route {name!r}: unknown, expected one of {sorted(r)}")
    return r[name]


def layout() -> dict[str, int]:
    """Expected folders of the MoRPI dataset and their number of runs.

    Returns
    -------
    dict of str -> int
        Folder (``phone/route[/split]``, as :func:`folder_key` writes it) to
        the number of recordings it holds in the public dataset.

    Examples
    --------
    >>> folders = layout()
    >>> folders["s8/short_distance/test"], sum(folders.values())
    (11, 143)
    """
    return {k: v["runs"] for k, v in _routes_file()["layout"].items()}


def resolve_data_root(data=None, *, required: bool = True) -> Path | None:
    """Find the dataset root: `data` if given, else ``$MORPI_DATA``.

    A folder without ``s6``/``s8`` whose ``data/`` has them (the root of an
    ansfl/MoRPI clone) stands for that ``data/`` folder.

    Parameters
    ----------
    data : str or Path, optional
        The folder given by the user (``--data``); a leading ``~`` is expanded.
        When None, the environment variable :data:`DATA_ENV` is read.
    required : bool, optional
        Raise when neither is set (default True); otherwise return None.

    Returns
    -------
    Path or None
        The dataset root; None when nothing is configured and not `required`.

    Raises
    ------
    MissingDataError
        When `required` and neither is set, or the folder does not exist.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> clone = pathlib.Path(tempfile.mkdtemp())
    >>> (clone / "data" / "s8").mkdir(parents=True)
    >>> resolve_data_root(clone) == clone / "data"
    True
    >>> resolve_data_root(clone / "nowhere")
    Traceback (most recent call last):
    ...
    morpi_filters.errors.MissingDataError: --data=...nowhere: not a directory; get the field recordings ...
    """
    source = "--data"
    if data is None:
        data = os.environ.get(DATA_ENV) or None
        source = DATA_ENV
    if data is None:
        if required:
            raise MissingDataError(f"no dataset configured: {_HOW_TO_GET}")
        return None
    root = Path(data).expanduser()
    if not root.is_dir():
        raise MissingDataError(f"{source}={data}: not a directory; {_HOW_TO_GET}")
    if not any((root / p).is_dir() for p in ("s6", "s8")) and any((root / "data" / p).is_dir() for p in ("s6", "s8")):
        root = root / "data"   # the root of an ansfl/MoRPI clone: its recordings are under data/
    return root


def missing_data_message() -> str:
    """How to get the field recordings, in one sentence.

    Returns
    -------
    str
        The sentence (it names ``morpi data fetch``, ``--data`` and
        :data:`DATA_ENV`).

    Examples
    --------
    >>> "morpi data fetch" in missing_data_message()
    True
    """
    return _HOW_TO_GET


def _split_parts(rel: Path) -> tuple[str, str, str | None] | None:
    parts = rel.parts
    if len(parts) < 3 or parts[0] not in ("s6", "s8"):
        return None
    phone, route_name = parts[0], parts[1]
    split = parts[2] if len(parts) == 4 and parts[2] in ("train", "test") else None
    if len(parts) not in (3, 4) or (len(parts) == 4 and split is None):
        return None
    return phone, route_name, split


def catalogue(root) -> list[CatalogueEntry]:
    """List the recordings under a dataset root, in a stable order.

    Files outside the MoRPI layout (``<phone>/<route>[/<split>]/<n>.csv``)
    and routes without ground truth are left out. Nothing is read but the
    folder names.

    Parameters
    ----------
    root : str or Path
        The dataset root (the folder holding ``s6`` and ``s8``).

    Returns
    -------
    list of CatalogueEntry
        Sorted by phone, route, split, then file number (``2.csv`` before
        ``10.csv``).

    Raises
    ------
    DataError
        `root` is not a directory.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for rel in ("s8/L_shape/test/10.csv", "s8/L_shape/test/2.csv", "s6/L_line/1.csv", "notes/x.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     (root / rel).touch()
    >>> [(e.relpath, e.split) for e in catalogue(root)]
    [('s6/L_line/1.csv', None), ('s8/L_shape/test/2.csv', 'test'), ('s8/L_shape/test/10.csv', 'test')]
    """
    root = Path(root)
    if not root.is_dir():
        raise DataError(f"{root}: not a directory; expected a dataset root (the folder holding s6 and s8)")
    known = routes()
    out = []
    for path in root.rglob("*.csv"):
        rel = path.relative_to(root)
        parts = _split_parts(rel)
        if parts is None or parts[1] not in known:
            continue
        out.append(CatalogueEntry(path=path, relpath=rel.as_posix(), phone=parts[0], route=parts[1], split=parts[2]))
    out.sort(key=lambda e: (e.phone, e.route, e.split or "", _natural_key(e.path.stem)))
    return out


def _natural_key(stem: str):
    return (0, int(stem), "") if stem.isdigit() else (1, 0, stem)


def load_recording(path) -> tuple[Recording, "Route | None"]:
    """Load one recording by path, with its labels and ground truth read from where it lies.

    A file at ``.../<phone>/<route>[/<split>]/<n>.csv`` of the MoRPI layout
    gets its phone, route and split and the route's ground truth; anywhere
    else it loads without labels, with a warning saying so.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    recording : Recording
        The validated recording (:func:`load_csv`, :func:`check_plausible`),
        labelled when in the layout.
    truth : Route or None
        The route's ground truth; None outside the layout.

    Raises
    ------
    DataError
        Every error of :func:`load_csv` and :func:`check_plausible`.

    Warns
    -----
    UserWarning
        When the file is not in the MoRPI layout.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "s8" / "short_distance" / "test"
    >>> folder.mkdir(parents=True)
    >>> t = np.arange(200) * 0.01
    >>> write_csv(folder / "1.csv", Recording(time=t, f=np.tile([0, 0, 9.8], (200, 1)),
    ...                                       omega=np.zeros((200, 3)), source="example"))
    >>> rec, truth = load_recording(folder / "1.csv")
    >>> rec.phone, rec.route, rec.split, truth.distance_m
    ('s8', 'short_distance', 'test', 6.3)
    """
    import warnings

    path = Path(path)
    known = routes()
    for depth in (4, 3):
        parts = path.resolve().parts[-depth:]
        labels = _split_parts(Path(*parts)) if len(parts) == depth else None
        if labels is not None and labels[1] in known:
            phone, route_name, split = labels
            rec = load_csv(path, phone=phone, route=route_name, split=split)
            return check_plausible(rec), known[route_name]
    warnings.warn(f"{path}: not in the MoRPI layout (<phone>/<route>[/<split>]/<n>.csv): loaded without "
                  "phone, route, split or ground truth", stacklevel=2)
    return check_plausible(load_csv(path)), None


def load_catalogue(root, *, phone=None, route=None, split=None) -> list[Recording]:
    """Load every recording under `root` that matches the given labels.

    Parameters
    ----------
    root : str or Path
        The dataset root.
    phone, route, split : str, optional
        Keep only recordings with these labels; None matches any. ``split`` is
        ``"train"`` or ``"test"`` (folders without a split never match one).

    Returns
    -------
    list of Recording
        Labelled recordings in the order of :func:`catalogue`.

    Raises
    ------
    DataError
        For the first file that does not load (:func:`CatalogueEntry.load`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(100) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)), omega=np.zeros((100, 3)))
    >>> for rel in ("s8/short_distance/train/1.csv", "s8/short_distance/test/1.csv", "s6/L_line/1.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     write_csv(root / rel, rec)
    >>> [r.name for r in load_catalogue(root, phone="s8", split="test")]
    ['s8/short_distance/test/1.csv']
    >>> len(load_catalogue(root)), len(load_catalogue(root, split="train"))
    (3, 1)
    """
    out = []
    for e in catalogue(root):
        if (phone is None or e.phone == phone) and (route is None or e.route == route) and \
                (split is None or e.split == split):
            out.append(e.load())
    return out


def expected_layout(root) -> dict[str, int]:
    """The folders a dataset root should hold and their number of recordings.

    The MoRPI layout (:func:`layout`), except for a synthetic dataset written
    by :func:`morpi_filters.synthetic.write_dataset`, whose ``manifest.json``
    lists its files (it may hold fewer runs per folder). An unreadable
    manifest, or one from another generator, is ignored.

    Parameters
    ----------
    root : str or Path
        The dataset root.

    Returns
    -------
    dict of str -> int
        Folder (``phone/route[/split]``) to its number of recordings.

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> expected_layout(root) == layout()
    True
    >>> files = {"s6/L_line/1.csv": "", "s6/L_line/2.csv": "", "s8/line_dataset/1.csv": ""}
    >>> _ = (root / "manifest.json").write_text(json.dumps({"generator": "morpi_filters.simulate", "files": files}))
    >>> expected_layout(root)
    {'s6/L_line': 2, 's8/line_dataset': 1}
    """
    man = Path(root) / "manifest.json"
    if man.is_file():
        try:
            m = json.loads(man.read_text())
            if isinstance(m, dict) and m.get("generator") == "morpi_filters.simulate" \
                    and isinstance(m.get("files"), dict):
                counts: dict[str, int] = {}
                for rel in (str(r) for r in m["files"] if str(r).endswith(".csv")):
                    folder = rel.rsplit("/", 1)[0]
                    counts[folder] = counts.get(folder, 0) + 1
                return counts
        except (OSError, ValueError):
            pass
    return layout()


def folder_key(phone: str, route_name: str, split: str | None) -> str:
    """The layout name of a folder: ``phone/route[/split]``.

    Parameters
    ----------
    phone : str
        ``"s6"`` or ``"s8"``.
    route_name : str
        Route folder name.
    split : str or None
        ``"train"``, ``"test"``, or None for a folder without a split.

    Returns
    -------
    str
        The key used by :func:`layout` and :func:`expected_layout`.

    Examples
    --------
    >>> folder_key("s8", "short_distance", "test"), folder_key("s6", "L_line", None)
    ('s8/short_distance/test', 's6/L_line')
    """
    return "/".join([phone, route_name] + ([split] if split else []))


def layout_problems(root, entries=None) -> list[str]:
    """One line per difference between the recordings under `root` and :func:`expected_layout`.

    A folder of the layout that is absent, a folder holding another number of
    recordings, and CSV files outside the layout (which no command reads) are
    named. No recording at all is one line saying so (with a hint when
    ``root/data`` holds the dataset). Files are not read.

    Parameters
    ----------
    root : str or Path
        The dataset root.
    entries : list of CatalogueEntry, optional
        ``catalogue(root)`` when already listed.

    Returns
    -------
    list of str
        The problems, one line each; empty when the layout is complete.

    Examples
    --------
    A synthetic dataset promising two runs of ``s6/L_line`` but holding one,
    plus a stray file:

    >>> import json, pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> files = {"s6/L_line/1.csv": "", "s6/L_line/2.csv": ""}
    >>> _ = (root / "manifest.json").write_text(json.dumps({"generator": "morpi_filters.simulate", "files": files}))
    >>> for rel in ("s6/L_line/1.csv", "notes/x.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     (root / rel).touch()
    >>> [line.replace(str(root), "ROOT")[:50] for line in layout_problems(root)]
    ['ROOT/s6/L_line: 1 recording(s), expected 2', 'ROOT/notes: 1 CSV file(s) outside the MoRPI layout']
    """
    root = Path(root)
    entries = catalogue(root) if entries is None else entries
    expected = expected_layout(root)
    counts: dict[str, int] = {}
    for e in entries:
        k = folder_key(e.phone, e.route, e.split)
        counts[k] = counts.get(k, 0) + 1
    out = []
    if not entries:
        inner = root / "data"
        hint = (f"; {inner} looks like the dataset root, pass --data {inner}"
                if inner.is_dir() and catalogue(inner) else f"; {_HOW_TO_GET}")
        out.append(f"{root}: no recordings in the MoRPI layout (<phone>/<route>[/<split>]/<n>.csv){hint}")
    for folder, n in (expected.items() if entries else ()):
        got = counts.get(folder, 0)
        if not (root / folder).is_dir():
            out.append(f"{root / folder}: missing folder, expected {n} recording(s)")
        elif got != n:
            out.append(f"{root / folder}: {got} recording(s), expected {n}")
    for folder in sorted(set(counts) - set(expected)):
        out.append(f"{root / folder}: unexpected folder ({counts[folder]} recording(s)), "
                   f"expected only {', '.join(sorted(expected))}")
    known = {e.path for e in entries}
    stray: dict[Path, int] = {}
    for path in root.rglob("*.csv"):
        if path not in known:
            stray[path.parent] = stray.get(path.parent, 0) + 1
    for folder in sorted(stray):
        out.append(f"{folder}: {stray[folder]} CSV file(s) outside the MoRPI layout "
                   "(<phone>/<route>[/<split>]/<n>.csv, routes of data/routes.json), read by no command")
    return out


def check_tree(root, *, usable=None) -> tuple[list[str], int]:
    r"""Validate every recording under `root` and the folder layout.

    Parameters
    ----------
    root : str or Path
        The dataset root.
    usable : callable, optional
        A further check of each recording that loads (with its labels):
        ``usable(recording)`` returns a one-line problem, or None
        (``morpi check`` passes :meth:`morpi_filters.field.FieldData.problem`).

    Returns
    -------
    problems : list of str
        One line per file that does not load (:func:`load_csv`), per
        implausible reading of a file that does (:func:`plausibility_problems`:
        a dead channel, wrong units, swapped columns, a z-down frame), and per
        difference from the expected layout (:func:`layout_problems`: missing
        or unexpected folders, wrong counts, no recordings at all).
    n_ok : int
        Number of files that loaded cleanly and passed every plausibility check (and `usable`).

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> files = {"s6/L_line/1.csv": "", "s6/L_line/2.csv": ""}
    >>> _ = (root / "manifest.json").write_text(json.dumps({"generator": "morpi_filters.simulate", "files": files}))
    >>> (root / "s6" / "L_line").mkdir(parents=True)
    >>> t = np.arange(100) * 0.01
    >>> write_csv(root / "s6/L_line/1.csv", Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)),
    ...                                                omega=np.zeros((100, 3))))
    >>> _ = (root / "s6/L_line/2.csv").write_text("time,f_x\n")
    >>> problems, n_ok = check_tree(root)
    >>> n_ok, [p.replace(str(root), "ROOT") for p in problems]
    (1, ['ROOT/s6/L_line/2.csv: line 1: missing column(s) f_y, f_z, g_x, g_y, g_z; expected the header time,f_x,f_y,f_z,g_x,g_y,g_z (in any order)'])
    """
    root = Path(root)
    entries = catalogue(root)
    problems, n_ok = [], 0
    for e in entries:
        try:
            rec = load_csv(e.path, phone=e.phone, route=e.route, split=e.split)
        except MorpiError as exc:
            problems.append(str(exc))
            continue
        found = plausibility_problems(rec)           # every one, where a load names the first
        if not found and usable is not None:
            line = usable(rec)
            found = [] if line is None else [line]
        problems += found
        n_ok += not found
    return problems + layout_problems(root, entries), n_ok
