"""Each subsystem's parameter-dependent Lyapunov matrix ``P(θ)``, its rounding margins, and the grid check.

:func:`robust_lyapunov` finds ``P(θ) = P_0 + Σ θ_j P_j`` with the fastest decay at the LMI points;
:func:`reach_lyapunov` one with the widest linear-zone ellipsoid at a slightly slower decay;
:func:`witness_margins` states what an answer certifies and the rounding bound of each strict inequality;
:func:`grid_check` re-checks the assembled 19-state ``P(θ)`` on the coupled loop at a grid of the box.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from nniquad.analysis.cascade.box import POINT_NAMES, ParameterBox, normalised_coordinates
from nniquad.analysis.cascade.conic import ConicProblem, sym_basis
from nniquad.analysis.cascade.family import SUBSYSTEMS, CascadeFamily, mode_transform, subsystem_blocks, subsystem_of
from nniquad.analysis.lmi import checks as lmi_checks
from nniquad.analysis.sampled import best_decay, conditioning_transform
from nniquad.config import CASCADE_GRID_MAX_POINTS_PER_AXIS, CASCADE_LYAPUNOV_RTOL
from nniquad.errors import CascadeError, SolverError

__all__ = ["spectral_norms", "contraction_batch", "checked_grid_size", "RobustLyapunov", "robust_lyapunov",
           "reach_lyapunov", "WitnessMargins", "witness_margins", "GridCheck", "grid_check", "point_index"]

# =============================================================================== robust Lyapunov LMI


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + np.swapaxes(M, -1, -2))


def spectral_norms(M: np.ndarray) -> np.ndarray:
    """``‖M‖₂`` of each matrix of a stack, as ``√λ_max(MᵀM)``.

    The same number as an SVD's largest singular value to a few ulps (the product's rounding is ``n ε ‖M‖²``,
    half that after the square root), at about 2/3 of the time on the stacks of 4096 matrices verify checks.
    """
    M = np.asarray(M, float)
    if np.isnan(M).any():  # as numpy's SVD does: NaN does not converge, an infinite entry gives NaN
        raise np.linalg.LinAlgError("spectral norm of a matrix with NaN entries")
    finite = np.all(np.isfinite(M), axis=(-2, -1))
    Mf = np.where(finite[..., None, None], M, 0.0)
    top = np.linalg.eigvalsh(np.swapaxes(Mf, -1, -2) @ Mf)[..., -1]
    return np.where(finite, np.sqrt(np.maximum(top, 0.0)), np.nan)


def contraction_batch(A_d: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``‖P^{1/2} A_d P^{-1/2}‖₂`` for a stack of ``A_d`` (numpy; :func:`nniquad.analysis.sampled.contraction`)."""
    Lt = np.swapaxes(np.linalg.cholesky(_sym(P)), -1, -2)  # P = L Lᵀ, ‖x‖_P = ‖Lᵀ x‖; P may be a stack
    M = Lt @ A_d @ np.linalg.inv(Lt)
    return spectral_norms(M)


@dataclass(frozen=True)
class RobustLyapunov:
    """A common Lyapunov matrix of the sampled cascade at the vertices of a box.

    Attributes
    ----------
    P : ndarray (n, n)
        ``P ≻ 0`` with ``A_d(v)ᵀ P A_d(v) ⪯ ρ² P`` at every vertex (original coordinates).
    rho
        The certified contraction factor per period at the vertices.
    rho_vertices : ndarray
        The numpy contraction factor ``‖P^{1/2} A_d(v) P^{-1/2}‖₂`` of each vertex (each <= ``rho``).
    spectral_radius
        Largest spectral radius over the vertices (the infimum of any common ``ρ``).
    T
        Sample period [s].
    decay_rate_1_s
        ``-ln ρ / T`` [1/s].
    min_eig_P
        Smallest over largest eigenvalue of ``P``.
    ok
        ``P ≻ 0`` and every vertex contracts by at most ``ρ < 1`` (numpy).
    """

    P: np.ndarray
    rho: float
    rho_vertices: np.ndarray
    spectral_radius: float
    T: float
    decay_rate_1_s: float
    min_eig_P: float
    status: str
    ok: bool


