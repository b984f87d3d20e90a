"""Cost of ``morpi simulate`` against its floor: drawing its random numbers and writing its CSV rows.

Both sides are fresh processes, run in alternation, the ratio taken per pair
(:func:`pairs.paired_commands`):

- A: ``morpi simulate --out DIR`` (every recording of the field layout: trajectories,
  IMU synthesis, the CSV files, their checksums and the manifest);
- B, the floor: a fresh interpreter that imports numpy, creates the same Generators
  (the same seeds) and makes the same calls with the same shapes, so it draws exactly
  the random numbers the command draws, then writes, for every file of the command,
  a CSV with the same header, the same number of rows and columns and the same
  ``%.17g`` format, filled with those draws, by one formatting of the whole table per
  file (numpy's ``savetxt`` formats row by row and is slower).

The draw plan is recorded once, untimed, by running the command's generator in this
process with Generators that log every call; replaying it is checked to leave every
Generator in the same state as the command left it (the same stream consumed).
No target: the ratio says what the synthesis costs above drawing and writing.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_simulate.py [--pairs N] [--runs-per-folder N]``
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from pairs import paired_commands, python_command  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

FLOOR = r"""
import json, sys
from pathlib import Path
import numpy as np
plan = json.loads(Path(sys.argv[1]).read_text())
out = Path(sys.argv[2])
G = np.random.Generator
streams = {}
for s in plan["streams"]:
    rng = G(np.random.PCG64(np.random.SeedSequence(entropy=s["entropy"], spawn_key=tuple(s["spawn_key"]))))
    draws = [getattr(rng, name)(size=tuple(shape)) for name, shape in s["calls"]]
    streams[s["id"]] = np.concatenate([np.ravel(d) for d in draws])
row = ",".join(["%.17g"] * 7) + "\n"
for f in plan["files"]:
    pool = np.concatenate([streams[i] for i in f["streams"]])
    table = np.resize(pool, (f["rows"], 7))
    p = out / f["path"]
    p.parent.mkdir(parents=True, exist_ok=True)
    with open(p, "w") as fh:
        fh.write(plan["header"])
        fh.write((row * f["rows"]) % tuple(table.ravel().tolist()))
"""


def record_plan(seed: int, runs_per_folder, tmp: Path) -> dict:
    """Run the command's generator once with logging Generators; return the draw plan."""
    from morpi_filters import dataset, synthetic

    streams, current = [], []

    class Logging(np.random.Generator):
        """A Generator that logs the name and output shape of every draw."""

        def _log(self, name, out):
            self.calls.append((name, list(np.shape(out))))
            return out

        def random(self, *a, **k):
            return self._log("random", super().random(*a, **k))

        def uniform(self, *a, **k):
            return self._log("uniform", super().uniform(*a, **k))

        def normal(self, *a, **k):
            return self._log("normal", super().normal(*a, **k))

        def standard_normal(self, *a, **k):
            return self._log("standard_normal", super().standard_normal(*a, **k))

    real = np.random.default_rng

    def logging_rng(seed_seq):
        g = Logging(np.random.PCG64(seed_seq))
        g.calls, g.seed_seq = [], seed_seq
        g.sid = len(streams)
        streams.append(g)
        current.append(g.sid)
        return g

    files = []
    real_write = dataset.write_csv

    def write_csv(path, rec):
        real_write(path, rec)
        rel = Path(path).relative_to(stage_of(Path(path))).as_posix()
        files.append({"path": rel, "rows": int(rec.time.size), "streams": list(current),
                      "bytes": Path(path).stat().st_size})
        current.clear()

    def stage_of(p: Path) -> Path:
        while not (p / "s8").is_dir() and not (p / "s6").is_dir():
            p = p.parent
        return p

    np.random.default_rng = logging_rng
    synthetic.dataset.write_csv = write_csv
    try:
        synthetic.write_dataset(tmp / "recorded", seed=seed, runs_per_folder=runs_per_folder)
    finally:
        np.random.default_rng = real
        synthetic.dataset.write_csv = real_write
    plan = {"header": ",".join(dataset.COLUMNS) + "\n", "files": files, "streams": []}
    for g in streams:
        for name, _ in g.calls:
            if name not in ("random", "uniform", "normal", "standard_normal"):
                raise RuntimeError(f"unlogged draw {name}")
        plan["streams"].append({"id": g.sid, "entropy": int(g.seed_seq.entropy),
                                "spawn_key": [int(k) for k in g.seed_seq.spawn_key], "calls": g.calls})
        # the replay consumes exactly the command's stream
        r = np.random.Generator(np.random.PCG64(np.random.SeedSequence(entropy=g.seed_seq.entropy,
                                                                       spawn_key=g.seed_seq.spawn_key)))
        for name, shape in g.calls:
            getattr(r, name)(size=tuple(shape))
        if r.bit_generator.state != g.bit_generator.state:
            raise RuntimeError(f"replay of stream {g.sid} does not consume the command's random numbers")
    return plan


def measure(pairs: int = 5, quick: bool = False, runs_per_folder=None, seed: int = 0):
    """The paired ratio of this benchmark (list of one :class:`pairs.PairedRatio`)."""
    if quick and runs_per_folder is None:
        runs_per_folder = 2
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        plan = record_plan(seed, runs_per_folder, tmp)
        (tmp / "plan.json").write_text(json.dumps(plan))
        cmd = [sys.executable, "-m", "morpi_filters.cli", "simulate", "--out", str(tmp / "sim"), "--seed", str(seed)]
        if runs_per_folder:
            cmd += ["--runs-per-folder", str(runs_per_folder)]
        floor = python_command(FLOOR) + [str(tmp / "plan.json"), str(tmp / "floor")]
        n_files = len(plan["files"])
        r = paired_commands(f"morpi simulate ({n_files} files) / same draws + numpy CSV write (fresh processes)",
                            cmd, floor, pairs=pairs, env=env)
        cmd_bytes = sum(f["bytes"] for f in plan["files"])
        floor_bytes = sum(p.stat().st_size for p in (tmp / "floor").rglob("*.csv"))
        rows = sum(f["rows"] for f in plan["files"])
        draws = sum(int(np.prod(s)) if s else 1 for st in plan["streams"] for _, s in st["calls"])
    note = (f"{rows} rows, {draws} random numbers; CSV bytes: command {cmd_bytes / 1e6:.1f} MB, "
            f"floor {floor_bytes / 1e6:.1f} MB")
    return [r], note


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--runs-per-folder", type=int, default=None)
    ap.add_argument("--quick", action="store_true", help="two runs per folder")
    args = ap.parse_args(argv)
    rows, note = measure(args.pairs, args.quick, args.runs_per_folder)
    for r in rows:
        print(r.line())
    print(note)
    return 0


if __name__ == "__main__":
    sys.exit(main())
