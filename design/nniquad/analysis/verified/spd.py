"""Verified positive definiteness in floating point (Rump, BIT 46:433-452, 2006).

Rump's Corollary 2.4: let ``A = Aᵀ`` be a floating-point matrix with a positive diagonal and let
``c >= Σ_i α_i a_ii + 6 n (n + max_i a_ii) η`` with ``α_i = γ_{t_i+2}/(1 - γ_{t_i+2})`` (``t_i`` entries left of the
diagonal in row ``i``).  If a floating-point Cholesky decomposition of ``A - cI`` (its diagonal rounded down)
runs to completion, then ``A`` is positive definite.  The bound holds for any order of the inner products and with
or without fused multiply-adds; it needs rounding to nearest and no interval library.  Corollary 2.7: a further
shift by a bound of ``‖R‖₂`` proves every symmetric matrix of ``A ± R`` positive definite.  INTLAB's ``isspd`` is
this test; its error analysis is machine-checked in Coq (``validsdp``, ``theories/cholesky.v``).

Before the test the matrix is scaled by powers of two to a diagonal in ``[1/4, 1)`` (van der Sluis), which is
exact and keeps a matrix of mixed units from looking ill conditioned.  Why an unshifted Cholesky proves nothing:
a matrix whose smallest eigenvalue is ``-1e-17`` relative to its norm factors to completion in floating point as
often as not (Higham, Theorem 10.7: Cholesky succeeds for ``A + ΔA`` with ``|ΔA| <= γ_{n+1}|Rᵀ||R|``).

Three outcomes:

* ``proven``: the shifted Cholesky ran to completion; ``margin`` is the largest extra shift ``s`` of
  :data:`MARGIN_LADDER` (half decades, in the scaled matrix's units) with which it still factors, a proven lower
  bound ``λ_min(D A D) > s`` for the scaling ``D`` (for a stack: the largest ``s`` with which every matrix factors).
* ``fails``: a vector ``x`` whose quadratic form is proven ``<= 0`` over the whole interval, including the rounding
  of evaluating it: no matrix of the set is positive definite (for a point matrix, the matrix is not).
* ``not proven``: neither; the margin is below what the arithmetic can prove.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.rounding import ETA, downward, gamma, upward

__all__ = ["PROVEN", "FAILS", "NOT_PROVEN", "METHOD", "MARGIN_LADDER", "Proof", "prove_definite", "prove_definite_batch",
           "cholesky_completes"]

PROVEN, FAILS, NOT_PROVEN = "proven", "fails", "not proven"
#: The method name ``verify --json`` reports for this test.
METHOD = "verified-cholesky"


@dataclass(frozen=True)
class Proof:
    """The outcome of a verified positive-definiteness test.

    Attributes
    ----------
    outcome
        ``'proven'``, ``'fails'`` or ``'not proven'``.
    shift
        The shift ``c + ‖R‖`` the proof subtracted (scaled units: the scaled diagonal lies in ``[1/4, 1)``).
    margin
        The largest extra shift of :data:`MARGIN_LADDER` that still factors (a proven lower bound of the scaled
        smallest eigenvalue; in a stack, the stack's), 0 when only the rounding shift passes, ``nan`` unless
        proven or when not searched.
    witness
        For ``fails``: the vector (in the original coordinates) whose quadratic form is proven ``<= 0``.
    form_upper
        For ``fails``: the proven upper bound of that quadratic form (scaled units).
    """

    outcome: str
    shift: float = math.nan
    margin: float = math.nan
    witness: np.ndarray | None = field(default=None, repr=False, compare=False)
    form_upper: float = math.nan

    @property
    def proven(self) -> bool:
        return self.outcome == PROVEN

    def to_json(self) -> dict[str, Any]:
        return {"outcome": self.outcome, "method": METHOD, "shift": self.shift, "margin": self.margin}


def _power_of_two_scaling(d: np.ndarray) -> np.ndarray:
    """``2^-ceil(log2(d)/2)``: ``s² d`` lies in ``[1/4, 1)`` and scaling by ``s`` is exact."""
    return np.exp2(-np.ceil(0.5 * np.log2(d)))


def _factors(M: np.ndarray) -> bool:
    """Whether a floating-point Cholesky decomposition of ``M`` runs to completion (LAPACK ``potrf``)."""
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return False
    return True


def cholesky_completes(M: np.ndarray) -> np.ndarray:
    """Whether a floating-point Cholesky decomposition of each matrix of a stack ``(k, n, n)`` runs to completion.

    The outer-product (right-looking) form of the textbook recurrences ``r_jj = sqrt(a_jj - Σ_{p<j} r_jp²)``,
    ``r_ij = (a_ij - Σ_{p<j} r_ip r_jp)/r_jj``, vectorised over the stack: each sum is accumulated in the order
    ``p = 0, 1, ...``, which Rump's error analysis allows (it holds for any order).  A matrix fails at its first
    pivot that is not positive (or not a number); its later steps run on a placeholder pivot of 1 and are ignored.
    """
    if _factors(M):  # LAPACK on the whole stack: the common case, every matrix factors
        return np.ones(np.shape(M)[0], dtype=bool)
    A = np.array(M, dtype=float, copy=True)
    k, n = A.shape[0], A.shape[-1]
    ok = np.ones(k, dtype=bool)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is a failure, recorded below
        for j in range(n):
            d = A[:, j, j]
            ok &= np.isfinite(d) & (d > 0)
            r = np.sqrt(np.where(ok, d, 1.0))
            col = np.where(ok[:, None], A[:, j + 1:, j], 0.0) / r[:, None]
            ok &= np.all(np.isfinite(col), axis=1)
            A[:, j + 1:, j + 1:] -= col[:, :, None] * col[:, None, :]
    return ok


def _prepare(mid: np.ndarray, rad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Scaled, shifted matrices of a stack ``(k, n, n)``: ``(Ms, shifted, shift, diagonal_ok)``.

    ``Ms`` is the scaled midpoint with its diagonal replaced by the scaled lower bound of the diagonal (Rump's
    ``isspd``: then the diagonal has radius 0); ``shifted = Ms - shift I`` with the diagonal rounded down, where
    ``shift = c + ‖R_s‖∞`` (Corollaries 2.4 and 2.7); ``diagonal_ok`` is False where a diagonal's lower bound is
    not positive (those rows of the other outputs are placeholders).
    """
    k, n, _ = mid.shape
    eye = np.eye(n, dtype=bool)
    d_low = downward(np.diagonal(mid, axis1=1, axis2=2) - np.diagonal(rad, axis1=1, axis2=2))
    ok = np.all(d_low > 0, axis=1)
    d_pos = np.where(d_low > 0, d_low, 1.0)  # a placeholder where the matrix is refused anyway
    s = _power_of_two_scaling(d_pos)
    S = s[:, :, None] * s[:, None, :]
    Ms = np.where(eye, (d_pos * s * s)[:, :, None] * eye, mid * S)
    Rs = np.where(eye, 0.0, rad * S + ETA)  # exact scaling by powers of two; an underflow costs at most η
    r_norm = np.max(upward(np.sum(Rs, axis=2), n), axis=1)  # ρ(R) <= ‖R‖∞ for R >= 0
    g = np.array([gamma(i + 2) for i in range(n)])
    alpha = upward(g / (1.0 - g), 3)
    dm = np.diagonal(Ms, axis1=1, axis2=2)
    c = upward(dm @ alpha + 6.0 * n * (n + np.max(dm, axis=1)) * ETA, n + 3)
    shift = upward(c + r_norm, 2)
    shifted = Ms.copy()
    idx = np.arange(n)
    shifted[:, idx, idx] = downward(dm - shift[:, None])
    return Ms, shifted, shift, ok


def prove_definite(A: "IMat | np.ndarray", radius: np.ndarray | None = None, *, margin: bool = True) -> Proof:
    """Prove (or refute) that every symmetric matrix of ``A ± radius`` is positive definite.

    Parameters
    ----------
    A
        An exactly symmetric floating-point matrix, or an :class:`IMat` (whose radius is used, plus ``radius``).
    radius
        A further entrywise radius (non-negative, symmetric), or ``None``.
    margin
        Also search the proven margin (a few more factorisations).
    """
    X = IMat.of(A)
    mid = np.asarray(X.mid, dtype=float)
    rad = np.asarray(X.rad, dtype=float) + (0.0 if radius is None else np.abs(np.asarray(radius, dtype=float)))
    if mid.ndim != 2 or mid.shape[0] != mid.shape[1]:
        raise ValueError(f"a square matrix is needed, got shape {mid.shape}")
    return prove_definite_batch(IMat(mid[None], np.broadcast_to(rad, mid.shape)[None].copy()), margin=margin)[0]


def prove_definite_batch(A: "IMat | np.ndarray", *, margin: bool = False, refute: bool = True,
                         symmetric_checked: bool = False) -> list[Proof]:
    """:func:`prove_definite` on every matrix of a stack ``(k, n, n)`` (an :class:`IMat` or a float array).

    The shifted decompositions run vectorised over the stack (:func:`cholesky_completes`).  Without ``refute``
    a matrix that does not factor is ``not proven`` without looking for a counterexample (the box proof, which
    refines such cells instead).  ``symmetric_checked``: the caller built the midpoints exactly symmetric (a
    difference or :meth:`IMat.symmetric` of symmetric matrices), and the check is skipped.
    """
    X = IMat.of(A)
    mid, rad = np.asarray(X.mid, dtype=float), np.asarray(X.rad, dtype=float)
    if mid.ndim != 3 or mid.shape[1] != mid.shape[2] or rad.shape != mid.shape:
        raise ValueError(f"a stack of square matrices is needed, got shapes {mid.shape} and {rad.shape}")
    if not symmetric_checked and not np.array_equal(mid, np.swapaxes(mid, 1, 2), equal_nan=True):
        raise ValueError("the midpoints must be exactly symmetric (use IMat.symmetric)")
    rad = np.maximum(rad, np.swapaxes(rad, 1, 2))
    finite = np.all(np.isfinite(mid), axis=(1, 2)) & np.all(np.isfinite(rad), axis=(1, 2))
    mid_f, rad_f = np.where(finite[:, None, None], mid, 1.0), np.where(finite[:, None, None], rad, 0.0)
    Ms, shifted, shift, diag_ok = _prepare(mid_f, rad_f)
    factored = diag_ok & finite & cholesky_completes(shifted)
    out = []
    for i in range(len(mid)):
        if not finite[i]:
            out.append(Proof(NOT_PROVEN, math.inf))
        elif not factored[i]:
            c = float(shift[i]) if diag_ok[i] else math.inf
            out.append(_refute_or_not_proven(mid[i], rad[i], c) if refute else Proof(NOT_PROVEN, c))
        else:
            out.append(Proof(PROVEN, shift=float(shift[i]), margin=math.nan))
    if margin and np.any(factored):
        idx = np.flatnonzero(factored)
        for i, m in zip(idx, _margins(Ms[idx], shift[idx])):
            out[i] = Proof(PROVEN, shift=out[i].shift, margin=m)
    return out


#: The extra shifts the proven margin is searched among (half decades from 1 down to 1e-15, in the scaled units).
MARGIN_LADDER = tuple(10.0 ** (-k / 2) for k in range(31))


def _margins(Ms: np.ndarray, shift: np.ndarray) -> list[float]:
    """The largest shift of :data:`MARGIN_LADDER` with which every matrix of the stack still factors (beyond its
    own rounding shift), by bisection on the ladder with stacked decompositions; 0 if none.  It is the stack's
    proven margin: every matrix ``A_s`` of it has ``λ_min(A_s) > margin``."""
    idx = np.arange(Ms.shape[-1])
    diag = np.diagonal(Ms, axis1=1, axis2=2)

    def passes(extra: float) -> bool:
        trial = Ms.copy()
        trial[:, idx, idx] = downward(diag - upward(shift + extra, 2)[:, None])
        return _factors(trial)  # LAPACK on the stack: it stops at the first matrix that fails

    # the scaled diagonal lies below 1, so the top rung never passes; search the rest
    lo, hi = len(MARGIN_LADDER), 1  # MARGIN_LADDER[lo] passes (lo = len: none yet), [hi - 1] fails
    while hi < lo:
        mid = (hi + lo) // 2
        if passes(MARGIN_LADDER[mid]):
            lo = mid
        else:
            hi = mid + 1
    return [MARGIN_LADDER[lo] if lo < len(MARGIN_LADDER) else 0.0] * len(Ms)


def _refute_or_not_proven(mid: np.ndarray, rad: np.ndarray, shift: float) -> Proof:
    """``fails`` with a vector whose quadratic form is proven ``<= 0`` for every matrix of ``mid ± rad`` (a diagonal
    entry, or the eigenvector of the smallest eigenvalue); ``not proven`` otherwise."""
    n = mid.shape[0]
    # the largest diagonal entry of the set: exact for a point entry, else one ulp above the rounded sum
    d_up = np.where(np.diag(rad) == 0, np.diag(mid), np.nextafter(np.diag(mid) + np.diag(rad), np.inf))
    if np.any(d_up <= 0):
        i = int(np.argmin(d_up))
        x = np.zeros(n)
        x[i] = 1.0
        return Proof(FAILS, shift=shift, witness=x, form_upper=float(d_up[i]))
    d = np.abs(np.diag(mid))
    s = _power_of_two_scaling(np.where(d > 0, d, 1.0))
    S = s[:, None] * s[None, :]
    Ms, Rs = mid * S, rad * S + ETA
    y = np.linalg.eigh(Ms)[1][:, 0]
    form = float(y @ (Ms @ y))
    absy = np.abs(y)
    # |fl(yᵀ(My)) - yᵀMy| <= γ_{n+1} |y|ᵀ|M||y| (any order); the set adds at most |y|ᵀR|y|
    slack = float(upward(gamma(n + 1) * float(absy @ (np.abs(Ms) @ absy)) + float(absy @ (Rs @ absy)), n + 3))
    upper = float(np.nextafter(form + slack, np.inf))
    if upper <= 0:
        return Proof(FAILS, shift=shift, witness=s * y, form_upper=upper)
    return Proof(NOT_PROVEN, shift=shift)
