"""Sphinx configuration of the nniquad docs: the topic pages (Markdown, MyST) and the API reference generated from
the numpydoc docstrings (autodoc, autosummary, napoleon).  Build with ``make docs``; the test suite builds it with
warnings as errors (``tests/test_docs.py``)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(os.environ.get("NNIQUAD_DOCS_ROOT", Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(ROOT / "design"))  # the package folder, also without an install
os.environ.setdefault("MPLBACKEND", "Agg")

project = "nniquad"
author = "the nniquad engineers"
copyright = "2026, the nniquad engineers"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
root_doc = "index"

# the docstrings are numpydoc: napoleon reads them, without the Google style
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True

autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_mock_imports: list[str] = []

myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3

html_theme = "alabaster"
html_title = "nniquad"
templates_path = ["_templates"]
