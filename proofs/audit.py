"""The job ``audit``: every claim of the paper checked, as one result object."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Sequence

from nniquad.errors import NniquadError
from nniquad.proofs.claims import (
    VERDICTS,
    ClaimResult,
    audit_table,
    audit_to_json,
    audit_to_markdown,
    claim_ids,
    run_audit,
)

__all__ = ["Audit", "audit"]


@dataclass(frozen=True)
class Audit:
    """The audited claims (see :func:`audit`).

    Attributes
    ----------
    claims
        One :class:`nniquad.proofs.claims.ClaimResult` per claim, in report order.
    """

    claims: tuple[ClaimResult, ...]

    def __len__(self) -> int:
        return len(self.claims)

    def __iter__(self):
        return iter(self.claims)

    def __getitem__(self, key: int | str) -> ClaimResult:
        if isinstance(key, str):
            for c in self.claims:
                if c.id == key:
                    return c
            raise KeyError(key)
        return self.claims[key]

    @property
    def verdicts(self) -> dict[str, int]:
        """Number of claims per verdict."""
        return {v: sum(c.verdict == v for c in self.claims) for v in VERDICTS}

    def __repr__(self) -> str:
        counts = ", ".join(f"{n} {v}" for v, n in self.verdicts.items())
        return f"Audit({len(self.claims)} claims: {counts})"

    def table(self, width: int = 100) -> str:
        """Plain-text table ``id | verdict | reason``.

        Parameters
        ----------
        width
            Longest reason shown before it is cut.
        """
        return audit_table(list(self.claims), width)

    def markdown(self) -> str:
        """The report a reader can follow without running code."""
        return audit_to_markdown(list(self.claims))

    def to_json(self) -> dict[str, Any]:
        """``{"claims": [...], "summary": {...}}``."""
        return audit_to_json(list(self.claims))


def audit(only: Iterable[str] | None = None, section: str | None = None, *, workers: int = 1) -> Audit:
    """Audit the claims of Ghallab & Petersen's paper, one check per claim.

    Parameters
    ----------
    only
        Claim ids to run (default: all, see :func:`nniquad.proofs.claims.claim_ids`).
    section
        Run only the claims of this paper section (``"ni_preliminaries"``,
        ``"quadrotor_model"``, ``"control_design"``, ``"simulation"``), or the project's
        extensions (``"extensions"``: not claims of the paper).
    workers
        Processes to run the claims in, one paper section per task
        (:func:`nniquad.proofs.claims.run_audit`); the results do not depend on it.

    Returns
    -------
    Audit
        Verdict, evidence, counterexample and correction of every claim.

    Raises
    ------
    NniquadError
        An unknown claim id.
    """
    from nniquad.proofs.claims import registry

    ids: Sequence[str] | None = None if only is None else [str(i) for i in only]
    if section is not None:
        reg = registry()
        sections = sorted({spec.section for spec in reg.values()})
        if section not in sections:
            raise NniquadError(f"unknown section {section!r} (known: {', '.join(sections)})")
        ids = [i for i in (ids if ids is not None else list(reg)) if reg[i].section == section]
    if ids is not None:
        known = claim_ids()
        bad = [i for i in ids if i not in known]
        if bad:
            raise NniquadError(f"unknown claim id {bad[0]!r} (known: {', '.join(known)})")
        if not ids:
            raise NniquadError("give at least one claim id")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise NniquadError(f"workers must be a positive integer, got {workers!r}")
    return Audit(tuple(run_audit(ids, workers=workers)))
