"""Batched, seeded Monte Carlo studies: gain error and closed-form drift.

Two studies live here.

Gain-error study (:func:`run_study`, :func:`gain_error_page`)
    For each of N runs: draw the IMU's turn-on biases and white noise from a
    :class:`~morpi_filters.units.SensorSpec` and one standard-normal number
    for the Weinberg gain error, then navigate one sine path (its duration,
    length or speed set by :class:`StudyConfig`) with INS-3D, INS-2D, MoRPI-A
    (Weinberg on ``f_y``) and MoRPI-G (Weinberg on ``omega_z``; MoRPI heading
    from the integrated gyro z), and record the horizontal position error over
    time. (``StudyConfig(ins_path="straight")`` puts the INS on the paper's
    straight baseline of the same length and speed instead.) The reference
    gains are trained on noisy runs of the same path and sensor (so the sensor
    noise's inflation of ``max - min`` is part of the gain, as in practice);
    each gain scenario multiplies them by ``1 + dG`` with
    ``dG = mean + std * z``. All scenarios share the run's draws (common
    random numbers). Results are labelled by the package's method names
    (:data:`METHODS`) and the scenarios' labels: :meth:`StudyResult.final_error`,
    :meth:`StudyResult.distance_error_of`, :meth:`StudyResult.curve`, and
    :func:`distance_law_check` tests the MoRPI distance law ``ds = dG D``.

Drift study (:func:`drift_map`, :func:`drift_page`)
    The same kind of bias draws through the nonlinear strapdown on a
    stationary trajectory and through the small-angle closed form, for 3D and
    2D INS, on a grid of gyro bias levels and times.

Reproducibility
    Run ``i`` of a study with seed ``s`` draws everything from its own
    Generator seeded with ``SeedSequence(s).spawn(N)[i]`` (built directly as
    ``SeedSequence(s, spawn_key=(i,))``, which is the same object), in a
    fixed order: 6 bias numbers (accelerometer xyz, gyro xyz), 1 gain number,
    then the ``(6, n)`` noise block (accelerometer xyz, gyro xyz; each
    channel's n samples consecutive). The noisy training runs behind the
    reference gains draw from the study seed's child
    ``SeedSequence(s, spawn_key=(TRAINING_KEY,))`` (:data:`TRAINING_KEY`,
    an index no run reaches: a study has fewer runs), so a study's training
    set changes with its seed and a seeded study fixes every number. Every
    computation is elementwise over runs, so a run's numbers do not depend on
    which chunk, thread or Dask worker computed it: the digest is the same for
    any chunk size, any number of workers and through Dask.

One pass, flat memory
    :func:`run_studies` runs several studies that share the draws and the
    paths (other calibrations, gain scenarios, training-set sizes) over one
    pass of the random numbers: each run's numbers are drawn once, each
    calibration's measurement errors are built once, and every study is a set
    of columns of the same draws, equal bit for bit to the study run alone.
    Chunks are reduced as they finish: the per-run final, gain and distance
    errors are kept (they are what the digest, the order statistics and the
    distance check need), the error series only as a sum of squares (RMS) and
    histogram counts per epoch (the 5/50/95 % bands), unless a caller asks
    for them (``series=True``); a study whose curves nobody reads (the
    gain-training studies, the page's raw-bias study) skips even those
    (``curves``). Dask workers return those reductions. The kernel's large
    planes are scratch arrays of the thread, reused from chunk to chunk, and
    a Dask worker process keeps its freed temporaries for the next chunk
    (:func:`_keep_freed_memory`; the caller's own process is left as it is).

Digest
    sha256 over the per-run final horizontal errors rounded to
    :data:`DIGEST_BITS` significant bits (a relative step of 2^-20, about
    1e-6: six significant digits), as a C-ordered little-endian float64
    array of shape ``(runs, columns)`` with the columns of
    :attr:`StudyResult.columns` (INS-3D, INS-2D, then MoRPI-A and MoRPI-G for
    each gain scenario in order). The rounding is exact bit arithmetic
    (``frexp``/``ldexp``), so the same values give the same digest
    everywhere, and it is coarse enough that the last-digit differences of
    another machine's arithmetic leave it unchanged: moving every sample of
    the simulated path by one unit in the last place changes the bits of
    81,258 of the page's 88,000 per-run errors (2000 runs, every study), by
    at most 3e-13 relative (median 4e-15); the expected number of them that
    cross a rounding boundary (the sum of each change over its step) is
    3e-4, and the page's nine digests stay as they are. A gain
    scenario set from the field recordings uses their spread and mismatch
    rounded to :data:`FIELD_GAIN_DIGITS` digits, so the field evaluation's own
    machine differences (up to a few 1e-11) do not reach the runs either.

Pieces from other modules
    Trajectories come from :mod:`morpi_filters.simulate` (``sine``,
    ``straight``); the drift study integrates with
    :func:`morpi_filters.strapdown.ins3d` / ``ins2d`` and evaluates
    :func:`morpi_filters.symbolic.closed_form_errors`. The gain-error study
    propagates the INS with a specialised kernel
    (:mod:`morpi_filters.montecarlo._batch_ins`: a quaternion attitude step over runs,
    compiled by numba, and trapezoid integration; the true signals go through
    the same rules once and are subtracted), because the general strapdown,
    which keeps every C_bn matrix, costs about 8 times the drawing of the
    random numbers; the tests check the kernel against strapdown.ins3d / ins2d.

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial
  Navigation," IEEE J. Indoor and Seamless Positioning and Navigation, 2023.
- [2] H. Weinberg, "Using the ADXL202 in pedometer and personal navigation
  applications," Analog Devices AN-602, 2002.
- [3] NumPy Enhancement Proposal 19 / SPEC 7: seeding with SeedSequence.spawn.
"""
from __future__ import annotations

