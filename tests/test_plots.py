"""The figures as a library: each function draws on the Axes it is given, or returns a new Figure, and saves nothing."""
from __future__ import annotations

import matplotlib
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from morpi_filters.report import plots
from morpi_filters.report.common import save_figure


class _Curves:
    times = np.linspace(0.0, 15.0, 16)
    e3d = 0.1 * times ** 2
    e2d = 0.05 * times ** 2
    morpi = {0.05: 0.05 * times, 0.10: 0.10 * times}


class _Cell:
    def __init__(self, i):
        self.label, self.ins_percent, self.morpi_percent = f"cell {i}", 100.0 + i, 5.0 + i
        self.forward_percent, self.smoothed_percent = 4.5 + i, 4.0 + i
        self.spec = type("Spec", (), {"paper_percent": 4.8 + i})()
        t = np.linspace(0.0, 10.0, 11)
        xy = np.c_[0.6 * t, 0.01 * t]
        self.paths = ((t, xy, xy + 0.01, xy - 0.01, np.broadcast_to(np.eye(2) * 1e-3, (11, 2, 2))),)
        self.runs = ({"file": "run.csv"},)


def _single_axes_calls():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 11)
    bands = np.sort(rng.random((11, 2, 3)), axis=-1) + 0.1
    return {
        "plot_tracks": lambda ax: plots.plot_tracks({"INS": np.c_[t, 0.1 * t]}, np.array([[0.0, 0.0], [10.0, 0.0]]),
                                                   title="tracks", ax=ax),
        "assessment_figure": lambda ax: plots.assessment_figure(_Curves(), ax=ax),
        "plot_aided_cells": lambda ax: plots.plot_aided_cells([_Cell(0), _Cell(1)], ax=ax),
        "plot_aided_paths": lambda ax: plots.plot_aided_paths(_Cell(0), np.array([[0.0, 0.0], [6.0, 0.0]]), ax=ax),
        "plot_aided_ellipses": lambda ax: plots.plot_aided_ellipses(_Cell(0), ax=ax),
        "montecarlo_error_curves": lambda ax: plots.montecarlo_error_curves(t, bands, ["a", "b"], title="e", ax=ax),
        "montecarlo_gain_vs_error": lambda ax: plots.montecarlo_gain_vs_error(rng.normal(0, 0.05, 50),
                                                                              rng.normal(0, 0.3, 50),
                                                                              analytic_slope=6.3, ax=ax),
        "montecarlo_training_runs": lambda ax: plots.montecarlo_training_runs([1, 2, 5], np.array([[3.0, 2.0], [2.0, 1.5],
                                                                                                   [1.0, 0.9]]),
                                                                              [3.1, 2.1, 1.1], ["A", "G"], ax=ax),
        "drift_disagreement_map": lambda ax: plots.drift_disagreement_map(np.logspace(-2, 1, 4), t,
                                                                          np.logspace(-5, 0, 44).reshape(4, 11), ax=ax),
    }


@pytest.mark.parametrize("name", sorted(_single_axes_calls()))
def test_single_axes_plots_draw_on_the_given_axes(name):
    call = _single_axes_calls()[name]
    fig = Figure()
    ax = fig.subplots()
    assert call(ax) is ax
    assert ax.lines or ax.patches or ax.collections  # something was drawn there
    own = call(None)  # without one: a new Figure of its own
    assert isinstance(own, Axes) and own.figure is not fig and isinstance(own.figure, Figure)


