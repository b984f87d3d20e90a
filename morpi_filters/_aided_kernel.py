"""The aided filter's forward pass and smoother over one recording: plain loops that numba compiles.

:func:`aided.run_batch` prepares each member (epoch grid, step events, rest flags, tunables) and
calls :func:`forward_member`, which runs the strapdown at every sample and the Kalman predict,
updates and feedback at the epochs, writing into arrays the caller owns, then, where asked,
:func:`smooth_member` over the epochs it recorded. The arithmetic is written element by element:

- the transition ``I + F T + (F T)^2 / 2`` of an epoch interval by its non-zero blocks, and the
  prediction that touches only those (:func:`transition_blocks`, :func:`predict`);
- filterpy's Joseph-form update (:func:`kf_update`; one considered state at most: the gain error);
- the measurement models ``h`` and ``H`` of the step displacement, zero velocity, zero rate and the
  non-holonomic constraint (:func:`step_model`, :func:`zero_velocity_model`, :func:`zero_rate_model`,
  :func:`nhc_model`);
- the strapdown at every sample with Rodrigues' formula and the 3 x 3 product of the strapdown's loops
  (``_strapdown_loops.rodrigues``, ``matmul3``);
- filterpy's Rauch-Tung-Striebel recursion for the fed-back filter (:func:`smooth_member`), its linear
  solves by LU factors with partial pivoting (:func:`lu_factor`, :func:`lu_solve`).

The loops avoid what numba is slow to compile (array assignments with broadcasting, numpy's linear
algebra, literal integer arguments, which it compiles a callee for once per value): a fresh install
compiles them on its first run.

The tests hold each piece within a stated rounding tolerance to the dense series or a numpy reference
form (``tests/oracles/aided.py``, itself held to filterpy and to finite differences).

numba is imported on the first call (:data:`compiled`, made by ``_jit.loops``, which compiles the
strapdown's loops first), not with the package, and its machine code is cached on disk. Every function
runs as plain Python too (slowly): the tests compare both.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import loops
from ._strapdown_loops import compiled as strapdown_loops, matmul3, rodrigues
from .error_model import BA, BG, DP, DV, EPS, N_STATES

# the aided error state (aided.CLONE, GAIN, TURN, N_AIDED)
_N = N_STATES + 4
_DP, _DV, _EPS, _BA, _BG = DP.start, DV.start, EPS.start, BA.start, BG.start
_CL, _GAIN, _TURN = N_STATES, N_STATES + 2, N_STATES + 3
# rows and columns of Phi - I that can be non-zero: dp, dv, eps and dv .. bg
_R0, _NR, _C0, _NC = DP.start, EPS.stop - DP.start, DV.start, BG.stop - DV.start

#: Bits of the per-sample flags.
EPOCH, REST, STAND, START = 1, 2, 4, 8
#: Measurement kinds, in the order of the NIS and innovation arrays.
KINDS = ("step", "zero velocity", "zero rate", "non-holonomic")
#: Their dimensions.
KIND_DOF = (2, 3, 3, 2)
#: Entries of the tunables vector `par` of :func:`forward_member`.
PAR = ("q_a", "q_a_rest", "q_g", "q_g_rest", "q_ba", "q_bg", "jump2", "step_sigma", "nhc_sigma",
       "zupt_sigma", "gyro_sigma_rest", "nhc", "g", "gyro_heading")


def copy_into(dst, src):
    """``dst[:, :] = src[:ni, :nj]`` for `dst` (ni, nj), element by element (numba compiles this loop in a
    fraction of the time an array assignment takes). Every caller's `src` is writeable: one compiled form."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


def transition_blocks(d, fn, Cm, A):
    """The blocks ``A = Phi - I`` of one interval into `A` (9, 12): ``Phi = I + F T + (F T)^2 / 2`` with the
    interval's duration `d`, force integral `fn` and attitude integral `Cm` (the rest of ``Phi - I`` is zero)."""
    A[:, :] = 0.0
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 0] = -fn[2], fn[1], fn[2]
    S[1, 2], S[2, 0], S[2, 1] = -fn[0], -fn[1], fn[0]
    SC = np.zeros((3, 3))
    matmul3(S, Cm, SC)
    for i in range(3):
        A[i, i] = d                                         # (dp, dv) = T I
        for j in range(3):
            A[3 + i, 3 + j] = -S[i, j]                      # (dv, eps) = -[fn x]
            A[3 + i, 6 + j] = Cm[i, j]                      # (dv, ba) = Cm
            A[6 + i, 9 + j] = Cm[i, j]                      # (eps, bg) = Cm
            A[i, 3 + j] = -0.5 * d * S[i, j]                # (dp, eps) = -T [fn x] / 2
            A[i, 6 + j] = 0.5 * d * Cm[i, j]                # (dp, ba) = T Cm / 2
            A[3 + i, 9 + j] = -0.5 * SC[i, j]               # (dv, bg) = -[fn x] Cm / 2


