"""The report folder layer (nniquad.reporting.folder): swap in whole, lock, delete only nniquad's own files.

The expensive steps of the report are replaced by a stub writer, so every
fault here (a failed run, Ctrl-C, a concurrent run, a killed run, a forged
report.json) is tested in milliseconds; tests/test_report.py does one real
concurrent run.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import time
from pathlib import Path

import pytest

from nniquad.errors import OutputError
from nniquad.reporting.folder import MANIFEST, ReportBusyError, ReportFolder, file_digest, owned_files

OUTPUTS = ("report.md", "report.json", "certificate.json", "figure.png")


def _build(folder: ReportFolder, tag: str, names=OUTPUTS) -> None:
    """Stub of the report: every output names the run that wrote it."""
    for n in names:
        (folder.path / n).write_text(f"{tag}:{n}\n")


def _run(target: Path, tag: str, names=OUTPUTS) -> list[str]:
    with ReportFolder(target, OUTPUTS) as folder:
        _build(folder, tag, names)
        return folder.commit(names)


def _contents(target: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in target.iterdir()}


def _siblings(target: Path) -> list[str]:
    """Everything next to the target but the target itself (build folders, lock files)."""
    return sorted(p.name for p in target.parent.iterdir() if p.name != target.name)


@pytest.fixture
def target(tmp_path):
    (tmp_path / "unrelated.txt").write_text("the user's\n")  # next to the report: never touched
    return tmp_path / "out"


def test_first_and_second_run_swap_in_whole(target):
    _run(target, "one")
    first = _contents(target)
    assert set(first) == set(OUTPUTS) | {MANIFEST}
    manifest = json.loads((target / MANIFEST).read_text())
    assert manifest["files"] == {n: file_digest(target / n) for n in OUTPUTS}
    _run(target, "two", names=OUTPUTS[:3])  # the second run makes no figure
    second = _contents(target)
    assert set(second) == set(OUTPUTS[:3]) | {MANIFEST}  # the stale figure of run one is gone
    assert all(v.startswith("two:") for k, v in second.items() if k != MANIFEST)
    assert _siblings(target) == ["unrelated.txt"]  # no lock file, no build folder left


@pytest.mark.parametrize("fault", [RuntimeError("solver failed"), KeyboardInterrupt(), OSError(28, "disk full")],
                         ids=["error", "ctrl-c", "disk-full"])
def test_failed_run_leaves_the_old_folder_intact(target, fault):
    _run(target, "old")
    before = _contents(target)
    with pytest.raises(type(fault)):
        with ReportFolder(target, OUTPUTS) as folder:
            _build(folder, "new", OUTPUTS[:2])  # half of the new report is written ...
            raise fault  # ... when the run fails
    assert _contents(target) == before
    assert _siblings(target) == ["unrelated.txt"]


def test_failed_first_run_creates_nothing(target):
    with pytest.raises(RuntimeError):
        with ReportFolder(target, OUTPUTS) as folder:
            _build(folder, "new")
            raise RuntimeError("no admissible gain set")
    assert not target.exists() and _siblings(target) == ["unrelated.txt"]


def test_forged_report_json_deletes_nothing_and_a_clash_is_refused(target):
    target.mkdir()
    (target / "precious.txt").write_text("mine\n")
    (target / "report.json").write_text(json.dumps({"files": ["precious.txt"]}))  # nniquad did not write it
    with pytest.raises(OutputError, match="report.json, which nniquad did not write"):
        ReportFolder(target, OUTPUTS).__enter__()
    assert _contents(target) == {"precious.txt": "mine\n", "report.json": json.dumps({"files": ["precious.txt"]})}
    assert _siblings(target) == ["unrelated.txt"]


def test_forged_manifest_entry_for_a_changed_file_is_not_ownership(target):
    _run(target, "old")
    (target / "report.md").write_text("edited by hand\n")  # its digest no longer matches the manifest
    assert "report.md" not in owned_files(target)
    with pytest.raises(OutputError, match="report.md"):
        _run(target, "new")
    assert (target / "report.md").read_text() == "edited by hand\n"


def test_user_files_are_carried_into_the_new_folder(target):
    _run(target, "old")
    (target / "notes.txt").write_text("my notes\n")
    (target / "sub").mkdir()
    (target / "sub" / "data.csv").write_text("1,2\n")
    carried = _run(target, "new")
    assert carried == ["notes.txt", "sub"]
    assert (target / "notes.txt").read_text() == "my notes\n" and (target / "sub" / "data.csv").exists()
    assert (target / "report.md").read_text() == "new:report.md\n"


def test_a_clash_that_appears_during_the_run_keeps_the_old_folder(target):
    _run(target, "old", names=OUTPUTS[:3])
    before = _contents(target)
    with pytest.raises(OutputError, match="during the run"):
        with ReportFolder(target, OUTPUTS) as folder:
            _build(folder, "new")
            (target / "figure.png").write_text("the user's figure\n")  # created while the run worked
            folder.commit(OUTPUTS)
    assert _contents(target) == {**before, "figure.png": "the user's figure\n"}
    assert _siblings(target) == ["unrelated.txt"]


def test_a_second_run_into_the_same_folder_is_refused_at_once(target):
    _run(target, "old")
    before = _contents(target)
    with ReportFolder(target, OUTPUTS) as first:
        with pytest.raises(ReportBusyError, match=f"pid {os.getpid()}"):
            ReportFolder(target, OUTPUTS).__enter__()
        _build(first, "first")
        first.commit(OUTPUTS)
    after = _contents(target)
    assert after != before and all(v.startswith("first:") for k, v in after.items() if k != MANIFEST)
    _run(target, "third")  # the lock is free again


def _hold(target: str, ready) -> None:  # pragma: no cover - runs in a child process
    with ReportFolder(Path(target), OUTPUTS) as folder:
        _build(folder, "child")
        ready.set()
        time.sleep(60)  # "working" until killed (no shared lock to wait on: a killed waiter would wedge it)
        folder.commit(OUTPUTS)


def test_lock_across_processes_and_a_killed_holder(target):
    ctx = multiprocessing.get_context("fork")
    ready = ctx.Event()
    child = ctx.Process(target=_hold, args=(str(target), ready))
    child.start()
    try:
        assert ready.wait(30)
        t0 = time.perf_counter()
        with pytest.raises(ReportBusyError, match=f"pid {child.pid}"):
            _run(target, "parent")
        assert time.perf_counter() - t0 < 1.0  # refused, not blocked
        os.kill(child.pid, signal.SIGKILL)  # the holder dies mid-run: its lock dies with it
        child.join(10)
    finally:
        if child.is_alive():
            child.kill()
            child.join(10)
    assert not target.exists()  # the killed run never swapped anything in
    assert any(".build-" in n for n in _siblings(target))  # ... but left its build folder
    _run(target, "after")  # the next run gets the lock and removes the dead run's build folder
    assert (target / "report.md").read_text() == "after:report.md\n"
    assert _siblings(target) == ["unrelated.txt"]


@pytest.mark.parametrize("name", ["", ".", ".."])
def test_odd_targets_refused(tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(OutputError):
        ReportFolder(Path(name), OUTPUTS).__enter__()


def test_symlinked_target_refused(tmp_path):
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    with pytest.raises(OutputError, match="symbolic link"):
        ReportFolder(tmp_path / "link", OUTPUTS).__enter__()


def test_undeclared_output_is_a_bug(target):
    with pytest.raises(Exception, match="undeclared"):
        with ReportFolder(target, OUTPUTS) as folder:
            (folder.path / "surprise.txt").write_text("x")
            folder.commit(["surprise.txt"])
    assert not target.exists()
