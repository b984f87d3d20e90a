"""The aided filter's Kalman core and measurement models in numpy, batched over a leading axis: the reference
forms the compiled pass of :mod:`morpi_filters._aided_kernel` is held to.

The prediction and the Joseph-form update are filterpy's ``KalmanFilter`` equations (with a considered
state: the gain of the filter that takes it as known), the smoother is filterpy's Rauch-Tung-Striebel
recursion written for the fed-back filter, and each measurement is a small object with its nonlinear
model ``h(x, nom)``, Jacobian ``H(x, nom)`` and noise ``R``. ``tests/test_aided.py`` holds these to
filterpy and to finite differences, ``tests/test_aided_kernel.py`` the kernel to these.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morpi_filters.aided import CLONE, GAIN, N_AIDED, TURN
from morpi_filters.error_model import BG, DP, DV, EPS
from morpi_filters.strapdown import rotvec_to_C


# --------------------------------------------------------------------------- Kalman core (batched)

def kf_predict(x, P, Phi, Q):
    """Kalman prediction ``x = Phi x``, ``P = Phi P Phi^T + Q`` over a leading batch axis.

    The equations of filterpy's ``KalmanFilter.predict`` (no control input).

    Parameters
    ----------
    x : ndarray, shape (b, n)
        Error states of b filters.
    P, Phi, Q : ndarray, shape (b, n, n)
        Covariances, transition matrices and discrete process noise.

    Returns
    -------
    x : ndarray, shape (b, n)
        Predicted states.
    P : ndarray, shape (b, n, n)
        Predicted covariances.

    Examples
    --------
    >>> Phi = np.array([[[1.0, 1.0], [0.0, 1.0]]])          # position integrates velocity over 1 s
    >>> x, P = kf_predict(np.array([[0.0, 1.0]]), np.eye(2)[None], Phi, np.zeros((1, 2, 2)))
    >>> x.tolist(), P[0].tolist()
    ([[1.0, 1.0]], [[2.0, 1.0], [1.0, 1.0]])
    """
    x = np.einsum("bij,bj->bi", Phi, x)
    P = Phi @ P @ np.swapaxes(Phi, 1, 2) + Q
    return x, P


def kf_update(x, P, y, H, R, frozen=None, out=None, work=None):
    """Kalman update with innovation `y` over a leading batch axis (Joseph form).

    The equations of filterpy's ``KalmanFilter.update``: ``S = H P H^T + R``,
    ``K = P H^T S^-1``, ``x = x + K y``, ``P = (I - K H) P (I - K H)^T + K R K^T``.
    With `frozen` (a consider analysis), the flagged states are taken as
    known at their estimate: the gain ``K`` is the one of the filter without
    them, computed from ``P`` conditioned on them (the Schur complement
    ``P - P_.f P_ff^-1 P_f.``, which evolves as that filter's own covariance),
    and they are not updated. The Joseph form, valid for any gain, then
    carries their uncertainty into ``P``: the covariance of the estimate
    around the truth, whatever their true value, and ``S`` the innovations'
    true covariance.

    Parameters
    ----------
    x : ndarray, shape (b, n)
        Prior states of b filters.
    P : ndarray, shape (b, n, n)
        Prior covariances.
    y : ndarray, shape (b, m)
        Innovation ``z - h(x)``.
    H : ndarray, shape (b, m, n)
        Measurement matrices.
    R : ndarray, shape (b, m, m)
        Measurement noise covariances.
    frozen : ndarray, shape (b, n) of bool, optional
        Considered states (not updated) per filter.
    out : ndarray, shape (b, n, n), optional
        Where to write the updated covariances (may be `P` itself).
    work : ndarray, shape (b, n, n), optional
        Scratch space for the update (not `P` or `out`).

    Returns
    -------
    x : ndarray, shape (b, n)
        Updated states.
    P : ndarray, shape (b, n, n)
        Updated covariances (Joseph form, symmetrized; `out` when given).
    S : ndarray, shape (b, m, m)
        Innovation covariances (for the NIS ``y^T S^-1 y``).

    Examples
    --------
    >>> x, P, S = kf_update(np.zeros((1, 1)), np.eye(1)[None], np.ones((1, 1)), np.eye(1)[None], np.eye(1)[None])
    >>> x.tolist(), P.tolist(), S.tolist()       # equal prior and measurement variances: half way
    ([[0.5]], [[[0.5]]], [[[2.0]]])
    """
    Ht = np.swapaxes(H, 1, 2)
    PHt = P @ Ht
    S = H @ PHt + R
    KHt = PHt
    Sc = S
    if frozen is not None:
        frozen = np.broadcast_to(np.asarray(frozen, bool), x.shape)
        cols = np.flatnonzero(frozen.any(axis=0))
        if cols.size == 1:
            # one frozen state: P_c H^T = P H^T - p_j (H p_j)^T / P_jj, without forming P_c
            j = int(cols[0])
            col = P[:, :, j]
            pjj = P[:, j, j]
            use = frozen[:, j] & (pjj > 0)
            w = np.where(use, 1.0 / np.where(pjj > 0, pjj, 1.0), 0.0)
            KHt = PHt - w[:, None, None] * col[:, :, None] * np.einsum("bmn,bn->bm", H, col)[:, None, :]
            KHt[use, j, :] = 0.0
        else:
            KHt = _condition(P, frozen) @ Ht
        Sc = H @ KHt + R
    K = KHt @ np.linalg.inv(Sc)
    x = x + np.einsum("bij,bj->bi", K, y)
    # the Joseph form expanded: (I - K H) P (I - K H)^T + K R K^T = P - K H P - P H^T K^T + K S K^T
    # = P + K D^T - P H^T K^T with D = K S - P H^T: one product of n x 2m and 2m x n factors
    D = K @ S - PHt
    Pn = np.matmul(np.concatenate([K, -PHt], axis=2), np.swapaxes(np.concatenate([D, K], axis=2), 1, 2), out=work)
    Pn += P
    if out is None:
        out = np.empty_like(Pn)
    np.add(Pn, np.swapaxes(Pn, 1, 2), out=out)
    out *= 0.5
    return x, out, S


def _condition(P, frozen):
    """``P`` conditioned on the `frozen` states (one Schur complement per state), batched.

    Parameters
    ----------
    P : ndarray, shape (b, n, n)
    frozen : ndarray, shape (b, n) or (n,) of bool

    Returns
    -------
    ndarray, shape (b, n, n)
        The conditional covariances: the frozen states' rows and columns are zero.
    """
    frozen = np.broadcast_to(np.asarray(frozen, bool), P.shape[:-1])
    Pc = P
    for j in np.flatnonzero(frozen.any(axis=0)):
        pjj = Pc[:, j, j]
        use = frozen[:, j] & (pjj > 0)
        w = np.where(use, 1.0 / np.where(pjj > 0, pjj, 1.0), 0.0)
        col = Pc[:, :, j]
        # P - w p_j p_j^T, the outer product's array taking the difference (one (b, n, n) array per state)
        out = w[:, None, None] * col[:, :, None] * col[:, None, :]
        Pc = np.subtract(Pc, out, out=out)
        Pc[use, j, :] = 0.0                   # exact zeros where rounding leaves 1e-20
        Pc[use, :, j] = 0.0
    return Pc


def rts_smooth(x_post, P_post, x_prior, P_prior, Phi, fed=None, frozen=None, covariance=True):
    """Rauch-Tung-Striebel smoother over epochs ``0..m-1`` (filterpy's recursion).

    ``Phi[k]`` propagates from epoch ``k - 1`` to ``k`` (filterpy's
    ``Fs[k]``); ``x_prior[k]``, ``P_prior[k]`` are the predictions at epoch ``k``
    before its update. With feedback, ``fed[k]`` is the correction moved into
    the nominal state at epoch ``k`` (the smoothed error there is then
    relative to the corrected nominal state).

    Parameters
    ----------
    x_post, x_prior : ndarray, shape (m, n)
        Filtered (after update) and predicted (before update) states.
    P_post, P_prior, Phi : ndarray, shape (m, n, n)
        Their covariances, and the transitions into each epoch (``Phi[0]``
        is not used).
    fed : ndarray, shape (m, n), optional
        Corrections fed back into the nominal state per epoch.
    frozen : ndarray, shape (n,) of bool, optional
        Considered states of the forward pass (:func:`kf_update`): the
        smoother's gains come from the covariances conditioned on them, so
        the smoothed estimate is that of the filter taking them as known
        (the smoothed covariance does not carry their uncertainty).
    covariance : bool
        Also run the covariance recursion (the states do not need it).

    Returns
    -------
    xs : ndarray, shape (m, n)
        Smoothed states.
    Ps : ndarray, shape (m, n, n), or None
        Smoothed covariances (None without `covariance`).

    Examples
    --------
    A constant measured twice (z = 1, then 4; prior 0, all variances 1):
    the smoothed value at both epochs is the mean of the three, 5/3, with
    variance 1/3.

    >>> one = np.ones((1, 1, 1))
    >>> x0, P0, _ = kf_update(np.zeros((1, 1)), one, np.array([[1.0]]), one, one)
    >>> x1p, P1p = kf_predict(x0, P0, one, 0 * one)
    >>> x1, P1, _ = kf_update(x1p, P1p, np.array([[4.0]]) - x1p, one, one)
    >>> xs, Ps = rts_smooth(np.concatenate([x0, x1]), np.concatenate([P0, P1]),
    ...                     np.concatenate([np.zeros((1, 1)), x1p]), np.concatenate([one, P1p]),
    ...                     np.concatenate([one, one]))
    >>> (3 * xs).round(12).ravel().tolist(), (3 * Ps).round(12).ravel().tolist()
    ([5.0, 5.0], [1.0, 1.0])
    """
    xs = np.array(x_post, dtype=float)
    Ps = np.array(P_post, dtype=float) if covariance else None
    if xs.shape[0] < 2:
        return xs, Ps
    # the smoother gains depend on the forward pass only: all of them in one batched call
    Pp, Pq = P_post[:-1], P_prior[1:]
    own = frozen is not None and bool(np.any(frozen))     # Pq then an array of the smoother's own
    if own:
        # the smoother of the filter that takes the frozen states as known (:func:`kf_update`)
        Pp, Pq = _condition(Pp, frozen), _condition(Pq, frozen)
    # G = Pp Phi^T Pq^+ : states without uncertainty (an unused clone or gain, a considered state) have
    # exactly zero rows and columns in Pq, where the pseudo-inverse is zero too; the rest is invertible
    dead = ~(Pq != 0).any(axis=2)
    if dead.any():
        if not own:                           # a view of the caller's P_prior: written in a copy
            Pq = Pq.copy()
        np.einsum("bii->bi", Pq)[...] += dead  # a one on the diagonal of each such state
    G = np.swapaxes(np.linalg.solve(Pq, Phi[1:] @ np.swapaxes(Pp, 1, 2)), 1, 2)
    np.copyto(G, 0.0, where=dead[:, None, :])
    for k in range(xs.shape[0] - 2, -1, -1):
        ahead = xs[k + 1] if fed is None else xs[k + 1] + fed[k + 1]
        xs[k] = x_post[k] + G[k] @ (ahead - x_prior[k + 1])
        if covariance:
            Ps[k] = P_post[k] + G[k] @ (Ps[k + 1] - P_prior[k + 1]) @ G[k].T
    return xs, Ps


def skew(v):
    """Batched cross-product matrices, shape (b, 3) -> (b, 3, 3)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


# --------------------------------------------------------------------------- measurements

@dataclass(frozen=True)
class Nominal:
    """Nominal (fed-back) navigation state the measurements linearize about, batched.

    Attributes
    ----------
    C : ndarray, shape (b, 3, 3)
        Body-to-navigation attitude.
    v, p : ndarray, shape (b, 3)
        Velocity [m/s] and position [m] in the navigation frame (z up).
    clone : ndarray, shape (b, 2)
        Horizontal position at the last step boundary [m].
    """

    C: np.ndarray
    v: np.ndarray
    p: np.ndarray
    clone: np.ndarray


@dataclass(frozen=True)
class StepDisplacement:
    """MoRPI step: ``z = (1 + k) R(e) (p_xy - c)`` with the true position ``p`` and clone ``c``.

    When the step's direction is read from the filter's own attitude
    (``attitude``), the measured vector turns with the filter's heading
    error, ``e = eps_z``: the step then says nothing about the heading, only
    about the length. With a direction from elsewhere (MoRPI's own heading
    reading, the route's heading), ``e`` is that reading's own heading error
    (:data:`TURN`, which grows with every turn the reading takes).

    Attributes
    ----------
    z : ndarray, shape (b, 2)
        Measured displacement [m].
    sigma : ndarray, shape (b,)
        Noise per axis [m].
    attitude : ndarray, shape (b,) of bool, optional
        Whether each member's direction comes from the filter's attitude.
    """

    z: np.ndarray
    sigma: np.ndarray
    attitude: np.ndarray | None = None

    def _d(self, x, nom):
        return (nom.p[:, :2] - x[:, DP][:, :2]) - (nom.clone - x[:, CLONE])

    def _e(self, x):
        if self.attitude is None:
            return x[:, TURN]
        return np.where(self.attitude, x[:, EPS.stop - 1], x[:, TURN])

    def h(self, x, nom: Nominal):
        gain = 1.0 + x[:, GAIN]
        d = self._d(x, nom)
        e = self._e(x)
        c, s = np.cos(e), np.sin(e)
        d = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=1)
        return gain[:, None] * d

    def H(self, x, nom: Nominal):
        # at the state given: the attitude's heading error is fed back (zero), the reading's is not
        gain = 1.0 + x[:, GAIN]
        d = self._d(x, nom)
        e = self._e(x)
        c, s = np.cos(e), np.sin(e)
        Rm = np.stack([np.stack([c, -s], axis=1), np.stack([s, c], axis=1)], axis=1)      # (b, 2, 2)
        Rd = np.einsum("bij,bj->bi", Rm, d)
        dRd = np.stack([-Rd[:, 1], Rd[:, 0]], axis=1)                                       # dR/de d
        H = np.zeros((x.shape[0], 2, N_AIDED))
        H[:, :, DP.start:DP.start + 2] = -gain[:, None, None] * Rm
        H[:, :, CLONE] = gain[:, None, None] * Rm
        H[:, :, GAIN] = Rd
        if self.attitude is None:
            H[:, :, TURN] = gain[:, None] * dRd
        else:
            a = np.asarray(self.attitude, bool)
            H[:, :, EPS.stop - 1] = np.where(a[:, None], gain[:, None] * dRd, 0.0)
            H[:, :, TURN] = np.where(a[:, None], 0.0, gain[:, None] * dRd)
        return H

    def R(self):
        return self.sigma[:, None, None] ** 2 * np.eye(2)


@dataclass(frozen=True)
class ZeroVelocity:
    """Rest: the true velocity is zero, ``z = 0 = v_hat - dv``."""

    sigma: np.ndarray

    @property
    def z(self):
        return np.zeros((self.sigma.shape[0], 3))

    def h(self, x, nom: Nominal):
        return nom.v - x[:, DV]

    def H(self, x, nom: Nominal):
        H = np.zeros((x.shape[0], 3, N_AIDED))
        H[:, :, DV] = -np.eye(3)
        return H

    def R(self):
        return self.sigma[:, None, None] ** 2 * np.eye(3)


@dataclass(frozen=True)
class ZeroRate:
    """Rest: the gyro reads its bias, ``z = mean(omega) - bg_hat = bg``.

    Attributes
    ----------
    z : ndarray, shape (b, 3)
        Mean bias-corrected angular rate over the epoch [rad/s].
    sigma : ndarray, shape (b,)
        Its noise per axis [rad/s] (the white-noise density over the epoch's duration).
    """

    z: np.ndarray
    sigma: np.ndarray

    def h(self, x, nom: Nominal):
        return x[:, BG].copy()

    def H(self, x, nom: Nominal):
        H = np.zeros((x.shape[0], 3, N_AIDED))
        H[:, :, BG] = np.eye(3)
        return H

    def R(self):
        return self.sigma[:, None, None] ** 2 * np.eye(3)


@dataclass(frozen=True)
class NonHolonomic:
    """Robot-frame lateral and vertical velocity zero: rows 2-3 of ``M C^T v`` (true ``C``, ``v``).

    Attributes
    ----------
    M : ndarray, shape (b, 3, 3)
        Phone body axes to robot axes (the tilt at rest, yaw zero).
    sigma : ndarray, shape (b,)
        Velocity noise [m/s].
    """

    M: np.ndarray
    sigma: np.ndarray

    @property
    def z(self):
        return np.zeros((self.sigma.shape[0], 2))

    def h(self, x, nom: Nominal):
        C_true = rotvec_to_C(-x[:, EPS]) @ nom.C
        vb = np.einsum("bji,bj->bi", C_true, nom.v - x[:, DV])
        return np.einsum("bij,bj->bi", self.M, vb)[:, 1:]

    def H(self, x, nom: Nominal):
        # linearized at the fed-back state (eps = dv = 0)
        A = (self.M @ np.swapaxes(nom.C, 1, 2))[:, 1:]
        H = np.zeros((x.shape[0], 2, N_AIDED))
        H[:, :, DV] = -A
        H[:, :, EPS] = -A @ skew(nom.v - x[:, DV])
        return H

    def R(self):
        return self.sigma[:, None, None] ** 2 * np.eye(2)
