"""Verifying a certificate: recompute everything it states, independently.

Every matrix condition is recomputed with numpy from the certificate's own
vehicle and gains (never from stored system matrices), with the same re-check
functions the LMIs use (:mod:`nniquad.analysis.lmi.checks`); both reference
runs are re-simulated.  Neither cvxpy nor the tuner is needed.

Every signed field is either recomputed or cross-checked (the model name, the
tolerances, the section layout and the stated forms, every tilt limit and
simulation setting, the ``diverged`` flags, the bound and the ratios to it), or
is one of :data:`RECORD_FIELDS`, which no check and no Monte Carlo run reads;
``tests/test_tampering.py`` edits every leaf of a certificate to show it.  A
schema-2 ``cascade`` section is rebuilt by
:func:`nniquad.analysis.robust_cascade.check_cascade_section`.  The checks run
cheap first, ``fail_fast`` stops at the first failure, and re-simulations,
margins and bounds are cached in the process by their exact inputs
(:func:`clear_cache`).
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from nniquad.analysis.lmi import checks as K
from nniquad.analysis.lmi.roa import axis_acceleration_limit
from nniquad.certificates.certificate import TOLERANCES, Certificate, read_certificate
from nniquad.errors import CertificateCheckError, CertificateError, NniquadError

__all__ = ["Check", "Verification", "verify_certificate", "ni_storage_check", "coverage_notes", "clear_cache",
           "same_multiset",
           "RECORD_FIELDS", "SECTION_KEYS"]


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
    notes
        What the certificate does not cover, and its unverified record fields
        (one line each; no bearing on :attr:`ok`).
    """

    checks: list[Check] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

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
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """``{'ok': ..., 'checks': [{'name', 'ok', 'detail'}, ...]}``."""
        return {"ok": self.ok, "checks": [{"name": c.name, "ok": c.ok, "detail": c.detail} for c in self.checks],
                "notes": list(self.notes)}


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
    definite, bound = K.definite_margin(P)
    worst = K.dissipation_residual(K.sym(P), A, B, C)
    ok = definite > bound and worst <= tol
    return Check(name, ok, f"min eig P = {min_eig:.3e} (scaled {definite:.3g} > rounding bound {bound:.2g}), max eig "
                           f"of the dissipation matrix {worst:.2e} (relative, <= {tol:g})")


#: Fields that are records, not claims: ``verify`` checks none of them, and they change
#: no check and nothing ``montecarlo`` simulates (``tests/test_tampering.py`` shows it
#: for every leaf).  ``tuning.model`` is the exception: it must equal ``model``.
RECORD_FIELDS: tuple[str, ...] = ("software", "tuning", "vehicle.name", "cascade.box_search",
                                  "cascade.region_of_attraction.lure_search")

#: The keys of every schema-1 section (a signed key no check reads would be a claim nobody verifies).
SECTION_KEYS: dict[str, frozenset[str]] = {k: frozenset(v) for k, v in {
    "sector": ("gamma", "gamma_max", "delta_min"),
    "stability_margin": ("routh_margin", "max_real_part_1_s", "decay_rate_1_s", "min_damping", "poles_1_s"),
    "lmi": ("plant_ni", "controller_ni", "closed_loop", "robust_mass", "region_of_attraction"),
    "lmi.plant_ni": ("P", "form"),
    "lmi.controller_ni": ("P", "form"),
    "lmi.closed_loop": ("P", "decay_rate_1_s"),
    "lmi.robust_mass": ("m_lo_kg", "m_hi_kg", "m_nominal_kg", "P0", "P1", "decay_rate_1_s"),
    "lmi.region_of_attraction": ("P", "G", "T", "u0_m_s2", "max_displacement_m"),
    "region_of_attraction": ("max_displacement_m", "u0_m_s2", "tilt_limit_deg", "model"),
    "performance": ("reduced", "full"),
    "performance.reduced": ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "settings"),
    "performance.full": ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "settings"),
    "bound": ("enter_band_s", "rest_to_rest_s", "a_max_m_s2"),
    "ratio_to_bound": ("reduced", "full"),
    "margins": ("rate_hz", "controller", "pade_order", "method", "required", "break_points", "meets_requirement",
                "horizontal_pm_ceiling_deg"),
    "law_class": ("name", "theorem"),
}.items()}

#: The ``sector`` keys of an ``sni2`` certificate (its controller gain bound ``k_max`` in place of ``delta_min``).
SNI2_SECTOR_KEYS: frozenset[str] = frozenset(("gamma", "gamma_max", "k_max"))

