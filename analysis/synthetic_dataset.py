"""Simulate one sine run, integrate it with the strapdown INS, and draw it.

Usage (from the project root)::

    PYTHONPATH=. python3 analysis/synthetic_dataset.py [--seed S] [--phone s8] [--out FILE.png]

The run is the short indoor route (6.3 m, 1 m periods) driven as in the synthetic
dataset (lateral amplitude 0.1 m x DATASET_OPTIONS["amplitude_factor"]): the phone's
irregular or regular time stamps, turn-on biases at the realistic fraction of the
datasheet (synthetic.REALISTIC_BIAS_FRACTION), white noise, mounting misalignment, motion
vibration and bias instability. The same run is integrated three ways: 3D INS on the
noise-free readings (integration error only), 3D and 2D INS on the noisy readings (the
drift the paper's raw-data INS baselines show).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from morpi_filters import dataset, simulate, synthetic, units
from morpi_filters.report import plots
from morpi_filters.report.common import save_figure
from morpi_filters.strapdown import ins2d, ins3d


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--phone", choices=sorted(synthetic.PHONE_CLOCKS), default="s8")
    ap.add_argument("--out", type=Path, default=Path("reports/simulation/sine_run.png"))
    args = ap.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    spec = dataset.folder_imu(args.phone)
    opts = synthetic.DATASET_OPTIONS
    amplitude = 0.1 * opts["amplitude_factor"]          # as the dataset drives the 0.1 m route
    traj = simulate.route_trajectory("short_distance", amplitude_m=amplitude, t0=0.4)
    noisy = simulate.imu(traj, spec, rng, sampling=synthetic.PHONE_CLOCKS[args.phone],
                         bias_scale=synthetic.REALISTIC_BIAS_FRACTION[args.phone], misalignment=opts["misalignment"], vibration=opts["vibration"],
                         bias_instability=opts["bias_instability"], correlation_time=opts["correlation_time"])
    clean = simulate.imu(traj, spec, rng, sampling=noisy.time, bias_scale=0.0, noise_scale=0.0)
    truth = noisy.truth
    start = dict(C0=truth.C_bn[0], p0=truth.position[0])
    solutions = {
        "3D INS, noise-free readings": ins3d(clean.time, clean.f, clean.omega, **start),
        "3D INS, noisy readings": ins3d(noisy.time, noisy.f, noisy.omega, **start),
        "2D INS, noisy readings": ins2d(noisy.time, noisy.f, noisy.omega, psi0=truth.heading[0], p0=truth.position[0]),
    }
    title = (f"simulated short route, {spec.name} ({args.phone}), seed {args.seed}: "
             f"{traj.distance:.2f} m travelled in {traj.stop_time - traj.start_time:.1f} s")
    save_figure(plots.simulation_run(truth, noisy, solutions, title=title), args.out)
    print(f"figure: {args.out}")
    for label, r in solutions.items():
        err = np.linalg.norm(r.position[-1, :2] - truth.position[-1, :2])
        print(f"{label:30s} end error {err * 1e3:12.4f} mm")
    print(f"lateral peaks: {truth.peak_times.size}, turn-on gyro bias [deg/s]: "
          + " ".join(f"{b / units.DEG_S:+.2f}" for b in noisy.gyro_bias))


if __name__ == "__main__":
    main()
