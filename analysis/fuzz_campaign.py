"""A seeded campaign of corrupted recordings through the tables evaluation (a script, not a test).

Every case rewrites one test recording of a tiny synthetic dataset with the
generators of the suite's ``tests/test_fuzz.py`` and runs it the way ``morpi tables`` does:
the commands' loader (:meth:`dataset.CatalogueEntry.load`, the parser and the
plausibility checks at rest), the recordings gate
(:func:`evaluate.dataset_problems`) and, when the file loads, the whole
evaluation (:func:`evaluate.evaluate_tables` and :func:`evaluate.check_cells`).

Even cases apply one plausible-but-wrong family (:data:`test_fuzz.FAMILIES`:
dead or stuck channel, accelerometer in g, gyro in deg/s, swapped columns
under a kept header, z-down frame) to one of :data:`test_fuzz.FAMILY_TARGETS`,
then 0 to 2 byte corruptions (:data:`test_fuzz.KINDS`); odd cases apply 1 to 3
byte corruptions to :data:`test_fuzz.TARGET`. A case passes when the gate names
a file the loader rejects (so it is never dropped silently), or, for a byte
corruption only, when every cell of an evaluation is finite and sane and the
file is among its cell's runs or named among its failed runs. A family case
that loads is a silent acceptance. Anything else, including any exception other
than the project's ``DataError``, is counted as a failure and printed.

Usage: ``python3 analysis/fuzz_campaign.py [--cases 1000] [--seed 7]``
(the suite runs the same checks on fewer cases in ``test_fuzz_through_the_tables``,
``test_each_plausible_but_wrong_family_is_refused_and_named`` and
``test_families_under_further_corruption_are_never_accepted``).
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

_ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(_ROOT / "tests"), str(_ROOT)]  # this checkout's package and fuzz generators
from test_fuzz import FAMILIES, FAMILY_TARGETS, TARGET, _ri, corrupt  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402
from morpi_filters import evaluate as ev  # noqa: E402
from morpi_filters import synthetic  # noqa: E402
from morpi_filters.errors import DataError  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    counts = {"rejected and named": 0, "byte corruptions refused at rest": 0, "loaded and evaluated": 0,
              "absurd cell": 0, "silent drop": 0, "silent acceptance": 0, "traceback": 0}
    per_family = {f.__name__: {"cases": 0, "refused by the parser": 0, "refused at rest": 0, "accepted": 0}
                  for f in FAMILIES}
    with tempfile.TemporaryDirectory() as tmp:
        base = synthetic.write_dataset(Path(tmp) / "base", seed=4, runs_per_folder=2)
        root = Path(tmp) / "ds"
        shutil.copytree(base, root)
        entries = {e.relpath: e for e in ds.catalogue(root)}
        clean = {rel: (base / rel).read_text() for rel in {TARGET, *FAMILY_TARGETS}}
        rng = np.random.default_rng(args.seed)
        for i in range(args.cases):
            family = FAMILIES[(i // 2) % len(FAMILIES)] if i % 2 == 0 else None
            rel = FAMILY_TARGETS[_ri(rng, 0, len(FAMILY_TARGETS))] if family else TARGET
            raw, names = corrupt(clean[rel], rng, n_ops=_ri(rng, 0, 3) if family else _ri(rng, 1, 4),
                                 family=family)
            target = root / rel
            target.write_bytes(raw)
            stats = per_family[family.__name__] if family else None
            try:
                try:
                    entries[rel].load()
                    loads = True
                except DataError:
                    loads = False
                if not loads:
                    problems = ev.dataset_problems(ev.FieldData(root))
                    if any(str(target) in p for p in problems):
                        counts["rejected and named"] += 1
                        try:
                            ds.load_csv(target)
                            at_rest = True
                        except DataError:
                            at_rest = False
                        if stats is not None:
                            stats["refused at rest" if at_rest else "refused by the parser"] += 1
                        elif at_rest:       # a byte corruption the parser takes, refused at rest: say which
                            counts["byte corruptions refused at rest"] += 1
                            print(f"case {i} {names}: refused at rest")
                    else:
                        counts["silent drop"] += 1
                        print(f"case {i} {rel} {names}: rejected by the loader but not named by the gate")
                    continue
                if stats is not None:
                    counts["silent acceptance"] += 1
                    stats["accepted"] += 1
                    print(f"case {i} {rel} {names}: loaded as if valid")
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
                if not any(any(rel in r.file for r in c.runs) or any(str(target) in f for f in c.failed)
                           for c in res.cells):
                    counts["silent drop"] += 1
                    print(f"case {i} {names}: loaded but neither used nor named")
                    continue
                counts["loaded and evaluated"] += 1
            except Exception:  # noqa: BLE001 - the campaign counts every unexpected exception
                counts["traceback"] += 1
                print(f"case {i} {rel} {names}:\n{traceback.format_exc()}")
            finally:
                if stats is not None:
                    stats["cases"] += 1
                target.write_text(clean[rel])
    print(f"{args.cases} cases (seed {args.seed}): " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    for name, s in per_family.items():
        print(f"  {name}: " + ", ".join(f"{k} {v}" for k, v in s.items()))
    bad = counts["absurd cell"] + counts["silent drop"] + counts["silent acceptance"] + counts["traceback"]
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
