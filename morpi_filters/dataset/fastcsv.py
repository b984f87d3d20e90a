"""The loader's fast path: a well-formed CSV read by pandas' C tokenizer (None: the line-by-line path decides)."""
from __future__ import annotations

import csv
import io
import os
import re
from functools import lru_cache
from pathlib import Path

import numpy as np

from .columns import COLUMNS, DATASET_CSV, MAX_GAP_S, TIME_LIMIT_S, ColumnLayout, column_limit

#: The bytes a data line may hold for the C reader to take the file: digits, the characters of a
#: decimal number (sign, point, exponent), comma, blank, double quote and the line ends. Anything else
#: (letters of nan/inf, tabs, NUL, other line breaks, non-ASCII) sends the file to the precise path.
_DATA_BYTES = b"0123456789.eE+-, \"\r\n"
#: Characters a header line may not hold for the C reader to take the file: NUL and the line
#: boundaries of ``str.splitlines`` other than the ``\n`` that ends it.
_HEADER_BREAKS = ("\x00", "\r", "\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")
#: Bytes read at a time; a file up to :data:`_KEEP_BYTES` is read at once, a larger one twice (a count
#: of its lines, then the parse into arrays of that many rows, block by block).
BLOCK_BYTES = 1 << 19
_KEEP_BYTES = 8 << 20
#: Bytes read to find the header line of a file above :data:`_KEEP_BYTES`.
_HEAD_BYTES = 1 << 16


def csv_fields(line: str, lenient: bool = False) -> list[str]:
    """The fields of one CSV line (standard quoting), stripped of blanks; `lenient` also reads a quoted field
    after blanks (a logger's ``1.5, "2.5"``)."""
    return [c.strip() for c in next(csv.reader([line], skipinitialspace=lenient), [])]


def _line_blocks(fh):
    """Blocks of a binary file, from where it stands, that each end at a ``\\n`` (the last one as the file ends)."""
    carry = b""
    while True:
        block = fh.read(BLOCK_BYTES)
        if not block:
            if carry:
                yield carry
            return
        block = carry + block
        cut = block.rfind(b"\n") + 1
        carry = block[cut:]
        if cut:
            yield block[:cut]


@lru_cache(maxsize=1)
def _pandas_options() -> dict:
    """Options of ``pandas.read_csv`` for correctly rounded floats, bit-identical to ``float(cell)``."""
    import pandas as pd

    return _float_options(pd.__version__)


def _float_options(version: str) -> dict:
    """:func:`_pandas_options` for a pandas version string.

    From pandas 3.1 the C engine has one float converter, fast_float, which
    rounds correctly; earlier versions round correctly only with the
    ``round_trip`` converter (Python's own; their default, ``high``, is off by
    one unit in the last place on about a quarter of 17-digit numbers).
    """
    major, minor = (int(x) for x in re.match(r"(\d+)\.(\d+)", version).groups())
    return {} if (major, minor) >= (3, 1) else {"float_precision": "round_trip"}


def fast_parse(path: Path, lay: ColumnLayout | None = None):
    """The columns ``(time, f, omega)`` of a well-formed file, read by pandas' C tokenizer, or None.

    None means "let the precise path decide" (:func:`_parse`, which names the
    bad line when there is one). The fast path takes a file only when it can
    be sure of the precise path's answer: a header line that is exactly the
    columns (any order, standard quoting, an optional byte-order mark), data
    lines made only of :data:`_DATA_BYTES` with ``\\r`` only in ``\\r\\n`` and
    an even number of quotes each, every row seven numbers, every value finite
    and within the limits, time strictly increasing with no gap above
    :data:`MAX_GAP_S`. Floats are correctly rounded (:func:`_pandas_options`):
    bit-identical to ``float(cell)``.

    Through a layout `lay` (``(time or None, group, ...)``): the `skip_rows`
    lines before the header free of line breaks other than ``\\n`` (or
    ``\\r\\n``), a header naming each column read once, and every data line
    holding as many fields as the header (its commas outside quotes counted),
    blank lines aside; the values read are converted before the limits.

    A file up to :data:`_KEEP_BYTES` is read at once. A longer one is read
    twice in blocks: once to count its lines, then block by block (each
    ending at a line end) into arrays allocated for that many rows, so memory
    stays near the float64 result (56 bytes per row) whatever its length.
    """
    lay = DATASET_CSV if lay is None else lay
    try:
        with open(path, "rb") as fh:
            whole = os.fstat(fh.fileno()).st_size <= _KEEP_BYTES
            head = fh.read() if whole else fh.read(_HEAD_BYTES)
            start = 0
            for _ in range(lay.skip_rows):
                start = head.find(b"\n", start) + 1
                if not start:
                    return None
            if start and not _plain_preamble(head[:start]):
                return None
            end = head.find(b"\n", start)
            header = _fast_header(head[start:end], lay, bom=start == 0) if end >= 0 else None
            if header is None:
                return None
            order = [header.index(c) for c in COLUMNS] if lay is DATASET_CSV else \
                [header.index(n) for n in lay.names if n is not None]
            if whole:
                rest = head[end + 1:]
                del head
                return _fast_columns([rest], None, order, lay, len(header))
            del head
            fh.seek(end + 1)
            n_lines = 1
            while chunk := fh.read(BLOCK_BYTES):
                n_lines += chunk.count(b"\n")
            del chunk
            fh.seek(end + 1)
            return _fast_columns(_line_blocks(fh), n_lines, order, lay, len(header))
    except OSError:
        return None


