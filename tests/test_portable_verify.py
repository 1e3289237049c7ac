"""A true certificate verifies on any machine; a false one is refused on every machine.

``verify`` runs here in subprocesses under every OpenBLAS kernel the installed
OpenBLAS offers (and this CPU runs), with one and with two threads, on the
committed certificate and on one built in this session.  Other kernels sum and
block the same products differently, as another user's machine would, so each
rounding-sensitive decision (a tie of the grid's worst point, the order of
repeated poles, a verdict at a threshold) shows up here as a refusal.  Two
controls make the test able to fail both ways: the same certificates with every
stored matrix jittered by a relative 1e-12 (a true statement, re-signed) must
still pass, and one stated number moved by more than its tolerance (re-signed)
must be refused under every kernel.

``OPENBLAS_CORETYPE`` is set only inside these subprocesses.
"""

from __future__ import annotations

import copy
import json
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from nniquad.certificates import canonical_digest, write_certificate
from nniquad.certificates.certificate import read_certificate

from tests.test_certificate import build_small_certificate

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "notebooks" / "data" / "full_model_certificate.json"

#: OpenBLAS x86-64 core names to try; the installed library keeps those it was built with (a name it does not
#: offer falls back to another core, which the probe sees and drops).
KERNEL_CANDIDATES = ("Prescott", "Katmai", "Core2", "Penryn", "Dunnington", "Nehalem", "Atom", "Sandybridge",
                     "Haswell", "Zen", "SkylakeX", "Cooperlake", "SapphireRapids", "Opteron", "Barcelona",
                     "Bulldozer", "Excavator")
#: Relative jitter of every stored matrix entry: far below every tolerance, far above the last bit.
JITTER = 1e-12

_CORE = re.compile(r"Core:\s*(\w+)")

_DRIVER = """
import json, sys
from nniquad.certificates import verify_certificate
from nniquad.cli.main import main
out = {}
for arg in sys.argv[1:]:
    how, path = arg.split(":", 1)
    if how == "cli":  # the whole command, re-simulation included
        out[path] = {"ok": main(["verify", path]) == 0, "failed": []}
    else:
        v = verify_certificate(path, simulate=False)
        out[path] = {"ok": v.ok, "failed": [c.name for c in v.checks if not c.ok]}
print("RESULT " + json.dumps(out))
"""


def _env(kernel: str | None, threads: int) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("OPENBLAS_")}
    env.update(OPENBLAS_NUM_THREADS=str(threads), OPENBLAS_VERBOSE="2", MPLBACKEND="Agg")
    if kernel is not None:
        env["OPENBLAS_CORETYPE"] = kernel
    return env


def _probe(kernel: str) -> str | None:
    """The core OpenBLAS reports when ``kernel`` is requested (``None``: it did not start on this CPU)."""
    res = subprocess.run([sys.executable, "-c", "import numpy; numpy.ones((4, 4)) @ numpy.ones((4, 4))"],
                         env=_env(kernel, 1), capture_output=True, text=True, timeout=60)
    found = _CORE.findall(res.stdout + res.stderr)
    return found[-1] if res.returncode == 0 and found else None


def kernels_offered() -> list[str]:
    """Every distinct kernel the installed OpenBLAS offers and this CPU runs (by the name OpenBLAS reports)."""
    with ThreadPoolExecutor(4) as pool:
        reported = list(pool.map(_probe, KERNEL_CANDIDATES))
    offered: dict[str, str] = {}
    for asked, got in zip(KERNEL_CANDIDATES, reported):
        if got is not None and got.lower() == asked.lower():
            offered.setdefault(got.lower(), asked)
    return sorted(offered.values())


def _jitter(node, rng: np.random.Generator):
    """Every matrix (a list of equal-length number lists) times ``1 + JITTER u``, ``u`` uniform in [-1, 1];
    a symmetric matrix stays exactly symmetric (verify requires that of a stored P)."""
    if isinstance(node, dict):
        return {k: _jitter(v, rng) for k, v in node.items()}
    if isinstance(node, list):
        rows = [r for r in node if isinstance(r, list)]
        if node and len(rows) == len(node) and all(r and all(isinstance(x, float) for x in r) for r in rows) \
                and len({len(r) for r in rows}) == 1:
            M = np.array(node, float)
            F = 1.0 + JITTER * rng.uniform(-1.0, 1.0, M.shape)
            if M.shape[0] == M.shape[1] and np.array_equal(M, M.T):
                F = np.triu(F) + np.triu(F, 1).T
            return (M * F).tolist()
        return [_jitter(v, rng) for v in node]
    return node


