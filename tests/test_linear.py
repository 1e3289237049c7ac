"""Reduced horizontal loop: symbolic model vs hand algebra, Routh region, sector bound, poles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nniquad.errors import GainError
from nniquad.analysis import linear as L
from nniquad.analysis.linear import ReducedLoop
from nniquad.control.gains import Gains, PAPER_GAINS

m_, kp_, G_, d_ = (L.SYMBOLS[k] for k in ("m", "kp", "Gamma", "delta"))
s = sp.Symbol("s")


def test_plant_and_controller_match_hand_derivation():
    A, B, C, D = L.plant_matrices_sym()
    # m xi'' + m kp xi = F, y = xi, state [xi, xi_dot]  (worked out by hand)
    assert A == sp.Matrix([[0, 1], [-kp_, 0]]) and B == sp.Matrix([0, 1 / m_]) and C == sp.Matrix([[1, 0]])
    G = sp.simplify((C * (s * sp.eye(2) - A).inv() * B)[0, 0])
    assert sp.simplify(G - 1 / (m_ * (s**2 + kp_))) == 0
    Ac, Bc, Cc, _ = L.controller_matrices_sym()
    Cs = sp.simplify((Cc * (s * sp.eye(1) - Ac).inv() * Bc)[0, 0])
    assert sp.simplify(Cs - G_ / (s + G_ * d_)) == 0


def test_closed_loop_matrix_and_polynomial_by_hand():
    A_cl = L.closed_loop_matrix_sym()
    assert A_cl == sp.Matrix([[0, 1, 0], [-kp_, 0, 1 / m_], [G_, 0, -G_ * d_]])
    poly = L.characteristic_polynomial().as_expr()
    hand = s**3 + G_ * d_ * s**2 + kp_ * s + G_ * (kp_ * d_ - 1 / m_)
    assert sp.simplify(poly - hand) == 0
    # the loop gain route: 1 - G(s)C(s) = 0  <=>  poly = 0
    loop = sp.together(1 - G_ / (s + G_ * d_) / (m_ * (s**2 + kp_)))
    assert sp.simplify(sp.numer(loop) / m_ - hand) == 0


def test_routh_region_is_m_kp_delta_greater_than_one():
    region = L.routh_stability_region()
    first = region["first_column"]
    assert [sp.simplify(e) for e in first[:2]] == [1, G_ * d_]
    assert sp.simplify(first[2] - 1 / (m_ * d_)) == 0  # always positive
    (cond,) = region["conditions"]
    ratio = sp.simplify(cond / (m_ * kp_ * d_ - 1))
    assert ratio.is_positive  # Gamma/m: same sign as m kp delta - 1
    assert sp.simplify(region["reduced"].lhs - (m_ * kp_ * d_ - 1)) == 0


def test_numeric_matrices_poles_three_independent_routes():
    m, kp, G, d = 0.5, 5.0, 160.0, 0.6
    loop = ReducedLoop(m, Gains(kp, G, d))
    A = loop.closed_loop_A_axis()
    coeffs = loop.characteristic_coefficients()
    np.testing.assert_allclose(coeffs, [1, 96, 5, 160], rtol=1e-14)
    np.testing.assert_allclose(np.poly(A), coeffs, rtol=1e-12)
    r1 = np.sort_complex(np.roots(coeffs))
    r2 = np.sort_complex(np.asarray(loop.closed_loop_ss().poles()))
    r3 = np.sort_complex(np.linalg.eigvals(A))
    np.testing.assert_allclose(r2, r1, rtol=1e-9)
    np.testing.assert_allclose(r3, r1, rtol=1e-9)


def test_paper_gains_dominant_pair_is_lightly_damped():
    pd = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).poles_and_damping()
    roots = np.roots([1, 96, 5, 160])
    pair = roots[np.abs(roots.imag) > 0][0]
    zeta_hand = -pair.real / abs(pair)
    assert pd.min_damping == pytest.approx(zeta_hand, rel=1e-9)
    assert 0.01 < pd.min_damping < 0.02
    assert pd.decay_rate == pytest.approx(-2 * pair.real, rel=1e-9)
    assert pd.stable


def test_two_axes_with_different_gains():
    A = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6, kpy=3.0)).closed_loop_A()
    assert A.shape == (6, 6) and np.all(A[:3, 3:] == 0) and np.all(A[3:, :3] == 0)
    np.testing.assert_array_equal(A[3:, 3:], ReducedLoop(0.5, Gains(3.0, 160.0, 0.6)).closed_loop_A_axis())
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6, kpy=3.0)).smallest_gamma == pytest.approx(1 / (0.5 * 3.0 * 0.6))
    assert not ReducedLoop(0.5, Gains(5.0, 160.0, 0.6, kpy=3.0)).stable  # 0.5*3*0.6 = 0.9 < 1
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6, kpy=4.0)).stable


def test_sector_bound_paper_numbers_and_equivalence_with_routh():
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).sector_delta_min(0.8) == pytest.approx(0.5)  # the paper's delta_min
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).smallest_gamma == pytest.approx(2 / 3)
    assert sp.simplify(L.dc_loop_gain_sym() - 1 / (m_ * kp_ * d_)) == 0
    rng = np.random.default_rng(1)
    for _ in range(200):
        m, kp, G, d = np.exp(rng.uniform(np.log([0.1, 0.5, 1, 0.05]), np.log([3, 50, 1000, 5])))
        if abs(m * kp * d - 1) < 1e-6:
            continue
        # the union of the sector regions over gamma < 1 is exactly the Routh region
        loop = ReducedLoop(m, Gains(kp, G, d))
        assert loop.sector_bound_holds == loop.stable == (np.max(np.roots(loop.characteristic_coefficients()).real) < 0)


@pytest.mark.parametrize("eps, expected", [(1e-4, True), (-1e-4, False)])
def test_stability_boundary_perturbation(eps, expected):
    m, kp, G = 0.5, 5.0, 160.0
    d = (1 + eps) / (m * kp)
    assert ReducedLoop(m, Gains(kp, G, d)).stable is expected
    assert ReducedLoop(m, Gains(kp, G, d)).poles_and_damping().stable is expected


def test_saturation_split_reassembles_the_loop():
    A0, B, K = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).saturation_split()
    np.testing.assert_array_equal(A0 + B @ K, ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).closed_loop_A_axis())
    np.testing.assert_allclose(K, [[-5.0, 0.0, 2.0]])  # a = -kp xi + z/m


def test_dc_gains_with_python_control():
    import control as ct

    loop = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6))
    assert ct.dcgain(loop.plant_ss()) == pytest.approx(1 / (0.5 * 5.0))
    assert ct.dcgain(loop.controller_ss()) == pytest.approx(1 / 0.6)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 0.0, -1.0, "x", True, None])
def test_gains_validation(bad):
    with pytest.raises(GainError) as info:
        Gains(kp=5.0, Gamma=bad, delta=0.6)
    assert "Gamma" in str(info.value) and "\n" not in str(info.value)


def test_paper_gains():
    assert PAPER_GAINS.axes() == (5.0, 5.0) and PAPER_GAINS.Gamma == 160.0 and PAPER_GAINS.delta == 0.6
    with pytest.raises(GainError):
        ReducedLoop(float("nan"), PAPER_GAINS)
