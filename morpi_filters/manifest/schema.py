"""A manifest's keys and values: the formats it reads, each key's check, [defaults] inherited key by key, the TOML
read into one table of values per recording, and the one-line errors naming the key."""
from __future__ import annotations

import difflib
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dataset import MAX_GAP_S, MEMS_SPEC
from ..errors import ParameterError
from .settings import SETTING_CHOICES, Settings
from ..units import DEG, DEG_S, DEG_S_SQRT_HZ, G0, IMUS, MG, UG_SQRT_HZ, SensorSpec

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
#: The frames a truth track may be given in.
FRAMES = ("NED", "ENU")
#: The column letters of each frame's axes.
FRAME_LETTERS = {"NED": ("n", "e", "d"), "ENU": ("e", "n", "u")}
_TOP_KEYS = ("format_version", "name", "description", "latitude_deg", "evaluation", "defaults", "recording")
_RECORDING_KEYS = ("id", "split", "group", "motion", "rest", "initial", "train_group", "notes", "imu", "truth")
_IMU_KEYS = ("file", "format", "columns", "skip_rows", "rate_hz", "time_unit", "time_origin", "accel_unit",
             "gyro_unit", "axes", "spec", "count")
#: The keys of a route truth.
ROUTE_KEYS = ("kind", "distance_m", "end_point_m", "polyline_m")
#: The keys of a truth track.
TRACK_KEYS = ("kind", "file", "format", "columns", "skip_rows", "rate_hz", "time_unit", "frame", "offset_s")
_TRUTH_KEYS = tuple(dict.fromkeys(ROUTE_KEYS + TRACK_KEYS))
#: The labels a recording takes when neither it nor [defaults] sets them.
DEFAULTS = {"split": "none", "group": "all", "motion": "periodic", "rest": "auto", "initial": "rest",
            "train_group": None, "notes": ""}


# --------------------------------------------------------------------------- values

class BadValue(Exception):
    """A value outside what a key accepts (the message says what was expected)."""


def _kind(v) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "an array",
            dict: "a table"}.get(type(v), type(v).__name__)


def _nearest(word: str, known, cutoff: float = 0.0):
    """The known word nearest to `word` (case aside; none below `cutoff`, difflib's similarity ratio), or None."""
    lowered = {str(k).lower(): k for k in known}
    near = difflib.get_close_matches(str(word).lower(), list(lowered), n=1, cutoff=cutoff)
    return lowered[near[0]] if near else None


def unknown_key(key: str, known) -> str:
    """The message for a key not in `known`, naming the nearest known one."""
    near = _nearest(key, known)
    return f"unknown key {key!r}" + (f", the nearest known one is {near!r}" if near else "")


def check_text(v) -> str:
    """A non-empty string (a name)."""
    if not isinstance(v, str):
        raise BadValue(f"{_kind(v)} {v!r}, expected a string")
    if not v.strip():
        raise BadValue("an empty string, expected a name")
    return v


def _free_text(v) -> str:
    if not isinstance(v, str):
        raise BadValue(f"{_kind(v)} {v!r}, expected a string")
    return v


def _train_group(v):
    """The name of a group with train recordings, or None (the recording's own group, else every train group)."""
    return None if v is None else check_text(v)


def _choice(options):
    def check(v):
        if not isinstance(v, str):
            raise BadValue(f"{_kind(v)} {v!r}, expected one of {', '.join(repr(o) for o in options)}")
        if v not in options:
            near = _nearest(v, options, cutoff=0.6)
            raise BadValue(f"{v!r} is not one of {', '.join(repr(o) for o in options)}"
                           + (f" (nearest: {near!r})" if near else ""))
        return v
    return check


def _integer(lowest: int):
    def check(v):
        if isinstance(v, bool) or not isinstance(v, int):
            raise BadValue(f"{_kind(v)} {v!r}, expected a whole number >= {lowest}")
        if v < lowest:
            raise BadValue(f"{v} is below {lowest}")
        return v
    return check


def _number(v, *, lowest=None, above=None) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BadValue(f"{_kind(v)} {v!r}, expected a number")
    v = float(v)
    if not math.isfinite(v):
        raise BadValue(f"{v!r}, expected a finite number")
    if lowest is not None and v < lowest:
        raise BadValue(f"{v!r}, expected at least {lowest:g}")
    if above is not None and v <= above:
        raise BadValue(f"{v!r}, expected a number above {above:g}")
    return v


