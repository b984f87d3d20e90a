"""``morpi evaluate --dataset``: the methods on simulated manifest datasets against the simulator's truth, the
reported metrics against an independent computation from the written files, and the train-only choices."""
from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from morpi_filters.cli import main
from morpi_filters.dataset_eval import evaluate
from morpi_filters.foreign import LAYOUTS, write_foreign_dataset
from morpi_filters.manifest import Dataset, load_dataset


def _given_rest(manifest: Path) -> None:
    """Give every recording the rest window [0.1, 1.8] s (the simulator rests for 2 s): on noiseless readings
    the automatic detection has no noise to scale its thresholds by and runs into the start of the motion."""
    text = manifest.read_text().replace('\nrest = [0.1, 1.8]', '')
    manifest.write_text(text.replace('motion = "', 'rest = [0.1, 1.8]\nmotion = "'))


def test_noise_free_ins_paths_lie_within_a_centimetre_of_the_truth_track(tmp_path):
    ds = write_foreign_dataset(tmp_path / "nf", LAYOUTS["truth-ned"], noise_free=True)
    _given_rest(ds.manifest)
    result = evaluate(load_dataset(ds.manifest), course_m=0.05)
    ins = [p for p in result.paths if p.method.startswith("INS")]
    assert len(ins) == 2 * 2 * 3                  # two recordings, two INS, three calibrations
    worst = max(p.metrics["path_rmse_m"] for p in ins)
    assert worst < 0.01, worst
    assert all(p.metrics["end_error_m"] < 0.02 for p in ins)


def test_noise_free_runs_that_start_moving_take_their_velocity_from_the_truth_track(tmp_path):
    ds = write_foreign_dataset(tmp_path / "nf", LAYOUTS["moving-start"], noise_free=True)
    data = load_dataset(ds.manifest)
    assert {dr.initial for dr in data.recordings} == {"truth"}
    result = evaluate(data)
    assert len(result.paths) == 2 * 2 and all(s["speed_mps"] > 0.3 for s in result.starts)
    worst = max(p.metrics["path_rmse_m"] for p in result.paths)
    assert worst < 0.01, worst


def _segment_distance(p, a, b) -> float:
    d = b - a
    u = 0.0 if not d.any() else min(1.0, max(0.0, float((p - a) @ d) / float(d @ d)))
    return float(np.linalg.norm(p - (a + u * d)))


def _polyline_distance(p, line) -> float:
    return min(_segment_distance(p, line[i], line[i + 1]) for i in range(len(line) - 1))


def test_reported_metrics_equal_a_computation_from_the_track_files_and_the_truth_file(tmp_path, capsys):
    ds = write_foreign_dataset(tmp_path / "data", LAYOUTS["truth-ned"], seed=3)
    out = tmp_path / "eval"
    assert main(["evaluate", "--dataset", str(ds.manifest), "--out", str(out), "--json",
                 str(tmp_path / "r.json")]) == 0
    result = json.loads((out / "result.json").read_text())
    assert json.loads((tmp_path / "r.json").read_text()) == result
    assert (out / "README.md").is_file()
    rows = result["recordings"]
    assert {r["method"] for r in rows} == {"INS-3D", "INS-2D"} and len(rows) == 12
    for run in ds.runs:
        imu_t0 = float(np.loadtxt(run.imu_file, delimiter=",", skiprows=1, max_rows=1)[0])
        raw = np.loadtxt(run.truth_file, delimiter=",", skiprows=1)            # t, pos_n, pos_e, pos_d
        tt = imu_t0 + LAYOUTS["truth-ned"].truth_offset_s + (raw[:, 0] - raw[0, 0])
        east, north = raw[:, 2], raw[:, 1]
        for row in (r for r in rows if r["id"] == run.id):
            est = np.loadtxt(out / row["track_file"], delimiter=",", skiprows=1)
            t, x, y = est[:, 0], est[:, 1], est[:, 2]
            inside = (tt >= t[0]) & (tt <= t[-1])
            ex, ey = np.interp(tt[inside], t, x), np.interp(tt[inside], t, y)
            rmse = math.sqrt(np.mean((ex - east[inside]) ** 2 + (ey - north[inside]) ** 2))
            # the truth over the estimate's span: its samples inside and the span's ends
            ts = np.r_[t[0], tt[inside], t[-1]]
            te, tn = np.interp(ts, tt, east), np.interp(ts, tt, north)
            length = np.sum(np.hypot(np.diff(te), np.diff(tn)))
            end = math.hypot(x[-1] - te[-1], y[-1] - tn[-1])
            sx, sy = np.interp(ts, t, x), np.interp(ts, t, y)
            est_length = np.sum(np.hypot(np.diff(sx), np.diff(sy)))
            line = np.column_stack([te, tn])
            cross = math.sqrt(np.mean([_polyline_distance(np.array([a, b]), line) ** 2 for a, b in zip(sx, sy)]))
            assert row["path_rmse_m"] == pytest.approx(rmse, rel=1e-9, abs=1e-12)
            assert row["end_error_m"] == pytest.approx(end, rel=1e-9, abs=1e-12)
            assert row["end_error_percent"] == pytest.approx(100 * end / length, rel=1e-9, abs=1e-12)
            assert row["distance_error_percent"] == pytest.approx(100 * (est_length - length) / length, rel=1e-9,
                                                                  abs=1e-12)
            assert row["cross_track_rmse_m"] == pytest.approx(cross, rel=1e-9, abs=1e-12)
            assert row["estimate"] is None and row["track_file"] == f"tracks/{run.id}/{row['method']}_" \
                                                                    f"{row['calibration']}.csv"


