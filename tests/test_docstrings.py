"""Every parameter of the public API is documented (numpydoc), in the manner of python-control's docstring test.

For each function and class that ``nniquad.__all__`` exports, and each public
method of those classes, every parameter of the signature must appear in the
docstring's ``Parameters`` section (classes: ``Parameters`` or ``Attributes``).
A new parameter without documentation fails this test.
"""

from __future__ import annotations

import dataclasses
import inspect
import re

import pytest

import nniquad

_SECTION = re.compile(r"^(\s*)(Parameters|Attributes|Other Parameters)\s*\n\s*-{3,}\s*$", re.M)
_HEADER = re.compile(r"^\s*[A-Z][A-Za-z ]+\s*\n\s*-{3,}\s*$", re.M)


def documented_names(doc: str) -> set[str]:
    """Parameter names listed in the numpydoc parameter-like sections of ``doc``."""
    doc = inspect.cleandoc(doc or "")
    names: set[str] = set()
    for m in _SECTION.finditer(doc):
        body = doc[m.end():]
        nxt = _HEADER.search(body)
        body = body[: nxt.start()] if nxt else body
        for line in body.splitlines():
            if not line.strip() or line.startswith((" ", "\t")):
                continue  # descriptions are indented
            head = line.split(" : ")[0]
            for name in head.split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _params(obj) -> list[str]:
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return []
    return [p.name for p in sig.parameters.values()
            if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]


def _targets():
    for name in nniquad.__all__:
        obj = getattr(nniquad, name)
        if inspect.isfunction(obj):
            yield name, obj, obj
        elif inspect.isclass(obj):
            yield name, obj, obj  # constructor parameters
            for attr, member in vars(obj).items():
                if attr.startswith("_") or not inspect.isfunction(member):
                    continue
                yield f"{name}.{attr}", member, member


TARGETS = list(_targets())


def test_parser_reads_numpydoc():
    doc = """Summary.

    Parameters
    ----------
    a, b : float
        Two numbers.
    c
        Another.

    Returns
    -------
    d : float
        Not a parameter.
    """
    assert documented_names(doc) == {"a", "b", "c"}
    assert documented_names("No sections.") == set()


@pytest.mark.parametrize("label,obj,doc_owner", TARGETS, ids=[t[0] for t in TARGETS])
def test_every_parameter_is_documented(label, obj, doc_owner):
    params = _params(obj)
    if dataclasses.is_dataclass(obj) and inspect.isclass(obj):
        params = [f.name for f in dataclasses.fields(obj) if f.init and not f.name.startswith("_")]
    if not params:
        return
    doc = inspect.getdoc(doc_owner) or ""
    missing = [p for p in params if p not in documented_names(doc)]
    assert not missing, f"{label}: parameter(s) {missing} not documented in its numpydoc docstring"
