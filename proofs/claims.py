"""Claim records, verdicts, the registry and the report writers of the paper audit.

Every claim of the paper is one function in one of the section modules
(:mod:`proofs.ni_preliminaries`, :mod:`proofs.quadrotor_model`,
:mod:`proofs.control_design`, :mod:`proofs.simulation`).  A claim function is
decorated with :func:`claim`, which records its id, the LaTeX label(s) of the
paper it checks, the paper section, a statement in our own words and the
method; the function itself returns a :class:`Finding` (verdict, one-line
reason, evidence, counterexample, correction) and the decorator turns it into a
:class:`ClaimResult`.

Claim functions take the object under test as a keyword parameter whose default
is the paper's version (typed from the LaTeX source), so tests can feed a
deliberately wrong variant and check that the verdict changes.

Besides the paper's claims the audit holds a few **extensions** (section
``extensions``, ``kind = "extension"``): statements the project relies on that
the paper does not make (e.g. that the filtered-derivative PD law is the NNI
law).  They are checked the same way and always marked as extensions, never as
claims of the paper (the table, the JSON ``kind`` and the Markdown say so).

Verdicts
--------
``holds``
    the statement holds exactly as printed;
``fails``
    it fails as printed and no small correction was checked;
``holds-with-correction``
    it fails as printed (the counterexample is given) but holds after the
    stated, smallest change (itself checked by the same code).
"""

from __future__ import annotations

import importlib
import json
import math
import sys
import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable, Iterable, Sequence

import numpy as np

__all__ = [
    "HOLDS",
    "FAILS",
    "HOLDS_WITH_CORRECTION",
    "VERDICTS",
    "METHODS",
    "KINDS",
    "EXTENSION_SECTIONS",
    "SECTIONS",
    "Finding",
    "ClaimResult",
    "ClaimSpec",
    "claim",
    "registry",
    "claim_ids",
    "run_audit",
    "jsonable",
    "audit_to_json",
    "audit_to_markdown",
    "audit_table",
]

HOLDS = "holds"
FAILS = "fails"
HOLDS_WITH_CORRECTION = "holds-with-correction"
#: The only admissible verdicts.
VERDICTS: tuple[str, ...] = (HOLDS, FAILS, HOLDS_WITH_CORRECTION)
#: Admissible methods (a claim may combine several, joined by '+').
METHODS: tuple[str, ...] = ("symbolic", "LMI", "numeric", "simulation")

#: Section module -> paper section title, in the paper's order.
SECTIONS: dict[str, str] = {
    "ni_preliminaries": "Preliminaries on negative imaginary systems (Sec. sec:prelim)",
    "quadrotor_model": "Quadrotor system (Sec. sec:quadrotor)",
    "control_design": "Control design and stability analysis (Sec. sec:control)",
    "simulation": "Simulation results (Sec. sec:simulation)",
    "extensions": "Extensions: not claims of the paper (statements the project adds and checks)",
}

#: A record's ``kind``: a claim of the paper, or an extension the project adds (never a claim of the paper).
KINDS: tuple[str, ...] = ("paper", "extension")

#: Sections that hold extensions only (every claim there has ``kind = "extension"``, and no other does).
EXTENSION_SECTIONS: tuple[str, ...] = ("extensions",)


def _check_verdict(verdict: str) -> str:
    if verdict not in VERDICTS:
        raise ValueError(f"verdict must be one of {VERDICTS}, got {verdict!r}")
    return verdict


#: The statement of every extension starts with this (what a reader sees first).
EXTENSION_PREFIX = "EXTENSION (not a claim of the paper): "


def _check_kind(kind: str, section: str) -> str:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    if (kind == "extension") != (section in EXTENSION_SECTIONS):
        raise ValueError(f"section {section!r} holds {'extensions' if section in EXTENSION_SECTIONS else 'claims of the paper'}"
                         f", not kind {kind!r}")
    return kind


def _check_method(method: str) -> str:
    parts = method.split("+")
    bad = [p for p in parts if p not in METHODS]
    if bad:
        raise ValueError(f"method parts must be among {METHODS}, got {method!r}")
    return method


@dataclass
class Finding:
    """What a claim function computed: the part of a :class:`ClaimResult` that is not metadata.

    Attributes
    ----------
    verdict
        One of :data:`VERDICTS`.
    reason
        One line for the summary table.
    evidence
        Residual expressions (as strings) that simplify to zero, inequalities,
        solver statuses, numbers with tolerances.
    counterexample
        Concrete values falsifying the statement as printed (``None`` if it holds).
    correction
        The smallest change that makes it hold, with the check of that change
        (``None`` if none is needed or none was found).
    """

    verdict: str
    reason: str
    evidence: dict[str, Any] = field(default_factory=dict)
    counterexample: dict[str, Any] | None = None
    correction: dict[str, Any] | str | None = None

    def __post_init__(self) -> None:
        _check_verdict(self.verdict)
        if self.verdict == HOLDS_WITH_CORRECTION and self.correction is None:
            raise ValueError("a 'holds-with-correction' finding needs a correction")