#: Sections a certificate may lack (written before they existed): the layout check skips them when absent.
OPTIONAL_SECTIONS = ("margins", "law_class")

# ----------------------------------------------------------------------------- cache of the expensive recomputations

_CACHE: dict[tuple[str, str], Any] = {}
_CACHE_SIZE = 256


def _memo(kind: str, inputs: Any, compute: Callable[[], Any]) -> Any:
    """``compute()``, cached in this process by ``kind`` and the exact ``inputs`` (canonical JSON, floats by repr).

    A result depends only on its inputs (the simulator and the margins are
    deterministic), so an unchanged recomputation is not repeated: verifying a
    certificate twice, or many edited copies of one, re-simulates only what changed.
    """
    key = (kind, json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=True))
    if key in _CACHE:
        return copy.deepcopy(_CACHE[key])
    value = compute()
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))  # the oldest entry
    _CACHE[key] = value
    return copy.deepcopy(value)


def clear_cache() -> None:
    """Forget every cached recomputation (re-simulations, margins, bounds) of :func:`verify_certificate`."""
    _CACHE.clear()


def verify_certificate(cert: Certificate | Mapping[str, Any] | str | Path, *, simulate: bool = True,
                       progress: Callable[[str], None] | None = None, fail_fast: bool = False) -> Verification:
    """Recompute everything a certificate states, independently, with numpy and the simulator.

    The checks run cheap first: the document's own consistency (model, tolerances,
    layout and stated forms, the simulation settings and the tilt limit), then the
    sector, the poles and every LMI condition, the bound, the classical margins,
    the schema-2 cascade section and last the two re-simulations.  Re-simulations,
    margins and bounds are cached in this process by their exact inputs.

    Parameters
    ----------
    cert
        A :class:`Certificate`, its JSON mapping, or a file path.
    simulate
        Also re-simulate the two reference runs.
    progress
        Called with a short message before the re-simulation.
    fail_fast
        Stop at the first failed check (the result then holds the checks run so far).

    Returns
    -------
    Verification
        One :class:`Check` per recomputed statement (the digest first), and
        :attr:`Verification.notes`: what the certificate does not cover and which
        fields are unverified records.

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
        return _verify(cert, simulate, progress or (lambda msg: None), fail_fast)
    except (TypeError, ValueError, KeyError, IndexError, np.linalg.LinAlgError) as exc:
        if isinstance(exc, NniquadError):
            raise
        # a signed document with a wrongly typed field: one line, not a traceback
        raise CertificateError(f"certificate has a malformed field ({type(exc).__name__}: {exc})") from None


def coverage_notes(cert: Certificate) -> list[str]:
    """What a certificate does not cover, and which of its fields are unverified records (one line each).

    Parameters
    ----------
    cert
        The certificate.
    """
    notes = []
    if cert.cascade is None:
        rm = cert.lmi.get("robust_mass", {})
        notes.append(
            "schema 1: the stability claim is for the continuous-time reduced horizontal loop (position measured "
            f"continuously) with the nominal vehicle parameters and a mass interval [{_f(rm.get('m_lo_kg'))}, "
            f"{_f(rm.get('m_hi_kg'))}] kg; it covers no sampled-data cascade (control rate, attitude loop, motor lag) "
            "and no parameter box (inertia, attitude gain, motor time constant)")
    if cert.law_class_name == "cascade":
        notes.append("class cascade: the paper's sector bound is not claimed; the reduced-loop LMIs are stated (they "
                     "hold whenever m kp delta > 1) but the design is certified by the sampled-data cascade section "
                     "alone, over its parameter box and within its region of attraction")
    notes.append("records, not verified (no check and no Monte Carlo run reads them): "
                 + ", ".join(RECORD_FIELDS) + " (except tuning.model, which must equal model)")
    return notes


def _verify(cert: Certificate, simulate: bool, say: Callable[[str], None], fail_fast: bool) -> Verification:
    tol = dict(TOLERANCES)
    out = Verification(notes=coverage_notes(cert))
    steps: list[Callable[[], Check | list[Check]]] = [
        lambda: Check("digest", True, f"sha256 {cert.signature[:16]}... matches the content"),
        lambda: _model_check(cert),
        lambda: _tolerances_check(cert),
        lambda: _layout_check(cert),
        lambda: _law_class_check(cert),
        lambda: _settings_check(cert),
        lambda: _sector_check(cert, tol),
        lambda: _poles_check(cert),
        lambda: _ni_checks(cert, tol, "plant_ni"),
        lambda: _ni_checks(cert, tol, "controller_ni"),
        lambda: _closed_loop_check(cert, tol),
        lambda: _roa_check(cert),
        lambda: _robust_mass_check(cert, tol),
        lambda: _bound_check(cert),
    ]
    if cert.margins is not None:
        steps.append(lambda: _margins_check(cert, tol))
    if cert.cascade is not None:
        steps.append(lambda: _cascade_checks(cert))
    if simulate:
        def runs() -> list[Check]:
            say("re-simulating the reference runs")
            return []

        steps.append(runs)
        steps += [lambda model=model: _performance_check(cert, tol, model) for model in ("reduced", "full")]
    for step in steps:
        got = step()
        got = [got] if isinstance(got, Check) else got
        out.checks += got
        if fail_fast and any(not c.ok for c in got):
            break
    return out


def _model_check(cert: Certificate) -> Check:
    from nniquad.sim.options import MODELS

    tuned = cert.tuning.get("model") if isinstance(cert.tuning, Mapping) and "model" in cert.tuning else cert.model
    ok = isinstance(cert.model, str) and cert.model in MODELS and tuned == cert.model
    return Check("model", ok, f"model {cert.model!r} is one of {', '.join(MODELS)} and equals tuning.model "
                              f"{tuned!r}" if ok else f"model {cert.model!r} (known: {', '.join(MODELS)}; "
                              f"tuning.model {tuned!r})")


def _tolerances_check(cert: Certificate) -> Check:
    stated = dict(cert.tolerances)
    ok = stated.keys() == TOLERANCES.keys() and all(
        _is_num(stated[k]) and float(stated[k]) == float(v) for k, v in TOLERANCES.items())
    bad = sorted(k for k in stated.keys() | TOLERANCES.keys() if stated.get(k) != TOLERANCES.get(k))
    return Check("tolerances", ok, "the stated tolerances are the library's (verify uses the library's)" if ok
                 else f"stated tolerances differ from the library's: {', '.join(bad)}")


def _layout_check(cert: Certificate) -> Check:
    """Every section has exactly its keys, and the stated forms are the library's."""
    from nniquad.certificates.build import MARGIN_FIELDS
    from nniquad.certificates.certificate import NI_FORM, ROA_MODEL

    doc = cert.body()
    bad: list[str] = []
    for path, keys in SECTION_KEYS.items():
        if path in OPTIONAL_SECTIONS and getattr(cert, path) is None:
            continue
        if path == "sector" and cert.controller == "sni2":  # the law's own gain bound: k_max, not delta_min
            keys = SNI2_SECTOR_KEYS
        node: Any = doc
        for part in path.split("."):
            node = node.get(part) if isinstance(node, Mapping) else None
        if not isinstance(node, Mapping) or set(node) != keys:
            bad.append(path)
    if cert.margins is not None:
        points = cert.margins.get("break_points")
        if not isinstance(points, Mapping) or any(not isinstance(p, Mapping) or set(p) != set(MARGIN_FIELDS)
                                                  for p in points.values()):
            bad.append("margins.break_points")
        if cert.margins.get("method") != "linearised cascade at hover":
            bad.append("margins.method")
    forms = {"lmi.plant_ni.form": cert.lmi.get("plant_ni", {}).get("form") == NI_FORM,
             "lmi.controller_ni.form": cert.lmi.get("controller_ni", {}).get("form") == NI_FORM,
             "region_of_attraction.model": cert.region_of_attraction.get("model") == ROA_MODEL}
    bad += [k for k, same in forms.items() if not same]
    return Check("layout", not bad, "every section has exactly its keys; the stated forms are the library's"
                 if not bad else f"unexpected keys or forms in: {', '.join(bad)}")


