"""Writing outputs safely: atomic files, staged folders, owned outputs.

Every output file is written under a temporary name in its destination folder
and renamed into place, so an interrupted run never leaves half a file. A
report section is built in a staging folder beside its destination and swapped
in only when it is complete, so an interrupted run leaves the previous complete
section in place. All outputs of one command (its folders and its ``--json``
file) are staged by one :class:`Outputs` and swapped in together at the end.

A command writes only what it owns: it replaces an output folder only when the
folder does not exist, is empty, or holds the marker file :data:`MARKER`, which
every folder a command writes carries. Any other folder is refused with one
line before anything is computed. Staging names carry the process id, so the
leftovers of a killed run are recognised and removed by the next run
(:func:`remove_stale`). Folders and files get the permissions the user's umask
gives, not the private ones of temporary files.

Numbers and reproducible files
    :func:`write_json` writes every float rounded to :data:`JSON_DIGITS`
    significant digits (:func:`round_significant`), the precision a result
    is stated at. Two results are the same result when their text is the same
    apart from numbers, and their numbers agree within :data:`SAME_REL`
    relative or :data:`SAME_ABS` absolute (:func:`same_output`): a margin far
    above what another CPU, libm or BLAS changes (a few 1e-11 relative at
    most in these studies) and far below any digit the pages discuss. When a
    command's new ``.json`` or ``.md`` file is the same result as the file it
    replaces, :class:`Outputs` keeps the previous file's bytes (and
    modification time), so a report regenerated on another machine, or
    twice, leaves version control clean; any difference of text or structure,
    or a number beyond the margin, writes the new file. Rounding alone
    cannot promise identical bytes: a value a machine's arithmetic moves
    across a rounding boundary changes its last digit, and this rule absorbs
    exactly that.

Each report section (tables, assessment, curves, montecarlo, drift) returns a
:class:`SectionSummary`; ``morpi report`` collects them into ``index.md``. The
pages themselves are written by :mod:`morpi_filters.report`.
"""
from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import MorpiError, ParameterError

__all__ = [
    "SectionSummary", "DataSource", "atomic_path", "write_text", "write_json", "staged_dir",
    "to_jsonable", "MARKER", "Outputs", "check_output_dir", "JSON_DIGITS", "SAME_REL", "SAME_ABS",
    "round_significant", "same_output",
    "check_output_file", "remove_stale", "swap_in", "foreign_entry", "user_umask", "new_stage_dir", "new_temp_file",
]

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
    The file gets the permissions of a file the user creates (``0o666``
    minus the umask); its temporary name carries this process's id, so a
    run that was killed leaves a name :func:`remove_stale` recognises.
    Missing parent folders are created.

    Parameters
    ----------
    path : str or Path
        Final file path.

    Yields
    ------
    Path
        An empty temporary file in the same folder, to write.

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
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


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


#: Significant digits of every float :func:`write_json` writes. A decimal step of at most 1e-12 relative
#: (a rounding error of at most 5e-13): finer than the machine-to-machine differences (up to a few 1e-11),
#: so the file keeps every digit the arithmetic can vouch for and a reader comparing at 1e-12 still finds
#: the computed value, and 1000 times finer than :data:`SAME_REL`, so rounding never decides whether two
#: results are the same.
JSON_DIGITS = 13

#: Relative and absolute margin within which two numbers of a result are the same number
#: (:func:`same_output`). Another CPU, libm or BLAS moves the reports' numbers by at most a few 1e-11
#: relative (3.3e-11 seen between two machines), a rounding to :data:`JSON_DIGITS` by at most 5e-13
#: more; 1e-9 leaves a factor 29 above both, and lies far below the digits the pages print. The absolute
#: margin [SI units] covers values that are zero up to rounding (a mean of signed errors, a difference
#: of equal sums), whose relative difference means nothing.
SAME_REL, SAME_ABS = 1e-9, 1e-12


def round_significant(x: float, digits: int) -> float:
    """`x` rounded to `digits` significant decimal digits, correctly rounded (the same on every machine).

    The rounding is Python's decimal formatting of the float (round half to
    even on the exact binary value), not a multiplication by a power of ten,
    so it depends on the bits of `x` only.

    Parameters
    ----------
    x : float
        Value; NaN and infinities are returned unchanged.
    digits : int
        Significant digits, at least 1.

    Returns
    -------
    float
        The float nearest to the decimal rounding of `x`.

    Examples
    --------
    >>> round_significant(0.1 + 0.2, 12), round_significant(-2.0 / 3.0, 3), round_significant(123456.0, 2)
    (0.3, -0.667, 120000.0)
    """
    x = float(x)
    return float(f"{x:.{int(digits) - 1}e}") if math.isfinite(x) else x


