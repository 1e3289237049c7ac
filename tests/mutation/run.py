"""Mutation testing of the modules that decide a verdict (``make mutation``).

Runs mutmut 3 on each module listed in ``tests/mutation/modules.toml`` with only
the tests that module lists, then prints the score per module

    killed / (mutants - equivalent)

where the equivalent mutants are those of ``tests/mutation/equivalent.toml``
(each with a one-line argument).  Exit status: 0 every module reaches its
target (90 % unless the module says otherwise), 1 a module is below it, 2 a
bad option or a stale configuration (a function pattern or an equivalence entry
that matches no mutant), 3 mutmut itself failed.

Why a staging folder.  The package folder is ``design/nniquad`` and mutmut names a
mutant after its file path relative to where it runs, so the run happens in
``build/mutation/<module>/``, which holds a copy of ``design/nniquad`` as
``nniquad`` (path and import name agree; the link ``nniquad/proofs`` is copied
as the folder it points at).  The copy exists for the two rewrites below, not to
rename anything.  mutmut puts its ``mutants/`` folder first on ``sys.path``; the
editable install's finder comes after the path finder on ``sys.meta_path``, so
``import nniquad`` loads the mutated copy.  mutmut's own forced-fail run (every
trampoline raises) stops the run if it does not.

Two rewrites of the staged copy keep mutmut from missing code:

* mutmut skips decorated functions, so a function whose decorators are all in
  :data:`LOWERABLE` (``property``, ``cache``, ``lru_cache(...)``,
  ``cached_property``) is rewritten as the same definition followed by
  ``name = decorator(name)``, which Python evaluates identically;
* mutmut forks each mutant from a process that ran the tests once, so a cache
  filled there would hide the mutant; the modules a module lists under
  ``clear_caches`` have their ``functools`` caches emptied before every test
  (by a ``conftest.py`` written into the staging folder).

And one widening of mutmut's test selection: mutmut runs, for a mutant, only the
tests that called its function while it recorded coverage; a module- or
session-scoped fixture calls it once, in the first test that asks for it, so the
later tests reading the fixture would never run against the mutant.  The same
``conftest.py`` therefore gives each function every test of each test file that
reached it (``widen = false`` in modules.toml turns this off for a module).
"""

from __future__ import annotations

import argparse
import ast
import fnmatch
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
STAGE_ROOT = ROOT / "build" / "mutation"
#: The tests' expensive shared documents (certificates), built by the first, unmutated run and read by the
#: sessions of every mutant (``shared_json`` in tests/conftest.py).  Emptied at the start of every ``make mutation``.
SHARED = STAGE_ROOT / "shared"
#: Decorators rewritten as ``name = decorator(name)`` after the definition.
LOWERABLE = {"property", "cache", "lru_cache", "cached_property"}
#: mutmut exit codes (mutmut.stats.status_by_exit_code) counted as a detected mutant.
DETECTED = {"killed", "timeout", "segfault"}
SEP = "\u01c1"  # mutmut's class separator in mangled names


# --------------------------------------------------------------------------- configuration


@dataclass
class Module:
    """One mutation target: a file, the functions scored, the tests that run."""

    name: str
    file: str
    functions: list[str]
    tests: list[str]
    clear_caches: list[str] = field(default_factory=list)
    target: float = 0.90
    widen: bool = True

    @property
    def import_name(self) -> str:
        rel = Path(self.file).with_suffix("")
        parts = rel.parts
        if parts[:2] == ("design", "nniquad"):
            return ".".join(parts[1:])
        if parts[0] == "proofs":
            return ".".join(("nniquad", "proofs") + parts[1:])
        raise SystemExit(f"mutation: error: {self.file} is not under design/nniquad/ or proofs/")

    @property
    def staged_file(self) -> str:
        return self.import_name.replace(".", "/") + ".py"


@dataclass
class Equivalent:
    module: str
    function: str
    before: str
    after: str
    reason: str
    used: int = 0


