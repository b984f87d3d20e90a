"""The foreign-layout tutorial (docs/tutorial_dataset.py) end to end in a temporary folder: its files hold the
robot it describes, it uses public names only, and its checks, tables and group means are what the ``morpi``
command prints and writes to its JSON on the same files."""
from __future__ import annotations

import ast
import contextlib
import importlib.util
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from morpi_filters import simulate
from morpi_filters.cli import main
from morpi_filters.dataset_eval import METRICS
from morpi_filters.results import JSON_DIGITS, round_significant

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "tutorial_dataset.py"


@pytest.fixture(scope="module")
def tutorial():
    spec = importlib.util.spec_from_file_location("morpi_tutorial_dataset", TUTORIAL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def page(tutorial, tmp_path_factory):
    """The tutorial run as a reader runs it (its command line), with what it printed."""
    folder = tmp_path_factory.mktemp("tutorial") / "robot"
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        r = tutorial.main(["--out", str(folder)])
    return r, text.getvalue()


def test_the_page_uses_public_names_only():
    tree = ast.parse(TUTORIAL.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            assert not (node.attr.startswith("_") and not node.attr.startswith("__")), (node.lineno, node.attr)
        if isinstance(node, ast.ImportFrom) and node.module.startswith("morpi_filters"):
            assert not any(part.startswith("_") for part in node.module.split(".")), node.module
            assert all(not a.name.startswith("_") for a in node.names), node.lineno
        if isinstance(node, ast.ImportFrom):
            assert node.module.split(".")[0] in ("morpi_filters", "matplotlib", "pathlib", "__future__"), node.module


def test_the_truth_files_hold_the_runs_the_page_states(tutorial, page):
    # independent of the page's NED arithmetic: the robot's path (x forward, y left, z up) turned in ENU by the
    # course (90 deg minus the heading from north, counter-clockwise from east) and put on the start point
    r, _ = page
    ds = r["load"]["dataset"]
    assert [dr.id for dr in ds.recordings] == [run[0] for run in tutorial.RUNS]
    for rec_id, split, length, heading_deg, (n0, e0) in tutorial.RUNS:
        dr = ds[rec_id]
        assert dr.split == split and dr.motion == "periodic" and dr.truth.source_frame == "NED"
        traj = simulate.sine(length, p2p_m=1.0, amplitude_m=0.1, rest_s=(2.0, 1.5))
        # the truth's clock: its first sample 0.4 s before the IMU's, one sample every 0.1 s
        np.testing.assert_allclose(dr.truth.time, -0.4 + np.arange(dr.truth.time.size) / 10.0, rtol=0, atol=1e-12)
        assert dr.truth.time[-1] >= dr.recording.time[-1] > dr.truth.time[-2]
        p = traj.at(dr.truth.time).position
        course = math.radians(90.0 - heading_deg)
        c, s = math.cos(course), math.sin(course)
        want = np.column_stack([e0 + c * p[:, 0] - s * p[:, 1], n0 + s * p[:, 0] + c * p[:, 1], p[:, 2]])
        np.testing.assert_allclose(dr.truth.position, want, rtol=0, atol=1e-9)


def test_the_imu_files_read_the_robots_motion_in_the_package_frame(tutorial, page):
    # the loaded readings minus the true specific force and rate of the same path are the sensor's errors only
    # (a few hundredths of g and of rad/s), not a flipped axis or a unit off by 9.8 or 57
    r, _ = page
    for rec_id, _, length, _, _ in tutorial.RUNS:
        rec = r["load"]["dataset"][rec_id].recording
        assert rec.n == math.floor(rec.time[-1] * 120.0 + 0.5) + 1 and rec.time[1] == pytest.approx(1 / 120.0)
        true = simulate.sine(length, p2p_m=1.0, amplitude_m=0.1, rest_s=(2.0, 1.5)).at(rec.time)
        rms_f = np.sqrt(np.mean((rec.f - true.f_b) ** 2, axis=0))
        rms_w = np.sqrt(np.mean((rec.omega - true.omega_b) ** 2, axis=0))
        assert rms_f.max() < 0.5 and rms_w.max() < 0.05, (rec_id, rms_f, rms_w)
        # the motion is well above those errors: the turn rates swing by about 1 rad/s
        assert np.sqrt(np.mean(true.omega_b[:, 2] ** 2)) > 0.5


def test_the_checks_are_the_commands(page, capsys):
    r, printed = page
    manifest = r["manifest"]
    assert r["check"] == {"n_ok": 4, "problems": [], "wrong_axes": r["check"]["wrong_axes"]}
    capsys.readouterr()
    assert main(["check", "--dataset", str(manifest)]) == 0
    assert capsys.readouterr().out.strip() == f"4 recording(s) OK, 0 problem(s) in {manifest}"
    wrong = manifest.with_name("wrong-axes.toml")
    assert main(["check", "--dataset", str(wrong)]) == 2
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[:-1] == r["check"]["wrong_axes"] and len(lines[:-1]) == 4
    assert all("check `axes`" in line for line in lines[:-1]) and lines[-1].startswith("0 recording(s) OK, 4")
    assert r["check"]["wrong_axes"][0] in printed


def _same(key, cell, value) -> bool:
    if hasattr(cell, "item"):
        cell = cell.item()
    if key not in METRICS:
        return type(cell) is type(value) and cell == value
    if value is None:
        return isinstance(cell, float) and math.isnan(cell)
    return isinstance(cell, float) and round_significant(cell, JSON_DIGITS) == value


def test_the_tables_and_the_printed_means_are_the_commands_json(page, tmp_path, capsys):
    r, printed = page
    js = tmp_path / "result.json"
    assert main(["evaluate", "--dataset", str(r["manifest"]), "--json", str(js)]) == 0
    cli = json.loads(js.read_text())
    rows, table = cli["recordings"], r["table"]
    # every method on every run: MoRPI too, with gains from the two train runs, and the aided filter read two ways
    aided = [x for x in rows if x["method"] == "MoRPI-aided INS"]
    assert {x["method"] for x in rows} == {"INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G", "MoRPI-aided INS"}
    assert len(rows) == 4 * 12 + len(aided) and len(aided) == 2 * 12
    assert sorted({x["estimate"] for x in aided}) == ["forward", "smoothed"]
    assert len(table) == len(rows) and list(table.columns) == [k for k in rows[0] if k != "track_file"]
    for i, row in enumerate(rows):
        bad = [k for k in table.columns if not _same(k, table.iloc[i][k], row[k])]
        assert not bad, (i, bad)
    groups = r["groups"]
    assert cli["groups"]["over"] == "test" == groups.attrs["over"] and len(groups) == len(cli["groups"]["rows"])
    for i, row in enumerate(cli["groups"]["rows"]):
        bad = [k for k in groups.columns if not _same(k, groups.iloc[i][k], row[k])]
        assert not bad, (i, bad)
    # the printed table: each mean end error, at two decimals, in its method's line and calibration's column
    lines = printed[printed.index("5. end error"):printed.index("6. figures")].splitlines()
    header = lines[1].split()[1:]
    shown = {ln.split()[0]: dict(zip(header, ln.split()[1:])) for ln in lines[3:]}
    for row in (x for x in cli["groups"]["rows"] if x["estimate"] is None):
        assert abs(float(shown[row["method"]][row["calibration"]]) - row["end_error_percent"]) <= 0.005 + 1e-9


def test_the_figures_draw_each_test_runs_estimates_and_truth(page):
    from matplotlib.colors import to_rgb
    from matplotlib.image import imread

    r, _ = page
    ds, result = r["load"]["dataset"], r["result"]
    shown = ("INS-2D GAC", "MoRPI-A GAC", "MoRPI-G GAC")
    tests = [dr.id for dr in ds.recordings if dr.split == "test"]
    assert [ax.get_title() for ax in r["figures"]["paths"].axes] == tests
    assert [ax.get_title() for ax in r["figures"]["errors"].axes] == tests
    for ax, ex, rec_id in zip(r["figures"]["paths"].axes, r["figures"]["errors"].axes, tests):
        truth = ds[rec_id].truth
        lines = {ln.get_label(): ln.get_xydata() for ln in ax.get_lines()}
        errors = {ln.get_label(): ln.get_xydata() for ln in ex.get_lines()}
        assert list(lines) == ["truth", *shown] and list(errors) == list(shown)
        np.testing.assert_array_equal(lines["truth"], truth.position[:, :2])
        for label in shown:
            p = next(p for p in result.paths if p.id == rec_id and f"{p.method} {p.calibration}" == label)
            np.testing.assert_array_equal(lines[label], p.xy)
            # the error against time, from the truth file's samples interpolated here
            want = np.hypot(p.xy[:, 0] - np.interp(p.time, truth.time, truth.position[:, 0]),
                            p.xy[:, 1] - np.interp(p.time, truth.time, truth.position[:, 1]))
            np.testing.assert_allclose(errors[label][:, 1], want, rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(errors[label][:, 0], p.time)
    for path in r["figures"]["files"].values():
        image = imread(path)[..., :3]
        assert image.shape[0] > 200 and image.shape[1] > 400
        # the files show the lines: matplotlib's first three colours appear (how many pixels each covers
        # depends on the estimates, which may lie over one another)
        for colour in ("C0", "C1", "C2"):
            near = np.all(np.abs(image - np.array(to_rgb(colour))) < 0.02, axis=-1)
            assert near.any(), (path.name, colour)
    # and every line lies inside its axes' view
    for fig in (r["figures"]["paths"], r["figures"]["errors"]):
        for ax in fig.axes:
            (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
            for ln in ax.get_lines():
                xy = ln.get_xydata()
                assert (xy[:, 0].min() >= x0 and xy[:, 0].max() <= x1 and xy[:, 1].min() >= y0
                        and xy[:, 1].max() <= y1), (ax.get_title(), ln.get_label())


def test_the_page_never_writes_into_a_folder_that_holds_files(tutorial, tmp_path):
    keep = tmp_path / "dataset.toml"
    keep.write_text("mine\n")
    with pytest.raises(FileExistsError):
        tutorial.run(tmp_path)
    assert keep.read_text() == "mine\n" and sorted(p.name for p in tmp_path.iterdir()) == ["dataset.toml"]


def test_the_readmes_manifest_loads_checks_and_evaluates_as_it_says(tmp_path, capsys):
    import re

    from morpi_filters import units
    from morpi_filters.dataset_eval import evaluate

    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Your own recordings\n"):]
    toml = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    assert len(toml.strip().splitlines()) <= 6
    root = tmp_path / "my-robot"
    (root / "imu").mkdir(parents=True)
    (root / "dataset.toml").write_text(toml)
    # the run it describes: 12 m straight ahead, written as the text says (FRD axes, g, deg/s, the default header)
    traj = simulate.straight(12.0, rest_s=(2.0, 1.5))
    t = 100.0 + np.arange(int(traj.end_time * 200.0) + 1) / 200.0
    data = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(3), sampling=t - 100.0, bias_scale=(0.25, 0.3))
    frd = np.array([1.0, -1.0, -1.0])
    table = np.column_stack([t, data.f * frd / units.G0, data.omega * frd / units.DEG])
    np.savetxt(root / "imu" / "run-01.csv", table, delimiter=",", header="time,f_x,f_y,f_z,g_x,g_y,g_z",
               comments="")
    capsys.readouterr()
    assert main(["check", "--dataset", str(root / "dataset.toml")]) == 0
    assert capsys.readouterr().out.startswith("1 recording(s) OK, 0 problem(s)")
    assert main(["evaluate", "--dataset", str(root / "dataset.toml"), "--out", str(root / "evaluation")]) == 0
    assert (root / "evaluation" / "README.md").is_file()
    result = evaluate(str(root / "dataset.toml"))
    rows, means = result.table(), result.group_table()
    assert set(rows["method"]) == {"INS-3D", "INS-2D"} and set(rows["calibration"]) == {"RD", "GC", "GAC"}
    assert list(means["group"].unique()) == ["all"] and len(means) == 6
    # the GAC estimate of a straight 12 m run ends within a few metres of its end point
    gac = rows[(rows["method"] == "INS-2D") & (rows["calibration"] == "GAC")]
    assert float(gac["end_error_m"].iloc[0]) < 3.0
