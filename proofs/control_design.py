"""Audit of Sec. ``sec:control`` (inner loop, NNI lemma, SNI controller, assumptions, sector bound, main theorem).

Frames: the horizontal rows come from the paper's ``f(x, u)``, which is NED
(see :mod:`proofs.quadrotor_model`); with ``psi = 0`` they read
``x'' = -(u1/m) c_phi s_theta`` and ``y'' = (u1/m) s_phi``.

The reduced linear loop (one axis: ``m xi'' + m kp xi = F``, ``z' = -Gamma delta z
+ Gamma xi``, ``F = z``, positive feedback) and its characteristic polynomial,
Routh array and sector bound come from :mod:`nniquad.analysis.linear`; the LMIs from
:mod:`nniquad.analysis.lmi`; the definition-level frequency checks are symbolic
(:mod:`proofs.ni_preliminaries`) with :mod:`nniquad.analysis.frequency` as a numeric
cross-check.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import sympy as sp

from nniquad.analysis import linear as L
from nniquad.analysis.linear import PAPER_LOOP, ReducedLoop
from nniquad.control.gains import Gains
from nniquad.model import symbolic as S

from .claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION, Finding, claim
from .ni_preliminaries import (
    PAPER_VALUES,
    controller_storage_analysis,
    s_var,
    sni_frequency_conditions,
    transfer_function,
)
from .quadrotor_model import paper_translational_rows

__all__ = [
    "paper_horizontal_subsystem",
    "paper_compact_lhs",
    "paper_storage",
    "paper_controller_tf",
    "paper_controller_realization",
    "paper_steady_state",
    "paper_delta_sq_threshold",
    "horizontal_subsystem",
    "compact_form",
    "nni_storage",
    "sni_controller",
    "controller_realization",
    "controller_ws_nni",
    "steady_state",
    "sector_bound",
    "zero_state_observability",
    "closed_loop_stability",
    "remark_robustness",
]

SEC = "control_design"
s = S.symbols()
m = s.m
kpx, kpy = sp.symbols("k_p^x k_p^y", positive=True)
Fx, Fy = sp.symbols("F_x F_y", real=True)
x1, x2, x3, x4 = s.xi[0], s.xi_dot[0], s.xi[1], s.xi_dot[1]
xdd, ydd = s.xi_ddot[0], s.xi_ddot[1]
phi, theta, psi = s.eta
gam = sp.Symbol("gamma", positive=True)
Gam, dlt, kp1 = L.SYMBOLS["Gamma"], L.SYMBOLS["delta"], L.SYMBOLS["kp"]
mL = L.SYMBOLS["m"]


# --------------------------------------------------------------------------- paper expressions (typed from the LaTeX)


def paper_horizontal_subsystem() -> sp.Matrix:
    """Eq. ``horizontal_subsystem`` as printed: (x1', x2', x3', x4')."""
    u1 = s.u1
    return sp.Matrix([x2, -u1 / m * sp.cos(phi) * sp.sin(theta) - kpx * x1, x4, u1 / m * sp.sin(phi) - kpy * x3])


def paper_compact_lhs() -> sp.Matrix:
    """Eq. ``compact_horizontal`` as printed, written as ``m xi'' + m Kp xi - F_h`` (= 0)."""
    Kp = sp.diag(kpx, kpy)
    xi, xidd = sp.Matrix([x1, x3]), sp.Matrix([xdd, ydd])
    return m * xidd + m * Kp * xi - sp.Matrix([Fx, Fy])


def paper_storage() -> sp.Expr:
    """Eq. ``storage_function``: ``V = 1/2 m |xi'|^2 + 1/2 xi^T Kp xi``."""
    return sp.Rational(1, 2) * m * (x2**2 + x4**2) + sp.Rational(1, 2) * (kpx * x1**2 + kpy * x3**2)


def paper_controller_tf() -> sp.Expr:
    """Eq. ``SNI_controller`` per axis (Gamma, Delta diagonal): ``(s + Gamma delta)^{-1} Gamma``."""
    return Gam / (s_var + Gam * dlt)


def paper_controller_realization() -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """Eq. ``controller_state_space``: ``z' = -Gamma Delta z + Gamma xi``, ``u_c = z`` (both axes)."""
    G2, D2 = sp.diag(Gam, Gam), sp.diag(dlt, dlt)
    return -G2 * D2, G2, sp.eye(2)


def paper_steady_state() -> sp.Matrix:
    """Eq. ``steady_state_solution``: ``(xbar, ybar) = (Fx/(m kpx), Fy/(m kpy))``."""
    return sp.Matrix([Fx / (m * kpx), Fy / (m * kpy)])


def paper_delta_sq_threshold(mass: sp.Expr, kp_min: sp.Expr, gamma: sp.Expr) -> sp.Expr:
    """Eq. ``parameter_constraint``: ``delta^2 >= 1 / (gamma^2 m^2 min(kp)^2)`` -- the right-hand side."""
    return 1 / (gamma**2 * mass**2 * kp_min**2)


