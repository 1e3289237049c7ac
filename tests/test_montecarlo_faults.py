"""Monte Carlo under faults: nothing computed is lost, nothing inconsistent is left.

Each fault is made real -- a signal to a real ``nniquad montecarlo`` process, a
worker process killed with SIGKILL or frozen with SIGSTOP, a Dask scheduler
closed, every Dask worker removed -- while a study runs.  Every test then
checks the saved file against an independent clean run: each scenario in it
is recomputed alone in this process (``run_scenarios`` of ``draw_scenario``)
and must agree exactly, the indices must be distinct, and the counts and the
``partial``/``stopped`` marks must match what is in the file.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import re
import signal
import subprocess
import sys
import threading
import time

import pytest


import nniquad.study as mc
from nniquad.errors import EXIT_STUDY_FAILED
from nniquad.progress import Progress
from test_montecarlo import MC_CERTIFICATE, build_mc_certificate

HORIZON = "2"


@pytest.fixture(scope="module")
def cert_path(tmp_path_factory, shared_json):
    """test_montecarlo's certificate of its tuned gains, built once per test session."""
    from nniquad.certificates.certificate import write_certificate

    return write_certificate(shared_json(MC_CERTIFICATE, build_mc_certificate),
                             tmp_path_factory.mktemp("mcfaults") / "cert.json")


def _study(cert_path, seed, samples, *extra):
    return ["montecarlo", "--certificate", str(cert_path), "--samples", str(samples), "--seed", str(seed),
            "--horizon", HORIZON, *extra]


def _check_saved(path, cert_path, seed, samples, kind, complete=False):
    """The file parses, is marked as it should be, and every scenario in it equals a clean run of its index."""
    from nniquad.certificates.certificate import load_certificate

    data = json.loads(path.read_text())
    idx = [r["index"] for r in data["results"]]
    assert idx == sorted(set(idx)) and all(0 <= i < samples for i in idx)
    assert data["completed"] == len(idx) and data["requested"] == samples
    if complete:
        assert data["partial"] is False and data["stopped"] is None and idx == list(range(samples))
    else:
        assert data["partial"] is True and data["stopped"]["kind"] == kind and data["stopped"]["reason"]
        assert 0 < len(idx) < samples
        assert data["summary"]["partial"] is True
    assert data["summary"]["n"] == len(idx)
    setup = mc.study_setup(load_certificate(cert_path), mc.DEFAULT_RANGES, horizon_s=float(HORIZON))
    clean = mc.run_scenarios([mc.draw_scenario(i, seed, mc.DEFAULT_RANGES, setup) for i in idx])
    assert data["results"] == json.loads(json.dumps([r.to_json() for r in clean]))
    assert not list(path.parent.glob("*.tmp")) and not list(path.parent.glob(".*.tmp"))
    return data


def _error_line(err, *needles):
    """Exactly one error line, naming the problem; no traceback."""
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("nniquad montecarlo: error: ")]
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _after_first_batch(monkeypatch, action):
    """Run ``action()`` once, right after the first batch's results arrived (the CLI's progress callback)."""
    real = Progress.count
    fired: list[float] = []

    def count(self, done, total):
        real(self, done, total)
        if not fired:
            fired.append(time.monotonic())
            action()

    monkeypatch.setattr(Progress, "count", count)
    return fired


def _pool_children():
    return [p for p in multiprocessing.active_children() if p.is_alive()]


def signal_when_ready(cmd, cwd, ready, send, start_new_session=False):
    """Run ``cmd``; once a stderr line satisfies ``ready`` (an event, never a fixed sleep) call ``send(proc)``.

    Returns ``(returncode, stdout, stderr lines)``; the process is killed if it outlives the test.
    """
    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"}, start_new_session=start_new_session)
    lines: list[str] = []
    event = threading.Event()

    def read_stderr():
        for line in proc.stderr:
            lines.append(line)
            if ready(line):
                event.set()

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    try:
        assert event.wait(120), "".join(lines)
        send(proc)
        proc.wait(timeout=60)
        out = proc.stdout.read()  # a few lines: they fit in the pipe while the process runs
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL) if start_new_session else proc.kill()
            proc.wait()
    reader.join(10)
    return proc.returncode, out, lines


def _finished_scenarios(line, samples):
    m = re.search(r"(\d+)/%d\s*$" % samples, line)
    return int(m.group(1)) if m else 0


# ----------------------------------------------------------------------------- signals


def test_catch_interrupts_turns_sigint_into_a_request_and_restores_the_handler():
    # a test runner started in the background inherits SIGINT ignored: start from Python's own handler
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        before = signal.getsignal(signal.SIGINT)
        with mc.catch_interrupts(repeat_message="") as stop:
            assert not stop.requested
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs between bytecodes; no KeyboardInterrupt must arrive
        assert stop.requested and stop.signals == 2
        assert signal.getsignal(signal.SIGINT) is before
        with pytest.raises(KeyboardInterrupt):  # outside, Ctrl-C means what it always meant
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
    finally:
        signal.signal(signal.SIGINT, inherited)


