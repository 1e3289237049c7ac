"""Verifying a certificate: recompute everything it states, independently.

Every matrix condition is recomputed with numpy from the certificate's own
vehicle and gains (never from stored system matrices), with the same re-check
functions the LMIs use (:mod:`nniquad.analysis.lmi.checks`); both reference
runs are re-simulated.  Neither cvxpy nor the tuner is needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.roa import axis_acceleration_limit
from nniquad.certificates.certificate import TOLERANCES, Certificate, read_certificate
from nniquad.errors import CertificateCheckError, CertificateError, NniquadError

__all__ = ["Check", "Verification", "verify_certificate", "ni_storage_check"]


@dataclass
class Check:
    """One verification check: name, pass/fail and what was compared.

    Attributes
    ----------
    name
        What was checked (``'sector'``, ``'lmi.plant_ni'``, ...).
    ok
        Whether it passed.
    detail
        The compared numbers, in one line.
    """

    name: str
    ok: bool
    detail: str

    def __post_init__(self) -> None:
        self.ok = bool(self.ok)  # numpy comparisons give numpy booleans, which JSON refuses


@dataclass
class Verification:
    """All checks of :func:`verify_certificate`; ``ok`` only if every one passed.

    Attributes
    ----------
    checks
        The checks, in the order they ran.
    """

    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True iff there is at least one check and every check passed."""
        return bool(self.checks) and all(c.ok for c in self.checks)

    @property
    def first_failure(self) -> Check | None:
        """The first failed check, or ``None``."""
        return next((c for c in self.checks if not c.ok), None)

    def __iter__(self):
        return iter(self.checks)

    def __len__(self) -> int:
        return len(self.checks)

    def __getitem__(self, name: str) -> Check:
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def __repr__(self) -> str:
        bad = [c.name for c in self.checks if not c.ok]
        return f"Verification(ok={self.ok}, checks={len(self.checks)}, failed={bad})"

    def table(self) -> str:
        """One row per check: name, pass/FAIL, detail."""
        w = max(len(c.name) for c in self.checks) if self.checks else 5
        lines = [f"{'check':<{w}}  result  detail", f"{'-' * w}  ------  ------"]
        lines += [f"{c.name:<{w}}  {'pass' if c.ok else 'FAIL':<6}  {c.detail}" for c in self.checks]
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """``{'ok': ..., 'checks': [{'name', 'ok', 'detail'}, ...]}``."""
        return {"ok": self.ok, "checks": [{"name": c.name, "ok": c.ok, "detail": c.detail} for c in self.checks]}


