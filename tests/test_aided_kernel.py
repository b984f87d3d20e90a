"""The aided filter's compiled pass and smoother: each piece against the numpy reference forms of
``tests/oracles/aided.py`` (or a dense reference built here) within a rounding tolerance stated beside it,
and the compiled loop against the same loop run as plain Python (the same bits)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from oracles import aided as oracle

from morpi_filters import _aided_kernel as K
from morpi_filters import aided, simulate, units
from morpi_filters.error_model import BA, BG, DP, DV, EPS
from conftest import plain_kernels

N = aided.N_AIDED
#: Machine epsilon of float64.
EPS_F = np.finfo(float).eps


@pytest.fixture(scope="module")
def jit():
    return K.compiled()


def _spd(rng, n=N, scale=1.0):
    A = rng.normal(size=(n, n)) * scale
    return A @ A.T + np.eye(n) * 1e-3


def _nominal(rng):
    from scipy.spatial.transform import Rotation

    C = Rotation.from_rotvec(rng.normal(size=(1, 3)) * 0.5).as_matrix()
    return oracle.Nominal(C=C, v=rng.normal(size=(1, 3)), p=rng.normal(size=(1, 3)), clone=rng.normal(size=(1, 2)))


def _error_state(rng):
    # an error state between updates of one epoch: nothing fed back yet, so every state may be non-zero
    return rng.normal(size=N) * 0.05


def test_the_state_layout_is_aideds():
    assert (K._N, K._CL, K._GAIN, K._TURN) == (N, aided.CLONE.start, aided.GAIN, aided.TURN)
    assert K.KINDS == ("step", "zero velocity", "zero rate", "non-holonomic")


def _dense_phi(d, fn, Cm):
    """``I + F T + (F T)^2 / 2`` built densely from the error model's blocks of ``F T``, batched."""
    b = d.shape[0]
    Fd = np.zeros((b, N, N))
    Fd[:, DP, DV] = np.eye(3) * d[:, None, None]
    Fd[:, DV, EPS] = -oracle.skew(fn)
    Fd[:, DV, BA] = Cm
    Fd[:, EPS, BG] = Cm
    return np.eye(N) + Fd + 0.5 * Fd @ Fd


