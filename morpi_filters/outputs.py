"""Writing outputs safely: atomic files, staged folders, owned outputs.

Every output file is written in a staging folder beside its destination and
renamed into place, so an interrupted run never leaves half a file. A report
section is built in a staging folder beside its destination and swapped in
only when it is complete, so an interrupted run leaves the previous complete
section in place. All outputs of one command (its folders and its ``--json``
file) are staged by one :class:`Outputs` and swapped in together at the end.

A command writes only what it owns. Every folder a command writes holds the
marker file :data:`MARKER`: a JSON object naming the command, the kind of
output (a report section such as ``"tables"``, ``"report"`` for a report
folder, ``"dataset"`` for a synthetic dataset) and every file and folder the
command wrote there. An output folder is replaced only when it does not exist,
is empty, or holds a marker of the same kind and nothing its marker does not
list. Anything else is refused with one line before anything is computed: a
folder without the marker, another command's kind of output (never mixed
with it, never replaced), or a file the user added to a morpi folder (named;
move it out and run again). A report folder itself is never replaced, only
the entries its marker lists (``index.md``; each section folder under the rule
above); the other entries stay. A marker of an earlier version (plain text,
no list) vouches for nothing but itself. The current directory, a folder
holding it and a mount point are never replaced.

Every JSON file a command writes (a section's ``result.json`` and its
``--json`` copy) begins with the key :data:`JSON_KEY`, an object naming the
format, the command and the section (:func:`stamp_json`); an existing
``--json`` file is overwritten only when it begins so (:func:`is_morpi_json`),
unless the caller forces it.

Staging folders are named ``.staging-<name>-<pid>-<token>`` (``.previous-...``
for an output being replaced) and hold, from their creation, a marker with the
same process id and random token. A later run removes those of dead processes
(:func:`remove_stale`) and nothing else: a file, or a folder that merely looks
like a staging name, is never touched. A replaced output is removed by its
marker's list; whatever it does not list is kept. Folders and files get the
permissions the user's umask gives, not the private ones of temporary files.

What a result is and when two are the same (JSON precision, the same-result rule):
:mod:`morpi_filters.results`.
"""
from __future__ import annotations

import contextlib
import functools
import json
import os
import re
import secrets
import shutil
import stat
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from .errors import OutputError

from .results import JSON_DIGITS, same_output, to_jsonable

__all__ = [
    "atomic_path", "write_text", "write_json", "staged_dir", "MARKER", "JSON_KEY", "OUTPUT_FORMAT", "Outputs",
    "check_output_dir", "check_output_file", "remove_stale", "swap_in", "foreign_entry", "user_umask", "new_stage_dir",
    "new_temp_file", "stamp_json", "is_morpi_json",
]


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
        _drop_stage(tmp.parent)


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


@contextlib.contextmanager
def staged_dir(final, tool: str = "morpi"):
    """Build a folder in a staging place and swap it in when complete.

    Yields the staging folder. On success the marker listing everything in
    it is written and the previous `final` folder is replaced; on an
    exception the staging folder is removed and `final` is left exactly as
    it was. `final` must be absent, empty or an earlier output of the same
    kind holding only what its marker lists (see :func:`check_output_dir`;
    the kind is the folder's name), otherwise a :class:`OutputError` is
    raised before anything is written.

    Parameters
    ----------
    final : str or Path
        The output folder.
    tool : str
        Writer named in the marker file.

    Yields
    ------
    Path
        The staging folder to fill.

    Examples
    --------
    >>> import tempfile
    >>> final = Path(tempfile.mkdtemp()) / "section"
    >>> with staged_dir(final) as stage:
    ...     _ = (stage / "README.md").write_text("page")
    ...     final.exists()
    False
    >>> sorted(p.name for p in final.iterdir())
    ['.morpi-output', 'README.md']
    >>> json.loads((final / MARKER).read_text())["files"]
    ['README.md']
    """
    with Outputs(tool) as outputs:
        yield outputs.folder(final)


# ----------------------------------------------------------------------------- output ownership

