"""Sphinx extension: a package documents the ``#:`` comments of the constants it re-exports.

Autodoc documents a module-level constant only when it finds a ``#:`` comment above the
assignment, and it looks for that comment in the source of the module it documents. A package
whose ``__init__`` re-exports names from its submodules (``from .rules import GRID_HZ``) holds no
such comment, so ``.. automodule:: morpi_filters.steps`` lists the functions and classes but not
the constants. This extension gives each package the comments of its submodules: for every name in
the package's ``__all__`` that is neither a module, a class nor a routine, it takes the ``#:``
comment of the submodule (at any depth inside the package) whose attribute is the very same object,
and adds it to the comments autodoc reads for the package. The constant is then documented once,
under the name users import (``morpi_filters.steps.GRID_HZ``), with the submodule's text.

Functions and classes are left alone (autodoc already documents them where they are re-exported),
and so is a comment the package's ``__init__`` writes itself. Two submodules giving the same object
different comments is a warning. Configuration: ``reexported_comments_packages``, the top-level
packages whose packages (the top level included) are treated.
"""
from __future__ import annotations

import importlib
import inspect
import pkgutil
import sys

from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer
from sphinx.util import logging

logger = logging.getLogger(__name__)


def _is_constant(value) -> bool:
    return not (inspect.ismodule(value) or inspect.isclass(value) or inspect.isroutine(value))


def _comments(modname: str) -> tuple[dict, str]:
    """``#:`` comments of a module's top-level names (name -> lines) and its source file."""
    try:
        analyzer = ModuleAnalyzer.for_module(modname)
        analyzer.analyze()
    except PycodeError:
        return {}, ""
    return {name: lines for (scope, name), lines in analyzer.attr_docs.items() if scope == ""}, analyzer.srcname


def package_comments(package) -> dict:
    """name -> (``#:`` lines, source file) for the constants ``package`` re-exports from its submodules."""
    prefix = package.__name__ + "."
    submodules = {name: _comments(name) for name in sorted(sys.modules) if name.startswith(prefix)}
    found = {}
    for name in getattr(package, "__all__", ()):
        value = getattr(package, name, None)
        if not _is_constant(value):
            continue
        sources = {}
        for modname, (comments, srcname) in submodules.items():
            lines = comments.get(name)
            if lines and getattr(sys.modules[modname], name, None) is value:
                sources.setdefault(tuple(lines), (modname, srcname))
        if len(sources) > 1:
            logger.warning("%s.%s: submodules %s give it different #: comments", package.__name__, name,
                           ", ".join(sorted(m for m, _ in sources.values())), type="reexported_comments")
        if sources:
            lines, (_, srcname) = next(iter(sources.items()))
            found[name] = (list(lines), srcname)
    return found


def _packages(root: str):
    top = importlib.import_module(root)
    yield top
    for info in pkgutil.walk_packages(getattr(top, "__path__", []), root + "."):
        if info.ispkg:
            yield importlib.import_module(info.name)


def add_package_comments(app) -> None:
    """Add the re-exported constants' comments to what autodoc reads for each package."""
    app.env.reexported_comment_sources = sources = {}
    for root in app.config.reexported_comments_packages:
        for package in _packages(root):
            extra = package_comments(package)
            if not extra:
                continue
            analyzer = ModuleAnalyzer.for_module(package.__name__)
            analyzer.analyze()
            for name, (lines, srcname) in extra.items():
                if ("", name) not in analyzer.attr_docs:
                    analyzer.attr_docs[("", name)] = lines
                    sources[f"{package.__name__}.{name}"] = srcname


def note_source(app, what, name, obj, options, lines) -> None:
    """A page showing a re-exported comment is rebuilt when the submodule holding it changes."""
    srcname = getattr(app.env, "reexported_comment_sources", {}).get(name)
    if what == "data" and srcname:
        app.env.note_dependency(srcname)


def setup(app):
    app.add_config_value("reexported_comments_packages", [], "env")
    app.connect("builder-inited", add_package_comments)
    app.connect("autodoc-process-docstring", note_source)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
