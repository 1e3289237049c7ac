"""The numpy re-checks of :mod:`nniquad.analysis.lmi.checks` against hand-written closed forms.

Scalar (1 x 1) systems make every matrix of the checks writable by hand; the
cases were chosen so that each term of a maximum, each sign and each power is
the one that decides the answer somewhere (the survivors of
``make mutation MODULE=checks``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nniquad.analysis.lmi import checks


def m(x: float) -> np.ndarray:
    return np.array([[float(x)]])


def eigmax_2x2(a: float, b: float, d: float) -> float:
    """Largest eigenvalue of the symmetric [[a, b], [b, d]]."""
    return (a + d) / 2 + math.hypot((a - d) / 2, b)


@pytest.mark.parametrize("p, a, b, c, scale", [
    (2.0, -2.0, 1.0, 0.5, 4.0),    # |p a| = 4 is the largest term
    (0.1, -3.0, 3.0, 2.0, 18.0),   # |a c b| = 18
    (0.1, -0.1, 2.0, 3.0, 6.0),    # |c b| = 6
    (1e-3, -1e-3, 1e-3, 2e-3, 2e-6),  # all terms small: no floor of 1 on the scale
])
def test_dissipation_residual_of_a_scalar_system(p, a, b, c, scale):
    # M = [[2 p a, p b - a c], [b p - c a, -2 c b]] (x' = a x + b u, y = c x, V = p x^2 / 2)
    M = checks.ni_dissipation_matrix(m(p), m(a), m(b), m(c))
    assert np.allclose(M, [[2 * p * a, p * b - a * c], [b * p - c * a, -2 * c * b]], rtol=0, atol=1e-15)
    expected = eigmax_2x2(2 * p * a, p * b - a * c, -2 * c * b) / scale
    assert abs(expected) > 1e-5  # a case with a zero eigenvalue would not show the scale
    assert checks.dissipation_residual(m(p), m(a), m(b), m(c)) == pytest.approx(expected, rel=1e-12)


def test_dissipation_residual_of_the_zero_system_is_zero():
    z = m(0.0)
    assert checks.dissipation_residual(z, z, z, z) == 0.0


def test_norm_is_the_largest_spectral_norm():
    # spectral norm of diag(3, 4) is 4 (Frobenius would be 5); of [[0, 2], [0, 0]] it is 2
    assert checks.norm(np.diag([3.0, 4.0])) == pytest.approx(4.0, rel=1e-15)
    assert checks.norm(np.array([[0.0, 2.0], [0.0, 0.0]]), np.diag([3.0, 4.0])) == pytest.approx(4.0, rel=1e-15)
    assert checks.norm(np.diag([1.0, 1.0]), np.array([[1.0, 1.0], [1.0, 1.0]])) == pytest.approx(2.0, rel=1e-15)


def test_certified_rate_closed_forms_and_non_definite_P():
    # A = diag(-1, -3), P = I: A'P + PA = diag(-2, -6) <= -eps I for eps <= 2
    A = np.diag([-1.0, -3.0])
    assert checks.certified_rate(A, np.eye(2)) == pytest.approx(2.0, rel=1e-14)
    # P = diag(1, 4): L^-1 (A'P + PA) L^-T = diag(-2, -6) again (diagonal, so scale-free)
    assert checks.certified_rate(A, np.diag([1.0, 4.0])) == pytest.approx(2.0, rel=1e-14)
    # a singular or a negative P certifies nothing
    assert checks.certified_rate(A, np.diag([1.0, 0.0])) == -math.inf
    assert checks.certified_rate(A, -np.eye(2)) == -math.inf


def test_roa_decrease_matrix_of_a_scalar_loop():
    a, b, p, g, t = -1.5, 2.0, 3.0, 0.25, 0.7
    got = checks.roa_decrease_matrix(m(a), m(b), m(p), m(g), m(t))
    want = [[2 * a * p, -p * b + g * t], [-b * p + t * g, -2 * t]]
    assert np.allclose(got, want, rtol=0, atol=1e-15)


def test_roa_inclusion_margin_against_the_ellipsoid_boundary():
    K, G, W, u0 = np.array([[2.0, 0.5]]), np.array([[1.0, 0.5]]), np.diag([4.0, 1.0]), 3.0
    # (K - G) = [1, 0]: (K - G) W (K - G)' = 4, so the margin is (9 - 4) / 9
    assert checks.roa_inclusion_margin(K, G, W, u0) == pytest.approx(5.0 / 9.0, rel=1e-15)
    # independent: the largest |(K - G) x| on the boundary x' W^-1 x = 1 (x = W^1/2 [cos s, sin s]) is 2 < 3
    s = np.linspace(0.0, 2 * np.pi, 100001)
    x = np.sqrt(np.diag(W))[:, None] * np.vstack([np.cos(s), np.sin(s)])
    peak = np.max(np.abs((K - G) @ x))
    assert peak == pytest.approx(2.0, rel=1e-9)
    assert checks.roa_inclusion_margin(K, G, W, u0) == pytest.approx((u0**2 - peak**2) / u0**2, rel=1e-8)
    # an ellipsoid reaching past the limit has a negative margin: u0 = 1.5 < 2
    assert checks.roa_inclusion_margin(K, G, W, 1.5) == pytest.approx((2.25 - 4.0) / 2.25, rel=1e-15)


def test_ellipsoid_level():
    P = np.diag([0.25, 1.0])
    assert checks.ellipsoid_level(P, [2.0, 0.0]) == pytest.approx(1.0, rel=1e-15)  # on the boundary
    assert checks.ellipsoid_level(P, np.array([[1.0], [0.5]])) == pytest.approx(0.5, rel=1e-15)


# ----------------------------------------------------------------------------- rounding bounds
# Each value below is worked out by hand from the definitions in the docstrings, on matrices whose diagonal
# scaling is exact: P = [[4, 2], [2, 9]] has D^-1/2 = diag(1/2, 1/3), so P_s = [[1, 1/3], [1/3, 1]] with
# eigenvalues 2/3 and 4/3 (condition number 2).

EPS = np.finfo(np.float64).eps
P2 = np.array([[4.0, 2.0], [2.0, 9.0]])
A2 = np.array([[1.0, 2.0], [3.0, 4.0]])
A2_S = np.array([[1.0, 4.0 / 3.0], [9.0 / 2.0, 4.0]])  # D^1/2 A D^-1/2 = a_ij d_i / d_j with d = (2, 3)


def spectral_norm_2x2(M: np.ndarray) -> float:
    """sqrt of the largest eigenvalue of M'M, by the 2 x 2 closed form."""
    S = M.T @ M
    return math.sqrt(eigmax_2x2(S[0, 0], S[0, 1], S[1, 1]))


