"""One number formatter for the command line, the report and the notebooks."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["fmt"]


def fmt(value: Any, unit: str = "", digits: int = 4, none: str = "-") -> str:
    """Format a value for people: significant digits and a unit.

    Parameters
    ----------
    value
        A number, a boolean, ``None`` or anything else (shown with ``str``).
    unit
        Unit appended after a space to finite numbers (e.g. ``"s"``, ``"deg"``).
    digits
        Significant digits of a float.
    none
        Text for ``None`` (a run that did not settle, a field that does not apply).

    Returns
    -------
    str
        ``"1.525 s"``, ``"yes"``, ``"-"``, ``"inf"``, ...
    """
    if value is None:
        return none
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        text = str(value)
    elif isinstance(value, float) or hasattr(value, "__float__") and not isinstance(value, str):
        v = float(value)
        if math.isnan(v):
            return none
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = f"{v:.{digits}g}"
    else:
        return str(value)
    return f"{text} {unit}" if unit else text
