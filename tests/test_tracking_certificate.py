"""The ``tracking`` section of a certificate: written by the builder's function, recomputed by ``verify``, a re-signed
edit caught; a certificate from before the section verifies with the section noted as not stated.

The committed certificate is amended (a copy, re-signed with the public recipe) rather than re-issued (an hour).
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from nniquad.analysis.tracking_section import COVERS, TRACKING_KEYS, tracking_section
from nniquad.certificates import canonical_digest, verify_certificate
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.recheck_tracking import NOT_STATED, tracking_check
from nniquad.certificates.sections import certificate_gains, certificate_inner_loop, certificate_vehicle
from nniquad.certificates.verify import coverage_notes

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"


@pytest.fixture(scope="module")
def amended() -> dict:
    doc = json.loads(CERT.read_text())
    doc["tracking"] = tracking_section(certificate_vehicle(doc), certificate_gains(doc), certificate_inner_loop(doc),
                                       rate_hz=doc["cascade"]["rate_hz"], tilt_limit_deg=doc["tilt_limit_deg"])
    doc["digest"]["value"] = canonical_digest(doc)
    return doc


def test_the_stated_section_is_recomputed(amended):
    cert = Certificate.from_json(amended)
    check = tracking_check(cert)
    assert check.ok, check.detail
    assert "m without feedforward" in check.detail and "m/s²" in check.detail
    assert NOT_STATED not in coverage_notes(cert)


@pytest.mark.parametrize("path, factor_or_value", [
    (("bound_m", "feedforward"), 0.99),           # a tighter bound than recomputed (1 %)
    (("per_axis_m", "no_feedforward"), 0.99),
    (("class", "accel_limit_m_s2"), 1.01),        # a wider class, its bounds left as they were
    (("zone_holds", "no_feedforward"), True),     # a linear zone the bound does not certify
    (("covers",), "the whole box"),               # a coverage the section has no recipe for
    (("rate_hz",), 2.0),                          # a rate other than the cascade section's
])
def test_a_re_signed_edit_of_the_tracking_section_fails_verify(amended, path, factor_or_value):
    doc = copy.deepcopy(amended)
    node = doc["tracking"]
    for p in path[:-1]:
        node = node[p]
    old = node[path[-1]]
    node[path[-1]] = old * factor_or_value if isinstance(old, float) else factor_or_value
    assert node[path[-1]] != old
    doc["digest"]["value"] = canonical_digest(doc)
    res = verify_certificate(doc, simulate=False, fail_fast=True)
    assert not res.ok and res.first_failure.name == "tracking", res.first_failure


def test_a_certificate_without_the_section_notes_it_as_not_stated():
    doc = json.loads(CERT.read_text())
    cert = Certificate.from_json(doc)
    assert cert.tracking is None
    assert NOT_STATED in coverage_notes(cert)


def test_the_builder_states_the_section_for_the_nominal_vehicle(shared_json):
    from tests.test_certificate import build_small_certificate  # the shared small certificate (built once)

    doc = shared_json("small-certificate", build_small_certificate)
    assert set(doc["tracking"]) == TRACKING_KEYS and doc["tracking"]["covers"] == COVERS[0]
    assert doc["tracking"]["rate_hz"] == doc["cascade"]["rate_hz"]
    assert tracking_check(Certificate.from_json(doc)).ok


@pytest.mark.parametrize("stated, passes", [(0.0, True), (3e-7, True), (1e-4, False), (0.25, False)])
def test_the_dc_mismatch_is_compared_on_the_scale_of_one(amended, stated, passes):
    """``|c - 1|`` is rounding alone at the nominal vehicle (other digits on another BLAS kernel): a stated
    value within the tolerance of 1 is the same claim, a larger one is not."""
    doc = copy.deepcopy(amended)
    assert abs(doc["tracking"]["gains"]["dc_mismatch"]) < 1e-9  # the nominal vehicle: c = 1 up to rounding
    doc["tracking"]["gains"]["dc_mismatch"] = stated
    doc["digest"]["value"] = canonical_digest(doc)
    assert tracking_check(Certificate.from_json(doc)).ok is passes
