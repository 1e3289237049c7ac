"""The cascade's Lyapunov inequality proven at its points and over every cell of its parameter box.

The stated Lyapunov function is ``V = xᵀP(θ)x`` with ``P(θ) = T_mᵀ diag(P_x, P_y, P_alt, P_yaw)(θ) T_m``, each block
affine in the box's normalised log coordinates ``θ ∈ [-1, 1]`` (:func:`nniquad.analysis.cascade.lyapunov.assemble_P`).
It certifies a contraction ``ρ`` per period where ``ρ²P(θ) - A_d(θ)ᵀP(θ)A_d(θ) ≻ 0``.  This module proves that
inequality with Rump's verified Cholesky (:mod:`nniquad.analysis.verified`):

* at the LMI points and the grid points, for the matrices recomputed there;
* over each cell of the grid (the box between its grid points).  In a fixed metric ``X`` (``XᵀP(0)X = I``) the
  form ``M̃(θ) = Xᵀ(ρ²P(θ) - A_d(θ)ᵀP(θ)A_d(θ))X`` is proven ``≻ F`` at every corner of the cell, where
  ``F = 2|M̃(c) - mean_v M̃(v)|`` (matrix absolute value) is the interpolation allowance: the gap between the
  centre and the corners' mean is the interpolation error at the centre, the largest for a form quadratic in each
  coordinate, doubled for what is not quadratic.  The multilinear interpolant of the corners is a convex
  combination of them, so it is ``≻ F`` over the cell, and ``M̃ ⪰ interpolant - F ≻ 0`` there.  The corner
  proofs are rigorous (``P(θ)`` is affine and enclosed exactly, ``A_d`` as recomputed); the allowance is an
  estimate, not interval arithmetic of the matrix exponential: the one step of the box proof that is not proven.

A cell that is not proven is cut in two across the coordinate along which the form curves most (up to
:data:`MAX_DEPTH` times);
a cell still not proven at the deepest level is a failure when its centre's matrix is proven indefinite, else it
is reported ``not proven``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox, normalised_coordinates
from nniquad.analysis.cascade.family import mode_transform, subsystem_blocks
from nniquad.analysis.verified import inequalities as V
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.spd import FAILS, NOT_PROVEN, PROVEN, prove_definite_batch

__all__ = ["BOX_PROOF_METHOD", "ENCLOSURE", "MAX_DEPTH", "MAX_CELLS", "RHO_SLACKS", "BOX_RHO_FRACTIONS",
           "BOX_MARGIN", "BoxProof", "full_affine_P", "box_proof", "box_rho", "allowed_box_rhos", "prove_box",
           "lyapunov_point_proofs", "grid_point_proofs"]

#: How the range of ``A_d`` over a cell is enclosed (stated in the certificate and by ``verify``).
ENCLOSURE = ("corner interpolation: the form is proven at every corner of a cell to exceed F = 2|M(centre) - mean of "
             "the corners' M|, the interpolation error at the centre (exact for a form quadratic in each coordinate, "
             "doubled; an estimate, not interval arithmetic of expm); P(theta) is affine, enclosed exactly")
#: The margin each corner of each cell is proven to clear beyond its interpolation allowance, in the box's central
#: metric (where the form is ρ²I - ÃᵀÃ, of order 1e-3 to 1 on a contracting cascade): the proof's stated margin.
BOX_MARGIN = 1e-6
#: Cells proven in one batch (their corner matrices: CHUNK x 64 matrices of the cascade's size at once).
CHUNK = 64
#: How each cell's corners are proven (stated in the certificate).
BOX_PROOF_METHOD = "verified-cholesky (Rump 2006, Corollaries 2.4 and 2.7) at every corner of every cell"
#: Times a cell that is not proven is cut in two (across the coordinate along which it curves most).
MAX_DEPTH = 12
#: The contraction proven at the LMI and grid points: the stated one plus the first of these that proves every
#: point (the stated value is the largest computed contraction, attained to rounding at one point, where nothing
#: larger can be proven; an ill-conditioned P, 1e16 between its eigenvalues, needs more than 1e-6).
RHO_SLACKS: tuple[float, ...] = (1e-5, 1e-4, 1e-3)


#: The contractions a box proof may claim: ``1 - f (1 - ρ_grid)`` for these ``f``, tried in order (between grid
#: points the contraction may exceed the grid's worst: first half the grid's margin is the allowance, then more).
BOX_RHO_FRACTIONS: tuple[float, ...] = (0.5, 0.125, 0.03125)
#: Largest number of cells one refinement level may hold (a bound on the proof's time and memory).
MAX_CELLS = 20000


def box_rho(grid_rho: float, fraction: float = BOX_RHO_FRACTIONS[0]) -> float:
    """The contraction a box proof claims: ``1 - fraction (1 - grid_rho)`` (:data:`BOX_RHO_FRACTIONS`), never above
    1 (a grid that does not contract leaves the claim of stability alone, which the proof then refutes)."""
    return min(1.0 - float(fraction) * (1.0 - float(grid_rho)), 1.0)


def allowed_box_rhos(grid_rho: float) -> list[float]:
    """Every contraction a stated box proof may claim for this grid's worst contraction."""
    return [box_rho(grid_rho, f) for f in BOX_RHO_FRACTIONS]


