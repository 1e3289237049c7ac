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
from nniquad.certificates.check_record import Check
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
    lines = v.table().splitlines()
    assert lines[:5] == ["check  result      requirement  method                    detail",
                         "-----  ----------  -----------  ------------------------  ------",
                         "a      pass        -            recomputed                one",
                         "b      FAIL        -            recomputed                two",
                         "c      FAIL        -            recomputed                three"]
    assert lines[5].startswith("note: result 'proven'") and lines[6].startswith("note: the result says")
    assert lines[7] == "note: a note"
    row = {"outcome": None, "method": "recomputed", "margin": None, "proofs": [], "requirement_met": None}
    assert v.to_json() == {"ok": False, "outcome": "fails",
                           "checks": [{"name": "a", "ok": True, "detail": "one"} | row | {"outcome": "pass"},
                                      {"name": "b", "ok": False, "detail": "two"} | row | {"outcome": "fails"},
                                      {"name": "c", "ok": False, "detail": "three"} | row | {"outcome": "fails"}],
                           "notes": ["a note"]}
    json.dumps(v.to_json())
    good = Verification(checks=[Check("a", True, "one")])
    assert good.ok and good.first_failure is None and good.outcome == "proven"
    assert good.table().splitlines()[2] == "a      pass        -            recomputed                one"
    assert not Verification().ok and Verification().table().splitlines()[0].split() == ["check", "result",
                                                                                          "requirement", "method",
                                                                                          "detail"]


def test_the_three_outcomes_of_a_check_with_proofs():
    """A check with proofs is ``proven`` only if every proof is; ``not proven`` is never a pass; a recomputed
    number that is off fails the check whatever its proofs say."""
    from nniquad.analysis.verified.inequalities import ProofRow
    from nniquad.certificates.check_record import proof_check

    good = ProofRow("P > 0", "proven", "verified-cholesky", 1e-15, 0.25)
    exact = ProofRow("P > 0", "proven", "exact")
    unsure = ProofRow("Q > 0", "not proven", "verified-cholesky", 1e-15)
    bad = ProofRow("R > 0", "fails", "exact")
    c = proof_check("x", True, "d", [good, exact])
    assert (c.ok, c.outcome, c.methods, c.margin) == (True, "proven", ["exact", "verified-cholesky"], 0.25)
    assert c.to_json()["method"] == "exact+verified-cholesky" and len(c.to_json()["proofs"]) == 2
    c = proof_check("x", True, "d", [good, unsure])
    assert (c.ok, c.outcome) == (False, "not proven") and "1 of 2 not proven" in c.detail
    v = Verification(checks=[Check("a", True, "one"), c])
    assert not v.ok and v.outcome == "not proven" and "NOT PROVEN" in v.table()
    assert proof_check("x", True, "d", [unsure, bad]).outcome == "fails"
    assert proof_check("x", False, "d", [good]).outcome == "fails"
    with pytest.raises(ValueError, match="outcome"):
        Check("x", True, "d", outcome="maybe")


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


@pytest.mark.parametrize("field, edit", [
    ("tilt_limit_deg", lambda c: c.__setitem__("tilt_limit_deg", int(c["tilt_limit_deg"]))),
    ("xi0_m", lambda c: c.__setitem__("xi0_m", [int(v) for v in c["xi0_m"]])),
    ("gains", lambda c: c["gains"].__setitem__("kp", int(c["gains"]["kp"]) + 1)),
], ids=["tilt limit an integer", "start an integer", "gain an integer"])
def test_a_field_that_does_not_read_back_as_signed_is_refused_by_name(cert, field, edit):
    """A re-signed document whose typed field holds an integer reads back as a float: its canonical text is not what
    was signed, so it is refused in one line naming the field (the typed certificate would otherwise sign other
    text than the file's).  The untouched document reads back, and its digest is the signature."""
    one = Certificate.from_json(cert)
    assert one.digest == one.signature == cert["digest"]["value"] == canonical_digest(one.body())
    c = copy.deepcopy(cert)
    c["tilt_limit_deg"], c["xi0_m"] = 30.0, [2.0, -1.5]  # integral values, so that the edit changes only the type
    edit(c)
    with pytest.raises(CertificateError, match=rf"^certificate: field '{field}' does not read back as it was signed"):
        Certificate.from_json(_resign(c))


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


