"""Atomic writes: complete file or nothing."""

from __future__ import annotations

import json
import os

import pytest

from nniquad.io import atomic_write_json, atomic_write_text, atomic_write_with


def test_atomic_write_replaces_and_uses_umask_mode(tmp_path):
    p = tmp_path / "a" / "out.json"
    atomic_write_json(p, {"x": 1})
    atomic_write_json(p, {"x": 2})
    assert json.loads(p.read_text()) == {"x": 2}
    umask = os.umask(0)
    os.umask(umask)
    assert p.stat().st_mode & 0o777 == 0o666 & ~umask


def test_failed_write_leaves_nothing_and_keeps_old(tmp_path):
    p = tmp_path / "out.txt"
    atomic_write_text(p, "old")

    def broken(tmp):
        tmp.write_text("partial")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write_with(p, broken)
    assert p.read_text() == "old"
    assert [f.name for f in tmp_path.iterdir()] == ["out.txt"]


def test_nan_is_refused_not_written(tmp_path):
    p = tmp_path / "n.json"
    with pytest.raises(ValueError):
        atomic_write_json(p, {"x": float("nan")})
    assert not p.exists()
