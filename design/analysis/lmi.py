"""LMIs of the NI design: NI / SNI lemmas, closed-loop Lyapunov, robust and saturated versions.

Every function builds a cvxpy problem with symmetric matrix variables, solves it
with Clarabel (``solver=cp.CLARABEL``), checks ``problem.status`` against
cvxpy's status constants and then **re-checks the returned matrices with numpy**
(eigenvalues, residual norms) against the tolerance it reports.  The answer is
an :class:`LMIResult`.

* Infeasibility is a legitimate answer: ``feasible=False`` and ``status`` is the
  solver's status string (``'infeasible'``).
* A solver crash, an ``'unbounded'`` status or non-finite data raise
  :class:`nniquad.errors.SolverError`; nothing returns a silent ``None``.
* If the solver says ``'optimal'`` but the numpy re-check fails, the result is
  ``feasible=False`` with a note saying so; the solver's word alone never
  certifies anything.

Which NI lemma?
---------------
The NI dissipation inequality for ``V = x^T P x / 2`` is ``dV/dt <= ydot^T u``.
Along ``x' = Ax + Bu``, ``y = Cx`` (D = 0):

.. math::

    \\dot V - \\dot y^T u = \\tfrac12 [x; u]^T
    \\begin{bmatrix} PA + A^TP & PB - A^TC^T \\\\ B^TP - CA & -(CB + B^TC^T) \\end{bmatrix}
    [x; u],

so the dissipation inequality holds for all ``(x, u)`` iff that block matrix is
negative semidefinite.  This is the NI lemma in the form used by the NI
literature (Xiong, Petersen & Lanzon, IEEE TAC 55(10), 2010, and Mabrok,
Kallapur, Petersen & Lanzon, IEEE TAC 59(10), 2014: ``D = D^T`` and ``P >= 0``
with the block matrix ``= -[L W]^T [L W]``; quoted from the statement reproduced
on the Wikipedia page "Negative imaginary systems", which cites those papers).
When ``CB = 0`` (the reshaped plant) it reduces to ``PA + A^TP <= 0`` and
``PB = A^T C^T``.

The paper's Lemma ``lem:time_domain_NI`` states instead ``PA + A^TP <= 0``,
``PB = C^T`` -- the positive-real (KYP) lemma equality, which certifies
``dV/dt <= y^T u`` (passivity), not ``dV/dt <= ydot^T u``.  On the reshaped plant
it forces ``P_22 = 0`` and is infeasible; on the controller it is feasible
(``P = 1/Gamma``) but the storage it returns violates the NI dissipation
inequality unless ``Gamma delta = 1`` (see :func:`ni_lemma_paper`, residual
``ni_dissipation_max_eig``).

The Lanzon & Petersen (IEEE TAC 53(4), 2008) form -- ``det A != 0``, ``Y > 0``,
``AY + YA^T <= 0``, ``B + AYC^T = 0`` -- and its strict (SNI) version with
``AY + YA^T < 0`` are implemented from memory of those papers (not quoted); they
agree with the dissipation form on this loop (``Y = P^{-1}``), which the tests
check.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from nniquad.errors import GainError, SolverError
from nniquad.analysis.linear import closed_loop_A_axis, controller_matrices, plant_matrices, saturation_split
from nniquad.control.gains import Gains, PAPER_GAINS

__all__ = [
    "LMIResult",
    "ni_lemma_paper",
    "ni_lemma_dissipation",
    "ni_lemma_lanzon_petersen",
    "sni_lemma",
    "ni_dissipation_strict",
    "ni_dissipation_matrix",
    "closed_loop_decay",
    "robust_mass_decay",
    "axis_acceleration_limit",
    "start_certified",
    "region_of_attraction",
    "run_all",
    "RTOL",
]

#: Relative tolerance of every numpy re-check (residuals are divided by the data's scale).
RTOL = 1e-6


# ----------------------------------------------------------------------------- result


@dataclass
class LMIResult:
    """Answer of one LMI, with the independent numpy re-check.

    Attributes
    ----------
    name
        Identifier of the LMI (e.g. ``'ni_lemma_paper[plant]'``).
    feasible
        True only if the solver returned a solution *and* the numpy re-check passed.
    status
        cvxpy's status string (``'optimal'``, ``'infeasible'``, ...).
    matrices
        Returned matrices (``P``, ``Y``, the data ``A``, ...), as numpy arrays.
    residuals
        Independent re-check quantities (relative, dimensionless unless the key says otherwise).
    margin
        The strictness margin achieved (its meaning is stated in ``note``).
    tolerance
        The relative tolerance the residuals were checked against.
    note
        What was solved, what the margin means, and anything the reader must know.
    values
        Named scalar results (decay rates in 1/s, displacement in m, ...).
    """

    name: str
    feasible: bool
    status: str
    matrices: dict[str, np.ndarray]
    residuals: dict[str, float]
    margin: float
    tolerance: float
    note: str = ""
    values: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dictionary (matrices as nested lists, non-finite numbers as strings)."""

        def num(x: float) -> float | str:
            x = float(x)
            return x if math.isfinite(x) else str(x)

        return {
            "name": self.name,
            "feasible": bool(self.feasible),
            "status": self.status,
            "margin": num(self.margin),
            "tolerance": self.tolerance,
            "residuals": {k: num(v) for k, v in self.residuals.items()},
            "values": {k: num(v) for k, v in self.values.items()},
            "matrices": {k: np.asarray(v, dtype=float).tolist() for k, v in self.matrices.items()},
            "note": self.note,
        }


