"""The built wheel installs into a fresh virtual environment and ``import nniquad`` works there.

The package folder is ``design/nniquad`` (``design/`` plays the role of
``src/``), and the audit's folder ``proofs/`` is linked into it as
``nniquad/proofs``; a wheel must carry both under the import name.  The test builds the wheel without
network access, installs it (without dependencies) into a temporary venv that
sees this environment's third-party packages through a ``.pth`` file, and
imports the package there, from a folder that is not the checkout.
"""

from __future__ import annotations

import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_installs_and_imports(tmp_path):
    dist = tmp_path / "dist"
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                            "-w", str(dist), str(ROOT)], capture_output=True, text=True, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    wheels = list(dist.glob("nniquad-*.whl"))
    assert len(wheels) == 1
    names = zipfile.ZipFile(wheels[0]).namelist()
    assert "nniquad/__init__.py" in names and "nniquad/proofs/__init__.py" in names
    assert not any(n.startswith(("design/", "proofs/")) for n in names), "the folders leaked as import names"
    # every sub-package of the source tree is in the wheel (a package missing from pyproject's list fails here)
    for init in (ROOT / "design" / "nniquad").rglob("__init__.py"):
        rel = init.relative_to(ROOT / "design" / "nniquad").as_posix()
        assert f"nniquad/{rel}" in names, f"nniquad/{rel} missing from the wheel"

    env = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env)
    py = env / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    # third-party dependencies from this environment, the wheel's own files first
    (Path(site) / "zz_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    inst = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "-q",
                           "--target", site, str(wheels[0])], capture_output=True, text=True)
    assert inst.returncode == 0, inst.stderr[-2000:]
    code = ("import nniquad as nq, nniquad.proofs as pr; print(nq.__file__); print(pr.__file__); "
            "print(len(nq.__all__)); print(sorted(nq.__all__))")
    run = subprocess.run([str(py), "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    lines = run.stdout.splitlines()
    assert lines[0].startswith(site) and lines[1].startswith(site), lines[:2]
    assert int(lines[2]) > 0
