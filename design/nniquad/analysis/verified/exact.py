"""Positive definiteness decided in exact rational arithmetic (a second, independent route for small matrices).

Every binary64 number is a rational, so a stored ``P`` and a recomputed ``A`` convert to :class:`fractions.Fraction`
without error; an expression such as ``-(AᵀP + PA + εP)`` is then formed exactly, and an LDLᵀ decomposition
without pivoting decides it: a symmetric matrix is positive definite iff every pivot is positive (the pivots are
ratios of consecutive leading principal minors, Sylvester's criterion).  The cost grows as ``n³`` big-rational
operations, so this is for the reduced loop's matrices (at most a few tens of rows), not the cascade.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import numpy as np

__all__ = ["FMatrix", "fraction_matrix", "fmul", "fadd", "fscale", "ftranspose", "exact_definite"]

#: A matrix of exact rationals, as a list of rows.
FMatrix = list[list[Fraction]]


def fraction_matrix(M: np.ndarray | Sequence[Sequence[float]]) -> FMatrix:
    """The exact rational value of every entry of a finite floating-point matrix."""
    A = np.atleast_2d(np.asarray(M, dtype=float))
    if not np.all(np.isfinite(A)):
        raise ValueError("a non-finite entry has no rational value")
    return [[Fraction(float(v)) for v in row] for row in A]


def fmul(A: FMatrix, B: FMatrix) -> FMatrix:
    """The exact product ``AB``."""
    if len(A[0]) != len(B):
        raise ValueError(f"shapes {len(A)}x{len(A[0])} and {len(B)}x{len(B[0])} do not multiply")
    cols = list(zip(*B))
    return [[sum((a * b for a, b in zip(row, col)), Fraction(0)) for col in cols] for row in A]


def fadd(A: FMatrix, B: FMatrix) -> FMatrix:
    """The exact sum ``A + B``."""
    return [[a + b for a, b in zip(ra, rb)] for ra, rb in zip(A, B)]


def fscale(s: Fraction | float, A: FMatrix) -> FMatrix:
    """The exact ``sA``."""
    s = Fraction(s)
    return [[s * a for a in row] for row in A]


def ftranspose(A: FMatrix) -> FMatrix:
    """The transpose."""
    return [list(col) for col in zip(*A)]


def exact_definite(M: FMatrix) -> tuple[bool, int | None]:
    """Whether the exact symmetric matrix ``M`` is positive definite, and the first non-positive pivot's index.

    Raises
    ------
    ValueError
        ``M`` is not square or not exactly symmetric.
    """
    n = len(M)
    if any(len(row) != n for row in M) or any(M[i][j] != M[j][i] for i in range(n) for j in range(i)):
        raise ValueError("exact_definite needs an exactly symmetric square matrix")
    A = [list(row) for row in M]
    for k in range(n):
        pivot = A[k][k]
        if pivot <= 0:
            return False, k
        # eliminate column k from the lower triangle: A[i][j] -= A[i][k] A[j][k] / pivot for k < j <= i
        for i in range(k + 1, n):
            f = A[i][k] / pivot
            for j in range(k + 1, i + 1):
                A[i][j] -= f * A[j][k]
    return True, None
