"""Shared fixtures."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
# One BLAS thread per process, as the command line runs (nniquad.cli.main._single_threaded_blas).  The suite runs
# one xdist worker per core, and each of them starts notebook kernels and CLI subprocesses; with OpenBLAS's
# default of one thread per core, the workers' small-matrix calls spin-wait for each other's threads (the tamper
# loop took 88 s instead of 60 s on 2 cores).  Set here, before a worker imports numpy: the xdist workers,
# notebook kernels and subprocesses inherit it.  A value the user set is kept.
for _blas_threads in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_blas_threads, "1")

#: Set by the controlling process for this session (before xdist starts its workers, which inherit it).
_SESSION_CACHE = "NNIQUAD_TEST_SESSION_CACHE"
#: A folder for :func:`shared_json` kept between sessions (set by ``tests/mutation/run.py``).
_SHARED_DIR = "NNIQUAD_TEST_SHARED_DIR"


def pytest_configure(config):
    """One code cache for the whole session, in a temporary folder: never the user's cache.

    The controlling process creates it and points ``NNIQUAD_CACHE_DIR`` at it; xdist workers
    and the subprocesses the tests start inherit the variable, so the suite still builds,
    writes and loads generated code (the first test that needs a function builds it, the
    others load it), without writing to ``~/.cache/nniquad``.  ``NNIQUAD_TEST_CACHE_DIR`` names
    a folder to use instead, kept between sessions (a CI cache: the compiled simulator
    functions are then not recompiled by every session).
    """
    if hasattr(config, "workerinput") or os.environ.get(_SESSION_CACHE):
        return  # a worker: the controller's folder is already in the environment
    kept = os.environ.get("NNIQUAD_TEST_CACHE_DIR")
    folder = kept or tempfile.mkdtemp(prefix="nniquad-test-cache-")
    os.environ[_SESSION_CACHE] = folder
    os.environ["NNIQUAD_CACHE_DIR"] = folder
    if not kept:
        config._nniquad_session_cache = folder


def pytest_unconfigure(config):
    folder = getattr(config, "_nniquad_session_cache", None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def run_cli(capsys):
    """Run ``nniquad`` in-process; return (exit status, stdout, stderr)."""
    from nniquad.cli.main import main

    def _run(*argv: str):
        try:
            code = main(list(argv))
        except SystemExit as exc:  # argparse usage errors
            code = exc.code
        out, err = capsys.readouterr()
        return code, out, err

    return _run


@pytest.fixture(scope="session")
def shared_json(tmp_path_factory, pytestconfig):
    """``shared_json(name, make)``: the JSON document ``make()`` returns, built once for the whole test session.

    Expensive inputs (a certificate with its cascade section takes 10-20 s) are built by the first pytest-xdist
    worker that asks and read by the others: the document is written atomically into the session's shared
    temporary folder under an exclusive ``flock``, so the others wait for it instead of building it again.  Only
    JSON crosses workers, which is also how a certificate travels between machines.  ``NNIQUAD_TEST_SHARED_DIR``
    names a folder kept between sessions instead (``make mutation`` sets it: the documents are built once, by the
    unmutated code of mutmut's first run, and every mutant's session reads them).
    """
    import fcntl
    import json
    import os

    kept = os.environ.get(_SHARED_DIR)
    if kept:  # kept between sessions: `make mutation` builds each document once, not once per mutant
        root = Path(kept)
        root.mkdir(parents=True, exist_ok=True)
    else:
        root = tmp_path_factory.getbasetemp()
        if hasattr(pytestconfig, "workerinput"):
            root = root.parent  # shared by every worker of this session
    made: dict[str, object] = {}

    def get(name: str, make):
        if name in made:
            return json.loads(json.dumps(made[name]))
        path, lock = root / f"shared-{name}.json", root / f"shared-{name}.lock"
        with open(lock, "w") as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)
            if path.exists():
                doc = json.loads(path.read_text(encoding="utf-8"))
            else:
                doc = make()
                tmp = path.with_suffix(".tmp")
                tmp.write_text(json.dumps(doc), encoding="utf-8")
                os.replace(tmp, path)
        made[name] = doc
        return json.loads(json.dumps(doc))

    return get


def pytest_collection_modifyitems(config, items):
    """Tests grouped onto one xdist worker (``pytest.mark.xdist_group``, ``--dist loadgroup``) run first, then
    the tests marked ``slow``.

    A group is a unit of work as long as its expensive module fixture and all its tests; scheduled last, it
    would leave the other worker idle at the end of the session.  The order is the same in every worker
    (xdist requires it): grouped tests first, in collection order, then the others.
    """
    grouped = [item for item in items if item.get_closest_marker("xdist_group")]
    # then the long end-to-end tests (marked slow), then the rest: short tests fill both workers at the end,
    # instead of one long test keeping one worker busy while the other is done
    slow = [item for item in items if not item.get_closest_marker("xdist_group") and item.get_closest_marker("slow")]
    rest = [item for item in items if not item.get_closest_marker("xdist_group") and not item.get_closest_marker("slow")]
    items[:] = grouped + slow + rest
