"""The audit's extensions: marked as such, and the filtered-PD identity decided by the same code that must fail a
wrong map."""

from __future__ import annotations

import pytest

from nniquad.proofs import claims as CL
from nniquad.proofs.extensions import Gam, dlt, filtered_pd_image, filtered_pd_is_nni, kd, kp, kpd, m, tauf


@pytest.fixture(scope="module")
def result():
    return filtered_pd_is_nni()


def test_the_identity_holds_and_is_an_extension(result):
    assert result.verdict == CL.HOLDS and result.kind == "extension" and result.extension
    assert result.statement.startswith(CL.EXTENSION_PREFIX)
    ev = result.evidence
    assert ev["NNI(map) - PD, simplified"] == "0" and ev["unique and equal to the map"] is True
    # the sector statement of the issue, and the paper's gamma = 0.8 region
    assert ev["gamma m kp delta - (k_p tau_f/k_d + 1) gamma under the map"] == "0"
    assert ev["gamma = 0.8: region of r = k_p tau_f/k_d"] == "Interval(1/4, oo)"
    assert ev["numeric (the tuned filtered PD of the speed study, m = 0.5 kg)"]["inside the paper's gamma = 0.8"] is False


@pytest.mark.parametrize("wrong", [
    {Gam: m * kd / tauf},                    # Gamma off by a factor tau_f
    {kp: kpd},                               # the derivative's high-frequency gain left out of kp'
    {dlt: tauf / kd},                        # the mass left out of delta
])
def test_a_wrong_map_fails(wrong):
    img = {**filtered_pd_image(), **wrong}
    r = filtered_pd_is_nni(image=img)
    assert r.verdict == CL.FAILS and r.counterexample is not None
    assert r.evidence["NNI(map) - PD, simplified"] != "0"


def test_reports_mark_the_extension(result):
    rows = [result]
    assert "[EXTENSION]" in CL.audit_table(rows)
    assert "not claims of the paper" in CL.audit_table(rows)
    md = CL.audit_to_markdown(rows)
    assert "EXTENSION: not a claim of the paper" in md and "EXTENSION, not a claim of the paper" in md
    data = CL.audit_to_json(rows)
    assert data["claims"][0]["kind"] == "extension" and data["summary"]["n_extensions"] == 1


def test_every_paper_claim_is_of_kind_paper_and_extensions_live_apart():
    reg = CL.registry()
    assert reg["filtered-pd-is-nni"].kind == "extension"
    assert all((spec.kind == "extension") == (spec.section in CL.EXTENSION_SECTIONS) for spec in reg.values())
    assert sum(spec.kind == "extension" for spec in reg.values()) >= 1
    with pytest.raises(ValueError, match="must start with"):
        CL.claim("x-ext", ["thm:main_result"], "extensions", "an extension without the prefix", "symbolic")
    with pytest.raises(ValueError, match="kind"):
        CL.ClaimResult("x", ["a"], "control_design", "s", CL.HOLDS, "r", {}, None, None, "symbolic", kind="extension")