def to_jsonable(obj, digits: int | None = None):
    """Convert numpy scalars/arrays and non-finite floats (to None) for JSON.

    Parameters
    ----------
    obj : object
        Nested dicts, lists and tuples of numbers, numpy scalars and arrays,
        paths and other JSON values.
    digits : int, optional
        Round every float to this many significant digits
        (:func:`round_significant`); default: floats as they are.

    Returns
    -------
    object
        The same structure with dict keys as str, tuples and arrays as lists,
        numpy integers and booleans as Python ones, floats as float (NaN and
        inf as None), paths as str; anything else unchanged.

    Examples
    --------
    >>> to_jsonable({1: np.array([1.5, np.nan]), "n": np.int64(3), "ok": np.bool_(True), "p": Path("a/b")})
    {'1': [1.5, None], 'n': 3, 'ok': True, 'p': 'a/b'}
    >>> to_jsonable([np.float64(2.0) / 3.0, 7], digits=4)
    [0.6667, 7]
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v, digits) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist(), digits)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        if not math.isfinite(v):
            return None
        return v if digits is None else round_significant(v, digits)
    if isinstance(obj, Path):
        return str(obj)
    return obj


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
    >>> p = write_json(Path(tempfile.mkdtemp()) / "r.json", {"rms_m": np.float64(0.25), "bad": float("inf"),
    ...                                                      "third": 1.0 / 3.0})
    >>> json.loads(p.read_text())
    {'rms_m': 0.25, 'bad': None, 'third': 0.3333333333333}
    """
    text = json.dumps(to_jsonable(obj, JSON_DIGITS), indent=2, allow_nan=False)
    return write_text(path, text + "\n")


#: A number in markdown: not part of a word, a path or a hexadecimal digest (``10.csv``, ``s6``, ``3fa9``).
_MD_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?!\.?\w)")


def _same_numbers(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=SAME_REL, abs_tol=SAME_ABS)


def _same_json(a, b) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same_json(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same_json(x, y) for x, y in zip(a, b))
    if type(a) is float and type(b) is float:   # the previous file's float is at the stated precision too
        return _same_numbers(a, b) and round_significant(a, JSON_DIGITS) == a
    return type(a) is type(b) and a == b


def _same_markdown(a: str, b: str) -> bool:
    na, nb = _MD_NUMBER.findall(a), _MD_NUMBER.findall(b)
    if len(na) != len(nb) or _MD_NUMBER.split(a) != _MD_NUMBER.split(b):
        return False
    # an integer (a count, a seed, a digest of digits only) is the same only when written the same
    return all(x == y if not any(c in x + y for c in ".eE") else _same_numbers(float(x), float(y))
               for x, y in zip(na, nb))


def same_output(old, new) -> bool:
    """Whether file `new` states the same result as file `old` (the rule :class:`Outputs` keeps files by).

    ``.json`` files: the same structure, keys, strings, booleans, nulls and
    integers, floats within :data:`SAME_REL` relative or :data:`SAME_ABS`
    absolute, the floats of `old` at :data:`JSON_DIGITS` digits (a file
    written at another precision is replaced). ``.md`` files: the same text around the numbers (a number is
    not glued to a word, a path or a hexadecimal digest), the same integers,
    the numbers with a decimal point or an exponent within the same margin.
    Any other file, or one that cannot be read or parsed: the same bytes.

    Parameters
    ----------
    old, new : str or Path
        The previous file and the new one (which may carry a temporary
        name); the suffix of `old` decides how they are compared.

    Returns
    -------
    bool
        False as well when `old` is missing.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "a.md").write_text("Error 5.023602694785 % over 40 runs (s6/L_line/10.csv).")
    >>> _ = (d / "b.md").write_text("Error 5.023602694801 % over 40 runs (s6/L_line/10.csv).")
    >>> _ = (d / "c.md").write_text("Error 5.023602694801 % over 40 runs (s6/L_line/11.csv).")
    >>> same_output(d / "a.md", d / "b.md"), same_output(d / "a.md", d / "c.md")
    (True, False)
    >>> _ = (d / "a.json").write_text('{"rms_m": 0.123456789012, "n": 40}')
    >>> _ = (d / "b.json").write_text('{"rms_m": 0.123456789013, "n": 40}')
    >>> _ = (d / "c.json").write_text('{"rms_m": 0.123456789913, "n": 40}')
    >>> _ = (d / "d.json").write_text('{"rms_m": 0.12345678901234567, "n": 40}')
    >>> same_output(d / "a.json", d / "b.json"), same_output(d / "a.json", d / "c.json")
    (True, False)
    >>> same_output(d / "d.json", d / "a.json")          # 17 digits: not a file of this precision
    False
    """
    old, new = Path(old), Path(new)
    try:
        a, b = old.read_bytes(), new.read_bytes()
    except OSError:
        return False
    if a == b:
        return True
    try:
        if old.suffix == ".json":
            return _same_json(json.loads(a), json.loads(b))
        if old.suffix == ".md":
            return _same_markdown(a.decode(), b.decode())
    except ValueError:            # not JSON, not UTF-8: the bytes decide
        return False
    return False


