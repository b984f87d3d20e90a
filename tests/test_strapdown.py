"""Tests of the strapdown mechanizations (ins3d, ins2d).

Evidence: noise-free motions with closed-form kinematics (straight line, sine,
smooth 90 degree turn), closed-form drift of constant sensor biases, a fine-step
reference integration of a tumbling body, and per-run loops for batching.
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from morpi_filters import _strapdown_loops, units
from morpi_filters.errors import MorpiError
from morpi_filters.strapdown import coarse_level, heading_from_C, ins2d, ins3d, rotvec_to_C, yaw_to_C
from conftest import plain_kernels

G = units.G0
# The acceptance bar: noise-free INS end error under 1 mm after 15 s at 100 Hz.
END_TOL_M = 1e-3


def _uniform(T=15.0, dt=0.01, t0=2.5):
    return t0 + np.arange(int(round(T / dt)) + 1) * dt


def _irregular(T=15.0, seed=3, t0=7.1):
    # like the S6 files: dt from 0.0095 s to 0.023 s (dataset README)
    rng = np.random.default_rng(seed)
    dt = rng.uniform(0.0095, 0.023, int(T / 0.0095) + 10)
    t = t0 + np.concatenate([[0.0], np.cumsum(dt)])
    return t[t <= t0 + T]


def _smoother(x):
    x = np.clip(x, 0.0, 1.0)
    return x ** 3 * (10 - 15 * x + 6 * x * x), 30 * x * x * (1 - x) ** 2


def _speed_profile(tau, T, L):
    """Forward distance X, speed X', acceleration X'' of a rest-to-rest move of length L in T."""
    x = tau / T
    X = L * (x - np.sin(2 * np.pi * x) / (2 * np.pi))
    dX = L / T * (1 - np.cos(2 * np.pi * x))
    ddX = L / T ** 2 * 2 * np.pi * np.sin(2 * np.pi * x)
    return X, dX, ddX


def _imu_from_heading(psi, dpsi, V, dV):
    """Body readings when the body x axis follows the velocity: f = (V', V psi', g), w = (0, 0, psi')."""
    f = np.column_stack([dV, V * dpsi, np.full_like(V, G)])
    w = np.column_stack([np.zeros_like(V), np.zeros_like(V), dpsi])
    return f, w


def motion_straight(t, L=6.3):
    """Straight line with a smooth speed profile, from rest to rest (the test span is 15 s)."""
    X, dX, ddX = _speed_profile(t - t[0], t[-1] - t[0], L)
    f, w = _imu_from_heading(np.zeros_like(X), np.zeros_like(X), dX, ddX)
    return f, w, 0.0, np.array([X[-1], 0.0, 0.0])


def motion_sine(t, P=1.0, A=0.1, L=6.3):
    """y = A sin(2 pi x / P) along x, rest to rest; heading psi = atan(y'(x))."""
    k = 2 * np.pi / P
    X, dX, ddX = _speed_profile(t - t[0], t[-1] - t[0], L)
    slope = A * k * np.cos(k * X)
    psi = np.arctan(slope)
    dpsi = -A * k * k * np.sin(k * X) * dX / (1 + slope ** 2)
    V = dX * np.sqrt(1 + slope ** 2)
    dV = ddX * np.sqrt(1 + slope ** 2) + dX * slope * (-A * k * k * np.sin(k * X)) * dX / np.sqrt(1 + slope ** 2)
    f, w = _imu_from_heading(psi, dpsi, V, dV)
    return f, w, psi[0], np.array([X[-1], A * np.sin(k * X[-1]), 0.0])


