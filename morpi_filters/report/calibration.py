"""Markdown of the calibration results: the rest window each recording used."""
from __future__ import annotations

import math

from .common import fmt, md_table

__all__ = ["rest_windows_table"]


def rest_windows_table(summary) -> str:
    """A markdown table of the rest windows of a ``calibration.RestSummary`` (gyro shift in deg/s)."""
    body = [[r.name, r.method, fmt(r.start_s), fmt(r.window_s), fmt(r.motion_s),
             fmt(None if r.gyro_shift is None else math.degrees(r.gyro_shift), 3), r.note or r.error]
            for r in summary.rows]
    return md_table(["recording", "window", "start [s]", "length [s]", "motion onset [s]",
                     "first-3 s gyro bias shift [deg/s]", "note"], body)