def _settings_check(cert: Certificate) -> Check:
    """The reference runs' settings are the reference settings of the certified tilt limit, start and inner loops."""
    from nniquad.certificates.certificate import PERFORMANCE_HORIZON_S, reference_run_options
    from nniquad.config import CONTROL_RATE_HZ

    bad = []
    for model in ("reduced", "full"):
        run = cert.performance.get(model)
        stated = _thaw_json(run.get("settings")) if isinstance(run, Mapping) else None
        rate = cert.cascade.get("rate_hz") if cert.cascade is not None else None
        try:
            want = reference_run_options(model, cert.inner_loop, tilt_limit_deg=cert.tilt_limit_deg,
                                         xi0=cert.xi0_m, horizon_s=PERFORMANCE_HORIZON_S, rate_hz=rate).to_json()
        except (TypeError, ValueError, NniquadError):
            bad.append(f"performance.{model}.settings (cascade.rate_hz {rate!r} is not a rate)")
            continue
        if stated != want:
            diff = sorted(k for k in set(want) | set(stated or {}) if (stated or {}).get(k) != want.get(k))
            bad.append(f"performance.{model}.settings ({', '.join(diff) or 'not an object'})")
    if cert.region_of_attraction.get("tilt_limit_deg") != cert.tilt_limit_deg:
        bad.append("region_of_attraction.tilt_limit_deg")
    if cert.lmi.get("robust_mass", {}).get("m_nominal_kg") != cert.vehicle.m:
        bad.append("lmi.robust_mass.m_nominal_kg (must be the vehicle's mass)")
    if cert.margins is not None:
        rate = cert.cascade.get("rate_hz") if cert.cascade is not None else CONTROL_RATE_HZ
        if cert.margins.get("rate_hz") != rate:
            bad.append(f"margins.rate_hz (must be {rate!r})")
    if cert.cascade is not None:
        roa = cert.cascade.get("region_of_attraction")
        if not isinstance(roa, Mapping) or roa.get("tilt_limit_deg") != cert.tilt_limit_deg:
            bad.append("cascade.region_of_attraction.tilt_limit_deg")
    return Check("settings", not bad,
                 f"both reference runs use the reference settings at tilt {cert.tilt_limit_deg:g} deg, start "
                 f"{list(cert.xi0_m)} m and the certified inner loops; every stated tilt limit is the same"
                 if not bad else "inconsistent: " + "; ".join(bad))


