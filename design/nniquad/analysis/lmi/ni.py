"""NI and SNI lemmas: the paper's statement, the literature's dissipation form, Lanzon-Petersen, strict forms.

Each function takes system matrices ``(A, B, C[, D])``, solves its LMI with
Clarabel (:mod:`.solver`) and re-checks the answer with :mod:`.checks`.

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

from typing import Any

import numpy as np

from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.solver import LMIResult, as_data, cpsym, result_fail, solve, solved

__all__ = ["ni_lemma_paper", "ni_lemma_dissipation", "ni_lemma_lanzon_petersen", "sni_lemma", "ni_dissipation_strict"]


def _cp():
    import cvxpy as cp

    return cp


# ----------------------------------------------------------------------------- 1. NI lemma as the paper states it


def _system(name: str, A: Any, B: Any, C: Any, D: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` as finite 2-D arrays (``D = 0`` when not given), or :class:`SolverError` naming ``name``."""
    d = as_data(name, A=A, B=B, C=C, D=np.zeros((np.atleast_2d(C).shape[0],) * 2) if D is None else D)
    return d["A"], d["B"], d["C"], d["D"]


def ni_lemma_paper(A, B, C, name: str = "ni_lemma_paper") -> LMIResult:
    """The paper's Lemma ``lem:time_domain_NI``: ``P > 0``, ``PA + A^TP <= 0``, ``PB = C^T``.

    ``P > 0`` is imposed as ``P >= t I`` with ``t >= 1e-6 * |C|/|B|`` (the scale
    that the equality gives P) and ``t`` maximised (capped at ``1e3 |C|/|B|``).

    Returns
    -------
    LMIResult
        ``margin`` = the smallest eigenvalue of P achieved.  Residuals:
        ``min_eig_P`` (relative to ``|P|``), ``lyapunov_max_eig`` (max eig of
        ``PA + A^TP`` relative to ``|P| |A|``), ``equality`` (``|PB - C^T| / |C|``)
        and ``ni_dissipation_max_eig``: whether the returned storage satisfies the
        NI inequality ``dV/dt <= ydot^T u`` (it need not: this is the passivity
        equality).
    """
    cp = _cp()
    d = as_data(name, A=A, B=B, C=C)
    A, B, C = d["A"], d["B"], d["C"]
    n = A.shape[0]
    scale = K.norm(C) / K.norm(B)
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    P = cp.Variable((n, n), symmetric=True, name="P")
    t = cp.Variable(name="t")
    cons = [P - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, cpsym(P @ A + A.T @ P) << 0, P @ B == C.T]
    prob = cp.Problem(cp.Maximize(t), cons)
    status = solve(prob, name)
    note = ("paper's Lemma: P>0, PA+A'P<=0, PB=C' (the positive-real lemma equality: it certifies "
            "dV/dt <= y'u, not the NI inequality dV/dt <= ydot'u); margin = min eig P")
    if not solved(status):
        return result_fail(name, status, {"A": A, "B": B, "C": C}, note + f"; solver: {status}", K.RTOL)
    Pv = K.sym(P.value)
    res = {
        "min_eig_P": K.eigmin(Pv) / K.norm(Pv),
        "lyapunov_max_eig": K.eigmax(Pv @ A + A.T @ Pv) / (K.norm(Pv) * K.norm(A)),
        "equality": float(np.linalg.norm(Pv @ B - C.T)) / K.norm(C),
        "ni_dissipation_max_eig": K.dissipation_residual(Pv, A, B, C),
    }
    ok = res["min_eig_P"] > 0.5 * t_min / K.norm(Pv) and res["lyapunov_max_eig"] <= K.RTOL and res["equality"] <= K.RTOL
    if ok and res["ni_dissipation_max_eig"] > K.RTOL:
        note += "; the returned P does NOT satisfy dV/dt <= ydot'u (ni_dissipation_max_eig > 0)"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"P": Pv, "A": A, "B": B, "C": C}, res, K.eigmin(Pv), K.RTOL, note)


# ----------------------------------------------------------------------------- 2. NI lemma as the literature states it


