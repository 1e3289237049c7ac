"""Re-checks of the reduced loop's stated numbers: sector bound, poles, NI storages, decay, reach, bound.

Every matrix condition is recomputed with numpy from the certificate's own
vehicle and gains (never from stored system matrices), with the re-check
functions the LMIs use (:mod:`nniquad.analysis.lmi.checks`); each strict
inequality is proven in floating point by a verified Cholesky decomposition
(:mod:`nniquad.analysis.verified`), and the small ones again in exact rational
arithmetic.  The schema-2
``cascade`` section is rebuilt by
:func:`nniquad.analysis.cascade.box_certificate.check_cascade_section`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from nniquad.analysis.bound import time_optimal_bound
from nniquad.analysis.cascade.box_certificate import check_cascade_rows
from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.reduced_region import axis_acceleration_limit
from nniquad.analysis.verified import inequalities as V
from nniquad.analysis.verified.interval import IMat
from nniquad.certificates.certificate import Certificate
from nniquad.certificates.check_record import (
    Check,
    close,
    fmt_value,
    proof_check,
    gains_key,
    memo,
    stated_array,
    stated_part,
    thaw_json,
)
from nniquad.certificates.start import CASCADE, start_section
from nniquad.errors import CertificateError
from nniquad.laws.classes import LAW_CLASSES, within_sector_bound

__all__ = ["ni_storage_check", "same_multiset", "POLE_RTOL", "sector_check", "poles_check", "ni_checks",
           "closed_loop_check", "robust_mass_check", "roa_check", "bound_check", "cascade_checks"]


def ni_storage_check(name: str, P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray, tol: float,
                     stated_P: np.ndarray | None = None) -> Check:
    """Whether ``V = x'Px/2`` is an NI storage of ``(A, B, C)``: ``P > 0`` *and* the dissipation inequality.

    ``P > 0`` is proven (verified Cholesky and exact rationals) on ``stated_P`` (default ``P``: the stored matrix,
    before any change of coordinates); the dissipation inequality is not strict (an NI system may be lossless),
    so what is proven is ``λ_max(dissipation matrix) < tol × scale``, the tolerance the certificate states.

    Parameters
    ----------
    name
        Name of the check.
    P
        Stored storage matrix (in the coordinates of ``A, B, C``).
    A, B, C
        The system, recomputed from the certificate's vehicle and gains.
    tol
        Tolerance on :func:`nniquad.analysis.lmi.checks.dissipation_residual`.
    stated_P
        The stored matrix itself, when ``P`` is its congruence into other coordinates.
    """
    min_eig = K.eigmin(P)
    worst = K.dissipation_residual(K.sym(P), A, B, C)
    dissipation = V.below(V.ni_dissipation(P, A, B, C), tol * K.dissipation_scale(P, A, B, C),
                          f"lambda_max(NI dissipation matrix) < {tol:g} x its scale")
    proofs = V.definite(P if stated_P is None else stated_P, exact=True) + dissipation
    return proof_check(name, worst <= tol, f"min eig P = {min_eig:.3e}, max eig of the dissipation matrix "
                                           f"{worst:.2e} (relative, <= {tol:g})", proofs)


def sector_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """The stated sector numbers, recomputed; the paper class (only) needs gamma <= gamma_max."""

    loop = cert.loop
    sec = cert.sector
    try:
        gamma_stated, gamma_max = float(sec["gamma"]), float(sec["gamma_max"])
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'sector' needs numbers 'gamma' and 'gamma_max'") from None
    cls = LAW_CLASSES.get(cert.law_class_name) if isinstance(cert.law_class_name, str) else None
    bound = cls is None or cls.sector_bound  # an unknown class is refused by law_class; here judged strictly
    gamma = loop.smallest_gamma
    ok = abs(gamma - gamma_stated) <= tol["sector_relative"] * gamma and 0 < gamma_max < 1 and gamma < 1
    if bound:
        ok = ok and within_sector_bound(gamma, gamma_max)
    key, _ = loop.sector_limit(0.5)
    limit = loop.sector_limit(gamma_max)[1] if 0 < gamma_max < 1 else math.nan
    ok = ok and close(sec.get(key), limit, tol["sector_relative"])
    claim = (f"<= gamma_max = {gamma_max:g} < 1 (the paper class's sector bound)" if bound else
             f"< 1 (class {cert.law_class_name}: the sector bound with gamma_max = {gamma_max:g} is not claimed"
             f"{'' if within_sector_bound(gamma, gamma_max) else '; it does not hold'})")
    what = f"the DC loop gain {loop.law.gamma_formula} is"
    return Check("sector", ok, f"{what} gamma = {gamma:.6g} (stated {gamma_stated:.6g}) {claim}; {key} "
                               f"{limit:.6g} (stated {fmt_value(sec.get(key))})",
                 # a requirement of the classes that claim the sector bound only (the cascade class drops it)
                 requirement_met=(0 < gamma_max < 1 and within_sector_bound(gamma, gamma_max)) if bound else None)


#: Largest distance of a stated pole from its recomputed match, relative to the largest pole's modulus.
POLE_RTOL = 1e-9


def poles_check(cert: Certificate) -> Check:
    loop = cert.loop
    routh = loop.routh_margin  # 1/gamma - 1 (m kp delta - 1 for the NNI law): positive iff the loop is stable
    pd = loop.poles_and_damping()
    margin = cert.stability_margin
    stated_rate = float(margin.get("decay_rate_1_s", math.nan))
    ok = pd.stable and abs(pd.decay_rate - stated_rate) <= 1e-6 * abs(pd.decay_rate) and loop.stable
    # every other stated number of the section too: a wrong damping or pole list must not pass
    # (the poles to 1e-9 of the largest: a stated imaginary part of 1e-6 on a real pole is refused up to
    # |p| = 1000 1/s; Bauer-Fike bounds the rounding error by kappa(V) eps ||A||, kappa(V) ~ 1e2 for these loops)
    stated_poles = np.array(margin.get("poles_1_s", ()), dtype=float)
    ok = (ok and close(margin.get("routh_margin"), routh, 1e-12)
          and close(margin.get("max_real_part_1_s"), pd.max_real_part, 1e-6)
          and close(margin.get("min_damping"), pd.min_damping, 1e-6)
          and same_multiset(stated_poles, pd.poles, POLE_RTOL * float(np.max(np.abs(pd.poles)))))
    return Check("poles", ok, f"max Re = {pd.max_real_part:.6g} 1/s, decay {pd.decay_rate:.6g} 1/s "
                              f"(stated {stated_rate:.6g}), min damping {pd.min_damping:.4g}, "
                              f"Routh margin 1/gamma - 1 = {routh:.4g}")


def same_multiset(stated: np.ndarray, computed: np.ndarray, tol: float) -> bool:
    """Whether stated ``[re, im]`` rows and computed complex numbers are the same multiset within ``tol``.

    True iff the stated values can be paired one to one with the computed ones, every pair closer than ``tol``
    (a perfect matching of the bipartite graph of close pairs; Kuhn's augmenting paths), never by position: the
    eigenvalues of the two identical axes (and the two members of a conjugate pair) tie in any sort key, and
    another machine's LAPACK returns tied values in another order.

    Parameters
    ----------
    stated : array (n, 2)
        Real and imaginary parts, as stated.
    computed : array (n,), complex
        The recomputed values.
    tol
        Largest distance of a matched pair.
    """
    got = np.asarray(computed, complex).ravel()
    if stated.ndim != 2 or stated.shape != (got.size, 2) or not np.all(np.isfinite(stated)):
        return False
    close_to = np.abs((stated[:, 0] + 1j * stated[:, 1])[:, None] - got[None, :]) <= tol
    match_of: list[int] = [-1] * got.size  # computed value -> the stated row it is paired with

    def augment(row: int, seen: list[bool]) -> bool:
        for col in np.flatnonzero(close_to[row]):
            if not seen[col]:
                seen[col] = True
                if match_of[col] < 0 or augment(match_of[col], seen):
                    match_of[col] = row
                    return True
        return False

    return all(augment(row, [False] * got.size) for row in range(got.size))


def ni_checks(cert: Certificate, tol: Mapping[str, float], which: str) -> Check:
    loop = cert.loop
    A, B, C, _ = loop.plant_matrices() if which == "plant_ni" else loop.controller_matrices()
    P = stated_array(stated_part(cert.lmi, which, "lmi"), "P", A.shape, f"lmi.{which}")
    if not np.array_equal(P, P.T):
        return Check(f"lmi.{which}", False, "stored P is not symmetric")
    if which == "controller_ni":
        # judged in the controller's normalised coordinates (recomputed from the gains): the state x = T x~ and the
        # time in units of 1/w.  P > 0 and the dissipation inequality are invariant (a congruence, and M/w), and
        # there the residual's scale is the system's own: the sni2 controller's B = [0, k] would otherwise dwarf the
        # storage's terms, and a 1 % edit of P would pass; identity for NNI
        T, w = loop.controller_normalisation()
        Ti = np.linalg.inv(T)
        stated = P
        P, A, B, C = T.T @ P @ T, Ti @ A @ T / w, Ti @ B / w, C @ T
        return ni_storage_check(f"lmi.{which}", P, A, B, C, tol["lmi_relative"], stated_P=stated)
    return ni_storage_check(f"lmi.{which}", P, A, B, C, tol["lmi_relative"])


def closed_loop_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    part = stated_part(cert.lmi, "closed_loop", "lmi")
    A = cert.loop.closed_loop_A_axis()
    P = stated_array(part, "P", A.shape, "lmi.closed_loop")
    if not np.array_equal(P, P.T):
        return Check("lmi.closed_loop", False, "stored P is not symmetric")
    rate = K.certified_rate(A, P)
    stated = float(part.get("decay_rate_1_s", math.nan))
    eps = stated * (1 - tol["rate_relative"])
    if not (math.isfinite(stated) and stated > 0):
        return Check("lmi.closed_loop", False, f"stated decay rate {stated!r} is not a positive number")
    proofs = V.definite(P, exact=True) + V.decay(A, P, eps, f"-(A'P + PA + eps P) > 0, eps = {eps:.6g} 1/s", exact=True)
    return proof_check("lmi.closed_loop", rate >= eps,
                       f"P > 0 and A'P + PA <= -eps P: recomputed eps = {rate:.6g} 1/s (stated {stated:.6g}, "
                       f"proven at {eps:.6g})", proofs)


def robust_mass_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """``P0 + P1/m`` certifies the stated decay on 201 masses of the stated interval (cached by its exact inputs:
    the loop's vehicle and gains, the stated section and the tolerance)."""
    part = stated_part(cert.lmi, "robust_mass", "lmi")
    inputs = [thaw_json(part), cert.vehicle.as_dict(), gains_key(cert), tol["rate_relative"]]
    return memo("robust_mass", inputs, lambda: _robust_mass_recheck(cert, part, tol))


def _robust_mass_recheck(cert: Certificate, part: Mapping[str, Any], tol: Mapping[str, float]) -> Check:
    n = cert.loop.closed_loop_A_axis().shape[0]
    P0 = stated_array(part, "P0", (n, n), "lmi.robust_mass")
    P1 = stated_array(part, "P1", (n, n), "lmi.robust_mass")
    if not (np.array_equal(P0, P0.T) and np.array_equal(P1, P1.T)):
        return Check("lmi.robust_mass", False, "stored P0 or P1 is not symmetric")
    lo, hi, mn = (float(part.get(k, math.nan)) for k in ("m_lo_kg", "m_hi_kg", "m_nominal_kg"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    if not (0 < lo <= hi and math.isfinite(mn) and mn > 0):
        raise CertificateError("certificate lmi.robust_mass needs 0 < m_lo_kg <= m_hi_kg and m_nominal_kg > 0")
    if not (math.isfinite(stated) and stated > 0):
        return Check("lmi.robust_mass", False, f"stated decay rate {stated!r} is not a positive number")
    nominal = cert.loop.with_mass(mn)
    eps = stated * (1 - tol["rate_relative"])
    masses = 1.0 / np.linspace(1.0 / hi, 1.0 / lo, 201)
    A_m = np.stack([nominal.with_mass(mt, thrust_model=True).closed_loop_A_axis() for mt in masses])
    # P(m) = P0 + P1 (1/m), enclosed: the rounding of 1/m only picks another valid candidate of the same form
    Pm = (IMat.point(np.broadcast_to(P0, A_m.shape).copy())
          + IMat.point(np.broadcast_to(P1, A_m.shape).copy()).divided(masses)).symmetric()
    worst = min(K.certified_rate(A, P) for A, P in zip(A_m, Pm.mid))
    where = [f"m = {mt:.6g} kg" for mt in masses]
    proofs = V.definite_interval(Pm, "P0 + P1/m > 0", where)
    proofs += V.decay_interval(A_m, Pm, eps, f"-(A'P + PA + eps P) > 0, eps = {eps:.6g} 1/s", where)
    return proof_check("lmi.robust_mass", worst >= eps,
                       f"P0 + P1/m > 0 and decay >= {worst:.6g} 1/s (stated {stated:.6g}, proven at {eps:.6g}) on "
                       f"201 masses in [{lo:g}, {hi:g}] kg (the masses between them are not covered)", proofs)


def roa_check(cert: Certificate) -> Check:
    part = stated_part(cert.lmi, "region_of_attraction", "lmi")
    A0, B, Kc = cert.loop.saturation_split()
    n = A0.shape[0]
    P = stated_array(part, "P", (n, n), "lmi.region_of_attraction")
    if not np.array_equal(P, P.T):
        return Check("lmi.region_of_attraction", False, "stored P is not symmetric")
    Gm = stated_array(part, "G", (1, n), "lmi.region_of_attraction")
    T = stated_array(part, "T", (1, 1), "lmi.region_of_attraction")
    r = float(part.get("max_displacement_m", math.nan))
    u0 = axis_acceleration_limit(cert.vehicle.g, cert.tilt_limit_deg, "norm")
    Acl = A0 + B @ Kc
    dec_rel, _ = K.roa_decrease_margin(Acl, B, P, Gm, T)
    proofs = V.definite(P, exact=True) + V.roa_decrease(Acl, B, P, Gm, T, exact=True)
    positive = K.eigmin(P) > 0
    W = np.linalg.inv(P) if positive else np.full((n, n), np.nan)
    incl = K.roa_inclusion_margin(Kc, Gm, W, u0)
    level = K.ellipsoid_level(P, r * cert.loop.start_direction())  # the law's start state at the reach
    top = cert.region_of_attraction
    consistent = (top.get("max_displacement_m") == r
                  and close(part.get("u0_m_s2"), u0, 1e-12) and close(top.get("u0_m_s2"), u0, 1e-12)
                  and top.get("tilt_limit_deg") == cert.tilt_limit_deg)
    ok = positive and T[0, 0] > 0 and incl >= -1e-6 and level <= 1 + 1e-6 and r >= 0 and consistent
    return proof_check("lmi.region_of_attraction", ok,
                       f"decrease max eig {dec_rel:.2e} (relative), inclusion margin {incl:.3g} (recomputed, >= -1e-6), "
                       f"reach {r:.4g} m at level {level:.6f} <= 1, stated consistently: {consistent} (the start: the "
                       f"'start' check)",
                       proofs)


def bound_check(cert: Certificate) -> Check:
    """The time-optimal bound, recomputed; each ratio from the stated settling time and the recomputed bound."""

    b = memo("bound", [cert.vehicle.as_dict(), list(cert.xi0_m), cert.tilt_limit_deg],
              lambda: time_optimal_bound(cert.vehicle, xi0=cert.xi0_m, tilt_limit_deg=cert.tilt_limit_deg))
    ok = all(close(cert.bound.get(k), getattr(b, k), 1e-9) for k in ("enter_band_s", "rest_to_rest_s", "a_max_m_s2"))
    ratios = []
    for model in ("reduced", "full"):
        run = cert.performance.get(model)
        want = run.get("settling_s") if isinstance(run, Mapping) else None
        ratio = None if want is None else float(want) / b.enter_band_s
        stated_ratio = cert.ratio_to_bound.get(model)
        ok = ok and ((ratio is None and stated_ratio is None)
                     or (ratio is not None and close(stated_ratio, ratio, 1e-9)))
        ratios.append(f"{model} {fmt_value(ratio)} (stated {fmt_value(stated_ratio)})")
    return Check("bound", ok, f"enter band {b.enter_band_s:.5g} s (stated {fmt_value(cert.bound.get('enter_band_s'))}), rest "
                              f"to rest {b.rest_to_rest_s:.5g} s, a_max {b.a_max_m_s2:.5g} m/s^2; ratio to bound "
                              + ", ".join(ratios))


def cascade_checks(cert: Certificate, fail_fast: bool = False, thorough: bool = False) -> list[Check]:
    """The schema-2 ``cascade`` section, rebuilt by :func:`nniquad.analysis.cascade.box_certificate.check_cascade_section`
    (with ``fail_fast``, up to its first failed row; with ``thorough``, the box proven over its cells too)."""
    section = thaw_json(cert.cascade)
    if isinstance(section, dict):
        section.pop("box_search", None)  # a record (RECORD_FIELDS): how the box was found, not what is certified
        if isinstance(section.get("region_of_attraction"), dict):
            section["region_of_attraction"].pop("lure_search", None)  # a record too: how the region was found
    # a pure function of the section and the design: an edit elsewhere in the document does not re-run it
    rows = memo("cascade", [section, cert.vehicle.as_dict(), gains_key(cert), cert.inner_loop.as_dict(),
                             cert.tilt_limit_deg, list(cert.xi0_m), bool(fail_fast), bool(thorough)],
                 lambda: check_cascade_rows(section, cert.vehicle, cert.gains, cert.inner_loop,
                                            tilt_limit_deg=cert.tilt_limit_deg, xi0_m=cert.xi0_m,
                                            fail_fast=fail_fast, cache=memo, thorough=thorough))
    checks = [proof_check(f"cascade.{name}", ok, detail, proofs) if proofs else Check(f"cascade.{name}", ok, detail)
              for name, ok, detail, proofs in rows]
    for c in checks:
        if c.name == "cascade.start certified":  # a requirement: the start inside the cascade's region
            c.requirement_met = start_section(cert.xi0_m, cert.region_of_attraction, cert.cascade)["methods"][CASCADE]["inside"]
    return checks or [Check("cascade", False, "the cascade check returned no checks")]