def _resigned(doc: dict) -> dict:
    doc = copy.deepcopy(doc)
    doc["digest"]["value"] = canonical_digest(doc)
    return doc


def _moved_past_tolerance(doc: dict) -> dict:
    """The grid's stated worst contraction lowered by three times verify's tolerance on it (a better, false claim)."""
    doc = copy.deepcopy(doc)
    grid = doc["cascade"]["grid"]
    tol = max(1e-9, grid["rounding_bound"])
    grid["worst_rho"] -= 3.0 * tol
    grid["worst_margin"] += 3.0 * tol
    return _resigned(doc)


@pytest.fixture(scope="module")
def variants(tmp_path_factory, shared_json) -> dict[str, Path]:
    """The committed and a freshly built certificate, each as is, jittered and moved past a tolerance."""
    d = tmp_path_factory.mktemp("portable")
    fresh = shared_json("small-certificate", build_small_certificate)
    committed = read_certificate(COMMITTED).to_json()
    files = {"committed": d / "committed.json"}
    shutil.copyfile(COMMITTED, files["committed"])
    rng = np.random.default_rng(20261203)
    for name, doc in (("committed", committed), ("fresh", fresh)):
        for kind, edited in (("", doc), ("_jittered", _resigned(_jitter(doc, rng))),
                             ("_moved", _moved_past_tolerance(doc))):
            if name + kind not in files:
                files[name + kind] = write_certificate(edited, d / f"{name}{kind}.json")
    return files


def _run(kernel: str | None, threads: int, files: dict[str, Path], names: dict[str, str]) -> tuple[str, dict]:
    """``verify`` of ``names`` (variant -> ``"cli"`` or ``"api"``) in one subprocess; (reported core, results)."""
    args = [f"{how}:{files[name]}" for name, how in names.items()]
    res = subprocess.run([sys.executable, "-c", _DRIVER, *args], cwd=ROOT, env=_env(kernel, threads),
                         capture_output=True, text=True, timeout=600)
    line = next((ln for ln in res.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert res.returncode == 0 and line is not None, (kernel, threads, res.returncode, res.stderr[-2000:])
    got = json.loads(line[len("RESULT "):])
    core = _CORE.findall(res.stdout + res.stderr)
    return (core[-1] if core else "?"), {name: got[str(files[name])] for name in names}


def test_the_probe_sees_kernels_switch_and_finds_at_least_three():
    offered = kernels_offered()
    assert len(offered) >= 3, offered
    # an unknown name is not offered (OpenBLAS falls back to another core, which the probe must notice)
    assert _probe("NoSuchCore") is None or _probe("NoSuchCore").lower() != "nosuchcore"


def test_verify_gives_the_same_verdicts_under_every_kernel_and_thread_count(variants):
    """Both true certificates pass under every kernel (1 thread) and with 2 threads; the whole command, with its
    re-simulation, passes under the first kernel; the jittered and moved controls run with 2 threads."""
    kernels = kernels_offered()
    both = {"committed": "api", "fresh": "api"}
    controls = {**both, "committed_jittered": "api", "fresh_jittered": "api", "committed_moved": "api",
                "fresh_moved": "api"}
    runs = [(k, 1, {**both, "committed": "cli"} if i == 0 else both) for i, k in enumerate(kernels)]
    runs.append((None, 2, controls))
    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda r: (r[:2], *_run(r[0], r[1], variants, r[2])), runs))
    for (kernel, threads), core, got in results:
        where = f"kernel {kernel or 'default'} (OpenBLAS reports {core}), {threads} thread(s)"
        if kernel is not None:
            assert core.lower() == kernel.lower(), where
        for name, res in got.items():
            if name.endswith("_moved"):  # the false claim: refused, by the check that owns the number
                assert not res["ok"] and "cascade.grid check" in res["failed"], (name, where, res)
            else:
                assert res["ok"], f"{name} refused under {where}: {res['failed']}"
    assert {name for _, _, got in results for name in got} == set(variants)