def _polish_equality(P: np.ndarray, B: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The symmetric ``P + Δ`` nearest ``P`` (Frobenius) with ``(P + Δ) B = R`` (least squares if inconsistent)."""
    n, m = B.shape
    iu = np.triu_indices(n)
    basis = []
    for i, j in zip(*iu):
        E = np.zeros((n, n))
        E[i, j] = E[j, i] = 1.0
        basis.append(E)
    # Δ = Σ c_k E_k: the equations (Σ c_k E_k) B = R - P B, minimum-norm c (off-diagonals weighted for the Frobenius norm)
    w = np.array([1.0 if i == j else np.sqrt(2.0) for i, j in zip(*iu)])
    M = np.stack([(E @ B).ravel() for E in basis], axis=1) / w
    c = np.linalg.lstsq(M, (R - P @ B).ravel(), rcond=None)[0] / w
    return K.sym(P + sum(ck * E for ck, E in zip(c, basis)))


def ni_lemma_dissipation(A, B, C, D=None, name: str = "ni_lemma_dissipation",
                         scaling: np.ndarray | None = None) -> LMIResult:
    """NI lemma in dissipation (KYP) form: ``D = D^T``, ``P > 0``, :func:`ni_dissipation_matrix` ``<= 0``.

    This is the statement of Xiong, Petersen & Lanzon (2010) / Mabrok et al. (2014)
    (see the module docstring), i.e. exactly ``dV/dt <= ydot^T u`` for
    ``V = x^T P x / 2``.  For ``CB = 0`` it is ``PA + A^TP <= 0``, ``PB = A^TC^T``.
    ``P > 0`` is imposed as ``P >= t I``, ``t >= 1e-6 |A||C|/|B|``, ``t`` maximised.

    With ``CB = 0`` and more than one state (the ``sni2`` controller) the LMI has a single
    feasible point (``P = diag(ω², 1)/k`` for ``k/(s² + 2ζωs + ω²)``), which an interior-point
    solver reaches only to about the square root of its tolerance; the answer is then
    *polished*: moved to the nearest symmetric matrix that satisfies the equality
    ``PB = A^TC^T`` exactly (:func:`_polish_equality`), and re-checked as it is.

    Parameters
    ----------
    A, B, C, D
        The system (``D = 0`` when not given).
    name
        Name of the result.
    scaling
        A state similarity ``T`` (``x = T x~``) in which the LMI is solved: the solver sees
        ``(T^{-1} A T, T^{-1} B, C T)``, ``P = T^{-T} P~ T^{-1}`` is returned (an exact congruence of
        the dissipation matrix, so it changes no answer; it only keeps the solver's numbers near 1).
        ``None``: the identity.

    Returns
    -------
    LMIResult
        ``margin`` = min eig P.  Residuals (in the solved coordinates): ``min_eig_P``,
        ``dissipation_max_eig`` (relative), ``equality_PB_AtCt`` (``|PB - A^TC^T|`` relative; zero is
        forced only when ``CB = 0``), ``D_asymmetry``; ``dissipation_max_eig_original``: the same
        residual of the returned ``P`` in the original coordinates (what ``verify`` recomputes).
    """
    A0, B0, C0, Dm = _system(name, A, B, C, D)
    if scaling is None:
        return _ni_lemma_dissipation(A0, B0, C0, Dm, name)
    T = np.atleast_2d(np.asarray(scaling, dtype=float))
    Ti = np.linalg.inv(T)
    res = _ni_lemma_dissipation(Ti @ A0 @ T, Ti @ B0, C0 @ T, Dm, name)
    data = {"A": A0, "B": B0, "C": C0, "D": Dm}
    if not res.feasible or "P" not in res.matrices:
        return LMIResult(res.name, res.feasible, res.status, data, res.residuals, res.margin, res.tolerance,
                         res.note + "; solved in scaled coordinates", res.values)
    P = K.sym(Ti.T @ res.matrices["P"] @ Ti)
    residuals = {**res.residuals, "dissipation_max_eig_original": K.dissipation_residual(P, A0, B0, C0)}
    return LMIResult(res.name, res.feasible, res.status, {"P": P, **data}, residuals, K.eigmin(P), res.tolerance,
                     res.note + "; solved in scaled coordinates x = T x~, P = T^-T P~ T^-1", res.values)


def _ni_lemma_dissipation(A: np.ndarray, B: np.ndarray, C: np.ndarray, Dm: np.ndarray, name: str) -> LMIResult:
    """:func:`ni_lemma_dissipation` in the coordinates given."""
    cp = _cp()
    n = A.shape[0]
    asym = float(np.linalg.norm(Dm - Dm.T))
    note = ("NI lemma, dissipation form (Xiong-Petersen-Lanzon 2010): D=D', P>0, "
            "[[PA+A'P, PB-A'C'],[B'P-CA, -(CB+B'C')]] <= 0, i.e. dV/dt <= ydot'u; margin = min eig P")
    if asym > K.RTOL * max(1.0, K.norm(Dm)):
        return result_fail(name, "not_solved", {"A": A, "B": B, "C": C, "D": Dm}, note + "; D is not symmetric", K.RTOL)
    scale = K.norm(A) * K.norm(C) / K.norm(B)
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    P = cp.Variable((n, n), symmetric=True, name="P")
    t = cp.Variable(name="t")
    M = cp.bmat([[P @ A + A.T @ P, P @ B - A.T @ C.T], [B.T @ P - C @ A, -(C @ B + B.T @ C.T)]])
    cons = [P - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, cpsym(M) << 0]
    status = solve(cp.Problem(cp.Maximize(t), cons), name)
    data = {"A": A, "B": B, "C": C, "D": Dm}
    if not solved(status):
        return result_fail(name, status, data, note + f"; solver: {status}", K.RTOL)
    Pv = K.sym(P.value)
    cb_zero = bool(np.allclose(C @ B, 0.0, atol=K.RTOL * K.norm(C) * K.norm(B)))
    if cb_zero and n > 1:
        Pv = _polish_equality(Pv, B, A.T @ C.T)
        note += "; polished onto PB = A'C'"
    res = {
        "min_eig_P": K.eigmin(Pv) / K.norm(Pv),
        "dissipation_max_eig": K.dissipation_residual(Pv, A, B, C),
        "equality_PB_AtCt": float(np.linalg.norm(Pv @ B - A.T @ C.T)) / max(K.norm(A.T @ C.T), 1e-300),
        "D_asymmetry": asym,
    }
    ok = res["min_eig_P"] > 0.5 * t_min / K.norm(Pv) and res["dissipation_max_eig"] <= K.RTOL
    if cb_zero:
        ok = ok and res["equality_PB_AtCt"] <= K.RTOL
        note += "; CB = 0 so the block reduces to PA+A'P<=0, PB=A'C'"
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    if t.value is not None and t.value >= 0.999 * t_cap:
        note += "; margin hit its cap"
    return LMIResult(name, ok, status, {"P": Pv, **data}, res, K.eigmin(Pv), K.RTOL, note)


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
    A, B, C, Dm = _system(name, A, B, C, D)
    n = A.shape[0]
    data = {"A": A, "B": B, "C": C, "D": Dm}
    note = "NI lemma, Lanzon-Petersen 2008 form (recalled): det A != 0, Y>0, AY+YA'<=0, B+AYC'=0; margin = min eig Y"
    sv = np.linalg.svd(A, compute_uv=False)
    det_rel = float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0
    if det_rel < 1e-12 or np.linalg.norm(Dm - Dm.T) > K.RTOL * max(1.0, K.norm(Dm)):
        return result_fail(name, "not_solved", data, note + "; premise fails (A singular or D not symmetric)", K.RTOL)
    scale = K.norm(B) / (K.norm(A) * K.norm(C))
    t_min, t_cap = 1e-6 * scale, 1e3 * scale
    Y = cp.Variable((n, n), symmetric=True, name="Y")
    t = cp.Variable(name="t")
    cons = [Y - t * np.eye(n) >> 0, t >= t_min, t <= t_cap, cpsym(A @ Y + Y @ A.T) << 0, B + A @ Y @ C.T == 0]
    status = solve(cp.Problem(cp.Maximize(t), cons), name)
    if not solved(status):
        return result_fail(name, status, data, note + f"; solver: {status}", K.RTOL)
    Yv = K.sym(Y.value)
    res = {
        "min_eig_Y": K.eigmin(Yv) / K.norm(Yv),
        "lyapunov_max_eig": K.eigmax(A @ Yv + Yv @ A.T) / (K.norm(Yv) * K.norm(A)),
        "equality": float(np.linalg.norm(B + A @ Yv @ C.T)) / K.norm(B),
        "det_A_relative": det_rel,
    }
    ok = res["min_eig_Y"] > 0.5 * t_min / K.norm(Yv) and res["lyapunov_max_eig"] <= K.RTOL and res["equality"] <= K.RTOL
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"Y": Yv, **data}, res, K.eigmin(Yv), K.RTOL, note)


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
    A, B, C, Dm = _system(name, A, B, C, D)
    n = A.shape[0]
    data = {"A": A, "B": B, "C": C, "D": Dm}
    note = "SNI lemma (recalled): Y>0, AY+YA' < 0, B+AYC'=0; margin s with AY+YA' <= -s I"
    yscale = K.norm(B) / (K.norm(A) * K.norm(C))
    sscale = K.norm(B) / K.norm(C)
    Y = cp.Variable((n, n), symmetric=True, name="Y")
    s = cp.Variable(name="s")
    cons = [Y >> 1e-6 * yscale * np.eye(n), cpsym(A @ Y + Y @ A.T) + s * np.eye(n) << 0,
            s >= 1e-6 * sscale, s <= 1e3 * sscale, B + A @ Y @ C.T == 0]
    status = solve(cp.Problem(cp.Maximize(s), cons), name)
    if not solved(status):
        return result_fail(name, status, data, note + f"; solver: {status}", K.RTOL)
    Yv = K.sym(Y.value)
    lyap = K.eigmax(A @ Yv + Yv @ A.T)
    res = {
        "min_eig_Y": K.eigmin(Yv) / K.norm(Yv),
        "lyapunov_max_eig": lyap / (K.norm(Yv) * K.norm(A)),
        "equality": float(np.linalg.norm(B + A @ Yv @ C.T)) / K.norm(B),
    }
    # strict inequalities with a margin above rounding (nniquad.analysis.lmi.checks)
    definite, definite_bound = K.definite_margin(Yv)
    ok = (definite > definite_bound and lyap < -K.expression_rounding_bound(n, 2 * K.norm(A) * K.norm(Yv))
          and res["equality"] <= K.RTOL)
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"Y": Yv, **data}, res, -lyap, K.RTOL, note)


def ni_dissipation_strict(A, B, C, name: str = "ni_dissipation_strict") -> LMIResult:
    """Strict dissipation: ``P > 0`` and :func:`ni_dissipation_matrix` ``<= -eta I``, ``eta > 0``.

    This asks for ``dV/dt - ydot^T u <= -eta (|x|^2 + |u|^2)``.  For the
    controller the non-strict matrix has determinant ``-Gamma^2 (P - delta)^2 <= 0``
    for every scalar P, so it is infeasible: the SNI strictness lives in
    ``AY + YA^T < 0`` (state dissipation), not in the whole block.
    """
    cp = _cp()
    d = as_data(name, A=A, B=B, C=C)
    A, B, C = d["A"], d["B"], d["C"]
    n, k = A.shape[0], B.shape[1]
    scale = K.norm(A) * K.norm(C) / K.norm(B)
    escale = K.norm(C) * K.norm(B)
    P = cp.Variable((n, n), symmetric=True, name="P")
    eta = cp.Variable(name="eta")
    M = cp.bmat([[P @ A + A.T @ P, P @ B - A.T @ C.T], [B.T @ P - C @ A, -(C @ B + B.T @ C.T)]])
    cons = [P >> 1e-6 * scale * np.eye(n), cpsym(M) + eta * np.eye(n + k) << 0, eta >= 1e-6 * escale, eta <= 1e3 * escale]
    status = solve(cp.Problem(cp.Maximize(eta), cons), name)
    data = {"A": A, "B": B, "C": C}
    note = "strict NI dissipation: P>0 and [[PA+A'P, PB-A'C'],[B'P-CA, -(CB+B'C')]] <= -eta I, eta>0"
    if not solved(status):
        return result_fail(name, status, data, note + f"; solver: {status}", K.RTOL)
    Pv = K.sym(P.value)
    top = K.eigmax(K.ni_dissipation_matrix(Pv, A, B, C))
    res = {"min_eig_P": K.eigmin(Pv) / K.norm(Pv), "dissipation_max_eig": top / escale}
    definite, definite_bound = K.definite_margin(Pv)
    ok = definite > definite_bound and top < -K.expression_rounding_bound(
        n + k, 2 * K.norm(Pv) * K.norm(A), 2 * K.norm(Pv) * K.norm(B), 2 * K.norm(A) * K.norm(C), 2 * K.norm(C) * K.norm(B))
    if not ok:
        note += "; solver reported a solution but the numpy re-check failed"
    return LMIResult(name, ok, status, {"P": Pv, **data}, res, -top, K.RTOL, note)
