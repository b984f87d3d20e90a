"""The aided filter's ablation in ``morpi evaluate --dataset``: simulated manifest datasets with truth tracks, the
ablation rows against numpy computations from the track files the evaluation writes, an unused aid's exact zero,
the rest updates removed from a filter started at the motion onset, both read-outs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from morpi_filters import dataset_eval as de
from morpi_filters import field_aided as fa
from morpi_filters import simulate, units
from morpi_filters.manifest import Dataset, TruthTrack
from morpi_filters.report.dataset_eval import report_dataset_evaluation

AIDED = "MoRPI-aided INS"
#: Where the simulated robot stands before it moves: the manifest's rest window [s from the first sample].
REST = [0.1, 1.8]


def _run(i, split, length, *, moving=False):
    """A sine run (1 m periods, biased and noisy IMU) with its truth track at 10 Hz; `moving`: cut 1.5 s after
    the motion starts (at cruise speed), no rest, started from the truth."""
    traj = simulate.sine(length, rest_s=(2.0, 1.5), p2p_m=1.0, amplitude_m=0.1)
    d = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(300 + i), bias_scale=(0.25, 0.3))
    t, f, w = d.time, d.f, d.omega
    out = {"id": f"{split}-{i}", "split": split, "group": "g", "motion": "periodic", "rest": list(REST)}
    if moving:
        k = int(np.searchsorted(t, traj.start_time + 1.5))
        t, f, w = t[k:], f[k:], w[k:]
        out.update(rest="none", initial="truth")
    truth = TruthTrack(time=traj.time[::10], position=traj.position[::10])
    return dict(out, time=t, f=f, omega=w, truth=truth), float(traj.start_time)


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    made = [_run(i, "train", L) for i, L in enumerate((4.0, 5.0, 6.0, 7.0))]
    made += [_run(10, "test", 7.0), _run(11, "test", 8.0), _run(12, "test", 5.0, moving=True)]
    ds = Dataset.from_arrays("sines", [m[0] for m in made])
    result = de.evaluate(ds, course_m=0.05)
    out = tmp_path_factory.mktemp("ablation")
    report_dataset_evaluation(out, result)
    motion_start = {m[0]["id"]: m[1] for m in made}
    return ds, result, out, json.loads((out / "result.json").read_text()), motion_start


def _track(out, rel):
    est = np.loadtxt(out / rel, delimiter=",", skiprows=1, ndmin=2)
    return est[:, 0], est[:, 1:3]


def _path_rmse(t, xy, truth):
    """The RMS horizontal distance to the truth at its samples inside the estimate's span, in numpy."""
    inside = (truth.time >= t[0]) & (truth.time <= t[-1])
    est = np.column_stack([np.interp(truth.time[inside], t, xy[:, k]) for k in range(2)])
    return float(np.sqrt(np.mean(np.sum((est - truth.position[inside, :2]) ** 2, axis=1))))


def test_every_aid_has_both_read_outs_on_every_test_recording_and_calibration(evaluated):
    ds, result, out, js, _ = evaluated
    rows = js["ablation"]
    aided = {(r["id"], r["calibration"]) for r in js["recordings"] if r["method"] == AIDED and r["split"] == "test"}
    assert {(i, c) for i, c in aided if i == "test-12"} == {("test-12", "RD")}          # no rest: RD only
    calibrations = sorted({c for _, c in aided}, key=de.CALIBRATIONS.index)
    assert [(r["calibration"], r["removed"], r["estimate"]) for r in rows] == [
        (c, n, e) for c in calibrations for n in fa.ABLATIONS for e in ("forward", "smoothed")]
    for r in rows:
        assert r["group"] == "g" and set(r["full"]) == set(r["ablated"]) == set(r["difference"]) == {
            "end_error_percent", "path_rmse_m", "cross_track_rmse_m"}
        # the test recordings alone (the train runs tuned the filter), each with the aided filter's rows
        assert {q["id"] for q in r["runs"]} == {i for i, c in aided if c == r["calibration"]}
        assert r["n"] == len(r["runs"]) and all(q["split"] == "test" for q in r["runs"])
    # removing the smoothing: the smoothed read-out becomes the forward one, the forward read-out stays
    forward = {(q["id"], q["calibration"]): q for q in js["recordings"]
               if q["method"] == AIDED and q["estimate"] == "forward"}
    for r in (r for r in rows if r["removed"] == "smoothing"):
        for q in r["runs"]:
            want = forward[q["id"], r["calibration"]]
            assert q["ablated_track_file"] == want["track_file"]
            assert all(q["ablated"][m] == want[m] for m in q["ablated"])
        if r["estimate"] == "forward":
            assert all(v == 0.0 for v in r["difference"].values())
        else:
            assert r["difference"]["path_rmse_m"] != 0.0


