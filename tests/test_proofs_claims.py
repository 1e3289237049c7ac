"""The audit as a whole: every required claim id, valid records, JSON and Markdown output."""

from __future__ import annotations

import json

import pytest

from nniquad.proofs import claims as CL

REQUIRED = [
    "rotation-matrix", "angular-velocity-map", "lagrangian-decoupling", "thrust-vector", "translational-dynamics",
    "rotational-rows", "horizontal-subsystem", "compact-form", "nni-storage", "ni-lemma-plant", "ni-frequency-plant",
    "sni-controller", "controller-realization", "controller-ws-nni", "steady-state", "sector-bound",
    "zero-state-observability", "delta-min", "closed-loop-stability", "simulation-claim", "full-model-stability",
]


@pytest.fixture(scope="module")
def audit():
    return CL.run_audit()


def test_every_required_claim_is_registered():
    ids = CL.claim_ids()
    missing = [i for i in REQUIRED if i not in ids]
    assert not missing
    assert len(ids) == len(set(ids))


def test_records_are_complete_and_verdicts_valid(audit):
    for r in audit:
        assert r.verdict in CL.VERDICTS
        assert r.paper_ref and all(isinstance(p, str) for p in r.paper_ref)
        assert r.statement and r.reason and r.method
        assert r.evidence
        if r.verdict == CL.HOLDS:
            assert r.counterexample is None
        else:
            assert r.counterexample is not None, r.id
        if r.verdict == CL.HOLDS_WITH_CORRECTION:
            assert r.correction is not None


def test_json_round_trip(audit):
    data = CL.audit_to_json(audit)
    text = json.dumps(data, allow_nan=False)
    back = json.loads(text)
    keys = {"id", "paper_ref", "verdict", "statement", "evidence", "counterexample", "correction", "method"}
    assert all(keys <= set(c) for c in back["claims"])
    assert back["summary"]["n_claims"] == len(audit)


def test_markdown_mentions_every_claim(audit):
    md = CL.audit_to_markdown(audit)
    for r in audit:
        assert f"### {r.id}" in md
        assert r.verdict in md


def test_expected_verdicts_of_the_paper(audit):
    """The audit's headline findings (each is re-derived independently in the section tests)."""
    v = {r.id: r.verdict for r in audit}
    assert v["rotation-matrix"] == CL.HOLDS
    assert v["thrust-vector"] == CL.HOLDS_WITH_CORRECTION
    assert v["nni-storage"] == CL.HOLDS_WITH_CORRECTION
    assert v["ni-lemma-plant"] == CL.HOLDS_WITH_CORRECTION
    assert v["closed-loop-stability"] == CL.HOLDS
    assert v["simulation-claim"] == CL.FAILS


def test_invalid_verdict_is_rejected():
    with pytest.raises(ValueError):
        CL.Finding("maybe", "x")
    with pytest.raises(ValueError):
        CL.Finding(CL.HOLDS_WITH_CORRECTION, "x")  # a correction is required


def test_unknown_id_raises_key_error():
    with pytest.raises(KeyError):
        CL.run_audit(["no-such-claim"])


def test_claims_run_in_worker_processes_give_the_serial_results(audit):
    """One claim of every section run in two forked workers: the same records as the serial audit."""
    ids = ["sni-ws-nni-equivalence", "angular-velocity-map", "delta-min", "steady-state", "simulation-claim"]
    reg = CL.registry()
    assert len({reg[i].section for i in ids}) == len(CL.SECTIONS)  # every section: several tasks
    parallel = CL.run_audit(ids, workers=2)
    assert [r.id for r in parallel] == ids  # report order kept
    serial = {r.id: r for r in audit}

    def record(r):
        d = CL.audit_to_json([r])["claims"][0]
        d.pop("seconds", None)
        return json.dumps(d, sort_keys=True)

    for r in parallel:
        assert record(r) == record(serial[r.id])