@contextlib.contextmanager
def staged_dir(final, tool: str = "morpi"):
    """Build a folder in a staging place and swap it in when complete.

    Yields the staging folder (with the ownership marker already in it). On
    success the previous `final` folder is replaced; on an exception the
    staging folder is removed and `final` is left exactly as it was. `final`
    must be absent, empty or marked as an earlier output (see
    :func:`check_output_dir`), otherwise a :class:`ParameterError` is raised
    before anything is written.

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
    """
    with Outputs(tool) as outputs:
        yield outputs.folder(final)


# ----------------------------------------------------------------------------- output ownership

#: Name of the file that marks a folder as written by a morpi command. A folder
#: holding it may be replaced by the next run; any other non-empty folder is
#: the user's and is never replaced.
MARKER = ".morpi-output"

_STAGE_RE = re.compile(r"^\.(staging|previous)-(?P<name>.*)-(?P<pid>[0-9]+)-[A-Za-z0-9_]{8}(\.tmp)?$")


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


def new_stage_dir(final) -> Path:
    """Create an empty staging folder beside `final` with the user's folder permissions.

    Its name, ``.staging-<name>-<pid>-XXXXXXXX``, carries this process's id.

    Parameters
    ----------
    final : str or Path
        The folder being built; its parent must exist.

    Returns
    -------
    Path
        The new empty folder, in ``final.parent``.

    Examples
    --------
    >>> import os, tempfile
    >>> stage = new_stage_dir(Path(tempfile.mkdtemp()) / "tables")
    >>> stage.name.startswith(f".staging-tables-{os.getpid()}-"), list(stage.iterdir())
    (True, [])
    """
    final = Path(final)
    stage = Path(tempfile.mkdtemp(prefix=f".staging-{final.name}-{os.getpid()}-", dir=final.parent))
    os.chmod(stage, 0o777 & ~user_umask())
    return stage


def new_temp_file(final) -> Path:
    """Create an empty temporary file beside `final` with the user's file permissions.

    Parameters
    ----------
    final : str or Path
        The file being written; its folder must exist.

    Returns
    -------
    Path
        ``.staging-<name>-<pid>-XXXXXXXX.tmp`` in the same folder, empty.

    Examples
    --------
    >>> import tempfile
    >>> tmp = new_temp_file(Path(tempfile.mkdtemp()) / "a.json")
    >>> tmp.suffix, tmp.stat().st_size
    ('.tmp', 0)
    """
    final = Path(final)
    fd, tmp = tempfile.mkstemp(prefix=f".staging-{final.name}-{os.getpid()}-", suffix=".tmp", dir=final.parent)
    try:
        os.fchmod(fd, 0o666 & ~user_umask())
    finally:
        os.close(fd)
    return Path(tmp)


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
    """Remove staging and previous-output leftovers of killed runs from `folder`.

    An entry ``.staging-*-<pid>-XXXXXXXX`` or ``.previous-*-<pid>-XXXXXXXX``
    whose process is no longer alive is removed; entries of live processes
    are left alone.

    Parameters
    ----------
    folder : str or Path
        Folder to clean; a missing or unreadable one is left alone.

    Returns
    -------
    list of Path
        Leftovers that could not be removed.

    Examples
    --------
    >>> import os, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> (d / ".staging-tables-999999999-abcdefgh").mkdir()        # no such process
    >>> mine = new_stage_dir(d / "curves")                         # this process: kept
    >>> remove_stale(d), [p.name == mine.name for p in d.iterdir()]
    ([], [True])
    """
    folder = Path(folder)
    try:
        entries = list(folder.iterdir())
    except OSError:
        return []
    failed = []
    for entry in entries:
        m = _STAGE_RE.match(entry.name)
        if m is None or _pid_alive(int(m["pid"])):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            failed.append(entry)
    return failed


