"""The field recordings as cached data, and the train-only choice of the step rule.

:class:`FieldData` gives lazy, cached access to a dataset root: recordings,
calibrations, INS runs and step signals, each computed once and shared by
every cell, the gain training and the rule search. :func:`select_config`
chooses the step rule on the ``train`` runs only, by leave-one-out end-point
error (:func:`held_out_score`); :func:`nested_rule_comparison` checks that
choice with the training sets themselves held out in turn. The cells and
comparisons built on this data are in :mod:`morpi_filters.evaluate`.

A package: ``entries`` (a manifest's recordings, their truth and the train
sets), ``thresholds`` (the detection thresholds the train runs set), ``data``
(:class:`FieldData`, :func:`check_recordings`, :func:`missing_recordings`), ``gains`` (the Weinberg gains
of the train runs) and ``rules`` (the leave-one-out scores and the rule search).
"""
from __future__ import annotations

from . import entries
from .entries import COURSE_M, TrainSet, track_course
from .thresholds import MORPI_METHODS, SWING_MARGIN, TURN_MARGIN, Thresholds, fold_thresholds, train_thresholds
from .data import (HEADING_ORIGINS, HEADING_SOURCES, INS_SPANS, LEVELED, FieldData, RecordingWork, check_recordings,
                   missing_recordings)
from .gains import Gain, set_gain, trained_gain
from .rules import (HELD_OUT, READING_GRID, RULES, SOURCE_SE, TUNABLE_GRID, Selection, held_out_errors,
                    held_out_score, loo_errors, nested_rule_comparison, select_config, train_summary)

#: Public before, outside ``__all__`` (and the API reference).
given_rest_window = entries.given_rest_window

__all__ = ["HELD_OUT", "COURSE_M", "TrainSet", "RecordingWork", "RULES", "INS_SPANS", "LEVELED", "HEADING_ORIGINS", "HEADING_SOURCES", "Gain",
           "Selection", "Thresholds", "FieldData", "train_thresholds", "fold_thresholds", "select_config", "nested_rule_comparison",
           "READING_GRID", "TUNABLE_GRID", "SWING_MARGIN", "TURN_MARGIN", "SOURCE_SE", "trained_gain",
           "set_gain", "track_course", "check_recordings", "missing_recordings", "MORPI_METHODS", "train_summary",
           "loo_errors",
           "held_out_errors", "held_out_score"]