def test_rounding_safety_constants():
    assert checks.EPS == 2.0**-52 and checks.ROUNDING_SAFETY == 10.0


def test_scaled_form_by_hand_and_the_invariant_it_keeps():
    Ps, As = checks.scaled_form(np.array([[4.0, 1.0], [3.0, 9.0]]), A2)  # the symmetric part of P is P2
    assert np.allclose(Ps, [[1.0, 1.0 / 3.0], [1.0 / 3.0, 1.0]], rtol=0, atol=1e-15)
    assert np.allclose(As, A2_S, rtol=0, atol=1e-15)
    assert checks.scaled_form(P2)[1] is None
    # independent: the P-norm of A (largest generalised eigenvalue of (A'PA, P)) is the same for (P_s, A_s)
    import scipy.linalg

    def p_norm(P, A):
        return math.sqrt(scipy.linalg.eigh(A.T @ P @ A, P, eigvals_only=True)[-1])

    assert p_norm(Ps, As) == pytest.approx(p_norm(P2, A2), rel=1e-12, abs=0)
    # a stack is scaled matrix by matrix
    Ps_stack, _ = checks.scaled_form(np.stack([P2, np.diag([1.0, 16.0])]))
    assert np.allclose(Ps_stack[1], np.eye(2), rtol=0, atol=0)
    # a non-positive diagonal entry leaves NaN in its row and column, silently
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Ps_bad, As_bad = checks.scaled_form(np.diag([-1.0, 4.0]), A2)
    assert np.isnan(Ps_bad[0]).all() and np.isnan(Ps_bad[:, 0]).all() and Ps_bad[1, 1] == 1.0
    assert np.isnan(As_bad[0]).all() and As_bad[1, 1] == 4.0
    # a zero diagonal entry, too, even with a non-zero off-diagonal (not an infinite entry)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Ps_zero, _ = checks.scaled_form(np.array([[0.0, 1.0], [1.0, 4.0]]))
        Ps_inf, _ = checks.scaled_form(np.diag([np.inf, 1.0]))  # inf / inf: NaN, silently
    assert np.isnan(Ps_zero[0]).all() and np.isnan(Ps_zero[:, 0]).all()
    assert np.isnan(Ps_inf[0, 0])
    # the symmetric part is taken matrix by matrix in a stack too
    Ps_ns, _ = checks.scaled_form(np.stack([np.array([[4.0, 1.0], [3.0, 9.0]]), np.eye(2)]))
    assert np.allclose(Ps_ns[0], [[1.0, 1.0 / 3.0], [1.0 / 3.0, 1.0]], rtol=0, atol=1e-15)