# --------------------------------------------------------------------------- helpers


def _f_rows_psi0() -> sp.Matrix:
    """(x'', y'') of the paper's f(x, u) (rows 2 and 4, NED) with psi = 0."""
    r = paper_translational_rows()
    return sp.Matrix([r[0], r[1]]).subs(psi, 0)


def _zero(M: sp.Matrix) -> bool:
    return all(sp.simplify(e) == 0 for e in M)


# --------------------------------------------------------------------------- claims


@claim("horizontal-subsystem", ["eq:horizontal_subsystem", "eq:inner_loop", "eq:full_dynamics"], SEC,
       "Eq. horizontal_subsystem (x'' = -(u1/m) c_phi s_theta - kp^x x, y'' = (u1/m) s_phi - kp^y y) follows from "
       "rows 1-4 of f(x, u) with psi = 0 and the inner loop U = -Kp xi_h.", "symbolic")
def horizontal_subsystem(rows: sp.Matrix | None = None) -> Finding:
    """Compare the printed subsystem with f(x, u) at psi = 0; then the corrected identification."""
    rows = paper_horizontal_subsystem() if rows is None else sp.Matrix(rows)
    f = _f_rows_psi0()
    acc = sp.Matrix([rows[1], rows[3]])
    literal = (acc - f).applyfunc(sp.simplify)
    kin = sp.Matrix([rows[0] - x2, rows[2] - x4])
    ev = {"f rows 2, 4 at psi = 0 (NED)": str(f),
          "printed (x2', x4') minus f": str(literal),
          "kinematic rows x1' - x2, x3' - x4": str(kin)}
    if _zero(literal) and _zero(kin):
        return Finding(HOLDS, "the printed rows equal f(x, u) at psi = 0", ev)
    cex = {"state": "hover at x = 1 m, y = 0, phi = theta = 0, u1 = m g, at rest",
           "f(x, u): x''": 0.0,
           "eq. horizontal_subsystem: x''": str(acc[0].subs({phi: 0, theta: 0, s.u1: m * s.g, x1: 1, x3: 0})),
           "reading": "the -kp x term is added on top of the full physical thrust u1: the inner loop is not "
                      "realised by any input of f, so the equation of motion is contradicted (the thrust is counted "
                      "once as physics and the inner loop once more)"}
    # correction: the physical horizontal force is split into the inner-loop part m U = -m Kp xi and the outer input
    Fdef = sp.Matrix([-s.u1 * sp.cos(phi) * sp.sin(theta) + m * kpx * x1, s.u1 * sp.sin(phi) + m * kpy * x3])
    corrected = sp.Matrix([Fx / m - kpx * x1, Fy / m - kpy * x3])
    corr_res = (corrected.subs({Fx: Fdef[0], Fy: Fdef[1]}) - f).applyfunc(sp.simplify)
    # the printed rows must at least carry the physical thrust of f on top of the inner loop
    physical = (acc + sp.Matrix([kpx * x1, kpy * x3]) - f).applyfunc(sp.simplify)
    ok = _zero(corr_res) and _zero(physical) and _zero(kin)
    correction = {
        "change": "write the subsystem as x'' = F_x/m - kp^x x, y'' = F_y/m - kp^y y, where (F_x, F_y) is the "
                  "outer-loop part of the horizontal thrust: F_x := -u1 c_phi s_theta + m kp^x x, "
                  "F_y := u1 s_phi + m kp^y y (i.e. the attitude/thrust loop realises the acceleration "
                  "command U + F_h/m with U = -Kp xi_h an acceleration, eq. inner_loop)",
        "corrected rows with that F_h, minus f at psi = 0": str(corr_res),
        "printed rows + Kp xi - f (the printed u1 terms are the physical thrust)": str(physical),
        "checked": ok,
    }
    return Finding(HOLDS_WITH_CORRECTION if ok else FAILS,
                   "as printed the -kp x term does not follow from f (hover at x = 1: f gives 0, eq. gives -kp); "
                   "holds with F_h := horizontal thrust + m Kp xi" if ok else "the printed rows contradict f(x, u)",
                   ev, cex, correction)


@claim("compact-form", ["eq:compact_horizontal", "eq:horizontal_subsystem"], SEC,
       "Eq. compact_horizontal, m xi'' + m Kp xi = F_h, y = xi, is equivalent to eq. horizontal_subsystem when F_h "
       "is identified with the horizontal thrust components (F_x, F_y) = (-u1 c_phi s_theta, u1 s_phi) (NED, psi = 0).",
       "symbolic")
