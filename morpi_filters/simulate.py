"""Synthetic trajectories and IMU synthesis.

The synthetic dataset in the field layout built from them is in
:mod:`morpi_filters.synthetic`.

Trajectories
    :func:`straight`, :func:`sine` and :func:`l_route` (and :func:`route_trajectory`
    for a route of ``data/routes.json``) build a :class:`Trajectory` with exact
    kinematics: the path is an analytic function of its centreline arc length
    ``u`` and time enters only through an analytic speed law ``u(t)``, so
    velocity, acceleration, attitude and angular rate are analytic derivatives
    (no finite differences). Position on a turn is the integral of the
    analytic tangent, evaluated by piecewise Gauss-Legendre quadrature to
    rounding accuracy.

    Geometry (navigation frame: x to the end point, y left, z up):

    - centreline: straight legs joined by a turn whose curvature rises and
      falls smoothly (C2 ramps, quintic smoothstep) around a constant-radius
      arc, so the angular rate and specific force are continuous;
    - periodic motion: a lateral horizontal offset ``A W(u) sin(2 pi u / P)``
      from the centreline, ``W`` a smooth taper over one period at both
      ends (the body starts and stops heading along the centreline);
    - optional downhill slope on the first metres (horizontal length),
      easing into level ground over 1 m;
    - the body x axis follows the path tangent (yaw = path heading, pitch =
      path inclination), body y stays horizontal (no roll);
    - speed law: rest, a smooth (C2) acceleration ramp, constant speed, a
      smooth stop, rest.

    Specific force ``f_b = C_nb (a^n - g^n)`` and angular rate
    ``omega_b = (psi_dot sin(gamma), -gamma_dot, psi_dot cos(gamma))`` for
    ``C_bn = R_z(psi) R_y(-gamma)`` (``gamma`` path inclination, positive up).

IMU synthesis
    :func:`imu` turns a trajectory into sensor readings from a
    :class:`~morpi_filters.units.SensorSpec`: turn-on bias per run, white
    noise from the noise density and the actual sampling interval
    (``sigma_k = density / sqrt(dt_k)``), optional bias random walk,
    Gauss-Markov bias instability, scale factor, mounting misalignment and
    motion vibration, on uniform or S6/S8-like irregular time stamps. Runs are
    batched on axis 0; every draw comes from the caller's ``rng`` (one
    Generator, or one per run so a run's draws do not depend on batching).

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
  IEEE Journal of Indoor and Seamless Positioning and Navigation, 2023.
- [2] P. D. Groves, "Principles of GNSS, Inertial, and Multisensor Integrated
  Navigation Systems", 2nd ed., Artech House, 2013 (ch. 4: IMU error model).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from . import dataset, units
from .deprecation import renamed_attribute, renamed_keywords
from .errors import ParameterError
from .strapdown import rotvec_to_C

__all__ = [
    "Trajectory", "ImuData", "straight", "sine", "l_route", "route_trajectory", "imu",
    "sample_times", "paper_speed", "L_ROUTE_SPEED",
]

# typical driven speeds [m/s] along the centreline, from the paper's average durations over 6.3 m:
# ~5 s straight, ~14.5 s with 1 m periods, ~11 s with 1.5 m periods (1 s ramps at both ends)
_SPEED = {"straight": 6.3 / 4.0, 1.0: 6.3 / 13.5, 1.5: 6.3 / 10.0}
#: Cruise speed of the paper's robot on the L route [m/s]: the field L recordings last 45-90 s for 28 m.
L_ROUTE_SPEED = 0.6



@renamed_keywords(period="p2p_m")
def paper_speed(p2p_m: float | None = None) -> float:
    """Cruise speed of the paper's robot [m/s]: on a straight line, or on a sine of peak-to-peak distance `p2p_m`.

    From the paper's average durations over 6.3 m with 1 s ramps: about 5 s on
    a straight line, 14.5 s with 1 m periods and 11 s with 1.5 m periods;
    other periods scale with the square root of the period from 1 m.

    Parameters
    ----------
    p2p_m : float, optional
        Peak-to-peak distance (period length) of the sine path [m]; None for a straight line.

    Returns
    -------
    float
        Cruise speed along the centreline [m/s].

    Raises
    ------
    ParameterError
        A period that is not a positive finite number.

    Examples
    --------
    >>> round(paper_speed(1.0), 4), round(paper_speed(), 4)     # 6.3 m in 13.5 s and in 4 s
    (0.4667, 1.575)
    >>> round(paper_speed(1.5), 4)                              # 6.3 m in 10 s
    0.63
    >>> round(paper_speed(4.0) / paper_speed(1.0), 12)          # sqrt(4) for a period not in the paper
    2.0
    """
    if p2p_m is None:
        return _SPEED["straight"]
    p2p_m = _positive("p2p_m", p2p_m)
    return _SPEED.get(p2p_m, _SPEED[1.0] * p2p_m ** 0.5)


# --------------------------------------------------------------------------- smooth steps

def _s5(x):
    """Quintic smoothstep S, S', S'' on [0, 1] (clamped outside)."""
    x = np.clip(x, 0.0, 1.0)
    x2 = x * x
    return (x2 * x * (10.0 - 15.0 * x + 6.0 * x2), 30.0 * x2 * (1.0 - x) ** 2,
            60.0 * x * (1.0 - x) * (1.0 - 2.0 * x))


def _s5_int(x):
    """Integral of S from 0 to x (x clamped to [0, 1]); 0.5 at x = 1."""
    x = np.clip(x, 0.0, 1.0)
    x2 = x * x
    return x2 * x2 * (2.5 - 3.0 * x + x2)


# --------------------------------------------------------------------------- checks

def _positive(name, v, *, allow_zero=False):
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ParameterError(f"{name}: expected a number, got {v!r}") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        want = "a finite number >= 0" if allow_zero else "a finite number > 0"
        raise ParameterError(f"{name}: expected {want}, got {v!r}")
    return v


# --------------------------------------------------------------------------- path model

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


