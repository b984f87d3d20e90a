"""Step rules for other robots: an absolute peak height, a least peak width and a grid that follows the data.

Each test builds a signal whose peaks are known in closed form and checks that the rule finds exactly them.
"""
from __future__ import annotations

import numpy as np
import pytest

from morpi_filters import steps as st
from morpi_filters.dataset import Recording
from morpi_filters.errors import DataError, MorpiError, ParameterError


def _time(duration, rate, rng, jitter=0.2, t0=5.0):
    """Time stamps at about `rate` [Hz], each step spread +-`jitter` (relative) around 1 / rate."""
    dt = rng.uniform(1 - jitter, 1 + jitter, int(duration * rate * 1.3)) / rate
    t = t0 + np.concatenate([[0.0], np.cumsum(dt)])
    return t[t <= t0 + duration]


def _recording(t, method, values, name="rule.csv"):
    """A recording whose MoRPI signal (f_y or omega_z) is `values`; the other channels at rest."""
    f = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 9.81)])
    omega = np.zeros((t.size, 3))
    if method == "MoRPI-A":
        f[:, 1] = values
    else:
        omega[:, 2] = values
    return Recording(time=t, f=f, omega=omega, source=name)


def _steps(rec, method, cfg, *, motion, cache=None):
    p = st.prepare_signal(rec, method, cfg.cutoff_hz, motion=motion, grid_hz=cfg.grid_hz)
    return st.extract_steps(None, method, cfg, prepared=p, peak_cache=cache)


#: A rule that finds every maximum more than 0.3 s apart with any noticeable prominence.
_LOOSE = st.StepConfig(heading="absolute", segment="maxima", ends="drop", min_period_s=0.3, prominence=0.05,
                       cutoff_hz=None, min_swing_deg=0.0)


# ----------------------------------------------------------------------------- least width

def _sine_with_spikes(rate=100.0, seed=0):
    """f_y = sin(2 pi t / 2) over 20 s, plus a narrow spike (Gaussian, sigma 10 ms, 1.5 high) on each
    falling zero crossing: maxima of the sine at 0.5 + 2 k s (width at half prominence 2/3 s), spikes at
    1 + 2 k s (width about 24 ms), 0.5 s after each maximum."""
    rng = np.random.default_rng(seed)
    t = _time(20.0, rate, rng)
    tau = t - t[0]
    x = np.sin(np.pi * tau)
    for c in 1.0 + 2.0 * np.arange(10):
        x += 1.5 * np.exp(-0.5 * ((tau - c) / 0.01) ** 2)
    return t, x


@pytest.mark.parametrize("method", tuple(st.METHODS))
def test_min_width_removes_narrow_spikes_and_keeps_the_sine_maxima(method):
    t, x = _sine_with_spikes()
    rec = _recording(t, method, x)
    motion = (t[0] + 0.1, t[-1] - 0.1)
    truth = t[0] + 0.5 + 2.0 * np.arange(10)
    spikes = t[0] + 1.0 + 2.0 * np.arange(10)
    plain = _steps(rec, method, _LOOSE, motion=motion)
    found = plain.peaks.grid_time[plain.peaks.grid_index]
    # without a width threshold the spikes are peaks too
    assert found.size == 20
    np.testing.assert_allclose(np.sort(np.r_[truth, spikes]), found, atol=0.02)
    # between the spikes' 24 ms and the sine maxima's 2/3 s (0.55 s for the first, whose prominence is measured
    # from the motion's start)
    for width in (0.1, 0.3, 0.5):
        s = _steps(rec, method, _LOOSE.with_(min_width_s=width), motion=motion)
        np.testing.assert_allclose(s.peaks.grid_time[s.peaks.grid_index], truth, atol=0.02)
        assert s.n == truth.size - 1
        np.testing.assert_allclose(s.start_time, truth[:-1], atol=0.02)
    # wider than the sine's own maxima: nothing periodic is left
    with pytest.raises(DataError, match="no periodic motion"):
        _steps(rec, method, _LOOSE.with_(min_width_s=0.8), motion=motion)


