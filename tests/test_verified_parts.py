"""The parts of the verified test, each against an independent computation: exact rationals for every enclosure,
the documented formulas (in exact arithmetic) for the rounding constants and the shift, LAPACK for the
decompositions.  The mutation runs of ``nniquad.analysis.verified`` read these tests."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from nniquad.analysis.verified import inequalities as V
from nniquad.analysis.verified.exact import exact_definite, fadd, fmul, fraction_matrix, fscale, ftranspose
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.rounding import ETA, UNIT_ROUNDOFF, downward, gamma, upward
from nniquad.analysis.verified.spd import (
    FAILS,
    MARGIN_LADDER,
    METHOD,
    NOT_PROVEN,
    PROVEN,
    Proof,
    cholesky_completes,
    prove_definite,
    prove_definite_batch,
)

F = Fraction
RNG = np.random.default_rng(2026)


def _exact(x) -> list:
    a = np.asarray(x, float)
    return [[F(float(v)) for v in row] for row in a.reshape(-1, a.shape[-1])]


def _contains(X: IMat, exact_rows: list, tight: float | None = None) -> None:
    """Every exact entry lies in ``mid ± rad``; with ``tight``, every radius is at most ``tight`` times the gap it
    must cover plus a few ulps of the midpoint (a radius mutated far upwards is caught too)."""
    mid, rad = X.mid.reshape(-1, X.mid.shape[-1]), X.rad.reshape(-1, X.mid.shape[-1])
    for i, row in enumerate(exact_rows):
        for j, e in enumerate(row):
            gap = abs(e - F(float(mid[i, j])))
            assert gap <= F(float(rad[i, j])), (i, j)
            if tight is not None:
                assert rad[i, j] <= tight * float(gap) + 64 * UNIT_ROUNDOFF * abs(mid[i, j]) + 1e-300, (i, j)


def _rand(*shape, spread=4):
    return RNG.standard_normal(shape) * 10.0 ** RNG.integers(-spread, spread + 1, shape)


# ----------------------------------------------------------------------------- rounding


def test_gamma_and_the_upward_and_downward_bounds_follow_their_formulas():
    assert gamma(0) == 0.0 and gamma(1) == UNIT_ROUNDOFF / (1 - UNIT_ROUNDOFF)
    assert gamma(7) == 7 * UNIT_ROUNDOFF / (1 - 7 * UNIT_ROUNDOFF)
    for bad in (-1, 2**52):
        with pytest.raises(ValueError, match="gamma"):
            gamma(bad)
    for x, k in ((1.0, 3), (3.7e-5, 40), (2.0**100, 1)):
        got = upward(x, k)
        want = F(x) * (1 + 2 * F(gamma(k + 2)))  # the documented inflation, exactly
        assert F(got) >= want and got <= x * (1 + 2 * gamma(k + 2) + 5 * UNIT_ROUNDOFF) + (k + 1) * ETA
        assert type(got) is float
    assert upward(0.0, 4) == 5 * ETA  # underflow allowance: (terms + 1) η
    arr = upward(np.array([1.0, 2.0]), 2)
    assert isinstance(arr, np.ndarray) and arr.shape == (2,)
    assert downward(1.0) == np.nextafter(1.0, -np.inf) and type(downward(1.0)) is float
    assert np.all(downward(np.array([1.0, -2.0])) < np.array([1.0, -2.0]))
    assert ETA == 2.0**-1074 and UNIT_ROUNDOFF == 2.0**-53


# ----------------------------------------------------------------------------- interval arithmetic


@pytest.mark.parametrize("seed", range(3))
def test_every_interval_operation_encloses_the_exact_result_tightly(seed):
    rng = np.random.default_rng(seed)
    k, n = 3, 4
    A, B = _rand(k, n, n), _rand(k, n, n)
    RA = np.abs(A) * RNG.uniform(0.5, 1.0, (k, n, n)) * 1e-9  # far above an ulp of A: A ± RA/2 rounds inside
    s = _rand(k)
    IA, IB = IMat.point(A), IMat.point(B)
    exact = lambda f: [row for i in range(k) for row in f(i)]  # noqa: E731
    _contains(IA + IB, exact(lambda i: fadd(_exact(A[i]), _exact(B[i]))), tight=4)
    _contains(IA - IB, exact(lambda i: fadd(_exact(A[i]), fscale(-1, _exact(B[i])))), tight=4)
    _contains(-IA, exact(lambda i: _exact(-A[i])))
    _contains(IA.scale(1 / 3), exact(lambda i: fscale(F(1 / 3), _exact(A[i]))), tight=4)
    _contains(IA.times(s), exact(lambda i: fscale(F(float(s[i])), _exact(A[i]))), tight=4)
    _contains(IA.divided(s), exact(lambda i: fscale(1 / F(float(s[i])), _exact(A[i]))), tight=4)
    _contains(IA @ IB, exact(lambda i: fmul(_exact(A[i]), _exact(B[i]))))
    _contains(IA.T, exact(lambda i: ftranspose(_exact(A[i]))))
    _contains(IA.symmetric(), exact(lambda i: fscale(F(1, 2), fadd(_exact(A[i]), ftranspose(_exact(A[i]))))), tight=4)
    _contains(IA.shift(0.3), exact(lambda i: fadd(_exact(A[i]), fscale(-F(0.3), _exact(np.eye(n))))), tight=4)
    d, e = 2.0 ** rng.integers(-5, 5, (k, n)), 2.0 ** rng.integers(-5, 5, (k, n))
    scaled = IA.diagonal_scaled(d, e)
    assert np.array_equal(scaled.mid, A * d[:, :, None] * e[:, None, :])  # powers of two: exact
    assert np.all(scaled.rad <= 2 * ETA)
    # a radius propagates: (A ± RA) B lies in IA' @ IB for the extreme members
    W = IMat.around(A, RA)
    assert np.array_equal(W.rad, RA) and np.array_equal(IMat.around(A[0], 1e-3).rad, np.full((n, n), 1e-3))
    prod = W @ IB
    for sign in (-0.5, 0.5):
        member = A + sign * RA
        _contains(prod, exact(lambda i: fmul(_exact(member[i]), _exact(B[i]))))
        _contains(IB @ W, exact(lambda i: fmul(_exact(B[i]), _exact(member[i]))))
        _contains(W.times(s), exact(lambda i: fscale(F(float(s[i])), _exact(member[i]))))
        _contains(W.divided(s), exact(lambda i: fscale(1 / F(float(s[i])), _exact(member[i]))))
        _contains(W.scale(-2.5), exact(lambda i: fscale(F(-2.5), _exact(member[i]))))
        _contains(W.symmetric(), exact(lambda i: fscale(F(1, 2), fadd(_exact(member[i]), ftranspose(_exact(member[i]))))))
        _contains(W.shift(-1.5), exact(lambda i: fadd(_exact(member[i]), fscale(F(1.5), _exact(np.eye(n))))))
        _contains(W + IB, exact(lambda i: fadd(_exact(member[i]), _exact(B[i]))))
    # no wider than what it must cover: the propagated radius is |B| RA to first order
    assert np.all(prod.rad <= 1.01 * (np.abs(np.swapaxes(RA, 1, 2) * 0 + RA) @ np.abs(B)) + 1e-6 * np.abs(prod.mid))


def test_contains_point_and_the_mixed_operands():
    A = np.array([[1.0, 2.0], [3.0, 4.0]])
    X = IMat.around(A, 0.5)
    assert X.contains(A + 0.5) and X.contains(A - 0.5) and not X.contains(A + 0.51)
    P = IMat.point(A)
    assert P.contains(A) and not P.contains(np.nextafter(A, 9))
    assert np.array_equal((P + A).mid, 2 * A) and np.array_equal((P @ np.eye(2)).mid, A)
    assert np.array_equal((P - A).mid, np.zeros((2, 2)))
    S = IMat.point(np.array([[1.0, 2.0], [3.0, 5.0]])).symmetric()
    assert np.array_equal(S.mid, S.mid.T) and np.array_equal(S.rad, S.rad.T) and S.mid[0, 1] == 2.5


# ----------------------------------------------------------------------------- the test itself


def test_the_shift_is_corollary_2_4s_and_the_radius_is_added():
    n = 6
    M = np.eye(n) * 0.5 + 0.01
    got = prove_definite(M)
    d = np.diag(M) * np.exp2(-2 * np.ceil(0.5 * np.log2(np.diag(M))))  # the scaled diagonal
    c = sum(F(gamma(i + 2)) / (1 - F(gamma(i + 2))) * F(float(d[i])) for i in range(n))
    c += 6 * n * (n + F(float(max(d)))) * F(ETA)
    assert got.outcome == PROVEN and F(got.shift) >= c and got.shift <= float(c) * (1 + 1e-9)
    R = np.full((n, n), 1e-6)
    withr = prove_definite(M, radius=R)
    # ‖R_s‖∞ of the off-diagonal radius (the diagonal's radius moves into the lower bound of the diagonal)
    assert withr.shift >= got.shift + (n - 1) * 1e-6 * float(np.exp2(-2 * np.ceil(0.5 * np.log2(0.51)))) * 0.999
    assert withr.outcome == PROVEN and withr.margin < got.margin + 1e-12


def test_the_proof_record():
    p = Proof(PROVEN, shift=1e-15, margin=0.25)
    assert p.proven and p.to_json() == {"outcome": PROVEN, "method": METHOD, "shift": 1e-15, "margin": 0.25}
    assert not Proof(FAILS).proven and not Proof(NOT_PROVEN).proven
    assert METHOD == "verified-cholesky"


def test_the_vectorised_decomposition_agrees_with_lapack():
    ok, bad = np.eye(5) * 2 + 0.1, np.eye(5)
    bad = bad.copy()
    bad[3, 3] = -1e-3
    late = np.eye(5)
    late[4, 4] = 0.0
    nan = np.eye(5)
    nan[2, 2] = np.nan
    huge = np.eye(5)
    huge[1, 0] = huge[0, 1] = 1e300
    stack = np.stack([ok, bad, ok, late, nan, huge])
    assert cholesky_completes(stack).tolist() == [True, False, True, False, False, False]
    assert cholesky_completes(np.stack([ok, ok])).tolist() == [True, True]
    rng = np.random.default_rng(8)
    for _ in range(20):
        M = rng.standard_normal((5, 5))
        M = M @ M.T - rng.uniform(0, 1) * np.eye(5)
        try:
            np.linalg.cholesky(M)
            ref = True
        except np.linalg.LinAlgError:
            ref = False
        assert cholesky_completes(np.stack([M, ok]))[0] == ref


def test_a_mixed_stack_gets_each_outcome_and_its_witness():
    rng = np.random.default_rng(12)
    Q, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    near = (Q * np.r_[1e-17, 1, 1, 1, 1]) @ Q.T
    near = 0.5 * (near + near.T)
    neg = np.diag([1.0, -2.0, 1.0, 1.0, 1.0])
    offdiag = np.array([[1.0, 2.0], [2.0, 1.0]])
    stack = np.stack([np.eye(5), neg, near, np.eye(5) * np.nan, np.diag([1.0, 1.0, 1.0, 1.0, 1e-300])])
    got = prove_definite_batch(stack, margin=True)
    assert [g.outcome for g in got[:4]] == [PROVEN, FAILS, NOT_PROVEN, NOT_PROVEN]
    assert got[0].margin == MARGIN_LADDER[0] * 0 + got[0].margin and 0 < got[0].margin <= 1
    assert got[1].witness is not None and got[1].witness[1] != 0 and got[1].form_upper <= 0
    assert math.isinf(got[3].shift)
    quiet = prove_definite_batch(stack, refute=False)
    assert [g.outcome for g in quiet[:3]] == [PROVEN, NOT_PROVEN, NOT_PROVEN] and quiet[1].witness is None
    assert math.isfinite(quiet[2].shift) and math.isinf(quiet[1].shift)  # a negative diagonal: no shift to try
    assert isinstance(got[1].form_upper, float) and isinstance(got[2].shift, float)
    assert math.isnan(quiet[0].margin)  # not searched
    two = prove_definite(offdiag)
    assert two.outcome == FAILS and np.isclose(abs(two.witness[0]), abs(two.witness[1]))
    x = two.witness
    assert x @ offdiag @ x < 0
    with pytest.raises(ValueError, match="^a square matrix is needed"):
        prove_definite(np.ones((2, 3)))
    with pytest.raises(ValueError, match="^a square matrix is needed"):
        prove_definite(np.ones((1, 2, 2)))
    with pytest.raises(ValueError, match="^a stack of square matrices"):
        prove_definite_batch(np.ones((1, 2, 3)))
    with pytest.raises(ValueError, match="stack"):
        prove_definite_batch(np.ones((2, 3)))
    with pytest.raises(ValueError, match="stack"):
        prove_definite_batch(IMat(np.ones((1, 2, 2)), np.zeros((1, 3, 3))))
    with pytest.raises(ValueError, match=r"^the midpoints must be exactly symmetric \(use IMat.symmetric\)$"):
        prove_definite_batch(np.array([[[1.0, 0.5], [0.0, 1.0]]]))
    # the caller may vouch for symmetry (the box proof): then no check runs
    assert prove_definite_batch(np.array([[[1.0, 0.0], [0.0, 1.0]]]), symmetric_checked=True)[0].proven


def test_the_margin_is_the_largest_rung_that_factors():
    for lam in (0.3, 2e-3, 5e-7):
        M = np.diag([lam, 0.75, 0.5])
        got = prove_definite(M)
        # the scaled diagonal of M: lam x 4^k in [1/4, 1), so the scaled λ_min is that
        scaled = lam * float(np.exp2(-2 * np.ceil(0.5 * np.log2(lam))))
        best = max(r for r in MARGIN_LADDER if r < scaled - got.shift)
        assert got.margin == best
    stack = np.stack([np.eye(3), np.diag([0.3, 1.0, 1.0]) * 0 + np.eye(3) * 0.26])
    got = prove_definite_batch(stack, margin=True)
    assert got[0].margin == got[1].margin  # a stack's margin is the stack's


def test_the_diagonal_refutation_and_the_interval_diagonal():
    # a diagonal entry below zero over the whole interval: refuted with the unit vector
    got = prove_definite(IMat.around(np.diag([1.0, -1.0]), np.diag([0.1, 0.5])))
    assert got.outcome == FAILS and got.witness.tolist() == [0.0, 1.0] and got.form_upper <= -0.5 + 1e-15
    # a diagonal that may touch zero: not proven (and not refuted: some members are definite)
    got = prove_definite(IMat.around(np.diag([1.0, 0.1]), np.diag([0.0, 0.2])))
    assert got.outcome == NOT_PROVEN


# ----------------------------------------------------------------------------- exact route


def test_the_exact_route_parts():
    M = np.array([[0.1, 0.2], [0.3, 0.4]])
    assert fraction_matrix(M)[0][0] == F(0.1) != F(1, 10)
    assert fraction_matrix([1.0, 2.0]) == [[F(1), F(2)]]
    with pytest.raises(ValueError, match="^a non-finite entry has no rational value$"):
        fraction_matrix(np.array([[np.inf]]))
    with pytest.raises(ValueError, match="multiply"):
        fmul(fraction_matrix(np.ones((2, 3))), fraction_matrix(np.ones((2, 3))))
    assert fmul(fraction_matrix(M), fraction_matrix(np.eye(2))) == fraction_matrix(M)
    assert fscale(2, fraction_matrix(M)) == fadd(fraction_matrix(M), fraction_matrix(M))
    assert ftranspose(fraction_matrix(M)) == fraction_matrix(M.T)
    assert exact_definite(fraction_matrix(np.diag([1.0, 2.0, -3.0]))) == (False, 2)
    assert exact_definite(fraction_matrix(np.diag([1.0, 0.0, 3.0]))) == (False, 1)
    assert exact_definite(fraction_matrix(np.array([[2.0, 1.0], [1.0, 2.0]]))) == (True, None)
    assert exact_definite(fraction_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))) == (False, 1)
    with pytest.raises(ValueError, match="^exact_definite needs an exactly symmetric square matrix$"):
        exact_definite([[F(1), F(0)]])
    # a 3x3 whose last pivot is decided by the fill-in of the first two steps
    A = np.array([[4.0, 2.0, 2.0], [2.0, 5.0, 1.0], [2.0, 1.0, 1.0 + 1e-12]])
    assert exact_definite(fraction_matrix(A))[0] == (np.linalg.det(A) > 0)


# ----------------------------------------------------------------------------- the inequalities


def test_proof_rows_summaries_and_outcomes():
    good = V.ProofRow("a", PROVEN, METHOD, 1e-16, 0.5, "p1")
    low = V.ProofRow("a", PROVEN, METHOD, 1e-16, 0.01, "p2")
    unsure = V.ProofRow("a", NOT_PROVEN, METHOD, 1e-16, math.nan, "p3")
    bad = V.ProofRow("a", FAILS, "exact", where="p4")
    assert V.outcome_of([]) == PROVEN and V.outcome_of([good, unsure]) == NOT_PROVEN
    assert V.outcome_of([unsure, bad]) == FAILS and V.outcome_of([good, low]) == PROVEN
    assert good.to_json() == {"inequality": "a", "outcome": PROVEN, "method": METHOD, "shift": 1e-16,
                              "margin": 0.5, "where": "p1"}
    assert V.ProofRow("b", FAILS, "exact").to_json() == {"inequality": "b", "outcome": FAILS, "method": "exact",
                                                         "shift": None, "margin": None}
    s = V.summary([good, low], "T", "points")
    assert (s.inequality, s.margin, s.where, s.outcome) == ("T", 0.01, "all 2 points", PROVEN)
    s = V.summary([good, unsure, bad], "T", "points")
    assert (s.outcome, s.where) == (FAILS, "p4 (2 of 3 points)")
    s = V.summary([good, unsure], "T", "cells")
    assert (s.outcome, s.where) == (NOT_PROVEN, "p3 (1 of 2 cells)")
    assert V.summary([], "T", "points").outcome == NOT_PROVEN


def test_affine_enclosures_contain_the_exact_p_of_theta():
    Pk = _rand(3, 3, 3, spread=2)
    Pk = 0.5 * (Pk + np.swapaxes(Pk, 1, 2))
    th = RNG.uniform(-1, 1, (4, 2))
    got = V.affine_enclosure(Pk, th)
    for i in range(4):
        e = fadd(fadd(_exact(Pk[0]), fscale(F(float(th[i, 0])), _exact(Pk[1]))), fscale(F(float(th[i, 1])), _exact(Pk[2])))
        _contains(IMat(got.mid[i], got.rad[i]), e, tight=8)
    corners = V.affine_corners(Pk)
    assert corners.mid.shape == (4, 3, 3)
    signs = [(-1, -1), (-1, 1), (1, -1), (1, 1)]
    for i, (a, b) in enumerate(signs):
        _contains(IMat(corners.mid[i], corners.rad[i]), _exact(Pk[0] + a * Pk[1] + b * Pk[2]))
    one = V.affine_corners(Pk[:1])
    assert one.mid.shape == (1, 3, 3) and np.array_equal(one.mid[0], Pk[0])


def test_the_ni_dissipation_and_below():
    A, B, C = _rand(3, 3, spread=1), _rand(3, 1, spread=1), _rand(1, 3, spread=1)
    P = np.eye(3)
    M = V.ni_dissipation(P, A, B, C)
    ex_tl = fadd(fmul(_exact(P), _exact(A)), fmul(ftranspose(_exact(A)), _exact(P)))
    ex_tr = fadd(fmul(_exact(P), _exact(B)), fscale(-1, fmul(ftranspose(_exact(A)), ftranspose(_exact(C)))))
    ex_br = fscale(-1, fadd(fmul(_exact(C), _exact(B)), fmul(ftranspose(_exact(B)), ftranspose(_exact(C)))))
    exact = [r1 + r2 for r1, r2 in zip(ex_tl, ex_tr)] + [r1 + r2 for r1, r2 in zip(ftranspose(ex_tr), ex_br)]
    _contains(M, exact)
    top = float(np.max(np.linalg.eigvalsh(0.5 * (M.mid + M.mid.T))))
    assert V.below(M, top + 1.0, "x")[0].outcome == PROVEN
    assert V.below(M, top - 1.0, "x")[0].outcome == FAILS
    rows = V.definite_interval(IMat.point(np.stack([np.eye(2), -np.eye(2)])), "P > 0", ["a", "b"])
    assert [(r.outcome, r.where) for r in rows] == [(PROVEN, "a"), (FAILS, "b")]
    rows = V.decay_interval(np.stack([-np.eye(2), np.eye(2)]), np.stack([np.eye(2)] * 2), 0.5, "d", ["s", "u"])
    assert [(r.outcome, r.where) for r in rows] == [(PROVEN, "s"), (FAILS, "u")]
    assert V.definite(np.eye(9), exact=True)[-1].method == METHOD  # above EXACT_MAX_DIM: no exact row
    assert len(V.definite(np.eye(3), exact=True)) == 2 and V.EXACT_MAX_DIM == 8


def test_the_contraction_metric_and_its_fallback():
    A = np.array([[[0.5, 1e3], [0.0, 0.5]]])
    P = np.array([[[1.0, 0.0], [0.0, 1e8]]])
    # ‖P^½AP^-½‖ = ‖[[0.5, 0.1], [0, 0.5]]‖ ≈ 0.55: proven at 0.6, refuted at 0.5
    assert V.contraction(A, P, 0.6)[0].outcome == PROVEN
    assert V.contraction(A, P, 0.5)[0].outcome == FAILS
    # a P whose midpoint does not factor: the diagonal scaling stands in, and nothing is proven
    assert V.contraction(A, -P, 0.6)[0].outcome != PROVEN
    assert np.array_equal(V.diagonal_scaling(np.diag([4.0, 0.25, -1.0, 0.0])), [0.5, 2.0, 1.0, 1.0])


# ----------------------------------------------------------------------------- stacks and edge cases


def test_stack_operations_keep_each_matrix_its_own_radius():
    """A stack of non-square matrices with asymmetric radii: the transpose, the symmetric part, the product with
    both radii and the diagonal scaling each keep every matrix's own radius where it belongs."""
    A = np.arange(24, dtype=float).reshape(2, 3, 4) + 1.0
    R = np.arange(24, dtype=float).reshape(2, 3, 4) * 1e-3
    X = IMat(A, R)
    assert np.array_equal(X.T.rad, np.swapaxes(R, 1, 2)) and X.T.mid.shape == (2, 4, 3)
    S = IMat(A[:, :, :3], R[:, :, :3]).symmetric()
    assert np.all(S.rad >= 0.5 * (R[:, :, :3] + np.swapaxes(R[:, :, :3], 1, 2)))
    assert np.all(S.rad <= 0.5 * (R[:, :, :3] + np.swapaxes(R[:, :, :3], 1, 2)) + 1e-12)
    assert np.array_equal(S.rad, np.swapaxes(S.rad, 1, 2))
    Y = IMat(np.swapaxes(A, 1, 2).copy(), np.swapaxes(R, 1, 2) * 2)
    P = X @ Y
    want = np.abs(A) @ (2 * np.swapaxes(R, 1, 2)) + R @ (np.abs(np.swapaxes(A, 1, 2)) + 2 * np.swapaxes(R, 1, 2))
    assert np.all(P.rad >= want) and np.all(P.rad <= want * (1 + 1e-12) + 1e-9 * np.abs(P.mid))
    d, e = np.array([[2.0, 0.5, 4.0], [1.0, 1.0, 0.25]]), np.array([[0.5, 2.0, 1.0, 8.0], [1.0, 0.5, 0.5, 2.0]])
    D = X.diagonal_scaled(d, e)
    assert np.allclose(D.rad, R * d[:, :, None] * e[:, None, :] + ETA, rtol=0, atol=0)
    assert np.all(D.rad >= R * d[:, :, None] * e[:, None, :])
    sq = IMat(A[:, :, :3], R[:, :, :3])
    sh = sq.shift(2.0)
    assert np.array_equal(sh.mid, A[:, :, :3] - 2.0 * np.eye(3)) and np.all(sh.rad >= R[:, :, :3])
    assert np.all(sh.rad[:, [0, 1, 2], [0, 1, 2]] > R[:, [0, 1, 2], [0, 1, 2]])  # the diagonal's rounding added
    for s in (np.array([2.0, -3.0]), [2.0, -3.0]):
        T = X.times(s)
        assert np.array_equal(T.mid, A * np.array([2.0, -3.0])[:, None, None])
        assert np.all(T.rad >= R * np.array([2.0, 3.0])[:, None, None])
        Q = X.divided(s)
        assert np.allclose(Q.mid, A / np.array([2.0, -3.0])[:, None, None], rtol=1e-15)
        assert np.all(Q.rad >= R / np.array([2.0, 3.0])[:, None, None])