# ----------------------------------------------------------------------------- helpers


def _cp():
    import cvxpy as cp

    return cp


def _as_data(name: str, **arrays: Any) -> dict[str, np.ndarray]:
    """Arrays as 2-D floats; non-finite entries raise :class:`SolverError`."""
    out = {}
    for key, value in arrays.items():
        a = np.atleast_2d(np.asarray(value, dtype=float))
        if not np.all(np.isfinite(a)):
            raise SolverError(f"{name}: data matrix {key} has non-finite entries (NaN or inf); nothing was solved")
        out[key] = a
    return out


def _solve(problem, name: str) -> str:
    """Solve with Clarabel; return the status, or raise :class:`SolverError` for failures."""
    cp = _cp()
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate": handled below by the numpy re-check, not by a warning.
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError as exc:
        raise SolverError(f"{name}: Clarabel failed ({exc})") from None
    except (ValueError, ArithmeticError) as exc:  # cvxpy rejects NaN parameters this way
        raise SolverError(f"{name}: problem data rejected ({exc})") from None
    status = problem.status
    if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
        raise SolverError(f"{name}: problem is {status}; the LMI is mis-posed (missing normalisation)")
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE, cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise SolverError(f"{name}: Clarabel stopped with status {status!r}")
    return status


def _solved(status: str) -> bool:
    cp = _cp()
    return status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + M.T)


def _eigmin(M: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(_sym(M))[0])


def _eigmax(M: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(_sym(M))[-1])


def _norm(*Ms: np.ndarray) -> float:
    return max(float(np.linalg.norm(M, 2)) for M in Ms)


def _cpsym(X):
    """Symmetric part of a cvxpy expression (PSD constraints need a symmetric argument)."""
    return 0.5 * (X + X.T)


def ni_dissipation_matrix(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """``[[PA + A^T P, PB - A^T C^T], [B^T P - CA, -(CB + B^T C^T)]]``.

    ``dV/dt - ydot^T u = [x; u]^T M [x; u] / 2`` for ``V = x^T P x / 2``; the NI
    dissipation inequality holds iff this matrix is negative semidefinite.
    """
    top = np.hstack([P @ A + A.T @ P, P @ B - A.T @ C.T])
    bottom = np.hstack([B.T @ P - C @ A, -(C @ B + B.T @ C.T)])
    return np.vstack([top, bottom])


def _dissipation_residual(P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> float:
    """Largest eigenvalue of :func:`ni_dissipation_matrix`, relative to its scale (<= ~0 for an NI storage)."""
    M = ni_dissipation_matrix(P, A, B, C)
    return _eigmax(M) / max(_norm(P) * _norm(A), _norm(A) * _norm(C) * _norm(B), _norm(C) * _norm(B), 1e-300)


def _result_fail(name, status, data, note, tol, **kw) -> LMIResult:
    return LMIResult(name=name, feasible=False, status=status, matrices=data, residuals={}, margin=float("nan"),
                     tolerance=tol, note=note, **kw)


# ----------------------------------------------------------------------------- 1. NI lemma as the paper states it


def ni_lemma_paper(A, B, C, name: str = "ni_lemma_paper") -> LMIResult:
    """The paper's Lemma ``lem:time_domain_NI``: ``P > 0``, ``PA + A^TP <= 0``, ``PB = C^T``.

    ``P > 0`` is imposed as ``P >= t I`` with ``t >= 1e-6 * |C|/|B|`` (the scale
    that the equality gives P) and ``t`` maximised (capped at ``1e3 |C|/|B|``).

    Returns
    -------
    LMIResult
        ``margin`` = the smallest eigenvalue of P achieved.  Residuals:
        ``min_eig_P`` (relative to |P|), ``lyapunov_max_eig`` (max eig of
        ``PA + A^TP`` relative to |P||A|), ``equality`` (``|PB - C^T| / |C|``)
        and ``ni_dissipation_max_eig``: whether the returned storage satisfies the
        NI inequality ``dV/dt <= ydot^T u`` (it need not: this is the passivity
        equality).
    """
    cp = _cp()
    d = _as_data(name, A=A, B=B, C=C)
    A, B, C = d["A"], d["B"], d["C"]
    n = A.shape[0]
    scale = _norm(C) / _norm(B)
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    P = cp.Variable((n, n), symmetric=True, name="P")
    t = cp.Variable(name="t")
    cons = [P - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, _cpsym(P @ A + A.T @ P) << 0, P @ B == C.T]
    prob = cp.Problem(cp.Maximize(t), cons)
    status = _solve(prob, name)
    note = ("paper's Lemma: P>0, PA+A'P<=0, PB=C' (the positive-real lemma equality: it certifies "
            "dV/dt <= y'u, not the NI inequality dV/dt <= ydot'u); margin = min eig P")
    if not _solved(status):
        return _result_fail(name, status, {"A": A, "B": B, "C": C}, note + f"; solver: {status}", RTOL)
    Pv = _sym(P.value)
    res = {
        "min_eig_P": _eigmin(Pv) / _norm(Pv),
        "lyapunov_max_eig": _eigmax(Pv @ A + A.T @ Pv) / (_norm(Pv) * _norm(A)),
        "equality": float(np.linalg.norm(Pv @ B - C.T)) / _norm(C),
        "ni_dissipation_max_eig": _dissipation_residual(Pv, A, B, C),
    }
    ok = res["min_eig_P"] > 0.5 * t_min / _norm(Pv) and res["lyapunov_max_eig"] <= RTOL and res["equality"] <= RTOL
    if ok and res["ni_dissipation_max_eig"] > RTOL:
        note += "; the returned P does NOT satisfy dV/dt <= ydot'u (ni_dissipation_max_eig > 0)"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"P": Pv, "A": A, "B": B, "C": C}, res, _eigmin(Pv), RTOL, note)