def compact_form(lhs: sp.Matrix | None = None) -> Finding:
    """Solve the compact form for xi'' and compare with eq. horizontal_subsystem under the identification."""
    lhs = paper_compact_lhs() if lhs is None else sp.Matrix(lhs)
    sol = sp.solve(list(lhs), [xdd, ydd], dict=True)[0]
    F_id = {Fx: -s.u1 * sp.cos(phi) * sp.sin(theta), Fy: s.u1 * sp.sin(phi)}
    compact_acc = sp.Matrix([sol[xdd], sol[ydd]]).subs(F_id)
    rows = paper_horizontal_subsystem()
    res = (compact_acc - sp.Matrix([rows[1], rows[3]])).applyfunc(sp.simplify)
    # the block diagram (Fig. control_diagram) feeds -Kp xi into m xi'' = F_h: a force gain
    diagram = sp.Matrix([m * xdd + kpx * x1 - Fx, m * ydd + kpy * x3 - Fy])
    dsol = sp.solve(list(diagram), [xdd, ydd], dict=True)[0]
    diag_res = (sp.Matrix([dsol[xdd], dsol[ydd]]) - sp.Matrix([sol[xdd], sol[ydd]])).applyfunc(sp.simplify)
    ev = {"identification": "F_x = -u1 cos(phi) sin(theta), F_y = u1 sin(phi) (horizontal thrust, NED, psi = 0)",
          "compact form solved for xi'' with that F_h, minus eq. horizontal_subsystem": str(res),
          "note (block diagram)": "Fig. control_diagram feeds -Kp xi into m xi'' = F_h, i.e. m xi'' + Kp xi = u_c "
                                  f"(Kp a force gain); its xi'' differs from the compact form by {diag_res.T} "
                                  "unless m = 1; the proof of Lemma NNI_horizontal also uses m xi'' + Kp xi",
          "note (corrected subsystem)": "with the correction of claim horizontal-subsystem, F_h is the horizontal "
                                        "thrust plus m Kp xi_h (the outer-loop part), and the compact form is exact"}
    if _zero(res):
        return Finding(HOLDS, "equivalent, with F_h = (-u1 c_phi s_theta, u1 s_phi), the horizontal thrust (NED, psi = 0)",
                       ev)
    pt = {m: sp.Rational(1, 2), kpx: 5, kpy: 5, x1: 1, x3: 0, phi: 0, theta: 0, s.u1: 0}
    return Finding(FAILS, "the compact form is not equivalent to eq. horizontal_subsystem", ev,
                   {"point": "m = 0.5, kp = 5, x = 1, u1 = 0", "compact x''": str(compact_acc[0].subs(pt)),
                    "eq. horizontal_subsystem x''": str(rows[1].subs(pt))})


@claim("nni-storage", ["lem:NNI_horizontal", "eq:storage_function", "eq:dissipation_proof", "eq:compact_horizontal"],
       SEC,
       "Lemma NNI_horizontal: along m xi'' + m Kp xi = F_h the storage V = 1/2 m |xi'|^2 + 1/2 xi^T Kp xi is positive "
       "definite and dV/dt = ydot^T F_h, so the subsystem is NNI with this storage.", "symbolic")
def nni_storage(storage: sp.Expr | None = None, dynamics: sp.Matrix | None = None) -> Finding:
    """dV/dt - xi'^T F_h along the compact form, for all positive m, kp^x, kp^y."""
    V = paper_storage() if storage is None else storage
    lhs = paper_compact_lhs() if dynamics is None else sp.Matrix(dynamics)
    sol = sp.solve(list(lhs), [xdd, ydd], dict=True)[0]
    grad = [sp.diff(V, v) for v in (x1, x2, x3, x4)]
    vel = [x2, sol[xdd], x4, sol[ydd]]
    Vdot = sp.expand(sum(g * v for g, v in zip(grad, vel)))
    resid = sp.factor(sp.expand(Vdot - (x2 * Fx + x4 * Fy)))
    H = sp.hessian(V, (x1, x2, x3, x4))
    pd = all(sp.factor(H.extract(list(range(k)), list(range(k))).det()).is_positive for k in range(1, 5))
    ev = {"storage": str(V), "dV/dt along the dynamics": str(Vdot), "dV/dt - ydot^T F_h": str(resid),
          "V positive definite (leading minors of the Hessian > 0 for all positive parameters)": pd,
          "proof line 2": "the printed proof writes m xi'' + Kp xi = F_h (without the m of eq. compact_horizontal)"}
    if resid == 0 and pd:
        return Finding(HOLDS, "dV/dt - ydot^T F_h simplifies to 0", ev)
    if pd and (resid.is_nonpositive is True):
        return Finding(HOLDS, f"dV/dt - ydot^T F_h = {resid} <= 0 for all states", ev)
    pt = {m: sp.Rational(1, 2), kpx: 5, kpy: 5, x1: 1, x2: 1, x3: 0, x4: 0, Fx: 0, Fy: 0}
    cex = {"point": "m = 0.5, kp^x = kp^y = 5, xi = (1, 0) m, xi' = (1, 0) m/s, F_h = 0",
           "dV/dt": str(Vdot.subs(pt)), "ydot^T F_h": "0",
           "so dV/dt > ydot^T F_h": "the NNI inequality (eq. NNI_condition) itself fails, not only the equality"
           if float(resid.subs(pt)) > 0 else "equality fails"}
    V_corr = sp.Rational(1, 2) * m * (x2**2 + x4**2) + sp.Rational(1, 2) * m * (kpx * x1**2 + kpy * x3**2)
    lhs0 = paper_compact_lhs()
    sol0 = sp.solve(list(lhs0), [xdd, ydd], dict=True)[0]
    Vdot_c = sp.expand(sum(sp.diff(V_corr, v) * w for v, w in zip((x1, x2, x3, x4), [x2, sol0[xdd], x4, sol0[ydd]])))
    res_c = sp.factor(Vdot_c - (x2 * Fx + x4 * Fy))
    ok = res_c == 0
    correction = {"storage": str(V_corr) + "  (= 1/2 m |xi'|^2 + 1/2 m xi^T Kp xi; equals 1/2 x^T P x with the "
                  "P = diag(m kp, m) of claim ni-lemma-plant)",
                  "dV/dt - ydot^T F_h along eq. compact_horizontal": str(res_c), "checked": ok}
    return Finding(HOLDS_WITH_CORRECTION if ok else FAILS,
                   f"dV/dt - ydot^T F_h = {resid} != 0 unless m = 1 (and > 0 at m = 0.5); V with m Kp works",
                   ev, cex, correction)


