"""The MoRPI-aided filter: the reference forms' Jacobians and Kalman core (``tests/oracles/aided.py``) against
finite differences and filterpy, simulated routes with known truth."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from oracles import aided as oracle

from morpi_filters import aided, simulate, units
from morpi_filters.errors import MorpiError, ParameterError


def _nominal(rng, b=3):
    from scipy.spatial.transform import Rotation

    C = Rotation.from_rotvec(rng.normal(size=(b, 3)) * 0.5).as_matrix()
    return oracle.Nominal(C=C, v=rng.normal(size=(b, 3)), p=rng.normal(size=(b, 3)), clone=rng.normal(size=(b, 2)))


def _fd_jacobian(meas, x, nom, h=1e-6):
    b, n = x.shape
    m = meas.h(x, nom).shape[1]
    J = np.zeros((b, m, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        J[:, :, j] = (meas.h(x + e, nom) - meas.h(x - e, nom)) / (2 * h)
    return J


@pytest.mark.parametrize("kind", ["step", "step (attitude heading)", "zero velocity", "zero rate", "non-holonomic"])
def test_jacobians_match_finite_differences(kind):
    rng = np.random.default_rng(1)
    nom = _nominal(rng)
    x = np.zeros((3, aided.N_AIDED))
    # the filter linearizes at the fed-back error state; the gain error and the clone stay states
    x[:, aided.GAIN] = 0.03
    x[:, aided.CLONE] = rng.normal(size=(3, 2)) * 0.01
    x[:, aided.TURN] = [0.05, -0.02, 0.1]                  # the reading's heading error is not fed back
    s = np.full(3, 0.1)
    meas = {"step": oracle.StepDisplacement(z=np.zeros((3, 2)), sigma=s),
            "step (attitude heading)": oracle.StepDisplacement(z=np.zeros((3, 2)), sigma=s,
                                                              attitude=np.array([True, False, True])),
            "zero velocity": oracle.ZeroVelocity(sigma=s),
            "zero rate": oracle.ZeroRate(z=np.zeros((3, 3)), sigma=s),
            "non-holonomic": oracle.NonHolonomic(M=_nominal(rng).C, sigma=s)}[kind]
    # central differences with h = 1e-6 on smooth functions of order 1: truncation ~h^2, rounding ~1e-16/h
    np.testing.assert_allclose(meas.H(x, nom), _fd_jacobian(meas, x, nom), atol=1e-8)


def test_predict_and_update_are_filterpys():
    from filterpy.kalman import KalmanFilter

    rng = np.random.default_rng(2)
    b, n, m = 4, 6, 2
    A = rng.normal(size=(b, n, n))
    P = A @ np.swapaxes(A, 1, 2) + np.eye(n)
    Phi = np.eye(n) + 0.1 * rng.normal(size=(b, n, n))
    Bq = rng.normal(size=(b, n, n)) * 0.1
    Q = Bq @ np.swapaxes(Bq, 1, 2)
    H = rng.normal(size=(b, m, n))
    R = np.broadcast_to(np.diag([0.3, 0.5]), (b, m, m)).copy()
    x = rng.normal(size=(b, n))
    z = rng.normal(size=(b, m))
    x1, P1 = oracle.kf_predict(x, P, Phi, Q)
    x2, P2, _ = oracle.kf_update(x1, P1, z - np.einsum("bij,bj->bi", H, x1), H, R)
    for j in range(b):
        kf = KalmanFilter(dim_x=n, dim_z=m)
        kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = x[j].copy(), P[j].copy(), Phi[j], Q[j], H[j], R[j]
        kf.predict()
        kf.update(z[j])
        # the same algebra (filterpy's Joseph form), evaluated in another order: rounding only
        np.testing.assert_allclose(x2[j], kf.x, atol=1e-9)
        np.testing.assert_allclose(P2[j], kf.P, atol=1e-9)


def test_smoother_is_filterpys_rts():
    from filterpy.kalman import KalmanFilter

    rng = np.random.default_rng(3)
    n, k = 4, 40
    Phi = np.eye(n) + 0.05 * rng.normal(size=(n, n))
    Q = np.eye(n) * 0.01
    kf = KalmanFilter(dim_x=n, dim_z=2)
    kf.x, kf.P, kf.F, kf.Q = np.zeros(n), np.eye(n), Phi, Q
    kf.H, kf.R = rng.normal(size=(2, n)), np.eye(2) * 0.2
    xs, Ps, xp, Pp = kf.batch_filter(rng.normal(size=(k, 2)))
    ref_x, ref_P, _, _ = kf.rts_smoother(xs, Ps)
    sx, sP = oracle.rts_smooth(xs, Ps, xp, Pp, np.broadcast_to(Phi, (k, n, n)))
    # the same recursion, the gains formed in another order: 40 epochs of values of order 1 whose
    # covariances' condition numbers stay below 1e3, about 40 * 1e3 * eps = 1e-11; 1e-9 holds with room
    np.testing.assert_allclose(sx, ref_x, atol=1e-9)
    np.testing.assert_allclose(sP, ref_P, atol=1e-9)


def _rest(traj):
    # the trajectory stands still before and after the motion (its exact speed is zero there)
    still = np.linalg.norm(traj.velocity, axis=1) < 1e-9
    t = traj.time
    i0 = int(np.argmin(still))
    i1 = t.size - int(np.argmin(still[::-1]))
    return ((t[0], t[i0 - 1]), (t[i1], t[-1]))


def _exact_input(traj, *, vectors=False, scale=1.0, f=None, omega=None, interior=False):
    """Steps between period boundaries with the exact chord lengths (times `scale`).

    With `interior`, only the periods of the cruise: there the mean heading of
    a sine period points along its chord (by symmetry), which is what the
    filter's attitude reading of the step direction assumes; in the speed
    ramps it does not.
    """
    t, pos = traj.time, traj.position
    pt = np.asarray(traj.period_times)
    if interior:
        pt = pt[1:-1]
    # boundaries on samples, as the filter places them
    pt = t[np.clip(np.searchsorted(t, pt), 0, t.size - 1)]
    a, b = pt[:-1], pt[1:]
    pa = np.array([np.interp(a, t, pos[:, j]) for j in range(2)]).T
    pb = np.array([np.interp(b, t, pos[:, j]) for j in range(2)]).T
    d = (pb - pa) * scale
    return aided.AidedInput(time=t, f=traj.f_b if f is None else f, omega=traj.omega_b if omega is None else omega,
                            C0=traj.C_bn[0], g=units.G0, step_start=a, step_end=b,
                            step_length=np.linalg.norm(d, axis=1), rest=_rest(traj),
                            step_vector=d if vectors else None)


@pytest.mark.parametrize("route,heading", [("sine", "gyro"), ("L", "gyro"), ("sine", "attitude")])
def test_noise_free_routes_within_1cm(route, heading):
    if route == "sine":
        traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    else:
        traj = simulate.l_route(p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    inp = _exact_input(traj, vectors=heading == "gyro", interior=heading == "attitude")
    tun = aided.AidTuning(accel_noise=1e-4, gyro_noise=1e-5, step_sigma=0.01, gain_sigma=0.0, nhc=False,
                          step_heading=heading)
    (r,) = aided.run_batch([inp], tun, smooth=True)
    truth = np.array([np.interp(r.time, traj.time, traj.position[:, j]) for j in range(2)]).T
    # the bar: the true path within 1 cm, forward and smoothed
    assert np.abs(r.position[:, :2] - truth).max() < 0.01
    assert np.abs(r.smoothed[:, :2] - truth).max() < 0.01
    # the smoother's last estimate is the forward filter's
    np.testing.assert_allclose(r.smoothed[-1], r.position[-1], atol=1e-9)



def test_a_misread_turn_is_taken_from_the_inertial_heading():
    """Step directions that read the L's turn 3 degrees short: the turn state takes the INS's heading.

    Noise-free inertial data, exact step lengths, and step directions after
    the turn off by 0.05 rad (the route's heading reading a turn wrong).
    Without the turn state the filter follows the steps' wrong heading;
    with it (3 % of the turn, 1 sigma) the exact attitude corrects the
    direction, and the true end point lies inside the claimed ellipse.
    """
    from dataclasses import replace

    traj = simulate.l_route(p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    inp = _exact_input(traj, vectors=True)
    v = inp.step_vector
    psi = np.arctan2(v[:, 1], v[:, 0])
    after = np.abs(np.angle(np.exp(1j * (psi - psi[0])))) > np.radians(45.0)
    assert 0 < after.sum() < after.size
    e = -0.05
    rot = np.array([[np.cos(e), -np.sin(e)], [np.sin(e), np.cos(e)]])
    wrong = replace(inp, step_vector=np.where(after[:, None], v @ rot.T, v))
    tun = aided.AidTuning(accel_noise=1e-3, gyro_noise=1e-5, step_sigma=0.01, gain_sigma=0.0, nhc=False,
                          step_heading="gyro")
    out = aided.run_batch([wrong, wrong], [tun, tun.with_(turn_sigma=0.03)])
    t_end = inp.step_end[-1]
    true = np.array([np.interp(t_end, traj.time, traj.position[:, j]) for j in range(2)])
    err = [np.linalg.norm(r.position[r.index_at(t_end), :2] - true) for r in out]
    # the misread turn swings the second leg by 0.05 rad; the turn state takes most of it back
    leg = np.linalg.norm(v[after].sum(axis=0))
    assert err[0] > 0.8 * abs(e) * leg and err[1] < 0.25 * err[0], (err, leg)
    r = out[1]
    j = r.index_at(t_end)
    d = r.position[j, :2] - true
    assert d @ np.linalg.solve(r.P_xy[j], d) < 13.8                # chi-square 2 dof, 99.9 %


def test_batched_members_equal_single_runs():
    traj = simulate.sine(4.0, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    inp = _exact_input(traj)
    short = _exact_input(simulate.sine(2.5, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0))
    tuns = [aided.AidTuning(step_sigma=0.02), aided.AidTuning(step_sigma=0.05, nhc=False)]
    both = aided.run_batch([inp, short], tuns)
    # the shorter member first: the batch runs its members longest first and returns them in order
    swapped = aided.run_batch([short, inp], tuns[::-1])
    for one, member, other, tun in zip((inp, short), both, swapped[::-1], tuns):
        (alone,) = aided.run_batch([one], tun)
        # padding and batching change no arithmetic of a member: identical up to summation order
        np.testing.assert_allclose(member.position, alone.position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(other.position, alone.position, rtol=0, atol=1e-12)
        assert other.time.size == alone.time.size


def test_kept_innovations_are_the_updates_the_nis_sums():
    """Every update's innovation and covariance, kept for the flagged members only.

    Step vectors 10 % long (a gain error the filter takes as exact) make
    the step innovations non-zero. Their normalized squares, recomputed here
    with a solve, add up to the filter's own NIS sums; the step updates fall
    on the step ends and measure the given vectors; keeping them changes no
    estimate, and a member not flagged keeps none.
    """
    from dataclasses import replace

    traj = simulate.sine(4.0, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    inp = _exact_input(traj, vectors=True)
    inp = replace(inp, step_vector=1.1 * inp.step_vector)
    short = _exact_input(simulate.sine(2.5, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0), vectors=True)
    tun = aided.AidTuning(step_sigma=0.02, gain_sigma=0.0, step_heading="gyro")
    kept, plain = aided.run_batch([short, inp], tun, innovations=[False, True])
    # the same batch without them: the same arithmetic, so the same estimates to the bit
    short_off, off = aided.run_batch([short, inp], tun)
    assert kept.innovations == {} and off.innovations == {}
    np.testing.assert_array_equal(plain.position, off.position)
    np.testing.assert_array_equal(kept.position, short_off.position)
    assert set(plain.innovations) == set(plain.nis) == {"step", "zero velocity", "zero rate", "non-holonomic"}
    for name, inn in plain.innovations.items():
        total, count, dof = plain.nis[name]
        assert inn.y.shape == inn.z.shape == (count, dof) and inn.S.shape == (count, dof, dof)
        assert np.all(np.diff(inn.time) >= 0)
        nis = np.einsum("ui,ui->u", inn.y, np.linalg.solve(inn.S, inn.y[:, :, None])[:, :, 0])
        # the filter inverts S, this solves with it: rounding only (measured 1e-16 to 2.4e-16 relative);
        # 1e-9 leaves room for other BLAS builds and is far below a missed or doubled update
        assert nis.sum() == pytest.approx(total, rel=1e-9)
    step = plain.innovations["step"]
    np.testing.assert_array_equal(step.time, inp.step_end)
    np.testing.assert_allclose(step.z, inp.step_vector, rtol=0, atol=1e-15)
    along, cross, sigma = aided.step_innovation_components(step)
    # the steps measure 10 % more than the robot travels: the noise-free INS falls short of the first by
    # exactly that (up to its integration error), and of every later one (each update speeds it up)
    length = np.linalg.norm(step.z, axis=1) / 1.1
    assert along[0] == pytest.approx(0.1 * length[0], abs=1e-3) and abs(cross[0]) < 1e-3
    assert np.all(along > 0) and np.all(sigma > 0)
    with pytest.raises(ParameterError, match="innovations must be"):
        aided.run_batch([inp], tun, innovations=[True, False])
    # the along/across reading is for 2-D steps: the zero-rate updates (3-D) are refused by name
    with pytest.raises(ParameterError, match="expected 2-D step innovations"):
        aided.step_innovation_components(plain.innovations["zero rate"])


def test_smoothed_members_of_a_batch_equal_single_runs_with_or_without_the_covariance():
    inp = _exact_input(simulate.sine(4.0, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0))
    short = _exact_input(simulate.sine(2.5, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0))
    ins = [inp, short, inp]
    tuns = [aided.AidTuning(step_sigma=0.02), aided.AidTuning(step_sigma=0.05, nhc=False), aided.AidTuning()]
    flags = [True, True, False]
    full = aided.run_batch(ins, tuns, smooth=flags)
    lean = aided.run_batch(ins, tuns, smooth=flags, smoothed_covariance=False, nis=False)
    # the innovation statistics are only read out: without them, every estimate is the same
    assert all(r.nis for r in full) and not any(r.nis for r in lean)
    for a, b in zip(full, lean):
        np.testing.assert_array_equal(a.position, b.position)
        np.testing.assert_array_equal(a.P_xy, b.P_xy)
    assert full[2].smoothed is None and lean[2].smoothed is None
    for i in (0, 1):
        (alone,) = aided.run_batch([ins[i]], tuns[i], smooth=True)
        # each member's epoch history is its own: as smoothed alone (up to summation order)
        np.testing.assert_allclose(full[i].smoothed, alone.smoothed, rtol=0, atol=1e-12)
        np.testing.assert_allclose(full[i].P_xy_smoothed, alone.P_xy_smoothed, rtol=0,
                                   atol=1e-12 * np.abs(alone.P_xy_smoothed).max())
        # the state recursion does not read the smoothed covariance
        np.testing.assert_array_equal(lean[i].smoothed, full[i].smoothed)
        assert lean[i].P_xy_smoothed is None


def test_simulated_biases_and_gain_error_recovered_within_3_sigma():
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    spec = units.LSM6DSL
    k_true = 0.05
    z = []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        d = simulate.imu(traj, spec, rng, bias_scale=(0.05, 0.05))
        inp = _exact_input(traj, scale=1.0 + k_true, f=d.f, omega=d.omega)
        tun = aided.AidTuning(accel_noise=spec.accel_noise, gyro_noise=spec.gyro_noise, step_sigma=0.01,
                              gain_sigma=0.1, ba0=0.05 * spec.accel_bias * 3, bg0=0.05 * spec.gyro_bias * 3)
        (r,) = aided.run_batch([inp], tun)
        z.append((r.gain_error - k_true) / r.gain_sigma)
        # the rest updates see the gyro bias directly
        bg_err = (r.bias_g - d.gyro_bias) / r.bias_g_sigma
        assert np.all(np.abs(bg_err) < 3), bg_err
    assert np.all(np.abs(z) < 3), z


def test_bad_inputs_are_refused():
    from morpi_filters.errors import MorpiError

    with pytest.raises(MorpiError, match="increase"):
        aided.AidedInput(time=np.array([0.0, 0.0, 1.0]), f=np.zeros((3, 3)), omega=np.zeros((3, 3)),
                         C0=np.eye(3), g=9.8)
    with pytest.raises(MorpiError, match="step_sigma"):
        aided.AidTuning(step_sigma=0.0)
    with pytest.raises(MorpiError, match="step_heading"):
        aided.AidTuning(step_heading="compass")
    with pytest.raises(MorpiError, match="nan"):
        aided.AidTuning(accel_noise=float("nan"))
    # a batch names its member by the caller's index, whatever order it runs them in
    t = np.arange(301) * 0.01
    still = aided.AidedInput(time=t, f=np.tile([0.0, 0.0, 9.8], (301, 1)), omega=np.zeros((301, 3)), C0=np.eye(3),
                             g=9.8, step_start=np.array([0.5]), step_end=np.array([1.5]), step_length=np.array([0.1]))
    shorter = aided.AidedInput(time=t[:200], f=still.f[:200], omega=still.omega[:200], C0=np.eye(3), g=9.8)
    with pytest.raises(MorpiError, match="member 1: step_heading='gyro'"):
        aided.run_batch([shorter, still], [aided.AidTuning(), aided.AidTuning(step_heading="gyro")])
    with pytest.raises(MorpiError, match="smooth must be"):
        aided.run_batch([shorter, still], aided.AidTuning(), smooth=[True, False, True])


def test_paired_difference_is_scipys_paired_t_test():
    from scipy import stats

    from morpi_filters.field_aided import paired_difference

    rng = np.random.default_rng(5)
    ref = rng.uniform(0.2, 1.5, 12)
    for shift, verdict in ((-0.4, "better"), (0.4, "worse"), (0.0, "tie")):
        err = ref + shift + rng.normal(0.0, 0.1, 12)
        err[3] = np.nan                                          # a failed run leaves its pair out
        ok = np.isfinite(err)
        d = paired_difference(err, ref, 40.0)
        t = stats.ttest_rel(err[ok], ref[ok])
        assert d.runs == 11
        assert d.mean_pp == pytest.approx(np.mean(err[ok] - ref[ok]) / 40.0 * 100, rel=1e-12)
        assert d.mean_pp / d.se_pp == pytest.approx(t.statistic, rel=1e-9)
        assert d.p_value == pytest.approx(t.pvalue, rel=1e-9)
        assert d.verdict == verdict, (shift, d)
    # the level decides: the same runs are a tie at a stricter level
    err = ref - 0.05 + rng.normal(0.0, 0.05, 12)
    d = paired_difference(err, ref, 40.0)
    assert d.p_value < 0.05 and d.verdict == "better"
    assert paired_difference(err, ref, 40.0, alpha=d.p_value / 2).verdict == "tie"
    assert paired_difference([1.0], [2.0], 40.0).verdict == "tie"   # one run tells nothing
    for bad, match in ((dict(errors_m=[1.0, 2.0], reference_m=[1.0]), "shapes"),
                       (dict(errors_m=[1.0], reference_m=[1.0], distance_m=0.0), "distance_m"),
                       (dict(errors_m=[1.0], reference_m=[1.0], alpha=1.0), "alpha")):
        with pytest.raises(MorpiError, match=match):
            paired_difference(**{"distance_m": 40.0, **bad})


def test_holm_step_down_matches_a_hand_worked_example():
    from morpi_filters.field_aided import holm

    # sorted: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03, 0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> raised to 0.06 (monotone)
    adj, rej = holm([0.01, 0.04, 0.03, 0.005])
    np.testing.assert_allclose(adj, [0.03, 0.06, 0.06, 0.02], rtol=1e-12)
    assert rej.tolist() == [True, False, False, True]
    # a cell without a test (NaN) is no member of the family: m = 2; products above 1 are capped
    adj, rej = holm([0.01, np.nan, 0.04])
    np.testing.assert_allclose(adj, [0.02, np.nan, 0.04], rtol=1e-12)
    assert rej.tolist() == [True, False, True]
    adj, rej = holm([0.6, 0.7])
    assert adj.tolist() == [1.0, 1.0] and not rej.any()
    # the family-wise level decides the rejections, not the adjusted values
    assert holm([0.01, 0.04, 0.03, 0.005], alpha=0.025)[1].tolist() == [False, False, False, True]
    with pytest.raises(MorpiError, match="p-values"):
        holm([0.5, 1.5])
    # a family of cells: wins before and after the correction (0.003 x 3 = 0.009; 0.03 x 2 = 0.06; 0.2)
    from types import SimpleNamespace

    from morpi_filters.field_aided import PairedDifference
    from morpi_filters.field_aided.study import _family

    cells = [SimpleNamespace(paired=PairedDifference(m, 0.1, 10, p)) for m, p in
             ((-0.5, 0.03), (-0.9, 0.003), (0.2, 0.2))] + [SimpleNamespace(paired=None)]
    pairs, summary = _family(cells, "paired")
    assert [None if d is None else round(d.p_holm, 12) for d in pairs] == [0.06, 0.009, 0.2, None]
    assert summary == {"cells": 3, "wins_uncorrected": 2, "wins_corrected": 1, "losses_uncorrected": 0,
                       "losses_corrected": 0, "ties_corrected": 2}


def test_detectable_difference_is_detected_at_the_stated_power():
    """At the returned difference, the paired t-test of ``runs`` normal differences rejects 80 % of the time."""
    from scipy import stats

    from morpi_filters.field_aided import detectable_difference, paired_difference

    rng = np.random.default_rng(21)
    sd, runs, sims = 0.3, 10, 20000
    delta = detectable_difference(sd, runs)
    d = rng.normal(delta, sd, (sims, runs))
    rate = np.mean(stats.ttest_1samp(d, 0.0, axis=1).pvalue < 0.05)
    # binomial standard error sqrt(0.8 x 0.2 / 20000) = 0.0028: four of them
    assert abs(rate - 0.8) < 0.0113, (delta, rate)
    # the normal approximation (z_0.975 + z_0.8) sd / sqrt(n) detects less often at ten runs ...
    z = (stats.norm.ppf(0.975) + stats.norm.ppf(0.8)) * sd / np.sqrt(runs)
    assert np.mean(stats.ttest_1samp(rng.normal(z, sd, (sims, runs)), 0.0, axis=1).pvalue < 0.05) < 0.78
    # ... and is its limit for many runs
    assert detectable_difference(sd, 4000) == pytest.approx(z * np.sqrt(runs / 4000), rel=2e-3)
    assert np.isnan(detectable_difference(sd, 1)) and detectable_difference(0.0, 5) == 0.0
    # a paired difference states it for its own runs and spread [pp]
    ref = rng.uniform(0.5, 1.5, 12)
    err = ref - 0.1 + rng.normal(0.0, 0.2, 12)
    pd = paired_difference(err, ref, 40.0)
    sd_pp = np.std((err - ref) / 40.0 * 100, ddof=1)
    assert pd.mdd_pp == pytest.approx(detectable_difference(sd_pp, 12), rel=1e-9)
    # outside a family there is no Holm verdict
    assert np.isnan(pd.p_holm) and pd.verdict_holm == "tie"


@pytest.mark.parametrize("runs", [2, 3])
def test_detectable_difference_of_two_or_three_runs_is_detected_at_the_stated_power(runs):
    """Two or three paired runs (a small cell): the returned difference is finite and detected 80 % of the
    time, as with ten; the root search passes through shifts where the lower tail is negligible."""
    from scipy import stats

    from morpi_filters.field_aided import detectable_difference

    rng = np.random.default_rng(22)
    sd, sims = 1.0, 20000
    delta = detectable_difference(sd, runs)
    assert np.isfinite(delta) and delta > detectable_difference(sd, 4)
    rate = np.mean(stats.ttest_1samp(rng.normal(delta, sd, (sims, runs)), 0.0, axis=1).pvalue < 0.05)
    assert abs(rate - 0.8) < 0.0113, (delta, rate)      # four binomial standard errors, as above


def test_steps_alone_is_where_the_filter_goes_on_its_steps_alone():
    """The filter's step vectors summed: what a filter that gives its INS no weight reaches.

    A phone that reads no motion, a loose INS (the accelerometer noise of a shaken phone) and exact,
    tight steps, one after the other from a rest that pins the start: each update hands the position to
    the step. Two more steps the
    filter does not use, their vectors far away: one without length, one that starts and ends on one
    sample.
    """
    from morpi_filters.field_aided import steps_alone

    t = np.arange(0.0, 6.0, 0.01)
    vec = np.array([[0.5, 0.0], [0.4, 0.3], [7.0, 7.0], [0.0, 0.5], [-5.0, 3.0], [0.2, -0.1], [0.3, 0.3]])
    length = np.linalg.norm(vec, axis=1)
    length[2] = np.nan
    start = np.array([0.5, 1.3, 1.5, 2.1, 2.9, 2.9, 3.7])
    end = np.array([1.3, 2.1, 1.9, 2.9, 2.902, 3.7, 4.5])
    inp = aided.AidedInput(time=t, f=np.tile([0.0, 0.0, units.G0], (t.size, 1)), omega=np.zeros((t.size, 3)),
                           C0=np.eye(3), g=units.G0, step_start=start, step_end=end, step_length=length,
                           step_vector=vec, rest=((0.0, 0.5),))
    want = np.zeros(2)
    for k in range(len(vec)):
        if np.isfinite(length[k]) and end[k] - start[k] >= 0.01:         # at least one sample (100 Hz)
            want = want + vec[k]
    np.testing.assert_allclose(steps_alone(inp), want, rtol=0, atol=1e-15)
    tun = aided.AidTuning(accel_noise=30.0, gyro_noise=1e-4, rest_accel_noise=1e-3, step_sigma=1e-4,
                          gain_sigma=0.0, nhc=False, step_heading="gyro")
    (r,) = aided.run_batch([inp], tun)
    end = r.position[r.index_at(end[-1]), :2]
    # within a millimetre of the step sum (measured: 1e-7 m; the dropped steps' vectors are metres away)
    assert np.linalg.norm(end - want) < 1e-3, (end, want)
    assert np.all(np.isnan(steps_alone(aided.AidedInput(time=t, f=inp.f, omega=inp.omega, C0=np.eye(3), g=9.8))))


def test_ellipse_coverage_counts_the_end_points_inside_their_regions():
    """End points drawn from their own covariances: the direct count of each region, near 95 % each."""
    from scipy import stats

    from morpi_filters.field_aided import ellipse_coverage

    rng = np.random.default_rng(8)
    n = 4000
    A = rng.normal(size=(n, 2, 2))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(2)
    e = np.einsum("nij,nj->ni", np.linalg.cholesky(P), rng.normal(size=(n, 2)))
    along = np.array([3.0, 4.0])
    cov = ellipse_coverage(e, P, along)
    u = along / 5.0
    c = np.array([-u[1], u[0]])
    inside = axis_u = axis_c = 0
    k2 = stats.chi2.ppf(0.95, 2)
    z = stats.norm.ppf(0.975)
    for ei, Pi in zip(e, P):
        inside += ei @ np.linalg.inv(Pi) @ ei <= k2
        axis_u += abs(ei @ u) <= z * np.sqrt(u @ Pi @ u)
        axis_c += abs(ei @ c) <= z * np.sqrt(c @ Pi @ c)
    assert cov["runs"] == n
    assert (cov["inside_95"], cov["along_95"], cov["cross_95"]) == (inside / n, axis_u / n, axis_c / n)
    # the right covariance holds 95 % (binomial standard error 0.0034: four of them); a wrong one does not
    for share in (cov["inside_95"], cov["along_95"], cov["cross_95"]):
        assert abs(share - 0.95) < 0.014, cov
    assert ellipse_coverage(e, 0.5 * P, along)["inside_95"] < 0.85
    with pytest.raises(MorpiError, match="along"):
        ellipse_coverage(e, P, [0.0, 0.0])


def test_nis_band_is_the_chi_square_of_the_cells_updates():
    """The band per degree of freedom holds 95 % of the mean NIS of a consistent filter's updates."""
    from scipy import stats

    from morpi_filters.field_aided import nis_consistency

    updates, dof = 150, 2
    q = nis_consistency(300.0, updates, dof)
    assert q["per_dof"] == 1.0 and q["updates"] == updates
    lo, hi = (stats.chi2.ppf(p, updates * dof) / (updates * dof) for p in (0.025, 0.975))
    np.testing.assert_allclose(q["band"], [lo, hi], rtol=1e-12)
    # consistent innovations: y ~ N(0, S), NIS = y^T S^-1 y chi-square with dof each
    rng = np.random.default_rng(4)
    sums = (rng.normal(size=(20000, updates, dof)) ** 2).sum(axis=(1, 2))
    per_dof = sums / (updates * dof)
    assert abs(np.mean((per_dof >= q["band"][0]) & (per_dof <= q["band"][1])) - 0.95) < 0.006
    assert np.isnan(nis_consistency(0.0, 0, 2)["per_dof"])


def test_an_aid_the_filter_does_not_use_has_exactly_zero_effect():
    """Not run: its row is the full filter's, in both read-outs; a used aid must have been run."""
    from morpi_filters.field_aided import ABLATIONS, aid_used
    from morpi_filters.field_aided.ablation import ablation_row

    considered = aided.AidTuning(nhc=False, gain_estimated=False, gain_sigma=0.05)
    assert [n for n in ABLATIONS if not aid_used(n, considered)] == ["non-holonomic", "gain state"]
    assert aid_used("gain state", considered.with_(gain_estimated=True))
    assert not aid_used("gain state", considered.with_(gain_estimated=True, gain_sigma=0.0))
    full = (5.213, 5.198)                      # smoothed and forward differ: each column keeps its own
    for name in ("non-holonomic", "gain state"):
        row = ablation_row("cell", name, aid_used(name, considered), full)
        assert row["used"] is False
        assert row["smoothed_percent"] - row["full_percent"] == 0.0
        assert row["forward_percent"] - row["full_forward_percent"] == 0.0
    # without smoothing both read-outs are the forward filter's
    row = ablation_row("cell", "smoothing", True, full)
    assert (row["smoothed_percent"], row["forward_percent"]) == (full[1], full[1])
    with pytest.raises(MorpiError, match="used but was not run"):
        ablation_row("cell", "steps", True, full)
    with pytest.raises(MorpiError, match="expected one of"):
        aid_used("compass", considered)


def _innovation_nis(rng, scale, runs, updates, dof):
    """NIS sums of `updates` innovations per run drawn with `scale` times the covariance the filter states:
    the NIS per dof of such a filter is `scale` in expectation (chi-square, ``updates * dof`` degrees per run)."""
    y = rng.normal(0.0, np.sqrt(scale), (runs, updates, dof))
    return (y ** 2).sum(axis=(1, 2)), np.full(runs, updates)


def _grid_case(rng, scales, coverage, runs=12, updates=40, dof=(2, 3)):
    """Candidates with the true innovation-to-stated variance ratio `scales[c][k]` per measurement type k and
    `coverage[c]` of the runs' end points inside their ellipse."""
    c, k = len(scales), len(dof)
    nis, count = np.zeros((c, runs, k)), np.zeros((c, runs, k), int)
    for i in range(c):
        for j in range(k):
            nis[i, :, j], count[i, :, j] = _innovation_nis(rng, scales[i][j], runs, updates, dof[j])
    inside = np.array([np.arange(runs) < round(cov * runs) for cov in coverage])
    return inside, nis, count, np.array(dof)


def test_the_consistent_point_is_chosen_over_a_less_erring_inconsistent_one():
    """Drawn innovations: the least-error candidate expects them 30 times wider than they come (a step dead
    reckoning), the second 6 times narrower, the third's ellipse misses a third of the end points; the fourth
    (the right spread, a larger error) is the only consistent one and is chosen, in every leave-one-out fold."""
    from morpi_filters.field_aided import MIN_TRAIN_COVERAGE, NIS_BAND, choose_consistent
    from morpi_filters.field_aided.tuning import _nis_per_dof

    rng = np.random.default_rng(11)
    scales = [(1 / 30, 1.0), (6.0, 1.0), (1.0, 1.0), (1.0, 0.8)]
    inside, nis, count, dof = _grid_case(rng, scales, coverage=(1.0, 1.0, 0.67, 1.0))
    err = np.array([2.0, 2.5, 2.2, 3.0])[:, None] + rng.normal(0.0, 0.05, (4, 12))
    per_dof = _nis_per_dof(nis, count, dof)
    assert per_dof[0, 0] < NIS_BAND[0] and per_dof[1, 0] > NIS_BAND[1]            # the draws show the spread
    assert np.all((per_dof[2:] > NIS_BAND[0]) & (per_dof[2:] < NIS_BAND[1]))
    assert inside[2].mean() < MIN_TRAIN_COVERAGE <= inside[3].mean()
    assert int(np.argmin(err.mean(axis=1))) == 0                                     # least error: inconsistent
    assert choose_consistent(err, inside, nis, count, dof) == (3, True)
    for i in range(12):
        f = np.arange(12) != i
        assert choose_consistent(err[:, f], inside[:, f], nis[:, f], count[:, f], dof) == (3, True)
    # a type without updates (the non-holonomic updates off) is not judged; with them, too loose, it is
    count[3, :, 1] = 0
    assert choose_consistent(err, inside, nis, count, dof) == (3, True)
    count[3, :, 1], nis[3, :, 1] = 40, nis[3, :, 1] / 100
    assert choose_consistent(err, inside, nis, count, dof)[1] is False


def test_without_a_consistent_point_the_least_inconsistent_wins_on_its_error():
    """No candidate consistent: those whose ellipse holds enough end points, then the fewest measurement types
    outside the band, then the least error; the verdict says it is a fallback."""
    from morpi_filters.field_aided import choose_consistent

    rng = np.random.default_rng(12)
    #            two types out      one type out     one type out      coverage short, none out
    scales = [(1 / 30, 1 / 30), (1 / 30, 1.0), (1.0, 1 / 30), (1.0, 1.0)]
    inside, nis, count, dof = _grid_case(rng, scales, coverage=(1.0, 1.0, 1.0, 0.5))
    err = np.array([[1.0] * 12, [2.0] * 12, [1.5] * 12, [0.5] * 12])
    assert choose_consistent(err, inside, nis, count, dof) == (2, False)
    # every ellipse short of the coverage: the types decide among all, the consistent-NIS one wins
    assert choose_consistent(err, np.zeros_like(inside), nis, count, dof) == (3, False)
    # among equally inconsistent candidates the tie-tolerant choice keeps the earliest of equal errors
    err[1] = err[2]
    assert choose_consistent(err, inside, nis, count, dof) == (1, False)


def test_an_aid_stays_when_it_makes_the_filter_less_inconsistent():
    """The second stage ranks by consistency first: a less inconsistent filter keeps (or drops) the
    non-holonomic updates whatever the errors; at the same rank the one-standard-error rule decides; an
    estimated gain never makes the filter less consistent."""
    from morpi_filters.field_aided.tuning import _aid_pays, _estimate_wins

    worse, better = np.full(10, 3.0), np.full(10, 2.0) + np.linspace(-0.01, 0.01, 10)
    assert _aid_pays(worse, (0, 0), better, (0, 1))          # only with the aid is the filter consistent
    assert not _aid_pays(better, (0, 1), worse, (0, 0))      # only without it
    assert _aid_pays(better, (0, 0), worse, (0, 0)) and not _aid_pays(worse, (0, 0), better, (0, 0))
    k = np.array([0.04, -0.02, 0.03, 0.05, -0.03, 0.02, 0.01, -0.04, 0.03, 0.02])
    assert _estimate_wins(worse, (0, 0), better, (0, 0), k, k)
    assert not _estimate_wins(worse, (0, 0), better, (0, 1), k, k)
    assert not _estimate_wins(worse, (0, 1), better, (1, 0), k, k)


def test_a_filter_started_later_knows_nothing_before():
    """Started at the motion onset, a rest window before it does not hold the filter: the INS drifts freely."""
    t = np.arange(0.0, 4.0, 0.01)
    f = np.tile([0.05, 0.0, units.G0], (t.size, 1))       # an accelerometer offset the rest updates would see
    inp = aided.AidedInput(time=t, f=f, omega=np.zeros((t.size, 3)), C0=np.eye(3), g=units.G0,
                           rest=((0.0, 2.0),), standing=((2.0, 2.5),))
    late = inp.since(2.5)
    assert late.time[0] == pytest.approx(2.5) and late.rest == () and late.standing == ((t[250], 2.5),)
    tun = aided.AidTuning(accel_noise=1e-3, nhc=False)
    whole, started = aided.run_batch([inp, late], tun)
    # started at 2.5 s it integrates 1.5 s of the offset: 0.05 x 1.5^2 / 2 m (up to the filter's own bias
    # estimate on the standing sample, ~0); the whole run's rest updates have learnt the offset
    assert started.end_point[0] == pytest.approx(0.05 * 1.5 ** 2 / 2, rel=0.05)
    assert abs(whole.end_point[0]) < 0.2 * started.end_point[0]


# --------------------------------------------------------------------------- field

@pytest.mark.field
def test_field_cell_json_contract_and_consistency(field_root, monkeypatch):
    from scipy import stats

    from morpi_filters import field_aided
    from morpi_filters.evaluate import evaluate_tables
    from morpi_filters.field_aided import aided_study, prepare
    from morpi_filters.report.aided import study_json

    # a cell whose train runs choose the route's heading (its steps alone are then defined)
    label = "short_route s8 1 m MoRPI-A GC"
    res = evaluate_tables(field_root, alternatives=False, ins=False)
    # with the RD cell of the same runs and method beside it: the study's coverage and NIS count each
    # (run, method) once, over the GC cells
    batches = []
    real = aided.run_batch

    def counting(inputs, tunings, **kw):
        batches.append((list(tunings), kw))
        return real(inputs, tunings, **kw)

    monkeypatch.setattr(aided, "run_batch", counting)
    study = aided_study(result=res, labels={label, label.replace("GC", "RD")})
    monkeypatch.setattr(aided, "run_batch", real)
    c = next(c for c in study.cells if c.label == label)
    assert len(study.cells) == 2
    assert c.label == label and len(c.runs) == 11  # s8/short_distance/test holds 11 runs
    # the steps tie the INS down: from hundreds of % (INS alone) to MoRPI's level (within x2)
    assert c.forward_percent < 0.05 * c.ins_percent
    assert c.forward_percent < 2 * c.morpi_percent
    payload = study_json(study)
    assert {"cells", "ablation", "coverage_95", "tunables", "coverage_95_forward", "significance"} <= set(payload)
    cell = next(x for x in payload["cells"] if x["label"] == label)
    assert {"table", "phone", "p2p_m", "method", "calibration", "paper_percent", "morpi_percent",
            "forward_percent", "smoothed_percent", "runs", "steps_alone_percent", "nis", "coverage_95",
            "coverage_95_forward"} <= set(cell)
    assert {a["removed"] for a in payload["ablation"]} == {"steps", "non-holonomic", "rest updates",
                                                          "gain state", "smoothing"}
    assert all(set(a) == {"cell", "removed", "smoothed_percent", "forward_percent", "used", "full_percent",
                          "full_forward_percent", "start"} for a in payload["ablation"])
    assert 0.0 <= payload["coverage_95"] <= 1.0
    # smoothed minus MoRPI alone, paired over the runs: its mean is the difference of the cell's means
    pair = cell["smoothed_vs_morpi"]
    assert pair["runs"] == len(c.runs) and pair["verdict"] in ("better", "worse", "tie")
    assert pair["mean_pp"] == pytest.approx(c.smoothed_percent - c.morpi_percent, abs=1e-9)
    # a family of one cell: Holm leaves its p-value as it is
    assert pair["p_holm"] == pytest.approx(pair["p_value"], rel=1e-12) and payload["significance"]["cells"] == 1
    # the step updates' innovations, up to the read-out: at least one step per run, an RMS that bounds the mean
    inn = cell["step_innovation"]
    assert inn["updates"] >= len(c.runs) and inn["predicted_along_sigma_m"] > 0
    assert inn["along_rms_m"] >= abs(inn["along_mean_m"]) and inn["cross_rms_m"] >= abs(inn["cross_mean_m"])
    # the figures' paths end where the end points are read: their last points are the rows' end points
    from morpi_filters.dataset import route

    truth = route(c.spec.route)
    end = truth.end_point_m
    for (_, fwd, sm, _, P), row in zip(c.paths, c.runs):
        assert np.linalg.norm(fwd[-1] - end) == pytest.approx(row["forward_m"], abs=1e-9)
        assert np.linalg.norm(sm[-1] - end) == pytest.approx(row["smoothed_m"], abs=1e-9)
        assert len(P) == len(fwd)

    # recomputed from the prepared recordings: the step vectors the filter is fed, summed by a plain loop;
    # the filter rerun with the cell's tunables, its NIS from the kept innovations and its coverage by count
    g = next(g for g in res.gains if (g.phone, g.route, g.method, g.calibration) == ("s8", "short_distance",
                                                                                  "MoRPI-A", "GC"))
    config = res.selections["MoRPI-A"].config
    preps = [prepare(res.data, rec, "GC", "MoRPI-A", config, g.mean)
             for rec in res.data.recordings("s8", "short_distance", "test")]
    preps = sorted(preps, key=lambda p: [r["file"] for r in c.runs].index(p.rel))
    alone = []
    for p in preps:
        inp = p.input_for(c.tuning)
        v = np.asarray(inp.step_vector)
        xy = np.zeros(2)
        for k in range(v.shape[0]):
            xy = xy + v[k]
        alone.append(np.linalg.norm(xy - end))
    assert c.tuning["step_heading"] == "route"
    assert cell["steps_alone_percent"] == pytest.approx(np.mean(alone) / truth.distance_m * 100, rel=1e-9)
    # MoRPI alone under its best train-chosen reading: with the Weinberg length and the route's heading, the
    # same step vectors summed (a second path to the same numbers); with the rule's own, MoRPI alone as the
    # tables have it
    best = [r["morpi_best_m"] for r in c.runs]
    if cell["morpi_length"] == "period count":
        assert best == [r["period_count_m"] for r in c.runs]
    elif cell["morpi_reading"] == "route":
        assert best == pytest.approx(alone, rel=1e-9)
    else:
        assert cell["morpi_reading"] == config.heading and best == [r["morpi_m"] for r in c.runs]
    assert cell["smoothed_vs_morpi_best"]["mean_pp"] == pytest.approx(c.smoothed_percent - c.morpi_best_percent,
                                                                      abs=1e-9)
    assert payload["significance"]["vs_morpi_best"]["cells"] == 1
    t = c.tuning
    tun = field_aided.tuning_from((t["rest_accel_noise"], t["gyro_noise"] / t["vibration"], t["rest_gyro_noise"],
                               t["gyro_walk"], t["accel_jump"]), t, t["gain_sigma"])
    out = aided.run_batch([p.input_for(t) for p in preps], tun, smooth=True, innovations=True)
    # the tunables' train verdict: the same filter rerun on the train runs up to the read-out, its NIS per
    # dof by type and its ellipse coverage, against the band and the least coverage
    tc = cell["train_consistency"]
    trains = field_aided.inputs.prepared_runs(res.data, "s8", "short_distance", "train", "GC", "MoRPI-A", config,
                                              g.mean)
    got = aided.run_batch([p.input_for(t, forward_only=True) for p in trains], tun)
    assert set(tc["nis"]) == set().union(*(r.nis for r in got))
    for kind, q in tc["nis"].items():
        total, n = sum(r.nis[kind][0] for r in got), sum(r.nis[kind][1] for r in got)
        assert q["updates"] == n and q["per_dof"] == pytest.approx(total / n / q["dof"], rel=1e-9)
    ends = [p.end(r) for p, r in zip(trains, got)]
    held = np.mean([(xy - end) @ np.linalg.solve(P, xy - end) <= stats.chi2.ppf(0.95, 2) for xy, P, _ in ends])
    assert tc["coverage_95"] == pytest.approx(held, abs=1e-12)
    lo, hi = field_aided.NIS_BAND
    assert tc["consistent"] == (held >= field_aided.MIN_TRAIN_COVERAGE
                                and all(lo <= q["per_dof"] <= hi for q in tc["nis"].values()))
    assert tc["outside"] == sorted(k for k, q in tc["nis"].items() if not lo <= q["per_dof"] <= hi)
    inside = inside_fw = 0
    for p, r, row in zip(preps, out, c.runs):
        j = r.index_at(p.stop_s)
        assert np.linalg.norm(r.smoothed[j, :2] - end) == pytest.approx(row["smoothed_m"], abs=1e-9)
        e, ef = r.smoothed[j, :2] - end, r.position[j, :2] - end
        m2, m2f = e @ np.linalg.inv(r.P_xy_smoothed[j]) @ e, ef @ np.linalg.inv(r.P_xy[j]) @ ef
        # each estimate under its own covariance (close here: the read-out is at the last step update, where
        # only the final rest's updates, when a run has them, reach the smoother)
        assert row["mahalanobis2_smoothed"] == pytest.approx(m2, rel=1e-9)
        assert row["mahalanobis2"] == pytest.approx(m2f, rel=1e-9)
        inside += m2 <= stats.chi2.ppf(0.95, 2)
        inside_fw += m2f <= stats.chi2.ppf(0.95, 2)
    assert (cell["coverage_95"], cell["coverage_95_forward"]) == (inside / len(preps), inside_fw / len(preps))
    assert payload["coverage"]["smoothed"]["runs"] == len(preps)
    assert payload["coverage_95"] == cell["coverage_95"]
    assert payload["coverage_95_forward"] == cell["coverage_95_forward"]
    for kind, q in cell["nis"].items():
        total = count = 0
        for r in out:
            y, S = r.innovations[kind].y, r.innovations[kind].S
            total += np.einsum("ui,ui->", y, np.linalg.solve(S, y[:, :, None])[:, :, 0])
            count += y.shape[0]
        dof = y.shape[1]
        assert q["updates"] == count and q["dof"] == dof
        assert q["per_dof"] == pytest.approx(total / count / dof, rel=1e-9)
        lo, hi = (stats.chi2.ppf(p, count * dof) / (count * dof) for p in (0.025, 0.975))
        assert q["band"] == pytest.approx([lo, hi], rel=1e-12)
    # the ablation: an aid not used is not run and changes nothing, in either read-out; both read-outs of the
    # used ones are compared with the same read-outs
    rows = {a["removed"]: a for a in payload["ablation"]}
    for name, a in rows.items():
        assert a["used"] == field_aided.aid_used(name, tun)
        if not a["used"]:
            assert (a["smoothed_percent"], a["forward_percent"]) == (a["full_percent"], a["full_forward_percent"])
    assert rows["smoothing"]["smoothed_percent"] == rows["smoothing"]["forward_percent"] == c.forward_percent
    assert rows["steps"]["full_percent"] == c.smoothed_percent and rows["steps"]["used"]
    assert rows["rest updates"]["start"] == "motion onset"
    # the rest updates' row: the filter started at the motion onset, with and without them
    late = [p.input_for(t).since(p.onset_s) for p in preps]
    assert all(li.time[0] <= p.onset_s < li.time[1] and all(a > p.onset_s for a, _ in li.rest)
               for li, p in zip(late, preps))
    for key, tuning in (("full", tun), ("smoothed", tun.with_(rest=False))):
        got = aided.run_batch(late, tuning, smooth=True)
        err = [np.linalg.norm(r.smoothed[r.index_at(p.stop_s), :2] - end) for p, r in zip(preps, got)]
        assert rows["rest updates"][f"{key}_percent"] == pytest.approx(np.mean(err) / truth.distance_m * 100,
                                                                       rel=1e-9)
    # one ablation batch: per run the steps removed, and the rest updates with and without from the onset;
    # the aids the filter does not use are not run
    (ablated,) = [b for b, kw in batches if kw.get("smooth") is True and not kw.get("innovations")]
    assert sorted(ablated, key=repr) == sorted([tun.with_(steps=False), tun, tun.with_(rest=False)] * len(c.runs),
                                               key=repr)


@pytest.mark.field
def test_tunables_do_not_see_the_test_folders(field_root):
    """The same tunables with every test folder hidden (train runs only)."""
    from morpi_filters.evaluate import evaluate_tables
    from morpi_filters.field_aided import choose_tunables

    picks = []
    for include_test in (True, False):
        res = evaluate_tables(field_root, include_test=include_test, alternatives=False)
        g = next(g for g in res.gains if (g.phone, g.route, g.method, g.calibration)
                 == ("s6", "short_distance", "MoRPI-G", "GC"))
        picks.append(choose_tunables(res.data, ("s6", "short_distance"), "MoRPI-G", "GC",
                                     res.selections["MoRPI-G"].config, g))
    assert picks[0] == picks[1]


def test_still_spans_keep_quiet_stretches_and_refuse_motion_and_slow_turns():
    from morpi_filters.field_aided import still_spans

    rng = np.random.default_rng(7)
    t = np.arange(0.0, 30.0, 0.01)
    w = rng.normal(0.0, 1e-3, (t.size, 3)) + np.array([2e-3, -1e-3, 5e-4])   # white noise on a bias
    moving = (t >= 5) & (t < 15)
    w[moving] += rng.normal(0.0, 0.3, (moving.sum(), 3))                       # the robot drives
    turn = (t >= 18) & (t < 21)
    w[turn, 2] += 0.05                                                         # a slow, quiet turn
    handled = (t >= 25) & (t < 26)
    w[handled] += rng.normal(0.0, 0.5, (handled.sum(), 3))                     # the phone is picked up
    spans = still_spans(t, w, (5.0, 15.0), (0, 300))
    inside = lambda a, b: any(s0 <= a and b <= s1 for s0, s1 in spans)  # noqa: E731
    # the quiet stretches are found (up to the 0.5 s window at their edges) ...
    assert inside(0.5, 4.4) and inside(15.6, 17.4) and inside(21.6, 24.4) and inside(26.6, 29.4)
    # ... and nothing of the motion, the slow turn or the handling is called still
    for s0, s1 in spans:
        for a, b in ((5, 15), (18, 21), (25, 26)):
            assert s1 <= a or s0 >= b, (s0, s1)


@pytest.mark.field
def test_tunables_and_gains_ignore_corrupted_test_recordings(field_root, tmp_path):
    """Every test recording corrupted (gyro sign flipped, f_y scaled): the same gains and tunables."""
    from dataclasses import replace

    from morpi_filters import dataset as ds
    from morpi_filters.evaluate import evaluate_tables
    from morpi_filters.field_aided import choose_tunables

    root = tmp_path / "corrupted"
    for e in ds.catalogue(field_root):
        dest = root / e.relpath
        dest.parent.mkdir(parents=True, exist_ok=True)
        if e.split == "test":
            rec = e.load()
            f = rec.f.copy()
            f[:, 1] *= 1.5
            ds.write_csv(dest, replace(rec, f=f, omega=-rec.omega))
        else:
            dest.symlink_to(e.path)
    picks = []
    for r in (field_root, root):
        res = evaluate_tables(r, alternatives=False)
        gains = {(g.phone, g.route, g.method, g.calibration): (g.mean, g.std) for g in res.gains}
        chosen = [choose_tunables(res.data, ("s8", "short_distance"), m, cal, res.selections[m].config,
                                  next(g for g in res.gains if (g.phone, g.route, g.method, g.calibration)
                                       == ("s8", "short_distance", m, cal)))
                  for m, cal in (("MoRPI-G", "GC"), ("MoRPI-A", "RD"))]
        picks.append((gains, chosen))
    assert picks[0] == picks[1]


def test_accelerometer_step_under_way_is_absorbed_when_modelled():
    """A specific-force offset while moving (the phone tilts on its mount): the bias-step model follows it."""
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    r0, r1 = _rest(traj)
    moving = (traj.time > r0[1]) & (traj.time < r1[0])
    f = traj.f_b.copy()
    f[moving, 0] += 0.25                        # the size seen on the field runs while cruising
    inp = _exact_input(traj, f=f)
    base = aided.AidTuning(accel_noise=1e-3, gyro_noise=1e-5, step_sigma=0.02, gain_sigma=0.0, nhc=False)
    out = []
    for tun in (base, base.with_(accel_jump=0.3)):
        (r,) = aided.run_batch([inp], tun)
        j = r.index_at(inp.step_end[-1])
        true = np.array([np.interp(inp.step_end[-1], traj.time, traj.position[:, k]) for k in range(2)])
        s, c, dof = r.nis["step"]
        out.append((np.linalg.norm(r.position[j, :2] - true), s / c / dof))
    (e0, nis0), (e1, nis1) = out
    # at the last step the modelled offset leaves a fraction of the error
    assert e1 < 0.5 * e0, out
    # and the step innovations agree with their covariance (NIS per dof near 1, far above it without)
    assert nis1 < 3.0 < nis0, out


def test_the_filter_is_read_at_the_step_boundary_epoch():
    """A step boundary is an epoch of its own; reading there gives the updated position, not the one before."""
    traj = simulate.sine(4.0, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    inp = _exact_input(traj)
    (r,) = aided.run_batch([inp], aided.AidTuning(step_sigma=0.01, gain_sigma=0.0))
    for te in inp.step_end:
        j = r.index_at(te)
        # the nearest sample to the boundary (100 Hz: within 5 ms)
        assert abs(r.time[j] - te) <= 0.005 + 1e-12


def test_considered_gain_is_the_exact_gain_filter_with_the_gain_spread_in_its_covariance():
    """Consider analysis: the estimate of the filter that takes the gain as exact; the covariance adds
    sigma_k^2 s s^T, with the sensitivity s of that estimate to the step scale (finite differences)."""
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    rng = np.random.default_rng(11)
    d = simulate.imu(traj, units.LSM6DSL, rng, bias_scale=(0.05, 0.05))
    inp = _exact_input(traj, f=d.f, omega=d.omega)
    sk = 0.04
    base = aided.AidTuning(accel_noise=0.05, gyro_noise=1e-3, step_sigma=0.02, gain_sigma=0.0)
    (exact,) = aided.run_batch([inp], base, smooth=True)
    (cons,) = aided.run_batch([inp], base.with_(gain_sigma=sk, gain_estimated=False), smooth=True)
    (est,) = aided.run_batch([inp], base.with_(gain_sigma=sk), smooth=True)
    # the estimate, forward and smoothed, is the exact-gain filter's (a separate code path: no gain state)
    np.testing.assert_allclose(cons.position, exact.position, atol=1e-9)
    np.testing.assert_allclose(cons.smoothed, exact.smoothed, atol=1e-9)
    assert cons.gain_error == 0.0 and cons.gain_sigma == pytest.approx(sk)
    # an estimated gain moves the estimate: the two modes differ
    assert np.abs(est.position - exact.position).max() > 1e-4
    # along the route the gain's spread dominates: the end's along-track sigma is about sk x distance
    assert np.sqrt(cons.P_xy[-1, 0, 0]) > 0.8 * sk * 6.3 > np.sqrt(exact.P_xy[-1, 0, 0])

    # covariance: the exact-gain filter's own plus the gain's spread along the sensitivity of its estimate.
    # On the exact IMU the innovations vanish, so the filter is linear in the step scale (with noise, the
    # gains' own dependence on the estimated attitude times the innovations adds terms of first order);
    # the step vectors are given (the attitude reading of the direction makes z depend on the estimate).
    base = base.with_(step_heading="gyro")
    inp = _exact_input(traj, vectors=True)
    (exact,) = aided.run_batch([inp], base)
    (cons,) = aided.run_batch([inp], base.with_(gain_sigma=sk, gain_estimated=False))
    h = 1e-4
    ends = []
    for sc in (1 - h, 1 + h):
        (r,) = aided.run_batch([_exact_input(traj, scale=sc, vectors=True)], base)
        ends.append(r.position[:, :2])
    s = (ends[1] - ends[0]) / (2 * h)                           # d(estimate)/dk per epoch
    want = exact.P_xy + sk ** 2 * s[:, :, None] * s[:, None, :]
    j = np.flatnonzero(exact.time > inp.step_start[2])          # once the steps have moved the robot
    scale = np.abs(want[j]).max(axis=(1, 2))
    # relative 2e-4: the trajectory's discretization leaves innovations of that order
    assert np.all(np.abs(cons.P_xy[j] - want[j]).max(axis=(1, 2)) <= 2e-4 * scale)


def test_standing_stretch_holds_the_robot_still_before_the_motion():
    """Between the rest window and the motion the robot stands (its phone hums): zero velocity only."""
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    (r0, r1) = _rest(traj)
    rng = np.random.default_rng(5)
    f = traj.f_b.copy()
    omega = traj.omega_b.copy()
    t = traj.time
    cut = r0[0] + 0.3 * (r0[1] - r0[0])                  # the calibration's rest window: the first 30 %
    hum = (t > cut) & (t <= r0[1])
    f[hum] += rng.normal(0.0, 0.3, (hum.sum(), 3)) + [0.05, 0.0, 0.0]   # motor vibration and a tilt
    omega[hum] += rng.normal(0.0, 0.05, (hum.sum(), 3))
    base = _exact_input(traj, f=f, omega=omega)
    tun = aided.AidTuning(accel_noise=0.03, gyro_noise=5e-3, step_sigma=0.01, gain_sigma=0.0, nhc=False)
    from dataclasses import replace
    errs = []
    for standing in ((), ((cut, r0[1]),)):
        inp = replace(base, rest=((r0[0], cut), r1), standing=standing)
        (r,) = aided.run_batch([inp], tun)
        j = r.index_at(r0[1])
        errs.append(np.linalg.norm(r.position[j, :2]))      # the truth there: the origin
        if standing:
            assert "zero velocity" in r.nis and "zero rate" in r.nis
    free, held = errs
    # a 0.05 m/s^2 offset over the stretch drifts by decimetres; zero velocity holds it to centimetres
    assert free > 0.05 and held < 0.2 * free, errs



def test_the_standing_robot_keeps_the_still_phones_noise():
    """While the robot stands the process noise is the still phone's, while it moves the motion's.

    A recording standing throughout, filtered with a motion noise 100 times
    the still noise, is filtered exactly as with the still noise alone
    (forward and smoothed); a moving recording without rest ignores it.
    """
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 6.0, 0.01)
    still = aided.AidedInput(time=t, f=[0.0, 0.0, 9.8] + rng.normal(0.0, 0.03, (t.size, 3)),
                             omega=rng.normal(0.0, 1e-3, (t.size, 3)), C0=np.eye(3), g=9.8,
                             rest=((0.0, 3.0),), standing=((3.0, 6.0),))
    small = aided.AidTuning(accel_noise=3e-3, gyro_noise=1e-4, step_sigma=0.02, gain_sigma=0.0)
    mixed = small.with_(accel_noise=0.3, gyro_noise=1e-2, rest_accel_noise=3e-3, rest_gyro_noise=1e-4)
    a, b = aided.run_batch([still, still], [small, mixed], smooth=True)
    np.testing.assert_allclose(b.P_xy, a.P_xy, rtol=1e-12, atol=0)
    np.testing.assert_allclose(b.position, a.position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.smoothed, a.smoothed, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.P_xy_smoothed, a.P_xy_smoothed, rtol=1e-12, atol=0)
    traj = simulate.sine(4.0, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    from dataclasses import replace
    moving = replace(_exact_input(traj), rest=(), standing=())
    c, d = aided.run_batch([moving, moving], [mixed.with_(rest_accel_noise=0.0, rest_gyro_noise=0.0), mixed])
    np.testing.assert_array_equal(c.P_xy, d.P_xy)


def test_a_standing_robot_stays_where_it_stands_under_a_vibrating_motion_noise():
    """Rest, then the motors hum while the robot stands: its position stays known to about a centimetre.

    The motion's noise density (0.3 m/s^2/sqrt(Hz), a vibrating robot under
    way) integrated between zero-velocity updates would leave the position
    uncertain by several centimetres after five seconds; with the standing
    robot's own noise the claim shrinks to the share the level's bias and
    tilt leave, and the true position (the origin) lies inside it.
    """
    rng = np.random.default_rng(12)
    t = np.arange(0.0, 5.0, 0.01)
    f = np.tile([0.0, 0.0, 9.8], (t.size, 1)) + rng.normal(0.0, 0.003, (t.size, 3))
    hum = t > 3.0
    f[hum] += rng.normal(0.0, 0.03, (hum.sum(), 3))           # density 0.03 * sqrt(0.01) = 3e-3
    inp = aided.AidedInput(time=t, f=f, omega=rng.normal(0.0, 1e-4, (t.size, 3)), C0=np.eye(3), g=9.8,
                           rest=((0.0, 3.0),), standing=((3.0, 5.0),))
    moving = aided.AidTuning(accel_noise=0.3, gyro_noise=1e-3, step_sigma=0.02, gain_sigma=0.0)
    (loose,), (held,) = (aided.run_batch([inp], tun) for tun in (moving, moving.with_(rest_accel_noise=3e-3)))
    sig = lambda r: float(np.sqrt(np.trace(r.P_xy[-1])))     # noqa: E731
    assert sig(loose) > 0.03 and sig(held) < 0.3 * sig(loose), (sig(loose), sig(held))
    m2 = held.end_point @ np.linalg.solve(held.P_xy[-1], held.end_point)
    assert m2 < 13.8                                          # chi-square 2 dof, 99.9 %


def test_a_cut_input_gives_the_same_forward_estimate_at_the_cut():
    """The forward filter is causal: cut after the last step, its estimate there is the whole run's."""
    traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, rate_hz=100.0)
    rng = np.random.default_rng(9)
    d = simulate.imu(traj, units.LSM6DSL, rng, bias_scale=(0.05, 0.05))
    inp = _exact_input(traj, f=d.f, omega=d.omega)
    stop = float(inp.step_end[-3])                       # a boundary inside the run
    tun = aided.AidTuning(step_sigma=0.02, gain_sigma=0.04, gain_estimated=False)
    (whole,) = aided.run_batch([inp], tun)
    (cut,) = aided.run_batch([inp.until(stop)], tun)
    j, k = whole.index_at(stop), cut.index_at(stop)
    assert k == cut.time.size - 1 and whole.time[j] == cut.time[k]
    np.testing.assert_allclose(cut.position[k], whole.position[j], rtol=0, atol=1e-12)
    np.testing.assert_allclose(cut.P_xy[k], whole.P_xy[j], rtol=0, atol=1e-12)


def test_consider_update_one_state_equals_the_conditioned_covariance_update():
    """The single-frozen-state shortcut against the update on the explicitly conditioned covariance."""
    rng = np.random.default_rng(6)
    b, n, m = 4, 7, 2
    A = rng.normal(size=(b, n, n))
    P = A @ np.swapaxes(A, 1, 2) + np.eye(n)
    H = rng.normal(size=(b, m, n))
    R = np.broadcast_to(np.eye(m) * 0.3, (b, m, m)).copy()
    x = rng.normal(size=(b, n))
    y = rng.normal(size=(b, m))
    frozen = np.zeros((b, n), bool)
    frozen[[0, 2, 3], 5] = True                    # member 1 estimates every state
    xs, Ps, Ss = oracle.kf_update(x, P, y, H, R, frozen)
    # reference: the gain from the Schur complement built by hand, Joseph form on the full covariance
    for i in range(b):
        Pc = P[i].copy()
        if frozen[i, 5]:
            Pc -= np.outer(P[i][:, 5], P[i][5, :]) / P[i][5, 5]
        K = Pc @ H[i].T @ np.linalg.inv(H[i] @ Pc @ H[i].T + R[i])
        IKH = np.eye(n) - K @ H[i]
        np.testing.assert_allclose(xs[i], x[i] + K @ y[i], atol=1e-12)
        np.testing.assert_allclose(Ps[i], IKH @ P[i] @ IKH.T + K @ R[i] @ K.T, atol=1e-10)
        assert (xs[i, 5] == x[i, 5]) == bool(frozen[i, 5])


def test_smoother_with_a_state_without_uncertainty_uses_the_pseudo_inverse():
    """A state with exactly zero variance (an unused clone): the gains of the pseudo-inverse formula."""
    rng = np.random.default_rng(8)
    n, k = 5, 12
    A = rng.normal(size=(k, n, n))
    P_post = A @ np.swapaxes(A, 1, 2) + np.eye(n)
    P_post[:, 4, :] = 0.0
    P_post[:, :, 4] = 0.0
    Phi = np.eye(n) + 0.05 * rng.normal(size=(k, n, n))
    Phi[:, 4, :] = 0.0
    Phi[:, :, 4] = 0.0
    Phi[:, 4, 4] = 1.0                                  # the dead state stays apart
    Q = np.eye(n) * 0.01
    Q[4, 4] = 0.0
    P_prior = P_post.copy()
    P_prior[1:] = Phi[1:] @ P_post[:-1] @ np.swapaxes(Phi[1:], 1, 2) + Q
    x_post = rng.normal(size=(k, n))
    x_post[:, 4] = 0.0
    x_prior = x_post.copy()
    x_prior[1:] = np.einsum("bij,bj->bi", Phi[1:], x_post[:-1])
    given = [a.copy() for a in (x_post, P_post, x_prior, P_prior, Phi)]
    xs, Ps = oracle.rts_smooth(x_post, P_post, x_prior, P_prior, Phi)
    # the dead state's padding goes into the smoother's own arrays: the caller's are left as they were
    for a, b in zip((x_post, P_post, x_prior, P_prior, Phi), given):
        assert np.array_equal(a, b)
    # reference: the recursion with numpy's pseudo-inverse, one epoch at a time
    rx, rP = x_post.copy(), P_post.copy()
    for j in range(k - 2, -1, -1):
        G = P_post[j] @ Phi[j + 1].T @ np.linalg.pinv(P_prior[j + 1])
        rx[j] = x_post[j] + G @ (rx[j + 1] - x_prior[j + 1])
        rP[j] = P_post[j] + G @ (rP[j + 1] - P_prior[j + 1]) @ G.T
    np.testing.assert_allclose(xs, rx, atol=1e-9)
    np.testing.assert_allclose(Ps, rP, atol=1e-9)



@pytest.mark.field
def test_what_precedes_the_initial_rest_does_not_move_the_filter(field_root, tmp_path):
    """The phone carried 0.3 m and turned 20 degrees before it is set down: the same filter estimate.

    A train recording, and the same recording with a second of handling put
    before it (a smooth acceleration pulse along the phone's y axis that
    carries it 0.3 m from rest to rest, a 20 degree turn about z): the robot's
    path, which starts at the initial rest, is the same, so the prepared inputs
    from that rest on and the filter's end points must agree.
    """
    from dataclasses import replace

    from morpi_filters import dataset as ds
    from morpi_filters.field import FieldData
    from morpi_filters.field_aided import prepare
    from morpi_filters.steps import StepConfig

    data = FieldData(field_root)
    rec = data.recordings("s8", "short_distance", "train")[0]
    rel = Path(data.relpath(rec))
    dt = float(np.median(np.diff(rec.time)))
    T = 1.0                                                         # shorter than a motion: a disturbance
    tp = rec.time[0] + np.arange(int(round(T / dt))) * dt          # the handling, then the recording
    amp = 0.3 * 2 * np.pi / T ** 2                                  # a sin(2 pi t / T): a T^2 / (2 pi) = 0.3 m
    # on the rest's own samples (its noise), a smooth pulse and turn
    f = rec.f[:tp.size].copy()
    f[:, 1] += amp * np.sin(2 * np.pi * (tp - tp[0]) / T)
    w = rec.omega[:tp.size].copy()
    w[:, 2] += np.radians(20.0) / T * (1 - np.cos(2 * np.pi * (tp - tp[0]) / T))
    handled = ds.Recording(time=np.r_[tp, rec.time + T], f=np.vstack([f, rec.f]), omega=np.vstack([w, rec.omega]),
                           source="handled")
    folder = tmp_path / rel.parent
    folder.mkdir(parents=True)
    ds.write_csv(folder / "2.csv", handled)
    # the same recording from the first sample of the handled one's initial rest on
    i0 = FieldData(tmp_path, thresholds=data.thresholds).rest_window(handled).i0
    assert handled.time[i0] >= tp[-1]                        # the handling is found to be no rest
    ds.write_csv(folder / "1.csv", ds.Recording(time=handled.time[i0:], f=handled.f[i0:], omega=handled.omega[i0:],
                                                source="plain"))
    other = FieldData(tmp_path, thresholds=data.thresholds)
    a, b = sorted(other.recordings("s8", "short_distance", "train"), key=lambda r: r.n)
    assert b.n == a.n + i0
    assert other.rest_window(a).start_s == other.rest_window(b).start_s
    pa, pb = (prepare(other, r, "GC", "MoRPI-G", StepConfig(), 0.5) for r in (a, b))
    # the filter's input from the rest on is the same (the steps, found on each whole recording, may differ
    # by the phase of the step detector's grid: both runs take the plain recording's)
    for name in ("time", "f", "omega", "C0"):
        assert np.array_equal(getattr(pa.input, name), getattr(pb.input, name)), name
    assert pa.input.rest[0] == pb.input.rest[0]
    steps = {k: getattr(pa.input, k) for k in ("step_start", "step_end", "step_length", "step_vector")}
    ra, rb = aided.run_batch([pa.input, replace(pb.input, **steps)],
                             aided.AidTuning(step_sigma=0.02, gain_sigma=0.0, step_heading="gyro"))
    assert np.linalg.norm(ra.end_point - rb.end_point) < 1e-6


# ----------------------------------------------------------------------------- MoRPI alone's best reading

def _drifting_root(root: Path, drift: float, *, test_gyro_scale: float = 1.0, amplitudes=None) -> Path:
    """A short-route set (s6, 4 train and 2 test runs) whose z gyro gains `drift` [rad/s] while the robot
    moves (after the rest window, so the GC calibration keeps it): the absolute heading turns away from the
    straight route, the route's heading (no turn) does not. With `test_gyro_scale` the test gyros are scaled."""
    from morpi_filters import dataset as ds

    rng = np.random.default_rng(11)
    for split, n in (("train", 4), ("test", 2)):
        for i in range(n):
            amp = None if amplitudes is None else amplitudes[i]
            traj = simulate.route_trajectory("short_distance", speed_mps=0.3 * (1.0 + 0.1 * rng.standard_normal()),
                                             amplitude_m=amp)
            imu = simulate.imu(traj, units.MPU6500, rng, sampling="two-rate", bias_scale=0.0)
            omega = imu.omega.copy()
            moving = (imu.time >= traj.start_time) & (imu.time <= traj.stop_time)
            omega[moving, 2] += drift
            if split == "test":
                omega = omega * test_gyro_scale
            rec = ds.Recording(time=imu.time, f=imu.f, omega=omega, source="synthetic")
            ds.write_csv(root / "s6" / "short_distance" / split / f"{i + 1}.csv", rec)
    return root


def test_the_route_heading_is_chosen_where_the_rule_reading_drifts(tmp_path):
    """Synthetic straight runs whose heading drifts while moving: MoRPI alone's absolute reading ends off
    the route, the route's heading does not, and the train runs' leave-one-out choice takes it; the rule's
    score is the rule search's own."""
    from morpi_filters import field as fd
    from morpi_filters.field_aided import choose_reading

    data = fd.FieldData(_drifting_root(tmp_path / "drift", 0.03))
    config = fd.select_config(data, "MoRPI-G").config.with_(heading="absolute")
    pick = choose_reading(data, "MoRPI-G", config)
    assert pick.runs == 4 and pick.reading == "route"
    assert pick.rule_percent == fd.held_out_score(data, "MoRPI-G", config)[0]
    assert pick.route_percent < pick.rule_percent - pick.difference_se_pp


def test_route_reading_within_the_tie_tolerance_keeps_the_rule_reading():
    from morpi_filters.field_aided import READING_SE, route_reading_pays

    rule = np.array([3.0, 4.0, 5.0, 4.5, 3.5])
    d = np.array([-0.4, 0.2, -0.5, 0.3, -0.35])            # mean -0.15 pp, standard error 0.17 pp
    se = d.std(ddof=1) / np.sqrt(d.size)
    assert -d.mean() < READING_SE * se < 2 * -d.mean()
    # better on average but within one standard error: the rule's own reading stays
    assert not route_reading_pays(rule, rule + d)
    # the same differences shifted beyond the tolerance: the route's heading is taken
    assert route_reading_pays(rule, rule + d - 2 * se)
    # a run the route's heading cannot read (not finite): no choice of it
    assert not route_reading_pays(rule, np.append(rule[:-1] - 1.0, np.nan))


def test_reading_choice_ignores_corrupted_test_recordings(tmp_path):
    """Every test recording's gyro scaled by 1.5: the same rules, readings and step lengths, scores and all."""
    from morpi_filters import field as fd
    from morpi_filters.field_aided import choose_length, choose_reading, period_length

    picks = []
    for name, scale in (("clean", 1.0), ("corrupted", 1.5)):
        data = fd.FieldData(_drifting_root(tmp_path / name, 0.03, test_gyro_scale=scale))
        out = []
        for m in ("MoRPI-A", "MoRPI-G"):
            config = fd.select_config(data, m).config
            pick = choose_reading(data, m, config)
            out += [config, pick, choose_reading(data, m, config.with_(heading="absolute")),
                    choose_length(data, "s6", m, config, pick.reading),
                    period_length(data, "s6", "RD", m, config, pick.reading)]
        picks.append(out)
    assert picks[0] == picks[1]


def test_the_period_count_is_chosen_where_the_amplitude_varies_and_counts_half_metres(tmp_path):
    """Synthetic 1 m periods whose lateral amplitude varies from run to run (0.03 to 0.15 m): the Weinberg
    weight follows the amplitude, the distance per period does not. The period count's half-period length
    is the designed half metre up to the partial end steps (at most one period of the 12.6 half periods of
    6.3 m left uncounted), and the held-out choice takes it."""
    from morpi_filters import field as fd
    from morpi_filters.field_aided import choose_length, period_length

    data = fd.FieldData(_drifting_root(tmp_path / "amp", 0.0, amplitudes=(0.03, 0.15, 0.05, 0.1)))
    for m in ("MoRPI-A", "MoRPI-G"):
        config = fd.select_config(data, m).config
        assert 0.5 * 0.99 <= period_length(data, "s6", "GC", m, config, config.heading) <= 6.3 / (12.6 - 2.0)
    config = fd.select_config(data, "MoRPI-G").config
    pick = choose_length(data, "s6", "MoRPI-G", config, config.heading)
    assert pick.held_out == "run" and pick.runs == 4
    assert pick.length == "period count" and pick.period_percent < pick.weinberg_percent


# ----------------------------------------------------------------------------- a recording that starts under way

#: chi-square, 2 dof: the squared Mahalanobis distance a consistent filter exceeds with probability 1e-6
#: (``scipy.stats.chi2.ppf(1 - 1e-6, 2) = -2 ln 1e-6``).
_M2_1E6 = -2.0 * np.log(1e-6)


def _level_cruise(v0, *, seconds=10.0, rate_hz=100.0, **kw):
    """A level phone carried straight along x at 1 m/s from its first sample: the specific force is exactly
    gravity, the rate zero; steps every 0.5 s with their exact lengths."""
    n = int(round(seconds * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    b = t[::int(round(0.5 * rate_hz))]
    return aided.AidedInput(time=t, f=np.tile([0.0, 0.0, units.G0], (n, 1)), omega=np.zeros((n, 3)),
                            C0=np.eye(3), g=units.G0, step_start=b[:-1], step_end=b[1:],
                            step_length=np.diff(b) * 1.0, v0=np.asarray(v0, float), **kw)


def test_a_cruise_started_at_its_true_velocity_ends_on_the_truth_and_from_zero_far_off():
    """A run that starts at 1 m/s along x (no rest before it), all aids on.

    Given the true initial velocity the nominal state is the truth itself:
    the phone is level and reads exactly gravity, so the acceleration is
    zero in floating point, the velocity stays 1 m/s and the position is the
    sum of the n trapezoid increments ``h (v + v') = dt``. That sum is off
    the exact ``v0 T`` by at most ``(n - 1) eps/2 T`` (recursive summation),
    the time differences ``dt`` by at most ``n eps/2 T`` more; the step and
    non-holonomic innovations are rounding of the same size and so are their
    corrections. Bound: ``n eps T``. Started at zero velocity (1 mm/s sigma:
    the filter is sure it stands), the steps pull the position only part of
    the way: meters off, far outside the filter's own ellipse.
    """
    from dataclasses import replace

    moving = _level_cruise([1.0, 0.0, 0.0], v0_sigma=1e-3)
    n, T = moving.time.size, float(moving.time[-1] - moving.time[0])
    truth = np.array([T, 0.0])
    good, bad = aided.run_batch([moving, replace(moving, v0=np.zeros(3))], aided.AidTuning())
    bound = n * np.finfo(float).eps * T
    assert np.abs(good.end_point - truth).max() <= bound, (good.end_point - truth, bound)
    e = bad.end_point - truth
    assert np.linalg.norm(e) > 0.1 * T, e                          # more than a tenth of the 10 m driven
    assert e @ np.linalg.solve(bad.end_cov, e) > _M2_1E6


def test_the_initial_velocity_sigma_is_the_velocity_covariance():
    """Without process noise or other initial uncertainty, the position variance after T seconds of
    dead reckoning is ``(v0_sigma T)^2`` per axis (``dp`` integrates ``dv``: ``Phi`` holds ``T I``)."""
    sig = np.array([0.1, 0.3, 0.05])
    quiet = aided.AidTuning(accel_noise=0.0, gyro_noise=0.0, accel_walk=0.0, gyro_walk=0.0, tilt0=0.0, ba0=0.0,
                            bg0=0.0, steps=False, nhc=False, rest=False)
    per_axis, one = aided.run_batch([_level_cruise([1.0, 0.0, 0.0], v0_sigma=sig),
                                     _level_cruise([1.0, 0.0, 0.0], v0_sigma=0.2)], quiet)
    T = 10.0
    # 101 epochs, each prediction a few products rounded at eps relative: 1e-12 relative covers them
    np.testing.assert_allclose(per_axis.end_cov, np.diag(sig[:2] * T) ** 2, rtol=1e-12, atol=0)
    np.testing.assert_allclose(one.end_cov, np.eye(2) * (0.2 * T) ** 2, rtol=1e-12, atol=0)


@pytest.mark.parametrize("kw, match", [
    (dict(v0=np.zeros(2)), "v0="), (dict(v0=np.array([0.0, np.nan, 0.0])), "v0="),
    (dict(v0_sigma=-1e-3), "v0_sigma="), (dict(v0_sigma=np.array([0.1, 0.1])), "v0_sigma="),
    (dict(v0_sigma=np.array([0.1, np.inf, 0.1])), "v0_sigma=")])
def test_a_bad_initial_velocity_is_refused_by_name(kw, match):
    t = np.arange(3) * 0.1
    with pytest.raises(ParameterError, match=match):
        aided.AidedInput(time=t, f=np.zeros((3, 3)), omega=np.zeros((3, 3)), C0=np.eye(3), g=9.8, **kw)


def test_a_simulated_drive_cut_under_way_is_followed_from_its_true_velocity():
    """The simulator's straight drive (1 m/s), noisy IMU, cut 2 s into the motion (``since``): from the
    true velocity at the cut (10 mm/s sigma) the end point lies inside the filter's own 1 - 1e-6 ellipse
    (chi-square, 2 dof; the tuning's noise densities are the simulated IMU's, its initial bias
    uncertainties above the simulated biases); from zero velocity it is meters off and far outside."""
    from dataclasses import replace

    traj = simulate.straight(12.0, speed_mps=1.0, ramp_s=1.0, rest_s=1.0, rate_hz=100.0)
    t, pos = traj.time, traj.position
    b = t[::50]
    pa = np.array([np.interp(b[:-1], t, pos[:, j]) for j in range(2)]).T
    pb = np.array([np.interp(b[1:], t, pos[:, j]) for j in range(2)]).T
    spec = units.LSM6DSL
    tun = aided.AidTuning(accel_noise=spec.accel_noise, gyro_noise=spec.gyro_noise)
    members = []
    for seed in (0, 1, 2):
        d = simulate.imu(traj, spec, np.random.default_rng(seed), bias_scale=(0.05, 0.05))
        whole = aided.AidedInput(time=t, f=d.f, omega=d.omega, C0=traj.C_bn[0], g=units.G0, step_start=b[:-1],
                                 step_end=b[1:], step_length=np.linalg.norm(pb - pa, axis=1),
                                 rest=((traj.stop_time + 0.1, t[-1]),))
        cut = whole.since(traj.start_time + 2.0)
        i0 = int(np.searchsorted(t, cut.time[0]))
        assert np.linalg.norm(traj.velocity[i0]) == pytest.approx(1.0, abs=1e-9)      # cruising at the cut
        members += [replace(cut, v0=traj.velocity[i0], v0_sigma=0.01), replace(cut, v0=np.zeros(3))]
        truth = traj.end_point[:2] - pos[i0, :2]
    out = aided.run_batch(members, tun)
    for good, bad in zip(out[::2], out[1::2]):
        e = good.end_point - truth
        assert e @ np.linalg.solve(good.end_cov, e) < _M2_1E6, e
        e = bad.end_point - truth
        assert np.linalg.norm(e) > 0.1 * np.linalg.norm(truth), e
        assert e @ np.linalg.solve(bad.end_cov, e) > _M2_1E6


# ----------------------------------------------------------------------------- the horizontal error ellipse

def _q(level):
    # the chi-square distribution with 2 dof is exponential: P(X <= q) = 1 - exp(-q / 2)
    return -2.0 * np.log1p(-level)


@pytest.mark.parametrize("sx, sy, angle", [(2.0, 1.0, 0.0), (0.5, 3.0, np.pi / 2)])
def test_error_ellipse_of_a_diagonal_covariance(sx, sy, angle):
    e = aided.error_ellipse(np.diag([sx ** 2, sy ** 2]))
    k = np.sqrt(_q(0.95))                                      # 2.4477: the 95 % radius in sigmas
    # a square root and a product of exact inputs: a few eps relative
    assert e.semi_major == pytest.approx(k * max(sx, sy), rel=1e-14)
    assert e.semi_minor == pytest.approx(k * min(sx, sy), rel=1e-14)
    assert e.orientation == pytest.approx(angle, abs=1e-15) and e.level == 0.95
    assert aided.CHI2_95_2DOF == pytest.approx(_q(0.95), rel=1e-15)
    np.testing.assert_allclose(np.abs(e.points).max(axis=0), k * np.array([sx, sy]), rtol=1e-12)


@pytest.mark.parametrize("theta", [0.3, -1.1, 1.4, np.pi / 2 - 1e-3])
def test_error_ellipse_of_a_rotated_covariance(theta):
    s1, s2 = 0.8, 0.25
    R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    P = R @ np.diag([s1 ** 2, s2 ** 2]) @ R.T
    e = aided.error_ellipse(P, level=0.99, center=(3.0, -2.0), n_points=37)
    q = _q(0.99)
    # P built with a few roundings of relative eps; its eigenvalues keep them, the square roots halve them
    assert e.semi_major == pytest.approx(np.sqrt(q) * s1, rel=1e-13)
    assert e.semi_minor == pytest.approx(np.sqrt(q) * s2, rel=1e-13)
    # the angle of an eigenvector: rounding of P (1e-16 relative) over the eigenvalue gap (0.6 of the largest)
    assert e.orientation == pytest.approx(theta, abs=1e-13)
    d = e.points - [3.0, -2.0]
    np.testing.assert_allclose(np.einsum("ki,ij,kj->k", d, np.linalg.inv(P), d), q, rtol=1e-12)
    assert e.points.shape == (37, 2) and np.array_equal(e.points[0], e.points[-1])


def test_error_ellipse_holds_its_share_of_gaussian_draws():
    rng = np.random.default_rng(20240601)
    P = np.array([[0.09, -0.05], [-0.05, 0.04]])
    d = rng.multivariate_normal([0.0, 0.0], P, size=200_000)
    for level in (0.5, 0.95):
        e = aided.error_ellipse(P, level=level)
        ct, st = np.cos(e.orientation), np.sin(e.orientation)
        u, w = ct * d[:, 0] + st * d[:, 1], -st * d[:, 0] + ct * d[:, 1]        # in the ellipse's axes
        inside = np.mean((u / e.semi_major) ** 2 + (w / e.semi_minor) ** 2 <= 1.0)
        # a binomial share of 200,000 draws: 5 standard deviations
        assert abs(inside - level) < 5 * np.sqrt(level * (1 - level) / d.shape[0]), (level, inside)


@pytest.mark.parametrize("P, kw, match", [
    (np.eye(3), {}, "2 x 2"), (np.array([[1.0, np.nan], [np.nan, 1.0]]), {}, "finite"),
    (np.array([[1.0, 0.5], [0.4, 1.0]]), {}, "symmetric"), (np.array([[1.0, 2.0], [2.0, 1.0]]), {}, "semi-definite"),
    (np.eye(2), {"level": 1.0}, "level="), (np.eye(2), {"n_points": 2}, "n_points="),
    (np.eye(2), {"center": (0.0, np.inf)}, "center=")])
def test_error_ellipse_refuses_a_bad_covariance_by_name(P, kw, match):
    with pytest.raises(ParameterError, match=match):
        aided.error_ellipse(P, **kw)
