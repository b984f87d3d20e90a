"""The report's front page (``index.md``): every section's title, summary and figures."""
from __future__ import annotations

from ..deprecation import renamed_keywords
from ..fetch import dataset_identity
from .common import SYNTHETIC_BANNER

__all__ = ["index_page"]


@renamed_keywords(source="data_source")
def index_page(summaries, data_source) -> str:
    """The markdown of ``index.md``.

    Parameters
    ----------
    summaries : sequence of results.SectionSummary
        One per section, in the report's order.
    data_source : results.DataSource or None
        The dataset the report was computed on.

    Returns
    -------
    str
        The title, the synthetic-data banner or what the field dataset is
        (:class:`morpi_filters.fetch.DatasetIdentity`, never its path),
        then per section a linked heading, a synthetic note, its summary and
        its figures as images, each block followed by a blank line.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from morpi_filters.results import DataSource, SectionSummary
    >>> root = Path(tempfile.mkdtemp())
    >>> _ = (root / "1.csv").write_bytes(b"abc")
    >>> s = SectionSummary("curves", "Covariance curves", summary="INS-3D grows fastest.", figures=("sigma.png",))
    >>> print(index_page([s], DataSource(root)))  # doctest: +ELLIPSIS
    # morpi_filters report
    <BLANKLINE>
    Dataset: field recordings (1 recording, not the published MoRPI set: 143 file(s) missing, ...).
    <BLANKLINE>
    ## [Covariance curves](curves/README.md)
    <BLANKLINE>
    INS-3D grows fastest.
    <BLANKLINE>
    ![Covariance curves: sigma.png](curves/sigma.png)
    <BLANKLINE>
    """
    lines = ["# morpi_filters report", ""]
    if data_source is not None and data_source.synthetic:
        lines += [SYNTHETIC_BANNER, ""]
    elif data_source is not None and data_source.root is not None:
        lines += [f"Dataset: {dataset_identity(data_source.root, seed=data_source.seed).text}.", ""]
    for s in summaries:
        lines += [f"## [{s.title}]({s.name}/{s.page})", ""]
        if s.synthetic:
            lines += ["*Computed on synthetic data.*", ""]
        if s.summary:
            lines += [s.summary.strip(), ""]
        for fig in s.figures:
            lines += [f"![{s.title}: {fig}]({s.name}/{fig})", ""]
    return "\n".join(lines)
