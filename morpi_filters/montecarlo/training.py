"""Training runs against gain error: how many training runs a Weinberg gain needs."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from .config import METHODS, GainError, StudyConfig
from .engine import run_studies, summarize

# ----------------------------------------------------------------------------- training runs vs gain error

@dataclass(frozen=True)
class TrainingStudy:
    """How the MoRPI error shrinks with the number k of training runs behind the gain.

    The gain is the mean of k per-run gains, each off by ``mismatch + spread * z_j``
    (a fraction of the true gain), so ``dG = mismatch + spread * mean(z_1..z_k)``,
    i.e. ``dG ~ N(mismatch, spread^2 / k)``.

    Attributes
    ----------
    k : ndarray, shape (K,)
        Numbers of training runs.
    mismatch, spread : float
        Motion mismatch between training and use, and per-run gain spread (fractions).
    rms_distance : ndarray, shape (K, 2)
        Monte Carlo RMS of the MoRPI-A / MoRPI-G distance error [m].
    rms_expected : ndarray, shape (K,)
        ``D * sqrt(mismatch^2 + spread^2 / k)`` [m] (gain term only).
    final : ndarray, shape (K, 2, 4)
        mean, std, median, p95 of the MoRPI-A / MoRPI-G final position error [m].
    digests : tuple of str
    distance : float
        D [m].
    """

    k: np.ndarray
    mismatch: float
    spread: float
    rms_distance: np.ndarray
    rms_expected: np.ndarray
    final: np.ndarray
    digests: tuple
    distance: float


def training_runs_study(ks, *, mismatch: float, spread: float, runs: int, seed: int,
                        config: StudyConfig | None = None, chunk=None, scheduler=None,
                        progress=None) -> TrainingStudy:
    """MoRPI-only studies with ``dG ~ N(mismatch, spread^2 / k)`` for each k in `ks`.

    Each k reuses the study seed, so the runs share their sensor draws and only
    the gain differs (common random numbers).

    Parameters
    ----------
    ks : sequence of int
        Numbers of training runs, each >= 1.
    mismatch : float
        Motion mismatch between training and use (fraction of the gain).
    spread : float
        Per-run gain spread, 1 sigma (fraction), >= 0.
    runs, seed, chunk, scheduler, progress
        As in :func:`run_study`.
    config : StudyConfig, optional
        Path and sensor (default :class:`StudyConfig`); its INS and gain
        scenarios are replaced.

    Returns
    -------
    TrainingStudy

    Examples
    --------
    >>> t = training_runs_study([1, 4], mismatch=0.0, spread=0.05, runs=20, seed=0,
    ...                         config=StudyConfig(training_runs=20))
    >>> round(float(t.rms_expected[0] / t.rms_expected[1]), 12)     # sqrt(4 / 1)
    2.0
    >>> t.rms_distance.shape, t.final.shape
    ((2, 2), (2, 2, 4))
    """
    base = StudyConfig() if config is None else config
    cfgs = training_configs(ks, mismatch=mismatch, spread=spread, config=base)
    results = run_studies(runs, seed, cfgs, chunk=chunk, scheduler=scheduler, progress=progress,
                          curves=(False,) * len(cfgs), label="montecarlo training-runs study")
    return training_summary(ks, results, mismatch=mismatch, spread=spread)


def training_configs(ks, *, mismatch: float, spread: float, config: StudyConfig | None = None) -> tuple:
    """The MoRPI-only study configs of :func:`training_runs_study`, one per k (for :func:`run_studies`).

    Parameters
    ----------
    ks : sequence of int
        Numbers of training runs, each >= 1.
    mismatch, spread : float
        As in :func:`training_runs_study`.
    config : StudyConfig, optional
        The base config (default :class:`StudyConfig`).

    Returns
    -------
    tuple of StudyConfig
        Copies of `config` with ``ins=False`` and one gain scenario
        ``GainError("k = <k>", mismatch, spread / sqrt(k))``.

    Raises
    ------
    ParameterError
        An empty `ks` or one below 1, a negative spread or a non-finite value.

    Examples
    --------
    >>> cfgs = training_configs([1, 4], mismatch=0.02, spread=0.1)
    >>> [(c.gains[0].label, c.gains[0].mean, c.gains[0].std, c.ins) for c in cfgs]
    [('k = 1', 0.02, 0.1, False), ('k = 4', 0.02, 0.05, False)]
    """
    ks = np.asarray(ks, int)
    if ks.ndim != 1 or ks.size == 0 or (ks < 1).any():
        raise ParameterError(f"ks: {ks.tolist()!r}, expected whole numbers >= 1")
    if not (math.isfinite(spread) and spread >= 0 and math.isfinite(mismatch)):
        raise ParameterError(f"spread/mismatch: {spread!r}/{mismatch!r}, expected finite, spread >= 0")
    base = StudyConfig() if config is None else config
    return tuple(replace(base, ins=False, gains=(GainError(f"k = {k}", mismatch, spread / math.sqrt(k)),))
                 for k in ks)


def training_summary(ks, results, *, mismatch: float, spread: float) -> TrainingStudy:
    """A :class:`TrainingStudy` from the results of the :func:`training_configs` studies.

    Parameters
    ----------
    ks : sequence of int
        The numbers of training runs given to :func:`training_configs`.
    results : sequence of StudyResult
        The studies of those configs, in the same order.
    mismatch, spread : float
        As given to :func:`training_configs`.

    Returns
    -------
    TrainingStudy

    Examples
    --------
    >>> ks = [2, 8]
    >>> cfgs = training_configs(ks, mismatch=0.0, spread=0.04, config=StudyConfig(training_runs=20))
    >>> t = training_summary(ks, run_studies(20, 1, cfgs), mismatch=0.0, spread=0.04)
    >>> t.k.tolist(), bool(np.allclose(t.rms_expected, t.distance * 0.04 / np.sqrt(ks)))
    ([2, 8], True)
    """
    ks = np.asarray(ks, int)
    rms, fin, dig = [], [], []
    D = results[0].distance
    for r in results:
        label = r.config.gains[0].label
        rms.append(np.sqrt(np.mean(r.distance_error[:, 0, :] ** 2, axis=0)))
        fin.append([[summarize(r.column(f"{m}[{label}]"))[q] for q in ("mean", "std", "median", "p95")]
                    for m in METHODS[2:]])
        dig.append(r.digest)
    return TrainingStudy(ks, float(mismatch), float(spread), np.array(rms),
                         D * np.sqrt(mismatch ** 2 + spread ** 2 / ks), np.array(fin), tuple(dig), float(D))
