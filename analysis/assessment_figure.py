"""Regenerate the analytical-assessment figure (3D & 2D INS vs MoRPI-A) from the library.

Usage (from the project root)::

    PYTHONPATH=. python3 analysis/assessment_figure.py [--params FILE] [--out FILE.png] [--convention z_up]

The INS curves come from the symbolic derivation (b_gz terms dropped, as in the
paper); the MoRPI-A lines are dG * v * t for the gain errors of the parameter file.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from morpi_filters.report import plots
from morpi_filters.report.common import save_figure
from morpi_filters.assessment import CONVENTION, DEFAULT_TIMES, assessment_curves, improvements
from morpi_filters.params import load_params


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", type=Path, default=None, help="parameter file (default data/assessment_params.json)")
    ap.add_argument("--out", type=Path, default=Path("reports/assessment/assessment.png"))
    ap.add_argument("--convention", default=CONVENTION, help="sign convention, e.g. z_up or z_down")
    args = ap.parse_args(argv)
    params = load_params(args.params)
    curves = assessment_curves(params, DEFAULT_TIMES, args.convention)
    save_figure(plots.assessment_figure(curves), args.out)
    print(f"figure: {args.out}")
    print("improvements [m]:", " ".join(f"{v:.2f}" for v in improvements(params, args.convention)))


if __name__ == "__main__":
    main()
