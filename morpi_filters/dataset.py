"""Recordings: the CSV loader with validation, and the MoRPI dataset catalogue.

A :class:`Recording` holds one IMU recording in SI units and phone axes (see
the package docstring for frames). :func:`load_csv` reads one file and rejects
anything that is not a clean recording with a :class:`MorpiError` naming the
file, and the line where there is one. :func:`catalogue` walks a dataset root
laid out as the public MoRPI repository (``s8/short_distance/train/3.csv``)
and attaches phone, route, split and the route's ground truth, which lives in
``data/routes.json`` (a file this project owns).

The dataset root is found by :func:`resolve_data_root`: an explicit path, else
the environment variable ``MORPI_DATA``.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import MorpiError
from .resources import project_data

__all__ = [
    "COLUMNS", "MIN_SAMPLES", "DATA_ENV", "Route", "Recording", "CatalogueEntry",
    "load_csv", "write_csv", "routes", "route", "catalogue", "load_catalogue",
    "resolve_data_root", "missing_data_message", "check_tree", "PROJECT_DATA",
]

#: The header every recording must have, in this order.
COLUMNS = ("time", "f_x", "f_y", "f_z", "g_x", "g_y", "g_z")
#: Fewest samples a recording may have (1 s at the nominal 100 Hz).
MIN_SAMPLES = 100
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
    """

    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    source: str = "<memory>"
    phone: str | None = None
    route: str | None = None
    split: str | None = None

    def __post_init__(self):
        n = self.time.shape[0]
        if self.time.ndim != 1 or self.f.shape != (n, 3) or self.omega.shape != (n, 3):
            raise MorpiError(
                f"{self.source}: expected time (n,), f (n, 3), omega (n, 3); got "
                f"{self.time.shape}, {self.f.shape}, {self.omega.shape}")

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
        """Short label ``phone/route/split/file``."""
        parts = [p for p in (self.phone, self.route, self.split) if p]
        return "/".join(parts + [Path(self.source).name]) if parts else self.source


@dataclass(frozen=True)
class CatalogueEntry:
    """A recording's place in the dataset layout, before it is read."""

    path: Path
    relpath: str
    phone: str
    route: str
    split: str | None

    def load(self) -> Recording:
        """Read and validate the file."""
        return load_csv(self.path, phone=self.phone, route=self.route, split=self.split)


# --------------------------------------------------------------------------- loading

def load_csv(path, *, phone=None, route=None, split=None, min_samples: int = MIN_SAMPLES) -> Recording:
    """Read one recording and validate it.

    Parameters
    ----------
    path : str or Path
        CSV file with the header ``time,f_x,f_y,f_z,g_x,g_y,g_z``.
    phone, route, split : str, optional
        Catalogue labels stored on the result.
    min_samples : int
        Fewest data rows accepted.

    Returns
    -------
    Recording

    Raises
    ------
    MorpiError
        With one line naming the file (and line) for: a missing or unreadable
        file, an empty or header-only file, a file that is not CSV text,
        missing or unexpected columns, a short or long row, a non-numeric
        cell, NaN or inf, a non-increasing or repeated time stamp, or fewer
        than `min_samples` rows.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise MorpiError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise MorpiError(f"{path}: is a directory, expected a CSV file") from None
    except OSError as exc:
        raise MorpiError(f"{path}: cannot read ({exc.strerror})") from None
    data = _parse(raw, str(path))
    if data.shape[0] < min_samples:
        raise MorpiError(f"{path}: too few samples: {data.shape[0]} rows, expected at least {min_samples}")
    return Recording(time=np.ascontiguousarray(data[:, 0]), f=np.ascontiguousarray(data[:, 1:4]),
                     omega=np.ascontiguousarray(data[:, 4:7]), source=str(path),
                     phone=phone, route=route, split=split)


def _parse(raw: bytes, name: str) -> np.ndarray:
    """Parse and validate CSV bytes; fast path with a precise slow path for errors."""
    if not raw.strip():
        raise MorpiError(f"{name}: empty file, expected the header {','.join(COLUMNS)} and data rows")
    if b"\x00" in raw:
        raise MorpiError(f"{name}: not CSV text (binary content)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise MorpiError(f"{name}: not CSV text (not UTF-8)") from None
    lines = text.splitlines()
    header = [c.strip() for c in lines[0].split(",")]
    if header != list(COLUMNS):
        missing = [c for c in COLUMNS if c not in header]
        extra = [c for c in header if c not in COLUMNS]
        what = []
        if missing:
            what.append("missing column(s) " + ", ".join(missing))
        if extra:
            what.append("unexpected column(s) " + ", ".join(repr(c) for c in extra))
        if not what:
            what.append("columns in the wrong order")
        raise MorpiError(f"{name}: line 1: {'; '.join(what)}; expected the header {','.join(COLUMNS)}")
    body = lines[1:]
    if not any(s.strip() for s in body):
        raise MorpiError(f"{name}: header only, no data rows")
    try:
        data = np.loadtxt(body, delimiter=",", ndmin=2, dtype=float)
        ok = data.shape[1] == len(COLUMNS) and data.shape[0] == sum(1 for s in body if s.strip())
    except ValueError:
        ok = False
    if ok and np.isfinite(data).all() and (np.diff(data[:, 0]) > 0).all():
        return data
    return _slow_parse(body, name)


def _slow_parse(body: list[str], name: str) -> np.ndarray:
    """Row-by-row parse that names the first bad line; returns the data if all is well."""
    rows = []
    prev_t, prev_line = -math.inf, None
    for i, s in enumerate(body, start=2):
        if not s.strip():
            continue
        cells = s.split(",")
        if len(cells) != len(COLUMNS):
            kind = "short" if len(cells) < len(COLUMNS) else "long"
            raise MorpiError(f"{name}: line {i}: {kind} row, {len(cells)} fields, expected {len(COLUMNS)}")
        vals = []
        for col, c in zip(COLUMNS, cells):
            try:
                v = float(c)
            except ValueError:
                raise MorpiError(f"{name}: line {i}: column {col}: {c.strip()!r} is not a number") from None
            if not math.isfinite(v):
                raise MorpiError(f"{name}: line {i}: column {col}: {c.strip()} is not finite, expected a real number")
            vals.append(v)
        t = vals[0]
        if t <= prev_t:
            what = "repeated" if t == prev_t else "decreasing"
            raise MorpiError(f"{name}: line {i}: {what} time stamp {t!r} (line {prev_line} has {prev_t!r}), "
                             "expected strictly increasing time")
        prev_t, prev_line = t, i
        rows.append(vals)
    return np.asarray(rows, dtype=float)


def write_csv(path, recording: Recording) -> None:
    """Write a recording in the dataset's CSV format (atomically: temp file, then rename)."""
    from .reporting import atomic_path

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


