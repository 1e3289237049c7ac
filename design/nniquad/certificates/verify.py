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
:func:`nniquad.analysis.cascade.box_certificate.check_cascade_section`.  The checks run
cheap first, ``fail_fast`` stops at the first failure, and re-simulations,
margins and bounds are cached in the process by their exact inputs
(:func:`clear_cache`).

This module holds the order of the checks and the form checks (model,
tolerances, layout, settings, law class); the recomputations live in
:mod:`nniquad.certificates.recheck_reduced_loop` (sector, poles, NI storages, decay,
reach, robust mass, bound, cascade) and :mod:`nniquad.certificates.recheck_runs`
(classical margins, reference runs), on the shared tools of
:mod:`nniquad.certificates.check_record`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from nniquad.certificates.build import MARGIN_FIELDS
from nniquad.certificates.certificate import (
    NI_FORM,
    PERFORMANCE_HORIZON_S,
    LATER_TOLERANCES,
    ROA_MODEL,
    TOLERANCES,
    Certificate,
    read_certificate,
    reference_run_options,
)
from nniquad.analysis.cascade.recheck import stated_delay
from nniquad.analysis.verified.inequalities import outcome_of
from nniquad.analysis.verified.spd import FAILS, NOT_PROVEN, PROVEN
from nniquad.certificates.check_record import PASS, Check, clear_cache, fmt_value, is_number, thaw_json
from nniquad.certificates.integral import REDUCED_LOOP_SECTIONS, reduced_loop_check, states_reduced_loop
from nniquad.certificates.recheck_reduced_loop import (
    bound_check,
    cascade_checks,
    closed_loop_check,
    ni_checks,
    ni_storage_check,
    poles_check,
    roa_check,
    robust_mass_check,
    same_multiset,
    sector_check,
)
from nniquad.certificates.recheck_runs import margins_check, performance_check
from nniquad.certificates.start import start_check, start_claim
from nniquad.certificates.recheck_tracking import NOT_STATED, tracking_check
from nniquad.config import CONTROL_RATE_HZ
from nniquad.errors import CertificateCheckError, CertificateError, NniquadError
from nniquad.laws.classes import LAW_CLASSES
from nniquad.sim.options import MODELS

__all__ = ["Check", "Verification", "verify_certificate", "ni_storage_check", "coverage_notes", "clear_cache",
           "same_multiset",
           "RECORD_FIELDS", "SECTION_KEYS"]


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

    @property
    def outcome(self) -> str:
        """``fails`` if a check fails, else ``not proven`` if a check is not proven, else ``proven``."""
        return outcome_of(self.checks) if self.checks else FAILS

    def table(self) -> str:
        """One row per check: name, outcome (``proven``, ``pass`` for a recomputed number, ``FAIL``,
        ``NOT PROVEN``), requirement (``met``, ``NOT MET``, ``-`` for a check that states none), method and detail."""
        w = max([len("check")] + [len(c.name) for c in self.checks])
        shown = {PROVEN: "proven", PASS: "pass", FAILS: "FAIL", NOT_PROVEN: "NOT PROVEN"}
        lines = [f"{'check':<{w}}  {'result':<10}  {'requirement':<11}  {'method':<24}  detail",
                 f"{'-' * w}  {'-' * 10}  {'-' * 11}  {'-' * 24}  ------"]
        lines += [f"{c.name:<{w}}  {shown[c.outcome]:<10}  {REQUIREMENT_SHOWN[c.requirement_met]:<11}  "
                  f"{'+'.join(c.methods):<24}  {c.detail}" for c in self.checks]
        lines.append("note: result 'proven': every strict matrix inequality of the check is proven in floating point "
                     "(verified Cholesky, Rump 2006) or in exact rational arithmetic, and its other numbers are "
                     "recomputed; 'pass': numbers recomputed within the certificate's tolerances (no inequality); "
                     "'NOT PROVEN': nothing fails, but a margin is below what floating point can prove")
        lines.append("note: the result says whether the certificate states the truth; 'requirement' says whether the "
                     "design meets what the check asks of it ('NOT MET': truly stated, and not met; '-': the check "
                     "states no requirement). The exit status follows the result only")
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """``{'ok', 'outcome', 'checks': [{'name', 'ok', 'requirement_met', 'outcome', 'method', 'margin', 'detail',
        'proofs'}], 'notes'}`` (``requirement_met``: :attr:`Check.requirement_met`, ``None`` when the check states
        no requirement)."""
        return {"ok": self.ok, "outcome": self.outcome, "checks": [c.to_json() for c in self.checks],
                "notes": list(self.notes)}


