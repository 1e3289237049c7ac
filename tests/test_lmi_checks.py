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
