"""The Examples sections of the package's docstrings run and print what they show."""
from __future__ import annotations

import doctest
import importlib
import pkgutil

import morpi_filters


def test_docstring_examples_run():
    finder, runner = doctest.DocTestFinder(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    documented = 0
    for info in pkgutil.walk_packages(morpi_filters.__path__, "morpi_filters."):
        module = importlib.import_module(info.name)
        for test in finder.find(module, info.name):
            documented += bool(test.examples)
            runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0
    # the API's bar: at least 40 docstrings with examples (what `pytest --doctest-modules` collects)
    assert documented >= 40, documented
