"""Shared fixtures."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


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
