"""Dataset manifests: every option round-trips against the simulator's truth, hand-made files against closed
forms, and malformed manifests are refused with one line naming the key (``morpi check --dataset``)."""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from morpi_filters import units
from morpi_filters.cli import main
from morpi_filters.errors import DataError, ParameterError
from morpi_filters.foreign import LAYOUTS, ForeignLayout, enu_from_navigation, write_foreign_dataset
from morpi_filters.manifest import Dataset, RouteTruth, TruthTrack, check_dataset, load_dataset

ROOT = Path(__file__).resolve().parent.parent


# ----------------------------------------------------------------------------- round trips against the simulator

#: Layouts beyond the named ones, so every option of the format is written and read at least once.
_MORE = {
    "ms-clock": ForeignLayout(time_unit="ms"),
    "ns-clock-rfu": ForeignLayout(time_unit="ns", axes="RFU"),
    "npy-with-time-lbu": ForeignLayout(format="npy", time_unit="ms", axes="LBU"),
    "preamble-3": ForeignLayout(preamble=3, logger_style=True, time_unit="ms", rate_hz=200.0),
    "truth-enu-xyz": ForeignLayout(truth="track", truth_frame="ENU", truth_columns="xyz", truth_offset_s=-1.0),
    "truth-ned-xyz-ms": ForeignLayout(truth="track", truth_frame="NED", truth_columns="xyz", truth_time_unit="ms",
                                      truth_rate_hz=25.0),
    "truth-npy-with-time": ForeignLayout(truth="track", truth_format="npy", truth_time_unit="us"),
    "groups-moving": ForeignLayout(groups=True, start="moving", truth="track", axes="FRD", gyro_unit="deg/s"),
}
_ALL = {**LAYOUTS, **_MORE}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    base = tmp_path_factory.mktemp("foreign")
    return {name: write_foreign_dataset(base / name, layout, seed=7) for name, layout in _ALL.items()}


@pytest.mark.parametrize("name", sorted(_ALL))
def test_every_layout_loads_as_the_simulator_made_it(written, name):
    fd = written[name]
    ds = load_dataset(fd.manifest)
    assert [r.id for r in ds.recordings] == [r.id for r in fd.runs]
    for run in fd.runs:
        got = ds[run.id]
        rec, sim = got.recording, run.imu
        # body axes x forward, y left, z up, SI: the simulator's own arrays, to rounding (a unit's factor
        # rounds once each way)
        np.testing.assert_array_equal(rec.time, sim.time)
        np.testing.assert_allclose(rec.f, sim.f, rtol=1e-15, atol=0)
        np.testing.assert_allclose(rec.omega, sim.omega, rtol=1e-15, atol=0)
        assert (got.split, got.group, got.motion) == (run.split, run.group, run.motion)
        if fd.layout.start == "moving":
            assert (got.rest, got.initial) == ("none", "truth")
            assert np.linalg.norm(sim.truth.velocity[0]) > 0.3          # it does start at cruise speed
        if fd.layout.truth == "route":
            traj = sim.truth
            assert isinstance(got.truth, RouteTruth)
            assert got.truth.distance_m == traj.distance
            np.testing.assert_array_equal(got.truth.end_point_m, traj.end_point[:2])
        else:
            assert isinstance(got.truth, TruthTrack) and got.truth.source_frame == fd.layout.truth_frame
            np.testing.assert_allclose(got.truth.time, run.truth_time, rtol=0, atol=1e-12)
            np.testing.assert_allclose(got.truth.position, enu_from_navigation(run.truth_position), rtol=0,
                                       atol=1e-12)
            assert got.truth.time[0] - rec.time[0] == pytest.approx(fd.layout.truth_offset_s, abs=1e-9)
    assert check_dataset(fd.manifest) == ([], len(fd.runs))


def test_the_named_layouts_write_what_they_say(written):
    # the files themselves, read without the manifest module
    npy = np.load(written["npy-120hz"].runs[0].imu_file)
    assert npy.shape[1] == 6 and written["npy-120hz"].runs[0].imu.time[1] == 1 / 120.0
    logger = written["logger-csv"].runs[0].imu_file.read_text().splitlines()
    assert logger[0].startswith("logger export") and logger[1].startswith("timestamp_us, ") and logger[2].endswith(",")
    assert '"' in logger[2] and logger[2].split(", ")[0].isdigit()
    frd = written["frd"].runs[0]
    first = frd.imu_file.read_text().splitlines()[1].split(",")      # time, g_z, g_y, g_x, f_x, f_y, f_z
    assert float(first[6]) < -9.0                                  # at rest a z-down accelerometer reads -g
    deg = written["gyro-deg"].runs[0]
    assert float(deg.imu_file.read_text().splitlines()[1].split(",")[1]) == pytest.approx(
        deg.imu.omega[0, 2] * 180 / math.pi, rel=1e-12)
    g = written["accel-g"].runs[0]
    assert float(g.imu_file.read_text().splitlines()[1].split(",")[6]) == pytest.approx(g.imu.f[0, 2] / units.G0,
                                                                                       rel=1e-12)
    ned = written["truth-ned"].runs[0]
    lines = ned.truth_file.read_text().splitlines()
    assert lines[0] == "t,pos_n,pos_e,pos_d" and len(lines) - 1 == ned.truth_time.size
    assert np.diff(ned.truth_time).max() == pytest.approx(0.1)
    groups = written["groups"]
    assert {r.group for r in groups.runs} == {"sine-1.0m", "sine-1.5m", "straight"}
    assert sorted(r.split for r in groups.runs) == ["test"] * 3 + ["train"] * 3


def test_simulate_layout_writes_a_dataset_check_accepts(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = tmp_path / "robot"
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "simulate", "--layout", "robot", "--out", str(out)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "check", "--dataset", str(out / "dataset.toml")],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0 and r.stdout.strip().endswith(f"2 recording(s) OK, 0 problem(s) in {out / 'dataset.toml'}")