def load_modules(path: Path) -> dict[str, Module]:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    out = {}
    for name, spec in data.get("modules", {}).items():
        out[name] = Module(name=name, file=spec["file"], functions=list(spec["functions"]),
                           tests=list(spec["tests"]), clear_caches=list(spec.get("clear_caches", [])),
                           target=float(spec.get("target", 0.90)), widen=bool(spec.get("widen", True)))
    return out


def load_equivalents(path: Path) -> list[Equivalent]:
    if not path.exists():
        return []
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    out = []
    for e in data.get("equivalent", []):
        missing = {"module", "function", "from", "to", "reason"} - set(e)
        if missing:
            raise SystemExit(f"mutation: error: {path.name}: an entry lacks {sorted(missing)}: {e}")
        if not str(e["reason"]).strip():
            raise SystemExit(f"mutation: error: {path.name}: an entry has no reason: {e}")
        out.append(Equivalent(e["module"], e["function"], _norm(e["from"]), _norm(e["to"]), e["reason"]))
    return out


def _norm(code: str) -> str:
    return "\n".join(line.strip() for line in code.strip().splitlines())


# --------------------------------------------------------------------------- staging


def lower_decorators(source: str) -> str:
    """Rewrite ``@dec def f`` as ``def f ...; f = dec(f)`` where every decorator is lowerable.

    Only functions at module level or directly in a class body are rewritten
    (mutmut mutates nested functions as part of the enclosing one).
    """
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    edits: list[tuple[int, int, int, str]] = []  # (first decorator line, def line, end line, assignment)

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, ast.ClassDef):
                visit(node.body)
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.decorator_list:
                if all(_lowerable(d) for d in node.decorator_list):
                    expr = node.name
                    for d in reversed(node.decorator_list):
                        expr = f"{ast.get_source_segment(source, d)}({expr})"
                    indent = " " * node.col_offset
                    first = min(d.lineno for d in node.decorator_list)
                    edits.append((first, node.lineno, node.end_lineno, f"{indent}{node.name} = {expr}\n"))

    visit(tree.body)
    for first, def_line, end, assignment in sorted(edits, reverse=True):
        lines.insert(end, assignment)
        del lines[first - 1:def_line - 1]
    out = "".join(lines)
    ast.parse(out)
    return out


def _lowerable(d: ast.expr) -> bool:
    f = d.func if isinstance(d, ast.Call) else d
    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "functools":
        return f.attr in LOWERABLE
    return isinstance(f, ast.Name) and f.id in LOWERABLE


CONFTEST = '''\
"""Written by tests/mutation/run.py: empty the caches of the mutated modules before each test, and
give each mutated function every test of the files whose tests reach it (see run.py)."""
import os
import sys

import pytest

_MODULES = {modules!r}
_WIDEN = {widen!r}


def pytest_sessionfinish(session, exitstatus):
    if not _WIDEN or os.environ.get("MUTANT_UNDER_TEST") != "stats":
        return
    from mutmut.state import state

    st = state()
    by_file = {{}}
    for test in st.duration_by_test:
        by_file.setdefault(test.split("::")[0], set()).add(test)
    for tests in st.tests_by_mangled_function_name.values():
        for f in {{t.split("::")[0] for t in tests}}:
            tests |= by_file.get(f, set())


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    for name in _MODULES:
        module = sys.modules.get(name)
        if module is None:
            continue
        for obj in list(vars(module).values()):
            clear = getattr(obj, "cache_clear", None)
            if callable(clear):
                clear()
        for own in ("clear_cache", "clear_memory"):  # a module's own cache: check.memo, codecache's loaded code
            clear = vars(module).get(own)
            if callable(clear):
                clear()
'''


def _toml_list(items: list[str]) -> str:
    return "[" + ", ".join(json.dumps(i) for i in items) + "]"


