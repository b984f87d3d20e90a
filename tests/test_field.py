"""FieldData's per-recording path on recordings of any length: a result, or one line naming the file.

What ``morpi tables`` and ``morpi aided`` compute per recording (rest window, RD/GC/GAC, motion window,
INS, steps, the aided filter's input and run) on cuts of a recording around every window and threshold
of that path.
"""
from __future__ import annotations

import inspect
from dataclasses import replace

import numpy as np
import pytest

from morpi_filters import aided, dataset, field_aided, simulate, synthetic, units
from morpi_filters import dataset as ds
from morpi_filters import steps as st
from morpi_filters.steps import prepare as stp
from morpi_filters.calibration import NoRestError, detect_rest
from morpi_filters.errors import DataError, MorpiError
from morpi_filters.field import INS_SPANS, LEVELED, FieldData, Thresholds

#: The thresholds of a root without train runs (the library's defaults).
THRESHOLDS = Thresholds(accel_floor=0.1, min_swing_deg=st.StepConfig().min_swing_deg)


def _run(phone: str):
    """A short-route run drawn as the synthetic dataset draws them: at rest from 0.4 s to 3.6 s, the sine path
    (6.3 m), at rest again for 3 s; the recording and the samples where the motion starts and stops."""
    rng = np.random.default_rng(7)
    o = synthetic.DATASET_OPTIONS
    traj = simulate.route_trajectory("short_distance", rest_s=(3.2, 3.0), t0=0.4, amplitude_m=0.05)
    data = simulate.imu(traj, dataset.folder_imu(phone), rng, sampling=synthetic.PHONE_CLOCKS[phone],
                        bias_scale=synthetic.REALISTIC_BIAS_FRACTION[phone], misalignment=o["misalignment"],
                        vibration=o["vibration"], bias_instability=o["bias_instability"],
                        correlation_time=o["correlation_time"])
    rec = data.recording(source="run.csv", phone=phone, route="short_distance", split="test")
    return rec, int(np.searchsorted(rec.time, traj.start_time)), int(np.searchsorted(rec.time, traj.stop_time))


def _windows_s() -> dict:
    """Every window and threshold of the per-recording path [s], read from the code."""
    rest = inspect.signature(detect_rest).parameters
    act = inspect.signature(st.activity_span).parameters
    epoch = inspect.signature(field_aided.rest_noise).parameters["dt_s"].default
    _, _, pad = stp._butter(2, 1.0, st.GRID_HZ)                  # the low-pass's odd padding [grid samples]
    return {
        "rest: moving window, noise blocks": rest["window_s"].default,
        "rest: guard": rest["guard_s"].default,
        "rest: fewest samples": rest["min_samples"].default / 100.0,
        "rest: shortest window without a note": rest["min_window_s"].default,
        "rest: longest window, noise span": rest["max_window_s"].default,
        "rest: shortest motion": rest["sustain_s"].default,
        "motion window: moving window": st.ACTIVITY_WINDOW_S,
        "motion window: rest without a window": act["rest_s"].default,
        "motion window: longest pause": act["min_pause_s"].default,
        "still spans: window, shortest": field_aided.STILL_WINDOW_S,
        "rest noise: epoch": epoch,
        "rest noise: four epochs": 4 * epoch,
        "aided filter: epoch": inspect.signature(aided.run_batch).parameters["dt_s"].default,
        "steps: peak distance": st.StepConfig().min_period_s,
        "steps: two peak distances": 2 * st.StepConfig().min_period_s,
        "low-pass: padding": pad / st.GRID_HZ,
    }


def _cut(rec, n: int, root):
    """The first `n` samples of `rec`, as a file of the layout under `root` (each cut its own file)."""
    folder = root.joinpath(*[p for p in (rec.phone, rec.route, rec.split) if p])
    return replace(rec, time=rec.time[:n], f=rec.f[:n], omega=rec.omega[:n], source=str(folder / f"{n}.csv"))


def _one_line(msg: str, rec) -> None:
    assert "\n" not in msg and msg.startswith(f"{rec.source}: "), msg


