"""Extensions: statements the project adds to the paper and checks the same way (EXTENSION, not claims of the paper).

Every record of this section has ``kind = "extension"`` and a statement that
starts with :data:`proofs.claims.EXTENSION_PREFIX`; its ``paper_ref`` lists the
labels of the paper it builds on, not a claim the paper makes.

The notation is the project's (:mod:`nniquad.analysis.reduced_loop`): per axis
``a_h = -k_p ξ + z/m``, ``z' = -Γδ z + Γ ξ`` (``m`` the controller's mass), the
controller transfer function from :func:`nniquad.analysis.reduced_loop.controller_matrices_sym`
and the smallest sector constant from its DC loop gain
(:func:`nniquad.analysis.reduced_loop.dc_loop_gain_sym`).
"""

from __future__ import annotations

from typing import Mapping

import sympy as sp

from nniquad.analysis import reduced_loop_symbolic as L

from .claims import FAILS, HOLDS, Finding, claim

__all__ = ["filtered_pd_image", "filtered_pd_is_nni"]

SEC = "extensions"
kp, Gam, dlt, m = L.SYMBOLS["kp"], L.SYMBOLS["Gamma"], L.SYMBOLS["delta"], L.SYMBOLS["m"]
#: The filtered PD's gains (named apart from the NNI k_p of nniquad.analysis.reduced_loop).
kpd, kd, tauf = sp.symbols("k_p^PD k_d tau_f", positive=True)
sv = sp.Symbol("s")
gam = sp.Symbol("gamma", positive=True)
#: The paper's sector constant of its simulation section (gamma = 0.8).
PAPER_GAMMA = sp.Rational(4, 5)


def filtered_pd_image() -> dict[sp.Symbol, sp.Expr]:
    """The map of the filtered PD onto the NNI law: ``k_p' = k_p + k_d/τ_f``, ``Γ = m k_d/τ_f²``, ``δ = τ_f/(m k_d)``."""
    return {kp: kpd + kd / tauf, Gam: m * kd / tauf**2, dlt: tauf / (m * kd)}


def _nni_law() -> sp.Expr:
    """``a_h/ξ`` of the NNI law: ``-k_p + C(s)/m`` with C the paper's realisation (nniquad.analysis.reduced_loop)."""
    Ac, Bc, Cc, _ = L.controller_matrices_sym()
    C = (Cc * (sv * sp.eye(1) - Ac).inv() * Bc)[0, 0]
    return -kp + C / m


def _pd_law() -> sp.Expr:
    """``a_h/ξ`` of the PD law with a dirty derivative: ``-k_p - k_d s/(τ_f s + 1)``."""
    return -kpd - kd * sv / (tauf * sv + 1)


@claim("filtered-pd-is-nni", ["eq:SNI_controller", "eq:controller_state_space", "assum:sector_bound",
                              "eq:parameter_constraint", "thm:main_result"], SEC,
       "EXTENSION (not a claim of the paper): with a_h = -kp xi + z/m, z' = -Gamma delta z + Gamma xi, the PD law "
       "with a filtered derivative a_h = -k_p xi - k_d s/(tau_f s + 1) xi is the NNI law with kp' = k_p + k_d/tau_f, "
       "Gamma = m k_d/tau_f^2, delta = tau_f/(m k_d) (state z = d/delta, d the filter state), the only NNI gains "
       "giving that transfer function; the map is onto the NNI gains with m kp delta > 1 (the Routh region). Under "
       "it the sector bound delta >= 1/(gamma m kp) reads (k_p tau_f/k_d + 1) gamma >= 1: every filtered PD "
       "satisfies it with gamma = k_d/(k_p tau_f + k_d) < 1 (so Theorem main_result's hypothesis on the reduced "
       "loop), and with the paper's gamma = 0.8 exactly the designs with k_p tau_f/k_d >= 1/4.",
       "symbolic+numeric")
