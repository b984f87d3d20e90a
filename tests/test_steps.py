"""Tests of morpi_filters.steps on synthetic signals with known peaks and distances."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid, quad

from morpi_filters import steps as st
from morpi_filters.steps import _loops, extract as stx, prepare as stp
from morpi_filters.dataset import Recording
from morpi_filters.errors import MorpiError
from conftest import plain_kernels


def _jittered_time(duration, rate, rng, t0=12.3):
    """Non-uniform time stamps: steps uniformly spread +-40 % around 1/rate."""
    n = int(duration * rate * 1.2)
    dt = (1.0 / rate) * rng.uniform(0.6, 1.4, n)
    t = t0 + np.concatenate([[0.0], np.cumsum(dt)])
    return t[t <= t0 + duration]


def sine_path_recording(n_periods, *, wavelength=1.0, amplitude=0.1, speed=0.4, rest=3.0, rate=80.0, seed=0,
                        name="sine.csv"):
    """A robot on y = A (1 - cos(2 pi x / lambda)) for `n_periods` periods, at constant forward speed.

    Rest before and after; the body frame follows the path tangent (heading psi = atan(dy/dx)),
    so omega_z = dpsi/dt and the lateral specific force is f_y = v_t * omega_z (centripetal),
    f_x the tangential acceleration, f_z = g. Returns (recording, x(t) as the truth).
    """
    rng = np.random.default_rng(seed)
    move = n_periods * wavelength / speed
    t = _jittered_time(2 * rest + move, rate, rng)
    tau = np.clip(t - t[0] - rest, 0.0, move)
    x = speed * tau
    k = 2 * np.pi / wavelength
    psi = np.arctan(amplitude * k * np.sin(k * x))  # zero at the start, as the integrated gyro
    moving = (t - t[0] > rest) & (t - t[0] < rest + move)
    # dpsi/dt = dpsi/dx * dx/dt
    dpsi_dx = (amplitude * k * k * np.cos(k * x)) / (1 + (amplitude * k * np.sin(k * x)) ** 2)
    wz = np.where(moving, dpsi_dx * speed, 0.0)
    vt = np.where(moving, speed / np.cos(psi), 0.0)
    fy = vt * wz
    fx = np.gradient(vt, t)
    f = np.column_stack([fx, fy, np.full_like(t, 9.81)])
    omega = np.column_stack([np.zeros_like(t), np.zeros_like(t), wz])
    return Recording(time=t, f=f, omega=omega, source=name), x


# ----------------------------------------------------------------------------- peak detection

def test_sinusoid_one_peak_per_period_at_the_right_times():
    rng = np.random.default_rng(1)
    period, amp = 2.5, 0.7
    t = _jittered_time(30.0, 60.0, rng)
    x = amp * np.sin(2 * np.pi * (t - t[0]) / period)
    idx, props = st.detect_peaks(x, t, min_period_s=0.5 * period, min_prominence=0.5 * amp)
    # maxima at t0 + period/4 + j*period strictly inside the record
    expected = t[0] + period / 4 + period * np.arange(12)
    expected = expected[expected < t[-1]]
    assert idx.size == expected.size
    # the grid is 100 Hz and the samples ~60 Hz with +-40 % jitter: peak times within one grid
    # step plus one sample interval (0.01 + 0.024 s)
    np.testing.assert_allclose(props["time"], expected, atol=0.035)
    np.testing.assert_allclose(t[idx], expected, atol=0.035)
    assert set(("prominences", "time", "grid_index")) <= set(props)


def test_min_period_in_seconds_suppresses_faster_peaks():
    rng = np.random.default_rng(2)
    t = _jittered_time(20.0, 90.0, rng)
    x = np.sin(2 * np.pi * (t - t[0]) / 2.0) + 0.3 * np.sin(2 * np.pi * (t - t[0]) / 0.25)
    many, _ = st.detect_peaks(x, t, min_period_s=0.1, min_prominence=0.1)
    few, _ = st.detect_peaks(x, t, min_period_s=1.5, min_prominence=0.1)
    assert few.size == 10  # one per 2 s period in 20 s
    assert many.size > 3 * few.size


def test_lowpass_cutoff_removes_noise_peaks():
    rng = np.random.default_rng(3)
    t = _jittered_time(20.0, 100.0, rng)
    x = np.sin(2 * np.pi * (t - t[0]) / 2.0) + 0.2 * rng.standard_normal(t.size)
    noisy, _ = st.detect_peaks(x, t, min_period_s=0.05, min_prominence=0.05)
    clean, _ = st.detect_peaks(x, t, min_period_s=0.05, min_prominence=0.05, cutoff_hz=1.5)
    assert clean.size == 10
    assert noisy.size > 20


@pytest.mark.parametrize("cutoff_hz", [0.5, 3.0, 20.0])
def test_lowpass_is_scipys_sosfiltfilt_within_the_filters_condition(cutoff_hz):
    # the loop and scipy run the same recursions, perhaps with other orders of operations: they agree within
    # the rounding the filter's condition lets grow (oracles.sums.filtfilt_bound)
    from scipy import signal

    from oracles.sums import filtfilt_bound

    rng = np.random.default_rng(31)
    sos = signal.butter(2, cutoff_hz, fs=st.GRID_HZ, output="sos")
    # the shortest signal scipy pads (10 samples), a long one, and columns filtered along axis 0
    for x in (rng.normal(size=10), 5.0 + rng.normal(size=4000), rng.normal(size=(300, 3))):
        np.testing.assert_allclose(st.lowpass(x, cutoff_hz), signal.sosfiltfilt(sos, x, axis=0), rtol=0.0,
                                   atol=filtfilt_bound(sos, np.abs(x).max()))
    short = rng.normal(size=9)                                   # too short for the padding: returned as is
    np.testing.assert_array_equal(st.lowpass(short, cutoff_hz), short)
    # the compiled loop gives the plain Python loop's bits: the same loop, the same operations in the same order
    plain = plain_kernels(_loops)
    x = rng.normal(size=200)
    out = np.empty(200)
    plain.filtfilt(sos, signal.sosfilt_zi(sos), 9, x, out)
    np.testing.assert_array_equal(out, st.lowpass(x, cutoff_hz))


def test_span_percentiles_are_numpys_within_the_rounding_of_the_interpolation():
    # both interpolate between the same two order statistics; the position and the interpolation may round
    # otherwise (oracles.sums.percentile_bound)
    from oracles.sums import percentile_bound

    rng = np.random.default_rng(5)
    for n in (3, 4, 5, 26, 50, 51, 76, 6000, 6001):               # 26, 76: an index halfway between two
        for x in (rng.normal(size=n), 1e3 + 1e-3 * rng.normal(size=n), np.round(rng.normal(size=n), 1)):
            for qs in ((2.0, 98.0), (0.0, 50.0, 100.0)):
                got, want = stp._percentiles(x, qs), np.percentile(x, qs)
                assert len(got) == len(qs)
                for g, w, q in zip(got, want, qs):
                    assert abs(g - w) <= percentile_bound(x, q), (n, q, g, w)
            # the extremes are order statistics, no arithmetic: exact
            assert stp._percentiles(x, (0.0, 100.0)) == (x.min(), x.max())


def test_weinberg_length_of_a_sinusoid():
    # a sinusoid of amplitude A has max - min = 2A in every period: length gain * (2A)^(1/4)
    rng = np.random.default_rng(4)
    A, gain, period = 0.8, 0.6, 3.0
    t = _jittered_time(32.0, 70.0, rng)
    wz = A * np.sin(2 * np.pi * (t - t[0] - 1.0) / period)
    rec = Recording(time=t, f=np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 9.81)]),
                    omega=np.column_stack([np.zeros_like(t), np.zeros_like(t), wz]), source="sin.csv")
    cfg = st.StepConfig(segment="maxima", ends="drop", cutoff_hz=None, min_swing_deg=0.0)
    s = st.extract_steps(rec, "MoRPI-G", cfg, heading=np.zeros_like(t))
    assert s.n == 9  # 10 maxima in 32 s (first at 1.75 s, then every 3 s), 9 peak-to-peak steps
    # max - min of the resampled sinusoid is within the linear-interpolation error of 2A:
    # A (1 - cos(pi dt_max / period)) with dt_max = 1.4/70 s gives 1.6e-4 relative
    np.testing.assert_allclose(s.weight, (2 * A) ** 0.25, rtol=1e-4)
    track = st.morpi_track(s, gain)
    np.testing.assert_allclose(track.length, gain * (2 * A) ** 0.25, rtol=1e-4)


def test_weinberg_length_vectorized_and_validated():
    vmax = np.array([[1.0, 2.0], [17.0, 0.5]])
    vmin = np.array([[0.0, 1.0], [1.0, 0.5]])
    np.testing.assert_allclose(st.weinberg_length(vmax, vmin, 2.0), [[2.0, 2.0], [4.0, 0.0]])  # (max - min)^(1/4) of exact powers of two: exact
    with pytest.raises(MorpiError, match="vmax >= vmin"):
        st.weinberg_length([0.0], [1.0], 1.0)


# ----------------------------------------------------------------------------- the MoRPI pipeline on a sine path

@pytest.mark.parametrize("segment", st.SEGMENTS)
@pytest.mark.parametrize("method", tuple(st.METHODS))
def test_trained_gain_gives_the_true_distance_on_a_sine_path(method, segment):
    cfg = st.StepConfig(heading="mean", segment=segment, ends="fraction", cutoff_hz=3.0)
    train, _ = sine_path_recording(6, seed=10, name="train.csv")
    s_train = st.extract_steps(train, method, cfg, rest_end_time=train.time[0] + 2.0)
    gain, std, per = st.train_gain([s_train], 6.0)
    assert std == 0.0 and per.shape == (1,)
    # trained on this path, the distance is the true one by construction of the gain
    np.testing.assert_allclose(st.morpi_track(s_train, gain).distance, 6.0, rtol=1e-12)
    # another run of the same path and speed (the Weinberg amplitude depends on the speed: f_y
    # scales with v^2, omega_z with v), with 9 periods and another sampling
    test, x = sine_path_recording(9, rate=55.0, seed=11, name="test.csv")
    tr = st.morpi_track(st.extract_steps(test, method, cfg, rest_end_time=test.time[0] + 2.0), gain)
    # partial end steps are counted by time fraction: the end estimate is good to a few % of one
    # period (1 m) over 9 m; 2 % of the distance is the bar
    assert tr.distance == pytest.approx(9.0, rel=0.02)
    if segment == "maxima":
        # mean heading over a whole period of the symmetric path is zero: the end point is on the x axis
        expected_x = 9.0
    else:
        # half periods alternate a mean heading of +-psi_bar, so each step is shortened by cos(psi_bar),
        # psi_bar = mean over theta in (0, pi) of atan(A k sin(theta)) (uniform in theta at constant
        # forward speed); the gain only makes the summed lengths right
        ak = 0.1 * 2 * np.pi
        psi_bar = quad(lambda th: np.arctan(ak * np.sin(th)), 0.0, np.pi)[0] / np.pi
        expected_x = 9.0 * np.cos(psi_bar)
    assert np.linalg.norm(tr.end_point - [expected_x, 0.0]) < 0.02 * 9.0


def test_dead_reckon_follows_the_heading():
    pos = st.dead_reckon([1.0, 1.0, 2.0], np.radians([0.0, 90.0, 180.0]))
    np.testing.assert_allclose(pos, [[0, 0], [1, 0], [1, 1], [-1, 1]], atol=1e-12)  # unit steps along right angles: float rounding of cos/sin


def _rate_and_integral(t):
    """omega = a + b t + c sin(w t) and its exact integral from t[0]."""
    a, b, c, w = 0.2, -0.03, 0.5, 2.0
    omega = a + b * t + c * np.sin(w * t)
    exact = a * (t - t[0]) + 0.5 * b * (t ** 2 - t[0] ** 2) - c / w * (np.cos(w * t) - np.cos(w * t[0]))
    return omega, exact


def test_integrate_heading_against_the_closed_form_on_irregular_steps():
    errors = []
    for rate in (50.0, 100.0, 200.0):
        t = _jittered_time(10.0, rate, np.random.default_rng(5))
        omega, exact = _rate_and_integral(t)
        psi = st.integrate_heading(t, omega, psi0=0.7)
        assert psi[0] == 0.7
        err = np.max(np.abs(psi - 0.7 - exact))
        trap = np.max(np.abs(cumulative_trapezoid(omega, t, initial=0.0) - exact))
        # the end correction removes the trapezoid's dt^2 term: at least 100 times smaller here
        # (trapezoid bound dt^2/12 max|w''| T = 3e-4 at 50 Hz; the corrected rule is O(dt^4))
        assert err < trap / 100, (rate, err, trap)
        errors.append(err)
    # fourth order: halving the step divides the error by about 16; 8 (order 3) leaves room for
    # the irregular steps and the 3-point slopes
    assert errors[0] / errors[1] > 8 and errors[1] / errors[2] > 8, errors


def test_heading_and_planar_ins_read_the_gyro_the_same_way():
    from morpi_filters import strapdown

    t = _jittered_time(5.0, 80.0, np.random.default_rng(9))
    omega, _ = _rate_and_integral(t)
    w3 = np.zeros((t.size, 3))
    w3[:, 2] = omega
    ins = strapdown.ins2d(t, np.zeros((t.size, 3)), w3, psi0=0.3)
    # the same rule on the same samples: equal up to float rounding
    np.testing.assert_allclose(st.integrate_heading(t, omega, 0.3), ins.heading, rtol=0, atol=1e-13)


def test_heading_readings_differ_as_documented():
    rec, _ = sine_path_recording(5, seed=12)
    psi = np.full(rec.n, 0.5)  # a constant heading of 0.5 rad
    base = st.StepConfig(segment="maxima", ends="drop", cutoff_hz=3.0, min_swing_deg=0.0)
    s_abs = st.extract_steps(rec, "MoRPI-G", base.with_(heading="absolute"), heading=psi)
    s_chg = st.extract_steps(rec, "MoRPI-G", base.with_(heading="change"), heading=psi)
    s_mean = st.extract_steps(rec, "MoRPI-G", base.with_(heading="mean"), heading=psi)
    np.testing.assert_allclose(s_abs.heading, 0.5)  # a constant heading read back: exact up to default tolerances
    np.testing.assert_allclose(s_chg.heading, 0.0)  # the change of a constant heading is zero: default tolerances
    np.testing.assert_allclose(s_mean.heading, 0.5)  # the mean of a constant heading: default tolerances
    # a heading growing linearly (a rad/s): its mean over a step is its value at the step's middle, partial end
    # steps included. The integral (a t^2 / 2, exact on the samples: trapezoids) is read between samples
    # by linear interpolation, off by at most a h^2 / 8 at each end (h the largest sample spacing): over a
    # step of length L the mean is off by at most a h^2 / (4 L)
    t0, a = rec.time[0], 0.1
    h = np.diff(rec.time).max()
    for ends in ("fraction", "drop"):
        s = st.extract_steps(rec, "MoRPI-G", base.with_(heading="mean", ends=ends), heading=a * (rec.time - t0))
        span = s.end_time - s.start_time
        assert span.min() > 0
        err = np.abs(s.heading - a * (0.5 * (s.start_time + s.end_time) - t0))
        assert np.all(err <= a * h * h / (4 * span) + 1e-12), (ends, err)


# ----------------------------------------------------------------------------- bad input

def _rest_recording(n=2000, name="flat.csv", noise=0.0):
    rng = np.random.default_rng(6)
    t = 5.0 + np.cumsum(rng.uniform(0.008, 0.02, n))
    f = np.tile([0.0, 0.0, 9.81], (n, 1)) + noise * rng.standard_normal((n, 3))
    w = noise * 0.01 * rng.standard_normal((n, 3))
    return Recording(time=t, f=f, omega=w, source=name)


@pytest.mark.parametrize("method", tuple(st.METHODS))
@pytest.mark.parametrize("noise", [0.0, 0.02])
def test_no_periodic_motion_is_an_error_naming_the_file(method, noise):
    rec = _rest_recording(name=f"/data/rest_{noise}.csv", noise=noise)
    with pytest.raises(MorpiError, match=r"rest_.*\.csv: no periodic motion"):
        st.extract_steps(rec, method)


def test_straight_drive_is_not_periodic():
    # straight drive with lateral vibration: peaks exist but the heading does not swing
    rng = np.random.default_rng(7)
    t = _jittered_time(20.0, 100.0, rng)
    wz = 0.05 * np.sin(2 * np.pi * 3.0 * t) + 0.01 * rng.standard_normal(t.size)
    rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.81], (t.size, 1)),
                    omega=np.column_stack([np.zeros_like(t), np.zeros_like(t), wz]), source="straight.csv")
    with pytest.raises(MorpiError, match="straight.csv: no periodic motion.*heading swing"):
        st.extract_steps(rec, "MoRPI-G", st.StepConfig(cutoff_hz=None, min_period_s=0.2))


@pytest.mark.parametrize("kw, what", [
    (dict(heading="sideways"), "heading"), (dict(segment="zeros"), "segment"), (dict(ends="skip"), "ends"),
    (dict(min_period_s=0.0), "min_period_s"), (dict(prominence=-1.0), "prominence"),
    (dict(cutoff_hz=80.0), "cutoff_hz"),
])
def test_bad_config_names_the_parameter(kw, what):
    with pytest.raises(MorpiError, match=f"StepConfig.{what}="):
        st.StepConfig(**kw)


def test_bad_method_and_training():
    rec, _ = sine_path_recording(3)
    with pytest.raises(MorpiError, match="method="):
        st.extract_steps(rec, "MoRPI-X")
    with pytest.raises(MorpiError, match="no training runs"):
        st.train_gain([], 6.3)
    with pytest.raises(MorpiError, match="strictly increasing"):
        st.detect_peaks([1.0, 2.0, 1.0], [0.0, 0.0, 1.0], min_period_s=1.0)


def test_activity_span_finds_the_motion_and_ignores_a_later_tap():
    rng = np.random.default_rng(8)
    t = _jittered_time(16.0, 90.0, rng, t0=0.0)
    w = 0.001 * rng.standard_normal((t.size, 3))
    moving = (t >= 3.0) & (t < 8.0)
    w[moving] += 0.1 * rng.standard_normal((moving.sum(), 3))
    tap = (t >= 13.0) & (t < 13.2)  # the phone handled after the robot stopped
    w[tap] += 0.5 * rng.standard_normal((tap.sum(), 3))
    a, b = st.activity_span(t, w)
    # the span is read on the 100 Hz grid from 0.5 s windows: within two grid steps plus one
    # sample interval (0.02 + 0.016 s) of the true onset and end
    assert a == pytest.approx(3.0, abs=0.04)
    assert b == pytest.approx(8.0, abs=0.04)


@pytest.mark.parametrize("method", tuple(st.METHODS))
def test_noise_free_simulated_sine_distance_within_half_percent(method):
    """MoRPI on the simulator's exact sine path (noise-free IMU), gain trained on the same path.

    The training run is sampled at a uniform 100 Hz, the test run of the same path with the S6's
    irregular time stamps, so the test is not the training data again. The bar, 0.5 % of the
    distance, is the acceptance bar for the simulator; what is left is the change of peak
    values and partial-step fractions with the sampling grid.
    """
    from morpi_filters import simulate, units

    path = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1, speed_mps=0.45)

    def run(pattern, seed):
        imu = simulate.imu(path, units.LSM6DSL, np.random.default_rng(seed), sampling=pattern,
                           bias_scale=0.0, noise_scale=0.0)
        return imu.recording(0)

    train, test = run("uniform", 1), run("two-rate", 2)
    cfg = st.StepConfig()
    gain, _, _ = st.train_gain([st.extract_steps(train, method, cfg, rest_end_time=train.time[0] + 2.5)], 6.3)
    track = st.morpi_track(st.extract_steps(test, method, cfg, rest_end_time=test.time[0] + 2.5), gain)
    assert track.distance == pytest.approx(6.3, rel=0.005)  # 0.5 % of 6.3 m (3 cm): the change of peak values and step fractions with the sampling grid


# ----------------------------------------------------------------------------- the "turns" heading reading

def test_turn_stretches_take_a_turn_spread_over_several_periods_in_full():
    # boundaries every half period (extrema), heading zigzag of +-20 deg around a centreline that turns
    # by 90 deg at an even pace over three full periods (30 deg each), then keeps straight
    k = np.arange(24)
    centre = np.clip((k - 6) / 6.0, 0.0, 1.0) * 90.0
    psi = np.radians(centre + 20.0 * (-1.0) ** k)
    t = 0.5 * k
    stretches = st.turn_stretches(t, psi, np.radians(25.0), 2)
    assert len(stretches) == 1
    before, a, b, after = stretches[0]
    # the turning periods start at boundaries 6..10 (30 deg each; those starting at 5 and 11 turn by 15 deg),
    # so the stretch spans boundaries 6..12 widened by a period each side, 4..14, and the periods around it
    assert (a, b) == (2.0, 7.0) and (before, after) == (1.0, 8.0)
    # the sampled heading: the boundaries' values, linear in between; the mean over a whole period of
    # the zigzag is its centreline, so the turn comes out at 90 deg
    tt = np.linspace(0.0, t[-1], 2301)
    end = st.turn_heading([t[-1]], tt, np.interp(tt, t, psi), stretches)[0]
    assert np.degrees(end) == pytest.approx(90.0, abs=1e-6)  # exact piecewise-linear means: float rounding
    # a threshold above every period's change (30 deg plus nothing from the zigzag) finds no turn
    assert st.turn_stretches(t, psi, np.radians(31.0), 2) == []


def test_turns_reading_ignores_drift_and_zigzag_without_a_turn():
    # a zigzag of +-25 deg drifting 2 deg per period: no period turns beyond 10 deg, the turn heading stays 0
    k = np.arange(30)
    psi = np.radians(25.0 * (-1.0) ** k + 1.0 * k)
    assert st.turn_stretches(0.5 * k, psi, np.radians(10.0), 2) == []
    np.testing.assert_array_equal(st.turn_heading(0.5 * k, 0.5 * k, psi, []), 0.0)
    with pytest.raises(MorpiError, match="StepConfig.turn_deg="):
        st.StepConfig(turn_deg=0.0)


def _simulated(traj, seed, *, bias_dps=0.0, pattern="uniform"):
    """A noise-free simulated recording of `traj`, with a constant z gyro bias [deg/s] added."""
    from morpi_filters import simulate, units

    r = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(seed), sampling=pattern, bias_scale=0.0,
                     noise_scale=0.0).recording(0)
    omega = r.omega.copy()
    omega[:, 2] += np.radians(bias_dps)
    return Recording(time=r.time, f=r.f, omega=omega, source=f"sim-{seed}.csv")


def _track(train_traj, test_traj, method, heading, *, bias_dps, train_m=10.0):
    """Gain trained on a bias-free straight sine of `train_m` m, then the biased test run dead-reckoned."""
    cfg = st.StepConfig(heading=heading)
    train = _simulated(train_traj, 1)
    gain, _, _ = st.train_gain([st.extract_steps(train, method, cfg, rest_end_time=train.time[0] + 2.5)], train_m)
    test = _simulated(test_traj, 2, bias_dps=bias_dps, pattern="two-rate")
    return st.morpi_track(st.extract_steps(test, method, cfg, rest_end_time=test.time[0] + 2.5), gain)


@pytest.mark.parametrize("method", tuple(st.METHODS))
def test_turns_reading_follows_the_simulated_l_route(method):
    """The simulated L route (18 m, a 90 deg left turn of radius 1 m, 10 m) with a 0.1 deg/s z gyro bias.

    "change" points the second leg along the first and misses by about the turn (the end point
    (28, 0) against (18, 10): 14 m). "turns" ends within 1 m of the truth: the Weinberg distance
    from the 10 m training sine is 3.6 % long on this route (28.6 m of steps against the 27.6 m
    centreline, which cuts the corner), 0.65 m along the first leg and 0.36 m along the second
    (0.74 m together), and a 1.5 deg error of the turn moves the 10 m second leg's end by 0.26 m.
    """
    from morpi_filters import simulate

    L = simulate.l_route(p2p_m=1.0, amplitude_m=0.1)
    train = simulate.sine(10.0, p2p_m=1.0, amplitude_m=0.1, speed_mps=simulate.L_ROUTE_SPEED)
    truth = L.position[-1, :2]
    change = _track(train, L, method, "change", bias_dps=0.1)
    turns = _track(train, L, method, "turns", bias_dps=0.1)
    assert np.linalg.norm(change.end_point - truth) > 12.0
    assert np.linalg.norm(turns.end_point - truth) < 1.0
    # the turn itself: one stretch, 90 deg within 1.5 deg (the bias over the 8.3 s between the middles of the
    # periods around the stretch adds 0.8 deg)
    s = turns.steps
    rec = _simulated(L, 2, bias_dps=0.1, pattern="two-rate")
    psi = st.integrate_heading(rec.time, rec.omega[:, 2])
    bt = s.peaks.grid_time[s.peaks.grid_index]
    stretches = st.turn_stretches(bt, np.interp(bt, rec.time, psi), np.radians(st.StepConfig().turn_deg), 2)
    assert len(stretches) == 1
    assert np.degrees(st.turn_heading([rec.time[-1]], rec.time, psi, stretches)[0]) == pytest.approx(90.0, abs=1.5)


@pytest.mark.parametrize("method", tuple(st.METHODS))
def test_turns_reading_drifts_less_than_absolute_on_a_biased_straight_sine(method):
    """A 13 m straight sine with a 0.3 deg/s z gyro bias (a heading drift of about 8 deg over the motion).

    "absolute" bends with the drift (its end point moves sideways by about half the drift times the
    distance, 1.1 m); "turns" finds no turn, equals "change" and ends within 0.25 m (the Weinberg distance
    over 13 m from a 10 m training run): at most a third of "absolute"'s error.
    """
    from morpi_filters import simulate

    straight = simulate.sine(13.0, p2p_m=1.0, amplitude_m=0.1, speed_mps=simulate.L_ROUTE_SPEED)
    train = simulate.sine(10.0, p2p_m=1.0, amplitude_m=0.1, speed_mps=simulate.L_ROUTE_SPEED)
    truth = straight.position[-1, :2]
    absolute = _track(train, straight, method, "absolute", bias_dps=0.3)
    turns = _track(train, straight, method, "turns", bias_dps=0.3)
    change = _track(train, straight, method, "change", bias_dps=0.3)
    e_abs = np.linalg.norm(absolute.end_point - truth)
    e_turns = np.linalg.norm(turns.end_point - truth)
    np.testing.assert_array_equal(turns.steps.heading, change.steps.heading)
    assert e_turns < 0.25 and e_turns < e_abs / 3, (e_turns, e_abs)


def test_step_sums_are_the_steps_own_sums_for_every_reading_and_refuse_the_same_runs():
    import math

    from morpi_filters import simulate

    plain = plain_kernels(_loops)
    eps = np.finfo(float).eps
    L = simulate.l_route(p2p_m=1.0, amplitude_m=0.1)
    rec = _simulated(L, 2, bias_dps=0.1, pattern="two-rate")
    turning = 0
    for method in st.METHODS:
        cache = {}
        for heading, segment, ends in itertools.product(st.HEADINGS, st.SEGMENTS, st.ENDS):
            cfg = st.StepConfig(heading=heading, segment=segment, ends=ends, turn_deg=45.0)
            prep = st.prepare_signal(rec, method, cfg.cutoff_hz)
            # sums first, then the steps: each fills the memo the other reads
            w, ux, uy, swing, n = st.step_sums(prep, method, cfg, peak_cache=cache)
            s = st.extract_steps(None, method, cfg, prepared=prep, peak_cache=cache)
            assert swing == s.swing_deg and n == s.n
            # the compiled loop sums the steps' own terms in step order: against the exact (fsum) sums of the
            # Steps' terms, the rounding of n additions and of each product and cosine (a few ulp each)
            wf = s.weight * s.fraction
            for got, terms in ((w, wf), (ux, wf * np.cos(s.heading)), (uy, wf * np.sin(s.heading))):
                assert abs(got - math.fsum(terms)) <= (n + 4) * eps * np.abs(terms).sum(), (heading, segment, ends)
            end = st.morpi_track(s, 1.0).end_point
            np.testing.assert_allclose([ux, uy], end, rtol=0, atol=1e-12 * s.effective_weight)
            turning += heading == "turns" and bool(np.any(s.heading != st.extract_steps(
                None, method, cfg.with_(heading="change"), prepared=prep, peak_cache=cache).heading))
            # the compiled loop gives the plain Python loop's bits
            pkey, _, bt, psi_b, psi_m, per, _, weight, _, wmed = stx._boundaries(prep, method, cfg, cache)
            edge = stx._edge_values(prep, cfg, pkey, bt, psi_b) if heading in ("turns", "mean") else np.zeros(0)
            assert plain.reading_sums(bt, psi_b, weight, edge, *prep.motion, *psi_m, per, wmed,
                                      stx._ENDS_CODES[ends], stx._HEADING_CODES[heading]) == (w, ux, uy, n)
    assert turning == 2 * len(st.SEGMENTS) * len(st.ENDS)        # the L route's turn enters every turns reading
    # the L route turns: the turns reading's integral, given or computed, gives the same heading
    prep = st.prepare_signal(rec, "MoRPI-G", 3.0)
    bt = prep.grid[::400]
    stretches = st.turn_stretches(bt, np.interp(bt, prep.time, prep.heading), np.radians(45.0), 2)
    assert stretches
    a = st.turn_heading(prep.grid, prep.time, prep.heading, stretches)
    b = st.turn_heading(prep.grid, prep.time, prep.heading, stretches, integral=prep.heading_integral)
    assert np.array_equal(a, b)
    with pytest.raises(MorpiError, match="integral of shape"):
        st.turn_heading(prep.grid, prep.time, prep.heading, stretches, integral=prep.heading_integral[1:])
    # what extract_steps refuses, step_sums refuses with the same message
    flat = _rest_recording(name="/data/flat.csv", noise=0.02)
    cfg = st.DEFAULT_CONFIGS["MoRPI-G"]
    prep = st.prepare_signal(flat, "MoRPI-G", cfg.cutoff_hz)
    with pytest.raises(MorpiError) as a:
        st.extract_steps(None, "MoRPI-G", cfg, prepared=prep)
    with pytest.raises(MorpiError) as b:
        st.step_sums(prep, "MoRPI-G", cfg)
    assert str(a.value) == str(b.value) and "flat.csv: no periodic motion" in str(a.value)
    with pytest.raises(MorpiError, match="does not match"):
        st.step_sums(prep, "MoRPI-G", cfg.with_(cutoff_hz=cfg.cutoff_hz / 2))


def test_interp_and_swing_kernels_are_numpys_within_rounding():
    # numpy interpolates as slope * (x - xp[j]) + fp[j] (or from j + 1), the loop perhaps otherwise: a few roundings
    # of at most the two neighbours' size each on each side (a slope's three, the product's two, the sum's one:
    # 12 u (|fp[j]| + |fp[j + 1]|) for both); where a neighbour is not finite the result is one of numpy's
    # fallbacks (a neighbour's value, inf or NaN), chosen without arithmetic: compared exactly
    from oracles.sums import U, assert_within

    plain = plain_kernels(_loops)
    rng = np.random.default_rng(8)
    t = np.cumsum(rng.uniform(0.005, 0.02, 3000))
    psi = np.cumsum(rng.normal(0.0, 0.01, 3000))
    # inside, outside, on the samples, on the last sample; a step and a NaN in fp
    mid = 0.5 * (t[:-1] + t[1:])
    x = np.concatenate([rng.uniform(t[0] - 1, t[-1] + 1, 500), t[::7], t[-1:], [t[0] - 5, t[-1] + 5],
                        mid[[99, 100, 105, 109, 110, 499, 500, 501, 1999, 2000]]])
    fp = psi.copy()
    fp[100:110] = 3.0
    fp[500:502] = np.inf                                         # inf - inf: numpy's fallbacks
    fp[2000] = np.nan
    for f in (plain.interp1, _loops.compiled()["interp1"]):
        for values in (psi, fp):
            with np.errstate(invalid="ignore"):                  # inf - inf in the plain loop's numpy scalars
                out = np.array([f(v, t, values) for v in x])
            j = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
            a, b = values[j], values[j + 1]
            finite = np.isfinite(a) & np.isfinite(b)
            with np.errstate(invalid="ignore"):
                bound = np.where(finite, 12.0 * U * (np.abs(a) + np.abs(b)), 0.0)
            assert_within(out, np.interp(x, t, values), bound, "interp")

    def numpy_swing(at):
        bi = np.searchsorted(t, at)
        if bi.size < 2:
            return float("nan")
        return stp.small_median(np.degrees(np.maximum.reduceat(psi, bi[:-1])[:bi.size - 1]
                                     - np.minimum.reduceat(psi, bi[:-1])[:bi.size - 1]))

    # peaks a sample apart, two peaks on one sample (a window of none), an odd and an even count
    at = np.sort(rng.uniform(t[0], t[-1], 41))
    cases = [at, at[:-1], np.sort(np.r_[at, at[5], t[10] + 1e-4, t[10] + 2e-4]), at[:2], at[:1],
             np.array([t[10] + 1e-4, t[10] + 2e-4, t[50]])]
    for f in (plain.swing_median, _loops.compiled()["swing_median"]):
        for a in cases:
            # a window's max and min are samples and their difference one rounding, the same on both sides;
            # degrees (one product) and the median of two (a sum and a halving) may round otherwise: 3 u each side
            want = numpy_swing(a)
            got = f(t, psi, a)
            assert (np.isnan(want) and np.isnan(got)) or abs(got - want) <= 6.0 * U * abs(want), (a.size, got, want)


def _turn_heading_bound(t, psi, integral, stretches) -> float:
    """How far two correct evaluations of turn_heading may differ: each linear interpolation (np.interp against
    the kernel's own) is within 4 eps of its values' magnitude (a subtraction, a product, a division and an
    addition, each correctly rounded: Higham, lemma 3.1), of psi (`dp`) or of its running integral (`dc`). A
    turn is a difference of two window means (each two interpolations of the integral over the window, or one
    of psi for an empty window); the share done of a turn is (psi(x) - pa) / (pb - pa) clipped to [0, 1], three
    interpolations over |pb - pa|; the clip only narrows a difference."""
    eps = np.finfo(float).eps
    dp, dc = 4 * eps * np.max(np.abs(psi)), 4 * eps * np.max(np.abs(integral))

    def mean(x0, x1):
        if x1 - x0 <= 1e-9:
            return float(np.interp(x0, t, psi)), dp
        return float((np.interp(x1, t, integral) - np.interp(x0, t, integral)) / (x1 - x0)), 2 * dc / (x1 - x0)

    total = 0.0
    for before, a, b, after in stretches:
        (m1, e1), (m0, e0) = mean(b, after), mean(before, a)
        pa, pb = np.interp([a, b], t, psi)
        total += e1 + e0 + (abs(m1 - m0) * 3 * dp / abs(pb - pa) if pb != pa else 0.0)
    return total


def test_turn_values_kernel_is_turn_heading_of_turn_stretches_within_the_rounding_of_interpolation():
    plain = plain_kernels(_loops)
    rng = np.random.default_rng(17)
    t = np.cumsum(rng.uniform(0.005, 0.02, 4000))
    stretches_seen = set()
    for case in range(60):
        # a zigzag heading with a few turns of random size and length (some merge, some stay apart)
        psi = 0.3 * np.sin(2 * np.pi * t / rng.uniform(0.5, 2.0))
        for _ in range(int(rng.integers(0, 5))):
            t0, dur, size = rng.uniform(t[0], t[-1]), rng.uniform(0.2, 8.0), rng.uniform(-2.0, 2.0)
            psi = psi + size * np.clip((t - t0) / dur, 0.0, 1.0)
        if case % 10 == 0:
            psi[1500:2500] = psi[1500]                              # a flat stretch: pb == pa
        integral = stp.running_integral(t, psi)
        bt = np.sort(rng.choice(t[50:-50], int(rng.integers(2, 120)), replace=False))
        psi_b = np.interp(bt, t, psi)
        x = np.concatenate([[t[10]], bt, [t[-10]]])
        for per_period, threshold in ((1, 0.4), (2, 0.4), (2, 1.5), (1, 0.05)):
            stretches = st.turn_stretches(bt, psi_b, threshold, per_period)
            stretches_seen.add(min(len(stretches), 3))
            want = st.turn_heading(x, t, psi, stretches, integral=integral)
            bound = _turn_heading_bound(t, psi, integral, stretches)
            for f in (_loops.compiled()["turn_values"], plain.turn_values):
                out = np.empty(x.shape[0])
                assert f(bt, psi_b, threshold, per_period, x, t, psi, integral, out) == len(stretches)
                np.testing.assert_allclose(out, want, rtol=0.0, atol=bound)
    assert stretches_seen == {0, 1, 2, 3}                           # none, one, several stretches
    # a stretch that starts and ends on the same heading (pb == pa) with a turn around it: the turn is
    # taken whole at the stretch's end, which is one of the edges read
    bt = np.arange(7.0)
    psi_b = np.array([0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0])
    tt = np.linspace(0.0, 6.0, 601)
    pp = np.interp(tt, bt, psi_b)
    integral = stp.running_integral(tt, pp)
    stretches = st.turn_stretches(bt, psi_b, 1.5, 1)
    assert stretches == [(0.0, 1.0, 5.0, 6.0)]
    want = st.turn_heading(bt, tt, pp, stretches, integral=integral)
    assert want[5] != 0.0 and want[4] == 0.0
    for f in (_loops.compiled()["turn_values"], plain.turn_values):
        out = np.empty(7)
        f(bt, psi_b, 1.5, 1, bt, tt, pp, integral, out)
        np.testing.assert_allclose(out, want, rtol=0.0, atol=_turn_heading_bound(tt, pp, integral, stretches))
        assert out[4] == 0.0                                    # before the stretch's end: exactly none of the turn


def test_window_spread_kernel_is_the_numpy_running_sums_within_their_rounding():
    # the loop and numpy's cumsum add the same running sums, each within Higham's bound of the exact ones,
    # carried through the window difference and the square root (oracles.sums.window_spread)
    from oracles import sums

    plain = plain_kernels(_loops)
    rng = np.random.default_rng(23)
    # gyro-like noise, on offsets (cancellation in E[x^2] - E[x]^2: clipped at 0), a constant column
    for w in (0.01 * rng.normal(size=(3000, 3)), 5.0 + 1e-4 * rng.normal(size=(500, 3)),
              np.c_[np.full(400, 0.3), rng.normal(size=(400, 2))]):
        for k in (2, 3, 50, w.shape[0]):
            want, mean, d_sd, d_mean = sums.window_spread(w, k)
            for f in (_loops.compiled()["window_spread"], plain.window_spread):
                sd, means = np.empty(w.shape[0] - k + 1), np.empty((w.shape[0] - k + 1, 3))
                f(w, k, sd, means)
                sums.assert_within(sd, want, d_sd, f"spread, k {k}")
                sums.assert_within(means, mean, d_mean, f"mean, k {k}")
            sums.assert_within(stp.window_spread(w, k)[1], mean, d_mean, f"window_spread, k {k}")


def test_reading_sums_kernel_by_hand():
    import math

    plain = plain_kernels(_loops)
    bt, psi_b, weight = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.1, 0.2]), np.array([2.0, 3.0])
    # the motion starts on the first boundary (an empty first step) and ends half a median step after the last
    m0, m1, psi_m0, psi_m1, per, wmed = 1.0, 3.5, 0.0, 0.3, 1.0, 2.5
    integral = np.array([0.0, 0.0, 0.05, 0.2, 0.3])              # at [m0, bt..., m1]
    turn = np.array([0.0, 0.0, 0.7, 0.7, 0.7])
    cases = [  # (ends, heading, aux, [(weight * fraction, heading) per step])
        (0, 0, np.zeros(0), [(2.0, 0.1), (3.0, 0.2)]),
        (0, 1, np.zeros(0), [(2.0, 0.1), (3.0, 0.1)]),
        (0, 2, turn, [(2.0, 0.1 + 0.0), (3.0, 0.1 + 0.7)]),
        (0, 3, integral, [(2.0, 0.05), (3.0, 0.15)]),
        # fraction: the empty first step counts 0 of a step, with the heading at its start (no 0 / 0)
        (1, 3, integral, [(0.0, 0.0), (2.0, 0.05), (3.0, 0.15), (1.25, 0.1 / 0.5)]),
        (1, 0, np.zeros(0), [(0.0, 0.0), (2.0, 0.1), (3.0, 0.2), (1.25, 0.3)]),
        # whole: half a step or more counts as one
        (2, 2, turn, [(0.0, 0.0 + 0.0), (2.0, 0.1 + 0.0), (3.0, 0.1 + 0.7), (2.5, 0.1 + 0.7)]),
    ]
    eps = np.finfo(float).eps
    for ends, heading, aux, steps in cases:
        wf = [a for a, _ in steps]
        want = (math.fsum(wf), math.fsum(a * math.cos(h) for a, h in steps),
                math.fsum(a * math.sin(h) for a, h in steps), len(steps))
        for f in (plain.reading_sums, _loops.compiled()["reading_sums"]):
            got = f(bt, psi_b, weight, aux, m0, m1, psi_m0, psi_m1, per, wmed, ends, heading)
            assert got[3] == want[3] and all(math.isfinite(v) for v in got[:3]), (ends, heading, got)
            # at most 4 terms added in order against their exact sum: a few roundings of numbers below 10
            np.testing.assert_allclose(got[:3], want[:3], rtol=8 * eps, atol=8 * eps, err_msg=str((ends, heading)))


def test_peaks_shared_across_prominence_thresholds_are_scipys_own():
    from scipy.signal import find_peaks

    rec, _ = sine_path_recording(8, seed=21)
    prep = st.prepare_signal(rec, "MoRPI-G", 3.0)
    i0, i1 = prep.motion_index
    seg = prep.filtered[i0:i1]
    cache, counts = {}, set()
    # thresholds up and down, each against scipy called afresh with that threshold
    for prominence in (0.5, 0.05, 0.35, 0.9, 0.2, 0.0):
        cfg = st.StepConfig(heading="absolute", prominence=prominence, min_swing_deg=0.0)
        s = st.extract_steps(None, "MoRPI-G", cfg, prepared=prep, peak_cache=cache)
        prom = prominence * (prep.span[1] - prep.span[0])
        dist = int(round(cfg.min_period_s * st.GRID_HZ))
        expected = np.sort(np.concatenate([find_peaks(seg, distance=dist, prominence=prom)[0],
                                           find_peaks(-seg, distance=dist, prominence=prom)[0]])) + i0
        np.testing.assert_array_equal(s.peaks.grid_index, expected)
        counts.add(expected.size)
    assert len(counts) > 2                                      # the thresholds do select different peaks


def test_a_derived_rule_is_one_object_and_a_bad_change_is_refused_every_time():
    base = st.StepConfig(heading="turns")
    a = base.with_(prominence=0.2, ends="whole")
    assert a is base.with_(ends="whole", prominence=0.2)          # the searches' caches find it by identity
    assert (a.prominence, a.ends, a.heading) == (0.2, "whole", "turns") and base.prominence == 0.35
    assert a == st.StepConfig(heading="turns", prominence=0.2, ends="whole")
    for _ in range(2):
        with pytest.raises(MorpiError, match="StepConfig.prominence"):
            base.with_(prominence=-1.0)
        with pytest.raises(MorpiError, match="StepConfig.heading"):
            base.with_(heading=["mean"])                          # not hashable: checked all the same


def test_a_rule_keys_caches_by_its_fields_in_this_process_and_after_a_pickle_from_another():
    import os
    import pickle
    import subprocess
    import sys

    a = st.StepConfig(heading="turns", prominence=0.2)
    b = st.StepConfig().with_(prominence=0.2).with_(heading="turns")     # equal fields, another object
    cache = {a: "steps of a"}
    assert b == a and hash(b) == hash(a) and cache[b] == "steps of a"
    assert b.with_(prominence=0.35) not in cache
    # a rule hashed and pickled by a process with another string-hash seed must still find its equal here
    code = ("import pickle, sys; from morpi_filters.steps import StepConfig; "
            "c = StepConfig(heading='turns', prominence=0.2); hash(c); sys.stdout.buffer.write(pickle.dumps(c))")
    for seed in ("1", "2"):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, check=True,
                             env=dict(os.environ, PYTHONHASHSEED=seed)).stdout
        assert cache[pickle.loads(out)] == "steps of a"