#: What a certificate's notes must say it leaves out, word for word: the coverage statement is part of the claim.
RECORDS_NOTE = ("records, not verified (no check and no Monte Carlo run reads them): {} (except tuning.model, which "
                "must equal model)")
SCHEMA_1_NOTE = ("schema 1: the stability claim is for the continuous-time reduced horizontal loop (position measured "
                 "continuously) with the nominal vehicle parameters and a mass interval [{:.5g}, {:.5g}] kg; it covers "
                 "no sampled-data cascade (control rate, attitude loop, motor lag) and no parameter box (inertia, "
                 "attitude gain, motor time constant)")
CASCADE_CLASS_NOTE = ("class cascade: the paper's sector bound is not claimed; the reduced-loop LMIs are stated (they "
                      "hold whenever m kp delta > 1) but the design is certified by the sampled-data cascade section "
                      "alone, over its parameter box and within its region of attraction")


def test_the_notes_word_for_word_for_each_kind_of_certificate(cert, shared_json):
    """A schema-2 paper-class certificate has the records note alone; schema 1 adds what it does not cover, with its
    mass interval; the cascade class says the sector bound is not claimed.  Each as ``verify`` reports it."""
    from tests.test_law_class import build_cascade_class_certificate

    records = RECORDS_NOTE.format(", ".join(RECORD_FIELDS))
    assert verify_certificate(cert, simulate=False).notes == [records]
    one = shared_json("small-certificate-schema-1", build_small_certificate_schema_1)
    rm = one["lmi"]["robust_mass"]
    assert verify_certificate(one, simulate=False).notes == [SCHEMA_1_NOTE.format(rm["m_lo_kg"], rm["m_hi_kg"]),
                                                             records]
    cascade = shared_json("law-class-cascade", build_cascade_class_certificate)
    assert coverage_notes(Certificate.from_json(cascade)) == [CASCADE_CLASS_NOTE, records]


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
                                 ["settings", "tracking", "cascade.rate and box"]),
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


def _tuned_model(c: dict) -> str:
    return c["tuning"]["model"] if isinstance(c.get("tuning"), dict) and "model" in c["tuning"] else c["model"]


def test_the_form_checks_say_what_they_checked(cert):
    from nniquad.sim.options import MODELS

    known = ", ".join(MODELS)
    d = {c.name: c.detail for c in verify_certificate(cert, simulate=False).checks}
    assert d["model"] == f"model {cert['model']!r} is one of {known} and equals tuning.model {_tuned_model(cert)!r}"
    assert d["tolerances"] == "the stated tolerances are the library's (verify uses the library's)"
    assert d["layout"] == "every section has exactly its keys; the stated forms are the library's"
    assert d["settings"] == (f"both reference runs use the reference settings at tilt {cert['tilt_limit_deg']:g} deg, "
                             f"start {list(cert['xi0_m'])} m and the certified inner loops; every stated tilt limit "
                             "is the same")

    def detail(edit, name):
        c = copy.deepcopy(cert)
        edit(c)
        return verify_certificate(_resign(c), simulate=False)[name].detail

    assert detail(lambda c: c.update(model="fast"), "model") == (
        f"model 'fast' (known: {known}; tuning.model {_tuned_model({**cert, 'model': 'fast'})!r})")

    def two_tolerances(c):
        c["tolerances"]["lmi_relative"] = 1.0
        c["tolerances"]["settling_abs_s"] = 1.0

    assert detail(two_tolerances, "tolerances") == (
        "stated tolerances differ from the library's: lmi_relative, settling_abs_s")
    assert detail(_set_tolerance("anything", 1.0), "tolerances") == (
        "stated tolerances differ from the library's: anything")
    assert detail(lambda c: c["tolerances"].pop("lmi_relative"), "tolerances") == (
        "stated tolerances differ from the library's: lmi_relative")


