"""The Lur'e-Postnikov region's decrease proven with the verified Cholesky test, per axis and on the coupled loop.

:mod:`nniquad.analysis.cascade.region` writes the decrease as a quadratic form ``ξᵀFξ`` in ``ξ = (x, ψ, ψ⁺)`` and
decides ``F ≺ 0`` against a first-order rounding estimate.  Here ``F`` is formed in midpoint-radius arithmetic
(:class:`nniquad.analysis.verified.interval.IMat`) from the loop as recomputed and the region's ``P, Ĝ, μ`` as
evaluated at each point, and ``-F ≻ 0`` is proven (Rump 2006, Corollary 2.7), as is ``P_a(θ) ≻ 0``.  At a fixed
parameter point any ``P`` works as a Lyapunov candidate, so the float evaluation of the stated ``P(θ)`` is the
function whose decrease is proven there; the reach and the inclusion are recomputed from the same numbers.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from nniquad.analysis.cascade.box import ParameterBox
from nniquad.analysis.cascade.family import CascadeFamily
from nniquad.analysis.cascade.lyapunov import RobustLyapunov
from nniquad.analysis.cascade.region import HORIZONTAL, LureRegion, axis_loops, coupled_parts
from nniquad.analysis.verified import inequalities as V
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.rounding import UNIT_ROUNDOFF
from nniquad.analysis.verified.spd import prove_definite_batch

__all__ = ["decrease_enclosure", "lure_proofs"]


def decrease_enclosure(A: "IMat | np.ndarray", Bh: "IMat | np.ndarray", Kh: "IMat | np.ndarray", P: np.ndarray,
                       G: np.ndarray, mu: np.ndarray, rho: float) -> IMat:
    """An enclosure of ``-F`` (:func:`nniquad.analysis.cascade.region.decrease_forms`) at every point of a stack.

    ``F = X⁺ᵀPX⁺ - ρ²XᵀPX + μ[(ν⁺ - ψ⁺)ᵀ(ν⁺ - ν) + (ν⁺ - ν)ᵀ(ν⁺ - ψ⁺) - sᵀs] - 2ψᵀψ + ψᵀĜX + XᵀĜᵀψ``
    with the selectors ``X, ψ, ψ⁺`` of ``ξ``, ``X⁺ = [A, -Bh, 0]``, ``ν = K̂X``, ``ν⁺ = K̂X⁺`` and
    ``s = (ν⁺ - ψ⁺) - (ν - ψ)``.
    """
    A, Bh, K = (IMat.of(x) for x in (A, Bh, Kh))
    N, n, m = A.mid.shape[0], A.mid.shape[-1], Bh.mid.shape[-1]
    d = n + 2 * m
    zeros = np.zeros(Bh.mid.shape)
    Xp = IMat(np.concatenate([A.mid, -Bh.mid, zeros], axis=-1), np.concatenate([A.rad, Bh.rad, zeros], axis=-1))
    # ν = K̂X is K̂ written into the x columns, and xᵀPx, ψᵀĜx, ψᵀψ are P, Ĝ, I written into their blocks of ξ:
    # placements, exact (the selectors' products would only add exact zeros)
    v = IMat(np.concatenate([K.mid, np.zeros((N, m, 2 * m))], axis=-1),
             np.concatenate([K.rad, np.zeros((N, m, 2 * m))], axis=-1))
    vp = K @ Xp
    eye = np.eye(d)
    a = vp - eye[n + m:]
    b = vp - v
    s = a - (v - eye[n:n + m])
    Mmu = a.T @ b + b.T @ a - s.T @ s
    r2 = float(np.nextafter(float(rho) * float(rho), np.inf))  # rounded up: -F grows smaller, the claim stronger
    blocks = np.zeros((N, d, d))
    blocks[:, :n, :n] = -r2 * P  # exact but for the product's one rounding, enclosed below
    blocks[:, n:n + m, :n] = G
    blocks[:, :n, n:n + m] = np.swapaxes(G, 1, 2)
    blocks[:, n:n + m, n:n + m] = -2.0 * np.eye(m)
    placed = IMat(blocks, UNIT_ROUNDOFF * np.abs(blocks))
    F = Xp.T @ IMat.point(P) @ Xp + Mmu.times(np.asarray(mu, float)) + placed
    return (-F).symmetric()


def _summary(proofs, text: str, where: str) -> V.ProofRow:
    return V.summary(V.rows_of(text, proofs), text, where)


def lure_proofs(region: LureRegion, box: ParameterBox, lmi: Mapping[str, CascadeFamily], grid: CascadeFamily,
                lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]]) -> list[V.ProofRow]:
    """The Lur'e region's strict inequalities, proven: each axis's decrease ``-F ≻ 0`` at its LMI points, ``P_a ≻ 0``
    at the grid, and the decrease of the coupled loop (both axes, every off-block entry kept) at the grid, in the
    subsystems' coordinates ``ζ = T_m x`` (the rounding of that change of variables is part of the enclosure).
    At the grid the coupled decrease is the one that matters: it is the loop that flies; the decoupled axes'
    decrease there stays a recomputed number (:func:`nniquad.analysis.cascade.region.lure_check`)."""
    dec, pos = [], []
    for a in HORIZONTAL:
        P, G, mu = region.at(box, lmi[a].points, a)
        A, Bh, Kh = axis_loops(lmi[a], a)
        dec += prove_definite_batch(decrease_enclosure(A, Bh, Kh, P, G, mu, region.rho), margin=True)
        P, _, _ = region.at(box, grid.points, a)
        pos += prove_definite_batch(IMat.point(0.5 * (P + np.swapaxes(P, 1, 2))), margin=True)
    rows = [_summary(dec, "-F > 0 (the Lur'e decrease, each axis)", "LMI points"),
            _summary(pos, "P_a(theta) > 0", "grid points")]
    rows.append(_summary(prove_definite_batch(_coupled_enclosure(region, lyap, dims, box, grid), margin=True),
                         "-F > 0 (the Lur'e decrease of the coupled loop)", "grid points"))
    return rows


def _coupled_enclosure(region: LureRegion, lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]],
                       box: ParameterBox, fam: CascadeFamily) -> IMat:
    """:func:`decrease_enclosure` of the coupled loop (:func:`nniquad.analysis.cascade.region.coupled_decrease`),
    with ``T_m A_d T_mᵀ``, ``T_m B L`` and ``K T_mᵀ / L`` enclosed too."""
    Tm, Pz, Gz, mu = coupled_parts(region, lyap, dims, box, fam)
    N = len(fam)
    L = np.broadcast_to(np.asarray(fam.accel_limit, float), (N,))
    T = IMat.point(np.broadcast_to(Tm, (N,) + Tm.shape).copy())
    A = T @ IMat.point(fam.A_d) @ T.T
    B = (T @ IMat.point(fam.B)).times(L)
    K = (IMat.point(np.broadcast_to(fam.K, (N,) + fam.K.shape).copy()) @ T.T).divided(L)
    return decrease_enclosure(A, B, K, Pz, Gz, mu, region.rho)
