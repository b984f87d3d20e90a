"""Time of the `morpi tables` computation as a ratio to parsing the 143 CSVs.

Both are measured in this one run, on the field dataset (``--data DIR`` or
``$MORPI_DATA``, else ``../shared/morpi-dataset``):

- parse: :func:`morpi_filters.dataset.load_csv` on every recording of the catalogue;
- tables: everything `morpi tables` computes, from the CSV files to result.json and
  the README text (:func:`evaluate.tables_study`: the evaluation, the report's alternatives
  and the figures' data; :func:`report.tables.result_json` and the page), without rendering
  the figures (reported separately);
- figures: the section's PNG figures, for information.

Target: tables / parse <= 5. Each timing is the best of ``--repeat`` runs, the two
interleaved so that a change of machine load affects both.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_tables.py [--data DIR] [--repeat N] [--profile]``
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from morpi_filters import dataset as ds
from morpi_filters import evaluate as ev
from morpi_filters.reporting import DataSource


def _root(arg):
    if arg:
        return Path(arg)
    if os.environ.get(ds.DATA_ENV):
        return Path(os.environ[ds.DATA_ENV])
    return Path(__file__).resolve().parents[1].parent / "shared" / "morpi-dataset"


def parse_all(root):
    return [ds.load_csv(e.path) for e in ds.catalogue(root)]


def tables(root):
    from morpi_filters.report import tables as page

    src = DataSource(root)
    study = ev.tables_study(root)
    payload = page.result_json(study, src)
    page._page(study, payload, src, [])
    return study, payload


def best_of(fn, repeat):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="dataset root")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--profile", action="store_true", help="print the top of a cProfile of the tables step")
    args = ap.parse_args(argv)
    root = _root(args.data)
    if not root.is_dir():
        print(f"no dataset at {root}; {ds.missing_data_message()}", file=sys.stderr)
        return 2
    # interleaved, so a change of machine load hits both timings alike; best of each
    t_parse = t_tab = float("inf")
    for _ in range(args.repeat):
        dt, recs = best_of(lambda: parse_all(root), 1)
        t_parse = min(t_parse, dt)
        dt, (res, _) = best_of(lambda: tables(root), 1)
        t_tab = min(t_tab, dt)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        from morpi_filters.report import tables as page

        page._figures(res, Path(tmp))
        t_fig = time.perf_counter() - t0
    print(f"recordings: {len(recs)}")
    print(f"parse all CSVs (dataset.load_csv): {t_parse:.3f} s")
    print(f"tables computation, no figures:    {t_tab:.3f} s")
    print(f"figures (for information):         {t_fig:.3f} s")
    print(f"ratio tables / parse: {t_tab / t_parse:.2f}x (target <= 5x)")
    if args.profile:
        import cProfile
        import pstats

        pr = cProfile.Profile()
        pr.enable()
        tables(root)
        pr.disable()
        pstats.Stats(pr).sort_stats("cumulative").print_stats(25)
    return 0


if __name__ == "__main__":
    sys.exit(main())