def _rate(v) -> float:
    # one sample per MAX_GAP_S at least: a slower file breaks the loader's gap bound anyway
    return _number(v, lowest=1.0 / MAX_GAP_S)


def _rest(v):
    if isinstance(v, str):
        if v in ("auto", "none"):
            return v
        raise BadValue(f"{v!r}, expected 'auto', 'none' or [t0, t1] in seconds from the first sample")
    if not isinstance(v, list) or len(v) != 2:
        raise BadValue(f"{_kind(v)} {v!r}, expected 'auto', 'none' or [t0, t1] in seconds from the first sample")
    t0, t1 = (_number(x, lowest=0.0) for x in v)
    if not t1 > t0:
        raise BadValue(f"[{t0:g}, {t1:g}] is empty, expected t0 < t1")
    return (t0, t1)


def _point(v) -> np.ndarray:
    if not isinstance(v, list) or len(v) != 2:
        raise BadValue(f"{_kind(v)} {v!r}, expected [x, y] in metres (two numbers)")
    return np.array([_number(x) for x in v])


def _polyline(v) -> np.ndarray:
    if not isinstance(v, list) or len(v) < 2:
        raise BadValue(f"{_kind(v)} {v!r}, expected [[x, y], ...] with at least two points in metres")
    pts = []
    for k, p in enumerate(v):
        try:
            pts.append(_point(p))
        except BadValue as bad:
            raise BadValue(f"point {k}: {bad}") from None
    return np.array(pts)


def _axes(v):
    """The body axis and sign of each file axis: ``flu[:, i] = sign[i] * file[:, perm[i]]``."""
    if not isinstance(v, str) or len(v) != 3 or any(c not in "FBLRUD" for c in v):
        raise BadValue(f"{v!r}, expected three letters giving the file's x, y, z directions, each from F/B, L/R, "
                       "U/D, such as 'FLU' (x forward, y left, z up) or 'FRD'")
    axis = {"F": 0, "B": 0, "L": 1, "R": 1, "U": 2, "D": 2}
    sign = {"F": 1.0, "B": -1.0, "L": 1.0, "R": -1.0, "U": 1.0, "D": -1.0}
    body = [axis[c] for c in v]
    if sorted(body) != [0, 1, 2]:
        twice = [c for c in v if body.count(axis[c]) > 1]
        raise BadValue(f"{v!r} repeats an axis ({' and '.join(twice)} lie on one line), expected one letter each "
                       "from F/B, L/R and U/D")
    m = np.zeros((3, 3))
    for j, c in enumerate(v):
        m[axis[c], j] = sign[c]
    if np.linalg.det(m) < 0:
        raise BadValue(f"{v!r} is left-handed, expected a right-handed triple such as 'FLU', 'FRD', 'RFU' or 'LBU'")
    perm = tuple(body.index(i) for i in range(3))
    return perm, tuple(sign[v[perm[i]]] for i in range(3))


def check_latitude(v) -> float:
    """A latitude in degrees, -90 to 90."""
    v = _number(v)
    if not -90.0 <= v <= 90.0:
        raise BadValue(f"{v!r}, expected a latitude in degrees from -90 to 90")
    return v


def _spec(v) -> SensorSpec:
    if isinstance(v, str):
        known = IMUS
        if v not in known:
            near = _nearest(v, known, cutoff=0.6)
            raise BadValue(f"{v!r} is not an IMU the package knows ({', '.join(repr(k) for k in known)})"
                           + (f" (nearest: {near!r})" if near else "") + ", expected one of them or a table of the "
                           f"IMU's datasheet figures: {', '.join(SPEC_KEYS)}")
        return known[v]
    if not isinstance(v, dict):
        raise BadValue(f"{_kind(v)} {v!r}, expected the name of an IMU the package knows or a table of the IMU's "
                       f"datasheet figures: {', '.join(SPEC_KEYS)}")
    figures = {}
    for key, x in v.items():
        if key not in SPEC_KEYS:
            raise BadValue(unknown_key(key, SPEC_KEYS))
        try:
            attr, unit = SPEC_KEYS[key]
            figures[attr] = _number(x, lowest=0.0) * unit
        except BadValue as bad:
            raise BadValue(f"{key}: {bad}") from None
    base = {k: getattr(MEMS_SPEC, k) for k in ("gyro_bias", "gyro_noise", "accel_bias", "accel_noise")}
    return SensorSpec("imu.spec", **{**base, **figures})


