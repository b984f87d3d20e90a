"""Cost of a Monte Carlo gain-error study relative to drawing its random numbers.

Prints the wall time of a seeded study (default 10,000 runs, 15 s at 100 Hz,
INS-3D, INS-2D, MoRPI-A and MoRPI-G) and of numpy drawing the same random
numbers alone (one Generator per run from SeedSequence(seed).spawn(N), each
drawing its own block of 7 + 6 n standard normals, in the same chunks, plus
the gain-training draws), both measured in this one process (best of
--repeat, wall clock and process CPU time), and their ratio. Target: 3x or less. The stricter ratio against
the per-run draws only is printed too.

Usage: PYTHONPATH=. python3 benchmarks/bench_montecarlo.py [--runs N] [--chunk K] [--repeat R]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from morpi_filters import montecarlo as mc


def draw_training(cfg) -> float:
    """Draw the gain-training numbers of the study (one Generator, same shapes as reference_gains)."""
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(mc._TRAINING_SEED)))
    n = int(round(cfg.duration * cfg.rate_hz)) + 1
    total = 0.0
    for a in range(0, cfg.training_runs, 500):
        total += float(rng.standard_normal((min(500, cfg.training_runs - a), 2, n))[:, 0, -1].sum())
    return total


def draw_only(runs: int, seed: int, n: int, chunk: int) -> float:
    """Draw exactly the study's per-run random numbers, chunk by chunk; return a checksum."""
    total = 0.0
    for a in range(0, runs, chunk):
        z = mc._draw(seed, a, min(a + chunk, runs), n)
        total += float(z[:, -1].sum())
    return total


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--chunk", type=int, default=None)
    ap.add_argument("--repeat", type=int, default=3, help="take the best of R timings of each")
    args = ap.parse_args(argv)
    cfg = mc.StudyConfig()
    n = int(round(cfg.duration * cfg.rate_hz)) + 1
    chunk = args.chunk or mc._default_chunk(n)
    # wall clock and process CPU time (the CPU time is not inflated when other processes share the cores)
    clocks = {"wall": time.perf_counter, "cpu": time.process_time}
    best = {(c, k): math.inf for c in clocks for k in ("draw", "train", "study")}
    for _ in range(args.repeat):
        for key, fn in (("draw", lambda: draw_only(args.runs, args.seed, n, chunk)),
                        ("train", lambda: draw_training(cfg)),
                        ("study", lambda: mc.run_study(args.runs, args.seed, cfg, chunk=chunk, progress=False))):
            t0 = {c: f() for c, f in clocks.items()}
            out = fn()
            for c, f in clocks.items():
                best[c, key] = min(best[c, key], f() - t0[c])
            if key == "study":
                r = out
    print(f"runs {args.runs}, n {n} samples, chunk {chunk}, best of {args.repeat}")
    for c in clocks:
        td, tt, ts = best[c, "draw"], best[c, "train"], best[c, "study"]
        print(f"[{c}] numpy drawing the per-run numbers alone: {td:.2f} s "
              f"({args.runs * (7 + 6 * n) / td / 1e6:.0f} M normals/s); gain-training numbers: {tt:.2f} s; "
              f"full study (4 methods, incl. gain training): {ts:.2f} s")
        print(f"[{c}] ratio study / all its draws: {ts / (td + tt):.2f}x (target <= 3x); "
              f"study / per-run draws only: {ts / td:.2f}x")
    print(f"digest {r.digest}")


if __name__ == "__main__":
    main()