def predict(x, P, A, q, AP, APA, xa):
    """``x = Phi x``, ``P = Phi P Phi^T + diag(q)`` in place for ``Phi = I + A`` (filterpy's prediction
    on the non-zero blocks); `AP` (9, n), `APA` (9, 9) and `xa` (9,) are scratch."""
    n = x.shape[0]
    AP[:, :] = 0.0
    for i in range(_NR):
        for l in range(_NC):
            a = A[i, l]
            if a != 0.0:
                for j in range(n):
                    AP[i, j] += a * P[_C0 + l, j]
    for i in range(_NR):
        for j in range(_NR):
            s = 0.0
            for l in range(_NC):
                s += AP[i, _C0 + l] * A[j, l]
            APA[i, j] = s
    for i in range(_NR):
        s = 0.0
        for l in range(_NC):
            s += A[i, l] * x[_C0 + l]
        xa[i] = s
    for i in range(_NR):
        x[_R0 + i] += xa[i]
        for j in range(n):
            P[_R0 + i, j] += AP[i, j]
    for i in range(n):
        for j in range(_NR):
            P[i, _R0 + j] += AP[j, i]
    for i in range(_NR):
        for j in range(_NR):
            P[_R0 + i, _R0 + j] += APA[i, j]
    for i in range(n):
        P[i, i] += q[i]


def inverse(S, m, out):
    """Inverse of the symmetric positive definite `S` (m x m, m <= 3) into `out`, by its cofactors."""
    if m == 1:
        out[0, 0] = 1.0 / S[0, 0]
    elif m == 2:
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        out[0, 0], out[1, 1] = S[1, 1] / det, S[0, 0] / det
        out[0, 1], out[1, 0] = -S[0, 1] / det, -S[1, 0] / det
    else:
        c00 = S[1, 1] * S[2, 2] - S[1, 2] * S[2, 1]
        c01 = S[1, 2] * S[2, 0] - S[1, 0] * S[2, 2]
        c02 = S[1, 0] * S[2, 1] - S[1, 1] * S[2, 0]
        det = S[0, 0] * c00 + S[0, 1] * c01 + S[0, 2] * c02
        out[0, 0] = c00 / det
        out[1, 0] = c01 / det
        out[2, 0] = c02 / det
        out[0, 1] = (S[0, 2] * S[2, 1] - S[0, 1] * S[2, 2]) / det
        out[1, 1] = (S[0, 0] * S[2, 2] - S[0, 2] * S[2, 0]) / det
        out[2, 1] = (S[0, 1] * S[2, 0] - S[0, 0] * S[2, 1]) / det
        out[0, 2] = (S[0, 1] * S[1, 2] - S[0, 2] * S[1, 1]) / det
        out[1, 2] = (S[0, 2] * S[1, 0] - S[0, 0] * S[1, 2]) / det
        out[2, 2] = (S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]) / det


def product(A, B, ni, nl, nj, out):
    """``out[:ni, :nj] = A[:ni, :nl] B[:nl, :nj]``, each entry summed over l in order."""
    for i in range(ni):
        for j in range(nj):
            s = 0.0
            for l in range(nl):
                s += A[i, l] * B[l, j]
            out[i, j] = s


def product_t(A, B, ni, nl, nj, out):
    """``out[:ni, :nj] = A[:ni, :nl] B[:nj, :nl]^T``, each entry summed over l in order, the terms of the zero
    entries of `B` left out (a measurement's Jacobian is mostly zeros; with a finite `A` they add nothing)."""
    for i in range(ni):
        for j in range(nj):
            out[i, j] = 0.0
    for j in range(nj):
        for l in range(nl):
            b = B[j, l]
            if b != 0.0:
                for i in range(ni):
                    out[i, j] += A[i, l] * b