@claim("sni-controller", ["eq:SNI_controller", "def:SNI"], SEC,
       "C(s) = (sI + Gamma Delta)^{-1} Gamma with Gamma = diag(Gamma, Gamma), Delta = diag(delta, delta) is strictly "
       "negative imaginary for every Gamma, delta > 0.", "symbolic+numeric")
def sni_controller(C: sp.Expr | None = None) -> Finding:
    """Definition def:SNI symbolically (per diagonal entry), and nniquad.analysis.frequency at the paper's numbers."""
    C = paper_controller_tf() if C is None else C
    res = sni_frequency_conditions(C, PAPER_VALUES)
    ev = {"per axis (the matrix is diagonal, so SNI per entry <=> SNI of the matrix)": res}
    try:
        import control as ct

        from nniquad.analysis import frequency as F

        num, den = sp.fraction(sp.cancel(C.subs(PAPER_VALUES)))
        tf = ct.tf([float(c) for c in sp.Poly(num, s_var).all_coeffs()], [float(c) for c in sp.Poly(den, s_var).all_coeffs()])
        fr = F.ni_check(tf)
        ev["nniquad.analysis.frequency.ni_check at Gamma = 160, delta = 0.6 (numeric grid)"] = {
            "is_sni": fr.is_sni, "grid_min_eig": fr.grid_min_eig, "notes": fr.notes}
    except ImportError:  # pragma: no cover - the frequency module is optional for the audit
        pass
    if res["holds"]:
        return Finding(HOLDS, "pole -Gamma delta < 0 and j(C - C^*) = 2 Gamma w / (w^2 + Gamma^2 delta^2) > 0", ev)
    return Finding(FAILS, "a condition of Definition def:SNI fails", ev, {"conditions": res})


@claim("controller-realization", ["eq:controller_state_space", "eq:SNI_controller", "eq:controller_x",
                                  "eq:controller_y"], SEC,
       "z' = -Gamma Delta z + Gamma xi_h, u_c = z realises C(s) = (sI + Gamma Delta)^{-1} Gamma, and the DC gain is "
       "C(0) = Delta^{-1}.", "symbolic")
def controller_realization(realization: tuple | None = None) -> Finding:
    """Transfer matrix of the realisation minus C(s), and C(0) - Delta^{-1}."""
    Ac, Bc, Cc = paper_controller_realization() if realization is None else tuple(sp.Matrix(M) for M in realization)
    G2, D2 = sp.diag(Gam, Gam), sp.diag(dlt, dlt)
    Ctf = (s_var * sp.eye(2) + G2 * D2).inv() * G2
    real = Cc * (s_var * sp.eye(2) - Ac).inv() * Bc
    res = (real - Ctf).applyfunc(sp.simplify)
    dc = (real.subs(s_var, 0) - D2.inv()).applyfunc(sp.simplify)
    a1, b1, c1, _ = L.controller_matrices_sym()
    ev = {"C_real(s) - C(s)": str(res), "C_real(0) - Delta^{-1}": str(dc),
          "nniquad.analysis.linear per-axis realisation": f"A = {a1}, B = {b1}, C = {c1}",
          "notation": "the text calls the same transfer matrix C_v(s) ('C_v(0) = Delta^{-1}', Fig. control_diagram); "
                      "C_v and C are one object"}
    if _zero(res) and _zero(dc):
        return Finding(HOLDS, "C_real(s) - C(s) = 0 and C(0) = Delta^{-1}", ev)
    return Finding(FAILS, "the realisation does not realise C(s) (or its DC gain differs)", ev,
                   {"C_real(s)": str(real.applyfunc(sp.simplify)), "C(s)": str(Ctf)})


@claim("controller-ws-nni", ["rem:SNI_WSNNI_equivalence", "def:NNI", "def:MS_NNI", "def:WS_NNI",
                             "eq:controller_state_space", "thm:main_result"], SEC,
       "The SNI controller (input xi_h, output z) is WS-NNI: NNI with some storage, MS-NNI (equality dV/dt = ydot^T u "
       "for all t implies u -> 0) and globally asymptotically stable for u = 0.", "symbolic")
