"""Tests of morpi_filters.montecarlo: seeding, chunk/worker/Dask invariance, kernels, studies, reports."""
from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from morpi_filters import montecarlo as mc
from morpi_filters.montecarlo import config as mcc, drift as mcd, engine as mce, pages as mcp
from morpi_filters.errors import MorpiError
from morpi_filters.units import DEG_S, G0

#: A fast study: few training runs (the reference gains only need to exist here).
FAST = mc.StudyConfig(training_runs=50)


# ----------------------------------------------------------------------------- seeding and digest

def test_child_seed_is_the_spawned_child():
    kids = np.random.SeedSequence(1234).spawn(9)
    for i in (0, 3, 8):
        assert np.array_equal(mc.child_seed(1234, i).generate_state(8), kids[i].generate_state(8))


def _mid_step(x):
    """`x` moved to the middle of its rounding interval in the digest (a multiple of the step: half a step
    from either boundary)."""
    m, e = np.frexp(np.asarray(x, dtype=float))
    return np.ldexp(np.rint(np.ldexp(m, mc.DIGEST_BITS)), e - mc.DIGEST_BITS)


def test_digest_depends_on_every_value_at_its_precision():
    # a change of one value by two rounding steps (2^-19 relative) changes the digest, wherever it is
    a = _mid_step(np.random.default_rng(3).uniform(0.01, 500.0, (6, 2)))
    assert mc.digest(a) == mc.digest(a.copy())
    for i, j in ((0, 0), (5, 1), (2, 0)):
        b = a.copy()
        b[i, j] *= 1 + 2.0 ** -(mc.DIGEST_BITS - 1)
        assert mc.digest(a) != mc.digest(b)


def test_digest_is_the_same_under_another_machines_last_digits():
    # values perturbed at 1e-12 relative (far above the differences of another libm or CPU), each value in
    # the middle of its rounding step: the digest does not move; the bits it hashed before did
    rng = np.random.default_rng(4)
    a = _mid_step(rng.uniform(0.01, 500.0, (300, 8)))
    b = a * (1 + 1e-12 * rng.choice([-1.0, 1.0], a.shape))
    assert not np.array_equal(a, b)
    assert mc.digest(b) == mc.digest(a)
    # NaN bits (sign, payload) and the sign of zero differ between machines too: not part of the digest
    odd_nan = np.frombuffer(np.uint64(0xFFF8000000000001).tobytes(), dtype=np.float64)[0]
    c, d = a.copy(), a.copy()
    c[0, 0], d[0, 0] = np.nan, odd_nan
    c[1, 1], d[1, 1] = 0.0, -0.0
    assert mc.digest(c) == mc.digest(d)


def test_field_gain_figures_below_their_precision_leave_the_study_unchanged(tmp_path, monkeypatch):
    # the field evaluation of another machine gives the spread and mismatch a few 1e-11 apart: the gain
    # scenario, every per-run error and the digests are the same
    from morpi_filters import evaluate
    from morpi_filters.results import DataSource

    root = tmp_path / "recordings"
    root.mkdir()
    (root / "1.csv").write_text("time,f_x\n")
    figures = (0.0502360, 0.00251238)            # six digits: the middle of their rounding intervals
    pages = []
    for scale in (1.0, 1 + 3e-11):
        monkeypatch.setattr(evaluate, "training_gain_spread",
                            lambda source, tables=None, k=scale: (figures[0] * k, figures[1] * k))
        pages.append(mc.gain_error_page(runs=12, seed=5, data_source=DataSource(root)))
    a, b = pages
    assert (a.spread, a.mismatch) == (b.spread, b.mismatch) == figures
    assert np.array_equal(a.calibrated.final, b.calibrated.final, equal_nan=True)
    assert a.calibrated.digest == b.calibrated.digest and a.training.digests == b.training.digests
    assert not a.assumed and str(root) not in a.spread_note and "1 recording" in a.spread_note


@pytest.fixture(scope="module")
def reference_study():
    return mc.run_study(13, 7, FAST, chunk=13, series=True)


@pytest.mark.parametrize("chunk, workers", [(1, 1), (7, 1), (7, 2), (2, 2)])
def test_same_seed_same_digest_whatever_the_chunking(reference_study, chunk, workers):
    r = mc.run_study(13, 7, FAST, chunk=chunk, workers=workers, series=True)
    assert r.digest == reference_study.digest
    assert np.array_equal(r.final, reference_study.final)
    assert np.array_equal(r.errors, reference_study.errors, equal_nan=True)
    # the histogram bands are integer counts: identical however the runs are chunked
    assert np.array_equal(r.bands, reference_study.bands, equal_nan=True)