def test_the_layout_check_reads_every_section_and_names_the_one_that_is_off(cert):
    def layout(edit, **kw):
        c = copy.deepcopy(cert)
        edit(c)
        return verify_certificate(_resign(c), simulate=False, **kw)

    # an optional section left out is skipped, and the sections after it are still read
    res = layout(lambda c: (c.pop("margins"), c["law_class"].update(extra=1.0)))
    assert [x.name for x in res.checks if not x.ok] == ["layout"]
    assert res["layout"].detail == "unexpected keys or forms in: law_class"
    # a section that is not an object is named, not an exception (fail_fast: the later checks would read it)
    res = layout(lambda c: c["lmi"].update(closed_loop=[1.0]), fail_fast=True)
    assert [x.name for x in res.checks][-1] == "layout" and not res.ok
    assert res["layout"].detail == "unexpected keys or forms in: lmi.closed_loop"
    res = layout(lambda c: next(iter(c["margins"]["break_points"].values())).update(extra=1.0))
    assert res["layout"].detail == "unexpected keys or forms in: margins.break_points"
    res = layout(lambda c: c["margins"].update(method="frequency sweep"))
    assert res["layout"].detail == "unexpected keys or forms in: margins.method"
    res = layout(lambda c: (c["lmi"]["controller_ni"].update(form="V' <= 0"),
                            c["region_of_attraction"].update(model="full")))
    assert res["layout"].detail == "unexpected keys or forms in: lmi.controller_ni.form, region_of_attraction.model"
    res = layout(lambda c: c["lmi"]["plant_ni"].update(form="V' <= 0"))
    assert res["layout"].detail == "unexpected keys or forms in: lmi.plant_ni.form"
    # a storage left out: its section and its form are named (fail_fast: the NI check would need it)
    for name in ("plant_ni", "controller_ni"):
        res = layout(lambda c: c["lmi"].pop(name), fail_fast=True)
        assert [x.name for x in res.checks][-1] == "layout" and not res.ok
        assert res["layout"].detail == f"unexpected keys or forms in: lmi, lmi.{name}, lmi.{name}.form"


def test_the_layout_of_an_sni2_certificate_has_its_own_sector_keys(shared_json):
    """The sni2 law states its gain bound k_max where the IRC states delta_min (the law's sector_limit key)."""
    from tests.test_sni2_certificate import build_sni2_certificate

    doc = shared_json("sni2-small-certificate", build_sni2_certificate)
    assert set(doc["sector"]) == {"gamma", "gamma_max", "k_max"} != SECTION_KEYS["sector"]
    assert verify_certificate(doc, simulate=False)["layout"].ok
    c = copy.deepcopy(doc)
    c["sector"]["delta_min"] = 0.1
    res = verify_certificate(_resign(c), simulate=False)
    assert not res["layout"].ok and res["layout"].detail == "unexpected keys or forms in: sector"


def test_the_settings_check_names_every_run_and_key_that_differs(cert):
    def settings(edit):
        c = copy.deepcopy(cert)
        edit(c)
        return verify_certificate(_resign(c), simulate=False)["settings"]

    def two_keys(c):
        c["performance"]["full"]["settings"].update(horizon_s=5.0, extra=1.0)

    got = settings(two_keys)
    assert not got.ok and got.detail == "inconsistent: performance.full.settings (extra, horizon_s)"
    got = settings(lambda c: c.update(cascade={**c["cascade"], "rate_hz": "fast"}))
    # the reduced run has no control rate; the full run's settings and the margins' rate both need it
    assert got.detail == ("inconsistent: performance.full.settings (cascade.rate_hz 'fast' is not a rate); "
                          "margins.rate_hz (must be 'fast')")
    got = settings(lambda c: c["region_of_attraction"].update(tilt_limit_deg=31.0))
    assert got.detail == "inconsistent: region_of_attraction.tilt_limit_deg"
    got = settings(lambda c: c["cascade"]["region_of_attraction"].update(tilt_limit_deg=31.0))
    assert got.detail == "inconsistent: cascade.region_of_attraction.tilt_limit_deg"
    got = settings(lambda c: c["lmi"]["robust_mass"].update(m_nominal_kg=0.9))
    assert got.detail == "inconsistent: lmi.robust_mass.m_nominal_kg (must be the vehicle's mass)"
    got = settings(lambda c: c["cascade"].update(rate_hz=50.0))
    assert got.detail == "inconsistent: performance.full.settings (noise_rate_hz); margins.rate_hz (must be 50.0)"
    # the margins' rate is the cascade's, not the default control rate
    got = settings(lambda c: (c["cascade"].update(rate_hz=50.0), c["margins"].update(rate_hz=50.0)))
    assert got.detail == "inconsistent: performance.full.settings (noise_rate_hz)"
    got = settings(lambda c: c["performance"].update(full=[1.0]))
    assert not got.ok and got.detail.startswith("inconsistent: performance.full.settings (") and "horizon_s" in got.detail