def h_x_plus_r(H, X, R, m, out):
    """``out = H X + R`` for the first `m` rows of `H` and columns of `X` (an innovation covariance; the terms
    of the zero entries of `H` left out, as in :func:`product_t`)."""
    for a in range(m):
        for c in range(m):
            s = 0.0
            for l in range(H.shape[1]):
                h = H[a, l]
                if h != 0.0:
                    s += h * X[l, c]
            out[a, c] = s + R[a, c]


def kf_update(x, P, y, H, R, m, fj, S, PHt, KHt, K, D, Si, Sc):
    """Joseph-form update in place, the innovation covariance into `S`.

    filterpy's ``S = H P H^T + R``, ``K = P H^T S^-1``, ``x = x + K y``, ``P = (I - K H) P (I - K H)^T
    + K R K^T``. `fj` is the considered (frozen) state, or -1: the gain is then the one of the filter taking
    it as known (from ``P`` conditioned on it) and it is not updated. Returns the NIS ``y^T S^-1 y``.
    `PHt`, `KHt`, `K`, `D` (n, 3) and `Si`, `Sc` (3, 3) are scratch.
    """
    n = x.shape[0]
    product_t(P, H, n, n, m, PHt)
    h_x_plus_r(H, PHt, R, m, S)
    inverse(S, m, Si)
    nis = 0.0
    for a in range(m):
        for c in range(m):
            nis += y[a] * Si[a, c] * y[c]
    for i in range(n):
        for a in range(m):
            KHt[i, a] = PHt[i, a]
    if fj >= 0 and P[fj, fj] > 0:
        # the filter that takes state fj as known: P conditioned on it (one Schur complement)
        w = 1.0 / P[fj, fj]
        for a in range(m):
            hc = 0.0
            for l in range(n):
                hc += H[a, l] * P[l, fj]
            for i in range(n):
                KHt[i, a] -= w * P[i, fj] * hc
            KHt[fj, a] = 0.0
        h_x_plus_r(H, KHt, R, m, Sc)
        inverse(Sc, m, Si)
    product(KHt, Si, n, m, m, K)
    for i in range(n):
        s = 0.0
        for a in range(m):
            s += K[i, a] * y[a]
        x[i] += s
    # (I - K H) P (I - K H)^T + K R K^T = P + K D^T - P H^T K^T with D = K S - P H^T
    for i in range(n):
        for c in range(m):
            s = 0.0
            for a in range(m):
                s += K[i, a] * S[a, c]
            D[i, c] = s - PHt[i, c]
    for i in range(n):
        for j in range(i, n):
            s1 = 0.0
            s2 = 0.0
            for a in range(m):
                s1 += K[i, a] * D[j, a] - PHt[i, a] * K[j, a]
                s2 += K[j, a] * D[i, a] - PHt[j, a] * K[i, a]
            v = 0.5 * ((P[i, j] + s1) + (P[j, i] + s2))
            P[i, j] = v
            P[j, i] = v
    return nis


def step_model(x, p, clone, attitude, z, H, y):
    """Innovation and Jacobian of the MoRPI step ``z = (1 + k) R(e) (p_xy - c)`` (true position ``p``
    and clone ``c``; ``e`` the attitude's heading error, or with given directions :data:`_TURN`)."""
    gain = 1.0 + x[_GAIN]
    d0 = (p[0] - x[_DP]) - (clone[0] - x[_CL])
    d1 = (p[1] - x[_DP + 1]) - (clone[1] - x[_CL + 1])
    e = x[_EPS + 2] if attitude else x[_TURN]
    c, s = math.cos(e), math.sin(e)
    r0, r1 = c * d0 - s * d1, s * d0 + c * d1
    y[0], y[1] = z[0] - gain * r0, z[1] - gain * r1
    H[:2, :] = 0.0
    H[0, _DP], H[0, _DP + 1], H[1, _DP], H[1, _DP + 1] = -gain * c, gain * s, -gain * s, -gain * c
    H[0, _CL], H[0, _CL + 1], H[1, _CL], H[1, _CL + 1] = gain * c, -gain * s, gain * s, gain * c
    H[0, _GAIN], H[1, _GAIN] = r0, r1
    col = _EPS + 2 if attitude else _TURN
    H[0, col], H[1, col] = -gain * r1, gain * r0


def zero_velocity_model(x, v, H, y):
    """Innovation and Jacobian of the zero-velocity update, ``z = 0 = v_hat - dv``."""
    H[:, :] = 0.0
    for i in range(3):
        H[i, _DV + i] = -1.0
        y[i] = -(v[i] - x[_DV + i])


