"""The cascade's Lyapunov inequality over the cells of a box (:mod:`nniquad.analysis.cascade.box_proof`).

Synthetic families with a known answer first (the contraction in closed form), then the real section of
tests/test_robust_cascade.py re-proven by ``check_cascade_rows(thorough=True)``.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.cascade.box_proof import box_proof, prove_box
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.spd import FAILS, PROVEN


def _mass_box(lo: float, hi: float) -> ParameterBox:
    return ParameterBox(mass_factor=(lo, hi), inertia_factor=(1.0, 1.0), attitude_gain_factor=(1.0, 1.0),
                        tau_motor_factor=(1.0, 1.0))


def _constant_identity_P(n: int) -> IMat:
    Q = np.zeros((7, n, n))
    Q[0] = np.eye(n)
    return IMat.point(Q)


def _family(s):
    """``A(θ) = diag(s(mass), 0.5)``: its contraction in the identity metric is ``max(|s|, 0.5)``."""
    def evaluate(points: np.ndarray) -> np.ndarray:
        out = np.zeros((points.shape[0], 2, 2))
        out[:, 0, 0] = s(points[:, 0])
        out[:, 1, 1] = 0.5
        return out
    return evaluate


def test_a_linear_family_inside_its_contraction_is_proven_on_every_cell():
    got = box_proof(_family(lambda m: 0.9 * m), _mass_box(0.8, 1.05), 4, _constant_identity_P(2), 0.99)
    assert got.outcome == PROVEN and got.cells >= got.initial_cells == 3 and got.failed_cell is None
    assert got.min_margin > 0


def test_a_family_that_leaves_its_contraction_inside_the_box_fails_at_a_named_cell():
    """s = 0.9 m exceeds 0.99 above m = 1.1: the failed cell lies there and its centre is a counterexample."""
    got = box_proof(_family(lambda m: 0.9 * m), _mass_box(0.8, 1.2), 4, _constant_identity_P(2), 0.99)
    assert got.outcome == FAILS
    lo, hi = got.failed_cell["mass"]
    assert 0.9 * np.sqrt(lo * hi) > 0.99 and hi > 1.1


def test_a_bump_between_the_grid_points_is_caught_by_the_interpolation_allowance():
    """s = 0.98 - 2 (m - 1)²: 0.90 at both grid points of a 2-point grid, 0.98 at the centre.  At rho = 0.95 the
    grid points contract and the middle does not: the proof must not pass on the corners alone."""
    bump = _family(lambda m: 0.98 - 2.0 * (m - 1.0) ** 2)
    got = box_proof(bump, _mass_box(0.8, 1.2), 2, _constant_identity_P(2), 0.95)
    assert got.outcome == FAILS and got.failed_cell["mass"][0] < 1.0 < got.failed_cell["mass"][1]
    # at rho = 0.99 the whole bump contracts, and the refinement proves it
    ok = box_proof(bump, _mass_box(0.8, 1.2), 2, _constant_identity_P(2), 0.99)
    assert ok.outcome == PROVEN and ok.refined > 0  # the 2-point grid's one cell needed cutting


def test_prove_box_falls_back_to_a_weaker_contraction_it_can_prove():
    """Grid worst 0.9 x 1.05 = 0.945: half the margin (0.9725) holds on the continuum of s = 0.9 m."""
    got = prove_box(_family(lambda m: 0.9 * m), _mass_box(0.8, 1.05), 3, _constant_identity_P(2), 0.945)
    assert got.outcome == PROVEN and got.rho == pytest.approx(1 - 0.5 * (1 - 0.945))


# ----------------------------------------------------------------------------- the real section


@pytest.fixture(scope="module")
def section(shared_json):
    from nniquad.analysis.cascade import box_certificate as RC
    from tests.test_robust_cascade import BOX, GAINS, INNER, RATE, TILT, V

    return shared_json("robust-cascade-section", lambda: RC.cascade_section(
        V, GAINS, INNER, tilt_limit_deg=TILT, rate_hz=RATE, box=BOX, grid_points_per_axis=2))


def _rows(sec, **kw):
    from nniquad.analysis.cascade import box_certificate as RC
    from tests.test_robust_cascade import GAINS, INNER, TILT, V

    return {n: (ok, d, p) for n, ok, d, p in RC.check_cascade_rows(sec, V, GAINS, INNER, tilt_limit_deg=TILT, **kw)}


def test_the_stated_box_proof_is_re_proven_by_thorough_and_equals_the_recomputed_one(section):
    stated = section["box_proof"]
    assert stated["outcome"] == PROVEN and stated["cells"] >= stated["initial_cells"]
    ok, detail, proofs = _rows(section, thorough=True)["box cells"]
    assert ok and [p.outcome for p in proofs] == [PROVEN] and f"{stated['cells']} cells" in detail
    # by default only the stated form is checked, and the detail says so
    ok, detail, proofs = _rows(section)["box cells"]
    assert ok and not proofs and "--thorough" in detail


@pytest.mark.parametrize("key, value, caught_by_default", [
    ("cells", 1, False), ("refined", 7, False), ("depth", 9, False), ("max_allowance", 0.5, False),
    ("min_margin", 0.123, False), ("rho", 0.5, True), ("outcome", "not proven", True),
    ("enclosure", "interval arithmetic", True), ("failed_cell", {"mass": [1, 2]}, True),
])
def test_an_edited_box_proof_is_caught(section, key, value, caught_by_default):
    sec = copy.deepcopy(section)
    sec["box_proof"][key] = value
    assert not _rows(sec, thorough=True)["box cells"][0], key
    assert _rows(sec)["box cells"][0] is (not caught_by_default), key


def test_the_lure_decrease_enclosure_contains_the_form_the_region_module_writes():
    """Two codings of the same form ``F`` (module region: numpy; lure_proof: midpoint-radius, with the selector
    products written as placements) agree within the enclosure's radius, on random data."""
    from nniquad.analysis.cascade.lure_proof import decrease_enclosure
    from nniquad.analysis.cascade.region import decrease_forms

    rng = np.random.default_rng(1)
    N, n, m = 5, 6, 1
    A = rng.standard_normal((N, n, n)) * 0.3
    Bh, Kh, G = rng.standard_normal((N, n, m)), rng.standard_normal((N, m, n)), rng.standard_normal((N, m, n))
    P = rng.standard_normal((N, n, n))
    P = P @ np.swapaxes(P, 1, 2) + np.eye(n)
    mu = rng.uniform(0, 2, N)
    F, _ = decrease_forms(A, Bh, Kh, P, G, mu, 0.97)
    M = decrease_enclosure(A, Bh, Kh, P, G, mu, 0.97)
    assert np.all(np.abs(M.mid + F) <= M.rad + 1e-12 * np.abs(F))


def test_a_section_whose_box_is_widened_past_what_it_holds_fails_at_a_named_cell(section):
    """The same stated P(θ) over a box four times wider in the motor lag (its normalised coordinates stretched with
    it): ``verify --thorough`` refuses the box, and the failing cell is named."""
    sec = copy.deepcopy(section)
    lo, hi = sec["box"]["tau_motor_factor"]
    sec["box"]["tau_motor_factor"] = [lo / 4.0, hi * 4.0]
    rows = _rows(sec, thorough=True)
    ok, detail, proofs = rows["box cells"]
    assert not ok and [p.outcome for p in proofs] == [FAILS]
    assert proofs[0].where.startswith("cell {") and "'tau_motor': [" in proofs[0].where
    # the grid's own worst contraction is past 1: the grid row is refuted too, at rho = 1 at most
    ok, _, proofs = rows["grid check"]
    assert not ok and proofs[0].outcome == FAILS and "rho = worst" in proofs[0].inequality
