"""Strapdown inertial navigation on real (non-uniform) time steps.

Two mechanizations, both in the package's navigation frame (x towards the end
point, y left, z up, gravity ``g^n = (0, 0, -g)``; see the package docstring):

:func:`ins3d`
    Full 3D strapdown for short times (no Earth rate, no transport rate, the
    navigation frame is taken as inertial, as in the paper's section
    "Inertial Navigation System" [1]_)::

        C_dot = C [omega x]        (C = C_bn, body to navigation)
        v_dot = C f + g^n
        p_dot = v

:func:`ins2d`
    The paper's planar INS (section "Two-Dimensions INS" [1]_): yaw only,
    from ``omega_z``; velocity from ``R(psi) [f_x, f_y]``; ``f_z``,
    ``omega_x`` and ``omega_y`` are ignored and the result lies in z = 0.

Integration rules. Each interval ``[t_k, t_k+1]`` uses the samples at both
ends, their time derivatives estimated by 3-point differences on the real
(non-uniform) grid, and the actual ``dt_k``; in effect each signal is
integrated as its cubic Hermite interpolant:

- attitude: exact exponential of the rotation vector of the interval,
  ``phi = int(w) + (w_k x w_k+1) dt^2 / 12``, with
  ``int(w) = dt (w_k + w_k+1)/2 + dt^2 (w'_k - w'_k+1)/12``. The cross term
  is the coning correction for a rate varying linearly over the interval
  (from the Bortz equation ``phi_dot = w + phi x w / 2`` [2]_);
- velocity: the same corrected trapezoid on ``a = C f + g^n``;
- position: ``p_k+1 = p_k + v_k dt + dt^2 (7 a_k + 3 a_k+1)/20
  + dt^3 (3 a'_k - 2 a'_k+1)/60``.

The derivative terms cancel in the sum on a uniform grid except at the two
ends (where a recording is at rest), so on uniform data this is the plain
trapezoid rule; on irregular grids (S6) it removes the trapezoid's
dt-dependent bias, which otherwise reaches ~1 mm of end error on a sine path.

Only the attitude needs a loop over time (a running product of rotation
matrices): each run's is compiled by numba (``_strapdown_loops.attitude_chains``,
imported on the first call), so a run's attitude does not depend on the batch
it is in.
The interval integrals, the coning term, the sample-time checks and the
velocity and position sums are compiled loops too (``_strapdown_loops``:
``increments``, ``coning``, ``time_order``, ``translation``; numpy's arithmetic
in its order); the accelerations are vectorized over time and runs. Batched
inputs (``(runs, n, 3)``) share one time vector.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE Journal of Indoor and Seamless Positioning and Navigation, 2023.
.. [2] P. G. Savage, "Strapdown Inertial Navigation Integration Algorithm
   Design Part 1: Attitude Algorithms", Journal of Guidance, Control, and
   Dynamics 21(1), 1998. https://doi.org/10.2514/2.4228
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import units
from .errors import ParameterError

__all__ = ["InsResult", "ins3d", "ins2d", "integrate_rate", "heading_from_C", "rotvec_to_C", "yaw_to_C", "coarse_level",
           "attitude_heading"]


@dataclass(frozen=True, eq=False)
class InsResult:
    """Navigation solution of a strapdown run.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s] (the input times).
    position : ndarray, shape (..., n, 3)
        Position in the navigation frame [m].
    velocity : ndarray, shape (..., n, 3)
        Velocity in the navigation frame [m/s].
    C_bn : ndarray, shape (..., n, 3, 3)
        Body-to-navigation rotation matrices.
    heading : ndarray, shape (..., n)
        Heading (yaw) [rad], positive to the left (about +z), continuous
        over time (unwrapped): for :func:`ins2d` the integrated yaw, for
        :func:`ins3d` :func:`heading_from_C` of ``C_bn`` unwrapped.
    """

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    C_bn: np.ndarray
    heading: np.ndarray

    @property
    def end_position(self) -> np.ndarray:
        """Position at the last sample, shape (..., 3) [m]."""
        return self.position[..., -1, :]


def heading_from_C(C) -> np.ndarray:
    """Heading (yaw of the body x axis about +z) of body-to-navigation matrices.

    Parameters
    ----------
    C : array_like, shape (..., 3, 3)
        Body-to-navigation rotation matrices.

    Returns
    -------
    ndarray, shape (...)
        ``atan2(C[1, 0], C[0, 0])`` [rad], in (-pi, pi]; the yaw of a
        z-y-x (yaw, pitch, roll) Euler sequence.

    Examples
    --------
    >>> heading_from_C(yaw_to_C([0.3, -2.0])).round(12).tolist()   # the inverse of a pure yaw
    [0.3, -2.0]
    >>> round(float(heading_from_C(np.eye(3))), 12)
    0.0
    """
    C = np.asarray(C, dtype=float)
    return np.arctan2(C[..., 1, 0], C[..., 0, 0])


def rotvec_to_C(phi) -> np.ndarray:
    """Rotation matrices ``exp([phi x])`` of rotation vectors (Rodrigues' formula).

    Parameters
    ----------
    phi : array_like, shape (..., 3)
        Rotation vectors [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``I + a [phi x] + b [phi x]^2`` with ``a = sin(t)/t``,
        ``b = (1 - cos(t))/t^2``, ``t = |phi|`` (Taylor series for small t).

    Examples
    --------
    >>> C = rotvec_to_C([0.0, 0.0, np.pi / 2])      # a quarter turn about z
    >>> (C @ [1.0, 0.0, 0.0]).round(12).tolist()
    [0.0, 1.0, 0.0]
    """
    phi = np.asarray(phi, dtype=float)
    t2 = np.einsum("...i,...i->...", phi, phi)
    t = np.sqrt(t2)
    small = t2 < 1e-8
    any_small = bool(small.any())
    ts = np.where(small, 1.0, t) if any_small else t
    a = np.sin(ts)
    a /= ts
    b = 1.0 - np.cos(ts)
    b /= ts * ts
    if any_small:
        # series to t^4: the truncation error is below 1e-17 for t^2 < 1e-8
        a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, a)
        b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, b)
    # I + a K + b K^2 with K^2 = phi phi^T - t^2 I, written out element by element
    x, y, z = phi[..., 0], phi[..., 1], phi[..., 2]
    out = b[..., None, None] * (phi[..., :, None] * phi[..., None, :])
    c = 1.0 - b * t2
    out[..., 0, 0] += c
    out[..., 1, 1] += c
    out[..., 2, 2] += c
    ax, ay, az = a * x, a * y, a * z
    out[..., 0, 1] -= az
    out[..., 1, 0] += az
    out[..., 0, 2] += ay
    out[..., 2, 0] -= ay
    out[..., 1, 2] -= ax
    out[..., 2, 1] += ax
    return out


def yaw_to_C(psi) -> np.ndarray:
    """Body-to-navigation matrices of a pure yaw (rotation about +z).

    Parameters
    ----------
    psi : float or array_like, shape (...)
        Yaw angles [rad], positive to the left (counter-clockwise seen from above).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[cos psi, -sin psi, 0], [sin psi, cos psi, 0], [0, 0, 1]]`` for each angle.

    Examples
    --------
    >>> (yaw_to_C(np.pi / 2) @ [1.0, 0.0, 0.0]).round(12).tolist()   # body x points to nav y
    [0.0, 1.0, 0.0]
    >>> yaw_to_C(np.zeros(4)).shape
    (4, 3, 3)
    """
    psi = np.asarray(psi, dtype=float)
    c, s = np.cos(psi), np.sin(psi)
    C = np.zeros(psi.shape + (3, 3))
    C[..., 0, 0], C[..., 0, 1] = c, -s
    C[..., 1, 0], C[..., 1, 1] = s, c
    C[..., 2, 2] = 1.0
    return C


# --------------------------------------------------------------------------- input checks

def coarse_level(f_rest) -> np.ndarray:
    """Initial attitude from the specific force at rest (roll and pitch; yaw 0).

    At rest the accelerometer reads the reaction to gravity,
    ``f^b = C_bn^T (0, 0, g)``, so the third row of ``C_bn`` is
    ``f^b / |f^b|``. With yaw set to zero (the navigation x axis is the
    body's heading at the start) that fixes ``C_bn = R_z(0) R_y(theta)
    R_x(phi)`` with ``phi = atan2(f_y, f_z)`` and
    ``theta = atan2(-f_x, sqrt(f_y^2 + f_z^2))``. An accelerometer bias is
    read as tilt (about 1 mrad per 10 mg), which is what an INS started this
    way cannot tell apart.

    Parameters
    ----------
    f_rest : array_like, shape (3,)
        Mean specific force over a rest period, body axes [m/s^2].

    Returns
    -------
    C_bn : ndarray, shape (3, 3)
        Body-to-navigation rotation matrix ``R_y(theta) R_x(phi)`` (yaw 0).

    Raises
    ------
    ParameterError
        If ``f_rest`` is not a finite, non-zero vector of shape (3,).

    Examples
    --------
    >>> bool(np.allclose(coarse_level([0.0, 0.0, 9.81]), np.eye(3)))   # a level phone
    True
    >>> f = [0.0, 9.81 * np.sin(0.1), 9.81 * np.cos(0.1)]           # rolled by 0.1 rad
    >>> (coarse_level(f) @ f).round(9).tolist()                      # maps back to (0, 0, g)
    [0.0, 0.0, 9.81]
    """
    f = np.asarray(f_rest, dtype=float)
    if f.shape != (3,) or not np.all(np.isfinite(f)) or not np.linalg.norm(f) > 0:
        raise ParameterError(f"f_rest={f_rest!r}: expected a finite, non-zero specific force (3,) [m/s^2]")
    phi = np.arctan2(f[1], f[2])
    theta = np.arctan2(-f[0], np.hypot(f[1], f[2]))
    cp, sp, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
    Ry = np.array([[ct, 0.0, st], [0.0, 1.0, 0.0], [-st, 0.0, ct]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    return Ry @ Rx

def _check_time(time) -> np.ndarray:
    from ._jit import read_only
    from ._strapdown_loops import compiled

    time = np.asarray(time, dtype=float)
    if time.ndim != 1 or time.shape[0] < 2:
        raise ParameterError(f"time: expected a 1-D array of at least 2 samples, got shape {time.shape}")
    time = np.require(time, float, ["C"])
    order = compiled()["time_order"](read_only(time))                      # one pass: finite, strictly increasing
    if order == 1:
        raise ParameterError("time: contains NaN or inf, expected finite sample times")
    if order == 2:
        raise ParameterError("time: not strictly increasing, expected strictly increasing sample times")
    return time


def _check_signal(name: str, x, n: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim < 2 or x.shape[-2:] != (n, 3):
        raise ParameterError(f"{name}: expected shape (n, 3) or (runs, n, 3) with n = {n}, got {x.shape}")
    if not np.isfinite(x).all():
        raise ParameterError(f"{name}: contains NaN or inf, expected finite readings")
    return x


def _check_init(name: str, x, tail: tuple, default) -> np.ndarray:
    if x is None:
        return np.asarray(default, dtype=float)
    x = np.asarray(x, dtype=float)
    if x.shape[x.ndim - len(tail):] != tail or x.ndim < len(tail):
        want = " or ".join(str(s) for s in (tail, ("runs",) + tail))
        raise ParameterError(f"{name}: expected shape {want}, got {x.shape}")
    if not np.isfinite(x).all():
        raise ParameterError(f"{name}: contains NaN or inf")
    return x


def _batch_shape(name_shapes) -> tuple:
    try:
        return np.broadcast_shapes(*(s for _, s in name_shapes))
    except ValueError:
        desc = ", ".join(f"{n} {s}" for n, s in name_shapes)
        raise ParameterError(f"batch shapes do not match: {desc}; expected the same leading runs axis") from None


def _increments(time, x):
    """Integral of `x` (B, n, ...) over each interval: trapezoid with the Hermite end correction.

    ``int = dt (x_k + x_k+1) / 2 + dt^2 (x'_k - x'_k+1) / 12``, exact for cubics when the
    slopes are exact; with 3-point slopes the local error is O(dt^4). The slopes ``x'`` are the
    3-point non-uniform differences (the derivative of the quadratic through each sample and its
    two neighbours, one-sided quadratics at both ends; second-order accurate). Returns the
    integrals (B, n - 1, ...) and the slopes (B, n, ...), computed by a compiled loop
    (``_strapdown_loops.increments``).
    """
    from ._strapdown_loops import compiled

    B, n = x.shape[:2]
    x3 = np.require(x, float, ["C", "W"]).reshape(B, n, -1)    # one compiled signature
    inc, d = np.empty((B, n - 1, x3.shape[2])), np.empty(x3.shape)
    compiled()["increments"](np.require(time, float, ["C", "W"]), x3, inc, d)
    return inc.reshape((B, n - 1) + x.shape[2:]), d.reshape(x.shape)


def integrate_rate(time, rate, x0=0.0) -> np.ndarray:
    """Running integral of a rate on the real time steps (heading from a yaw rate, for example).

    Each interval integrates the cubic Hermite interpolant of the samples with
    3-point slopes: ``x_k+1 = x_k + dt (r_k + r_k+1)/2 + dt^2 (r'_k - r'_k+1)/12``
    (the trapezoid plus its end correction). The same rule integrates the
    attitude increments of :func:`ins3d` and the heading of :func:`ins2d`.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s], strictly increasing (n >= 2).
    rate : array_like, shape (..., n)
        Rate samples along the last axis [unit/s].
    x0 : float or array_like, shape (...)
        Value at ``time[0]`` [unit].

    Returns
    -------
    ndarray, shape (..., n)
        The integral [unit], ``x0`` at ``time[0]``.

    Examples
    --------
    >>> integrate_rate([0.0, 0.5, 2.0], [0.1, 0.1, 0.1]).round(12).tolist()
    [0.0, 0.05, 0.2]
    """
    time = _check_time(time)
    r = np.asarray(rate, dtype=float)
    if r.shape[-1:] != time.shape:
        raise ParameterError(f"rate: expected the last axis to have {time.shape[0]} samples, got shape {r.shape}")
    batch = r.shape[:-1]
    rb = r.reshape(-1, time.shape[0])
    x0b = np.broadcast_to(np.asarray(x0, dtype=float), batch).reshape(-1)
    out = np.empty_like(rb)
    out[:, 0] = x0b
    np.cumsum(_increments(time, rb)[0], axis=1, out=out[:, 1:])
    out[:, 1:] += x0b[:, None]
    return out.reshape(r.shape)


def _integrate_translation(time, a, v0, p0):
    """Velocity and position from navigation-frame accelerations.

    a : (B, n, 3), v0, p0 : (B, 3). Returns v, p of shape (B, n, 3). Each interval
    integrates the cubic Hermite interpolant of `a` (values and 3-point slopes at
    both ends): ``dv = dt (a_k + a_k+1)/2 + dt^2 (a'_k - a'_k+1)/12``,
    ``dp = v_k dt + dt^2 (7 a_k + 3 a_k+1)/20 + dt^3 (3 a'_k - 2 a'_k+1)/60``.
    """
    from ._strapdown_loops import compiled

    dt = np.diff(time)
    a = np.require(a, float, ["C", "W"])
    dv, d = _increments(time, a)
    v, p = np.empty(a.shape), np.empty(a.shape)
    compiled()["translation"](dt, a, d, dv, dt ** 3 / 60.0, np.require(v0, float, ["C", "W"]),
                              np.require(p0, float, ["C", "W"]), v, p)
    return v, p


# --------------------------------------------------------------------------- mechanizations

def _attitude_matrices(time, wb, C0b) -> np.ndarray:
    """The attitude part of :func:`ins3d`: ``C_bn`` of B runs at every sample, shape (B, n, 3, 3).

    `time` (n,) checked, `wb` (B, n, 3) the body rates, `C0b` (B, 3, 3) the initial attitudes.
    """
    from ._jit import read_only
    from ._strapdown_loops import compiled

    n, B = time.shape[0], wb.shape[0]
    wb = np.require(wb, float, ["C", "W"])
    phi = _increments(time, wb)[0]
    # the coning term, (w_j x w_j+1) dt^2 / 12 per interval (a compiled loop)
    compiled()["coning"](read_only(time), wb, phi)
    # each run's running product C0 E_0 E_1 ... in a compiled loop (numba, loaded on the first call): Rodrigues'
    # formula and 3 x 3 products, each sum in plain order; a run's attitude does not depend on its batch
    C = np.empty((B, n, 3, 3))
    compiled()["attitude_chains"](phi, read_only(np.broadcast_to(C0b, (B, 3, 3))), C)
    return C


def ins3d(time, f, omega, *, C0=None, v0=None, p0=None, g: float = units.G0) -> InsResult:
    """3D strapdown INS in the navigation frame (z up).

    Parameters
    ----------
    time : array_like, shape (n,)
        Real sample times [s], strictly increasing (need not be uniform).
    f : array_like, shape (n, 3) or (runs, n, 3)
        Specific force in the body frame [m/s^2].
    omega : array_like, shape (n, 3) or (runs, n, 3)
        Angular rate of the body in the body frame [rad/s].
    C0 : array_like, shape (3, 3) or (runs, 3, 3), optional
        Initial body-to-navigation matrix (default identity).
    v0, p0 : array_like, shape (3,) or (runs, 3), optional
        Initial velocity [m/s] and position [m] (default zero).
    g : float
        Gravity magnitude [m/s^2]; ``g^n = (0, 0, -g)``.

    Returns
    -------
    InsResult
        Arrays with the broadcast leading runs axis of the inputs (none when
        every input is unbatched).

    Raises
    ------
    ParameterError
        For a bad shape, a non-finite value or non-increasing time.

    Notes
    -----
    One step from ``t_k`` to ``t_k+1`` (``dt = t_k+1 - t_k``)::

        phi   = dt (w_k + w_k+1)/2 + dt^2 (w'_k - w'_k+1)/12 + dt^2 (w_k x w_k+1)/12
        C_k+1 = C_k exp([phi x])
        a_k   = C_k f_k + g^n
        v_k+1 = v_k + dt (a_k + a_k+1)/2 + dt^2 (a'_k - a'_k+1)/12
        p_k+1 = p_k + v_k dt + dt^2 (7 a_k + 3 a_k+1)/20 + dt^3 (3 a'_k - 2 a'_k+1)/60

    with ``x'`` the 3-point derivative estimate on the real time grid (see
    the module docstring).

    The attitude is a compiled loop over time per run; the other terms are
    vectorized over time and runs. Memory: ``C_bn`` holds ``runs * n * 9``
    floats; chunk large Monte Carlo batches.

    Examples
    --------
    >>> t = np.arange(101) * 0.01                     # one second at rest, level, exact gravity
    >>> r = ins3d(t, np.tile([0.0, 0.0, units.G0], (101, 1)), np.zeros((101, 3)), g=units.G0)
    >>> r.position.shape, float(np.abs(r.position).max())
    ((101, 3), 0.0)

    A constant 1 m/s^2 forward for 2 s covers ``a t^2 / 2 = 2`` m (the
    integrator is exact on a constant acceleration), also on an uneven grid:

    >>> t = np.cumsum(np.r_[0.0, np.tile([0.01, 0.03], 50)])       # 2 s, non-uniform steps
    >>> f = np.tile([1.0, 0.0, units.G0], (t.size, 1))
    >>> r = ins3d(t, f, np.zeros_like(f))
    >>> r.end_position.round(9).tolist(), round(float(r.velocity[-1, 0]), 9)
    ([2.0, 0.0, 0.0], 2.0)
    """
    time = _check_time(time)
    n = time.shape[0]
    f = _check_signal("f", f, n)
    omega = _check_signal("omega", omega, n)
    C0 = _check_init("C0", C0, (3, 3), np.eye(3))
    v0 = _check_init("v0", v0, (3,), np.zeros(3))
    p0 = _check_init("p0", p0, (3,), np.zeros(3))
    if C0.shape[-2:] == (3, 3) and not np.allclose(C0 @ np.swapaxes(C0, -1, -2), np.eye(3), atol=1e-9):
        raise ParameterError("C0: not a rotation matrix (C0 C0^T != I)")
    batch = _batch_shape([("f", f.shape[:-2]), ("omega", omega.shape[:-2]), ("C0", C0.shape[:-2]),
                          ("v0", v0.shape[:-1]), ("p0", p0.shape[:-1])])
    B = int(np.prod(batch, dtype=int))
    fb = np.broadcast_to(f, batch + (n, 3)).reshape(B, n, 3)
    wb = np.broadcast_to(omega, batch + (n, 3)).reshape(B, n, 3)
    C0b = np.broadcast_to(C0, batch + (3, 3)).reshape(B, 3, 3)
    v0b = np.broadcast_to(v0, batch + (3,)).reshape(B, 3)
    p0b = np.broadcast_to(p0, batch + (3,)).reshape(B, 3)

    C = _attitude_matrices(time, wb, C0b)                      # (B, n, 3, 3)

    a = (C @ fb[..., None])[..., 0]
    a[..., 2] -= g
    v, p = _integrate_translation(time, a, v0b, p0b)
    return InsResult(time=time, position=p.reshape(batch + (n, 3)), velocity=v.reshape(batch + (n, 3)),
                     C_bn=C.reshape(batch + (n, 3, 3)),
                     heading=np.unwrap(heading_from_C(C), axis=-1).reshape(batch + (n,)))


def ins2d(time, f, omega, *, psi0=0.0, v0=None, p0=None) -> InsResult:
    """Planar INS (the paper's "Two-Dimensions INS"): yaw from ``omega_z`` only.

    Parameters
    ----------
    time : array_like, shape (n,)
        Real sample times [s], strictly increasing.
    f : array_like, shape (n, 3) or (runs, n, 3)
        Specific force in the body frame [m/s^2]; only ``f_x, f_y`` are used.
    omega : array_like, shape (n, 3) or (runs, n, 3)
        Angular rate [rad/s]; only ``omega_z`` is used.
    psi0 : float or array_like, shape (runs,)
        Initial heading [rad], positive to the left.
    v0, p0 : array_like, shape (3,) or (runs, 3), optional
        Initial velocity and position; their z components are ignored.

    Returns
    -------
    InsResult
        Position and velocity with z = 0, ``C_bn`` the yaw-only matrices,
        ``heading`` the integrated (unwrapped) yaw.

    Raises
    ------
    ParameterError
        For a bad shape, a non-finite value or non-increasing time.

    Notes
    -----
    ``psi_k+1 = psi_k + dt (w_z,k + w_z,k+1)/2 + dt^2 (w_z,k' - w_z,k+1')/12``;
    ``a_k = R(psi_k) [f_x,k, f_y,k]``; velocity and position as in
    :func:`ins3d`.

    Examples
    --------
    A body heading 90 deg left, pushed forward at 1 m/s^2 for 1 s, ends
    0.5 m along the navigation y axis; ``f_z`` is ignored:

    >>> t = np.linspace(0.0, 1.0, 101)
    >>> f = np.tile([1.0, 0.0, 123.0], (101, 1))
    >>> r = ins2d(t, f, np.zeros((101, 3)), psi0=np.pi / 2)
    >>> r.end_position.round(9).tolist(), round(float(r.heading[-1]), 6)
    ([0.0, 0.5, 0.0], 1.570796)

    Two runs at once through a leading runs axis:

    >>> ins2d(t, np.stack([f, 2 * f]), np.zeros((101, 3))).end_position.round(9).tolist()
    [[0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]
    """
    time = _check_time(time)
    n = time.shape[0]
    f = _check_signal("f", f, n)
    omega = _check_signal("omega", omega, n)
    psi0 = np.asarray(psi0, dtype=float)
    if not np.isfinite(psi0).all():
        raise ParameterError("psi0: contains NaN or inf")
    v0 = _check_init("v0", v0, (3,), np.zeros(3))
    p0 = _check_init("p0", p0, (3,), np.zeros(3))
    batch = _batch_shape([("f", f.shape[:-2]), ("omega", omega.shape[:-2]), ("psi0", psi0.shape),
                          ("v0", v0.shape[:-1]), ("p0", p0.shape[:-1])])
    B = int(np.prod(batch, dtype=int))
    fb = np.broadcast_to(f, batch + (n, 3)).reshape(B, n, 3)
    wz = np.broadcast_to(omega[..., 2], batch + (n,)).reshape(B, n)
    psi0b = np.broadcast_to(psi0, batch).reshape(B)
    v0b = np.broadcast_to(v0, batch + (3,)).reshape(B, 3).copy()
    p0b = np.broadcast_to(p0, batch + (3,)).reshape(B, 3).copy()
    v0b[:, 2] = 0.0
    p0b[:, 2] = 0.0

    psi = integrate_rate(time, wz, psi0b)
    c, s = np.cos(psi), np.sin(psi)
    a = np.zeros((B, n, 3))
    a[..., 0] = c * fb[..., 0] - s * fb[..., 1]
    a[..., 1] = s * fb[..., 0] + c * fb[..., 1]
    v, p = _integrate_translation(time, a, v0b, p0b)
    return InsResult(time=time, position=p.reshape(batch + (n, 3)), velocity=v.reshape(batch + (n, 3)),
                     C_bn=yaw_to_C(psi).reshape(batch + (n, 3, 3)), heading=psi.reshape(batch + (n,)))


def attitude_heading(time, f, omega, f_rest) -> np.ndarray:
    """Heading from the attitude matrix of the 3D mechanization, relative to its start [rad].

    The paper's heading equation: the yaw of ``C_bn`` of :func:`ins3d`,
    started with the roll and pitch of the rest specific force
    (:func:`coarse_level`, gravity ``|f_rest|``). On a level phone it is the
    integrated z rate; on a tilted one it also takes the x and y rates that
    turn the phone about the vertical.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s].
    f, omega : array_like, shape (n, 3)
        Specific force [m/s^2] and angular rate [rad/s], body axes.
    f_rest : array_like, shape (3,)
        Mean specific force over a rest period before `time[0]` [m/s^2].

    Returns
    -------
    ndarray, shape (n,)
        Yaw minus its first value [rad].

    Examples
    --------
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> w = np.zeros((t.size, 3)); w[:, 2] = 0.1
    >>> f = np.tile([0.0, 0.0, 9.81], (t.size, 1))
    >>> round(float(attitude_heading(t, f, w, [0.0, 0.0, 9.81])[-1]), 6)   # level: 0.1 rad/s for 1.99 s
    0.199
    """
    f_rest = np.asarray(f_rest, dtype=float)
    # the attitude of ins3d (the specific force enters only through the initial level)
    time = _check_time(time)
    n = time.shape[0]
    _check_signal("f", f, n)
    omega = _check_signal("omega", omega, n)
    if omega.ndim != 2:
        raise ParameterError(f"omega: shape {omega.shape}, expected ({n}, 3) (one recording)")
    C = _attitude_matrices(time, omega[None], coarse_level(f_rest)[None])[0]
    psi = np.unwrap(heading_from_C(C))
    return psi - psi[0]
