"""Cost per step of the error-state filter's covariance propagation, against a plain numpy loop.

In one process, sides in alternation, the ratio taken per pair (:func:`pairs.paired`);
every side propagates the same ``Phi``, ``Qd`` and ``P0`` (the paper's trajectory, an
MPU6500, 100 Hz) over the same number of steps:

- ``eskf.run_filter`` without measurements, 15 states and the 22-state MoRPI model
  (target <= 2x the floor, per step);
- floor: ``P = Phi @ P @ Phi.T + Qd`` in a Python loop with numpy, nothing else;
- for information: filterpy's ``KalmanFilter.predict(F=, Q=)`` in a loop, and
  ``eskf.propagate_covariance`` (closed form by batched doublings, every epoch kept)
  against the same floor; the MoRPI-aided filter batched over Monte Carlo runs
  against the same runs one by one through ``run_filter``.

Usage: ``PYTHONPATH=. python3 benchmarks/bench_eskf.py [--pairs N] [--steps N]``
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from filterpy.kalman import KalmanFilter  # noqa: E402
from pairs import paired  # noqa: E402

from morpi_filters import units  # noqa: E402
from morpi_filters.error_model import (  # noqa: E402
    discretize, noise_coupling, noise_density, paper_trajectory, system_matrix,
)
from morpi_filters.eskf import (  # noqa: E402
    Measurement, StepModel, augment, augment_covariance, initial_covariance, propagate_covariance, run_filter,
    step_update,
)

TARGET = 2.0


def numpy_loop(Phi, Qd, P0, n):
    """The floor: the covariance recursion and nothing else."""
    P = P0.copy()
    for _ in range(n):
        P = Phi @ P @ Phi.T + Qd
    return P


def filterpy_loop(Phi, Qd, P0, n):
    kf = KalmanFilter(dim_x=Phi.shape[0], dim_z=1)
    kf.x, kf.P = np.zeros(Phi.shape[0]), P0.copy()
    for _ in range(n):
        kf.predict(F=Phi, Q=Qd)
    return kf.P


def models(dt=0.01):
    C, f = paper_trajectory(9.81)
    Phi, Qd = discretize(system_matrix(C, f), noise_coupling(C), noise_density(units.MPU6500), dt)
    P0 = initial_covariance(0.05, 0.3, 0.01, dp0=0.01, eps0=1e-3)
    model = StepModel()
    return {"15 states": (Phi, Qd, P0), "22 states": (*augment(Phi, Qd, model), augment_covariance(P0, model))}


def measure(pairs: int = 7, steps: int = 6000, quick: bool = False):
    """The paired ratios of this benchmark (list of :class:`pairs.PairedRatio`)."""
    t = np.arange(steps + 1) * 0.01
    rows = []
    for label, (F, Q, P0) in models().items():
        # the same final covariance on both sides (a check that they do the same work)
        a, b = run_filter(F, Q, P0, t).P_end, numpy_loop(F, Q, P0, steps)
        assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max(), "run_filter and the numpy loop disagree"
        rows.append(paired(f"run_filter, {label}, {steps} steps / numpy loop P = Phi P Phi^T + Q",
                           lambda: run_filter(F, Q, P0, t), lambda: numpy_loop(F, Q, P0, steps),
                           pairs=pairs, target=TARGET))
        if quick:
            continue
        rows.append(paired(f"filterpy predict() loop, {label} / numpy loop (for information)",
                           lambda: filterpy_loop(F, Q, P0, steps), lambda: numpy_loop(F, Q, P0, steps), pairs=pairs))
        rows.append(paired(f"propagate_covariance (every epoch), {label} / numpy loop (for information)",
                           lambda: propagate_covariance(F, Q, P0, steps), lambda: numpy_loop(F, Q, P0, steps),
                           pairs=pairs))
    if not quick:
        Fa, Qa, P0a = models()["22 states"]
        n, runs = 1500, 40
        ta = np.arange(n + 1) * 0.01
        rng = np.random.default_rng(1)
        model = StepModel()
        meas = [step_update(i, 1.0, 0.0, model, 1.0, z=rng.normal(size=(runs, 2))) for i in range(100, n + 1, 100)]
        one = [[Measurement(m.index, m.z[j], m.H, m.R, m.reset) for m in meas] for j in range(runs)]
        rows.append(paired(f"MoRPI-aided filter, {runs} runs one by one / batched over runs (for information)",
                           lambda: [run_filter(Fa, Qa, P0a, ta, mj) for mj in one],
                           lambda: run_filter(Fa, Qa, P0a, ta, meas), pairs=max(3, pairs // 2)))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--quick", action="store_true", help="the target lines only")
    args = ap.parse_args(argv)
    for r in measure(args.pairs, args.steps, args.quick):
        print(r.line(), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
