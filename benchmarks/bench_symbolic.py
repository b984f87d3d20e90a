"""Cold cost of the symbolic derivation against ``import sympy`` alone.

Each measurement runs in a fresh interpreter (nothing cached): one process
times ``import sympy``; the other times ``import sympy`` + importing
``morpi_filters.symbolic`` + deriving dp, e_3D^2, e_2D^2 + ``lambdify(cse=True)``
of the numeric functions the assessment uses + one evaluation. The two kinds
alternate; medians are printed with their ratio, measured in this one run.

Run from the project root: ``PYTHONPATH=. python3 benchmarks/bench_symbolic.py [repeats]``.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

IMPORT_ONLY = """
import time
t0 = time.perf_counter()
import sympy
print(time.perf_counter() - t0)
"""

COLD_DERIVATION = """
import time
t0 = time.perf_counter()
import sympy
from morpi_filters import symbolic as S
for kind in ("3d", "2d", "dp"):
    fn = S.lambdified(kind, "z_up", False)
fn = S.lambdified("3d", "z_up", False)
fn(5.0, 0.1, 0.1, 0.0, 0.01, 0.01, 0.0, 1e-3, 1e-3, 0.0, 9.81)
print(time.perf_counter() - t0)
"""


def run(code: str) -> float:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env, cwd=ROOT)
    return float(out.stdout.strip().splitlines()[-1])


def main(repeats: int = 7) -> None:
    run(IMPORT_ONLY)  # warm the OS file cache once, as any second run of the tool would see it
    imp, cold = [], []
    for _ in range(repeats):
        imp.append(run(IMPORT_ONLY))
        cold.append(run(COLD_DERIVATION))
    mi, mc = statistics.median(imp), statistics.median(cold)
    print(f"import sympy alone          : median {mi * 1e3:7.1f} ms over {repeats} fresh processes")
    print(f"import sympy + derive + lambdify: median {mc * 1e3:7.1f} ms over {repeats} fresh processes")
    print(f"derivation on top of the import : {(mc - mi) * 1e3:7.1f} ms")
    print(f"ratio cold derivation / import  : {mc / mi:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
