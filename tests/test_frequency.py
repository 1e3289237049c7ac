"""Definition-level NI / SNI checks against hand-derived frequency responses and residues."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
import sympy as sp

from nniquad.analysis.frequency import ni_check, ni_interconnection_check, residues_on_imaginary_axis
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.laws.nni import Gains


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


def _systems():
    """State-space systems of several shapes: the reduced loop's plant and controller, a 3-state SISO with a
    direct term, a 2x2 MIMO, and a discrete one."""
    loop = ReducedLoop(0.7, Gains(4.0, 30.0, 0.8))
    mimo = ct.ss([[-1.0, 2.0], [-3.0, -0.5]], [[1.0, 0.0], [0.5, 1.0]], [[1.0, 0.2], [0.0, 1.0]],
                 [[0.1, 0.0], [0.0, 0.0]])
    return [loop.plant_ss(), loop.controller_ss(), ct.ss(ct.tf([2.0, 1.0, 3.0], [1.0, 3.0, 2.0, 1.0])), mimo,
            ct.c2d(ct.ss(ct.tf([1.0], [1.0, 0.4, 4.0])), 0.05)]


@pytest.mark.parametrize("index", range(5))
def test_linear_system_evaluates_as_python_control(index):
    """Frequency response and DC gain of LinearSystem (numpy) against python-control's on the same matrices."""
    from nniquad.analysis.loops import as_linear_system

    sys = _systems()[index]
    mine = as_linear_system(sys)
    w = np.geomspace(0.01, 50.0, 37)
    np.testing.assert_allclose(mine.frequency_response(w), ct.frequency_response(sys, w, squeeze=False).complex,
                               rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(np.atleast_2d(mine.dc_gain()), np.atleast_2d(ct.dcgain(sys)), rtol=1e-13)
    np.testing.assert_allclose(np.sort_complex(mine.poles()), np.sort_complex(sys.poles()), rtol=1e-13)


@pytest.mark.parametrize("sign", [+1, -1])
def test_feedback_matrix_has_python_controls_poles(sign):
    """feedback_matrix against python-control's feedback, with and without direct terms (an algebraic loop)."""
    from nniquad.analysis.loops import as_linear_system, feedback_matrix

    loop = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6))
    pairs = [(loop.plant_ss(), loop.controller_ss()),
             (ct.ss(ct.tf([1.0, 2.0], [1.0, 1.0, 3.0])), ct.ss(ct.tf([0.5, 1.0], [1.0, 4.0])))]  # D_K != 0
    for G, K in pairs:
        A = feedback_matrix(as_linear_system(G), as_linear_system(K), sign=sign)
        np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)),
                                   np.sort_complex(ct.feedback(G, K, sign=sign).poles()), rtol=1e-12, atol=1e-12)


def test_interconnection_check_is_the_same_for_python_control_and_numpy_systems():
    loop = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6))
    a = ni_interconnection_check(loop.plant_ss(), loop.controller_ss())
    b = ni_interconnection_check(loop.plant_system(), loop.controller_system())
    assert (a.predicted_stable, a.poles_stable, a.plant.is_ni, a.controller.is_sni) == \
        (b.predicted_stable, b.poles_stable, b.plant.is_ni, b.controller.is_sni) == (True, True, True, True)
    assert a.dc_loop_gain == pytest.approx(b.dc_loop_gain, rel=1e-15)
    np.testing.assert_allclose(np.sort_complex(a.poles), np.sort_complex(b.poles), rtol=1e-13)
    np.testing.assert_allclose(np.sort_complex(b.poles), np.sort_complex(
        ct.feedback(loop.plant_ss(), loop.controller_ss(), sign=+1).poles()), rtol=1e-12)
