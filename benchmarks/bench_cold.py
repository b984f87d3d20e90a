"""The first run after a fresh install against a warm run: what compiling the numba loops costs a user.

numba compiles each loop on its first call and keeps the machine code in a cache
on disk (``NUMBA_CACHE_DIR``). A fresh install has an empty cache, so its first
``morpi tables`` pays for compiling every loop the command reaches. Each pair runs
the same whole command (fresh processes, figures included, in alternation, the ratio
taken per pair: :func:`pairs.paired_commands`) twice: A with an empty cache folder
made for that run, B with a cache folder filled once before the pairs start. Both
sides do the same work; A adds only the compiling and the writing of the cache.

Rows: ``morpi tables``, ``morpi aided`` and ``morpi report`` (each ``--data DIR``).
Target (each): first run / warm run <= 2.

``--suite`` adds, for information, one cold and one warm run of the test suite as
the README runs it (``python -m pytest``), each with its own cache folder (the cold
one empty): minutes each, so a single pair.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_cold.py [--data DIR] [--pairs N] [--suite]``
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_aided import _root  # noqa: E402
from pairs import PairedRatio, paired, run_command  # noqa: E402

TARGET = 2.0
COMMANDS = ("tables", "aided", "report")


def _run(argv, env, cwd, cache: Path, fresh: bool) -> float:
    """Seconds of one run of `argv` with `cache` as numba's cache folder (emptied first when `fresh`)."""
    if fresh:
        shutil.rmtree(cache, ignore_errors=True)
    cache.mkdir(parents=True, exist_ok=True)
    return run_command(argv, env=dict(env, NUMBA_CACHE_DIR=str(cache)), cwd=cwd)


def measure(pairs: int = 3, quick: bool = False, data=None, suite: bool = False):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`)."""
    root = _root(data)
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(repo), MPLBACKEND="Agg")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in COMMANDS[:1] if quick else COMMANDS:
            out = tmp / f"out-{name}"
            argv = [sys.executable, "-m", "morpi_filters.cli", name, "--data", str(root), "--out", str(out)]
            warm = tmp / f"warm-{name}"
            _run(argv, env, tmp, warm, fresh=True)                      # fills the warm cache
            rows.append(paired(f"morpi {name} --data: first run (empty numba cache) / warm run",
                               lambda: _run(argv, env, tmp, tmp / "cold", fresh=True),
                               lambda: _run(argv, env, tmp, warm, fresh=False),
                               pairs=pairs, warmup=0, target=TARGET, self_timed=True))
        if suite:
            argv = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(repo / "tests")]
            senv = dict(env, MORPI_DATA=str(root))
            cold = _run(argv, senv, repo, tmp / "suite-cache", fresh=True)
            warm = _run(argv, senv, repo, tmp / "suite-cache", fresh=False)
            import numpy as np

            rows.append(PairedRatio("test suite (python -m pytest): cold numba cache / warm (one pair, for information)",
                                    np.array([cold]), np.array([warm])))
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", help="dataset root")
    p.add_argument("--pairs", type=int, default=3)
    p.add_argument("--suite", action="store_true", help="also one cold and one warm run of the test suite")
    args = p.parse_args(argv)
    for r in measure(args.pairs, data=args.data, suite=args.suite):
        print(r.line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
