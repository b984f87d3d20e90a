"""Owned outputs: the :data:`MARKER` file, the staging folders it proves, and removing only what it lists.

Staging folders are named ``.staging-<name>-<pid>-<token>`` (``.previous-...``
for an output being replaced) and hold, from their creation, a marker with the
same process id and random token. A later run removes those of dead processes
(:func:`remove_stale`) and nothing else: a file, or a folder that merely looks
like a staging name, is never touched. A replaced output is removed by its
marker's list (:func:`swap_in`); whatever it does not list is kept.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path


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


@dataclass(frozen=True)
class Claim:
    """What a folder's marker says: the writer, the kind of output, the entries it wrote."""

    kind: str | None = None            # None: a marker of an earlier version (it lists nothing)
    command: str | None = None
    files: frozenset = frozenset()
    folders: frozenset = frozenset()
    staged_as: dict | None = None


def read_claim(folder: Path):
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
        return Claim()
    if not (isinstance(obj, dict) and isinstance(obj.get(JSON_KEY), int) and isinstance(obj.get("kind"), str)):
        return Claim()
    files, folders = obj.get("files", []), obj.get("folders", [])
    if not (isinstance(files, list) and isinstance(folders, list)):
        return Claim()
    staged = obj.get("staged_as")
    return Claim(kind=obj["kind"], command=str(obj.get("command", "morpi")),
                 files=frozenset(f for f in files if _safe_rel(f)),
                 folders=frozenset(f for f in folders if _safe_rel(f)),
                 staged_as=staged if isinstance(staged, dict) else None)


def _safe_rel(rel) -> bool:
    """Whether `rel` is a relative path that stays inside its folder."""
    if not isinstance(rel, str) or rel == "" or rel.startswith("/") or "\\" in rel:
        return False
    return all(part not in ("", ".", "..") for part in rel.split("/"))


def marker_text(tool: str, kind: str, files=(), folders=(), staged_as=None, kept: bool = False) -> str:
    """The JSON text of a marker: writer, kind, the entries it lists, and a staging proof or a kept folder's note."""
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
    claim = read_claim(entry)
    if claim is None or claim.staged_as != {"pid": int(m["pid"]), "token": m["token"]}:
        return None
    return m


def unclaimed(folder: Path, claim, claimed=()) -> list:
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
    claim = read_claim(folder)
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
    >>> from morpi_filters.outputs import staged_dir
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
    bad = unclaimed(folder, read_claim(folder))
    if not bad:
        return None
    return folder if bad[0] == "" else folder / bad[0]


def new_stage(final: Path, prefix: str, tool: str, kind: str) -> Path:
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
        (stage / MARKER).write_text(marker_text(tool, kind, staged_as={"pid": pid, "token": token}))
    except BaseException:
        with contextlib.suppress(OSError):
            (stage / MARKER).unlink()
        with contextlib.suppress(OSError):
            stage.rmdir()
        raise
    return stage


def drop_stage(stage: Path) -> None:
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
    return new_stage(Path(final), "staging", "morpi", "staging")


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
    >>> env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))       # this package
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
            drop_stage(entry)
        if entry.exists():
            failed.append(entry)
    return failed


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
    >>> from morpi_filters.outputs import staged_dir
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
    keep = new_stage(final, "previous", "morpi", "previous")
    try:
        os.replace(final, keep / final.name)
    except BaseException:
        drop_stage(keep)
        raise
    try:
        os.replace(stage, final)
    except BaseException:
        os.replace(keep / final.name, final)
        drop_stage(keep)
        raise
    if _remove_owned(keep / final.name, claimed):
        drop_stage(keep)
        return None
    return keep