def zero_rate_model(x, z, H, y):
    """Innovation and Jacobian of the zero-rate update, ``z = mean(omega) - bg_hat = bg`` (`z` the mean rate)."""
    H[:, :] = 0.0
    for i in range(3):
        H[i, _BG + i] = 1.0
        y[i] = z[i] - x[_BG + i]


def nhc_model(x, C, v, M, H, y):
    """Innovation (measurement zero) and Jacobian of the non-holonomic constraint: rows 2-3 of ``M C^T v``
    (true ``C`` and ``v``; `M` the phone-to-robot tilt), linearized at the fed-back state."""
    R = np.zeros((3, 3))
    rodrigues(-x[_EPS], -x[_EPS + 1], -x[_EPS + 2], R)
    Ct = np.zeros((3, 3))
    matmul3(R, C, Ct)
    u = np.zeros(3)
    for i in range(3):
        u[i] = v[i] - x[_DV + i]
    vb = np.zeros(3)
    for i in range(3):
        vb[i] = Ct[0, i] * u[0] + Ct[1, i] * u[1] + Ct[2, i] * u[2]
    H[:2, :] = 0.0
    for r in range(2):
        y[r] = -(M[r + 1, 0] * vb[0] + M[r + 1, 1] * vb[1] + M[r + 1, 2] * vb[2])
        # rows of M C^T at the fed-back state, and -A [u x]
        a0 = M[r + 1, 0] * C[0, 0] + M[r + 1, 1] * C[0, 1] + M[r + 1, 2] * C[0, 2]
        a1 = M[r + 1, 0] * C[1, 0] + M[r + 1, 1] * C[1, 1] + M[r + 1, 2] * C[1, 2]
        a2 = M[r + 1, 0] * C[2, 0] + M[r + 1, 1] * C[2, 1] + M[r + 1, 2] * C[2, 2]
        H[r, _DV], H[r, _DV + 1], H[r, _DV + 2] = -a0, -a1, -a2
        H[r, _EPS] = -(a1 * u[2] - a2 * u[1])
        H[r, _EPS + 1] = -(a2 * u[0] - a0 * u[2])
        H[r, _EPS + 2] = -(a0 * u[1] - a1 * u[0])


