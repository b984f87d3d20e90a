"""What every page writer shares: number formatting, markdown tables, the synthetic-data banner, saving figures
(with the garbage collector paused while they are drawn)."""
from __future__ import annotations

import contextlib
import gc
import math
from pathlib import Path

from ..deprecation import renamed_keywords
from ..outputs import atomic_path

__all__ = ["SYNTHETIC_BANNER", "banner", "fmt", "md_table", "save_figure", "collector_paused"]

#: Shown at the top of every page computed on synthetic data.
SYNTHETIC_BANNER = (
    "> **Synthetic data.** No field dataset was configured, so this page was computed on a seeded "
    "synthetic dataset made by `morpi simulate` with the paper's two IMU specifications. "
    "To run it on the MoRPI field recordings: `morpi data fetch --out DIR` (or clone the public "
    "repository ansfl/MoRPI), then `morpi report --data DIR/data` or set `MORPI_DATA`."
)


@renamed_keywords(source="data_source")
def banner(data_source) -> str:
    """The synthetic-data notice for a page on `data_source` (a ``results.DataSource`` or None), else ``""``.

    Parameters
    ----------
    data_source : results.DataSource or None
        Where the page's recordings come from.

    Returns
    -------
    str
        :data:`SYNTHETIC_BANNER` and a blank line when ``data_source.synthetic``,
        else the empty string.

    Examples
    --------
    >>> from morpi_filters.results import DataSource
    >>> banner(None), banner(DataSource(root=None))
    ('', '')
    >>> text = banner(DataSource(root=None, synthetic=True, seed=0))
    >>> text.startswith(SYNTHETIC_BANNER), len(text) - len(SYNTHETIC_BANNER)     # and two newlines
    (True, 2)
    >>> text.rstrip() == SYNTHETIC_BANNER
    True
    """
    return SYNTHETIC_BANNER + "\n\n" if data_source is not None and data_source.synthetic else ""


def fmt(x, digits: int = 2) -> str:
    """Format a number for a markdown table (``-`` for None or NaN).

    Parameters
    ----------
    x : float, int, None or object
        The value; anything :class:`float` cannot convert is shown as ``str(x)``.
    digits : int
        Digits after the decimal point.

    Returns
    -------
    str
        Fixed-point text, ``"-"`` for None, NaN or inf.

    Examples
    --------
    >>> fmt(3.14159), fmt(None), fmt(float("nan")), fmt(2, 3), fmt("n/a")
    ('3.14', '-', '-', '2.000', 'n/a')
    """
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
    """A GitHub markdown table from a header list and rows of cells.

    Parameters
    ----------
    headers : sequence
        Column titles (converted with ``str``).
    rows : iterable of sequence
        Cells of each row (converted with ``str``), as many as the headers.

    Returns
    -------
    str
        The header line, the ``|---|`` separator and one line per row, each
        ending with a newline.

    Examples
    --------
    >>> print(md_table(["method", "error %"], [["MoRPI-G", "4.22"]]).rstrip())
    | method | error % |
    |---|---|
    | MoRPI-G | 4.22 |
    """
    head = "| " + " | ".join(str(h) for h in headers) + " |"
    sep = "|" + "|".join("---" for _ in headers) + "|"
    body = ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join([head, sep, *body]) + "\n"


def save_figure(fig, path, dpi: int = 120, crop: bool = False) -> Path:
    """Write `fig` (a Figure, or an Axes of one) as a PNG file, atomically.

    Parameters
    ----------
    fig : matplotlib.figure.Figure or matplotlib.axes.Axes
        What to save (an Axes saves its whole figure).
    path : str or Path
        Destination PNG file; missing folders are created.
    dpi : int
        Resolution [dots per inch].
    crop : bool
        Trim the margins to what is drawn (``bbox_inches="tight"``, which
        draws the figure once more), for a figure without a layout engine of
        its own; the package's figures lay themselves out
        (:func:`morpi_filters.report.plots.new_figure`): by default the
        layout engine runs once and the figure is saved in one draw.

    Returns
    -------
    Path
        `path`.

    Examples
    --------
    >>> import tempfile
    >>> from morpi_filters.report.plots import new_axes
    >>> ax, _ = new_axes()
    >>> _ = ax.plot([0, 1], [0, 1])
    >>> p = save_figure(ax, Path(tempfile.mkdtemp()) / "fig" / "line.png")
    >>> p.name, p.read_bytes()[1:4]             # the PNG signature
    ('line.png', b'PNG')
    """
    fig = getattr(fig, "figure", fig)
    path = Path(path)
    engine = None if crop else fig.get_layout_engine()
    if engine is not None:
        # matplotlib draws a figure with a layout engine twice when saving it (once to lay it out), and
        # lays it out in both draws: lay it out once here and save it without the engine, in one draw
        engine.execute(fig)
        fig.set_layout_engine(None)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight" if crop else None)
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
    return path


@contextlib.contextmanager
def collector_paused():
    """Pause Python's cyclic garbage collector while figures are drawn.

    matplotlib allocates a few hundred thousand objects per figure, none of
    them garbage before the figure is dropped; the collector would scan them
    over and over (about a tenth of the drawing time). Cycles left meanwhile
    are collected once it runs again.

    Yields
    ------
    None
        The block runs with the collector paused; its state is restored after.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