def test_the_radius_of_a_stack_is_judged_per_matrix():
    """Two matrices, one with a radius that defeats it and one without: the second is still proven (the radius'
    norm is each matrix's own, never the stack's largest)."""
    M = np.stack([np.eye(3), np.eye(3)])
    R = np.stack([np.full((3, 3), 0.6), np.zeros((3, 3))])
    got = prove_definite_batch(IMat(M, R))
    assert [g.outcome for g in got] == [NOT_PROVEN, PROVEN] and got[0].shift > got[1].shift
    # a radius on the diagonal alone lowers the diagonal (it is not added to the off-diagonal norm)
    diag_only = prove_definite(IMat(np.eye(3), np.eye(3) * 0.5))
    assert diag_only.outcome == PROVEN


def test_a_zero_diagonal_and_a_zero_form_are_refuted():
    """``x'Mx = 0`` refutes strict definiteness: a zero diagonal entry, and a singular matrix's null vector."""
    z = prove_definite(np.diag([1.0, 0.0, 2.0]))
    assert z.outcome == FAILS and z.witness.tolist() == [0.0, 1.0, 0.0] and z.form_upper == 0.0
    assert math.isfinite(z.shift) or math.isinf(z.shift)
    singular = np.array([[1.0, 1.0], [1.0, 1.0]])
    # its null vector is not a float vector: the form's upper bound stays above 0, so not proven (never proven)
    assert prove_definite(singular).outcome == NOT_PROVEN
    # with a radius the same vector is not a counterexample: the set may hold definite members
    assert prove_definite(IMat.around(singular, np.full((2, 2), 1e-3))).outcome == NOT_PROVEN
    # a not-proven answer still states the shift it tried
    near = prove_definite(np.diag([1.0, 1e-18]) + 0.0)
    assert near.outcome in (NOT_PROVEN, PROVEN) and math.isfinite(near.shift)