def stage(module: Module) -> Path:
    """A fresh staging folder holding a copy of the package folder ``design/nniquad`` (proofs included)."""
    d = STAGE_ROOT / module.name
    if d.exists():
        shutil.rmtree(d)
    d.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "design" / "nniquad", d / "nniquad", ignore=ignore)  # follows the proofs link
    shutil.copytree(ROOT / "tests", d / "tests", ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "mutation"))
    shutil.copytree(ROOT / "notebooks" / "data", d / "notebooks" / "data", ignore=ignore)
    shutil.copy2(ROOT / "README.md", d / "README.md")
    target = d / module.staged_file
    if not target.exists():
        raise SystemExit(f"mutation: error: {module.file} does not exist")
    target.write_text(lower_decorators(target.read_text(encoding="utf-8")), encoding="utf-8")
    (d / "conftest.py").write_text(CONFTEST.format(modules=[module.import_name] + module.clear_caches,
                                                   widen=module.widen))

    real = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    markers = real.get("tool", {}).get("pytest", {}).get("ini_options", {}).get("markers", [])
    (d / "pyproject.toml").write_text(
        "[tool.pytest.ini_options]\n"
        f"markers = {_toml_list(markers)}\n\n"
        "[tool.mutmut]\n"
        'source_paths = ["nniquad"]\n'
        f"only_mutate = {_toml_list([module.staged_file])}\n"
        f"pytest_add_cli_args_test_selection = {_toml_list(module.tests)}\n"
        'pytest_add_cli_args = ["-p", "no:cacheprovider", "-p", "no:xdist"]\n'
        f"also_copy = {_toml_list(['conftest.py', 'notebooks', 'README.md'])}\n"
        "use_git_change_detection = false\n",
        encoding="utf-8",
    )
    return d


# --------------------------------------------------------------------------- mutant names


def qualname(key: str) -> str:
    """``pkg.mod.x_f__mutmut_3`` -> ``f``; ``pkg.mod.xǁClsǁm__mutmut_3`` -> ``Cls.m``."""
    mangled = key.rpartition(".")[2].partition("__mutmut_")[0]
    if mangled.startswith("x" + SEP):
        cls, _, meth = mangled[2:].partition(SEP)
        return f"{cls}.{meth}"
    return mangled[2:]


def mutant_globs(module: Module) -> list[str]:
    """mutmut name globs of the selected functions."""
    out = []
    for pat in module.functions:
        if any(c in pat for c in "*?["):
            return [f"{module.import_name}.*"]  # a wildcard: run the whole file, score the matches
        if "." in pat:
            cls, _, meth = pat.partition(".")
            out.append(f"{module.import_name}.x{SEP}{cls}{SEP}{meth}__mutmut_*")
        else:
            out.append(f"{module.import_name}.x_{pat}__mutmut_*")
    return out


def selected(module: Module, key: str) -> bool:
    return any(fnmatch.fnmatchcase(qualname(key), pat) for pat in module.functions)


# --------------------------------------------------------------------------- run and score


@dataclass
class Score:
    module: Module
    total: int
    killed: int
    equivalent: int
    survivors: list[tuple[str, str, str]]  # (key, status, diff)

    @property
    def denominator(self) -> int:
        return self.total - self.equivalent

    @property
    def fraction(self) -> float:
        return self.killed / self.denominator if self.denominator else 1.0

    @property
    def ok(self) -> bool:
        return self.fraction >= self.module.target


def _diff_lines(diff: str) -> tuple[str, str]:
    before = [ln[1:] for ln in diff.splitlines() if ln.startswith("-") and not ln.startswith("---")]
    after = [ln[1:] for ln in diff.splitlines() if ln.startswith("+") and not ln.startswith("+++")]
    return _norm("\n".join(before)), _norm("\n".join(after))


def _mutant_env() -> dict[str, str]:
    """The environment of mutmut and its test runs.

    The on-disk code cache (:mod:`nniquad.codecache`) is switched off: it is keyed by a hash of the generating
    module's source, which a mutant does not change (mutmut switches mutants at run time), so a warm cache would
    hand every mutant of a code generator (``reduced_loop_symbolic.lambdified``) the unmutated code.
    """
    return dict(os.environ, MPLBACKEND="Agg", PYTHONHASHSEED="0", NNIQUAD_TEST_SHARED_DIR=str(SHARED),
                NNIQUAD_NO_CODE_CACHE="1")