def test_multi_panel_plots_return_a_figure(tmp_path):
    t = np.linspace(0.0, 5.0, 50)
    f = np.c_[np.zeros(50), np.sin(t), np.full(50, 9.8)]
    fig = plots.plot_recording(t + 100.0, f, 0.1 * f, rest=(100.0, 101.0), peaks=np.array([102.0, 103.0]))
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    panels = [{"title": "p", "truth": np.array([[0.0, 0.0], [5.0, 0.0]]), "paths": {"A": [np.c_[t, 0 * t]]}}]
    assert isinstance(plots.plot_path_sets(panels), Figure)
    fig = plots.montecarlo_final_errors(["a", "b"], np.abs(np.random.default_rng(1).normal(size=(40, 2))))
    assert isinstance(fig, Figure) and not list(tmp_path.iterdir())  # drawing writes nothing
    path = save_figure(fig, tmp_path / "f.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]  # no temporary file left beside it


def test_drawing_uses_no_pyplot():
    # Figures are plain matplotlib.figure.Figure objects: nothing is registered with pyplot
    import sys

    before = "matplotlib.pyplot" in sys.modules and len(sys.modules["matplotlib.pyplot"].get_fignums())
    plots.assessment_figure(_Curves())
    after = "matplotlib.pyplot" in sys.modules and len(sys.modules["matplotlib.pyplot"].get_fignums())
    assert before == after


def _inside(fig) -> bool:
    """Whether everything drawn on `fig` lies within its canvas (nothing clipped by the margins)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    box = fig.get_tightbbox(canvas.get_renderer())            # inches
    w, h = fig.get_size_inches()
    return box.x0 >= 0 and box.y0 >= 0 and box.x1 <= w and box.y1 <= h


def test_monte_carlo_figures_lay_every_label_out_on_the_canvas(tmp_path):
    # the figures are saved without cropping (one draw, laid out by their own engine): the layout must hold
    # every label, here with the Monte Carlo page's longest titles and with tick labels of a million runs
    rng = np.random.default_rng(2)
    cols = ["INS-3D", "INS-2D"] + [f"MoRPI-{m}[training spread]" for m in "AG"] * 3
    final = np.abs(rng.normal(0.25, 0.3, (400_000, len(cols))))
    fig = plots.montecarlo_final_errors(cols, final, title="MPU-6500, 15 s, 1000000 runs, GAC-calibrated biases")
    assert _inside(fig)
    t = np.linspace(0.0, 15.0, 151)
    bands = np.stack([np.logspace(-7, 0, 151)[:, None] * [[0.5, 1.0, 2.0]]] * 4, axis=1)
    labels = ["INS-3D", "INS-2D", "MoRPI-A (dG 5 %)", "MoRPI-G (dG 5 %)"]
    assert _inside(plots.montecarlo_error_curves(t, bands, labels, title="horizontal error over time (median, "
                                                 "5-95 % band)").figure)
    dG = rng.normal(0.0, 0.05, 400_000)
    assert _inside(plots.montecarlo_gain_vs_error(dG, 6.3 * dG, analytic_slope=6.3, title="MoRPI-A distance error "
                                                  "against the gain error (training-spread scenario)").figure)
    k = np.array([1, 2, 3, 5, 10, 20, 50])
    rms = 0.3 / np.sqrt(k) + 0.01
    assert _inside(plots.montecarlo_training_runs(k, np.c_[rms, rms], rms, ["MoRPI-A", "MoRPI-G"],
                                                  title="gain from k training runs: spread 5 %, mismatch 2 %").figure)


def test_save_without_cropping_keeps_the_canvas(tmp_path):
    from PIL import Image

    ax, _ = plots.new_axes(figsize=(5.0, 3.0))
    ax.plot([0, 1], [0, 1])
    full = Image.open(save_figure(ax, tmp_path / "full.png", dpi=100)).size
    cropped = Image.open(save_figure(ax, tmp_path / "crop.png", dpi=100, crop=True)).size
    assert full == (500, 300) and cropped[0] < 500 and cropped[1] < 300


def _drawn(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def test_monte_carlo_panels_and_titles_do_not_overlap():
    # the histogram grid is laid out from its labels' widths (no layout pass): with the tick labels of a million
    # runs, no panel's labels or title reach into a neighbour, and the suptitle stays clear of the panel titles
    rng = np.random.default_rng(3)
    cols = ["INS-3D", "INS-2D"] + [f"MoRPI-{m}[training spread]" for m in "AG"] * 3
    fig = plots.montecarlo_final_errors(cols, np.abs(rng.normal(0.25, 0.3, (400_000, len(cols)))),
                                        title="MPU-6500, 15 s, 1000000 runs, GAC-calibrated biases")
    renderer = _drawn(fig)
    boxes = [ax.get_tightbbox(renderer) for ax in fig.axes if ax.get_visible()]
    assert len(boxes) == len(cols)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.overlaps(b)
    sup = fig._suptitle.get_window_extent(renderer)
    assert all(not sup.overlaps(b) for b in boxes)


def test_monte_carlo_log_axes_label_the_same_ticks_in_plain_text():
    # the log axes show matplotlib's labels (the same ticks labelled), written with Unicode superscripts
    from matplotlib.ticker import LogFormatterSciNotation

    sup = dict(zip("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079"))
    k = np.array([1, 2, 3, 5, 10, 20, 50])
    rms = 0.3 / np.sqrt(k) + 0.01
    t = np.linspace(0.0, 15.0, 151)
    bands = np.stack([np.logspace(-7, 0, 151)[:, None] * [[0.5, 1.0, 2.0]]] * 2, axis=1)
    for ax, axes in ((plots.montecarlo_training_runs(k, np.c_[rms, rms], rms, ["A", "G"]), "xy"),
                     (plots.montecarlo_error_curves(t, bands, ["a", "b"]), "y")):
        _drawn(ax.figure)
        for name in axes:
            axis = getattr(ax, name + "axis")
            for minor in (False, True):
                ticks = axis.get_minor_ticks() if minor else axis.get_major_ticks()
                locs = axis.get_minorticklocs() if minor else axis.get_majorticklocs()
                reference = LogFormatterSciNotation(labelOnlyBase=not minor)
                reference.set_axis(axis)
                reference.set_locs(locs)
                for tick, x in zip(ticks, locs):
                    shown, ref = tick.label1.get_text(), reference(x)
                    assert bool(shown) == bool(ref) and "$" not in shown
                    if shown:
                        e = int(np.floor(np.log10(x) + 1e-9))
                        c = round(x / 10.0 ** e)
                        power = "10" + "".join(sup[ch] for ch in str(e))
                        assert shown == (power if c == 1 else f"{c}\u00d7{power}")


def test_drift_map_is_placed_once_with_its_colour_bar_beside_it_on_the_canvas():
    # the map and its colour bar are placed from their labels (no layout engine): everything on the canvas, the
    # bar right of the map's labels and annotations, its tick labels and the map's y labels in plain text
    bias, t = np.logspace(-2, 1, 26), np.linspace(0.1, 15.0, 150)
    rel = np.clip(1e-3 * np.outer(bias, t) ** 1.5, 0, 3.0)
    ax = plots.drift_disagreement_map(bias, t, rel, marks=[(6.0, 14.0, "S6 datasheet, 14 s")],
                                      title="INS-3D INS at rest: strapdown vs small-angle closed form "
                                            "(median of 32 draws)")
    fig = ax.figure
    assert fig.get_layout_engine() is None or type(fig.get_layout_engine()).__name__ == "PlaceHolderLayoutEngine"
    assert _inside(fig)
    renderer = _drawn(fig)
    cax = [a for a in fig.axes if a is not ax]
    assert len(cax) == 1
    bar = cax[0].get_tightbbox(renderer)
    parts = [ax.bbox, ax.title.get_window_extent(renderer), ax.xaxis.get_tightbbox(renderer),
             *(a.get_window_extent(renderer) for a in ax.texts)]
    assert all(not bar.overlaps(p) for p in parts)
    for axis in (ax.yaxis, cax[0].yaxis):
        shown = [tk.label1.get_text() for tk in axis.get_major_ticks() if tk.label1.get_text()]
        assert shown and all("$" not in x for x in shown)
    assert any(lbl.get_text() == "10\u2070" for lbl in cax[0].yaxis.get_ticklabels() + cax[0].yaxis.get_ticklabels(
        which="both"))


def test_monte_carlo_margins_hold_wide_labels_an_offset_text_and_a_long_title():
    # tick labels of many digits, a y offset text ("+1e3") above the Axes with the title above it, and a title
    # wider than the Axes: all on the canvas
    dG = np.random.default_rng(4).normal(0.0, 0.05, 2000)
    title = "MoRPI-A distance error against the gain error (training-spread scenario)"
    for err in (2000.0 * dG, 1000.0 + 1e-3 * dG, 1e-6 * dG):
        ax = plots.montecarlo_gain_vs_error(dG, err, title=title)
        assert _inside(ax.figure)


def _aided_cells(rng, n=24):
    cells = []
    for i in range(n):
        c = _Cell(i)
        c.label = f"morpi_l_shape s{6 + 2 * (i % 2)} 1.5 m MoRPI-{'AG'[i % 2]} {('RD', 'GC')[i // 2 % 2]}"
        c.ins_percent, c.morpi_percent, c.smoothed_percent = 10 ** rng.uniform(2.5, 4.3), rng.uniform(2, 60), rng.uniform(1.5, 12)
        c.spec.paper_percent = rng.uniform(4, 20)
        cells.append(c)
    return cells


def _aided_path_cell(rng, runs=10, n=800):
    # an L route walked `runs` times: MoRPI, forward and smoothed paths that wander off it, the forward one widely
    cell = _Cell(0)
    cell.label = "morpi_l_shape s6 1 m MoRPI-G GC"
    s = np.linspace(0.0, 30.0, n)
    route = np.where(s[:, None] < 18.0, np.c_[s, 0 * s], np.c_[np.full(n, 18.0), 18.0 - s])
    t = np.linspace(0.0, 40.0, n)
    paths = []
    for _ in range(runs):
        walk = np.cumsum(rng.normal(0.0, 0.15, (n, 2)), axis=0)
        P = np.broadcast_to(np.eye(2) * 0.04, (n, 2, 2)) * (1 + t)[:, None, None]
        paths.append((t, route + 3 * walk, route + 0.3 * walk, route + walk, P))
    cell.paths = tuple(paths)
    cell.runs = tuple({"file": f"s6/morpi_l_shape/test/{k}.csv"} for k in range(runs))
    return cell, np.array([[0.0, 0.0], [18.0, 0.0], [18.0, -12.0]])


def test_aided_figures_are_placed_once_with_labels_titles_and_legends_on_the_canvas_apart():
    # the aided page's figures are placed from their labels' widths (no layout pass when drawn); everything is on
    # the canvas, and the legend outside the Axes (above the bars, under the paths' x label) and the title keep
    # clear of the Axes, their tick labels and each other; the log axis is labelled in plain text
    from matplotlib.layout_engine import PlaceHolderLayoutEngine  # a layout engine that does nothing

    rng = np.random.default_rng(5)
    cell, route = _aided_path_cell(rng)
    for ax in (plots.plot_aided_cells(_aided_cells(rng)), plots.plot_aided_paths(cell, route),
               plots.plot_aided_ellipses(cell, every_s=4.0)):
        fig = ax.figure
        assert fig.get_layout_engine() is None or isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine)
        assert _inside(fig)
        renderer = _drawn(fig)
        box = ax.get_window_extent(renderer)
        parts = {"x axis": ax.xaxis.get_tightbbox(renderer), "y axis": ax.yaxis.get_tightbbox(renderer)}
        if ax.get_title():
            parts["title"] = ax.title.get_window_extent(renderer)
            assert parts["title"].y0 >= box.y1
        if ax.get_legend() is not None:
            parts["legend"] = ax.get_legend().get_window_extent(renderer)
            assert not parts["legend"].overlaps(box)
        for i, a in enumerate(parts):
            for b in list(parts)[i + 1:]:
                if {a, b} != {"x axis", "y axis"}:                 # the axes' ticks meet at the corner
                    assert not parts[a].overlaps(parts[b]), (ax.get_title(), a, b)
        if ax.get_xscale() == "log":
            shown = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
            assert shown and all("$" not in t for t in shown)


def test_tables_figures_are_placed_once_with_panels_labels_and_titles_on_the_canvas_apart():
    # the tables page's figures are placed from their labels' widths (no layout pass when drawn): a recording's two
    # panels on a shared time axis, INS tracks hundreds of metres long (scaled freely and equally), and a grid of
    # path sets of fixed aspect with one cell unused; everything is on the canvas and no panel's tick labels, axis
    # labels or title reach into another's
    from matplotlib.layout_engine import PlaceHolderLayoutEngine  # a layout engine that does nothing

    rng = np.random.default_rng(6)
    t = 1000.0 + np.arange(2200) * 0.01
    f = np.c_[rng.normal(0.2, 0.4, 2200), rng.normal(0.0, 0.4, 2200), np.full(2200, 9.8)]
    omega = np.c_[rng.normal(0.0, 0.1, 2200), rng.normal(0.0, 0.1, 2200), np.sin(2 * np.pi * 0.5 * (t - t[0]))]
    recording = plots.plot_recording(t, f, omega, title="s8/short_distance/test/2.csv", rest=(t[0], t[300]),
                                     motion=(t[350], t[1700]), peaks=t[400:1700:100])
    s = np.linspace(0.0, 1.0, 300)[:, None]
    truth = np.array([[0.0, 0.0], [18.0, 0.0], [18.0, -10.0]])
    tracks = {"INS-3D RD": s * [-500.0, 390.0] + 40 * s ** 2, "INS-2D GAC": s * [170.0, 70.0]}
    figures = [recording] + [plots.plot_tracks(tracks, truth, title="INS on s6/L_line/2.csv (median 2D GAC run)",
                                               equal=equal).figure for equal in (False, True)]
    walk = lambda n, scale: np.cumsum(rng.normal(0.0, scale, (n, 2)), axis=0)   # noqa: E731
    panels = [{"title": f"morpi_l_shape s{6 + 2 * (i % 2)} 1.5 m", "truth": truth,
               "paths": {"MoRPI-A GC": [truth[-1] * np.linspace(0, 1, 200)[:, None] + walk(200, 0.2) for _ in range(8)],
                         "MoRPI-G GC": [walk(150, 1.5) for _ in range(8)]}} for i in range(5)]
    figures.append(plots.plot_path_sets(panels))
    for fig in figures:
        assert fig.get_layout_engine() is None or isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine)
        assert _inside(fig)
        renderer = _drawn(fig)
        shown = [ax for ax in fig.axes if ax.axison]
        boxes = [ax.get_tightbbox(renderer) for ax in shown]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not a.overlaps(b)
        for ax in shown:
            if ax.get_title():
                assert ax.title.get_window_extent(renderer).y0 >= ax.get_window_extent(renderer).y1