def _law_class_check(cert: Certificate) -> Check:
    """The stated class is a known one, its theorem the library's, and what the class's proof needs is there."""
    from nniquad.control.law_classes import LAW_CLASSES

    name = cert.law_class_name
    cls = LAW_CLASSES.get(name) if isinstance(name, str) else None
    if cls is None:
        return Check("law_class", False, f"unknown law class {name!r} (known: {', '.join(LAW_CLASSES)})")
    stated = cert.law_class.get("theorem") if cert.law_class is not None else cls.theorem
    if stated != cls.theorem:
        return Check("law_class", False, f"the stated theorem is not the {name} class's: {stated!r}")
    if cls.needs_cascade and cert.cascade is None:
        return Check("law_class", False, f"the {name} class is certified by the cascade section, and there is none")
    return Check("law_class", True, f"class {name}{' (not stated: a certificate from before classes)' if cert.law_class is None else ''}; "
                                    f"certified by {cls.theorem}")


def _sector_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """The stated sector numbers, recomputed; the paper class (only) needs gamma <= gamma_max."""
    from nniquad.control.law_classes import LAW_CLASSES

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
        ok = ok and gamma <= gamma_max * (1 + 1e-12)
    sni2 = cert.controller == "sni2"
    key = "k_max" if sni2 else "delta_min"
    if 0 < gamma_max < 1:
        limit = loop.sector_k_max(gamma_max) if sni2 else loop.sector_delta_min(gamma_max)
    else:
        limit = math.nan
    ok = ok and _close(sec.get(key), limit, tol["sector_relative"])
    claim = (f"<= gamma_max = {gamma_max:g} < 1 (the paper class's sector bound)" if bound else
             f"< 1 (class {cert.law_class_name}: the sector bound with gamma_max = {gamma_max:g} is not claimed"
             f"{'' if gamma <= gamma_max else '; it does not hold'})")
    what = "the DC loop gain k/(m kp omega^2) is" if sni2 else "delta m kp gamma >= 1 holds with"
    return Check("sector", ok, f"{what} gamma = {gamma:.6g} (stated {gamma_stated:.6g}) {claim}; {key} "
                               f"{limit:.6g} (stated {_f(sec.get(key))})")


