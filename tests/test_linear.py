"""Reduced horizontal loop: symbolic model vs hand algebra, Routh region, sector bound, poles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nniquad.errors import GainError
from nniquad.analysis import linear as L
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
    A = L.closed_loop_A_axis(m, kp, G, d)
    coeffs = L.characteristic_coefficients(m, kp, G, d)
    np.testing.assert_allclose(coeffs, [1, 96, 5, 160], rtol=1e-14)
    np.testing.assert_allclose(np.poly(A), coeffs, rtol=1e-12)
    r1 = np.sort_complex(np.roots(coeffs))
    r2 = np.sort_complex(np.asarray(L.closed_loop_ss(m, kp, G, d).poles()))
    r3 = np.sort_complex(np.linalg.eigvals(A))
    np.testing.assert_allclose(r2, r1, rtol=1e-9)
    np.testing.assert_allclose(r3, r1, rtol=1e-9)


def test_paper_gains_dominant_pair_is_lightly_damped():
    pd = L.poles_and_damping(0.5, 5.0, 160.0, 0.6)
    roots = np.roots([1, 96, 5, 160])
    pair = roots[np.abs(roots.imag) > 0][0]
    zeta_hand = -pair.real / abs(pair)
    assert pd.min_damping == pytest.approx(zeta_hand, rel=1e-9)
    assert 0.01 < pd.min_damping < 0.02
    assert pd.decay_rate == pytest.approx(-2 * pair.real, rel=1e-9)
    assert pd.stable


def test_two_axes_with_different_gains():
    A = L.closed_loop_A(0.5, 5.0, 160.0, 0.6, kpy=3.0)
    assert A.shape == (6, 6) and np.all(A[:3, 3:] == 0) and np.all(A[3:, :3] == 0)
    np.testing.assert_array_equal(A[3:, 3:], L.closed_loop_A_axis(0.5, 3.0, 160.0, 0.6))
    assert L.smallest_gamma(0.5, 5.0, 3.0, 0.6) == pytest.approx(1 / (0.5 * 3.0 * 0.6))
    assert not L.stable(0.5, 5.0, 160.0, 0.6, kpy=3.0)  # 0.5*3*0.6 = 0.9 < 1
    assert L.stable(0.5, 5.0, 160.0, 0.6, kpy=4.0)


def test_sector_bound_paper_numbers_and_equivalence_with_routh():
    assert L.sector_delta_min(0.5, 5.0, 0.8) == pytest.approx(0.5)  # the paper's delta_min
    assert L.smallest_gamma(0.5, 5.0, None, 0.6) == pytest.approx(2 / 3)
    assert sp.simplify(L.dc_loop_gain_sym() - 1 / (m_ * kp_ * d_)) == 0
    rng = np.random.default_rng(1)
    for _ in range(200):
        m, kp, G, d = np.exp(rng.uniform(np.log([0.1, 0.5, 1, 0.05]), np.log([3, 50, 1000, 5])))
        if abs(m * kp * d - 1) < 1e-6:
            continue
        # the union of the sector regions over gamma < 1 is exactly the Routh region
        assert L.sector_bound_holds(m, kp, None, d) == L.stable(m, kp, G, d) == (np.max(np.roots(L.characteristic_coefficients(m, kp, G, d)).real) < 0)


@pytest.mark.parametrize("eps, expected", [(1e-4, True), (-1e-4, False)])
def test_stability_boundary_perturbation(eps, expected):
    m, kp, G = 0.5, 5.0, 160.0
    d = (1 + eps) / (m * kp)
    assert L.stable(m, kp, G, d) is expected
    assert L.poles_and_damping(m, kp, G, d).stable is expected


def test_saturation_split_reassembles_the_loop():
    A0, B, K = L.saturation_split(0.5, 5.0, 160.0, 0.6)
    np.testing.assert_array_equal(A0 + B @ K, L.closed_loop_A_axis(0.5, 5.0, 160.0, 0.6))
    np.testing.assert_allclose(K, [[-5.0, 0.0, 2.0]])  # a = -kp xi + z/m


def test_dc_gains_with_python_control():
    import control as ct

    assert ct.dcgain(L.plant_ss(0.5, 5.0)) == pytest.approx(1 / (0.5 * 5.0))
    assert ct.dcgain(L.controller_ss(160.0, 0.6)) == pytest.approx(1 / 0.6)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 0.0, -1.0, "x", True, None])
def test_gains_validation(bad):
    with pytest.raises(GainError) as info:
        Gains(kp=5.0, Gamma=bad, delta=0.6)
    assert "Gamma" in str(info.value) and "\n" not in str(info.value)


def test_paper_gains():
    assert PAPER_GAINS.axes() == (5.0, 5.0) and PAPER_GAINS.Gamma == 160.0 and PAPER_GAINS.delta == 0.6
    with pytest.raises(GainError):
        L.closed_loop_A_axis(float("nan"), 5.0, 160.0, 0.6)