def routes() -> dict[str, Route]:
    """Ground truth of every route, by route folder name."""
    out = {}
    for name, r in _routes_file()["routes"].items():
        out[name] = Route(name=name, kind=r["kind"], environment=r["environment"], p2p_m=r["p2p_m"],
                          amplitude_m=r["amplitude_m"], distance_m=r["distance_m"],
                          end_point_m=np.asarray(r["end_point_m"], dtype=float),
                          segments_m=tuple(r["segments_m"]), turn_deg=r["turn_deg"],
                          slope_deg=r.get("slope_deg", 0.0), slope_length_m=r.get("slope_length_m", 0.0))
    return out


def route(name: str) -> Route:
    """Ground truth of one route (see :func:`routes`)."""
    r = routes()
    if name not in r:
        raise MorpiError(f"route {name!r}: unknown, expected one of {sorted(r)}")
    return r[name]


def layout() -> dict[str, int]:
    """Expected folders of the MoRPI dataset and their number of runs."""
    return {k: v["runs"] for k, v in _routes_file()["layout"].items()}


def resolve_data_root(data=None, *, required: bool = True) -> Path | None:
    """Find the dataset root: `data` if given, else ``$MORPI_DATA``.

    Raises
    ------
    MorpiError
        When `required` and neither is set, or the folder does not exist.
    """
    source = "--data"
    if data is None:
        data = os.environ.get(DATA_ENV) or None
        source = DATA_ENV
    if data is None:
        if required:
            raise MorpiError(f"no dataset configured: {_HOW_TO_GET}")
        return None
    root = Path(data).expanduser()
    if not root.is_dir():
        raise MorpiError(f"{source}={data}: not a directory; {_HOW_TO_GET}")
    return root


def missing_data_message() -> str:
    """How to get the field recordings, in one sentence."""
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
    and routes without ground truth are left out.
    """
    root = Path(root)
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


def load_catalogue(root, *, phone=None, route=None, split=None) -> list[Recording]:
    """Load every recording under `root` that matches the given labels."""
    out = []
    for e in catalogue(root):
        if (phone is None or e.phone == phone) and (route is None or e.route == route) and \
                (split is None or e.split == split):
            out.append(e.load())
    return out


def check_tree(root) -> tuple[list[str], int]:
    """Validate every CSV under `root`.

    Returns
    -------
    problems : list of str
        One line per bad file (or missing folder of the MoRPI layout).
    n_ok : int
        Number of files that loaded cleanly.
    """
    root = Path(root)
    problems, n_ok = [], 0
    files = sorted(root.rglob("*.csv"))
    for path in files:
        try:
            load_csv(path)
            n_ok += 1
        except MorpiError as exc:
            problems.append(str(exc))
    if not files:
        problems.append(f"{root}: no CSV files found; {_HOW_TO_GET}")
    return problems, n_ok

