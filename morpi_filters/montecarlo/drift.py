"""Drift: the closed-form position error against the strapdown's, over gyro bias and time."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..deprecation import renamed_keywords
from ..errors import ParameterError
from ..parallel import Progress, chunk_ranges, execute
from ..units import DEG_S, G0, MPU6500, SensorSpec
from .config import CHUNK_BYTES, DRIFT_SEED, child_seed
from .engine import check_runs, mechanizations, study_seed

# ----------------------------------------------------------------------------- drift: closed form vs strapdown

@dataclass(frozen=True)
class DriftMap:
    """Closed form against nonlinear strapdown, over gyro bias level and time.

    Attributes
    ----------
    gyro_bias : ndarray, shape (L,)
        Gyro bias levels, 1 sigma per axis [rad/s].
    time : ndarray, shape (m,)
        Times [s] (t > 0).
    rel_3d, rel_2d : ndarray, shape (L, m)
        Median over the draws of ``|dp_sim - dp_cf| / |dp_sim|`` (horizontal).
    p90_3d, p90_2d : ndarray, shape (L, m)
        90th percentile of the same.
    final_3d, final_2d : ndarray, shape (L, 2)
        Median final horizontal error [m]: (strapdown, closed form).
    accel_bias : float
        Accelerometer bias 1 sigma per axis [m/s^2].
    draws, seed : int
        Bias draws per level (shared by every level) and their seed.
    backends : dict
    """

    gyro_bias: np.ndarray
    time: np.ndarray
    rel_3d: np.ndarray
    rel_2d: np.ndarray
    p90_3d: np.ndarray
    p90_2d: np.ndarray
    final_3d: np.ndarray
    final_2d: np.ndarray
    accel_bias: float
    draws: int
    seed: int
    backends: dict = field(default_factory=dict)

    def onset(self, which: str = "INS-3D", level: float = 0.01) -> np.ndarray:
        """Time [s] from which the median disagreement stays above `level` to the end, per bias
        (NaN: below it at the end).

        Parameters
        ----------
        which : {"INS-3D", "INS-2D"}
            Which mechanization's disagreement (anything but ``"INS-3D"`` reads ``"INS-2D"``).
        level : float
            Relative disagreement threshold (0.01 is 1 %).

        Returns
        -------
        ndarray, shape (L,)
            One time per gyro bias level [s].
        """
        rel = self.rel_3d if which == "INS-3D" else self.rel_2d
        out = np.full(rel.shape[0], np.nan)
        for i, row in enumerate(rel):
            if row[-1] > level:
                below = np.flatnonzero(row <= level)
                out[i] = self.time[below[-1] + 1] if below.size else self.time[0]
        return out


def _closed_form_symbolic(ba, bg, t, g, kind):
    """Closed-form horizontal position error (z up, C = I, f^n = gravity, gyro-z terms kept).

    ba, bg: (R, 3) biases; t: (m,) times; kind "INS-3D" or "INS-2D". Returns (R, m, 2): the
    function of :func:`morpi_filters.symbolic.closed_form_errors` evaluated for every run at once
    (runs along axis 0, times along axis 1; elementwise, so each run's numbers are those of its
    own evaluation).
    """
    from .. import symbolic

    which = {"INS-3D": "INS-3D position", "INS-2D": "INS-2D position"}[kind]
    fn = symbolic.lambdified(which, "z_up", True)
    R = ba.shape[0]
    zero = np.zeros((R, 1))
    cols = fn(t[None, :], zero, zero, zero, *(ba[:, j:j + 1] for j in range(3)), *(bg[:, j:j + 1] for j in range(3)),
              float(g))
    return np.stack([np.broadcast_to(np.asarray(c, float), (R, t.size)) for c in cols[:2]], axis=2)


def _closed_form():
    return _closed_form_symbolic, "symbolic.lambdified (z_up, keep_bgz=True), every run at once"


@dataclass(frozen=True)
class _DriftPayload:
    levels: np.ndarray
    z: np.ndarray          # (draws, 6)
    time: np.ndarray       # (n,)
    keep: np.ndarray
    accel_bias: float
    g: float


def _drift_chunk(payload: _DriftPayload, a: int, b: int) -> dict:
    D = payload.z.shape[0]
    idx = np.arange(a, b)
    lev, d = idx // D, idx % D
    z = payload.z[d]
    ba = payload.accel_bias * z[:, :3]
    bg = payload.levels[lev][:, None] * z[:, 3:]
    t, keep, g = payload.time, payload.keep, payload.g
    R, n = b - a, t.size
    f = np.empty((R, n, 3))
    f[:] = ba[:, None, :]
    f[:, :, 2] += g
    w = np.empty((R, n, 3))
    w[:] = bg[:, None, :]
    ins3d, ins2d, _ = mechanizations()
    cf, _ = _closed_form()
    out = {}
    tk = t[keep]
    for kind, p in (("INS-3D", ins3d(t, f, w, g=g)), ("INS-2D", ins2d(t, f, w))):
        sim = p[:, keep, :2]
        cfv = cf(ba, bg, tk, g, kind)
        num = np.hypot(*(sim - cfv).transpose(2, 0, 1))
        den = np.hypot(*sim.transpose(2, 0, 1))
        out["rel_" + kind[-2:].lower()] = num / den
        out["end_" + kind[-2:].lower()] = np.stack([den[:, -1], np.hypot(*cfv[:, -1].T)], axis=1)
    return out


@renamed_keywords(duration="duration_s")
def drift_map(gyro_bias=None, *, spec: SensorSpec = MPU6500, duration_s: float = 15.0, rate_hz: float = 100.0,
              draws: int = 32, seed: int = DRIFT_SEED, keep_every: int = 10, chunk: int | None = None,
              scheduler=None, progress: bool | None = None) -> DriftMap:
    """Compare the closed-form and the strapdown position error of a stationary INS.

    Every level of `gyro_bias` uses the same `draws` bias draws (run d of the
    study: 3 accelerometer then 3 gyro standard normals from
    ``SeedSequence(seed).spawn(draws)[d]``), the gyro numbers scaled by the
    level and the accelerometer ones by ``spec.accel_bias``. The strapdown
    integrates the biased IMU at `rate_hz` (no noise); the closed form is the
    small-angle error polynomial of the 15-state model with C = I and
    f^n = (0, 0, g) [1], including the gyro-z terms.

    Parameters
    ----------
    gyro_bias : array_like, shape (L,), optional
        Gyro bias levels, 1 sigma per axis [rad/s]. Default: 25 levels from
        0.01 to 10 deg/s, log spaced.
    spec : SensorSpec
        Source of the accelerometer bias sigma.
    duration_s, rate_hz : float
        Length [s] and sampling rate [Hz].
    draws : int
        Bias draws per level.
    seed : int or numpy.random.Generator
        Their seed (a Generator gives it by one draw, as in :func:`run_study`;
        default :data:`DRIFT_SEED`, the seed of ``morpi drift``).
    keep_every : int
        Keep every k-th sample in time.
    chunk, scheduler, progress
        As in :func:`run_study` (results do not depend on them).

    Returns
    -------
    DriftMap
        Medians and 90th percentiles over the draws of the relative
        disagreement per level and kept time, and the median final errors.

    Raises
    ------
    ParameterError
        Bad levels, duration, rate, draw count, seed or chunk.

    Examples
    --------
    Over 2 s the two models agree to well below 1 % at 0.1 and 1 deg/s:

    >>> d = drift_map([0.1 * DEG_S, 1.0 * DEG_S], draws=4, duration_s=2.0)
    >>> d.rel_3d.shape, bool((d.rel_3d[:, -1] < 0.01).all()), d.onset("INS-3D").tolist()
    ((2, 20), True, [nan, nan])
    >>> bool(np.allclose(d.final_3d[:, 0], d.final_3d[:, 1], rtol=0.01))
    True
    """
    levels = np.logspace(-2, 1, 25) * DEG_S if gyro_bias is None else np.asarray(gyro_bias, float)
    if levels.ndim != 1 or levels.size == 0 or not np.all(np.isfinite(levels)) or (levels <= 0).any():
        raise ParameterError("gyro_bias: expected a 1-D list of finite levels > 0 [rad/s]")
    duration = duration_s
    if not (math.isfinite(duration) and duration > 0 and math.isfinite(rate_hz) and duration * rate_hz >= 2):
        raise ParameterError(f"duration_s/rate_hz: {duration!r} s at {rate_hz!r} Hz, expected at least 2 samples")
    seed = study_seed(seed)
    check_runs(draws, seed, chunk)
    n = int(round(duration * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    keep = np.unique(np.r_[np.arange(keep_every, n, keep_every), n - 1])
    z = np.stack([np.random.Generator(np.random.PCG64(child_seed(seed, d))).standard_normal(6)
                  for d in range(draws)])
    payload = _DriftPayload(levels, z, t, keep, float(spec.accel_bias), G0)
    total = levels.size * draws
    # a run of the strapdown holds about 40 floats per sample (its inputs, attitude matrices, increments,
    # derivative estimates, velocity and position): 43 measured at 58 runs per chunk, 36 at 465
    chunk = max(1, CHUNK_BYTES // (8 * 48 * n)) if chunk is None else int(chunk)
    prog = Progress(total, "drift study (gyro bias x time)", total > 1000 if progress is None else progress)
    parts = execute(_drift_chunk, payload, chunk_ranges(total, min(chunk, total)), scheduler=scheduler, progress=prog)
    cat = {k: np.concatenate([p[k] for p in parts]).reshape(levels.size, draws, *parts[0][k].shape[1:])
           for k in parts[0]}
    return DriftMap(
        gyro_bias=levels, time=t[keep],
        rel_3d=np.median(cat["rel_3d"], axis=1), rel_2d=np.median(cat["rel_2d"], axis=1),
        p90_3d=np.percentile(cat["rel_3d"], 90, axis=1), p90_2d=np.percentile(cat["rel_2d"], 90, axis=1),
        final_3d=np.median(cat["end_3d"], axis=1), final_2d=np.median(cat["end_2d"], axis=1),
        accel_bias=float(spec.accel_bias), draws=int(draws), seed=int(seed),
        backends={"strapdown": mechanizations()[2], "closed form": _closed_form()[1]})