def _poles_check(cert: Certificate) -> Check:
    loop = cert.loop
    routh = loop.routh_margin  # m kp delta - 1 (NNI), 1/gamma - 1 (sni2): positive iff the reduced loop is stable
    pd = loop.poles_and_damping()
    margin = cert.stability_margin
    stated_rate = float(margin.get("decay_rate_1_s", math.nan))
    ok = pd.stable and abs(pd.decay_rate - stated_rate) <= 1e-6 * abs(pd.decay_rate) and loop.stable
    # every other stated number of the section too: a wrong damping or pole list must not pass
    # (the poles to 1e-8 of the largest: a stated imaginary part of 1e-6 on a real pole is refused)
    stated_poles = np.array(margin.get("poles_1_s", ()), dtype=float)
    ok = (ok and _close(margin.get("routh_margin"), routh, 1e-12)
          and _close(margin.get("max_real_part_1_s"), pd.max_real_part, 1e-6)
          and _close(margin.get("min_damping"), pd.min_damping, 1e-6)
          and same_multiset(stated_poles, pd.poles, 1e-8 * float(np.max(np.abs(pd.poles)))))
    return Check("poles", ok, f"max Re = {pd.max_real_part:.6g} 1/s, decay {pd.decay_rate:.6g} 1/s "
                              f"(stated {stated_rate:.6g}), min damping {pd.min_damping:.4g}, "
                              f"Routh margin 1/gamma - 1 = {routh:.4g}")


def same_multiset(stated: np.ndarray, computed: np.ndarray, tol: float) -> bool:
    """Whether stated ``[re, im]`` rows and computed complex numbers are the same multiset within ``tol``.

    The rows are matched by an optimal assignment, never by position: the eigenvalues of the two identical axes
    (and the two members of a conjugate pair) tie in any sort key, and another machine's LAPACK returns tied
    values in another order.

    Parameters
    ----------
    stated : array (n, 2)
        Real and imaginary parts, as stated.
    computed : array (n,), complex
        The recomputed values.
    tol
        Largest distance of a matched pair.
    """
    from scipy.optimize import linear_sum_assignment

    got = np.asarray(computed, complex).ravel()
    if stated.ndim != 2 or stated.shape != (got.size, 2) or not np.all(np.isfinite(stated)):
        return False
    dist = np.abs((stated[:, 0] + 1j * stated[:, 1])[:, None] - got[None, :])
    rows, cols = linear_sum_assignment(dist)
    return bool(np.all(dist[rows, cols] <= tol))


def _ni_checks(cert: Certificate, tol: Mapping[str, float], which: str) -> Check:
    loop = cert.loop
    A, B, C, _ = loop.plant_matrices() if which == "plant_ni" else loop.controller_matrices()
    P = _array(_part(cert.lmi, which, "lmi"), "P", A.shape, f"lmi.{which}")
    if not np.array_equal(P, P.T):
        return Check(f"lmi.{which}", False, "stored P is not symmetric")
    if which == "controller_ni":
        # judged in the controller's normalised coordinates (recomputed from the gains): the state x = T x~ and the
        # time in units of 1/w.  P > 0 and the dissipation inequality are invariant (a congruence, and M/w), and
        # there the residual's scale is the system's own: the sni2 controller's B = [0, k] would otherwise dwarf the
        # storage's terms, and a 1 % edit of P would pass; identity for NNI
        T, w = loop.controller_normalisation()
        Ti = np.linalg.inv(T)
        P, A, B, C = T.T @ P @ T, Ti @ A @ T / w, Ti @ B / w, C @ T
    return ni_storage_check(f"lmi.{which}", P, A, B, C, tol["lmi_relative"])


def _closed_loop_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    part = _part(cert.lmi, "closed_loop", "lmi")
    A = cert.loop.closed_loop_A_axis()
    P = _array(part, "P", A.shape, "lmi.closed_loop")
    if not np.array_equal(P, P.T):
        return Check("lmi.closed_loop", False, "stored P is not symmetric")
    rate = K.certified_rate(A, P)
    bound = K.rate_rounding_bound(A, P, rate)
    stated = float(part.get("decay_rate_1_s", math.nan))
    ok = rate >= stated * (1 - tol["rate_relative"]) and stated > 0 and rate > bound
    return Check("lmi.closed_loop", ok, f"P > 0 and A'P + PA <= -eps P with eps = {rate:.6g} 1/s "
                                        f"(stated {stated:.6g}; rounding bound {bound:.2g} 1/s)")


