"""One check for every number a user gives: finite, a real number, optionally positive.

Each layer raises its own error class (``GainError`` for gains,
``SimulationError`` for simulation options, ...); the messages are the same
everywhere: "``name`` must be a number / finite / positive / not negative, got ...".
"""

from __future__ import annotations

import math
from typing import Any

from nniquad.errors import NniquadError

__all__ = ["finite_number"]


def finite_number(name: str, value: Any, *, error: type[NniquadError] = NniquadError, positive: bool = False,
                  nonneg: bool = False) -> float:
    """``value`` as a finite float, else ``error`` naming ``name``.

    Parameters
    ----------
    name
        What the value is, for the message.
    value
        The user's value (booleans are refused: ``True`` is not a gain).
    error
        Exception class to raise.
    positive, nonneg
        Also require ``> 0`` or ``>= 0``.
    """
    if isinstance(value, bool):
        raise error(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise error(f"{name} must be finite, got {value!r}")
    if positive and v <= 0:
        raise error(f"{name} must be positive, got {value!r}")
    if nonneg and v < 0:
        raise error(f"{name} must not be negative, got {value!r}")
    return v
