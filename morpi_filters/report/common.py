"""What every page writer shares: number formatting, markdown tables, the synthetic-data banner, saving figures."""
from __future__ import annotations

import math
from pathlib import Path

from ..reporting import atomic_path

__all__ = ["SYNTHETIC_BANNER", "banner", "fmt", "md_table", "save_figure"]

#: Shown at the top of every page computed on synthetic data.
SYNTHETIC_BANNER = (
    "> **Synthetic data.** No field dataset was configured, so this page was computed on a seeded "
    "synthetic dataset made by `morpi simulate` with the paper's two IMU specifications. "
    "To run it on the MoRPI field recordings: `morpi data fetch --dest DIR` (or clone the public "
    "repository ansfl/MoRPI), then `morpi report --data DIR/data` or set `MORPI_DATA`."
)


def banner(source) -> str:
    """The synthetic-data notice for a page on `source` (a ``reporting.DataSource`` or None), else ``""``."""
    return SYNTHETIC_BANNER + "\n\n" if source is not None and source.synthetic else ""


def fmt(x, digits: int = 2) -> str:
    """Format a number for a markdown table (``-`` for None or NaN).

    Examples
    --------
    >>> fmt(3.14159), fmt(None), fmt(float("nan"))
    ('3.14', '-', '-')
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


def save_figure(fig, path, dpi: int = 120) -> Path:
    """Write `fig` (a Figure, or an Axes of one) as a PNG file, atomically.

    Returns
    -------
    Path
        `path`.
    """
    fig = getattr(fig, "figure", fig)
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    return path
