"""``verify`` decides every strict matrix inequality by a proof, and says how (``--json``: outcome, method, margin).

The reduced-loop checks are proven twice, by the verified Cholesky test and in exact rationals; an edit that makes
an inequality false (re-signed, so only the recomputation can catch it) is refuted by both routes.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from nniquad.certificates import canonical_digest, verify_certificate

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "notebooks" / "data" / "designs" / "sni2_paper_certificate.json"

#: The checks whose inequalities are also decided exactly (small matrices).
EXACT = {"lmi.plant_ni", "lmi.controller_ni", "lmi.closed_loop", "lmi.region_of_attraction"}
#: The checks of the cascade section proven at their points.
CASCADE_PROVEN = {"cascade.Lyapunov LMI [x]", "cascade.Lyapunov LMI [y]", "cascade.Lyapunov LMI [altitude]",
                  "cascade.Lyapunov LMI [yaw]", "cascade.grid check"}


def test_verify_json_gives_each_check_its_outcome_method_and_proven_margin(run_cli, tmp_path):
    out = tmp_path / "v.json"
    code, text, _ = run_cli("verify", "--no-simulate", "--json", str(out), str(COMMITTED))
    assert code == 0, text
    doc = json.loads(out.read_text())
    assert doc["ok"] is True and doc["outcome"] == "proven"
    checks = {c["name"]: c for c in doc["checks"]}
    for name in EXACT:
        c = checks[name]
        assert c["outcome"] == "proven" and c["method"] == "exact+verified-cholesky", name
        assert c["margin"] > 0 and {p["method"] for p in c["proofs"]} == {"exact", "verified-cholesky"}, name
        assert all(p["outcome"] == "proven" for p in c["proofs"]), name
    assert checks["lmi.robust_mass"]["outcome"] == "proven" and len(checks["lmi.robust_mass"]["proofs"]) == 402
    for name in CASCADE_PROVEN:
        assert checks[name]["outcome"] == "proven" and checks[name]["method"] == "verified-cholesky", name
    assert checks["bound"]["outcome"] == "pass" and checks["bound"]["method"] == "recomputed"
    assert "proven" in text and "exact+verified-cholesky" in text


def _resigned(doc: dict) -> dict:
    doc["digest"]["value"] = canonical_digest(doc)
    return doc


@pytest.fixture(scope="module")
def committed() -> dict:
    return json.loads(COMMITTED.read_text())


def test_a_decay_stated_beyond_what_holds_is_refuted_by_both_routes(committed):
    doc = copy.deepcopy(committed)
    doc["lmi"]["closed_loop"]["decay_rate_1_s"] *= 1.5
    res = verify_certificate(_resigned(doc), simulate=False)
    c = res["lmi.closed_loop"]
    assert not res.ok and c.outcome == "fails"
    assert {(p.method, p.outcome) for p in c.proofs if "eps" in p.inequality} == {("verified-cholesky", "fails"),
                                                                                  ("exact", "fails")}


def test_a_storage_matrix_made_indefinite_is_refuted_with_a_witness(committed):
    doc = copy.deepcopy(committed)
    P = doc["lmi"]["plant_ni"]["P"]
    P[0][0] = -abs(P[0][0])
    res = verify_certificate(_resigned(doc), simulate=False)
    c = res["lmi.plant_ni"]
    assert c.outcome == "fails" and any(p.inequality == "P > 0" and p.outcome == "fails" for p in c.proofs)


def test_a_region_decrease_edited_to_fail_is_refuted(committed):
    doc = copy.deepcopy(committed)
    doc["lmi"]["region_of_attraction"]["T"][0][0] *= -1.0
    res = verify_certificate(_resigned(doc), simulate=False)
    assert res["lmi.region_of_attraction"].outcome == "fails"