def robust_lyapunov(A_v: np.ndarray, T: float, *, S: np.ndarray | None = None, theta: np.ndarray | None = None,
                    rtol: float = CASCADE_LYAPUNOV_RTOL, max_iter: int = 8) -> RobustLyapunov:
    """Common ``P`` with ``A_vᵀ P A_v ⪯ ρ² P`` at every vertex, smallest ``ρ`` by :func:`best_decay` (Clarabel).

    Posed for ``P̃ = Sᵀ P S`` (``S`` the well-scaled coordinates of the nominal
    loop, :func:`nniquad.analysis.sampled.conditioning_transform`), with
    ``I ⪯ P̃ ⪯ t I`` and ``t`` minimised; the answer is re-checked with numpy
    in the original coordinates, and the stated ``ρ`` is the largest numpy
    contraction over the points (:func:`nniquad.analysis.sampled.best_decay`:
    the decay ``1 - rtol`` of the spectral bound first, then a bisection).

    Parameters
    ----------
    A_v : array (n_v, n, n)
        The vertex loops.
    T
        Sample period [s].
    S
        Coordinates of the LMI (default: those of ``A_v[0]``).

    Raises
    ------
    SolverError
        A vertex is unstable, or no ``ρ < 1`` is certified.
    """
    try:
        return _robust_lyapunov(A_v, T, S=S, theta=theta, rtol=rtol, max_iter=max_iter)
    except SolverError:
        if S is not None:
            raise
        # the modal coordinates of a loop with a measurement delay line can be too ill-conditioned for a witness
        # whose margins clear rounding: diagonal balancing instead (only where the modal answer failed)
        _, (scale, _) = sla.matrix_balance(np.asarray(A_v, float)[0], permute=False, separate=True)
        return _robust_lyapunov(A_v, T, S=np.diag(scale), theta=theta, rtol=rtol, max_iter=max_iter)


def _robust_lyapunov(A_v: np.ndarray, T: float, *, S: np.ndarray | None, theta: np.ndarray | None, rtol: float,
                     max_iter: int) -> RobustLyapunov:
    """:func:`robust_lyapunov` in the coordinates ``S`` (``None``: :func:`conditioning_transform` of ``A_v[0]``)."""
    A_v = np.asarray(A_v, float)
    nv, n = A_v.shape[0], A_v.shape[1]
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_v))))
    if not rho_spec < 1.0:
        raise SolverError(f"robust cascade LMI: a vertex of the box is unstable (spectral radius {rho_spec:.6g})")
    S = conditioning_transform(A_v[0]) if S is None else S
    Sinv = np.linalg.inv(S)
    Ab = Sinv @ A_v @ S
    th = np.zeros((nv, 0)) if theta is None else np.asarray(theta, float).reshape(nv, -1)
    E = sym_basis(n)
    corners, at_points = _affine_weights(th)
    # P(θ) is affine, so P ⪰ I and P ⪯ t I at the corners of the θ-cube hold on the whole cube
    P_corner = _affine_terms(corners, E)
    eye = np.broadcast_to(np.eye(n), (len(corners), n, n))
    AEA = _congruences(Ab, E)

    def solve(rho: float) -> tuple[float, tuple[np.ndarray, np.ndarray, str]] | None:
        prob = ConicProblem()
        iP, it = prob.variables(P_corner.shape[1]), prob.variables(1)
        prob.psd(-eye, iP, P_corner)
        prob.psd(np.zeros_like(eye), np.concatenate([iP, it]),
                 np.concatenate([-P_corner, eye[:, None]], axis=1))
        _add_decrease(prob, iP, at_points, E, AEA, rho)
        got = _solved_affine(prob, it, iP, E, Sinv, A_v, th)
        return None if got is None else (float(np.max(got[1])), got)

    best = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=max_iter)
    if best is None:
        raise SolverError(f"robust cascade LMI: no common P for any decay in (0, {-math.log(rho_spec) / T:.4g}) 1/s")
    rho, (P, rv, status) = best
    wm = witness_margins(P, A_v, th)
    if not wm.ok:  # a witness whose margins do not clear rounding is refused, not stated
        raise SolverError(f"robust cascade LMI: the answer's margins do not clear rounding (1 - rho = "
                          f"{1 - wm.rho:.3g} vs bound {wm.rho_bound:.3g}; min eig {wm.definite:.3g} vs "
                          f"{wm.definite_bound:.3g})")
    return RobustLyapunov(P=P, rho=wm.rho, rho_vertices=rv, spectral_radius=rho_spec, T=T,
                          decay_rate_1_s=-math.log(wm.rho) / T, min_eig_P=wm.min_eig_ratio, status=status, ok=True)


