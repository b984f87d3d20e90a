"""The paper's protocol on the field recordings: every table cell, ours beside the paper's.

Cells (32 in all, the tables of Etzion and Klein [1]_):

========================  =====================================  ===========================
table (JSON name)         recordings                             what
========================  =====================================  ===========================
``ins_straight``          s8/line_dataset                        INS-3D/2D x RD/GAC
``short_route``           {s8 1 m, s8 1.5 m, s6 1 m} test        MoRPI-A/G x RD/GC
``long_route``            {s8, s6}/long_distance/test            MoRPI-A/G x RD/GC, indoor gains
``ins_l_shape``           s6/L_line                              INS-3D/2D x RD/GAC
``morpi_l_shape``         s6/L_shape/test                        MoRPI-A/G x RD/GC, s6 indoor gains
========================  =====================================  ===========================

Protocol
    Gains are trained per training set (phone, route), method and calibration
    on the ``train`` split with the known distance: each run's gain makes its
    summed steps equal the distance, the gain is the mean over runs (the std is
    kept). The long route and the L shape use the indoor 1 m gains of the same
    phone, without retraining.

Tunables
    The step rule (the paper's open readings and the thresholds, see
    :mod:`morpi_filters.steps`) is chosen by :func:`select_config` from the
    short-route ``train`` runs only: a coordinate search scored by the
    leave-one-out end-point error on the train runs (each held-out run is
    dead-reckoned with the gain of the other runs of its set). Either each
    method gets its own rule (``rule="per_method"``) or one rule serves both
    (``"joint"``, the paper's "in the same manner" reading); the other is
    reported beside the default. The default is the way of choosing that
    :func:`nested_rule_comparison` prefers: nested leave-one-out over the
    train runs, without the bias of scoring on the runs a rule was chosen
    on (a rule per method always has the lower plain train error). And
    :func:`rule_sensitivity` shows how far each rule the search tried moves
    the short-route cells. Nothing of a ``test`` folder enters the choice, so
    the result is the same with the test folders absent.

INS cells
    3D (:func:`morpi_filters.strapdown.ins3d`, level start) and 2D
    (:func:`~morpi_filters.strapdown.ins2d`) INS on the RD or GAC recording,
    integrated over the robot's motion (:func:`morpi_filters.steps.activity_span`;
    the whole recording is reported beside it).

Caching
    :class:`FieldData` computes each per-recording quantity once (the file,
    the rest window, calibrations, resampled and filtered step signals, peaks,
    INS runs) and every cell, the gain training and the rule search share it.

Errors
    ``ours_percent`` is the mean end-point error over the test runs, in % of
    the route's travelled distance (the paper's measure); the distance error
    ``|travelled estimate - true distance|`` is given beside it.

A package: ``cells`` (the paper's cells and numbers, :func:`evaluate_tables`
and the checks of the data and the cells), ``compare`` (the comparisons built
on the cells, the paper's claims beside ours) and ``study`` (the section's
frozen result, :func:`tables_study`).

References
----------
.. [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
   IEEE J-ISPIN, 2023 (tables "INS results", "weinberg results short",
   "tab:comparison methods", "weinberg results long", "tab:INS_Lshape",
   "tab:morpi_Lshape").
"""
from __future__ import annotations

from . import cells, compare
from .cells import (DEVIATION_PP, PAPER_CELLS, PAPER_COMPARISON, TABLES, Cell, CellSpec, RunResult, TablesResult,
                    check_cells, dataset_problems, evaluate_tables, rule_json, rule_sensitivity,
                    short_route_sets, training_gain_spread)
from .compare import comparison, heading_readings, ins_full_span, ins_leveled, other_rule, turn_reading
from .study import RecordingView, TablesStudy, TrackView, tables_study

# public before, outside __all__ (and the API reference); FieldData is field's, which evaluate imported
INS_METHODS, CELL_SANITY_PERCENT, cell_specs = cells.INS_METHODS, cells.CELL_SANITY_PERCENT, cells.cell_specs
FieldData = cells.FieldData
CLAIM_PP, CLAIM_DURATION, CLAIM_LINEAR, paper_claims = (compare.CLAIM_PP, compare.CLAIM_DURATION, compare.CLAIM_LINEAR,
                                                        compare.paper_claims)

__all__ = [
    "TABLES", "PAPER_CELLS", "PAPER_COMPARISON", "CellSpec", "RunResult", "Cell",
    "TablesResult", "evaluate_tables", "TablesStudy", "RecordingView", "TrackView", "tables_study",
    "training_gain_spread", "rule_sensitivity", "comparison", "ins_full_span", "ins_leveled", "other_rule",
    "DEVIATION_PP", "check_cells", "dataset_problems", "heading_readings", "turn_reading", "rule_json",
    "short_route_sets",
]
