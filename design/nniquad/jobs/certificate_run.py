"""Flying a certificate's reference run again: :func:`simulate_certificate`."""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from nniquad.certificates.certificate import Certificate, read_certificate
from nniquad.sim import SimulationResult

__all__ = ["simulate_certificate"]


def simulate_certificate(cert: Certificate | str | Path, model: str = "full", *,
                         progress: Callable[[float], None] | None = None) -> SimulationResult:
    """Fly a certificate's reference run again: its vehicle, gains, inner loops, rate, motor lag, start, horizon.

    The metrics of the result reproduce the certificate's ``performance.<model>``
    within its tolerances (what ``nniquad verify`` checks);
    :meth:`~nniquad.certificates.certificate.Certificate.run_settings` gives the run itself,
    to change a setting (``run.with_(...)``) or to read what it uses.

    Parameters
    ----------
    cert
        A :class:`~nniquad.certificates.certificate.Certificate` or the path of one (form and digest checked).
    model
        ``"full"`` (default) or ``"reduced"``.
    progress
        Called with the completed fraction.

    Raises
    ------
    CertificateError
        The file is not a certificate, or the certificate states no such run.
    """
    if isinstance(cert, (str, Path)):
        cert = read_certificate(cert)
    return cert.run_settings(model).simulate(progress)