@dataclass(frozen=True)
class BoxProof:
    """The outcome of the proof over the cells of a box.

    Attributes
    ----------
    outcome
        ``proven`` (every cell), ``fails`` (a cell whose centre is proven not to contract by ``rho``) or
        ``not proven``.
    rho
        The contraction proven on every cell.
    cells
        Number of cells proven (the leaves of the refinement).
    initial_cells
        Cells of the grid before refinement.
    refined
        Cells that were split.
    depth
        Deepest refinement used.
    max_allowance
        Largest ``‖F‖₂`` of the interpolation allowances of the leaves (in the box's central metric).
    min_margin
        The margin every corner clears beyond its allowance (:data:`BOX_MARGIN`, proven), ``nan`` unless proven.
    failed_cell
        The first cell not proven (its lower and upper factors by :data:`POINT_NAMES`), or ``None``.
    """

    outcome: str
    rho: float
    cells: int
    initial_cells: int
    refined: int
    depth: int
    max_allowance: float
    min_margin: float
    failed_cell: dict[str, list[float]] | None = field(default=None)

    def to_json(self) -> dict[str, Any]:
        return {"outcome": self.outcome, "rho": self.rho, "cells": self.cells, "initial_cells": self.initial_cells,
                "refined": self.refined, "depth": self.depth, "max_allowance": self.max_allowance,
                "min_margin": self.min_margin if math.isfinite(self.min_margin) else None,
                "enclosure": ENCLOSURE, "method": BOX_PROOF_METHOD,
                "failed_cell": self.failed_cell}

    def row(self) -> V.ProofRow:
        where = (f"{self.cells} cells ({self.initial_cells} + refinements of {self.refined}, depth {self.depth})"
                 if self.failed_cell is None else f"cell {self.failed_cell}")
        return V.ProofRow(f"rho^2 P(theta) - A_d(theta)'P(theta)A_d(theta) > 0 over every cell, rho = {self.rho:.10g}",
                          self.outcome, "verified-cholesky", math.nan, self.min_margin, where)


def full_affine_P(lyap_P: Mapping[str, np.ndarray], dims: Mapping[str, Sequence[int]],
                  state_names: Sequence[str], frame: str) -> IMat:
    """``P(θ) = Q_0 + Σ_d θ_d Q_d`` in the cascade's own coordinates: a stack ``(7, n, n)`` (``Q_{1+d}`` for
    coordinate ``d`` of :data:`POINT_NAMES`, zero where no block depends on it), enclosed."""
    Tm, _ = mode_transform(state_names, frame)
    n = Tm.shape[0]
    Z = np.zeros((1 + len(POINT_NAMES), n, n))
    for name, sl in subsystem_blocks(state_names).items():
        Pk = np.asarray(lyap_P[name], float)
        Z[0, sl, sl] += Pk[0]
        for j, d in enumerate(dims[name]):
            Z[1 + d, sl, sl] += Pk[1 + j]
    T = IMat.point(np.broadcast_to(Tm, Z.shape).copy())
    return (T.T @ IMat.point(Z) @ T).symmetric()


def _initial_cells(box: ParameterBox, grid_n: int) -> tuple[np.ndarray, np.ndarray]:
    """The cells between the grid's points (:meth:`ParameterBox.grid`): lower and upper factors ``(k, 6)``."""
    lo, hi = box.bounds()
    axes = [np.unique(np.geomspace(a, b, grid_n)) if b > a else np.array([a]) for a, b in zip(lo, hi)]
    pairs = [list(zip(ax[:-1], ax[1:])) if ax.size > 1 else [(ax[0], ax[0])] for ax in axes]
    cells = list(itertools.product(*pairs))
    return (np.array([[c[d][0] for d in range(6)] for c in cells], float),
            np.array([[c[d][1] for d in range(6)] for c in cells], float))


