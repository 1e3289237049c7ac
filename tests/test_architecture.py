"""The package's shape, read from its source: layers that import one way, no import cycle, a law is one unit.

* ``lint-imports`` (import-linter, the contracts in ``pyproject.toml``) passes: the ``layers`` contract
  covers every sub-package and module of ``nniquad`` (``exhaustive``), the ``acyclic_siblings`` contract
  every package.
* An independent check of the same rule at the finest grain: the graph of every import between the
  package's modules (those inside functions and under ``if TYPE_CHECKING`` too) has no cycle (Tarjan).
* Outside ``nniquad.laws`` no code compares a value with a registered law's name or tests an
  ``isinstance`` against a law's gains type: the tuner, simulator, certificate, export and CLI ask the law.
* No private name (``_x``) is imported from another module.
* Every import of the package inside a function states its cold-start reason in a comment.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "design" / "nniquad"


def _modules() -> dict[str, Path]:
    out = {}
    for dirpath, _, files in os.walk(PACKAGE):  # the proofs link is not followed: proofs/ is its own folder
        for f in files:
            if f.endswith(".py"):
                path = Path(dirpath) / f
                rel = path.relative_to(PACKAGE).with_suffix("").as_posix().replace("/", ".")
                name = "nniquad" if rel == "__init__" else "nniquad." + rel.removesuffix(".__init__")
                out[name] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> list[tuple[str, ast.AST, list[str]]]:
    """``(imported module, node, imported names)`` of every import in a module, resolved to absolute names."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, node, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            out.append((module, node, [a.name for a in node.names]))
    return out


def _resolve(target: str) -> str | None:
    while target and target not in MODULES:
        target = target.rsplit(".", 1)[0] if "." in target else ""
    return target or None


def test_the_import_contracts_hold():
    lint = Path(sys.executable).with_name("lint-imports")
    proc = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "Contracts: 2 kept, 0 broken." in proc.stdout, proc.stdout[-2000:]


def test_the_layers_contract_names_every_sub_package_and_module():
    """``exhaustive = true`` makes import-linter refuse a child of ``nniquad`` missing from the layers; here the
    same, independently: every child module or package appears in exactly one layer."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["importlinter"]
    (layers,) = [c for c in config["contracts"] if c["type"] == "layers"]
    assert layers["containers"] == ["nniquad"] and layers["exhaustive"] is True
    named = [n.strip() for layer in layers["layers"] for n in re.split(r"[|:]", layer)]
    children = sorted({m.split(".")[1] for m in MODULES if m.count(".") >= 1} | {"proofs"})
    assert sorted(named) == children


def test_no_import_cycle_between_modules():
    graph = {name: set() for name in MODULES}
    for name, path in MODULES.items():
        if path.name == "__init__.py":
            continue  # a package's re-exports: importing the package runs them, but they are not a dependency
        for module, _, names in _imports(name, path):
            for target in [module] + [f"{module}.{n}" for n in names]:
                t = _resolve(target)
                if t is not None and t != name and t in graph:
                    graph[name].add(t)
    index, low, stack, on, cycles = {}, {}, [], set(), []
    counter = [0]
    sys.setrecursionlimit(10_000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    assert cycles == []


def _law_facts() -> tuple[set[str], set[str]]:
    from nniquad.laws.registry import LAWS

    names = set(LAWS)
    types = {law.gains_type.__name__ for law in LAWS.values()} | {"Gains", "NNIGains"}
    return names, types


def test_no_code_outside_laws_branches_on_a_law():
    names, types = _law_facts()
    found = []
    for name, path in MODULES.items():
        if name.startswith("nniquad.laws"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare):
                consts = [c.value for c in [node.left, *node.comparators] if isinstance(c, ast.Constant)]
                consts += [e.value for c in node.comparators if isinstance(c, (ast.Tuple, ast.List, ast.Set))
                           for e in c.elts if isinstance(e, ast.Constant)]
                if any(isinstance(c, str) and c in names for c in consts):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: compares with a law's name")
            elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance" and len(node.args) == 2:
                kinds = node.args[1].elts if isinstance(node.args[1], ast.Tuple) else [node.args[1]]
                if any(getattr(k, "id", getattr(k, "attr", None)) in types for k in kinds):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: isinstance against a law's gains type")
    assert found == []


def test_no_private_name_is_imported_from_another_module():
    found = []
    for name, path in MODULES.items():
        for module, node, names in _imports(name, path):
            if module.startswith("nniquad") and module != name:
                found += [f"{name} <- {module}.{n}" for n in names if n.startswith("_") and not n.startswith("__")]
    assert found == []


def test_every_import_inside_a_function_states_its_cold_start_reason():
    """A lazy import of the package is allowed for a stated reason (the cold start of ``--help``, ``verify``, ...):
    a comment on its line or the line before it."""
    reason = re.compile(r"lazily|cold start|cold command|--help", re.I)
    found = []
    for name, path in MODULES.items():
        lines = path.read_text(encoding="utf-8").split("\n")
        tree = ast.parse("\n".join(lines))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            stated = False  # one stated reason covers the function's later lazy imports
            imports = sorted((n for n in ast.walk(fn) if isinstance(n, (ast.Import, ast.ImportFrom))),
                             key=lambda n: n.lineno)
            for node in imports:
                module = node.module if isinstance(node, ast.ImportFrom) else node.names[0].name
                if not (module or "").startswith("nniquad"):
                    continue
                here = lines[node.lineno - 1] + (lines[node.lineno - 2] if node.lineno > 1 else "")
                stated = stated or bool(reason.search(here))
                if not stated:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert found == []


@pytest.mark.parametrize("law_name", ["nni", "sni2", "pd_filtered", "pd_velocity"])
def test_each_law_is_one_module_of_the_laws_package(law_name):
    from nniquad.laws.registry import LAWS

    law = LAWS[law_name]
    module = sys.modules[type(law).__module__]
    assert module.__name__ == f"nniquad.laws.{law_name}"
    assert sys.modules[law.gains_type.__module__] is module