def check_columns(v):
    """A columns table: each value a header name or a 0-based column index."""
    if not isinstance(v, dict):
        raise BadValue(f"{_kind(v)} {v!r}, expected a table of column names (CSV) or 0-based indices (npy)")
    for key, name in v.items():
        if isinstance(name, bool) or not isinstance(name, (str, int)):
            raise BadValue(f"{key}: {_kind(name)} {name!r}, expected a header name or a 0-based column index")
    return v


#: The check of each label: the value to use, or BadValue.
LABEL_CHECKS = {"split": _choice(_SPLITS), "group": check_text, "motion": _choice(_MOTIONS), "rest": _rest,
                "initial": _choice(_INITIALS), "train_group": _train_group, "notes": _free_text}
#: The check of each ``imu`` key.
IMU_CHECKS = {"file": check_text, "format": _choice(("csv", "npy")), "columns": check_columns,
              "skip_rows": _integer(0), "rate_hz": _rate, "time_unit": _choice(tuple(TIME_UNITS)),
              "time_origin": _choice(("clock", "first")), "accel_unit": _choice(tuple(ACCEL_UNITS)),
              "gyro_unit": _choice(tuple(GYRO_UNITS)), "axes": _axes, "spec": _spec, "count": _integer(1)}
#: The check of each ``truth`` key.
TRUTH_CHECKS = {"kind": _choice(("route", "track")), "distance_m": lambda v: _number(v, above=0.0),
                "end_point_m": _point, "polyline_m": _polyline, "file": check_text, "format": _choice(("csv", "npy")),
                "columns": check_columns, "skip_rows": _integer(0), "rate_hz": _rate,
                "time_unit": _choice(tuple(TIME_UNITS)), "frame": _choice(FRAMES), "offset_s": _number}


# --------------------------------------------------------------------------- reading the manifest

class Context:
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
class ParsedManifest:
    """A manifest read and merged, its files not yet read (:func:`read_manifest`)."""

    path: Path
    name: str
    description: str
    entries: tuple        # (context, merged values or None, problem or None)
    latitude_deg: float | None = None
    settings: Settings = Settings()
    base: Path | None = None
    empty: tuple = ()     # (context, values) of each glob table that matches no file
    globs: tuple = ()     # (context, pattern, files matched, imu.count or None) of each glob table


def _settings(table, path: Path) -> Settings:
    """The settings of a manifest's ``[evaluation]`` table (keys left out keep their defaults)."""
    if not isinstance(table, dict):
        raise ParameterError(f"{path}: evaluation: {_kind(table)} {table!r}, expected a table [evaluation]")
    for key in table:
        if key not in SETTING_CHOICES:
            raise ParameterError(f"{path}: [evaluation]: {unknown_key(key, tuple(SETTING_CHOICES))}")
    try:
        return Settings(**table)
    except ParameterError as exc:
        raise ParameterError(f"{path}: {exc}") from None


def _toml():
    if sys.version_info >= (3, 11):
        import tomllib
        return tomllib
    import tomli      # the same parser, for Python 3.10
    return tomli


def read_manifest(path, root=None) -> ParsedManifest:
    """Read a manifest's TOML: its top-level keys, [defaults] and each recording's values over them."""
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
            raise ParameterError(f"{path}: {unknown_key(key, _TOP_KEYS)}")
    version = doc.get("format_version")
    if version is None:
        raise ParameterError(f"{path}: format_version: missing, expected format_version = {FORMAT_VERSION}")
    if isinstance(version, bool) or not isinstance(version, int) or version != FORMAT_VERSION:
        raise ParameterError(f"{path}: format_version: {version!r} is not supported, expected {FORMAT_VERSION} "
                             "(the manifest format this version of morpi_filters reads)")
    try:
        name = check_text(doc["name"]) if "name" in doc else None
        description = _free_text(doc.get("description", ""))
    except BadValue as bad:
        raise ParameterError(f"{path}: {'name' if 'name' in doc else 'description'}: {bad}") from None
    if name is None:
        raise ParameterError(f"{path}: name: missing, expected the dataset's name (a string)")
    try:
        latitude = check_latitude(doc["latitude_deg"]) if "latitude_deg" in doc else None
    except BadValue as bad:
        raise ParameterError(f"{path}: latitude_deg: {bad}") from None
    settings = _settings(doc["evaluation"], path) if "evaluation" in doc else Settings()
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
    entries, first_of, empty, globs = [], {}, [], []
    for k, table in enumerate(tables, start=1):
        rec_id = table.get("id") if isinstance(table.get("id"), str) else None
        head = f"{path}: [[recording]] {k}" + (f" (id {rec_id!r})" if rec_id else "")
        try:
            values, origin = _merge(head, defaults, table)
            ctx = Context(head, origin, str(path), rec_id, base, k)
            expanded = _expand(ctx, values, k)
            if _is_glob(values.get("imu", {}).get("file")):
                globs.append((ctx, values["imu"]["file"], len(expanded),
                              value_of(ctx, values["imu"], "imu", "count", IMU_CHECKS)))
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
            entries.append((Context(head, {}, str(path), rec_id, base), None, exc))
    return ParsedManifest(path=path, name=name, description=description, entries=tuple(entries), latitude_deg=latitude,
                          settings=settings, base=base, empty=tuple(empty), globs=tuple(globs))


