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


# ---------------------------------------------------------------- the shared reader, output checks, transactions

import math  # noqa: E402
import threading  # noqa: E402

from nniquad.errors import InputError, OutputError  # noqa: E402
from nniquad.io import (check_output_folder, check_output_path, check_output_paths, load_data_file,  # noqa: E402
                        output_transaction, parse_data, read_text_file)


def test_reader_returns_the_text_and_strips_a_utf8_bom(tmp_path):
    p = tmp_path / "a.json"
    p.write_bytes(b"\xef\xbb\xbf" + '{"x": "é"}'.encode())
    assert read_text_file(p) == '{"x": "é"}'
    assert load_data_file(p) == {"x": "é"}


def test_reader_bounds_the_size_read(tmp_path):
    p = tmp_path / "a.json"
    p.write_bytes(b"1" * 101)
    with pytest.raises(InputError, match="more than"):
        read_text_file(p, max_bytes=100)
    assert read_text_file(p, max_bytes=101) == "1" * 101


def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "v.toml"
    os.mkfifo(fifo)
    result = []
    t = threading.Thread(target=lambda: result.append(pytest.raises(InputError, read_text_file, fifo)), daemon=True)
    t.start()
    t.join(5)
    assert not t.is_alive(), "reading a FIFO blocked"
    assert "FIFO" in str(result[0].value)


@pytest.mark.parametrize("text, fmt, word", [
    ('{"a": 1, "a": 2}', "json", "duplicate key 'a'"),
    ("a = 1\na = 2\n", "toml", "TOML"),
    ("[" * 65 + "]" * 65, "json", "nested more than 64"),
    ("1" * 4301, "json", "4301 digits"),
    ("x = " + "1" * 5000, "toml", "digits"),
    ("1" + "0" * 309, "json", "beyond the range of a float"),
])
def test_parse_refusals(text, fmt, word):
    with pytest.raises(InputError, match=word):
        parse_data(text, fmt)


def test_parse_accepts_what_it_should():
    # the limits sit just beyond what they refuse: 64 levels, 4300 digits within the float range, 1e308
    assert parse_data("[" * 64 + "]" * 64, "json") is not None
    assert parse_data("1" + "0" * 308, "json") == 10**308
    assert math.isinf(parse_data("1e999", "json"))  # a float literal overflows to inf; the value checks refuse it


def test_output_checks_create_nothing(tmp_path):
    (tmp_path / "f").write_text("x")
    before = sorted(tmp_path.rglob("*"))
    assert check_output_path(tmp_path / "new" / "deeper" / "x.json") == tmp_path / "new" / "deeper" / "x.json"
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_output_path(tmp_path / "f" / "x.json", option="--json")
    with pytest.raises(OutputError, match="is a folder"):
        check_output_path(tmp_path, option="--json")
    with pytest.raises(OutputError, match="same file"):
        check_output_paths([("--a", tmp_path / "x"), ("--b", tmp_path / "." / "x")])
    with pytest.raises(OutputError, match="expected a folder"):
        check_output_folder(tmp_path / "f")
    assert sorted(tmp_path.rglob("*")) == before


def test_transaction_is_all_or_nothing(tmp_path):
    a, b = tmp_path / "sub" / "a.txt", tmp_path / "sub" / "b.txt"
    with pytest.raises(RuntimeError):
        with output_transaction():
            atomic_write_text(a, "A")
            assert not a.exists()  # the rename waits for the end of the transaction
            atomic_write_text(b, "B")
            raise RuntimeError("the third output failed")
    assert list(tmp_path.iterdir()) == []  # nothing staged is left, not even the folder
    with output_transaction():
        atomic_write_text(a, "A")
        atomic_write_text(b, "B")
    assert a.read_text() == "A" and b.read_text() == "B"
    assert sorted(p.name for p in (tmp_path / "sub").iterdir()) == ["a.txt", "b.txt"]


def test_failed_write_removes_the_folders_it_created(tmp_path):
    def broken(tmp):
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError):
        atomic_write_with(tmp_path / "x" / "y" / "z.txt", broken)
    assert list(tmp_path.iterdir()) == []
