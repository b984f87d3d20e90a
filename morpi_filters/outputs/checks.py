"""Checks made before anything is computed: may a command write a folder or a file; the JSON header it stamps."""
from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from pathlib import Path, PurePosixPath

from ..errors import OutputError
from .atomic import write_json, write_text
from .claims import JSON_KEY, MARKER, OUTPUT_FORMAT, Claim, read_claim, unclaimed


_JSON_HEAD = re.compile(rb'^\s*\{\s*"' + JSON_KEY.encode() + rb'"\s*:\s*')


def _names(rels) -> str:
    """``a``, ``a and b``, ``a, b and c``, ``a, b, c and 2 more``."""
    if len(rels) > 3:
        return ", ".join(rels[:3]) + f" and {len(rels) - 3} more"
    return rels[0] if len(rels) == 1 else ", ".join(rels[:-1]) + " and " + rels[-1]


def _check_replaceable(folder: Path, option: str) -> None:
    """Refuse a folder that cannot be renamed away: the current directory, one holding it, a mount point."""
    real = os.path.realpath(folder)
    advice = "give a new or morpi-owned folder"
    with contextlib.suppress(OSError):
        cwd = os.path.realpath(os.getcwd())
        if cwd == real:
            raise OutputError(f"{option} {folder}: is the current directory, which cannot be replaced; {advice}")
        if cwd.startswith(real.rstrip(os.sep) + os.sep):
            raise OutputError(f"{option} {folder}: holds the current directory, which cannot be replaced; "
                                 f"{advice}")
    if os.path.ismount(real):
        raise OutputError(f"{option} {folder}: is a mount point, which cannot be replaced; {advice}")
    if folder.name in ("", ".", ".."):
        raise OutputError(f"{option} {folder}: ends in {folder.name!r}; name the output folder itself")


def check_output_dir(folder, option: str = "--out", kind: str | None = None, claimed=(), replace: bool = True,
                     writes=()) -> Path:
    """Refuse an output folder a command may not write, before anything is computed.

    Parameters
    ----------
    folder : str or Path
        The output folder.
    option : str
        Command-line option named in the message.
    kind : str, optional
        The kind of output the command writes there (a section name,
        ``"report"``, ``"dataset"``); a folder marked with another kind is
        refused. None accepts any kind.
    claimed : iterable of str
        Files (relative, ``/``-separated) the caller knows an earlier run
        wrote there besides what the marker lists, or without a marker (a
        synthetic dataset's manifest names its files).
    replace : bool
        True (default) when the folder is replaced whole: it must hold nothing
        its marker does not list, and must not be the current directory, hold
        it or be a mount point. False for a folder that is kept and only has
        the entries `writes` replaced (a report folder): it must be new,
        empty or marked with `kind`, and each of `writes` absent or listed.
    writes : iterable of str
        Entries a kept folder gets replaced (with ``replace=False``).

    Returns
    -------
    Path
        `folder`.

    Raises
    ------
    OutputError
        When `folder` is an empty name, a symbolic link or not a folder,
        holds entries without the marker or entries its marker does not
        list, holds another kind of output, cannot be renamed away, or cannot
        be created (its nearest existing parent does not accept a new file:
        read-only, not a folder, or a virtual system folder).

    Examples
    --------
    >>> import tempfile
    >>> from morpi_filters.outputs import staged_dir
    >>> d = Path(tempfile.mkdtemp())
    >>> check_output_dir(d / "reports") == d / "reports"
    True
    >>> _ = (d / "thesis.tex").write_text("")
    >>> check_output_dir(d, "--out")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    morpi_filters.errors.OutputError: --out ...: holds thesis.tex, which morpi did not write (no .morpi-output marker); refusing to replace it, choose a new or empty folder
    >>> with staged_dir(d / "drift") as stage:
    ...     _ = (stage / "README.md").write_text("page")
    >>> check_output_dir(d / "drift", kind="assessment")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    morpi_filters.errors.OutputError: --out .../drift: holds the drift output of morpi; refusing to put assessment output there (morpi never mixes or replaces another command's output), choose a new or empty folder
    """
    if str(folder) == "":
        raise OutputError(f"{option}: empty path, expected a folder name")
    folder = Path(folder)
    if folder.is_symlink():
        raise OutputError(f"{option} {folder}: is a symbolic link (no {MARKER} marker); refusing to replace it, "
                             "choose a new or empty folder")
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{option} {folder}: exists and is not a folder, expected an output folder")
    if folder.is_dir():
        if replace:
            _check_replaceable(folder, option)
        claim = read_claim(folder)
        if claim is None and claimed:
            claim = Claim()                  # no marker, but the caller knows what an earlier run wrote
        if claim is None:
            bad = unclaimed(folder, None)
            if bad:
                what = "is unreadable" if bad[0] == "" else f"holds {_names(bad)}, which morpi did not write"
                raise OutputError(f"{option} {folder}: {what} (no {MARKER} marker); refusing to replace it, "
                                     "choose a new or empty folder")
        else:
            if kind is not None and claim.kind is not None and claim.kind != kind:
                raise OutputError(
                    f"{option} {folder}: holds the {claim.kind} output of {claim.command}; refusing to put {kind} "
                    "output there (morpi never mixes or replaces another command's output), choose a new or "
                    "empty folder")
            bad = unclaimed(folder, claim, claimed)
            if not replace and claim.kind is not None:
                writes = set(writes)
                bad = [b for b in bad if b.split("/")[0] in writes]
            if bad:
                if bad == [""]:
                    what = "is unreadable"
                elif claim.kind is None:
                    what = (f"holds {_names(bad)}, which morpi cannot tell from your files (its {MARKER} marker, "
                            "from an earlier morpi version, lists no files)")
                else:
                    what = f"holds {_names(bad)}, which morpi did not write (not listed in its {MARKER} marker)"
                verb = "replace it" if replace else "write into it"
                raise OutputError(f"{option} {folder}: {what}; refusing to {verb}, move them out of it or "
                                     "choose another folder")
    _check_creatable(folder.parent, option, folder)
    return folder