from .config import (BAND_BINS_PER_DECADE, BAND_PERCENTILES, BAND_RANGE_M, CALIBRATIONS, DEFAULT_DURATION_S,
                     DEFAULT_LENGTH_M, DIGEST_BITS, DRIFT_SEED, INS_PATHS, METHODS, RAMP_S, TRAINING_KEY, GainError,
                     StudyConfig, StudyResult, child_seed, digest, training_seed)
from .engine import band_quantiles, reference_gains, run_studies, run_study, summarize
from .training import TrainingStudy, training_configs, training_runs_study, training_summary
from .drift import DriftMap, drift_map
from .pages import (ASSUMED_MISMATCH, ASSUMED_SPREAD, CHUNK_SAMPLE_BYTES, FIELD_GAIN_DIGITS, FIXED_BYTES,
                    FIXED_SECONDS, RUN_BYTES, RUN_SECONDS, TRAINING_KS, Z99, DriftPage, GainErrorPage, PageCost,
                    distance_law_check, drift_page, final_statistics, gain_error_page, page_cost, study_config_json)

__all__ = [
    "GainError", "StudyConfig", "CALIBRATIONS", "StudyResult", "METHODS", "run_study", "run_studies", "summarize",
    "digest", "child_seed", "training_seed", "TRAINING_KEY", "DRIFT_SEED", "reference_gains", "training_runs_study",
    "training_configs", "training_summary", "TrainingStudy", "band_quantiles", "BAND_PERCENTILES",
    "BAND_BINS_PER_DECADE", "DriftMap", "drift_map", "GainErrorPage", "gain_error_page", "DriftPage", "drift_page",
    "Z99", "final_statistics", "distance_law_check", "INS_PATHS", "PageCost", "page_cost", "study_config_json",
    "DIGEST_BITS", "ASSUMED_SPREAD", "ASSUMED_MISMATCH", "RAMP_S", "DEFAULT_LENGTH_M", "DEFAULT_DURATION_S",
    "BAND_RANGE_M", "TRAINING_KS", "RUN_BYTES", "RUN_SECONDS", "FIXED_SECONDS", "FIXED_BYTES", "CHUNK_SAMPLE_BYTES",
    "FIELD_GAIN_DIGITS",
]
