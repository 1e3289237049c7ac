"""``nniquad simulate``: outputs, files, certificates and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest


def test_simulate_writes_json_trajectory_and_plot(run_cli, tmp_path):
    js, png = tmp_path / "run.json", tmp_path / "run.png"
    code, out, err = run_cli("simulate", "--model", "reduced", "--horizon", "5", "--json", str(js), "--plot", str(png))
    assert code == 0, err
    assert "settling time" in out and "peak tilt" in out
    assert "[simulate]" in err and "done" in err  # start/end progress lines
    data = json.loads(js.read_text())
    for key in ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "horizon_s", "trajectory"):
        assert key in data
    assert data["horizon_s"] == pytest.approx(5.0)
    assert data["gains"]["kp"] == 5.0 and data["gains"]["Gamma"] == 160.0 and data["gains"]["delta"] == 0.6
    assert data["peak_tilt_deg"] == pytest.approx(30.0, abs=1e-9)
    traj = tmp_path / "run.traj.npz"
    assert data["trajectory"] == str(traj)
    with np.load(traj) as t:
        assert t["state"].shape[0] == 501 and t["t"][-1] == pytest.approx(5.0)
    assert png.stat().st_size > 10_000
    assert not list(tmp_path.glob("*.tmp"))


def test_simulate_full_csv_and_gains(run_cli, tmp_path):
    csv = tmp_path / "traj.csv"
    code, out, err = run_cli("simulate", "--model", "full", "--horizon", "1", "--kp", "8", "--Gamma", "12",
                             "--delta", "0.3", "--noise", "0.01", "--rate", "50", "--wind", "0.1", "0",
                             "--motor-lag", "--trajectory", str(csv))
    assert code == 0, err
    assert "kp=8" in out and "Gamma=12" in out
    header = csv.read_text().splitlines()[0].split(",")
    assert header[0] == "t" and "out_w1" in header


def _signed(body: dict) -> str:
    """A certificate-shaped document with a valid digest (only the form is checked by simulate)."""
    from nniquad.certificates.certificate import SCHEMA, SCHEMA_VERSION, canonical_digest

    doc = {"schema": SCHEMA, "schema_version": SCHEMA_VERSION, **body}
    doc["digest"] = {"algorithm": "sha256", "value": canonical_digest(doc)}
    return json.dumps(doc)


def test_certificate_gains(run_cli, tmp_path):
    cert = tmp_path / "cert.json"
    cert.write_text(_signed({"gains": {"kp": 8.0, "Gamma": 12.0, "delta": 0.3}, "other": 1}))
    js = tmp_path / "r.json"
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "2", "--certificate", str(cert),
                             "--json", str(js))
    assert code == 0, err
    assert json.loads(js.read_text())["gains"]["Gamma"] == 12.0
    # not a complete certificate: its gains fly with the command's options, and it says so in one line
    notes = [line for line in out.splitlines() if line.startswith("certificate:")]
    assert len(notes) == 1 and "states no reference run" in notes[0] and "nothing is compared" in notes[0]
    assert json.loads(js.read_text())["certificate"]["reproduced"] is None


@pytest.mark.parametrize(
    "content, message",
    [
        ("{not json", "not valid JSON"),
        (_signed({"no": "gains"}), "no valid 'gains'"),
        (_signed({"gains": {"kp": 5, "Gamma": 160}}), "lacks 'delta'"),
        (_signed({"gains": {"kp": "fast", "Gamma": 160, "delta": 0.6}}), "kp must be a number"),
        (_signed({"gains": {"kp": -5, "Gamma": 160, "delta": 0.6}}), "kp must be positive"),
        (_signed({"gains": {"kp": 5, "Gamma": 160, "delta": 0.6}}).replace("160", "161"), "digest mismatch"),
        (json.dumps({"gains": {"kp": 5, "Gamma": 160, "delta": 0.6}}), "schema"),
    ],
)
def test_malformed_certificate(run_cli, tmp_path, content, message):
    cert = tmp_path / "bad.json"
    cert.write_text(content)
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "1", "--certificate", str(cert))
    # exit-status scheme (nniquad.cli.main): a digest mismatch is a failed check (1), the rest user errors (2)
    assert code == (1 if message == "digest mismatch" else 2)
    assert message in err and "certificate" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "args, message",
    [
        (["--horizon", "-1"], "horizon must be positive"),
        (["--noise", "-0.1"], "noise sigma must not be negative"),
        (["--rate", "0"], "rate must be positive"),
        (["--kp", "nan"], "kp must be finite"),
        (["--Gamma", "inf"], "Gamma must be finite"),
        (["--delta", "0"], "delta must be positive"),
        (["--dt", "0.001", "--output-dt", "0.0025"], "whole multiple"),
        (["--certificate", "/nonexistent/cert.json"], "cannot read certificate"),
        (["--certificate", "x.json", "--kp", "3"], "not both"),
        (["--trajectory", "out.txt"], ".npz or .csv"),
        (["--vehicle", "/nonexistent/v.toml"], "cannot read vehicle file"),
    ],
)
def test_bad_options_exit_2_with_one_line(run_cli, args, message):
    code, out, err = run_cli("simulate", "--model", "linear", "--horizon", "1", *args)
    assert code == 2
    assert message in err
    assert "Traceback" not in err
    assert len([line for line in err.strip().splitlines() if not line.startswith("[simulate]")]) == 1


def test_a_lost_vehicle_is_diverged_beside_its_loss_verdict(run_cli, tmp_path):
    """kp = 1e308 overflows the command, the rotors stop and the vehicle falls: diverged true, verdict altitude lost.

    Compared against a hand derivation: with no thrust from t = 0 the altitude is free fall, z = g t^2 / 2 (NED).
    """
    from nniquad.config import ALTITUDE_LIMIT_M
    from nniquad.model.vehicle import PAPER_VEHICLE

    js = tmp_path / "kp.json"
    code, out, err = run_cli("simulate", "--kp", "1e308", "--model", "full", "--horizon", "5", "--json", str(js))
    assert code == 0, err
    data = json.loads(js.read_text())
    assert data["failure"] == "altitude lost"  # the cause: it fell, it did not fly off
    assert data["diverged"] is True and data["metrics"]["diverged"] is True  # ... and the vehicle is lost
    assert data["altitude_lost"] is True and data["metrics"]["blew_up"] is False
    assert data["settling_s"] is None
    with np.load(data["trajectory"]) as tr:
        names = list(tr["state_names"])
        t, z = tr["t"], tr["state"][:, names.index("z")]
        xy = tr["state"][:, [names.index("x"), names.index("y")]]
    np.testing.assert_allclose(z, 0.5 * PAPER_VEHICLE.g * t**2, rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(z)) > ALTITUDE_LIMIT_M and np.all(np.isfinite(xy))  # lost by altitude, horizontally finite
    rows = {line[:26].strip(): line[26:].split() for line in out.splitlines() if len(line) > 26}
    assert rows["diverged"][0] == "yes" and rows["altitude lost"][0] == "yes"
    assert " ".join(rows["verdict"]) == "altitude lost"