def test_definite_margin_by_hand():
    # P_s = I: lambda_min 1, bound 10 n eps ||P_s|| = 10 * 3 * eps
    lam, bound = checks.definite_margin(np.diag([1.0, 4.0, 9.0]))
    assert lam == pytest.approx(1.0, rel=1e-15, abs=0) and bound == pytest.approx(30.0 * EPS, rel=1e-12, abs=0)
    assert isinstance(lam, float) and isinstance(bound, float)
    lam, bound = checks.definite_margin(P2)
    assert lam == pytest.approx(2.0 / 3.0, rel=1e-14, abs=0) and bound == pytest.approx(20.0 * EPS * 4.0 / 3.0, rel=1e-12, abs=0)
    # indefinite with a positive diagonal: lambda(P_s) = -1, 3, and the bound takes the largest |lambda|
    lam, bound = checks.definite_margin(np.array([[1.0, 2.0], [2.0, 1.0]]))
    assert lam == pytest.approx(-1.0, rel=1e-14, abs=0) and bound == pytest.approx(20.0 * EPS * 3.0, rel=1e-12, abs=0)
    # a non-positive diagonal is not positive definite at all: -inf, with the bound of a unit matrix
    assert checks.definite_margin(np.diag([0.0, 1.0])) == (-math.inf, pytest.approx(20.0 * EPS, rel=1e-12, abs=0))
    # a stack gives one pair per matrix
    lam, bound = checks.definite_margin(np.stack([np.diag([1.0, 4.0]), P2, np.diag([-1.0, 1.0])]))
    assert np.allclose(lam[:2], [1.0, 2.0 / 3.0], rtol=1e-14, atol=0) and lam[2] == -math.inf
    assert np.allclose(bound, [20.0 * EPS, 20.0 * EPS * 4.0 / 3.0, 20.0 * EPS], rtol=1e-12, atol=0)


def test_contraction_rounding_bound_by_hand():
    norm_as = spectral_norm_2x2(A2_S)
    # P = diag(4, 9): P_s = I, kappa 1: 10 n eps (|rho| + ||A_s||), with A_s as for P2 (same diagonal)
    got = checks.contraction_rounding_bound(A2, np.diag([4.0, 9.0]), -0.5)
    assert got == pytest.approx(20.0 * EPS * (0.5 + norm_as), rel=1e-12, abs=0)
    # P2: kappa = (4/3) / (2/3) = 2
    got = checks.contraction_rounding_bound(A2, P2, 0.9)
    assert got == pytest.approx(20.0 * EPS * (2.0 * 0.9 + math.sqrt(2.0) * norm_as), rel=1e-12, abs=0)
    assert isinstance(got, float)
    # not positive definite (indefinite, or a zero diagonal): nothing is certified, the bound is infinite
    assert checks.contraction_rounding_bound(A2, np.array([[1.0, 2.0], [2.0, 1.0]]), 0.5) == math.inf
    assert checks.contraction_rounding_bound(A2, np.diag([0.0, 1.0]), 0.5) == math.inf
    # stacks: one bound per (A, P, rho)
    out = checks.contraction_rounding_bound(np.stack([A2, A2]), np.stack([np.diag([4.0, 9.0]), P2]),
                                            np.array([0.5, 0.9]))
    assert np.allclose(out, [20.0 * EPS * (0.5 + norm_as), 20.0 * EPS * (1.8 + math.sqrt(2.0) * norm_as)],
                       rtol=1e-12, atol=0)