#: Name of the file that marks a folder as written by a morpi command: a JSON
#: object with the format (``"morpi_output"``), the ``"command"``, the
#: ``"kind"`` of output and the ``"files"`` and ``"folders"`` it wrote there
#: (relative, ``/``-separated); a folder built in a staging folder also keeps
#: its ``"staged_as"`` (the pid and token of the staging name). The next run
#: that writes the same kind of output may replace the folder while it holds
#: nothing else.
MARKER = ".morpi-output"

#: Version of the marker's and of the JSON header's layout.
OUTPUT_FORMAT = 1

#: First key of every JSON file a morpi command writes: ``{"format": 1,
#: "command": "morpi drift", "section": "drift"}``.
JSON_KEY = "morpi_output"

_STAGE_RE = re.compile(r"^\.(?P<kind>staging|previous)-(?P<name>.+)-(?P<pid>[0-9]+)-(?P<token>[0-9a-f]{16})$")
_JSON_HEAD = re.compile(rb'^\s*\{\s*"' + JSON_KEY.encode() + rb'"\s*:\s*')


@dataclass(frozen=True)
class _Claim:
    """What a folder's marker says: the writer, the kind of output, the entries it wrote."""

    kind: str | None = None            # None: a marker of an earlier version (it lists nothing)
    command: str | None = None
    files: frozenset = frozenset()
    folders: frozenset = frozenset()
    staged_as: dict | None = None


def _read_claim(folder: Path):
    """The claim of `folder`'s marker; None when the folder holds no marker (a regular file)."""
    path = Path(folder) / MARKER
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return None
        text = path.read_text(errors="replace")
    except OSError:
        return None
    try:
        obj = json.loads(text)
    except ValueError:
        return _Claim()
    if not (isinstance(obj, dict) and isinstance(obj.get(JSON_KEY), int) and isinstance(obj.get("kind"), str)):
        return _Claim()
    files, folders = obj.get("files", []), obj.get("folders", [])
    if not (isinstance(files, list) and isinstance(folders, list)):
        return _Claim()
    staged = obj.get("staged_as")
    return _Claim(kind=obj["kind"], command=str(obj.get("command", "morpi")),
                  files=frozenset(f for f in files if _safe_rel(f)),
                  folders=frozenset(f for f in folders if _safe_rel(f)),
                  staged_as=staged if isinstance(staged, dict) else None)


def _safe_rel(rel) -> bool:
    """Whether `rel` is a relative path that stays inside its folder."""
    if not isinstance(rel, str) or rel == "" or rel.startswith("/") or "\\" in rel:
        return False
    return all(part not in ("", ".", "..") for part in rel.split("/"))


def _marker_text(tool: str, kind: str, files=(), folders=(), staged_as=None, kept: bool = False) -> str:
    if kept:
        note = (f"Written by {tool}. This folder is kept: a later {tool} replaces the entries listed here (each "
                "folder under its own marker) and leaves everything else in place.")
    elif kind == "previous":
        note = "An output being replaced by a morpi command; the next morpi run removes it."
    elif kind == "staging":
        note = "A morpi command's work in progress; the next morpi run removes it if the command was killed."
    else:
        note = (f"Written by {tool}. A later morpi command that writes {kind} output replaces the entries listed "
                "here; it stops before computing, naming them, while the folder holds anything else, and leaves "
                "everything it does not list in place.")
    content = {JSON_KEY: OUTPUT_FORMAT, "command": tool, "kind": kind, "note": note,
               "files": sorted(files), "folders": sorted(folders)}
    if staged_as is not None:
        content["staged_as"] = staged_as
    return json.dumps(content, indent=1) + "\n"


def _listing(folder: Path):
    """Every file and folder under `folder` (relative, ``/``-separated), the top-level marker left out."""
    files, folders = [], []

    def walk(d: Path, rel: str):
        with os.scandir(d) as it:
            entries = sorted(it, key=lambda e: e.name)
        for e in entries:
            r = rel + e.name
            if not rel and e.name == MARKER:
                continue
            if e.is_dir(follow_symlinks=False):
                folders.append(r)
                walk(Path(e.path), r + "/")
            else:
                files.append(r)

    walk(Path(folder), "")
    return files, folders


