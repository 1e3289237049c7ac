"""The on-disk cache of generated code (nniquad.codecache): keys, trust, concurrency, identical results.

Each test works in its own cache folder (``NNIQUAD_CACHE_DIR`` set to a temporary
folder), so it sees a miss, a write and a load; the results are compared with
closed forms, with the function built afresh without the cache, or with the
cache turned off in another process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from nniquad import codecache
from nniquad.codecache import STATS

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("NNIQUAD_CACHE_DIR", str(folder))
    monkeypatch.delenv("NNIQUAD_NO_CODE_CACHE", raising=False)
    codecache.clear_memory()
    STATS.reset()
    yield folder
    codecache.clear_memory()  # later tests load from their own folder, not functions held from this one


def _entries(folder: Path, kind: str = "casadi", pattern: str = "*") -> list[Path]:
    return sorted((folder / kind).glob(pattern + (".casadi" if kind == "casadi" else ".py.txt")))


def _key_of(path: Path) -> str:
    return path.read_bytes().split(b"\n")[1].decode().removeprefix("key ")


def _square_builder(calls: list):
    @codecache.cached_casadi_function
    def square(n: int = 2) -> ca.Function:
        calls.append(n)
        x = ca.SX.sym("x", n)
        return ca.Function("square", [x], [x * x])

    return square


def test_entry_is_built_once_then_loaded(cache):
    calls: list[int] = []
    square = _square_builder(calls)
    square(3)
    assert calls == [3] and STATS.misses == 1 and len(_entries(cache)) == 1
    codecache.clear_memory()
    loaded = square(n=3)  # the same entry: arguments are bound with the builder's signature
    assert calls == [3] and STATS.hits == 1
    x = np.array([1.0, -2.0, 3.0])
    np.testing.assert_allclose(np.asarray(loaded(x)).ravel(), x ** 2, rtol=0)  # closed form
    assert square(3) is loaded  # held in memory after the first load
    square(2)
    assert calls == [3, 2] and len(_entries(cache)) == 2  # other arguments, another entry


def test_changed_generating_source_or_versions_rebuild(cache, monkeypatch):
    calls: list[int] = []
    square = _square_builder(calls)
    square(2)
    codecache.clear_memory()
    monkeypatch.setattr(codecache, "source_digest", lambda: "0" * 64)  # an edited nniquad module
    square(2)
    assert calls == [2, 2] and len(_entries(cache)) == 2
    codecache.clear_memory()
    monkeypatch.setattr(codecache, "_environment", lambda: "casadi=9.9")  # another CasADi, sympy or numpy
    square(2)
    assert calls == [2, 2, 2] and len(_entries(cache)) == 3
    assert STATS.hits == 0  # no stale entry was loaded


def test_source_digest_follows_every_package_file(tmp_path, monkeypatch):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("A = 1\n")
    (pkg / "sub" / "b.py").write_text("def f():\n    return 2\n")
    monkeypatch.setattr(codecache, "_PACKAGE_ROOT", pkg)

    def digest() -> str:
        codecache._package_digest.cache_clear()
        return codecache.source_digest()

    try:
        first = digest()
        (pkg / "sub" / "b.py").write_text("def f():\n    return 3\n")
        edited = digest()
        (pkg / "sub" / "b.py").write_text("def f():\n    return 2\n")
        assert digest() == first != edited
        (pkg / "sub" / "b.py").rename(pkg / "sub" / "c.py")  # same bytes, another module
        assert digest() != first
    finally:
        codecache._package_digest.cache_clear()
    # the real package: the modules that generate the simulator's functions are hashed
    hashed = {p.relative_to(Path(codecache.__file__).parent).as_posix()
              for p in Path(codecache.__file__).parent.rglob("*.py")}
    assert {"model/symbolic.py", "model/numeric.py", "sim/models.py", "control/inner_loops.py"} <= hashed


def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif how == "bit flip":
        i = len(data) - 100
        path.write_bytes(data[:i] + bytes([data[i] ^ 0x01]) + data[i + 1:])
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "another entry's key":
        path.write_bytes(data.replace(b"key ", b"key 0", 1))


@pytest.mark.parametrize("how", ["truncated", "bit flip", "empty", "another entry's key"])
def test_a_damaged_entry_is_rebuilt_and_never_loaded(cache, monkeypatch, how):
    from nniquad.sim.models import rhs_function

    built = rhs_function("reduced")
    (path,) = _entries(cache, pattern="rhs_function_reduced*")
    good = path.read_bytes()
    _damage(path, how)
    codecache.clear_memory()
    handed: list[str] = []
    real = ca.Function.deserialize
    monkeypatch.setattr(ca.Function, "deserialize", staticmethod(lambda s: handed.append(s) or real(s)))
    rebuilt = rhs_function("reduced")
    assert handed == []  # the damaged payload never reached CasADi
    assert STATS.rejected == 1 and STATS.hits == 0
    assert path.read_bytes() == good  # replaced by a complete entry
    rng = np.random.default_rng(1)
    args = [rng.standard_normal(built.size_in(i)) for i in range(built.n_in())]
    np.testing.assert_allclose(np.asarray(rebuilt(*args)), np.asarray(built(*args)), rtol=1e-15, atol=0)


def test_a_payload_casadi_refuses_is_rebuilt(cache):
    from nniquad.sim.models import rhs_function

    rhs_function("reduced")
    (path,) = _entries(cache, pattern="rhs_function_reduced*")
    good = path.read_bytes()
    codecache.write_entry(path, _key_of(path), b"not a serialized casadi function")  # checksum and key valid
    codecache.clear_memory()
    fn = rhs_function("reduced")
    assert STATS.rejected == 1 and isinstance(fn, ca.Function)
    assert path.read_bytes() == good


_WRITER = textwrap.dedent("""
    import pathlib, sys, time
    from nniquad import codecache
    path, key, start = pathlib.Path(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    payload = (sys.argv[4] * 400_000).encode()
    while time.time() < start:
        time.sleep(0.001)
    for _ in range(60):
        codecache.write_entry(path, key, payload)
""")


def test_two_processes_writing_one_entry_leave_a_valid_entry(cache):
    """Two writers replace one entry 60 times each while this process reads it: never a partial file."""
    folder = cache / "casadi"
    folder.mkdir(parents=True)
    path, key = folder / "race.casadi", "k" * 64
    payload = ("0123456789" * 400_000).encode()
    start = time.time() + 3.0
    procs = [subprocess.Popen([sys.executable, "-c", _WRITER, str(path), key, str(start), "0123456789"])
             for _ in range(2)]
    seen_full, seen_missing_after_full, reads = 0, 0, 0
    try:
        while any(p.poll() is None for p in procs):
            got = codecache.read_entry(path, key)
            reads += 1
            if got is None:
                seen_missing_after_full += seen_full > 0
            else:
                assert got == payload
                seen_full += 1
    finally:
        for p in procs:
            p.wait(timeout=120)
    assert [p.returncode for p in procs] == [0, 0]
    assert seen_full > 0 and seen_missing_after_full == 0 and STATS.rejected == 0  # nothing yet, or a whole entry
    assert codecache.read_entry(path, key) == payload
    assert [p.name for p in folder.iterdir()] == ["race.casadi"]  # no temporary file left behind


_BUILDER = textwrap.dedent("""
    import sys, time
    start = float(sys.argv[1])
    while time.time() < start:
        time.sleep(0.001)
    from nniquad import codecache
    from nniquad.sim.models import step_function
    step_function("full")
    print(codecache.STATS.misses, codecache.STATS.hits)
""")


def test_two_processes_building_one_function_at_once_leave_a_loadable_entry(cache):
    env = {**os.environ, "NNIQUAD_CACHE_DIR": str(cache)}
    start = time.time() + 4.0
    procs = [subprocess.Popen([sys.executable, "-c", _BUILDER, str(start)], env=env, stdout=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    third = subprocess.run([sys.executable, "-c", _BUILDER, "0"], env=env, capture_output=True, text=True,
                           timeout=600)
    assert third.returncode == 0, third.stderr
    misses, hits = map(int, third.stdout.split())
    assert misses == 0 and hits >= 1  # the third process loaded what the two wrote
    assert not [p for p in (cache / "casadi").iterdir() if p.name.startswith(".")]  # no temporary files


_SIMULATE = textwrap.dedent("""
    import json, sys
    import numpy as np
    from nniquad.laws.nni import Gains
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.sim import SimOptions, simulate
    out = {}
    for model in ("reduced", "full"):
        res = simulate(PAPER_VEHICLE, Gains(3.0, 9.0, 0.9), SimOptions(model=model, horizon_s=1.5, motor_lag=True))
        out[model] = res.states[0].tolist()
    print(json.dumps({"trajectories": out, "sympy": "sympy" in sys.modules}))
""")


def _run_json(script: str, env: dict, *args: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", script, *args], env=env, capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_simulations_are_identical_with_and_without_the_cache(cache):
    """Trajectories from functions built afresh (cache off), built and written, and loaded, agree."""
    env = {**os.environ, "NNIQUAD_CACHE_DIR": str(cache), "NNIQUAD_NO_JIT": "1"}
    fresh = _run_json(_SIMULATE, {**env, "NNIQUAD_NO_CODE_CACHE": "1"})
    written = _run_json(_SIMULATE, env)
    loaded = _run_json(_SIMULATE, env)
    assert fresh["sympy"] and written["sympy"] and not loaded["sympy"]  # the last one did not derive anything
    for model in ("reduced", "full"):
        ref = np.asarray(fresh["trajectories"][model])
        assert ref.ndim == 2 and ref.shape[0] > 10 and np.all(np.isfinite(ref)) and np.ptp(ref) > 0
        for other in (written, loaded):
            np.testing.assert_allclose(np.asarray(other["trajectories"][model]), ref, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("law_name", ["nni", "sni2"])
def test_lambdified_functions_round_trip_through_source(cache, law_name):
    from nniquad.analysis import reduced_loop, reduced_loop_symbolic
    from nniquad.laws import law_named

    law = law_named(law_name)
    n_args = 2 + len(reduced_loop_symbolic.law_symbols(law))
    built = reduced_loop_symbolic.lambdified(law)  # sympy, in this process
    reduced_loop.lambdified(law)  # miss: written
    codecache.clear_memory()
    loaded = reduced_loop.lambdified(law)
    assert STATS.misses == 1 and STATS.hits == 1 and set(loaded) == set(built)
    rng = np.random.default_rng(4)
    for _ in range(5):
        args = rng.uniform(0.2, 5.0, n_args)
        for name, fn in built.items():
            want, got = fn(*args), loaded[name](*args)
            for w, g in zip(np.atleast_1d(np.asarray(want, dtype=object)), np.atleast_1d(np.asarray(got, dtype=object))):
                np.testing.assert_allclose(np.asarray(g, float), np.asarray(w, float), rtol=1e-15)


def test_a_function_needing_more_than_numpy_is_not_stored(cache):
    import sympy as sp

    x = sp.Symbol("x")
    calls = []

    def build():
        calls.append(1)
        custom = sp.Function("custom")
        return {"f": sp.lambdify([x], custom(x) + 1, modules=[{"custom": lambda v: 2 * v}, "numpy"])}

    first = codecache.cached_numpy_functions("test.custom", build)
    assert first["f"](3.0) == 7.0
    codecache.clear_memory()
    codecache.cached_numpy_functions("test.custom", build)
    assert len(calls) == 2 and not _entries(cache, "numpy")


def test_the_cache_can_be_turned_off(cache, monkeypatch):
    monkeypatch.setenv("NNIQUAD_NO_CODE_CACHE", "1")
    calls: list[int] = []
    square = _square_builder(calls)
    square(2)
    codecache.clear_memory()
    square(2)
    assert calls == [2, 2] and not (cache / "casadi").exists()


@pytest.mark.slow
def test_verify_results_are_identical_with_and_without_the_cache(cache):
    """A cold verify with every function loaded from the cache recomputes the same checks as one that builds
    them afresh, and imports neither sympy nor python-control."""
    script = textwrap.dedent("""
        import json, sys
        from nniquad.certificates import verify_certificate
        res = verify_certificate(sys.argv[1])
        heavy = sorted(m for m in ("sympy", "control", "cvxpy", "matplotlib") if m in sys.modules)
        print(json.dumps({"checks": [[c.name, c.ok, c.detail] for c in res.checks], "heavy": heavy}))
    """)
    env = {**os.environ, "NNIQUAD_CACHE_DIR": str(cache)}
    fresh = _run_json(script, {**env, "NNIQUAD_NO_CODE_CACHE": "1"}, str(CERT))
    _run_json(script, env, str(CERT))  # fills the cache
    loaded = _run_json(script, env, str(CERT))
    assert len(loaded["checks"]) >= 30
    assert loaded["checks"] == fresh["checks"]
    assert loaded["heavy"] == []