def foreign_entry(folder):
    """The first entry that makes `folder` someone else's, or None if a command may replace it.

    A folder may be replaced when it does not exist, is empty, or holds
    :data:`MARKER`. Staging leftovers of morpi runs do not count.

    Parameters
    ----------
    folder : str or Path
        The candidate output folder.

    Returns
    -------
    Path or None
        None when the folder may be replaced; else `folder` itself (a file,
        a symbolic link or unreadable) or its first entry by name.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> foreign_entry(d / "new") is None, foreign_entry(d) is None
    (True, True)
    >>> _ = (d / "notes.txt").write_text("mine")
    >>> foreign_entry(d).name
    'notes.txt'
    >>> _ = (d / MARKER).write_text("")
    >>> foreign_entry(d) is None
    True
    """
    folder = Path(folder)
    if not folder.exists() and not folder.is_symlink():
        return None
    if folder.is_symlink() or not folder.is_dir():
        return folder
    try:
        names = sorted(p.name for p in folder.iterdir())
    except OSError:
        return folder
    names = [n for n in names if not _STAGE_RE.match(n)]
    if not names or MARKER in names:
        return None
    return folder / names[0]


def check_output_dir(folder, option: str = "--out") -> Path:
    """Refuse an output folder a command may not replace, before anything is computed.

    Parameters
    ----------
    folder : str or Path
        The output folder.
    option : str
        Command-line option named in the message.

    Returns
    -------
    Path
        `folder`.

    Raises
    ------
    ParameterError
        When `folder` is an empty name, exists as something other than a
        folder, holds files without the marker, or cannot be created (its
        nearest existing parent does not accept a new file: read-only, not a
        folder, or a virtual system folder).

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
    morpi_filters.errors.ParameterError: --out ...: holds thesis.tex, which morpi did not write (no .morpi-output marker); refusing to replace it, choose a new or empty folder
    """
    if str(folder) == "":
        raise ParameterError(f"{option}: empty path, expected a folder name")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ParameterError(f"{option} {folder}: exists and is not a folder, expected an output folder")
    bad = foreign_entry(folder)
    if bad is not None:
        what = "is a symbolic link" if bad == folder else f"holds {bad.name}, which morpi did not write"
        raise ParameterError(f"{option} {folder}: {what} (no {MARKER} marker); refusing to replace it, "
                             "choose a new or empty folder")
    _check_creatable(folder.parent, option, folder)
    return folder


def check_output_file(path, option: str = "--json") -> Path:
    """Refuse an output file path before anything is computed (empty, a folder, unwritable place).

    Parameters
    ----------
    path : str or Path
        The output file.
    option : str
        Command-line option named in the message.

    Returns
    -------
    Path
        `path`.

    Raises
    ------
    ParameterError
        An empty name, a folder, an existing non-regular file, or a place
        where no file can be created.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> check_output_file(d / "out.json").name
    'out.json'
    >>> check_output_file(d)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    morpi_filters.errors.ParameterError: --json ...: is a folder, expected a file name
    """
    if str(path) == "":
        raise ParameterError(f"{option}: empty path, expected a file name")
    path = Path(path)
    if path.is_dir():
        raise ParameterError(f"{option} {path}: is a folder, expected a file name")
    if path.exists() and not path.is_file():
        raise ParameterError(f"{option} {path}: exists and is not a regular file")
    _check_creatable(path.parent, option, path)
    return path


def _check_creatable(parent: Path, option: str, target: Path) -> None:
    """Check that a file can be created in `parent` (or its nearest existing ancestor)."""
    probe = Path(os.path.abspath(parent))
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise ParameterError(f"{option} {target}: {probe} is not a folder")
    try:
        with tempfile.TemporaryFile(dir=probe, prefix=f".staging-probe-{os.getpid()}-"):
            pass
    except OSError as exc:
        raise ParameterError(f"{option} {target}: cannot write in {probe} ({exc.strerror or exc})") from None


