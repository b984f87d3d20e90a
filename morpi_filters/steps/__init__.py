"""MoRPI step machinery: peak detection, Weinberg length, gain training, dead reckoning.

The robot drives a sine path; each period ("step", by analogy with pedestrian
dead reckoning) is found between peaks of a periodic IMU signal, its length is
estimated with the Weinberg formula [2]_

    s = G (max - min)^(1/4)

on the lateral specific force ``f_y`` (MoRPI-A) or on the z angular rate
``omega_z`` (MoRPI-G) [1]_, and the position is advanced with the gyro heading,
``x += s cos(dpsi), y += s sin(dpsi)``.

Sampling
    The recordings are not uniformly sampled (the S6 files wander between about
    50 and 100 Hz). Peak detection therefore resamples the signal by linear
    interpolation onto a uniform grid (:data:`GRID_HZ`, or the recording's
    median sample rate: :attr:`StepConfig.grid_hz`), low-pass filters it
    there (zero-phase Butterworth), runs :func:`scipy.signal.find_peaks` with
    the period and width converted to grid samples, and maps the peaks back to
    the nearest original sample. Heading is integrated on the original time
    stamps (trapezoid rule on the real steps).

Readings of the paper
    The paper leaves three points open; :class:`StepConfig` implements each
    reading as an option:

    ``heading`` (what Delta psi_k is)
        ``"absolute"``: the heading accumulated since the start, taken at the
        step's end peak; ``"mean"``: its mean over the step; ``"change"``: the
        heading change inside the step (end minus start); ``"turns"``: the
        step's heading change plus the turn heading at the step's start
        (:func:`turn_heading`: the heading followed only through the
        stretches whose full-period heading change exceeds
        :attr:`StepConfig.turn_deg`, held still elsewhere).
    ``segment`` (where a step starts and ends)
        ``"maxima"``: between consecutive maxima (one period); ``"extrema"``:
        between consecutive extrema (half periods, two per period).
    ``ends`` (the partial steps before the first and after the last peak)
        ``"drop"``: ignored; ``"fraction"``: counted as the fraction of the
        run's median step duration they last, with the run's median step
        length; ``"whole"``: counted as whole steps when at least half a step
        long.

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023.
.. [2] H. Weinberg, "Using the ADXL202 in pedometer and personal navigation
   applications", Analog Devices AN-602, 2002.
"""
from __future__ import annotations

from .rules import (ACTIVITY_WINDOW_S, DEFAULT_CONFIGS, ENDS, GRID_HZ, HEADING_SOURCES, HEADINGS, METHODS, SEGMENTS,
                    MorpiTrack, Peaks, StepConfig, Steps)
from .prepare import (PreparedSignal, activity_span, detect_peaks, integrate_heading, lowpass, motion_span,
                      prepare_signal, resample_uniform)
from .extract import StepSums, extract_steps, require_swing, step_sums
from .headings import period_changes, turn_heading, turn_stretches
from .reckon import dead_reckon, morpi_track, train_gain, weinberg_length

__all__ = [
    "GRID_HZ", "ACTIVITY_WINDOW_S", "HEADINGS", "SEGMENTS", "ENDS", "HEADING_SOURCES", "METHODS", "StepConfig",
    "Peaks", "Steps", "MorpiTrack",
    "resample_uniform", "lowpass", "detect_peaks", "weinberg_length", "integrate_heading",
    "motion_span", "activity_span", "PreparedSignal", "prepare_signal", "extract_steps", "StepSums", "step_sums",
    "train_gain", "dead_reckon", "morpi_track", "DEFAULT_CONFIGS", "require_swing", "period_changes", "turn_stretches",
    "turn_heading",
]
