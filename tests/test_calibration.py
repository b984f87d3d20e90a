"""Rest detection and zero-order calibration on synthetic data with known truth and on the field data."""
from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest

from morpi_filters import _calibration_loops, simulate, units
from morpi_filters.calibration import (DEFAULT_IMU, STILL_NOISE_FACTOR, Calibration, NoRestError,
                                       RestWindow, StillBound, calibrate, detect_rest, normal_gravity,
                                       rest_measures, rest_windows_summary, still_bound)
from morpi_filters.choice import choose
from morpi_filters.dataset import Recording, folder_imu, load_catalogue
from morpi_filters.errors import DataError, MorpiError
from morpi_filters.synthetic import DATASET_OPTIONS, PHONE_CLOCKS
from morpi_filters.report.calibration import rest_windows_table
from conftest import plain_kernels

GYRO_BIAS = np.array([0.012, -0.021, 0.0305])   # rad/s, of the order of the field recordings' biases
ACCEL_BIAS = np.array([0.15, -0.22, 0.09])      # m/s^2
SIG_G = 6e-4                                    # rad/s, white gyro noise per sample (S8-like)
SIG_A = 9e-3                                    # m/s^2, white accel noise per sample (S8 datasheet x sqrt(50 Hz))


def synthetic(rng, *, rest_s=3.5, total_s=8.0, tap=None, g=units.G0):
    """Level phone at rest (f = (0, 0, g) + bias + noise), then a sine yaw/forward motion.

    Time steps are non-uniform (0.0095 to 0.0125 s). Returns the recording and
    the index of the first moving sample.
    """
    n = int(total_s / 0.011) + 1
    t = 12.5 + np.cumsum(rng.uniform(0.0095, 0.0125, n))
    tau = t - t[0]
    f = np.array([0.0, 0.0, g]) + ACCEL_BIAS + SIG_A * rng.standard_normal((n, 3))
    w = GYRO_BIAS + SIG_G * rng.standard_normal((n, 3))
    move = tau >= rest_s
    s = tau[move] - rest_s
    w[move, 2] += 0.6 * np.sin(2 * np.pi * 0.8 * s) + 0.05   # yaw rate of a sine path [rad/s]
    w[move, 0] += 0.05 * np.sin(2 * np.pi * 7.0 * s)         # roll vibration
    f[move, 0] += 1.0 * np.cos(2 * np.pi * 0.8 * s)          # forward acceleration
    if tap is not None:
        a, b = tap
        hit = (tau >= a) & (tau < b)
        w[hit] += 0.03 * np.sin(2 * np.pi * 15.0 * tau[hit])[:, None]
    rec = Recording(time=t, f=f, omega=w, source="synthetic.csv")
    return rec, int(np.argmax(move)) if move.any() else None


def test_rest_window_and_biases_recovered():
    rng = np.random.default_rng(11)
    rec, onset = synthetic(rng)
    w = detect_rest(rec)
    assert isinstance(w, RestWindow)
    assert w.method == "full" and w.i0 == 0
    assert 2.95 <= w.duration_s <= 3.0                  # capped at the paper's 3 s (one sample ~0.0125 s)
    # Motion onset: the refined onset is the first sample whose gyro leaves the 6-sigma band;
    # the sine starts at zero but the 0.05 rad/s offset (83 sigma) crosses it at once.
    assert abs(rec.time[onset] - w.motion_s) <= 3 * 0.0125   # within 3 samples
    cal = calibrate(rec, "GAC", window=w)
    # Noise bound: the mean of N white samples has sigma/sqrt(N); 4 of those is the tolerance.
    n = w.n
    assert np.all(np.abs(cal.gyro_bias - GYRO_BIAS) < 4 * SIG_G / math.sqrt(n))
    assert np.all(np.abs(cal.accel_bias - ACCEL_BIAS) < 4 * SIG_A / math.sqrt(n))


def test_motion_at_1_2_s_is_found_and_window_ends_before_it():
    rng = np.random.default_rng(12)
    rec, onset = synthetic(rng, rest_s=1.2)
    w = detect_rest(rec)
    t_on = rec.time[onset]
    assert w.method == "detected" and "motion starts" in w.note
    assert w.end_s < t_on                               # the window never contains motion
    assert t_on - w.end_s <= 0.05 + 4 * 0.0125          # guard_s plus at most 4 samples
    assert abs(w.motion_s - t_on) <= 3 * 0.0125         # onset within 3 samples
    cal = calibrate(rec, "GC", window=w)
    assert np.all(np.abs(cal.gyro_bias - GYRO_BIAS) < 4 * SIG_G / math.sqrt(w.n))


def test_short_rest_is_used_and_said():
    rng = np.random.default_rng(13)
    rec, onset = synthetic(rng, rest_s=0.5)
    w = detect_rest(rec)
    assert w.method == "short" and "min_window_s" in w.note
    assert w.end_s < rec.time[onset]