def test_the_margin_ladder_edges():
    assert MARGIN_LADDER[0] == 1.0 and MARGIN_LADDER[-1] == 1e-15 and len(MARGIN_LADDER) == 31
    # far from singular: the highest rung below the scaled λ_min 0.9 (the scaled diagonal is below 1)
    assert prove_definite(np.eye(4) * 0.9).margin == 10**-0.5
    # a smallest eigenvalue between rungs: the rung just below it, for every rung
    for k in range(1, 26):
        lam = MARGIN_LADDER[k] * 1.5 + 1e-14
        got = prove_definite(np.diag([0.5, lam * 2.0 ** (2 * math.ceil(-0.5 * math.log2(lam))) * 0 + lam, 0.75]))
        scaled = lam * float(np.exp2(-2 * np.ceil(0.5 * np.log2(lam))))
        assert got.margin == max(r for r in MARGIN_LADDER if r < scaled - got.shift), k
    # only the rounding shift passes (λ_min below the lowest rung): margin 0
    q, _ = np.linalg.qr(np.random.default_rng(3).standard_normal((6, 6)))
    for _ in range(20):
        M = (q * np.r_[3e-16, np.ones(5) * 0.5]) @ q.T
        got = prove_definite(0.5 * (M + M.T))
        if got.outcome == PROVEN:
            assert got.margin == 0.0
            break