def _evaluate(data: FieldData, rec) -> tuple[list, list]:
    """Every per-recording stage of the tables and the aided filter: the stages that gave a result, and those
    that raised a MorpiError (one line naming the file: a cell lists it as failed)."""
    done, failed = [], []

    def stage(name, compute):
        try:
            out = compute()
        except MorpiError as exc:
            _one_line(str(exc), rec)
            failed.append(name)
            return None
        done.append(name)
        return out

    for mode in ("RD", "GC", "GAC"):
        stage(f"calibration {mode}", lambda: data.calibrated(rec, mode))
    stage("motion window", lambda: data.activity(rec))
    for span in INS_SPANS:
        for mode, method in (("RD", "INS-3D"), ("RD", "INS-2D"), ("GAC", "INS-3D"), ("GAC", "INS-2D"),
                             (LEVELED, "INS-3D")):
            stage(f"INS {mode} {method} {span}", lambda: data.ins(rec, mode, method, span))
    stage("tilt", lambda: data.tilt_leak(rec, "GAC"))
    tuning = aided.AidTuning(step_sigma=0.02, gain_sigma=0.0, step_heading="gyro")
    for method, cfg in st.DEFAULT_CONFIGS.items():
        for source in st.HEADING_SOURCES:
            c = cfg.with_(heading_source=source)
            for mode in ("RD", "GC", "GAC"):
                stage(f"step sums {method} {mode} {source}", lambda: data.step_sums(rec, mode, method, c))
                s = stage(f"steps {method} {mode} {source}", lambda: data.steps(rec, mode, method, c))
                if s is not None:
                    st.morpi_track(s, 0.5)
                p = stage(f"aided {method} {mode} {source}",
                          lambda: field_aided.prepare(data, rec, mode, method, c, 0.5))
                if p is not None and mode == "GC":
                    r, = aided.run_batch([p.input], tuning, smooth=True, workers=1)
                    p.end(r)
    return done, failed


@pytest.mark.parametrize("phone", ["s8", "s6"])
def test_every_length_gives_results_or_one_line_naming_the_file(tmp_path, phone):
    rec, onset, stop = _run(phone)
    data = FieldData(tmp_path, thresholds=THRESHOLDS)
    rate = rec.rate_hz
    # the shortest cut in which the rest detection tells the motion: the movement is flagged from at most
    # half a moving window (0.125 s) before the motion starts (later as the robot speeds up over its 1 s
    # ramp), and told from a disturbance once it lasts 1.5 s
    first = onset
    while data.problem(_cut(rec, first, tmp_path)) is not None or data.rest_window(
            _cut(rec, first, tmp_path)).motion_s is None:
        first += 1
    told = rec.time[first - 1] - rec.time[onset]
    assert 1.5 - 0.125 - 1.5 / rate <= told <= 1.5 + 1.0, told
    # w - 1, w and w + 1 samples for every window w: from the first sample, from the motion's start, from the
    # first cut that tells it, before and after the motion's stop; and the check's fewest samples
    counts = {ds.MIN_SAMPLES, first, onset, stop, rec.n}
    for w in _windows_s().values():
        k = int(round(w * rate))
        counts |= {k, onset + k, first + k, stop - k, stop + k}
    lengths = sorted(n + d for n in counts for d in (-1, 0, 1) if ds.MIN_SAMPLES <= n + d <= rec.n)
    kinds = set()
    for n in lengths:
        cut = _cut(rec, n, tmp_path)
        problem = data.problem(cut)
        assert problem is None or n < first, (n, problem)      # a motion told stays told in a longer cut
        if problem is not None:
            # refused: one line naming the file and the length it needs, the rest detection's DataError
            _one_line(problem, cut)
            assert "is too short" in problem and "needed" in problem, problem
            with pytest.raises(DataError) as ei:
                data.rest_window(cut)
            assert str(ei.value) == problem
            # only cuts ending in the first movement (flagged from 0.125 s before it at most)
            assert n > onset - 0.15 * rate, (n, problem)
            kinds.add("refused")
            continue
        _, failed = _evaluate(data, cut)
        # a rest window, its calibrations, the motion window and every INS on it, whatever the length
        assert not [s for s in failed if not s.startswith(("step", "aided"))], (n, failed)
        kinds.add("steps" if not failed else "no steps")
    assert kinds == {"refused", "no steps", "steps"}, kinds
    # the whole recording: every stage gives a result
    assert not _evaluate(data, _cut(rec, rec.n, tmp_path))[1]