def test_initial_tap_is_skipped():
    rng = np.random.default_rng(14)
    rec, onset = synthetic(rng, rest_s=4.5, tap=(0.2, 0.7))
    w = detect_rest(rec)
    tau0 = w.start_s - rec.time[0]
    assert 0.7 <= tau0 <= 0.7 + 0.125 + 0.05 + 0.0125   # after the tap: half a window plus guard plus a step
    assert w.i0 > 0 and "disturbance" in w.note
    assert abs(w.motion_s - rec.time[onset]) <= 3 * 0.0125
    cal = calibrate(rec, "GC", window=w)
    assert np.all(np.abs(cal.gyro_bias - GYRO_BIAS) < 4 * SIG_G / math.sqrt(w.n))


def test_motion_from_first_sample_raises_naming_file():
    rng = np.random.default_rng(15)
    rec, _ = synthetic(rng, rest_s=0.0)
    with pytest.raises(MorpiError, match="synthetic.csv: no initial rest"):
        detect_rest(rec)
    with pytest.raises(MorpiError, match="synthetic.csv"):
        calibrate(rec, "GC")


def _cut(rec, n):
    """The first `n` samples of a recording."""
    return Recording(time=rec.time[:n], f=rec.f[:n], omega=rec.omega[:n], source=rec.source)


@pytest.mark.parametrize("tap", [None, (1.0, 1.3)])
def test_every_length_gives_a_window_or_one_line_naming_the_file(tap):
    # Every cut of a recording (3.5 s of rest, optionally a tap, then the motion), from one sample to all
    # of them: a window inside the cut, or a DataError of one line naming the file and the length needed;
    # never another exception.
    rng = np.random.default_rng(20)
    rec, onset = synthetic(rng, rest_s=3.5, total_s=6.0, tap=tap)
    kinds = set()
    for n in range(1, rec.n + 1):
        try:
            w = detect_rest(_cut(rec, n))
        except DataError as exc:
            msg = str(exc)
            assert "\n" not in msg and msg.startswith("synthetic.csv: ") and "needed" in msg, (n, msg)
            kinds.add("too short" if "too short" in msg else msg)
            continue
        assert 0 <= w.i0 < w.i1 <= n and w.n >= 10, (n, w)
        kinds.add("rest only" if w.motion_s is None else "motion")
    # the cuts inside the rest give a window, those into the first 1.5 s of the motion (and, with the tap,
    # those into it or just after it) are too short, the longer ones find the motion
    assert kinds == {"too short", "rest only", "motion"}


def test_a_recording_cut_inside_its_first_movement_says_how_long_it_must_be():
    # The message names the time the recording must reach (the movement's start plus sustain_s, to its
    # 0.01 s): every cut ending before it is refused, every cut reaching it finds the motion.
    for seed in range(20, 26):
        rng = np.random.default_rng(seed)
        rec, onset = synthetic(rng, rest_s=3.5, total_s=8.0)
        tau = rec.time - rec.time[0]
        with pytest.raises(DataError) as ei:
            detect_rest(_cut(rec, onset + 40))                    # 0.4 s into the motion
        msg = str(ei.value)
        m = re.search(r"into a movement that starts at ([0-9.]+) s, .* at least ([0-9.]+) s "
                      r"\(about (\d+) samples\) needed$", msg)
        assert m and "\n" not in msg and msg.startswith("synthetic.csv: "), msg
        start, need_s, need_n = float(m[1]), float(m[2]), int(m[3])
        # the movement is flagged from half a centred window (0.125 s) before the motion, to a time step
        assert 0.0 < tau[onset] - start <= 0.125 + 0.0125 + 0.005
        assert need_s == pytest.approx(start + 1.5, abs=0.011)   # both printed to 0.01 s
        short = int(np.searchsorted(tau, need_s - 0.005, side="left"))      # last sample before the time
        enough = int(np.searchsorted(tau, need_s + 0.005, side="left")) + 1  # first sample after it
        for n in [*range(onset + 10, short, 7), short]:
            with pytest.raises(DataError, match="too short"):
                detect_rest(_cut(rec, n))
        for n in (enough, enough + 1, rec.n):
            assert detect_rest(_cut(rec, n)).motion_s == detect_rest(rec).motion_s
        # the sample count is that time at the median rate: a few samples off at most (0.0095-0.0125 s steps)
        assert abs(need_n - enough) <= 3, (need_n, enough)


def test_rd_changes_nothing_and_gac_levels_the_rest():
    rng = np.random.default_rng(16)
    rec, _ = synthetic(rng)
    rd = calibrate(rec, "RD")
    out = rd.apply(rec)
    assert rd.window is None
    # exact: RD does no arithmetic on the readings (and GC subtracts no accelerometer bias: 0.0 exactly)
    np.testing.assert_array_equal(out.f, rec.f)
    np.testing.assert_array_equal(out.omega, rec.omega)
    np.testing.assert_array_equal(out.time, rec.time)
    gac = calibrate(rec, "GAC")
    fixed = gac.apply(rec)
    sl = slice(gac.window.i0, gac.window.i1)
    # Exact by construction up to float rounding of a mean of ~300 values near 9.8 (1e-12 m/s^2).
    np.testing.assert_allclose(fixed.f[sl].mean(axis=0), [0.0, 0.0, units.G0], rtol=0, atol=1e-12)   # the default g
    np.testing.assert_allclose(fixed.omega[sl].mean(axis=0), 0.0, rtol=0, atol=1e-15)
    gc = calibrate(rec, "GC")
    np.testing.assert_array_equal(gc.accel_bias, 0.0)
    np.testing.assert_array_equal(gc.apply(rec).f, rec.f)
    assert isinstance(gac, Calibration) and rec.f is not fixed.f    # input untouched


