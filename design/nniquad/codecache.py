"""On-disk cache of generated code: CasADi functions and sympy-lambdified numpy source.

Building the simulator's CasADi functions from the symbolic model (import
sympy, derive, ``lambdify`` onto ``SX``, Jacobians) costs seconds in every new
process, although the result depends only on the source that generates it.
This module keeps that *code* between processes; it never keeps a result: a
cached function is the same sequence of operations the builder would produce
(``casadi.Function.serialize``), evaluated afresh on every call.

Where
    :func:`cache_dir`: ``$NNIQUAD_CACHE_DIR`` when set, else the user cache
    folder (``platformdirs``; ``~/.cache/nniquad`` on Linux).  CasADi functions
    live in ``casadi/``, lambdified numpy source in ``numpy/``, the compiled C
    of :mod:`nniquad.sim.codegen` at the top.  ``NNIQUAD_NO_CODE_CACHE=1``
    builds everything afresh and neither reads nor writes.

Key
    SHA-256 of the entry's name and arguments, the Python implementation and
    version, the machine, the versions of CasADi, sympy and numpy, and the
    source of every module of the ``nniquad`` package (:func:`source_digest`),
    with the source files added by :func:`add_source` (a control law registered
    from outside the package: its realisation generates the simulator's code).
    Hashing the whole package costs milliseconds and cannot miss a module that
    takes part in generating a function; any edit therefore rebuilds once.

Trust
    An entry is a header (format, full key, SHA-256 of the payload) and the
    payload.  It is used only when the header's key equals the wanted key and
    the payload's hash matches; a truncated, corrupt or foreign file is
    rebuilt and replaced, never loaded.  Writes go to a temporary file in the
    same folder, then ``os.replace``: two processes writing one entry at once
    leave one complete entry, and a reader never sees a partial file.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import platform
import sys
import tempfile
import threading
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Mapping, TypeVar

__all__ = ["ENV_DIR", "ENV_DISABLE", "cache_dir", "writable_cache_dir", "enabled", "source_digest", "add_source",
           "entry_key",
           "read_entry", "write_entry", "cached_casadi_function", "cached_numpy_functions", "clear_memory",
           "STATS"]

#: Environment variable that overrides the cache folder (tests point it at a temporary folder).
ENV_DIR = "NNIQUAD_CACHE_DIR"
#: Environment variable that turns the code cache off (``1``): every function is built afresh.
ENV_DISABLE = "NNIQUAD_NO_CODE_CACHE"

_FORMAT = "nniquad-code-cache 1"
_PACKAGE_ROOT = Path(__file__).resolve().parent

F = TypeVar("F", bound=Callable[..., Any])


@dataclass
class CacheStats:
    """Counts of this process's cache lookups (for tests and ``--verbose`` diagnostics).

    Attributes
    ----------
    hits
        Entries loaded from disk.
    misses
        Entries not on disk (built, then written).
    rejected
        Entries on disk that failed the header, key or checksum test, or did not
        load (built afresh, then replaced).
    """

    hits: int = 0
    misses: int = 0
    rejected: int = 0

    def reset(self) -> None:
        """Set every count to zero."""
        self.hits = self.misses = self.rejected = 0


#: This process's counts.
STATS = CacheStats()


def cache_dir() -> Path:
    """Cache folder: ``$NNIQUAD_CACHE_DIR``, else the user cache folder of ``nniquad`` (platformdirs)."""
    env = os.environ.get(ENV_DIR)
    if env:
        return Path(env)
    import platformdirs

    return Path(platformdirs.user_cache_dir("nniquad", appauthor=False))


def writable_cache_dir(sub: str = "") -> Path:
    """:func:`cache_dir` (or its subfolder ``sub``), created; a private temp folder if it cannot be written.

    Parameters
    ----------
    sub
        Subfolder name (``""`` for the cache folder itself).
    """
    folder = cache_dir() / sub if sub else cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not os.access(folder, os.W_OK):
            raise PermissionError(str(folder))
    except OSError:  # read-only home (CI sandboxes): a private temp folder instead
        uid = os.getuid() if hasattr(os, "getuid") else 0
        folder = Path(tempfile.gettempdir()) / f"nniquad-cache-{uid}" / sub
        folder.mkdir(parents=True, exist_ok=True)
    return folder


def enabled() -> bool:
    """Whether the code cache is used (``NNIQUAD_NO_CODE_CACHE`` unset or ``0``)."""
    return os.environ.get(ENV_DISABLE, "") in ("", "0")


#: Source files outside the package that take part in generating code (:func:`add_source`).
_EXTRA_SOURCES: set[Path] = set()


def add_source(path: str | os.PathLike[str]) -> None:
    """Make a source file outside the package part of every key (:func:`source_digest`): an edit of it rebuilds.

    Parameters
    ----------
    path
        The file (a control law's module registered from outside ``nniquad``).
    """
    p = Path(path).resolve()
    if _PACKAGE_ROOT not in p.parents:
        _EXTRA_SOURCES.add(p)


@functools.lru_cache(maxsize=1)
def _package_digest() -> str:
    h = hashlib.sha256()
    for path in sorted(_PACKAGE_ROOT.rglob("*.py")):
        h.update(path.relative_to(_PACKAGE_ROOT).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    return h.hexdigest()


def source_digest() -> str:
    """SHA-256 over the relative path and bytes of every ``.py`` file of the ``nniquad`` package (read once per
    process), and of the files added by :func:`add_source` (their absolute paths)."""
    if not _EXTRA_SOURCES:
        return _package_digest()
    h = hashlib.sha256(_package_digest().encode())
    for path in sorted(_EXTRA_SOURCES):
        h.update(path.as_posix().encode() + b"\0")
        h.update((path.read_bytes() if path.is_file() else b"") + b"\0")
    return h.hexdigest()


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "absent"


@functools.lru_cache(maxsize=1)
def _environment() -> str:
    return "|".join([
        _FORMAT, sys.implementation.name, sys.version, platform.machine(),
        *(f"{d}={_version(d)}" for d in ("casadi", "sympy", "numpy")),
    ])


def entry_key(name: str, args: tuple = ()) -> str:
    """The full key (hex SHA-256) of entry ``name`` built with ``args``.

    Parameters
    ----------
    name
        Entry name (the builder's module and qualified name).
    args
        The builder's arguments, defaults applied (their ``repr`` enters the key).
    """
    h = hashlib.sha256()
    for part in (_environment(), source_digest(), name, repr(tuple(args))):
        h.update(part.encode() + b"\0")
    return h.hexdigest()


def _entry_path(kind: str, name: str, args: tuple, key: str, suffix: str) -> Path:
    readable = "_".join([name.rsplit(".", 1)[-1], *(str(a) for a in args)])
    readable = "".join(c if c.isalnum() or c in "_-" else "-" for c in readable)[:80]
    return writable_cache_dir(kind) / f"{readable}-{key[:20]}{suffix}"


def read_entry(path: Path, key: str) -> bytes | None:
    """The payload of a cache file whose header names ``key`` and whose checksum matches; else ``None``.

    ``None`` for a missing file too; :data:`STATS` counts a present but invalid
    file as rejected.

    Parameters
    ----------
    path
        The cache file.
    key
        The full key the entry must have been written for.
    """
    try:
        data = path.read_bytes()
    except OSError:
        STATS.misses += 1
        return None
    header, sep, payload = data.partition(b"\n\n")
    lines = header.decode("ascii", "replace").split("\n")
    ok = (sep == b"\n\n" and len(lines) == 3 and lines[0] == _FORMAT and lines[1] == f"key {key}"
          and lines[2] == f"sha256 {hashlib.sha256(payload).hexdigest()}")
    if not ok:
        STATS.rejected += 1
        return None
    return payload


def write_entry(path: Path, key: str, payload: bytes) -> None:
    """Write ``payload`` under ``key`` atomically (temporary file in the same folder, then ``os.replace``).

    A failure to write (disk full, read-only folder) is ignored: the cache is an
    optimisation, the caller already holds the built code.

    Parameters
    ----------
    path, key
        As for :func:`read_entry`.
    payload
        The bytes to keep.
    """
    header = f"{_FORMAT}\nkey {key}\nsha256 {hashlib.sha256(payload).hexdigest()}\n\n".encode("ascii")
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            fh.write(header + payload)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError:
        pass
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


# ----------------------------------------------------------------------------- the two kinds of entry

_MEMORY: dict[tuple[str, tuple], Any] = {}
_LOCK = threading.Lock()


def clear_memory() -> None:
    """Forget the functions held in this process (the next call loads from disk or builds)."""
    with _LOCK:
        _MEMORY.clear()


def _bound_args(fn: Callable[..., Any], args: tuple, kwargs: Mapping[str, Any]) -> tuple:
    bound = inspect.signature(fn).bind(*args, **kwargs)
    bound.apply_defaults()
    return tuple(bound.arguments.values())


def cached_casadi_function(builder: F) -> F:
    """Decorate a builder of a :class:`casadi.Function`: kept in memory and on disk.

    The builder must be a pure function of its (hashable, ``repr``-stable)
    arguments and of the ``nniquad`` source.  In a process the first call per
    argument set loads the serialized function (:mod:`module docstring <nniquad.codecache>`)
    or builds and stores it; later calls return the same object.
    """
    name = f"{builder.__module__}.{builder.__qualname__}"

    @functools.wraps(builder)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        call = _bound_args(builder, args, kwargs)
        mem_key = (name, call)
        with _LOCK:
            if mem_key in _MEMORY:
                return _MEMORY[mem_key]
        fn = _load_or_build_casadi(name, call, lambda: builder(*call))
        with _LOCK:
            return _MEMORY.setdefault(mem_key, fn)

    return wrapper  # type: ignore[return-value]


def _load_or_build_casadi(name: str, call: tuple, build: Callable[[], Any]) -> Any:
    import casadi as ca

    if not enabled():
        return build()
    key = entry_key(name, call)
    path = _entry_path("casadi", name, call, key, ".casadi")
    payload = read_entry(path, key)
    if payload is not None:
        try:
            fn = ca.Function.deserialize(payload.decode("utf-8"))
            STATS.hits += 1
            return fn
        except Exception:  # noqa: BLE001 -- a payload CasADi refuses is rebuilt like a corrupt one
            STATS.rejected += 1
    fn = build()
    write_entry(path, key, fn.serialize().encode("utf-8"))
    return fn


def cached_numpy_functions(name: str, build: Callable[[], Mapping[str, Callable[..., Any]]]
                           ) -> dict[str, Callable[..., Any]]:
    """Functions generated by ``sympy.lambdify(..., modules="numpy")``, kept as source on disk.

    ``build`` returns a mapping name -> lambdified function.  Each function's
    source is stored and, in a later process, compiled again in a namespace of
    numpy's attributes only.  A function whose source names anything other than
    numpy attributes and builtins (bound identically in the lambdify namespace)
    is not stored: the next process builds the whole mapping afresh.

    Parameters
    ----------
    name
        Entry name.
    build
        Builder of the mapping (imports sympy; called only on a miss).
    """
    with _LOCK:
        if (name, ()) in _MEMORY:
            return _MEMORY[(name, ())]
    funcs = _load_or_build_numpy(name, build)
    with _LOCK:
        return _MEMORY.setdefault((name, ()), funcs)


_SEPARATOR = "\n# ---- nniquad codecache: "


def _load_or_build_numpy(name: str, build: Callable[[], Mapping[str, Callable[..., Any]]]
                         ) -> dict[str, Callable[..., Any]]:
    if not enabled():
        return dict(build())
    key = entry_key(name)
    path = _entry_path("numpy", name, (), key, ".py.txt")
    payload = read_entry(path, key)
    if payload is not None:
        try:
            funcs = _compile_sources(payload.decode("utf-8"))
            STATS.hits += 1
            return funcs
        except Exception:  # noqa: BLE001 -- a payload that does not compile is rebuilt
            STATS.rejected += 1
    funcs = dict(build())
    sources = []
    for fname, fn in funcs.items():
        portable = _portable_source(fn)
        if portable is None:
            return funcs  # not storable: keep building afresh
        src, numpy_names = portable
        sources.append(f"{_SEPARATOR}{fname} {','.join(sorted(numpy_names))}\n{src}")
    write_entry(path, key, "".join(sources).encode("utf-8"))
    return funcs


def _names(code: Any) -> set[str]:
    out = set(code.co_names)
    for const in code.co_consts:
        if inspect.iscode(const):
            out |= _names(const)
    return out


def _portable_source(fn: Callable[..., Any]) -> tuple[str, set[str]] | None:
    """The source of a lambdified function and the global names it binds to numpy attributes.

    ``None`` when a global name is bound to anything else than a numpy attribute
    (or the ``numpy`` module itself), or is neither bound nor a builtin.
    """
    import builtins

    import numpy as np

    try:
        src = inspect.getsource(fn)
    except (OSError, TypeError):
        return None
    glb = getattr(fn, "__globals__", {})
    numpy_names = set()
    for n in _names(fn.__code__):
        if n not in glb:
            if hasattr(builtins, n):
                continue
            return None  # an attribute name not resolvable here: be safe
        if n == "numpy" and glb[n] is np:
            continue
        if glb[n] is not getattr(np, n, object()):
            return None
        numpy_names.add(n)
    return src, numpy_names


def _compile_sources(text: str) -> dict[str, Callable[..., Any]]:
    import numpy as np

    funcs: dict[str, Callable[..., Any]] = {}
    for chunk in text.split(_SEPARATOR)[1:]:
        head, _, src = chunk.partition("\n")
        fname, _, names = head.partition(" ")
        namespace: dict[str, Any] = {n: getattr(np, n) for n in names.split(",") if n}
        namespace["numpy"] = np
        before = set(namespace)
        exec(compile(src, f"<nniquad codecache {fname}>", "exec"), namespace)  # noqa: S102 -- checksummed, keyed
        (new,) = [namespace[k] for k in namespace if k not in before and k != "__builtins__"]
        if not inspect.isfunction(new):
            raise ValueError(f"entry {fname} does not define a function")
        funcs[fname] = new
    if not funcs:
        raise ValueError("empty entry")
    return funcs
