"""Certificates: written, verified, and every tampering caught."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from nniquad.analysis.cascade.box_certificate import ParameterBox

from nniquad.certificates import (SCHEMA_VERSION, SCHEMA_VERSIONS, Certificate, build_certificate, canonical_digest, load_certificate,
                                  read_certificate, verify_certificate, write_certificate)
from nniquad.errors import CertificateError
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE as V

# a gain set found by `nniquad tune --model full --roa-radius 0` (it only has to be certifiable here)
GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56, attitude_zeta=1.132, attitude_accel_limit_rad_s2=31.14)

#: The tests that build this design's certificate run on one xdist worker (here and test_cli_rate's ``certify``):
#: the worker builds it once, in the shared fixture, and ``certify`` of the same design then reuses the cascade
#: section computed in that process (nniquad.analysis.cascade.section.cascade_section); spread over two workers,
#: one would wait for the other's build and then build it again.
pytestmark = pytest.mark.xdist_group("small_certificate")

# the test design tolerates only a slightly slower motor: its cascade box is a tenth of the Monte Carlo
# ranges (log scale), as the widest-box search finds
SMALL_BOX = ParameterBox.monte_carlo_default().scaled(0.1)


def build_small_certificate() -> dict:
    """The test design's certificate over :data:`SMALL_BOX` (JSON), as every test module that needs one builds it."""
    return build_certificate(V, GAINS, inner=INNER, model="full", box=SMALL_BOX).to_json()


@pytest.fixture(scope="module")
def certificate(shared_json) -> Certificate:
    return Certificate.from_json(shared_json("small-certificate", build_small_certificate))


@pytest.fixture(scope="module")
def cert(certificate) -> dict:
    """The certificate's JSON document (what the tamper tests edit)."""
    return certificate.to_json()


def build_small_certificate_schema_1() -> dict:
    """A schema-1 certificate of the same design (no cascade section), JSON."""
    return build_certificate(V, GAINS, inner=INNER, model="full", cascade=False).to_json()


@pytest.fixture(scope="module")
def certificate1(shared_json) -> Certificate:
    """A schema-1 certificate of the same design (no cascade section)."""
    return Certificate.from_json(shared_json("small-certificate-schema-1", build_small_certificate_schema_1))


@pytest.fixture(scope="module")
def cert1(certificate1) -> dict:
    return certificate1.to_json()


def test_default_certificate_is_schema_2_with_the_sampled_full_run(certificate, certificate1):
    assert certificate.schema_version == 2 and certificate.cascade["rate_hz"] == 100.0
    assert certificate.performance["full"]["settings"]["controller_sampling"] == "discrete"
    assert certificate1.schema_version == 1 and certificate1.cascade is None
    assert "controller_sampling" not in certificate1.performance["full"]["settings"]
    # the sampled run is a different run from the continuous one
    assert certificate.performance["full"]["settling_s"] != certificate1.performance["full"]["settling_s"]


