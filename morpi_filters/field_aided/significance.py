"""Run-by-run tests (paired t-test, Holm's correction, the smallest detectable difference), the coverage of the
filter's 95 % regions and the NIS bands."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import aided
from ..errors import ParameterError


#: Level of the paired tests, and the power at which a tie states the smallest difference the runs
#: could have detected (:func:`detectable_difference`).
ALPHA, POWER = 0.05, 0.8
#: Two-sided 95 % point of the standard normal: the bound of one axis' 95 % interval [sigma].
Z_95 = 1.959963984540054


@dataclass(frozen=True)
class PairedDifference:
    """End-point errors of one method minus another's over the same runs [pp of the route's distance].

    Attributes
    ----------
    mean_pp : float
        Mean of the per-run differences (negative: the first method is better).
    se_pp : float
        Its standard error (sample standard deviation / sqrt(runs)); NaN below two runs.
    runs : int
        Runs where both errors are finite.
    p_value : float
        Two-sided paired t-test of a zero mean difference (NaN below two runs, 1 when every difference
        is zero).
    alpha : float
        Level of :attr:`verdict`.
    p_holm : float
        :attr:`p_value` adjusted by Holm's step-down over a family of cells (:func:`holm`; NaN outside
        one).
    mdd_pp : float
        The smallest true mean difference the test detects with probability :attr:`power` at
        :attr:`alpha`, with these runs and their spread (:func:`detectable_difference`) [pp].
    power : float
        The power of :attr:`mdd_pp`.
    """

    mean_pp: float
    se_pp: float
    runs: int
    p_value: float
    alpha: float = ALPHA
    p_holm: float = float("nan")
    mdd_pp: float = float("nan")
    power: float = POWER

    @property
    def verdict(self) -> str:
        """``"better"`` or ``"worse"`` where the test rejects a zero difference at :attr:`alpha`, else ``"tie"``."""
        if not self.p_value < self.alpha:
            return "tie"
        return "better" if self.mean_pp < 0 else "worse"

    @property
    def verdict_holm(self) -> str:
        """:attr:`verdict` with the Holm-adjusted p-value (:attr:`p_holm`); ``"tie"`` outside a family."""
        if not self.p_holm < self.alpha:
            return "tie"
        return "better" if self.mean_pp < 0 else "worse"


def paired_difference(errors_m, reference_m, distance_m: float, *, alpha: float = ALPHA) -> PairedDifference:
    """Compare two methods' end-point errors run by run (paired t-test).

    With ten or so test runs per cell, a mean difference of a few tenths of a
    per cent is often within the runs' own spread; the test says which
    differences the runs support, and :attr:`PairedDifference.mdd_pp` how
    large a difference they could have shown (a tie is no equivalence).

    Parameters
    ----------
    errors_m, reference_m : array_like, shape (n,)
        End-point errors of the method and of the reference on the same runs [m]; pairs with a NaN are
        left out.
    distance_m : float
        The route's distance [m] (the errors are reported in % of it).
    alpha : float
        Level of the test, in (0, 1).

    Returns
    -------
    PairedDifference
        Outside a family of cells (:attr:`PairedDifference.p_holm` NaN).

    Raises
    ------
    ParameterError
        For arrays of different shapes, a distance that is not positive or `alpha` outside (0, 1).

    Examples
    --------
    >>> d = paired_difference([1.0, 1.2, 0.9, 1.1], [1.5, 1.6, 1.4, 1.7], 50.0)
    >>> round(d.mean_pp, 3), d.runs, d.verdict
    (-1.0, 4, 'better')
    """
    a = np.asarray(errors_m, dtype=float)
    b = np.asarray(reference_m, dtype=float)
    if a.ndim != 1 or a.shape != b.shape:
        raise ParameterError(f"paired_difference: errors of shapes {a.shape} and {b.shape}, expected two (n,) arrays")
    if not (np.isfinite(distance_m) and distance_m > 0):
        raise ParameterError(f"distance_m={distance_m!r}: expected a positive route distance [m]")
    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    ok = np.isfinite(a) & np.isfinite(b)
    d = (a[ok] - b[ok]) / distance_m * 100
    n = int(d.size)
    if n < 2:
        return PairedDifference(float(d.mean()) if n else float("nan"), float("nan"), n, float("nan"), alpha)
    mean, sd = float(d.mean()), float(d.std(ddof=1))
    se = sd / np.sqrt(n)
    if se > 0:
        from scipy import stats

        p = float(2 * stats.t.sf(abs(mean) / se, n - 1))
    else:
        p = 1.0 if mean == 0 else 0.0
    return PairedDifference(mean, se, n, p, alpha, mdd_pp=detectable_difference(sd, n, alpha=alpha))


def holm(p_values, alpha: float = ALPHA):
    """Holm's step-down correction of a family of tests.

    The ``m`` finite p-values sorted ascending, the i-th (from 0) is
    multiplied by ``m - i``; each adjusted value is the running maximum of
    these products (capped at 1), so the order of the p-values is kept. A
    test is rejected where its adjusted value is below `alpha`: the chance of
    any false rejection in the family stays at most `alpha`.

    Parameters
    ----------
    p_values : array_like, shape (m,)
        The family's p-values; NaN (no test) is left out of the family.
    alpha : float
        Family-wise level, in (0, 1).

    Returns
    -------
    adjusted : ndarray, shape (m,)
        Adjusted p-values (NaN where the input is NaN).
    reject : ndarray of bool, shape (m,)
        ``adjusted < alpha``.

    Raises
    ------
    ParameterError
        For `alpha` outside (0, 1) or p-values outside [0, 1].

    Examples
    --------
    Four tests: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, and 0.04 x 1
    raised to the 0.06 before it:

    >>> adj, rej = holm([0.01, 0.04, 0.03, 0.005])
    >>> adj.round(12).tolist(), rej.tolist()
    ([0.03, 0.06, 0.06, 0.02], [True, False, False, True])
    """
    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    p = np.asarray(p_values, dtype=float).ravel()
    ok = np.flatnonzero(np.isfinite(p))
    if np.any((p[ok] < 0) | (p[ok] > 1)):
        raise ParameterError(f"holm: p-values {p.tolist()}: expected values in [0, 1] (or NaN)")
    adj = np.full(p.shape, np.nan)
    run = 0.0
    for i, j in enumerate(ok[np.argsort(p[ok], kind="stable")]):
        run = max(run, min(1.0, (ok.size - i) * p[j]))
        adj[j] = run
    with np.errstate(invalid="ignore"):
        return adj, adj < alpha


def detectable_difference(sd: float, runs: int, *, alpha: float = ALPHA, power: float = POWER) -> float:
    """The smallest true mean difference a two-sided paired t-test detects with probability `power`.

    With ``runs`` paired differences of standard deviation `sd`, the t
    statistic of a true mean difference ``delta`` follows the noncentral t
    distribution with ``runs - 1`` degrees of freedom and noncentrality
    ``delta sqrt(runs) / sd`` (scipy.stats.nct); the returned ``delta`` is
    the one whose rejection probability at `alpha` is `power`. Smaller true
    differences may well end in a tie: a tie says no more than this.

    Parameters
    ----------
    sd : float
        Standard deviation of the paired differences (any unit; the result is in it).
    runs : int
        Number of pairs.
    alpha : float
        Two-sided level, in (0, 1).
    power : float
        Wanted probability of detection, in (alpha, 1).

    Returns
    -------
    float
        The difference, in the unit of `sd`; NaN below two runs, 0 for ``sd == 0``.

    Raises
    ------
    ParameterError
        For `alpha`, `power` or `sd` out of range.

    Examples
    --------
    Ten pairs of unit spread (near the rule of thumb ``(t_0.975 + t_0.8) / sqrt(10) = 0.995``):

    >>> round(detectable_difference(1.0, 10), 3)
    0.996
    """
    from scipy import optimize, stats

    if not 0 < alpha < 1:
        raise ParameterError(f"alpha={alpha!r}: expected a test level in (0, 1)")
    if not alpha < power < 1:
        raise ParameterError(f"power={power!r}: expected a probability in (alpha, 1)")
    if not (np.isfinite(sd) and sd >= 0):
        raise ParameterError(f"sd={sd!r}: expected a finite standard deviation >= 0")
    if runs < 2:
        return float("nan")
    if sd == 0:
        return 0.0
    df = runs - 1
    se = sd / np.sqrt(runs)
    tc = stats.t.ppf(1 - alpha / 2, df)

    def gap(delta):
        nc = delta / se
        # the lower tail as the upper tail of the mirrored distribution: the same probability, where scipy's
        # noncentral t cdf returns NaN far in its tail (two or three runs at a large shift)
        return stats.nct.sf(tc, df, nc) + stats.nct.sf(tc, df, -nc) - power

    hi = (tc + stats.norm.ppf(power)) * se
    while gap(hi) <= 0:
        hi *= 2
    return float(optimize.brentq(gap, 0.0, hi, xtol=1e-12 * se, rtol=1e-12))


def ellipse_coverage(errors_xy, P_xy, along) -> dict:
    """How often the true end points lie inside the filter's 95 % regions: the ellipse and each axis.

    Parameters
    ----------
    errors_xy : array_like, shape (r, 2)
        Estimated minus true end points [m].
    P_xy : array_like, shape (r, 2, 2)
        Their covariances [m^2].
    along : array_like, shape (2,)
        Direction of the along-track axis (the route's start to its end); the
        cross-track axis is to its left.

    Returns
    -------
    dict
        ``runs``; ``inside_95``: share inside the 95 % ellipse (squared
        Mahalanobis distance at most the 2-dof chi-square point
        :data:`aided.CHI2_95_2DOF`); ``along_95``, ``cross_95``: share inside
        each axis' 95 % interval (``|e| <= 1.96 sigma`` of that axis'
        variance ``u^T P u``). NaN shares without runs.

    Raises
    ------
    ParameterError
        For mismatched shapes or a zero `along`.

    Examples
    --------
    Two end points with a unit covariance: one 1 m ahead (inside), one 2.5 m
    to the left (outside the ellipse, 2.5^2 > 5.99, and the cross-track interval):

    >>> cov = ellipse_coverage([[1.0, 0.0], [0.0, 2.5]], [np.eye(2), np.eye(2)], [2.0, 0.0])
    >>> cov["inside_95"], cov["along_95"], cov["cross_95"]
    (0.5, 1.0, 0.5)
    """
    e = np.asarray(errors_xy, dtype=float).reshape(-1, 2)
    P = np.asarray(P_xy, dtype=float).reshape(-1, 2, 2)
    if e.shape[0] != P.shape[0]:
        raise ParameterError(f"ellipse_coverage: {e.shape[0]} errors and {P.shape[0]} covariances; expected one each")
    u = np.asarray(along, dtype=float)
    if u.shape != (2,) or not np.linalg.norm(u) > 0:
        raise ParameterError(f"ellipse_coverage: along={u.tolist()}: expected a non-zero 2-vector")
    u = u / np.linalg.norm(u)
    c = np.array([-u[1], u[0]])
    if not e.shape[0]:
        return {"runs": 0, "inside_95": float("nan"), "along_95": float("nan"), "cross_95": float("nan")}
    m2 = np.einsum("ri,ri->r", e, np.linalg.solve(P, e[:, :, None])[:, :, 0])

    def axis(w):
        return float(np.mean(np.abs(e @ w) <= Z_95 * np.sqrt(np.einsum("i,rij,j->r", w, P, w))))

    return {"runs": int(e.shape[0]), "inside_95": float(np.mean(m2 <= aided.CHI2_95_2DOF)),
            "along_95": axis(u), "cross_95": axis(c)}


def nis_consistency(total: float, updates: int, dof: int, confidence: float = 0.95) -> dict:
    """The normalized innovation squared of some updates per degree of freedom, and the band it keeps.

    For a consistent filter the sum of ``updates`` NIS values, each of
    `dof` degrees of freedom, is chi-square with ``updates * dof`` degrees
    of freedom (:func:`morpi_filters.eskf.chi2_band`, from scipy.stats.chi2);
    divided by ``updates * dof``, its two-sided band at `confidence`.

    Parameters
    ----------
    total : float
        Sum of the NIS values.
    updates : int
        Number of updates.
    dof : int
        Degrees of freedom of one update (the measurement's size).
    confidence : float
        Probability inside the band.

    Returns
    -------
    dict
        ``per_dof`` (``total / (updates * dof)``; NaN without updates),
        ``band`` (``[lo, hi]``, NaN without updates) and ``updates``.

    Examples
    --------
    >>> out = nis_consistency(190.0, 100, 2)
    >>> out["per_dof"], [round(float(v), 3) for v in out["band"]]
    (0.95, [0.814, 1.205])
    """
    from ..eskf import chi2_band

    if updates < 1 or dof < 1:
        return {"per_dof": float("nan"), "band": [float("nan"), float("nan")], "updates": int(updates)}
    lo, hi = chi2_band(dof, updates, confidence)
    return {"per_dof": float(total) / (updates * dof), "band": [float(lo) / dof, float(hi) / dof],
            "updates": int(updates)}
