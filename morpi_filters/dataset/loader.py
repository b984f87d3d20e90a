"""The CSV loader: :func:`load_csv` and :func:`read_columns` with their checks, the line-by-line path that names a
bad line, :func:`keep_parsed`, and :func:`write_csv`."""
from __future__ import annotations

import array
import codecs
import csv
import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import DataError
from .columns import COLUMNS, DATASET_CSV, MAX_GAP_S, MIN_SAMPLES, TIME_LIMIT_S, ColumnLayout, column_limit
from .fastcsv import BLOCK_BYTES, csv_fields, fast_parse
from .recording import Recording


def _header_text(lay: ColumnLayout) -> str:
    if lay is DATASET_CSV:
        return ",".join(COLUMNS)
    return "naming the columns " + ", ".join(repr(str(n)) for n in lay.names if n is not None)


def load_csv(path, *, phone=None, route=None, split=None, imu=None, min_samples: int = MIN_SAMPLES) -> Recording:
    r"""Read one recording and validate it.

    Parameters
    ----------
    path : str or Path
        CSV file whose header names the columns ``time,f_x,f_y,f_z,g_x,g_y,g_z``
        (in any order; standard CSV: quoted fields, a UTF-8 byte-order mark
        and CRLF line ends are accepted): time [s], specific force [m/s^2] and
        angular rate [rad/s] in phone axes.
    phone, route, split : str, optional
        Catalogue labels stored on the result (not checked against the path;
        :func:`load_recording` reads them from it).
    imu : units.SensorSpec, optional
        The recording's IMU, when known (the MoRPI catalogue takes it from the shipped manifest).
    min_samples : int, optional
        Fewest data rows accepted (default :data:`MIN_SAMPLES`).

    Returns
    -------
    Recording
        The samples in the column order of :data:`COLUMNS`, ``source`` set to
        the path. Each value is ``float(cell)`` to the last bit.

    Raises
    ------
    DataError
        With one line naming the file (and line) for: a missing or unreadable
        file, an empty, blank or header-only file, a file that is not UTF-8
        CSV text, missing, repeated or unknown columns, a short or long row,
        a non-numeric cell, NaN or inf, a value beyond :data:`ACCEL_LIMIT_MPS2`
        or :data:`GYRO_LIMIT_RADPS`, a time beyond :data:`TIME_LIMIT_S`, a
        non-increasing or repeated time stamp, a gap above :data:`MAX_GAP_S`,
        or fewer than `min_samples` rows.

    Notes
    -----
    A well-formed file is parsed by pandas' C tokenizer (imported on the
    first call), block by block into arrays allocated once: memory stays near
    the float64 result, 56 bytes per row. Anything the fast reader is not sure
    of (a bad row, a limit broken, an unusual but valid spelling) is decided
    by a line-by-line reading, which names the first bad line. Files in
    other layouts and units are read by :func:`read_columns`.

    Examples
    --------
    Columns in another order are read; a repeated time stamp is named by line:

    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write("f_x,f_y,f_z,g_x,g_y,g_z,time\n0,0,9.8,0,0,0.1,0.00\n0,0,9.8,0,0,0.1,0.01\n")
    >>> rec = load_csv(path, min_samples=2)
    >>> rec.time.tolist(), rec.f[0].tolist(), rec.omega[0].tolist()
    ([0.0, 0.01], [0.0, 0.0, 9.8], [0.0, 0.0, 0.1])
    >>> with open(path, "a") as fh:
    ...     _ = fh.write("0,0,9.8,0,0,0.1,0.01\n")
    >>> load_csv(path, min_samples=2)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: ...: line 4: repeated time stamp 0.01 (line 3 has 0.01), expected strictly increasing time
    """
    path = Path(path)
    time, f, omega = _read(path, DATASET_CSV)
    if time.shape[0] < min_samples:
        raise DataError(f"{path}: too few samples: {time.shape[0]} rows, expected at least {min_samples}")
    return Recording(time=time, f=f, omega=omega, source=str(path), phone=phone, route=route, split=split,
                     imu=imu)


