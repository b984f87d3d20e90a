"""The report's front page (``index.md``): every section's title, summary and figures."""
from __future__ import annotations

from .common import SYNTHETIC_BANNER

__all__ = ["index_page"]


def index_page(summaries, source) -> str:
    """The markdown of ``index.md``.

    Parameters
    ----------
    summaries : sequence of reporting.SectionSummary
        One per section, in the report's order.
    source : reporting.DataSource or None
        The dataset the report was computed on.

    Returns
    -------
    str
        The title, the synthetic-data banner or the field dataset's root,
        then per section a linked heading, a synthetic note, its summary and
        its figures as images, each block followed by a blank line.

    Examples
    --------
    >>> from pathlib import Path
    >>> from morpi_filters.reporting import DataSource, SectionSummary
    >>> s = SectionSummary("curves", "Covariance curves", summary="INS-3D grows fastest.", figures=("sigma.png",))
    >>> print(index_page([s], DataSource(Path("data"))))
    # morpi_filters report
    <BLANKLINE>
    Field dataset: `data`.
    <BLANKLINE>
    ## [Covariance curves](curves/README.md)
    <BLANKLINE>
    INS-3D grows fastest.
    <BLANKLINE>
    ![Covariance curves: sigma.png](curves/sigma.png)
    <BLANKLINE>
    """
    lines = ["# morpi_filters report", ""]
    if source is not None and source.synthetic:
        lines += [SYNTHETIC_BANNER, ""]
    elif source is not None:
        lines += [f"Field dataset: `{source.root}`.", ""]
    for s in summaries:
        lines += [f"## [{s.title}]({s.name}/{s.page})", ""]
        if s.synthetic:
            lines += ["*Computed on synthetic data.*", ""]
        if s.summary:
            lines += [s.summary.strip(), ""]
        for fig in s.figures:
            lines += [f"![{s.title}: {fig}]({s.name}/{fig})", ""]
    return "\n".join(lines)
