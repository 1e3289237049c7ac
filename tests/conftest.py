"""Shared fixtures."""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

#: Set by the controlling process for this session (before xdist starts its workers, which inherit it).
_SESSION_CACHE = "NNIQUAD_TEST_SESSION_CACHE"


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
def shared_json(tmp_path_factory, worker_id):
    """``shared_json(name, make)``: the JSON document ``make()`` returns, built once for the whole test session.

    Expensive inputs (a certificate with its cascade section takes 10-20 s) are built by the first pytest-xdist
    worker that asks and read by the others: the document is written atomically into the session's shared
    temporary folder under an exclusive ``flock``, so the others wait for it instead of building it again.  Only
    JSON crosses workers, which is also how a certificate travels between machines.
    """
    import fcntl
    import json
    import os

    root = tmp_path_factory.getbasetemp()
    if worker_id != "master":
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