def test_rate_rounding_bound_by_hand():
    norm_as = spectral_norm_2x2(A2_S)
    # P = diag(4, 9): kappa 1: 10 n eps (|rate| + 2 ||A_s||)
    got = checks.rate_rounding_bound(A2, np.diag([4.0, 9.0]), -3.0)
    assert got == pytest.approx(20.0 * EPS * (3.0 + 2.0 * norm_as), rel=1e-12, abs=0)
    assert checks.rate_rounding_bound(A2, P2, 3.0) == pytest.approx(20.0 * EPS * 2.0 * (3.0 + 2.0 * norm_as),
                                                                    rel=1e-12, abs=0)
    # singular (lambda_min exactly 0), indefinite, or a non-positive diagonal: infinite
    assert checks.rate_rounding_bound(A2, np.array([[1.0, 1.0], [1.0, 1.0]]), 1.0) == math.inf
    assert checks.rate_rounding_bound(A2, np.array([[1.0, 2.0], [2.0, 1.0]]), 1.0) == math.inf
    assert checks.rate_rounding_bound(A2, np.diag([0.0, 1.0]), 1.0) == math.inf


def test_expression_rounding_bound_by_hand():
    assert checks.expression_rounding_bound(3, 2.0, -1.5) == pytest.approx(10.0 * 3 * EPS * 3.5, rel=1e-15, abs=0)
    assert checks.expression_rounding_bound(4) == 0.0


def test_scaled_eig_margin_by_hand():
    # M = [[-4, 2], [2, -9]], D = diag(1/2, 1/3): D M D = [[-1, 1/3], [1/3, -1]], lambda_max = -2/3;
    # with M_abs = |M|: ||D M_abs D|| = 4/3 and ||D M D|| = 4/3, so bound = 10 eps (2 * 4/3 + 2 * 4/3)
    M = np.array([[-4.0, 2.0], [2.0, -9.0]])
    lam, bound = checks.scaled_eig_margin(M, np.abs(M), 2)
    assert lam == pytest.approx(-2.0 / 3.0, rel=1e-14, abs=0)
    assert bound == pytest.approx(10.0 * EPS * (2 * 4.0 / 3.0 + 2 * 4.0 / 3.0), rel=1e-12, abs=0)
    # n_inner scales the product term only: 5 * 4/3 + 2 * 4/3
    assert checks.scaled_eig_margin(M, np.abs(M), 5)[1] == pytest.approx(10.0 * EPS * 7 * 4.0 / 3.0, rel=1e-12, abs=0)
    # the symmetric part is used, and a zero diagonal entry is left unscaled
    lam, _ = checks.scaled_eig_margin(np.array([[0.0, 2.0], [0.0, -1.0]]), np.ones((2, 2)), 1)
    assert lam == pytest.approx((-1.0 + math.sqrt(5.0)) / 2.0, rel=1e-14, abs=0)
    # M_abs is taken in absolute value: a negative M_abs gives the same bound
    assert checks.scaled_eig_margin(M, -np.abs(M), 2)[1] == pytest.approx(bound, rel=1e-15, abs=0)


def test_roa_decrease_margin_of_a_scalar_loop_by_hand():
    a, b, p, g, t = -1.5, 2.0, 3.0, 0.25, 0.7
    # M = [[2ap, -pb + gt], [., -2t]] = [[-9, -5.825], [., -1.4]]; M_abs off-diagonal |p||b| + |g||t| = 6.175
    s = 1.0 / (3.0 * math.sqrt(1.4))  # d1 d2 with d = (1/3, 1/sqrt(1.4))
    lam, bound = checks.roa_decrease_margin(m(a), m(b), m(p), m(g), m(t))
    assert lam == pytest.approx(-1.0 + 5.825 * s, rel=1e-13, abs=0)
    norm_ms = 1.0 + 5.825 * s  # eigenvalues -1 +- 5.825 s
    norm_es = 1.0 + 6.175 * s  # eigenvalues 1 +- 6.175 s
    assert bound == pytest.approx(10.0 * EPS * (2 * norm_es + 2 * norm_ms), rel=1e-12, abs=0)


# A 3 x 3 case with three distinct eigenvalues (the middle one is not the extreme one): P3 has a unit diagonal
# (D = I, so P_s = P3 and A_s = A3) and eigenvalues 1/2, 1, 3/2, condition number 3.
P3 = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]])
A3 = np.diag([1.0, -2.0, 3.0])  # ||A_s|| = 3


