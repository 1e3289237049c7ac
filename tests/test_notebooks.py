"""Every notebook (jupytext py:percent source in notebooks/) executes without error.

Each notebook is converted in memory and run with nbclient in the project's own
Python (its ipykernel), from an empty temporary folder: a notebook reads its data
through ``nniquad.notebook_data`` (the checkout's notebooks/data), never the
working folder, so it runs the same from anywhere.  A cell that runs longer
than ``CELL_TIMEOUT_S`` is a hang and fails the test; how long the notebooks
take is a speed target, measured in ``benchmarks/bench_notebooks.py`` (timed
tests on a shared machine measure the machine, not the notebook).

The kernel runs with ``NNIQUAD_NOTEBOOK_SIZE=smoke``: a notebook's large grids
(``nniquad.sized(full, smoke)``) are coarser; every cell, check and the printed
conclusion are the same code.  ``make bench`` runs every notebook at full size,
with the same conclusion check.
"""

from __future__ import annotations

from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.py"))
#: A cell running longer than this has hung [s].
CELL_TIMEOUT_S = 600


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, tmp_path, monkeypatch):
    from nniquad.reporting.display import NOTEBOOK_SIZE_ENV
    from nniquad.reporting.notebooks import NOTEBOOK_DATA_ENV, NOTEBOOK_VEHICLE_ENV

    monkeypatch.setenv(NOTEBOOK_SIZE_ENV, "smoke")  # the kernel inherits the environment
    monkeypatch.delenv(NOTEBOOK_VEHICLE_ENV, raising=False)  # the paper's vehicle, whatever the caller's shell says
    monkeypatch.delenv(NOTEBOOK_DATA_ENV, raising=False)
    jupytext = pytest.importorskip("jupytext")
    nbclient = pytest.importorskip("nbclient")
    nb = jupytext.read(path)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    client = nbclient.NotebookClient(
        nb, timeout=CELL_TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    # The notebook ends in a written conclusion built from the numbers it computed:
    # a final code cell that prints it (so no number in it is typed by hand).
    last = nb.cells[-1]
    assert last.cell_type == "code" and "conclusion" in last.source.lower()
    printed = "".join(o.get("text", "") for o in last.get("outputs", []) if o.get("output_type") == "stream")
    assert "Conclusion" in printed and any(ch.isdigit() for ch in printed)
    # the notebook states the grids it ran on (a notebook without sized grids has nothing to state)
    assert "smoke grids" in printed or "sized(" not in path.read_text(encoding="utf-8")