# ----------------------------------------------------------------------------- least height

def _amplitude_stretches(rate=100.0, seed=1, low=0.2):
    """omega_z = a(t) sin(2 pi t) over 24 s with a = 1 except a = `low` between 8 and 16 s: maxima at
    0.25 + k s, minima at 0.75 + k s, those of the middle stretch `low` high (deep)."""
    rng = np.random.default_rng(seed)
    t = _time(24.0, rate, rng)
    tau = t - t[0]
    amp = np.where((tau >= 8.0) & (tau < 16.0), low, 1.0)
    return t, amp * np.sin(2 * np.pi * tau)


def _outside_middle(times, t0):
    return times[(times - t0 < 8.0) | (times - t0 > 16.0)]


@pytest.mark.parametrize("segment", st.SEGMENTS)
def test_min_height_removes_the_peaks_of_a_low_amplitude_stretch(segment):
    t, x = _amplitude_stretches()
    rec = _recording(t, "MoRPI-G", x)
    motion = (t[0] + 0.05, t[-1] - 0.05)
    maxima = t[0] + 0.25 + np.arange(24)
    extrema = np.sort(np.r_[maxima, maxima + 0.5])
    truth_all = maxima if segment == "maxima" else extrema
    cfg = _LOOSE.with_(segment=segment)
    # the prominence alone (5 % of the range) keeps the low stretch's peaks
    plain = _steps(rec, "MoRPI-G", cfg, motion=motion)
    np.testing.assert_allclose(plain.peaks.grid_time[plain.peaks.grid_index], truth_all, atol=0.02)
    # a least height between 0.2 and 1 rad/s drops them, the maxima's and (mirrored) the minima's
    for height in (0.3, 0.9):
        s = _steps(rec, "MoRPI-G", cfg.with_(min_height=height), motion=motion)
        np.testing.assert_allclose(s.peaks.grid_time[s.peaks.grid_index], _outside_middle(truth_all, t[0]),
                                   atol=0.02)
    # above every peak: none left
    with pytest.raises(DataError, match="no periodic motion"):
        _steps(rec, "MoRPI-G", cfg.with_(min_height=1.1), motion=motion)


def test_min_height_is_absolute_so_an_offset_signal_keeps_its_own_peaks_in_a_shared_cache():
    t, x = _amplitude_stretches()
    motion = (t[0] + 0.05, t[-1] - 0.05)
    maxima = t[0] + 0.25 + np.arange(24)
    # the same recording and source, once as recorded and once with a gyro offset of 0.3 rad/s: the low
    # stretch peaks at 0.2 and at 0.5 rad/s, one below and one above a least height of 0.45 rad/s
    cfg = _LOOSE.with_(min_height=0.45)
    cache = {}
    for offset, want in ((0.0, _outside_middle(maxima, t[0])), (0.3, maxima), (0.0, _outside_middle(maxima, t[0]))):
        s = _steps(_recording(t, "MoRPI-G", x + offset), "MoRPI-G", cfg, motion=motion, cache=cache)
        np.testing.assert_allclose(s.peaks.grid_time[s.peaks.grid_index], want, atol=0.02)
    # without a least height the offset changes nothing, and the cache serves both
    for offset in (0.0, 0.3):
        s = _steps(_recording(t, "MoRPI-G", x + offset), "MoRPI-G", _LOOSE, motion=motion, cache=cache)
        np.testing.assert_allclose(s.peaks.grid_time[s.peaks.grid_index], maxima, atol=0.02)


