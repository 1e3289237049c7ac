"""Wall time of each notebook, executed as the test suite executes it (target: 120 s each on 2 cores)."""

from __future__ import annotations

import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
NOTEBOOKS = sorted((HERE.parent / "notebooks").glob("*.py"))
TARGET_S = 120.0


def run(quick: bool = False) -> list[dict]:
    """Rows for ``benchmarks/run.py``; ``quick``: the first notebook only."""
    import jupytext
    import nbclient

    rows = []
    for path in NOTEBOOKS[:1] if quick else NOTEBOOKS:
        nb = jupytext.read(path)
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                         resources={"metadata": {"path": str(path.parent)}})
        t0 = time.perf_counter()
        client.execute()
        wall = time.perf_counter() - t0
        rows.append({"name": f"notebook {path.stem}", "value": wall, "unit": "s", "target": TARGET_S,
                     "ok": wall <= TARGET_S})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