def test_double_sigint_on_a_real_process_keeps_every_finished_scenario(cert_path, tmp_path):
    """SIGINT after the first batch, SIGINT again 0.3 s later: exit 130, the partial file holds the finished ones."""
    samples, seed = 2000, 3
    js = tmp_path / "study.json"
    cmd = [sys.executable, "-m", "nniquad", *_study(cert_path, seed, samples, "--workers", "2", "--batch-size", "10",
                                                    "--json", str(js))]

    def twice(proc):
        proc.send_signal(signal.SIGINT)
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)

    code, out, lines = signal_when_ready(cmd, tmp_path, lambda line: _finished_scenarios(line, samples) > 0, twice)
    err = "".join(lines)
    assert code == 130, err
    assert "Traceback" not in err, err
    assert not js.exists()
    data = _check_saved(tmp_path / "study.partial.json", cert_path, seed, samples, "interrupted")
    assert data["completed"] % 10 == 0  # whole batches of 10 (a pool's unit of work), none half-kept
    assert "PARTIAL" in out and "interrupted" in err


def test_catch_interrupts_takes_sigterm_only_when_asked():
    """The library default leaves SIGTERM alone; the command line's set turns it into a 'terminated' request."""
    inherited = signal.getsignal(signal.SIGTERM)
    seen = []
    signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))  # stands for whatever was there
    try:
        before = signal.getsignal(signal.SIGTERM)
        with mc.catch_interrupts(repeat_message="") as stop:
            assert signal.getsignal(signal.SIGTERM) is before
        with mc.catch_interrupts(repeat_message="", signals=mc.STOP_SIGNALS) as stop:
            os.kill(os.getpid(), signal.SIGTERM)
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
        assert stop.requested and stop.signals == 2 and not seen
        assert stop.kind == "terminated" and "SIGTERM" in stop.reason  # the first signal names the stop
        assert signal.getsignal(signal.SIGTERM) is before
    finally:
        signal.signal(signal.SIGTERM, inherited)


@pytest.mark.parametrize("whom", ["process", "process group"])
def test_sigterm_on_a_real_process_keeps_every_finished_scenario(cert_path, tmp_path, whom):
    """SIGTERM after the first batch (to the process, as kill does, or to its whole group, as timeout and
    service managers do, killing the pool's workers too): exit 143, every finished scenario saved, marked."""
    samples, seed = 2000, 9
    js = tmp_path / "study.json"
    cmd = [sys.executable, "-m", "nniquad", *_study(cert_path, seed, samples, "--workers", "2", "--batch-size", "10",
                                                    "--json", str(js))]

    def send(proc):
        if whom == "process":
            proc.send_signal(signal.SIGTERM)
        else:
            os.killpg(proc.pid, signal.SIGTERM)

    code, out, lines = signal_when_ready(cmd, tmp_path, lambda line: _finished_scenarios(line, samples) > 0, send,
                                         start_new_session=True)
    err = "".join(lines)
    assert code == 143, err
    assert "Traceback" not in err, err
    assert not js.exists()  # not complete: no study file, only the partial one
    data = _check_saved(tmp_path / "study.partial.json", cert_path, seed, samples, "terminated")
    assert data["stopped"]["reason"] == "terminated (SIGTERM)"
    assert data["completed"] % 10 == 0  # whole batches of 10, none half-kept
    assert data["completed"] >= max(_finished_scenarios(ln, samples) for ln in lines)  # nothing reported is lost
    assert "PARTIAL" in out and "nniquad montecarlo: terminated;" in err


def test_second_sigint_while_writing_the_partial_file(run_cli, cert_path, tmp_path, monkeypatch):
    """The second Ctrl-C lands exactly while the partial file is written: it is ignored, the file is whole."""
    import nniquad.cli.commands.montecarlo_command as cli

    real_write = cli.atomic_write_json
    handlers = []

    def write_under_fire(path, data):
        handlers.append(signal.getsignal(signal.SIGINT))
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # the second signal is handled here, before the file is written
        return real_write(path, data)

    monkeypatch.setattr(cli, "atomic_write_json", write_under_fire)
    _after_first_batch(monkeypatch, lambda: os.kill(os.getpid(), signal.SIGINT))
    js = tmp_path / "s.json"
    code, out, err = run_cli(*_study(cert_path, 5, 40, "--workers", "1", "--json", str(js)))
    assert code == 130, err
    assert handlers and handlers[0] is not signal.default_int_handler  # the write ran under the guard
    _check_saved(tmp_path / "s.partial.json", cert_path, 5, 40, "interrupted")


# ----------------------------------------------------------------------------- local process pool


def test_local_worker_killed_saves_partial_and_names_it(run_cli, cert_path, tmp_path, monkeypatch):
    killed = []

    def kill_one():
        victim = _pool_children()[0]
        killed.append(victim.pid)
        os.kill(victim.pid, signal.SIGKILL)

    _after_first_batch(monkeypatch, kill_one)
    js = tmp_path / "s.json"
    code, out, err = run_cli(*_study(cert_path, 2, 400, "--workers", "2", "--batch-size", "5", "--json", str(js)))
    assert code == EXIT_STUDY_FAILED, err
    _error_line(err, "a local worker process died", f"pid {killed[0]}", "SIGKILL", "s.partial.json")
    assert not js.exists()
    _check_saved(tmp_path / "s.partial.json", cert_path, 2, 400, "worker")
    assert not _pool_children()


