"""Typed values of a certificate's sections: its gains, vehicle and inner loops.

Each accessor takes a :class:`nniquad.certificates.certificate.Certificate`
(whose fields are typed already) or a form-checked JSON mapping (what
``simulate --certificate``, the Monte Carlo study and the export read), and
turns a bad section into one :class:`nniquad.errors.CertificateError` line.
"""

from __future__ import annotations

from dataclasses import fields
from typing import TYPE_CHECKING, Any, Mapping

from nniquad.control.gains import DEFAULT_INNER_LOOP_GAINS, Gains, InnerLoopGains, SNI2Gains
from nniquad.errors import CertificateError, GainError, NniquadError, VehicleError
from nniquad.model.vehicle import Vehicle

if TYPE_CHECKING:
    from nniquad.certificates.certificate import Certificate

__all__ = ["GAINS_LAW_KEY", "gains_json", "certificate_gains", "certificate_vehicle", "certificate_inner_loop"]


def _get(cert: Mapping[str, Any], key: str, kind: type = dict) -> Any:
    value = cert.get(key) if isinstance(cert, Mapping) else None
    if not isinstance(value, kind):
        raise CertificateError(f"certificate has no valid '{key}' ({kind.__name__} expected)")
    return value


#: The ``controller`` entry of the ``gains`` section of a law other than the NNI law (whose section has none).
GAINS_LAW_KEY = "controller"


def gains_json(gains: Gains | SNI2Gains) -> dict[str, Any]:
    """The ``gains`` section of a gain set: ``kp, Gamma, delta`` (NNI), ``controller, kp, k, omega, zeta`` (``sni2``)."""
    if isinstance(gains, SNI2Gains):
        return {GAINS_LAW_KEY: gains.controller, **gains.values()}
    return {"kp": gains.kp, "Gamma": gains.Gamma, "delta": gains.delta}


def certificate_gains(cert: "Mapping[str, Any] | Certificate") -> Gains | SNI2Gains:
    """The certified gain set, of a :class:`Certificate` or of a form-checked mapping.

    Parameters
    ----------
    cert
        The certificate.
    """
    if not isinstance(cert, Mapping):  # a Certificate: typed already
        return cert.gains
    g = _get(cert, "gains")
    law = g.get(GAINS_LAW_KEY, "nni")
    if law == SNI2Gains.controller:
        names = [f.name for f in fields(SNI2Gains)]
        missing = [k for k in names if k not in g]
        if missing:
            raise CertificateError(f"certificate 'gains' lacks '{missing[0]}'")
        try:
            return SNI2Gains(**{k: g[k] for k in names})
        except (GainError, TypeError) as exc:
            raise CertificateError(f"certificate gains: {exc}") from None
    if GAINS_LAW_KEY in g:  # the NNI law's section names no law: any other value is not a certified law
        raise CertificateError(f"certificate 'gains' names an unknown law {law!r} (known: nni without the key, "
                               f"{SNI2Gains.controller})")
    missing = [k for k in ("kp", "Gamma", "delta") if k not in g]
    if missing:
        raise CertificateError(f"certificate 'gains' lacks '{missing[0]}'")
    try:
        return Gains(kp=g["kp"], Gamma=g["Gamma"], delta=g["delta"])
    except (GainError, TypeError) as exc:
        raise CertificateError(f"certificate gains: {exc}") from None


def certificate_vehicle(cert: "Mapping[str, Any] | Certificate") -> Vehicle:
    """The certified vehicle (validated as any vehicle file is).

    Parameters
    ----------
    cert
        The certificate.
    """
    from nniquad.model.vehicle import vehicle_from_mapping

    if not isinstance(cert, Mapping):  # a Certificate: typed already
        return cert.vehicle
    try:
        return vehicle_from_mapping(_get(cert, "vehicle"), source="certificate")
    except VehicleError as exc:
        raise CertificateError(f"certificate vehicle: {exc}") from None


def certificate_inner_loop(cert: "Mapping[str, Any] | Certificate") -> InnerLoopGains:
    """The inner-loop gains the ``full`` performance was measured with.

    Parameters
    ----------
    cert
        The certificate (a mapping without ``inner_loop`` gets the defaults).
    """
    if not isinstance(cert, Mapping):  # a Certificate: typed already
        return cert.inner_loop
    data = cert.get("inner_loop", DEFAULT_INNER_LOOP_GAINS.as_dict())
    if not isinstance(data, Mapping):
        raise CertificateError("certificate 'inner_loop' must be an object")
    try:
        return InnerLoopGains(**data)
    except TypeError as exc:
        raise CertificateError(f"certificate inner_loop: {exc}") from None
    except NniquadError as exc:
        raise CertificateError(f"certificate inner_loop: {exc}") from None
