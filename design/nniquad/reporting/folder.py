"""The report folder: built aside, swapped in whole, locked against a concurrent run.

:class:`ReportFolder` is the only code that touches a report's ``--out``
folder.  Its rules:

* **One run at a time.**  An exclusive ``fcntl.flock`` on the lock file
  ``.<name>.nniquad-lock`` next to the folder is taken before any work; a second
  run into the same folder is refused at once (exit status 2), naming the
  process that holds the lock.  The lock dies with its process, so a killed
  run never blocks the next one.
* **Built aside, swapped in whole.**  The run writes into a fresh
  ``.<name>.build-XXXX`` folder beside the target.  Only when everything is
  written does :meth:`ReportFolder.commit` swap it in with two renames, so the
  folder holds either the old report or the new one, never a mix.  A failed
  or interrupted run removes its build folder and leaves the old folder as
  it was.
* **Only nniquad's own files are ever deleted.**  Every report folder carries
  :data:`MANIFEST` (``manifest.json``): a marker and the SHA-256 of every file
  the run wrote.  A later run deletes an old file only if the manifest lists
  it and its content still has that digest.  Any other entry (a file of the
  user's, a file the user edited) is moved into the new folder unchanged; if
  such an entry has the name of a report output, the run is refused before
  it starts, so nothing of the user's is ever overwritten.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Any, Iterable

from nniquad.errors import NniquadError, OutputError
from nniquad.io import atomic_write_json

__all__ = ["ReportFolder", "ReportBusyError", "MANIFEST", "MANIFEST_MARKER", "file_digest", "owned_files"]

#: Name of the manifest inside every report folder.
MANIFEST = "manifest.json"
#: Marker stored in the manifest: the folder was written by ``nniquad report``.
MANIFEST_MARKER = "nniquad report folder"
_BUILD = ".build-"
_LOCK = ".nniquad-lock"
_BUILDING = ".nniquad-building"


class ReportBusyError(OutputError):
    """Another ``nniquad report`` is writing into the same folder."""


def file_digest(path: Path) -> str:
    """SHA-256 (hex) of a file's content."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def owned_files(folder: Path) -> dict[str, str]:
    """Files of ``folder`` that nniquad wrote and nobody changed since: name -> digest.

    A file counts only if the folder's :data:`MANIFEST` carries the marker,
    lists the file, and the file's current SHA-256 equals the listed one.  A
    missing or malformed manifest owns nothing.
    """
    try:
        with open(folder / MANIFEST, "rb") as fh:
            manifest = json.loads(fh.read(1 << 20))
    except (OSError, ValueError):
        return {}
    if not isinstance(manifest, dict) or manifest.get("marker") != MANIFEST_MARKER:
        return {}
    files = manifest.get("files")
    if not isinstance(files, dict):
        return {}
    owned = {}
    for name, digest in files.items():
        if not (isinstance(name, str) and isinstance(digest, str)) or "/" in name or name in ("", ".", ".."):
            continue
        p = folder / name
        try:
            if stat.S_ISREG(os.lstat(p).st_mode) and file_digest(p) == digest:
                owned[name] = digest
        except OSError:
            continue
    if owned:
        owned[MANIFEST] = ""  # the manifest itself goes with the files it describes
    return owned


