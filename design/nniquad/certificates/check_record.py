"""One check of a verification, and the tools every re-check of :mod:`nniquad.certificates.verify` shares.

:class:`Check` is a named verdict with its evidence; :func:`stated_part` and
:func:`stated_array` read a stated section or matrix (a missing or misshapen
one is a failed check, never an exception that escapes); :func:`memo` caches
the expensive recomputations (re-simulations, margins, the bound, the cascade
check and its grid, region and margin rows) in this process by their exact inputs, so that the tamper loop's many
edits of unrelated fields do not redo them (:func:`clear_cache` empties it).
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from nniquad.certificates.certificate import Certificate, gains_json
from nniquad.errors import CertificateError

__all__ = ["Check", "stated_array", "stated_part", "memo", "clear_cache", "thaw_json", "gains_key", "is_number",
           "close", "fmt_value"]


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


def stated_array(cert_part: Mapping[str, Any], key: str, shape: tuple[int, int], where: str) -> np.ndarray:
    try:
        M = np.array(cert_part[key], dtype=float)
    except (KeyError, TypeError, ValueError):
        raise CertificateError(f"certificate {where}.{key} is missing or not a numeric matrix") from None
    if M.shape != shape or not np.all(np.isfinite(M)):
        raise CertificateError(f"certificate {where}.{key} must be a finite {shape[0]}x{shape[1]} matrix")
    return M


def stated_part(section: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    value = section.get(key)
    if not isinstance(value, Mapping):
        raise CertificateError(f"certificate has no valid '{where}.{key}' (dict expected)")
    return value


_CACHE: dict[tuple[str, str], Any] = {}


_CACHE_SIZE = 256


def memo(kind: str, inputs: Any, compute: Callable[[], Any]) -> Any:
    """``compute()``, cached in this process by ``kind`` and the exact ``inputs`` (canonical JSON, floats by repr).

    A result depends only on its inputs (the simulator and the margins are
    deterministic), so an unchanged recomputation is not repeated: verifying a
    certificate twice, or many edited copies of one, re-simulates only what changed.
    At most ``_CACHE_SIZE`` results are kept; the least recently used one goes first.
    """
    key = (kind, json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=True))
    if key in _CACHE:
        _CACHE[key] = _CACHE.pop(key)  # most recently used last: a stream of one-off edits evicts itself, not it
        return copy.deepcopy(_CACHE[key])
    value = compute()
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))  # the least recently used entry
    _CACHE[key] = value
    return copy.deepcopy(value)


def clear_cache() -> None:
    """Forget every cached recomputation (re-simulations, margins, bounds) of :func:`verify_certificate`."""
    _CACHE.clear()


def thaw_json(value: Any) -> Any:
    """A read-only section as plain JSON data (dicts and lists)."""
    return json.loads(json.dumps(value, default=lambda o: dict(o) if isinstance(o, Mapping) else list(o)))


def gains_key(cert: Certificate) -> dict[str, Any]:
    """The certified law and gains, as the exact inputs of a cached recomputation (:func:`memo`)."""

    return {"controller": cert.controller, **gains_json(cert.gains)}


def is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def close(stated: Any, computed: float, rtol: float) -> bool:
    """Whether a stated number (any JSON value) equals a recomputed one within ``rtol`` (relative, and absolute near 0)."""
    if isinstance(stated, bool) or not isinstance(stated, (int, float)):
        return False
    return math.isfinite(stated) and abs(float(stated) - computed) <= rtol * max(abs(computed), 1e-300) + 1e-300


def fmt_value(x: Any) -> str:
    return "none" if x is None else f"{float(x):.5g}"