def read_columns(path, layout: ColumnLayout, *, min_rows: int = 1) -> tuple:
    r"""Read a table (a recording or a truth track) in another layout and units, converted to SI and validated.

    Parameters
    ----------
    path : str or Path
        The CSV or ``.npy`` file (as ``layout.format`` says).
    layout : ColumnLayout
        Where the file holds each column and in which unit.
    min_rows : int, optional
        Fewest rows accepted (default 1).

    Returns
    -------
    tuple of ndarray
        ``(time, group, ...)``: time [s], shape (n,) (``k / rate_hz`` when
        the file has none), and one array of shape (n, 3) per group of three
        columns after it, in SI units; C-contiguous, each value the file's
        number (``float(cell)`` for a CSV) times its factor (time divided by
        ``time_per_s``).

    Raises
    ------
    DataError
        With one line naming the file and the line (a CSV) or the row index
        (an ``.npy`` array): every check of :func:`load_csv`, on the converted
        values; for an ``.npy`` file, one that is not a 2-D array of numbers
        or lacks a column; fewer than `min_rows` rows.

    Examples
    --------
    A truth track in an ``.npy`` array at 10 Hz without a time column:

    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "truth.npy")
    >>> np.save(path, np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.05, 0.0]]))
    >>> lay = ColumnLayout(("time", "n", "e", "d"), (None, 0, 1, 2), format="npy", rate_hz=10.0)
    >>> time, ned = read_columns(path, lay)
    >>> time.tolist(), ned[2].tolist()
    ([0.0, 0.1, 0.2], [0.2, 0.05, 0.0])
    >>> np.save(path, np.array([[0.0, 0.0, np.nan]]))
    >>> read_columns(path, lay)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: ...truth.npy: row index 0: column 2: nan is not finite, expected a real number
    """
    path = Path(path)
    cols = _read(path, layout)
    if cols[0].shape[0] < min_rows:
        raise DataError(f"{path}: too few rows: {cols[0].shape[0]}, expected at least {min_rows}")
    return cols


def check_recording(recording: Recording, *, min_samples: int = MIN_SAMPLES) -> None:
    r"""Apply the checks of :func:`load_csv` to a recording built in memory.

    Parameters
    ----------
    recording : Recording
        The samples (SI units).
    min_samples : int, optional
        Fewest samples accepted (default :data:`MIN_SAMPLES`).

    Returns
    -------
    None
        When every check passes.

    Raises
    ------
    DataError
        One line naming the recording's ``source`` and the first bad row by
        its index: a value that is not finite or beyond a limit, time not
        strictly increasing or with a gap above :data:`MAX_GAP_S`; or fewer
        than `min_samples` samples.

    Examples
    --------
    >>> t = np.arange(200) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (200, 1)), omega=np.zeros((200, 3)), source="mine")
    >>> check_recording(rec)
    >>> rec.time[50] = rec.time[49]
    >>> check_recording(rec)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: mine: row index 50: repeated time stamp 0.49 (row index 49 has 0.49), expected strictly increasing time
    """
    data = np.column_stack([recording.time, recording.f, recording.omega])
    if data.shape[0] < min_samples:
        raise DataError(f"{recording.source}: too few samples: {data.shape[0]} rows, expected at least {min_samples}")
    if not (np.isfinite(data).all() and _within_limits(data)):
        _name_bad_line(data, range(data.shape[0]), recording.source, word="row index")


def _read(path: Path, lay: ColumnLayout) -> tuple:
    """The columns ``(time, group, ...)`` of a file in layout `lay`, parsed once inside :func:`keep_parsed`."""
    key = _kept_key(path)
    if key is not None and lay is not DATASET_CSV:
        key = key + (lay,)
    if key is not None and key in _KEPT:
        return _KEPT[key]
    if lay.format == "npy":
        cols = _read_npy(path, lay)
    elif lay is DATASET_CSV:
        cols = fast_parse(path) if path.is_file() else None
        cols = cols if cols is not None else _parse(path)
    else:
        cols = fast_parse(path, lay) if path.is_file() else None
        cols = cols if cols is not None else _parse(path, lay)
    if cols[0] is None:
        cols = (np.arange(cols[1].shape[0]) / float(lay.rate_hz),) + tuple(cols[1:])
    if key is not None:
        for a in cols:
            a.flags.writeable = False         # shared by every later reading of the file
        _KEPT[key] = cols
    return cols