def forward_member(t, f, w, flags, end_k, end_a, end_j, step_len, step_vec, turn_q, par, C0, v0, P0, fj,
                   keep_inn, keep_hist, ep_k, ep_p, ep_P, nis, inn_k, inn_z, inn_y, inn_S, inn_n,
                   hist_P, hist_rec, x, P, bias):
    """The forward filter over one recording, written into the output arrays.

    Parameters
    ----------
    t, f, w : (n,), (n, 3), (n, 3)
        Times, specific force and angular rate.
    flags : (n,) int
        Bits :data:`EPOCH`, :data:`REST`, :data:`STAND`, :data:`START` per sample.
    end_k, end_a, end_j : (s,) int
        Step updates in order: end sample, start sample, step index.
    step_len, step_vec : (k,), (k, 2)
        Step lengths and given step vectors.
    turn_q : (n,) or (0,)
        Turn variance added to the heading error of given directions at a sample.
    par : (len(PAR),)
        Tunables (:data:`PAR`).
    C0, v0, P0 : (3, 3), (3,), (N, N)
        Initial attitude (also the phone-to-robot tilt), velocity and covariance.
    fj : int
        Considered state, or -1.
    keep_inn, keep_hist : bool
        Whether to write the innovations and the smoother's history.

    The outputs: per epoch its sample, position and horizontal covariance; ``nis`` (4, 3): the
    sum, the count and the first update's sample per kind (:data:`KINDS`); the innovations per
    kind (``inn_n`` of them); the smoother's history (:func:`smooth_member`: per epoch the
    posterior covariance, and the posterior, the correction fed back and the interval's terms
    in the columns of ``aided._HIST``); the final ``x``, ``P`` and the bias estimates ``bias`` (6,).
    """
    n = t.shape[0]
    q_a, q_a_rest, q_g, q_g_rest, q_ba, q_bg, jump2 = par[0], par[1], par[2], par[3], par[4], par[5], par[6]
    step_sig, nhc_sig, zupt_sig, gsr = par[7], par[8], par[9], par[10]
    use_nhc, g, gyro = par[11] != 0.0, par[12], par[13] != 0.0
    # sizes and kinds as run-time integers: numba compiles a callee once per literal argument it is given
    two, three = np.int64(2), np.int64(3)
    kinds = np.arange(4)
    N = x.shape[0]
    C = C0.copy()
    Cn = np.zeros((3, 3))
    Rt = np.zeros((3, 3))
    v = v0.copy()
    p = np.zeros(3)
    clone = np.zeros(2)
    ba = np.zeros(3)
    bg = np.zeros(3)
    x[:] = 0.0
    for i in range(N):                         # (P0 is read-only: copy_into takes writeable sources)
        for j in range(N):
            P[i, j] = P0[i, j]
    acc = np.zeros(16)                         # duration, force integral (3), attitude integral (9), rate (3)
    head = np.zeros(2)
    head_at = np.zeros((n, 2))
    fp = np.zeros(3)
    wp = np.zeros(3)
    ap = np.zeros(3)
    fk = np.zeros(3)
    wk = np.zeros(3)
    ak = np.zeros(3)
    for i in range(3):
        fp[i] = f[0, i] - ba[i]
        wp[i] = w[0, i] - bg[i]
    for i in range(3):
        ap[i] = C[i, 0] * fp[0] + C[i, 1] * fp[1] + C[i, 2] * fp[2]
    ap[2] -= g
    A = np.zeros((_NR, _NC))
    q = np.zeros(N)
    H = np.zeros((3, N))
    Rm = np.zeros((3, 3))
    y = np.zeros(3)
    z = np.zeros(3)
    S = np.zeros((3, 3))
    fed = np.zeros(N)
    Cm = np.zeros((3, 3))
    # scratch of the prediction and the updates
    AP, APA, xa = np.zeros((_NR, N)), np.zeros((_NR, _NR)), np.zeros(_NR)
    W1, W2, W3, W4 = np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 3))
    Si, Sc = np.zeros((3, 3)), np.zeros((3, 3))
    fn = np.zeros(3)
    was_still = (flags[0] & (REST | STAND)) != 0
    e = 0
    ie = 0
    for k in range(n):
        if k > 0:
            dt = t[k] - t[k - 1]
            for i in range(3):
                fk[i] = f[k, i] - ba[i]
                wk[i] = w[k, i] - bg[i]
            h = 0.5 * dt
            rodrigues(h * (wp[0] + wk[0]), h * (wp[1] + wk[1]), h * (wp[2] + wk[2]), Rt)
            matmul3(C, Rt, Cn)
            for i in range(3):
                ak[i] = Cn[i, 0] * fk[0] + Cn[i, 1] * fk[1] + Cn[i, 2] * fk[2]
            ak[2] -= g
            acc[0] += dt
            for i in range(3):
                vn = v[i] + h * (ap[i] + ak[i])
                p[i] += h * (v[i] + vn)
                v[i] = vn
                acc[1 + i] += dt * (C[i, 0] * (0.5 * (fp[0] + fk[0])) + C[i, 1] * (0.5 * (fp[1] + fk[1]))
                                    + C[i, 2] * (0.5 * (fp[2] + fk[2])))
                for j in range(3):
                    acc[4 + 3 * i + j] += dt * C[i, j]
                acc[13 + i] += dt * (0.5 * (wp[i] + wk[i]))
            for i in range(3):
                fp[i], wp[i], ap[i] = fk[i], wk[i], ak[i]
                for j in range(3):
                    C[i, j] = Cn[i, j]
        head[0] += C[0, 0]
        head[1] += C[1, 0]
        fl = flags[k]
        if (fl & EPOCH) == 0:
            continue
        still = (fl & (REST | STAND)) != 0
        jq = 0.0
        tq = 0.0
        qa_k, qg_k = q_a, q_g
        if k > 0:
            for i in range(3):
                fn[i] = acc[1 + i]
                for j in range(3):
                    Cm[i, j] = acc[4 + 3 * i + j]
            d = acc[0]
            transition_blocks(d, fn, Cm, A)
            if still:
                qa_k, qg_k = q_a_rest, q_g_rest
            q[:] = 0.0
            if still != was_still:
                jq = jump2
            if turn_q.shape[0] > 0:
                tq = turn_q[k]
            for i in range(3):
                q[_DV + i] = qa_k * d
                q[_EPS + i] = qg_k * d
                q[_BA + i] = q_ba * d + jq
                q[_BG + i] = q_bg * d
            q[_TURN] += tq
            predict(x, P, A, q, AP, APA, xa)
        was_still = still
        touched = False
        # ---- updates, all about the same nominal state; the feedback follows them
        while ie < end_k.shape[0] and end_k[ie] == k:
            a, j = end_a[ie], end_j[ie]
            if gyro:
                z[0], z[1] = step_vec[j, 0], step_vec[j, 1]
            else:
                psi = math.atan2(head[1] - head_at[a, 1], head[0] - head_at[a, 0])
                z[0], z[1] = step_len[j] * math.cos(psi), step_len[j] * math.sin(psi)
            step_model(x, p, clone, not gyro, z, H, y)
            Rm[:, :] = 0.0
            Rm[0, 0] = Rm[1, 1] = step_sig * step_sig
            val = kf_update(x, P, y, H, Rm, two, fj, S, W1, W2, W3, W4, Si, Sc)
            _log(kinds[0], two, k, z, y, val, S, nis, keep_inn, inn_k, inn_z, inn_y, inn_S, inn_n)
            touched = True
            ie += 1
        if k > 0 and (fl & (REST | STAND)) != 0:
            # zero velocity (rest and standing), then zero rate (rest only)
            zero_velocity_model(x, v, H, y)
            Rm[:, :] = 0.0
            for i in range(3):
                Rm[i, i] = zupt_sig * zupt_sig
                z[i] = 0.0
            val = kf_update(x, P, y, H, Rm, three, fj, S, W1, W2, W3, W4, Si, Sc)
            _log(kinds[1], three, k, z, y, val, S, nis, keep_inn, inn_k, inn_z, inn_y, inn_S, inn_n)
            if (fl & REST) != 0:
                dr = max(acc[0], 1e-9)
                sg = gsr / math.sqrt(dr)
                for i in range(3):
                    Rm[i, i] = sg * sg
                    z[i] = acc[13 + i] / dr
                zero_rate_model(x, z, H, y)
                val = kf_update(x, P, y, H, Rm, three, fj, S, W1, W2, W3, W4, Si, Sc)
                _log(kinds[2], three, k, z, y, val, S, nis, keep_inn, inn_k, inn_z, inn_y, inn_S, inn_n)
            touched = True
        if k > 0 and not still and use_nhc:
            nhc_model(x, C, v, C0, H, y)
            Rm[:, :] = 0.0
            Rm[0, 0] = Rm[1, 1] = nhc_sig * nhc_sig
            z[0] = z[1] = 0.0
            val = kf_update(x, P, y, H, Rm, two, fj, S, W1, W2, W3, W4, Si, Sc)
            _log(kinds[3], two, k, z, y, val, S, nis, keep_inn, inn_k, inn_z, inn_y, inn_S, inn_n)
            touched = True
        # ---- feedback into the nominal state
        fed[:] = 0.0
        if touched:
            for i in range(3):
                p[i] -= x[_DP + i]
                v[i] -= x[_DV + i]
                ba[i] += x[_BA + i]
                bg[i] += x[_BG + i]
            rodrigues(-x[_EPS], -x[_EPS + 1], -x[_EPS + 2], Rt)
            matmul3(Rt, C, Cn)
            copy_into(C, Cn)
            clone[0] -= x[_CL]
            clone[1] -= x[_CL + 1]
            for i in range(_GAIN):
                fed[i] = x[i]
                x[i] = 0.0
            for i in range(3):
                fp[i] = f[k, i] - ba[i]
                wp[i] = w[k, i] - bg[i]
            for i in range(3):
                ap[i] = C[i, 0] * fp[0] + C[i, 1] * fp[1] + C[i, 2] * fp[2]
            ap[2] -= g
        # ---- a step starts: the clone takes the current horizontal position error
        if (fl & START) != 0:
            for r in range(2):
                for j in range(N):
                    P[_CL + r, j] = P[_DP + r, j]
            for r in range(2):
                for i in range(N):
                    P[i, _CL + r] = P[i, _DP + r]
                x[_CL + r] = x[_DP + r]
                clone[r] = p[r]
                head_at[k, r] = head[r]
        ep_k[e] = k
        for i in range(3):
            ep_p[e, i] = p[i]
        for i in range(2):
            for j in range(2):
                ep_P[e, i, j] = P[i, j]
        if keep_hist:
            copy_into(hist_P[e], P)
            for i in range(N):
                hist_rec[e, i] = x[i]
                hist_rec[e, N + i] = fed[i]
            for i in range(13):
                hist_rec[e, 2 * N + i] = acc[i]
            hist_rec[e, 2 * N + 13] = jq
            hist_rec[e, 2 * N + 14] = qa_k
            hist_rec[e, 2 * N + 15] = qg_k
            hist_rec[e, 2 * N + 16] = tq
        acc[:] = 0.0
        e += 1
    for i in range(3):
        bias[i] = ba[i]
        bias[3 + i] = bg[i]
    return e


