"""The MoRPI-aided INS in ``morpi evaluate --dataset``: simulated manifest datasets with known truth, the JSON
rows and track files of the aided method, its NIS and ellipse coverage against numpy computations from what
the evaluation writes, the start from the truth's velocity, and the train-only tunables."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import chi2

from morpi_filters import dataset_eval as de
from morpi_filters import simulate, units
from morpi_filters.cli import main
from morpi_filters.foreign import LAYOUTS, write_foreign_dataset
from morpi_filters.manifest import Dataset, TruthTrack, load_dataset
from morpi_filters.report.dataset_eval import report_dataset_evaluation

AIDED = "MoRPI-aided INS"


def _run(i, split, length, *, noise_free, moving=False, **labels):
    """A sine run (1 m periods) with its truth track at 10 Hz; `moving`: cut 1.5 s after the motion starts (at
    cruise speed), no rest, started from the truth."""
    traj = simulate.sine(length, rest_s=(2.0, 1.5), p2p_m=1.0, amplitude_m=0.1)
    scales = dict(bias_scale=0.0, noise_scale=0.0) if noise_free else dict(bias_scale=(0.25, 0.3))
    d = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(100 + i), **scales)
    t, f, w = d.time, d.f, d.omega
    out = {"id": f"{split}-{i}", "split": split, "group": "g", "motion": "periodic", "rest": [0.1, 1.8]}
    if moving:
        k = int(np.searchsorted(t, traj.start_time + 1.5))
        t, f, w = t[k:], f[k:], w[k:]
        out.update(rest="none", initial="truth")
    out.update(labels)
    return dict(out, time=t, f=f, omega=w, truth=TruthTrack(time=traj.time[::10], position=traj.position[::10]))


def _dataset(noise_free, extra=()):
    runs = [_run(i, "train", L, noise_free=noise_free) for i, L in enumerate((4.0, 5.0, 6.0, 7.0))]
    runs += [_run(10, "test", 5.0, noise_free=noise_free), _run(11, "test", 5.0, noise_free=noise_free, moving=True)]
    return Dataset.from_arrays("sines", runs + list(extra))


@pytest.fixture(scope="module")
def noise_free():
    ds = _dataset(True)
    return ds, de.evaluate(ds, course_m=0.05)


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    ds = _dataset(False)
    result = de.evaluate(ds, course_m=0.05)
    out = tmp_path_factory.mktemp("noisy")
    report_dataset_evaluation(out, result)
    return ds, result, out


def _aided(result, rec_id):
    return [p for p in result.paths if p.id == rec_id and p.method == AIDED]


def test_noise_free_aided_paths_lie_closer_to_the_truth_than_their_steps_alone(noise_free):
    # Noise-free readings make the INS exact: the step displacements (trained Weinberg lengths) are the only
    # inexact measurement the filter takes, so its path, a blend of the exact INS and the steps, lies no
    # farther from the truth than the steps dead-reckoned alone (MoRPI of the method whose steps it takes)
    ds, result = noise_free
    rows = _aided(result, "test-10")
    assert sorted((p.calibration, p.estimate) for p in rows) == sorted(
        (c, e) for c in ("RD", "GC", "GAC") for e in ("forward", "smoothed"))
    steps_of = {e["calibration"]: e["method"] for e in result.choices["aided"]}
    for p in rows:
        morpi = next(q for q in result.paths if q.id == "test-10" and q.method == steps_of[p.calibration]
                     and q.calibration == p.calibration)
        assert p.metrics["path_rmse_m"] < morpi.metrics["path_rmse_m"], (p.calibration, p.estimate)
        assert p.metrics["path_rmse_m"] < 0.05 * np.ptp(ds["test-10"].truth.position[:, 0])


def test_a_moving_start_is_followed_from_the_truth_velocity_and_lost_from_zero(noise_free, monkeypatch):
    # The run starts at cruise speed: from the truth's velocity the exact INS follows it up to the filter's
    # first step update; forced to start from zero velocity (as a start at rest, 1 mm/s), it stays where it
    # started while the robot moves on, so its error is the speed times the time (a closed form)
    ds, result = noise_free
    start = next(s for s in result.starts if s["id"] == "test-11")
    assert start["initial"] == "truth" and start["speed_mps"] > 0.3 and start["v0_sigma_mps"] >= de.V0_SIGMA_MIN
    (fw,) = [p for p in _aided(result, "test-11") if p.estimate == "forward"]
    assert fw.calibration == "RD"
    first_step = float(fw.innovations["step"].time[0])
    truth = ds["test-11"].truth

    def before_first_step(p):
        tt = truth.time[(truth.time >= p.time[0]) & (truth.time < first_step)]
        est = np.column_stack([np.interp(tt, p.time, p.xy[:, 0]), np.interp(tt, p.time, p.xy[:, 1])])
        return tt, np.hypot(*(est - truth.at(tt)[:, :2]).T)

    tt, err = before_first_step(fw)
    assert tt.size >= 10 and np.sqrt(np.mean(err ** 2)) < 0.02

    from morpi_filters.dataset_eval import pipeline

    orig = pipeline._start

    def at_zero(dr, course_m):
        s = orig(dr, course_m)
        return dict(s, v0=np.zeros(3), v0_sigma=1e-3) if dr.id == "test-11" else s

    monkeypatch.setattr(pipeline, "_start", at_zero)
    zero = de.evaluate(ds, course_m=0.05)
    (zf,) = [p for p in _aided(zero, "test-11") if p.estimate == "forward"]
    tz, ez = before_first_step(zf)
    np.testing.assert_allclose(ez, start["speed_mps"] * (tz - zf.time[0]), atol=0.03)
    assert np.sqrt(np.mean(ez ** 2)) > 10 * np.sqrt(np.mean(err ** 2)) + 0.2


def test_aided_rows_have_the_contract_columns_and_their_track_files(tmp_path):
    ds = write_foreign_dataset(tmp_path / "groups", LAYOUTS["groups"], seed=4)
    out = tmp_path / "eval"
    assert main(["evaluate", "--dataset", str(ds.manifest), "--out", str(out)]) == 0
    js = json.loads((out / "result.json").read_text())
    rows = [r for r in js["recordings"] if r["method"] == AIDED]
    periodic = {r.id for r in ds.runs if r.motion == "periodic"}
    assert {r["id"] for r in rows} == periodic
    for r in rows:
        assert set(r) == {"id", "split", "group", "method", "calibration", "estimate", *de.METRICS, "track_file",
                          "nis", "coverage_95"}
        assert r["estimate"] in ("forward", "smoothed")
        assert r["track_file"] == f"tracks/{r['id']}/{AIDED}_{r['calibration']}_{r['estimate']}.csv"
        assert (out / r["track_file"]).read_text().splitlines()[0] == "time,x,y,p_xx,p_xy,p_yy"
        assert r["coverage_95"] in (0.0, 1.0)                       # a route: its end point in or out
        assert set(r["nis"]) >= {"step", "zero velocity"}
        assert all(set(v) == {"per_dof", "band", "updates", "dof"} for v in r["nis"].values())
    assert {(r["id"], r["calibration"], r["estimate"]) for r in rows} == {
        (i, c, e) for i in periodic for c in ("RD", "GC", "GAC") for e in ("forward", "smoothed")}
    assert all(r["estimate"] is None and "nis" not in r for r in js["recordings"] if r["method"] != AIDED)
    # the ablation runs on the recordings the group means read; a route has no path RMSE
    over = js["groups"]["over"]
    ablated = {r["id"] for r in rows if over == "all" or r["split"] == "test"}
    assert js["ablation"] and {q["id"] for a in js["ablation"] for q in a["runs"]} == ablated
    assert all(a["full"]["path_rmse_m"] is None and a["full"]["end_error_percent"] is not None
               for a in js["ablation"])
    # the page: each periodic group's table holds the aided rows beside the other methods
    page = (out / "README.md").read_text()
    for group in ("sine-1.0m", "sine-1.5m"):
        section = page[page.index(f"## Group {group}"):]
        section = section[:section.index("\n## ", 1)]
        assert "| MoRPI-G |" in section and f"| {AIDED} (forward) |" in section \
            and f"| {AIDED} (smoothed) |" in section


def test_nis_and_coverage_equal_a_numpy_computation_from_the_track_files(noisy):
    ds, result, out = noisy
    js = json.loads((out / "result.json").read_text())
    q = chi2.ppf(0.95, 2)
    checked = 0
    for row in (r for r in js["recordings"] if r["method"] == AIDED):
        est = np.loadtxt(out / row["track_file"], delimiter=",", skiprows=1)
        t, xy, P = est[:, 0], est[:, 1:3], est[:, 3:6]
        truth = ds[row["id"]].truth
        inside = (truth.time >= t[0]) & (truth.time <= t[-1])
        tt, ref = truth.time[inside], truth.position[inside, :2]
        d = np.column_stack([np.interp(tt, t, xy[:, 0]), np.interp(tt, t, xy[:, 1])]) - ref
        share = []
        for k, tk in enumerate(tt):
            cov = np.array([[np.interp(tk, t, P[:, 0]), np.interp(tk, t, P[:, 1])],
                            [np.interp(tk, t, P[:, 1]), np.interp(tk, t, P[:, 2])]])
            if np.linalg.det(cov) > 0:
                share.append(d[k] @ np.linalg.inv(cov) @ d[k] <= q)
            else:                                   # the start: the estimate is put on the truth
                share.append(not np.any(d[k]))
        assert row["coverage_95"] == pytest.approx(np.mean(share), abs=1e-12), row["track_file"]
        # NIS from every update of the forward pass (measured minus predicted, and its covariance)
        (path,) = [p for p in result.paths if (p.id, p.method, p.calibration, p.estimate)
                   == (row["id"], AIDED, row["calibration"], row["estimate"])]
        assert set(row["nis"]) == set(path.innovations)
        for kind, inn in path.innovations.items():
            n, dof = inn.y.shape
            total = sum(float(y @ np.linalg.solve(S, y)) for y, S in zip(inn.y, inn.S))
            got = row["nis"][kind]
            assert (got["updates"], got["dof"]) == (n, dof)
            assert got["per_dof"] == pytest.approx(total / (n * dof), rel=1e-8)
            assert got["band"] == pytest.approx([chi2.ppf(0.025, n * dof) / (n * dof),
                                                 chi2.ppf(0.975, n * dof) / (n * dof)], rel=1e-8)
        checked += 1
    assert checked == 2 * (5 * 3 + 1)      # five runs at rest under three calibrations, the moving one under RD


def test_a_recording_without_rest_that_starts_at_rest_leaves_the_aided_filter_out():
    extra = [dict(_run(12, "test", 5.0, noise_free=False, moving=True), initial="rest")]
    result = de.evaluate(_dataset(False, extra), course_m=0.05)
    assert not _aided(result, "test-12")
    (why,) = [x for x in result.left_out if x["id"] == "test-12" and x["what"] == AIDED]
    assert "without a rest window" in why["why"]
    assert _aided(result, "test-11")                       # the same run started from the truth is evaluated


def _corrupted(dr):
    rec = dr.recording
    return replace(dr, recording=replace(rec, f=rec.f * np.array([1.3, -0.7, 1.0]) + 0.2,
                                         omega=rec.omega * 2.0 + 0.05))


def test_corrupting_every_test_recording_leaves_the_aided_tunables_unchanged(tmp_path):
    ds = write_foreign_dataset(tmp_path / "groups", LAYOUTS["groups"], seed=2)
    data = load_dataset(ds.manifest)
    clean = de.evaluate(data)
    dirty = de.evaluate(Dataset(name=data.name, source=data.source,
                                        recordings=[_corrupted(dr) if dr.split == "test" else dr
                                                    for dr in data.recordings]))
    chosen = [e for e in clean.choices["aided"] if e["tunables"] is not None]
    assert len(chosen) == 2 * 3                            # two periodic groups, three calibrations
    assert json.dumps(dirty.choices["aided"], sort_keys=True) == json.dumps(clean.choices["aided"], sort_keys=True)
    before = {(p.id, p.calibration, p.estimate): p.metrics["end_error_m"] for p in clean.paths
              if p.method == AIDED and p.split == "test"}
    after = {(p.id, p.calibration, p.estimate): p.metrics["end_error_m"] for p in dirty.paths
             if p.method == AIDED and p.split == "test"}
    assert before and any(not math.isclose(before[k], after.get(k, math.nan)) for k in before)


def test_the_tuning_runs_each_input_and_tuning_once_and_chooses_as_when_every_run_is_made(noisy, monkeypatch):
    """The tuning's second stage takes the result of a run already made (the same input and tunables) instead
    of running it again: no input runs twice under equal tunables, and the choices and the aided rows are
    those of the evaluation that runs every member (tunables equal only to themselves: nothing is shared)."""
    from morpi_filters import aided

    ds, result, _ = noisy
    orig = aided.run_batch
    runs = []

    def counted(inputs, tunings, **kw):
        inputs = list(inputs)
        tunings = [tunings] * len(inputs) if isinstance(tunings, aided.AidTuning) else list(tunings)
        if "smooth" not in kw:                    # the tuning's batches (the evaluation's smooth)
            runs.extend(zip(inputs, tunings))
        return orig(inputs, tunings, **kw)

    monkeypatch.setattr(aided, "run_batch", counted)
    shared = de.evaluate(ds, course_m=0.05)
    once = len(runs)
    assert len({(id(i), t) for i, t in runs}) == once
    runs.clear()
    monkeypatch.setattr(aided.AidTuning, "__eq__", lambda a, b: a is b)
    monkeypatch.setattr(aided.AidTuning, "__hash__", object.__hash__)
    every = de.evaluate(ds, course_m=0.05)
    assert len(runs) > once                       # the grid's winners include points run again in stage two
    assert json.dumps(shared.choices["aided"]) == json.dumps(every.choices["aided"]) == json.dumps(
        result.choices["aided"])
    rows = lambda r: [(p.id, p.calibration, p.estimate, p.xy.tobytes()) for p in r.paths  # noqa: E731
                      if p.method == AIDED]
    assert rows(shared) == rows(every)


def test_the_trained_pipeline_gives_each_recordings_rows_and_runs_its_aided_filter(noisy):
    """dataset_eval.train, then one recording at a time: Pipeline.estimates are the evaluation's rows of that
    recording, bit for bit (the same calls on the same choices), and the aided filter run by hand from
    Pipeline.aided_input with its trained tuning (aided.run_batch) ends where the row ends, turned into the
    truth's frame by the start's course."""
    from morpi_filters import aided

    ds, result, _ = noisy
    pipe = de.train(ds, course_m=0.05)
    assert pipe.rules == result.pipeline.rules and pipe.choices == result.choices
    for dr in ds.recordings:
        paths, left, runs = pipe.estimates(dr.id)
        rows = [p for p in result.paths if p.id == dr.id]
        assert [(p.method, p.calibration, p.estimate) for p in paths] == \
            [(p.method, p.calibration, p.estimate) for p in rows]
        for a, b in zip(paths, rows):
            assert a.metrics == b.metrics
            np.testing.assert_array_equal(a.xy, b.xy)
        assert runs == [] and left == [x for x in result.left_out if x["id"] == dr.id]
    for rec_id in ("test-10", "test-11"):                     # from the rest window; from the truth, moving
        inp, tuning, stop = pipe.aided_input(rec_id, "RD")
        r = aided.run_batch([inp], [tuning], smooth=True)[0]
        j = r.index_at(stop)
        row = next(p for p in _aided(result, rec_id) if p.calibration == "RD" and p.estimate == "smoothed")
        psi = pipe.prepare(rec_id).start["psi"]
        turn = np.array([[math.cos(psi), -math.sin(psi)], [math.sin(psi), math.cos(psi)]])
        np.testing.assert_allclose(turn @ (r.smoothed[j, :2] - r.smoothed[0, :2]), row.xy[-1] - row.xy[0],
                                   rtol=0, atol=1e-9)
    from morpi_filters.errors import ParameterError

    with pytest.raises(ParameterError, match="'no-such-run' is not an id of the dataset 'sines'"):
        pipe.estimates("no-such-run")


def test_the_page_draws_each_groups_paths_and_errors_against_the_truth(noisy):
    """The evaluation's page shows, after a group's means, its recordings' paths against the truth and, for
    truth tracks, the error against time: PNG files the page links, one panel per recording the means read
    (the group's test recordings here)."""
    from PIL import Image

    ds, result, out = noisy
    page = (out / "README.md").read_text()
    for kind in ("paths", "errors"):
        f = out / "figures" / f"g_{kind}.png"
        assert f.read_bytes()[1:4] == b"PNG" and f"](figures/g_{kind}.png)" in page
        assert Image.open(f).size[0] > 400
    tests = [dr.id for dr in ds.recordings if dr.split == "test"]
    assert f"Paths against the truth ({len(tests)} of the {len(tests)} recording(s) the means read" in page


def test_the_aided_studys_train_side_reads_each_runs_truth_from_the_dataset(noisy):
    """The period count's length and the tuning of a train set named by (phone, route) take each train run's
    end point and distance from the dataset (its truth tracks here), not from a route catalogue: a group named
    "g" is no MoRPI route."""
    from morpi_filters import field_aided as fa
    from morpi_filters import steps as st
    from morpi_filters.errors import ParameterError
    from morpi_filters.field import FieldData, set_gain

    ds, _, _ = noisy
    data = FieldData(ds, course_m=0.05)
    (tset,) = [t for t in data.train_sets() if t.runs]
    config = st.DEFAULT_CONFIGS["MoRPI-A"]
    halves = sum(fa.period_sums(data, r, "GC", "MoRPI-A", config, config.heading)[0] for r in tset.runs)
    assert fa.period_length(data, tset.phone, "GC", "MoRPI-A", config, config.heading) == \
        pytest.approx(float(np.sum(tset.distance_m)) / halves, rel=1e-12)
    gain = set_gain(data, tset, "GC", "MoRPI-A", config)
    by_name = fa.choose_tunables(data, (tset.phone, tset.route), "MoRPI-A", "GC", config, gain)
    by_set = fa.choose_tunables(data, tset, "MoRPI-A", "GC", config, gain)
    assert by_name.info == by_set.info and by_name.score_percent == by_set.score_percent
    with pytest.raises(ParameterError, match="names no train set"):
        fa.choose_tunables(data, ("s8", "short_distance"), "MoRPI-A", "GC", config, gain)
