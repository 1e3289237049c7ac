"""Certificates: a signed gain set with everything needed to check it, and the independent check.

:mod:`.certificate`
    The document (:class:`Certificate`), its digest, form checks and file IO.
:mod:`.build`
    :func:`build_certificate`: solve the LMIs, simulate, sign.
:mod:`.verify`
    :func:`verify_certificate`: recompute every statement, a :class:`Verification`.
"""

from nniquad.certificates.build import build_certificate, performance_runs
from nniquad.certificates.certificate import (
    CASCADE_SCHEMA_VERSION,
    SCHEMA,
    SCHEMA_VERSION,
    SCHEMA_VERSIONS,
    TOLERANCES,
    Certificate,
    canonical_digest,
    certificate_gains,
    certificate_inner_loop,
    certificate_vehicle,
    check_form,
    load_certificate,
    read_certificate,
    write_certificate,
)
from nniquad.certificates.verify import Check, Verification, verify_certificate

__all__ = [
    "SCHEMA", "SCHEMA_VERSION", "SCHEMA_VERSIONS", "CASCADE_SCHEMA_VERSION", "TOLERANCES", "Certificate",
    "canonical_digest", "check_form", "load_certificate", "read_certificate", "write_certificate", "certificate_gains",
    "certificate_vehicle", "certificate_inner_loop",
    "build_certificate", "performance_runs", "Check", "Verification", "verify_certificate",
]
