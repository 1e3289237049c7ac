"""The one input/output layer of the project: bounded reads, checked output paths, atomic writes.

Reading (:func:`read_text_file`, :func:`parse_data`, :func:`load_data_file`)
    Every input file (a vehicle, a certificate) is read by the same function:
    only a regular file is opened (a FIFO, a device such as ``/dev/zero`` or a
    folder is refused without blocking), at most
    :data:`nniquad.config.INPUT_MAX_BYTES` are read, the bytes must be UTF-8
    text (binary and UTF-16 files are refused by name), and the JSON or TOML
    parse refuses duplicate keys, integers longer than
    :data:`nniquad.config.INPUT_MAX_INT_DIGITS` digits or beyond the float
    range, and nesting deeper than :data:`nniquad.config.INPUT_MAX_DEPTH`.
    Every problem is one line of the caller's error class
    (``VehicleError``, ``CertificateError``, ...).

Writing (:func:`check_output_path`, :func:`check_output_paths`, :func:`atomic_write_with`, :func:`output_transaction`)
    Output paths are checked before any work starts: not a folder, no file
    used as a folder on the way, not a device, and a probe file can be
    created in the nearest existing folder (root ignores permission bits, so
    only a real probe tells).  Every file is written to a temporary file in
    its folder and renamed; inside :func:`output_transaction` the renames wait
    until the whole transaction has succeeded, so a command with several
    outputs writes all of them or none.  A failed write leaves nothing behind,
    not even the folders it created.
"""

from __future__ import annotations

import codecs
import contextlib
import contextvars
import json
import os
import stat
import tempfile
import tomllib
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from nniquad.config import INPUT_MAX_BYTES, INPUT_MAX_DEPTH, INPUT_MAX_INT_DIGITS
from nniquad.errors import InputError, NniquadError, OutputError

__all__ = [
    "atomic_write_text",
    "atomic_write_json",
    "atomic_write_with",
    "output_transaction",
    "check_output_path",
    "check_output_paths",
    "check_output_folder",
    "read_text_file",
    "parse_data",
    "load_data_file",
    "format_bytes",
]


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


def _kind(mode: int) -> str:
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
            raise error(f"cannot read {what} {p}: it is {_kind(st.st_mode)}, not a regular file")
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


# ============================================================================ output paths


def _stat(p: Path) -> os.stat_result | None:
    """``os.stat`` following links; ``None`` when nothing is there (or a dangling link)."""
    try:
        return os.stat(p)
    except (FileNotFoundError, NotADirectoryError):
        return None


def _probe(folder: Path) -> None:
    """Create and delete a file in ``folder``: the only test of writability root and /proc cannot fool."""
    fd, name = tempfile.mkstemp(prefix=".nniquad-probe-", dir=folder)
    os.close(fd)
    os.unlink(name)


def _nearest_existing_folder(p: Path, option: str) -> Path:
    """The nearest existing ancestor of ``p``; an ancestor that is a file is an error."""
    for anc in [p.parent, *p.parent.parents]:
        st = _stat(anc)
        if st is None:
            try:
                os.lstat(anc)
            except (FileNotFoundError, NotADirectoryError):
                continue
            raise OutputError(f"cannot write {option} {p}: {anc} is a broken symbolic link")
        if not stat.S_ISDIR(st.st_mode):
            raise OutputError(f"cannot write {option} {p}: {anc} is {_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}, not a folder")
        return anc
    raise OutputError(f"cannot write {option} {p}: no existing folder on its path")  # pragma: no cover


def check_output_path(path: str | os.PathLike[str], *, option: str = "output") -> Path:
    """Check, before any work, that ``path`` can be written as a file; nothing is created.

    Parameters
    ----------
    path
        The output file.
    option
        The option that named it (``"--json"``), for the message.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputError
        Empty name, a folder (existing, or a name ending in ``/``), a device or
        FIFO, a file used as a folder on the way, or no permission to create a
        file in the nearest existing folder (``/proc``, a read-only mount).
    """
    raw = os.fspath(path)
    if isinstance(raw, bytes):  # pragma: no cover - the CLI gives str
        raw = os.fsdecode(raw)
    if not raw.strip():
        raise OutputError(f"{option} needs a file name, got {raw!r}")
    if "\x00" in raw:
        raise OutputError(f"{option} {raw!r}: a file name cannot contain a NUL byte")
    p = Path(raw)
    if raw.endswith(("/", os.sep)) or p.name in ("", ".", ".."):
        raise OutputError(f"{option} {raw} names a folder, expected a file name")
    try:
        st = _stat(p)
        if st is not None:
            if stat.S_ISDIR(st.st_mode):
                raise OutputError(f"{option} {p} is a folder, expected a file name")
            if not stat.S_ISREG(st.st_mode):
                raise OutputError(f"{option} {p} is {_kind(st.st_mode)}, not a regular file; refusing to replace it")
        folder = _nearest_existing_folder(p, option)
    except OSError as exc:
        raise OutputError(f"cannot write {option} {p}: {exc.strerror or exc}") from None
    _probe_or_refuse(folder, option, p)
    return p


