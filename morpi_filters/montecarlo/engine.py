"""The Monte Carlo engine: trajectories, the chunk kernel and its reductions, run_study and run_studies."""
from __future__ import annotations

import functools
import math
import threading
import time as _time
from dataclasses import dataclass

import numpy as np

from . import _batch_ins as bi
from ..deprecation import renamed_keywords
from ..errors import ParameterError
from ..parallel import Progress, chunk_ranges, execute
from ..steps import weinberg_length
from .config import (BAND_BINS_PER_DECADE, BAND_EDGES, BAND_PERCENTILES, CHUNK_BYTES, METHODS, N_HEAD,
                     TRAINING_KEY, StudyConfig, StudyResult, child_seed, digest, training_seed)

# ----------------------------------------------------------------------------- trajectories

@dataclass(frozen=True)
class _Path:
    """An exact trajectory sampled on `time` (private; see simulate.Trajectory)."""

    time: np.ndarray        # (n,)
    position: np.ndarray    # (n, 3)
    velocity: np.ndarray    # (n, 3)
    f_b: np.ndarray         # (n, 3)
    omega_b: np.ndarray     # (n, 3)
    psi: np.ndarray         # (n,) heading
    peaks: np.ndarray       # sample indices of period boundaries (lateral f_y maxima)


def _time_grid(cfg: StudyConfig) -> np.ndarray:
    n = sample_count(cfg.motion()[2], cfg.rate_hz)
    return np.arange(n) / cfg.rate_hz


@renamed_keywords(duration="duration_s")
def sample_count(duration_s: float, rate_hz: float) -> int:
    """Samples of a run from t = 0 until the first sample at or after `duration_s`.

    Parameters
    ----------
    duration_s : float
        The run's length [s].
    rate_hz : float
        The sample rate [Hz].

    Returns
    -------
    int
        ``ceil(duration_s * rate_hz) + 1`` (a product within 1e-9 of a whole number counts as it).
    """
    return int(math.ceil(duration_s * rate_hz - 1e-9)) + 1


def _as_path(traj, t: np.ndarray, peaks: np.ndarray) -> _Path:
    return _Path(t, traj.position, traj.velocity, traj.f_b, traj.omega_b, traj.heading, peaks)


@functools.lru_cache(maxsize=8)
def _paths_cached(length, speed, period, amplitude, duration, rate_hz, ins_path):
    from .. import simulate

    t = np.arange(sample_count(duration, rate_hz)) / rate_hz
    sn = simulate.sine(length, p2p_m=period, amplitude_m=amplitude, speed_mps=speed, rest_s=0.0, rate_hz=rate_hz)
    if abs(sn.end_time - duration) > 1e-9 * duration:
        raise ParameterError(f"StudyConfig: the sine path lasts {sn.end_time:.6g} s, expected {duration:.6g} s")
    sine = sn.at(t)
    if np.abs(sine.heading[0]) > 1e-12 or np.abs(sine.pitch).max() > 0:
        raise ParameterError("simulate.sine: expected a level path starting along x "
                             "(the INS kernel starts at C_bn = I)")
    # f_y maxima: the right-hand lateral extremes (centripetal acceleration to the left)
    pt = sn.peak_times[sn.peak_side < 0]
    peaks = np.unique(np.rint(pt * rate_hz).astype(int))
    sine = _as_path(sine, t, peaks)
    if ins_path == "sine":
        return sine, sine
    st = simulate.straight(length, speed_mps=speed, rest_s=0.0, rate_hz=rate_hz).at(t)
    return _as_path(st, t, np.array([0, t.size - 1])), sine


def _paths(cfg: StudyConfig):
    """(path of the INS, sine path of MoRPI, backend name) sampled on the study's time grid."""
    L, v, T = cfg.motion()
    ins, sn = _paths_cached(L, v, cfg.p2p_m, cfg.amplitude_m, T, cfg.rate_hz, cfg.ins_path)
    return ins, sn, f"simulate.sine / simulate.{cfg.ins_path} (rest 0 s, sampled on the study grid)"


# ----------------------------------------------------------------------------- mechanizations

def mechanizations():
    """The batched strapdown mechanizations the engine runs.

    Returns
    -------
    tuple
        ``(ins3d, ins2d, name)``: two callables returning positions of shape
        (R, n, 3) for R runs, and the name the page shows for them.
    """
    from .. import strapdown

    return (lambda *a, **k: strapdown.ins3d(*a, **k).position,
            lambda *a, **k: strapdown.ins2d(*a, **k).position,
            "strapdown.ins3d / strapdown.ins2d")


# ----------------------------------------------------------------------------- MoRPI

