"""The verified positive-definiteness test (Rump 2006) against exact rational arithmetic.

Every outcome is compared with an independent, exact decision: the LDLᵀ of the same floating-point matrix in
:class:`fractions.Fraction` (``exact_definite``), itself checked against Sylvester's criterion by sympy on small
cases.  The invariant that makes the test a proof: ``proven`` never meets an exactly indefinite matrix and ``fails``
never meets an exactly definite one; near the limit of floating point the answer is ``not proven``.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg as sla
import sympy as sp

from nniquad.analysis.verified import FAILS, NOT_PROVEN, PROVEN, IMat, prove_definite, prove_definite_batch
from nniquad.analysis.verified.exact import exact_definite, fadd, fmul, fraction_matrix, fscale, ftranspose
from nniquad.analysis.verified.inequalities import contraction, decay, definite, roa_decrease
from nniquad.analysis.verified.rounding import UNIT_ROUNDOFF, gamma, upward


def _exact(M: np.ndarray) -> bool:
    return exact_definite(fraction_matrix(M))[0]


def _known_spectrum(n: int, smallest: float, rng: np.random.Generator) -> np.ndarray:
    """``Q diag(λ) Qᵀ`` with a random orthogonal ``Q``, ``λ_min = smallest``, the rest in [0.5, 2]; exactly symmetric."""
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    M = (Q * np.r_[smallest, rng.uniform(0.5, 2.0, n - 1)]) @ Q.T
    return 0.5 * (M + M.T)


@pytest.mark.parametrize("n", [2, 3, 5, 8, 13, 20])
def test_known_spectra_either_side_of_zero_are_proven_and_refuted_like_exact_arithmetic(n):
    rng = np.random.default_rng(n)
    for smallest in (1e-2, 1e-6, 1e-10, -1e-10, -1e-6, -1e-2):
        M = _known_spectrum(n, smallest, rng)
        got, exact = prove_definite(M), _exact(M)
        assert exact == (smallest > 0)  # at 1e-10 of the norm, the rounding of forming M (1e-15) cannot flip it
        # far from the limit of floating point, the verified test decides as exact arithmetic does
        assert got.outcome == (PROVEN if smallest > 0 else FAILS), (n, smallest, got)
        if got.outcome == FAILS:  # the witness's quadratic form is <= 0 in exact arithmetic
            x = [Fraction(float(v)) for v in got.witness]
            Mf = fraction_matrix(M)
            assert sum(x[i] * Mf[i][j] * x[j] for i in range(n) for j in range(n)) <= 0


@pytest.mark.parametrize("n", [3, 6, 12, 20])
def test_near_the_limit_of_floating_point_the_answer_is_never_wrong(n):
    """λ_min at 1e-17 .. 1e-13 of the norm, either sign: below what the arithmetic can prove, so ``not proven`` is
    allowed; ``proven`` only for an exactly definite matrix, ``fails`` only for an exactly indefinite one."""
    rng = np.random.default_rng(100 + n)
    seen = set()
    for smallest in (1e-13, 1e-15, 1e-17, -1e-17, -1e-15, -1e-13):
        for _ in range(4):
            M = _known_spectrum(n, smallest, rng)
            got, exact = prove_definite(M).outcome, _exact(M)
            seen.add(got)
            assert not (got == PROVEN and not exact) and not (got == FAILS and exact), (n, smallest, got, exact)
    assert NOT_PROVEN in seen  # the limit is reached: the third outcome is used


@pytest.mark.parametrize("n", [2, 4, 6, 9])
def test_shifted_hilbert_matrices_just_above_and_below_their_smallest_eigenvalue(n):
    """``H - s I`` with ``s`` a factor below and above ``λ_min(H)`` (exact: sympy's characteristic polynomial)."""
    H = sla.hilbert(n)
    lam = min(float(r) for r in sp.Matrix(n, n, lambda i, j: sp.Rational(1, i + j + 1)).charpoly().all_roots()
              if r.is_real)
    for factor, pd in ((0.9, True), (0.999, True), (1.001, False), (1.1, False)):
        M = H - factor * lam * np.eye(n)
        got, exact = prove_definite(M).outcome, _exact(M)
        assert exact == pd
        assert not (got == PROVEN and not pd) and not (got == FAILS and pd)
        if n <= 6 and factor in (0.9, 1.1):  # a margin of 10 % of λ_min >= 1e-8 relative: decided
            assert got == (PROVEN if pd else FAILS), (n, factor, got)


def test_an_unshifted_cholesky_that_succeeds_is_not_taken_as_a_proof():
    """Higham Thm 10.7: a matrix just indefinite can factor in floating point; the shift refuses to call it proven."""
    rng = np.random.default_rng(7)
    fooled = 0
    for _ in range(200):
        M = _known_spectrum(12, -1e-17, rng)
        try:
            np.linalg.cholesky(M)
            factored = True
        except np.linalg.LinAlgError:
            factored = False
        if factored and not _exact(M):
            fooled += 1
            assert prove_definite(M).outcome != PROVEN
    assert fooled > 0  # the trap is real: plain Cholesky accepts some exactly indefinite matrices


def test_the_proven_margin_is_a_lower_bound_of_the_smallest_eigenvalue():
    rng = np.random.default_rng(3)
    for n in (3, 10):
        M = _known_spectrum(n, 0.1, rng)
        got = prove_definite(M)
        assert got.outcome == PROVEN and 0 < got.margin
        # the margin is in the units of the matrix scaled to a diagonal in [1/4, 1) by powers of two
        d = np.exp2(-np.ceil(0.5 * np.log2(np.diag(M))))
        Ms = M * d[:, None] * d[None, :]
        shifted = Ms - got.margin * np.eye(n)
        assert _exact(0.5 * (shifted + shifted.T)) or np.linalg.eigvalsh(Ms)[0] > got.margin


def test_an_interval_is_proven_only_when_every_member_is_definite():
    """Corollary 2.7: ``I ± R`` with ``‖R‖ < 1`` is proven; with a member that is singular it is not."""
    n = 5
    rng = np.random.default_rng(11)
    R = np.abs(rng.standard_normal((n, n)))
    R = 0.5 * (R + R.T)
    R *= 0.5 / np.max(np.sum(R, axis=1))  # ‖R‖∞ = 0.5
    assert prove_definite(IMat.around(np.eye(n), R)).outcome == PROVEN
    # the member I - 1.0001 * 11ᵀ/n is indefinite; an interval containing it must not be proven
    J = np.ones((n, n)) / n * 1.0001
    got = prove_definite(IMat.around(np.eye(n), J))
    assert got.outcome != PROVEN
    # every member indefinite: the diagonal's upper end is negative
    assert prove_definite(IMat.around(-np.eye(n), 0.5 * np.eye(n))).outcome == FAILS


def test_non_finite_or_asymmetric_input():
    assert prove_definite(np.array([[1.0, np.nan], [np.nan, 1.0]])).outcome == NOT_PROVEN
    with pytest.raises(ValueError, match="symmetric"):
        prove_definite(np.array([[1.0, 0.1], [0.0, 1.0]]))
    with pytest.raises(ValueError, match="symmetric"):
        exact_definite(fraction_matrix(np.array([[1.0, 0.1], [0.0, 1.0]])))


def test_exact_ldl_matches_sylvesters_criterion():
    rng = np.random.default_rng(5)
    for _ in range(40):
        n = int(rng.integers(1, 5))
        M = rng.integers(-3, 4, (n, n)).astype(float)
        M = M + M.T + np.diag(rng.integers(-2, 6, n))
        minors = [sp.Matrix(M[:k, :k].tolist()).det() for k in range(1, n + 1)]
        assert exact_definite(fraction_matrix(M))[0] == all(m > 0 for m in minors)


def test_interval_products_contain_the_exact_product():
    rng = np.random.default_rng(2)
    for k in (2, 7, 19):
        A = rng.standard_normal((4, k)) * 10.0 ** rng.integers(-8, 8, (4, k))
        B = rng.standard_normal((k, 3)) * 10.0 ** rng.integers(-8, 8, (k, 3))
        C = IMat.point(A) @ IMat.point(B)
        exact = fmul(fraction_matrix(A), fraction_matrix(B))
        for i in range(4):
            for j in range(3):
                assert abs(exact[i][j] - Fraction(float(C.mid[i, j]))) <= Fraction(float(C.rad[i, j]))
        D = rng.standard_normal((4, 3)) * 10.0 ** rng.integers(-8, 8, (4, 3))
        S = (IMat.point(A[:, :2] @ np.ones((2, 3))) + IMat.point(D)).scale(1 / 3)
        ex = fscale(Fraction(1 / 3), fadd(fraction_matrix(A[:, :2] @ np.ones((2, 3))), fraction_matrix(D)))
        assert all(abs(ex[i][j] - Fraction(float(S.mid[i, j]))) <= Fraction(float(S.rad[i, j]))
                   for i in range(4) for j in range(3))


def test_upward_bounds_exact_sums():
    rng = np.random.default_rng(9)
    for n in (3, 50, 1000):
        x = rng.uniform(0, 1, n) * 10.0 ** rng.integers(-300, 300, n)
        assert Fraction(float(upward(np.sum(x), n))) >= sum(Fraction(float(v)) for v in x)
    assert gamma(3) == pytest.approx(3 * UNIT_ROUNDOFF)


def test_inequalities_agree_with_the_exact_route_and_with_a_stable_and_an_unstable_loop():
    A = np.array([[0.0, 1.0], [-2.0, -3.0]])
    P = sla.solve_continuous_lyapunov(A.T, -np.eye(2))
    P = 0.5 * (P + P.T)
    rate = 1 / np.max(np.linalg.eigvalsh(P))  # A'P + PA = -I <= -rate P
    ok = decay(A, P, 0.9 * rate, exact=True)
    assert [r.outcome for r in ok] == [PROVEN, PROVEN] and {r.method for r in ok} == {"verified-cholesky", "exact"}
    bad = decay(A, P, 1.5 * np.max(-np.linalg.eigvals(A).real) * 2, exact=True)
    assert [r.outcome for r in bad] == [FAILS, FAILS]
    assert [r.outcome for r in definite(np.diag([1.0, -1e-300]), exact=True)] == [FAILS, FAILS]
    Ad = np.array([[0.5, 0.1], [0.0, 0.8]])
    Pd = sla.solve_discrete_lyapunov(Ad.T, np.eye(2))
    Pd = 0.5 * (Pd + Pd.T)
    assert contraction(Ad[None], Pd[None], 0.95)[0].outcome == PROVEN
    assert contraction(Ad[None], Pd[None], 0.5)[0].outcome == FAILS  # a spectral radius of 0.8 cannot contract by 0.5
    # the saturated-loop decrease of a stable scalar loop with a zero multiplier block
    rows = roa_decrease(np.array([[-1.0]]), np.array([[0.0]]), np.array([[1.0]]), np.array([[0.0]]),
                        np.array([[1.0]]), exact=True)
    assert [r.outcome for r in rows] == [PROVEN, PROVEN]


def test_batch_and_single_agree():
    rng = np.random.default_rng(4)
    Ms = np.stack([_known_spectrum(6, s, rng) for s in (1e-3, -1e-3, 1e-2, 1e-16)])
    batch = [p.outcome for p in prove_definite_batch(Ms, margin=True)]
    assert batch == [prove_definite(M).outcome for M in Ms]
    assert ftranspose(fraction_matrix(Ms[0])) == fraction_matrix(Ms[0].T)
