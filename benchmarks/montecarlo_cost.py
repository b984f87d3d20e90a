"""The cost constants of ``morpi montecarlo``'s estimate: how its time and memory grow.

``montecarlo.page_cost`` estimates a run of the command from its run count, its
samples per run (duration x 100 Hz) and its steps (path length / period), with
constants this script measures. Each design point is a path shape (``--duration-s``,
``--speed-mps``) run as the whole command, in a fresh process and without a dataset,
at two run counts R1 < R2; for each run the script reads the child's CPU time
(user + system, from ``wait4``), its wall time and its peak resident memory.

- Per run: the slope ``(T(R2) - T(R1)) / (R2 - R1)`` of each point, fitted as
  ``a n + b n^2 + g K n`` (n samples per run) by least squares on the relative
  error. A chunk holds fewer runs the longer they are (its noise block is fixed
  at 32 MiB), and each chunk reduces every kept epoch (``n^2``) and loops over
  the steps (``K n``).
- Fixed: ``T(R1) - R1 x per-run`` of each point, fitted as ``c0 + c1 n + c2 n^2 + c3 K``
  (K steps per run): the interpreter and imports, the 4000 noisy runs that
  train the reference gains, the page and its figures.
- Memory: the larger peak of each point, fitted the same way as the fixed time;
  the runs add their per-run arrays (``montecarlo.RUN_BYTES``, measured at 1,000,000
  runs) and a chunk its planes.
- Field: with a dataset configured, the command also trains the gains on the
  field recordings: the difference of one small point with and without ``--data``.
- Chunk: the peak of 4000 runs of 15 s in one chunk against the default chunks.

CPU time, not wall time, is fitted: the command runs on one thread, so on an
idle machine the two agree, and the CPU time is far less disturbed by other
work on a shared machine. The script prints every point, what the current
``montecarlo.page_cost`` says of it, the fitted constants as Python lines, and
each point's fit against its measurement (``--quick``: the points and the current
estimates only).

Usage: ``PYTHONPATH=. python3 benchmarks/montecarlo_cost.py [--data DIR] [--quick] [--save FILE | --points FILE]``
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: (duration [s] or None, speed [m/s] or None, R1, R2): default speed at four durations, a fast
#: and a slow path (many and few steps) at the long end.
DESIGN = ((15, None, 2000, 10000), (60, None, 1000, 4000), (150, None, 300, 1200), (300, None, 100, 400),
          (600, None, 60, 240), (150, 10.0, 100, 400), (600, 10.0, 20, 80), (600, 0.02, 60, 240))
QUICK = ((15, None, 500, 2000), (60, None, 200, 800), (150, 10.0, 50, 200))


def run(runs, duration=None, speed=None, data=None, chunk=None) -> dict:
    """One whole command: its CPU time [s], wall time [s] and peak resident memory [bytes]."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    env.pop("MORPI_DATA", None)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "morpi_filters.cli", "montecarlo", "--runs", str(runs), "--out", f"{tmp}/o",
               "--allow-long"]
        cmd += ["--duration-s", str(duration)] if duration else []
        cmd += ["--speed-mps", str(speed)] if speed else []
        cmd += ["--data", str(data)] if data else []
        cmd += ["--chunk", str(chunk)] if chunk else []
        with open(f"{tmp}/err", "w") as err:
            t0 = time.perf_counter()
            p = subprocess.Popen(cmd, env=env, cwd=tmp, stdout=subprocess.DEVNULL, stderr=err)
            _, status, ru = os.wait4(p.pid, 0)
            wall = time.perf_counter() - t0
        if status:
            raise RuntimeError(f"{' '.join(cmd)} failed: {Path(tmp, 'err').read_text()[-500:]}")
    return {"cpu": ru.ru_utime + ru.ru_stime, "wall": wall, "peak": ru.ru_maxrss * 1024.0}


def shape(duration, speed):
    """(samples per run, steps per run) of the path ``--duration-s``/``--speed-mps`` give."""
    from morpi_filters.montecarlo import page_cost

    cost = page_cost(1, duration_s=duration, speed_mps=speed)
    return cost.samples, cost.steps


def fit(columns, y, relative=True):
    """Least-squares coefficients of ``y ~ columns`` (relative errors when `relative`), non-negative."""
    A = np.column_stack(columns).astype(float)
    y = np.asarray(y, float)
    w = 1.0 / y if relative else np.ones_like(y)
    coef = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)[0]
    return np.maximum(coef, 0.0)