def controller_ws_nni(storage: sp.Expr | None = None) -> Finding:
    """Dissipation inequality of an explicit storage, GAS at u = 0, and the MS-NNI clause (per axis)."""
    an = controller_storage_analysis(storage)
    ev = {k: v for k, v in an.items() if not k.startswith("_")}
    ev["GAS for u = 0"] = "z' = -Gamma delta z, eigenvalue -Gamma delta < 0 for all Gamma, delta > 0"
    if not (an["NNI inequality holds for all (z, xi)"] and an["V positive definite"]):
        z, xi = sp.symbols("z xi", real=True)
        pt = {Gam: 160, dlt: sp.Rational(3, 5), z: 1, xi: 0}
        val = an["_resid"].subs(pt)
        if val <= 0:
            pt = {Gam: 160, dlt: sp.Rational(3, 5), z: 1, xi: 2}
            val = an["_resid"].subs(pt)
        return Finding(FAILS, "the storage does not satisfy dV/dt <= ydot u (only V = delta z^2/2 does)", ev,
                       {"point": {str(k): float(v) for k, v in pt.items()}, "dV/dt - zdot xi": float(val)})
    cex = {"trajectory": "z(t) = 1, xi(t) = delta (constant): zdot = 0, so dV/dt = 0 = ydot u for all t",
           "u(t) = xi(t)": "= delta for all t, which does not tend to 0",
           "any storage": "V = delta z^2/2 is the only storage (see evidence), so no choice of V rescues MS-NNI"}
    correction = {
        "change": "in Definition def:MS_NNI replace 'lim u(t) = 0' by 'the trajectory is an equilibrium "
                  "(ydot = 0, xdot = 0)' -- or apply the definition to the steady-state-shifted system",
        "check": "with V = delta z^2/2: dV/dt - ydot u = -zdot^2/Gamma, so equality for all t <=> zdot = 0 for all t "
                 "<=> z constant and xi = delta z: an equilibrium; GAS at u = 0 as above",
        "residual dV/dt - zdot xi + zdot^2/Gamma": ev["dV/dt - zdot*xi + zdot^2/Gamma"],
        "checked": ev["dV/dt - zdot*xi + zdot^2/Gamma"] == "0",
        "consequence": "the closed-loop conclusion of Theorem thm:main_result is checked independently "
                       "(claim closed-loop-stability)",
    }
    return Finding(HOLDS_WITH_CORRECTION,
                   "NNI with V = delta z^2/2 (dV/dt - ydot u = -zdot^2/Gamma) and GAS, but not MS-NNI as defined: "
                   "z = 1, u = delta gives equality with u -/-> 0", ev, cex, correction)


@claim("steady-state", ["eq:ss_x", "eq:ss_y", "eq:steady_state_solution", "assum:steady_state_H1",
                        "assum:steady_state_H2", "assum:positivity"], SEC,
       "At steady state 0 = F_x/m - kp^x xbar (and for y), so xbar = F_x/(m kp^x), ybar = F_y/(m kp^y): unique, "
       "continuous, nonzero for nonzero input (Assumption 1); the controller's steady state is u_c = Delta^{-1} xi "
       "(Assumption 2) and xi^T u_c = |xi|^2/delta >= 0 (Assumption 3).", "symbolic")
def steady_state(xbar: sp.Matrix | None = None) -> Finding:
    """Solve the steady-state equations and compare with the printed solution; check Assumptions 1-3."""
    xbar = paper_steady_state() if xbar is None else sp.Matrix(xbar)
    xb, yb, zb = sp.symbols("xbar ybar zbar", real=True)
    ss = sp.solve([Fx / m - kpx * xb, Fy / m - kpy * yb], [xb, yb], dict=True)
    unique = len(ss) == 1
    derived = sp.Matrix([ss[0][xb], ss[0][yb]])
    res = (xbar - derived).applyfunc(sp.simplify)
    nonzero = sp.simplify(derived[0] / Fx).is_positive is True  # linear with a positive factor: xbar != 0 iff F != 0
    zs = sp.solve(-Gam * dlt * zb + Gam * xb, zb)
    pos = sp.factor(xb * zs[0] + yb * zs[0].subs(xb, yb))
    ev = {"derived steady state": str(derived), "printed - derived": str(res), "unique": unique,
          "Assumption 1 (xbar != 0 iff F != 0, continuous)": nonzero,
          "controller steady state z (Assumption 2)": str(zs), "xi^T u_c (Assumption 3)": str(pos),
          "Assumption 3 sign": "nonnegative" if pos.is_nonnegative else "undecided"}
    if _zero(res) and unique and nonzero and pos.is_nonnegative:
        return Finding(HOLDS, "xbar = F_x/(m kp^x), u_c = xi/delta, xi^T u_c = |xi|^2/delta >= 0", ev)
    return Finding(FAILS, "the printed steady state differs from the solution of eqs. ss_x, ss_y", ev,
                   {"printed": str(xbar), "solution": str(derived)})


