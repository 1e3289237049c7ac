"""Certificates: a gain set with everything needed to check it, and the independent check.

A certificate is one JSON document (:data:`SCHEMA`, :data:`SCHEMA_VERSION`):

``vehicle``, ``gains``, ``inner_loop``, ``tilt_limit_deg``, ``xi0_m``
    What is certified: the vehicle, the horizontal gains ``kp, Gamma, delta`` (the NNI law;
    every other law of the NI structure names itself, ``{"controller": "sni2", "kp", "k", "omega", "zeta"}``,
    :meth:`nniquad.laws.base.ControlLaw.gains_json`),
    the inner loops the ``full`` performance was measured with, the tilt
    limit and the initial position of the reference run.
``sector``
    ``gamma`` (the smallest γ the gains satisfy ``δ >= 1/(γ m kp)`` with),
    ``gamma_max`` and the bound on the law's own gain (:meth:`nniquad.laws.base.NILaw.sector_limit`:
    ``delta_min = 1/(γ_max m kp)`` for the NNI law); for ``sni2`` ``gamma`` is the DC loop
    gain ``k/(m kp ω²)`` and ``k_max = γ_max m kp ω²`` replaces ``delta_min``.
``stability_margin``
    ``m kp δ - 1`` (the exact Routh condition is ``> 0``), the slowest pole's
    real part, the decay rate ``-2 max Re λ`` and the smallest damping ratio.
``lmi``
    The matrices: the plant's and the controller's NI certificates (the
    dissipation form ``V̇ <= ẏᵀu``, see :mod:`nniquad.analysis.lmi`), the closed-loop
    Lyapunov ``P`` with its decay rate, the parameter-dependent ``P0 + P1/m``
    over the mass interval (thrust sized with the nominal mass), and the
    saturation region-of-attraction ellipsoid ``P`` with its multipliers ``G, T``.
``region_of_attraction``
    The reduced loop's largest certified displacement from rest.
``start``, ``start_certified``
    Whether ``xi0_m`` lies in each certified region, method by method (the reduced loop's, and in schema 2 the
    cascade's: model, method, reach, ``inside``; :mod:`nniquad.certificates.start`), and ``every_method``.
    ``start_certified`` is ``start.every_method``: true only if every method named covers the start.  A
    certificate written before the ``start`` section has none; its ``start_certified`` states the reduced-loop
    ellipsoid only (what it meant then; its digest is unchanged, and ``verify`` says which meaning it checked).
``performance``
    ``reduced`` and ``full``: settling time, overshoot, peak tilt and the exact
    simulation settings, so that :func:`verify_certificate` can re-simulate.
``bound``, ``ratio_to_bound``
    The time-optimal bound and each model's settling time divided by it.
``law_class``
    ``{"name", "theorem"}``: the class of the design (:mod:`nniquad.laws.classes`:
    ``paper``, the sector bound holds, or ``cascade``, the sector bound dropped) and the
    theorem that certifies it.  A certificate written before classes existed has no
    such field and is of the ``paper`` class (its digest is unchanged).
``cascade`` (schema 2 only)
    The sampled-data cascade certificate (rate, parameter box, matrices, decay
    rate, reach, margins; :mod:`nniquad.analysis.cascade.box_certificate`).  A document
    with this section has ``schema_version`` 2, one without it 1
    (:data:`SCHEMA_VERSIONS`); each version refuses the other's layout.
``tracking`` (optional, with a ``cascade`` section)
    The certified tracking-error bound for a class of references (acceleration and
    jerk limits), without and with acceleration feedforward, and the linear-zone
    condition (:mod:`nniquad.analysis.tracking_section`).  A certificate written
    before it existed has none (its digest is unchanged); ``verify`` then notes it.
``delay_samples`` (optional, with a ``cascade`` section)
    The measurement delay [control periods] the cascade section certifies (its own ``delay_samples``: the
    position reaches the law that many samples late).  A certificate written before it has none (its digest is
    unchanged) and covers no delay.
``software``
    Package versions.  ``digest``: SHA-256 of the canonical JSON of everything
    else (sorted keys, no whitespace, UTF-8).

:class:`Certificate` is the typed, immutable form of that document
(:meth:`Certificate.from_json`, :meth:`Certificate.to_json`,
:attr:`Certificate.digest`); :func:`load_certificate` reads and form-checks a
file as a plain mapping (what the Monte Carlo study and ``simulate
--certificate`` need), :func:`read_certificate` reads it as a
:class:`Certificate`.  :func:`nniquad.certificates.verify.verify_certificate`
recomputes every matrix condition with numpy from the certificate's own vehicle
and gains (never from stored system matrices), re-runs both simulations and
checks the digest.  It needs neither cvxpy nor the tuner.

The envelope (schema, version, digest, reading and writing) lives in
:mod:`nniquad.certificates.document`, the typed accessors of a mapping's
gains, vehicle and inner loops in :mod:`nniquad.certificates.sections`; every
name is re-exported here.
"""


