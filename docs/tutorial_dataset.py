"""Tutorial: your own robot's recordings, from the logger's files to each method's error.

Run it from the project root::

    python3 docs/tutorial_dataset.py --out robot-tutorial

Your robot is not a MoRPI phone: its logger writes NumPy ``.npy`` arrays with
no time column at 120 Hz, the gyro first in deg/s and the accelerometer in g,
on a board mounted x forward, y right, z down (FRD); a motion-capture system
gives its positions at 10 Hz in a north-east-down (NED) frame, and its first
sample comes 0.4 s before the IMU's. The steps below:

1. write four such recordings (simulated here, with their exact truth, so the
   page runs anywhere; with a real robot the files are already on disk);
2. write the dataset manifest (``dataset.toml``) that says what the files hold:
   every key is in the text below, and ``docs/manifest.md`` is the reference;
3. check it (what ``morpi check --dataset robot-tutorial/dataset.toml`` does),
   and see how a wrong declaration is named on one line;
4. load it: every recording in the package's frame and units (body x forward,
   y left, z up; s, m/s^2, rad/s), the truth in a local east-north-up frame;
5. evaluate every method and calibration against the truth (what ``morpi
   evaluate --dataset robot-tutorial/dataset.toml --json result.json`` does) and
   read the rows and the group means as pandas tables;
6. draw the paths against the truth and the error against time with
   matplotlib, from the estimates the evaluation returns.

The test suite (``tests/test_tutorial_dataset.py``) runs the whole page in a
temporary folder and compares its numbers with what the ``morpi`` command
writes to its JSON on the same files.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

#: The runs: id, split, distance along the course [m], heading of the course [deg clockwise from north],
#: start point (north, east) in the motion-capture frame [m].
RUNS = (("run-01", "train", 6.0, 20.0, (3.0, -2.0)),
        ("run-02", "train", 8.0, 110.0, (-4.0, 1.0)),
        ("run-03", "test", 7.0, 200.0, (5.0, 6.0)),
        ("run-04", "test", 9.0, 290.0, (-1.0, -7.0)))
IMU_RATE_HZ = 120.0                 # the logger's rate (its files hold no time)
TRUTH_RATE_HZ = 10.0                # the motion capture's rate
TRUTH_OFFSET_S = -0.4               # the motion capture starts 0.4 s before the IMU


# %% 1. The recordings, as the robot's logger and the motion capture write them
def write_recordings(folder, seed=0):
    from morpi_filters import simulate, synthetic, units

    folder = Path(folder)
    (folder / "imu").mkdir(parents=True, exist_ok=True)
    (folder / "mocap").mkdir(exist_ok=True)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(RUNS))]
    for (rec_id, _, length, heading_deg, (n0, e0)), rng in zip(RUNS, rngs):
        # a robot moving along a sine (1 m periods, 0.1 m to each side), standing 2 s before and 1.5 s after
        traj = simulate.sine(length, p2p_m=1.0, amplitude_m=0.1, rest_s=(2.0, 1.5))
        t = np.arange(int(traj.end_time * IMU_RATE_HZ) + 1) / IMU_RATE_HZ
        data = simulate.imu(traj, units.LSM6DSL, rng, sampling=t,      # a MEMS IMU with its biases and noise
                            bias_scale=synthetic.REALISTIC_BIAS_FRACTION["s8"])
        # the simulator's axes are x forward, y left, z up (FLU) in m/s^2 and rad/s; the board's are FRD
        frd = np.array([1.0, -1.0, -1.0])
        imu = np.column_stack([data.omega * frd / units.DEG, data.f * frd / units.G0])   # gx gy gz [deg/s], ax ay az [g]
        np.save(folder / "imu" / f"{rec_id}.npy", imu)
        # the truth on the motion capture's clock: IMU time 0 is truth time -TRUTH_OFFSET_S after its first sample
        m = math.ceil((t[-1] - TRUTH_OFFSET_S) * TRUTH_RATE_HZ) + 1
        p = traj.at(TRUTH_OFFSET_S + np.arange(m) / TRUTH_RATE_HZ).position     # x forward, y left, z up [m]
        c, s = math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))
        ned = np.column_stack([n0 + c * p[:, 0] + s * p[:, 1], e0 + s * p[:, 0] - c * p[:, 1], -p[:, 2]])
        np.save(folder / "mocap" / f"{rec_id}.npy", ned)                 # columns n, e, d [m]
    return folder


# %% 2. The manifest: what the files hold, key by key (docs/manifest.md)
MANIFEST = """\
format_version = 1
name = "my robot, motion capture"

[defaults]
group = "1 m periods"         # results are averaged per group
motion = "periodic"           # MoRPI counts the periods of the motion
rest = "auto"                 # find the initial rest (or rest = [t0, t1] in s from the first sample)
initial = "rest"              # the robot starts standing

[defaults.imu]
format = "npy"
columns = { g_x = 0, g_y = 1, g_z = 2, f_x = 3, f_y = 4, f_z = 5 }    # column indices of the array
rate_hz = 120.0               # no time column: sample k is at k / 120 s
accel_unit = "g"
gyro_unit = "deg/s"
axes = "FRD"                  # the board's x, y, z point forward, right and down

[defaults.truth]
kind = "track"
format = "npy"
columns = { n = 0, e = 1, d = 2 }      # the letters say the frame: NED
rate_hz = 10.0
offset_s = -0.4               # the truth's first sample is 0.4 s before the IMU's

[[recording]]
id = "run-01"
split = "train"               # the MoRPI gains are trained on these
imu.file = "imu/run-01.npy"
truth.file = "mocap/run-01.npy"

[[recording]]
id = "run-02"
split = "train"
imu.file = "imu/run-02.npy"
truth.file = "mocap/run-02.npy"

