"""Sphinx configuration: Markdown pages (MyST) and an API reference from numpydoc docstrings."""

import importlib.util
import os
import sys

sys.path.insert(0, os.path.abspath(".."))

project = "symladders"
author = "symladders developers"
extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath"]
# Anchors for the headings (links such as solvers.md#stopping-rules), GitHub's slugs.
myst_heading_anchors = 4
numpydoc_show_class_members = False
numpydoc_validation_checks = set()
autosummary_generate = True
# A package's __all__ re-exports its modules' names: document each where it is defined.
autodoc_default_options = {
    "members": True,
    "inherited-members": False,
    "show-inheritance": True,
    "ignore-module-all": True,
}
# The benchmarks' generated tables are included in the pages, not pages of their own.
exclude_patterns = ["_build", "generated"]
# The geomstats adapter is documented even when the optional extra is not installed.
autodoc_mock_imports = [] if importlib.util.find_spec("geomstats") else ["geomstats"]
html_theme = "alabaster"
suppress_warnings = ["myst.header"]