# ----------------------------------------------------------------------------- 2. NI lemma as the literature states it


def ni_lemma_dissipation(A, B, C, D=None, name: str = "ni_lemma_dissipation") -> LMIResult:
    """NI lemma in dissipation (KYP) form: ``D = D^T``, ``P > 0``, :func:`ni_dissipation_matrix` ``<= 0``.

    This is the statement of Xiong, Petersen & Lanzon (2010) / Mabrok et al. (2014)
    (see the module docstring), i.e. exactly ``dV/dt <= ydot^T u`` for
    ``V = x^T P x / 2``.  For ``CB = 0`` it is ``PA + A^TP <= 0``, ``PB = A^TC^T``.
    ``P > 0`` is imposed as ``P >= t I``, ``t >= 1e-6 |A||C|/|B|``, ``t`` maximised.

    Returns
    -------
    LMIResult
        ``margin`` = min eig P.  Residuals: ``min_eig_P``, ``dissipation_max_eig``
        (relative), ``equality_PB_AtCt`` (``|PB - A^TC^T|`` relative; zero is forced
        only when ``CB = 0``), ``D_asymmetry``.
    """
    cp = _cp()
    d = _as_data(name, A=A, B=B, C=C, D=np.zeros((np.atleast_2d(C).shape[0],) * 2) if D is None else D)
    A, B, C, Dm = d["A"], d["B"], d["C"], d["D"]
    n, k = A.shape[0], B.shape[1]
    asym = float(np.linalg.norm(Dm - Dm.T))
    note = ("NI lemma, dissipation form (Xiong-Petersen-Lanzon 2010): D=D', P>0, "
            "[[PA+A'P, PB-A'C'],[B'P-CA, -(CB+B'C')]] <= 0, i.e. dV/dt <= ydot'u; margin = min eig P")
    if asym > RTOL * max(1.0, _norm(Dm)):
        return _result_fail(name, "not_solved", {"A": A, "B": B, "C": C, "D": Dm}, note + "; D is not symmetric", RTOL)
    scale = _norm(A) * _norm(C) / _norm(B)
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    P = cp.Variable((n, n), symmetric=True, name="P")
    t = cp.Variable(name="t")
    M = cp.bmat([[P @ A + A.T @ P, P @ B - A.T @ C.T], [B.T @ P - C @ A, -(C @ B + B.T @ C.T)]])
    cons = [P - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, _cpsym(M) << 0]
    status = _solve(cp.Problem(cp.Maximize(t), cons), name)
    data = {"A": A, "B": B, "C": C, "D": Dm}
    if not _solved(status):
        return _result_fail(name, status, data, note + f"; solver: {status}", RTOL)
    Pv = _sym(P.value)
    res = {
        "min_eig_P": _eigmin(Pv) / _norm(Pv),
        "dissipation_max_eig": _dissipation_residual(Pv, A, B, C),
        "equality_PB_AtCt": float(np.linalg.norm(Pv @ B - A.T @ C.T)) / max(_norm(A.T @ C.T), 1e-300),
        "D_asymmetry": asym,
    }
    ok = res["min_eig_P"] > 0.5 * t_min / _norm(Pv) and res["dissipation_max_eig"] <= RTOL
    if np.allclose(C @ B, 0.0, atol=RTOL * _norm(C) * _norm(B)):
        ok = ok and res["equality_PB_AtCt"] <= RTOL
        note += "; CB = 0 so the block reduces to PA+A'P<=0, PB=A'C'"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    if t.value is not None and t.value >= 0.999 * t_cap:
        note += "; margin hit its cap"
    return LMIResult(name, ok, status, {"P": Pv, **data}, res, _eigmin(Pv), RTOL, note)


def ni_lemma_lanzon_petersen(A, B, C, D=None, name: str = "ni_lemma_lanzon_petersen") -> LMIResult:
    """NI lemma in the Lanzon & Petersen (2008) form, recalled (not quoted):

    ``det A != 0``, ``D = D^T`` and ``Y = Y^T > 0`` with ``AY + YA^T <= 0`` and
    ``B + AYC^T = 0``.  On this loop ``Y`` is the inverse of the dissipation-form
    ``P`` (the tests check ``Y P = I``).

    Returns
    -------
    LMIResult
        ``margin`` = min eig Y; residuals ``min_eig_Y``, ``lyapunov_max_eig``
        (``AY + YA^T``), ``equality`` (``|B + AYC^T| / |B|``), ``det_A_relative``.
    """
    cp = _cp()
    d = _as_data(name, A=A, B=B, C=C, D=np.zeros((np.atleast_2d(C).shape[0],) * 2) if D is None else D)
    A, B, C, Dm = d["A"], d["B"], d["C"], d["D"]
    n = A.shape[0]
    data = {"A": A, "B": B, "C": C, "D": Dm}
    note = "NI lemma, Lanzon-Petersen 2008 form (recalled): det A != 0, Y>0, AY+YA'<=0, B+AYC'=0; margin = min eig Y"
    sv = np.linalg.svd(A, compute_uv=False)
    det_rel = float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0
    if det_rel < 1e-12 or np.linalg.norm(Dm - Dm.T) > RTOL * max(1.0, _norm(Dm)):
        return _result_fail(name, "not_solved", data, note + "; premise fails (A singular or D not symmetric)", RTOL)
    scale = _norm(B) / (_norm(A) * _norm(C))
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    Y = cp.Variable((n, n), symmetric=True, name="Y")
    t = cp.Variable(name="t")
    cons = [Y - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, _cpsym(A @ Y + Y @ A.T) << 0, B + A @ Y @ C.T == 0]
    status = _solve(cp.Problem(cp.Maximize(t), cons), name)
    if not _solved(status):
        return _result_fail(name, status, data, note + f"; solver: {status}", RTOL)
    Yv = _sym(Y.value)
    res = {
        "min_eig_Y": _eigmin(Yv) / _norm(Yv),
        "lyapunov_max_eig": _eigmax(A @ Yv + Yv @ A.T) / (_norm(Yv) * _norm(A)),
        "equality": float(np.linalg.norm(B + A @ Yv @ C.T)) / _norm(B),
        "det_A_relative": det_rel,
    }
    ok = res["min_eig_Y"] > 0.5 * t_min / _norm(Yv) and res["lyapunov_max_eig"] <= RTOL and res["equality"] <= RTOL
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"Y": Yv, **data}, res, _eigmin(Yv), RTOL, note)