def _log(kind, m, k, z, y, val, S, nis, keep_inn, inn_k, inn_z, inn_y, inn_S, inn_n):
    """Add one update's NIS to its kind's sum; keep its measurement, innovation and covariance when asked."""
    if nis[kind, 1] == 0.0:
        nis[kind, 2] = k
    nis[kind, 0] += val
    nis[kind, 1] += 1.0
    if keep_inn:
        r = inn_n[kind]
        inn_k[kind, r] = k
        for a in range(m):
            inn_z[kind, r, a] = z[a]
            inn_y[kind, r, a] = y[a]
            for c in range(m):
                inn_S[kind, r, a, c] = S[a, c]
        inn_n[kind] = r + 1


def condition(P, j):
    """``P`` conditioned on state `j` in place (one Schur complement; its row and column zero)."""
    pjj = P[j, j]
    if pjj > 0:
        w = 1.0 / pjj
        col = P[:, j].copy()
        for a in range(P.shape[0]):
            for b in range(P.shape[0]):
                P[a, b] -= w * col[a] * col[b]
        P[j, :] = 0.0
        P[:, j] = 0.0


def lu_factor(A, piv):
    """LU factorization of the square `A` in place with partial pivoting (the largest magnitude of each
    column below the diagonal, the first of equals: LAPACK's ``getrf``), the row swaps into `piv`."""
    n = A.shape[0]
    for c in range(n):
        p = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big = abs(A[i, c])
                p = i
        piv[c] = p
        if p != c:
            for j in range(n):
                a = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = a
        d = A[c, c]
        for i in range(c + 1, n):
            l = A[i, c] / d
            A[i, c] = l
            if l != 0.0:
                for j in range(c + 1, n):
                    A[i, j] -= l * A[c, j]


