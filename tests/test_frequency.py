"""Definition-level NI / SNI checks against hand-derived frequency responses and residues."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
import sympy as sp

from nniquad.analysis.frequency import ni_check, ni_interconnection_check, residues_on_imaginary_axis
from nniquad.analysis.linear import ReducedLoop
from nniquad.control.gains import Gains


@pytest.mark.parametrize("m, kp", [(0.5, 5.0), (2.0, 0.3)])
def test_plant_is_ni_not_sni_with_hand_residue(m, kp):
    r = ni_check(ReducedLoop(m, Gains(kp=kp, Gamma=1.0, delta=1.0)).plant_ss())
    assert r.is_ni and not r.is_sni
    (w0, K0), = r.residues
    assert w0 == pytest.approx(np.sqrt(kp))
    # independent: sympy limit of (s - j w0) s G(s) with G = 1/(m (s^2 + kp))
    s = sp.Symbol("s")
    jw0 = sp.I * sp.sqrt(sp.nsimplify(kp))
    K_sym = sp.limit((s - jw0) * s / (sp.nsimplify(m) * (s**2 + sp.nsimplify(kp))), s, jw0)
    assert complex(K_sym) == pytest.approx(1 / (2 * m))
    assert K0[0, 0] == pytest.approx(complex(K_sym), rel=1e-9)
    # G(jw) is real off the pole: j(G - G*) = 0 (lossless)
    assert abs(r.grid_min_eig_relative) < 1e-12


def test_controller_is_sni_with_hand_imaginary_part():
    Gamma, delta = 160.0, 0.6
    r = ni_check(ReducedLoop(1.0, Gains(kp=1.0, Gamma=Gamma, delta=delta)).controller_ss())
    assert r.is_ni and r.is_sni
    w = np.array([0.1, 1.0, 96.0, 1e4])
    G = ct.frequency_response(ReducedLoop(1.0, Gains(kp=1.0, Gamma=Gamma, delta=delta)).controller_ss(), w).complex
    a = Gamma * delta
    # j(G - G*) = -2 Im G = 2 Gamma w / (w^2 + a^2) > 0
    np.testing.assert_allclose(-2 * G.imag, 2 * Gamma * w / (w**2 + a**2), rtol=1e-12)


@pytest.mark.parametrize(
    "num, den, reason",
    [
        ([1.0], [1.0, -1.0], "Re s > 0"),
        ([1.0], [1.0, 0.0], "origin"),
        ([-1.0], [1.0, 1.0], "negative eigenvalue"),
        ([-1.0], [1.0, 0.0, 1.0], "residue"),
        ([1.0], [1.0, 0.0, 2.0, 0.0, 1.0], "not simple"),
    ],
)
def test_non_ni_systems_are_rejected_with_a_reason(num, den, reason):
    r = ni_check(ct.tf(num, den))
    assert not r.is_ni and not r.is_sni
    assert any(reason in n for n in r.notes)


def test_double_pole_detected_as_not_simple():
    res, simple = residues_on_imaginary_axis(ct.ss(ct.tf([1.0], [1.0, 0.0, 2.0, 0.0, 1.0])))
    assert not simple


def test_interconnection_matches_routh():
    ok = ni_interconnection_check(ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).plant_ss(), ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).controller_ss())
    assert ok.dc_loop_gain == pytest.approx(1 / (0.5 * 5.0 * 0.6)) and ok.predicted_stable and ok.poles_stable
    bad = ni_interconnection_check(ReducedLoop(0.5, Gains(5.0, 160.0, 0.3)).plant_ss(), ReducedLoop(0.5, Gains(5.0, 160.0, 0.3)).controller_ss())
    assert bad.dc_loop_gain > 1 and not bad.predicted_stable and not bad.poles_stable
