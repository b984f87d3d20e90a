"""Time of the field aided study (tuning included) as a ratio to the `morpi tables` computation.

Both sides start from the CSV files with empty caches, in alternation, the ratio
taken per pair (:func:`pairs.paired`):

- aided: :func:`morpi_filters.field_aided.aided_study` on the dataset root: the field
  evaluation it builds on (cells, gains, step rules), the train-only tunable search
  (every grid point on every train run), the smoothed pass over the 24 MoRPI cells'
  test runs and the ablation;
- tables: :func:`morpi_filters.evaluate.evaluate_tables` as `morpi tables` runs it
  (with the alternative readings).

Target: aided / tables <= 3.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_aided.py [--data DIR] [--pairs N]``
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pairs import paired  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402
from morpi_filters.evaluate import evaluate_tables  # noqa: E402
from morpi_filters.field_aided import aided_study  # noqa: E402


def _root(arg):
    if arg:
        root = Path(arg)
    elif os.environ.get(ds.DATA_ENV):
        root = Path(os.environ[ds.DATA_ENV])
    else:
        root = Path(__file__).resolve().parents[1].parent / "shared" / "morpi-dataset"
    if not root.is_dir() or not ds.catalogue(root):
        # an empty root times nothing: both sides would return at once
        sys.exit(f"bench_aided: no recordings under {root} (--data DIR or ${ds.DATA_ENV})")
    return root


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", help="dataset root")
    p.add_argument("--pairs", type=int, default=5)
    args = p.parse_args(argv)
    root = _root(args.data)
    print(f"dataset {root}", flush=True)
    r = paired("aided study (tuning included) / morpi tables computation",
               lambda: aided_study(root), lambda: evaluate_tables(root), pairs=args.pairs, warmup=0, target=3.0)
    print(r.line())


if __name__ == "__main__":
    main()
