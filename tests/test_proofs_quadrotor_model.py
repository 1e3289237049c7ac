"""Section 'Quadrotor system': each claim against a deliberately wrong variant, and independent numbers."""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from nniquad.model import symbolic as S
from nniquad.proofs import quadrotor_model as Q
from nniquad.proofs.claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION

s = S.symbols()


def test_rotation_matrix_holds_and_wrong_variants_fail():
    assert Q.rotation_matrix().verdict == HOLDS
    R = Q.paper_rotation_matrix()
    wrong = R.copy()
    wrong[0, 1] = -wrong[0, 1]
    assert Q.rotation_matrix(R=wrong).verdict == FAILS
    assert Q.rotation_matrix(R=R.T).verdict == FAILS  # orthonormal, but the XYZ (transposed) convention


def test_rotation_matrix_by_hand_numbers():
    # independent: compose the elementary rotations numerically
    ph, th, ps = 0.3, -0.4, 0.5
    c, sn = np.cos, np.sin
    Rz = np.array([[c(ps), -sn(ps), 0], [sn(ps), c(ps), 0], [0, 0, 1]])
    Ry = np.array([[c(th), 0, sn(th)], [0, 1, 0], [-sn(th), 0, c(th)]])
    Rx = np.array([[1, 0, 0], [0, c(ph), -sn(ph)], [0, sn(ph), c(ph)]])
    R = np.array(Q.paper_rotation_matrix().subs(dict(zip(s.eta, (ph, th, ps)))), dtype=float)
    np.testing.assert_allclose(R, Rz @ Ry @ Rx, atol=1e-14)


def test_angular_velocity_map_holds_and_transpose_fails():
    assert Q.angular_velocity_map().verdict == HOLDS
    assert Q.angular_velocity_map(W=Q.paper_angular_velocity_matrix().T).verdict == FAILS


def test_lagrangian_decoupling_correction_and_coupled_variant():
    r = Q.lagrangian_decoupling()
    assert r.verdict == HOLDS_WITH_CORRECTION
    assert r.correction["checked"] is True
    coupled = Q.paper_lagrangian() + s.xi_dot[0] * s.eta_dot[0]
    assert Q.lagrangian_decoupling(lagrangian=coupled).verdict == FAILS


def test_paper_lagrangian_gives_J_eta_ddot_equals_tau():
    # independent hand computation: d/dt(J eta') = J eta'', no eta dependence
    L = Q.paper_lagrangian()
    EL = S.euler_lagrange(L, s.eta, s.eta_dot, s.eta_ddot)
    assert EL == sp.Matrix([s.Jx * s.eta_ddot[0], s.Jy * s.eta_ddot[1], s.Jz * s.eta_ddot[2]])


def test_thrust_vector_corrected_holds_and_counterexample_numbers():
    r = Q.thrust_vector()
    assert r.verdict == HOLDS_WITH_CORRECTION
    # hand numbers: at phi = 0, theta = 0.3, psi = 0 the body z axis leans to +x (R e3 = (sin 0.3, 0, cos 0.3))
    cex = r.counterexample["phi=0, theta=0.3, psi=0 (per unit u1)"]
    assert np.allclose(np.ravel(cex["u1 R e3"]), [np.sin(0.3), 0, np.cos(0.3)])
    assert np.allclose(np.ravel(cex["paper"]), [-np.sin(0.3), 0, np.cos(0.3)])
    good = s.u1 * Q.paper_rotation_matrix() * sp.Matrix([0, 0, 1])
    assert Q.thrust_vector(thrust=good).verdict == HOLDS


def test_translational_dynamics_wrong_gravity_fails():
    assert Q.translational_dynamics().verdict == HOLDS_WITH_CORRECTION
    rows = Q.paper_translational_rows()
    wrong = rows.copy()
    wrong[2] = -s.g - s.u1 / s.m * sp.cos(s.eta[0]) * sp.cos(s.eta[1])
    assert Q.translational_dynamics(rows=wrong).verdict == FAILS


def test_rotational_rows_wrong_gyro_sign_fails():
    r = Q.rotational_rows()
    assert r.verdict == HOLDS_WITH_CORRECTION
    rows = Q.paper_rotational_rows()
    wrong = rows.copy()
    wrong[0] = rows[0] + 2 * s.eta_dot[1] * s.Jr / s.Jx * s.Omega_r  # -a2 -> +a2
    assert Q.rotational_rows(rows=wrong).verdict == FAILS


def test_rotational_gap_is_first_order_in_attitude():
    """Independent of the claim's own ratio: the two evaluations it reports shrink by 10 for a 10x smaller attitude."""
    num = Q.rotational_rows().evidence["numeric gap (first order in the attitude)"]
    g1, g2 = (v["max|gap| / max|exact|"] for v in num.values())
    assert 8.0 < g1 / g2 < 12.0


def test_the_exact_zero_test_decides_identities_on_the_circles_and_only_those():
    """``_vanishes_on_the_circles`` (sᵃ² + cᵃ² = 1 reduction): true identities, rational ones included, are
    zero; a residual that is not an identity is not (checked at random angles too); what it cannot read (a tan)
    is left undecided for trigsimp.  A residual that is not zero keeps its value in the normal form ``_simp``
    prints, and two ways of writing one function print alike."""
    a, b, c, m = sp.symbols("a b c m", positive=True)
    sa, ca, sb, cb = sp.sin(a), sp.cos(a), sp.sin(b), sp.cos(b)
    identities = [
        sa**2 + ca**2 - 1,
        (sa**2 + ca**2) ** 3 - 1,
        (sa**4 - ca**4 - sa**2 + ca**2) * sp.cos(c) / m,
        (sa**2 * cb**2 + sa**2 * sb**2 + ca**2 - 1) / (ca + 2),
        (sa * cb + ca * sb) ** 2 + (ca * cb - sa * sb) ** 2 - 1,  # sin² + cos² of a + b, opened
    ]
    others = [sa**2 - ca**2, sa**2 + ca**2 - 1 + 1e-12 * sb, sa**2 * cb**2 - sa**2, (sa - ca) / m]
    rng = np.random.default_rng(7)
    for e in identities:
        assert Q._vanishes_on_the_circles(sp.expand(e)), e
        assert Q._simp(e) == 0 and sp.trigsimp(sp.expand(e)) == 0
    for e in others:
        assert not Q._vanishes_on_the_circles(sp.expand(e)), e
        f = sp.lambdify((a, b, c, m), e)
        points = rng.uniform(0.1, 3.0, (5, 4))
        assert max(abs(f(*p)) for p in points) > 0  # truly not zero
        printed = Q._simp(e)
        assert printed != 0
        g = sp.lambdify((a, b, c, m), printed)
        assert all(math.isclose(g(*p), f(*p), rel_tol=1e-12, abs_tol=1e-14) for p in points)
    # the same function written two ways (sin² against 1 - cos²) has one normal form
    assert Q._simp(sa**2 * cb - ca) == Q._simp((1 - ca**2) * cb - ca) != 0
    assert not Q._vanishes_on_the_circles(sp.tan(a) * ca - sa)  # undecided: trigsimp's turn
    assert Q._simp(sp.tan(a) * ca - sa) == 0