class _Path:
    """Centreline (legs, smooth turn, slope) plus a tapered sine offset, as functions of u."""

    def __init__(self, legs, turn_rad, radius, slope_rad, slope_len, period, amplitude, taper):
        self.legs = legs                        # (a1, a2): straight leg lengths [m]
        self.turn = turn_rad
        self.k0 = 0.0 if turn_rad == 0 else math.copysign(1.0 / radius, turn_rad)
        if turn_rad != 0:
            arc = abs(turn_rad) * radius
            self.ramp = arc / 3.0               # curvature ramp length, each side
            self.const = arc - self.ramp        # turn: kappa0 * (ramp + const) = turn
        else:
            self.ramp = self.const = 0.0
        self.u1 = legs[0]
        self.turn_len = 2 * self.ramp + self.const
        self.length = legs[0] + self.turn_len + legs[1]
        self.slope_t = math.tan(slope_rad)
        self.slope_len = slope_len
        self.slope_ease = 1.0
        self.k = 0.0 if not period else 2 * math.pi / period
        self.A = amplitude or 0.0
        self.taper = taper
        # breakpoints of the turn's three pieces, and the heading/offset at each
        self._pieces = [self.u1, self.u1 + self.ramp, self.u1 + self.ramp + self.const, self.u1 + self.turn_len]
        self._turn_xy = [np.zeros(2)]
        for a, b in zip(self._pieces[:-1], self._pieces[1:]):
            self._turn_xy.append(self._turn_xy[-1] + self._gl(a, np.array([b]))[0])

    # ---- centreline heading and curvature
    def theta(self, u):
        """Centreline heading theta(u), curvature kappa(u) and its derivative."""
        if self.turn == 0:
            z = np.zeros_like(u)
            return z, z, z
        r, c, k0 = self.ramp, self.const, self.k0
        s = u - self.u1
        x1 = s / r
        x3 = (s - r - c) / r
        S1, dS1, _ = _s5(x1)
        S3, dS3, _ = _s5(x3)
        kappa = k0 * (S1 - S3)
        dkappa = k0 * (dS1 - dS3) / r
        # integral of kappa: ramp in (r/2 when complete), constant part, ramp out (r/2 when complete)
        ramp_out = np.where(x3 > 0, r * (np.clip(x3, 0, 1) - _s5_int(x3)), 0.0)
        th = k0 * (r * _s5_int(x1) + np.clip(s - r, 0.0, c) + ramp_out)
        return th, kappa, dkappa

    def _gl(self, a, b):
        """Integral of (cos theta, sin theta) from scalar a to each b (a <= b, one smooth piece)."""
        half = 0.5 * (b - a)
        uq = a + half[:, None] * (_GL_X[None, :] + 1.0)
        th = self.theta(uq)[0]
        return np.stack([np.cos(th) @ _GL_W * half, np.sin(th) @ _GL_W * half], axis=-1)

    def centre_xy(self, u):
        """Horizontal centreline position c(u), shape (n, 2)."""
        out = np.zeros(u.shape + (2,))
        before = u <= self.u1
        out[before, 0] = u[before]
        if self.turn == 0:
            out[~before, 0] = u[~before]
            return out
        p = self._pieces
        for i in range(3):
            m = (u > p[i]) & (u <= p[i + 1])
            if m.any():
                out[m] = np.array([self.u1, 0.0]) + self._turn_xy[i] + self._gl(p[i], u[m])
        after = u > p[3]
        if after.any():
            end = np.array([self.u1, 0.0]) + self._turn_xy[3]
            out[after] = end + (u[after] - p[3])[:, None] * np.array([math.cos(self.turn), math.sin(self.turn)])
        return out

    # ---- slope
    def z(self, u):
        """Height z(u) and its first two derivatives in u."""
        if self.slope_t == 0:
            zz = np.zeros_like(u)
            return zz, zz, zz
        ell = self.slope_ease
        a = self.slope_len - ell / 2
        x = (u - a) / ell
        S, dS, _ = _s5(x)
        z = -self.slope_t * (u - ell * _s5_int(x) - np.maximum(0.0, u - a - ell))
        return z, -self.slope_t * (1.0 - S), self.slope_t * dS / ell

    # ---- lateral offset
    def offset(self, u):
        """Lateral offset y(u) and its first two derivatives."""
        if self.A == 0:
            zz = np.zeros_like(u)
            return zz, zz, zz
        L, ell, k = self.length, self.taper, self.k
        Sa, dSa, ddSa = _s5(u / ell)
        Sb, dSb, ddSb = _s5((L - u) / ell)
        W = Sa * Sb
        dW = (dSa * Sb - Sa * dSb) / ell
        ddW = (ddSa * Sb - 2 * dSa * dSb + Sa * ddSb) / ell ** 2
        sn, cs = np.sin(k * u), np.cos(k * u)
        A = self.A
        return A * W * sn, A * (dW * sn + k * W * cs), A * (ddW * sn + 2 * k * dW * cs - k * k * W * sn)

    def geometry(self, u):
        """Position r(u), tangent r'(u) and r''(u), each (n, 3)."""
        th, kap, dkap = self.theta(u)
        y, dy, ddy = self.offset(u)
        z, dz, ddz = self.z(u)
        t = np.stack([np.cos(th), np.sin(th)], axis=-1)
        nrm = np.stack([-t[:, 1], t[:, 0]], axis=-1)
        r = np.empty(u.shape + (3,))
        r[:, :2] = self.centre_xy(u) + y[:, None] * nrm
        r[:, 2] = z
        d1 = np.empty_like(r)
        d1[:, :2] = t * (1.0 - y * kap)[:, None] + dy[:, None] * nrm
        d1[:, 2] = dz
        d2 = np.empty_like(r)
        d2[:, :2] = nrm * (kap * (1.0 - y * kap) + ddy)[:, None] + t * (-2.0 * dy * kap - y * dkap)[:, None]
        d2[:, 2] = ddz
        return r, d1, d2


