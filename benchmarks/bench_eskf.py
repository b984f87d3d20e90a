"""Cost of the error-state filter's covariance propagation and of a 15 s curve.

Prints, measured in this run (best of several repeats):
  * per-step cost of filterpy's own ``KalmanFilter.predict(F=, Q=)`` on the 15- and
    22-state matrices, and of ``eskf.run_filter`` (the same predict plus bookkeeping)
    and ``eskf.propagate_covariance`` (batched over epochs) as ratios to it;
  * the cost of one 15 s curve (``curves.compute_curves``) without and with the
    Monte Carlo, and of the Monte Carlo of the MoRPI-aided filter batched over runs
    against the same runs done one by one through filterpy;
  * the cost of the closed-loop MoRPI-aided INS on one simulated recording.

Run: ``PYTHONPATH=. python3 benchmarks/bench_eskf.py``
"""
from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import KalmanFilter

from morpi_filters import units
from morpi_filters.curves import case_from_sensor, compute_curves
from morpi_filters.error_model import discretize, noise_coupling, noise_density, paper_trajectory, system_matrix
from morpi_filters.eskf import (
    Measurement, StepModel, augment, augment_covariance, initial_covariance, propagate_covariance, run_filter,
    step_update,
)
from morpi_filters.params import params_from_dict


def best(fn, repeat=5):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def filterpy_loop(Phi, Qd, P0, n):
    kf = KalmanFilter(dim_x=Phi.shape[0], dim_z=1)
    kf.x, kf.P = np.zeros(Phi.shape[0]), P0.copy()
    for _ in range(n):
        kf.predict(F=Phi, Q=Qd)
    return kf.P


def main():
    n, dt = 1500, 0.01
    C, f = paper_trajectory(9.81)
    Phi, Qd = discretize(system_matrix(C, f), noise_coupling(C), noise_density(units.MPU6500), dt)
    P0 = initial_covariance(0.05, 0.3, 0.01, dp0=0.01, eps0=1e-3)
    t = np.arange(n + 1) * dt
    print(f"covariance propagation, {n} steps, cost per step and ratio to filterpy predict()")
    aug = (*augment(Phi, Qd, StepModel()), augment_covariance(P0, StepModel()))
    for label, (F_, Q_, P_) in {"15 states": (Phi, Qd, P0), "22 states": aug}.items():
        ref = best(lambda: filterpy_loop(F_, Q_, P_, n))
        ours = best(lambda: run_filter(F_, Q_, P_, t))
        batched = best(lambda: propagate_covariance(F_, Q_, P_, n))
        print(f"  {label}: filterpy predict {1e6 * ref / n:7.2f} us/step | run_filter {1e6 * ours / n:7.2f} us/step "
              f"(x{ours / ref:.2f}) | propagate_covariance {1e6 * batched / n:7.2f} us/step (x{batched / ref:.3f})")
        Pa, Pb = filterpy_loop(F_, Q_, P_, n), propagate_covariance(F_, Q_, P_, n)[-1]
        print(f"     max relative difference of the final P: {np.abs(Pa - Pb).max() / np.abs(Pa).max():.1e}")

    params = params_from_dict({"dv0_mps": [0.05] * 3, "ba_mps2": [0.1] * 3, "bg_radps": [0.01] * 3, "g_mps2": 9.81,
                               "process_noise": True})
    case = case_from_sensor(units.LSM6DSL, params)
    c0 = best(lambda: compute_curves(case, runs=0), repeat=3)
    c1 = best(lambda: compute_curves(case, runs=1000), repeat=2)
    print(f"one 15 s curve (3 methods, 100 Hz): {1e3 * c0:.0f} ms without Monte Carlo, "
          f"{1e3 * c1:.0f} ms with 1000 Monte Carlo runs")

    # MoRPI-aided filter over runs: batched vs run by run through filterpy
    model = StepModel()
    Pa_, Qa_ = augment(Phi, Qd, model)
    P0a = augment_covariance(P0, model)
    runs = 200
    rng = np.random.default_rng(1)
    meas = [step_update(i, 1.0, 0.0, model, 1.0, z=rng.normal(size=(runs, 2))) for i in range(100, n + 1, 100)]
    tb = best(lambda: run_filter(Pa_, Qa_, P0a, t, meas), repeat=3)
    one = [[Measurement(m.index, m.z[j], m.H, m.R, m.reset) for m in meas] for j in range(runs)]
    ts = best(lambda: [run_filter(Pa_, Qa_, P0a, t, mj) for mj in one[:20]], repeat=1) * runs / 20
    print(f"MoRPI-aided filter, {runs} runs x {n} steps: batched {1e3 * tb:.0f} ms, run by run {1e3 * ts:.0f} ms "
          f"(x{ts / tb:.0f})")


if __name__ == "__main__":
    main()