def test_an_aid_the_filter_does_not_use_changes_nothing_exactly(evaluated):
    ds, result, out, js, _ = evaluated
    tunables = {e["calibration"]: e["tunables"] for e in result.choices["aided"]}
    unused = [r for r in js["ablation"] if not r["used"]]
    # the chosen filters here consider the gain error without estimating it: the gain state is unused
    assert {r["removed"] for r in unused} >= {"gain state"}
    assert all(tunables[r["calibration"]]["gain_state"] == "considered" for r in unused
               if r["removed"] == "gain state")
    for r in unused:
        assert all(v == 0.0 for v in r["difference"].values()), r
        for q in r["runs"]:
            assert q["ablated_track_file"] == q["full_track_file"]
            assert q["ablated"] == q["full"]
    # used aids, run without: their files and values differ from the full filter's
    for r in (r for r in js["ablation"] if r["used"] and r["removed"] in ("steps", "non-holonomic")):
        for q in r["runs"]:
            assert q["ablated_track_file"] != q["full_track_file"]
            assert q["ablated"]["path_rmse_m"] != q["full"]["path_rmse_m"]


def test_removing_the_steps_raises_the_path_rmse_read_from_the_track_files(evaluated):
    # The path RMSE of every run's full and stepless filter is computed here from the exported track files
    # against the truth track; the group's difference is their mean difference. On the runs started at rest the
    # biased, noisy IMU drifts within seconds and the steps carry the filter: without them each run's path RMSE
    # grows (by 8-14 cm here). The run started under way from the truth's velocity is only averaged.
    ds, result, out, js, _ = evaluated
    steps = [r for r in js["ablation"] if r["removed"] == "steps"]
    assert len(steps) == 2 * 3 and all(r["used"] and r["start"] != "motion onset" for r in steps)
    for r in steps:
        diffs = []
        for q in r["runs"]:
            truth = ds[q["id"]].truth
            full = _path_rmse(*_track(out, q["full_track_file"]), truth)
            without = _path_rmse(*_track(out, q["ablated_track_file"]), truth)
            assert full == pytest.approx(q["full"]["path_rmse_m"], rel=1e-9)
            assert without == pytest.approx(q["ablated"]["path_rmse_m"], rel=1e-9)
            diffs.append(without - full)
            if q["start"] == "rest window":
                assert without - full > 0.05, (r["calibration"], r["estimate"], q["id"], full, without)
        assert r["difference"]["path_rmse_m"] == pytest.approx(np.mean(diffs), rel=1e-9, abs=1e-12)


def test_the_rest_updates_are_removed_from_a_filter_started_at_the_motion_onset(evaluated):
    ds, result, out, js, motion_start = evaluated
    for r in js["ablation"]:
        for q in r["runs"]:
            t0 = float(ds[q["id"]].recording.time[0])
            tf, _ = _track(out, q["full_track_file"])
            ta, _ = _track(out, q["ablated_track_file"])
            assert tf[0] == pytest.approx(t0 + q["start_s"], abs=1e-9) and ta[0] == tf[0]
            if r["removed"] != "rest updates":
                # the filter's own start: the rest window, or the first sample for a start from the truth
                assert q["start"] == ("first sample" if q["id"] == "test-12" else "rest window")
                assert q["start_s"] == pytest.approx(0.0 if q["id"] == "test-12" else REST[0], abs=0.011)
                continue
            assert r["used"] and q["start"] == "motion onset" and r["start"] == "motion onset"
            if q["id"] == "test-12":                       # under way from its first sample
                assert q["start_s"] == 0.0
            else:
                # after the rest window and the robot's true motion start, before it has gone one period (1 m)
                truth = ds[q["id"]].truth
                gone = np.hypot(*(truth.position[:, :2] - truth.position[0, :2]).T)
                one_period = float(truth.time[np.argmax(gone >= 1.0)])
                assert REST[1] < motion_start[q["id"]] <= t0 + q["start_s"] < one_period
                assert q["full_track_file"] != [p for p in js["recordings"] if p["id"] == q["id"]
                                                and p["method"] == AIDED and p["calibration"] == r["calibration"]
                                                and p["estimate"] == r["estimate"]][0]["track_file"]


def test_the_page_has_an_ablation_table_per_group_naming_each_read_out(evaluated):
    ds, result, out, js, _ = evaluated
    page = (out / "README.md").read_text()
    section = page[page.index("## Group g"):]
    section = section[:section.index("\n## ", 1)]
    table = section[section.index(f"### {AIDED} ablation, group g"):]
    for metric in ("end error [%]", "path RMSE [m]", "cross-track RMSE [m]"):
        for estimate in ("smoothed", "forward"):
            assert f"{metric}, {estimate}: full -> without" in table
    for r in js["ablation"]:
        assert f"| {r['calibration']} | {r['removed']} |" in table