@dataclass
class ClaimResult:
    """One audited claim.

    Attributes
    ----------
    id, paper_ref, section, statement, method
        Metadata from :func:`claim` (``paper_ref``: LaTeX labels of the paper; for an
        extension, the labels it builds on).
    verdict, reason, evidence, counterexample, correction
        From the claim's :class:`Finding`.
    seconds
        Wall time of the check.
    kind
        ``"paper"`` (a claim of the paper) or ``"extension"`` (:data:`KINDS`).
    """

    id: str
    paper_ref: list[str]
    section: str
    statement: str
    verdict: str
    reason: str
    evidence: dict[str, Any] | str
    counterexample: dict[str, Any] | None
    correction: dict[str, Any] | str | None
    method: str
    seconds: float = 0.0
    kind: str = "paper"

    def __post_init__(self) -> None:
        _check_verdict(self.verdict)
        _check_method(self.method)
        _check_kind(self.kind, self.section)

    @property
    def extension(self) -> bool:
        """Whether this record is an extension (not a claim of the paper)."""
        return self.kind == "extension"

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dictionary (sympy objects as strings, arrays as lists)."""
        return {
            "id": self.id,
            "kind": self.kind,
            "paper_ref": list(self.paper_ref),
            "section": self.section,
            "verdict": self.verdict,
            "reason": self.reason,
            "statement": self.statement,
            "evidence": jsonable(self.evidence),
            "counterexample": jsonable(self.counterexample),
            "correction": jsonable(self.correction),
            "method": self.method,
            "seconds": round(float(self.seconds), 4),
        }


@dataclass(frozen=True)
class ClaimSpec:
    """Registry entry: metadata and the undecorated claim function."""

    id: str
    paper_ref: tuple[str, ...]
    section: str
    statement: str
    method: str
    func: Callable[..., Finding]
    kind: str = "paper"


_REGISTRY: dict[str, ClaimSpec] = {}

#: Section modules, imported (and thereby registered) by :func:`registry`.
_MODULES = tuple(f"nniquad.proofs.{name}" for name in SECTIONS)


def claim(id: str, paper_ref: Sequence[str] | str, section: str, statement: str, method: str):
    """Register a claim function; the decorated function returns a :class:`ClaimResult`.

    Parameters
    ----------
    id
        Claim id (unique).
    paper_ref
        LaTeX label(s) of the equations / lemmas checked (for an extension: the ones it builds on).
    section
        Section module name (a key of :data:`SECTIONS`); a section of
        :data:`EXTENSION_SECTIONS` makes the record an extension (``kind = "extension"``),
        and its statement must say so.
    statement
        The claim in our own words.
    method
        ``symbolic``, ``LMI``, ``numeric``, ``simulation`` or several joined by ``+``.
    """
    refs = (paper_ref,) if isinstance(paper_ref, str) else tuple(paper_ref)
    if section not in SECTIONS:
        raise ValueError(f"unknown section {section!r}")
    _check_method(method)
    kind = "extension" if section in EXTENSION_SECTIONS else "paper"
    if kind == "extension" and not statement.startswith(EXTENSION_PREFIX):
        raise ValueError(f"an extension's statement must start with {EXTENSION_PREFIX!r}")

    def decorate(func: Callable[..., Finding]) -> Callable[..., ClaimResult]:
        spec = ClaimSpec(id, refs, section, statement, method, func, kind)
        if id in _REGISTRY and _REGISTRY[id].func.__qualname__ != func.__qualname__:
            raise ValueError(f"claim id {id!r} registered twice")

        def wrapper(*args: Any, **kwargs: Any) -> ClaimResult:
            t0 = time.perf_counter()
            finding = func(*args, **kwargs)
            if not isinstance(finding, Finding):
                raise TypeError(f"claim {id!r} must return a Finding, got {type(finding).__name__}")
            return ClaimResult(
                id=id, paper_ref=list(refs), section=section, statement=statement,
                verdict=finding.verdict, reason=finding.reason, evidence=finding.evidence,
                counterexample=finding.counterexample, correction=finding.correction,
                method=method, seconds=time.perf_counter() - t0, kind=kind,
            )

        wrapper.__name__ = func.__name__
        wrapper.__qualname__ = func.__qualname__
        wrapper.__doc__ = func.__doc__
        wrapper.__module__ = func.__module__
        wrapper.spec = spec  # type: ignore[attr-defined]
        _REGISTRY[id] = ClaimSpec(id, refs, section, statement, method, wrapper, kind)
        return wrapper

    return decorate


def registry() -> dict[str, ClaimSpec]:
    """All registered claims, in the paper's section order (imports the section modules)."""
    for mod in _MODULES:
        importlib.import_module(mod)
    order = list(SECTIONS)
    return dict(sorted(_REGISTRY.items(), key=lambda kv: order.index(kv[1].section)))