def _resign(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def test_certificate_verifies_and_states_independent_numbers(cert, tmp_path):
    path = write_certificate(cert, tmp_path / "c.json")
    res = verify_certificate(path)
    assert res.ok, res.table()
    names = {c.name for c in res.checks}
    assert {"digest", "sector", "poles", "lmi.plant_ni", "lmi.controller_ni", "lmi.closed_loop",
            "lmi.robust_mass", "lmi.region_of_attraction", "performance.reduced", "performance.full",
            "margins"} <= names
    # the margins section: both break points, against python-control on the same linearised cascade
    from nniquad.analysis.linearised_cascade import linearise_cascade
    from nniquad.analysis.margins import cascade_margins

    ref = cascade_margins(linearise_cascade(V, GAINS, INNER), 100.0)
    for bp in ("horizontal", "attitude"):
        assert cert["margins"]["break_points"][bp]["pm_deg"] == pytest.approx(ref[bp].pm_deg, abs=1e-6)
    assert cert["margins"]["rate_hz"] == 100.0 and cert["margins"]["meets_requirement"] is False
    # hand formulas: gamma = 1/(m kp delta); the plant's NI storage is P = diag(m kp, m)/... -> P > 0 checked above
    assert cert["sector"]["gamma"] == pytest.approx(1.0 / (V.m * GAINS.kp * GAINS.delta), rel=1e-12)
    poles = np.roots([1, GAINS.Gamma * GAINS.delta, GAINS.kp, GAINS.Gamma * (GAINS.kp * GAINS.delta - 1 / V.m)])
    assert cert["stability_margin"]["max_real_part_1_s"] == pytest.approx(max(poles.real), rel=1e-9)
    # the start per method, each against its own region's stated reach; the top level never claims more than both
    reaches = [cert["region_of_attraction"]["max_displacement_m"],
               cert["cascade"]["region_of_attraction"]["max_displacement_m"]]
    assert [m["inside"] for m in cert["start"]["methods"].values()] == [np.hypot(2.0, -1.5) <= r for r in reaches]
    assert cert["start_certified"] == all(np.hypot(2.0, -1.5) <= r for r in reaches)
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


def _tamper_phase_margin(c):
    c["margins"]["break_points"]["horizontal"]["pm_deg"] += 1.0


def _tamper_gain_margin(c):
    c["margins"]["break_points"]["attitude"]["gm_lower_db"] -= 0.5


def _tamper_margin_verdict(c):
    c["margins"]["meets_requirement"] = True


def _tamper_inner_loop(c):
    c["inner_loop"]["attitude_zeta"] *= 1.05  # the margins (and the full run) depend on the inner loops


@pytest.mark.parametrize("tamper, failing", [
    (_tamper_gain, {"sector", "poles"}),
    (_tamper_matrix, {"lmi.closed_loop"}),
    (_tamper_roa, {"lmi.region_of_attraction"}),
    (_tamper_performance, {"performance.full"}),
    (_tamper_rate, {"lmi.robust_mass"}),
    (_tamper_phase_margin, {"margins"}),
    (_tamper_gain_margin, {"margins"}),
    (_tamper_margin_verdict, {"margins"}),
    (_tamper_inner_loop, {"margins"}),
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
    (lambda c: c.__setitem__("schema_version", max(SCHEMA_VERSIONS) + 1), "schema version"),
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
    n_checks = len(verify_certificate(cert, simulate=True).checks)  # the library's own count, cascade rows included
    assert n_checks > 16 and code == 0 and f"all {n_checks} checks pass" in out and "lmi.robust_mass" in out and "margins" in out
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
    out = tmp_path / "given.json"
    code, stdout, err = run_cli("certify", "--kp", repr(GAINS.kp), "--Gamma", repr(GAINS.Gamma), "--delta",
                                repr(GAINS.delta), "--attitude-wn", repr(INNER.attitude_wn_rad_s), "--attitude-zeta",
                                repr(INNER.attitude_zeta), "--attitude-accel", repr(INNER.attitude_accel_limit_rad_s2),
                                "--model", "full", "--box-scale", "0.1", "--out", str(out))
    assert code == 0, err
    c = load_certificate(out)
    assert c["sector"]["gamma"] == pytest.approx(1 / (0.5 * GAINS.kp * GAINS.delta))
    for model in ("reduced", "full"):  # written only because both reference runs settle, and are seen to stay
        run = c["performance"][model]
        assert run["settling_s"] is not None and not run["diverged"]
        assert run["settling_s"] + max(5.0, 2 * run["settling_s"]) <= run["settings"]["horizon_s"]
    assert verify_certificate(c).ok


def test_certify_refuses_gains_whose_reference_run_does_not_settle(tmp_path, run_cli):
    """The paper's gains satisfy the sector bound (delta = 0.6 >= 0.5), but neither 20 s run settles."""
    out = tmp_path / "paper.json"
    code, stdout, err = run_cli("certify", "--kp", "5", "--Gamma", "160", "--delta", "0.6", "--out", str(out))
    assert code == 2, (stdout, err)
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("[")]  # [certify] progress lines
    assert len(lines) == 1 and "Traceback" not in err
    assert "reference run did not settle within its 20 s horizon" in lines[0] and "nothing certified" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_library_certify_refuses_an_unsettled_reference_run():
    """The refusal is the library's, not only the CLI's: ``nniquad.certify`` raises and returns nothing."""
    import nniquad

    with pytest.raises(CertificateError, match=r"^refused: the \w+ reference run did not settle within its 20 s"):
        nniquad.certify(V, Gains(5.0, 160.0, 0.6))


@pytest.mark.parametrize("settling, verdict", [(6.6, None), (6.81, "not shown to stay there for 13.6 s"),
                                               (None, "did not settle"), (1.0, "diverged")])
def test_reference_run_must_be_seen_in_the_band_for_the_hold_time(cert, settling, verdict):
    """On a 20 s run a last exit at s counts only if s + max(5 s, 2 s) <= 20 s, i.e. s <= 6.67 s."""
    from nniquad.certificates.build import unsettled_reference_run

    c = copy.deepcopy(cert)
    assert unsettled_reference_run(c) is None  # the fixture's runs settle at about 2-3 s
    c["performance"]["full"]["settling_s"] = settling
    c["performance"]["full"]["diverged"] = verdict == "diverged"
    reason = unsettled_reference_run(c)
    if verdict is None:
        assert reason is None
    else:
        assert reason is not None and verdict in reason and "full" in reason


def test_signed_but_malformed_field_is_one_line(cert, tmp_path, run_cli):
    c = copy.deepcopy(cert)
    c["stability_margin"]["decay_rate_1_s"] = "fast"
    c["lmi"]["closed_loop"]["P"] = [[1, 2], [3]]
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_resign(c)))
    code, _, err = run_cli("verify", str(path))
    assert code == 2 and "malformed" in err and "Traceback" not in err


