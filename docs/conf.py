"""Sphinx configuration of the turbgen documentation (``sphinx-build -W docs docs/_build``).

Sphinx with numpydoc because every docstring of turbgen is numpydoc-style (Parameters / Returns / Raises with units),
so the API reference is generated from the docstrings as written; myst-parser so the pages stay Markdown (readable on
GitHub and in an editor, and the command blocks are extracted and run by tests/docs/test_commands_as_written.py);
pydata-sphinx-theme as the scientific-Python projects' (numpy, scipy, xarray) theme.
"""

import turbgen

project = "turbgen"
author = "turbgen authors"
release = version = turbgen.__version__

extensions = ["sphinx.ext.autodoc", "numpydoc", "myst_parser"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "examples"]
html_theme = "pydata_sphinx_theme"
html_title = "turbgen"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}
myst_heading_anchors = 3
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
autodoc_typehints = "none"  # the numpydoc Parameters sections give types and units

