"""Time of ``morpi report --data DIR`` as a ratio to ``morpi tables --data DIR``.

Both sides are whole commands as a user runs them, figures included, in fresh
processes, in alternation, the ratio taken per pair (:func:`pairs.paired_commands`):
the report (every section: tables, assessment, curves, Monte Carlo with its default
runs, drift, aided, the index) against its tables section alone. The report runs the
aided filter's recordings on threads (one per core the process may use) and the tables
command has no threaded part; a second row, for information, runs the report with
``--workers 1``, all of it on one thread.

Target: report / tables <= 3.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_report.py [--data DIR] [--pairs N]``
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
        rows = [paired_commands("morpi report --data / morpi tables --data (whole commands)", cmd("report"),
                                cmd("tables"), pairs=pairs, warmup=0, target=TARGET, env=env, cwd=tmp)]
        if not quick:
            rows.append(paired_commands("morpi report --data --workers 1 / morpi tables --data (whole commands, "
                                        "for information)", cmd("report") + ["--workers", "1"], cmd("tables"),
                                        pairs=pairs, warmup=0, env=env, cwd=tmp))
    return rows


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