def fit_points(rows):
    """The constants from measured points ``(n, K, R1, R2, run R1, run R2)``; prints each point against its fit."""
    n = np.array([r[0] for r in rows], float)
    k = np.array([r[1] for r in rows], float)
    per_run = np.array([(r[5]["cpu"] - r[4]["cpu"]) / (r[3] - r[2]) for r in rows])
    a, b, g = fit([n, n * n, k * n], per_run)
    fixed = np.array([r[4]["cpu"] - r[2] * (a * r[0] + b * r[0] ** 2 + g * r[0] * r[1]) for r in rows])
    c = fit([np.ones_like(n), n, n * n, k], fixed)
    peak = np.array([max(r[4]["peak"], r[5]["peak"]) for r in rows])
    m = fit([np.ones_like(n), n, n * n, k], peak)
    print(f"RUN_SECONDS = ({a:.3g}, {b:.3g}, {g:.3g})")
    print(f"FIXED_SECONDS = ({c[0]:.3g}, {c[1]:.3g}, {c[2]:.3g}, {c[3]:.3g})")
    print(f"FIXED_BYTES = ({m[0]:.3g}, {m[1]:.3g}, {m[2]:.3g}, {m[3]:.3g})")
    for (nn, kk, r1, r2, ra, rb), pr, fx, pk in zip(rows, per_run, fixed, peak):
        fit_pr = a * nn + b * nn * nn + g * kk * nn
        fit_fx = c[0] + c[1] * nn + c[2] * nn * nn + c[3] * kk
        fit_pk = m[0] + m[1] * nn + m[2] * nn * nn + m[3] * kk
        print(f"n {nn:6.0f} K {kk:5.0f}: per run {1e3 * pr:7.3f} ms (fit {1e3 * fit_pr:7.3f}), fixed {fx:6.2f} s "
              f"(fit {fit_fx:6.2f}), peak {pk / 1e6:5.0f} MB (fit {fit_pk / 1e6:5.0f}); "
              f"{r2} runs: {rb['cpu']:.1f} s CPU, predicted {fit_fx + r2 * fit_pr:.1f} s")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="field dataset: also measure the field gain training's fixed cost")
    ap.add_argument("--quick", action="store_true", help="three small points (a smoke run, not for the constants)")
    ap.add_argument("--save", metavar="FILE", help="write the measured points here (JSON)")
    ap.add_argument("--points", metavar="FILE", help="fit the points of an earlier --save instead of measuring")
    args = ap.parse_args(argv)
    if args.points:
        fit_points(json.loads(Path(args.points).read_text()))
        return
    rows = []
    for duration, speed, r1, r2 in (QUICK if args.quick else DESIGN):
        n, k = shape(duration, speed)
        a, b = run(r1, duration, speed), run(r2, duration, speed)
        rows.append((n, k, r1, r2, a, b))
        print(f"{duration} s, speed {speed or 'default'}: n {n}, K {k}; {r1} runs {a['cpu']:.2f} s CPU "
              f"({a['wall']:.2f} s wall, {a['peak'] / 1e6:.0f} MB), {r2} runs {b['cpu']:.2f} s CPU "
              f"({b['wall']:.2f} s wall, {b['peak'] / 1e6:.0f} MB)", flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(rows, indent=1))
    from morpi_filters.montecarlo import page_cost

    for (duration, speed, r1, r2), row in zip(QUICK if args.quick else DESIGN, rows):
        est = page_cost(r2, duration_s=duration, speed_mps=speed)
        print(f"{duration} s, speed {speed or 'default'}, {r2} runs: {row[5]['cpu']:.1f} s CPU and "
              f"{row[5]['peak'] / 1e6:.0f} MB; montecarlo.page_cost says {est.seconds:.1f} s and "
              f"{est.bytes / 1e6:.0f} MB")
    if not args.quick:                  # three points do not fix the seven constants
        fit_points(rows)
    if args.data:
        plain, field = run(200, 15), run(200, 15, data=args.data)
        print(f"FIELD_SECONDS, FIELD_BYTES = {field['cpu'] - plain['cpu']:.3g}, {field['peak'] - plain['peak']:.3g}")
    for r1, chunk in ((4000, None), (4000, 4000)):
        print(f"15 s, {r1} runs, chunk {chunk or 'default'}: peak {run(r1, chunk=chunk)['peak'] / 1e6:.0f} MB")


if __name__ == "__main__":
    main()