def test_custom_gravity():
    rng = np.random.default_rng(17)
    rec, _ = synthetic(rng, g=9.81)
    gac = calibrate(rec, "GAC", g_local=9.81)
    np.testing.assert_allclose(gac.apply(rec).f[gac.window.i0:gac.window.i1].mean(axis=0),
                               [0, 0, 9.81], rtol=0, atol=1e-12)  # GAC subtracts the window mean: float rounding


@pytest.mark.parametrize("kwargs, match", [(dict(calibration="XYZ"), "calibration='XYZ'"),
                                           (dict(calibration="GAC", g_local=-1.0), "g_local")])
def test_bad_parameters(kwargs, match):
    rng = np.random.default_rng(18)
    rec, _ = synthetic(rng)
    with pytest.raises(MorpiError, match=match):
        calibrate(rec, **kwargs)
    with pytest.raises(MorpiError, match="min_window_s"):
        detect_rest(rec, min_window_s=5.0, max_window_s=3.0)


def test_rest_measured_once_gives_the_same_windows_for_every_threshold():
    # The window found from stored measures must be the one detect_rest finds measuring itself, whatever the
    # thresholds: a tap (window starts after it), an early motion, and floors that move the window
    rng = np.random.default_rng(19)
    rec, _ = synthetic(rng, rest_s=2.5, tap=(0.2, 0.35))
    m = rest_measures(rec)
    windows = set()
    for kw in (dict(), dict(accel_floor=0.0), dict(accel_floor=0.02), dict(accel_floor=1e9), dict(k_std=2.0),
               dict(k_dev=3.0, guard_s=0.1), dict(sustain_s=0.5, min_window_s=0.5)):
        w = detect_rest(rec, measures=m, **kw)
        assert w == detect_rest(rec, **kw)
        windows.add((w.i0, w.i1))
    assert len(windows) > 1                              # the thresholds did move the window
    # measures taken with other parameters, or on another recording, are refused
    with pytest.raises(MorpiError, match="measures: taken with .*window_s=0.5"):
        detect_rest(rec, measures=rest_measures(rec, window_s=0.5))
    other, _ = synthetic(rng, total_s=6.0)
    with pytest.raises(MorpiError, match="synthetic.csv"):
        detect_rest(other, measures=m)
    with pytest.raises(MorpiError, match="window_s=0"):
        rest_measures(rec, window_s=0.0)


def test_normal_gravity_reference_values():
    # NIMA TR8350.2 Table 3.4: gamma_e = 9.7803253359, gamma_p = 9.8321849378 m/s^2.
    assert normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity(90.0) == pytest.approx(9.8321849378, abs=1e-9)
    # Free-air gradient about -3.086e-6 s^-2 at mid latitudes (first-order term of eq. 4-3).
    dg = normal_gravity(32.8, 100.0) - normal_gravity(32.8)
    assert dg == pytest.approx(-3.086e-4, rel=0.01)
    assert 9.795 < normal_gravity(32.8) < 9.796                   # the MoRPI site (its manifest's latitude_deg)
    with pytest.raises(MorpiError, match="latitude"):
        normal_gravity(91.0)


def test_summary_counts_and_shift():
    rng = np.random.default_rng(19)
    still, _ = synthetic(rng)
    early, _ = synthetic(rng, rest_s=1.2)
    moving, _ = synthetic(rng, rest_s=0.0)
    summary = rest_windows_summary([still, early, moving])
    assert (summary.n_total, summary.n_moving_early, summary.n_disturbed) == (3, 2, 0)
    a, b, c = summary.rows
    assert a.method == "full" and a.motion_s == pytest.approx(3.5, abs=3 * 0.0125)  # three time steps of at most 0.0125 s (the synthetic grid)
    # Same samples averaged twice (up to the last ~half sample): floating rounding only.
    assert a.gyro_shift < 1e-3 * SIG_G
    # With motion from 1.2 s the first 3 s average in the yaw-rate sine (0.6 rad/s amplitude, 0.05 offset):
    # the shift is of the order of 0.1 rad/s, far above the 4 sigma/sqrt(N) noise bound.
    assert b.gyro_shift > 0.01
    assert c.method == "none" and "no initial rest" in c.error
    js = summary.to_json()
    assert js["n_total"] == 3 and js["rows"][1]["method"] == "detected"
    assert rest_windows_table(summary).count("\n") == 5


