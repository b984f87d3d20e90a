"""Writing reports safely: atomic files, staged folders, markdown helpers.

Every output file is written under a temporary name in its destination folder
and renamed into place, so an interrupted run never leaves half a file. A
report section is built in a staging folder beside its destination and swapped
in only when it is complete, so an interrupted run leaves the previous complete
section in place.

Each report section (tables, assessment, curves, montecarlo, drift) returns a
:class:`SectionSummary`; ``morpi report`` collects them into ``index.md``.
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import MorpiError

__all__ = [
    "SectionSummary", "DataSource", "atomic_path", "write_text", "write_json", "staged_dir",
    "md_table", "fmt", "to_jsonable", "SYNTHETIC_BANNER",
]

#: Shown at the top of every page computed on synthetic data.
SYNTHETIC_BANNER = (
    "> **Synthetic data.** No field dataset was configured, so this page was computed on a seeded "
    "synthetic dataset made by `morpi simulate` with the paper's two IMU specifications. "
    "To run it on the MoRPI field recordings: `morpi data fetch --dest DIR` (or clone the public "
    "repository ansfl/MoRPI), then `morpi report --data DIR/data` or set `MORPI_DATA`."
)


@dataclass(frozen=True)
class DataSource:
    """Where the recordings of a run come from.

    Attributes
    ----------
    root : Path or None
        Dataset root in the MoRPI layout; None when no recordings are used.
    synthetic : bool
        True when `root` holds simulated recordings.
    seed : int or None
        Seed of the synthetic dataset.
    """

    root: Path | None
    synthetic: bool = False
    seed: int | None = None

    @property
    def banner(self) -> str:
        """The synthetic-data notice, or an empty string for field data."""
        return SYNTHETIC_BANNER + "\n\n" if self.synthetic else ""


@dataclass(frozen=True)
class SectionSummary:
    """What a report section wrote, for the report's index.

    Attributes
    ----------
    name : str
        Folder name under ``reports/`` (``"tables"``, ``"assessment"``, ...).
    title : str
        Human title.
    page : str
        The section's markdown page, relative to the section folder.
    figures : tuple of str
        PNG files relative to the section folder, shown inline in the index.
    summary : str
        A few lines of markdown for the index.
    synthetic : bool
        Whether the section was computed on synthetic data.
    placeholder : bool
        True when the section is not implemented yet.
    """

    name: str
    title: str
    page: str = "README.md"
    figures: tuple = ()
    summary: str = ""
    synthetic: bool = False
    placeholder: bool = False


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside `path`; rename it to `path` on success.

    On an exception the temporary file is removed and `path` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text(path, text: str) -> Path:
    """Write text atomically."""
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return Path(path)


def to_jsonable(obj):
    """Convert numpy scalars/arrays and non-finite floats (to None) for JSON."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_json(path, obj) -> Path:
    """Write JSON atomically (numpy converted, NaN and inf written as null)."""
    text = json.dumps(to_jsonable(obj), indent=2, allow_nan=False)
    return write_text(path, text + "\n")


@contextlib.contextmanager
def staged_dir(final):
    """Build a folder in a staging place and swap it in when complete.

    Yields the staging folder. On success the previous `final` folder (if any)
    is replaced; on an exception the staging folder is removed and `final` is
    left exactly as it was.
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".staging-{final.name}-", dir=final.parent))
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    if final.is_dir() and not final.is_symlink():
        old = Path(tempfile.mkdtemp(prefix=f".previous-{final.name}-", dir=final.parent))
        os.replace(final, old / final.name)
        os.replace(stage, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        if final.exists():
            raise MorpiError(f"{final}: exists and is not a folder, expected an output folder")
        os.replace(stage, final)


def fmt(x, digits: int = 2) -> str:
    """Format a number for a markdown table (``-`` for None or NaN)."""
    if x is None:
        return "-"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return "-"
    return f"{v:.{digits}f}"


def md_table(headers, rows) -> str:
    """A GitHub markdown table from a header list and rows of cells."""
    head = "| " + " | ".join(str(h) for h in headers) + " |"
    sep = "|" + "|".join("---" for _ in headers) + "|"
    body = ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join([head, sep, *body]) + "\n"