def motion_turn(t, L=18.0, t_turn=6.0, T_turn=3.0, left=True):
    """Rest to rest; heading from 0 to +-90 deg in a smooth (C2) profile mid-way."""
    sgn = 1.0 if left else -1.0
    T = t[-1] - t[0]

    def kin(tau):
        S, dS = _smoother((tau - t_turn) / T_turn)
        X, dX, ddX = _speed_profile(tau, T, L)
        return sgn * np.pi / 2 * S, sgn * np.pi / 2 * dS / T_turn, dX, ddX

    psi, dpsi, V, dV = kin(t - t[0])
    f, w = _imu_from_heading(psi, dpsi, V, dV)
    opts = dict(points=[t_turn, t_turn + T_turn], epsabs=1e-13, epsrel=1e-13, limit=200)
    xe = quad(lambda s: kin(np.array(s))[2] * math.cos(kin(np.array(s))[0]), 0, T, **opts)[0]
    ye = quad(lambda s: kin(np.array(s))[2] * math.sin(kin(np.array(s))[0]), 0, T, **opts)[0]
    return f, w, 0.0, np.array([xe, ye, 0.0])


MOTIONS = {"straight": motion_straight, "sine": motion_sine, "turn": motion_turn,
           "sine_wide": lambda t: motion_sine(t, P=1.5, A=0.2, L=9.0),
           "turn_right": lambda t: motion_turn(t, left=False)}


@pytest.mark.parametrize("sampling", ["uniform", "irregular"])
@pytest.mark.parametrize("name", sorted(MOTIONS))
def test_noise_free_motion_recovered(name, sampling):
    t = _uniform() if sampling == "uniform" else _irregular()
    f, w, psi0, p_end = MOTIONS[name](t)
    r3 = ins3d(t, f, w, C0=yaw_to_C(psi0))
    r2 = ins2d(t, f, w, psi0=psi0)
    assert np.linalg.norm(r3.position[-1] - p_end) < END_TOL_M
    assert np.linalg.norm(r2.position[-1] - p_end) < END_TOL_M
    assert r3.position.shape == (len(t), 3) and r3.C_bn.shape == (len(t), 3, 3)
    assert r2.heading.shape == (len(t),)
    # both mechanizations see the same planar motion: heading agrees to rounding of the
    # integration (the 2D yaw is the 3D rotation angle about a fixed z axis, 1e-9 rad slack)
    np.testing.assert_allclose(r3.heading, r2.heading, atol=1e-9)


def test_accelerometer_bias_closed_form():
    t = _irregular(T=15.0)
    b = 0.05
    f = np.tile([b, 0.0, G], (len(t), 1))
    r = ins3d(t, f, np.zeros_like(f))
    tau = t - t[0]
    # the integration is exact for piecewise-linear acceleration: only rounding remains
    np.testing.assert_allclose(r.position[:, 0], 0.5 * b * tau ** 2, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.position[:, 1:], 0.0, atol=1e-9)
    r2 = ins2d(t, f, np.zeros_like(f))
    np.testing.assert_allclose(r2.position[:, 0], 0.5 * b * tau ** 2, rtol=1e-10, atol=1e-12)  # as for the 3D INS above: exact for piecewise-linear acceleration, only rounding


def test_gyro_bias_closed_form_z_up():
    """Level at rest, gyro bias b about body y (left).

    Derivation (z up): C_bn(t) = R_y(b t), so f^n = C f^b = (g sin(bt), 0, g cos(bt))
    and a^n = f^n + g^n = (g sin(bt), 0, g (cos(bt) - 1)). Hence exactly
    x(t) = g (t - sin(bt)/b) / b = +(1/6) g b t^3 - O(b^3 t^5).
    The sign is + in this z-up frame: a positive rate about the left axis tilts the
    body's z axis (the measured +g) towards +x. In the paper's z-down frame the same
    physics reads x = -(1/6) g b t^3.
    """
    t = _uniform(T=15.0)
    b = 1e-4                                                    # rad/s, small: b t = 1.5e-3 rad
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    w = np.tile([0.0, b, 0.0], (len(t), 1))
    r = ins3d(t, f, w)
    tau = t - t[0]
    exact = G * (tau - np.sin(b * tau) / b) / b
    # exact closed form: attitude increments are exact for a constant rate; the residual is
    # the dt^2 truncation of the translation rules, about dt^2/12 * |jerk| * t^2 = 1e-9 m here
    np.testing.assert_allclose(r.position[:, 0], exact, rtol=0, atol=1e-8)
    first_order = G * b * tau ** 3 / 6
    # first order: the neglected term is g b^3 t^5 / 120 = 6.2e-9 m at 15 s
    assert np.all(np.abs(r.position[:, 0] - first_order) <= 1e-8 + G * b ** 3 * tau ** 5 / 120)
    assert r.position[-1, 0] > 0.05                             # 0.55 m at 15 s, with the + sign