def is_morpi_json(path) -> bool:
    """Whether `path` is a JSON file a morpi command wrote: it begins with the :data:`JSON_KEY` header.

    Only the first 4 kB are read.

    Parameters
    ----------
    path : str or Path
        A file.

    Returns
    -------
    bool
        True when the file is a JSON object whose first key is
        ``"morpi_output"``, an object with an integer ``"format"`` and a
        ``"command"`` starting with ``"morpi"``.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> p = write_json(d / "r.json", {"rms_m": 0.25})
    >>> is_morpi_json(p), is_morpi_json(stamp_json(p, "morpi drift", "drift"))
    (False, True)
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    m = _JSON_HEAD.match(head)
    if m is None:
        return False
    try:
        obj, _ = json.JSONDecoder().raw_decode(head[m.end():].decode("utf-8", "replace"))
    except ValueError:
        return False
    return (isinstance(obj, dict) and isinstance(obj.get("format"), int) and not isinstance(obj["format"], bool)
            and str(obj.get("command", "")).startswith("morpi"))


def stamp_json(path, command: str, section: str) -> Path:
    """Put the header :data:`JSON_KEY` first in the JSON object of file `path` (atomically).

    The header is ``{"format": OUTPUT_FORMAT, "command": command,
    "section": section}``, on one line; the rest of the file is kept as it
    is (a header already there is replaced).

    Parameters
    ----------
    path : str or Path
        A file holding a JSON object.
    command : str
        The command that wrote it (``"morpi drift"``).
    section : str
        The section it holds (``"drift"``).

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    OutputError
        The file does not hold a JSON object.

    Examples
    --------
    >>> import tempfile
    >>> p = write_json(Path(tempfile.mkdtemp()) / "r.json", {"rms_m": 0.25})
    >>> print(stamp_json(p, "morpi drift", "drift").read_text(), end="")
    {
      "morpi_output": {"format": 1, "command": "morpi drift", "section": "drift"},
      "rms_m": 0.25
    }
    """
    path = Path(path)
    text = path.read_text()
    try:
        obj = json.loads(text)
    except ValueError as exc:
        raise OutputError(f"{path}: not JSON ({exc})") from None
    if not isinstance(obj, dict):
        raise OutputError(f"{path}: holds a JSON {type(obj).__name__}, expected an object")
    header = {"format": OUTPUT_FORMAT, "command": command, "section": section}
    if JSON_KEY in obj:
        obj.pop(JSON_KEY)
        return write_json(path, {JSON_KEY: header, **obj})
    head = json.dumps({JSON_KEY: header})[1:-1]
    body = text.strip()[1:]
    new = "{" + head + body if not obj else "{\n  " + head + "," + body
    return write_text(path, new + "\n")


def check_output_file(path, option: str = "--json", force: bool = False, folder=None) -> Path:
    """Refuse an output file path before anything is computed.

    An existing file is overwritten only when morpi wrote it
    (:func:`is_morpi_json`) or `force` is set. A file inside `folder` (the
    command's output folder) is written into the new folder and checked
    with it.

    Parameters
    ----------
    path : str or Path
        The output file.
    option : str
        Command-line option named in the message.
    force : bool
        Overwrite an existing file morpi did not write.
    folder : str or Path, optional
        The output folder of the same command.

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    OutputError
        An empty name, a folder, an existing non-regular file, an existing
        file morpi did not write (without `force`), the output folder itself,
        a path the output folder would lie in, or a place where no file can be
        created.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> check_output_file(d / "out.json").name
    'out.json'
    >>> check_output_file(d)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    morpi_filters.errors.OutputError: --json ...: is a folder, expected a file name
    >>> _ = (d / "mine.json").write_text('{"a": 1}')
    >>> check_output_file(d / "mine.json")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    morpi_filters.errors.OutputError: --json .../mine.json: exists and morpi did not write it (...); refusing to overwrite it, choose another file name or pass --force
    >>> check_output_file(d / "mine.json", force=True).name
    'mine.json'
    """
    if str(path) == "":
        raise OutputError(f"{option}: empty path, expected a file name")
    path = Path(path)
    if folder is not None:
        rel = inside(path, folder)
        if rel == ".":
            raise OutputError(f"{option} {path}: is the output folder {folder}, expected a file name")
        if rel is not None:
            if PurePosixPath(rel).name == MARKER:
                raise OutputError(f"{option} {path}: {MARKER} is the name of morpi's folder marker, "
                                     "expected another file name")
            return path                       # goes into the new output folder, checked with it
        if inside(folder, path) is not None:
            raise OutputError(f"{option} {path}: the output folder {folder} would lie inside it, "
                                 "expected a file name")
    if path.is_dir():
        raise OutputError(f"{option} {path}: is a folder, expected a file name")
    if path.exists() and not path.is_file():
        raise OutputError(f"{option} {path}: exists and is not a regular file")
    if path.is_file() and not force and not is_morpi_json(path):
        raise OutputError(f"{option} {path}: exists and morpi did not write it (a morpi JSON begins with the "
                             f"key \"{JSON_KEY}\"); refusing to overwrite it, choose another file name or pass --force")
    _check_creatable(path.parent, option, path)
    return path


def inside(path, folder):
    """`path` relative to `folder` (``"."`` for the folder itself) when it lies inside it, else None."""
    p = os.path.join(os.path.realpath(Path(path).parent), Path(path).name) if Path(path).name else \
        os.path.realpath(path)
    f = os.path.realpath(folder)
    if p == f:
        return "."
    if p.startswith(f.rstrip(os.sep) + os.sep):
        return PurePosixPath(*Path(os.path.relpath(p, f)).parts).as_posix()
    return None


def _check_creatable(parent: Path, option: str, target: Path) -> None:
    """Check that a file can be created in `parent` (or its nearest existing ancestor)."""
    probe = Path(os.path.abspath(parent))
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{option} {target}: {probe} is not a folder")
    try:
        with tempfile.TemporaryFile(dir=probe, prefix=".morpi-probe-"):
            pass
    except OSError as exc:
        raise OutputError(f"{option} {target}: cannot write in {probe} ({exc.strerror or exc})") from None
