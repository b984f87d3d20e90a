"""What a command reports: its data source, its section summary, JSON values at a stated precision,
and when two results are the same.

Numbers and reproducible files
    :func:`~morpi_filters.outputs.write_json` writes every float rounded to :data:`JSON_DIGITS`
    significant digits (:func:`round_significant`), the precision a result
    is stated at. Two results are the same result when their text is the same
    apart from numbers, and their numbers agree within :data:`SAME_REL`
    relative or :data:`SAME_ABS` absolute (:func:`same_output`): a margin far
    above what another CPU, libm or BLAS changes (a few 1e-11 relative at
    most in these studies) and far below any digit the pages discuss. When a
    command's new ``.json`` or ``.md`` file is the same result as the file it
    replaces, :class:`~morpi_filters.outputs.Outputs` keeps the previous file's bytes (and
    modification time), so a report regenerated on another machine, or
    twice, leaves version control clean; any difference of text or structure,
    or a number beyond the margin, writes the new file. Rounding alone
    cannot promise identical bytes: a value a machine's arithmetic moves
    across a rounding boundary changes its last digit, and this rule absorbs
    exactly that.

Each report section (tables, assessment, curves, montecarlo, drift) returns a
:class:`SectionSummary`; ``morpi report`` collects them into ``index.md``. The
pages themselves are written by :mod:`morpi_filters.report`; files are written by
:mod:`morpi_filters.outputs`.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np


__all__ = ["DataSource", "SectionSummary", "JSON_DIGITS", "SAME_REL", "SAME_ABS", "round_significant", "to_jsonable",
           "same_output"]


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



#: Significant digits of every float :func:`~morpi_filters.outputs.write_json` writes. A decimal step of at most 1e-12 relative
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
    """Whether file `new` states the same result as file `old` (the rule :class:`~morpi_filters.outputs.Outputs` keeps files by).

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
