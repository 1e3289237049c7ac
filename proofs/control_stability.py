"""Audit of Sec. ``sec:control``, second half: the stability analysis.

The sector bound (eq. ``parameter_constraint``), zero-state observability,
Theorem ``main_result`` on the reduced linear loop and the remark on robustness.
The first half of the section (the NNI plant and the SNI controller) is
:mod:`proofs.control_design`, which imports this module so that the claims of
the whole section register in the paper's order.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import sympy as sp

from nniquad.analysis import reduced_loop_symbolic as L
from nniquad.analysis.reduced_loop import PAPER_LOOP, ReducedLoop
from nniquad.laws.nni import Gains
from nniquad.model import symbolic as S

from .claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION, Finding, claim

__all__ = [
    "paper_delta_sq_threshold",
    "sector_bound",
    "zero_state_observability",
    "closed_loop_stability",
    "remark_robustness",
]

#: The claims register under the paper's section, whichever module holds them.
SEC = "control_design"
m = S.symbols().m  # the model's mass symbol, as in proofs.control_design
gam = sp.Symbol("gamma", positive=True)
Gam, dlt, kp1 = L.SYMBOLS["Gamma"], L.SYMBOLS["delta"], L.SYMBOLS["kp"]
mL = L.SYMBOLS["m"]


def paper_delta_sq_threshold(mass: sp.Expr, kp_min: sp.Expr, gamma: sp.Expr) -> sp.Expr:
    """Eq. ``parameter_constraint``: ``delta^2 >= 1 / (gamma^2 m^2 min(kp)^2)`` -- the right-hand side."""
    return 1 / (gamma**2 * mass**2 * kp_min**2)


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
    # stability of the reduced loop: Routh region m kp delta > 1 (nniquad.analysis.reduced_loop)
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
        "Routh region of the reduced loop (nniquad.analysis.reduced_loop)": str(routh["reduced"]),
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
        A variant closed-loop matrix in the symbols of :data:`nniquad.analysis.reduced_loop.SYMBOLS`
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
    ev = {"model": "paper's compact form with the true mass: m xi'' + m Kp xi = F_h (nniquad.analysis.reduced_loop; the controller does "
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