# ----------------------------------------------------------------------------- 3. strict versions


def sni_lemma(A, B, C, D=None, name: str = "sni_lemma") -> LMIResult:
    """Strict (SNI) version of the Lanzon-Petersen form, recalled (not quoted):

    ``Y > 0``, ``AY + YA^T < 0`` (imposed as ``<= -s I``, ``s >= 1e-6 |B|/|C|``,
    ``s`` maximised) and ``B + AYC^T = 0``.  It implies A Hurwitz; as recalled, the
    SNI lemma also needs a rank condition on ``G(s) - G(-s)^T`` on the imaginary
    axis, which :func:`nniquad.analysis.frequency.sni_check` verifies at definition level.

    Returns
    -------
    LMIResult
        ``margin`` = ``s``, the strictness of ``AY + YA^T < 0``.
    """
    cp = _cp()
    d = _as_data(name, A=A, B=B, C=C, D=np.zeros((np.atleast_2d(C).shape[0],) * 2) if D is None else D)
    A, B, C, Dm = d["A"], d["B"], d["C"], d["D"]
    n = A.shape[0]
    data = {"A": A, "B": B, "C": C, "D": Dm}
    note = "SNI lemma (recalled): Y>0, AY+YA' < 0, B+AYC'=0; margin s with AY+YA' <= -s I"
    yscale = _norm(B) / (_norm(A) * _norm(C))
    sscale = _norm(B) / _norm(C)
    Y = cp.Variable((n, n), symmetric=True, name="Y")
    s = cp.Variable(name="s")
    cons = [Y >> 1e-6 * yscale * np.eye(n), _cpsym(A @ Y + Y @ A.T) + s * np.eye(n) << 0,
            s >= 1e-6 * sscale, s <= 1e3 * sscale, B + A @ Y @ C.T == 0]
    status = _solve(cp.Problem(cp.Maximize(s), cons), name)
    if not _solved(status):
        return _result_fail(name, status, data, note + f"; solver: {status}", RTOL)
    Yv = _sym(Y.value)
    lyap = _eigmax(A @ Yv + Yv @ A.T)
    res = {
        "min_eig_Y": _eigmin(Yv) / _norm(Yv),
        "lyapunov_max_eig": lyap / (_norm(Yv) * _norm(A)),
        "equality": float(np.linalg.norm(B + A @ Yv @ C.T)) / _norm(B),
    }
    ok = res["min_eig_Y"] > 0 and lyap < 0 and res["equality"] <= RTOL
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"Y": Yv, **data}, res, -lyap, RTOL, note)


def ni_dissipation_strict(A, B, C, name: str = "ni_dissipation_strict") -> LMIResult:
    """Strict dissipation: ``P > 0`` and :func:`ni_dissipation_matrix` ``<= -eta I``, ``eta > 0``.

    This asks for ``dV/dt - ydot^T u <= -eta (|x|^2 + |u|^2)``.  For the
    controller the non-strict matrix has determinant ``-Gamma^2 (P - delta)^2 <= 0``
    for every scalar P, so it is infeasible: the SNI strictness lives in
    ``AY + YA^T < 0`` (state dissipation), not in the whole block.
    """
    cp = _cp()
    d = _as_data(name, A=A, B=B, C=C)
    A, B, C = d["A"], d["B"], d["C"]
    n, k = A.shape[0], B.shape[1]
    scale = _norm(A) * _norm(C) / _norm(B)
    escale = _norm(C) * _norm(B)
    P = cp.Variable((n, n), symmetric=True, name="P")
    eta = cp.Variable(name="eta")
    M = cp.bmat([[P @ A + A.T @ P, P @ B - A.T @ C.T], [B.T @ P - C @ A, -(C @ B + B.T @ C.T)]])
    cons = [P >> 1e-6 * scale * np.eye(n), _cpsym(M) + eta * np.eye(n + k) << 0, eta >= 1e-6 * escale, eta <= 1e3 * escale]
    status = _solve(cp.Problem(cp.Maximize(eta), cons), name)
    data = {"A": A, "B": B, "C": C}
    note = "strict NI dissipation: P>0 and [[PA+A'P, PB-A'C'],[B'P-CA, -(CB+B'C')]] <= -eta I, eta>0"
    if not _solved(status):
        return _result_fail(name, status, data, note + f"; solver: {status}", RTOL)
    Pv = _sym(P.value)
    top = _eigmax(ni_dissipation_matrix(Pv, A, B, C))
    res = {"min_eig_P": _eigmin(Pv) / _norm(Pv), "dissipation_max_eig": top / escale}
    ok = res["min_eig_P"] > 0 and top < 0
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"P": Pv, **data}, res, -top, RTOL, note)


