"""Recordings: the CSV loader with validation, and the MoRPI dataset catalogue.

A :class:`Recording` holds one IMU recording in SI units and phone axes (see
the package docstring for frames). :func:`load_csv` reads one file and rejects
anything that is not a clean recording with a :class:`MorpiError` naming the
file, and the line where there is one; :func:`read_columns` reads a table in
another layout and units (a :class:`ColumnLayout`: a logger's CSV or an
``.npy`` array) with the same checks on the values converted to SI.
:func:`plausibility_problems` reads what
a clean file says at rest (gravity's magnitude and direction, the gyro's offset
and noise, channels that never move) and names what no phone IMU in SI units
and the z-up frame would record; the catalogue's loader applies it
(:func:`check_plausible`). Its checks live in :func:`rest_problems`,
structured and scaled by a sensor's error figures, which dataset manifests
call too. :func:`catalogue` walks a dataset root
laid out as the public MoRPI repository (``s8/short_distance/train/3.csv``)
and attaches phone, route, split and the route's ground truth, which lives in
``data/routes.json`` (a file this project owns).

The dataset root is found by :func:`resolve_data_root`: an explicit path, else
the environment variable ``MORPI_DATA``.
"""
from __future__ import annotations

from .truth import PROJECT_DATA, Route, layout, route, routes
from .recording import Recording
from .columns import (ACCEL_LIMIT_MPS2, COLUMNS, GYRO_LIMIT_RADPS, MAX_GAP_S, MIN_SAMPLES, TIME_LIMIT_S,
                      ColumnLayout)
from .loader import check_recording, keep_parsed, load_csv, read_columns, write_csv
from .plausibility import (GRAVITY_BAND_MPS2, GYRO_NOISE_FACTOR, GYRO_REST_LIMIT_RADPS, MEMS_SPEC,
                           MOVING_RATE_LIMIT_RADPS, UP_FRACTION_MIN, RestProblem, check_plausible,
                           plausibility_problems, rest_problems)
from .folders import (DATA_ENV, CatalogueEntry, catalogue, folder_imu, load_catalogue, load_recording,
                      missing_data_message, resolve_data_root)

__all__ = [
    "COLUMNS", "MIN_SAMPLES", "ACCEL_LIMIT_MPS2", "GYRO_LIMIT_RADPS", "MAX_GAP_S", "TIME_LIMIT_S", "DATA_ENV", "Route", "Recording", "CatalogueEntry",
    "ColumnLayout", "load_csv", "read_columns", "check_recording", "load_recording", "write_csv", "routes", "route",
    "catalogue", "load_catalogue", "folder_imu",
    "resolve_data_root", "missing_data_message", "keep_parsed", "PROJECT_DATA",
    "layout", "GRAVITY_BAND_MPS2", "UP_FRACTION_MIN",
    "GYRO_REST_LIMIT_RADPS", "GYRO_NOISE_FACTOR", "MOVING_RATE_LIMIT_RADPS", "MEMS_SPEC", "RestProblem",
    "rest_problems", "plausibility_problems", "check_plausible",
]