def _affine_weights(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The weights ``(1, θ_1, …, θ_q)`` of ``P_0, …, P_q`` at the corners of the θ-cube and at each point."""
    q = theta.shape[1]
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=q)), float).reshape(-1, q)
    return (np.concatenate([np.ones((len(corners), 1)), corners], axis=1),
            np.concatenate([np.ones((theta.shape[0], 1)), theta], axis=1))


def _affine_terms(weights: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Coefficient matrices of ``Σ_j w_j Σ_e z_je M_e`` at each row of ``weights`` ``(N, q+1)``.

    ``M`` is ``(n_E, m, m)``, or ``(N, n_E, m, m)`` per point; the answer is ``(N, (q+1) n_E, m, m)``, the
    coefficient of ``z_je`` (basis matrix ``e`` of ``P_j``) at index ``j n_E + e``."""
    M = np.broadcast_to(M, (weights.shape[0],) + np.shape(M)[-3:])
    N, nE, m = M.shape[0], M.shape[1], M.shape[-1]
    return (weights[:, :, None, None, None] * M[:, None]).reshape(N, weights.shape[1] * nE, m, m)


def _congruences(Ab: np.ndarray, E: np.ndarray) -> np.ndarray:
    """``Abᵢᵀ E_e Abᵢ`` for every point ``i`` and basis matrix ``e``, ``(N, n_E, n, n)``."""
    return np.einsum("nai,eab,nbj->neij", Ab, E, Ab)


def _add_decrease(prob: ConicProblem, iP: np.ndarray, at_points: np.ndarray, E: np.ndarray, AEA: np.ndarray,
                  rho: float) -> None:
    """The decrease ``ρ² P(θᵢ) - Abᵢᵀ P(θᵢ) Abᵢ ⪰ 0`` at every point (``AEA`` from :func:`_congruences`)."""
    n = E.shape[-1]
    prob.psd(np.zeros((AEA.shape[0], n, n)), iP, _affine_terms(at_points, rho * rho * E[None] - AEA))


#: Clarabel's relative gap and feasibility tolerance for :func:`reach_lyapunov`.  Its answer is a witness only if
#: numpy finds it contracting with margins above rounding (:func:`witness_margins`), so the solver's accuracy does not
#: decide; at 1e-8 the solve often ended ``AlmostSolved`` after Clarabel's whole iteration budget (5.6 s, against
#: 1.0 s at 1e-7, on the widened box of ``tests/test_cascade_roa.py``).
_REACH_SOLVER_TOL = 1e-7


def _solved_affine(prob: ConicProblem, it: np.ndarray, iP: np.ndarray, E: np.ndarray, Sinv: np.ndarray,
                   A_v: np.ndarray, theta: np.ndarray, tol: float = 1e-8) -> tuple[np.ndarray, np.ndarray, str] | None:
    """Minimise ``z[it]`` for an affine ``P(θ)`` posed in scaled coordinates, to Clarabel's tolerance ``tol``;
    ``(P_k stacked, contraction per point, status)``.

    The problem is handed to Clarabel directly (:class:`nniquad.analysis.cascade.conic.ConicProblem`): cvxpy took
    about 0.8 s to canonicalise each problem, a tenth of that per solve, three times the solves in all.  The
    answer is mapped back to the original coordinates and its contraction at every point computed with numpy;
    ``None`` when the solver fails or ``P(θ)`` is not positive definite at a point.
    """
    cost = np.zeros(prob.n)
    cost[it] = 1.0
    status, z = prob.solve(cost, tol=tol)
    if z is None:
        return None
    Pt = np.einsum("ke,eij->kij", z[iP].reshape(-1, E.shape[0]), E)
    Po = np.stack([_sym(Sinv.T @ _sym(V) @ Sinv) for V in Pt])
    try:
        return Po, contraction_batch(A_v, affine_in(Po, theta)), status
    except np.linalg.LinAlgError:  # P(θ) not positive definite at a point
        return None


def reach_lyapunov(A_v: np.ndarray, T: float, K: np.ndarray, L: float, rho: float, *,
                   theta: np.ndarray | None = None, eps: float = 1e-6,
                   start: np.ndarray | None = None) -> RobustLyapunov | None:
    """A horizontal axis's ``P(θ)`` with the widest linear-zone reach, at a given contraction ``rho``.

    The ellipsoid ``{xᵀ P(θ) x <= 1}`` lies where the tilt limit is inactive iff
    ``K P(θ)⁻¹ Kᵀ <= L²``, i.e. ``[[P(θ), Kᵀ], [K, L²]] ⪰ 0`` (Schur), which is
    linear in ``P``.  A start ``r e_0`` (position offset, all else at hover) is
    inside iff ``r² P(θ)_00 <= 1``, so the reach is widest when the largest
    ``P(θ)_00`` over the θ-cube (its corners: ``P`` is affine) is smallest.  That
    is minimised subject to the decrease ``A_vᵀ P A_v ⪯ ρ² P`` and ``P ⪰ eps I``
    at the LMI points (Clarabel, in diagonally balanced coordinates).
    The answer is re-checked with numpy in the original coordinates, and its
    stated ``ρ`` is its numpy contraction (:func:`robust_lyapunov`).

    Parameters
    ----------
    A_v : array (n_v, n, n)
        The loops at the LMI points.
    T
        Sample period [s].
    K : array (1, n)
        The axis's acceleration command ``a = K x`` before the tilt limit.
    L
        The tilt limit as an acceleration bound [m/s²].
    rho
        Target contraction per period (< 1).
    theta : array (n_v, q)
        The points' coordinates in the θ-cube.
    eps
        Smallest eigenvalue of ``P`` in the balanced coordinates.
    start : array (n,), optional
        The start per metre in place of ``e_0`` (its level ``startᵀ P(θ) start`` is minimised; a delay line
        starts full, :func:`nniquad.analysis.cascade.region.start_vector`).

    Returns
    -------
    RobustLyapunov or None
        ``None`` when the solver fails or its answer does not contract (< 1) with ``P ≻ 0``.
    """
    A_v = np.asarray(A_v, float)
    nv, n = A_v.shape[0], A_v.shape[1]
    th = np.zeros((nv, 0)) if theta is None else np.asarray(theta, float).reshape(nv, -1)
    _, (scale, _) = sla.matrix_balance(A_v[0], permute=False, separate=True)
    S, Sinv = np.diag(scale), np.diag(1.0 / scale)
    Ab = Sinv @ A_v @ S
    KS = np.asarray(K, float).reshape(1, n) @ S
    e0 = Sinv[:, 0] if start is None else Sinv @ np.asarray(start, float)  # x_0 = r e_0 in the balanced coordinates
    E = sym_basis(n)
    corners, at_points = _affine_weights(th)
    prob = ConicProblem()
    iP, top = prob.variables(corners.shape[1] * E.shape[0]), prob.variables(1)
    prob.psd(np.broadcast_to(-eps * np.eye(n), (len(corners), n, n)), iP, _affine_terms(corners, E))
    e0E = np.einsum("i,eij,j->e", e0, E, e0)  # e0ᵀ P(corner) e0 <= top
    prob.nonnegative(np.zeros(len(corners)), np.concatenate([iP, top]),
                     np.concatenate([-(corners[:, :, None] * e0E[None, None]).reshape(len(corners), -1),
                                     np.ones((len(corners), 1))], axis=1))
    _add_decrease(prob, iP, at_points, E, _congruences(Ab, E), rho)
    # [[P(θ), Kᵀ], [K, L²]] ⪰ 0: the ellipsoid lies where the tilt limit is inactive
    F0 = np.zeros((n + 1, n + 1))
    F0[:n, n], F0[n, :n], F0[n, n] = KS[0], KS[0], L * L
    Eb = np.zeros((E.shape[0], n + 1, n + 1))
    Eb[:, :n, :n] = E
    prob.psd(np.broadcast_to(F0, (nv, n + 1, n + 1)), iP, _affine_terms(at_points, Eb))
    solved = _solved_affine(prob, top, iP, E, Sinv, A_v, th, tol=_REACH_SOLVER_TOL)
    if solved is None:
        return None
    Po, rv, status = solved
    wm = witness_margins(Po, A_v, th)
    if not wm.ok:  # no contraction, or margins below rounding: not a witness
        return None
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_v))))
    return RobustLyapunov(P=Po, rho=wm.rho, rho_vertices=rv, spectral_radius=rho_spec, T=T,
                          decay_rate_1_s=-math.log(wm.rho) / T, min_eig_P=wm.min_eig_ratio, status=status, ok=True)