def _robust_mass_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    part = _part(cert.lmi, "robust_mass", "lmi")
    n = cert.loop.closed_loop_A_axis().shape[0]
    P0 = _array(part, "P0", (n, n), "lmi.robust_mass")
    P1 = _array(part, "P1", (n, n), "lmi.robust_mass")
    if not (np.array_equal(P0, P0.T) and np.array_equal(P1, P1.T)):
        return Check("lmi.robust_mass", False, "stored P0 or P1 is not symmetric")
    lo, hi, mn = (float(part.get(k, math.nan)) for k in ("m_lo_kg", "m_hi_kg", "m_nominal_kg"))
    stated = float(part.get("decay_rate_1_s", math.nan))
    if not (0 < lo <= hi and math.isfinite(mn) and mn > 0):
        raise CertificateError("certificate lmi.robust_mass needs 0 < m_lo_kg <= m_hi_kg and m_nominal_kg > 0")
    nominal = cert.loop.with_mass(mn)
    worst, above = math.inf, math.inf  # the smallest rate, and the smallest rate less its rounding bound
    for mt in 1.0 / np.linspace(1.0 / hi, 1.0 / lo, 201):
        A_m = nominal.with_mass(mt, thrust_model=True).closed_loop_A_axis()
        rate = K.certified_rate(A_m, P0 + P1 / mt)
        worst = min(worst, rate)
        above = min(above, rate - K.rate_rounding_bound(A_m, P0 + P1 / mt, rate))
    ok = worst >= stated * (1 - tol["rate_relative"]) and stated > 0 and above > 0
    return Check("lmi.robust_mass", ok, f"P0 + P1/m > 0 and decay >= {worst:.6g} 1/s (stated {stated:.6g}; above "
                                        f"its rounding bound: {above > 0}) on 201 masses in [{lo:g}, {hi:g}] kg")


def _bound_check(cert: Certificate) -> Check:
    """The time-optimal bound, recomputed; each ratio from the stated settling time and the recomputed bound."""
    from nniquad.analysis.bound import time_optimal_bound

    b = _memo("bound", [cert.vehicle.as_dict(), list(cert.xi0_m), cert.tilt_limit_deg],
              lambda: time_optimal_bound(cert.vehicle, xi0=cert.xi0_m, tilt_limit_deg=cert.tilt_limit_deg))
    ok = all(_close(cert.bound.get(k), getattr(b, k), 1e-9) for k in ("enter_band_s", "rest_to_rest_s", "a_max_m_s2"))
    ratios = []
    for model in ("reduced", "full"):
        run = cert.performance.get(model)
        want = run.get("settling_s") if isinstance(run, Mapping) else None
        ratio = None if want is None else float(want) / b.enter_band_s
        stated_ratio = cert.ratio_to_bound.get(model)
        ok = ok and ((ratio is None and stated_ratio is None)
                     or (ratio is not None and _close(stated_ratio, ratio, 1e-9)))
        ratios.append(f"{model} {_f(ratio)} (stated {_f(stated_ratio)})")
    return Check("bound", ok, f"enter band {b.enter_band_s:.5g} s (stated {_f(cert.bound.get('enter_band_s'))}), rest "
                              f"to rest {b.rest_to_rest_s:.5g} s, a_max {b.a_max_m_s2:.5g} m/s^2; ratio to bound "
                              + ", ".join(ratios))


def _cascade_checks(cert: Certificate) -> list[Check]:
    """The schema-2 ``cascade`` section, rebuilt by :func:`nniquad.analysis.robust_cascade.check_cascade_section`."""
    try:
        from nniquad.analysis.robust_cascade import check_cascade_section
    except ImportError:
        return [Check("cascade", False, "this nniquad cannot check a cascade section "
                                        "(nniquad.analysis.robust_cascade.check_cascade_section is missing)")]
    section = _thaw_json(cert.cascade)
    if isinstance(section, dict):
        section.pop("box_search", None)  # a record (RECORD_FIELDS): how the box was found, not what is certified
        if isinstance(section.get("region_of_attraction"), dict):
            section["region_of_attraction"].pop("lure_search", None)  # a record too: how the region was found
    # a pure function of the section and the design: an edit elsewhere in the document does not re-run it
    rows = _memo("cascade", [section, cert.vehicle.as_dict(), _gains_key(cert), cert.inner_loop.as_dict(),
                             cert.tilt_limit_deg, list(cert.xi0_m)],
                 lambda: check_cascade_section(section, cert.vehicle, cert.gains, cert.inner_loop,
                                               tilt_limit_deg=cert.tilt_limit_deg, xi0_m=cert.xi0_m))
    checks = [Check(f"cascade.{name}", ok, detail) for name, ok, detail in rows]
    return checks or [Check("cascade", False, "the cascade check returned no checks")]


def _thaw_json(value: Any) -> Any:
    """A read-only section as plain JSON data (dicts and lists)."""
    return json.loads(json.dumps(value, default=lambda o: dict(o) if isinstance(o, Mapping) else list(o)))


