"""A seeded campaign of corrupted recordings through the tables evaluation (a script, not a test).

Each case corrupts one test recording of a tiny synthetic dataset with the
generator of ``tests/test_fuzz.py`` (1 to 3 operations) and runs it the way
``morpi tables`` does: the recordings gate (:func:`evaluate.dataset_problems`)
and, when the file loads, the whole evaluation (:func:`evaluate.evaluate_tables`
and :func:`evaluate.check_cells`). A case passes when the gate names a file the
loader rejects (so it can never be dropped silently), or when every cell of an
evaluation is finite and sane and the corrupted file is among its cell's runs
or named among its failed runs. Anything else, including any exception other
than the project's ``DataError``, is counted as a failure and printed.

Usage: ``python3 tests/fuzz_tables_campaign.py [--cases 1000] [--seed 7]``
(the suite runs the same checks on 40 cases in ``test_fuzz_through_the_tables``).
"""
from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_fuzz import TARGET, corrupt  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402
from morpi_filters import evaluate as ev  # noqa: E402
from morpi_filters import synthetic  # noqa: E402
from morpi_filters.errors import DataError  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    counts = {"rejected and named": 0, "loaded and evaluated": 0, "absurd cell": 0, "silent drop": 0,
              "traceback": 0}
    with tempfile.TemporaryDirectory() as tmp:
        base = synthetic.write_dataset(Path(tmp) / "base", seed=4, runs_per_folder=2)
        root = Path(tmp) / "ds"
        shutil.copytree(base, root)
        target = root / TARGET
        text = (base / TARGET).read_text()
        rng = np.random.default_rng(args.seed)
        for i in range(args.cases):
            raw, names = corrupt(text, rng, n_ops=int(rng.integers(1, 4)))
            target.write_bytes(raw)
            try:
                try:
                    ds.load_csv(target)
                    loads = True
                except DataError:
                    loads = False
                if not loads:
                    problems = ev.dataset_problems(ev.FieldData(root))
                    if any(str(target) in p for p in problems):
                        counts["rejected and named"] += 1
                    else:
                        counts["silent drop"] += 1
                        print(f"case {i} {names}: rejected by the loader but not named by the gate")
                    continue
                res = ev.evaluate_tables(root, alternatives=False)
                try:
                    ev.check_cells(res)
                except DataError as exc:
                    counts["absurd cell"] += 1
                    print(f"case {i} {names}: {exc}")
                    continue
                if any(c.runs and not (math.isfinite(c.ours_percent) and abs(c.ours_percent) <= ev.CELL_SANITY_PERCENT)
                       for c in res.cells):
                    counts["absurd cell"] += 1
                    print(f"case {i} {names}: a cell beyond the sanity bound")
                    continue
                if not any(any(TARGET in r.file for r in c.runs) or any(str(target) in f for f in c.failed)
                           for c in res.cells):
                    counts["silent drop"] += 1
                    print(f"case {i} {names}: loaded but neither used nor named")
                    continue
                counts["loaded and evaluated"] += 1
            except Exception:  # noqa: BLE001 - the campaign counts every unexpected exception
                counts["traceback"] += 1
                print(f"case {i} {names}:\n{traceback.format_exc()}")
    print(f"{args.cases} cases (seed {args.seed}): " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0 if counts["absurd cell"] + counts["silent drop"] + counts["traceback"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