# ------------------------------------------------------------------------------ checks that can fail


@pytest.mark.parametrize("which", ["plant_ni", "controller_ni"])
@pytest.mark.parametrize("scale", [2.0, 0.5])
def test_resigned_scaled_ni_storage_fails(cert, which, scale):
    """A scaled P stays positive definite but is no NI storage (the plant's and the controller's are unique up to
    nothing: P = diag(m kp, m) and P = delta); a check of P > 0 alone would pass it."""
    c = copy.deepcopy(cert)
    P = np.array(c["lmi"][which]["P"]) * scale
    assert np.linalg.eigvalsh(P)[0] > 0
    c["lmi"][which]["P"] = P.tolist()
    res = verify_certificate(_resign(c), simulate=False)
    assert {chk.name for chk in res.checks if not chk.ok} == {f"lmi.{which}"}


def _edit(value):
    """A small edit of a JSON value that keeps its type."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        return value + 1
    if isinstance(value, str):
        return value + "x"
    if isinstance(value, list):
        return value + [0]
    if isinstance(value, dict):
        return {**value, "edited": 1}
    return {"edited": 1}  # None


def test_every_top_level_field_is_covered_by_the_digest(cert, tmp_path):
    """Editing any one top-level field without re-signing is refused, by the loader and by verify."""
    assert {"schema", "schema_version", "vehicle", "gains", "lmi", "tuning", "software", "digest"} <= set(cert)
    for key in cert:
        c = copy.deepcopy(cert)
        if key == "digest":
            c["digest"]["value"] = c["digest"]["value"][::-1]
        else:
            c[key] = _edit(c[key])
        path = tmp_path / f"{key}.json"
        path.write_text(json.dumps(c))
        with pytest.raises(CertificateError):
            load_certificate(path)
        with pytest.raises(CertificateError):
            verify_certificate(c, simulate=False)
        with pytest.raises(CertificateError):
            Certificate.from_json(c)
    for extra in ({**cert, "added": 1}, {k: v for k, v in cert.items() if k != "bound"}):
        with pytest.raises(CertificateError, match="digest mismatch"):
            verify_certificate(extra, simulate=False)


@pytest.mark.parametrize("edit, message", [
    (lambda c: c["digest"].__setitem__("algorithm", "md5"), "digest must be"),
    (lambda c: c["digest"].__setitem__("extra", 1), "digest must be"),
    (lambda c: c.__setitem__("schema_version", True), "schema version"),
])
def test_digest_and_version_form(cert, edit, message):
    c = copy.deepcopy(cert)
    edit(c)
    c["digest"]["value"] = canonical_digest(c)
    with pytest.raises(CertificateError, match=message):
        Certificate.from_json(c)


def test_typed_certificate_round_trip_and_immutability(certificate, cert, tmp_path):
    import dataclasses

    assert certificate.signature == certificate.digest == cert["digest"]["value"]
    again = Certificate.from_json(json.loads(json.dumps(cert)))
    assert again == certificate and again.to_json() == cert
    with pytest.raises(dataclasses.FrozenInstanceError):
        certificate.gains = GAINS
    with pytest.raises(TypeError):
        certificate.lmi["closed_loop"]["decay_rate_1_s"] = 1.0
    # an edited copy keeps the old signature and is refused until it is signed again
    edited = dataclasses.replace(certificate, tilt_limit_deg=25.0)
    assert not edited.signature_ok
    with pytest.raises(CertificateError, match="digest mismatch"):
        verify_certificate(edited, simulate=False)
    resigned = edited.signed()
    assert resigned.signature_ok
    failed = {c.name for c in verify_certificate(resigned, simulate=False).checks if not c.ok}
    assert "lmi.region_of_attraction" in failed  # u0 and the stated tilt no longer agree
    path = write_certificate(certificate, tmp_path / "t.json")
    assert read_certificate(path) == certificate


def test_committed_certificate_still_loads_and_verifies():
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"
    c = read_certificate(path)
    assert c.signature == c.digest == json.loads(path.read_text())["digest"]["value"]
    assert verify_certificate(c, simulate=False).ok


@pytest.mark.parametrize("section, key, factor", [
    ("stability_margin", "min_damping", 1.01),
    ("stability_margin", "routh_margin", 1.01),
    ("stability_margin", "max_real_part_1_s", 1.01),
    ("sector", "delta_min", 1.01),
    ("region_of_attraction", "u0_m_s2", 1.01),
])
def test_resigned_secondary_numbers_fail(cert, section, key, factor):
    """Every stated number is recomputed, not only the headline ones."""
    c = copy.deepcopy(cert)
    c[section][key] *= factor
    res = verify_certificate(_resign(c), simulate=False)
    assert not res.ok


def test_resigned_pole_list_and_bound_fail(cert):
    c = copy.deepcopy(cert)
    c["stability_margin"]["poles_1_s"][0][1] += 0.1
    assert "poles" in {chk.name for chk in verify_certificate(_resign(c), simulate=False).checks if not chk.ok}
    c = copy.deepcopy(cert)
    c["bound"]["enter_band_s"] *= 0.9
    c["ratio_to_bound"] = {k: v / 0.9 for k, v in c["ratio_to_bound"].items()}
    failed = {chk.name for chk in verify_certificate(_resign(c)).checks if not chk.ok}
    assert failed == {"bound"}  # the bound is recomputed, and the ratios from it and the stated settling times


def test_sector_check_refuses_gamma_max_one(cert):
    c = copy.deepcopy(cert)
    c["sector"]["gamma_max"] = 1.0
    res = verify_certificate(_resign(c), simulate=False)
    assert "sector" in {chk.name for chk in res.checks if not chk.ok}


# ------------------------------------------------------------------------------ every signed field


def _failed(c, **kw):
    return {chk.name for chk in verify_certificate(_resign(c), **kw).checks if not chk.ok}


@pytest.mark.parametrize("edit, failing", [
    (lambda c: c["performance"]["full"].__setitem__("diverged", True), {"performance.full"}),
    (lambda c: c["performance"]["reduced"]["settings"].__setitem__("tilt_limit_deg", 60.0), {"settings"}),
    (lambda c: c["region_of_attraction"].__setitem__("tilt_limit_deg", 60.0), {"settings"}),
    (lambda c: c.__setitem__("model", "fast"), {"model"}),
    (lambda c: c["tolerances"].__setitem__("settling_abs_s", 1.0), {"tolerances"}),  # loosened
    (lambda c: c["tolerances"].pop("tilt_abs_deg"), {"tolerances"}),
    (lambda c: c["lmi"]["plant_ni"].__setitem__("form", "V' <= 0"), {"layout"}),
    (lambda c: c["sector"].__setitem__("claim", "anything"), {"layout"}),
    (lambda c: c["lmi"]["robust_mass"].__setitem__("m_nominal_kg", 0.6), {"settings"}),
    (lambda c: c["margins"].__setitem__("rate_hz", 50.0), {"settings"}),
])
def test_resigned_edit_of_a_stated_field_fails(cert, edit, failing):
    c = copy.deepcopy(cert)
    edit(c)
    assert failing <= _failed(c)


def test_model_must_agree_with_the_tuning_record(cert):
    c = copy.deepcopy(cert)
    c["tuning"] = {"source": "nniquad tune", "model": "reduced"}
    assert _failed(c, simulate=False) == {"model"}
    c["tuning"]["model"] = "full"
    assert _failed(c, simulate=False) == set()


def test_tilt_limit_alone_changed_to_60_fails_and_a_consistent_60_certificate_is_what_montecarlo_runs(cert):
    """Every tilt limit of the document 30 -> 60 deg, re-signed: the recomputed u0, bound and runs refuse it.  A
    certificate derived at 60 deg throughout is a true statement about 60 deg: it verifies, and the Monte Carlo
    setup simulates at 60 deg over that certificate's own reach."""
    from nniquad.study.certificate_setup import study_setup

    c = copy.deepcopy(cert)
    c["tilt_limit_deg"] = c["region_of_attraction"]["tilt_limit_deg"] = 60.0
    for run in c["performance"].values():
        run["settings"]["tilt_limit_deg"] = 60.0
    assert {"lmi.region_of_attraction", "bound"} <= _failed(c)
    # the cascade grid at 3 points per parameter (the tamper loop's): this test is about the tilt limit, and the
    # 4096-point grid of the default is checked on the shared certificate
    c60 = build_certificate(V, GAINS, inner=INNER, model="full", tilt_limit_deg=60.0, box=SMALL_BOX,
                            grid_points_per_axis=3).to_json()
    assert verify_certificate(c60).ok
    setup = study_setup(c60).to_json()
    assert setup["tilt_limit_deg"] == pytest.approx(60.0)
    assert setup["displacement_radius_m"] == min(c60["region_of_attraction"]["max_displacement_m"], 5.0)
    assert c60["region_of_attraction"]["max_displacement_m"] >= cert["region_of_attraction"]["max_displacement_m"]


