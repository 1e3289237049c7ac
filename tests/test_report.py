"""``nniquad report`` end to end: files, a verifying certificate, and report.md numbers equal to the JSON."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nniquad.certificates import canonical_digest, load_certificate, read_certificate, verify_certificate
from nniquad.reporting.folder import MANIFEST, MANIFEST_MARKER, file_digest
from nniquad.jobs.report_sections import fmt

#: One xdist worker runs this module: its module fixture runs a whole report (audit, bound, paper-gain runs, a tune,
#: a certificate with both reference runs and the sampled cascade section, verification, figures), built once.
pytestmark = pytest.mark.xdist_group("test_report")

COMMITTED = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"
#: A committed certificate of another design (the cascade class): the second run reports on it.
OTHER = COMMITTED.with_name("cascade_model_certificate.json")
QUICK = ["--budget", "quick", "--reruns", "0", "--roa-radius", "0", "--nominal"]  # the robust default is tested in test_robust_objective


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    from nniquad.cli.main import main

    out = tmp_path_factory.mktemp("report")
    # an earlier run's folder: a stale figure it wrote (in its manifest, unchanged) must go,
    # a file of the user's must stay
    (out / "old_figure.png").write_bytes(b"x")
    (out / MANIFEST).write_text(json.dumps({"marker": MANIFEST_MARKER,
                                            "files": {"old_figure.png": file_digest(out / "old_figure.png")}}))
    (out / "notes.txt").write_text("the user's notes\n")
    # tuned on the reduced model (seconds, where the full model's quick tune takes 20 s): the report passes the model
    # on to the tuner and the certificate builder and nothing else (test_vehicles runs `certify --model full`)
    code = main(["report", "--out", str(out), *QUICK, "--model", "reduced"])
    assert code == 0
    return out


def test_every_listed_file_exists_and_nothing_stale(report_dir):
    data = json.loads((report_dir / "report.json").read_text())
    for name in ("report.md", "report.json", "certificate.json", "audit.json", "audit.md", "paper_gains.png",
                 "certified_gains.png"):
        assert name in data["files"]
    for name in data["files"]:
        assert (report_dir / name).is_file() and (report_dir / name).stat().st_size > 0
    assert not (report_dir / "old_figure.png").exists()
    assert sorted(p.name for p in report_dir.iterdir()) == sorted(data["files"] + ["notes.txt"])
    assert (report_dir / "notes.txt").read_text() == "the user's notes\n"
    manifest = json.loads((report_dir / MANIFEST).read_text())
    assert manifest["files"] == {n: file_digest(report_dir / n) for n in data["files"] if n != MANIFEST}


def test_certificate_verifies(report_dir):
    cert = load_certificate(report_dir / "certificate.json")
    assert verify_certificate(cert).ok


def test_report_numbers_equal_the_json_files(report_dir):
    md = (report_dir / "report.md").read_text()
    data = json.loads((report_dir / "report.json").read_text())
    cert = json.loads((report_dir / "certificate.json").read_text())
    audit = json.loads((report_dir / "audit.json").read_text())
    c = data["certified"]
    assert c["gains"]["kp"] == cert["gains"]["kp"] and c["digest"] == cert["digest"]["value"]
    assert c["performance"]["full"]["settling_s"] == cert["performance"]["full"]["settling_s"]
    assert c["ratio_to_bound"] == cert["ratio_to_bound"]
    assert data["audit"]["claims"] == len(audit["claims"])
    for claim in audit["claims"]:
        assert claim["id"] in md
    expected = [
        fmt(c["gains"]["kp"]), fmt(c["gains"]["Gamma"]), fmt(c["gains"]["delta"]), fmt(c["gamma"]),
        fmt(c["max_displacement_m"]), fmt(data["bound"]["enter_band_s"]), fmt(data["bound"]["rest_to_rest_s"]),
        fmt(cert["ratio_to_bound"]["full"]), fmt(cert["performance"]["full"]["settling_s"]),
        fmt(cert["performance"]["reduced"]["settling_s"]), cert["digest"]["value"],
        fmt(data["paper_gains"]["models"]["linear"]["settling_s"]),
    ] + [fmt(row["value"]) for row in data["tradeoffs"]]
    for text in expected:
        assert text in md, text


def _consistent(folder) -> None:
    """report.md, report.json and certificate.json of one run: the digest report.md cites is the certificate's."""
    cert = json.loads((folder / "certificate.json").read_text())
    data = json.loads((folder / "report.json").read_text())
    assert data["certified"]["digest"] == cert["digest"]["value"]
    assert cert["digest"]["value"] in (folder / "report.md").read_text()