def test_the_law_class_check_says_why_it_refuses(cert, shared_json):
    from nniquad.laws.classes import LAW_CLASSES

    def law(c):
        return verify_certificate(_resign(c), simulate=False)["law_class"]

    c = copy.deepcopy(cert)
    c["law_class"]["name"] = "fast"
    assert law(c).detail == f"unknown law class 'fast' (known: {', '.join(LAW_CLASSES)})" and not law(c).ok
    name = cert["law_class"]["name"]
    assert law(copy.deepcopy(cert)).detail == f"class {name}; certified by {LAW_CLASSES[name].theorem}"
    c["law_class"]["name"] = 1  # not a text: unknown, not an exception
    assert law(c).detail == f"unknown law class 1 (known: {', '.join(LAW_CLASSES)})"
    c = copy.deepcopy(cert)
    c["law_class"]["theorem"] = "Lyapunov"
    assert law(c).detail == f"the stated theorem is not the {c['law_class']['name']} class's: 'Lyapunov'"
    # the cascade class without a cascade section (a schema-1 certificate stating it)
    one = copy.deepcopy(shared_json("small-certificate-schema-1", build_small_certificate_schema_1))
    one["law_class"] = {"name": "cascade", "theorem": LAW_CLASSES["cascade"].theorem}
    assert law(one).detail == "the cascade class is certified by the cascade section, and there is none"


def test_a_schema_1_certificate_passes_its_form_checks(shared_json):
    one = shared_json("small-certificate-schema-1", build_small_certificate_schema_1)
    res = verify_certificate(one, simulate=False)
    assert res.ok and [c.name for c in res.checks][:len(FORM_CHECKS)] == FORM_CHECKS
    assert not any(c.name.startswith("cascade.") for c in res.checks)


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
    from nniquad.laws.classes import LAW_CLASSES

    assert res.ok and res["law_class"].detail == ("class paper (not stated: a certificate from before classes); "
                                                  f"certified by {LAW_CLASSES['paper'].theorem}")


@pytest.mark.parametrize("path", ["lmi.plant_ni", "lmi.controller_ni", "lmi.robust_mass", "cascade.region_of_attraction",
                                  "cascade.matrices"])
@pytest.mark.parametrize("bad", [[1.0], "text"])
def test_a_section_that_is_not_an_object_is_a_one_line_error(cert, path, bad):
    """Re-signed, a part of the document replaced by a list or a text: a CertificateError naming the malformed
    field (a user error at the command line), never an AttributeError's traceback."""
    c = copy.deepcopy(cert)
    node = c
    *parents, last = path.split(".")
    for p in parents:
        node = node[p]
    node[last] = bad
    with pytest.raises(CertificateError, match=r"^certificate has a malformed field \(AttributeError: "):
        verify_certificate(_resign(c), simulate=False)


def test_the_recomputation_cache_keeps_what_is_used_and_evicts_the_least_recently_used():
    """``memo`` holds at most ``_CACHE_SIZE`` results.  A result used again stays, however many one-off
    results follow it (the tamper loop's edits), and the one not used for longest is the one that goes."""
    from nniquad.certificates import check_record as check
    check.clear_cache()
    computed = []

    def get(i):
        return check.memo("test", {"i": i}, lambda: computed.append(i) or [i])

    try:
        assert get(0) == [0] and get(1) == [1] and computed == [0, 1]
        for i in range(2, 2 + check._CACHE_SIZE):  # one-off results, each more than the cache holds
            get(i)
            assert get(0) == [0]  # used again: kept
        assert computed.count(0) == 1
        assert computed.count(1) == 1 and get(1) == [1] and computed.count(1) == 2  # unused: evicted, recomputed
        first = get(0)
        first.append("edited")  # a caller's copy: the cached result is not touched
        assert get(0) == [0]
    finally:
        check.clear_cache()
