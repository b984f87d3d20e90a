"""Every figure of the package, as a library: data in, matplotlib objects out.

Each function draws on the Axes it is given (``ax=``) or, without one, on a
new :class:`matplotlib.figure.Figure`, and returns the Axes it drew on; a
figure of several panels returns its Figure. Nothing here saves a file or
selects a backend: figures are plain ``Figure`` objects (no pyplot state), and
the page writers save them (:func:`morpi_filters.report.common.save_figure`).
matplotlib is imported inside the functions, so importing this module does not
load it.

The file is organised by report section, each under its own heading comment.
"""
from __future__ import annotations

import functools

__all__ = [
    "new_figure", "new_axes", "plot_recording", "plot_tracks", "plot_path_sets", "plot_error_sets", "assessment_figure", "plot_curves",
    "plot_aided_cells", "plot_aided_paths", "plot_aided_ellipses", "simulation_run", "montecarlo_final_errors", "montecarlo_error_curves",
    "montecarlo_gain_vs_error", "montecarlo_training_runs", "drift_disagreement_map",
]


def new_figure(**kw):
    """A new :class:`matplotlib.figure.Figure` (no pyplot, no backend), laid out when drawn.

    The figure's layout engine is the tight layout over the whole figure
    (:class:`matplotlib.layout_engine.TightLayoutEngine` with ``rect=None``,
    one pass over the Axes' extents) unless `kw` names another: the layout is
    computed once, when the figure is drawn (saved or shown), not before.

    Parameters
    ----------
    **kw
        Passed to :class:`matplotlib.figure.Figure` (``figsize`` [in], ``dpi``,
        ``layout``, ...).

    Returns
    -------
    matplotlib.figure.Figure
        Not registered with pyplot: it is freed with its last reference.

    Examples
    --------
    >>> fig = new_figure(figsize=(4, 3))
    >>> fig.get_size_inches().tolist(), fig.axes
    ([4.0, 3.0], [])
    """
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import TightLayoutEngine

    if "layout" not in kw:
        # rect=None: the subplots fill the whole figure, which the tight layout then finds in one pass over
        # the Axes' extents (with a rect, even the default (0, 0, 1, 1), it takes a second pass that only
        # repeats the first one's margins)
        kw["layout"] = TightLayoutEngine(rect=None)
    return Figure(**kw)


def new_axes(ax=None, figsize=(6.4, 4.8)):
    """`ax`, or the single Axes of a new Figure of size `figsize` [in]; and whether it is new.

    Parameters
    ----------
    ax : matplotlib.axes.Axes, optional
        An Axes to draw on; returned as it is.
    figsize : (float, float)
        Size of the new Figure [in] when `ax` is None.

    Returns
    -------
    ax : matplotlib.axes.Axes
        The Axes to draw on.
    new : bool
        True when the Axes belongs to a Figure made here.

    Examples
    --------
    >>> ax, new = new_axes(figsize=(5, 2))
    >>> new, ax.figure.get_size_inches().tolist()
    (True, [5.0, 2.0])
    >>> new_axes(ax) == (ax, False)
    True
    """
    if ax is not None:
        return ax, False
    return new_figure(figsize=figsize).subplots(), True