def test_one_pass_equals_each_study_alone():
    # every study of one pass over the draws is, bit for bit, the study run alone with the same seed
    gains = (mc.GainError("a", 0.05), mc.GainError("spread", 0.02, 0.05))
    cal = replace(FAST, gains=gains, calibration="GAC")
    raw = replace(cal, calibration="RD")
    cfgs = (cal, raw, *mc.training_configs([1, 4], mismatch=0.02, spread=0.05, config=cal))
    together = mc.run_studies(17, 4, cfgs, chunk=5, series=True)
    for cfg, r in zip(cfgs, together):
        alone = mc.run_study(17, 4, cfg, chunk=17, series=True)
        assert r.digest == alone.digest
        assert np.array_equal(r.errors, alone.errors, equal_nan=True)
        assert np.array_equal(r.distance_error, alone.distance_error) and np.array_equal(r.dG, alone.dG)
    # the runs' gain draws are kept once for the whole pass (8 bytes per run), each study's gain errors
    # formed from them: dG = mean + std * z per scenario, with z the runs' own standard normal numbers
    assert all(r.gain_draw is together[0].gain_draw for r in together)
    z = together[0].gain_draw
    assert z.shape == (17,) and abs(float(z.mean())) < 4 / np.sqrt(17)      # 4 sigma of a mean of 17 N(0, 1)
    for r in together:
        for s_i, g in enumerate(r.config.gains):
            assert np.array_equal(r.dG[:, s_i], g.mean + g.std * z)


def test_curves_without_the_series_are_those_of_the_series():
    # the reductions are computed column by column without building the series (a MoRPI column from
    # its values after each step): the same sums and counts as from the series itself, bit for bit
    cfgs = (FAST, replace(FAST, calibration="GAC", ins=False))
    with_series = mc.run_studies(31, 2, cfgs, chunk=12, series=True)
    without = mc.run_studies(31, 2, cfgs, chunk=12)
    for a, b in zip(with_series, without):
        assert np.array_equal(a.rms, b.rms, equal_nan=True) and np.array_equal(a.bands, b.bands, equal_nan=True)
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)          # the INS columns of the MoRPI-only study
            expected = np.sqrt(np.nanmean(a.errors ** 2, axis=0))
        np.testing.assert_allclose(b.rms, expected, rtol=1e-12)


def test_studies_without_curves_keep_the_same_numbers():
    # leaving a study's curves out skips its series reductions only: every per-run number is the same
    cal = replace(FAST, calibration="GAC")
    cfgs = (cal, *mc.training_configs([1, 4], mismatch=0.02, spread=0.05, config=cal))
    full = mc.run_studies(23, 6, cfgs, chunk=9)
    lean = mc.run_studies(23, 6, cfgs, chunk=9, curves=(True, False, False))
    for a, b in zip(full, lean):
        assert a.digest == b.digest and np.array_equal(a.final, b.final, equal_nan=True)
        assert np.array_equal(a.distance_error, b.distance_error) and np.array_equal(a.dG, b.dG)
    assert np.array_equal(full[0].bands, lean[0].bands, equal_nan=True) and np.array_equal(full[0].rms, lean[0].rms,
                                                                                           equal_nan=True)
    assert lean[1].rms is None and lean[1].bands is None and full[1].rms is not None
    with pytest.raises(MorpiError, match="without curves"):
        lean[1].curve("MoRPI-A")
    with pytest.raises(MorpiError, match="one per study"):
        mc.run_studies(3, 0, cfgs, curves=(True,))


def test_one_pass_refuses_studies_with_other_draws():
    with pytest.raises(MorpiError, match="duration"):
        mc.run_studies(3, 0, (FAST, replace(FAST, duration_s=16.0)))


def test_series_reductions_agree_with_the_series():
    r = mc.run_study(300, 3, FAST, chunk=70, series=True)
    # RMS from the chunks' sums of squares against numpy on the kept series (summation order only)
    np.testing.assert_allclose(r.rms, np.sqrt(np.mean(r.errors ** 2, axis=0)), rtol=1e-12)
    # the histogram percentile lies in the bin of the exact order statistic (numpy's inverted CDF):
    # within one bin ratio, 10 ** (1 / 40), above the first edge, and within the first bin (1e-6 m) below it
    q = np.percentile(r.errors, mc.BAND_PERCENTILES, axis=0, method="inverted_cdf").transpose(1, 2, 0)
    ok = np.isfinite(q)
    assert np.array_equal(ok, np.isfinite(r.bands))
    big = ok & (q > mc.BAND_RANGE_M[0])
    ratio = r.bands[big] / q[big]
    step = 10 ** (1 / mc.BAND_BINS_PER_DECADE)
    assert ratio.min() >= 1 / step - 1e-12 and ratio.max() <= step + 1e-12
    assert np.abs(r.bands[ok & ~big] - q[ok & ~big]).max() <= mc.BAND_RANGE_M[0]


def test_series_not_kept_by_default():
    r = mc.run_study(13, 7, FAST, chunk=5)
    assert r.errors is None and r.rms.shape == (r.time.size, 4) and r.bands.shape == (r.time.size, 4, 3)


