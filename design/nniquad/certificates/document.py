"""The certificate file format: schema, version, canonical digest, form check, reading and writing.

A certificate is a JSON document (fields in :mod:`nniquad.certificates.certificate`).
This module knows only its envelope: the ``schema`` name and ``schema_version``
(1 without, 2 with the sampled-data ``cascade`` section), and the ``digest``,
SHA-256 of the canonical JSON of every other top-level field (sorted keys, no
whitespace, UTF-8, no NaN), so that no field can be edited without re-signing.
:func:`load_certificate` reads a file through the project's bounded reader and
checks that envelope; :func:`write_certificate` writes atomically.  What the
fields mean is checked by :class:`nniquad.certificates.certificate.Certificate`
and recomputed by :mod:`nniquad.certificates.verify`.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, Mapping

from nniquad.errors import CertificateCheckError, CertificateError
from nniquad.io import atomic_write_text, parse_data, read_text_file

__all__ = ["SCHEMA", "SCHEMA_VERSION", "CASCADE_SCHEMA_VERSION", "SCHEMA_VERSIONS", "DIGEST_ALGORITHM",
           "canonical_digest", "canonical_json", "check_form", "checked_form_text", "load_certificate",
           "write_certificate"]

SCHEMA = "nniquad-certificate"
#: Version of a certificate without a ``cascade`` section (every certificate written before the sampled-data cascade section).
SCHEMA_VERSION = 1
#: Version of a certificate with a ``cascade`` section (the sampled-data cascade over a parameter box).
CASCADE_SCHEMA_VERSION = 2
#: The versions :func:`check_form` reads.
SCHEMA_VERSIONS: tuple[int, ...] = (SCHEMA_VERSION, CASCADE_SCHEMA_VERSION)
DIGEST_ALGORITHM = "sha256"


def canonical_json(value: Any) -> str:
    """Canonical JSON text of ``value``: sorted keys, no whitespace, UTF-8 characters kept, no NaN."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def canonical_digest(cert: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of the certificate without its ``digest``.

    Every other top-level field is covered, whatever its name: the canonical JSON
    has sorted keys, no whitespace, UTF-8 and no NaN.

    Parameters
    ----------
    cert
        The certificate as a JSON mapping.
    """
    body = {k: v for k, v in cert.items() if k != "digest"}
    return hashlib.sha256(canonical_json(body).encode("utf-8")).hexdigest()


def check_form(cert: Any, where: str = "certificate") -> None:
    """Check a certificate mapping's form: a JSON object, schema, version, digest algorithm and value.

    Parameters
    ----------
    cert
        The decoded JSON document.
    where
        Name of the document in the messages (e.g. its path).

    Raises
    ------
    CertificateError
        One line naming the problem.
    """
    checked_form_text(cert, where)


def checked_form_text(cert: Any, where: str = "certificate") -> str:
    """:func:`check_form` (same arguments and errors), returning the canonical JSON of the signed content, which
    is what the digest is of: :meth:`Certificate.from_json` compares its read-back fields with it."""
    if not isinstance(cert, dict):
        raise CertificateError(f"{where}: top level must be a JSON object")
    if cert.get("schema") != SCHEMA:
        raise CertificateError(f"{where}: schema is {cert.get('schema')!r}, expected {SCHEMA!r}")
    version = cert.get("schema_version")
    if version not in SCHEMA_VERSIONS or isinstance(version, bool) or not isinstance(version, int):
        raise CertificateError(f"{where}: schema version {version!r} is not supported "
                               f"(expected one of {', '.join(map(str, SCHEMA_VERSIONS))})")
    # the version states the layout: 2 has the sampled-data cascade section, 1 has none
    has_cascade = "cascade" in cert
    if version == CASCADE_SCHEMA_VERSION and not isinstance(cert.get("cascade"), dict):
        raise CertificateError(f"{where}: schema version {version} needs a 'cascade' object")
    if version == SCHEMA_VERSION and has_cascade:
        raise CertificateError(f"{where}: schema version {version} has no 'cascade' section "
                               f"(a cascade certificate is version {CASCADE_SCHEMA_VERSION})")
    digest = cert.get("digest")
    if not isinstance(digest, dict) or not isinstance(digest.get("value"), str):
        raise CertificateError(f"{where}: no digest")
    if digest.get("algorithm") != DIGEST_ALGORITHM or set(digest) != {"algorithm", "value"}:
        raise CertificateError(f"{where}: digest must be {{'algorithm': {DIGEST_ALGORITHM!r}, 'value': ...}}, "
                               f"got algorithm {digest.get('algorithm')!r}")
    try:
        text = canonical_json({k: v for k, v in cert.items() if k != "digest"})
    except (TypeError, ValueError) as exc:
        raise CertificateError(f"{where}: content cannot be canonicalised ({exc})") from None
    if hashlib.sha256(text.encode("utf-8")).hexdigest() != digest["value"]:
        raise CertificateCheckError(f"{where}: digest mismatch (content changed after signing)")
    return text


def load_certificate(path: str | Path) -> dict[str, Any]:
    """Read a certificate file as a plain mapping and check its form: JSON, schema, version, digest.

    Only the form is checked (what ``simulate --certificate`` and the Monte Carlo
    study need); :func:`read_certificate` also types every field.

    Parameters
    ----------
    path
        The certificate file.

    Raises
    ------
    CertificateError
        One line naming the problem (unreadable, not JSON, wrong schema or
        version, digest mismatch).
    """

    p = Path(path)
    # the shared reader: a regular file of bounded size, UTF-8, no duplicate keys, bounded nesting and integers
    cert = parse_data(read_text_file(p, what="certificate", error=CertificateError), "json",
                      where=f"certificate {p}", error=CertificateError)
    check_form(cert, str(p))
    return cert


def write_certificate(cert: "Certificate | Mapping[str, Any]", path: str | Path) -> Path:
    """Write atomically (temporary file, then rename); the certificate's form is checked first.

    Parameters
    ----------
    cert
        A :class:`Certificate` or its JSON mapping.
    path
        Destination file.
    """
    data = dict(cert) if isinstance(cert, Mapping) else cert.to_json()
    check_form(data)
    return atomic_write_text(Path(path), json.dumps(data, indent=2, allow_nan=False) + "\n")