def _corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The corners ``(k, 2^q, 6)`` of each cell (``q`` non-degenerate coordinates, the same for every cell)."""
    free = [d for d in range(lo.shape[1]) if np.any(hi[:, d] > lo[:, d])]
    out = np.repeat(lo[:, None, :], 2 ** len(free), axis=1)
    for c, bits in enumerate(itertools.product((0, 1), repeat=len(free))):
        for d, b in zip(free, bits):
            if b:
                out[:, c, d] = hi[:, d]
    return out


def _bisect(forms: "_Forms", lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each cell cut in two (at its geometric middle) across the coordinate along which ``M̃`` curves most.

    The curvature along ``d`` is ``‖M̃(c + h e_d) + M̃(c - h e_d) - 2M̃(c)‖_F`` at the centre ``c`` (the face centres
    are evaluated once); halving that coordinate divides its share of the interpolation error by four.
    """
    centre = np.sqrt(lo * hi)
    free = [d for d in range(lo.shape[1]) if np.any(hi[:, d] > lo[:, d])]
    Mc = forms(centre).mid
    curv = np.zeros((lo.shape[0], lo.shape[1]))
    for d in free:
        up, down = centre.copy(), centre.copy()
        up[:, d], down[:, d] = hi[:, d], lo[:, d]
        curv[:, d] = np.linalg.norm(forms(up).mid + forms(down).mid - 2.0 * Mc, axis=(1, 2))
    # six significant digits: the mirrored axes (Jx, Jy) tie, and another machine's rounding must not untie them
    cut = np.argmax(np.array([[float(f"{v:.6g}") for v in row] for row in curv]), axis=1)
    rows = np.arange(lo.shape[0])
    a_hi, b_lo = hi.copy(), lo.copy()
    a_hi[rows, cut] = centre[rows, cut]
    b_lo[rows, cut] = centre[rows, cut]
    return np.concatenate([lo, b_lo]), np.concatenate([a_hi, hi])


class _PerPoint:
    """A value per parameter point, each point computed once (``compute(rows)`` for the points not seen yet)."""

    def __init__(self, compute: Callable[[np.ndarray], Sequence[Any]]) -> None:
        self.compute = compute
        self.index: dict[bytes, int] = {}
        self.values: list[Any] = []

    def remember(self, points: np.ndarray, values: Sequence[Any]) -> None:
        for p, v in zip(np.asarray(points, float), values):
            if p.tobytes() not in self.index:
                self.index[p.tobytes()] = len(self.values)
                self.values.append(v)

    def lookup(self, points: np.ndarray) -> list[Any]:
        """The values at ``points`` ``(..., 6)``, flattened in row order."""
        flat = np.ascontiguousarray(points, float).reshape(-1, points.shape[-1])
        keys = [p.tobytes() for p in flat]
        missing = list(dict.fromkeys(k for k in keys if k not in self.index))
        if missing:
            rows = np.array([np.frombuffer(k, float) for k in missing])
            self.remember(rows, self.compute(rows))
        return [self.values[self.index[k]] for k in keys]


class _Evaluator(_PerPoint):
    """``A_d`` at points, each point evaluated once (the grid's matrices handed in are reused)."""

    def __init__(self, evaluate: Callable[[np.ndarray], np.ndarray], known_points: np.ndarray | None,
                 known_A: np.ndarray | None) -> None:
        super().__init__(evaluate)
        if known_points is not None and known_A is not None:
            self.remember(known_points, known_A)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        out = np.stack(self.lookup(points))
        return out.reshape(points.shape[:-1] + out.shape[-2:])


def _theta(box: ParameterBox, points: np.ndarray) -> np.ndarray:
    """The box's normalised log coordinates of ``points`` ``(k, 6)``; 0 in a degenerate coordinate (which no
    block of ``P`` depends on)."""
    lo, hi = box.bounds()
    free = [d for d in range(len(lo)) if hi[d] > lo[d]]
    out = np.zeros((np.atleast_2d(points).shape[0], len(lo)))
    out[:, free] = normalised_coordinates(box, points, free)
    return out


def _psd_abs(E: np.ndarray) -> np.ndarray:
    """The matrix absolute value ``V|Λ|Vᵀ`` of each symmetric matrix of a stack."""
    w, Q = np.linalg.eigh(0.5 * (E + np.swapaxes(E, -1, -2)))
    F = (Q * np.abs(w)[..., None, :]) @ np.swapaxes(Q, -1, -2)
    return 0.5 * (F + np.swapaxes(F, -1, -2))