@claim("sector-bound", ["eq:sector_bound", "eq:sector_bound_specific", "eq_47", "eq:sufficient_condition",
                        "eq:parameter_constraint", "assum:sector_bound"], SEC,
       "From the steady-state relations, |u_c|^2 <= gamma^2 |F_h|^2 for all F_h holds if delta^2 >= 1/(gamma^2 m^2 "
       "min(kp)^2) (stated as sufficient); we also decide whether it is necessary, and how it relates to closed-loop "
       "stability of the reduced linear loop.", "symbolic+numeric")
def sector_bound(threshold=paper_delta_sq_threshold) -> Finding:
    """Derive the exact sector condition and compare with the printed constraint; relate it to Routh."""
    kmin = sp.Symbol("k_min", positive=True)
    kmax = sp.Symbol("k_max", positive=True)
    # |u_c|^2 / |F|^2 = sum_i F_i^2 / (delta m kp_i)^2 / sum F_i^2 : its supremum is the largest coefficient
    ratio_coeffs = [1 / (dlt * m * kmin) ** 2, 1 / (dlt * m * kmax) ** 2]
    sup = ratio_coeffs[0]  # kmin <= kmax
    exact = sp.solve(sp.Eq(sup, gam**2), dlt)
    exact_sq = sp.simplify(exact[0] ** 2)
    given = threshold(m, kmin, gam)
    res = sp.simplify(given - exact_sq)
    # stability of the reduced loop: Routh region m kp delta > 1 (nniquad.analysis.linear)
    routh = L.routh_stability_region()
    # sector with fixed gamma < 1 implies Routh: delta >= 1/(gamma m kmin) => m kp delta >= 1/gamma > 1
    r = sp.Symbol("r", positive=True)  # gamma = 1/(1 + r)
    e = sp.Symbol("e", nonnegative=True)  # delta = 1/(gamma m kmin) + e
    margin = sp.expand((m * kmin * (1 / (gam * m * kmin) + e) - 1).subs(gam, 1 / (1 + r)))
    sufficient = margin.is_positive is True
    # not necessary for a fixed gamma: m kp delta = 1.1 is stable but needs gamma >= 1/1.1 > 0.8
    mv, kv = 0.5, 5.0
    dv = 1.1 / (mv * kv)
    pd = ReducedLoop(mv, Gains(kp=kv, Gamma=160.0, delta=dv)).poles_and_damping()
    ev = {
        "sup over F of |u_c|^2/|F|^2": str(sup) + " (attained with F along the axis of the smallest kp)",
        "exact condition on delta^2": str(exact_sq),
        "printed threshold - exact": str(res),
        "necessary too": "yes: F along the smallest-kp axis attains the supremum, so eq. sufficient_condition is "
                         "necessary and sufficient for eq. sector_bound_specific ('it is sufficient that' understates it)",
        "Routh region of the reduced loop (nniquad.analysis.linear)": str(routh["reduced"]),
        "sector with gamma in (0, 1) => stability": f"m kmin delta - 1 = {margin} > 0 for r > 0, e >= 0: {sufficient}",
        "not necessary for a fixed gamma (numeric)": {
            "m": mv, "kp": kv, "Gamma": 160.0, "delta": dv, "m kp delta": 1.1,
            "smallest admissible gamma": 1 / 1.1, "violates gamma = 0.8": True,
            "max Re(pole) [1/s]": pd.max_real_part, "stable": pd.stable},
        "union over gamma in (0, 1)": "exists gamma < 1 with the bound <=> m kmin delta > 1 <=> Routh stability of "
                                      "both axes: necessary and sufficient",
    }
    if res == 0 and sufficient and pd.stable:
        return Finding(HOLDS,
                       "derivation exact; the bound is necessary and sufficient for the sector inequality; "
                       "with some gamma < 1 it is equivalent to Routh stability (m kp delta > 1)", ev)
    pt = {m: sp.Rational(1, 2), kmin: 5, gam: sp.Rational(4, 5)}
    return Finding(FAILS, "the printed constraint differs from the exact sector condition", ev,
                   {"at m = 0.5, kp = 5, gamma = 0.8": {"printed delta^2 >=": str(given.subs(pt)),
                                                        "exact delta^2 >=": str(exact_sq.subs(pt))}})


@claim("zero-state-observability", ["lem:zero_state_observability", "eq:horizontal_subsystem"], SEC,
       "The horizontal subsystem (with F_h = 0, output xi_h) is zero-state observable: y = 0 and u = 0 for all t "
       "force the state to zero.", "symbolic")
