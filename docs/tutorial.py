"""Tutorial: three studies in a few calls of the public API.

Run it from the project root (the field study needs the recordings)::

    python3 docs/tutorial.py --data ../shared/morpi-dataset

Each study is one function; its body uses only public names of the package,
and the test suite (``tests/test_tutorial.py``) runs each one and compares its
numbers with what the ``morpi`` command writes to its JSON.

1. A field run: load one recording by path, calibrate it, cut its MoRPI-G
   steps, train the Weinberg gain on the route's train recordings, and compare
   the dead-reckoned end point with the route's ground truth.
2. Closed form against the filter: the paper's closed-form RMS of the 3D and
   2D INS position error next to the error-state filter's horizontal 1 sigma
   for the same error parameters, and the MoRPI-aided filter beside them.
3. A Monte Carlo gain-error study of your own shape: a 20 s sine path, every
   method on that same path, the MoRPI distance law checked on the draws, and
   your own IMU from its datasheet.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


# %% 1. One field run, from the CSV file to its end-point error
def field_run(data_root, relpath="s8/short_distance/test/2.csv", method="MoRPI-G", calibration="GC"):
    from morpi_filters import dataset, field, steps

    rec, route = dataset.load_recording(Path(data_root) / relpath)     # labels and ground truth from the path
    data = field.FieldData(data_root)                                  # rest and motion windows, cached
    rule = field.select_config(data, method).config                    # the method's step rule: train runs only
    gain = field.trained_gain(data, rec.phone, rec.route, calibration, method, rule)
    track = steps.morpi_track(data.steps(rec, calibration, method, rule), gain.mean)
    error = track.error(route)                                         # end point against the ground truth [m]
    return {"end_error_m": error, "end_error_percent": 100 * error / route.distance_m,
            "steps": track.steps.n, "gain": gain.mean}


# %% 2. Closed-form RMS against the filter's 1 sigma
def closed_form_vs_filter(times=(0.0, 5.0, 10.0, 15.0)):
    from morpi_filters import curves, params

    p = params.load_params()                                           # the paper's error parameters, as 1 sigma
    case = curves.case_from_params(p)
    out = {}
    for method in curves.CURVE_METHODS:                                # "INS-3D", "INS-2D", "MoRPI-aided INS"
        out[method] = {"sigma_m": curves.horizontal_sigma(p, times, method),
                       "closed_form_rms_m": np.sqrt(curves.case_mean_square(case, times, method))}
    return out


# %% 3. A Monte Carlo study of your own shape
def shaped_monte_carlo(runs=300, seed=0, duration=20.0, spec=None):
    from morpi_filters import montecarlo as mc
    from morpi_filters import units

    gains = (mc.GainError("dG = 5 %", 0.05), mc.GainError("dG = 10 %", 0.10),
             mc.GainError("training spread", mc.ASSUMED_MISMATCH, mc.ASSUMED_SPREAD))
    cfg = mc.StudyConfig(spec=spec or units.MPU6500, duration_s=duration, calibration="GAC", gains=gains)
    result = mc.run_study(runs, seed, cfg)                             # INS and MoRPI on the same sine path
    return result, mc.final_statistics(result), mc.distance_law_check(result)   # ds = dG D on the draws


def own_imu():
    """Your own IMU, in the units its datasheet prints."""
    from morpi_filters import units

    return units.SensorSpec.from_datasheet("my IMU", gyro_bias_deg_s=0.5, gyro_noise_deg_s_sqrt_hz=0.01,
                                           accel_bias_mg=20.0, accel_noise_ug_sqrt_hz=150.0)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help="the MoRPI recordings (study 1)")
    args = ap.parse_args(argv)
    if args.data is not None:
        r = field_run(args.data)
        print(f"1. s8 short route, test run 2, MoRPI-G GC: {r['steps']} steps, gain {r['gain']:.4f}, "
              f"end error {r['end_error_m']:.3f} m ({r['end_error_percent']:.2f} %)")
    for method, v in closed_form_vs_filter().items():
        print(f"2. {method:16s} filter 1 sigma {np.round(v['sigma_m'], 3)} m, closed form {np.round(v['closed_form_rms_m'], 3)} m")
    result, stats, checks = shaped_monte_carlo(spec=own_imu())
    length, speed, duration = result.config.motion()
    print(f"3. {result.runs} runs, {length:.2f} m in {duration:g} s at {speed:.3f} m/s: "
          + ", ".join(f"{m} {s['mean']:.2f} m" for m, s in stats.items())
          + "; distance law " + ", ".join(f"{c['label']}: {'holds' if c['MoRPI-A']['within'] else 'FAILS'}"
                                           for c in checks))


if __name__ == "__main__":
    main()