#: Files parsed inside :func:`keep_parsed`: (path, size, modification time[, layout]) -> (time, f, omega) or
#: the columns of :func:`read_columns`.
_KEPT: dict | None = None


def _kept_key(path: Path):
    if _KEPT is None:
        return None
    try:
        st = path.stat()
    except OSError:
        return None
    return str(path.resolve()), st.st_size, st.st_mtime_ns


@contextmanager
def keep_parsed():
    r"""Within the block, :func:`load_csv` and :func:`read_columns` parse a file once: a later call on the
    unchanged file (same size and modification time, and layout) returns its arrays
    (read-only, shared). Files that fail are read again. For a command that
    checks every recording before its study reads them.

    Yields
    ------
    None
        The files parsed are kept until the outermost block ends.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write("time,f_x,f_y,f_z,g_x,g_y,g_z\n0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n")
    >>> with keep_parsed():
    ...     a, b = load_csv(path, min_samples=2), load_csv(path, min_samples=2)
    >>> a.time is b.time, a.time.flags.writeable, load_csv(path, min_samples=2).time is a.time
    (True, False, False)
    """
    global _KEPT
    outer = _KEPT
    if outer is None:
        _KEPT = {}
    try:
        yield
    finally:
        if outer is None:
            _KEPT = None


def _header_order(header: list[str], name: str, lay: ColumnLayout = DATASET_CSV, line: int = 1) -> list[int] | None:
    """Column index in the file of each column the layout reads, in its order; None when already in order."""
    if lay is not DATASET_CSV:
        wanted = [n for n in lay.names if n is not None]
        missing = [n for n in wanted if n not in header]
        repeated = [n for n in wanted if header.count(n) > 1]
        if missing or repeated:
            what = (["missing column(s) " + ", ".join(repr(n) for n in missing)] if missing else []) + \
                   (["repeated column(s) " + ", ".join(repr(n) for n in repeated)] if repeated else [])
            shown = ", ".join(repr(c) for c in header[:12]) + (", ..." if len(header) > 12 else "")
            raise DataError(f"{name}: line {line}: {'; '.join(what)}; the header has {shown}")
        return [header.index(n) for n in wanted]
    if header == list(COLUMNS):
        return None
    missing = [c for c in COLUMNS if c not in header]
    extra = [c for c in header if c not in COLUMNS]
    repeated = sorted({c for c in header if c in COLUMNS and header.count(c) > 1})
    what = []
    if missing:
        what.append("missing column(s) " + ", ".join(missing))
    if extra:
        what.append("unexpected column(s) " + ", ".join(repr(c) for c in extra))
    if repeated:
        what.append("repeated column(s) " + ", ".join(repeated))
    if what:
        raise DataError(f"{name}: line {line}: {'; '.join(what)}; expected the header {','.join(COLUMNS)} "
                        "(in any order)")
    return [header.index(c) for c in COLUMNS]


