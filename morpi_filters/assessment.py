"""The analytical assessment: closed-form 3D and 2D INS error vs MoRPI-A.

Reproduces the paper's figure "Analytical assessment of 3D & 2D INS vs.
MoRPI-A distance error" [1]_ from the symbolic derivation
(:mod:`morpi_filters.symbolic`, reached only through its lambdified bridge;
this module does not import sympy at module level):

* ``e_3D(t)``, ``e_2D(t)``: horizontal distance error of the 3D and the 2D
  (yaw-only) INS under the paper's assumptions, with the ``b_gz`` terms dropped
  as in the paper and the package's ``"z_up"`` sign convention. These come from
  the derivation, not from the printed eq:error-3d, which the audit found
  inconsistent in sign (``reports/assessment/audit.md``).
* ``ds(t) = dG * v * t``: MoRPI-A distance error for a Weinberg gain error
  ``dG`` (fraction of the gain) over a path covered at ``v`` metres per second
  (``morpi_speed_mps``).

The paper quotes eight improvements (INS error minus MoRPI-A error). Writing
``E3 = e_3D(5 s)``, ``E2 = e_2D(5 s)`` and ``r = v``, they are
``E - dG r T`` for ``E in (E3, E2)``, ``dG in (0.10, 0.05)`` and
``T in (5 s, 14 s)``: eight numbers, three unknowns. They pin E3, E2 and the
MoRPI-A error rate, not the individual biases; :func:`fit_paper_numbers` finds
one physically plausible parameter set (closest to a stated prior) that gives
all eight within 0.01 m, committed as ``data/assessment_params.json``.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023, section "Analytical Assessment".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ParameterError
from .params import DEFAULT_PARAMS_FILE, ErrorParams, load_params
from .outputs import write_json

__all__ = [
    "PAPER_IMPROVEMENTS", "PaperNumber", "AssessmentCurves", "assessment_curves", "improvements",
    "fit_paper_numbers", "FitResult", "write_fitted_params", "AssessmentStudy", "assessment_study", "morpi_distance_error",
    "DEFAULT_TIMES",
    "CONVENTION", "FIT_PRIOR", "FIT_BOUNDS",
]

#: Sign convention of the section (the package's frames, see morpi_filters.__init__).
CONVENTION = "z_up"
#: Default time grid of the figure [s]: 0 to 15 s.
DEFAULT_TIMES = np.arange(151) / 10.0


@dataclass(frozen=True)
class PaperNumber:
    """One improvement quoted by the paper: ``e_INS(t_ins) - ds_MoRPI-A(t_morpi; dG)``.

    Attributes
    ----------
    ins : {"INS-3D", "INS-2D"}
    dG : float
        Gain error (fraction).
    t_ins, t_morpi : float
        Times of the INS and MoRPI-A errors [s].
    paper_m : float
        The printed value [m], rounded to 0.01 m in the paper.
    """

    ins: str
    dG: float
    t_ins: float
    t_morpi: float
    paper_m: float


#: The eight improvements of the section, in the paper's order.
PAPER_IMPROVEMENTS = (
    PaperNumber("INS-3D", 0.10, 5.0, 5.0, 2.95), PaperNumber("INS-2D", 0.10, 5.0, 5.0, 0.91),
    PaperNumber("INS-3D", 0.05, 5.0, 5.0, 3.20), PaperNumber("INS-2D", 0.05, 5.0, 5.0, 1.15),
    PaperNumber("INS-3D", 0.10, 5.0, 14.0, 2.07), PaperNumber("INS-2D", 0.10, 5.0, 14.0, 0.02),
    PaperNumber("INS-3D", 0.05, 5.0, 14.0, 2.76), PaperNumber("INS-2D", 0.05, 5.0, 14.0, 0.71),
)


def _symbolic():
    from . import symbolic  # sympy is loaded here, on first use only

    return symbolic


def morpi_distance_error(dG: float, speed_mps: float, times) -> np.ndarray:
    """MoRPI-A distance error ``dG * v * t``.

    Parameters
    ----------
    dG : float
        Weinberg gain error, as a fraction of the gain (0.1 is 10 %).
    speed_mps : float
        Distance travelled per second along the path [m/s].
    times : array_like, shape (n,)
        Times since the start [s].

    Returns
    -------
    ndarray, shape (n,)
        Distance error at each time [m] (the sign of `dG`).

    Examples
    --------
    >>> morpi_distance_error(0.1, 0.5, [0.0, 2.0]).tolist()      # 10 % of 1 m
    [0.0, 0.1]
    """
    return float(dG) * float(speed_mps) * np.asarray(times, dtype=float)


@dataclass(frozen=True)
class AssessmentCurves:
    """Closed-form curves of the assessment.

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s]
    e3d, e2d : ndarray, shape (n,)
        3D / 2D INS horizontal distance error, b_gz terms dropped [m].
    e3d_bgz, e2d_bgz : ndarray, shape (n,)
        The same with the b_gz terms kept [m].
    morpi : dict of float -> ndarray, shape (n,)
        MoRPI-A distance error per gain error [m].
    convention : str
    """

    times: np.ndarray
    e3d: np.ndarray
    e2d: np.ndarray
    e3d_bgz: np.ndarray
    e2d_bgz: np.ndarray
    morpi: dict
    convention: str


def assessment_curves(params: ErrorParams, times=None, convention: str = CONVENTION) -> AssessmentCurves:
    """Evaluate e_3D, e_2D (from the derivation) and MoRPI-A over `times`.

    The INS curves are
    :func:`morpi_filters.symbolic.closed_form_errors` with the b_gz terms
    dropped (``e3d``, ``e2d``) and kept (``e3d_bgz``, ``e2d_bgz``); the MoRPI-A
    curves are :func:`morpi_distance_error` for each gain error of
    ``params.dG`` at ``params.morpi_speed_mps``. The first call loads sympy.

    Parameters
    ----------
    params : ErrorParams
        One error realisation (the values are used as they are, not as sigmas).
    times : array_like, shape (n,), optional
        Times [s]; :data:`DEFAULT_TIMES` (0 to 15 s by 0.1 s) when None.
    convention : str, optional
        Sign convention of the derivation (default :data:`CONVENTION`, ``"z_up"``).

    Returns
    -------
    AssessmentCurves
        The curves over `times`, each of shape (n,) [m], and the convention's name.

    Examples
    --------
    With an initial velocity error alone, both INS drift as ``|dv0_xy| t``:

    >>> from morpi_filters.params import params_from_dict
    >>> p = params_from_dict({"dv0_mps": [0.03, 0.04, 0.0], "accel_bias_mps2": [0.0] * 3, "gyro_bias_radps": [0.0] * 3,
    ...                       "g_mps2": 9.81, "dG": [0.1], "morpi_speed_mps": 0.5})
    >>> c = assessment_curves(p, [0.0, 1.0, 2.0])
    >>> c.e3d.round(12).tolist(), c.e2d.round(12).tolist(), c.morpi[0.1].round(12).tolist(), c.convention
    ([0.0, 0.05, 0.1], [0.0, 0.05, 0.1], [0.0, 0.05, 0.1], 'z_up')
    """
    S = _symbolic()
    t = DEFAULT_TIMES if times is None else np.asarray(times, dtype=float)
    cf = S.closed_form_errors
    return AssessmentCurves(
        times=t,
        e3d=cf(params, t, "INS-3D", convention, keep_bgz=False),
        e2d=cf(params, t, "INS-2D", convention, keep_bgz=False),
        e3d_bgz=cf(params, t, "INS-3D", convention, keep_bgz=True),
        e2d_bgz=cf(params, t, "INS-2D", convention, keep_bgz=True),
        morpi={dG: morpi_distance_error(dG, params.morpi_speed_mps, t) for dG in params.dG},
        convention=S.convention(convention).name,
    )


def improvements(params: ErrorParams, convention: str = CONVENTION, numbers=PAPER_IMPROVEMENTS) -> np.ndarray:
    """Our values of the paper's improvements, ``e_INS(t_ins) - dG v t_morpi``.

    Parameters
    ----------
    params : ErrorParams
        One error realisation; ``params.morpi_speed_mps`` is v.
    convention : str, optional
        Sign convention of the derivation (default :data:`CONVENTION`).
    numbers : sequence of PaperNumber, optional
        The improvements to evaluate (default :data:`PAPER_IMPROVEMENTS`, the
        paper's eight); ``paper_m`` is not read.

    Returns
    -------
    ndarray, shape (len(numbers),)
        INS distance error (b_gz terms dropped) minus MoRPI-A distance error [m].

    Examples
    --------
    With a horizontal dv0 of 0.05 m/s the INS error at 5 s is 0.25 m; at 0.5 m/s
    MoRPI-A with a 10 % gain error loses 0.25 m in 5 s and 0.7 m in 14 s:

    >>> from morpi_filters.params import params_from_dict
    >>> p = params_from_dict({"dv0_mps": [0.03, 0.04, 0.0], "accel_bias_mps2": [0.0] * 3, "gyro_bias_radps": [0.0] * 3,
    ...                       "g_mps2": 9.81, "morpi_speed_mps": 0.5})
    >>> improvements(p).round(6).tolist()
    [0.0, 0.0, 0.125, 0.125, -0.45, -0.45, -0.1, -0.1]
    >>> improvements(p, numbers=[PaperNumber("INS-2D", 0.1, 2.0, 1.0, 0.0)]).round(6).tolist()
    [0.05]
    """
    S = _symbolic()
    out = []
    for n in numbers:
        e = S.closed_form_errors(params, [n.t_ins], n.ins, convention, keep_bgz=False)[0]
        out.append(e - morpi_distance_error(n.dG, params.morpi_speed_mps, n.t_morpi))
    return np.array(out)


# ----------------------------------------------------------------------------- fit

#: Prior of the fit (a plausible calibrated smartphone IMU, z_up frames) and its scale.
FIT_PRIOR = {
    "dv0_mps": ([0.05, 0.03, 0.02], 0.05),
    "accel_bias_mps2": ([0.05, 0.04, 0.03], 0.05),    # ~5 mg residual after calibration
    "gyro_bias_radps": ([0.003, 0.003, 0.002], 0.003),  # ~0.17 deg/s residual
    "morpi_speed_mps": (1.0, 1.0),
}
#: Bounds of the fitted components (absolute value at most): the paper's turn-on biases (60 mg, 6 deg/s).
FIT_BOUNDS = {"dv0_mps": 0.3, "accel_bias_mps2": 0.6, "gyro_bias_radps": 0.105, "morpi_speed_mps": (0.1, 3.0)}


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_paper_numbers`.

    Attributes
    ----------
    params : dict
        The parameter file content (JSON-ready, units in key names).
    ours_m : ndarray, shape (8,)
        The eight improvements from `params` [m].
    paper_m : ndarray, shape (8,)
    max_abs_error_m : float
    """

    params: dict
    ours_m: np.ndarray
    paper_m: np.ndarray
    max_abs_error_m: float


def fit_paper_numbers(g_mps2: float = 9.81, convention: str = CONVENTION, digits: int = 6) -> FitResult:
    """Find a plausible parameter set reproducing the paper's eight improvements.

    Bounded least squares (``scipy.optimize.least_squares``, trust-region
    reflective) on the horizontal dv0, b_a, b_g and the MoRPI-A speed, with
    the eight residuals weighted by 1/(1 mm) and a weak pull towards
    :data:`FIT_PRIOR` (which picks one point of the solution family: the data
    fix only e_3D(5 s), e_2D(5 s) and the MoRPI-A error rate). The vertical
    components stay at the prior (b_gz is dropped as in the paper; b_az enters
    only through alpha). The fitted values are rounded to `digits` significant
    digits before the improvements are recomputed. Takes a few seconds, so it
    has no example here (``tests/test_assessment.py`` runs it).

    Parameters
    ----------
    g_mps2 : float, optional
        Gravity magnitude written to the parameters [m/s^2] (default 9.81).
    convention : str, optional
        Sign convention of the derivation (default :data:`CONVENTION`).
    digits : int, optional
        Significant digits kept of each fitted value (default 6).

    Returns
    -------
    FitResult
        The parameter mapping (keys ``dv0_mps``, ``accel_bias_mps2``, ``gyro_bias_radps``,
        ``g_mps2``, ``dG``, ``morpi_speed_mps``, ``process_noise``), our eight
        improvements from it, the paper's eight and the largest absolute
        difference [m].
    """
    from scipy.optimize import least_squares

    from .params import params_from_dict

    paper = np.array([n.paper_m for n in PAPER_IMPROVEMENTS])
    dv_p, dv_s = FIT_PRIOR["dv0_mps"]
    ba_p, ba_s = FIT_PRIOR["accel_bias_mps2"]
    bg_p, bg_s = FIT_PRIOR["gyro_bias_radps"]
    v_p, v_s = FIT_PRIOR["morpi_speed_mps"]
    x0 = np.array([*dv_p[:2], *ba_p[:2], *bg_p[:2], v_p])
    scale = np.array([dv_s] * 2 + [ba_s] * 2 + [bg_s] * 2 + [v_s])
    lo = np.array([-FIT_BOUNDS["dv0_mps"]] * 2 + [-FIT_BOUNDS["accel_bias_mps2"]] * 2 + [-FIT_BOUNDS["gyro_bias_radps"]] * 2
                  + [FIT_BOUNDS["morpi_speed_mps"][0]])
    hi = np.array([FIT_BOUNDS["dv0_mps"]] * 2 + [FIT_BOUNDS["accel_bias_mps2"]] * 2 + [FIT_BOUNDS["gyro_bias_radps"]] * 2
                  + [FIT_BOUNDS["morpi_speed_mps"][1]])

    def to_dict(x):
        return {
            "dv0_mps": [float(x[0]), float(x[1]), dv_p[2]], "accel_bias_mps2": [float(x[2]), float(x[3]), ba_p[2]],
            "gyro_bias_radps": [float(x[4]), float(x[5]), bg_p[2]], "g_mps2": g_mps2, "dG": [0.05, 0.10],
            "morpi_speed_mps": float(x[6]),
            "process_noise": False,
        }

    def resid(x):
        ours = improvements(params_from_dict(to_dict(x)), convention)
        return np.concatenate([(ours - paper) / 1e-3, 0.05 * (x - x0) / scale])

    sol = least_squares(resid, x0, bounds=(lo, hi), method="trf", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    x = np.array([float(f"{v:.{digits}g}") for v in sol.x])
    d = to_dict(x)
    ours = improvements(params_from_dict(d), convention)
    return FitResult(params=d, ours_m=ours, paper_m=paper, max_abs_error_m=float(np.max(np.abs(ours - paper))))


def write_fitted_params(path=DEFAULT_PARAMS_FILE, **kw) -> FitResult:
    """Run :func:`fit_paper_numbers` once and write the parameter file atomically.

    The file holds the fitted mapping plus a ``"note"`` naming the fit and its
    largest difference from the paper. Takes a few seconds (the fit), so it
    has no example here.

    Parameters
    ----------
    path : path-like, optional
        File written (default :data:`~morpi_filters.params.DEFAULT_PARAMS_FILE`,
        the committed ``data/assessment_params.json``).
    **kw
        Keyword arguments of :func:`fit_paper_numbers` (``g_mps2``,
        ``convention``, ``digits``).

    Returns
    -------
    FitResult
        The fit that was written.
    """
    fit = fit_paper_numbers(**kw)
    d = dict(fit.params)
    d["note"] = ("Fitted by morpi_filters.assessment.fit_paper_numbers to the paper's eight improvements "
                 f"(max |ours - paper| = {fit.max_abs_error_m:.4f} m); convention {CONVENTION}, b_gz terms "
                 "dropped. Only e_3D(5 s), e_2D(5 s) and the MoRPI-A rate are determined by the paper.")
    write_json(path, d)
    return fit


# ----------------------------------------------------------------------------- the section's study

def _check_times(times):
    if times is None:
        return DEFAULT_TIMES
    t = np.asarray(list(times), dtype=float)
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ParameterError("--times: expected one or more finite times >= 0 s")
    return t


@dataclass(frozen=True)
class AssessmentStudy:
    """Everything the assessment section shows, computed once.

    Attributes
    ----------
    params : params.ErrorParams
        The parameter file as read.
    curves : AssessmentCurves
        The closed-form curves over the requested times.
    improvements_m : ndarray, shape (8,)
        Our values of :data:`PAPER_IMPROVEMENTS` [m].
    e3d_5s_m, e2d_5s_m : float
        e_3D(5 s) and e_2D(5 s), b_gz terms dropped [m].
    audit : symbolic.AuditResult
        The audit of the printed equations under :data:`CONVENTION`.
    dropped_terms : dict
        ``{"INS-3D": str, "INS-2D": str}``: the b_gz terms the paper drops from e^2
        (:func:`morpi_filters.symbolic.dropped_bgz_terms`).
    conventions : tuple of (str, bool)
        The audited sign conventions and whether each is physically consistent.
    """

    params: ErrorParams
    curves: AssessmentCurves
    improvements_m: np.ndarray
    e3d_5s_m: float
    e2d_5s_m: float
    audit: object
    dropped_terms: dict
    conventions: tuple

    @property
    def times(self) -> np.ndarray:
        """The times of the curves [s], ``curves.times``, shape (n,)."""
        return self.curves.times


def assessment_study(params_path=None, times=None) -> AssessmentStudy:
    """Compute the analytical-assessment section: curves, the eight improvements and the audit.

    Parameters
    ----------
    params_path : path-like, optional
        Parameter file; default ``data/assessment_params.json``.
    times : sequence of float, optional
        Times of the curves [s], finite and >= 0; default 0 to 15 s by 0.1 s.

    Returns
    -------
    AssessmentStudy
        The parameters, the curves over `times`, our eight improvements,
        e_3D(5 s) and e_2D(5 s), the audit of the printed equations, the
        dropped b_gz terms and the audited conventions.

    Raises
    ------
    ParameterError
        For an empty, non-finite or negative time grid, and every error of
        :func:`~morpi_filters.params.load_params`.

    Examples
    --------
    The committed parameters reproduce the paper's eight printed improvements
    to 0.01 m:

    >>> s = assessment_study(times=[0.0, 5.0])
    >>> s.improvements_m.round(2).tolist()
    [2.95, 0.91, 3.2, 1.15, 2.07, 0.02, 2.76, 0.71]
    >>> s.times.tolist(), bool(s.curves.e3d[1] == s.e3d_5s_m), sorted(s.dropped_terms)
    ([0.0, 5.0], True, ['INS-2D', 'INS-3D'])
    """
    params = load_params(params_path)
    t = _check_times(times)
    S = _symbolic()
    curves = assessment_curves(params, t)
    ours = improvements(params)
    audit = S.audit(CONVENTION)
    dropped = S.dropped_bgz_terms(audit.reference)
    e3_5 = S.closed_form_errors(params, [5.0], "INS-3D", CONVENTION)[0]
    e2_5 = S.closed_form_errors(params, [5.0], "INS-2D", CONVENTION)[0]
    return AssessmentStudy(params=params, curves=curves, improvements_m=ours, e3d_5s_m=e3_5, e2d_5s_m=e2_5,
                           audit=audit, dropped_terms=dropped,
                           conventions=tuple((c.name, bool(c.physical)) for c in S.AUDIT_CONVENTIONS))
