"""Certificates: a gain set with everything needed to check it, and the independent check.

A certificate is one JSON document (:data:`SCHEMA`, :data:`SCHEMA_VERSION`):

``vehicle``, ``gains``, ``inner_loop``, ``tilt_limit_deg``, ``xi0_m``
    What is certified: the vehicle, the horizontal gains ``kp, Gamma, delta``,
    the inner loops the ``full`` performance was measured with, the tilt
    limit and the initial position of the reference run.
``sector``
    ``gamma`` (the smallest γ the gains satisfy ``δ >= 1/(γ m kp)`` with),
    ``gamma_max`` and ``delta_min = 1/(γ_max m kp)``.
``stability_margin``
    ``m kp δ - 1`` (the exact Routh condition is ``> 0``), the slowest pole's
    real part, the decay rate ``-2 max Re λ`` and the smallest damping ratio.
``lmi``
    The matrices: the plant's and the controller's NI certificates (the
    dissipation form ``V̇ <= ẏᵀu``, see :mod:`nniquad.analysis.lmi`), the closed-loop
    Lyapunov ``P`` with its decay rate, the parameter-dependent ``P0 + P1/m``
    over the mass interval (thrust sized with the nominal mass), and the
    saturation region-of-attraction ellipsoid ``P`` with its multipliers ``G, T``.
``region_of_attraction``, ``start_certified``
    The largest certified displacement from rest, and whether ``xi0_m`` is inside.
``performance``
    ``reduced`` and ``full``: settling time, overshoot, peak tilt and the exact
    simulation settings, so that :func:`verify_certificate` can re-simulate.
``bound``, ``ratio_to_bound``
    The time-optimal bound and each model's settling time divided by it.
``software``
    Package versions.  ``digest``: SHA-256 of the canonical JSON of everything
    else (sorted keys, no whitespace, UTF-8).

:func:`verify_certificate` recomputes every matrix condition with numpy from
the certificate's own vehicle and gains (never from stored system matrices),
re-runs both simulations and checks the digest.  It needs neither cvxpy nor
the tuner.
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.errors import CertificateError, GainError, NniquadError, VehicleError
from nniquad.control.gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.io import atomic_write_text
from nniquad.analysis.linear import closed_loop_A_axis, controller_matrices, plant_matrices, poles_and_damping, saturation_split, sector_delta_min, smallest_gamma
from nniquad.control.gains import Gains
from nniquad.model.vehicle import Vehicle

__all__ = [
    "SCHEMA",
    "SCHEMA_VERSION",
    "TOLERANCES",
    "Check",
    "Verification",
    "build_certificate",
    "write_certificate",
    "load_certificate",
    "verify_certificate",
    "canonical_digest",
    "certificate_gains",
    "certificate_vehicle",
    "certificate_inner_loop",
]

SCHEMA = "nniquad-certificate"
SCHEMA_VERSION = 1

#: Tolerances of :func:`verify_certificate` (stored in every certificate for the record).
TOLERANCES: dict[str, float] = {
    "lmi_relative": 1e-7,        # largest eigenvalue of a Lyapunov expression, relative to its scale
    "rate_relative": 1e-6,       # certified decay rate may fall short of the stated one by this fraction
    "sector_relative": 1e-9,     # recomputed smallest gamma vs stated
    "settling_abs_s": 2e-3,      # re-simulated settling time vs stated
    "overshoot_abs_pct": 0.05,   # re-simulated overshoot vs stated (percentage points)
    "tilt_abs_deg": 0.02,        # re-simulated peak tilt vs stated
}

#: Default horizon of the certificate's performance runs [s].
PERFORMANCE_HORIZON_S = 20.0


# ----------------------------------------------------------------------------- accessors


def _get(cert: Mapping[str, Any], key: str, kind: type = dict) -> Any:
    value = cert.get(key) if isinstance(cert, Mapping) else None
    if not isinstance(value, kind):
        raise CertificateError(f"certificate has no valid '{key}' ({kind.__name__} expected)")
    return value


def certificate_gains(cert: Mapping[str, Any]) -> Gains:
    """The certified gain set."""
    g = _get(cert, "gains")
    missing = [k for k in ("kp", "Gamma", "delta") if k not in g]
    if missing:
        raise CertificateError(f"certificate 'gains' lacks '{missing[0]}'")
    try:
        return Gains(kp=g["kp"], Gamma=g["Gamma"], delta=g["delta"])
    except (GainError, TypeError) as exc:
        raise CertificateError(f"certificate gains: {exc}") from None


def certificate_vehicle(cert: Mapping[str, Any]) -> Vehicle:
    """The certified vehicle (validated as any vehicle file is)."""
    from nniquad.model.vehicle import vehicle_from_mapping

    try:
        return vehicle_from_mapping(_get(cert, "vehicle"), source="certificate")
    except VehicleError as exc:
        raise CertificateError(f"certificate vehicle: {exc}") from None


def certificate_inner_loop(cert: Mapping[str, Any]) -> InnerLoopGains:
    """The inner-loop gains the ``full`` performance was measured with."""
    data = cert.get("inner_loop", DEFAULT_INNER_LOOP_GAINS.as_dict())
    if not isinstance(data, Mapping):
        raise CertificateError("certificate 'inner_loop' must be an object")
    try:
        return InnerLoopGains(**data)
    except TypeError as exc:
        raise CertificateError(f"certificate inner_loop: {exc}") from None
    except NniquadError as exc:
        raise CertificateError(f"certificate inner_loop: {exc}") from None


def canonical_digest(cert: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of the certificate without its ``digest``."""
    body = {k: v for k, v in cert.items() if k != "digest"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def load_certificate(path: str | Path) -> dict[str, Any]:
    """Read a certificate and check its form: JSON, schema, version, digest.

    Raises
    ------
    CertificateError
        One line naming the problem (unreadable, not JSON, wrong schema or
        version, digest mismatch).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise CertificateError(f"cannot read certificate {p}: {exc.strerror or exc}") from None
    try:
        cert = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CertificateError(f"certificate {p} is not valid JSON ({exc.msg}, line {exc.lineno})") from None
    _check_form(cert, str(p))
    return cert


def _check_form(cert: Any, where: str = "certificate") -> None:
    if not isinstance(cert, dict):
        raise CertificateError(f"{where}: top level must be a JSON object")
    if cert.get("schema") != SCHEMA:
        raise CertificateError(f"{where}: schema is {cert.get('schema')!r}, expected {SCHEMA!r}")
    if cert.get("schema_version") != SCHEMA_VERSION:
        raise CertificateError(
            f"{where}: schema version {cert.get('schema_version')!r} is not supported (expected {SCHEMA_VERSION})"
        )
    digest = cert.get("digest")
    if not isinstance(digest, dict) or not isinstance(digest.get("value"), str):
        raise CertificateError(f"{where}: no digest")
    try:
        actual = canonical_digest(cert)
    except (TypeError, ValueError) as exc:
        raise CertificateError(f"{where}: content cannot be canonicalised ({exc})") from None
    if actual != digest["value"]:
        raise CertificateError(f"{where}: digest mismatch (content changed after signing)")


# ----------------------------------------------------------------------------- building


def _software() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for pkg in ("nniquad", "numpy", "scipy", "casadi", "cvxpy", "clarabel", "sympy", "control"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "unknown"
    return out


def _mat(M: np.ndarray) -> list[list[float]]:
    return np.asarray(M, dtype=float).tolist()


def performance_runs(vehicle: Vehicle, gains: Gains, inner: InnerLoopGains, *, tilt_limit_deg: float = 30.0,
                     xi0: Sequence[float] = (2.0, -1.5), horizon_s: float = PERFORMANCE_HORIZON_S,
                     motor_lag: bool = True) -> dict[str, Any]:
    """Settings and metrics of the two reference runs (``reduced`` and ``full``)."""
    from nniquad.sim import SimOptions, simulate

    out = {}
    for model in ("reduced", "full"):
        opts = SimOptions(model=model, horizon_s=horizon_s, output_dt_s=0.005, tilt_limit_deg=tilt_limit_deg,
                          xi0=tuple(xi0), motor_lag=motor_lag and model == "full", inner=inner)
        met = simulate(vehicle, gains, opts)[0].metrics()
        out[model] = {"settling_s": met.settling_s, "overshoot_pct": met.overshoot_pct,
                      "peak_tilt_deg": met.peak_tilt_deg, "diverged": met.diverged, "settings": opts.to_json()}
    return out


def build_certificate(vehicle: Vehicle, gains: Gains, *, inner: InnerLoopGains = DEFAULT_INNER_LOOP_GAINS,
                      gamma_max: float = 0.8, tilt_limit_deg: float = 30.0,
                      mass_range: tuple[float, float] | None = None, xi0: Sequence[float] = (2.0, -1.5),
                      model: str = "reduced", tuning: Mapping[str, Any] | None = None,
                      progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Solve every LMI for ``gains``, simulate, and assemble a signed certificate.

    Raises
    ------
    CertificateError
        The gains violate the sector bound for ``gamma_max``, or an LMI is
        infeasible (nothing is certified, so nothing is returned).
    """
    from nniquad.analysis.bound import time_optimal_bound
    from nniquad.analysis.lmi import (axis_acceleration_limit, closed_loop_decay, ni_lemma_dissipation, region_of_attraction,
                      robust_mass_decay)

    say = progress or (lambda msg: None)
    if gains.kpy is not None and gains.kpy != gains.kp:
        raise CertificateError("certificates cover equal axis gains only (kpy must equal kp)")
    if not 0.0 < gamma_max < 1.0:
        raise CertificateError(f"gamma_max must lie in (0, 1), got {gamma_max!r}")
    m, kp = vehicle.m, gains.kp
    gamma = smallest_gamma(m, kp, None, gains.delta)
    if gamma > gamma_max * (1 + 1e-12):
        raise CertificateError(
            f"gains violate the sector bound: delta = {gains.delta:.6g} < 1/(gamma_max m kp) = "
            f"{sector_delta_min(m, kp, gamma_max):.6g} (smallest gamma {gamma:.6g} > gamma_max {gamma_max:g})"
        )
    lo, hi = mass_range if mass_range is not None else (0.8 * m, 1.2 * m)
    say("solving the LMIs")
    A, B, C, D = plant_matrices(m, kp)
    plant = ni_lemma_dissipation(A, B, C, D, name="ni_lemma_dissipation[plant]")
    Ac, Bc, Cc, _ = controller_matrices(gains.Gamma, gains.delta)
    ctrl = ni_lemma_dissipation(Ac, Bc, Cc, name="ni_lemma_dissipation[controller]")
    cl = closed_loop_decay(m, gains)
    rob = robust_mass_decay(lo, hi, gains, parameter_dependent=True, m_nominal=m)
    u0 = axis_acceleration_limit(vehicle.g, tilt_limit_deg, "norm")
    roa = region_of_attraction(m, kp, gains.Gamma, gains.delta, u0)
    for res in (plant, ctrl, cl, rob, roa):
        if not res.feasible:
            raise CertificateError(f"LMI {res.name} is infeasible for these gains (solver status {res.status})")
    pd = poles_and_damping(m, kp, gains.Gamma, gains.delta)
    reach = float(roa.values["max_displacement_m"])
    say("simulating the reference runs")
    perf = performance_runs(vehicle, gains, inner, tilt_limit_deg=tilt_limit_deg, xi0=xi0)
    bound = time_optimal_bound(vehicle, xi0=xi0, tilt_limit_deg=tilt_limit_deg)
    ratios = {k: (None if v["settling_s"] is None else v["settling_s"] / bound.enter_band_s) for k, v in perf.items()}
    cert: dict[str, Any] = {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "model": model,
        "vehicle": vehicle.as_dict(),
        "gains": {"kp": kp, "Gamma": gains.Gamma, "delta": gains.delta},
        "inner_loop": inner.as_dict(),
        "tilt_limit_deg": float(tilt_limit_deg),
        "xi0_m": [float(xi0[0]), float(xi0[1])],
        "sector": {"gamma": gamma, "gamma_max": float(gamma_max), "delta_min": sector_delta_min(m, kp, gamma_max)},
        "stability_margin": {
            "routh_margin": m * kp * gains.delta - 1.0,
            "max_real_part_1_s": float(pd.max_real_part),
            "decay_rate_1_s": float(pd.decay_rate),
            "min_damping": float(pd.min_damping),
            "poles_1_s": [[float(p.real), float(p.imag)] for p in pd.poles],
        },
        "lmi": {
            "plant_ni": {"P": _mat(plant.matrices["P"]), "form": "V' <= ydot' u (dissipation)"},
            "controller_ni": {"P": _mat(ctrl.matrices["P"]), "form": "V' <= ydot' u (dissipation)"},
            "closed_loop": {"P": _mat(cl.matrices["P"]), "decay_rate_1_s": float(cl.values["decay_rate"])},
            "robust_mass": {"m_lo_kg": float(lo), "m_hi_kg": float(hi), "m_nominal_kg": m,
                            "P0": _mat(rob.matrices["P0"]), "P1": _mat(rob.matrices["P1"]),
                            "decay_rate_1_s": float(rob.values["decay_rate"])},
            "region_of_attraction": {"P": _mat(roa.matrices["P"]), "G": _mat(roa.matrices["G"]),
                                     "T": _mat(roa.matrices["T"]), "u0_m_s2": u0,
                                     "max_displacement_m": reach},
        },
        "region_of_attraction": {"max_displacement_m": reach, "u0_m_s2": u0, "tilt_limit_deg": float(tilt_limit_deg),
                                 "model": "norm-limited horizontal acceleration, rotation-invariant ellipsoid"},
        "start_certified": bool(math.hypot(*xi0) <= reach),
        "performance": perf,
        "bound": {"enter_band_s": bound.enter_band_s, "rest_to_rest_s": bound.rest_to_rest_s,
                  "a_max_m_s2": bound.a_max_m_s2},
        "ratio_to_bound": ratios,
        "tolerances": dict(TOLERANCES),
        "tuning": dict(tuning) if tuning is not None else None,
        "software": _software(),
    }
    cert["digest"] = {"algorithm": "sha256", "value": canonical_digest(cert)}
    return cert


def write_certificate(cert: Mapping[str, Any], path: str | Path) -> Path:
    """Write atomically (temporary file, then rename); the certificate's form is checked first."""
    _check_form(dict(cert))
    return atomic_write_text(Path(path), json.dumps(cert, indent=2, allow_nan=False) + "\n")


# ----------------------------------------------------------------------------- verification


@dataclass
class Check:
    """One verification check: name, pass/fail and what was compared."""

    name: str
    ok: bool
    detail: str

    def __post_init__(self) -> None:
        self.ok = bool(self.ok)  # numpy comparisons give numpy booleans, which JSON refuses


@dataclass
class Verification:
    """All checks of :func:`verify_certificate`; ``ok`` only if every one passed."""

    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return bool(self.checks) and all(c.ok for c in self.checks)

    @property
    def first_failure(self) -> Check | None:
        return next((c for c in self.checks if not c.ok), None)

    def table(self) -> str:
        w = max(len(c.name) for c in self.checks) if self.checks else 5
        lines = [f"{'check':<{w}}  result  detail", f"{'-' * w}  ------  ------"]
        lines += [f"{c.name:<{w}}  {'pass' if c.ok else 'FAIL':<6}  {c.detail}" for c in self.checks]
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        return {"ok": self.ok, "checks": [{"name": c.name, "ok": c.ok, "detail": c.detail} for c in self.checks]}


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + M.T)


