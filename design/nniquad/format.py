"""One number formatter for the command line, the report and the notebooks."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["fmt", "margin_text", "failing_margins", "margin_verdict"]


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


def _number(value: Any) -> float:
    """A margin as stored (a float, or ``"inf"``/``"nan"`` text in JSON) as a float; anything else is nan."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def margin_text(gm_db: Any, gm_lower_db: Any, pm_deg: Any) -> str:
    """Classical margins to three significant digits with units: ``"GM +11.2/-16.4 dB, PM 47.3 deg"``.

    Parameters
    ----------
    gm_db, gm_lower_db, pm_deg
        The upper and lower gain margins [dB] and the phase margin [deg] (numbers, or ``"inf"``-style text).
    """
    up, low = _number(gm_db), _number(gm_lower_db)
    if math.isnan(up) and math.isnan(low):  # no gain margin computed (python-control gives none on an unstable loop)
        gm = "GM n/a"
    else:
        shown = fmt(up, digits=3, none="n/a")
        gm = f"GM {'' if shown.startswith(('-', 'n')) else '+'}{shown}/{fmt(low, digits=3, none='n/a')} dB"
    return f"{gm}, PM {fmt(_number(pm_deg), 'deg', digits=3, none='n/a')}"


def failing_margins(gm_db: Any, gm_lower_db: Any, pm_deg: Any, required_gm_db: float,
                    required_pm_deg: float) -> list[str]:
    """Which margin misses its requirement: a sublist of ``["GM", "PM"]`` (a nan margin misses it).

    Parameters
    ----------
    gm_db, gm_lower_db, pm_deg
        The margins as in :func:`margin_text`.
    required_gm_db, required_pm_deg
        The requirement: GM >= ``required_gm_db`` both ways, PM >= ``required_pm_deg``.
    """
    up, low, pm = _number(gm_db), _number(gm_lower_db), _number(pm_deg)
    gm_ok = up >= required_gm_db and low <= -required_gm_db  # False for nan
    return [name for name, ok in (("GM", gm_ok), ("PM", pm >= required_pm_deg)) if not ok]


def margin_verdict(margins: Any, required_gm_db: float, required_pm_deg: float) -> str:
    """``"meets GM >= 6 dB, PM >= 45 deg"``, or what fails: ``"FAILS PM >= 45 deg"``, ``"FAILS GM >= 6 dB and PM >=
    45 deg"``, ``"FAILS: unstable loop"``.

    Parameters
    ----------
    margins
        A mapping with ``gm_db``, ``gm_lower_db``, ``pm_deg`` and optionally ``stable``.
    required_gm_db, required_pm_deg
        The requirement.
    """
    if margins.get("stable", True) is not True:
        return "FAILS: unstable loop"
    req = {"GM": f"GM >= {required_gm_db:g} dB", "PM": f"PM >= {required_pm_deg:g} deg"}
    bad = failing_margins(margins.get("gm_db"), margins.get("gm_lower_db"), margins.get("pm_deg"), required_gm_db,
                          required_pm_deg)
    return "FAILS " + " and ".join(req[b] for b in bad) if bad else "meets " + ", ".join(req.values())