@pytest.mark.field
def test_field_recordings_cut_to_any_length_in_their_first_seconds(field_root, tmp_path):
    # Field recordings cut to 250-300 rows (and to every 20th length from 100 to 520), many of them inside
    # the first movement: with the tables' accelerometer floor (the train runs'), a cut is refused on one
    # line naming it, or the per-recording path gives its results.
    floor = FieldData(field_root).accel_floor()
    data = FieldData(tmp_path, thresholds=replace(THRESHOLDS, accel_floor=floor))
    kinds = set()
    for rel in ("s8/short_distance/test/3.csv", "s6/short_distance/train/1.csv", "s8/line_dataset/29.csv"):
        rec, _ = ds.load_recording(field_root / rel)
        for n in sorted({*range(250, 301, 2), *range(100, 521, 20)}):
            cut = _cut(rec, n, tmp_path)
            problem = data.problem(cut)
            if problem is not None:
                _one_line(problem, cut)
                assert "is too short" in problem and "needed" in problem, problem
                kinds.add("refused")
                continue
            _, failed = _evaluate(data, cut)
            assert not [s for s in failed if not s.startswith(("step", "aided"))], (rel, n, failed)
            kinds.add("evaluated")
    assert kinds == {"refused", "evaluated"}


@pytest.mark.parametrize("route, speed", [("line_dataset", 0.87), ("long_distance", 0.6)])
def test_a_recording_moving_from_its_first_sample_is_evaluated_under_rd_only(tmp_path, route, speed):
    # A robot on a straight line, or on the long route's sine path, recorded from 1 s after it set off (at its
    # cruise speed, with the synthetic dataset's motion vibration) until it has stood 3 s at the end: no rest
    # is invented. The recording is no problem; every stage that needs a rest window (GC, GAC, the leveled
    # INS, the tilt, the attitude heading, the aided filter, which starts at the rest) names the recording on
    # one line, and every raw-data stage gives its result (the steps where the path is periodic), over a
    # motion window from the first sample to the stop.
    rng = np.random.default_rng(8)
    o = synthetic.DATASET_OPTIONS
    traj = simulate.route_trajectory(route, speed_mps=speed, rest_s=(0.0, 3.0), **({"amplitude_m": 0.05}
                                                                            if route == "long_distance" else {}))
    imu = simulate.imu(traj, units.LSM6DSL, rng, sampling="jittered", bias_scale=synthetic.REALISTIC_BIAS_FRACTION["s8"],
                       misalignment=o["misalignment"], vibration=o["vibration"],
                       time_span=(traj.start_time + 1.0, traj.end_time))
    assert 0.5 < float(np.linalg.norm(imu.truth.velocity[0])) < 1.0          # under way at the first sample
    folder = tmp_path / "s8" / route / ("test" if route == "long_distance" else "")
    rec = imu.recording(source=str(folder / "1.csv"), route=route, split="test" if route == "long_distance" else None)
    data = FieldData(tmp_path, thresholds=THRESHOLDS)
    assert data.problem(rec) is None
    why = data.no_rest(rec)
    _one_line(why, rec)
    assert "no initial rest" in why and "motion starts 0.000 s" in why, why
    start, end = data.activity(rec)
    # it closes as the robot's vibration fades over the 1 s stop ramp (the vibration scales with the speed)
    assert start == rec.time[0] and traj.stop_time - 1.0 < end <= traj.stop_time + 0.5, (start, end, traj.stop_time)
    done, failed = _evaluate(data, rec)
    needs_rest = [s for s in done + failed if set(s.split()) & {"GC", "GAC", LEVELED, "tilt", "attitude", "aided"}]
    assert set(needs_rest) <= set(failed), done
    assert {"calibration RD", "motion window", "INS RD INS-3D motion", "INS RD INS-2D full"} <= set(done), done
    if route == "long_distance":
        assert failed == needs_rest and {"step sums MoRPI-A RD gyro", "steps MoRPI-G RD gyro"} <= set(done), failed
    with pytest.raises(NoRestError) as ei:
        data.calibrated(rec, "GC")
    assert str(ei.value) == why


# ----------------------------------------------------------------------------- a rule's grid and absolute height

def _offset_run(gyro_offset: float = 0.08):
    """The s8 short-route run with a z gyro offset, as a one-recording manifest dataset."""
    from morpi_filters.manifest import Dataset, RouteTruth

    rec, _, _ = _run("s8")
    w = rec.omega.copy()
    w[:, 2] += gyro_offset
    dataset = Dataset.from_arrays("bench", [{"id": "r", "time": rec.time, "f": rec.f, "omega": w,
                                             "truth": RouteTruth(distance_m=6.3, end_point_m=np.array([6.3, 0.0]))}])
    data = FieldData(dataset, thresholds=THRESHOLDS)
    return data, data.recording_at("r")


