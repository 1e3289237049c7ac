"""Reduced horizontal loop: symbolic model vs hand algebra, Routh region, sector bound, poles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from nniquad.errors import GainError
from nniquad.analysis import reduced_loop_symbolic as L
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.laws.nni import Gains, PAPER_GAINS

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
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).sector_limit(0.8)[1] == pytest.approx(0.5)  # the paper's delta_min
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


def test_sector_bound_and_routh_exactly_on_the_boundary():
    """m kp delta = 1 exactly (m = 0.5, kp = 4, delta = 0.5): gamma = 1 is not admissible and the loop is not
    asymptotically stable (a pole at the origin); one ulp of delta inside, both hold."""
    on = ReducedLoop(0.5, Gains(4.0, 160.0, 0.5))
    assert 0.5 * 4.0 * 0.5 == 1.0  # exact in binary floating point
    assert on.smallest_gamma == 1.0 and on.margin_product == 1.0
    assert not on.sector_bound_holds
    assert not on.stable
    # independent: a0 = G (kp d - 1/m) = 160 (2 - 2) = 0, so s = 0 is a pole
    np.testing.assert_allclose(on.characteristic_coefficients(), [1.0, 80.0, 4.0, 0.0], atol=1e-12)
    inside = ReducedLoop(0.5, Gains(4.0, 160.0, np.nextafter(0.5, 1.0)))
    assert inside.smallest_gamma < 1.0 and inside.sector_bound_holds and inside.stable
    outside = ReducedLoop(0.5, Gains(4.0, 160.0, np.nextafter(0.5, 0.0)))
    assert not outside.sector_bound_holds and not outside.stable


def test_sector_delta_min_gives_gamma_back():
    loop = ReducedLoop(0.5, Gains(4.0, 160.0, 0.5))
    for gamma in (0.3, 0.8, 0.999):
        d = loop.sector_limit(gamma)[1]
        assert d == pytest.approx(1.0 / (gamma * 0.5 * 4.0), rel=1e-14)
        assert loop.with_gains(Gains(4.0, 160.0, d)).smallest_gamma == pytest.approx(gamma, rel=1e-14)


def test_thrust_model_loop_is_the_paper_loop_with_effective_gain():
    """Thrust sized with m_hat on a vehicle of mass m: kp_eff = kp m_hat / m (characteristic polynomial by hand)."""
    nominal = ReducedLoop(0.5, PAPER_GAINS)
    for m in (0.3, 0.5, 0.9):
        true = nominal.with_mass(m, thrust_model=True)
        assert true.m == m and true.m_nominal == 0.5 and true.nominal_mass == 0.5
        hand = [1.0, 160.0 * 0.6, 5.0 * 0.5 / m, 160.0 * (5.0 * 0.5 * 0.6 - 1.0) / m]
        np.testing.assert_allclose(np.poly(true.closed_loop_A_axis()), hand, rtol=1e-12)
        np.testing.assert_allclose(true.characteristic_coefficients(), hand, rtol=1e-12)
        assert true.stable  # m_hat kp delta = 1.5 > 1 whatever the true mass
        A0, B, K = true.saturation_split()
        np.testing.assert_allclose(B[:, 0], [0.0, 0.5 / m, 0.0], rtol=1e-15)
    assert not nominal.with_mass(0.3).stable  # the paper model: 0.3 * 5 * 0.6 = 0.9 < 1


def test_reduced_loop_rejects_bad_input():
    with pytest.raises(GainError, match="m must be positive"):
        ReducedLoop(-1.0, PAPER_GAINS)
    with pytest.raises(GainError, match="law of the NI structure"):
        ReducedLoop(0.5, (5.0, 160.0, 0.6))
    with pytest.raises(GainError, match="axis"):
        ReducedLoop(0.5, PAPER_GAINS).plant_matrices("z")


# ------------------------------------------------------------------ edges found by mutation testing
# (survivors of `make mutation MODULE=sector` / `MODULE=sector_symbolic`)


def test_axes_and_per_axis_gains_with_different_kp():
    loop = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6, kpy=3.0))
    assert loop.kp() == 5.0 and loop.kp("x") == 5.0 and loop.kp("y") == 3.0  # the default axis is x
    assert loop.axes == [("x", 5.0), ("y", 3.0)]
    assert ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).axes == [("x", 5.0)]  # one axis when both share kp
    # the DC loop gain of each axis is 1/(m kp delta), x by default
    assert loop.dc_loop_gain() == pytest.approx(1 / (0.5 * 5.0 * 0.6), rel=1e-15)
    assert loop.dc_loop_gain("y") == pytest.approx(1 / (0.5 * 3.0 * 0.6), rel=1e-15)
    with pytest.raises(GainError, match="axis must be 'x' or 'y'"):
        loop.kp("z")


def test_sector_delta_min_refuses_a_non_positive_gamma_by_name():
    with pytest.raises(GainError, match="^gamma must be positive, got 0"):
        ReducedLoop(0.5, PAPER_GAINS).sector_limit(0.0)[1]


def test_reduced_routh_condition_is_exactly_m_kp_delta_minus_one_above_zero():
    reduced = L.routh_stability_region()["reduced"]
    assert isinstance(reduced, sp.StrictGreaterThan) and reduced.rhs == 0
    assert sp.expand(reduced.lhs - (m_ * kp_ * d_ - 1)) == 0


@pytest.mark.parametrize("coeffs, table", [
    # s^4 + 2 s^3 + 3 s^2 + 4 s + 5, by hand: row 2 = [(2*3 - 1*4)/2, (2*5 - 1*0)/2] = [1, 5],
    # row 3 = [(1*4 - 2*5)/1] = [-6], row 4 = [(-6*5 - 1*0)/-6] = [5]
    ([1, 2, 3, 4, 5], [[1, 3, 5], [2, 4, 0], [1, 5, 0], [-6, 0, 0], [5, 0, 0]]),
    # s^5 + 2 s^4 + 3 s^3 + 4 s^2 + 5 s + 7: row 2 = [(2*3 - 1*4)/2, (2*5 - 1*7)/2] = [1, 3/2],
    # row 3 = [(1*4 - 2*3/2)/1, (1*7 - 2*0)/1] = [1, 7], row 4 = [(1*3/2 - 1*7)/1] = [-11/2], row 5 = [7]
    ([1, 2, 3, 4, 5, 7], [[1, 3, 5], [2, 4, 7], [1, sp.Rational(3, 2), 0], [1, 7, 0], [sp.Rational(-11, 2), 0, 0],
                          [7, 0, 0]]),
    # s^3 + 2 s^2 + 3 s + 4: row 2 = [(2*3 - 1*4)/2] = [1], row 3 = [(1*4 - 2*0)/1] = [4]
    ([1, 2, 3, 4], [[1, 3], [2, 4], [1, 0], [4, 0]]),
])
def test_routh_array_by_hand(coeffs, table):
    poly = sp.Poly(coeffs, s)
    rows = L.routh_array(poly)
    assert [[sp.nsimplify(v) for v in r] for r in rows] == table
    first = [float(r[0]) for r in rows]
    changes = sum(1 for a, b in zip(first, first[1:]) if a * b < 0)
    assert changes == int(np.sum(np.roots(coeffs).real > 0))  # independent: the roots themselves


@pytest.mark.parametrize("m, gains", [(0.5, Gains(5.0, 160.0, 0.6)), (1.3, Gains(2.0, 12.0, 0.9, kpy=3.5)),
                                      (0.8, Gains(0.5, 3.0, 0.3))])
def test_poles_and_damping_match_python_control_damp(m, gains):
    """numpy's poles, natural frequencies and damping equal python-control's damp of the same closed loop."""
    import control as ct

    loop = ReducedLoop(m, gains)
    pd = loop.poles_and_damping()
    wn, zeta, poles = ct.ss(loop.closed_loop_A(), np.zeros((6, 1)), np.zeros((1, 6)), 0).damp()
    order = np.argsort(poles.real)[::-1]
    np.testing.assert_allclose(pd.poles, poles[order], rtol=1e-12)
    np.testing.assert_allclose(pd.wn, np.asarray(wn)[order], rtol=1e-12)
    np.testing.assert_allclose(pd.zeta, np.asarray(zeta)[order], rtol=1e-12, atol=1e-15)
