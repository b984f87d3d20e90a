"""Tests of morpi_filters.evaluate: the paper's numbers, train-only tuning, synthetic truth, the field tables."""
from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from morpi_filters.errors import DataError, MorpiError

from morpi_filters import dataset as ds
from morpi_filters import evaluate as ev
from morpi_filters import field as fd
from morpi_filters.field import _loops as field_loops, rules as fdr, thresholds as fdt
from morpi_filters import simulate, units
from morpi_filters import steps as st
from morpi_filters.report.tables import report_tables
from morpi_filters.results import DataSource
from conftest import plain_kernels



# ----------------------------------------------------------------------------- the paper's numbers

def _tex_table_numbers(tex: str, label: str) -> list[float]:
    """Numbers of the data rows of the tabular after \\label{label}, in reading order."""
    start = tex.index("\\label{" + label + "}")
    body = tex[start:tex.index("\\end{tabular}", start)]
    out = []
    for line in body.splitlines():
        if "&" not in line or "\\multicolumn" in line:
            continue
        for cell in line.replace("\\\\", "").split("&"):
            cell = cell.strip()
            m = re.fullmatch(r"([0-9]+(\.[0-9]+)?)(\\%)?", cell)
            if m:
                out.append(float(m.group(1)))
    return out


def test_paper_cells_are_the_tex_tables(paper_tex):
    tex = paper_tex.read_text()
    assert len(ev.PAPER_CELLS) == 32
    for table, label in ev.TABLES.items():
        ours = [c[5] for c in ev.PAPER_CELLS if c[0] == table]
        assert _tex_table_numbers(tex, label) == ours, table
    comp = _tex_table_numbers(tex, ev.PAPER_COMPARISON["label"])
    # rows: error in m, then the improvements against the methods above
    assert comp == [3.34, 1.80, 24.5, 0.37, 47.2, 22.7, 0.29, 48.5, 24.0, 1.27]


def test_cell_specs_cover_the_protocol():
    specs = ev.cell_specs()
    assert len(specs) == 32
    counts = {t: sum(1 for s in specs if s.table == t) for t in ev.TABLES}
    assert counts == {"ins_straight": 4, "short_route": 12, "long_route": 8, "ins_l_shape": 4, "morpi_l_shape": 4}
    for s in specs:
        if s.table == "long_route":
            assert s.train == (s.phone, "short_distance")
        if s.table == "morpi_l_shape":
            assert s.train == ("s6", "short_distance")


def test_routes_turn_as_the_recordings_do(field_root):
    # integrating the GC z rate over the motion: L_line turns left, L_shape right (routes.json)
    from morpi_filters.calibration import calibrate
    from morpi_filters.steps import integrate_heading

    for route, sign in (("L_line", 1.0), ("L_shape", -1.0)):
        assert np.sign(ds.route(route).turn_deg) == sign
        assert np.sign(ds.route(route).end_point_m[1]) == sign
        for rec in ds.load_catalogue(field_root, phone="s6", route=route)[:3]:
            c = calibrate(rec, "GC").apply(rec)
            psi_end = np.degrees(integrate_heading(c.time, c.omega[:, 2])[-1])
            # a 90 deg turn; the gyro heading of a phone on a hand-driven car is within +-20 deg of it
            assert sign * psi_end == pytest.approx(90.0, abs=20.0), rec.source


# ----------------------------------------------------------------------------- synthetic truth

def _write_synthetic(root: Path, folder: str, route: str, runs: int, seed: int, *, sampling="two-rate", speed=None):
    rng = np.random.default_rng(seed)
    for i in range(runs):
        traj = simulate.route_trajectory(route, speed_mps=speed if speed else None)
        imu = simulate.imu(traj, units.MPU6500, rng, sampling=sampling, bias_scale=0.0, noise_scale=0.0)
        rec = ds.Recording(time=imu.time, f=imu.f, omega=imu.omega, source="synthetic")
        ds.write_csv(root / folder / f"{i + 1}.csv", rec)


def test_noise_free_synthetic_routes_are_recovered(tmp_path):
    root = tmp_path / "synthetic"
    _write_synthetic(root, "s8/line_dataset", "line_dataset", 1, 1, sampling="jittered")
    _write_synthetic(root, "s6/short_distance/train", "short_distance", 2, 3)
    _write_synthetic(root, "s6/short_distance/test", "short_distance", 1, 4)
    res = ev.evaluate_tables(root, alternatives=False)
    # (the L route starts on a 15 deg slope, where the level assumption of GAC does not hold, so
    # only the straight line has an exact answer)
    for m in ("INS-3D", "INS-2D"):
        for cal in ("RD", "GAC"):
            c = res.cell("ins_straight", "s8", None, m, cal)
            # noise-free, bias-free, level IMU: the end point is recovered to integration error; the
            # strapdown's own tests bound it to millimetres, 1 cm over 6.3 m is the bar here
            assert c.runs and c.ours_m < 0.01, (m, cal, c.ours_m)
    for m in ("MoRPI-A", "MoRPI-G"):
        c = res.cell("short_route", "s6", 1.0, m, "GC")
        # gain trained on the same noise-free path: the distance is right to the partial-step
        # accounting (a fraction of one 1 m period, tapered); 3 % of 6.3 m is the bar
        assert c.runs and c.distance_percent < 3.0, (m, c.distance_percent)
    assert "s8/short_distance/test" in res.missing