def test_a_recording_without_rest_gets_raw_data_only_and_is_listed(tmp_path):
    ds = write_foreign_dataset(tmp_path / "moving", LAYOUTS["moving-start"], seed=1)
    data = load_dataset(ds.manifest)
    assert {dr.rest for dr in data.recordings} == {"none"}
    result = evaluate(data)
    assert result.paths and {p.calibration for p in result.paths} == {"RD"}
    listed = {x["id"]: x for x in result.left_out if x["what"] == "GC, GAC"}
    assert set(listed) == {dr.id for dr in data.recordings}
    assert all("none" in x["why"] for x in listed.values())


def _corrupted(dr):
    rec = dr.recording
    bad = replace(rec, f=rec.f * np.array([1.3, -0.7, 1.0]) + 0.2, omega=rec.omega * 2.0 + 0.05)
    return replace(dr, recording=bad)


def test_corrupting_every_test_recording_leaves_the_choices_unchanged(tmp_path):
    ds = write_foreign_dataset(tmp_path / "groups", LAYOUTS["groups"], seed=2)
    data = load_dataset(ds.manifest)
    assert {dr.split for dr in data.recordings} == {"train", "test"}
    clean = evaluate(data)
    dirty = evaluate(Dataset(name=data.name, source=data.source,
                                     recordings=[_corrupted(dr) if dr.split == "test" else dr
                                                 for dr in data.recordings]))
    assert any(g["mean"] is not None for g in clean.choices["gains"])
    assert json.dumps(dirty.choices, sort_keys=True) == json.dumps(clean.choices, sort_keys=True)
    assert clean.groups_over == "test"
    # the corruption is seen where it may be: on the test rows
    before = {(p.id, p.method, p.calibration): p.metrics["end_error_m"] for p in clean.paths if p.split == "test"}
    after = {(p.id, p.method, p.calibration): p.metrics["end_error_m"] for p in dirty.paths if p.split == "test"}
    assert any(before[k] != after.get(k) for k in before)


