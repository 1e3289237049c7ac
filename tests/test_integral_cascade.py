"""The cascade certificate of a law with integral action: its sampled loop, its region, its certificate.

The sampled loop of :func:`nniquad.analysis.cascade.family.sampled_family` (``x⁺ = A0 x + B sat(K x)``, the
anti-windup in ``A0`` and ``B``) is compared with one step of the simulator's generated discrete law in a saturated
state: the family comes from the hover Jacobians and ``scipy.linalg.expm``, the simulator's step from the law's own
sample update with its excess recomputed in CasADi, so the two share no code but the law's equations.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from nniquad.analysis.cascade.family import sampled_family, subsystems
from nniquad.analysis.cascade.region import start_command, start_vector
from nniquad.analysis.linearised_cascade import hover_params
from nniquad.certificates import canonical_digest, read_certificate, verify_certificate
from nniquad.cli.commands.certify_command import summary_lines
from nniquad.laws import integral_variant
from nniquad.laws.sni2 import SNI2Gains, sni2_from_nni
from nniquad.reporting.comparison import certificate_column, comparison_table
from nniquad.sim import EXO_FIELDS, initial_state, state_names
from nniquad.sim.models import step_function
from tests.test_honest_word import assert_no_contradiction
from tests.test_robust_cascade import GAINS, INNER, RATE, TILT, V

#: The sni2 law of the test design of tests/test_robust_cascade.py (its NNI law behind a fast low-pass, as in
#: tests/test_sni2_certificate.py), and its integral variant with the integral zero at 0.01 of sqrt(kp): a base law
#: that takes over at a state other than 0.
BASE = SNI2Gains(*sni2_from_nni(GAINS.kp, GAINS.Gamma, GAINS.delta, 3.0))
LAW = integral_variant(BASE.law)
GAINS_I = LAW.with_ki(BASE, 0.01 * BASE.kp ** 1.5)


@pytest.fixture(scope="module")
def fam():
    """The family of ``GAINS_I`` at the nominal point."""
    return sampled_family(V, GAINS_I, INNER, np.ones((1, 6)), tilt_limit_deg=TILT, rate_hz=RATE)


def test_the_family_loop_is_one_step_of_the_simulators_discrete_law_in_saturation(fam):
    T = 1.0 / RATE
    names = list(fam.state_names)
    n_k = len(LAW.sim_state_names)
    # a saturated state: 3 m out, the controller wound up at an arbitrary state
    xi = np.array([3.0, -2.0])
    xc = np.array([0.7, -0.4, 2.1, -1.6, 1.3, 0.9])  # zc, zcd, zci (x, y each)
    x = np.zeros(len(names))
    x[names.index("x")], x[names.index("y")] = xi
    x[[names.index(s) for s in LAW.sim_state_names]] = xc
    a = fam.K @ x
    L = float(fam.accel_limit[0])
    assert np.linalg.norm(a) > 5 * L  # deep in the saturation
    sat = a * min(1.0, L / np.linalg.norm(a))
    family_next = (fam.A0[0] @ x + fam.B[0] @ sat)[-n_k:]
    # the simulator: the full model at hover, the position held over the period that ends, a later sample
    params = hover_params(V, GAINS_I, INNER, TILT, None).with_(run={"sample_hold": 1.0, "discrete": 1.0,
                                                                    "sample_period": T})
    snames = state_names("full", LAW.name)
    X = np.array(initial_state("full", params, (0.0, 0.0)), float)
    w_hover = math.sqrt(V.m * V.g / (4.0 * V.b))
    for k in range(1, 5):
        X[snames.index(f"w{k}")] = w_hover
    X[snames.index("held_x")], X[snames.index("held_y")] = xi
    X[[snames.index(s) for s in LAW.sim_state_names]] = xc
    e = np.zeros(len(EXO_FIELDS))
    e[2] = 2.0  # a later sample instant: the controller advances one period on the held value
    X_next = np.asarray(step_function("full", LAW.name)(X, e, params.vector())).ravel()
    sim_next = X_next[[snames.index(s) for s in LAW.sim_state_names]]
    # the same state order on both sides (the family's controller states are the law's, interleaved)
    assert names[-n_k:] == list(LAW.sim_state_names)
    np.testing.assert_allclose(family_next, sim_next, rtol=1e-9, atol=1e-12)
    # and the anti-windup is what makes them agree: without it the integrator would gain T ξ, not T (ξ + ψ/ks)
    q_no_aw = xc[-2:] + T * xi
    assert np.min(np.abs(sim_next[-2:] - q_no_aw)) > 1e-3 * T


# ----------------------------------------------------------------------------- the certificate

#: A certificate of an integral design on a small box (command in tests/data/README.md).
CERT_PATH = Path(__file__).resolve().parent / "data" / "nni_i_small_box_certificate.json"
COMMITTED_NNI = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"


def _resign(c: dict) -> dict:
    c["digest"]["value"] = canonical_digest(c)
    return c


def _doc() -> dict:
    return json.loads(CERT_PATH.read_text())


def test_an_integral_certificate_verifies_and_claims_only_the_cascade_theorem():
    cert = read_certificate(CERT_PATH)
    res = verify_certificate(cert)
    assert res.ok, res.table()
    assert cert.gains.law.integral and cert.gains.ki > 0 and "ki" in cert.to_json()["gains"]
    assert cert.law_class_name == "cascade"
    # nothing of the paper's reduced loop is claimed: each section says why, in the same words
    for key in ("sector", "stability_margin", "lmi", "region_of_attraction"):
        (text,) = dict(getattr(cert, key)).values()
        assert "not applicable" in text and "thm:main_result" in text
    action = cert.law_class["integral_action"]
    assert "back-calculation" in action["anti_windup"] and "cascade" in action["certified_by"]
    assert "does not certify" in action["not_certified_by"]
    assert set(cert.start["methods"]) == {"cascade"}  # no reduced-loop region to be inside
    # the stated anti-windup is T/ks on each axis's integrator, ks = kp - C(0)/m = kp - 1/(m delta) by hand
    E = np.asarray(cert.cascade["matrices"]["E_anti_windup"])
    T = 1.0 / cert.cascade["rate_hz"]
    names = cert.cascade["matrices"]["state_names"][-E.shape[0]:]
    want = np.zeros_like(E)
    ks = cert.gains.kp - 1.0 / (cert.vehicle.m * cert.gains.delta)
    want[names.index("zci_x"), 0] = want[names.index("zci_y"), 1] = T / ks
    np.testing.assert_allclose(E, want, rtol=1e-14)
    # its region reaches through the saturation with the integrator at 0 and the NNI state at its start
    roa = cert.cascade["region_of_attraction"]
    assert roa["method"] == "lure" and roa["max_displacement_m"] > 5 * roa["linear_zone_reach_grid_m"]
    # what certify prints says the same, and no line claims the sector theorem or contradicts another
    lines = summary_lines(cert)
    assert_no_contradiction(lines, cert)
    assert any("no sector bound" in line for line in lines) and not any("gamma =" in line for line in lines)
    assert any(line.startswith("not certified by: not applicable") for line in lines)
    # the report's comparison column states no gamma and says why, where a base law's states its sector verdict
    column = certificate_column(cert)
    assert column["gamma"] is None and column["within_sector_bound"] is None
    _, rows = comparison_table({"certified law": column})
    (gamma_row,) = [r for r in rows if r[0] == "DC loop gain gamma"]
    assert gamma_row[1].startswith("not applicable (integral action")


@pytest.mark.parametrize("factor", [1.01, 0.5])
def test_a_resigned_edit_of_ki_is_caught(factor):
    c = _doc()
    c["gains"]["ki"] *= factor
    res = verify_certificate(_resign(c), simulate=False, fail_fast=True)
    assert not res.ok and res.first_failure.name in ("margins", "tracking", "cascade.nominal matrices rebuilt")


@pytest.mark.parametrize("edit", ["sector claimed", "reason edited", "integral action dropped", "E dropped"])
def test_a_resigned_claim_beyond_the_cascade_theorem_is_caught(edit):
    c = _doc()
    if edit == "sector claimed":
        c["sector"] = {"gamma": 0.5, "gamma_max": 0.8, "delta_min": 0.5}
    elif edit == "reason edited":
        c["lmi"]["not_applicable"] = "the NI sector theorem applies"
    elif edit == "integral action dropped":
        del c["law_class"]["integral_action"]
    else:
        del c["cascade"]["matrices"]["E_anti_windup"]
    res = verify_certificate(_resign(c), simulate=False, fail_fast=False)
    assert not res.ok


def test_a_law_of_the_ni_structure_cannot_state_its_theorem_not_applicable():
    c = json.loads(COMMITTED_NNI.read_text())
    c["sector"] = {"not_applicable": "no"}
    res = verify_certificate(_resign(c), simulate=False, fail_fast=True)
    assert not res.ok and res.first_failure.name == "layout"


@pytest.mark.parametrize("command", ["tune", "certify"])
def test_integral_of_a_law_without_a_variant_is_one_line(run_cli, command, tmp_path):
    code, _, err = run_cli(command, "--integral", "--controller", "pd_filtered" if command == "tune" else "nni",
                           "--law-class", "paper", *(["--out", str(tmp_path / "c.json")] if command == "certify" else []))
    # tune: pd_filtered has no integral variant; certify: nni_i has no paper class
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert ("no integral variant" in err) if command == "tune" else ("no law class 'paper'" in err)


def test_the_regions_start_is_the_base_laws_take_over_state_and_the_integrator_at_zero(fam):
    """The start vector of the Lur'e region (region.start_vector) of sni2_i: the position 1, the SNI state at its DC
    value C(0) = k/ω² per metre, z' = 0 and q = 0; its command per metre is the base law's take-over command
    -kp + k/(m ω²) (by hand), read through the family's K (from the simulator's Jacobians)."""
    base = BASE
    for axis in ("x", "y"):
        order = subsystems(fam.state_names)[axis]
        want = {axis: 1.0, f"zc_{axis}": base.k / base.omega ** 2}  # every other state (zcd, zci) at 0
        v = start_vector(fam, axis)
        assert [v[order.index(n)] for n in order] == pytest.approx([want.get(n, 0.0) for n in order], rel=1e-12)
    assert start_command(fam) == pytest.approx(base.kp - base.k / (V.m * base.omega ** 2), rel=1e-9)