def run_module(module: Module, jobs: int, equivalents: list[Equivalent], log) -> Score:
    d = stage(module)
    mutmut = Path(sys.executable).with_name("mutmut")
    env = _mutant_env()
    cmd = [str(mutmut), "run", "--max-children", str(jobs), *mutant_globs(module)]
    print(f"== {module.name}: {module.file} ({', '.join(module.functions)}); tests: {' '.join(module.tests)}",
          flush=True)
    return _run_and_score(module, d, cmd, env, equivalents, log)


def rerun_survivors(module: Module, jobs: int, equivalents: list[Equivalent], log) -> Score:
    """Run again only the mutants that survived the last full run of ``module``, against the current tests.

    The loop of killing survivors: edit the tests, then re-run the survivors in minutes instead of every
    mutant.  Refused (exit 2) when the module's source changed since that run (the mutants are of the old
    source: run it in full).  The certificates the tests share are those the last full run built.
    """
    d = STAGE_ROOT / module.name
    meta_path = d / "mutants" / (module.staged_file + ".meta")
    staged = d / module.staged_file
    if not meta_path.exists() or not staged.exists():
        print(f"mutation: error: no earlier run of {module.name} to resume (run it without --survivors)",
              file=sys.stderr)
        raise SystemExit(2)
    if staged.read_text(encoding="utf-8") != lower_decorators((ROOT / module.file).read_text(encoding="utf-8")):
        print(f"mutation: error: {module.file} changed since its last full run (run it without --survivors)",
              file=sys.stderr)
        raise SystemExit(2)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "mutation")
    for dst in (d / "tests", d / "mutants" / "tests"):
        shutil.copytree(ROOT / "tests", dst, ignore=ignore, dirs_exist_ok=True)
    from mutmut.stats import status_by_exit_code

    codes = json.loads(meta_path.read_text())["exit_code_by_key"]
    again = sorted(k for k in codes if selected(module, k) and status_by_exit_code[codes[k]] not in DETECTED)
    print(f"== {module.name}: {len(again)} survivors of the last run, against the current tests", flush=True)
    if not again:
        return _run_and_score(module, d, None, {}, equivalents, log)
    mutmut = Path(sys.executable).with_name("mutmut")
    env = _mutant_env()
    return _run_and_score(module, d, [str(mutmut), "run", "--max-children", str(jobs), *again], env, equivalents, log)


