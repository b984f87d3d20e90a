"""Report pages: the home of the markdown pages, JSON payloads and figures of ``reports/``.

Studies return results; page writers turn them into files. Today the page
writers still sit beside their studies (``evaluate.report_tables``,
``curves.report_curves``, ``montecarlo.report_montecarlo`` and
``report_drift``, ``assessment.report_assessment``) and move here one by one.
"""