def _roa_check(cert: Certificate) -> Check:
    part = _part(cert.lmi, "region_of_attraction", "lmi")
    A0, B, Kc = cert.loop.saturation_split()
    n = A0.shape[0]
    P = _array(part, "P", (n, n), "lmi.region_of_attraction")
    if not np.array_equal(P, P.T):
        return Check("lmi.region_of_attraction", False, "stored P is not symmetric")
    Gm = _array(part, "G", (1, n), "lmi.region_of_attraction")
    T = _array(part, "T", (1, 1), "lmi.region_of_attraction")
    r = float(part.get("max_displacement_m", math.nan))
    u0 = axis_acceleration_limit(cert.vehicle.g, cert.tilt_limit_deg, "norm")
    Acl = A0 + B @ Kc
    dec_rel, dec_bound = K.roa_decrease_margin(Acl, B, P, Gm, T)
    definite, definite_bound = K.definite_margin(P)
    positive = definite > definite_bound
    W = np.linalg.inv(P) if positive else np.full((n, n), np.nan)
    incl = K.roa_inclusion_margin(Kc, Gm, W, u0)
    level = K.ellipsoid_level(P, r * cert.loop.start_direction())  # the law's start state at the reach
    top = cert.region_of_attraction
    start = cert.start_certified
    consistent = (top.get("max_displacement_m") == r and start == bool(math.hypot(*cert.xi0_m) <= r)
                  and _close(part.get("u0_m_s2"), u0, 1e-12) and _close(top.get("u0_m_s2"), u0, 1e-12)
                  and top.get("tilt_limit_deg") == cert.tilt_limit_deg)
    ok = (positive and T[0, 0] > 0 and dec_rel < -dec_bound and incl >= -1e-6 and level <= 1 + 1e-6 and r >= 0
          and consistent)
    return Check("lmi.region_of_attraction", ok,
                 f"decrease max eig {dec_rel:.2e} (relative, < -{dec_bound:.2g}, its rounding bound), inclusion margin "
                 f"{incl:.3g}, reach {r:.4g} m "
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


def _meets_within(stated: Any, comp: Mapping[str, Any], required: Mapping[str, float],
                  tol: Mapping[str, float]) -> bool:
    """A stated ``meets_requirement`` against the recomputed margins, judged within the margins' tolerances.

    A verdict is a threshold on numbers that ``verify`` compares only within ``margin_db_abs`` and
    ``margin_deg_abs``: a margin within that of its requirement may be computed on either side of it on another
    machine, so either verdict is accepted there, and only there.  ``True`` needs every margin to reach its
    requirement less the tolerance (on a stable loop); ``False`` needs one margin short of it by more than the
    tolerance, or an unstable loop.
    """
    if not isinstance(stated, bool):
        return False
    if comp.get("stable") is not True:
        return stated is False
    gm_req, pm_req = float(required["gm_db"]), float(required["pm_deg"])
    shortfalls = (  # how far each requirement is missed (negative: met with room)
        (gm_req - float(comp["gm_db"]), tol["margin_db_abs"]),
        (float(comp["gm_lower_db"]) + gm_req, tol["margin_db_abs"]),
        (pm_req - float(comp["pm_deg"]), tol["margin_deg_abs"]),
    )
    shortfalls = tuple((math.inf if math.isnan(short) else short, t) for short, t in shortfalls)  # nan: not met
    if stated:
        return all(short <= t for short, t in shortfalls)
    return any(short > -t for short, t in shortfalls)


def _margins_check(cert: Certificate, tol: Mapping[str, float]) -> Check:
    """Recompute the classical margins from the vehicle, the gains and the inner loops (never stored matrices)."""
    from nniquad.certificates.build import MARGIN_FIELDS, margins_section, sector_pm_ceiling_deg

    stated = cert.margins
    try:
        rate = float(stated["rate_hz"])
        gamma_max = float(cert.sector["gamma_max"])
    except (KeyError, TypeError, ValueError):
        raise CertificateError("certificate 'margins' needs a number 'rate_hz'") from None
    if (stated.get("controller") != "discrete" or stated.get("pade_order") != 2
            or isinstance(stated.get("pade_order"), bool)):
        return Check("margins", False, "margins stated for another sampling model than the one recomputed")
    fresh = _memo("margins", [cert.vehicle.as_dict(), _gains_key(cert), cert.inner_loop.as_dict(),
                              cert.tilt_limit_deg, gamma_max, rate],
                  lambda: margins_section(cert.vehicle, cert.gains, cert.inner_loop,
                                          tilt_limit_deg=cert.tilt_limit_deg, gamma_max=gamma_max, rate_hz=rate))
    ok = True
    bad: list[str] = []
    points = stated.get("break_points")
    if not isinstance(points, Mapping) or set(points) != set(fresh["break_points"]):
        return Check("margins", False, "margins: the break points stated differ from the recomputed ones")
    for name, comp in fresh["break_points"].items():
        st = points[name]
        for key in MARGIN_FIELDS:
            if key == "meets_requirement":
                same = _meets_within(st.get(key), comp, fresh["required"], tol)
            elif key.endswith("_db"):
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
    # the overall verdict is the conjunction of the stated per-break-point verdicts (each checked above)
    ok = ok and stated.get("meets_requirement") is all(points[n].get("meets_requirement") is True for n in points)
    ok = ok and isinstance(stated.get("required"), Mapping) and dict(stated["required"]) == fresh["required"]
    ok = ok and _close(stated.get("horizontal_pm_ceiling_deg"), sector_pm_ceiling_deg(gamma_max, cert.controller),
                       1e-12)
    h, a = fresh["break_points"]["horizontal"], fresh["break_points"]["attitude"]
    detail = (f"horizontal GM +{h['gm_db']}/{h['gm_lower_db']} dB PM {h['pm_deg']} deg; attitude GM +{a['gm_db']}/"
              f"{a['gm_lower_db']} dB PM {a['pm_deg']} deg at {rate:g} Hz; meets GM >= {fresh['required']['gm_db']:g} dB, "
              f"PM >= {fresh['required']['pm_deg']:g} deg: {fresh['meets_requirement']}")
    if bad:
        detail += "; differs: " + ", ".join(bad[:3])
    return Check("margins", ok, detail)


def _performance_check(cert: Certificate, tol: Mapping[str, float], model: str) -> Check:
    """Re-simulate one reference run with its stated settings (checked by ``settings``) and compare every number."""
    from nniquad.sim import SimOptions, simulate

    stated = cert.performance.get(model)
    if not isinstance(stated, Mapping) or not isinstance(stated.get("settings"), Mapping):
        raise CertificateError(f"certificate performance.{model} is missing or has no settings")
    settings = _thaw_json(stated["settings"])
    settings.pop("inner", None)
    try:
        opts = SimOptions(**{**settings, "xi0": tuple(settings.get("xi0", cert.xi0_m)),
                             "zc0": tuple(settings.get("zc0", (0.0, 0.0))),
                             "wind_N": tuple(settings.get("wind_N", (0.0, 0.0))), "inner": cert.inner_loop})
    except (TypeError, NniquadError) as exc:
        raise CertificateError(f"certificate performance.{model}.settings: {exc}") from None

    def run() -> dict[str, Any]:
        met = simulate(cert.vehicle, cert.gains, opts)[0].metrics()
        return {k: getattr(met, k) for k in ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged")}

    got_all = _memo("simulate", [cert.vehicle.as_dict(), _gains_key(cert), opts.to_json()], run)
    diffs = []
    ok = True
    for key, tkey in (("settling_s", "settling_abs_s"), ("overshoot_pct", "overshoot_abs_pct"),
                      ("peak_tilt_deg", "tilt_abs_deg")):
        want, got = stated.get(key), got_all[key]
        if want is None or got is None:
            same = want is None and got is None
        else:
            same = _is_num(want) and abs(float(want) - float(got)) <= tol[tkey]
        ok &= same
        diffs.append(f"{key} {_f(got)} (stated {_f(want)})")
    same = stated.get("diverged") is bool(got_all["diverged"])
    ok &= same
    diffs.append(f"diverged {bool(got_all['diverged'])} (stated {stated.get('diverged')!r})")
    return Check(f"performance.{model}", ok, ", ".join(diffs))


def _gains_key(cert: Certificate) -> dict[str, Any]:
    """The certified law and gains, as the exact inputs of a cached recomputation (:func:`_memo`)."""
    from nniquad.certificates.certificate import gains_json

    return {"controller": cert.controller, **gains_json(cert.gains)}


def _is_num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _close(stated: Any, computed: float, rtol: float) -> bool:
    """Whether a stated number (any JSON value) equals a recomputed one within ``rtol`` (relative, and absolute near 0)."""
    if isinstance(stated, bool) or not isinstance(stated, (int, float)):
        return False
    return math.isfinite(stated) and abs(float(stated) - computed) <= rtol * max(abs(computed), 1e-300) + 1e-300


def _f(x: Any) -> str:
    return "none" if x is None else f"{float(x):.5g}"