def test_evaluate_on_a_malformed_manifest_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "dataset.toml"
    bad.write_text('format_version = 1\nname = "x"\n[[recording]]\nid = "a"\nimu = { file = "a.csv" }\n'
                   'truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }\nspeed = 3\n')
    assert main(["evaluate", "--dataset", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "speed" in err
    assert not (tmp_path / "out").exists()


def test_a_truth_track_that_never_moves_leaves_its_recording_out_with_the_reason():
    from morpi_filters.manifest import TruthTrack

    t = np.arange(400) / 100.0
    still = {"time": t, "f": np.tile([0.0, 0.0, 9.81], (400, 1)), "omega": np.zeros((400, 3)),
             "motion": "straight", "rest": [0.0, 1.0],
             "truth": TruthTrack(time=t[::10], position=np.zeros((40, 3)))}
    result = evaluate(Dataset.from_arrays("bench", [dict(still, id="a")]))
    assert result.paths == ()
    assert [(x["id"], x["what"]) for x in result.left_out] == [("a", "every method")]
    assert "never moves" in result.left_out[0]["why"]


def _sine_recording(seed, split, group, **kw):
    from morpi_filters import simulate, units
    from morpi_filters.manifest import RouteTruth

    traj = simulate.sine(4.0, rest_s=(2.0, 1.5), **kw)
    d = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(seed), bias_scale=(0.25, 0.3))
    return {"id": f"{group}-{split}-{seed}", "time": d.time, "f": d.f, "omega": d.omega, "split": split,
            "group": group, "motion": "periodic", "rest": [0.1, 1.8],
            "truth": RouteTruth(distance_m=float(traj.distance), end_point_m=np.asarray(traj.end_point[:2], float))}


def _test_end_errors(result, method):
    return [p.metrics["end_error_percent"] for p in result.paths
            if p.split == "test" and p.method == method and p.calibration == "GC"]


def test_the_rule_searched_on_the_train_runs_beats_the_phones_rule_on_the_test_runs(monkeypatch):
    # a fast, narrow sway (0.8 m periods at 1.6 m/s, 6 cm to each side): the phones' MoRPI-A rule miscounts a
    # test run, the rule searched on the dataset's own train runs does not
    from morpi_filters import field as fd
    from morpi_filters import steps as st

    data = Dataset.from_arrays("sway", [_sine_recording(i, "train" if i % 3 else "test", "g", p2p_m=0.8,
                                                        amplitude_m=0.06, speed_mps=1.6) for i in range(1, 7)])
    searched = evaluate(data)
    rule = searched.choices["rule"]["MoRPI-A"]
    assert searched.choices["held_out"]["used"] == "recording"
    assert rule["from"].startswith("field.select_config") and rule["runs_scored"]["recording"] == 4
    assert rule["score_percent"]["group"] is None                      # one group: no leave-one-group-out
    # the same evaluation with the phones' rule (the fallback when nothing scores)
    monkeypatch.setattr(fd, "select_config",
                        lambda *a, **k: fd.Selection("x", st.StepConfig(), float("inf"), (), 0))
    phones = evaluate(data)
    assert phones.choices["rule"]["MoRPI-A"]["from"].startswith("steps.DEFAULT_CONFIGS")
    assert phones.choices["rule"]["MoRPI-A"]["config"]["ends"] == st.DEFAULT_CONFIGS["MoRPI-A"].ends
    got, base = _test_end_errors(searched, "MoRPI-A"), _test_end_errors(phones, "MoRPI-A")
    assert len(got) == len(base) == 2
    assert np.mean(got) < 0.5 * np.mean(base)


def test_a_dataset_without_train_recordings_falls_back_to_the_phones_rule():
    from morpi_filters import steps as st

    data = Dataset.from_arrays("bench", [_sine_recording(i, "none", "g") for i in (1, 2)])
    result = evaluate(data)
    for m in ("MoRPI-A", "MoRPI-G"):
        c = result.choices["rule"][m]
        assert c["from"].startswith("steps.DEFAULT_CONFIGS") and "no train recording" in c["from"]
        assert c["config"] == {k: getattr(st.DEFAULT_CONFIGS[m], k) for k in c["config"]}
    assert result.choices["train_sets"] == []
    assert all("default" in t["from"] for t in result.choices["thresholds"].values())


def test_the_leave_one_group_out_score_is_the_numpy_computation_from_the_steps(tmp_path):
    # two groups with periodic train runs (one run each): each run is dead-reckoned with the gain of the other
    # group's run; the score is the mean of the two end-point errors [%]
    from morpi_filters import field as fd
    from morpi_filters.steps import StepConfig

    ds = write_foreign_dataset(tmp_path / "groups", LAYOUTS["groups"], seed=2)
    data = load_dataset(ds.manifest)
    result = evaluate(data)
    assert result.choices["held_out"]["used"] == "group"
    assert [s["group"] for s in result.choices["train_sets"]] == ["sine-1.0m", "sine-1.5m"]
    fdata = fd.FieldData(data)
    train = [dr for dr in data.recordings if dr.split == "train" and dr.motion == "periodic"]
    for m in ("MoRPI-A", "MoRPI-G"):
        cfg = StepConfig(**result.choices["rule"][m]["config"])
        own, unit = [], []
        for dr in train:
            s = fdata.steps(dr.recording, "GC", m, cfg)
            w = np.asarray(s.weight) * np.asarray(s.fraction)
            own.append(dr.truth.distance_m / w.sum())
            unit.append([np.sum(w * np.cos(s.heading)), np.sum(w * np.sin(s.heading))])
        errs = [np.linalg.norm(own[1 - i] * np.array(unit[i]) - train[i].truth.end_point_m)
                / train[i].truth.distance_m * 100 for i in range(2)]
        assert result.choices["rule"][m]["score_percent"]["group"] == pytest.approx(np.mean(errs), rel=1e-9)
        assert result.choices["rule"][m]["runs_scored"]["group"] == 2
        assert result.choices["rule"][m]["score_percent"]["recording"] is None   # one train run per group


# ----------------------------------------------------------------------------- the tables and evaluate on one root

def _cell_rows(ev, tables, study):
    """(label, the cell's mean from the tables or the aided study, evaluate's group mean) of every cell."""
    from morpi_filters.dataset_eval import AIDED_BY

    means = {(g["group"], g["method"], g["calibration"], g["estimate"]): g for g in ev.groups}
    out = []
    for c in tables:
        group = f"{c['phone']}/{c['route']}"
        g = means.get((group, c["method"], c["calibration"], None))
        out.append((c["label"], c["percent"], c["n"], None if g is None else g["end_error_percent"],
                    None if g is None else g["n"]))
    for c in study:
        group = f"{c['phone']}/{c['route']}"
        for estimate in ("forward", "smoothed"):
            g = means.get((group, AIDED_BY[c["method"]], c["calibration"], estimate))
            out.append((f"aided {c['label']} {estimate}", c[f"{estimate}_percent"], c["n"],
                        None if g is None else g["end_error_percent"], None if g is None else g["n"]))
    return out


def test_the_shipped_manifest_gives_every_cell_of_the_tables_and_the_aided_study(tmp_path):
    """One root in the MoRPI layout, three commands: ``morpi tables`` (evaluate.evaluate_tables),
    ``morpi aided`` (field_aided.aided_study) and ``morpi evaluate`` with the package's MoRPI manifest. The
    manifest's [evaluation] settings and train groups are the tables' (runs held out of their own group, the
    INS over the motion window, the long and L routes on a short route's gains and tuning, a filter per MoRPI
    method), so every table cell and every aided cell is evaluate's group mean: the same runs, to rounding
    (1e-9 relative: the two paths differ in how a MoRPI end point is summed, G * sum(u) against the track's
    running sum, about 1e-15 relative)."""
    from morpi_filters import synthetic
    from morpi_filters.dataset_eval import evaluate
    from morpi_filters.evaluate import evaluate_tables
    from morpi_filters.field_aided import aided_study
    from morpi_filters.resources import morpi_manifest

    root = synthetic.write_dataset(tmp_path / "ds", seed=3, runs_per_folder=3)
    ev = evaluate(load_dataset(morpi_manifest(), root=root), ablation=False)
    res = evaluate_tables(root, alternatives=False)
    study = aided_study(result=res, ablation=False)
    tables = [{"label": c.spec.label, "phone": c.spec.phone, "route": c.spec.route, "method": c.spec.method,
               "calibration": c.spec.calibration, "percent": float(np.mean([r.end_error_percent for r in c.runs])),
               "n": len(c.runs)} for c in res.cells if c.runs]
    cells = [{"label": c.spec.label, "phone": c.spec.phone, "route": c.spec.route, "method": c.spec.method,
              "calibration": c.spec.calibration, "forward_percent": c.forward_percent,
              "smoothed_percent": c.smoothed_percent, "n": len(c.runs)} for c in study.cells]
    assert len(tables) == 32 and len(cells) == 24
    for label, want, n, got, m in _cell_rows(ev, tables, cells):
        assert got is not None and m == n, (label, n, m)
        assert got == pytest.approx(want, rel=1e-9), label


def test_the_shipped_manifest_gives_the_committed_cells_on_the_morpi_dataset(field_root):
    """The same on the MoRPI dataset itself, against the committed reports of ``morpi tables`` and
    ``morpi aided`` (reports/tables and reports/aided, which the report tests hold to what the code
    produces; their JSON keeps 13 significant digits, far inside 1e-9): all 32 table cells and all 24 aided
    cells, forward and smoothed."""
    import json
    from pathlib import Path

    from morpi_filters.dataset_eval import evaluate
    from morpi_filters.resources import morpi_manifest

    reports = Path(__file__).resolve().parents[1] / "reports"
    tables = json.loads((reports / "tables" / "result.json").read_text())["cells"]
    aided = json.loads((reports / "aided" / "result.json").read_text())["cells"]
    ev = evaluate(load_dataset(morpi_manifest(), root=field_root), ablation=False)
    rows = _cell_rows(ev, [{"label": f"{c['table']} {c['phone']} {c['method']} {c['calibration']}",
                            "percent": c["ours_percent"], "n": c["n_runs"], **c} for c in tables],
                      [{**c, "n": len(c["runs"])} for c in aided])
    assert len(rows) == 32 + 2 * 24
    for label, want, n, got, m in rows:
        assert got is not None and m == n, (label, n, m)
        assert got == pytest.approx(want, rel=1e-9), label


def test_evaluate_data_reads_a_morpi_root_through_the_shipped_manifest(tmp_path, capsys):
    # `morpi evaluate --data DIR` is `morpi evaluate --dataset <the shipped manifest>` with DIR as the root its
    # files start at: the same JSON as the Python call on that dataset; --data and --dataset exclude each other
    import json

    from morpi_filters import cli, synthetic
    from morpi_filters.dataset_eval import evaluate
    from morpi_filters.resources import morpi_manifest

    root = synthetic.write_dataset(tmp_path / "ds", seed=4, runs_per_folder=2)
    out = tmp_path / "ev.json"
    assert cli.main(["evaluate", "--data", str(root), "--json", str(out)]) == 0
    got = json.loads(out.read_text())
    want = evaluate(load_dataset(morpi_manifest(), root=root)).to_json()
    assert got["dataset"]["name"] == "MoRPI" and got["dataset"]["count"] == want["dataset"]["count"]
    assert [(r["id"], r["method"], r["calibration"], r["estimate"]) for r in got["recordings"]] == \
        [(r["id"], r["method"], r["calibration"], r["estimate"]) for r in want["recordings"]]
    for a, b in zip(got["recordings"], want["recordings"]):
        for k in ("end_error_m", "end_error_percent"):
            assert (a[k] is None) == (b[k] is None) and (a[k] is None or a[k] == pytest.approx(b[k], rel=1e-12))
    # a group with test recordings is averaged over them; the straight-line group (split "none") over its own
    printed = capsys.readouterr().out.splitlines()
    assert any(s.startswith("s8/short_distance: MoRPI-G GC:") and s.endswith("test recording(s))") for s in printed)
    assert any(s.startswith("s8/line_dataset: INS-3D RD:") and s.endswith("outside the train split)")
               for s in printed), printed
    for argv in (["evaluate", "--data", str(root), "--dataset", str(morpi_manifest())], ["evaluate"]):
        with pytest.raises(SystemExit) as exc:
            cli.main(argv)
        assert exc.value.code == 2 and "--data" in capsys.readouterr().err


def test_track_files_hold_each_value_as_its_repr_whatever_the_float(tmp_path):
    """The track writer formats a column at once; each file's bytes are those of writing every value by
    ``repr``, row by row, for floats of every kind (subnormal, -0.0, powers beyond 1e16, nan, inf, random bit
    patterns), and each value reads back as the same float."""
    from types import SimpleNamespace

    from morpi_filters.report.dataset_eval import _write_track

    rng = np.random.default_rng(7)
    special = np.array([0.0, -0.0, 0.1, 1e22, -1e22, 1e16, 9999999999999998.0, 1e-5, 1e-4, 5e-324, -5e-324,
                        2.2250738585072014e-308, 2.225073858507201e-308, 1.7976931348623157e308, np.inf, -np.inf,
                        np.nan, 1.0, 123456789.0, 0.30000000000000004])
    bits = rng.integers(0, 2 ** 63, 400, dtype=np.int64) * rng.choice([1, -1], 400)
    values = np.concatenate([special, bits.view(np.float64), rng.standard_normal(400) * 10.0 ** rng.integers(
        -320, 300, 400)])

    def pick(shape):
        return rng.permutation(np.resize(values, int(np.prod(shape)))).reshape(shape)

    def expected(p):
        rows = [[t, *xy] if p.P_xy is None else [t, *xy, P[0, 0], P[0, 1], P[1, 1]]
                for t, xy, P in zip(p.time.tolist(), p.xy.tolist(), [None] * len(p.time) if p.P_xy is None
                                    else p.P_xy)]
        head = "time,x,y" if p.P_xy is None else "time,x,y,p_xx,p_xy,p_yy"
        return "\n".join([head] + [",".join(repr(float(v)) for v in r) for r in rows]) + "\n"

    times = {}
    clock = pick(len(values))
    tracks = [SimpleNamespace(time=clock, xy=pick((len(values), 2)), P_xy=None),
              SimpleNamespace(time=clock, xy=pick((len(values), 2)), P_xy=pick((len(values), 2, 2))),
              SimpleNamespace(time=pick(1), xy=pick((1, 2)), P_xy=pick((1, 2, 2))),
              SimpleNamespace(time=np.zeros(0), xy=np.zeros((0, 2)), P_xy=None),
              SimpleNamespace(time=np.zeros(0), xy=np.zeros((0, 2)), P_xy=np.zeros((0, 2, 2)))]
    for i, p in enumerate(tracks):
        path = tmp_path / "tracks" / f"{i}.csv"
        _write_track(path, p, times)
        text = path.read_bytes().decode()
        assert text == expected(p), i
        sent = np.column_stack([p.time, p.xy] + ([] if p.P_xy is None else
                                                  [p.P_xy[:, 0, 0], p.P_xy[:, 0, 1], p.P_xy[:, 1, 1]]))
        back = np.array([[float(v) for v in line.split(",")] for line in text.splitlines()[1:]]).reshape(
            sent.shape)
        assert np.array_equal(back.view(np.int64)[~np.isnan(sent)], sent.view(np.int64)[~np.isnan(sent)]), i
        assert np.array_equal(np.isnan(back), np.isnan(sent)), i


def test_track_files_written_on_two_processes_equal_those_written_on_one(tmp_path, monkeypatch):
    """Two workers split the tracks by folder between this process and a forked child; the files are those of
    one worker, byte for byte, also when the child fails (this process writes its share again)."""
    import os
    import sys
    from types import SimpleNamespace

    from morpi_filters.report import dataset_eval as page

    rng = np.random.default_rng(3)

    def track(n, cov):
        return SimpleNamespace(time=np.cumsum(rng.random(n)), xy=rng.standard_normal((n, 2)),
                               P_xy=rng.random((n, 2, 2)) if cov else None)

    tracks = [(f"r{i % 7}", track(int(rng.integers(0, 60)), i % 3 == 0)) for i in range(40)]

    def write(out, workers):
        out.mkdir()
        jobs = [(out / "tracks" / f / f"{j}.csv", p, f) for j, (f, p) in enumerate(tracks)]
        page._write_tracks(jobs, workers, meanwhile=lambda: (out / "page.csv").write_text("page"))
        return {q.relative_to(out): q.read_bytes() for q in sorted(out.rglob("*.csv"))}

    one = write(tmp_path / "one", 1)
    assert len(one) == len(tracks) + 1 and one[Path("page.csv")] == b"page"
    assert write(tmp_path / "two", 2) == one
    if sys.platform.startswith("linux") and hasattr(os, "fork"):
        parent, plain = os.getpid(), page._write_track

        def fails_in_child(path, p, times):
            if os.getpid() != parent:
                raise OSError("disk full")
            plain(path, p, times)

        monkeypatch.setattr(page, "_write_track", fails_in_child)
        assert write(tmp_path / "child fails", 2) == one