def _finish(ax, title="", which="major"):
    """Grid, legend and title of a one-axis plot (a Figure of our own lays itself out when drawn)."""
    ax.grid(True, which=which, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return ax


# ============================================================================ margins without a layout pass
# A figure of our own can be placed once from the labels it will show (no tight-layout pass when drawn).

_PAD_IN = 1.08 * 10 / 72      # the margin around everything drawn [in] (tight layout's pad at 10 pt)
_TICK_IN = 7 / 72             # tick length + tick-label pad [in] (matplotlib's defaults, 3.5 + 3.5 pt)
_LABEL_IN = 16 / 72           # an axis label at 10 pt and its pad [in]
_TITLE_IN = 0.343 - _PAD_IN   # a 10 pt Axes title and its pad [in]
_XTICKS_IN = 0.585 - _PAD_IN  # the x tick labels and x label under an Axes [in]
_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def _plain_log_labels(*axes):
    """Label log axes with plain text (``10⁻⁷``, ``2×10⁻¹``) instead of mathtext.

    The labels are those of matplotlib's :class:`~matplotlib.ticker.LogFormatterSciNotation`
    (the same ticks labelled), written with Unicode superscripts, so drawing
    them needs no mathtext parser (a tenth of a second for a page's first log
    axis); a label this cannot write stays mathtext.
    """
    import re

    from matplotlib.ticker import LogFormatterSciNotation

    class PlainLogFormatter(LogFormatterSciNotation):
        def __call__(self, x, pos=None):
            s = super().__call__(x, pos)
            m = re.fullmatch(r"\$\\mathdefault\{(.*)\}\$", s)
            if m is None:
                return s
            body = re.sub(r"\^\{(-?\d+)\}", lambda e: e.group(1).translate(_SUPERSCRIPT),
                          m.group(1).replace(r"\times", "\u00d7"))
            return s if any(c in body for c in "\\{}^$") else body.replace("-", "\u2212")

    for axis in axes:
        axis.set_major_formatter(PlainLogFormatter())
        axis.set_minor_formatter(PlainLogFormatter(labelOnlyBase=False))


def _tick_labels(axis):
    """(position, text) of the tick labels `axis` shows at its current limits, major and minor."""
    lo, hi = sorted(axis.get_view_interval())
    tol = 1e-9 * (hi - lo)
    out = []
    for locator, formatter in ((axis.get_major_locator(), axis.get_major_formatter()),
                               (axis.get_minor_locator(), axis.get_minor_formatter())):
        locs = [x for x in locator() if lo - tol <= x <= hi + tol]
        out += [(x, t) for x, t in zip(locs, formatter.format_ticks(locs)) if t]
    return out


@functools.lru_cache(maxsize=4096)
def _drawn_width(text, size, dpi) -> float:
    """Width [pixels] of `text` in the default font at `size` [pt] as drawn at `dpi` (kept: tick labels repeat)."""
    from matplotlib.font_manager import FontProperties, findfont, get_font

    prop = FontProperties(size=size)
    font = get_font(findfont(prop))
    font.set_size(prop.get_size_in_points(), dpi)
    font.set_text(text, 0.0)
    return font.get_width_height()[0] / 64


def _text_width(texts, size=10.0, dpi=120) -> float:
    """Width [in] of the widest of `texts` in the default font at `size` [pt], as drawn at `dpi` (0 for none).

    One point is added for the rounding of the drawn glyphs.
    """
    return max(_drawn_width(t, float(size), dpi) for t in texts) / dpi + 1 / 72 if texts else 0.0


@functools.lru_cache(maxsize=2)
def _measuring_renderer(dpi):
    """An Agg renderer that only measures (kept, so matplotlib's text metrics cache serves every figure)."""
    from matplotlib.backends.backend_agg import RendererAgg

    return RendererAgg(1, 1, dpi)


def _label_size(axis) -> float:
    """Font size [pt] of `axis`'s tick labels (as set on its ticks, e.g. by ``set_yticks(..., fontsize=7)``)."""
    return axis.majorTicks[0].label1.get_fontsize()


def _label_room(ax):
    """Room [in] left of `ax` for its y tick labels and y label; how far its x tick labels reach right of it [fraction of the label's width, width in]."""
    y = _text_width([t for _, t in _tick_labels(ax.yaxis)], _label_size(ax.yaxis))
    left = y + _TICK_IN + (_LABEL_IN if ax.get_ylabel() else 0.0)
    lo, hi = ax.get_xlim()
    xs = _tick_labels(ax.xaxis)
    if not xs:
        return left, 0.0, 0.0
    scale = ax.xaxis.get_transform()
    x, t = max(xs, key=lambda e: e[0])
    a, b, c = scale.transform([lo, hi, x])
    return left, (b - c) / (b - a), _text_width([t], _label_size(ax.xaxis)) / 2


def _title_room(ax) -> float:
    """Room [in] above `ax` for its title (0 without one): its pad and a line at its font size (10 pt at least)."""
    if not ax.get_title():
        return 0.0
    return 6 / 72 + (_TITLE_IN - 6 / 72) * max(ax.title.get_fontsize(), 10.0) / 10


def _legend_reach(ax, renderer):
    """How far [in] a legend anchored outside `ax` reaches above, below and right of it, as placed now (0 for none)."""
    legend = ax.get_legend()
    if legend is None or legend.get_bbox_to_anchor() is ax.bbox:
        return 0.0, 0.0, 0.0
    dpi = ax.figure.dpi
    box = ax.get_position(original=True).transformed(ax.figure.transFigure)
    drawn = legend.get_window_extent(renderer)
    return max(0.0, drawn.y1 - box.y1) / dpi, max(0.0, box.y0 - drawn.y0) / dpi, max(0.0, drawn.x1 - box.x1) / dpi


def _under_room(ax) -> float:
    """Room [in] under `ax` for its x tick labels and x label (the tick marks only under a panel above a shared x)."""
    label = _LABEL_IN if ax.get_xlabel() else 0.0
    if not ax.xaxis.get_tick_params().get("labelbottom", True):
        return _TICK_IN / 2 + label
    return _XTICKS_IN - _LABEL_IN + label


def _fixed_layout(fig, axes, nrow=1, ncol=1, suptitle=False, right_room=0.0):
    """Place the `nrow` x `ncol` grid of `axes` with margins sized to their labels (no layout pass when drawn).

    The margins hold the tick labels the Axes show at their limits (measured
    in their fonts), the axis labels, the titles and legends anchored outside
    the Axes, with the tight layout's pad around them; the figure then draws
    in one pass. An Axes of fixed aspect (``adjustable="datalim"``) gets its
    limits for the final box here, and its labels are measured at those.
    `right_room` [in] is kept free right of the grid (for a colour bar placed
    there by the caller).
    """
    w, h = fig.get_size_inches()
    fixed = [ax for ax in axes if ax.get_aspect() != "auto"]
    outside = [ax for ax in axes if ax.get_legend() is not None and ax.get_legend().get_bbox_to_anchor() is not ax.bbox]
    renderer = _measuring_renderer(fig.dpi) if outside else None
    rows = [ax.get_subplotspec().rowspan for ax in axes]
    first = [r.start == 0 for r in rows]
    last = [r.stop == nrow for r in rows]
    title = any(ax.get_title() for ax in axes)
    above = below = beyond = 0.0
    for _ in range(3 if fixed or outside else 1):
        # a fixed aspect sets the limits (hence the labels) from the box, and a legend anchored at a fraction of
        # the Axes' height moves with it: a few rounds settle both
        rooms = [_label_room(ax) for ax in axes]
        left = max(r[0] for r in rooms)
        gap = _PAD_IN + left
        right = _PAD_IN + beyond + right_room
        for _ in range(2):              # the x labels' overhang depends on the Axes width, which depends on it
            width = (w - _PAD_IN - left - right - (ncol - 1) * gap) / ncol
            over = max(max(0.0, half - frac * width) for _, frac, half in rooms)
            right, gap = _PAD_IN + max(over, beyond + right_room), _PAD_IN + left + over
        if ncol == 1 and title:
            # a title wider than the Axes overhangs both sides equally: keep it on the canvas
            widest = max(_text_width([ax.get_title()], ax.title.get_fontsize()) for ax in axes)
            right = max(right, left + widest + 2 * _PAD_IN - w)
            width = w - _PAD_IN - left - right
        # over an Axes: its title and, under it, a y offset text (e.g. "1e6"); under it: its x tick labels and label
        overs = [max(_title_room(ax), above) + (_TITLE_IN if ax.yaxis.get_major_formatter().get_offset() else 0.0)
                 for ax in axes]
        unders = [max(_under_room(ax), below) for ax in axes]
        # a suptitle hangs from 0.98 of the height: its 10 pt line and a gap above the Axes titles
        top = (0.02 * h + 0.25 if suptitle else _PAD_IN) + max(o for o, f in zip(overs, first) if f)
        bottom = _PAD_IN + max(u for u, b in zip(unders, last) if b)
        vgap = (_PAD_IN + max((u for u, b in zip(unders, last) if not b), default=0.0)
                + max((o for o, f in zip(overs, first) if not f), default=0.0))
        height = (h - top - bottom - (nrow - 1) * vgap) / nrow
        fig.set_layout_engine("none")
        fig.subplots_adjust(left=(_PAD_IN + left) / w, right=1 - right / w, bottom=bottom / h,
                            top=1 - top / h, wspace=gap / width, hspace=vgap / height)
        for ax in fixed:
            ax.apply_aspect()
        if outside:
            reach = [_legend_reach(ax, renderer) for ax in outside]
            above, below, beyond = (max(r[i] for r in reach) for i in range(3))
    for ax in axes:
        # an Axes title goes to the top of the Axes unless top tick labels or a y offset text are in its way, which
        # every draw would measure the whole y axis to find out: with neither, the title is placed there now
        if (ax.get_title() and not ax.yaxis.get_major_formatter().get_offset()
                and ax.xaxis.get_ticks_position() == "bottom" and ax.xaxis.get_label_position() == "bottom"):
            ax.set_title(ax.get_title(), fontsize=ax.title.get_fontsize(), y=1.0)


# ============================================================================ tables (field pipeline)
# Figures of reports/tables/: recordings, INS trajectories, MoRPI paths.

def plot_recording(time, f, omega, *, title="", rest=None, motion=None, peaks=None, peak_signal="omega_z"):
    """Specific force and angular rate of one recording, as in the paper's recording figures.

    Parameters
    ----------
    time : ndarray, shape (n,)
        [s]; shown from the first sample.
    f, omega : ndarray, shape (n, 3)
        Specific force [m/s^2] and angular rate [rad/s] in phone axes.
    title : str
        Title of the upper panel.
    rest : tuple of float, optional
        Initial rest window (start, end) [s], shaded.
    motion : tuple of float, optional
        Motion span (start, end) [s], dashed lines.
    peaks : ndarray, optional
        Peak times [s], marked on `peak_signal` (``"omega_z"`` or ``"f_y"``).

    peak_signal : {"omega_z", "f_y"}
        The signal the peaks are marked on.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels (specific force above, angular rate below).

    Examples
    --------
    >>> import numpy as np
    >>> t = 100.0 + np.arange(500) * 0.01                  # a recording's own clock
    >>> f = np.tile([0.0, 0.0, 9.8], (500, 1))
    >>> omega = np.zeros((500, 3))
    >>> omega[:, 2] = np.sin(2 * np.pi * (t - 100.0))
    >>> fig = plot_recording(t, f, omega, rest=(100.0, 101.0), peaks=[100.25, 101.25])
    >>> [ax.get_ylabel() for ax in fig.axes], bool(fig.axes[1].get_xlim()[0] < 0.5)   # time from the first sample
    (['m/s$^2$', 'rad/s'], True)
    """
    import numpy as np

    t = np.asarray(time) - time[0]
    fig = new_figure(figsize=(8, 5.5))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, data, name, unit in ((axes[0], f, "f", "m/s$^2$"), (axes[1], omega, "\\omega", "rad/s")):
        for j, c in enumerate("xyz"):
            ax.plot(t, data[:, j], lw=0.8, label=f"${name}_{c}$")
        ax.set_ylabel(unit)
        if rest is not None:
            ax.axvspan(rest[0] - time[0], rest[1] - time[0], color="0.85", zorder=0,
                       label="rest window" if ax is axes[0] else None)
        if motion is not None:
            for v in motion:
                ax.axvline(v - time[0], color="k", ls="--", lw=0.7)
        ax.grid(alpha=0.3)
    if peaks is not None and len(peaks):
        ax = axes[1] if peak_signal == "omega_z" else axes[0]
        col = omega[:, 2] if peak_signal == "omega_z" else f[:, 1]
        pk = np.asarray(peaks)
        ax.plot(pk - time[0], np.interp(pk, time, col), "kv", ms=5, label="step boundaries")
    axes[0].legend(loc="upper right", fontsize=7, ncol=4)
    axes[1].legend(loc="upper right", fontsize=7, ncol=4)
    axes[1].set_xlabel("time from first sample [s]")
    axes[0].set_title(title)
    _fixed_layout(fig, list(axes), 2, 1)
    return fig


def plot_tracks(tracks, truth, *, title="", equal=True, ax=None):
    """Horizontal tracks against the true route.

    Parameters
    ----------
    tracks : dict
        Label -> ndarray (k, 2) positions [m].
    truth : ndarray, shape (m, 2)
        True route polyline [m].
    title : str
        Axes title.
    equal : bool
        Equal scales on x and y.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new 7 x 5 in Figure).

    Returns
    -------
    matplotlib.axes.Axes
        With one line for the route and, per track, a line and its end point.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.array([[0.0, 0.0], [6.3, 0.0]])
    >>> ax, _ = new_axes()
    >>> out = plot_tracks({"MoRPI-G": np.array([[0.0, 0.0], [3.0, 0.1], [6.0, 0.2]])}, truth, ax=ax)
    >>> out is ax, [t.get_text() for t in ax.get_legend().get_texts()]
    (True, ['true route', 'MoRPI-G'])
    """
    import numpy as np

    ax, new = new_axes(ax, (7, 5))
    ax.plot(truth[:, 0], truth[:, 1], "k-", lw=2.5, alpha=0.4, label="true route")
    ax.plot(*truth[-1], "k*", ms=12)
    for label, p in tracks.items():
        p = np.asarray(p)
        ax.plot(p[:, 0], p[:, 1], lw=1.2, label=label)
        ax.plot(p[-1, 0], p[-1, 1], "o", ms=4, color=ax.lines[-1].get_color())
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(title)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def _panel_grid(count: int, ncols: int, height: float):
    """A figure of `count` panels (at least one), `ncols` per row at most, each 4.6 in wide and `height` in
    high, the grid's unused cells switched off: (figure, axes grid, panels, rows, columns)."""
    n = max(1, count)
    ncols = min(ncols, n)
    nrows = (n + ncols - 1) // ncols
    fig = new_figure(figsize=(4.6 * ncols, height * nrows))
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    return fig, axes, n, nrows, ncols


def plot_path_sets(panels, *, ncols=3, around_truth: float | None = None, legend: str = "each"):
    """MoRPI paths of several test sets, one panel per set.

    Parameters
    ----------
    panels : list of dict
        Each with ``title``, ``truth`` (m, 2) and ``paths``: dict label -> list of (k, 2) arrays
        (one colour per label, one line per run).
    ncols : int
        Panels per row (at most).
    around_truth : float, optional
        Show each panel's truth and this fraction of its extent around it
        (at least 1 m), whatever the paths reach; default: everything drawn.
    legend : {"each", "first"}
        A legend in every panel, or in the first only (panels that share their labels).

    Returns
    -------
    matplotlib.figure.Figure
        One visible Axes per panel; unused grid cells are switched off.

    Examples
    --------
    >>> truth = [[0.0, 0.0], [6.3, 0.0]]
    >>> runs = [[[0.0, 0.0], [6.1, 0.2]], [[0.0, 0.0], [6.4, -0.1]]]
    >>> fig = plot_path_sets([{"title": f"set {i}", "truth": truth, "paths": {"MoRPI-A": runs}} for i in range(4)])
    >>> len(fig.axes), [ax.get_title() for ax in fig.axes if ax.axison]
    (6, ['set 0', 'set 1', 'set 2', 'set 3'])
    """
    import numpy as np

    fig, axes, n, nrows, ncols = _panel_grid(len(panels), ncols, 3.8)
    for ax, pnl in zip(axes.ravel(), panels):
        tr = np.asarray(pnl["truth"])
        ax.plot(tr[:, 0], tr[:, 1], "k-", lw=3, alpha=0.35)
        ax.plot(*tr[-1], "k*", ms=11)
        for i, (label, runs) in enumerate(pnl["paths"].items()):
            color = f"C{i}"
            for j, p in enumerate(runs):
                p = np.asarray(p)
                ax.plot(p[:, 0], p[:, 1], color=color, lw=0.8, alpha=0.7, label=label if j == 0 else None)
                ax.plot(p[-1, 0], p[-1, 1], ".", color=color, ms=5)
        ax.set_title(pnl["title"], fontsize=9)
        if around_truth is not None:
            lo, hi = tr.min(axis=0), tr.max(axis=0)
            pad = np.maximum(around_truth * float(np.max(hi - lo)), 1.0)
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box" if around_truth is not None else "datalim")
        ax.grid(alpha=0.3)
        if legend == "each" or ax is axes.ravel()[0]:
            ax.legend(fontsize=7)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    _fixed_layout(fig, list(axes.ravel()[:n]), nrows, ncols)
    return fig


def plot_error_sets(panels, *, ncols=3, legend: str = "each"):
    """Horizontal error against time, one panel per recording.

    Parameters
    ----------
    panels : list of dict
        Each with ``title`` and ``curves``: dict label -> (time [s], error [m]) arrays.
    ncols : int
        Panels per row (at most).
    legend : {"each", "first"}
        A legend in every panel, or in the first only.

    Returns
    -------
    matplotlib.figure.Figure
        One visible Axes per panel; unused grid cells are switched off.

    Examples
    --------
    >>> t = [0.0, 1.0, 2.0]
    >>> fig = plot_error_sets([{"title": "run 1", "curves": {"INS-2D": (t, [0.0, 0.1, 0.4])}}])
    >>> [ax.get_title() for ax in fig.axes], [ln.get_label() for ln in fig.axes[0].get_lines()]
    (['run 1'], ['INS-2D'])
    """
    import numpy as np

    fig, axes, n, nrows, ncols = _panel_grid(len(panels), ncols, 3.2)
    for ax, pnl in zip(axes.ravel(), panels):
        for i, (label, (t, e)) in enumerate(pnl["curves"].items()):
            ax.plot(np.asarray(t), np.asarray(e), color=f"C{i}", lw=1.0, label=label)
        ax.set_title(pnl["title"], fontsize=9)
        ax.grid(alpha=0.3)
        if legend == "each" or ax is axes.ravel()[0]:
            ax.legend(fontsize=7)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("horizontal error [m]")
    _fixed_layout(fig, list(axes.ravel()[:n]), nrows, ncols)
    return fig



# ============================================================================ assessment (symbolic)
# The analytical assessment figure.

def assessment_figure(curves, title: str = "Analytical assessment of 3D & 2D INS vs. MoRPI-A distance error", *,
                      ax=None):
    """Draw e_3D, e_2D and MoRPI-A distance error over time.

    Parameters
    ----------
    curves : morpi_filters.assessment.AssessmentCurves
        ``times`` (n,) [s], ``e3d``, ``e2d`` (n,) [m], ``morpi`` {dG: (n,)} [m].
    title : str
        Axes title.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new 6.4 x 4.2 in Figure).

    Returns
    -------
    matplotlib.axes.Axes
        Curves sorted by time, one per INS and one per gain error; dashed
        grey lines at 5 s and 14 s when they are in range; y from 0.

    Examples
    --------
    >>> import numpy as np
    >>> from morpi_filters.assessment import AssessmentCurves
    >>> t = np.array([0.0, 10.0, 20.0])
    >>> c = AssessmentCurves(times=t, e3d=t ** 3 / 100, e2d=t ** 2 / 10, e3d_bgz=t, e2d_bgz=t,
    ...                      morpi={0.05: 0.05 * t, 0.1: 0.1 * t}, convention="z_up")
    >>> ax = assessment_figure(c)
    >>> len(ax.get_lines()), float(ax.get_ylim()[0]), [t.get_text() for t in ax.get_legend().get_texts()][:2]
    (6, 0.0, ['3D INS', '2D INS'])
    """
    ax, new = new_axes(ax, (6.4, 4.2))
    order = sorted(range(len(curves.times)), key=lambda i: curves.times[i])
    t = [curves.times[i] for i in order]
    ax.plot(t, [curves.e3d[i] for i in order], color="tab:red", lw=2, label="3D INS")
    ax.plot(t, [curves.e2d[i] for i in order], color="tab:blue", lw=2, label="2D INS")
    styles = ["--", ":", "-.", (0, (5, 1))]
    for k, (dG, e) in enumerate(sorted(curves.morpi.items())):
        ax.plot(t, [e[i] for i in order], color="tab:green", ls=styles[k % len(styles)], lw=2,
                label=f"MoRPI-A, $\\delta G_A$ = {dG * 100:g}%")
    for tm in (5.0, 14.0):  # the paper's straight-line and periodic-run durations
        if t and min(t) <= tm <= max(t):
            ax.axvline(tm, color="0.6", lw=0.8, ls="--", zorder=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance error [m]")
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize=9)
    ax.set_xlim(left=min(t) if t else 0.0)
    ax.set_ylim(bottom=0.0)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


# ============================================================================ curves (filter covariance)
# Closed form, filter sigma, Monte Carlo RMS and field end-point errors on one axis.

_CURVE_PANELS = (("INS-3D", "3D INS"), ("INS-2D", "2D INS"), ("MoRPI-aided INS", "MoRPI-aided INS"))


def plot_curves(curves):
    """One figure per case: a panel per method, every error view on the same axes.

    Needs a computed :class:`morpi_filters.curves.CaseCurves` (about a
    second), so there is no example.

    Parameters
    ----------
    curves : curves.CaseCurves
        The case's filter sigma, closed-form RMS and realisation, Monte Carlo
        RMS (linear and strapdown) and field end points, per method.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels (INS-3D, INS-2D, MoRPI-aided INS) on a shared time axis,
        symmetric-log error scale, titled with the case.
    """
    import numpy as np

    fig = new_figure(figsize=(13, 4.2))
    axes = fig.subplots(1, 3, sharex=True)
    for ax, (key, title) in zip(axes, _CURVE_PANELS):
        t = curves.times
        ax.plot(t, curves.sigma[key], color="C0", lw=2, label="filter 1 sigma")
        ax.plot(t, curves.rms_closed_form[key], color="C1", ls="--", label="closed-form RMS")
        if key in curves.realisation:
            ax.plot(t, curves.realisation[key], color="C2", ls=":", label="closed form, one realisation")
        if key in curves.mc_rms:
            ax.plot(curves.mc_times, curves.mc_rms[key], color="C3", marker=".", ls="none", ms=3,
                    label=f"Monte Carlo RMS ({curves.mc_runs} runs)")
        if key in curves.nl_rms:
            ax.plot(curves.nl_times[::10], curves.nl_rms[key][::10], color="C4", marker="+", ls="none", ms=5,
                    label=f"strapdown Monte Carlo RMS ({curves.nl_runs} runs)")
        pts = curves.field.get(key) if curves.field else None
        if pts:
            d, e = np.asarray(pts).T
            ax.plot(d, e, "kx", label="field end points (S8 straight line)")
        ax.set_title(title)
        ax.set_xlabel("time [s]")
        ax.set_yscale("symlog", linthresh=1e-2)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("horizontal position error [m]")
    axes[0].legend(fontsize=8)
    fig.suptitle(curves.case.title)
    _plain_log_labels(*(ax.yaxis for ax in axes))
    _fixed_layout(fig, list(axes), 1, 3, suptitle=True)
    return fig


def plot_aided_cells(cells, *, ax=None):
    """Field end-point error per MoRPI table cell: aided filter (smoothed), MoRPI alone, INS alone, the paper.

    Parameters
    ----------
    cells : sequence of field_aided.AidedCell
        Their ``ins_percent``, ``morpi_percent``, ``smoothed_percent``,
        ``spec.paper_percent`` and ``label`` are drawn.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new Figure 8 in wide, 0.32 in per cell high).

    Returns
    -------
    matplotlib.axes.Axes
        Three horizontal bars per cell (log scale), the paper's value as a tick,
        cells from top to bottom in order.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> cell = SimpleNamespace(label="s8 short GC MoRPI-G", ins_percent=40.0, morpi_percent=4.0,
    ...                        smoothed_percent=3.0, spec=SimpleNamespace(paper_percent=4.2))
    >>> ax = plot_aided_cells([cell, cell])
    >>> len(ax.patches), ax.get_xscale(), [t.get_text() for t in ax.get_yticklabels()]
    (6, 'log', ['s8 short GC MoRPI-G', 's8 short GC MoRPI-G'])
    """
    import numpy as np

    n = len(cells)
    ax, new = new_axes(ax, (8, 0.32 * n + 1.5))
    y = np.arange(n)
    h = 0.27
    ax.barh(y - h, [c.ins_percent for c in cells], h, color="0.7", label="INS-3D alone")
    ax.barh(y, [c.morpi_percent for c in cells], h, color="C1", label="MoRPI alone")
    ax.barh(y + h, [c.smoothed_percent for c in cells], h, color="C0", label="MoRPI-aided filter (smoothed)")
    ax.plot([c.spec.paper_percent for c in cells], y, "k|", ms=9, label="paper (MoRPI)")
    ax.set_yticks(y, [c.label for c in cells], fontsize=7)
    ax.invert_yaxis()
    ax.set_xscale("log")
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel("mean end-point error [% of travelled distance]")
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, frameon=False)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def plot_aided_paths(cell, truth_xy, *, ax=None):
    """Test paths of one cell: MoRPI alone, forward and smoothed filter, against the true route.

    Parameters
    ----------
    cell : field_aided.AidedCell
        Its ``paths`` (per run: epoch time, forward xy, smoothed xy, MoRPI
        xy, forward P_xy) and ``label`` are drawn.
    truth_xy : ndarray, shape (m, 2)
        The true route's polyline [m].
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new 8 x 4 in Figure).

    Returns
    -------
    matplotlib.axes.Axes
        The route and three lines (MoRPI, forward, smoothed), each through
        every run's path, titled with the cell's label.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> xy = np.array([[0.0, 0.0], [3.0, 0.1], [6.3, 0.0]])
    >>> run = (np.array([0.0, 5.0, 10.0]), xy, xy, xy + 0.1, np.tile(np.eye(2) * 0.01, (3, 1, 1)))
    >>> ax = plot_aided_paths(SimpleNamespace(label="s8 short", paths=(run, run)), np.array([[0.0, 0.0], [6.3, 0.0]]))
    >>> len(ax.get_lines()), ax.get_title()                 # the route, and one line per kind for every run
    (4, 's8 short')
    """
    import numpy as np

    ax, new = new_axes(ax, (8, 4))
    ax.plot(truth_xy[:, 0], truth_xy[:, 1], "k-", lw=2, label="true route")

    def runs(k):
        # every run's path as one line, the runs apart (a NaN row between two runs breaks the line)
        gap = np.full((1, 2), np.nan)
        return np.concatenate([part for p in cell.paths for part in (np.asarray(p[k], float)[:, :2], gap)][:-1])

    for k, style, color, label in ((3, "-", "C1", "MoRPI alone"), (1, "-", "C0", "forward filter"),
                                   (2, "--", "C2", "smoothed")):
        if cell.paths:
            xy = runs(k)
            ax.plot(xy[:, 0], xy[:, 1], style, color=color, lw=0.8, label=label)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(cell.label, fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.15), frameon=False)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def plot_aided_ellipses(cell, *, run: int = 0, every_s: float = 2.0, ax=None):
    """The filter's 2-sigma horizontal ellipses along one test run of a cell.

    Parameters
    ----------
    cell : field_aided.AidedCell
        Its ``paths``, ``runs`` (for the file name) and ``label`` are read.
    run : int
        Which run of the cell.
    every_s : float
        Spacing of the ellipses [s].
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new 8 x 4 in Figure).

    Returns
    -------
    matplotlib.axes.Axes
        The forward path and one ellipse per `every_s` (and one at the end).

    Examples
    --------
    A 0.1 m circle (P = 0.0025 I m^2, 2 sigma) every 2 s over 5 s: at 0, 2, 4 and 5 s.

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> t = np.arange(6.0)
    >>> fwd = np.stack([t, 0 * t], axis=1)
    >>> cell = SimpleNamespace(label="s8 short", runs=({"file": "1.csv"},),
    ...                        paths=((t, fwd, fwd, fwd, np.tile(np.eye(2) * 0.0025, (6, 1, 1))),))
    >>> ax = plot_aided_ellipses(cell)
    >>> lines = ax.get_lines()
    >>> len(lines), round(float(np.ptp(lines[1].get_xdata())), 3)      # diameter 4 sigma
    (5, 0.2)
    """
    import numpy as np

    ax, new = new_axes(ax, (8, 4))
    t, fwd, _, _, P = cell.paths[run]
    ax.plot(fwd[:, 0], fwd[:, 1], "-", color="C0", lw=1, label="forward filter")
    ang = np.linspace(0, 2 * np.pi, 60)
    circle = np.stack([np.cos(ang), np.sin(ang)])
    last = -np.inf
    for k in range(t.size):
        if t[k] - last < every_s and k != t.size - 1:
            continue
        last = t[k]
        w, V = np.linalg.eigh(0.5 * (P[k] + P[k].T))
        e = V @ (2.0 * np.sqrt(np.maximum(w, 0.0))[:, None] * circle)
        ax.plot(fwd[k, 0] + e[0], fwd[k, 1] + e[1], "-", color="C3", lw=0.6)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{cell.label}: 2-sigma ellipses every {every_s:g} s ({cell.runs[run]['file']})", fontsize=8)
    ax.grid(True, alpha=0.3)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