def test_cached_thresholds_are_scipys_find_peaks_called_afresh():
    from scipy.signal import find_peaks

    t, x = _sine_with_spikes(seed=3)
    t2, x2 = _amplitude_stretches(seed=4)
    x = x + np.interp(t, t2, x2)                                  # spikes, two amplitudes, two frequencies
    rec = _recording(t, "MoRPI-G", x)
    p = st.prepare_signal(rec, "MoRPI-G", None, motion=(t[0] + 0.05, t[-1] - 0.05))
    i0, i1 = p.motion_index
    seg = p.filtered[i0:i1]
    cache, seen = {}, set()
    # thresholds up and down in one cache, each against scipy with all of them at once
    for prominence, height, width in ((0.05, None, None), (0.05, 0.5, None), (0.05, None, 0.2), (0.3, 0.5, 0.2),
                                      (0.05, 1.2, None), (0.05, 0.5, 0.05), (0.02, None, 0.02), (0.3, None, None),
                                      (0.05, -0.5, 0.2), (0.05, 0.5, None)):
        cfg = _LOOSE.with_(segment="extrema", prominence=prominence, min_height=height, min_width_s=width)
        s = st.extract_steps(None, "MoRPI-G", cfg, prepared=p, peak_cache=cache)
        kw = dict(distance=30, prominence=prominence * (p.span[1] - p.span[0]), height=height,
                  width=None if width is None else width * 100.0)
        want = np.sort(np.r_[find_peaks(seg, **kw)[0], find_peaks(-seg, **kw)[0]]) + i0
        np.testing.assert_array_equal(s.peaks.grid_index, want)
        seen.add(want.size)
    assert len(seen) >= 5                                         # the thresholds do select different peaks


# ----------------------------------------------------------------------------- grid from the data

def _two_harmonics(tau):
    """sin(2 pi tau) + 0.4 sin(6 pi tau + 1): per 1 s period a main maximum (at 0.339 s) and two lesser
    ones, 0.26 s before and 0.34 s after it."""
    return np.sin(2 * np.pi * tau) + 0.4 * np.sin(6 * np.pi * tau + 1.0)


@pytest.mark.parametrize("rate", [120.0, 400.0])
def test_grid_from_the_recording_rate_gives_the_true_steps(rate):
    n = 12
    rng = np.random.default_rng(int(rate))
    t = _time(n + 4.0, rate, rng)
    tau = t - t[0] - 2.0                                          # 2 s of rest on each side
    moving = (tau >= 0) & (tau <= n)
    rec = _recording(t, "MoRPI-G", np.where(moving, _two_harmonics(np.clip(tau, 0, n)), 0.0))
    # the truth, from the closed form on a fine grid: one main maximum per period, and the range
    fine = np.linspace(0.0, 1.0, 1_000_001)
    y = _two_harmonics(fine)
    main = t[0] + 2.0 + fine[np.argmax(y)] + np.arange(n)
    weight = (y.max() - y.min()) ** 0.25
    # the least period (0.8 s) leaves one maximum per period only when it is counted in the grid's own samples
    cfg = st.StepConfig(heading="absolute", segment="maxima", ends="drop", min_period_s=0.8, prominence=0.05,
                        cutoff_hz=None, min_swing_deg=0.0, grid_hz=None)
    s = st.extract_steps(rec, "MoRPI-G", cfg)
    grid_rate = 1.0 / np.diff(s.peaks.grid_time)
    assert abs(grid_rate.mean() - rate) < 0.02 * rate                # the recording's rate, not 100 Hz
    assert s.n == n - 1
    np.testing.assert_allclose(s.start_time, main[:-1], atol=1.5 / rate)
    np.testing.assert_allclose(s.end_time, main[1:], atol=1.5 / rate)
    # the grid's extremes lie within h^2 |x''| / 2 of the true ones (h = 1.2 / rate the longest sample step,
    # |x''| <= 4 pi^2 (1 + 3.6) = 182): the range within 0.75 % at 120 Hz, its fourth root within 0.19 %
    np.testing.assert_allclose(s.weight, weight, rtol=2e-3)
    # lengths with a known gain: gain times the weight of each whole step
    np.testing.assert_allclose(st.morpi_track(s, 0.7).length, 0.7 * weight, rtol=2e-3)
    # the same recording on the default 100 Hz grid gives the same steps (the grid only samples the signal)
    d = st.extract_steps(rec, "MoRPI-G", cfg.with_(grid_hz=st.GRID_HZ))
    assert np.allclose(1.0 / np.diff(d.peaks.grid_time), st.GRID_HZ)
    assert d.n == n - 1
    np.testing.assert_allclose(d.start_time, main[:-1], atol=0.015)