class Outputs:
    """Every output of one command, staged aside and swapped in together at the end.

    Use as a context manager: :meth:`folder` and :meth:`file` return the
    staging paths to write; leaving the block normally swaps every staged
    folder in (each checked again under the ownership rule) and then renames
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
        self._folders = []   # (stage, final)
        self._files = []     # (tmp, final)
        self._roots = []     # folders kept, with only some entries replaced
        self._made = []      # parent folders created here (removed again on failure if empty)

    def _marker_text(self, what: str) -> str:
        return (f"Written by {self.tool} ({what}). The next run of a morpi command may replace this folder "
                "or the entries it writes in it; files added to it are then lost.\n")

    def _mkdirs(self, folder: Path) -> None:
        missing = []
        p = Path(os.path.abspath(folder))
        while not p.exists() and p.parent != p:
            missing.append(p)
            p = p.parent
        folder.mkdir(parents=True, exist_ok=True)
        self._made.extend(missing)   # deepest first

    def folder(self, final, section: str | None = None) -> Path:
        """A staging folder for output folder `final`, holding the marker already.

        Parameters
        ----------
        final : str or Path
            The output folder (checked with :func:`check_output_dir`).
        section : str, optional
            What the marker names (default the folder's name).

        Returns
        -------
        Path
            The staging folder, swapped in at the end of the block.
        """
        final = Path(final)
        check_output_dir(final)
        self._mkdirs(final.parent)
        stage = new_stage_dir(final)
        self._folders.append((stage, final))
        (stage / MARKER).write_text(self._marker_text(section or final.name))
        return stage

    def root(self, folder) -> Path:
        """Claim `folder` as a report folder whose entries are replaced one by one.

        The folder itself is kept: entries a command does not write stay
        untouched. It must pass :func:`check_output_dir`; it gets the marker.

        Parameters
        ----------
        folder : str or Path
            The report folder.

        Returns
        -------
        Path
            `folder` (created if missing).
        """
        folder = check_output_dir(Path(folder))
        self._mkdirs(folder)
        self._roots.append(folder)
        tmp = self.file(folder / MARKER)
        tmp.write_text(self._marker_text("report folder"))
        return folder

    def file(self, final) -> Path:
        """A temporary file beside `final`, renamed to `final` at the end.

        Parameters
        ----------
        final : str or Path
            The output file (checked with :func:`check_output_file`).

        Returns
        -------
        Path
            The temporary file to write.
        """
        final = check_output_file(final)
        self._mkdirs(final.parent)
        tmp = new_temp_file(final)
        self._files.append((tmp, final))
        return tmp

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self._discard()
            return False
        try:
            for folder in self._roots + [final for _, final in self._folders]:
                check_output_dir(folder)
            self._keep_unchanged()
        except BaseException:
            self._discard()
            raise
        final = None
        try:
            for stage, final in self._folders:
                swap_in(stage, final)
            for tmp, final in self._files:
                os.replace(tmp, final)
        except OSError as exc:
            self._discard()
            raise MorpiError(f"{final}: cannot put the new output in place ({exc.strerror or exc})") from None
        return False

    def _keep_unchanged(self):
        """Give every staged output that states the same result as its previous file that file's bytes."""
        for stage, final in self._folders:
            if not final.is_dir() or final.is_symlink():
                continue
            for new in sorted(stage.rglob("*")):
                old = final / new.relative_to(stage)
                if (new.suffix in (".json", ".md") and new.is_file() and not new.is_symlink()
                        and old.is_file() and not old.is_symlink() and same_output(old, new)):
                    shutil.copy2(old, new)
        changed = []
        for tmp, final in self._files:
            if final.is_file() and not final.is_symlink() and same_output(final, tmp):
                os.unlink(tmp)
            else:
                changed.append((tmp, final))
        self._files = changed

    def _discard(self):
        for stage, _ in self._folders:
            shutil.rmtree(stage, ignore_errors=True)
        for tmp, _ in self._files:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        for folder in self._made:
            with contextlib.suppress(OSError):
                folder.rmdir()


def swap_in(stage: Path, final: Path) -> None:
    """Rename the staging folder `stage` to `final`; a folder already at `final` is replaced.

    The old folder is first moved aside (``.previous-...``) and removed after
    the rename, so `final` always names a complete folder.

    Parameters
    ----------
    stage : Path
        The complete staging folder.
    final : Path
        Destination, in the same file system.

    Returns
    -------
    None

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> (d / "out").mkdir(); _ = (d / "out" / "old.md").write_text("old")
    >>> stage = new_stage_dir(d / "out"); _ = (stage / "new.md").write_text("new")
    >>> swap_in(stage, d / "out")
    >>> sorted(p.name for p in d.iterdir()), [p.name for p in (d / "out").iterdir()]
    (['out'], ['new.md'])
    """
    if final.is_dir():
        keep = Path(tempfile.mkdtemp(prefix=f".previous-{final.name}-{os.getpid()}-", dir=final.parent))
        os.replace(final, keep / final.name)
        os.replace(stage, final)
        shutil.rmtree(keep, ignore_errors=True)
    else:
        os.replace(stage, final)