def test_attitude_matches_fine_reference():
    """A tumbling body (rate varying on all axes): the coning-corrected exponential
    update agrees with a 64x finer integration of C_dot = C [w x]."""
    def rate(t):
        return np.column_stack([0.8 * np.sin(2.1 * t), 0.5 * np.cos(1.3 * t + 0.4), 0.3 + 0.6 * np.sin(0.7 * t)])

    t = _irregular(T=10.0, seed=11, t0=0.0)
    w = rate(t)
    r = ins3d(t, np.tile([0.0, 0.0, G], (len(t), 1)), w)
    tf = np.linspace(t[0], t[-1], 64 * len(t))
    rf = ins3d(tf, np.tile([0.0, 0.0, G], (len(tf), 1)), rate(tf))
    dC = r.C_bn[-1].T @ rf.C_bn[-1]
    # third-order method, local error ~ dt^3 |w|^2 |w'| / 12 ~ 1e-7 rad per step, 700 steps,
    # well below 1e-4 rad; without the coning term the error is of order 1e-3 rad
    ang = np.arccos(np.clip((np.trace(dC) - 1) / 2, -1, 1))
    assert ang < 1e-4
    np.testing.assert_allclose(r.C_bn[-1] @ r.C_bn[-1].T, np.eye(3), atol=1e-12)  # orthogonality kept by the Rodrigues update: float rounding over the run


def test_batched_equals_per_run_loop():
    rng = np.random.default_rng(2)
    t = _irregular(T=4.0, seed=5)
    runs, n = 5, len(t)
    f = np.array([0.0, 0.0, G]) + 0.3 * rng.standard_normal((runs, n, 3))
    w = 0.2 * rng.standard_normal((runs, n, 3))
    C0 = rotvec_to_C(0.1 * rng.standard_normal((runs, 3)))
    v0 = rng.standard_normal((runs, 3))
    p0 = rng.standard_normal((runs, 3))
    psi0 = rng.standard_normal(runs)
    r3 = ins3d(t, f, w, C0=C0, v0=v0, p0=p0)
    r2 = ins2d(t, f, w, psi0=psi0, v0=v0, p0=p0)
    for i in range(runs):
        a = ins3d(t, f[i], w[i], C0=C0[i], v0=v0[i], p0=p0[i])
        b = ins2d(t, f[i], w[i], psi0=psi0[i], v0=v0[i], p0=p0[i])
        for fld in ("position", "velocity", "C_bn", "heading"):
            # same operations in the same order: equal to rounding
            np.testing.assert_allclose(getattr(r3, fld)[i], getattr(a, fld), rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(getattr(r2, fld)[i], getattr(b, fld), rtol=1e-12, atol=1e-12)
    assert r3.position.shape == (runs, n, 3) and r3.C_bn.shape == (runs, n, 3, 3)
    assert r2.heading.shape == (runs, n) and np.all(r2.position[..., 2] == 0)
    # unbatched signals with batched initial conditions broadcast to the runs axis
    rb = ins3d(t, f[0], w[0], v0=v0)
    assert rb.position.shape == (runs, n, 3)


def test_heading_is_continuous_through_full_turns():
    t = _uniform(T=10.0)
    w = np.tile([0.0, 0.0, 2.0], (len(t), 1))                  # 20 rad: more than three turns
    f = np.tile([0.0, 0.0, G], (len(t), 1))
    r3 = ins3d(t, f, w)
    r2 = ins2d(t, f, w)
    # constant rate: both integrate exactly (rounding only)
    np.testing.assert_allclose(r3.heading, 2.0 * (t - t[0]), atol=1e-10)
    np.testing.assert_allclose(r2.heading, 2.0 * (t - t[0]), atol=1e-10)


def test_heading_from_C():
    psi = np.array([0.0, 0.3, -2.0, 3.0])
    np.testing.assert_allclose(heading_from_C(yaw_to_C(psi)), psi, atol=1e-15)  # atan2 of the yaw matrix: one rounding


def test_rotvec_to_C_small_and_large_angles():
    from scipy.linalg import expm
    for phi in ([1e-9, -2e-9, 3e-9], [1e-5, 2e-5, -1e-5], [0.3, -1.2, 2.0]):
        phi = np.array(phi)
        K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
        # independent reference: the matrix exponential; 1e-14 is double-precision rounding
        np.testing.assert_allclose(rotvec_to_C(phi), expm(K), atol=1e-14)


@pytest.mark.parametrize("kwargs, word", [
    (dict(time=[0.0, 0.1, 0.1]), "time"),
    (dict(time=[0.0]), "time"),
    (dict(f=np.zeros((4, 2))), "f"),
    (dict(omega=np.full((3, 3), np.nan)), "omega"),
    (dict(C0=np.ones((3, 3))), "C0"),
    (dict(v0=np.zeros(2)), "v0"),
    (dict(f=np.zeros((2, 3, 3)), p0=np.zeros((4, 3))), "batch"),
])
def test_bad_input_raises(kwargs, word):
    args = dict(time=[0.0, 0.1, 0.2], f=np.zeros((3, 3)), omega=np.zeros((3, 3)))
    args.update(kwargs)
    with pytest.raises(MorpiError, match=word):
        ins3d(args.pop("time"), args.pop("f"), args.pop("omega"), **args)


def test_coarse_level_recovers_roll_and_pitch():
    # Any attitude with zero yaw is determined by the gravity direction it sees at rest.
    rng = np.random.default_rng(31)
    for _ in range(20):
        phi, theta = rng.uniform(-1.2, 1.2, 2)
        cp, sp, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
        C = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]]) @ np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
        f_rest = C.T @ np.array([0.0, 0.0, 9.8])
        # 1e-12: both sides are the same rotation up to rounding
        np.testing.assert_allclose(coarse_level(f_rest), C, atol=1e-12)
    with pytest.raises(MorpiError, match="f_rest"):
        coarse_level([0.0, 0.0, 0.0])


