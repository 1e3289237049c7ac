"""The discrete-time Lyapunov certificate of a sampled loop: ``A_dᵀ P A_d ⪯ ρ² P``, ``P ≻ 0``.

For a sampled loop ``x_{k+1} = A_d x_k`` (:mod:`nniquad.analysis.sampled`), an
LMI in ``P`` is solved for the smallest ``ρ`` it can (:func:`best_decay`, cvxpy
+ Clarabel), so that ``‖x_k‖_P <= ρ^k ‖x_0‖_P``: a decay rate ``-ln ρ / T``
[1/s].  The answer is re-checked with numpy: the eigenvalues of ``P`` and
``ρ_P = ‖P^{1/2} A_d P^{-1/2}‖₂`` (:func:`contraction`, the exact contraction
factor of ``P``), which must not exceed the stated ``ρ``.  The robust cascade
certificate (:mod:`nniquad.analysis.cascade`) solves its LMIs with the same
decay search and Clarabel call.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, Callable, TypeVar

import numpy as np
import scipy.linalg as sla

from nniquad.errors import SolverError

__all__ = ["DiscreteDecay", "contraction", "best_decay", "solve_with_clarabel", "discrete_lyapunov_decay"]


@dataclass(frozen=True)
class DiscreteDecay:
    """A discrete-time Lyapunov certificate ``A_dᵀ P A_d ⪯ ρ² P``, ``P ≻ 0``.

    Attributes
    ----------
    P : ndarray
        The Lyapunov matrix (original coordinates).
    rho
        Certified contraction factor per period (numpy re-check ``rho_numpy <= rho``).
    rho_numpy
        ``‖P^{1/2} A_d P^{-1/2}‖₂``, the exact contraction of ``‖x‖_P`` in one period.
    spectral_radius
        ``max |eig(A_d)|``, the infimum of every certifiable ``ρ``.
    T
        Sample period [s].
    decay_rate_1_s
        ``-ln(rho)/T`` [1/s]: ``‖x(kT)‖_P <= e^{-rate kT} ‖x(0)‖_P``.
    min_eig_P
        Smallest eigenvalue of ``P`` (relative to its largest): must be positive.
    status
        Solver status of the last feasible solve.
    ok
        ``P ≻ 0`` and ``rho_numpy <= rho < 1`` (re-checked with numpy).
    """

    P: np.ndarray
    rho: float
    rho_numpy: float
    spectral_radius: float
    T: float
    decay_rate_1_s: float
    min_eig_P: float
    status: str
    ok: bool

    def to_json(self) -> dict[str, Any]:
        return {"rho": self.rho, "rho_numpy": self.rho_numpy, "spectral_radius": self.spectral_radius,
                "period_s": self.T, "rate_hz": 1.0 / self.T, "decay_rate_1_s": self.decay_rate_1_s,
                "min_eig_P_relative": self.min_eig_P, "status": self.status, "ok": self.ok,
                "P": self.P.tolist()}


def contraction(A_d: np.ndarray, P: np.ndarray) -> float:
    """``‖P^{1/2} A_d P^{-1/2}‖₂``: the factor by which one period shrinks ``‖x‖_P`` at most (numpy)."""
    Ls = np.linalg.cholesky(0.5 * (P + P.T))  # P = L Lᵀ, ‖x‖_P = ‖Lᵀ x‖
    M = Ls.T @ A_d @ np.linalg.inv(Ls.T)
    return float(np.linalg.norm(M, 2))


def conditioning_transform(A: np.ndarray, max_cond: float = 1e8) -> np.ndarray:
    """A similarity ``S`` that makes ``S^{-1} A S`` well scaled for the SDP solver.

    The real modal form (scipy ``cdf2rdf`` of the eigenvectors) when its basis is
    well conditioned: there ``P = I`` nearly certifies the spectral radius, so
    the solver works near a well-scaled optimum.  Otherwise diagonal balancing
    (scipy ``matrix_balance``).  Any invertible ``S`` gives a valid certificate
    in the original coordinates; the numpy re-check is done there.
    """
    w, V = np.linalg.eig(A)
    try:
        _, Vr = sla.cdf2rdf(w, V)
        if np.linalg.cond(Vr) < max_cond:
            return np.real(Vr)
    except (ValueError, np.linalg.LinAlgError):
        pass
    _, (scale, _) = sla.matrix_balance(A, permute=False, separate=True)
    return np.diag(scale)


def solve_with_clarabel(prob: Any, var: Any) -> str | None:
    """Solve a cvxpy problem with Clarabel: its status when (inaccurately) optimal and ``var`` has a value, else ``None``.

    Every answer is re-checked with numpy by the caller, so an inaccurate optimum is offered, not trusted.
    """
    import cvxpy as cp

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or var.value is None:
        return None
    return str(prob.status)


_Answer = TypeVar("_Answer")


def best_decay(solve: Callable[[float], tuple[float, _Answer] | None], rho_spec: float, T: float, *,
               rtol: float, max_iter: int) -> tuple[float, _Answer] | None:
    """The best certified contraction of a Lyapunov LMI family ``A_dᵀ P A_d ⪯ ρ² P`` (one search for every LMI here).

    ``solve(rho)`` solves the LMI for the target ``rho`` and returns
    ``(rho_numpy, answer)``: the contraction the answer achieves, re-checked
    with numpy, or ``None`` when the solver fails.  Any ``rho_numpy < 1`` is a
    certificate, whether it meets the target or not, and the smallest one seen
    is returned: near the spectral radius the solver often stops just short of
    the target yet beats every target a bisection would reach later.

    The decay ``(1 - rtol)`` of the spectral bound ``-ln(rho_spec)/T`` is tried
    first.  If its target is missed and no answer came back, the decay ``rtol``
    times the bound is tried (the slowest worth stating: a miss there ends the
    search).  The target decay is then bisected between the best decay
    achieved so far and the first target (at most ``max_iter`` solves), until
    that bracket is within ``rtol``.

    Parameters
    ----------
    solve
        ``solve(rho_target) -> (rho_numpy, answer) | None``.
    rho_spec
        The largest spectral radius of the loops (the infimum of any certified ``rho``), ``< 1``.
    T
        Sample period [s].
    rtol
        Relative accuracy of the decay rate ``-ln(rho)/T``.
    max_iter
        Bisection solves at most.

    Returns
    -------
    (rho, answer) or None
        ``None``: no solve gave a contraction below 1.
    """
    best: tuple[float, _Answer] | None = None

    def met(lam: float) -> bool:
        nonlocal best
        target = math.exp(-lam * T)
        got = solve(target)
        if got is None or not got[0] < 1.0:
            return False
        if best is None or got[0] < best[0]:
            best = got
        return got[0] <= target * (1 + 1e-9)

    def achieved() -> float:
        return -math.log(best[0]) / T if best is not None else 0.0

    lam_spec = -math.log(rho_spec) / T
    hi = lam_spec * (1 - rtol)
    if met(hi):
        return best
    if best is None:
        # the slowest decay worth stating: if even it is missed the LMI is (nearly) infeasible and a
        # bisection would only repeat failing solves
        if not met(lam_spec * rtol):
            return best
    lo = achieved()  # a certificate exists at the decay achieved so far: search above it only
    for _ in range(max_iter):
        if hi - lo <= rtol * hi:
            break
        mid = 0.5 * (lo + hi)
        lo, hi = (max(mid, achieved()), hi) if met(mid) else (lo, mid)
    return best


def discrete_lyapunov_decay(A_d: np.ndarray, T: float, *, rtol: float = 1e-3, max_iter: int = 40) -> DiscreteDecay:
    """Largest certified decay of ``x_{k+1} = A_d x_k``: the LMI ``A_dᵀ P A_d ⪯ ρ² P``, ``I ⪯ P``.

    For a fixed ``ρ`` the LMI is solved (cvxpy + Clarabel, minimising the
    condition bound ``t`` with ``P ⪯ t I``); the target ``ρ`` is searched by
    :func:`best_decay` between the spectral radius (the infimum) and 1, and the
    stated ``ρ`` is the numpy contraction of the best answer.  The LMI is posed in well-scaled
    coordinates (:func:`conditioning_transform`) because the cascade mixes
    metres, radians and rotor speeds of ~10³ rad/s.

    Parameters
    ----------
    A_d
        Discrete closed-loop matrix.
    T
        Sample period [s].
    rtol
        Relative accuracy of the decay rate.
    max_iter
        Bisection steps at most.

    Returns
    -------
    DiscreteDecay

    Raises
    ------
    SolverError
        Unstable ``A_d`` (no certificate exists) or no feasible solve.
    """
    import cvxpy as cp

    A_d = np.asarray(A_d, float)
    n = A_d.shape[0]
    rho_spec = float(np.max(np.abs(np.linalg.eigvals(A_d))))
    if not rho_spec < 1.0:
        raise SolverError(f"discrete Lyapunov LMI: the sampled loop is unstable (spectral radius {rho_spec:.6g})")
    S = conditioning_transform(A_d)  # A_d = S Ab S^{-1}
    Ab = np.linalg.solve(S, A_d @ S)
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    rho2 = cp.Parameter(nonneg=True)
    Pm = 0.5 * (P + P.T)
    cons = [Pm >> np.eye(n), Pm << t * np.eye(n),
            rho2 * Pm - Ab.T @ Pm @ Ab >> 0]
    prob = cp.Problem(cp.Minimize(t), cons)
    Sinv = np.linalg.inv(S)

    def solve(rho: float) -> tuple[float, np.ndarray] | None:
        rho2.value = rho * rho
        if solve_with_clarabel(prob, P) is None:
            return None
        Pb = 0.5 * (P.value + P.value.T)
        Po = Sinv.T @ Pb @ Sinv  # xᵀ P x = (S^{-1} x)ᵀ Pb (S^{-1} x)
        Po = 0.5 * (Po + Po.T)
        try:
            return contraction(A_d, Po), Po
        except np.linalg.LinAlgError:  # not positive definite
            return None

    lam_spec = -math.log(rho_spec) / T
    best = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=max_iter)
    if best is None:
        raise SolverError(f"discrete Lyapunov LMI: no feasible P for any decay in (0, {lam_spec:.4g}) 1/s")
    rho, Pbest = best
    rho_num = contraction(A_d, Pbest)
    ev = np.linalg.eigvalsh(Pbest)
    min_rel = float(ev[0] / ev[-1])
    ok = bool(min_rel > 0 and rho_num <= rho * (1 + 1e-9) and rho < 1)
    return DiscreteDecay(P=Pbest, rho=rho, rho_numpy=rho_num, spectral_radius=rho_spec, T=T,
                         decay_rate_1_s=-math.log(rho) / T, min_eig_P=min_rel, status=str(prob.status), ok=ok)