def test_fail_fast_stops_at_the_first_failure_and_cheap_checks_run_first(cert):
    c = copy.deepcopy(cert)
    c["tolerances"]["lmi_relative"] = 1.0
    full = verify_certificate(_resign(c))
    fast = verify_certificate(_resign(copy.deepcopy(c)), fail_fast=True)
    assert not fast.ok and fast.checks[-1].name == "tolerances" and fast.first_failure.name == "tolerances"
    assert [ch.name for ch in fast.checks] == [ch.name for ch in full.checks][:len(fast.checks)]
    names = [ch.name for ch in full.checks]
    assert names.index("tolerances") < names.index("sector") < names.index("margins") < names.index("performance.full")
    ok = verify_certificate(cert, fail_fast=True)  # nothing fails: every check runs
    assert ok.ok and len(ok.checks) == len(full.checks)


def test_re_simulation_is_cached_by_its_exact_inputs(cert, monkeypatch):
    import nniquad.certificates.reference_run as sim  # the module whose simulate the re-check calls (ReferenceRun)
    from nniquad.certificates.verify import clear_cache

    calls = []
    real = sim.simulate

    def counting(*a, **k):
        calls.append(a[2].model)
        return real(*a, **k)

    monkeypatch.setattr(sim, "simulate", counting)
    clear_cache()
    first = verify_certificate(cert)
    assert sorted(calls) == ["full", "reduced"]
    again = verify_certificate(copy.deepcopy(cert))
    assert len(calls) == 2 and again.to_json() == first.to_json()
    c = copy.deepcopy(cert)
    c["software"]["numpy"] += "x"  # a record: the same runs, not simulated again
    assert verify_certificate(_resign(c)).ok and len(calls) == 2
    c = copy.deepcopy(cert)
    c["inner_loop"]["attitude_zeta"] *= 1.05  # other inputs: simulated again (and refused: the runs differ)
    for run in c["performance"].values():
        run["settings"]["inner"]["attitude_zeta"] = c["inner_loop"]["attitude_zeta"]
    verify_certificate(_resign(c))
    assert sorted(calls[2:]) == ["full", "reduced"]


