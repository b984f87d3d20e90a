"""Gain-error Monte Carlo: final-error distributions of INS-3D, INS-2D, MoRPI-A and MoRPI-G.

Usage (from the project root)::

    PYTHONPATH=. python3 analysis/gain_error_study.py [--runs N] [--seed S] [--imu MPU-6500|LSM6DSL]
        [--calibration RD|GC|GAC] [--duration-s S] [--speed-mps V] [--scheduler ADDRESS] [--out DIR]

Runs one seeded study with the paper's gain errors (5 % and 10 %) and a spread
scenario, prints the final-error statistics and the MoRPI distance error next
to the analytical ds = dG D, and draws the histograms and error curves. The
same seed gives the same digest on any chunking or cluster.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from morpi_filters import montecarlo as mc
from morpi_filters.report import plots
from morpi_filters.report.common import save_figure
from morpi_filters.units import IMUS, MPU6500


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--imu", default=MPU6500.name, choices=sorted(IMUS), help="the IMU whose datasheet to use")
    ap.add_argument("--calibration", default="GAC", choices=mc.CALIBRATIONS)
    ap.add_argument("--duration-s", type=float, default=None, help="time of the sine path [s] (default 15)")
    ap.add_argument("--duration", dest="duration_s", type=float, help=argparse.SUPPRESS)   # name before 0.2
    ap.add_argument("--speed-mps", type=float, default=None, help="cruise speed [m/s] (default the paper's)")
    ap.add_argument("--speed", dest="speed_mps", type=float, help=argparse.SUPPRESS)       # name before 0.2
    ap.add_argument("--spread", type=float, default=mc.ASSUMED_SPREAD, help="per-run gain spread (fraction)")
    ap.add_argument("--scheduler", default=None, help="Dask scheduler address")
    ap.add_argument("--out", type=Path, default=Path("reports/analysis/gain_error"))
    args = ap.parse_args(argv)

    gains = (mc.GainError("dG = 5 %", 0.05), mc.GainError("dG = 10 %", 0.10),
             mc.GainError("spread", 0.0, args.spread))
    cfg = mc.StudyConfig(spec=IMUS[args.imu], gains=gains, calibration=args.calibration,
                         duration_s=args.duration_s, speed_mps=args.speed_mps)
    r = mc.run_study(args.runs, args.seed, cfg, scheduler=args.scheduler)
    length, speed, duration = r.config.motion()
    print(f"{r.runs} runs, seed {r.seed}, {cfg.spec.name}, calibration {cfg.calibration}, {length:.2f} m in "
          f"{duration:g} s at {speed:.3f} m/s: digest {r.digest}")
    print(f"{'method':28s} {'mean':>9s} {'std':>9s} {'median':>9s} {'p95':>9s}  [m]")
    for c in r.columns:
        st = mc.summarize(r.column(c))
        print(f"{c:28s} {st['mean']:9.3f} {st['std']:9.3f} {st['median']:9.3f} {st['p95']:9.3f}")
    print(f"MoRPI distance error vs ds = dG D (D = {r.distance:.3f} m), bound z std / sqrt(N), z = {mc.Z99:.3f}:")
    for c in mc.distance_law_check(r):
        for m in ("MoRPI-A", "MoRPI-G"):
            v = c[m]
            print(f"  {c['label']:12s} {m}: MC {v['mc_mean']:+.4f} m, ds {c['analytic_mean']:+.4f} m, "
                  f"difference {v['residual_mean']:+.5f} +/- {v['bound']:.5f} m")
    args.out.mkdir(parents=True, exist_ok=True)
    save_figure(plots.montecarlo_final_errors(r.columns, r.final), args.out / "final_errors.png")
    save_figure(plots.montecarlo_error_curves(r.time, r.bands, list(mc.METHODS)),
                args.out / "error_curves.png")
    print(f"figures: {args.out}")


if __name__ == "__main__":
    main()