def test_start_on_a_slope_needs_the_measured_tilt():
    """The simulator's L route starting at rest on its 15 degree slope, noise-free IMU.

    Started from the tilt the rest specific force shows, the INS follows the true path (the
    noise-free bar, 1 mm); assuming a level phone and removing the rest reading minus gravity as
    accelerometer bias (the paper's GAC) turns g sin(15 deg) into a false acceleration once the
    slope ends, hundreds of metres over the route.
    """
    from morpi_filters import simulate, units

    traj = simulate.l_route(slope_deg=15.0)
    rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(1), bias_scale=0.0,
                       noise_scale=0.0).recording(0)
    f_rest = rec.f[rec.time < rec.time[0] + 2.0].mean(axis=0)
    leveled = ins3d(rec.time, rec.f, rec.omega, C0=coarse_level(f_rest), g=np.linalg.norm(f_rest))
    assert np.linalg.norm(leveled.position[-1] - traj.position[-1]) < 1e-3  # the simulator's acceptance bar (1 mm), as in test_simulate
    g = np.linalg.norm(f_rest)
    level = ins3d(rec.time, rec.f - (f_rest - [0.0, 0.0, g]), rec.omega, g=g)
    assert np.linalg.norm(level.position[-1] - traj.position[-1]) > 100.0