# ----------------------------------------------------------------------------- train-only tuning

def _train_only_tree(field_root: Path, dest: Path) -> Path:
    """Symlink every recording of the dataset except those of the test splits.

    (Files, not folders: pathlib's rglob does not descend into symlinked folders.)
    """
    for folder in ds.layout():
        if folder.endswith("/test"):
            continue
        _link_folder(field_root / folder, dest / folder)
    return dest


def _link_folder(src: Path, dst: Path):
    dst.mkdir(parents=True, exist_ok=True)
    for f in sorted(src.glob("*.csv")):
        (dst / f.name).symlink_to(f)


def test_gains_and_step_rule_do_not_see_the_test_folders(field_root, tmp_path):
    full = ev.evaluate_tables(field_root, alternatives=False)
    root = _train_only_tree(field_root, tmp_path / "train_only")
    part = ev.evaluate_tables(root, alternatives=False)
    assert {m: s.config for m, s in part.selections.items()} == {m: s.config for m, s in full.selections.items()}
    assert [s.score for s in part.selections.values()] == [s.score for s in full.selections.values()]
    # the library's default step rules are the ones the search picks on the field train runs
    from morpi_filters.steps import DEFAULT_CONFIGS
    assert {m: s.config for m, s in full.selections.items()} == DEFAULT_CONFIGS
    assert [(g.phone, g.route, g.method, g.calibration, g.mean, g.std) for g in part.gains] == \
           [(g.phone, g.route, g.method, g.calibration, g.mean, g.std) for g in full.gains]
    # test folders are reported missing, their cells are empty with a reason, nothing crashes
    assert sorted(part.missing) == sorted(f for f in ds.layout() if f.endswith("/test"))
    for c in part.cells:
        if c.spec.split == "test":
            assert not c.runs and "no recordings" in c.missing
        else:
            assert c.runs


def test_the_morpi_cells_alone_equal_those_of_the_whole_evaluation(field_root):
    full = ev.evaluate_tables(field_root, alternatives=False)
    lean = ev.evaluate_tables(field_root, alternatives=False, ins=False)
    assert not any(c.spec.method.startswith("INS") for c in lean.cells)
    morpi = [c for c in full.cells if not c.spec.method.startswith("INS")]
    assert any(c.spec.method.startswith("INS") for c in full.cells) and len(morpi) == len(lean.cells)
    for a, b in zip(morpi, lean.cells):
        assert a.spec == b.spec and a.runs == b.runs


def _loo_by_tracking(data, method, config, sets=None, drop=()):
    """Leave-one-out end-point errors [%] the long way: train_gain on the others, morpi_track on the run."""
    from morpi_filters import steps as st
    errs = []
    for phone, route, _ in ev.short_route_sets(data) if sets is None else sets:
        truth = ds.route(route)
        recs = [r for r in data.recordings(phone, route, "train") if data.relpath(r) not in drop]
        sl = [data.steps(r, "GC", method, config) for r in recs]
        for i in range(len(sl)):
            gain, _, _ = st.train_gain(sl[:i] + sl[i + 1:], truth.distance_m)
            end = st.morpi_track(sl[i], gain).end_point
            errs.append(np.linalg.norm(np.asarray(end[:2]) - truth.end_point_m) / truth.distance_m * 100)
    return np.array(errs)


def test_train_score_is_the_tracked_leave_one_out_error(field_root):
    # the search's vectorised score against dead-reckoning every held-out run with the tracker; the
    # same sums in another order, so they agree to rounding (rel 1e-12)
    from morpi_filters.steps import DEFAULT_CONFIGS
    data = fd.FieldData(field_root, include_test=False)
    drop = ("s6/short_distance/train/1.csv",)
    for m in ("MoRPI-A", "MoRPI-G"):
        score, n = fd.held_out_score(data, m, DEFAULT_CONFIGS[m])
        ref = _loo_by_tracking(data, m, DEFAULT_CONFIGS[m])
        assert n == ref.size == 40 and score == pytest.approx(ref.mean(), rel=1e-12)  # the mean of the same errors: float rounding
        score, n = fd.held_out_score(data, m, DEFAULT_CONFIGS[m], exclude=frozenset(drop))
        ref = _loo_by_tracking(data, m, DEFAULT_CONFIGS[m], drop=drop)
        assert n == ref.size == 39 and score == pytest.approx(ref.mean(), rel=1e-12)  # the mean of the same errors: float rounding