def _weinberg_sums(sig: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """(max - min)^(1/4) of `sig` (R, n) over each peak-to-peak window (inclusive): (R, K)."""
    K = peaks.size - 1
    out = np.empty((sig.shape[0], K))
    for j in range(K):
        w = sig[:, peaks[j]:peaks[j + 1] + 1]
        out[:, j] = weinberg_length(w.max(axis=1), w.min(axis=1), 1.0)
    return out


def _chord_sum(path: _Path) -> float:
    """True distance D covered by the Weinberg steps: sum of the peak-to-peak chords [m]."""
    return float(np.linalg.norm(np.diff(path.position[path.peaks, :2], axis=0), axis=1).sum())


def reference_gains(cfg: StudyConfig, seed: int):
    """Train the MoRPI-A and MoRPI-G reference gains on noisy runs of the sine path.

    Each training run gives ``G_j = D / sum_k df_k`` (D: true peak-to-peak
    distance, df_k: Weinberg term of step k); the reference gain is the mean of
    the G_j, as in the paper's gain calculation [1]. The runs draw from one
    Generator seeded with :func:`training_seed` of the study seed, in blocks of
    500 runs (a larger training set extends a smaller one's draws).

    Parameters
    ----------
    cfg : StudyConfig
        Sensor, path, rate and ``training_runs`` of the training set.
    seed : int
        Study seed (>= 0).

    Returns
    -------
    gains : tuple of float
        (G_A [m/(m/s^2)^(1/4)], G_G [m/(rad/s)^(1/4)]).
    cv : tuple of float
        Coefficient of variation of the per-run gains (spread / mean).

    Examples
    --------
    >>> (ga, gg), (cv_a, cv_g) = reference_gains(StudyConfig(training_runs=20), seed=0)
    >>> bool(ga > 0 and gg > 0 and cv_a < 0.01 and cv_g < 0.01)
    True
    >>> reference_gains(StudyConfig(training_runs=20), seed=0) == ((ga, gg), (cv_a, cv_g))   # the same seed
    True
    >>> reference_gains(StudyConfig(training_runs=20), seed=1) == ((ga, gg), (cv_a, cv_g))   # another seed
    False
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0")
    L, v, _ = cfg.motion()
    return _reference_gains(cfg.spec, L, v, cfg.p2p_m, cfg.amplitude_m, cfg.rate_hz, cfg.training_runs, int(seed))


@functools.lru_cache(maxsize=16)
def _reference_gains(spec, length_m, speed_mps, p2p_m, amplitude_m, rate_hz, training_runs, seed):
    cfg = StudyConfig(spec=spec, length_m=length_m, speed_mps=speed_mps, p2p_m=p2p_m, amplitude_m=amplitude_m,
                      rate_hz=rate_hz, training_runs=training_runs)
    _, sine, _ = _paths(cfg)
    rng = np.random.Generator(np.random.PCG64(training_seed(seed)))
    sa = cfg.spec.accel_noise * math.sqrt(cfg.rate_hz)
    sg = cfg.spec.gyro_noise * math.sqrt(cfg.rate_hz)
    D = _chord_sum(sine)
    M = cfg.training_runs
    ga, gg = np.empty(M), np.empty(M)
    # the Weinberg windows span the first to the last peak: only those samples of the signals are formed,
    # in two buffers kept over the blocks of 500 runs
    lo, hi = sine.peaks[0], sine.peaks[-1] + 1
    z = np.empty((min(500, M), 2, sine.time.size))
    sig = np.empty((min(500, M), hi - lo))
    for a in range(0, M, 500):
        m = min(500, M - a)
        rng.standard_normal(out=z[:m])
        for c, sd, true, g in ((0, sa, sine.f_b[lo:hi, 1], ga), (1, sg, sine.omega_b[lo:hi, 2], gg)):
            np.multiply(z[:m, c, lo:hi], sd, out=sig[:m])       # the measured signal: true + sd z
            sig[:m] += true
            g[a:a + m] = D / _weinberg_sums(sig[:m], sine.peaks - lo).sum(axis=1)
    return (float(ga.mean()), float(gg.mean())), (float(ga.std(ddof=1) / ga.mean()), float(gg.std(ddof=1) / gg.mean()))


# ----------------------------------------------------------------------------- the chunk kernel

@dataclass(frozen=True)
class _Payload:
    configs: tuple          # StudyConfig of each study; they share the draws and the paths
    seed: int
    ins_path: _Path         # the path INS-3D and INS-2D drive
    ins_heading: np.ndarray | None   # its heading integrated by the kernel's rule (None: straight)
    ins_truth: tuple        # ((x, y) 3D, (x, y) 2D) of the kernels on its true signals, at `keep`
    sine: _Path
    gain_ref: tuple
    keep: np.ndarray
    series: bool            # return the per-run error series too
    curves: tuple           # per study: whether its error series are reduced (RMS, histogram counts)


#: Scratch arrays of the chunk kernel, per thread, kept from one chunk to the next (see :func:`_scratch`).
_SCRATCH = threading.local()

#: Whether :func:`_keep_freed_memory` has run in this process.
_MALLOC_TUNED = False


def _on_dask_worker() -> bool:
    """Whether this code runs inside a Dask worker (a process the study's scheduler owns)."""
    import sys

    if "distributed" not in sys.modules:
        return False
    from distributed import get_worker

    try:
        get_worker()
    except ValueError:
        return False
    return True


def _keep_freed_memory() -> None:
    """Ask the C library's allocator to keep freed memory for reuse (glibc; once per process).

    A chunk allocates and frees many numpy temporaries of 0.1 to 6 MB. With
    glibc's default thresholds, in a process that has not yet freed a larger
    block (a fresh Dask worker), each of them is mapped and unmapped, or the
    heap grown and trimmed again, so the system maps and zeroes that memory
    every time: measured 64,000 page faults and 1.8 times the CPU of a chunk
    in a fresh worker. Fixing the mmap threshold at 32 MB and the trim
    threshold at 256 MB keeps such blocks in the heap. Nothing happens where
    the allocator is not glibc's. Called in Dask worker processes only: a
    library does not change the allocator of the process that imports it.
    """
    global _MALLOC_TUNED
    if _MALLOC_TUNED:
        return
    _MALLOC_TUNED = True
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 32 * 2**20)     # M_MMAP_THRESHOLD
        libc.mallopt(-1, 256 * 2**20)    # M_TRIM_THRESHOLD
    except (OSError, AttributeError):    # not glibc: its own allocator, left as it is
        pass


def _scratch(name: str, shape: tuple) -> np.ndarray:
    """A scratch array of this thread (uninitialised), reused by the next chunk of the same shape.

    The chunk kernel's large planes (the draws, the noise, the measured
    signals) are tens of MB each; allocating them afresh for every chunk makes
    the system map and zero that memory again each time. Nothing returned by a
    chunk may be a view of a scratch array.
    """
    cache = getattr(_SCRATCH, "arrays", None)
    if cache is None:
        cache = _SCRATCH.arrays = {}
    a = cache.get(name)
    if a is None or a.shape != shape:
        cache[name] = None
        a = cache[name] = np.empty(shape)
    return a


def _release_scratch() -> None:
    """Free this thread's scratch arrays (the end of a study)."""
    _SCRATCH.arrays = {}


def _draw(seed: int, a: int, b: int, n: int, out: np.ndarray | None = None) -> np.ndarray:
    """Per-run draws of runs a..b-1: (b - a, 7 + 6 n) standard normals, each from its own Generator."""
    z = np.empty((b - a, N_HEAD + 6 * n)) if out is None else out
    for r in range(a, b):
        np.random.Generator(np.random.PCG64(child_seed(seed, r))).standard_normal(out=z[r - a])
    return z


def _chunk(payload: _Payload, a: int, b: int) -> tuple:
    """Runs a..b-1 of every study of the payload from one draw of their random numbers.

    The studies differ only in the calibration (which scales the same bias
    numbers), the gain scenarios and whether the INS runs. The noise planes
    are built once; each calibration adds its biases to them once (into the
    draws' buffer, free once the noise is built, and the last calibration in
    place, the noise being needed no more), and those measurement errors
    serve all its studies. Returns the runs' gain draws (``{"gain_draw": z}``,
    shared by every study: each forms its gain errors from them) and one dict
    per study: per-run final errors and distance errors, and, for a study
    whose curves are kept, the chunk's reductions of the error series (sum of
    squares and histogram counts per epoch), plus the series themselves when
    ``payload.series``.
    """
    if _on_dask_worker():
        _keep_freed_memory()
    cfg0, sine = payload.configs[0], payload.sine
    n = sine.time.size
    h = 1.0 / cfg0.rate_hz
    R = b - a
    z = _draw(payload.seed, a, b, n, out=_scratch("draws", (R, N_HEAD + 6 * n)))
    zg = z[:, 6].copy()
    head = z[:, :6].copy()
    sa, sg = cfg0.spec.accel_noise * math.sqrt(cfg0.rate_hz), cfg0.spec.gyro_noise * math.sqrt(cfg0.rate_hz)
    # time-major planes (6, n, R) of the white noise at the discrete sigma (accelerometer xyz, gyro xyz)
    noise = _scratch("noise", (6, n, R))
    zr = z[:, N_HEAD:].reshape(R, 6, n)
    for c in range(6):
        # a plain copy transposes faster than a multiply reading the transposed planes
        noise[c] = zr[:, c, :].T
        noise[c] *= sa if c < 3 else sg
    spare = z.reshape(-1)[:6 * n * R].reshape(6, n, R)     # the draws' buffer, free from here on
    del z, zr
    psi = _scratch("psi", (n, R))
    keep = payload.keep
    out = [None] * len(payload.configs)
    cals = list(dict.fromkeys(c.calibration for c in payload.configs))
    for cal in cals:
        members = [i for i, c in enumerate(payload.configs) if c.calibration == cal]
        cfg = payload.configs[members[0]]
        sig_ba, sig_bg = cfg.bias_sigmas()
        # the measured errors: white noise + bias (the biases as contiguous rows, one per channel); the last
        # calibration writes them over the noise planes
        bias = np.concatenate([sig_ba * head[:, 0:3], sig_bg * head[:, 3:6]], axis=1).T.copy()
        err = noise if cal == cals[-1] else spare
        for c in range(6):
            np.add(noise[c], bias[c], out=err[c])
        _heading_error(err[5], h, psi)
        # MoRPI on the sine path: Weinberg terms from the measured signals (constant biases cancel in
        # max - min); heading = true heading + integrated gyro-z error.
        pk = sine.peaks
        dfa = _weinberg_terms(err[1], sine.f_b[:, 1], pk)          # (R, K)
        dfg = _weinberg_terms(err[5], sine.omega_b[:, 2], pk)
        hd = (psi[pk[1:]] + sine.psi[pk[1:], None]).T                # (R, K) heading at each step's end peak
        trig = (np.cos(hd), np.sin(hd))
        ins_e = None
        if any(payload.configs[i].ins for i in members):
            ins_e = _ins_errors(payload, err, psi, h, keep)
        for i in members:
            out[i] = _study_chunk(payload, payload.configs[i], ins_e, dfa, dfg, trig, zg, R, payload.curves[i])
    return {"gain_draw": zg}, out


def _heading_error(w, h, out, block: int = 64):
    """Heading error integrated from the gyro-z error `w` (n, R) by the trapezoid rule, into `out` (n, R).

    ``psi_k = h (sum_{i<k} w_i + (w_k - w_0) / 2)``, formed as
    ``((P_k + w_k / 2) - w_0 / 2) h`` with ``P_k = sum_{i<k} w_i`` by
    :func:`_batch_ins.prefix_rows`; block by block of `block`
    rows, each finished while it is in cache (the same operations as over
    the whole array in turn).
    """
    n, R = w.shape
    w0 = 0.5 * w[0]
    half = np.empty((block, R))
    last = np.zeros(R)                      # P of the row before the block
    first = np.empty(R)
    for r0 in range(0, n, block):
        r1 = min(r0 + block, n)
        p = bi.prefix_rows(w[r0:r1 - 1], out[r0:r1], start=np.add(last, w[r0 - 1], out=first) if r0 else None)
        last[...] = p[-1]
        p += np.multiply(w[r0:r1], 0.5, out=half[:r1 - r0])
        p -= w0
        p *= h
    return out


def _ins_errors(payload, err, psi, h, keep):
    """INS-3D and INS-2D horizontal errors (R, m) on the INS path from rest.

    The measured signals are the true ones of the path plus `err`; both go
    through the same integration rules (the truth once, in
    :func:`_ins_truth`), so the difference is the error the sensor errors
    cause. Overwrites `err` with the measured signals, and then with the
    four horizontal accelerations, which take the planes of the signals
    already consumed: the 3D x and y those of the x and y rates (the kernel
    reads each sample's rates before it writes the sample's accelerations),
    the 2D x and y those of f_z and the z rate (not read by the 2D kernel).
    Planes 2 to 5 of `err` are then integrated twice in one call (the
    integration is elementwise over its columns).
    """
    path = payload.ins_path
    for c in range(3):
        err[c] += path.f_b[:, c, None]
        if path.omega_b[:, c].any():
            err[3 + c] += path.omega_b[:, c, None]
    f, w = [err[0], err[1], err[2]], [err[3], err[4], err[5]]
    bi.horizontal_accel_3d(h, f, w, err[3], err[4])
    bi.horizontal_accel_2d(f, psi, err[2], err[5], heading=payload.ins_heading)
    del f, w
    # columns: 2D x, 3D x, 3D y, 2D y
    pos = bi.double_integral_at(err[2:].transpose(1, 0, 2), h, keep)
    (x3, y3), (x2, y2) = payload.ins_truth
    return [np.hypot(pos[:, 1] - x3, pos[:, 2] - y3).T, np.hypot(pos[:, 0] - x2, pos[:, 3] - y2).T]


def _ins_truth(path: _Path, h: float, keep: np.ndarray):
    """(trapezoid heading (n,) or None, ((x, y) of the 3D kernel, (x, y) of the 2D kernel)) on the true signals."""
    f = [path.f_b[:, c, None].copy() for c in range(3)]
    w = [path.omega_b[:, c, None].copy() for c in range(3)]
    heading = None
    if path.omega_b[:, 2].any():
        wz = path.omega_b[:, 2]
        heading = np.concatenate([[0.0], np.cumsum(0.5 * h * (wz[1:] + wz[:-1]))])
    zero = np.zeros((path.time.size, 1))
    return heading, (bi.horizontal_3d(h, f, w, keep), bi.horizontal_2d(f, zero, h, keep, heading=heading))


def _study_chunk(payload, cfg, ins_e, dfa, dfg, trig, zg, R, curves) -> dict:
    """One study's part of a chunk: finals and distance errors, and (`curves`) series reductions."""
    sine, keep = payload.sine, payload.keep
    pk = sine.peaks
    cps, sps = trig
    S = len(cfg.gains)
    series = np.full((R, keep.size, 4), np.nan) if payload.series else None
    final = np.full((R, 2 + 2 * S), np.nan)
    if cfg.ins:
        for j, e in enumerate(ins_e):
            if series is not None:
                series[:, :, j] = e
            final[:, j] = e[:, -1]
    truth = sine.position[pk, :2] - sine.position[pk[0], :2]   # (K+1, 2)
    D = _chord_sum(sine)
    steps_done = np.clip(np.searchsorted(pk, keep, side="right") - 1, 0, None)   # 0 before the first peak
    dist = np.empty((R, S, 2))
    morpi = []                                                  # (R, K+1) MoRPI errors after 0..K steps
    for s_i, gain in enumerate(cfg.gains):
        scale = 1.0 + gain.errors(zg)[:, None]
        for m, (df, G) in enumerate(((dfa, payload.gain_ref[0]), (dfg, payload.gain_ref[1]))):
            st = (G * scale) * df                           # (R, K) step lengths
            x = np.cumsum(st * cps, axis=1)
            y = np.cumsum(st * sps, axis=1)
            e = np.hypot(x - truth[1:, 0], y - truth[1:, 1])   # (R, K)
            final[:, 2 + 2 * s_i + m] = e[:, -1]
            dist[:, s_i, m] = st.sum(axis=1) - D
            if s_i == 0 and (curves or series is not None):
                e0 = np.concatenate([np.zeros((R, 1)), e], axis=1)
                morpi.append(e0)
                if series is not None:
                    series[:, :, 2 + m] = e0[:, steps_done]
    part = {"final": final, "dist": dist}
    if curves and series is not None:
        part.update(sumsq=np.nansum(series * series, axis=0), count=np.isfinite(series).sum(axis=0),
                    hist=_band_counts(series))
    elif curves:
        part.update(_curve_reductions(ins_e if cfg.ins else None, morpi, steps_done, R))
    if series is not None:
        part["series"] = series
    return part


def _curve_reductions(ins_e, morpi, steps_done, R) -> dict:
    """``sumsq``, ``count`` and ``hist`` of the error series (R, m, 4) without building it.

    The same numbers as ``np.nansum(series ** 2, axis=0)``, ``np.isfinite(series).sum(axis=0)``
    and :func:`_band_counts` of the series: column by column, each sum over the
    runs in run order. A MoRPI column changes only at a step, so its sums and
    histograms are those of its K + 1 values (after 0..K steps), repeated over
    the epochs that have taken as many steps.
    """
    m = steps_done.size
    nb = BAND_EDGES.size - 1
    sumsq = np.zeros((m, 4))
    count = np.zeros((m, 4), np.int64)
    hist = np.zeros((m, 4, nb), np.int64)
    cols = [] if ins_e is None else [(j, e, None) for j, e in enumerate(ins_e)]
    cols += [(2 + j, e0, steps_done) for j, e0 in enumerate(morpi)]
    for j, e, rows in cols:
        sq = np.multiply(e, e, out=np.empty(e.shape))          # C order: the sum over axis 0 goes run by run
        ok = np.isfinite(e)
        sq[np.isnan(sq)] = 0.0
        s, c = np.add.reduce(sq, axis=0), ok.sum(axis=0)
        x = e[ok]
        k = np.broadcast_to(np.arange(e.shape[1]), e.shape)[ok]
        h = np.bincount(k * nb + _band_bins(x), minlength=e.shape[1] * nb).reshape(e.shape[1], nb)
        if rows is None:
            sumsq[:, j], count[:, j], hist[:, j] = s, c, h
        else:
            sumsq[:, j], count[:, j], hist[:, j] = s[rows], c[rows], h[rows]
    cells = np.flatnonzero(hist)
    return {"sumsq": sumsq, "count": count, "hist": (cells.astype(np.int32), hist.reshape(-1)[cells].astype(np.int32))}


def _band_counts(series) -> tuple:
    """Histogram of series (R, m, k) over :data:`BAND_EDGES` (NaN left out), sparse.

    Returns ``(cells, counts)``: the occupied cells of the (m, k, bins)
    histogram as flat indices (int32) and their counts (int32). A chunk's runs
    occupy a few bins per epoch, so this is far smaller than the dense array
    (which matters when chunks travel back from Dask workers).
    """
    R, m, k = series.shape
    nb = BAND_EDGES.size - 1
    ok = np.isfinite(series)
    idx = _band_bins(series[ok])
    flat = np.broadcast_to(((np.arange(m)[:, None] * k + np.arange(k)[None, :]) * nb)[None], series.shape)[ok] + idx
    dense = np.bincount(flat, minlength=m * k * nb)
    cells = np.flatnonzero(dense)
    return cells.astype(np.int32), dense[cells].astype(np.int32)


def _band_bins(x) -> np.ndarray:
    """Bin of each finite value of `x` among :data:`BAND_EDGES` (int64): ``edges[i] <= x < edges[i + 1]``.

    Values below 0 go to the first bin and values at or above the last edge to the last one.
    """
    nb = BAND_EDGES.size - 1
    # bin from the logarithm (the edges are log-spaced), then corrected against the edges themselves
    lo = BAND_EDGES[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        idx = np.floor(np.log10(np.maximum(x, lo) / lo) * BAND_BINS_PER_DECADE).astype(np.int64) + 1
    idx[x < lo] = 0
    np.clip(idx, 0, nb - 1, out=idx)
    idx -= x < BAND_EDGES[idx]
    idx += (x >= BAND_EDGES[idx + 1]) & (idx < nb - 1)
    return idx


def band_quantiles(counts, q=BAND_PERCENTILES) -> np.ndarray:
    """Percentiles from histogram counts over :data:`BAND_EDGES`.

    The bins are the first one from 0 to ``BAND_RANGE_M[0]`` and then
    ``10 * BAND_BINS_PER_DECADE`` log-spaced ones up to ``BAND_RANGE_M[1]``
    (401 in all) [m].

    Parameters
    ----------
    counts : ndarray, shape (..., 401)
        Counts per bin.
    q : sequence of float
        Percentiles in [0, 100].

    Returns
    -------
    ndarray, shape (..., len(q))
        Interpolated geometrically inside a bin (linearly in the first bin,
        which starts at 0); NaN where the counts are all zero.

    Examples
    --------
    Everything in the first bin (0 to 1 um) reads linearly; nothing at all is NaN:

    >>> counts = np.zeros((2, 401))
    >>> counts[0, 0] = 10
    >>> (band_quantiles(counts, q=(50.0, 100.0)) * 1e6).round(9).tolist()
    [[0.5, 1.0], [nan, nan]]

    Everything in the bin from 1 to ``10 ** (1 / 40)`` m reads geometrically:

    >>> one = np.zeros(401)
    >>> one[241] = 4
    >>> round(float(band_quantiles(one, q=(50.0,))[0]), 12) == round(10 ** (1 / 80), 12)
    True
    """
    counts = np.asarray(counts, float)
    cum = np.cumsum(counts, axis=-1)
    total = cum[..., -1:]
    out = []
    lo_e, hi_e = BAND_EDGES[:-1], BAND_EDGES[1:]
    for p in q:
        target = p / 100.0 * total
        j = np.minimum((cum < target).sum(axis=-1, keepdims=True), counts.shape[-1] - 1)
        before = np.take_along_axis(cum, j, axis=-1) - np.take_along_axis(counts, j, axis=-1)
        inbin = np.take_along_axis(counts, j, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.clip(np.where(inbin > 0, (target - before) / inbin, 0.0), 0.0, 1.0)
        lo, hi = lo_e[j], hi_e[j]
        val = np.where(lo > 0, lo * (hi / np.where(lo > 0, lo, 1.0)) ** frac, hi * frac)
        out.append(np.where(total > 0, val, np.nan)[..., 0])
    return np.stack(out, axis=-1)


def _weinberg_terms(err, true, peaks):
    """(max - min)^(1/4) of ``true[:, None] + err`` over each peak-to-peak window (inclusive).

    err: (n, R) time-major measurement errors; true: (n,) true signal. Returns (R, K).
    """
    K = peaks.size - 1
    out = np.empty((err.shape[1], K))
    for j in range(K):
        win = err[peaks[j]:peaks[j + 1] + 1] + true[peaks[j]:peaks[j + 1] + 1, None]
        out[:, j] = weinberg_length(win.max(axis=0), win.min(axis=0), 1.0)
    return out


# ----------------------------------------------------------------------------- the engine

def default_chunk(n: int) -> int:
    """Runs per chunk when none is given: as many as keep a chunk's arrays near :data:`CHUNK_BYTES`.

    Parameters
    ----------
    n : int
        Samples per run.

    Returns
    -------
    int
        At least 1.
    """
    return max(1, CHUNK_BYTES // (8 * (N_HEAD + 6 * n)))


def study_seed(seed) -> int:
    """A study seed from an int, or drawn once from a numpy Generator (``rng``).

    Parameters
    ----------
    seed : int or numpy.random.Generator
        A whole number >= 0, or a Generator one draw is taken from.

    Returns
    -------
    int
        The study's seed.
    """
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**63))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0 or a numpy.random.Generator")
    return int(seed)


def check_runs(runs, seed, chunk) -> None:
    """Refuse a run count, seed or chunk size a study cannot take (a ParameterError naming it).

    Parameters
    ----------
    runs : int
        Runs, 1 to :data:`TRAINING_KEY`.
    seed : int
        Seed, >= 0.
    chunk : int or None
        Runs per chunk, >= 1, or None.

    Returns
    -------
    None
    """
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or not 1 <= runs <= TRAINING_KEY:
        raise ParameterError(f"runs: {runs!r}, expected a whole number from 1 to {TRAINING_KEY}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise ParameterError(f"chunk: {chunk!r}, expected a whole number >= 1")


#: StudyConfig fields that fix the draws and the paths: the studies of one
#: :func:`run_studies` call must agree on them.
_SHARED_FIELDS = ("spec", "duration_s", "rate_hz", "length_m", "speed_mps", "p2p_m", "amplitude_m", "ins_path",
                  "keep_every", "training_runs", "cal_window_s")


def run_study(runs: int, seed: int, config: StudyConfig | None = None, *, chunk: int | None = None,
              workers: int = 1, scheduler=None, progress: bool | None = None, series: bool = False) -> StudyResult:
    """Run a seeded gain-error Monte Carlo study.

    Parameters
    ----------
    runs : int
        Number of runs N (axis 0 of every output).
    seed : int or numpy.random.Generator
        Study seed; run i uses ``SeedSequence(seed).spawn(N)[i]``. A
        Generator (``rng``) gives the seed by one draw of ``rng.integers(0, 2**63)``.
    config : StudyConfig, optional
        What to simulate (default: a :class:`StudyConfig` with its defaults).
    chunk : int, optional
        Runs per batch (bounds memory; results do not depend on it). Default:
        as many as fit a 32 MiB noise block.
    workers : int
        Local threads running chunks (results do not depend on it).
    scheduler : str or distributed.Client, optional
        Run the chunks on this Dask cluster instead (results identical).
    progress : bool, optional
        Progress on stderr; default on when the study has more than 1000 runs.
    series : bool
        Keep every run's error series (:attr:`StudyResult.errors`, 8 bytes x
        runs x epochs x 4); by default only their reductions are kept.

    Returns
    -------
    StudyResult
        With the config resolved (:meth:`StudyConfig.resolved`), the final
        errors of every method and scenario, the per-epoch RMS and bands, the
        distance errors, the applied gain errors and the digest.

    Raises
    ------
    ParameterError
        A bad run count, seed, chunk or config.

    Examples
    --------
    A MoRPI-only study with a 5 % gain error: the distance error is about
    5 % of the distance, and the numbers do not depend on the chunk size.

    >>> from morpi_filters.montecarlo import GainError, StudyConfig
    >>> cfg = StudyConfig(training_runs=20, ins=False, gains=(GainError("dG = 5 %", 0.05),))
    >>> r = run_study(40, 3, cfg)
    >>> r.columns
    ('INS-3D', 'INS-2D', 'MoRPI-A[dG = 5 %]', 'MoRPI-G[dG = 5 %]')
    >>> r.final.shape, r.rms.shape == (r.time.size, 4), r.errors is None
    ((40, 4), True, True)
    >>> round(float(r.distance_error_of("MoRPI-G").mean() / r.distance), 2)
    0.05
    >>> run_study(40, 3, cfg, chunk=7).digest == r.digest
    True
    """
    return run_studies(runs, seed, (StudyConfig() if config is None else config,), chunk=chunk, workers=workers,
                       scheduler=scheduler, progress=progress, series=series)[0]


def run_studies(runs: int, seed: int, configs, *, chunk: int | None = None, workers: int = 1, scheduler=None,
                progress: bool | None = None, series: bool = False, curves=None,
                label: str = "montecarlo gain-error study") -> tuple:
    """Several gain-error studies over one pass of the same random numbers.

    The studies may differ in calibration, gain scenarios and whether the
    INS runs; everything that fixes the draws and the paths (sensor, duration,
    rate, path, kept epochs, training runs, calibration window) must be the
    same. Each run's numbers are drawn once and serve every study, and every
    study's result is identical, bit for bit, to what :func:`run_study` gives
    for it alone with the same seed. Chunks are reduced as they finish, so
    memory grows with the runs only by the per-run final and distance errors
    (8 bytes x (2 + 4 x scenarios) per run and study) and the runs' gain
    draws (8 bytes per run, shared by the studies), not by the error series
    (unless `series`).

    Parameters
    ----------
    runs, seed, chunk, workers, scheduler, progress, series
        As in :func:`run_study`.
    configs : sequence of StudyConfig
        The studies; they must agree on the fields that fix the draws and paths.
    curves : sequence of bool, optional
        Per study, whether to reduce its error series to :attr:`StudyResult.rms`
        and :attr:`StudyResult.bands` (default: every study). A study left out
        has ``rms`` and ``bands`` None and costs only its per-run final, gain
        and distance errors; `series` keeps the curves of every study.
    label : str
        Name of the progress line.

    Returns
    -------
    tuple of StudyResult
        One per config, in order.

    Raises
    ------
    ParameterError
        An empty or invalid config list, configs that differ in a shared
        field, or a bad run count, seed or chunk.

    Examples
    --------
    >>> from dataclasses import replace
    >>> from morpi_filters.montecarlo import StudyConfig
    >>> raw = StudyConfig(training_runs=20, ins=False)
    >>> gac = replace(raw, calibration="GAC")
    >>> both = run_studies(20, 5, (raw, gac))
    >>> [r.config.calibration for r in both], both[1].digest == run_study(20, 5, gac).digest
    (['RD', 'GAC'], True)
    """
    t0 = _time.perf_counter()
    configs = tuple(configs)
    if not configs or not all(isinstance(c, StudyConfig) for c in configs):
        raise ParameterError("configs: expected a non-empty sequence of StudyConfig")
    for c in configs:
        c.validate()
    configs = tuple(c.resolved() for c in configs)
    for c in configs:
        for name in _SHARED_FIELDS:
            if getattr(c, name) != getattr(configs[0], name):
                raise ParameterError(f"configs: StudyConfig.{name} differs between studies of one pass "
                                     f"({getattr(configs[0], name)!r} and {getattr(c, name)!r}); run them separately")
    seed = study_seed(seed)
    check_runs(runs, seed, chunk)
    runs = int(runs)
    curves = (True,) * len(configs) if curves is None or series else tuple(bool(c) for c in curves)
    if len(curves) != len(configs):
        raise ParameterError(f"curves: {len(curves)} values for {len(configs)} studies; expected one per study")
    cfg = configs[0]
    ins_path, sine, traj_backend = _paths(cfg)
    if sine.peaks.size < 2:
        raise ParameterError("StudyConfig: the sine path has fewer than two period boundaries")
    n = sine.time.size
    keep = np.unique(np.r_[np.arange(0, n, cfg.keep_every), n - 1])
    gain_ref, cv = reference_gains(cfg, seed)
    ins_heading, ins_truth = _ins_truth(ins_path, 1.0 / cfg.rate_hz, keep)
    payload = _Payload(configs, seed, ins_path, ins_heading, ins_truth, sine, gain_ref, keep, bool(series), curves)
    chunk = default_chunk(n) if chunk is None else int(chunk)
    ranges = chunk_ranges(runs, min(chunk, runs))
    prog = Progress(runs, label, runs > 1000 if progress is None else progress)
    acc = [_Reduction(runs) for _ in configs]
    draws = _Reduction(runs)            # the gain draws, shared by every study (each forms its dG from them)
    try:
        execute(_chunk, payload, ranges, workers=workers, scheduler=scheduler, progress=prog,
                reduce=lambda res: (draws.add(res[0]), [r.add(p) for r, p in zip(acc, res[1])]))
    finally:
        _release_scratch()
    out = []
    for c, red in zip(configs, acc):
        final = red.cat("final")
        columns = METHODS[:2] + tuple(f"{m}[{g.label}]" for g in c.gains for m in METHODS[2:])
        rms = bands = None
        if red.sumsq is not None:
            with np.errstate(invalid="ignore", divide="ignore"):
                rms = np.where(red.count > 0, np.sqrt(red.sumsq / np.maximum(red.count, 1)), np.nan)
            bands = band_quantiles(red.hist)
        out.append(StudyResult(
            config=c, runs=runs, seed=seed, time=sine.time[keep], errors=red.cat("series") if series else None,
            columns=columns, final=final, distance_error=red.cat("dist"), gain_draw=draws.cat("gain_draw"),
            distance=_chord_sum(sine), steps=int(sine.peaks.size - 1), gain_ref=gain_ref, gain_ref_cv=cv,
            digest=digest(final),
            backends={"trajectories": traj_backend,
                      "ins": f"batched strapdown kernel on the {c.ins_path} path (quaternion attitude, "
                             "trapezoid integration, the truth through the same rules; tested against "
                             "strapdown.ins3d/ins2d)"},
            elapsed=_time.perf_counter() - t0, rms=rms, bands=bands))
    return tuple(out)


class _Reduction:
    """Running reduction of one study's chunks, fed in run order.

    Per-run arrays are written into arrays allocated once for all the runs
    (no list of chunks concatenated at the end, which would hold them twice).
    """

    _PER_RUN = ("final", "dist", "series", "gain_draw")

    def __init__(self, runs: int):
        self.runs, self.filled = runs, 0
        self.arrays = {}
        self.sumsq = self.count = self.hist = None

    def add(self, part: dict) -> None:
        m = next(part[k] for k in self._PER_RUN if k in part).shape[0]
        for k in self._PER_RUN:
            if k in part:
                if k not in self.arrays:
                    self.arrays[k] = np.empty((self.runs,) + part[k].shape[1:], part[k].dtype)
                self.arrays[k][self.filled:self.filled + m] = part[k]
        self.filled += m
        if "sumsq" not in part:
            return
        if self.sumsq is None:
            m_, k_ = part["sumsq"].shape
            self.sumsq, self.count = part["sumsq"].copy(), part["count"].copy()
            self.hist = np.zeros((m_, k_, BAND_EDGES.size - 1), np.int64)
        else:
            self.sumsq += part["sumsq"]
            self.count += part["count"]
        cells, counts = part["hist"]
        np.add.at(self.hist.reshape(-1), cells, counts)

    def cat(self, key: str) -> np.ndarray:
        return self.arrays[key]


def summarize(x: np.ndarray) -> dict:
    """mean, std (ddof=1), median and 95th percentile of a sample (NaN-free) [same unit as x].

    Parameters
    ----------
    x : array_like, shape (n,)
        The sample, n >= 1.

    Returns
    -------
    dict
        ``mean``, ``std`` (sample standard deviation, 0.0 for one value),
        ``median`` and ``p95`` (linear interpolation), as floats.

    Examples
    --------
    >>> {k: round(v, 6) for k, v in summarize([1.0, 2.0, 3.0, 4.0]).items()}
    {'mean': 2.5, 'std': 1.290994, 'median': 2.5, 'p95': 3.85}
    """
    x = np.asarray(x, float)
    return {"mean": float(x.mean()), "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
            "median": float(np.median(x)), "p95": float(np.percentile(x, 95))}
