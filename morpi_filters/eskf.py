"""Error-state Kalman filter on filterpy: INS covariance propagation and MoRPI updates.

The filter estimates the error state of :mod:`morpi_filters.error_model`
(``[dp, dv, eps, b_a, b_g]``, computed minus true) and drives a
:class:`filterpy.kalman.KalmanFilter`: at every detected MoRPI step
``kf.update(z, R=R, H=H)`` (its per-call overrides; ``kf.F`` is never touched).
Between updates the prediction of every IMU epoch is filterpy's
``predict(F=Phi_k, Q=Qd_k)`` written out with the same numpy calls
(``x = dot(F, x)``, ``P = dot(dot(F, P), F.T) + Q``, bit for bit the same numbers)
without the copies of the prior that ``predict`` keeps for its smoother: those
copies and the call's bookkeeping cost more than the prediction itself on 15
states. filterpy's
update is the Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T``; the
filter symmetrizes P after every update and state reset.

:func:`run_filter` runs the filter on given ``Phi, Qd`` stacks and
measurements (covariance analysis, Monte Carlo runs batched over a leading
axis). The closed-loop MoRPI-aided INS on recorded or simulated IMU data is
:mod:`morpi_filters.aided`.

MoRPI step pseudo-measurement
-----------------------------
MoRPI measures the distance travelled over one period of the periodic path,
``s_M = G (max f_y - min f_y)^(1/4)``, and places it along the INS heading.
The filter compares, over the same step, the INS displacement with the MoRPI
displacement (horizontal, 2 components)::

    z = (p_ins(t_k) - p_ins(t_c)) - s_M u(psi_hat)

where ``t_c`` is the start of the step (the previous peak) and ``u = (cos psi, sin psi)``. To first
order, with ``x_g`` the relative gain error (``s_M = (1 + x_g) s + n``) and
``J = [[0, -1], [1, 0]]``::

    z = (dp(t_k) - dp(t_c))_xy - s u x_g - s J u (eps_z(t_k) + eps_z(t_c)) / 2 - n

The heading error enters through the mean of its two end values (exact for a
heading error growing linearly over the step, i.e. a constant ``b_gz``). The
step-start values come from a *clone* of ``dp`` and ``eps`` held in the
augmented state (stochastic cloning) and reset to the current values after
each update. The gain error ``x_g`` is a bias shared by every step (a wrong
gain is not white noise), so it is an augmented constant state by default;
with ``augment_gain=False`` its variance is added to R as if it were white,
which is inconsistent over many steps and is offered for comparison only.

R of one step, along and across the step direction::

    var_along = (s sigma_step)^2 + 2 (speed sigma_jitter)^2 [+ (s sigma_gain)^2 without the gain state]
    var_cross = sigma_cross^2

The jitter term: each peak time is off by ``N(0, sigma_jitter^2)``, so the
true displacement between the detected peaks differs from ``s`` by
``speed (j_k - j_c)``. Consecutive steps share one peak, so this error is a
moving average of order one; treating it as white overstates its effect on a
long sum of steps (the sum telescopes), a conservative approximation.

Augmented state layout: the 15 core states, then :data:`C_DP` (3),
:data:`C_EPS` (3) and, with the gain state, :data:`GAIN` (1).

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
  IEEE J. Indoor and Seamless Positioning and Navigation, 2023.
- [2] R. Labbe, FilterPy, ``filterpy.kalman.KalmanFilter`` (predict/update overrides, Joseph form).
- [3] S. I. Roumeliotis and J. W. Burdick, "Stochastic cloning: a generalized
  framework for processing relative state measurements", ICRA 2002.
  doi:10.1109/ROBOT.2002.1014801
- [4] Y. Bar-Shalom, X. R. Li and T. Kirubarajan, "Estimation with Applications
  to Tracking and Navigation", Wiley, 2001, sec. 5.4 (NEES, NIS, chi-square bands).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from filterpy.kalman import KalmanFilter
from numpy import dot
from scipy.stats import chi2

from .error_model import DP, EPS, N_STATES, STATE_NAMES
from .deprecation import renamed_keywords
from .errors import ParameterError

__all__ = [
    "C_DP", "C_EPS", "GAIN", "AUG_STATE_NAMES", "Measurement", "FilterResult", "StepModel",
    "initial_covariance", "augment", "augment_covariance", "clone_reset", "step_update", "step_z",
    "run_filter", "propagate_covariance", "SYMMETRIZE_EVERY", "nees", "nis", "chi2_band", "simulate_steps",
]

#: Clone of the position error at the previous step (augmented state).
C_DP = slice(15, 18)
#: Clone of the misalignment at the previous step (augmented state).
C_EPS = slice(18, 21)
#: Relative Weinberg gain error (augmented constant state).
GAIN = slice(21, 22)
#: Names of the augmented states.
AUG_STATE_NAMES = STATE_NAMES + tuple("c_" + n for n in STATE_NAMES[DP] + STATE_NAMES[EPS]) + ("gain",)

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


@dataclass(frozen=True)
class Measurement:
    """One measurement update at one epoch.

    Attributes
    ----------
    index : int
        Epoch index; the update follows the prediction into this epoch.
    z : ndarray, shape (m,) or (runs, m)
        Measurement (one per Monte Carlo run when 2-D); None with ``H=None``.
    H : ndarray, shape (m, k) or None
        None for a reset-only event (no update).
    R : ndarray, shape (m, m) or None
    reset : ndarray, shape (k, k) or None
        Linear state reset applied after the update (``x = T x``,
        ``P = T P T^T``), e.g. re-cloning the step-start states.
    """

    index: int
    z: np.ndarray
    H: np.ndarray
    R: np.ndarray
    reset: np.ndarray | None = None


@dataclass(frozen=True)
class FilterResult:
    """Output of :func:`run_filter`.

    Attributes
    ----------
    times : ndarray, shape (n + 1,)
        Epoch times [s].
    x : ndarray, shape (n + 1, k) or (runs, n + 1, k)
        Posterior error-state estimate per epoch.
    sigma : ndarray, shape (n + 1, k)
        Posterior standard deviation per state (sqrt of diag P).
    P_end : ndarray, shape (k, k)
        Final covariance.
    update_index : ndarray of int, shape (u,)
        Epoch index of each update.
    innovations : ndarray, shape (u, m) or (runs, u, m)
        ``z - H x_prior`` per update.
    S : ndarray, shape (u, m, m)
        Innovation covariance per update.
    normalized_innovations : ndarray, shape (u, m) or (runs, u, m)
        Innovations whitened by ``S``: ``L^-1 y`` with ``S = L L^T``; each
        component is N(0, 1) for a consistent filter.
    P : ndarray, shape (len(P_index), k, k) or None
        Covariances kept at the epochs `P_index`.
    P_index : ndarray of int
        Epochs of `P`.
    state_names : tuple of str
    """

    times: np.ndarray
    x: np.ndarray
    sigma: np.ndarray
    P_end: np.ndarray
    update_index: np.ndarray
    innovations: np.ndarray
    S: np.ndarray
    normalized_innovations: np.ndarray
    P: np.ndarray | None = None
    P_index: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    state_names: tuple = STATE_NAMES

    @property
    def horizontal_sigma(self) -> np.ndarray:
        """Horizontal position 1 sigma ``sqrt(var dp_x + var dp_y)`` [m], shape (n + 1,)."""
        return np.sqrt(self.sigma[:, 0] ** 2 + self.sigma[:, 1] ** 2)

    @property
    def nis(self) -> np.ndarray:
        """Normalized innovation squared per update, shape (u,) or (runs, u)."""
        return (self.normalized_innovations ** 2).sum(axis=-1)


@dataclass(frozen=True)
class StepModel:
    """Error model of one MoRPI step (the Weinberg distance of one period).

    Attributes
    ----------
    gain_sigma : float
        1 sigma of the relative gain error (fraction of the gain); a bias shared
        by every step.
    augment_gain : bool
        Estimate the gain error as an augmented constant state (default). When
        False its variance is added to R of every step (white; inconsistent).
    jitter_s : float
        1 sigma of the peak-detection time jitter [s].
    step_sigma : float
        1 sigma of the step-to-step (white) relative error of the Weinberg length.
    cross_sigma_m : float
        1 sigma of the cross-track error of one step [m].
    """

    gain_sigma: float = 0.05
    augment_gain: bool = True
    jitter_s: float = 0.01
    step_sigma: float = 0.02
    cross_sigma_m: float = 0.02

    def __post_init__(self):
        for name in ("gain_sigma", "jitter_s", "step_sigma", "cross_sigma_m"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ParameterError(f"StepModel.{name}: {v!r} must be a finite number >= 0")

    @property
    def n_states(self) -> int:
        """Size of the augmented state."""
        return GAIN.stop if self.augment_gain else C_EPS.stop


def initial_covariance(dv0=0.0, ba=0.0, bg=0.0, dp0=0.0, eps0=0.0):
    """Diagonal initial covariance of the 15 states from 1-sigma values.

    Parameters
    ----------
    dv0, ba, bg, dp0, eps0 : float or array_like, shape (3,)
        1 sigma per axis: initial velocity error [m/s], accelerometer bias
        [m/s^2], gyro bias [rad/s], initial position error [m], initial
        misalignment [rad].

    Returns
    -------
    P0 : ndarray, shape (15, 15)
        Diagonal covariance holding the squared 1-sigma values, in the state
        order ``[dp, dv, eps, b_a, b_g]`` (units of the squared states).

    Examples
    --------
    >>> P0 = initial_covariance(dv0=0.1)
    >>> P0.shape, float(P0[3, 3]), float(P0[0, 0])
    ((15, 15), 0.010000000000000002, 0.0)
    """
    from .error_model import BA, BG, DV

    d = np.zeros(N_STATES)
    for sl, name, v in ((DP, "dp0", dp0), (DV, "dv0", dv0), (EPS, "eps0", eps0), (BA, "ba", ba), (BG, "bg", bg)):
        v = np.broadcast_to(np.asarray(v, dtype=float), (3,))
        if not np.all(np.isfinite(v)):
            raise ParameterError(f"initial_covariance: {name} must be finite, got {v}")
        d[sl] = v ** 2
    return np.diag(d)


def augment(Phi, Qd, model: StepModel):
    """Embed core ``Phi, Qd`` into the augmented state (clones and gain constant).

    Parameters
    ----------
    Phi, Qd : ndarray, shape (15, 15) or (n, 15, 15)
        Core transition matrix (dimensionless per state pair, units of the
        states it maps) and discrete process noise (units of the squared
        states) of one step, or one per step.
    model : StepModel
        Step error model; its ``augment_gain`` sets the size ``k`` of the
        augmented state (21 without, 22 with the gain state).

    Returns
    -------
    Phi_a, Qd_a : tuple of ndarray, shape (k, k) or (n, k, k), ``k = model.n_states``
        ``Phi`` in the core block and identity on the clone and gain states
        (held constant by the prediction); ``Qd`` in the core block and zeros
        elsewhere.

    Examples
    --------
    >>> Phi_a, Qd_a = augment(np.eye(15), 0.01 * np.eye(15), StepModel())
    >>> Phi_a.shape, float(Phi_a[21, 21]), float(Qd_a[0, 0]), float(Qd_a[21, 21])
    ((22, 22), 1.0, 0.01, 0.0)
    """
    k = model.n_states
    Phi = np.asarray(Phi, dtype=float)
    Phi_a = np.zeros(Phi.shape[:-2] + (k, k))
    Phi_a[..., :N_STATES, :N_STATES] = Phi
    idx = np.arange(N_STATES, k)
    Phi_a[..., idx, idx] = 1.0
    Qd_a = np.zeros_like(Phi_a)
    Qd_a[..., :N_STATES, :N_STATES] = Qd
    return Phi_a, Qd_a


def clone_reset(k):
    """The reset that copies ``dp, eps`` into their clones, shape (k, k).

    Parameters
    ----------
    k : int
        Size of the augmented state (21 or 22, see :attr:`StepModel.n_states`).

    Returns
    -------
    T : ndarray, shape (k, k)
        Identity, except that the rows of :data:`C_DP` and :data:`C_EPS` pick
        ``dp`` and ``eps`` (``x = T x`` sets the clones to the current values).

    Examples
    --------
    >>> T = clone_reset(22)
    >>> T.shape, float(T[15, 0]), float(T[15, 15]), float(T[21, 21])
    ((22, 22), 1.0, 0.0, 1.0)
    """
    return _clone_reset(k)


def _clone_reset(k):
    T = np.eye(k)
    for c, s in ((C_DP, DP), (C_EPS, EPS)):
        T[c, :] = 0.0
        T[c, s] = np.eye(3)
    return T


def augment_covariance(P0, model: StepModel):
    """Augmented initial covariance: clones equal to their states, gain prior.

    Parameters
    ----------
    P0 : ndarray, shape (15, 15)
        Initial covariance of the core states (units of the squared states,
        e.g. from :func:`initial_covariance`).
    model : StepModel
        Step error model: the size ``k = model.n_states`` and, with
        ``augment_gain``, the gain prior ``gain_sigma ** 2`` (dimensionless).

    Returns
    -------
    P0_a : ndarray, shape (k, k)
        Augmented covariance: the clones are fully correlated with ``dp`` and
        ``eps`` (equal to them), the gain state is uncorrelated.

    Examples
    --------
    >>> Pa = augment_covariance(initial_covariance(dp0=1.0), StepModel())
    >>> Pa.shape, float(Pa[15, 15]), float(Pa[0, 15]), round(float(Pa[21, 21]), 6)
    ((22, 22), 1.0, 1.0, 0.0025)
    """
    k = model.n_states
    P = np.zeros((k, k))
    P[:N_STATES, :N_STATES] = P0
    if model.augment_gain:
        P[GAIN, GAIN] = model.gain_sigma ** 2
    T = _clone_reset(k)
    return T @ P @ T.T


@renamed_keywords(speed="speed_mps")
def step_update(index, length, psi, model: StepModel, speed_mps, z=None):
    """The MoRPI step pseudo-measurement at one detected step.

    Parameters
    ----------
    index : int
        Epoch of the step's end peak.
    length : float
        Step length ``s`` [m] (nominal, or the MoRPI value).
    psi : float
        Heading of the step [rad].
    model : StepModel
        Step error model (the sigmas of R and whether the gain is a state).
    speed_mps : float
        Speed along the path [m/s] (jitter term of R).
    z : array_like, shape (2,) or (runs, 2), optional
        The measurement [m] (see :func:`step_z`); zeros for a covariance analysis.

    Returns
    -------
    Measurement
        ``H`` of shape (2, k), ``R`` of shape (2, 2) [m^2], ``z`` as given,
        with the clone reset (:func:`clone_reset`) attached.

    Examples
    --------
    A 1 m step heading along x at 1 m/s: ``var_along = 0.02^2 + 2 * 0.01^2``,
    ``var_cross = 0.02^2``; the gain column is ``-s u``.

    >>> m = step_update(10, 1.0, 0.0, StepModel(), 1.0)
    >>> m.index, m.H.shape, np.round(m.R, 6).tolist()
    (10, (2, 22), [[0.0006, 0.0], [0.0, 0.0004]])
    >>> m.H[:, 21].tolist(), m.H[:, 15:17].tolist()
    ([-1.0, -0.0], [[-1.0, -0.0], [-0.0, -1.0]])
    """
    k = model.n_states
    u = np.array([np.cos(psi), np.sin(psi)])
    Ju = _J @ u
    H = np.zeros((2, k))
    H[:, DP.start:DP.start + 2] = np.eye(2)
    H[:, C_DP.start:C_DP.start + 2] = -np.eye(2)
    H[:, EPS.stop - 1] = -0.5 * length * Ju
    H[:, C_EPS.stop - 1] = -0.5 * length * Ju
    var_along = (length * model.step_sigma) ** 2 + 2.0 * (speed_mps * model.jitter_s) ** 2
    if model.augment_gain:
        H[:, GAIN.start] = -length * u
    else:
        var_along += (length * model.gain_sigma) ** 2
    R = var_along * np.outer(u, u) + model.cross_sigma_m ** 2 * np.outer(Ju, Ju)
    z = np.zeros(2) if z is None else np.asarray(z, dtype=float)
    return Measurement(index=int(index), z=z, H=H, R=R, reset=_clone_reset(k))


def step_z(p_ins_end, p_ins_start, length_morpi, psi_hat):
    """Measurement of one step from an INS and MoRPI: ``dp_ins - s_M u(psi_hat)``.

    Parameters
    ----------
    p_ins_end, p_ins_start : array_like, shape (2,) or (runs, 2)
        INS horizontal positions at the step's end and start peaks [m].
    length_morpi : float or array_like, shape (runs,)
        Weinberg step length [m].
    psi_hat : float or array_like, shape (runs,)
        Heading of the step from the INS [rad].

    Returns
    -------
    z : ndarray, shape (2,) or (runs, 2)
        INS displacement minus the MoRPI displacement along ``psi_hat`` [m].

    Examples
    --------
    >>> step_z([3.0, 4.0], [1.0, 1.0], 2.0, 0.0).tolist()
    [0.0, 3.0]
    """
    psi_hat = np.asarray(psi_hat, dtype=float)
    u = np.stack([np.cos(psi_hat), np.sin(psi_hat)], -1)
    return (np.asarray(p_ins_end, float) - np.asarray(p_ins_start, float)
            - np.asarray(length_morpi, float)[..., None] * u)


def _symmetrize(P):
    return 0.5 * (P + np.swapaxes(P, -1, -2))


#: Predictions between two symmetrizations of P in :func:`run_filter`. The
#: round-off asymmetry of one prediction is a few ulps; symmetrizing every
#: step would add about 20 % to the cost of a 15-state prediction.
SYMMETRIZE_EVERY = 100


def run_filter(Phi, Qd, P0, times, measurements=(), x0=None, keep_P=False):
    """Run the error-state filter (filterpy's update, its prediction written out).

    Parameters
    ----------
    Phi, Qd : ndarray, shape (k, k) or (n, k, k)
        Transition (units of the states it maps) and discrete process noise
        (units of the squared states) of each step (constant when 2-D).
    P0 : ndarray, shape (k, k)
        Initial covariance (units of the squared states).
    times : array_like, shape (n + 1,)
        Epoch times [s] (for the result only; the steps are in Phi, Qd).
    measurements : sequence of Measurement
        Indices 1..n (several per epoch allowed), all of one size m. When any ``z`` is
        2-D, the estimate is run for every Monte Carlo run at once with the
        gains of the single covariance recursion (batched over runs); run 0 is
        also the filterpy state.
    x0 : ndarray, shape (k,) or (runs, k), optional
        Initial estimate in the units of the states (zeros by default).
    keep_P : bool, int or array_like of int
        Keep the full covariance at every epoch (True), at none (False, the
        default: a one-hour run at 100 Hz would otherwise hold 0.65 GB for 15
        states), at every `keep_P`-th epoch (an int: epochs 0, s, 2s, ...), or
        at the epochs listed.

    Notes
    -----
    The covariance is symmetrized (``(P + P^T) / 2``) after every update and
    reset, every :data:`SYMMETRIZE_EVERY` predictions and at the end; kept
    covariances are stored symmetrized, so every covariance returned is
    exactly symmetric and the numbers do not depend on `keep_P`. Updates use
    the Joseph form. Memory grows with the number of epochs only through the
    estimate and the standard deviations (2 k floats per epoch).

    Returns
    -------
    FilterResult
        Estimates ``x`` of shape (n + 1, k) or (runs, n + 1, k), ``sigma`` of
        shape (n + 1, k), innovations and their covariances per update, and
        the covariances kept by `keep_P`.

    Examples
    --------
    A 1-D constant-velocity model (state ``[position, velocity]``, 1 s steps,
    no process noise, unit prior): ``P_2 = [[5, 2], [2, 1]]``; a position
    measurement ``z = 1`` with ``R = 1`` at epoch 2 gives ``S = 6`` and the
    gain ``K = [5, 2] / 6``.

    >>> Phi = np.array([[1.0, 1.0], [0.0, 1.0]])
    >>> m = Measurement(index=2, z=np.array([1.0]), H=np.array([[1.0, 0.0]]), R=np.array([[1.0]]))
    >>> r = run_filter(Phi, np.zeros((2, 2)), np.eye(2), [0.0, 1.0, 2.0], [m])
    >>> r.x.shape, np.round(r.x[-1], 4).tolist(), r.S.tolist()
    ((3, 2), [0.8333, 0.3333], [[[6.0]]])
    >>> np.round(r.sigma[1] ** 2, 6).tolist()
    [2.0, 1.0]
    """
    Phi = np.asarray(Phi, dtype=float)
    Qd = np.asarray(Qd, dtype=float)
    times = np.asarray(times, dtype=float)
    n = times.size - 1
    k = Phi.shape[-1]
    if Phi.ndim == 3 and Phi.shape[0] != n or Qd.ndim == 3 and Qd.shape[0] != n:
        raise ParameterError(f"Phi {Phi.shape} / Qd {Qd.shape}: expected one matrix per step ({n} steps)")
    P0 = np.asarray(P0, dtype=float)
    if P0.shape != (k, k):
        raise ParameterError(f"P0: expected shape ({k}, {k}), got {P0.shape}")
    meas = sorted(measurements, key=lambda m: m.index)
    if meas and not (1 <= meas[0].index and meas[-1].index <= n):
        raise ParameterError(f"measurement index out of range 1..{n}")
    runs = None
    for m in meas:
        if m.H is not None and np.ndim(m.z) == 2:
            runs = np.shape(m.z)[0]
    if x0 is not None and np.ndim(x0) == 2:
        runs = np.shape(x0)[0]
    if runs is None:
        X = np.zeros(k) if x0 is None else np.array(x0, dtype=float)
    else:
        X = np.zeros((runs, k)) if x0 is None else np.broadcast_to(np.asarray(x0, float), (runs, k)).copy()

    upd = [m for m in meas if m.H is not None]
    dim_z = upd[0].H.shape[0] if upd else 1
    for m in upd:
        if m.H.shape != (dim_z, k) or m.R.shape != (dim_z, dim_z) or np.shape(m.z)[-1] != dim_z:
            raise ParameterError(f"measurement at epoch {m.index}: expected H ({dim_z}, {k}), R ({dim_z}, {dim_z}) "
                                 f"and z of length {dim_z}, got {m.H.shape}, {m.R.shape}, {np.shape(m.z)}")
    kf = KalmanFilter(dim_x=k, dim_z=dim_z)
    kf.x = (X if runs is None else X[0]).copy()
    kf.P = P0.copy()

    if keep_P is True:
        P_index = np.arange(n + 1)
    elif keep_P is False or keep_P is None:
        P_index = np.zeros(0, int)
    elif isinstance(keep_P, (int, np.integer)):
        if keep_P < 1:
            raise ParameterError(f"keep_P: a stride must be a whole number >= 1, got {keep_P}")
        P_index = np.arange(0, n + 1, int(keep_P))
    else:
        P_index = np.unique(np.asarray(keep_P, dtype=int))
        if P_index.size and (P_index[0] < 0 or P_index[-1] > n):
            raise ParameterError(f"keep_P: epochs must lie in 0..{n}")
    keep = np.zeros(n + 1, bool)
    keep[P_index] = True
    P_store = np.empty((P_index.size, k, k)) if P_index.size else None
    slot = 0

    xs = np.empty((n + 1,) + X.shape)
    var = np.empty((n + 1, k))
    xs[0], var[0] = X, np.diag(kf.P)
    if keep[0]:
        P_store[slot] = kf.P
        slot += 1
    ys, Ss, ws = [], [], []
    mi = 0
    const = Phi.ndim == 2
    x, P = kf.x, kf.P
    for i in range(n):
        F_i = Phi if const else Phi[i]
        Q_i = Qd if Qd.ndim == 2 else Qd[i]
        # filterpy's predict(F=F_i, Q=Q_i) with the same numpy calls (its fading factor is 1),
        # without the copies of the prior it keeps for a smoother this filter does not use
        x = dot(F_i, x)
        P = dot(dot(F_i, P), F_i.T) + Q_i
        if (i + 1) % SYMMETRIZE_EVERY == 0 or i + 1 == n:
            P = _symmetrize(P)
        if runs is not None:
            X = X @ F_i.T
        if mi < len(meas) and meas[mi].index == i + 1:
            kf.x, kf.P = x, P
            while mi < len(meas) and meas[mi].index == i + 1:
                m = meas[mi]
                mi += 1
                if m.H is None:  # a state reset only (e.g. re-cloning at a step start)
                    kf.x = m.reset @ kf.x
                    kf.P = _symmetrize(m.reset @ kf.P @ m.reset.T)
                    if runs is not None:
                        X = X @ m.reset.T
                    continue
                z = np.asarray(m.z, dtype=float)
                H, R = m.H, m.R
                if runs is None:
                    y = z - H @ kf.x
                else:
                    Z = np.broadcast_to(z, (runs, H.shape[0]))
                    y = Z - X @ H.T
                kf.update(z if runs is None else Z[0], R=R, H=H)
                kf.P = _symmetrize(kf.P)
                S = kf.S
                L = np.linalg.cholesky(S)
                ys.append(y)
                Ss.append(S)
                ws.append(np.linalg.solve(L, y.T).T if runs is not None else np.linalg.solve(L, y))
                if runs is not None:
                    X = X + y @ kf.K.T
                if m.reset is not None:
                    T = m.reset
                    kf.x = T @ kf.x
                    kf.P = _symmetrize(T @ kf.P @ T.T)
                    if runs is not None:
                        X = X @ T.T
            x, P = kf.x, kf.P
        if runs is None:
            X = x
        xs[i + 1] = X
        var[i + 1] = P.diagonal()
        if keep[i + 1]:
            P_store[slot] = _symmetrize(P)
            slot += 1
    kf.x, kf.P = x, P

    m_dim = dim_z
    if runs is None:
        innov = np.array(ys).reshape(len(ys), m_dim)
        white = np.array(ws).reshape(len(ws), m_dim)
        x_out = xs
    else:
        innov = np.array(ys).reshape(len(ys), runs, m_dim).transpose(1, 0, 2)
        white = np.array(ws).reshape(len(ws), runs, m_dim).transpose(1, 0, 2)
        x_out = xs.transpose(1, 0, 2)
    names = AUG_STATE_NAMES[:k] if k > N_STATES else STATE_NAMES[:k]
    return FilterResult(
        times=times, x=x_out, sigma=np.sqrt(np.clip(var, 0.0, None)), P_end=kf.P.copy(),
        update_index=np.array([m.index for m in upd], dtype=int),
        innovations=innov, S=np.array(Ss).reshape(len(Ss), m_dim, m_dim),
        normalized_innovations=white, P=P_store, P_index=P_index, state_names=names,
    )


def propagate_covariance(Phi, Qd, P0, n, stride=1):
    """Covariance of a constant-``Phi`` prediction at epochs ``0, s, 2s, ... <= n``, vectorized.

    ``P_k = Phi^k P0 Phi^kT + sum_{j<k} Phi^j Qd Phi^jT``, the closed form of
    the recursion ``P <- Phi P Phi^T + Qd`` that :func:`run_filter` runs through
    filterpy. The powers come from ``log2`` batched doublings: first over the
    `s` steps of one stride (giving ``Phi^s`` and the noise ``Q_s`` of one
    stride), then over the ``n // s`` strides, so memory holds about
    ``s + n / s`` matrices instead of ``n``.

    Parameters
    ----------
    Phi, Qd : ndarray, shape (k, k)
        Constant transition (units of the states it maps) and discrete
        process noise of one step (units of the squared states).
    P0 : ndarray, shape (k, k)
        Initial covariance (units of the squared states).
    n : int
        Number of steps.
    stride : int
        Keep every `stride`-th epoch (default 1: every epoch). Epoch `n` is
        included when `stride` divides `n`.

    Returns
    -------
    P : ndarray, shape (n // stride + 1, k, k)
        Symmetric covariances at epochs ``0, stride, 2 stride, ...``.

    Examples
    --------
    The 1-D constant-velocity model of :func:`run_filter` without
    measurements: the position variance is ``1 + k^2``.

    >>> Phi = np.array([[1.0, 1.0], [0.0, 1.0]])
    >>> P = propagate_covariance(Phi, np.zeros((2, 2)), np.eye(2), 4)
    >>> P.shape, P[:, 0, 0].tolist()
    ((5, 2, 2), [1.0, 2.0, 5.0, 10.0, 17.0])
    >>> propagate_covariance(Phi, np.zeros((2, 2)), np.eye(2), 4, stride=2)[:, 0, 0].tolist()
    [1.0, 5.0, 17.0]
    """
    Phi = np.asarray(Phi, dtype=float)
    Qd = np.asarray(Qd, dtype=float)
    P0 = np.asarray(P0, dtype=float)
    if isinstance(stride, bool) or not isinstance(stride, (int, np.integer)) or stride < 1:
        raise ParameterError(f"stride: expected a whole number >= 1, got {stride!r}")
    stride = int(stride)
    if stride > 1:
        A_s, Q_s = _powers_and_noise(Phi, Qd, stride)
        Phi, Qd = A_s[-1], _symmetrize(Q_s[-1])
    A, Qsum = _powers_and_noise(Phi, Qd, n // stride)
    At = np.swapaxes(A, -1, -2)
    return _symmetrize(A @ P0 @ At + Qsum)


def _powers_and_noise(Phi, Qd, m):
    """``Phi^j`` and ``sum_{i<j} Phi^i Qd Phi^iT`` for ``j = 0..m`` (batched doublings)."""
    A = np.eye(Phi.shape[0])[None]
    step = Phi
    while A.shape[0] < m + 1:
        A = np.concatenate([A, A @ step])
        step = step @ step
    A = A[: m + 1]
    terms = A @ Qd @ np.swapaxes(A, -1, -2)
    Qsum = np.concatenate([np.zeros((1,) + Phi.shape), np.cumsum(terms[:-1], axis=0)])
    return A, Qsum


def nees(err, P):
    """Normalized estimation error squared ``e^T P^-1 e``.

    Parameters
    ----------
    err : ndarray, shape (..., n, d)
        Estimate minus truth of the selected states (in their units, e.g. [m]).
    P : ndarray, shape (n, d, d)
        Their covariance per epoch (non-singular, units of the squared states).

    Returns
    -------
    ndarray, shape (..., n)
        NEES per epoch (dimensionless; mean ``d`` for a consistent filter).

    Examples
    --------
    >>> nees(np.array([[1.0, 2.0]]), np.array([np.diag([1.0, 4.0])])).tolist()
    [2.0]
    """
    L = np.linalg.cholesky(P)
    w = np.linalg.solve(L, np.asarray(err, dtype=float)[..., None])[..., 0]
    return (w ** 2).sum(axis=-1)


def nis(result: FilterResult):
    """Normalized innovation squared of every update (see :class:`FilterResult`).

    Parameters
    ----------
    result : FilterResult
        Output of :func:`run_filter`.

    Returns
    -------
    ndarray, shape (u,) or (runs, u)
        ``y^T S^-1 y`` per update (dimensionless; mean ``m`` for a consistent filter).

    Examples
    --------
    The update of the :func:`run_filter` example: ``y = 1``, ``S = 6``.

    >>> Phi = np.array([[1.0, 1.0], [0.0, 1.0]])
    >>> m = Measurement(index=2, z=np.array([1.0]), H=np.array([[1.0, 0.0]]), R=np.array([[1.0]]))
    >>> r = run_filter(Phi, np.zeros((2, 2)), np.eye(2), [0.0, 1.0, 2.0], [m])
    >>> np.round(nis(r), 4).tolist()
    [0.1667]
    """
    return result.nis


def chi2_band(dof, runs, confidence=0.95):
    """Two-sided band of the run-averaged NEES/NIS of a consistent filter.

    ``runs * mean`` is chi-square with ``runs * dof`` degrees of freedom [4].

    Parameters
    ----------
    dof : int
        Degrees of freedom of one NEES/NIS value (the state or measurement size).
    runs : int
        Number of Monte Carlo runs averaged.
    confidence : float
        Probability inside the band (dimensionless, default 0.95).

    Returns
    -------
    (lo, hi) : tuple of float
        Lower and upper bound of the run average (dimensionless).

    Examples
    --------
    >>> [round(float(v), 3) for v in chi2_band(2, 100)]
    [1.627, 2.411]
    """
    a = (1.0 - confidence) / 2.0
    return (chi2.ppf(a, runs * dof) / runs, chi2.ppf(1.0 - a, runs * dof) / runs)


@renamed_keywords(speed="speed_mps")
def simulate_steps(X, step_index, length, psi, model: StepModel, speed_mps, gain, rng):
    """Synthetic MoRPI step measurements of simulated error-state runs.

    Parameters
    ----------
    X : ndarray, shape (runs, n + 1, 15)
        True error states (e.g. from :func:`error_model.simulate_linear`).
    step_index : array_like of int, shape (s,)
        Epochs of the step peaks; the first step starts at epoch 0.
    length, psi : float
        Step length [m] and heading [rad].
    model : StepModel
        Step error model (R of each step, and whether the gain is a state).
    speed_mps : float
        Speed along the path [m/s] (jitter term of R).
    gain : ndarray, shape (runs,)
        True relative gain error per run (dimensionless).
    rng : numpy.random.Generator
        Source of the measurement noise ``N(0, R)``.

    Returns
    -------
    list of Measurement
        One per step, with ``z`` of shape (runs, 2) [m], ready for :func:`run_filter`.

    Examples
    --------
    Without navigation errors and with a noise-free model, ``z`` is the gain
    error times ``-s u``.

    >>> model = StepModel(jitter_s=0.0, step_sigma=0.0, cross_sigma_m=0.0)
    >>> X = np.zeros((2, 3, 15))
    >>> ms = simulate_steps(X, [2], 1.0, 0.0, model, 1.0, np.array([0.1, -0.2]), np.random.default_rng(0))
    >>> len(ms), ms[0].index, (np.round(ms[0].z, 6) + 0.0).tolist()
    (1, 2, [[-0.1, 0.0], [0.2, 0.0]])
    """
    runs = X.shape[0]
    out = []
    prev = 0
    for idx in step_index:
        m = step_update(idx, length, psi, model, speed_mps)
        xa = np.zeros((runs, m.H.shape[1]))
        xa[:, :N_STATES] = X[:, idx]
        xa[:, C_DP] = X[:, prev, DP]
        xa[:, C_EPS] = X[:, prev, EPS]
        if model.augment_gain:
            xa[:, GAIN] = gain[:, None]
        z = xa @ m.H.T
        if not model.augment_gain:
            u = np.array([np.cos(psi), np.sin(psi)])
            z = z - length * gain[:, None] * u
        lam, V = np.linalg.eigh(m.R)
        z = z + rng.standard_normal((runs, 2)) @ (V * np.sqrt(np.clip(lam, 0, None))).T
        out.append(Measurement(index=m.index, z=z, H=m.H, R=m.R, reset=m.reset))
        prev = idx
    return out