def _holds_pid(lock, pid: int) -> bool:
    try:
        return lock.read_text(encoding="ascii").strip() == str(pid)
    except (FileNotFoundError, UnicodeDecodeError):
        return False


def test_second_run_replaces_cleanly_and_a_concurrent_run_is_refused(report_dir, run_cli):
    """A second run into the folder replaces every file it lists, and a third one started while it works is
    refused in one line.  The second run reports on a committed certificate of another design (``--certificate``:
    the fixture's run tuned and certified; this one verifies the given certificate and skips both): it writes the
    same files with other contents."""
    before = json.loads((report_dir / "report.json").read_text())["files"]
    first_digest = json.loads((report_dir / "certificate.json").read_text())["digest"]["value"]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, "-m", "nniquad", "report", "--out", str(report_dir),
                             "--certificate", str(OTHER)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        lock = report_dir.parent / f".{report_dir.name}.nniquad-lock"
        deadline = time.monotonic() + 120
        # the lock is taken when its file holds the holder's pid (created, locked, then the pid written)
        while not _holds_pid(lock, proc.pid) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _holds_pid(lock, proc.pid) and proc.poll() is None, "the first run never took the lock"
        t0 = time.perf_counter()
        code, _, err = run_cli("report", "--out", str(report_dir), *QUICK)
        assert code == 2 and "another 'nniquad report'" in err and f"pid {proc.pid}" in err, err
        assert len(err.strip().splitlines()) == 1 and time.perf_counter() - t0 < 10
        _consistent(report_dir)  # while the first run works, the old report is whole
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    after = json.loads((report_dir / "report.json").read_text())["files"]
    assert before == after and sorted(p.name for p in report_dir.iterdir()) == sorted(after + ["notes.txt"])
    assert "report.md" in out and "%" in err  # prints where everything is; progress on stderr
    _consistent(report_dir)
    # the files are the second run's: its certificate is the given one, as it was signed
    cert = json.loads((report_dir / "certificate.json").read_text())
    given = json.loads(OTHER.read_text())
    assert cert == given and cert["digest"]["value"] != first_digest
    data = json.loads((report_dir / "report.json").read_text())
    assert data["tuning"] == given["tuning"] and data["tradeoffs"] == [] and str(OTHER) in data["source"]
    assert data["certified"]["law_class"]["name"] == given["law_class"]["name"] == "cascade"
    assert sorted(p.name for p in report_dir.parent.iterdir() if p.name.startswith(f".{report_dir.name}")) == []


def test_bad_options(run_cli, tmp_path):
    code, _, err = run_cli("report", "--out", str(tmp_path / "r"), "--gamma-max", "1.2")
    assert code == 2 and "gamma" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("option", [("--budget", "quick"), ("--reruns", "0"), ("--nominal",), ("--model", "full"),
                                    ("--vehicle", "v.toml"), ("--law-class", "paper"), ("--roa-radius", "0")])
def test_a_tuning_option_is_refused_with_a_given_certificate(run_cli, tmp_path, option):
    """A report on a given certificate tunes nothing: a tuning option with it (even at its default value) is a
    mistake, refused in one line before any work, naming the option."""
    code, out, err = run_cli("report", "--out", str(tmp_path / "r"), "--certificate", str(COMMITTED), *option)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and out == "" and len(lines) == 1 and option[0] in lines[0] and "--certificate" in lines[0], err
    assert not (tmp_path / "r").exists()


