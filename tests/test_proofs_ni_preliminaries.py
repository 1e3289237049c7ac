"""Section 'Preliminaries': NI lemma, NI definition, SNI <-> WS-NNI; wrong variants and independent numbers."""

from __future__ import annotations

import numpy as np
import sympy as sp

from nniquad.analysis import reduced_loop_symbolic as L
from nniquad.analysis.reduced_loop import PAPER_LOOP
from nniquad.proofs import ni_preliminaries as N
from nniquad.proofs.claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION

m, kp, Gam, dlt = L.SYMBOLS["m"], L.SYMBOLS["kp"], L.SYMBOLS["Gamma"], L.SYMBOLS["delta"]
s = N.s_var


def test_ni_lemma_plant_variants():
    r = N.ni_lemma_plant()
    assert r.verdict == HOLDS_WITH_CORRECTION
    assert N.ni_lemma_plant(lemma="literature").verdict == HOLDS
    A, B, C, _ = L.plant_matrices_sym()
    assert N.ni_lemma_plant(plant=(A, -B, C)).verdict == FAILS  # -G is not NI


def test_ni_lemma_plant_P_matches_closed_form():
    r = N.ni_lemma_plant()
    P = np.array(r.correction["LMI (numeric)"]["P"])
    np.testing.assert_allclose(P, np.diag([0.5 * 5.0, 0.5]), rtol=1e-6, atol=1e-7)


def test_ni_lemma_controller_variant_with_gamma_delta_one_holds():
    assert N.ni_lemma_controller().verdict == HOLDS_WITH_CORRECTION
    ctrl = (sp.Matrix([[-1]]), sp.Matrix([[Gam]]), sp.Matrix([[1]]))  # Gamma delta = 1
    assert N.ni_lemma_controller(controller=ctrl, values={Gam: 2.0, dlt: 0.5, m: 0.5, kp: 5.0}).verdict == HOLDS


def test_ni_frequency_plant_and_non_ni_variants():
    assert N.ni_frequency_plant().verdict == HOLDS
    assert N.ni_frequency_plant(G=-1 / (m * (s**2 + kp))).verdict == FAILS
    assert N.ni_frequency_plant(G=1 / (m * (s**2 - kp))).verdict == FAILS


def test_residue_against_python_control():
    import control as ct

    from nniquad.analysis import frequency as F

    res, simple = F.residues_on_imaginary_axis(PAPER_LOOP.plant_ss())
    assert simple
    K0 = float(np.real(res[0][1]).ravel()[0])
    assert abs(K0 - 1 / (2 * 0.5)) < 1e-9  # closed form 1/(2m)
    r = N.ni_frequency_plant()
    k_sym = r.evidence["3. imaginary-axis poles simple with K0 = lim (s - jw0) s G(s) >= 0"]["residues"][0]["K0"]
    assert float(sp.sympify(k_sym, locals={"m": m}).subs(m, sp.Rational(1, 2))) == 1.0
    assert ct  # imported for the realisation


def test_sni_ws_nni_equivalence_counterexample_and_non_sni_variant():
    r = N.sni_ws_nni_equivalence()
    assert r.verdict == FAILS
    # a non-SNI system cannot refute the remark
    assert N.sni_ws_nni_equivalence(G=1 / (s - 1)).verdict == HOLDS


def test_storage_uniqueness_by_hand():
    an = N.controller_storage_analysis()
    assert an["NNI inequality holds for all (z, xi)"]
    z = sp.Symbol("z", real=True)
    assert not N.controller_storage_analysis(2 * dlt * z**2 / 2)["NNI inequality holds for all (z, xi)"]