@pytest.mark.field
def test_field_every_recording_gets_a_window(field_root):
    recs = load_catalogue(field_root)
    assert len(recs) == 143
    summary = rest_windows_summary(recs)
    errors = [r.error for r in summary.rows if r.error]
    assert errors == []
    for rec, row in zip(recs, summary.rows):
        w = detect_rest(rec)
        assert w.duration_s <= 3.0 + 1e-9 and w.n >= 10
        # Rest is rest: over the window the gyro scatter stays far below the robot's motion
        # (windowed gyro standard deviations during the drives are >= 0.03 rad/s).
        assert rec.omega[w.i0:w.i1].std(axis=0).max() < 0.01, rec.name
        if w.motion_s is not None:
            assert w.end_s < w.motion_s
    worst = max(summary.rows, key=lambda r: r.gyro_shift)
    print(f"\n{summary.n_moving_early} of {summary.n_total} recordings move within their first 3 s; "
          f"{summary.n_disturbed} start with a brief disturbance; largest first-3 s gyro bias shift "
          f"{math.degrees(worst.gyro_shift):.2f} deg/s ({worst.name})")
    assert rest_windows_table(summary).count("\n") == summary.n_total + 2


def test_noise_free_recording():
    # Simulated recordings may carry no noise at all: the exact rest and onset must still come out.
    n = 1000
    t = 1.0 + np.cumsum(np.full(n, 0.01))
    f = np.tile([0.1, 0.2, 9.9], (n, 1))
    w = np.tile(GYRO_BIAS, (n, 1))
    w[400:, 2] += 0.3 * np.sin(np.arange(600) * 0.05) + 0.02
    rec = Recording(time=t, f=f, omega=w, source="clean.csv")
    win = detect_rest(rec)
    assert win.method == "full" and win.motion_s == t[400]
    np.testing.assert_allclose(calibrate(rec, "GC").gyro_bias, GYRO_BIAS, rtol=0, atol=1e-15)  # mean of a constant bias: float rounding


# ----------------------------------------------------------------------------- stillness against the IMU's noise

def _driven(phone, *, speed, seed, rest_s=None, seconds=8.0):
    """A robot driven along a straight line (exact kinematics) seen by an IMU with the synthetic dataset's
    mounting and motion vibration: from `rest_s` seconds of rest, or (None) from its first sample on, at its
    cruise speed. `phone` "" is an IMU the library does not know (the MPU-6500's figures, uniform 100 Hz).
    The recording, its IMU data (biases, truth) and the trajectory."""
    o = DATASET_OPTIONS
    spec = folder_imu(phone) if phone else DEFAULT_IMU
    traj = simulate.straight(40.0, speed_mps=speed, ramp_s=1.0, rest_s=(rest_s or 0.0, 2.0))
    t_a = traj.start_time + 1.0 if rest_s is None else traj.time[0]      # after the 1 s ramp: at cruise speed
    data = simulate.imu(traj, spec, np.random.default_rng(seed), sampling=PHONE_CLOCKS[phone] if phone else "uniform",
                        bias_scale=0.3,
                        misalignment=o["misalignment"], vibration=o["vibration"], time_span=(t_a, t_a + seconds))
    return data.recording(source="driven.csv", phone=phone), data, traj


@pytest.mark.parametrize("phone", ["s8", "s6", ""])
def test_a_robot_driving_from_its_first_sample_has_no_rest(phone):
    # Driving at 0.5-1 m/s from the first sample, with the vibration of a driving robot: the noise the
    # detector measures on the recording is the vibration, so only the IMU's own noise tells it from rest.
    # No window is invented: detect_rest raises NoRestError naming the file, GC and GAC are refused, RD is not.
    for speed, seed in ((0.5, 1), (0.87, 2), (1.0, 3)):
        rec, data, _ = _driven(phone, speed=speed, seed=seed)
        v0 = float(np.linalg.norm(data.truth.velocity[0]))
        assert v0 == pytest.approx(speed, rel=1e-9)                   # under way at the first sample (truth)
        with pytest.raises(NoRestError) as ei:
            detect_rest(rec)
        msg = str(ei.value)
        assert "\n" not in msg and msg.startswith("driven.csv: no initial rest found: motion starts 0.000 s"), msg
        assert isinstance(ei.value, DataError) and ei.value.exit_code == 1
        b = still_bound(rec)
        assert f"{b.gyro:.3g} rad/s" in msg and b.basis in msg
        for mode in ("GC", "GAC"):
            with pytest.raises(NoRestError):
                calibrate(rec, mode)
        rd = calibrate(rec, "RD")
        assert rd.window is None and not rd.gyro_bias.any() and not rd.accel_bias.any()
        row, = rest_windows_summary([rec]).rows
        assert row.method == "none" and row.error == msg


