"""Certificates: written, verified, and every tampering caught."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from nniquad.certificates import (SCHEMA_VERSION, Certificate, build_certificate, canonical_digest, load_certificate,
                                  read_certificate, verify_certificate, write_certificate)
from nniquad.errors import CertificateError
from nniquad.control.gains import InnerLoopGains
from nniquad.control.gains import Gains
from nniquad.model.vehicle import PAPER_VEHICLE as V

# a gain set found by `nniquad tune --model full --roa-radius 0` (it only has to be certifiable here)
GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)


@pytest.fixture(scope="module")
def certificate() -> Certificate:
    return build_certificate(V, GAINS, inner=INNER, model="full")


@pytest.fixture(scope="module")
def cert(certificate) -> dict:
    """The certificate's JSON document (what the tamper tests edit)."""
    return certificate.to_json()


def _resign(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def test_certificate_verifies_and_states_independent_numbers(cert, tmp_path):
    path = write_certificate(cert, tmp_path / "c.json")
    res = verify_certificate(path)
    assert res.ok, res.table()
    names = {c.name for c in res.checks}
    assert {"digest", "sector", "poles", "lmi.plant_ni", "lmi.controller_ni", "lmi.closed_loop",
            "lmi.robust_mass", "lmi.region_of_attraction", "performance.reduced", "performance.full"} <= names
    # hand formulas: gamma = 1/(m kp delta); the plant's NI storage is P = diag(m kp, m)/... -> P > 0 checked above
    assert cert["sector"]["gamma"] == pytest.approx(1.0 / (V.m * GAINS.kp * GAINS.delta), rel=1e-12)
    poles = np.roots([1, GAINS.Gamma * GAINS.delta, GAINS.kp, GAINS.Gamma * (GAINS.kp * GAINS.delta - 1 / V.m)])
    assert cert["stability_margin"]["max_real_part_1_s"] == pytest.approx(max(poles.real), rel=1e-9)
    assert cert["start_certified"] == (np.hypot(2.0, -1.5) <= cert["region_of_attraction"]["max_displacement_m"])
    assert [p.name for p in tmp_path.iterdir()] == ["c.json"]


def _tamper_gain(c):
    c["gains"]["kp"] *= 1.01


def _tamper_matrix(c):
    c["lmi"]["closed_loop"]["P"][0][1] += 0.05 * abs(c["lmi"]["closed_loop"]["P"][0][0])


def _tamper_roa(c):
    c["lmi"]["region_of_attraction"]["max_displacement_m"] *= 1.5
    c["region_of_attraction"]["max_displacement_m"] = c["lmi"]["region_of_attraction"]["max_displacement_m"]


def _tamper_performance(c):
    c["performance"]["full"]["settling_s"] *= 0.9


def _tamper_rate(c):
    c["lmi"]["robust_mass"]["decay_rate_1_s"] *= 1.2


@pytest.mark.parametrize("tamper, failing", [
    (_tamper_gain, {"sector", "poles"}),
    (_tamper_matrix, {"lmi.closed_loop"}),
    (_tamper_roa, {"lmi.region_of_attraction"}),
    (_tamper_performance, {"performance.full"}),
    (_tamper_rate, {"lmi.robust_mass"}),
])
def test_resigned_tampering_fails_the_recomputation(cert, tamper, failing):
    c = copy.deepcopy(cert)
    tamper(c)
    res = verify_certificate(_resign(c))
    assert not res.ok
    assert failing <= {chk.name for chk in res.checks if not chk.ok}


@pytest.mark.parametrize("edit, message", [
    (lambda c: c["gains"].__setitem__("Gamma", c["gains"]["Gamma"] + 1), "digest mismatch"),
    (lambda c: c["performance"]["reduced"].__setitem__("settling_s", 0.5), "digest mismatch"),
    (lambda c: c.__setitem__("schema_version", SCHEMA_VERSION + 1), "schema version"),
    (lambda c: c.__setitem__("schema", "something-else"), "schema"),
    (lambda c: c.pop("digest"), "no digest"),
])
def test_form_errors_via_cli(cert, tmp_path, run_cli, edit, message):
    c = copy.deepcopy(cert)
    edit(c)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(c))
    code, out, err = run_cli("verify", str(path))
    assert code != 0 and message in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_broken_json_and_missing_file(tmp_path, run_cli, cert):
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(cert)[:-20])
    code, _, err = run_cli("verify", str(path))
    assert code == 2 and "not valid JSON" in err
    code, _, err = run_cli("verify", str(tmp_path / "nope.json"))
    assert code == 2 and "cannot read" in err
    with pytest.raises(CertificateError):
        load_certificate(path)


def test_cli_verify_table_and_failure_exit(cert, tmp_path, run_cli):
    good = write_certificate(cert, tmp_path / "good.json")
    code, out, _ = run_cli("verify", str(good))
    assert code == 0 and "all 10 checks pass" in out and "lmi.robust_mass" in out
    c = copy.deepcopy(cert)
    _tamper_matrix(c)
    bad = tmp_path / "resigned.json"
    bad.write_text(json.dumps(_resign(c)))
    code, out, _ = run_cli("verify", str(bad), "--no-simulate")
    assert code == 1 and "FAIL" in out and "lmi.closed_loop" in out


def test_certify_refuses_the_sector_violation_and_leaves_no_file(tmp_path, run_cli):
    out = tmp_path / "c.json"
    code, _, err = run_cli("certify", "--kp", "5", "--Gamma", "160", "--delta", "0.1", "--out", str(out))
    assert code == 2 and "sector bound" in err
    assert list(tmp_path.iterdir()) == []
    code, _, err = run_cli("certify", "--kp", "5", "--Gamma", "160", "--out", str(out))
    assert code == 2 and "--delta" in err


def test_certify_given_gains_writes_a_verifiable_certificate(tmp_path, run_cli):
    # the paper's gains satisfy the sector bound (delta = 0.6 >= 0.5): they are certifiable, if slow
    out = tmp_path / "paper.json"
    code, stdout, err = run_cli("certify", "--kp", "5", "--Gamma", "160", "--delta", "0.6", "--out", str(out))
    assert code == 0, err
    c = load_certificate(out)
    assert c["sector"]["gamma"] == pytest.approx(1 / (0.5 * 5 * 0.6))
    assert c["performance"]["full"]["diverged"] in (True, False)
    assert verify_certificate(c).ok


def test_signed_but_malformed_field_is_one_line(cert, tmp_path, run_cli):
    c = copy.deepcopy(cert)
    c["stability_margin"]["decay_rate_1_s"] = "fast"
    c["lmi"]["closed_loop"]["P"] = [[1, 2], [3]]
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_resign(c)))
    code, _, err = run_cli("verify", str(path))
    assert code == 2 and "malformed" in err and "Traceback" not in err
