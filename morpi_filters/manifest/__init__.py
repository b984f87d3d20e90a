"""Dataset manifests (format version 1): a researcher's own recordings, loaded, converted and checked.

A manifest is a TOML file that describes recordings made with any robot and
IMU: where each file lies, how its columns are named, its rate, units and
axes, and its ground truth (an end point as the MoRPI routes give, or a
truth track). :func:`load_dataset` reads it into a :class:`Dataset` whose
recordings are in the package's frame and units (body axes x forward, y
left, z up; s, m/s^2, rad/s); :func:`check_dataset` reports every problem,
one line each (``morpi check --dataset FILE``). ``docs/manifest.md`` is the
reference of the format, key by key.

Layout of a manifest::

    format_version = 1
    name = "my robot"
    [defaults]            # keys every recording inherits (its own keys win, one by one)
    imu.rate_hz = 200.0
    [[recording]]         # one table per recording
    id = "run1"
    imu.file = "imu/run1.csv"
    truth = { kind = "route", distance_m = 6.3, end_point_m = [6.3, 0.0] }

Relative file names start at the manifest's folder, or at a ``root`` given
when it is read, so one manifest describes every copy of a dataset (the
package's MoRPI manifest, :func:`morpi_filters.resources.morpi_manifest`); an
``imu.file`` holding a glob pattern makes one recording of each file it
matches, its id the file's relative path. :func:`index_dataset` lists the
recordings with their labels without reading a file. ``latitude_deg`` sets
the gravity the calibrations take; ``imu.spec`` may name an IMU the package
knows. An ``[evaluation]`` table (:class:`Settings`) says how the dataset is
evaluated, and a recording's ``train_group`` which group's train recordings
set its gains.

Truth tracks are stored in a local ENU frame (x east, y north, z up: right
handed and z up like the package's navigation frame, from which it differs
by a rotation about z and the origin), whatever the file's frame (NED or
ENU), on the IMU file's clock in seconds: the truth time of the IMU file's
first sample is 0, and the truth file's first sample is at ``offset_s``.

Checks, each one line naming the manifest, the recording and the key (and
the data file and line where there is one): a manifest that is not TOML,
a format version other than 1, unknown keys (with the nearest known one),
wrong types, unknown units, frames or axes, left-handed or repeated axes,
duplicate ids, missing files, ``rate_hz`` missing without a time column or
disagreeing with it raise :class:`~morpi_filters.errors.ParameterError`
(exit 2); a file that does not load (every check of
:func:`~morpi_filters.dataset.read_columns` on the values converted to SI:
time increasing, gaps, limits) or a truth track shorter than its recording
raise :class:`~morpi_filters.errors.DataError` (exit 1). After conversion the
recording must pass :func:`~morpi_filters.dataset.rest_problems`, the checks
the MoRPI catalogue applies, with the IMU's error figures (``imu.spec``, else
:data:`~morpi_filters.dataset.MEMS_SPEC`) and the recording's ``rest``:
gravity up the body z axis, gyro offsets and noise at rest, the turns'
rates; otherwise a ParameterError names the key to fix (``accel_unit``,
``axes``, ``gyro_unit`` or ``columns``), and a dead channel is a DataError
naming ``imu.file``. :func:`check_dataset` also names, as a DataError, a
glob ``imu.file`` that matches another number of files than its
``imu.count`` (:func:`count_problems`).
"""
from __future__ import annotations

from .schema import ACCEL_UNITS, FORMAT_VERSION, GLOB_CHARS, GYRO_UNITS, RATE_TOLERANCE, SPEC_KEYS, TIME_UNITS
from .read import DatasetRecording, RouteTruth, TruthTrack
from .model import Dataset, DatasetIndex, IndexedRecording, check_dataset, count_problems, index_dataset, load_dataset
from .settings import AIDED_METHODS, HELD_OUT_CHOICES, INS_SPANS, SETTING_CHOICES, Settings

__all__ = [
    "FORMAT_VERSION", "TIME_UNITS", "ACCEL_UNITS", "GYRO_UNITS", "SPEC_KEYS", "RATE_TOLERANCE", "RouteTruth",
    "TruthTrack",
    "DatasetRecording", "Dataset", "IndexedRecording", "DatasetIndex", "index_dataset", "load_dataset", "check_dataset",
    "count_problems",
    "GLOB_CHARS", "Settings", "HELD_OUT_CHOICES", "INS_SPANS", "AIDED_METHODS", "SETTING_CHOICES",
]