@pytest.mark.parametrize("phone", ["s8", "s6", ""])
def test_the_same_robot_starting_at_rest_keeps_its_rest(phone):
    # The same robot, IMU and vibration, standing 2.5 s before it drives off: the window starts with the
    # recording and ends as the robot sets off (the vibration grows with the speed over the 1 s ramp: by a
    # quarter of it at most, the robot having moved under 2 mm), and its mean recovers the drawn gyro bias to
    # its noise.
    for speed, seed in ((0.5, 4), (1.0, 5)):
        rec, data, traj = _driven(phone, speed=speed, seed=seed, rest_s=2.5)
        w = detect_rest(rec)
        assert w.i0 == 0 and w.duration_s > 2.0 and w.end_s < traj.start_time + 0.25, w
        assert np.linalg.norm(data.truth.position[w.i1 - 1]) < 0.002, w
        assert w.end_s < w.motion_s <= traj.start_time + 1.0, w                 # within the ramp
        sigma = data.spec.gyro_noise / math.sqrt(float(np.median(np.diff(rec.time))))   # white noise per sample
        bias = calibrate(rec, "GC", window=w).gyro_bias
        # the window's samples are at rest: the mean is the bias up to 4 sigma / sqrt(N) of white noise
        assert np.all(np.abs(bias - data.gyro_bias) < 4 * sigma / math.sqrt(w.n)), (bias, data.gyro_bias)


def test_the_still_bound_follows_the_sensor_spec():
    # The bound is STILL_NOISE_FACTOR times the noise density over the Nyquist band (closed form), from the
    # phone's IMU, a given spec, or the default. A rest whose white gyro noise is 2 sigma of a noisy IMU's
    # spec is a rest for that spec and motion for a spec 25 times quieter; a StillBound is used as given.
    n, rate = 600, 100.0
    t = np.arange(n) / rate
    quiet = units.SensorSpec.from_datasheet("quiet", gyro_bias_deg_s=1, gyro_noise_deg_s_sqrt_hz=0.004,
                                            accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)
    noisy = units.SensorSpec.from_datasheet("noisy", gyro_bias_deg_s=1, gyro_noise_deg_s_sqrt_hz=0.1,
                                            accel_bias_mg=40, accel_noise_ug_sqrt_hz=130)
    sig_noisy = noisy.gyro_noise * math.sqrt(rate / 2)
    rng = np.random.default_rng(30)
    rec = Recording(time=t, f=[0.0, 0.0, 9.8] + 0.005 * rng.standard_normal((n, 3)),
                    omega=[0.01, -0.02, 0.005] + 2 * sig_noisy * rng.standard_normal((n, 3)), source="still.csv")
    for spec in (quiet, noisy):
        b = still_bound(rec, spec)
        assert b.gyro == pytest.approx(STILL_NOISE_FACTOR * spec.gyro_noise * math.sqrt(rate / 2), rel=1e-12)
        assert b.accel == pytest.approx(STILL_NOISE_FACTOR * spec.accel_noise * math.sqrt(rate / 2), rel=1e-12)
    assert still_bound(rec) == still_bound(rec, DEFAULT_IMU)                   # an unknown IMU
    # the recording's own IMU figures, never its phone's name
    assert still_bound(Recording(time=t, f=rec.f, omega=rec.omega, imu=units.LSM6DSL)) == still_bound(rec, units.LSM6DSL)
    assert still_bound(Recording(time=t, f=rec.f, omega=rec.omega, phone="s8")) == still_bound(rec, DEFAULT_IMU)
    w = detect_rest(rec, bound=noisy)
    assert w.method == "full" and w.motion_s is None
    with pytest.raises(NoRestError, match="still.csv: no initial rest"):
        detect_rest(rec, bound=quiet)
    assert detect_rest(rec, bound=StillBound(gyro=10 * sig_noisy, accel=0.1)) == w
    with pytest.raises(NoRestError):
        detect_rest(rec, bound=StillBound(gyro=sig_noisy, accel=0.1))
    with pytest.raises(MorpiError, match="StillBound: gyro=-1.0"):
        StillBound(gyro=-1.0, accel=0.1)


@pytest.mark.field
def test_the_train_rests_stay_within_half_the_still_bound(field_root):
    # STILL_NOISE_FACTOR is set on the train runs: inside each train run's rest window, every moving standard
    # deviation (windows lying inside the rest) stays within half the bound (a margin of two) on every gyro and
    # accelerometer axis; the noise the detector measures there, times k_std, stays below the bound (so the
    # bound moves none of their windows); and the drive's median gyro spread is far beyond it.
    import inspect

    from morpi_filters.field import FieldData

    data = FieldData(field_root)
    k_std = inspect.signature(detect_rest).parameters["k_std"].default
    worst = {"gyro": 0.0, "accel": 0.0, "noise": 0.0}
    n = 0
    for e in data.train_entries():
        rec = data._entry_recording(e)
        w, m, b = data.rest_window(rec), data.rest_measures(rec), still_bound(rec)
        half = m.window_s / 2
        inside = (rec.time - half >= w.start_s) & (rec.time + half <= w.end_s)
        assert inside.sum() > 10, e.relpath
        worst["gyro"] = max(worst["gyro"], m.s_g[inside].max() / b.gyro)
        worst["accel"] = max(worst["accel"], m.s_a[inside].max() / b.accel)
        worst["noise"] = max(worst["noise"], k_std * m.sig_g.max() / b.gyro, k_std * m.sig_a.max() / b.accel)
        a, z = data.activity(rec)
        drive = (rec.time >= a) & (rec.time <= z)
        assert np.median(m.s_g[drive].max(axis=1)) > 5 * b.gyro, e.relpath
        n += 1
    assert n == 40
    print(f"\ntrain rests against the still bound: {worst}")
    assert worst["gyro"] <= 0.5 and worst["accel"] <= 0.5 and worst["noise"] < 1.0, worst