def test_a_long_dot_product_is_enclosed_by_its_inner_dimension():
    """γ_k of the *inner* dimension: 1 x 3000 times 3000 x 1 with cancelling terms; the exact value lies inside."""
    rng = np.random.default_rng(30)
    a = rng.standard_normal((1, 3000)) * 10.0 ** rng.integers(-3, 4, (1, 3000))
    b = rng.standard_normal((3000, 1))
    got = IMat.point(a) @ IMat.point(b)
    exact = sum(F(float(x)) * F(float(y)) for x, y in zip(a[0], b[:, 0]))
    assert abs(exact - F(float(got.mid[0, 0]))) <= F(float(got.rad[0, 0]))
    assert got.rad[0, 0] >= gamma(3000) * float((np.abs(a) @ np.abs(b))[0, 0])


def test_the_scaling_of_the_radius_and_a_stack_with_one_infinite_radius():
    big = np.eye(2) * 1e6
    off = np.array([[0.0, 1.0], [1.0, 0.0]])
    assert prove_definite(IMat(big, off * 0.9e6)).outcome == PROVEN  # every member diagonally dominant
    assert prove_definite(IMat(big, off * 1.1e6)).outcome == NOT_PROVEN  # a member is indefinite
    every = IMat(np.array([[1e6, 3e6], [3e6, 1e6]]), off * 1e3)
    refuted = prove_definite(every)
    assert refuted.outcome == FAILS and refuted.form_upper < 0 and math.isfinite(refuted.shift)
    stack = IMat(np.stack([np.eye(2), np.eye(2)]), np.stack([np.zeros((2, 2)), np.full((2, 2), np.inf)]))
    assert [p.outcome for p in prove_definite_batch(stack)] == [PROVEN, NOT_PROVEN]
    # a diagonal whose lower bound is exactly zero: not proven (never a division by a zero scale)
    assert prove_definite(IMat(np.diag([1.0, 0.5]), np.diag([0.0, 0.5]))).outcome == NOT_PROVEN


