"""Every figure of the package; the only module that imports matplotlib.

Other modules return data (dataclasses, arrays); the functions here draw it and
write PNG files atomically. matplotlib is imported lazily with the Agg backend,
so importing the package never needs a display.

The file is organised by report section, each under its own heading comment.
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["pyplot", "save"]


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


# ============================================================================ curves (filter covariance)
# Closed form, filter sigma, Monte Carlo RMS and field end-point errors on one axis.


# ============================================================================ montecarlo and drift
# Gain-error distributions and the closed-form vs strapdown drift map.