def _parse(path: Path, lay: ColumnLayout | None = None):
    """Read and validate a file line by line, naming the first bad line; the columns ``(time, f, omega)``
    (``(time or None, group, ...)`` for a layout `lay`).

    The precise path, which decides whatever :func:`fast_parse` leaves (it is
    tried first). Its rules are the documented ones: UTF-8 text with an
    optional byte-order mark, lines as ``str.splitlines`` cuts them, blank
    lines skipped, each row read by the ``csv`` module and each cell by
    ``float`` (no underscores). The file is read twice in blocks, never held
    whole: a scan for NUL bytes, invalid UTF-8 and content (so those errors
    come first, whatever line they are on), then the rows, kept as float64
    values with their line numbers (64 bytes per row).
    """
    lay = DATASET_CSV if lay is None else lay
    name = str(path)
    binary = not_utf8 = False
    content = False
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    try:
        with open(path, "rb") as fh:
            while block := fh.read(BLOCK_BYTES):
                binary = binary or b"\x00" in block
                if not not_utf8:
                    try:
                        content = bool(decoder.decode(block).strip()) or content
                    except UnicodeDecodeError:
                        not_utf8 = True
            if not not_utf8:
                try:
                    content = bool(decoder.decode(b"", final=True).strip()) or content
                except UnicodeDecodeError:
                    not_utf8 = True
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise DataError(f"{name}: is a directory, expected a CSV file") from None
    except OSError as exc:
        raise DataError(f"{name}: cannot read ({exc.strerror})") from None
    if binary:
        raise DataError(f"{name}: not CSV text (binary content)")
    if not_utf8:
        raise DataError(f"{name}: not CSV text (not UTF-8)")
    if not content:
        raise DataError(f"{name}: empty file, expected the header {_header_text(lay)} and data rows")
    try:
        return _parse_lines(_text_lines(path), name, lay)
    except OSError as exc:
        raise DataError(f"{name}: cannot read ({exc.strerror})") from None


def _text_lines(path: Path):
    """The lines of a UTF-8 file (an optional byte-order mark dropped), exactly as ``str.splitlines`` cuts
    its whole text, decoded block by block."""
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    carry = ""
    with open(path, "rb") as fh:
        while block := fh.read(BLOCK_BYTES):
            parts = (carry + decoder.decode(block)).splitlines(keepends=True)
            # the last part waits for the next block: it may lack its line end, or end in a "\r" whose "\n" follows
            carry = parts.pop() if parts else ""
            for part in parts:
                yield part.splitlines()[0]
        yield from (carry + decoder.decode(b"", final=True)).splitlines()


def _parse_lines(lines, name: str, lay: ColumnLayout = DATASET_CSV):
    """Validate the lines of a table (an iterator), naming the first bad line; ``(time, f, omega)`` (or the
    columns of layout `lay`, time None when the file has none)."""
    lenient = lay is not DATASET_CSV
    for k in range(lay.skip_rows):
        if next(lines, None) is None:
            raise DataError(f"{name}: {k} line(s), expected {lay.skip_rows} line(s) before the header "
                            f"(skip_rows) and the header {_header_text(lay)}")
    h = lay.skip_rows + 1
    first = next(lines, "")
    if not first.strip():
        raise DataError(f"{name}: line {h}: blank line before the header {_header_text(lay)}")
    try:
        header = csv_fields(first, lenient)
    except csv.Error as exc:
        raise DataError(f"{name}: line {h}: not a CSV header ({exc})") from None
    order = _header_order(header, name, lay, h)
    read = list(range(len(COLUMNS))) if order is None else order
    in_file = sorted(read)                      # the cells read, in the file's order
    values, line_of = array.array("d"), array.array("q")
    for i, s in enumerate(lines, start=h + 1):
        if s.strip():
            values.extend(_row_values(s, i, header, name, in_file if lenient else None, lenient))
            line_of.append(i)
    if not line_of:
        raise DataError(f"{name}: header only, no data rows")
    data = np.frombuffer(values, dtype=np.float64).reshape(-1, len(read))
    back = [in_file.index(j) for j in read]
    if back != list(range(len(read))):
        data = data[:, back]
    data = _convert(data, lay)
    if not (np.isfinite(data).all() and _within_limits(data, lay)):
        _name_bad_line(data, line_of, name, lay)
    return _split_columns(data, lay)