def test_other_seed_other_digest(reference_study):
    r = mc.run_study(13, 8, FAST, chunk=7)
    assert r.digest != reference_study.digest


def test_the_training_draws_follow_the_study_seed(reference_study):
    # the reference gains are trained on draws of the study seed's training child: the same seed gives the
    # same gains, another seed other gains, and the training child is the stream the gains are drawn from
    again = mc.run_study(3, 7, FAST)
    assert again.gain_ref == reference_study.gain_ref and again.gain_ref_cv == reference_study.gain_ref_cv
    other = mc.run_study(3, 8, FAST)
    assert other.gain_ref[0] != reference_study.gain_ref[0] and other.gain_ref[1] != reference_study.gain_ref[1]
    assert mc.reference_gains(FAST, 8) == (other.gain_ref, other.gain_ref_cv)
    a = mc.training_seed(7).generate_state(4)
    assert np.array_equal(a, np.random.SeedSequence(7, spawn_key=(2**32 - 1,)).generate_state(4))
    # no run of a study draws from it: a study's runs are fewer than the training key
    assert not any(np.array_equal(a, mc.child_seed(7, i).generate_state(4)) for i in range(64))


def test_the_gain_error_page_is_reproducible_and_its_seed_reaches_the_training(monkeypatch):
    monkeypatch.setattr(mcp, "TRAINING_KS", (1,))
    a, b, c = (mc.gain_error_page(runs=6, seed=s) for s in (11, 11, 12))
    for x, y in ((a.calibrated, b.calibrated), (a.raw, b.raw)):
        assert x.digest == y.digest and np.array_equal(x.final, y.final) and x.gain_ref == y.gain_ref
    assert a.training.digests == b.training.digests
    assert c.calibrated.gain_ref != a.calibrated.gain_ref and c.calibrated.digest != a.calibrated.digest


def test_the_drift_page_takes_its_seed(monkeypatch):
    real = mc.drift_map
    monkeypatch.setattr(mcp, "drift_map", lambda levels, **kw: real(levels[::12], **{**kw, "draws": 3, "duration_s": 2.0}))
    a, b, c = mc.drift_page(), mc.drift_page(seed=mc.DRIFT_SEED), mc.drift_page(seed=5)
    assert a.drift.seed == mc.DRIFT_SEED and c.drift.seed == 5
    assert np.array_equal(a.drift.final_3d, b.drift.final_3d)
    assert not np.array_equal(a.drift.final_3d, c.drift.final_3d)


def test_cli_seed_reaches_the_training_gains(tmp_path, monkeypatch):
    from morpi_filters import cli

    monkeypatch.setattr(mcp, "TRAINING_KS", (1,))
    got = []
    for k, seed in enumerate(("3", "3", "4")):
        js = tmp_path / f"mc{k}.json"
        assert cli.main(["montecarlo", "--runs", "4", "--seed", seed, "--out", str(tmp_path / f"mc{k}"),
                         "--json", str(js)]) == 0
        got.append(json.loads(js.read_text()))
    assert got[0]["gain_ref"] == got[1]["gain_ref"] and got[0]["digest"] == got[1]["digest"]
    assert got[2]["gain_ref"]["MoRPI-A"] != got[0]["gain_ref"]["MoRPI-A"]
    assert got[2]["gain_ref"]["MoRPI-G"] != got[0]["gain_ref"]["MoRPI-G"]


def test_run_i_depends_only_on_its_own_seed(reference_study):
    # the first 5 runs of a 13-run study are the 5 runs of a 5-run study with the same seed
    r = mc.run_study(5, 7, FAST)
    assert np.array_equal(r.final, reference_study.final[:5])


def test_dask_local_cluster_gives_the_same_digest(reference_study):
    import distributed  # the test extra installs it: a missing one is a failure, not a skip

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        r = mc.run_study(13, 7, FAST, chunk=4, scheduler=cluster.scheduler_address)
        d = mc.drift_map([0.1 * DEG_S, 1 * DEG_S], draws=3, seed=2, duration_s=2.0, chunk=2,
                         scheduler=cluster.scheduler_address)
        # several studies of one pass, as the page runs them (curves kept for some): the workers return
        # reductions, and every number is the local one
        cal = replace(FAST, calibration="GAC")
        cfgs = (cal, FAST, *mc.training_configs([1, 4], mismatch=0.02, spread=0.05, config=cal))
        curves = (True, True, False, False)
        far = mc.run_studies(21, 3, cfgs, chunk=5, curves=curves, scheduler=cluster.scheduler_address)
    near = mc.run_studies(21, 3, cfgs, chunk=5, curves=curves, workers=2)
    other = mc.run_studies(21, 3, cfgs, chunk=8, curves=curves)
    for a, b, c in zip(far, near, other):
        assert a.digest == b.digest == c.digest and np.array_equal(a.distance_error, b.distance_error)
        assert (a.rms is None) == (b.rms is None)
        if a.rms is not None:
            # the same chunks give the same sums; the histogram counts agree whatever the chunks
            assert np.array_equal(a.rms, b.rms, equal_nan=True)
            assert np.array_equal(a.bands, b.bands, equal_nan=True) and np.array_equal(a.bands, c.bands, equal_nan=True)
    assert r.digest == reference_study.digest
    local = mc.drift_map([0.1 * DEG_S, 1 * DEG_S], draws=3, seed=2, duration_s=2.0)
    assert np.array_equal(d.rel_3d, local.rel_3d) and np.array_equal(d.rel_2d, local.rel_2d)