class _Forms(_PerPoint):
    """``Xᵀ(ρ²P(θ) - A_d(θ)ᵀP(θ)A_d(θ))X`` enclosed at points, each point once (``X`` fixed: ``L⁻ᵀ`` of the box's
    central ``P(0) = LLᵀ``, a float matrix; a congruence by any nonsingular ``X`` keeps definiteness, and a proven
    ``XᵀMX ≻ 0`` implies that ``X`` is nonsingular)."""

    def __init__(self, evaluate: _Evaluator, box: ParameterBox, P: IMat, rho: float) -> None:
        super().__init__(self._forms)
        self.evaluate, self.box, self.P, self.rho = evaluate, box, P, float(rho)
        P0 = 0.5 * (P.mid[0] + P.mid[0].T)
        self.X = np.linalg.inv(np.linalg.cholesky(P0)).T

    def _forms(self, rows: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        A = self.evaluate(rows)
        M = V.metric_form(A, V.affine_enclosure(self.P, _theta(self.box, rows)),
                          np.broadcast_to(self.X, A.shape).copy(), self.rho)
        return list(zip(M.mid, M.rad))

    def __call__(self, points: np.ndarray) -> IMat:
        got = self.lookup(points)
        shape = points.shape[:-1] + got[0][0].shape
        return IMat(np.stack([m for m, _ in got]).reshape(shape), np.stack([r for _, r in got]).reshape(shape))


def _cell_proofs(forms: _Forms, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Prove each cell: ``M̃(v) - F ≻ 0`` at every corner ``v`` (``M̃`` of :class:`_Forms`).

    ``F = 2|E|`` with ``E = M̃(centre) - mean_v M̃(v)``: the interpolation error at the centre, where a function
    quadratic in each coordinate has its largest one; the factor 2 is the allowance for what is not quadratic.
    The multilinear interpolant of the corners is a convex combination of them, so ``M̃(v) - F ≻ 0`` at every
    corner makes it ``≻ F`` over the cell, and ``M̃ = interpolant + error ⪰ interpolant - F`` there.

    Returns each cell's proven flag and ``‖F‖₂`` (the interpolation allowance).
    """
    corners, centre = _corners(lo, hi), np.sqrt(lo * hi)
    k, nc = corners.shape[:2]
    Mv, Mc = forms(corners), forms(centre)
    # the allowance, and the margin every corner must clear beyond it (proven in the same decomposition)
    F = 2.0 * _psd_abs(Mc.mid - np.mean(Mv.mid, axis=1)) + BOX_MARGIN * np.eye(Mc.mid.shape[-1])
    shifted = Mv - F[:, None]  # both symmetric, so the difference is exactly symmetric
    n = Mv.mid.shape[-1]
    proofs = prove_definite_batch(IMat(shifted.mid.reshape(k * nc, n, n), shifted.rad.reshape(k * nc, n, n)),
                                  refute=False, symmetric_checked=True)
    ok = np.array([p.outcome == PROVEN for p in proofs]).reshape(k, nc)
    return np.all(ok, axis=1), np.linalg.norm(F, 2, axis=(1, 2))


def box_proof(evaluate: Callable[[np.ndarray], np.ndarray], box: ParameterBox, grid_n: int, P: IMat, rho: float,
              *, known_points: np.ndarray | None = None, known_A: np.ndarray | None = None,
              max_depth: int = MAX_DEPTH) -> BoxProof:
    """Prove ``ρ²P(θ) - A_d(θ)ᵀP(θ)A_d(θ) ≻ 0`` over every cell of the grid of ``grid_n`` points per coordinate.

    Parameters
    ----------
    evaluate
        ``A_d`` at points ``(k, 6)`` (factors by :data:`POINT_NAMES`): a stack ``(k, n, n)``.
    box
        The parameter box.
    grid_n
        Grid points per coordinate (its cells are the initial cells).
    P
        :func:`full_affine_P` of the stated Lyapunov blocks.
    rho
        The contraction to prove.
    known_points, known_A
        Points whose ``A_d`` is known already (the grid), reused.
    max_depth
        Refinements of a cell that is not proven.
    """
    forms = _Forms(_Evaluator(evaluate, known_points, known_A), box, P, rho)
    lo, hi = _initial_cells(box, grid_n)
    initial, cells, refined, depth, worst_allowance = lo.shape[0], 0, 0, 0, 0.0
    failed: tuple[np.ndarray, np.ndarray, str] | None = None
    level = 0
    while lo.shape[0]:
        good, allowance = [], []
        for start in range(0, lo.shape[0], CHUNK):
            g, a = _cell_proofs(forms, lo[start:start + CHUNK], hi[start:start + CHUNK])
            good.append(g), allowance.append(a)
        good, allowance = np.concatenate(good), np.concatenate(allowance)
        cells += int(np.sum(good))
        if np.any(good):
            worst_allowance = max(worst_allowance, float(np.max(allowance[good])))
        bad = np.flatnonzero(~good)
        depth = max(depth, level)
        if not bad.size:
            break
        refuted = _refuted_centres(forms, lo[bad], hi[bad])
        if refuted is not None:
            i = int(bad[refuted])
            failed = (lo[i], hi[i], FAILS)
            break
        if level >= max_depth:
            failed = (lo[bad[0]], hi[bad[0]], NOT_PROVEN)  # no centre refuted (above): not proven
            break
        if 2 * bad.size > MAX_CELLS:
            failed = (lo[bad[0]], hi[bad[0]], NOT_PROVEN)
            break
        refined += int(bad.size)
        lo, hi = _bisect(forms, lo[bad], hi[bad])
        level += 1
    if failed is None:
        return BoxProof(PROVEN, float(rho), cells, initial, refined, depth, worst_allowance, BOX_MARGIN)
    cell = {name: [float(failed[0][d]), float(failed[1][d])] for d, name in enumerate(POINT_NAMES)}
    return BoxProof(failed[2], float(rho), cells, initial, refined, depth, worst_allowance, math.nan, cell)


def _refuted_centres(forms: "_Forms", lo: np.ndarray, hi: np.ndarray) -> int | None:
    """The first cell whose centre's form is proven not positive definite (a point of the box where the stated
    ``P`` does not contract by ``ρ``), or ``None``."""
    verdicts = prove_definite_batch(forms(np.sqrt(lo * hi)))
    return next((i for i, p in enumerate(verdicts) if p.outcome == FAILS), None)


def prove_box(evaluate: Callable[[np.ndarray], np.ndarray], box: ParameterBox, grid_n: int, P: IMat,
              grid_rho: float, *, known_points: np.ndarray | None = None,
              known_A: np.ndarray | None = None) -> BoxProof:
    """:func:`box_proof` at the first contraction of :func:`allowed_box_rhos` that it proves (else the last try)."""
    got = None
    for rho in allowed_box_rhos(grid_rho):
        got = box_proof(evaluate, box, grid_n, P, rho, known_points=known_points, known_A=known_A)
        if got.outcome == PROVEN:
            break
    assert got is not None
    return got


def _with_slack(prove: Callable[[float], list[V.ProofRow]], rho: float) -> tuple[list[V.ProofRow], float]:
    """``prove(ρ + slack)`` at the first slack of :data:`RHO_SLACKS` (below 1) that proves every row."""
    rows, used = [], RHO_SLACKS[0]
    for slack in RHO_SLACKS:
        if rho + slack >= 1.0 and slack != RHO_SLACKS[0]:
            break
        # never a contraction above 1: a stated rho at or past 1 is checked for stability, and refuted
        rows, used = prove(min(rho + slack, 1.0)), slack
        if all(r.outcome == PROVEN for r in rows) or any(r.outcome == FAILS for r in rows):
            break
    return rows, used


def lyapunov_point_proofs(Pk: np.ndarray, A_v: np.ndarray, theta: np.ndarray, rho: float) -> list[V.ProofRow]:
    """A subsystem's stated ``P(θ)`` at its LMI points: ``(ρ + slack)²P(θ) - AᵀP(θ)A ≻ 0`` at each point
    (:data:`RHO_SLACKS`), and ``P ≻ 0`` at every corner of the θ-cube (``P`` is affine, so the corners prove the
    whole cube)."""
    P = V.affine_enclosure(Pk, theta)
    points, slack = _with_slack(lambda r: V.contraction(A_v, P, r), rho)
    corners = V.rows_of("P(theta) > 0", prove_definite_batch(V.affine_corners(Pk), margin=True))
    return [V.summary(points, f"rho^2 P(theta) - A'P(theta)A > 0, rho = stated + {slack:g}", "LMI points"),
            V.summary(corners, "P(theta) > 0 on the theta-cube", "corners")]


def grid_point_proofs(P: IMat, box: ParameterBox, points: np.ndarray, A_d: np.ndarray, rho: float) -> V.ProofRow:
    """The assembled ``P(θ)`` (:func:`full_affine_P`) at the grid points: ``(ρ + slack)²P - A_dᵀPA_d ≻ 0``."""
    Pg = V.affine_enclosure(P, _theta(box, points))
    rows, slack = _with_slack(lambda r: V.contraction(A_d, Pg, r), rho)
    return V.summary(rows, f"rho^2 P(theta) - A_d'P(theta)A_d > 0, rho = worst + {slack:g}", "grid points")
