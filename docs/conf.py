"""Sphinx configuration of the morpi_filters API reference."""
import os
import sys

sys.path.insert(0, os.path.abspath(".."))
sys.path.insert(0, os.path.abspath("."))

project = "morpi_filters"
author = "the morpi_filters authors"
extensions = ["sphinx.ext.autodoc", "numpydoc", "reexported_comments"]
numpydoc_show_class_members = False
numpydoc_validation_checks = set()
autodoc_default_options = {"members": True, "undoc-members": False}
exclude_patterns = ["_build"]
html_theme = "alabaster"
# a package documents the constants it re-exports with their submodules' #: comments
reexported_comments_packages = ["morpi_filters"]