def _convert(data: np.ndarray, lay: ColumnLayout) -> np.ndarray:
    """The columns read (in the layout's order, the absent time left out) in SI: time less its first reading
    when ``time_from_first``, divided by ``time_per_s``, each other column times its factor. Unchanged (the
    same array) when nothing is to be done."""
    present = lay.held_columns()
    scale = [(k, j) for k, j in enumerate(present)
             if (j == 0 and lay.time_per_s != 1.0) or (j > 0 and lay.factor(j) != 1.0)]
    shift = lay.has_time and lay.time_from_first
    if not scale and not shift:
        return data
    data = np.array(data, dtype=np.float64)
    if shift and data.shape[0]:
        data[:, 0] -= data[0, 0]
    for k, j in scale:
        if j == 0:
            data[:, k] /= lay.time_per_s
        else:
            data[:, k] *= lay.factor(j)
    return data


def _split_columns(data: np.ndarray, lay: ColumnLayout) -> tuple:
    """``(time or None, group, ...)`` of the converted columns, each C-contiguous."""
    k = 1 if lay.has_time else 0
    time = np.ascontiguousarray(data[:, 0]) if lay.has_time else None
    groups = tuple(np.ascontiguousarray(data[:, p:p + 3]) for p in range(k, data.shape[1], 3))
    return (time,) + groups


def _read_npy(path: Path, lay: ColumnLayout) -> tuple:
    """The columns ``(time or None, group, ...)`` of an ``.npy`` array, converted and validated."""
    name = str(path)
    try:
        with open(path, "rb") as fh:
            magic = fh.read(6)
        if magic != b"\x93NUMPY":
            raise DataError(f"{name}: not a .npy array file (it does not start with the NumPy format's "
                            "header), expected one 2-D array written by numpy.save")
        arr = np.load(path, mmap_mode="r", allow_pickle=False)
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise DataError(f"{name}: is a directory, expected a .npy file") from None
    except (ValueError, OSError, EOFError) as exc:
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise DataError(f"{name}: not a .npy array file ({reason})") from None
    if arr.ndim != 2:
        raise DataError(f"{name}: array of shape {arr.shape}, expected 2-D (samples, columns)")
    if arr.dtype.kind not in "fiu":
        raise DataError(f"{name}: array of {arr.dtype}, expected numbers (float or integer)")
    index = [lay.names[j] for j in lay.held_columns()]
    beyond = [f"{i} ({lay.columns[j]})" for j, i in zip(lay.held_columns(), index) if i >= arr.shape[1]]
    if beyond:
        raise DataError(f"{name}: no column {', '.join(beyond)}: the array has {arr.shape[1]} column(s), "
                        f"indices 0 to {arr.shape[1] - 1}")
    if arr.shape[0] == 0:
        raise DataError(f"{name}: no rows")
    data = _convert(np.array(arr[:, index], dtype=np.float64), lay)
    del arr
    if not (np.isfinite(data).all() and _within_limits(data, lay)):
        _name_bad_line(data, range(data.shape[0]), name, lay, word="row index")
    return _split_columns(data, lay)


def _within_limits(data: np.ndarray, lay: ColumnLayout = DATASET_CSV) -> bool:
    """Whether finite rows (columns in the layout's order, the absent time left out) are within every limit."""
    present = lay.held_columns()
    ok = True
    if lay.has_time:
        t = data[:, 0]
        dt = np.diff(t)
        ok = bool(np.abs(t).max() <= TIME_LIMIT_S and (dt > 0).all() and (dt <= MAX_GAP_S).all())
    for k, j in enumerate(present):
        lim = column_limit(lay.columns[j]) if j else None
        if ok and lim is not None:
            ok = bool(np.abs(data[:, k]).max() <= lim[0])
    return ok