def test_simulate_layout_keeps_the_users_folder_and_names_the_layouts(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    assert main(["simulate", "--layout", "frd", "--out", str(out)]) == 2
    assert [p.name for p in out.iterdir()] == ["thesis.tex"] and (out / "thesis.tex").read_text() == "mine"
    assert main(["simulate", "--layout", "boat", "--out", str(tmp_path / "new")]) == 2
    err = capsys.readouterr().err
    assert "which morpi did not write" in err and "--layout: 'boat' is not a layout, expected one of " in err
    assert ", ".join(sorted(LAYOUTS)) in err and not (tmp_path / "new").exists()


# ----------------------------------------------------------------------------- hand-made files, closed forms

def _imu_csv(path, rows, header="t,ax,ay,az,gx,gy,gz"):
    path.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    return path


_COLS = '{ time = "t", f_x = "ax", f_y = "ay", f_z = "az", g_x = "gx", g_y = "gy", g_z = "gz" }'


def _manifest(folder, body, defaults=""):
    text = f'format_version = 1\nname = "bench"\n{defaults}\n{body}\n'
    path = folder / "dataset.toml"
    path.write_text(text)
    return path


def _still_rows(n=300, dt=0.01, f=(0.0, 0.0, 9.81), w=(0.0, 0.0, 0.0)):
    return [[k * dt, *f, *w] for k in range(n)]


_ROUTE = 'truth = { kind = "route", distance_m = 2.0, end_point_m = [2.0, 0.0] }'


@pytest.mark.parametrize("axes, f_file, w_file, f_flu, w_flu", [
    # x forward, y right, z down: y and z change sign
    ("FRD", (0.5, 0.2, -9.81), (0.01, 0.03, -0.04), (0.5, -0.2, 9.81), (0.01, -0.03, 0.04)),
    # x right, y forward, z up: forward is the file's y, left is minus its x
    ("RFU", (0.2, 0.5, 9.81), (0.03, 0.01, 0.04), (0.5, -0.2, 9.81), (0.01, -0.03, 0.04)),
    # x backward, y down, z right (backward x down is right: right-handed)
    ("BDR", (-0.5, -9.81, -0.2), (-0.01, -0.04, -0.03), (0.5, 0.2, 9.81), (0.01, 0.03, 0.04)),
])
def test_axes_give_the_body_frame(tmp_path, axes, f_file, w_file, f_flu, w_flu):
    _imu_csv(tmp_path / "a.csv", _still_rows(f=f_file, w=w_file))
    path = _manifest(tmp_path, f'[[recording]]\nid = "a"\nimu = {{ file = "a.csv", columns = {_COLS}, '
                               f'axes = "{axes}" }}\n{_ROUTE}')
    rec = load_dataset(path)["a"].recording
    assert rec.f[0].tolist() == list(f_flu) and rec.omega[0].tolist() == list(w_flu)


def test_units_and_clocks_closed_form(tmp_path):
    # a microsecond clock from 1.5 s, g and deg/s: 1 g is 9.80665 m/s^2, 90 deg/s is pi/2 rad/s
    rows = [[1_500_000 + 10_000 * k, 0.0, 0.0, 1.0, 90.0, 0.0, 0.0] for k in range(300)]
    _imu_csv(tmp_path / "a.csv", rows)
    path = _manifest(tmp_path, f'[[recording]]\nid = "a"\nrest = "none"\nimu = {{ file = "a.csv", columns = {_COLS}, '
                               f'time_unit = "us", accel_unit = "g", gyro_unit = "deg/s" }}\n{_ROUTE}')
    rec = load_dataset(path)["a"].recording
    assert rec.time[0] == 1.5 and rec.time[1] == 1.51 and rec.f[0, 2] == 9.80665
    assert rec.omega[0, 0] == pytest.approx(math.pi / 2, rel=1e-15)


def test_a_unix_clock_loads_counted_from_its_first_sample(tmp_path):
    rows = [[1_700_000_000_000 + 10 * k, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0] for k in range(300)]   # Unix time in ms
    _imu_csv(tmp_path / "a.csv", rows)
    imu = f'file = "a.csv", columns = {_COLS}, time_unit = "ms"'
    with pytest.raises(DataError, match=r"imu.file: .*a.csv: line 2: column t: 1700000000.0 s is beyond the limit"):
        load_dataset(_manifest(tmp_path, f'[[recording]]\nid = "a"\nimu = {{ {imu} }}\n{_ROUTE}'))
    first = f'[[recording]]\nid = "a"\nimu = {{ {imu}, time_origin = "first" }}\n{_ROUTE}'
    rec = load_dataset(_manifest(tmp_path, first))["a"].recording
    assert rec.time[0] == 0.0 and rec.time[-1] == 2.99


def test_a_ned_track_becomes_enu_on_the_imu_clock(tmp_path):
    _imu_csv(tmp_path / "a.csv", [[100.0 + 0.01 * k, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0] for k in range(300)])
    # a truth clock of its own (GPS seconds), 10 Hz, starting 0.25 s before the IMU's first sample
    truth = [[1.4e9 + 0.1 * k, 1.0 + k, 2.0, 3.0 - 0.5 * k] for k in range(33)]
    (tmp_path / "t.csv").write_text("gps_s,N,E,D\n" + "\n".join(",".join(repr(v) for v in r) for r in truth) + "\n")
    path = _manifest(tmp_path, f'[[recording]]\nid = "a"\nimu = {{ file = "a.csv", columns = {_COLS} }}\n'
                               'truth = { kind = "track", file = "t.csv", offset_s = -0.25, '
                               'columns = { time = "gps_s", n = "N", e = "E", d = "D" } }')
    track = load_dataset(path)["a"].truth
    assert track.frame == "ENU" and track.source_frame == "NED"
    assert track.position[0].tolist() == [2.0, 1.0, -3.0] and track.position[2].tolist() == [2.0, 3.0, -2.0]
    assert track.time[0] == pytest.approx(99.75, abs=1e-9) and track.time[1] - track.time[0] == pytest.approx(0.1)


def test_defaults_are_inherited_key_by_key(tmp_path):
    _imu_csv(tmp_path / "a.csv", _still_rows(f=(0.0, 0.0, -9.81)))
    _imu_csv(tmp_path / "b.csv", _still_rows(f=(0.0, 0.0, 1.0)), header="t,ax,ay,az,gx,gy,gz")
    np.save(tmp_path / "c.npy", np.array(_still_rows(f=(0.0, 0.0, 9.81)))[:, 1:])
    defaults = (f'[defaults]\nsplit = "train"\ngroup = "g"\n{_ROUTE}\n'
                f'[defaults.imu]\ncolumns = {_COLS}\naxes = "FRD"\nskip_rows = 0\n')
    body = ('[[recording]]\nid = "a"\nimu.file = "a.csv"\n'                               # everything inherited
            '[[recording]]\nid = "b"\nsplit = "test"\nnotes = "windy"\n'
            'imu = { file = "b.csv", axes = "FLU", accel_unit = "g" }\n'
            # an .npy file: the skip_rows of the defaults is ignored
            '[[recording]]\nid = "c"\nimu = { file = "c.npy", axes = "FLU", rate_hz = 50.0, '
            'columns = { f_x = 0, f_y = 1, f_z = 2, g_x = 3, g_y = 4, g_z = 5 } }\n')
    ds = load_dataset(_manifest(tmp_path, body, defaults))
    a, b, c = ds["a"], ds["b"], ds["c"]
    assert (a.split, a.group, b.split, b.group, a.notes, b.notes) == ("train", "g", "test", "g", "", "windy")
    assert a.recording.f[0, 2] == 9.81 and b.recording.f[0, 2] == 9.80665 and c.recording.f[0, 2] == 9.81
    assert c.recording.time[1] == 1 / 50.0 and a.truth.distance_m == 2.0


def test_from_arrays_has_the_checks_of_a_manifest():
    t = np.arange(300) / 100.0
    good = {"id": "a", "time": t, "f": np.tile([0.0, 0.0, 9.81], (300, 1)), "omega": np.zeros((300, 3)),
            "truth": RouteTruth(distance_m=1.0, end_point_m=[1.0, 0.0])}
    ds = Dataset.from_arrays("mem", [good, dict(good, id="b", group="x")])
    assert len(ds) == 2 and set(ds.groups()) == {"all", "x"}
    with pytest.raises(ParameterError, match="id 'a' appears twice"):
        Dataset.from_arrays("mem", [good, good])
    with pytest.raises(ParameterError, match=r"recordings\[0\].split: 'dev' is not one of"):
        Dataset.from_arrays("mem", [dict(good, split="dev")])
    with pytest.raises(ParameterError, match="looks like z down"):
        Dataset.from_arrays("mem", [dict(good, f=-good["f"])])
    with pytest.raises(ParameterError, match="unknown key 'omgea', the nearest known one is 'omega'"):
        Dataset.from_arrays("mem", [dict(good, omgea=1)])
    gap = t.copy()
    gap[150:] += 2.0
    with pytest.raises(DataError, match=r"row index 150: time gap of 2.01 s"):
        Dataset.from_arrays("mem", [dict(good, time=gap)])
    short = TruthTrack(time=np.array([0.0, 1.0]), position=np.zeros((2, 3)))
    with pytest.raises(DataError, match="truth shorter than the recording"):
        Dataset.from_arrays("mem", [dict(good, truth=short, initial="truth")])


# ----------------------------------------------------------------------------- refused: physics after conversion

@pytest.mark.parametrize("f, w, declared, key, hint", [
    ((0.0, 0.0, -9.81), (0.0, 0.0, 0.0), "", "imu.axes", r"looks like z down: check `axes` \(declared 'FLU'"),
    ((9.81, 0.0, 0.0), (0.0, 0.0, 0.0), "", "imu.axes", "lies across the body z axis"),
    ((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), "", "imu.accel_unit", "magnitude 1 m/s\\^2 .* check accel_unit"),
    ((0.0, 0.0, 9.81), (0.0, 0.0, 0.0), ', accel_unit = "g"', "imu.accel_unit", "magnitude 96.2"),
    ((0.0, 0.0, 9.81), (0.0, 0.0, 1.5), "", "imu.gyro_unit", r"at rest is 1.5 rad/s .* check gyro_unit"),
])
def test_readings_that_look_declared_wrong_are_refused(tmp_path, f, w, declared, key, hint):
    _imu_csv(tmp_path / "a.csv", _still_rows(f=f, w=w))
    path = _manifest(tmp_path, f'[[recording]]\nid = "a"\nimu = {{ file = "a.csv", columns = {_COLS}{declared} }}\n'
                               f'{_ROUTE}')
    with pytest.raises(ParameterError, match=f"'a'\\): {key}: .*{hint}"):
        load_dataset(path)


def test_a_gyro_in_deg_s_declared_rad_s_is_refused_while_moving(tmp_path):
    rows = _still_rows(w=(0.0, 0.0, 0.0))
    for k, r in enumerate(rows):
        r[6] = 20.0 * math.sin(k / 10.0)     # 20 deg/s turns read as rad/s: within the gyro limit, beyond a robot
    _imu_csv(tmp_path / "a.csv", rows)
    path = _manifest(tmp_path, f'[[recording]]\nid = "a"\nrest = "none"\nimu = {{ file = "a.csv", columns = {_COLS} }}'
                               f'\n{_ROUTE}')
    with pytest.raises(ParameterError, match=r"imu.gyro_unit: 1 % of the angular rates exceed 20 rad/s"):
        load_dataset(path)
    path.write_text(path.read_text().replace("columns", 'gyro_unit = "deg/s", columns'))
    assert load_dataset(path)["a"].recording.omega[:, 2].max() < 0.35


def _phone_then_turning(tilt_deg=3.0, seed=5, n=700):
    """A noisy IMU built here from known truth: tilted `tilt_deg` about x and standing 3 s (gravity up z, small
    offsets, white noise near the datasheet figures), then swinging about z at 1 Hz (0.5 rad/s)."""
    rng = np.random.default_rng(seed)
    t = 0.5 + 0.01 * np.arange(n)
    tilt = math.radians(tilt_deg)
    f = np.tile([0.05, units.G0 * math.sin(tilt), units.G0 * math.cos(tilt)], (n, 1))
    w = np.tile([0.01, -0.02, 0.015], (n, 1))
    moving = t > t[0] + 3.0
    f[moving, 1] += 0.4 * np.sin(2 * np.pi * (t[moving] - t[0]))
    w[moving, 2] += 0.5 * np.sin(2 * np.pi * (t[moving] - t[0]))
    return t, f + 0.01 * rng.standard_normal((n, 3)), w + 0.0015 * rng.standard_normal((n, 3))


def _same_arrays_case(kind):
    t, f, w = _phone_then_turning(tilt_deg=50.0 if kind == "tilted 50 deg" else 3.0)
    if kind == "z down":                        # turned 180 deg about x: a right-handed z-down frame
        f[:, 1:] *= -1
        w[:, 1:] *= -1
    elif kind == "accelerometer in g":
        f = f / units.G0
    elif kind == "0.77 g":                      # 2.26 m/s^2 short of gravity: beyond 3 x 60 mg + 3 % + 0.05
        f = 0.77 * f
    elif kind == "gyro in deg/s":
        w = np.degrees(w)
    elif kind == "gyro in deg/s, offsets removed":      # only its noise tells at rest
        w = np.degrees(w - np.median(w[:300], axis=0))
    elif kind == "gyro offset 0.4 rad/s":       # beyond 3 x 6 deg/s on g_z
        w[:, 2] += 0.4
    elif kind == "dead g_y":
        w[:, 1] = 0.0
    return t, f, w


#: The manifest key each kind of finding names (docs/manifest.md, "Checks").
_KEY_OF_KIND = {"axes": "imu.axes", "accel_unit": "imu.accel_unit", "gyro_unit": "imu.gyro_unit",
                "dead_channel": "imu.file"}


@pytest.mark.parametrize("kind, expect", [
    ("plausible", None), ("z down", "axes"), ("accelerometer in g", "accel_unit"), ("gyro in deg/s", "gyro_unit"),
    # where the two checks once differed: 0.75-1.25 g, within 60 deg of up, 0.5 rad/s at rest, no noise bound
    ("0.77 g", "accel_unit"), ("tilted 50 deg", "axes"), ("gyro offset 0.4 rad/s", "gyro_unit"),
    ("gyro in deg/s, offsets removed", "gyro_unit"), ("dead g_y", "dead_channel"),
])
def test_the_catalogue_and_a_manifest_give_one_verdict_on_the_same_file(tmp_path, monkeypatch, kind, expect):
    """One file read by the MoRPI catalogue and by a manifest: both judge it by dataset.rest_problems (each call
    is seen), with the same verdict, the manifest naming the key of the finding's kind."""
    from morpi_filters import dataset
    from morpi_filters.dataset import Recording, catalogue, plausibility, write_csv
    from morpi_filters.manifest import read as manifest_read

    seen = []
    shared = dataset.rest_problems

    def spy(rec, **kw):
        found = shared(rec, **kw)
        seen.append((rec, kw, found))
        return found

    monkeypatch.setattr(plausibility, "rest_problems", spy)
    monkeypatch.setattr(manifest_read, "rest_problems", spy)
    t, f, w = _same_arrays_case(kind)
    path = tmp_path / "s8" / "line_dataset" / "1.csv"
    path.parent.mkdir(parents=True)
    write_csv(path, Recording(time=t, f=f, omega=w))
    (tmp_path / "dataset.toml").write_text(f'format_version = 1\nname = "same"\n[[recording]]\nid = "a"\n'
                                           f'imu.file = "s8/line_dataset/1.csv"\n{_ROUTE}\n')
    if expect is None:
        catalogue(tmp_path)[0].load()
        load_dataset(tmp_path / "dataset.toml")
    else:
        with pytest.raises(DataError):
            catalogue(tmp_path)[0].load()
        with pytest.raises(DataError if expect == "dead_channel" else ParameterError,
                           match=f"'a'\\): {_KEY_OF_KIND[expect]}: ") as ei:
            load_dataset(tmp_path / "dataset.toml")
        assert "\n" not in str(ei.value)
    assert len(seen) == 2, "each path calls dataset.rest_problems once"
    (rec_c, kw_c, found_c), (rec_m, kw_m, found_m) = seen
    np.testing.assert_array_equal(rec_c.f, rec_m.f)
    np.testing.assert_array_equal(rec_c.omega, rec_m.omega)
    assert kw_c.get("spec", dataset.MEMS_SPEC) == kw_m.get("spec", dataset.MEMS_SPEC) == dataset.MEMS_SPEC
    assert [p.kind for p in found_c] == [p.kind for p in found_m]
    assert (found_c[0].kind if found_c else None) == expect


def test_imu_spec_scales_the_bounds(tmp_path):
    """A gyro offset of 0.4 rad/s lies beyond three offsets of the default 6 deg/s (0.31 rad/s) and within three
    of a declared 10 deg/s (0.52 rad/s); unknown spec keys are refused naming the key."""
    from morpi_filters.dataset import Recording, write_csv

    t, f, w = _same_arrays_case("gyro offset 0.4 rad/s")
    write_csv(tmp_path / "a.csv", Recording(time=t, f=f, omega=w))
    body = f'[[recording]]\nid = "a"\nimu = {{ file = "a.csv"SPEC }}\n{_ROUTE}'
    with pytest.raises(ParameterError, match=r"imu.gyro_unit: the median angular rate at rest is 0.41\d rad/s on g_z"):
        load_dataset(_manifest(tmp_path, body.replace("SPEC", "")))
    loaded = load_dataset(_manifest(tmp_path, body.replace("SPEC", ", spec = { gyro_bias_deg_s = 10 }"))).recordings
    # the declared figures travel with the recording (what rest detection reads), unspecified ones the default's
    from morpi_filters.dataset import MEMS_SPEC

    imu = loaded[0].recording.imu
    assert imu.gyro_bias == pytest.approx(10 * units.DEG) and imu.gyro_noise == MEMS_SPEC.gyro_noise
    with pytest.raises(ParameterError, match=r"imu.spec: unknown key 'gyro_bias', the nearest known one is "
                                             r"'gyro_bias_deg_s'"):
        load_dataset(_manifest(tmp_path, body.replace("SPEC", ", spec = { gyro_bias = 10 }")))
    with pytest.raises(ParameterError, match=r"imu.spec: accel_bias_mg: -1.0, expected at least 0"):
        load_dataset(_manifest(tmp_path, body.replace("SPEC", ", spec = { accel_bias_mg = -1 }")))


def test_without_a_rest_a_dead_channel_is_named_in_a_noisy_recording_only(tmp_path):
    """rest = "none": a column that never moves is a dead channel when the others carry white noise; in a
    noise-free recording (a smooth turn sampled at 100 Hz) the still columns prove nothing."""
    from morpi_filters.dataset import Recording, write_csv

    t, f, w = _same_arrays_case("dead g_y")
    write_csv(tmp_path / "a.csv", Recording(time=t, f=f, omega=w))
    body = f'[[recording]]\nid = "a"\nrest = "none"\nimu.file = "a.csv"\n{_ROUTE}'
    with pytest.raises(DataError, match=r"imu.file: .*a.csv: column g_y is all zero in all 700 samples: a dead"):
        load_dataset(_manifest(tmp_path, body))
    smooth = np.zeros_like(w)
    smooth[:, 2] = 0.5 * np.sin(2 * np.pi * (t - t[0]))
    write_csv(tmp_path / "a.csv", Recording(time=t, f=np.tile([0.0, 0.0, units.G0], (t.size, 1)), omega=smooth))
    assert load_dataset(_manifest(tmp_path, body))["a"].rest == "none"


def test_a_z_down_file_declared_flu_is_refused_by_check_with_the_axes_hint(written, tmp_path, capsys):
    folder = tmp_path / "frd"
    shutil.copytree(written["frd"].manifest.parent, folder)
    text = (folder / "dataset.toml").read_text()
    (folder / "dataset.toml").write_text(text.replace('axes = "FRD"', 'axes = "FLU"'))
    code = main(["check", "--dataset", str(folder / "dataset.toml")])
    out = capsys.readouterr()
    lines = out.out.strip().splitlines()
    assert code == 2 and len(lines) == 3 and lines[-1].startswith("0 recording(s) OK, 2 problem(s)")
    assert all("[defaults] imu.axes" in s and "looks like z down: check `axes`" in s for s in lines[:2])


# ----------------------------------------------------------------------------- refused: malformed manifests

def _base(tmp_path) -> Path:
    """A good manifest with two recordings (a CSV with a time column, a truth track in NED)."""
    _imu_csv(tmp_path / "a.csv", _still_rows())
    _imu_csv(tmp_path / "b.csv", _still_rows())
    (tmp_path / "t.csv").write_text("t,n,e,d\n" + "\n".join(f"{0.1 * k!r},{0.01 * k!r},0.0,0.0" for k in range(40))
                                    + "\n")
    np.save(tmp_path / "n.npy", np.array(_still_rows())[:, 1:])
    return tmp_path


_GOOD = f'''format_version = 1
name = "bench"
description = "two recordings"

[defaults]
group = "bench"

[defaults.imu]
columns = {_COLS}
rate_hz = 100.0

[[recording]]
id = "a"
split = "train"
motion = "straight"
rest = [0.2, 2.0]
imu = {{ file = "a.csv", axes = "FLU" }}
truth = {{ kind = "route", distance_m = 2.0, end_point_m = [2.0, 0.0] }}

[[recording]]
id = "b"
initial = "truth"
imu = {{ file = "b.csv" }}
truth.kind = "track"
truth.file = "t.csv"
truth.frame = "NED"
truth.offset_s = -0.1
truth.columns = {{ time = "t", n = "n", e = "e", d = "d" }}
'''


def _sub(old, new, count=1):
    def edit(text):
        assert old in text, old
        return text.replace(old, new, count)
    return edit


_B = 'imu = { file = "b.csv" }'
_NPY_COLS = "columns = { f_x = 0, f_y = 1, f_z = 2, g_x = 3, g_y = 4, g_z = 5 }"
_SIX = 'f_y = "ay", f_z = "az", g_x = "gx", g_y = "gy"'


def _imu_b(extra):
    return _sub(_B, 'imu = { file = "b.csv", ' + extra + " }")


def _imu_a(extra):
    return _sub('axes = "FLU"', 'axes = "FLU", ' + extra)


#: (label, edit of the good manifest, text the one-line message must hold, ...). Each exits 2.
MALFORMED = [
    ("version 2", _sub("format_version = 1", "format_version = 2"), "format_version: 2 is not supported, expected 1"),
    ("version missing", _sub("format_version = 1\n", ""), "format_version: missing"),
    ("version a string", _sub("format_version = 1", 'format_version = "1"'), "format_version: '1' is not supported"),
    ("name missing", _sub('name = "bench"\n', ""), "name: missing"),
    ("name empty", _sub('name = "bench"', 'name = ""'), "name: an empty string"),
    ("not TOML", _sub("[defaults]", "[defaults"), "not valid TOML"),
    ("top-level key", _sub('description = "two', 'recordings = 3\ndescription = "two'),
     "unknown key 'recordings', the nearest known one is 'recording'"),
    ("one [recording]", lambda t: t.split("[[recording]]")[0] + '[recording]\nid = "a"\n', "recording: one table"),
    ("defaults key", _sub('group = "bench"', 'grup = "bench"'),
     "[defaults]: unknown key 'grup', the nearest known one is 'group'"),
    ("defaults id", _sub('group = "bench"', 'id = "x"'), "[defaults] id: ids cannot have a default"),
    ("defaults imu key", _sub("rate_hz = 100.0", "rate = 100.0"),
     "[defaults] imu: unknown key 'rate', the nearest known one is 'rate_hz'"),
    ("defaults value", _sub("rate_hz = 100.0", "rate_hz = 0.5"), "[defaults] imu.rate_hz: 0.5, expected at least 1"),
    ("recording key", _sub('split = "train"', 'spilt = "train"'),
     "unknown key 'spilt', the nearest known one is 'split'"),
    ("imu key", _sub('axes = "FLU"', 'axis = "FLU"'), "imu: unknown key 'axis', the nearest known one is 'axes'"),
    ("imu not a table", _sub(_B, 'imu = "b.csv"'), "imu: a string 'b.csv', expected a table"),
    ("split", _sub('split = "train"', 'split = "validation"'),
     "split: 'validation' is not one of 'train', 'test', 'none'"),
    ("motion", _sub('motion = "straight"', 'motion = "circle"'), "motion: 'circle' is not one of"),
    ("rest reversed", _sub("rest = [0.2, 2.0]", "rest = [2.0, 0.2]"), "rest: [2, 0.2] is empty"),
    ("rest word", _sub("rest = [0.2, 2.0]", 'rest = "sometimes"'), "rest: 'sometimes', expected 'auto', 'none'"),
    ("rest beyond", _sub("rest = [0.2, 2.0]", "rest = [0.2, 20.0]"), "rest: [0.2, 20] ends after the recording"),
    ("initial", _sub('initial = "truth"', 'initial = "moving"'), "initial: 'moving' is not one of 'rest', 'truth'"),
    ("initial truth on a route", _sub('split = "train"', 'split = "train"\ninitial = "truth"'),
     "initial: 'truth' needs a truth track"),
    ("duplicate id", _sub('id = "b"', 'id = "a"'), "id: 'a' is the id of [[recording]] 1 too"),
    ("id a number", _sub('id = "b"', "id = 2"), "id: an integer 2, expected a string"),
    ("missing file", _sub('file = "a.csv"', 'file = "gone.csv"'), "imu.file: ", "gone.csv: no such file"),
    ("format", _sub('file = "a.csv"', 'file = "a.csv", format = "parquet"'), "imu.format: 'parquet' is not one of"),
    ("time unit", _imu_a('time_unit = "min"'), "imu.time_unit: 'min' is not one of 's', 'ms', 'us', 'ns'"),
    ("accel unit", _imu_a('accel_unit = "G"'), "imu.accel_unit: 'G' is not one of 'm/s^2', 'g' (nearest: 'g')"),
    ("gyro unit", _imu_a('gyro_unit = "deg/sec"'),
     "imu.gyro_unit: 'deg/sec' is not one of 'rad/s', 'deg/s' (nearest: 'deg/s')"),
    ("left-handed axes", _sub('axes = "FLU"', 'axes = "FRU"'), "imu.axes: 'FRU' is left-handed"),
    ("repeated axis", _sub('axes = "FLU"', 'axes = "FBU"'), "imu.axes: 'FBU' repeats an axis"),
    ("unknown axes", _sub('axes = "FLU"', 'axes = "XYZ"'), "imu.axes: 'XYZ', expected three letters"),
    ("skip_rows negative", _imu_a("skip_rows = -1"), "imu.skip_rows: -1 is below 0"),
    ("skip_rows a number", _imu_a("skip_rows = 1.5"), "imu.skip_rows: a number 1.5, expected a whole number"),
    ("rate a string", _imu_b('rate_hz = "fast"'), "imu.rate_hz: a string 'fast', expected a number"),
    ("rate disagrees", _imu_b("rate_hz = 250.0"), "imu.rate_hz: 250 Hz, but the time column gives 100 Hz"),
    ("no time, no rate", lambda t: _sub(_B, 'imu = { file = "n.npy", ' + _NPY_COLS + " }")(
        t.replace("rate_hz = 100.0\n", "")), "imu.rate_hz: missing, expected the sampling rate"),
    ("skip_rows on npy", _sub(_B, 'imu = { file = "n.npy", skip_rows = 1, ' + _NPY_COLS + " }"),
     "imu.skip_rows: not used by an .npy file"),
    ("column key", _imu_b('columns = { time = "t", acc_x = "ax" }'), "imu.columns: unknown key 'acc_x'"),
    ("column missing", _imu_b('columns = { time = "t", f_x = "ax", ' + _SIX + " }"), "imu.columns: missing g_z"),
    ("column index in a CSV", _imu_b('columns = { time = 0, f_x = "ax", ' + _SIX + ', g_z = "gz" }'),
     "imu.columns.time: 0, expected a header name"),
    ("column twice", _imu_b('columns = { time = "t", f_x = "ax", f_y = "ax", f_z = "az", g_x = "gx", g_y = "gy", '
                            'g_z = "gz" }'), "imu.columns.f_y: 'ax' is also f_x"),
    ("truth missing", _sub('truth = { kind = "route", distance_m = 2.0, end_point_m = [2.0, 0.0] }\n', ""),
     "truth: missing"),
    ("truth kind", _sub('kind = "route"', 'kind = "gps"'), "truth.kind: 'gps' is not one of 'route', 'track'"),
    ("end point shape", _sub("end_point_m = [2.0, 0.0]", "end_point_m = [2.0, 0.0, 0.0]"),
     "truth.end_point_m: an array [2.0, 0.0, 0.0], expected [x, y]"),
    ("distance", _sub("distance_m = 2.0", "distance_m = -2.0"), "truth.distance_m: -2.0, expected a number above 0"),
    ("route without end", _sub(", end_point_m = [2.0, 0.0]", ""), "truth.end_point_m: missing"),
    ("polyline off the end", _sub("end_point_m = [2.0, 0.0]", "end_point_m = [2.0, 0.0], "
                                                               "polyline_m = [[0.0, 0.0], [1.0, 1.0]]"),
     "truth.polyline_m: ends at [1.0, 1.0], expected end_point_m"),
    ("track key on a route", _sub("end_point_m = [2.0, 0.0]", 'end_point_m = [2.0, 0.0], frame = "NED"'),
     "truth.frame: not used by kind = 'route'"),
    ("latitude beyond a pole", _sub('description = "two recordings"', 'description = "two recordings"\n'
                                                                       "latitude_deg = 95.0"),
     "latitude_deg: 95.0, expected a latitude in degrees from -90 to 90"),
    ("latitude a string", _sub('description = "two recordings"', 'description = "two recordings"\n'
                                                                  'latitude_deg = "32.8 N"'),
     "latitude_deg: a string '32.8 N', expected a number"),
    ("spec an unknown IMU", _imu_a('spec = "LSM6DS3"'),
     "imu.spec: 'LSM6DS3' is not an IMU the package knows ('MPU-6500', 'LSM6DSL') (nearest: 'LSM6DSL')"),
    ("glob with an id", _sub('file = "a.csv"', 'file = "a*.csv"'), "id: not used with a glob imu.file"),
    ("glob with a track", lambda t: _sub('id = "b"\n', "")(_sub(_B, 'imu = { file = "[b].csv" }')(t)),
     "truth.kind: 'track' with a glob imu.file"),
    ("frame", _sub('frame = "NED"', 'frame = "NEU"'), "truth.frame: 'NEU' is not one of 'NED', 'ENU'"),
    ("frame against letters", _sub('frame = "NED"', 'frame = "ENU"'),
     "truth.frame: 'ENU', but columns name the NED axes"),
    ("mixed letters", _sub('n = "n", e = "e", d = "d"', 'n = "n", e = "e", z = "d"'),
     "truth.columns: expected time (optional) and x, y, z"),
    ("offset", _sub("offset_s = -0.1", 'offset_s = "soon"'), "truth.offset_s: a string 'soon', expected a number"),
    ("truth file", _sub('file = "t.csv"', 'file = "nowhere.csv"'), "truth.file: ", "nowhere.csv: no such file"),
    ("evaluation key", _sub("[defaults]", '[evaluation]\nheld_ot = "group"\n\n[defaults]'),
     "[evaluation]: unknown key 'held_ot', the nearest known one is 'held_out'"),
    ("evaluation value", _sub("[defaults]", '[evaluation]\nins_span = "all"\n\n[defaults]'),
     "evaluation.ins_span: 'all', expected one of 'motion', 'full'"),
    ("evaluation not a table", _sub('description = "two recordings"', 'description = "two recordings"\n'
                                                                       "evaluation = 3"),
     "evaluation: an integer 3, expected a table [evaluation]"),
    ("train_group without train runs", _sub('id = "b"', 'id = "b"\ntrain_group = "elsewhere"'),
     "recording 'b': train_group: 'elsewhere' has no train recording"),
    ("train_group split in a group", _sub('id = "b"', 'id = "b"\ntrain_group = "bench"'),
     "recording 'b': train_group: 'bench', but recording 'a' of the same group 'bench' says None"),
]


@pytest.mark.parametrize("label, edit, expect", [(m[0], m[1], m[2:]) for m in MALFORMED],
                         ids=[m[0] for m in MALFORMED])
def test_a_malformed_manifest_exits_2_with_one_line_naming_the_key(tmp_path, capsys, label, edit, expect):
    folder = _base(tmp_path)
    path = folder / "dataset.toml"
    path.write_text(_GOOD)
    assert main(["check", "--dataset", str(path)]) == 0                # the good manifest passes
    capsys.readouterr()
    path.write_text(edit(_GOOD))
    code = main(["check", "--dataset", str(path)])
    out = capsys.readouterr()
    assert code == 2 and "Traceback" not in out.out + out.err
    problems = [s for s in (out.out + out.err).splitlines() if "recording(s) OK" not in s]
    assert len(problems) >= 1 and all(s.count(str(path)) >= 1 for s in problems), problems
    assert any(all(e in s for e in expect) for s in problems), problems


def test_there_are_thirty_malformed_manifests_or_more():
    assert len(MALFORMED) >= 30


def test_check_from_the_command_line_without_a_traceback(tmp_path):
    folder = _base(tmp_path)
    path = folder / "dataset.toml"
    path.write_text(_GOOD.replace('axes = "FLU"', 'axes = "FRU"'))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "check", "--dataset", str(path)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "Traceback" not in r.stdout + r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2 and "[[recording]] 1 (id 'a'): imu.axes: 'FRU' is left-handed" in lines[0]
    assert lines[1] == f"1 recording(s) OK, 1 problem(s) in {path}"
    r = subprocess.run([sys.executable, "-m", "morpi_filters.cli", "check", "--dataset", str(path),
                        "--data", str(folder)], capture_output=True, text=True, env=env)
    assert r.returncode == 2 and r.stderr.startswith("morpi: error: --data and --dataset: give one")


# ----------------------------------------------------------------------------- refused: bad data (exit 1)

@pytest.mark.parametrize("label, make, expect", [
    ("time back", lambda f: f.write_text(f.read_text().replace("\n0.5,", "\n0.3,", 1)),
     r"imu.file: .*a.csv: line 52: decreasing time stamp"),
    ("gap", lambda f: _imu_csv(f, [[k * 0.01 + (1.5 if k > 100 else 0.0), 0.0, 0.0, 9.81, 0.0, 0.0, 0.0]
                                   for k in range(300)]), r"imu.file: .*a.csv: line 103: time gap of 1.51 s"),
    ("not a number", lambda f: f.write_text(f.read_text().replace("\n0.5,0.0", "\n0.5,abc", 1)),
     r"imu.file: .*a.csv: line 52: column ax: 'abc' is not a number"),
    ("track shorter", lambda f: (f.parent / "t.csv").write_text("t,n,e,d\n0.0,0,0,0\n0.1,0,0,0\n"),
     r"\(id 'b'\): truth: the track covers .* truth shorter than the recording"),
    ("track not a table of numbers", lambda f: (f.parent / "t.csv").write_text("t,n,e,d\n0.0,0,0\n"),
     r"truth.file: .*t.csv: line 2: short row"),
])
def test_bad_data_exits_1_naming_the_manifest_key_and_the_line(tmp_path, capsys, label, make, expect):
    import re

    folder = _base(tmp_path)
    path = folder / "dataset.toml"
    path.write_text(_GOOD)
    make(folder / "a.csv")
    code = main(["check", "--dataset", str(path)])
    out = capsys.readouterr()
    lines = out.out.strip().splitlines()
    assert code == 1 and len(lines) == 2 and lines[0].startswith(f"{path}: [[recording]] ")
    assert re.search(expect, lines[0]), lines[0]


def test_a_truth_track_of_the_wrong_shape_is_refused(tmp_path):
    folder = _base(tmp_path)
    np.save(folder / "t.npy", np.zeros(40))
    path = folder / "dataset.toml"
    path.write_text(_GOOD.replace('truth.file = "t.csv"', 'truth.file = "t.npy"\ntruth.rate_hz = 10.0')
                    .replace('{ time = "t", n = "n", e = "e", d = "d" }', "{ n = 0, e = 1, d = 2 }"))
    with pytest.raises(DataError, match=r"\(id 'b'\): truth.file: .*t.npy: array of shape \(40,\), expected 2-D"):
        load_dataset(path)


# ----------------------------------------------------------------------------- the reference page's examples

def _doc_block(heading: str) -> str:
    """The TOML block of docs/manifest.md under a heading."""
    text = (ROOT / "docs" / "manifest.md").read_text()
    section = text.split(heading, 1)[1]
    return section.split("```toml\n", 1)[1].split("```", 1)[0]


def test_the_csv_example_of_the_reference_page_loads(tmp_path):
    from morpi_filters.simulate import imu, sine

    (tmp_path / "imu").mkdir()
    sims = {}
    for k, name in enumerate(("run-01", "run-02")):
        traj = sine(3.0, rest_s=(4.5, 1.0))
        n = int(traj.end_time * 200) + 1
        clock_us = 1_697_040_000_000_000 + 5000 * np.arange(n, dtype=np.int64)       # Unix time, 200 Hz
        data = imu(traj, units.LSM6DSL, np.random.default_rng(k), sampling=(clock_us - clock_us[0]) / 1e6,
                   bias_scale=0.0, noise_scale=0.0)
        f_frd = data.f * [1.0, -1.0, -1.0] / units.G0
        w_frd = data.omega * [1.0, -1.0, -1.0] * 180 / math.pi
        lines = ["# MyLogger v2.3, board 7", "timestamp_us, ax_g, ay_g, az_g, gx_dps, gy_dps, gz_dps, temp_c,"]
        lines += [", ".join([str(int(clock_us[i]))] + [repr(float(v)) for v in (*f_frd[i], *w_frd[i])] + ["31.5"]) + ","
                  for i in range(n)]
        (tmp_path / "imu" / f"{name}.csv").write_text("\n".join(lines) + "\n")
        sims[name] = data
    path = tmp_path / "dataset.toml"
    path.write_text(_doc_block("## Example: a CSV dataset"))
    ds = load_dataset(path)
    a, b = ds["run-01"], ds["run-02"]
    assert (a.split, a.group, a.rest, b.split) == ("train", "1 m periods", (0.5, 4.0), "test")
    assert a.recording.time[0] == 0.0 and a.recording.rate_hz == pytest.approx(200.0)
    for name, data in sims.items():       # g, deg/s and FRD back to the simulator's SI body frame, to rounding
        np.testing.assert_allclose(ds[name].recording.f, data.f, rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(ds[name].recording.omega, data.omega, rtol=1e-15, atol=1e-15)
    assert a.recording.f[0, 2] == pytest.approx(units.G0, rel=1e-12)
    assert b.truth.polyline.tolist() == [[0.0, 0.0], [18.0, 0.0], [18.0, -10.0]]


def test_the_npy_example_of_the_reference_page_loads(tmp_path):
    from morpi_filters.simulate import imu, straight

    (tmp_path / "imu").mkdir()
    (tmp_path / "mocap").mkdir()
    sims = {}
    for k, (name, offset) in enumerate((("lab-01", -0.4), ("lab-02", -0.25))):
        traj = straight(3.0, rest_s=(0.0, 1.0))
        begin = traj.start_time + 1.5                                   # moving from the first sample
        n = int((traj.end_time - begin) * 120)
        data = imu(traj, units.LSM6DSL, np.random.default_rng(k), sampling=begin + np.arange(n) / 120.0)
        # axes RFU: the file's x is right (minus left), y forward, z up
        f_rfu = np.column_stack([-data.f[:, 1], data.f[:, 0], data.f[:, 2]])
        w_rfu = np.column_stack([-data.omega[:, 1], data.omega[:, 0], data.omega[:, 2]])
        np.save(tmp_path / "imu" / f"{name}.npy", np.hstack([w_rfu, f_rfu]))
        m = int(np.ceil((n / 120.0 - offset) * 10)) + 2
        t_rel = offset + np.arange(m) / 10.0
        pos = traj.at(begin + t_rel).position                          # x east (the heading), y north, z up
        rows = [f"{7000 + 100 * i},{float(pos[i, 1])!r},{float(pos[i, 0])!r},{float(-pos[i, 2])!r}" for i in range(m)]
        (tmp_path / "mocap" / f"{name}.csv").write_text("t_ms,north_m,east_m,down_m\n" + "\n".join(rows) + "\n")
        sims[name] = (data, pos, t_rel)
    path = tmp_path / "dataset.toml"
    path.write_text(_doc_block("## Example: `.npy` arrays with a truth track"))
    ds = load_dataset(path)
    for name, (data, pos, t_rel) in sims.items():
        got = ds[name]
        assert (got.rest, got.initial, got.truth.source_frame) == ("none", "truth", "NED")
        np.testing.assert_array_equal(got.recording.f, data.f)
        np.testing.assert_array_equal(got.recording.omega, data.omega)
        np.testing.assert_array_equal(got.truth.position, pos)
        np.testing.assert_allclose(got.truth.time, t_rel, rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- globs, a root, gravity, named IMUs

def _glob_tree(root: Path) -> Path:
    (root / "runs").mkdir(parents=True)
    (root / "other").mkdir()
    for name in ("10.csv", "2.csv", "1.csv", "run.csv"):
        _imu_csv(root / "runs" / name, _still_rows())
    _imu_csv(root / "other" / "3.csv", _still_rows())
    return root


def test_a_glob_gives_one_recording_per_file_in_number_order_with_its_path_as_id(tmp_path):
    folder = _glob_tree(tmp_path / "copy")
    body = (f'[[recording]]\ngroup = "g"\nimu = {{ file = "runs/*.csv", columns = {_COLS} }}\n{_ROUTE}\n'
            f'[[recording]]\nid = "x"\nimu = {{ file = "other/3.csv", columns = {_COLS} }}\n{_ROUTE}\n')
    ds = load_dataset(_manifest(folder, body))
    assert [r.id for r in ds.recordings] == ["runs/1.csv", "runs/2.csv", "runs/10.csv", "runs/run.csv", "x"]
    assert [r.recording.source for r in ds.recordings[:2]] == [str(folder / "runs" / "1.csv"),
                                                               str(folder / "runs" / "2.csv")]
    assert {r.group for r in ds.recordings[:4]} == {"g"}
    # the same manifest read against another folder: its files, its ids
    other = _glob_tree(tmp_path / "other-copy")
    (other / "runs" / "10.csv").unlink()
    ds2 = load_dataset(folder / "dataset.toml", root=other)
    assert [r.id for r in ds2.recordings] == ["runs/1.csv", "runs/2.csv", "runs/run.csv", "x"]
    assert ds2["x"].recording.source == str(other / "other" / "3.csv")
    assert check_dataset(folder / "dataset.toml", root=other) == ([], 4)


def test_globs_that_match_nothing_give_no_recording_and_a_manifest_of_none_is_refused(tmp_path):
    from morpi_filters.manifest import index_dataset

    body = f'[[recording]]\ngroup = "g"\nsplit = "train"\nimu = {{ file = "runs/*.csv" }}\n{_ROUTE}\n'
    path = _manifest(tmp_path, body)
    index = index_dataset(path)
    assert index.recordings == () and index.declared == (("g", "train", "periodic"),)
    with pytest.raises(ParameterError, match="recording: the glob imu.file patterns match no file under"):
        load_dataset(path)
    problems, n_ok = check_dataset(path)
    assert n_ok == 0 and len(problems) == 1 and "match no file" in str(problems[0])
    with pytest.raises(ParameterError, match="not a directory, expected the folder the manifest's file names start"):
        load_dataset(path, root=tmp_path / "nowhere")


def test_a_named_imu_is_the_packages_spec(tmp_path):
    _imu_csv(tmp_path / "a.csv", _still_rows())
    body = f'[[recording]]\nid = "a"\nimu = {{ file = "a.csv", columns = {_COLS}, spec = "MPU-6500" }}\n{_ROUTE}'
    assert load_dataset(_manifest(tmp_path, body))["a"].recording.imu is units.MPU6500


@pytest.mark.parametrize("latitude", [None, 0.0, 32.8, -90.0])
def test_the_latitude_sets_the_gravity_the_calibrations_take(latitude):
    """At rest GAC leaves exactly (0, 0, g) on the mean specific force: g the WGS84 normal gravity at the
    manifest's latitude (Somigliana's closed form), or standard gravity without one."""
    from morpi_filters.calibration import normal_gravity
    from morpi_filters.field import FieldData

    rng = np.random.default_rng(3)
    t = np.arange(600) / 100.0
    f = np.array([0.2, -0.1, 9.79]) + 0.01 * rng.standard_normal((600, 3))
    w = 0.001 * rng.standard_normal((600, 3))
    w[400:, 2] += 0.4 * np.sin(2 * np.pi * t[400:])
    truth = RouteTruth(distance_m=1.0, end_point_m=np.array([1.0, 0.0]))
    ds = Dataset.from_arrays("bench", [{"id": "a", "time": t, "f": f, "omega": w, "truth": truth,
                                        "rest": [0.0, 3.0]}], latitude_deg=latitude)
    data = FieldData(ds)
    rec = data.recording_at("a")
    crec, _ = data.calibrated(rec, "GAC")
    window = data.rest_window(rec)
    g = units.G0 if latitude is None else normal_gravity(latitude)
    np.testing.assert_allclose(crec.f[window.i0:window.i1].mean(axis=0), [0.0, 0.0, g], rtol=0, atol=1e-12)
    assert data._g_local == g
    with pytest.raises(ParameterError, match="latitude_deg: 91.0, expected a latitude"):
        Dataset.from_arrays("bench", [{"id": "a", "time": t, "f": f, "omega": w, "truth": truth}], latitude_deg=91.0)


def test_the_shipped_morpi_manifest_is_what_its_generator_writes():
    from morpi_filters.resources import morpi_manifest

    sys.path.insert(0, str(ROOT / "analysis"))
    try:
        import morpi_manifest as generator
    finally:
        sys.path.remove(str(ROOT / "analysis"))
    assert morpi_manifest().read_text() == generator.manifest_text()


def test_the_morpi_manifest_applied_to_a_root_lists_the_catalogues_recordings(tmp_path):
    """Every CSV of the layout in the catalogue's folders, each folder in number order, ids the relative paths;
    the groups of the train recordings those that train the paper's short-route table, in its order."""
    from morpi_filters import dataset as mds
    from morpi_filters.evaluate import cell_specs
    from morpi_filters.manifest import index_dataset
    from morpi_filters.resources import morpi_manifest

    rels = [f"{folder}/{n}.csv" for folder in mds.layout() for n in (1, 2, 11)] + ["notes/x.csv", "s8/L_line/1.csv"]
    for rel in rels:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).touch()
    index = index_dataset(morpi_manifest(), root=tmp_path)
    cat = [e.relpath for e in mds.catalogue(tmp_path)
           if "/".join(p for p in (e.phone, e.route, e.split) if p) in mds.layout()]
    ids = [r.id for r in index.recordings]
    assert sorted(ids) == sorted(cat) and len(ids) == 3 * len(mds.layout())
    for folder in mds.layout():           # within each folder, the catalogue's order
        assert [i for i in ids if i.startswith(folder + "/")] == [c for c in cat if c.startswith(folder + "/")]
    for r in index.recordings:
        phone, route, *_ = r.id.split("/")
        assert r.group == f"{phone}/{route}" and r.file == tmp_path / r.id
        assert r.split == (r.id.split("/")[2] if r.id.count("/") == 3 else "none")
        assert r.motion == ("periodic" if mds.route(route).kind == "periodic" else "straight")
    train = [g for g, split, motion in index.declared if split == "train"]
    assert train == list(dict.fromkeys(f"{s.train[0]}/{s.train[1]}" for s in cell_specs() if s.table == "short_route"))
    assert index.latitude_deg == 32.8


def test_a_glob_count_names_each_pattern_that_matches_another_number_of_files(tmp_path):
    """imu.count: one DataError line per glob table that finds fewer or more files than declared (a missing folder
    named as such), none for one that finds its count; loading ignores it; on a single file it is refused."""
    from conftest import good_rows, write_rows
    from morpi_filters.manifest import count_problems

    for rel in ("a/1.csv", "a/2.csv", "b/1.csv", "c/1.csv", "c/2.csv", "c/3.csv"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        write_rows(tmp_path / rel, good_rows())
    head = 'format_version = 1\nname = "counted"\n'
    truth = 'truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }\n'
    tables = [("a/*.csv", 2), ("b/*.csv", 3), ("c/*.csv", 1), ("gone/*.csv", 4)]
    text = head + "".join(f'[[recording]]\nimu = {{ file = "{p}", count = {n} }}\n' + truth for p, n in tables)
    man = tmp_path / "dataset.toml"
    man.write_text(text)
    problems, n_ok = check_dataset(man)
    assert n_ok == 6 and all(isinstance(p, DataError) for p in problems)
    assert [str(p) for p in problems] == [
        f"{man}: [[recording]] 2: imu.file: 'b/*.csv' matches 1 file(s) under {tmp_path}, expected 3 (imu.count)",
        f"{man}: [[recording]] 3: imu.file: 'c/*.csv' matches 3 file(s) under {tmp_path}, expected 1 (imu.count)",
        f"{man}: [[recording]] 4: imu.file: 'gone/*.csv' matches no file: missing folder {tmp_path / 'gone'}, "
        "expected 4 file(s) (imu.count)"]
    assert [str(p) for p in count_problems(man)] == [str(p) for p in problems]
    # counts given by the caller replace the manifest's: a pattern they leave out has none
    assert [str(p) for p in count_problems(man, counts={"b/*.csv": 1, "gone/*.csv": 2})] == [
        f"{man}: [[recording]] 4: imu.file: 'gone/*.csv' matches no file: missing folder {tmp_path / 'gone'}, "
        "expected 2 file(s) (imu.count)"]
    assert len(load_dataset(man)) == 6
    # nothing matches: one line for the whole manifest, of the data (exit 1)
    empty = tmp_path / "empty"
    empty.mkdir()
    problems, n_ok = check_dataset(man, root=empty)
    assert n_ok == 0 and len(problems) == 1 and isinstance(problems[0], DataError)
    assert str(problems[0]) == (f"{empty}: no recordings: no file matches the imu.file patterns of {man}, expected "
                                "10 recording(s) (imu.count)")
    man.write_text(head + '[[recording]]\nimu = { file = "a/1.csv", count = 1 }\n' + truth)
    with pytest.raises(ParameterError, match=r"\[\[recording\]\] 1: imu.count: not used without a glob imu.file"):
        load_dataset(man)
    man.write_text(head + '[[recording]]\nimu = { file = "a/*.csv", count = 0 }\n' + truth)
    (p,), _ = check_dataset(man)
    assert isinstance(p, ParameterError) and str(p) == f"{man}: [[recording]] 1: imu.count: 0 is below 1"


def test_the_morpi_manifest_counts_the_runs_of_the_public_dataset():
    """Each folder's table of data/morpi.toml declares the folder's runs (routes.json's layout): 143 in all."""
    import tomllib

    from morpi_filters import dataset as mds
    from morpi_filters.manifest.schema import read_manifest
    from morpi_filters.resources import morpi_manifest

    doc = tomllib.loads(morpi_manifest().read_text())
    counts = {r["imu"]["file"].rsplit("/", 1)[0]: r["imu"]["count"] for r in doc["recording"]}
    assert counts == mds.layout() and sum(counts.values()) == 143
    globs = read_manifest(morpi_manifest()).globs                        # every table is a glob with its count
    assert [(pattern, n) for _, pattern, _, n in globs] == [(f"{k}/*.csv", n) for k, n in counts.items()]
