"""C code generation of the simulation functions, with a disk cache keyed by the source hash.

A function is generated to C, compiled with ``$CC`` (default gcc) and loaded
with ``casadi.external``; the shared object is cached in :func:`cache_dir`
(:mod:`nniquad.codecache`) under a name that holds the hash of the source, the
compiler, its flags and the CasADi version, so a changed model (or parameter layout) compiles anew
and an unchanged one loads in milliseconds.  Beside it, a record (a code-cache
entry) holds the object's SHA-256: an object that does not match it, or has
none, is compiled again, never loaded.  Without a compiler, or with
``NNIQUAD_NO_JIT=1``, the CasADi VM runs the same function, with a warning.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
import warnings
from pathlib import Path

import casadi as ca

from nniquad import codecache

__all__ = ["cache_dir", "compile_function", "compile_status"]


def cache_dir() -> Path:
    """Folder of compiled simulation functions: :func:`nniquad.codecache.cache_dir` (``$NNIQUAD_CACHE_DIR``)."""
    return codecache.cache_dir()


_CFLAGS = ("-O2", "-fPIC", "-shared", "-fno-math-errno")
_COMPILE_NOTES: dict[str, str] = {}


def compile_function(fn: ca.Function) -> ca.Function:
    """C code generation + gcc, cached by the hash of the source; falls back to the CasADi VM."""
    if os.environ.get("NNIQUAD_NO_JIT"):
        _COMPILE_NOTES[fn.name()] = "vm (NNIQUAD_NO_JIT)"
        return fn
    try:
        cg = ca.CodeGenerator(f"{fn.name()}.c", {"with_header": False})
        cg.add(fn)
        src = cg.dump()
        compiler = os.environ.get("CC", "gcc")
        key = hashlib.sha256((src + compiler + " ".join(_CFLAGS) + ca.__version__).encode()).hexdigest()[:16]
        folder = codecache.writable_cache_dir()
        so = folder / f"{fn.name()}_{key}.so"
        digest = so.with_name(so.name + ".sha256")
        if not _intact(so, digest):
            with tempfile.TemporaryDirectory(dir=folder) as tmp:
                c_file = Path(tmp) / f"{fn.name()}.c"
                c_file.write_text(src)
                out = Path(tmp) / "out.so"
                # relative names: no temporary path in the object, so every build of a source is the same file
                res = subprocess.run([compiler, *_CFLAGS, c_file.name, "-o", out.name, "-lm"], cwd=tmp,
                                     capture_output=True, text=True, timeout=600)
                if res.returncode != 0:
                    raise RuntimeError(res.stderr.strip().splitlines()[-1] if res.stderr.strip() else "compile failed")
                os.replace(out, so)  # atomic: a reader sees the old file or the new one
                codecache.write_entry(digest, key, hashlib.sha256(so.read_bytes()).hexdigest().encode("ascii"))
            if not _intact(so, digest):
                raise RuntimeError(f"{so.name} changed while it was being written (another process?)")
        ext = ca.external(fn.name(), str(so))
        _COMPILE_NOTES[fn.name()] = f"compiled ({so})"
        return ext
    except Exception as exc:  # noqa: BLE001 -- any failure: run in the VM instead
        warnings.warn(f"nniquad: C compilation of {fn.name()} failed ({exc}); using the slower CasADi VM",
                      RuntimeWarning, stacklevel=2)
        _COMPILE_NOTES[fn.name()] = f"vm (compile failed: {exc})"
        return fn


def _intact(so: Path, digest: Path) -> bool:
    """Whether the shared object exists and its SHA-256 is the one recorded beside it when it was compiled.

    A truncated or damaged object, or one without its record (an older cache), is compiled again,
    never loaded.
    """
    key = so.stem.rsplit("_", 1)[-1]
    recorded = codecache.read_entry(digest, key)
    if recorded is None:
        return False
    try:
        return hashlib.sha256(so.read_bytes()).hexdigest().encode("ascii") == recorded
    except OSError:
        return False


def compile_status() -> dict[str, str]:
    """How each simulation function runs (compiled C or the CasADi VM)."""
    return dict(_COMPILE_NOTES)
