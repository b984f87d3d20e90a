"""Atomic files: each written in a staging folder of its own beside its destination, then renamed into place."""
from __future__ import annotations

import contextlib
import functools
import json
import os
from pathlib import Path

from ..results import JSON_DIGITS, to_jsonable
from .claims import MARKER, drop_stage, new_stage_dir


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path for `path`; rename it to `path` on success.

    The temporary file lies in a staging folder of its own beside `path`
    (:func:`new_temp_file`), removed when the block ends; on an exception
    `path` is untouched. The file gets the permissions of a file the user
    creates (``0o666`` minus the umask); the staging folder's name and marker
    carry this process's id, so what a killed run leaves is removed by
    :func:`remove_stale`. Missing parent folders are created.

    Parameters
    ----------
    path : str or Path
        Final file path.

    Yields
    ------
    Path
        An empty temporary file, to write.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "sub" / "a.txt"
    >>> with atomic_path(out) as tmp:
    ...     _ = tmp.write_text("done")
    ...     out.exists()                      # not yet in place while writing
    False
    >>> out.read_text(), sorted(p.name for p in out.parent.iterdir())
    ('done', ['a.txt'])
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = new_temp_file(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        drop_stage(tmp.parent)


def write_text(path, text: str) -> Path:
    """Write text atomically (see :func:`atomic_path`).

    Parameters
    ----------
    path : str or Path
        Destination file; missing parent folders are created.
    text : str
        Content.

    Returns
    -------
    Path
        `path`.

    Examples
    --------
    >>> import tempfile
    >>> p = write_text(Path(tempfile.mkdtemp()) / "note.md", "# title")
    >>> p.name, p.read_text()
    ('note.md', '# title')
    """
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return Path(path)


def write_json(path, obj) -> Path:
    """Write JSON atomically (numpy converted, floats to :data:`JSON_DIGITS` digits, NaN and inf as null).

    Parameters
    ----------
    path : str or Path
        Destination file.
    obj : object
        Anything :func:`to_jsonable` converts to JSON values.

    Returns
    -------
    Path
        `path`; the file holds the JSON indented by 2, ending with a newline,
        every float rounded to :data:`JSON_DIGITS` significant digits.

    Examples
    --------
    >>> import json, tempfile
    >>> import numpy as np
    >>> p = write_json(Path(tempfile.mkdtemp()) / "r.json", {"rms_m": np.float64(0.25), "bad": float("inf"),
    ...                                                      "third": 1.0 / 3.0})
    >>> json.loads(p.read_text())
    {'rms_m': 0.25, 'bad': None, 'third': 0.3333333333333}
    """
    text = json.dumps(to_jsonable(obj, JSON_DIGITS), indent=2, allow_nan=False)
    return write_text(path, text + "\n")


@functools.lru_cache(maxsize=1)
def user_umask() -> int:
    """The process umask, read once.

    Read from ``/proc/self/status`` where the kernel reports it; elsewhere by
    setting and restoring it once (the first call, before any thread of this
    package writes).

    Returns
    -------
    int
        The umask bits (e.g. ``0o022``); cached after the first call.

    Examples
    --------
    >>> m = user_umask()
    >>> 0 <= m <= 0o777, user_umask() == m
    (True, True)
    """
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    old = os.umask(0o022)
    os.umask(old)
    return old


def new_temp_file(final) -> Path:
    """Create an empty temporary file for `final` with the user's file permissions.

    The file lies in a staging folder of its own beside `final` (see
    :func:`new_stage_dir`) and has `final`'s name (its suffix tells a
    writer such as matplotlib the format), except for a marker file, whose
    name the staging folder's own marker holds.

    Parameters
    ----------
    final : str or Path
        The file being written; its folder must exist.

    Returns
    -------
    Path
        ``.staging-<name>-<pid>-<token>/<name>`` in `final`'s folder, empty.

    Examples
    --------
    >>> import tempfile
    >>> tmp = new_temp_file(Path(tempfile.mkdtemp()) / "a.json")
    >>> tmp.name, tmp.parent.name.startswith(".staging-a.json-"), tmp.stat().st_size
    ('a.json', True, 0)
    """
    final = Path(final)
    stage = new_stage_dir(final)
    tmp = stage / (final.name if final.name != MARKER else "marker.new")
    try:
        with open(tmp, "x"):             # 0o666 minus the umask
            pass
    except BaseException:
        drop_stage(stage)
        raise
    return tmp
