"""Writing outputs: paths checked before any work, atomic writes, all-or-none transactions.

Output paths are checked before any work starts (:func:`check_output_path`,
:func:`check_output_paths`, :func:`check_output_folder`): not a folder, no file
used as a folder on the way, not a device, and a probe file can be created in
the nearest existing folder (root ignores permission bits, so only a real probe
tells).  Every file is written to a temporary file in its folder and renamed
(:func:`atomic_write_with`); inside :func:`output_transaction` the renames wait
until the whole transaction has succeeded, so a command with several outputs
writes all of them or none.  A failed write leaves nothing behind, not even the
folders it created.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

from nniquad.errors import OutputError
from nniquad.io.reading import file_kind

__all__ = ["atomic_write_text", "atomic_write_json", "atomic_write_with", "output_transaction", "check_output_path",
           "check_output_paths", "check_output_folder"]


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
            raise OutputError(f"cannot write {option} {p}: {anc} is {file_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}, not a folder")
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
                raise OutputError(f"{option} {p} is {file_kind(st.st_mode)}, not a regular file; refusing to replace it")
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
            raise OutputError(f"{option} {p} is {'a file' if stat.S_ISREG(st.st_mode) else file_kind(st.st_mode)}, "
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
