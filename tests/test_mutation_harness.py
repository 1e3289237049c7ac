"""The mutation harness (``make mutation``, tests/mutation/run.py) can see every mutant it scores.

A mutant that the harness cannot switch on survives without saying so, which lowers a score for no reason, or
hides a missing test behind a cache.  These tests check the three ways that happened or could happen: a stale
module or equivalence entry, the on-disk code cache, and a module's own in-memory cache.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("mutation_run", ROOT / "tests" / "mutation" / "run.py")
run = importlib.util.module_from_spec(_spec)
sys.modules["mutation_run"] = run  # dataclasses look their module up while the class is built
_spec.loader.exec_module(run)

MODULES = run.load_modules(ROOT / "tests" / "mutation" / "modules.toml")


@pytest.mark.parametrize("name", sorted(MODULES))
def test_each_module_names_files_and_caches_that_exist(name):
    m = MODULES[name]
    assert (ROOT / m.file).is_file(), m.file
    files = [t.split("::")[0] for t in m.tests if t.startswith("tests/")]  # the rest are pytest options
    assert files
    for test in files:
        assert (ROOT / test).is_file(), test
    for cache_owner in m.clear_caches:
        importlib.import_module(cache_owner)  # a misspelt module would silently clear nothing


def test_every_equivalence_entry_names_a_configured_module():
    entries = run.load_equivalents(ROOT / "tests" / "mutation" / "equivalent.toml")
    assert entries and {e.module for e in entries} <= set(MODULES)
    assert all(e.before != e.after and e.reason.strip() for e in entries)


def test_mutants_run_without_the_on_disk_code_cache(monkeypatch):
    """The cache is keyed by the source, which a mutant switched on at run time does not change."""
    from nniquad import codecache

    env = run._mutant_env()
    assert env["NNIQUAD_NO_CODE_CACHE"] == "1"
    monkeypatch.setenv(codecache.ENV_DISABLE, env[codecache.ENV_DISABLE])
    assert not codecache.enabled()
    monkeypatch.setenv(codecache.ENV_DISABLE, "0")
    assert codecache.enabled()  # the variable is what switches it


def test_the_staged_conftest_empties_functools_caches_and_each_modules_own(tmp_path, monkeypatch):
    calls: list[str] = []
    fake = types.ModuleType("fake_cached_module")

    def cached():
        return None

    cached.cache_clear = lambda: calls.append("functools")
    fake.cached = cached
    fake.clear_cache = lambda: calls.append("clear_cache")
    fake.clear_memory = lambda: calls.append("clear_memory")
    monkeypatch.setitem(sys.modules, "fake_cached_module", fake)
    path = tmp_path / "staged_conftest.py"
    path.write_text(run.CONFTEST.format(modules=["fake_cached_module", "not_imported_module"], widen=False))
    spec = importlib.util.spec_from_file_location("staged_conftest", path)
    conftest = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conftest)
    conftest.pytest_runtest_setup(None)
    assert sorted(calls) == ["clear_cache", "clear_memory", "functools"]


def test_sector_symbolic_clears_the_code_cache_memory():
    """reduced_loop_symbolic's generated functions are kept in codecache's memory between tests of one process."""
    assert "nniquad.codecache" in MODULES["sector_symbolic"].clear_caches
    from nniquad import codecache

    assert callable(codecache.clear_memory)
