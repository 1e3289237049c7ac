"""The paper audit: one module per paper section, each claim a function returning a record.

Entry points (used by ``nniquad prove`` and ``nniquad report``)::

    from nniquad.proofs import run_audit, audit_to_json, audit_to_markdown
    results = run_audit()            # list[ClaimResult], every claim with the paper's versions
    data = audit_to_json(results)    # {"claims": [...], "summary": {...}}
    text = audit_to_markdown(results)
"""

from .claims import (  # noqa: F401
    FAILS,
    HOLDS,
    HOLDS_WITH_CORRECTION,
    VERDICTS,
    ClaimResult,
    Finding,
    audit_table,
    audit_to_json,
    audit_to_markdown,
    claim_ids,
    registry,
    run_audit,
)

__all__ = [
    "HOLDS", "FAILS", "HOLDS_WITH_CORRECTION", "VERDICTS", "ClaimResult", "Finding",
    "run_audit", "audit_to_json", "audit_to_markdown", "audit_table", "claim_ids", "registry",
]