# ----------------------------------------------------------------------------- gain error

def test_morpi_distance_error_mean_matches_analytical_ds():
    # ds = dG D (paper, Section III-A). Bound: MC mean +/- z std / sqrt(N), z = 2.576 (two-sided 99 %).
    # Fixed gain errors as in the paper; the MC spread is the sensor noise in the Weinberg terms.
    gains = (mc.GainError("5 %", 0.05), mc.GainError("10 %", 0.10))
    N = 400
    r = mc.run_study(N, 11, replace(mc.StudyConfig(calibration="GAC"), gains=gains, ins=False), chunk=200)
    for s_i, g in enumerate(gains):
        for m in (0, 1):
            x = r.distance_error[:, s_i, m]
            bound = mc.Z99 * x.std(ddof=1) / math.sqrt(N)
            assert abs(x.mean() - g.mean * r.distance) <= bound, (g.label, m, x.mean(), g.mean * r.distance, bound)
    # the check can fail: a 1 % gain offset is far outside the bound of the fixed-gain scenario
    x = r.distance_error[:, 0, 0]
    assert abs(x.mean() - 0.06 * r.distance) > 10 * mc.Z99 * x.std(ddof=1) / math.sqrt(N)
    # the report's check (same dG draws, residual bound) agrees
    assert all(c[m]["within"] for c in mc.distance_law_check(r) for m in ("MoRPI-A", "MoRPI-G"))


def test_random_gain_error_matches_ds_for_the_same_draws():
    # dG ~ N(3 %, 5 %): compare with ds = dG_i D run by run; bound z std(x - dG D) / sqrt(N), z = 2.576
    r = mc.run_study(400, 11, replace(mc.StudyConfig(calibration="GAC"),
                                      gains=(mc.GainError("spread", 0.03, 0.05),), ins=False), chunk=200)
    for m in (0, 1):
        res = r.distance_error[:, 0, m] - r.dG[:, 0] * r.distance
        assert abs(res.mean()) <= mc.Z99 * res.std(ddof=1) / math.sqrt(400)


def test_gain_errors_are_applied_per_run():
    gains = (mc.GainError("spread", 0.0, 0.1),)
    r = mc.run_study(200, 5, replace(FAST, gains=gains, ins=False, calibration="GC"))
    # with a random gain the distance error follows dG * D run by run (sensor noise adds
    # ~0.2 % of D, the training spread of the gain, far below the 10 % gain spread)
    np.testing.assert_allclose(r.distance_error[:, 0, 0], r.dG[:, 0] * r.distance, atol=0.01 * r.distance)
    assert abs(np.std(r.dG[:, 0], ddof=1) - 0.1) < 0.1 * 4 / math.sqrt(2 * 200)  # 4 sigma of the sample std


def test_training_runs_study_follows_one_over_sqrt_k():
    tr = mc.training_runs_study([1, 4, 16], mismatch=0.02, spread=0.05, runs=300, seed=3,
                                config=replace(FAST, calibration="GAC"))
    # RMS of dG D with dG ~ N(m, s^2/k): relative sampling error of an RMS over 300 runs is about
    # 1/sqrt(2*300) = 4 %; bar 15 % (about 3.5 sigma), plus the 0.2 % sensor-noise term.
    np.testing.assert_allclose(tr.rms_distance[:, 0], tr.rms_expected, rtol=0.15)
    assert tr.rms_distance[0, 0] > tr.rms_distance[1, 0] > tr.rms_distance[2, 0]


def test_calibration_shrinks_the_ins_errors():
    raw = mc.run_study(20, 1, FAST)
    cal = mc.run_study(20, 1, replace(FAST, calibration="GAC"))
    assert np.median(cal.column("INS-3D")) < 0.1 * np.median(raw.column("INS-3D"))


# ----------------------------------------------------------------------------- drift