def test_frozen_local_pool_stalls_within_the_timeout(run_cli, cert_path, tmp_path, monkeypatch):
    """Both workers stopped with SIGSTOP: the study ends within --stall-timeout, no process is left behind."""
    monkeypatch.chdir(tmp_path)  # no --json: the partial file goes to the current folder
    frozen = []

    def freeze_all():
        for p in _pool_children():
            os.kill(p.pid, signal.SIGSTOP)
            frozen.append(p.pid)

    fired = _after_first_batch(monkeypatch, freeze_all)
    code, out, err = run_cli(*_study(cert_path, 6, 400, "--workers", "2", "--batch-size", "5",
                                     "--stall-timeout", "2"))
    assert fired, err
    took = time.monotonic() - fired[0]
    assert code == EXIT_STUDY_FAILED, err
    _error_line(err, "no batch finished in 2 s", "stopped making progress")
    assert 2.0 <= took < 2.0 + 8.0, took
    assert frozen and not _pool_children()  # the frozen processes were killed, not left stopped
    _check_saved(tmp_path / "montecarlo-seed6.partial.json", cert_path, 6, 400, "stalled")


@pytest.mark.parametrize("value", ["0", "-1", "nan"])
def test_stall_timeout_must_be_positive(run_cli, cert_path, tmp_path, value):
    code, out, err = run_cli(*_study(cert_path, 0, 4, "--stall-timeout", value))
    assert code == 2 and out == ""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--stall-timeout must be a positive number of seconds" in lines[0], err
    assert not list(tmp_path.iterdir())


def test_run_study_rejects_a_bad_stall_timeout_before_work():
    scenarios = ["not run"]
    for bad in (0, -2.0, math.nan, True, "soon"):
        with pytest.raises(mc.MonteCarloError, match="stall timeout"):
            mc.run_study(scenarios, workers=2, stall_timeout_s=bad)


# ----------------------------------------------------------------------------- Dask cluster


@pytest.fixture
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as c:
        yield c


def test_dask_worker_killed_is_recovered_and_nothing_is_lost(run_cli, cert_path, tmp_path, monkeypatch, cluster):
    """A Dask worker SIGKILLed mid-study: its batch runs again elsewhere; the study completes, exactly."""
    from distributed import Client

    with Client(cluster.scheduler_address, set_as_default=False) as c:
        pids = list(c.run(os.getpid).values())
    _after_first_batch(monkeypatch, lambda: os.kill(pids[0], signal.SIGKILL))
    js = tmp_path / "s.json"
    code, out, err = run_cli(*_study(cert_path, 4, 60, "--scheduler", cluster.scheduler_address,
                                     "--batch-size", "5", "--json", str(js)))
    assert code == 0, err
    with pytest.raises(ProcessLookupError):
        os.kill(pids[0], 0)  # it really died
    _check_saved(js, cert_path, 4, 60, None, complete=True)
    assert not (tmp_path / "s.partial.json").exists()


def test_dask_scheduler_lost_saves_partial_and_says_so(run_cli, cert_path, tmp_path, monkeypatch, cluster):
    _after_first_batch(monkeypatch, lambda: threading.Thread(target=cluster.close, daemon=True).start())
    js = tmp_path / "s.json"
    code, out, err = run_cli(*_study(cert_path, 7, 400, "--scheduler", cluster.scheduler_address,
                                     "--batch-size", "5", "--json", str(js)))
    assert code == EXIT_STUDY_FAILED, err
    line = _error_line(err, "lost the Dask scheduler at tcp://127.0.0.1:", "s.partial.json")
    assert "installed" not in line
    assert not js.exists()
    _check_saved(tmp_path / "s.partial.json", cert_path, 7, 400, "scheduler")


def test_dask_cluster_without_workers_stalls_within_the_timeout(run_cli, cert_path, tmp_path, monkeypatch,
                                                                cluster):
    """Every worker removed mid-study: the study ends within --stall-timeout, saying the cluster has none."""
    fired = _after_first_batch(monkeypatch, lambda: threading.Thread(target=cluster.scale, args=(0,),
                                                                     daemon=True).start())
    js = tmp_path / "s.json"
    code, out, err = run_cli(*_study(cert_path, 8, 400, "--scheduler", cluster.scheduler_address,
                                     "--batch-size", "5", "--stall-timeout", "3", "--json", str(js)))
    assert fired, err
    took = time.monotonic() - fired[0]
    assert code == EXIT_STUDY_FAILED, err
    _error_line(err, "no batch finished in 3 s", "no worker left")
    assert 3.0 <= took < 3.0 + 10.0, took
    _check_saved(tmp_path / "s.partial.json", cert_path, 8, 400, "stalled")
