"""Markdown of the calibration results: the rest window each recording used."""
from __future__ import annotations

import math

from .common import fmt, md_table

__all__ = ["rest_windows_table"]


def rest_windows_table(summary) -> str:
    """A markdown table of the rest windows of a ``calibration.RestSummary`` (gyro shift in deg/s).

    Parameters
    ----------
    summary : calibration.RestSummary
        One row per recording (:func:`morpi_filters.calibration.rest_windows_summary`).

    Returns
    -------
    str
        A :func:`~morpi_filters.report.common.md_table` with the recording,
        the window method, its start, length and the motion onset [s], the
        gyro bias shift [deg/s, 3 digits] and the note (or the error).

    Examples
    --------
    >>> from morpi_filters.calibration import RestRow, RestSummary
    >>> row = RestRow(name="s8/L_shape/test/1", method="full", start_s=0.0, window_s=3.0, motion_s=4.5,
    ...               gyro_shift=math.radians(0.01))
    >>> print(rest_windows_table(RestSummary(rows=(row,), n_moving_early=0, n_disturbed=0, n_total=1)).rstrip())
    | recording | window | start [s] | length [s] | motion onset [s] | first-3 s gyro bias shift [deg/s] | note |
    |---|---|---|---|---|---|---|
    | s8/L_shape/test/1 | full | 0.00 | 3.00 | 4.50 | 0.010 |  |
    """
    body = [[r.name, r.method, fmt(r.start_s), fmt(r.window_s), fmt(r.motion_s),
             fmt(None if r.gyro_shift is None else math.degrees(r.gyro_shift), 3), r.note or r.error]
            for r in summary.rows]
    return md_table(["recording", "window", "start [s]", "length [s]", "motion onset [s]",
                     "first-3 s gyro bias shift [deg/s]", "note"], body)