def test_drift_closed_form_and_strapdown_agree_for_small_biases():
    d = mc.drift_map([0.01 * DEG_S, 0.1 * DEG_S, 6.0 * DEG_S], draws=8, seed=4)
    assert d.time[-1] == pytest.approx(15.0)
    # the acceptance bar: within 1 % at 15 s for small biases (measured: ~2e-5 and ~8e-4 for 3D)
    assert (d.p90_3d[:2, -1] < 0.01).all() and (d.p90_2d[:2, -1] < 0.01).all()
    # and they part for the S6 datasheet bias (84 degrees of tilt in 14 s)
    assert d.rel_3d[2, -1] > 0.2 and d.rel_2d[2, -1] > 0.05


def test_strapdown_drift_matches_exact_single_axis_solution():
    # gyro bias b about x only, no accelerometer bias: the attitude turns by b t about x and
    # gravity leaks into y as -g sin(b t), so dp_y = -g (t / b - sin(b t) / b^2) exactly,
    # while the closed form gives -g b t^3 / 6.
    from morpi_filters import strapdown

    b, n = 6 * DEG_S, 1501
    t = np.arange(n) / 100.0
    f = np.tile([0.0, 0.0, G0], (n, 1))
    w = np.tile([b, 0.0, 0.0], (n, 1))
    p = strapdown.ins3d(t, f, w).position
    exact = -G0 * (t / b - np.sin(b * t) / b ** 2)
    # trapezoid integration of a smooth signal at 100 Hz: relative error O(dt^2) ~ 1e-5, bar 1e-4
    np.testing.assert_allclose(p[1:, 1], exact[1:], rtol=1e-4)
    cf = mcd._closed_form()[0](np.zeros((1, 3)), np.array([[b, 0, 0]]), t, G0, "INS-3D")[0, :, 1]
    x = b * t[-1]
    # the small-angle cubic overshoots by x^3 / (6 (x - sin x)) - 1 (13 % at x = 90 degrees)
    expected = x ** 3 / (6 * (x - math.sin(x))) - 1
    assert abs(cf[-1] - p[-1, 1]) / abs(p[-1, 1]) == pytest.approx(expected, rel=1e-3)


def test_drift_closed_form_over_runs_is_each_runs_own_evaluation():
    # the drift map evaluates the closed form for a chunk of runs at once (runs along axis 0): each run's
    # numbers are those of symbolic.closed_form_errors with its own biases. Elementwise numpy in both; the
    # tolerance covers numpy's vector and scalar loops of sin/cos, which may differ in the last bit.
    from morpi_filters import symbolic

    rng = np.random.default_rng(5)
    ba, bg = rng.normal(size=(4, 3)) * 0.05, rng.normal(size=(4, 3)) * 0.02
    t = np.linspace(0.1, 15.0, 40)
    for kind in ("INS-3D", "INS-2D"):
        many = mcd._closed_form()[0](ba, bg, t, G0, kind)
        for r in range(4):
            p = {"dv0_mps": [0.0] * 3, "accel_bias_mps2": ba[r].tolist(), "gyro_bias_radps": bg[r].tolist(), "g_mps2": G0}
            one = symbolic.closed_form_errors(p, t, kind + " position", "z_up", True)[:, :2]
            np.testing.assert_allclose(many[r], one, rtol=1e-14, atol=0)


def test_drift_onset_is_monotone_in_the_bias():
    d = mc.drift_map(np.array([0.5, 1.0, 2.0, 4.0]) * DEG_S, draws=6, seed=1)
    on = d.onset("INS-3D", 0.01)
    assert np.isfinite(on[1:]).all()
    assert (np.diff(on[1:]) < 0).all()


# ----------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("kw, word", [
    (dict(runs=0, seed=1), "runs"),
    (dict(runs=3, seed=-1), "seed"),
    (dict(runs=3, seed=1, chunk=0), "chunk"),
    (dict(runs=mc.TRAINING_KEY + 1, seed=1), "runs"),     # run indices stay below the training key
])
def test_bad_arguments_raise_one_line(kw, word):
    with pytest.raises(MorpiError, match=word):
        mc.run_study(config=FAST, **kw)


@pytest.mark.parametrize("change, word", [
    (dict(duration_s=5.0), "length_m"),                    # 1.9 m at the paper's speed: fewer than 3 periods
    (dict(length_m=2.0), "length_m"),
    (dict(duration_s=1.5), "duration_s"),                    # shorter than the two 1 s ramps
    (dict(duration_s=10.0, length_m=6.3, speed_mps=1.0), "disagree"),
    (dict(speed_mps=-1.0), "speed_mps"),
    (dict(ins_path="circle"), "ins_path"),
    (dict(calibration="magic"), "calibration"),
    (dict(gains=()), "gains"),
    (dict(gains=(mc.GainError("x", 0.1, -1.0),)), "gains"),
])
def test_bad_config_raises(change, word):
    with pytest.raises(MorpiError, match=word):
        mc.run_study(2, 0, replace(FAST, **change))


def test_drift_bad_levels():
    with pytest.raises(MorpiError, match="gyro_bias"):
        mc.drift_map([0.0])