def _array(cert_part: Mapping[str, Any], key: str, shape: tuple[int, int], where: str) -> np.ndarray:
    try:
        M = np.array(cert_part[key], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise CertificateError(f"certificate {where}.{key} is missing or not a numeric matrix") from None
    if M.shape != shape or not np.all(np.isfinite(M)):
        raise CertificateError(f"certificate {where}.{key} must be a finite {shape[0]}x{shape[1]} matrix")
    return M


def _part(section: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    value = section.get(key)
    if not isinstance(value, Mapping):
        raise CertificateError(f"certificate has no valid '{where}.{key}' (dict expected)")
    return value


def ni_storage_check(name: str, P: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray, tol: float) -> Check:
    """Whether ``V = x'Px/2`` is an NI storage of ``(A, B, C)``: ``P > 0`` *and* the dissipation inequality.

    Parameters
    ----------
    name
        Name of the check.
    P
        Stored storage matrix.
    A, B, C
        The system, recomputed from the certificate's vehicle and gains.
    tol
        Tolerance on :func:`nniquad.analysis.lmi.checks.dissipation_residual`.
    """
    min_eig = K.eigmin(P)
    worst = K.dissipation_residual(K.sym(P), A, B, C)
    ok = min_eig > 0 and worst <= tol
    return Check(name, ok, f"min eig P = {min_eig:.3e}, max eig of the dissipation matrix "
                           f"{worst:.2e} (relative, <= {tol:g})")


def verify_certificate(cert: Certificate | Mapping[str, Any] | str | Path, *, simulate: bool = True,
                       progress: Callable[[str], None] | None = None) -> Verification:
    """Recompute everything a certificate states, independently, with numpy and the simulator.

    Parameters
    ----------
    cert
        A :class:`Certificate`, its JSON mapping, or a file path.
    simulate
        Also re-simulate the two reference runs.
    progress
        Called with a short message before the re-simulation.

    Returns
    -------
    Verification
        One :class:`Check` per recomputed statement (the digest first).

    Raises
    ------
    CertificateError
        A form error (not JSON, wrong schema or version, digest mismatch,
        missing or malformed field); a stated number that the recomputation does
        not reproduce is a failed :class:`Check` instead.
    """
    if isinstance(cert, (str, Path)):
        cert = read_certificate(cert)
    elif not isinstance(cert, Certificate):
        cert = Certificate.from_json(cert)
    if not cert.signature_ok:
        raise CertificateCheckError("certificate: digest mismatch (content changed after signing)")
    try:
        return _verify(cert, simulate, progress or (lambda msg: None))
    except (TypeError, ValueError, KeyError, IndexError, np.linalg.LinAlgError) as exc:
        if isinstance(exc, NniquadError):
            raise
        # a signed document with a wrongly typed field: one line, not a traceback
        raise CertificateError(f"certificate has a malformed field ({type(exc).__name__}: {exc})") from None


def _verify(cert: Certificate, simulate: bool, say: Callable[[str], None]) -> Verification:
    tol = dict(TOLERANCES)
    checks = [Check("digest", True, f"sha256 {cert.signature[:16]}... matches the content")]
    vehicle, gains = cert.vehicle, cert.gains
    loop = cert.loop
    m, kp, d = vehicle.m, gains.kp, gains.delta

    sec = cert.sector
    try:
        gamma_stated, gamma_max = float(sec["gamma"]), float(sec["gamma_max"])
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'sector' needs numbers 'gamma' and 'gamma_max'") from None
    gamma = loop.smallest_gamma
    ok = abs(gamma - gamma_stated) <= tol["sector_relative"] * gamma and gamma <= gamma_max * (1 + 1e-12) < 1 + 1e-12
    delta_min = loop.sector_delta_min(gamma_max) if 0 < gamma_max < 1 else math.nan
    ok = ok and _close(sec.get("delta_min"), delta_min, tol["sector_relative"])
    checks.append(Check("sector", ok, f"delta m kp gamma >= 1 holds with gamma = {gamma:.6g} (stated "
                                      f"{gamma_stated:.6g}) <= gamma_max = {gamma_max:g} < 1; delta_min "
                                      f"{delta_min:.6g} (stated {_f(sec.get('delta_min'))})"))

    pd = loop.poles_and_damping()
    margin = cert.stability_margin
    stated_rate = float(margin.get("decay_rate_1_s", math.nan))
    ok = pd.stable and abs(pd.decay_rate - stated_rate) <= 1e-6 * abs(pd.decay_rate) and loop.stable
    # every other stated number of the section too: a wrong damping or pole list must not pass
    poles = np.array([[p.real, p.imag] for p in pd.poles])
    stated_poles = np.array(margin.get("poles_1_s", ()), dtype=float)
    ok = (ok and _close(margin.get("routh_margin"), m * kp * d - 1.0, 1e-12)
          and _close(margin.get("max_real_part_1_s"), pd.max_real_part, 1e-6)
          and _close(margin.get("min_damping"), pd.min_damping, 1e-6)
          and stated_poles.shape == poles.shape
          and bool(np.all(np.abs(stated_poles - poles) <= 1e-6 * np.max(np.abs(pd.poles)))))
    checks.append(Check("poles", ok, f"max Re = {pd.max_real_part:.6g} 1/s, decay {pd.decay_rate:.6g} 1/s "
                                     f"(stated {stated_rate:.6g}), min damping {pd.min_damping:.4g}, "
                                     f"m kp delta - 1 = {m * kp * d - 1:.4g}"))

    lmi = cert.lmi
    A, B, C, _ = loop.plant_matrices()
    checks.append(ni_storage_check("lmi.plant_ni", _array(_part(lmi, "plant_ni", "lmi"), "P", A.shape, "lmi.plant_ni"),
                                   A, B, C, tol["lmi_relative"]))
    Ac, Bc, Cc, _ = loop.controller_matrices()
    checks.append(ni_storage_check("lmi.controller_ni",
                                   _array(_part(lmi, "controller_ni", "lmi"), "P", Ac.shape, "lmi.controller_ni"),
                                   Ac, Bc, Cc, tol["lmi_relative"]))

    part = _part(lmi, "closed_loop", "lmi")
    rate = K.certified_rate(loop.closed_loop_A_axis(), _array(part, "P", (3, 3), "lmi.closed_loop"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    ok = rate >= stated * (1 - tol["rate_relative"]) and stated > 0
    checks.append(Check("lmi.closed_loop", ok, f"P > 0 and A'P + PA <= -eps P with eps = {rate:.6g} 1/s "
                                               f"(stated {stated:.6g})"))

    part = _part(lmi, "robust_mass", "lmi")
    P0 = _array(part, "P0", (3, 3), "lmi.robust_mass")
    P1 = _array(part, "P1", (3, 3), "lmi.robust_mass")
    lo, hi, mn = (float(part.get(k, math.nan)) for k in ("m_lo_kg", "m_hi_kg", "m_nominal_kg"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    if not (0 < lo <= hi and math.isfinite(mn) and mn > 0):
        raise CertificateError("certificate lmi.robust_mass needs 0 < m_lo_kg <= m_hi_kg and m_nominal_kg > 0")
    nominal = loop.with_mass(mn)
    worst = math.inf
    for mt in 1.0 / np.linspace(1.0 / hi, 1.0 / lo, 201):
        worst = min(worst, K.certified_rate(nominal.with_mass(mt, thrust_model=True).closed_loop_A_axis(), P0 + P1 / mt))
    ok = worst >= stated * (1 - tol["rate_relative"]) and stated > 0
    checks.append(Check("lmi.robust_mass", ok, f"P0 + P1/m > 0 and decay >= {worst:.6g} 1/s (stated {stated:.6g}) "
                                               f"on 201 masses in [{lo:g}, {hi:g}] kg"))

    checks.append(_roa_check(cert, tol["lmi_relative"]))
    if cert.margins is not None:
        checks.append(_margins_check(cert, tol))

    if simulate:
        say("re-simulating the reference runs")
        checks += _performance_checks(cert, tol)
    return Verification(checks)


def _roa_check(cert: Certificate, tol: float) -> Check:
    part = _part(cert.lmi, "region_of_attraction", "lmi")
    P = K.sym(_array(part, "P", (3, 3), "lmi.region_of_attraction"))
    Gm = _array(part, "G", (1, 3), "lmi.region_of_attraction")
    T = _array(part, "T", (1, 1), "lmi.region_of_attraction")
    r = float(part.get("max_displacement_m", math.nan))
    u0 = axis_acceleration_limit(cert.vehicle.g, cert.tilt_limit_deg, "norm")
    A0, B, Kc = cert.loop.saturation_split()
    Acl = A0 + B @ Kc
    dec = K.roa_decrease_matrix(Acl, B, P, Gm, T)
    dec_rel = K.eigmax(dec) / max(K.norm(dec), 1e-300)
    positive = K.eigmin(P) > 0
    W = np.linalg.inv(P) if positive else np.full((3, 3), np.nan)
    incl = K.roa_inclusion_margin(Kc, Gm, W, u0)
    level = K.ellipsoid_level(P, [r, 0.0, 0.0])
    top = cert.region_of_attraction
    start = cert.start_certified
    consistent = (top.get("max_displacement_m") == r and start == bool(math.hypot(*cert.xi0_m) <= r)
                  and _close(part.get("u0_m_s2"), u0, 1e-12) and _close(top.get("u0_m_s2"), u0, 1e-12)
                  and top.get("tilt_limit_deg") == cert.tilt_limit_deg)
    ok = (positive and T[0, 0] > 0 and dec_rel < tol and incl >= -1e-6 and level <= 1 + 1e-6 and r >= 0
          and consistent)
    return Check("lmi.region_of_attraction", ok,
                 f"decrease max eig {dec_rel:.2e} (relative, <= {tol:g}), inclusion margin {incl:.3g}, reach {r:.4g} m "
                 f"at level {level:.6f} <= 1, start_certified = {start} consistent: {consistent}")


def _same_margin(stated: Any, computed: Any, tol: float, relative: bool = False) -> bool:
    """A stated margin number (or ``"inf"``/``"-inf"``/``"nan"`` string, or bool) against the recomputed one."""
    if isinstance(computed, bool) or isinstance(stated, bool):
        return stated is computed
    if isinstance(computed, str) or isinstance(stated, str):
        return isinstance(stated, str) and isinstance(computed, str) and stated == computed
    if not isinstance(stated, (int, float)):
        return False
    err = abs(float(stated) - float(computed))
    return err <= (tol * max(abs(float(computed)), 1e-12) if relative else tol)


def _margins_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """Recompute the classical margins from the vehicle, the gains and the inner loops (never stored matrices)."""
    from nniquad.certificates.build import MARGIN_FIELDS, margins_section, sector_pm_ceiling_deg

    stated = cert.margins
    try:
        rate = float(stated["rate_hz"])
        gamma_max = float(cert.sector["gamma_max"])
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'margins' needs a number 'rate_hz'") from None
    if stated.get("controller") != "discrete" or stated.get("pade_order") != 2:
        return Check("margins", False, "margins stated for another sampling model than the one recomputed")
    fresh = margins_section(cert.vehicle, cert.gains, cert.inner_loop, tilt_limit_deg=cert.tilt_limit_deg,
                            gamma_max=gamma_max, rate_hz=rate)
    ok = True
    bad: list[str] = []
    points = stated.get("break_points")
    if not isinstance(points, Mapping) or set(points) != set(fresh["break_points"]):
        return Check("margins", False, "margins: the break points stated differ from the recomputed ones")
    for name, comp in fresh["break_points"].items():
        st = points[name]
        for key in MARGIN_FIELDS:
            if key.endswith("_db"):
                same = _same_margin(st.get(key), comp[key], tol["margin_db_abs"])
            elif key.endswith("_deg"):
                same = _same_margin(st.get(key), comp[key], tol["margin_deg_abs"])
            elif key.endswith("_rad_s"):
                same = _same_margin(st.get(key), comp[key], tol["margin_freq_relative"], relative=True)
            else:
                same = _same_margin(st.get(key), comp[key], 0.0)
            if not same:
                ok = False
                bad.append(f"{name}.{key} {st.get(key)!r} (recomputed {comp[key]!r})")
    ok = ok and stated.get("meets_requirement") is fresh["meets_requirement"]
    ok = ok and isinstance(stated.get("required"), Mapping) and dict(stated["required"]) == fresh["required"]
    ok = ok and _close(stated.get("horizontal_pm_ceiling_deg"), sector_pm_ceiling_deg(gamma_max), 1e-12)
    h, a = fresh["break_points"]["horizontal"], fresh["break_points"]["attitude"]
    detail = (f"horizontal GM +{h['gm_db']}/{h['gm_lower_db']} dB PM {h['pm_deg']} deg; attitude GM +{a['gm_db']}/"
              f"{a['gm_lower_db']} dB PM {a['pm_deg']} deg at {rate:g} Hz; meets GM >= {fresh['required']['gm_db']:g} dB, "
              f"PM >= {fresh['required']['pm_deg']:g} deg: {fresh['meets_requirement']}")
    if bad:
        detail += "; differs: " + ", ".join(bad[:3])
    return Check("margins", ok, detail)


def _performance_checks(cert: Certificate, tol: Mapping[str, float]) -> list[Check]:
    from nniquad.sim import SimOptions, simulate

    from nniquad.analysis.bound import time_optimal_bound

    bound = time_optimal_bound(cert.vehicle, xi0=cert.xi0_m, tilt_limit_deg=cert.tilt_limit_deg)
    bound_ok = all(_close(cert.bound.get(k), getattr(bound, k), 1e-9)
                   for k in ("enter_band_s", "rest_to_rest_s", "a_max_m_s2"))
    out = []
    for model in ("reduced", "full"):
        stated = cert.performance.get(model)
        if not isinstance(stated, Mapping) or not isinstance(stated.get("settings"), Mapping):
            raise CertificateError(f"certificate performance.{model} is missing or has no settings")
        settings = {k: (list(v) if isinstance(v, tuple) else v) for k, v in stated["settings"].items()}
        settings.pop("inner", None)
        try:
            opts = SimOptions(**{**settings, "xi0": tuple(settings.get("xi0", cert.xi0_m)),
                                 "zc0": tuple(settings.get("zc0", (0.0, 0.0))),
                                 "wind_N": tuple(settings.get("wind_N", (0.0, 0.0))), "inner": cert.inner_loop})
        except (TypeError, NniquadError) as exc:
            raise CertificateError(f"certificate performance.{model}.settings: {exc}") from None
        met = simulate(cert.vehicle, cert.gains, opts)[0].metrics()
        diffs = []
        ok = True
        for key, tkey in (("settling_s", "settling_abs_s"), ("overshoot_pct", "overshoot_abs_pct"),
                          ("peak_tilt_deg", "tilt_abs_deg")):
            want, got = stated.get(key), getattr(met, key)
            if want is None or got is None:
                same = want is None and got is None
            else:
                same = abs(float(want) - float(got)) <= tol[tkey]
            ok &= same
            diffs.append(f"{key} {_f(got)} (stated {_f(want)})")
        # the ratio to the time-optimal bound, from the stated settling time and the recomputed bound
        want = stated.get("settling_s")
        ratio = None if want is None else float(want) / bound.enter_band_s
        stated_ratio = cert.ratio_to_bound.get(model)
        same = (ratio is None and stated_ratio is None) or (ratio is not None and _close(stated_ratio, ratio, 1e-9))
        ok = ok and same and bound_ok
        diffs.append(f"ratio to bound {_f(ratio)} (stated {_f(stated_ratio)}), bound {bound.enter_band_s:.5g} s "
                     f"(stated {_f(cert.bound.get('enter_band_s'))})")
        out.append(Check(f"performance.{model}", ok, ", ".join(diffs)))
    return out


def _close(stated: Any, computed: float, rtol: float) -> bool:
    """Whether a stated number (any JSON value) equals a recomputed one within ``rtol`` (relative, and absolute near 0)."""
    if isinstance(stated, bool) or not isinstance(stated, (int, float)):
        return False
    return math.isfinite(stated) and abs(float(stated) - computed) <= rtol * max(abs(computed), 1e-300) + 1e-300


def _f(x: Any) -> str:
    return "none" if x is None else f"{float(x):.5g}"