def _array(cert_part: Mapping[str, Any], key: str, shape: tuple[int, int], where: str) -> np.ndarray:
    try:
        M = np.array(cert_part[key], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise CertificateError(f"certificate {where}.{key} is missing or not a numeric matrix") from None
    if M.shape != shape or not np.all(np.isfinite(M)):
        raise CertificateError(f"certificate {where}.{key} must be a finite {shape[0]}x{shape[1]} matrix")
    return M


def _rel_max_eig(M: np.ndarray, scale: float) -> float:
    return float(np.max(np.linalg.eigvalsh(_sym(M)))) / max(scale, 1e-300)


def _rate(A: np.ndarray, P: np.ndarray) -> float:
    """Decay rate ``P`` certifies for ``A`` (largest eps with A'P + PA <= -eps P); -inf unless P > 0."""
    P = _sym(P)
    if np.min(np.linalg.eigvalsh(P)) <= 0:
        return -math.inf
    Li = np.linalg.inv(np.linalg.cholesky(P))
    return -float(np.max(np.linalg.eigvalsh(_sym(Li @ (A.T @ P + P @ A) @ Li.T))))


def _ni_check(name: str, part: Mapping[str, Any], A, B, C, tol: float) -> Check:
    from nniquad.analysis.lmi import ni_dissipation_matrix

    P = _array(part, "P", A.shape, f"lmi.{name}")
    min_eig = float(np.min(np.linalg.eigvalsh(_sym(P))))
    M = ni_dissipation_matrix(_sym(P), A, B, C)
    scale = max(np.linalg.norm(P, 2) * np.linalg.norm(A, 2), np.linalg.norm(A, 2) * np.linalg.norm(C) * np.linalg.norm(B),
                np.linalg.norm(C) * np.linalg.norm(B))
    worst = _rel_max_eig(M, scale)
    ok = min_eig > 0 and worst <= tol
    return Check(f"lmi.{name}", ok, f"min eig P = {min_eig:.3e}, max eig of the dissipation matrix "
                                    f"{worst:.2e} (relative, <= {tol:g})")


def verify_certificate(cert: Mapping[str, Any] | str | Path, *, simulate: bool = True,
                       progress: Callable[[str], None] | None = None) -> Verification:
    """Recompute everything a certificate states, independently, with numpy and the simulator.

    A form error (not JSON, wrong schema or version, digest mismatch, missing
    or malformed field) raises :class:`CertificateError`; a stated number that
    the recomputation does not reproduce is a failed :class:`Check`.
    """
    if not isinstance(cert, Mapping):
        cert = load_certificate(cert)
    cert = dict(cert)
    _check_form(cert)
    try:
        return _verify(cert, simulate, progress or (lambda msg: None))
    except (TypeError, ValueError, KeyError, IndexError, np.linalg.LinAlgError) as exc:
        # a signed document with a wrongly typed field: one line, not a traceback
        raise CertificateError(f"certificate has a malformed field ({type(exc).__name__}: {exc})") from None


def _verify(cert: dict[str, Any], simulate: bool, say: Callable[[str], None]) -> Verification:
    tol = dict(TOLERANCES)
    checks = [Check("digest", True, f"sha256 {cert['digest']['value'][:16]}... matches the content")]
    vehicle, gains, inner = certificate_vehicle(cert), certificate_gains(cert), certificate_inner_loop(cert)
    m, kp, G, d = vehicle.m, gains.kp, gains.Gamma, gains.delta

    sec = _get(cert, "sector")
    try:
        gamma_stated, gamma_max = float(sec["gamma"]), float(sec["gamma_max"])
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'sector' needs numbers 'gamma' and 'gamma_max'") from None
    gamma = smallest_gamma(m, kp, None, d)
    ok = abs(gamma - gamma_stated) <= tol["sector_relative"] * gamma and gamma <= gamma_max * (1 + 1e-12) < 1 + 1e-12
    checks.append(Check("sector", ok, f"delta m kp gamma >= 1 holds with gamma = {gamma:.6g} (stated "
                                      f"{gamma_stated:.6g}) <= gamma_max = {gamma_max:g} < 1"))

    pd = poles_and_damping(m, kp, G, d)
    margin = _get(cert, "stability_margin")
    stated_rate = float(margin.get("decay_rate_1_s", math.nan))
    ok = pd.stable and abs(pd.decay_rate - stated_rate) <= 1e-6 * abs(pd.decay_rate) and m * kp * d > 1
    checks.append(Check("poles", ok, f"max Re = {pd.max_real_part:.6g} 1/s, decay {pd.decay_rate:.6g} 1/s "
                                     f"(stated {stated_rate:.6g}), min damping {pd.min_damping:.4g}, "
                                     f"m kp delta - 1 = {m * kp * d - 1:.4g}"))

    lmi = _get(cert, "lmi")
    A, B, C, _ = plant_matrices(m, kp)
    checks.append(_ni_check("plant_ni", _get(lmi, "plant_ni"), A, B, C, tol["lmi_relative"]))
    Ac, Bc, Cc, _ = controller_matrices(G, d)
    checks.append(_ni_check("controller_ni", _get(lmi, "controller_ni"), Ac, Bc, Cc, tol["lmi_relative"]))

    part = _get(lmi, "closed_loop")
    Acl = closed_loop_A_axis(m, kp, G, d)
    rate = _rate(Acl, _array(part, "P", (3, 3), "lmi.closed_loop"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    ok = rate >= stated * (1 - tol["rate_relative"]) and stated > 0
    checks.append(Check("lmi.closed_loop", ok, f"P > 0 and A'P + PA <= -eps P with eps = {rate:.6g} 1/s "
                                               f"(stated {stated:.6g})"))

    part = _get(lmi, "robust_mass")
    P0 = _array(part, "P0", (3, 3), "lmi.robust_mass")
    P1 = _array(part, "P1", (3, 3), "lmi.robust_mass")
    lo, hi, mn = (float(part.get(k, math.nan)) for k in ("m_lo_kg", "m_hi_kg", "m_nominal_kg"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    if not (0 < lo <= hi and math.isfinite(mn) and mn > 0):
        raise CertificateError("certificate lmi.robust_mass needs 0 < m_lo_kg <= m_hi_kg and m_nominal_kg > 0")
    A0, Bs, K = saturation_split(mn, kp, G, d)
    worst = math.inf
    for mt in 1.0 / np.linspace(1.0 / hi, 1.0 / lo, 201):
        worst = min(worst, _rate(A0 + (mn / mt) * (Bs @ K), P0 + P1 / mt))
    ok = worst >= stated * (1 - tol["rate_relative"]) and stated > 0
    checks.append(Check("lmi.robust_mass", ok, f"P0 + P1/m > 0 and decay >= {worst:.6g} 1/s (stated {stated:.6g}) "
                                               f"on 201 masses in [{lo:g}, {hi:g}] kg"))

    checks.append(_roa_check(cert, lmi, vehicle, gains, tol["lmi_relative"]))

    if simulate:
        say("re-simulating the reference runs")
        checks += _performance_checks(cert, vehicle, gains, inner, tol)
    return Verification(checks)


def _roa_check(cert: Mapping[str, Any], lmi: Mapping[str, Any], vehicle: Vehicle, gains: Gains, tol: float) -> Check:
    from nniquad.analysis.lmi import axis_acceleration_limit

    part = _get(lmi, "region_of_attraction")
    P = _sym(_array(part, "P", (3, 3), "lmi.region_of_attraction"))
    Gm = _array(part, "G", (1, 3), "lmi.region_of_attraction")
    T = _array(part, "T", (1, 1), "lmi.region_of_attraction")
    r = float(part.get("max_displacement_m", math.nan))
    u0 = axis_acceleration_limit(vehicle.g, float(cert.get("tilt_limit_deg", 30.0)), "norm")
    A0, B, K = saturation_split(vehicle.m, gains.kp, gains.Gamma, gains.delta)
    Acl = A0 + B @ K
    dec = np.block([[Acl.T @ P + P @ Acl, -P @ B + Gm.T @ T], [-B.T @ P + T @ Gm, -2 * T]])
    dec_rel = _rel_max_eig(dec, np.linalg.norm(dec, 2))
    W = np.linalg.inv(P) if np.min(np.linalg.eigvalsh(P)) > 0 else np.full((3, 3), np.nan)
    incl = float(u0**2 - ((K - Gm) @ W @ (K - Gm).T)[0, 0]) / u0**2
    level = float(r * r * P[0, 0])
    top = cert.get("region_of_attraction", {})
    start = cert.get("start_certified")
    xi0 = cert.get("xi0_m", [2.0, -1.5])
    consistent = (isinstance(top, Mapping) and top.get("max_displacement_m") == r
                  and start == bool(math.hypot(*xi0) <= r))
    ok = (np.min(np.linalg.eigvalsh(P)) > 0 and T[0, 0] > 0 and dec_rel < tol and incl >= -1e-6
          and level <= 1 + 1e-6 and r >= 0 and consistent)
    return Check("lmi.region_of_attraction", ok,
                 f"decrease max eig {dec_rel:.2e} (relative, <= {tol:g}), inclusion margin {incl:.3g}, reach {r:.4g} m "
                 f"at level {level:.6f} <= 1, start_certified = {start} consistent: {consistent}")


def _performance_checks(cert: Mapping[str, Any], vehicle: Vehicle, gains: Gains, inner: InnerLoopGains,
                        tol: Mapping[str, float]) -> list[Check]:
    from nniquad.sim import SimOptions, simulate

    perf = _get(cert, "performance")
    out = []
    for model in ("reduced", "full"):
        stated = perf.get(model)
        if not isinstance(stated, Mapping) or not isinstance(stated.get("settings"), Mapping):
            raise CertificateError(f"certificate performance.{model} is missing or has no settings")
        settings = dict(stated["settings"])
        settings.pop("inner", None)
        try:
            opts = SimOptions(**{**settings, "xi0": tuple(settings.get("xi0", (2.0, -1.5))),
                                 "zc0": tuple(settings.get("zc0", (0.0, 0.0))),
                                 "wind_N": tuple(settings.get("wind_N", (0.0, 0.0))), "inner": inner})
        except (TypeError, NniquadError) as exc:
            raise CertificateError(f"certificate performance.{model}.settings: {exc}") from None
        met = simulate(vehicle, gains, opts)[0].metrics()
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
        out.append(Check(f"performance.{model}", ok, ", ".join(diffs)))
    return out


def _f(x: Any) -> str:
    return "none" if x is None else f"{float(x):.5g}"