def _probe_or_refuse(folder: Path, option: str, target: Path) -> None:
    """Refuse ``target`` (an :class:`OutputError` naming ``option``) unless a file can be created in ``folder``."""
    try:
        _probe(folder)
    except OSError as exc:
        raise OutputError(f"cannot write {option} {target}: cannot create a file in {folder} "
                          f"({exc.strerror or exc})") from None


def check_output_folder(path: str | os.PathLike[str], *, option: str = "--out") -> Path:
    """Check that ``path`` is an existing folder or can be created as one; nothing is created."""
    raw = os.fspath(path)
    if not str(raw).strip():
        raise OutputError(f"{option} needs a folder name, got {raw!r}")
    p = Path(raw)
    try:
        st = _stat(p)
        if st is not None and not stat.S_ISDIR(st.st_mode):
            raise OutputError(f"{option} {p} is {'a file' if stat.S_ISREG(st.st_mode) else _kind(st.st_mode)}, "
                              f"expected a folder")
        base = p if st is not None else _nearest_existing_folder(p, option)
    except OSError as exc:
        raise OutputError(f"cannot write {option} {p}: {exc.strerror or exc}") from None
    _probe_or_refuse(base, option, p)
    return p


def check_output_paths(items: Iterable[tuple[str, str | os.PathLike[str] | None]]) -> list[Path]:
    """Check several outputs of one command: each with :func:`check_output_path`, and no file named twice.

    Parameters
    ----------
    items
        ``(option, path)`` pairs; ``None`` paths (option not given) are skipped.
    """
    seen: dict[Path, str] = {}
    out = []
    for option, path in items:
        if path is None:
            continue
        p = check_output_path(path, option=option)
        key = Path(os.path.abspath(p))
        if key in seen:
            raise OutputError(f"{seen[key]} and {option} name the same file {p}")
        seen[key] = option
        out.append(p)
    return out


# ============================================================================ atomic writes

#: The open transaction's staged files ``(temporary, final)``, or None outside :func:`output_transaction`.
_STAGED: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar("nniquad_staged", default=None)
_CREATED: contextvars.ContextVar[list[Path] | None] = contextvars.ContextVar("nniquad_created", default=None)


def _make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return those created, outermost first."""
    missing = []
    for anc in [folder, *folder.parents]:
        if anc.exists():
            break
        missing.append(anc)
    created = []
    for anc in reversed(missing):
        try:
            anc.mkdir()
        except FileExistsError:
            continue
        created.append(anc)
    return created


def _remove_folders(created: list[Path]) -> None:
    for folder in reversed(created):
        with contextlib.suppress(OSError):
            folder.rmdir()  # only if still empty


def _mode_from_umask(tmp: Path) -> None:
    # mkstemp creates 0600; give the result the mode a plain open() would (umask applies)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)


def atomic_write_with(path: str | os.PathLike[str], writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` and rename the result onto ``path``.

    Inside :func:`output_transaction` the rename is deferred to the end of the
    transaction (all files of a command appear together, or none does).

    Parameters
    ----------
    path
        Final destination.  Its parent folder is created if needed (and removed
        again if the write fails).
    writer
        Function that writes the complete content to the temporary path it is given.

    Returns
    -------
    Path
        The final path.
    """
    target = Path(path)
    created = _make_parents(target.parent)
    staged = _STAGED.get()
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except BaseException:
        _remove_folders(created)
        raise
    os.close(fd)
    tmp = Path(tmp_name)
    done = False
    try:
        writer(tmp)
        _mode_from_umask(tmp)
        if staged is not None:
            staged.append((tmp, target))
            outer = _CREATED.get()
            if outer is not None:
                outer.extend(created)
        else:
            os.replace(tmp, target)
        done = True
    finally:
        if not done:
            with contextlib.suppress(OSError):
                tmp.unlink()
            _remove_folders(created)
    return target


@contextlib.contextmanager
def output_transaction() -> Iterator[list[tuple[Path, Path]]]:
    """All files written by :func:`atomic_write_with` inside appear at the end, together, or not at all.

    On an exception (or Ctrl-C) inside the block every staged temporary file
    and every folder the writes created is removed, and the exception goes on.
    A nested transaction joins the outer one.

    Yields
    ------
    list
        The staged ``(temporary, final)`` pairs (for inspection).
    """
    if _STAGED.get() is not None:
        yield _STAGED.get()  # type: ignore[misc]
        return
    staged: list[tuple[Path, Path]] = []
    created: list[Path] = []
    t1, t2 = _STAGED.set(staged), _CREATED.set(created)
    committed = 0
    try:
        try:
            yield staged
        finally:
            _STAGED.reset(t1)
            _CREATED.reset(t2)
        for tmp, target in staged:
            os.replace(tmp, target)
            committed += 1
    finally:
        for tmp, _ in staged[committed:]:
            with contextlib.suppress(OSError):
                tmp.unlink()
        if committed < len(staged):
            _remove_folders(created)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_with(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def atomic_write_json(path: str | os.PathLike[str], data: Any) -> Path:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    text = json.dumps(data, indent=2, sort_keys=False, allow_nan=False) + "\n"
    return atomic_write_text(path, text)
