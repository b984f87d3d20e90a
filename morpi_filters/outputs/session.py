"""One command's outputs (:class:`Outputs`), staged aside and swapped in together; :func:`staged_dir` for one folder."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
from pathlib import Path

from ..errors import OutputError
from ..results import same_output
from .atomic import new_temp_file, write_text
from .checks import check_output_dir, check_output_file, inside
from .claims import MARKER, drop_stage, marker_text, new_stage, read_claim, swap_in


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
        stage = new_stage(final, "staging", self.tool, kind)
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
            rel = inside(final, folder)
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
            staged = read_claim(stage).staged_as
            write_text(stage / MARKER, marker_text(self.tool, kind, files, folders, staged_as=staged))
        for folder, kind in self._roots:
            old = read_claim(folder)
            files, folders = set(), set()
            if old is not None and old.kind == kind:
                files = {n for n in old.files if (folder / n).is_file()}
                folders = {n for n in old.folders if (folder / n).is_dir()}
            files |= {final.name for _, final, _, root in self._files if root is not None and root[0] == folder}
            folders |= {final.name for _, final, _, _ in self._folders if _same(final.parent, folder)}
            tmp = new_temp_file(folder / MARKER)
            self._files.append((tmp, folder / MARKER, True, (folder, kind)))
            tmp.write_text(marker_text(self.tool, kind, files, folders, kept=True))

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
                drop_stage(tmp.parent)
        except OSError as err:
            self._discard()
            raise OutputError(f"{final}: cannot put the new output in place ({err.strerror or err})") from None
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
                drop_stage(tmp.parent)          # the temporary file and the staging folder holding it
            else:
                changed.append(entry)
        self._files = changed

    def _discard(self):
        for stage, *_ in self._folders:
            if stage.exists():
                shutil.rmtree(stage, ignore_errors=True)
        for tmp, *_ in self._files:
            drop_stage(tmp.parent)
        for folder in self._made:
            with contextlib.suppress(OSError):
                folder.rmdir()