def test_attitude_product_is_the_step_by_step_product_and_a_run_does_not_depend_on_its_batch():
    """Each run multiplies its attitude increments in a compiled loop. Against numpy's step-by-step product
    (rotvec_to_C and matmul) the same products summed in another order, and numpy's sine and cosine: equal to
    rounding (1e-12 over 3000 steps of an irregular, tumbling motion). A run alone and the same run in a
    batch (with another run beside it) give the same bits."""
    from morpi_filters.strapdown import _increments, rotvec_to_C

    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.005, 0.02, 2999)])
    w = np.stack([np.sin(t), 0.5 * np.cos(2 * t), 0.3 + 0.2 * np.sin(3 * t)], axis=1) + 0.05 * rng.normal(size=(t.size, 3))
    f = np.tile([0.1, -0.2, 9.8], (t.size, 1)) + 0.1 * rng.normal(size=(t.size, 3))
    C0 = coarse_level([0.3, -0.2, 9.8])
    one = ins3d(t, f, w, C0=C0)
    # numpy's product of the same increments (the interval integral and the coning term)
    phi = _increments(t, w[None])[0][0]
    dt = np.diff(t)
    phi += np.cross(w[:-1], w[1:]) * (dt ** 2 / 12.0)[:, None]
    ref = np.empty((t.size, 3, 3))
    ref[0] = C0
    for k, E in enumerate(rotvec_to_C(phi)):
        ref[k + 1] = ref[k] @ E
    np.testing.assert_allclose(one.C_bn, ref, rtol=0, atol=1e-12)
    w2 = w[::-1].copy()
    two = ins3d(t, np.stack([f, f[::-1]]), np.stack([w, w2]), C0=np.stack([C0, np.eye(3)]))
    np.testing.assert_array_equal(two.C_bn[0], one.C_bn)
    np.testing.assert_array_equal(two.position[0], one.position)
    np.testing.assert_array_equal(two.C_bn[1], ins3d(t, f[::-1], w2).C_bn)
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", one.C_bn, one.C_bn), np.broadcast_to(np.eye(3), one.C_bn.shape),
                               atol=1e-12)


def _numpy_increments(time, x):
    # the interval integrals written with numpy: 3-point non-uniform slopes, one-sided at both ends
    n = time.shape[0]
    d = np.empty_like(x)
    if n == 2:
        d[:] = ((x[:, 1] - x[:, 0]) / (time[1] - time[0]))[:, None]
    else:
        h = np.diff(time)
        h1, h2 = h[:-1], h[1:]
        shape = (1, n - 2) + (1,) * (x.ndim - 2)
        c0 = (-h2 / (h1 * (h1 + h2))).reshape(shape)
        c1 = ((h2 - h1) / (h1 * h2)).reshape(shape)
        c2 = (h1 / (h2 * (h1 + h2))).reshape(shape)
        d[:, 1:-1] = c0 * x[:, :-2] + c1 * x[:, 1:-1] + c2 * x[:, 2:]
        a, b = h[0], h[1]
        d[:, 0] = -(2 * a + b) / (a * (a + b)) * x[:, 0] + (a + b) / (a * b) * x[:, 1] - a / (b * (a + b)) * x[:, 2]
        a, b = h[-2], h[-1]
        d[:, -1] = b / (a * (a + b)) * x[:, -3] - (a + b) / (a * b) * x[:, -2] + (a + 2 * b) / (b * (a + b)) * x[:, -1]
    dt = np.diff(time).reshape((1, -1) + (1,) * (x.ndim - 2))
    return 0.5 * (x[:, :-1] + x[:, 1:]) * dt + (d[:, :-1] - d[:, 1:]) * (dt * dt / 12.0), d


@pytest.mark.parametrize("size", [0.0, 1e-6, 1e-4, 0.3, 3.0])
def test_rodrigues_is_rotvec_to_C(size):
    rng = np.random.default_rng(11)
    for phi in rng.normal(size=(20, 3)) * size:
        out = np.zeros((3, 3))
        _strapdown_loops.compiled()["rodrigues"](phi[0], phi[1], phi[2], out)
        # the same formula in another order of rounding: a few units of 1e-16
        np.testing.assert_allclose(out, rotvec_to_C(phi), rtol=0, atol=1e-15)