def test_grid_from_the_data_checks_the_cutoff_against_the_recording_rate():
    rng = np.random.default_rng(7)
    t = _time(20.0, 5.0, rng, jitter=0.05)                        # a 5 Hz logger
    rec = _recording(t, "MoRPI-G", np.sin(2 * np.pi * 0.25 * (t - t[0])), name="/data/slow.csv")
    cfg = st.StepConfig(grid_hz=None, cutoff_hz=3.0, min_swing_deg=0.0)
    with pytest.raises(DataError, match=r"slow\.csv: StepConfig\.cutoff_hz=3\.0 Hz with grid_hz=None"):
        st.extract_steps(rec, "MoRPI-G", cfg)
    with pytest.raises(DataError, match="StepConfig.cutoff_hz"):
        st.prepare_signal(rec, "MoRPI-G", 3.0, grid_hz=None)
    # below half the recording's rate the cut-off is taken
    p = st.prepare_signal(rec, "MoRPI-G", 1.0, grid_hz=None)
    assert p.grid_hz is None and abs(p.rate_hz - 5.0) < 0.1 and np.allclose(np.diff(p.grid), 1 / p.rate_hz)
    # a given grid rate is checked as the config checks it
    with pytest.raises(ParameterError, match="StepConfig.cutoff_hz=3.0: expected below half of grid_hz=5.0"):
        st.prepare_signal(rec, "MoRPI-G", 3.0, grid_hz=5.0)
    # a signal prepared on another grid is refused
    with pytest.raises(ParameterError, match="does not match"):
        st.extract_steps(None, "MoRPI-G", cfg.with_(cutoff_hz=1.0, grid_hz=st.GRID_HZ), prepared=p)


# ----------------------------------------------------------------------------- validation

@pytest.mark.parametrize("kw, what", [
    (dict(min_height=float("nan")), "min_height"), (dict(min_height=float("inf")), "min_height"),
    (dict(min_height="0.5"), "min_height"),
    (dict(min_width_s=0.0), "min_width_s"), (dict(min_width_s=-0.1), "min_width_s"),
    (dict(min_width_s=float("inf")), "min_width_s"),
    (dict(grid_hz=0.0), "grid_hz"), (dict(grid_hz=-100.0), "grid_hz"), (dict(grid_hz=float("nan")), "grid_hz"),
    (dict(grid_hz=True), "grid_hz"),
    (dict(grid_hz=5.0), "cutoff_hz"),                             # the default 3 Hz cut-off is not below 2.5 Hz
    (dict(grid_hz=400.0, cutoff_hz=200.0), "cutoff_hz"),
    (dict(grid_hz=None, cutoff_hz=0.0), "cutoff_hz"), (dict(grid_hz=None, cutoff_hz=float("inf")), "cutoff_hz"),
])
def test_bad_new_fields_are_refused_naming_the_field(kw, what):
    with pytest.raises(ParameterError, match=f"^StepConfig.{what}=") as e:
        st.StepConfig(**kw)
    assert "\n" not in str(e.value) and "expected" in str(e.value)


def test_new_fields_accept_what_they_document():
    assert st.StepConfig().min_height is None and st.StepConfig().min_width_s is None
    assert st.StepConfig().grid_hz == st.GRID_HZ == 100.0
    cfg = st.StepConfig(min_height=-0.2, min_width_s=0.05, grid_hz=400.0, cutoff_hz=150.0)
    assert (cfg.min_height, cfg.min_width_s, cfg.grid_hz) == (-0.2, 0.05, 400.0)
    assert st.StepConfig(grid_hz=None, cutoff_hz=80.0).grid_hz is None      # checked against the data later
    with pytest.raises(MorpiError, match="StepConfig.grid_hz"):
        cfg.with_(grid_hz=-1.0)