def _is_glob(name) -> bool:
    return isinstance(name, str) and any(c in name for c in GLOB_CHARS)


def _natural(p: Path):
    """A file's place among the matches of a glob: by folder, then by the number its name is (``2.csv`` before
    ``10.csv``), then by name."""
    return (p.parent.parts, (0, int(p.stem), "") if p.stem.isdigit() else (1, 0, p.stem), p.name)


def _expand(ctx: Context, values: dict, k: int) -> list:
    """A recording's (context, values), or one per file a glob ``imu.file`` matches (its id the file's path
    relative to the base folder), in the order of :func:`_natural`."""
    pattern = values.get("imu", {}).get("file") if isinstance(values.get("imu"), dict) else None
    if not _is_glob(pattern):
        refuse_unused(ctx, values.get("imu", {}), "imu", ("count",), "without a glob imu.file (a file is one "
                                                                       "recording)")
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
        out.append((Context(head, origin, ctx.manifest, rel, ctx.base, k),
                    {**values, "id": rel, "imu": {**values["imu"], "file": rel}}))
    return out


def _check_defaults(path: Path, defaults: dict) -> None:
    """Keys and context-free values of [defaults] (an error there would repeat for every recording)."""
    for key, v in defaults.items():
        where = f"{path}: [defaults] {key}"
        if key == "id":
            raise ParameterError(f"{where}: ids cannot have a default, expected one id in each [[recording]]")
        if key not in _RECORDING_KEYS:
            raise ParameterError(f"{path}: [defaults]: {unknown_key(key, _RECORDING_KEYS[1:])}")
        if key in ("imu", "truth"):
            if not isinstance(v, dict):
                raise ParameterError(f"{where}: {_kind(v)}, expected a table")
            checks = IMU_CHECKS if key == "imu" else TRUTH_CHECKS
            for sub, sv in v.items():
                if sub not in checks:
                    raise ParameterError(f"{where}: {unknown_key(sub, checks)}")
                try:
                    checks[sub](sv)
                except BadValue as bad:
                    raise ParameterError(f"{where}.{sub}: {bad}") from None
            continue
        try:
            LABEL_CHECKS[key](v)
        except BadValue as bad:
            raise ParameterError(f"{where}: {bad}") from None


def _merge(head: str, defaults: dict, table: dict):
    """A recording's values over the defaults (sub-tables ``imu`` and ``truth`` key by key), and where
    each came from."""
    for key, v in table.items():
        if key not in _RECORDING_KEYS:
            raise ParameterError(f"{head}: {unknown_key(key, _RECORDING_KEYS)}")
        if key in ("imu", "truth") and not isinstance(v, dict):
            raise ParameterError(f"{head}: {key}: {_kind(v)} {v!r}, expected a table")
        if key in ("imu", "truth"):
            known = _IMU_KEYS if key == "imu" else _TRUTH_KEYS
            for sub in v:
                if sub not in known:
                    raise ParameterError(f"{head}: {key}: {unknown_key(sub, known)}")
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

def value_of(ctx: Context, table: dict, prefix: str, key: str, checks: dict, default=None, required=False):
    """The checked value of a key of `table` (or its default), or the one-line error naming the key."""
    full = f"{prefix}.{key}" if prefix else key
    if key not in table:
        if required:
            raise ctx.bad(full, "missing")
        return None if default is None else checks[key](default)
    try:
        return checks[key](table[key])
    except BadValue as bad:
        raise ctx.bad(full, str(bad)) from None


def refuse_unused(ctx: Context, table: dict, prefix: str, keys, why: str) -> None:
    """Refuse keys a recording sets that its other keys make meaningless (from [defaults] they are ignored)."""
    for key in keys:
        full = f"{prefix}.{key}"
        if key in table and ctx.origin.get(full) == "recording":
            raise ctx.bad(full, f"not used {why}; remove it")