def test_blockwise_noise_sigma_is_the_per_block_one():
    # detect_rest measures the noise of many short blocks at once; every block must give exactly
    # what noise_sigma gives on that block alone: odd and even lengths (median of one or two middle
    # values), quantized signals with many zero differences, and a constant block (no non-zero step)
    from morpi_filters.calibration import noise_sigma
    from oracles.noise import noise_sigma_blocks as _noise_sigma_blocks

    rng = np.random.default_rng(11)
    n = 400
    x = np.column_stack([rng.normal(0.0, 0.02, n),
                         np.round(rng.normal(0.0, 0.9, n)) * 0.0011,      # quantized, about one step of noise
                         np.cumsum(rng.normal(0.0, 0.01, n)) + 9.81])     # random walk around gravity
    x[300:340, 1] = 0.004                                                  # constant stretch
    blocks = [(0, 5), (5, 11), (11, 60), (60, 133), (133, 134 + 97), (300, 340), (340, 400)]
    got = _noise_sigma_blocks(x, blocks)
    want = np.array([noise_sigma(x[a:b]) for a, b in blocks])
    # numpy sums each block alone and the padded blocks all at once, perhaps in other orders: REL_SUMS
    np.testing.assert_allclose(got, want, rtol=REL_SUMS, atol=0.0)
    assert got[5, 1] == np.finfo(float).tiny                  # a constant block: the floor, a constant


def test_moving_stats_are_the_numpy_window_sums_within_the_rounding_of_the_sums():
    # the loop and numpy's cumsum add the same running sums, each within Higham's bound of the exact ones
    # (oracles.sums: gamma(k) times the sum of |terms| for a prefix of k terms, both sides), so the means and
    # spreads agree within that bound carried through the window difference, the division and the square root
    from morpi_filters.calibration import _moving_stats
    from oracles import sums

    rng = np.random.default_rng(21)
    t = np.cumsum(rng.uniform(0.002, 0.012, 3000))                # irregular steps, windows of 10 to 60 samples
    x = np.column_stack([rng.normal(size=t.size), np.full(t.size, 9.8),  # a constant column: variance clamped at 0
                         1e4 + 0.01 * rng.normal(size=t.size)])     # a large offset: the sums are taken from x[0]
    for half in (0.0, 0.125, 2.0):
        mean, std = _moving_stats(t, x, half)
        ref_mean, ref_std, d_mean, d_std = sums.moving_stats(t, x, half)
        sums.assert_within(mean, ref_mean, d_mean, f"mean, half {half}")
        sums.assert_within(std, ref_std, d_std, f"std, half {half}")
    assert np.all(std[:, 1] == 0.0)                               # a constant column: every difference is 0.0
    # the compiled loop gives the plain Python loop's bits: the same loop, the same operations in the same
    # order (numba compiles without fast-math), so exactness does not depend on numpy
    plain = plain_kernels(_calibration_loops)
    m2, s2 = np.empty_like(x[:500]), np.empty_like(x[:500])
    plain.moving_stats(t[:500], x[:500], 0.125, m2, s2)
    m1, s1 = _moving_stats(t[:500], x[:500], 0.125)
    np.testing.assert_array_equal(m1, m2)
    np.testing.assert_array_equal(s1, s2)


def test_motion_flags_are_the_numpy_comparisons():
    rng = np.random.default_rng(22)
    n = 2000
    s_g, m_g, s_a = rng.exponential(size=(n, 3)), rng.normal(size=(n, 3)), rng.exponential(size=(n, 3))
    s_g[::97, 1] = np.nan                                         # NaN compares false, as in numpy
    g_spread, g_level, g_dev, a_spread = rng.uniform(1, 4, 3), rng.normal(size=3), rng.uniform(1, 4, 3), \
        rng.uniform(1, 4, 3)
    ref = ((s_g > g_spread) | (np.abs(m_g - g_level) > g_dev)).any(axis=1) | (s_a > a_spread).any(axis=1)
    assert 0.1 < ref.mean() < 0.9                                 # both outcomes are exercised
    out = np.empty(n, dtype=bool)
    _calibration_loops.compiled()["motion_flags"](s_g, m_g, s_a, g_spread, g_level, g_dev, a_spread, out)
    np.testing.assert_array_equal(out, ref)
    plain = plain_kernels(_calibration_loops)
    out2 = np.empty(n, dtype=bool)
    plain.motion_flags(s_g, m_g, s_a, g_spread, g_level, g_dev, a_spread, out2)
    np.testing.assert_array_equal(out2, ref)


# ----------------------------------------------------------------------------- block noise kernel

def _block_kernels(compiled):
    """The block loops of ``_calibration_loops``, compiled by numba or as plain Python."""
    if compiled:
        return _calibration_loops.compiled()
    plain = plain_kernels(_calibration_loops)
    return {n: getattr(plain, n) for n in ("block_edges", "block_noise", "block_pick", "block_sigma_loops")}