# ============================================================================ montecarlo and drift
# Gain-error distributions and the closed-form vs strapdown drift map.

def montecarlo_final_errors(columns, final, *, title=""):
    """Histograms of final horizontal errors, one panel per column.

    Parameters
    ----------
    columns : sequence of str
        Column names (panel titles).
    final : ndarray, shape (runs, len(columns))
        Final errors [m].
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Up to 3 panels per row, each a 50-bin histogram (one filled step
        outline) with its mean and 95th percentile; unused cells hidden.

    Examples
    --------
    >>> import numpy as np
    >>> final = np.random.default_rng(0).rayleigh(1.0, (100, 2))
    >>> fig = montecarlo_final_errors(["MoRPI-A[5 %]", "MoRPI-G[5 %]"], final)
    >>> [ax.get_title() for ax in fig.axes], fig.axes[0].patches[0].get_data().values.size   # 50 bins each
    (['MoRPI-A[5 %]', 'MoRPI-G[5 %]'], 50)
    >>> int(fig.axes[0].patches[0].get_data().values.sum())                                 # every run counted
    100
    """
    import numpy as np

    k = len(columns)
    ncol = min(k, 3)
    nrow = (k + ncol - 1) // ncol
    fig = new_figure(figsize=(4.2 * ncol, 3.0 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for i, name in enumerate(columns):
        ax = axes[i // ncol][i % ncol]
        x = np.asarray(final[:, i], float)
        counts, edges = np.histogram(x, bins=50)
        ax.stairs(counts, edges, fill=True, color="C%d" % (i % 10), alpha=0.8)
        ax.axvline(np.mean(x), color="k", lw=1, label=f"mean {np.mean(x):.3g} m")
        ax.axvline(np.percentile(x, 95), color="k", lw=1, ls="--", label=f"p95 {np.percentile(x, 95):.3g} m")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("final horizontal error [m]")
        ax.legend(fontsize=7, loc="upper right")
    for j in range(k, nrow * ncol):
        axes[j // ncol][j % ncol].set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    _fixed_layout(fig, [ax for row in axes for ax in row if ax.get_visible()], nrow, ncol, suptitle=bool(title))
    return fig


def montecarlo_error_curves(time, bands, labels, *, analytic=None, title="", ax=None):
    """Median and 5-95 % band of the error over time, log scale.

    Parameters
    ----------
    time : ndarray, shape (m,)
        [s].
    bands : ndarray, shape (m, k, 3)
        5th, 50th and 95th percentile of the horizontal errors over the runs
        [m] (``montecarlo.StudyResult.bands``).
    labels : sequence of str, length k
        Names of the k error columns.
    analytic : dict, optional
        label -> (time (q,), value (q,)) curves drawn dashed.
    title : str
        Axes title.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new 7 x 4.2 in Figure).

    Returns
    -------
    matplotlib.axes.Axes
        Log y axis; one median line and band per column with any finite
        value, then the analytic curves.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 10.0, 11)
    >>> band = np.stack([0.5 * t, t, 2 * t], axis=-1)[:, None, :]          # (11, 1, 3)
    >>> ax = montecarlo_error_curves(t, band, ["INS-2D"], analytic={"t^2 / 10": (t, t ** 2 / 10)})
    >>> ax.get_yscale(), [t.get_text() for t in ax.get_legend().get_texts()]
    ('log', ['INS-2D (median)', 't^2 / 10'])
    """
    import numpy as np

    ax, new = new_axes(ax, (7, 4.2))
    for i, lab in enumerate(labels):
        b = np.asarray(bands)[:, i, :]
        if not np.isfinite(b).any():
            continue
        lo, med, hi = b[:, 0], b[:, 1], b[:, 2]
        shown = hi > 0                      # log axis: leave out times with no error yet
        med = np.where(shown & (med > 0), med, np.nan)
        ax.plot(time, med, color=f"C{i}", label=f"{lab} (median)")
        ax.fill_between(time, np.where(lo > 0, lo, np.nan), np.where(shown, hi, np.nan), color=f"C{i}", alpha=0.2)
    for j, (lab, (t, v)) in enumerate((analytic or {}).items()):
        ax.plot(t, v, ls="--", color=f"C{len(labels) + j}", label=lab)
    ax.set_yscale("log")
    _plain_log_labels(ax.yaxis)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("horizontal position error [m]")
    _finish(ax, title, which="both")
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def montecarlo_gain_vs_error(dG, err, *, analytic_slope=None, label="MoRPI-A", title="", ax=None):
    """Scatter of final distance error against the gain error, with the analytical line ds = dG * D.

    Draws on `ax` (default: a new 6 x 4 in Figure) and returns it.

    Parameters
    ----------
    dG : array_like, shape (runs,)
        Gain errors (fractions; shown in %).
    err : array_like, shape (runs,)
        Distance errors [m].
    analytic_slope : float, optional
        D [m]: draws the line ``dG * D`` over the range of `dG`.
    label : str
        Method name in the legend.
    title : str
        Axes title.
    ax : matplotlib.axes.Axes, optional
        Where to draw.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> import numpy as np
    >>> dG = np.array([0.04, 0.05, 0.06])
    >>> ax = montecarlo_gain_vs_error(dG, 5.0 * dG, analytic_slope=5.0)
    >>> line = ax.get_lines()[1]                              # the analytical line, x in %
    >>> line.get_xdata()[[0, -1]].round(9).tolist(), line.get_ydata()[[0, -1]].round(9).tolist()
    ([4.0, 6.0], [0.2, 0.3])
    """
    import numpy as np

    ax, new = new_axes(ax, (6, 4))
    ax.plot(100 * np.asarray(dG), err, ".", ms=2, alpha=0.4, label=f"{label} Monte Carlo")
    if analytic_slope is not None:
        x = np.linspace(np.min(dG), np.max(dG), 50)
        ax.plot(100 * x, analytic_slope * x, "k--", lw=1, label="analytical ds = dG D")
    ax.set_xlabel("gain error dG [%]")
    ax.set_ylabel("distance error [m]")
    _finish(ax, title)
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def montecarlo_training_runs(k, rms_mc, rms_expected, labels, *, title="", ax=None):
    """RMS distance error against the number of training runs behind the gain (log-log).

    Draws on `ax` (default: a new 6 x 4 in Figure) and returns it.

    Parameters
    ----------
    k : array_like, shape (K,)
        Numbers of training runs.
    rms_mc : array_like, shape (K, len(labels))
        Monte Carlo RMS distance error per method [m].
    rms_expected : array_like, shape (K,)
        ``D sqrt(mismatch^2 + spread^2 / k)`` [m], drawn dashed.
    labels : sequence of str
        Method names.
    title : str
        Axes title.
    ax : matplotlib.axes.Axes, optional
        Where to draw.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> import numpy as np
    >>> k = np.array([1, 4, 16])
    >>> expected = 0.3 / np.sqrt(k)
    >>> ax = montecarlo_training_runs(k, np.stack([expected, expected], 1), expected, ["MoRPI-A", "MoRPI-G"])
    >>> ax.get_xscale(), ax.get_yscale(), len(ax.get_lines())
    ('log', 'log', 3)
    """
    import numpy as np

    ax, new = new_axes(ax, (6, 4))
    rms_mc = np.asarray(rms_mc)
    for i, lab in enumerate(labels):
        ax.plot(k, rms_mc[:, i], "o-", ms=4, label=f"{lab} Monte Carlo")
    ax.plot(k, rms_expected, "k--", label="D sqrt(mismatch^2 + spread^2 / k)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log_labels(ax.xaxis, ax.yaxis)
    ax.set_xlabel("training runs k")
    ax.set_ylabel("RMS distance error [m]")
    _finish(ax, title, which="both")
    if new:
        _fixed_layout(ax.figure, [ax])
    return ax


def drift_disagreement_map(gyro_bias_deg_s, time, rel, *, title="", marks=(), ax=None):
    """Map of the relative disagreement (log colour) over gyro bias [deg/s] and time [s].

    `marks`: (bias_deg_s, time_s, text) points to annotate. Contours at 1 % and 10 %.
    Draws on `ax` (default: a new 7 x 4.5 in Figure), with its colour bar beside it,
    and returns it.

    Parameters
    ----------
    gyro_bias_deg_s : array_like, shape (L,)
        Gyro bias levels [deg/s] (log y axis).
    time : array_like, shape (m,)
        Times [s].
    rel : array_like, shape (L, m)
        Relative disagreement (``montecarlo.DriftMap.rel_3d`` or ``rel_2d``),
        clipped at 1e-7 for the log colours.
    title : str
        Axes title.
    marks : sequence of (float, float, str)
        Points to mark and annotate.
    ax : matplotlib.axes.Axes, optional
        Where to draw.

    Returns
    -------
    matplotlib.axes.Axes
        The map; its Figure also holds the colour bar's Axes.

    Examples
    --------
    >>> import numpy as np
    >>> bias, t = np.logspace(-2, 1, 4), np.linspace(1.0, 15.0, 5)
    >>> rel = 1e-3 * np.outer(bias, t)                   # crosses 1 % and 10 %
    >>> ax = drift_disagreement_map(bias, t, rel, marks=[(1.0, 10.0, "datasheet")])
    >>> ax.get_yscale(), len(ax.figure.axes), ax.texts[-1].get_text()
    ('log', 2, 'datasheet')
    """
    import numpy as np
    from matplotlib.colors import LogNorm

    ax, new = new_axes(ax, (7, 4.5))
    fig = ax.figure
    r = np.clip(np.asarray(rel, float), 1e-7, None)
    m = ax.pcolormesh(time, gyro_bias_deg_s, r, norm=LogNorm(vmin=1e-5, vmax=max(1.0, r.max())), shading="nearest",
                      cmap="viridis")
    cs = ax.contour(time, gyro_bias_deg_s, r, levels=[0.01, 0.1], colors=["w", "r"], linewidths=1)
    ax.clabel(cs, fmt={0.01: "1 %", 0.1: "10 %"}, fontsize=8)
    for b, t, text in marks:
        ax.plot([t], [b], "r*", ms=9)
        ax.annotate(text, (t, b), textcoords="offset points", xytext=(-60, -14), color="r", fontsize=8)
    ax.set_yscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("gyro bias, 1 sigma per axis [deg/s]")
    if title:
        ax.set_title(title, fontsize=10)
    label = "|dp strapdown - dp closed form| / |dp strapdown|"
    _plain_log_labels(ax.yaxis)
    if not new:
        fig.colorbar(m, ax=ax, label=label)
        return ax
    # the colour bar in an Axes of its own right of the map: room for it, its tick labels and its label is
    # kept out of the map's margins, and both are placed once (no layout pass when drawn)
    cax = fig.add_axes((0.9, 0.1, 0.02, 0.8))
    fig.colorbar(m, cax=cax, label=label)
    _plain_log_labels(cax.yaxis)
    gap, bar = 0.15, 0.16                       # [in]: between map and bar, the bar's width (about 1/20 of its height)
    room = gap + bar + _TICK_IN + _text_width([t for _, t in _tick_labels(cax.yaxis)]) + _LABEL_IN
    _fixed_layout(fig, [ax], right_room=room)
    w, _ = fig.get_size_inches()
    box = ax.get_position()
    cax.set_position((box.x1 + gap / w, box.y0, bar / w, box.height))
    return ax


# ============================================================================ simulation
# One simulated run: the true path against the INS, the periodic motion in f_y and omega_z,
# and the INS position error over time.

def simulation_run(truth, imu_data, solutions, *, title=None):
    """Figure of one simulated run and its strapdown solutions.

    Parameters
    ----------
    truth : simulate.Trajectory
        The true motion sampled at the IMU times (``imu_data.truth``).
    imu_data : simulate.ImuData
        The synthesized readings of one run (unbatched).
    solutions : dict of str -> strapdown.InsResult
        INS solutions to draw, by label (e.g. ``"3D INS, noise-free"``).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Four panels: the horizontal paths, f_y and omega_z (measured and
        true, lateral peaks in grey) and the INS horizontal error (log scale).

    Examples
    --------
    >>> import numpy as np
    >>> from morpi_filters import simulate, strapdown, units
    >>> data = simulate.imu(simulate.sine(6.3), units.LSM6DSL, np.random.default_rng(0))
    >>> ins = strapdown.ins3d(data.time, data.f, data.omega, C0=data.truth.C_bn[0])
    >>> fig = simulation_run(data.truth, data, {"3D INS": ins}, title="one run")
    >>> len(fig.axes), fig.axes[2].get_yscale()
    (4, 'log')
    """
    import numpy as np

    fig = new_figure(figsize=(11, 7.5))
    ax = fig.subplots(2, 2)
    t = imu_data.time - imu_data.time[0]
    a = ax[0, 0]
    a.plot(truth.position[:, 0], truth.position[:, 1], "k", lw=2, label="true path")
    for label, r in solutions.items():
        a.plot(r.position[:, 0], r.position[:, 1], lw=1, label=label)
    a.set_xlabel("x [m]")
    a.set_ylabel("y [m]")
    a.set_title("path (navigation frame; drifting solutions leave the frame)")
    lo, hi = truth.position[:, :2].min(axis=0), truth.position[:, :2].max(axis=0)
    pad = 0.1 * max(hi - lo) + 0.2
    a.set_xlim(lo[0] - pad, hi[0] + pad)
    a.set_ylim(lo[1] - pad, hi[1] + pad)
    a.legend(fontsize=8)
    a = ax[0, 1]
    a.plot(t, imu_data.f[:, 1], lw=0.6, color="C0", label="f_y measured")
    a.plot(t, truth.f_b[:, 1], lw=1.2, color="k", label="f_y true")
    a.set_ylabel("f_y [m/s^2]")
    a.set_xlabel("t [s]")
    a.set_title("lateral specific force")
    for tp in truth.peak_times:
        a.axvline(tp - imu_data.time[0], color="0.8", lw=0.6, zorder=0)
    a.legend(fontsize=8)
    a = ax[1, 1]
    a.plot(t, imu_data.omega[:, 2], lw=0.6, color="C1", label="omega_z measured")
    a.plot(t, truth.omega_b[:, 2], lw=1.2, color="k", label="omega_z true")
    for tp in truth.peak_times:
        a.axvline(tp - imu_data.time[0], color="0.8", lw=0.6, zorder=0)
    a.set_ylabel("omega_z [rad/s]")
    a.set_xlabel("t [s]")
    a.set_title("z angular rate (grey: lateral peaks)")
    a.legend(fontsize=8)
    a = ax[1, 0]
    for label, r in solutions.items():
        err = np.linalg.norm(r.position[:, :2] - truth.position[:, :2], axis=1)
        a.semilogy(t, np.maximum(err, 1e-9), lw=1, label=label)
    a.set_xlabel("t [s]")
    a.set_ylabel("horizontal position error [m]")
    a.set_title("INS error")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return fig
