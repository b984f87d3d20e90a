"""How the cost of the field tables and of Monte Carlo grows with the size of the work.

Each point is one whole command in a fresh process, as a user runs it, with its
wall time and its peak resident memory (``ru_maxrss`` of that child, read by
``/usr/bin/time -v``: :func:`pairs.run_peak`):

- ``morpi tables --data DIR`` on 1x, 2x, 5x and 10x the field dataset: a
  temporary root holding, for every recording ``<phone>/<route>[/<split>]/<n>.csv``,
  symbolic links ``<n + 1000 j>.csv`` (j = 0 .. k-1) to it, so the loader sees k
  times as many recordings in the same layout (train copies also enlarge every
  training set); ``--partial`` on every point, since a folder holding more runs
  than the field layout is otherwise refused;
- ``morpi montecarlo --runs N`` for N = 1k, 10k, 100k and 1M (the largest ``--runs``; several
  minutes on 2 cores), or the sizes given with ``--runs``.

One measurement per point (a scale study, not a ratio); the machine is shared, so
read the growth, not the third digit.

Usage: ``PYTHONPATH=. python3 benchmarks/scale.py [--data DIR] [--copies 1 2 5 10] [--runs 1000 10000 100000]``
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_aided import _root  # noqa: E402
from pairs import run_peak  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
COPIES = (1, 2, 5, 10)
RUNS = (1_000, 10_000, 100_000, 1_000_000)


def copied_dataset(root: Path, k: int, dest: Path) -> tuple[Path, int]:
    """A dataset root under `dest` with every recording of `root` linked k times; (root, recordings)."""
    entries = ds.catalogue(root)
    for e in entries:
        folder = dest / Path(e.relpath).parent
        folder.mkdir(parents=True, exist_ok=True)
        n = int(e.path.stem)
        for j in range(k):
            (folder / f"{n + 1000 * j}.csv").symlink_to(e.path.resolve())
    return dest, len(entries) * k


def measure(quick: bool = False, data=None, copies=None, runs=None) -> list[dict]:
    """One row per point: ``{"command", "size", "seconds", "peak_mb"}``."""
    copies = copies or ((1, 2) if quick else COPIES)
    runs = runs or ((1_000, 10_000) if quick else RUNS)
    root = _root(data)
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in copies:
            croot, n = copied_dataset(root, k, tmp / f"x{k}")
            cmd = [sys.executable, "-m", "morpi_filters.cli", "tables", "--data", str(croot),
                   "--out", str(tmp / f"tables{k}"), "--partial"]
            dt, mb = run_peak(cmd, env=env, cwd=tmp)
            rows.append({"command": "morpi tables --data", "size": f"{k}x ({n} recordings)", "seconds": dt,
                         "peak_mb": mb})
            print(f"tables {k}x: {dt:.1f} s, {mb:.0f} MB", flush=True)
        for n in runs:
            cmd = [sys.executable, "-m", "morpi_filters.cli", "montecarlo", "--runs", str(n),
                   "--out", str(tmp / f"mc{n}")]
            dt, mb = run_peak(cmd, env=env, cwd=tmp)
            rows.append({"command": "morpi montecarlo --runs", "size": f"{n:,} runs", "seconds": dt, "peak_mb": mb})
            print(f"montecarlo {n}: {dt:.1f} s, {mb:.0f} MB", flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="dataset root")
    ap.add_argument("--copies", type=int, nargs="+", default=None)
    ap.add_argument("--runs", type=int, nargs="+", default=None)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    measure(args.quick, args.data, args.copies, args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