def lu_solve(LU, piv, B):
    """``B = A^-1 B`` in place (`B` (n, k)) from the factors of :func:`lu_factor`. Each entry of a row takes
    its terms over l in order; the loops run along the rows of `B`."""
    n, k = B.shape
    for c in range(n):
        p = piv[c]
        if p != c:
            for j in range(k):
                b = B[c, j]
                B[c, j] = B[p, j]
                B[p, j] = b
    for i in range(n):
        for l in range(i):
            c = LU[i, l]
            for j in range(k):
                B[i, j] -= c * B[l, j]
    for i in range(n - 1, -1, -1):
        for l in range(i + 1, n):
            c = LU[i, l]
            for j in range(k):
                B[i, j] -= c * B[l, j]
        d = LU[i, i]
        for j in range(k):
            B[i, j] = B[i, j] / d


def smooth_member(hist_P, hist_rec, q_ba, q_bg, fj, covariance, xs, Ps_xy):
    """Rauch-Tung-Striebel smoother over one member's epochs (filterpy's recursion), from the
    history :func:`forward_member` wrote: the smoothed error states into `xs` (m, N) and, with
    `covariance`, the smoothed horizontal covariances into `Ps_xy` (m, 2, 2).

    The transitions and predictions are rebuilt from the history's interval terms, as the
    forward pass computed them. The smoother's gain ``G = P Phi^T Pq^+`` (with `fj` >= 0, from
    the covariances conditioned on that considered state) is applied as ``P Phi^T u`` with
    ``Pq u = r`` (solved by :func:`lu_factor` and :func:`lu_solve`, the partial pivoting of
    ``numpy.linalg.solve``); states without uncertainty (their rows of ``Pq`` zero) take no correction.
    """
    m, n = hist_P.shape[0], hist_P.shape[1]
    A = np.zeros((_NR, _NC))
    q = np.zeros(n)
    fn = np.zeros(3)
    Cm = np.zeros((3, 3))
    xp = np.zeros(n)
    Pq = np.zeros((n, n))
    Pp = np.zeros((n, n))
    Pprior = np.zeros((n, n))
    LU = np.zeros((n, n))
    piv = np.zeros(n, np.int64)
    u = np.zeros((n, 1))
    Gt = np.zeros((n, n))
    T = np.zeros((n, n))
    Ps = np.zeros((n, n))
    r = np.zeros(n)
    row = np.zeros(n)
    wv = np.zeros(n)
    dead = np.zeros(n, np.bool_)
    AP, APA, xa = np.zeros((_NR, n)), np.zeros((_NR, _NR)), np.zeros(_NR)
    copy_into(Ps, hist_P[m - 1])
    for i in range(n):
        xs[m - 1, i] = hist_rec[m - 1, i]
    if covariance:
        copy_into(Ps_xy[m - 1], Ps)
    for k in range(m - 2, -1, -1):
        # the forward pass's prediction into epoch k + 1
        e = hist_rec[k + 1]
        d = e[2 * n]
        for i in range(3):
            fn[i] = e[2 * n + 1 + i]
            for j in range(3):
                Cm[i, j] = e[2 * n + 4 + 3 * i + j]
        transition_blocks(d, fn, Cm, A)
        q[:] = 0.0
        for i in range(3):
            q[_DV + i] = e[2 * n + 14] * d
            q[_EPS + i] = e[2 * n + 15] * d
            q[_BA + i] = q_ba * d + e[2 * n + 13]
            q[_BG + i] = q_bg * d
        q[_TURN] += e[2 * n + 16]
        for i in range(n):
            xp[i] = hist_rec[k, i]
        copy_into(Pq, hist_P[k])
        predict(xp, Pq, A, q, AP, APA, xa)
        copy_into(Pp, hist_P[k])
        if covariance:
            copy_into(Pprior, Pq)
        if fj >= 0:
            condition(Pp, fj)
            condition(Pq, fj)
        for i in range(n):
            r[i] = xs[k + 1, i] + e[n + i] - xp[i]
        for i in range(n):
            dead[i] = True
            for j in range(n):
                if Pq[i, j] != 0.0:
                    dead[i] = False
                    break
        for i in range(n):
            if dead[i]:
                Pq[i, i] = 1.0
                r[i] = 0.0
        # G r = P Phi^T u with Pq u = r
        copy_into(LU, Pq)
        lu_factor(LU, piv)
        for i in range(n):
            u[i, 0] = r[i]
        lu_solve(LU, piv, u)
        for i in range(n):
            wv[i] = u[i, 0]
        for l in range(_NC):
            s = 0.0
            for i in range(_NR):
                s += A[i, l] * u[_R0 + i, 0]
            wv[_C0 + l] += s
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += Pp[i, j] * wv[j]
            xs[k, i] = hist_rec[k, i] + s
        if covariance:
            # Ps = P + G (Ps' - Pq) G^T with G^T = Pq^+ Phi P (the dead states' columns of G zero)
            copy_into(Gt, Pp)
            for i in range(_NR):
                for j in range(n):
                    row[j] = 0.0
                for l in range(_NC):
                    a = A[i, l]
                    if a != 0.0:
                        for j in range(n):
                            row[j] += a * Pp[_C0 + l, j]
                for j in range(n):
                    Gt[_R0 + i, j] += row[j]
            lu_solve(LU, piv, Gt)
            for i in range(n):
                if dead[i]:
                    for j in range(n):
                        Gt[i, j] = 0.0
            # T = (Ps' - Pq) G^T, then Ps = P + G T: each entry summed over l in order, along the rows; a
            # zero factor's terms left out (they add nothing to a finite sum that starts at +0)
            for i in range(n):
                for j in range(n):
                    T[i, j] = 0.0
                for l in range(n):
                    dl = Ps[i, l] - Pprior[i, l]
                    if dl != 0.0:
                        for j in range(n):
                            T[i, j] += dl * Gt[l, j]
            for i in range(n):
                for j in range(n):
                    row[j] = 0.0
                for l in range(n):
                    gl = Gt[l, i]
                    if gl != 0.0:
                        for j in range(n):
                            row[j] += gl * T[l, j]
                for j in range(n):
                    Ps[i, j] = hist_P[k, i, j] + row[j]
            copy_into(Ps_xy[k], Ps)


#: The functions numba compiles, callees first (each finds the compiled form of those it calls).
_FUNCTIONS = ("copy_into", "transition_blocks", "predict", "inverse", "product", "product_t", "h_x_plus_r", "kf_update",
              "step_model", "zero_velocity_model", "zero_rate_model", "nhc_model", "_log", "forward_member", "condition",
              "lu_factor", "lu_solve", "smooth_member")
compiled = loops(globals(), _FUNCTIONS, uses=(strapdown_loops,))
