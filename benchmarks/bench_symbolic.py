"""Cold cost of deriving Phi(t) and the position-error polynomials, against ``import sympy``.

Every measurement is a fresh interpreter (nothing cached, no earlier import), and
each child times itself from its first statement, so the interpreter's start-up,
the same on both sides, counts on neither. The sides run in alternation and the
ratio is taken per pair (:func:`pairs.paired_reported`):

- cold derivation (target <= 1.5x): ``import sympy``, ``import morpi_filters.symbolic``,
  the transition matrix ``Phi(t, t0)`` of the 15-state model with generic symbols
  ``C_ij``, ``f_i`` (:func:`symbolic.phi_exponential`), the position error
  ``dp(t)`` of the 3D and 2D INS with and without the ``b_gz`` terms and the squared
  distance errors ``e_3D^2``, ``e_2D^2`` (:func:`symbolic.position_error` and
  :func:`symbolic.distance_error_squared`, taken from Phi applied to the initial error);
- floor: ``import sympy`` alone;
- for information: the same with Phi from the paper's block integrals
  (:func:`symbolic.phi_block_form`) in place of the series, and the numeric bridge
  the assessment uses on top of the cold derivation (``lambdify(cse=True)`` of the
  3D, 2D and dp functions and one evaluation, numpy loaded).

Usage: ``PYTHONPATH=. python3 benchmarks/bench_symbolic.py [--pairs N]``
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pairs import paired_reported, python_command  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1.5

IMPORT_ONLY = """
import time
t0 = time.perf_counter()
import sympy
print(time.perf_counter() - t0)
"""

DERIVE = """
import time
t0 = time.perf_counter()
import sympy
from morpi_filters import symbolic as S
Phi = S.{phi}("z_up")
assert Phi.shape == (15, 15)
for ins in ("INS-3D", "INS-2D"):
    for keep_bgz in (False, True):
        S.position_error("z_up", ins, keep_bgz)
    S.distance_error_squared("z_up", ins, False)
{extra}
print(time.perf_counter() - t0)
"""

NUMERIC = """
for kind in ("INS-3D", "INS-2D", "INS-3D position"):
    fn = S.lambdified(kind, "z_up", False)
fn(5.0, 0.1, 0.1, 0.0, 0.01, 0.01, 0.0, 1e-3, 1e-3, 0.0, 9.81)
"""


def measure(pairs: int = 5, quick: bool = False):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    floor = python_command(IMPORT_ONLY)
    run = lambda name, code, target=None, n=pairs: paired_reported(  # noqa: E731
        name, python_command(code), floor, pairs=n, target=target, env=env, cwd=ROOT)
    rows = [run("cold Phi (series) + dp, e^2 polynomials / import sympy (fresh processes)",
                DERIVE.format(phi="phi_exponential", extra=""), TARGET)]
    if not quick:
        rows.append(run("cold Phi (block integrals) + dp, e^2 / import sympy (for information)",
                        DERIVE.format(phi="phi_block_form", extra=""), n=max(3, pairs // 2)))
        rows.append(run("cold Phi (series) + dp, e^2 + lambdify, one evaluation / import sympy (for information)",
                        DERIVE.format(phi="phi_exponential", extra=NUMERIC), n=max(3, pairs // 2)))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="the target line only")
    args = ap.parse_args(argv)
    for r in measure(args.pairs, args.quick):
        print(r.line(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