from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, ClassVar, Mapping

from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.certificates.document import (
    CASCADE_SCHEMA_VERSION,
    DIGEST_ALGORITHM,
    SCHEMA,
    SCHEMA_VERSION,
    SCHEMA_VERSIONS,
    canonical_digest,
    canonical_json,
    check_form,
    checked_form_text,
    load_certificate,
    write_certificate,
)
from nniquad.certificates.sections import (
    GAINS_LAW_KEY,
    certificate_gains,
    certificate_inner_loop,
    certificate_vehicle,
    gains_json,
    section_of,
)
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CertificateError
from nniquad.laws.base import GainBlock
from nniquad.laws.classes import DEFAULT_LAW_CLASS
from nniquad.model.vehicle import Vehicle

__all__ = [
    "SCHEMA",
    "SCHEMA_VERSION",
    "SCHEMA_VERSIONS",
    "CASCADE_SCHEMA_VERSION",
    "PERFORMANCE_OUTPUT_DT_S",
    "NI_FORM",
    "ROA_MODEL",
    "reference_run_options",
    "DIGEST_ALGORITHM",
    "TOLERANCES",
    "LATER_TOLERANCES",
    "PERFORMANCE_HORIZON_S",
    "Certificate",
    "write_certificate",
    "load_certificate",
    "read_certificate",
    "check_form",
    "canonical_digest",
    "certificate_gains",
    "gains_json",
    "GAINS_LAW_KEY",
    "certificate_vehicle",
    "certificate_inner_loop",
]

#: Tolerances of :func:`nniquad.certificates.verify.verify_certificate` (stored in every certificate for the record).
TOLERANCES: dict[str, float] = {
    "lmi_relative": 1e-7,        # largest eigenvalue of a Lyapunov expression, relative to its scale
    "rate_relative": 1e-6,       # certified decay rate may fall short of the stated one by this fraction
    "sector_relative": 1e-9,     # recomputed smallest gamma vs stated
    "settling_abs_s": 2e-3,      # re-simulated settling time vs stated
    "overshoot_abs_pct": 0.05,   # re-simulated overshoot vs stated (percentage points)
    "tilt_abs_deg": 0.02,        # re-simulated peak tilt vs stated
    "margin_db_abs": 0.05,       # recomputed classical gain margins vs stated [dB]
    "margin_deg_abs": 0.05,      # recomputed phase margins vs stated [deg]
    "margin_freq_relative": 1e-3,  # recomputed crossover frequencies vs stated
    "offset_abs_m": 1e-4,        # re-simulated steady offset vs stated [m] (certificates since issue 44)
}

#: Tolerances added after certificates were first written, each with the stated number it checks: a certificate
#: whose tolerances lack one states none of those numbers and is read with its old meaning (it does not claim them).
LATER_TOLERANCES: dict[str, str] = {"offset_abs_m": "steady_offset_m"}

#: Default horizon of the certificate's performance runs [s].
PERFORMANCE_HORIZON_S = 20.0
#: The stated form of the plant's and the controller's NI certificates (``lmi.*_ni.form``).
NI_FORM = "V' <= ydot' u (dissipation)"
#: The stated saturation model of the region of attraction (``region_of_attraction.model``).
ROA_MODEL = "norm-limited horizontal acceleration, rotation-invariant ellipsoid"

#: Output sample period of the certificate's performance runs [s].
PERFORMANCE_OUTPUT_DT_S = 0.005


