"""Report pages: every markdown page, JSON payload and figure of ``reports/``.

Studies return frozen results; the writers here turn them into files. They
evaluate, integrate and simulate nothing (at most a mean, a percentile or a
minimum over what a result holds). One module per page:

========================  ===================================================  ==========================
module                    writes                                               from
========================  ===================================================  ==========================
:mod:`.tables`            ``tables/``: the paper's tables on the recordings     ``evaluate.tables_study``
:mod:`.assessment`        ``assessment/``: closed-form assessment, audit        ``assessment.assessment_study``
:mod:`.curves`            ``curves/``: covariance curves                        ``curves.curves_study``
:mod:`.aided`             ``aided/``: the MoRPI-aided filter on the field       ``field_aided.aided_study``
:mod:`.montecarlo`        ``montecarlo/`` and ``drift/``                        ``gain_error_page``, ``drift_page``
:mod:`.index`             ``index.md``                                          the sections' summaries
========================  ===================================================  ==========================

:mod:`.plots` draws every figure (the only matplotlib importer) and
:mod:`.common` holds what the writers share (number formatting, markdown
tables, the synthetic-data banner, saving a figure).
"""