def test_a_tampered_or_unreadable_given_certificate_is_refused(run_cli, tmp_path):
    """The given certificate is read like any other: a missing file is a user error (2), an edit after signing a
    failed check (1); one line each, and no report folder."""
    code, _, err = run_cli("report", "--out", str(tmp_path / "r"), "--certificate", str(tmp_path / "none.json"))
    assert code == 2 and "none.json" in err and len(err.strip().splitlines()) == 1, err
    doc = json.loads(COMMITTED.read_text())
    doc["gains"]["kp"] *= 1.01  # not re-signed
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    code, _, err = run_cli("report", "--out", str(tmp_path / "r"), "--certificate", str(tmp_path / "edited.json"))
    assert code == 1 and "digest mismatch" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "r").exists()


def test_a_given_certificate_that_does_not_verify_leaves_no_report(run_cli, tmp_path):
    """A re-signed certificate whose stated sector gamma is false passes the form check and fails the report's own
    verification: exit 1, one line naming the failed check, no report folder."""
    doc = json.loads(COMMITTED.read_text())
    doc["sector"]["gamma"] *= 0.9
    doc["digest"]["value"] = canonical_digest(doc)
    (tmp_path / "false.json").write_text(json.dumps(doc))
    code, _, err = run_cli("report", "--out", str(tmp_path / "r"), "--certificate", str(tmp_path / "false.json"))
    last = err.strip().splitlines()[-1]
    assert code == 1 and "the given certificate does not verify" in last and "sector" in last, err
    assert "Traceback" not in err and not (tmp_path / "r").exists()


@pytest.mark.parametrize("earlier_report", [False, True], ids=["first-run", "over-an-earlier-report"])
def test_a_failed_own_verification_leaves_no_files(run_cli, tmp_path, monkeypatch, earlier_report):
    """``report`` whose issued certificate fails its own verification (here the check
    ``lmi.region_of_attraction``) exits 1 with one line and writes nothing: no new folder, an earlier
    report untouched, no build folder or lock file left.  The tuner and the certificate builder are replaced by
    the committed certificate, and the audit by three of its claims (what they would compute is thrown away
    when the verification fails; the whole report runs for real in ``report_dir``); the report's own
    verification of that certificate runs for real, with the forced failure."""
    from types import SimpleNamespace

    import nniquad.jobs.report_sections as sections  # the report's module: the names it calls are replaced there
    from nniquad.certificates import certificate_gains, certificate_inner_loop, verify
    from nniquad.reporting.folder import ReportFolder

    committed = load_certificate(COMMITTED)
    stub = SimpleNamespace(gains=certificate_gains(committed), inner=certificate_inner_loop(committed), roa_radius_m=0.0,
                           to_json=lambda: {"stub": True})
    monkeypatch.setattr(sections, "tune", lambda *args, **kwargs: stub)

    built = []
    monkeypatch.setattr(sections, "build_certificate",
                        lambda *args, **kwargs: built.append(1) or read_certificate(COMMITTED))
    real_audit = sections.run_audit
    monkeypatch.setattr(sections, "run_audit",
                        lambda *args, **kwargs: real_audit(["rotation-matrix", "steady-state", "sector-bound"]))
    calls = []

    def failing_roa_check(cert, *_):
        calls.append(1)
        return verify.Check("lmi.region_of_attraction", False, "forced failure")

    monkeypatch.setattr(verify, "roa_check", failing_roa_check)
    out = tmp_path / "r"
    (tmp_path / "unrelated.txt").write_text("the user's\n")
    before = {}
    if earlier_report:
        with ReportFolder(out, ("report.md", "report.json")) as folder:
            for name in ("report.md", "report.json"):
                (folder.path / name).write_text(f"earlier {name}\n")
            folder.commit(["report.md", "report.json"])
        before = {p.name: p.read_bytes() for p in out.iterdir()}
    code, _, err = run_cli("report", "--out", str(out), *QUICK)
    assert calls and built, "the report never built or verified its certificate"
    assert code == 1, err
    last = err.strip().splitlines()[-1]
    assert "does not verify" in last and "lmi.region_of_attraction" in last and "Traceback" not in err
    if earlier_report:
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    else:
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["unrelated.txt"] + (["r"] if earlier_report else []))
