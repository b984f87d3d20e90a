"""Cost of batched IMU synthesis relative to drawing the same random numbers with numpy.

Simulates 10,000 runs of a 15 s trajectory at 100 Hz (both sensors: specific force and
angular rate, turn-on biases and white noise), in chunks of 1,000 runs to bound memory,
and times numpy drawing the same count of standard normals into the same chunk shapes.
Both are measured in this run; the printed ratio is synthesis / drawing alone.
Target: 3x or less.

Usage: PYTHONPATH=. python3 benchmarks/bench_simulate.py [--runs N] [--chunk K]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from morpi_filters import simulate, units

TARGET = 3.0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=10_000)
    p.add_argument("--chunk", type=int, default=1_000)
    p.add_argument("--repeat", type=int, default=3, help="best of this many timings")
    args = p.parse_args(argv)

    # 15 s at 100 Hz: 1 s rest, a 6.3 m sine (1 m periods) in 13 s, 1 s rest
    traj = simulate.sine(6.3, period=1.0, amplitude=0.1, speed=6.3 / 12.0, rest=1.0, rate_hz=100.0)
    n = traj.time.size
    chunks = [min(args.chunk, args.runs - i) for i in range(0, args.runs, args.chunk)]

    def synthesize(**options):
        rng = np.random.default_rng(0)
        for c in chunks:
            d = simulate.imu(traj, units.LSM6DSL, rng, runs=c, sampling=traj.time, **options)
        return d

    def draw_only():
        rng = np.random.default_rng(0)
        for c in chunks:
            a = rng.standard_normal((c, n, 3))
            b = rng.standard_normal((c, n, 3))
            s = rng.standard_normal((c, 15))
        return a, b, s

    def best(fn):
        out = []
        for _ in range(args.repeat):
            t = time.perf_counter()
            fn()
            out.append(time.perf_counter() - t)
        return min(out)

    t_draw = best(draw_only)
    t_sim = best(synthesize)
    t_full = best(lambda: synthesize(scale_factor=0.01, misalignment=0.01))
    ratio = t_sim / t_draw
    print(f"runs={args.runs} chunk={args.chunk} samples/run={n} ({traj.time[-1] - traj.time[0]:.1f} s at 100 Hz)")
    print(f"numpy drawing alone : {t_draw:.3f} s")
    print(f"IMU synthesis       : {t_sim:.3f} s")
    print(f"ratio               : {ratio:.2f}x (target <= {TARGET:g}x: {'met' if ratio <= TARGET else 'NOT met'})")
    print(f"with scale factor and misalignment: {t_full:.3f} s, ratio {t_full / t_draw:.2f}x (information)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