# ----------------------------------------------------------------------------- report sections

def test_report_montecarlo_contract(tmp_path, monkeypatch):
    monkeypatch.setattr(mcp, "TRAINING_KS", (1, 4))
    from morpi_filters.report.montecarlo import report_montecarlo

    s = report_montecarlo(tmp_path, mc.gain_error_page(runs=30, seed=2, chunk=16))
    res = json.loads((tmp_path / "result.json").read_text())
    assert res["runs"] == 30 and res["seed"] == 2 and len(res["digest"]) == 64
    for m in ("INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G"):
        assert set(res[m]) == {"mean", "std", "median", "p95"}
        assert res[m]["p95"] >= res[m]["median"] >= 0
    again = mc.run_study(30, 2, mc.StudyConfig(gains=tuple(mc.GainError(c["label"], c["dG_mean"], c["dG_std"])
                                                             for c in res["scenarios"]),
                                               calibration="GAC"))
    assert again.digest == res["digest"]
    # the keys renamed in 0.2 are written beside the new ones for one release, with the same values
    tr, cfg = res["training_runs"], res["config"]
    assert tr["source"] == tr["spread_basis"] and tr["spread_basis"].startswith("assumed")
    assert cfg["period_m"] == cfg["p2p_m"] == 1.0
    page = (tmp_path / "README.md").read_text()
    assert "ASSUMED" in page
    for f in s.figures:
        assert (tmp_path / f).stat().st_size > 1000


def test_report_drift_contract(tmp_path, monkeypatch):
    real = mc.drift_map
    monkeypatch.setattr(mcp, "drift_map", lambda levels, **kw: real(levels[::6], **{**kw, "draws": 4}))
    from morpi_filters.report.montecarlo import report_drift

    s = report_drift(tmp_path, mc.drift_page())
    res = json.loads((tmp_path / "result.json").read_text())
    assert len(res["rel_3d"]) == len(res["gyro_bias_deg_s"]) and len(res["rel_3d"][0]) == len(res["time_s"])
    assert set(s.figures) == {"drift_map_3d.png", "drift_map_2d.png"}


def test_cli_montecarlo_json(tmp_path, monkeypatch):
    from morpi_filters import cli

    monkeypatch.setattr(mcp, "TRAINING_KS", (1,))
    out, js = tmp_path / "mc", tmp_path / "mc.json"
    assert cli.main(["montecarlo", "--runs", "8", "--seed", "3", "--chunk", "3", "--out", str(out),
                     "--json", str(js)]) == 0
    assert json.loads(js.read_text())["runs"] == 8


def test_progress_goes_to_stderr(capsys):
    mc.run_study(4, 0, FAST, chunk=2, progress=True)
    err = capsys.readouterr().err
    assert "4/4 runs" in err
    mc.run_study(4, 0, FAST, chunk=2, progress=False)
    assert capsys.readouterr().err == ""


@pytest.mark.field
def test_field_training_gain_spread(field_root):
    """The spread scenario of the gain study comes from the field train runs.

    Each training run's own gain G_run makes its steps sum to the known
    distance; the error of applying the set's mean is G_mean / G_run - 1.
    Its RMS must be positive and below the largest per-set coefficient of
    variation times 1.2 (Jensen: G_mean/G_run - 1 is about -dG/G + (dG/G)^2),
    and its mean is second order, so smaller than the spread.
    """
    from morpi_filters.evaluate import evaluate_tables, training_gain_spread
    from morpi_filters.results import DataSource

    spread, mismatch = training_gain_spread(DataSource(field_root))
    res = evaluate_tables(field_root, include_test=False, alternatives=False)
    cvs = [g.std / g.mean for g in res.gains if g.calibration == "GC"]
    assert 0 < spread < 1.2 * max(cvs)
    assert abs(mismatch) < spread


def test_band_binning_equals_a_search_over_the_edges():
    # the log-based bin index against numpy's searchsorted over the edges, values on the edges included
    rng = np.random.default_rng(1)
    x = np.concatenate([10 ** rng.uniform(-8, 5, 20000), mcc.BAND_EDGES, [0.0, np.nan, 1e6]])
    cells, counts = mce._band_counts(x.reshape(-1, 1, 1))
    nb = mcc.BAND_EDGES.size - 1
    ref = np.bincount(np.clip(np.searchsorted(mcc.BAND_EDGES, x[np.isfinite(x)], side="right") - 1, 0, nb - 1),
                      minlength=nb)
    assert np.array_equal(cells, np.flatnonzero(ref)) and np.array_equal(counts, ref[ref > 0])


# ----------------------------------------------------------------------------- shaping the study