def _plain_preamble(block: bytes) -> bool:
    """Whether the lines before a header (ending at a ``\\n``) are UTF-8 with no line break of
    ``str.splitlines`` but their ``\\n`` (or ``\\r\\n``), so both readers count them alike."""
    try:
        text = block.decode("utf-8-sig")
    except UnicodeDecodeError:
        return False
    return not any(c in text.replace("\r\n", "\n") for c in _HEADER_BREAKS)


def _plain_block(block: bytes) -> bool:
    """Whether data lines hold only :data:`_DATA_BYTES`, ``\\r`` only before ``\\n``, and an even number of
    quotes on each line (so no quoted field runs across a line end, where the C reader and a line-by-line
    reading would split the fields differently)."""
    if block.translate(None, _DATA_BYTES) or (b"\r" in block and block.count(b"\r") != block.count(b"\r\n")):
        return False
    if b'"' not in block:
        return True
    a = np.frombuffer(block, dtype=np.uint8)
    parity = np.cumsum(a == ord('"'), dtype=np.uint8) & 1     # quotes so far, mod 2 (the uint8 sum wraps at 256)
    return not parity[-1] and not parity[a == ord("\n")].any()


def _fields_per_line(block: bytes, width: int) -> bool:
    """Whether every line of a plain block (:func:`_plain_block`) holds `width` fields (its commas outside
    quotes counted) or is blank: the C reader would fill a short row's missing cells with NaN, which
    a column left unread would not show."""
    a = np.frombuffer(block, dtype=np.uint8)
    ends = np.flatnonzero(a == ord("\n"))
    if a.size and a[-1] != ord("\n"):
        ends = np.append(ends, a.size)
    if not ends.size:
        return True
    comma = a == ord(",")
    if b'"' in block:
        comma &= (np.cumsum(a == ord('"'), dtype=np.uint8) & 1) == 0
    per_line = np.bincount(np.searchsorted(ends, np.flatnonzero(comma)), minlength=ends.size)
    starts = np.concatenate([[0], ends[:-1] + 1])
    return all(not block[starts[k]:ends[k]].strip() for k in np.flatnonzero(per_line != width - 1))


def _fast_header(line: bytes, lay: ColumnLayout | None = None, *, bom: bool = True) -> list[str] | None:
    """The header's column names when the line is exactly a permutation of :data:`COLUMNS` (or, for a
    layout, names each column read once), else None. A byte-order mark is dropped when `bom` (the file's
    first line)."""
    lay = DATASET_CSV if lay is None else lay
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError:
        return None
    text = text[1:] if bom and text.startswith("\ufeff") else text
    text = text[:-1] if text.endswith("\r") else text
    if any(c in text for c in _HEADER_BREAKS) or text.count('"') % 2:
        return None
    try:
        header = csv_fields(text, lay is not DATASET_CSV)
    except csv.Error:
        return None
    if lay is not DATASET_CSV:
        return header if all(header.count(n) == 1 for n in lay.names if n is not None) else None
    return header if len(header) == len(COLUMNS) and sorted(header) == sorted(COLUMNS) else None


