"""Covariance curves of 3D INS, 2D INS and MoRPI-aided INS, side by side with the closed form.

Edit the parameters below and run from the project root:

    python3 analysis/covariance_curves.py

It prints the horizontal 1 sigma of the error-state filter, the closed-form RMS and
the Monte Carlo RMS at the chosen times, and writes one figure per case (the
parameter file and the paper's two IMUs) into ``reports/analysis/covariance_curves/``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from morpi_filters import units
from morpi_filters.report import plots
from morpi_filters.report.common import save_figure
from morpi_filters.curves import PAPER_IMU_TITLES, case_from_params, case_from_sensor, compute_curves
from morpi_filters.params import load_params

# ----------------------------------------------------------------------------- parameters
PARAMS_FILE = None            # None: data/assessment_params.json (values read as 1 sigma)
TIMES = [1.0, 5.0, 10.0, 14.0, 15.0]  # evaluation times [s]
MC_RUNS = 1000                # Monte Carlo runs of the linear model per case
SEED = 7
OUT = Path("reports") / "analysis" / "covariance_curves"


def main():
    params = load_params(PARAMS_FILE)
    cases = [case_from_params(params)] + [case_from_sensor(s, params, PAPER_IMU_TITLES[s.name])
                                          for s in (units.MPU6500, units.LSM6DSL)]
    rng = np.random.default_rng(SEED)
    for case, sub in zip(cases, rng.spawn(len(cases))):
        cc = compute_curves(case, times=TIMES, runs=MC_RUNS, rng=sub)
        v = cc.at_eval_times()
        print(f"\n{case.title}  (process noise {'on' if case.noise else 'off'})")
        print("  t [s]   3D sigma / closed / MC       2D sigma / closed / MC       MoRPI-aided sigma / MC")
        for i, t in enumerate(cc.eval_times):
            print(f"  {t:5.1f}  " + "  ".join(
                f"{v['sigma_m'][k][i]:9.3f} {v['rms_closed_form_m'][k][i]:9.3f} {v['mc_rms_m'][k][i]:9.3f}"
                for k in ("INS-3D", "INS-2D")) + f"  {v['sigma_m']['MoRPI-aided INS'][i]:9.3f} "
                f"{v['mc_rms_m']['MoRPI-aided INS'][i]:9.3f}")
        path = save_figure(plots.plot_curves(cc), OUT / f"curves_{case.name}.png")
        print(f"  figure: {path}")


if __name__ == "__main__":
    main()
