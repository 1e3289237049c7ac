"""``verify``'s own checks (:mod:`nniquad.certificates.verify`): the result object, the form checks, the order.

Each edit below is re-signed, so only a recomputation or a form check can refuse it, and each must fail exactly
the check named beside it (the re-simulations are left out: ``simulate=False``; tests/test_certificate.py runs
them).  The certificate is test_certificate's small one, shared with it.
"""

from __future__ import annotations

import copy
import json

import pytest

from nniquad.certificates import TOLERANCES, Certificate, canonical_digest, verify_certificate, write_certificate
from nniquad.certificates.verify import RECORD_FIELDS, SECTION_KEYS, Verification, coverage_notes
from nniquad.certificates.check import Check
from nniquad.errors import CertificateCheckError, CertificateError
from tests.test_certificate import build_small_certificate, build_small_certificate_schema_1

#: The checks of a schema-2 certificate without re-simulation, in the order ``verify`` runs them (cheap first).
FORM_CHECKS = ["digest", "model", "tolerances", "layout", "law_class", "settings"]


@pytest.fixture(scope="module")
def cert(shared_json) -> dict:
    return shared_json("small-certificate", build_small_certificate)


def _resign(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def _failed(c: dict, **kw) -> list[str]:
    return [chk.name for chk in verify_certificate(_resign(c), simulate=False, **kw).checks if not chk.ok]


# ----------------------------------------------------------------------------- the result object

def test_the_result_object_by_hand():
    v = Verification(checks=[Check("a", True, "one"), Check("b", False, "two"), Check("c", False, "three")],
                     notes=["a note"])
    assert not v.ok and v.first_failure.name == "b" and len(v) == 3 and [c.name for c in v] == ["a", "b", "c"]
    assert v["c"].detail == "three"
    with pytest.raises(KeyError, match="^'d'$"):
        v["d"]
    assert repr(v) == "Verification(ok=False, checks=3, failed=['b', 'c'])"
    assert v.table().splitlines() == ["check  result  detail", "-----  ------  ------", "a      pass    one",
                                      "b      FAIL    two", "c      FAIL    three", "note: a note"]
    assert v.to_json() == {"ok": False, "checks": [{"name": "a", "ok": True, "detail": "one"},
                                                   {"name": "b", "ok": False, "detail": "two"},
                                                   {"name": "c", "ok": False, "detail": "three"}],
                           "notes": ["a note"]}
    json.dumps(v.to_json())
    good = Verification(checks=[Check("a", True, "one")])
    assert good.ok and good.first_failure is None and good.table().splitlines()[2] == "a      pass    one"
    assert not Verification().ok and Verification().table().splitlines()[0] == "check  result  detail"


def test_a_check_holds_a_python_boolean():
    import numpy as np

    c = Check("x", np.bool_(True), "d")
    assert c.ok is True and json.dumps({"ok": c.ok}) == '{"ok": true}'


# ----------------------------------------------------------------------------- inputs

def test_a_path_a_mapping_and_a_certificate_give_the_same_checks(cert, tmp_path):
    path = write_certificate(cert, tmp_path / "c.json")
    runs = [verify_certificate(x, simulate=False) for x in (path, str(path), cert, Certificate.from_json(cert))]
    assert all(r.ok for r in runs)
    assert len({json.dumps(r.to_json(), sort_keys=True) for r in runs}) == 1
    assert [c.name for c in runs[0].checks][:len(FORM_CHECKS)] == FORM_CHECKS
    assert runs[0]["digest"].detail == f"sha256 {cert['digest']['value'][:16]}... matches the content"


def test_a_digest_mismatch_and_a_malformed_field_are_errors_not_checks(cert):
    c = copy.deepcopy(cert)
    c["sector"]["gamma"] = 0.5  # not re-signed
    with pytest.raises(CertificateCheckError, match="digest mismatch"):
        verify_certificate(c, simulate=False)
    # a Certificate object whose signature is not its content's (from_json refuses the mapping before verify sees it)
    import dataclasses

    forged = dataclasses.replace(Certificate.from_json(cert), signature="0" * 64)
    with pytest.raises(CertificateCheckError, match=r"^certificate: digest mismatch \(content changed after signing\)$"):
        verify_certificate(forged, simulate=False)
    c = copy.deepcopy(cert)
    c["lmi"]["closed_loop"]["decay_rate_1_s"] = [1.0]  # a list where a number belongs, re-signed
    with pytest.raises(CertificateError, match=r"^certificate has a malformed field \(TypeError: float\(\) argument"):
        verify_certificate(_resign(c), simulate=False)


def test_progress_is_said_before_the_re_simulation_only(cert, monkeypatch):
    import nniquad.certificates.verify as verify_module

    said = []
    monkeypatch.setattr(verify_module, "performance_check",
                        lambda cert, tol, model: Check(f"performance.{model}", True, "stub"))
    res = verify_certificate(cert, progress=said.append)
    assert res.ok and said == ["re-simulating the reference runs"]
    assert [c.name for c in res.checks][-2:] == ["performance.reduced", "performance.full"]
    said.clear()
    res = verify_certificate(cert, simulate=False, progress=said.append)
    assert said == [] and not any(c.name.startswith("performance.") for c in res.checks)


def test_fail_fast_keeps_the_full_order_and_stops_at_the_first_failure(cert):
    c = copy.deepcopy(cert)
    c["law_class"]["theorem"] = "another theorem"
    c["model"] = "fast"
    full = verify_certificate(_resign(copy.deepcopy(c)), simulate=False)
    fast = verify_certificate(_resign(c), simulate=False, fail_fast=True)
    assert [x.name for x in full.checks if not x.ok] == ["model", "law_class"]
    assert [x.name for x in fast.checks] == ["digest", "model"] and not fast.ok


def test_fail_fast_also_stops_the_cascade_check_at_its_first_failed_row(cert):
    c = copy.deepcopy(cert)
    c["cascade"]["covers_monte_carlo_default"] = not c["cascade"]["covers_monte_carlo_default"]
    full = verify_certificate(_resign(copy.deepcopy(c)), simulate=False)
    fast = verify_certificate(_resign(c), simulate=False, fail_fast=True)
    assert [x.name for x in full.checks if not x.ok] == ["cascade.covers_monte_carlo_default"]
    assert full.checks[-1].name == "cascade.margins at the stated worst vertices"
    assert [x.name for x in fast.checks] == [x.name for x in full.checks][:len(fast.checks)]
    assert fast.checks[-1].name == "cascade.covers_monte_carlo_default" and not fast.ok


# ----------------------------------------------------------------------------- notes

def test_the_notes_name_the_records_and_what_is_not_covered(cert, shared_json):
    notes = coverage_notes(Certificate.from_json(cert))
    assert len(notes) == 1 and notes[0].startswith("records, not verified") and all(f in notes[0] for f in RECORD_FIELDS)
    one = Certificate.from_json(shared_json("small-certificate-schema-1", build_small_certificate_schema_1))
    n1 = coverage_notes(one)
    lo, hi = one.lmi["robust_mass"]["m_lo_kg"], one.lmi["robust_mass"]["m_hi_kg"]
    assert n1[0].startswith("schema 1:") and f"[{lo:.5g}, {hi:.5g}] kg" in n1[0] and len(n1) == 2


# ----------------------------------------------------------------------------- the form checks, one edit each

def _set_tolerance(key: str, value):
    return lambda c: c["tolerances"].__setitem__(key, value)


EDITS = {
    "model unknown": (lambda c: c.update(model="fast"), ["model"]),
    "model not the tuning's": (lambda c: c.update(tuning={"model": "reduced"}), ["model"]),
    "a tolerance loosened": (_set_tolerance("lmi_relative", TOLERANCES["lmi_relative"] * 10), ["tolerances"]),
    "a tolerance as text": (_set_tolerance("lmi_relative", str(TOLERANCES["lmi_relative"])), ["tolerances"]),
    "a tolerance as true": (_set_tolerance("settling_abs_s", True), ["tolerances"]),
    "a tolerance added": (_set_tolerance("anything", 1.0), ["tolerances"]),
    "a tolerance dropped": (lambda c: c["tolerances"].pop("lmi_relative"), ["tolerances"]),
    "a section key added": (lambda c: c["bound"].update(claim=1.0), ["layout"]),
    "a section key dropped": (lambda c: c["lmi"]["plant_ni"].pop("form"), ["layout"]),
    "a margin break point with another field": (
        lambda c: next(iter(c["margins"]["break_points"].values())).update(extra=1.0), ["layout"]),
    "the margin method": (lambda c: c["margins"].update(method="frequency sweep"), ["layout"]),
    "the controller NI form": (lambda c: c["lmi"]["controller_ni"].update(form="V' <= 0"), ["layout"]),
    "the region model": (lambda c: c["region_of_attraction"].update(model="full"), ["layout"]),
    "the law class unknown": (lambda c: c["law_class"].update(name="fast"), ["law_class"]),
    "the class's theorem": (lambda c: c["law_class"].update(theorem="Lyapunov"), ["law_class"]),
    "a run's horizon": (lambda c: c["performance"]["full"]["settings"].update(horizon_s=5.0), ["settings"]),
    "the region's tilt limit": (lambda c: c["region_of_attraction"].update(tilt_limit_deg=31.0),
                                ["settings", "lmi.region_of_attraction"]),
    "the nominal mass of the robust LMI": (lambda c: c["lmi"]["robust_mass"].update(m_nominal_kg=0.9),
                                           ["settings", "lmi.robust_mass"]),
    "the margins' rate": (lambda c: c["margins"].update(rate_hz=50.0), ["settings", "margins"]),
    "the cascade region's tilt limit": (lambda c: c["cascade"]["region_of_attraction"].update(tilt_limit_deg=31.0),
                                        ["settings", "cascade.tilt limit and u0"]),
    "the cascade rate as text": (lambda c: c["cascade"].update(rate_hz="fast"),
                                 ["settings", "cascade.rate and box"]),
}


@pytest.mark.parametrize("name", list(EDITS))
def test_an_edit_fails_exactly_its_checks(cert, name):
    edit, failing = EDITS[name]
    c = copy.deepcopy(cert)
    edit(c)
    assert _failed(c) == failing, name
    detail = verify_certificate(_resign(c), simulate=False, fail_fast=True).first_failure.detail
    assert detail.strip() and "\n" not in detail


def test_a_failed_form_check_says_what_failed(cert):
    def first_failure(edit):
        c = copy.deepcopy(cert)
        edit(c)
        return verify_certificate(_resign(c), simulate=False, fail_fast=True).first_failure

    assert first_failure(lambda c: c.update(model="fast")).detail.startswith("model 'fast' (known:")
    assert first_failure(_set_tolerance("lmi_relative", 1.0)).detail.endswith("library's: lmi_relative")
    assert first_failure(lambda c: c["bound"].update(claim=1.0)).detail.endswith("keys or forms in: bound")
    assert "performance.full.settings (horizon_s)" in first_failure(
        lambda c: c["performance"]["full"]["settings"].update(horizon_s=5.0)).detail
    assert first_failure(lambda c: c["law_class"].update(name="fast")).detail.startswith("unknown law class 'fast'")


def test_every_section_key_list_is_the_keys_a_certificate_has(cert):
    """SECTION_KEYS (what the layout check demands) against a certificate the library writes."""
    for path, keys in SECTION_KEYS.items():
        node = cert
        for part in path.split("."):
            node = node[part]
        assert set(node) == keys, path


def test_a_certificate_from_before_law_classes_is_of_the_paper_class(cert):
    c = copy.deepcopy(cert)
    del c["law_class"]
    res = verify_certificate(_resign(c), simulate=False)
    assert res.ok and "not stated" in res["law_class"].detail
