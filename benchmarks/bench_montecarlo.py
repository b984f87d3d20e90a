"""Cost of ``morpi montecarlo`` against drawing its random numbers, both as whole processes.

A: the command a user runs, ``morpi montecarlo --runs N`` (every study of the
page, the gain training, the JSON, the page and the figures), in a fresh
interpreter. B, the floor: a fresh interpreter that imports numpy and draws
exactly the random numbers the command draws: one Generator per run from
``SeedSequence(seed, spawn_key=(i,))`` with its 7 + 6 n standard normals, in
the command's chunks, plus the gain-training numbers of the reference gains
(one Generator, ``training_runs x 2 x n`` normals). The two run in
alternation and the ratio A / B is taken per pair (``benchmarks/pairs.py``).

A second, in-process line compares :func:`montecarlo.run_studies` (every study
of the page in one pass, no files) with the same draws in the same process.

A third line runs the same command on a Dask ``LocalCluster`` of 2 worker
processes (1 thread each, started once by this script and kept for every
pair; ``--scheduler ADDRESS``) against the command run locally (its default:
one thread), both with ``--dask-runs`` runs; the two result.json digests must
be equal (``--dask-runs 0`` leaves the line out). Target: no slower than local (<= 1x).

Every command here runs without a dataset (``MORPI_DATA`` is removed from its
environment): the page's default studies, with the assumed gain spread. With a
dataset the command also trains the gains on the field recordings, which is the
tables' work (:mod:`bench_tables`), not a cost of the Monte Carlo.

Target: whole command / draws <= 4x.

Usage: ``python3 benchmarks/bench_montecarlo.py [--runs N] [--pairs P] [--dask-runs N] [--dask-pairs P]``
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pairs import paired, paired_commands, python_command  # noqa: E402

from morpi_filters import montecarlo as mc  # noqa: E402
from morpi_filters.montecarlo import config as mcc, engine as mce  # noqa: E402

TARGET = 4.0

DRAWS = """
import numpy as np
runs, seed, n, chunk, head, training, training_key = {runs}, {seed}, {n}, {chunk}, {head}, {training}, {tkey}
total = 0.0
for a in range(0, runs, chunk):
    b = min(a + chunk, runs)
    z = np.empty((b - a, head + 6 * n))
    for r in range(a, b):
        np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(r,)))).standard_normal(out=z[r - a])
    total += float(z[:, -1].sum())
rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(training_key,))))
for a in range(0, training, 500):
    total += float(rng.standard_normal((min(500, training - a), 2, n))[:, 0, -1].sum())
print(total)
"""


def page_configs():
    """The studies ``morpi montecarlo`` runs without a dataset (assumed gain spread)."""
    gains = (mc.GainError("dG = 5 %", 0.05), mc.GainError("dG = 10 %", 0.10),
             mc.GainError("training spread", mc.ASSUMED_MISMATCH, mc.ASSUMED_SPREAD))
    cal = mc.StudyConfig(gains=gains, calibration="GAC")
    return (cal, replace(cal, calibration="RD"),
            *mc.training_configs(mc.TRAINING_KS, mismatch=mc.ASSUMED_MISMATCH, spread=mc.ASSUMED_SPREAD, config=cal))


def dask_vs_local(runs: int = 100_000, pairs: int = 3, seed: int = 0, env=None):
    """``morpi montecarlo`` on a 2-worker Dask LocalCluster / the same command locally (a :class:`pairs.PairedRatio`).

    Raises RuntimeError when the two digests differ.
    """
    import json

    from distributed import LocalCluster

    root = str(Path(__file__).resolve().parents[1])
    if root not in sys.path:
        # the workers are spawned with this process's sys.path: they must import this checkout
        sys.path.insert(0, root)
    with tempfile.TemporaryDirectory() as tmp, LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                                             dashboard_address=None) as cluster:
        base = [sys.executable, "-m", "morpi_filters.cli", "montecarlo", "--runs", str(runs), "--seed", str(seed)]
        far, near = Path(tmp) / "dask", Path(tmp) / "local"
        ratio = paired_commands(f"morpi montecarlo --runs {runs}: Dask LocalCluster, 2 workers / local "
                                "(whole commands)",
                                base + ["--out", str(far), "--scheduler", cluster.scheduler_address],
                                base + ["--out", str(near)], pairs=pairs, target=1.0, env=env, cwd=tmp)
        digests = [json.loads((d / "result.json").read_text())["digest"] for d in (far, near)]
    if digests[0] != digests[1]:
        raise RuntimeError(f"Dask and local digests differ: {digests}")
    return ratio


def measure(pairs: int = 5, quick: bool = False, runs: int = 10_000, seed: int = 0, dask_runs: int = 100_000,
            dask_pairs: int = 3):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`); `quick`: at most 2000 runs, no Dask."""
    if quick:
        runs = min(runs, 2000)
    cfg = mc.StudyConfig()
    _, _, duration = cfg.motion()
    n = mce.sample_count(duration, cfg.rate_hz)  # samples of a run, as the study draws them
    chunk = min(mce.default_chunk(n), runs)
    code = DRAWS.format(runs=runs, seed=seed, n=n, chunk=chunk, head=mcc.N_HEAD,
                        training=cfg.training_runs, tkey=mc.TRAINING_KEY)
    env_root = str(Path(__file__).resolve().parents[1])
    import os

    env = dict(os.environ, PYTHONPATH=env_root + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg")
    # the default studies: without a dataset the command takes the assumed gain spread; with one it would
    # also evaluate the field gains (the tables' work, which the draws floor does not do)
    env.pop("MORPI_DATA", None)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "morpi_filters.cli", "montecarlo", "--runs", str(runs),
               "--seed", str(seed), "--out", str(Path(tmp) / "mc")]
        whole = paired_commands(f"morpi montecarlo --runs {runs} / its random draws (whole processes)",
                                cmd, python_command(code), pairs=pairs, target=TARGET, env=env, cwd=tmp)
    if quick:
        return [whole]

    def draws():
        for a in range(0, runs, chunk):
            mce._draw(seed, a, min(a + chunk, runs), n)

    cfgs = page_configs()
    mc.reference_gains(cfgs[0], seed)    # the training is cached per process: not part of either side here
    curves = (True,) + (False,) * (len(cfgs) - 1)           # as the page runs them
    inproc = paired(f"run_studies (the page's {len(cfgs)} studies, one pass) / per-run draws (in process)",
                    lambda: mc.run_studies(runs, seed, cfgs, progress=False, curves=curves), draws, pairs=pairs)
    out = [whole, inproc]
    if dask_runs <= 0:
        return out
    try:
        import distributed  # noqa: F401
    except ImportError:
        return out, "Dask line left out: dask[distributed] is not installed"
    out.append(dask_vs_local(dask_runs, dask_pairs, seed, env))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--dask-runs", type=int, default=100_000)
    ap.add_argument("--dask-pairs", type=int, default=3)
    args = ap.parse_args(argv)
    out = measure(args.pairs, runs=args.runs, seed=args.seed, dask_runs=args.dask_runs, dask_pairs=args.dask_pairs)
    if isinstance(out, tuple):
        out, note = out
        print(note)
    for r in out:
        print(r.line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
