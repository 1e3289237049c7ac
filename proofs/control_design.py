"""Audit of Sec. ``sec:control``, first half (inner loop, NNI lemma, SNI controller, steady state).

The second half (sector bound, observability, main theorem, robustness remark) is
:mod:`proofs.control_stability`; its claims register under the same section.

Frames: the horizontal rows come from the paper's ``f(x, u)``, which is NED
(see :mod:`proofs.quadrotor_model`); with ``psi = 0`` they read
``x'' = -(u1/m) c_phi s_theta`` and ``y'' = (u1/m) s_phi``.

The reduced linear loop (one axis: ``m xi'' + m kp xi = F``, ``z' = -Gamma delta z
+ Gamma xi``, ``F = z``, positive feedback) and its characteristic polynomial,
Routh array and sector bound come from :mod:`nniquad.analysis.reduced_loop`; the LMIs from
:mod:`nniquad.analysis.lmi`; the definition-level frequency checks are symbolic
(:mod:`proofs.ni_preliminaries`) with :mod:`nniquad.analysis.frequency` as a numeric
cross-check.
"""

from __future__ import annotations

import sympy as sp

from nniquad.analysis import reduced_loop_symbolic as L
from nniquad.model import symbolic as S

from .claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION, Finding, claim
from .ni_preliminaries import (
    PAPER_VALUES,
    controller_storage_analysis,
    s_var,
    sni_frequency_conditions,
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
          "nniquad.analysis.reduced_loop per-axis realisation": f"A = {a1}, B = {b1}, C = {c1}",
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


# The stability analysis, second half of the section: imported here so that its claims register after the ones
# above (the paper's order) and stay reachable as attributes of this module.
from .control_stability import (  # noqa: E402
    _closed_loop_sym,  # noqa: F401 -- the tests build variants of the interconnection from it
    closed_loop_stability,
    paper_delta_sq_threshold,
    remark_robustness,
    sector_bound,
    zero_state_observability,
)
