"""The MoRPI-aided filter (:mod:`morpi_filters.aided`) on the field recordings.

Per MoRPI table cell of :func:`morpi_filters.evaluate.evaluate_tables` (its
steps, step rule and trained gain), the aided filter runs once over each test
recording, forward and smoothed, beside MoRPI alone and the INS alone.

Tunables are chosen per training set, method and calibration on the ``train``
runs only (:func:`choose_tunables`): the noise densities, the zero-rate noise
and the gyro bias walk come from what the train runs show at rest (the
densities while the robot stands); the grid
(:data:`GRID`) scales the densities for the vibration of the moving robot, sets
the step noise and where the step direction comes from (the filter's attitude,
or the route's heading: :func:`route_vectors`, whose turns carry a heading
error of :data:`TURN_SIGMA` of their angle, set a priori: the train routes take
no turn); at the chosen point the non-holonomic updates stay and the gain error is estimated
(rather than considered) only where the train runs show it pays. The gain
error's prior is the trained gain's spread. Nothing of a ``test`` folder
enters the choice.

The choice is a consistency criterion before an error criterion
(:func:`choose_consistent`, fixed before any test run was scored with it): a
grid point competes on its mean train end-point error only when it is
consistent on the train runs, its 95 % ellipse holding the true end point of
at least :data:`MIN_TRAIN_COVERAGE` of them and the NIS per degree of freedom
of each measurement type it uses (steps, zero velocity, zero rate,
non-holonomic), summed over the train runs' forward passes up to the read-out,
inside :data:`NIS_BAND`. The least error alone picked points whose step updates
expect innovations tens of times wider than they come (a dead reckoning of the
steps with an INS beside it that the covariance does not describe). When no
point is consistent the least inconsistent wins: enough coverage first, then
the fewest measurement types outside the band, then the least error. The
nested leave-one-out repeats the same rule on each fold's runs, and the second
stage (non-holonomic updates, estimated gain) keeps a change only when it
leaves the filter no less consistent.

The filter starts at the calibration's initial rest window (what precedes it,
the phone placed and handled, is no motion of the robot). The rest updates run
on that window and on every
still stretch after the motion (:func:`still_spans`), zero velocity alone
between that window and the motion onset; the filter is read where MoRPI's own
track ends (:meth:`Prepared.end`).

Each cell holds, beside MoRPI alone, the filter's own steps alone
(:func:`steps_alone`: the step vectors it is fed, summed without the INS), the
run-by-run tests against both with Holm's correction over the cells of a
calibration (:func:`paired_difference`, :func:`holm`, with the smallest
difference a tie could have shown: :func:`detectable_difference`), the same
tests against MoRPI alone under its best train-chosen heading reading (the
rule's own, or the route's heading where the train runs prefer it beyond the
tie tolerance: :func:`choose_reading`; with the Weinberg length or the period
count, :func:`choose_length`; the tables' cells are left as they are), the
share of
true end points inside the 95 % regions of the smoothed and the forward
estimate, each under its own covariance (:func:`ellipse_coverage`), and the
NIS of each measurement per degree of freedom with its chi-square band
(:func:`nis_consistency`). The ablation removes each aid the chosen filter
uses (:func:`aid_used`) and reads both filters the same two ways.
"""
from __future__ import annotations

from .inputs import (STILL_FACTOR, STILL_MIN_S, STILL_WINDOW_S, Prepared, gyro_drift, prepare, rest_noise, rest_terms,
                     route_steps, route_vectors, still_spans)
from .baselines import (LENGTHS, READING_SE, LengthChoice, ReadingChoice, choose_length, choose_reading, period_length,
                        period_sums, route_reading_pays, route_sums, steps_alone)
from .tuning import (ACCEL_WALK, GRID, MIN_TRAIN_COVERAGE, NHC_SIGMA, NIS_BAND, TURN_SIGMA, TunableChoice,
                     choose_consistent, choose_tunables, choose_tunables_many, gain_estimate_pays, tuning_from)
from .significance import (ALPHA, POWER, Z_95, PairedDifference, detectable_difference, ellipse_coverage, holm,
                           nis_consistency, paired_difference)
from .ablation import ABLATIONS, aid_used
from .study import AidedCell, AidedStudy, aided_study

__all__ = ["GRID", "ABLATIONS", "AidedCell", "AidedStudy", "PairedDifference", "Prepared", "aided_study",
           "choose_tunables", "choose_tunables_many", "paired_difference", "prepare",
           "still_spans", "rest_noise", "gyro_drift", "gain_estimate_pays", "route_vectors", "steps_alone",
           "holm", "detectable_difference", "READING_SE", "ReadingChoice", "route_sums",
           "route_reading_pays", "choose_reading", "LENGTHS", "period_sums", "period_length", "LengthChoice",
           "choose_length", "ellipse_coverage", "nis_consistency", "aid_used", "NIS_BAND",
           "choose_consistent", "route_steps", "tuning_from", "rest_terms", "TunableChoice", "NHC_SIGMA", "TURN_SIGMA",
           "MIN_TRAIN_COVERAGE", "ACCEL_WALK", "ALPHA", "POWER", "Z_95", "STILL_WINDOW_S", "STILL_FACTOR",
           "STILL_MIN_S"]
