"""The block noise of rest detection written with numpy: the reference the compiled loops are held to.

``block_sigma`` is what ``calibration._block_sigma`` computes with ``_calibration_loops.block_sigma_loops``:
the blocks of at least five samples, each block's :func:`morpi_filters.calibration.noise_sigma`
(blockwise, all blocks at once), the lower quartile of the sigmas and the median of the quietest block
(the tie-tolerant choice of :func:`morpi_filters.choice.choose`). numpy sums in its own (pairwise)
order, the loops in row order: the two agree within rounding, not bit for bit.
"""
from __future__ import annotations

import math

import numpy as np

from morpi_filters.calibration import noise_sigma
from morpi_filters.choice import choose, tie_margin


def sorted_order_stat(s: np.ndarray, n: np.ndarray, q: float) -> np.ndarray:
    """Linear-interpolation quantile `q` of sorted, padded columns, as :func:`numpy.quantile` computes it.

    `s` has shape (blocks, L, k), sorted along axis 1 with each block's `n` values first; returns shape
    (blocks, k).
    """
    pos = (n - 1) * q
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, n - 1)
    frac = (pos - lo)[:, None]
    rows = np.arange(s.shape[0])
    a, b = s[rows, lo], s[rows, hi]
    diff = b - a
    return np.where(frac >= 0.5, b - diff * (1 - frac), a + diff * frac)


def noise_sigma_blocks(x: np.ndarray, blocks) -> np.ndarray:
    """:func:`noise_sigma` of every ``x[a:b]`` for ``(a, b)`` in `blocks` (each b - a >= 3) at once,
    shape (len(blocks), k)."""
    d_all = np.diff(np.asarray(x, dtype=float), axis=0)
    start = np.array([a for a, _ in blocks])
    n = np.array([b - a - 1 for a, b in blocks])
    col = np.arange(n.max())
    valid = (col[None, :] < n[:, None])[..., None]
    d = d_all[np.where(valid[..., 0], start[:, None] + col[None, :], 0)]
    srt = np.sort(np.where(valid, d, np.inf), axis=1)
    rows = np.arange(len(blocks))
    mid = (n - 1) // 2
    odd = (n % 2 == 1)[:, None]
    med = np.where(odd, srt[rows, mid], (srt[rows, mid] + srt[rows, np.minimum(mid + 1, n - 1)]) / 2.0)
    dev = np.abs(d - med[:, None, :])
    q90 = sorted_order_stat(np.sort(np.where(valid, dev, np.inf), axis=1), n, 0.9)
    keep = valid & (dev <= q90[:, None, :] + tie_margin(q90)[:, None, :])
    sigma = np.sqrt((np.where(keep, dev, 0.0) ** 2).sum(axis=1) / keep.sum(axis=1)) / 0.7891 / math.sqrt(2.0)
    ad = np.abs(d)
    pos_min = np.where(valid & (ad > 0), ad, np.inf).min(axis=1)
    floor = np.where(np.isfinite(pos_min), pos_min, 0.0) / math.sqrt(12.0)
    return np.maximum(np.maximum(sigma, floor), np.finfo(float).tiny)


def block_edges(t, span, block) -> np.ndarray:
    """The candidate blocks' edges: sample indices of 0, block, 2 block, ... up to max(span, block) [s]."""
    return np.searchsorted(t, np.arange(0.0, max(span, block) + 1e-12, block), side="left")


def block_sigma(t: np.ndarray, x: np.ndarray, span: float, block: float):
    """(lower quartile of the blocks' sigmas, median of the quietest block), each shape (k,)."""
    edges = block_edges(t, span, block)
    blocks = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b - a >= 5]
    if not blocks:
        stop = max(int(np.searchsorted(t, span, side="right")), 3)
        return noise_sigma(x[:stop]), np.median(x[:stop], axis=0)
    sig = noise_sigma_blocks(x, blocks)
    spread = np.array([x[a:b].std(axis=0) for a, b in blocks])
    a, b = blocks[choose((spread / np.maximum(sig.min(axis=0), 1e-300)).sum(axis=1))]
    return np.quantile(sig, 0.25, axis=0), np.median(x[a:b], axis=0)
