"""Closed-form vs nonlinear strapdown drift of an INS at rest, over gyro bias and time.

Usage (from the project root)::

    PYTHONPATH=. python3 analysis/drift_study.py [--imu MPU-6500|LSM6DSL] [--draws N] [--scheduler ADDRESS] [--out DIR]

Prints, per gyro bias level, the relative disagreement at the end and the time
from which it stays above 1 % and 10 %, and draws the 3D and 2D maps.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from morpi_filters import montecarlo as mc
from morpi_filters.report import plots
from morpi_filters.report.common import save_figure
from morpi_filters.units import DEG_S, IMUS, MPU6500


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imu", default=MPU6500.name, choices=sorted(IMUS), help="the IMU whose accelerometer bias to use")
    ap.add_argument("--draws", type=int, default=32)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scheduler", default=None, help="Dask scheduler address")
    ap.add_argument("--out", type=Path, default=Path("reports/analysis/drift"))
    args = ap.parse_args(argv)
    spec = IMUS[args.imu]
    levels = np.union1d(np.logspace(-2, 1, 13), [spec.gyro_bias / DEG_S]) * DEG_S
    d = mc.drift_map(levels, spec=spec, draws=args.draws, seed=args.seed, scheduler=args.scheduler)
    on = {(k, lv): d.onset(k, lv) for k in ("INS-3D", "INS-2D") for lv in (0.01, 0.1)}
    print(f"{'bias [deg/s]':>12s} {'3D end':>8s} {'>1% from':>9s} {'>10% from':>9s} "
          f"{'2D end':>8s} {'>1% from':>9s} {'>10% from':>9s}")
    for i, b in enumerate(d.gyro_bias / DEG_S):
        print(f"{b:12.3f} {100 * d.rel_3d[i, -1]:7.3f}% {on['3d', 0.01][i]:9.1f} {on['3d', 0.1][i]:9.1f} "
              f"{100 * d.rel_2d[i, -1]:7.3f}% {on['2d', 0.01][i]:9.1f} {on['2d', 0.1][i]:9.1f}")
    args.out.mkdir(parents=True, exist_ok=True)
    for kind, rel in (("INS-3D", d.rel_3d), ("INS-2D", d.rel_2d)):
        save_figure(plots.drift_disagreement_map(d.gyro_bias / DEG_S, d.time, rel,
                                                 title=f"{kind.upper()} INS at rest, {spec.name}"),
                    args.out / f"drift_map_{kind}.png")
    print(f"figures: {args.out}")


if __name__ == "__main__":
    main()