def _run_and_score(module: Module, d: Path, cmd: list[str] | None, env: dict, equivalents: list[Equivalent],
                   log) -> Score:
    t0 = time.monotonic()
    proc = subprocess.CompletedProcess([], 0)
    if cmd is not None:
        with open(d / "mutmut.log", "w") as out:
            proc = subprocess.run(cmd, cwd=d, env=env, stdout=out, stderr=subprocess.STDOUT)
    elapsed = time.monotonic() - t0
    meta_path = d / "mutants" / (module.staged_file + ".meta")
    if proc.returncode != 0 or not meta_path.exists():
        tail = (d / "mutmut.log").read_text(errors="replace")[-3000:]
        print(tail, file=sys.stderr)
        print(f"mutation: error: mutmut failed on {module.name} (exit {proc.returncode}); log: {d / 'mutmut.log'}",
              file=sys.stderr)
        raise SystemExit(3)
    codes = json.loads(meta_path.read_text())["exit_code_by_key"]

    from mutmut.stats import status_by_exit_code  # the tool's own reading of its exit codes

    keys = sorted(k for k in codes if selected(module, k))
    stale = [p for p in module.functions if not any(fnmatch.fnmatchcase(qualname(k), p) for k in codes)]
    if stale:
        print(f"mutation: error: {module.name}: no mutant in {stale} (renamed or removed?)", file=sys.stderr)
        raise SystemExit(2)
    killed = equivalent = 0
    survivors = []
    cwd = os.getcwd()
    os.chdir(d)
    try:
        from mutmut.mutation.diff_apply import get_diff_for_mutant

        for key in keys:
            status = status_by_exit_code[codes[key]]
            if status == "not checked":
                print(f"mutation: error: {key} was not run", file=sys.stderr)
                raise SystemExit(3)
            if status in DETECTED:
                killed += 1
                continue
            diff = get_diff_for_mutant(key, path=module.staged_file)
            before, after = _diff_lines(diff)
            match = [e for e in equivalents if e.module == module.name and e.function == qualname(key)
                     and e.before == before and e.after == after]
            if match:
                for e in match:
                    e.used += 1
                equivalent += 1
            else:
                survivors.append((key, status, diff))
    finally:
        os.chdir(cwd)
    score = Score(module, len(keys), killed, equivalent, survivors)
    log.write(json.dumps({"module": module.name, "total": score.total, "killed": killed, "equivalent": equivalent,
                          "survived": [k for k, _, _ in survivors], "seconds": round(elapsed, 1)}) + "\n")
    print(f"   {module.name}: {killed}/{score.denominator} killed ({100 * score.fraction:.1f} %), "
          f"{equivalent} equivalent excluded, {len(survivors)} survived, {elapsed:.0f} s", flush=True)
    return score


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="mutation", description="Mutation score of the verdict modules (mutmut; see tests/mutation/).")
    parser.add_argument("--module", action="append", default=[],
                        help="run only this module of modules.toml (repeatable; default: all)")
    parser.add_argument("--jobs", type=int, default=2, help="mutants tested at once (default 2)")
    parser.add_argument("--list", action="store_true", help="list the modules and exit")
    parser.add_argument("--show", action="store_true", help="print the diff of every surviving mutant")
    parser.add_argument("--survivors", action="store_true",
                        help="run again only the survivors of each module's last full run, against the current "
                             "tests (refused if the module's source changed since)")
    args = parser.parse_args(argv)
    modules = load_modules(HERE / "modules.toml")
    if args.list:
        for m in modules.values():
            print(f"{m.name:16s} {m.file}  ({', '.join(m.functions)})")
        return 0
    unknown = [m for m in args.module if m not in modules]
    if unknown or args.jobs < 1:
        print(f"mutation: error: unknown module {unknown} (known: {', '.join(modules)})" if unknown
              else "mutation: error: --jobs must be >= 1", file=sys.stderr)
        return 2
    chosen = [modules[m] for m in (args.module or modules)]
    equivalents = load_equivalents(HERE / "equivalent.toml")
    bad = [e for e in equivalents if e.module not in modules]
    if bad:
        print(f"mutation: error: equivalent.toml names unknown modules {[e.module for e in bad]}", file=sys.stderr)
        return 2
    STAGE_ROOT.mkdir(parents=True, exist_ok=True)
    if not args.survivors:
        shutil.rmtree(SHARED, ignore_errors=True)  # built again from this checkout's code, never an earlier one's
    scores = []
    with open(STAGE_ROOT / "scores.jsonl", "a" if args.survivors else "w") as log:
        for m in chosen:
            scores.append((rerun_survivors if args.survivors else run_module)(m, args.jobs, equivalents, log))
    print("\nmutation score (killed / (mutants - equivalent)):")
    for s in scores:
        flag = "ok" if s.ok else f"BELOW {100 * s.module.target:.0f} %"
        print(f"  {s.module.name:16s} {s.killed:4d}/{s.denominator:<4d} {100 * s.fraction:5.1f} %  "
              f"({s.equivalent} equivalent)  {flag}")
        if args.show or not s.ok:
            for key, status, diff in s.survivors:
                print(f"\n  {status}: {key}\n" + "\n".join("    " + ln for ln in diff.splitlines()[2:]))
    stale = [e for e in equivalents if e.used == 0 and e.module in {m.name for m in chosen}]
    if stale:
        for e in stale:
            print(f"mutation: error: equivalent.toml entry matches no surviving mutant: "
                  f"{e.module} {e.function}: {e.before!r} -> {e.after!r}", file=sys.stderr)
        return 2
    return 0 if all(s.ok for s in scores) else 1


if __name__ == "__main__":
    sys.exit(main())
