"""Reading input files: bounded, typed, one-line errors (:func:`read_text_file`, :func:`parse_data`,
:func:`load_data_file`).

Every input file (a vehicle, a certificate) is read by the same function: only
a regular file is opened (a FIFO, a device such as ``/dev/zero`` or a folder is
refused without blocking), at most :data:`nniquad.config.INPUT_MAX_BYTES` are
read, the bytes must be UTF-8 text (binary and UTF-16 files are refused by
name), and the JSON or TOML parse refuses duplicate keys, integers longer than
:data:`nniquad.config.INPUT_MAX_INT_DIGITS` digits or beyond the float range,
and nesting deeper than :data:`nniquad.config.INPUT_MAX_DEPTH`.  Every problem
is one line of the caller's error class (``VehicleError``, ``CertificateError``, ...).
"""

from __future__ import annotations

import codecs
import json
import os
import stat
import tomllib
from pathlib import Path
from typing import Any, Iterable

from nniquad.config import INPUT_MAX_BYTES, INPUT_MAX_DEPTH, INPUT_MAX_INT_DIGITS
from nniquad.errors import InputError, NniquadError

__all__ = ["read_text_file", "parse_data", "load_data_file", "format_bytes", "file_kind"]


def format_bytes(n: float) -> str:
    """``n`` bytes with a binary unit: ``'37.3 GiB'``."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(n) < 1024 or unit == "EiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024
    raise AssertionError("unreachable")  # pragma: no cover


# ============================================================================ reading

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def file_kind(mode: int) -> str:
    """What a ``stat`` mode is, in words (``"a folder"``, ``"a FIFO"``, ...), for one-line refusals."""
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def read_text_file(path: str | os.PathLike[str], *, what: str = "input file",
                   error: type[NniquadError] = InputError, max_bytes: int = INPUT_MAX_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes`` bytes.

    The file is opened non-blocking, so a FIFO with no writer cannot hang the
    reader; it is then refused because it is not a regular file, as is a
    device or a folder.  At most ``max_bytes + 1`` bytes are ever read (a file
    that grows while it is read is caught too).

    Parameters
    ----------
    path
        The file.
    what
        What it is, for the message ("vehicle file", "certificate").
    error
        Error class raised, with a one-line message naming ``path``.
    max_bytes
        Largest size accepted.

    Raises
    ------
    error
        Cannot be opened; not a regular file; too large; binary, UTF-16 or not UTF-8.
    """
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise error(f"cannot read {what} {p}: {exc.strerror or exc}") from None
    except ValueError as exc:  # an embedded NUL byte in the name
        raise error(f"cannot read {what} {p!r}: {exc}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise error(f"cannot read {what} {p}: it is {file_kind(st.st_mode)}, not a regular file")
        if st.st_size > max_bytes:
            raise error(f"{what} {p} is {format_bytes(st.st_size)}, more than the {format_bytes(max_bytes)} accepted")
        chunks, total = [], 0
        while total <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > max_bytes:
            raise error(f"{what} {p} is more than the {format_bytes(max_bytes)} accepted")
    except OSError as exc:
        raise error(f"cannot read {what} {p}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    return _decode(b"".join(chunks), f"{what} {p}", error)


def _decode(data: bytes, where: str, error: type[NniquadError]) -> str:
    for bom, name in ((codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
                      (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16")):
        if data.startswith(bom):
            raise error(f"{where} is {name} text; save it as UTF-8")
    if b"\x00" in data:
        # UTF-16 without a byte-order mark has a NUL in every ASCII character
        even, odd = data[0::2], data[1::2]
        z_even, z_odd = even.count(0) / max(len(even), 1), odd.count(0) / max(len(odd), 1)
        if len(data) >= 4 and max(z_even, z_odd) > 0.9 and min(z_even, z_odd) < 0.1:
            raise error(f"{where} looks like UTF-16 text (NUL bytes between the characters); save it as UTF-8")
        raise error(f"{where} is a binary file (it contains NUL bytes), not text")
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8):]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{where} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})") from None


class _Refused(Exception):
    """Raised inside the JSON hooks; turned into the caller's error class with its message."""


def _json_object(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise _Refused(f"duplicate key {key!r}")
        out[key] = value
    return out


def _json_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    if digits > INPUT_MAX_INT_DIGITS:
        raise _Refused(f"an integer has {digits} digits, more than the {INPUT_MAX_INT_DIGITS} accepted")
    return int(text)


def _check_tree(data: Any) -> str | None:
    """A problem of the parsed tree (too deep, an integer beyond the float range), else ``None``."""
    stack = [(data, 1)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children: Iterable[Any] = node.values()
        elif isinstance(node, list):
            children = node
        else:
            if isinstance(node, int) and not isinstance(node, bool) and node.bit_length() > 1024:
                return "an integer is beyond the range of a float (about 1.8e308)"
            continue
        if depth > INPUT_MAX_DEPTH:
            return f"nested more than {INPUT_MAX_DEPTH} levels deep"
        stack.extend((child, depth + 1) for child in children)
    return None


def parse_data(text: str, fmt: str, *, where: str = "input", error: type[NniquadError] = InputError) -> Any:
    """Parse JSON or TOML text with the checks of :func:`load_data_file`.

    Parameters
    ----------
    text
        The document.
    fmt
        ``"json"`` or ``"toml"``.
    where
        What and where it is, for the message ("vehicle file v.json").
    error
        Error class raised.
    """
    label = fmt.upper()
    try:
        if fmt == "json":
            data = json.loads(text, object_pairs_hook=_json_object, parse_int=_json_int)
        elif fmt == "toml":
            data = tomllib.loads(text)  # refuses duplicate keys itself
        else:
            raise ValueError(f"unknown format {fmt!r}")
    except _Refused as exc:
        raise error(f"{where} is not valid {label}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise error(f"{where} is not valid {label}: {exc.msg} (line {exc.lineno}, column {exc.colno})") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{where} is not valid {label}: {str(exc).splitlines()[0]}") from None
    except RecursionError:
        raise error(f"{where} is not valid {label}: nested too deeply "
                    f"(more than {INPUT_MAX_DEPTH} levels accepted)") from None
    except ValueError as exc:  # Python's int-to-str limit, an impossible TOML date, ...
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "digits" in msg and "integer" in msg:
            msg = "an integer has too many digits"
        raise error(f"{where} is not valid {label}: {msg}") from None
    problem = _check_tree(data)
    if problem:
        raise error(f"{where} is not valid {label}: {problem}")
    return data


def load_data_file(path: str | os.PathLike[str], *, what: str = "input file", error: type[NniquadError] = InputError,
                   formats: tuple[str, ...] = ("json", "toml"), max_bytes: int = INPUT_MAX_BYTES) -> Any:
    """Read and parse a ``.json`` or ``.toml`` file: the one reader behind every input file.

    Parameters
    ----------
    path
        The file; its extension picks the format.
    what, error, max_bytes
        As for :func:`read_text_file`.
    formats
        Formats accepted (``"json"``, ``"toml"``).

    Raises
    ------
    error
        One line naming the file and the problem.
    """
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".")
    if fmt not in formats:
        allowed = " or ".join(f".{f}" for f in formats)
        raise error(f"{what} {p}: unsupported extension '{p.suffix}' (use {allowed})")
    text = read_text_file(p, what=what, error=error, max_bytes=max_bytes)
    return parse_data(text, fmt, where=f"{what} {p}", error=error)
