"""The strict matrix inequalities of a certificate, each posed as "this expression is positive definite" and proven.

Each function forms its expression in midpoint-radius arithmetic (:class:`~nniquad.analysis.verified.interval.IMat`)
from exact floating-point inputs, so the interval contains the exact expression of those inputs, and hands it to
Rump's test (:func:`~nniquad.analysis.verified.spd.prove_definite`).  With ``exact=True`` (small matrices) the same
expression is also formed and decided in exact rational arithmetic
(:func:`~nniquad.analysis.verified.exact.exact_definite`), a second route that shares no code with the first.

What is proven is the inequality for the *floating-point* inputs: the stored matrices as stated and the system
matrices as recomputed from the design; the rounding of that recomputation is not part of the proof (the
tolerance checks of ``verify`` compare it with the stated numbers).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np

from nniquad.analysis.verified.exact import FMatrix, exact_definite, fadd, fmul, fraction_matrix, fscale, ftranspose
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.rounding import downward
from nniquad.analysis.verified.spd import FAILS, METHOD, NOT_PROVEN, PROVEN, Proof, prove_definite, prove_definite_batch

__all__ = ["ProofRow", "EXACT", "EXACT_MAX_DIM", "outcome_of", "definite", "definite_interval",
           "decay", "decay_interval", "below", "ni_dissipation", "roa_decrease", "contraction", "contraction_enclosure",
           "metric_form", "rows_of", "diagonal_scaling", "summary", "affine_enclosure", "affine_corners"]

#: Method name of the rational route.
EXACT = "exact"
#: Largest dimension the rational route is run on (its cost grows as n³ big-rational operations).
EXACT_MAX_DIM = 8


@dataclass(frozen=True)
class ProofRow:
    """One proven (or refuted) inequality: what, the outcome, by which method, and the proven margin.

    Attributes
    ----------
    inequality
        The inequality in words, e.g. ``"-(A'P + PA + eps P) > 0"``.
    outcome
        ``'proven'``, ``'fails'`` or ``'not proven'``.
    method
        ``'verified-cholesky'`` or ``'exact'``.
    shift, margin
        Of the verified Cholesky (:class:`~nniquad.analysis.verified.spd.Proof`); ``nan`` for the exact route.
    where
        Where it was decided (a point or a cell), or ``''``.
    """

    inequality: str
    outcome: str
    method: str
    shift: float = math.nan
    margin: float = math.nan
    where: str = ""

    def to_json(self) -> dict[str, Any]:
        out = {"inequality": self.inequality, "outcome": self.outcome, "method": self.method,
               "shift": _json_number(self.shift), "margin": _json_number(self.margin)}
        if self.where:
            out["where"] = self.where
        return out


def _json_number(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def outcome_of(rows: Sequence[Any]) -> str:
    """``fails`` if any row fails, else ``not proven`` if any is not proven, else ``proven`` (no rows: ``proven``).

    Any records with an ``outcome`` (proof rows, or a verification's checks, whose ``pass`` counts as proven)."""
    outcomes = {r.outcome for r in rows}
    return FAILS if FAILS in outcomes else NOT_PROVEN if NOT_PROVEN in outcomes else PROVEN


def _row(text: str, proof: Proof, where: str = "") -> ProofRow:
    return ProofRow(text, proof.outcome, METHOD, proof.shift, proof.margin, where)


def rows_of(text: str, proofs: Sequence[Proof], where: Sequence[str] | None = None) -> list[ProofRow]:
    """One row per proof of a stack, each with its place (``where``, one per proof) or none."""
    return [_row(text, p, w) for p, w in zip(proofs, where if where is not None else [""] * len(proofs))]


def _prove_rows(text: str, M: IMat, where: Sequence[str] | None) -> list[ProofRow]:
    """``M ≻ 0`` for one matrix (its margin searched alone) or a stack (one row per matrix, the stack's margin)."""
    if M.mid.ndim == 2:
        return [_row(text, prove_definite(M))]
    return rows_of(text, prove_definite_batch(M, margin=True), where)


def _exact_row(text: str, M: FMatrix) -> ProofRow:
    pd, _ = exact_definite(M)
    return ProofRow(text, PROVEN if pd else FAILS, EXACT)


def _sym_exact(M: FMatrix) -> FMatrix:
    return fscale(0.5, fadd(M, ftranspose(M)))


def definite(P: np.ndarray, text: str = "P > 0", *, exact: bool = False) -> list[ProofRow]:
    """``P ≻ 0`` for a stored, exactly symmetric ``P``."""
    P = np.asarray(P, dtype=float)
    rows = [_row(text, prove_definite(P))]
    if exact and P.shape[0] <= EXACT_MAX_DIM:
        rows.append(_exact_row(text, fraction_matrix(P)))
    return rows


def definite_interval(P: IMat, text: str = "P > 0", where: Sequence[str] | None = None) -> list[ProofRow]:
    """``P ≻ 0`` for every matrix of an enclosure (an expression such as ``P0 + P1/m``); on a stack, one row per
    matrix (with one ``where`` each)."""
    return _prove_rows(text, P.symmetric(), where)


def decay_interval(A: "IMat | np.ndarray", P: "IMat | np.ndarray", eps: float,
                   text: str = "-(A'P + PA + eps P) > 0", where: Sequence[str] | None = None) -> list[ProofRow]:
    """``-(AᵀP + PA + εP) ≻ 0`` for every ``A`` and ``P`` of their enclosures; on a stack ``(k, n, n)`` (with one
    ``where`` per matrix) one row per matrix."""
    Ai, Pi = IMat.of(A), IMat.of(P)
    return _prove_rows(text, (-(Ai.T @ Pi + Pi @ Ai + Pi.scale(eps))).symmetric(), where)


def decay(A: np.ndarray, P: np.ndarray, eps: float, text: str = "-(A'P + PA + eps P) > 0", *,
          exact: bool = False) -> list[ProofRow]:
    """``-(AᵀP + PA + εP) ≻ 0``: ``V = xᵀPx`` decays at least at the rate ``ε`` along ``x' = Ax``."""
    A, P = np.asarray(A, float), np.asarray(P, float)
    rows = decay_interval(A, P, eps, text)
    if exact and A.shape[0] <= EXACT_MAX_DIM:
        Af, Pf = fraction_matrix(A), fraction_matrix(P)
        Mf = fadd(fadd(fmul(ftranspose(Af), Pf), fmul(Pf, Af)), fscale(eps, Pf))
        rows.append(_exact_row(text, fscale(-1, _sym_exact(Mf))))
    return rows


def below(M: IMat, t: float, text: str) -> list[ProofRow]:
    """``tI - M ≻ 0`` (``λ_max(M) < t``) for an enclosed symmetric expression ``M``."""
    return [_row(text, prove_definite((-M).symmetric().shift(-float(t))))]


def ni_dissipation(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> IMat:
    """An enclosure of ``[[PA + AᵀP, PB - AᵀCᵀ], [BᵀP - CA, -(CB + BᵀCᵀ)]]`` (the NI dissipation matrix)."""
    p, a, b, c = (IMat.point(np.asarray(x, float)) for x in (P, A, B, C))
    tl = p @ a + a.T @ p
    tr = p @ b - a.T @ c.T
    br = -(c @ b + b.T @ c.T)
    return _blocks(tl, tr, br)


def _blocks(tl: IMat, tr: IMat, br: IMat) -> IMat:
    """The symmetric block matrix ``[[tl, tr], [trᵀ, br]]``."""
    return IMat(np.block([[tl.mid, tr.mid], [tr.T.mid, br.mid]]), np.block([[tl.rad, tr.rad], [tr.T.rad, br.rad]]))


def roa_decrease(A_cl: np.ndarray, B: np.ndarray, P: np.ndarray, G: np.ndarray, T: np.ndarray, *,
                 exact: bool = False) -> list[ProofRow]:
    """``-[[A_clᵀP + PA_cl, -PB + GᵀT], [-BᵀP + TG, -2T]] ≻ 0``: the saturated loop's S-procedure decrease."""
    A_cl, B, P, G, T = (np.asarray(x, float) for x in (A_cl, B, P, G, T))
    a, b, p, g, t = (IMat.point(x) for x in (A_cl, B, P, G, T))
    top_left = a.T @ p + p @ a
    top_right = g.T @ t - p @ b
    bottom_right = t.scale(-2.0)
    M = _blocks(top_left, top_right, bottom_right)
    text = "-[[A'P + PA, -PB + G'T], [-B'P + TG, -2T]] > 0"
    rows = [_row(text, prove_definite((-M).symmetric()))]
    if exact and A_cl.shape[0] + 1 <= EXACT_MAX_DIM:
        Af, Bf, Pf, Gf, Tf = (fraction_matrix(x) for x in (A_cl, B, P, G, T))
        tl = fadd(fmul(ftranspose(Af), Pf), fmul(Pf, Af))
        tr = fadd(fmul(ftranspose(Gf), Tf), fscale(-1, fmul(Pf, Bf)))
        br = fscale(-2, Tf)
        Mf = [r1 + r2 for r1, r2 in zip(tl, tr)] + [r1 + r2 for r1, r2 in zip(ftranspose(tr), br)]
        rows.append(_exact_row(text, fscale(-1, _sym_exact(Mf))))
    return rows


def contraction_enclosure(A: "IMat | np.ndarray", P: "IMat | np.ndarray", rho: float) -> IMat:
    """An enclosure of ``Xᵀ(ρ²P - AᵀPA)X`` on a stack, ``X = L⁻ᵀ`` from the Cholesky factor of ``P``'s midpoint.

    A congruence by any nonsingular ``X`` keeps the sign of every eigenvalue, and a proven ``XᵀMX ≻ 0`` implies
    that ``X`` is nonsingular, so ``X`` may be any floating-point matrix; this one makes ``XᵀPX ≈ I`` and the
    form ``≈ ρ²I - ÃᵀÃ``, whose smallest eigenvalue is ``ρ² - ‖Ã‖²`` whatever the conditioning of ``P`` (a cascade's
    ``P`` mixes states in units twelve orders of magnitude apart).  Where ``P``'s midpoint does not factor, a
    diagonal scaling by powers of two stands in.  ``ρ²`` is rounded down.
    """
    Pi = IMat.of(P)
    mid = 0.5 * (Pi.mid + np.swapaxes(Pi.mid, -1, -2))
    try:
        X = np.swapaxes(np.linalg.inv(np.linalg.cholesky(mid)), -1, -2)
    except np.linalg.LinAlgError:
        X = diagonal_scaling(mid)[..., :, None] * np.eye(mid.shape[-1])
    return metric_form(A, Pi, X, rho)


def metric_form(A: "IMat | np.ndarray", P: "IMat | np.ndarray", X: np.ndarray, rho: float) -> IMat:
    """An enclosure of ``Xᵀ(ρ²P - AᵀPA)X`` for a float metric ``X`` (any nonsingular one keeps definiteness; a
    proven ``XᵀMX ≻ 0`` implies that ``X`` is nonsingular), with ``ρ²`` rounded down; stacks allowed."""
    Pi, Xi = IMat.of(P), IMat.point(X)
    Y = IMat.of(A) @ Xi
    r2 = float(downward(float(rho) * float(rho)))
    return ((Xi.T @ Pi @ Xi).scale(r2) - Y.T @ Pi @ Y).symmetric()


def diagonal_scaling(P: np.ndarray) -> np.ndarray:
    """Powers of two ``d`` with ``d_i² |P_ii|`` near 1 (1 where the diagonal is not positive and finite)."""
    diag = np.abs(np.diagonal(np.asarray(P, float), axis1=-2, axis2=-1))
    ok = np.isfinite(diag) & (diag > 0)
    return np.where(ok, np.exp2(-np.round(0.5 * np.log2(np.where(ok, diag, 1.0)))), 1.0)


def contraction(A: "IMat | np.ndarray", P: "IMat | np.ndarray", rho: float, text: str = "rho^2 P - A'PA > 0",
                where: Sequence[str] | None = None) -> list[ProofRow]:
    """``ρ²P - AᵀPA ≻ 0`` on a stack ``(k, n, n)`` of loops (intervals allowed): the contraction is at most ``ρ``.

    One row per matrix (:func:`contraction_enclosure`).
    """
    return rows_of(text, prove_definite_batch(contraction_enclosure(A, P, rho), margin=True), where)


def summary(rows: Sequence[ProofRow], text: str, where: str) -> ProofRow:
    """One row standing for many (points or cells): the first that is not proven, or the smallest margin."""
    if not rows:
        return ProofRow(text, NOT_PROVEN, METHOD, where=f"{where} (none)")
    bad = [r for r in rows if r.outcome != PROVEN]
    if bad:
        first = next((r for r in bad if r.outcome == FAILS), bad[0])
        return replace(first, inequality=text, where=f"{first.where} ({len(bad)} of {len(rows)} {where})")
    low = min(rows, key=lambda r: r.margin if math.isfinite(r.margin) else math.inf)
    return replace(low, inequality=text, where=f"all {len(rows)} {where}")


def affine_enclosure(Pk: "IMat | np.ndarray", theta: np.ndarray) -> IMat:
    """``P(θ) = P_0 + Σ_j θ_j P_j`` at every row of ``theta`` ``(k, q)``, enclosed (stack ``(k, n, n)``).

    The coefficients ``Pk`` ``(q + 1, n, n)`` may be enclosures themselves; each term and each partial sum is
    enclosed in turn (:class:`IMat`), which keeps the radius at the size of the partial sums, not of the terms.
    """
    Q = IMat.of(Pk)
    th = np.atleast_2d(np.asarray(theta, float))
    shape = (th.shape[0],) + Q.mid.shape[1:]

    def coefficient(j: int) -> IMat:
        return IMat(np.broadcast_to(Q.mid[j], shape).copy(), np.broadcast_to(Q.rad[j], shape).copy())

    out = coefficient(0)
    for j in range(Q.mid.shape[0] - 1):
        out = out + coefficient(j + 1).times(th[:, j])
    return out.symmetric()


def affine_corners(Pk: np.ndarray) -> IMat:
    """``P(θ) = P_0 + Σ θ_j P_j`` at every corner ``θ ∈ {-1, 1}^q`` of the cube, enclosed (stack ``(2^q, n, n)``)."""
    q = np.asarray(Pk).shape[0] - 1
    signs = list(itertools.product((-1.0, 1.0), repeat=q))
    corners = np.array(signs, float).reshape(len(signs), q)  # q = 0: one corner, no coordinate
    return affine_enclosure(Pk, corners)