def affine_in(Pk: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``P(θ) = P_0 + Σ θ_j P_j`` for every row of ``theta`` (``Pk`` stacked ``(q + 1, n, n)``)."""
    theta = np.atleast_2d(theta)
    return Pk[0][None] + np.einsum("ij,jkl->ikl", theta, Pk[1:]) if Pk.shape[0] > 1 else \
        np.broadcast_to(Pk[0], (theta.shape[0],) + Pk.shape[1:])


@dataclass(frozen=True)
class WitnessMargins:
    """What an affine ``P(θ)`` certifies at the LMI points, with the rounding bound of each strict inequality.

    Attributes
    ----------
    rho
        Largest numpy contraction ``‖P(θ)^{1/2} A(θ) P(θ)^{-1/2}‖₂`` over the points (``inf``: ``P`` not
        positive definite at a point).
    rho_bound
        Largest rounding bound of that contraction over the points
        (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    definite
        Smallest eigenvalue of the diagonally scaled ``P(θ)`` over the corners of the θ-cube (``P`` is affine,
        so ``P ≻ 0`` there holds on the whole cube).
    definite_bound
        Its rounding bound (:func:`nniquad.analysis.lmi.checks.definite_margin`).
    min_eig_ratio
        Smallest ``λ_min / λ_max`` of ``P(θ)`` over the corners (unscaled; a record of the conditioning).
    rho_all : ndarray
        The contraction at every point.
    """

    rho: float
    rho_bound: float
    definite: float
    definite_bound: float
    min_eig_ratio: float
    rho_all: np.ndarray

    @property
    def ok(self) -> bool:
        """``ρ < 1`` and ``P ≻ 0``, each with a margin above its rounding bound."""
        return bool(self.rho < 1.0 and 1.0 - self.rho > self.rho_bound and self.definite > self.definite_bound)


def witness_margins(Pk: np.ndarray, A_v: np.ndarray, theta: np.ndarray) -> WitnessMargins:
    """:class:`WitnessMargins` of ``P(θ) = P_0 + Σ θ_j P_j`` for the loops ``A_v`` at the points ``theta`` (numpy)."""
    Pk = np.asarray(Pk, float)
    th = np.atleast_2d(np.asarray(theta, float)).reshape(A_v.shape[0], -1)
    q = th.shape[1]
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=q)), float).reshape(-1, q)
    Pc = affine_in(Pk, corners)
    lam, lam_bound = lmi_checks.definite_margin(Pc)
    ev = np.linalg.eigvalsh(_sym(Pc))
    ratio = float(np.min(ev[:, 0] / ev[:, -1]))
    P = affine_in(Pk, th)
    try:
        rv = contraction_batch(A_v, P)
    except np.linalg.LinAlgError:  # P(θ) not positive definite at a point
        return WitnessMargins(math.inf, math.inf, float(np.min(lam)), float(np.max(lam_bound)), ratio, np.array([]))
    bound = lmi_checks.contraction_rounding_bound(A_v, P, rv)
    return WitnessMargins(rho=float(np.max(rv)), rho_bound=float(np.max(bound)), definite=float(np.min(lam)),
                          definite_bound=float(np.max(lam_bound)), min_eig_ratio=ratio, rho_all=rv)


@dataclass(frozen=True)
class GridCheck:
    """The numpy check of a Lyapunov matrix on a grid inside the box (covers the grid points only).

    Attributes
    ----------
    size
        Number of grid points.
    points_per_axis
        Grid points per coordinate.
    worst_rho
        Largest contraction factor ``‖P^{1/2} A_d(θ) P^{-1/2}‖₂`` over the grid.
    worst_margin
        ``1 - worst_rho`` (positive: ``P`` decreases at every grid point).
    worst_point
        A point where ``worst_rho`` is attained (many points may tie to rounding: a check compares the value
        at a stated point, never which of the tied points an argmax picks).
    worst_spectral_radius
        Largest spectral radius of ``A_d`` over the grid (at most the contraction: implied by ``rho < 1``).
    worst_spectral_point
        A point where it is attained.
    rounding_bound
        Largest rounding bound of the contraction over the grid
        (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    margin_over_bound
        Smallest ``(1 - rho) / bound`` over the grid: ``rho < 1`` is certified at every point iff it exceeds 1.
    rho_all, spectral_all : ndarray
        The contraction and the spectral radius at every grid point (not serialised).
    """

    size: int
    points_per_axis: int
    worst_rho: float
    worst_margin: float
    worst_point: tuple[float, ...]
    worst_spectral_radius: float
    worst_spectral_point: tuple[float, ...]
    rounding_bound: float = math.nan
    margin_over_bound: float = math.nan
    rho_all: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)
    spectral_all: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False, compare=False)

    @property
    def ok(self) -> bool:
        """Every grid point contracts with a margin above rounding (and so has spectral radius < 1)."""
        return bool(self.worst_rho < 1.0 and self.worst_spectral_radius < 1.0 and self.margin_over_bound > 1.0)

    def to_json(self) -> dict[str, Any]:
        return {"size": self.size, "points_per_axis": self.points_per_axis, "worst_rho": self.worst_rho,
                "worst_margin": self.worst_margin, "worst_point": dict(zip(POINT_NAMES, self.worst_point)),
                "worst_spectral_radius": self.worst_spectral_radius,
                "worst_spectral_point": dict(zip(POINT_NAMES, self.worst_spectral_point)),
                "rounding_bound": self.rounding_bound, "margin_over_bound": self.margin_over_bound, "ok": self.ok}


def checked_grid_size(value: object) -> int:
    """``value`` as the grid check's points per coordinate: an integer from 2 to the configured limit.

    The one rule shared by ``certify`` and ``verify``: a grid of ``n`` points per coordinate has ``n**6``
    points, so a re-signed certificate must not be able to ask for an unbounded one.

    Raises
    ------
    CascadeError
        ``value`` is not an ``int`` (a ``bool`` or a float is refused too) or lies outside 2 to
        :data:`nniquad.config.CASCADE_GRID_MAX_POINTS_PER_AXIS`.
    """
    if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= CASCADE_GRID_MAX_POINTS_PER_AXIS:
        raise CascadeError(f"grid.points_per_axis must be an integer from 2 to {CASCADE_GRID_MAX_POINTS_PER_AXIS}, "
                           f"got {value!r}")
    return value


def grid_check(family: CascadeFamily, P: np.ndarray, points_per_axis: int) -> GridCheck:
    """Contraction factor of ``P`` and spectral radius at every point of ``family`` (numpy).

    The vertex LMIs of :func:`robust_lyapunov` do not extend to the interior of
    the box (``A_d`` is not affine in the parameters); this check covers the
    grid points, and only them.  Each point's ``1 - rho`` is compared with its
    rounding bound (:func:`nniquad.analysis.lmi.checks.contraction_rounding_bound`).
    """
    rho = contraction_batch(family.A_d, P)
    sr = family.spectral_radius
    bound = np.asarray(lmi_checks.contraction_rounding_bound(family.A_d, P, rho), float).reshape(rho.shape)
    i, j = int(np.argmax(rho)), int(np.argmax(sr))
    return GridCheck(size=len(family), points_per_axis=int(points_per_axis), worst_rho=float(rho[i]),
                     worst_margin=float(1.0 - rho[i]), worst_point=tuple(float(v) for v in family.points[i]),
                     worst_spectral_radius=float(sr[j]), worst_spectral_point=tuple(float(v) for v in family.points[j]),
                     rounding_bound=float(np.max(bound)), margin_over_bound=float(np.min((1.0 - rho) / bound)),
                     rho_all=rho, spectral_all=np.asarray(sr, float))


def point_index(points: np.ndarray, point: Sequence[float], rtol: float = 1e-9) -> int | None:
    """Index of ``point`` among the rows of ``points`` (within ``rtol``, relative), or ``None``."""
    p = np.asarray(point, float).reshape(1, -1)
    if p.shape[1] != points.shape[1] or not np.all(np.isfinite(p)):
        return None
    hit = np.flatnonzero(np.all(np.abs(points - p) <= rtol * np.abs(p), axis=1))
    return int(hit[0]) if hit.size else None


def assemble_P(lyap: Mapping[str, RobustLyapunov], dims: Mapping[str, Sequence[int]], box: ParameterBox,
                points: np.ndarray, state_names: Sequence[str], frame: str) -> np.ndarray:
    """The full Lyapunov matrix ``T_mᵀ diag(P_x, P_y, P_alt, P_yaw)(θ) T_m`` at every point (``frame``: the
    vehicle's rotor layout, :func:`mode_transform`)."""
    Tm, _ = mode_transform(state_names, frame)
    n = Tm.shape[0]
    Pz = np.zeros((points.shape[0], n, n))
    for name, sl in subsystem_blocks(state_names).items():
        Pz[:, sl, sl] = affine_in(lyap[name].P, normalised_coordinates(box, points, dims[name]))
    return Tm.T @ Pz @ Tm


def mirror_blocks(x: tuple, y: tuple, rtol: float = 1e-6) -> np.ndarray | None:
    """Signs ``d`` with ``A_y ≈ D A_x D`` and ``K_y ≈ K_x D`` (``D = diag(d)``) at every LMI point, or ``None``.

    A vehicle with equal roll and pitch data has mirrored x and y blocks (roll and
    pitch move the position with opposite signs; the linearisation leaves
    differences of about 1e-10); then ``D P_x D`` is a candidate Lyapunov matrix
    of y, which :func:`mirrored_blocks` re-checks with numpy on y's own loops, so
    ``rtol`` only decides whether the candidate is tried.
    """
    (Ax, Kx, thx), (Ay, Ky, thy) = x, y
    if Ax.shape != Ay.shape or thx.shape != thy.shape or not np.allclose(thx, thy, rtol=0, atol=1e-15):
        return None
    tol = rtol * max(float(np.max(np.abs(Ax))), 1.0)
    for signs in itertools.product((1.0, -1.0), repeat=Ax.shape[1] - 1):
        d = np.array((1.0,) + signs)
        if np.max(np.abs(Ay - d[:, None] * Ax * d[None, :])) <= tol and np.max(np.abs(Ky - Kx * d)) <= tol:
            return d
    return None


def mirrored_blocks(lx: RobustLyapunov, d: np.ndarray, A_v: np.ndarray, theta: np.ndarray) -> RobustLyapunov | None:
    """``D P_x(θ) D`` as y's Lyapunov matrix, its contraction re-checked with numpy on y's loops (``None``: it fails)."""
    P = d[None, :, None] * lx.P * d[None, None, :]
    wm = witness_margins(P, A_v, theta)
    if not wm.ok:
        return None
    return replace(lx, P=P, rho=wm.rho, rho_vertices=wm.rho_all,
                   spectral_radius=float(np.max(np.abs(np.linalg.eigvals(A_v)))),
                   decay_rate_1_s=-math.log(wm.rho) / lx.T, min_eig_P=wm.min_eig_ratio,
                   status=f"mirrored from x ({lx.status})")


def block_loops(fam: CascadeFamily, box: ParameterBox, pts: Mapping[str, np.ndarray],
                 dims: Mapping[str, Sequence[int]]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each subsystem's loops ``A`` at its LMI points and their θ coordinates, from a family stacked as
    ``[nominal, LMI points of each subsystem in SUBSYSTEMS order, ...]``."""
    out, k = {}, 1
    for name in SUBSYSTEMS:
        m = pts[name].shape[0]
        out[name] = (subsystem_of(fam, name)[0][k:k + m], normalised_coordinates(box, pts[name], dims[name]))
        k += m
    return out