# ----------------------------------------------------------------------------- 4./5. closed-loop decay rate


def _axis_scaling(kp: float, Gamma: float) -> np.ndarray:
    """Diagonal state scaling ``x = T x~`` used inside the decay LMIs of one axis.

    ``T = diag(1, sqrt(kp), Gamma)`` measures the velocity in units of the inner
    loop's natural frequency and the controller state in units of Γ; without it
    the fast controller pole (-Γδ) next to the slow, lightly damped pair makes
    Clarabel stall on infeasible instances.  A congruence, so it changes no answer:
    ``P = T^{-T} P~ T^{-1}``.
    """
    return np.diag([1.0, math.sqrt(kp), Gamma])


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
            status = _solve(prob, name)
        except SolverError:
            # Near or above the supremum the problem is ill-posed and Clarabel may give
            # up; inside the bisection that only means "not certified at this eps"
            # (conservative).  At eps_min a failure is a real failure and propagates.
            if first:
                raise
            return "solver_error", None
        if not _solved(status):
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


def _certified_rate(A: np.ndarray, P: np.ndarray) -> float:
    """The decay rate a given ``P > 0`` certifies for ``A``, computed with numpy (scale-free).

    The largest eps with ``A'P + PA <= -eps P`` is ``-lambda_max(L^{-1}(A'P + PA)L^{-T})``
    with ``P = L L'`` (a generalised symmetric eigenvalue problem).
    """
    Lc = np.linalg.cholesky(_sym(P))
    Li = np.linalg.inv(Lc)
    return -_eigmax(Li @ (A.T @ P + P @ A) @ Li.T)


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
    cons = [Pt >> np.eye(n)] + [_cpsym(A.T @ Pt + Pt @ A) + eps * Pt << 0 for A in At]
    prob = cp.Problem(cp.Minimize(cp.trace(Pt)), cons)

    def recheck(value: float):
        P_s = _sym(Pt.value)
        if _eigmin(P_s) < 1 - 1e-6:
            return None
        # numpy: the rate this P really certifies (scale-free); it must reach the target
        rate = min(_certified_rate(A, P_s) for A in At)
        if rate < value:
            return None
        P = _sym(Ti.T @ P_s @ Ti)
        return {"P": P, "_min_eig_P": _eigmin(P), "_rate": rate}

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
    cons = [_cpsym(A1.T @ P1 + P1 @ A1) >> 0]
    for th, A in ((th_lo, Al), (th_hi, Ah)):
        P = P0 + th * P1
        cons += [P >> np.eye(n), _cpsym(A.T @ P + P @ A) + eps * P << 0]
    prob = cp.Problem(cp.Minimize(cp.trace(2 * P0 + (th_lo + th_hi) * P1)), cons)

    def recheck(value: float):
        p0, p1 = _sym(P0.value), _sym(P1.value)
        if _eigmin(A1.T @ p1 + p1 @ A1) < -RTOL * _norm(A1) * _norm(p1):
            return None
        # independent of the convexity argument: the rate P(theta) certifies on a grid, with numpy
        min_eig, rate = math.inf, math.inf
        for th in np.linspace(th_lo, th_hi, 41):
            A, P = Al + (th - th_lo) * A1, p0 + th * p1
            if _eigmin(P) <= 0:
                return None
            rate = min(rate, _certified_rate(A, P))
            min_eig = min(min_eig, _eigmin(Ti.T @ P @ Ti))
        if rate < value:
            return None
        return {"P0": _sym(Ti.T @ p0 @ Ti), "P1": _sym(Ti.T @ p1 @ Ti), "_min_eig_P": min_eig, "_rate": rate}

    return _bisect(prob, eps, recheck, eps_max, name, rtol)


def _axes(gains: Gains) -> list[tuple[str, float]]:
    kpx, kpy = gains.axes()
    return [("x", kpx)] if kpx == kpy else [("x", kpx), ("y", kpy)]


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
    return LMIResult(name, feasible, status_all, mats, res, values["decay_rate"], RTOL, note, values)


def closed_loop_decay(m: float, gains: Gains = PAPER_GAINS, rtol: float = 1e-3, name: str = "closed_loop_decay") -> LMIResult:
    """Closed-loop Lyapunov certificate with the largest decay rate.

    Solves ``P > 0``, ``A_cl' P + P A_cl <= -eps P`` per axis (the axes are
    decoupled, so a block-diagonal P loses nothing) and bisects on ``eps``
    (relative resolution ``rtol``).  The supremum of feasible ``eps`` is
    ``-2 max Re(lambda(A_cl))``: the inequality says ``A_cl + eps/2 I`` is
    Lyapunov stable, i.e. every eigenvalue has ``Re lambda <= -eps/2``; conversely
    below that value the Lyapunov equation of ``A_cl + eps/2 I`` has a positive
    definite solution.  ``V = x'Px`` then decays at least like ``exp(-eps t)``.

    Returns
    -------
    LMIResult
        ``feasible`` iff some ``eps >= 1e-6 eps_max`` is certified for every axis,
        where ``eps_max = -2 tr(A_cl)/3`` (a-priori bound).  ``margin`` =
        ``values['decay_rate']`` = certified eps (1/s); ``values['decay_rate_poles']``
        = ``-2 max Re(lambda)`` from numpy eigenvalues, for comparison.
    """
    _as_data(name, m=np.array([m]))
    per_axis = []
    As = []
    for label, kp in _axes(gains):
        A = closed_loop_A_axis(m, kp, gains.Gamma, gains.delta)
        As.append(A)
        per_axis.append((label, _common_decay([A], _axis_scaling(kp, gains.Gamma), name, rtol)))
    note = f"P>0, A'P+PA <= -eps P per axis, eps maximised by bisection (rel. {rtol:g}); margin = eps (1/s)"
    return _combine_axes(name, per_axis, note, {"decay_rate_poles": _pole_decay(As), "decay_rate_trace_bound": _trace_bound(As)})