def _settle_marker(folder: Path) -> None:
    """Drop the staging proof (``"staged_as"``) from the marker of a folder swapped into place.

    The proof is needed only while the folder carries its staging name; the
    placed marker then lists just what the output is, so the same output
    gives the same marker bytes on every run. A run killed before this step
    leaves the proof in a folder whose name no longer matches a staging name,
    where it proves nothing, and the next run's marker replaces it.
    """
    marker = folder / MARKER
    try:
        content = json.loads(marker.read_text())
    except (OSError, ValueError):
        return
    if isinstance(content, dict) and content.pop("staged_as", None) is not None:
        write_text(marker, json.dumps(content, indent=1) + "\n")


def _proven_stage(entry: Path):
    """The name match of `entry` when it is a staging folder a morpi run created, else None.

    Proof: a real folder named ``.staging-<name>-<pid>-<token>`` (or ``.previous-...``) holding a marker
    written with the same pid and token.
    """
    m = _STAGE_RE.match(entry.name)
    if m is None:
        return None
    try:
        if not stat.S_ISDIR(os.lstat(entry).st_mode):
            return None
    except OSError:
        return None
    claim = _read_claim(entry)
    if claim is None or claim.staged_as != {"pid": int(m["pid"]), "token": m["token"]}:
        return None
    return m


def _unclaimed(folder: Path, claim, claimed=()) -> list:
    """Entries of `folder` that neither its marker nor `claimed` lists, sorted (``""``: `folder` is unreadable).

    A claimed folder is walked; an unclaimed one is one entry. Staging folders of morpi runs do not count.
    """
    files = set(claim.files) if claim is not None else set()
    folders = set(claim.folders) if claim is not None else set()
    for rel in claimed:
        if _safe_rel(rel):
            files.add(rel)
            parts = rel.split("/")
            folders.update("/".join(parts[:i]) for i in range(1, len(parts)))
    out = []

    def walk(d: Path, rel: str):
        try:
            with os.scandir(d) as it:
                entries = sorted(it, key=lambda e: e.name)
        except OSError:
            out.append(rel.rstrip("/"))
            return
        for e in entries:
            r = rel + e.name
            if (not rel and e.name == MARKER and claim is not None) or _proven_stage(Path(e.path)) is not None:
                continue
            try:
                is_dir = e.is_dir(follow_symlinks=False)
            except OSError:
                is_dir = False
            if is_dir and r in folders:
                walk(Path(e.path), r + "/")
            elif is_dir or r not in files:
                out.append(r)

    walk(Path(folder), "")
    return out


def _owned_path(folder: Path, rel: str):
    """``folder / rel`` when every folder on the way is a real folder (no symbolic link), else None."""
    if not _safe_rel(rel):
        return None
    p = Path(folder)
    for part in rel.split("/")[:-1]:
        p = p / part
        try:
            if not stat.S_ISDIR(os.lstat(p).st_mode):
                return None
        except OSError:
            return None
    return p / rel.split("/")[-1]


def _remove_owned(folder: Path, claimed=()) -> bool:
    """Remove what `folder`'s marker (and `claimed`) lists, then the folder if nothing else is left in it.

    Entries the marker does not list stay where they are, and so does the folder holding them.

    Returns
    -------
    bool
        True when `folder` is gone.
    """
    folder = Path(folder)
    claim = _read_claim(folder)
    files = set(claimed) | (set(claim.files) if claim is not None else set())
    folders = set(claim.folders) if claim is not None else set()
    for rel in files:
        folders.update("/".join(rel.split("/")[:i]) for i in range(1, rel.count("/") + 1))
    for rel in sorted(files):
        p = _owned_path(folder, rel)
        if p is not None:
            try:
                if not stat.S_ISDIR(os.lstat(p).st_mode):
                    p.unlink()
            except OSError:
                pass
    for rel in sorted(folders, key=lambda r: -r.count("/")):
        p = _owned_path(folder, rel)
        if p is not None and not p.is_symlink():
            with contextlib.suppress(OSError):
                p.rmdir()
    try:
        rest = [n for n in os.listdir(folder) if n != MARKER]
    except OSError:
        return False
    if rest:
        return False
    with contextlib.suppress(FileNotFoundError):
        (folder / MARKER).unlink()
    try:
        folder.rmdir()
    except OSError:
        return False
    return True


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


