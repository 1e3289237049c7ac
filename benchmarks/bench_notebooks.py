"""Wall time of each notebook at full size (target: 120 s each on 2 cores), and its printed conclusion.

The test suite runs the notebooks on their smoke grids (``tests/test_notebooks.py``); this is where they run at
the size they show (``NNIQUAD_NOTEBOOK_SIZE=full``), and where a full-size run that fails or prints no conclusion
is seen.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
NOTEBOOKS = sorted((HERE.parent / "notebooks").glob("*.py"))
TARGET_S = 120.0


def run(quick: bool = False) -> list[dict]:
    """Rows for ``benchmarks/run.py``; ``quick``: the first notebook only."""
    import jupytext
    import nbclient

    from nniquad.reporting.display import NOTEBOOK_SIZE_ENV

    env = {**os.environ, NOTEBOOK_SIZE_ENV: "full"}  # the kernels' environment, whatever the caller's says
    rows = []
    for path in NOTEBOOKS[:1] if quick else NOTEBOOKS:
        nb = jupytext.read(path)
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                         resources={"metadata": {"path": str(path.parent)}})
        t0 = time.perf_counter()
        client.execute(env=env)  # passed on to the kernel's launch
        wall = time.perf_counter() - t0
        last = nb.cells[-1]
        printed = "".join(o.get("text", "") for o in last.get("outputs", []) if o.get("output_type") == "stream")
        concluded = "Conclusion" in printed
        rows.append({"name": f"notebook {path.stem} (full size{'' if concluded else ', NO CONCLUSION PRINTED'})",
                     "value": wall, "unit": "s", "target": TARGET_S, "ok": wall <= TARGET_S and concluded})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