def _true_mass_A(m_true: float, kp: float, gains: Gains, m_nominal: float | None) -> np.ndarray:
    """Closed loop of one axis when the vehicle's true mass is ``m_true``.

    ``m_nominal=None``: the paper's reduced model (``kp`` an exact acceleration gain,
    only ``z/m`` sees the true mass): ``A_cl(m_true)``.  ``m_nominal`` given: the
    command ``a = -kp xi + z/m_nominal`` is realised by a thrust sized with the
    nominal mass, so the plant sees ``(m_nominal/m_true) a`` (the model of
    :mod:`nniquad.sim.simulate`): ``A0 + (m_nominal/m_true) B K`` from
    :func:`nniquad.analysis.linear.saturation_split` at ``m_nominal``.
    """
    if m_nominal is None:
        return closed_loop_A_axis(m_true, kp, gains.Gamma, gains.delta)
    A0, B, K = saturation_split(m_nominal, kp, gains.Gamma, gains.delta)
    return A0 + (m_nominal / m_true) * (B @ K)


def robust_mass_decay(m_lo: float, m_hi: float, gains: Gains = PAPER_GAINS, parameter_dependent: bool = False,
                      rtol: float = 1e-3, name: str | None = None, m_nominal: float | None = None) -> LMIResult:
    """Lyapunov certificate for every true mass in ``[m_lo, m_hi]``.

    The closed-loop matrix depends on the mass only through the entry ``1/m`` (the
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

    Two mass models (see :func:`_true_mass_A`): ``m_nominal=None`` is the paper's
    reduced equation, where the loop is stable iff ``m kp delta > 1``, so
    ``values['m_min_exact'] = 1/(kp_min delta)`` and nothing can be certified when
    ``m_lo`` is not above it.  With ``m_nominal`` (thrust sized with the nominal
    mass, as in :mod:`nniquad.sim.simulate`) the characteristic polynomial is
    ``s^3 + G d s^2 + kp (mn/m) s + G (kp mn d - 1)/m``: stable for every true
    mass iff ``mn kp delta > 1`` (``m_min_exact`` = 0 then, inf otherwise); the
    mass only changes the decay rate.  Either way the closed loop is affine in
    ``1/m``.
    """
    kind = ("pdlf" if parameter_dependent else "common_P") + ("" if m_nominal is None else ",thrust_model")
    name = name or f"robust_mass_decay[{kind}]"
    m_lo, m_hi = float(m_lo), float(m_hi)
    if not (math.isfinite(m_lo) and math.isfinite(m_hi) and 0 < m_lo <= m_hi):
        raise GainError(f"mass range must satisfy 0 < m_lo <= m_hi, got [{m_lo}, {m_hi}]")
    per_axis, As = [], []
    for label, kp in _axes(gains):
        A_lo = _true_mass_A(m_lo, kp, gains, m_nominal)
        A_hi = _true_mass_A(m_hi, kp, gains, m_nominal)
        As += [A_lo, A_hi]
        T = _axis_scaling(kp, gains.Gamma)
        if parameter_dependent and m_hi > m_lo:
            out = _pdlf_decay(A_hi, A_lo, 1.0 / m_hi, 1.0 / m_lo, T, name, rtol)
        else:
            out = _common_decay([A_lo, A_hi], T, name, rtol)
        per_axis.append((label, out))
    kmin = min(gains.axes())
    grid = 1.0 / np.linspace(1.0 / m_hi, 1.0 / m_lo, 41)
    pointwise = _pole_decay([_true_mass_A(mm, k, gains, m_nominal) for mm in grid for _, k in _axes(gains)])
    if m_nominal is None:
        m_min = 1.0 / (kmin * gains.delta)
    else:
        m_min = 0.0 if m_nominal * kmin * gains.delta > 1.0 else math.inf
    values = {"m_lo": m_lo, "m_hi": m_hi, "m_min_exact": m_min,
              "decay_rate_poles_vertices": _pole_decay(As), "decay_rate_poles_pointwise_min": pointwise}
    how = "P(theta)=P0+theta P1, theta=1/m, multiconvex" if parameter_dependent else "one common P at both vertices"
    model = "paper model (kp exact)" if m_nominal is None else f"thrust sized with nominal {m_nominal:g} kg"
    note = (f"true mass in [{m_lo:g}, {m_hi:g}] kg, {model}, A_cl affine in 1/m; {how}; "
            f"A'P+PA <= -eps P, eps maximised by bisection; margin = eps (1/s)")
    return _combine_axes(name, per_axis, note, values)


# ----------------------------------------------------------------------------- 6. region of attraction under saturation


