"""The docs site builds without a warning (``make docs``): every topic page, the findings notes, and the API
reference generated from the numpydoc docstrings.  A docstring that breaks the reStructuredText, a page missing from
the table of contents or a broken cross-reference between pages fails here.

The tree is copied to a temporary folder first, so the stubs autosummary writes never land in the checkout.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow  # the API reference imports and documents every module (about a minute on 2 cores)
def test_the_docs_build_with_warnings_as_errors(tmp_path):
    src = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", src, ignore=shutil.ignore_patterns("_build", "api"))
    env = {**os.environ, "MPLBACKEND": "Agg", "NNIQUAD_DOCS_ROOT": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q", str(src),
                           str(tmp_path / "html")], capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    html = tmp_path / "html"
    for page in ("index", "architecture", "certificates", "cli", "export", "api", "notes/README"):
        assert (html / f"{page}.html").stat().st_size > 0, page
    # the reference documents the law interface, generated from its docstrings
    api = (html / "api" / "nniquad.laws.base.html").read_text(encoding="utf-8")
    assert "ControlLaw" in api and "realisation" in api


def test_the_readme_stays_short_and_points_to_every_page():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.encode("utf-8")) <= 12 * 1024
    pages = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").glob("*.md")
                   if p.name not in ("index.md", "api.md"))
    missing = [p for p in pages if p not in readme]
    assert missing == [], f"README.md does not point to {missing}"
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    assert all(Path(p).stem in index for p in pages)