def test_three_by_three_bounds_by_hand():
    lam, bound = checks.definite_margin(P3)
    assert lam == pytest.approx(0.5, rel=1e-14, abs=0) and bound == pytest.approx(30.0 * EPS * 1.5, rel=1e-12, abs=0)
    got = checks.contraction_rounding_bound(A3, P3, 0.25)
    assert got == pytest.approx(30.0 * EPS * (3.0 * 0.25 + math.sqrt(3.0) * 3.0), rel=1e-12, abs=0)
    assert type(got) is float
    assert checks.rate_rounding_bound(A3, P3, 1.0) == pytest.approx(30.0 * EPS * 3.0 * (1.0 + 6.0), rel=1e-12, abs=0)
    # M = -P3: its largest eigenvalue is -1/2 (not the middle -1)
    lam, _ = checks.scaled_eig_margin(-P3, P3, 3)
    assert lam == pytest.approx(-0.5, rel=1e-14, abs=0)
    # a stack of stacks (2 x 1 matrices of 3 x 3): n is the matrices' size, not a stack dimension
    lam, bound = checks.definite_margin(P3[None, None].repeat(2, axis=0))
    assert bound.shape == (2, 1) and np.allclose(bound, 30.0 * EPS * 1.5, rtol=1e-12, atol=0)
    out = checks.contraction_rounding_bound(A3[None, None].repeat(2, axis=0), P3[None, None].repeat(2, axis=0),
                                            np.full((2, 1), 0.25))
    assert np.allclose(out, 30.0 * EPS * (0.75 + 3.0 * math.sqrt(3.0)), rtol=1e-12, atol=0)


def test_scaled_eig_margin_is_free_of_the_units():
    # the same M in other units (all entries / 100, diagonal below 1): the same scaled eigenvalue and bound
    M = np.array([[-4.0, 2.0], [2.0, -9.0]])
    assert checks.scaled_eig_margin(M / 100.0, np.abs(M) / 100.0, 2) == pytest.approx(
        checks.scaled_eig_margin(M, np.abs(M), 2), rel=1e-14, abs=0)
    assert checks.scaled_eig_margin(M / 100.0, np.abs(M) / 100.0, 2)[0] == pytest.approx(-2.0 / 3.0, rel=1e-14, abs=0)


def test_float32_matrices_are_checked_in_float64():
    """The hand values of P2, A2 (exact in float32) must come out at float64 precision from float32 input."""
    f32 = np.float32
    lam, bound = checks.definite_margin(P2.astype(f32))
    assert lam == pytest.approx(2.0 / 3.0, rel=1e-14, abs=0)
    norm_as = spectral_norm_2x2(A2_S)
    assert checks.contraction_rounding_bound(A2.astype(f32), P2.astype(f32), 0.9) == pytest.approx(
        20.0 * EPS * (1.8 + math.sqrt(2.0) * norm_as), rel=1e-12, abs=0)
    assert checks.rate_rounding_bound(A2.astype(f32), P2.astype(f32), 3.0) == pytest.approx(
        20.0 * EPS * 2.0 * (3.0 + 2.0 * norm_as), rel=1e-12, abs=0)
    M = np.array([[-4.0, 2.0], [2.0, -9.0]])
    lam, bound = checks.scaled_eig_margin(M.astype(f32), np.abs(M).astype(f32), 2)
    assert lam == pytest.approx(-2.0 / 3.0, rel=1e-14, abs=0)
    assert bound == pytest.approx(10.0 * EPS * 4 * 4.0 / 3.0, rel=1e-12, abs=0)


def test_bounds_of_a_matrix_that_is_not_positive_definite_are_infinite_and_silent():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # lambda_min(P_s) exactly 0 (singular), a zero diagonal: nothing certified, no RuntimeWarning
        assert checks.rate_rounding_bound(A2, np.array([[1.0, 1.0], [1.0, 1.0]]), 1.0) == math.inf
        assert checks.contraction_rounding_bound(A2, np.array([[1.0, 1.0], [1.0, 1.0]]), 0.5) == math.inf
        assert checks.contraction_rounding_bound(A2, np.diag([0.0, 1.0]), 0.5) == math.inf
        assert checks.definite_margin(np.diag([np.inf, 1.0]))[0] == -math.inf
