"""Section 'Control design': each claim against a wrong variant, and numbers from independent routes."""

from __future__ import annotations

import numpy as np
import sympy as sp

from nniquad.analysis import reduced_loop_symbolic as L
from nniquad.analysis.reduced_loop import PAPER_LOOP
from nniquad.proofs import control_design as C
from nniquad.proofs.claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION, jsonable

m, kpx, kpy, Fx, Fy = C.m, C.kpx, C.kpy, C.Fx, C.Fy
x1, x2, x3, x4 = C.x1, C.x2, C.x3, C.x4
Gam, dlt = C.Gam, C.dlt


def test_horizontal_subsystem_wrong_sign_fails():
    assert C.horizontal_subsystem().verdict == HOLDS_WITH_CORRECTION
    rows = C.paper_horizontal_subsystem()
    wrong = rows.copy()
    wrong[3] = -rows[3] - 2 * kpy * x3  # -(u1/m) s_phi - kp y: wrong sign of the physical term
    assert C.horizontal_subsystem(rows=wrong).verdict == FAILS


def test_compact_form_without_m_fails():
    assert C.compact_form().verdict == HOLDS
    wrong = sp.Matrix([m * C.xdd + kpx * x1 - Fx, m * C.ydd + kpy * x3 - Fy])
    assert C.compact_form(lhs=wrong).verdict == FAILS


def test_nni_storage_variants():
    r = C.nni_storage()
    assert r.verdict == HOLDS_WITH_CORRECTION
    good = sp.Rational(1, 2) * m * (x2**2 + x4**2) + sp.Rational(1, 2) * m * (kpx * x1**2 + kpy * x3**2)
    assert C.nni_storage(storage=good).verdict == HOLDS
    # the proof's own dynamics (m xi'' + Kp xi = F) make the paper's storage exact
    proof_dyn = sp.Matrix([m * C.xdd + kpx * x1 - Fx, m * C.ydd + kpy * x3 - Fy])
    assert C.nni_storage(dynamics=proof_dyn).verdict == HOLDS


def test_nni_storage_counterexample_by_hand():
    # m = 0.5, kp = 5, xi = (1, 0), xi' = (1, 0), F = 0: V' = m xi' xi'' + kp xi xi' = 0.5*(-5) + 5 = 2.5
    r = C.nni_storage()
    assert float(sp.sympify(r.counterexample["dV/dt"])) == 2.5


def test_sni_controller_unstable_variant_fails():
    assert C.sni_controller().verdict == HOLDS
    assert C.sni_controller(C=Gam / (C.s_var - Gam * dlt)).verdict == FAILS


def test_sni_expression_numeric():
    w, G, d = 1.7, 160.0, 0.6
    c = G / (1j * w + G * d)
    assert abs((1j * (c - np.conj(c))).real - 2 * G * w / (w**2 + G**2 * d**2)) < 1e-12


def test_controller_realization_wrong_sign_fails():
    assert C.controller_realization().verdict == HOLDS
    Ac, Bc, Cc = C.paper_controller_realization()
    assert C.controller_realization(realization=(-Ac, Bc, Cc)).verdict == FAILS


def test_controller_ws_nni_wrong_storage_fails():
    assert C.controller_ws_nni().verdict == HOLDS_WITH_CORRECTION
    z = sp.Symbol("z", real=True)
    assert C.controller_ws_nni(storage=dlt * z**2).verdict == FAILS


def test_steady_state_wrong_formula_fails():
    assert C.steady_state().verdict == HOLDS
    assert C.steady_state(xbar=sp.Matrix([Fx / kpx, Fy / kpy])).verdict == FAILS


def test_sector_bound_wrong_threshold_fails():
    assert C.sector_bound().verdict == HOLDS
    assert C.sector_bound(threshold=lambda mm, k, g: 1 / (g**2 * mm * k**2)).verdict == FAILS


def test_zero_state_observability_unobservable_variant():
    assert C.zero_state_observability().verdict == HOLDS
    A = sp.Matrix([[0, 1], [0, 0]])
    assert C.zero_state_observability(A=A, C=sp.Matrix([[0, 1]])).verdict == FAILS


def test_closed_loop_negative_feedback_fails():
    assert C.closed_loop_stability().verdict == HOLDS
    assert C.closed_loop_stability(sign=-1).verdict == FAILS


def test_closed_loop_poles_match_closed_form_cubic():
    """Closed-form (Cardano) roots of s^3 + 96 s^2 + 5 s + 160 against the audit's poles."""
    sv = sp.Symbol("s")
    exact = [complex(r.evalf(30)) for r in sp.roots(sp.Poly(sv**3 + 96 * sv**2 + 5 * sv + 160, sv), cubics=True)]
    r = C.closed_loop_stability()
    poles = jsonable(r.evidence["paper's gains: poles (numpy roots / eig / python-control feedback)"])
    audit = [complex(p["re"], p["im"]) if isinstance(p, dict) else complex(p) for p in poles]
    for p in exact:
        assert min(abs(p - q) for q in audit) < 1e-5


def test_remark_robustness_variant_within_bound_holds():
    assert C.remark_robustness().verdict == HOLDS_WITH_CORRECTION
    assert C.remark_robustness(true_masses=(0.5, 0.7, 1.5)).verdict == HOLDS
    # independent: Routh boundary 1/(kp delta) = 1/3 kg
    assert PAPER_LOOP.with_mass(0.34).stable and not PAPER_LOOP.with_mass(0.33).stable


def test_closed_loop_claim_needs_its_symbolic_routh_check():
    """A loop whose poles are stable at the paper's gains but which the constraint does not make stable.

    The coupling 1.2/m instead of 1/m gives a0 = Gamma (kp delta - 1.2/m): stable iff m kp delta > 1.2.  The
    paper's gains (m kp delta = 1.5) pass the numeric pole check; gains on the constraint with gamma close to 1
    (m kp delta = 1/gamma ~ 1.05) do not, and only the symbolic Routh check under the constraint sees it.
    """
    m_, kp_, G_, d_ = (L.SYMBOLS[k] for k in ("m", "kp", "Gamma", "delta"))
    variant = sp.Matrix([[0, 1, 0], [-kp_, 0, sp.Rational(6, 5) / m_], [G_, 0, -G_ * d_]])
    at_paper = np.array(variant.subs({m_: 0.5, kp_: 5.0, G_: 160.0, d_: 0.6}), dtype=float)
    assert np.max(np.linalg.eigvals(at_paper).real) < 0  # the numeric route alone would accept it
    near_edge = np.array(variant.subs({m_: 0.5, kp_: 5.0, G_: 160.0, d_: 1.05 / 2.5}), dtype=float)
    assert np.max(np.linalg.eigvals(near_edge).real) > 0  # yet it is unstable inside the constraint
    r = C.closed_loop_stability(closed_loop=variant)
    assert r.verdict == FAILS
    assert C.closed_loop_stability(closed_loop=C._closed_loop_sym(+1)).verdict == HOLDS