#: How the table shows :attr:`Check.requirement_met`.
REQUIREMENT_SHOWN = {True: "met", False: "NOT MET", None: "-"}

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
    "performance.reduced": ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "steady_offset_m",
                            "settings"),
    "performance.full": ("settling_s", "overshoot_pct", "peak_tilt_deg", "diverged", "steady_offset_m", "settings"),
    "bound": ("enter_band_s", "rest_to_rest_s", "a_max_m_s2"),
    "ratio_to_bound": ("reduced", "full"),
    "margins": ("rate_hz", "controller", "pade_order", "method", "required", "break_points", "meets_requirement",
                "horizontal_pm_ceiling_deg"),
    "law_class": ("name", "theorem"),
    "start": ("distance_m", "methods", "every_method"),
}.items()}


def sector_keys(cert: Certificate) -> frozenset[str]:
    """The keys of the certificate's ``sector`` section: ``gamma``, ``gamma_max`` and the key of the bound on the
    law's own gain (:meth:`nniquad.laws.base.NILaw.sector_limit`: ``delta_min``, ``k_max``, ...).

    Parameters
    ----------
    cert
        The certificate.
    """
    key, _ = cert.loop.sector_limit(0.5)
    return frozenset(("gamma", "gamma_max", key))


#: Sections a certificate may lack (written before they existed): the layout check skips them when absent.
OPTIONAL_SECTIONS = ("margins", "law_class", "start")

# ----------------------------------------------------------------------------- cache of the expensive recomputations


def verify_certificate(cert: Certificate | Mapping[str, Any] | str | Path, *, simulate: bool = True,
                       progress: Callable[[str], None] | None = None, fail_fast: bool = False,
                       thorough: bool = False) -> Verification:
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
    thorough
        Also prove the cascade's Lyapunov inequality over every cell of its parameter box
        (:func:`nniquad.analysis.cascade.box_proof.box_proof`; without it a stated ``box_proof`` is checked for
        form only).

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
        return _verify(cert, simulate, progress or (lambda msg: None), fail_fast, thorough)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError, np.linalg.LinAlgError) as exc:
        if isinstance(exc, NniquadError):
            raise
        # a signed document with a wrongly typed field (AttributeError: a part that should be an object is a list
        # or a text, and a check asked it for a key): one line, not a traceback
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
            f"continuously) with the nominal vehicle parameters and a mass interval [{fmt_value(rm.get('m_lo_kg'))}, "
            f"{fmt_value(rm.get('m_hi_kg'))}] kg; it covers no sampled-data cascade (control rate, attitude loop, motor lag) "
            "and no parameter box (inertia, attitude gain, motor time constant)")
    if not states_reduced_loop(cert.gains.law):
        notes.append(f"integral action ({cert.controller}): the paper's sector theorem does not apply and is not "
                     "claimed (no reduced-loop section); the design is certified by the sampled-data cascade section "
                     "alone, the integrator and its anti-windup in its loop, over its parameter box and within its "
                     "region of attraction")
    elif cert.law_class_name == "cascade":
        notes.append("class cascade: the paper's sector bound is not claimed; the reduced-loop LMIs are stated (they "
                     "hold whenever m kp delta > 1) but the design is certified by the sampled-data cascade section "
                     "alone, over its parameter box and within its region of attraction")
    if cert.start is None:
        notes.append(f"start_certified = {cert.start_certified} states {start_claim(cert)}; the 'start' check gives "
                     "the start's status in every region the certificate states")
    if cert.tracking is None and cert.cascade is not None:  # schema 1 covers no sampled cascade: said above
        notes.append(NOT_STATED)
    if cert.certified_delay_samples and cert.cascade is not None:
        n, rate = cert.certified_delay_samples, cert.cascade.get("rate_hz")
        ms = f" ({1000.0 * n / rate:g} ms at {rate:g} Hz)" if is_number(rate) and rate > 0 else ""
        notes.append(f"measurement delay: the cascade section certifies the loop with a delay of exactly {n} samples"
                     f"{ms}; the reduced-loop LMIs, the margins and the reference runs are without it")
    notes.append("records, not verified (no check and no Monte Carlo run reads them): "
                 + ", ".join(RECORD_FIELDS) + " (except tuning.model, which must equal model)")
    return notes