#: The loops add in row order, numpy pairwise: a sum of n terms differs by at most about n * eps relative
#: (Higham, Accuracy and Stability of Numerical Algorithms, section 4.2), and a square root halves it. The
#: blocks here hold at most a few thousand samples, so 1e-10 relative lies above both with a margin; the
#: medians and quantiles are the same operations on the same values in both forms.
REL_SUMS = 1e-10


def _close(ref, got, rtol=REL_SUMS):
    for r, g in zip(ref, got, strict=True):
        assert g.dtype == r.dtype and g.shape == r.shape
        np.testing.assert_allclose(g, r, rtol=rtol, atol=0.0)


def _check_block_sigma(t, x, span, block, compiled):
    """``_block_sigma`` (and the loops run plain when not `compiled`) against the numpy oracle
    (``tests/oracles/noise.py``) within rounding; each block's sigma and spread, the quietest block's index
    and the edges too."""
    from morpi_filters.calibration import _block_sigma
    from oracles import noise

    ref = noise.block_sigma(t, x, span, block)
    _close(ref, _block_sigma(t, x, span, block))
    fns = _block_kernels(compiled)
    edges = noise.block_edges(t, span, block)
    np.testing.assert_array_equal(fns["block_edges"](t, float(span), float(block)), edges)
    blocks = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b - a >= 5]
    if not blocks:
        return
    sig = noise.noise_sigma_blocks(x, blocks)
    spread = np.array([x[a:b].std(axis=0) for a, b in blocks])
    best = choose((spread / np.maximum(sig.min(axis=0), 1e-300)).sum(axis=1))     # the tie-tolerant argmin
    k = x.shape[1]
    nc = len(edges) - 1
    bounds, s, sp = np.empty((nc, 2), np.int64), np.empty((nc, k)), np.empty((nc, k))
    nb = fns["block_noise"](x, edges, bounds, s, sp)
    assert nb == len(blocks)
    np.testing.assert_array_equal(bounds[:nb], blocks)
    np.testing.assert_allclose(s[:nb], sig, rtol=REL_SUMS, atol=0.0)
    np.testing.assert_allclose(sp[:nb], spread, rtol=REL_SUMS, atol=1e-300)
    q, med = np.empty(k), np.empty(k)
    assert fns["block_pick"](x, bounds, nb, s, sp, q, med) == best
    _close(ref, (q, med))


def test_the_quietest_block_is_the_earlier_of_two_tied_within_rounding():
    # block 1 is block 0 scaled by (1 - 1e-13): quieter by rounding only, so block 0 is kept (an argmin takes
    # block 1), in the numpy form, the compiled loops and the loops run plain; its median is block 0's
    from morpi_filters.calibration import _block_sigma
    from oracles import noise

    rng = np.random.default_rng(5)
    m = 25
    t = np.arange(4 * m) / (4 * m)                           # four blocks of 0.25 s, 25 samples each
    quiet = 0.01 * rng.standard_normal((m, 3)) + [0.1, -0.2, 0.3]
    x = np.concatenate([quiet, quiet * (1 - 1e-13), 0.5 * rng.standard_normal((2 * m, 3))])
    span, block = 1.0, 0.25
    spread = np.array([x[a:a + m].std(axis=0) for a in (0, m)])
    assert (spread[1] < spread[0]).all()                     # the argmin would take block 1
    want = np.median(quiet, axis=0)
    assert (want != np.median(x[m:2 * m], axis=0)).any()
    for compiled in (True, False):
        q, med = np.empty(3), np.empty(3)
        assert _block_kernels(compiled)["block_sigma_loops"](t, x, span, block, q, med) == 4
        assert med.tobytes() == want.tobytes()               # exact: the median of 25 values is one of them
    _close(noise.block_sigma(t, x, span, block), _block_sigma(t, x, span, block))
    assert _block_sigma(t, x, span, block)[1].tobytes() == want.tobytes()
    assert noise.block_sigma(t, x, span, block)[1].tobytes() == want.tobytes()


def test_block_noise_kernel_is_the_numpy_form_on_the_field_recordings(field_root):
    recs = load_catalogue(field_root)
    assert len(recs) == 143
    for i, rec in enumerate(recs):
        t = rec.time - rec.time[0]                               # as rest_measures passes it
        for x in (rec.omega, rec.f):
            _check_block_sigma(t, x, 3.0, 0.25, compiled=True)
            if i % 20 == 0:
                _check_block_sigma(t, x, 1.0, 0.5, compiled=False)