def test_the_attitude_chain_is_the_running_product_of_rotvec_to_C():
    # a tumbling run: large and tiny increments (both branches of Rodrigues' formula)
    rng = np.random.default_rng(12)
    phi = rng.normal(size=(400, 3)) * np.repeat([0.3, 1e-5], 200)[:, None]
    C0 = rotvec_to_C(rng.normal(size=3))
    out = np.empty((401, 3, 3))
    _strapdown_loops.compiled()["attitude_chain"](phi, C0, out)
    ref = [C0]
    for E in rotvec_to_C(phi):
        ref.append(ref[-1] @ E)
    # the numpy product in another order of rounding: 400 steps of a few units of 1e-16
    np.testing.assert_allclose(out, np.array(ref), rtol=0, atol=1e-13)
    plain = np.empty_like(out)
    plain_kernels(_strapdown_loops).attitude_chain(phi, C0, plain)
    np.testing.assert_array_equal(out, plain)


def test_coning_term_is_the_numpy_elementwise_form_exactly():
    # exact: the term is elementwise products and differences, each one correctly rounded operation in the
    # same order on both sides; no sum whose order numpy chooses
    plain = plain_kernels(_strapdown_loops)
    rng = np.random.default_rng(44)
    for n, B in ((2, 1), (300, 1), (300, 3)):
        time = np.cumsum(rng.uniform(0.003, 0.02, n))
        w = rng.normal(size=(B, n, 3))
        phi = 1e-5 * rng.normal(size=(B, n - 1, 3))                # the size of the term: its bits show
        dt = np.diff(time)[None, :]
        c = dt * dt / 12.0
        w0, w1 = w[:, :-1], w[:, 1:]
        want = phi.copy()
        want[..., 0] += (w0[..., 1] * w1[..., 2] - w0[..., 2] * w1[..., 1]) * c
        want[..., 1] += (w0[..., 2] * w1[..., 0] - w0[..., 0] * w1[..., 2]) * c
        want[..., 2] += (w0[..., 0] * w1[..., 1] - w0[..., 1] * w1[..., 0]) * c
        for f in (_strapdown_loops.compiled()["coning"], plain.coning):
            got = phi.copy()
            f(time, w, got)
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("n", [2, 3, 500])
def test_translation_is_the_numpy_sums_within_the_rounding_of_the_running_sums(n):
    # the loop and numpy's cumsum add the same increments, each within Higham's bound of the exact running
    # sums (oracles.sums.prefix_bound, v0 and p0 among the terms: either may be added first); a velocity's
    # error enters the position increments times dt, each increment's products round a few times
    from morpi_filters.strapdown import _integrate_translation
    from oracles.sums import U, assert_within, prefix_bound

    rng = np.random.default_rng(43)
    time = 1.0 + np.cumsum(rng.uniform(0.003, 0.02, n))
    for B in (1, 2):
        a, v0, p0 = rng.normal(size=(B, n, 3)), rng.normal(size=(B, 3)), rng.normal(size=(B, 3))
        # the numpy form: running sums of the Hermite velocity and position increments
        dt = np.diff(time)[None, :, None]
        dv, d = _numpy_increments(time, a)
        v = np.concatenate([v0[:, None], np.cumsum(dv, axis=1) + v0[:, None]], axis=1)
        dp = v[:, :-1] * dt
        dp += (7.0 * a[:, :-1] + 3.0 * a[:, 1:]) * (dt * dt / 20.0)
        dp += (3.0 * d[:, :-1] - 2.0 * d[:, 1:]) * (dt ** 3 / 60.0)
        p = np.concatenate([p0[:, None], np.cumsum(dp, axis=1) + p0[:, None]], axis=1)
        dv_bound = prefix_bound(np.concatenate([v0[:, None], dv], axis=1), axis=1)[:, 1:]
        terms = (np.abs(v[:, :-1] * dt) + np.abs((7.0 * a[:, :-1] + 3.0 * a[:, 1:]) * (dt * dt / 20.0))
                 + np.abs((3.0 * d[:, :-1] - 2.0 * d[:, 1:]) * (dt ** 3 / 60.0)))
        dp_bound = dv_bound[:, :-1] * dt * (1.0 + 2.0 * U) + 16.0 * U * terms
        p_bound = (prefix_bound(np.concatenate([p0[:, None], dp], axis=1), axis=1)[:, 1:]
                   + np.concatenate([np.zeros((B, 1, 3)), np.cumsum(dp_bound, axis=1)], axis=1))
        got_v, got_p = _integrate_translation(time, a, v0, p0)
        assert_within(got_v, v, dv_bound, "velocity")
        assert_within(got_p, p, p_bound, "position")
    # the compiled loop gives the plain Python loop's bits: the same loop, the same operations in the same order
    plain = plain_kernels(_strapdown_loops)
    pv, pp = np.empty(a.shape), np.empty(a.shape)
    dv, d = _numpy_increments(time, a)
    plain.translation(np.diff(time), a, d, dv, np.diff(time) ** 3 / 60.0, v0, p0, pv, pp)
    np.testing.assert_array_equal(pv, got_v)
    np.testing.assert_array_equal(pp, got_p)