def test_transition_and_prediction_are_the_dense_ones(jit):
    """Phi's closed-form blocks against I + F T + (F T)^2 / 2 built densely; the sparse predict against kf_predict."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(4)
    for _ in range(10):
        d = rng.uniform(0.05, 0.2)
        fn = rng.normal(size=3) * 2.0
        Cm = Rotation.from_rotvec(rng.normal(size=3)).as_matrix() * d
        A = np.zeros((K._NR, K._NC))
        jit["transition_blocks"](d, fn, Cm, A)
        Phi = np.eye(N)
        Phi[K._R0:K._R0 + K._NR, K._C0:K._C0 + K._NC] += A
        dense = _dense_phi(np.array([d]), fn[None], Cm[None])[0]
        # the same products in another order (entries below 10): a few units of 1e-16 each
        np.testing.assert_allclose(Phi, dense, rtol=0, atol=1e-14)
        x, P, q = rng.normal(size=N), _spd(rng), rng.uniform(0, 1e-3, N)
        xr, Pr = oracle.kf_predict(x[None], P[None], Phi[None], np.diag(q)[None])
        jit["predict"](x, P, A, q, np.zeros((K._NR, N)), np.zeros((K._NR, K._NR)), np.zeros(K._NR))
        # sums of up to 19 products in another order: relative 1e-12 of the largest entry
        np.testing.assert_allclose(x, xr[0], rtol=0, atol=1e-12 * np.abs(xr).max())
        np.testing.assert_allclose(P, Pr[0], rtol=0, atol=1e-12 * np.abs(Pr).max())


@pytest.mark.parametrize("m", [1, 2, 3])
@pytest.mark.parametrize("frozen", [False, True])
def test_update_is_kf_update(jit, m, frozen):
    rng = np.random.default_rng(13 + m)
    for _ in range(10):
        P = _spd(rng, scale=0.3)
        x, y = rng.normal(size=N), rng.normal(size=m)
        H = np.zeros((3, N))
        H[:m] = rng.normal(size=(m, N))
        R = np.eye(3) * rng.uniform(0.01, 1.0)
        fz = np.zeros(N, bool)
        fz[aided.GAIN] = frozen
        xr, Pr, Sr = oracle.kf_update(x[None], P[None], y[None], H[None, :m], R[None, :m, :m],
                                     fz[None] if frozen else None)
        S = np.zeros((3, 3))
        x0 = x.copy()
        scratch = [np.full((N, 3), np.nan) for _ in range(4)] + [np.full((3, 3), np.nan) for _ in range(2)]
        nis = jit["kf_update"](x, P, y, H, R, m, aided.GAIN if frozen else -1, S, *scratch)
        # cofactor inverse against LU, products summed in another order: relative 1e-11 covers the
        # innovation covariance's condition number (below 1e3 here) times a few 1e-16
        np.testing.assert_allclose(S[:m, :m], Sr[0], rtol=1e-12)
        np.testing.assert_allclose(x, xr[0], rtol=0, atol=1e-11 * np.abs(xr).max())
        np.testing.assert_allclose(P, Pr[0], rtol=0, atol=1e-11 * np.abs(Pr).max())
        np.testing.assert_allclose(nis, y @ np.linalg.solve(Sr[0], y), rtol=1e-11)
        assert (x[aided.GAIN] == x0[aided.GAIN]) == frozen          # a considered state is not updated


@pytest.mark.parametrize("attitude", [True, False])
def test_step_model_is_step_displacement(jit, attitude):
    rng = np.random.default_rng(14)
    for _ in range(10):
        nom, x = _nominal(rng), _error_state(rng)
        z = rng.normal(size=3)
        meas = oracle.StepDisplacement(z=z[None, :2], sigma=np.ones(1), attitude=np.array([attitude]))
        H, y = np.zeros((3, N)), np.zeros(3)
        jit["step_model"](x, nom.p[0], nom.clone[0], attitude, z, H, y)
        # the same arithmetic on values of order 1, the rotation written out: a few units of 1e-16
        np.testing.assert_allclose(y[:2], (meas.z - meas.h(x[None], nom))[0], rtol=0, atol=1e-14)
        np.testing.assert_allclose(H[:2], meas.H(x[None], nom)[0], rtol=0, atol=1e-14)


def test_rest_models_are_zero_velocity_and_zero_rate(jit):
    rng = np.random.default_rng(17)
    for _ in range(10):
        nom, x = _nominal(rng), _error_state(rng)
        z = rng.normal(size=3) * 1e-3
        H, y = np.zeros((3, N)), np.zeros(3)
        zv = oracle.ZeroVelocity(sigma=np.ones(1))
        jit["zero_velocity_model"](x, nom.v[0], H, y)
        # one subtraction and a sign on values below 3: one rounding, at most eps/2 * 4 < 1e-15
        np.testing.assert_allclose(y, (zv.z - zv.h(x[None], nom))[0], rtol=0, atol=1e-15)
        # the Jacobians are the constants 0 and +-1, computed by neither form: a tolerance of one eps
        # leaves room for no arithmetic
        np.testing.assert_allclose(H, zv.H(x[None], nom)[0], rtol=0, atol=EPS_F)
        zr = oracle.ZeroRate(z=z[None], sigma=np.ones(1))
        jit["zero_rate_model"](x, z, H, y)
        np.testing.assert_allclose(y, (zr.z - zr.h(x[None], nom))[0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(H, zr.H(x[None], nom)[0], rtol=0, atol=EPS_F)


def test_nhc_model_is_non_holonomic(jit):
    rng = np.random.default_rng(15)
    for _ in range(10):
        nom, x = _nominal(rng), _error_state(rng)
        M = _nominal(rng).C
        meas = oracle.NonHolonomic(M=M, sigma=np.ones(1))
        H, y = np.zeros((3, N)), np.zeros(3)
        jit["nhc_model"](x, nom.C[0], nom.v[0], M[0], H, y)
        # a rotation and two 3 x 3 products on values of order 1 in another order: a few units of 1e-16
        np.testing.assert_allclose(y[:2], (meas.z - meas.h(x[None], nom))[0], rtol=0, atol=1e-14)
        # the Jacobian at the fed-back state: the class takes eps = 0 as well
        np.testing.assert_allclose(H[:2], meas.H(x[None], nom)[0], rtol=0, atol=1e-14)


def _busy_input():
    # a short sine drive with rest at both ends and a standing stretch: every measurement runs
    traj = simulate.sine(2.5, p2p_m=0.5, amplitude_m=0.1, rate_hz=100.0)
    rng = np.random.default_rng(16)
    d = simulate.imu(traj, units.LSM6DSL, rng, bias_scale=(0.05, 0.05))
    t, pos = traj.time, traj.position
    pt = t[np.clip(np.searchsorted(t, np.asarray(traj.period_times)), 0, t.size - 1)]
    pa = np.array([np.interp(pt[:-1], t, pos[:, j]) for j in range(2)]).T
    pb = np.array([np.interp(pt[1:], t, pos[:, j]) for j in range(2)]).T
    vec = (pb - pa) * 1.03
    rest = ((t[0], t[0] + 0.3), (t[-1] - 0.3, t[-1]))
    return aided.AidedInput(time=t, f=d.f, omega=d.omega, C0=traj.C_bn[0], g=units.G0, step_start=pt[:-1],
                            step_end=pt[1:], step_length=np.linalg.norm(vec, axis=1), rest=rest,
                            standing=((t[0] + 0.3, t[0] + 0.4),), step_vector=vec)


@pytest.mark.parametrize("tun", [aided.AidTuning(gain_estimated=False, accel_jump=0.01),
                                 aided.AidTuning(step_heading="gyro", turn_sigma=0.05, rest_gyro_noise=1e-4)],
                         ids=["attitude, considered gain", "gyro heading, turns"])
def test_the_compiled_loop_gives_the_plain_loops_bits(jit, tun):
    # numba compiles without fast-math (no fused multiply-add, no reordering) and calls the same libm
    inp = _busy_input()
    plain = plain_kernels(K)
    # the strapdown's loops it calls are plain too, although the compiled pass put their compiled forms in place
    assert not any(hasattr(getattr(plain, f), "py_func") for f in ("rodrigues", "matmul3", "forward_member"))
    a = aided._kernel_args(inp, tun, 0.1, True, True)
    b = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in a.items()}
    e1 = jit["forward_member"](*a.values())
    e2 = plain.forward_member(*b.values())
    assert e1 == e2 == a["ep_k"].size
    assert np.all(a["nis"][:, 1] > 0), a["nis"]              # every kind of update ran
    for k in a:
        if isinstance(a[k], np.ndarray):
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_run_batch_members_do_not_share_state():
    # each member's pass starts from its own zeroed state: the same member twice, and beside another
    inp = _busy_input()
    tun = aided.AidTuning()
    other = replace(inp, f=inp.f * 1.01)
    r1, r2, r3 = aided.run_batch([inp, other, inp], [tun, tun, tun])
    np.testing.assert_array_equal(r1.position, r3.position)
    assert not np.array_equal(r1.position, r2.position)


def test_run_batch_on_threads_gives_one_threads_bits():
    # members differ (scaled inputs, two tunings, smoothing and innovations on some): the threads hand
    # back each member's own result, in order, with the bits of the one-thread run
    inp = _busy_input()
    tuns = [aided.AidTuning(), aided.AidTuning(step_heading="gyro", turn_sigma=0.05)]
    members = [replace(inp, f=inp.f * (1 + 0.002 * i)) for i in range(11)]
    tunings = [tuns[i % 2] for i in range(11)]
    flags = [i % 3 == 0 for i in range(11)]
    one = aided.run_batch(members, tunings, smooth=flags, innovations=flags, workers=1)
    many = aided.run_batch(members, tunings, smooth=flags, innovations=flags, workers=3)
    assert len(one) == len(many) == 11
    for a, b in zip(one, many):
        for name in ("time", "position", "P_xy", "bias_a", "bias_g"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        assert (a.smoothed is None) == (b.smoothed is None)
        if a.smoothed is not None:
            np.testing.assert_array_equal(a.smoothed, b.smoothed)
        assert a.nis == b.nis and a.gain_error == b.gain_error
        assert a.innovations.keys() == b.innovations.keys()
        for k in a.innovations:
            np.testing.assert_array_equal(a.innovations[k].y, b.innovations[k].y)
    assert len({r.position[-1, 0] for r in one}) == 11          # the members really differ
    for i in (0, 5, 10):                                        # and each result is its own member's
        (alone,) = aided.run_batch([members[i]], [tunings[i]], workers=1)
        np.testing.assert_array_equal(alone.position, many[i].position)


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_run_batch_refuses_a_worker_count_that_is_not_a_whole_positive_number(workers):
    with pytest.raises(aided.ParameterError, match="workers"):
        aided.run_batch([_busy_input()], aided.AidTuning(), workers=workers)


def _reference_smooth(hist_P, hist_rec, q_ba, q_bg, frozen, covariance):
    """filterpy's recursion (:func:`oracles.aided.rts_smooth`, tested against ``rts_smoother``) over a recorded
    history, with the transitions built densely and the predictions by :func:`oracles.aided.kf_predict`."""
    col = lambda name: hist_rec[:, aided._HIST[name][0]]                    # noqa: E731
    m = hist_P.shape[0]
    d = col("d")
    Phi = _dense_phi(d, col("fn"), col("Cm").reshape(-1, 3, 3))
    q = np.zeros((m, N))
    q[:, DV] = (col("qa") * d)[:, None]
    q[:, EPS] = (col("qg") * d)[:, None]
    q[:, BA] = (q_ba * d + col("jq"))[:, None]
    q[:, BG] = (q_bg * d)[:, None]
    q[:, aided.TURN] = col("tq")
    Q = np.zeros((m, N, N))
    Q[:, range(N), range(N)] = q
    x_post = col("x")
    x_prior, P_prior = np.zeros_like(x_post), hist_P.copy()
    x_prior[1:], P_prior[1:] = oracle.kf_predict(x_post[:-1], hist_P[:-1], Phi[1:], Q[1:])
    return oracle.rts_smooth(x_post, hist_P, x_prior, P_prior, Phi, fed=col("fed"), frozen=frozen,
                            covariance=covariance)


@pytest.mark.parametrize("covariance", [False, True])
@pytest.mark.parametrize("tun", [aided.AidTuning(), aided.AidTuning(gain_estimated=False, accel_jump=0.01),
                                 aided.AidTuning(step_heading="gyro", turn_sigma=0.05, steps=True)],
                         ids=["estimated gain", "considered gain", "gyro heading"])
def test_the_compiled_smoother_is_filterpys_recursion(jit, tun, covariance):
    a = aided._kernel_args(_busy_input(), tun, 0.1, True, False)
    jit["forward_member"](*a.values())
    m = a["ep_k"].size
    xs, Ps_xy = np.zeros((m, N)), np.zeros((m, 2, 2))
    jit["smooth_member"](a["hist_P"], a["hist_rec"], tun.accel_walk ** 2, tun.gyro_walk ** 2, a["fj"], covariance,
                         xs, Ps_xy)
    frozen = np.zeros(N, bool)
    frozen[aided.GAIN] = not tun.gain_estimated
    xr, Pr = _reference_smooth(a["hist_P"], a["hist_rec"], tun.accel_walk ** 2, tun.gyro_walk ** 2, frozen, covariance)
    # the same recursion in another order (the gain applied as P Phi^T u with Pq u = r, one epoch at a time,
    # against G formed for all epochs): per epoch a solve with the prior covariance Pq, rounding of eps times
    # its condition number (a median of 2e5 over this run's epochs; larger only along the clone copied from
    # the position at a step start, a direction the smoothed residual does not excite), carried back through
    # the m epochs: m * 2e5 * eps of the states' scale
    tol = m * 2e5 * EPS_F
    np.testing.assert_allclose(xs, xr, rtol=0, atol=tol * np.abs(xr).max())
    assert np.abs(xr[:, :2]).max() > 1e-3                 # the smoother moves the path
    if covariance:
        # the covariance recursion solves with the same Pq: the same bound, but this assertion keeps the
        # stricter 1e-9 of the covariance's scale it was written with (the bound, m * 2e5 * eps, is 7e-9 here)
        np.testing.assert_allclose(Ps_xy, Pr[:, :2, :2], rtol=0, atol=min(tol, 1e-9) * np.abs(Pr[:, :2, :2]).max())


def test_kernels_wrapped_once_when_threads_reach_them_together():
    # A fresh interpreter, so no kernel is wrapped yet: two threads per loops module (a study's chunks on threads
    # or Dask workers) ask for every loops module at once, those that call another module's loops (the aided
    # kernel, the steps' loops) among them; none may wrap a function another already wrapped, nor wait forever.
    import subprocess
    import sys

    code = (
        "import threading\n"
        "from morpi_filters import _aided_kernel, _calibration_loops, _strapdown_loops\n"
        "from morpi_filters.field import _loops as field_loops\n"
        "from morpi_filters.montecarlo import _batch_ins\n"
        "from morpi_filters.steps import _loops as steps_loops\n"
        "errors = []\n"
        "def call(mod):\n"
        "    try:\n"
        "        mod.compiled()\n"
        "    except Exception as exc:\n"
        "        errors.append(repr(exc))\n"
        "mods = (_aided_kernel, steps_loops, _strapdown_loops, _calibration_loops, field_loops, _batch_ins)\n"
        "threads = [threading.Thread(target=call, args=(m,)) for m in mods * 2]\n"
        "[t.start() for t in threads]\n"
        "[t.join() for t in threads]\n"
        "print(len(errors), errors[:1])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[0] == "0", out.stdout
