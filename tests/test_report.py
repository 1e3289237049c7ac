"""``nniquad report`` end to end: files, a verifying certificate, and report.md numbers equal to the JSON."""

from __future__ import annotations

import json

import pytest

from nniquad.certificates import load_certificate, verify_certificate
from nniquad.reporting.report import fmt


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory):
    from nniquad.cli.main import main

    out = tmp_path_factory.mktemp("report")
    # a stale file from an "earlier run" that listed it: the new run must remove it
    (out / "old_figure.png").write_bytes(b"x")
    (out / "report.json").write_text(json.dumps({"files": ["old_figure.png"]}))
    code = main(["report", "--out", str(out), "--budget", "quick", "--reruns", "0", "--roa-radius", "0"])
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
    assert sorted(p.name for p in report_dir.iterdir()) == sorted(data["files"])


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


def test_second_run_replaces_cleanly(report_dir, run_cli):
    before = json.loads((report_dir / "report.json").read_text())["files"]
    code, out, err = run_cli("report", "--out", str(report_dir), "--budget", "quick", "--reruns", "0",
                             "--roa-radius", "0")
    assert code == 0, err
    after = json.loads((report_dir / "report.json").read_text())["files"]
    assert before == after and sorted(p.name for p in report_dir.iterdir()) == sorted(after)
    assert "report.md" in out and "%" in err  # prints where everything is; progress on stderr


def test_bad_options(run_cli, tmp_path):
    code, _, err = run_cli("report", "--out", str(tmp_path / "r"), "--gamma-max", "1.2")
    assert code == 2 and "gamma" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()
