"""Time of the field aided study (tuning included) as a ratio to the `morpi tables` computation.

Both sides are whole commands as a user runs them, from the CSV files to the section's
files (figures included), in alternation, the ratio taken per pair
(:func:`pairs.paired_commands`):

- aided: ``morpi aided --data DIR``: the field evaluation it builds on (cells, gains,
  step rules), the train-only tunable search (every grid point on every train run in
  one batched pass per training set), the smoothed pass over the 24 MoRPI cells' test
  runs, the ablation, the page and its figures;
- tables: ``morpi tables --data DIR``.

And the computations alone, in process (no figures, no interpreter start): the aided study from
the CSV files (:func:`field_aided.aided_study`: its field evaluation, the tunable search, the
test runs and the ablation) against the tables computation of ``bench_tables`` (the tables
study and its page text). The tables computation runs on one thread, so the target row runs the
aided study on one thread too (``workers=1``); a second row, for information, runs it as the
command does, its recordings' passes on threads (one per core the process may use).

Target: aided / tables <= 3, for the whole commands and for the one-thread computation.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_aided.py [--data DIR] [--pairs N]``
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pairs import paired, paired_commands  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402


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


def measure(pairs: int = 5, quick: bool = False, data=None):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`)."""
    from bench_tables import tables

    from morpi_filters.field_aided import aided_study
    from morpi_filters.parallel import available_cores

    root = _root(data)
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(repo), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = lambda name: [sys.executable, "-m", "morpi_filters.cli", name, "--data", str(root),  # noqa: E731
                            "--out", str(Path(tmp) / name)]
        rows = [paired_commands("morpi aided / morpi tables (whole commands)", cmd("aided"), cmd("tables"),
                                pairs=pairs, warmup=0, target=3.0, env=env, cwd=tmp)]
    if not quick:
        rows.append(paired("aided study, one thread / tables computation (in process, from the CSV files, "
                           "no figures)", lambda: aided_study(root, workers=1), lambda: tables(root), pairs=pairs,
                           warmup=1, target=3.0))
        rows.append(paired(f"aided study, {available_cores()} threads / tables computation (in process, "
                           "for information)", lambda: aided_study(root), lambda: tables(root), pairs=pairs,
                           warmup=1))
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", help="dataset root")
    p.add_argument("--pairs", type=int, default=5)
    args = p.parse_args(argv)
    print(f"dataset {_root(args.data)}", flush=True)
    for r in measure(args.pairs, data=args.data):
        print(r.line())


if __name__ == "__main__":
    main()
