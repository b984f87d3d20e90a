"""Choosing among candidates by a score, robust to rounding.

Every discrete choice the package makes by a least score (a step rule, a
filter tunable, a calibration, a quiet block) goes through :func:`choose`:
the candidates within the tie tolerance of the least score are tied, and the
earliest of them in the candidate order wins. The callers list their
candidates simplest first, so a tie keeps the simpler one.

The tolerance (:data:`TIE_REL`, relative to the least score) lies far above
the rounding of a score and far below any difference that matters. A score
here is a mean or a sum of a few hundred float64 terms at most; summed in
another order (another numpy release, another BLAS or libm) it moves by a
few hundred units of the last place, a few 1e-14 relative, and the field
data moves the committed numbers by at most a few 1e-11 between machines
(``tests/test_reports_reproduce.py``). 1e-9 is 30 times above the latter and
1e4 times above the former, and far below any difference that matters: two
leave-one-out errors of 5 % within it differ by less than 5e-9 percentage
points, nothing a table shows (on the field data, the closest runner-up of
a rule search that is not an exact tie scores 3.9e-5 relative above the
best). Without the tolerance, two candidates whose
scores agree to the last bits on one machine could swap on another and move
a table cell by a percent.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["TIE_REL", "TIE_ABS", "choose", "tie_margin"]

#: Relative tie tolerance: scores within ``TIE_REL * |least|`` of the least score are tied (see above).
TIE_REL = 1e-9
#: Absolute tie tolerance in the score's units, for a least score at or near zero: the least score of a
#: choice is zero only when the candidates agree exactly (a score is an error or a spread), so rounding
#: of zero-scored candidates is below 1e-300 and 0 would do; 1e-300 keeps the rule defined at zero.
TIE_ABS = 1e-300


def tie_margin(best: float, tol_rel: float = TIE_REL, tol_abs: float = TIE_ABS) -> float:
    """The width of the tie band above the least score `best`: ``tol_rel * |best| + tol_abs``.

    Parameters
    ----------
    best : float
        The least score.
    tol_rel, tol_abs : float
        Relative and absolute tie tolerance (:data:`TIE_REL`, :data:`TIE_ABS`).

    Returns
    -------
    float
        The margin (infinite when `best` is).

    Examples
    --------
    >>> tie_margin(2.0)
    2e-09
    """
    return tol_rel * abs(best) + tol_abs


def choose(scores, tol_rel: float = TIE_REL, tol_abs: float = TIE_ABS) -> int:
    """Index of the earliest candidate whose score is within the tie tolerance of the least score.

    A candidate is tied with the best when its score is at most
    ``least + tol_rel * |least| + tol_abs`` (:func:`tie_margin`); among the
    tied, the first in the order given wins. NaN scores are never chosen
    (unless every score is NaN: then the first); infinite scores only when no
    score is finite (then the first of the least). Without a tolerance
    (``tol_rel = tol_abs = 0``) this is ``np.argmin`` on scores without NaN.

    Parameters
    ----------
    scores : array_like, shape (n,)
        One score per candidate, in the candidate order (simplest first); the
        lower the better.
    tol_rel, tol_abs : float
        Relative tie tolerance and absolute tie tolerance in the score's units
        (:data:`TIE_REL`, :data:`TIE_ABS`).

    Returns
    -------
    int

    Raises
    ------
    ValueError
        When `scores` is empty or not one-dimensional, or a tolerance is
        negative or not finite.

    Examples
    --------
    >>> choose([3.0, 2.0, 2.0 * (1 - 1e-12), 5.0])      # the third is lower by rounding only: a tie
    1
    >>> choose([3.0, 2.0, 1.99, 5.0])                   # lower beyond the tolerance: the better
    2
    """
    s = np.asarray(scores, dtype=float)
    if s.ndim != 1 or s.size == 0:
        raise ValueError(f"choose: expected a non-empty one-dimensional array of scores, got shape {s.shape}")
    if not (math.isfinite(tol_rel) and math.isfinite(tol_abs) and tol_rel >= 0 and tol_abs >= 0):
        raise ValueError(f"choose: expected finite tolerances >= 0, got tol_rel={tol_rel}, tol_abs={tol_abs}")
    ok = ~np.isnan(s)
    if not ok.any():
        return 0
    least = float(s[ok].min())
    if math.isinf(least):                        # every score -inf, or no finite one: the first of the least
        return int(np.flatnonzero(s == least)[0])
    return int(np.flatnonzero(ok & (s <= least + tie_margin(least, tol_rel, tol_abs)))[0])
