"""Time of `morpi tables` as a ratio to the true floor of its input: pandas' parse of the 143 CSVs.

Measured in one run on the field dataset (``--data DIR`` or ``$MORPI_DATA``, else
``../shared/morpi-dataset``), each ratio over alternating pairs (:mod:`pairs`):

- computation: everything `morpi tables` computes, from the CSV files to result.json and
  the README text (:func:`evaluate.tables_study`: the evaluation, the report's alternatives
  and the figures' data; :func:`report.tables.result_json` and the page), without the PNGs,
  against ``pandas.read_csv`` of every recording in the same process (target <= 8x);
- whole command: ``morpi tables --data DIR`` (figures included) against a fresh interpreter
  that imports pandas and parses every recording (target <= 12x);
- the project's own loader (:func:`dataset.load_csv`: pandas' C tokenizer plus every check of
  a recording, arrays in the column order of the package) against the plain parse of the same
  files, in the same process (target <= 1.5x).

pandas is both the floor and the loader's tokenizer (a dependency of the package).

Usage: ``PYTHONPATH=. python3 benchmarks/bench_tables.py [--data DIR] [--pairs N] [--profile]``
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pairs import paired, paired_commands, python_command  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402
from morpi_filters import evaluate as ev  # noqa: E402
from morpi_filters.results import DataSource  # noqa: E402


def _root(arg):
    if arg:
        return Path(arg)
    if os.environ.get(ds.DATA_ENV):
        return Path(os.environ[ds.DATA_ENV])
    return Path(__file__).resolve().parents[1].parent / "shared" / "morpi-dataset"


def parse_floor(paths):
    import pandas as pd

    return [pd.read_csv(p) for p in paths]


def parse_ours(paths):
    return [ds.load_csv(p) for p in paths]


def tables(root):
    from morpi_filters.report import tables as page

    src = DataSource(root)
    study = ev.tables_study(root)
    payload = page.result_json(study, src)
    page._page(study, payload, src, [])
    return study, payload


def measure(pairs: int = 5, quick: bool = False, data=None):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`).

    Raises
    ------
    RuntimeError
        Without recordings or without pandas (there would be nothing to compare).
    """
    root = _root(data)
    paths = [e.path for e in ds.catalogue(root)] if root.is_dir() else []
    if not paths:
        raise RuntimeError(f"no recordings under {root}; {ds.missing_data_message()}")
    try:
        import pandas  # noqa: F401
    except ImportError:
        raise RuntimeError("bench_tables: the floor is pandas' parse: pip install pandas") from None
    rows = [paired(f"tables computation ({len(paths)} recordings) / pandas parse (in process)", lambda: tables(root),
                   lambda: parse_floor(paths), pairs=pairs, target=8.0)]
    if not quick:
        rows.append(paired(f"load_csv ({len(paths)} recordings) / pandas parse (in process)", lambda: parse_ours(paths),
                           lambda: parse_floor(paths), pairs=pairs, target=1.5))
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(repo), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "morpi_filters.cli", "tables", "--data", str(root), "--out", str(Path(tmp) / "t")]
        floor = python_command("import pandas, sys; [pandas.read_csv(p) for p in sys.argv[1:]]") + [str(p) for p in paths]
        rows.append(paired_commands("morpi tables (whole command) / pandas parse (fresh process)", cmd, floor,
                                    pairs=pairs, target=12.0, env=env))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="dataset root")
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--profile", action="store_true", help="print the top of a cProfile of the computation")
    args = ap.parse_args(argv)
    try:
        rows = measure(args.pairs, data=args.data)
    except RuntimeError as e:
        print(e, file=sys.stderr)
        return 2
    for r in rows:
        print(r.line())
    if args.profile:
        import cProfile
        import pstats

        pr = cProfile.Profile()
        pr.enable()
        tables(_root(args.data))
        pr.disable()
        pstats.Stats(pr).sort_stats("cumulative").print_stats(25)
    return 0


if __name__ == "__main__":
    sys.exit(main())
