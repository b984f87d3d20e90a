"""Peak memory and time of a one-hour, 100 Hz covariance propagation (360,000 steps).

Runs one of three cases, chosen by the first argument, and prints its wall
time and the process's peak resident memory (``ru_maxrss``):

  ``unaided``    ``eskf.run_filter`` on the 15-state model, P kept every minute;
  ``aided``      the same with the 22-state MoRPI model and one step update per second;
  ``closed``     ``eskf.propagate_covariance`` with a one-minute stride.

Run each case in its own process so the peak belongs to it, e.g.
``PYTHONPATH=. /usr/bin/time -v python3 benchmarks/long_covariance.py aided``.
"""
from __future__ import annotations

import resource
import sys
import time

import numpy as np

from morpi_filters import units
from morpi_filters.error_model import discretize, noise_coupling, noise_density, paper_trajectory, system_matrix
from morpi_filters.eskf import (
    StepModel, augment, augment_covariance, initial_covariance, propagate_covariance, run_filter, step_update,
)


def main(case: str) -> None:
    dt, n, every_minute = 0.01, 360_000, 6000
    C, f = paper_trajectory(9.81)
    Phi, Qd = discretize(system_matrix(C, f), noise_coupling(C), noise_density(units.MPU6500), dt)
    P0 = initial_covariance([0.05] * 3, [0.3] * 3, [0.01] * 3, dp0=0.01, eps0=1e-3)
    t = np.arange(n + 1) * dt
    t0 = time.perf_counter()
    if case == "unaided":
        r = run_filter(Phi, Qd, P0, t, keep_P=every_minute)
        kept = r.P
    elif case == "aided":
        model = StepModel()
        Pa, Qa = augment(Phi, Qd, model)
        meas = [step_update(i, 1.0, 0.0, model, 1.0) for i in range(100, n + 1, 100)]
        r = run_filter(Pa, Qa, augment_covariance(P0, model), t, meas, keep_P=every_minute)
        kept = r.P
    elif case == "closed":
        kept = propagate_covariance(Phi, Qd, P0, n, stride=every_minute)
    else:
        raise SystemExit(f"unknown case {case!r}: expected unaided, aided or closed")
    wall = time.perf_counter() - t0
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    sym = all(np.array_equal(P, P.T) for P in kept)
    print(f"{case}: {n} steps in {wall:.1f} s, {len(kept)} covariances kept, all symmetric: {sym}, "
          f"peak resident memory {peak_mb:.0f} MB")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "unaided")
