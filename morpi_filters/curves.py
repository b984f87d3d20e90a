"""Covariance curves: closed form, filter sigma, Monte Carlo and field errors side by side.

For each *case* (a parameter file, or one of the paper's IMUs) and each method
(3D INS, 2D INS, MoRPI-aided INS) this module computes, over time:

* the error-state filter's horizontal 1 sigma (:mod:`morpi_filters.eskf`,
  covariance propagation at the IMU rate, MoRPI steps as pseudo-measurements);
* the closed-form RMS: the expectation of the squared paper polynomials for
  independent zero-mean errors with the given 1-sigma values (process noise
  not included, as in the paper);
* the closed-form error of one realisation (the parameters taken as values,
  as ``morpi assess`` reads them);
* the Monte Carlo RMS over seeded runs of the linear error model (sampled
  white noise, :func:`morpi_filters.error_model.simulate_linear`), and for the
  MoRPI-aided case the RMS of the filter's own estimation error;
* the nonlinear Monte Carlo of the IMU cases (``simulate.imu`` at rest through
  the 3D/2D strapdown), where the linear model's limits show;
* when a data source is configured, the field straight-line INS end-point
  errors at their durations (the MoRPI-aided filter on the recordings is the
  ``aided`` section, :func:`morpi_filters.field_aided.aided_study`).

Nominal trajectory and assumptions (the paper's analytical assessment [1]_):
``C_b^n = I`` and ``f^n = (0, 0, g)``, z-up package convention. As in the
paper, the heading error is common to every method and the gyro z-bias is
left out (``keep_bgz=False``): its 1 sigma is set to zero in every case.
The MoRPI steps are ``STEP_LENGTH_M`` long, one every
``STEP_LENGTH_M / morpi_speed_mps`` seconds; the relative gain error has
1 sigma ``dG[0]`` and is estimated as a constant augmented state.
The parameter file's ``process_noise`` switch adds the white noise of the
MPU-6500 datasheet to the parameter-file case (the noisier of the two IMUs)
and the IMU's own noise to each IMU case.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J. Indoor and Seamless Positioning and Navigation, 2023.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from . import units
from .error_model import (
    DP, discretize, noise_coupling, noise_density, paper_trajectory, planar_noise_coupling,
    planar_noise_density, planar_system_matrix, simulate_linear, system_matrix,
)
from .deprecation import renamed_attribute, renamed_keywords
from .errors import MorpiError, ParameterError
from .eskf import (
    StepModel, augment, augment_covariance, initial_covariance, run_filter, simulate_steps, step_update,
)

__all__ = [
    "STEP_LENGTH_M", "DEFAULT_TIMES", "CURVE_METHODS", "horizontal_sigma", "CurveCase", "CaseCurves", "case_from_params", "case_from_sensor",
    "time_grid", "case_mean_square", "error_realisation", "compute_curves", "CurvesStudy", "curves_study", "PAPER_IMU_TITLES",
]

#: The curves' methods, in the package's names: the filter's horizontal 1 sigma of each, and
#: the closed forms (for "MoRPI-aided INS", the paper's MoRPI distance error ``dG v t``).
CURVE_METHODS = ("INS-3D", "INS-2D", "MoRPI-aided INS")

#: Length of one MoRPI step [m]: the 1 m peak-to-peak period of the paper's periodic routes.
STEP_LENGTH_M = 1.0
#: Default evaluation times [s]: 0..15 s.
DEFAULT_TIMES = tuple(float(t) for t in range(16))
#: IMU sampling step of the filter [s] (100 Hz, the dataset's rate).
FILTER_DT = 0.01
#: Step of the Monte Carlo runs [s].
MC_DT = 0.05
#: Monte Carlo runs per case, and the default seed of the curves study (``morpi curves --seed``,
#: :func:`curves_study`).
MC_RUNS, MC_SEED = 1000, 20230901
#: The page's titles of the paper's IMUs: each with the phone of the MoRPI recordings that carries it.
PAPER_IMU_TITLES = {"MPU-6500": "MPU-6500 (S6)", "LSM6DSL": "LSM6DSL (S8)"}
#: Runs per chunk of the linear Monte Carlo and most epochs of its grid (memory bound).
MC_CHUNK, MC_MAX_EPOCHS = 250, 600
#: Runs of the nonlinear (strapdown) Monte Carlo per IMU case, and the longest
#: time it is run for [s] (its memory and time grow with runs x samples).
NL_RUNS, NL_MAX_T = 200, 60.0
#: Noise spec used for a parameter file with ``process_noise: true``.
PARAMS_NOISE_SPEC = units.MPU6500


@dataclass(frozen=True)
class CurveCase:
    """1-sigma error parameters of one set of curves (SI).

    Attributes
    ----------
    name : str
        Short name (file-name safe).
    title : str
    dv0, ba, bg : ndarray, shape (3,)
        1 sigma of the initial velocity error [m/s], accelerometer bias
        [m/s^2] and gyro bias [rad/s].
    g : float
        Gravity [m/s^2].
    gain_sigma : float
        1 sigma of the relative Weinberg gain error.
    speed_mps : float
        Speed along the path [m/s].
    noise : units.SensorSpec or None
        White noise added to the model (None: no process noise).
    realisation : tuple of ndarray or None
        ``(dv0, ba, bg, dG)`` read as one error realisation (parameter file).
    spec : units.SensorSpec or None
        The IMU of an IMU case (drives the nonlinear Monte Carlo).
    """

    name: str
    title: str
    dv0: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    g: float
    gain_sigma: float
    speed_mps: float
    noise: units.SensorSpec | None = None
    realisation: tuple | None = None
    spec: units.SensorSpec | None = None


CurveCase.__init__ = renamed_keywords(speed="speed_mps")(CurveCase.__init__)
CurveCase.speed = renamed_attribute("CurveCase", "speed", "speed_mps")


def _drop_bgz(bg):
    bg = np.array(bg, dtype=float)
    bg[2] = 0.0  # z axis: common heading error, left out as in the paper
    return bg


def case_from_params(params, noise_spec=PARAMS_NOISE_SPEC) -> CurveCase:
    """The case of a parameter file (values read as 1 sigma).

    The absolute values of the file's dv0, b_a and b_g become the 1 sigmas
    (the gyro z sigma set to zero, as in the paper), ``dG[0]`` the gain-error
    sigma and ``morpi_speed_mps`` the speed; the signed values are kept as the
    case's one realisation.

    Parameters
    ----------
    params : params.ErrorParams
        The error parameters.
    noise_spec : units.SensorSpec, optional
        Noise used when ``params.process_noise`` is true (default
        :data:`PARAMS_NOISE_SPEC`, the MPU-6500).

    Returns
    -------
    CurveCase
        A case named ``"params"`` whose title names the file.

    Examples
    --------
    >>> from morpi_filters.params import params_from_dict
    >>> p = params_from_dict({"dv0_mps": [0.03, -0.04, 0.0], "accel_bias_mps2": [0.0] * 3,
    ...                       "gyro_bias_radps": [0.001, 0.002, 0.003], "g_mps2": 9.81, "dG": [-0.1]})
    >>> case = case_from_params(p)
    >>> case.name, case.dv0.tolist(), case.bg.tolist(), case.gain_sigma, case.noise is None
    ('params', [0.03, 0.04, 0.0], [0.001, 0.002, 0.0], 0.1, True)
    """
    return CurveCase(
        name="params", title=f"parameter file {params.label}", dv0=np.abs(params.dv0), ba=np.abs(params.ba),
        bg=_drop_bgz(np.abs(params.bg)), g=params.g, gain_sigma=abs(params.dG[0]), speed_mps=params.morpi_speed_mps,
        noise=noise_spec if params.process_noise else None,
        realisation=(params.dv0, params.ba, _drop_bgz(params.bg), params.dG[0]),
    )


def case_from_sensor(spec, params, title: str | None = None) -> CurveCase:
    """The case of one IMU: datasheet biases, `params` for the rest.

    Parameters
    ----------
    spec : units.SensorSpec
        Turn-on biases as 1 sigma per axis (the gyro z sigma set to zero, as in
        the paper); its noise when ``params.process_noise`` is true.
    params : params.ErrorParams
        Initial velocity error (absolute values, as 1 sigma), gravity, gain
        error (``dG[0]``) and speed.
    title : str, optional
        The case's title on the page (default the IMU's name).

    Returns
    -------
    CurveCase
        A case named after the IMU (lower case, no hyphen), without a
        realisation, with `spec` kept for the nonlinear Monte Carlo.

    Examples
    --------
    >>> from morpi_filters import units
    >>> from morpi_filters.params import load_params
    >>> case = case_from_sensor(units.LSM6DSL, load_params(), title=PAPER_IMU_TITLES["LSM6DSL"])
    >>> case.name, case.title
    ('lsm6dsl', 'LSM6DSL (S8)')
    >>> bool(np.all(case.ba == units.LSM6DSL.accel_bias)), float(case.bg[2])
    (True, 0.0)
    """
    return CurveCase(
        name=spec.name.lower().replace("-", ""), title=spec.name if title is None else str(title),
        dv0=np.abs(params.dv0), ba=np.full(3, spec.accel_bias), bg=_drop_bgz(np.full(3, spec.gyro_bias)),
        g=params.g, gain_sigma=abs(params.dG[0]), speed_mps=params.morpi_speed_mps,
        noise=spec if params.process_noise else None, spec=spec,
    )


def _keys(dv0, ba, bg, g):
    return {"dv0_mps": [float(v) for v in dv0], "accel_bias_mps2": [float(v) for v in ba],
            "gyro_bias_radps": [float(v) for v in bg], "g_mps2": float(g)}


def case_mean_square(case: CurveCase, t, kind):
    """Expected squared horizontal error of the paper's linearized closed form.

    ``E[dp_x^2 + dp_y^2]`` for independent zero-mean errors with the case's
    1-sigma values, from :func:`morpi_filters.symbolic.closed_form_mean_square`
    (``linearized=True``, z up, ``b_gz`` dropped), e.g. for the 3D INS::

        (s_vx^2 + s_vy^2) t^2 + (s_ax^2 + s_ay^2) t^4 / 4 + g^2 (s_gx^2 + s_gy^2) t^6 / 36

    and for ``"MoRPI-aided INS"`` the paper's MoRPI-A distance error
    ``ds = dG v t`` (:func:`morpi_filters.symbolic.morpi_error`): ``(s_G speed t)^2``.

    Parameters
    ----------
    case : CurveCase
        The 1-sigma errors.
    t : array_like, shape (n,)
        Times [s].
    kind : {"INS-3D", "INS-2D", "MoRPI-aided INS"}
        A name of :data:`CURVE_METHODS`.

    Returns
    -------
    ndarray, shape (n,)
        Mean squared horizontal error [m^2].

    Raises
    ------
    ParameterError
        For a `kind` not in :data:`CURVE_METHODS`.

    Examples
    --------
    A velocity error of 1 sigma (0.03, 0.04) m/s grows as (0.05 t)^2:

    >>> from morpi_filters.params import params_from_dict
    >>> p = params_from_dict({"dv0_mps": [0.03, 0.04, 0.0], "accel_bias_mps2": [0.0] * 3, "gyro_bias_radps": [0.0] * 3,
    ...                       "g_mps2": 9.81, "dG": [0.1], "morpi_speed_mps": 0.5})
    >>> np.sqrt(case_mean_square(case_from_params(p), [0.0, 1.0, 2.0], "INS-3D")).round(12).tolist()
    [0.0, 0.05, 0.1]
    >>> case_mean_square(case_from_params(p), [4.0], "MoRPI-aided INS").round(12).tolist()  # (0.1 * 0.5 * 4)^2
    [0.04]
    """
    from . import symbolic

    t = np.asarray(t, dtype=float)
    if kind == "MoRPI-aided INS":
        return (case.gain_sigma * case.speed_mps * t) ** 2
    if kind not in ("INS-3D", "INS-2D"):
        raise ParameterError(f"kind {kind!r}: expected one of {', '.join(CURVE_METHODS)}")
    return symbolic.closed_form_mean_square(_keys(case.dv0, case.ba, case.bg, case.g), t, kind, "z_up",
                                            linearized=True, keep_bgz=False)


@renamed_keywords(speed="speed_mps")
def error_realisation(dv0, ba, bg, dG, g, speed_mps, t, kind):
    """Horizontal error of one realisation of the paper's closed form (z up, ``b_gz`` dropped).

    From :func:`morpi_filters.symbolic.closed_form_errors`: the paper's
    polynomials with ``alpha = g + b_az``; for ``"MoRPI-aided INS"`` the
    MoRPI-A distance error ``|dG| speed_mps t``.

    Parameters
    ----------
    dv0 : array_like, shape (3,)
        Initial velocity error [m/s].
    ba : array_like, shape (3,)
        Accelerometer bias [m/s^2].
    bg : array_like, shape (3,)
        Gyro bias [rad/s] (the z component does not enter).
    dG : float
        Relative Weinberg gain error (MoRPI only).
    g : float
        Gravity magnitude [m/s^2].
    speed_mps : float
        Speed along the path [m/s] (MoRPI only).
    t : array_like, shape (n,)
        Times [s].
    kind : {"INS-3D", "INS-2D", "MoRPI-aided INS"}
        A name of :data:`CURVE_METHODS`.

    Returns
    -------
    ndarray, shape (n,)
        Horizontal distance error [m].

    Raises
    ------
    ParameterError
        For a `kind` not in :data:`CURVE_METHODS`.

    Examples
    --------
    >>> error_realisation([0.03, 0.04, 0.0], [0.0] * 3, [0.0] * 3, 0.1, 9.81, 0.5, [0.0, 2.0], "INS-2D").round(12).tolist()
    [0.0, 0.1]
    >>> error_realisation([0.0] * 3, [0.0] * 3, [0.0] * 3, -0.1, 9.81, 0.5, [2.0], "MoRPI-aided INS").round(12).tolist()
    [0.1]
    """
    from . import symbolic

    t = np.asarray(t, dtype=float)
    if kind == "MoRPI-aided INS":
        return np.abs(dG) * speed_mps * t
    if kind not in ("INS-3D", "INS-2D"):
        raise ParameterError(f"kind {kind!r}: expected one of {', '.join(CURVE_METHODS)}")
    return symbolic.closed_form_errors(_keys(dv0, ba, bg, g), t, kind, "z_up", keep_bgz=False)


@renamed_keywords(dt="dt_s", step_period="step_period_s")
def time_grid(times, dt_s, step_period_s=None):
    """Epochs of a run: a uniform grid plus the requested times and step times.

    Times are merged after rounding to 1e-9 s, so a requested time or a step
    time that falls on the uniform grid is one epoch.

    Parameters
    ----------
    times : array_like, shape (m,)
        Requested times [s], >= 0; the grid ends at the largest.
    dt_s : float
        Nominal time step [s].
    step_period_s : float, optional
        MoRPI step period [s]: steps at ``step_period_s``, ``2 step_period_s``, ...
        up to the last time.

    Returns
    -------
    grid : ndarray, shape (n + 1,)
        Epoch times [s]: sorted, unique, starting at 0.
    steps : ndarray of int
        Epoch indices of the MoRPI steps (empty without `step_period_s`).
    at : ndarray of int, shape (m,)
        Epoch index of each requested time.

    Examples
    --------
    >>> grid, steps, at = time_grid([0.5, 1.0], 0.3, step_period_s=0.4)
    >>> grid.tolist(), steps.tolist(), at.tolist()
    ([0.0, 0.3, 0.4, 0.5, 0.6, 0.8, 0.9, 1.0], [2, 5], [3, 7])
    """
    times = np.asarray(times, dtype=float)
    T = float(times.max()) if times.size else 0.0
    parts = [np.arange(0.0, T, dt_s), [T], times]
    st = np.zeros(0)
    if step_period_s is not None:
        st = np.arange(1, int(np.floor(T / step_period_s + 1e-9)) + 1) * step_period_s
        parts.append(st)
    grid = np.unique(np.round(np.concatenate(parts), 9))
    at = np.searchsorted(grid, np.round(times, 9))
    steps = np.searchsorted(grid, np.round(st, 9))
    return grid, steps.astype(int), at.astype(int)


@dataclass(frozen=True)
class CaseCurves:
    """Every curve of one case, on a dense time grid.

    Attributes
    ----------
    case : CurveCase
    times : ndarray, shape (n,)
        Dense grid [s].
    sigma : dict of str -> ndarray, shape (n,)
        Filter horizontal 1 sigma per method (:data:`CURVE_METHODS`) [m].
    rms_closed_form : dict of str -> ndarray, shape (n,)
        Closed-form RMS per method [m].
    realisation : dict of str -> ndarray, shape (n,)
        Closed-form error of one realisation per method [m] (empty when the
        case has none).
    mc_times : ndarray, shape (nm,)
    mc_rms : dict of str -> ndarray, shape (nm,)
        Monte Carlo RMS of the horizontal error per method [m].
    mc_runs : int
    nl_times, nl_rms, nl_runs, nl_eval_index
        Nonlinear Monte Carlo (synthesized IMU through the strapdown) of the
        INS methods, IMU cases only (empty otherwise).
    field : dict
        Field end points per method: lists of (duration [s], error [m]).
    """

    case: CurveCase
    times: np.ndarray
    sigma: dict
    rms_closed_form: dict
    realisation: dict
    mc_times: np.ndarray
    mc_rms: dict
    mc_runs: int
    eval_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    eval_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    mc_eval_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    nl_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    nl_rms: dict = field(default_factory=dict)
    nl_runs: int = 0
    nl_eval_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    field: dict = field(default_factory=dict)

    def at_eval_times(self) -> dict:
        """Every curve at the requested times (grid epochs, no interpolation).

        Returns
        -------
        dict
            ``sigma_m``, ``rms_closed_form_m``, and when computed
            ``closed_form_error_m`` (a realisation), ``mc_rms_m`` (linear Monte
            Carlo) and ``nonlinear_mc_rms_m`` (strapdown Monte Carlo): each a
            dict from method name (:data:`CURVE_METHODS`) to an ndarray of shape (m,).

        Examples
        --------
        Without Monte Carlo runs and without a realisation (an IMU case),
        only the filter sigma and the closed-form RMS are there:

        >>> from morpi_filters import units
        >>> from morpi_filters.params import load_params
        >>> case = case_from_sensor(units.LSM6DSL, load_params())
        >>> at = compute_curves(case, times=[1.0, 2.0], runs=0, nonlinear_runs=0).at_eval_times()
        >>> sorted(at), [v.shape for v in at["sigma_m"].values()]
        (['rms_closed_form_m', 'sigma_m'], [(2,), (2,), (2,)])
        """
        out = {"sigma_m": {}, "rms_closed_form_m": {}}
        for k in CURVE_METHODS:
            out["sigma_m"][k] = self.sigma[k][self.eval_index]
            out["rms_closed_form_m"][k] = self.rms_closed_form[k][self.eval_index]
            for key, src, idx in (("closed_form_error_m", self.realisation, self.eval_index),
                                  ("mc_rms_m", self.mc_rms, self.mc_eval_index),
                                  ("nonlinear_mc_rms_m", self.nl_rms, self.nl_eval_index)):
                if k in src:
                    out.setdefault(key, {})[k] = src[k][idx]
        return out


def _models(case: CurveCase):
    """Continuous 3D and planar models and initial covariances of a case."""
    C, f = paper_trajectory(case.g)
    F3, G3 = system_matrix(C, f), noise_coupling(C)
    F2, G2 = planar_system_matrix(0.0, np.zeros(2)), planar_noise_coupling(0.0)
    if case.noise is None:
        Q3, Q2 = np.zeros((G3.shape[1],) * 2), np.zeros((G2.shape[1],) * 2)
    else:
        Q3, Q2 = noise_density(case.noise), planar_noise_density(case.noise)
    P3 = initial_covariance(case.dv0, case.ba, case.bg)
    P2 = np.diag(np.r_[0.0, 0.0, case.dv0[:2] ** 2, 0.0, case.ba[:2] ** 2, case.bg[2] ** 2])
    return (F3, G3, Q3, P3), (F2, G2, Q2, P2)


def _steps(grid):
    # steps of a uniform grid differ in the last bits; rounding to 1e-12 s makes
    # them equal, so that discretize() exponentiates each distinct step once
    return np.round(np.diff(grid), 12)


def _run_methods(case, grid, steps, model, only=None):
    (F3, G3, Q3, P3), (F2, G2, Q2, P2) = _models(case)
    dts = _steps(grid)
    out = {}
    if only in (None, "INS-3D", "MoRPI-aided INS"):
        D3 = discretize(F3, G3, Q3, dts)
        if only in (None, "INS-3D"):
            out["INS-3D"] = run_filter(D3.Phi, D3.Qd, P3, grid)
        if only in (None, "MoRPI-aided INS"):
            Phi_a, Qd_a = augment(D3.Phi, D3.Qd, model)
            meas = [step_update(i, STEP_LENGTH_M, 0.0, model, case.speed_mps) for i in steps]
            out["MoRPI-aided INS"] = run_filter(Phi_a, Qd_a, augment_covariance(P3, model), grid, meas)
    if only in (None, "INS-2D"):
        D2 = discretize(F2, G2, Q2, dts)
        out["INS-2D"] = run_filter(D2.Phi, D2.Qd, P2, grid)
    return out


def _monte_carlo(case, times, model, runs, rng):
    """Linear-model Monte Carlo RMS per method, in chunks of :data:`MC_CHUNK` runs (bounded memory)."""
    period = STEP_LENGTH_M / case.speed_mps
    T = float(np.max(times))
    grid, steps, at = time_grid(times, max(MC_DT, T / MC_MAX_EPOCHS), period)
    dts = _steps(grid)
    (F3, G3, Q3, P3), (F2, G2, Q2, P2) = _models(case)
    n = grid.size - 1
    D3 = discretize(F3, G3, Q3, dts)
    Phi_a, Qd_a = augment(D3.Phi, D3.Qd, model)
    P0a = augment_covariance(P3, model)
    sq = {k: np.zeros(n + 1) for k in CURVE_METHODS}
    sizes = [min(MC_CHUNK, runs - i) for i in range(0, runs, MC_CHUNK)]
    for size, sub in zip(sizes, rng.spawn(len(sizes))):
        rng3, rng2, rngs, rngg = sub.spawn(4)
        X3 = simulate_linear(F3, G3, Q3, P3, dts, n, size, rng3)
        X2 = simulate_linear(F2, G2, Q2, P2, dts, n, size, rng2)
        sq["INS-3D"] += (X3[..., 0] ** 2 + X3[..., 1] ** 2).sum(axis=0)
        sq["INS-2D"] += (X2[..., 0] ** 2 + X2[..., 1] ** 2).sum(axis=0)
        gain = model.gain_sigma * rngg.standard_normal(size)
        meas = simulate_steps(X3, steps, STEP_LENGTH_M, 0.0, model, case.speed_mps, gain, rngs)
        r = run_filter(Phi_a, Qd_a, P0a, grid, meas)
        e = r.x[..., DP][..., :2] - X3[..., DP][..., :2]
        sq["MoRPI-aided INS"] += (e ** 2).sum(axis=-1).sum(axis=0)
    return grid, {k: np.sqrt(v / runs) for k, v in sq.items()}, at


def _nonlinear_monte_carlo(case, times, runs, rng):
    """RMS horizontal error of 3D/2D strapdown runs on synthesized IMU data at rest.

    The IMU (``simulate.imu``, the case's datasheet spec: turn-on biases on
    all three axes, white noise when the case has process noise) is at rest
    with ``C = I`` (the nominal trajectory); each run starts with a velocity
    error drawn from the case's 1 sigma. The result includes the second-order
    terms the linear model drops (``b_a x b_g``, ``b_gz``).
    """
    from .simulate import imu, straight
    from .strapdown import ins2d, ins3d

    T = float(np.max(times))
    traj = straight(rest_s=(T + 1.0, 1.0), g=case.g, rate_hz=1.0 / FILTER_DT)
    r_imu, r_v0 = rng.spawn(2)
    data = imu(traj, case.spec, r_imu, runs=runs, time_span=(0.0, T),
               noise_scale=1.0 if case.noise is not None else 0.0)
    v0 = r_v0.standard_normal((runs, 3)) * case.dv0
    rms = {}
    for key, fn, kw in (("INS-3D", ins3d, {"g": case.g}), ("INS-2D", ins2d, {})):
        res = fn(data.time, data.f, data.omega, v0=v0, **kw)
        e = np.asarray(res.position)[..., :2] - traj.at(data.time).position[:, :2]
        rms[key] = np.sqrt((e ** 2).sum(axis=-1).mean(axis=0))
    at = np.searchsorted(np.round(data.time, 9), np.round(np.asarray(times, float), 9))
    return data.time, rms, at.clip(0, data.time.size - 1)


def horizontal_sigma(errors, times, method: str = "INS-3D") -> np.ndarray:
    """The error-state filter's horizontal position 1 sigma at `times`, in one call.

    The covariance of the 15-state filter (3D INS) or the 8-state planar one
    (2D INS, with its own initial covariance: horizontal velocity, horizontal
    accelerometer biases, gyro z bias), or the 3D filter with the MoRPI step
    updates (``"MoRPI-aided INS"``: steps of :data:`STEP_LENGTH_M` at the
    parameters' speed, gain error as an augmented state), on the paper's
    nominal trajectory, from an error-parameter set read as 1 sigma.

    Parameters
    ----------
    errors : params.ErrorParams or CurveCase or units.SensorSpec
        The 1-sigma errors: a parameter file's set (:func:`morpi_filters.params.load_params`,
        ``params_from_dict``), a prepared case, or an IMU's datasheet biases
        (with the default parameter file's initial velocity error, gravity,
        gain error and speed).
    times : array_like, shape (m,)
        Times [s], >= 0, the last > 0.
    method : {"INS-3D", "INS-2D", "MoRPI-aided INS"}, optional
        A name of :data:`CURVE_METHODS` (default ``"INS-3D"``).

    Returns
    -------
    ndarray, shape (m,)
        ``sqrt(var dp_x + var dp_y)`` [m] at the sorted, unique `times`.

    Examples
    --------
    The 3D filter without process noise propagates the closed form's
    covariance exactly:

    >>> from morpi_filters import params
    >>> p = params.load_params()
    >>> sigma = horizontal_sigma(p, [5.0, 15.0], "INS-3D")
    >>> rms = np.sqrt(case_mean_square(case_from_params(p), [5.0, 15.0], "INS-3D"))
    >>> bool(np.allclose(sigma, rms, rtol=1e-9))
    True
    """
    from .params import ErrorParams, load_params

    if method not in CURVE_METHODS:
        raise ParameterError(f"method {method!r}: expected one of {', '.join(CURVE_METHODS)}")
    if isinstance(errors, units.SensorSpec):
        case = case_from_sensor(errors, load_params())
    elif isinstance(errors, ErrorParams):
        case = case_from_params(errors)
    elif isinstance(errors, CurveCase):
        case = errors
    else:
        raise ParameterError(f"errors: {type(errors).__name__}, expected params.ErrorParams, curves.CurveCase or "
                             "units.SensorSpec")
    times = np.unique(np.asarray(times, dtype=float))
    if times.size == 0 or not np.all(np.isfinite(times)) or times.min() < 0 or times.max() <= 0:
        raise ParameterError(f"times: expected finite times >= 0 s with the last > 0, got {times.tolist()}")
    grid, steps, at = time_grid(times, FILTER_DT, STEP_LENGTH_M / case.speed_mps)
    res = _run_methods(case, grid, steps, StepModel(gain_sigma=case.gain_sigma), only=method)
    return res[method].horizontal_sigma[at]


def compute_curves(case: CurveCase, times=DEFAULT_TIMES, runs=MC_RUNS, rng=None, nonlinear_runs=NL_RUNS) -> CaseCurves:
    """All curves of one case from 0 to the last of `times`.

    Parameters
    ----------
    case : CurveCase
        The 1-sigma errors (and, optionally, one realisation and an IMU spec).
    times : array_like, shape (m,), optional
        Requested times [s], >= 0, last > 0; they are epochs of every grid
        (default :data:`DEFAULT_TIMES`, 0 to 15 s).
    runs : int, optional
        Linear Monte Carlo runs (default :data:`MC_RUNS`; 0 skips the Monte Carlo).
    rng : numpy.random.Generator, optional
        Generator of the Monte Carlo draws; required when a Monte Carlo runs
        (`runs` > 0, or the nonlinear one), unused otherwise.
    nonlinear_runs : int, optional
        Runs of the nonlinear (strapdown) Monte Carlo of an IMU case (default
        :data:`NL_RUNS`; 0 skips it). It runs only when ``case.spec`` is set and
        the last time is at most :data:`NL_MAX_T`.

    Returns
    -------
    CaseCurves
        The filter sigma and the closed-form RMS of every method on the filter's
        grid (:data:`FILTER_DT` plus the times and step times), the realisation
        when the case has one, and the Monte Carlo curves that were run.

    Raises
    ------
    ParameterError
        For empty, non-finite or negative times, a last time of 0, or a Monte
        Carlo without a Generator `rng`.

    Examples
    --------
    With only an initial velocity error, the filter's 1 sigma of both INS equals
    the closed form ``|s_dv| t``; the MoRPI steps bound the aided one:

    >>> from morpi_filters.params import params_from_dict
    >>> p = params_from_dict({"dv0_mps": [0.03, 0.04, 0.0], "accel_bias_mps2": [0.0] * 3, "gyro_bias_radps": [0.0] * 3,
    ...                       "g_mps2": 9.81, "dG": [0.1], "morpi_speed_mps": 0.5})
    >>> cc = compute_curves(case_from_params(p), times=[1.0, 2.0], runs=20, rng=np.random.default_rng(0))
    >>> at = cc.at_eval_times()
    >>> sorted(at)
    ['closed_form_error_m', 'mc_rms_m', 'rms_closed_form_m', 'sigma_m']
    >>> {k: v.round(6).tolist() for k, v in at["sigma_m"].items() if k != "MoRPI-aided INS"}
    {'INS-3D': [0.05, 0.1], 'INS-2D': [0.05, 0.1]}
    >>> bool(at["sigma_m"]["MoRPI-aided INS"][1] < 0.1)
    True
    """
    times = np.unique(np.asarray(times, dtype=float))
    if times.size == 0 or not np.all(np.isfinite(times)) or times.min() < 0 or times.max() <= 0:
        raise ParameterError(f"times: expected finite times >= 0 s with the last > 0, got {times.tolist()}")
    nonlinear = bool(nonlinear_runs and case.spec is not None and times.max() <= NL_MAX_T)
    if (runs or nonlinear) and not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng: {type(rng).__name__}, expected a numpy.random.Generator for the Monte Carlo "
                             f"draws (runs={runs}, nonlinear_runs={nonlinear_runs})")
    model = StepModel(gain_sigma=case.gain_sigma)
    period = STEP_LENGTH_M / case.speed_mps
    grid, steps, at = time_grid(times, FILTER_DT, period)
    res = _run_methods(case, grid, steps, model)
    sigma = {k: r.horizontal_sigma for k, r in res.items()}
    rms = {k: np.sqrt(case_mean_square(case, grid, k)) for k in CURVE_METHODS}
    real = {}
    if case.realisation is not None:
        dv0, ba, bg, dG = case.realisation
        real = {k: error_realisation(dv0, ba, bg, dG, case.g, case.speed_mps, grid, k)
                for k in CURVE_METHODS}
    mc_t, mc, mc_at = np.zeros(0), {}, np.zeros(0, int)
    r_lin, r_nl = rng.spawn(2) if rng is not None else (None, None)
    if runs:
        mc_t, mc, mc_at = _monte_carlo(case, times, model, runs, r_lin)
    nl_t, nl, nl_at = np.zeros(0), {}, np.zeros(0, int)
    if nonlinear:
        nl_t, nl, nl_at = _nonlinear_monte_carlo(case, times, nonlinear_runs, r_nl)
    return CaseCurves(case=case, times=grid, sigma=sigma, rms_closed_form=rms, realisation=real,
                      mc_times=mc_t, mc_rms=mc, mc_runs=runs, eval_times=times, eval_index=at,
                      mc_eval_index=mc_at, nl_times=nl_t, nl_rms=nl, nl_runs=nonlinear_runs if nl else 0,
                      nl_eval_index=nl_at)


def _field_points(source, data=None):
    """End-point errors of the field INS straight-line runs, or why there are none.

    Each recording the dataset's manifest labels straight along one straight
    segment (:meth:`morpi_filters.field.FieldData.straight_line_recordings`)
    is calibrated (GAC, the paper's best for INS) and integrated by the 3D and
    2D strapdown over the robot's motion, as the field evaluation does
    (:class:`morpi_filters.field.FieldData`), and compared with its route's
    end point.

    Returns
    -------
    points : dict of str -> list of (duration [s], end-point error [m])
    note : str
    """
    if source is None or source.root is None:
        return {}, "no data source configured, so no field end points are drawn"
    from .field import FieldData

    data = data if data is not None else FieldData(source.root)
    recs = data.straight_line_recordings()
    if not recs:
        return {}, "the dataset has no straight-line recordings (motion = \"straight\" along one straight segment)"
    pts, skipped, lengths = {"INS-3D": [], "INS-2D": []}, 0, set()
    for rec in recs:
        end_point, distance = data.run_truth(rec)
        for key in ("INS-3D", "INS-2D"):
            try:
                res = data.ins(rec, "GAC", key)
            except MorpiError:
                skipped += 1
                continue
            lengths.add(distance)
            end = np.asarray(res.position)[-1, :2]
            pts[key].append((float(res.time[-1] - res.time[0]), float(np.linalg.norm(end - end_point))))
    if not pts["INS-3D"]:
        return {}, "no straight-line recording of the dataset could be integrated"
    note = (f"{len(pts['INS-3D'])} straight-line recordings ({', '.join(f'{d:g}' for d in sorted(lengths))} m, GAC "
            f"calibration, INS over the robot's motion as in the tables section); end-point error against duration"
            + (f"; {skipped} INS runs skipped (no rest or no motion found)" if skipped else "")
            + ". MoRPI runs are compared per table cell below")
    return pts, note


@dataclass(frozen=True)
class CurvesStudy:
    """The curves section computed once.

    Attributes
    ----------
    params : params.ErrorParams
        The parameter file (values read as 1 sigma).
    times : ndarray, shape (m,)
        Evaluation times [s].
    cases : tuple of CaseCurves
        The parameter-file case and the two IMU cases, each with the field end points.
    field_points : dict
        Method -> list of (duration [s], end-point error [m]) of the field
        straight-line runs (:func:`_field_points`).
    field_note : str
        Where the field points come from, or why there are none.
    seed : int
        Seed of the Monte Carlo draws (each case draws from
        ``numpy.random.default_rng(seed)``).
    synthetic : bool
        Whether the recordings are synthetic.
    """

    params: object
    times: np.ndarray
    cases: tuple
    field_points: dict
    field_note: str
    seed: int
    synthetic: bool = False


@renamed_keywords(source="data_source")
def curves_study(*, params_path=None, times=None, data_source=None, tables=None, seed: int = MC_SEED) -> CurvesStudy:
    """Compute the ``curves`` section (``morpi curves``, ``morpi report``).

    Runs :func:`compute_curves` with its default Monte Carlo sizes on three
    cases: the parameter file, the MPU-6500 and the LSM6DSL. That takes
    seconds, so this function has no example; see :func:`compute_curves`.

    Parameters
    ----------
    params_path : path-like, optional
        Parameter file (values read as 1 sigma); default the committed one.
    times : sequence of float, optional
        Evaluation times [s] (default :data:`DEFAULT_TIMES`, 0 to 15 s).
    data_source : results.DataSource or None, optional
        Recordings for the field end points (none when None).
    tables : evaluate.TablesResult, optional
        The field evaluation of ``data_source.root`` when already computed (its
        cached recordings are reused).
    seed : int, optional
        Seed of the Monte Carlo draws, >= 0 (default :data:`MC_SEED`, the seed
        of ``morpi curves``): every case draws from its own
        ``numpy.random.default_rng(seed)`` (the same numbers for each case).

    Returns
    -------
    CurvesStudy
        The parameters, the sorted unique times, the three cases' curves (each
        carrying the field end points) and the field note.
    """
    from .params import load_params

    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0")
    params = load_params(params_path)
    times = np.unique(np.asarray(DEFAULT_TIMES if not times else times, dtype=float))
    cases = [case_from_params(params)] + [case_from_sensor(s, params, PAPER_IMU_TITLES[s.name])
                                          for s in (units.MPU6500, units.LSM6DSL)]
    field_pts, field_note = _field_points(data_source, tables.data if tables is not None else None)
    curves = tuple(replace(compute_curves(case, times, rng=np.random.default_rng(int(seed))), field=field_pts)
                   for case in cases)
    return CurvesStudy(params=params, times=times, cases=curves, field_points=field_pts, field_note=field_note,
                       synthetic=bool(data_source is not None and data_source.synthetic), seed=int(seed))