def test_nested_rule_comparison_matches_a_search_without_the_held_out_run(field_root, tmp_path):
    from morpi_filters import steps as st
    data = fd.FieldData(field_root, include_test=False)
    nest = fd.nested_rule_comparison(data)
    assert nest["n_folds"] == 40 and len(nest["folds"]) == 40
    for rule in fd.RULES:
        for m in ("MoRPI-A", "MoRPI-G"):
            assert nest["rules"][rule][m] == pytest.approx(np.mean([f[rule][m] for f in nest["folds"]]))  # the mean of the same fold values: pytest's default 1e-6 relative
    # folds recomputed independently: the run's file is absent from a symlinked tree, the whole
    # table evaluation runs there (its own search and gains), and the held-out run is dead-reckoned
    # with what that evaluation chose (same arithmetic in another order: rel 1e-12). Without 1.5p2p/30 the per-method MoRPI-A search picks
    # another rule than on all train runs, without s6/14 the joint search does; s8/6 changes neither.
    # The run with the least heading swing sets the least swing of a periodic run: its fold sets a higher one.
    th = data.thresholds
    least = th.swing_files[int(np.argmin(th.swings_deg))]
    for rel in ("s8/short_distance_1.5p2p/train/30.csv", "s6/short_distance/train/14.csv",
                "s8/short_distance/train/6.csv", least):
        assert (field_root / rel).is_file()
        tree = _train_only_tree(field_root, tmp_path / rel.replace("/", "_"))
        (tree / rel).unlink()
        phone, route = rel.split("/")[:2]
        run = next(r for r in data.recordings(phone, route, "train") if data.relpath(r) == rel)
        truth = ds.route(route)
        fold = next(f for f in nest["folds"] if f["file"] == rel)
        for rule in fd.RULES:
            part = ev.evaluate_tables(tree, alternatives=False, rule=rule)
            for m in ("MoRPI-A", "MoRPI-G"):
                cfg = part.selections[m].config
                # the tree sets its thresholds without the held-out run, as each fold of the nested check does
                # (s8/short_distance/train/6 holds the largest full-period change: the turn threshold is 49 deg
                # without it, 51 with it)
                assert cfg.turn_deg == fold["turn_deg"] and cfg.min_swing_deg == fold["min_swing_deg"]
                assert part.data.thresholds.accel_floor == fold["accel_floor"]
                th, _ = fd.fold_thresholds(data, rel)
                ref = fd.select_config(data, m if rule == "per_method" else fd.MORPI_METHODS, exclude=(rel,),
                                       thresholds=th).config
                assert cfg == ref
                gain = part.gain(phone, route, m, "GC").mean
                end = st.morpi_track(data.steps(run, "GC", m, cfg), gain).end_point
                err = np.linalg.norm(np.asarray(end[:2]) - truth.end_point_m) / truth.distance_m * 100
                assert fold[rule][m] == pytest.approx(err, rel=1e-12)  # the same run error recomputed: float rounding
    d = np.array([np.mean([f["joint"][m] - f["per_method"][m] for m in ("MoRPI-A", "MoRPI-G")])
                  for f in nest["folds"]])
    assert nest["difference_pp"] == pytest.approx(d.mean())  # the mean of the same differences: pytest's default 1e-6 relative
    assert nest["difference_se_pp"] == pytest.approx(d.std(ddof=1) / np.sqrt(d.size))  # the standard error of the same differences: pytest's default 1e-6 relative
    assert nest["preferred"] == min(fd.RULES, key=lambda r: nest["mean"][r])


def test_rule_sensitivity_rows_agree_with_the_tables(field_root):
    res = ev.evaluate_tables(field_root, alternatives=False)
    rows = ev.rule_sensitivity(res)
    for m in ("MoRPI-A", "MoRPI-G"):
        mine = [r for r in rows if r["method"] == m]
        assert len(mine) == len(res.selections[m].trials)
        scores = [r["train_loo_percent"] for r in mine]
        assert scores == sorted(scores)
        sel = [r for r in mine if r["selected"]]
        assert len(sel) == 1 and sel[0]["train_difference_pp"] == 0.0
        # the method's own train error; with one rule for both methods the search scored their mean
        assert sel[0]["train_loo_percent"] == pytest.approx(fd.held_out_score(res.data, m, res.selections[m].config)[0])  # same errors, same mean: rounding
        # the selected rule's cells are the main table's
        for x in sel[0]["cells"]:
            assert x["ours_percent"] == pytest.approx(res.cell("short_route", x["phone"], x["p2p_m"], m, "GC").ours_percent)
        # a paired difference over the same runs is the difference of the two means (to rounding of
        # means of ~10 % errors over 40 runs: abs 1e-9 pp)
        for r in mine:
            assert r["train_difference_pp"] == pytest.approx(r["train_loo_percent"] - sel[0]["train_loo_percent"],
                                                              abs=1e-9)


def test_missing_folders_give_a_partial_report(field_root, tmp_path):
    root = tmp_path / "partial"
    _link_folder(field_root / "s6/short_distance/train", root / "s6/short_distance/train")
    out = tmp_path / "out"
    # Without --partial the missing folders stop the section, named in one line.
    with pytest.raises(DataError, match=r"missing folder [^,]*/s8/line_dataset, expected 24 file\(s\)") as ei:
        ev.tables_study(root)
    assert "--partial" in str(ei.value) and "\n" not in str(ei.value)
    summary = report_tables(out, ev.tables_study(root, partial=True), DataSource(root))
    page = (out / "README.md").read_text()
    payload = json.loads((out / "result.json").read_text())
    assert "Missing folders" in page and "s8/line_dataset" in page
    assert "Partial evaluation" in page and payload["partial"] is True
    assert any(f"missing folder {root / 's8/line_dataset'}," in x for x in payload["left_out"])
    assert len(payload["cells"]) == 32
    assert sum(c["n_runs"] > 0 for c in payload["cells"]) == 0
    assert {g["train_set"] for g in payload["gains"]} == {"s6/short_distance/train"}
    assert "Missing folders" in summary.summary


