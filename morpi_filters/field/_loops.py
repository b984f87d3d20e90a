"""Loops of the rule search that numba compiles (:mod:`morpi_filters.field`).

- :func:`loo_errors`, the leave-one-out end-point errors the rule searches score
  (``field.loo_errors``), the gains summed in order (the search's choices are tie-tolerant,
  ``choice.choose``, so the numpy form is met within rounding, not bit for bit).

numba is imported on the first call (:data:`compiled`, made by ``_jit.loops``), not with the package, and its
machine code is cached on disk (so no function here calls itself: numba's cache does not hold recursive
functions). The loop runs as plain Python too (slowly): the tests compare both, and hold it to the numpy
form it restates within the rounding its sum allows, the bound written beside it (``tests/oracles``).
"""
from __future__ import annotations

import math

from .._jit import loops


def loo_errors(g, u, keep, end, dist, out):
    """End-point errors [%] of the runs flagged in `keep` with the mean gain of the other flagged runs:
    ``field._loo_errors`` of ``g[keep]``, ``u[keep]`` (g (n,), u (n, 2)), each run against its own true
    end point ``end[i]`` (n, 2) and distance ``dist[i]`` (n,) (the gains summed in order: a score, chosen
    among within the tie tolerance of ``choice.choose``, so another order's rounding does not matter);
    the m errors in ``out[:m]``, returns m."""
    m = 0
    total = 0.0
    for i in range(g.shape[0]):
        if keep[i]:
            total += g[i]
            m += 1
    j = 0
    for i in range(g.shape[0]):
        if keep[i]:
            gi = (total - g[i]) / (m - 1)
            dx = gi * u[i, 0] - end[i, 0]
            dy = gi * u[i, 1] - end[i, 1]
            out[j] = math.sqrt(dx * dx + dy * dy) / dist[i] * 100
            j += 1
    return m


#: The functions numba compiles, callees first.
_FUNCTIONS = ("loo_errors",)
compiled = loops(globals(), _FUNCTIONS)