class _SpeedLaw:
    """u(t): rest, smooth ramp up, cruise at speed V, smooth ramp down, rest."""

    def __init__(self, length, speed, ramp, rest0, rest1, t0):
        self.L, self.V, self.Tr, self.t0 = length, speed, ramp, t0
        self.Tc = length / speed - ramp
        if self.Tc < 0:
            raise ParameterError(f"speed_mps: {speed!r} m/s is too fast to cover {length:.3g} m with {ramp:g} s ramps; "
                                 f"expected at most {length / ramp:.3g} m/s")
        self.start = t0 + rest0
        self.stop = self.start + 2 * ramp + self.Tc
        self.end = self.stop + rest1

    def __call__(self, t):
        V, Tr, Tc = self.V, self.Tr, self.Tc
        tau = np.asarray(t, dtype=float) - self.start
        x1 = tau / Tr
        x3 = (tau - Tr - Tc) / Tr
        S1, dS1, ddS1 = _s5(x1)
        S3, dS3, ddS3 = _s5(x3)
        u = V * (Tr * _s5_int(x1) + np.clip(tau - Tr, 0.0, Tc)
                 + np.where(x3 > 0, Tr * (np.clip(x3, 0, 1) - _s5_int(x3)), 0.0))
        du = V * (S1 - S3)
        ddu = V * (dS1 - dS3) / Tr
        return u, du, ddu

    def inverse(self, u):
        """Times at which the centreline distance first reaches each u (bisection)."""
        u = np.atleast_1d(np.asarray(u, dtype=float))
        lo = np.full(u.shape, self.start)
        hi = np.full(u.shape, self.stop)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            below = self(mid)[0] < u
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        return 0.5 * (lo + hi)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """True motion of the body, sampled at `time`.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s].
    position, velocity, acceleration : ndarray, shape (n, 3)
        In the navigation frame [m, m/s, m/s^2].
    C_bn : ndarray, shape (n, 3, 3)
        Body-to-navigation matrices.
    heading, pitch : ndarray, shape (n,)
        Path heading (about +z, unwrapped) and inclination (positive up) [rad].
    f_b : ndarray, shape (n, 3)
        True specific force in the body frame [m/s^2].
    omega_b : ndarray, shape (n, 3)
        True angular rate in the body frame [rad/s].
    kind : str
        ``"straight"``, ``"sine"`` or ``"l_route"``.
    start_time, stop_time : float
        Times the motion starts and stops [s] (rest before and after).
    centreline_length : float
        Horizontal length of the centreline [m].
    distance : float
        Travelled 3D path length, including the lateral weaving [m].
    end_point : ndarray, shape (3,)
        Position at rest after the motion [m].
    p2p_m, amplitude_m : float or None
        Peak-to-peak distance (period length) and lateral amplitude of the periodic motion [m].
    peak_times : ndarray, shape (m,)
        Times of the lateral extremes of the periodic motion [s] (empty if none).
    peak_side : ndarray, shape (m,)
        +1 for an extreme to the left, -1 to the right.
    period_times : ndarray, shape (k,)
        Times the centreline distance passes each multiple of the period
        (period boundaries, upward zero crossings of the untapered sine) [s].
    """

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    C_bn: np.ndarray
    heading: np.ndarray
    pitch: np.ndarray
    f_b: np.ndarray
    omega_b: np.ndarray
    kind: str
    start_time: float
    stop_time: float
    centreline_length: float
    distance: float
    end_point: np.ndarray
    p2p_m: float | None = None
    amplitude_m: float | None = None
    peak_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    peak_side: np.ndarray = field(default_factory=lambda: np.zeros(0))
    period_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    _model: tuple = field(default=None, repr=False)

    @property
    def end_time(self) -> float:
        """Time of the end of the trajectory (rest included) [s]."""
        return float(self._model[1].end)

    def at(self, time) -> "Trajectory":
        """The same trajectory sampled at other times (any times; rest outside the motion).

        Parameters
        ----------
        time : array_like, shape (m,)
            Finite sample times [s], in any order.

        Returns
        -------
        Trajectory
            A copy with every sampled field (``time``, ``position``, ...,
            ``omega_b``) evaluated at `time`; the path and speed law are shared.

        Examples
        --------
        >>> traj = straight(6.3)
        >>> traj.at([0.0, 1e6]).position[:, 0].round(9).tolist()    # at the start, and long after the stop
        [0.0, 6.3]
        """
        time = np.asarray(time, dtype=float)
        if time.ndim != 1 or not np.isfinite(time).all():
            raise ParameterError("time: expected a 1-D array of finite sample times")
        return replace(self, **_kinematics(*self._model, time))


Trajectory.period = renamed_attribute("Trajectory", "period", "p2p_m")
Trajectory.amplitude = renamed_attribute("Trajectory", "amplitude", "amplitude_m")


def _kinematics(path: _Path, law: _SpeedLaw, g: float, time: np.ndarray) -> dict:
    u, du, ddu = law(time)
    r, d1, d2 = path.geometry(u)
    vel = d1 * du[:, None]
    acc = d2 * (du * du)[:, None] + d1 * ddu[:, None]
    hx, hy, hz = d1[:, 0], d1[:, 1], d1[:, 2]
    h2 = hx * hx + hy * hy
    h = np.sqrt(h2)
    psi = np.unwrap(np.arctan2(hy, hx))
    dpsi_du = (hx * d2[:, 1] - hy * d2[:, 0]) / h2
    dh_du = (hx * d2[:, 0] + hy * d2[:, 1]) / h
    gam = np.arctan2(hz, h)
    dgam_du = (h * d2[:, 2] - hz * dh_du) / (h2 + hz * hz)
    psid, gamd = dpsi_du * du, dgam_du * du
    cp, sp, cg, sg = np.cos(psi), np.sin(psi), np.cos(gam), np.sin(gam)
    C = np.empty(time.shape + (3, 3))
    # C_bn = R_z(psi) R_y(-gamma): columns are body x (tangent), body y (horizontal left), body z
    C[:, :, 0] = np.stack([cp * cg, sp * cg, sg], axis=-1)
    C[:, :, 1] = np.stack([-sp, cp, np.zeros_like(cp)], axis=-1)
    C[:, :, 2] = np.stack([-cp * sg, -sp * sg, cg], axis=-1)
    fn = acc.copy()
    fn[:, 2] += g
    f_b = np.einsum("nji,nj->ni", C, fn)
    omega = np.stack([psid * sg, -gamd, psid * cg], axis=-1)
    return dict(time=time, position=r, velocity=vel, acceleration=acc, C_bn=C, heading=psi, pitch=gam,
                f_b=f_b, omega_b=omega)


