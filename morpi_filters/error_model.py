"""Numeric INS error model: the 15-state F(t), G, Q and their discretization.

The error state (package convention, see :mod:`morpi_filters`) is::

    dx = [dp(3), dv(3), eps(3), b_a(3), b_g(3)]

indexed through the named slices :data:`DP`, :data:`DV`, :data:`EPS`,
:data:`BA`, :data:`BG`. The navigation frame is z up (gravity
``g^n = (0, 0, -g)``, a body at rest has ``f^n = (0, 0, +g)``); earth and
transport rates are neglected, as in the paper [1].

Sign conventions
----------------
Every error is *computed minus true*:

* ``dp = p_hat - p``, ``dv = v_hat - v`` (navigation frame, m and m/s);
* ``eps`` is the misalignment of the computed attitude, defined by
  ``C_hat = (I + [eps x]) C`` (small rotation of the computed navigation axes,
  expressed in n, rad). A positive ``eps_z`` is a computed heading larger than
  the true one (``psi_hat = psi + eps_z``);
* ``b_a = f_measured - f_true`` and ``b_g = w_measured - w_true`` (body frame).

With these definitions the error dynamics are those of the paper's F [1]::

    dp_dot  = dv
    dv_dot  = -(f^n x) eps + C b_a + C w_a
    eps_dot = C b_g + C w_g
    b_a_dot = w_ba,   b_g_dot = w_bg        (zero unless a bias walk is given)

Derivation of the second line: ``v_hat_dot = C_hat f_hat + g`` so
``dv_dot = [eps x] C f + C b_a = -(f^n x) eps + C b_a``. Third line:
``C_hat_dot = C_hat Omega_hat`` gives ``[eps_dot x] = C [b_g x] C^T``.
On the paper's nominal trajectory (C = I, f^n = (0, 0, g)) this gives
``dp_x = dv_x t + b_ax t^2/2 + g b_gy t^3/6`` and
``dp_y = dv_y t + b_ay t^2/2 - g b_gx t^3/6``; the paper's z-down reading flips
the sign of the gyro terms.

Noise
-----
The noise vector is ``w = [w_a(3), w_g(3), w_ba(3), w_bg(3)]`` (12), with
continuous spectral density ``Q = diag(N_a^2, N_g^2, q_ba^2, q_bg^2)`` from the
root-PSD noise densities of a :class:`~morpi_filters.units.SensorSpec`
(``N_a`` [m/s^2/sqrt(Hz)], ``N_g`` [rad/s/sqrt(Hz)]) and optional bias random
walks. A sampled sensor at rate ``fs`` carries white noise of standard
deviation ``N sqrt(fs)`` per sample.

Planar model
------------
The 2D INS (heading from ``w_z`` only, horizontal velocity from ``f_x, f_y``)
has 8 error states ``[dp_x, dp_y, dv_x, dv_y, dpsi, b_ax, b_ay, b_gz]`` indexed
by :data:`P2_DP`, :data:`P2_DV`, :data:`P2_PSI`, :data:`P2_BA`, :data:`P2_BG`::

    dv_dot   = dpsi J f^n_xy + C(psi) b_a,xy + C(psi) w_a,xy,   J = [[0, -1], [1, 0]]
    dpsi_dot = b_gz + w_gz

which is the horizontal, heading-only restriction of the 15-state model.

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
  IEEE J. Indoor and Seamless Positioning and Navigation, 2023.
- [2] P. D. Groves, "Principles of GNSS, Inertial, and Multisensor Integrated
  Navigation Systems", 2nd ed., Artech House, 2013, ch. 14.
- [3] C. F. van Loan, "Computing integrals involving the matrix exponential",
  IEEE Trans. Automatic Control, 23(3), 1978. doi:10.1109/TAC.1978.1101743
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from .deprecation import renamed_keywords
from .errors import ParameterError

__all__ = [
    "DP", "DV", "EPS", "BA", "BG", "N_STATES", "STATE_NAMES", "N_NOISE",
    "P2_DP", "P2_DV", "P2_PSI", "P2_BA", "P2_BG", "N_PLANAR", "PLANAR_STATE_NAMES", "N_PLANAR_NOISE",
    "skew", "system_matrix", "noise_coupling", "noise_density",
    "planar_system_matrix", "planar_noise_coupling", "planar_noise_density",
    "paper_trajectory", "Discretized", "discretize", "simulate_linear",
]

#: Position error [m], navigation frame.
DP = slice(0, 3)
#: Velocity error [m/s], navigation frame.
DV = slice(3, 6)
#: Misalignment [rad], navigation frame (``C_hat = (I + [eps x]) C``).
EPS = slice(6, 9)
#: Accelerometer bias residual [m/s^2], body frame.
BA = slice(9, 12)
#: Gyro bias residual [rad/s], body frame.
BG = slice(12, 15)
#: Size of the error state.
N_STATES = 15
#: Column names of the 15 states.
STATE_NAMES = (
    "dp_x", "dp_y", "dp_z", "dv_x", "dv_y", "dv_z", "eps_x", "eps_y", "eps_z",
    "ba_x", "ba_y", "ba_z", "bg_x", "bg_y", "bg_z",
)
#: Size of the noise vector ``[w_a, w_g, w_ba, w_bg]``.
N_NOISE = 12

#: Planar model: horizontal position error [m].
P2_DP = slice(0, 2)
#: Planar model: horizontal velocity error [m/s].
P2_DV = slice(2, 4)
#: Planar model: heading error [rad] (``psi_hat - psi``).
P2_PSI = slice(4, 5)
#: Planar model: accelerometer bias residual on x and y [m/s^2].
P2_BA = slice(5, 7)
#: Planar model: gyro bias residual on z [rad/s].
P2_BG = slice(7, 8)
#: Size of the planar error state.
N_PLANAR = 8
#: Column names of the planar states.
PLANAR_STATE_NAMES = ("dp_x", "dp_y", "dv_x", "dv_y", "dpsi", "ba_x", "ba_y", "bg_z")
#: Size of the planar noise vector ``[w_ax, w_ay, w_gz, w_bax, w_bay, w_bgz]``.
N_PLANAR_NOISE = 6

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


def skew(v):
    """Cross-product matrix ``[v x]`` of one vector or a stack.

    Parameters
    ----------
    v : array_like, shape (3,) or (n, 3)
        One vector or a stack of vectors (any unit; the matrix carries it).

    Returns
    -------
    ndarray, shape (3, 3) or (n, 3, 3)
        ``skew(v) @ u == cross(v, u)``.

    Raises
    ------
    ParameterError
        When the last axis is not of length 3.

    Examples
    --------
    >>> (skew([1.0, 2.0, 3.0]) @ [4.0, 5.0, 6.0]).tolist()     # the cross product
    [-3.0, 6.0, -3.0]
    """
    v = np.asarray(v, dtype=float)
    if v.shape[-1] != 3:
        raise ParameterError(f"skew: expected vectors of length 3, got shape {v.shape}")
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def _check_traj(C, f):
    C = np.asarray(C, dtype=float)
    f = np.asarray(f, dtype=float)
    if C.shape[-2:] != (3, 3) or C.ndim not in (2, 3):
        raise ParameterError(f"C_b^n: expected shape (3, 3) or (n, 3, 3), got {C.shape}")
    if f.shape[-1:] != (3,) or f.ndim not in (1, 2):
        raise ParameterError(f"f^n: expected shape (3,) or (n, 3), got {f.shape}")
    if (C.ndim == 3) != (f.ndim == 2) or (C.ndim == 3 and C.shape[0] != f.shape[0]):
        raise ParameterError(f"C_b^n {C.shape} and f^n {f.shape}: expected one epoch each or stacks of equal length")
    return C, f


def system_matrix(C, f):
    """The 15-state system matrix F along a trajectory.

    Parameters
    ----------
    C : array_like, shape (3, 3) or (n, 3, 3)
        Body-to-navigation rotation ``C_b^n`` per epoch.
    f : array_like, shape (3,) or (n, 3)
        Specific force in the navigation frame [m/s^2] per epoch
        (``(0, 0, g)`` at rest, z up).

    Returns
    -------
    F : ndarray, shape (15, 15) or (n, 15, 15)
        ``dx_dot = F dx`` with the blocks of the module docstring [1].

    Examples
    --------
    >>> F = system_matrix(np.eye(3), [0.0, 0.0, 9.8])
    >>> F.shape, float(F[0, 3]), float(F[3, 7])      # dp' = dv; dv'_x = g * eps_y (z up)
    ((15, 15), 1.0, 9.8)
    """
    C, f = _check_traj(C, f)
    F = np.zeros(C.shape[:-2] + (N_STATES, N_STATES))
    F[..., DP, DV] = np.eye(3)
    F[..., DV, EPS] = -skew(f)
    F[..., DV, BA] = C
    F[..., EPS, BG] = C
    return F


def noise_coupling(C):
    """Noise coupling G of ``w = [w_a, w_g, w_ba, w_bg]``.

    The accelerometer and gyro white noises enter the velocity and the
    misalignment rows through ``C_b^n``; the bias random walks drive the bias
    states directly.

    Parameters
    ----------
    C : array_like, shape (3, 3) or (n, 3, 3)
        Body-to-navigation rotation ``C_b^n`` per epoch.

    Returns
    -------
    G : ndarray, shape (15, 12) or (n, 15, 12)
        ``dx_dot = F dx + G w``.

    Raises
    ------
    ParameterError
        For a `C` of another shape.

    Examples
    --------
    >>> G = noise_coupling(np.eye(3))
    >>> G.shape, G[DV, 0:3].tolist() == np.eye(3).tolist(), float(G[BG, 9:12].trace())
    ((15, 12), True, 3.0)
    >>> noise_coupling(np.broadcast_to(np.eye(3), (4, 3, 3))).shape
    (4, 15, 12)
    """
    C = np.asarray(C, dtype=float)
    if C.shape[-2:] != (3, 3) or C.ndim not in (2, 3):
        raise ParameterError(f"C_b^n: expected shape (3, 3) or (n, 3, 3), got {C.shape}")
    G = np.zeros(C.shape[:-2] + (N_STATES, N_NOISE))
    G[..., DV, 0:3] = C
    G[..., EPS, 3:6] = C
    G[..., BA, 6:9] = np.eye(3)
    G[..., BG, 9:12] = np.eye(3)
    return G


def _nonneg(name, v):
    v = float(v)
    if not np.isfinite(v) or v < 0:
        raise ParameterError(f"{name}: {v!r} must be a finite number >= 0")
    return v


def noise_density(spec, accel_bias_walk=0.0, gyro_bias_walk=0.0):
    """Continuous noise spectral density Q from a sensor spec.

    Parameters
    ----------
    spec : units.SensorSpec
        ``accel_noise`` [m/s^2/sqrt(Hz)] and ``gyro_noise`` [rad/s/sqrt(Hz)]
        are used; the turn-on biases are initial-covariance terms, not noise.
    accel_bias_walk : float, optional
        Accelerometer bias random walk [m/s^2/sqrt(s)] (default none).
    gyro_bias_walk : float, optional
        Gyro bias random walk [rad/s/sqrt(s)] (default none).

    Returns
    -------
    Q : ndarray, shape (12, 12)
        Diagonal, in the order of :func:`noise_coupling`.

    Examples
    --------
    >>> from morpi_filters.units import LSM6DSL
    >>> Q = noise_density(LSM6DSL)
    >>> Q.shape, bool(Q[0, 0] == LSM6DSL.accel_noise ** 2)
    ((12, 12), True)
    """
    q = [_nonneg("accel_noise", spec.accel_noise), _nonneg("gyro_noise", spec.gyro_noise),
         _nonneg("accel_bias_walk", accel_bias_walk), _nonneg("gyro_bias_walk", gyro_bias_walk)]
    return np.diag(np.repeat(np.square(q), 3))


def _rot2(psi):
    psi = np.asarray(psi, dtype=float)
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def planar_system_matrix(psi, f_xy):
    """System matrix of the planar (2D INS) error model.

    The blocks are those of the module docstring: ``dp' = dv``,
    ``dv' = dpsi J f^n_xy + C(psi) b_a,xy`` and ``dpsi' = b_gz``.

    Parameters
    ----------
    psi : float or array_like, shape (n,)
        Heading [rad] (x towards the end point, positive to the left).
    f_xy : array_like, shape (2,) or (n, 2)
        Horizontal specific force in the navigation frame [m/s^2].

    Returns
    -------
    F : ndarray, shape (8, 8) or (n, 8, 8)
        ``dx_dot = F dx`` over the states :data:`PLANAR_STATE_NAMES`.

    Raises
    ------
    ParameterError
        For an `f_xy` whose shape does not match `psi`.

    Examples
    --------
    A forward specific force of 1 m/s^2 turns a heading error into a lateral
    velocity error (``dv_y' = f_x dpsi``):

    >>> F = planar_system_matrix(0.0, [1.0, 0.0])
    >>> F.shape, float(F[0, 2]), float(F[3, 4]), float(F[4, 7])
    ((8, 8), 1.0, 1.0, 1.0)
    >>> planar_system_matrix([0.0, 0.1], np.zeros((2, 2))).shape
    (2, 8, 8)
    """
    C = _rot2(psi)
    f_xy = np.asarray(f_xy, dtype=float)
    if f_xy.shape[-1:] != (2,) or f_xy.shape[:-1] != C.shape[:-2]:
        raise ParameterError(f"f_xy: expected shape {C.shape[:-2] + (2,)}, got {f_xy.shape}")
    F = np.zeros(C.shape[:-2] + (N_PLANAR, N_PLANAR))
    F[..., P2_DP, P2_DV] = np.eye(2)
    F[..., P2_DV, P2_PSI] = (f_xy @ _J.T)[..., :, None]
    F[..., P2_DV, P2_BA] = C
    F[..., P2_PSI, P2_BG] = 1.0
    return F


def planar_noise_coupling(psi):
    """Noise coupling of ``w = [w_ax, w_ay, w_gz, w_bax, w_bay, w_bgz]``.

    Parameters
    ----------
    psi : float or array_like, shape (n,)
        Heading [rad]; the horizontal accelerometer noise enters the velocity
        rows through its rotation ``C(psi)``.

    Returns
    -------
    G : ndarray, shape (8, 6) or (n, 8, 6)
        ``dx_dot = F dx + G w`` over the states :data:`PLANAR_STATE_NAMES`.

    Examples
    --------
    At a heading of 90 degrees the body x noise drives the navigation y velocity:

    >>> G = planar_noise_coupling(np.pi / 2)
    >>> G.shape, np.round(G[P2_DV, 0], 12).tolist()
    ((8, 6), [0.0, 1.0])
    """
    C = _rot2(psi)
    G = np.zeros(C.shape[:-2] + (N_PLANAR, N_PLANAR_NOISE))
    G[..., P2_DV, 0:2] = C
    G[..., P2_PSI, 2:3] = 1.0
    G[..., P2_BA, 3:5] = np.eye(2)
    G[..., P2_BG, 5:6] = 1.0
    return G


def planar_noise_density(spec, accel_bias_walk=0.0, gyro_bias_walk=0.0):
    """Planar counterpart of :func:`noise_density`.

    Parameters
    ----------
    spec : units.SensorSpec
        ``accel_noise`` [m/s^2/sqrt(Hz)] and ``gyro_noise`` [rad/s/sqrt(Hz)]
        are used.
    accel_bias_walk : float, optional
        Accelerometer bias random walk [m/s^2/sqrt(s)] (default none).
    gyro_bias_walk : float, optional
        Gyro bias random walk [rad/s/sqrt(s)] (default none).

    Returns
    -------
    Q : ndarray, shape (6, 6)
        Diagonal, in the order of :func:`planar_noise_coupling`.

    Raises
    ------
    ParameterError
        For a negative or non-finite value.

    Examples
    --------
    >>> from morpi_filters.units import LSM6DSL
    >>> Q = planar_noise_density(LSM6DSL, gyro_bias_walk=1e-4)
    >>> Q.shape, bool(Q[2, 2] == LSM6DSL.gyro_noise ** 2), float(Q[5, 5]), float(Q[3, 3])
    ((6, 6), True, 1e-08, 0.0)
    """
    a, g = _nonneg("accel_noise", spec.accel_noise), _nonneg("gyro_noise", spec.gyro_noise)
    ab, gb = _nonneg("accel_bias_walk", accel_bias_walk), _nonneg("gyro_bias_walk", gyro_bias_walk)
    return np.diag(np.square([a, a, g, ab, ab, gb]))


def paper_trajectory(g, n=None):
    """The paper's nominal trajectory: ``C = I`` and ``f^n = (0, 0, g)``.

    Parameters
    ----------
    g : float
        Gravity magnitude [m/s^2].
    n : int, optional
        Number of epochs; one epoch when None.

    Returns
    -------
    C : ndarray, shape (3, 3) or (n, 3, 3)
        Body-to-navigation rotation (identity).
    f : ndarray, shape (3,) or (n, 3)
        Specific force in the navigation frame [m/s^2].

    Examples
    --------
    >>> C, f = paper_trajectory(9.81)
    >>> C.tolist() == np.eye(3).tolist(), f.tolist()
    (True, [0.0, 0.0, 9.81])
    >>> [a.shape for a in paper_trajectory(9.81, n=5)]
    [(5, 3, 3), (5, 3)]
    """
    C, f = np.eye(3), np.array([0.0, 0.0, float(g)])
    if n is None:
        return C, f
    return np.broadcast_to(C, (n, 3, 3)).copy(), np.broadcast_to(f, (n, 3)).copy()


def _expm(M, max_power=12):
    """Matrix exponential of one matrix or a stack; a finite series when nilpotent.

    The INS error model without Earth rate is nilpotent (its blocks form a
    chain dp <- dv <- eps <- b_g, dv <- b_a, so F^5 = 0 and the Van Loan
    matrix of it vanishes at the 10th power). Its powers then reach exact
    zeros (structural zeros multiply to exact zeros in floating point) and
    ``sum_j M^j / j!`` is the exact exponential, 5-10 times cheaper than
    scipy's Pade approximant on stacks. Any other matrix goes to
    :func:`scipy.linalg.expm`.
    """
    S = np.eye(M.shape[-1]) + M
    P = M
    fact = 1.0
    for j in range(2, max_power + 1):
        P = P @ M
        if not P.any():
            return S
        fact *= j
        S = S + P / fact
    return expm(M)


@dataclass(frozen=True)
class Discretized:
    """Discrete transition and process-noise covariance of one or many steps.

    Attributes
    ----------
    Phi : ndarray, shape (k, k) or (n, k, k)
        ``expm(F dt)``.
    Qd : ndarray, shape (k, k) or (n, k, k)
        ``int_0^dt expm(F s) G Q G^T expm(F s)^T ds`` (symmetric).
    """

    Phi: np.ndarray
    Qd: np.ndarray

    def __iter__(self):
        return iter((self.Phi, self.Qd))


@renamed_keywords(dt="dt_s")
def discretize(F, G, Q, dt_s):
    """Discretize ``x_dot = F x + G w`` (``E[w w^T] = Q delta``) by Van Loan.

    The one place of the package where continuous models become discrete.

    Parameters
    ----------
    F : array_like, shape (k, k) or (n, k, k)
        System matrix.
    G : array_like, shape (k, m) or (n, k, m)
        Noise coupling.
    Q : array_like, shape (m, m) or (n, m, m)
        Spectral density of the white noise (e.g. [m^2/s^3] for an acceleration
        noise).
    dt_s : float or array_like, shape (n,)
        Time step(s) [s], >= 0; an array gives one step per epoch (real,
        non-uniform time steps).

    Returns
    -------
    Discretized
        ``Phi`` and ``Qd``, shape (k, k); stacks (n, k, k) when any input is a
        stack. It unpacks as ``Phi, Qd = discretize(...)``.

    Raises
    ------
    ParameterError
        For inconsistent shapes, a negative or non-finite step, or stacks of
        different leading axes.

    Notes
    -----
    With ``M = [[-F, G Q G^T], [0, F^T]] dt`` and ``expm(M) = [[., B12], [0, B22]]``,
    ``Phi = B22^T`` and ``Qd = Phi B12`` [3]. ``Qd`` is symmetrized.

    Examples
    --------
    A double integrator driven by white acceleration of density q has the
    textbook ``Phi = [[1, dt], [0, 1]]`` and
    ``Qd = q [[dt^3 / 3, dt^2 / 2], [dt^2 / 2, dt]]``:

    >>> Phi, Qd = discretize([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0]], 2.0)
    >>> Phi.tolist(), np.round(Qd, 6).tolist()
    ([[1.0, 2.0], [0.0, 1.0]], [[2.666667, 2.0], [2.0, 2.0]])
    >>> discretize(np.zeros((2, 2)), np.eye(2), np.eye(2), [0.1, 0.2, 0.1]).Qd.shape
    (3, 2, 2)
    """
    F = np.asarray(F, dtype=float)
    G = np.asarray(G, dtype=float)
    Q = np.asarray(Q, dtype=float)
    dt = np.asarray(dt_s, dtype=float)
    if F.ndim not in (2, 3) or F.shape[-1] != F.shape[-2]:
        raise ParameterError(f"F: expected shape (k, k) or (n, k, k), got {F.shape}")
    k = F.shape[-1]
    if G.ndim not in (2, 3) or G.shape[-2] != k:
        raise ParameterError(f"G: expected shape ({k}, m) or (n, {k}, m), got {G.shape}")
    m = G.shape[-1]
    if Q.ndim not in (2, 3) or Q.shape[-2:] != (m, m):
        raise ParameterError(f"Q: expected shape ({m}, {m}) or (n, {m}, {m}), got {Q.shape}")
    if dt.ndim > 1 or not np.all(np.isfinite(dt)) or np.any(dt < 0):
        raise ParameterError("dt_s: expected a finite time step >= 0 [s] or a 1-D array of them")
    lead = np.broadcast_shapes(F.shape[:-2], G.shape[:-2], Q.shape[:-2], dt.shape)
    if len(lead) > 1:
        raise ParameterError("discretize: stacks must share one leading (time) axis")
    if F.ndim == 2 and G.ndim == 2 and Q.ndim == 2 and dt.ndim == 1:
        # one model, many steps: exponentiate each distinct step once
        u, inv = np.unique(dt, return_inverse=True)
        if u.size < dt.size:
            D = discretize(F, G, Q, u)
            return Discretized(Phi=D.Phi[inv], Qd=D.Qd[inv])
    GQGt = G @ Q @ np.swapaxes(G, -1, -2)
    M = np.zeros(lead + (2 * k, 2 * k))
    M[..., :k, :k] = -F
    M[..., :k, k:] = GQGt
    M[..., k:, k:] = np.swapaxes(F, -1, -2)
    M = M * (dt[..., None, None] if dt.ndim else dt)
    E = _expm(M)
    Phi = np.swapaxes(E[..., k:, k:], -1, -2)
    Qd = Phi @ E[..., :k, k:]
    Qd = 0.5 * (Qd + np.swapaxes(Qd, -1, -2))
    return Discretized(Phi=np.ascontiguousarray(Phi), Qd=Qd)


@renamed_keywords(dt="dt_s")
def simulate_linear(F, G, Q, P0, dt_s, n_steps, runs, rng, keep=None):
    """Monte Carlo of the linear error model with sampled white noise.

    Each run draws ``x0 ~ N(0, P0)`` and integrates ``x_dot = F x + G w``
    exactly over time steps of length `dt_s` with `w` held constant over a step and
    drawn as ``N(0, Q / dt)``, i.e. the way a sampled IMU delivers white
    noise of spectral density Q. The transition of a step comes from
    ``expm([[F, G], [0, 0]] dt)``; the Van Loan covariance integral of
    :func:`discretize` is not used, so the runs are an independent check of
    it (they agree to O(dt / t)).

    Parameters
    ----------
    F : array_like, shape (k, k) or (n_steps, k, k)
        System matrix (one, or one per step).
    G : array_like, shape (k, m) or (n_steps, k, m)
        Noise coupling (one, or one per step).
    Q : array_like, shape (m, m)
        Spectral density of the white noise.
    P0 : array_like, shape (k, k)
        Initial covariance (positive semi-definite).
    dt_s : float or array_like, shape (n_steps,)
        Time step(s) [s], > 0.
    n_steps : int
        Number of steps.
    runs : int
        Number of independent runs.
    rng : numpy.random.Generator
        Source of every draw (initial states first, then the noise step by step).
    keep : array_like of int, optional
        Epochs (0..n_steps) to return; all by default.

    Returns
    -------
    ndarray, shape (runs, n_steps + 1, k) or (runs, len(keep), k)
        Error states at the epochs ``0..n_steps`` (or at `keep`).

    Raises
    ------
    ParameterError
        For a step that is not finite and > 0, or a step array of another
        length than `n_steps`.

    Examples
    --------
    Without noise, a velocity error drawn from P0 moves the position by
    ``v t``, exactly, in every run:

    >>> F, G = [[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]]
    >>> X = simulate_linear(F, G, [[0.0]], np.diag([0.0, 1.0]), 0.5, 4, 3, np.random.default_rng(0))
    >>> X.shape, bool(np.allclose(X[:, -1, 0], 2.0 * X[:, 0, 1]))
    ((3, 5, 2), True)
    """
    F = np.asarray(F, dtype=float)
    G = np.asarray(G, dtype=float)
    Q = np.asarray(Q, dtype=float)
    k, m = G.shape[-2], G.shape[-1]
    dt = np.asarray(dt_s, dtype=float)
    if not np.all(np.isfinite(dt)) or np.any(dt <= 0) or dt.ndim > 1 or (dt.ndim == 1 and dt.size != n_steps):
        raise ParameterError(f"dt_s: expected a time step > 0 [s] or {n_steps} of them")
    dts, inv = (np.unique(dt, return_inverse=True) if F.ndim == 2 and G.ndim == 2 and dt.ndim == 1
                else (dt, None))
    M = np.zeros(np.broadcast_shapes(F.shape[:-2], G.shape[:-2], dts.shape) + (k + m, k + m))
    M[..., :k, :k] = F
    M[..., :k, k:] = G
    E = _expm(M * (dts[..., None, None] if dts.ndim else dts))
    if inv is not None:
        E = E[inv]
    Phi, Gam = E[..., :k, :k], E[..., :k, k:]
    # P0 may be singular (zero initial position error): factor by eigenvalues
    lam, V = np.linalg.eigh(np.asarray(P0, dtype=float))
    L0 = V * np.sqrt(np.clip(lam, 0.0, None))
    lq, Vq = np.linalg.eigh(Q)
    Lq = Vq * np.sqrt(np.clip(lq, 0.0, None))
    sdt = 1.0 / np.sqrt(np.broadcast_to(dt, (n_steps,)))
    keep = np.arange(n_steps + 1) if keep is None else np.asarray(keep, dtype=int)
    slot = np.full(n_steps + 1, -1)
    slot[keep] = np.arange(keep.size)
    out = np.empty((runs, keep.size, k))
    x = rng.standard_normal((runs, k)) @ L0.T
    if slot[0] >= 0:
        out[:, slot[0]] = x
    for i in range(n_steps):
        Ph = Phi if Phi.ndim == 2 else Phi[i]
        Ga = Gam if Gam.ndim == 2 else Gam[i]
        w = (rng.standard_normal((runs, m)) @ Lq.T) * sdt[i]
        x = x @ Ph.T + w @ Ga.T
        if slot[i + 1] >= 0:
            out[:, slot[i + 1]] = x
    return out