def _fast_columns(blocks, capacity: int | None, order: list[int], lay: ColumnLayout | None = None,
                  width: int = len(COLUMNS)):
    """Parse blocks of data lines into C-ordered ``(time, f, omega)`` (the groups of a layout); None at
    the first doubt.

    `capacity` bounds the number of rows (the arrays are allocated once); None when `blocks`
    holds one block, whose rows then set it. `order` holds the file's index of each column read,
    `width` the number of fields of a line.
    """
    lay = DATASET_CSV if lay is None else lay
    lenient = lay is not DATASET_CSV
    present = lay.held_columns()
    pos_t = 0 if lay.has_time else None
    first = 1 if lay.has_time else 0
    group_idx = [order[p:p + 3] for p in range(first, len(order), 3)]
    group_cols = [present[p:p + 3] for p in range(first, len(present), 3)]
    limits = [column_limit(lay.columns[cols[0]]) for cols in group_cols]
    # a short row's missing cells are NaN, which the limits refuse in a column read: the fields are counted
    # only when some column is left unread
    counted = lenient and len(order) < width
    if capacity is None:
        (block,) = blocks
        rows = _read_rows(block, width, lenient, counted)
        if rows is None:
            return None
        parsed, capacity = iter([rows]), rows.shape[0]
        del rows
    else:
        parsed = (_read_rows(block, width, lenient, counted) for block in blocks)
    time = np.empty(capacity) if pos_t is not None else None
    groups = [np.empty((capacity, 3)) for _ in group_idx]
    n, prev_t, t_first = 0, None, None
    for rows in parsed:
        if rows is None:
            return None
        m = rows.shape[0]
        if n + m > capacity:
            return None
        t = None
        if time is not None:
            t = time[n:n + m]
            t[:] = rows[:, order[pos_t]]
            if lay.time_from_first and m:
                t_first = t[0] if t_first is None else t_first
                t -= t_first
            if lay.time_per_s != 1.0:
                t /= lay.time_per_s
        parts = []
        for g, idx, cols in zip(groups, group_idx, group_cols):
            part = g[n:n + m]
            for j in range(3):      # column by column: pandas' rows are in Fortran order
                part[:, j] = rows[:, idx[j]]
                if lay.factor(cols[j]) != 1.0:
                    part[:, j] *= lay.factor(cols[j])
            parts.append(part)
        if not _block_within_limits(t, parts, limits, prev_t):
            return None
        n += m
        prev_t = t[-1] if m and t is not None else prev_t
    if n == 0:
        return None
    out = [time] + groups
    if n < capacity:       # blank lines and the final line end: a trimmed copy only when much is spare
        out = [None if a is None else (a[:n] if n > capacity // 2 else a[:n].copy()) for a in out]
    return tuple(out)


def _read_rows(block: bytes, width: int = len(COLUMNS), lenient: bool = False,
               counted: bool = False) -> np.ndarray | None:
    """The rows of a block of data lines as float64, shape (m, width) (m = 0 for blank lines); None when the
    bytes are not plain (:func:`_plain_block`), pandas' C reader refuses them (a cell that is not a
    number, a long row) or they are not `width` columns (`counted`: a line of another width,
    :func:`_fields_per_line`). `lenient` skips the spaces that start a field."""
    import warnings

    import pandas as pd

    if not _plain_block(block) or (counted and not _fields_per_line(block, width)):
        return None
    if not block or block.isspace():
        return np.empty((0, width))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            frame = pd.read_csv(io.BytesIO(block), header=None, index_col=False, dtype=np.float64,
                                engine="c", low_memory=False, skipinitialspace=lenient, **_pandas_options())
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    rows = frame.to_numpy(dtype=np.float64)
    return rows if rows.ndim == 2 and rows.shape[1] == width else None


def _block_within_limits(t, groups, limits, prev_t) -> bool:
    """Whether rows are finite and within every limit (NaN fails every comparison), time following `prev_t`.
    `t` is None for a table without time; `limits` holds one :func:`_limit` (or None: finite) per group."""
    if t is not None and t.size:
        dt = np.diff(t) if prev_t is None else np.diff(t, prepend=prev_t)
        if not (t.max() <= TIME_LIMIT_S and -t.min() <= TIME_LIMIT_S and (dt > 0).all() and (dt <= MAX_GAP_S).all()):
            return False
    for g, lim in zip(groups, limits):
        if not g.size:
            continue
        if lim is None:
            if not np.isfinite(g).all():
                return False
        elif not (g.max() <= lim[0] and -g.min() <= lim[0]):
            return False
    return True