def _new_stage(final: Path, prefix: str, tool: str, kind: str) -> Path:
    """Create ``.<prefix>-<name>-<pid>-<token>`` beside `final`, holding its marker (the proof it is ours)."""
    final = Path(final)
    pid = os.getpid()
    while True:
        token = secrets.token_hex(8)
        stage = final.parent / f".{prefix}-{final.name[:64]}-{pid}-{token}"
        try:
            os.mkdir(stage)               # 0o777 minus the umask
        except FileExistsError:
            continue
        break
    try:
        (stage / MARKER).write_text(_marker_text(tool, kind, staged_as={"pid": pid, "token": token}))
    except BaseException:
        with contextlib.suppress(OSError):
            (stage / MARKER).unlink()
        with contextlib.suppress(OSError):
            stage.rmdir()
        raise
    return stage


def _drop_stage(stage: Path) -> None:
    """Remove a staging folder of files (a temporary file and the marker); a folder in it keeps it."""
    with contextlib.suppress(OSError):
        for entry in os.scandir(stage):
            if not entry.is_dir(follow_symlinks=False):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)
        os.rmdir(stage)


def new_stage_dir(final) -> Path:
    """Create an empty staging folder beside `final` with the user's folder permissions.

    Its name, ``.staging-<name>-<pid>-<token>``, carries this process's id
    and a random token; the marker in it (:data:`MARKER`) holds the same
    two, the proof :func:`remove_stale` needs to remove it once this process
    is gone.

    Parameters
    ----------
    final : str or Path
        The folder being built; its parent must exist.

    Returns
    -------
    Path
        The new folder, in ``final.parent``, holding only its marker.

    Examples
    --------
    >>> import os, tempfile
    >>> stage = new_stage_dir(Path(tempfile.mkdtemp()) / "tables")
    >>> stage.name.startswith(f".staging-tables-{os.getpid()}-"), [p.name for p in stage.iterdir()]
    (True, ['.morpi-output'])
    """
    return _new_stage(Path(final), "staging", "morpi", "staging")


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
        _drop_stage(stage)
        raise
    return tmp


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


def remove_stale(folder) -> list:
    """Remove the staging folders that killed morpi runs left in `folder`.

    Only a folder proven to be a morpi run's staging folder is touched: named
    ``.staging-<name>-<pid>-<token>`` or ``.previous-<name>-<pid>-<token>``
    and holding the marker written with that pid and token when it was
    created, by a process no longer alive. A ``.staging`` folder is removed.
    A ``.previous`` folder holds an output being replaced: it is put back
    when its place is empty (the run was killed between the two renames),
    else removed by its marker's list; entries the list does not name are
    kept, with the folder. Files, and folders that only look like staging
    names, are never touched.

    Parameters
    ----------
    folder : str or Path
        Folder to clean; a missing or unreadable one is left alone.

    Returns
    -------
    list of Path
        Leftovers that could not be removed (or hold entries morpi did not write).

    Examples
    --------
    >>> import os, subprocess, sys, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> code = f"from morpi_filters.outputs import new_stage_dir; new_stage_dir({str(d / 'tables')!r})"
    >>> env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))       # this package
    >>> _ = subprocess.run([sys.executable, "-c", code], check=True, env=env)  # a run that left its stage
    >>> (d / ".staging-notes-1-abcdef0123456789").mkdir()              # looks like one, holds no proof
    >>> mine = new_stage_dir(d / "curves")                              # this process: kept
    >>> remove_stale(d), sorted(p.name[:15] for p in d.iterdir())
    ([], ['.staging-curves', '.staging-notes-'])
    """
    folder = Path(folder)
    try:
        entries = sorted(folder.iterdir())
    except OSError:
        return []
    failed = []
    for entry in entries:
        m = _proven_stage(entry)
        if m is None or _pid_alive(int(m["pid"])):
            continue
        if m["kind"] == "staging":
            try:
                shutil.rmtree(entry)
            except OSError:
                failed.append(entry)
            continue
        try:
            children = sorted(entry.iterdir())
        except OSError:
            failed.append(entry)
            continue
        done = True
        for child in children:
            if child.name == MARKER:
                continue
            if not (child.is_dir() and not child.is_symlink()):
                done = False
                continue
            place = folder / child.name
            try:
                if not place.exists() and not place.is_symlink():
                    swap_in(child, place)                       # the new output never arrived: the old one back
                    continue
            except OSError:
                done = False
                continue
            done = _remove_owned(child) and done
        if done:
            _drop_stage(entry)
        if entry.exists():
            failed.append(entry)
    return failed