def axis_acceleration_limit(g: float, tilt_limit_deg: float = 30.0, split: str = "norm") -> float:
    """Horizontal acceleration limit ``u0`` used in the region-of-attraction LMI (m/s^2).

    At tilt θ with the vertical thrust balancing gravity the horizontal
    acceleration is ``g tan θ``; the reduced model limits the *norm* of the
    2-D command, ``‖a_h‖ <= g tan θ``.

    * ``split='norm'`` (default) returns ``g tan θ``.  When both axes have the
      same gains the 2-D loop commutes with rotations of the horizontal plane,
      so a rotation-invariant ellipsoid ``P1 ⊗ I2`` loses nothing; the norm
      dead-zone ``ψ = a (1 - u0/‖a‖)_+`` satisfies ``ψ'(ψ - G x) <= 0`` whenever
      ``‖(K - G) x‖ <= u0`` (because ``a'(a - w) <= ‖a‖ ‖a - w‖``), and with a
      scalar multiplier every LMI reduces to the single-axis LMI with limit
      ``u0``.  The certified set is ``{x_x' P1 x_x + x_y' P1 x_y <= 1}``; from rest
      it contains every displacement of norm up to ``max_displacement_m``.
    * ``split='inscribed'`` returns ``g tan θ / sqrt(2)``: clipping each axis
      there keeps the vector inside the norm limit; used when the axes differ.
    * ``split='box'`` returns ``g tan θ`` per axis (a different, box-limited loop).
    """
    if not (0.0 < tilt_limit_deg < 90.0):
        raise GainError(f"tilt limit must be in (0, 90) degrees, got {tilt_limit_deg}")
    a = float(g) * math.tan(math.radians(tilt_limit_deg))
    if split == "inscribed":
        return a / math.sqrt(2.0)
    if split in ("box", "norm"):
        return a
    raise GainError(f"split must be 'norm', 'inscribed' or 'box', got {split!r}")


def start_certified(roa_results: Sequence[LMIResult], xi0: Sequence[float]) -> bool:
    """Whether the displacement ``xi0`` (m, from rest, controller state 0) lies in the certified region.

    One result (equal axis gains, norm model): ``‖xi0‖ <= max_displacement_m``.
    Two results (per-axis, inscribed box model): each coordinate within its axis's reach.
    """
    reach = [r.values.get("max_displacement_m", 0.0) if r.feasible else 0.0 for r in roa_results]
    if not reach:
        return False
    if len(reach) == 1:
        return math.hypot(*xi0) <= reach[0]
    return all(abs(v) <= rr for v, rr in zip(xi0, reach))


def region_of_attraction(m: float, kp: float, Gamma: float, delta: float, u0: float,
                         name: str = "region_of_attraction", r_cap: float = 1e4) -> LMIResult:
    """Certified ellipsoidal region of attraction of one axis under acceleration saturation.

    Model (one axis): ``x = [xi, xi_dot, z]``, ``x' = A0 x + B sat_u0(K x)`` with
    ``K x = -kp xi + z/m`` the acceleration command (:func:`nniquad.analysis.linear.saturation_split`).
    With the dead zone ``psi(v) = v - sat(v)``, ``x' = A_cl x - B psi(Kx)``.  The
    generalised sector condition (Tarbouriech, Garcia, Gomes da Silva & Queinnec,
    *Stability and Stabilization of Linear Systems with Saturating Actuators*,
    Springer 2011, Lemma 1.6 / Ch. 3): for x with ``|(K - G) x| <= u0``,
    ``psi' T (psi - G x) <= 0`` for any ``T > 0`` (diagonal).  With ``W = P^{-1}``,
    ``Z = G W``, ``S = T^{-1}`` the S-procedure gives the LMIs

    * ``[[A_cl W + W A_cl', -B S + Z'], [Z - S B', -2 S]] <= -eta I``  (decrease),
    * ``[[W, (K W - Z)'], [K W - Z, u0^2]] >= 0``  (ellipsoid inside the GSC region),
    * ``[[W, r e1], [r e1', 1]] >= 0``  (start ``x0 = [r, 0, 0]`` inside ``x'Px <= 1``),

    and ``r`` is maximised: the largest initial displacement from rest (with
    ``z(0) = 0``) that is certified to converge.

    Returns
    -------
    LMIResult
        ``matrices['P']`` the ellipsoid, ``values['max_displacement_m']`` = r (m),
        ``values['u0']`` the per-axis acceleration limit (m/s^2).
    """
    cp = _cp()
    A0, B, K = saturation_split(m, kp, Gamma, delta)
    A_cl = A0 + B @ K
    _as_data(name, A=A_cl, u0=np.array([u0]))
    if u0 <= 0:
        raise GainError(f"acceleration limit must be positive, got {u0}")
    n = 3
    e1 = np.zeros((n, 1))
    e1[0, 0] = 1.0
    W = cp.Variable((n, n), symmetric=True, name="W")
    Z = cp.Variable((1, n), name="Z")
    S = cp.Variable((1, 1), name="S")
    r = cp.Variable(name="r")
    eta = 1e-7
    dec = cp.bmat([[A_cl @ W + W @ A_cl.T, -B @ S + Z.T], [Z - S @ B.T, -2 * S]])
    inc = cp.bmat([[W, (K @ W - Z).T], [K @ W - Z, np.array([[u0**2]])]])
    start = cp.bmat([[W, r * e1], [r * e1.T, np.ones((1, 1))]])
    cons = [_cpsym(dec) << -eta * np.eye(n + 1), _cpsym(inc) >> 0, _cpsym(start) >> 0, S >= eta, r >= 0, r <= r_cap]
    status = _solve(cp.Problem(cp.Maximize(r), cons), name)
    data = {"A_cl": A_cl, "B": B, "K": K}
    note = (f"generalised sector condition, saturation at u0 = {u0:.4g} m/s^2; "
            "ellipsoid x'Px <= 1 invariant and attractive; margin = max initial displacement from rest (m)")
    if not _solved(status):
        return _result_fail(name, status, data, note + f"; solver: {status}", RTOL, values={"u0": u0})
    Wv, Zv, Sv, rv = _sym(W.value), np.asarray(Z.value), np.asarray(S.value), float(r.value)
    Pv = _sym(np.linalg.inv(Wv))
    Gv = Zv @ Pv
    # numpy re-check in the original (P, G, T) variables
    T = np.linalg.inv(Sv)
    dec_P = np.block([[A_cl.T @ Pv + Pv @ A_cl, -Pv @ B + Gv.T @ T], [-B.T @ Pv + T @ Gv, -2 * T]])
    x0 = rv * e1
    res = {
        "min_eig_W": _eigmin(Wv) / _norm(Wv),
        "decrease_max_eig_W": _eigmax(np.block([[A_cl @ Wv + Wv @ A_cl.T, -B @ Sv + Zv.T], [Zv - Sv @ B.T, -2 * Sv]])),
        "decrease_max_eig_P": _eigmax(dec_P) / _norm(dec_P),
        "inclusion_margin": float(u0**2 - ((K - Gv) @ Wv @ (K - Gv).T)[0, 0]) / u0**2,
        "x0_level": float((x0.T @ Pv @ x0)[0, 0]),
    }
    ok = (res["min_eig_W"] > 0 and res["decrease_max_eig_W"] < 0 and res["decrease_max_eig_P"] < 0
          and res["inclusion_margin"] >= -RTOL and res["x0_level"] <= 1 + 1e-5 and T[0, 0] > 0)
    if rv >= 0.999 * r_cap:
        note += "; displacement hit its cap"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    values = {"max_displacement_m": rv, "u0": u0}
    return LMIResult(name, ok, status, {"P": Pv, "W": Wv, "G": Gv, "T": T, **data}, res, rv, RTOL, note, values)