def _noise_signal(rng, n, kind):
    """(n, 3) samples: noise on offsets large enough that the summation order shows in the last bits."""
    x = np.array([1e4, -3.0, 9.81]) + rng.standard_normal((n, 3)) * np.array([1e-3, 0.05, 0.02])
    if kind == "quantized":                                      # many zero differences
        x = np.round(rng.standard_normal((n, 3)) * 0.01 + np.array([0.0, 9.8, -1.0]), 2)
    elif kind == "constant":                                     # a constant column, a zero column
        x[:, 0] = 9.8
        x[:, 2] = 0.0
    elif kind == "drift":                                        # a trend and a burst (a moving block)
        x += np.linspace(0.0, 5.0, n)[:, None]
        x[n // 3: n // 3 + 40] += rng.standard_normal((min(40, n - n // 3), 3))
    elif kind == "wide":                                         # magnitudes from 1e-9 to 1e9
        x = rng.standard_normal((n, 3)) * np.exp(rng.uniform(-20, 20, (n, 3)))
    return x


@pytest.mark.parametrize("compiled", [True, False])
def test_block_noise_kernel_on_blocks_of_every_size_and_kind(compiled):
    dt = 1.0 / 1024.0                                            # exact times: block edges fall on samples
    # 5 samples (the least), below, at and above numpy's 8-term and 128-term summation blocks
    # 12 blocks and 6: with the short block of 7 samples at the end, 13 and 7 (the quartile halfway
    # between two blocks' sigmas)
    for m, nblk in itertools.product((5, 6, 8, 9, 127, 128, 129, 300), (12, 6)):
        for kind in ("noise", "quantized", "constant", "drift", "wide"):
            rng = np.random.default_rng(1000 * m + len(kind) + nblk)
            n = m * nblk + 7                                     # a short block left at the end
            t = np.arange(n) * dt
            _check_block_sigma(t, _noise_signal(rng, n, kind), m * nblk * dt, m * dt, compiled)
    for seed in range(6 if compiled else 2):                     # uneven blocks: steps that wander, gaps
        rng = np.random.default_rng(seed)
        n = int(rng.integers(300, 3000))
        steps = rng.choice([0.002, 0.005, 0.01]) * rng.uniform(0.2, 2.5, n)
        steps[rng.random(n) < 0.02] *= 8.0
        t = np.concatenate([[0.0], np.cumsum(steps[1:])])
        x = _noise_signal(rng, n, ["noise", "quantized", "constant", "drift", "wide"][seed % 5])
        _check_block_sigma(t, x, float(rng.choice([3.0, 1.0, t[-1]])), float(rng.choice([0.25, 0.5, 0.1])), compiled)


def test_block_noise_takes_any_layout_and_names_a_bad_value():
    from morpi_filters.calibration import _block_sigma
    from oracles import noise

    rng = np.random.default_rng(4)
    dt = 1.0 / 1024.0
    t = np.arange(3000) * dt
    x = 1e4 + 1e-3 * rng.standard_normal((3000, 3))
    wide = np.zeros((3000, 9))
    wide[:, 2:5] = x
    # column-major, a strided view, one column, nine columns, seven columns
    for xx in (np.asfortranarray(x), wide[:, 2:5], x[:, :1], wide, 1e3 + wide[:, :7]):
        _close(noise.block_sigma(t, xx, 2.0, 300 * dt), _block_sigma(t, xx, 2.0, 300 * dt))
    for bad in (np.nan, np.inf):
        y = x.copy()
        y[300, 1] = bad
        with pytest.raises(DataError, match=r"^run\.csv: a value that is not finite"):
            _block_sigma(t, y, 0.9, 64 * dt, "run.csv")
    with pytest.raises(DataError, match="too large to sum"):
        _block_sigma(t, 1e306 * rng.standard_normal((3000, 3)), 0.9, 64 * dt, "run.csv")   # the sums overflow
    short = np.arange(40) * 0.1                                  # 3 samples per block: no block of five
    _close(noise.block_sigma(short, x[:40], 3.0, 0.25), _block_sigma(short, x[:40], 3.0, 0.25))


def test_a_deviation_at_the_noise_quantile_stays_kept_under_last_bit_changes():
    # a quantized signal: many deviations equal the 90 % quantile exactly; scaling the input by 1 + 1e-15
    # moves them by rounding around the quantile, and each must stay kept (the tie margin), so the sigma
    # moves by rounding only, in noise_sigma, the compiled loops and the oracle alike
    from morpi_filters.calibration import _block_sigma, noise_sigma
    from oracles import noise

    rng = np.random.default_rng(9)
    x = np.round(rng.standard_normal((600, 3)) * 1.3, 0) * 0.01 + [0.3, -0.1, 9.81]
    dt = 0.01
    t = np.arange(600) * dt
    base = noise_sigma(x)
    flips = 0
    for k in range(1, 40):
        y = x * (1.0 + k * 1e-15)
        np.testing.assert_allclose(noise_sigma(y), base, rtol=1e-12)
        np.testing.assert_allclose(_block_sigma(t, y, 3.0, 0.25)[0], _block_sigma(t, x, 3.0, 0.25)[0], rtol=1e-12)
        np.testing.assert_allclose(noise.block_sigma(t, y, 3.0, 0.25)[0], noise.block_sigma(t, x, 3.0, 0.25)[0],
                                   rtol=1e-12)
        d = np.abs(np.diff(y, axis=0) - np.median(np.diff(y, axis=0), axis=0))
        q = np.quantile(d, 0.9, axis=0)
        flips += int(((d > q) & (d <= q + 1e-9 * q)).sum())
    assert flips > 0             # rounding did put deviations a hair above the quantile: the margin mattered