def _direct_sums(data, rec, mode, method, config):
    """steps.step_sums on the mode's calibrated recording prepared afresh on the rule's grid (no cache)."""
    crec, _ = data.calibrated(rec, mode)
    p = st.prepare_signal(crec, method, config.cutoff_hz, motion=data.activity(rec),
                          heading=data.heading(rec, mode), grid_hz=config.grid_hz)
    return st.step_sums(p, method, config)


@pytest.mark.parametrize("grid_hz", [50.0, 40.0, None])
def test_a_rule_on_another_grid_runs_on_that_grid(grid_hz):
    """A rule's grid_hz reaches the prepared signal: its steps are those steps.step_sums finds on that grid (the
    default grid's differ), for FieldData.step_sums and FieldData.steps alike."""
    data, rec = _offset_run()
    for method in ("MoRPI-A", "MoRPI-G"):
        cfg = replace(st.StepConfig(cutoff_hz=2.0), grid_hz=grid_hz)
        got = data.step_sums(rec, "GC", method, cfg)
        want = _direct_sums(data, rec, "GC", method, cfg)
        assert tuple(got) == tuple(want)
        steps = data.steps(rec, "GC", method, cfg)
        assert steps.peaks.grid_time.size == data.prepared(rec, "GC", method, 2.0, grid_hz=grid_hz).grid.size
        rate = rec.rate_hz if grid_hz is None else grid_hz
        np.testing.assert_allclose(np.diff(steps.peaks.grid_time), 1.0 / rate, rtol=1e-9)
        assert tuple(got) != tuple(data.step_sums(rec, "GC", method, replace(cfg, grid_hz=st.GRID_HZ)))


def test_an_absolute_peak_height_sees_the_gyro_offset_rd_and_gc_keep_their_own_signals():
    """With min_height the RD signal (gyro offset in) and the GC signal (offset out) give other steps; FieldData
    gives each mode the steps of its own signal, whichever mode was asked first."""
    data, rec = _offset_run()
    cfg = st.StepConfig(cutoff_hz=2.0, min_height=0.9)
    want = {mode: _direct_sums(data, rec, mode, "MoRPI-G", cfg) for mode in ("RD", "GC")}
    assert want["RD"][0] != want["GC"][0]           # the offset moves the absolute threshold
    for order in (("RD", "GC"), ("GC", "RD")):
        fresh, r = _offset_run()
        for mode in order:
            assert tuple(fresh.step_sums(r, mode, "MoRPI-G", cfg)) == tuple(want[mode])
            assert fresh.steps(r, mode, "MoRPI-G", cfg).weight.size > 0
    # without a height the two modes still share one signal (the offset cannot move a relative threshold)
    plain = st.StepConfig(cutoff_hz=2.0)
    assert data.prepared(rec, "RD", "MoRPI-G", 2.0).filtered is data.prepared(rec, "GC", "MoRPI-G", 2.0).filtered
    assert tuple(data.step_sums(rec, "RD", "MoRPI-G", plain)[:1]) == tuple(_direct_sums(data, rec, "RD", "MoRPI-G",
                                                                                     plain)[:1])


def test_straight_line_recordings_are_what_the_manifest_labels_straight_along_one_segment():
    # chosen by the manifest's labels (motion, route truth), whatever the groups are called
    from morpi_filters.manifest import Dataset, RouteTruth

    t = np.arange(600) / 100.0
    f = np.tile([0.0, 0.0, 9.81], (600, 1))
    f[t > 3.0, 0] = 0.2
    one = RouteTruth(distance_m=2.0, end_point_m=np.array([2.0, 0.0]))
    bent = RouteTruth(distance_m=2.0, end_point_m=np.array([1.0, 1.0]),
                      polyline_m=np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]))
    base = {"time": t, "f": f, "omega": np.zeros((600, 3)), "rest": [0.0, 2.5]}
    ds = Dataset.from_arrays("labels", [
        {**base, "id": "a", "group": "robot/hall", "motion": "straight", "truth": one},
        {**base, "id": "b", "group": "robot/corner", "motion": "straight", "truth": bent},
        {**base, "id": "c", "group": "robot/sway", "motion": "periodic", "truth": one},
        {**base, "id": "d", "group": "robot/hall", "motion": "straight", "truth": one}])
    data = FieldData(ds)
    assert [data.relpath(r) for r in data.straight_line_recordings()] == ["a", "d"]