class ReportFolder:
    """Lock, build aside and swap in one report folder (see the module docstring).

    Parameters
    ----------
    target
        The ``--out`` folder (need not exist).
    outputs
        Every file name the report may write (top level of the folder).

    Examples
    --------
    >>> with ReportFolder(out, outputs) as folder:   # doctest: +SKIP
    ...     write_everything_into(folder.path)
    ...     folder.commit(names_written)
    """

    def __init__(self, target: str | os.PathLike[str], outputs: Iterable[str]) -> None:
        self.shown = Path(target)
        self.outputs = set(outputs) | {MANIFEST}
        self.target = Path(os.path.abspath(self.shown))
        self.parent = self.target.parent
        self.name = self.target.name
        self.path: Path | None = None
        self._lock_fd: int | None = None
        self._lock_path = self.parent / f".{self.name}{_LOCK}"
        self._committed = False

    # ------------------------------------------------------------------ enter / exit

    def __enter__(self) -> "ReportFolder":
        self._refuse_odd_targets()
        self._acquire_lock()
        try:
            self._check_old_folder()
            self._remove_stale_builds()
            self.path = Path(tempfile.mkdtemp(prefix=f".{self.name}{_BUILD}", dir=self.parent))
            (self.path / _BUILDING).write_text(f"{os.getpid()}\n", encoding="ascii")
        except BaseException:
            self._release_lock()
            raise
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        try:
            if self.path is not None and self.path.exists():
                shutil.rmtree(self.path, ignore_errors=True)  # only the build folder: nniquad's own files
        finally:
            self._release_lock()

    # ------------------------------------------------------------------ checks

    def _refuse_odd_targets(self) -> None:
        if self.name in ("", ".", "..") or self.target == Path(self.target.anchor):
            raise OutputError(f"--out {self.shown} must name a folder of its own")
        cwd = Path(os.getcwd()).resolve()
        real = self.target.resolve()
        if real == cwd or real in cwd.parents:
            raise OutputError(f"--out {self.shown} is the current folder or one of its parents; "
                              f"give the report a folder of its own")
        if self.target.is_symlink():
            raise OutputError(f"--out {self.shown} is a symbolic link; give the folder it points to")
        if self.target.exists() and not self.target.is_dir():
            raise OutputError(f"--out {self.shown} is a file, expected a folder")

    def _acquire_lock(self) -> None:
        for _ in range(10):
            try:
                fd = os.open(self._lock_path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o644)
            except OSError as exc:
                raise OutputError(f"cannot lock --out {self.shown}: {exc.strerror or exc}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                holder = _read_pid(fd)
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise ReportBusyError(
                        f"another 'nniquad report'{f' (pid {holder})' if holder else ''} is writing into "
                        f"{self.shown}; wait for it to finish or choose another --out") from None
                raise OutputError(f"cannot lock --out {self.shown}: {exc.strerror or exc}") from None
            # the holder before us may have unlinked the file after we opened it: lock the file on disk
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self._lock_path))
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode("ascii"))
                self._lock_fd = fd
                return
            os.close(fd)
        raise OutputError(f"cannot lock --out {self.shown}: the lock file keeps changing")  # pragma: no cover

    def _release_lock(self) -> None:
        if self._lock_fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self._lock_path)  # before unlocking: a waiter re-checks the file it locked
        os.close(self._lock_fd)
        self._lock_fd = None

    def _check_old_folder(self) -> None:
        if not self.target.is_dir():
            return
        owned = owned_files(self.target)
        clash = sorted(n for n in os.listdir(self.target) if n in self.outputs and n not in owned)
        if clash:
            raise OutputError(
                f"--out {self.shown} holds {clash[0]}, which nniquad did not write (or which was changed since); "
                f"move it away or choose another folder - nothing was changed")

    def _remove_stale_builds(self) -> None:
        """Build folders of runs that died (we hold the lock, so none is in use)."""
        prefix = f".{self.name}{_BUILD}"
        for entry in os.listdir(self.parent):
            p = self.parent / entry
            if entry.startswith(prefix) and p.is_dir() and not p.is_symlink() and (p / _BUILDING).is_file():
                shutil.rmtree(p, ignore_errors=True)

    # ------------------------------------------------------------------ commit

    def commit(self, files: Iterable[str]) -> list[str]:
        """Write the manifest of ``files`` (names in the build folder) and swap the build folder in.

        Returns
        -------
        list
            The names of the entries carried over from the old folder (not written by nniquad).
        """
        if self.path is None or self._lock_fd is None:
            raise NniquadError("ReportFolder.commit outside its 'with' block")  # pragma: no cover
        names = sorted(set(files) | {MANIFEST})
        unknown = [n for n in names if n not in self.outputs]
        if unknown:
            raise NniquadError(f"report wrote an undeclared file {unknown[0]!r}")  # a bug, caught by the tests

        digests = {n: file_digest(self.path / n) for n in names if n != MANIFEST}
        atomic_write_json(self.path / MANIFEST, {"marker": MANIFEST_MARKER, "files": digests})
        (self.path / _BUILDING).unlink()
        carried: list[str] = []
        old = None
        if self.target.is_dir():
            owned = owned_files(self.target)
            carried = sorted(n for n in os.listdir(self.target) if n not in owned)
            clash = [n for n in carried if n in self.outputs]
            if clash:  # appeared during the run: the user's file wins, the new report is dropped
                raise OutputError(f"--out {self.shown}: {clash[0]} was created or changed there during the run; "
                                  f"the old folder is left as it was")
            for n in carried:  # the user's entries go into the new folder, untouched
                os.rename(self.target / n, self.path / n)
            old = Path(tempfile.mkdtemp(prefix=f".{self.name}.old-", dir=self.parent))
            try:
                os.rename(self.target, old / self.name)
            except BaseException:
                for n in carried:
                    os.rename(self.path / n, self.target / n)
                old.rmdir()
                raise
        try:
            os.rename(self.path, self.target)
        except BaseException:
            if old is not None:
                os.rename(old / self.name, self.target)
                for n in carried:
                    os.rename(self.path / n, self.target / n)
                old.rmdir()
            raise
        self.path = None
        self._committed = True
        if old is not None:
            previous = old / self.name
            for n in os.listdir(previous):  # only nniquad's verified files are left in it
                with contextlib.suppress(OSError):
                    (previous / n).unlink()
            with contextlib.suppress(OSError):
                previous.rmdir()
                old.rmdir()
        return carried


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else None
    except OSError:
        return None