def test_notes_say_what_schema_1_does_not_cover_and_which_fields_are_records(cert1, tmp_path, run_cli):
    cert = cert1
    res = verify_certificate(cert, simulate=False)
    assert any("schema 1" in n and "no sampled-data cascade" in n and "no parameter box" in n for n in res.notes)
    assert any("records, not verified" in n and "software" in n and "tuning" in n for n in res.notes)
    code, out, _ = run_cli("verify", str(write_certificate(cert, tmp_path / "c.json")), "--no-simulate")
    assert code == 0 and "note: schema 1" in out and "records, not verified" in out


# ------------------------------------------------------------------------------ schema 2


@pytest.mark.parametrize("edit, message", [
    (lambda c: c.__setitem__("schema_version", 2), "schema version 2 needs a 'cascade' object"),
    (lambda c: c.__setitem__("cascade", {"rate_hz": 100.0}), "schema version 1 has no 'cascade' section"),
    (lambda c: c.__setitem__("schema_version", 3), "schema version 3 is not supported"),
    (lambda c: c.update(schema_version=2, cascade=[1]), "needs a 'cascade' object"),
])
def test_schema_version_and_cascade_section_must_agree(cert1, tmp_path, run_cli, edit, message):
    c = copy.deepcopy(cert1)
    edit(c)
    path = tmp_path / "v.json"
    path.write_text(json.dumps(_resign(c)))
    code, _, err = run_cli("verify", str(path))
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_schema_2_certificate_round_trips_and_keeps_schema_1_digests(certificate1, cert1):
    import dataclasses

    certificate, cert = certificate1, cert1
    assert certificate.cascade is None and certificate.schema_version == 1 and "cascade" not in cert
    section = {"rate_hz": 100.0, "controller": "discrete", "region_of_attraction": {"tilt_limit_deg": 30.0}}
    two = dataclasses.replace(certificate, cascade=section).signed()
    doc = two.to_json()
    assert doc["schema_version"] == 2 and doc["cascade"] == section
    back = Certificate.from_json(json.loads(json.dumps(doc)))
    assert back == two and back.to_json() == doc
    with pytest.raises(TypeError):
        back.cascade["rate_hz"] = 1.0


