"""Every figure of the package; the only module that imports matplotlib.

Other modules return data (dataclasses, arrays); the functions here draw it and
write PNG files atomically. matplotlib is imported lazily with the Agg backend,
so importing the package never needs a display.

The file is organised by report section, each under its own heading comment.
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["pyplot", "save", "assessment_figure"]


def pyplot():
    """Return ``matplotlib.pyplot`` with the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save(fig, path, dpi: int = 120) -> Path:
    """Save `fig` as PNG atomically and close it."""
    from .reporting import atomic_path

    path = Path(path)
    plt = pyplot()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


# ============================================================================ tables (field pipeline)
# Figures of reports/tables/: recordings, INS trajectories, MoRPI paths.


# ============================================================================ assessment (symbolic)
# The analytical assessment figure.

def assessment_figure(curves, path, title: str = "Analytical assessment of 3D & 2D INS vs. MoRPI-A distance error"):
    """Draw e_3D, e_2D and MoRPI-A distance error over time and save a PNG.

    Parameters
    ----------
    curves : morpi_filters.assessment.AssessmentCurves
        ``times`` (n,) [s], ``e3d``, ``e2d`` (n,) [m], ``morpi`` {dG: (n,)} [m].
    path : path-like
        PNG file to write (atomically).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
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
    return save(fig, path)


# ============================================================================ curves (filter covariance)
# Closed form, filter sigma, Monte Carlo RMS and field end-point errors on one axis.


# ============================================================================ montecarlo and drift
# Gain-error distributions and the closed-form vs strapdown drift map.
