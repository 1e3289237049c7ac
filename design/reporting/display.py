"""Tables and figures for Markdown reports and notebooks (IPython is imported only when displaying)."""

from __future__ import annotations

import io
from typing import Any, Sequence

__all__ = ["markdown_table", "show_table", "show_figure"]


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