# ----------------------------------------------------------------------------- the field tables

def test_field_tables_end_to_end(field_root, tmp_path):
    out = tmp_path / "tables"
    summary = report_tables(out, ev.tables_study(field_root), DataSource(field_root))
    payload = json.loads((out / "result.json").read_text())
    page = (out / "README.md").read_text()
    assert summary.name == "tables" and not summary.synthetic
    assert not page.startswith(">")  # no synthetic banner on field data
    for f in summary.figures:
        assert (out / f).stat().st_size > 1000
    cells = payload["cells"]
    assert len(cells) == 32 and all(c["n_runs"] > 0 and c["ours_percent"] is not None for c in cells)
    for c in cells:
        assert c["table"] in ev.TABLES and c["phone"] in ("s6", "s8")
        assert c["method"] in ("INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G") and c["calibration"] in ("RD", "GAC", "GC")
        assert c["ours_percent"] == pytest.approx(np.mean([r["end_error_percent"] for r in c["runs"]]))  # the cell is the mean of its runs: pytest's default 1e-6 relative
    n_train = {("s8", "short_distance"): 12, ("s8", "short_distance_1.5p2p"): 13, ("s6", "short_distance"): 15}
    for g in payload["gains"]:
        assert len(g["per_run"]) == n_train[(g["phone"], g["route"])]
        assert g["mean"] == pytest.approx(np.mean(g["per_run"])) and g["std"] >= 0  # the gain is the mean of its runs: pytest's default 1e-6 relative
    # the reproduction bar of the six GC MoRPI cells of the short route: within 2.5 percentage
    # points of the paper's table "weinberg results short". The set of misses is pinned so a change
    # either way shows. Before the motion windows were shared, s8 1.5 m MoRPI-G GC missed on the low
    # side (3.46 % against 6.67 %): MoRPI-A's steps ran over their own, longer motion span (the
    # accelerometer settling after start-up opened it at the first sample in 44 of the 109 periodic
    # runs and closed it seconds after the robot stopped), so its partial end steps counted rest as
    # travel and the search's rules were fitted to that. With one motion window per recording
    # (after the detected rest, to the robot's stop) and the heading from its start, the nested
    # train-only check prefers one rule for both methods; under that rule s8 1.5 m MoRPI-G GC is
    # within the bar and s8 1.5 m MoRPI-A GC misses on the low side (ours is lower than the paper's).
    # With the "turns" heading reading among the search's candidates (the step's own heading change
    # plus the turns, blind to the gyro drift between turns), MoRPI-G's own search picks it and the
    # nested check prefers a rule per method; MoRPI-A's rule (mean heading, whole end steps) brings
    # s8 1.5 m MoRPI-A GC within the bar (6.52 % against 8.25 %), and MoRPI-G's drift-free heading takes
    # s8 1.5 m MoRPI-G GC below it (3.26 % against 6.67 %): the miss is on the low side.
    gc = [c for c in cells if c["table"] == "short_route" and c["calibration"] == "GC"]
    assert len(gc) == 6
    misses = [c for c in gc if abs(c["ours_percent"] - c["paper_percent"]) > 2.5]
    assert [(c["phone"], c["p2p_m"], c["method"]) for c in misses] == [("s8", 1.5, "MoRPI-G")]
    assert misses[0]["ours_percent"] < misses[0]["paper_percent"]
    # every run carries the windows it used; the motion starts after the rest ends
    for c in cells:
        for r in c["runs"]:
            rest, motion = r["rest_window_s"], r["motion_window_s"]
            assert rest[0] <= rest[1] < motion[0] < motion[1], (c["table"], r["file"])
    # the default way of choosing the step rule is the one the nested train-only check prefers
    import inspect
    default_rule = inspect.signature(ev.evaluate_tables).parameters["rule"].default
    assert payload["step_rule_nested"]["preferred"] == default_rule
    assert "Nested check of that choice" in page and "## How much the step rule moves" in page
    # every cell further than the bar is explained on the page
    for c in cells:
        if abs(c["ours_percent"] - c["paper_percent"]) > ev.DEVIATION_PP:
            p2p = f" {c['p2p_m']:g} m" if c["p2p_m"] is not None else ""
            assert f"**{c['table']} {c['phone']}{p2p} {c['method']} {c['calibration']}**" in page


def test_a_recording_without_periodic_motion_is_reported_not_fatal(field_root, tmp_path):
    # a straight-line run placed in a periodic test folder: its cell lists it as failed, naming the
    # file, and the other runs are still evaluated
    root = tmp_path / "mixed"
    _link_folder(field_root / "s6/short_distance/train", root / "s6/short_distance/train")
    test = root / "s6/short_distance/test"
    test.mkdir(parents=True)
    (test / "1.csv").symlink_to(field_root / "s8/line_dataset/1.csv")
    (test / "2.csv").symlink_to(field_root / "s6/short_distance/test/16.csv")
    res = ev.evaluate_tables(root, alternatives=False)
    for m in ("MoRPI-A", "MoRPI-G"):
        c = res.cell("short_route", "s6", 1.0, m, "GC")
        assert [r.file for r in c.runs] == ["s6/short_distance/test/2.csv"]
        assert len(c.failed) == 1 and "1.csv: no periodic motion" in c.failed[0]