def filtered_pd_is_nni(image: Mapping[sp.Symbol, sp.Expr] | None = None) -> Finding:
    """Transfer function, state map, uniqueness, inverse and the sector bound under the map (sympy), and the
    library's map (:mod:`nniquad.laws.pd_filtered`) at the tuned filtered PD of the speed study (numbers; docs/notes/laws.md).

    Parameters
    ----------
    image
        The NNI gains ``{k_p, Γ, δ}`` as expressions of ``k_p^PD, k_d, τ_f, m`` (default
        :func:`filtered_pd_image`); a wrong map must fail.
    """
    img = dict(filtered_pd_image() if image is None else image)
    H_nni, H_pd = _nni_law(), _pd_law()
    tf_res = sp.simplify(H_nni.subs(img) - H_pd)
    # uniqueness: the numerator of H_nni - H_pd vanishes for all s only at one (kp, Gamma, delta)
    num = sp.Poly(sp.numer(sp.together(H_nni - H_pd)), sv)
    sols = sp.solve(num.coeffs(), [kp, Gam, dlt], dict=True)
    unique = len(sols) == 1 and all(sp.simplify(sols[0][k] - filtered_pd_image()[k]) == 0 for k in (kp, Gam, dlt))
    # state by state: z = d/delta with d' = (xi - d)/tau_f gives z' = -Gamma delta z + Gamma xi and the same a_h
    xi, d = sp.symbols("xi d", real=True)
    z = d / img[dlt]
    zdot_res = sp.simplify((xi - d) / tauf / img[dlt] - (-img[Gam] * img[dlt] * z + img[Gam] * xi))
    out_res = sp.simplify((-img[kp] * xi + z / m) - (-kpd * xi - kd * (xi - d) / tauf))
    # the inverse: every NNI gain set with m kp delta > 1 is a filtered PD (k_p = kp - 1/(m delta) > 0)
    inverse = {kpd: kp - 1 / (m * dlt), kd: 1 / (m * Gam * dlt**2), tauf: 1 / (Gam * dlt)}
    inv_res = [sp.simplify(filtered_pd_image()[k].subs(inverse) - k) for k in (kp, Gam, dlt)]
    routh = L.routh_stability_region()["reduced"].lhs  # m kp delta - 1 (> 0: the reduced loop is stable)
    kp_static_vs_routh = sp.simplify(inverse[kpd] * m * dlt - routh)
    # the sector bound under the map: gamma_min = DC loop gain = 1/(m kp delta)
    gamma_min = sp.simplify(L.dc_loop_gain_sym().subs(img))
    gamma_res = sp.simplify(gamma_min - kd / (kpd * tauf + kd))
    sector_res = sp.simplify((gam * m * kp * dlt).subs(img) - (kpd * tauf / kd + 1) * gam)
    below_one = sp.factor(1 - gamma_min)
    always_below_one = below_one.is_positive is True
    r = sp.Symbol("r", positive=True)  # r = k_p tau_f / k_d
    paper_region = sp.solve_univariate_inequality((r + 1) * PAPER_GAMMA >= 1, r, relational=False)
    ok_sym = (tf_res == 0 and unique and zdot_res == 0 and out_res == 0 and all(x == 0 for x in inv_res)
              and kp_static_vs_routh == 0 and gamma_res == 0 and sector_res == 0 and always_below_one
              and paper_region == sp.Interval(sp.Rational(1, 4), sp.oo))
    # the library's map and gamma at the tuned filtered PD of the speed study (paper's vehicle, m = 0.5 kg)
    from nniquad.analysis.reduced_loop import ReducedLoop
    from nniquad.laws.pd_filtered import PDFilteredGains, filtered_pd_gamma, nni_from_filtered_pd
    from nniquad.model.vehicle import PAPER_VEHICLE

    pd = PDFilteredGains(kp=9.111984627754474, kd=4.426807306344244, tau_f=0.05246651970835971)
    vals = {kpd: pd.kp, kd: pd.kd, tauf: pd.tau_f, m: PAPER_VEHICLE.m}
    lib = nni_from_filtered_pd(pd, PAPER_VEHICLE.m)
    sym = {k: float(img[k].subs(vals)) for k in (kp, Gam, dlt)}
    lib_dev = max(abs(getattr(lib, n) - sym[k]) / abs(sym[k]) for n, k in (("kp", kp), ("Gamma", Gam), ("delta", dlt)))
    g_sym = float(gamma_min.subs(vals))
    g_loop = ReducedLoop.from_vehicle(PAPER_VEHICLE, lib).smallest_gamma
    ratio = pd.kp * pd.tau_f / pd.kd
    ok_num = lib_dev < 1e-12 and abs(filtered_pd_gamma(pd) - g_sym) < 1e-12 and abs(g_loop - g_sym) < 1e-12
    ev = {
        "NNI law a_h/xi (project notation)": str(H_nni),
        "filtered PD a_h/xi": str(_pd_law()),
        "map (kp', Gamma, delta)": {str(k): str(v) for k, v in img.items()},
        "NNI(map) - PD, simplified": str(tf_res),
        "solutions (kp, Gamma, delta) of NNI = PD for all s": [{str(k): str(v) for k, v in s_.items()} for s_ in sols],
        "unique and equal to the map": unique,
        "state map z = d/delta: z' - (-Gamma delta z + Gamma xi) along d' = (xi - d)/tau_f": str(zdot_res),
        "state map: a_h(NNI) - a_h(PD)": str(out_res),
        "inverse k_p = kp - 1/(m delta), k_d = 1/(m Gamma delta^2), tau_f = 1/(Gamma delta): map(inverse) - id":
            [str(x) for x in inv_res],
        "k_p m delta - (Routh lhs of the reduced loop, nniquad.analysis.reduced_loop)": str(kp_static_vs_routh),
        "smallest sector gamma of the image (DC loop gain 1/(m kp delta))": str(gamma_min),
        "gamma m kp delta - (k_p tau_f/k_d + 1) gamma under the map": str(sector_res),
        "1 - gamma_min (positive for all positive k_p, k_d, tau_f)": str(below_one),
        "gamma = 0.8: region of r = k_p tau_f/k_d": str(paper_region),
        "numeric (the tuned filtered PD of the speed study, m = 0.5 kg)": {
            "k_p, k_d, tau_f": [pd.kp, pd.kd, pd.tau_f], "library map (kp, Gamma, delta)": [lib.kp, lib.Gamma, lib.delta],
            "largest relative deviation from the symbolic map": lib_dev, "gamma (symbolic / library / reduced loop)":
            [g_sym, filtered_pd_gamma(pd), g_loop], "k_p tau_f/k_d": ratio,
            "inside the paper's gamma = 0.8": bool(ratio >= 0.25)},
        "what the theorem then covers": "Theorem main_result is about the reduced continuous loop; for it the sector "
                                        "hypothesis adds nothing to Routh stability (gamma_min < 1 always). The "
                                        "project's 'paper' law class keeps the paper's gamma_max = 0.8; the "
                                        "'cascade' class drops it and relies on the sampled-data cascade certificate.",
    }
    if ok_sym and ok_num:
        return Finding(HOLDS, "the filtered PD is the NNI law under the map (unique, onto m kp delta > 1); its image "
                              "has gamma = k_d/(k_p tau_f + k_d) < 1, inside gamma = 0.8 iff k_p tau_f/k_d >= 1/4", ev)
    pt = {kpd: 2, kd: 1, tauf: sp.Rational(1, 10), m: sp.Rational(1, 2), sv: sp.I}
    return Finding(FAILS, "the map does not make the NNI law the filtered PD (or the sector statement fails)", ev,
                   {"point": "k_p = 2, k_d = 1, tau_f = 0.1, m = 0.5, s = j",
                    "NNI(map)": str(sp.nsimplify(H_nni.subs(img).subs(pt))), "PD": str(sp.nsimplify(H_pd.subs(pt)))})