def _verify(cert: Certificate, simulate: bool, say: Callable[[str], None], fail_fast: bool,
            thorough: bool = False) -> Verification:
    tol = dict(TOLERANCES)
    out = Verification(notes=coverage_notes(cert))
    steps: list[Callable[[], Check | list[Check]]] = [
        lambda: Check("digest", True, f"sha256 {cert.signature[:16]}... matches the content"),
        lambda: _model_check(cert),
        lambda: _tolerances_check(cert),
        lambda: _layout_check(cert),
        lambda: _law_class_check(cert),
        lambda: _settings_check(cert),
        lambda: _delay_check(cert),
    ]
    if states_reduced_loop(cert.gains.law):
        steps += [
            lambda: sector_check(cert, tol),
            lambda: poles_check(cert),
            lambda: ni_checks(cert, tol, "plant_ni"),
            lambda: ni_checks(cert, tol, "controller_ni"),
            lambda: closed_loop_check(cert, tol),
            lambda: roa_check(cert),
            lambda: start_check(cert),
            lambda: robust_mass_check(cert, tol),
            lambda: bound_check(cert),
        ]
    else:  # integral action: the paper's theorem does not apply, and the sections say only that
        steps += [lambda: reduced_loop_check(cert), lambda: start_check(cert), lambda: bound_check(cert)]
    if cert.margins is not None:
        steps.append(lambda: margins_check(cert, tol))
    if cert.tracking is not None:  # a second (or 20 s over a box's corners): before the cascade's minute
        steps.append(lambda: tracking_check(cert))
    if cert.cascade is not None:
        if thorough:
            say("proving the cascade's Lyapunov inequality over the cells of its box")
        steps.append(lambda: cascade_checks(cert, fail_fast, thorough))
    if simulate:
        def runs() -> list[Check]:
            say("re-simulating the reference runs")
            return []

        steps.append(runs)
        steps += [lambda model=model: performance_check(cert, tol, model) for model in ("reduced", "full")]
    for step in steps:
        got = step()
        got = [got] if isinstance(got, Check) else got
        out.checks += got
        if fail_fast and any(not c.ok for c in got):
            break
    return out


def _model_check(cert: Certificate) -> Check:

    tuned = cert.tuning.get("model") if isinstance(cert.tuning, Mapping) and "model" in cert.tuning else cert.model
    ok = isinstance(cert.model, str) and cert.model in MODELS and tuned == cert.model
    return Check("model", ok, f"model {cert.model!r} is one of {', '.join(MODELS)} and equals tuning.model "
                              f"{tuned!r}" if ok else f"model {cert.model!r} (known: {', '.join(MODELS)}; "
                              f"tuning.model {tuned!r})")


def _tolerances_check(cert: Certificate) -> Check:
    """The stated tolerances are the library's, or an older certificate's: the library's without some of
    :data:`LATER_TOLERANCES`, and then it states none of the numbers those check."""
    stated = dict(cert.tolerances)
    missing = {k for k in LATER_TOLERANCES if k not in stated}
    library = {k: v for k, v in TOLERANCES.items() if k not in missing}
    runs = [r for r in (cert.performance.get(m) for m in ("reduced", "full")) if isinstance(r, Mapping)]
    unclaimed = sorted(LATER_TOLERANCES[k] for k in missing if any(LATER_TOLERANCES[k] in r for r in runs))
    ok = stated.keys() == library.keys() and not unclaimed and all(
        is_number(stated[k]) and float(stated[k]) == float(v) for k, v in library.items())
    bad = sorted(k for k in stated.keys() | library.keys() if stated.get(k) != library.get(k))
    older = f" (an older certificate's: without {', '.join(sorted(missing))})" if missing else ""
    return Check("tolerances", ok, f"the stated tolerances are the library's{older} (verify uses the library's)"
                 if ok else f"stated tolerances differ from the library's: {', '.join(bad + unclaimed)}"
                 + (f" ({', '.join(unclaimed)} stated without its tolerance)" if unclaimed else ""))