def claim_ids() -> list[str]:
    """Ids of every registered claim, in report order."""
    return list(registry())


def run_audit(only: Iterable[str] | None = None, *, workers: int = 1) -> list[ClaimResult]:
    """Run the audit (every claim, or the ids in ``only``) with the paper's versions as inputs.

    Parameters
    ----------
    only
        Claim ids (default: all, in report order).
    workers
        Processes to spread the claims over, one paper section per task (the
        sections share nothing but imports and the symbolic model's caches).
        A claim is a pure function of its inputs, so the results are the same
        for any number.  With more than one (on Linux; elsewhere the claims run
        here, one after the other) the workers are forked from this process,
        inheriting its imports, or, when this process runs other threads (which
        a fork does not copy, with any lock they hold), from a fresh fork server.

    Raises
    ------
    KeyError
        For an unknown id in ``only`` (the CLI turns it into a one-line error).
    """
    reg = registry()
    ids = list(reg) if only is None else list(only)
    unknown = [i for i in ids if i not in reg]
    if unknown:
        raise KeyError(unknown[0])
    groups: dict[str, list[str]] = {}
    for i in ids:
        groups.setdefault(reg[i].section, []).append(i)
    if workers <= 1 or len(groups) <= 1 or not sys.platform.startswith("linux"):
        return [reg[i].func() for i in ids]
    import multiprocessing
    import threading
    from concurrent.futures import ProcessPoolExecutor

    if threading.active_count() == 1:
        ctx = multiprocessing.get_context("fork")
    else:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(_MODULES))
    with ProcessPoolExecutor(min(int(workers), len(groups)), mp_context=ctx) as pool:
        done = {r.id: r for part in pool.map(_run_claims, groups.values()) for r in part}
    return [done[i] for i in ids]


def _run_claims(ids: Sequence[str]) -> list[ClaimResult]:
    """Run the claims ``ids`` in this (worker) process."""
    reg = registry()
    return [reg[i].func() for i in ids]


# --------------------------------------------------------------------------- serialisation