@pytest.mark.parametrize("n", [2, 3, 4, 500])
def test_increments_are_the_numpy_form_and_the_running_integral_its_sums_within_rounding(n):
    from morpi_filters.steps.prepare import running_integral as _running_integral
    from morpi_filters.strapdown import _increments
    from oracles.sums import assert_within, prefix_bound

    rng = np.random.default_rng(41)
    time = 3.0 + np.cumsum(rng.uniform(0.003, 0.02, n))           # irregular steps
    for shape in ((1, n), (4, n), (1, n, 3), (2, n, 3)):
        x = rng.normal(size=shape)
        inc, d = _increments(time, x)
        ref_inc, ref_d = _numpy_increments(time, x)
        assert inc.shape == ref_inc.shape and d.shape == ref_d.shape
        # exact: slopes and increments are elementwise expressions of neighbouring samples, the same correctly
        # rounded operations in the same order on both sides (no sum whose order numpy chooses)
        np.testing.assert_array_equal(inc, ref_inc)
        np.testing.assert_array_equal(d, ref_d)
    # exact on a quadratic (its 3-point slopes are exact and the Hermite rule integrates cubics); the
    # difference of the antiderivative (values up to about 200) carries about 1e-14 of rounding
    x = (1.0 + 2.0 * time - 0.5 * time ** 2)[None]
    if n >= 3:
        exact = (time + time ** 2 - time ** 3 / 6.0)
        np.testing.assert_allclose(_increments(time, x)[0][0], np.diff(exact), rtol=1e-12, atol=1e-12)
    # the running integral adds the trapezoids in order, numpy's cumsum in its own: Higham's bound of the
    # running sums (the trapezoids themselves are elementwise, the same on both sides)
    psi = rng.normal(size=n)
    trapezoids = 0.5 * (psi[1:] + psi[:-1]) * np.diff(time)
    assert_within(_running_integral(time, psi), np.concatenate([[0.0], np.cumsum(trapezoids)]), prefix_bound(trapezoids),
                  "running integral")
    # the compiled loops give the plain Python loops' bits: the same loops, the same operations in the same order
    plain = plain_kernels(_strapdown_loops)
    x = rng.normal(size=(2, n, 3))
    inc, d = np.empty((2, n - 1, 3)), np.empty((2, n, 3))
    plain.increments(time, x, inc, d)
    np.testing.assert_array_equal(inc, _increments(time, x)[0])
    np.testing.assert_array_equal(d, _increments(time, x)[1])


def test_time_checks_name_what_is_wrong():
    from morpi_filters.strapdown import integrate_rate

    good = np.arange(6.0)
    assert integrate_rate(good[::2], np.ones(3))[-1] == pytest.approx(4.0)           # a strided view
    for bad, what in (([0.0, np.nan, 2.0], "NaN or inf"), ([0.0, 1.0, np.inf], "NaN or inf"),
                      ([0.0, 2.0, 1.0], "not strictly increasing"), ([0.0, 1.0, 1.0], "not strictly increasing"),
                      ([0.0, 2.0, 1.0, np.nan], "NaN or inf"), ([1.0], "at least 2 samples")):
        with pytest.raises(MorpiError, match=what):
            integrate_rate(bad, np.ones(len(bad)))