def reference_run_options(model: str, inner: InnerLoopGains, *, tilt_limit_deg: float, xi0: Any,
                          horizon_s: float = PERFORMANCE_HORIZON_S, motor_lag: bool = True,
                          rate_hz: float | None = None) -> Any:
    """The simulation options of a certificate's reference run (``reduced`` or ``full``).

    The one definition :func:`nniquad.certificates.build.performance_runs` simulates
    with and :func:`nniquad.certificates.verify.verify_certificate` compares the stated
    ``performance.*.settings`` against: the nominal vehicle at rest at ``xi0``, no noise,
    wind or gust, motor lag in ``full`` only.  The ``reduced`` run is the paper's
    continuous loop; the ``full`` run is what flies when ``rate_hz`` is given (a
    schema-2 certificate: the position sampled at the certified rate, the NNI
    controller in discrete time, its exact ZOH equivalent) and continuous otherwise
    (schema 1).

    Parameters
    ----------
    model
        ``"reduced"`` or ``"full"``.
    inner
        Inner-loop gains.
    tilt_limit_deg
        Tilt limit [deg].
    xi0
        Initial horizontal position [m].
    horizon_s
        Simulated time [s].
    motor_lag
        Motor lag on in the ``full`` run.
    rate_hz
        Control rate of the ``full`` run [Hz]; ``None``: continuous measurement.

    Returns
    -------
    nniquad.sim.SimOptions
    """
    from nniquad.sim import SimOptions  # lazily: reading a certificate needs no CasADi

    opts = SimOptions(model=model, horizon_s=horizon_s, output_dt_s=PERFORMANCE_OUTPUT_DT_S,
                      tilt_limit_deg=tilt_limit_deg, xi0=tuple(xi0), motor_lag=motor_lag and model == "full",
                      inner=inner)
    if rate_hz is not None and model == "full":
        opts = opts.with_(controller_sampling="discrete", noise_rate_hz=float(rate_hz))
    return opts


def read_certificate(path: str | Path) -> "Certificate":
    """Read a certificate file as a :class:`Certificate` (form and every field checked).

    Parameters
    ----------
    path
        The certificate file.
    """
    return Certificate.from_json(load_certificate(path), where=str(path))


# ----------------------------------------------------------------------------- the typed certificate


#: JSON's scalar types, returned as they are by :func:`_freeze` and :func:`_thaw` (tested by exact type first:
#: ``isinstance`` against ``typing.Mapping`` costs a microsecond per value, and a certificate has 10^5 of them).
_SCALARS = frozenset((float, int, str, bool, type(None)))