[[recording]]
id = "run-03"
split = "test"                # the results are reported on these
imu.file = "imu/run-03.npy"
truth.file = "mocap/run-03.npy"

[[recording]]
id = "run-04"
split = "test"
imu.file = "imu/run-04.npy"
truth.file = "mocap/run-04.npy"
"""


def write_manifest(folder):
    path = Path(folder) / "dataset.toml"
    path.write_text(MANIFEST)
    return path


# %% 3. The checks of `morpi check --dataset`, and a wrong declaration
def check(manifest):
    from morpi_filters.manifest import check_dataset

    problems, n_ok = check_dataset(manifest)                  # one MorpiError per recording that fails
    wrong = Path(manifest).with_name("wrong-axes.toml")       # the same files, axes left at the default "FLU"
    wrong.write_text(Path(manifest).read_text().replace('axes = "FRD"', 'axes = "FLU"'))
    wrong_problems, _ = check_dataset(wrong)
    return {"n_ok": n_ok, "problems": [str(p) for p in problems],
            "wrong_axes": [str(p) for p in wrong_problems]}


# %% 4. The recordings in the package's frame and units
def load(manifest):
    from morpi_filters.manifest import load_dataset

    ds = load_dataset(manifest)
    run = ds["run-01"]
    still = run.recording.time < 1.0                           # the first second: standing
    return {"dataset": ds, "f_at_rest": run.recording.f[still].mean(axis=0),   # about (0, 0, 9.81) m/s^2
            "truth_frame": run.truth.frame, "truth_start_s": float(run.truth.time[0])}


# %% 5. Every method against the truth, as tables
def evaluate_tables(manifest):
    from morpi_filters.dataset_eval import evaluate

    result = evaluate(manifest)                                # a DatasetEvaluation
    table = result.table()                                     # one row per recording, method and calibration
    groups = result.group_table()                              # means over the test recordings
    return result, table, groups


# %% 6. Paths against the truth, error against time
def figures(result, dataset, folder, shown=(("INS-2D", "GAC"), ("MoRPI-A", "GAC"), ("MoRPI-G", "GAC"))):
    from matplotlib.figure import Figure

    ids = [r.id for r in dataset.recordings if r.split == "test"]
    paths_fig, errors_fig = Figure(figsize=(10, 4.5)), Figure(figsize=(10, 4.5))
    for k, rec_id in enumerate(ids):
        truth = dataset[rec_id].truth                          # ENU: x east, y north [m], on the IMU clock [s]
        ax, ex = paths_fig.add_subplot(1, len(ids), k + 1), errors_fig.add_subplot(1, len(ids), k + 1)
        ax.plot(truth.position[:, 0], truth.position[:, 1], "k-", lw=3, alpha=0.3, label="truth")
        for p in result.paths:
            if p.id == rec_id and (p.method, p.calibration) in shown:
                ax.plot(p.xy[:, 0], p.xy[:, 1], label=f"{p.method} {p.calibration}")
                error = np.hypot(*(p.xy - truth.at(p.time)[:, :2]).T)         # horizontal error [m]
                ex.plot(p.time, error, label=f"{p.method} {p.calibration}")
        ax.set(title=rec_id, xlabel="east [m]", ylabel="north [m]", aspect="equal", adjustable="datalim")
        ex.set(title=rec_id, xlabel="time [s]", ylabel="horizontal error [m]")
        ax.legend(fontsize=8)
        ex.legend(fontsize=8)
    files = {"paths": Path(folder) / "paths.png", "errors": Path(folder) / "errors.png"}
    paths_fig.savefig(files["paths"], dpi=100, bbox_inches="tight")
    errors_fig.savefig(files["errors"], dpi=100, bbox_inches="tight")
    return {"files": files, "paths": paths_fig, "errors": errors_fig}


def run(folder, seed=0):
    """Every step in `folder` (new or empty: nothing in it is overwritten); what each returns."""
    folder = Path(folder)
    if folder.exists() and any(folder.iterdir()):
        raise FileExistsError(f"{folder}: not empty; give a new or empty folder")
    manifest = write_manifest(write_recordings(folder, seed))
    checked = check(manifest)
    loaded = load(manifest)
    result, table, groups = evaluate_tables(manifest)
    figs = figures(result, loaded["dataset"], folder)
    return {"manifest": manifest, "check": checked, "load": loaded, "result": result, "table": table,
            "groups": groups, "figures": figs}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("robot-tutorial"), help="a new or empty folder for the files")
    ap.add_argument("--seed", type=int, default=0, help="seed of the simulated sensor errors")
    args = ap.parse_args(argv)
    r = run(args.out, args.seed)
    c = r["check"]
    print(f"3. {c['n_ok']} recording(s) OK, {len(c['problems'])} problem(s); declared FLU instead of FRD:")
    print("   " + c["wrong_axes"][0])
    f = r["load"]["f_at_rest"]
    print(f"4. run-01 at rest reads f = ({f[0]:.3f}, {f[1]:.3f}, {f[2]:.3f}) m/s^2 in x forward, y left, z up; "
          f"its truth is in {r['load']['truth_frame']}, from {r['load']['truth_start_s']:g} s")
    print("5. end error [% of the distance], mean over the test runs:")
    single = r["groups"][r["groups"]["estimate"].isna()]       # the aided filter's forward and smoothed rows apart
    print(single.pivot(index="method", columns="calibration", values="end_error_percent")
          .reindex(columns=["RD", "GC", "GAC"]).round(2).to_string())
    print(f"6. figures: {r['figures']['files']['paths']}, {r['figures']['files']['errors']}")
    return r


if __name__ == "__main__":
    main()