def foreign_entry(folder):
    """The first entry that makes `folder` someone else's, or None if a command may replace it.

    A folder may be replaced when it does not exist, is empty, or holds
    :data:`MARKER` and nothing its marker does not list. Staging folders of
    morpi runs do not count.

    Parameters
    ----------
    folder : str or Path
        The candidate output folder.

    Returns
    -------
    Path or None
        None when the folder may be replaced; else `folder` itself (a file,
        a symbolic link or unreadable) or its first entry morpi did not
        write, by name.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> foreign_entry(d / "new") is None, foreign_entry(d) is None
    (True, True)
    >>> with staged_dir(d / "out") as stage:
    ...     _ = (stage / "README.md").write_text("page")
    >>> foreign_entry(d / "out") is None
    True
    >>> _ = (d / "out" / "notes.txt").write_text("mine")
    >>> foreign_entry(d / "out").name
    'notes.txt'
    """
    folder = Path(folder)
    if not folder.exists() and not folder.is_symlink():
        return None
    if folder.is_symlink() or not folder.is_dir():
        return folder
    bad = _unclaimed(folder, _read_claim(folder))
    if not bad:
        return None
    return folder if bad[0] == "" else folder / bad[0]


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
        claim = _read_claim(folder)
        if claim is None and claimed:
            claim = _Claim()                  # no marker, but the caller knows what an earlier run wrote
        if claim is None:
            bad = _unclaimed(folder, None)
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
            bad = _unclaimed(folder, claim, claimed)
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
        rel = _inside(path, folder)
        if rel == ".":
            raise OutputError(f"{option} {path}: is the output folder {folder}, expected a file name")
        if rel is not None:
            if PurePosixPath(rel).name == MARKER:
                raise OutputError(f"{option} {path}: {MARKER} is the name of morpi's folder marker, "
                                     "expected another file name")
            return path                       # goes into the new output folder, checked with it
        if _inside(folder, path) is not None:
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


def _inside(path, folder):
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


def _same(a, b) -> bool:
    return os.path.realpath(a) == os.path.realpath(b)