def _layout_check(cert: Certificate) -> Check:
    """Every section has exactly its keys, and the stated forms are the library's."""

    doc = cert.body()
    bad: list[str] = []
    reduced = states_reduced_loop(cert.gains.law)
    for path, keys in SECTION_KEYS.items():
        if path in OPTIONAL_SECTIONS and getattr(cert, path) is None:
            continue
        if not reduced and path.split(".")[0] in REDUCED_LOOP_SECTIONS:
            continue  # each holds only why it does not apply: reduced_loop_check compares it whole
        if path == "law_class" and not reduced:
            keys = keys | {"integral_action"}
        if path == "sector":  # the law's own gain bound: delta_min (NNI), k_max (sni2)
            keys = sector_keys(cert)
        node: Any = doc
        for part in path.split("."):
            node = node.get(part) if isinstance(node, Mapping) else None
        if path.startswith("performance.") and isinstance(node, Mapping) and "steady_offset_m" not in node:
            keys = keys - {"steady_offset_m"}  # a certificate written before issue 44 (the tolerances check ties it)
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
    bad += [k for k, same in forms.items() if not same and reduced]
    return Check("layout", not bad, "every section has exactly its keys; the stated forms are the library's"
                 if not bad else f"unexpected keys or forms in: {', '.join(bad)}")


def _delay_check(cert: Certificate) -> Check:
    """The stated ``delay_samples`` is the cascade section's, which its re-check rebuilds the loop with; a
    certificate without a cascade section states none (it certifies no sampled loop)."""
    stated = cert.delay_samples
    if cert.cascade is None:
        return Check("delay_samples", stated is None, "no cascade section: no delay stated" if stated is None
                     else f"states delay_samples {stated} without a cascade section that certifies it")
    section = stated_delay(cert.cascade)
    ok = section is not None and (stated if stated is not None else 0) == section
    return Check("delay_samples", ok, f"stated {stated}, cascade section {cert.cascade.get('delay_samples')} "
                                      "(the section's re-check rebuilds the loop with its own)")


def _settings_check(cert: Certificate) -> Check:
    """The reference runs' settings are the reference settings of the certified tilt limit, start and inner loops."""

    bad = []
    for model in ("reduced", "full"):
        run = cert.performance.get(model)
        stated = thaw_json(run.get("settings")) if isinstance(run, Mapping) else None
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
    reduced = states_reduced_loop(cert.gains.law)
    if reduced and cert.region_of_attraction.get("tilt_limit_deg") != cert.tilt_limit_deg:
        bad.append("region_of_attraction.tilt_limit_deg")
    if reduced and cert.lmi.get("robust_mass", {}).get("m_nominal_kg") != cert.vehicle.m:
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

    name = cert.law_class_name
    cls = LAW_CLASSES.get(name) if isinstance(name, str) else None
    if cls is None:
        return Check("law_class", False, f"unknown law class {name!r} (known: {', '.join(LAW_CLASSES)})")
    stated = cert.law_class.get("theorem") if cert.law_class is not None else cls.theorem
    if not cls.states_its_theorem(stated):
        return Check("law_class", False, f"the stated theorem is not the {name} class's: {stated!r}")
    if cls.needs_cascade and cert.cascade is None:
        return Check("law_class", False, f"the {name} class is certified by the cascade section, and there is none")
    if not states_reduced_loop(cert.gains.law) and (cls.sector_bound or cert.cascade is None):
        return Check("law_class", False, f"the {cert.controller} law has no reduced-loop theorem: only the cascade "
                                         "class, with its cascade section, certifies it")
    return Check("law_class", True, f"class {name}{' (not stated: a certificate from before classes)' if cert.law_class is None else ''}; "
                                    f"certified by {cls.theorem}")