def test_schema_2_cascade_section_is_checked_by_robust_cascade(certificate, monkeypatch):
    """verify hands the section, vehicle, gains, inner loops and tilt limit to check_cascade_rows; its rows are
    checks (a stub stands in for the function, which another module provides)."""
    import dataclasses

    seen = {}

    def stub(section, vehicle, gains, inner, *, tilt_limit_deg, **_):
        seen.update(section=section, vehicle=vehicle, gains=gains, inner=inner, tilt=tilt_limit_deg)
        return [("lyapunov", True, "stub", ()), ("grid", section.get("grid_ok", True), "stub", ())]

    import nniquad.certificates.recheck_reduced_loop as recheck

    monkeypatch.setattr(recheck, "check_cascade_rows", stub)
    section = {"rate_hz": 100.0, "region_of_attraction": {"tilt_limit_deg": 30.0}}
    # no 'start' section (as a certificate from before it): the stub's region states no reach to compare the start with
    certificate = dataclasses.replace(certificate, start=None)
    two = dataclasses.replace(certificate, cascade=section).signed()
    res = verify_certificate(two, simulate=False)
    assert res.ok, res.table()
    assert {"cascade.lyapunov", "cascade.grid"} <= {c.name for c in res.checks}
    assert seen["section"] == section and seen["tilt"] == 30.0 and seen["gains"] == certificate.gains
    assert not any("schema 1" in n for n in res.notes)
    bad = dataclasses.replace(certificate, cascade={**section, "grid_ok": False}).signed()
    assert {c.name for c in verify_certificate(bad, simulate=False).checks if not c.ok} == {"cascade.grid"}
    other_rate = dataclasses.replace(certificate, cascade={**section, "rate_hz": 50.0}).signed()
    assert "settings" in {c.name for c in verify_certificate(other_rate, simulate=False).checks if not c.ok}


def test_the_kept_schema_1_certificate_verifies_and_says_what_it_does_not_cover(run_cli):
    from pathlib import Path

    path = Path(__file__).resolve().parent / "data" / "schema1_certificate.json"
    assert json.loads(path.read_text())["schema_version"] == 1 and "cascade" not in json.loads(path.read_text())
    code, out, err = run_cli("verify", str(path), "--no-simulate", "--fail-fast")
    assert code == 0, (out, err)
    assert "note: schema 1" in out and "no sampled-data cascade" in out and "no parameter box" in out
    assert "records, not verified" in out
