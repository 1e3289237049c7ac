"""Closed-loop decay LMIs: the nominal loop, and every true mass in an interval.

The LMIs are posed in a diagonally scaled state ``x = T x~`` (the loop's ``axis_scaling``: for the
NNI law ``diag(1, sqrt(kp), Γ)``, the velocity in units of the inner loop's natural frequency and the
controller state in units of Γ); without it the fast controller pole next to the slow, lightly
damped pair makes Clarabel stall on infeasible instances.  A congruence, so it changes no answer:
``P = T^{-T} P~ T^{-1}``.  The loop is a :class:`nniquad.analysis.reduced_loop.ReducedLoop` of any law of
the NI structure.

``P > 0``, ``A' P + P A <= -eps P`` with ``eps`` maximised by bisection; the
robust versions use one common ``P`` or a parameter-dependent ``P(1/m)``.  Every
answer is re-checked with :func:`nniquad.analysis.lmi.checks.certified_rate`:
the reported rate is what numpy verifies the returned ``P`` certifies.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.solver import LMIResult, cpsym, solve, solved
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.errors import SolverError, VehicleError

__all__ = ["closed_loop_decay", "robust_mass_decay"]


def _cp():
    import cvxpy as cp

    return cp


def _bisect(prob, eps, recheck, eps_max: float, name: str, rtol: float):
    """Geometric bisection on the cvxpy parameter ``eps`` in ``[1e-6 eps_max, eps_max]``.

    ``recheck(eps_value)`` re-checks the solver's matrices with numpy and returns
    them (dict) or ``None``.  Returns ``(status at eps_min, eps, matrices, solves)``.
    """

    def attempt(value: float, first: bool = False):
        # Ask the solver for a little more than ``value`` (0.2 % plus 1e-6 eps_max) so that
        # its answer, re-checked by numpy, certifies ``value`` despite solver tolerances.
        eps.value = 1.002 * value + 1e-6 * eps_max
        try:
            status = solve(prob, name)
        except SolverError:
            # Near or above the supremum the problem is ill-posed and Clarabel may give
            # up; inside the bisection that only means "not certified at this eps"
            # (conservative).  At eps_min a failure is a real failure and propagates.
            if first:
                raise
            return "solver_error", None
        if not solved(status):
            return status, None
        return status, recheck(value)

    lo = 1e-6 * eps_max
    status, mats = attempt(lo, first=True)
    solves = 1
    if mats is None:
        return status, 0.0, None, solves
    hi = eps_max
    while hi / lo > 1.0 + rtol:
        mid = math.sqrt(lo * hi)
        _, m_mid = attempt(mid)
        solves += 1
        if m_mid is None:
            hi = mid
        else:
            lo, mats = mid, m_mid
    return status, lo, mats, solves


def _trace_bound(As: Sequence[np.ndarray]) -> float:
    """A-priori bound ``eps <= -2 tr(A)/n`` (multiply ``A'P + PA + eps P <= 0`` by ``P^{-1}``, take the trace)."""
    return min(-2.0 * float(np.trace(A)) / A.shape[0] for A in As)


def _common_decay(As: Sequence[np.ndarray], T: np.ndarray, name: str, rtol: float):
    """Largest eps with one ``P > 0``: ``A_i' P + P A_i <= -eps P`` at every vertex ``A_i``."""
    cp = _cp()
    n = As[0].shape[0]
    Ti = np.linalg.inv(T)
    At = [Ti @ A @ T for A in As]
    eps_max = _trace_bound(As)
    if eps_max <= 0:
        return cp.INFEASIBLE, 0.0, None, 0
    Pt = cp.Variable((n, n), symmetric=True, name="P_scaled")
    eps = cp.Parameter(nonneg=True, name="eps")
    cons = [Pt >> np.eye(n)] + [cpsym(A.T @ Pt + Pt @ A) + eps * Pt << 0 for A in At]
    prob = cp.Problem(cp.Minimize(cp.trace(Pt)), cons)

    def recheck(value: float):
        P_s = K.sym(Pt.value)
        if K.eigmin(P_s) < 1 - 1e-6:
            return None
        # numpy: the rate this P really certifies (scale-free); it must reach the target
        rate = min(K.certified_rate(A, P_s) for A in At)
        if rate < value:
            return None
        P = K.sym(Ti.T @ P_s @ Ti)
        return {"P": P, "_min_eig_P": K.eigmin(P), "_rate": rate}

    return _bisect(prob, eps, recheck, eps_max, name, rtol)


def _pdlf_decay(A_lo: np.ndarray, A_hi: np.ndarray, th_lo: float, th_hi: float, T: np.ndarray, name: str, rtol: float):
    """Largest eps with an affine ``P(theta) = P0 + theta P1`` on ``A(theta)`` affine in theta.

    Vertex conditions plus the multiconvexity condition ``A1' P1 + P1 A1 >= 0``
    (Gahinet, Apkarian & Chilali, IEEE TAC 41(3), 1996, recalled): the Lyapunov
    expression is then a convex quadratic in theta, so its vertices bound it.
    Valid for a constant unknown mass (not for a time-varying one).
    """
    cp = _cp()
    n = A_lo.shape[0]
    Ti = np.linalg.inv(T)
    Al, Ah = Ti @ A_lo @ T, Ti @ A_hi @ T
    A1 = (Ah - Al) / (th_hi - th_lo)
    eps_max = _trace_bound([A_lo, A_hi])
    if eps_max <= 0:
        return cp.INFEASIBLE, 0.0, None, 0
    P0 = cp.Variable((n, n), symmetric=True, name="P0_scaled")
    P1 = cp.Variable((n, n), symmetric=True, name="P1_scaled")
    eps = cp.Parameter(nonneg=True, name="eps")
    cons = [cpsym(A1.T @ P1 + P1 @ A1) >> 0]
    for th, A in ((th_lo, Al), (th_hi, Ah)):
        P = P0 + th * P1
        cons += [P >> np.eye(n), cpsym(A.T @ P + P @ A) + eps * P << 0]
    prob = cp.Problem(cp.Minimize(cp.trace(2 * P0 + (th_lo + th_hi) * P1)), cons)

    def recheck(value: float):
        p0, p1 = K.sym(P0.value), K.sym(P1.value)
        if K.eigmin(A1.T @ p1 + p1 @ A1) < -K.RTOL * K.norm(A1) * K.norm(p1):
            return None
        # independent of the convexity argument: the rate P(theta) certifies on a grid, with numpy
        min_eig, rate = math.inf, math.inf
        for th in np.linspace(th_lo, th_hi, 41):
            A, P = Al + (th - th_lo) * A1, p0 + th * p1
            if K.eigmin(P) <= 0:
                return None
            rate = min(rate, K.certified_rate(A, P))
            min_eig = min(min_eig, K.eigmin(Ti.T @ P @ Ti))
        if rate < value:
            return None
        return {"P0": K.sym(Ti.T @ p0 @ Ti), "P1": K.sym(Ti.T @ p1 @ Ti), "_min_eig_P": min_eig, "_rate": rate}

    return _bisect(prob, eps, recheck, eps_max, name, rtol)


def _pole_decay(As: Sequence[np.ndarray]) -> float:
    """``-2 max Re(lambda)`` over the matrices, from numpy eigenvalues (1/s)."""
    return min(-2.0 * float(np.max(np.linalg.eigvals(A).real)) for A in As)


def _combine_axes(name: str, per_axis: list[tuple[str, tuple]], note: str, values: dict[str, float]) -> LMIResult:
    """One result from per-axis bisections: feasible iff every axis is; eps = the smallest."""
    mats: dict[str, np.ndarray] = {}
    feasible, eps_all, status_all, solves, min_eig = True, math.inf, "optimal", 0, math.inf
    for label, (status, eps, m, k) in per_axis:
        solves += k
        if m is None:
            feasible, status_all = False, status
            eps_all = 0.0
            continue
        # report what numpy verifies the returned P certifies, not the bisection's target
        eps_all = min(eps_all, float(m["_rate"]))
        suffix = "" if len(per_axis) == 1 else f"_{label}"
        min_eig = min(min_eig, float(m["_min_eig_P"]))
        mats.update({f"{key}{suffix}": v for key, v in m.items() if not key.startswith("_")})
    values = {"decay_rate": eps_all if feasible else 0.0, **values, "solves": float(solves)}
    res: dict[str, float] = {}
    if feasible:
        res["min_eig_P"] = min_eig  # absolute, in the original coordinates (P is not normalised there)
    else:
        note += f"; not certified: solver status {status_all!r} at eps_min (or the numpy re-check failed)"
    return LMIResult(name, feasible, status_all, mats, res, values["decay_rate"], K.RTOL, note, values)


def closed_loop_decay(loop: ReducedLoop, rtol: float = 1e-3, name: str = "closed_loop_decay") -> LMIResult:
    """Closed-loop Lyapunov certificate with the largest decay rate.

    Solves ``P > 0``, ``A_cl' P + P A_cl <= -eps P`` per axis (the axes are
    decoupled, so a block-diagonal P loses nothing) and bisects on ``eps``
    (relative resolution ``rtol``).  The supremum of feasible ``eps`` is
    ``-2 max Re(lambda(A_cl))``: the inequality says ``A_cl + eps/2 I`` is
    Lyapunov stable, i.e. every eigenvalue has ``Re lambda <= -eps/2``; conversely
    below that value the Lyapunov equation of ``A_cl + eps/2 I`` has a positive
    definite solution.  ``V = x'Px`` then decays at least like ``exp(-eps t)``.

    Parameters
    ----------
    loop
        The reduced loop (its mass model is used as it is).
    rtol
        Relative resolution of the bisection on ``eps``.
    name
        Name of the result.

    Returns
    -------
    LMIResult
        ``feasible`` iff some ``eps >= 1e-6 eps_max`` is certified for every axis,
        where ``eps_max = -2 tr(A_cl)/3`` (a-priori bound).  ``margin`` =
        ``values['decay_rate']`` = certified eps (1/s); ``values['decay_rate_poles']``
        = ``-2 max Re(lambda)`` from numpy eigenvalues, for comparison.
    """
    per_axis = []
    As = []
    for label, kp in loop.axes:
        A = loop.closed_loop_A_axis(label)
        As.append(A)
        per_axis.append((label, _common_decay([A], loop.axis_scaling(label), name, rtol)))
    note = f"P>0, A'P+PA <= -eps P per axis, eps maximised by bisection (rel. {rtol:g}); margin = eps (1/s)"
    return _combine_axes(name, per_axis, note, {"decay_rate_poles": _pole_decay(As), "decay_rate_trace_bound": _trace_bound(As)})


def robust_mass_decay(loop: ReducedLoop, m_lo: float, m_hi: float, *, parameter_dependent: bool = False,
                      thrust_model: bool = False, rtol: float = 1e-3, name: str | None = None) -> LMIResult:
    """Lyapunov certificate for every true mass in ``[m_lo, m_hi]``.

    The closed-loop matrix depends on the mass only through ``1/m`` (the
    controller and the inner gain do not contain m), so it is affine in
    ``theta = 1/m`` and the interval is the segment between the vertices
    ``A_cl(m_lo)`` and ``A_cl(m_hi)``.

    * ``parameter_dependent=False`` (the quadratic-stability test): one common P
      at both vertices, which holds on the whole segment by convexity.  Sufficient
      only; for this lightly damped loop it fails already for small intervals,
      because the slow pair's frequency moves with m.
    * ``parameter_dependent=True``: ``P(theta) = P0 + theta P1`` with the
      multiconvexity condition (see :func:`_pdlf_decay`); valid for a constant
      unknown mass and far less conservative.

    Two mass models (:meth:`ReducedLoop.with_mass`): ``thrust_model=False`` is the
    paper's reduced equation, where the loop is stable iff ``m kp delta > 1``, so
    ``values['m_min_exact'] = 1/(kp_min delta)`` and nothing can be certified when
    ``m_lo`` is not above it.  With ``thrust_model=True`` (thrust sized with the
    nominal mass ``loop.m``, as in :mod:`nniquad.sim`) the characteristic
    polynomial is ``s^3 + G d s^2 + kp (mn/m) s + G (kp mn d - 1)/m``: stable for
    every true mass iff ``mn kp delta > 1`` (``m_min_exact`` = 0 then, inf
    otherwise); the mass only changes the decay rate.

    Parameters
    ----------
    loop
        The nominal loop (its gains; with ``thrust_model`` also its mass).
    m_lo, m_hi
        The true-mass interval [kg], ``0 < m_lo <= m_hi``.
    parameter_dependent
        Use ``P(1/m)`` instead of one common P.
    thrust_model
        Thrust sized with the nominal mass (see above).
    rtol
        Relative resolution of the bisection.
    name
        Name of the result (default from the options).

    Raises
    ------
    GainError
        If the mass interval is not ``0 < m_lo <= m_hi`` (finite).
    """
    kind = ("pdlf" if parameter_dependent else "common_P") + (",thrust_model" if thrust_model else "")
    name = name or f"robust_mass_decay[{kind}]"
    m_lo, m_hi = float(m_lo), float(m_hi)
    if not (math.isfinite(m_lo) and math.isfinite(m_hi) and 0 < m_lo <= m_hi):
        raise VehicleError(f"mass range must satisfy 0 < m_lo <= m_hi, got [{m_lo}, {m_hi}]")
    per_axis, As = [], []
    for label, kp in loop.axes:
        A_lo = loop.with_mass(m_lo, thrust_model=thrust_model).closed_loop_A_axis(label)
        A_hi = loop.with_mass(m_hi, thrust_model=thrust_model).closed_loop_A_axis(label)
        As += [A_lo, A_hi]
        T = loop.axis_scaling(label)
        if parameter_dependent and m_hi > m_lo:
            out = _pdlf_decay(A_hi, A_lo, 1.0 / m_hi, 1.0 / m_lo, T, name, rtol)
        else:
            out = _common_decay([A_lo, A_hi], T, name, rtol)
        per_axis.append((label, out))
    grid = 1.0 / np.linspace(1.0 / m_hi, 1.0 / m_lo, 41)
    pointwise = _pole_decay([loop.with_mass(mm, thrust_model=thrust_model).closed_loop_A_axis(label)
                             for mm in grid for label, _ in loop.axes])
    if not thrust_model:
        m_min = loop.min_stable_mass()
    else:
        m_min = 0.0 if loop.stable else math.inf
    values = {"m_lo": m_lo, "m_hi": m_hi, "m_min_exact": m_min,
              "decay_rate_poles_vertices": _pole_decay(As), "decay_rate_poles_pointwise_min": pointwise}
    how = "P(theta)=P0+theta P1, theta=1/m, multiconvex" if parameter_dependent else "one common P at both vertices"
    model = f"thrust sized with nominal {loop.m:g} kg" if thrust_model else "paper model (kp exact)"
    note = (f"true mass in [{m_lo:g}, {m_hi:g}] kg, {model}, A_cl affine in 1/m; {how}; "
            f"A'P+PA <= -eps P, eps maximised by bisection; margin = eps (1/s)")
    return _combine_axes(name, per_axis, note, values)