def test_the_vectorised_decomposition_leaves_its_input_alone():
    M = np.stack([[[2.0, 1.0, 0.0], [1.0, 2.0, 1.0], [0.0, 1.0, 2.0]], [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]])
    before = M.copy()
    assert cholesky_completes(M).tolist() == [True, False] and np.array_equal(M, before)


def test_a_margin_below_the_lowest_rung_is_zero():
    delta = 2.0**-50  # λ_min of [[1/2, 1/2 - δ], [1/2 - δ, 1/2]] is δ: above the rounding shift, below 1e-15
    M = np.array([[0.5, 0.5 - delta], [0.5 - delta, 0.5]])
    got = prove_definite(M)
    assert got.outcome == PROVEN and got.margin == 0.0


def test_each_inequality_row_carries_its_text_place_margin_and_routes():
    """The rows say what was proven, where, with which margin, by which routes (exact only up to EXACT_MAX_DIM
    and only when asked)."""
    A = np.array([[-1.0, 0.5], [0.0, -2.0]])
    P = np.eye(2)
    rows = V.decay(A, P, 0.1, "my decay")
    assert [(r.inequality, r.method) for r in rows] == [("my decay", METHOD)] and rows[0].margin > 0
    rows = V.decay(A, P, 0.1, "my decay", exact=True)
    assert [(r.inequality, r.method, r.outcome) for r in rows] == [("my decay", METHOD, PROVEN), ("my decay", "exact", PROVEN)]
    big = -np.eye(9)
    assert [r.method for r in V.decay(big, np.eye(9), 0.1, exact=True)] == [METHOD]
    assert [r.method for r in V.decay(-np.eye(8), np.eye(8), 0.1, exact=True)] == [METHOD, "exact"]
    assert [r.method for r in V.definite(np.eye(8), exact=True)] == [METHOD, "exact"]
    assert [r.inequality for r in V.definite(np.eye(2), "Q > 0")] == ["Q > 0"]
    stack = np.stack([np.eye(2), 2 * np.eye(2)])
    for rows in (V.definite_interval(IMat.point(stack), "S > 0", ["s1", "s2"]),
                 V.decay_interval(np.stack([A, A]), stack, 0.1, "S decay", ["s1", "s2"]),
                 V.contraction(np.stack([0.5 * np.eye(2)] * 2), stack, 0.9, "S contracts", ["s1", "s2"])):
        assert [r.where for r in rows] == ["s1", "s2"] and len({r.inequality for r in rows}) == 1
        assert all(math.isfinite(r.margin) and r.margin > 0 and math.isfinite(r.shift) for r in rows)
    assert [r.where for r in V.contraction(np.stack([0.5 * np.eye(2)] * 2), stack, 0.9)] == ["", ""]
    assert [r.where for r in V.decay_interval(np.stack([A, A]), stack, 0.1)] == ["", ""]
    assert [r.where for r in V.definite_interval(IMat.point(stack))] == ["", ""]
    assert V.contraction(np.stack([0.5 * np.eye(2)]), np.eye(2)[None], 0.9)[0].inequality == "rho^2 P - A'PA > 0"
    assert V.below(IMat.point(np.eye(2)), 2.0, "below two")[0].inequality == "below two"
    none = V.summary([], "T", "cells")
    assert (none.inequality, none.method, none.where) == ("T", METHOD, "cells (none)")
    bad = V.summary([V.ProofRow("x", FAILS, "exact", where="c7")], "T", "cells")
    assert bad.inequality == "T" and bad.method == "exact"
    assert V.summary([V.ProofRow("x", PROVEN, METHOD, 1e-16, math.nan, "a"),
                      V.ProofRow("x", PROVEN, METHOD, 1e-16, 0.2, "b")], "T", "p").margin == 0.2


def test_the_saturation_decrease_against_the_exact_route_near_its_boundary():
    """The S-procedure block -2T decides this case: the verified and the exact route must agree on each side."""
    A_cl, B, G = np.array([[-1.0]]), np.array([[1.0]]), np.array([[0.0]])
    P = np.array([[1.0]])
    # M = [[-2, -1], [-1, -2T]]: negative definite iff 4T > 1
    for T, want in ((0.26, PROVEN), (0.24, FAILS)):
        rows = V.roa_decrease(A_cl, B, P, G, np.array([[T]]), exact=True)
        assert [r.outcome for r in rows] == [want, want] and [r.method for r in rows] == [METHOD, "exact"]
    assert len(V.roa_decrease(A_cl, B, P, G, np.array([[1.0]]))) == 1
    assert len(V.roa_decrease(-np.eye(8), np.ones((8, 1)), np.eye(8), np.zeros((1, 8)), np.eye(1), exact=True)) == 1
