"""Typed values of a certificate's sections: its gains, vehicle and inner loops.

Each accessor takes a :class:`nniquad.certificates.certificate.Certificate`
(whose fields are typed already) or a form-checked JSON mapping (what
``simulate --certificate``, the Monte Carlo study and the export read), and
turns a bad section into one :class:`nniquad.errors.CertificateError` line.
"""

from __future__ import annotations

from typing import Any, Mapping

from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS, InnerLoopGains
from nniquad.errors import CertificateError, GainError, NniquadError, VehicleError
from nniquad.laws.base import ControlLaw, GainBlock
from nniquad.laws.registry import DEFAULT_LAW, law_named, law_names
from nniquad.model.vehicle import Vehicle, vehicle_from_mapping

__all__ = ["GAINS_LAW_KEY", "gains_json", "certificate_gains", "certificate_vehicle", "certificate_inner_loop"]


def section_of(cert: Mapping[str, Any], key: str, kind: type = dict) -> Any:
    value = cert.get(key) if isinstance(cert, Mapping) else None
    if not isinstance(value, kind):
        raise CertificateError(f"certificate has no valid '{key}' ({kind.__name__} expected)")
    return value


#: The ``controller`` entry of the ``gains`` section of a law other than the NNI law (whose section has none).
GAINS_LAW_KEY = ControlLaw.SECTION_LAW_KEY


def gains_json(gains: GainBlock) -> dict[str, Any]:
    """The ``gains`` section of a gain set (:meth:`nniquad.laws.base.ControlLaw.gains_json`: ``kp, Gamma, delta``
    for the NNI law, ``controller`` and every gain for the others).

    Parameters
    ----------
    gains
        A gain block.
    """
    return gains.law.gains_json(gains)


def certificate_gains(cert: "Mapping[str, Any] | Certificate") -> GainBlock:
    """The certified gain set, of a :class:`Certificate` or of a form-checked mapping.

    Parameters
    ----------
    cert
        The certificate.
    """
    if not isinstance(cert, Mapping):  # a Certificate: typed already
        return cert.gains
    g = section_of(cert, "gains")
    name = g.get(GAINS_LAW_KEY, DEFAULT_LAW)
    try:
        law = law_named(name)
    except GainError:
        raise CertificateError(f"certificate 'gains' names an unknown law {name!r} (known: {', '.join(law_names())})"
                               ) from None
    try:
        return law.gains_from_json(g)
    except GainError as exc:
        raise CertificateError(f"certificate 'gains' {exc}" if str(exc).startswith("lacks") else
                               f"certificate gains: {exc}") from None


def certificate_vehicle(cert: "Mapping[str, Any] | Certificate") -> Vehicle:
    """The certified vehicle (validated as any vehicle file is).

    Parameters
    ----------
    cert
        The certificate.
    """
    if not isinstance(cert, Mapping):  # a Certificate: typed already
        return cert.vehicle
    try:
        return vehicle_from_mapping(section_of(cert, "vehicle"), source="certificate")
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