def _build(kind, path: _Path, *, speed, ramp, rest, rate_hz, t0, g, period=None, amplitude=None) -> Trajectory:
    speed = _positive("speed_mps", speed)
    ramp = _positive("ramp_s", ramp)
    rate_hz = _positive("rate_hz", rate_hz)
    rest0, rest1 = (rest, rest) if np.ndim(rest) == 0 else tuple(rest)
    rest0, rest1 = _positive("rest_s", rest0, allow_zero=True), _positive("rest_s", rest1, allow_zero=True)
    t0 = float(t0)
    if not math.isfinite(t0):
        raise ParameterError(f"t0: expected a finite start time, got {t0!r}")
    law = _SpeedLaw(path.length, speed, ramp, rest0, rest1, t0)
    n = int(math.floor((law.end - t0) * rate_hz + 1e-9)) + 1
    time = t0 + np.arange(n) / rate_hz
    kin = _kinematics(path, law, g, time)
    # travelled 3D length by composite Gauss-Legendre over 2 cm pieces of the centreline
    edges = np.linspace(0.0, path.length, max(2, int(path.length / 0.02) + 1))
    half = 0.5 * np.diff(edges)
    uq = (edges[:-1, None] + half[:, None] * (_GL_X[None, :] + 1.0)).ravel()
    speed_u = np.linalg.norm(path.geometry(uq)[1], axis=1).reshape(-1, _GL_X.size)
    distance = float(np.sum((speed_u @ _GL_W) * half))
    end_point = path.geometry(np.array([path.length]))[0][0]
    peak_t, side, bounds = np.zeros(0), np.zeros(0), np.zeros(0)
    if path.A:
        uu = np.linspace(0.0, path.length, int(path.length * 400) + 2)
        dy = path.offset(uu)[1]
        idx = np.flatnonzero(np.sign(dy[:-1]) * np.sign(dy[1:]) < 0)
        lo, hi = uu[idx], uu[idx + 1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            same = np.sign(path.offset(mid)[1]) == np.sign(path.offset(lo)[1])
            lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        up = 0.5 * (lo + hi)
        peak_t = law.inverse(up)
        side = np.sign(path.offset(up)[0])
        bounds = law.inverse(np.arange(1, int(path.length / period + 1e-9) + 1) * period)
    return Trajectory(**kin, kind=kind, start_time=law.start, stop_time=law.stop, centreline_length=path.length,
                      distance=distance, end_point=end_point, p2p_m=period, amplitude_m=amplitude,
                      peak_times=peak_t, peak_side=side, period_times=bounds, _model=(path, law, g))


@renamed_keywords(length="length_m", speed="speed_mps", ramp="ramp_s", rest="rest_s")
def straight(length_m: float = 6.3, *, speed_mps: float = _SPEED["straight"], ramp_s: float = 1.0, rest_s=3.0,
             rate_hz: float = 100.0, t0: float = 0.0, g: float = units.G0) -> Trajectory:
    """Straight line along x, from rest to rest.

    Parameters
    ----------
    length_m : float
        Distance [m].
    speed_mps : float
        Cruise speed [m/s] (default: 6.3 m in about 5 s, the paper's average).
    ramp_s : float
        Duration of the smooth start and of the smooth stop [s].
    rest_s : float or (float, float)
        Rest before and after the motion [s].
    rate_hz : float
        Sampling rate of the returned samples [Hz] (use :meth:`Trajectory.at` for other times).
    t0 : float
        Time of the first sample [s].
    g : float
        Gravity [m/s^2].

    Returns
    -------
    Trajectory
        ``kind`` ``"straight"``, sampled at `rate_hz` from `t0` to the end
        of the second rest.

    Raises
    ------
    ParameterError
        A non-positive or non-finite length, speed, ramp or rest.

    Examples
    --------
    >>> traj = straight(6.3)
    >>> round(float(traj.position[-1, 0]), 9), float(traj.velocity[-1, 0])    # ends at rest, 6.3 m along x
    (6.3, 0.0)
    >>> round(traj.start_time, 9)                                # after the 3 s rest
    3.0
    """
    length = _positive("length_m", length_m)
    return _build("straight", _Path((length, 0.0), 0.0, 1.0, 0.0, 0.0, None, None, None),
                  speed=speed_mps, ramp=ramp_s, rest=rest_s, rate_hz=rate_hz, t0=t0, g=g)


def _check_sine(period, amplitude, taper, length):
    period = _positive("p2p_m", period)
    amplitude = _positive("amplitude_m", amplitude)
    if amplitude * 2 * math.pi / period > 1.5:
        raise ParameterError(f"amplitude_m: {amplitude!r} m is too large for {period!r} m periods; expected at most "
                             f"{1.5 * period / (2 * math.pi):.3g} m (path slope 2 pi A / P <= 1.5)")
    taper = period if taper is None else _positive("taper_m", taper)
    if 2 * taper > length:
        raise ParameterError(f"taper_m: {taper!r} m at both ends does not fit in {length:.3g} m; "
                             "expected a shorter taper or period")
    return period, amplitude, taper


@renamed_keywords(length="length_m", period="p2p_m", amplitude="amplitude_m", speed="speed_mps", ramp="ramp_s",
                  rest="rest_s", taper="taper_m")
def sine(length_m: float = 6.3, *, p2p_m: float = 1.0, amplitude_m: float = 0.1, speed_mps: float | None = None,
         ramp_s: float = 1.0, rest_s=3.0, taper_m: float | None = None, rate_hz: float = 100.0, t0: float = 0.0,
         g: float = units.G0) -> Trajectory:
    """Periodic (sine) motion along x: ``y = A W(x) sin(2 pi x / P)``, from rest to rest.

    Parameters
    ----------
    length_m : float
        Distance along x (start to end point) [m].
    p2p_m : float
        Peak-to-peak distance (period length) P [m]; the paper uses 1 m and 1.5 m.
    amplitude_m : float
        Lateral amplitude A [m]; the paper uses 0.1 m and 0.2 m.
    speed_mps : float, optional
        Cruise speed along x [m/s]; default from the paper's average durations
        (6.3 m in about 14.5 s with 1 m periods, 11 s with 1.5 m periods).
    ramp_s, rest_s, rate_hz, t0, g
        As in :func:`straight`.
    taper_m : float, optional
        Length over which the amplitude fades in and out at both ends [m]
        (default P), so the body starts and stops heading along x. A half
        period taper works too but turns 50 % faster than the steady sine.

    Returns
    -------
    Trajectory
        ``kind`` ``"sine"``, with ``peak_times`` and ``peak_side`` the times
        and sides of the lateral extremes and ``period_times`` the period
        boundaries.

    Raises
    ------
    ParameterError
        A bad length, period or amplitude, an amplitude too large for the
        period (path slope ``2 pi A / P`` above 1.5) or a taper that does not fit.

    Examples
    --------
    >>> traj = sine(6.3, p2p_m=1.0, amplitude_m=0.1)
    >>> round(float(traj.position[-1, 0]), 9), round(float(abs(traj.position[:, 1]).max()), 3)
    (6.3, 0.1)
    >>> traj.peak_times.size, traj.peak_side[:2].tolist()    # at x = 0.25, 0.75, ..., 6.25 m; left first
    (13, [1.0, -1.0])
    """
    length = _positive("length_m", length_m)
    period, amplitude, taper = _check_sine(p2p_m, amplitude_m, taper_m, length)
    speed = paper_speed(period) if speed_mps is None else speed_mps
    return _build("sine", _Path((length, 0.0), 0.0, 1.0, 0.0, 0.0, period, amplitude, taper),
                  speed=speed, ramp=ramp_s, rest=rest_s, rate_hz=rate_hz, t0=t0, g=g, period=period, amplitude=amplitude)


@renamed_keywords(slope_length="slope_length_m", period="p2p_m", amplitude="amplitude_m", speed="speed_mps",
                  turn_radius="turn_radius_m", ramp="ramp_s", rest="rest_s", taper="taper_m")
def l_route(legs=(18.0, 10.0), *, turn_deg: float = 90.0, turn_radius_m: float = 1.0, slope_deg: float = 0.0,
            slope_length_m: float = 5.0, p2p_m: float | None = None, amplitude_m: float | None = None,
            speed_mps: float = L_ROUTE_SPEED, ramp_s: float = 1.0, rest_s=3.0, taper_m: float | None = None,
            rate_hz: float = 100.0, t0: float = 0.0, g: float = units.G0) -> Trajectory:
    """L-shaped route: a leg along x, a smooth turn, a second leg; optional slope and sine.

    The end point is exactly ``legs[0]`` along x and ``legs[1]`` across (the
    turn cuts the corner, so the straight parts are shorter than the legs).

    Parameters
    ----------
    legs : (float, float)
        Leg lengths [m] (the field route: 18 m then 10 m).
    turn_deg : float
        Heading change [deg], positive to the left, 0 < abs(turn_deg) < 180.
    turn_radius_m : float
        Radius of the turn's constant-curvature part [m]; curvature ramps in
        and out over a third of the turn's arc length each side.
    slope_deg : float
        Downhill slope at the start [deg] (the field L route: 15 deg over 5 m).
    slope_length_m : float
        Horizontal length of the slope [m]; it eases into level ground over 1 m.
    p2p_m, amplitude_m : float, optional
        Periodic motion on top of the centreline (both or neither).
    speed_mps, ramp_s, rest_s, taper_m, rate_hz, t0, g
        As in :func:`sine`.

    Returns
    -------
    Trajectory
        ``kind`` ``"l_route"``, ending at ``(legs[0], legs[1])`` rotated by
        the turn, and lower by ``slope_length_m tan(slope_deg)`` (approached
        through the 1 m easing) when there is a slope.

    Raises
    ------
    ParameterError
        A bad leg, turn, radius or slope, only one of `p2p_m` and
        `amplitude_m`, or a geometry that does not fit (turn radius or slope
        too long for the legs, amplitude above half the radius).

    Examples
    --------
    >>> l_route().position[-1, :2].round(9).tolist()   # 18 m along x, then 10 m across
    [18.0, 10.0]
    >>> end = l_route(turn_deg=-90.0, slope_deg=15.0).position[-1]
    >>> end.round(6).tolist(), round(5.0 * math.tan(math.radians(15.0)), 6)   # 5 m of 15 deg downhill
    ([18.0, -10.0, -1.339746], 1.339746)
    """
    try:
        legs = tuple(float(v) for v in legs)
    except (TypeError, ValueError):
        raise ParameterError(f"legs: expected two lengths in m, got {legs!r}") from None
    if len(legs) != 2:
        raise ParameterError(f"legs: expected two lengths in m, got {legs!r}")
    for v in legs:
        _positive("legs", v)
    turn_deg = float(turn_deg)
    if not (0 < abs(turn_deg) < 180):
        raise ParameterError(f"turn_deg: expected 0 < |turn_deg| < 180, got {turn_deg!r}")
    turn_radius = _positive("turn_radius_m", turn_radius_m)
    taper = taper_m
    slope_deg = float(slope_deg)
    if not (0 <= abs(slope_deg) < 45):
        raise ParameterError(f"slope_deg: expected a downhill slope of 0 to 45 deg, got {slope_deg!r}")
    slope_length = _positive("slope_length_m", slope_length_m, allow_zero=slope_deg == 0)
    if slope_deg and slope_length < 0.5:
        raise ParameterError(f"slope_length_m: expected at least 0.5 m (the slope eases out over 1 m), "
                             f"got {slope_length!r}")
    period, amplitude = p2p_m, amplitude_m
    if (period is None) != (amplitude is None):
        raise ParameterError("p2p_m, amplitude_m: give both for periodic motion, or neither")
    turn = turn_deg * units.DEG
    probe = _Path((0.0, 0.0), turn, turn_radius, 0.0, 0.0, None, None, None)
    d = probe.centre_xy(np.array([probe.turn_len]))[0]
    # solve a1 e_x + a2 (cos turn, sin turn) = target - d for the straight lengths
    target = np.array([legs[0] + legs[1] * math.cos(turn), legs[1] * math.sin(turn)])
    M = np.array([[1.0, math.cos(turn)], [0.0, math.sin(turn)]])
    a1, a2 = np.linalg.solve(M, target - d)
    if a1 <= 0 or a2 <= 0:
        raise ParameterError(f"turn_radius_m: {turn_radius!r} m does not fit legs {legs!r}; expected a smaller radius")
    if slope_deg and slope_length + 0.5 > a1:
        raise ParameterError(f"slope_length_m: {slope_length!r} m does not fit in the first leg ({a1:.3g} m straight)")
    if period is not None:
        period, amplitude, taper = _check_sine(period, amplitude, taper, legs[0] + legs[1])
        if amplitude >= 0.5 * turn_radius:
            raise ParameterError(f"amplitude_m: {amplitude!r} m is too large for a {turn_radius!r} m turn radius; "
                                 "expected less than half the radius")
    path = _Path((float(a1), float(a2)), turn, turn_radius, abs(slope_deg) * units.DEG, slope_length,
                 period, amplitude, taper)
    return _build("l_route", path, speed=speed_mps, ramp=ramp_s, rest=rest_s, rate_hz=rate_hz, t0=t0, g=g,
                  period=period, amplitude=amplitude)


@renamed_keywords(speed="speed_mps", period="p2p_m", amplitude="amplitude_m")
def route_trajectory(name: str, *, speed_mps: float | None = None, p2p_m: float | None = None,
                     amplitude_m: float | None = None, **kwargs) -> Trajectory:
    """Trajectory of a route of ``data/routes.json`` (``"short_distance"``, ``"L_shape"``, ...).

    Parameters
    ----------
    name : str
        Route folder name.
    speed_mps, p2p_m, amplitude_m : float, optional
        Override the route's typical speed and its designed peak-to-peak distance and amplitude.
    **kwargs
        Passed to :func:`straight`, :func:`sine` or :func:`l_route`.

    Returns
    -------
    Trajectory
        A :func:`l_route` for a two-segment route (with its turn, slope and,
        for a periodic route, its sine), else a :func:`sine` for a periodic
        route or a :func:`straight` line, over the route's ``distance_m``.

    Raises
    ------
    ParameterError
        An unknown route name, or a bad override.

    Examples
    --------
    >>> traj = route_trajectory("L_shape")          # 18 m, a right turn, 10 m; 15 deg downhill at first
    >>> traj.kind, traj.p2p_m, traj.position[-1].round(6).tolist()
    ('l_route', 1.0, [18.0, -10.0, -1.339746])
    >>> route_trajectory("short_distance_1.5p2p").amplitude_m
    0.2
    """
    r = dataset.route(name)
    period = r.p2p_m if p2p_m is None else p2p_m
    amplitude = r.amplitude_m if amplitude_m is None else amplitude_m
    if len(r.segments_m) == 2:
        kw = dict(kwargs, turn_deg=r.turn_deg, slope_deg=r.slope_deg, slope_length_m=r.slope_length_m or 5.0)
        if speed_mps is not None:
            kw["speed_mps"] = speed_mps
        if r.kind == "periodic":
            kw.update(p2p_m=period, amplitude_m=amplitude)
        return l_route(tuple(r.segments_m), **kw)
    if r.kind == "periodic":
        return sine(r.distance_m, p2p_m=period, amplitude_m=amplitude, speed_mps=speed_mps, **kwargs)
    return straight(r.distance_m, **(dict(kwargs, speed_mps=speed_mps) if speed_mps is not None else kwargs))


# --------------------------------------------------------------------------- IMU synthesis

def sample_times(t_start: float, t_end: float, rng, *, pattern: str = "uniform", rate_hz: float = 100.0) -> np.ndarray:
    """Sample times from `t_start` to at most `t_end`.

    Parameters
    ----------
    t_start, t_end : float
        Time span [s].
    rng : numpy.random.Generator
        Source of the irregular intervals (unused for ``"uniform"``).
    pattern : {"uniform", "two-rate", "jittered"}
        ``"uniform"``: ``1 / rate_hz``. ``"two-rate"`` (the Galaxy S6's irregular
        stamps in the MoRPI recordings): a two-state Markov chain between ~100 Hz (dt uniform in
        0.0095-0.0115 s) and ~50 Hz (dt 0.0195 +- 0.0009 s, clipped to
        0.0175-0.0223 s) with lag-1 correlation 0.35 and a per-run share of
        slow intervals drawn in 0.1-0.75 (median dt 0.011-0.019 s, as in the
        field files). ``"jittered"`` (the Galaxy S8's): 0.0100 s with
        +-0.1 ms jitter and a rare (0.3 %) longer interval up to 0.019 s.
    rate_hz : float
        Rate of the uniform pattern [Hz].

    Returns
    -------
    ndarray, shape (n,)
        Increasing sample times [s], the first `t_start`, none after `t_end`.

    Raises
    ------
    ParameterError
        An unknown pattern, or a non-positive `rate_hz` for ``"uniform"``.

    Examples
    --------
    >>> sample_times(0.0, 0.05, None).round(12).tolist()
    [0.0, 0.01, 0.02, 0.03, 0.04, 0.05]
    >>> dt = np.diff(sample_times(0.0, 60.0, np.random.default_rng(0), pattern="two-rate"))
    >>> bool(dt.min() >= 0.0095 and dt.max() <= 0.0223 + 1e-12)      # the two clipped ranges
    True
    """
    span = float(t_end) - float(t_start)
    if pattern == "uniform":
        rate_hz = _positive("rate_hz", rate_hz)
        return t_start + np.arange(int(math.floor(span * rate_hz + 1e-9)) + 1) / rate_hz
    n_max = int(span / 0.0095) + 2
    if pattern == "two-rate":
        q = rng.uniform(0.1, 0.75)
        lam = 0.35
        redraw = rng.random(n_max) < 1.0 - lam
        redraw[0] = True
        fresh = rng.random(n_max) < q
        last = np.maximum.accumulate(np.where(redraw, np.arange(n_max), 0))
        slow = fresh[last]
        slow_dt = np.clip(rng.normal(0.0195, 0.0009, n_max), 0.0175, 0.0223)
        dt = np.where(slow, slow_dt, rng.uniform(0.0095, 0.0115, n_max))
    elif pattern == "jittered":
        dt = 0.0100 + rng.uniform(-1e-4, 1e-4, n_max)
        gap = rng.random(n_max) < 0.003
        dt = np.where(gap, rng.uniform(0.011, 0.019, n_max), dt)
    else:
        raise ParameterError(f"sampling: {pattern!r}: expected 'uniform', 'two-rate', 'jittered' or an array of times")
    t = t_start + np.concatenate([[0.0], np.cumsum(dt)])
    return t[t <= t_end]


@dataclass(frozen=True, eq=False)
class ImuData:
    """Synthesized IMU readings of one or more runs over one trajectory, with the drawn errors.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s], shared by all runs.
    f : ndarray, shape (n, 3) or (runs, n, 3)
        Measured specific force [m/s^2].
    omega : ndarray, shape (n, 3) or (runs, n, 3)
        Measured angular rate [rad/s].
    truth : Trajectory
        The trajectory sampled at `time` (true f_b, omega_b, position, ...).
    accel_bias, gyro_bias : ndarray, shape (3,) or (runs, 3)
        Turn-on biases [m/s^2, rad/s].
    accel_scale, gyro_scale : ndarray, shape (3,) or (runs, 3)
        Scale-factor errors (relative).
    misalignment : ndarray, shape (3,) or (runs, 3)
        Mounting misalignment rotation vector of the sensor axes [rad].
    accel_bias_drift, gyro_bias_drift : ndarray or None, shape (n, 3) or (runs, n, 3)
        Time-varying part of the bias (random walk plus Gauss-Markov; None when
        both are disabled).
    spec : units.SensorSpec
        The sensor specification used.
    """

    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    truth: Trajectory
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
    accel_scale: np.ndarray
    gyro_scale: np.ndarray
    misalignment: np.ndarray
    accel_bias_drift: np.ndarray | None
    gyro_bias_drift: np.ndarray | None
    spec: units.SensorSpec

    @property
    def runs(self) -> int | None:
        """Number of runs, None when unbatched."""
        return None if self.f.ndim == 2 else int(self.f.shape[0])

    def recording(self, run: int = 0, *, source: str = "<synthetic>", phone=None, route=None, split=None):
        """One run as a :class:`~morpi_filters.dataset.Recording`.

        Parameters
        ----------
        run : int
            Run index (ignored when unbatched).
        source : str
            Name the recording reports in messages.
        phone, route, split : str, optional
            Dataset labels.

        Returns
        -------
        dataset.Recording
            Copies of the time stamps and of the run's specific force and
            angular rate.

        Examples
        --------
        >>> data = imu(straight(), units.LSM6DSL, np.random.default_rng(0), runs=2)
        >>> rec = data.recording(1, source="run1.csv")
        >>> rec.source, rec.imu.name, bool((rec.f == data.f[1]).all())
        ('run1.csv', 'LSM6DSL', True)
        """
        f = self.f if self.f.ndim == 2 else self.f[run]
        w = self.omega if self.omega.ndim == 2 else self.omega[run]
        return dataset.Recording(time=self.time.copy(), f=np.ascontiguousarray(f), omega=np.ascontiguousarray(w),
                                 source=source, phone=phone,
                                 route=route, split=split, imu=self.spec)


def _rngs(rng, runs):
    """One generator for all runs, or one per run (results independent of batching)."""
    if isinstance(rng, np.random.Generator):
        return rng, None
    rngs = list(rng)
    if runs is None or len(rngs) != runs or not all(isinstance(r, np.random.Generator) for r in rngs):
        raise ParameterError("rng: expected a numpy Generator, or a list of one Generator per run")
    return None, rngs


def _normal(rng, rngs, shape, out=None):
    """Standard normals of shape (R, ...) from one generator or one per run."""
    if out is None:
        out = np.empty(shape)
    if rngs is None:
        rng.standard_normal(out=out)
    else:
        for i, r in enumerate(rngs):
            r.standard_normal(out=out[i])
    return out


def imu(traj: Trajectory, spec: units.SensorSpec, rng, *, runs: int | None = None, sampling="uniform",
        bias_scale=1.0, noise_scale: float = 1.0, accel_bias_rw: float = 0.0, gyro_bias_rw: float = 0.0,
        bias_instability=(0.0, 0.0), correlation_time: float = 100.0,
        scale_factor: float = 0.0, misalignment: float = 0.0, vibration=(0.0, 0.0),
        time_span=None) -> ImuData:
    """Synthesize IMU readings of a trajectory.

    Measurement model per run (sensor axes rotated from the body by the
    mounting misalignment ``M = exp([m x])``)::

        f     = (1 + s_a) * M^T f_b     + b_a + b_a(t) + v_a(t) + sigma_a,k z
        omega = (1 + s_g) * M^T omega_b + b_g + b_g(t) + v_g(t) + sigma_g,k z

    (``b(t)``: bias random walk plus Gauss-Markov bias instability, ``v(t)``:
    vibration while moving) and the model of [2] for the rest.

    with ``sigma_k = density / sqrt(dt_k)`` the white-noise standard deviation
    of sample k from its actual interval ``dt_k`` (the interval before it;
    the first sample uses the interval after it).

    Parameters
    ----------
    traj : Trajectory
        Truth; it is resampled at the IMU time stamps.
    spec : units.SensorSpec
        Datasheet figures (turn-on bias 1 sigma, noise densities).
    rng : numpy.random.Generator or list of Generator
        Every draw comes from it. A list of one generator per run makes each
        run's draws independent of how the runs are batched (then `sampling`
        must be ``"uniform"`` or explicit times).
    runs : int, optional
        Number of runs (leading axis); None for one unbatched run.
    sampling : {"uniform", "two-rate", "jittered"} or array_like
        Time-stamp pattern (see :func:`sample_times`), drawn once and shared
        by the runs, or explicit times.
    bias_scale : float or (float, float)
        Turn-on bias 1 sigma as a fraction of the datasheet's (accelerometer,
        gyro). The datasheet figures are worst-case; see
        :data:`morpi_filters.synthetic.REALISTIC_BIAS_FRACTION` for values matching the field data.
    noise_scale : float
        Factor on both noise densities.
    accel_bias_rw, gyro_bias_rw : float
        Bias random-walk densities [m/s^2/sqrt(s), rad/s/sqrt(s)] (0: off).
    bias_instability : (float, float)
        Steady-state 1 sigma of a first-order Gauss-Markov bias (accelerometer
        [m/s^2], gyro [rad/s]), started in steady state (0: off), exact
        discretization on the real intervals:
        ``b_k+1 = exp(-dt/tau) b_k + sigma sqrt(1 - exp(-2 dt/tau)) z``.
    correlation_time : float
        Its correlation time tau [s].
    scale_factor : float
        1-sigma scale-factor error per axis (relative, e.g. 0.01).
    misalignment : float
        1-sigma mounting misalignment per axis [rad].
    vibration : (float, float)
        Rms of motion-induced vibration (accelerometer [m/s^2], gyro [rad/s]),
        present only while moving (scaled by the speed fraction): a sum of six
        sinusoids per axis at random frequencies in 4-25 Hz, so it integrates
        to a bounded velocity like a real vibration, not to a random walk.
    time_span : (float, float), optional
        Span of the time stamps (default the trajectory's first sample to its end).

    Returns
    -------
    ImuData
        Readings of shape (n, 3), or (runs, n, 3) when `runs` is given, on
        the shared time stamps, with the drawn biases, scale factors,
        misalignment and bias drifts and the truth at those times.

    Raises
    ------
    ParameterError
        For a bad parameter (named in the message).

    Examples
    --------
    Without errors the sensor reads the true specific force and rate:

    >>> traj = straight(6.3)
    >>> perfect = imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=0.0, noise_scale=0.0)
    >>> bool(np.array_equal(perfect.f, perfect.truth.f_b)), perfect.runs
    (True, None)

    Four runs on the S6's irregular time stamps, shared by the runs:

    >>> data = imu(traj, units.MPU6500, np.random.default_rng(0), runs=4, sampling="two-rate")
    >>> data.f.shape[0], data.f.shape[1] == data.time.size, data.gyro_bias.shape
    (4, True, (4, 3))
    """
    if runs is not None:
        if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 1:
            raise ParameterError(f"runs: expected a positive integer or None, got {runs!r}")
        runs = int(runs)
    rng1, rngs = _rngs(rng, runs)
    sa, sg = (bias_scale, bias_scale) if np.ndim(bias_scale) == 0 else tuple(bias_scale)
    sa, sg = _positive("bias_scale", sa, allow_zero=True), _positive("bias_scale", sg, allow_zero=True)
    noise_scale = _positive("noise_scale", noise_scale, allow_zero=True)
    accel_bias_rw = _positive("accel_bias_rw", accel_bias_rw, allow_zero=True)
    gyro_bias_rw = _positive("gyro_bias_rw", gyro_bias_rw, allow_zero=True)
    scale_factor = _positive("scale_factor", scale_factor, allow_zero=True)
    misalignment = _positive("misalignment", misalignment, allow_zero=True)
    va, vg = (_positive("vibration", v, allow_zero=True) for v in vibration)
    gm_a, gm_g = (_positive("bias_instability", v, allow_zero=True) for v in bias_instability)
    tau = _positive("correlation_time", correlation_time)

    if isinstance(sampling, str):
        if rngs is not None and sampling != "uniform":
            raise ParameterError(f"sampling: {sampling!r} time stamps are shared by the runs and need one Generator; "
                                 "with one Generator per run pass explicit times (e.g. from sample_times)")
        t_a, t_b = (traj.time[0], traj.end_time) if time_span is None else time_span
        time = sample_times(t_a, t_b, rng1, pattern=sampling, rate_hz=spec.rate_hz)
    else:
        time = np.asarray(sampling, dtype=float)
        if time.ndim != 1 or time.size < 2 or not np.isfinite(time).all() or not (np.diff(time) > 0).all():
            raise ParameterError("sampling: expected strictly increasing finite sample times")
    truth = traj.at(time)
    n = time.size
    R = 1 if runs is None else runs
    dt = np.diff(time)
    dt_k = np.concatenate([dt[:1], dt])

    def per_run(k):                           # (R, k) normals
        return _normal(rng1, rngs, (R, k))

    # small per-run draws first (same order for either rng form)
    small = per_run(15)
    b_a = spec.accel_bias * sa * small[:, 0:3]
    b_g = spec.gyro_bias * sg * small[:, 3:6]
    s_a = scale_factor * small[:, 6:9]
    s_g = scale_factor * small[:, 9:12]
    mis = misalignment * small[:, 12:15]

    def channel(true, sens_scale, bias, density, rw, vib, gm):
        out = _normal(rng1, rngs, (R, n, 3))
        out *= (noise_scale * density / np.sqrt(dt_k))[None, :, None]
        if misalignment:
            M = rotvec_to_C(mis)                                    # (R, 3, 3) sensor-to-body
            body = np.matmul(true[None], M)                         # rows: M^T f_b
        else:
            body = true[None]
        if scale_factor:
            out += body * (1.0 + sens_scale[:, None, :])
        else:
            out += body
        out += bias[:, None, :]
        drift = None
        if rw:
            steps = _normal(rng1, rngs, (R, n - 1, 3)) * (rw * np.sqrt(dt))[None, :, None]
            drift = np.zeros((R, n, 3))
            np.cumsum(steps, axis=1, out=drift[:, 1:])
        if gm:
            b = _gauss_markov(_normal(rng1, rngs, (R, n, 3)), time, gm, tau)
            drift = b if drift is None else drift + b
        if drift is not None:
            out += drift
        if vib:
            frac = (np.abs(traj._model[1](time)[1]) / traj._model[1].V)[None, :, None]
            freq = 4.0 + 21.0 * _uniform(rng1, rngs, (R, 6, 3))
            phase = 2 * np.pi * _uniform(rng1, rngs, (R, 6, 3))
            amp = vib / math.sqrt(3.0)                              # six sines of amplitude a: rms a sqrt(3)
            wave = np.zeros((R, n, 3))
            for j in range(6):
                wave += np.sin(2 * np.pi * freq[:, None, j, :] * (time - time[0])[None, :, None] + phase[:, None, j, :])
            out += amp * frac * wave
        return out, drift

    f, drift_a = channel(truth.f_b, s_a, b_a, spec.accel_noise, accel_bias_rw, va, gm_a)
    w, drift_g = channel(truth.omega_b, s_g, b_g, spec.gyro_noise, gyro_bias_rw, vg, gm_g)
    if runs is None:
        f, w, b_a, b_g, s_a, s_g, mis = f[0], w[0], b_a[0], b_g[0], s_a[0], s_g[0], mis[0]
        drift_a = None if drift_a is None else drift_a[0]
        drift_g = None if drift_g is None else drift_g[0]
    return ImuData(time=time, f=f, omega=w, truth=truth, accel_bias=b_a, gyro_bias=b_g, accel_scale=s_a,
                   gyro_scale=s_g, misalignment=mis, accel_bias_drift=drift_a, gyro_bias_drift=drift_g, spec=spec)


def _gauss_markov(z, time, sigma, tau):
    """First-order Gauss-Markov sequence from standard normals z (R, n, 3), started in steady state.

    Exact discretization ``b_k+1 = p_k b_k + sigma sqrt(1 - p_k^2) z_k+1`` with
    ``p_k = exp(-dt_k / tau)``, evaluated without a loop over samples: within a
    block where ``L_k = (t_k - t_s) / tau`` stays below 30,
    ``b_k = exp(-L_k) (b_s + sum_{s<j<=k} exp(L_j) w_j)``, ``w_j`` the innovations.
    """
    dt = np.diff(time)
    p = np.exp(-dt / tau)
    w = np.empty_like(z)
    w[:, 0] = sigma * z[:, 0]
    w[:, 1:] = z[:, 1:] * (sigma * np.sqrt(-np.expm1(-2.0 * dt / tau)))[None, :, None]
    b = np.empty_like(z)
    n, s = time.size, 0
    while s < n:
        e = max(int(np.searchsorted(time, time[s] + 30.0 * tau, side="right")), s + 1)
        L = (time[s:e] - time[s]) / tau                        # at most 30: exp(L) < 1.1e13
        acc = np.cumsum(w[:, s:e] * np.exp(L)[None, :, None], axis=1)
        if s > 0:
            acc += (p[s - 1] * b[:, s - 1])[:, None, :]
        b[:, s:e] = acc * np.exp(-L)[None, :, None]
        s = e
    return b


def _uniform(rng, rngs, shape):
    if rngs is None:
        return rng.random(shape)
    return np.stack([r.random(shape[1:]) for r in rngs])