def zero_state_observability(A: sp.Matrix | None = None, C: sp.Matrix | None = None) -> Finding:
    """Observability matrix rank for all positive kp (one axis; the axes are decoupled)."""
    A0, _, C0, _ = L.plant_matrices_sym()
    A = A0 if A is None else sp.Matrix(A)
    C = C0 if C is None else sp.Matrix(C)
    n = A.shape[0]
    O = sp.Matrix.vstack(*[C * A**k for k in range(n)])
    det = sp.factor(O.det()) if O.shape[0] == O.shape[1] else None
    rank = O.rank(simplify=True)
    ev = {"A": str(A), "C": str(C), "observability matrix": str(O), "det": str(det), "rank": rank,
          "proof order": "the printed proof derives x2' = 0 first, then x2 = x1' = 0; the direct argument is "
                         "y = x1 = 0 for all t => x2 = x1' = 0 (same conclusion)"}
    if rank == n and (det is None or det != 0):
        return Finding(HOLDS, f"observability matrix {O.tolist()} has full rank {n} for all kp > 0", ev)
    return Finding(FAILS, f"observability matrix has rank {rank} < {n}", ev,
                   {"unobservable direction": str(O.nullspace()[0] if O.nullspace() else None)})


def _closed_loop_sym(sign: int) -> sp.Matrix:
    A, B, C, _ = L.plant_matrices_sym()
    Ac, Bc, Cc, _ = L.controller_matrices_sym()
    return sp.BlockMatrix([[A, sign * B * Cc], [Bc * C, Ac]]).as_explicit()


@claim("closed-loop-stability", ["thm:main_result", "thm:main_stability", "eq:parameter_constraint"], SEC,
       "Theorem main_result for the reduced linear loop: for all positive m, kp^x, kp^y, Gamma, delta satisfying "
       "eq. parameter_constraint with some gamma in (0, 1), the positive-feedback loop of m xi'' + m Kp xi = F_h "
       "and the SNI controller is asymptotically stable and xi_h -> 0.", "symbolic+numeric")
def closed_loop_stability(sign: int = +1, closed_loop: sp.Matrix | None = None) -> Finding:
    """Routh-Hurwitz on the characteristic polynomial under the constraint, plus poles at the paper's gains.

    Parameters
    ----------
    sign
        Feedback sign of the interconnection (+1 is the paper's positive feedback).
    closed_loop
        A variant closed-loop matrix in the symbols of :data:`nniquad.analysis.linear.SYMBOLS`
        (state ``[xi, xi_dot, z]``) instead of the interconnection; the verdict needs
        both the symbolic Routh check *and* stable poles at the paper's gains.
    """
    A_cl = _closed_loop_sym(sign) if closed_loop is None else sp.Matrix(closed_loop)
    sv = sp.Symbol("s")
    poly = sp.Poly(sp.expand((sv * sp.eye(3) - A_cl).det()), sv)
    rows = L.routh_array(poly)
    first = [sp.factor(r[0]) for r in rows]
    r = sp.Symbol("r", positive=True)  # gamma = 1/(1 + r) in (0, 1)
    e = sp.Symbol("e", nonnegative=True)  # delta = 1/(gamma m kp_min) + e, kp >= kp_min for the other axis
    d_sub = (1 + r) / (mL * kp1) + e  # constraint on the axis with kp = kp_min; the other axis has larger kp
    under = [sp.factor(sp.expand(c.subs(dlt, d_sub))) for c in first]
    signs = [u.is_positive for u in under]
    # also the other axis: kp = kp_min * (1 + q), q >= 0
    q = sp.Symbol("q", nonnegative=True)
    # delta is set by kp_min = kp1; the other axis has kp = kp1 (1 + q)
    under2 = [sp.factor(sp.expand(c.subs(kp1, kp1 * (1 + q)).subs(dlt, (1 + r) / (mL * kp1) + e))) for c in first]
    signs2 = [u.is_positive for u in under2]
    ok_sym = all(x is True for x in signs) and all(x is True for x in signs2)
    # numeric at the paper's gains: three independent routes to the poles
    import control as ct

    vals = {mL: 0.5, kp1: 5.0, Gam: 160.0, dlt: 0.6}
    coeffs = [float(c.subs(vals)) for c in poly.all_coeffs()]
    r_np = np.sort_complex(np.roots(coeffs))
    A_num = np.array(A_cl.subs(vals), dtype=float)
    r_eig = np.sort_complex(np.linalg.eigvals(A_num))
    Ap, Bp, Cp, Dp = (np.array(M.subs(vals), dtype=float) for M in L.plant_matrices_sym())
    Ac, Bc, Cc, Dc = (np.array(M.subs(vals), dtype=float) for M in L.controller_matrices_sym())
    if closed_loop is None:
        r_ct = np.sort_complex(np.asarray(ct.feedback(ct.ss(Ap, Bp, Cp, Dp), ct.ss(Ac, Bc, Cc, Dc), sign=sign).poles()))
    else:  # a variant has no plant/controller split: python-control's poles of the matrix itself
        r_ct = np.sort_complex(np.asarray(ct.ss(A_num, np.zeros((3, 1)), np.zeros((1, 3)), 0).poles()))
    dev = float(max(np.max(np.abs(r_np - r_eig)), np.max(np.abs(r_ct - r_eig))))
    ev = {"feedback sign": sign, "characteristic polynomial": str(poly.as_expr()),
          "Routh first column": [str(c) for c in first],
          "under the constraint (delta = (1 + r)/(m kp_min) + e, gamma = 1/(1 + r))": [str(u) for u in under],
          "positive for all r > 0, e >= 0 (axis with kp_min)": signs,
          "positive for the other axis (kp = kp_min (1 + q))": signs2,
          "paper's gains: poles (numpy roots / eig / python-control feedback)": r_eig.round(6).tolist(),
          "max deviation between the three pole computations": dev,
          "scope": "the theorem is stated for eq. horizontal_subsystem (which contains u1, phi, theta); this check "
                   "covers the reduced linear loop only; the full vehicle is claim full-model-stability"}
    if ok_sym and bool(np.all(r_eig.real < 0)):
        return Finding(HOLDS, "Routh first column > 0 under the constraint for all positive parameters "
                              "(stable iff m kp delta > 1, implied by the bound)", ev)
    bad = {"m": 0.5, "kp": 5.0, "Gamma": 160.0, "delta": 0.6, "poles": r_eig.round(6).tolist(),
           "max Re": float(np.max(r_eig.real))}
    return Finding(FAILS, "a Routh entry is not positive under the constraint", ev, bad)


