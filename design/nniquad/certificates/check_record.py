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
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.analysis.verified.inequalities import ProofRow, outcome_of
from nniquad.analysis.verified.spd import FAILS, NOT_PROVEN, PROVEN
from nniquad.certificates.certificate import Certificate, gains_json
from nniquad.errors import CertificateError

__all__ = ["Check", "proof_check", "PASS", "RECOMPUTED", "stated_array", "stated_part", "memo", "clear_cache", "thaw_json", "gains_key", "is_number",
           "close", "fmt_value"]


#: Outcome of a check decided by recomputing numbers (within the certificate's tolerances), not by a proof.
PASS = "pass"
#: Method name of such a check.
RECOMPUTED = "recomputed"


@dataclass
class Check:
    """One verification check: name, verdict, what was compared, and the proofs behind it.

    Attributes
    ----------
    name
        What was checked (``'sector'``, ``'lmi.plant_ni'``, ...).
    ok
        Whether it passed: its outcome is ``proven`` or ``pass``.
    detail
        The compared numbers, in one line.
    proofs
        The strict matrix inequalities this check proved (or failed to), each with its method and margin
        (:class:`nniquad.analysis.verified.inequalities.ProofRow`); empty for a check of recomputed numbers.
    outcome
        ``proven`` (every inequality proven, every recomputed number within tolerance), ``pass`` (no inequality:
        every recomputed number within tolerance), ``fails`` or ``not proven`` (nothing fails, but an inequality's
        margin is below what floating point can prove: never a pass).  Derived from ``ok`` when not given.
    requirement_met
        For a check of a requirement (the classical margins, the start inside a certified region, ...): whether
        the design meets it, recomputed; ``None`` for a check that states no requirement.  Independent of ``ok``:
        a certificate that truly states "the phase margin requirement is not met" passes (``ok``) with
        ``requirement_met`` false.
    """

    name: str
    ok: bool
    detail: str
    proofs: Sequence[ProofRow] = field(default_factory=tuple)
    outcome: str = ""
    requirement_met: bool | None = None

    def __post_init__(self) -> None:
        self.ok = bool(self.ok)  # numpy comparisons give numpy booleans, which JSON refuses
        if not self.outcome:
            self.outcome = (PROVEN if self.proofs else PASS) if self.ok else FAILS
        if self.outcome not in (PROVEN, PASS, FAILS, NOT_PROVEN):
            raise ValueError(f"unknown outcome {self.outcome!r}")
        self.ok = self.ok and self.outcome in (PROVEN, PASS)
        self.proofs = tuple(self.proofs)
        if self.requirement_met is not None:
            self.requirement_met = bool(self.requirement_met)

    @property
    def methods(self) -> list[str]:
        """The methods that decided it: ``verified-cholesky`` and ``exact`` for proofs, ``recomputed`` otherwise."""
        found = sorted({r.method for r in self.proofs})
        return found or [RECOMPUTED]

    @property
    def margin(self) -> float | None:
        """The smallest proven margin of its verified-Cholesky proofs (scaled units), or ``None``."""
        m = [r.margin for r in self.proofs if math.isfinite(r.margin)]
        return min(m) if m else None

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "ok": self.ok, "requirement_met": self.requirement_met, "outcome": self.outcome,
                "method": "+".join(self.methods), "margin": self.margin, "detail": self.detail, "proofs": [r.to_json() for r in self.proofs]}


def proof_check(name: str, recomputed_ok: bool, detail: str, proofs: Sequence[ProofRow]) -> Check:
    """A check whose strict inequalities are ``proofs`` and whose other numbers were recomputed (``recomputed_ok``).

    Its outcome: ``fails`` if a recomputed number is off or an inequality fails, ``not proven`` if one is not
    proven, ``proven`` otherwise.  The detail gets the proofs' summary appended.
    """
    proven = outcome_of(proofs)
    outcome = FAILS if not recomputed_ok or proven == FAILS else proven
    return Check(name, outcome == PROVEN, f"{detail}; {proof_summary(proofs)}", proofs, outcome)


def proof_summary(proofs: Sequence[ProofRow]) -> str:
    """``'3 inequalities proven (verified-cholesky, exact), smallest margin 1.2e-03'`` or what failed."""
    if not proofs:
        return "no inequality"
    methods = ", ".join(sorted({r.method for r in proofs}))
    bad = [r for r in proofs if r.outcome != PROVEN]
    if bad:
        first = bad[0]
        where = f" at {first.where}" if first.where else ""
        return f"{len(bad)} of {len(proofs)} {first.outcome} ({first.method}: {first.inequality}{where})"
    margins = [r.margin for r in proofs if math.isfinite(r.margin)]
    small = f", smallest margin {min(margins):.2e}" if margins else ""
    return f"{len(proofs)} proven ({methods}){small}"


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