def jsonable(obj: Any) -> Any:
    """Convert evidence to JSON-ready data: sympy -> str, numpy -> lists/floats, non-finite -> str."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else str(v)
    if isinstance(obj, (complex, np.complexfloating)):
        return {"re": jsonable(obj.real), "im": jsonable(obj.imag)}
    if isinstance(obj, Fraction):
        return str(obj)
    if isinstance(obj, np.ndarray):
        return [jsonable(x) for x in obj.tolist()] if obj.ndim else jsonable(obj.item())
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [jsonable(x) for x in obj]
    try:
        import sympy as sp

        if isinstance(obj, sp.Basic) or isinstance(obj, sp.MatrixBase):
            return str(obj)
    except ImportError:  # pragma: no cover
        pass
    return str(obj)


def audit_to_json(results: Sequence[ClaimResult]) -> dict[str, Any]:
    """``{"claims": [...], "summary": {...}}`` for the given results."""
    counts = {v: sum(r.verdict == v for r in results) for v in VERDICTS}
    data = {
        "claims": [r.to_json() for r in results],
        "summary": {"n_claims": len(results), "verdicts": counts,
                    "n_extensions": sum(r.kind == "extension" for r in results),
                    "seconds": round(sum(r.seconds for r in results), 3)},
    }
    json.dumps(data, allow_nan=False)  # fail here, not in the writer, if something is not JSON
    return data


def audit_table(results: Sequence[ClaimResult], width: int = 100) -> str:
    """Plain-text table ``id | verdict | reason`` for the terminal."""
    idw = max([len("id")] + [len(r.id) for r in results])
    vw = max(len(v) for v in VERDICTS)
    lines = [f"{'id':<{idw}}  {'verdict':<{vw}}  reason", f"{'-' * idw}  {'-' * vw}  {'-' * 6}"]
    for r in results:
        reason = ("[EXTENSION] " if r.extension else "") + r.reason
        reason = reason if len(reason) <= width else reason[: width - 3] + "..."
        lines.append(f"{r.id:<{idw}}  {r.verdict:<{vw}}  {reason}")
    counts = ", ".join(f"{sum(r.verdict == v for r in results)} {v}" for v in VERDICTS)
    n_ext = sum(r.extension for r in results)
    lines.append(f"{len(results)} claims: {counts}"
                 + (f" ({n_ext} of them extensions, not claims of the paper)" if n_ext else ""))
    return "\n".join(lines)


def _md_value(value: Any, indent: str = "") -> list[str]:
    """Markdown bullet lines for an evidence value (nested dicts become nested bullets)."""
    value = jsonable(value)
    if isinstance(value, dict):
        out = []
        for k, v in value.items():
            if isinstance(v, (dict, list)) and v and not _is_flat_list(v):
                out.append(f"{indent}- **{k}**:")
                out.extend(_md_value(v, indent + "  "))
            else:
                out.append(f"{indent}- **{k}**: {_md_inline(v)}")
        return out
    if isinstance(value, list) and not _is_flat_list(value):
        out = []
        for v in value:
            if isinstance(v, dict):
                sub = _md_value(v, indent + "  ")
                if sub:
                    sub[0] = indent + "- " + sub[0].lstrip()[2:]
                out.extend(sub)
            else:
                out.append(f"{indent}- {_md_inline(v)}")
        return out
    return [f"{indent}- {_md_inline(value)}"]


def _is_flat_list(v: Any) -> bool:
    return isinstance(v, list) and all(not isinstance(x, (dict, list)) for x in v) or (
        isinstance(v, list) and all(isinstance(x, list) and all(not isinstance(y, (dict, list)) for y in x) for x in v)
    )


def _md_inline(v: Any) -> str:
    if isinstance(v, str):
        return f"`{v}`" if len(v) < 400 and ("*" in v or "_" in v or "^" in v or "(" in v) else v
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list):
        return "`" + json.dumps(v) + "`"
    return str(v)


def audit_to_markdown(results: Sequence[ClaimResult], title: str = "Audit of the paper's claims") -> str:
    """A Markdown report a reader can follow without running code."""
    lines = [f"# {title}", ""]
    lines.append(
        "Source: A. G. Ghallab and I. R. Petersen, *Velocity-Free Horizontal Position Control of "
        "Quadrotor Aircraft via Nonlinear Negative Imaginary Systems Theory*. Each claim is checked "
        "**literally as printed** first; where it fails, the smallest correction is stated and checked "
        "by the same code. Verdicts: `holds` (as printed), `fails`, `holds-with-correction`. "
        "Symbolic checks hold for all positive parameters unless the evidence says *numeric*. "
        "The last section holds **extensions**: statements the project adds and checks, marked as such; they "
        "are not claims of the paper."
    )
    lines.append("")
    counts = ", ".join(f"{sum(r.verdict == v for r in results)} `{v}`" for v in VERDICTS)
    lines.append(f"**{len(results)} claims**: {counts}. Total check time {sum(r.seconds for r in results):.1f} s.")
    lines.append("")
    lines.append("| id | paper ref | verdict | reason |")
    lines.append("|---|---|---|---|")
    for r in results:
        reason = ("**EXTENSION, not a claim of the paper.** " if r.extension else "") + r.reason.replace("|", "\\|")
        lines.append(f"| [`{r.id}`](#{r.id}) | {', '.join(r.paper_ref)} | **{r.verdict}** | {reason} |")
    lines.append("")
    for sec, title_ in SECTIONS.items():
        sec_results = [r for r in results if r.section == sec]
        if not sec_results:
            continue
        lines += [f"## {title_}", ""]
        for r in sec_results:
            lines += [f"### {r.id}", ""]
            if r.extension:
                lines.append("- **Kind**: EXTENSION: not a claim of the paper; the paper's labels below are what it "
                             "builds on")
            lines.append(f"- **Paper reference**: {', '.join('`' + p + '`' for p in r.paper_ref)}")
            lines.append(f"- **Statement**: {r.statement}")
            lines.append(f"- **Verdict**: **{r.verdict}** — {r.reason}")
            lines.append(f"- **Method**: {r.method} ({r.seconds:.2f} s)")
            lines.append("")
            lines.append("**Evidence**")
            lines.append("")
            lines += _md_value(r.evidence) if isinstance(r.evidence, dict) else [r.evidence]
            lines.append("")
            if r.counterexample is not None:
                lines.append("**Counterexample**")
                lines.append("")
                lines += _md_value(r.counterexample)
                lines.append("")
            if r.correction is not None:
                lines.append("**Correction**")
                lines.append("")
                lines += _md_value(r.correction) if isinstance(r.correction, dict) else [r.correction]
                lines.append("")
    return "\n".join(lines).rstrip() + "\n"