def _freeze(value: Any) -> Any:
    """JSON data as read-only data: objects become mapping proxies, arrays tuples."""
    t = type(value)
    if t in _SCALARS:
        return value
    if t is list or t is tuple:
        return tuple(_freeze(v) for v in value)
    if isinstance(value, Mapping):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    """The inverse of :func:`_freeze` (plain dicts and lists, JSON ready)."""
    t = type(value)
    if t in _SCALARS:
        return value
    if t is tuple:
        return [_thaw(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


@dataclass(frozen=True)
class Certificate:
    """A signed, immutable certificate of one gain set (the JSON document of the module docstring).

    The typed fields are the vehicle, the gains and the inner loops; the
    sections (``sector``, ``lmi``, ``performance``, ...) are read-only mappings
    with the JSON's own keys (matrices as tuples of tuples).  ``signature`` is
    the digest stored at signing; :attr:`digest` recomputes it from the content,
    so an edited copy (``dataclasses.replace``) no longer verifies until
    :meth:`signed` is called.

    Attributes
    ----------
    model
        The model the gains were tuned on (``'reduced'`` or ``'full'``).
    vehicle
        The certified vehicle.
    gains
        The certified gains (equal axes) of a law of the NI structure.
    inner_loop
        The inner-loop gains of the ``full`` performance run.
    tilt_limit_deg
        Tilt limit [deg].
    xi0_m
        Initial horizontal position of the reference runs [m].
    sector, stability_margin, lmi, region_of_attraction, performance, bound, ratio_to_bound, tolerances, software
        The sections of the document (read-only mappings).
    start_certified
        Whether ``xi0_m`` lies in the certified regions: with a ``start`` section in every one it names
        (``start.every_method``); without one (an older certificate), in the reduced loop's region only.
    tuning
        How the gains were found (``None`` if not recorded).
    cascade
        The sampled-data cascade section (schema 2); ``None`` in a schema-1
        certificate, which then has no such field (its digest is unchanged).
    margins
        Classical margins of the linearised cascade at both break points
        (:func:`nniquad.certificates.build.margins_section`); ``None`` in a
        certificate written before they were stated (it then has no such field,
        so its digest is unchanged).
    law_class
        ``{"name", "theorem"}`` (:mod:`nniquad.laws.classes`); ``None`` in a
        certificate written before classes existed (of the ``paper`` class, no such
        field, digest unchanged): :attr:`law_class_name` resolves it.
    start
        The start's status per method (:func:`nniquad.certificates.start.start_section`); ``None`` in a
        certificate written before it existed (no such field, digest unchanged):
        :func:`nniquad.certificates.start.start_methods` derives it.
    tracking
        The certified tracking-error bound (:mod:`nniquad.analysis.tracking_section`); ``None`` in a
        certificate written before it was stated (no such field, digest unchanged).
    delay_samples
        The measurement delay [samples] the cascade section certifies; ``None`` in a certificate written
        before it was stated (no such field, digest unchanged; it covers no delay: :attr:`certified_delay_samples`).
    signature
        The SHA-256 digest (hex) the certificate was signed with.
    """

    SCHEMA: ClassVar[str] = SCHEMA
    SCHEMA_VERSION: ClassVar[int] = SCHEMA_VERSION

    model: str
    vehicle: Vehicle
    gains: GainBlock
    inner_loop: InnerLoopGains
    tilt_limit_deg: float
    xi0_m: tuple[float, float]
    sector: Mapping[str, Any]
    stability_margin: Mapping[str, Any]
    lmi: Mapping[str, Any]
    region_of_attraction: Mapping[str, Any]
    start_certified: bool
    performance: Mapping[str, Any]
    bound: Mapping[str, Any]
    ratio_to_bound: Mapping[str, Any]
    tolerances: Mapping[str, Any]
    tuning: Mapping[str, Any] | None
    software: Mapping[str, Any]
    signature: str = ""
    margins: Mapping[str, Any] | None = None
    cascade: Mapping[str, Any] | None = None
    law_class: Mapping[str, Any] | None = None
    start: Mapping[str, Any] | None = None
    tracking: Mapping[str, Any] | None = None
    delay_samples: int | None = None

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name in _SECTIONS or f.name in ("tuning", "margins", "cascade", "law_class", "start", "tracking"):
                object.__setattr__(self, f.name, _freeze(getattr(self, f.name)))
        object.__setattr__(self, "xi0_m", tuple(float(v) for v in self.xi0_m))

    # ------------------------------------------------------------------ JSON

    def body(self) -> dict[str, Any]:
        """The signed content: every field but the digest, as plain JSON data."""
        body = {
            "schema": SCHEMA,
            "schema_version": self.schema_version,
            "model": self.model,
            "vehicle": self.vehicle.as_dict(),
            "gains": gains_json(self.gains),
            "inner_loop": self.inner_loop.as_dict(),
            "tilt_limit_deg": self.tilt_limit_deg,
            "xi0_m": list(self.xi0_m),
            "sector": _thaw(self.sector),
            "stability_margin": _thaw(self.stability_margin),
            "lmi": _thaw(self.lmi),
            "region_of_attraction": _thaw(self.region_of_attraction),
            "start_certified": self.start_certified,
            "performance": _thaw(self.performance),
            "bound": _thaw(self.bound),
            "ratio_to_bound": _thaw(self.ratio_to_bound),
            "tolerances": _thaw(self.tolerances),
            "tuning": _thaw(self.tuning),
            "software": _thaw(self.software),
        }
        if self.margins is not None:  # optional: older certificates have none and keep their digest
            body["margins"] = _thaw(self.margins)
        if self.cascade is not None:  # schema 2 only: a schema-1 certificate keeps its digest
            body["cascade"] = _thaw(self.cascade)
        if self.law_class is not None:  # optional: older certificates (class paper) have none and keep their digest
            body["law_class"] = _thaw(self.law_class)
        if self.start is not None:  # optional: older certificates have none and keep their digest
            body["start"] = _thaw(self.start)
        if self.tracking is not None:  # optional: older certificates have none and keep their digest
            body["tracking"] = _thaw(self.tracking)
        if self.delay_samples is not None:  # optional: older certificates have none and keep their digest
            body["delay_samples"] = self.delay_samples
        return body

    @property
    def certified_delay_samples(self) -> int:
        """The measurement delay [samples] the certificate covers: its ``delay_samples``, 0 when it states none."""
        return 0 if self.delay_samples is None else int(self.delay_samples)

    @property
    def law_class_name(self) -> Any:
        """The stated class name (``law_class.name``); ``"paper"`` when the certificate states none."""
        return DEFAULT_LAW_CLASS if self.law_class is None else self.law_class.get("name")

    @property
    def schema_version(self) -> int:
        """2 (:data:`CASCADE_SCHEMA_VERSION`) with a ``cascade`` section, else 1."""
        return CASCADE_SCHEMA_VERSION if self.cascade is not None else SCHEMA_VERSION

    def to_json(self) -> dict[str, Any]:
        """The JSON document: :meth:`body` plus ``digest = {'algorithm': 'sha256', 'value': signature}``."""
        return {**self.body(), "digest": {"algorithm": DIGEST_ALGORITHM, "value": self.signature}}

    @property
    def digest(self) -> str:
        """SHA-256 (hex) of the canonical JSON of :meth:`body`, recomputed now.

        Of a certificate read by :meth:`from_json` it is known without recomputing: there the content was shown to
        read back to exactly the text its signature is the digest of (the fields are immutable, and
        ``dataclasses.replace`` builds a new certificate without it).
        """
        known = self.__dict__.get("_read_back_digest")
        return known if known is not None else canonical_digest(self.body())

    @property
    def signature_ok(self) -> bool:
        """Whether the stored signature matches the content."""
        return self.signature == self.digest

    def signed(self) -> "Certificate":
        """A copy signed with its current content."""
        return replace(self, signature=self.digest)

    @classmethod
    def from_json(cls, data: Mapping[str, Any], where: str = "certificate") -> "Certificate":
        """A certificate from its JSON mapping; the form, the digest and every field are checked.

        Parameters
        ----------
        data
            The decoded JSON document.
        where
            Name of the document in the messages.

        Raises
        ------
        CertificateError
            One line naming the problem: a form error (schema, version, digest),
            a missing or wrongly typed field, or a field that does not read back
            exactly as it was signed.
        """
        if isinstance(data, Certificate):
            return data
        data = dict(data) if isinstance(data, Mapping) else data
        signed_text = checked_form_text(data, where)  # the content the digest is of, checked against it
        missing = [k for k in _ALL_FIELDS if k not in data]
        extra = [k for k in data
                 if k not in _ALL_FIELDS and k not in _OPTIONAL_FIELDS]
        if missing or extra:
            what = f"lacks '{missing[0]}'" if missing else f"has an unknown field '{extra[0]}'"
            raise CertificateError(f"{where}: {what}")
        for key in _SECTIONS:
            section_of(data, key)
        for key in ("margins", "law_class", "start", "tracking"):
            if key in data and not isinstance(data[key], Mapping):
                raise CertificateError(f"{where}: '{key}' must be an object")
        delay = data.get("delay_samples")
        if delay is not None and (isinstance(delay, bool) or not isinstance(delay, int) or delay < 0):
            raise CertificateError(f"{where}: 'delay_samples' must be a whole number of samples >= 0")
        if data["tuning"] is not None and not isinstance(data["tuning"], Mapping):
            raise CertificateError(f"{where}: 'tuning' must be an object or null")
        if not isinstance(data["model"], str) or not isinstance(data["start_certified"], bool):
            raise CertificateError(f"{where}: 'model' must be a string and 'start_certified' a boolean")
        xi0 = data["xi0_m"]
        if not (isinstance(xi0, list) and len(xi0) == 2 and all(_is_number(v) for v in xi0)):
            raise CertificateError(f"{where}: 'xi0_m' must be two numbers")
        if not _is_number(data["tilt_limit_deg"]):
            raise CertificateError(f"{where}: 'tilt_limit_deg' must be a number")
        if not isinstance(data.get("inner_loop"), Mapping):
            raise CertificateError(f"{where}: certificate 'inner_loop' must be an object")
        cert = cls(
            model=data["model"], vehicle=certificate_vehicle(data), gains=certificate_gains(data),
            inner_loop=certificate_inner_loop(data), tilt_limit_deg=float(data["tilt_limit_deg"]),
            xi0_m=tuple(xi0), start_certified=data["start_certified"], tuning=data["tuning"],
            signature=data["digest"]["value"], margins=data.get("margins"), cascade=data.get("cascade"),
            law_class=data.get("law_class"), start=data.get("start"), tracking=data.get("tracking"),
            delay_samples=delay, **{k: data[k] for k in _SECTIONS},
        )
        # the typed fields must serialise back to exactly what was signed (one comparison of the whole text:
        # JSON values are self-delimiting, so equal texts of the same keys are equal field by field)
        body = cert.body()
        if canonical_json(body) != signed_text:
            for key, value in body.items():
                if key not in data or canonical_json(value) != canonical_json(data[key]):
                    raise CertificateError(f"{where}: field '{key}' does not read back as it was signed "
                                           "(unexpected type or extra entries)")
            raise CertificateError(f"{where}: the fields do not read back as they were signed")
        # so the content's digest is the signature, which checked_form_text matched
        object.__setattr__(cert, "_read_back_digest", cert.signature)
        return cert

    # ------------------------------------------------------------------ derived objects

    @property
    def loop(self) -> ReducedLoop:
        """The certified reduced loop (vehicle mass and gravity, gains)."""
        return ReducedLoop.from_vehicle(self.vehicle, self.gains)

    @property
    def controller(self) -> str:
        """The certified law's name (the type of :attr:`gains`)."""
        return self.gains.controller

    def run_settings(self, model: str = "full") -> Any:
        """Everything the reference run ``performance.<model>`` was flown with, to fly it again.

        The vehicle, the gains (the law), and the complete simulation options (inner
        loops, rate and controller sampling, motor lag, start, horizon, tilt limit, step
        and output period), read back from the run's recorded ``settings``:
        ``run.simulate()`` or ``nniquad.simulate(**run.kwargs())`` reproduces the stated
        numbers (``run.stated``) within :attr:`tolerances`.

        Parameters
        ----------
        model
            ``"full"`` (default) or ``"reduced"``.

        Returns
        -------
        nniquad.certificates.reference_run.ReferenceRun
        """
        # lazily: the run's options live in nniquad.sim, and reading a certificate needs no CasADi
        from nniquad.certificates.reference_run import reference_run_of

        return reference_run_of(self, model)

    @property
    def certified_reach_m(self) -> float:
        """The certified displacement from rest [m] (``region_of_attraction.max_displacement_m``)."""
        return float(self.region_of_attraction["max_displacement_m"])

    def write(self, path: str | Path) -> Path:
        """Write the certificate atomically to ``path`` (JSON); returns the path.

        Parameters
        ----------
        path
            Destination file (its folder is created if needed).
        """
        return write_certificate(self, path)

    @classmethod
    def read(cls, path: str | Path) -> "Certificate":
        """Read and form-check a certificate file (:func:`read_certificate`).

        Parameters
        ----------
        path
            A certificate written by :meth:`write` or ``nniquad certify``.
        """
        return read_certificate(path)

    def __repr__(self) -> str:
        gains = ", ".join(f"{k}={v:.6g}" for k, v in gains_json(self.gains).items() if k != GAINS_LAW_KEY)
        law = f"controller={self.controller!r}, " if GAINS_LAW_KEY in gains_json(self.gains) else ""
        return (f"Certificate(vehicle={self.vehicle.name!r}, {law}{gains}, "
                f"model={self.model!r}, reach={self.region_of_attraction.get('max_displacement_m')!r} m, "
                f"digest={self.signature[:16]}...)")


_SECTIONS = ("sector", "stability_margin", "lmi", "region_of_attraction", "performance", "bound", "ratio_to_bound",
             "tolerances", "software")
_ALL_FIELDS = ("model", "vehicle", "gains", "inner_loop", "tilt_limit_deg", "xi0_m", *_SECTIONS, "start_certified",
               "tuning")
#: Top-level fields besides :data:`_ALL_FIELDS`: the form's own, and the sections a certificate may lack.
_OPTIONAL_FIELDS = ("schema", "schema_version", "digest", "margins", "cascade", "law_class", "start", "tracking",
                    "delay_samples")


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