@claim("remark-robustness", ["thm:main_result", "eq:parameter_constraint"], SEC,
       "Remark after Theorem main_result: stability is maintained for all parameter values satisfying eq. "
       "parameter_constraint, regardless of model uncertainties in the quadrotor dynamics, provided the NNI property "
       "is preserved.", "symbolic+numeric")
def remark_robustness(true_masses: Sequence[float] = (0.25, 0.3, 0.4, 0.5, 0.75, 1.0, 2.0),
                      loop: ReducedLoop = PAPER_LOOP, gamma: float = 0.8) -> Finding:
    """Mass uncertainty in the paper's model (kp an exact acceleration gain): the plant stays NNI for any mass.

    Parameters
    ----------
    true_masses
        True masses to test [kg].
    loop
        The nominal loop (its mass is the nominal mass).
    gamma
        The sector gain the gains were designed with.
    """
    nominal_mass, gains = loop.m, loop.gains
    kp_min = min(gains.axes())
    designed = nominal_mass * kp_min * gains.delta >= 1 / gamma
    rows = []
    for mt in true_masses:
        pd = loop.with_mass(mt).poles_and_damping()
        rows.append({"true mass kg": mt, "plant NNI (V = 1/2 m |xi'|^2 + 1/2 m xi^T Kp xi)": True,
                     "m kp delta": mt * kp_min * gains.delta, "stable": pd.stable,
                     "max Re(pole)": pd.max_real_part})
    ev = {"model": "paper's compact form with the true mass: m xi'' + m Kp xi = F_h (nniquad.analysis.linear; the controller does "
                   "not contain m)",
          "constraint with the nominal mass": {"nominal m": nominal_mass, "gamma": gamma, "holds": designed},
          "true masses": rows,
          "note": "nniquad.sim models the implemented inner loop (command scaled by the nominal mass); there the "
                  "stability condition m_nominal kp delta > 1 does not involve the true mass"}
    bad = [r for r in rows if not r["stable"]]
    if designed and not bad:
        return Finding(HOLDS, "every tested true mass is stable", ev)
    if not designed:
        return Finding(FAILS, "the gains do not satisfy the constraint with the nominal mass", ev)
    m_crit = 1 / (kp_min * gains.delta)
    lo, hi = 1 / (gamma * kp_min * gains.delta), 4 * nominal_mass
    grid = np.geomspace(lo, hi, 41)
    grid_ok = all(loop.with_mass(mt).poles_and_damping().stable for mt in grid)
    mu = sp.Symbol("m_true", positive=True)
    routh_true = sp.factor(L.routh_stability_region()["reduced"].lhs.subs(mL, mu))
    cex = {"true mass kg": bad[0]["true mass kg"], "m kp delta": bad[0]["m kp delta"],
           "max Re(pole) [1/s]": bad[0]["max Re(pole)"],
           "why": "the plant is NNI for every m > 0, the gains satisfy the constraint with the nominal m, yet the loop "
                  f"is unstable for true m < 1/(kp delta) = {m_crit:.4g} kg"}
    correction = {
        "change": "require eq. parameter_constraint with the TRUE parameters (m_true kp_min delta >= 1/gamma), not "
                  "only NNI preservation; exact robust region: m_true > 1/(kp_min delta)",
        "symbolic": f"Routh entry with the true mass: {routh_true} > 0 <=> m_true kp delta > 1, implied by the "
                    "constraint with m_true (claim closed-loop-stability, all positive parameters)",
        f"poles on 41 true masses in [{lo:.4g}, {hi:.4g}] kg (numeric)": {"all stable": grid_ok},
        "checked": grid_ok,
    }
    return Finding(HOLDS_WITH_CORRECTION if grid_ok else FAILS,
                   f"mass uncertainty keeps the plant NNI but m_true < {m_crit:.3g} kg destabilises the paper's gains; "
                   "the bound must hold with the true mass", ev, cex, correction)