# ----------------------------------------------------------------------------- everything, for the CLI


def run_all(m: float, g: float, gains: Gains = PAPER_GAINS, mass_range: tuple[float, float] | None = None,
            tilt_limit_deg: float = 30.0) -> list[LMIResult]:
    """Every LMI of this module for one vehicle mass and gain set (what ``nniquad lmi`` prints).

    ``mass_range`` defaults to ``[0.8 m, 1.2 m]``; the robust LMIs are solved for
    both mass models of :func:`robust_mass_decay` (paper model, and thrust sized
    with the nominal mass ``m``).  Plant LMIs are solved per
    distinct ``kp``; the region of attraction with the norm limit of
    :func:`axis_acceleration_limit` when the axes share ``kp`` (rotation-invariant
    ellipsoid), else per axis with the inscribed per-axis limit.
    """
    results: list[LMIResult] = []
    kpx, kpy = gains.axes()
    axes = [("x", kpx)] if kpy == kpx else [("x", kpx), ("y", kpy)]
    Ac, Bc, Cc, _ = controller_matrices(gains.Gamma, gains.delta)
    for label, kp in axes:
        A, B, C, D = plant_matrices(m, kp)
        tag = "plant" if len(axes) == 1 else f"plant_{label}"
        results.append(ni_lemma_paper(A, B, C, name=f"ni_lemma_paper[{tag}]"))
        results.append(ni_lemma_dissipation(A, B, C, D, name=f"ni_lemma_dissipation[{tag}]"))
        results.append(ni_lemma_lanzon_petersen(A, B, C, D, name=f"ni_lemma_lanzon_petersen[{tag}]"))
        results.append(sni_lemma(A, B, C, D, name=f"sni_lemma[{tag}]"))
    results.append(ni_lemma_paper(Ac, Bc, Cc, name="ni_lemma_paper[controller]"))
    results.append(ni_lemma_dissipation(Ac, Bc, Cc, name="ni_lemma_dissipation[controller]"))
    results.append(ni_lemma_lanzon_petersen(Ac, Bc, Cc, name="ni_lemma_lanzon_petersen[controller]"))
    results.append(sni_lemma(Ac, Bc, Cc, name="sni_lemma[controller]"))
    results.append(ni_dissipation_strict(Ac, Bc, Cc, name="ni_dissipation_strict[controller]"))
    results.append(closed_loop_decay(m, gains))
    lo, hi = mass_range if mass_range is not None else (0.8 * m, 1.2 * m)
    for m_nominal in (None, m):
        results.append(robust_mass_decay(lo, hi, gains, parameter_dependent=False, m_nominal=m_nominal))
        results.append(robust_mass_decay(lo, hi, gains, parameter_dependent=True, m_nominal=m_nominal))
    u0 = axis_acceleration_limit(g, tilt_limit_deg, "norm" if len(axes) == 1 else "inscribed")
    for label, kp in axes:
        roa = region_of_attraction(m, kp, gains.Gamma, gains.delta, u0, name=f"region_of_attraction[{label}]")
        roa.values["tilt_limit_deg"] = tilt_limit_deg
        roa.values["norm_model"] = float(len(axes) == 1)
        results.append(roa)
    return results