def _name_bad_line(data: np.ndarray, line_of, name: str, lay: ColumnLayout = DATASET_CSV, word: str = "line") -> None:
    """Raise the error of the first row that breaks a limit (the data parsed as numbers and converted, `line_of`
    the line number of each row, or its index: `word`)."""
    present = lay.held_columns()
    cols = [str(lay.names[j]) for j in present]
    timed = lay.has_time
    checked = [(k, j, column_limit(lay.columns[j])) for k, j in enumerate(present)
               if j and column_limit(lay.columns[j])]
    prev_t = -math.inf
    for k in range(data.shape[0]):
        row, i = data[k], line_of[k]
        for j, col in enumerate(cols):
            v = float(row[j])
            if not math.isfinite(v):
                raise DataError(f"{name}: {word} {i}: column {col}: {v} is not finite, expected a real number")
        t = float(row[0]) if timed else 0.0
        if timed and abs(t) > TIME_LIMIT_S:
            raise DataError(f"{name}: {word} {i}: column {cols[0]}: {t!r} s is beyond the limit of "
                            f"+-{TIME_LIMIT_S:g} s, expected a plausible clock reading")
        for c, j, (limit, what, unit, sensor) in checked:
            v = float(row[c])
            if abs(v) > limit:
                read = f" (converted from {lay.unit(j)})" if lay.factor(j) != 1.0 and lay.unit(j) else ""
                raise DataError(f"{name}: {word} {i}: column {cols[c]}: {what} {v!r} {unit}{read} is beyond "
                                f"+-{limit:.4g} {unit}, the {sensor} full scale of a phone IMU")
        if timed and k:
            if t <= prev_t:
                what = "repeated" if t == prev_t else "decreasing"
                raise DataError(f"{name}: {word} {i}: {what} time stamp {t!r} ({word} {line_of[k - 1]} has "
                                f"{prev_t!r}), expected strictly increasing time")
            if t - prev_t > MAX_GAP_S:
                raise DataError(f"{name}: {word} {i}: time gap of {t - prev_t:.6g} s after {word} "
                                f"{line_of[k - 1]}, expected at most {MAX_GAP_S:g} s between samples")
        prev_t = t
    raise AssertionError("limits broken but no row found")  # pragma: no cover


def _row_values(s: str, i: int, header: list[str], name: str, read=None, lenient: bool = False) -> list[float]:
    """The numbers of data line `i` (text `s`, cells in the file's column order), or the error naming it.
    `read`: the indices of the cells to read (ascending); None reads every cell."""
    if '"' in s:
        try:
            cells = csv_fields(s, lenient)
        except csv.Error as exc:
            raise DataError(f"{name}: line {i}: not a CSV row ({exc})") from None
    else:       # without quotes the csv module splits at every comma
        cells = [c.strip() for c in s.split(",")]
    if len(cells) != len(header):
        kind = "short" if len(cells) < len(header) else "long"
        raise DataError(f"{name}: line {i}: {kind} row, {len(cells)} fields, expected {len(header)}")
    vals = []
    for j in (range(len(cells)) if read is None else read):
        c = cells[j]
        try:
            if "_" in c:
                raise ValueError(c)
            v = float(c)
        except ValueError:
            raise DataError(f"{name}: line {i}: column {header[j]}: {c!r} is not a number") from None
        if not math.isfinite(v):
            raise DataError(f"{name}: line {i}: column {header[j]}: {c} is not finite, expected a real number")
        vals.append(v)
    return vals



def write_csv(path, recording: Recording) -> None:
    """Write a recording in the dataset's CSV format (atomically: temp file, then rename).

    The header is :data:`COLUMNS`; every value is written with 17 significant
    digits, so :func:`load_csv` reads back the same floats. The recording's
    labels are not written (they come from where the file lies).

    Parameters
    ----------
    path : str or Path
        File to write; its folder must exist.
    recording : Recording
        The samples to write.

    Returns
    -------
    None

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "r.csv")
    >>> t = 0.1 + np.arange(100) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.1, 0.0, 9.8], (100, 1)), omega=np.full((100, 3), 1 / 3))
    >>> write_csv(path, rec)
    >>> back = load_csv(path)
    >>> bool(np.array_equal(back.time, rec.time) and np.array_equal(back.omega, rec.omega))
    True
    >>> open(path).readline().strip()
    'time,f_x,f_y,f_z,g_x,g_y,g_z'
    """
    from ..outputs import atomic_path

    data = np.column_stack([recording.time, recording.f, recording.omega])
    with atomic_path(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(",".join(COLUMNS) + "\n")
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")


