"""Tables and figures for Markdown reports and notebooks (IPython is imported only when displaying)."""

from __future__ import annotations

import io
import os
from typing import Any, Sequence, TypeVar

from nniquad.errors import NniquadError

__all__ = ["markdown_table", "show_table", "show_figure", "NOTEBOOK_SIZE_ENV", "NOTEBOOK_SIZES", "notebook_size",
           "sized"]

#: Environment variable that sets the size of the notebooks' grids (:func:`notebook_size`).
NOTEBOOK_SIZE_ENV = "NNIQUAD_NOTEBOOK_SIZE"
#: Its values: ``full`` (the default: the grids the notebooks show and discuss) and ``smoke`` (coarser grids, the
#: same code, checks and conclusion; what ``make test`` runs, while ``make bench`` runs them full size).
NOTEBOOK_SIZES = ("full", "smoke")

T = TypeVar("T")


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A Markdown table from a header and rows of already formatted cells.

    Parameters
    ----------
    header
        Column titles.
    rows
        Rows of already formatted cells.
    """
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def show_table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
    """Display :func:`markdown_table` in a notebook.

    Parameters
    ----------
    header
        Column titles.
    rows
        Rows of already formatted cells.
    """
    from IPython.display import Markdown, display

    display(Markdown(markdown_table(header, rows)))


def show_figure(fig: Any, dpi: int = 80) -> None:
    """Display a matplotlib figure as a PNG (works under any backend, Agg included) and close it.

    Parameters
    ----------
    fig
        A matplotlib figure (closed after display).
    dpi
        Resolution of the PNG.
    """
    import matplotlib.pyplot as plt
    from IPython.display import Image, display

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    display(Image(data=buf.getvalue()))


def notebook_size() -> str:
    """The notebooks' grid size, ``full`` or ``smoke``, from ``$NNIQUAD_NOTEBOOK_SIZE`` (unset or empty: ``full``).

    A notebook's grids are sized for the figures it discusses.  Its test (``tests/test_notebooks.py``) runs the
    same cells on coarser grids, which exercise every line and check; ``make bench``
    (``benchmarks/bench_notebooks.py``) runs every notebook at full size.

    Raises
    ------
    NniquadError
        Any other value, named in one line.
    """

    value = os.environ.get(NOTEBOOK_SIZE_ENV, "").strip() or "full"
    if value not in NOTEBOOK_SIZES:
        raise NniquadError(f"{NOTEBOOK_SIZE_ENV}={value!r} is not a notebook size (expected one of "
                           f"{', '.join(NOTEBOOK_SIZES)})")
    return value


def sized(full: T, smoke: T) -> T:
    """``full`` at the full notebook size, else ``smoke`` (:func:`notebook_size`).

    Parameters
    ----------
    full
        The value the notebook shows and discusses.
    smoke
        A smaller value of the same kind, for the test run.
    """
    return full if notebook_size() == "full" else smoke
