"""Time of ``morpi evaluate --data DIR`` (the MoRPI dataset read through the manifest the package ships) as a
ratio to ``morpi tables --data DIR``.

Both sides are whole commands as a user runs them, pages included, in fresh
processes, in alternation, the ratio taken per pair (:func:`pairs.paired_commands`).
They do not do the same work: ``evaluate`` runs every method (INS-3D and INS-2D
under RD, GC and GAC, MoRPI-A and MoRPI-G, the MoRPI-aided INS forward and
smoothed with its train-only tuning) on every recording and writes every estimated
path; ``tables`` computes the paper's cells. The ratio says what the general
pipeline costs against the paper's.

Target: evaluate / tables <= 3.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_evaluate.py [--data DIR] [--pairs N]``
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_aided import _root  # noqa: E402
from pairs import paired_commands  # noqa: E402

TARGET = 3.0


def measure(pairs: int = 5, quick: bool = False, data=None):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`)."""
    root = _root(data)
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(repo), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = lambda name: [sys.executable, "-m", "morpi_filters.cli", name, "--data", str(root),  # noqa: E731
                            "--out", str(Path(tmp) / name)]
        return [paired_commands("morpi evaluate --data / morpi tables --data (whole commands)", cmd("evaluate"),
                                cmd("tables"), pairs=2 if quick else pairs, warmup=1, target=TARGET, env=env,
                                cwd=tmp)]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", help="dataset root")
    p.add_argument("--pairs", type=int, default=5)
    args = p.parse_args(argv)
    for r in measure(args.pairs, data=args.data):
        print(r.line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