class Outputs:
    """Every output of one command, staged aside and swapped in together at the end.

    Use as a context manager: :meth:`folder` and :meth:`file` return the
    staging paths to write; leaving the block normally checks every output
    again under the ownership rule, writes each folder's marker (listing
    everything staged in it), swaps every staged folder in and then renames
    every staged file into place; an exception removes everything staged and
    leaves the previous outputs exactly as they were. A staged ``.json`` or
    ``.md`` file of a folder, or any staged file, that states the same result
    as the file it replaces (:func:`same_output`) is not written: the
    previous file's bytes and modification time stay (see the module
    docstring).

    Parameters
    ----------
    tool : str
        What the marker file names as the writer (e.g. ``"morpi tables"``).

    Examples
    --------
    >>> import json, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> with Outputs("morpi example") as out:
    ...     _ = (out.folder(d / "tables") / "README.md").write_text("page")
    ...     _ = out.file(d / "result.json").write_text("{}")
    ...     sorted(p.name for p in d.iterdir() if not p.name.startswith("."))   # nothing in place yet
    []
    >>> sorted(p.name for p in d.iterdir())
    ['result.json', 'tables']
    """

    def __init__(self, tool: str):
        self.tool = tool
        self._folders = []   # (stage, final, kind, claimed)
        self._files = []     # (tmp, final, force, root or None)
        self._roots = []     # (folder, kind): folders kept, with only some entries replaced
        self._made = []      # parent folders created here (removed again on failure if empty)

    def _mkdirs(self, folder: Path) -> None:
        missing = []
        p = Path(os.path.abspath(folder))
        while not p.exists() and p.parent != p:
            missing.append(p)
            p = p.parent
        folder.mkdir(parents=True, exist_ok=True)
        self._made.extend(missing)   # deepest first

    def folder(self, final, section: str | None = None, claimed=()) -> Path:
        """A staging folder for output folder `final`, swapped in at the end of the block.

        Parameters
        ----------
        final : str or Path
            The output folder (checked with :func:`check_output_dir`).
        section : str, optional
            The kind of output the marker records (default the folder's name).
        claimed : iterable of str
            Files an earlier run wrote in `final` besides what its marker lists
            (see :func:`check_output_dir`).

        Returns
        -------
        Path
            The staging folder.
        """
        final = Path(final)
        kind = section or final.name
        claimed = tuple(claimed)
        check_output_dir(final, kind=kind, claimed=claimed)
        self._mkdirs(final.parent)
        stage = _new_stage(final, "staging", self.tool, kind)
        self._folders.append((stage, final, kind, claimed))
        return stage

    def root(self, folder, kind: str = "report") -> Path:
        """Claim `folder` as a folder that is kept, whose entries written here are replaced one by one.

        Entries a command does not write stay untouched. It must pass
        :func:`check_output_dir` with ``replace=False``; its marker, written
        at the end, lists what was ever written there.

        Parameters
        ----------
        folder : str or Path
            The report folder.
        kind : str
            The kind of folder its marker records.

        Returns
        -------
        Path
            `folder` (created if missing).
        """
        folder = check_output_dir(Path(folder), kind=kind, replace=False)
        self._mkdirs(folder)
        self._roots.append((folder, kind))
        return folder

    def file(self, final, force: bool = False) -> Path:
        """A temporary file for `final`, renamed to `final` at the end.

        A file inside a folder staged here is written straight into the
        staging folder (and listed by its marker).

        Parameters
        ----------
        final : str or Path
            The output file (checked with :func:`check_output_file`, or as an
            entry of its kept folder, see :meth:`root`).
        force : bool
            Overwrite an existing file morpi did not write.

        Returns
        -------
        Path
            The temporary file to write.
        """
        final = Path(final)
        for stage, folder, _, _ in self._folders:
            rel = _inside(final, folder)
            if rel is not None:
                check_output_file(final, force=force, folder=folder)
                tmp = stage / rel
                tmp.parent.mkdir(parents=True, exist_ok=True)
                with open(tmp, "a"):
                    pass
                return tmp
        root = next((r for r in self._roots if _same(final.parent, r[0])), None)
        if root is not None:
            check_output_dir(root[0], kind=root[1], replace=False, writes=(final.name,))
            final = check_output_file(final, force=True)
        else:
            final = check_output_file(final, force=force)
        self._mkdirs(final.parent)
        tmp = new_temp_file(final)
        self._files.append((tmp, final, force, root))
        return tmp

    def __enter__(self):
        return self

    def _check_again(self) -> None:
        for folder, kind in self._roots:
            writes = [final.name for _, final, _, root in self._files if root is not None and root[0] == folder]
            check_output_dir(folder, kind=kind, replace=False, writes=writes)
        for _, final, kind, claimed in self._folders:
            check_output_dir(final, kind=kind, claimed=claimed)
        for _, final, force, root in self._files:
            if root is None:
                check_output_file(final, force=force)

    def _mark(self) -> None:
        """Write the marker of every staged folder and kept folder, listing what it holds."""
        for stage, _, kind, _ in self._folders:
            files, folders = _listing(stage)
            staged = _read_claim(stage).staged_as
            write_text(stage / MARKER, _marker_text(self.tool, kind, files, folders, staged_as=staged))
        for folder, kind in self._roots:
            old = _read_claim(folder)
            files, folders = set(), set()
            if old is not None and old.kind == kind:
                files = {n for n in old.files if (folder / n).is_file()}
                folders = {n for n in old.folders if (folder / n).is_dir()}
            files |= {final.name for _, final, _, root in self._files if root is not None and root[0] == folder}
            folders |= {final.name for _, final, _, _ in self._folders if _same(final.parent, folder)}
            tmp = new_temp_file(folder / MARKER)
            self._files.append((tmp, folder / MARKER, True, (folder, kind)))
            tmp.write_text(_marker_text(self.tool, kind, files, folders, kept=True))

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self._discard()
            return False
        try:
            self._check_again()
            self._mark()                     # lists every output, kept or not, before ...
            self._keep_unchanged()           # ... an unchanged file is dropped from the writes
        except BaseException:
            self._discard()
            raise
        final, kept = None, []
        try:
            for stage, final, _, claimed in self._folders:
                left = swap_in(stage, final, claimed)
                if left is not None:
                    kept.append(left)
            for tmp, final, _, _ in self._files:
                os.replace(tmp, final)
                _drop_stage(tmp.parent)
        except OSError as exc:
            self._discard()
            raise OutputError(f"{final}: cannot put the new output in place ({exc.strerror or exc})") from None
        for _, final, _, _ in self._folders:
            _settle_marker(final)
        for left in kept:
            print(f"morpi: kept {left}: the output it replaced held entries morpi did not write", file=sys.stderr)
        return False

    def _keep_unchanged(self):
        """Give every staged output that states the same result as its previous file that file's bytes."""
        for stage, final, *_ in self._folders:
            if not final.is_dir() or final.is_symlink():
                continue
            for new in sorted(stage.rglob("*")):
                old = final / new.relative_to(stage)
                if (new.suffix in (".json", ".md") and new.is_file() and not new.is_symlink()
                        and old.is_file() and not old.is_symlink() and same_output(old, new)):
                    shutil.copy2(old, new)
        changed = []
        for entry in self._files:
            tmp, final = entry[0], entry[1]
            if final.is_file() and not final.is_symlink() and same_output(final, tmp):
                _drop_stage(tmp.parent)          # the temporary file and the staging folder holding it
            else:
                changed.append(entry)
        self._files = changed

    def _discard(self):
        for stage, *_ in self._folders:
            if stage.exists():
                shutil.rmtree(stage, ignore_errors=True)
        for tmp, *_ in self._files:
            _drop_stage(tmp.parent)
        for folder in self._made:
            with contextlib.suppress(OSError):
                folder.rmdir()


