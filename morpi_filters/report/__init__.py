"""Report pages: every markdown page, JSON payload and figure of ``reports/``.

Studies return frozen results; the modules of this package turn them into
files. Nothing here computes a study, and no module outside this package
writes markdown or imports matplotlib.
"""
