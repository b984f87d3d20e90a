"""The leave-one-out end-point errors of the rule search in numpy, and how far another order of the sum moves them."""
from __future__ import annotations

import numpy as np

EPS = np.finfo(float).eps


def loo_errors(truth, g, u, keep):
    """``|gi u - end| / distance * 100`` with ``gi = (sum(g) - g) / (n - 1)`` over the runs flagged in `keep`."""
    gk, uk = g[keep], u[keep]
    gi = (gk.sum() - gk) / (gk.size - 1)
    return np.linalg.norm(gi[:, None] * uk - truth.end_point_m, axis=1) / truth.distance_m * 100


def order_bound(truth, g, u, keep):
    """Per run, a bound on how much the errors of :func:`loo_errors` move when the gains are summed in
    another order.

    n positive terms summed in any order differ from the exact sum by at most ``(n - 1) eps sum(g)``
    (first order), so ``gi`` by that over ``n - 1``, the end point by ``|u|`` times that, and the
    error by that over the distance (x 100): doubled for the two orders compared, plus 8 eps relative for
    the subtraction, the division and the norm, which both forms round alike up to that.
    """
    gk, uk = g[keep], u[keep]
    shift = 2 * EPS * gk.sum() * np.linalg.norm(uk, axis=1) / truth.distance_m * 100    # 2 (n-1) eps sum / (n-1)
    return shift + 8 * EPS * loo_errors(truth, g, u, keep)
