"""Every figure of the package; the only module that imports matplotlib.

Other modules return data (dataclasses, arrays); the functions here draw it and
write PNG files atomically. matplotlib is imported lazily with the Agg backend,
so importing the package never needs a display.

The file is organised by report section, each under its own heading comment.
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["pyplot", "save", "assessment_figure", "plot_curves", "simulation_run"]


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

_CURVE_PANELS = (("ins3d", "3D INS"), ("ins2d", "2D INS"), ("morpi", "MoRPI-aided INS"))


def plot_curves(curves, path):
    """One figure per case: a panel per method, every error view on the same axes.

    Parameters
    ----------
    curves : curves.CaseCurves
    path : path
        PNG destination.
    """
    import numpy as np

    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharex=True)
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
    fig.tight_layout()
    return save(fig, path)


# ============================================================================ montecarlo and drift
# Gain-error distributions and the closed-form vs strapdown drift map.


# ============================================================================ simulation
# One simulated run: the true path against the INS, the periodic motion in f_y and omega_z,
# and the INS position error over time.

def simulation_run(truth, imu_data, solutions, path, *, title=None) -> Path:
    """Figure of one simulated run and its strapdown solutions.

    Parameters
    ----------
    truth : simulate.Trajectory
        The true motion sampled at the IMU times (``imu_data.truth``).
    imu_data : simulate.ImuData
        The synthesized readings of one run (unbatched).
    solutions : dict of str -> strapdown.InsResult
        INS solutions to draw, by label (e.g. ``"3D INS, noise-free"``).
    path : str or Path
        PNG file to write.
    title : str, optional
        Figure title.

    Returns
    -------
    Path
    """
    import numpy as np

    plt = pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
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
    fig.tight_layout()
    return save(fig, path)