@pytest.mark.parametrize("duration", [15.0, 20.0, 40.0])
def test_a_longer_duration_drives_a_longer_path(duration):
    # the motion fills the run: at the paper's speed for 1 m periods, 20 s drive
    # 0.4667 * (20 - 1) = 8.87 m (duration = length / speed + one ramp of 1 s)
    cfg = mc.StudyConfig(duration_s=duration, p2p_m=1.0, training_runs=50)
    length, speed, T = cfg.motion()
    assert T == duration and speed == pytest.approx(6.3 / 13.5) and length == pytest.approx(speed * (duration - 1))
    ins_path, sine, _ = mce._paths(cfg)
    assert ins_path is sine                               # INS and MoRPI drive the same path
    t, v = sine.time, np.linalg.norm(sine.velocity, axis=1)
    assert t[-1] == pytest.approx(duration)
    # moving from the first ramp to the last: the robot stops only at the end of the run
    moving = (t > 0.5) & (t < duration - 0.5)
    assert (v[moving] > 0.1).all() and v[-1] < 1e-9
    assert sine.position[-1, 0] == pytest.approx(length)
    r = mc.run_study(8, 0, cfg)
    assert r.time[-1] == pytest.approx(duration)
    # one Weinberg step per period, less the tapered ends
    assert r.steps == pytest.approx(length - 1, abs=1.0)


def test_speed_and_length_fix_the_duration():
    cfg = mc.StudyConfig(length_m=10.0, speed_mps=0.5)
    assert cfg.motion() == pytest.approx((10.0, 0.5, 21.0))
    assert mc.StudyConfig(duration_s=11.0, speed_mps=1.0).motion() == pytest.approx((10.0, 1.0, 11.0))
    assert mc.StudyConfig().motion() == pytest.approx((6.3, 6.3 / 14.0, 15.0))


def test_ins_errors_are_those_of_the_sine_path():
    # Only an accelerometer bias b (body x, y) and no noise: the planar INS error is the double
    # integral of the bias rotated by the path's heading, R(psi(t)) b, which this test integrates
    # independently with scipy from the simulated heading. On a straight line it is |b| t^2 / 2.
    from scipy.integrate import cumulative_trapezoid

    from morpi_filters import simulate
    from morpi_filters.units import SensorSpec

    spec = SensorSpec(name="accelerometer bias only", gyro_bias=0.0, gyro_noise=0.0,
                      accel_bias=0.02, accel_noise=0.0)
    runs, seed, T = 3, 5, 20.0
    errs = {}
    for path in ("sine", "straight"):
        r = mc.run_study(runs, seed, mc.StudyConfig(spec=spec, duration_s=T, training_runs=2, ins_path=path))
        errs[path] = r.final_error("INS-2D")
    length, speed, _ = mc.StudyConfig(duration_s=T).motion()
    traj = simulate.sine(length, p2p_m=1.0, amplitude_m=0.1, speed_mps=speed, rest_s=0.0)
    t, psi = traj.time, traj.heading
    for i in range(runs):
        b = spec.accel_bias * np.random.Generator(np.random.PCG64(mc.child_seed(seed, i))).standard_normal(3)
        ax = np.cos(psi) * b[0] - np.sin(psi) * b[1]
        ay = np.sin(psi) * b[0] + np.cos(psi) * b[1]
        x = cumulative_trapezoid(cumulative_trapezoid(ax, t, initial=0), t, initial=0)[-1]
        y = cumulative_trapezoid(cumulative_trapezoid(ay, t, initial=0), t, initial=0)[-1]
        # the kernel turns the bias by the heading integrated from the rate (trapezoid), this test by
        # the simulated heading itself: measured 1.1e-5 relative on the sine, 1e-12 on the line; bar 1e-4
        assert errs["sine"][i] == pytest.approx(math.hypot(x, y), rel=1e-4)
        assert errs["straight"][i] == pytest.approx(np.hypot(*b[:2]) * T ** 2 / 2, rel=1e-4)
        assert errs["sine"][i] != pytest.approx(errs["straight"][i], rel=1e-3)


def test_labelled_results_and_rng():
    gains = (mc.GainError("five", 0.05), mc.GainError("ten", 0.10))
    r = mc.run_study(40, 3, replace(FAST, gains=gains))
    assert np.array_equal(r.final_error("MoRPI-G", "ten"), r.column("MoRPI-G[ten]"))
    assert np.array_equal(r.distance_error_of("MoRPI-A", "ten"), r.distance_error[:, 1, 0])
    assert np.array_equal(r.curve("INS-3D"), r.rms[:, 0]) and r.curve("MoRPI-G", "p95").shape == r.time.shape
    with pytest.raises(MorpiError, match="gain 'seven'"):
        r.final_error("MoRPI-A", "seven")
    with pytest.raises(MorpiError, match="method 'ins3d'"):
        r.final_error("ins3d")
    # a Generator is accepted where a seed is: the study seed is drawn from it once
    a = mc.run_study(5, np.random.default_rng(9), FAST)
    b = mc.run_study(5, int(np.random.default_rng(9).integers(0, 2**63)), FAST)
    assert a.digest == b.digest and a.seed == b.seed


