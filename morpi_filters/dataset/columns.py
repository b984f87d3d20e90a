"""A recording's columns and the limits a reading keeps; :class:`ColumnLayout`, a table in another layout and units."""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ParameterError
from ..units import G0

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
    >>> from morpi_filters.dataset import read_columns
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

    def held_columns(self) -> list[int]:
        """Indices (in `columns`) of the columns the file holds."""
        return [j for j, n in enumerate(self.names) if n is not None]

    def factor(self, j: int) -> float:
        """The SI value of one unit of the file in column `j` (1 without `factors`)."""
        return float(self.factors[j - 1]) if self.factors else 1.0

    def unit(self, j: int) -> str:
        """The file's unit of column `j`, as `units` names it ("" without `units`)."""
        return self.units[j - 1] if self.units else ""


#: The dataset's own CSV format: :data:`COLUMNS` by header name, SI units, nothing else on a line.
DATASET_CSV = ColumnLayout(COLUMNS, COLUMNS)


def column_limit(column: str):
    """(limit, what, unit, sensor) of a column by its name in the table, or None (finite only)."""
    if column.startswith("f_"):
        return ACCEL_LIMIT_MPS2, "specific force", "m/s^2", "accelerometer"
    if column.startswith("g_"):
        return GYRO_LIMIT_RADPS, "angular rate", "rad/s", "gyro"
    return None

