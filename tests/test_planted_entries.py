"""The planted bugs of ``make planted`` still match the source (a stale entry would plant nothing)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("planted", ROOT / "tests" / "mutation" / "planted.py")
planted = importlib.util.module_from_spec(_spec)
sys.modules["planted"] = planted  # dataclasses look their module up while the class is built
_spec.loader.exec_module(planted)


def _source(file: str) -> str:
    if file.startswith("proofs/"):
        return (ROOT / file).read_text()
    return (ROOT / "design" / "nniquad" / file).read_text()


@pytest.mark.parametrize("bug", planted.PLANTED, ids=lambda b: b.name)
def test_each_planted_line_occurs_once_and_the_edit_changes_it(bug):
    src = _source(bug.file)
    assert src.count(bug.old) == 1
    assert bug.new != bug.old and src.replace(bug.old, bug.new).count(bug.new) >= 1
    for test in bug.tests:
        assert (ROOT / test).is_file()


def test_a_stale_entry_is_refused_not_counted(tmp_path, monkeypatch):
    monkeypatch.setattr(planted, "BUILD", tmp_path)
    stale = planted.Planted("stale", "a line that is not there", "sim/metrics.py", "no such line", "x", ())
    with pytest.raises(LookupError, match="occurs 0 times"):
        planted.stage(stale)