def test_cli_tables_writes_the_section_and_json(field_root, tmp_path):
    from morpi_filters import cli

    root = tmp_path / "partial"
    _link_folder(field_root / "s8/short_distance/train", root / "s8/short_distance/train")
    _link_folder(field_root / "s8/short_distance/test", root / "s8/short_distance/test")
    out, js = tmp_path / "reports" / "tables", tmp_path / "tables.json"
    # the other nine folders are missing: exit 1 (bad input data), nothing written
    assert cli.main(["tables", "--data", str(root), "--out", str(out), "--json", str(js)]) == 1
    assert not out.exists() and not js.exists()
    assert cli.main(["tables", "--data", str(root), "--out", str(out), "--json", str(js), "--partial"]) == 0
    payload = json.loads(js.read_text())
    done = [c for c in payload["cells"] if c["n_runs"]]
    assert {(c["table"], c["phone"], c["p2p_m"]) for c in done} == {("short_route", "s8", 1.0)}
    assert len(done) == 4 and (out / "README.md").is_file()
    # no dataset at all: one line on stderr, exit code 2, nothing written
    assert cli.main(["tables", "--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()


def test_unreadable_files_stop_the_tables_or_are_listed_with_partial(field_root, tmp_path):
    root = tmp_path / "broken"
    _link_folder(field_root / "s6/short_distance/train", root / "s6/short_distance/train")
    (root / "s6/short_distance/train/99.csv").write_text("time,f_x\n1,2\n")
    test = root / "s6/short_distance/test"
    test.mkdir(parents=True)
    (test / "16.csv").symlink_to(field_root / "s6/short_distance/test/16.csv")
    (test / "17.csv").write_text("not a recording\n")
    out = tmp_path / "out"
    with pytest.raises(DataError, match=r"17.csv: line 1: .*99.csv: line 1: missing column"):
        ev.tables_study(root)
    report_tables(out, ev.tables_study(root, partial=True), DataSource(root))
    payload = json.loads((out / "result.json").read_text())
    cell = next(c for c in payload["cells"] if (c["table"], c["phone"], c["method"], c["calibration"])
                == ("short_route", "s6", "MoRPI-G", "GC"))
    assert cell["n_runs"] == 1 and len(cell["failed"]) == 1 and "17.csv" in cell["failed"][0]
    gain = next(g for g in payload["gains"] if g["method"] == "MoRPI-G" and g["calibration"] == "GC")
    assert len(gain["per_run"]) == 15 and any("99.csv" in s for s in gain["skipped"])
    assert "17.csv" in (out / "README.md").read_text()
    assert any("17.csv" in x for x in payload["left_out"]) and any("99.csv" in x for x in payload["left_out"])


@pytest.mark.field
def test_planar_ins_overshoot_is_the_tilt_leak(field_root):
    """On the straight runs the planar INS overshoots the 3D one by the gravity its tilt leaks into f_x.

    Independent evidence: the two mechanizations run separately (ins2d ignores the attitude), and the
    leak is computed from the 3D attitude alone. What else separates them (the planar heading
    against the 3D yaw, lateral leakage through roll) is second order, so the residual RMS must be
    under 10 % of the leak's RMS.
    """
    from morpi_filters.field import FieldData

    data = FieldData(field_root)
    recs = data.recordings("s8", "line_dataset", None)
    leak = np.array([data.tilt_leak(r, "GAC")[1] for r in recs])
    gap = np.array([data.ins(r, "GAC", "INS-2D").position[-1, 0] - data.ins(r, "GAC", "INS-3D").position[-1, 0]
                    for r in recs])
    assert np.sqrt(np.mean((gap - leak) ** 2)) < 0.1 * np.sqrt(np.mean(leak ** 2))


@pytest.mark.field
def test_leveled_ins_is_computed_for_the_3d_cells(field_root):
    """The tilt-at-rest start is a further reading of the two 3D GAC cells, never a replacement."""
    res = ev.evaluate_tables(field_root, alternatives=False)
    rows = ev.ins_leveled(res)
    assert [(r["table"], r["phone"]) for r in rows] == [("ins_straight", "s8"), ("ins_l_shape", "s6")]
    for r in rows:
        assert r["runs"] > 0 and r["leveled_percent"] > 0
        assert r["gac_percent"] == res.cell(r["table"], r["phone"], None, "INS-3D", "GAC").ours_percent
    # the L route starts on a slope: the rest tilt is several degrees there, about level indoors
    tilt = {r["table"]: r["mean_rest_tilt_deg"] for r in rows}
    assert tilt["ins_l_shape"] > 5.0 > tilt["ins_straight"]


@pytest.mark.field
def test_paper_claims_beside_ours(field_root, paper_tex):
    """Each claim quotes the paper (its numbers appear in the source) and ours comes from the data."""
    from morpi_filters import dataset as ds
    from morpi_filters.evaluate import evaluate_tables, paper_claims

    res = evaluate_tables(field_root, alternatives=False)
    claims = paper_claims(res)
    assert len(claims) >= 8   # the bar
    text = paper_tex.read_text()
    for c in claims:
        assert set(c) == {"claim", "paper", "ours", "holds", "evidence"}
        for v in (c["paper"] if isinstance(c["paper"], list) else [c["paper"]]):
            # every paper value is printed in the paper (4.6 as "4.60"); three are written otherwise there:
            # 6.1 is its 28.6 / 4.68 ("a factor of six"), 0.025 m is "2.5cm", 103 is "One hundred and three"
            if v not in (6.1, 0.025, 103):
                assert f"{v:g}" in text or f"{v:.2f}" in text, v
    by = {c["claim"]: c for c in claims}
    # ours from independent counts: the catalogue and the cells
    assert by["143 trajectories were recorded"]["ours"] == len(ds.catalogue(field_root))
    g = [res.cell("short_route", p, 1.0, "MoRPI-G", "GC").ours_percent for p in ("s8", "s6")]
    assert by["MoRPI-G averages 4.68 % over the two phones"]["ours"] == round(sum(g) / 2, 2)
    assert by["MoRPI-G averages 4.68 % over the two phones"]["holds"] == (abs(sum(g) / 2 - 4.68) <= 1.0)


# ----------------------------------------------------------------------------- motion windows and heading

_PERIODIC = ("short_distance", "short_distance_1.5p2p", "long_distance", "L_shape")


@pytest.mark.field
def test_one_motion_window_per_recording_after_the_rest(field_root):
    """In every periodic run (train and test) the window opens after the detected rest, and both methods
    and the INS use it."""
    from morpi_filters import steps as st

    data = fd.FieldData(field_root)
    runs = [r for k in sorted(data.folders(), key=str) if k[1] in _PERIODIC for r in data.recordings(*k)]
    assert len(runs) == 109
    cfg = st.StepConfig(min_swing_deg=0.0)
    for r in runs:
        w = data.rest_window(r)
        a, b = data.activity(r)
        assert w.end_s < a < b <= r.time[-1], data.relpath(r)
        for m in ("MoRPI-A", "MoRPI-G"):
            assert data.steps(r, "GC", m, cfg).motion == (a, b), (data.relpath(r), m)
        t = np.asarray(data.ins(r, "GAC", "INS-2D").time)
        # the INS runs on the samples inside the window
        assert t[0] >= a and t[-1] <= b and np.searchsorted(r.time, a) == np.searchsorted(r.time, t[0])


@pytest.mark.field
def test_morpi_heading_starts_at_the_motion_onset(field_root):
    """The heading is zero before the window and the integral of the z rate from its start after."""
    for origin in ("motion", "start"):
        data = fd.FieldData(field_root, heading_from=origin)
        r = data.recordings("s8", "short_distance", "test")[0]
        psi = data.heading(r, "RD")
        a, b = data.activity(r)
        i0 = int(np.searchsorted(r.time, a)) if origin == "motion" else 0
        # from the first sample the heading runs through the whole recording
        i1 = int(np.searchsorted(r.time, b, side="right")) if origin == "motion" else r.n
        w = r.omega[:, 2]
        ref = np.concatenate([[0.0], np.cumsum(0.5 * (w[i0 + 1:i1] + w[i0:i1 - 1]) * np.diff(r.time[i0:i1]))])
        assert np.all(psi[:i0] == 0.0)
        # integrate_rate is higher-order than the trapezoid; they differ by ~2e-4 rad over a run, an
        # origin error would be the drift through the rest (several degrees on the raw S8 gyro)
        np.testing.assert_allclose(psi[i0:i1], ref, atol=1e-3)
        assert np.all(psi[i1:] == psi[i1 - 1])


@pytest.mark.field
def test_attitude_heading_follows_the_gyro_heading_of_a_nearly_level_phone(field_root):
    """On the flat indoor route the phone stays within a few degrees of level, so the yaw of the 3D attitude
    is the integrated z rate to within a few degrees; on the L route's slope they part."""
    data = fd.FieldData(field_root)
    recs = data.recordings("s8", "short_distance", "train")
    for r in recs[:4]:
        d = np.degrees(np.abs(data.heading(r, "GC", "attitude") - data.heading(r, "GC", "gyro")))
        assert d.max() < 3.0, (r.source, d.max())
    with pytest.raises(MorpiError, match="compass"):
        data.heading(recs[0], "GC", "compass")
    with pytest.raises(MorpiError, match="heading_source"):
        st.StepConfig(heading_source="compass")


def _corrupt_test_folders(field_root: Path, dest: Path) -> Path:
    """The dataset with every test recording corrupted (gyro sign flipped, f_y scaled 1.7), the rest linked."""
    for e in ds.catalogue(field_root):
        out = dest / e.relpath
        out.parent.mkdir(parents=True, exist_ok=True)
        if e.split == "test":
            rec = e.load()
            f = rec.f.copy()
            f[:, 1] *= 1.7
            ds.write_csv(out, ds.Recording(time=rec.time, f=f, omega=-rec.omega, source=str(out)))
        else:
            out.symlink_to(e.path)
    return dest


@pytest.mark.field
def test_corrupted_test_recordings_change_no_threshold_window_rule_or_gain(field_root, tmp_path):
    """Honesty: everything chosen from data (detection thresholds, the train runs' windows, step rules,
    gains) is the same when every test recording is corrupted; only the test cells move."""
    root = _corrupt_test_folders(field_root, tmp_path / "corrupted")
    full = ev.evaluate_tables(field_root, alternatives=False)
    bad = ev.evaluate_tables(root, alternatives=False)
    assert bad.data.thresholds == full.data.thresholds
    for phone, route, _ in ev.short_route_sets(full.data):
        for r0, r1 in zip(full.data.recordings(phone, route, "train"), bad.data.recordings(phone, route, "train")):
            assert full.data.rest_window(r0) == bad.data.rest_window(r1)
            assert full.data.activity(r0) == bad.data.activity(r1)
    assert {m: s.config for m, s in bad.selections.items()} == {m: s.config for m, s in full.selections.items()}
    assert [s.score for s in bad.selections.values()] == [s.score for s in full.selections.values()]
    assert [(g.phone, g.route, g.method, g.calibration, g.mean, g.std) for g in bad.gains] == \
           [(g.phone, g.route, g.method, g.calibration, g.mean, g.std) for g in full.gains]
    # the corruption reached the test cells (the test is not vacuous)
    moved = [c.spec.label for c, d in zip(full.cells, bad.cells)
             if c.spec.split == "test" and c.runs and d.runs and c.ours_percent != d.ours_percent]
    assert moved


@pytest.mark.field
def test_turns_reading_finds_the_l_turn_and_no_turn_on_the_straight_routes(field_root):
    """With the turn threshold of the train runs, the "turns" reading (each method's chosen rule) finds no
    turning stretch in any of the 99 straight periodic runs (train and test, short and long routes; GC and
    RD) and exactly one in each L-route run, of 90 deg within 20 deg (the gyro heading of the phone on the
    hand-driven car: see test_routes_turn_as_the_recordings_do). The threshold comes from the train runs."""
    from morpi_filters import steps as st

    data = fd.FieldData(field_root)
    th = data.thresholds
    assert len(th.period_changes_deg) == 80     # 40 train runs, two methods
    assert th.turn_deg == np.floor(fd.TURN_MARGIN * max(th.period_changes_deg))
    for m in ("MoRPI-A", "MoRPI-G"):
        cfg = fd.select_config(data, m).config.with_(heading="turns")
        assert cfg.turn_deg == th.turn_deg
        n_straight = 0
        for k in sorted(data.folders(), key=str):
            if k[1] not in _PERIODIC:
                continue
            for r in data.recordings(*k):
                for mode in ("GC", "RD"):
                    s = data.steps(r, mode, m, cfg)
                    psi = data.heading(r, mode)
                    bt = s.peaks.grid_time[s.peaks.grid_index]
                    found = st.turn_stretches(bt, np.interp(bt, r.time, psi), np.radians(cfg.turn_deg),
                                              2 if cfg.segment == "extrema" else 1)
                    if k[1] == "L_shape":
                        assert len(found) == 1, (data.relpath(r), m, mode)
                        turn = np.degrees(st.turn_heading([r.time[-1]], r.time, psi, found)[0])
                        assert turn == pytest.approx(ds.route("L_shape").turn_deg, abs=20.0), (data.relpath(r), m)
                    else:
                        assert found == [], (data.relpath(r), m, mode)
                        n_straight += mode == "GC"
        assert n_straight == 99


@pytest.mark.field
@pytest.mark.parametrize("n_se", [1.0, 0.0])
def test_heading_source_is_chosen_by_the_one_standard_error_rule_on_tracked_train_errors(field_root, monkeypatch,
                                                                                         n_se):
    """The attitude heading wins only when its tracked leave-one-out train error beats the gyro's by more than
    SOURCE_SE standard errors of the paired difference. Evidence: both sources' train errors dead-reckoned the long
    way (train_gain on the other runs, morpi_track on the held-out one), not the search's vectorised score. With
    no margin (0 standard errors) the lower mean wins, so a search that always kept the gyro would fail there."""
    monkeypatch.setattr(fdr, "SOURCE_SE", n_se)
    data = fd.FieldData(field_root, include_test=False)
    th = data.thresholds
    start = fdt.SEARCH_START.with_(min_swing_deg=th.min_swing_deg, turn_deg=th.turn_deg)
    for m in ("MoRPI-A", "MoRPI-G"):
        sel = fd.select_config(data, m)
        best = {h: fdr._search(data, (m,), frozenset(), start.with_(heading_source=h))[0] for h in st.HEADING_SOURCES}
        assert {c.heading_source for c, _ in sel.trials} == set(st.HEADING_SOURCES)   # both sources were scored
        g, a = _loo_by_tracking(data, m, best["gyro"]), _loo_by_tracking(data, m, best["attitude"])
        d = a - g
        attitude_wins = d.mean() < -fdr.SOURCE_SE * d.std(ddof=1) / np.sqrt(d.size)
        assert sel.config == best["attitude" if attitude_wins else "gyro"], (m, d.mean(), d.std(ddof=1))
        assert sel.config.heading_source == ("attitude" if attitude_wins else "gyro")


@pytest.mark.field
@pytest.mark.parametrize("which", ["least swing", "largest turn change", "first"])
def test_fold_thresholds_equal_the_thresholds_of_the_train_runs_without_the_held_out_one(field_root, tmp_path, which):
    """Evidence: train_thresholds computed from scratch on a copy of the train folders without the held-out run
    (its own rest windows, calibrations and steps). The folds chosen include the run that sets the least swing and
    the run that sets the turn threshold, so the fold's thresholds differ from the full ones."""
    data = fd.FieldData(field_root, include_test=False)
    th = data.thresholds
    if which == "least swing":
        held = th.swing_files[int(np.argmin(th.swings_deg))]
    elif which == "largest turn change":
        held = th.change_files[int(np.argmax(th.period_changes_deg))]
    else:
        held = th.rest_files[0]
    fold, same = fd.fold_thresholds(data, held)
    root = tmp_path / "fold"
    for folder in ds.layout():
        if folder.endswith("/train"):
            dst = root / folder
            dst.mkdir(parents=True)
            for f in sorted((field_root / folder).glob("*.csv")):
                if f"{folder}/{f.name}" != held:
                    (dst / f.name).symlink_to(f)
    ref = fd.train_thresholds(fd.FieldData(root, include_test=False))
    assert same
    assert (fold.accel_floor, fold.min_swing_deg, fold.turn_deg) == (ref.accel_floor, ref.min_swing_deg, ref.turn_deg)
    assert sorted(fold.swings_deg) == sorted(ref.swings_deg) and len(fold.rest_std) == len(th.rest_std) - 1
    if which != "first":
        assert (fold.min_swing_deg, fold.turn_deg) != (th.min_swing_deg, th.turn_deg)


def test_a_study_freezes_the_heap_only_while_it_runs_and_only_when_nobody_else_did():
    import gc

    from morpi_filters.evaluate.cells import frozen_heap

    seen = []
    study = frozen_heap(lambda x: seen.append(gc.get_freeze_count()) or x + 1)
    assert gc.get_freeze_count() == 0
    assert study(1) == 2 and seen[-1] > 0 and gc.get_freeze_count() == 0
    # a study inside a study: the inner one freezes what the outer one allocated before it (here 5000 lists),
    # and leaves the heap frozen for the rest of the outer one
    kept = []
    outer = frozen_heap(lambda: (seen.append(gc.get_freeze_count()), kept.extend([] for _ in range(5000)),
                                 study(1), seen.append(gc.get_freeze_count())))
    outer()
    assert seen[-2] >= seen[-3] + 5000 and seen[-1] >= seen[-3] + 5000 and gc.get_freeze_count() == 0

    def fails():
        raise ZeroDivisionError

    with pytest.raises(ZeroDivisionError):
        frozen_heap(fails)()
    assert gc.get_freeze_count() == 0
    gc.freeze()                                                  # a caller's own freeze is left as it is
    try:
        frozen = gc.get_freeze_count()
        study(1)
        assert seen[-1] == frozen and gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()
    assert ev.tables_study.__doc__.startswith("Compute everything the tables section shows")


def test_leave_one_out_errors_kernel_is_the_numpy_form_within_the_rounding_of_the_sum():
    # the kernel sums the gains in order, numpy pairwise: the errors agree within the bound of another order
    # of the sum (oracles.loo.order_bound: about n eps relative), and the kernel run plain gives its bits
    from oracles import loo as oracle

    plain = plain_kernels(field_loops)
    rng = np.random.default_rng(29)
    truth = ds.route("L_shape")
    for n in (2, 3, 7, 8, 9, 15, 16, 17, 127, 128, 129, 300, 1029):
        g = rng.uniform(0.5, 2.0, n) * 10.0 ** rng.uniform(-3, 3, n)
        u = rng.normal(size=(n, 2)) * 30.0
        for keep in (np.ones(n, dtype=bool), rng.random(n) < 0.7):
            if keep.sum() < 2:
                continue
            want = oracle.loo_errors(truth, g, u, keep)
            got = fd.loo_errors(truth, g, u, None if keep.all() else keep)
            assert got.shape == want.shape
            assert np.all(np.abs(got - want) <= oracle.order_bound(truth, g, u, keep))
            if n <= 300:
                out = np.empty(n)
                m = plain.loo_errors(g, u, keep, np.tile(truth.end_point_m, (n, 1)), np.full(n, truth.distance_m), out)
                np.testing.assert_array_equal(out[:m], got)
            # each run with its own end point and distance (a train set's arrays; a column-major copy alike)
            ends, dists = rng.normal(size=(n, 2)) * 30.0, rng.uniform(1.0, 50.0, n)
            for e in (ends, np.asfortranarray(ends)):
                own = SimpleNamespace(end_point_m=e, distance_m=dists)
                got = fd.loo_errors(own, g, u, None if keep.all() else keep)
                out = np.empty(n)
                m = plain.loo_errors(g, u, keep, ends, dists, out)
                np.testing.assert_array_equal(out[:m], got)