def test_heading_error_by_blocks_is_the_trapezoid_integral():
    # psi_k = h (sum_{i<k} w_i + (w_k - w_0) / 2): against the trapezoid rule written with cumsum (to
    # rounding: the two add in other orders, 1e-12 rad on 300 rows of 0.01 rad/s), and the same bits
    # for any block size (the blocks carry the running sum on, row by row)
    rng = np.random.default_rng(4)
    n, R, h = 300, 3, 0.01
    w = rng.normal(0.0, 0.01, (n, R))
    ref = np.vstack([np.zeros((1, R)), np.cumsum(0.5 * h * (w[1:] + w[:-1]), axis=0)])
    out = {b: mce._heading_error(w, h, np.empty((n, R)), block=b) for b in (1, 7, 64, 500)}
    np.testing.assert_allclose(out[64], ref, rtol=0, atol=1e-12)
    for b in (1, 7, 500):
        assert np.array_equal(out[b], out[64])


# ----------------------------------------------------------------------------- the cost estimate

@pytest.mark.parametrize("duration, speed", [(None, None), (60.0, None), (30.0, 2.0), (None, 0.2), (40.0, 0.1)])
def test_the_estimate_counts_the_samples_and_steps_of_the_path_the_study_drives(duration, speed):
    cfg = mc.StudyConfig(duration_s=duration, speed_mps=speed).resolved()
    _, sine, _ = mce._paths(cfg)                         # the path the study builds
    cost = mc.page_cost(10, duration_s=duration, speed_mps=speed)
    assert cost.duration_s == cfg.duration_s and cost.samples == sine.time.size
    assert abs(cost.steps - (sine.peaks.size - 1)) <= 1


def test_the_estimate_is_affine_in_the_runs_and_grows_faster_than_the_duration():
    c = [mc.page_cost(r, duration_s=60.0) for r in (1000, 2000, 3000)]
    assert c[1].seconds - c[0].seconds == pytest.approx(c[2].seconds - c[1].seconds, rel=1e-12)
    assert c[1].bytes - c[0].bytes == pytest.approx(1000 * mc.RUN_BYTES, rel=1e-12)
    per_run = {d: mc.page_cost(2, duration_s=d).seconds - mc.page_cost(1, duration_s=d).seconds
               for d in (15.0, 60.0, 240.0, 600.0)}
    for short, long in ((15.0, 60.0), (60.0, 240.0), (240.0, 600.0)):
        assert per_run[long] > long / short * per_run[short] > 0
    # more steps in the same time cost more (the fast path of the same duration)
    assert mc.page_cost(1000, duration_s=600.0, speed_mps=10.0).seconds > mc.page_cost(1000, duration_s=600.0).seconds
    # a configured dataset adds the field gain training
    assert mc.page_cost(10, field=True).seconds > mc.page_cost(10).seconds


def test_a_larger_chunk_costs_at_least_its_scratch_planes(monkeypatch):
    # the chunk kernel's scratch arrays, left in place after a study, against the estimate's bytes per sample
    monkeypatch.setattr(mce, "_release_scratch", lambda: None)
    mce._SCRATCH.arrays = {}
    cfg = mc.StudyConfig(training_runs=20, duration_s=8.0)
    mc.run_study(24, 0, cfg, chunk=24)
    n = mce.sample_count(cfg.resolved().duration_s, cfg.rate_hz)
    planes = sum(a.nbytes for a in mce._SCRATCH.arrays.values())
    mce._SCRATCH.arrays = {}
    assert planes / (24 * n) >= 13 * 8                   # draws (6 n + 7), noise (6 n), heading (n) per run
    assert mc.CHUNK_SAMPLE_BYTES >= planes / (24 * n) * (1 - 1e-3)
    big, plain = mc.page_cost(100_000, chunk=20_000), mc.page_cost(100_000)
    default = mce.default_chunk(plain.samples)
    assert big.bytes - plain.bytes >= planes / (24 * n) * plain.samples * (20_000 - default) * (1 - 1e-3)
    assert big.seconds == plain.seconds


@pytest.mark.parametrize("kwargs", [{"runs": 0}, {"runs": 10, "duration_s": 2.0}, {"runs": 10, "chunk": 0},
                                    {"runs": 10, "speed_mps": -1.0}])
def test_the_estimate_refuses_what_the_study_refuses(kwargs):
    runs = kwargs.pop("runs")
    with pytest.raises(MorpiError):
        mc.page_cost(runs, **kwargs)


def test_a_speed_alone_sets_the_duration_of_the_paper_length():
    assert mc.page_cost(1, speed_mps=0.01).duration_s == pytest.approx(mc.DEFAULT_LENGTH_M / 0.01 + mc.RAMP_S)