def swap_in(stage: Path, final: Path, claimed=()):
    """Rename the staging folder `stage` to `final`; a folder already at `final` is replaced.

    The old folder is first moved aside (into a ``.previous-...`` staging
    folder) and, after the rename, removed by its marker's list (and
    `claimed`), so `final` always names a complete folder and entries the old
    folder's marker does not list are never deleted: they stay, with the
    ``.previous-...`` folder holding them.

    Parameters
    ----------
    stage : Path
        The complete staging folder.
    final : Path
        Destination, in the same file system.
    claimed : iterable of str
        Files of the old folder to remove besides those its marker lists.

    Returns
    -------
    Path or None
        None; or the ``.previous-...`` folder kept because the old folder held
        entries its marker does not list.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> with staged_dir(d / "out") as stage:
    ...     _ = (stage / "old.md").write_text("old")
    >>> stage = new_stage_dir(d / "out"); _ = (stage / "new.md").write_text("new")
    >>> swap_in(stage, d / "out") is None
    True
    >>> sorted(p.name for p in d.iterdir()), sorted(p.name for p in (d / "out").iterdir())
    (['out'], ['.morpi-output', 'new.md'])
    """
    stage, final = Path(stage), Path(final)
    if not final.is_dir() or final.is_symlink():
        os.replace(stage, final)
        return None
    keep = _new_stage(final, "previous", "morpi", "previous")
    try:
        os.replace(final, keep / final.name)
    except BaseException:
        _drop_stage(keep)
        raise
    try:
        os.replace(stage, final)
    except BaseException:
        os.replace(keep / final.name, final)
        _drop_stage(keep)
        raise
    if _remove_owned(keep / final.name, claimed):
        _drop_stage(keep)
        return None
    return keep
